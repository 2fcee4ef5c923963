#!/usr/bin/env bash
# Device memory faults (issue 30): every device allocation a run makes is made to fail in turn
# (PN_FAULT_ALLOC=K fails the K-th: a vkCreateBuffer, vkCreateImage, vkAllocateMemory or
# vkCreateAccelerationStructureKHR, with VK_ERROR_OUT_OF_DEVICE_MEMORY). For each K the run must
# exit 1 (not 134/139: a crash or a sanitizer's abort; not 3: the validation layer saw a misuse while
# cleaning up), say on stderr which allocation failed, leave no output file nor temporary behind, and
# (under ASan, build-asan/) leak nothing. Then PN_FAULT_MAX_ALLOC and PN_FAULT_HEAP shrink the
# device to check the modes whose pools cannot outgrow lavapipe's real limits in a test.
# Needs a PN_FAULT_INJECTION build (ci/test.sh's build-asan/); elsewhere it skips. tests/sanitizers.md.
set -u
BIN=${PN_BIN:?PN_BIN not set}
ASSETS=${PN_ASSETS:?PN_ASSETS not set}
TMP=${PN_TEST_TMP:-/tmp}/device_memory_faults
rm -rf "$TMP" && mkdir -p "$TMP"
BUNNY=$ASSETS/stanford-bunny-69k.glb
fail=0
runs=0

# A clean run with PN_FAULT_ALLOC=0 lists every allocation ("fault injection: allocation K is
# vkCreateBuffer of the X") and logs the count at exit ("fault injection: N device allocations"):
# this prints the count, then the list's Ks to fail (below); nothing when this build has no fault
# injection.
#
# Which Ks: a run allocates in waves that repeat the same allocations (render makes its frame's
# resources for the view-cull pass and again for the frame; bench for the reference and each
# cell). Failing an allocation runs its caller's error path and the clean-up of everything made
# before it, within its wave and outside it. The first turn of each distinct allocation (by call
# and name) runs each of those error paths, and in the first wave each partial clean-up; the
# first allocation of each later wave runs the clean-up with the earlier waves' resources held; a
# later turn of an allocation that is not a wave's first reruns code a failure already ran with
# the same resources held, but for more of the same kind (and the run's last allocation is
# failed too). So those are the Ks: 68 of 116 for render linespace, the late and dearer ones left
# out (issue 62: the sweep was the sanitizer pass's longest test). With STRIDE, every STRIDE-th
# K and the last instead, as before.
fault_plan() { # ARGS... (run in $TMP/count)
  rm -rf "$TMP/count" && mkdir -p "$TMP/count"
  (cd "$TMP/count" && PN_FAULT_ALLOC=0 "$BIN" "$@" 2>&1 >/dev/null) | awk '
    /fault injection: allocation [0-9]+ is / {
      k = $0; sub(/.*fault injection: allocation /, "", k); name = k; sub(/ .*/, "", k); sub(/^[0-9]+ is /, "", name)
      turn = ++seen[name]
      if (turn == 1 || turn != last) pick[++picked] = k
      last = turn
    }
    /fault injection: [0-9]+ device allocations/ { n = $0; sub(/.*fault injection: /, "", n); sub(/ .*/, "", n) }
    END {
      if (n == "") exit
      print n
      pick[++picked] = n
      for (i = 1; i <= picked; i++) if (!done[pick[i]]++) print pick[i]
    }'
}

# One failing run in an empty folder: exit 1, the fault and the failed allocation named, no
# sanitizer report, and the folder still empty (no output, no temporary) but for KEEP (a pattern
# of files the command may leave, e.g. bench's folder it creates before the device). With SKIP,
# exit 0 is right too when the run says it skipped what failed (bench skips a cell it cannot set
# up, and reports the others).
check_run() { # LABEL K KEEP SKIP ARGS...
  local label=$1 k=$2 keep=$3 skip=$4; shift 4
  local dir=$TMP/run err rc left
  rm -rf "$dir" && mkdir -p "$dir"
  err=$(cd "$dir" && PN_FAULT_ALLOC=$k "$BIN" "$@" 2>&1 >/dev/null); rc=$?
  runs=$((runs + 1))
  local why=""
  if [ "$rc" -gt 128 ]; then why="crashed (exit $rc)"
  elif ! grep -qE "fault injection: allocation $k \(" <<<"$err"; then why="the fault was not injected"
  elif grep -qE 'Sanitizer|runtime error' <<<"$err"; then why="a sanitizer reported"
  elif [ "$rc" -eq 0 ] && [ -n "$skip" ] && grep -qE "$skip" <<<"$err"; then keep="${keep:+$keep|}$skip_keep"
  elif [ "$rc" -ne 1 ]; then why="exited $rc, expected 1"
  elif ! grep -qE 'error: (out of device memory allocating the |vk[A-Za-z]+ failed for the )[a-zA-Z]' <<<"$err"; then
    why="no message naming the allocation"
  fi
  # (with no KEEP every file is left behind: an empty alternative would match them all)
  left=$(cd "$dir" && find . -mindepth 1 | { if [ -n "$keep" ]; then grep -vE "^\./($keep)"; else cat; fi; } | head -n 3)
  [ -z "$why" ] && [ -n "$left" ] && why="left files behind: $(tr '\n' ' ' <<<"$left")"
  if [ -n "$why" ]; then
    echo "FAIL: $label, PN_FAULT_ALLOC=$k: $why: penumbra $*"
    echo "$err" | tail -n 25 | sed 's/^/    /'
    fail=1
    return 1
  fi
  return 0
}

# sweep LABEL KEEP SKIP ARGS...: the Ks fault_plan picks from a clean run's allocations (every
# $STRIDE-th and the last with STRIDE set).
sweep() {
  local label=$1 keep=$2 skip=$3; shift 3
  local n t0=$SECONDS bad=0 tried=0 plan ks
  plan=$(fault_plan "$@")
  n=$(head -n 1 <<<"$plan")
  if [ -z "$n" ] || [ "$n" -lt 1 ]; then
    echo "FAIL: $label: no allocation count from PN_FAULT_ALLOC=0: penumbra $*"; fail=1; return
  fi
  if [ -n "${STRIDE:-}" ]; then
    ks=$( (seq 1 "$STRIDE" "$n"; echo "$n") | sort -nu)
  else
    ks=$(tail -n +2 <<<"$plan" | sort -nu)
  fi
  for k in $ks; do
    tried=$((tried + 1))
    if ! check_run "$label" "$k" "$keep" "$skip" "$@"; then
      bad=$((bad + 1))
      [ "$bad" -ge 3 ] && { echo "  ($label: stopping after 3 failures)"; break; }
    fi
  done
  [ "$bad" -eq 0 ] && echo "ok: $label: $tried of its $n allocations failed in turn, cleanly ($((SECONDS - t0)) s)"
}

# --- skip outside fault-injection builds
probe=$(PN_FAULT_ALLOC=0 "$BIN" info 2>&1 >/dev/null | grep -c 'fault injection: ')
if [ "$probe" -eq 0 ]; then
  echo "skipped: $BIN was built without PN_FAULT_INJECTION (ci/test.sh's build-asan/ has it)"
  exit 77
fi

# --- one K, read closely: the message names the allocation, its size and the heap
out=$(cd "$TMP" && PN_FAULT_ALLOC=1 "$BIN" render builtin:default --size 32x32 --mode exact -o out.exr 2>&1)
echo "$out" | grep -E 'fault injection|error' | sed 's/^/  /'
grep -qE 'error: vkCreateBuffer failed for the [a-z]' <<<"$out" ||
  { echo "FAIL: PN_FAULT_ALLOC=1 does not name the buffer"; fail=1; }
out=$(cd "$TMP" && PN_FAULT_ALLOC=2 "$BIN" render builtin:default --size 32x32 --mode exact -o out.exr 2>&1)
echo "$out" | grep -E 'fault injection|error' | sed 's/^/  /'
grep -qE 'error: out of device memory allocating the [a-z].*\(([0-9.]+ (MiB|KiB|bytes)); [0-9.]+ MiB already held, device-local heap [0-9.]+ MiB\)' <<<"$out" ||
  { echo "FAIL: PN_FAULT_ALLOC=2 does not name the allocation with its size and the heap"; fail=1; }

# --- every allocation of a render, in the modes that allocate differently
R=(render builtin:default --size 32x32 -o out.exr)
# exact's pools (BVH, triangles) are hybrid's too, with candidate lists and a tree (every other K:
# its renderer's allocations are linespace's).
sweep "render linespace --aovs" "" "" "${R[@]}" --mode linespace --tree 3,2 --aovs
STRIDE=2 sweep "render hybrid" "" "" "${R[@]}" --mode hybrid --tree 3,2
sweep "render linespace --trees object" "" "" "${R[@]}" --mode linespace --trees object --tree 3,2
# A temporal sequence: the history's images and parameters in its first frame, the structures built
# again under the kept renderer in its second (which leaves the first frame's file).
sweep "render --frames --temporal" "t\.00\.exr" "" render builtin:default --size 32x32 --mode exact --frames 0:1 \
  --temporal -o t.%02d.exr
rq=$("$BIN" info 2>/dev/null | grep -c 'ray queries: *yes')
if [ "$rq" -gt 0 ]; then
  sweep "render rayquery" "" "" "${R[@]}" --mode rayquery
else
  echo "note: no ray queries on this device: the rayquery sweep is skipped"
fi
# rtpipeline: rayquery's structure, and the pipeline's shader binding table (every third K).
if "$BIN" info 2>/dev/null | grep -q 'ray-tracing pipelines: *yes'; then
  STRIDE=3 sweep "render rtpipeline" "" "" "${R[@]}" --mode rtpipeline
else
  echo "note: no ray-tracing pipelines on this device: the rtpipeline sweep is skipped"
fi
# build uploads the pools alone.
sweep "build" "" "" build builtin:default --tree 3,2
# bench: the reference render, then a cell per mode, each with its own setup, into a folder it
# makes before the device; the reference it caches there is whole or absent. A cell that fails
# is skipped (exit 0, the others' results written), a failed reference or exact cell ends the run
# with no results. Every 4th allocation of its ~200: the paths are render's.
skip_keep="b/(bench\.(csv|json)|time_to_error\.md|builtin_default_32x32\.(gp|dat|png))$"
STRIDE=4 sweep "bench" "b$|b/reference$|b/reference/builtin_default_32x32_16spp_[0-9a-f]+\.exr$" \
  "warning: bench: linespace LS\(3,2\) skipped" \
  bench --scenes builtin:default --size 32x32 --modes linespace,exact --trees 3,2 --spp 4 --filter none \
  --repeat 1 --warmup 0 --no-embree --reference-spp 16 --out b

# --- a device smaller than lavapipe: limits the real one is too large to reach in a test
# expect_limit LABEL PATTERN ENV ARGS...: exit 1, the message, no output.
expect_limit() {
  local label=$1 pattern=$2 envs=$3; shift 3
  local dir=$TMP/limit err rc
  rm -rf "$dir" && mkdir -p "$dir"
  err=$(cd "$dir" && env $envs "$BIN" "$@" 2>&1 >/dev/null); rc=$?
  if [ "$rc" -ne 1 ] || ! grep -qE -- "$pattern" <<<"$err" || grep -qE 'Sanitizer|runtime error' <<<"$err" ||
    [ -n "$(ls -A "$dir")" ]; then
    echo "FAIL: $label: exit $rc (expected 1 and /$pattern/, no output): $envs penumbra $*"
    echo "$err" | tail -n 10 | sed 's/^/    /'
    fail=1
    return
  fi
  echo "ok: $label: $(grep -E 'error' <<<"$err" | head -n 1)"
}
L=(render "$BUNNY" --size 32x32 -o out.exr)
expect_limit "exact, 1 MiB allocations" 'the triangle pool needs [0-9.]+ MiB, more than one allocation of this device can hold \(1\.0 MiB\)' \
  PN_FAULT_MAX_ALLOC=1M "${L[@]}" --mode exact
expect_limit "exact-ls, 1 MiB allocations" 'the triangle pool needs [0-9.]+ MiB, more than one allocation of this device can hold \(1\.0 MiB\)' \
  PN_FAULT_MAX_ALLOC=1M "${L[@]}" --mode exact-ls --tree 3,2 --no-view-cull
expect_limit "linespace, 256 KiB allocations" 'LS\(7,3\) needs a pool of at least [0-9.]+ MiB .*more than one buffer of this device can hold \(0\.2 MiB\)' \
  PN_FAULT_MAX_ALLOC=256K "${L[@]}" --mode linespace --no-view-cull
expect_limit "linespace --trees object, 256 KiB allocations" 'LS\(7,3\) needs a pool of at least [0-9.]+ MiB .*more than one buffer of this device can hold \(0\.2 MiB\)' \
  PN_FAULT_MAX_ALLOC=256K "${L[@]}" --mode linespace --trees object
if [ "$rq" -gt 0 ]; then
  expect_limit "rayquery, 1 MiB buffers" "the acceleration structure's triangles needs [0-9.]+ MiB, more than one buffer of this device can hold \(maxBufferSize 1\.0 MiB\)" \
    PN_FAULT_MAX_ALLOC=1M "${L[@]}" --mode rayquery
  expect_limit "rayquery, 3 MiB buffers" "the bottom-level acceleration structure of [0-9]+ primitives needs [0-9.]+ MiB \(build scratch [0-9.]+ MiB\), more than one buffer of this device can hold \(3\.0 MiB\)" \
    PN_FAULT_MAX_ALLOC=3M "${L[@]}" --mode rayquery
fi
expect_limit "ray dump, 64 MiB buffers" 'the ray dump needs [0-9.]+ MiB, more than one buffer of this device can hold \(maxBufferSize 64\.0 MiB\)' \
  PN_FAULT_MAX_ALLOC=64M render builtin:default --size 256x256 --spp 64 --ray-dump rays.bin -o out.exr
# --max-memory above a 16 MiB heap: the tree passes its budget, the upload finds the heap full.
expect_limit "linespace --max-memory over a 16 MiB heap" 'out of device memory allocating the [a-z -]+ pool \([0-9.]+ (MiB|KiB|bytes); [0-9.]+ MiB already held, device-local heap 16\.0 MiB\)' \
  PN_FAULT_HEAP=16M "${L[@]}" --mode linespace --tree 7,3 --max-memory 1G --no-view-cull
# The default budget is half the heap: the tree is refused before it is built in full.
expect_limit "linespace, default budget of a 16 MiB heap" 'LS\(7,4\) needs (at least )?[0-9.]+ MiB of pools .* over the limit of 8\.0 MiB' \
  PN_FAULT_HEAP=16M "${L[@]}" --mode linespace --tree 7,4 --no-view-cull

echo "$runs failing runs checked in $SECONDS s"
exit $fail
