// The demo's swapchain: its images filled from host memory and presented.
#include "gpu/swapchain.h"

#include <string.h>

static pn_result pick_format(pn_swapchain *sc)
{
    pn_gpu_device *dev = sc->dev;
    VkSurfaceFormatKHR formats[64];
    uint32_t n = 64;
    VkResult r = vkGetPhysicalDeviceSurfaceFormatsKHR(dev->physical, sc->surface, &n, formats);
    if (r != VK_INCOMPLETE)
        VK_CHECK(r);
    // UNORM only: the pixels arrive sRGB-encoded (see swapchain.h).
    const VkFormat wanted[2] = {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM};
    for (int w = 0; w < 2; w++)
        for (uint32_t i = 0; i < n; i++)
            if (formats[i].format == wanted[w] && formats[i].colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) {
                sc->format = wanted[w];
                sc->bgra = w == 0;
                return PN_OK;
            }
    pn_error("the window's surface offers neither B8G8R8A8_UNORM nor R8G8B8A8_UNORM (sRGB colour space)");
    return PN_ERR_UNSUPPORTED;
}

static pn_result pick_present_mode(pn_swapchain *sc)
{
    sc->present_mode = VK_PRESENT_MODE_FIFO_KHR; // the one mode every surface supports
    if (sc->vsync)
        return PN_OK;
    VkPresentModeKHR modes[16];
    uint32_t n = 16;
    VkResult r = vkGetPhysicalDeviceSurfacePresentModesKHR(sc->dev->physical, sc->surface, &n, modes);
    if (r != VK_INCOMPLETE)
        VK_CHECK(r);
    for (uint32_t i = 0; i < n; i++)
        if (modes[i] == VK_PRESENT_MODE_IMMEDIATE_KHR ||
            (modes[i] == VK_PRESENT_MODE_MAILBOX_KHR && sc->present_mode == VK_PRESENT_MODE_FIFO_KHR))
            sc->present_mode = modes[i];
    return PN_OK;
}

// Destroys what depends on the swapchain's images; the swapchain handle itself stays (it becomes
// the oldSwapchain of the next one).
static void destroy_images(pn_swapchain *sc)
{
    VkDevice d = sc->dev->device;
    for (uint32_t i = 0; i < sc->image_count; i++)
        if (sc->copied[i])
            vkDestroySemaphore(d, sc->copied[i], NULL);
    memset(sc->copied, 0, sizeof sc->copied);
    memset(sc->images, 0, sizeof sc->images);
    sc->image_count = 0;
    pn_gpu_buffer_destroy(sc->dev, &sc->staging);
}

pn_result pn_swapchain_recreate(pn_swapchain *sc, uint32_t width, uint32_t height)
{
    pn_gpu_device *dev = sc->dev;
    VkDevice d = dev->device;
    // Nothing may still use the old images, semaphores or staging buffer.
    VK_CHECK(vkDeviceWaitIdle(d));
    destroy_images(sc);
    sc->image = UINT32_MAX;

    VkSurfaceCapabilitiesKHR caps;
    VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(dev->physical, sc->surface, &caps));
    VkExtent2D extent = caps.currentExtent;
    if (extent.width == UINT32_MAX) { // the surface takes the swapchain's size: use the window's
        extent.width = width < caps.minImageExtent.width ? caps.minImageExtent.width
                       : width > caps.maxImageExtent.width ? caps.maxImageExtent.width : width;
        extent.height = height < caps.minImageExtent.height ? caps.minImageExtent.height
                        : height > caps.maxImageExtent.height ? caps.maxImageExtent.height : height;
    }
    VkSwapchainKHR old = sc->swapchain;
    sc->swapchain = VK_NULL_HANDLE;
    sc->extent = extent;
    if (extent.width == 0 || extent.height == 0) { // minimised: no swapchain until it has an area
        if (old)
            vkDestroySwapchainKHR(d, old, NULL);
        sc->extent = (VkExtent2D){0, 0};
        return PN_OK;
    }
    if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT)) {
        if (old)
            vkDestroySwapchainKHR(d, old, NULL);
        pn_error("the window's surface does not allow copying into its images (TRANSFER_DST)");
        return PN_ERR_UNSUPPORTED;
    }
    // One more than the minimum, so that the copy never waits for the presentation engine.
    uint32_t count = caps.minImageCount + 1;
    if (caps.maxImageCount && count > caps.maxImageCount)
        count = caps.maxImageCount;
    VkCompositeAlphaFlagBitsKHR alpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
    if (!(caps.supportedCompositeAlpha & alpha))
        for (uint32_t bit = 1; bit <= VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR; bit <<= 1)
            if (caps.supportedCompositeAlpha & bit) {
                alpha = (VkCompositeAlphaFlagBitsKHR)bit;
                break;
            }
    VkSwapchainCreateInfoKHR ci = {
        .sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR,
        .surface = sc->surface,
        .minImageCount = count,
        .imageFormat = sc->format,
        .imageColorSpace = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR,
        .imageExtent = extent,
        .imageArrayLayers = 1,
        .imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT,
        .imageSharingMode = VK_SHARING_MODE_EXCLUSIVE,
        .preTransform = caps.currentTransform,
        .compositeAlpha = alpha,
        .presentMode = sc->present_mode,
        .clipped = VK_TRUE,
        .oldSwapchain = old,
    };
    VkResult r = vkCreateSwapchainKHR(d, &ci, NULL, &sc->swapchain);
    if (old)
        vkDestroySwapchainKHR(d, old, NULL); // retired either way; no image of it is acquired
    VK_CHECK(r);

    uint32_t n = 0;
    VK_CHECK(vkGetSwapchainImagesKHR(d, sc->swapchain, &n, NULL));
    if (n > PN_SWAPCHAIN_MAX_IMAGES) {
        pn_error("the swapchain has %u images, more than the %d expected", n, PN_SWAPCHAIN_MAX_IMAGES);
        return PN_ERR_UNSUPPORTED;
    }
    VK_CHECK(vkGetSwapchainImagesKHR(d, sc->swapchain, &n, sc->images));
    sc->image_count = n;
    VkSemaphoreCreateInfo si = {.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    for (uint32_t i = 0; i < n; i++)
        VK_CHECK(vkCreateSemaphore(d, &si, NULL, &sc->copied[i]));
    PN_TRY(pn_gpu_buffer_create(dev, "swapchain's staging buffer", (VkDeviceSize)extent.width * extent.height * 4, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                PN_GPU_HOST_UPLOAD, &sc->staging));
    return PN_OK;
}

static pn_result check_support(pn_swapchain *sc)
{
    pn_gpu_device *dev = sc->dev;
    VkBool32 supported = VK_FALSE;
    VK_CHECK(vkGetPhysicalDeviceSurfaceSupportKHR(dev->physical, dev->queue_family, sc->surface, &supported));
    if (!supported) {
        pn_error("%s cannot present to this window from its queue family %u", dev->props.deviceName, dev->queue_family);
        return PN_ERR_UNSUPPORTED;
    }
    return PN_OK;
}

static pn_result create_sync(pn_swapchain *sc)
{
    pn_gpu_device *dev = sc->dev;
    VkSemaphoreCreateInfo si = {.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    // Created signalled: the first acquire has no previous copy to wait for.
    VkFenceCreateInfo fi = {.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO, .flags = VK_FENCE_CREATE_SIGNALED_BIT};
    VkCommandBufferAllocateInfo ai = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = dev->cmd_pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    VK_CHECK(vkCreateSemaphore(dev->device, &si, NULL, &sc->acquired));
    VK_CHECK(vkCreateFence(dev->device, &fi, NULL, &sc->done));
    VK_CHECK(vkAllocateCommandBuffers(dev->device, &ai, &sc->cmd));
    return PN_OK;
}

pn_result pn_swapchain_create(pn_gpu_device *dev, const pn_swapchain_desc *desc, pn_swapchain *out)
{
    memset(out, 0, sizeof *out);
    out->dev = dev;
    out->surface = desc->surface;
    out->vsync = desc->vsync;
    out->image = UINT32_MAX;
    pn_result r = check_support(out);
    if (r == PN_OK)
        r = pick_format(out);
    if (r == PN_OK)
        r = pick_present_mode(out);
    if (r == PN_OK)
        r = create_sync(out);
    if (r == PN_OK)
        r = pn_swapchain_recreate(out, desc->width, desc->height);
    if (r != PN_OK)
        pn_swapchain_destroy(out);
    return r;
}

void pn_swapchain_destroy(pn_swapchain *sc)
{
    pn_gpu_device *dev = sc->dev;
    if (!dev || !dev->device) {
        memset(sc, 0, sizeof *sc);
        return;
    }
    VkDevice d = dev->device;
    vkDeviceWaitIdle(d);
    destroy_images(sc);
    if (sc->swapchain)
        vkDestroySwapchainKHR(d, sc->swapchain, NULL);
    if (sc->cmd)
        vkFreeCommandBuffers(d, dev->cmd_pool, 1, &sc->cmd);
    if (sc->done)
        vkDestroyFence(d, sc->done, NULL);
    if (sc->acquired)
        vkDestroySemaphore(d, sc->acquired, NULL);
    if (sc->surface)
        vkDestroySurfaceKHR(dev->instance, sc->surface, NULL);
    memset(sc, 0, sizeof *sc);
}

pn_result pn_swapchain_acquire(pn_swapchain *sc, bool *stale)
{
    *stale = false;
    sc->image = UINT32_MAX;
    if (!sc->swapchain) {
        *stale = true;
        return PN_OK;
    }
    VkDevice d = sc->dev->device;
    VK_CHECK(vkWaitForFences(d, 1, &sc->done, VK_TRUE, UINT64_MAX));
    uint32_t image;
    VkResult r = vkAcquireNextImageKHR(d, sc->swapchain, UINT64_MAX, sc->acquired, VK_NULL_HANDLE, &image);
    if (r == VK_ERROR_OUT_OF_DATE_KHR) { // nothing acquired, `acquired` left unsignalled
        *stale = true;
        return PN_OK;
    }
    // VK_SUBOPTIMAL_KHR acquired an image and will signal `acquired`: present it, then recreate
    // (pn_swapchain_present reports the same status).
    if (r != VK_SUBOPTIMAL_KHR)
        VK_CHECK(r);
    sc->image = image;
    return PN_OK;
}

pn_result pn_swapchain_present(pn_swapchain *sc, bool *stale)
{
    *stale = false;
    if (sc->image == UINT32_MAX) {
        *stale = true;
        return PN_OK;
    }
    pn_gpu_device *dev = sc->dev;
    uint32_t image = sc->image;
    sc->image = UINT32_MAX;
    VK_CHECK(vkResetFences(dev->device, 1, &sc->done));
    VK_CHECK(vkResetCommandBuffer(sc->cmd, 0));
    VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                   .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
    VK_CHECK(vkBeginCommandBuffer(sc->cmd, &bi));
    const VkImageSubresourceRange all = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    // The layout change starts in the stage the acquire semaphore is waited in (COPY), so it runs
    // after the presentation engine let go of the image; the old contents are discarded (UNDEFINED).
    VkImageMemoryBarrier2 to_copy = {
        .sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2,
        .srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT,
        .srcAccessMask = VK_ACCESS_2_NONE,
        .dstStageMask = VK_PIPELINE_STAGE_2_COPY_BIT,
        .dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT,
        .oldLayout = VK_IMAGE_LAYOUT_UNDEFINED,
        .newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
        .srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED,
        .image = sc->images[image],
        .subresourceRange = all,
    };
    pn_gpu_cmd_barrier(sc->cmd, NULL, 1, &to_copy);
    VkBufferImageCopy copy = {
        .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
        .imageExtent = {sc->extent.width, sc->extent.height, 1},
    };
    vkCmdCopyBufferToImage(sc->cmd, sc->staging.buffer, sc->images[image], VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                           &copy);
    // To the presentation engine: the semaphore signal below makes the copy's writes available to
    // it, so the barrier's second scope is empty.
    VkImageMemoryBarrier2 to_present = to_copy;
    to_present.srcStageMask = VK_PIPELINE_STAGE_2_COPY_BIT;
    to_present.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    to_present.dstStageMask = VK_PIPELINE_STAGE_2_NONE;
    to_present.dstAccessMask = VK_ACCESS_2_NONE;
    to_present.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    to_present.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
    pn_gpu_cmd_barrier(sc->cmd, NULL, 1, &to_present);
    VK_CHECK(vkEndCommandBuffer(sc->cmd));

    VkSemaphoreSubmitInfo wait = {
        .sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO,
        .semaphore = sc->acquired,
        .stageMask = VK_PIPELINE_STAGE_2_COPY_BIT,
    };
    VkSemaphoreSubmitInfo signal = {
        .sType = VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO,
        .semaphore = sc->copied[image],
        .stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
    };
    VkCommandBufferSubmitInfo cmd = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO, .commandBuffer = sc->cmd};
    VkSubmitInfo2 submit = {
        .sType = VK_STRUCTURE_TYPE_SUBMIT_INFO_2,
        .waitSemaphoreInfoCount = 1,
        .pWaitSemaphoreInfos = &wait,
        .commandBufferInfoCount = 1,
        .pCommandBufferInfos = &cmd,
        .signalSemaphoreInfoCount = 1,
        .pSignalSemaphoreInfos = &signal,
    };
    VK_CHECK(vkQueueSubmit2(dev->queue, 1, &submit, sc->done));

    VkPresentInfoKHR pi = {
        .sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR,
        .waitSemaphoreCount = 1,
        .pWaitSemaphores = &sc->copied[image],
        .swapchainCount = 1,
        .pSwapchains = &sc->swapchain,
        .pImageIndices = &image,
    };
    VkResult r = vkQueuePresentKHR(dev->queue, &pi);
    if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) {
        *stale = true;
        return PN_OK;
    }
    VK_CHECK(r);
    return PN_OK;
}
