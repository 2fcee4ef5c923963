// penumbra bench's matrix: per view and size, the converged reference (bench_reference.c), exact at
// every spp with its Embree peer, then every mode and tree at every spp, timed, with both errors;
// --work counters and --max-error checks of --quality auto.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/bench/bench.h"
#include "shadow/metrics.h"
#include "apps/quality.h"
#include "shadow/setup.h"
#include "core/log.h"
#include "core/timer.h"
#include "io/exr.h"

// Renders warm-up and timed frames; fills the timing fields of `row` and leaves the last frame's
// images in the renderer.
static pn_result time_frames_lights(const bench_opts *o, pn_renderer *r, const pn_camera *cam, const pn_light *lights,
                                    uint32_t light_count, bench_row *row)
{
    double g[1000], s[1000], f[1000], h[1000];
    pn_frame_times t;
    for (int i = 0; i < o->warmup; i++)
        if (pn_renderer_render_lights(r, cam, lights, light_count, &t) != PN_OK)
            return PN_ERR_VULKAN;
    for (int i = 0; i < o->repeat; i++) {
        if (pn_renderer_render_lights(r, cam, lights, light_count, &t) != PN_OK)
            return PN_ERR_VULKAN;
        g[i] = t.gbuffer_ms, s[i] = t.shadow_ms, f[i] = t.filter_ms, h[i] = t.shade_ms;
    }
    row->gbuffer_ms = pn_time_median(g, o->repeat);
    // Without a filter the interval between the shadow and shading passes holds no work, only the
    // timestamps' own overhead: 0, so that an unfiltered cell's time is its shadow pass.
    row->filter_ms = row->filter != PN_FILTER_NONE ? pn_time_median(f, o->repeat) : 0.0;
    row->shade_ms = pn_time_median(h, o->repeat);
    row->shadow_ms = pn_time_median(s, o->repeat); // sorts s
    row->shadow_min_ms = s[0];
    row->shadow_max_ms = s[o->repeat - 1];
    return PN_OK;
}

static pn_result time_frames(const bench_opts *o, pn_renderer *r, const pn_camera *cam, const pn_light *light,
                             bench_row *row)
{
    return time_frames_lights(o, r, cam, light, 1, row);
}

// Appends the `size` bytes at `item` to the array *items of *count elements, doubling its capacity
// *cap when full (from 16). False when out of memory; the array is then unchanged.
static bool append(void **items, int *count, int *cap, const void *item, size_t size)
{
    if (*count == *cap) {
        int grown = *cap ? 2 * *cap : 16;
        void *n = realloc(*items, (size_t)grown * size);
        if (!n)
            return false;
        *items = n;
        *cap = grown;
    }
    memcpy((char *)*items + (size_t)(*count)++ * size, item, size);
    return true;
}

static bool push_row(bench_rows *rows, const bench_row *r)
{
    if (!append((void **)&rows->rows, &rows->count, &rows->cap, r, sizeof *r))
        return false;
    pn_bench_print_row(r);
    return true;
}

static void tree_label(char *out, size_t n, int tn, int td, bool per_object)
{
    if (tn)
        snprintf(out, n, " LS(%d,%d)%s", tn, td, per_object ? " per object" : "");
    else
        out[0] = '\0';
}

// A cell's name in file names and the console: view_WxH_Sspp_mode[_filter][_LSn_d][_objects], with
// MIN-MAXspp for adaptive samples.
static void cell_label(char *out, size_t n, const bench_row *r)
{
    char spp[32];
    if (r->spp_min)
        snprintf(spp, sizeof spp, "%u-%u", r->spp_min, r->spp);
    else
        snprintf(spp, sizeof spp, "%u", r->spp);
    int len = snprintf(out, n, "%s_%ux%u_%sspp_%s%s", r->scene, r->width, r->height, spp, MODE_NAME(r->mode),
                       r->filter != PN_FILTER_NONE ? "_filter" : "");
    if (r->n && len > 0 && (size_t)len < n)
        snprintf(out + len, n - (size_t)len, "_LS%d_%d%s", r->n, r->d, r->per_object ? "_objects" : "");
}

// o->out_dir/PREFIX_LABEL.exr, with the characters a file name should not hold in the label replaced.
static void cell_path(char *out, size_t n, const bench_opts *o, const char *prefix, const char *label)
{
    snprintf(out, n, "%s/%s_%s.exr", o->out_dir, prefix, label);
    for (char *c = out + strlen(o->out_dir) + 1; *c; c++)
        if (*c == ':' || *c == '/' || *c == ',' || *c == ' ')
            *c = '_';
}

static bool push_quality(bench_rows *rows, const bench_quality *q)
{
    return append((void **)&rows->quality, &rows->quality_count, &rows->quality_cap, q, sizeof *q);
}

// Sets up one configuration of the matrix at full size for timing beside another.
static pn_result setup_config(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                              const pn_renderer_desc *frame, pn_shadow_mode mode, int n, int d, uint32_t spp,
                              uint32_t spp_min, float pixel_error, pn_setup *s)
{
    pn_setup_desc sd = {.frame = *frame, .tree_n = n, .tree_d = d, .view = cam};
    sd.frame.mode = mode;
    sd.frame.spp = spp;
    sd.frame.spp_min = spp_min;
    sd.frame.pixel_error = spp_min ? pixel_error : frame->pixel_error;
    sd.frame.dump_rays = false;
    return pn_setup_create(dev, scene, light, &sd, s);
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
static int check_quality(const bench_opts *o, pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                         const pn_light *light, const pn_renderer_desc *frame, const float *v_conv, const uint8_t *mask,
                         double budget, bench_rows *rows, int first_row)
{
    bench_quality bq = {.width = frame->width, .height = frame->height, .budget = budget};
    snprintf(bq.scene, sizeof bq.scene, "%s", rows->rows[first_row].scene);
    // --quality auto chooses among unfiltered configurations over the scene-wide tree, so the front
    // it is held to is those cells'.
    for (int i = first_row; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        if (r->filter == PN_FILTER_NONE && !r->per_object && r->ref.mae <= budget && (!bq.has_best || r->shadow_ms < bq.best_ms)) {
            bq.has_best = true;
            bq.best_mode = r->mode, bq.best_n = r->n, bq.best_d = r->d, bq.best_spp = r->spp;
            bq.best_spp_min = r->spp_min;
            bq.best_ms = r->shadow_ms, bq.best_mae = r->ref.mae;
        }
    }
    uint64_t t0 = pn_time_ns();
    if (pn_quality_choose(dev, scene, cam, light, frame, budget, 0, o->reference_spp, &bq.choice) != PN_OK) {
        pn_error("bench: %s: --quality auto at %g failed (see above)", bq.scene, budget);
        return PN_EXIT_FAILURE;
    }
    const pn_quality_choice *q = &bq.choice;
    bq.choose_ms = pn_ms_since(t0);
    bq.mode = q->mode, bq.n = q->tree_n, bq.d = q->tree_d, bq.spp = q->spp, bq.spp_min = q->spp_min;
    bq.pilot_mae = q->pilot_mae;
    // An adaptive pick is a cell only at the matrix's own pixel error.
    const bench_row *cell = NULL;
    for (int i = first_row; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        if (r->filter == PN_FILTER_NONE && !r->per_object && r->mode == q->mode && r->n == q->tree_n && r->d == q->tree_d &&
            r->spp == q->spp && r->spp_min == q->spp_min && (!q->spp_min || q->pixel_error == o->pixel_error))
            cell = r;
    }
    bool is_front = bq.has_best && cell && bq.best_mode == q->mode && bq.best_n == q->tree_n &&
                    bq.best_d == q->tree_d && bq.best_spp == q->spp && bq.best_spp_min == q->spp_min;
    if (cell) {
        bq.shadow_ms = cell->shadow_ms;
        bq.ref = cell->ref;
    }
    bq.pair_pick_ms = bq.pair_front_ms = bq.shadow_ms;
    // A pick that is the front's cell is timed already; one that is a cell with no front to beat
    // needs nothing more.
    if (!is_front && (bq.has_best || !cell)) {
        pn_setup ps, fs;
        if (setup_config(dev, scene, cam, light, frame, q->mode, q->tree_n, q->tree_d, q->spp, q->spp_min,
                         q->pixel_error, &ps) != PN_OK) {
            pn_error("bench: %s: --quality auto's pick cannot be set up at full size (see above)", bq.scene);
            return PN_EXIT_FAILURE;
        }
        bool ok = true;
        if (bq.has_best) {
            ok = setup_config(dev, scene, cam, light, frame, bq.best_mode, bq.best_n, bq.best_d, bq.best_spp,
                              bq.best_spp_min, o->pixel_error, &fs) ==
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
            ok = time_frames(o, &ps.renderer, cam, light, &row) == PN_OK;
            bq.pair_pick_ms = row.shadow_ms;
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
    tree_label(tree, sizeof tree, q->tree_n, q->tree_d, false);
    if (q->spp_min)
        snprintf(spp, sizeof spp, "%u:%u spp (pixel error %g)", q->spp_min, q->spp, (double)q->pixel_error);
    else
        snprintf(spp, sizeof spp, "%u spp", q->spp);
    printf("quality auto (max error %.4g): %s%s %s%s, shadow %.1f ms, reference MAE %.4f (pilot %.4f; chosen in "
           "%.1f s)",
           budget, MODE_NAME(q->mode), tree, spp, cell ? " (a cell of the matrix)" : "", bq.shadow_ms, bq.ref.mae,
           q->pilot_mae, bq.choose_ms * 1e-3);
    if (bq.has_best && bq.best_ms > 0) {
        tree_label(best_tree, sizeof best_tree, bq.best_n, bq.best_d, false);
        if (bq.best_spp_min)
            snprintf(best_spp, sizeof best_spp, "%u:%u", bq.best_spp_min, bq.best_spp);
        else
            snprintf(best_spp, sizeof best_spp, "%u", bq.best_spp);
        printf("; the matrix's fastest within the budget: %s%s %s spp %.1f ms (MAE %.4f); side by side auto takes "
               "%.2fx its time (%.1f / %.1f ms)\n",
               MODE_NAME(bq.best_mode), best_tree, best_spp, bq.best_ms, bq.best_mae,
               bq.pair_pick_ms / bq.pair_front_ms, bq.pair_pick_ms, bq.pair_front_ms);
    } else {
        printf("; no cell of the matrix meets the budget\n");
    }
    fflush(stdout);
    return PN_EXIT_OK;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

// --work: one frame with the counting build of the cell's shadow shader; the distribution of each
// counter over the pixels with geometry, and the counters as EXR layers.
static void report_work(const bench_opts *o, pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                        const pn_light *light, pn_setup_desc sd, const char *label)
{
    sd.frame.count_work = true;
    sd.frame.dump_rays = false;
    pn_setup s;
    if (pn_setup_create(dev, scene, light, &sd, &s) != PN_OK)
        return;
    pn_frame_times t;
    if ((!o->gbuffer || pn_renderer_set_gbuffer(&s.renderer, o->gb_p, o->gb_n) == PN_OK) &&
        pn_renderer_render(&s.renderer, cam, light, &t) == PN_OK) {
        const uint32_t *w = pn_renderer_work(&s.renderer);
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        size_t px = (size_t)sd.frame.width * sd.frame.height, n = 0;
        uint32_t *vals = malloc(px * sizeof *vals);
        float *planes = calloc(px * 4, sizeof *planes);
        static const char *const names[4] = {"work.nodes", "work.lookups", "work.triangles", "work.depth"};
        printf("  work of %s per pixel (p50 / p90 / p99 / max):", label);
        for (int c = 0; c < 4 && vals && planes; c++) {
            n = 0;
            for (size_t i = 0; i < px; i++) {
                // Background pixels trace nothing and their counters are never written (the
                // buffer is not cleared): 0 there.
                bool geometry = img.p[4 * i + 3] > 0;
                planes[c * px + i] = geometry ? (float)w[4 * i + c] : 0.0f;
                if (geometry)
                    vals[n++] = w[4 * i + c];
            }
            qsort(vals, n, sizeof *vals, cmp_u32);
            if (n)
                printf(" %s %u/%u/%u/%u", names[c] + 5, vals[n / 2], vals[(size_t)(0.9 * (double)(n - 1))],
                       vals[(size_t)(0.99 * (double)(n - 1))], vals[n - 1]);
        }
        printf("\n");
        if (vals && planes) {
            char path[4096];
            cell_path(path, sizeof path, o, "work", label);
            pn_exr_channel ch[4];
            for (int c = 0; c < 4; c++)
                ch[c] = (pn_exr_channel){names[c], planes + c * px};
            pn_exr_write(path, (int)sd.frame.width, (int)sd.frame.height, ch, 4, NULL, 0);
        }
        free(vals);
        free(planes);
    }
    pn_setup_destroy(dev, &s);
}

// One configuration (a mode and tree) with every filter at every spp of the matrix over one set-up:
// a row per filter and spp with both errors. v_exact holds exact's V per filter and spp (the bias
// reference: exact with the same samples and the same filter), which exact itself stores there.
// exact_ms per filter and spp, embree_ms per spp (0: no peer).
typedef struct group {
    const bench_opts *o;
    pn_gpu_device *dev;
    const pn_scene *scene;
    const pn_camera *cam;
    const pn_light *light;
    bench_row base;
    pn_renderer_desc frame;
    const float *v_conv;
    const uint8_t *mask;
    uint64_t covered;
    float *v_exact;
    double exact_ms[2 * MAX_LIST], embree_ms[MAX_LIST];
    pn_embree_scene *rtc; // traces exact's rays
    double move_ms;             // the configuration's (bench_row.move_ms)
} group;

// A filtered cell's edge leak (metrics.h); with --edge-images also its EXR of V, V_raw, the
// reference and the edge classes, to look at where the error grew.
static bool measure_edges(const group *g, const pn_frame_images *img, bench_row *row, double pixel_angle)
{
    uint32_t w = g->frame.width, h = g->frame.height;
    size_t px = (size_t)w * h;
    uint8_t *cls = g->o->edge_images ? malloc(px) : NULL;
    // The edge classes, then the filter's inputs (P, N, view depth, valid rays, penumbra width), so
    // that the filter can be reproduced from the file.
    enum { PLANES = 10 };
    float *plane = cls ? malloc(PLANES * px * sizeof *plane) : NULL;
    bool ok = (!g->o->edge_images || (cls && plane)) &&
              pn_edge_leak_measure(img->p, img->n, img->v, img->v_raw, g->v_conv, w, h, pixel_angle, cls, &row->edge);
    if (ok && plane) {
        for (size_t i = 0; i < px; i++) {
            plane[i] = cls[i];
            for (int c = 0; c < 3; c++) {
                plane[(1 + c) * px + i] = img->p[4 * i + c];
                plane[(4 + c) * px + i] = img->n[4 * i + c];
            }
            plane[7 * px + i] = img->n[4 * i + 3];
            plane[8 * px + i] = (float)img->counts[4 * i + 1];
            memcpy(&plane[9 * px + i], &img->counts[4 * i + 3], sizeof(float));
        }
        char label[512], path[4096];
        cell_label(label, sizeof label, row);
        cell_path(path, sizeof path, g->o, "edge", label);
        static const char *const names[PLANES] = {"edge", "P.X", "P.Y", "P.Z", "N.X",
                                                  "N.Y",  "N.Z", "Z",   "shadow.valid", "shadow.penumbra"};
        pn_exr_channel ch[3 + PLANES] = {{"shadow.V", img->v}, {"shadow.V_raw", img->v_raw}, {"reference.V", g->v_conv}};
        for (int c = 0; c < PLANES; c++)
            ch[3 + c] = (pn_exr_channel){names[c], plane + c * px};
        ok = pn_exr_write(path, (int)w, (int)h, ch, 3 + PLANES, NULL, 0) == PN_OK;
    }
    free(cls);
    free(plane);
    return ok;
}

// One cell: the set-up `s` (its filter already set) at the fi-th filter and pi-th spp, timed, with
// both errors and, filtered, the leak across edges. `sd` describes the set-up (for --work).
static int run_cell(group *g, pn_setup *s, pn_setup_desc *sd, int fi, int pi, double pixel_angle, bench_rows *rows,
                    bool push)
{
    const bench_opts *o = g->o;
    size_t px = (size_t)g->frame.width * g->frame.height;
    pn_shadow_mode mode = sd->frame.mode;
    bool exact = mode == PN_SHADOW_REFERENCE;
    uint32_t spp = o->spps[pi], spp_min = o->spp_mins[pi];
    int ci = fi * o->spp_count + pi; // the cell's place among the filters' spp
    sd->frame.spp = spp;
    sd->frame.spp_min = spp_min, sd->frame.pixel_error = o->pixel_error;
    // Adaptive cells trace no ray dump (each pixel its own count): the dump goes off first.
    if ((sd->frame.dump_rays && pn_renderer_set_dump_rays(&s->renderer, false) != PN_OK) ||
        pn_renderer_set_adaptive(&s->renderer, spp_min, spp, o->pixel_error) != PN_OK ||
        (ci == 0 && o->gbuffer && pn_renderer_set_gbuffer(&s->renderer, o->gb_p, o->gb_n) != PN_OK))
        return PN_EXIT_FAILURE;
    bench_row row = g->base;
    row.spp = spp;
    row.spp_min = spp_min;
    row.mode = mode;
    row.n = sd->tree_n, row.d = sd->tree_d;
    row.per_object = sd->per_object;
    row.filter = sd->frame.filter;
    if (row.filter != PN_FILTER_NONE)
        row.tile_w = pn_filter_tile(sd->frame.tile_w), row.tile_h = pn_filter_tile(sd->frame.tile_h);
    // Timed without the ray dump (off above), whose writes would slow the frames down.
    if (time_frames(o, &s->renderer, g->cam, g->light, &row) != PN_OK)
        return PN_EXIT_FAILURE;
    pn_frame_images img;
    pn_renderer_images(&s->renderer, &img);
    row.mean_rays = spp;
    row.beyond_2se = -1;
    if (img.rays) {
        double rays = 0;
        size_t beyond = 0, compared = 0;
        const float *v_raw = img.v_raw ? img.v_raw : img.v;
        for (size_t i = 0; i < px; i++) {
            rays += img.rays[4 * i];
            if (!g->mask[i])
                continue;
            float se;
            memcpy(&se, &img.rays[4 * i + 1], sizeof se);
            compared++;
            beyond += fabsf(v_raw[i] - g->v_conv[i]) > 2.0f * se;
        }
        row.mean_rays = g->covered ? rays / (double)g->covered : 0;
        row.beyond_2se = compared ? (double)beyond / (double)compared : 0;
        fprintf(stderr, "bench: adaptive %u:%u: %.2f rays per pixel; %.2f%% of pixels off the reference by more than "
                        "2 estimated standard errors\n",
                spp_min, spp, row.mean_rays, 100.0 * row.beyond_2se);
    }
    float *same = g->v_exact + (size_t)ci * px; // exact with this filter and spp
    if (exact) {
        memcpy(same, img.v, px * sizeof *same);
        g->exact_ms[ci] = pn_bench_row_ms(&row);
    }
    // Embree traces the first filter's rays: their number, which is what its time depends on, is the
    // same with every filter.
    if (exact && sd->frame.dump_rays && fi == 0 && !spp_min) {
        // One more frame with the dump for Embree: the same rays (the frame is deterministic).
        pn_frame_times t;
        uint64_t floats;
        if (pn_renderer_set_dump_rays(&s->renderer, true) != PN_OK ||
            pn_renderer_render(&s->renderer, g->cam, g->light, &t) != PN_OK)
            return PN_EXIT_FAILURE;
        g->embree_ms[pi] = pn_bench_embree_time(o, g->rtc, pn_renderer_ray_dump(&s->renderer, &floats), px, spp);
        pn_renderer_images(&s->renderer, &img);
    }
    row.build_ms = s->build_ms;
    row.move_ms = g->move_ms;
    row.pool_mb = pn_shadow_accel_gpu_bytes(&s->accel) / 1048576.0; // with per-object trees' top level
    row.rays_per_s = img.rays ? (row.shadow_ms > 0 ? row.mean_rays * (double)g->covered / (row.shadow_ms * 1e-3) : 0)
                              : pn_shadow_rays_per_s(g->covered, spp, g->light, row.shadow_ms);
    row.vs_exact = g->exact_ms[ci] > 0 ? pn_bench_row_ms(&row) / g->exact_ms[ci] : 0;
    row.embree_ms = g->embree_ms[pi];
    row.vs_embree = row.embree_ms > 0 ? pn_bench_row_ms(&row) / row.embree_ms : 0;
    if (!pn_error_compare(img.v, g->v_conv, g->mask, px, NULL, &row.ref) ||
        !pn_error_compare(img.v, same, g->mask, px, NULL, &row.bias))
        return PN_EXIT_FAILURE;
    if (row.filter != PN_FILTER_NONE && !measure_edges(g, &img, &row, pixel_angle))
        return PN_EXIT_FAILURE;
    if (push && !push_row(rows, &row))
        return PN_EXIT_FAILURE;
    if (o->work) {
        char label[512];
        cell_label(label, sizeof label, &row);
        report_work(o, g->dev, g->scene, g->cam, g->light, *sd, label);
    }
    return PN_EXIT_OK;
}

// What moving one object costs the set-up's acceleration structures (bench_row.move_ms): per-object
// trees rebuild their top level from the objects' transforms and upload it, the same work whether
// an object moved or not (pn_objects_update recomputes every instance), so it is timed on the scene
// as it stands, the least of a few runs; every other structure is rebuilt whole.
static pn_result time_move(group *g, pn_setup *s, double *ms)
{
    if (!s->accel.desc.per_object) {
        *ms = s->build_ms;
        return PN_OK;
    }
    *ms = INFINITY;
    for (int i = 0; i < 3; i++) {
        uint64_t t0 = pn_time_ns();
        PN_TRY(pn_objects_update(g->scene, &s->accel.objects));
        PN_TRY(pn_gpu_objects_update(g->dev, &s->accel.objects, &s->accel.gpu_objects));
        double t = pn_ms_since(t0);
        *ms = t < *ms ? t : *ms;
    }
    return PN_OK;
}

static int run_config(group *g, pn_shadow_mode mode, int tn, int td, bool per_object, bench_rows *rows, bool push)
{
    const bench_opts *o = g->o;
    bool exact = mode == PN_SHADOW_REFERENCE;
    pn_setup s;
    pn_setup_desc sd = {.frame = g->frame, .tree_n = tn, .tree_d = td, .per_object = per_object,
                        .view = o->gbuffer ? NULL : g->cam}; // the tree models what the picture needs
    sd.frame.mode = mode;
    sd.frame.spp = o->spps[o->spp_count - 1]; // the most: the ray dump holds that many rays per pixel
    sd.frame.dump_rays = exact && g->rtc;
    char cell[64];
    tree_label(cell, sizeof cell, tn, td, per_object);
    fprintf(stderr, "bench: %s %ux%u %s%s\n", g->base.scene, g->frame.width, g->frame.height, MODE_NAME(mode), cell);
    if (pn_setup_create(g->dev, g->scene, g->light, &sd, &s) != PN_OK) {
        if (exact)
            return PN_EXIT_FAILURE;
        pn_warn("bench: %s%s skipped (see above)", MODE_NAME(mode), cell);
        return PN_EXIT_OK;
    }
    int rc = PN_EXIT_OK;
    // Timed before the cells, which then report it: the top level rebuilt from the same transforms
    // is the one built with the trees.
    if (time_move(g, &s, &g->move_ms) != PN_OK) {
        pn_error("bench: %s%s: the top level's rebuild failed", MODE_NAME(mode), cell);
        pn_setup_destroy(g->dev, &s);
        return PN_EXIT_FAILURE;
    }
    double pixel_angle = 2.0 * tan(0.5 * g->cam->yfov_deg * 3.14159265358979323846 / 180.0) / g->frame.height;
    for (int fi = 0; fi < o->filter_count && rc == PN_EXIT_OK; fi++) {
        pn_filter filter = o->filters[fi];
        if (pn_renderer_set_filter(&s.renderer, filter, o->tile_w, o->tile_h) != PN_OK) {
            rc = PN_EXIT_FAILURE;
            break;
        }
        sd.frame.filter = filter, sd.frame.tile_w = o->tile_w, sd.frame.tile_h = o->tile_h;
        for (int pi = 0; pi < o->spp_count && rc == PN_EXIT_OK; pi++)
            rc = run_cell(g, &s, &sd, fi, pi, pixel_angle, rows, push);
    }
    pn_setup_destroy(g->dev, &s);
    return rc;
}

// --lights: the view's light turned about the vertical (+Y) axis through `centre` in k even steps,
// light i with 2^-i of the first's radiance and all together with the one light's (so the set
// lights the scene about as brightly as it): a bright light and dimmer ones, as real sets are, so
// that a budgeted split has shares to follow.
static void light_set(const pn_light *light, const float centre[3], uint32_t k, pn_light *out)
{
    double weights = 2.0 - ldexp(1.0, 1 - (int)k); // sum of 2^-i, i < k
    for (uint32_t i = 0; i < k; i++) {
        double a = 2.0 * 3.14159265358979323846 * i / k, c = cos(a), s = sin(a);
        pn_light *l = &out[i];
        *l = *light;
        // Rotation about +Y: (x, z) -> (c x + s z, -s x + c z), positions about the centre.
        float dx = light->pos[0] - centre[0], dz = light->pos[2] - centre[2];
        l->pos[0] = centre[0] + (float)(c * dx + s * dz);
        l->pos[2] = centre[2] + (float)(-s * dx + c * dz);
        const float *v[2] = {light->normal, light->up};
        float *w[2] = {l->normal, l->up};
        for (int j = 0; j < 2; j++) {
            w[j][0] = (float)(c * v[j][0] + s * v[j][2]);
            w[j][2] = (float)(-s * v[j][0] + c * v[j][2]);
        }
        for (int ch = 0; ch < 3; ch++)
            l->radiance[ch] = (float)(light->radiance[ch] * ldexp(1.0, -(int)i) / weights);
    }
}

static bool push_light_row(bench_rows *rows, const bench_light_row *r)
{
    if (!append((void **)&rows->lights, &rows->light_count, &rows->light_cap, r, sizeof *r))
        return false;
    pn_bench_print_light_row(r);
    return true;
}

// The converged reference of a set of lights: exact, --reference-spp rays per light and pixel,
// stratified, a seed no measured frame uses, the even split, no filter. Its radiance (rgba per pixel)
// into `out`; not cached on disk (bench_reference.c caches one light's V).
static pn_result lights_reference(const group *g, const pn_light *set, uint32_t k, float *out)
{
    pn_setup s;
    pn_setup_desc sd = {.frame = {.width = g->frame.width, .height = g->frame.height, .mode = PN_SHADOW_REFERENCE,
                                  .sampler = PN_SAMPLER_STRATIFIED, .spp = g->o->reference_spp,
                                  .seed = PN_REFERENCE_SEED},
                        .light_count = k};
    uint64_t t0 = pn_time_ns();
    PN_TRY(pn_setup_create(g->dev, g->scene, set, &sd, &s));
    pn_frame_times t;
    pn_result r = pn_renderer_render_lights(&s.renderer, g->cam, set, k, &t);
    if (r == PN_OK) {
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        memcpy(out, img.radiance, (size_t)g->frame.width * g->frame.height * 4 * sizeof *out);
        fprintf(stderr, "bench: %s %ux%u: converged reference of %u lights (exact, %u spp per light) in %.1f s\n",
                g->base.scene, g->frame.width, g->frame.height, k, g->o->reference_spp, pn_ms_since(t0) * 1e-3);
    }
    pn_setup_destroy(g->dev, &s);
    return r;
}

// The last frame's radiance against the reference (bench_light_row's mae_rel, rmse_rel).
static void lights_error(const pn_renderer *r, const float *ref, bench_light_row *row)
{
    pn_frame_images img;
    pn_renderer_images(r, &img);
    size_t px = (size_t)r->width * r->height, n = 0;
    double ae = 0, se = 0, level = 0;
    for (size_t i = 0; i < px; i++) {
        if (!(ref[4 * i + 3] > 0))
            continue;
        double want = (double)ref[4 * i] + ref[4 * i + 1] + ref[4 * i + 2];
        double d = (double)img.radiance[4 * i] + img.radiance[4 * i + 1] + img.radiance[4 * i + 2] - want;
        ae += fabs(d), se += d * d, level += want;
        n++;
    }
    row->has_error = n > 0 && level > 0;
    row->mae_rel = row->has_error ? ae / level : 0;
    row->rmse_rel = row->has_error ? sqrt(se / (double)n) / (level / (double)n) : 0;
}

// --lights for one configuration: per light count, a set-up whose tree is built for that set, and
// frames of all its lights timed as the matrix times its cells, with the even split and (several
// lights, stratified sampler) the budgeted one. refs[li]: light count li's reference radiance, or
// NULL (--gbuffer).
static int run_lights(const group *g, const float centre[3], pn_shadow_mode mode, int tn, int td,
                      float *const *refs, bench_rows *rows)
{
    const bench_opts *o = g->o;
    double one_ms = 0;
    for (int li = 0; li < o->light_count_count; li++) {
        uint32_t k = o->light_counts[li];
        pn_light set[PN_MAX_LIGHTS];
        light_set(g->light, centre, k, set);
        pn_setup_desc sd = {.frame = g->frame, .tree_n = tn, .tree_d = td, .light_count = k,
                            .view = o->gbuffer ? NULL : g->cam};
        sd.frame.mode = mode;
        sd.frame.spp = o->spps[0];
        sd.frame.filter = o->filters[0], sd.frame.tile_w = o->tile_w, sd.frame.tile_h = o->tile_h;
        pn_setup s;
        if (pn_setup_create(g->dev, g->scene, set, &sd, &s) != PN_OK)
            return PN_EXIT_FAILURE;
        bench_row t = {.filter = sd.frame.filter};
        bench_light_row r = {0};
        bool ok = (!o->gbuffer || pn_renderer_set_gbuffer(&s.renderer, o->gb_p, o->gb_n) == PN_OK) &&
                  time_frames_lights(o, &s.renderer, g->cam, set, k, &t) == PN_OK;
        if (ok && refs[li])
            lights_error(&s.renderer, refs[li], &r); // the set's last frame, before the single lights'
        // Each light of the set alone, on the same set-up: what k separate frames would cost.
        double sum_ms = 0;
        for (uint32_t i = 0; i < k && ok; i++) {
            bench_row ti = {.filter = sd.frame.filter};
            ok = time_frames_lights(o, &s.renderer, g->cam, &set[i], 1, &ti) == PN_OK;
            sum_ms += ti.gbuffer_ms + ti.shadow_ms + ti.filter_ms + ti.shade_ms;
        }
        r.width = g->frame.width, r.height = g->frame.height, r.spp = sd.frame.spp, r.mode = mode, r.n = tn, r.d = td;
        r.filter = sd.frame.filter, r.lights = k, r.build_ms = s.build_ms, r.culled = s.accel.tree.culled;
        r.pool_mb = pn_shadow_accel_gpu_bytes(&s.accel) / 1048576.0;
        r.shadow_ms = t.shadow_ms, r.shade_ms = t.shade_ms;
        snprintf(r.scene, sizeof r.scene, "%s", g->base.scene);
        r.frame_ms = t.gbuffer_ms + t.shadow_ms + t.filter_ms + t.shade_ms;
        if (k == 1)
            one_ms = r.frame_ms;
        r.vs_one = one_ms > 0 ? r.frame_ms / one_ms : 0;
        r.vs_sum = sum_ms > 0 ? r.frame_ms / sum_ms : 0;
        ok = ok && push_light_row(rows, &r);
        // The budgeted split over the same set-up and rays per pixel: it needs the stratified sampler
        // and no filter (one light alone gets the whole budget: the even split).
        if (ok && k > 1 && sd.frame.sampler == PN_SAMPLER_STRATIFIED) {
            bench_light_row b = r;
            bench_row tb = {.filter = PN_FILTER_NONE};
            ok = pn_renderer_set_filter(&s.renderer, PN_FILTER_NONE, o->tile_w, o->tile_h) == PN_OK &&
                 pn_renderer_set_split(&s.renderer, PN_SPLIT_BUDGET) == PN_OK &&
                 time_frames_lights(o, &s.renderer, g->cam, set, k, &tb) == PN_OK;
            b.split = PN_SPLIT_BUDGET, b.filter = PN_FILTER_NONE, b.has_error = false;
            if (ok && refs[li])
                lights_error(&s.renderer, refs[li], &b);
            b.shadow_ms = tb.shadow_ms, b.shade_ms = tb.shade_ms;
            b.frame_ms = tb.gbuffer_ms + tb.shadow_ms + tb.filter_ms + tb.shade_ms;
            b.vs_one = one_ms > 0 ? b.frame_ms / one_ms : 0;
            b.vs_sum = sum_ms > 0 ? b.frame_ms / sum_ms : 0;
            ok = ok && push_light_row(rows, &b);
        }
        pn_setup_destroy(g->dev, &s);
        if (!ok)
            return PN_EXIT_FAILURE;
    }
    return PN_EXIT_OK;
}

// One view: per size its converged reference, exact at every spp (the bias reference, and Embree's
// rays), then every other mode and tree at every spp.
int pn_bench_view(const bench_opts *o, pn_gpu_device *dev, pn_embree *rtc, const bench_view *view,
                  bench_rows *rows)
{
    pn_prepared_scene prep;
    int prc = pn_bench_view_prepare(view, &prep);
    if (prc != PN_EXIT_OK)
        return prc;
    pn_scene scene = prep.scene;
    pn_camera cam = prep.camera;
    pn_light light = prep.lights[0];
    pn_embree_scene *rs = rtc ? pn_embree_scene_create(rtc, &scene) : NULL;
    int rc = PN_EXIT_OK;
    bool want_exact = false;
    for (int m = 0; m < o->mode_count; m++)
        want_exact = want_exact || o->modes[m] == PN_SHADOW_REFERENCE;
    for (int si = 0; si < o->size_count && rc == PN_EXIT_OK; si++) {
        uint32_t w = o->sizes[si][0], h = o->sizes[si][1];
        size_t px = (size_t)w * h;
        group g = {.o = o, .dev = dev, .scene = &scene, .cam = &cam, .light = &light, .rtc = rs,
                   .frame = {.width = w, .height = h, .traversal = o->traversal, .sampler = o->sampler,
                             .seed = o->seed}};
        g.base = (bench_row){.width = w, .height = h, .triangles = pn_scene_triangle_count(&scene)};
        snprintf(g.base.scene, sizeof g.base.scene, "%s", view->name);
        float *v_conv = malloc(px * sizeof *v_conv);
        uint8_t *mask = malloc(px);
        g.v_exact = malloc(px * (size_t)(o->filter_count * o->spp_count) * sizeof *g.v_exact);
        if (!v_conv || !mask || !g.v_exact ||
            pn_bench_reference(o, dev, &scene, view->name, &cam, &light, w, h, v_conv, mask) != PN_OK) {
            free(v_conv), free(mask), free(g.v_exact);
            rc = PN_EXIT_FAILURE;
            break;
        }
        g.v_conv = v_conv;
        g.mask = mask;
        for (size_t i = 0; i < px; i++)
            g.covered += mask[i];
        int first_row = rows->count; // this group's rows start here
        rc = run_config(&g, PN_SHADOW_REFERENCE, 0, 0, false, rows, want_exact);
        for (int m = 0; m < o->mode_count && rc == PN_EXIT_OK; m++) {
            const pn_shadow_mode_info *info = pn_shadow_mode_get(o->modes[m]);
            const char *lack;
            if (o->modes[m] == PN_SHADOW_REFERENCE)
                continue;
            if (!pn_shadow_mode_available(dev, o->modes[m], &lack)) {
                if (si == 0)
                    pn_warn("bench: %s skipped: %s lacks %s", info->name, dev->props.deviceName, lack);
                continue;
            }
            // A mode without a tree is one configuration; a tree mode one per tree and tree kind
            // (per-object trees serve linespace alone).
            for (int kind = PN_TREE_KIND_SCENE; kind <= PN_TREE_KIND_OBJECT && rc == PN_EXIT_OK; kind++) {
                bool per_object = kind == PN_TREE_KIND_OBJECT;
                if (!info->needs.tree) {
                    if (kind == PN_TREE_KIND_SCENE)
                        rc = run_config(&g, o->modes[m], 0, 0, false, rows, true);
                    continue;
                }
                if (!o->kinds[kind])
                    continue;
                if (per_object && !info->objects) {
                    if (si == 0)
                        pn_warn("bench: %s has no per-object trees (they serve linespace alone)", info->name);
                    continue;
                }
                for (int ti = 0; ti < o->tree_count && rc == PN_EXIT_OK; ti++)
                    rc = run_config(&g, o->modes[m], o->trees[ti][0], o->trees[ti][1], per_object, rows, true);
            }
        }
        float centre[3];
        for (int k = 0; k < 3; k++)
            centre[k] = 0.5f * (prep.object_min[k] + prep.object_max[k]);
        // --lights: each set's converged reference (not with --gbuffer: its albedo is black, so
        // there is no radiance to compare), then exact and every mode available with its first tree.
        float *refs[MAX_LIST] = {0};
        for (int li = 0; li < o->light_count_count && rc == PN_EXIT_OK && !o->gbuffer; li++) {
            pn_light set[PN_MAX_LIGHTS];
            light_set(&light, centre, o->light_counts[li], set);
            refs[li] = malloc(px * 4 * sizeof *refs[li]);
            if (!refs[li] || lights_reference(&g, set, o->light_counts[li], refs[li]) != PN_OK)
                rc = PN_EXIT_FAILURE;
        }
        for (int m = -1; m < o->mode_count && rc == PN_EXIT_OK && o->light_count_count; m++) {
            pn_shadow_mode mode = m < 0 ? PN_SHADOW_REFERENCE : o->modes[m];
            const pn_shadow_mode_info *info = pn_shadow_mode_get(mode);
            const char *lack;
            if ((m >= 0 && mode == PN_SHADOW_REFERENCE) || !pn_shadow_mode_available(dev, mode, &lack))
                continue;
            rc = run_lights(&g, centre, mode, info->needs.tree ? o->trees[0][0] : 0,
                            info->needs.tree ? o->trees[0][1] : 0, refs, rows);
        }
        for (int li = 0; li < o->light_count_count; li++)
            free(refs[li]);
        if (o->gbuffer && o->max_error_count)
            pn_warn("bench: --max-error is not checked with --gbuffer (--quality auto renders its own G-buffer)");
        for (int b = 0; b < o->max_error_count && rc == PN_EXIT_OK && !o->gbuffer && rows->count > first_row; b++)
            rc = check_quality(o, dev, &scene, &cam, &light, &g.frame, v_conv, mask, o->max_errors[b], rows, first_row);
        free(v_conv);
        free(mask);
        free(g.v_exact);
    }
    if (rs)
        pn_embree_scene_destroy(rs);
    pn_scene_destroy(&scene);
    return rc;
}
