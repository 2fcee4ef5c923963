// Determinism of the acceleration structures (issue 30): every buffer the renderer uploads from the
// CPU builds (the N-tree's node, tree, line-space and plane pools, its candidate lists, the exact
// BVH and its triangle order, the triangle pool, the per-object trees' pools, instances and top
// level) is byte for byte the same whether the build runs on 1, 2 or 8 threads. Scenes: the
// built-in default scene and the Stanford bunny (69k triangles: more than the BVH's parallel
// threshold and many occupancy chunks, so the parallel paths really run; skipped if
// ../shared/assets is missing), each with the ground plane render adds.
//
// The thread count is set through PN_THREADS between builds: pn_parallel_threads() reads it on every
// call, and no build function takes a thread count of its own.
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/bvh.h"
#include "accel/ntree.h"
#include "accel/objects.h"
#include "accel/pools.h"
#include "core/parallel.h"
#include "core/timer.h"
#include "scene/scene.h"
#include "scene/view.h"
#include "test_util.h"

enum { MAX_BLOBS = 64 };

// One named buffer (a copy of what would be uploaded).
typedef struct blob {
    char name[64];
    uint8_t *data;
    uint64_t size;
} blob;

typedef struct blobs {
    blob b[MAX_BLOBS];
    int count;
} blobs;

static uint64_t fnv1a64(const uint8_t *p, uint64_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (uint64_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

static void add(blobs *s, const char *name, const void *data, uint64_t size)
{
    if (s->count == MAX_BLOBS) {
        CHECK_MSG(0, "more than %d buffers", MAX_BLOBS);
        return;
    }
    blob *b = &s->b[s->count++];
    snprintf(b->name, sizeof b->name, "%s", name);
    b->size = data ? size : 0;
    b->data = malloc(b->size ? b->size : 1);
    CHECK(b->data != NULL);
    if (b->data && b->size)
        memcpy(b->data, data, b->size);
}

static void blobs_free(blobs *s)
{
    for (int i = 0; i < s->count; i++)
        free(s->b[i].data);
    s->count = 0;
}

// The plain values the shaders or the host read besides the pools, field by field (no padding).
static void add_u64s(blobs *s, const char *name, const uint64_t *v, int n) { add(s, name, v, (uint64_t)n * 8); }

// Builds everything once on the current PN_THREADS and records every uploaded buffer.
static void build_all(const pn_scene *scene, const float (*corners)[3], blobs *out)
{
    // The scene-wide tree as render builds it for the modes that need the most: candidate lists
    // (hybrid, exact-ls) and leaf planes (ls-plane).
    pn_ntree t;
    pn_ntree_desc td = {.n = 7, .d = 3, .cull_light = corners, .keep_candidates = true, .leaf_planes = true};
    if (pn_ntree_build(scene, &td, &t) != PN_OK) {
        CHECK_MSG(0, "%s: N-tree build", scene->name);
        return;
    }
    pn_pools p;
    if (pn_pools_pack(&t, &p) != PN_OK) {
        CHECK_MSG(0, "%s: pools", scene->name);
        pn_ntree_destroy(&t);
        return;
    }
    add(out, "tree.node pool", p.nodes, p.bytes.node);
    add(out, "tree.tree pool", p.tree, p.bytes.tree);
    add(out, "tree.line-space pool", p.linespace, p.bytes.linespace);
    add(out, "tree.plane pool", p.planes, p.bytes.planes);
    add(out, "tree.info", &p.info, sizeof p.info); // addresses are 0 before upload
    add(out, "tree.cand_offset", t.cand_offset, (uint64_t)t.cand_offsets * 4);
    add(out, "tree.cand_tris", t.cand_tris, t.cand_count * 4);
    uint64_t th[PN_NTREE_MAX_DEPTH + 8] = {t.triangles, t.culled, t.node_count, t.set_bits, t.cand_first_node};
    for (int l = 0; l <= PN_NTREE_MAX_DEPTH; l++)
        th[5 + l] = t.filled_per_level[l];
    add_u64s(out, "tree.counts", th, 6 + PN_NTREE_MAX_DEPTH);
    pn_pools_destroy(&p);
    pn_ntree_destroy(&t);

    // The exact modes' BVH and the triangle pool.
    pn_bvh bvh;
    if (pn_bvh_build(scene, &bvh) != PN_OK) {
        CHECK_MSG(0, "%s: BVH build", scene->name);
        return;
    }
    add(out, "bvh.nodes", bvh.nodes, (uint64_t)bvh.node_count * sizeof *bvh.nodes);
    add(out, "bvh.tri_index", bvh.tri_index, (uint64_t)bvh.triangles * 4);
    add_u64s(out, "bvh.counts", (const uint64_t[]){bvh.node_count, bvh.triangles, bvh.depth}, 3);
    pn_bvh_destroy(&bvh);
    float *tris = NULL;
    uint64_t tri_bytes = 0;
    if (pn_triangle_pool(scene, &tris, &tri_bytes) != PN_OK) {
        CHECK_MSG(0, "%s: triangle pool", scene->name);
        return;
    }
    add(out, "triangle pool", tris, tri_bytes);
    free(tris);

    // Per-object trees (--trees object): each tree's pools, the instances the object table is made
    // of, and the top level.
    pn_objects o;
    pn_ntree_desc od = {.n = 5, .d = 3, .cull_light = corners};
    if (pn_objects_build(scene, &od, &o) != PN_OK) {
        CHECK_MSG(0, "%s: per-object build", scene->name);
        return;
    }
    for (uint32_t i = 0; i < o.tree_count && i < 8; i++) {
        char name[64];
        snprintf(name, sizeof name, "objects.tree %u node pool", i);
        add(out, name, o.pools[i].nodes, o.pools[i].bytes.node);
        snprintf(name, sizeof name, "objects.tree %u tree pool", i);
        add(out, name, o.pools[i].tree, o.pools[i].bytes.tree);
        snprintf(name, sizeof name, "objects.tree %u line-space pool", i);
        add(out, name, o.pools[i].linespace, o.pools[i].bytes.linespace);
    }
    for (uint32_t i = 0; i < o.placed && i < 8; i++) {
        const pn_object_instance *in = &o.instances[i];
        char name[64];
        snprintf(name, sizeof name, "objects.instance %u", i);
        float f[19];
        memcpy(f, in->to_local, 12 * sizeof(float));
        memcpy(f + 12, in->box, 6 * sizeof(float));
        f[18] = (float)in->world_leaf;
        add(out, name, f, sizeof f);
    }
    add(out, "objects.top nodes", o.top.nodes, (uint64_t)o.top.node_count * sizeof *o.top.nodes);
    add(out, "objects.top ids", o.top.tri_index, (uint64_t)o.placed * 4);
    add_u64s(out, "objects.counts", (const uint64_t[]){o.tree_count, o.instance_count, o.placed, o.culled}, 4);
    pn_objects_destroy(&o);
}

// Compares run `got` (threads `threads`) with the reference, buffer by buffer.
static void compare(const char *scene, const blobs *ref, const blobs *got, const char *threads)
{
    CHECK_MSG(ref->count == got->count, "%s: %d buffers on 1 thread, %d on %s", scene, ref->count, got->count,
              threads);
    for (int i = 0; i < ref->count && i < got->count; i++) {
        const blob *a = &ref->b[i], *b = &got->b[i];
        if (a->size != b->size) {
            CHECK_MSG(0, "%s: %s: %llu bytes on 1 thread, %llu on %s", scene, a->name, (unsigned long long)a->size,
                      (unsigned long long)b->size, threads);
            continue;
        }
        uint64_t first = a->size;
        for (uint64_t k = 0; k < a->size; k++)
            if (a->data[k] != b->data[k]) {
                first = k;
                break;
            }
        CHECK_MSG(first == a->size, "%s: %s (%llu bytes) differs between 1 and %s threads from byte %llu on", scene,
                  a->name, (unsigned long long)a->size, threads, (unsigned long long)first);
    }
}

static void check_scene(const char *source)
{
    pn_scene scene;
    if (pn_scene_load(source, &scene) != PN_OK) {
        CHECK_MSG(0, "cannot load %s", source);
        return;
    }
    // As render and build do: the default light from the bounds without the ground, then the ground.
    pn_light light;
    float corners[4][3];
    pn_light_default(scene.bounds_min, scene.bounds_max, &light);
    pn_light_corners(&light, corners);
    CHECK(pn_scene_add_ground(&scene, 6.0f) == PN_OK);

    static const char *const threads[] = {"1", "2", "8"};
    blobs ref = {0}, got = {0};
    for (size_t i = 0; i < sizeof threads / sizeof *threads; i++) {
        setenv("PN_THREADS", threads[i], 1);
        CHECK(pn_parallel_threads() == (unsigned)atoi(threads[i]));
        uint64_t t0 = pn_time_ns();
        build_all(&scene, (const float(*)[3])corners, i == 0 ? &ref : &got);
        printf("%s: built on %s thread(s) in %.0f ms\n", source, threads[i], pn_ms_since(t0));
        if (i > 0) {
            compare(source, &ref, &got, threads[i]);
            blobs_free(&got);
        }
    }
    uint64_t total = 0;
    for (int i = 0; i < ref.count; i++) {
        printf("  %-32s %10llu bytes  fnv1a64 %016llx\n", ref.b[i].name, (unsigned long long)ref.b[i].size,
               (unsigned long long)fnv1a64(ref.b[i].data, ref.b[i].size));
        total += ref.b[i].size;
    }
    printf("  %d buffers, %llu bytes compared per thread count\n", ref.count, (unsigned long long)total);
    blobs_free(&ref);
    pn_scene_destroy(&scene);
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    check_scene("builtin:default");
    char path[1024];
    snprintf(path, sizeof path, "%s/stanford-bunny-69k.glb", pn_test_env("PN_ASSETS", "../shared/assets"));
    FILE *f = fopen(path, "rb");
    if (!f) {
        int rc = pn_test_result();
        if (rc)
            return rc;
        TEST_SKIP("%s not found (the built-in scene passed)", path);
    }
    fclose(f);
    check_scene(path);
    return pn_test_result();
}
