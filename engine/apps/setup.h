// Everything one shadow configuration needs on the GPU, built from a scene: the N-tree and its pools
// (line-space modes), the BVH (exact), the triangle pools (exact tests) and the renderer. Shared by
// the bench; render and demo build the same pieces.
#pragma once
#include "accel/bvh.h"
#include "accel/pools.h"
#include "gpu/renderer.h"

typedef struct pn_setup_desc {
    pn_renderer_desc frame; // size, mode, traversal, sampler, spp, seed, dump_rays (pools filled in here)
    int tree_n, tree_d;
    uint64_t max_bytes;     // for the tree's pools; 0: half the device's heap
} pn_setup_desc;

typedef struct pn_setup {
    pn_ntree tree;
    pn_pools pools;
    pn_gpu_pools gpu_pools;
    pn_bvh bvh;
    pn_gpu_exact_pools exact;
    pn_renderer renderer;
    double build_ms;          // N-tree with line spaces, or BVH
    pn_pool_bytes pool_bytes; // of the N-tree (zero without one)
    uint64_t exact_bytes;     // triangle, BVH and candidate pools
} pn_setup;

// Builds what desc.frame.mode needs (the tree culls triangles that cannot block a ray to `light`)
// and creates the renderer. Logs and fails as the pieces do.
pn_result pn_setup_create(pn_gpu_device *dev, const pn_scene *scene, const pn_light *light, const pn_setup_desc *desc,
                          pn_setup *out);
void pn_setup_destroy(pn_gpu_device *dev, pn_setup *s);
