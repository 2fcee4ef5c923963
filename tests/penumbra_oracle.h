// The penumbra filter's Gaussian (penumbra_filter.comp) recomputed in double from a frame's floats,
// with bounds on the shader's float evaluation: each of its two passes from the very floats that
// pass read (the row pass from the interleaved window's V, pn_frame_images.v_window; the column
// pass from the row pass's V and footprint, pn_frame_images.footprint), so that neither pass's
// bound carries the other's. Written from the weights penumbra_filter.comp documents, not from its
// code; the surface weight is filter_oracle.h's (the same filter_common.glsl).
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "filter_oracle.h" // FLOAT_U, filter_tap_at

#define PENUMBRA_RADIUS_SIGMAS 2.5  // PN_PENUMBRA_RADIUS_SIGMAS: max_radius over it bounds the deviation
#define PENUMBRA_TAP_SIGMAS 2.0     // PN_PENUMBRA_TAP_SIGMAS: the reach, in deviations
#define PENUMBRA_MIN_SIGMA 0.5      // penumbra_filter.comp's MIN_SIGMA, pixels
#define PENUMBRA_RANGE_SIGMAS 2.5   // ... RANGE_SIGMAS
#define PENUMBRA_WINDOW_SAMPLES 3.0 // ... WINDOW_SAMPLES
#define PENUMBRA_MAX_TAPS 129       // 2 x 64 + 1: a reach of up to 64 pixels at step 1

// A frame filtered with --filter penumbra, as its Gaussian saw it (pn_frame_images and the frame's
// settings). Uniform samples only (the pass's pc.adaptive = 0).
typedef struct penumbra_frame {
    int width, height;    // pixels
    uint32_t samples;     // the pass's pc.samples (pn_filter_noise_samples): > 0, an area light
    uint32_t max_radius;  // pn_penumbra_max_radius(height)
    float pixel_angle;    // what penumbra_pass.c passes: (float) pn_pixel_angle(yfov, height)
    const float *p, *n;   // 4 floats per pixel: position and coverage; normal and view depth
    const float *v_raw;   // the shadow pass's V: below 1 where one of the pixel's valid rays was blocked
    const uint32_t *valid; // valid rays per pixel (without one the pixel lends nothing along rows)
    const uint32_t *reaches; // whether the light reaches above the pixel's horizon (counts.z):
                             // without a valid ray, it lends along columns the V its neighbours gave it
    const float *v_window; // the Gaussian's input: the interleaved filter's V
    const float *scratch;  // 2 floats per pixel: the row pass's V (penumbra_row_v) and footprint (pixels)
    const float *v;        // the column pass's V: the frame's
} penumbra_frame;

// One pixel of one pass as penumbra_filter.comp documents it, in double.
typedef struct penumbra_pixel {
    bool filtered;    // the Gaussian ran (covered, and sigma_px at least MIN_SIGMA)
    bool ambiguous;   // sigma_px lies within the float evaluation's error of a threshold of
                      // MIN_SIGMA, the step or the reach: the shader's integers may differ from these
    double footprint; // the centre's footprint, world units (rows: dilated over 3 x 3)
    double sigma_px;  // the Gaussian's deviation in pixels along the pass
    double sigma_err; // bound on |sigma_px - the shader's float one|, relative
    int step, reach;  // taps every `step` pixels out to `reach`
    int taps;         // inside the image
    double v_in;      // the pixel's input V
    double spread;    // the range weight's
    double w;         // the sum of the taps' weights
    double v, tol;    // the pass's V and a bound on |V - the shader's float V|
    bool range_between, surface_between, gauss_between; // a tap's weight strictly inside (0, 1)
    bool narrowed;    // a tap took the neighbour's narrower footprint
} penumbra_pixel;

// The footprint the Gaussian is centred with at (x, y), world units, as the row pass reads it: the
// pixel's own where one of its valid rays was blocked, else the narrowest of its 3 x 3 neighbours'
// own, else of the 5 x 5's outer ring (0 if none has one), at most max_radius / RADIUS_SIGMAS of the
// pixel's own pixels; *ring says which: 0 its own, 1 or 2 the ring it came from, -1 none.
// Recovered from the row pass's footprint output
// (pixels facing the camera) times the pixel's footprint, within PENUMBRA_SIGMA_REL.
double penumbra_centre_footprint(const penumbra_frame *f, int x, int y, int *ring);
// The relative error of a footprint recovered that way: the shader's quotient (2.5 ulp, 5u) and
// one more u for the product here.
#define PENUMBRA_SIGMA_REL (6 * FLOAT_U)

// The row pass's V as it stores it: -V where the pixel lends nothing along columns (no valid ray
// of its own, and the light cannot reach it), the sign bit telling which (penumbra_filter.comp's
// row_value).
double penumbra_row_v(float stored);
bool penumbra_row_lends(float stored);
// Whether pixel i lends its V to the row pass (rows) or the column pass.
bool penumbra_lends(const penumbra_frame *f, int i, bool rows);

// The row pass (rows = true: window V -> scratch.x) or the column pass (scratch.x -> V) at (x, y).
void penumbra_recompute(const penumbra_frame *f, int x, int y, bool rows, penumbra_pixel *o);
