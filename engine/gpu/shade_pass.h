// The shading pass: outgoing radiance = albedo / pi * E(light) * V per pixel, linear HDR, alpha =
// coverage (shaders/glsl/shade.comp).
#pragma once
#include "gpu/compute.h"
#include "gpu/resources.h"
#include "interface.h"
#include "scene/view.h"

typedef struct pn_shade_pass {
    pn_gpu_compute compute; // its layout and set; no pipeline of its own
    // by_kind[k]: the pipeline for lights of kind k (PN_LIGHT_*_ID), the device's, made when a frame
    // first has such a light (pn_shade_pass_prepare).
    VkPipeline by_kind[PN_LIGHT_KIND_IDS];
    uint32_t width, height;
    bool one_tile; // the renderer's warm-up frame: dispatch over the first tile only (renderer.c)
} pn_shade_pass;

// The light as the shaders read it (interface.h): corners, unit normal, radiance.
pn_light_gpu pn_light_to_gpu(const pn_light *light);

// Reads p, n, albedo and v; writes radiance.
pn_result pn_shade_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, const pn_gpu_image *p,
                               const pn_gpu_image *n, const pn_gpu_image *albedo, const pn_gpu_image *v,
                               const pn_gpu_image *radiance, pn_shade_pass *out);
void pn_shade_pass_destroy(pn_gpu_device *dev, pn_shade_pass *s);

// Makes the pipelines of the kinds among `lights` not made yet; *made: how many it made.
pn_result pn_shade_pass_prepare(pn_gpu_device *dev, pn_shade_pass *s, const pn_light_gpu *lights, uint32_t count,
                                uint32_t *made);

// One light's term: the first light (accumulate false) writes the radiance, the others add theirs.
void pn_shade_pass_record(VkCommandBuffer cmd, const pn_shade_pass *s, const pn_light_gpu *light, bool accumulate);
