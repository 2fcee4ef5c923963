// The N-tree build: the occupancy level by level (ntree_occupancy.c, with its chunk and gather
// workers in ntree_level.c), candidate lists and leaf planes (ntree_leaves.c), then the line spaces
// here. The triangle tests it uses (overlap with a cell, whether a triangle can block) are in
// ntree_tri.c, the cells' sizes and boxes and the pools' bytes in ntree_cells.c: the files call
// one way, ntree.c -> ntree_occupancy.c -> ntree_leaves.c, ntree_level.c -> ntree_tri.c,
// ntree_cells.c.
#include "accel/ntree.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "accel/ntree_internal.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/timer.h"

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

    pn_result r = pn_ntree_build_occupancy(s, desc, t);
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
