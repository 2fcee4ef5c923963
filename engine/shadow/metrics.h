// Error of one visibility (or any scalar) image against another, over a mask of pixels.
#pragma once
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

// The converged reference errors are measured against (bench, --quality auto): exact at this many
// stratified light samples per pixel, with a seed no measured configuration uses (they use --seed,
// default 1), so that its own noise is independent of theirs.
enum { PN_REFERENCE_SPP = 1024, PN_REFERENCE_SEED = 0x2c5e7f1u };

typedef struct pn_error_metrics {
    size_t pixels;    // compared
    double mae, rmse; // of the absolute error
    double p99, max;  // nearest-rank 99th percentile and maximum of the absolute error
    double over005, over02; // share of pixels off by more than 0.05 and 0.2
} pn_error_metrics;

// Compares a and b where mask (may be NULL: everywhere) is nonzero. A NaN or Inf counts as an
// infinite error. Writes the per-pixel absolute error to err_out when given (0 outside the mask).
// Returns false when out of memory.
bool pn_error_compare(const float *a, const float *b, const uint8_t *mask, size_t n, float *err_out,
                      pn_error_metrics *out);

// How a filter's error grows next to edges of geometry (--filter interleaved): over the covered
// pixels within PN_EDGE_BAND pixels of an edge, the share whose error against a reference grows by
// more than PN_EDGE_GROWTH through the filter (|v - ref| > |v_raw - ref| + PN_EDGE_GROWTH): light
// or shadow carried across the edge. An edge lies between two 4-neighbours when one has geometry and
// the other not, when their normals differ by more than 30 degrees (a crease), or when one lies more
// than half a pixel footprint off the other's tangent plane (a step in depth); all three are
// dimensionless, so the measure is the same at every scale. Deliberately looser than filter.comp's
// own cut-off (a full footprint, weights falling with the cosine): edges the filter half-trusts count.
enum { PN_EDGE_BAND = 2 };
#define PN_EDGE_GROWTH 0.05
typedef struct pn_edge_leak {
    size_t band;  // covered pixels within PN_EDGE_BAND of an edge
    size_t grown; // of them, those whose error grew by more than PN_EDGE_GROWTH
    double share; // grown / band (0 without edges)
    // The same count over the covered pixels away from edges: there the filter's averaging alone,
    // right on average but not in every pixel, grows some errors past PN_EDGE_GROWTH. The band's
    // share beyond this baseline is what the edges add.
    size_t away, away_grown;
    double away_share; // away_grown / away (0 without such pixels)
} pn_edge_leak;

// p, n: the frame's rgba position (w = 1 where geometry is) and normal (w = view depth); v the
// filtered and v_raw the unfiltered V, ref the reference, all w*h; pixel_angle = 2 tan(yfov/2) / h
// (a pixel's footprint per unit of view depth). class_out (may be NULL) gets per pixel 0 away from
// edges, 1 on an edge, 2 in the band, 3 in the band with its error grown. False when out of memory.
bool pn_edge_leak_measure(const float *p, const float *n, const float *v, const float *v_raw, const float *ref,
                          uint32_t w, uint32_t h, double pixel_angle, uint8_t *class_out, pn_edge_leak *out);
