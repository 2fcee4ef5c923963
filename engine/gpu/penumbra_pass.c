// The penumbra filter (--filter penumbra): images, pipeline and its two dispatches.
#include "gpu/penumbra_pass.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "gpu/frame.h"
#include "penumbra_filter_comp.h"

// A block's marks fit its texel, a bit per tile (interface.h).
_Static_assert(PN_PENUMBRA_BLOCK_W % PN_PENUMBRA_MARK_W == 0 && PN_PENUMBRA_BLOCK_W / PN_PENUMBRA_MARK_W <= 32,
               "a block's tiles are a bit each of its mark");

// The pass's set over f's images and a pipeline per stage (the first the set's own, the second the
// device's for the same layout), specialised for f->temporal.
static pn_result create_compute(pn_gpu_device *dev, const pn_penumbra_pass *f, pn_gpu_compute *out,
                                VkPipeline stages[PN_PENUMBRA_STAGES])
{
    uint32_t values[2] = {f->temporal ? VK_TRUE : VK_FALSE, PN_PENUMBRA_STAGE_BLUR_X};
    const VkSpecializationMapEntry entries[2] = {
        {.constantID = PN_SPEC_PENUMBRA_TEMPORAL, .offset = 0, .size = 4},
        {.constantID = PN_SPEC_PENUMBRA_STAGE, .offset = 4, .size = 4},
    };
    VkSpecializationInfo spec = {.mapEntryCount = 2, .pMapEntries = entries, .dataSize = sizeof values, .pData = values};
    PN_TRY(pn_gpu_compute_create_images_buffer(dev, pn_spv_penumbra_filter_comp, sizeof pn_spv_penumbra_filter_comp,
                                               f->images, PN_PENUMBRA_BINDING_COUNT, PN_PENUMBRA_BINDING_LIST,
                                               f->list.buffer, sizeof(pn_penumbra_push), &spec, out));
    stages[PN_PENUMBRA_STAGE_BLUR_X] = out->pipeline;
    values[1] = PN_PENUMBRA_STAGE_BLUR_Y;
    pn_result r = pn_gpu_compute_pipeline(dev, out, pn_spv_penumbra_filter_comp, sizeof pn_spv_penumbra_filter_comp,
                                          &spec, &stages[PN_PENUMBRA_STAGE_BLUR_Y]);
    if (r != PN_OK)
        pn_gpu_compute_destroy(dev, out);
    return r;
}

pn_result pn_penumbra_pass_set_counts(pn_gpu_device *dev, pn_penumbra_pass *f, VkImageView counts, bool temporal)
{
    if (counts == f->images[PN_PENUMBRA_BINDING_COUNTS] && temporal == f->temporal)
        return PN_OK;
    pn_penumbra_pass was = *f;
    f->images[PN_PENUMBRA_BINDING_COUNTS] = counts, f->temporal = temporal;
    pn_gpu_compute fresh;
    VkPipeline stages[PN_PENUMBRA_STAGES];
    pn_result r = create_compute(dev, f, &fresh, stages);
    if (r != PN_OK) {
        *f = was;
        return r;
    }
    pn_gpu_compute_destroy(dev, &f->compute);
    f->compute = fresh;
    memcpy(f->stages, stages, sizeof stages);
    return PN_OK;
}

pn_result pn_penumbra_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, const pn_gpu_image *p,
                                  const pn_gpu_image *n, const pn_gpu_image *counts, const pn_gpu_image *v,
                                  pn_penumbra_pass *out)
{
    memset(out, 0, sizeof *out);
    out->width = width, out->height = height;
    // Both rg32f; the scratch image is read back with the frame (pn_frame_images.footprint).
    pn_gpu_image *imgs[2] = {&out->sigma, &out->scratch};
    const char *names[2] = {"penumbra filter's footprint image", "penumbra filter's scratch image"};
    pn_result r = PN_OK;
    for (int i = 0; i < 2 && r == PN_OK; i++)
        r = pn_gpu_image_create(dev,
                                &(pn_gpu_image_desc){.name = names[i],
                                                     .format = VK_FORMAT_R32G32_SFLOAT,
                                                     .width = width,
                                                     .height = height,
                                                     .usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                                                              (i == 1 ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0)},
                                imgs[i]);
    // A texel per block, cleared before each filter pass (pn_penumbra_pass_begin).
    const uint32_t BW = PN_PENUMBRA_BLOCK_W, BH = PN_PENUMBRA_BLOCK_H;
    if (r == PN_OK)
        r = pn_gpu_image_create(dev,
                                &(pn_gpu_image_desc){.name = "penumbra filter's tile marks",
                                                     .format = VK_FORMAT_R32_UINT,
                                                     .width = (width + BW - 1) / BW,
                                                     .height = (height + BH - 1) / BH,
                                                     .usage = VK_IMAGE_USAGE_STORAGE_BIT |
                                                              VK_IMAGE_USAGE_TRANSFER_DST_BIT},
                                &out->tiles);
    // The list of marked blocks: at most every block once (filter.comp lists a block at its first
    // mark).
    out->tiles_across = (width + BW - 1) / BW, out->tiles_down = (height + BH - 1) / BH;
    if (r == PN_OK)
        r = pn_gpu_buffer_create(dev, "penumbra filter's tile list",
                                 (PN_TILE_LIST_HEADER + (VkDeviceSize)out->tiles_across * out->tiles_down) * 4,
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                                     VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                 PN_GPU_DEVICE_LOCAL, &out->list);
    out->images[PN_PENUMBRA_BINDING_P] = p->view;
    out->images[PN_PENUMBRA_BINDING_N] = n->view;
    out->images[PN_PENUMBRA_BINDING_COUNTS] = counts->view;
    out->images[PN_PENUMBRA_BINDING_V] = v->view;
    out->images[PN_PENUMBRA_BINDING_SIGMA] = out->sigma.view;
    out->images[PN_PENUMBRA_BINDING_SCRATCH] = out->scratch.view;
    out->images[PN_PENUMBRA_BINDING_TILES] = out->tiles.view;
    if (r == PN_OK)
        r = create_compute(dev, out, &out->compute, out->stages);
    if (r != PN_OK)
        pn_penumbra_pass_destroy(dev, out);
    return r;
}

void pn_penumbra_pass_destroy(pn_gpu_device *dev, pn_penumbra_pass *f)
{
    pn_gpu_compute_destroy(dev, &f->compute);
    pn_gpu_image_destroy(dev, &f->sigma);
    pn_gpu_image_destroy(dev, &f->scratch);
    pn_gpu_image_destroy(dev, &f->tiles);
    pn_gpu_buffer_destroy(dev, &f->list);
    memset(f, 0, sizeof *f);
}

float pn_penumbra_width_scale(void)
{
    const char *e = getenv("PN_PENUMBRA_WIDTH_SCALE");
    float s = e ? strtof(e, NULL) : 0.0f;
    return s > 0.0f && isfinite(s) ? s : 0.25f; // penumbra_pass.h
}

float pn_penumbra_window_scale(void) { return 2.0f; }

uint32_t pn_penumbra_max_radius(uint32_t height)
{
    uint32_t r = height / 32;
    return r < 8 ? 8 : r > 32 ? 32 : r;
}

void pn_penumbra_pass_begin(VkCommandBuffer cmd, const pn_penumbra_pass *f, const pn_gpu_image *v)
{
    // Its images (and V) are rewritten: discard what an earlier light or frame left, after all of
    // its work on them (the shade pass's reads of V, the readback's copies of V and the footprint).
    const VkAccessFlags2 RW = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
    const VkAccessFlags2 WRITTEN = VK_ACCESS_2_MEMORY_WRITE_BIT, CLEARS = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    const VkPipelineStageFlags2 ALL = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, CLEAR = VK_PIPELINE_STAGE_2_CLEAR_BIT;
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL, UNDEFINED = VK_IMAGE_LAYOUT_UNDEFINED;
    // Under the interleaved filter alone nothing of the pass is read or written: its images need
    // only be GENERAL, as for any dispatch of the filter pass's set, which holds them.
    const pn_gpu_image *imgs[4] = {&f->tiles, &f->scratch, &f->sigma, v};
    uint32_t count = v ? 4 : 3;
    VkImageMemoryBarrier2 fresh[4];
    for (uint32_t i = 0; i < count; i++)
        fresh[i] = v ? pn_gpu_image_barrier(imgs[i], ALL, WRITTEN, CLEAR, CLEARS, UNDEFINED, GENERAL)
                     : pn_gpu_image_barrier(imgs[i], ALL, WRITTEN, COMPUTE, RW, UNDEFINED, GENERAL);
    if (!v) {
        pn_gpu_cmd_barrier(cmd, NULL, count, fresh);
        return;
    }
    // Under the penumbra filter: the marks cleared (the filter pass sets them); the row pass's
    // output cleared to a lit pixel's, since that pass runs only in the marked blocks
    // (PN_PENUMBRA_SCRATCH_CLEAR); V and the footprints too (PN_PENUMBRA_LIT_V, _FOOTPRINT), which
    // the filter pass then writes only where they differ; and the list emptied, after the
    // dispatches an earlier light or frame read it for.
    VkMemoryBarrier2 list_free = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                  .srcStageMask = COMPUTE | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                                  .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                  .dstStageMask = VK_PIPELINE_STAGE_2_COPY_BIT,
                                  .dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT};
    pn_gpu_cmd_barrier(cmd, &list_free, count, fresh);
    const VkImageSubresourceRange all = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    const VkClearColorValue clears[4] = {
        {.uint32 = {0, 0, 0, 0}},
        {.float32 = {PN_PENUMBRA_SCRATCH_CLEAR, 0, 0, 0}},
        {.float32 = {PN_PENUMBRA_LIT_FOOTPRINT, 1, 0, 0}},
        {.float32 = {PN_PENUMBRA_LIT_V, 0, 0, 0}},
    };
    VkImageMemoryBarrier2 cleared[4];
    for (uint32_t i = 0; i < count; i++) {
        vkCmdClearColorImage(cmd, imgs[i]->image, GENERAL, &clears[i], 1, &all);
        cleared[i] = pn_gpu_image_barrier(imgs[i], CLEAR, CLEARS, COMPUTE, RW, GENERAL, GENERAL);
    }
    // VkDispatchIndirectCommand (0 blocks, a row each), and a first block at the origin for the
    // warm-up frame's one group (pn_penumbra_pass_record).
    const uint32_t empty[PN_TILE_LIST_HEADER + 1] = {0, PN_PENUMBRA_BLOCK_H, 1, 0, 0};
    vkCmdUpdateBuffer(cmd, f->list.buffer, 0, sizeof empty, empty);
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT,
                                           .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                           .dstStageMask = COMPUTE,
                                           .dstAccessMask = RW},
                       count, cleared);
}

void pn_penumbra_pass_record(VkCommandBuffer cmd, const pn_penumbra_pass *f, uint32_t samples, bool adaptive,
                             float yfov_deg)
{
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    const VkAccessFlags2 RW = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
    pn_penumbra_push push = {
        .pixel_angle = (float)pn_pixel_angle(yfov_deg, f->height),
        .samples = samples,
        .adaptive = adaptive,
        .max_radius = pn_penumbra_max_radius(f->height),
    };
    for (uint32_t stage = 0; stage < (PN_PENUMBRA_STAGES); stage++) {
        // Each stage reads what the ones before wrote (the first, the filter pass's footprints and
        // its list of tiles, the dispatch's group count).
        pn_gpu_cmd_barrier(cmd,
                           &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                               .srcStageMask = COMPUTE,
                                               .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                               .dstStageMask = COMPUTE | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                                               .dstAccessMask = RW | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT},
                           0, NULL);
        pn_gpu_compute c = f->compute;
        c.pipeline = f->stages[stage];
        // The warm-up frame runs the first tile whatever the list holds, so that llvmpipe compiles
        // both stages there (it compiles at a pipeline's first dispatch).
        if (f->one_tile)
            pn_gpu_compute_dispatch(cmd, &c, sizeof push, &push, 1, 1, 1);
        else
            pn_gpu_compute_dispatch_indirect(cmd, &c, sizeof push, &push, f->list.buffer, 0);
    }
}
