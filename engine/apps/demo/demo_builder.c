// N-tree rebuilds on a worker thread: the frame loop keeps drawing with the old tree until the new
// one is built, then uploads it (Vulkan stays on the frame loop's thread).
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "apps/demo/demo.h"
#include "core/timer.h"

// The parts of `s` a move changes (pn_scene_move_object: vertices, object transforms, bounds) copied
// into *out, the rest shared with `s`: free with snapshot_free, never pn_scene_destroy.
static pn_result snapshot_take(const pn_scene *s, pn_scene *out)
{
    *out = *s;
    out->vertices = malloc((s->vertex_count ? s->vertex_count : 1) * sizeof *out->vertices);
    out->objects = malloc((s->object_count ? s->object_count : 1) * sizeof *out->objects);
    if (!out->vertices || !out->objects) {
        free(out->vertices);
        free(out->objects);
        memset(out, 0, sizeof *out);
        return PN_ERR_MEMORY;
    }
    memcpy(out->vertices, s->vertices, s->vertex_count * sizeof *out->vertices);
    memcpy(out->objects, s->objects, s->object_count * sizeof *out->objects);
    return PN_OK;
}

static void snapshot_free(pn_scene *s)
{
    free(s->vertices);
    free(s->objects);
    memset(s, 0, sizeof *s);
}

static void *build(void *arg)
{
    pn_demo_builder *b = arg;
    b->status = pn_shadow_accel_build(b->scene, &b->desc, &b->result);
    // Release: the result is complete before the frame loop sees DONE.
    atomic_store_explicit(&b->state, PN_DEMO_BUILD_DONE, memory_order_release);
    return NULL;
}

pn_result pn_demo_builder_start(pn_demo_builder *b, const pn_scene *scene, const pn_shadow_accel_desc *desc)
{
    if (atomic_load(&b->state) != PN_DEMO_BUILD_IDLE) {
        pn_error("demo: a tree build is already running");
        return PN_ERR_INVALID;
    }
    snapshot_free(&b->snapshot); // the last build's, uploaded by now
    b->scene = scene;
    if (scene->object_count > 0) {
        if (snapshot_take(scene, &b->snapshot) != PN_OK) {
            pn_error("demo: out of memory copying the scene for a tree build");
            return PN_ERR_MEMORY;
        }
        b->scene = &b->snapshot;
    }
    b->desc = *desc;
    uint32_t lights = desc->light_count ? desc->light_count : 1;
    memcpy(b->lights, desc->light, lights * sizeof *desc->light);
    b->desc.light = b->lights; // the caller's lights keep moving while these are built for
    memset(&b->result, 0, sizeof b->result);
    b->start_ns = pn_time_ns();
    atomic_store(&b->state, PN_DEMO_BUILD_RUNNING);
    if (pthread_create(&b->thread, NULL, build, b) != 0) {
        atomic_store(&b->state, PN_DEMO_BUILD_IDLE);
        pn_error("demo: cannot start the tree build thread");
        return PN_ERR_MEMORY;
    }
    return PN_OK;
}

bool pn_demo_builder_poll(pn_demo_builder *b, pn_shadow_accel *out, pn_result *status)
{
    if (atomic_load_explicit(&b->state, memory_order_acquire) != PN_DEMO_BUILD_DONE)
        return false;
    pthread_join(b->thread, NULL);
    *out = b->result;
    *status = b->status;
    memset(&b->result, 0, sizeof b->result);
    atomic_store(&b->state, PN_DEMO_BUILD_IDLE);
    return true;
}

void pn_demo_builder_wait(const pn_demo_builder *b)
{
    // A millisecond's sleep: builds take tens of milliseconds to seconds, and this is only for
    // scripted screenshots.
    while (atomic_load_explicit(&b->state, memory_order_acquire) == PN_DEMO_BUILD_RUNNING)
        nanosleep(&(struct timespec){.tv_nsec = 1000000}, NULL);
}

double pn_demo_builder_elapsed(const pn_demo_builder *b) { return pn_ms_since(b->start_ns) * 1e-3; }

void pn_demo_builder_destroy(pn_demo_builder *b)
{
    if (atomic_load(&b->state) != PN_DEMO_BUILD_IDLE) {
        pthread_join(b->thread, NULL);
        pn_shadow_accel_destroy(NULL, &b->result); // CPU only: never uploaded
    }
    snapshot_free(&b->snapshot);
    memset(b, 0, sizeof *b);
}
