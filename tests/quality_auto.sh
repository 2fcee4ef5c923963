#!/usr/bin/env bash
# --quality auto picks a configuration whose error against exact fits the budget:
#  - with --max-error 0 it must pick an exact configuration (exact, exact-ls or rayquery): the full render then
#    equals exact, MAE 0;
#  - with --max-error 0.02 its pilot error (a quarter of the pixels) is within the budget, and the full
#    render's MAE against exact is within 1.5x the budget: the pilot estimates the MAE from a
#    quarter of the pixels, which the 1.5 allows for (measured here: pilot and full MAE agree to a
#    few percent);
#  - at every budget the pick is the fastest of the pilots it reports (exact included) whose error
#    is within the budget, and at 0.02 at least one line-space configuration is within it. Which
#    one is fastest depends on the driver: on Mesa 25's lavapipe exact beats line space on this
#    small scene, on Mesa 22.3 it does not.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/quality_auto
rm -rf "$T" && mkdir -p "$T"
common=(builtin:default --size 128x96 --spp 16 --seed 5)
"$BIN" render "${common[@]}" --mode exact -o "$T/exact.exr" >/dev/null || { echo "FAIL: exact render"; exit 1; }
fail=0
for budget in 0 0.02; do
  "$BIN" render "${common[@]}" --quality auto --max-error $budget --json -o "$T/auto_$budget.exr" > "$T/auto_$budget.json" \
    || { echo "FAIL: auto render ($budget)"; fail=1; continue; }
  "$BIN" diff "$T/exact.exr" "$T/auto_$budget.exr" --json > "$T/diff_$budget.json" || { echo "FAIL: diff"; fail=1; continue; }
  python3 - "$budget" "$T/auto_$budget.json" "$T/diff_$budget.json" <<'PY' || fail=1
import json, sys
budget = float(sys.argv[1]); run = json.load(open(sys.argv[2])); d = json.load(open(sys.argv[3]))
q = run["quality"]
print("budget %g: chose %s %s, pilot MAE %.5f, full MAE %.5f, pilot shadow %.1f ms vs exact %.1f ms"
      % (budget, run["mode"], run["tree"], q["pilot_mae"], d["mae"], q["pilot_shadow_ms"], q["pilot_exact_ms"]))
assert q["pilot_mae"] <= budget, q
if budget == 0:
    assert run["mode"] in ("exact", "exact-ls", "rayquery"), run["mode"]
    assert d["max"] == 0, d
else:
    assert d["mae"] <= 1.5 * budget, d
    assert any(t["pilot_mae"] <= budget for t in q["tried"]), q["tried"]
fits = [("exact", None, q["pilot_exact_ms"])] + [
    (t["mode"], t["tree"], t["pilot_shadow_ms"]) for t in q["tried"] if t["pilot_mae"] <= budget]
best = min(fits, key=lambda f: f[2])
assert q["candidates"] == len(q["tried"]) and q["candidates"] >= 9, q
assert (run["mode"], run["tree"]) == best[:2], (run["mode"], run["tree"], best)
assert q["pilot_shadow_ms"] == best[2], (q, best)
PY
done
exit $fail
