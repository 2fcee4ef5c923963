// The demo's trees kept up with the scene: a rebuild on the worker thread swapped in when done
// (the renderers then read it, their history dropped where its shadows changed), the next one
// started when the wanted tree differs, and objects moved since the last frame brought into the
// renderers and the trees.
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

#include "apps/demo/demo.h"
#include "core/log.h"
#include "core/timer.h"

void pn_demo_boxes_join(pn_history_boxes *b, const pn_history_boxes *more)
{
    for (uint32_t i = 0; i < more->count; i++)
        pn_history_boxes_add(b, more->box[i], more->box[i] + 3);
}

// The shadow structures changed where `moved` says (geometry moved within those boxes) or, for a
// renderer whose mode ends rays in a scene-wide N-tree built anew, everywhere: its cells moved
// with the new tree (or with the new N and d), and every pixel's line-space V with them.
static void history_follows(pn_renderer *r, const pn_history_boxes *moved, bool rebuilt)
{
    if (!r->dev)
        return;
    if (rebuilt && r->shadow.mode->needs.tree) {
        pn_renderer_history_drop(r);
        return;
    }
    for (uint32_t i = 0; i < moved->count; i++)
        pn_renderer_history_moved(r, moved->box[i], moved->box[i] + 3);
}

pn_shadow_accel_desc pn_demo_tree_desc(const pn_demo *d, int n, int depth)
{
    // What every mode needs together (candidate lists, the shared BVH), so that switching modes
    // never needs a rebuild; with the same light it is the tree render builds (culling included).
    // Per-object trees serve linespace alone (the renderer's rule): its needs only.
    return (pn_shadow_accel_desc){
        .needs = d->opts.per_object ? pn_shadow_mode_get(PN_SHADOW_LINESPACE)->needs : pn_shadow_needs_all(&d->dev),
        .tree_n = n,
        .tree_d = depth,
        .max_bytes = d->opts.max_bytes ? d->opts.max_bytes : pn_gpu_device_pool_budget(&d->dev),
        .max_pool_bytes = pn_gpu_device_max_buffer(&d->dev),
        .light = d->lights,
        .light_count = d->light_count,
        .reuse_bvh = d->scene_moved ? NULL : &d->bvh,
        .per_object = d->opts.per_object,
    };
}

// Swaps in a finished rebuild and starts the next one when the wanted tree differs.
pn_result pn_demo_update_tree(pn_demo *d)
{
    pn_shadow_accel fresh;
    pn_result status;
    if (pn_demo_builder_poll(&d->builder, &fresh, &status)) {
        // Per-object trees hold no world positions: placed as the objects stand now (they may have
        // moved while the worker built), and the rest's culling asked again.
        if (status == PN_OK && fresh.desc.needs.tree && fresh.desc.per_object) {
            status = pn_objects_update(&d->scene, &fresh.objects);
            d->want_rebuild |= !pn_objects_cull_holds(&d->scene, &fresh.objects);
        }
        // The scene the worker built from: exact pools and the device's acceleration structure must
        // hold the triangles its BVH is over. Objects moved since want_rebuild: the next build follows.
        if (status == PN_OK)
            status = pn_shadow_accel_upload(&d->dev, d->builder.scene, &fresh);
        if (status == PN_OK) {
            // The renderers read the new structures from the next frame on (the queue is idle
            // between frames), and keep their history where the build changed no shadow.
            pn_shadow_accel old = d->accel;
            d->accel = fresh;
            pn_renderer_desc rd = {0};
            pn_shadow_accel_bind(&d->accel, &rd);
            pn_renderer *rs[2] = {&d->renderer, &d->exact};
            for (int i = 0; i < 2; i++)
                if (rs[i]->dev) {
                    pn_renderer_set_accel(rs[i], &d->scene, &rd);
                    history_follows(rs[i], &d->moved_building, true);
                }
            pn_shadow_accel_destroy(&d->dev, &old);
            memset(&d->moved_building, 0, sizeof d->moved_building);
            d->opts.tree_n = d->accel.desc.tree_n, d->opts.tree_d = d->accel.desc.tree_d;
            pn_info("demo: tree LS(%d,%d) swapped in: built in %.0f ms on a worker thread, %.1f MB of pools",
                    d->accel.desc.tree_n, d->accel.desc.tree_d, d->accel.build_ms,
                    pn_shadow_accel_gpu_bytes(&d->accel) / 1048576.0);
            d->build_message[0] = '\0';
        } else {
            snprintf(d->build_message, sizeof d->build_message, "tree LS(%d,%d) failed: %s; still LS(%d,%d)",
                     d->builder.desc.tree_n, d->builder.desc.tree_d, pn_result_str(status), d->accel.desc.tree_n,
                     d->accel.desc.tree_d);
            pn_shadow_accel_destroy(&d->dev, &fresh);
            d->want_n = d->accel.desc.tree_n, d->want_d = d->accel.desc.tree_d; // no retry loop
            pn_demo_boxes_join(&d->moved_pending, &d->moved_building); // still not in the structures
            memset(&d->moved_building, 0, sizeof d->moved_building);
        }
    }
    bool idle = atomic_load(&d->builder.state) == PN_DEMO_BUILD_IDLE;
    if (idle && (d->want_n != d->accel.desc.tree_n || d->want_d != d->accel.desc.tree_d || d->want_rebuild)) {
        pn_shadow_accel_desc desc = pn_demo_tree_desc(d, d->want_n, d->want_d);
        PN_TRY(pn_demo_builder_start(&d->builder, &d->scene, &desc));
        d->want_rebuild = false;
        d->moved_building = d->moved_pending; // the build holds them
        memset(&d->moved_pending, 0, sizeof d->moved_pending);
    }
    if (atomic_load(&d->builder.state) != PN_DEMO_BUILD_IDLE)
        snprintf(d->build_message, sizeof d->build_message,
                 "tree LS(%d,%d): building on the CPU, %.1f s; drawing with LS(%d,%d)", d->builder.desc.tree_n,
                 d->builder.desc.tree_d, pn_demo_builder_elapsed(&d->builder), d->accel.desc.tree_n, d->accel.desc.tree_d);
    return PN_OK;
}

// Waits for the tree builds running or due (a script's screenshot shows the scene as it stands,
// whatever the machine's speed).
pn_result pn_demo_settle_tree(pn_demo *d)
{
    for (;;) {
        PN_TRY(pn_demo_update_tree(d)); // swaps a finished build in; starts the next one due
        if (atomic_load(&d->builder.state) == PN_DEMO_BUILD_IDLE)
            return PN_OK;
        pn_demo_builder_wait(&d->builder);
    }
}

// Brings the renderers and the shadow structure up to the objects moved since the last frame
// (pn_demo_move_object moved the scene's vertices, transforms and bounds), and reports the cost.
// Per-object trees hold no world positions: the top level alone is rebuilt, no line space. The rest's
// tree (triangles of no object, e.g. --ground) was culled by the lights against the scene's bounds at
// build; a move changes neither its triangles nor the lights, only the bounds, so its culling holds
// while the moved objects stay on the kept side of every left-out triangle's plane
// (pn_objects_cull_holds), else the trees are rebuilt. The scene-wide tree, the BVH and the
// device's acceleration structure hold world-space triangles: rebuilt on the worker thread while
// the old ones keep drawing (pn_demo_update_tree).
pn_result pn_demo_apply_moves(pn_demo *d)
{
    pn_demo_move *m = &d->move;
    if (m->count == 0)
        return PN_OK;
    uint64_t t0 = pn_time_ns();
    // Renderers not created yet (the first frame) are made from the moved scene.
    uint32_t count = m->end - m->first;
    if (d->renderer.dev)
        PN_TRY(pn_renderer_update_vertices(&d->renderer, &d->scene, m->first, count));
    if (d->exact.dev)
        PN_TRY(pn_renderer_update_vertices(&d->exact, &d->scene, m->first, count));
    m->vertices_ms = pn_ms_since(t0);
    uint64_t t1 = pn_time_ns();
    if (d->accel.desc.needs.tree && d->accel.desc.per_object) {
        // A translation keeps every instance's leaf extent: the renderers' leaf_size stays right.
        PN_TRY(pn_objects_update(&d->scene, &d->accel.objects));
        m->top_ms = d->accel.objects.update_ms;
        PN_TRY(pn_gpu_objects_update(&d->dev, &d->accel.objects, &d->accel.gpu_objects));
        m->rebuild = !pn_objects_cull_holds(&d->scene, &d->accel.objects);
        m->top_upload_ms = pn_ms_since(t1) - m->top_ms;
        // The shadows follow the move at once: the history drops what its boxes reach.
        history_follows(&d->renderer, &m->boxes, false);
        history_follows(&d->exact, &m->boxes, false);
    } else {
        m->rebuild = true;
        pn_demo_boxes_join(&d->moved_pending, &m->boxes); // when the rebuild is swapped in
    }
    d->want_rebuild |= m->rebuild;
    m->total_ms = m->scene_ms + pn_ms_since(t0);
    printf("demo: frame %llu: object %u moved%s in %.2f ms (scene %.2f, G-buffer vertices %.2f", (unsigned long long)d->frame,
           m->object, m->count > 1 ? " (and others)" : "", m->total_ms, m->scene_ms, m->vertices_ms);
    if (d->accel.desc.per_object)
        printf(", top level %.2f + upload %.2f); per-object trees: %s\n", m->top_ms, m->top_upload_ms,
               m->rebuild ? "the rest's culling no longer holds, trees rebuilt on a worker thread" : "no tree rebuilt");
    else
        printf("); scene-wide tree, BVH and acceleration structure rebuilt on a worker thread\n");
    d->stats.move_ms = m->total_ms;
    d->last_move = *m;
    memset(m, 0, sizeof *m);
    return PN_OK;
}
