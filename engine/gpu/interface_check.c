// The C side of the shader interface (shaders/glsl/interface.h) has the layout GLSL gives the
// same structs: std430 for storage buffers and push constants, std140 for ShadowParams. A wrong
// offset here fails the build; tests/test_interface.c reads every struct back on the GPU.
#include <stddef.h>

#include "interface.h"

#define AT(type, field, offset) _Static_assert(offsetof(type, field) == (offset), #type "." #field)
#define SIZE(type, bytes) _Static_assert(sizeof(type) == (bytes), "sizeof " #type)

AT(pn_gpu_node, min, 0);
AT(pn_gpu_node, size, 12);
AT(pn_gpu_node, children, 16);
AT(pn_gpu_node, parent, 28);
SIZE(pn_gpu_node, 32);

AT(pn_bvh_node, first, 12);
AT(pn_bvh_node, max, 16);
AT(pn_bvh_node, count, 28);
SIZE(pn_bvh_node, 32);

AT(pn_gpu_tree_info, root_size, 12);
AT(pn_gpu_tree_info, n, 16);
AT(pn_gpu_tree_info, node_count, 28);
AT(pn_gpu_tree_info, node_pool, 32); // 8-byte aligned references
AT(pn_gpu_tree_info, ls_pool, 48);
AT(pn_gpu_tree_info, plane_pool, 56);
SIZE(pn_gpu_tree_info, 64);

AT(pn_light_gpu, normal, 64);
AT(pn_light_gpu, radiance, 80);
SIZE(pn_light_gpu, 96);

AT(pn_material_gpu, texture, 16);
SIZE(pn_material_gpu, 32); // an array element: a multiple of its 16-byte alignment

AT(pn_gbuffer_push, eye, 64);
AT(pn_gbuffer_push, forward, 80);
AT(pn_gbuffer_push, material, 96);
SIZE(pn_gbuffer_push, 112); // the block's size rounded up to its 16-byte alignment

// std140: the struct member `tree` and vec4 arrays on 16-byte boundaries, references on 8.
AT(pn_shadow_params, tree, 0);
AT(pn_shadow_params, spp, 64);
AT(pn_shadow_params, leaf_size, 84);
AT(pn_shadow_params, canary, 88);
AT(pn_shadow_params, scene_mag, 92);
AT(pn_shadow_params, tris, 96);
AT(pn_shadow_params, dump, 136);
AT(pn_shadow_params, dump_rays, 144);
AT(pn_shadow_params, cand_first, 148);
AT(pn_shadow_params, work, 152);
AT(pn_shadow_params, tile_w, 160);
AT(pn_shadow_params, tile_h, 164);
AT(pn_shadow_params, object_count, 168);
AT(pn_shadow_params, objects, 176);
AT(pn_shadow_params, top_ids, 192);
AT(pn_shadow_params, budget, 204);
AT(pn_shadow_params, spp_min, 208);
AT(pn_shadow_params, alpha_bits, 224);
AT(pn_shadow_params, masked_tris, 232);
AT(pn_shadow_params, project_budget, 240);
AT(pn_shadow_params, unreached_v, 256);
AT(pn_shadow_params, lights, 272); // an array of structs: 16-byte aligned, stride 96 (a multiple of 16)
SIZE(pn_shadow_params, 272 + 96 * PN_MAX_LIGHTS);
AT(pn_gpu_object, tree, 0);
AT(pn_gpu_object, to_local, 64);
AT(pn_gpu_object, rise_scale, 112);
SIZE(pn_gpu_object, 128);

SIZE(pn_shadow_chunk, 32);

AT(pn_shade_push, light, 0);
AT(pn_shade_push, accumulate, 96);
SIZE(pn_shade_push, 112);

// FilterPush: std430 push constants.
SIZE(pn_filter_push, 32);
SIZE(pn_penumbra_push, 32);
AT(pn_filter_push, samples, 4);

// std140: the matrix, then the boxes and lights on 16-byte boundaries.
AT(pn_history_params, prev_eye, 64);
AT(pn_history_params, box_count, 96);
AT(pn_history_params, box_lo, 112);
AT(pn_history_params, box_hi, 112 + 16 * PN_HISTORY_MAX_BOXES);
AT(pn_history_params, lights, 112 + 32 * PN_HISTORY_MAX_BOXES);
AT(pn_history_params, eye, 112 + 32 * PN_HISTORY_MAX_BOXES + 96 * PN_MAX_LIGHTS);
AT(pn_history_params, view_proj, 144 + 32 * PN_HISTORY_MAX_BOXES + 96 * PN_MAX_LIGHTS);
AT(pn_history_params, frame, 208 + 32 * PN_HISTORY_MAX_BOXES + 96 * PN_MAX_LIGHTS);
SIZE(pn_history_params, 224 + 32 * PN_HISTORY_MAX_BOXES + 96 * PN_MAX_LIGHTS);
SIZE(pn_history_push, 16);
_Static_assert(PN_MAX_LIGHTS <= 32, "HistoryParams.drop_mask holds a bit per light");
