#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Line-space soft shadows: one invocation per G-buffer pixel traces its shadow rays from the surface
// point to samples on the rectangular light and writes the visible fraction V.
// TRAVERSAL packet: the rays of the pixel walk the tree together, slice by slice along the
// dominant axis of the light direction, visiting in each slice the cells of the packet's footprint,
// with an explicit stack of one frame per depth (Klee 2016, sec. 4.3). ray: each ray walks
// alone, a 3D-DDA per level (PN_TRAVERSAL_* in interface.h). Both decide every (ray, node) pair with ls_classify, so they agree up
// to rays that graze cell boundaries.
//
// llvmpipe (Mesa 22.3): control flow is kept structured (no break, continue or early return in
// loops): that driver miscompiles early exits inside loops (linespace_trace.glsl) and charges every
// loop iteration against one budget per invocation (see the push constant in shadow_common.glsl);
// structured loops keep that count predictable. Harmless elsewhere. engine/gpu/llvmpipe.md.
//
// MODE linespace (PN_VARIANT_LINESPACE): the paper's method; a ray starts where it has risen clear of
// its surface (t_rise, shadow_frame.glsl), a set shaft of a last-level node blocks it, and the
// last-level nodes where it starts or ends are skipped.
// MODE ls-leaf: the same start, but a set last-level shaft, and the last-level nodes where the ray
// starts or ends, are walked down to their leaves (the DDA of the node's children): a filled leaf
// the ray crosses blocks it. The ray rises clear of its surface sooner (RISE_LEAVES).
// MODE ls-plane: walked like ls-leaf, from the ray's origin; each filled leaf holds a plane and a
// thickness bounding its triangles (ntree.h), and blocks the ray if the ray crosses that slab
// inside the leaf (leaf_plane_blocks).
// MODE hybrid: as linespace, but the ray starts at its origin, and the last-level nodes the line
// space cannot decide (entered before t_rise, or holding the ray's end) have their triangles tested
// exactly. MODE exact-ls: line spaces only skip empty space; wherever a last-level shaft is set,
// or a node holds the ray's start or end, its triangles are tested exactly: the result is exact.
#include "shadow_common.glsl"
layout(constant_id = PN_SPEC_TRAVERSAL) const int TRAVERSAL = PN_TRAVERSAL_RAY_ID;
layout(constant_id = PN_SPEC_VARIANT) const int MODE = PN_VARIANT_LINESPACE;
const bool LINESPACE = MODE == PN_VARIANT_LINESPACE;
const bool LEAF = MODE == PN_VARIANT_LEAF;
const bool PLANE = MODE == PN_VARIANT_PLANE;
const bool HYBRID = MODE == PN_VARIANT_HYBRID;
const bool EXACT_LS = MODE == PN_VARIANT_EXACT_LS;
// Rays start where they rise clear of their surface (the others start at their origin).
const bool RISE_START = LINESPACE || LEAF;

#include "shadow_frame.glsl"
#include "exact.glsl"
#include "linespace_trace.glsl"

// Where a ray rises clear of its surface, in leaves above its tangent plane (shadow_origin): for a
// ray that meets the tree's cells through shafts, 3 (RISE_SHAFT_LEAVES: a shaft reaches one leaf
// beyond the ray and a filled leaf one leaf beyond its surface). ls-leaf meets only the leaves the
// ray itself crosses: a leaf holding a point x with n.(x - p) > s |n|_1 lies wholly above the
// tangent plane (its points are within s of x in the max norm), so 1 leaf clears the surface's
// own leaves; a quarter leaf more covers the traversal's rounding allowance (4 ulps of leaves at
// least 16 ulps wide: ntree.c, linespace_trace.glsl).
const float RISE_LEAVES = LEAF ? 1.25 : RISE_SHAFT_LEAVES;

layout(local_size_x = PN_WORKGROUP, local_size_y = PN_WORKGROUP) in;
const int MAX_DEPTH = PN_NTREE_MAX_DEPTH;

// Where ray i's segment starts, and from where the line space may answer for it (see MODE).
float ray_start(uint i) { return RISE_START ? t_rise[i] : 0.0; }
float ray_trust(uint i) { return EXACT_LS || PLANE ? 0.0 : t_rise[i]; }

// A last-level verdict per mode. LS_BLOCKED blocks in linespace and hybrid; in the other modes the
// ray walks the node's leaves instead. LS_INSIDE is skipped by the paper's rule, and walked in the
// others. A walked last-level node decides each filled leaf the ray crosses (leaf_blocks).
bool ls_blocks(int c) { return c == LS_BLOCKED && (LINESPACE || HYBRID); }
bool ls_walks(int c) { return c == LS_DESCEND || (!LINESPACE && c == LS_INSIDE) || (c == LS_BLOCKED && !ls_blocks(c)); }

// ls-plane: does filled leaf `cell` of last-level node `node` block the ray? lo: the ray's origin
// in the node's local frame (the node spans [0, N]^3, a leaf is 1), ld its direction there, eps
// the rounding allowance of those coordinates (ls_local_box); [t_in, t_out]: where the ray is in
// the leaf grown by eps (ls_slabs), so that a crossing on the leaf's boundary is seen from either
// side.
// The leaf's slab (its plane, within the stored thickness) holds every point of its triangles, so a
// ray that misses the slab inside the leaf misses them. A ray that crosses it is blocked, except
// in the leaves around its origin (within 1.5 leaves of it in the max norm) whose slab holds the
// origin up to OWN_SLACK, and those around its end whose slab holds the end: there the slab may be
// the surface the ray leaves (or the one the light lies on), which it does not cross again. A
// neighbouring leaf's plane is fitted to the origin's surface where it curves: for curvature
// radius R it passes beside the origin by about r^2 / (2 R) at distance r <= 1.5 leaves, so
// OWN_SLACK = 0.5 leaf covers radii down to 2.25 leaves (finer curvature is below what the tree
// resolves). What this gives up is a blocker within 2 leaves of the origin or the light sample.
const float OWN_SLACK = 0.5;
const float HALF_DIAGONAL = 0.8660254; // of a unit cube, sqrt(3)/2: the range of a plane's offset
// Farther leaves count as the origin's surface only if they are planar, i.e. no thicker than a plane
// through the leaf comes out of the fit (at most 10/256 leaf, the 7+7-bit normal's tilt across the
// leaf: tests/test_leaf_plane.c), and their slab holds the origin: a ray leaving a point of a
// plane does not cross that plane again (it only grazes the slab when it is nearly in the plane).
const uint PLANAR_THICKNESS = 10u;
bool leaf_plane_blocks(uint node, uint cell, uint n3, vec3 lo, vec3 ld, float eps, float t_in, float t_out)
{
    uint n = params.tree.n;
    uint w = params.tree.plane_pool.ids[(node - params.cand_first) * n3 + cell];
    vec3 mid = vec3(uvec3(cell % n, (cell / n) % n, cell / (n * n))) + 0.5;
    // Decoding as pn_leaf_plane_decode (accel/leaf_plane.h): octahedral normal (7 + 7 bits),
    // offset from the leaf's centre in [-sqrt(3)/2, sqrt(3)/2] (9 bits), half-thickness in 1/256
    // leaf (9 bits).
    vec2 e = vec2(float(w & 127u), float((w >> 7u) & 127u)) / 126.0 * 2.0 - 1.0;
    vec3 m = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    m.xy = m.z < 0.0 ? (1.0 - abs(m.yx)) * mix(vec2(-1.0), vec2(1.0), greaterThanEqual(m.xy, vec2(0.0))) : m.xy;
    m = normalize(m);
    float off = (float((w >> 14u) & 511u) / 511.0 * 2.0 - 1.0) * HALF_DIAGONAL;
    // The slab grown by the rounding of both the point's coordinates and the leaf's centre, each
    // within eps (ls_local_box).
    float slab = float(w >> 23u) / 256.0 + 2.0 * eps;
    float d_o = dot(m, lo - mid) - off, dm = dot(m, ld);
    float d0 = d_o + max(t_in, 0.0) * dm, d1 = d_o + min(t_out, 1.0) * dm;
    bool crosses = min(d0, d1) <= slab && max(d0, d1) >= -slab;
    bool near_o = all(lessThanEqual(abs(lo - mid), vec3(1.5 + eps)));
    bool near_e = all(lessThanEqual(abs(lo + ld - mid), vec3(1.5 + eps)));
    bool planar = (w >> 23u) <= PLANAR_THICKNESS;
    bool own = (near_o && abs(d_o) <= slab + OWN_SLACK) || (planar && abs(d_o) <= slab) ||
               (near_e && abs(d_o + dm) <= slab);
    return crosses && !own;
}

// ls-leaf at the light's end, as at the ray's start: the ray x(t) = o + t d lies (1 - t) n_L.(-d)
// in front of the light's plane (n_L its emitting normal), so a leaf it enters before
// t_fall = 1 - RISE_LEAVES s |n_L|_1 / n_L.(-d) lies wholly in front of the light (by the argument of
// RISE_LEAVES); a later one may hold the surface the light is mounted on, and does not block.
float leaf_t_fall(vec3 d)
{
    vec3 nl = LIGHT.normal.xyz;
    return 1.0 - RISE_LEAVES * params.leaf_size * (abs(nl.x) + abs(nl.y) + abs(nl.z)) / dot(nl, -d);
}

// Does filled leaf `cell` of walked last-level node `node` block ray (o, d)? See MODE.
bool leaf_blocks(uint node, uint cell, uint n3, vec3 o, vec3 d, vec3 lo, vec3 ld, float eps, float t_in, float t_out)
{
    bool blocks = LINESPACE || (LEAF && t_in < leaf_t_fall(d));
    if (PLANE)
        blocks = leaf_plane_blocks(node, cell, n3, lo, ld, eps, t_in, t_out);
    else if (HYBRID || EXACT_LS)
        blocks = leaf_blocked(node, cell, n3, wray(o, d), 0.0, 1.0);
    return blocks;
}

// ---------------------------------------------------------------------------------------------
// Per-ray traversal

// llvmpipe (Mesa 22.3): this walk is shaped by that driver's cost model (engine/gpu/llvmpipe.md).
// There an `if` does not branch: both sides run masked on all 8 lanes; only loops branch, and their
// bodies run until no lane is active (at least once). So a loop iteration costs its whole body,
// whatever each lane does. The dearest operations are loads from buffers: every component of a
// load is a loop over the 8 lanes with a branch and a scalar load each. On GPUs with real branches
// and vector loads the trade-offs below may differ (measure before copying them). Hence:
// - one loop over all the chunk's rays: a lane whose ray is done takes its next ray in the same
//   iteration (no lane idles until the slowest ray of the group is finished);
// - per iteration at most one node is loaded and classified, shared by starting a ray at the root
//   and visiting a child; of the node only its box is loaded, as two 64-bit components; its level is
//   the depth, and its children group and line space sit at fixed multiples of its index (pools.h);
// - returning to a parent loads nothing: the stack holds the parent's whole DDA state, in separate
//   variables with constant indices (registers updated by selects; a per-lane indexed array would
//   cost a scalar access per lane and word).

// The node pool as 64-bit words, 4 per node (pn_gpu_node, 32 bytes): node i's box (min.xyz, size) is
// words[4i] = (min.x, min.y) and words[4i+1] = (min.z, size). Typed double only to load 64 bits at
// once (the device enables shaderFloat64, not shaderInt64): the bits are only unpacked, never used
// as doubles.
// llvmpipe: two 64-bit loads, not four 32-bit ones, as each loaded component there is a scalar
// loop over the lanes (cost model above).
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer NodeBoxes { double words[]; };

// The DDA of a node over its children: the cell the ray is in, its step direction, the parameters
// where the ray crosses the next cell boundary on each axis and their spacing, the end of the
// segment in the node, and whether the ray has left it.
struct Dda {
    uint node;
    ivec3 cell;
    ivec3 step;
    vec3 t_max;
    vec3 t_delta;
    float t_end;
    bool done;
};

// The tree entry of the DDA's current cell (and its child index), then the DDA advanced to the next cell.
// llvmpipe: branch-free, with no dynamic component index (that driver turns one into branches).
uint dda_step(TreeInfo t, int n, uint n3, inout Dda f, out uint child)
{
    child = uint((f.cell.z * n + f.cell.y) * n + f.cell.x);
    uint entry = t.tree_pool.entries[f.node * n3 + child];
    bool mx = f.t_max.x <= f.t_max.y && f.t_max.x <= f.t_max.z, my = !mx && f.t_max.y <= f.t_max.z;
    bvec3 m = bvec3(mx, my, !mx && !my);
    float t_cell = min(f.t_max.x, min(f.t_max.y, f.t_max.z)); // where the next cell starts
    f.cell += ivec3(m) * f.step;
    f.t_max += mix(vec3(0.0), f.t_delta, m);
    f.done = t_cell > f.t_end || any(lessThan(f.cell, ivec3(0))) || any(greaterThanEqual(f.cell, ivec3(n)));
    return entry;
}

// The chunk's rays `rays` (bits into dir[]) from o: the bits of those that are blocked.
uint rays_blocked(TreeInfo t, vec3 o, uint rays)
{
    int n = int(t.n);
    float fn = float(n);
    uint n3 = t.n * t.n * t.n;
    NodeBoxes boxes = NodeBoxes(t.node_pool);
    uint result = 0u, pending = rays, ray = 0u;
    vec3 d = vec3(0.0);
    float t_start = 0.0, t_trust = 0.0;
    int depth = -1; // of the current node; -1: no ray in flight
    // The ray in the frame of the node last entered. Leaves are walked only in a last-level node,
    // always the deepest frame, so this needs no slot on the stack.
    Local leaf_l = Local(vec3(0.0), vec3(0.0), 0.0);
    Dda f = Dda(0u, ivec3(0), ivec3(0), vec3(0.0), vec3(0.0), 0.0, true);
    // The stack: s<i> holds the DDA of the ancestor at depth i (a node at depth MAX_DEPTH - 1 is
    // never entered below, so 5 slots).
    Dda s0 = f, s1 = f, s2 = f, s3 = f, s4 = f;
    while (depth >= 0 || pending != 0u) {
        bool blocked = false, visit = false;
        uint next = 0u; // the node to visit (classify, and enter if the ray must walk its children)
        if (depth < 0) {
            // Next ray, starting at the root.
            ray = uint(findLSB(pending));
            pending &= pending - 1u;
            d = dir[ray];
            t_start = ray_start(ray);
            t_trust = ray_trust(ray);
            visit = true;
        } else if (f.done) {
            depth--; // this node is done: back to its parent
            f = depth == 0 ? s0 : (depth == 1 ? s1 : (depth == 2 ? s2 : (depth == 3 ? s3 : s4)));
        } else {
            // Up to 3 cells per iteration: after an empty cell the walk goes on to the next one in
            // the same iteration, which saves the rest of an iteration's cost (above all the node
            // and line-space loads) for the common empty cells.
            // llvmpipe (Mesa 22.3): written out, not as a loop, so that it costs no loop budget;
            // 3 beats 2 and 4 as measured there.
            uint child;
            uint entry = dda_step(t, n, n3, f, child);
            if (entry == CELL_EMPTY && !f.done)
                entry = dda_step(t, n, n3, f, child);
            if (entry == CELL_EMPTY && !f.done)
                entry = dda_step(t, n, n3, f, child);
            // A filled leaf, reached by a ray walking a last-level node's children (in linespace mode
            // only rays in a face plane walk them): the mode decides (leaf_blocks). The DDA has moved
            // on: the leaf is the cell it left. ls-leaf and ls-plane need where the ray is in it:
            // the same slab test as the packet traversal's, in the node's frame (leaf_l).
            // Also where the leaf blocks the ray in linespace mode (rays in a face plane), for the
            // blocker's t (hybrid and exact-ls record their triangles' hits).
            float t_in = 0.0, t_out = 1.0;
            if (entry == CELL_FILLED && !(HYBRID || EXACT_LS)) {
                uvec3 c = uvec3(child % t.n, (child / t.n) % t.n, child / (t.n * t.n));
                Local lc = Local(leaf_l.o - vec3(c), leaf_l.d, leaf_l.eps);
                ls_slabs(lc, 1.0, t_in, t_out);
            }
            if (entry == CELL_FILLED)
                blocked = leaf_blocks(f.node, child, n3, o, d, leaf_l.o, leaf_l.d, leaf_l.eps, t_in, t_out);
            if (blocked)
                blocker_at(ray, HYBRID || EXACT_LS ? last_hit_t() : max(t_in, t_start));
            visit = entry > CELL_FILLED;
            next = entry - 2u;
        }
        if (visit) {
            if (COUNT_WORK)
                work = uvec4(work.x + 1u, work.yz, max(work.w, uint(depth + 2)));
            vec2 xy = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * next]));
            vec2 zs = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * next + 1u]));
            Local l = ls_local_box(vec3(xy, zs.x), zs.y, fn, o, d);
            float t_in, t_out;
            bool hit = ls_slabs(l, fn, t_in, t_out);
            int c = ls_classify_local(t, uint(depth + 1), next * t.ls_words, l, hit, t_in, t_out, t_start, t_trust);
            if (ls_blocks(c))
                blocker_at(ray, max(t_in, t_start));
            blocked = blocked || ls_blocks(c);
            if (ls_walks(c) && depth + 1 < MAX_DEPTH) {
                s0 = depth == 0 ? f : s0;
                s1 = depth == 1 ? f : s1;
                s2 = depth == 2 ? f : s2;
                s3 = depth == 3 ? f : s3;
                s4 = depth == 4 ? f : s4;
                depth++;
                // The child's DDA from where the ray enters it (or starts).
                float t0 = max(t_in, t_start);
                bvec3 flat_axis = equal(l.d, vec3(0.0));
                f.node = next;
                f.t_end = min(t_out, 1.0);
                leaf_l = l;
                f.cell = clamp(ivec3(floor(l.o + t0 * l.d)), ivec3(0), ivec3(n - 1));
                f.step = ivec3(sign(l.d));
                vec3 boundary = vec3(f.cell + ivec3(greaterThan(l.d, vec3(0.0))));
                f.t_max = mix((boundary - l.o) / l.d, vec3(1e30), flat_axis);
                f.t_delta = mix(abs(1.0 / l.d), vec3(1e30), flat_axis);
                f.done = t0 > f.t_end;
            }
        }
        if (blocked) {
            result |= 1u << ray;
            depth = -1;
        }
    }
    truncated = truncated || depth >= 0 || pending != 0u;
    return result;
}

// ---------------------------------------------------------------------------------------------
// Packet traversal


// One frame per depth: the slices of `node` along axis k, and in the current slice the cells of
// the packet's footprint [u0,u1] x [v0,v1]; `rays` are the rays that descended into this node.
struct PacketFrame {
    uint node;
    uint rays;
    int slice, slice_end, slice_step;
    int u, v, u0, u1, v0, v1;
};


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
    // llvmpipe: loops over rays visit the set bits only, as every iteration counts against the
    // loop budget there.
    for (uint left = rays; left != 0u; left &= left - 1u) {
        uint i = uint(findLSB(left));
        int r = ls_classify(t, root, o, dir[i], ray_start(i), ray_trust(i));
        if (ls_blocks(r))
            blocker_at(i, ray_start(i)); // a root without children: the blocker lies beyond the start
        blocked |= ls_blocks(r) ? (1u << i) : 0u;
        descend |= ls_walks(r) ? (1u << i) : 0u;
    }
    // The top frame lives in registers, its ancestors in p<i> for depth i: separate variables with
    // constant indices, updated by selects.
    // llvmpipe: a per-lane indexed array costs a scalar access per lane and word there, run on
    // every iteration, masked, whether or not a lane needs it.
    int depth = descend != 0u ? 0 : -1;
    PacketFrame f = PacketFrame(0u, descend, 0, 0, 0, 0, 0, 0, 0, 0, 0);
    PacketFrame p0 = f, p1 = f, p2 = f, p3 = f, p4 = f;
    NodeBoxes boxes = NodeBoxes(t.node_pool);
    uint n3 = t.n * t.n * t.n;
    bool fresh = true; // the top frame has not set up its slices yet
    while (depth >= 0 && (rays & ~blocked) != 0u) {
        // Of the node only its box is loaded (see rays_blocked); its children group is at index * N^3.
        vec2 xy = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * f.node]));
        vec2 zs = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * f.node + 1u]));
        vec3 node_min = vec3(xy, zs.x);
        float s = fn / zs.y;
        vec3 o_local = (o - node_min) * s;
        vec3 q_local[4];
        [[unroll]] for (int i = 0; i < 4; i++)
            q_local[i] = (corners[i] - node_min) * s;
        // A new node starts at its first slice, a slice whose footprint is done goes on to the next
        // slice; either needs the footprint, computed once per iteration (a slice whose footprint is
        // empty is left in the next iteration).
        bool past = !fresh && (f.v > f.v1 || f.u > f.u1);
        if (fresh) {
            // Slices the packet spans in this node, in the direction of travel.
            float kmin = min(o_local[k], min(min(q_local[0][k], q_local[1][k]), min(q_local[2][k], q_local[3][k])));
            float kmax = max(o_local[k], max(max(q_local[0][k], q_local[1][k]), max(q_local[2][k], q_local[3][k])));
            int s0 = clamp(int(floor(kmin)) - 1, 0, n - 1), s1 = clamp(int(floor(kmax)) + 1, 0, n - 1);
            f.slice_step = c[k] >= 0.0 ? 1 : -1;
            f.slice = f.slice_step > 0 ? s0 : s1;
            f.slice_end = f.slice_step > 0 ? s1 + 1 : s0 - 1;
        } else if (past) {
            f.slice += f.slice_step;
        }
        if ((fresh || past) && f.slice != f.slice_end) {
            ivec4 r;
            packet_footprint(o_local, q_local, k, f.slice, fn, r);
            f.u0 = r.x, f.u1 = r.y, f.v0 = r.z, f.v1 = r.w;
            f.u = f.u0;
            f.v = f.v0;
        }
        fresh = false;
        if (f.slice == f.slice_end) {
            depth--; // this node is done
            f = depth == 0 ? p0 : (depth == 1 ? p1 : (depth == 2 ? p2 : (depth == 3 ? p3 : p4)));
        } else if (f.u <= f.u1 && f.v <= f.v1) {
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
            uint entry = t.tree_pool.entries[f.node * n3 + uint((cell.z * n + cell.y) * n + cell.x)];
            uint live = f.rays & ~blocked;
            if (entry == CELL_FILLED) {
                // A leaf, reached by rays walking a last-level node's children: the mode decides for
                // each of them that crosses it (leaf_blocks).
                for (uint left = live; left != 0u; left &= left - 1u) {
                    uint i = uint(findLSB(left));
                    Local l = ls_local_box(node_min, zs.y, fn, o, dir[i]);
                    l.o -= vec3(cell);
                    float t_in, t_out;
                    bool hit = ls_slabs(l, 1.0, t_in, t_out) && t_in <= 1.0 && t_out >= ray_start(i);
                    uint ci = uint((cell.z * n + cell.y) * n + cell.x);
                    hit = hit && leaf_blocks(f.node, ci, n3, o, dir[i], l.o + vec3(cell), l.d, l.eps, t_in, t_out);
                    if (hit)
                        blocker_at(i, HYBRID || EXACT_LS ? last_hit_t() : max(t_in, ray_start(i)));
                    blocked |= hit ? (1u << i) : 0u;
                }
            } else if (entry != CELL_EMPTY && live != 0u) {
                uint child_index = entry - 2u;
                vec2 cxy = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * child_index]));
                vec2 czs = uintBitsToFloat(unpackDouble2x32(boxes.words[4u * child_index + 1u]));
                uint down = 0u;
                if (COUNT_WORK) // the packet visits the child once for all its rays
                    work = uvec4(work.x + 1u, work.yz, max(work.w, uint(depth + 2)));
                for (uint left = live; left != 0u; left &= left - 1u) {
                    uint i = uint(findLSB(left));
                    Local l = ls_local_box(vec3(cxy, czs.x), czs.y, fn, o, dir[i]);
                    float t_in, t_out;
                    bool hit = ls_slabs(l, fn, t_in, t_out);
                    // The child's level is depth + 1, its line space at index * ls_words (pools.h).
                    int r = ls_classify_local(t, uint(depth + 1), child_index * t.ls_words, l, hit, t_in, t_out,
                                              ray_start(i), ray_trust(i));
                    if (ls_blocks(r))
                        blocker_at(i, max(t_in, ray_start(i)));
                    blocked |= ls_blocks(r) ? (1u << i) : 0u;
                    down |= ls_walks(r) ? (1u << i) : 0u;
                }
                if (down != 0u && depth + 1 < MAX_DEPTH) {
                    p0 = depth == 0 ? f : p0;
                    p1 = depth == 1 ? f : p1;
                    p2 = depth == 2 ? f : p2;
                    p3 = depth == 3 ? f : p3;
                    p4 = depth == 4 ? f : p4;
                    depth++;
                    f.node = child_index;
                    f.rays = down;
                    fresh = true;
                }
            }
        }
    }
    truncated = truncated || (depth >= 0 && (rays & ~blocked) != 0u);
    return blocked;
}

// ---------------------------------------------------------------------------------------------

// ---------------------------------------------------------------------------------------------
// Per-object trees (--trees object, accel/objects.h): each object has its own tree in its own frame;
// a BVH over the objects' world boxes finds those the pixel's rays may reach, and the rays are
// carried into each one's frame by its affine map. An affine map keeps a segment's parameter: the
// point at t of the world segment o + t d is the point at t of the local one, so t_rise and the
// traversal's [t_start, 1] carry over unchanged. Each tree has leaves of its own world size: a ray
// rises clear of its surface by the object's leaves (ObjectData.rise_scale times the finest tree's,
// the params' leaf_size) before that tree may block it, by the argument of shadow_origin for a leaf
// that fits in a world box of that edge.

vec3 to_local(ObjectData ob, vec3 x)
{
    return vec3(dot(ob.to_local[0].xyz, x) + ob.to_local[0].w, dot(ob.to_local[1].xyz, x) + ob.to_local[1].w,
                dot(ob.to_local[2].xyz, x) + ob.to_local[2].w);
}

vec3 to_local_dir(ObjectData ob, vec3 d)
{
    return vec3(dot(ob.to_local[0].xyz, d), dot(ob.to_local[1].xyz, d), dot(ob.to_local[2].xyz, d));
}

// The blocked ones of `rays` from o to the light's `corners` (the packet's pyramid), over the objects.
uint objects_blocked(vec3 o, vec3 corners[4], uint count, uint rays)
{
    // Every segment lies in the convex hull of o and the corners, so in this box.
    vec3 lo = min(o, min(min(corners[0], corners[1]), min(corners[2], corners[3])));
    vec3 hi = max(o, max(max(corners[0], corners[1]), max(corners[2], corners[3])));
    vec3 dir_world[MAX_CHUNK];
    float rise_world[MAX_CHUNK];
    for (uint j = 0u; j < count; j++) {
        dir_world[j] = dir[j];
        rise_world[j] = t_rise[j];
    }
    uint blocked = 0u;
    uint stack[PN_BVH_STACK];
    int sp = 0;
    uint node = 0u;
    bool more = params.object_count > 0u;
    while (more && (rays & ~blocked) != 0u) {
        BvhNodeData nd = params.top.nodes[node];
        bool hit = all(lessThanEqual(nd.min, hi)) && all(greaterThanEqual(nd.max, lo));
        if (COUNT_WORK)
            work.x++;
        // A leaf's objects, each in its own frame.
        for (uint k = 0u; hit && k < nd.count; k++) {
            ObjectData ob = params.objects.objects[params.top_ids.ids[nd.first + k]];
            uint live = rays & ~blocked;
            for (uint j = 0u; j < count; j++) {
                dir[j] = to_local_dir(ob, dir_world[j]);
                t_rise[j] = rise_world[j] * ob.rise_scale;
                live &= t_rise[j] < 1.0 ? ~0u : ~(1u << j); // within its leaves of the surface up to the light
            }
            vec3 ol = to_local(ob, o);
            if (TRAVERSAL == PN_TRAVERSAL_PACKET_ID) {
                vec3 cl[4] = vec3[4](to_local(ob, corners[0]), to_local(ob, corners[1]), to_local(ob, corners[2]),
                                     to_local(ob, corners[3]));
                blocked |= live != 0u ? packet_blocked(ob.tree, ol, cl, count, live) : 0u;
            } else {
                blocked |= live != 0u ? rays_blocked(ob.tree, ol, live) : 0u;
            }
        }
        bool inner = hit && nd.count == 0u;
        if (inner && sp < PN_BVH_STACK) {
            stack[sp++] = nd.first + 1u;
            node = nd.first;
        } else if (sp > 0) {
            node = stack[--sp];
        } else {
            more = false;
        }
    }
    for (uint j = 0u; j < count; j++) {
        dir[j] = dir_world[j];
        t_rise[j] = rise_world[j];
    }
    truncated = truncated || (more && (rays & ~blocked) != 0u); // cut short, not done because all are blocked
    return blocked;
}

// ---------------------------------------------------------------------------------------------

void main()
{
    ivec2 px = shadow_invocation_pixel(ivec2(gl_LocalInvocationID.xy));
    vec3 p, nrm;
    if (!shadow_pixel(px, p, nrm))
        return;
    float rise;
    vec3 o = shadow_origin(p, nrm, RISE_LEAVES, rise);
    TreeInfo t = params.tree;
    uint count = chunk_count(p, nrm), i;
    vec2 st_lo, st_hi;
    uint valid_rays = chunk_rays(uvec2(px), o, nrm, rise, count, i, st_lo, st_hi);
    // The rays to trace: the valid ones; in linespace and ls-leaf only those that rise clear of their
    // surface before reaching the light (the others pass within a few leaves of it: unblocked).
    uint traced = valid_rays;
    for (uint j = 0u; RISE_START && j < count; j++)
        traced &= t_rise[j] < 1.0 ? ~0u : ~(1u << j);
    // The packet's bounding pyramid: over the part of the light that holds this chunk's traced
    // samples rather than the whole light (the light is a parallelogram, so its (s, t) box is one);
    // its footprints have fewer cells to visit, the rays and their decisions are the same. Modes
    // that trace every valid ray use the whole light.
    if (!RISE_START) {
        st_lo = vec2(0.0);
        st_hi = vec2(1.0);
    }
    vec3 corners[4] = vec3[4](light_point(st_lo), light_point(vec2(st_hi.x, st_lo.y)), light_point(st_hi),
                              light_point(vec2(st_lo.x, st_hi.y)));
    uint blocked = 0u;
    if (traced == 0u)
        blocked = 0u;
    else if (params.object_count > 0u)
        blocked = objects_blocked(o, corners, count, traced);
    else if (TRAVERSAL == PN_TRAVERSAL_PACKET_ID)
        blocked = packet_blocked(t, o, corners, count, traced);
    else
        blocked = rays_blocked(t, o, traced);
    shadow_finish(px, o, count, valid_rays, blocked, i < count);
}
