// The penumbra filter (--filter penumbra): after the interleaved filter, a separable Gaussian as
// wide as the penumbra each pixel lies in, from the nearest blocker the shadow pass met
// (shaders/glsl/penumbra_filter.comp). The interleaved filter's pass writes each pixel's footprint,
// marks the 8 x 8 tiles with a blocker near and lists the 64 x 8 blocks that hold them
// (filter.comp); then two indirect dispatches over the listed blocks: the Gaussian along rows and
// along columns. Reads the G-buffer and the shadow pass's counts, and rewrites V (the interleaved
// filter's output) in place; leaves each pixel's footprint (the Gaussian's standard deviation in
// pixels) in `scratch`'s second channel for the EXR (0 outside the listed blocks).
#pragma once
#include "gpu/compute.h"
#include "gpu/resources.h"
#include "interface.h"

typedef struct pn_penumbra_pass {
    pn_gpu_compute compute;
    VkPipeline stages[PN_PENUMBRA_STAGES]; // the device's: a pipeline per stage (penumbra_filter.comp)
    uint32_t width, height;
    bool one_tile; // the renderer's warm-up frame: dispatch over the first tile only (renderer.c)
    pn_gpu_image sigma;   // rg32f: each pixel's own footprint (world units) and whether it lends its V
    pn_gpu_image scratch; // rg32f: the row pass's V and each pixel's footprint
    pn_gpu_image tiles;   // r32ui: per PN_PENUMBRA_BLOCK_W x _H block, a bit per tile with a blocker near
    pn_gpu_buffer list;   // the marked blocks (PN_TILE_LIST_*), the Gaussian's indirect dispatches
    uint32_t tiles_across, tiles_down;
    VkImageView images[PN_PENUMBRA_BINDING_COUNT]; // the set's, kept for pn_penumbra_pass_set_counts
    bool temporal; // the counts are the temporal history's sums (PN_SPEC_PENUMBRA_TEMPORAL)
} pn_penumbra_pass;

pn_result pn_penumbra_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, const pn_gpu_image *p,
                                  const pn_gpu_image *n, const pn_gpu_image *counts, const pn_gpu_image *v,
                                  pn_penumbra_pass *out);
void pn_penumbra_pass_destroy(pn_gpu_device *dev, pn_penumbra_pass *f);
// The counts the pass reads, as pn_filter_pass_set_counts (the device idle; f unchanged on failure).
pn_result pn_penumbra_pass_set_counts(pn_gpu_device *dev, pn_penumbra_pass *f, VkImageView counts, bool temporal);

// The Gaussian's standard deviation at one sample per pixel, in widths of the penumbra its nearest
// blocker casts (penumbra_filter.comp): 0.25; PN_PENUMBRA_WIDTH_SCALE overrides it (measurements).
// Measured since the window's edge rule and the narrowest neighbour's footprint (stop 54; bench,
// 512 x 512, exact, the five standard views, 1 / 2 / 4 spp, seeds 1 and 2, reference MAE and edge
// leak at 1 spp): against 0.35, the meshes' MAE within 0.0002 in every cell (the dragon's 4 spp
// 0.0057 -> 0.0055, seed 1), the canopy's 1 spp 0.0283 -> 0.0266 and 0.0279 -> 0.0261, and the
// edge leak lower on every view (seed 1: the bunny 0.86 -> 0.76%, the dragon 0.93 -> 0.76%; seed
// 2: 0.98 -> 0.85%, 0.96 -> 0.77%); 0.18 and 0.12 lose at 1 spp (the dragon 0.0127, 0.0134; the
// canopy 0.0286, 0.0338), 0.5 and 0.7 too, with the leak past 1% (the dragon 1.42%, 2.07%).
float pn_penumbra_width_scale(void);
// The interleaved filter's window under the penumbra filter: its weights fall as a Gaussian of this
// many widths of the nearest blocker's penumbra times n^-3/4 (pn_filter_pass_record's narrow;
// filter.comp), the penumbra taken as at least a pixel wide (since stop 56). n^-3/4, not the
// Gaussian's n^-1/2: a stratified estimate's error at an edge falls as n^-3/4, and the window's
// bias must fall as fast for the filtered V to converge with it (on the analytic penumbra,
// tests/test_penumbra_filter.c, at 256 spp: n^-1/2 left 0.000212 against unfiltered's 0.000187,
// n^-3/4 0.000174). Measured (bench, bunny, canopy and Sponza at 256 x 256, exact, 4 / 16 / 256
// spp, reference MAE; the scale as 1.4 n^-1/2 at 4 spp, which is 2 n^-3/4 there): 0.35 n^-1/2 cost
// the canopy at 4 and 16 spp (0.0313 / 0.0169 against 0.0248 / 0.0129 with a fixed window); 2
// n^-3/4 keeps 4 and 16 spp within 3% of the fixed window and cuts 256 spp's (canopy 0.0024 against
// 0.0037, unfiltered 0.0029; Sponza 0.00072 against 0.00082, unfiltered 0.00103); 16 times that no
// longer narrowed the canopy's at 256 spp (0.0032).
float pn_penumbra_window_scale(void);
// The most pixels a tap lies from its pixel: the frame's budget, growing with the image's height
// (a penumbra spans more pixels at a higher resolution) within [8, 32].
uint32_t pn_penumbra_max_radius(uint32_t height);

// Discards its images' contents and makes them GENERAL before the filter pass (every frame and
// light with a filter: the filter pass's set holds them). Under the penumbra filter v is V (the
// filter pass's output, with TRANSFER_DST): the marks and the list are emptied, and V, the
// footprints and the row pass's output cleared to a lit pixel's, which the filter pass leaves
// (filter.comp); NULL under the interleaved filter alone, which uses none of them.
void pn_penumbra_pass_begin(VkCommandBuffer cmd, const pn_penumbra_pass *f, const pn_gpu_image *v);
// Records the two dispatches with the barriers before and between them; V and the footprints
// must be written (the filter pass's), and V is visible to compute reads after. samples, adaptive,
// yfov_deg: as pn_filter_pass_record.
void pn_penumbra_pass_record(VkCommandBuffer cmd, const pn_penumbra_pass *f, uint32_t samples, bool adaptive,
                             float yfov_deg);
