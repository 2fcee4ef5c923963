// How a BVH node is split: binned SAH over its centroids (bins filled on one thread, or per block on
// all threads and merged in block order), then a partition: in place on one thread, or a stable one
// into the other array on all threads for the wide nodes of the top (bvh.c).
#include <string.h>

#include "accel/bvh_internal.h"
#include "core/parallel.h"

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
uint32_t pn_bvh_split_node(prim *p, uint32_t *id, const task *t, aabb side[4])
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
uint32_t pn_bvh_split_wide(const builder *b, const task *t, wide *scratch, aabb side[4], bool *moved)
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
