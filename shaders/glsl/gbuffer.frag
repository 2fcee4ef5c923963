#version 460
#extension GL_GOOGLE_include_directive : require
// G-buffer pass, fragment stage. Outputs (all 32-bit float, cleared to 0 = background):
//   P: world position, w = 1 where geometry is
//   N: unit normal turned towards the viewer, w = view depth
//   albedo: baseColorFactor * baseColorTexture (linear), w = 1
#include "gbuffer.glsl"

layout(constant_id = PN_SPEC_TEXTURE_COUNT) const int TEXTURE_COUNT = 1;

layout(std430, set = 0, binding = PN_GBUFFER_BINDING_MATERIALS) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = PN_GBUFFER_BINDING_TEXTURES) uniform sampler2D textures[TEXTURE_COUNT];

layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(location = 0) out vec4 out_p;
layout(location = 1) out vec4 out_n;
layout(location = 2) out vec4 out_albedo;

void main()
{
    Material m = materials[pc.material];
    vec4 albedo = m.base_color;
    if (m.texture >= 0)
        albedo *= texture(textures[m.texture], in_uv); // sRGB format: sampled as linear
    // Alpha-masked: no surface where the alpha is below the cutoff (the shadow rays' alpha test:
    // alpha.glsl, at the nearest texel; this one filtered as the albedo).
    if (m.alpha_cutoff > 0.0 && albedo.a < m.alpha_cutoff)
        discard;
    // Interpolated normals shorten; surfaces are two-sided for shading, so face the viewer.
    vec3 n = normalize(in_normal);
    vec3 to_eye = pc.eye.xyz - in_pos;
    if (dot(n, to_eye) < 0.0)
        n = -n;
    out_p = vec4(in_pos, 1.0);
    out_n = vec4(n, dot(in_pos - pc.eye.xyz, pc.forward.xyz));
    out_albedo = vec4(albedo.rgb, 1.0);
}
