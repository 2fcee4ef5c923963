// What the leaves of the N-tree's last level keep besides their occupancy: the triangle lists of
// the leaves (every leaf's with desc.keep_candidates, else those holding an alpha-masked triangle,
// with their bits) and, for ls-plane, one plane per leaf.
#include <stdlib.h>
#include <string.h>

#include "accel/leaf_plane.h"
#include "accel/ntree_internal.h"
#include "core/parallel.h"

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
pn_result pn_ntree_keep_candidates(pn_ntree *t, const pn_ntree_desc *desc, uint32_t lcount, uint32_t **lists)
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
pn_result pn_ntree_build_planes(pn_ntree *t, const float (*tri)[9], const level_node *lnodes, uint32_t lcount,
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
