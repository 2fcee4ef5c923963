// Compute pipelines: shader module, set layout, pipeline, descriptors and dispatches.
#include "gpu/compute.h"

#include <string.h>

pn_result pn_gpu_shader_module(pn_gpu_device *dev, const uint32_t *spirv, size_t bytes, VkShaderModule *out)
{
    VkShaderModuleCreateInfo ci = {.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO, .codeSize = bytes, .pCode = spirv};
    VK_CHECK(vkCreateShaderModule(dev->device, &ci, NULL, out));
    return PN_OK;
}

pn_result pn_gpu_set_layout(pn_gpu_device *dev, const VkDescriptorSetLayoutBinding *bindings, uint32_t count,
                            VkDescriptorSetLayout *out)
{
    VkDescriptorSetLayoutCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO,
        .bindingCount = count,
        .pBindings = bindings,
    };
    VK_CHECK(vkCreateDescriptorSetLayout(dev->device, &ci, NULL, out));
    return PN_OK;
}

pn_result pn_gpu_pipeline_layout(pn_gpu_device *dev, VkDescriptorSetLayout set, VkShaderStageFlags stages,
                                 uint32_t push_size, VkPipelineLayout *out)
{
    VkPushConstantRange range = {.stageFlags = stages, .size = push_size};
    VkPipelineLayoutCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO,
        .setLayoutCount = 1,
        .pSetLayouts = &set,
        .pushConstantRangeCount = push_size ? 1 : 0,
        .pPushConstantRanges = &range,
    };
    VK_CHECK(vkCreatePipelineLayout(dev->device, &ci, NULL, out));
    return PN_OK;
}

pn_result pn_gpu_compute_pipeline(pn_gpu_device *dev, VkPipelineLayout layout, const uint32_t *spirv, size_t spirv_size,
                                  const VkSpecializationInfo *spec, VkPipeline *out)
{
    VkShaderModule module = VK_NULL_HANDLE;
    PN_TRY(pn_gpu_shader_module(dev, spirv, spirv_size, &module));
    VkComputePipelineCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
        .stage = {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                  .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                  .module = module,
                  .pName = "main",
                  .pSpecializationInfo = spec},
        .layout = layout,
    };
    VkResult vr = vkCreateComputePipelines(dev->device, VK_NULL_HANDLE, 1, &ci, NULL, out);
    vkDestroyShaderModule(dev->device, module, NULL);
    if (vr != VK_SUCCESS) {
        pn_error("creating a compute pipeline failed: %s", pn_vk_result_str(vr));
        return PN_ERR_VULKAN;
    }
    return PN_OK;
}

pn_result pn_gpu_compute_create(pn_gpu_device *dev, const pn_gpu_compute_desc *desc, pn_gpu_compute *out)
{
    memset(out, 0, sizeof *out);
    VkDescriptorSetLayoutBinding b[16];
    VkDescriptorPoolSize sizes[16];
    if (desc->binding_count > 16)
        return PN_ERR_INVALID;
    out->stages = desc->stages ? desc->stages : VK_SHADER_STAGE_COMPUTE_BIT;
    out->bind_point = desc->stages & ~VK_SHADER_STAGE_COMPUTE_BIT ? VK_PIPELINE_BIND_POINT_RAY_TRACING_KHR
                                                                  : VK_PIPELINE_BIND_POINT_COMPUTE;
    for (uint32_t i = 0; i < desc->binding_count; i++) {
        b[i] = desc->bindings[i];
        if (!b[i].stageFlags)
            b[i].stageFlags = out->stages;
        if (!b[i].descriptorCount)
            b[i].descriptorCount = 1;
        sizes[i] = (VkDescriptorPoolSize){b[i].descriptorType, b[i].descriptorCount};
    }
    pn_result r = pn_gpu_set_layout(dev, b, desc->binding_count, &out->set_layout);
    if (r == PN_OK)
        r = pn_gpu_pipeline_layout(dev, out->set_layout, out->stages, desc->push_size, &out->layout);
    if (r == PN_OK && desc->spirv)
        r = pn_gpu_compute_pipeline(dev, out->layout, desc->spirv, desc->spirv_size, desc->spec, &out->pipeline);
    if (r == PN_OK && desc->binding_count) {
        VkDescriptorPoolCreateInfo pi = {
            .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO,
            .maxSets = 1,
            .poolSizeCount = desc->binding_count,
            .pPoolSizes = sizes,
        };
        VkDescriptorSetAllocateInfo ai = {
            .sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO,
            .descriptorSetCount = 1,
            .pSetLayouts = &out->set_layout,
        };
        VkResult vr = vkCreateDescriptorPool(dev->device, &pi, NULL, &out->pool);
        ai.descriptorPool = out->pool;
        if (vr == VK_SUCCESS)
            vr = vkAllocateDescriptorSets(dev->device, &ai, &out->set);
        if (vr != VK_SUCCESS) {
            pn_error("creating a compute pipeline's descriptor set failed: %s", pn_vk_result_str(vr));
            r = PN_ERR_VULKAN;
        }
    }
    if (r != PN_OK)
        pn_gpu_compute_destroy(dev, out);
    return r;
}

void pn_gpu_compute_destroy(pn_gpu_device *dev, pn_gpu_compute *c)
{
    if (c->pipeline)
        vkDestroyPipeline(dev->device, c->pipeline, NULL);
    if (c->layout)
        vkDestroyPipelineLayout(dev->device, c->layout, NULL);
    if (c->pool)
        vkDestroyDescriptorPool(dev->device, c->pool, NULL);
    if (c->set_layout)
        vkDestroyDescriptorSetLayout(dev->device, c->set_layout, NULL);
    memset(c, 0, sizeof *c);
}

pn_result pn_gpu_compute_create_images(pn_gpu_device *dev, const uint32_t *spirv, size_t spirv_size,
                                       const VkImageView *images, uint32_t count, uint32_t push_size,
                                       const VkSpecializationInfo *spec, pn_gpu_compute *out)
{
    VkDescriptorSetLayoutBinding bindings[PN_GPU_MAX_IMAGE_BINDINGS];
    if (count > PN_GPU_MAX_IMAGE_BINDINGS)
        return PN_ERR_INVALID;
    for (uint32_t i = 0; i < count; i++)
        bindings[i] = (VkDescriptorSetLayoutBinding){.binding = i, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE};
    PN_TRY(pn_gpu_compute_create(dev,
                                 &(pn_gpu_compute_desc){.spirv = spirv,
                                                        .spirv_size = spirv_size,
                                                        .bindings = bindings,
                                                        .binding_count = count,
                                                        .push_size = push_size,
                                                        .spec = spec},
                                 out));
    for (uint32_t i = 0; i < count; i++)
        pn_gpu_compute_write_image(dev, out, i, images[i]);
    return PN_OK;
}

void pn_gpu_compute_write_image(pn_gpu_device *dev, pn_gpu_compute *c, uint32_t binding, VkImageView view)
{
    VkDescriptorImageInfo info = {VK_NULL_HANDLE, view, VK_IMAGE_LAYOUT_GENERAL};
    VkWriteDescriptorSet w = {
        .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
        .dstSet = c->set,
        .dstBinding = binding,
        .descriptorCount = 1,
        .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
        .pImageInfo = &info,
    };
    vkUpdateDescriptorSets(dev->device, 1, &w, 0, NULL);
}

static void write_buffer(pn_gpu_device *dev, pn_gpu_compute *c, uint32_t binding, VkBuffer buffer, VkDescriptorType type)
{
    VkDescriptorBufferInfo info = {buffer, 0, VK_WHOLE_SIZE};
    VkWriteDescriptorSet w = {
        .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
        .dstSet = c->set,
        .dstBinding = binding,
        .descriptorCount = 1,
        .descriptorType = type,
        .pBufferInfo = &info,
    };
    vkUpdateDescriptorSets(dev->device, 1, &w, 0, NULL);
}

void pn_gpu_compute_write_buffer(pn_gpu_device *dev, pn_gpu_compute *c, uint32_t binding, VkBuffer buffer)
{
    write_buffer(dev, c, binding, buffer, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
}

void pn_gpu_compute_write_uniform(pn_gpu_device *dev, pn_gpu_compute *c, uint32_t binding, VkBuffer buffer)
{
    write_buffer(dev, c, binding, buffer, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
}

void pn_gpu_compute_write_tlas(pn_gpu_device *dev, pn_gpu_compute *c, uint32_t binding, VkAccelerationStructureKHR tlas)
{
    VkWriteDescriptorSetAccelerationStructureKHR as = {
        .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET_ACCELERATION_STRUCTURE_KHR,
        .accelerationStructureCount = 1,
        .pAccelerationStructures = &tlas,
    };
    VkWriteDescriptorSet w = {
        .sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET,
        .pNext = &as,
        .dstSet = c->set,
        .dstBinding = binding,
        .descriptorCount = 1,
        .descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR,
    };
    vkUpdateDescriptorSets(dev->device, 1, &w, 0, NULL);
}

void pn_gpu_compute_bind(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size, const void *push)
{
    vkCmdBindPipeline(cmd, c->bind_point, c->pipeline);
    if (c->set)
        vkCmdBindDescriptorSets(cmd, c->bind_point, c->layout, 0, 1, &c->set, 0, NULL);
    if (push_size)
        vkCmdPushConstants(cmd, c->layout, c->stages, 0, push_size, push);
}

void pn_gpu_compute_dispatch(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size, const void *push,
                             uint32_t x, uint32_t y, uint32_t z)
{
    pn_gpu_compute_bind(cmd, c, push_size, push);
    vkCmdDispatch(cmd, x, y, z);
}

void pn_gpu_compute_dispatch_indirect(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size,
                                      const void *push, VkBuffer args, VkDeviceSize offset)
{
    pn_gpu_compute_bind(cmd, c, push_size, push);
    vkCmdDispatchIndirect(cmd, args, offset);
}
