#!/usr/bin/env bash
# --quality auto picks mode, tree and samples per pixel against the converged reference (exact at
# 1024 spp with its own seed, apps/metrics.h):
#  - at budgets 0.05 and 0.02 the frame (128x96) is its own pilot, so the pick's pilot error is the
#    render's error: the full render, diffed against the same reference rendered here, has the
#    MAE the pilot reported, within the budget;
#  - the pick is within the budget and, of the pilots within it, the fastest; or, where several
#    were within 1.5x of the fastest pilot's time, the fastest of those (at most 4, the fastest
#    pilots) timed again side by side at the frame's size (the run-off); every configuration's
#    pilots climb 1, 2, 4, ... samples per pixel;
#  - every configuration's climb ends for a reason (within the budget, slower than the pick, or a
#    biased mode's error no longer falling), and line space stops before 256 spp;
#  - an unreachable budget (0) warns and takes the least error found.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/quality_auto
rm -rf "$T" && mkdir -p "$T"
common=(builtin:default --size 128x96 --seed 5)
# PN_REFERENCE_SPP and PN_REFERENCE_SEED (0x2c5e7f1), as the pilots use them.
"$BIN" render "${common[@]}" --mode exact --spp 1024 --filter none --seed 46524401 -o "$T/reference.exr" >/dev/null \
  || { echo "FAIL: reference render"; exit 1; }
fail=0
for budget in 0.05 0.02 0; do
  "$BIN" render "${common[@]}" --quality auto --max-error $budget --json -o "$T/auto_$budget.exr" \
    > "$T/auto_$budget.json" 2> "$T/auto_$budget.err" || { echo "FAIL: auto render ($budget)"; fail=1; continue; }
  "$BIN" diff "$T/reference.exr" "$T/auto_$budget.exr" --json > "$T/diff_$budget.json" || { echo "FAIL: diff"; fail=1; continue; }
  python3 - "$budget" "$T/auto_$budget.json" "$T/diff_$budget.json" "$T/auto_$budget.err" <<'PY' || fail=1
import json, sys
budget = float(sys.argv[1]); run = json.load(open(sys.argv[2])); d = json.load(open(sys.argv[3]))
err = open(sys.argv[4]).read()
q = run["quality"]
print("budget %g: chose %s %s %d spp, pilot MAE %.5f, full MAE %.5f, %d pilots"
      % (budget, run["mode"], run["tree"], run["spp"], q["pilot_mae"], d["mae"], q["candidates"]))
assert q["pilot"] == [128, 96] and q["pilot_se"] == 0, q          # its own pilot
assert abs(d["mae"] - q["pilot_mae"]) < 1e-6, (d["mae"], q["pilot_mae"])
tried = q["tried"]
assert q["candidates"] == len(tried), q
configs = {}
for t in tried:
    configs.setdefault((t["mode"], str(t["tree"])), []).append(t["spp"])
for c, spps in configs.items():
    assert spps == [1 << i for i in range(len(spps))], (c, spps)
assert ("exact", "None") in configs and any(m == "linespace" for m, _ in configs), configs
if budget > 0:
    assert q["within"] and q["pilot_mae"] <= budget and d["mae"] <= budget, q
    fits = [t for t in tried if t["pilot_mae"] <= budget]
    fastest = min(t["pilot_shadow_ms"] for t in fits)
    near = sorted((t for t in fits if t["pilot_shadow_ms"] <= 1.5 * fastest), key=lambda t: t["pilot_shadow_ms"])[:4]
    finalists = [t for t in tried if t["final_shadow_ms"] >= 0]
    if len(near) >= 2:
        assert q["runoff"] == len(near) and sorted(map(id, finalists)) == sorted(map(id, near)), (q["runoff"], near)
        best = min(finalists, key=lambda t: t["final_shadow_ms"])
    else:
        assert q["runoff"] == len(near) and not finalists, q
        best = near[0]
    assert (run["mode"], run["tree"], run["spp"]) == (best["mode"], best["tree"], best["spp"]), (run, best)
    assert q["pilot_shadow_ms"] == best["pilot_shadow_ms"], (q, best)
    # Every configuration's climb ends for a reason: within the budget, slower than the pick, its
    # error no longer falling (biased modes only), or the last spp.
    for c, spps in configs.items():
        last = [t for t in tried if (t["mode"], str(t["tree"])) == c][-1]
        prev = [t for t in tried if (t["mode"], str(t["tree"])) == c][-2:-1]
        flat = prev and last["pilot_mae"] > 0.9 * prev[0]["pilot_mae"] and c[0] not in ("exact", "exact-ls", "rayquery")
        assert (last["within"] or last["pilot_shadow_ms"] >= fastest or flat
                or last["spp"] == 256), (c, last, q)
    if budget == 0.02:
        ls = [t for t in tried if t["mode"] == "linespace" and t["tree"] == [7, 3]]
        assert ls and ls[-1]["spp"] < 256, ls                    # stopped: within, slower or at its floor
else:
    assert not q["within"] and "no configuration reaches" in err, (q, err)
    assert q["pilot_mae"] == min(t["pilot_mae"] for t in tried), q
PY
done
exit $fail
