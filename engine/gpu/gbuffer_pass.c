// The G-buffer pass: the raster pipeline, its targets and the scene's vertex buffers.
#include "gpu/gbuffer_pass.h"

#include <cglm/cglm.h>
#include <cglm/clipspace/persp_rh_zo.h> // Vulkan depth range 0..1, whatever cglm defaults to
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <meshoptimizer.h>

#include "core/timer.h"
#include "gbuffer_frag.h"
#include "gbuffer_vert.h"

static const VkFormat FMT_RGBA32F = VK_FORMAT_R32G32B32A32_SFLOAT;
static const VkFormat FMT_DEPTH = VK_FORMAT_D32_SFLOAT;

// The raster pass's own index order: each draw's triangles in vertex-cache order (meshoptimizer's
// Forsyth-style optimizer), so that the vertex shader runs for fewer repeated vertices. Only the
// order of triangles within a draw changes, and only for the raster pass (the trees and BVH keep
// the scene's): each pixel still shows its nearest triangle, so P and N change only where two
// triangles of a draw meet a pixel at the same depth, which the depth test decides by order.
// Measured in engine/gpu/README.md (the G-buffer pass).
static pn_result raster_indices(const pn_scene *s, uint32_t **out)
{
    uint32_t longest = 0;
    for (uint32_t i = 0; i < s->draw_count; i++)
        longest = s->draws[i].index_count > longest ? s->draws[i].index_count : longest;
    uint32_t *idx = malloc((size_t)s->index_count * sizeof *idx), *local = malloc(((size_t)longest + 1) * sizeof *local);
    if (!idx || !local) {
        free(idx), free(local);
        return PN_ERR_MEMORY;
    }
    memcpy(idx, s->indices, (size_t)s->index_count * sizeof *idx);
    for (uint32_t i = 0; i < s->draw_count; i++) {
        const pn_draw *d = &s->draws[i];
        if (d->index_count < 3 || d->first_index + d->index_count > s->index_count)
            continue;
        // Over the draw's own vertex range: the optimizer's tables are as long as the vertex count
        // it is given, per call (the scene's whole count made a scene of many draws pay for all
        // of its vertices at every draw).
        const uint32_t *src = s->indices + d->first_index;
        uint32_t lo = UINT32_MAX, hi = 0;
        for (uint32_t k = 0; k < d->index_count; k++)
            lo = src[k] < lo ? src[k] : lo, hi = src[k] > hi ? src[k] : hi;
        for (uint32_t k = 0; k < d->index_count; k++)
            local[k] = src[k] - lo;
        uint32_t *dst = idx + d->first_index;
        meshopt_optimizeVertexCache(dst, local, d->index_count, (size_t)hi - lo + 1);
        for (uint32_t k = 0; k < d->index_count; k++)
            dst[k] += lo;
    }
    free(local);
    *out = idx;
    return PN_OK;
}

static pn_result upload_scene(pn_gpu_device *dev, pn_gbuffer_pass *r, const pn_scene *s)
{
    PN_TRY(pn_gpu_buffer_create_with_data(dev, "vertex buffer", s->vertices, (VkDeviceSize)s->vertex_count * sizeof(pn_vertex),
                                          VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                          &r->vertices));
    PN_TRY(raster_indices(s, &r->raster_indices));
    PN_TRY(pn_gpu_buffer_create_with_data(dev, "index buffer", r->raster_indices,
                                          (VkDeviceSize)s->index_count * sizeof(uint32_t), VK_BUFFER_USAGE_INDEX_BUFFER_BIT,
                                          &r->indices));
    PN_TRY(pn_gbuffer_clusters_build(s, r->raster_indices, &r->clusters));
    uint32_t most = 1; // the most clusters of a draw: room for its runs (pn_gbuffer_clusters_runs)
    for (uint32_t d = 0; d < s->draw_count; d++) {
        uint32_t n = r->clusters.first[d + 1] - r->clusters.first[d];
        most = n > most ? n : most;
    }
    r->runs = malloc(most * sizeof *r->runs);
    if (!r->runs)
        return PN_ERR_MEMORY;
    pn_material_gpu *m = calloc(s->material_count, sizeof *m);
    if (!m)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < s->material_count; i++) {
        memcpy(m[i].base_color, s->materials[i].base_color, sizeof m[i].base_color);
        m[i].texture = s->materials[i].texture;
        m[i].alpha_cutoff = s->materials[i].alpha_cutoff;
    }
    pn_result res = pn_gpu_buffer_create_with_data(dev, "material buffer", m, s->material_count * sizeof *m,
                                                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, &r->materials);
    free(m);
    PN_TRY(res);

    r->texture_count = s->texture_count ? s->texture_count : 1;
    r->textures = calloc(r->texture_count, sizeof *r->textures);
    if (!r->textures)
        return PN_ERR_MEMORY;
    if (s->texture_count == 0) {
        static const uint8_t white[4] = {255, 255, 255, 255};
        PN_TRY(pn_gpu_texture_create(dev, "white texture", 1, 1, white, &r->textures[0]));
    }
    for (uint32_t i = 0; i < s->texture_count; i++)
        PN_TRY(pn_gpu_texture_create(dev, "texture", s->textures[i].width, s->textures[i].height, s->textures[i].rgba,
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
    r->cull = calloc(s->draw_count ? s->draw_count : 1, sizeof *r->cull);
    if (!r->cull)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < s->draw_count; i++)
        PN_TRY(pn_gbuffer_cull_analyse(s, &s->draws[i], &r->cull[i]));
    memcpy(r->scene_min, s->bounds_min, sizeof r->scene_min);
    memcpy(r->scene_max, s->bounds_max, sizeof r->scene_max);
    return PN_OK;
}

static pn_result create_pipeline(pn_gpu_device *dev, pn_gbuffer_pass *r)
{
    VkShaderModule vs, fs;
    PN_TRY(pn_gpu_shader_module(dev, pn_spv_gbuffer_vert, sizeof pn_spv_gbuffer_vert, &vs));
    pn_result res = pn_gpu_shader_module(dev, pn_spv_gbuffer_frag, sizeof pn_spv_gbuffer_frag, &fs);
    if (res != PN_OK) {
        vkDestroyShaderModule(dev->device, vs, NULL);
        return res;
    }
    int32_t texture_count = (int32_t)r->texture_count;
    VkSpecializationMapEntry entry = {.constantID = PN_SPEC_TEXTURE_COUNT, .offset = 0, .size = sizeof texture_count};
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
    // The cull mode per draw (dynamic): open meshes (Sponza's walls, the ground) are seen from both
    // sides, closed ones from outside cull their back faces (gbuffer_cull.h). glTF's front faces
    // wind counter-clockwise; with the projection's y flipped (pn_gbuffer_camera) Vulkan sees them
    // counter-clockwise too (checked: culling the other way empties the dragon's silhouette).
    VkPipelineRasterizationStateCreateInfo rs = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO,
        .polygonMode = VK_POLYGON_MODE_FILL,
        .cullMode = VK_CULL_MODE_NONE,
        .frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE,
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
    VkDynamicState dyn[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR, VK_DYNAMIC_STATE_CULL_MODE};
    VkPipelineDynamicStateCreateInfo dy = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO,
        .dynamicStateCount = 3,
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
        .layout = r->layout,
    };
    uint64_t t0 = pn_time_ns();
    VkResult vr = vkCreateGraphicsPipelines(dev->device, VK_NULL_HANDLE, 1, &ci, NULL, &r->pipeline);
    vkDestroyShaderModule(dev->device, vs, NULL);
    vkDestroyShaderModule(dev->device, fs, NULL);
    VK_CHECK(vr);
    // Made per pass, not kept by the device (3 ms warm: its render pass and formats are the pass's).
    uint64_t variant = pn_gpu_variant_hash(PN_GPU_VARIANT_SEED, pn_spv_gbuffer_vert, sizeof pn_spv_gbuffer_vert);
    variant = pn_gpu_variant_hash(variant, pn_spv_gbuffer_frag, sizeof pn_spv_gbuffer_frag);
    variant = pn_gpu_variant_hash(variant, &texture_count, sizeof texture_count);
    pn_gpu_pipeline_log(dev, "graphics", variant, sizeof pn_spv_gbuffer_vert + sizeof pn_spv_gbuffer_frag, t0);
    return PN_OK;
}

static pn_result create_descriptors(pn_gpu_device *dev, pn_gbuffer_pass *r)
{
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
        .pSetLayouts = &r->set_layout,
    };
    VK_CHECK(vkAllocateDescriptorSets(dev->device, &ai, &r->set));

    VkDescriptorImageInfo *tex = calloc(r->texture_count, sizeof *tex);
    if (!tex)
        return PN_ERR_MEMORY;
    for (uint32_t i = 0; i < r->texture_count; i++)
        tex[i] = (VkDescriptorImageInfo){r->sampler, r->textures[i].view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkDescriptorBufferInfo mat = {r->materials.buffer, 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet w[2] = {
        {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .dstSet = r->set, .dstBinding = PN_GBUFFER_BINDING_MATERIALS,
         .descriptorCount = 1, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, .pBufferInfo = &mat},
        {.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET, .dstSet = r->set, .dstBinding = PN_GBUFFER_BINDING_TEXTURES,
         .descriptorCount = r->texture_count, .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, .pImageInfo = tex},
    };
    vkUpdateDescriptorSets(dev->device, 2, w, 0, NULL);
    free(tex);
    return PN_OK;
}

const uint32_t *pn_gbuffer_pass_spirv(int stage, size_t *size)
{
    *size = stage == 0 ? sizeof pn_spv_gbuffer_vert : sizeof pn_spv_gbuffer_frag;
    return stage == 0 ? pn_spv_gbuffer_vert : pn_spv_gbuffer_frag;
}

pn_result pn_gbuffer_pass_create(pn_gpu_device *dev, const pn_scene *scene, pn_gbuffer_pass *out)
{
    memset(out, 0, sizeof *out);
    const VkPhysicalDeviceLimits *lim = &dev->props.limits;
    if (scene->texture_count > lim->maxPerStageDescriptorSampledImages) {
        pn_error("%s: %u textures, the device allows %u", scene->name, scene->texture_count,
                 lim->maxPerStageDescriptorSampledImages);
        return PN_ERR_UNSUPPORTED;
    }
    pn_result r = upload_scene(dev, out, scene);
    const VkShaderStageFlags FRAGMENT = VK_SHADER_STAGE_FRAGMENT_BIT;
    VkDescriptorSetLayoutBinding b[2] = {
        {.binding = PN_GBUFFER_BINDING_MATERIALS, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
         .descriptorCount = 1, .stageFlags = FRAGMENT},
        {.binding = PN_GBUFFER_BINDING_TEXTURES, .descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
         .descriptorCount = out->texture_count, .stageFlags = FRAGMENT},
    };
    if (r == PN_OK)
        r = pn_gpu_set_layout(dev, b, 2, &out->set_layout);
    if (r == PN_OK)
        r = pn_gpu_pipeline_layout(dev, out->set_layout, VK_SHADER_STAGE_VERTEX_BIT | FRAGMENT, sizeof(pn_gbuffer_push),
                                   &out->layout);
    if (r == PN_OK)
        r = create_pipeline(dev, out);
    if (r == PN_OK)
        r = create_descriptors(dev, out);
    if (r != PN_OK)
        pn_gbuffer_pass_destroy(dev, out);
    return r;
}

void pn_gbuffer_pass_destroy(pn_gpu_device *dev, pn_gbuffer_pass *g)
{
    VkDevice d = dev->device;
    if (g->pipeline)
        vkDestroyPipeline(d, g->pipeline, NULL);
    if (g->layout)
        vkDestroyPipelineLayout(d, g->layout, NULL);
    if (g->set_layout)
        vkDestroyDescriptorSetLayout(d, g->set_layout, NULL);
    if (g->descriptor_pool)
        vkDestroyDescriptorPool(d, g->descriptor_pool, NULL);
    for (uint32_t i = 0; g->textures && i < g->texture_count; i++)
        pn_gpu_image_destroy(dev, &g->textures[i]);
    free(g->textures);
    if (g->sampler)
        vkDestroySampler(d, g->sampler, NULL);
    pn_gpu_buffer_destroy(dev, &g->vertices);
    pn_gpu_buffer_destroy(dev, &g->indices);
    pn_gpu_buffer_destroy(dev, &g->materials);
    free(g->draws);
    free(g->cull);
    pn_gbuffer_clusters_destroy(&g->clusters);
    free(g->raster_indices);
    free(g->runs);
    memset(g, 0, sizeof *g);
}

pn_result pn_gbuffer_pass_update_vertices(pn_gpu_device *dev, pn_gbuffer_pass *g, const pn_scene *scene,
                                          uint32_t first, uint32_t count)
{
    if (first > scene->vertex_count || count > scene->vertex_count - first ||
        (VkDeviceSize)scene->vertex_count * sizeof(pn_vertex) != g->vertices.size) {
        pn_error("%s: vertices %u..%u to update, the G-buffer holds %llu of the scene's %u", scene->name, first,
                 first + count, (unsigned long long)(g->vertices.size / sizeof(pn_vertex)), scene->vertex_count);
        return PN_ERR_INVALID;
    }
    PN_TRY(pn_gpu_buffer_write(dev, "vertex buffer", &g->vertices, (VkDeviceSize)first * sizeof(pn_vertex), scene->vertices + first,
                               (VkDeviceSize)count * sizeof(pn_vertex)));
    memcpy(g->scene_min, scene->bounds_min, sizeof g->scene_min);
    memcpy(g->scene_max, scene->bounds_max, sizeof g->scene_max);
    for (uint32_t i = 0; i < g->draw_count; i++)
        if (g->draws[i].index_count && g->cull[i].last >= first && g->cull[i].first < first + count) {
            pn_gbuffer_cull_moved(scene, &g->draws[i], &g->cull[i]);
            pn_gbuffer_clusters_moved(&g->clusters, scene, g->raster_indices, i);
        }
    return PN_OK;
}

// The near and far planes' view depths for an eye at `eye`: around the scene's bounding sphere.
static float clip_planes(const pn_gbuffer_pass *r, const float eye[3], float *zfar)
{
    // Clip planes enclose the scene's bounding sphere. Far/near is capped at 2^20: with reversed Z
    // in a float depth buffer that still leaves about 2^-3 relative depth resolution... per ulp
    // of the float exponent range, far more than 24-bit fixed point gives.
    float c[3], rad = 0, dist = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5f * (r->scene_min[k] + r->scene_max[k]);
        float e = r->scene_max[k] - r->scene_min[k];
        rad += e * e;
        dist += (eye[k] - c[k]) * (eye[k] - c[k]);
    }
    rad = 0.5f * sqrtf(rad);
    dist = sqrtf(dist);
    *zfar = (dist + rad) * 1.01f;
    float znear = fmaxf(dist - rad, 0.0f) * 0.99f;
    return znear < *zfar * 0x1p-20f ? *zfar * 0x1p-20f : znear;
}

pn_gbuffer_push pn_gbuffer_camera(const pn_gbuffer_pass *r, const pn_camera *cam, uint32_t width, uint32_t height)
{
    pn_gbuffer_push out = {0}, *push = &out;
    vec3 eye = {cam->pos[0], cam->pos[1], cam->pos[2]};
    vec3 target = {cam->target[0], cam->target[1], cam->target[2]};
    vec3 up = {cam->up[0], cam->up[1], cam->up[2]};
    vec3 fwd;
    glm_vec3_sub(target, eye, fwd);
    glm_vec3_normalize(fwd);
    float zfar, znear = clip_planes(r, eye, &zfar);
    mat4 view, proj, vp;
    glm_lookat_rh(eye, target, up, view);
    float aspect = (float)width / (float)height;
    // Swapping near and far in a 0..1 projection gives reversed Z.
    glm_perspective_rh_zo(glm_rad(cam->yfov_deg), aspect, zfar, znear, proj);
    proj[1][1] = -proj[1][1]; // Vulkan's clip space has y pointing down
    glm_mat4_mul(proj, view, vp);
    memcpy(push->view_proj, vp, sizeof push->view_proj);
    push->eye[0] = eye[0], push->eye[1] = eye[1], push->eye[2] = eye[2], push->eye[3] = 1;
    push->forward[0] = fwd[0], push->forward[1] = fwd[1], push->forward[2] = fwd[2], push->forward[3] = 0;
    return out;
}

bool pn_gbuffer_pass_culls(const pn_gbuffer_pass *g, uint32_t draw, const pn_gbuffer_push *camera)
{
    float zfar, znear = clip_planes(g, camera->eye, &zfar);
    return pn_gbuffer_cull_back(&g->cull[draw], camera->eye, camera->forward, znear);
}

void pn_gbuffer_pass_record(VkCommandBuffer cmd, const pn_gbuffer_pass *g, const pn_gbuffer_targets *t,
                            const pn_gbuffer_push *camera)
{
    const VkPipelineStageFlags2 ALL = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    const VkPipelineStageFlags2 COLOR = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    const VkPipelineStageFlags2 DEPTH = VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    const VkAccessFlags2 WRITE = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL, UNDEF = VK_IMAGE_LAYOUT_UNDEFINED;
    // Every target is fully rewritten: discard old contents (UNDEFINED) after all earlier work on them.
    VkImageMemoryBarrier2 start[4] = {
        pn_gpu_image_barrier(t->p, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COLOR, WRITE, UNDEF, GENERAL),
        pn_gpu_image_barrier(t->n, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COLOR, WRITE, UNDEF, GENERAL),
        pn_gpu_image_barrier(t->albedo, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COLOR, WRITE, UNDEF, GENERAL),
        pn_gpu_image_barrier(t->depth, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, DEPTH,
                             VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, UNDEF,
                             VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 4, start);
    VkRenderingAttachmentInfo colors[3];
    const pn_gpu_image *targets[3] = {t->p, t->n, t->albedo};
    for (int i = 0; i < 3; i++)
        colors[i] = (VkRenderingAttachmentInfo){
            .sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO,
            .imageView = targets[i]->view,
            .imageLayout = VK_IMAGE_LAYOUT_GENERAL,
            .loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR,
            .storeOp = VK_ATTACHMENT_STORE_OP_STORE,
        };
    VkRenderingAttachmentInfo depth = {
        .sType = VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO,
        .imageView = t->depth->view,
        .imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
        .loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR,
        .storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE,
        .clearValue = {.depthStencil = {0.0f, 0}}, // reversed Z: 0 is the far plane
    };
    VkRenderingInfo ri = {
        .sType = VK_STRUCTURE_TYPE_RENDERING_INFO,
        .renderArea = {{0, 0}, {t->width, t->height}},
        .layerCount = 1,
        .colorAttachmentCount = 3,
        .pColorAttachments = colors,
        .pDepthAttachment = &depth,
    };
    vkCmdBeginRendering(cmd, &ri);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, g->pipeline);
    vkCmdSetViewport(cmd, 0, 1, &(VkViewport){0, 0, (float)t->width, (float)t->height, 0, 1});
    uint32_t sw = t->one_tile && t->width > PN_WORKGROUP ? PN_WORKGROUP : t->width;
    uint32_t sh = t->one_tile && t->height > PN_WORKGROUP ? PN_WORKGROUP : t->height;
    vkCmdSetScissor(cmd, 0, 1, &(VkRect2D){{0, 0}, {sw, sh}});
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, g->layout, 0, 1, &g->set, 0, NULL);
    vkCmdBindVertexBuffers(cmd, 0, 1, &g->vertices.buffer, &(VkDeviceSize){0});
    vkCmdBindIndexBuffer(cmd, g->indices.buffer, 0, VK_INDEX_TYPE_UINT32);
    pn_gbuffer_push push = *camera;
    VkCullModeFlags mode = VK_CULL_MODE_NONE;
    vkCmdSetCullMode(cmd, mode);
    for (uint32_t i = 0; i < g->draw_count; i++) {
        bool back = pn_gbuffer_pass_culls(g, i, camera);
        uint64_t kept;
        uint32_t runs = 1;
        if (g->draw_all)
            g->runs[0] = (pn_gbuffer_run){g->draws[i].first_index, g->draws[i].index_count};
        else
            runs = pn_gbuffer_clusters_runs(&g->clusters, i, camera, t->width, t->height, back, g->runs, &kept);
        if (runs == 0)
            continue;
        VkCullModeFlags want = back ? VK_CULL_MODE_BACK_BIT : VK_CULL_MODE_NONE;
        if (want != mode)
            vkCmdSetCullMode(cmd, mode = want);
        push.material = g->draws[i].material;
        vkCmdPushConstants(cmd, g->layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof push,
                           &push);
        for (uint32_t k = 0; k < runs; k++)
            vkCmdDrawIndexed(cmd, g->runs[k].index_count, 1, g->runs[k].first_index, 0, 0);
    }
    vkCmdEndRendering(cmd);
    // The compute passes read all three.
    const VkAccessFlags2 READ = VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
    VkImageMemoryBarrier2 done[3] = {
        pn_gpu_image_barrier(t->p, COLOR, WRITE, COMPUTE, READ, GENERAL, GENERAL),
        pn_gpu_image_barrier(t->n, COLOR, WRITE, COMPUTE, READ, GENERAL, GENERAL),
        pn_gpu_image_barrier(t->albedo, COLOR, WRITE, COMPUTE, READ, GENERAL, GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 3, done);
}
