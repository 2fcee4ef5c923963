// The N-tree's GPU pools (after Crassin's octree pools), declared once for C and GLSL in
// shaders/glsl/interface.h; tests/test_pools.c checks that both agree on sizes and offsets.
//
//   tree pool:      uint32 entries, N^3 per subdivided node (its children group, child
//                   c = (z*N + y)*N + x): PN_CELL_EMPTY, PN_CELL_FILLED (a filled leaf) or
//                   PN_CELL_NODE(i) (subdivided child i). Node i's group starts at i * N^3.
//   node pool:      one pn_gpu_node per subdivided node, breadth-first, root = 0.
//   line-space pool: node i's line space is 32-bit words [i * W, (i+1) * W), W = 2 * pn_ls_words64(N);
//                   bit layout in accel/linespace.h.
//   plane pool:     trees built with leaf planes (ls-plane) only: one word per leaf of the
//                   last-level nodes (ntree.h, `planes`).
// Pools are reached through buffer device addresses, so none is bound by maxStorageBufferRange; a
// pool larger than the device's maxMemoryAllocationSize is refused (never truncated).
// llvmpipe: maxStorageBufferRange is 128 MiB per binding (Mesa 22.3 and 25), below a large pool.
#pragma once
#include <stdint.h>

#include "accel/ntree.h"
#include "interface.h"

// pn_gpu_node (one per subdivided node) and pn_gpu_tree_info (what a shader needs to walk the
// pools) are shared with the shaders: interface.h.

// The pools as plain bytes, ready to upload. `tree` and `linespace` point into the tree (no copy);
// `nodes` is allocated here.
typedef struct pn_pools {
    pn_gpu_node *nodes;
    const uint32_t *tree;
    const uint32_t *linespace;
    const uint32_t *planes; // NULL without leaf planes
    pn_pool_bytes bytes;
    pn_gpu_tree_info info; // addresses left 0 until uploaded
} pn_pools;

pn_result pn_pools_pack(const pn_ntree *tree, pn_pools *out);
void pn_pools_destroy(pn_pools *pools);
