#version 460
#extension GL_GOOGLE_include_directive : require
// Shading pass, once per light: outgoing radiance = sum over the lights of albedo / pi * E * V * L,
// linear HDR; alpha = coverage. The first light writes the radiance, the others add to it.
#include "interface.h"
// A pipeline per light kind (shade_pass.c): llvmpipe runs both sides of an `if`, so a shader for
// every kind evaluated every kind's irradiance (the disk's polygon, the sphere's acos and atan) at
// every pixel whatever the light.
layout(constant_id = PN_SPEC_LIGHT_KIND) const uint SHADE_LIGHT_KIND = PN_LIGHT_RECT_ID;
#define LIGHT_KIND_OF(l) SHADE_LIGHT_KIND
#include "light.glsl"

layout(local_size_x = PN_ROW_GROUP) in;

layout(set = 0, binding = PN_SHADE_BINDING_P, rgba32f) uniform readonly image2D img_p;
layout(set = 0, binding = PN_SHADE_BINDING_N, rgba32f) uniform readonly image2D img_n;
layout(set = 0, binding = PN_SHADE_BINDING_ALBEDO, rgba32f) uniform readonly image2D img_albedo;
layout(set = 0, binding = PN_SHADE_BINDING_V, r32f) uniform readonly image2D img_v;
layout(set = 0, binding = PN_SHADE_BINDING_OUT, rgba32f) uniform image2D img_out;

layout(push_constant) uniform ShadePushBlock { ShadePush pc; };

void main()
{
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(img_out))))
        return;
    vec4 p = imageLoad(img_p, px);
    if (p.w <= 0.0) {
        imageStore(img_out, px, vec4(0.0));
        return;
    }
    vec3 n = imageLoad(img_n, px).xyz;
    vec3 albedo = imageLoad(img_albedo, px).rgb;
    float v = imageLoad(img_v, px).r;
    float e = light_irradiance(pc.light, p.xyz, n);
    const float INV_PI = 0.31830988618379067;
    vec3 sum = pc.accumulate != 0u ? imageLoad(img_out, px).rgb : vec3(0.0);
    imageStore(img_out, px, vec4(sum + albedo * INV_PI * e * v * pc.light.radiance.rgb, 1.0));
}
