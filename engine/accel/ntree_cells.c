// An N-tree's cells and sizes, which every stage of its build asks (ntree.h): a level's cell size,
// a cell's box with the tree's slack, and the pools' bytes for a count of subdivided nodes.
#include "accel/ntree.h"

#include <math.h>

#include "accel/linespace.h"

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
