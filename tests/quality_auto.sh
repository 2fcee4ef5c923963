#!/usr/bin/env bash
# --quality auto picks mode, tree and samples per pixel against the converged reference (exact at
# 1024 spp with its own seed, shadow/metrics.h):
#  - at budgets 0.05 and 0.02 the frame (128x96) is its own pilot, so the pick's pilot error is the
#    render's error: the full render, diffed against the same reference rendered here, has the
#    MAE the pilot reported, within the budget;
#  - the pick is within the budget and is what the rule makes of the times the run reported
#    (tests/quality_rule.py: of the pilots within it, the fastest; or, where several were within
#    1.5x of the fastest pilot's time, the fastest of those, at most 4, timed again side by side at
#    the frame's size); which configuration wins is the machine's, the rule is checked exactly;
#  - every configuration's pilots climb 1, 2, 4, ... samples per pixel and the climb ends for a
#    reason (within the budget, slower than the pick, or a biased mode's error no longer falling),
#    and line space stops before 256 spp;
#  - adaptive samples (4:256 down a ladder of pixel errors) are climbed by the configurations the
#    rule names, and at 0.005 by exact at least; with render's default filter (penumbra) every
#    configuration climbs its uniform samples filtered too, then adaptive samples under the filter
#    (1:4, 2:8, ... as the rule names), and the render takes its pick's filter;
#  - an unreachable budget (0) warns and takes the least error found.
# Arguments: the budgets to try (default 0.05 0.02 0.005 0; ctest runs 0.05 as quality_auto_fast, in
# the fast tier, and the other three as quality_auto).
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/quality_auto${1:+_$1}
rm -rf "$T" && mkdir -p "$T"
common=(builtin:default --size 128x96 --seed 5)
# PN_REFERENCE_SPP and PN_REFERENCE_SEED (0x2c5e7f1), as the pilots use them.
"$BIN" render "${common[@]}" --mode exact --spp 1024 --filter none --seed 46524401 -o "$T/reference.exr" >/dev/null \
  || { echo "FAIL: reference render"; exit 1; }
fail=0
budgets=("$@")
[ ${#budgets[@]} -gt 0 ] || budgets=(0.05 0.02 0.005 0)
for budget in "${budgets[@]}"; do
  "$BIN" render "${common[@]}" --quality auto --max-error $budget --json -o "$T/auto_$budget.exr" \
    > "$T/auto_$budget.json" 2> "$T/auto_$budget.err" || { echo "FAIL: auto render ($budget)"; fail=1; continue; }
  "$BIN" diff "$T/reference.exr" "$T/auto_$budget.exr" --json > "$T/diff_$budget.json" || { echo "FAIL: diff"; fail=1; continue; }
  TESTS=$(dirname "$0") python3 - "$budget" "$T/auto_$budget.json" "$T/diff_$budget.json" "$T/auto_$budget.err" <<'PY' || fail=1
import json, os, sys
sys.path.insert(0, os.environ["TESTS"])
import quality_rule
budget = float(sys.argv[1]); run = json.load(open(sys.argv[2])); d = json.load(open(sys.argv[3]))
err = open(sys.argv[4]).read()
q = run["quality"]
print("budget %g: chose %s %s %s%d spp, filter %s, pilot MAE %.5f, full MAE %.5f, %d pilots (%d adaptive, %d filtered)"
      % (budget, run["mode"], run["tree"], "%d:" % run["spp_min"] if "spp_min" in run else "", run["spp"],
         run["filter"], q["pilot_mae"], d["mae"], q["candidates"], sum(t["spp_min"] > 0 for t in q["tried"]),
         sum(t["filter"] != "none" for t in q["tried"])))
assert q["pilot"] == [128, 96] and q["pilot_se"] == 0, q          # its own pilot
assert abs(d["mae"] - q["pilot_mae"]) < 1e-6, (d["mae"], q["pilot_mae"])
tried = q["tried"]
configs = {(t["mode"], str(t["tree"])) for t in tried}
assert ("exact", "None") in configs and any(m == "linespace" for m, _ in configs), configs
# The frame's filter is render's default (penumbra): every configuration climbs it too, and the
# render is filtered as its pick was (the rule below checks the pick's filter with the rest).
if budget > 0:
    assert any(t["filter"] == "penumbra" for t in tried) and any(t["filter"] == "none" for t in tried), tried
assert run["filter"] == q["filter"], (run["filter"], q["filter"])
# The pick is what the rule makes of the times this run reported (quality_rule.py), whichever
# configuration those times happened to favour; every climb stopped for a reason.
best = tried[quality_rule.check(tried, run, q["runoff"], q["candidates"], budget)]
assert q["pilot_shadow_ms"] == best["pilot_shadow_ms"] and q["pilot_mae"] == best["pilot_mae"], (q, best)
if budget > 0:
    assert q["within"] and q["pilot_mae"] <= budget and d["mae"] <= budget, q
    if budget == 0.005:
        # Exact's uniform climb goes past 4 samples here, so adaptive samples were tried (which
        # configurations climbed them is checked by the rule above).
        assert any(t["spp_min"] == 4 and t["mode"] == "exact" for t in tried), tried
    if budget == 0.02:
        ls = [t for t in tried if t["mode"] == "linespace" and t["tree"] == [7, 3]]
        assert ls and ls[-1]["spp"] < 256, ls                    # stopped: within, slower or at its floor
else:
    assert not q["within"] and "no configuration reaches" in err, (q, err)
    assert q["pilot_mae"] == min(t["pilot_mae"] for t in tried), q
PY
done
exit $fail
