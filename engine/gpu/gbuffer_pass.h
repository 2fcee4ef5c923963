// The G-buffer pass: the scene's triangles rasterised into P (world position), N (normal, view
// depth) and albedo, with reversed Z. Owns the scene's GPU copy (vertices, indices, materials,
// textures) and the graphics pipeline.
#pragma once
#include "gpu/compute.h"
#include "gpu/gbuffer_clusters.h"
#include "gpu/gbuffer_cull.h"
#include "gpu/resources.h"
#include "interface.h"
#include "scene/scene.h"
#include "scene/view.h"

typedef struct pn_gbuffer_pass {
    pn_gpu_buffer vertices, indices, materials;
    pn_gpu_image *textures; // at least one (a white texel when the scene has none)
    uint32_t texture_count;
    VkSampler sampler;
    pn_draw *draws;
    pn_gbuffer_cull *cull; // per draw: whether it may cull its back faces (gbuffer_cull.h)
    uint32_t draw_count;
    // The draws cut into clusters, what a frame skips (gbuffer_clusters.h), over the raster order
    // (raster_indices, kept for their bounds when vertices move), and room for one draw's runs.
    pn_gbuffer_clusters clusters;
    uint32_t *raster_indices;
    pn_gbuffer_run *runs;
    bool draw_all; // every triangle drawn, no cluster skipped: the reference tests compare with
    float scene_min[3], scene_max[3]; // for the clip planes
    VkDescriptorPool descriptor_pool;
    VkDescriptorSetLayout set_layout;
    VkDescriptorSet set;
    VkPipelineLayout layout;
    VkPipeline pipeline;
} pn_gbuffer_pass;

// The targets the pass draws into (colour attachments in GENERAL layout, depth in DEPTH_ATTACHMENT).
typedef struct pn_gbuffer_targets {
    const pn_gpu_image *p, *n, *albedo, *depth;
    uint32_t width, height;
    // The renderer's warm-up frame: fragments only in the first PN_WORKGROUP-square tile (the
    // scissor), the same ones the frame itself writes there; the whole image is still cleared.
    bool one_tile;
} pn_gbuffer_targets;

// Uploads the scene and creates the pipeline. All or nothing; logs the reason on failure.
pn_result pn_gbuffer_pass_create(pn_gpu_device *dev, const pn_scene *scene, pn_gbuffer_pass *out);
void pn_gbuffer_pass_destroy(pn_gpu_device *dev, pn_gbuffer_pass *g);

// The scene's vertices [first, first + count) moved (pn_scene_move_object): copies them to the pass's
// vertex buffer and takes the scene's new bounds for the clip planes. Indices, draws and materials
// stay. The queue must be idle.
pn_result pn_gbuffer_pass_update_vertices(pn_gpu_device *dev, pn_gbuffer_pass *g, const pn_scene *scene,
                                          uint32_t first, uint32_t count);

// The pass's SPIR-V (stage 0: vertex, 1: fragment) and its size in bytes: what a cache of rendered
// images keys on (apps/bench/bench_reference.c), since these shaders place P and N.
const uint32_t *pn_gbuffer_pass_spirv(int stage, size_t *size);

// The camera as the pass's push constants for an image of width x height: view-projection with
// clip planes around the scene's bounding sphere, eye and view direction.
pn_gbuffer_push pn_gbuffer_camera(const pn_gbuffer_pass *g, const pn_camera *cam, uint32_t width, uint32_t height);

// Whether draw `draw` culls its back faces seen by `camera` (gbuffer_cull.h).
bool pn_gbuffer_pass_culls(const pn_gbuffer_pass *g, uint32_t draw, const pn_gbuffer_push *camera);

// Records the draws, with the targets' barriers: before, after any earlier access (their contents
// are discarded); after, for reads by compute shaders in GENERAL layout.
void pn_gbuffer_pass_record(VkCommandBuffer cmd, const pn_gbuffer_pass *g, const pn_gbuffer_targets *t,
                            const pn_gbuffer_push *camera);
