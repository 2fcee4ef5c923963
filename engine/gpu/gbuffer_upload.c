// A G-buffer read from an EXR (bench --shader shadow --gbuffer) put where the raster pass would
// write.
#include "gpu/gbuffer_upload.h"

#include <string.h>

pn_result pn_gbuffer_upload_create(pn_gpu_device *dev, uint32_t width, uint32_t height, const float *p, const float *n,
                                   pn_gbuffer_upload *out)
{
    memset(out, 0, sizeof *out);
    VkDeviceSize bytes = (VkDeviceSize)width * height * 16;
    PN_TRY(pn_gpu_buffer_create(dev, "G-buffer upload", 2 * bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, PN_GPU_HOST_UPLOAD, &out->buffer));
    memcpy(out->buffer.mapped, p, bytes);
    memcpy((char *)out->buffer.mapped + bytes, n, bytes);
    return PN_OK;
}

void pn_gbuffer_upload_destroy(pn_gpu_device *dev, pn_gbuffer_upload *u) { pn_gpu_buffer_destroy(dev, &u->buffer); }

void pn_gbuffer_upload_record(VkCommandBuffer cmd, const pn_gbuffer_upload *u, const pn_gbuffer_targets *t)
{
    const VkPipelineStageFlags2 ALL = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    const VkPipelineStageFlags2 COPY = VK_PIPELINE_STAGE_2_COPY_BIT, CLEAR = VK_PIPELINE_STAGE_2_CLEAR_BIT;
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    const VkAccessFlags2 WRITE = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    const VkAccessFlags2 READ = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL, DST = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    const VkImageLayout UNDEF = VK_IMAGE_LAYOUT_UNDEFINED;
    VkImageMemoryBarrier2 start[3] = {
        pn_gpu_image_barrier(t->p, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COPY, WRITE, UNDEF, DST),
        pn_gpu_image_barrier(t->n, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COPY, WRITE, UNDEF, DST),
        pn_gpu_image_barrier(t->albedo, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, CLEAR, WRITE, UNDEF, GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 3, start);
    VkDeviceSize px = (VkDeviceSize)t->width * t->height;
    const pn_gpu_image *dst[2] = {t->p, t->n};
    for (int i = 0; i < 2; i++) {
        VkBufferImageCopy copy = {
            .bufferOffset = (VkDeviceSize)i * px * 16,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {t->width, t->height, 1},
        };
        vkCmdCopyBufferToImage(cmd, u->buffer.buffer, dst[i]->image, DST, 1, &copy);
    }
    // Albedo is not part of the input: black, so the shade pass reads defined values.
    vkCmdClearColorImage(cmd, t->albedo->image, GENERAL, &(VkClearColorValue){{0, 0, 0, 0}}, 1,
                         &(VkImageSubresourceRange){VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1});
    VkImageMemoryBarrier2 ready[3] = {
        pn_gpu_image_barrier(t->p, COPY, WRITE, COMPUTE | COPY, READ, DST, GENERAL),
        pn_gpu_image_barrier(t->n, COPY, WRITE, COMPUTE | COPY, READ, DST, GENERAL),
        pn_gpu_image_barrier(t->albedo, CLEAR, WRITE, COMPUTE | COPY, READ, GENERAL, GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 3, ready);
}
