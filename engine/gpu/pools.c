#include "gpu/pools.h"

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
        pn_result r = pn_gpu_buffer_create_with_data(dev, p[i].size ? p[i].data : zero, p[i].size ? p[i].size : sizeof zero,
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
