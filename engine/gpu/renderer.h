// One frame of penumbra: G-buffer raster pass, shadow compute pass, shading compute pass,
// readback. Shared by render, demo and bench.
#pragma once
#include "gpu/compute.h"
#include "gpu/exact_pools.h"
#include "gpu/pools.h"
#include "gpu/resources.h"
#include "scene/scene.h"
#include "scene/view.h"

typedef enum pn_shadow_mode {
    PN_SHADOW_NONE = 0,      // V = 1: unshadowed
    PN_SHADOW_LINESPACE = 1, // line-space visibility (shaders/glsl/shadow_linespace.comp)
    PN_SHADOW_HYBRID = 2,    // line spaces, and the triangles exactly where the ray starts and ends
    PN_SHADOW_EXACT_LS = 3,  // line spaces skip empty space; set shafts test their triangles exactly
    PN_SHADOW_EXACT = 4,     // BVH and watertight triangle tests (shaders/glsl/shadow_exact.comp)
} pn_shadow_mode;

typedef enum pn_traversal { PN_TRAVERSAL_PACKET = 0, PN_TRAVERSAL_RAY = 1 } pn_traversal;
typedef enum pn_sampler { PN_SAMPLER_GRID = 0, PN_SAMPLER_STRATIFIED = 1 } pn_sampler;

typedef struct pn_renderer_desc {
    uint32_t width, height;
    pn_shadow_mode mode;
    pn_traversal traversal;
    pn_sampler sampler;
    uint32_t spp;  // shadow rays per pixel
    uint32_t seed; // fixes the stratified jitter
    const pn_gpu_pools *pools; // the uploaded N-tree, for the line-space modes
    double leaf_size;          // edge of a leaf cell of that tree, world units
    const pn_gpu_exact_pools *exact; // triangles, BVH and candidate lists, for the exact tests
    uint32_t cand_first_node;        // pn_ntree.cand_first_node of the tree behind `pools`
    bool dump_rays; // keep every shadow ray for pn_renderer_ray_dump
    bool count_work; // a build of the shadow shader that counts its work (pn_renderer_work); slower
} pn_renderer_desc;

// Light samples the shadow pass traces per pixel for spp: one for a point light, whose samples all
// coincide (the first decides V), else spp. Shadow rays per second count these.
uint32_t pn_shadow_samples(uint32_t spp, const pn_light *light);

// The light-sample grid for spp rays: grid_u * grid_v == spp with grid_u the largest divisor of
// spp not above its square root (a square grid when spp is a square).
void pn_sample_grid(uint32_t spp, uint32_t *grid_u, uint32_t *grid_v);

typedef struct pn_frame_times {
    double gbuffer_ms, shadow_ms, shade_ms; // GPU time per pass, from timestamp queries
} pn_frame_times;

// The frame's images after pn_renderer_render, in the renderer's host-visible readback buffer.
// All are width*height pixels, row 0 at the top; background pixels are all zero.
typedef struct pn_frame_images {
    const float *p;        // rgba: world position, w = 1 where geometry is
    const float *n;        // rgba: unit normal facing the viewer, w = view depth
    const float *albedo;   // rgba: linear albedo, w = 1 where geometry is
    const float *v;        // one float: visibility of the light, 0..1
    const float *radiance; // rgba: linear HDR outgoing radiance, alpha = coverage
} pn_frame_images;

typedef struct pn_renderer {
    pn_gpu_device *dev;
    uint32_t width, height;
    pn_renderer_desc desc;
    pn_gpu_buffer shadow_params; // uniform buffer of the shadow pass
    pn_gpu_buffer ray_dump;      // with desc.dump_rays
    pn_gpu_buffer gbuffer_upload; // pn_renderer_set_gbuffer's P and N
    pn_gpu_buffer work;           // with desc.count_work
    pn_gpu_buffer shadow_status; // host-visible flag: a shadow dispatch ran out of llvmpipe's loop budget
    pn_gpu_image counts;         // (visible, valid) sample counts between shadow chunks
    uint32_t chunk;              // light samples per shadow dispatch (halved when a dispatch is cut short)
    float scene_min[3], scene_max[3]; // for the clip planes

    pn_gpu_buffer vertices, indices, materials;
    pn_gpu_image *textures; // at least one (a white texel when the scene has none)
    uint32_t texture_count;
    VkSampler sampler;
    pn_draw *draws;
    uint32_t draw_count;

    pn_gpu_image p, n, albedo, depth, v, radiance;
    pn_gpu_buffer readback;

    VkDescriptorPool descriptor_pool;
    VkDescriptorSetLayout gbuffer_set_layout;
    VkDescriptorSet gbuffer_set;
    VkPipelineLayout gbuffer_layout;
    VkPipeline gbuffer_pipeline;
    pn_gpu_compute shadow, shade;
    VkQueryPool timestamps;
    VkCommandBuffer cmd;
} pn_renderer;

// Uploads the scene and creates targets and pipelines as `desc` says.
pn_result pn_renderer_create(pn_gpu_device *dev, const pn_scene *scene, const pn_renderer_desc *desc,
                             pn_renderer *out);
void pn_renderer_destroy(pn_renderer *r);

// Records, submits and waits for one frame; fills `times` and leaves the images readable through
// pn_renderer_images until the next call.
pn_result pn_renderer_render(pn_renderer *r, const pn_camera *camera, const pn_light *light, pn_frame_times *times);

void pn_renderer_images(const pn_renderer *r, pn_frame_images *out);

// With desc.count_work, after a frame: per pixel 4 counts over all its shadow rays: nodes visited
// (N-tree or BVH), line-space lookups, triangle tests, deepest stack reached. NULL otherwise.
const uint32_t *pn_renderer_work(const pn_renderer *r);

// Shader-level benchmarking: the following frames skip the raster pass and use this G-buffer
// instead (P and N as width*height RGBA floats as pn_frame_images has them, P.w = 1 where
// geometry is; albedo black). NULL for both restores the raster pass.
pn_result pn_renderer_set_gbuffer(pn_renderer *r, const float *p, const float *n);

// Changes the stratified sampler's seed from the next pn_renderer_render on: the demo's progressive
// refinement takes new light samples every frame without recreating the renderer.
void pn_renderer_set_seed(pn_renderer *r, uint32_t seed);

// With desc.dump_rays, after a frame: per pixel, the ray origin (xyz; w = 1 where geometry is),
// then per pixel and light sample the sample point (xyz) and flags in w's bits (bit 0: valid, the
// sample carries light; bit 1: blocked). NULL without dump_rays. Modes exact, hybrid and exact-ls.
const float *pn_renderer_ray_dump(const pn_renderer *r, uint64_t *floats);
