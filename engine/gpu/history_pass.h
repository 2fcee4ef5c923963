// The temporal history (render --temporal, the demo): per light and pixel the sums of visible and
// valid samples over the frames so far, carried from frame to frame by the camera's reprojection
// and dropped where geometry or the light moved (shaders/glsl/history.comp). After each light's
// shadow pass it adds the frame's samples to the history and writes what the filters read in the
// counts' place and the unfiltered V; the renderer keeps the previous frame's camera, lights and
// G-buffer for it (renderer_frame.c).
#pragma once
#include "gpu/compute.h"
#include "gpu/resources.h"
#include "interface.h"

// Boxes of geometry that moved since the last frame (each object's before and after): past
// PN_HISTORY_MAX_BOXES the last grows to hold the rest.
typedef struct pn_history_boxes {
    double box[PN_HISTORY_MAX_BOXES][6]; // lo xyz, hi xyz
    uint32_t count;
} pn_history_boxes;
void pn_history_boxes_add(pn_history_boxes *b, const double lo[3], const double hi[3]);

typedef struct pn_history_pass {
    uint32_t width, height, layers; // layers: lights with a history of their own
    // store[k]: the sums per light (a layer each), where their samples lie and the pixel's normal;
    // pos[k]: a frame's P (light 0's pass writes it); compute[k] reads store[k] and pos[k] and
    // writes store[1 - k] and pos[1 - k]; cur says which hold the previous frame's.
    pn_gpu_image store[2];
    pn_gpu_image pos[2];
    pn_gpu_image out;            // rgba32ui: the sums as float bits, counts.z, counts.w (the filters')
    // The lineage (PN_HISTORY_BINDING_LINEAGE): this frame's, which the shadow pass draws its
    // samples by (pn_shadow_pass_set_lineage); trail[k]: a frame's, kept for the next frame's
    // choice (compute[k] reads trail[k], light 0's pass writes trail[1 - k]).
    pn_gpu_image lineage, trail[2];
    pn_gpu_buffer params;        // HistoryParams, host-visible
    pn_gpu_compute compute[2];
    VkPipeline choose; // the choosing stage's (the device's), with compute[cur]'s set
    VkPipeline take;   // and the adding stage's that takes its choice (compute[k]'s own chooses itself)
    const pn_gpu_image *counts; // the shadow pass's, which the set holds (pn_history_pass_record_choose)
    uint32_t cur;
    bool ready;    // its images are in the GENERAL layout (pn_history_pass_record_start)
    bool one_tile; // the renderer's warm-up frame: dispatch over the first tile only
} pn_history_pass;

// Images for width x height pixels and `layers` lights, the pass's sets pointed at the renderer's
// P, N, counts and V_raw. Their contents start undefined: the first frame drops every light's
// history (pn_history_pass_record's drop).
pn_result pn_history_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, uint32_t layers,
                                 const pn_gpu_image *p, const pn_gpu_image *n, const pn_gpu_image *counts,
                                 const pn_gpu_image *v_raw, pn_history_pass *out);
void pn_history_pass_destroy(pn_gpu_device *dev, pn_history_pass *h);

// The frame's parameters (the queue idle): written to h->params.
pn_history_params *pn_history_pass_params(pn_history_pass *h);
// The moved boxes into the parameters, grown by what a ray's meeting with them can be off by at
// the scene's magnitude `scene_mag`, and by 3 leaves of `leaf_size` where rays end in an N-tree's
// cells (0 otherwise): history_pass.c.
void pn_history_pass_set_boxes(pn_history_pass *h, const pn_history_boxes *b, double scene_mag, double leaf_size);

// Records what orders the frame's history passes after the previous frame's work on the sums and
// positions (and, the first time, brings the images to the GENERAL layout).
void pn_history_pass_record_start(VkCommandBuffer cmd, pn_history_pass *h);

// Records the frame's choice, before its shadow passes: each pixel's previous pixel (whose
// history every light takes) and the lineage its samples continue (history.comp); fresh: no
// previous frame to take them from. Only for frames without an interleaved tile (unfiltered):
// under one, each pixel keeps its own samples, whose tile-mates' are complementary within the
// frame, which the filter's window relies on, and each light's pass chooses for itself. Reads P, N
// (compute-readable), the previous frame's P, lineages and sums; writes h->lineage.
void pn_history_pass_record_choose(VkCommandBuffer cmd, const pn_history_pass *h, bool fresh);

// Records light `light`'s pass: with drop, the frame's samples alone; cap: the most samples the
// sums hold (HistoryPush). Reads the counts and writes V_raw and h->out, both GENERAL.
// noise_pixels: how many pixels the filter after it averages a frame's noise over (its tile; 1
// unfiltered), which the share of a moved history weighs its bias against (history.comp).
// chosen: the frame's choice was recorded (pn_history_pass_record_choose), and the pass takes it.
// Light 0's pass also keeps this frame's P and lineages for the next frame (a frame without a
// choice starts every pixel's lineage).
void pn_history_pass_record(VkCommandBuffer cmd, const pn_history_pass *h, uint32_t light, bool drop, float cap,
                            float noise_pixels, bool chosen);

// After a frame completed: its sums become the previous frame's.
static inline void pn_history_pass_flip(pn_history_pass *h) { h->cur ^= 1u; }
