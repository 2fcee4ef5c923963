#version 460
#extension GL_GOOGLE_include_directive : require
// Shadow pass without occlusion: V = 1 on every pixel that holds geometry, 0 on the background.
// The line-space and exact shadow shaders replace it with the same bindings.
#include "interface.h"

layout(local_size_x = PN_WORKGROUP, local_size_y = PN_WORKGROUP) in;

layout(set = 0, binding = PN_SHADOW_BINDING_P, rgba32f) uniform readonly image2D img_p;
layout(set = 0, binding = PN_SHADOW_BINDING_N, rgba32f) uniform readonly image2D img_n;
layout(set = 0, binding = PN_SHADOW_BINDING_V, r32f) uniform writeonly image2D img_v;
layout(set = 0, binding = PN_SHADOW_BINDING_COUNTS, rgba32ui) uniform writeonly uimage2D img_counts;
layout(set = 0, binding = PN_SHADOW_BINDING_BLOCKERS, rg32f) uniform writeonly image2D img_blockers;

void main()
{
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(img_v))))
        return;
    float covered = imageLoad(img_p, px).w;
    imageStore(img_v, px, vec4(covered > 0.0 ? 1.0 : 0.0));
    // For the filter: one valid, visible sample where there is geometry (V = 1 is exact).
    imageStore(img_counts, px, covered > 0.0 ? uvec4(1u, 1u, 1u, floatBitsToUint(PN_PENUMBRA_NONE)) : uvec4(0u));
    imageStore(img_blockers, px, vec4(1.0, PN_PENUMBRA_NONE, 0.0, 0.0)); // no blocker
}
