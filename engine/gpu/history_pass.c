// The temporal history: its images, parameters and dispatch (gpu/history_pass.h).
#include "gpu/history_pass.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "history_comp.h"

pn_result pn_history_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, uint32_t layers,
                                 const pn_gpu_image *p, const pn_gpu_image *n, const pn_gpu_image *counts,
                                 const pn_gpu_image *v_raw, pn_history_pass *out)
{
    memset(out, 0, sizeof *out);
    out->width = width, out->height = height, out->layers = layers;
    out->counts = counts;
    const VkImageUsageFlags storage = VK_IMAGE_USAGE_STORAGE_BIT;
    struct {
        pn_gpu_image *img;
        const char *name;
        VkFormat format;
        uint32_t layers;
        VkImageUsageFlags usage;
    } t[] = {
        {&out->store[0], "history's sums (even frames)", VK_FORMAT_R32G32B32A32_UINT, layers, storage},
        {&out->store[1], "history's sums (odd frames)", VK_FORMAT_R32G32B32A32_UINT, layers, storage},
        {&out->pos[0], "history's positions (even frames)", VK_FORMAT_R32G32B32A32_SFLOAT, 0, storage},
        {&out->pos[1], "history's positions (odd frames)", VK_FORMAT_R32G32B32A32_SFLOAT, 0, storage},
        // read back with the frame (pn_frame_images.history)
        {&out->out, "history's counts", VK_FORMAT_R32G32B32A32_UINT, 0, storage | VK_IMAGE_USAGE_TRANSFER_SRC_BIT},
        {&out->lineage, "history's lineage", VK_FORMAT_R32G32B32A32_UINT, 0, storage},
        {&out->trail[0], "history's lineages (even frames)", VK_FORMAT_R32G32B32A32_UINT, 0, storage},
        {&out->trail[1], "history's lineages (odd frames)", VK_FORMAT_R32G32B32A32_UINT, 0, storage},
    };
    pn_result r = PN_OK;
    for (size_t i = 0; i < sizeof t / sizeof t[0] && r == PN_OK; i++)
        r = pn_gpu_image_create(dev,
                                &(pn_gpu_image_desc){.name = t[i].name,
                                                     .format = t[i].format,
                                                     .width = width,
                                                     .height = height,
                                                     .layers = t[i].layers,
                                                     .usage = t[i].usage},
                                t[i].img);
    if (r == PN_OK)
        r = pn_gpu_buffer_create(dev, "history's parameters", sizeof(pn_history_params),
                                 VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, PN_GPU_HOST_UPLOAD, &out->params);
    VkDescriptorSetLayoutBinding bindings[PN_HISTORY_BINDING_COUNT];
    for (uint32_t i = 0; i < PN_HISTORY_BINDING_COUNT; i++)
        bindings[i] = (VkDescriptorSetLayoutBinding){
            .binding = i,
            .descriptorType = i == PN_HISTORY_BINDING_PARAMS ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER
                                                             : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE};
    for (int k = 0; k < 2 && r == PN_OK; k++) {
        pn_gpu_compute *c = &out->compute[k];
        r = pn_gpu_compute_create(dev,
                                  &(pn_gpu_compute_desc){.spirv = pn_spv_history_comp,
                                                         .spirv_size = sizeof pn_spv_history_comp,
                                                         .bindings = bindings,
                                                         .binding_count = PN_HISTORY_BINDING_COUNT,
                                                         .push_size = sizeof(pn_history_push)},
                                  c);
        if (r != PN_OK)
            break;
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_P, p->view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_N, n->view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_PREV_P, out->pos[k].view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_POS_OUT, out->pos[1 - k].view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_COUNTS, counts->view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_V_RAW, v_raw->view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_STORE_IN, out->store[k].view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_STORE_OUT, out->store[1 - k].view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_OUT, out->out.view);
        pn_gpu_compute_write_uniform(dev, c, PN_HISTORY_BINDING_PARAMS, out->params.buffer);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_LINEAGE, out->lineage.view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_TRAIL, out->trail[k].view);
        pn_gpu_compute_write_image(dev, c, PN_HISTORY_BINDING_TRAIL_OUT, out->trail[1 - k].view);
    }
    // The choosing stage and the stage that takes its choice: the device's pipelines for the same
    // layout (both sets share it).
    uint32_t stage = 1;
    const VkSpecializationMapEntry entry = {.constantID = PN_SPEC_HISTORY_STAGE, .offset = 0, .size = 4};
    VkSpecializationInfo spec = {.mapEntryCount = 1, .pMapEntries = &entry, .dataSize = 4, .pData = &stage};
    if (r == PN_OK)
        r = pn_gpu_compute_pipeline(dev, &out->compute[0], pn_spv_history_comp, sizeof pn_spv_history_comp, &spec,
                                    &out->choose);
    stage = 2;
    if (r == PN_OK)
        r = pn_gpu_compute_pipeline(dev, &out->compute[0], pn_spv_history_comp, sizeof pn_spv_history_comp, &spec,
                                    &out->take);
    if (r != PN_OK)
        pn_history_pass_destroy(dev, out);
    return r;
}

void pn_history_pass_destroy(pn_gpu_device *dev, pn_history_pass *h)
{
    for (int k = 0; k < 2; k++) {
        pn_gpu_compute_destroy(dev, &h->compute[k]);
        pn_gpu_image_destroy(dev, &h->store[k]);
        pn_gpu_image_destroy(dev, &h->pos[k]);
        pn_gpu_image_destroy(dev, &h->trail[k]);
    }
    pn_gpu_image_destroy(dev, &h->out);
    pn_gpu_image_destroy(dev, &h->lineage);
    pn_gpu_buffer_destroy(dev, &h->params);
    memset(h, 0, sizeof *h);
}

pn_history_params *pn_history_pass_params(pn_history_pass *h) { return (pn_history_params *)h->params.mapped; }

void pn_history_boxes_add(pn_history_boxes *b, const double lo[3], const double hi[3])
{
    bool merge = b->count == PN_HISTORY_MAX_BOXES;
    double *box = b->box[merge ? PN_HISTORY_MAX_BOXES - 1 : b->count++];
    for (int k = 0; k < 3; k++) {
        box[k] = merge ? fmin(box[k], lo[k]) : lo[k];
        box[3 + k] = merge ? fmax(box[3 + k], hi[k]) : hi[k];
    }
}

void pn_history_pass_set_boxes(pn_history_pass *h, const pn_history_boxes *b, double scene_mag, double leaf_size)
{
    // The boxes grown by what a ray's meeting with them can be off by: its origin is raised 8 ulps
    // of the scene's magnitude (shadow_origin) and the shader's projections round by a few ulps
    // more, which 64 ulps hold with room to spare; and in the modes that end rays in the N-tree's
    // cells (line space), a shaft touches the cells within a leaf of its ray and a filled leaf
    // reaches a leaf beyond its surface (shadow_frame.glsl's RISE_SHAFT_LEAVES): 3 leaves more.
    // Then rounded outward to float.
    pn_history_params *hp = pn_history_pass_params(h);
    hp->box_count = b->count;
    for (uint32_t i = 0; i < b->count; i++) {
        const double *box = b->box[i];
        double mag = scene_mag;
        for (int k = 0; k < 6; k++)
            mag = fmax(mag, fabs(box[k]));
        double pad = 64.0 * FLT_EPSILON * mag + 3.0 * leaf_size;
        for (int k = 0; k < 3; k++) {
            hp->box_lo[i][k] = nextafterf((float)(box[k] - pad), -INFINITY);
            hp->box_hi[i][k] = nextafterf((float)(box[3 + k] + pad), INFINITY);
        }
        hp->box_lo[i][3] = hp->box_hi[i][3] = 0.0f;
    }
}

void pn_history_pass_record_start(VkCommandBuffer cmd, pn_history_pass *h)
{
    const VkPipelineStageFlags2 ALL = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    const VkAccessFlags2 RW = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
    VkImageLayout from = h->ready ? VK_IMAGE_LAYOUT_GENERAL : VK_IMAGE_LAYOUT_UNDEFINED;
    VkImageMemoryBarrier2 b[8];
    const pn_gpu_image *images[8] = {&h->store[0], &h->store[1], &h->pos[0],   &h->pos[1],
                                     &h->out,      &h->lineage,  &h->trail[0], &h->trail[1]};
    for (uint32_t i = 0; i < 8; i++)
        b[i] = pn_gpu_image_barrier(images[i], ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                    RW, from, VK_IMAGE_LAYOUT_GENERAL);
    pn_gpu_cmd_barrier(cmd, NULL, 8, b);
    h->ready = true;
}

void pn_history_pass_record(VkCommandBuffer cmd, const pn_history_pass *h, uint32_t light, bool drop, float cap,
                            float noise_pixels, bool chosen)
{
    pn_history_push push = {.light = light, .drop = drop, .cap = cap, .noise_pixels = noise_pixels};
    pn_gpu_compute c = h->compute[h->cur];
    if (chosen)
        c.pipeline = h->take;
    pn_gpu_compute_dispatch_rows(cmd, &c, sizeof push, &push, h->width, h->height, h->one_tile);
}

void pn_history_pass_record_choose(VkCommandBuffer cmd, const pn_history_pass *h, bool fresh)
{
    pn_history_push push = {.drop = fresh};
    // The set holds the shadow pass's counts, which the choice does not read but whose layout the
    // set's use requires before that pass's own barrier makes it GENERAL (the first frame's is
    // UNDEFINED): discarded, as that pass rewrites them from its first chunk on.
    VkImageMemoryBarrier2 counts = pn_gpu_image_barrier(
        h->counts, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
        VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
        VK_IMAGE_LAYOUT_GENERAL);
    pn_gpu_cmd_barrier(cmd, NULL, 1, &counts);
    pn_gpu_compute c = h->compute[h->cur];
    c.pipeline = h->choose;
    pn_gpu_compute_dispatch_rows(cmd, &c, sizeof push, &push, h->width, h->height, h->one_tile);
    // The lineage before the shadow passes draw by it and the adding stages take the chosen pixels
    // (and whatever else the set's images are written by next).
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                           .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                           .dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                           .dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                                                            VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT},
                       0, NULL);
}
