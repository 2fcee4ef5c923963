// --quality auto: pilots of every configuration against a converged reference, and the pick.
#include "shadow/quality.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "shadow/metrics.h"
#include "shadow/quality_pilot.h"
#include "shadow/setup.h"
#include "core/log.h"
#include "core/timer.h"
#include "scene/view.h"

// The standard trees, coarse to fine; a mode tries the first pn_shadow_mode_info.auto_trees of
// them, modes in climb_order. A tree that does not fit max_bytes (or float precision) is skipped.
static const int TREES[][2] = {{6, 3}, {7, 3}, {8, 3}, {5, 4}};
_Static_assert(sizeof TREES / sizeof TREES[0] <= PN_QUALITY_MAX_TREES, "quality.h's PN_QUALITY_MAX_TRIED counts the trees");
_Static_assert(1 << 8 == PN_QUALITY_MAX_SPP, "quality.h's PN_QUALITY_MAX_TRIED counts 9 spp steps");

// Is the configuration within the budget? Decided at pilot size when its MAE is two standard errors
// from the budget or more (about a 97.7% one-sided bound for the full picture's MAE were the
// pixels' errors independent). Nearer, the pilot cannot tell, and the same configuration is
// rendered at the confirming size (twice the pilot's width and height, or the frame itself) against
// that size's reference; still undecided there, or refused there (too large a tree), it is taken as
// outside. *confirm_mae: the confirming MAE, or -1 when none was needed.
static pn_result decide(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                        const pn_setup_desc *cfg, double mae, double se, double budget, pn_pilot_size *big, bool *within,
                        double *confirm_mae, double *confirm_se)
{
    *confirm_mae = -1, *confirm_se = 0;
    *within = mae + 2 * se <= budget;
    if (*within || mae - 2 * se > budget || !big->used)
        return PN_OK;
    PN_TRY(pn_pilot_reference(dev, scene, cam, light, big));
    pn_setup_desc sd = big->sd;
    sd.frame.mode = cfg->frame.mode;
    sd.frame.spp = cfg->frame.spp;
    sd.frame.spp_min = cfg->frame.spp_min;
    sd.frame.pixel_error = cfg->frame.pixel_error;
    sd.frame.filter = cfg->frame.filter;
    sd.tree_n = cfg->tree_n;
    sd.tree_d = cfg->tree_d;
    pn_setup s;
    if (pn_pilot_quiet_setup(dev, scene, light, &sd, &s) != PN_OK)
        return PN_OK; // outside, as undecided
    double ms;
    pn_result r = pn_pilot_error(&s, cam, light, big, false, false, confirm_mae, confirm_se, &ms); // only its error counts
    pn_setup_destroy(dev, &s);
    *within = r == PN_OK && *confirm_mae + 2 * *confirm_se <= budget;
    return r;
}

// The run-off: the pilots that met the budget in up to this much of the fastest one's time, at most
// RUNOFF_MAX of them, are timed again at the frame's size, side by side, and the fastest there wins.
// A pilot is a frame of at most 128x128 pixels: its fixed costs and the machine's load of the
// moment move its time by tens of percent against the full frame's (measured: a pick 1.56x and
// 1.66x slower at full size than a configuration whose pilot was as fast), so pilots within 1.5x of
// each other are not ranked by their pilots.
#define RUNOFF_MARGIN 1.5
enum { RUNOFF_MAX = 4 };

pn_result pn_quality_time_side_by_side(pn_renderer *const *r, int count, int warmup, int rounds,
                                       const pn_camera *cam, const pn_light *light, double *least_ms)
{
    pn_frame_times t;
    for (int k = 0; k < count; k++)
        least_ms[k] = INFINITY;
    for (int round = 0; round < warmup + rounds; round++)
        for (int k = 0; k < count; k++) {
            PN_TRY(pn_renderer_render(r[k], cam, light, &t));
            if (round >= warmup)
                least_ms[k] = fmin(least_ms[k], t.shadow_ms + t.filter_ms);
        }
    return PN_OK;
}

// Is pilot a slower than pilot b? Equal times rank by the order they were tried, so that every
// choice below is a function of the reported times alone, ties included (tests/quality_rule.py
// replays it from the JSON).
static bool pilot_slower(const pn_quality_choice *q, int a, int b)
{
    double ta = q->tried[a].pilot_ms, tb = q->tried[b].pilot_ms;
    return ta > tb || (ta == tb && a > b);
}

static pn_result runoff(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                        const pn_renderer_desc *frame, uint64_t max_bytes, pn_quality_choice *out)
{
    int finalists[RUNOFF_MAX], count = 0;
    for (int i = 0; i < out->candidates && i < PN_QUALITY_MAX_TRIED; i++) {
        pn_quality_tried *t = &out->tried[i];
        t->final_ms = -1;
        if (!t->within || t->pilot_ms > RUNOFF_MARGIN * out->pilot_ms)
            continue;
        if (count < RUNOFF_MAX) {
            finalists[count++] = i;
            continue;
        }
        int slowest = 0; // keep the RUNOFF_MAX fastest pilots
        for (int k = 1; k < count; k++)
            if (pilot_slower(out, finalists[k], finalists[slowest]))
                slowest = k;
        if (pilot_slower(out, finalists[slowest], i))
            finalists[slowest] = i;
    }
    // In the order tried, so that equal run-off times go to the one tried first.
    for (int k = 1; k < count; k++)
        for (int j = k; j > 0 && finalists[j - 1] > finalists[j]; j--) {
            int swap = finalists[j];
            finalists[j] = finalists[j - 1];
            finalists[j - 1] = swap;
        }
    out->runoff = count;
    if (count < 2)
        return PN_OK;
    // A finalist that cannot be set up at the frame's size (the memory limit holds for each set-up,
    // and the full view may keep more geometry) drops out; the pilots' pick stands if fewer than
    // two remain.
    pn_setup s[RUNOFF_MAX];
    pn_renderer *timed[RUNOFF_MAX];
    int ready = 0;
    for (int k = 0; k < count; k++) {
        const pn_quality_tried *t = &out->tried[finalists[k]];
        pn_setup_desc sd = {.frame = *frame, .max_bytes = max_bytes, .view = cam, .tree_n = t->tree_n, .tree_d = t->tree_d};
        sd.frame.mode = t->mode, sd.frame.spp = t->spp;
        sd.frame.spp_min = t->spp_min, sd.frame.pixel_error = t->pixel_error;
        sd.frame.filter = t->filter;
        sd.frame.dump_rays = sd.frame.count_work = false;
        if (pn_pilot_quiet_setup(dev, scene, light, &sd, &s[ready]) == PN_OK) {
            timed[ready] = &s[ready].renderer;
            finalists[ready++] = finalists[k];
        }
    }
    count = ready;
    out->runoff = count;
    double ms[RUNOFF_MAX];
    // One warm-up round (first touches of the pools), then round robin: a load lasting a frame or
    // two slows every finalist alike.
    pn_result r = count < 2 ? PN_OK : pn_quality_time_side_by_side(timed, count, 1, PN_PILOT_TIMED_FRAMES, cam, light, ms);
    for (int k = 0; k < ready; k++)
        pn_setup_destroy(dev, &s[k]);
    if (r != PN_OK || count < 2)
        return r;
    for (int k = 0; k < count; k++)
        out->tried[finalists[k]].final_ms = ms[k];
    int best = finalists[0];
    for (int k = 1; k < count; k++)
        if (out->tried[finalists[k]].final_ms < out->tried[best].final_ms)
            best = finalists[k];
    const pn_quality_tried *b = &out->tried[best];
    out->mode = b->mode, out->tree_n = b->tree_n, out->tree_d = b->tree_d, out->spp = b->spp;
    out->spp_min = b->spp_min, out->pixel_error = b->pixel_error, out->filter = b->filter;
    out->pilot_mae = b->pilot_mae, out->pilot_se = b->pilot_se, out->confirm_mae = b->confirm_mae;
    out->pilot_ms = b->pilot_ms;
    return PN_OK;
}

void pn_quality_write_tried(FILE *f, const pn_quality_choice *q)
{
    static const char *const CONFIRM_NAMES[] = {"none", "double", "frame", "bound"};
    fputc('[', f);
    for (int i = 0; i < q->candidates && i < PN_QUALITY_MAX_TRIED; i++) {
        const pn_quality_tried *c = &q->tried[i];
        fprintf(f, "%s{\"mode\": \"%s\", \"tree\": ", i ? ", " : "", pn_shadow_mode_get(c->mode)->name);
        if (c->tree_n)
            fprintf(f, "[%d, %d]", c->tree_n, c->tree_d);
        else
            fprintf(f, "null");
        fprintf(f, ", \"spp\": %u, \"spp_min\": %u, \"pixel_error\": %.9g, \"filter\": \"%s\", \"mean_rays\": %.6g, \"pilot_mae\": %.17g, \"pilot_se\": %.17g, \"confirm_mae\": %.17g, \"confirm_se\": %.17g, \"confirm_at\": \"%s\", \"within\": %s, "
                   "\"pilot_shadow_ms\": %.17g, \"final_shadow_ms\": %.17g}",
                c->spp, c->spp_min, (double)c->pixel_error, pn_filter_names[c->filter], c->mean_rays, c->pilot_mae, c->pilot_se, c->confirm_mae, c->confirm_se, CONFIRM_NAMES[c->confirm_at], c->within ? "true" : "false", c->pilot_ms, c->final_ms);
    }
    fputc(']', f);
}

// The adaptive climb's k-th pixel error: 32, 16, 8, 4, 2 and 1 times the budget. A pixel that
// stops has its standard error below E, so its expected |error| is below about 0.8 E (a normal's
// mean absolute value), and less, as the halves' estimate is conservative; lit and umbra pixels
// stop with almost none, so the MAE over the picture is a fraction of that, about the share of
// pixels in penumbra. Measured, MAE / E: 0.04 (builtin:default, 128x96), 0.09-0.2 (bunny and
// dragon views, 512x512, E 0.02-0.1). So the climb starts where nearly every pixel stops after its
// first round and halves E down to the budget itself (a picture of penumbrae). Above 1 (budgets
// over 1/32) E only lets every pixel stop that has a valid half: no clamp, so no step repeats.
static float adaptive_error(double budget, int k) { return (float)(budget * 32.0 / (double)(1 << k)); }

// The climb's state over one set-up: the pick so far lives in the choice.
typedef struct climb {
    pn_gpu_device *dev;
    const pn_scene *scene;
    const pn_camera *cam;
    const pn_light *light;
    double max_error;
    pn_pilot_size *pilot, *big;
    pn_frame_sample *sample;
    pn_renderer *frame; // the configuration's frame, filtered, where sample is used; else NULL
    // Its filtered uniform climb's frame / pilot MAE at 1, 2, 4, ... spp (pn_frame_sample; 0: not
    // rendered at that many).
    double frame_ratio[9];
    pn_quality_choice *out;
    bool have;
} climb;

// One pilot of the set-up s configured as sd (uniform or adaptive): its error, decision and time,
// recorded as tried and taken as the pick where it is better.
static pn_result climb_step(climb *c, pn_setup *s, const pn_setup_desc *sd, bool warm_up, double *mae, double *ms,
                            bool *within)
{
    const pn_renderer_desc *f = &sd->frame;
    double se, confirm_mae;
    *within = false;
    PN_TRY(pn_renderer_set_adaptive(&s->renderer, f->spp_min, f->spp, f->pixel_error));
    PN_TRY(pn_pilot_error(s, c->cam, c->light, c->pilot, true, warm_up, mae, &se, ms));
    double mean_rays = f->spp;
    if (f->spp_min) {
        pn_frame_images img;
        pn_renderer_images(&s->renderer, &img);
        uint64_t rays = 0, covered = 0;
        for (size_t i = 0; img.rays && i < c->pilot->px; i++)
            if (c->pilot->mask[i])
                rays += img.rays[4 * i], covered++;
        mean_rays = covered ? (double)rays / (double)covered : 0;
    }
    pn_quality_confirm confirm_at = PN_QUALITY_CONFIRM_NONE;
    double confirm_se = 0;
    int steps = (int)(sizeof c->frame_ratio / sizeof c->frame_ratio[0]), log2_spp = 0;
    while ((2u << log2_spp) <= (f->spp_min ? f->spp_min : f->spp) && log2_spp + 1 < steps)
        log2_spp++;
    double share = 0; // the frame's share of the pilot's error measured at the most samples up to these
    for (int k = log2_spp; k >= 0 && share == 0; k--)
        share = c->frame_ratio[k];
    if (f->filter != PN_FILTER_NONE && c->frame && share > 0 && (*mae - 2 * se) * share > c->max_error) {
        // Filtered, and outside by the frame's error the pilot's predicts: the frame need not be
        // rendered (pn_frame_sample).
        confirm_mae = *mae * share;
        confirm_at = PN_QUALITY_CONFIRM_BOUND;
    } else if (f->filter != PN_FILTER_NONE && c->frame) {
        // Filtered, the pilot cannot tell (pn_frame_sample): the frame's own pixels decide.
        PN_TRY(pn_renderer_set_adaptive(c->frame, f->spp_min, f->spp, f->pixel_error));
        PN_TRY(pn_frame_sample_error(c->frame, c->cam, c->light, c->sample, &confirm_mae, &confirm_se));
        *within = confirm_mae + 2 * confirm_se <= c->max_error;
        confirm_at = PN_QUALITY_CONFIRM_FRAME;
        if (!f->spp_min && *mae > 0)
            c->frame_ratio[log2_spp] = confirm_mae / *mae;
    } else {
        PN_TRY(decide(c->dev, c->scene, c->cam, c->light, sd, *mae, se, c->max_error, c->big, within, &confirm_mae,
                      &confirm_se));
        confirm_at = confirm_mae >= 0 ? PN_QUALITY_CONFIRM_DOUBLE : PN_QUALITY_CONFIRM_NONE;
    }
    pn_quality_choice *out = c->out;
    if (out->candidates < PN_QUALITY_MAX_TRIED)
        out->tried[out->candidates] = (pn_quality_tried){f->mode, sd->tree_n, sd->tree_d, f->spp, f->spp_min,
                                                         f->pixel_error, mean_rays, *mae, se, *ms, confirm_mae,
                                                         confirm_se, *within, -1, f->filter, confirm_at};
    out->candidates++;
    pn_debug("quality: %s LS(%d,%d) %u:%u spp (E %g, %.1f rays), filter %s: pilot MAE %.4f +- %.4f in %.2f ms%s",
             pn_shadow_mode_get(f->mode)->name, sd->tree_n, sd->tree_d, f->spp_min, f->spp, (double)f->pixel_error,
             mean_rays, pn_filter_names[f->filter], *mae, se, *ms, *within ? " (within)" : "");
    // Within the budget: the fastest such pilot wins. Until one is found, the least error.
    bool better = *within ? !out->within || *ms < out->pilot_ms : !out->within && (!c->have || *mae < out->pilot_mae);
    if (better) {
        out->mode = f->mode;
        out->tree_n = sd->tree_n;
        out->tree_d = sd->tree_d;
        out->spp = f->spp;
        out->spp_min = f->spp_min;
        out->pixel_error = f->pixel_error;
        out->filter = f->filter;
        out->pilot_mae = *mae;
        out->pilot_se = se;
        out->confirm_mae = confirm_mae;
        out->pilot_ms = *ms;
        out->within = *within;
        c->have = true;
    }
    return PN_OK;
}

// More samples only cost more: a climb stops once within the budget, once slower than a pick within
// it, or, for a biased mode, once its error no longer falls: doubling the samples (or halving the
// pixel error) cuts noise by about 1/sqrt(2), 0.9 is far from that and near a floor. An exact mode
// has no floor (its error is noise) and climbs on.
static bool climb_ends(const climb *c, const pn_shadow_mode_info *info, bool within, double ms, double mae,
                       double prev_mae)
{
    return within || (c->out->within && ms >= c->out->pilot_ms) || (!info->exact && mae > 0.9 * prev_mae);
}

// One configuration's uniform climb, 1, 2, 4, ... PN_QUALITY_MAX_SPP samples with sd's filter, until
// climb_ends; *met: some step was within the budget; *last_spp and *mae: the samples it ended at
// and their error.
static pn_result uniform_climb(climb *c, pn_setup *s, pn_setup_desc *sd, const pn_shadow_mode_info *info, bool *met,
                               uint32_t *last_spp, double *mae)
{
    double prev_mae = INFINITY, ms;
    bool within;
    *met = false, *last_spp = 0;
    for (uint32_t spp = 1; spp <= PN_QUALITY_MAX_SPP; spp *= 2) {
        sd->frame.spp = spp;
        PN_TRY(climb_step(c, s, sd, spp == 1, mae, &ms, &within)); // warm: the set-up's (or filter's) first
        *met = *met || within;
        *last_spp = spp;
        if (climb_ends(c, info, within, ms, *mae, prev_mae))
            break;
        prev_mae = *mae;
    }
    return PN_OK;
}

// The pixel error of adaptive samples under the filter: twice the budget. There the width rule
// decides which pixels go on, the error hardly: on the dragon and buddha views (512x512, 1:4, 2:8
// and 4:16) pixel errors 0.005, 0.01 and 0.02 gave the same MAE to .0001, 0.05 .0001 more at 4:16.
static float filtered_pixel_error(double budget) { return (float)(2.0 * budget); }

// Adaptive samples under the penumbra filter, MIN:4 MIN for MIN = 1, 2, 4, ... below the samples
// the filtered uniform climb ended at (flast): every pixel traces its MIN, so from MIN = flast on
// none could be faster than that climb's last step. Under the filter a pixel refines only where the
// filter cannot average (a penumbra under 2 pixels: adaptive_decide, shadow_frame.glsl): few
// pixels, 2-10% more rays than MIN (engine/gpu/README.md, "Under a filter"), so MAX = 4 MIN costs
// little more than 2 MIN and lowers the error further (the dragon, 512x512: 4:8 .00486, 4:16
// .00443, uniform 4 .00515). The climb ends as the others do (climb_ends).
static pn_result filtered_adaptive_climb(climb *c, pn_setup *s, pn_setup_desc *sd, const pn_shadow_mode_info *info,
                                         uint32_t flast)
{
    double prev_mae = INFINITY, mae, ms;
    bool within;
    for (uint32_t min = 1, k = 0; min < flast && k < PN_QUALITY_FILTERED_STEPS; min *= 2, k++) {
        sd->frame.spp_min = min;
        sd->frame.spp = 4 * min;
        sd->frame.pixel_error = filtered_pixel_error(c->max_error);
        PN_TRY(climb_step(c, s, sd, k == 0, &mae, &ms, &within)); // warm: the first adaptive frame
        if (climb_ends(c, info, within, ms, mae, prev_mae))
            break;
        prev_mae = mae;
    }
    sd->frame.spp_min = 0, sd->frame.pixel_error = 0;
    return PN_OK;
}

// How many of its standard trees --quality auto climbs for mode m (1 for a mode without a tree), 0
// when m is no candidate for the scene on this device.
static int candidate_trees(const pn_gpu_device *dev, const pn_scene *scene, pn_shadow_mode m)
{
    const pn_shadow_mode_info *info = pn_shadow_mode_get(m);
    if (!info->traces || !pn_shadow_mode_available(dev, m, NULL) || !pn_shadow_mode_takes_scene(m, scene, NULL, 0))
        return 0;
    int most = (int)(sizeof TREES / sizeof TREES[0]);
    return info->auto_trees < most ? info->auto_trees : most;
}

// The k-th mode to climb: exact first, then the others in table order (cheapest first). A climb
// ends once slower than a pick within the budget (climb_ends), and exact reaches any budget (its
// error is noise), so with its pick in hand the biased modes' climbs end where they get slower,
// instead of running to PN_QUALITY_MAX_SPP where they never meet the budget (a view whose
// penumbrae line space cannot resolve, such as the canopy's, had every tree climb 256 spp
// filtered before exact's turn came). Where a configuration's time grows with its samples the
// pilots' fastest within the budget is the same in either order: what a climb no longer tries is
// its steps after one already slower than a pick within it.
static pn_shadow_mode climb_order(int k)
{
    if (k == 0)
        return PN_SHADOW_EXACT;
    return (pn_shadow_mode)(k <= PN_SHADOW_EXACT ? k - 1 : k);
}
_Static_assert(PN_SHADOW_EXACT > 0 && PN_SHADOW_EXACT < PN_SHADOW_MODE_COUNT, "climb_order");

pn_result pn_quality_choose(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                            const pn_renderer_desc *frame, double max_error, uint64_t max_bytes, uint32_t reference_spp,
                            bool uniform_only, pn_quality_choice *out)
{
    memset(out, 0, sizeof *out);
    reference_spp = reference_spp ? reference_spp : PN_REFERENCE_SPP;
    double scale = fmin(1.0, sqrt(PN_PILOT_PIXELS / ((double)frame->width * frame->height)));
    pn_pilot_size pilot, big = {0};
    pn_result r = pn_pilot_size_init(&pilot, frame, scale, max_bytes, reference_spp, cam);
    if (r == PN_OK && scale < 1.0)
        r = pn_pilot_size_init(&big, frame, fmin(1.0, 2.0 * scale), max_bytes, reference_spp, cam);
    if (r == PN_OK)
        r = pn_pilot_reference(dev, scene, cam, light, &pilot);
    if (r == PN_OK)
        pn_info("quality auto: the converged reference, %u spp at %ux%u, in %.1f s", reference_spp,
                pilot.sd.frame.width, pilot.sd.frame.height, pilot.reference_ms * 1e-3);
    out->pilot_width = pilot.sd.frame.width;
    out->pilot_height = pilot.sd.frame.height;
    out->reference_ms = pilot.reference_ms;
    pn_frame_sample sample = {0};
    climb c = {dev, scene, cam, light, max_error, &pilot, &big, &sample, NULL, {0}, out, false};
    // Adaptive samples need the stratified sampler's Sobol' draws, the even split and no ray dump
    // (pn_shadow_check_samples: the frame's own options must allow the pick), and a budget of 0 is
    // met by nothing.
    bool adaptive = !uniform_only && frame->sampler == PN_SAMPLER_STRATIFIED && frame->split == PN_SPLIT_EVEN &&
                    !frame->dump_rays && max_error > 0 && !pn_light_is_point(light);
    // The penumbra filter, likewise: the frame must ask for a filter (render's default; --filter
    // none keeps auto to unfiltered configurations) and allow one (pn_renderer_check_split), and a
    // point light's V, exact at one ray, has nothing to filter.
    bool filtered = frame->filter != PN_FILTER_NONE && frame->split == PN_SPLIT_EVEN && !pn_light_is_point(light) &&
                    max_error > 0;
    if (r == PN_OK)
        r = pn_frame_sample_init(&sample, frame, &pilot, filtered);
    pn_setup_desc sd = pilot.sd;
    pn_setup s;
    // The configurations to climb, for the progress lines: a mode's trees, or the mode once.
    int total = 0, done = 0;
    uint64_t t_start = pn_time_ns();
    for (int m = 0; m < PN_SHADOW_MODE_COUNT; m++)
        total += candidate_trees(dev, scene, (pn_shadow_mode)m);
    for (int o = 0; r == PN_OK && o < PN_SHADOW_MODE_COUNT; o++) {
        pn_shadow_mode m = climb_order(o);
        const pn_shadow_mode_info *info = pn_shadow_mode_get(m);
        int trees = candidate_trees(dev, scene, m); // 0: not a candidate here (rayquery, rtpipeline on a device without them)
        for (int t = 0; r == PN_OK && t < trees; t++) {
            sd.frame.mode = m;
            sd.frame.spp = 1;
            sd.frame.spp_min = 0;
            sd.frame.pixel_error = 0;
            sd.tree_n = info->needs.tree ? TREES[t][0] : 0;
            sd.tree_d = info->needs.tree ? TREES[t][1] : 0;
            if (pn_pilot_quiet_setup(dev, scene, light, &sd, &s) != PN_OK)
                continue; // does not fit: try the next
            double prev_mae = INFINITY, mae = INFINITY, ms = INFINITY;
            bool within = false, met = false;
            uint32_t last_spp = 0;
            r = uniform_climb(&c, &s, &sd, info, &met, &last_spp, &mae);
            // The same climb with the penumbra filter, on the same set-up (the filter is the
            // renderer's to switch), and adaptive samples under it; then back to none for the
            // unfiltered adaptive climb.
            if (r == PN_OK && filtered) {
                bool fmet;
                uint32_t flast;
                double fmae;
                r = pn_renderer_set_filter(&s.renderer, PN_FILTER_PENUMBRA, frame->tile_w, frame->tile_h);
                sd.frame.filter = PN_FILTER_PENUMBRA;
                // The frame itself, on the pilot's tree, for the filtered pilots' errors
                // (pn_frame_sample); one that does not fit leaves them to the pilots, which judge
                // them too strictly, not too leniently.
                pn_renderer frame_r;
                if (r == PN_OK && sample.used)
                    r = pn_frame_sample_reference(dev, scene, cam, light, &pilot, &sample);
                if (r == PN_OK && sample.used) {
                    pn_renderer_desc fd = s.renderer.desc;
                    fd.width = frame->width, fd.height = frame->height;
                    pn_log_level level = pn_log_get_level();
                    pn_log_set_level(PN_LOG_ERROR);
                    c.frame = pn_renderer_create(dev, scene, &fd, &frame_r) == PN_OK ? &frame_r : NULL;
                    memset(c.frame_ratio, 0, sizeof c.frame_ratio);
                    pn_log_set_level(level);
                }
                if (r == PN_OK)
                    r = uniform_climb(&c, &s, &sd, info, &fmet, &flast, &fmae);
                // Adaptive samples under the filter, from one sample up: as the unfiltered
                // adaptive climb, only for an exact mode or where the climb met the budget.
                if (r == PN_OK && adaptive && flast > 1 && (info->exact || fmet))
                    r = filtered_adaptive_climb(&c, &s, &sd, info, flast);
                if (c.frame)
                    pn_renderer_destroy(c.frame);
                c.frame = NULL;
                sd.frame.filter = PN_FILTER_NONE;
                if (r == PN_OK)
                    r = pn_renderer_set_filter(&s.renderer, PN_FILTER_NONE, frame->tile_w, frame->tile_h);
            }
            // Adaptive samples trace at least their first round's in every pixel: where the uniform
            // climb ended at as few samples (within the budget, or already slower than a pick
            // within it), no adaptive configuration can be faster. They cut noise, not bias: a
            // biased mode whose uniform climb never met the budget ended at its floor, which
            // adaptive samples do not lower either.
            bool climb_adaptive = adaptive && last_spp > PN_QUALITY_ADAPTIVE_MIN && (info->exact || met);
            prev_mae = INFINITY;
            for (int k = 0; r == PN_OK && climb_adaptive && k < PN_QUALITY_ADAPTIVE_STEPS; k++) {
                sd.frame.spp = PN_QUALITY_MAX_SPP;
                sd.frame.spp_min = PN_QUALITY_ADAPTIVE_MIN;
                sd.frame.pixel_error = adaptive_error(max_error, k);
                r = climb_step(&c, &s, &sd, k == 0, &mae, &ms, &within); // warm: the first adaptive frame
                if (r != PN_OK || climb_ends(&c, info, within, ms, mae, prev_mae))
                    break;
                prev_mae = mae;
            }
            pn_setup_destroy(dev, &s);
            done++;
            double elapsed = pn_ms_since(t_start) * 1e-3;
            // Through the logger (the library's calls keep stderr quiet unless asked).
            char tree[32] = "";
            if (info->needs.tree)
                snprintf(tree, sizeof tree, " LS(%d,%d)", sd.tree_n, sd.tree_d);
            pn_info("quality auto: %d/%d %s%s: MAE %.4f at the last step; %.1f s elapsed, about %.1f s left", done,
                    total, info->name, tree, mae, elapsed, elapsed / done * (total - done));
        }
    }
    if (r == PN_OK && !c.have) {
        pn_error("quality auto: no configuration could be set up (see the trees' memory limit, --max-memory)");
        r = PN_ERR_UNSUPPORTED;
    }
    if (r == PN_OK && out->within)
        r = runoff(dev, scene, cam, light, frame, max_bytes, out);
    if (r == PN_OK && !out->within)
        pn_warn("quality auto: no configuration reaches MAE %.4g within %d samples per pixel; taking the least "
                "error found (%.4f)",
                max_error, PN_QUALITY_MAX_SPP, out->pilot_mae);
    if (big.ready)
        out->confirm_width = big.sd.frame.width, out->confirm_height = big.sd.frame.height;
    if (sample.ready)
        out->frame_sample_width = sample.cells_w, out->frame_sample_height = sample.cells_h;
    pn_pilot_size_free(&pilot);
    pn_pilot_size_free(&big);
    pn_frame_sample_free(&sample);
    return r;
}
