#version 460
#extension GL_GOOGLE_include_directive : require
// Reads the N-tree pools through pools.glsl and writes what it sees, so test_pools.c can compare
// every field with the C side: any disagreement in sizes, offsets, addresses or the line-space
// index mapping shows up as a wrong value.
#include "pools.glsl"

layout(local_size_x = 64) in;
layout(push_constant) uniform Push { TreeInfo tree; } pc;
layout(std430, set = 0, binding = 0) writeonly buffer Out { uint values[]; };

const uint HEADER = 8u;
const uint PER_NODE = 12u;

void main()
{
    TreeInfo t = pc.tree;
    uint i = gl_GlobalInvocationID.x;
    if (i == 0u) {
        values[0] = floatBitsToUint(t.root_min.x);
        values[1] = floatBitsToUint(t.root_min.y);
        values[2] = floatBitsToUint(t.root_min.z);
        values[3] = floatBitsToUint(t.root_size);
        values[4] = t.n;
        values[5] = t.d;
        values[6] = t.ls_words;
        values[7] = t.node_count;
    }
    if (i >= t.node_count)
        return;
    Node node = t.node_pool.nodes[i];
    uint o = HEADER + i * PER_NODE;
    values[o + 0] = floatBitsToUint(node.min.x);
    values[o + 1] = floatBitsToUint(node.min.y);
    values[o + 2] = floatBitsToUint(node.min.z);
    values[o + 3] = floatBitsToUint(node.size);
    values[o + 4] = node.children;
    values[o + 5] = node.level;
    values[o + 6] = node.linespace;
    values[o + 7] = node.parent;
    uint n3 = t.n * t.n * t.n;
    values[o + 8] = t.tree_pool.entries[node.children + (i * 7u) % n3];
    values[o + 9] = t.ls_pool.words[node.linespace + (i * 13u) % t.ls_words];
    // A shaft picked from the node index: entry patch on face i%6, exit on the next face.
    uint n2 = t.n * t.n;
    uint a = ls_patch(t.n, i % 6u, i % t.n, (i / 3u) % t.n);
    uint b = ls_patch(t.n, (i + 1u) % 6u, (i / 5u) % t.n, (i / 7u) % t.n);
    uint bit = ls_shaft(t.n, a, b);
    values[o + 10] = bit;
    values[o + 11] = ls_bit(t, node, bit) ? 1u : 0u;
}
