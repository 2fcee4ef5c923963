// penumbra bench --sequence: frames in motion, the temporal history (engine/gpu/README.md) against
// the same frames without it and against each frame rendered at once with all the samples its
// history could hold, every frame scored against its own converged reference.
//
// Per view, size, tracing mode, filter and uniform spp, and per sequence kind:
//   orbit   the camera turns about the vertical through its target, --sequence-step degrees a frame
//           (a camera inside the scene's bounds, as Sponza's, turns about its own place instead)
//   light   the light turns about the vertical through the view's centre as much a frame (every
//           frame a new light: the history drops its samples each frame, and must cost no error)
//   walk    the camera walks towards its target, level, --sequence-step percent of the view's
//           bounding radius a frame (through Sponza's atrium; towards a Table-1 mesh)
//   object  the scene's first object (a glTF node: the mesh of the Table-1 views, not their
//           ground) crosses the light: it moves sideways, level and square to the light's
//           direction, --sequence-step percent of its bounding radius a frame, from as far on one
//           side as it ends on the other (the history drops what its boxes before and after reach)
// three renderers draw frame k: with the history (--history frames), without it (the frame alone,
// the same spp), and without it at min(k + 1, history) x spp at once (what the history's samples
// would give had the frame had them); under `object` a fourth at 16 spp unfiltered, and the errors
// with and without the history over the pixels whose V the move changed since the frame before (a
// ghost shows there). With Embree (not --no-embree), the CPU peer per frame: plain exact unfiltered
// at 1, 2, 4, ... PEER_MAX_SPP spp, the fewest that reach the error the history's frame has, and
// Embree's time to trace those rays (the same rays: apps/embree_peer.h). sequence.csv has a line
// per frame; per sequence a plot of the error per frame (seq_*.png) and a summary line on the
// console.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/bench/bench.h"
#include "core/log.h"
#include "core/timer.h"

static const char *const KIND_NAMES[PN_BENCH_SEQUENCES] = {"orbit", "light", "object", "walk"};
enum { KIND_ORBIT, KIND_LIGHT, KIND_OBJECT, KIND_WALK };

// `v` turned by `deg` degrees about the vertical (+Y): a direction, or a point relative to the
// centre it turns round.
static void turn(double deg, const float v[3], float out[3])
{
    double a = deg * 3.14159265358979323846 / 180.0, c = cos(a), s = sin(a);
    out[0] = (float)(c * v[0] + s * v[2]);
    out[1] = v[1];
    out[2] = (float)(-s * v[0] + c * v[2]);
}

// `p` turned by `deg` degrees about the vertical through `centre`.
static void turn_about(const float centre[3], double deg, const float p[3], float out[3])
{
    float d[3] = {p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]};
    turn(deg, d, out);
    for (int i = 0; i < 3; i++)
        out[i] += centre[i];
}

// Frame k of a sequence: its camera and light.
static void frame_at(int kind, int k, float step, const pn_prepared_scene *prep, pn_camera *cam, pn_light *light)
{
    *cam = prep->camera;
    *light = prep->lights[0];
    double deg = (double)k * step;
    if (kind == KIND_ORBIT) {
        // A camera inside the scene's bounds (Sponza's atrium) turns where it stands, looking
        // round (an orbit about its target would take it through the walls); one outside them
        // orbits its target.
        bool inside = true;
        for (int i = 0; i < 3; i++)
            inside = inside && prep->camera.pos[i] > prep->object_min[i] && prep->camera.pos[i] < prep->object_max[i];
        if (inside)
            turn_about(cam->pos, deg, prep->camera.target, cam->target);
        else
            turn_about(cam->target, deg, prep->camera.pos, cam->pos);
    } else if (kind == KIND_WALK) {
        // Level, along the view's direction on the ground plane.
        float d[3] = {cam->target[0] - cam->pos[0], 0.0f, cam->target[2] - cam->pos[2]}, r2 = 0;
        for (int i = 0; i < 3; i++)
            r2 += (prep->object_max[i] - prep->object_min[i]) * (prep->object_max[i] - prep->object_min[i]);
        float len = sqrtf(d[0] * d[0] + d[2] * d[2]), along = (float)k * step * 0.01f * 0.5f * sqrtf(r2);
        for (int i = 0; len > 0 && i < 3; i += 2) {
            cam->pos[i] += along * d[i] / len;
            cam->target[i] += along * d[i] / len;
        }
    } else if (kind == KIND_LIGHT) {
        float centre[3];
        for (int i = 0; i < 3; i++)
            centre[i] = 0.5f * (prep->object_min[i] + prep->object_max[i]);
        turn_about(centre, deg, prep->lights[0].pos, light->pos);
        turn(deg, prep->lights[0].normal, light->normal);
        turn(deg, prep->lights[0].up, light->up);
    }
}

static double frame_ms(const pn_frame_times *t) { return t->gbuffer_ms + t->shadow_ms + t->filter_ms + t->shade_ms; }

typedef struct seq_frame {
    double history_samples; // mean samples behind a covered pixel's V (with the history)
    double mae_history, mae_none, mae_at_once;
    uint32_t at_once_spp;
    double ms_history, ms_none;
    // KIND_OBJECT (NaN otherwise): 16 spp unfiltered, and with and without the history over the
    // pixels whose V changed since the frame before (`changed` of them).
    double mae_16, mae_history_changed, mae_none_changed;
    size_t changed;
    // With Embree: the fewest plain exact spp (a power of two) whose error is at most mae_history,
    // 0 if even PEER_MAX_SPP's is not, and Embree's time for that frame's rays.
    uint32_t embree_spp;
    double embree_ms;
} seq_frame;

// The moving object's offset in frame k of `frames`, along the unit direction `side`: centred on
// its place, so that it crosses the light (KIND_OBJECT).
static void object_offset(int k, uint32_t frames, float step, double radius, const float side[3], float out[3])
{
    double along = ((double)k - 0.5 * (double)(frames - 1)) * step * 0.01 * radius;
    for (int i = 0; i < 3; i++)
        out[i] = (float)(along * side[i]);
}

// The object's box (pn_scene_object_bounds), in the history's doubles.
static void object_box(const pn_scene *scene, uint32_t index, double lo[3], double hi[3])
{
    float l[3], h[3];
    pn_scene_object_bounds(scene, index, l, h);
    for (int k = 0; k < 3; k++)
        lo[k] = l[k], hi[k] = h[k];
}

// The renderer's V against the reference; the history's mean samples a covered pixel.
static double frame_error(const pn_renderer *r, const float *ref, const uint8_t *mask, size_t px, double *history)
{
    pn_frame_images img;
    pn_renderer_images(r, &img);
    pn_error_metrics m;
    if (!pn_error_compare(img.v, ref, mask, px, NULL, &m))
        return NAN;
    if (history) {
        double sum = 0;
        size_t n = 0;
        for (size_t i = 0; i < px; i++)
            if (mask[i] && img.history)
                sum += img.history[4 * i + 1], n++;
        *history = n ? sum / (double)n : 0.0;
    }
    return m.mae;
}

// The most samples the CPU peer's exact frames take (a ray dump of that many a pixel).
enum { PEER_MAX_SPP = 64 };

// The CPU peer's part of frame k: the peer renderer's exact unfiltered frames at 1, 2, 4, ... spp
// against the reference until one is no worse than the history's frame, then that frame again with
// its ray dump, which Embree traces (timed once, as the frames are).
static bool peer_frame(const bench_opts *o, const pn_embree_scene *rtc, pn_setup *peer, const pn_camera *cam,
                       const pn_light *light, const float *ref, const uint8_t *mask, size_t px, seq_frame *fk)
{
    fk->embree_spp = 0, fk->embree_ms = NAN;
    pn_frame_times t;
    for (uint32_t spp = 1; spp <= PEER_MAX_SPP && !fk->embree_spp; spp *= 2) {
        if (pn_renderer_set_spp(&peer->renderer, spp) != PN_OK ||
            pn_renderer_render_lights(&peer->renderer, cam, light, 1, &t) != PN_OK)
            return false;
        if (frame_error(&peer->renderer, ref, mask, px, NULL) <= fk->mae_history)
            fk->embree_spp = spp;
    }
    if (!fk->embree_spp)
        return true;
    uint64_t floats;
    bench_opts once = *o;
    once.repeat = 1, once.warmup = 0;
    bool ok = pn_renderer_set_spp(&peer->renderer, fk->embree_spp) == PN_OK &&
              pn_renderer_set_dump_rays(&peer->renderer, true) == PN_OK &&
              pn_renderer_render_lights(&peer->renderer, cam, light, 1, &t) == PN_OK;
    if (ok)
        fk->embree_ms = pn_bench_embree_time(&once, rtc, pn_renderer_ray_dump(&peer->renderer, &floats), px,
                                             fk->embree_spp);
    return pn_renderer_set_dump_rays(&peer->renderer, false) == PN_OK && ok;
}

static bool write_plot(const bench_opts *o, const char *stem, const seq_frame *f, uint32_t frames, const char *title)
{
    char path[4096], tmp[4096], name[600];
    snprintf(name, sizeof name, "%s.dat", stem);
    FILE *dat = pn_bench_open_out(o->out_dir, name, path, tmp);
    if (!dat)
        return false;
    fprintf(dat, "# frame mae_history mae_none mae_at_once at_once_spp\n");
    for (uint32_t k = 0; k < frames; k++)
        fprintf(dat, "%u %.6g %.6g %.6g %u\n", k, f[k].mae_history, f[k].mae_none, f[k].mae_at_once, f[k].at_once_spp);
    if (!pn_bench_close_out(dat, path, tmp))
        return false;
    snprintf(name, sizeof name, "%s.gp", stem);
    FILE *gp = pn_bench_open_out(o->out_dir, name, path, tmp);
    if (!gp)
        return false;
    fprintf(gp,
            "set terminal pngcairo size 900,540 noenhanced\nset output '%s.png'\nset title '%s'\n"
            "set xlabel 'frame'\nset ylabel 'MAE of V against the frame''s converged reference'\nset logscale y\n"
            "set grid\nset key top right\n"
            "plot '%s.dat' using 1:2 with linespoints title 'with the history', "
            "'' using 1:3 with linespoints title 'the frame alone', "
            "'' using 1:4 with linespoints title 'at once: min(k+1, history) x spp'\n",
            stem, title, stem);
    if (!pn_bench_close_out(gp, path, tmp))
        return false;
    char cmd[8192];
    snprintf(cmd, sizeof cmd, "cd '%s' && gnuplot '%s.gp' 2>/dev/null", o->out_dir, stem);
    if (system(cmd) != 0)
        pn_warn("gnuplot could not draw %s.gp (is gnuplot-nox installed?)", stem);
    return true;
}

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

// Moves the sequence's object to frame k's place (KIND_OBJECT): the scene's object 0 to its
// offset, every renderer's structures built again over it, the history told of its boxes before
// and after. `rest` holds its vertices' positions at rest.
static bool object_frame(pn_gpu_device *dev, pn_prepared_scene *prep, const pn_setup_desc *sd, pn_setup *s, int count,
                         const float (*rest)[3], const float offset[3], const pn_light *light)
{
    pn_scene *scene = &prep->scene;
    const pn_scene_object *ob = &scene->objects[0];
    double lo[2][3], hi[2][3];
    object_box(scene, 0, lo[0], hi[0]);
    for (uint32_t v = 0; v < ob->vertex_count; v++)
        for (int k = 0; k < 3; k++)
            scene->vertices[ob->first_vertex + v].pos[k] = rest[v][k] + offset[k];
    pn_scene_update_bounds(scene);
    object_box(scene, 0, lo[1], hi[1]);
    for (int b = 0; b < 2; b++)
        pn_renderer_history_moved(&s[0].renderer, lo[b], hi[b]);
    for (int i = 0; i < count; i++) {
        pn_setup_desc d = *sd;
        d.frame = s[i].renderer.desc;
        if (pn_setup_rebuild(dev, scene, light, &d, ob->first_vertex, ob->vertex_count, &s[i]) != PN_OK)
            return false;
    }
    return true;
}

// One sequence of one configuration: frames 0 .. seq_frames - 1 with and without the history and at
// once; lines into csv, a summary on stdout, a plot.
static int run_sequence(const bench_opts *o, pn_gpu_device *dev, pn_embree *rtc, pn_prepared_scene *prep,
                        const char *view, uint32_t w, uint32_t h, int kind, pn_shadow_mode mode, pn_filter filter,
                        uint32_t spp, FILE *csv)
{
    size_t px = (size_t)w * h;
    uint32_t frames = o->seq_frames;
    pn_camera cam;
    pn_light light;
    frame_at(kind, 0, o->seq_step, prep, &cam, &light);
    // No culling to the view: a tree culled to each frame's camera would change its cells with it,
    // where the history relies on V at a point not depending on the camera (render --temporal's rule).
    pn_setup_desc sd = {.frame = {.width = w, .height = h, .mode = mode, .traversal = o->traversal, .sampler = o->sampler,
                                  .seed = o->seed, .spp = spp, .filter = filter, .tile_w = o->tile_w, .tile_h = o->tile_h},
                        .tree_n = o->trees[0][0], .tree_d = o->trees[0][1]};
    // The moving object: where it rests, and the way it moves (level, square to the light's
    // direction), its bounding radius the step's unit.
    bool object = kind == KIND_OBJECT;
    const pn_scene_object *ob = object ? &prep->scene.objects[0] : NULL;
    float (*rest)[3] = NULL, side[3] = {0, 0, 0};
    double radius = 0;
    if (object) {
        rest = malloc((size_t)ob->vertex_count * sizeof *rest);
        for (uint32_t v = 0; rest && v < ob->vertex_count; v++)
            memcpy(rest[v], prep->scene.vertices[ob->first_vertex + v].pos, sizeof rest[v]);
        double lo[3], hi[3];
        object_box(&prep->scene, 0, lo, hi);
        radius = 0.5 * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                            (hi[2] - lo[2]) * (hi[2] - lo[2]));
        float dx = light.normal[0], dz = light.normal[2], len = sqrtf(dx * dx + dz * dz);
        side[0] = len > 0 ? -dz / len : 1.0f, side[2] = len > 0 ? dx / len : 0.0f;
    }
    // With the history, without, at once, (object) 16 spp unfiltered; then (Embree) the peer's exact,
    // whose ray dump holds PEER_MAX_SPP + 1 points of 16 bytes a pixel (1.1 GB at 1280x720: none
    // beyond 1 GiB).
    bool peer_on = rtc && (uint64_t)px * (PEER_MAX_SPP + 1) * 16 <= (1ull << 30);
    if (rtc && !peer_on)
        pn_warn("bench --sequence: %ux%u: the CPU peer's ray dump would pass 1 GiB: no Embree per frame", w, h);
    int count = object ? 4 : 3, peer = peer_on ? count : -1;
    count += peer_on;
    pn_setup s[5] = {0};
    pn_embree_scene *rtc_scene = NULL;
    int made = 0, rc = PN_EXIT_OK;
    if (object && !rest) {
        pn_error("bench --sequence object: out of memory for %s's object", view);
        rc = PN_EXIT_FAILURE;
    }
    float offset[3];
    if (object && rc == PN_EXIT_OK) {
        // Its first place before anything is built over the scene.
        object_offset(0, frames, o->seq_step, radius, side, offset);
        for (uint32_t v = 0; v < ob->vertex_count; v++)
            for (int k = 0; k < 3; k++)
                prep->scene.vertices[ob->first_vertex + v].pos[k] = rest[v][k] + offset[k];
        pn_scene_update_bounds(&prep->scene);
    }
    for (; made < count && rc == PN_EXIT_OK; made++) {
        pn_setup_desc d = sd;
        if (made == 3 && object)
            d.frame.filter = PN_FILTER_NONE, d.frame.spp = 16;
        if (made == peer)
            d.frame.mode = PN_SHADOW_EXACT, d.frame.filter = PN_FILTER_NONE, d.frame.spp = PEER_MAX_SPP,
            d.frame.traversal = PN_TRAVERSAL_AUTO, d.frame.dump_rays = true;
        if (pn_setup_create(dev, &prep->scene, &light, &d, &s[made]) != PN_OK)
            rc = PN_EXIT_FAILURE;
    }
    float *ref = malloc(2 * px * sizeof *ref); // this frame's, the last frame's
    uint8_t *mask = malloc(2 * px);            // covered; and V changed since the last frame
    seq_frame *f = calloc(frames, sizeof *f);
    double *ratio = calloc(frames, sizeof *ratio);
    if (rc == PN_EXIT_OK && (!ref || !mask || !f || !ratio)) {
        pn_error("bench --sequence: out of memory for %ux%u", w, h);
        rc = PN_EXIT_FAILURE;
    }
    if (rc == PN_EXIT_OK && pn_renderer_set_history(&s[0].renderer, o->seq_history) != PN_OK)
        rc = PN_EXIT_FAILURE;
    // V changed between two frames' references where they differ by more than 4 deviations of the
    // difference of two means of reference_spp samples (each at most 0.5 / sqrt(n)): not their noise.
    const double changed_by = 4.0 * sqrt(2.0) * 0.5 / sqrt((double)o->reference_spp);
    for (uint32_t k = 0; k < frames && rc == PN_EXIT_OK; k++) {
        frame_at(kind, (int)k, o->seq_step, prep, &cam, &light);
        if (object && k > 0) {
            object_offset((int)k, frames, o->seq_step, radius, side, offset);
            if (!object_frame(dev, prep, &sd, s, count, (const float(*)[3])rest, offset, &light)) {
                rc = PN_EXIT_FAILURE;
                break;
            }
        }
        if (k > 0)
            memcpy(ref + px, ref, px * sizeof *ref);
        if (pn_bench_reference(o, dev, &prep->scene, view, &cam, &light, w, h, ref, mask) != PN_OK) {
            rc = PN_EXIT_FAILURE;
            break;
        }
        seq_frame *fk = &f[k];
        fk->at_once_spp = spp * (k + 1 < o->seq_history ? k + 1 : o->seq_history);
        pn_frame_times t[5];
        bool ok = pn_renderer_set_spp(&s[2].renderer, fk->at_once_spp) == PN_OK;
        if (k == 0 && peer >= 0) // its dump only where Embree traces it (peer_frame)
            ok = ok && pn_renderer_set_dump_rays(&s[peer].renderer, false) == PN_OK;
        for (int i = 0; i < count && ok; i++)
            ok = i == peer || pn_renderer_render_lights(&s[i].renderer, &cam, &light, 1, &t[i]) == PN_OK;
        if (!ok) {
            rc = PN_EXIT_FAILURE;
            break;
        }
        fk->mae_history = frame_error(&s[0].renderer, ref, mask, px, &fk->history_samples);
        fk->mae_none = frame_error(&s[1].renderer, ref, mask, px, NULL);
        fk->mae_at_once = frame_error(&s[2].renderer, ref, mask, px, NULL);
        fk->ms_history = frame_ms(&t[0]), fk->ms_none = frame_ms(&t[1]);
        fk->mae_16 = fk->mae_history_changed = fk->mae_none_changed = fk->embree_ms = NAN;
        if (peer >= 0) {
            // Embree's BVH over the scene as it is (again each frame the object moved: it shares
            // the scene's buffers, which must not change under it).
            if (peer_on && (!rtc_scene || object)) {
                pn_embree_scene_destroy(rtc_scene);
                rtc_scene = pn_embree_scene_create(rtc, &prep->scene);
                if (!rtc_scene)
                    pn_warn("bench --sequence: Embree could not build %s: no CPU peer from frame %u", view, k);
                peer_on = rtc_scene != NULL;
            }
            if (peer_on && !peer_frame(o, rtc_scene, &s[peer], &cam, &light, ref, mask, px, fk)) {
                rc = PN_EXIT_FAILURE;
                break;
            }
        }
        if (object) {
            fk->mae_16 = frame_error(&s[3].renderer, ref, mask, px, NULL);
            uint8_t *changed = mask + px;
            fk->changed = 0;
            for (size_t i = 0; i < px; i++) {
                changed[i] = k > 0 && mask[i] && fabs((double)ref[i] - ref[px + i]) > changed_by;
                fk->changed += changed[i];
            }
            if (fk->changed) {
                fk->mae_history_changed = frame_error(&s[0].renderer, ref, changed, px, NULL);
                fk->mae_none_changed = frame_error(&s[1].renderer, ref, changed, px, NULL);
            }
        }
        fprintf(csv, "%s,%u,%u,%s,%s,%s,%u,%u,%u,%.3f,%.6g,%.6g,%u,%.6g,%.3f,%.3f,%.6g,%zu,%.6g,%.6g,%u,%.3f\n", view,
                w, h, KIND_NAMES[kind], MODE_NAME(mode), pn_filter_names[filter], spp, o->seq_history, k,
                fk->history_samples, fk->mae_history, fk->mae_none, fk->at_once_spp, fk->mae_at_once, fk->ms_history,
                fk->ms_none, fk->mae_16, fk->changed, fk->mae_history_changed, fk->mae_none_changed, fk->embree_spp,
                fk->embree_ms);
    }
    if (rc == PN_EXIT_OK) {
        // The summary: from frame 15 on (the targets' "from frame 15"), the worst ratios of the error
        // with the history to the frame alone's and to the at-once frame's, and the median ratio of
        // their frame times (the first frames carry the pipelines' first runs: left out).
        uint32_t from = frames > 16 ? 15 : 0;
        double worst_none = 0, worst_once = 0, worst_16 = 0, worst_ghost = 0;
        double *vs_embree = calloc(frames, sizeof *vs_embree);
        int n = 0, n_embree = 0;
        for (uint32_t k = from; k < frames; k++) {
            worst_none = fmax(worst_none, f[k].mae_history / f[k].mae_none);
            worst_once = fmax(worst_once, f[k].mae_history / f[k].mae_at_once);
            worst_16 = fmax(worst_16, f[k].mae_history / f[k].mae_16);
            ratio[n++] = f[k].ms_history / f[k].ms_none;
            if (vs_embree && f[k].embree_spp)
                vs_embree[n_embree++] = f[k].embree_ms / f[k].ms_history;
        }
        for (uint32_t k = 0; object && k < frames; k++)
            if (f[k].changed)
                worst_ghost = fmax(worst_ghost, f[k].mae_history_changed / f[k].mae_none_changed);
        qsort(ratio, (size_t)n, sizeof *ratio, by_value);
        printf("sequence %-6s %-10s %ux%u %-9s%-9s %3u spp: frame %u MAE %.5f with the history, %.5f alone, %.5f at "
               "once (%u spp); from frame %u the worst ratio to alone %.2f, to at once %.2f",
               KIND_NAMES[kind], view, w, h, MODE_NAME(mode), pn_bench_filter_suffix(filter), spp, frames - 1,
               f[frames - 1].mae_history, f[frames - 1].mae_none, f[frames - 1].mae_at_once, f[frames - 1].at_once_spp,
               from, worst_none, worst_once);
        if (object)
            printf(", to 16 spp unfiltered %.2f; where V changed, the worst ratio to alone %.2f", worst_16, worst_ghost);
        printf("; frame time %.2fx", n ? ratio[n / 2] : 0.0);
        if (peer >= 0 && peer_on && vs_embree) {
            // Embree's time at equal error over the frame's with the history: the median from frame
            // `from` of the frames whose error plain exact reaches within PEER_MAX_SPP.
            qsort(vs_embree, (size_t)n_embree, sizeof *vs_embree, by_value);
            if (n_embree)
                printf("; Embree at its error %.2fx the frame's time (%d of %u frames)", vs_embree[n_embree / 2],
                       n_embree, frames - from);
            else
                printf("; Embree not at its error within %u spp", (unsigned)PEER_MAX_SPP);
        }
        free(vs_embree);
        printf("\n");
        char stem[512], title[512];
        snprintf(stem, sizeof stem, "seq_%s_%ux%u_%s_%s%s_%uspp", view, w, h, KIND_NAMES[kind], MODE_NAME(mode),
                 pn_bench_filter_suffix(filter), spp);
        for (char *c = stem; *c; c++)
            if (*c == ':' || *c == '/' || *c == ' ' || *c == '+')
                *c = '_';
        snprintf(title, sizeof title, "%s %ux%u, %s %.3g %s a frame: %s%s, %u spp a frame, history %u frames", view, w,
                 h, KIND_NAMES[kind], o->seq_step, object || kind == KIND_WALK ? "% of a radius" : "deg", MODE_NAME(mode),
                 pn_bench_filter_suffix(filter), spp, o->seq_history);
        if (!write_plot(o, stem, f, frames, title))
            rc = PN_EXIT_FAILURE;
    }
    // The scene as it was, for the sequences after this one (Embree's BVH over it gone first).
    pn_embree_scene_destroy(rtc_scene);
    if (object && rest) {
        for (uint32_t v = 0; v < ob->vertex_count; v++)
            memcpy(prep->scene.vertices[ob->first_vertex + v].pos, rest[v], sizeof rest[v]);
        pn_scene_update_bounds(&prep->scene);
    }
    free(rest), free(ref), free(mask), free(f), free(ratio);
    for (int i = 0; i < made; i++)
        pn_setup_destroy(dev, &s[i]);
    return rc;
}

static int sequences(const bench_opts *o, pn_gpu_device *dev, pn_embree *rtc)
{
    char path[4096], tmp[4096];
    FILE *csv = pn_bench_open_out(o->out_dir, "sequence.csv", path, tmp);
    if (!csv)
        return PN_EXIT_FAILURE;
    fprintf(csv, "view,width,height,sequence,mode,filter,spp,history,frame,history_samples,mae_history,mae_none,"
                 "at_once_spp,mae_at_once,ms_history,ms_none,mae_16_unfiltered,changed_px,mae_history_changed,"
                 "mae_none_changed,embree_spp,embree_ms\n");
    int rc = PN_EXIT_OK;
    uint64_t t0 = pn_time_ns();
    for (int vi = 0; vi < o->view_count && rc == PN_EXIT_OK; vi++) {
        pn_prepared_scene prep;
        if ((rc = pn_bench_view_prepare(&o->views[vi], &prep)) != PN_EXIT_OK)
            break;
        for (int si = 0; si < o->size_count && rc == PN_EXIT_OK; si++)
            for (int kind = 0; kind < PN_BENCH_SEQUENCES && rc == PN_EXIT_OK; kind++)
                for (int mi = 0; mi < o->mode_count && rc == PN_EXIT_OK; mi++)
                    for (int fi = 0; fi < o->filter_count && rc == PN_EXIT_OK; fi++)
                        for (int pi = 0; pi < o->spp_count && rc == PN_EXIT_OK; pi++) {
                            const pn_shadow_mode_info *m = pn_shadow_mode_get(o->modes[mi]);
                            // Uniform samples of a tracing mode: what the history takes; the light
                            // sequence without a tree (culled by the first frame's light); the
                            // object's where the scene has one that is not all of it.
                            const pn_scene *sc = &prep.scene;
                            bool movable = sc->object_count > 0 && sc->objects[0].index_count > 0 &&
                                           sc->objects[0].vertex_count < sc->vertex_count;
                            if (kind == KIND_OBJECT && o->sequences[kind] && !movable && mi == 0 && fi == 0 && pi == 0)
                                pn_warn("bench --sequence object: %s has no object to move (a glTF node with a "
                                        "mesh that is not the whole scene): skipped", o->views[vi].name);
                            if (!o->sequences[kind] || o->spp_mins[pi] || !m->traces ||
                                (kind == KIND_LIGHT && m->needs.tree) || (kind == KIND_OBJECT && !movable))
                                continue;
                            rc = run_sequence(o, dev, rtc, &prep, o->views[vi].name, o->sizes[si][0],
                                              o->sizes[si][1], kind, o->modes[mi], o->filters[fi], o->spps[pi], csv);
                            fflush(stdout);
                        }
        pn_scene_destroy(&prep.scene);
    }
    // A failed run leaves no partial table behind (written to a temporary name, removed).
    if (rc != PN_EXIT_OK) {
        fclose(csv);
        remove(tmp);
        return rc;
    }
    if (!pn_bench_close_out(csv, path, tmp))
        return PN_EXIT_FAILURE;
    fprintf(stderr, "bench: sequences in %.1f s; %s and seq_*.png\n", pn_ms_since(t0) * 1e-3, path);
    return PN_EXIT_OK;
}

int pn_bench_sequences(const bench_opts *o, pn_gpu_device *dev)
{
    pn_embree *rtc = o->embree ? pn_embree_create() : NULL;
    if (o->embree && !rtc)
        pn_warn("Embree could not start: the sequences' CPU peer is skipped");
    int rc = sequences(o, dev, rtc);
    if (rtc)
        pn_embree_destroy(rtc);
    return rc;
}
