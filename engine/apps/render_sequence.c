// penumbra render --frames: an animated scene's frames as numbered EXRs (name.%04d.exr, as offline
// renderers number them), the shadow structure built once and brought up to each pose: per-object
// trees (--trees object) by their top level alone, the scene-wide structures (N-tree, BVH, the
// device's acceleration structure) built again. A line per frame says what moving cost, and
// stderr a progress line with the time left. --shard K/N renders every N-th frame from the K-th,
// so that N jobs under any runner render the sequence between them.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/render_output.h"
#include "apps/render_sequence.h"
#include "core/log.h"
#include "core/timer.h"
#include "shadow/setup.h"

bool pn_parse_frames(const char *v, pn_sequence *q)
{
    long long x[3] = {0, 0, 1};
    int n = 0;
    char buf[128];
    snprintf(buf, sizeof buf, "%s", v);
    bool ok = strlen(v) < sizeof buf;
    for (char *p = buf, *colon; ok && p && n < 3; p = colon ? colon + 1 : NULL) {
        colon = strchr(p, ':');
        if (colon)
            *colon = '\0';
        ok = pn_parse_int_range("--frames", p, n == 2 ? 1 : -1000000000, 1000000000, &x[n]);
        n++;
        if (colon && n == 3)
            ok = false;
    }
    if (!ok || n < 2 || x[0] > x[1]) {
        if (ok)
            pn_error("--frames: expected FIRST:LAST[:STEP] with FIRST <= LAST, got '%s'", v);
        return false;
    }
    q->on = true;
    q->first = x[0], q->last = x[1], q->step = x[2];
    return true;
}

bool pn_frame_pattern_ok(const char *opt, const char *pattern)
{
    const char *p = strchr(pattern, '%');
    bool ok = p != NULL;
    if (ok) {
        const char *q = p + 1;
        while (*q >= '0' && *q <= '9' && q - p < 4)
            q++;
        ok = *q == 'd' && !strchr(q + 1, '%');
    }
    if (!ok)
        pn_error("%s %s: with --frames, the name takes the frame number as one %%d or %%0Nd (e.g. shot.%%04d.exr)",
                 opt, pattern);
    return ok;
}

void pn_frame_name(const char *pattern, long long f, char *out, size_t n)
{
    const char *p = strchr(pattern, '%'), *d = strchr(p, 'd');
    char conv[16];
    snprintf(conv, sizeof conv, "%.*sll%s", (int)(d - p), p, "d");
    char head[4096];
    snprintf(head, sizeof head, "%.*s", (int)(p - pattern), pattern);
    char num[64];
    snprintf(num, sizeof num, conv, f);
    snprintf(out, n, "%s%s%s", head, num, d + 1);
}

// Brings the set-up up to the scene as posed: per-object trees by their top level (unless the
// rest's culling no longer holds), everything else built again. *rebuilt: a full build.
static pn_result follow_pose(pn_gpu_device *dev, const pn_scene *scene, const pn_light *lights, uint32_t light_count,
                             const pn_setup_desc *sd, const pn_pose_report *pose, bool keep_renderer, pn_setup *s,
                             bool *rebuilt, double *ms)
{
    uint64_t t0 = pn_time_ns();
    *rebuilt = false;
    if (s->accel.desc.per_object && pn_objects_cull_holds(scene, &s->accel.objects)) {
        PN_TRY(pn_objects_update(scene, &s->accel.objects));
        PN_TRY(pn_gpu_objects_update(dev, &s->accel.objects, &s->accel.gpu_objects));
        if (pose->end_vertex > pose->first_vertex)
            PN_TRY(pn_renderer_update_vertices(&s->renderer, scene, pose->first_vertex,
                                               pose->end_vertex - pose->first_vertex));
        // A turned or scaled instance changes its leaves' extent along the world's axes.
        pn_renderer_set_leaf_size(&s->renderer, s->accel.objects.leaf_size);
        *ms = pn_ms_since(t0);
        return PN_OK;
    }
    *rebuilt = true;
    pn_result r;
    if (keep_renderer) { // its temporal history with it
        r = pn_setup_rebuild(dev, scene, lights, sd, pose->first_vertex, pose->end_vertex - pose->first_vertex, s);
    } else {
        pn_setup_destroy(dev, s);
        r = pn_setup_create(dev, scene, lights, sd, s);
    }
    *ms = pn_ms_since(t0);
    return r;
}

// --temporal: the boxes, before and after, of every posed primitive whose vertices the pose moved
// (`was`: the scene's positions before it), given to the renderer's history. Whether any moved.
static bool history_moves(const pn_scene *scene, const float (*was)[3], pn_renderer *r)
{
    const pn_scene_anim *a = scene->anim;
    bool any = false;
    for (uint32_t i = 0; a && i < a->prim_count; i++) {
        const pn_anim_prim *p = &a->prims[i];
        uint32_t count = p->normals ? p->vertex_count : 3 * p->triangle_count;
        double box[2][6] = {{INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY},
                            {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY}};
        bool moved = false;
        for (uint32_t v = p->first_vertex; v < p->first_vertex + count; v++) {
            const float *now = scene->vertices[v].pos;
            moved = moved || memcmp(now, was[v], sizeof was[v]) != 0;
            for (int k = 0; k < 3; k++) {
                box[0][k] = fmin(box[0][k], was[v][k]), box[0][3 + k] = fmax(box[0][3 + k], was[v][k]);
                box[1][k] = fmin(box[1][k], now[k]), box[1][3 + k] = fmax(box[1][3 + k], now[k]);
            }
        }
        for (int b = 0; moved && b < 2; b++)
            pn_renderer_history_moved(r, box[b], box[b] + 3);
        any = any || moved;
    }
    return any;
}

// Which frames (by index in the sequence) this run renders, [*from, *end), and from which it
// writes (*write_from): with a shard, every shard_n-th from the shard_k-th; with --temporal a run
// of consecutive frames instead, after `history` frames before it that only feed its history.
static void shard_frames(const pn_sequence *q, long long count, long long *from, long long *write_from, long long *end)
{
    if (!q->temporal || q->shard_n == 1) {
        *from = *write_from = 0, *end = count;
        return;
    }
    long long per = (count + q->shard_n - 1) / q->shard_n;
    *write_from = per * (q->shard_k - 1);
    if (*write_from >= count) { // more shards than shares: nothing to render
        *from = *write_from = *end = count;
        return;
    }
    *end = *write_from + per < count ? *write_from + per : count;
    *from = *write_from > q->history ? *write_from - q->history : 0;
}

static bool writes(const pn_sequence *q, long long index, long long write_from, long long end)
{
    if (q->temporal)
        return index >= write_from && index < end;
    return index % q->shard_n == q->shard_k - 1;
}

int pn_render_sequence(const pn_render_cmd_opts *o, pn_prepared_scene *prep, pn_gpu_device *dev)
{
    const pn_sequence *q = &o->seq;
    long long count = 0, mine = 0, from, write_from, end;
    for (long long f = q->first; f <= q->last; f += q->step)
        count++;
    shard_frames(q, count, &from, &write_from, &end);
    for (long long j = from; j < end; j++)
        mine += writes(q, j, write_from, end);
    printf("%s: frames %lld to %lld step %lld at %g fps: %lld frames%s", prep->scene.name, q->first, q->last, q->step,
           q->fps, count, q->shard_n > 1 ? "" : "\n");
    if (q->shard_n > 1)
        printf(", shard %d/%d renders %lld of them%s\n", q->shard_k, q->shard_n, mine,
               q->temporal && write_from > from ? " after the history's frames before them" : "");
    pn_setup_desc sd = pn_render_opts_setup(&o->r);
    sd.frame.keep_window = o->aovs; // shadow.V_window, with the penumbra filter
    // Under --temporal no view culling: a tree culled to each frame's view would change its cells
    // with the camera (the line-space modes' V with them), where the history relies on V at a point
    // not depending on the camera.
    sd.view = o->view_cull && !q->temporal ? &prep->camera : NULL;
    sd.light_count = prep->light_count;
    pn_setup s = {0};
    bool have = false;
    int rc = PN_EXIT_OK;
    uint64_t t_start = pn_time_ns();
    long long done = 0;
    double build_total = 0;
    uint32_t full_builds = 0;
    // --temporal: the scene's positions before each pose, for the boxes of what it moved (a scene
    // without animation never moves).
    bool poses = q->temporal && prep->scene.anim;
    float(*was)[3] = poses ? malloc(((size_t)prep->scene.vertex_count + 1) * sizeof *was) : NULL;
    if (poses && !was) {
        pn_error("%s: out of memory for the history's vertex copy", prep->scene.name);
        return PN_EXIT_FAILURE;
    }
    for (long long index = from; index < end && rc == PN_EXIT_OK; index++) {
        long long f = q->first + index * q->step;
        bool write = writes(q, index, write_from, end);
        if (!write && !q->temporal)
            continue;
        double t = (double)f / q->fps;
        for (uint32_t v = 0; was && v < prep->scene.vertex_count; v++)
            memcpy(was[v], prep->scene.vertices[v].pos, sizeof was[v]);
        rc = pn_render_pose(&o->r, prep, t);
        if (rc != PN_EXIT_OK)
            break;
        bool rebuilt = true;
        double move_ms = 0;
        if (!have) {
            uint64_t t0 = pn_time_ns();
            if (pn_setup_create(dev, &prep->scene, prep->lights, &sd, &s) != PN_OK) {
                rc = PN_EXIT_FAILURE;
                break;
            }
            have = true;
            if (q->temporal && pn_renderer_set_history(&s.renderer, (uint32_t)q->history) != PN_OK) {
                rc = PN_EXIT_FAILURE;
                break;
            }
            move_ms = pn_ms_since(t0);
        } else {
            bool moved = poses && history_moves(&prep->scene, was, &s.renderer);
            if (follow_pose(dev, &prep->scene, prep->lights, prep->light_count, &sd, &prep->pose, q->temporal, &s,
                            &rebuilt, &move_ms) != PN_OK) {
                rc = PN_EXIT_FAILURE; // (a failed build leaves s empty, which destroys as nothing)
                break;
            }
            // The boxes bound where V changed for the modes that test triangles. A line-space tree
            // built again over moved geometry may have another root box, and then every cell and
            // every pixel's approximation moves: its history goes (per-object trees moved by their
            // top level keep their own cells, and the boxes hold).
            bool scene_tree = pn_shadow_mode_get(o->r.mode)->needs.tree && !(s.accel.desc.per_object && !rebuilt);
            if (moved && scene_tree)
                pn_renderer_history_drop(&s.renderer);
        }
        full_builds += rebuilt;
        build_total += move_ms;
        // Each frame its own samples for the history to add up, the window's share of its place in
        // the sequence (the same in every shard; consecutive whatever the step).
        if (q->temporal)
            pn_renderer_set_history_frame(&s.renderer, (uint32_t)index);
        pn_frame_times times;
        pn_frame_images img;
        char name[4096];
        pn_frame_name(o->output, f, name, sizeof name);
        if (pn_renderer_render_lights(&s.renderer, &prep->camera, prep->lights, prep->light_count, &times) != PN_OK) {
            rc = PN_EXIT_FAILURE;
            break;
        }
        pn_renderer_images(&s.renderer, &img);
        char history[96] = "";
        if (img.history) {
            double sum = 0;
            long long covered = 0;
            for (size_t i = 0; i < (size_t)o->r.width * o->r.height; i++)
                if (img.p[4 * i + 3] > 0)
                    sum += img.history[4 * i + 1], covered++;
            snprintf(history, sizeof history, "; history %.1f samples a pixel", covered ? sum / (double)covered : 0.0);
        }
        if (!write) {
            printf("frame %lld (%.4g s): rendered for the history of the frames after it%s\n", f, t, history);
            continue;
        }
        pn_render_record rec = {.opts = &o->r, .scene = &prep->scene, .camera = &prep->camera, .lights = prep->lights,
                                .light_count = prep->light_count, .times = times, .build_ms = move_ms};
        pn_exr_attr extra[3] = {{.name = "penumbra.frame", .type = PN_EXR_ATTR_INT, .i = (int32_t)f},
                                {.name = "penumbra.time", .type = PN_EXR_ATTR_FLOAT, .f = {(float)t}},
                                {.name = "penumbra.history", .type = PN_EXR_ATTR_INT, .i = (int32_t)q->history}};
        if (pn_render_write_exr(name, &rec, &img, o->aovs, extra, q->temporal ? 3 : 2) != PN_OK) {
            rc = PN_EXIT_FAILURE;
            break;
        }
        done++;
        double elapsed = pn_ms_since(t_start) * 1e-3;
        printf("frame %lld (%.4g s): %u object(s) posed in %.2f ms; %s in %.2f ms; shadow %.1f ms%s -> %s\n", f, t,
               prep->pose.objects, prep->pose.ms,
               done == 1 ? "shadow structure built" : rebuilt ? "shadow structure built again" : "top level updated",
               move_ms, times.shadow_ms, history, name);
        fprintf(stderr, "render: %lld/%lld frames, %.1f s elapsed, about %.1f s left\n", done, mine, elapsed,
                elapsed / (double)done * (double)(mine - done));
        fflush(stdout);
    }
    free(was);
    if (have)
        pn_setup_destroy(dev, &s);
    if (rc == PN_EXIT_OK)
        printf("%lld frames in %.1f s; the shadow structure built %u time%s, %.1f ms building and updating in all\n",
               done, pn_ms_since(t_start) * 1e-3, full_builds, full_builds == 1 ? "" : "s", build_total);
    return rc;
}
