// Wall-clock timing for CPU stages (GPU passes use timestamp queries, see gpu/).
#pragma once
#include <stdint.h>

// Monotonic time in nanoseconds.
uint64_t pn_time_ns(void);
static inline double pn_ms_since(uint64_t start_ns) { return (double)(pn_time_ns() - start_ns) * 1e-6; }

// Median of the times v[0..n), n >= 1 (sorts v): what the bench reports of repeated frames.
double pn_time_median(double *v, int n);
