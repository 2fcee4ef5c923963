// The N-tree build: the occupancy level by level (ntree_occupancy.c, with its chunk and gather
// workers in ntree_level.c), candidate lists and leaf planes (ntree_leaves.c), then the line spaces
// here. The triangle tests it uses (overlap with a cell, whether a triangle can block) are in
// ntree_tri.c.
#include "accel/ntree.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "accel/ntree_internal.h"
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
