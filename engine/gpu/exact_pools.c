// The exact triangle tests' pools on the GPU: triangles, BVH nodes and the N-tree's candidate
// lists, and which of its leaves hold alpha-masked triangles.
#include "gpu/exact_pools.h"

#include <stdlib.h>
#include <string.h>

static pn_result upload(pn_gpu_device *dev, const char *name, const void *data, uint64_t bytes, pn_gpu_buffer *out,
                        uint64_t *total)
{
    static const uint32_t zero[4] = {0};
    const VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    VkDeviceSize max_alloc = dev->maintenance3.maxMemoryAllocationSize;
    if (max_alloc && bytes > max_alloc) {
        pn_error("the %s needs %.1f MiB, more than one allocation of this device can hold (%.1f MiB)", name,
                 (double)bytes / 1048576.0, (double)max_alloc / 1048576.0);
        return PN_ERR_MEMORY;
    }
    *total += bytes;
    // Vulkan buffers cannot be empty: a missing pool gets a few zero bytes.
    return pn_gpu_buffer_create_with_data(dev, name, data && bytes ? data : zero, data && bytes ? bytes : sizeof zero, usage, out);
}

pn_result pn_gpu_exact_pools_create(pn_gpu_device *dev, const pn_scene *scene, const pn_bvh *bvh, const pn_ntree *tree,
                                    pn_gpu_exact_pools *out)
{
    memset(out, 0, sizeof *out);
    float *tris = NULL;
    uint64_t tri_bytes = 0;
    pn_result r = pn_triangle_pool(scene, &tris, &tri_bytes);
    if (r == PN_OK)
        r = upload(dev, "triangle pool", tris, tri_bytes, &out->tris, &out->bytes);
    free(tris);
    if (r == PN_OK)
        r = upload(dev, "BVH node pool", bvh ? bvh->nodes : NULL, bvh ? (uint64_t)bvh->node_count * sizeof(pn_bvh_node) : 0,
                   &out->bvh_nodes, &out->bytes);
    if (r == PN_OK)
        r = upload(dev, "BVH triangle index pool", bvh ? bvh->tri_index : NULL, bvh ? (uint64_t)bvh->triangles * 4 : 0, &out->bvh_tris, &out->bytes);
    bool cands = tree && tree->cand_offset;
    if (r == PN_OK)
        r = upload(dev, "candidate offset pool", cands ? tree->cand_offset : NULL, cands ? (uint64_t)tree->cand_offsets * 4 : 0,
                   &out->cand_offset, &out->bytes);
    if (r == PN_OK)
        r = upload(dev, "candidate list pool", cands ? tree->cand_tris : NULL, cands ? tree->cand_count * 4 : 0, &out->cand_tris, &out->bytes);
    bool alpha = tree && tree->alpha_bits;
    if (r == PN_OK)
        r = upload(dev, "alpha-masked leaf bits", alpha ? tree->alpha_bits : NULL, alpha ? (uint64_t)tree->alpha_words * 4 : 0,
                   &out->alpha_bits, &out->bytes);
    if (r != PN_OK)
        pn_gpu_exact_pools_destroy(dev, out);
    return r;
}

void pn_gpu_exact_pools_destroy(pn_gpu_device *dev, pn_gpu_exact_pools *p)
{
    pn_gpu_buffer *b[6] = {&p->tris, &p->bvh_nodes, &p->bvh_tris, &p->cand_offset, &p->cand_tris, &p->alpha_bits};
    for (int i = 0; i < 6; i++)
        pn_gpu_buffer_destroy(dev, b[i]);
    memset(p, 0, sizeof *p);
}
