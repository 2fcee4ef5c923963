// Error of one visibility (or any scalar) image against another, over a mask of pixels.
#pragma once
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
