// The N-tree's occupancy, level by level: the triangles that can block and the root box around
// them, then per level the chunks tested and gathered (ntree_level.c), the filled children
// numbered, and the pools' size checked against the limits as the tree grows.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/ntree_internal.h"
#include "core/log.h"
#include "core/parallel.h"

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

pn_result pn_ntree_build_occupancy(const pn_scene *s, const pn_ntree_desc *desc, pn_ntree *t)
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
        pn_parallel_for(nchunks, 1, pn_ntree_split_chunks, &b);
        gather_ctx g = {&b, nc};
        pn_parallel_for(lcount, 1, pn_ntree_gather_nodes, &g);
        for (uint64_t i = 0; i < nchunks; i++)
            free(chunks[i].pairs);
        free(chunks);
        free(nc);
        if (atomic_load(&b.failed)) {
            free_lists(lists, lcount);
            r = PN_ERR_MEMORY;
            break;
        }
        if ((desc->keep_candidates || desc->masked) && level + 1 == t->d && (r = pn_ntree_keep_candidates(t, desc, lcount, lists)) != PN_OK) {
            free_lists(lists, lcount);
            break;
        }
        if (desc->leaf_planes && level + 1 == t->d &&
            (r = pn_ntree_build_planes(t, (const float(*)[9])tri, lnodes, lcount, lists)) != PN_OK) {
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
