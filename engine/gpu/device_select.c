// The device's choices: its description from the environment (PN_VALIDATION, PN_DEVICE,
// PN_PIPELINE_LOG and the fault injection's PN_FAULT_*), the fault injection itself, and the
// physical device a selector picks.
#include "gpu/device.h"

#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "core/log.h"

#ifdef PN_FAULT_INJECTION
// A byte count with an optional K/M/G suffix from the environment; 0 when unset or malformed.
static uint64_t env_bytes(const char *name)
{
    const char *v = getenv(name);
    char *end;
    if (!v || !*v)
        return 0;
    unsigned long long n = strtoull(v, &end, 10);
    int shift = *end == 'K' || *end == 'k' ? 10 : *end == 'M' || *end == 'm' ? 20 : *end == 'G' || *end == 'g' ? 30 : 0;
    if (end == v || (shift && end[1]) || (!shift && *end)) {
        pn_error("%s: expected a byte count with an optional K/M/G suffix, got '%s' (ignored)", name, v);
        return 0;
    }
    return (uint64_t)n << shift;
}
#endif

pn_gpu_device_desc pn_gpu_device_desc_from_env(void)
{
    const char *v = getenv("PN_VALIDATION");
    const char *d = getenv("PN_DEVICE");
    const char *log = getenv("PN_PIPELINE_LOG");
    pn_gpu_device_desc desc = {
        .validation = v && *v && strcmp(v, "0") != 0,
        .selector = d && *d ? d : NULL,
        .pipeline_log = log && *log ? log : NULL,
    };
#ifdef PN_FAULT_INJECTION
    const char *k = getenv("PN_FAULT_ALLOC");
    if (k && *k) {
        desc.fault.count = true;
        desc.fault.fail_at = strtoull(k, NULL, 10);
    }
    desc.fault.max_alloc = env_bytes("PN_FAULT_MAX_ALLOC");
    desc.fault.heap = env_bytes("PN_FAULT_HEAP");
#endif
    return desc;
}

bool pn_gpu_fault(pn_gpu_device *dev, const char *call, const char *what, uint64_t bytes)
{
#ifdef PN_FAULT_INJECTION
    if (dev->fault.heap && dev->memory_bytes + bytes > dev->fault.heap && !strcmp(call, "vkAllocateMemory")) {
        pn_info("fault injection: %s of the %s fails: %.1f MiB more than the %.1f MiB heap holds", call, what,
                bytes / 1048576.0, dev->fault.heap / 1048576.0);
        return true;
    }
    if (!dev->fault.count)
        return false;
    ++dev->fault_count;
    // PN_FAULT_ALLOC=0 fails none and lists each allocation: a sweep picks its K from the list
    // (tests/device_memory_faults.sh fails each distinct allocation at its first and last turn).
    if (dev->fault.fail_at == 0)
        pn_info("fault injection: allocation %llu is %s of the %s", (unsigned long long)dev->fault_count, call, what);
    if (dev->fault_count != dev->fault.fail_at)
        return false;
    pn_info("fault injection: allocation %llu (%s of the %s) fails", (unsigned long long)dev->fault_count, call, what);
    return true;
#else
    (void)dev, (void)call, (void)what, (void)bytes;
    return false;
#endif
}

static int type_rank(VkPhysicalDeviceType t)
{
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
    }
}

static bool ci_contains(const char *hay, const char *needle)
{
    size_t n = strlen(needle);
    for (; *hay; hay++)
        if (strncasecmp(hay, needle, n) == 0)
            return true;
    return n == 0;
}

pn_result pn_gpu_pick_physical(VkInstance instance, const char *selector, const char *from, uint32_t *index)
{
    from = from ? from : "PN_DEVICE";
    uint32_t count = 0;
    VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, NULL));
    if (count == 0) {
        pn_error("no Vulkan device found (is mesa-vulkan-drivers installed? ci/deps.sh installs it)");
        return PN_ERR_VULKAN;
    }
    VkPhysicalDevice *pd = calloc(count, sizeof *pd);
    if (!pd)
        return PN_ERR_MEMORY;
    VkResult vr = vkEnumeratePhysicalDevices(instance, &count, pd);
    if (vr != VK_SUCCESS && vr != VK_INCOMPLETE) {
        free(pd);
        pn_error("vkEnumeratePhysicalDevices failed: %s", pn_vk_result_str(vr));
        return PN_ERR_VULKAN;
    }
    int best = -1, best_rank = -1;
    bool by_index = selector && *selector && strspn(selector, "0123456789") == strlen(selector);
    for (uint32_t i = 0; i < count; i++) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(pd[i], &p);
        bool ok13 = p.apiVersion >= VK_API_VERSION_1_3;
        if (selector) {
            bool match = by_index ? (uint32_t)atoi(selector) == i : ci_contains(p.deviceName, selector);
            if (match && best < 0) {
                if (!ok13) {
                    pn_error("device \"%s\" (%s) selects %s, which lacks Vulkan 1.3", selector, from, p.deviceName);
                    free(pd);
                    return PN_ERR_VULKAN;
                }
                best = (int)i;
            }
        } else if (ok13 && type_rank(p.deviceType) > best_rank) {
            best = (int)i;
            best_rank = type_rank(p.deviceType);
        }
    }
    free(pd);
    if (best < 0) {
        if (selector)
            pn_error("device \"%s\" (%s) matches none of the %u Vulkan devices (see `penumbra info`)", selector, from,
                     count);
        else
            pn_error("no Vulkan 1.3 device among the %u found", count);
        return PN_ERR_VULKAN;
    }
    *index = (uint32_t)best;
    return PN_OK;
}
