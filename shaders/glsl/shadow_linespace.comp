#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Line-space soft shadows: one invocation per G-buffer pixel traces its shadow rays from the surface
// point to samples on the rectangular light and writes the visible fraction V.
// TRAVERSAL 0 (packet): the rays of the pixel walk the tree together, slice by slice along the
// dominant axis of the light direction, visiting in each slice the cells of the packet's footprint,
// with an explicit stack of one frame per depth (Klee 2016, sec. 4.3). 1 (ray): each ray walks
// alone, a 3D-DDA per level. Both decide every (ray, node) pair with ls_classify, so they agree up
// to rays that graze cell boundaries.
//
// Control flow is kept structured (no break, continue or early return in loops): Mesa 22.3's
// llvmpipe charges every loop iteration against one budget per invocation (see Chunk in
// shadow_common.glsl), and structured loops keep that count predictable.
#include "shadow_common.glsl"
#include "linespace_trace.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 0) const int TRAVERSAL = 0;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D img_p;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D img_n;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D img_v;

const int MAX_DEPTH = 6;
const uint MAX_CHUNK = 32u; // rays of one dispatch (renderer.c keeps chunks at most this big)

bool truncated = false; // set when llvmpipe's loop budget ended a loop early

// ---------------------------------------------------------------------------------------------
// Per-ray traversal

// One frame per depth: a 3D-DDA over the children of `node` between t and t_end.
struct Frame {
    uint node;
    ivec3 cell;
    ivec3 step;
    vec3 t_max;
    vec3 t_delta;
    float t, t_end;
};

Frame stack[MAX_DEPTH];

Frame frame_begin(TreeInfo t, uint index, Node node, vec3 o, vec3 d, float t_start)
{
    float n = float(t.n);
    Local l = ls_local(node, n, o, d);
    float t_in, t_out;
    ls_slabs(l, n, t_in, t_out);
    Frame f;
    f.node = index;
    f.t = max(t_in, t_start);
    f.t_end = min(t_out, 1.0);
    vec3 p = l.o + f.t * l.d;
    f.cell = clamp(ivec3(floor(p)), ivec3(0), ivec3(int(t.n) - 1));
    [[unroll]] for (int k = 0; k < 3; k++) {
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

// The current frame lives in registers; the stack holds only its ancestors, so the (per-lane
// dynamically indexed, hence gathered) stack is touched on descent and return only.
bool ray_blocked(TreeInfo t, vec3 o, vec3 d, float t_start)
{
    Node root = t.node_pool.nodes[0];
    int c = ls_classify(t, root, o, d, t_start);
    bool blocked = c == LS_BLOCKED;
    int depth = c == LS_DESCEND ? 0 : -1;
    Frame f;
    uint children = root.children;
    if (depth == 0)
        f = frame_begin(t, 0u, root, o, d, t_start);
    int n = int(t.n);
    while (depth >= 0 && !blocked) {
        if (f.t > f.t_end || any(lessThan(f.cell, ivec3(0))) || any(greaterThanEqual(f.cell, ivec3(n)))) {
            depth--; // this node is done: back to its parent
            if (depth >= 0) {
                f = stack[depth];
                children = t.node_pool.nodes[f.node].children;
            }
        } else {
            uint entry = t.tree_pool.entries[children + uint((f.cell.z * n + f.cell.y) * n + f.cell.x)];
            // Advance the DDA before possibly descending; branch-free (no dynamic component index,
            // which llvmpipe turns into divergent branches).
            bool mx = f.t_max.x <= f.t_max.y && f.t_max.x <= f.t_max.z, my = !mx && f.t_max.y <= f.t_max.z;
            bvec3 m = bvec3(mx, my, !mx && !my);
            f.t = min(f.t_max.x, min(f.t_max.y, f.t_max.z));
            f.cell += ivec3(m) * f.step;
            f.t_max += mix(vec3(0.0), f.t_delta, m);
            if (entry == CELL_FILLED) {
                blocked = true; // a leaf, reached only by rays walking a last-level node's children
            } else if (entry != CELL_EMPTY) {
                uint child_index = entry - 2u;
                Node child = t.node_pool.nodes[child_index];
                int cc = ls_classify(t, child, o, d, t_start);
                if (cc == LS_BLOCKED) {
                    blocked = true;
                } else if (cc == LS_DESCEND && depth + 1 < MAX_DEPTH) {
                    stack[depth] = f;
                    depth++;
                    f = frame_begin(t, child_index, child, o, d, t_start);
                    children = child.children;
                }
            }
        }
    }
    truncated = truncated || (depth >= 0 && !blocked);
    return blocked;
}

// ---------------------------------------------------------------------------------------------
// Packet traversal

// The packet of a dispatch: all its rays start at o; ray i ends at o + dir[i] and starts counting
// at t_start[i]. `active` holds the rays not yet blocked.
vec3 dir[MAX_CHUNK];
float t_begin[MAX_CHUNK];

// One frame per depth: the slices of `node` along axis k, and in the current slice the cells of
// the packet's footprint [u0,u1] x [v0,v1]; `rays` are the rays that descended into this node.
struct PacketFrame {
    uint node;
    uint rays;
    int slice, slice_end, slice_step;
    int u, v, u0, u1, v0, v1;
};

PacketFrame pstack[MAX_DEPTH];

// Footprint of the packet (the pyramid from o over the light's corners) in slice [s, s+1] along
// axis k, in node-local cell units: the box of the pyramid's points in the slab, i.e. of its
// vertices inside it and its edges' crossings of the slab's two planes.
void packet_footprint(vec3 o_local, vec3 q_local[4], int k, int s, float n, out ivec4 range)
{
    int a = (k + 1) % 3, b = (k + 2) % 3;
    vec2 lo = vec2(1e30), hi = vec2(-1e30);
    float z0 = float(s), z1 = float(s + 1);
    if (o_local[k] >= z0 && o_local[k] <= z1) {
        lo = min(lo, vec2(o_local[a], o_local[b]));
        hi = max(hi, vec2(o_local[a], o_local[b]));
    }
    [[unroll]] for (int i = 0; i < 4; i++) {
        vec3 q = q_local[i];
        if (q[k] >= z0 && q[k] <= z1) {
            lo = min(lo, vec2(q[a], q[b]));
            hi = max(hi, vec2(q[a], q[b]));
        }
        // Edges from the apex and along the light's rim, crossing either plane.
        vec3 e0[2] = vec3[2](o_local, q_local[(i + 1) & 3]);
        [[unroll]] for (int e = 0; e < 2; e++) {
            vec3 p0 = e0[e], d = q - p0;
            [[unroll]] for (int side = 0; side < 2; side++) {
                float z = side == 0 ? z0 : z1;
                if (d[k] != 0.0) {
                    float tt = (z - p0[k]) / d[k];
                    if (tt >= 0.0 && tt <= 1.0) {
                        vec3 x = p0 + tt * d;
                        lo = min(lo, vec2(x[a], x[b]));
                        hi = max(hi, vec2(x[a], x[b]));
                    }
                }
            }
        }
    }
    // Cells touched, widened by one cell for rounding; empty when the packet misses the slice.
    int nn = int(n) - 1;
    range = lo.x > hi.x ? ivec4(1, 0, 1, 0)
                        : ivec4(clamp(int(floor(lo.x)) - 1, 0, nn), clamp(int(floor(hi.x)) + 1, 0, nn),
                                clamp(int(floor(lo.y)) - 1, 0, nn), clamp(int(floor(hi.y)) + 1, 0, nn));
}

uint packet_blocked(TreeInfo t, vec3 o, vec3 corners[4], uint count, uint rays)
{
    // Dominant axis of the direction to the light's centre: slices along it, front to back.
    vec3 c = 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]) - o;
    vec3 ac = abs(c);
    int k = ac.x >= ac.y && ac.x >= ac.z ? 0 : (ac.y >= ac.z ? 1 : 2);
    int a = (k + 1) % 3, b = (k + 2) % 3;
    int n = int(t.n);
    float fn = float(n);
    uint blocked = 0u;

    // The root, classified ray by ray.
    Node root = t.node_pool.nodes[0];
    uint descend = 0u;
    for (uint i = 0u; i < count; i++) {
        if ((rays & (1u << i)) != 0u) {
            int r = ls_classify(t, root, o, dir[i], t_begin[i]);
            blocked |= r == LS_BLOCKED ? (1u << i) : 0u;
            descend |= r == LS_DESCEND ? (1u << i) : 0u;
        }
    }
    int depth = -1;
    if (descend != 0u) {
        depth = 0;
        pstack[0].node = 0u;
        pstack[0].rays = descend;
    }
    bool fresh = true; // the top frame has not set up its slices yet
    while (depth >= 0 && (rays & ~blocked) != 0u) {
        PacketFrame f = pstack[depth];
        Node node = t.node_pool.nodes[f.node];
        float s = fn / node.size;
        vec3 o_local = (o - node.min) * s;
        vec3 q_local[4];
        [[unroll]] for (int i = 0; i < 4; i++)
            q_local[i] = (corners[i] - node.min) * s;
        if (fresh) {
            // Slices the packet spans in this node, in the direction of travel.
            float kmin = min(o_local[k], min(min(q_local[0][k], q_local[1][k]), min(q_local[2][k], q_local[3][k])));
            float kmax = max(o_local[k], max(max(q_local[0][k], q_local[1][k]), max(q_local[2][k], q_local[3][k])));
            int s0 = clamp(int(floor(kmin)) - 1, 0, n - 1), s1 = clamp(int(floor(kmax)) + 1, 0, n - 1);
            f.slice_step = c[k] >= 0.0 ? 1 : -1;
            f.slice = f.slice_step > 0 ? s0 : s1;
            f.slice_end = f.slice_step > 0 ? s1 + 1 : s0 - 1;
            ivec4 r;
            packet_footprint(o_local, q_local, k, f.slice, fn, r);
            f.u0 = r.x, f.u1 = r.y, f.v0 = r.z, f.v1 = r.w;
            f.u = f.u0;
            f.v = f.v0;
            fresh = false;
        }
        // Past the footprint of this slice: go to the next slice.
        if (f.v > f.v1 || f.u > f.u1) {
            f.slice += f.slice_step;
            if (f.slice != f.slice_end) {
                ivec4 r;
                packet_footprint(o_local, q_local, k, f.slice, fn, r);
                f.u0 = r.x, f.u1 = r.y, f.v0 = r.z, f.v1 = r.w;
                f.u = f.u0;
                f.v = f.v0;
            }
        }
        if (f.slice == f.slice_end) {
            depth--; // this node is done
        } else {
            ivec3 cell;
            cell[k] = f.slice;
            cell[a] = f.u;
            cell[b] = f.v;
            // Next cell of the footprint, row by row.
            f.u++;
            if (f.u > f.u1) {
                f.u = f.u0;
                f.v++;
            }
            pstack[depth] = f;
            uint entry = t.tree_pool.entries[node.children + uint((cell.z * n + cell.y) * n + cell.x)];
            uint live = f.rays & ~blocked;
            if (entry == CELL_FILLED) {
                // A leaf, reached only by rays walking a last-level node's children (in a face
                // plane): each of them that crosses it is blocked.
                for (uint i = 0u; i < count; i++) {
                    if ((live & (1u << i)) != 0u) {
                        Local l = ls_local(node, fn, o, dir[i]);
                        l.o -= vec3(cell);
                        float t_in, t_out;
                        bool hit = ls_slabs(l, 1.0, t_in, t_out) && t_in <= 1.0 && t_out >= t_begin[i];
                        blocked |= hit ? (1u << i) : 0u;
                    }
                }
            } else if (entry != CELL_EMPTY && live != 0u) {
                uint child_index = entry - 2u;
                Node child = t.node_pool.nodes[child_index];
                uint down = 0u;
                for (uint i = 0u; i < count; i++) {
                    if ((live & (1u << i)) != 0u) {
                        int r = ls_classify(t, child, o, dir[i], t_begin[i]);
                        blocked |= r == LS_BLOCKED ? (1u << i) : 0u;
                        down |= r == LS_DESCEND ? (1u << i) : 0u;
                    }
                }
                if (down != 0u && depth + 1 < MAX_DEPTH) {
                    depth++;
                    pstack[depth].node = child_index;
                    pstack[depth].rays = down;
                    fresh = true;
                }
            }
        }
    }
    truncated = truncated || (depth >= 0 && (rays & ~blocked) != 0u);
    return blocked;
}

// ---------------------------------------------------------------------------------------------

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
    //    max norm, i.e. once n.(x - p) > 3 s |n|_1. The ray starts there, at t_start along itself
    //    (not moved along the normal, which would shift the penumbrae); the node holding that point
    //    is the start node of the paper's rule. A ray that never rises that far before reaching the
    //    light passes within a few leaves of the surface only: it counts as unblocked.
    float mag = max(max(abs(p.x), abs(p.y)), abs(p.z));
    vec3 o = p.xyz + nrm * (8.0 * ulp_bound(mag));
    float rise = 3.0 * params.leaf_size * (abs(nrm.x) + abs(nrm.y) + abs(nrm.z));
    TreeInfo t = params.tree;
    uvec2 counts = chunk.first != 0u ? uvec2(0u) : imageLoad(img_counts, px).xy; // (visible, valid)
    uint count = min(chunk.sample_end - chunk.sample_begin, MAX_CHUNK);
    // The chunk's rays: those that carry light and rise clear of the surface before the light.
    uint valid_rays = 0u, traced = 0u, i = 0u;
    for (; i < count; i++) {
        vec3 q = light_point(light_sample(chunk.sample_begin + i, uvec2(px)));
        vec3 d = q - o;
        float dn = dot(d, nrm);
        // Samples behind the receiver or behind the one-sided light carry no light: not counted.
        bool valid = dn > 0.0 && dot(params.light_normal.xyz, -d) > 0.0;
        valid_rays |= valid ? (1u << i) : 0u;
        dir[i] = d;
        t_begin[i] = valid ? rise / dn : 2.0;
        traced |= valid && t_begin[i] < 1.0 ? (1u << i) : 0u;
    }
    uint blocked = 0u;
    if (TRAVERSAL == 0) {
        vec3 corners[4] = vec3[4](params.corners[0].xyz, params.corners[1].xyz, params.corners[2].xyz, params.corners[3].xyz);
        blocked = traced != 0u ? packet_blocked(t, o, corners, count, traced) : 0u;
    } else {
        for (uint j = 0u; j < count; j++)
            blocked |= (traced & (1u << j)) != 0u && ray_blocked(t, o, dir[j], t_begin[j]) ? (1u << j) : 0u;
    }
    // Valid rays that are not blocked are visible (including those that never rise clear).
    counts.x += uint(bitCount(valid_rays & ~blocked));
    counts.y += uint(bitCount(valid_rays));
    if (truncated || i < count || budget_spent())
        atomicOr(status.truncated, 1u);
    if (chunk.last != 0u)
        imageStore(img_v, px, vec4(counts.y > 0u ? float(counts.x) / float(counts.y) : 1.0));
    else
        imageStore(img_counts, px, uvec4(counts, 0u, 0u));
}
