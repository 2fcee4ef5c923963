// Writing a rendered frame, shared by `render` and `demo`: the EXR whose header records every
// parameter of the render, and the tone-mapped PNG.
#pragma once
#include "apps/render_opts.h"
#include "gpu/renderer.h"
#include "io/exr.h"

// What the EXR header records besides the pixels.
typedef struct pn_render_record {
    const pn_render_opts *opts; // mode, traversal, sampler, spp, seed, tree, size
    const pn_scene *scene;
    const pn_camera *camera;
    const pn_light *lights; // light_count of them (0 counts as 1)
    uint32_t light_count;
    pn_frame_times times;
    double build_ms;   // tree and BVH
    double rays_per_s; // of the shadow pass
} pn_render_record;

// Writes the frame as EXR: R G B A and shadow.V (with several lights shadow.V.0, shadow.V.1, ...,
// one per light; with a filter also shadow.V_raw or shadow.V_raw.0, ...), with `aovs` also P, N,
// albedo and Z; the header holds every parameter of `rec` under penumbra.* (light 0 as
// penumbra.light.*, light i > 0 as penumbra.light.i.*), then `extra` attributes.
pn_result pn_render_write_exr(const char *path, const pn_render_record *rec, const pn_frame_images *img, bool aovs,
                              const pn_exr_attr *extra, int extra_count);

// Writes the tone-mapped radiance as an sRGB PNG (pn_tonemap_srgb8).
pn_result pn_render_write_png(const char *path, const float *radiance, uint32_t width, uint32_t height, float exposure);

// Fails early, before any GPU work, when `path` cannot be created (logs why).
bool pn_render_output_writable(const char *path);
