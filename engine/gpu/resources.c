// Buffers, images and barriers: one allocation each, created, uploaded and destroyed.
#include "gpu/resources.h"

#include <stdio.h>
#include <string.h>

static double mib(VkDeviceSize bytes) { return (double)bytes / 1048576.0; }

// A size for the messages: small buffers in KiB or bytes, so that none reads "0.0 MiB".
static const char *size_str(VkDeviceSize bytes, char buf[32])
{
    if (bytes >= 1048576)
        snprintf(buf, 32, "%.1f MiB", mib(bytes));
    else if (bytes >= 1024)
        snprintf(buf, 32, "%.1f KiB", (double)bytes / 1024.0);
    else
        snprintf(buf, 32, "%llu bytes", (unsigned long long)bytes);
    return buf;
}

// The one place penumbra allocates device memory. `what` names the resource for the messages
// ("node pool"): a failure says what did not fit, how big it was and against which limit.
static pn_result allocate(pn_gpu_device *dev, const char *what, VkMemoryRequirements req, VkMemoryPropertyFlags want,
                          VkMemoryPropertyFlags fallback, bool device_address, VkDeviceMemory *out)
{
    uint32_t type = pn_gpu_memory_type(dev, req.memoryTypeBits, want);
    if (type == UINT32_MAX)
        type = pn_gpu_memory_type(dev, req.memoryTypeBits, fallback);
    if (type == UINT32_MAX) {
        pn_error("no Vulkan memory type for the %s (%llu bytes)", what, (unsigned long long)req.size);
        return PN_ERR_VULKAN;
    }
    // Refused before asking: past maxMemoryAllocationSize a driver may fail, or may not and
    // misbehave later.
    VkDeviceSize max_alloc = dev->maintenance3.maxMemoryAllocationSize;
    if (max_alloc && req.size > max_alloc) {
        pn_error("the %s needs %.1f MiB, more than one allocation of this device can hold (maxMemoryAllocationSize "
                 "%.1f MiB)",
                 what, mib(req.size), mib(max_alloc));
        return PN_ERR_MEMORY;
    }
    VkMemoryAllocateFlagsInfo flags = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO,
        .flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT,
    };
    VkMemoryAllocateInfo ai = {
        .sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO,
        .pNext = device_address ? &flags : NULL,
        .allocationSize = req.size,
        .memoryTypeIndex = type,
    };
    VkResult r = pn_gpu_fault(dev, "vkAllocateMemory", what, req.size) ? VK_ERROR_OUT_OF_DEVICE_MEMORY
                                                                      : vkAllocateMemory(dev->device, &ai, NULL, out);
    if (r != VK_SUCCESS)
        *out = VK_NULL_HANDLE; // the spec leaves it undefined: the caller's destroy must not free it
    if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY) {
        char size[32];
        pn_error("out of %s memory allocating the %s (%s; %.1f MiB already held, device-local heap %.1f MiB)",
                 r == VK_ERROR_OUT_OF_HOST_MEMORY ? "host" : "device", what, size_str(req.size, size),
                 mib(dev->memory_bytes), mib(pn_gpu_device_heap(dev)));
        return PN_ERR_MEMORY;
    }
    VK_CHECK(r);
    dev->memory_bytes += req.size;
    dev->memory_allocations++;
    return PN_OK;
}

// Every vkFreeMemory of penumbra goes through here, so that the tally matches the live allocations.
static void release(pn_gpu_device *dev, VkDeviceMemory memory, VkDeviceSize bytes)
{
    vkFreeMemory(dev->device, memory, NULL); // unmaps implicitly
    dev->memory_bytes -= bytes;
    dev->memory_allocations--;
}

// Creates a buffer or image handle: its own fault point, as a driver may refuse the handle alone.
static pn_result check_create(pn_gpu_device *dev, VkResult r, const char *call, const char *what, VkDeviceSize size)
{
    if (r == VK_SUCCESS)
        return PN_OK;
    char bytes[32];
    pn_error("%s failed for the %s (%s): %s", call, what, size_str(size, bytes), pn_vk_result_str(r));
    return r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY ? PN_ERR_MEMORY : PN_ERR_VULKAN;
}

pn_result pn_gpu_buffer_create(pn_gpu_device *dev, const char *name, VkDeviceSize size, VkBufferUsageFlags usage,
                               pn_gpu_memory memory, pn_gpu_buffer *out)
{
    memset(out, 0, sizeof *out);
    // Past maxBufferSize vkCreateBuffer is invalid usage, not a failure: refused here.
    VkDeviceSize max_buffer = dev->maintenance4.maxBufferSize;
    if (max_buffer && size > max_buffer) {
        pn_error("the %s needs %.1f MiB, more than one buffer of this device can hold (maxBufferSize %.1f MiB)", name,
                 mib(size), mib(max_buffer));
        return PN_ERR_MEMORY;
    }
    out->size = size;
    VkBufferCreateInfo bi = {
        .sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO,
        .size = size ? size : 16,
        .usage = usage,
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
    };
    VkResult vr = pn_gpu_fault(dev, "vkCreateBuffer", name, size) ? VK_ERROR_OUT_OF_DEVICE_MEMORY
                                                                  : vkCreateBuffer(dev->device, &bi, NULL, &out->buffer);
    if (vr != VK_SUCCESS)
        out->buffer = VK_NULL_HANDLE;
    PN_TRY(check_create(dev, vr, "vkCreateBuffer", name, size));
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(dev->device, out->buffer, &req);
    VkMemoryPropertyFlags want, fallback;
    switch (memory) {
    case PN_GPU_DEVICE_LOCAL:
        want = fallback = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
        break;
    case PN_GPU_HOST_UPLOAD:
        want = fallback = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        break;
    default: // readback prefers cached memory: the CPU reads every byte
        want = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT | VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
        fallback = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        break;
    }
    bool address = (usage & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT) != 0;
    pn_result r = allocate(dev, name, req, want, fallback, address, &out->memory);
    if (r == PN_OK)
        out->memory_bytes = req.size;
    if (r == PN_OK && (vr = vkBindBufferMemory(dev->device, out->buffer, out->memory, 0)) != VK_SUCCESS)
        r = check_create(dev, vr, "vkBindBufferMemory", name, size);
    if (r == PN_OK && memory != PN_GPU_DEVICE_LOCAL &&
        (vr = vkMapMemory(dev->device, out->memory, 0, VK_WHOLE_SIZE, 0, &out->mapped)) != VK_SUCCESS)
        r = check_create(dev, vr, "vkMapMemory", name, size);
    if (r != PN_OK) {
        pn_gpu_buffer_destroy(dev, out);
        return r;
    }
    if (address) {
        VkBufferDeviceAddressInfo ai = {.sType = VK_STRUCTURE_TYPE_BUFFER_DEVICE_ADDRESS_INFO, .buffer = out->buffer};
        out->address = vkGetBufferDeviceAddress(dev->device, &ai);
    }
    return PN_OK;
}

void pn_gpu_buffer_destroy(pn_gpu_device *dev, pn_gpu_buffer *buf)
{
    if (buf->buffer)
        vkDestroyBuffer(dev->device, buf->buffer, NULL);
    if (buf->memory)
        release(dev, buf->memory, buf->memory_bytes);
    memset(buf, 0, sizeof *buf);
}

// Copies `size` bytes of `data` to `dst` at `offset` through a staging buffer, and waits.
static pn_result copy_through_staging(pn_gpu_device *dev, const char *name, const pn_gpu_buffer *dst,
                                      VkDeviceSize offset, const void *data, VkDeviceSize size)
{
    pn_gpu_buffer staging;
    char what[160];
    snprintf(what, sizeof what, "staging buffer of the %s", name);
    PN_TRY(pn_gpu_buffer_create(dev, what, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, PN_GPU_HOST_UPLOAD, &staging));
    memcpy(staging.mapped, data, size);
    VkCommandBuffer cmd;
    pn_result r = pn_gpu_begin_once(dev, &cmd);
    if (r == PN_OK) {
        vkCmdCopyBuffer(cmd, staging.buffer, dst->buffer, 1, &(VkBufferCopy){.dstOffset = offset, .size = size});
        // Later submissions read it in any stage: make the copy visible to all of them.
        pn_gpu_cmd_barrier(cmd,
                           &(VkMemoryBarrier2){
                               .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                               .srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT,
                               .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT,
                               .dstStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                               .dstAccessMask = VK_ACCESS_2_MEMORY_READ_BIT,
                           },
                           0, NULL);
        r = pn_gpu_submit_wait(dev, cmd);
    }
    pn_gpu_buffer_destroy(dev, &staging);
    return r;
}

pn_result pn_gpu_buffer_create_with_data(pn_gpu_device *dev, const char *name, const void *data, VkDeviceSize size,
                                         VkBufferUsageFlags usage, pn_gpu_buffer *out)
{
    pn_result r = pn_gpu_buffer_create(dev, name, size, usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, PN_GPU_DEVICE_LOCAL, out);
    if (r == PN_OK)
        r = copy_through_staging(dev, name, out, 0, data, size);
    if (r != PN_OK)
        pn_gpu_buffer_destroy(dev, out);
    return r;
}

pn_result pn_gpu_buffer_write(pn_gpu_device *dev, const char *name, pn_gpu_buffer *buf, VkDeviceSize offset,
                              const void *data, VkDeviceSize size)
{
    if (offset > buf->size || size > buf->size - offset) {
        pn_error("buffer write of %llu bytes at %llu past the buffer's %llu", (unsigned long long)size,
                 (unsigned long long)offset, (unsigned long long)buf->size);
        return PN_ERR_INVALID;
    }
    return size ? copy_through_staging(dev, name, buf, offset, data, size) : PN_OK;
}

pn_result pn_gpu_image_create(pn_gpu_device *dev, const pn_gpu_image_desc *desc, pn_gpu_image *out)
{
    memset(out, 0, sizeof *out);
    out->format = desc->format;
    out->extent = (VkExtent2D){desc->width, desc->height};
    out->mip_levels = desc->mip_levels ? desc->mip_levels : 1;
    out->layers = desc->layers ? desc->layers : 1;
    VkImageCreateInfo ii = {
        .sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO,
        .imageType = VK_IMAGE_TYPE_2D,
        .format = desc->format,
        .extent = {desc->width, desc->height, 1},
        .mipLevels = out->mip_levels,
        .arrayLayers = out->layers,
        .samples = VK_SAMPLE_COUNT_1_BIT,
        .tiling = VK_IMAGE_TILING_OPTIMAL,
        .usage = desc->usage,
        .sharingMode = VK_SHARING_MODE_EXCLUSIVE,
        .initialLayout = VK_IMAGE_LAYOUT_UNDEFINED,
    };
    const char *name = desc->name ? desc->name : "image";
    // Its size is only known once created: the texels' for the messages until then.
    VkDeviceSize texels = (VkDeviceSize)desc->width * desc->height * 16;
    VkResult vr = pn_gpu_fault(dev, "vkCreateImage", name, texels) ? VK_ERROR_OUT_OF_DEVICE_MEMORY
                                                                   : vkCreateImage(dev->device, &ii, NULL, &out->image);
    if (vr != VK_SUCCESS)
        out->image = VK_NULL_HANDLE;
    PN_TRY(check_create(dev, vr, "vkCreateImage", name, texels));
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(dev->device, out->image, &req);
    pn_result r = allocate(dev, name, req, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, 0, false, &out->memory);
    if (r == PN_OK)
        out->memory_bytes = req.size;
    if (r == PN_OK && (vr = vkBindImageMemory(dev->device, out->image, out->memory, 0)) != VK_SUCCESS)
        r = check_create(dev, vr, "vkBindImageMemory", name, req.size);
    if (r != PN_OK) {
        pn_gpu_image_destroy(dev, out);
        return r;
    }
    VkImageViewCreateInfo vi = {
        .sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO,
        .image = out->image,
        .viewType = desc->layers ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D,
        .format = desc->format,
        .subresourceRange = {desc->aspect ? desc->aspect : VK_IMAGE_ASPECT_COLOR_BIT, 0, out->mip_levels, 0, out->layers},
    };
    if ((vr = vkCreateImageView(dev->device, &vi, NULL, &out->view)) != VK_SUCCESS) {
        out->view = VK_NULL_HANDLE;
        r = check_create(dev, vr, "vkCreateImageView", name, req.size);
        pn_gpu_image_destroy(dev, out);
    }
    return r;
}

void pn_gpu_image_destroy(pn_gpu_device *dev, pn_gpu_image *img)
{
    if (img->view)
        vkDestroyImageView(dev->device, img->view, NULL);
    if (img->image)
        vkDestroyImage(dev->device, img->image, NULL);
    if (img->memory)
        release(dev, img->memory, img->memory_bytes);
    memset(img, 0, sizeof *img);
}

static VkImageAspectFlags aspect_of(VkFormat f)
{
    return f == VK_FORMAT_D32_SFLOAT || f == VK_FORMAT_D16_UNORM ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
}

VkImageMemoryBarrier2 pn_gpu_image_barrier(const pn_gpu_image *img, VkPipelineStageFlags2 src_stage,
                                           VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage,
                                           VkAccessFlags2 dst_access, VkImageLayout old_layout,
                                           VkImageLayout new_layout)
{
    return (VkImageMemoryBarrier2){
        .sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2,
        .srcStageMask = src_stage,
        .srcAccessMask = src_access,
        .dstStageMask = dst_stage,
        .dstAccessMask = dst_access,
        .oldLayout = old_layout,
        .newLayout = new_layout,
        .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .image = img->image,
        .subresourceRange = {aspect_of(img->format), 0, VK_REMAINING_MIP_LEVELS, 0, VK_REMAINING_ARRAY_LAYERS},
    };
}

void pn_gpu_cmd_barrier(VkCommandBuffer cmd, const VkMemoryBarrier2 *memory, uint32_t image_count,
                        const VkImageMemoryBarrier2 *images)
{
    VkDependencyInfo di = {
        .sType = VK_STRUCTURE_TYPE_DEPENDENCY_INFO,
        .memoryBarrierCount = memory ? 1 : 0,
        .pMemoryBarriers = memory,
        .imageMemoryBarrierCount = image_count,
        .pImageMemoryBarriers = images,
    };
    vkCmdPipelineBarrier2(cmd, &di);
}

static uint32_t mip_count(uint32_t w, uint32_t h)
{
    uint32_t n = 1;
    while ((w | h) >> n)
        n++;
    return n;
}

pn_result pn_gpu_texture_create(pn_gpu_device *dev, const char *name, uint32_t width, uint32_t height,
                                const uint8_t *rgba, pn_gpu_image *out)
{
    memset(out, 0, sizeof *out);
    VkDeviceSize size = (VkDeviceSize)width * height * 4;
    uint32_t mips = mip_count(width, height);
    pn_gpu_buffer staging;
    char what[160];
    snprintf(what, sizeof what, "staging buffer of the %s", name);
    PN_TRY(pn_gpu_buffer_create(dev, what, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, PN_GPU_HOST_UPLOAD, &staging));
    memcpy(staging.mapped, rgba, size);
    pn_result r = pn_gpu_image_create(dev,
                                      &(pn_gpu_image_desc){
                                          .name = name,
                                          .format = VK_FORMAT_R8G8B8A8_SRGB,
                                          .width = width,
                                          .height = height,
                                          .mip_levels = mips,
                                          .usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                                                   VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                      },
                                      out);
    VkCommandBuffer cmd;
    if (r == PN_OK)
        r = pn_gpu_begin_once(dev, &cmd);
    if (r != PN_OK) {
        pn_gpu_buffer_destroy(dev, &staging);
        pn_gpu_image_destroy(dev, out);
        return r;
    }
    VkImageMemoryBarrier2 b = pn_gpu_image_barrier(out, VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                                                   VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                                                   VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    pn_gpu_cmd_barrier(cmd, NULL, 1, &b);
    VkBufferImageCopy copy = {
        .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
        .imageExtent = {width, height, 1},
    };
    vkCmdCopyBufferToImage(cmd, staging.buffer, out->image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
    // Each mip is blitted from the one above, which first moves to TRANSFER_SRC; sRGB blits filter
    // in linear space, so the mips keep the right average brightness.
    int32_t w = (int32_t)width, h = (int32_t)height;
    for (uint32_t m = 1; m < mips; m++) {
        VkImageMemoryBarrier2 to_src = pn_gpu_image_barrier(out, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                                            VK_PIPELINE_STAGE_2_BLIT_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                                                            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                                            VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
        to_src.subresourceRange.baseMipLevel = m - 1;
        to_src.subresourceRange.levelCount = 1;
        pn_gpu_cmd_barrier(cmd, NULL, 1, &to_src);
        int32_t nw = w > 1 ? w / 2 : 1, nh = h > 1 ? h / 2 : 1;
        VkImageBlit blit = {
            .srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, m - 1, 0, 1},
            .srcOffsets = {{0, 0, 0}, {w, h, 1}},
            .dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, m, 0, 1},
            .dstOffsets = {{0, 0, 0}, {nw, nh, 1}},
        };
        vkCmdBlitImage(cmd, out->image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, out->image,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
        w = nw, h = nh;
    }
    // All but the last mip are TRANSFER_SRC now, the last is TRANSFER_DST.
    VkImageMemoryBarrier2 fin[2];
    fin[0] = pn_gpu_image_barrier(out, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                                  VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                                  VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    fin[0].subresourceRange.levelCount = mips - 1;
    fin[1] = pn_gpu_image_barrier(out, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                  VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                                  VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    fin[1].subresourceRange.baseMipLevel = mips - 1;
    fin[1].subresourceRange.levelCount = 1;
    pn_gpu_cmd_barrier(cmd, NULL, mips > 1 ? 2 : 1, mips > 1 ? fin : fin + 1);
    r = pn_gpu_submit_wait(dev, cmd);
    pn_gpu_buffer_destroy(dev, &staging);
    if (r != PN_OK)
        pn_gpu_image_destroy(dev, out);
    return r;
}
