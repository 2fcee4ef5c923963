// What describes one frame, shared by the renderer and its passes: size, shadow configuration and
// the acceleration structures the mode reads; and what a frame gives back.
#pragma once
#include <math.h>
#include "gpu/exact_pools.h"
#include "gpu/pools.h"
#include "gpu/shadow_modes.h"
#include "gpu/tlas.h"

// What follows the shadow pass. none: V is the pixel's own samples' visible fraction. interleaved:
// the pixels of each tile_w x tile_h tile share the light's strata (each traces spp of the tile's
// spp * tile_w * tile_h samples), and a filter pass averages V over the tile around each pixel
// across neighbours on the pixel's own surface (filter.comp); the pixel's own V is kept (v_raw).
// penumbra: interleaved, then a separable Gaussian as wide as the penumbra the pixel's nearest
// blocker casts, narrowing as samples grow (penumbra_filter.comp).
typedef enum pn_filter { PN_FILTER_NONE, PN_FILTER_INTERLEAVED, PN_FILTER_PENUMBRA } pn_filter;
#define PN_FILTER_LAST PN_FILTER_PENUMBRA
extern const char *const pn_filter_names[];

// How a pixel's rays are shared among the frame's lights. even: spp rays for every light.
// budget: spp x lights rays per pixel in all (as many as even), given to each light by its share of
// the pixel's unshadowed irradiance, at least one to each light that reaches the pixel (budget_rays
// in shadow_frame.glsl). A pixel's count then varies per light, so budget draws its samples from
// a digitally shifted Sobol' sequence rather than a grid, and works without interleaving (filter none) or ray dumps.
typedef enum pn_split { PN_SPLIT_EVEN = PN_SPLIT_EVEN_ID, PN_SPLIT_BUDGET = PN_SPLIT_BUDGET_ID } pn_split;
extern const char *const pn_split_names[];

// Zero-initialised means: mode none, per-ray traversal, stratified sampler, seed 0; width, height and spp
// must be set (apps/render_opts.c fills one from the command line).
typedef struct pn_renderer_desc {
    uint32_t width, height;
    pn_shadow_mode mode;
    pn_traversal traversal;
    pn_sampler sampler;
    uint32_t spp;  // shadow rays per pixel (adaptive: at most)
    // Adaptive sampling (--spp MIN:MAX, adaptive_decide in shadow_frame.glsl): 0, or the first
    // round's samples MIN, with spp = MIN x 2^k; each further round doubles the samples of the
    // pixels whose V's standard error is still pixel_error or more. Draws each pixel's samples from
    // a Sobol' sequence (as the budgeted split does): even split, no interleaving, no ray dump.
    uint32_t spp_min;
    float pixel_error;
    uint32_t seed; // fixes the stratified jitter
    pn_filter filter;
    uint32_t tile_w, tile_h; // the interleaving tile and filter window (with filter; 0 means 3)
    pn_split split;          // with several lights (stratified sampler, no filter, no ray dump for budget)
    const pn_gpu_pools *pools; // the uploaded N-tree, for the modes whose needs.tree is set
    const struct pn_gpu_objects *objects; // or the per-object trees (gpu/pools.h), for needs.tree
    double leaf_size;          // edge of a leaf cell of that tree, world units (per-object trees:
                               // the finest tree's leaf extent along a world axis, pn_objects.leaf_size)
    const pn_gpu_exact_pools *exact; // triangles, BVH and candidate lists, for needs.exact_pools (as
                                     // pn_shadow_needs_for_scene gives them)
    uint32_t cand_first_node;        // pn_ntree.cand_first_node of the tree behind `pools`
    const pn_gpu_tlas *tlas;         // the device-built structure, for needs.tlas (gpu/tlas.h)
    bool dump_rays; // keep every shadow ray for pn_renderer_ray_dump
    bool count_work; // a build of the shadow shader that counts its work (pn_renderer_work); slower
    // No warm-up frame (renderer.c): a frame whose pipelines have not run yet carries their first
    // run in its passes' times, and reports only their creation as compile_ms. For a renderer that
    // draws frame after frame (the demo), where one slow frame after a switch is what is seen
    // anyway and an extra submission per switch only costs.
    bool no_warm_up;
    // With the penumbra filter: keep V as the interleaved filter's window left it, the Gaussian's
    // input (pn_frame_images.v_window; render --aovs writes it as shadow.V_window), and the nearest
    // blockers the window read (pn_frame_images.blockers), so that both the window and the
    // Gaussian can be checked against recomputations (tests/filter_oracle.h, penumbra_oracle.h).
    // Two more image copies per frame, inside the filter's time, and 12 bytes a pixel more of the
    // readback buffer: off unless asked for.
    bool keep_window;
    // V where none of a pixel's samples carries light (below its horizon, behind a one-sided
    // light): false, the convention 1 that render and the filters read (the radiance there is 0
    // anyway); true, 0, the library's V (engine/api/penumbra.h: the fraction of the samples above
    // the horizon that reach the point, 0 where none is), for which nothing is filtered.
    bool unreached_zero;
} pn_renderer_desc;

// A tile edge as the passes use it: 0 (unset) means 3, the thesis' 3 x 3.
static inline uint32_t pn_filter_tile(uint32_t edge) { return edge ? edge : 3; }

// A pixel's footprint per unit of view depth, 2 tan(yfov / 2) / height: what the filters take a
// pixel's world size to be (FilterPush.pixel_angle).
static inline double pn_pixel_angle(double yfov_deg, uint32_t height)
{
    return 2.0 * tan(0.5 * yfov_deg * 3.14159265358979323846 / 180.0) / height;
}

typedef struct pn_frame_times {
    double gbuffer_ms, shadow_ms, filter_ms, shade_ms; // GPU time per pass, from timestamp queries (filter
                                                       // 0 without one)
    // Wall-clock time this frame spent readying pipelines before it ran, kept out of the passes'
    // times: creating those it lacked (the renderer's own, on its first frame) and their first run,
    // over one tile (renderer.c: warm_up), where a driver that compiles lazily (llvmpipe: at the
    // first dispatch, 1.3 s of a cold cache's first shadow pass) does its compiling. 0 once warm.
    double compile_ms;
} pn_frame_times;

// The frame's images after pn_renderer_render, in the renderer's host-visible readback buffer.
// All are width*height pixels, row 0 at the top; background pixels are all zero.
typedef struct pn_frame_images {
    const float *p;        // rgba: world position, w = 1 where geometry is
    const float *n;        // rgba: unit normal facing the viewer, w = view depth
    const float *albedo;   // rgba: linear albedo, w = 1 where geometry is
    const float *v;        // one float: visibility of the light, 0..1 (filtered, with a filter)
    const float *v_raw;    // with a filter: the shadow pass's V before it; NULL without
    // The shadow pass's samples per pixel (rgba, of the frame's last light): visible, valid (above
    // the horizon and in front of the light; V = visible / valid, 1 without one), whether any of
    // the light lies above the horizon and in front (1 wherever valid > 0), and the float bits of
    // the penumbra width at the pixel's mean blocker (world units; FLT_MAX where no ray was
    // blocked, 0 for a point light's blocked rays and on the background).
    const uint32_t *counts;
    // Adaptive sampling (desc.spp_min): per pixel (of the frame's last light) the samples it took,
    // the float bits of the standard error of its V_raw (adaptive_decide), whether it stopped
    // before the most, and a zero; NULL where that light was not sampled adaptively (a point
    // light, mode none, or no spp_min).
    const uint32_t *rays;
    const float *radiance; // rgba: linear HDR outgoing radiance, alpha = coverage
    // With the penumbra filter: per pixel (rg, of the frame's last light) V after the Gaussian's
    // row pass and the footprint, its standard deviation in pixels (below 0.5: V is the
    // interleaved filter's); NULL with another filter.
    const float *footprint;
    // With the penumbra filter and desc.keep_window: V before its Gaussian, as the interleaved
    // filter's window left it (of the frame's last light); NULL otherwise.
    const float *v_window;
    // With the penumbra filter and desc.keep_window: per pixel (rg, of the frame's last light) the
    // nearest blocker's segment parameter t and the penumbra width it casts (world units;
    // PN_PENUMBRA_NONE where no ray was blocked), as the window read them; NULL otherwise.
    const float *blockers;
    // With the temporal history (pn_renderer_set_history): per pixel (rgba, of the frame's last
    // light) the history's sums of visible and valid samples over the frames, this frame's
    // included (floats: V_raw = [0] / [1], [1] the samples behind it), and the counts' z and w as
    // uint bits; NULL without.
    const float *history;
    // Per light of the frame (pn_renderer_render_lights): its V and V_raw as above; v and v_raw are
    // light 0's.
    uint32_t light_count;
    const float *v_light[PN_MAX_LIGHTS], *v_raw_light[PN_MAX_LIGHTS];
} pn_frame_images;
