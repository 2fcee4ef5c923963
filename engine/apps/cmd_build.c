// penumbra build: builds the N-tree and its line spaces over a scene, uploads the pools and reports
// their size, occupancy and build time.
#include <stdio.h>
#include <string.h>

#include "accel/pools.h"
#include "apps/args.h"
#include "apps/commands.h"
#include "apps/options.h"
#include "core/log.h"
#include "core/parallel.h"
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
           "  --json             print one JSON object instead of the table\n"
           "  PN_THREADS=K       build threads (default: all cores)\n");
}

int pn_build_parse(int argc, char **argv, pn_build_opts *o)
{
    *o = (pn_build_opts){.tree_n = 7, .tree_d = 3, .ground = true, .upload = true, .cull = true};
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
    return PN_EXIT_OK;
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
    if (pn_ntree_build(&scene, &(pn_ntree_desc){.n = n, .d = d, .max_bytes = max_bytes, .max_pool_bytes = max_pool, .cull_light = cull ? (const float(*)[3])corners : NULL}, &tree) == PN_OK) {
        if (pn_pools_pack(&tree, &pools) == PN_OK && (!upload || pn_gpu_pools_create(&dev, &pools, &gpu) == PN_OK))
            rc = PN_EXIT_OK;
        double share = tree.node_count ? (double)tree.set_bits / ((double)tree.node_count * pn_ls_bits(n)) : 0;
        if (rc == PN_EXIT_OK && json) {
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
