// penumbra bench's matrix: per view and size, the converged reference (bench_reference.c), exact at
// every spp with its Embree peer, then every mode and tree at every spp, timed, with both errors,
// and the --work counters; then the --lights rows (bench_lights.c) and the --max-error checks of
// --quality auto (bench_quality.c).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "accel/alpha.h"
#include "apps/bench/bench.h"
#include "shadow/metrics.h"
#include "shadow/quality.h"
#include "shadow/setup.h"
#include "core/log.h"
#include "core/timer.h"
#include "io/exr.h"

static pn_result time_frames(const bench_opts *o, pn_renderer *r, const pn_camera *cam, const pn_light *light,
                             bench_row *row)
{
    return pn_bench_time_frames(o, r, cam, light, 1, row);
}

static void cell_label(char *out, size_t n, const bench_row *r);

// Appends the row of cell `index`, prints it, and a progress line on stderr: the cells done of
// this run's, the time since the first, and what is left at the mean time per cell so far (which
// includes the references and, in a shard, exact's cells measured for the others' bias).
static bool push_row(bench_rows *rows, const bench_row *r, int index)
{
    int n = rows->count, cap = rows->index_cap;
    if (!pn_bench_append((void **)&rows->index, &n, &cap, &index, sizeof index))
        return false;
    rows->index_cap = cap;
    if (!pn_bench_append((void **)&rows->rows, &rows->count, &rows->cap, r, sizeof *r))
        return false;
    pn_bench_print_row(r);
    bench_cells *c = &rows->cells;
    c->done++;
    double s = pn_ms_since(c->t0) * 1e-3;
    double left = c->mine > c->done ? s / c->done * (c->mine - c->done) : 0;
    char label[512];
    cell_label(label, sizeof label, r);
    fprintf(stderr, "bench: cell %d/%d done (%s), %.1f s elapsed, about %.*f s left\n", c->done, c->mine, label, s,
            left < 10 ? 1 : 0, left);
    return true;
}

// A cell's name in file names and the console: view_WxH_Sspp_mode[_filter|_penumbra][_LSn_d][_objects], with
// MIN-MAXspp for adaptive samples.
static void cell_label(char *out, size_t n, const bench_row *r)
{
    char spp[32];
    if (r->spp_min)
        snprintf(spp, sizeof spp, "%u-%u", r->spp_min, r->spp);
    else
        snprintf(spp, sizeof spp, "%u", r->spp);
    int len = snprintf(out, n, "%s_%ux%u_%sspp_%s%s", r->scene, r->width, r->height, spp, MODE_NAME(r->mode),
                       r->filter == PN_FILTER_NONE ? "" : r->filter == PN_FILTER_INTERLEAVED ? "_filter" : "_penumbra");
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
                // The depth counter's top bit marks a projection walk that fell back (PN_WORK_FALLBACK).
                uint32_t v = c == 3 ? w[4 * i + c] & ~PN_WORK_FALLBACK : w[4 * i + c];
                planes[c * px + i] = geometry ? (float)v : 0.0f;
                if (geometry)
                    vals[n++] = v;
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


// A filtered cell's edge leak (metrics.h); with --edge-images also its EXR of V, V_raw, the
// reference and the edge classes, to look at where the error grew.
static bool measure_edges(const bench_group *g, const pn_frame_images *img, bench_row *row, double pixel_angle)
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

// The projection traversal's work at a cell (bench_row.projected, fallback): one frame of the
// counting build of the shader (work.y: triangles projected; work.w's PN_WORK_FALLBACK bit: the
// budget ran out), over the covered pixels.
static pn_result project_work(bench_group *g, const pn_setup_desc *cell, bench_row *row)
{
    pn_setup_desc sd = *cell;
    sd.frame.count_work = true;
    sd.frame.dump_rays = false;
    pn_setup s;
    PN_TRY(pn_setup_create(g->dev, g->scene, g->light, &sd, &s));
    pn_frame_times t;
    pn_result r = PN_OK;
    if (g->o->gbuffer)
        r = pn_renderer_set_gbuffer(&s.renderer, g->o->gb_p, g->o->gb_n);
    if (r == PN_OK)
        r = pn_renderer_render(&s.renderer, g->cam, g->light, &t);
    if (r == PN_OK) {
        const uint32_t *w = pn_renderer_work(&s.renderer);
        size_t px = (size_t)g->frame.width * g->frame.height;
        double projected = 0, fallback = 0;
        for (size_t i = 0; i < px; i++) {
            if (!g->mask[i])
                continue;
            projected += w[4 * i + 1];
            fallback += (w[4 * i + 3] & PN_WORK_FALLBACK) != 0;
        }
        row->projected = g->covered ? projected / (double)g->covered : 0;
        row->fallback = g->covered ? fallback / (double)g->covered : 0;
    }
    pn_setup_destroy(g->dev, &s);
    return r;
}

// One cell: the set-up `s` (its filter already set) at the fi-th filter and pi-th spp, timed, with
// both errors and, filtered, the leak across edges. `sd` describes the set-up (for --work).
// `first`: the first cell run over this set-up; `index`: its number when it is pushed.
static int run_cell(bench_group *g, pn_setup *s, pn_setup_desc *sd, int fi, int pi, double pixel_angle, bench_rows *rows,
                    bool push, bool first, int index)
{
    const bench_opts *o = g->o;
    size_t px = (size_t)g->frame.width * g->frame.height;
    pn_shadow_mode mode = sd->frame.mode;
    bool project = sd->frame.traversal == PN_TRAVERSAL_PROJECT;
    bool exact = mode == PN_SHADOW_REFERENCE && !project; // the cells the others are measured against
    uint32_t spp = o->spps[pi], spp_min = o->spp_mins[pi];
    int ci = fi * o->spp_count + pi; // the cell's place among the filters' spp
    sd->frame.spp = spp;
    sd->frame.spp_min = spp_min, sd->frame.pixel_error = o->pixel_error;
    // Adaptive cells trace no ray dump (each pixel its own count): the dump goes off first.
    if ((sd->frame.dump_rays && pn_renderer_set_dump_rays(&s->renderer, false) != PN_OK) ||
        pn_renderer_set_adaptive(&s->renderer, spp_min, spp, o->pixel_error) != PN_OK ||
        (first && o->gbuffer && pn_renderer_set_gbuffer(&s->renderer, o->gb_p, o->gb_n) != PN_OK))
        return PN_EXIT_FAILURE;
    bench_row row = g->base;
    row.spp = spp;
    row.spp_min = spp_min;
    row.mode = mode;
    row.n = sd->tree_n, row.d = sd->tree_d;
    row.per_object = sd->per_object;
    row.project = project;
    row.projected = row.fallback = -1;
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
    if (project && project_work(g, sd, &row) != PN_OK)
        return PN_EXIT_FAILURE;
    if (push && !push_row(rows, &row, index))
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
static pn_result time_move(bench_group *g, pn_setup *s, double *ms)
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

// One configuration's cells, numbered from rows->cells.next when pushed. Exact runs every cell
// whatever the shard, since the other modes' bias and time ratios are measured against it; another
// mode only this run's share, and no set-up at all when the share holds none of its cells.
static int run_config(bench_group *g, pn_shadow_mode mode, int tn, int td, bool per_object, bool project, bench_rows *rows,
                      bool push)
{
    const bench_opts *o = g->o;
    bool exact = mode == PN_SHADOW_REFERENCE; // exact's configuration, or exact/project
    int cells = o->filter_count * o->spp_count, first_index = push ? rows->cells.next : -1, mine = 0;
    if (push)
        rows->cells.next += cells;
    for (int c = 0; push && c < cells; c++)
        mine += pn_bench_owns(o, first_index + c);
    if ((!exact || project) && !mine)
        return PN_EXIT_OK;
    pn_setup s;
    pn_setup_desc sd = {.frame = g->frame, .tree_n = tn, .tree_d = td, .per_object = per_object,
                        .view = o->gbuffer ? NULL : g->cam}; // the tree models what the picture needs
    sd.frame.mode = mode;
    sd.frame.spp = o->spps[o->spp_count - 1]; // the most: the ray dump holds that many rays per pixel
    sd.frame.dump_rays = exact && g->rtc && !project;
    if (project)
        sd.frame.traversal = PN_TRAVERSAL_PROJECT;
    char cell[64];
    pn_bench_tree_label(cell, sizeof cell, tn, td, per_object);
    if (project)
        snprintf(cell, sizeof cell, "%s", pn_bench_project_suffix(true));
    fprintf(stderr, "bench: %s %ux%u %s%s\n", g->base.scene, g->frame.width, g->frame.height, MODE_NAME(mode), cell);
    if (pn_setup_create(g->dev, g->scene, g->light, &sd, &s) != PN_OK) {
        if (exact && !project)
            return PN_EXIT_FAILURE;
        pn_warn("bench: %s%s skipped (see above)", MODE_NAME(mode), cell);
        // Recorded for --merge, which would otherwise take them for a shard's missing cells.
        bench_cells *bc = &rows->cells;
        bc->mine -= mine;
        for (int c = 0; c < cells; c++)
            if (pn_bench_owns(o, first_index + c) &&
                !pn_bench_append((void **)&bc->skipped, &bc->skip_count, &bc->skip_cap, &(int){first_index + c},
                                 sizeof(int)))
                return PN_EXIT_FAILURE;
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
    bool first = true;
    double pixel_angle = pn_pixel_angle(g->cam->yfov_deg, g->frame.height);
    for (int fi = 0; fi < o->filter_count && rc == PN_EXIT_OK; fi++) {
        pn_filter filter = o->filters[fi];
        if (pn_renderer_set_filter(&s.renderer, filter, o->tile_w, o->tile_h) != PN_OK) {
            rc = PN_EXIT_FAILURE;
            break;
        }
        sd.frame.filter = filter, sd.frame.tile_w = o->tile_w, sd.frame.tile_h = o->tile_h;
        for (int pi = 0; pi < o->spp_count && rc == PN_EXIT_OK; pi++) {
            int index = first_index + fi * o->spp_count + pi;
            bool own = push && pn_bench_owns(o, index);
            if ((!exact || project) && !own)
                continue;
            // The projection walk takes uniform samples only: its adaptive cells are skipped (and
            // recorded so, for --merge).
            if (project && o->spp_mins[pi]) {
                bench_cells *bc = &rows->cells;
                bc->mine--;
                if (!pn_bench_append((void **)&bc->skipped, &bc->skip_count, &bc->skip_cap, &index, sizeof index))
                    rc = PN_EXIT_FAILURE;
                continue;
            }
            rc = run_cell(g, &s, &sd, fi, pi, pixel_angle, rows, own, first, index);
            first = false;
        }
    }
    pn_setup_destroy(g->dev, &s);
    return rc;
}

static bool wants_exact(const bench_opts *o)
{
    for (int m = 0; m < o->mode_count; m++)
        if (o->modes[m] == PN_SHADOW_REFERENCE)
            return true;
    return false;
}

// The same walk as pn_bench_view's over the configurations, counting their cells.
int pn_bench_view_cells(const bench_opts *o, const pn_gpu_device *dev, const pn_scene *scene)
{
    int configs = wants_exact(o) * (1 + o->project);
    for (int m = 0; m < o->mode_count; m++) {
        const pn_shadow_mode_info *info = pn_shadow_mode_get(o->modes[m]);
        const char *lack;
        if (o->modes[m] == PN_SHADOW_REFERENCE || !pn_shadow_mode_available(dev, o->modes[m], &lack) ||
            (scene && !pn_shadow_mode_takes_scene(o->modes[m], scene, NULL, 0)))
            continue;
        if (!info->needs.tree) {
            configs++;
            continue;
        }
        if (o->kinds[PN_TREE_KIND_SCENE])
            configs += o->tree_count;
        if (o->kinds[PN_TREE_KIND_OBJECT] && info->objects && !(scene && pn_alpha_masked_triangles(scene)))
            configs += o->tree_count;
    }
    return o->size_count * configs * o->filter_count * o->spp_count;
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
    bool want_exact = wants_exact(o);
    // The run's count of cells held this view's upper bound until now: its own count instead.
    bench_cells *bc = &rows->cells;
    int view_cells = pn_bench_view_cells(o, dev, &scene);
    bc->total += view_cells - pn_bench_view_cells(o, dev, NULL);
    bc->mine = pn_bench_share(o, bc->total) - bc->skip_count;
    for (int si = 0; si < o->size_count && rc == PN_EXIT_OK; si++) {
        uint32_t w = o->sizes[si][0], h = o->sizes[si][1];
        size_t px = (size_t)w * h;
        // A shard that has none of this size's cells needs neither its reference nor its exact.
        int group_cells = view_cells / o->size_count, owned = 0;
        for (int c = 0; o->shard_n && c < group_cells; c++)
            owned += pn_bench_owns(o, bc->next + c);
        if (o->shard_n && !owned) {
            bc->next += group_cells;
            continue;
        }
        bench_group g = {.o = o, .dev = dev, .scene = &scene, .cam = &cam, .light = &light, .rtc = rs,
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
        rc = run_config(&g, PN_SHADOW_REFERENCE, 0, 0, false, false, rows, want_exact);
        if (rc == PN_EXIT_OK && want_exact && o->project)
            rc = run_config(&g, PN_SHADOW_REFERENCE, 0, 0, false, true, rows, true);
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
            char why[512];
            if (!pn_shadow_mode_takes_scene(o->modes[m], &scene, why, sizeof why)) {
                if (si == 0)
                    pn_warn("bench: skipped: %s", why);
                continue;
            }
            // A mode without a tree is one configuration; a tree mode one per tree and tree kind
            // (per-object trees serve linespace alone).
            for (int kind = PN_TREE_KIND_SCENE; kind <= PN_TREE_KIND_OBJECT && rc == PN_EXIT_OK; kind++) {
                bool per_object = kind == PN_TREE_KIND_OBJECT;
                if (!info->needs.tree) {
                    if (kind == PN_TREE_KIND_SCENE)
                        rc = run_config(&g, o->modes[m], 0, 0, false, false, rows, true);
                    continue;
                }
                if (!o->kinds[kind])
                    continue;
                if (per_object && !info->objects) {
                    if (si == 0)
                        pn_warn("bench: %s has no per-object trees (they serve linespace alone)", info->name);
                    continue;
                }
                if (per_object && pn_alpha_masked_triangles(&scene)) {
                    if (si == 0)
                        pn_warn("bench: %s: skipped per-object trees: they keep no triangles to test alpha masks",
                                scene.name);
                    continue;
                }
                for (int ti = 0; ti < o->tree_count && rc == PN_EXIT_OK; ti++)
                    rc = run_config(&g, o->modes[m], o->trees[ti][0], o->trees[ti][1], per_object, false, rows, true);
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
            pn_bench_light_set(&light, centre, o->light_counts[li], set);
            refs[li] = malloc(px * 4 * sizeof *refs[li]);
            if (!refs[li] || pn_bench_lights_reference(&g, set, o->light_counts[li], refs[li]) != PN_OK)
                rc = PN_EXIT_FAILURE;
        }
        for (int m = -1; m < o->mode_count && rc == PN_EXIT_OK && o->light_count_count; m++) {
            pn_shadow_mode mode = m < 0 ? PN_SHADOW_REFERENCE : o->modes[m];
            const pn_shadow_mode_info *info = pn_shadow_mode_get(mode);
            const char *lack;
            if ((m >= 0 && mode == PN_SHADOW_REFERENCE) || !pn_shadow_mode_available(dev, mode, &lack) ||
                !pn_shadow_mode_takes_scene(mode, &scene, NULL, 0))
                continue;
            rc = pn_bench_run_lights(&g, centre, mode, info->needs.tree ? o->trees[0][0] : 0,
                            info->needs.tree ? o->trees[0][1] : 0, refs, rows);
        }
        for (int li = 0; li < o->light_count_count; li++)
            free(refs[li]);
        if (o->gbuffer && o->max_error_count)
            pn_warn("bench: --max-error is not checked with --gbuffer (--quality auto renders its own G-buffer)");
        for (int b = 0; b < o->max_error_count && rc == PN_EXIT_OK && !o->gbuffer && rows->count > first_row; b++)
            rc = pn_bench_check_quality(o, dev, &scene, &cam, &light, &g.frame, v_conv, mask, o->max_errors[b], rows, first_row);
        free(v_conv);
        free(mask);
        free(g.v_exact);
    }
    if (rs)
        pn_embree_scene_destroy(rs);
    pn_scene_destroy(&scene);
    return rc;
}
