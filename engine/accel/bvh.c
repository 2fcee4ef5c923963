#include "accel/bvh.h"

#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "core/parallel.h"
#include "core/timer.h"

enum {
    BINS = 16,       // SAH bins per axis
    LEAF_MAX = 4,    // triangles per leaf at most, unless they cannot be split
    MAX_DEPTH = PN_BVH_STACK - 4, // the GPU walk's stack holds PN_BVH_STACK entries
    PARALLEL_MIN = 16384, // subtrees larger than this are built as separate tasks
};

typedef struct aabb {
    float lo[3], hi[3];
} aabb;

// Plain comparisons rather than fminf/fmaxf, which are library calls here: a NaN coordinate is
// still never taken (the comparison is false), as with fminf.
static inline float min1(float a, float b) { return a < b ? a : b; }
static inline float max1(float a, float b) { return a > b ? a : b; }

static void aabb_empty(aabb *b)
{
    for (int k = 0; k < 3; k++)
        b->lo[k] = FLT_MAX, b->hi[k] = -FLT_MAX;
}

static inline void aabb_grow(aabb *b, const aabb *o)
{
    for (int k = 0; k < 3; k++) {
        b->lo[k] = min1(o->lo[k], b->lo[k]);
        b->hi[k] = max1(o->hi[k], b->hi[k]);
    }
}

static inline void aabb_grow_point(aabb *b, const float p[3])
{
    for (int k = 0; k < 3; k++) {
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

// A primitive as the build sees it: its box with its id, moved together by the partitions, so that
// binning and partitioning read one array front to back instead of boxes through an index.
typedef struct prim {
    aabb box;
    uint32_t id, pad; // 32 bytes
} prim;

static inline void prim_centroid(const prim *p, float c[3])
{
    for (int k = 0; k < 3; k++)
        c[k] = 0.5f * (p->box.lo[k] + p->box.hi[k]);
}

// Build state. Nodes are allocated from a shared counter; subtrees may be built by other threads.
typedef struct builder {
    prim *prims; // permuted in place
    pn_bvh_node *nodes;
    atomic_uint node_count;
    uint32_t capacity;
    atomic_uint depth;
} builder;

// A node to build over prims [begin, end), with the bounds of their boxes and of their centroids
// (the parent's partition computes both, so no node reads its primitives just for its bounds).
typedef struct task {
    uint32_t node, begin, end, depth;
    aabb box, cbox;
} task;

static uint32_t alloc_nodes(builder *b, uint32_t n) { return atomic_fetch_add(&b->node_count, n); }

static void range_bounds(const prim *p, uint32_t begin, uint32_t end, aabb *box, aabb *cbox)
{
    aabb_empty(box);
    aabb_empty(cbox);
    for (uint32_t i = begin; i < end; i++) {
        float c[3];
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

static void bins_fill(const prim *p, uint32_t begin, uint32_t end, const aabb *cbox, bins *out)
{
    float lo[3], scale[3];
    for (int k = 0; k < 3; k++) {
        float ext = cbox->hi[k] - cbox->lo[k];
        lo[k] = cbox->lo[k];
        scale[k] = ext > 0 ? BINS / ext : 0.0f; // a flat axis fills bin 0 and is not swept
        for (int i = 0; i < BINS; i++) {
            aabb_empty(&out->box[k][i]);
            out->count[k][i] = 0;
        }
    }
    for (uint32_t i = begin; i < end; i++) {
        float c[3];
        prim_centroid(&p[i], c);
        for (int k = 0; k < 3; k++) {
            int bin = bin_of(c[k], lo[k], scale[k]);
            out->count[k][bin]++;
            aabb_grow(&out->box[k][bin], &p[i].box);
        }
    }
}

// Splits task t by binned SAH over centroids; returns the split index, or t->begin when a leaf is
// cheaper (or nothing separates the centroids). On a split, the two sides' bounds are set.
static uint32_t sah_split(builder *b, const task *t, aabb *lbox, aabb *lcbox, aabb *rbox, aabb *rcbox)
{
    uint32_t begin = t->begin, end = t->end, n = end - begin;
    const aabb *box = &t->box, *cbox = &t->cbox;
    float area = aabb_area(box), best_cost = (float)n * area; // the leaf's cost
    int best_axis = -1, best_bin = 0;
    bins bn;
    bins_fill(b->prims, begin, end, cbox, &bn);
    for (int k = 0; k < 3; k++) {
        if (!(cbox->hi[k] - cbox->lo[k] > 0))
            continue;
        // Sweep: cost of splitting after bin i = N_left * A_left + N_right * A_right. Only splits
        // after non-empty bins are weighed: one after an empty bin has the same sides as one after
        // the non-empty bin before it, and small nodes, the most of them, fill few of the bins.
        int used[BINS], m = 0;
        for (int i = 0; i < BINS; i++)
            if (bn.count[k][i])
                used[m++] = i;
        float right_area[BINS];
        uint32_t right_count[BINS];
        aabb acc;
        aabb_empty(&acc);
        uint32_t c = 0;
        for (int j = m - 1; j > 0; j--) {
            aabb_grow(&acc, &bn.box[k][used[j]]);
            c += bn.count[k][used[j]];
            right_area[j] = aabb_area(&acc);
            right_count[j] = c;
        }
        aabb_empty(&acc);
        c = 0;
        for (int j = 0; j < m - 1; j++) {
            aabb_grow(&acc, &bn.box[k][used[j]]);
            c += bn.count[k][used[j]];
            // The traversal step costs about one triangle test: both are a few dozen flops.
            float cost = area + (float)c * aabb_area(&acc) + (float)right_count[j + 1] * right_area[j + 1];
            if (cost < best_cost) {
                best_cost = cost;
                best_axis = k;
                best_bin = used[j];
            }
        }
    }
    if (best_axis < 0) {
        if (n <= LEAF_MAX)
            return begin;
        // No good SAH split of a big set: split at the median of the widest centroid axis.
        int k = 0;
        for (int a = 1; a < 3; a++)
            if (cbox->hi[a] - cbox->lo[a] > cbox->hi[k] - cbox->lo[k])
                k = a;
        if (!(cbox->hi[k] > cbox->lo[k])) { // identical centroids: any split
            uint32_t mid = begin + n / 2;
            range_bounds(b->prims, begin, mid, lbox, lcbox);
            range_bounds(b->prims, mid, end, rbox, rcbox);
            return mid;
        }
        best_axis = k;
        best_bin = BINS / 2 - 1;
    }
    // Partition, growing each side's bounds with what goes to it.
    float lo = cbox->lo[best_axis], scale = BINS / (cbox->hi[best_axis] - lo);
    aabb_empty(lbox), aabb_empty(lcbox), aabb_empty(rbox), aabb_empty(rcbox);
    prim *p = b->prims;
    uint32_t i = begin, j = end;
    while (i < j) {
        prim q = p[i];
        float c[3];
        prim_centroid(&q, c);
        if (bin_of(c[best_axis], lo, scale) <= best_bin) {
            aabb_grow(lbox, &q.box);
            aabb_grow_point(lcbox, c);
            i++;
        } else {
            aabb_grow(rbox, &q.box);
            aabb_grow_point(rcbox, c);
            p[i] = p[--j];
            p[j] = q;
        }
    }
    if (i == begin || i == end) { // all on one side: a leaf, or halves when it is too big
        if (n <= LEAF_MAX)
            return begin;
        uint32_t mid = begin + n / 2;
        range_bounds(p, begin, mid, lbox, lcbox);
        range_bounds(p, mid, end, rbox, rcbox);
        return mid;
    }
    return i;
}

// Builds the subtree of task t; pushes subtrees bigger than PARALLEL_MIN to `spill` when given.
static void build_subtree(builder *b, task t, task *spill, uint32_t *spill_count, uint32_t spill_cap)
{
    task stack[2 * MAX_DEPTH + 8];
    int sp = 0;
    stack[sp++] = t;
    while (sp > 0) {
        task cur = stack[--sp];
        pn_bvh_node *node = &b->nodes[cur.node];
        memcpy(node->min, cur.box.lo, sizeof node->min);
        memcpy(node->max, cur.box.hi, sizeof node->max);
        uint32_t n = cur.end - cur.begin;
        task kids[2];
        uint32_t split = cur.depth + 1 >= MAX_DEPTH
                             ? cur.begin
                             : sah_split(b, &cur, &kids[0].box, &kids[0].cbox, &kids[1].box, &kids[1].cbox);
        if (split == cur.begin) { // leaf (also when the depth limit is reached)
            node->first = cur.begin;
            node->count = n;
            uint32_t d = cur.depth + 1, old = atomic_load(&b->depth);
            while (d > old && !atomic_compare_exchange_weak(&b->depth, &old, d))
                ;
            continue;
        }
        uint32_t child = alloc_nodes(b, 2);
        node->first = child;
        node->count = 0;
        kids[0].node = child, kids[0].begin = cur.begin, kids[0].end = split, kids[0].depth = cur.depth + 1;
        kids[1].node = child + 1, kids[1].begin = split, kids[1].end = cur.end, kids[1].depth = cur.depth + 1;
        // Top phase (spill given): the children become tasks for the parallel phase.
        for (int i = 0; i < 2; i++) {
            if (spill && *spill_count < spill_cap)
                spill[(*spill_count)++] = kids[i];
            else
                stack[sp++] = kids[i];
        }
        if (spill && sp == 0)
            return;
    }
}

// Renumbers the nodes depth-first, left child first, each interior node's two children placed
// together when it is visited. The build allocates node pairs from a shared counter in whatever
// order the threads reach them, and how many levels the top phase splits before the parallel one
// depends on the thread count: the node array would differ from run to run and with PN_THREADS
// (issue 30), though the tree is the same. This pass fixes the order by the tree alone.
static pn_result renumber(pn_bvh *out)
{
    if (out->node_count < 3) // the root alone (a leaf; count 0 with no triangles at all)
        return PN_OK;
    pn_bvh_node *dst = malloc((size_t)(out->node_count ? out->node_count : 1) * sizeof *dst);
    if (!dst)
        return PN_ERR_MEMORY;
    // (source, destination) of nodes placed but whose children are not: at most one pending right
    // sibling per level, and leaves are never deeper than MAX_DEPTH.
    uint32_t stack[MAX_DEPTH + 8][2];
    int sp = 0;
    uint32_t next = 1;
    dst[0] = out->nodes[0];
    stack[sp][0] = 0, stack[sp][1] = 0, sp++;
    while (sp > 0) {
        sp--;
        uint32_t s = stack[sp][0], d = stack[sp][1];
        if (out->nodes[s].count > 0)
            continue;
        uint32_t c = next, sc = out->nodes[s].first;
        next += 2;
        dst[c] = out->nodes[sc];
        dst[c + 1] = out->nodes[sc + 1];
        dst[d].first = c;
        stack[sp][0] = sc + 1, stack[sp][1] = c + 1, sp++; // right below left: left is visited first
        stack[sp][0] = sc, stack[sp][1] = c, sp++;
    }
    free(out->nodes);
    out->nodes = dst;
    return PN_OK;
}

typedef struct par_ctx {
    builder *b;
    const task *tasks;
} par_ctx;

static void build_tasks(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    par_ctx *p = ctx;
    for (uint64_t i = begin; i < end; i++)
        build_subtree(p->b, p->tasks[i], NULL, NULL, 0);
}

// Builds over n primitives; takes ownership of prims (freed here), whose ids are 0 .. n-1.
static pn_result build(prim *prims, uint32_t n, pn_bvh *out)
{
    uint64_t t0 = pn_time_ns();
    out->tri_index = malloc((size_t)(n ? n : 1) * sizeof *out->tri_index);
    // A binary tree with leaves of at least one triangle has fewer than 2n nodes.
    uint32_t capacity = 2 * (n ? n : 1);
    out->nodes = malloc((size_t)capacity * sizeof *out->nodes);
    // Top levels one at a time on this thread until there are enough independent subtrees, then
    // the subtrees on all threads.
    enum { TASKS = 4096 };
    task *tasks = malloc(2 * TASKS * sizeof *tasks);
    if (!prims || !out->tri_index || !out->nodes || !tasks) {
        free(prims), free(tasks);
        pn_bvh_destroy(out);
        return PN_ERR_MEMORY;
    }
    builder b = {.prims = prims, .nodes = out->nodes, .capacity = capacity};
    atomic_init(&b.node_count, 1);
    atomic_init(&b.depth, 0);
    task *cur = tasks, *next = tasks + TASKS;
    uint32_t ncur = 1, nnext;
    cur[0] = (task){0, 0, n, 0};
    range_bounds(prims, 0, n, &cur[0].box, &cur[0].cbox);
    unsigned threads = pn_parallel_threads();
    while (ncur < 8 * threads && ncur < TASKS / 2) {
        nnext = 0;
        bool split_any = false;
        for (uint32_t i = 0; i < ncur; i++) {
            uint32_t before = nnext;
            if (cur[i].end - cur[i].begin > PARALLEL_MIN) {
                build_subtree(&b, cur[i], next, &nnext, TASKS);
                split_any = split_any || nnext != before;
            } else {
                next[nnext++] = cur[i];
            }
        }
        task *t = cur;
        cur = next;
        next = t;
        ncur = nnext;
        if (!split_any)
            break;
    }
    uint64_t t1 = pn_time_ns();
    par_ctx p = {&b, cur};
    pn_parallel_for(ncur, 1, build_tasks, &p);
    uint64_t t2 = pn_time_ns();
    free(tasks);
    for (uint32_t i = 0; i < n; i++)
        out->tri_index[i] = prims[i].id;
    free(prims);
    out->node_count = atomic_load(&b.node_count);
    out->triangles = n;
    out->depth = atomic_load(&b.depth);
    if (renumber(out) != PN_OK) {
        pn_bvh_destroy(out);
        return PN_ERR_MEMORY;
    }
    pn_debug("bvh: %u primitives: boxes %.1f ms, top levels %.1f ms (%u tasks), subtrees %.1f ms, renumber %.1f ms",
             n, out->build_ms, (double)(t1 - t0) * 1e-6, ncur, (double)(t2 - t1) * 1e-6, pn_ms_since(t2));
    out->build_ms += pn_ms_since(t0);
    return PN_OK;
}

pn_result pn_bvh_build(const pn_scene *s, pn_bvh *out)
{
    memset(out, 0, sizeof *out);
    uint64_t t0 = pn_time_ns();
    uint32_t n = pn_scene_triangle_count(s);
    prim *prims = malloc((size_t)(n ? n : 1) * sizeof *prims);
    for (uint32_t i = 0; prims && i < n; i++) {
        aabb_empty(&prims[i].box);
        for (int j = 0; j < 3; j++)
            aabb_grow_point(&prims[i].box, s->vertices[s->indices[3 * i + j]].pos);
        prims[i].id = i, prims[i].pad = 0;
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
        prims[i].id = i, prims[i].pad = 0;
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
    *bytes = (uint64_t)(n ? n : 1) * 12 * sizeof(float);
    *out = calloc(1, *bytes);
    if (!*out)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < n; i++)
        for (int j = 0; j < 3; j++)
            memcpy(*out + 12 * i + 4 * j, s->vertices[s->indices[3 * i + j]].pos, 3 * sizeof(float));
    return PN_OK;
}
