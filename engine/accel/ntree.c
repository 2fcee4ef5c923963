// The N-tree build: the occupancy level by level (parallel chunks of triangle lists), candidate
// lists, leaf planes and line spaces. The triangle tests it uses (overlap with a cell, whether a
// triangle can block) are in ntree_tri.c. Over 500 lines because build_occupancy (160 lines) and
// its chunk and gather workers share the file-local level_node and chunk types.
#include "accel/ntree.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "accel/leaf_plane.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/timer.h"

pn_pool_bytes pn_ntree_pool_bytes(int n, uint64_t s)
{
    pn_pool_bytes b = {0};
    b.tree = s * (uint64_t)(n * n * n) * sizeof(uint32_t);
    b.node = s * 32; // pn_gpu_node, accel/pools.h
    b.linespace = s * pn_ls_words64(n) * sizeof(uint64_t);
    b.total = b.tree + b.node + b.linespace;
    return b;
}

double pn_ntree_cell_size(const pn_ntree *t, int level) { return t->root_size / pow((double)t->n, level); }

void pn_ntree_cell_box(const pn_ntree *t, int level, const uint64_t coord[3], double lo[3], double hi[3])
{
    double cs = pn_ntree_cell_size(t, level);
    for (int k = 0; k < 3; k++) {
        lo[k] = t->root_min[k] + (double)coord[k] * cs - t->slack;
        hi[k] = t->root_min[k] + (double)(coord[k] + 1) * cs + t->slack;
    }
}

// ---------------------------------------------------------------------------------------------
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

static bool push_pair(chunk *ch, uint32_t child, uint32_t tri)
{
    if (ch->pair_count == ch->pair_cap) {
        uint32_t cap = ch->pair_cap ? ch->pair_cap * 2 : 4096;
        uint64_t *p = realloc(ch->pairs, cap * sizeof *p);
        if (!p)
            return false;
        ch->pairs = p;
        ch->pair_cap = cap;
    }
    ch->pairs[ch->pair_count++] = (uint64_t)child << 32 | tri;
    return true;
}

static void split_chunks(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    build_ctx *b = ctx;
    pn_ntree *t = b->t;
    int n = t->n;
    double cs = pn_ntree_cell_size(t, b->level + 1);
    for (uint64_t ci = begin; ci < end; ci++) {
        chunk *ch = &b->chunks[ci];
        const level_node *ln = &b->lnodes[ch->lnode];
        const pn_ntree_node *node = &t->nodes[ln->node];
        uint64_t base[3];
        double origin[3];
        for (int k = 0; k < 3; k++) {
            base[k] = (uint64_t)node->coord[k] * (uint64_t)n;
            origin[k] = t->root_min[k] + (double)base[k] * cs;
        }
        for (uint32_t i = ch->begin; i < ch->end && !ch->failed; i++) {
            uint32_t tri = ln->tris[i];
            const float *bb = b->box[tri];
            int r0[3], r1[3];
            bool single = true;
            for (int k = 0; k < 3; k++) {
                // Candidate children from the bounds, widened by the slack; the SAT decides.
                double a = ceil(((double)bb[k] - t->slack - origin[k]) / cs) - 1;
                double z = floor(((double)bb[3 + k] + t->slack - origin[k]) / cs);
                single = single && a == z && a >= 0 && a < n;
                r0[k] = a < 0 ? 0 : a > n - 1 ? n - 1 : (int)a;
                r1[k] = z < 0 ? 0 : z > n - 1 ? n - 1 : (int)z;
            }
            if (single) { // bounds (grown by the slack) inside one child: it overlaps that child
                if (!push_pair(ch, (uint32_t)((r0[2] * n + r0[1]) * n + r0[0]), tri))
                    ch->failed = true;
                continue;
            }
            double v[3][3];
            for (int j = 0; j < 3; j++)
                for (int k = 0; k < 3; k++)
                    v[j][k] = b->tri[tri][3 * j + k];
            for (int z = r0[2]; z <= r1[2]; z++)
                for (int y = r0[1]; y <= r1[1]; y++)
                    for (int x = r0[0]; x <= r1[0]; x++) {
                        uint64_t cc[3] = {base[0] + (uint64_t)x, base[1] + (uint64_t)y, base[2] + (uint64_t)z};
                        double lo[3], hi[3];
                        pn_ntree_cell_box(t, b->level + 1, cc, lo, hi);
                        if (pn_tri_box_overlap((const double(*)[3])v, lo, hi) &&
                            !push_pair(ch, (uint32_t)((z * n + y) * n + x), tri))
                            ch->failed = true;
                    }
        }
        if (ch->failed)
            atomic_store(&b->failed, true);
    }
}

typedef struct node_chunks {
    uint32_t first, count; // range in the chunk array
} node_chunks;

typedef struct gather_ctx {
    build_ctx *b;
    const node_chunks *nc;
} gather_ctx;

static void gather_nodes(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    gather_ctx *g = ctx;
    build_ctx *b = g->b;
    pn_ntree *t = b->t;
    uint32_t n3 = (uint32_t)(t->n * t->n * t->n);
    for (uint64_t li = begin; li < end; li++) {
        const node_chunks *nc = &g->nc[li];
        uint32_t node = b->lnodes[li].node;
        uint32_t *entries = t->children + (size_t)node * n3;
        // Count per child (entries double as counters until the level is numbered).
        uint64_t total = 0;
        for (uint32_t c = nc->first; c < nc->first + nc->count; c++)
            for (uint32_t i = 0; i < b->chunks[c].pair_count; i++) {
                entries[b->chunks[c].pairs[i] >> 32]++;
                total++;
            }
        if (!b->need_lists)
            continue;
        uint32_t *list = malloc((n3 + 1 + total) * sizeof *list);
        if (!list) {
            atomic_store(&b->failed, true);
            continue;
        }
        uint32_t *offset = list, *ids = list + n3 + 1;
        offset[0] = 0;
        for (uint32_t c = 0; c < n3; c++)
            offset[c + 1] = offset[c] + entries[c];
        uint32_t *fill = calloc(n3, sizeof *fill);
        if (!fill) {
            free(list);
            atomic_store(&b->failed, true);
            continue;
        }
        for (uint32_t c = nc->first; c < nc->first + nc->count; c++)
            for (uint32_t i = 0; i < b->chunks[c].pair_count; i++) {
                uint64_t p = b->chunks[c].pairs[i];
                uint32_t child = (uint32_t)(p >> 32);
                ids[offset[child] + fill[child]++] = (uint32_t)p;
            }
        free(fill);
        b->child_lists[li] = list;
    }
}

// True if pools of `subdivided` nodes (and plane_bytes of leaf planes) fit the limits of desc; else
// logs why not.
static bool fits(const pn_ntree_desc *desc, uint64_t subdivided, uint64_t plane_bytes, bool partial)
{
    pn_pool_bytes pb = pn_ntree_pool_bytes(desc->n, subdivided);
    pb.total += plane_bytes;
    uint64_t largest = pb.linespace > pb.tree ? pb.linespace : pb.tree;
    largest = plane_bytes > largest ? plane_bytes : largest;
    largest = pb.node > largest ? pb.node : largest;
    bool total_ok = !desc->max_bytes || pb.total <= desc->max_bytes;
    bool pool_ok = !desc->max_pool_bytes || largest <= desc->max_pool_bytes;
    if (total_ok && pool_ok)
        return true;
    char hint[128];
    if (desc->d > 1)
        snprintf(hint, sizeof hint, "--tree %d,%d or --tree %d,%d", desc->n > 2 ? desc->n - 1 : 2, desc->d,
                 desc->n, desc->d - 1);
    else
        snprintf(hint, sizeof hint, "--tree %d,%d", desc->n > 2 ? desc->n - 1 : 2, desc->d);
    if (!total_ok)
        pn_error("LS(%d,%d) needs %s%.1f MiB of pools (%llu subdivided nodes x %.1f KiB of line space), over the "
                 "limit of %.1f MiB (--max-memory); try a smaller N or d, e.g. %s",
                 desc->n, desc->d, partial ? "at least " : "", (double)pb.total / 1048576.0,
                 (unsigned long long)subdivided, (double)pn_ls_words64(desc->n) * 8 / 1024.0,
                 (double)desc->max_bytes / 1048576.0, hint);
    else
        pn_error("LS(%d,%d) needs a pool of %s%.1f MiB (%llu subdivided nodes x %.1f KiB of line space), more than "
                 "one buffer of this device can hold (%.1f MiB); try a smaller N or d, e.g. %s",
                 desc->n, desc->d, partial ? "at least " : "", (double)largest / 1048576.0,
                 (unsigned long long)subdivided, (double)pn_ls_words64(desc->n) * 8 / 1024.0,
                 (double)desc->max_pool_bytes / 1048576.0, hint);
    return false;
}

// Copies the triangles into flat arrays (vertices, bounds) for the build's inner loops.
static pn_result gather_triangles(const pn_scene *s, float (**tri)[9], float (**box)[6])
{
    uint32_t n = pn_scene_triangle_count(s);
    *tri = malloc((size_t)n * sizeof **tri);
    *box = malloc((size_t)n * sizeof **box);
    if (!*tri || !*box)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < n; i++) {
        float *v = (*tri)[i], *b = (*box)[i];
        for (int j = 0; j < 3; j++)
            memcpy(v + 3 * j, s->vertices[s->indices[3 * i + j]].pos, 3 * sizeof(float));
        for (int k = 0; k < 3; k++) {
            b[k] = fminf(v[k], fminf(v[3 + k], v[6 + k]));
            b[3 + k] = fmaxf(v[k], fmaxf(v[3 + k], v[6 + k]));
        }
    }
    return PN_OK;
}

static void root_box(const float lo[3], const float hi[3], pn_ntree *t)
{
    float mag = 0, ext = 0;
    for (int k = 0; k < 3; k++) {
        mag = fmaxf(mag, fmaxf(fabsf(lo[k]), fabsf(hi[k])));
        ext = fmaxf(ext, hi[k] - lo[k]);
    }
    // Positions are floats, and the GPU computes cell boundaries in float: near magnitude `mag`
    // both are only known to one float ulp there. Four ulps of padding keep every triangle strictly
    // inside the root, and four ulps of slack on every cell make the occupancy conservative against
    // that rounding: a triangle within rounding distance of a cell counts as touching it.
    double ulp = (double)nextafterf(mag, INFINITY) - (double)mag;
    t->slack = 4 * ulp;
    t->root_size = (double)ext + 2 * t->slack;
    for (int k = 0; k < 3; k++)
        t->root_min[k] = 0.5 * ((double)lo[k] + (double)hi[k]) - 0.5 * t->root_size;
}

static pn_result grow_nodes(pn_ntree *t, uint32_t needed, uint32_t *cap)
{
    if (needed <= *cap)
        return PN_OK;
    uint32_t nc = *cap ? *cap : 64;
    while (nc < needed)
        nc = nc > UINT32_MAX / 2 ? UINT32_MAX - 2 : nc * 2;
    size_t n3 = (size_t)(t->n * t->n * t->n);
    pn_ntree_node *nodes = realloc(t->nodes, nc * sizeof *nodes);
    if (!nodes)
        return PN_ERR_MEMORY;
    t->nodes = nodes;
    uint32_t *ch = realloc(t->children, nc * n3 * sizeof *ch);
    if (!ch)
        return PN_ERR_MEMORY;
    memset(ch + (size_t)*cap * n3, 0, (nc - *cap) * n3 * sizeof *ch);
    t->children = ch;
    *cap = nc;
    return PN_OK;
}

static void free_lists(uint32_t **lists, uint32_t count)
{
    for (uint32_t i = 0; lists && i < count; i++)
        free(lists[i]);
    free(lists);
}

// Does leaf c's list (of a last-level node's per-child lists) hold an alpha-masked triangle?
static bool leaf_masked(const uint32_t *list, uint64_t n3, uint64_t c, const uint8_t *masked)
{
    const uint32_t *off = list, *ids = list + n3 + 1;
    bool any = false;
    for (uint32_t k = off[c]; masked && k < off[c + 1] && !any; k++)
        any = masked[ids[k]] != 0;
    return any;
}

// The triangle lists of the leaves of the last-level nodes (this level's nodes, whose per-child
// lists the gather has just built), in node and child order: every leaf's (keep_candidates), or
// only those of the leaves holding an alpha-masked triangle (desc.masked), whose bits it sets.
static pn_result keep_candidates(pn_ntree *t, const pn_ntree_desc *desc, uint32_t lcount, uint32_t **lists)
{
    uint64_t n3 = (uint64_t)t->n * t->n * t->n, entries = (uint64_t)lcount * n3 + 1, total = 0;
    bool all = desc->keep_candidates;
    uint64_t bits = (uint64_t)lcount * (n3 + 1);
    if (desc->masked) {
        t->alpha_words = (uint32_t)((bits + 31) / 32);
        if (bits > UINT32_MAX || !(t->alpha_bits = calloc(t->alpha_words ? t->alpha_words : 1, sizeof *t->alpha_bits)))
            return PN_ERR_MEMORY;
    }
    for (uint32_t i = 0; i < lcount; i++)
        for (uint64_t c = 0; c < n3; c++) {
            bool m = leaf_masked(lists[i], n3, c, desc->masked);
            if (m) {
                uint64_t node_bit = i * (n3 + 1), leaf_bit = node_bit + 1 + c;
                t->alpha_bits[node_bit / 32] |= 1u << (node_bit % 32);
                t->alpha_bits[leaf_bit / 32] |= 1u << (leaf_bit % 32);
                t->masked_leaves++;
            }
            total += all || m ? lists[i][c + 1] - lists[i][c] : 0;
        }
    if (total > UINT32_MAX || entries > UINT32_MAX)
        return PN_ERR_MEMORY;
    t->cand_offsets = (uint32_t)entries;
    t->cand_offset = malloc(entries * sizeof *t->cand_offset);
    t->cand_tris = malloc((size_t)(total ? total : 1) * sizeof *t->cand_tris);
    if (!t->cand_offset || !t->cand_tris)
        return PN_ERR_MEMORY;
    uint32_t at = 0;
    for (uint32_t i = 0; i < lcount; i++) {
        // Nodes of one level are numbered consecutively, in the order of lnodes.
        const uint32_t *off = lists[i], *ids = lists[i] + n3 + 1;
        for (uint64_t c = 0; c < n3; c++) {
            t->cand_offset[i * n3 + c] = at;
            if (all || leaf_masked(lists[i], n3, c, desc->masked)) {
                memcpy(t->cand_tris + at, ids + off[c], (off[c + 1] - off[c]) * sizeof(uint32_t));
                at += off[c + 1] - off[c];
            }
        }
    }
    t->cand_offset[entries - 1] = at;
    t->cand_count = total;
    return PN_OK;
}

// ---------------------------------------------------------------------------------------------
// Leaf planes (ls-plane, accel/leaf_plane.h): one word per leaf of the last-level nodes.

typedef struct plane_ctx {
    pn_ntree *t;
    const float (*tri)[9];
    const level_node *lnodes;
    uint32_t **lists; // per last-level node: n^3 + 1 offsets, then the triangle ids
} plane_ctx;

static void plane_nodes(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    (void)thread;
    plane_ctx *a = ctx;
    pn_ntree *t = a->t;
    uint32_t n = (uint32_t)t->n, n3 = n * n * n;
    double cs = pn_ntree_cell_size(t, t->d);
    for (uint64_t i = begin; i < end; i++) {
        const pn_ntree_node *node = &t->nodes[a->lnodes[i].node];
        const uint32_t *off = a->lists[i], *ids = a->lists[i] + n3 + 1;
        for (uint32_t c = 0; c < n3; c++) {
            uint32_t xyz[3] = {c % n, c / n % n, c / (n * n)};
            double lo[3];
            for (int k = 0; k < 3; k++)
                lo[k] = t->root_min[k] + (double)(node->coord[k] * n + xyz[k]) * cs;
            // Clipped to the box the occupancy test used (grown by the slack), so that a triangle
            // that filled the leaf within the slack counts.
            t->planes[i * n3 + c] = pn_leaf_plane_fit(a->tri, ids + off[c], off[c + 1] - off[c], lo, cs, t->slack);
        }
    }
}

// The planes of the leaves of the last-level nodes (this level's nodes, whose per-child lists the
// gather has just built), in node and child order.
static pn_result build_planes(pn_ntree *t, const float (*tri)[9], const level_node *lnodes, uint32_t lcount,
                              uint32_t **lists)
{
    uint64_t n3 = (uint64_t)t->n * t->n * t->n;
    t->plane_count = (uint64_t)lcount * n3;
    if (!(t->planes = calloc(t->plane_count ? t->plane_count : 1, sizeof *t->planes)))
        return PN_ERR_MEMORY;
    plane_ctx a = {t, tri, lnodes, lists};
    pn_parallel_for(lcount, 4, plane_nodes, &a);
    return PN_OK;
}

static pn_result build_occupancy(const pn_scene *s, const pn_ntree_desc *desc, pn_ntree *t)
{
    float(*tri)[9] = NULL, (*box)[6] = NULL;
    pn_result r = gather_triangles(s, &tri, &box);
    uint32_t cap = 0, n3 = (uint32_t)(t->n * t->n * t->n);
    uint32_t *all = NULL;
    level_node *lnodes = NULL;
    uint32_t **parent_lists = NULL, parent_count = 0, lcount = 1;
    if (r == PN_OK)
        r = grow_nodes(t, 1, &cap);
    uint32_t total = pn_scene_triangle_count(s);
    if (r == PN_OK && !(all = malloc((size_t)(total ? total : 1) * sizeof *all)))
        r = PN_ERR_MEMORY;
    if (r == PN_OK && !(lnodes = malloc(sizeof *lnodes)))
        r = PN_ERR_MEMORY;
    if (r == PN_OK) {
        // The triangles that can block a shadow ray, and the root box around them.
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        t->triangles = 0;
        for (uint32_t i = 0; i < total; i++) {
            if (desc->cull_light && !pn_ntree_can_block(tri[i], s->bounds_min, s->bounds_max, desc->cull_light,
                                                        desc->cull_light_corners ? desc->cull_light_corners : 4))
                continue;
            const float *kb = desc->keep_box;
            if (kb && (box[i][0] > kb[3] || box[i][1] > kb[4] || box[i][2] > kb[5] || box[i][3] < kb[0] ||
                       box[i][4] < kb[1] || box[i][5] < kb[2])) {
                t->culled_box++;
                continue;
            }
            all[t->triangles++] = i;
            for (int k = 0; k < 3; k++) {
                lo[k] = fminf(lo[k], box[i][k]);
                hi[k] = fmaxf(hi[k], box[i][3 + k]);
            }
        }
        t->culled = total - t->triangles;
        if (t->triangles == 0) // nothing can cast a shadow: an empty tree over the scene
            for (int k = 0; k < 3; k++)
                lo[k] = s->bounds_min[k], hi[k] = s->bounds_max[k];
        root_box(lo, hi, t);
        // The leaves must be resolved by float positions: the GPU walks the tree in float, and a
        // leaf a few ulps wide (a small scene far from the origin, or a deep tree) cannot be told
        // from its neighbours. 16 ulps per leaf keeps the traversal's rounding allowance (4 ulps,
        // see linespace_trace.glsl) a quarter of a leaf.
        // (Geometry without extent, a point, gets a root of padding only: nothing to resolve.)
        float mag = 0, ext = 0;
        for (int k = 0; k < 3; k++) {
            mag = fmaxf(mag, fmaxf(fabsf(lo[k]), fabsf(hi[k])));
            ext = fmaxf(ext, hi[k] - lo[k]);
        }
        double ulp = (double)nextafterf(mag, INFINITY) - (double)mag;
        double leaf = t->root_size / pow(t->n, t->d);
        if (t->triangles && ext > 0 && leaf < 16 * ulp) {
            pn_error("%s: LS(%d,%d) leaves would be %.3g wide, only %.1f float steps at %.3g from the origin; use a "
                     "smaller N or d, or move the scene towards the origin",
                     s->name, t->n, t->d, leaf, leaf / ulp, (double)mag);
            r = PN_ERR_UNSUPPORTED;
        }
        t->nodes[0] = (pn_ntree_node){0, {0, 0, 0}};
        t->node_count = 1;
        t->filled_per_level[0] = 1;
        lnodes[0] = (level_node){all, t->triangles, 0};
    }
    for (int level = 0; r == PN_OK && level < t->d; level++) {
        // Chunks of every node's list.
        uint64_t nchunks = 0;
        for (uint32_t i = 0; i < lcount; i++)
            nchunks += (lnodes[i].count + CHUNK - 1) / CHUNK;
        chunk *chunks = calloc(nchunks ? nchunks : 1, sizeof *chunks);
        node_chunks *nc = calloc(lcount, sizeof *nc);
        uint32_t **lists = calloc(lcount, sizeof *lists);
        if (!chunks || !nc || !lists) {
            free(chunks), free(nc), free(lists);
            r = PN_ERR_MEMORY;
            break;
        }
        uint64_t c = 0;
        for (uint32_t i = 0; i < lcount; i++) {
            nc[i].first = (uint32_t)c;
            for (uint32_t b = 0; b < lnodes[i].count; b += CHUNK) {
                chunks[c++] = (chunk){.lnode = i, .begin = b, .end = b + CHUNK < lnodes[i].count ? b + CHUNK : lnodes[i].count};
                nc[i].count++;
            }
        }
        build_ctx b = {.t = t, .tri = (const float(*)[9])tri, .box = (const float(*)[6])box, .lnodes = lnodes,
                       .chunks = chunks, .level = level,
                       .need_lists = level + 1 < t->d || desc->keep_candidates || desc->masked || desc->leaf_planes, .child_lists = lists};
        atomic_init(&b.failed, false);
        pn_parallel_for(nchunks, 1, split_chunks, &b);
        gather_ctx g = {&b, nc};
        pn_parallel_for(lcount, 1, gather_nodes, &g);
        for (uint64_t i = 0; i < nchunks; i++)
            free(chunks[i].pairs);
        free(chunks);
        free(nc);
        if (atomic_load(&b.failed)) {
            free_lists(lists, lcount);
            r = PN_ERR_MEMORY;
            break;
        }
        if ((desc->keep_candidates || desc->masked) && level + 1 == t->d && (r = keep_candidates(t, desc, lcount, lists)) != PN_OK) {
            free_lists(lists, lcount);
            break;
        }
        if (desc->leaf_planes && level + 1 == t->d &&
            (r = build_planes(t, (const float(*)[9])tri, lnodes, lcount, lists)) != PN_OK) {
            free_lists(lists, lcount);
            break;
        }
        if (level + 1 == t->d)
            t->cand_first_node = lcount ? lnodes[0].node : 0;
        // Number the filled children breadth-first; those above the last level become nodes.
        uint64_t filled = 0;
        for (uint32_t i = 0; i < lcount; i++)
            for (uint32_t k = 0; k < n3; k++)
                filled += t->children[(size_t)lnodes[i].node * n3 + k] != 0;
        t->filled_per_level[level + 1] = filled;
        bool last = level + 1 == t->d;
        uint64_t subdivided = t->node_count + (last ? 0 : filled);
        uint64_t plane_bytes = last && desc->leaf_planes ? (uint64_t)lcount * n3 * sizeof(uint32_t) : 0;
        if (!fits(desc, subdivided, plane_bytes, !last)) {
            free_lists(lists, lcount);
            r = PN_ERR_MEMORY;
            break;
        }
        if (subdivided > UINT32_MAX - 2 || (!last && (r = grow_nodes(t, (uint32_t)subdivided, &cap)) != PN_OK)) {
            free_lists(lists, lcount);
            r = PN_ERR_MEMORY;
            break;
        }
        level_node *next = last ? NULL : malloc((filled ? filled : 1) * sizeof *next);
        if (!last && !next) {
            free_lists(lists, lcount);
            r = PN_ERR_MEMORY;
            break;
        }
        uint32_t nn = 0;
        for (uint32_t i = 0; i < lcount; i++) {
            const pn_ntree_node parent = t->nodes[lnodes[i].node];
            uint32_t *entries = t->children + (size_t)lnodes[i].node * n3;
            for (uint32_t k = 0; k < n3; k++) {
                if (!entries[k])
                    continue;
                if (last) {
                    entries[k] = PN_CELL_FILLED;
                    continue;
                }
                uint32_t idx = t->node_count++;
                uint32_t xyz[3] = {k % (uint32_t)t->n, k / (uint32_t)t->n % (uint32_t)t->n, k / (uint32_t)(t->n * t->n)};
                t->nodes[idx].level = (uint32_t)level + 1;
                for (int a = 0; a < 3; a++)
                    t->nodes[idx].coord[a] = parent.coord[a] * (uint32_t)t->n + xyz[a];
                entries[k] = PN_CELL_NODE(idx);
                const uint32_t *off = lists[i];
                next[nn++] = (level_node){off + n3 + 1 + off[k], off[k + 1] - off[k], idx};
            }
        }
        // The lists of the level above were only referenced by this level's nodes.
        free_lists(parent_lists, parent_count);
        free(all);
        all = NULL;
        parent_lists = lists;
        parent_count = lcount;
        free(lnodes);
        lnodes = next;
        lcount = nn;
    }
    free_lists(parent_lists, parent_count);
    free(all);
    free(lnodes);
    free(tri);
    free(box);
    return r;
}

// ---------------------------------------------------------------------------------------------
// Line spaces: OR of the shaft masks of each node's filled children.

typedef struct ls_ctx {
    pn_ntree *t;
    const pn_ls_masks *masks;
    atomic_uint_fast64_t set_bits;
} ls_ctx;

static void build_linespaces(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    ls_ctx *c = ctx;
    pn_ntree *t = c->t;
    uint32_t n3 = (uint32_t)(t->n * t->n * t->n), w = t->words64;
    uint64_t bits = 0;
    for (uint64_t i = begin; i < end; i++) {
        uint64_t *ls = t->linespaces + i * w;
        const uint32_t *entries = t->children + i * n3;
        for (uint32_t k = 0; k < n3; k++) {
            if (entries[k] == PN_CELL_EMPTY)
                continue;
            const uint64_t *m = c->masks->bits + (size_t)k * w;
            for (uint32_t j = 0; j < w; j++)
                ls[j] |= m[j];
        }
        for (uint32_t j = 0; j < w; j++)
            bits += (uint64_t)__builtin_popcountll(ls[j]);
    }
    atomic_fetch_add(&c->set_bits, bits);
}

pn_result pn_ntree_build(const pn_scene *s, const pn_ntree_desc *desc, pn_ntree *t)
{
    memset(t, 0, sizeof *t);
    if (desc->n < 2 || desc->n > 16 || desc->d < 1 || desc->d > PN_NTREE_MAX_DEPTH) {
        pn_error("N-tree: N = %d, d = %d outside N in [2, 16], d in [1, %d]", desc->n, desc->d, PN_NTREE_MAX_DEPTH);
        return PN_ERR_INVALID;
    }
    uint64_t t0 = pn_time_ns();
    t->n = desc->n;
    t->d = desc->d;
    t->words64 = pn_ls_words64(t->n);

    pn_result r = build_occupancy(s, desc, t);
    t->occupancy_ms = pn_ms_since(t0);
    pn_ls_masks masks = {0};
    if (r == PN_OK) {
        uint64_t t1 = pn_time_ns();
        r = pn_ls_masks_create(t->n, &masks);
        t->masks_ms = pn_ms_since(t1);
    }
    if (r == PN_OK && !(t->linespaces = calloc((size_t)t->node_count * t->words64, sizeof(uint64_t))))
        r = PN_ERR_MEMORY;
    if (r == PN_OK) {
        uint64_t t2 = pn_time_ns();
        ls_ctx c = {.t = t, .masks = &masks};
        atomic_init(&c.set_bits, 0);
        pn_parallel_for(t->node_count, 16, build_linespaces, &c);
        t->set_bits = atomic_load(&c.set_bits);
        t->linespace_ms = pn_ms_since(t2);
    }
    pn_ls_masks_destroy(&masks);
    if (r != PN_OK) {
        if (r == PN_ERR_MEMORY && t->node_count && !desc->max_bytes && !desc->max_pool_bytes)
            pn_error("N-tree LS(%d,%d): out of memory", desc->n, desc->d);
        pn_ntree_destroy(t);
        return r;
    }
    t->build_ms = pn_ms_since(t0);
    return PN_OK;
}

void pn_ntree_destroy(pn_ntree *t)
{
    free(t->nodes);
    free(t->children);
    free(t->linespaces);
    free(t->cand_offset);
    free(t->cand_tris);
    free(t->planes);
    free(t->alpha_bits);
    memset(t, 0, sizeof *t);
}
