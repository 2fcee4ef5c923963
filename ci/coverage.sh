#!/usr/bin/env bash
# Line coverage of engine/ per stage of ci/test.sh (PN_COVERAGE=1 ./ci/test.sh runs this instead of
# the suite; not part of every run). One build with gcc --coverage and the fault injection on
# (build-cov/), the suite run once in two groups without resetting the counters in between:
#   sanitize: the tests the sanitizer pass runs (label sanitize), measured after the first group;
#   plain:    every test (the rest added), measured after the second;
# then, with PN_COV_FUZZ_SECONDS > 0 (default 60), the fuzzers: a clang build with --coverage and
# libFuzzer (build-cov-fuzz/), each target for that long from its corpus, as ci/test.sh fuzzes.
# Output: $PN_COV_OUT (default build-cov/coverage)/<stage>.json (gcovr's JSON, lines per file) and
# <stage>.txt (gcovr's summary per file). tests/coverage_compare.py compares two stages' files.
# For another tree (an earlier commit): PN_COV_SOURCE=path; its groups by PN_COV_FIRST and
# PN_COV_REST (ctest arguments; default -L sanitize and -LE sanitize).
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
src=$(cd "${PN_COV_SOURCE:-.}" && pwd)
out=${PN_COV_OUT:-$src/build-cov/coverage}
read -r -a first <<<"${PN_COV_FIRST:--L sanitize}"
read -r -a rest <<<"${PN_COV_REST:--LE sanitize}"
fuzz_seconds=${PN_COV_FUZZ_SECONDS:-60}
"$repo/ci/deps.sh"
step() { echo "== $1 ($(date +%T))"; }
mkdir -p "$out"
out=$(cd "$out" && pwd)
# Atomic counters: the tree builds' threads update the same counters, and plain increments race
# (gcov then reads negative counts, which gcovr refuses).
cov_flags=("-DCMAKE_C_FLAGS=--coverage -fprofile-update=atomic" "-DCMAKE_CXX_FLAGS=--coverage -fprofile-update=atomic"
  -DCMAKE_EXE_LINKER_FLAGS=--coverage -DCMAKE_SHARED_LINKER_FLAGS=--coverage)

step "coverage build ($src/build-cov, gcc --coverage, fault injection)"
cmake -S "$src" -B "$src/build-cov" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPN_FAULT_INJECTION=ON "${cov_flags[@]}" >/dev/null
cmake --build "$src/build-cov" --parallel "$(nproc)"
find "$src/build-cov" -name '*.gcda' -delete
report() { # report <stage> <object directory> [gcovr arguments]
  local name=$1 objects=$2
  shift 2
  (cd "$src" && gcovr -r . --object-directory "$objects" --filter 'engine/' --gcov-ignore-parse-errors "$@" \
    --json "$out/$name.json" \
    --txt "$out/$name.txt" --print-summary) | tail -n 2
}
status=0
step "coverage: the sanitizer pass's tests (${first[*]})"
(cd "$src/build-cov" && ctest --timeout 1800 -j"$(nproc)" "${first[@]}") >"$out/sanitize.log" 2>&1 || status=1
tail -n 3 "$out/sanitize.log"
report sanitize "$src/build-cov"
step "coverage: the rest of the plain pass (${rest[*]})"
(cd "$src/build-cov" && ctest --timeout 1800 -j"$(nproc)" "${rest[@]}") >"$out/plain.log" 2>&1 || status=1
tail -n 3 "$out/plain.log"
report plain "$src/build-cov"

if [ "$fuzz_seconds" -gt 0 ]; then
  step "fuzzer coverage build ($src/build-cov-fuzz, clang --coverage, libFuzzer)"
  cmake -S "$src" -B "$src/build-cov-fuzz" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
    -DCMAKE_CXX_COMPILER=clang++ -DPN_FUZZ=ON "${cov_flags[@]}" >/dev/null
  cmake --build "$src/build-cov-fuzz" --parallel "$(nproc)" --target fuzz_scene fuzz_cli fuzz_exr fuzz_script fuzz_api
  find "$src/build-cov-fuzz" -name '*.gcda' -delete
  step "coverage: each fuzzer for $fuzz_seconds s from its corpus"
  for target in scene cli exr script api; do
    dict=$src/tests/fuzz/$target.dict
    [ "$target" = scene ] && dict=$src/tests/fuzz/gltf.dict
    dir=$src/build-cov-fuzz/fuzz/$target
    mkdir -p "$dir/new"
    "$src/build-cov-fuzz/tests/fuzz/fuzz_$target" -max_total_time="$fuzz_seconds" -timeout=20 -rss_limit_mb=3072 \
      -dict="$dict" -artifact_prefix="$dir/" "$dir/new" "$src/tests/fuzz/corpus_$target" >"$dir/log.txt" 2>&1 ||
      { echo "fuzz_$target stopped: $dir/log.txt"; status=1; }
  done
  gcov=$(command -v llvm-cov-14 || command -v llvm-cov)
  report fuzz "$src/build-cov-fuzz" --gcov-executable "$gcov gcov"
fi
exit $status
