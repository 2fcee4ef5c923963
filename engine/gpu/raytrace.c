// Ray-tracing pipelines and their shader binding tables.
#include "gpu/raytrace.h"

#include <string.h>

#include "core/log.h"
#include "core/timer.h"

static VkDeviceSize align_up(VkDeviceSize v, VkDeviceSize a) { return a ? (v + a - 1) / a * a : v; }

pn_result pn_gpu_ray_pipeline_create(pn_gpu_device *dev, const pn_gpu_compute *c, const pn_gpu_ray_shaders *shaders,
                                     const VkSpecializationInfo *spec, pn_gpu_ray_pipeline *out)
{
    memset(out, 0, sizeof *out);
    if (!dev->ray_pipeline) {
        pn_error("%s has no ray-tracing pipelines (VK_KHR_ray_tracing_pipeline)", dev->props.deviceName);
        return PN_ERR_UNSUPPORTED;
    }
    const uint32_t *code[4] = {shaders->raygen, shaders->miss, shaders->closest_hit, shaders->any_hit};
    const size_t size[4] = {shaders->raygen_size, shaders->miss_size, shaders->closest_hit_size, shaders->any_hit_size};
    const VkShaderStageFlagBits stage[4] = {VK_SHADER_STAGE_RAYGEN_BIT_KHR, VK_SHADER_STAGE_MISS_BIT_KHR,
                                            VK_SHADER_STAGE_CLOSEST_HIT_BIT_KHR, VK_SHADER_STAGE_ANY_HIT_BIT_KHR};
    uint32_t count = shaders->any_hit ? 4 : 3;
    // The device's pipeline for these shaders, or a new one kept there (pn_gpu_pipeline_find).
    pn_gpu_pipeline_entry e = {0};
    for (uint32_t i = 0; i < count; i++)
        e.spirv[i] = code[i], e.spirv_size[i] = size[i];
    PN_TRY(pn_gpu_pipeline_find(dev, c, spec, &e, &out->pipeline));
    if (!out->pipeline)
        PN_TRY(pn_gpu_pipeline_begin(dev, c, &e));
    VkShaderModule modules[4] = {VK_NULL_HANDLE};
    VkPipelineShaderStageCreateInfo stages[4];
    pn_result r = PN_OK;
    for (uint32_t i = 0; i < count && r == PN_OK && !out->pipeline; i++) {
        r = pn_gpu_shader_module(dev, code[i], size[i], &modules[i]);
        stages[i] = (VkPipelineShaderStageCreateInfo){.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                                                      .stage = stage[i],
                                                      .module = modules[i],
                                                      .pName = "main",
                                                      .pSpecializationInfo = spec};
    }
    // Groups: 0 ray generation, 1 miss (general shaders), 2 the triangles' hit group.
    const VkRayTracingShaderGroupCreateInfoKHR UNUSED = {.sType = VK_STRUCTURE_TYPE_RAY_TRACING_SHADER_GROUP_CREATE_INFO_KHR,
                                                         .generalShader = VK_SHADER_UNUSED_KHR,
                                                         .closestHitShader = VK_SHADER_UNUSED_KHR,
                                                         .anyHitShader = VK_SHADER_UNUSED_KHR,
                                                         .intersectionShader = VK_SHADER_UNUSED_KHR};
    VkRayTracingShaderGroupCreateInfoKHR groups[3] = {UNUSED, UNUSED, UNUSED};
    groups[0].type = groups[1].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_GENERAL_KHR;
    groups[0].generalShader = 0;
    groups[1].generalShader = 1;
    groups[2].type = VK_RAY_TRACING_SHADER_GROUP_TYPE_TRIANGLES_HIT_GROUP_KHR;
    groups[2].closestHitShader = 2;
    groups[2].anyHitShader = shaders->any_hit ? 3 : VK_SHADER_UNUSED_KHR;
    VkRayTracingPipelineCreateInfoKHR ci = {.sType = VK_STRUCTURE_TYPE_RAY_TRACING_PIPELINE_CREATE_INFO_KHR,
                                            .stageCount = count,
                                            .pStages = stages,
                                            .groupCount = 3,
                                            .pGroups = groups,
                                            .maxPipelineRayRecursionDepth = 1,
                                            .layout = e.layout};
    if (!out->pipeline) {
        uint64_t t0 = pn_time_ns();
        VkResult vr = r == PN_OK ? dev->rt.create(dev->device, VK_NULL_HANDLE, VK_NULL_HANDLE, 1, &ci, NULL, &e.pipeline)
                                 : VK_SUCCESS;
        if (vr != VK_SUCCESS) {
            e.pipeline = VK_NULL_HANDLE;
            pn_error("creating a ray-tracing pipeline failed: %s", pn_vk_result_str(vr));
            r = PN_ERR_VULKAN;
        } else if (r == PN_OK) {
            pn_gpu_pipeline_log(dev, "raytracing", e.variant, size[0] + size[1] + size[2] + size[3], t0);
        }
        for (uint32_t i = 0; i < count; i++)
            if (modules[i])
                vkDestroyShaderModule(dev->device, modules[i], NULL);
        r = pn_gpu_pipeline_end(dev, &e, r);
        out->pipeline = r == PN_OK ? e.pipeline : VK_NULL_HANDLE;
    }
    // The binding table: each region starts at a multiple of shaderGroupBaseAlignment, each record
    // is a handle rounded up to shaderGroupHandleAlignment (no record data).
    const VkPhysicalDeviceRayTracingPipelinePropertiesKHR *rp = &dev->rt_props;
    uint32_t handle = rp->shaderGroupHandleSize;
    VkDeviceSize record = align_up(handle, rp->shaderGroupHandleAlignment);
    VkDeviceSize base = rp->shaderGroupBaseAlignment ? rp->shaderGroupBaseAlignment : 1;
    VkDeviceSize region = align_up(record, base);
    uint8_t handles[3 * 64];
    if (r == PN_OK && (handle == 0 || handle > 64)) {
        pn_error("%s: shader group handles of %u bytes (penumbra takes 1 to 64)", dev->props.deviceName, handle);
        r = PN_ERR_UNSUPPORTED;
    }
    VkResult vr = r == PN_OK ? dev->rt.handles(dev->device, out->pipeline, 0, 3, 3 * handle, handles) : VK_SUCCESS;
    if (vr != VK_SUCCESS) {
        pn_error("vkGetRayTracingShaderGroupHandlesKHR failed: %s", pn_vk_result_str(vr));
        r = PN_ERR_VULKAN;
    }
    // One more region's worth, so that the first record can start on the base alignment.
    if (r == PN_OK)
        r = pn_gpu_buffer_create(dev, "shader binding table", 4 * region,
                                 VK_BUFFER_USAGE_SHADER_BINDING_TABLE_BIT_KHR | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT,
                                 PN_GPU_HOST_UPLOAD, &out->table);
    if (r != PN_OK) {
        pn_gpu_ray_pipeline_destroy(dev, out);
        return r;
    }
    VkDeviceAddress first = align_up(out->table.address, base);
    uint8_t *mapped = (uint8_t *)out->table.mapped + (first - out->table.address);
    memset(out->table.mapped, 0, 4 * region);
    for (int g = 0; g < 3; g++)
        memcpy(mapped + g * region, handles + g * handle, handle);
    // The ray generation region's stride must equal its size; miss and hit have one record each.
    out->raygen = (VkStridedDeviceAddressRegionKHR){first, region, region};
    out->miss = (VkStridedDeviceAddressRegionKHR){first + region, record, record};
    out->hit = (VkStridedDeviceAddressRegionKHR){first + 2 * region, record, record};
    out->trace = dev->rt.trace;
    return PN_OK;
}

void pn_gpu_ray_pipeline_destroy(pn_gpu_device *dev, pn_gpu_ray_pipeline *p)
{
    pn_gpu_buffer_destroy(dev, &p->table); // p->pipeline is the device's
    memset(p, 0, sizeof *p);
}

void pn_gpu_ray_trace(VkCommandBuffer cmd, const pn_gpu_compute *c, const pn_gpu_ray_pipeline *p,
                      uint32_t push_size, const void *push, uint32_t width, uint32_t height)
{
    pn_gpu_compute pass = *c;
    pass.pipeline = p->pipeline;
    pn_gpu_compute_bind(cmd, &pass, push_size, push);
    p->trace(cmd, &p->raygen, &p->miss, &p->hit, &p->callable, width, height, 1);
}
