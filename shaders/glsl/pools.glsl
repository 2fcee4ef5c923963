// Reading the N-tree's GPU pools (layout: engine/accel/pools.h, structs: interface.h; tests/test_pools.c
// checks the two sides agree) and the line-space index mapping of engine/accel/linespace.h.
#include "interface.h" // Node, TreeInfo and the pools' buffer references

const uint CELL_EMPTY = PN_CELL_EMPTY;
const uint CELL_FILLED = PN_CELL_FILLED;
// Entries >= PN_CELL_FIRST_NODE are subdivided children: node index = entry - PN_CELL_FIRST_NODE.

// Patch index of (face, u, v); face = 2*axis + side, u along axis (axis+1)%3, v along (axis+2)%3.
uint ls_patch(uint n, uint face, uint u, uint v) { return (face * n + v) * n + u; }

uint ls_face_pair(uint f, uint g) { return f * (11u - f) / 2u + (g - f - 1u); }

// Shaft bit of patches a and b on different faces.
uint ls_shaft(uint n, uint a, uint b)
{
    uint n2 = n * n;
    uint lo = min(a, b), hi = max(a, b);
    uint fa = lo / n2, fb = hi / n2;
    return ls_face_pair(fa, fb) * n2 * n2 + (lo - fa * n2) * n2 + (hi - fb * n2);
}

bool ls_bit(TreeInfo t, Node node, uint bit)
{
    return ((t.ls_pool.words[node.linespace + (bit >> 5)] >> (bit & 31u)) & 1u) != 0u;
}
