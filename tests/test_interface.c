// C and GLSL agree on every struct of shaders/glsl/interface.h: tests/interface_probe.comp receives
// one instance of each the way the engine's shaders do (ShadowParams in a std140 uniform block;
// Node, BvhNodeData, TreeInfo, Light and Material as std430 arrays of two, which checks the array
// stride; GBufferPush and ShadowChunk as push constants, the range being their C sizeof) and
// writes every field back in declaration order. Every word of every C struct holds a distinct
// value, so a field the GPU finds at another offset than C put it reads as a wrong value.
// interface_check.c pins the C offsets; this pins the GLSL ones to them.
#include <stddef.h>

#include "gpu/compute.h"
#include "gpu/resources.h"
#include "interface.h"
#include "interface_probe_comp.h"
#include "test_util.h"

// A field: its offset and size in 32-bit words; `sub` lists a struct member's own fields.
typedef struct field {
    const char *name;
    size_t offset, words;
    const struct field *sub;
} field;
#define F(type, f) {#f, offsetof(type, f), sizeof(((type *)0)->f) / 4, NULL}
#define SUB(type, f, fields) {#f, offsetof(type, f), sizeof(((type *)0)->f) / 4, fields}

// In the order of the shader's writes (and of the declarations); each ends with {0}.
static const field tree_fields[] = {
    F(pn_gpu_tree_info, root_min),  F(pn_gpu_tree_info, root_size), F(pn_gpu_tree_info, n),
    F(pn_gpu_tree_info, d),         F(pn_gpu_tree_info, ls_words),  F(pn_gpu_tree_info, node_count),
    F(pn_gpu_tree_info, node_pool), F(pn_gpu_tree_info, tree_pool), F(pn_gpu_tree_info, ls_pool),
    F(pn_gpu_tree_info, plane_pool), {0}};
static const field light_fields[] = {F(pn_light_gpu, corners), F(pn_light_gpu, normal), F(pn_light_gpu, radiance),
                                     {0}};
#define LIGHT(i) SUB(pn_shadow_params, lights[i], light_fields)
static const field params_fields[] = {
    SUB(pn_shadow_params, tree, tree_fields),
    F(pn_shadow_params, spp),                 F(pn_shadow_params, grid_u),      F(pn_shadow_params, grid_v),
    F(pn_shadow_params, sampler_kind),        F(pn_shadow_params, seed),        F(pn_shadow_params, leaf_size),
    F(pn_shadow_params, canary),              F(pn_shadow_params, scene_mag),       F(pn_shadow_params, tris),
    F(pn_shadow_params, bvh),                 F(pn_shadow_params, bvh_tris),    F(pn_shadow_params, cand_offset),
    F(pn_shadow_params, cand_tris),           F(pn_shadow_params, dump),        F(pn_shadow_params, dump_rays),
    F(pn_shadow_params, cand_first),          F(pn_shadow_params, work),        F(pn_shadow_params, tile_w),
    F(pn_shadow_params, tile_h),              F(pn_shadow_params, object_count), F(pn_shadow_params, split),
    F(pn_shadow_params, objects),             F(pn_shadow_params, top),         F(pn_shadow_params, top_ids),
    F(pn_shadow_params, light_count),         F(pn_shadow_params, budget),      F(pn_shadow_params, spp_min),
    F(pn_shadow_params, pixel_error),         F(pn_shadow_params, tiles_across), F(pn_shadow_params, tile_total),
    F(pn_shadow_params, alpha_bits),          F(pn_shadow_params, masked_tris), F(pn_shadow_params, project_budget),
    F(pn_shadow_params, block_walk),          F(pn_shadow_params, pixel_angle), F(pn_shadow_params, refine_narrow),
    F(pn_shadow_params, unreached_v),         F(pn_shadow_params, frame), F(pn_shadow_params, frame_side),
    F(pn_shadow_params, frame_part),
    LIGHT(0), LIGHT(1), LIGHT(2), LIGHT(3), LIGHT(4), LIGHT(5), LIGHT(6), LIGHT(7),
    LIGHT(8), LIGHT(9), LIGHT(10), LIGHT(11), LIGHT(12), LIGHT(13), LIGHT(14), LIGHT(15),
    {0}};
_Static_assert(PN_MAX_LIGHTS == 16, "params_fields lists every element of ShadowParams.lights");
static const field node_fields[] = {F(pn_gpu_node, min),       F(pn_gpu_node, size),      F(pn_gpu_node, children),
                                    F(pn_gpu_node, level),     F(pn_gpu_node, linespace), F(pn_gpu_node, parent),
                                    {0}};
static const field bvh_fields[] = {F(pn_bvh_node, min), F(pn_bvh_node, first), F(pn_bvh_node, max),
                                   F(pn_bvh_node, count), {0}};
static const field material_fields[] = {F(pn_material_gpu, base_color), F(pn_material_gpu, texture),
                                        F(pn_material_gpu, alpha_cutoff), F(pn_material_gpu, pad1),
                                        F(pn_material_gpu, pad2),       {0}};
static const field gbuffer_fields[] = {F(pn_gbuffer_push, view_proj), F(pn_gbuffer_push, eye),
                                       F(pn_gbuffer_push, forward),   F(pn_gbuffer_push, material),
                                       F(pn_gbuffer_push, pad0),      F(pn_gbuffer_push, pad1),
                                       F(pn_gbuffer_push, pad2),      {0}};
static const field chunk_fields[] = {F(pn_shadow_chunk, sample_begin), F(pn_shadow_chunk, sample_end),
                                     F(pn_shadow_chunk, first), F(pn_shadow_chunk, last),
                                     F(pn_shadow_chunk, light),
                                     F(pn_shadow_chunk, decide), F(pn_shadow_chunk, list_in),
                                     F(pn_shadow_chunk, list_out), {0}};

// The probe's push-constant block: both push-constant structs, one after the other.
typedef struct push {
    pn_gbuffer_push gb;
    pn_shadow_chunk chunk;
} push;
_Static_assert(offsetof(push, chunk) == sizeof(pn_gbuffer_push), "no padding between the push constants");

// One struct instance as the probe receives it.
typedef struct probed {
    const char *name;
    int index; // in its array, -1 for none
    void *c;
    size_t size;
    const field *fields;
} probed;

// Every word of [p, p + bytes) gets the bits of the float ++*k: distinct, and a normal float.
static void fill(void *p, size_t bytes, uint32_t *k)
{
    for (size_t i = 0; i < bytes / 4; i++) {
        float f = (float)++*k;
        memcpy((char *)p + 4 * i, &f, 4);
    }
}

static size_t covered(const field *f)
{
    size_t words = 0;
    for (; f->name; f++)
        words += f->words;
    return words;
}

// Compares the GPU's words from v[*o] on with the C fields of `c`; counts mismatches in *bad.
static void compare(const char *path, const char *c, const field *f, const uint32_t *v, uint32_t *o, unsigned *bad)
{
    for (; f->name; f++) {
        char name[128];
        snprintf(name, sizeof name, "%s.%s", path, f->name);
        if (f->sub) {
            compare(name, c + f->offset, f->sub, v, o, bad);
            continue;
        }
        for (size_t w = 0; w < f->words; w++, (*o)++) {
            uint32_t want;
            memcpy(&want, c + f->offset + 4 * w, 4);
            if (v[*o] != want && (*bad)++ < 12)
                fprintf(stderr, "%s word %zu (C offset %zu): GPU read 0x%08x, C wrote 0x%08x\n", name, w,
                        f->offset + 4 * w, v[*o], want);
        }
    }
}

int main(void)
{
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK)
        TEST_SKIP("no Vulkan device");

    pn_shadow_params params;
    pn_gpu_node nodes[2];
    pn_bvh_node bvh[2];
    pn_gpu_tree_info trees[2];
    pn_light_gpu lights[2];
    pn_material_gpu materials[2];
    push pc;
    // Binding i + 1 of the probe is inputs[i]; the bindings' order is the shader's.
    const struct {
        void *data;
        size_t size, count;
        const char *name;
        const field *fields;
    } inputs[] = {{nodes, sizeof nodes[0], 2, "Node", node_fields},
                  {bvh, sizeof bvh[0], 2, "BvhNodeData", bvh_fields},
                  {trees, sizeof trees[0], 2, "TreeInfo", tree_fields},
                  {lights, sizeof lights[0], 2, "Light", light_fields},
                  {materials, sizeof materials[0], 2, "Material", material_fields}};
    enum { INPUTS = sizeof inputs / sizeof inputs[0] };
    // Everything the shader writes, in its order.
    probed order[1 + 2 * INPUTS + 2] = {{"ShadowParams", -1, &params, sizeof params, params_fields}};
    size_t count = 1;
    for (int i = 0; i < INPUTS; i++)
        for (size_t e = 0; e < inputs[i].count; e++)
            order[count++] = (probed){inputs[i].name, (int)e, (char *)inputs[i].data + e * inputs[i].size,
                                      inputs[i].size, inputs[i].fields};
    order[count++] = (probed){"GBufferPush", -1, &pc.gb, sizeof pc.gb, gbuffer_fields};
    order[count++] = (probed){"ShadowChunk", -1, &pc.chunk, sizeof pc.chunk, chunk_fields};

    uint32_t k = 0, words = 0;
    for (size_t i = 0; i < count; i++) {
        fill(order[i].c, order[i].size, &k);
        // Padding is explicit in interface.h: every word belongs to a field the probe reads.
        CHECK_MSG(covered(order[i].fields) * 4 == order[i].size, "%s: the probe reads %zu of its %zu bytes",
                  order[i].name, covered(order[i].fields) * 4, order[i].size);
        words += (uint32_t)covered(order[i].fields);
    }

    VkDescriptorSetLayoutBinding b[INPUTS + 2] = {{.binding = 0, .descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER}};
    for (uint32_t i = 1; i < INPUTS + 2; i++)
        b[i] = (VkDescriptorSetLayoutBinding){.binding = i, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER};
    pn_gpu_compute c;
    CHECK(pn_gpu_compute_create(&dev,
                                &(pn_gpu_compute_desc){.spirv = pn_spv_interface_probe_comp,
                                                       .spirv_size = sizeof pn_spv_interface_probe_comp,
                                                       .bindings = b,
                                                       .binding_count = INPUTS + 2,
                                                       .push_size = sizeof pc},
                                &c) == PN_OK);
    pn_gpu_buffer in[INPUTS + 1], out;
    CHECK(pn_gpu_buffer_create_with_data(&dev, "probe parameters", &params, sizeof params, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, &in[0]) ==
          PN_OK);
    pn_gpu_compute_write_uniform(&dev, &c, 0, in[0].buffer);
    for (uint32_t i = 0; i < INPUTS; i++) {
        CHECK(pn_gpu_buffer_create_with_data(&dev, "probe input", inputs[i].data, inputs[i].size * inputs[i].count,
                                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &in[i + 1]) == PN_OK);
        pn_gpu_compute_write_buffer(&dev, &c, i + 1, in[i + 1].buffer);
    }
    CHECK(pn_gpu_buffer_create(&dev, "probe output", (words + 2) * 4ull, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, PN_GPU_HOST_READBACK,
                               &out) == PN_OK);
    memset(out.mapped, 0xee, (words + 2) * 4ull);
    pn_gpu_compute_write_buffer(&dev, &c, INPUTS + 1, out.buffer);

    VkCommandBuffer cmd;
    CHECK(pn_gpu_begin_once(&dev, &cmd) == PN_OK);
    pn_gpu_compute_dispatch(cmd, &c, sizeof pc, &pc, 1, 1, 1);
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                           .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                           .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
                                           .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT},
                       0, NULL);
    CHECK(pn_gpu_submit_wait(&dev, cmd) == PN_OK);

    const uint32_t *v = out.mapped;
    uint32_t o = 0;
    unsigned bad = 0;
    for (size_t i = 0; i < count; i++) {
        char name[64];
        if (order[i].index < 0)
            snprintf(name, sizeof name, "%s", order[i].name);
        else
            snprintf(name, sizeof name, "%s[%d]", order[i].name, order[i].index);
        compare(name, order[i].c, order[i].fields, v, &o, &bad);
    }
    CHECK_MSG(bad == 0, "%u of %u words differ", bad, words);
    CHECK_MSG(v[words] == words + 1 && v[words + 1] == 0xeeeeeeeeu, "the probe wrote %u words, C expected %u",
              v[words] - 1, words);
    fprintf(stderr, "%zu struct instances, %u words probed\n", count, words);

    pn_gpu_compute_destroy(&dev, &c);
    for (int i = 0; i < INPUTS + 1; i++)
        pn_gpu_buffer_destroy(&dev, &in[i]);
    pn_gpu_buffer_destroy(&dev, &out);
    pn_gpu_device_destroy(&dev);
    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    return pn_test_result();
}
