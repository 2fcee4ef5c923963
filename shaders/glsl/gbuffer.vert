#version 460
#extension GL_GOOGLE_include_directive : require
// G-buffer pass, vertex stage: world-space position and normal pass through; one matrix to clip.
#include "gbuffer.glsl"

layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;

layout(location = 0) out vec3 out_pos;
layout(location = 1) out vec3 out_normal;
layout(location = 2) out vec2 out_uv;

void main()
{
    out_pos = in_pos;
    out_normal = in_normal;
    out_uv = in_uv;
    gl_Position = pc.view_proj * vec4(in_pos, 1.0);
}
