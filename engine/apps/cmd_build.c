// penumbra build: builds the N-tree and its line spaces over a scene, uploads the pools and reports
// their size, occupancy and build time.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/pools.h"
#include "apps/args.h"
#include "apps/commands.h"
#include "apps/options.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/timer.h"
#include "gpu/pools.h"
#include "scene/view.h"
#include "io/json.h"

void pn_print_build_help(void)
{
    printf("usage: penumbra build [SCENE] [options]\n"
           "  Builds the N-tree with line spaces over SCENE (glTF or builtin:NAME, default builtin:default),\n"
           "  uploads its pools to the GPU and reports per-level node counts, pool bytes, the share of set\n"
           "  line-space bits and the build time.\n"
           "  --tree N,d         branching factor 2..16, depth 1..6 (default 7,3)\n"
           "  --max-memory SIZE  refuse a tree whose pools exceed SIZE (MiB, or K/M/G suffix);\n"
           "                     default: half the device's largest memory heap\n"
           "  --ground, --no-ground   include the receiver plane render adds (default: on)\n"
           "  --no-cull          keep triangles that cannot block a ray to the default light\n"
           "  --no-upload        build on the CPU only (no Vulkan device needed; default limit 1G)\n"
           "  --trees scene|object|both   the one scene-wide tree (default), the per-object trees\n"
           "                     (one per mesh in its own frame, shared by its instances; render's\n"
           "                     --trees object), or both, one after the other, with their ratios\n"
           "  --object-tree N,d  the per-object trees' N and d (default: --tree's)\n"
           "  --updates K        with per-object trees: time K moves of object 0 (top level rebuilt\n"
           "                     and uploaded; default 9), reported as the median\n"
           "  --json             print one JSON object instead of the table\n"
           "  PN_THREADS=K       build threads (default: all cores)\n");
}

int pn_build_parse(int argc, char **argv, pn_build_opts *o)
{
    *o = (pn_build_opts){.tree_n = 7, .tree_d = 3, .ground = true, .upload = true, .cull = true, .updates = 9};
    pn_args a = {argc, argv, 0};
    while (a.i < argc) {
        const char *v = NULL, *arg = argv[a.i];
        bool err = false, ok = true;
        if (pn_args_flag(&a, "--help") || pn_args_flag(&a, "-h")) {
            pn_print_build_help();
            return -1;
        } else if (pn_args_value(&a, "--tree", &v, &err)) {
            ok = v && pn_parse_tree("--tree", v, &o->tree_n, &o->tree_d);
        } else if (pn_args_value(&a, "--max-memory", &v, &err)) {
            ok = v && pn_parse_bytes("--max-memory", v, &o->max_bytes);
        } else if (pn_args_value(&a, "--trees", &v, &err)) {
            static const char *const trees[] = {"scene", "object", "both", NULL};
            o->trees = v ? pn_parse_choice("--trees", v, trees) : -1;
            ok = o->trees >= 0;
        } else if (pn_args_value(&a, "--object-tree", &v, &err)) {
            ok = v && pn_parse_tree("--object-tree", v, &o->object_n, &o->object_d);
        } else if (pn_args_value(&a, "--updates", &v, &err)) {
            ok = v && pn_parse_int_range("--updates", v, 1, 1000, &o->updates);
        } else if (pn_args_flag(&a, "--json")) {
            o->json = true;
        } else if (pn_args_flag(&a, "--ground")) {
            o->ground = true;
        } else if (pn_args_flag(&a, "--no-ground")) {
            o->ground = false;
        } else if (pn_args_flag(&a, "--no-cull")) {
            o->cull = false;
        } else if (pn_args_flag(&a, "--no-upload")) {
            o->upload = false;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            pn_error("build: unknown option '%s' (see penumbra build --help)", arg);
            return PN_EXIT_USAGE;
        } else if (!o->scene) {
            o->scene = arg;
            a.i++;
        } else {
            pn_error("build: more than one scene given ('%s' and '%s')", o->scene, arg);
            return PN_EXIT_USAGE;
        }
        if (err || !ok)
            return PN_EXIT_USAGE;
    }
    if (!o->scene)
        o->scene = "builtin:default";
    if (!o->object_n) {
        o->object_n = o->tree_n;
        o->object_d = o->tree_d;
    }
    return PN_EXIT_OK;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

// --trees object|both: the per-object trees, and the time a moving object costs them (the top level
// rebuilt and uploaded; the vertices' own move is the raster pass's business, not timed). With
// `single` (both), their ratios to the scene-wide tree.
static int build_objects(pn_gpu_device *dev, pn_scene *scene, const pn_build_opts *o, const float (*corners)[3],
                         uint64_t max_bytes, uint64_t max_pool, const pn_ntree *single, const pn_pools *single_pools)
{
    pn_objects objs;
    pn_ntree_desc td = {.n = o->object_n, .d = o->object_d, .max_bytes = max_bytes, .max_pool_bytes = max_pool,
                        .cull_light = o->cull ? corners : NULL};
    if (pn_objects_build(scene, &td, &objs) != PN_OK)
        return PN_EXIT_FAILURE;
    int rc = PN_EXIT_OK;
    pn_gpu_objects gpu = {0};
    if (o->upload && pn_gpu_objects_create(dev, &objs, &gpu) != PN_OK)
        rc = PN_EXIT_FAILURE;
    // Object 0 steps by a hundredth of the scene back and forth, so the scene ends where it began.
    double *ms = calloc((size_t)o->updates, sizeof *ms);
    float step = 0.01f * fmaxf(scene->bounds_max[0] - scene->bounds_min[0], 1e-30f);
    long long timed = 0;
    for (long long i = 0; rc == PN_EXIT_OK && ms && scene->object_count && i < o->updates; i++) {
        float delta[3] = {i % 2 ? -step : step, 0, 0};
        pn_scene_move_object(scene, 0, delta);
        uint64_t t0 = pn_time_ns();
        if (pn_objects_update(scene, &objs) != PN_OK || (o->upload && pn_gpu_objects_update(dev, &objs, &gpu) != PN_OK))
            rc = PN_EXIT_FAILURE;
        ms[timed++] = pn_ms_since(t0);
    }
    if (timed)
        qsort(ms, (size_t)timed, sizeof *ms, cmp_double);
    double update_ms = timed ? ms[timed / 2] : 0.0;
    free(ms);
    double max_leaf = 0;
    for (uint32_t i = 0; i < objs.placed; i++)
        max_leaf = fmax(max_leaf, objs.instances[i].world_leaf);
    double pool_ratio = single_pools && single_pools->bytes.total ? (double)objs.bytes.total / single_pools->bytes.total : 0;
    double update_ratio = single && single->build_ms > 0 ? update_ms / single->build_ms : 0;
    if (rc == PN_EXIT_OK && o->json) {
        printf("{\"scene\": ");
        pn_json_string(stdout, scene->name);
        printf(", \"objects\": %u, \"meshes\": %u, \"trees\": %u, \"placed\": %u, \"n\": %d, \"d\": %d, "
               "\"pool_bytes\": %llu, \"top_bytes\": %llu, \"leaf_min\": %.9g, \"leaf_max\": %.9g, "
               "\"build_ms\": %.3f, \"update_ms\": %.4f, \"updates\": %lld",
               scene->object_count, scene->mesh_count, objs.tree_count, objs.placed, o->object_n, o->object_d,
               (unsigned long long)objs.bytes.total, (unsigned long long)objs.top_bytes, objs.leaf_size, max_leaf,
               objs.build_ms, update_ms, timed);
        if (single)
            printf(", \"single\": {\"n\": %d, \"d\": %d, \"leaf\": %.9g, \"pool_bytes\": %llu, \"build_ms\": %.3f}, "
                   "\"pool_ratio\": %.6f, \"update_over_single_build\": %.6f",
                   single->n, single->d, pn_ntree_cell_size(single, single->d),
                   (unsigned long long)single_pools->bytes.total, single->build_ms, pool_ratio, update_ratio);
        printf("}\n");
    } else if (rc == PN_EXIT_OK) {
        printf("%s: per-object trees LS(%d,%d): %u trees for %u objects of %u meshes (%u placed, with the rest)\n",
               scene->name, o->object_n, o->object_d, objs.tree_count, scene->object_count, scene->mesh_count,
               objs.placed);
        printf("  pools: %.2f MiB, top level %.1f KiB; leaves %.4g..%.4g wide in world units\n",
               objs.bytes.total / 1048576.0, objs.top_bytes / 1024.0, objs.leaf_size, max_leaf);
        printf("  build: %.1f ms; a moving object: %.3f ms (top level rebuilt%s, median of %lld)\n", objs.build_ms,
               update_ms, o->upload ? " and uploaded" : "", timed);
        if (single)
            printf("  against the scene-wide LS(%d,%d) (leaves %.4g wide): pools %.4fx (%.2f MiB), a move costs "
                   "%.3f%% of its build (%.1f ms)\n",
                   single->n, single->d, pn_ntree_cell_size(single, single->d), pool_ratio,
                   single_pools->bytes.total / 1048576.0, 100 * update_ratio, single->build_ms);
    }
    pn_gpu_objects_destroy(dev, &gpu);
    pn_objects_destroy(&objs);
    return rc;
}

int pn_cmd_build(int argc, char **argv)
{
    pn_build_opts o;
    int prc = pn_build_parse(argc, argv, &o);
    if (prc != PN_EXIT_OK)
        return prc < 0 ? PN_EXIT_OK : prc;
    const char *source = o.scene;
    const int n = o.tree_n, d = o.tree_d;
    uint64_t max_bytes = o.max_bytes;
    const bool json = o.json, ground = o.ground, upload = o.upload, cull = o.cull;

    pn_scene scene;
    if (pn_scene_load(source, &scene) != PN_OK)
        return PN_EXIT_FAILURE;
    // The same tree render builds with its default light: triangles that cannot block a ray to it
    // (a ground plane under everything) are left out.
    pn_light light;
    float corners[4][3];
    pn_light_default(scene.bounds_min, scene.bounds_max, &light);
    pn_light_corners(&light, corners);
    if (ground && pn_scene_add_ground(&scene, 6.0f) != PN_OK) {
        pn_error("%s: out of memory adding the ground plane", scene.name);
        pn_scene_destroy(&scene);
        return PN_EXIT_FAILURE;
    }
    pn_gpu_device dev = {0};
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    if (upload && pn_gpu_device_create(&desc, &dev) != PN_OK) {
        pn_scene_destroy(&scene);
        return PN_EXIT_FAILURE;
    }
    if (!max_bytes) // default: the device's pool budget, leaving room for the frame's images
        max_bytes = upload ? pn_gpu_device_pool_budget(&dev) : (1ull << 30);
    uint64_t max_pool = upload ? pn_gpu_device_max_buffer(&dev) : 0; // every pool is one buffer

    int rc = PN_EXIT_FAILURE;
    pn_ntree tree;
    pn_pools pools = {0};
    pn_gpu_pools gpu = {0};
    if (o.trees == PN_BUILD_TREES_OBJECT) {
        rc = build_objects(&dev, &scene, &o, (const float(*)[3])corners, max_bytes, max_pool, NULL, NULL);
    } else if (pn_ntree_build(&scene, &(pn_ntree_desc){.n = n, .d = d, .max_bytes = max_bytes, .max_pool_bytes = max_pool, .cull_light = cull ? (const float(*)[3])corners : NULL}, &tree) == PN_OK) {
        if (pn_pools_pack(&tree, &pools) == PN_OK && (!upload || pn_gpu_pools_create(&dev, &pools, &gpu) == PN_OK))
            rc = PN_EXIT_OK;
        double share = tree.node_count ? (double)tree.set_bits / ((double)tree.node_count * pn_ls_bits(n)) : 0;
        if (rc == PN_EXIT_OK && o.trees == PN_BUILD_TREES_BOTH) {
            rc = build_objects(&dev, &scene, &o, (const float(*)[3])corners, max_bytes, max_pool, &tree, &pools);
        } else if (rc == PN_EXIT_OK && json) {
            printf("{\"scene\": ");
            pn_json_string(stdout, scene.name);
            printf(", \"n\": %d, \"d\": %d, \"triangles\": %u, \"culled_triangles\": %u, \"threads\": %u, \"filled_per_level\": [", n, d,
                   tree.triangles, tree.culled, pn_parallel_threads());
            for (int l = 0; l <= d; l++)
                printf("%s%llu", l ? ", " : "", (unsigned long long)tree.filled_per_level[l]);
            printf("], \"nodes_per_level\": [");
            for (int l = 0; l < d; l++)
                printf("%s%llu", l ? ", " : "", (unsigned long long)tree.filled_per_level[l]);
            printf("], \"subdivided_nodes\": %u, \"pool_bytes\": {\"tree\": %llu, \"node\": %llu, \"linespace\": %llu, "
                   "\"total\": %llu}, \"set_bit_share\": %.6f, \"build_ms\": %.3f, \"occupancy_ms\": %.3f, "
                   "\"masks_ms\": %.3f, \"linespace_ms\": %.3f, \"uploaded\": %s}\n",
                   tree.node_count, (unsigned long long)pools.bytes.tree, (unsigned long long)pools.bytes.node,
                   (unsigned long long)pools.bytes.linespace, (unsigned long long)pools.bytes.total, share,
                   tree.build_ms, tree.occupancy_ms, tree.masks_ms, tree.linespace_ms, upload ? "true" : "false");
        } else if (rc == PN_EXIT_OK) {
            printf("%s: %u triangles in the tree (%u left out: they cannot block a ray to the default light), "
                   "LS(%d,%d), %u threads\n",
                   scene.name, tree.triangles, tree.culled, n, d, pn_parallel_threads());
            printf("  level  filled cells  subdivided\n");
            for (int l = 0; l <= d; l++)
                printf("  %5d  %12llu  %10llu\n", l, (unsigned long long)tree.filled_per_level[l],
                       (unsigned long long)(l < d ? tree.filled_per_level[l] : 0));
            printf("  subdivided nodes: %u\n", tree.node_count);
            printf("  pools: tree %.2f MiB, node %.2f MiB, line space %.2f MiB, total %.2f MiB%s\n",
                   pools.bytes.tree / 1048576.0, pools.bytes.node / 1048576.0, pools.bytes.linespace / 1048576.0,
                   pools.bytes.total / 1048576.0, upload ? " (uploaded)" : "");
            printf("  set line-space bits: %.2f%%\n", 100 * share);
            printf("  build: %.1f ms (occupancy %.1f, shaft masks %.1f, line spaces %.1f)\n", tree.build_ms,
                   tree.occupancy_ms, tree.masks_ms, tree.linespace_ms);
        }
        pn_gpu_pools_destroy(&dev, &gpu);
        pn_pools_destroy(&pools);
        pn_ntree_destroy(&tree);
    }
    pn_scene_destroy(&scene);
    if (upload) {
        pn_gpu_device_destroy(&dev);
        if (dev.validation_messages) {
            pn_error("the Vulkan validation layer reported %u message(s)", dev.validation_messages);
            return PN_EXIT_VALIDATION;
        }
    }
    return rc;
}
