#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_ballot : require
// Exact soft shadows by projection (--mode exact --traversal project): exact's V, every light
// sample of a pixel answered by one walk of its pyramid to the light (project.glsl). A shader of
// its own: only it needs the subgroup's vote and ballot (the walk is shared by the subgroup).
#include "shadow_common.glsl"
#include "shadow_frame.glsl"
layout(constant_id = PN_SPEC_TRAVERSAL) const int TRAVERSAL = PN_TRAVERSAL_PROJECT_ID;
#include "exact.glsl"
#include "project.glsl"

layout(local_size_x = PN_WORKGROUP, local_size_y = PN_WORKGROUP) in;

void main()
{
    // llvmpipe: 8 consecutive invocations run as one SIMD group; map them to a 4x2 block of
    // pixels, whose pyramids to the light are nearly the same (the walk is shared by them).
    uint idx = gl_LocalInvocationIndex, block = idx / 8u, within = idx % 8u;
    ivec2 px = shadow_invocation_pixel(ivec2((block % 2u) * 4u + within % 4u, (block / 2u) * 2u + within / 4u));
    vec3 p, nrm;
    bool mine = shadow_pixel(px, p, nrm); // a pixel with samples in this dispatch
    if (LIGHT.radiance.w == 0.0) {
        // Every lane takes part in the shared walk, with a pixel of its own or not.
        project_pixel(px, p, nrm, mine);
        return;
    }
    // A point light (an omni light, or a rectangle of no size): one sample, whose plane is no
    // plane: its ray through the packet walk. The branch is the dispatch's, uniform.
    if (!mine)
        return;
    float rise;
    vec3 o = shadow_origin(p, nrm, 0.0, rise);
    uint count = chunk_count(p, nrm), i;
    vec2 st_lo, st_hi;
    uint valid_rays = chunk_rays(uvec2(px), o, nrm, rise, count, i, st_lo, st_hi);
    uint blocked = bvh_packet_blocked(o, valid_rays, st_lo, st_hi);
    shadow_finish(px, o, count, valid_rays, blocked, i < count);
}
