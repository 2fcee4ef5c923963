#!/usr/bin/env bash
# --quality auto judges a filtered configuration at the frame's own size (shadow/quality.c,
# frame_sample): a filter averages over the frame's pixels, and a pilot with wider pixels measures
# more error than the frame has. builtin:default at 384x288, 2.6 times the pilot's width and height
# (148x111, about 128x128 pixels), with render's default filter (penumbra), at a budget of 0.005:
#  - every filtered pilot's error was confirmed at the frame (confirm_at "frame"), over one pixel
#    per pilot pixel (frame_sample: the pilot's size), and no unfiltered one's;
#  - each of exact's confirming MAEs is the frame's: the same configuration rendered here at
#    384x288 and diffed against the converged reference lies within 4 of the sample's standard
#    errors of it, plus the references' own part: the confirming reference (over the sampled
#    pixels) and this one are independent, and a pixel's |V - ref| moves by at most |ref - ref'|,
#    so by the mean difference of two independent references (measured here with a second one at
#    another seed) and 4 standard errors of that mean;
#  - the pick holds at full size, and is what the rule makes of the run's times (quality_rule.py).
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/quality_filtered
rm -rf "$T" && mkdir -p "$T"
common=(builtin:default --size 384x288 --seed 5)
budget=0.005
# PN_REFERENCE_SPP and PN_REFERENCE_SEED (0x2c5e7f1), as the pilots use them; the second at another seed.
"$BIN" render "${common[@]}" --mode exact --spp 1024 --filter none --seed 46524401 -o "$T/reference.exr" >/dev/null \
  && "$BIN" render "${common[@]}" --mode exact --spp 1024 --filter none --seed 77 -o "$T/reference2.exr" >/dev/null \
  || { echo "FAIL: reference renders"; exit 1; }
"$BIN" diff "$T/reference.exr" "$T/reference2.exr" --json > "$T/refs.json" || { echo "FAIL: diff of the references"; exit 1; }
"$BIN" render "${common[@]}" --quality auto --max-error $budget --json -o "$T/auto.exr" > "$T/auto.json" 2> "$T/auto.err" \
  || { echo "FAIL: auto render"; tail -5 "$T/auto.err"; exit 1; }
"$BIN" diff "$T/reference.exr" "$T/auto.exr" --json > "$T/diff.json" || { echo "FAIL: diff"; exit 1; }
# exact's filtered pilots, rendered at the frame's size.
python3 - "$T/auto.json" > "$T/exact_filtered.txt" <<'PY' || { echo "FAIL: reading the run"; exit 1; }
import json, sys
for t in json.load(open(sys.argv[1]))["quality"]["tried"]:
    if t["mode"] == "exact" and t["filter"] == "penumbra":
        print("%d:%d" % (t["spp_min"], t["spp"]) if t["spp_min"] else t["spp"], "%.9g" % t["pixel_error"])
PY
[ -s "$T/exact_filtered.txt" ] || { echo "FAIL: exact climbed no filtered samples"; exit 1; }
k=0
while read -r spp e; do
  "$BIN" render "${common[@]}" --mode exact --spp "$spp" --pixel-error "$e" --filter penumbra -o "$T/exact_$k.exr" \
    >/dev/null && "$BIN" diff "$T/reference.exr" "$T/exact_$k.exr" --json > "$T/exact_$k.json" \
    || { echo "FAIL: exact $spp"; exit 1; }
  k=$((k + 1))
done < "$T/exact_filtered.txt"
TESTS=$(dirname "$0") python3 - "$budget" "$T" <<'PY'
import json, math, os, sys
sys.path.insert(0, os.environ["TESTS"])
import quality_rule
budget, T = float(sys.argv[1]), sys.argv[2]
run = json.load(open(T + "/auto.json"))
q = run["quality"]
tried = q["tried"]
assert q["pilot"] == [148, 111] and q["frame_sample"] == q["pilot"], (q["pilot"], q["frame_sample"])
for t in tried:
    assert (t["confirm_at"] == "frame") == (t["filter"] != "none"), t
refs = json.load(open(T + "/refs.json"))
# The mean |ref - ref'| over the covered pixels, and its standard error as a mean of them.
ref_mean = refs["mae"]
ref_se = math.sqrt(max(refs["rmse"] ** 2 - refs["mae"] ** 2, 0.0) / refs["pixels"])
exact = [t for t in tried if t["mode"] == "exact" and t["filter"] == "penumbra"]
for k, t in enumerate(exact):
    full = json.load(open("%s/exact_%d.json" % (T, k)))["mae"]
    bound = 4 * t["confirm_se"] + ref_mean + 4 * ref_se
    print("exact %s%d spp penumbra: at the frame's sampled pixels %.5f +- %.5f, the frame %.5f (|d| %.5f, bound %.5f); pilot %.5f"
          % ("%d:" % t["spp_min"] if t["spp_min"] else "", t["spp"], t["confirm_mae"], t["confirm_se"], full,
             abs(t["confirm_mae"] - full), bound, t["pilot_mae"]))
    assert abs(t["confirm_mae"] - full) <= bound, (t, full, bound)
d = json.load(open(T + "/diff.json"))
print("chose %s %s %s%d spp, filter %s: full MAE %.5f" % (run["mode"], run["tree"],
      "%d:" % run["spp_min"] if "spp_min" in run else "", run["spp"], run["filter"], d["mae"]))
assert q["within"] and d["mae"] <= budget, (q, d["mae"])
quality_rule.check(tried, run, q["runoff"], q["candidates"], budget)
PY
