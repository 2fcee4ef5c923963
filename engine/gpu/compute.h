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

// The pipeline log (PN_PIPELINE_LOG, pn_gpu_device.pipeline_log): each pipeline created appends
// "<kind> <variant> <SPIR-V bytes> <ms>" to the file, the variant a hash of its SPIR-V,
// specialisation and layout (the same variant twice: a pipeline made again by another device), ms
// the creation's wall-clock time. Mesa's disk cache makes a cold creation seconds and a warm one
// milliseconds on llvmpipe, so the log tells what a test compiled (tests/timings.sh).
// pn_gpu_variant_hash folds `bytes` of `data` into h (FNV-1a; start from PN_GPU_VARIANT_SEED).
#define PN_GPU_VARIANT_SEED 14695981039346656037ull
uint64_t pn_gpu_variant_hash(uint64_t h, const void *data, size_t bytes);
void pn_gpu_pipeline_log(const pn_gpu_device *dev, const char *kind, uint64_t variant, size_t spirv_bytes,
                         uint64_t start_ns);
// The same log's row `first-use <pass> 0 <ms>`: a pass's time in a renderer's warm-up frame, where
// llvmpipe JIT-compiles the pipelines it runs (their creation does not), so a cold cache's cost
// shows there (tests/timings.sh adds it to the creation's).
void pn_gpu_first_use_log(const pn_gpu_device *dev, const char *pass, double ms);

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

enum { PN_GPU_MAX_BINDINGS = 16 };
typedef struct pn_gpu_compute {
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkPipeline pipeline; // the device's (pn_gpu_compute_pipeline)
    // The layout's definition, as created (stageFlags and counts filled in): what the device's
    // pipelines for this pass are keyed by and their own layouts are made from.
    VkDescriptorSetLayoutBinding bindings[PN_GPU_MAX_BINDINGS];
    uint32_t binding_count;
    uint32_t push_size;
    VkDescriptorPool pool;
    VkDescriptorSet set; // allocated, not written: see pn_gpu_compute_write_*
    VkShaderStageFlags stages;       // desc.stages (compute if 0)
    VkPipelineBindPoint bind_point; // compute, or ray tracing for ray-tracing stages
} pn_gpu_compute;

// A compute pipeline of `spirv` for c's layout (spec may be NULL): pn_gpu_compute_create's, or
// another specialisation of the same shader sharing a pass's layout and set. The device's own
// (pn_gpu_device.pipelines): made once per device for each SPIR-V, specialisation and layout
// definition, shared by every pass that asks for it, destroyed with the device, never by a pass.
// spirv must outlive the device (the engine's shaders are static arrays).
pn_result pn_gpu_compute_pipeline(pn_gpu_device *dev, const pn_gpu_compute *c, const uint32_t *spirv,
                                  size_t spirv_size, const VkSpecializationInfo *spec, VkPipeline *out);

// The device's pipelines, for each kind of pipeline: e->spirv and e->spirv_size set (unused
// stages NULL and 0), find fills e's key and *found with the device's pipeline, VK_NULL_HANDLE if
// none; then begin makes e's own layouts (e->layout, to create e->pipeline with) and end keeps e
// where r is PN_OK and e->pipeline was made, and otherwise destroys what e holds and returns r.
pn_result pn_gpu_pipeline_find(pn_gpu_device *dev, const pn_gpu_compute *c, const VkSpecializationInfo *spec,
                               pn_gpu_pipeline_entry *e, VkPipeline *found);
pn_result pn_gpu_pipeline_begin(pn_gpu_device *dev, const pn_gpu_compute *c, pn_gpu_pipeline_entry *e);
pn_result pn_gpu_pipeline_end(pn_gpu_device *dev, pn_gpu_pipeline_entry *e, pn_result r);

pn_result pn_gpu_compute_create(pn_gpu_device *dev, const pn_gpu_compute_desc *desc, pn_gpu_compute *out);
void pn_gpu_compute_destroy(pn_gpu_device *dev, pn_gpu_compute *c);

// A compute pass whose set is storage images only, binding i = images[i] (GENERAL layout): the
// shading and filter passes. spec may be NULL.
enum { PN_GPU_MAX_IMAGE_BINDINGS = 12 };
pn_result pn_gpu_compute_create_images(pn_gpu_device *dev, const uint32_t *spirv, size_t spirv_size,
                                       const VkImageView *images, uint32_t count, uint32_t push_size,
                                       const VkSpecializationInfo *spec, pn_gpu_compute *out);
// The same with binding buffer_binding a storage buffer, `buffer` (images[buffer_binding] unused):
// the filters' list of tiles near a blocker (penumbra_pass.h).
pn_result pn_gpu_compute_create_images_buffer(pn_gpu_device *dev, const uint32_t *spirv, size_t spirv_size,
                                              const VkImageView *images, uint32_t count, uint32_t buffer_binding,
                                              VkBuffer buffer, uint32_t push_size, const VkSpecializationInfo *spec,
                                              pn_gpu_compute *out);

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
// The same over a width x height image in PN_ROW_GROUP-pixel rows (the image passes' work groups:
// interface.h); one_tile, the renderer's warm-up frame, dispatches one group.
void pn_gpu_compute_dispatch_rows(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size, const void *push,
                                  uint32_t width, uint32_t height, bool one_tile);
// The same with the group counts read from `args` at `offset` (a VkDispatchIndirectCommand) when
// the dispatch runs: a count an earlier dispatch wrote.
void pn_gpu_compute_dispatch_indirect(VkCommandBuffer cmd, const pn_gpu_compute *c, uint32_t push_size,
                                      const void *push, VkBuffer args, VkDeviceSize offset);
