// Error measures of one image against another: MAE, RMSE, percentiles, and the filter's edge leak.
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "shadow/metrics.h"

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

// Whether 4-neighbours i and j (both with geometry) lie across an edge (metrics.h).
static bool across_edge(const float *p, const float *n, size_t i, size_t j, double pixel_angle)
{
    const float *pi = p + 4 * i, *pj = p + 4 * j, *ni = n + 4 * i, *nj = n + 4 * j;
    double c = (double)ni[0] * nj[0] + (double)ni[1] * nj[1] + (double)ni[2] * nj[2];
    if (c < 0.8660254037844386) // cos 30 degrees
        return true;
    // Each point's distance from the other's tangent plane, in that pixel's footprint. The positions
    // carry a few ulps of their magnitude of rounding (filter.comp takes 8 off, as here), which far
    // from the origin can exceed a footprint; without taking it off every pixel would be an edge.
    double d[3], mag = 0;
    for (int k = 0; k < 3; k++) {
        d[k] = (double)pj[k] - pi[k];
        mag = fmax(mag, fmax(fabs(pi[k]), fabs(pj[k])));
    }
    double slack = 8.0 * mag * 1.1920929e-7;
    double off_i = fmax(fabs(ni[0] * d[0] + ni[1] * d[1] + ni[2] * d[2]) - slack, 0.0) / (ni[3] * pixel_angle);
    double off_j = fmax(fabs(nj[0] * d[0] + nj[1] * d[1] + nj[2] * d[2]) - slack, 0.0) / (nj[3] * pixel_angle);
    return !(fmax(off_i, off_j) <= 0.5); // a NaN (a zero depth) counts as an edge
}

bool pn_edge_leak_measure(const float *p, const float *n, const float *v, const float *v_raw, const float *ref,
                          uint32_t w, uint32_t h, double pixel_angle, uint8_t *class_out, pn_edge_leak *out)
{
    memset(out, 0, sizeof *out);
    size_t px = (size_t)w * h;
    uint8_t *edge = calloc(px ? px : 1, 1);
    if (!edge)
        return false;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            // Right and down neighbours: each pair once; both pixels of an edge are on it.
            size_t nb[2] = {x + 1 < w ? i + 1 : i, y + 1 < h ? i + w : i};
            for (int k = 0; k < 2; k++) {
                size_t j = nb[k];
                if (j == i)
                    continue;
                bool gi = p[4 * i + 3] > 0, gj = p[4 * j + 3] > 0;
                if (gi != gj || (gi && across_edge(p, n, i, j, pixel_angle)))
                    edge[i] = edge[j] = 1;
            }
        }
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            if (class_out)
                class_out[i] = edge[i];
            if (p[4 * i + 3] <= 0)
                continue;
            bool near = false;
            for (int dy = -PN_EDGE_BAND; dy <= PN_EDGE_BAND && !near; dy++)
                for (int dx = -PN_EDGE_BAND; dx <= PN_EDGE_BAND && !near; dx++) {
                    long qx = (long)x + dx, qy = (long)y + dy;
                    near = qx >= 0 && qy >= 0 && qx < (long)w && qy < (long)h && edge[(size_t)qy * w + (size_t)qx];
                }
            bool grown = fabs((double)v[i] - ref[i]) > fabs((double)v_raw[i] - ref[i]) + PN_EDGE_GROWTH;
            if (!near) {
                out->away++;
                out->away_grown += grown;
                continue;
            }
            out->band++;
            out->grown += grown;
            if (class_out && !edge[i])
                class_out[i] = grown ? 3 : 2;
            else if (class_out && grown)
                class_out[i] = 3;
        }
    out->share = out->band ? (double)out->grown / (double)out->band : 0.0;
    out->away_share = out->away ? (double)out->away_grown / (double)out->away : 0.0;
    free(edge);
    return true;
}
