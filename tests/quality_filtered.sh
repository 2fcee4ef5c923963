#!/usr/bin/env bash
# --quality auto judges a filtered configuration at the frame's own size (shadow/quality.c,
# frame_sample): a filter averages over the frame's pixels, and a pilot with wider pixels measures
# more error than the frame has. builtin:default at 384x288, 2.6 times the pilot's width and height
# (148x111, about 128x128 pixels), with render's default filter (penumbra), at a budget of 0.002:
# tight enough that exact's own filtered climb (climbed first, quality.c: climb_order) has steps the
# bound judges outside, whatever the pilots' times (at 0.005 exact's pick ended every other mode's
# climb at its first step, so no pilot met the bound where exact's 2 spp was fast enough):
#  - every filtered pilot's error was confirmed at the frame (confirm_at "frame"), over one pixel
#    per pilot pixel (frame_sample: the pilot's size), or judged outside by the frame's error its
#    pilot's predicts ("bound", after the configuration's first frame), and no unfiltered one's;
#  - each of exact's confirming MAEs is the frame's: the same configuration rendered here at
#    384x288 and diffed against the converged reference lies within 4 of the sample's standard
#    errors of it, plus the references' own part: the confirming reference (over the sampled
#    pixels) and this one are independent, and a pixel's |V - ref| moves by at most |ref - ref'|,
#    so by the mean difference of two independent references (measured here with a second one at
#    another seed) and 4 standard errors of that mean;
#    where the bound judged one of exact's or LS(7,3) line space's outside, the frame's MAE (rendered
#    here) is over the budget (exact's 4 spp: .00243 predicted, the frame .00228);
#  - the pick holds at full size, and is what the rule makes of the run's times (quality_rule.py).
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/quality_filtered
rm -rf "$T" && mkdir -p "$T"
common=(builtin:default --size 384x288 --seed 5)
budget=0.002
# PN_REFERENCE_SPP and PN_REFERENCE_SEED (0x2c5e7f1), as the pilots use them; the second at another seed.
"$BIN" render "${common[@]}" --mode exact --spp 1024 --filter none --seed 46524401 -o "$T/reference.exr" >/dev/null \
  && "$BIN" render "${common[@]}" --mode exact --spp 1024 --filter none --seed 77 -o "$T/reference2.exr" >/dev/null \
  || { echo "FAIL: reference renders"; exit 1; }
"$BIN" diff "$T/reference.exr" "$T/reference2.exr" --json > "$T/refs.json" || { echo "FAIL: diff of the references"; exit 1; }
"$BIN" render "${common[@]}" --quality auto --max-error $budget --json -o "$T/auto.exr" > "$T/auto.json" 2> "$T/auto.err" \
  || { echo "FAIL: auto render"; tail -5 "$T/auto.err"; exit 1; }
"$BIN" diff "$T/reference.exr" "$T/auto.exr" --json > "$T/diff.json" || { echo "FAIL: diff"; exit 1; }
# exact's filtered pilots, and those of LS(7,3) line space the bound judged, rendered at the frame's size.
python3 - "$T/auto.json" "$T/checked.json" > "$T/checked.txt" <<'PY' || { echo "FAIL: reading the run"; exit 1; }
import json, sys
checked = [t for t in json.load(open(sys.argv[1]))["quality"]["tried"] if t["filter"] == "penumbra" and
           (t["mode"] == "exact" or (t["mode"] == "linespace" and t["tree"] == [7, 3] and t["confirm_at"] == "bound"))]
json.dump(checked, open(sys.argv[2], "w"))
for t in checked:
    spp = "%d:%d" % (t["spp_min"], t["spp"]) if t["spp_min"] else str(t["spp"])
    print(t["mode"], ",".join(map(str, t["tree"])) if t["tree"] else "-", spp, "%.9g" % t["pixel_error"])
PY
grep -q "^exact " "$T/checked.txt" || { echo "FAIL: exact climbed no filtered samples"; exit 1; }
k=0
while read -r mode tree spp e; do
  tree_arg=()
  [ "$tree" = - ] || tree_arg=(--tree "$tree")
  "$BIN" render "${common[@]}" --mode "$mode" "${tree_arg[@]}" --spp "$spp" --pixel-error "$e" --filter penumbra \
    -o "$T/checked_$k.exr" >/dev/null \
    && "$BIN" diff "$T/reference.exr" "$T/checked_$k.exr" --json > "$T/checked_$k.json" \
    || { echo "FAIL: $mode $tree $spp"; exit 1; }
  k=$((k + 1))
done < "$T/checked.txt"
TESTS=$(dirname "$0") python3 - "$budget" "$T" <<'PY'
import json, math, os, sys
sys.path.insert(0, os.environ["TESTS"])
import quality_rule
budget, T = float(sys.argv[1]), sys.argv[2]
run = json.load(open(T + "/auto.json"))
q = run["quality"]
tried = q["tried"]
assert q["pilot"] == [148, 111] and q["frame_sample"] == q["pilot"], (q["pilot"], q["frame_sample"])
first = {}
for i, t in enumerate(tried):
    assert (t["confirm_at"] in ("frame", "bound")) == (t["filter"] != "none"), t
    config = (t["mode"], str(t["tree"]))
    if t["filter"] != "none":
        first.setdefault(config, t)
        assert first[config]["confirm_at"] == "frame", (first[config], t)   # the first measures the share
    if t["confirm_at"] == "bound":
        assert not t["within"] and t["confirm_mae"] > budget, t
refs = json.load(open(T + "/refs.json"))
# The mean |ref - ref'| over the covered pixels, and its standard error as a mean of them.
ref_mean = refs["mae"]
ref_se = math.sqrt(max(refs["rmse"] ** 2 - refs["mae"] ** 2, 0.0) / refs["pixels"])
bounded = 0
for k, t in enumerate(json.load(open(T + "/checked.json"))):
    full = json.load(open("%s/checked_%d.json" % (T, k)))["mae"]
    name = "%s %s %s%d spp penumbra" % (t["mode"], t["tree"], "%d:" % t["spp_min"] if t["spp_min"] else "", t["spp"])
    if t["confirm_at"] == "bound":
        print("%s: outside by the bound (%.5f predicted), the frame %.5f" % (name, t["confirm_mae"], full))
        assert full > budget, (t, full)
        bounded += 1
        continue
    bound = 4 * t["confirm_se"] + ref_mean + 4 * ref_se
    print("%s: at the frame's sampled pixels %.5f +- %.5f, the frame %.5f (|d| %.5f, bound %.5f); pilot %.5f"
          % (name, t["confirm_mae"], t["confirm_se"], full, abs(t["confirm_mae"] - full), bound, t["pilot_mae"]))
    assert abs(t["confirm_mae"] - full) <= bound, (t, full, bound)
assert bounded > 0, "no pilot judged by the bound was checked"
d = json.load(open(T + "/diff.json"))
print("chose %s %s %s%d spp, filter %s: full MAE %.5f" % (run["mode"], run["tree"],
      "%d:" % run["spp_min"] if "spp_min" in run else "", run["spp"], run["filter"], d["mae"]))
assert q["within"] and d["mae"] <= budget, (q, d["mae"])
quality_rule.check(tried, run, q["runoff"], q["candidates"], budget)
PY
