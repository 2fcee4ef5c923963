#!/usr/bin/env bash
# Every .gltf and .glb of Debian's assimp-testmodels (glTF/ and glTF2/, 53 files: glTF 1.0, Draco,
# missing buffers, bad indices, infinities, cycles, wrong JSON types, every primitive mode...)
# through `penumbra render`, each against the outcome the table below expects:
#   ok:N       renders (exit 0) a scene of N triangles (the 2 of the ground plane included), with
#              geometry in the image and the EXR written;
#   fail:RE    exits 1 with an error line naming the file and matching the extended regex RE, and
#              leaves no output (nor a temporary file) behind.
# Whatever the table says, no file may crash penumbra (exit >= 128, i.e. a signal, which is also
# how the sanitizer build reports a finding) or run past the time limit. A file found on disk but
# missing from the table, or the reverse, fails the test: the table is the complete list.
set -u
BIN=${PN_BIN:?PN_BIN not set}
MODELS=${PN_ASSIMP_MODELS:-/usr/share/assimp/models}
TMP=${PN_TEST_TMP:-/tmp}/hostile_gltf
LIMIT=${PN_HOSTILE_TIMEOUT:-60} # seconds per file; the largest (2CylinderEngine) takes ~0.2 s
if [ ! -d "$MODELS/glTF2" ]; then
  echo "SKIP: $MODELS/glTF2 not found (Debian package assimp-testmodels, see ci/deps.sh)"
  exit 77
fi
rm -rf "$TMP" && mkdir -p "$TMP"

declare -A EXPECT=(
  # glTF 1.0: refused by version, whether tinygltf parses it or not
  [glTF/BoxTextured-glTF-Binary/BoxTextured.glb]='fail:binary glTF version 1 is not supported'
  [glTF/BoxTextured-glTF-Embedded/BoxTextured.gltf]='fail:glTF version "1.0" is not supported'
  [glTF/BoxTextured-glTF-MaterialsCommon/BoxTextured.gltf]='fail:glTF version "1.0" is not supported'
  [glTF/BoxTextured-glTF/BoxTextured.gltf]='fail:glTF version "1.0" is not supported'
  [glTF/CesiumMilkTruck/CesiumMilkTruck.gltf]='fail:glTF version 1 is not supported'
  [glTF/IncorrectVertexArrays/Cube_v1.gltf]='fail:glTF version "1.0" is not supported'
  [glTF/TwoBoxes/TwoBoxes.gltf]='fail:glTF version "1.0" is not supported'
  # glTF 2.0 that renders (warnings for what is skipped are fine)
  [glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb]='ok:121498'
  [glTF2/BoxBadNormals-glTF-Binary/BoxBadNormals.glb]='ok:14'
  [glTF2/BoxTexcoords-glTF/boxTexcoords.gltf]='ok:14'
  [glTF2/BoxTextured-glTF-Binary/BoxTextured.glb]='ok:14'
  [glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf]='ok:14'
  [glTF2/BoxTextured-glTF-pbrSpecularGlossiness/BoxTextured.gltf]='ok:14'
  [glTF2/BoxTextured-glTF-techniqueWebGL/BoxTextured.gltf]='ok:14'
  [glTF2/BoxTextured-glTF/BoxTextured.gltf]='ok:14'
  [glTF2/ClearCoat-glTF/ClearCoatTest.gltf]='ok:37118'
  [glTF2/IncorrectVertexArrays/Cube.gltf]='ok:48' # truncated arrays: the whole triangles are kept
  [glTF2/cameras/Cameras.gltf]='ok:4'
  [glTF2/glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf]='ok:14' # base shape
  [glTF2/issue_3269/texcoord_crash.gltf]='ok:12'
  [glTF2/simple_skin/simple_skin.gltf]='ok:10' # bind pose
  [glTF2/textureTransform/TextureTransformTest.gltf]='ok:26'
  [glTF2/wrongTypes/badExtension.gltf]='ok:14'
  [glTF2/wrongTypes/badNumber.gltf]='ok:14'
  [glTF2/wrongTypes/badObject.gltf]='ok:14'
  [glTF2/wrongTypes/badString.gltf]='ok:14'
  [glTF2/wrongTypes/badUint.gltf]='ok:14'
  # every triangle primitive mode renders; points and lines alone leave nothing to draw
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_00.gltf]='fail:no triangles in the scene \(1 point or line primitive'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_01.gltf]='fail:no triangles in the scene \(1 point or line primitive'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_02.gltf]='fail:no triangles in the scene \(1 point or line primitive'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_03.gltf]='fail:no triangles in the scene \(1 point or line primitive'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_04.gltf]='ok:4'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_05.gltf]='ok:4'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_06.gltf]='ok:4'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_07.gltf]='fail:no triangles in the scene \(1 point or line primitive'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_08.gltf]='fail:no triangles in the scene \(1 point or line primitive'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_09.gltf]='fail:no triangles in the scene \(1 point or line primitive'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_10.gltf]='fail:no triangles in the scene \(1 point or line primitive'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_11.gltf]='ok:4'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_12.gltf]='ok:4'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_13.gltf]='ok:4'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_14.gltf]='ok:4'
  [glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_15.gltf]='ok:4'
  # broken or unsupported content: refused with the reason
  [glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb]='fail:accessor 2 \(POSITION\): vertex 0 is not finite'
  [glTF2/IndexOutOfRange/AllIndicesOutOfRange.gltf]='fail:indices out of range \(index 65535 >= 24 vertices\)'
  [glTF2/IndexOutOfRange/IndexOutOfRange.gltf]='fail:indices out of range \(index 255 >= 24 vertices\)'
  [glTF2/MissingBin/BoxTextured.gltf]='fail:File not found : BoxTextured0\.bin'
  [glTF2/SchemaFailures/sceneWrongType.gltf]='fail:File not found : BoxTextured0\.bin'
  [glTF2/RecursiveNodes/RecursiveNodes.gltf]='fail:node 0 is reached twice \(a cycle'
  [glTF2/TestNoRootNode/NoScene.gltf]='fail:no triangles in the scene \(the file has no meshes\)'
  [glTF2/TestNoRootNode/SceneWithoutNodes.gltf]='fail:no triangles in the scene \(the file has no meshes\)'
  [glTF2/draco/2CylinderEngine.gltf]='fail:requires extension KHR_draco_mesh_compression \(Draco-compressed meshes\), which is not supported'
  [glTF2/wrongTypes/badArray.gltf]='fail:no triangles in the scene \(its meshes have no primitives\)'
)

fail=0
declare -A seen=()
n_ok=0 n_fail=0 k=0
mapfile -t files < <(cd "$MODELS" && find glTF glTF2 -type f \( -name '*.gltf' -o -name '*.glb' \) 2>/dev/null | LC_ALL=C sort)
start=$SECONDS
for rel in "${files[@]}"; do
  seen[$rel]=1
  want=${EXPECT[$rel]:-}
  if [ -z "$want" ]; then
    echo "FAIL: $rel: not in the table of expected outcomes (run it and add it)"; fail=1; continue
  fi
  k=$((k + 1))
  out="$TMP/out$k.exr"
  # A small N-tree with line spaces and few rays, exercised on odd geometry at a fraction of the
  # cost of the defaults: exact-ls, the line-space mode that tests alpha-masked casters' texels
  # (several of these files have MASK or BLEND materials, which linespace refuses).
  err=$(timeout -k 5 "$LIMIT" "$BIN" render "$MODELS/$rel" --size 64x64 --spp 4 --mode exact-ls --tree 4,2 --json -o "$out" \
        2>&1 >"$TMP/stdout$k"); rc=$?
  if [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then
    echo "FAIL: $rel: still running after ${LIMIT} s (hang?)"; fail=1; continue
  fi
  if [ "$rc" -ge 128 ]; then
    echo "FAIL: $rel: crashed (exit $rc, signal $((rc - 128)))"; echo "$err" | tail -n 30 | sed 's/^/    /'; fail=1; continue
  fi
  if ls -a "$TMP" | grep -q '\.tmp-'; then
    echo "FAIL: $rel: left a temporary file"; ls -a "$TMP" | grep '\.tmp-' | sed 's/^/    /'; fail=1
    rm -f "$TMP"/.*.tmp-*
  fi
  case $want in
  ok:*)
    tris=${want#ok:}
    if [ "$rc" -ne 0 ]; then
      echo "FAIL: $rel: expected to render, exited $rc"; echo "$err" | sed 's/^/    /'; fail=1; continue
    fi
    [ -s "$out" ] || { echo "FAIL: $rel: exit 0 but no $out"; fail=1; continue; }
    summary=$(python3 -c '
import json, sys
j = json.load(open(sys.argv[1]))
print(j["triangles"], j["covered_pixels"])' "$TMP/stdout$k") || { echo "FAIL: $rel: no JSON summary"; fail=1; continue; }
    read -r got_tris covered <<<"$summary"
    if [ "$got_tris" != "$tris" ] || [ "$covered" -eq 0 ]; then
      echo "FAIL: $rel: $got_tris triangles and $covered covered pixels, expected $tris triangles and some coverage"
      fail=1; continue
    fi
    n_ok=$((n_ok + 1))
    echo "ok: $rel renders ($tris triangles, $covered pixels covered)"
    ;;
  fail:*)
    pattern=${want#fail:}
    if [ "$rc" -ne 1 ]; then
      echo "FAIL: $rel: expected exit 1, got $rc"; echo "$err" | sed 's/^/    /'; fail=1; continue
    fi
    # The error line names the file; the reason matches the table.
    line=$(grep -F -- "error: $MODELS/$rel: " <<<"$err")
    if [ -z "$line" ] || ! grep -qE -- "$pattern" <<<"$line"; then
      echo "FAIL: $rel: no error line naming the file and matching /$pattern/:"; echo "$err" | sed 's/^/    /'
      fail=1; continue
    fi
    if [ -e "$out" ]; then
      echo "FAIL: $rel: failed but wrote $out"; fail=1; continue
    fi
    n_fail=$((n_fail + 1))
    echo "ok: $rel fails: ${line#*"$MODELS/$rel: "}"
    ;;
  esac
  rm -f "$out"
done
for rel in "${!EXPECT[@]}"; do
  [ -n "${seen[$rel]:-}" ] || { echo "FAIL: $rel: in the table but not under $MODELS"; fail=1; }
done
echo "${#files[@]} files: $n_ok render, $n_fail fail as expected, in $((SECONDS - start)) s"
exit $fail
