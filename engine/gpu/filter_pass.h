// The filter pass (--filter interleaved): V averaged over the interleaved-sampling tile around each
// pixel, across neighbours on the pixel's own surface only (shaders/glsl/filter.comp). Reads the
// shadow pass's V (v_raw) and sample counts (which pixels have an estimate of V), writes the
// filtered V the shading pass reads.
#pragma once
#include "gpu/compute.h"
#include "gpu/resources.h"
#include "interface.h"

typedef struct pn_filter_pass {
    pn_gpu_compute compute;
    uint32_t width, height;
} pn_filter_pass;

pn_result pn_filter_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, const pn_gpu_image *p,
                                const pn_gpu_image *n, const pn_gpu_image *v_raw, const pn_gpu_image *counts,
                                const pn_gpu_image *v, pn_filter_pass *out);
void pn_filter_pass_destroy(pn_gpu_device *dev, pn_filter_pass *f);

// tile_w x tile_h: the window (the tile of light_sample's interleaving); yfov_deg: the camera's
// vertical field of view, which with the height gives a pixel's footprint per unit of depth;
// samples: the shadow pass's light samples per pixel, which set the noise one pixel's V carries.
void pn_filter_pass_record(VkCommandBuffer cmd, const pn_filter_pass *f, uint32_t tile_w, uint32_t tile_h,
                           uint32_t samples, float yfov_deg);
