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

// The packet walk at 1-16 rays a pixel, shared by a block of pixels (exact.glsl: bvh_tile_blocked):
// invocation k of the work group takes block k of its 8 x 8 pixels (at 4 x 2 pixels a block, the
// first 8 invocations: one SIMD group, all its lanes busy); the others have no pixel. Only where
// every pixel's rays in the dispatch are the chunk's (uniform samples over the image and adaptive
// sampling's first round, not a budgeted split, not the later rounds over a list of pixels), so
// that the block's rays fit the per-ray arrays; not in adaptive sampling's decisions (a pixel per
// invocation, so that the pixel lists they write run in 4 x 2 groups), and not once the loop
// budget ran out (params.block_walk: pn_shadow_pass_end_frame).
void tile_main()
{
    uint idx = gl_LocalInvocationIndex;
    const uint across = PN_WORKGROUP / TILE_W;
    if (idx >= across * (PN_WORKGROUP / TILE_H))
        return;
    ivec2 base = ivec2(gl_WorkGroupID.xy) * PN_WORKGROUP + ivec2((idx % across) * TILE_W, (idx / across) * TILE_H);
    uint live = 0u, count[TILE_PIXELS], valid[TILE_PIXELS], ends[TILE_PIXELS];
    bool has[TILE_PIXELS];
    vec3 towards = vec3(0.0);
    for (uint k = 0u; k < TILE_PIXELS; k++) {
        ivec2 px = base + ivec2(k % TILE_W, k / TILE_W);
        vec3 p, nrm;
        has[k] = shadow_pixel(px, p, nrm);
        count[k] = 0u;
        valid[k] = 0u;
        ends[k] = 0u;
        if (has[k]) {
            float rise;
            vec3 o = shadow_origin(p, nrm, 0.0, rise);
            tile_o[k] = o;
            count[k] = chunk_count(p, nrm);
            vec2 st_lo, st_hi;
            valid[k] = chunk_rays_from(k * PACKET_RAYS, uvec2(px), o, nrm, rise, count[k], ends[k], st_lo, st_hi);
            live |= valid[k] << (k * PACKET_RAYS);
            towards += light_point(vec2(0.5)) - o;
        }
    }
    uint blocked = live != 0u ? bvh_tile_blocked(live, towards) : 0u;
    for (uint k = 0u; k < TILE_PIXELS; k++) {
        if (has[k]) {
            // A sphere's patch faces the pixel (light_patch): the penumbra width shadow_store
            // computes from it must be the pixel's own, not the block's last pixel's.
            if (LIGHT_KIND == PN_LIGHT_SPHERE_ID)
                light_patch(tile_o[k]);
            uint mine = (blocked >> (k * PACKET_RAYS)) & PIXEL_RAYS;
            shadow_finish_from(k * PACKET_RAYS, base + ivec2(k % TILE_W, k / TILE_W), tile_o[k], count[k], valid[k], mine,
                               ends[k] < count[k]);
            work = uvec4(0u); // the walk's work counted once, at the block's first pixel with geometry
        }
    }
    // llvmpipe: shadow_store reports a loop budget spent, but runs inside the loop above, which the
    // spent budget may end before any pixel of the block is stored.
    if (truncated || budget_spent())
        atomicOr(status.truncated, 1u);
}

void main()
{
    // The specialisation constants' tests last: a chain that starts with them made glslang emit an
    // undefined id (the pipeline would not build).
    if (TRAVERSAL == PN_TRAVERSAL_PACKET_ID && params.block_walk != 0u && SPLIT != PN_SPLIT_BUDGET_ID &&
        CHUNK_LIST_IN == 0u && CHUNK_DECIDE == 0u && TILE_PIXELS * PACKET_RAYS <= MAX_CHUNK && TILE_PIXELS > 1u) {
        tile_main();
        return;
    }
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
    if (TRAVERSAL == PN_TRAVERSAL_PACKET_ID && SPLIT != PN_SPLIT_BUDGET_ID) {
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
