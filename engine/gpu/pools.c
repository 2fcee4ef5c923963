// The N-tree pools uploaded into device-local buffers and bound by device address.
#include "gpu/pools.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

pn_result pn_gpu_pools_create(pn_gpu_device *dev, const pn_pools *pools, pn_gpu_pools *out)
{
    memset(out, 0, sizeof *out);
    const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    struct {
        const void *data;
        uint64_t size;
        pn_gpu_buffer *buf;
        const char *name;
    } p[4] = {
        {pools->nodes, pools->bytes.node, &out->nodes, "node"},
        {pools->tree, pools->bytes.tree, &out->tree, "tree"},
        {pools->linespace, pools->bytes.linespace, &out->linespace, "line-space"},
        {pools->planes, pools->bytes.planes, &out->planes, "plane"},
    };
    VkDeviceSize max_alloc = dev->maintenance3.maxMemoryAllocationSize;
    for (int i = 0; i < 4; i++)
        if (max_alloc && p[i].size > max_alloc) {
            pn_error("the %s pool needs %.1f MiB, more than one allocation of this device can hold (%.1f MiB); "
                     "try a smaller N or d",
                     p[i].name, (double)p[i].size / 1048576.0, (double)max_alloc / 1048576.0);
            return PN_ERR_MEMORY;
        }
    for (int i = 0; i < 4; i++) {
        // Vulkan buffers cannot be empty: a zero-sized pool gets a few zero bytes.
        static const uint32_t zero[4] = {0};
        char what[32];
        snprintf(what, sizeof what, "%s pool", p[i].name);
        pn_result r = pn_gpu_buffer_create_with_data(dev, what, p[i].size ? p[i].data : zero, p[i].size ? p[i].size : sizeof zero,
                                                     usage, p[i].buf);
        if (r != PN_OK) {
            pn_gpu_pools_destroy(dev, out);
            return r;
        }
    }
    out->has_planes = pools->planes != NULL;
    out->info = pools->info;
    out->info.node_pool = out->nodes.address;
    out->info.tree_pool = out->tree.address;
    out->info.ls_pool = out->linespace.address;
    out->info.plane_pool = out->planes.address;
    return PN_OK;
}

void pn_gpu_pools_destroy(pn_gpu_device *dev, pn_gpu_pools *p)
{
    pn_gpu_buffer_destroy(dev, &p->nodes);
    pn_gpu_buffer_destroy(dev, &p->tree);
    pn_gpu_buffer_destroy(dev, &p->linespace);
    pn_gpu_buffer_destroy(dev, &p->planes);
    memset(p, 0, sizeof *p);
}

static void objects_top_destroy(pn_gpu_device *dev, pn_gpu_objects *g)
{
    pn_gpu_buffer_destroy(dev, &g->table);
    pn_gpu_buffer_destroy(dev, &g->top);
    pn_gpu_buffer_destroy(dev, &g->top_ids);
}

pn_result pn_gpu_objects_update(pn_gpu_device *dev, const pn_objects *o, pn_gpu_objects *g)
{
    objects_top_destroy(dev, g);
    uint32_t n = o->placed;
    pn_gpu_object *table = calloc(n ? n : 1, sizeof *table);
    if (!table)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < n; i++) {
        const pn_object_instance *inst = &o->instances[i];
        table[i].tree = g->trees[inst->tree].info;
        memcpy(table[i].to_local, inst->to_local, sizeof table[i].to_local);
        table[i].rise_scale = o->leaf_size > 0 ? (float)(inst->world_leaf / o->leaf_size) : 1.0f;
    }
    const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    static const uint32_t zero[8] = {0}; // Vulkan buffers cannot be empty
    pn_result r = pn_gpu_buffer_create_with_data(dev, "object table", table, (n ? n : 1) * sizeof *table, usage, &g->table);
    if (r == PN_OK)
        r = pn_gpu_buffer_create_with_data(dev, "top-level node pool", o->top.node_count ? (const void *)o->top.nodes : zero,
                                           o->top.node_count ? o->top.node_count * sizeof *o->top.nodes : sizeof zero,
                                           usage, &g->top);
    if (r == PN_OK)
        r = pn_gpu_buffer_create_with_data(dev, "top-level object index pool", n ? (const void *)o->top.tri_index : zero,
                                           n ? n * sizeof *o->top.tri_index : sizeof zero, usage, &g->top_ids);
    free(table);
    g->count = r == PN_OK ? n : 0;
    return r;
}

pn_result pn_gpu_objects_create(pn_gpu_device *dev, const pn_objects *o, pn_gpu_objects *out)
{
    memset(out, 0, sizeof *out);
    out->trees = calloc(o->tree_count ? o->tree_count : 1, sizeof *out->trees);
    if (!out->trees)
        return PN_ERR_MEMORY;
    out->tree_count = o->tree_count;
    pn_result r = PN_OK;
    for (uint32_t i = 0; r == PN_OK && i < o->tree_count; i++)
        if (o->trees[i].node_count) // a mesh without triangles has no tree and no object
            r = pn_gpu_pools_create(dev, &o->pools[i], &out->trees[i]);
    if (r == PN_OK)
        r = pn_gpu_objects_update(dev, o, out);
    if (r != PN_OK)
        pn_gpu_objects_destroy(dev, out);
    return r;
}

void pn_gpu_objects_destroy(pn_gpu_device *dev, pn_gpu_objects *g)
{
    objects_top_destroy(dev, g);
    for (uint32_t i = 0; g->trees && i < g->tree_count; i++)
        pn_gpu_pools_destroy(dev, &g->trees[i]);
    free(g->trees);
    memset(g, 0, sizeof *g);
}
