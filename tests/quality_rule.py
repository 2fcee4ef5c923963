# --quality auto's choice replayed from what the run reported (engine/apps/quality.c), for
# quality_auto.sh and bench_quality.sh. The times are measurements, so which configuration wins
# differs from run to run; the rule that turns the reported times into the pick does not. The
# report writes every number with 17 significant digits (pn_quality_write_tried), so this replays
# the engine's comparisons on the very same doubles: ties and the 1.5x margin included, nothing
# here can go either way on rounding.

RUNOFF_MARGIN = 1.5
RUNOFF_MAX = 4


def key(t):
    return (t["mode"], None if t["tree"] is None else tuple(t["tree"]), t["spp"])


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


def check(tried, pick, runoff, candidates, all_set_up=True):
    """Asserts that `pick` (a dict with mode, tree, spp) is what the rule makes of `tried`, that the
    run-off timed its finalists (every one of them with all_set_up: no memory limit refused one at
    the frame's size), and that every configuration's climb stopped for a reason."""
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
    configs = {}
    for i, t in enumerate(tried):
        configs.setdefault((t["mode"], str(t["tree"])), []).append(i)
    for c, idx in configs.items():
        assert [tried[i]["spp"] for i in idx] == [1 << k for k in range(len(idx))], (c, idx)
        last = tried[idx[-1]]
        before = [tried[i] for i in range(idx[-1]) if tried[i]["within"]]
        slower = before and last["pilot_shadow_ms"] >= min(t["pilot_shadow_ms"] for t in before)
        flat = len(idx) > 1 and last["pilot_mae"] > 0.9 * tried[idx[-2]]["pilot_mae"] \
            and c[0] not in ("exact", "exact-ls", "rayquery")
        assert last["within"] or slower or flat or last["spp"] == 256, (c, last)
    return best
