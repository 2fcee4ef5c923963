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
// Over 500 lines because its phases share the file-local primitive, bin and task types: binning,
// the parallel top and the per-thread subtrees are one build.
#include "accel/bvh.h"

#include <float.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "accel/alpha.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/timer.h"

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

static void aabb_empty(aabb *b)
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
// nodes). assemble() then puts them all in one array.
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

// Where the bins of each axis start and how wide they are, from the centroids' bounds.
static void bins_frame(const aabb *cbox, float lo[3], float scale[3])
{
    for (int k = 0; k < 3; k++) {
        float ext = cbox->hi[k] - cbox->lo[k];
        lo[k] = cbox->lo[k];
        scale[k] = ext > 0 ? BINS / ext : 0.0f; // a flat axis fills bin 0 and is not swept
    }
}

// Adds primitive q, whose bin along axis k is bin, to the bins of that axis.
static inline void bins_add(bins *b, int k, int bin, const prim *q)
{
    b->count[k][bin]++;
    aabb_grow(&b->box[k][bin], &q->box);
}

static void bins_fill(const prim *p, uint32_t begin, uint32_t end, const float frame_lo[3],
                      const float frame_scale[3], bins *out)
{
    // Local copies in four lanes (the fourth idle): the stores to out could alias the caller's
    // arrays, and the three axes' bins are found together.
    float lo[4] = {frame_lo[0], frame_lo[1], frame_lo[2], 0.0f};
    float scale[4] = {frame_scale[0], frame_scale[1], frame_scale[2], 0.0f};
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < BINS; i++) {
            aabb_empty(&out->box[k][i]);
            out->count[k][i] = 0;
        }
    for (uint32_t i = begin; i < end; i++) {
        float c[4];
        int bin[4];
        prim_centroid(&p[i], c);
        for (int k = 0; k < 4; k++)
            bin[k] = bin_of(c[k], lo[k], scale[k]);
        bins_add(out, 0, bin[0], &p[i]);
        bins_add(out, 1, bin[1], &p[i]);
        bins_add(out, 2, bin[2], &p[i]);
    }
}

// Adds o's contents to b. The SAH sweep alone reads bins, and only their areas and counts: the
// order bins are merged in changes nothing it sees.
static void bins_merge(bins *b, const bins *o)
{
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < BINS; i++) {
            aabb_grow(&b->box[k][i], &o->box[k][i]);
            b->count[k][i] += o->count[k][i];
        }
}

// How a node is split: what falls in bins 0 .. bin of axis goes left; or in two halves of its
// primitives as they lie (SPLIT_HALVES: nothing separates their centroids); or not (SPLIT_LEAF).
typedef struct split {
    int axis, bin;
} split;
enum { SPLIT_LEAF = -1, SPLIT_HALVES = -2 };

// Chooses the split of task t by binned SAH over centroids from its bins.
static split sah_choose(const task *t, const bins *bn)
{
    uint32_t n = t->end - t->begin;
    const aabb *box = &t->box, *cbox = &t->cbox;
    float area = aabb_area(box), best_cost = (float)n * area; // the leaf's cost
    int best_axis = -1, best_bin = 0;
    for (int k = 0; k < 3; k++) {
        if (!(cbox->hi[k] - cbox->lo[k] > 0))
            continue;
        // Sweep: cost of splitting after bin i = N_left * A_left + N_right * A_right. Only splits
        // after non-empty bins are weighed: one after an empty bin has the same sides as one after
        // the non-empty bin before it, and small nodes, the most of them, fill few of the bins.
        int used[BINS], m = 0;
        for (int i = 0; i < BINS; i++) {
            used[m] = i; // kept when the bin is not empty (no branch: which ones are, is random)
            m += bn->count[k][i] != 0;
        }
        float right_area[BINS];
        uint32_t right_count[BINS];
        aabb acc;
        aabb_empty(&acc);
        uint32_t c = 0;
        for (int j = m - 1; j > 0; j--) {
            aabb_grow(&acc, &bn->box[k][used[j]]);
            c += bn->count[k][used[j]];
            right_area[j] = aabb_area(&acc);
            right_count[j] = c;
        }
        aabb_empty(&acc);
        c = 0;
        for (int j = 0; j < m - 1; j++) {
            aabb_grow(&acc, &bn->box[k][used[j]]);
            c += bn->count[k][used[j]];
            // The traversal step costs about one triangle test: both are a few dozen flops.
            float cost = area + (float)c * aabb_area(&acc) + (float)right_count[j + 1] * right_area[j + 1];
            if (cost < best_cost) {
                best_cost = cost;
                best_axis = k;
                best_bin = used[j];
            }
        }
    }
    if (best_axis >= 0)
        return (split){best_axis, best_bin};
    if (n <= LEAF_MAX)
        return (split){SPLIT_LEAF, 0};
    // No good SAH split of a big set: split at the median of the widest centroid axis.
    int k = 0;
    for (int a = 1; a < 3; a++)
        if (cbox->hi[a] - cbox->lo[a] > cbox->hi[k] - cbox->lo[k])
            k = a;
    if (!(cbox->hi[k] > cbox->lo[k])) // identical centroids: any split
        return (split){SPLIT_HALVES, 0};
    return (split){k, BINS / 2 - 1};
}

// The two halves of [begin, end) as they lie, with their bounds; returns the middle.
static uint32_t split_halves(const prim *p, uint32_t begin, uint32_t end, aabb side[4])
{
    uint32_t mid = begin + (end - begin) / 2;
    range_bounds(p, begin, mid, &side[0], &side[1]);
    range_bounds(p, mid, end, &side[2], &side[3]);
    return mid;
}

// Splits task t on this thread, in place (the primitives p and their ids); returns the split index,
// or t->begin for a leaf. On a split, side[] is set to the bounds of the left boxes and centroids,
// then the right ones.
static uint32_t split_node(prim *p, uint32_t *id, const task *t, aabb side[4])
{
    uint32_t begin = t->begin, end = t->end, n = end - begin;
    float lo[3], scale[3];
    bins bn;
    bins_frame(&t->cbox, lo, scale);
    bins_fill(p, begin, end, lo, scale, &bn);
    split s = sah_choose(t, &bn);
    if (s.axis == SPLIT_LEAF)
        return begin;
    if (s.axis == SPLIT_HALVES)
        return split_halves(p, begin, end, side);
    // Partition, growing each side's bounds with what goes to it.
    int k = s.axis;
    for (int i = 0; i < 4; i++)
        aabb_empty(&side[i]);
    uint32_t i = begin, j = end;
    while (i < j) {
        prim q = p[i];
        float c[4];
        prim_centroid(&q, c);
        if (bin_of(c[k], lo[k], scale[k]) <= s.bin) {
            aabb_grow(&side[0], &q.box);
            aabb_grow_point(&side[1], c);
            i++;
        } else {
            aabb_grow(&side[2], &q.box);
            aabb_grow_point(&side[3], c);
            uint32_t qid = id[i];
            j--;
            p[i] = p[j], id[i] = id[j];
            p[j] = q, id[j] = qid;
        }
    }
    if (i == begin || i == end) // all on one side: a leaf, or halves when it is too big
        return n <= LEAF_MAX ? begin : split_halves(p, begin, end, side);
    return i;
}

// Makes node a leaf over the task's primitives; records its depth.
static void make_leaf(builder *b, pn_bvh_node *node, const task *t)
{
    node->first = t->begin;
    node->count = t->end - t->begin;
    uint32_t d = t->depth + 1, old = atomic_load(&b->depth);
    while (d > old && !atomic_compare_exchange_weak(&b->depth, &old, d))
        ;
}

// Makes node (the task's) interior with children over [begin, split) and [split, end), whose
// bounds are side[]: nodes[*count] and the next, which *count then passes; sets their tasks.
static void make_interior(pn_bvh_node *node, const task *t, uint32_t split_at, const aabb side[4], pn_bvh_node *nodes,
                          uint32_t *count, task kids[2])
{
    uint32_t child = *count;
    *count += 2;
    node->first = child;
    node->count = 0;
    for (int i = 0; i < 2; i++) {
        task *k = &kids[i];
        k->node = child + i;
        k->begin = i == 0 ? t->begin : split_at;
        k->end = i == 0 ? split_at : t->end;
        k->depth = t->depth + 1;
        k->box = side[2 * i];
        k->cbox = side[2 * i + 1];
        pn_bvh_node *c = &nodes[k->node];
        memcpy(c->min, k->box.lo, sizeof c->min);
        memcpy(c->max, k->box.hi, sizeof c->max);
    }
}

// Builds the subtree of task t on this thread, then writes its primitives' order to ids. Its
// root is top[t.node]; the descendants are numbered in the order of the final array (assemble()).
// Returns their count.
static uint32_t build_subtree(builder *b, task t)
{
    prim *p = b->prims[t.in_other];
    uint32_t *id = b->id[t.in_other];
    pn_bvh_node *local = b->sub + 2 * (size_t)t.begin;
    uint32_t count = 0;
    task stack[2 * MAX_DEPTH + 8];
    int sp = 0;
    stack[sp++] = t;
    for (bool root = true; sp > 0; root = false) {
        task cur = stack[--sp];
        pn_bvh_node *node = root ? &b->top[cur.node] : &local[cur.node];
        aabb side[4];
        uint32_t split_at = cur.depth + 1 >= MAX_DEPTH ? cur.begin : split_node(p, id, &cur, side);
        if (split_at == cur.begin) { // leaf (also when the depth limit is reached)
            make_leaf(b, node, &cur);
            continue;
        }
        task kids[2];
        make_interior(node, &cur, split_at, side, local, &count, kids);
        stack[sp++] = kids[1]; // the left child is taken first
        stack[sp++] = kids[0];
    }
    if (t.in_other)
        memcpy(b->id[0] + t.begin, id + t.begin, (size_t)(t.end - t.begin) * sizeof *id);
    return count;
}

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

static void block_range(const wide *w, uint64_t k, uint32_t *begin, uint32_t *end)
{
    *begin = w->begin + (uint32_t)k * BLOCK;
    *end = w->end - *begin > BLOCK ? *begin + BLOCK : w->end;
}

static void wide_bins(void *ctx, uint64_t first, uint64_t last, unsigned thread)
{
    wide *w = ctx;
    for (uint64_t k = first; k < last; k++) {
        uint32_t begin, end;
        block_range(w, k, &begin, &end);
        bins_fill(w->src, begin, end, w->lo, w->scale, &w->bins[k]);
    }
}

static void wide_scatter(void *ctx, uint64_t first, uint64_t last, unsigned thread)
{
    const wide *w = ctx;
    int k = w->s.axis, bin = w->s.bin;
    float lo = w->lo[k], scale = w->scale[k];
    const prim *src = w->src;
    prim *dst = w->dst;
    const uint32_t *src_id = w->src_id;
    uint32_t *dst_id = w->dst_id;
    for (uint64_t blk = first; blk < last; blk++) {
        uint32_t begin, end, l = w->left[blk], r = w->right[blk];
        block_range(w, blk, &begin, &end);
        // Here, not in w->side, which the stores to dst could alias; and the four by name, so
        // that they stay in registers.
        aabb lbox, lcbox, rbox, rcbox;
        aabb_empty(&lbox), aabb_empty(&lcbox), aabb_empty(&rbox), aabb_empty(&rcbox);
        for (uint32_t i = begin; i < end; i++) {
            const prim *q = &src[i];
            float c[4];
            prim_centroid(q, c);
            if (bin_of(c[k], lo, scale) <= bin) {
                dst[l] = *q, dst_id[l] = src_id[i], l++;
                aabb_grow(&lbox, &q->box);
                aabb_grow_point(&lcbox, c);
            } else {
                dst[r] = *q, dst_id[r] = src_id[i], r++;
                aabb_grow(&rbox, &q->box);
                aabb_grow_point(&rcbox, c);
            }
        }
        w->side[blk][0] = lbox, w->side[blk][1] = lcbox, w->side[blk][2] = rbox, w->side[blk][3] = rcbox;
    }
}

// Splits task t with all threads. Its primitives are in b->prims[t->in_other] (and their ids in
// b->id[t->in_other]); the split's end in the other array (and *moved is set) or stay. Returns the
// split index, or t->begin for a leaf. `scratch` holds the per-block state for ceil(n / BLOCK)
// blocks.
static uint32_t split_wide(const builder *b, const task *t, wide *scratch, aabb side[4], bool *moved)
{
    wide w = *scratch;
    prim *src = b->prims[t->in_other], *dst = b->prims[!t->in_other];
    w.src = src, w.dst = dst, w.begin = t->begin, w.end = t->end;
    w.src_id = b->id[t->in_other], w.dst_id = b->id[!t->in_other];
    uint32_t n = t->end - t->begin, blocks = (n + BLOCK - 1) / BLOCK;
    *moved = false;
    bins_frame(&t->cbox, w.lo, w.scale);
    pn_parallel_for(blocks, 1, wide_bins, &w);
    bins all = w.bins[0];
    for (uint32_t k = 1; k < blocks; k++)
        bins_merge(&all, &w.bins[k]);
    w.s = sah_choose(t, &all);
    if (w.s.axis == SPLIT_LEAF)
        return t->begin;
    if (w.s.axis == SPLIT_HALVES)
        return split_halves(src, t->begin, t->end, side);
    // Each block's bins say how many of its primitives go left: where each block's left and
    // right ones go in dst.
    uint32_t left = 0;
    for (uint32_t k = 0; k < blocks; k++) {
        w.left[k] = 0;
        for (int i = 0; i <= w.s.bin; i++)
            w.left[k] += w.bins[k].count[w.s.axis][i];
        left += w.left[k];
    }
    uint32_t l = t->begin, r = t->begin + left;
    for (uint32_t k = 0; k < blocks; k++) {
        uint32_t begin, end;
        block_range(&w, k, &begin, &end);
        uint32_t lk = w.left[k];
        w.left[k] = l, w.right[k] = r;
        l += lk, r += end - begin - lk;
    }
    pn_parallel_for(blocks, 1, wide_scatter, &w);
    *moved = true;
    if (left == 0 || left == n) // all on one side (dst is src's copy): halves
        return n <= LEAF_MAX ? t->begin : split_halves(dst, t->begin, t->end, side);
    for (int i = 0; i < 4; i++)
        side[i] = w.side[0][i];
    for (uint32_t k = 1; k < blocks; k++)
        for (int i = 0; i < 4; i++)
            aabb_grow(&side[i], &w.side[k][i]);
    return t->begin + left;
}

typedef struct par_ctx {
    builder *b;
    const task *tasks;
    uint32_t *count; // per task: its root's descendants
    uint32_t *at;    // per task: where they start in the final array
    pn_bvh_node *nodes; // the final array
} par_ctx;

static void build_tasks(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    par_ctx *p = ctx;
    for (uint64_t i = begin; i < end; i++)
        p->count[i] = build_subtree(p->b, p->tasks[i]);
}

static void place_tasks(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    par_ctx *p = ctx;
    for (uint64_t i = begin; i < end; i++) {
        const pn_bvh_node *local = p->b->sub + 2 * (size_t)p->tasks[i].begin;
        pn_bvh_node *dst = p->nodes + p->at[i];
        for (uint32_t j = 0; j < p->count[i]; j++) {
            dst[j] = local[j];
            if (dst[j].count == 0)
                dst[j].first += p->at[i];
        }
    }
}

// Puts the nodes in their final order: depth first, left child first, each interior node's two
// children placed together when it is visited. That order follows from the tree alone: the same
// on any number of threads (issue 30). Walks the top nodes; the descendants of a task's root are
// one run of that order (all of a node's descendants come right after its children's pair is
// placed, before anything outside it), which the task numbered in that order already: they are
// copied over, by all threads. Returns the array, or NULL when out of memory.
static pn_bvh_node *assemble(par_ctx *p, uint32_t ntasks, uint32_t *node_count)
{
    const builder *b = p->b;
    uint32_t total = b->top_count;
    for (uint32_t i = 0; i < ntasks; i++)
        total += p->count[i];
    uint32_t *task_of = malloc((size_t)b->top_count * sizeof *task_of);
    pn_bvh_node *dst = malloc((size_t)total * sizeof *dst);
    if (!task_of || !dst) {
        free(task_of), free(dst);
        return NULL;
    }
    for (uint32_t i = 0; i < b->top_count; i++)
        task_of[i] = UINT32_MAX;
    for (uint32_t i = 0; i < ntasks; i++)
        task_of[p->tasks[i].node] = i;
    // (top node, its place) of nodes placed but whose children are not: at most one pending right
    // sibling per level, and leaves are never deeper than MAX_DEPTH.
    uint32_t stack[MAX_DEPTH + 8][2];
    int sp = 0;
    uint32_t next = 1;
    dst[0] = b->top[0];
    stack[sp][0] = 0, stack[sp][1] = 0, sp++;
    while (sp > 0) {
        sp--;
        uint32_t s = stack[sp][0], d = stack[sp][1], t = task_of[s];
        if (b->top[s].count > 0) // a leaf (or the root of no primitives)
            continue;
        if (t != UINT32_MAX) { // a task's root: its descendants' run
            if (p->count[t] > 0)
                dst[d].first = next;
            p->at[t] = next;
            next += p->count[t];
            continue;
        }
        uint32_t c = next, sc = b->top[s].first;
        next += 2;
        dst[c] = b->top[sc];
        dst[c + 1] = b->top[sc + 1];
        dst[d].first = c;
        stack[sp][0] = sc + 1, stack[sp][1] = c + 1, sp++; // right below left: left is visited first
        stack[sp][0] = sc, stack[sp][1] = c, sp++;
    }
    free(task_of);
    p->nodes = dst;
    pn_parallel_for(ntasks, 1, place_tasks, p);
    *node_count = total;
    return dst;
}

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
        uint32_t split_at = cur.depth + 1 >= MAX_DEPTH ? cur.begin : split_wide(&b, &cur, &scratch, side, &moved);
        bool in_other = cur.in_other != moved;
        if (split_at == cur.begin) { // a leaf: at the depth limit only, this wide
            if (in_other)
                memcpy(b.id[0] + cur.begin, b.id[1] + cur.begin, (size_t)(cur.end - cur.begin) * sizeof *b.id[1]);
            make_leaf(&b, &top[cur.node], &cur);
            continue;
        }
        task kids[2];
        make_interior(&top[cur.node], &cur, split_at, side, top, &b.top_count, kids);
        kids[0].in_other = kids[1].in_other = in_other;
        stack[sp++] = kids[1];
        stack[sp++] = kids[0];
    }
    free(scratch.bins), free(scratch.left), free(scratch.right), free(scratch.side);
    uint64_t t1 = pn_time_ns();
    qsort(tasks, ntasks, sizeof *tasks, by_size);
    par_ctx p = {&b, tasks, task_count, task_at};
    pn_parallel_for(ntasks, 1, build_tasks, &p);
    free(other), free(other_id);
    free(prims);
    uint64_t t2 = pn_time_ns();
    out->nodes = assemble(&p, ntasks, &out->node_count);
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

pn_result pn_triangle_pool(const pn_scene *s, float **out, uint64_t *bytes)
{
    uint32_t n = pn_scene_triangle_count(s);
    // The masks of alpha-masked triangles follow the triangles (accel/alpha.h); none: nothing.
    *bytes = ((uint64_t)(n ? n : 1) * 3 + pn_alpha_pool_vec4s(s)) * 4 * sizeof(float);
    *out = calloc(1, *bytes);
    if (!*out)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < n; i++)
        for (int j = 0; j < 3; j++)
            memcpy(*out + 12 * i + 4 * j, s->vertices[s->indices[3 * i + j]].pos, 3 * sizeof(float));
    pn_result r = pn_alpha_masked_triangles(s) ? pn_alpha_pool_fill(s, *out) : PN_OK;
    if (r != PN_OK) {
        free(*out);
        *out = NULL;
    }
    return r;
}
