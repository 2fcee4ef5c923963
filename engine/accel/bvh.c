// The exact mode's BVH: binned SAH (16 bins per axis, the split cost a traversal step plus the
// sides' triangle tests weighted by area), leaves of at most LEAF_MAX triangles. The build, in
// order of its phases:
//   triangle boxes on all threads;
//   the top: nodes of more than WIDE_MIN primitives, one at a time, each with all threads over
//     fixed blocks of its primitives (per-block bins merged in block order; a stable partition
//     into a second array);
//   the rest: each subtree below the top is one thread's task, biggest first, built depth first
//     with in-place partitions;
//   assembly: the nodes in depth-first order, each interior node's children together.
// Every step depends on the primitives alone, never on the thread count: the nodes and the
// triangle order are the same bytes on any number of threads (issue 30).
//
// The phases' pieces: how a node is split in bvh_split.c, the nodes, subtrees and assembly in
// bvh_tree.c, their shared types in bvh_internal.h; here the phases in order.
#include "accel/bvh.h"

#include <stdlib.h>
#include <string.h>

#include "accel/bvh_internal.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/timer.h"

// Bigger subtrees first, so that the last ones to start are short; ties by position.
static int by_size(const void *a, const void *b)
{
    const task *x = a, *y = b;
    uint32_t nx = x->end - x->begin, ny = y->end - y->begin;
    if (nx != ny)
        return nx > ny ? -1 : 1;
    return x->begin < y->begin ? -1 : x->begin > y->begin;
}

typedef struct bounds_ctx {
    const prim *p;
    uint32_t *id;
    uint32_t n;
    aabb (*block)[4]; // per block: the boxes' bounds, the centroids'
} bounds_ctx;

// The bounds of each block of the primitives, and their ids (0 .. n-1).
static void block_bounds(void *ctx, uint64_t first, uint64_t last, unsigned thread)
{
    bounds_ctx *c = ctx;
    for (uint64_t k = first; k < last; k++) {
        uint32_t begin = (uint32_t)k * BLOCK, end = c->n - begin > BLOCK ? begin + BLOCK : c->n;
        range_bounds(c->p, begin, end, &c->block[k][0], &c->block[k][1]);
        for (uint32_t i = begin; i < end; i++)
            c->id[i] = i;
    }
}

// Builds over n primitives, whose ids are 0 .. n-1; takes ownership of prims (freed here).
static pn_result build(prim *prims, uint32_t n, pn_bvh *out)
{
    uint64_t t0 = pn_time_ns();
    out->tri_index = malloc((size_t)(n ? n : 1) * sizeof *out->tri_index);
    // The wide nodes are split one at a time, depth first; the nodes they leave narrower become
    // the subtree tasks. Wide nodes of one depth do not overlap, so there are at most
    // n / WIDE_MIN of them per depth, and each leaves at most two tasks: the top nodes are the
    // root and two per wide node.
    uint32_t blocks = (n + BLOCK - 1) / BLOCK, max_tasks = 2 * (MAX_DEPTH + 1) * (n / WIDE_MIN + 1);
    task *tasks = malloc((size_t)max_tasks * sizeof *tasks);
    uint32_t *task_count = malloc((size_t)max_tasks * sizeof *task_count);
    uint32_t *task_at = malloc((size_t)max_tasks * sizeof *task_at);
    pn_bvh_node *top = malloc((size_t)(max_tasks + 1) * sizeof *top);
    pn_bvh_node *sub = malloc((size_t)2 * (n ? n : 1) * sizeof *sub);
    // Wide splits partition from one array into the other and back (`in_other` says which holds
    // a task's primitives); per-block state for the widest node, the root.
    prim *other = n > WIDE_MIN ? malloc((size_t)n * sizeof *other) : NULL;
    uint32_t *other_id = n > WIDE_MIN ? malloc((size_t)n * sizeof *other_id) : NULL;
    wide scratch = {
        .bins = malloc((size_t)(blocks ? blocks : 1) * sizeof *scratch.bins),
        .left = malloc((size_t)(blocks ? blocks : 1) * sizeof *scratch.left),
        .right = malloc((size_t)(blocks ? blocks : 1) * sizeof *scratch.right),
        .side = malloc((size_t)(blocks ? blocks : 1) * sizeof *scratch.side),
    };
    if (!prims || !out->tri_index || !tasks || !task_count || !task_at || !top || !sub ||
        (n > WIDE_MIN && (!other || !other_id)) || !scratch.bins || !scratch.left || !scratch.right || !scratch.side) {
        free(prims), free(other), free(other_id), free(tasks), free(task_count), free(task_at), free(top), free(sub);
        free(scratch.bins), free(scratch.left), free(scratch.right), free(scratch.side);
        pn_bvh_destroy(out);
        return PN_ERR_MEMORY;
    }
    builder b = {.prims = {prims, other}, .id = {out->tri_index, other_id}, .top = top, .sub = sub, .top_count = 1};
    atomic_init(&b.depth, 0);

    // The root's bounds, block by block (into the first two bounds of scratch.side per block).
    task root = {.node = 0, .begin = 0, .end = n};
    bounds_ctx bc = {prims, out->tri_index, n, scratch.side};
    pn_parallel_for(blocks, 1, block_bounds, &bc);
    aabb_empty(&root.box);
    aabb_empty(&root.cbox);
    for (uint32_t k = 0; k < blocks; k++) {
        aabb_grow(&root.box, &scratch.side[k][0]);
        aabb_grow(&root.cbox, &scratch.side[k][1]);
    }
    memcpy(top[0].min, root.box.lo, sizeof top[0].min);
    memcpy(top[0].max, root.box.hi, sizeof top[0].max);

    uint32_t ntasks = 0, wide_nodes = 0;
    task stack[2 * MAX_DEPTH + 8];
    int sp = 0;
    stack[sp++] = root;
    while (sp > 0) {
        task cur = stack[--sp];
        if (cur.end - cur.begin <= WIDE_MIN) {
            tasks[ntasks++] = cur;
            continue;
        }
        wide_nodes++;
        aabb side[4];
        bool moved = false;
        uint32_t split_at = cur.depth + 1 >= MAX_DEPTH ? cur.begin : pn_bvh_split_wide(&b, &cur, &scratch, side, &moved);
        bool in_other = cur.in_other != moved;
        if (split_at == cur.begin) { // a leaf: at the depth limit only, this wide
            if (in_other)
                memcpy(b.id[0] + cur.begin, b.id[1] + cur.begin, (size_t)(cur.end - cur.begin) * sizeof *b.id[1]);
            pn_bvh_make_leaf(&b, &top[cur.node], &cur);
            continue;
        }
        task kids[2];
        pn_bvh_make_interior(&top[cur.node], &cur, split_at, side, top, &b.top_count, kids);
        kids[0].in_other = kids[1].in_other = in_other;
        stack[sp++] = kids[1];
        stack[sp++] = kids[0];
    }
    free(scratch.bins), free(scratch.left), free(scratch.right), free(scratch.side);
    uint64_t t1 = pn_time_ns();
    qsort(tasks, ntasks, sizeof *tasks, by_size);
    par_ctx p = {&b, tasks, task_count, task_at};
    pn_parallel_for(ntasks, 1, pn_bvh_build_tasks, &p);
    free(other), free(other_id);
    free(prims);
    uint64_t t2 = pn_time_ns();
    out->nodes = pn_bvh_assemble(&p, ntasks, &out->node_count);
    free(tasks), free(task_count), free(task_at), free(top), free(sub);
    if (!out->nodes) {
        pn_bvh_destroy(out);
        return PN_ERR_MEMORY;
    }
    out->triangles = n;
    out->depth = atomic_load(&b.depth);
    pn_debug("bvh: %u primitives: boxes %.1f ms, top levels %.1f ms (%u wide nodes, %u tasks), subtrees %.1f ms, "
             "assembly %.1f ms",
             n, out->build_ms, (double)(t1 - t0) * 1e-6, wide_nodes, ntasks, (double)(t2 - t1) * 1e-6,
             pn_ms_since(t2));
    out->build_ms += pn_ms_since(t0);
    return PN_OK;
}

typedef struct boxes_ctx {
    const pn_scene *s;
    prim *prims;
    uint32_t n;
} boxes_ctx;

static void triangle_boxes(void *ctx, uint64_t first, uint64_t last, unsigned thread)
{
    const boxes_ctx *c = ctx;
    const pn_vertex *v = c->s->vertices;
    const uint32_t *idx = c->s->indices;
    uint32_t end = last * BLOCK < c->n ? (uint32_t)last * BLOCK : c->n;
    for (uint32_t i = (uint32_t)first * BLOCK; i < end; i++) {
        aabb *b = &c->prims[i].box;
        for (int k = 0; k < 4; k++)
            b->lo[k] = b->hi[k] = 0.0f;
        for (int k = 0; k < 3; k++)
            b->lo[k] = FLT_MAX, b->hi[k] = -FLT_MAX;
        for (int j = 0; j < 3; j++) {
            const float *q = v[idx[3 * i + j]].pos;
            for (int k = 0; k < 3; k++) {
                b->lo[k] = min1(q[k], b->lo[k]);
                b->hi[k] = max1(q[k], b->hi[k]);
            }
        }
    }
}

pn_result pn_bvh_build(const pn_scene *s, pn_bvh *out)
{
    memset(out, 0, sizeof *out);
    uint64_t t0 = pn_time_ns();
    uint32_t n = pn_scene_triangle_count(s);
    prim *prims = malloc((size_t)(n ? n : 1) * sizeof *prims);
    if (prims) {
        boxes_ctx c = {s, prims, n};
        pn_parallel_for((n + BLOCK - 1) / BLOCK, 1, triangle_boxes, &c);
    }
    out->build_ms = pn_ms_since(t0);
    return build(prims, n, out);
}

pn_result pn_bvh_build_boxes(const float (*box)[6], uint32_t n, pn_bvh *out)
{
    memset(out, 0, sizeof *out);
    prim *prims = malloc((size_t)(n ? n : 1) * sizeof *prims);
    for (uint32_t i = 0; prims && i < n; i++) {
        for (int k = 0; k < 3; k++) {
            prims[i].box.lo[k] = box[i][k];
            prims[i].box.hi[k] = box[i][3 + k];
        }
        prims[i].box.lo[3] = prims[i].box.hi[3] = 0.0f;
    }
    return build(prims, n, out);
}

void pn_bvh_destroy(pn_bvh *bvh)
{
    free(bvh->nodes);
    free(bvh->tri_index);
    memset(bvh, 0, sizeof *bvh);
}
