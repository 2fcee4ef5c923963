// The frame's readback: the buffer the frame's images are copied to, the copies' recording (after
// the frame, and per light with several), and where each image lies in it (pn_renderer_images).
#include "gpu/renderer.h"

#include <string.h>

#include "gpu/renderer_internal.h"

// Copies every image to the readback buffer and makes it, the shadow pass's status flag and its
// ray dump visible to the host. The V the frame gives (filtered with a filter) goes to V's place;
// with a filter, the shadow pass's own V follows the radiance.
void pn_renderer_record_readback(pn_renderer *r, VkCommandBuffer cmd)
{
    const VkPipelineStageFlags2 COLOR = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    const VkPipelineStageFlags2 COPY = VK_PIPELINE_STAGE_2_COPY_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL, SRC = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    const VkAccessFlags2 READ = VK_ACCESS_2_TRANSFER_READ_BIT;
    const VkAccessFlags2 STORAGE = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
    const pn_gpu_image *v = filtered(r) ? &r->v : &r->v_raw;
    const pn_gpu_image *src[6] = {&r->p, &r->n, &r->albedo, v, &r->radiance, &r->v_raw};
    int count = filtered(r) ? 6 : 5;
    VkImageMemoryBarrier2 to_copy[8] = {
        pn_gpu_image_barrier(&r->p, COLOR | COMPUTE, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(&r->n, COLOR | COMPUTE, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(&r->albedo, COLOR | COMPUTE, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(v, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(&r->radiance, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(&r->v_raw, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC),
    };
    to_copy[count] = pn_gpu_image_barrier(&r->shadow.counts, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC);
    to_copy[count + 1] = pn_gpu_image_barrier(&r->shadow.rays, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC);
    pn_gpu_cmd_barrier(cmd, NULL, (uint32_t)count + 2, to_copy);
    if (r->desc.filter == PN_FILTER_PENUMBRA) {
        // The footprint (the last light's), left in SRC: the next frame's penumbra pass discards it.
        VkImageMemoryBarrier2 b = pn_gpu_image_barrier(&r->penumbra.scratch, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC);
        pn_gpu_cmd_barrier(cmd, NULL, 1, &b);
        VkBufferImageCopy copy = {
            .bufferOffset = (VkDeviceSize)PN_READBACK_FOOTPRINT * 4 * pn_renderer_readback_plane(r),
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, r->penumbra.scratch.image, SRC, r->readback.buffer, 1, &copy);
    }
    VkDeviceSize px = pn_renderer_readback_plane(r), offset = 0;
    for (int i = 0; i < count; i++) {
        VkBufferImageCopy copy = {
            .bufferOffset = offset,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, src[i]->image, SRC, r->readback.buffer, 1, &copy);
        offset += px * (src[i]->format == VK_FORMAT_R32_SFLOAT ? 4 : 16);
    }
    // The shadow pass's counts and rays (the last light's), at their place after V_raw's, filtered
    // or not.
    const pn_gpu_image *shadow[2] = {&r->shadow.counts, &r->shadow.rays};
    for (int i = 0; i < 2; i++) {
        VkBufferImageCopy copy = {
            .bufferOffset = (PN_READBACK_COUNTS + 4 * i) * 4 * px,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, shadow[i]->image, SRC, r->readback.buffer, 1, &copy);
    }
    if (r->history_frames) {
        // The history's counts (the last light's), back to GENERAL for the next light's or frame's pass.
        VkImageMemoryBarrier2 b = pn_gpu_image_barrier(&r->history.out, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC);
        pn_gpu_cmd_barrier(cmd, NULL, 1, &b);
        VkBufferImageCopy copy = {
            .bufferOffset = (VkDeviceSize)pn_renderer_readback_history(r) * 4 * px,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, r->history.out.image, SRC, r->readback.buffer, 1, &copy);
        b = pn_gpu_image_barrier(&r->history.out, COPY, VK_ACCESS_2_NONE, COMPUTE, STORAGE, SRC, GENERAL);
        pn_gpu_cmd_barrier(cmd, NULL, 1, &b);
    }
    // Back to the shadow pass's layout after the copy: a frame that continues this one's adaptive
    // samples (pn_renderer_set_continue) takes counts, half counts and rays from GENERAL.
    VkImageMemoryBarrier2 back[2] = {
        pn_gpu_image_barrier(&r->shadow.counts, COPY, VK_ACCESS_2_NONE, COMPUTE, STORAGE, SRC, GENERAL),
        pn_gpu_image_barrier(&r->shadow.rays, COPY, VK_ACCESS_2_NONE, COMPUTE, STORAGE, SRC, GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 2, back);
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){
                           .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                           .srcStageMask = COPY | COMPUTE,
                           .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                           .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
                           .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT,
                       },
                       0, NULL);
}

// Copies V as the interleaved filter wrote it to its place in the readback buffer: after the filter
// pass's writes, and before the penumbra pass's, which read it and rewrite it in place, in GENERAL
// (the layout the passes keep it in) again. And the shadow pass's nearest blockers, which the
// filter pass read (its window's weights), back to GENERAL for the next light's or frame's shadow
// pass. The readback's last barrier makes the copies visible to the host with the others.
void pn_renderer_record_window_copy(pn_renderer *r, VkCommandBuffer cmd)
{
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, COPY = VK_PIPELINE_STAGE_2_COPY_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL, SRC = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    const VkAccessFlags2 WRITE = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, READ = VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
    const pn_gpu_image *src[2] = {&r->v, &r->shadow.blockers};
    const VkDeviceSize plane = pn_renderer_readback_plane(r), floats[2] = {PN_READBACK_V_WINDOW, PN_READBACK_BLOCKERS};
    // V: written by the filter pass. The blockers: written by the shadow pass, read by the filter
    // pass (the copy must not overtake either).
    VkImageMemoryBarrier2 before[2] = {
        pn_gpu_image_barrier(src[0], COMPUTE, WRITE, COPY, VK_ACCESS_2_TRANSFER_READ_BIT, GENERAL, SRC),
        pn_gpu_image_barrier(src[1], COMPUTE, WRITE | READ, COPY, VK_ACCESS_2_TRANSFER_READ_BIT, GENERAL, SRC),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 2, before);
    for (int k = 0; k < 2; k++) {
        VkBufferImageCopy copy = {
            .bufferOffset = floats[k] * 4 * plane,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, src[k]->image, SRC, r->readback.buffer, 1, &copy);
    }
    VkImageMemoryBarrier2 after[2] = {
        pn_gpu_image_barrier(src[0], COPY, VK_ACCESS_2_NONE, COMPUTE, READ | WRITE, SRC, GENERAL),
        pn_gpu_image_barrier(src[1], COPY, VK_ACCESS_2_NONE, COMPUTE, READ | WRITE, SRC, GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 2, after);
}

// Copies light `i`'s V (and V_raw with a filter) to its place after the readback's images
// (pn_renderer_images), in the GENERAL layout the passes keep them in.
void pn_renderer_record_light_copy(pn_renderer *r, VkCommandBuffer cmd, uint32_t i)
{
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, COPY = VK_PIPELINE_STAGE_2_COPY_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL, SRC = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    const VkAccessFlags2 WRITE = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, READ = VK_ACCESS_2_TRANSFER_READ_BIT;
    const pn_gpu_image *src[2] = {filtered(r) ? &r->v : &r->v_raw, &r->v_raw};
    uint32_t count = filtered(r) ? 2 : 1;
    VkImageMemoryBarrier2 to_copy[2] = {
        pn_gpu_image_barrier(src[0], COMPUTE, WRITE, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(src[1], COMPUTE, WRITE, COPY, READ, GENERAL, SRC),
    };
    pn_gpu_cmd_barrier(cmd, NULL, count, to_copy);
    VkDeviceSize px = pn_renderer_readback_plane(r);
    for (uint32_t k = 0; k < count; k++) {
        VkBufferImageCopy copy = {
            .bufferOffset = (pn_renderer_readback_floats(r) + 2 * i + k) * 4 * px,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, src[k]->image, SRC, r->readback.buffer, 1, &copy);
    }
    // Back to the passes' layout, after the copy: the next light rewrites them, the readback reads
    // them from GENERAL.
    VkImageMemoryBarrier2 back[2] = {
        pn_gpu_image_barrier(src[0], COPY, VK_ACCESS_2_NONE, COMPUTE | COPY, WRITE | READ, SRC, GENERAL),
        pn_gpu_image_barrier(src[1], COPY, VK_ACCESS_2_NONE, COMPUTE | COPY, WRITE | READ, SRC, GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, count, back);
}

// The readback buffer holds the frame's images and, with several lights, every light's V and V_raw.
pn_result pn_renderer_reserve_readback(pn_renderer *r, uint32_t light_count)
{
    VkDeviceSize px = pn_renderer_readback_plane(r);
    VkDeviceSize bytes = px * 4 * (pn_renderer_readback_floats(r) + (light_count > 1 ? 2 * light_count : 0));
    if (r->readback.size >= bytes)
        return PN_OK;
    pn_gpu_buffer_destroy(r->dev, &r->readback);
    return pn_gpu_buffer_create(r->dev, "frame's readback buffer", bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                PN_GPU_HOST_READBACK, &r->readback);
}

void pn_renderer_images(const pn_renderer *r, pn_frame_images *out)
{
    size_t px = pn_renderer_readback_plane(r);
    const float *base = r->readback.mapped;
    memset(out, 0, sizeof *out);
    out->p = base;
    out->n = out->p + 4 * px;
    out->albedo = out->n + 4 * px;
    out->v = out->albedo + 4 * px;
    out->radiance = out->v + px;
    out->v_raw = filtered(r) ? out->radiance + 4 * px : NULL;
    out->counts = (const uint32_t *)(base + PN_READBACK_COUNTS * px);
    out->rays = r->rays_written ? (const uint32_t *)(base + PN_READBACK_RAYS * px) : NULL;
    out->footprint = r->desc.filter == PN_FILTER_PENUMBRA ? base + PN_READBACK_FOOTPRINT * px : NULL;
    out->v_window = keeps_window(r) ? base + PN_READBACK_V_WINDOW * px : NULL;
    out->blockers = keeps_window(r) ? base + PN_READBACK_BLOCKERS * px : NULL;
    out->history = r->history_frames ? base + pn_renderer_readback_history(r) * px : NULL;
    out->light_count = r->light_count ? r->light_count : 1;
    if (out->light_count == 1) {
        out->v_light[0] = out->v;
        out->v_raw_light[0] = out->v_raw;
        return;
    }
    // Several lights: each one's V and V_raw after the images (pn_renderer_record_light_copy); V is light 0's.
    for (uint32_t i = 0; i < out->light_count; i++) {
        out->v_light[i] = base + (pn_renderer_readback_floats(r) + 2 * i) * px;
        out->v_raw_light[i] = filtered(r) ? out->v_light[i] + px : NULL;
    }
    out->v = out->v_light[0];
    out->v_raw = out->v_raw_light[0];
}
