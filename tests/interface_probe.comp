#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference_uvec2 : require
// Reads one instance of every struct of interface.h the way the engine's shaders receive it and
// writes every field back as 32-bit words, in declaration order, so that test_interface.c can
// compare each with what C put at that field's offset. References come back as their address
// (two words, low first), floats as their bits.
#include "interface.h"

layout(local_size_x = 1) in;
// As shadow_common.glsl declares it.
layout(set = 0, binding = 0, std140) uniform ShadowParamsBlock { ShadowParams params; };
// Arrays of two in std430 storage buffers (the second element checks the array stride).
layout(set = 0, binding = 1, std430) readonly buffer Nodes { Node nodes[]; };
layout(set = 0, binding = 2, std430) readonly buffer Bvh { BvhNodeData bvh[]; };
layout(set = 0, binding = 3, std430) readonly buffer Trees { TreeInfo trees[]; };
layout(set = 0, binding = 4, std430) readonly buffer Lights { Light lights[]; };
layout(set = 0, binding = 5, std430) readonly buffer Materials { Material materials[]; };
layout(set = 0, binding = 6, std430) writeonly buffer Out { uint values[]; };
// One push-constant block holds both push-constant structs (a stage has only one such block).
layout(push_constant) uniform Push { GBufferPush gb; ShadowChunk chunk; } pc;

uint o = 0u;
void put(uint v) { values[o++] = v; }
void put(int v) { put(uint(v)); }
void put(float v) { put(floatBitsToUint(v)); }
void put(uvec2 v) { put(v.x); put(v.y); }
void put(vec3 v) { put(v.x); put(v.y); put(v.z); }
void put(vec4 v) { put(v.xyz); put(v.w); }
void put(uvec4 v) { put(v.xy); put(v.zw); }

void put_tree(TreeInfo t)
{
    put(t.root_min); put(t.root_size); put(t.n); put(t.d); put(t.ls_words); put(t.node_count);
    put(uvec2(t.node_pool)); put(uvec2(t.tree_pool)); put(uvec2(t.ls_pool)); put(uvec2(t.plane_pool));
}

void put_light(Light l)
{
    for (int k = 0; k < 4; k++)
        put(l.corners[k]);
    put(l.normal); put(l.radiance);
}

void main()
{
    // Same order as the tables of test_interface.c.
    put_tree(params.tree);
    put(params.spp); put(params.grid_u); put(params.grid_v); put(params.sampler_kind);
    put(params.seed); put(params.leaf_size); put(params.canary); put(params.scene_mag);
    put(uvec2(params.tris)); put(uvec2(params.bvh)); put(uvec2(params.bvh_tris));
    put(uvec2(params.cand_offset)); put(uvec2(params.cand_tris)); put(uvec2(params.dump));
    put(params.dump_rays); put(params.cand_first); put(uvec2(params.work)); put(params.tile_w);
    put(params.tile_h); put(params.object_count); put(params.split);
    put(uvec2(params.objects)); put(uvec2(params.top)); put(uvec2(params.top_ids)); put(params.light_count); put(params.budget);
    put(params.spp_min); put(params.pixel_error); put(params.tiles_across); put(params.tile_total);
    put(uvec2(params.alpha_bits)); put(uvec2(params.masked_tris)); put(params.project_budget);
    put(params.block_walk); put(params.pixel_angle); put(params.refine_narrow);
    put(params.unreached_v); put(params.frame); put(params.frame_side); put(params.frame_part);
    for (int i = 0; i < PN_MAX_LIGHTS; i++)
        put_light(params.lights[i]);

    for (int i = 0; i < 2; i++) {
        Node n = nodes[i];
        put(n.min); put(n.size); put(n.children); put(n.level); put(n.linespace); put(n.parent);
    }
    for (int i = 0; i < 2; i++) {
        BvhNodeData b = bvh[i];
        put(b.min); put(b.first); put(b.max); put(b.count);
    }
    for (int i = 0; i < 2; i++)
        put_tree(trees[i]);
    for (int i = 0; i < 2; i++)
        put_light(lights[i]);
    for (int i = 0; i < 2; i++) {
        Material m = materials[i];
        put(m.base_color); put(m.texture); put(m.alpha_cutoff); put(m.pad1); put(m.pad2);
    }

    for (int c = 0; c < 4; c++)
        put(pc.gb.view_proj[c]);
    put(pc.gb.eye); put(pc.gb.forward);
    put(pc.gb.material); put(pc.gb.pad0); put(pc.gb.pad1); put(pc.gb.pad2);
    put(pc.chunk.sample_begin); put(pc.chunk.sample_end); put(pc.chunk.first); put(pc.chunk.last);
    put(pc.chunk.light); put(pc.chunk.decide); put(pc.chunk.list_in);
    put(pc.chunk.list_out);

    put(o + 1u); // the count of words written, this one included
}
