#include "gpu/renderer.h"

#include <cglm/cglm.h>
#include <cglm/clipspace/persp_rh_zo.h> // Vulkan depth range 0..1, whatever cglm defaults to
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gbuffer_frag.h"
#include "gbuffer_vert.h"
#include "shade_comp.h"
#include "shadow_exact_comp.h"
#include "shadow_linespace_comp.h"
#include "shadow_none_comp.h"

// Mirrors GBufferPush in shaders/glsl/gbuffer.glsl.
typedef struct pn_gbuffer_push {
    float view_proj[16];
    float eye[4];
    float forward[4];
    uint32_t material;
} pn_gbuffer_push;

// Mirrors Light in shaders/glsl/light.glsl.
typedef struct pn_light_gpu {
    float corners[4][4];
    float normal[4];
    float radiance[4];
} pn_light_gpu;

// Mirrors ShadowParams in shaders/glsl/shadow_common.glsl (std140).
typedef struct pn_shadow_params {
    pn_gpu_tree_info tree;
    float corners[4][4];
    float light_normal[4];
    uint32_t spp, grid_u, grid_v, sampler, seed;
    float leaf_size;
    uint32_t canary; // 2, see budget_spent in shadow_common.glsl
    uint32_t pad;
    uint64_t tris, bvh, bvh_tris, cand_offset, cand_tris; // buffer device addresses
    uint64_t dump;
    uint32_t dump_rays, cand_first;
    uint64_t work; // COUNT_WORK builds
    uint32_t pad3[2];
} pn_shadow_params;

uint32_t pn_shadow_samples(uint32_t spp, const pn_light *light) { return pn_light_is_point(light) ? 1 : spp; }

void pn_sample_grid(uint32_t spp, uint32_t *grid_u, uint32_t *grid_v)
{
    uint32_t u = 1;
    for (uint32_t i = 1; i * i <= spp; i++)
        if (spp % i == 0)
            u = i;
    *grid_u = u;
    *grid_v = spp / u;
}

// Mirrors the Chunk push constants of shaders/glsl/shadow_common.glsl.
typedef struct pn_shadow_chunk {
    uint32_t sample_begin, sample_end, first, last;
} pn_shadow_chunk;

enum { TS_START, TS_GBUFFER, TS_SHADOW, TS_SHADE, TS_COUNT };

static const VkFormat FMT_RGBA32F = VK_FORMAT_R32G32B32A32_SFLOAT;
static const VkFormat FMT_DEPTH = VK_FORMAT_D32_SFLOAT;

// ---------------------------------------------------------------------------------------------
// Scene upload

static pn_result upload_scene(pn_renderer *r, const pn_scene *s)
{
    pn_gpu_device *dev = r->dev;
    PN_TRY(pn_gpu_buffer_create_with_data(dev, s->vertices, (VkDeviceSize)s->vertex_count * sizeof(pn_vertex),
                                          VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                          &r->vertices));
    PN_TRY(pn_gpu_buffer_create_with_data(dev, s->indices, (VkDeviceSize)s->index_count * sizeof(uint32_t),
                                          VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                          &r->indices));
    // Mirrors Material in gbuffer.frag: vec4 base_color, int texture, 3 ints of padding.
    typedef struct {
        float base_color[4];
        int32_t texture, pad[3];
    } gpu_material;
    gpu_material *m = calloc(s->material_count, sizeof *m);
    if (!m)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < s->material_count; i++) {
        memcpy(m[i].base_color, s->materials[i].base_color, sizeof m[i].base_color);
        m[i].texture = s->materials[i].texture;
    }
    pn_result res = pn_gpu_buffer_create_with_data(dev, m, s->material_count * sizeof *m,
                                                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->materials);
    free(m);
    PN_TRY(res);

    r->texture_count = s->texture_count ? s->texture_count : 1;
    r->textures = calloc(r->texture_count, sizeof *r->textures);
    if (!r->textures)
        return PN_ERR_MEMORY;
    if (s->texture_count == 0) {
        static const uint8_t white[4] = {255, 255, 255, 255};
        PN_TRY(pn_gpu_texture_create(dev, 1, 1, white, &r->textures[0]));
    }
    for (uint32_t i = 0; i < s->texture_count; i++)
        PN_TRY(pn_gpu_texture_create(dev, s->textures[i].width, s->textures[i].height, s->textures[i].rgba,
                                     &r->textures[i]));
    VkSamplerCreateInfo si = {
        .sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO,
        .magFilter = VK_FILTER_LINEAR,
        .minFilter = VK_FILTER_LINEAR,
        .mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR,
        .addressModeU = VK_SAMPLER_ADDRESS_MODE_REPEAT,
        .addressModeV = VK_SAMPLER_ADDRESS_MODE_REPEAT,
        .addressModeW = VK_SAMPLER_ADDRESS_MODE_REPEAT,
        .maxLod = VK_LOD_CLAMP_NONE,
    };
    VK_CHECK(vkCreateSampler(dev->device, &si, NULL, &r->sampler));

    r->draws = malloc(s->draw_count * sizeof *r->draws);
    if (!r->draws)
        return PN_ERR_MEMORY;
    memcpy(r->draws, s->draws, s->draw_count * sizeof *r->draws);
    r->draw_count = s->draw_count;
    memcpy(r->scene_min, s->bounds_min, sizeof r->scene_min);
    memcpy(r->scene_max, s->bounds_max, sizeof r->scene_max);
    return PN_OK;
}

// ---------------------------------------------------------------------------------------------
// Targets

static pn_result create_targets(pn_renderer *r)
{
    pn_gpu_device *dev = r->dev;
    const VkImageUsageFlags gbuf = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT |
                                   VK_IMAGE_USAGE_TRANSFER_DST_BIT | // pn_renderer_set_gbuffer
                                   VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    const VkImageUsageFlags comp = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    struct {
        pn_gpu_image *img;
        VkFormat format;
        VkImageUsageFlags usage;
        VkImageAspectFlags aspect;
    } t[] = {
        {&r->p, FMT_RGBA32F, gbuf, 0},
        {&r->n, FMT_RGBA32F, gbuf, 0},
        {&r->albedo, FMT_RGBA32F, gbuf, 0},
        {&r->depth, FMT_DEPTH, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_IMAGE_ASPECT_DEPTH_BIT},
        {&r->v, VK_FORMAT_R32_SFLOAT, comp, 0},
        {&r->radiance, FMT_RGBA32F, comp, 0},
        {&r->counts, VK_FORMAT_R32G32_UINT, VK_IMAGE_USAGE_STORAGE_BIT, 0},
    };
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++)
        PN_TRY(pn_gpu_image_create(dev,
                                   &(pn_gpu_image_desc){.format = t[i].format,
                                                        .width = r->width,
                                                        .height = r->height,
                                                        .usage = t[i].usage,
                                                        .aspect = t[i].aspect},
                                   t[i].img));
    VkDeviceSize px = (VkDeviceSize)r->width * r->height;
    PN_TRY(pn_gpu_buffer_create(dev, px * (4 * 16 + 4), VK_BUFFER_USAGE_TRANSFER_DST_BIT, PN_GPU_HOST_READBACK,
                                &r->readback));
    VkQueryPoolCreateInfo qi = {
        .sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
        .queryType = VK_QUERY_TYPE_TIMESTAMP,
        .queryCount = TS_COUNT,
    };
    VK_CHECK(vkCreateQueryPool(dev->device, &qi, NULL, &r->timestamps));
    VkCommandBufferAllocateInfo ai = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = dev->cmd_pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    VK_CHECK(vkAllocateCommandBuffers(dev->device, &ai, &r->cmd));
    return PN_OK;
}

// ---------------------------------------------------------------------------------------------
// Pipelines

static pn_result shader_module(pn_gpu_device *dev, const uint32_t *code, size_t size, VkShaderModule *out)
{
    VkShaderModuleCreateInfo ci = {.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO, .codeSize = size, .pCode = code};
    VK_CHECK(vkCreateShaderModule(dev->device, &ci, NULL, out));
    return PN_OK;
}

static pn_result set_layout(pn_gpu_device *dev, const VkDescriptorSetLayoutBinding *b, uint32_t n,
                            VkDescriptorSetLayout *out)
{
    VkDescriptorSetLayoutCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
        .bindingCount = n,
        .pBindings = b,
    };
    VK_CHECK(vkCreateDescriptorSetLayout(dev->device, &ci, NULL, out));
    return PN_OK;
}

static pn_result pipeline_layout(pn_gpu_device *dev, VkDescriptorSetLayout set, VkShaderStageFlags stages,
                                 uint32_t push_size, VkPipelineLayout *out)
{
    VkPushConstantRange range = {.stageFlags = stages, .size = push_size};
    VkPipelineLayoutCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
        .setLayoutCount = 1,
        .pSetLayouts = &set,
        .pushConstantRangeCount = push_size ? 1 : 0,
        .pPushConstantRanges = &range,
    };
    VK_CHECK(vkCreatePipelineLayout(dev->device, &ci, NULL, out));
    return PN_OK;
}

static pn_result gbuffer_pipeline(pn_renderer *r)
{
    pn_gpu_device *dev = r->dev;
    VkShaderModule vs, fs;
    PN_TRY(shader_module(dev, pn_spv_gbuffer_vert, sizeof pn_spv_gbuffer_vert, &vs));
    pn_result res = shader_module(dev, pn_spv_gbuffer_frag, sizeof pn_spv_gbuffer_frag, &fs);
    if (res != PN_OK) {
        vkDestroyShaderModule(dev->device, vs, NULL);
        return res;
    }
    int32_t texture_count = (int32_t)r->texture_count;
    VkSpecializationMapEntry entry = {.constantID = 0, .offset = 0, .size = sizeof texture_count};
    VkSpecializationInfo spec = {.mapEntryCount = 1, .pMapEntries = &entry, .dataSize = sizeof texture_count, .pData = &texture_count};
    VkPipelineShaderStageCreateInfo stages[2] = {
        {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, .stage = VK_SHADER_STAGE_VERTEX_BIT, .module = vs, .pName = "main"},
        {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
         .stage = VK_SHADER_STAGE_FRAGMENT_BIT,
         .module = fs,
         .pName = "main",
         .pSpecializationInfo = &spec},
    };
    VkVertexInputBindingDescription binding = {.binding = 0, .stride = sizeof(pn_vertex), .inputRate = VK_VERTEX_INPUT_RATE_VERTEX};
    VkVertexInputAttributeDescription attrs[3] = {
        {.location = 0, .binding = 0, .format = VK_FORMAT_R32G32B32_SFLOAT, .offset = offsetof(pn_vertex, pos)},
        {.location = 1, .binding = 0, .format = VK_FORMAT_R32G32B32_SFLOAT, .offset = offsetof(pn_vertex, normal)},
        {.location = 2, .binding = 0, .format = VK_FORMAT_R32G32_SFLOAT, .offset = offsetof(pn_vertex, uv)},
    };
    VkPipelineVertexInputStateCreateInfo vi = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO,
        .vertexBindingDescriptionCount = 1,
        .pVertexBindingDescriptions = &binding,
        .vertexAttributeDescriptionCount = 3,
        .pVertexAttributeDescriptions = attrs,
    };
    VkPipelineInputAssemblyStateCreateInfo ia = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO,
        .topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST,
    };
    VkPipelineViewportStateCreateInfo vp = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO,
        .viewportCount = 1,
        .scissorCount = 1,
    };
    // No culling: open meshes (Sponza's walls, the ground) are seen from both sides.
    VkPipelineRasterizationStateCreateInfo rs = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO,
        .polygonMode = VK_POLYGON_MODE_FILL,
        .cullMode = VK_CULL_MODE_NONE,
        .lineWidth = 1.0f,
    };
    VkPipelineMultisampleStateCreateInfo ms = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO,
        .rasterizationSamples = VK_SAMPLE_COUNT_1_BIT,
    };
    // Reversed Z (near = 1, far = 0) with a float depth buffer: nearly uniform relative precision.
    VkPipelineDepthStencilStateCreateInfo ds = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO,
        .depthTestEnable = VK_TRUE,
        .depthWriteEnable = VK_TRUE,
        .depthCompareOp = VK_COMPARE_OP_GREATER,
    };
    VkPipelineColorBlendAttachmentState blend[3] = {{.colorWriteMask = 0xf}, {.colorWriteMask = 0xf}, {.colorWriteMask = 0xf}};
    VkPipelineColorBlendStateCreateInfo cb = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO,
        .attachmentCount = 3,
        .pAttachments = blend,
    };
    VkDynamicState dyn[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dy = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO,
        .dynamicStateCount = 2,
        .pDynamicStates = dyn,
    };
    VkFormat colors[3] = {FMT_RGBA32F, FMT_RGBA32F, FMT_RGBA32F};
    VkPipelineRenderingCreateInfo ri = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO,
        .colorAttachmentCount = 3,
        .pColorAttachmentFormats = colors,
        .depthAttachmentFormat = FMT_DEPTH,
    };
    VkGraphicsPipelineCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO,
        .pNext = &ri,
        .stageCount = 2,
        .pStages = stages,
        .pVertexInputState = &vi,
        .pInputAssemblyState = &ia,
        .pViewportState = &vp,
        .pRasterizationState = &rs,
        .pMultisampleState = &ms,
        .pDepthStencilState = &ds,
        .pColorBlendState = &cb,
        .pDynamicState = &dy,
        .layout = r->gbuffer_layout,
    };
    VkResult vr = vkCreateGraphicsPipelines(dev->device, VK_NULL_HANDLE, 1, &ci, NULL, &r->gbuffer_pipeline);
    vkDestroyShaderModule(dev->device, vs, NULL);
    vkDestroyShaderModule(dev->device, fs, NULL);
    VK_CHECK(vr);
    return PN_OK;
}

static pn_result create_pipelines(pn_renderer *r)
{
    pn_gpu_device *dev = r->dev;
    VkDescriptorSetLayoutBinding gb[2] = {
        {.binding = 0, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .descriptorCount = 1, .stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT},
        {.binding = 1,
         .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
         .descriptorCount = r->texture_count,
         .stageFlags = VK_SHADER_STAGE_FRAGMENT_BIT},
    };
    PN_TRY(set_layout(dev, gb, 2, &r->gbuffer_set_layout));
    PN_TRY(pipeline_layout(dev, r->gbuffer_set_layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                           sizeof(pn_gbuffer_push), &r->gbuffer_layout));
    PN_TRY(gbuffer_pipeline(r));

    const VkDescriptorSetLayoutBinding img[5] = {
        {.binding = 0, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
        {.binding = 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
        {.binding = 2, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
        {.binding = 3, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
        {.binding = 4, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
    };
    // Every shadow shader sees the same set: P, N, V and the parameters.
    const VkDescriptorSetLayoutBinding shadow_bindings[6] = {
        img[0], img[1], img[2], {.binding = 3, .descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER}, img[4],
        {.binding = 5, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}};
    // Specialisation of the shadow shaders: TRAVERSAL (id 0), MODE (id 1: 0 linespace, 1 hybrid,
    // 2 exact-ls) and COUNT_WORK (id 2, a 32-bit bool).
    int32_t spec_data[3] = {(int32_t)r->desc.traversal, (int32_t)r->desc.mode - PN_SHADOW_LINESPACE,
                            r->desc.count_work ? 1 : 0};
    VkSpecializationMapEntry entries[3] = {{.constantID = 0, .offset = 0, .size = 4},
                                           {.constantID = 1, .offset = 4, .size = 4},
                                           {.constantID = 2, .offset = 8, .size = 4}};
    VkSpecializationInfo spec = {.mapEntryCount = 3, .pMapEntries = entries, .dataSize = sizeof spec_data, .pData = spec_data};
    bool ls = r->desc.mode >= PN_SHADOW_LINESPACE && r->desc.mode <= PN_SHADOW_EXACT_LS;
    const uint32_t *spirv = pn_spv_shadow_none_comp;
    size_t spirv_size = sizeof pn_spv_shadow_none_comp;
    if (ls) {
        spirv = pn_spv_shadow_linespace_comp;
        spirv_size = sizeof pn_spv_shadow_linespace_comp;
    } else if (r->desc.mode == PN_SHADOW_EXACT) {
        spirv = pn_spv_shadow_exact_comp;
        spirv_size = sizeof pn_spv_shadow_exact_comp;
    }
    PN_TRY(pn_gpu_compute_create(dev,
                                 &(pn_gpu_compute_desc){.spirv = spirv,
                                                        .spirv_size = spirv_size,
                                                        .bindings = shadow_bindings,
                                                        .binding_count = 6,
                                                        .push_size = sizeof(pn_shadow_chunk),
                                                        .spec = &spec},
                                 &r->shadow));
    PN_TRY(pn_gpu_buffer_create(dev, sizeof(pn_shadow_params), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, PN_GPU_HOST_UPLOAD,
                                &r->shadow_params));
    pn_gpu_compute_write_uniform(dev, &r->shadow, 3, r->shadow_params.buffer);
    if (r->desc.count_work)
        PN_TRY(pn_gpu_buffer_create(dev, (uint64_t)r->width * r->height * 16,
                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT,
                                    PN_GPU_HOST_READBACK, &r->work));
    if (r->desc.dump_rays) {
        uint64_t px = (uint64_t)r->width * r->height;
        PN_TRY(pn_gpu_buffer_create(dev, px * (1 + r->desc.spp) * 16,
                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT,
                                    PN_GPU_HOST_READBACK, &r->ray_dump));
        memset(r->ray_dump.mapped, 0, px * (1 + r->desc.spp) * 16);
    }
    PN_TRY(pn_gpu_buffer_create(dev, sizeof(uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, PN_GPU_HOST_READBACK,
                                &r->shadow_status));
    pn_gpu_compute_write_image(dev, &r->shadow, 4, r->counts.view);
    pn_gpu_compute_write_buffer(dev, &r->shadow, 5, r->shadow_status.buffer);
    PN_TRY(pn_gpu_compute_create(dev,
                                 &(pn_gpu_compute_desc){.spirv = pn_spv_shade_comp,
                                                        .spirv_size = sizeof pn_spv_shade_comp,
                                                        .bindings = img,
                                                        .binding_count = 5,
                                                        .push_size = sizeof(pn_light_gpu)},
                                 &r->shade));
    const pn_gpu_image *shadow_imgs[3] = {&r->p, &r->n, &r->v};
    for (uint32_t i = 0; i < 3; i++)
        pn_gpu_compute_write_image(dev, &r->shadow, i, shadow_imgs[i]->view);
    const pn_gpu_image *shade_imgs[5] = {&r->p, &r->n, &r->albedo, &r->v, &r->radiance};
    for (uint32_t i = 0; i < 5; i++)
        pn_gpu_compute_write_image(dev, &r->shade, i, shade_imgs[i]->view);

    VkDescriptorPoolSize sizes[2] = {
        {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1},
        {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, r->texture_count},
    };
    VkDescriptorPoolCreateInfo pi = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
        .maxSets = 1,
        .poolSizeCount = 2,
        .pPoolSizes = sizes,
    };
    VK_CHECK(vkCreateDescriptorPool(dev->device, &pi, NULL, &r->descriptor_pool));
    VkDescriptorSetAllocateInfo ai = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
        .descriptorPool = r->descriptor_pool,
        .descriptorSetCount = 1,
        .pSetLayouts = &r->gbuffer_set_layout,
    };
    VK_CHECK(vkAllocateDescriptorSets(dev->device, &ai, &r->gbuffer_set));

    VkDescriptorImageInfo *tex = calloc(r->texture_count, sizeof *tex);
    if (!tex)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < r->texture_count; i++)
        tex[i] = (VkDescriptorImageInfo){r->sampler, r->textures[i].view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkDescriptorBufferInfo mat = {r->materials.buffer, 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet w[2];
    uint32_t nw = 0;
    w[nw++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .dstSet = r->gbuffer_set, .dstBinding = 0,
                                     .descriptorCount = 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .pBufferInfo = &mat};
    w[nw++] = (VkWriteDescriptorSet){.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .dstSet = r->gbuffer_set, .dstBinding = 1,
                                     .descriptorCount = r->texture_count,
                                     .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, .pImageInfo = tex};
    vkUpdateDescriptorSets(dev->device, nw, w, 0, NULL);
    free(tex);
    return PN_OK;
}

// ---------------------------------------------------------------------------------------------

pn_result pn_renderer_create(pn_gpu_device *dev, const pn_scene *scene, const pn_renderer_desc *desc,
                             pn_renderer *out)
{
    memset(out, 0, sizeof *out);
    out->dev = dev;
    out->desc = *desc;
    uint32_t width = desc->width, height = desc->height;
    out->width = width;
    out->height = height;
    if (desc->mode >= PN_SHADOW_LINESPACE && desc->mode <= PN_SHADOW_EXACT_LS && !desc->pools) {
        pn_error("line-space shadows need the N-tree's pools");
        return PN_ERR_INVALID;
    }
    if (desc->mode >= PN_SHADOW_HYBRID && !desc->exact) {
        pn_error("exact shadow tests need the triangle pools");
        return PN_ERR_INVALID;
    }
    // Samples per shadow dispatch: small enough that a pixel's loops stay below llvmpipe's budget
    // of 65535 iterations (a ray takes tens), halved when that is not enough. 32 (the shader's
    // MAX_CHUNK) runs 25 spp in one dispatch; the per-ray walk balances its lanes better the more
    // rays each has, and the packet walk does fewer walks.
    out->chunk = 32;
    if (desc->spp == 0 && desc->mode != PN_SHADOW_NONE) {
        pn_error("spp must be at least 1");
        return PN_ERR_INVALID;
    }
    const VkPhysicalDeviceLimits *lim = &dev->props.limits;
    if (width == 0 || height == 0 || width > lim->maxImageDimension2D || height > lim->maxImageDimension2D) {
        pn_error("image size %ux%u outside the device's 1..%u", width, height, lim->maxImageDimension2D);
        return PN_ERR_INVALID;
    }
    if (scene->texture_count > lim->maxPerStageDescriptorSampledImages) {
        pn_error("%s: %u textures, the device allows %u", scene->name, scene->texture_count,
                 lim->maxPerStageDescriptorSampledImages);
        return PN_ERR_UNSUPPORTED;
    }
    pn_result r = upload_scene(out, scene);
    if (r == PN_OK)
        r = create_targets(out);
    if (r == PN_OK)
        r = create_pipelines(out);
    if (r != PN_OK)
        pn_renderer_destroy(out);
    return r;
}

void pn_renderer_destroy(pn_renderer *r)
{
    pn_gpu_device *dev = r->dev;
    if (!dev || !dev->device) {
        memset(r, 0, sizeof *r);
        return;
    }
    VkDevice d = dev->device;
    vkDeviceWaitIdle(d);
    if (r->cmd)
        vkFreeCommandBuffers(d, dev->cmd_pool, 1, &r->cmd);
    if (r->timestamps)
        vkDestroyQueryPool(d, r->timestamps, NULL);
    pn_gpu_compute_destroy(dev, &r->shadow);
    pn_gpu_compute_destroy(dev, &r->shade);
    if (r->gbuffer_pipeline)
        vkDestroyPipeline(d, r->gbuffer_pipeline, NULL);
    if (r->gbuffer_layout)
        vkDestroyPipelineLayout(d, r->gbuffer_layout, NULL);
    if (r->gbuffer_set_layout)
        vkDestroyDescriptorSetLayout(d, r->gbuffer_set_layout, NULL);
    if (r->descriptor_pool)
        vkDestroyDescriptorPool(d, r->descriptor_pool, NULL);
    pn_gpu_image *imgs[7] = {&r->p, &r->n, &r->albedo, &r->depth, &r->v, &r->radiance, &r->counts};
    for (int i = 0; i < 7; i++)
        pn_gpu_image_destroy(dev, imgs[i]);
    pn_gpu_buffer_destroy(dev, &r->readback);
    pn_gpu_buffer_destroy(dev, &r->shadow_params);
    pn_gpu_buffer_destroy(dev, &r->shadow_status);
    pn_gpu_buffer_destroy(dev, &r->gbuffer_upload);
    pn_gpu_buffer_destroy(dev, &r->work);
    pn_gpu_buffer_destroy(dev, &r->ray_dump);
    for (uint32_t i = 0; r->textures && i < r->texture_count; i++)
        pn_gpu_image_destroy(dev, &r->textures[i]);
    free(r->textures);
    if (r->sampler)
        vkDestroySampler(d, r->sampler, NULL);
    pn_gpu_buffer_destroy(dev, &r->vertices);
    pn_gpu_buffer_destroy(dev, &r->indices);
    pn_gpu_buffer_destroy(dev, &r->materials);
    free(r->draws);
    memset(r, 0, sizeof *r);
}

// ---------------------------------------------------------------------------------------------
// The frame

static void camera_matrices(const pn_renderer *r, const pn_camera *cam, pn_gbuffer_push *push)
{
    vec3 eye = {cam->pos[0], cam->pos[1], cam->pos[2]};
    vec3 target = {cam->target[0], cam->target[1], cam->target[2]};
    vec3 up = {cam->up[0], cam->up[1], cam->up[2]};
    vec3 fwd;
    glm_vec3_sub(target, eye, fwd);
    glm_vec3_normalize(fwd);
    // Clip planes enclose the scene's bounding sphere. Far/near is capped at 2^20: with reversed Z
    // in a float depth buffer that still leaves about 2^-3 relative depth resolution... per ulp
    // of the float exponent range, far more than 24-bit fixed point gives.
    vec3 c;
    float rad = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5f * (r->scene_min[k] + r->scene_max[k]);
        float e = r->scene_max[k] - r->scene_min[k];
        rad += e * e;
    }
    rad = 0.5f * sqrtf(rad);
    float dist = glm_vec3_distance(eye, c);
    float zfar = (dist + rad) * 1.01f;
    float znear = fmaxf(dist - rad, 0.0f) * 0.99f;
    if (znear < zfar * 0x1p-20f)
        znear = zfar * 0x1p-20f;
    mat4 view, proj, vp;
    glm_lookat_rh(eye, target, up, view);
    float aspect = (float)r->width / (float)r->height;
    // Swapping near and far in a 0..1 projection gives reversed Z.
    glm_perspective_rh_zo(glm_rad(cam->yfov_deg), aspect, zfar, znear, proj);
    proj[1][1] = -proj[1][1]; // Vulkan's clip space has y pointing down
    glm_mat4_mul(proj, view, vp);
    memcpy(push->view_proj, vp, sizeof push->view_proj);
    push->eye[0] = eye[0], push->eye[1] = eye[1], push->eye[2] = eye[2], push->eye[3] = 1;
    push->forward[0] = fwd[0], push->forward[1] = fwd[1], push->forward[2] = fwd[2], push->forward[3] = 0;
}

static void light_to_gpu(const pn_light *l, pn_light_gpu *g)
{
    float q[4][3];
    pn_light_corners(l, q);
    memset(g, 0, sizeof *g);
    for (int i = 0; i < 4; i++)
        memcpy(g->corners[i], q[i], sizeof q[i]);
    float n = sqrtf(l->normal[0] * l->normal[0] + l->normal[1] * l->normal[1] + l->normal[2] * l->normal[2]);
    for (int k = 0; k < 3; k++) {
        g->normal[k] = n > 0 ? l->normal[k] / n : 0;
        g->radiance[k] = l->radiance[k];
    }
    g->radiance[3] = pn_light_is_point(l) ? 1.0f : 0.0f; // light.glsl: radiance is then an intensity
}

// `samples`: light samples traced per pixel (pn_shadow_samples).
static void record_frame(pn_renderer *r, VkCommandBuffer cmd, const pn_gbuffer_push *cam, const pn_light_gpu *light,
                         uint32_t samples)
{
    const VkPipelineStageFlags2 ALL = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    const VkPipelineStageFlags2 COLOR = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    const VkPipelineStageFlags2 DEPTH = VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL, UNDEF = VK_IMAGE_LAYOUT_UNDEFINED;
    uint32_t gx = (r->width + 7) / 8, gy = (r->height + 7) / 8;

    vkCmdResetQueryPool(cmd, r->timestamps, 0, TS_COUNT);
    // Every target is fully rewritten each frame: discard old contents (UNDEFINED) after all of the
    // previous frame's work on them.
    // With an external G-buffer (pn_renderer_set_gbuffer) P and N are copied in instead of drawn.
    bool external = r->gbuffer_upload.buffer != VK_NULL_HANDLE;
    const VkPipelineStageFlags2 PN_STAGE = external ? VK_PIPELINE_STAGE_2_COPY_BIT : COLOR;
    const VkAccessFlags2 PN_ACCESS = external ? VK_ACCESS_2_TRANSFER_WRITE_BIT : VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    const VkImageLayout PN_LAYOUT = external ? VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL : GENERAL;
    VkImageMemoryBarrier2 start[7] = {
        pn_gpu_image_barrier(&r->p, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, PN_STAGE, PN_ACCESS, UNDEF, PN_LAYOUT),
        pn_gpu_image_barrier(&r->n, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, PN_STAGE, PN_ACCESS, UNDEF, PN_LAYOUT),
        pn_gpu_image_barrier(&r->albedo, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COLOR, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, UNDEF, GENERAL),
        pn_gpu_image_barrier(&r->depth, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, DEPTH,
                             VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, UNDEF,
                             VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL),
        pn_gpu_image_barrier(&r->v, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, UNDEF, GENERAL),
        pn_gpu_image_barrier(&r->radiance, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, UNDEF, GENERAL),
        pn_gpu_image_barrier(&r->counts, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COMPUTE,
                             VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, UNDEF, GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 7, start);
    vkCmdWriteTimestamp2(cmd, ALL, r->timestamps, TS_START);

    // --- G-buffer
    if (external) {
        VkDeviceSize px = (VkDeviceSize)r->width * r->height;
        const pn_gpu_image *dst[2] = {&r->p, &r->n};
        for (int i = 0; i < 2; i++) {
            VkBufferImageCopy copy = {
                .bufferOffset = (VkDeviceSize)i * px * 16,
                .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
                .imageExtent = {r->width, r->height, 1},
            };
            vkCmdCopyBufferToImage(cmd, r->gbuffer_upload.buffer, dst[i]->image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                                   &copy);
        }
        // Albedo is not part of the input: black, so the shade pass reads defined values.
        VkImageMemoryBarrier2 albedo = pn_gpu_image_barrier(&r->albedo, COLOR, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                                                            VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                                            GENERAL, GENERAL);
        pn_gpu_cmd_barrier(cmd, NULL, 1, &albedo);
        vkCmdClearColorImage(cmd, r->albedo.image, GENERAL, &(VkClearColorValue){{0, 0, 0, 0}}, 1,
                             &(VkImageSubresourceRange){VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1});
        VkImageMemoryBarrier2 ready[3] = {
            pn_gpu_image_barrier(&r->p, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, COMPUTE | VK_PIPELINE_STAGE_2_COPY_BIT,
                                 VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT,
                                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, GENERAL),
            pn_gpu_image_barrier(&r->n, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, COMPUTE | VK_PIPELINE_STAGE_2_COPY_BIT,
                                 VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT,
                                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, GENERAL),
            pn_gpu_image_barrier(&r->albedo, VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                 COMPUTE | VK_PIPELINE_STAGE_2_COPY_BIT,
                                 VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT, GENERAL, GENERAL),
        };
        pn_gpu_cmd_barrier(cmd, NULL, 3, ready);
    } else {
        VkRenderingAttachmentInfo colors[3];
        const pn_gpu_image *targets[3] = {&r->p, &r->n, &r->albedo};
        for (int i = 0; i < 3; i++)
            colors[i] = (VkRenderingAttachmentInfo){
                .sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO,
                .imageView = targets[i]->view,
                .imageLayout = GENERAL,
                .loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR,
                .storeOp = VK_ATTACHMENT_STORE_OP_STORE,
            };
        VkRenderingAttachmentInfo depth = {
            .sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO,
            .imageView = r->depth.view,
            .imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
            .loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR,
            .storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE,
            .clearValue = {.depthStencil = {0.0f, 0}}, // reversed Z: 0 is the far plane
        };
        VkRenderingInfo ri = {
            .sType = VK_STRUCTURE_TYPE_RENDERING_INFO,
            .renderArea = {{0, 0}, {r->width, r->height}},
            .layerCount = 1,
            .colorAttachmentCount = 3,
            .pColorAttachments = colors,
            .pDepthAttachment = &depth,
        };
        vkCmdBeginRendering(cmd, &ri);
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r->gbuffer_pipeline);
        vkCmdSetViewport(cmd, 0, 1, &(VkViewport){0, 0, (float)r->width, (float)r->height, 0, 1});
        vkCmdSetScissor(cmd, 0, 1, &(VkRect2D){{0, 0}, {r->width, r->height}});
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, r->gbuffer_layout, 0, 1, &r->gbuffer_set, 0, NULL);
        vkCmdBindVertexBuffers(cmd, 0, 1, &r->vertices.buffer, &(VkDeviceSize){0});
        vkCmdBindIndexBuffer(cmd, r->indices.buffer, 0, VK_INDEX_TYPE_UINT32);
        pn_gbuffer_push push = *cam;
        for (uint32_t i = 0; i < r->draw_count; i++) {
            push.material = r->draws[i].material;
            vkCmdPushConstants(cmd, r->gbuffer_layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                               sizeof push, &push);
            vkCmdDrawIndexed(cmd, r->draws[i].index_count, 1, r->draws[i].first_index, 0, 0);
        }
        vkCmdEndRendering(cmd);
    }
    vkCmdWriteTimestamp2(cmd, ALL, r->timestamps, TS_GBUFFER);

    // --- shadow: reads P and N, writes V
    VkImageMemoryBarrier2 to_compute[3] = {
        pn_gpu_image_barrier(&r->p, COLOR, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_READ_BIT, GENERAL, GENERAL),
        pn_gpu_image_barrier(&r->n, COLOR, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_READ_BIT, GENERAL, GENERAL),
        pn_gpu_image_barrier(&r->albedo, COLOR, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_READ_BIT, GENERAL, GENERAL),
    };
    if (!external) // the external path made its copies visible already
        pn_gpu_cmd_barrier(cmd, NULL, 3, to_compute);
    // In chunks of light samples (see Chunk in shadow_common.glsl); each reads the counts the previous
    // one wrote.
    uint32_t spp = r->desc.mode == PN_SHADOW_NONE ? 1 : samples;
    for (uint32_t begin = 0; begin < spp; begin += r->chunk) {
        pn_shadow_chunk ch = {begin, begin + r->chunk < spp ? begin + r->chunk : spp, begin == 0, begin + r->chunk >= spp};
        if (begin > 0)
            pn_gpu_cmd_barrier(cmd,
                               &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                                   .srcStageMask = COMPUTE,
                                                   .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                                   .dstStageMask = COMPUTE,
                                                   .dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                                                                    VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT},
                               0, NULL);
        pn_gpu_compute_dispatch(cmd, &r->shadow, sizeof ch, &ch, gx, gy, 1);
    }
    vkCmdWriteTimestamp2(cmd, ALL, r->timestamps, TS_SHADOW);

    // --- shade: reads P, N, albedo, V; writes radiance
    VkImageMemoryBarrier2 v_ready =
        pn_gpu_image_barrier(&r->v, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_READ_BIT, GENERAL, GENERAL);
    pn_gpu_cmd_barrier(cmd, NULL, 1, &v_ready);
    pn_gpu_compute_dispatch(cmd, &r->shade, sizeof *light, light, gx, gy, 1);
    vkCmdWriteTimestamp2(cmd, ALL, r->timestamps, TS_SHADE);

    // --- readback
    const VkPipelineStageFlags2 COPY = VK_PIPELINE_STAGE_2_COPY_BIT;
    const VkImageLayout SRC = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    VkImageMemoryBarrier2 to_copy[5] = {
        pn_gpu_image_barrier(&r->p, COLOR | COMPUTE, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COPY, VK_ACCESS_2_TRANSFER_READ_BIT, GENERAL, SRC),
        pn_gpu_image_barrier(&r->n, COLOR | COMPUTE, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COPY, VK_ACCESS_2_TRANSFER_READ_BIT, GENERAL, SRC),
        pn_gpu_image_barrier(&r->albedo, COLOR | COMPUTE, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COPY, VK_ACCESS_2_TRANSFER_READ_BIT, GENERAL, SRC),
        pn_gpu_image_barrier(&r->v, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, COPY, VK_ACCESS_2_TRANSFER_READ_BIT, GENERAL, SRC),
        pn_gpu_image_barrier(&r->radiance, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, COPY, VK_ACCESS_2_TRANSFER_READ_BIT, GENERAL, SRC),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 5, to_copy);
    VkDeviceSize px = (VkDeviceSize)r->width * r->height, offset = 0;
    const pn_gpu_image *src[5] = {&r->p, &r->n, &r->albedo, &r->v, &r->radiance};
    for (int i = 0; i < 5; i++) {
        VkBufferImageCopy copy = {
            .bufferOffset = offset,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, src[i]->image, SRC, r->readback.buffer, 1, &copy);
        offset += px * (src[i] == &r->v ? 4 : 16);
    }
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){
                           .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                           // The copies, the shadow pass's status flag and ray dump: all read by the host.
                           .srcStageMask = COPY | COMPUTE,
                           .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                           .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
                           .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT,
                       },
                       0, NULL);
}

pn_result pn_renderer_render(pn_renderer *r, const pn_camera *camera, const pn_light *light, pn_frame_times *times)
{
    pn_gpu_device *dev = r->dev;
    pn_gbuffer_push cam = {0};
    camera_matrices(r, camera, &cam);
    pn_light_gpu l;
    light_to_gpu(light, &l);
    pn_shadow_params sp = {0};
    if (r->desc.pools)
        sp.tree = r->desc.pools->info;
    memcpy(sp.corners, l.corners, sizeof sp.corners);
    memcpy(sp.light_normal, l.normal, sizeof sp.light_normal);
    sp.spp = r->desc.spp ? r->desc.spp : 1;
    pn_sample_grid(sp.spp, &sp.grid_u, &sp.grid_v);
    sp.sampler = (uint32_t)r->desc.sampler;
    sp.seed = r->desc.seed;
    sp.leaf_size = (float)r->desc.leaf_size;
    sp.canary = 2;
    if (r->desc.exact) {
        const pn_gpu_exact_pools *e = r->desc.exact;
        sp.tris = e->tris.address;
        sp.bvh = e->bvh_nodes.address;
        sp.bvh_tris = e->bvh_tris.address;
        sp.cand_offset = e->cand_offset.address;
        sp.cand_tris = e->cand_tris.address;
    }
    sp.dump = r->ray_dump.address;
    sp.cand_first = r->desc.cand_first_node;
    sp.dump_rays = r->desc.dump_rays;
    sp.work = r->work.address;
    // The queue is idle between frames (pn_renderer_render waits), so the host may rewrite it.
    memcpy(r->shadow_params.mapped, &sp, sizeof sp);

    for (;;) {
        *(volatile uint32_t *)r->shadow_status.mapped = 0;
        VK_CHECK(vkResetCommandBuffer(r->cmd, 0));
        VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                       .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
        VK_CHECK(vkBeginCommandBuffer(r->cmd, &bi));
        record_frame(r, r->cmd, &cam, &l, pn_shadow_samples(sp.spp, light));
        VK_CHECK(vkEndCommandBuffer(r->cmd));
        VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &r->cmd};
        VK_CHECK(vkQueueSubmit(dev->queue, 1, &si, VK_NULL_HANDLE));
        VK_CHECK(vkQueueWaitIdle(dev->queue));
        if (*(volatile uint32_t *)r->shadow_status.mapped == 0)
            break;
        // A dispatch ran out of llvmpipe's loop budget: its counts are incomplete, so the frame is
        // rendered again with half the samples per dispatch.
        if (r->chunk == 1) {
            pn_error("a single shadow ray's traversal exceeds the device's shader loop budget; "
                     "try a smaller N or d");
            return PN_ERR_UNSUPPORTED;
        }
        r->chunk /= 2;
        pn_info("shadow pass cut short by the shader loop budget: retrying with %u samples per dispatch", r->chunk);
    }

    uint64_t ts[TS_COUNT];
    VK_CHECK(vkGetQueryPoolResults(dev->device, r->timestamps, 0, TS_COUNT, sizeof ts, ts, sizeof ts[0],
                                   VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    double period_ms = dev->props.limits.timestampPeriod * 1e-6;
    times->gbuffer_ms = (double)(ts[TS_GBUFFER] - ts[TS_START]) * period_ms;
    times->shadow_ms = (double)(ts[TS_SHADOW] - ts[TS_GBUFFER]) * period_ms;
    times->shade_ms = (double)(ts[TS_SHADE] - ts[TS_SHADOW]) * period_ms;
    return PN_OK;
}

void pn_renderer_images(const pn_renderer *r, pn_frame_images *out)
{
    size_t px = (size_t)r->width * r->height;
    const float *base = r->readback.mapped;
    out->p = base;
    out->n = out->p + 4 * px;
    out->albedo = out->n + 4 * px;
    out->v = out->albedo + 4 * px;
    out->radiance = out->v + px;
}

void pn_renderer_set_seed(pn_renderer *r, uint32_t seed) { r->desc.seed = seed; }

const float *pn_renderer_ray_dump(const pn_renderer *r, uint64_t *floats)
{
    *floats = r->ray_dump.mapped ? (uint64_t)r->width * r->height * (1 + r->desc.spp) * 4 : 0;
    return r->ray_dump.mapped;
}

pn_result pn_renderer_set_gbuffer(pn_renderer *r, const float *p, const float *n)
{
    pn_gpu_buffer_destroy(r->dev, &r->gbuffer_upload);
    if (!p || !n)
        return PN_OK;
    VkDeviceSize bytes = (VkDeviceSize)r->width * r->height * 16;
    PN_TRY(pn_gpu_buffer_create(r->dev, 2 * bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, PN_GPU_HOST_UPLOAD, &r->gbuffer_upload));
    memcpy(r->gbuffer_upload.mapped, p, bytes);
    memcpy((char *)r->gbuffer_upload.mapped + bytes, n, bytes);
    return PN_OK;
}

const uint32_t *pn_renderer_work(const pn_renderer *r) { return r->work.mapped; }
