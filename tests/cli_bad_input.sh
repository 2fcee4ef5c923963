#!/usr/bin/env bash
# Bad input: every case ends with the expected exit code, a message on stderr that names the file
# (or option) and the problem, no crash, and no output file (an existing one left intact).
set -u
BIN=${PN_BIN:?PN_BIN not set}
TMP=${PN_TEST_TMP:-/tmp}/cli_bad_input
rm -rf "$TMP" && mkdir -p "$TMP"
fail=0

# expect EXIT PATTERN -- ARGS...: runs penumbra ARGS with -o $TMP/out.exr appended for render.
expect() {
  local want=$1 pattern=$2; shift 3
  local err rc
  err=$("$BIN" "$@" 2>&1 >/dev/null); rc=$?
  if [ "$rc" -ne "$want" ]; then
    echo "FAIL: penumbra $* exited $rc, expected $want"; echo "$err" | sed 's/^/    /'; fail=1; return
  fi
  if ! grep -qE -- "$pattern" <<<"$err"; then
    echo "FAIL: penumbra $*: stderr lacks /$pattern/:"; echo "$err" | sed 's/^/    /'; fail=1; return
  fi
  if [ "$rc" -ne 0 ] && ls "$TMP"/out.exr "$TMP"/.out.exr.* >/dev/null 2>&1; then
    echo "FAIL: penumbra $*: left an output file"; fail=1
  fi
  echo "ok: exit $rc, /$pattern/: penumbra $*"
}

# --- broken scene files
printf '{"asset": {"version": "2.0"}, "meshes": [ {' > "$TMP/malformed.gltf"
printf 'not a glb at all' > "$TMP/garbage.glb"
printf 'solid x\nendsolid\n' > "$TMP/model.stl"
# Valid JSON, one triangle whose third index is out of range (buffer: 3 float3 positions + 3 u16).
b64pos=$(python3 -c "
import struct,base64
pos=struct.pack('<9f',0,0,0,1,0,0,0,1,0)
print(base64.b64encode(pos).decode())")
gltf() { # $1 = positions base64, $2 = indices base64, $3 = min/max json, $4 = mode
  cat <<JSON
{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
 "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"mode":$4}]}],
 "buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,$1"},
            {"byteLength":8,"uri":"data:application/octet-stream;base64,$2"}],
 "bufferViews":[{"buffer":0,"byteLength":36},{"buffer":1,"byteLength":6}],
 "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",$3},
              {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]}
JSON
}
idx_ok=$(python3 -c "import struct,base64;print(base64.b64encode(struct.pack('<4H',0,1,2,0)).decode())")
idx_bad=$(python3 -c "import struct,base64;print(base64.b64encode(struct.pack('<4H',0,1,7,0)).decode())")
nanpos=$(python3 -c "
import struct,base64
print(base64.b64encode(struct.pack('<9f',0,0,0,float('nan'),0,0,0,1,0)).decode())")
mm='"min":[0,0,0],"max":[1,1,0]'
gltf "$b64pos" "$idx_ok" "$mm" 4 > "$TMP/good.gltf"
gltf "$b64pos" "$idx_bad" "$mm" 4 > "$TMP/index_range.gltf"
gltf "$nanpos" "$idx_ok" "$mm" 4 > "$TMP/nan.gltf"
gltf "$b64pos" "$idx_ok" "$mm" 0 > "$TMP/points.gltf"
touch "$TMP/unreadable.glb" && chmod 000 "$TMP/unreadable.glb"

R=(render --size 32x32 -o "$TMP/out.exr")
expect 1 "missing.glb.*(No such file|cannot|not found|unable|open)" -- "${R[@]}" "$TMP/missing.glb"
if [ "$(id -u)" -ne 0 ]; then
  expect 1 "unreadable.glb" -- "${R[@]}" "$TMP/unreadable.glb"
fi
expect 1 "malformed.gltf.*" -- "${R[@]}" "$TMP/malformed.gltf"
expect 1 "garbage.glb.*" -- "${R[@]}" "$TMP/garbage.glb"
expect 1 "model.stl.*(\.gltf|\.glb)" -- "${R[@]}" "$TMP/model.stl"
expect 1 "index_range.gltf.*(out of range|range)" -- "${R[@]}" "$TMP/index_range.gltf"
expect 1 "nan.gltf.*(NaN|non-finite|finite)" -- "${R[@]}" "$TMP/nan.gltf"
expect 1 "points.gltf.*no triangles" -- "${R[@]}" "$TMP/points.gltf"
expect 1 "builtin:nope.*no such built-in" -- "${R[@]}" builtin:nope

# --- command line
expect 2 "unknown command" -- frobnicate
expect 2 "unknown option '--bogus'" -- "${R[@]}" --bogus
expect 2 "--size: expected WIDTHxHEIGHT" -- "${R[@]}" --size 0x10
expect 2 "--size: expected WIDTHxHEIGHT" -- "${R[@]}" --size 12
expect 2 "--size: expected WIDTHxHEIGHT" -- "${R[@]}" --size 99999x10
expect 2 "--camera-pos: expected 3" -- "${R[@]}" --camera-pos 1,2
expect 2 "--camera-pos: expected 3" -- "${R[@]}" --camera-pos 1,nan,2
expect 2 "--light-pos: expected 3" -- "${R[@]}" --light-pos inf,0,0
expect 2 "--light-size: width and height must be positive" -- "${R[@]}" --light-size 0,1
expect 2 "--light-radiance: must not be negative" -- "${R[@]}" --light-radiance -1
expect 2 "--light-normal: must not be zero" -- "${R[@]}" --light-normal 0,0,0
expect 2 "--light-up: must not be zero or parallel" -- "${R[@]}" --light-normal 0,-1,0 --light-up 0,2,0
expect 2 "camera position and target coincide" -- "${R[@]}" --camera-pos 1,1,1 --camera-target 1,1,1
expect 2 "--fov: expected a number" -- "${R[@]}" --fov 180
expect 2 "--tree: expected N,d" -- "${R[@]}" --tree 17,3
expect 2 "--tree: expected N,d" -- "${R[@]}" --tree 4,0
expect 2 "--spp: expected an integer" -- "${R[@]}" --spp 0
expect 2 "--seed: expected an integer" -- "${R[@]}" --seed x
expect 2 "--mode: expected one of" -- "${R[@]}" --mode fast
expect 2 "--traversal: expected one of" -- "${R[@]}" --traversal bfs
expect 2 "--sampler: expected one of" -- "${R[@]}" --sampler halton
expect 2 "option --size needs a value" -- "${R[@]}" --size
expect 2 "more than one scene" -- "${R[@]}" builtin:plane builtin:default

# --- outputs
expect 1 "nonexistent-dir/x.exr.*cannot write" -- render --size 32x32 builtin:plane -o "$TMP/nonexistent-dir/x.exr"
# A failing render leaves an existing output untouched.
echo "previous" > "$TMP/keep.exr"
expect 1 "index_range.gltf" -- render --size 32x32 -o "$TMP/keep.exr" "$TMP/index_range.gltf"
[ "$(cat "$TMP/keep.exr")" = "previous" ] || { echo "FAIL: previous output overwritten"; fail=1; }
ls -a "$TMP" | grep -q '\.tmp-' && { echo "FAIL: temporary file left behind"; ls -a "$TMP"; fail=1; }

# The good file renders (so the broken ones fail for their defect, not for the harness).
"$BIN" render --size 32x32 -o "$TMP/good.exr" "$TMP/good.gltf" >/dev/null || { echo "FAIL: good.gltf did not render"; fail=1; }
[ -s "$TMP/good.exr" ] || { echo "FAIL: good.exr missing"; fail=1; }

chmod 644 "$TMP/unreadable.glb"
exit $fail
