// One frame of penumbra: G-buffer raster pass, shadow compute pass, filter compute pass (with a
// filter), shading compute pass, readback (renderer_frame.c records them in that order; each pass is its own file). Shared by render,
// demo and bench.
#pragma once
#include "gpu/frame.h"
#include "gpu/gbuffer_pass.h"
#include "gpu/filter_pass.h"
#include "gpu/gbuffer_upload.h"
#include "gpu/history_pass.h"
#include "gpu/penumbra_pass.h"
#include "gpu/resources.h"
#include "gpu/shade_pass.h"
#include "gpu/shadow_pass.h"
#include "scene/scene.h"
#include "scene/view.h"

typedef struct pn_renderer {
    pn_gpu_device *dev;
    uint32_t width, height;
    pn_renderer_desc desc;
    // The frame's images. The shadow pass writes v_raw; with a filter, the filter pass writes v from
    // it, and the shading pass reads v; without, the shading pass reads v_raw, and v is unused.
    pn_gpu_image p, n, albedo, depth, v_raw, v, radiance;
    pn_gpu_buffer readback;                        // host-visible copies of them (pn_frame_images)
    pn_gbuffer_pass gbuffer;
    pn_gbuffer_upload upload; // pn_renderer_set_gbuffer's P and N, replacing the G-buffer pass
    pn_shadow_pass shadow;
    pn_filter_pass filter;
    pn_penumbra_pass penumbra; // the penumbra filter's stages after `filter` (filter penumbra)
    pn_shade_pass shade;
    VkQueryPool timestamps;
    VkCommandBuffer cmd;
    uint32_t light_count; // of the last frame
    bool rays_written;    // its last light was sampled adaptively: the shadow pass's rays image holds it
    // pn_renderer_set_continue: the next frame continues the last one's adaptive samples; the
    // most samples a pixel of the last frame could take, where that frame can be continued (one
    // light, sampled adaptively), else 0, with its first round and seed (a frame with others is
    // one of its own); and whether the last frame did continue the one before.
    bool continue_next;
    uint32_t continuable_spp, continuable_spp_min, continuable_seed;
    uint32_t continuable_tile; // the first round's interleaved tile (w << 8 | h; 0: none, no filter)
    bool resumed;
    // Pipelines not run yet (at creation, after pn_renderer_set_filter, or when the shadow pass made
    // one): the next frame first runs over one tile (warm_up), and reports that and
    // compile_pending_ms (their creation) as its compile_ms. shadow_made: pipelines_made when warm.
    bool cold;
    double compile_pending_ms;
    uint32_t shadow_made;
    // The temporal history (pn_renderer_set_history): off while history_frames is 0. What the next
    // frame reprojects and compares with: the last frame's camera (its G-buffer push), pixel angle
    // and lights, whether there was one (history_prev), whether it is to be forgotten
    // (pn_renderer_history_drop), and the boxes of what moved since (pn_renderer_history_moved).
    pn_history_pass history;
    uint32_t history_frames;
    bool history_prev, history_drop;
    pn_gbuffer_push history_camera;
    float history_angle;
    pn_light_gpu history_lights[PN_MAX_LIGHTS];
    uint32_t history_light_count;
    pn_history_boxes history_boxes;
    uint32_t history_frame; // the next frame's number (pn_renderer_set_history_frame)
} pn_renderer;

// Uploads the scene and creates targets and pipelines as `desc` says.
pn_result pn_renderer_create(pn_gpu_device *dev, const pn_scene *scene, const pn_renderer_desc *desc,
                             pn_renderer *out);
void pn_renderer_destroy(pn_renderer *r);

// The scene's vertices [first, first + count) moved (pn_scene_move_object, the demo's live moves):
// copies them to the G-buffer pass and takes the scene's new bounds for what the renderer derives
// from them at create (clip planes, the shadow rays' origin offset scene_mag), so that the next
// frame is the frame a renderer created on the moved scene would draw. The shadow pass's pools are
// the caller's to update (per-object trees: pn_objects_update, pn_gpu_objects_update).
pn_result pn_renderer_update_vertices(pn_renderer *r, const pn_scene *scene, uint32_t first, uint32_t count);

// The leaf extent the shadow rays rise by (pn_renderer_desc.leaf_size) from the next frame on: per-
// object trees whose instances turned or scaled (pn_objects_update's leaf_size). Another extent
// drops the temporal history (every pixel's rays rise otherwise).
void pn_renderer_set_leaf_size(pn_renderer *r, double leaf_size);

// Records, submits and waits for one frame; fills `times` and leaves the images readable through
// pn_renderer_images until the next call.
pn_result pn_renderer_render(pn_renderer *r, const pn_camera *camera, const pn_light *light, pn_frame_times *times);

// The same with 1..PN_MAX_LIGHTS lights: one G-buffer, then per light the shadow pass, the filter
// and the shading pass, which adds the light's term to the radiance (the sum over the lights of
// albedo / pi x exact irradiance x V x radiance). Every light gets the same samples it would get
// alone (same seed), so a frame of several lights is the sum of their single-light frames. The
// times are summed over the lights. PN_ERR_INVALID, logged, for another count.
pn_result pn_renderer_render_lights(pn_renderer *r, const pn_camera *camera, const pn_light *lights,
                                    uint32_t light_count, pn_frame_times *times);

// The last frame's images in the readback buffer (pn_frame_images), valid until the next frame,
// pn_renderer_set_filter or pn_renderer_set_history (which move the planes: the penumbra filter's
// window and the history's counts are kept only with them).
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
// The shadow structures built anew for the same scene and mode (a move: the API rebuilds the
// BVH, the tree or the device's acceleration structure): `accel`'s pools, objects, exact, tlas,
// leaf_size and cand_first_node (pn_shadow_accel_bind) replace the renderer's, and the scene's
// bounds give the rays' offsets again (scene_mag). No pipeline, image or buffer is made: the
// shadow pass reads the structures by the addresses it writes each frame, and the acceleration
// structure's descriptor is rewritten here (the queue is idle between frames).
void pn_renderer_set_accel(pn_renderer *r, const pn_scene *scene, const pn_renderer_desc *accel);

// The temporal history (V at a surface point does not depend on the camera): with frames > 0, each
// frame adds its samples to those its pixels' surface points gathered in earlier frames, found
// through the last frame's camera (a moved camera's pixels show other points), and the filters
// and the shading read V over all of them; the sums hold at most `frames` frames' samples (older
// ones weigh less past that: an exponential window). A pixel drops its history where the surface
// it shows was not in the last frame (uncovered, off its image), where geometry moved since
// (pn_renderer_history_moved) within the pyramid from its point to a light, and for a light that
// changed (position, size, kind, radiance): every light keeps a history of its own, as many as the
// frame has. Each frame draws its own samples: consecutive frames take the strata of a window of
// frames (pn_renderer_set_history_frame). 0 turns it off; a change of `frames` keeps what there is.
// pn_frame_images.history has the sums. PN_ERR_INVALID, logged, over PN_HISTORY_MAX_FRAMES.
#define PN_HISTORY_MAX_FRAMES 4096
pn_result pn_renderer_set_history(pn_renderer *r, uint32_t frames);
// The next frame's number in its sequence (then one more per frame): with the history, frames
// share the strata of a window of consecutive frames (light_sample's frame window), so a sequence
// rendered in parts (render --shard) numbers them as the whole does. The seed stays from frame to
// frame under the history; the window's strata draw a frame's samples anew.
void pn_renderer_set_history_frame(pn_renderer *r, uint32_t frame);
// The next frame starts every light's history afresh (a cut, a new scene state).
void pn_renderer_history_drop(pn_renderer *r);
// Geometry within the box [lo, hi] changed since the last frame (an object moved: give its box
// before and after, or one box round both): the next frame drops the history of every pixel whose
// pyramid to a light meets it. More than PN_HISTORY_MAX_BOXES boxes in a frame are merged into one.
void pn_renderer_history_moved(pn_renderer *r, const double lo[3], const double hi[3]);

// Changes the filter and its tile from the next pn_renderer_render on (the bench's filter axis
// steps through them over one tree). tile_w, tile_h: 0 means 3; otherwise 1..PN_FILTER_MAX_TILE.
// PN_ERR_INVALID, logged, outside that.
pn_result pn_renderer_set_filter(pn_renderer *r, pn_filter filter, uint32_t tile_w, uint32_t tile_h);

// Changes the light samples per pixel from the next pn_renderer_render on (the bench's spp axis and
// --quality auto's pilots step through them without new pipelines). With desc.dump_rays, spp may not
// exceed the desc's (the dump's buffer holds that many rays per pixel): PN_ERR_INVALID, logged.
pn_result pn_renderer_set_spp(pn_renderer *r, uint32_t spp);
// Changes the samples per pixel to adaptive rounds from spp_min up to spp (desc.spp_min; spp_min 0:
// spp for every pixel) from the next pn_renderer_render on.
pn_result pn_renderer_set_adaptive(pn_renderer *r, uint32_t spp_min, uint32_t spp, float pixel_error);
// Progressive refinement by adaptive samples (the demo's accumulation): with `on`, the next frame
// continues the samples of the one before instead of drawing its own, where that one sampled its
// one light adaptively and this one raises the most samples (pn_renderer_set_adaptive): every
// pixel keeps its counts, and the rounds go on from them under the new pixel error and most, so
// rays go only to the pixels still uncertain. A frame with another seed or first round is one of
// its own; the caller keeps the camera, light and scene as they were (else the counts are another
// picture's). Otherwise the frame is one of its own. pn_renderer.resumed tells which it was.
void pn_renderer_set_continue(pn_renderer *r, bool on);

// PN_OK if desc's split goes with its filter, sampler and ray dump; else logs why (the command
// lines check it before any set-up, as a usage error).
pn_result pn_renderer_check_split(const pn_renderer_desc *desc);

// Changes how the rays are shared among several lights from the next frame on (the bench's --lights
// rows time both splits on one set-up). Budget needs filter none, the stratified sampler and no ray
// dump: PN_ERR_INVALID, logged, otherwise.
pn_result pn_renderer_set_split(pn_renderer *r, pn_split split);

// Turns the ray dump off and on again from the next frame on (a renderer created with dump_rays;
// on: spp at most the desc's). The bench times exact without it and dumps one more frame for Embree.
pn_result pn_renderer_set_dump_rays(pn_renderer *r, bool on);

// With desc.dump_rays, after a frame: per pixel, the ray origin (xyz; w = 1 where geometry is),
// then per pixel and light sample the sample point (xyz) and flags in w's bits (bit 0: valid, the
// sample carries light; bit 1: blocked). NULL without dump_rays. Modes exact, hybrid and exact-ls.
const float *pn_renderer_ray_dump(const pn_renderer *r, uint64_t *floats);
