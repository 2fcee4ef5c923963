// The Vulkan device: instance, physical device, one queue, the validation layer and its messages, submits.
// Its description from the environment, the fault injection and the physical device's choice
// are in device_select.c.
//
// Over 500 lines because instance, physical device, feature chain (ray queries, 64-bit floats,
// buffer addresses, synchronization2) and the validation messenger are one sequence of set-up.
#include "gpu/device.h"

#include <ctype.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

static VKAPI_ATTR VkBool32 VKAPI_CALL on_debug_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                       VkDebugUtilsMessageTypeFlagsEXT type,
                                                       const VkDebugUtilsMessengerCallbackDataEXT *data,
                                                       void *user)
{
    pn_gpu_device *dev = user;
    if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
        dev->validation_messages++;
        pn_log(severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT ? PN_LOG_ERROR : PN_LOG_WARN,
               "vulkan validation: %s", data->pMessage);
    }
    return VK_FALSE;
}

static bool layer_available(const char *name)
{
    uint32_t n = 0;
    vkEnumerateInstanceLayerProperties(&n, NULL);
    VkLayerProperties *props = calloc(n ? n : 1, sizeof *props);
    bool found = false;
    if (props && vkEnumerateInstanceLayerProperties(&n, props) == VK_SUCCESS)
        for (uint32_t i = 0; i < n && !found; i++)
            found = strcmp(props[i].layerName, name) == 0;
    free(props);
    return found;
}

static pn_result create_instance(const pn_gpu_device_desc *desc, pn_gpu_device *dev)
{
    const char *layers[] = {"VK_LAYER_KHRONOS_validation"};
    // Debug utils with validation, then the window system's surface extensions when presenting.
    enum { MAX_EXTS = 16 };
    const char *exts[MAX_EXTS];
    uint32_t ext_count = 0;
    if (desc->validation)
        exts[ext_count++] = VK_EXT_DEBUG_UTILS_EXTENSION_NAME;
    if (desc->present) {
        if (desc->instance_extension_count > MAX_EXTS - 1) {
            pn_error("the window system asks for %u Vulkan instance extensions, at most %d are supported",
                     desc->instance_extension_count, MAX_EXTS - 1);
            return PN_ERR_UNSUPPORTED;
        }
        for (uint32_t i = 0; i < desc->instance_extension_count; i++)
            exts[ext_count++] = desc->instance_extensions[i];
    }
    if (desc->validation && !layer_available(layers[0])) {
        pn_error("PN_VALIDATION is set but VK_LAYER_KHRONOS_validation is not installed "
                 "(Debian package vulkan-validationlayers; ci/deps.sh installs it)");
        return PN_ERR_VULKAN;
    }
    VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
    VkValidationFeaturesEXT features = {
        .sType = VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT,
        .enabledValidationFeatureCount = 1,
        .pEnabledValidationFeatures = enables,
    };
    VkDebugUtilsMessengerCreateInfoEXT messenger_info = {
        .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT,
        .pNext = &features,
        .messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
        .messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT,
        .pfnUserCallback = on_debug_message,
        .pUserData = dev,
    };
    VkApplicationInfo app = {
        .sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
        .pApplicationName = "penumbra",
        .pEngineName = "penumbra",
        .apiVersion = VK_API_VERSION_1_3,
    };
    VkInstanceCreateInfo info = {
        .sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
        // Chaining the messenger info also reports messages from instance creation itself.
        .pNext = desc->validation ? &messenger_info : NULL,
        .pApplicationInfo = &app,
        .enabledLayerCount = desc->validation ? 1 : 0,
        .ppEnabledLayerNames = layers,
        .enabledExtensionCount = ext_count,
        .ppEnabledExtensionNames = exts,
    };
    VkResult r = vkCreateInstance(&info, NULL, &dev->instance);
    if (r != VK_SUCCESS) {
        pn_error("cannot create a Vulkan 1.3 instance%s: %s (is libvulkan1 with a driver installed?)",
                 desc->present ? " with the window system's surface extensions" : "", pn_vk_result_str(r));
        return PN_ERR_VULKAN;
    }
    if (desc->validation) {
        PFN_vkCreateDebugUtilsMessengerEXT create = (PFN_vkCreateDebugUtilsMessengerEXT)vkGetInstanceProcAddr(
            dev->instance, "vkCreateDebugUtilsMessengerEXT");
        messenger_info.pNext = NULL;
        if (!create) {
            pn_error("vkCreateDebugUtilsMessengerEXT not available");
            return PN_ERR_VULKAN;
        }
        VK_CHECK(create(dev->instance, &messenger_info, NULL, &dev->messenger));
    }
    return PN_OK;
}

static pn_result device_extension_available(VkPhysicalDevice physical, const char *name, bool *found)
{
    uint32_t n = 0;
    VK_CHECK(vkEnumerateDeviceExtensionProperties(physical, NULL, &n, NULL));
    VkExtensionProperties *props = calloc(n ? n : 1, sizeof *props);
    if (!props)
        return PN_ERR_MEMORY;
    VkResult r = vkEnumerateDeviceExtensionProperties(physical, NULL, &n, props);
    *found = false;
    for (uint32_t i = 0; r == VK_SUCCESS && i < n && !*found; i++)
        *found = strcmp(props[i].extensionName, name) == 0;
    free(props);
    VK_CHECK(r);
    return PN_OK;
}

// The physical device's properties and memory, as dev keeps them.
static void query_properties(pn_gpu_device *dev)
{
    dev->driver = (VkPhysicalDeviceDriverProperties){.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    dev->maintenance4 = (VkPhysicalDeviceMaintenance4Properties){.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_4_PROPERTIES,
                                                                 .pNext = &dev->driver};
    dev->maintenance3 = (VkPhysicalDeviceMaintenance3Properties){.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES,
                                                                 .pNext = &dev->maintenance4};
    dev->subgroup = (VkPhysicalDeviceSubgroupProperties){.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES,
                                                         .pNext = &dev->maintenance3};
    VkPhysicalDeviceProperties2 props2 = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, .pNext = &dev->subgroup};
    vkGetPhysicalDeviceProperties2(dev->physical, &props2);
    dev->props = props2.properties;
    vkGetPhysicalDeviceMemoryProperties(dev->physical, &dev->memory);
}

// The acceleration-structure and ray-tracing-pipeline properties, for a device with them enabled.
static void query_ray_properties(pn_gpu_device *dev, bool rt)
{
    dev->rt_props = (VkPhysicalDeviceRayTracingPipelinePropertiesKHR){
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_PROPERTIES_KHR};
    dev->as_props = (VkPhysicalDeviceAccelerationStructurePropertiesKHR){
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_PROPERTIES_KHR,
        .pNext = rt ? &dev->rt_props : NULL};
    VkPhysicalDeviceProperties2 p2 = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, .pNext = &dev->as_props};
    vkGetPhysicalDeviceProperties2(dev->physical, &p2);
}

// The extension entry points (the loader exports none of them: fetched from the device), and
// from them which ways of tracing the device's structures work.
static void load_ray_procs(pn_gpu_device *dev, bool rq, bool rt)
{
#define PN_DEVICE_PROC(field, name) (field = (PFN_##name)vkGetDeviceProcAddr(dev->device, #name))
    bool loaded = PN_DEVICE_PROC(dev->as.create, vkCreateAccelerationStructureKHR) &&
                  PN_DEVICE_PROC(dev->as.destroy, vkDestroyAccelerationStructureKHR) &&
                  PN_DEVICE_PROC(dev->as.build_sizes, vkGetAccelerationStructureBuildSizesKHR) &&
                  PN_DEVICE_PROC(dev->as.cmd_build, vkCmdBuildAccelerationStructuresKHR) &&
                  PN_DEVICE_PROC(dev->as.address, vkGetAccelerationStructureDeviceAddressKHR);
    dev->ray_query = loaded && rq;
    dev->ray_pipeline = loaded && rt && PN_DEVICE_PROC(dev->rt.create, vkCreateRayTracingPipelinesKHR) &&
                        PN_DEVICE_PROC(dev->rt.handles, vkGetRayTracingShaderGroupHandlesKHR) &&
                        PN_DEVICE_PROC(dev->rt.trace, vkCmdTraceRaysKHR);
#undef PN_DEVICE_PROC
    dev->accel = dev->ray_query || dev->ray_pipeline;
}

static pn_result create_command_pool(pn_gpu_device *dev)
{
    VkCommandPoolCreateInfo pi = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
        .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
        .queueFamilyIndex = dev->queue_family,
    };
    VK_CHECK(vkCreateCommandPool(dev->device, &pi, NULL, &dev->cmd_pool));
    return PN_OK;
}

static pn_result create_device(const pn_gpu_device_desc *desc, pn_gpu_device *dev)
{
    uint32_t index;
    PN_TRY(pn_gpu_pick_physical(dev->instance, desc->selector, desc->selector_from, &index));
    uint32_t count = index + 1;
    VkPhysicalDevice *pd = calloc(count, sizeof *pd);
    if (!pd)
        return PN_ERR_MEMORY;
    VkResult vr = vkEnumeratePhysicalDevices(dev->instance, &count, pd);
    dev->physical = pd[index];
    free(pd);
    if (vr != VK_SUCCESS && vr != VK_INCOMPLETE)
        VK_CHECK(vr);

    query_properties(dev);
#ifdef PN_FAULT_INJECTION
    // A smaller device than this one, for the tests of what does not fit (pn_gpu_fault_desc).
    VkDeviceSize *limits[2] = {&dev->maintenance3.maxMemoryAllocationSize, &dev->maintenance4.maxBufferSize};
    for (int i = 0; desc->fault.max_alloc && i < 2; i++)
        *limits[i] = *limits[i] && *limits[i] < desc->fault.max_alloc ? *limits[i] : desc->fault.max_alloc;
    for (uint32_t i = 0; desc->fault.heap && i < dev->memory.memoryHeapCount; i++)
        if (dev->memory.memoryHeaps[i].size > desc->fault.heap)
            dev->memory.memoryHeaps[i].size = desc->fault.heap;
#endif

    uint32_t qn = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(dev->physical, &qn, NULL);
    VkQueueFamilyProperties qf[16];
    qn = qn > 16 ? 16 : qn;
    vkGetPhysicalDeviceQueueFamilyProperties(dev->physical, &qn, qf);
    dev->queue_family = UINT32_MAX;
    const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
    // One queue does everything, presenting included: frames are short and submitted one at a time.
    for (uint32_t i = 0; i < qn && dev->queue_family == UINT32_MAX; i++)
        if ((qf[i].queueFlags & need) == need && qf[i].timestampValidBits > 0 &&
            (!desc->present || !desc->can_present || desc->can_present(dev->instance, dev->physical, i)))
            dev->queue_family = i;
    if (dev->queue_family == UINT32_MAX) {
        if (desc->present)
            pn_error("%s has no queue with graphics, compute, timestamps and presentation to this window "
                     "(PN_DEVICE picks another device)", dev->props.deviceName);
        else
            pn_error("%s has no queue with graphics, compute and timestamps", dev->props.deviceName);
        return PN_ERR_VULKAN;
    }
    const char *device_exts[7] = {VK_KHR_SWAPCHAIN_EXTENSION_NAME};
    uint32_t ext_count = desc->present ? 1 : 0;
    if (desc->present) {
        bool swapchain = false;
        PN_TRY(device_extension_available(dev->physical, device_exts[0], &swapchain));
        if (!swapchain) {
            pn_error("%s lacks %s, which presenting to a window needs", dev->props.deviceName, device_exts[0]);
            return PN_ERR_VULKAN;
        }
    }

    // The device's acceleration structures where it has them, with ray queries (rayquery) and
    // ray-tracing pipelines (rtpipeline), each where it has that too, independently: Mesa 25's
    // lavapipe has both; the NVIDIA H100/H200 servers this project targets were seen offering the
    // pipelines without the queries.
    static const char *const AS_EXTS[2] = {VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME,
                                           VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME};
    bool as = true, rq = false, rt = false;
    for (int i = 0; i < 2 && as; i++)
        PN_TRY(device_extension_available(dev->physical, AS_EXTS[i], &as));
    if (as) {
        PN_TRY(device_extension_available(dev->physical, VK_KHR_RAY_QUERY_EXTENSION_NAME, &rq));
        PN_TRY(device_extension_available(dev->physical, VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME, &rt));
    }
    // Each extension's feature struct is chained only where the device lists the extension.
    VkPhysicalDeviceRayTracingPipelineFeaturesKHR rt_f = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR};
    VkPhysicalDeviceRayQueryFeaturesKHR rq_f = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR,
                                                .pNext = rt ? &rt_f : NULL};
    VkPhysicalDeviceAccelerationStructureFeaturesKHR as_f = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR,
        .pNext = rq ? (void *)&rq_f : rt ? (void *)&rt_f : NULL};
    if (as) {
        VkPhysicalDeviceFeatures2 q = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, .pNext = &as_f};
        vkGetPhysicalDeviceFeatures2(dev->physical, &q);
        rq = rq && as_f.accelerationStructure && rq_f.rayQuery;
        rt = rt && as_f.accelerationStructure && rt_f.rayTracingPipeline;
        as = rq || rt; // the structures alone trace nothing
    }
    if (as) {
        // Only the features penumbra uses are enabled: each struct rewritten with its one flag.
        rt_f = (VkPhysicalDeviceRayTracingPipelineFeaturesKHR){
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_TRACING_PIPELINE_FEATURES_KHR, .rayTracingPipeline = rt};
        rq_f = (VkPhysicalDeviceRayQueryFeaturesKHR){.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR,
                                                     .pNext = rt ? &rt_f : NULL,
                                                     .rayQuery = rq};
        as_f = (VkPhysicalDeviceAccelerationStructureFeaturesKHR){
            .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_ACCELERATION_STRUCTURE_FEATURES_KHR,
            .pNext = rq ? (void *)&rq_f : rt ? (void *)&rt_f : NULL,
            .accelerationStructure = VK_TRUE};
        for (int i = 0; i < 2; i++)
            device_exts[ext_count++] = AS_EXTS[i];
        if (rq)
            device_exts[ext_count++] = VK_KHR_RAY_QUERY_EXTENSION_NAME;
        if (rt)
            device_exts[ext_count++] = VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME;
        query_ray_properties(dev, rt);
    }
    // The driver's own count of the memory in use, where it keeps one (Mesa 25 lavapipe does):
    // the demo's --stats report it beside penumbra's tally.
    PN_TRY(device_extension_available(dev->physical, VK_EXT_MEMORY_BUDGET_EXTENSION_NAME, &dev->memory_budget));
    if (dev->memory_budget)
        device_exts[ext_count++] = VK_EXT_MEMORY_BUDGET_EXTENSION_NAME;
    VkPhysicalDeviceVulkan13Features f13 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES,
        .pNext = as ? &as_f : NULL,
        .dynamicRendering = VK_TRUE,
        .synchronization2 = VK_TRUE,
    };
    VkPhysicalDeviceVulkan12Features f12 = {
        .sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES,
        .pNext = &f13,
        .hostQueryReset = VK_TRUE,
        .bufferDeviceAddress = VK_TRUE, // the N-tree pools are reached by address (accel/pools.h)
    };
    VkPhysicalDeviceFeatures supported;
    vkGetPhysicalDeviceFeatures(dev->physical, &supported);
    VkPhysicalDeviceFeatures2 f = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, .pNext = &f12};
    // The watertight triangle test recomputes its edge functions in double when they round to zero.
    if (!supported.shaderFloat64) {
        pn_error("%s lacks shaderFloat64, which the exact triangle test needs", dev->props.deviceName);
        return PN_ERR_VULKAN;
    }
    f.features.shaderFloat64 = VK_TRUE;
    float priority = 1.0f;
    VkDeviceQueueCreateInfo qi = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
        .queueFamilyIndex = dev->queue_family,
        .queueCount = 1,
        .pQueuePriorities = &priority,
    };
    VkDeviceCreateInfo di = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
        .pNext = &f,
        .queueCreateInfoCount = 1,
        .pQueueCreateInfos = &qi,
        .enabledExtensionCount = ext_count,
        .ppEnabledExtensionNames = device_exts,
    };
    VK_CHECK(vkCreateDevice(dev->physical, &di, NULL, &dev->device));
    if (as)
        load_ray_procs(dev, rq, rt);
    vkGetDeviceQueue(dev->device, dev->queue_family, 0, &dev->queue);
    return create_command_pool(dev);
}

pn_result pn_gpu_device_create(const pn_gpu_device_desc *desc, pn_gpu_device *dev)
{
    memset(dev, 0, sizeof *dev);
    dev->validation = desc->validation;
    dev->present = desc->present;
    dev->pipeline_log = desc->pipeline_log;
#ifdef PN_FAULT_INJECTION
    dev->fault = desc->fault;
#endif
    pn_result r = create_instance(desc, dev);
    if (r == PN_OK)
        r = create_device(desc, dev);
    if (r != PN_OK)
        pn_gpu_device_destroy(dev);
    return r;
}

uint32_t pn_gpu_device_extensions(const pn_gpu_device *dev, const char *out[PN_GPU_OPTIONAL_EXTENSIONS])
{
    uint32_t n = 0;
    if (dev->accel) {
        out[n++] = VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME;
        out[n++] = VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME;
    }
    if (dev->ray_query)
        out[n++] = VK_KHR_RAY_QUERY_EXTENSION_NAME;
    if (dev->ray_pipeline)
        out[n++] = VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME;
    if (dev->memory_budget)
        out[n++] = VK_EXT_MEMORY_BUDGET_EXTENSION_NAME;
    return n;
}

pn_result pn_gpu_device_adopt(const pn_gpu_device_adopt_desc *desc, pn_gpu_device *dev)
{
    memset(dev, 0, sizeof *dev);
    dev->adopted = true;
    dev->instance = desc->instance;
    dev->physical = desc->physical;
    dev->device = desc->device;
    dev->queue = desc->queue;
    dev->queue_family = desc->queue_family;
    query_properties(dev);
    if (dev->props.apiVersion < VK_API_VERSION_1_3) {
        pn_error("%s: Vulkan %u.%u; penumbra needs 1.3", dev->props.deviceName, VK_API_VERSION_MAJOR(dev->props.apiVersion),
                 VK_API_VERSION_MINOR(dev->props.apiVersion));
        memset(dev, 0, sizeof *dev);
        return PN_ERR_UNSUPPORTED;
    }
    uint32_t qn = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(dev->physical, &qn, NULL);
    VkQueueFamilyProperties qf[16];
    qn = qn > 16 ? 16 : qn;
    vkGetPhysicalDeviceQueueFamilyProperties(dev->physical, &qn, qf);
    const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
    if (desc->queue_family >= qn || (qf[desc->queue_family].queueFlags & need) != need ||
        qf[desc->queue_family].timestampValidBits == 0) {
        pn_error("%s: queue family %u is not one with graphics, compute and timestamps", dev->props.deviceName,
                 desc->queue_family);
        memset(dev, 0, sizeof *dev);
        return PN_ERR_INVALID; // the caller's argument
    }
    // What the host enabled of the extensions penumbra can use.
    bool has[5] = {false};
    static const char *const names[5] = {VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME,
                                         VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME, VK_KHR_RAY_QUERY_EXTENSION_NAME,
                                         VK_KHR_RAY_TRACING_PIPELINE_EXTENSION_NAME, VK_EXT_MEMORY_BUDGET_EXTENSION_NAME};
    for (uint32_t i = 0; i < desc->extension_count; i++)
        for (int k = 0; k < 5; k++)
            has[k] = has[k] || (desc->extensions[i] && strcmp(desc->extensions[i], names[k]) == 0);
    bool as = has[0] && has[1] && (has[2] || has[3]);
    if (as) {
        query_ray_properties(dev, has[3]);
        load_ray_procs(dev, has[2], has[3]);
    }
    dev->memory_budget = has[4];
    pn_result r = create_command_pool(dev);
    if (r != PN_OK)
        memset(dev, 0, sizeof *dev);
    return r;
}

void pn_gpu_device_destroy(pn_gpu_device *dev)
{
    // Every allocation of gpu/resources.c is released by its resource's destroy: memory still held
    // here is a resource never destroyed. Counted as the layer's messages are, so that every test
    // (which requires none) fails on it, with or without the layer.
    if (dev->memory_allocations || dev->memory_bytes) {
        pn_error("%u device memory allocations (%.1f MiB) still held when the device is destroyed: a resource "
                 "was not destroyed",
                 dev->memory_allocations, (double)dev->memory_bytes / 1048576.0);
        dev->validation_messages++;
    }
    if (dev->device) {
        vkQueueWaitIdle(dev->queue); // no work of penumbra's may still use a pipeline
        for (uint32_t i = 0; i < dev->pipeline_count; i++) {
            vkDestroyPipeline(dev->device, dev->pipelines[i].pipeline, NULL);
            vkDestroyPipelineLayout(dev->device, dev->pipelines[i].layout, NULL);
            vkDestroyDescriptorSetLayout(dev->device, dev->pipelines[i].set_layout, NULL);
        }
    }
    free(dev->pipelines);
    dev->pipelines = NULL, dev->pipeline_count = 0;
    if (dev->device && dev->adopted) {
        // The host's device: only what penumbra made on it goes (its queue idle first: the host may
        // still have work of its own on it, which it waits for as it likes).
        vkQueueWaitIdle(dev->queue);
        if (dev->cmd_pool)
            vkDestroyCommandPool(dev->device, dev->cmd_pool, NULL);
        dev->device = VK_NULL_HANDLE, dev->instance = VK_NULL_HANDLE;
    }
    if (dev->device) {
        vkDeviceWaitIdle(dev->device);
        if (dev->cmd_pool)
            vkDestroyCommandPool(dev->device, dev->cmd_pool, NULL);
        vkDestroyDevice(dev->device, NULL);
    }
    if (dev->messenger) {
        PFN_vkDestroyDebugUtilsMessengerEXT destroy = (PFN_vkDestroyDebugUtilsMessengerEXT)vkGetInstanceProcAddr(
            dev->instance, "vkDestroyDebugUtilsMessengerEXT");
        if (destroy)
            destroy(dev->instance, dev->messenger, NULL);
    }
    if (dev->instance)
        vkDestroyInstance(dev->instance, NULL);
    // The count a sweep of PN_FAULT_ALLOC needs: how many allocations the whole run made.
    if (dev->fault.count)
        pn_info("fault injection: %llu device allocations", (unsigned long long)dev->fault_count);
    unsigned messages = dev->validation_messages;
    bool validation = dev->validation;
    memset(dev, 0, sizeof *dev);
    dev->validation_messages = messages; // still readable after destroy: the final count
    dev->validation = validation;
}

pn_result pn_gpu_begin_once(pn_gpu_device *dev, VkCommandBuffer *cmd)
{
    VkCommandBufferAllocateInfo ai = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = dev->cmd_pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    VK_CHECK(vkAllocateCommandBuffers(dev->device, &ai, cmd));
    VkCommandBufferBeginInfo bi = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
        .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT,
    };
    VkResult r = vkBeginCommandBuffer(*cmd, &bi);
    if (r != VK_SUCCESS) {
        vkFreeCommandBuffers(dev->device, dev->cmd_pool, 1, cmd);
        VK_CHECK(r);
    }
    return PN_OK;
}

pn_result pn_gpu_submit_wait(pn_gpu_device *dev, VkCommandBuffer cmd)
{
    VkResult r = vkEndCommandBuffer(cmd);
    if (r == VK_SUCCESS) {
        VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &cmd};
        r = vkQueueSubmit(dev->queue, 1, &si, VK_NULL_HANDLE);
        if (r == VK_SUCCESS)
            r = vkQueueWaitIdle(dev->queue);
    }
    vkFreeCommandBuffers(dev->device, dev->cmd_pool, 1, &cmd);
    VK_CHECK(r);
    return PN_OK;
}

uint32_t pn_gpu_memory_type(const pn_gpu_device *dev, uint32_t type_bits, VkMemoryPropertyFlags flags)
{
    for (uint32_t i = 0; i < dev->memory.memoryTypeCount; i++)
        if ((type_bits & (1u << i)) && (dev->memory.memoryTypes[i].propertyFlags & flags) == flags)
            return i;
    return UINT32_MAX;
}

// llvmpipe: lavapipe names its device "llvmpipe (LLVM ...)"; see device.h.
bool pn_gpu_device_loop_budget(const pn_gpu_device *dev) { return strstr(dev->props.deviceName, "llvmpipe") != NULL; }

VkDeviceSize pn_gpu_device_max_buffer(const pn_gpu_device *dev)
{
    VkDeviceSize a = dev->maintenance3.maxMemoryAllocationSize, b = dev->maintenance4.maxBufferSize;
    return a && b ? (a < b ? a : b) : (a ? a : b);
}

VkDeviceSize pn_gpu_device_pool_budget(const pn_gpu_device *dev) { return pn_gpu_device_heap(dev) / 2; }

VkDeviceSize pn_gpu_device_heap(const pn_gpu_device *dev)
{
    VkDeviceSize heap = 0;
    for (uint32_t i = 0; i < dev->memory.memoryHeapCount; i++)
        if ((dev->memory.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) && dev->memory.memoryHeaps[i].size > heap)
            heap = dev->memory.memoryHeaps[i].size;
    return heap;
}

bool pn_gpu_device_heap_usage(const pn_gpu_device *dev, VkDeviceSize *bytes)
{
    *bytes = 0;
    if (!dev->memory_budget)
        return false;
    VkPhysicalDeviceMemoryBudgetPropertiesEXT budget = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_BUDGET_PROPERTIES_EXT};
    VkPhysicalDeviceMemoryProperties2 props = {.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MEMORY_PROPERTIES_2, .pNext = &budget};
    vkGetPhysicalDeviceMemoryProperties2(dev->physical, &props);
    for (uint32_t i = 0; i < props.memoryProperties.memoryHeapCount; i++)
        *bytes += budget.heapUsage[i];
    return true;
}
