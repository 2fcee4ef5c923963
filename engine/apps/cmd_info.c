// penumbra info: every Vulkan device, the one penumbra picks, and the limits that matter to it.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/commands.h"
#include "gpu/device.h"

static const char *type_name(VkPhysicalDeviceType t)
{
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete GPU";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated GPU";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual GPU";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "CPU";
    default: return "other";
    }
}

int pn_cmd_info(int argc, char **argv)
{
    for (int i = 0; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            printf("usage: penumbra info\n  Lists the Vulkan devices (PN_DEVICE selects one) and the chosen one's limits.\n");
            return PN_EXIT_OK;
        }
        pn_error("info: unexpected argument '%s'", argv[i]);
        return PN_EXIT_USAGE;
    }
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK)
        return PN_EXIT_FAILURE;

    uint32_t count = 0;
    vkEnumeratePhysicalDevices(dev.instance, &count, NULL);
    VkPhysicalDevice *pd = calloc(count ? count : 1, sizeof *pd);
    if (pd && vkEnumeratePhysicalDevices(dev.instance, &count, pd) == VK_SUCCESS) {
        printf("Vulkan devices:\n");
        for (uint32_t i = 0; i < count; i++) {
            VkPhysicalDeviceProperties p;
            vkGetPhysicalDeviceProperties(pd[i], &p);
            printf("  %c %u: %s (%s, Vulkan %u.%u.%u)\n", pd[i] == dev.physical ? '*' : ' ', i, p.deviceName,
                   type_name(p.deviceType), VK_API_VERSION_MAJOR(p.apiVersion), VK_API_VERSION_MINOR(p.apiVersion),
                   VK_API_VERSION_PATCH(p.apiVersion));
        }
    }
    free(pd);

    const VkPhysicalDeviceLimits *l = &dev.props.limits;
    VkDeviceSize heap = 0;
    for (uint32_t i = 0; i < dev.memory.memoryHeapCount; i++)
        if (dev.memory.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT && dev.memory.memoryHeaps[i].size > heap)
            heap = dev.memory.memoryHeaps[i].size;
    printf("chosen: %s\n", dev.props.deviceName);
    printf("  driver:                     %s %s\n", dev.driver.driverName, dev.driver.driverInfo);
    printf("  largest buffer:             %.0f MiB\n", (double)pn_gpu_device_max_buffer(&dev) / 1048576.0);
    printf("  ray queries:                %s\n", dev.ray_query ? "yes (--mode rayquery)" : "no (--mode rayquery is refused)");
    printf("  ray-tracing pipelines:      %s\n",
           dev.ray_pipeline ? "yes (--mode rtpipeline)" : "no (--mode rtpipeline is refused)");
    printf("  max storage buffer range:   %u bytes (%.0f MiB)\n", l->maxStorageBufferRange,
           l->maxStorageBufferRange / 1048576.0);
    printf("  device-local heap:          %.0f MiB\n", (double)heap / 1048576.0);
    printf("  compute shared memory:      %u bytes\n", l->maxComputeSharedMemorySize);
    printf("  compute invocations/group:  %u\n", l->maxComputeWorkGroupInvocations);
    printf("  subgroup size:              %u\n", dev.subgroup.subgroupSize);
    printf("  max image dimension 2D:     %u\n", l->maxImageDimension2D);
    printf("  timestamps:                 %s, period %g ns\n",
           l->timestampComputeAndGraphics ? "on graphics and compute queues" : "queue-dependent",
           (double)l->timestampPeriod);
    printf("  validation layer:           %s\n", desc.validation ? "on (PN_VALIDATION=1)" : "off");
    pn_gpu_device_destroy(&dev);
    if (dev.validation_messages) {
        pn_error("the validation layer reported %u message(s)", dev.validation_messages);
        return PN_EXIT_VALIDATION;
    }
    return PN_EXIT_OK;
}
