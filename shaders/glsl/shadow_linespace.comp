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

#include "linespace_leaf.glsl"
#include "linespace_ray.glsl"
#include "linespace_packet.glsl"
#include "linespace_objects.glsl"

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
