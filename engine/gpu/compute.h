// Pipelines: the helpers every pipeline is made of (shader module, set layout, pipeline layout),
// and a compute pipeline with its own descriptor set, what every compute pass (shadow, shade,
// tests' probes) needs, created from one description.
#pragma once
#include "gpu/device.h"

pn_result pn_gpu_shader_module(pn_gpu_device *dev, const uint32_t *spirv, size_t bytes, VkShaderModule *out);
// Bindings whose stageFlags are 0 get `stages`.
pn_result pn_gpu_set_layout(pn_gpu_device *dev, const VkDescriptorSetLayoutBinding *bindings, uint32_t count,
                            VkDescriptorSetLayout *out);
// One set; push constants of push_size bytes (0: none) visible to `stages`.
pn_result pn_gpu_pipeline_layout(pn_gpu_device *dev, VkDescriptorSetLayout set, VkShaderStageFlags stages,
                                 uint32_t push_size, VkPipelineLayout *out);

// A compute pipeline of `spirv` with `layout` (spec may be NULL): pn_gpu_compute_create's, or
// another specialisation of the same shader sharing a pass's layout and set.
pn_result pn_gpu_compute_pipeline(pn_gpu_device *dev, VkPipelineLayout layout, const uint32_t *spirv, size_t spirv_size,
                                  const VkSpecializationInfo *spec, VkPipeline *out);

typedef struct pn_gpu_compute_desc {
    const uint32_t *spirv; // NULL: no pipeline (the caller makes its own with the layout: gpu/raytrace.h)
    size_t spirv_size; // bytes
    const VkDescriptorSetLayoutBinding *bindings; // set 0; stageFlags may be left 0 (compute)
    uint32_t binding_count;
    uint32_t push_size; // bytes of push constants, 0 for none
    const VkSpecializationInfo *spec;
    // The stages that see the set and the push constants: 0 for compute; ray-tracing stages make
    // the set and pushes bind to the ray-tracing bind point (a pass without a compute shader).
    VkShaderStageFlags stages;
} pn_gpu_compute_desc;

typedef struct pn_gpu_compute {
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkPipeline pipeline;
    VkDescriptorPool pool;
    VkDescriptorSet set; // allocated, not written: see pn_gpu_compute_write_*
    VkShaderStageFlags stages;       // desc.stages (compute if 0)
    VkPipelineBindPoint bind_point; // compute, or ray tracing for ray-tracing stages
} pn_gpu_compute;

pn_result pn_gpu_compute_create(pn_gpu_device *dev, const pn_gpu_compute_desc *desc, pn_gpu_compute *out);
void pn_gpu_compute_destroy(pn_gpu_device *dev, pn_gpu_compute *c);

// A compute pass whose set is storage images only, binding i = images[i] (GENERAL layout): the
// shading and filter passes. spec may be NULL.
enum { PN_GPU_MAX_IMAGE_BINDINGS = 8 };
pn_result pn_gpu_compute_create_images(pn_gpu_device *dev, const uint32_t *spirv, size_t spirv_size,
                                       const VkImageView *images, uint32_t count, uint32_t push_size,
                                       const VkSpecializationInfo *spec, pn_gpu_compute *out);

// Points binding `binding` of the set at a storage image (GENERAL layout) or a storage buffer.
void pn_gpu_compute_write_image(pn_gpu_device *dev, pn_gpu_compute *c, uint32_t binding, VkImageView view);
void pn_gpu_compute_write_buffer(pn_gpu_device *dev, pn_gpu_compute *c, uint32_t binding, VkBuffer buffer);
void pn_gpu_compute_write_uniform(pn_gpu_device *dev, pn_gpu_compute *c, uint32_t binding, VkBuffer buffer);
void pn_gpu_compute_write_tlas(pn_gpu_device *dev, pn_gpu_compute *c, uint32_t binding, VkAccelerationStructureKHR tlas);

// Binds pipeline and set at the pass's bind point and pushes `push` (push_size bytes, may be NULL).
void pn_gpu_compute_bind(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size, const void *push);
// Binds pipeline and set, pushes `push` (push_size bytes, may be NULL) and dispatches.
void pn_gpu_compute_dispatch(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size, const void *push,
                             uint32_t x, uint32_t y, uint32_t z);
// The same with the group counts read from `args` at `offset` (a VkDispatchIndirectCommand) when
// the dispatch runs: a count an earlier dispatch wrote.
void pn_gpu_compute_dispatch_indirect(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size,
                                      const void *push, VkBuffer args, VkDeviceSize offset);
