#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "apps/metrics.h"

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

bool pn_error_compare(const float *a, const float *b, const uint8_t *mask, size_t n, float *err_out,
                      pn_error_metrics *m)
{
    memset(m, 0, sizeof *m);
    float *err = malloc((n ? n : 1) * sizeof *err);
    if (!err)
        return false;
    double sum = 0, sum2 = 0;
    size_t k = 0, over005 = 0, over02 = 0;
    for (size_t i = 0; i < n; i++) {
        if (err_out)
            err_out[i] = 0.0f;
        if (mask && !mask[i])
            continue;
        float e = fabsf(a[i] - b[i]);
        if (!isfinite(e)) // a NaN or Inf in either is as far off as it gets
            e = INFINITY;
        if (err_out)
            err_out[i] = e;
        err[k++] = e;
        sum += e;
        sum2 += (double)e * e;
        m->max = e > m->max ? e : m->max;
        over005 += e > 0.05f;
        over02 += e > 0.2f;
    }
    if (k) {
        qsort(err, k, sizeof *err, cmp_float);
        size_t rank = (size_t)ceil(0.99 * (double)k); // nearest-rank percentile
        m->pixels = k;
        m->mae = sum / (double)k;
        m->rmse = sqrt(sum2 / (double)k);
        m->p99 = err[rank ? rank - 1 : 0];
        m->over005 = (double)over005 / (double)k;
        m->over02 = (double)over02 / (double)k;
    }
    free(err);
    return true;
}
