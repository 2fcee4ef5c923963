// Buffers, images and the barrier helpers the passes use. One allocation per resource: penumbra
// has few, large resources, so a sub-allocator would buy nothing.
#pragma once
#include "gpu/device.h"

typedef struct pn_gpu_buffer {
    VkBuffer buffer;
    VkDeviceMemory memory;
    VkDeviceSize size;
    VkDeviceSize memory_bytes; // of `memory` (the driver's requirement, >= size): the device's tally
    void *mapped;           // non-NULL for host-visible buffers (persistently mapped)
    VkDeviceAddress address; // with VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT in the usage
} pn_gpu_buffer;

typedef enum pn_gpu_memory { PN_GPU_DEVICE_LOCAL, PN_GPU_HOST_UPLOAD, PN_GPU_HOST_READBACK } pn_gpu_memory;

// `name` says what the buffer is for ("node pool"): every failure's message names it, with its size
// and the limit it did not fit (maxBufferSize, maxMemoryAllocationSize, the heap). All or nothing:
// on failure *out is zeroed and nothing is held.
pn_result pn_gpu_buffer_create(pn_gpu_device *dev, const char *name, VkDeviceSize size, VkBufferUsageFlags usage,
                               pn_gpu_memory memory, pn_gpu_buffer *out);
void pn_gpu_buffer_destroy(pn_gpu_device *dev, pn_gpu_buffer *buf);

// Creates a device-local buffer holding `data`, through a staging buffer. The copy is complete and
// visible to every later command on the queue when this returns.
pn_result pn_gpu_buffer_create_with_data(pn_gpu_device *dev, const char *name, const void *data, VkDeviceSize size,
                                         VkBufferUsageFlags usage, pn_gpu_buffer *out);

// Overwrites bytes [offset, offset + size) of a device-local buffer made by
// pn_gpu_buffer_create_with_data (which gives it TRANSFER_DST), through a staging buffer. The queue
// must be idle (no submitted command still reads the buffer); the copy is complete and visible to
// every later command when this returns.
pn_result pn_gpu_buffer_write(pn_gpu_device *dev, const char *name, pn_gpu_buffer *buf, VkDeviceSize offset,
                              const void *data, VkDeviceSize size);

typedef struct pn_gpu_image {
    VkImage image;
    VkDeviceMemory memory;
    VkDeviceSize memory_bytes; // of `memory`: the device's tally
    VkImageView view;
    VkFormat format;
    VkExtent2D extent;
    uint32_t mip_levels;
    uint32_t layers;
} pn_gpu_image;

typedef struct pn_gpu_image_desc {
    const char *name; // for the messages, as pn_gpu_buffer_create's (NULL: "image")
    VkFormat format;
    uint32_t width, height;
    uint32_t mip_levels; // 0 means 1
    VkImageUsageFlags usage;
    VkImageAspectFlags aspect; // 0 means colour
    uint32_t layers;           // 0: one, viewed as a 2D image; otherwise this many, as a 2D array
                               // (last: the fields before it may be given in order)
} pn_gpu_image_desc;

pn_result pn_gpu_image_create(pn_gpu_device *dev, const pn_gpu_image_desc *desc, pn_gpu_image *out);
void pn_gpu_image_destroy(pn_gpu_device *dev, pn_gpu_image *img);

// Creates a mipmapped R8G8B8A8_SRGB texture from `rgba`, in SHADER_READ_ONLY_OPTIMAL layout.
pn_result pn_gpu_texture_create(pn_gpu_device *dev, const char *name, uint32_t width, uint32_t height,
                                const uint8_t *rgba, pn_gpu_image *out);

// An image memory barrier over all mips and layers of `img`, for vkCmdPipelineBarrier2.
VkImageMemoryBarrier2 pn_gpu_image_barrier(const pn_gpu_image *img, VkPipelineStageFlags2 src_stage,
                                           VkAccessFlags2 src_access, VkPipelineStageFlags2 dst_stage,
                                           VkAccessFlags2 dst_access, VkImageLayout old_layout,
                                           VkImageLayout new_layout);

// Records one vkCmdPipelineBarrier2 with optional global memory barrier and image barriers.
void pn_gpu_cmd_barrier(VkCommandBuffer cmd, const VkMemoryBarrier2 *memory, uint32_t image_count,
                        const VkImageMemoryBarrier2 *images);
