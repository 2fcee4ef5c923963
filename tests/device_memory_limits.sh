#!/usr/bin/env bash
# Device memory limits (issue 30), on the device as it is: a scene whose pools cannot fit one
# buffer of the device (LS(8,6) on the bunny: ~6.5 GiB of line space against lavapipe's 2 GiB
# maxMemoryAllocationSize), with --max-memory raised out of the way, in every mode that builds a
# tree and with --trees object; a tree over --max-memory; a ray dump over maxBufferSize. Each must
# exit 1 with one message naming what did not fit, its size and the limit, and leave no output
# file nor temporary. The tree is refused while it is built, before its line spaces exist: the
# test needs no more than a few hundred MB of RAM. The limits lavapipe is too large to reach here
# (exact's and rayquery's pools, the heap) are checked on a shrunk device in device_memory_faults.
set -u
BIN=${PN_BIN:?PN_BIN not set}
ASSETS=${PN_ASSETS:?PN_ASSETS not set}
TMP=${PN_TEST_TMP:-/tmp}/device_memory_limits
rm -rf "$TMP" && mkdir -p "$TMP"
BUNNY=$ASSETS/stanford-bunny-69k.glb
SPONZA=$ASSETS/dabrovic-sponza-66k.glb
for f in "$BUNNY" "$SPONZA"; do
  [ -f "$f" ] || { echo "skipped: $f missing (../shared/assets)"; exit 77; }
done
fail=0

# expect LABEL PATTERN ARGS...: exit 1, PATTERN on stderr as its only error line, an empty folder.
expect() {
  local label=$1 pattern=$2; shift 2
  local dir=$TMP/run err rc errors
  rm -rf "$dir" && mkdir -p "$dir"
  err=$(cd "$dir" && "$BIN" "$@" 2>&1 >/dev/null); rc=$?
  errors=$(grep -c 'error:' <<<"$err")
  if [ "$rc" -ne 1 ] || ! grep -qE -- "$pattern" <<<"$err" || [ "$errors" -ne 1 ] || [ -n "$(ls -A "$dir")" ]; then
    echo "FAIL: $label: exit $rc (expected 1), $errors error line(s) (expected 1 matching /$pattern/)," \
      "files left: '$(ls -A "$dir" | tr '\n' ' ')': penumbra $*"
    echo "$err" | tail -n 10 | sed 's/^/    /'
    fail=1
    return
  fi
  echo "ok: $label: $(grep 'error:' <<<"$err")"
}

POOL='LS\(8,6\) needs a pool of at least [0-9.]+ MiB \([0-9]+ subdivided nodes x 7\.5 KiB of line space\), more than one buffer of this device can hold \([0-9.]+ MiB\)'
for mode in linespace ls-leaf ls-plane hybrid exact-ls; do
  expect "$mode LS(8,6)" "$POOL" render "$BUNNY" --size 64x64 --mode "$mode" --tree 8,6 --max-memory 64G -o out.exr
done
# Per-object trees: the mesh's tree says why; nothing after it claims the host ran out of memory.
expect "linespace --trees object LS(8,6)" "$POOL" render "$SPONZA" --size 64x64 --trees object --tree 8,6 \
  --max-memory 64G -o out.exr
expect "--max-memory 1M" 'LS\(7,3\) needs (at least )?[0-9.]+ MiB of pools .*, over the limit of 1\.0 MiB \(--max-memory\)' \
  render "$BUNNY" --size 64x64 --mode linespace --max-memory 1M -o out.exr
expect "build LS(8,6)" "$POOL" build "$BUNNY" --tree 8,6 --max-memory 64G
# The ray dump's buffer: 1024x1024 pixels x 4097 x 16 bytes, 16 times lavapipe's 4 GiB maxBufferSize.
expect "ray dump over maxBufferSize" 'the ray dump needs [0-9.]+ MiB, more than one buffer of this device can hold \(maxBufferSize [0-9.]+ MiB\)' \
  render builtin:default --size 1024x1024 --spp 4096 --ray-dump rays.bin -o out.exr

exit $fail
