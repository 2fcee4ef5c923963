// --quality auto's measurements (quality.c decides with them): pilot frames of a configuration at
// a pilot size against that size's converged reference, and a filtered configuration's frame
// against the reference at a stratified sample of its pixels.
#pragma once
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "gpu/renderer.h"
#include "shadow/metrics.h"
#include "shadow/setup.h"

// The pilot's pixels: at most about 128x128. Errors are per pixel, so a smaller image of the same
// framing estimates the full image's MAE (bench --max-error checks it at full size); the reference
// at PN_REFERENCE_SPP costs pixels x 1024 rays, which this keeps to a few seconds. A frame of at
// most that many pixels is its own pilot: the same pixels, samples and seed, so the same image.
enum { PN_PILOT_PIXELS = 128 * 128 };

// One pilot size with its converged reference (rendered when first needed).
typedef struct pn_pilot_size {
    bool used;    // false: no such size (the frame is its own pilot, nothing to confirm)
    double scale; // of the frame's width and height; 1: the frame itself
    uint32_t reference_spp;
    pn_setup_desc sd;
    size_t px;
    float *ref, *v;
    uint8_t *mask;
    double reference_ms;
    bool ready;
} pn_pilot_size;

// Pilot frames are small, so one frame's time is at the mercy of whatever else the machine does:
// configurations timed moments apart are ranked by the least of this many frames.
enum { PN_PILOT_TIMED_FRAMES = 3 };

// A filtered configuration is judged at the frame's own size. The filter averages over a footprint
// as wide as the penumbra in the frame's pixels; a pilot whose pixels are 4x as wide (128x128 for a
// 512x512 frame) averages a 16th as many samples under it, and measured about twice the frame's
// error (the dragon view, exact, penumbra filter, pilot against frame: 1 spp 0.0221 / 0.0108, 4 spp
// 0.0095 / 0.0051; unfiltered 0.0476 / 0.0480 and 0.0179 / 0.0177, as a pixel's own noise does not
// depend on the scale): --quality auto took exact 4 spp filtered for MAE 0.01 where 2 spp reached
// 0.0076 in 0.6x its time. So the configuration renders the frame itself, on the pilot's tree, and
// its error is measured at one pixel drawn at random in each cell of a grid of the pilot's size,
// against the converged reference at those pixels alone (their positions and normals uploaded as
// the G-buffer: pn_renderer_set_gbuffer): as many reference rays as the pilot's. A stratified
// sample, so its MAE estimates the frame's (without bias where the pilot's size divides the
// frame's; else the cells differ by a pixel across, a few percent of their weight), with a standard
// error as the pilot's, conservative for a stratified sample.
// A frame costs about 4x a step's pilot frames (16x the pixels, once against 4 pilot frames), and a
// climb that meets the budget late renders it at every step: the canopy view's choice took 363 s
// against 192 s, 16 s of it for one line-space frame at 256 spp. But the frame's error is a share
// of the pilot's that grows towards 1 with the samples, as the footprint narrows (frame / pilot
// MAE at 1, 2, 4, ... spp, exact: the dragon .48, .48, .52, .56; the canopy .39, .40, .38, .42,
// .49, .60, .75, .95; adaptive MIN:4 MIN at or above uniform MIN's: .50 against .48, .43 / .53 /
// .57 against .39 / .40 / .38). So a step whose pilot error, less two standard errors, times the
// share measured at the most uniform samples up to its own (MIN when adaptive) is over the budget
// is outside without its frame (PN_QUALITY_CONFIRM_BOUND). Where the share dips (the canopy's 4
// spp, 5%), the bound can only lose a pick, never admit one outside.
typedef struct pn_frame_sample {
    bool used, ready;
    uint32_t width, height;    // the frame's
    uint32_t cells_w, cells_h; // the grid: the pilot's size
    size_t count;
    uint32_t *index; // each cell's pixel in the frame
    float *ref, *v;
    uint8_t *mask;
    double reference_ms;
} pn_frame_sample;

// Renders the set-up's frame `frames` times (once more first with warm_up): V (and the coverage
// into mask) of the last, the least shadow (and filter) time into ms.
pn_result pn_pilot_frame(pn_setup *s, const pn_camera *cam, const pn_light *light, size_t px, bool warm_up, int frames,
                         float *v, uint8_t *mask, double *ms);
// pn_setup_create without its log: a refused set-up (a tree too large) is not the user's error.
pn_result pn_pilot_quiet_setup(pn_gpu_device *dev, const pn_scene *scene, const pn_light *light,
                               const pn_setup_desc *sd, pn_setup *s);

// A pilot size of `scale` times the frame's width and height, its reference not rendered yet.
pn_result pn_pilot_size_init(pn_pilot_size *p, const pn_renderer_desc *frame, double scale, uint64_t max_bytes,
                             uint32_t reference_spp, const pn_camera *cam);
void pn_pilot_size_free(pn_pilot_size *p);

// Renders p's converged reference (once).
pn_result pn_pilot_reference(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                             pn_pilot_size *p);
// The standard error of an MAE over a sample of the picture's pixels.
double pn_pilot_mae_se(const pn_error_metrics *e);

// The frame sample of a filtered configuration (used only where some pilot is filtered).
pn_result pn_frame_sample_init(pn_frame_sample *fs, const pn_renderer_desc *frame, const pn_pilot_size *pilot,
                               bool filtered);
void pn_frame_sample_free(pn_frame_sample *fs);

// The converged reference at the sampled pixels (once).
pn_result pn_frame_sample_reference(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                                    const pn_light *light, const pn_pilot_size *pilot, pn_frame_sample *fs);
// A configuration's frame error at the sampled pixels (r renders at the frame's size).
pn_result pn_frame_sample_error(pn_renderer *r, const pn_camera *cam, const pn_light *light, pn_frame_sample *fs,
                                double *mae, double *se);
// The set-up's frame error at pilot size p: its MAE and that MAE's standard error; ms its time.
pn_result pn_pilot_error(pn_setup *s, const pn_camera *cam, const pn_light *light, pn_pilot_size *p, bool timed,
                         bool warm_up, double *mae, double *se, double *ms);
