// The shadow pass: one compute invocation per pixel traces the pixel's shadow rays to the light
// with the mode's shader (shadow_modes.c) and writes V, the visible fraction of the light samples.
// Light samples run in chunks of at most PN_MAX_CHUNK per dispatch, counts accumulating between them.
// Driver workarounds here and in the shadow shaders (llvmpipe's loop budget, its cost model) are
// collected in engine/gpu/llvmpipe.md: read it before tuning for another device.
#pragma once
#include "gpu/compute.h"
#include "gpu/frame.h"
#include "gpu/raytrace.h"
#include "gpu/resources.h"
#include "scene/view.h"

enum { PN_PACKET_RAY_SIZES = 6 }; // 1, 2, 4 .. PN_MAX_CHUNK (32) rays
enum { PN_PROJECT_SIZES = 6 };     // 32, 64 .. PN_PROJECT_MAX_SAMPLES (1024) samples

typedef struct pn_shadow_pass {
    const pn_shadow_mode_info *mode;
    pn_gpu_compute compute; // its pipeline is the one for PN_MAX_CHUNK rays (none for a ray_pipeline mode)
    // A mode with ray_pipeline (rtpipeline): its pipeline, traced with compute's set and pushes.
    pn_gpu_ray_pipeline ray;
    // The stage its shaders run in: compute, or ray tracing for ray_pipeline. The pass's barriers
    // name it, and bridge to compute at its ends (pn_shadow_pass_record), so the passes around it
    // see a compute pass whatever the mode.
    VkPipelineStageFlags2 stage;
    // The compute modes' pipelines, the device's, each made when a frame first needs it
    // (pn_shadow_pass_prepare), from spec_data but for what the slot says; [u]: for uniform frames
    // (u 1: PN_SPEC_UNIFORM, `uniform` below) or any (u 0). own[u]: the mode's shader (a mode with
    // packet_rays under packet traversal: for PN_MAX_CHUNK rays; --traversal project: for
    // PN_PROJECT_MAX_SAMPLES). A mode with packet_rays under packet traversal: by_rays[u][k] for at
    // most 2^k rays of a pixel per dispatch. The projection traversal: by_samples[u][k] for at most
    // 32 x 2^k samples (its per-sample arrays), from shadow_project.comp. A dispatch takes the
    // smallest that fits. The ray-tracing pipeline (ray) is made with the pass, for any frame.
    VkPipeline own[2];
    VkPipeline by_rays[2][PN_PACKET_RAY_SIZES];
    VkPipeline by_samples[2][PN_PROJECT_SIZES];
    int32_t spec_data[7];
    // This frame's lights are all sampled uniformly (spp_min 0) under the even split, so no
    // dispatch has rounds, lists or decisions: its pipelines are the uniform ones (pn_shadow_pass_update).
    bool uniform;
    bool sized_rays;
    bool project;      // --traversal project: every frame by projection (exact)
    bool auto_project; // --traversal auto, exact: frames of PN_PROJECT_AUTO_SAMPLES samples and more
    uint32_t project_chunk; // samples per dispatch of the projection (PN_PROJECT_MAX_SAMPLES; llvmpipe halves it)
    const uint32_t *spirv; // the shadow shader: the mode's, or for project shadow_project.comp
    size_t spirv_size;
    pn_gpu_buffer params;   // uniform ShadowParams, host-written between frames
    pn_gpu_buffer status;   // llvmpipe: host-visible flag, a dispatch ran out of the loop budget
    pn_gpu_buffer ray_dump; // with desc.dump_rays
    pn_gpu_buffer work;     // with desc.count_work
    pn_gpu_image counts;    // (visible, valid) sample counts between chunks; after the last, with
                            // whether the light reaches above the horizon and the penumbra width
                            // (the filter reads them; pn_frame_images.counts)
    pn_gpu_image adapt;     // per pixel: the counts over the first half of its samples, the blocked
                            // rays' summed t, its samples so far (PN_SHADOW_BINDING_ADAPT)
    pn_gpu_image rays;      // adaptive sampling: per pixel its samples and V's standard error
    pn_gpu_image blockers;  // per pixel: the nearest blocker (t), then the penumbra width it casts
                            // (PN_SHADOW_BINDING_BLOCKERS; the penumbra filter reads it)
    pn_gpu_buffer lists;    // adaptive sampling: the pixel lists of its rounds (PN_SHADOW_BINDING_LISTS)
    VkImageView lineage_view; // what PN_SHADOW_BINDING_LINEAGE holds (pn_shadow_pass_set_lineage)
    uint32_t tiles_across, tile_total; // PN_WORKGROUP-square tiles across the image, and in all
    uint32_t width, height;
    uint32_t spp_min; // adaptive sampling's first round (desc.spp_min at the last update), 0: off
    // Adaptive sampling continued from the previous frame (pn_renderer_set_continue): that frame's
    // most samples (its spp); the next record keeps every pixel's counts and resumes the rounds
    // from them. 0: a frame of its own. Set by the renderer, only where the frame samples adaptively
    // with more samples than that.
    uint32_t resume_from;
    // The temporal history's frame window (light_sample): this frame's number and the side of the
    // window's split of a sub-cell (frame_side^2 parts; 0: no window) and the part the frame starts
    // from. The renderer's.
    uint32_t frame, frame_side, frame_part; // (pn_shadow_pass_set_frame)
    uint32_t dump_spp; // rays per pixel the ray dump holds (desc.dump_rays at create), else 0
    // Light samples per dispatch: PN_MAX_CHUNK, the size of the shader's per-ray arrays.
    // llvmpipe: halved whenever a dispatch runs out of the loop budget (pn_shadow_pass_end_frame);
    // a device without that budget keeps PN_MAX_CHUNK.
    uint32_t chunk;
    float scene_mag; // largest |coordinate| of the scene's bounds (ShadowParams.scene_mag)
    bool loop_budget; // llvmpipe: the device ends long-running shader loops; chunk and retry
    bool block_walk_off; // llvmpipe: the budget ran out once: each pixel walks alone (shadow_exact.comp)
    bool one_tile;    // the renderer's warm-up frame: dispatches over the first tile only (renderer.c)
    uint32_t pipelines_made; // by pn_shadow_pass_prepare so far: the renderer warms new ones up
} pn_shadow_pass;

// Light samples the shadow pass traces per pixel for spp: one for a point light, whose samples all
// coincide (the first decides V), else spp. Shadow rays per second count these.
uint32_t pn_shadow_samples(uint32_t spp, const pn_light *light);
// A budgeted split's rays per pixel over all `light_count` lights: as many as the even split's.
uint32_t pn_shadow_budget(uint32_t spp, uint32_t light_count);

// The samples one pixel's V is the mean of, as the filter's noise model counts them (FilterPush.samples):
// pn_shadow_samples, but 0 for a point light, whose V has no noise (every sample is the same ray).
uint32_t pn_filter_noise_samples(uint32_t spp, const pn_light *light);

// Shadow rays per second of a frame: every covered pixel traces pn_shadow_samples rays.
double pn_shadow_rays_per_s(uint64_t covered_pixels, uint32_t spp, const pn_light *light, double shadow_ms);

// The light-sample grid for spp rays: grid_u * grid_v == spp with grid_u the largest divisor of
// spp not above its square root (a square grid when spp is a square).
void pn_sample_grid(uint32_t spp, uint32_t *grid_u, uint32_t *grid_v);

// Creates the mode's pipeline and buffers; p, n (read) and v (written) are the frame's images.
// scene_mag: the largest |coordinate| of the scene's bounds, which bounds every vertex's (shadow_origin).
// alpha_masks: the scene has alpha-masked casters (the pipeline's alpha tests, PN_SPEC_ALPHA).
pn_result pn_shadow_pass_create(pn_gpu_device *dev, const pn_renderer_desc *desc, const pn_gpu_image *p,
                                const pn_gpu_image *n, const pn_gpu_image *v, float scene_mag, bool alpha_masks,
                                pn_shadow_pass *out);
void pn_shadow_pass_destroy(pn_gpu_device *dev, pn_shadow_pass *s);
// The temporal history's lineage image (pn_history_pass.lineage: which pixel's samples each pixel
// draws), or NULL for none. The queue idle: the set is rewritten.
void pn_shadow_pass_set_lineage(pn_gpu_device *dev, pn_shadow_pass *s, const pn_gpu_image *lineage);

// The temporal history's frame window for frame `frame` of a history of `history_frames` frames (0:
// none) under an interleaving tile of `tile_pixels` pixels: consecutive frames share the strata of
// a window of them (light_sample): each sub-cell in side x side parts, side the smallest power of
// two with side^2 at least the history's frames (so that its frames take other parts), at most 64;
// under an even tile the part steps by one more every T frames.
void pn_shadow_pass_set_frame(pn_shadow_pass *p, uint32_t history_frames, uint32_t frame, uint32_t tile_pixels);

// Writes the frame's parameters (its 1..PN_MAX_LIGHTS lights, samples, pools, the camera's pixel
// angle: pn_pixel_angle); the queue must be idle.
void pn_shadow_pass_update(pn_shadow_pass *s, const pn_renderer_desc *desc, const pn_light_gpu *lights,
                           uint32_t light_count, float pixel_angle);

// After pn_shadow_pass_update, for each light's `samples` (pn_shadow_samples): makes the pipelines
// its dispatches want that are not made yet, for this frame's uniform flag (own, by_rays,
// by_samples; nothing for the ray-tracing pipeline, made with the pass).
pn_result pn_shadow_pass_prepare(pn_gpu_device *dev, pn_shadow_pass *s, uint32_t samples);

// Whether a light of `samples` samples per pixel (pn_shadow_samples) is sampled adaptively:
// rounds from desc.spp_min up to `samples` (a point light's single sample never is).
bool pn_shadow_adaptive(const pn_shadow_pass *s, uint32_t samples);

// Checks desc's samples: adaptive sampling with spp_min 0, or spp = spp_min x 2^k with the even
// split, no ray dump, the stratified sampler, and pixel_error >= 0; the projection traversal only
// for exact and uniform samples (logs and returns PN_ERR_INVALID otherwise).
pn_result pn_shadow_check_samples(const pn_renderer_desc *desc);

// --traversal project: the triangles a pixel's walk may test per sample before its remaining
// samples are traced as rays (ShadowParams.project_budget; env PN_PROJECT_BUDGET overrides it).
#define PN_PROJECT_BUDGET_DEFAULT 1.0f
float pn_project_budget(void);

// Records the dispatches of `samples` samples per pixel (pn_shadow_samples) of light `light` (an
// index into the lights of pn_shadow_pass_update) after P and N are ready; V is written when the
// last one ends; adaptively, the rounds with a decision after each (the last one's gives the final
// error estimate). Every light's samples are the same function of the seed and the pixel, so a light
// sees the same samples alone as among others. With resume_from, adaptively, the rounds go on from
// the counts the previous frame left (the same pixels, light and seed), starting with a decision
// over the whole image under this frame's pixel error and most samples.
void pn_shadow_pass_record(VkCommandBuffer cmd, const pn_shadow_pass *s, uint32_t samples, uint32_t light);

// Before a submit: clears the status flag. After it: PN_OK, with *retry set if a dispatch was cut
// short and the chunk was halved (record and submit the frame again); PN_ERR_UNSUPPORTED, logged,
// if not even one sample per dispatch fits.
// llvmpipe: only there can a dispatch be cut short (pn_gpu_device_loop_budget).
void pn_shadow_pass_begin_frame(pn_shadow_pass *s);
pn_result pn_shadow_pass_end_frame(pn_shadow_pass *s, bool *retry);
