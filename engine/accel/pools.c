// The N-tree's GPU pools packed from a built tree (layouts in interface.h).
#include "accel/pools.h"

#include <stdlib.h>
#include <string.h>

#include "core/log.h"

pn_result pn_pools_pack(const pn_ntree *t, pn_pools *out)
{
    memset(out, 0, sizeof *out);
    // Pool offsets are 32-bit words on the GPU; a tree whose pools pass 16 GiB cannot be addressed.
    if ((uint64_t)t->node_count * (uint64_t)(t->n * t->n * t->n) > UINT32_MAX ||
        (uint64_t)t->node_count * 2 * t->words64 > UINT32_MAX) {
        pn_error("LS(%d,%d) with %u subdivided nodes exceeds the pools' 32-bit offsets; try a smaller N or d", t->n,
                 t->d, t->node_count);
        return PN_ERR_MEMORY;
    }
    out->nodes = malloc((t->node_count ? t->node_count : 1) * sizeof *out->nodes);
    if (!out->nodes)
        return PN_ERR_MEMORY;
    uint32_t n3 = (uint32_t)(t->n * t->n * t->n);
    // Parents from the children groups (breadth-first order: parents come first).
    for (uint32_t i = 0; i < t->node_count; i++)
        out->nodes[i].parent = UINT32_MAX;
    for (uint32_t i = 0; i < t->node_count; i++)
        for (uint32_t c = 0; c < n3; c++) {
            uint32_t e = t->children[(size_t)i * n3 + c];
            if (e >= PN_CELL_NODE(0))
                out->nodes[e - PN_CELL_NODE(0)].parent = i;
        }
    for (uint32_t i = 0; i < t->node_count; i++) {
        const pn_ntree_node *nd = &t->nodes[i];
        double cs = pn_ntree_cell_size(t, (int)nd->level);
        pn_gpu_node *g = &out->nodes[i];
        for (int k = 0; k < 3; k++)
            g->min[k] = (float)(t->root_min[k] + (double)nd->coord[k] * cs);
        g->size = (float)cs;
        g->children = i * n3;
        g->level = nd->level;
        g->linespace = i * 2 * t->words64;
    }
    out->tree = t->children;
    out->linespace = (const uint32_t *)t->linespaces;
    out->bytes = pn_ntree_pool_bytes(t->n, t->node_count);
    out->planes = t->planes;
    out->bytes.planes = t->planes ? t->plane_count * sizeof *t->planes : 0;
    out->bytes.total += out->bytes.planes;
    for (int k = 0; k < 3; k++)
        out->info.root_min[k] = (float)t->root_min[k];
    out->info.root_size = (float)t->root_size;
    out->info.n = (uint32_t)t->n;
    out->info.d = (uint32_t)t->d;
    out->info.ls_words = 2 * t->words64;
    out->info.node_count = t->node_count;
    return PN_OK;
}

void pn_pools_destroy(pn_pools *p)
{
    free(p->nodes);
    memset(p, 0, sizeof *p);
}
