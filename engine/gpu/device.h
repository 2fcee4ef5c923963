// The Vulkan device: instance, the chosen physical device, one queue that does graphics and
// compute, a command pool and, with validation, a debug messenger that counts messages.
#pragma once
#include <stdbool.h>

#include "gpu/vk.h"

// Asks the window system whether a queue family of a device can present to it; the signature of
// glfwGetPhysicalDevicePresentationSupport, so that GLFW's function can be passed as is.
typedef int (*pn_gpu_present_query)(VkInstance instance, VkPhysicalDevice physical, uint32_t queue_family);

// Fault injection, for tests only: honoured in PN_FAULT_INJECTION builds (a CMake option, off by
// default; ci/test.sh's sanitizer build has it on), ignored in every other. tests/sanitizers.md.
typedef struct pn_gpu_fault_desc {
    bool count;          // count the device's allocations, and log the count when it is destroyed
    uint64_t fail_at;    // with count: the fail_at-th allocation (1-based) fails with
                         // VK_ERROR_OUT_OF_DEVICE_MEMORY; 0 fails none
    uint64_t max_alloc;  // non-zero: maxMemoryAllocationSize and maxBufferSize reported as at most this
    uint64_t heap;       // non-zero: device-local heaps reported as at most this, and allocations that
                         // would hold more in all fail as on a device that small
} pn_gpu_fault_desc;

typedef struct pn_gpu_device_desc {
    bool validation;      // Khronos validation layer + synchronization validation
    const char *selector; // NULL: best device; else an index ("1") or a name substring
    const char *selector_from; // where the selector came from, for messages; NULL: "PN_DEVICE"
    // Presenting to a window (penumbra demo). False: offscreen only, nothing below is used.
    // True: also enables `instance_extensions` (the window system's surface extensions, e.g.
    // from glfwGetRequiredInstanceExtensions) and VK_KHR_swapchain, and the queue family must be
    // one that `can_present` accepts (NULL: any).
    bool present;
    const char *const *instance_extensions;
    uint32_t instance_extension_count;
    pn_gpu_present_query can_present;
    pn_gpu_fault_desc fault;
    // A file each pipeline creation appends one line to (pn_gpu_pipeline_log in gpu/compute.h):
    // what the suite's timing table counts (tests/timings.sh). NULL: none. Outlives the device.
    const char *pipeline_log;
} pn_gpu_device_desc;

// A pipeline the device keeps for every pass that asks for the same one (pn_gpu_compute_pipeline
// and pn_gpu_ray_pipeline_create): the same SPIR-V (the engine's static arrays, which outlive any device), the
// same specialisation and a layout of the same definition (key: its bytes). It has a layout of its
// own, defined as its users' and so compatible with theirs (pipeline layout compatibility: layouts
// created from identical definitions), and lives until the device is destroyed.
enum { PN_GPU_PIPELINE_KEY_MAX = 512 };
typedef struct pn_gpu_pipeline_entry {
    uint64_t variant; // pn_gpu_variant_hash of the SPIR-V and the key
    const uint32_t *spirv[4]; // its stages' (compute: one; ray tracing: up to four)
    size_t spirv_size[4];
    uint8_t key[PN_GPU_PIPELINE_KEY_MAX]; // the set layout's bindings, push constants, specialisation
    size_t key_size;
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkPipeline pipeline;
} pn_gpu_pipeline_entry;

typedef struct pn_gpu_device {
    VkInstance instance;
    VkDebugUtilsMessengerEXT messenger;
    VkPhysicalDevice physical;
    VkPhysicalDeviceProperties props;
    VkPhysicalDeviceSubgroupProperties subgroup;
    VkPhysicalDeviceMaintenance3Properties maintenance3; // maxMemoryAllocationSize
    VkPhysicalDeviceMaintenance4Properties maintenance4; // maxBufferSize
    VkPhysicalDeviceDriverProperties driver;             // driverName, driverInfo (the Mesa version)
    VkPhysicalDeviceMemoryProperties memory;
    VkDevice device;
    uint32_t queue_family;
    VkQueue queue;
    VkCommandPool cmd_pool;
    bool validation;
    bool present;                 // VK_KHR_swapchain enabled, the queue can present (desc.present)
    // VK_KHR_acceleration_structure (gpu/tlas.h), enabled wherever the device also has one way
    // to trace it: ray queries (VK_KHR_ray_query: Mesa 25 lavapipe, RTX, RDNA2+, Arc; the rayquery
    // shadow mode) or ray-tracing pipelines (VK_KHR_ray_tracing_pipeline: the same, and the NVIDIA
    // drivers that offer no ray queries; the rtpipeline shadow mode).
    bool accel;
    bool ray_query;
    bool ray_pipeline;
    VkPhysicalDeviceAccelerationStructurePropertiesKHR as_props; // with accel
    VkPhysicalDeviceRayTracingPipelinePropertiesKHR rt_props;    // with ray_pipeline
    struct {                                                      // loaded with accel
        PFN_vkCreateAccelerationStructureKHR create;
        PFN_vkDestroyAccelerationStructureKHR destroy;
        PFN_vkGetAccelerationStructureBuildSizesKHR build_sizes;
        PFN_vkCmdBuildAccelerationStructuresKHR cmd_build;
        PFN_vkGetAccelerationStructureDeviceAddressKHR address;
    } as;
    struct { // loaded with ray_pipeline
        PFN_vkCreateRayTracingPipelinesKHR create;
        PFN_vkGetRayTracingShaderGroupHandlesKHR handles;
        PFN_vkCmdTraceRaysKHR trace;
    } rt;
    unsigned validation_messages; // warnings and errors reported by the layer so far
    const char *pipeline_log;     // desc.pipeline_log
    // The pipelines made so far, shared by every pass that asks for one of them: a renderer made
    // again (a bench cell, a test's sweep, the library's next scene, the demo's mode switched back)
    // takes them as they are, where llvmpipe would run its shader passes again even on a warm
    // disk cache (0.3-0.6 s for each shadow pipeline) and compile again at the first dispatch.
    pn_gpu_pipeline_entry *pipelines;
    uint32_t pipeline_count;
    pn_gpu_fault_desc fault;      // as given, in PN_FAULT_INJECTION builds; zero in others
    uint64_t fault_count;         // allocations so far, with fault.count
    // penumbra's live VkDeviceMemory (every allocation goes through gpu/resources.c): bytes and
    // count. Plain counters: like the queue and the command pool, the device is used from one
    // thread (the demo's worker builds trees on the CPU only).
    VkDeviceSize memory_bytes;
    uint32_t memory_allocations;
    bool memory_budget; // VK_EXT_memory_budget enabled: pn_gpu_device_heap_usage answers
    bool adopted;       // the host's device (pn_gpu_device_adopt): destroy leaves it and its instance
} pn_gpu_device;

// A device another program created (the library's penumbra_context_create_vulkan): its handles,
// the queue penumbra submits to (a family with graphics, compute and timestamps), and the device
// extensions it enabled, of which penumbra uses the acceleration-structure, ray-query,
// ray-tracing-pipeline and memory-budget ones where listed. The device must have Vulkan 1.3's
// dynamicRendering and synchronization2, 1.2's hostQueryReset and bufferDeviceAddress, and
// shaderFloat64 enabled (what pn_gpu_device_create enables), and the instance be 1.3's.
typedef struct pn_gpu_device_adopt_desc {
    VkInstance instance;
    VkPhysicalDevice physical;
    VkDevice device;
    uint32_t queue_family;
    VkQueue queue;
    const char *const *extensions;
    uint32_t extension_count;
} pn_gpu_device_adopt_desc;

// The optional device extensions dev has enabled (acceleration structures with their ray queries and
// ray-tracing pipelines, the memory budget), as a host lists them to pn_gpu_device_adopt; returns
// their count (at most PN_GPU_OPTIONAL_EXTENSIONS).
enum { PN_GPU_OPTIONAL_EXTENSIONS = 5 };
uint32_t pn_gpu_device_extensions(const pn_gpu_device *dev, const char *out[PN_GPU_OPTIONAL_EXTENSIONS]);

// Takes the host's device as penumbra's: its properties, the entry points of the extensions listed,
// a command pool of penumbra's own. pn_gpu_device_destroy then destroys the pool alone. Logs and
// fails for a device below Vulkan 1.3 (PN_ERR_UNSUPPORTED) or a queue family without graphics,
// compute or timestamps (PN_ERR_INVALID).
pn_result pn_gpu_device_adopt(const pn_gpu_device_adopt_desc *desc, pn_gpu_device *out);

// Desc from the environment: PN_VALIDATION=1 turns validation on, PN_DEVICE selects the device.
// PN_FAULT_INJECTION builds also read PN_FAULT_ALLOC=K (fault.count, fault.fail_at = K),
// PN_FAULT_MAX_ALLOC=SIZE and PN_FAULT_HEAP=SIZE (bytes, or with a K/M/G suffix).
pn_gpu_device_desc pn_gpu_device_desc_from_env(void);

// Creates everything or nothing; logs the reason on failure. `out` must not move afterwards
// (the messenger keeps a pointer to it to count messages).
pn_result pn_gpu_device_create(const pn_gpu_device_desc *desc, pn_gpu_device *out);
void pn_gpu_device_destroy(pn_gpu_device *dev);

// Picks a physical device: by PN_DEVICE-style selector if given (index or case-insensitive name
// substring), else the best by type (discrete, integrated, virtual, CPU) among those with Vulkan
// 1.3. Writes its index in the enumeration order; logs and fails if none fits, naming the selector
// as coming from `from` (NULL: "PN_DEVICE").
pn_result pn_gpu_pick_physical(VkInstance instance, const char *selector, const char *from, uint32_t *index);

// llvmpipe (Mesa 22.3): every shader invocation has one budget of 65,535 loop iterations, after
// which all its loops silently end (Mesa's loop_limiter). The shadow pass then splits its work
// into chunks and retries (shadow_pass.c). True on llvmpipe of any Mesa version (by device name;
// re-check the budget on Mesa 25), false on every other driver. engine/gpu/llvmpipe.md.
bool pn_gpu_device_loop_budget(const pn_gpu_device *dev);

// The largest single buffer this device can allocate: min(maxMemoryAllocationSize, maxBufferSize).
// Every pool is one buffer, so no pool may be larger (Mesa 22.3 and 25 lavapipe: 2 GiB).
VkDeviceSize pn_gpu_device_max_buffer(const pn_gpu_device *dev);

// The default budget of a tree's pools: half the largest device-local heap, leaving room for the
// frame's images (lavapipe: Mesa 22.3 reports a 2 GiB heap, Mesa 25 the machine's RAM).
VkDeviceSize pn_gpu_device_pool_budget(const pn_gpu_device *dev);

// Size of the largest device-local heap.
VkDeviceSize pn_gpu_device_heap(const pn_gpu_device *dev);

// A fault point, called by gpu/resources.c and gpu/tlas.c before each call that allocates (memory,
// a buffer, an image, an acceleration structure): counts it and returns true when it is the one to
// fail (fault.fail_at), or when `bytes` more would overflow fault.heap. Always false in builds without
// PN_FAULT_INJECTION.
bool pn_gpu_fault(pn_gpu_device *dev, const char *call, const char *what, uint64_t bytes);

// With VK_EXT_memory_budget (dev->memory_budget): the driver's figure of the bytes in use, summed
// over the heaps (this process's, as the extension defines it), into *bytes; false without it.
bool pn_gpu_device_heap_usage(const pn_gpu_device *dev, VkDeviceSize *bytes);

// One-shot command buffers for uploads and single frames: begin, then submit and wait.
pn_result pn_gpu_begin_once(pn_gpu_device *dev, VkCommandBuffer *cmd);
pn_result pn_gpu_submit_wait(pn_gpu_device *dev, VkCommandBuffer cmd);

// Index of a memory type with all of `flags` among `type_bits`, or UINT32_MAX.
uint32_t pn_gpu_memory_type(const pn_gpu_device *dev, uint32_t type_bits, VkMemoryPropertyFlags flags);
