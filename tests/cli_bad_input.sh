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
# The 1-unit triangle far from the origin: at 1e7 it spans 1 float step, at 1e4 about 1000.
sed 's/"nodes":\[{"mesh":0}\]/"nodes":[{"mesh":0,"translation":[1e7,1e7,1e7]}]/' "$TMP/good.gltf" > "$TMP/far7.gltf"
sed 's/"nodes":\[{"mesh":0}\]/"nodes":[{"mesh":0,"translation":[1e4,1e4,1e4]}]/' "$TMP/good.gltf" > "$TMP/far4.gltf"

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
# Precision limits (engine/shadow/README.md, "Accuracy at the extremes"): a scene float cannot resolve, a tree whose
# leaves it cannot resolve; a coarser tree and the exact mode render.
expect 1 "far7.gltf.*only 1 float steps" -- "${R[@]}" "$TMP/far7.gltf"
expect 1 "far4.gltf.*LS\(7,3\) leaves .* float steps" -- "${R[@]}" "$TMP/far4.gltf" --mode linespace
expect 0 "" -- render --size 32x32 -o "$TMP/far_ok.exr" "$TMP/far4.gltf" --tree 2,2
expect 0 "" -- render --size 32x32 -o "$TMP/far_ok.exr" "$TMP/far4.gltf" --mode exact

# --- command line
expect 2 "unknown command" -- frobnicate
expect 2 "unknown option '--bogus'" -- "${R[@]}" --bogus
expect 2 "--size: expected WIDTHxHEIGHT" -- "${R[@]}" --size 0x10
expect 2 "--size: expected WIDTHxHEIGHT" -- "${R[@]}" --size 12
expect 2 "--size: expected WIDTHxHEIGHT" -- "${R[@]}" --size 99999x10
expect 2 "--camera-pos: expected 3" -- "${R[@]}" --camera-pos 1,2
expect 2 "--camera-pos: expected 3" -- "${R[@]}" --camera-pos 1,nan,2
expect 2 "--light-pos: expected 3" -- "${R[@]}" --light-pos inf,0,0
expect 2 "--light-size: width and height must both be positive, or both 0" -- "${R[@]}" --light-size 0,1
expect 2 "--light-size: width and height must both be positive, or both 0" -- "${R[@]}" --light-size 2,0
expect 2 "--light-radiance: must not be negative" -- "${R[@]}" --light-radiance -1
expect 2 "--light-normal: must not be zero" -- "${R[@]}" --light-normal 0,0,0
expect 2 "--light-up: must not be zero or parallel" -- "${R[@]}" --light-normal 0,-1,0 --light-up 0,2,0
# --light groups: position:normal:up:size:radiance
L="0,4,0:0,-1,0:0,0,1:1,1:10"
expect 2 "--light: expected position:normal:up:size:radiance" -- "${R[@]}" --light 0,4,0:0,-1,0:0,0,1:1,1
expect 2 "--light: expected position:normal:up:size:radiance" -- "${R[@]}" --light "$L:1"
expect 2 "--light normal: expected 3" -- "${R[@]}" --light 0,4,0:0,-1:0,0,1:1,1:10
expect 2 "--light size: width and height must both be positive" -- "${R[@]}" --light 0,4,0:0,-1,0:0,0,1:0,1:10
expect 2 "--light radiance: must not be negative" -- "${R[@]}" --light 0,4,0:0,-1,0:0,0,1:1,1:1,-1,1
expect 2 "--light 2: the normal and up must not be zero, nor parallel" -- "${R[@]}" --light "$L" \
  --light 0,4,0:0,-1,0:0,3,0:1,1:10
expect 2 "--light 1's position .* beyond 1e\+18" -- "${R[@]}" --light 0,1e19,0:0,-1,0:0,0,1:1,1:10
# the kinds by name (scene/light.h)
expect 2 "--light: unknown kind 'lamp'" -- "${R[@]}" --light lamp:0,4,0:5
expect 2 "--light range: expected a number in \\[0" -- "${R[@]}" --light omni:0,4,0:5:-1
expect 2 "--light: expected omni:position:intensity\\[:range\\]" -- "${R[@]}" --light omni:0,4,0:5:4:9
expect 2 "--light sphere radius: must be positive" -- "${R[@]}" --light sphere:0,4,0:0:5
expect 2 "--light spot cone: inner and outer angles need 0 <= inner < outer <= 90" -- "${R[@]}" --light spot:0,4,0:0,-1,0:30,20:5
expect 2 "--light and --light-pos" -- "${R[@]}" --light "$L" --light-size 2,2
expect 2 "--light: at most 16 lights" -- "${R[@]}" $(for i in $(seq 17); do echo --light "$L"; done)
expect 2 "camera position and target coincide" -- "${R[@]}" --camera-pos 1,1,1 --camera-target 1,1,1
expect 2 "--fov: expected a number" -- "${R[@]}" --fov 180
expect 2 "--tree: expected N,d" -- "${R[@]}" --tree 17,3
expect 2 "--tree: expected N,d" -- "${R[@]}" --tree 4,0
expect 2 "--spp: expected an integer" -- "${R[@]}" --spp 0
expect 2 "--seed: expected an integer" -- "${R[@]}" --seed x
expect 2 "--mode: expected one of" -- "${R[@]}" --mode fast
expect 2 "--traversal: expected one of" -- "${R[@]}" --traversal bfs
expect 2 "--sampler: expected one of" -- "${R[@]}" --sampler halton
expect 2 "--filter: expected one of" -- "${R[@]}" --filter bilateral
expect 2 "--tile: expected WIDTHxHEIGHT" -- "${R[@]}" --tile 9x3
expect 2 "--split: expected one of" -- "${R[@]}" --split half
expect 2 "budgeted split .* needs filter none.*got filter interleaved" -- "${R[@]}" --split budget --filter interleaved
expect 2 "budgeted split .* needs filter none.*sampler grid" -- "${R[@]}" --sampler grid --split budget
expect 2 "budgeted split .* ray dump" -- "${R[@]}" --mode exact --split budget --ray-dump "$TMP/rays.bin"
expect 2 "--tile: expected WIDTHxHEIGHT" -- "${R[@]}" --tile 0x3
expect 2 "option --size needs a value" -- "${R[@]}" --size
expect 2 "more than one scene" -- "${R[@]}" builtin:plane builtin:default

# Every render option with values it must refuse, NaN and Inf included (exit 2 naming the option).
bad_values() { # OPTION PATTERN VALUE...: each VALUE of OPTION is refused with PATTERN
  local opt=$1 pattern=$2; shift 2
  for v in "$@"; do expect 2 "$opt: $pattern" -- "${R[@]}" "$opt" "$v"; done
}
bad_values --size "expected WIDTHxHEIGHT" 10x-1 x10 10x10x10 "" 10x 16385x16 nanx3
bad_values --camera-pos "expected 3 comma-separated finite numbers" 1,nan,2 inf,0,0 0,-inf,0 1e39,0,0 \
  0x1p200,0,0 1,2,3,4 1,,3 ""
bad_values --camera-target "expected 3 comma-separated finite numbers" -inf,0,0 nan,nan,nan 1,2
bad_values --fov "expected a number in" 0 180 nan inf -5 x 1e39
bad_values --light-pos "expected 3 comma-separated finite numbers" nan,0,0 0,inf,0 0,0,1e40
bad_values --light-normal "expected 3 comma-separated finite numbers" nan,0,1 0,-inf,0
bad_values --light-up "expected 3 comma-separated finite numbers" inf,0,0
bad_values --light-size "(expected 2 comma-separated finite numbers|width and height must both be positive)" \
  -1,1 inf,1 1 nan,nan 0,-0.5
bad_values --light-radiance "(expected [0-9] comma-separated finite numbers|must not be negative)" nan inf 1,2 -1,0,0
bad_values --exposure "expected a number in" -1 nan inf x
bad_values --seed "expected an integer in" -1 4294967296 1.5 x ""
bad_values --spp "expected an integer in" 4097 -3 nan 1e3
bad_values --tree "expected N,d" 1,3 4,7 4 a,b 4,2,1 ""
bad_values --max-memory "expected a positive size" 0 -1 1e-300 x nan 1e30G 5T ""
bad_values --max-error "expected a number in" 2 -0.1 nan
bad_values --quality "expected one of manual\|auto, got 'best'" best
for opt in -o --output --preview --ray-dump --camera-pos --light-size --tree --mode --max-memory; do
  expect 2 "option $opt needs a value" -- "${R[@]}" "$opt"
done
expect 2 "--ray-dump: mode none traces no rays" -- "${R[@]}" --mode none --ray-dump "$TMP/rays.bin"
# Finite values whose squares or sums overflow float further on: refused with the reason.
expect 2 "camera position .* beyond 1e\+18" -- "${R[@]}" --camera-pos 3e38,0,0
expect 2 "camera target .* beyond 1e\+18" -- "${R[@]}" --camera-target 0,-2e18,0
expect 2 "light position .* beyond 1e\+18" -- "${R[@]}" --light-pos 0,1e19,0
expect 2 "corner of the light .* beyond 1e\+18" -- "${R[@]}" --light-size 3e38,1
expect 2 "camera position and target coincide" -- "${R[@]}" --camera-pos 0,1,1 --camera-target 0,1,1.00000001
# ... while extreme but usable directions are normalised without overflow or underflow: the image
# is the one of the plain direction, bit for bit. (diff counts a NaN or Inf as an infinite error,
# so --fail max=0 also proves every pixel finite.)
same_render() { # EXTREME_ARGS REFERENCE_ARGS
  local a=$TMP/extreme.exr b=$TMP/reference.exr
  # shellcheck disable=SC2086
  if ! "$BIN" render builtin:default --size 24x16 --spp 4 $1 -o "$a" >/dev/null 2>"$TMP/extreme.err" ||
     ! "$BIN" render builtin:default --size 24x16 --spp 4 $2 -o "$b" >/dev/null 2>>"$TMP/extreme.err"; then
    echo "FAIL: render $1 or $2 failed:"; sed 's/^/    /' "$TMP/extreme.err"; fail=1; return
  fi
  for ch in R shadow.V; do
    if ! "$BIN" diff "$a" "$b" --channel "$ch" --fail max=0 >/dev/null; then
      echo "FAIL: render $1 differs from render $2 in $ch"; fail=1; return
    fi
  done
  echo "ok: render $1 = render $2"
}
same_render "--light-normal 1e30,-1e30,0" "--light-normal 1,-1,0"
same_render "--light-normal 1e-30,-2e-30,1e-31" "--light-normal 10,-20,1"
same_render "--light-up 0,0,-1e-30" "--light-up 0,0,-1"
same_render "--light-up 3e38,0,0" "--light-up 1,0,0"
same_render "--light-radiance 1e30" "--light-radiance 1e30"

# build, diff and info refuse bad command lines the same way.
expect 2 "--tree: expected N,d" -- build --no-upload --tree 1,1
expect 2 "--max-memory: expected a positive size" -- build --no-upload --max-memory 0
expect 2 "build: unknown option '--bogus'" -- build --bogus
expect 2 "build: more than one scene" -- build builtin:plane builtin:default
expect 2 "option --tree needs a value" -- build --tree
expect 1 "missing.glb.*cannot open" -- build --no-upload "$TMP/missing.glb"
# A tree over --max-memory is refused while it is built, with its size in the message.
expect 1 "LS\(8,4\) needs at least [0-9.]+ MiB of pools .* over the limit of 1.0 MiB" -- build --no-upload --tree 8,4 --max-memory 1M
expect 1 "LS\(8,4\) needs at least [0-9.]+ MiB of pools" -- "${R[@]}" --tree 8,4 --max-memory 1M
expect 2 "diff: expected two EXR files" -- diff "$TMP/a.exr"
expect 2 "diff: more than two files" -- diff a.exr b.exr c.exr
expect 2 "diff: unknown option '--bogus'" -- diff a.exr b.exr --bogus
expect 2 "--fail: expected KEY=VALUE" -- diff a.exr b.exr --fail mae
expect 2 "--fail: expected KEY=VALUE" -- diff a.exr b.exr --fail ""
expect 2 "--fail: expected one of" -- diff a.exr b.exr --fail speed=1
expect 2 "--fail: expected a non-negative number for mae" -- diff a.exr b.exr --fail mae=-1
expect 2 "--fail: expected a non-negative number for p99" -- diff a.exr b.exr --fail p99=nan
expect 2 "--fail: expected a non-negative number for max" -- diff a.exr b.exr --fail max=inf
expect 2 "option --channel needs a value" -- diff a.exr b.exr --channel
expect 2 "missing.exr" -- diff "$TMP/missing.exr" "$TMP/missing.exr"
expect 2 "info: unexpected argument '--bogus'" -- info --bogus
expect 2 "--tree-kinds: expected one of scene\|object, got .foo." -- bench --tree-kinds foo
expect 2 "--tree-kinds: scene is listed twice" -- bench --tree-kinds scene,scene
expect 2 "--tree-kinds: expected scene, object or both" -- bench --tree-kinds ,

# --- outputs: every one is checked before any work, and refused when it cannot be written
expect 1 "nonexistent-dir/x.exr.*cannot write" -- render --size 32x32 builtin:plane -o "$TMP/nonexistent-dir/x.exr"
mkdir -p "$TMP/adir"
expect 1 "adir: cannot write: is a folder" -- render --size 32x32 builtin:plane -o "$TMP/adir"
expect 1 "adir/: cannot write: is a folder" -- render --size 32x32 builtin:plane -o "$TMP/adir/"
expect 1 "empty output file name" -- render --size 32x32 builtin:plane -o ""
mkfifo "$TMP/fifo.exr"
expect 1 "fifo.exr: cannot write: exists and is not a regular file" -- render --size 32x32 builtin:plane -o "$TMP/fifo.exr"
[ -p "$TMP/fifo.exr" ] || { echo "FAIL: the FIFO was replaced"; fail=1; }
rm -f "$TMP/fifo.exr"
if [ "$(id -u)" -ne 0 ]; then # root writes anywhere
  mkdir -p "$TMP/readonly" && chmod 555 "$TMP/readonly"
  expect 1 "readonly/x.exr: cannot write here: Permission denied" -- render --size 32x32 builtin:plane -o "$TMP/readonly/x.exr"
  chmod 755 "$TMP/readonly"
fi
# A second output that cannot be written stops the run before the first is (over)written.
echo "previous" > "$TMP/out.exr"
for extra in "--preview $TMP/nonexistent-dir/p.png" "--preview $TMP/adir" "--ray-dump $TMP/adir"; do
  # shellcheck disable=SC2086
  err=$("$BIN" render --size 32x32 builtin:plane -o "$TMP/out.exr" $extra 2>&1 >/dev/null); rc=$?
  if [ "$rc" -ne 1 ] || ! grep -q "cannot write" <<<"$err" || [ "$(cat "$TMP/out.exr")" != "previous" ]; then
    echo "FAIL: render $extra: exit $rc, output $(head -c 8 "$TMP/out.exr"):"; echo "$err" | sed 's/^/    /'; fail=1
  else
    echo "ok: exit 1, previous output intact: render $extra"
  fi
done
rm -f "$TMP/out.exr"
# A failing render leaves an existing output untouched.
echo "previous" > "$TMP/keep.exr"
expect 1 "index_range.gltf" -- render --size 32x32 -o "$TMP/keep.exr" "$TMP/index_range.gltf"
[ "$(cat "$TMP/keep.exr")" = "previous" ] || { echo "FAIL: previous output overwritten"; fail=1; }
ls -a "$TMP" | grep -q '\.tmp-' && { echo "FAIL: temporary file left behind"; ls -a "$TMP"; fail=1; }

# The good file renders (so the broken ones fail for their defect, not for the harness).
"$BIN" render --size 32x32 -o "$TMP/good.exr" "$TMP/good.gltf" >/dev/null || { echo "FAIL: good.gltf did not render"; fail=1; }
[ -s "$TMP/good.exr" ] || { echo "FAIL: good.exr missing"; fail=1; }
# diff's error image cannot go into a folder either; the comparison itself works.
expect 2 "adir.*(cannot|Is a directory)" -- diff "$TMP/good.exr" "$TMP/good.exr" -o "$TMP/adir"
"$BIN" diff "$TMP/good.exr" "$TMP/good.exr" --fail max=0 >/dev/null || { echo "FAIL: good.exr differs from itself"; fail=1; }
ls -a "$TMP" "$TMP/adir" | grep -q '\.tmp-' && { echo "FAIL: temporary file left behind"; ls -a "$TMP"; fail=1; }
# Broken EXRs given to diff (either side): exit 2, the file named with its problem, no error image.
printf 'not an EXR at all' > "$TMP/garbage.exr"
head -c "$(($(stat -c %s "$TMP/good.exr") * 3 / 4))" "$TMP/good.exr" > "$TMP/truncated.exr"
"$BIN" diff "$TMP/good.exr" "$TMP/good.exr" -o "$TMP/error.exr" >/dev/null || { echo "FAIL: diff -o error.exr"; fail=1; }
expect 2 "garbage.exr: not a readable EXR" -- diff "$TMP/garbage.exr" "$TMP/good.exr" -o "$TMP/out.exr"
expect 2 "truncated.exr: .*(damaged|EXR)" -- diff "$TMP/good.exr" "$TMP/truncated.exr" -o "$TMP/out.exr"
expect 2 "error.exr: no channel 'shadow.V'" -- diff "$TMP/error.exr" "$TMP/good.exr" -o "$TMP/out.exr"
# The same broken file as bench's G-buffer: refused before any work, nothing written.
expect 1 "garbage.exr: not a readable EXR" -- bench --shader shadow --gbuffer "$TMP/garbage.exr" \
  --scenes builtin:default --out "$TMP/bench-out"
expect 1 "error.exr: no P.X channel" -- bench --shader shadow --gbuffer "$TMP/error.exr" \
  --scenes builtin:default --out "$TMP/bench-out"
[ -e "$TMP/bench-out" ] && { echo "FAIL: bench created its output folder for a G-buffer it refused"; fail=1; }
# And as render's: exit 1, the file and its problem named, no output (expect checks out.exr).
expect 1 "garbage.exr: not a readable EXR" -- render builtin:default --gbuffer "$TMP/garbage.exr" -o "$TMP/out.exr"
expect 1 "error.exr: no P.X channel" -- render builtin:default --gbuffer "$TMP/error.exr" -o "$TMP/out.exr"
expect 2 "--gbuffer: .*not with --frames" -- render builtin:default --gbuffer "$TMP/good.exr" --frames 1:2 -o "$TMP/f%d.exr"

chmod 644 "$TMP/unreadable.glb"
exit $fail
