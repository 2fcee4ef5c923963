#version 460
// Shadow pass without occlusion: V = 1 on every pixel that holds geometry, 0 on the background.
// The line-space and exact shadow shaders replace it with the same bindings.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D img_p;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D img_n;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D img_v;

void main()
{
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(px, imageSize(img_v))))
        return;
    float covered = imageLoad(img_p, px).w;
    imageStore(img_v, px, vec4(covered > 0.0 ? 1.0 : 0.0));
}
