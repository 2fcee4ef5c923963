// penumbra bench's matrix: per scene, the exact reference and its Embree peer for each size and
// spp, then every mode and tree timed and compared with it; --work counters and --max-error checks.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/bench.h"
#include "apps/metrics.h"
#include "apps/quality.h"
#include "apps/setup.h"
#include "core/log.h"
#include "io/exr.h"

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double pn_bench_median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Renders warm-up and timed frames; fills the timing fields of `row` and leaves the last frame's
// images in the renderer.
static pn_result time_frames(const bench_opts *o, pn_renderer *r, const pn_camera *cam, const pn_light *light,
                             bench_row *row)
{
    double g[1000], s[1000], h[1000];
    pn_frame_times t;
    for (int i = 0; i < o->warmup; i++)
        if (pn_renderer_render(r, cam, light, &t) != PN_OK)
            return PN_ERR_VULKAN;
    for (int i = 0; i < o->repeat; i++) {
        if (pn_renderer_render(r, cam, light, &t) != PN_OK)
            return PN_ERR_VULKAN;
        g[i] = t.gbuffer_ms, s[i] = t.shadow_ms, h[i] = t.shade_ms;
    }
    row->gbuffer_ms = pn_bench_median(g, o->repeat);
    row->shade_ms = pn_bench_median(h, o->repeat);
    row->shadow_ms = pn_bench_median(s, o->repeat); // sorts s
    row->shadow_min_ms = s[0];
    row->shadow_max_ms = s[o->repeat - 1];
    return PN_OK;
}

static bool push_row(bench_rows *rows, const bench_row *r)
{
    if (rows->count == rows->cap) {
        int cap = rows->cap ? 2 * rows->cap : 64;
        bench_row *n = realloc(rows->rows, (size_t)cap * sizeof *n);
        if (!n)
            return false;
        rows->rows = n;
        rows->cap = cap;
    }
    rows->rows[rows->count++] = *r;
    pn_bench_print_row(r);
    return true;
}

// --quality auto against the matrix: the configuration it picks from its pilot, rendered in full and
// measured against exact, next to the fastest cell of this group that meets the same budget.
static void check_quality(const bench_opts *o, pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                          const pn_light *light, const pn_renderer_desc *frame, const float *v_ref, const uint8_t *mask,
                          bench_rows *rows, int first_row)
{
    const bench_row *best = NULL;
    for (int i = first_row; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        if (r->err.mae <= o->max_error && (!best || r->shadow_ms < best->shadow_ms))
            best = r;
    }
    pn_quality_choice q;
    if (pn_quality_choose(dev, scene, cam, light, frame, o->max_error, 0, &q) != PN_OK)
        return;
    pn_setup s;
    pn_setup_desc sd = {.frame = *frame, .tree_n = q.tree_n, .tree_d = q.tree_d, .view = cam};
    sd.frame.mode = (pn_shadow_mode)q.mode;
    bench_row row = rows->rows[first_row < rows->count ? first_row : 0];
    if (pn_setup_create(dev, scene, light, &sd, &s) != PN_OK)
        return;
    if (time_frames(o, &s.renderer, cam, light, &row) == PN_OK) {
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        pn_error_compare(img.v, v_ref, mask, (size_t)frame->width * frame->height, NULL, &row.err);
        printf("quality auto (max error %.4g): %s", o->max_error, MODE_NAME(q.mode));
        if (q.tree_n)
            printf(" LS(%d,%d)", q.tree_n, q.tree_d);
        printf(", shadow %.1f ms, MAE %.4f (pilot %.4f)", row.shadow_ms, row.err.mae, q.pilot_mae);
        char tree[32] = "";
        if (best && best->n)
            snprintf(tree, sizeof tree, " LS(%d,%d)", best->n, best->d);
        if (best)
            printf("; the matrix's fastest within the budget: %s%s %.1f ms: auto takes %.2fx its time\n",
                   MODE_NAME(best->mode), tree, best->shadow_ms, row.shadow_ms / best->shadow_ms);
        else
            printf("; no cell of the matrix meets the budget\n");
    }
    pn_setup_destroy(dev, &s);
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
                planes[c * px + i] = (float)w[4 * i + c];
                if (img.p[4 * i + 3] > 0)
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
            snprintf(path, sizeof path, "%s/work_%s.exr", o->out_dir, label);
            for (char *c = path + strlen(o->out_dir) + 1; *c; c++)
                if (*c == ':' || *c == '/' || *c == ',' || *c == ' ')
                    *c = '_';
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

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

// One scene: its exact reference and Embree peer per size and spp, then every mode and tree.
int pn_bench_scene(const bench_opts *o, pn_gpu_device *dev, pn_bench_embree *rtc, const char *source, bench_rows *rows)
{
    // Reproducible camera and light from the bounds, and the ground plane: render's defaults.
    pn_render_opts defaults = pn_render_opts_default();
    pn_prepared_scene prep;
    int prc = pn_render_prepare(&defaults, source, &prep);
    if (prc != PN_EXIT_OK)
        return prc;
    pn_scene scene = prep.scene;
    pn_camera cam = prep.camera;
    pn_light light = prep.light;
    pn_bench_embree_scene *rs = rtc ? pn_bench_embree_scene_create(rtc, &scene) : NULL;
    int rc = PN_EXIT_OK;
    for (int si = 0; si < o->size_count && rc == PN_EXIT_OK; si++)
        for (int pi = 0; pi < o->spp_count && rc == PN_EXIT_OK; pi++) {
            uint32_t w = o->sizes[si][0], h = o->sizes[si][1], spp = o->spps[pi];
            size_t px = (size_t)w * h;
            pn_renderer_desc frame = {.width = w, .height = h, .traversal = o->traversal, .sampler = o->sampler,
                                      .spp = spp, .seed = 1};
            // The reference: exact, with its rays kept for Embree.
            pn_setup ref;
            pn_setup_desc rd = {.frame = frame};
            rd.frame.mode = PN_SHADOW_REFERENCE;
            rd.frame.dump_rays = rtc != NULL;
            bench_row base = {.width = w, .height = h, .spp = spp, .triangles = pn_scene_triangle_count(&scene)};
            snprintf(base.scene, sizeof base.scene, "%s", base_name(scene.name));
            fprintf(stderr, "bench: %s %ux%u %u spp: exact reference\n", scene.name, w, h, spp);
            if (pn_setup_create(dev, &scene, &light, &rd, &ref) != PN_OK) {
                rc = PN_EXIT_FAILURE;
                break;
            }
            if (o->gbuffer && pn_renderer_set_gbuffer(&ref.renderer, o->gb_p, o->gb_n) != PN_OK) {
                pn_setup_destroy(dev, &ref);
                rc = PN_EXIT_FAILURE;
                break;
            }
            bench_row exact_row = base;
            exact_row.mode = PN_SHADOW_REFERENCE;
            float *v_ref = malloc(px * sizeof *v_ref);
            uint8_t *mask = malloc(px);
            if (!v_ref || !mask || time_frames(o, &ref.renderer, &cam, &light, &exact_row) != PN_OK) {
                free(v_ref), free(mask);
                pn_setup_destroy(dev, &ref);
                rc = PN_EXIT_FAILURE;
                break;
            }
            pn_frame_images img;
            pn_renderer_images(&ref.renderer, &img);
            uint64_t covered = 0;
            for (size_t i = 0; i < px; i++) {
                v_ref[i] = img.v[i];
                mask[i] = img.p[4 * i + 3] > 0;
                covered += mask[i];
            }
            double embree_ms = 0;
            if (rs) {
                uint64_t floats;
                const float *dump = pn_renderer_ray_dump(&ref.renderer, &floats);
                embree_ms = pn_bench_embree_time(o, rs, dump, px, spp);
            }
            double exact_ms = exact_row.shadow_ms;
            exact_row.build_ms = ref.build_ms;
            exact_row.pool_mb = ref.exact_bytes / 1048576.0;
            exact_row.rays_per_s = pn_shadow_rays_per_s(covered, spp, &light, exact_ms);
            exact_row.vs_exact = 1.0;
            exact_row.vs_embree = embree_ms > 0 ? exact_ms / embree_ms : 0;
            pn_error_compare(v_ref, v_ref, mask, px, NULL, &exact_row.err);
            pn_setup_destroy(dev, &ref);
            int first_row = rows->count; // this group's rows start here
            if (o->work) {
                char label[512];
                snprintf(label, sizeof label, "%s_%ux%u_%uspp_exact", base.scene, w, h, spp);
                report_work(o, dev, &scene, &cam, &light, rd, label);
            }
            bool want_exact = false;
            for (int m = 0; m < o->mode_count; m++)
                want_exact = want_exact || o->modes[m] == PN_SHADOW_REFERENCE;
            if (want_exact)
                push_row(rows, &exact_row);
            // Every other mode and tree against it.
            for (int m = 0; m < o->mode_count && rc == PN_EXIT_OK; m++) {
                const pn_shadow_mode_info *info = pn_shadow_mode_get(o->modes[m]);
                const char *lack;
                if (o->modes[m] == PN_SHADOW_REFERENCE)
                    continue;
                if (!pn_shadow_mode_available(dev, o->modes[m], &lack)) {
                    pn_warn("bench: %s skipped: %s lacks %s", info->name, dev->props.deviceName, lack);
                    continue;
                }
                // A mode without a tree is one cell; a tree mode one per tree.
                int cells = info->needs.tree ? o->tree_count : 1;
                for (int ti = 0; ti < cells && rc == PN_EXIT_OK; ti++) {
                    pn_setup s;
                    int tn = info->needs.tree ? o->trees[ti][0] : 0, td = info->needs.tree ? o->trees[ti][1] : 0;
                    pn_setup_desc sd = {.frame = frame, .tree_n = tn, .tree_d = td,
                                        .view = o->gbuffer ? NULL : &cam}; // the tree models what the picture needs
                    sd.frame.mode = (pn_shadow_mode)o->modes[m];
                    bench_row row = base;
                    row.mode = o->modes[m];
                    row.n = tn, row.d = td;
                    char cell[64] = "";
                    if (row.n)
                        snprintf(cell, sizeof cell, " LS(%d,%d)", row.n, row.d);
                    fprintf(stderr, "bench: %s %s%s\n", scene.name, MODE_NAME(row.mode), cell);
                    if (pn_setup_create(dev, &scene, &light, &sd, &s) != PN_OK) {
                        pn_warn("bench: %s%s skipped (see above)", MODE_NAME(row.mode), cell);
                        continue;
                    }
                    if (o->gbuffer && pn_renderer_set_gbuffer(&s.renderer, o->gb_p, o->gb_n) != PN_OK) {
                        pn_setup_destroy(dev, &s);
                        rc = PN_EXIT_FAILURE;
                        break;
                    }
                    if (time_frames(o, &s.renderer, &cam, &light, &row) == PN_OK) {
                        pn_renderer_images(&s.renderer, &img);
                        row.build_ms = s.build_ms;
                        row.pool_mb = (s.pool_bytes.total + s.exact_bytes) / 1048576.0;
                        row.rays_per_s = pn_shadow_rays_per_s(covered, spp, &light, row.shadow_ms);
                        row.vs_exact = row.shadow_ms / exact_ms;
                        row.vs_embree = embree_ms > 0 ? row.shadow_ms / embree_ms : 0;
                        pn_error_compare(img.v, v_ref, mask, px, NULL, &row.err);
                        push_row(rows, &row);
                        if (o->work) {
                            char label[512];
                            snprintf(label, sizeof label, "%s_%ux%u_%uspp_%s_LS%d_%d", base.scene, w, h, spp,
                                     MODE_NAME(row.mode), row.n, row.d);
                            report_work(o, dev, &scene, &cam, &light, sd, label);
                        }
                    } else {
                        rc = PN_EXIT_FAILURE;
                    }
                    pn_setup_destroy(dev, &s);
                }
            }
            if (o->max_error > 0 && rc == PN_EXIT_OK)
                check_quality(o, dev, &scene, &cam, &light, &frame, v_ref, mask, rows, first_row);
            free(v_ref);
            free(mask);
        }
    if (rs)
        pn_bench_embree_scene_destroy(rs);
    pn_scene_destroy(&scene);
    return rc;
}
