// Triangles sorted by the Morton code of their centroids, for the device-built acceleration
// structure.
#include "accel/morton.h"

#include <math.h>
#include <stdlib.h>

// Spreads the low 10 bits of v to every third bit.
static uint32_t spread3(uint32_t v)
{
    v &= 0x3ffu;
    v = (v | (v << 16)) & 0x030000ffu;
    v = (v | (v << 8)) & 0x0300f00fu;
    v = (v | (v << 4)) & 0x030c30c3u;
    v = (v | (v << 2)) & 0x09249249u;
    return v;
}

typedef struct keyed {
    uint32_t code, tri;
} keyed;

static int by_code(const void *a, const void *b)
{
    const keyed *x = a, *y = b;
    if (x->code != y->code)
        return x->code < y->code ? -1 : 1;
    return x->tri < y->tri ? -1 : x->tri > y->tri;
}

pn_result pn_triangles_morton(const pn_scene *s, float **xyz, uint32_t **order, uint32_t *count)
{
    uint32_t n = s->index_count / 3;
    *xyz = NULL;
    if (order)
        *order = NULL;
    *count = n;
    keyed *k = malloc((n ? n : 1) * sizeof *k);
    float *out = malloc((n ? n : 1) * 9 * sizeof *out);
    uint32_t *ord = order ? malloc((n ? n : 1) * sizeof *ord) : NULL;
    if (!k || !out || (order && !ord)) {
        free(k), free(out), free(ord);
        return PN_ERR_MEMORY;
    }
    // Centroids quantised to 1024 steps per axis of the scene's bounds (in double: the bounds may
    // be huge or tiny; a zero extent maps everything to step 0).
    double lo[3], scale[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = s->bounds_min[a];
        double e = (double)s->bounds_max[a] - lo[a];
        scale[a] = e > 0 ? 1023.0 / e : 0;
    }
    for (uint32_t t = 0; t < n; t++) {
        uint32_t q[3];
        for (int a = 0; a < 3; a++) {
            double c = 0;
            for (int v = 0; v < 3; v++)
                c += s->vertices[s->indices[3 * t + v]].pos[a];
            double step = (c / 3 - lo[a]) * scale[a];
            q[a] = !(step > 0) ? 0 : step >= 1023 ? 1023 : (uint32_t)step;
        }
        k[t] = (keyed){spread3(q[0]) | spread3(q[1]) << 1 | spread3(q[2]) << 2, t};
    }
    qsort(k, n, sizeof *k, by_code);
    for (uint32_t i = 0; i < n; i++) {
        for (int v = 0; v < 3; v++)
            for (int a = 0; a < 3; a++)
                out[9 * i + 3 * v + a] = s->vertices[s->indices[3 * k[i].tri + v]].pos[a];
        if (ord)
            ord[i] = k[i].tri;
    }
    free(k);
    *xyz = out;
    if (order)
        *order = ord;
    return PN_OK;
}
