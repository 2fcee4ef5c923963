// A swapchain fed from host memory. The demo composes each frame on the CPU (tone mapping, overlay
// text) into a staging buffer; presenting copies it into the acquired image with
// vkCmdCopyBufferToImage. One frame in flight: the renderer waits for every frame anyway.
//
// The image format is an 8-bit UNORM one (B8G8R8A8 or R8G8B8A8): the pixels written are already
// sRGB-encoded, and an _SRGB format would encode them a second time on the way out.
//
// Typical frame:
//     bool stale;
//     pn_swapchain_acquire(&sc, &stale);  // stale: pn_swapchain_recreate and skip the frame
//     write sc.extent.width * sc.extent.height pixels to sc.staging.mapped
//     pn_swapchain_present(&sc, &stale);  // stale: recreate before the next acquire
#pragma once
#include <stdbool.h>

#include "gpu/resources.h"

#define PN_SWAPCHAIN_MAX_IMAGES 8

typedef struct pn_swapchain_desc {
    VkSurfaceKHR surface;   // taken over: destroyed by pn_swapchain_destroy, or by a failed create
    uint32_t width, height; // the window's framebuffer size, for surfaces that leave the size to us
    bool vsync;             // FIFO; else IMMEDIATE or MAILBOX when the surface offers them
} pn_swapchain_desc;

typedef struct pn_swapchain {
    pn_gpu_device *dev;
    VkSurfaceKHR surface;
    VkSwapchainKHR swapchain; // VK_NULL_HANDLE while the surface has no area (minimised)
    VkFormat format;
    bool bgra;                // pixel byte order B, G, R, A (else R, G, B, A)
    VkPresentModeKHR present_mode;
    VkExtent2D extent;        // 0x0 while minimised
    uint32_t image_count;
    VkImage images[PN_SWAPCHAIN_MAX_IMAGES];
    // Per image, signalled when its copy is done and waited for by its present. Per image rather
    // than per frame: a present's wait is only known to be over once that image is acquired again.
    VkSemaphore copied[PN_SWAPCHAIN_MAX_IMAGES];
    VkSemaphore acquired;     // signalled by the acquire, waited for by the copy
    VkFence done;             // the last copy finished: staging, command buffer and `acquired` are free
    VkCommandBuffer cmd;
    pn_gpu_buffer staging;    // extent.width * extent.height 32-bit pixels, row 0 at the top
    uint32_t image;           // the acquired image, or UINT32_MAX
    bool vsync;
} pn_swapchain;

// Picks format and present mode and creates the swapchain at the surface's current size. Fails
// (logged) when the device's queue cannot present to the surface or the surface offers no 8-bit
// UNORM format that can be a copy destination.
pn_result pn_swapchain_create(pn_gpu_device *dev, const pn_swapchain_desc *desc, pn_swapchain *out);

// Recreates images and staging buffer at the surface's current size (width, height when the
// surface leaves it open), e.g. after a resize or an out-of-date acquire or present. Waits for the
// device first. A surface without area leaves extent 0x0 and no swapchain: skip frames until the
// window has a size again, then recreate.
pn_result pn_swapchain_recreate(pn_swapchain *sc, uint32_t width, uint32_t height);

void pn_swapchain_destroy(pn_swapchain *sc);

// Waits for the previous copy, then acquires the next image. *stale is set when the swapchain no
// longer fits the surface and nothing was acquired: recreate it and skip the frame.
pn_result pn_swapchain_acquire(pn_swapchain *sc, bool *stale);

// Copies the staging pixels into the acquired image and queues it for presentation. *stale is set
// when the swapchain should be recreated before the next acquire (suboptimal or out of date).
pn_result pn_swapchain_present(pn_swapchain *sc, bool *stale);
