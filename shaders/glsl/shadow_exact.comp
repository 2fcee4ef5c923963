#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Exact soft shadows (--mode exact): every shadow ray is traced through the BVH with the watertight
// triangle test; any hit blocks it. The ground truth of every error figure, and the baseline the
// paper compared against (Aila and Laine style GPU traversal).
#include "shadow_common.glsl"
#include "shadow_frame.glsl"
layout(constant_id = PN_SPEC_TRAVERSAL) const int TRAVERSAL = PN_TRAVERSAL_RAY_ID;
#include "exact.glsl"

layout(local_size_x = PN_WORKGROUP, local_size_y = PN_WORKGROUP) in;

void main()
{
    // llvmpipe: 8 consecutive invocations run as one SIMD group; map them to a 4x2 block of
    // pixels (not a row of 8), whose walks are more alike.
    uint idx = gl_LocalInvocationIndex, block = idx / 8u, within = idx % 8u;
    ivec2 px = shadow_invocation_pixel(ivec2((block % 2u) * 4u + within % 4u, (block / 2u) * 2u + within / 4u));
    vec3 p, nrm;
    if (!shadow_pixel(px, p, nrm))
        return;
    // Every ray is tested from its origin: no rise (that is the line-space modes'), so chunk_rays'
    // st_lo, st_hi bound all the valid samples.
    float rise;
    vec3 o = shadow_origin(p, nrm, 0.0, rise);
    uint count = chunk_count(p, nrm), i;
    vec2 st_lo, st_hi;
    uint valid_rays = chunk_rays(uvec2(px), o, nrm, rise, count, i, st_lo, st_hi);
    uint blocked = 0u;
    if (TRAVERSAL == PN_TRAVERSAL_PACKET_ID && params.split != PN_SPLIT_BUDGET_ID) {
        // The valid samples lie in [st_lo, st_hi] of the light's (s, t): the frustum's parallelogram.
        blocked = bvh_packet_blocked(o, valid_rays, st_lo, st_hi);
        shadow_finish(px, o, count, valid_rays, blocked, i < count);
        return;
    }
    for (uint j = 0u; j < count; j++) {
        bool hit = (valid_rays & (1u << j)) != 0u && bvh_blocked(o, dir[j], 0.0, 1.0);
        blocked |= hit ? (1u << j) : 0u;
        if (hit)
            blocker_at(j, last_hit_t());
    }
    shadow_finish(px, o, count, valid_rays, blocked, i < count);
}
