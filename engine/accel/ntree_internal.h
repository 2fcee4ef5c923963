// What the N-tree build's files share (ntree.c: the build's steps and line spaces;
// ntree_occupancy.c: the occupancy level by level; ntree_level.c: one level's parallel chunk and
// gather workers; ntree_leaves.c: what the last level's leaves keep): the level's node and chunk
// types. Not for use outside engine/accel/ntree*.c.
#pragma once
#include <stdatomic.h>

#include "accel/ntree.h"

// Occupancy, level by level. Each level's triangle lists are cut into chunks tested in parallel;
// then each node gathers its chunks' (child, triangle) pairs into per-child lists.

enum { CHUNK = 2048 };

typedef struct level_node {
    const uint32_t *tris;
    uint32_t count;
    uint32_t node; // index into tree->nodes
} level_node;

typedef struct chunk {
    uint32_t lnode; // index into the level's node array
    uint32_t begin, end;
    uint64_t *pairs; // (child << 32) | triangle
    uint32_t pair_count, pair_cap;
    bool failed;
} chunk;

typedef struct build_ctx {
    pn_ntree *t;
    const float (*tri)[9];     // triangle vertices
    const float (*box)[6];     // triangle bounds lo xyz, hi xyz
    level_node *lnodes;
    chunk *chunks;
    int level; // of the nodes being split
    bool need_lists;
    uint32_t **child_lists; // per level node: n^3 + 1 offsets followed by the triangle ids
    atomic_bool failed;
} build_ctx;

typedef struct node_chunks {
    uint32_t first, count; // range in the chunk array
} node_chunks;

typedef struct gather_ctx {
    build_ctx *b;
    const node_chunks *nc;
} gather_ctx;

// pn_parallel_for's workers of one level (ntree_level.c): chunks [begin, end) of a build_ctx tested
// against the children of their node; level nodes [begin, end) of a gather_ctx gathering their
// chunks' pairs into per-child counts and lists.
void pn_ntree_split_chunks(void *ctx, uint64_t begin, uint64_t end, unsigned thread);
void pn_ntree_gather_nodes(void *ctx, uint64_t begin, uint64_t end, unsigned thread);
// What the last level's leaves keep (ntree_leaves.c): their candidate lists (and alpha bits), and
// their planes.
pn_result pn_ntree_keep_candidates(pn_ntree *t, const pn_ntree_desc *desc, uint32_t lcount, uint32_t **lists);
pn_result pn_ntree_build_planes(pn_ntree *t, const float (*tri)[9], const level_node *lnodes, uint32_t lcount,
                                uint32_t **lists);
// The occupancy level by level (ntree_occupancy.c): the nodes and their children's entries.
pn_result pn_ntree_build_occupancy(const pn_scene *s, const pn_ntree_desc *desc, pn_ntree *t);
