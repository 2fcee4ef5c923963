// Vulkan include and the check macro used on every Vulkan call that returns a VkResult.
#pragma once
#include <vulkan/vulkan.h>

#include "core/error.h"
#include "core/log.h"

const char *pn_vk_result_str(VkResult r);

// Logs the failing call with its location and returns PN_ERR_VULKAN from the enclosing function.
#define VK_CHECK(call)                                                                             \
    do {                                                                                           \
        VkResult vk_check_r_ = (call);                                                             \
        if (vk_check_r_ != VK_SUCCESS) {                                                           \
            pn_error("%s:%d: %s failed: %s", __FILE__, __LINE__, #call, pn_vk_result_str(vk_check_r_)); \
            return PN_ERR_VULKAN;                                                                  \
        }                                                                                          \
    } while (0)

// Propagates a pn_result.
#define PN_TRY(call)                                                                               \
    do {                                                                                           \
        pn_result pn_try_r_ = (call);                                                              \
        if (pn_try_r_ != PN_OK)                                                                    \
            return pn_try_r_;                                                                      \
    } while (0)
