# --quality auto's choice replayed from what the run reported (engine/shadow/quality.c), for
# quality_auto.sh and bench_quality.sh. The times are measurements, so which configuration wins
# differs from run to run; the rule that turns the reported times into the pick does not. The
# report writes every number with 17 significant digits (pn_quality_write_tried), so this replays
# the engine's comparisons on the very same doubles: ties and the 1.5x margin included, nothing
# here can go either way on rounding.

import struct

RUNOFF_MARGIN = 1.5
RUNOFF_MAX = 4
MAX_SPP = 256
ADAPTIVE_MIN = 4      # quality.h: PN_QUALITY_ADAPTIVE_MIN
ADAPTIVE_STEPS = 6    # PN_QUALITY_ADAPTIVE_STEPS
FILTERED_STEPS = 7    # PN_QUALITY_FILTERED_STEPS: adaptive MIN:4 MIN under the filter, MIN = 1 .. 64
EXACT_MODES = ("exact", "exact-ls", "rayquery", "rtpipeline")


def f32(x):
    """x rounded to a float, as the engine stores a pixel error."""
    return struct.unpack("f", struct.pack("f", x))[0]


def adaptive_error(budget, k):
    """quality.c: adaptive_error, the adaptive climb's k-th pixel error."""
    return f32(budget * 32.0 / (1 << k))


def filtered_pixel_error(budget):
    """quality.c: filtered_pixel_error, the pixel error of adaptive samples under the filter."""
    return f32(2.0 * budget)


def key(t):
    """A configuration: mode, tree, samples, for adaptive samples their first round and pixel
    error (to 6 digits: a render's JSON prints it so, the pilots' record to 9), and the filter
    (none or penumbra)."""
    spp_min = t.get("spp_min", 0)
    return (t["mode"], None if t["tree"] is None else tuple(t["tree"]), t["spp"], spp_min,
            float("%.6g" % t["pixel_error"]) if spp_min else 0.0, t.get("filter", "none"))


def replay(tried):
    """The pick's index in `tried`, and the run-off's finalists (indices, in the order tried).
    A finalist that cannot be set up at the frame's size drops out (it has no run-off time); with
    fewer than two left, the pilots' fastest stands."""
    fits = [i for i, t in enumerate(tried) if t["within"]]
    if not fits:
        # Nothing within the budget: the least error, the first tried of equals.
        return min(range(len(tried)), key=lambda i: (tried[i]["pilot_mae"], i)), []
    ms = lambda i: tried[i]["pilot_shadow_ms"]
    fastest = min(fits, key=lambda i: (ms(i), i))
    near = [i for i in fits if ms(i) <= RUNOFF_MARGIN * ms(fastest)]
    finalists = sorted(sorted(near, key=lambda i: (ms(i), i))[:RUNOFF_MAX])
    timed = [i for i in finalists if tried[i]["final_shadow_ms"] >= 0]
    if len(finalists) < 2 or len(timed) < 2:
        return fastest, finalists
    final = lambda i: tried[i]["final_shadow_ms"]
    return min(timed, key=lambda i: (final(i), i)), finalists


def check(tried, pick, runoff, candidates, budget, all_set_up=True, adaptive=True):
    """Asserts that `pick` (a dict with mode, tree, spp, and spp_min and pixel_error when adaptive)
    is what the rule makes of `tried`, that the run-off timed its finalists (every one of them with
    all_set_up: no memory limit refused one at the frame's size), and that every configuration's
    climbs stopped for a reason. adaptive: the frame could take adaptive samples (stratified
    sampler, an area light), so every configuration the rule names climbed them."""
    assert candidates == len(tried), (candidates, len(tried))
    best, finalists = replay(tried)
    assert key(pick) == key(tried[best]), (pick, tried[best])
    # Only finalists were timed, and with fewer than two finalists none; the run-off's count is of
    # those it could set up (all of them, where the memory limit let every one be set up).
    timed = [i for i, t in enumerate(tried) if t["final_shadow_ms"] >= 0]
    assert set(timed) <= set(finalists) and (len(finalists) >= 2 or not timed), (timed, finalists)
    if len(finalists) < 2:
        assert runoff == len(finalists), (runoff, finalists)
    else:
        assert runoff <= len(finalists) and (len(timed) < 2 or runoff == len(timed)), (runoff, timed, finalists)
    if all_set_up and len(finalists) >= 2:
        assert timed == finalists, (timed, finalists)
    # Every configuration climbs 1, 2, 4, ... samples per pixel, and its climb ends within the
    # budget, no faster than a pick already within it, with a biased mode's error no longer falling
    # (by 10% a doubling), or at the last spp.
    # Adaptive climbs (spp_min > 0) go from 4 up to 256 samples down the pixel errors 32, 16, 8, 4,
    # 2, 1 times the budget, after the same configuration's uniform climb, with the same reasons to end.
    # A filtered climb (the penumbra filter) is uniform, after the same configuration's unfiltered
    # one; then adaptive under the filter, MIN:4 MIN for MIN = 1, 2, 4, ... at twice the budget's
    # pixel error, while MIN is below the samples the filtered uniform climb ended at.
    configs = {}
    for i, t in enumerate(tried):
        configs.setdefault((t["mode"], str(t["tree"]), t.get("spp_min", 0) > 0, t.get("filter", "none")), []).append(i)
    for c, idx in configs.items():
        if c[3] != "none":
            assert c[3] == "penumbra", c
            unfiltered = configs.get((c[0], c[1], False, "none"), [])
            assert unfiltered and unfiltered[-1] < idx[0], (c, idx)
        if c[2] and c[3] != "none":
            filtered = configs.get((c[0], c[1], False, c[3]), [])
            assert filtered and filtered[-1] < idx[0], (c, idx)   # after the filtered uniform climb
            flast = tried[filtered[-1]]["spp"]
            assert [tried[i]["spp_min"] for i in idx] == [1 << k for k in range(len(idx))], (c, idx)
            assert all(tried[i]["spp"] == 4 * tried[i]["spp_min"] < 4 * flast for i in idx), (c, idx, flast)
            assert all(f32(tried[i]["pixel_error"]) == filtered_pixel_error(budget) for i in idx), (c, idx)
        elif c[2]:
            assert [tried[i]["spp_min"] for i in idx] == [ADAPTIVE_MIN] * len(idx), (c, idx)
            assert [tried[i]["spp"] for i in idx] == [MAX_SPP] * len(idx), (c, idx)
            assert [f32(tried[i]["pixel_error"]) for i in idx] == [adaptive_error(budget, k) for k in range(len(idx))], (c, idx)
            uniform = configs.get((c[0], c[1], False, "none"), [])
            assert uniform and uniform[-1] < idx[0], (c, idx)   # after the uniform climb
        else:
            assert [tried[i]["spp"] for i in idx] == [1 << k for k in range(len(idx))], (c, idx)
        last = tried[idx[-1]]
        before = [tried[i] for i in range(idx[-1]) if tried[i]["within"]]
        slower = before and last["pilot_shadow_ms"] >= min(t["pilot_shadow_ms"] for t in before)
        flat = len(idx) > 1 and last["pilot_mae"] > 0.9 * tried[idx[-2]]["pilot_mae"] and c[0] not in EXACT_MODES
        if not c[2]:
            at_end = last["spp"] == MAX_SPP
        elif c[3] == "none":
            at_end = len(idx) == ADAPTIVE_STEPS
        else:
            flast = tried[configs[(c[0], c[1], False, c[3])][-1]]["spp"]
            at_end = len(idx) == FILTERED_STEPS or 2 * last["spp_min"] >= flast
        assert last["within"] or slower or flat or at_end, (c, last)
    # Which configurations climb adaptive samples: those whose uniform climb went past 4 samples
    # (under the filter: past 1), exact modes always, a biased mode only where that uniform climb
    # met the budget.
    for (mode, tree, is_adaptive, filt), idx in configs.items():
        if is_adaptive:
            continue
        met = any(tried[i]["within"] for i in idx)
        least = ADAPTIVE_MIN if filt == "none" else 1
        expected = adaptive and budget > 0 and tried[idx[-1]]["spp"] > least and (mode in EXACT_MODES or met)
        assert ((mode, tree, True, filt) in configs) == expected, (mode, tree, filt, expected)
    return best
