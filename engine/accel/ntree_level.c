// One level of the N-tree's occupancy on all threads: chunks of the nodes' triangle lists tested
// against their children (the triangle-cell test is ntree_tri.c's), then each node's chunks gathered
// into per-child counts and lists (ntree_occupancy.c drives the levels).
#include <math.h>
#include <stdlib.h>

#include "accel/ntree_internal.h"

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

void pn_ntree_split_chunks(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
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

void pn_ntree_gather_nodes(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
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
