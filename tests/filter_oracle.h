// filter.comp recomputed in double from a frame's floats, with bounds on the shader's float
// evaluation: the one oracle of the filter, shared by test_extremes.c (the filter at the extremes
// and its scale invariance) and test_filter.c (the default scene, windows other than 3x3, 1 spp).
// Written from the weights filter.comp documents, not from its code.
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "interface.h" // PN_FILTER_MAX_TILE

#define FLOAT_U 0x1p-24         // float's unit roundoff
#define FILTER_RANGE_SIGMAS 2.5 // filter.comp's RANGE_SIGMAS

#define FILTER_PENUMBRA_TOLERANCE 0.5 // filter.comp's PENUMBRA_TOLERANCE
#define FILTER_SURFACE_CONTINUES 0.75 // filter.comp's SURFACE_CONTINUES
#define FILTER_CONTACT_REACH 2        // filter.comp's CONTACT_REACH
#define FILTER_MAX_TAPS (PN_FILTER_MAX_TILE * PN_FILTER_MAX_TILE)

// A filtered frame as the filter pass saw it (pn_frame_images and the frame's settings).
typedef struct filter_frame {
    int width, height;   // pixels
    int tile_w, tile_h;  // the window (filter.comp's TILE_W x TILE_H)
    uint32_t samples;    // filter.comp's pc.samples: the light samples per pixel, 0 for a point light
    float eye_mag;       // the camera position's largest coordinate magnitude
    float pixel_angle;   // what filter_pass.c passes: 2 tan(yfov / 2) / height
    const float *p, *n;  // 4 floats per pixel: position and coverage (> 0 on geometry); normal and
                         // view depth
    const float *v, *v_raw; // the filtered and the unfiltered V
    const uint32_t *valid;  // valid rays per pixel (a pixel without one has no V of its own)
    const bool *reaches;    // whether the light reaches above the pixel's horizon
    const float *penumbra;  // the penumbra width at the pixel's mean blocker (filter.comp's penumbra_weight)
    // Under the penumbra filter, filter.comp's pc.narrow (> 0: the window's Gaussian and its edge
    // rule for the penumbra weight) and per pixel the penumbra width of its nearest blocker
    // (pn_frame_images.blockers' second channel); 0 and NULL under the interleaved filter.
    float narrow;
    const float *width_near;
} filter_frame;

// One neighbour q of a pixel p in its window, as filter.comp weighs it, evaluated in double from the
// frame's float P and N.
typedef struct filter_tap {
    double w;         // max(1 - rho^2, 0) c^2: the geometric weight (times pen, filter_recompute)
    double wgeo;      // the geometric weight alone
    double pen;       // filter_penumbra: 1 for a pixel without a V of its own
    double rho;       // the larger of the two plane offsets over their footprints
    double c;         // max(n.m, 0)
    double err;       // bound on |w - the shader's float w| (filter_tap_at)
    double mag;       // the largest coordinate magnitude of p and q
    double footprint; // the smaller of the two footprints, times the pixel distance (world units)
    double depth;     // the smaller of the two view depths
} filter_tap;

// One covered pixel's window as filter.comp evaluates it, in double from the frame's floats, with
// bounds on the shader's float evaluation (filter_recompute). Taps in the shader's order.
typedef struct filter_window {
    bool in[FILTER_MAX_TAPS];      // the tap is in the image and covered: filter.comp weighs it
    filter_tap t[FILTER_MAX_TAPS]; // its geometric weight
    float v_raw[FILTER_MAX_TAPS];  // its V_raw
    double d[FILTER_MAX_TAPS];     // |its V_raw - the pixel's|
    double wr[FILTER_MAX_TAPS];    // its range weight (filter_range_weight of the spread below)
    double wg, mean, mean_tol; // first loop: the sum of the geometric weights, V_raw's mean under
                               // them and a bound on |mean - the shader's float mean|
    double spread;             // filter_spread(mean), or of a mean of 1/2 where widest
    double w, v, tol;          // second loop: the sum of the weights wg wr, the filtered V and a
                               // bound on |V - the shader's float V|
    bool range_between;        // a tap the geometry keeps has a range weight between 0 and 1
    bool pen_between;          // ... a penumbra weight between 0 and 1 that applies
    // Under the penumbra filter (filter_frame.narrow > 0):
    bool gauss_between; // a tap the geometry keeps has a Gaussian weight between 0 and 1
    bool floored;       // ... and the penumbra under it counts as a pixel wide, wider than the blocker's
    bool refuses;       // the penumbra weight would refuse a usable neighbour (below 1)
    bool lifted;        // ... and it does not apply: no edge of geometry within CONTACT_REACH
    bool ring;          // ... it applies, and only the ring CONTACT_REACH away saw the edge
    bool ambiguous;     // whether it applies lies within rounding of a threshold: no verdict
    bool widest;        // one sample a pixel, the penumbra weight not applying (filter.comp's
                        // near_edge false): the range weight takes V's largest variance, 1/4
    bool widest_acted;  // ... and it changed a tap's range weight from the window mean's
} filter_window;

// A weight strictly between 0 and 1 (neither keeping nor dropping its tap), beyond every rounding
// bound here.
bool filter_between(double w);
// filter.comp's geometric weight max(1 - rho^2, 0) c^2.
double filter_weight(double rho, double c);
// The tap of pixel (x, y) at (x + dx, y + dy); false outside the image or on the background.
bool filter_tap_at(const filter_frame *f, int x, int y, int dx, int dy, filter_tap *t);
// filter.comp's spread for a window mean m, and the spreads of the means in [m_lo, m_hi].
double filter_spread(double m, uint32_t samples);
void filter_spread_range(double m_lo, double m_hi, uint32_t samples, double *lo, double *hi);
// filter.comp's range weight of a neighbour whose V_raw differs from the pixel's by d.
double filter_range_weight(double d, double spread);
// [*lo, *hi] holds the shader's float max(1 - (d / spread)^2, 0) for d != 0 (one float subtraction
// away from the double d) and a float spread in [s_lo, s_hi] (penumbra_oracle.c's range weight too).
void filter_range_weight_float(double d, double s_lo, double s_hi, double *lo, double *hi);
// filter.comp at covered pixel (x, y): the window's weights, the filtered V and its bound.
void filter_recompute(const filter_frame *f, int x, int y, filter_window *o);
