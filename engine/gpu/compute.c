// Compute pipelines: shader module, set layout, pipeline, descriptors and dispatches.
#include "gpu/compute.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "core/timer.h"
#include "interface.h"

uint64_t pn_gpu_variant_hash(uint64_t h, const void *data, size_t bytes)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < bytes; i++)
        h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

// Appends one row to PN_PIPELINE_LOG's file: one short write in append mode, so that the
// processes of a test (a script's commands) share the file.
static void log_row(const pn_gpu_device *dev, const char *kind, const char *name, size_t bytes, double ms)
{
    FILE *f = fopen(dev->pipeline_log, "a");
    if (!f) {
        pn_warn("PN_PIPELINE_LOG: cannot append to %s", dev->pipeline_log);
        return;
    }
    fprintf(f, "%s %s %zu %.1f\n", kind, name, bytes, ms);
    fclose(f);
}

void pn_gpu_pipeline_log(const pn_gpu_device *dev, const char *kind, uint64_t variant, size_t spirv_bytes,
                         uint64_t start_ns)
{
    if (!dev->pipeline_log)
        return;
    char name[17];
    snprintf(name, sizeof name, "%016llx", (unsigned long long)variant);
    log_row(dev, kind, name, spirv_bytes, pn_ms_since(start_ns));
}

void pn_gpu_first_use_log(const pn_gpu_device *dev, const char *pass, double ms)
{
    if (dev->pipeline_log)
        log_row(dev, "first-use", pass, 0, ms);
}

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

// Appends `size` bytes to the key; false where it would exceed `cap`.
static bool key_put(uint8_t *key, size_t *n, size_t cap, const void *bytes, size_t size)
{
    if (*n + size > cap)
        return false;
    memcpy(key + *n, bytes, size);
    *n += size;
    return true;
}

// The key of a pipeline for c's layout with `spec`: the set layout's bindings, the push constants'
// size and stages, each specialisation constant's id and bytes. 0 where it exceeds `cap`.
static size_t pipeline_key(const pn_gpu_compute *c, const VkSpecializationInfo *spec, uint8_t *key, size_t cap)
{
    size_t n = 0;
    uint32_t spec_count = spec ? spec->mapEntryCount : 0;
    bool ok = key_put(key, &n, cap, &c->binding_count, sizeof c->binding_count);
    for (uint32_t i = 0; ok && i < c->binding_count; i++) {
        const VkDescriptorSetLayoutBinding *b = &c->bindings[i];
        uint32_t v[4] = {b->binding, (uint32_t)b->descriptorType, b->descriptorCount, b->stageFlags};
        ok = !b->pImmutableSamplers && key_put(key, &n, cap, v, sizeof v); // compute passes have none
    }
    uint32_t v[3] = {c->push_size, c->stages, spec_count};
    ok = ok && key_put(key, &n, cap, v, sizeof v);
    for (uint32_t i = 0; ok && i < spec_count; i++) {
        const VkSpecializationMapEntry *e = &spec->pMapEntries[i];
        uint32_t head[2] = {e->constantID, (uint32_t)e->size};
        ok = key_put(key, &n, cap, head, sizeof head) &&
             key_put(key, &n, cap, (const char *)spec->pData + e->offset, e->size);
    }
    return ok ? n : 0;
}

pn_result pn_gpu_pipeline_find(pn_gpu_device *dev, const pn_gpu_compute *c, const VkSpecializationInfo *spec,
                               pn_gpu_pipeline_entry *e, VkPipeline *found)
{
    *found = VK_NULL_HANDLE;
    e->key_size = pipeline_key(c, spec, e->key, sizeof e->key);
    if (!e->key_size) {
        pn_error("a pipeline's layout and specialisation exceed %d bytes of key", PN_GPU_PIPELINE_KEY_MAX);
        return PN_ERR_INVALID;
    }
    e->variant = PN_GPU_VARIANT_SEED;
    for (int k = 0; k < 4; k++)
        e->variant = pn_gpu_variant_hash(e->variant, e->spirv[k], e->spirv_size[k]);
    e->variant = pn_gpu_variant_hash(e->variant, e->key, e->key_size);
    for (uint32_t i = 0; i < dev->pipeline_count; i++) {
        const pn_gpu_pipeline_entry *m = &dev->pipelines[i];
        bool same = m->variant == e->variant && m->key_size == e->key_size && !memcmp(m->key, e->key, e->key_size);
        for (int k = 0; same && k < 4; k++)
            same = m->spirv_size[k] == e->spirv_size[k] &&
                   (m->spirv[k] == e->spirv[k] || !memcmp(m->spirv[k], e->spirv[k], e->spirv_size[k]));
        if (same) {
            *found = m->pipeline;
            return PN_OK;
        }
    }
    return PN_OK;
}

pn_result pn_gpu_pipeline_begin(pn_gpu_device *dev, const pn_gpu_compute *c, pn_gpu_pipeline_entry *e)
{
    pn_gpu_pipeline_entry *grown = realloc(dev->pipelines, (dev->pipeline_count + 1) * sizeof *grown);
    if (!grown)
        return PN_ERR_MEMORY;
    dev->pipelines = grown;
    pn_result r = pn_gpu_set_layout(dev, c->bindings, c->binding_count, &e->set_layout);
    if (r == PN_OK)
        r = pn_gpu_pipeline_layout(dev, e->set_layout, c->stages, c->push_size, &e->layout);
    if (r != PN_OK)
        pn_gpu_pipeline_end(dev, e, r);
    return r;
}

pn_result pn_gpu_pipeline_end(pn_gpu_device *dev, pn_gpu_pipeline_entry *e, pn_result r)
{
    if (r == PN_OK && e->pipeline) {
        dev->pipelines[dev->pipeline_count++] = *e; // room made by pn_gpu_pipeline_begin
        return PN_OK;
    }
    if (e->pipeline)
        vkDestroyPipeline(dev->device, e->pipeline, NULL);
    if (e->layout)
        vkDestroyPipelineLayout(dev->device, e->layout, NULL);
    if (e->set_layout)
        vkDestroyDescriptorSetLayout(dev->device, e->set_layout, NULL);
    e->pipeline = VK_NULL_HANDLE, e->layout = VK_NULL_HANDLE, e->set_layout = VK_NULL_HANDLE;
    return r;
}

pn_result pn_gpu_compute_pipeline(pn_gpu_device *dev, const pn_gpu_compute *c, const uint32_t *spirv,
                                  size_t spirv_size, const VkSpecializationInfo *spec, VkPipeline *out)
{
    pn_gpu_pipeline_entry e = {.spirv = {spirv}, .spirv_size = {spirv_size}};
    PN_TRY(pn_gpu_pipeline_find(dev, c, spec, &e, out));
    if (*out)
        return PN_OK;
    PN_TRY(pn_gpu_pipeline_begin(dev, c, &e));
    VkShaderModule module = VK_NULL_HANDLE;
    pn_result r = pn_gpu_shader_module(dev, spirv, spirv_size, &module);
    if (r == PN_OK) {
        VkComputePipelineCreateInfo ci = {
            .sType = VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO,
            .stage = {.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
                      .stage = VK_SHADER_STAGE_COMPUTE_BIT,
                      .module = module,
                      .pName = "main",
                      .pSpecializationInfo = spec},
            .layout = e.layout,
        };
        uint64_t t0 = pn_time_ns();
        VkResult vr = vkCreateComputePipelines(dev->device, VK_NULL_HANDLE, 1, &ci, NULL, &e.pipeline);
        vkDestroyShaderModule(dev->device, module, NULL);
        if (vr == VK_SUCCESS) {
            pn_gpu_pipeline_log(dev, "compute", e.variant, spirv_size, t0);
        } else {
            pn_error("creating a compute pipeline failed: %s", pn_vk_result_str(vr));
            e.pipeline = VK_NULL_HANDLE;
            r = PN_ERR_VULKAN;
        }
    }
    PN_TRY(pn_gpu_pipeline_end(dev, &e, r));
    *out = e.pipeline;
    return PN_OK;
}

pn_result pn_gpu_compute_create(pn_gpu_device *dev, const pn_gpu_compute_desc *desc, pn_gpu_compute *out)
{
    memset(out, 0, sizeof *out);
    VkDescriptorSetLayoutBinding *b = out->bindings;
    VkDescriptorPoolSize sizes[PN_GPU_MAX_BINDINGS];
    if (desc->binding_count > PN_GPU_MAX_BINDINGS)
        return PN_ERR_INVALID;
    out->binding_count = desc->binding_count;
    out->push_size = desc->push_size;
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
        r = pn_gpu_compute_pipeline(dev, out, desc->spirv, desc->spirv_size, desc->spec, &out->pipeline);
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
    if (c->layout) // c->pipeline is the device's
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
    return pn_gpu_compute_create_images_buffer(dev, spirv, spirv_size, images, count, UINT32_MAX, VK_NULL_HANDLE,
                                               push_size, spec, out);
}

pn_result pn_gpu_compute_create_images_buffer(pn_gpu_device *dev, const uint32_t *spirv, size_t spirv_size,
                                              const VkImageView *images, uint32_t count, uint32_t buffer_binding,
                                              VkBuffer buffer, uint32_t push_size, const VkSpecializationInfo *spec,
                                              pn_gpu_compute *out)
{
    VkDescriptorSetLayoutBinding bindings[PN_GPU_MAX_IMAGE_BINDINGS];
    if (count > PN_GPU_MAX_IMAGE_BINDINGS)
        return PN_ERR_INVALID;
    for (uint32_t i = 0; i < count; i++)
        bindings[i] = (VkDescriptorSetLayoutBinding){
            .binding = i,
            .descriptorType = i == buffer_binding ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE};
    PN_TRY(pn_gpu_compute_create(dev,
                                 &(pn_gpu_compute_desc){.spirv = spirv,
                                                        .spirv_size = spirv_size,
                                                        .bindings = bindings,
                                                        .binding_count = count,
                                                        .push_size = push_size,
                                                        .spec = spec},
                                 out));
    for (uint32_t i = 0; i < count; i++) {
        if (i == buffer_binding)
            pn_gpu_compute_write_buffer(dev, out, i, buffer);
        else
            pn_gpu_compute_write_image(dev, out, i, images[i]);
    }
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

void pn_gpu_compute_dispatch_rows(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size, const void *push,
                                  uint32_t width, uint32_t height, bool one_tile)
{
    uint32_t gx = one_tile ? 1 : (width + PN_ROW_GROUP - 1) / PN_ROW_GROUP, gy = one_tile ? 1 : height;
    pn_gpu_compute_dispatch(cmd, c, push_size, push, gx, gy, 1);
}

void pn_gpu_compute_dispatch_indirect(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size,
                                      const void *push, VkBuffer args, VkDeviceSize offset)
{
    pn_gpu_compute_bind(cmd, c, push_size, push);
    vkCmdDispatchIndirect(cmd, args, offset);
}
