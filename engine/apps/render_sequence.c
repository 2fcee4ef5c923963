// penumbra render --frames: an animated scene's frames as numbered EXRs (name.%04d.exr, as offline
// renderers number them), the shadow structure built once and brought up to each pose: per-object
// trees (--trees object) by their top level alone, the scene-wide structures (N-tree, BVH, the
// device's acceleration structure) built again. A line per frame says what moving cost, and
// stderr a progress line with the time left. --shard K/N renders every N-th frame from the K-th,
// so that N jobs under any runner render the sequence between them.
#include <stdio.h>
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
                             const pn_setup_desc *sd, const pn_pose_report *pose, pn_setup *s, bool *rebuilt,
                             double *ms)
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
    pn_setup_destroy(dev, s);
    *rebuilt = true;
    pn_result r = pn_setup_create(dev, scene, lights, sd, s);
    *ms = pn_ms_since(t0);
    return r;
}

int pn_render_sequence(const pn_render_cmd_opts *o, pn_prepared_scene *prep, pn_gpu_device *dev)
{
    const pn_sequence *q = &o->seq;
    long long count = 0, mine = 0;
    for (long long f = q->first; f <= q->last; f += q->step, count++)
        mine += count % q->shard_n == q->shard_k - 1;
    printf("%s: frames %lld to %lld step %lld at %g fps: %lld frames%s", prep->scene.name, q->first, q->last, q->step,
           q->fps, count, q->shard_n > 1 ? "" : "\n");
    if (q->shard_n > 1)
        printf(", shard %d/%d renders %lld of them\n", q->shard_k, q->shard_n, mine);
    pn_setup_desc sd = pn_render_opts_setup(&o->r);
    sd.frame.keep_window = o->aovs; // shadow.V_window, with the penumbra filter
    sd.view = o->view_cull ? &prep->camera : NULL;
    sd.light_count = prep->light_count;
    pn_setup s = {0};
    bool have = false;
    int rc = PN_EXIT_OK;
    uint64_t t_start = pn_time_ns();
    long long done = 0, index = 0;
    double build_total = 0;
    uint32_t full_builds = 0;
    for (long long f = q->first; f <= q->last && rc == PN_EXIT_OK; f += q->step, index++) {
        if (index % q->shard_n != q->shard_k - 1)
            continue;
        double t = (double)f / q->fps;
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
            move_ms = pn_ms_since(t0);
            have = true;
        } else if (follow_pose(dev, &prep->scene, prep->lights, prep->light_count, &sd, &prep->pose, &s, &rebuilt,
                               &move_ms) != PN_OK) {
            rc = PN_EXIT_FAILURE; // (a failed build leaves s empty, which destroys as nothing)
            break;
        }
        full_builds += rebuilt;
        build_total += move_ms;
        pn_frame_times times;
        pn_frame_images img;
        char name[4096];
        pn_frame_name(o->output, f, name, sizeof name);
        if (pn_renderer_render_lights(&s.renderer, &prep->camera, prep->lights, prep->light_count, &times) != PN_OK) {
            rc = PN_EXIT_FAILURE;
            break;
        }
        pn_renderer_images(&s.renderer, &img);
        pn_render_record rec = {.opts = &o->r, .scene = &prep->scene, .camera = &prep->camera, .lights = prep->lights,
                                .light_count = prep->light_count, .times = times, .build_ms = move_ms};
        pn_exr_attr extra[2] = {{.name = "penumbra.frame", .type = PN_EXR_ATTR_INT, .i = (int32_t)f},
                                {.name = "penumbra.time", .type = PN_EXR_ATTR_FLOAT, .f = {(float)t}}};
        if (pn_render_write_exr(name, &rec, &img, o->aovs, extra, 2) != PN_OK) {
            rc = PN_EXIT_FAILURE;
            break;
        }
        done++;
        double elapsed = pn_ms_since(t_start) * 1e-3;
        printf("frame %lld (%.4g s): %u object(s) posed in %.2f ms; %s in %.2f ms; shadow %.1f ms -> %s\n", f, t,
               prep->pose.objects, prep->pose.ms,
               done == 1 ? "shadow structure built" : rebuilt ? "shadow structure built again" : "top level updated",
               move_ms, times.shadow_ms, name);
        fprintf(stderr, "render: %lld/%lld frames, %.1f s elapsed, about %.1f s left\n", done, mine, elapsed,
                elapsed / (double)done * (double)(mine - done));
        fflush(stdout);
    }
    if (have)
        pn_setup_destroy(dev, &s);
    if (rc == PN_EXIT_OK)
        printf("%lld frames in %.1f s; the shadow structure built %u time%s, %.1f ms building and updating in all\n",
               done, pn_ms_since(t_start) * 1e-3, full_builds, full_builds == 1 ? "" : "s", build_total);
    return rc;
}
