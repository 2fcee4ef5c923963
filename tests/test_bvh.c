// The exact mode's BVH (accel/bvh.h): the tree is well formed, and its build time and the quality
// it gives are reported. Checks: every triangle appears once in tri_index; every node's box holds
// its children's boxes (interior) or its triangles' boxes (leaf); children come after their parent
// and every node is reached once; the depth the GPU walk's stack allows; leaves of more than
// LEAF_MAX triangles only where the triangles cannot be told apart by their centroids. Reported
// (never asserted: tests/no_timing_asserts.sh): the build time of each repeat and the tree's SAH
// cost (the cost model bvh.c splits by, relative to the root's area), node, leaf and depth counts.
//
// Scenes: the built-in default scene and the Stanford bunny (skipped if ../shared/assets is missing),
// each with the ground plane render adds; or the files named on the command line. `--repeat N`
// builds each scene N times, and `--embree` Embree 3's BVH too, alternately, so that both see the
// same load on a shared machine (the timing harness: test_bvh --embree --repeat 5 <dragon>).
// Each build prints its wall time and the process's CPU time over it (all threads).
#include <float.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "accel/bvh.h"
#include "apps/embree_peer.h"
#include "core/log.h"
#include "core/timer.h"
#include "scene/scene.h"
#include "test_util.h"

enum { LEAF_MAX = 4 }; // bvh.c's

static float area(const float lo[3], const float hi[3])
{
    float e[3];
    for (int k = 0; k < 3; k++)
        e[k] = hi[k] > lo[k] ? hi[k] - lo[k] : 0.0f;
    return e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
}

static bool contains(const float lo[3], const float hi[3], const float olo[3], const float ohi[3])
{
    for (int k = 0; k < 3; k++)
        if (olo[k] < lo[k] || ohi[k] > hi[k])
            return false;
    return true;
}

static void tri_box(const pn_scene *s, uint32_t t, float lo[3], float hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = FLT_MAX, hi[k] = -FLT_MAX;
    for (int j = 0; j < 3; j++) {
        const float *p = s->vertices[s->indices[3 * t + j]].pos;
        for (int k = 0; k < 3; k++) {
            lo[k] = p[k] < lo[k] ? p[k] : lo[k];
            hi[k] = p[k] > hi[k] ? p[k] : hi[k];
        }
    }
}

// Checks the tree and prints its shape and SAH cost; returns the SAH cost.
static double check_tree(const pn_scene *s, const pn_bvh *b)
{
    uint32_t n = pn_scene_triangle_count(s);
    CHECK(b->triangles == n);
    CHECK(b->node_count >= 1 && b->node_count < 2 * (n ? n : 1));
    CHECK(b->depth <= PN_BVH_STACK);
    uint8_t *seen_tri = calloc(n ? n : 1, 1), *seen_node = calloc(b->node_count, 1);
    uint32_t *depth = calloc(b->node_count, sizeof *depth);
    CHECK(seen_tri && seen_node && depth);
    if (!seen_tri || !seen_node || !depth) {
        free(seen_tri), free(seen_node), free(depth);
        return 0;
    }
    for (uint32_t i = 0; i < n; i++) {
        uint32_t t = b->tri_index[i];
        CHECK_MSG(t < n && !seen_tri[t], "%s: tri_index[%u] = %u", s->name, i, t);
        if (t < n)
            seen_tri[t] = 1;
    }
    double root = area(b->nodes[0].min, b->nodes[0].max), cost = 0;
    uint32_t leaves = 0, big_leaves = 0, max_depth = 0, bad = 0;
    uint64_t leaf_tris = 0;
    seen_node[0] = 1, depth[0] = 1;
    // Children always follow their parent (depth-first order), so one forward pass sees every
    // parent before its children.
    for (uint32_t i = 0; i < b->node_count && bad < 10; i++) {
        const pn_bvh_node *nd = &b->nodes[i];
        if (!seen_node[i]) {
            CHECK_MSG(0, "%s: node %u is not reached from the root before its index", s->name, i);
            bad++;
            continue;
        }
        double a = root > 0 ? area(nd->min, nd->max) / root : 0;
        max_depth = depth[i] > max_depth ? depth[i] : max_depth;
        if (nd->count > 0) {
            leaves++;
            leaf_tris += nd->count;
            cost += a * nd->count;
            CHECK_MSG(nd->first + nd->count <= n, "%s: leaf %u past the triangles", s->name, i);
            if (nd->first + nd->count > n) {
                bad++;
                continue;
            }
            float c0[3] = {0};
            bool same = true;
            for (uint32_t j = 0; j < nd->count; j++) {
                float lo[3], hi[3];
                uint32_t t = b->tri_index[nd->first + j];
                tri_box(s, t, lo, hi);
                if (!contains(nd->min, nd->max, lo, hi)) {
                    CHECK_MSG(0, "%s: leaf %u does not hold triangle %u", s->name, i, t);
                    bad++;
                }
                for (int k = 0; k < 3; k++) {
                    float c = 0.5f * (lo[k] + hi[k]);
                    if (j == 0)
                        c0[k] = c;
                    same = same && c == c0[k];
                }
            }
            if (nd->count > LEAF_MAX) {
                big_leaves++;
                // Depth-limited leaves may be big too; they would be deep.
                CHECK_MSG(same || depth[i] + 4 >= PN_BVH_STACK, "%s: leaf %u holds %u triangles", s->name, i,
                          nd->count);
            }
            continue;
        }
        cost += a; // one traversal step per visit, about one triangle test (bvh.c)
        uint32_t c = nd->first;
        CHECK_MSG(c > i && c + 1 < b->node_count, "%s: node %u's children at %u", s->name, i, c);
        if (!(c > i && c + 1 < b->node_count)) {
            bad++;
            continue;
        }
        for (uint32_t j = c; j <= c + 1; j++) {
            CHECK_MSG(!seen_node[j], "%s: node %u reached twice", s->name, j);
            CHECK_MSG(contains(nd->min, nd->max, b->nodes[j].min, b->nodes[j].max), "%s: node %u outside parent %u",
                      s->name, j, i);
            seen_node[j] = 1;
            depth[j] = depth[i] + 1;
        }
    }
    // A hash of the nodes (-0 read as +0) and the triangle order: two builders that make the same
    // tree print the same hash.
    uint64_t h = 0xcbf29ce484222325ull;
    for (uint32_t i = 0; i < b->node_count; i++) {
        const pn_bvh_node *nd = &b->nodes[i];
        uint32_t w[8] = {[3] = nd->first, [7] = nd->count};
        for (int k = 0; k < 3; k++) {
            float lo = nd->min[k] + 0.0f, hi = nd->max[k] + 0.0f;
            memcpy(&w[k], &lo, 4);
            memcpy(&w[4 + k], &hi, 4);
        }
        for (int k = 0; k < 8; k++)
            h = (h ^ w[k]) * 0x100000001b3ull;
    }
    uint64_t h_nodes = h; // the nodes alone: the same tree with its leaves' triangles in another order
    for (uint32_t i = 0; i < n; i++)
        h = (h ^ b->tri_index[i]) * 0x100000001b3ull;
    CHECK_MSG(leaf_tris == n, "%s: leaves hold %llu triangles of %u", s->name, (unsigned long long)leaf_tris, n);
    CHECK_MSG(max_depth == b->depth, "%s: depth %u, reported %u", s->name, max_depth, b->depth);
    fprintf(stderr, "test_bvh: %s: %u triangles, %u nodes, %u leaves (%.2f triangles each, %u above %d), depth %u, "
                    "SAH cost %.4f, hash %016llx (nodes %016llx)\n",
            s->name, n, b->node_count, leaves, leaves ? (double)leaf_tris / leaves : 0.0, big_leaves, LEAF_MAX,
            b->depth, cost, (unsigned long long)h, (unsigned long long)h_nodes);
    free(seen_tri), free(seen_node), free(depth);
    return cost;
}

static double cpu_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static void check_scene(const char *source, int repeat, pn_embree *embree)
{
    pn_scene scene;
    if (pn_scene_load(source, &scene) != PN_OK) {
        CHECK_MSG(0, "%s: load", source);
        return;
    }
    CHECK(pn_scene_add_ground(&scene, 6.0f) == PN_OK);
    for (int r = 0; r < repeat; r++) {
        if (embree) {
            double c0 = cpu_ms();
            pn_embree_scene *es = pn_embree_scene_create(embree, &scene);
            double cpu = cpu_ms() - c0;
            CHECK_MSG(es != NULL, "%s: Embree's BVH", source);
            if (es)
                fprintf(stderr, "test_bvh: %s: Embree build %.1f ms (%.1f ms CPU)\n", source,
                        pn_embree_scene_build_ms(es), cpu);
            pn_embree_scene_destroy(es);
        }
        pn_bvh bvh;
        double c0 = cpu_ms();
        if (pn_bvh_build(&scene, &bvh) != PN_OK) {
            CHECK_MSG(0, "%s: BVH build", source);
            break;
        }
        double cpu = cpu_ms() - c0;
        fprintf(stderr, "test_bvh: %s: build %.1f ms (%.1f ms CPU)\n", source, bvh.build_ms, cpu);
        if (r == repeat - 1)
            check_tree(&scene, &bvh);
        pn_bvh_destroy(&bvh);
    }
    pn_scene_destroy(&scene);
}

int main(int argc, char **argv)
{
    int repeat = 1, files = 0;
    pn_embree *embree = NULL;
    pn_log_set_level(PN_LOG_DEBUG); // bvh.c's time per phase
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--repeat") && i + 1 < argc) {
            repeat = atoi(argv[++i]);
            repeat = repeat < 1 ? 1 : repeat;
        } else if (!strcmp(argv[i], "--embree")) {
            embree = embree ? embree : pn_embree_create();
            CHECK_MSG(embree != NULL, "Embree did not start");
        } else {
            check_scene(argv[i], repeat, embree);
            files++;
        }
    }
    if (files) {
        pn_embree_destroy(embree);
        return pn_test_result();
    }
    check_scene("builtin:default", repeat, embree);
    char path[1024];
    snprintf(path, sizeof path, "%s/stanford-bunny-69k.glb", pn_test_env("PN_ASSETS", "../shared/assets"));
    FILE *f = fopen(path, "rb");
    if (!f) {
        int failed = pn_test_result();
        if (failed)
            return failed;
        TEST_SKIP("%s not found (the built-in scene passed)", path);
    }
    fclose(f);
    check_scene(path, repeat, embree);
    pn_embree_destroy(embree);
    return pn_test_result();
}
