#!/usr/bin/env bash
# penumbra bench --shard K/N and --merge (issue 31): a small matrix (builtin:default at two sizes,
# the six modes every device runs: 48 cells) run once whole and once as three shards at the same time under GNU parallel (or as
# three background jobs when `parallel` is not installed), which share one reference cache that
# starts empty (so all three may render a reference at once: it is written under a temporary name
# and renamed). The merge must hold exactly the unsharded run's cells, in its order, with the same
# values in every column but the times (the errors are written with 17 digits, so they round-trip
# exactly); its JSON the same cells, its time-to-error table the same groups and columns, the same
# plots. Bad input: a shard out of range or malformed, --merge of an incomplete set, of two runs,
# of the same shard twice, of a folder without a partial file, of a partial file cut short: exit
# code, message, nothing in --out. A shard that fails leaves no partial file behind.
set -u
BIN=${PN_BIN:?PN_BIN not set}
T=${PN_TEST_TMP:-/tmp}/bench_shards
rm -rf "$T" && mkdir -p "$T"
# The modes are named, so that the cells do not depend on the device's ray queries and pipelines.
MODES=exact,exact-ls,hybrid,linespace,ls-leaf,ls-plane
A=(bench --scenes builtin:default --size 64x48,32x32 --spp 4,9 --trees 5,2 --modes $MODES --repeat 1 --warmup 0)
fail=0
"$BIN" "${A[@]}" --out "$T/whole" > "$T/whole.txt" 2> "$T/whole.err" \
  || { echo "FAIL: the unsharded bench exited $?"; cat "$T/whole.err"; exit 1; }
grep -q "bench: cell 48/48 done (.*), [0-9.]* s elapsed, about [0-9.]* s left" "$T/whole.err" \
  || { echo "FAIL: no progress line for the last of 48 cells"; fail=1; }
grep -q "reference rendered in [0-9.]* s" "$T/whole.err" || { echo "FAIL: no reference time line"; fail=1; }

RC="$T/reference_cache"
shard() { "$BIN" "${A[@]}" --reference-cache "$RC" --shard "$1/3" --out "$T/s$1" > "$T/s$1.txt" 2> "$T/s$1.err"; }
if command -v parallel > /dev/null; then
  export BIN T RC
  export -f shard
  A_STR=$(printf '%q ' "${A[@]}")
  export A_STR
  # The array does not cross into parallel's shells: each rebuilds it from its quoted form.
  parallel --will-cite --halt now,fail=1 'eval "A=($A_STR)"; shard {}' ::: 1 2 3 \
    || { echo "FAIL: a shard under parallel failed"; cat "$T"/s?.err; exit 1; }
else
  echo "note: GNU parallel is not installed (ci/deps.sh installs it): the three shards run as background jobs"
  pids=()
  for k in 1 2 3; do shard $k & pids+=($!); done
  for k in 1 2 3; do wait "${pids[$((k - 1))]}" || { echo "FAIL: shard $k/3 failed"; cat "$T/s$k.err"; exit 1; }; done
fi
for k in 1 2 3; do
  [ -s "$T/s$k/bench_partial.txt" ] || { echo "FAIL: shard $k wrote no partial file"; fail=1; }
done
n=$(ls "$RC"/*.exr 2> /dev/null | wc -l)
[ "$n" = 2 ] || { echo "FAIL: the shared cache holds $n references, expected one per size"; fail=1; }
ls -a "$RC" | grep -q tmp && { echo "FAIL: a temporary file was left in the cache"; fail=1; }

"$BIN" bench --merge "$T/s1" "$T/s2" "$T/s3" --out "$T/merged" > "$T/merged.txt" 2> "$T/merged.err" \
  || { echo "FAIL: --merge exited $?"; cat "$T/merged.err"; exit 1; }
for f in bench.csv bench.json time_to_error.md builtin_default_64x48.dat builtin_default_32x32.dat; do
  [ -s "$T/merged/$f" ] || { echo "FAIL: the merge wrote no $f"; fail=1; }
done
[ "$(cd "$T/whole" && ls *.dat *.gp *.png 2> /dev/null)" = "$(cd "$T/merged" && ls *.dat *.gp *.png 2> /dev/null)" ] \
  || { echo "FAIL: the merge's plots are not the unsharded run's"; fail=1; }
python3 - "$T/whole" "$T/merged" <<'PY' || fail=1
import csv, json, re, sys
whole, merged = sys.argv[1], sys.argv[2]
a = list(csv.DictReader(open(whole + "/bench.csv")))
b = list(csv.DictReader(open(merged + "/bench.csv")))
assert len(a) == 48, len(a)
assert len(a) == len(b), (len(a), len(b))
times = {c for c in a[0] if c.endswith("_ms")} | {"rays_per_s", "vs_exact", "vs_embree"}
compared = [c for c in a[0] if c not in times]
assert "ref_mae" in compared and "bias_max" in compared and "edge_share" in compared, compared
for i, (x, y) in enumerate(zip(a, b)):
    for c in compared:
        assert x[c] == y[c], ("row", i, c, x[c], y[c])
    # Times come from the shard that measured them: there, and positive.
    assert float(y["shadow_ms"]) > 0, y
def cells(d):
    j = json.load(open(d + "/bench.json"))
    key = ("scene", "width", "height", "spp", "spp_min", "mode", "tree", "filter", "tree_kind")
    return [tuple(json.dumps(r[k]) for k in key) for r in j["results"]], j
ca, ja = cells(whole)
cb, jb = cells(merged)
assert ca == cb, "bench.json: other cells"
for k in ("device", "driver", "repeat", "warmup", "seed", "filters", "tile", "views", "reference"):
    assert ja["context"][k] == jb["context"][k], k
assert [(t["scene"], t["width"], t["level"]) for t in ja["time_to_error"]] == \
       [(t["scene"], t["width"], t["level"]) for t in jb["time_to_error"]]
def heads(d):
    return [l for l in open(d + "/time_to_error.md") if l.startswith("| MAE") or l.startswith("builtin")]
ha, hb = heads(whole), heads(merged)
assert ha == hb and len(ha) == 4, (ha, hb)
PY
# The console table: the same rows (view, size, spp, mode, tree, filter) in the same order.
cols() { grep "^builtin:default " "$1" | awk '{print $1, $2, $3, $4, $5, $6}'; }
[ "$(cols "$T/whole.txt")" = "$(cols "$T/merged.txt")" ] || { echo "FAIL: the console tables differ"; fail=1; }

# Bad input: a usage error (2) and nothing written.
for s in 4/3 0/0 1/0 x/2 1 2/; do
  "$BIN" "${A[@]}" --shard "$s" --out "$T/bad" > /dev/null 2> "$T/bad.err"
  rc=$?
  [ $rc = 2 ] || { echo "FAIL: --shard $s exited $rc, expected 2"; fail=1; }
  grep -q -- "--shard" "$T/bad.err" || { echo "FAIL: --shard $s: no message naming --shard"; cat "$T/bad.err"; fail=1; }
  [ -e "$T/bad" ] && { echo "FAIL: --shard $s wrote $T/bad"; rm -rf "$T/bad"; fail=1; }
done
"$BIN" "${A[@]}" --lights 2 --shard 1/2 --out "$T/bad" > /dev/null 2> "$T/bad.err"
[ $? = 2 ] && grep -q -- "--shard: not with --lights" "$T/bad.err" || { echo "FAIL: --shard with --lights"; fail=1; }
# Another run's shard 3/3: the same cells, another seed; and one of another matrix (other samples).
"$BIN" "${A[@]}" --seed 2 --reference-cache "$RC" --shard 3/3 --out "$T/other" > /dev/null 2>&1 \
  || { echo "FAIL: the other run's shard"; fail=1; }
"$BIN" bench --scenes builtin:default --size 64x48,32x32 --spp 4 --trees 5,2 --modes $MODES --repeat 1 --warmup 0 --no-embree \
  --reference-cache "$RC" --shard 3/3 --out "$T/small" > /dev/null 2>&1 || { echo "FAIL: the small run's shard"; fail=1; }
mkdir -p "$T/empty"
bad_merge() { # expected message, then the folders
  local want=$1
  shift
  "$BIN" bench --merge "$@" --out "$T/bad" > /dev/null 2> "$T/bad.err"
  local rc=$?
  [ $rc != 0 ] || { echo "FAIL: --merge $* succeeded"; fail=1; }
  grep -q -- "$want" "$T/bad.err" || { echo "FAIL: --merge $*: no message '$want'"; cat "$T/bad.err"; fail=1; }
  [ -e "$T/bad" ] && { echo "FAIL: --merge $* wrote $T/bad"; rm -rf "$T/bad"; fail=1; }
}
bad_merge "shard 2/3 missing" "$T/s1" "$T/s3"
bad_merge "shards of different runs: 'opt seed 1' against 'opt seed 2'" "$T/s1" "$T/s2" "$T/other"
bad_merge "is shard 3/3 of 24 cells, .* shard 1/3 of 48: not shards of one run" "$T/s1" "$T/s2" "$T/small"
bad_merge "are both shard 1/3" "$T/s1" "$T/s1" "$T/s2" "$T/s3"
bad_merge "no bench_partial.txt" "$T/s1" "$T/s2" "$T/empty"
bad_merge "no shard folders"
# A partial file cut short (a shard that died while writing it would leave none: this is damage).
mkdir -p "$T/cut" && head -n 20 "$T/s2/bench_partial.txt" > "$T/cut/bench_partial.txt"
bad_merge "cut short" "$T/s1" "$T/cut" "$T/s3"
# A shard that fails leaves no partial file, not even an earlier run's in its folder.
mkdir -p "$T/stale" && cp "$T/s1/bench_partial.txt" "$T/stale/"
"$BIN" bench --scenes "$T/no_such_scene.glb" --shard 1/3 --out "$T/stale" > /dev/null 2> "$T/stale.err" \
  && { echo "FAIL: a shard of a missing scene succeeded"; fail=1; }
[ -e "$T/stale/bench_partial.txt" ] && { echo "FAIL: a failed shard left a partial file"; fail=1; }
[ $fail = 0 ] && echo "PASS: three shards merged into the unsharded run's 48 cells, same errors; bad input refused"
exit $fail
