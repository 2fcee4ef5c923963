// The pools of the exact triangle tests on the GPU: triangles, the BVH (exact mode) and the N-tree's
// candidate lists (hybrid, exact-ls; the line-space modes' masked leaves) and the bits marking its
// alpha-masked leaves (pn_ntree.alpha_bits), each a device-local buffer reached by address.
#pragma once
#include "accel/bvh.h"
#include "accel/ntree.h"
#include "gpu/resources.h"

typedef struct pn_gpu_exact_pools {
    pn_gpu_buffer tris, bvh_nodes, bvh_tris, cand_offset, cand_tris, alpha_bits;
    uint64_t bytes; // all of them
} pn_gpu_exact_pools;

// Uploads the scene's triangles and, when given, the BVH and the tree's candidate lists.
pn_result pn_gpu_exact_pools_create(pn_gpu_device *dev, const pn_scene *scene, const pn_bvh *bvh, const pn_ntree *tree,
                                    pn_gpu_exact_pools *out);
void pn_gpu_exact_pools_destroy(pn_gpu_device *dev, pn_gpu_exact_pools *p);
