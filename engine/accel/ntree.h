// The N-tree: a recursive grid over the scene's triangles. The root box (the scene bounds made
// cubic) is split into N^3 children; a child that holds geometry is split again, down to depth d.
// Children at level d are leaves, filled or empty. Every subdivided node gets a line space.
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "accel/linespace.h"
#include "core/error.h"
#include "scene/scene.h"

#include "interface.h" // PN_NTREE_MAX_DEPTH; PN_CELL_EMPTY, PN_CELL_FILLED: the tree pool's encoding

#define PN_CELL_NODE(i) ((uint32_t)(i) + PN_CELL_FIRST_NODE) // a subdivided child: node index i

typedef struct pn_ntree_desc {
    int n, d;           // branching factor 2..16, depth 1..6
    uint64_t max_bytes; // refuse a tree whose pools would exceed this; 0 = no limit
    uint64_t max_pool_bytes; // refuse a tree with a pool larger than this (the device's largest
                             // buffer, pn_gpu_device_max_buffer); 0 = no limit
    // With the lights' corners: leave out triangles that cannot block any shadow ray, i.e. those
    // whose plane has the whole scene and every light on one closed side (a ground plane under
    // everything, the outer walls of a room lit from inside). NULL keeps every triangle.
    const float (*cull_light)[3];
    uint32_t cull_light_corners; // points at cull_light: 8 per light, pn_light_reach (0 counts as 4)
    // With a box (lo xyz, hi xyz): also leave out triangles wholly outside it, e.g. the box of the
    // visible receivers and the light, which holds every segment from one to the other.
    const float *keep_box;
    // Keep each last-level node's triangles (the paper's candidate lists), for the modes that test
    // triangles exactly where the line space cannot decide (hybrid, exact-ls).
    bool keep_candidates;
    // Fit a plane to every filled leaf of the last-level nodes (ls-plane): `planes` below.
    bool leaf_planes;
    // Per scene triangle, nonzero if it is alpha-masked (accel/alpha.h); NULL: none is. Marks the
    // leaves holding one (`alpha_bits` below), and without keep_candidates keeps the candidate
    // lists of those leaves only: the line-space modes test them exactly, as a line space (a
    // filled leaf) cannot tell a cut-out texel from a solid one.
    const uint8_t *masked;
} pn_ntree_desc;

typedef struct pn_ntree_node {
    uint32_t level;    // root = 0
    uint32_t coord[3]; // cell coordinates at its level: box = root_min + coord * cell_size(level)
} pn_ntree_node;

// Bytes of the GPU pools for `subdivided` nodes (see accel/pools.h for their layout).
typedef struct pn_pool_bytes {
    uint64_t tree, node, linespace, planes, total;
} pn_pool_bytes;

typedef struct pn_ntree {
    int n, d;
    double root_min[3];
    double root_size; // edge of the cubic root box
    double slack;     // every cell is grown by this for the occupancy test (see ntree.c)
    uint32_t triangles;   // in the tree
    uint32_t culled;      // left out: they cannot block a shadow ray (cull_light, keep_box)
    uint32_t culled_box;  // of those, left out by keep_box
    uint32_t node_count;  // subdivided nodes, breadth-first, root = 0
    pn_ntree_node *nodes; // node_count
    uint32_t *children;   // node_count * n^3 child entries, child c = (z*n + y)*n + x
    uint32_t words64;     // 64-bit words per line space
    uint64_t *linespaces; // node_count * words64
    uint64_t filled_per_level[PN_NTREE_MAX_DEPTH + 1]; // filled cells at level 0..d
    uint64_t set_bits;                                 // over all line spaces
    // The last-level nodes are numbered consecutively from cand_first_node (every tree).
    // With keep_candidates: the triangles (scene ids) of every leaf of the last-level nodes. Leaf c
    // of last-level node i has cand_tris[cand_offset[k] .. cand_offset[k + 1]),
    // k = (i - cand_first_node) * n^3 + c.
    uint32_t cand_first_node;
    uint32_t *cand_offset; // (last-level nodes) * n^3 + 1
    uint32_t cand_offsets; // entries of cand_offset
    uint32_t *cand_tris;
    uint64_t cand_count;
    // With leaf_planes: one word per leaf of the last-level nodes, leaf c of node i at
    // (i - cand_first_node) * n^3 + c (accel/leaf_plane.h).
    uint32_t *planes;
    uint64_t plane_count;
    // With desc.masked: per last-level node i, n^3 + 1 bits from bit (i - cand_first_node) (n^3 + 1):
    // the first set if any of its leaves holds an alpha-masked triangle, then one per leaf c.
    uint32_t *alpha_bits;
    uint32_t alpha_words;
    uint64_t masked_leaves;
    double occupancy_ms, masks_ms, linespace_ms, build_ms;
} pn_ntree;

pn_pool_bytes pn_ntree_pool_bytes(int n, uint64_t subdivided_nodes);

// Builds the tree over the scene's triangles on all cores. PN_ERR_INVALID for N or d out of range;
// PN_ERR_MEMORY (with a logged estimate and a suggestion) when the pools would exceed max_bytes.
pn_result pn_ntree_build(const pn_scene *scene, const pn_ntree_desc *desc, pn_ntree *out);
void pn_ntree_destroy(pn_ntree *tree);

// The cull_light test: can triangle v (3 vertices, xyz each) block a segment between two points of
// the box [lo, hi] (the scene's bounds), or between one and a light? Not if its plane has the box's
// corners and the `corners` light corners all on one closed side. Degenerate triangles can.
bool pn_ntree_can_block(const float v[9], const float lo[3], const float hi[3], const float (*light)[3],
                        uint32_t corners);

// Edge length of a cell at `level` (root = level 0).
double pn_ntree_cell_size(const pn_ntree *t, int level);

// The closed box of the cell with integer coordinates `coord` at `level`, grown by t->slack.
// The build and the tests' oracle share it so that both see exactly the same boxes.
void pn_ntree_cell_box(const pn_ntree *t, int level, const uint64_t coord[3], double lo[3], double hi[3]);

// Exact separating-axis test of a triangle against the closed box [lo, hi] (Akenine-Moller), in
// double precision; degenerate triangles (segments, points) are handled by skipping zero axes.
bool pn_tri_box_overlap(const double v[3][3], const double lo[3], const double hi[3]);
