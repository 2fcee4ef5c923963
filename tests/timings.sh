#!/usr/bin/env bash
# The suite's time per test with Mesa's shader cache empty (cold) and as that run left it (warm),
# and the pipelines each test created: the table in tests/README.md.
#
#   tests/timings.sh run BUILD [ctest args...]   # e.g. run build, or run build-asan -L sanitize
#   tests/timings.sh table BUILD [BUILD...]       # the markdown table of the runs made
#
# `run` points MESA_SHADER_CACHE_DIR at a new folder (BUILD/timings/cache), runs ctest there twice
# (-j$(nproc), as ci/test.sh does) and keeps each run's JUnit report and each test's pipeline log
# (PN_PIPELINE_LOG: one line per pipeline created, its creation time in ms) in BUILD/timings/.
# `table` prints, per test, its seconds cold and warm in each build given, the pipelines it created
# cold (all of them; distinct variants in parentheses) and their creation's milliseconds, slowest
# (cold, first build) first, with the stages' totals. A test's pipelines are counted from the
# first build given (the sanitizer build's lavapipe is the same).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
cmd=${1:-}
shift || true
case $cmd in
  run)
    build=$(cd "${1:?tests/timings.sh run BUILD [ctest args]}" && pwd)
    shift
    out=$build/timings
    rm -rf "$out"
    mkdir -p "$out/cache"
    for pass in cold warm; do
      rm -rf "$build/tests/tmp/pipelines"
      mkdir -p "$build/tests/tmp/pipelines"
      t0=$SECONDS
      # A failing test is reported in the table (its time stands); the run goes on.
      (cd "$build" && MESA_SHADER_CACHE_DIR="$out/cache" ctest --timeout 1800 -j"$(nproc)" \
        --output-junit "$out/$pass.xml" "$@") >"$out/$pass.txt" 2>&1 || true
      echo "$pass: $((SECONDS - t0)) s ($(grep -E 'tests passed' "$out/$pass.txt" || echo 'no summary'))"
      cp -r "$build/tests/tmp/pipelines" "$out/pipelines-$pass"
    done
    ;;
  table)
    [ $# -ge 1 ] || { echo "tests/timings.sh table BUILD [BUILD...]" >&2; exit 2; }
    python3 - "$@" <<'PY'
import os, sys, xml.etree.ElementTree as ET
builds = sys.argv[1:]
def times(b, p):
    f = os.path.join(b, "timings", p + ".xml")
    if not os.path.exists(f):
        return {}
    return {t.get("name"): float(t.get("time")) for t in ET.parse(f).getroot().iter("testcase")}
def pipelines(b, t):
    f = os.path.join(b, "timings", "pipelines-cold", t + ".log")
    if not os.path.exists(f):
        return 0, 0, 0.0
    rows = [l.split() for l in open(f) if l.strip()]
    made = [r for r in rows if r[0] != "first-use"]  # first-use: a warm-up pass, where llvmpipe compiles
    return len(made), len({r[1] for r in made}), sum(float(r[3]) for r in rows)
cols = [(b, times(b, "cold"), times(b, "warm")) for b in builds]
names = sorted(set().union(*[c[1].keys() for c in cols]), key=lambda n: -cols[0][1].get(n, 0))
head = "| test |" + "".join(" %s cold s | %s warm s |" % (os.path.basename(b.rstrip("/")), os.path.basename(b.rstrip("/"))) for b in builds)
print(head + " pipelines cold (variants) | their creation and first use ms |")
print("|---|" + "---:|---:|" * len(builds) + "---:|---:|")
f = lambda v: "%.0f" % v if v is not None else "-"
for n in names:
    made, variants, ms = pipelines(builds[0], n)
    print("| %s |" % n + "".join(" %s | %s |" % (f(c.get(n)), f(w.get(n))) for _, c, w in cols) +
          " %d (%d) | %.0f |" % (made, variants, ms))
print("| **sum** |" + "".join(" %.0f | %.0f |" % (sum(c.values()), sum(w.values())) for _, c, w in cols) + " | |")
PY
    ;;
  *)
    sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
