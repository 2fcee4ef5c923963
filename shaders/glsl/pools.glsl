// The N-tree's GPU pools; mirrors engine/accel/pools.h (tests/test_pools.c checks the two agree)
// and the line-space index mapping of engine/accel/linespace.h.
#extension GL_EXT_buffer_reference : require

struct Node {
    vec3 min;       // box corner; the box is a cube
    float size;     // edge length
    uint children;  // first entry of its children group in the tree pool
    uint level;     // root = 0
    uint linespace; // first word of its line space in the line-space pool
    uint parent;    // node index, 0xffffffff for the root
};

layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer NodePool { Node nodes[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer TreePool { uint entries[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer LinespacePool { uint words[]; };

// Mirrors pn_gpu_tree_info.
struct TreeInfo {
    vec3 root_min;
    float root_size;
    uint n;
    uint d;
    uint ls_words;   // 32-bit words per line space
    uint node_count;
    NodePool node_pool;
    TreePool tree_pool;
    LinespacePool ls_pool;
    uvec2 pad;      // keeps the struct at 64 bytes without needing 64-bit integers
};

const uint CELL_EMPTY = 0u;
const uint CELL_FILLED = 1u;
// Entries >= 2 are subdivided children: node index = entry - 2.

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
