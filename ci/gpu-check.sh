#!/usr/bin/env bash
# One run that says whether penumbra works on this machine's Vulkan device, and how fast:
#   gpu-check.sh OUT_DIR [--size N] [--quick] [--skip-bench] [--bench-args "ARGS"] [--scenes LIST]
# From the bundle (ci/bundle.sh: ./gpu-check.sh at its root) or from the repository
# (ci/gpu-check.sh, with build/penumbra; PN_BIN overrides either). Everything goes under OUT_DIR.
#  1. the device and driver (penumbra info);
#  2. every mode, and exact's per-ray and projection walks, against exact on the same pixels and
#     samples (render --filter none, same seed;
#     penumbra diff's mean |V - exact's|) on builtin:default, the bunny and builtin:canopy (alpha-
#     masked; --scenes names a subset, comma-separated: default, bunny, canopy), within the
#     documented bound: exact-ls, rayquery, rtpipeline are exact (<= 1e-3: at most a ray grazing an
#     edge may go the other way, engine/shadow/README.md); the line-space modes <= 0.05
#     (tests/test_light_kinds.c's bound; their bias is 0.001-0.03 there);
#  3. exact (and rayquery, rtpipeline where the device has them) against Embree 3 ray by ray on
#     the same rays (--ray-dump), by the project's oracles tests/test_exact_oracle.c (bunny, Sponza;
#     >= 99.99% agreement, the rest within 1e-5 of an edge) and tests/test_alpha_oracle.c
#     (alpha-masked quads, exact and exact-ls); a bundle whose oracle predates rtpipeline says
#     that it did not check it;
#  4. the Khronos validation layer with synchronization validation (PN_VALIDATION=1) on every mode,
#     where the layer is installed or bundled (its absence is reported, not a failure);
#  5. penumbra bench on the standard views, modes exact, linespace, ls-plane, hybrid, exact-ls (and
#     rtpipeline where info lists it) at --size (default 1024 on a GPU, 64 with --quick, 256 on a
#     CPU device): bench.csv, bench.json, time_to_error.md and plots (gnuplot, if there) in
#     OUT_DIR/bench. The bench is measured, never judged: it only fails if it cannot run.
# Ends with a PASS/FAIL summary; exits 1 if any check of 1-4 (or the bench run) failed, 2 on
# bad arguments.
# shellcheck disable=SC2054 # commas inside penumbra's arguments (--spp 4,16), not array separators
set -euo pipefail

usage() {
  sed -n '2,4p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}
[ $# -ge 1 ] || usage
out=$1
shift
case $out in -*) usage ;; esac
size="" quick=0 skip_bench=0 bench_args="" scene_names="default,bunny,canopy"
while [ $# -gt 0 ]; do
  case $1 in
    --size) [ $# -ge 2 ] || usage; size=$2; shift 2 ;;
    --quick) quick=1; shift ;;
    --skip-bench) skip_bench=1; shift ;;
    --bench-args) [ $# -ge 2 ] || usage; bench_args=$2; shift 2 ;;
    --scenes) [ $# -ge 2 ] || usage; scene_names=$2; shift 2 ;;
    -h | --help) usage ;;
    *) echo "gpu-check.sh: unknown argument '$1'" >&2; usage ;;
  esac
done
if ! [[ ,$scene_names, =~ ^(,(default|bunny|canopy))+,$ ]]; then
  echo "gpu-check.sh: --scenes takes a comma-separated list of default, bunny and canopy, got '$scene_names'" >&2
  exit 2
fi
if [ -n "$size" ] && ! [[ $size =~ ^[0-9]+$ && $size -ge 16 && $size -le 8192 ]]; then
  echo "gpu-check.sh: --size takes a number of pixels from 16 to 8192, got '$size'" >&2
  exit 2
fi

# Where penumbra is: the bundle (bin/penumbra beside this script) or the repository (build/).
here=$(cd "$(dirname "$(readlink -f "$0")")" && pwd)
envrun=()
if [ -x "$here/bin/penumbra" ] && [ -x "$here/libexec/penumbra" ]; then
  where="bundle $here"
  pn=${PN_BIN:-$here/bin/penumbra}
  libexec=$here/libexec
  envrun=("$here/bin/bundle-env")
  export PN_ASSETS=${PN_ASSETS:-$here/assets}
else
  repo=$(cd "$here/.." && pwd)
  where="repository $repo"
  pn=${PN_BIN:-$repo/build/penumbra}
  libexec=$(dirname "$pn")/tests
  [ -d "$libexec" ] || libexec=$repo/build/tests
  export PN_ASSETS=${PN_ASSETS:-$(cd "$repo/.." && pwd)/shared/assets}
fi
if [ ! -x "$pn" ]; then
  echo "gpu-check.sh: no penumbra at $pn (build it with ci/build.sh, or set PN_BIN)" >&2
  exit 1
fi

mkdir -p "$out"
out=$(cd "$out" && pwd)
log=$out/gpu-check.log
: >"$log"
# Everything to the console and the log; at exit the log's tee is waited for, so that whoever
# reads this script's output finds all of it once the script has ended.
exec 3>&1 4>&2
exec > >(tee -a "$log") 2>&1
tee_pid=$!
trap 'exec 1>&3 2>&4 3>&- 4>&-; wait "$tee_pid" 2>/dev/null || true' EXIT
t_start=$SECONDS
results=()
failed=0
record() { # STATUS WHAT...
  local status=$1
  shift
  results+=("$status  $*")
  [ "$status" != FAIL ] || failed=1
  echo "$status: $*"
}
step() { echo; echo "== $1 ($(date +%T), $((SECONDS - t_start)) s in)"; }
unset PN_VALIDATION # each step sets it where wanted

echo "gpu-check: $where"
echo "gpu-check: penumbra $pn; assets $PN_ASSETS; output $out"
[ -f "$here/BUNDLE.txt" ] && sed -n '2,3p' "$here/BUNDLE.txt"

# --- 1. The device --------------------------------------------------------------------------------
step "device and driver (penumbra info)"
if ! "$pn" info >"$out/info.txt" 2>&1; then
  cat "$out/info.txt"
  record FAIL "penumbra info: no usable Vulkan device (see $out/info.txt)"
  echo
  echo "gpu-check: FAIL (no device; nothing else was run)"
  exit 1
fi
cat "$out/info.txt"
device=$(sed -n 's/^chosen: *//p' "$out/info.txt" | head -n1)
driver=$(sed -n 's/^ *driver: *//p' "$out/info.txt" | head -n1)
record PASS "device: $device; driver: $driver"
cpu=0
grep -F "$device" "$out/info.txt" | grep "(CPU," >/dev/null && cpu=1
rq=0
grep -Eq "ray queries: *yes" "$out/info.txt" && rq=1
rtp=0
# A line naming rtpipeline that does not say it is refused ("ray-tracing pipelines: yes (--mode rtpipeline)").
grep -i "rtpipeline" "$out/info.txt" | grep -Evi "refused|:[[:space:]]*no([[:space:]]|$)" >/dev/null && rtp=1
if [ -z "$size" ]; then
  if [ $quick = 1 ]; then size=64; elif [ $cpu = 1 ]; then size=256; else size=1024; fi
fi
check_size=$([ $quick = 1 ] && echo 96 || echo 256)
echo "device kind: $([ $cpu = 1 ] && echo "CPU (lavapipe or the like)" || echo GPU); ray queries: $([ $rq = 1 ] && echo yes || echo no);" \
  "rtpipeline: $([ $rtp = 1 ] && echo listed || echo "not listed")"

# The modes render knows (its --help), those this device runs.
modes=()
while read -r m; do
  case $m in
    exact | none) continue ;;
    rayquery) [ $rq = 1 ] || { echo "rayquery: skipped, the device has no ray queries"; continue; } ;;
    rtpipeline) [ $rtp = 1 ] || { echo "rtpipeline: skipped, penumbra info does not list it"; continue; } ;;
  esac
  modes+=("$m")
done < <("$pn" render --help 2>&1 | awk '/--mode M/ {on = 1; sub(/.*--mode M */, "")} on && /^  --/ && !/--mode M/ {on = 0}
  on && match($0, /^ *[a-z][a-z0-9-]*:/) {s = substr($0, RSTART, RLENGTH); gsub(/[ :]/, "", s); print s}')
if [ $rtp = 1 ] && ! printf '%s\n' "${modes[@]}" | grep -x rtpipeline >/dev/null; then
  modes+=(rtpipeline) # listed by info, not yet in render's help
fi
# exact's other walks too (exact itself walks as a packet at 16 spp): the per-ray walk, and the
# projection, whose walk is shared by the subgroup (8 lanes on llvmpipe, 32 or 64 on a GPU).
modes=(exact/ray exact/project "${modes[@]}")
echo "modes checked against exact: ${modes[*]}"
bound_of() {
  case $1 in
    exact/* | exact-ls | rayquery | rtpipeline) echo 0.001 ;;
    linespace | ls-leaf | ls-plane | hybrid) echo 0.05 ;;
    *) echo 0.05 ;; # a mode this script does not know: held to the line-space bound, said below
  esac
}

# --- 2. Every mode against exact -----------------------------------------------------------------
step "every mode against exact, same samples (${check_size}x${check_size}, 16 spp, unfiltered)"
# The scenes of steps 2 and 4 (--scenes).
scenes=()
for nm in ${scene_names//,/ }; do
  case $nm in
    bunny) scenes+=("$PN_ASSETS/stanford-bunny-69k.glb") ;;
    *) scenes+=("builtin:$nm") ;;
  esac
done
cdir=$out/modes
mkdir -p "$cdir"
for sc in "${scenes[@]}"; do
  nm=$(basename "$sc" .glb | sed 's/^builtin://')
  if [[ $sc != builtin:* ]] && [ ! -f "$sc" ]; then
    record FAIL "modes on $nm: $sc is missing (set PN_ASSETS)"
    continue
  fi
  common=(--size "${check_size}x${check_size}" --spp 16 --filter none --seed 7 --tree 7,3)
  if ! "$pn" render "$sc" "${common[@]}" --mode exact -o "$cdir/$nm.exact.exr" >"$cdir/$nm.exact.log" 2>&1; then
    cat "$cdir/$nm.exact.log"
    record FAIL "modes on $nm: exact failed to render"
    continue
  fi
  for m in "${modes[@]}"; do
    b=$(bound_of "$m")
    margs=(--mode "$m")
    [[ $m == exact/* ]] && margs=(--mode exact --traversal "${m#exact/}")
    f=${m//\//-} # a file name
    if ! "$pn" render "$sc" "${common[@]}" "${margs[@]}" -o "$cdir/$nm.$f.exr" >"$cdir/$nm.$f.log" 2>&1; then
      tail -n 5 "$cdir/$nm.$f.log"
      record FAIL "$m on $nm: failed to render"
      continue
    fi
    rc=0
    js=$("$pn" diff "$cdir/$nm.exact.exr" "$cdir/$nm.$f.exr" --json --fail "mae=$b" 2>&1) || rc=$?
    mae=$(sed -n 's/.*"mae": *\([^,]*\),.*/\1/p' <<<"$js")
    mx=$(sed -n 's/.*"max": *\([^,]*\),.*/\1/p' <<<"$js")
    what="$m on $nm: mean |V - exact's| ${mae:-?} (bound $b$(case $m in exact/* | exact-ls | rayquery | rtpipeline | linespace | ls-leaf | ls-plane | hybrid) ;; *) echo ", a mode unknown to gpu-check" ;; esac)), max ${mx:-?}"
    case $rc in
      0) record PASS "$what" ;;
      1) record FAIL "$what" ;;
      *) echo "$js"; record FAIL "$m on $nm: penumbra diff could not compare (exit $rc)" ;;
    esac
  done
done

# --- 3. Against Embree 3, ray by ray ---------------------------------------------------------------
step "exact$([ $rq = 1 ] && echo ", rayquery")$([ $rtp = 1 ] && echo ", rtpipeline") against Embree 3 on the same rays (test_exact_oracle, test_alpha_oracle)"
odir=$out/oracle
mkdir -p "$odir/tmp"
for t in test_exact_oracle test_alpha_oracle; do
  exe=$libexec/$t
  if [ ! -x "$exe" ]; then
    record FAIL "$t: $exe is missing (build the tests: ci/build.sh; ci/bundle.sh copies them)"
    continue
  fi
  rc=0
  PN_BIN=$pn PN_TEST_TMP=$odir/tmp "${envrun[@]}" "$exe" >"$odir/$t.log" 2>&1 || rc=$?
  grep -E "Embree agrees|Embree with the filter|skipped" "$odir/$t.log" | head -n 20 || true
  case $rc in
    0) record PASS "$t: every checked mode agrees with Embree 3 within the bound ($odir/$t.log)" ;;
    77) record SKIP "$t: skipped: $(tail -n 1 "$odir/$t.log")" ;;
    *) tail -n 20 "$odir/$t.log"; record FAIL "$t exited $rc ($odir/$t.log)" ;;
  esac
done
if [ $rtp = 1 ]; then
  if grep -q "^rtpipeline" "$odir/test_exact_oracle.log" 2>/dev/null; then
    echo "rtpipeline: traced by test_exact_oracle (above)"
  else
    record SKIP "rtpipeline against Embree: not checked (test_exact_oracle does not trace it; no other CLI path compares a ray dump with Embree); it was checked against exact in step 2"
  fi
fi
[ $rq = 1 ] || echo "rayquery against Embree: not run, the device has no ray queries"

# --- 4. The validation layer -----------------------------------------------------------------------
step "Khronos validation layer (PN_VALIDATION=1), every mode"
vdir=$out/validation
mkdir -p "$vdir"
vrc=0 vfail=0
PN_VALIDATION=1 "$pn" info >"$vdir/info.txt" 2>&1 || vrc=$?
if [ $vrc != 0 ] && grep -q "not installed" "$vdir/info.txt"; then
  record SKIP "validation layer: not installed on this machine nor in the bundle ($(tail -n 1 "$vdir/info.txt"))"
else
  [ $vrc = 0 ] || { vfail=1; cat "$vdir/info.txt"; record FAIL "validation: penumbra info under the layer exited $vrc"; }
  vsize=$([ $quick = 1 ] && echo 64 || echo 128)
  for sc in "${scenes[@]}"; do
    nm=$(basename "$sc" .glb | sed 's/^builtin://')
    [[ $sc == builtin:* ]] || [ -f "$sc" ] || continue
    for m in exact "${modes[@]}"; do
      rc=0
      margs=(--mode "$m")
      [[ $m == exact/* ]] && margs=(--mode exact --traversal "${m#exact/}")
      f=${m//\//-}
      PN_VALIDATION=1 "$pn" render "$sc" --size "${vsize}x${vsize}" --spp 4 "${margs[@]}" --tree 6,3 \
        -o "$vdir/$nm.$f.exr" >"$vdir/$nm.$f.log" 2>&1 || rc=$?
      case $rc in
        0) ;;
        3) grep -m 3 "validation" "$vdir/$nm.$f.log" || true
           vfail=1; record FAIL "validation: $m on $nm: the layer reported messages ($vdir/$nm.$f.log)" ;;
        *) vfail=1; tail -n 5 "$vdir/$nm.$f.log"; record FAIL "validation: $m on $nm: render exited $rc ($vdir/$nm.$f.log)" ;;
      esac
    done
  done
  # One bench cell under the layer too: the bench's own frames, timestamps and reference.
  rc=0
  PN_VALIDATION=1 "$pn" bench --scenes builtin:default --size 64x64 --modes "exact,linespace" --trees 6,3 --spp 4 \
    --filter none,penumbra --reference-spp 64 --repeat 1 --warmup 1 --no-embree --out "$vdir/bench" \
    >"$vdir/bench.log" 2>&1 || rc=$?
  [ $rc = 0 ] || { vfail=1; tail -n 5 "$vdir/bench.log"; record FAIL "validation: bench exited $rc ($vdir/bench.log)"; }
  if [ $vfail = 0 ]; then
    record PASS "validation layer: no message on exact and ${#modes[@]} other modes (${#scenes[@]} scenes) and a bench run"
  fi
fi

# --- 5. The bench ----------------------------------------------------------------------------------
if [ $skip_bench = 1 ]; then
  record SKIP "bench: --skip-bench"
else
  bmodes=exact,linespace,ls-plane,hybrid,exact-ls
  [ $rtp = 1 ] && bmodes=$bmodes,rtpipeline
  if [ $quick = 1 ]; then
    matrix=(--spp 4,16 --filter none --trees 6,3 --reference-spp 256 --repeat 2 --warmup 1)
  else
    matrix=(--spp 4,16,64 --filter none,penumbra --trees 7,3 --reference-spp 1024)
  fi
  # shellcheck disable=SC2206 # the user's extra arguments, split as words on purpose
  extra=($bench_args)
  step "bench: standard views, modes $bmodes, ${size}x${size} (${matrix[*]} ${extra[*]})"
  bdir=$out/bench
  rc=0
  "$pn" bench --size "${size}x${size}" --modes "$bmodes" "${matrix[@]}" "${extra[@]}" --out "$bdir" \
    >"$out/bench.log" 2>&1 || rc=$?
  grep -v "cell [0-9]*/[0-9]* done" "$out/bench.log" | tail -n 60 || true
  if [ $rc = 0 ]; then
    # bench draws its plots with gnuplot inside penumbra's environment (the bundle's libraries);
    # a plot it could not draw is drawn again here in the machine's own, where gnuplot is.
    if command -v gnuplot >/dev/null 2>&1; then
      for gp in "$bdir"/*.gp; do
        [ -f "$gp" ] || continue
        [ -f "${gp%.gp}.png" ] || (cd "$bdir" && gnuplot "$(basename "$gp")" 2>/dev/null) ||
          echo "gnuplot could not draw $gp"
      done
    else
      echo "gnuplot is not installed: no plots (their data and scripts are in $bdir: *.dat, *.gp)"
    fi
    views=$(awk -F, 'NR == 1 {for (i = 1; i <= NF; i++) if ($i == "view") c = i} NR > 1 && c {print $c}' \
      "$bdir/bench.csv" 2>/dev/null | sort -u | tr '\n' ' ')
    record PASS "bench: ${views:-its views}at ${size}x${size}: $bdir/{bench.csv,bench.json,time_to_error.md}, $(ls "$bdir"/*.png 2>/dev/null | wc -l) plots"
  else
    record FAIL "bench exited $rc ($out/bench.log)"
  fi
fi

# --- Summary -----------------------------------------------------------------------------------------
echo
echo "== summary ($((SECONDS - t_start)) s; device: $device; log: $log)"
printf '%s\n' "${results[@]}"
if [ $failed = 0 ]; then
  echo "gpu-check: PASS"
else
  echo "gpu-check: FAIL ($(printf '%s\n' "${results[@]}" | grep -c '^FAIL') failed checks)"
fi
exit $failed
