// Shared by gbuffer.vert/.frag; mirrors pn_gbuffer_push in engine/gpu/renderer.c.
layout(push_constant) uniform GBufferPush {
    mat4 view_proj;  // world -> Vulkan clip space (y down, depth 0..1)
    vec4 eye;        // camera position (xyz)
    vec4 forward;    // unit view direction (xyz): view depth = dot(P - eye, forward)
    uint material;   // index into materials[]
} pc;
