// Ray-tracing pipelines (VK_KHR_ray_tracing_pipeline): one ray generation shader, one miss shader
// and one triangle hit group (closest hit and, optionally, any hit), with the shader binding table
// that holds their handles. The rtpipeline shadow mode traces through one (shadow_pass.c); its
// set and push constants are a pn_gpu_compute made for the ray-tracing stages (compute.h).
#pragma once
#include "gpu/compute.h"
#include "gpu/resources.h"

// The stages a ray-tracing pass's set and push constants are visible to.
#define PN_GPU_RAY_STAGES                                                                                         \
    (VK_SHADER_STAGE_RAYGEN_BIT_KHR | VK_SHADER_STAGE_MISS_BIT_KHR | VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR |     \
     VK_SHADER_STAGE_ANY_HIT_BIT_KHR)

typedef struct pn_gpu_ray_shaders {
    const uint32_t *raygen, *miss, *closest_hit, *any_hit; // SPIR-V; any_hit may be NULL
    size_t raygen_size, miss_size, closest_hit_size, any_hit_size; // bytes
} pn_gpu_ray_shaders;

typedef struct pn_gpu_ray_pipeline {
    VkPipeline pipeline;
    pn_gpu_buffer table; // the shader binding table: raygen, miss, hit group records
    VkStridedDeviceAddressRegionKHR raygen, miss, hit, callable;
    PFN_vkCmdTraceRaysKHR trace; // the device's (recording needs no device)
} pn_gpu_ray_pipeline;

// A pipeline of `shaders` for c's layout (spec, may be NULL, for every stage) and a recursion depth
// of 1 (no shader traces rays), and its binding table. Needs pn_gpu_device.ray_pipeline. The
// pipeline is the device's (pn_gpu_compute_pipeline says how), the binding table the caller's.
pn_result pn_gpu_ray_pipeline_create(pn_gpu_device *dev, const pn_gpu_compute *c, const pn_gpu_ray_shaders *shaders,
                                     const VkSpecializationInfo *spec, pn_gpu_ray_pipeline *out);
void pn_gpu_ray_pipeline_destroy(pn_gpu_device *dev, pn_gpu_ray_pipeline *p);

// Binds `p` with the set and push constants of `c` (a pass made for PN_GPU_RAY_STAGES) and
// launches width x height ray generation invocations.
void pn_gpu_ray_trace(VkCommandBuffer cmd, const pn_gpu_compute *c, const pn_gpu_ray_pipeline *p,
                      uint32_t push_size, const void *push, uint32_t width, uint32_t height);
