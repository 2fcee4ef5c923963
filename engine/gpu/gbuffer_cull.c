// Back faces in the G-buffer pass: the analysis of a draw's surface and the per-frame test
// (gbuffer_cull.h says why it is exact).
#include "gpu/gbuffer_cull.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <meshoptimizer.h>

static uint32_t part_of(uint32_t *parent, uint32_t x)
{
    while (parent[x] != x)
        x = parent[x] = parent[parent[x]];
    return x;
}

// Keys sorted by 8 bits a pass, least significant first; tmp as long as keys.
static void sort_keys(uint64_t *keys, uint64_t *tmp, size_t n)
{
    for (int shift = 0; shift < 64; shift += 8) {
        size_t count[257] = {0};
        for (size_t i = 0; i < n; i++)
            count[((keys[i] >> shift) & 0xff) + 1]++;
        if (count[((keys[0] >> shift) & 0xff) + 1] == n)
            continue; // every key has this byte: the order stands
        for (int b = 0; b < 256; b++)
            count[b + 1] += count[b];
        for (size_t i = 0; i < n; i++)
            tmp[count[(keys[i] >> shift) & 0xff]++] = keys[i];
        memcpy(keys, tmp, n * sizeof *keys);
    }
}

// Six times the signed volume of the tetrahedron (o, a, b, c), in double relative to o: the draw's
// first vertex, so that a mesh far from the origin keeps its digits.
static double tet6(const float *o, const float *a, const float *b, const float *c)
{
    double u[3], v[3], w[3];
    for (int k = 0; k < 3; k++)
        u[k] = (double)a[k] - o[k], v[k] = (double)b[k] - o[k], w[k] = (double)c[k] - o[k];
    return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
}

// The draw's vertex range, bounds and signed volume.
static void measure(const pn_scene *s, const pn_draw *d, pn_gbuffer_cull *c)
{
    const uint32_t *idx = s->indices + d->first_index;
    c->first = UINT32_MAX, c->last = 0;
    for (uint32_t k = 0; k < d->index_count; k++)
        c->first = idx[k] < c->first ? idx[k] : c->first, c->last = idx[k] > c->last ? idx[k] : c->last;
    for (int k = 0; k < 3; k++)
        c->min[k] = INFINITY, c->max[k] = -INFINITY;
    for (uint32_t i = c->first; i <= c->last && d->index_count; i++)
        for (int k = 0; k < 3; k++)
            c->min[k] = fminf(c->min[k], s->vertices[i].pos[k]), c->max[k] = fmaxf(c->max[k], s->vertices[i].pos[k]);
    double v6 = 0;
    const float *o = d->index_count ? s->vertices[c->first].pos : NULL;
    for (uint32_t t = 0; t + 2 < d->index_count; t += 3)
        v6 += tet6(o, s->vertices[idx[t]].pos, s->vertices[idx[t + 1]].pos, s->vertices[idx[t + 2]].pos);
    c->volume = v6 / 6;
}

pn_result pn_gbuffer_cull_analyse(const pn_scene *s, const pn_draw *d, pn_gbuffer_cull *out)
{
    memset(out, 0, sizeof *out);
    measure(s, d, out);
    const pn_material *mat = &s->materials[d->material];
    if (d->index_count < 3 || mat->double_sided || mat->alpha_cutoff > 0 || out->last - out->first >= (1u << 31))
        return PN_OK; // (c), or nothing to cull; edge keys hold 31-bit vertex numbers
    const uint32_t n = out->last - out->first + 1, count = d->index_count - d->index_count % 3;
    const uint32_t *idx = s->indices + d->first_index;
    uint32_t *local = malloc((size_t)count * sizeof *local), *weld = malloc((size_t)count * sizeof *weld);
    uint32_t *parent = malloc((size_t)n * sizeof *parent);
    double *part_v6 = calloc(n, sizeof *part_v6);
    uint64_t *keys = malloc((size_t)count * sizeof *keys), *tmp = malloc((size_t)count * sizeof *tmp);
    if (!local || !weld || !parent || !part_v6 || !keys || !tmp) {
        free(local), free(weld), free(parent), free(part_v6), free(keys), free(tmp);
        return PN_ERR_MEMORY;
    }
    // Welded by position (the bits of x, y, z): split vertices (seams of normals or UVs, flat
    // shading's three per triangle) share their edges.
    for (uint32_t k = 0; k < count; k++)
        local[k] = idx[k] - out->first;
    meshopt_generateShadowIndexBuffer(weld, local, count, s->vertices[out->first].pos, n, sizeof(float[3]), sizeof(pn_vertex));
    // (a) Each directed edge as a key: the smaller vertex, the larger, and which way it runs.
    size_t edges = 0;
    for (uint32_t t = 0; t < count; t += 3)
        for (int e = 0; e < 3; e++) {
            uint32_t a = weld[t + e], b = weld[t + (e + 1) % 3];
            if (a != b) // a degenerate triangle's edge from a vertex to itself bounds nothing
                keys[edges++] = (uint64_t)(a < b ? a : b) << 33 | (uint64_t)(a < b ? b : a) << 1 | (a > b);
        }
    bool closed = edges > 0;
    if (closed)
        sort_keys(keys, tmp, edges);
    for (size_t i = 0; closed && i < edges;) {
        size_t j = i, forward = 0;
        for (; j < edges && keys[j] >> 1 == keys[i] >> 1; j++)
            forward += (keys[j] & 1) == 0;
        closed = 2 * forward == j - i;
        i = j;
    }
    // (b) The connected parts' volumes.
    for (uint32_t i = 0; closed && i < n; i++)
        parent[i] = i;
    for (uint32_t t = 0; closed && t < count; t += 3) {
        uint32_t a = part_of(parent, weld[t]);
        parent[part_of(parent, weld[t + 1])] = a;
        parent[part_of(parent, weld[t + 2])] = a;
    }
    const float *o = s->vertices[out->first].pos;
    for (uint32_t t = 0; closed && t < count; t += 3)
        part_v6[part_of(parent, weld[t])] += tet6(o, s->vertices[idx[t]].pos, s->vertices[idx[t + 1]].pos, s->vertices[idx[t + 2]].pos);
    for (uint32_t t = 0; closed && t < count; t += 3)
        closed = part_v6[part_of(parent, weld[t])] > 0;
    out->closed = closed;
    out->outward = closed && out->volume > 0;
    free(local), free(weld), free(parent), free(part_v6), free(keys), free(tmp);
    return PN_OK;
}

void pn_gbuffer_cull_moved(const pn_scene *s, const pn_draw *d, pn_gbuffer_cull *c)
{
    measure(s, d, c);
    c->outward = c->closed && c->volume > 0;
}

bool pn_gbuffer_cull_back(const pn_gbuffer_cull *c, const float eye[3], const float forward[3], float znear)
{
    if (!c->closed || !c->outward)
        return false;
    // Every corner of the box beyond the near plane by more than the rasterizer's rounding: it
    // transforms float positions, so its view depth is off by some ulps of the coordinates'
    // magnitude; a 2^-8 of the depth is there for the matrix's own rounding. (pn_gbuffer_camera's
    // near plane lies 1% before the scene's bounding sphere, so an eye outside that sphere passes.)
    for (int i = 0; i < 8; i++) {
        double depth = 0, mag = 0;
        for (int k = 0; k < 3; k++) {
            double corner = i >> k & 1 ? c->max[k] : c->min[k];
            depth += (corner - eye[k]) * forward[k];
            mag = fmax(mag, fmax(fabs(corner), fabs((double)eye[k])));
        }
        if (!(depth > znear + znear * 0x1p-8 + 64 * FLT_EPSILON * mag))
            return false;
    }
    return true;
}
