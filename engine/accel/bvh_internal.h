// What the BVH build's files share (bvh.c: the build's phases in order; bvh_split.c: how a node is
// split, on one thread or on all; bvh_tree.c: the nodes, the per-thread subtrees and the final
// order): the primitive, box, bin and task types and their small inline helpers. Not for use
// outside engine/accel/bvh*.c.
#pragma once
#include <float.h>
#include <stdatomic.h>
#include <stdbool.h>

#include "accel/bvh.h"

enum {
    BINS = 16,       // SAH bins per axis
    LEAF_MAX = 4,    // triangles per leaf at most, unless they cannot be split
    MAX_DEPTH = PN_BVH_STACK - 4, // the GPU walk's stack holds PN_BVH_STACK entries
    // The top of the tree is split by all threads together, each pass over a node's primitives cut
    // into blocks of BLOCK, for nodes of more than WIDE_MIN primitives; below that, each subtree
    // is one thread's task. Both are fixed numbers, not functions of the thread count: which nodes
    // are split which way, and so the order the primitives end in, must not depend on it.
    BLOCK = 8192,
    WIDE_MIN = 4 * BLOCK,
};

// A box: x, y, z and a fourth lane, 0 in every primitive's box and read by nothing, there so that
// a box is two rows of four floats: the compiler grows boxes four lanes at a time (one min and one
// max instruction each), a third of the instructions and stores of six separate floats.
typedef struct aabb {
    float lo[4], hi[4];
} aabb;

// Plain comparisons rather than fminf/fmaxf, which are library calls here: a NaN coordinate is
// still never taken (the comparison is false), as with fminf.
static inline float min1(float a, float b) { return a < b ? a : b; }
static inline float max1(float a, float b) { return a > b ? a : b; }

static inline void aabb_empty(aabb *b)
{
    for (int k = 0; k < 4; k++)
        b->lo[k] = FLT_MAX, b->hi[k] = -FLT_MAX;
}

static inline void aabb_grow(aabb *b, const aabb *o)
{
    for (int k = 0; k < 4; k++) {
        b->lo[k] = min1(o->lo[k], b->lo[k]);
        b->hi[k] = max1(o->hi[k], b->hi[k]);
    }
}

static inline void aabb_grow_point(aabb *b, const float p[4])
{
    for (int k = 0; k < 4; k++) {
        b->lo[k] = min1(p[k], b->lo[k]);
        b->hi[k] = max1(p[k], b->hi[k]);
    }
}

static inline float aabb_area(const aabb *b)
{
    float e[3];
    for (int k = 0; k < 3; k++)
        e[k] = max1(b->hi[k] - b->lo[k], 0.0f);
    return e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
}

// A primitive as the build sees it: its box (32 bytes), moved by the partitions together with its
// id (in an array of their own, in the same order), so that binning and partitioning read one
// array front to back instead of boxes through an index.
typedef struct prim {
    aabb box;
} prim;

static inline void prim_centroid(const prim *p, float c[4])
{
    for (int k = 0; k < 4; k++)
        c[k] = 0.5f * (p->box.lo[k] + p->box.hi[k]);
}

// Build state. The top phase numbers its nodes (the wide ones and the tasks' roots) in `top` on
// one thread; each task numbers its root's descendants from 0 in its own stretch of `sub`, two
// nodes per primitive from its first primitive's (a subtree over m primitives has fewer than 2m
// nodes). pn_bvh_assemble() then puts them all in one array.
typedef struct builder {
    prim *prims[2];  // the primitives, permuted; a task's are in prims[task.in_other]
    uint32_t *id[2]; // their ids, in the same order; id[0] is the output triangle order
    pn_bvh_node *top, *sub;
    uint32_t top_count;
    atomic_uint depth;
} builder;

// A node to build over prims [begin, end), with the bounds of their boxes and of their centroids
// (the parent's partition computes both, so no node reads its primitives just for its bounds).
typedef struct task {
    uint32_t node, begin, end, depth;
    bool in_other; // the top phase's wide splits leave primitives in either of two arrays
    aabb box, cbox;
} task;

static inline void range_bounds(const prim *p, uint32_t begin, uint32_t end, aabb *box, aabb *cbox)
{
    aabb_empty(box);
    aabb_empty(cbox);
    for (uint32_t i = begin; i < end; i++) {
        float c[4];
        prim_centroid(&p[i], c);
        aabb_grow(box, &p[i].box);
        aabb_grow_point(cbox, c);
    }
}

// Where a centroid coordinate falls among BINS bins from lo, scale = BINS / extent.
static inline int bin_of(float c, float lo, float scale)
{
    int bin = (int)((c - lo) * scale);
    return bin < 0 ? 0 : bin >= BINS ? BINS - 1 : bin;
}

// Bins over all three axes, filled in one pass over the primitives.
typedef struct bins {
    aabb box[3][BINS];
    uint32_t count[3][BINS];
} bins;

// How a node is split: what falls in bins 0 .. bin of axis goes left; or in two halves of its
// primitives as they lie (SPLIT_HALVES: nothing separates their centroids); or not (SPLIT_LEAF).
typedef struct split {
    int axis, bin;
} split;
enum { SPLIT_LEAF = -1, SPLIT_HALVES = -2 };

// One node's passes on all threads, over blocks of BLOCK primitives from `begin`. Each block has
// its own bins and bounds, merged in block order: the same result on any number of threads.
typedef struct wide {
    const prim *src;
    prim *dst; // the partition's output, a stable one: left side first, then right, each in order
    const uint32_t *src_id;
    uint32_t *dst_id;
    uint32_t begin, end;
    float lo[3], scale[3];
    split s;
    bins *bins;         // per block
    uint32_t *left;     // per block: where its left ones go in dst
    uint32_t *right;    // per block: where its right ones go in dst
    aabb (*side)[4];    // per block: bounds of what goes left (boxes, centroids) and right
} wide;

typedef struct par_ctx {
    builder *b;
    const task *tasks;
    uint32_t *count; // per task: its root's descendants
    uint32_t *at;    // per task: where they start in the final array
    pn_bvh_node *nodes; // the final array
} par_ctx;

// Splits task t on this thread, in place (bvh_split.c).
uint32_t pn_bvh_split_node(prim *p, uint32_t *id, const task *t, aabb side[4]);
// Splits task t with all threads, into the other array (bvh_split.c).
uint32_t pn_bvh_split_wide(const builder *b, const task *t, wide *scratch, aabb side[4], bool *moved);
// Makes a node a leaf, or interior with two children (bvh_tree.c).
void pn_bvh_make_leaf(builder *b, pn_bvh_node *node, const task *t);
void pn_bvh_make_interior(pn_bvh_node *node, const task *t, uint32_t split_at, const aabb side[4], pn_bvh_node *nodes,
                          uint32_t *count, task kids[2]);
// pn_parallel_for's worker: builds the subtrees of tasks [begin, end) of a par_ctx (bvh_tree.c).
void pn_bvh_build_tasks(void *ctx, uint64_t begin, uint64_t end, unsigned thread);
// The nodes in their final order (bvh_tree.c).
pn_bvh_node *pn_bvh_assemble(par_ctx *p, uint32_t ntasks, uint32_t *node_count);
