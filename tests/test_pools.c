// The C and GLSL declarations of the N-tree pools agree: a compute shader reads the uploaded pools
// through shaders/glsl/pools.glsl (buffer device addresses, std430) and writes back every field of
// every node, one tree-pool entry and one line-space word per node, and the shaft bit and its
// value for a patch pair; all must equal what the C side packed. Also checks that the pools are
// reached by address, not bound by the 128 MiB storage-buffer range: a tree with a line-space
// pool over that size is uploaded and probed at its far end.
#include "accel/pools.h"
#include "gpu/compute.h"
#include "gpu/pools.h"
#include "gpu/resources.h"
#include "pools_probe_comp.h"
#include "test_util.h"

enum { HEADER = 8, PER_NODE = 12 };

static uint32_t fbits(float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

static void probe(pn_gpu_device *dev, const pn_ntree *tree, const char *what)
{
    pn_pools pools;
    CHECK(pn_pools_pack(tree, &pools) == PN_OK);
    pn_gpu_pools gp;
    if (pn_gpu_pools_create(dev, &pools, &gp) != PN_OK) {
        CHECK_MSG(0, "%s: upload failed", what);
        pn_pools_destroy(&pools);
        return;
    }
    uint32_t count = HEADER + tree->node_count * PER_NODE;
    pn_gpu_buffer out;
    CHECK(pn_gpu_buffer_create(dev, "probe output", count * 4ull, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, PN_GPU_HOST_READBACK, &out) == PN_OK);
    memset(out.mapped, 0xee, count * 4ull);
    pn_gpu_compute c;
    const VkDescriptorSetLayoutBinding b = {.binding = 0, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    CHECK(pn_gpu_compute_create(dev,
                                &(pn_gpu_compute_desc){.spirv = pn_spv_pools_probe_comp,
                                                       .spirv_size = sizeof pn_spv_pools_probe_comp,
                                                       .bindings = &b,
                                                       .binding_count = 1,
                                                       .push_size = sizeof(pn_gpu_tree_info)},
                                &c) == PN_OK);
    pn_gpu_compute_write_buffer(dev, &c, 0, out.buffer);
    VkCommandBuffer cmd;
    CHECK(pn_gpu_begin_once(dev, &cmd) == PN_OK);
    pn_gpu_compute_dispatch(cmd, &c, sizeof gp.info, &gp.info, (tree->node_count + 63) / 64, 1, 1);
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                           .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                           .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
                                           .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT},
                       0, NULL);
    CHECK(pn_gpu_submit_wait(dev, cmd) == PN_OK);

    const uint32_t *v = out.mapped;
    const pn_gpu_tree_info *info = &pools.info;
    CHECK(v[0] == fbits(info->root_min[0]) && v[1] == fbits(info->root_min[1]) && v[2] == fbits(info->root_min[2]));
    CHECK(v[3] == fbits(info->root_size));
    CHECK(v[4] == info->n && v[5] == info->d && v[6] == info->ls_words && v[7] == info->node_count);
    uint32_t n = (uint32_t)tree->n, n3 = n * n * n, bad = 0;
    for (uint32_t i = 0; i < tree->node_count; i++) {
        const uint32_t *o = v + HEADER + i * PER_NODE;
        const pn_gpu_node *g = &pools.nodes[i];
        uint32_t a = pn_ls_patch((int)n, (int)(i % 6), (int)(i % n), (int)(i / 3 % n));
        uint32_t bb = pn_ls_patch((int)n, (int)((i + 1) % 6), (int)(i / 5 % n), (int)(i / 7 % n));
        uint32_t bit = pn_ls_shaft((int)n, a, bb);
        uint32_t want[PER_NODE] = {
            fbits(g->min[0]), fbits(g->min[1]), fbits(g->min[2]), fbits(g->size), g->children, g->level,
            g->linespace, g->parent, pools.tree[g->children + (i * 7) % n3],
            pools.linespace[g->linespace + (i * 13) % info->ls_words], bit,
            pn_ls_get(tree->linespaces + (size_t)i * tree->words64, bit)};
        // shadow_linespace.comp loads only a node's box and relies on these two layout facts (pools.h).
        CHECK_MSG(g->children == i * n3 && g->linespace == i * info->ls_words, "node %u: children %u, line space %u", i,
                  g->children, g->linespace);
        for (int k = 0; k < PER_NODE; k++)
            if (o[k] != want[k] && bad++ < 10)
                fprintf(stderr, "%s: node %u field %d: GPU read %u, C wrote %u\n", what, i, k, o[k], want[k]);
    }
    CHECK_MSG(bad == 0, "%s: %u mismatches", what, bad);
    fprintf(stderr, "%s: %u nodes probed, pools %.1f MiB (line space %.1f MiB)\n", what, tree->node_count,
            pools.bytes.total / 1048576.0, pools.bytes.linespace / 1048576.0);
    pn_gpu_compute_destroy(dev, &c);
    pn_gpu_buffer_destroy(dev, &out);
    pn_gpu_pools_destroy(dev, &gp);
    pn_pools_destroy(&pools);
}

int main(void)
{
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK)
        TEST_SKIP("no Vulkan device");
    pn_scene scene;
    CHECK(pn_scene_load("builtin:default", &scene) == PN_OK);
    CHECK(pn_scene_add_ground(&scene, 6.0f) == PN_OK);
    const int cases[][2] = {{2, 3}, {4, 2}, {7, 3}, {16, 1}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        pn_ntree tree;
        char what[64];
        snprintf(what, sizeof what, "LS(%d,%d)", cases[k][0], cases[k][1]);
        CHECK(pn_ntree_build(&scene, &(pn_ntree_desc){.n = cases[k][0], .d = cases[k][1]}, &tree) == PN_OK);
        probe(&dev, &tree, what);
        pn_ntree_destroy(&tree);
    }
    // llvmpipe: over its 128 MiB per binding (maxStorageBufferRange): LS(10,3) of the default scene
    // with its ground has about 170 MiB of line space; the last nodes' words lie past 128 MiB.
    pn_ntree big;
    CHECK(pn_ntree_build(&scene, &(pn_ntree_desc){.n = 10, .d = 3}, &big) == PN_OK);
    pn_pool_bytes pb = pn_ntree_pool_bytes(big.n, big.node_count);
    CHECK_MSG(pb.linespace > dev.props.limits.maxStorageBufferRange, "line space %.1f MiB not over the %u-byte range",
              pb.linespace / 1048576.0, dev.props.limits.maxStorageBufferRange);
    probe(&dev, &big, "LS(10,3) beyond one binding");
    pn_ntree_destroy(&big);
    pn_scene_destroy(&scene);
    pn_gpu_device_destroy(&dev);
    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    return pn_test_result();
}
