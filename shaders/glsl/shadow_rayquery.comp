#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_ray_query : require
// Exact soft shadows through the device's ray queries (--mode rayquery): every shadow ray is one
// query against the acceleration structure the device built (engine/gpu/tlas.c), ending at the
// first hit. Same rays as exact mode (origin, samples, segment); only the traversal and the
// triangle test are the driver's. Alpha-masked casters: the texel test is exact mode's
// (alpha.glsl), at the driver's barycentrics.
#include "shadow_common.glsl"
#include "shadow_frame.glsl"
#include "alpha.glsl"

layout(local_size_x = PN_WORKGROUP, local_size_y = PN_WORKGROUP) in;
layout(set = 0, binding = PN_SHADOW_BINDING_TLAS) uniform accelerationStructureEXT scene_as;

// Any hit of the segment o + t*d, t in [0, 1]: d is not normalised, so t is the same parameter
// as exact mode's (the light sample at t = 1). t_hit: the hit's t where it found one.
// An opaque scene (ALPHA off) is traced all opaque and the loop has nothing to do. With masked
// casters (ALPHA), their geometry is the one that is not opaque (gpu/tlas.h): the query commits a
// hit on the opaque one itself and hands each hit on a masked triangle to the loop, which commits
// it unless its texel is cut out; either commit ends the query (TerminateOnFirstHit).
bool rq_blocked(vec3 o, vec3 d, out float t_hit)
{
    rayQueryEXT q;
    uint flags = gl_RayFlagsTerminateOnFirstHitEXT | (ALPHA ? 0u : gl_RayFlagsOpaqueEXT);
    rayQueryInitializeEXT(q, scene_as, flags, 0xffu, o, 0.0, d, 1.0);
    while (rayQueryProceedEXT(q)) {
        if (ALPHA) { // a candidate: a triangle of the masked geometry, the only one not opaque
            uint tri = params.masked_tris.ids[rayQueryGetIntersectionPrimitiveIndexEXT(q, false)];
            // The driver's (u, v) weigh vertices 1 and 2 (b and c); alpha_cut takes a, b, c's.
            vec2 uv = rayQueryGetIntersectionBarycentricsEXT(q, false);
            if (!alpha_cut(alpha_record(tri), vec3(1.0 - uv.x - uv.y, uv.x, uv.y)))
                rayQueryConfirmIntersectionEXT(q);
        }
    }
    bool hit = rayQueryGetIntersectionTypeEXT(q, true) != gl_RayQueryCommittedIntersectionNoneEXT;
    t_hit = hit ? rayQueryGetIntersectionTEXT(q, true) : 1.0;
    return hit;
}

void main()
{
    ivec2 px = shadow_invocation_pixel(ivec2(gl_LocalInvocationID.xy));
    vec3 p, nrm;
    if (!shadow_pixel(px, p, nrm))
        return;
    float rise;
    vec3 o = shadow_origin(p, nrm, RISE_SHAFT_LEAVES, rise);
    uint count = chunk_count(p, nrm), i;
    vec2 st_lo, st_hi;
    uint valid_rays = chunk_rays(uvec2(px), o, nrm, rise, count, i, st_lo, st_hi);
    uint blocked = 0u;
    for (uint j = 0u; j < count; j++) {
        float t = 1.0;
        bool hit = (valid_rays & (1u << j)) != 0u && rq_blocked(o, dir[j], t);
        blocked |= hit ? (1u << j) : 0u;
        if (hit)
            blocker_at(j, t);
    }
    shadow_finish(px, o, count, valid_rays, blocked, i < count);
}
