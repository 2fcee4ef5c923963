// The filter pass (--filter interleaved): V averaged over the interleaved-sampling tile around each
// pixel, across neighbours on the pixel's own surface only (shaders/glsl/filter.comp). Reads the
// shadow pass's V (v_raw) and sample counts (which pixels have an estimate of V), writes the
// filtered V the shading pass reads. Under --filter penumbra it also reads the blocker bounds and
// writes the penumbra filter's footprints, marks and list of tiles (gpu/penumbra_pass.h: its images
// and list).
#pragma once
#include "gpu/compute.h"
#include "gpu/penumbra_pass.h"
#include "gpu/resources.h"
#include "interface.h"

typedef struct pn_filter_pass {
    pn_gpu_compute compute; // specialised for the window (PN_SPEC_TILE_W, PN_SPEC_TILE_H)
    uint32_t width, height;
    bool one_tile; // the renderer's warm-up frame: dispatch over the first tile only (renderer.c)
    uint32_t tile_w, tile_h; // the window: the tile of light_sample's interleaving
    VkImageView images[PN_FILTER_BINDING_COUNT]; // the set's, kept for a new window's pipeline
    VkBuffer list; // the set's PN_FILTER_BINDING_LIST: the penumbra pass's list of tiles
    bool temporal; // the counts are the temporal history's sums (PN_SPEC_FILTER_TEMPORAL)
} pn_filter_pass;

// tile_w, tile_h: 1..PN_FILTER_MAX_TILE.
pn_result pn_filter_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, uint32_t tile_w,
                                uint32_t tile_h, const pn_gpu_image *p, const pn_gpu_image *n,
                                const pn_gpu_image *v_raw, const pn_gpu_image *counts, const pn_gpu_image *blockers,
                                const pn_penumbra_pass *penumbra, const pn_gpu_image *v, pn_filter_pass *out);
void pn_filter_pass_destroy(pn_gpu_device *dev, pn_filter_pass *f);
// Another window: a pipeline specialised for it, made only when it changes. The device must be
// idle with respect to f (the old pipeline is destroyed); f is unchanged on failure.
pn_result pn_filter_pass_set_tile(pn_gpu_device *dev, pn_filter_pass *f, uint32_t tile_w, uint32_t tile_h);

// The counts the pass reads: the shadow pass's, or with `temporal` the history's sums
// (gpu/history_pass.h); a new pipeline and set where that changes. The device must be idle with
// respect to f; f is unchanged on failure.
pn_result pn_filter_pass_set_counts(pn_gpu_device *dev, pn_filter_pass *f, VkImageView counts, bool temporal);

// yfov_deg: the camera's vertical field of view, which with the height gives a pixel's footprint
// per unit of depth; samples: the shadow pass's light samples per pixel, which set the noise one
// pixel's V carries (adaptive: the first round's, MIN; a pixel's own valid rays count where more); narrow: 0, or under the penumbra filter pn_penumbra_window_scale, with which the
// window's weights fall as a Gaussian of the pixel's footprint (filter.comp), so that its 3 x 3
// average narrows as the samples grow, and the pass writes the penumbra filter's footprints to
// `sigma` (width_scale: its pn_penumbra_width_scale); sigma must then be in the GENERAL layout
// (pn_penumbra_pass_begin), as it must be for any dispatch of the pass.
void pn_filter_pass_record(VkCommandBuffer cmd, const pn_filter_pass *f, uint32_t samples, bool adaptive,
                           float yfov_deg, float narrow, float width_scale);
