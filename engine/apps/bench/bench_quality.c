// penumbra bench --max-error: --quality auto's pick at each budget against the matrix's front, at
// full size against the converged reference, the two timed side by side.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/bench/bench.h"
#include "core/log.h"
#include "core/timer.h"
#include "shadow/quality.h"

static bool push_quality(bench_rows *rows, const bench_quality *q)
{
    return pn_bench_append((void **)&rows->quality, &rows->quality_count, &rows->quality_cap, q, sizeof *q);
}

// The pick and the front's cell are timed side by side (pn_quality_time_side_by_side), the least of
// this many frames each: the matrix timed them minutes apart, and the machine's load in between
// moves a time by more than two configurations on the front differ (seen under CI: the same
// traversal at 28 and 47 ms).
enum { QUALITY_ROUNDS = 5 };

// --quality auto against the matrix at one budget: the configuration it picks from its pilots, at
// full size against the converged reference, next to the fastest cell of this group within the
// budget. The pick's error is its cell's when it is one (same pixels, samples and reference);
// another pick is rendered here. The pick and the front's cell are then timed side by side. An exit
// code; a failure is logged.
int pn_bench_check_quality(const bench_opts *o, pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                           const pn_light *light, const pn_renderer_desc *frame, const float *v_conv, const uint8_t *mask,
                         double budget, bench_rows *rows, int first_row)
{
    bench_quality bq = {.width = frame->width, .height = frame->height, .budget = budget};
    snprintf(bq.scene, sizeof bq.scene, "%s", rows->rows[first_row].scene);
    // --quality auto chooses among configurations over the scene-wide tree, unfiltered or with the
    // penumbra filter where the matrix has that axis (it is then allowed to choose it), so the front
    // it is held to is those cells', each at its shadow and filter passes' time.
    bool penumbra = false;
    for (int i = 0; i < o->filter_count; i++)
        penumbra = penumbra || o->filters[i] == PN_FILTER_PENUMBRA;
    pn_renderer_desc qframe = *frame;
    qframe.filter = penumbra ? PN_FILTER_PENUMBRA : PN_FILTER_NONE;
    qframe.tile_w = o->tile_w, qframe.tile_h = o->tile_h;
    for (int i = first_row; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        // Auto climbs adaptive samples unfiltered only (quality.c).
        bool choosable = r->filter == PN_FILTER_NONE || (penumbra && r->filter == PN_FILTER_PENUMBRA && !r->spp_min);
        double ms = r->shadow_ms + r->filter_ms;
        if (choosable && !r->per_object && r->ref.mae <= budget && (!bq.has_best || ms < bq.best_ms)) {
            bq.has_best = true;
            bq.best_mode = r->mode, bq.best_n = r->n, bq.best_d = r->d, bq.best_spp = r->spp;
            bq.best_spp_min = r->spp_min, bq.best_filter = r->filter;
            bq.best_ms = ms, bq.best_mae = r->ref.mae;
        }
    }
    uint64_t t0 = pn_time_ns();
    if (pn_quality_choose(dev, scene, cam, light, &qframe, budget, 0, o->reference_spp, false, &bq.choice) != PN_OK) {
        pn_error("bench: %s: --quality auto at %g failed (see above)", bq.scene, budget);
        return PN_EXIT_FAILURE;
    }
    const pn_quality_choice *q = &bq.choice;
    bq.choose_ms = pn_ms_since(t0);
    bq.mode = q->mode, bq.n = q->tree_n, bq.d = q->tree_d, bq.spp = q->spp, bq.spp_min = q->spp_min;
    bq.filter = q->filter;
    bq.pilot_mae = q->pilot_mae;
    // An adaptive pick is a cell only at the matrix's own pixel error.
    const bench_row *cell = NULL;
    for (int i = first_row; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        if (r->filter == q->filter && !r->per_object && r->mode == q->mode && r->n == q->tree_n && r->d == q->tree_d &&
            r->spp == q->spp && r->spp_min == q->spp_min && (!q->spp_min || q->pixel_error == o->pixel_error))
            cell = r;
    }
    bool is_front = bq.has_best && cell && bq.best_mode == q->mode && bq.best_n == q->tree_n &&
                    bq.best_d == q->tree_d && bq.best_spp == q->spp && bq.best_spp_min == q->spp_min &&
                    bq.best_filter == q->filter;
    if (cell) {
        bq.shadow_ms = cell->shadow_ms + cell->filter_ms;
        bq.ref = cell->ref;
    }
    bq.pair_pick_ms = bq.pair_front_ms = bq.shadow_ms;
    // A pick that is the front's cell is timed already; one that is a cell with no front to beat
    // needs nothing more.
    if (!is_front && (bq.has_best || !cell)) {
        pn_setup ps, fs;
        if (pn_bench_setup_config(dev, scene, cam, light, &qframe, q->mode, q->tree_n, q->tree_d, q->spp, q->spp_min,
                         q->pixel_error, q->filter, &ps) != PN_OK) {
            pn_error("bench: %s: --quality auto's pick cannot be set up at full size (see above)", bq.scene);
            return PN_EXIT_FAILURE;
        }
        bool ok = true;
        if (bq.has_best) {
            ok = pn_bench_setup_config(dev, scene, cam, light, &qframe, bq.best_mode, bq.best_n, bq.best_d, bq.best_spp,
                              bq.best_spp_min, o->pixel_error, bq.best_filter, &fs) ==
                 PN_OK;
            if (ok) {
                pn_renderer *pair[2] = {&ps.renderer, &fs.renderer};
                double ms[2];
                ok = pn_quality_time_side_by_side(pair, 2, o->warmup, QUALITY_ROUNDS, cam, light, ms) == PN_OK;
                bq.pair_pick_ms = ms[0], bq.pair_front_ms = ms[1];
                pn_setup_destroy(dev, &fs);
            }
        } else {
            bench_row row = {0};
            row.filter = q->filter;
            ok = pn_bench_time_frames(o, &ps.renderer, cam, light, 1, &row) == PN_OK;
            bq.pair_pick_ms = row.shadow_ms + row.filter_ms;
        }
        if (ok && !cell) {
            pn_frame_images img;
            pn_renderer_images(&ps.renderer, &img);
            ok = pn_error_compare(img.v, v_conv, mask, (size_t)frame->width * frame->height, NULL, &bq.ref);
            bq.shadow_ms = bq.pair_pick_ms;
        }
        pn_setup_destroy(dev, &ps);
        if (!ok) {
            pn_error("bench: %s: --quality auto's pick or the front's cell failed to render", bq.scene);
            return PN_EXIT_FAILURE;
        }
    }
    if (!push_quality(rows, &bq))
        return PN_EXIT_FAILURE;
    char tree[32], best_tree[32], spp[48], best_spp[48];
    pn_bench_tree_label(tree, sizeof tree, q->tree_n, q->tree_d, false);
    if (q->spp_min)
        snprintf(spp, sizeof spp, "%u:%u spp (pixel error %g)", q->spp_min, q->spp, (double)q->pixel_error);
    else
        snprintf(spp, sizeof spp, "%u spp", q->spp);
    printf("quality auto (max error %.4g): %s%s %s%s%s, shadow%s %.1f ms, reference MAE %.4f (pilot %.4f; chosen "
           "in %.1f s)",
           budget, MODE_NAME(q->mode), tree, spp, q->filter != PN_FILTER_NONE ? " penumbra-filtered" : "",
           cell ? " (a cell of the matrix)" : "", q->filter != PN_FILTER_NONE ? " and filter" : "", bq.shadow_ms,
           bq.ref.mae, q->pilot_mae, bq.choose_ms * 1e-3);
    if (bq.has_best && bq.best_ms > 0) {
        pn_bench_tree_label(best_tree, sizeof best_tree, bq.best_n, bq.best_d, false);
        if (bq.best_spp_min)
            snprintf(best_spp, sizeof best_spp, "%u:%u", bq.best_spp_min, bq.best_spp);
        else
            snprintf(best_spp, sizeof best_spp, "%u", bq.best_spp);
        printf("; the matrix's fastest within the budget: %s%s %s spp%s %.1f ms (MAE %.4f); side by side auto takes "
               "%.2fx its time (%.1f / %.1f ms)\n",
               MODE_NAME(bq.best_mode), best_tree, best_spp, bq.best_filter != PN_FILTER_NONE ? " penumbra-filtered" : "",
               bq.best_ms, bq.best_mae,
               bq.pair_pick_ms / bq.pair_front_ms, bq.pair_pick_ms, bq.pair_front_ms);
    } else {
        printf("; no cell of the matrix meets the budget\n");
    }
    fflush(stdout);
    return PN_EXIT_OK;
}
