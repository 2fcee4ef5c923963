#!/usr/bin/env bash
# Set-up and the whole test suite: installs what is missing, builds, runs ctest. Every GPU test
# runs on lavapipe with the Khronos validation layer and synchronization validation on.
# Then the tests labelled `sanitize` (the fast tier, which runs every module, and the fault
# injection) again in a second build with AddressSanitizer and UndefinedBehaviorSanitizer (clang,
# build-asan/, with device-allocation faults injected), which must report nothing; then the
# libFuzzer targets (clang, build-fuzz/, the same sanitizers and libFuzzer's coverage
# instrumentation, the targets alone) replay their corpora and each fuzzes for a bounded time,
# two at a time, the last beside a build with ThreadSanitizer (clang, build-tsan/, the penumbra
# executable alone) and its one test, a scripted demo session with tree builds on the worker
# thread (tests/demo_tsan.sh), which must report nothing. (The fuzzers' instrumentation is a build of its own because it doubles the time
# of instrumented code: a tree build of the bunny at LS(7,3) took 4.4 s under it, 2.2 s without,
# 0.85 s plain; the tests need the sanitizers, not the fuzzers' counters. Issue 62.)
# Arguments go to the first two ctest runs (e.g. -R hostile). Environment:
#   PN_SANITIZERS=0     skip the sanitizer builds, their tests and the fuzzing
#   PN_FUZZ_SECONDS=N   fuzzing time per target (default 60; 0 skips fuzzing); five targets,
#                       two at a time: the step takes about 3 x N seconds
#   PN_COVERAGE=1       instead of the suite, line coverage of engine/ per stage (ci/coverage.sh)
# How the sanitizer run is set up, and why: tests/sanitizers.md.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "${PN_COVERAGE:-0}" = 1 ] && exec ./ci/coverage.sh
./ci/build.sh
step() { echo "== $1 ($(date +%T))"; }
t0=$SECONDS
step "tests"
(cd build && ctest --output-on-failure --timeout 1800 -j"$(nproc)" "$@")
echo "== tests: $((SECONDS - t0)) s"
[ "${PN_SANITIZERS:-1}" = 0 ] && exit 0

t0=$SECONDS
step "sanitizer build (build-asan/, clang, -fsanitize=address,undefined, fault injection)"
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DPN_SANITIZE=ON -DPN_FUZZ=OFF -DPN_FAULT_INJECTION=ON >/dev/null
cmake --build build-asan --parallel "$(nproc)"
echo "== sanitizer build: $((SECONDS - t0)) s"

t0=$SECONDS
step "tests under the sanitizers (label sanitize: the fast tier, the fault injection)"
# What covers the code, at small sizes: the long statistical tests and sweeps run in the plain pass
# alone (tests/CMakeLists.txt, tests/README.md).
(cd build-asan && ctest --output-on-failure --timeout 1800 -j"$(nproc)" -L sanitize "$@")
echo "== tests under the sanitizers: $((SECONDS - t0)) s"

# The ThreadSanitizer stage, which the fuzzing's last round (one target, one core) runs beside.
tsan_stage() {
  local t0=$SECONDS
  step "ThreadSanitizer build (build-tsan/, clang, -fsanitize=thread, penumbra alone)"
  # (called where set -e does not reach into it: each step's failure returns)
  cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
    -DPN_TSAN=ON >/dev/null || return 1
  cmake --build build-tsan --parallel "$(nproc)" || return 1
  echo "== ThreadSanitizer build: $((SECONDS - t0)) s"
  t0=$SECONDS
  step "the demo under ThreadSanitizer"
  # Every other test is registered there but disabled (its program is not built): ctest runs demo_tsan.
  (cd build-tsan && ctest --output-on-failure --timeout 1800) || return 1
  echo "== the demo under ThreadSanitizer: $((SECONDS - t0)) s"
}

t0=$SECONDS
step "fuzzer build (build-fuzz/, clang, -fsanitize=address,undefined,fuzzer-no-link, the libFuzzer targets)"
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DPN_SANITIZE=ON -DPN_FUZZ=ON -DPN_FAULT_INJECTION=ON >/dev/null
fuzz_targets=(fuzz_scene fuzz_cli fuzz_exr fuzz_script fuzz_api)
cmake --build build-fuzz --parallel "$(nproc)" --target "${fuzz_targets[@]}" pn_san_pin
echo "== fuzzer build: $((SECONDS - t0)) s"
t0=$SECONDS
step "the fuzzers' corpora, replayed"
(cd build-fuzz && ctest --output-on-failure --timeout 1800 -j"$(nproc)" -R '^fuzz_[a-z]+_corpus$')
echo "== the fuzzers' corpora: $((SECONDS - t0)) s"

seconds=${PN_FUZZ_SECONDS:-60}
if [ "$seconds" -le 0 ]; then
  tsan_stage
  exit 0
fi
t0=$SECONDS
step "fuzzing, ${seconds} s per target (the last beside the ThreadSanitizer stage)"
# Five targets on two cores: two at a time, one core each; the fifth beside the ThreadSanitizer
# build and demo (about 45 s), so the step takes about 3 x seconds, that stage included.
# New inputs go to build-fuzz/fuzz/<target>/new, never into the corpus in tests/fuzz; a crash
# leaves its input in build-fuzz/fuzz/<target>/ as crash-*.
dict_of() {
  case $1 in
    scene) echo tests/fuzz/gltf.dict ;;
    *) echo "tests/fuzz/$1.dict" ;;
  esac
}
status=0
for pair in "scene cli" "exr script" "api"; do
  read -r -a targets <<<"$pair"
  pids=()
  for target in "${targets[@]}"; do
    dir=build-fuzz/fuzz/$target
    mkdir -p "$dir/new"
    build-fuzz/tests/fuzz/fuzz_$target -max_total_time="$seconds" -timeout=20 -rss_limit_mb=3072 \
      -dict="$(dict_of "$target")" -artifact_prefix="$dir/" -print_final_stats=1 "$dir/new" \
      "tests/fuzz/corpus_$target" >"$dir/log.txt" 2>&1 &
    pids+=($!)
  done
  tsan_status=0
  if [ ${#targets[@]} -eq 1 ]; then
    tsan_stage || tsan_status=$?
  fi
  for i in "${!targets[@]}"; do
    target=${targets[$i]}
    if wait "${pids[$i]}"; then
      echo "fuzz_$target: $(grep -E '^Done [0-9]+ runs' "build-fuzz/fuzz/$target/log.txt"), no crash"
    else
      status=1
      echo "FAIL: fuzz_$target found a crash: build-fuzz/fuzz/$target/log.txt ends with"
      tail -n 40 "build-fuzz/fuzz/$target/log.txt"
      echo "Reproduce with build-fuzz/tests/fuzz/fuzz_$target <crash file>; once fixed, add the file to"
      echo "tests/fuzz/corpus_$target/ as regress_<what>, so that ctest replays it (tests/sanitizers.md)."
    fi
  done
  if [ "$tsan_status" -ne 0 ]; then
    echo "FAIL: the ThreadSanitizer stage exited $tsan_status"
    status=1
  fi
done
echo "== fuzzing and the ThreadSanitizer stage: $((SECONDS - t0)) s"
exit $status
