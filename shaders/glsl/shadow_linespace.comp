#version 460
#extension GL_GOOGLE_include_directive : require
// Line-space soft shadows: one invocation per G-buffer pixel traces spp shadow rays from the surface
// point to samples on the rectangular light and writes the visible fraction V.
// TRAVERSAL 0: the rays of a pixel walk the tree together as a packet; 1: each ray walks alone
// (3D-DDA per level). Both apply ls_classify (linespace_trace.glsl), so they decide alike.
#include "shadow_common.glsl"
#include "linespace_trace.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const int TRAVERSAL = 1;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D img_p;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D img_n;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D img_v;

const int MAX_DEPTH = 6;

// One frame per depth: a 3D-DDA over the children of `node` between t and t_end.
struct Frame {
    uint node;
    ivec3 cell;
    ivec3 step;
    vec3 t_max;
    vec3 t_delta;
    float t, t_end;
};

Frame frame_begin(TreeInfo t, uint index, Node node, vec3 o, vec3 d)
{
    float n = float(t.n);
    Local l = ls_local(node, n, o, d);
    float t_in, t_out;
    ls_slabs(l, n, t_in, t_out);
    Frame f;
    f.node = index;
    f.t = max(t_in, 0.0);
    f.t_end = min(t_out, 1.0);
    vec3 p = l.o + f.t * l.d;
    f.cell = clamp(ivec3(floor(p)), ivec3(0), ivec3(int(t.n) - 1));
    for (int k = 0; k < 3; k++) {
        if (l.d[k] == 0.0) {
            f.step[k] = 0;
            f.t_max[k] = 1e30;
            f.t_delta[k] = 1e30;
        } else {
            f.step[k] = l.d[k] > 0.0 ? 1 : -1;
            float boundary = float(f.cell[k] + (l.d[k] > 0.0 ? 1 : 0));
            f.t_max[k] = (boundary - l.o[k]) / l.d[k];
            f.t_delta[k] = abs(1.0 / l.d[k]);
        }
    }
    return f;
}

Frame stack[MAX_DEPTH]; // the traversal stack, one frame per depth (private to the invocation)
bool truncated = false; // set when llvmpipe's loop budget ended a loop early

// Per-ray traversal: true if the line-space rule blocks the segment o + t*d, t in [0,1].
// Structured control flow only: no return, break or continue inside the loop. Mesa 22.3's llvmpipe
// miscompiles a `continue` in this loop once it is inlined into the caller's sample loop (the
// caller's loop then ends early; found by tests/test_linespace_shadow.c).
bool ray_blocked(TreeInfo t, vec3 o, vec3 d)
{
    Node root = t.node_pool.nodes[0];
    int c = ls_classify(t, root, o, d);
    bool blocked = c == LS_BLOCKED;
    int depth = c == LS_DESCEND ? 0 : -1;
    if (depth == 0)
        stack[0] = frame_begin(t, 0u, root, o, d);
    int n = int(t.n);
    while (depth >= 0 && !blocked) {
        Frame f = stack[depth];
        if (f.t > f.t_end || any(lessThan(f.cell, ivec3(0))) || any(greaterThanEqual(f.cell, ivec3(n)))) {
            depth--; // this node is done
        } else {
            Node node = t.node_pool.nodes[f.node];
            uint entry = t.tree_pool.entries[node.children + uint((f.cell.z * n + f.cell.y) * n + f.cell.x)];
            // Advance this frame's DDA before possibly descending.
            int axis = f.t_max.x < f.t_max.y ? (f.t_max.x < f.t_max.z ? 0 : 2) : (f.t_max.y < f.t_max.z ? 1 : 2);
            stack[depth].t = f.t_max[axis];
            stack[depth].cell[axis] += f.step[axis];
            stack[depth].t_max[axis] += f.t_delta[axis];
            if (entry == CELL_FILLED) {
                blocked = true; // a leaf, reached only by rays walking a last-level node's children
            } else if (entry != CELL_EMPTY) {
                uint child_index = entry - 2u;
                Node child = t.node_pool.nodes[child_index];
                int cc = ls_classify(t, child, o, d);
                if (cc == LS_BLOCKED) {
                    blocked = true;
                } else if (cc == LS_DESCEND && depth + 1 < MAX_DEPTH) {
                    depth++;
                    stack[depth] = frame_begin(t, child_index, child, o, d);
                }
            }
        }
    }
    truncated = truncated || (depth >= 0 && !blocked);
    return blocked;
}

void main()
{
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(img_v))))
        return;
    vec4 p = imageLoad(img_p, px);
    if (p.w <= 0.0) {
        if (chunk.last != 0u)
            imageStore(img_v, px, vec4(0.0));
        return;
    }
    vec3 nrm = imageLoad(img_n, px).xyz;
    // Surface offsets against self-shadowing.
    // 1. Float precision: the G-buffer position is interpolated in float, so it is only known to a
    //    few ulps of its magnitude; lifting the origin by 8 ulps along the normal puts it on the lit
    //    side of its own triangle.
    // 2. Cell size: a shaft entered through a patch touches every cell within one leaf (edge s) of
    //    the ray (its cross-section is one patch wide and cells are closed), and the surface's own
    //    filled leaves reach one leaf beyond the surface. So no shaft of a node the ray enters sees
    //    the surface it starts on once the ray is more than 3s away from the tangent plane in the
    //    max norm, i.e. once n.(x - p) > 3 s |n|_1. The ray starts there, at t_rise along itself
    //    (not moved along the normal, which would shift the penumbrae). The node holding that start
    //    is the start node of the paper's rule. A ray that never rises that far before reaching
    //    the light passes within a few leaves of the surface only: it counts as unblocked.
    float mag = max(max(abs(p.x), abs(p.y)), abs(p.z));
    vec3 o = p.xyz + nrm * (8.0 * ulp_bound(mag));
    float rise = 3.0 * params.leaf_size * (abs(nrm.x) + abs(nrm.y) + abs(nrm.z));
    TreeInfo t = params.tree;
    uvec2 counts = chunk.first != 0u ? uvec2(0u) : imageLoad(img_counts, px).xy; // (visible, valid)
    uint k = chunk.sample_begin;
    for (; k < chunk.sample_end; k++) {
        vec3 q = light_point(light_sample(k, uvec2(px)));
        vec3 d = q - o;
        float dn = dot(d, nrm);
        // Samples behind the receiver or behind the one-sided light carry no light: not counted.
        if (dn > 0.0 && dot(params.light_normal.xyz, -d) > 0.0) {
            counts.y++;
            float t_rise = rise / dn;
            if (t_rise >= 1.0 || !ray_blocked(t, o + t_rise * d, (1.0 - t_rise) * d))
                counts.x++;
        }
    }
    if (truncated || k < chunk.sample_end)
        atomicOr(status.truncated, 1u);
    if (chunk.last != 0u)
        imageStore(img_v, px, vec4(counts.y > 0u ? float(counts.x) / float(counts.y) : 1.0));
    else
        imageStore(img_counts, px, uvec4(counts, 0u, 0u));
}
