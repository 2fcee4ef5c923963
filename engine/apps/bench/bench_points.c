// bench --points: points in, V out through the library (engine/api, penumbra_visibility) beside
// the renderer's shadow pass, per view, size, samples and mode. The points are the view's covered
// pixels (P and N from the renderer's frame), in row order, as a baker or another renderer would
// hand them over; the library runs on the bench's own device (penumbra_context_create_vulkan) over
// the view's scene as arrays (penumbra_scene_create, the ground included). Reported per row:
// the renderer's shadow pass per covered pixel, the library's call per point (wall-clock: upload,
// pass, readback) and its shadow pass per point (timestamps), each the median of --repeat after
// the first call (which builds and compiles), and their ratios; to points.csv in the output folder.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/bench/bench.h" // Vulkan first: penumbra.h declares its Vulkan part only then
#include "api/penumbra.h"
#include "core/log.h"
#include "core/timer.h"

typedef struct points_row {
    char view[64];
    uint32_t width, height, spp;
    pn_shadow_mode mode;
    size_t points;
    double render_shadow_ms, api_ms, api_shadow_ms, api_first_ms;
} points_row;

// The view's triangles as one mesh of the library's (world space: no transform).
static penumbra_status scene_from(penumbra_context *ctx, const pn_scene *s, penumbra_scene **out)
{
    float *pos = malloc((size_t)s->vertex_count * 3 * sizeof *pos);
    if (!pos)
        return PENUMBRA_ERROR_OUT_OF_MEMORY;
    for (uint32_t i = 0; i < s->vertex_count; i++)
        memcpy(pos + 3 * (size_t)i, s->vertices[i].pos, 3 * sizeof *pos);
    penumbra_mesh_desc m = {.positions = pos, .vertex_count = s->vertex_count, .indices = s->indices,
                            .index_count = s->index_count};
    penumbra_status st = penumbra_scene_create(ctx, &m, 1, out);
    free(pos);
    return st;
}

static penumbra_light light_out(const pn_light *l)
{
    static const penumbra_light_kind kinds[] = {[PN_LIGHT_RECT] = PENUMBRA_LIGHT_RECT, [PN_LIGHT_OMNI] = PENUMBRA_LIGHT_POINT,
                                                [PN_LIGHT_SUN] = PENUMBRA_LIGHT_SUN, [PN_LIGHT_SPHERE] = PENUMBRA_LIGHT_SPHERE,
                                                [PN_LIGHT_DISK] = PENUMBRA_LIGHT_DISK};
    penumbra_light o = {.kind = kinds[l->kind], .radius = l->radius, .angle = l->angle, .range = l->range};
    memcpy(o.position, l->pos, sizeof o.position);
    memcpy(o.normal, l->normal, sizeof o.normal);
    memcpy(o.up, l->up, sizeof o.up);
    memcpy(o.size, l->size, sizeof o.size);
    memcpy(o.cone, l->cone, sizeof o.cone);
    return o;
}

// One row: the renderer's frames, then the library's calls over the frame's covered pixels.
static int points_row_run(const bench_opts *o, pn_gpu_device *dev, penumbra_context *ctx, penumbra_scene *api_scene,
                          const pn_prepared_scene *prep, uint32_t w, uint32_t h, uint32_t spp, pn_shadow_mode mode,
                          points_row *row)
{
    pn_renderer_desc frame = {.width = w, .height = h, .sampler = o->sampler, .traversal = o->traversal, .seed = o->seed};
    pn_setup s;
    int tn = o->trees[0][0], td = o->trees[0][1];
    if (pn_bench_setup_config(dev, &prep->scene, &prep->camera, &prep->lights[0], &frame, mode, tn, td, spp, 0, 0,
                              PN_FILTER_NONE, &s) != PN_OK)
        return PN_EXIT_FAILURE;
    bench_row timed = {.filter = PN_FILTER_NONE};
    int rc = pn_bench_time_frames(o, &s.renderer, &prep->camera, &prep->lights[0], 1, &timed) == PN_OK
                 ? PN_EXIT_OK
                 : PN_EXIT_FAILURE;
    size_t px = (size_t)w * h, n = 0;
    float *pts = malloc(px * 3 * sizeof *pts), *nrm = malloc(px * 3 * sizeof *nrm), *v = malloc(px * sizeof *v);
    if (rc == PN_EXIT_OK && pts && nrm && v) {
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        for (size_t i = 0; i < px; i++)
            if (img.p[4 * i + 3] > 0) {
                memcpy(pts + 3 * n, img.p + 4 * i, 3 * sizeof *pts);
                memcpy(nrm + 3 * n, img.n + 4 * i, 3 * sizeof *nrm);
                n++;
            }
    } else {
        rc = PN_EXIT_FAILURE;
    }
    pn_setup_destroy(dev, &s);
    penumbra_light light = light_out(&prep->lights[0]);
    penumbra_visibility_desc vd = {.mode = pn_shadow_mode_get(mode)->name, .traversal = pn_traversal_names[o->traversal],
                                   .sampler = pn_sampler_names[o->sampler], .spp = spp, .seed = o->seed,
                                   .tree_n = (uint32_t)tn, .tree_d = (uint32_t)td, .width = w};
    double wall[1000], gpu[1000];
    penumbra_times t;
    for (int i = -1; rc == PN_EXIT_OK && i < o->repeat; i++) {
        if (penumbra_visibility(ctx, api_scene, &vd, &light, 1, pts, nrm, n, v) != PENUMBRA_OK) {
            pn_error("bench --points: %s", penumbra_context_error(ctx));
            rc = PN_EXIT_FAILURE;
            break;
        }
        penumbra_scene_last_times(api_scene, &t);
        if (i < 0) { // the first call builds and compiles
            row->api_first_ms = t.total_ms;
            continue;
        }
        wall[i] = t.total_ms, gpu[i] = t.shadow_ms;
    }
    if (rc == PN_EXIT_OK) {
        row->width = w, row->height = h, row->spp = spp, row->mode = mode, row->points = n;
        row->render_shadow_ms = timed.shadow_ms;
        row->api_ms = pn_time_median(wall, o->repeat);
        row->api_shadow_ms = pn_time_median(gpu, o->repeat);
    }
    free(pts), free(nrm), free(v);
    return rc;
}

static void print_row(FILE *f, const points_row *r, bool csv)
{
    double per_px = r->points ? 1e6 * r->render_shadow_ms / (double)r->points : 0; // ns
    double per_pt = r->points ? 1e6 * r->api_ms / (double)r->points : 0;
    double per_pt_gpu = r->points ? 1e6 * r->api_shadow_ms / (double)r->points : 0;
    if (csv)
        fprintf(f, "%s,%u,%u,%u,%s,%zu,%.4f,%.4f,%.4f,%.4f,%.3f,%.3f,%.3f,%.4f,%.4f\n", r->view, r->width, r->height,
                r->spp, MODE_NAME(r->mode), r->points, r->render_shadow_ms, r->api_ms, r->api_shadow_ms, r->api_first_ms,
                per_px, per_pt, per_pt_gpu, per_px > 0 ? per_pt / per_px : 0, per_px > 0 ? per_pt_gpu / per_px : 0);
    else
        fprintf(f, "%-10s %5ux%-5u %4u spp %-10s %8zu points | render shadow %9.2f ms %7.1f ns/px | library call "
                   "%9.2f ms %7.1f ns/pt (%.2fx), its shadow pass %9.2f ms (%.2fx) | first call %.0f ms\n",
                r->view, r->width, r->height, r->spp, MODE_NAME(r->mode), r->points, r->render_shadow_ms, per_px,
                r->api_ms, per_pt, per_px > 0 ? per_pt / per_px : 0, r->api_shadow_ms,
                per_px > 0 ? per_pt_gpu / per_px : 0, r->api_first_ms);
}

int pn_bench_points(const bench_opts *o, pn_gpu_device *dev)
{
    const char *exts[PN_GPU_OPTIONAL_EXTENSIONS];
    uint32_t ext_count = pn_gpu_device_extensions(dev, exts);
    penumbra_context *ctx = NULL;
    penumbra_vulkan_desc vk = {.instance = dev->instance, .physical_device = dev->physical, .device = dev->device,
                               .queue_family = dev->queue_family, .queue = dev->queue, .enabled_extensions = exts,
                               .enabled_extension_count = ext_count};
    if (penumbra_context_create_vulkan(&vk, &(penumbra_context_desc){.log_level = 2}, &ctx) != PENUMBRA_OK) {
        pn_error("bench --points: %s", penumbra_context_error(ctx));
        penumbra_context_destroy(ctx);
        return PN_EXIT_FAILURE;
    }
    char path[4096], tmp[4096];
    FILE *csv = pn_bench_open_out(o->out_dir, "points.csv", path, tmp);
    int rc = csv ? PN_EXIT_OK : PN_EXIT_FAILURE;
    if (csv)
        fprintf(csv, "view,width,height,spp,mode,points,render_shadow_ms,api_ms,api_shadow_ms,api_first_ms,"
                     "render_ns_per_pixel,api_ns_per_point,api_shadow_ns_per_point,api_vs_render,api_shadow_vs_render\n");
    for (int vi = 0; vi < o->view_count && rc == PN_EXIT_OK; vi++) {
        pn_prepared_scene prep;
        if ((rc = pn_bench_view_prepare(&o->views[vi], &prep)) != PN_EXIT_OK)
            break;
        penumbra_scene *api_scene = NULL;
        if (scene_from(ctx, &prep.scene, &api_scene) != PENUMBRA_OK) {
            pn_error("bench --points: %s", penumbra_context_error(ctx));
            rc = PN_EXIT_FAILURE;
        }
        for (int si = 0; si < o->size_count && rc == PN_EXIT_OK; si++)
            for (int pi = 0; pi < o->spp_count && rc == PN_EXIT_OK; pi++)
                for (int mi = 0; mi < o->mode_count && rc == PN_EXIT_OK; mi++) {
                    if (o->spp_mins[pi] || !pn_shadow_mode_get(o->modes[mi])->traces)
                        continue; // uniform samples of a tracing mode: what the library offers
                    points_row row = {0};
                    snprintf(row.view, sizeof row.view, "%s", o->views[vi].name);
                    rc = points_row_run(o, dev, ctx, api_scene, &prep, o->sizes[si][0], o->sizes[si][1], o->spps[pi],
                                        o->modes[mi], &row);
                    if (rc == PN_EXIT_OK) {
                        print_row(stdout, &row, false);
                        print_row(csv, &row, true);
                    }
                }
        penumbra_scene_destroy(api_scene);
        pn_scene_destroy(&prep.scene);
    }
    if (csv && !pn_bench_close_out(csv, path, tmp))
        rc = PN_EXIT_FAILURE;
    penumbra_context_destroy(ctx);
    if (rc == PN_EXIT_OK)
        fprintf(stderr, "bench: points rows in %s\n", path);
    return rc;
}
