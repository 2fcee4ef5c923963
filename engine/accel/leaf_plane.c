// Leaf planes: the plane that best fits a leaf's triangles and the slab around it that holds them.
#include "accel/leaf_plane.h"

#include <math.h>
#include <stdbool.h>
#include <string.h>

static const double HALF_DIAGONAL = 0.8660254037844386; // of a unit cube: sqrt(3) / 2

// At most 9 vertices in exact arithmetic (3 + one per plane); rounding at vertices on a face can add
// sign changes, so the arrays hold more and a polygon that would still overflow them is reported.
enum { CLIP_MAX = 16 };

// Triangle v clipped to the box [lo, hi] (Sutherland-Hodgman, in double): the polygon's vertices
// (returned: their count, or -1 if they overflowed CLIP_MAX) and its area vector (A m).
static int clip_polygon(const float v[9], const double lo[3], const double hi[3], double res[CLIP_MAX][3],
                        double area[3])
{
    double poly[2][CLIP_MAX][3];
    bool overflow = false;
    int count = 3, cur = 0;
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            poly[0][i][k] = v[3 * i + k];
    for (int plane = 0; plane < 6 && count > 0; plane++) {
        int k = plane >> 1;
        double bound = (plane & 1) ? hi[k] : lo[k], sign = (plane & 1) ? -1.0 : 1.0;
        int out = 0;
        for (int i = 0; i < count; i++) {
            const double *a = poly[cur][i], *b = poly[cur][(i + 1) % count];
            double da = sign * (a[k] - bound), db = sign * (b[k] - bound);
            overflow = overflow || out + 2 > CLIP_MAX;
            if (da >= 0 && out < CLIP_MAX)
                memcpy(poly[!cur][out++], a, sizeof(double[3]));
            if ((da >= 0) != (db >= 0) && out < CLIP_MAX) {
                double f = da / (da - db);
                for (int j = 0; j < 3; j++)
                    poly[!cur][out][j] = a[j] + f * (b[j] - a[j]);
                out++;
            }
        }
        cur = !cur;
        count = out;
    }
    area[0] = area[1] = area[2] = 0;
    for (int i = 1; i + 1 < count; i++) {
        const double *a = poly[cur][0], *b = poly[cur][i], *c = poly[cur][i + 1];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        area[0] += 0.5 * (e1[1] * e2[2] - e1[2] * e2[1]);
        area[1] += 0.5 * (e1[2] * e2[0] - e1[0] * e2[2]);
        area[2] += 0.5 * (e1[0] * e2[1] - e1[1] * e2[0]);
    }
    memcpy(res, poly[cur], (size_t)count * sizeof res[0]);
    return overflow ? -1 : count;
}

// Octahedral code of unit vector n in 7 + 7 bits, and its decoding (mirrored in the shader).
static uint32_t oct_encode(const double n[3])
{
    double l1 = fabs(n[0]) + fabs(n[1]) + fabs(n[2]), x = n[0] / l1, y = n[1] / l1;
    if (n[2] < 0) {
        double ox = (1 - fabs(y)) * (x >= 0 ? 1 : -1), oy = (1 - fabs(x)) * (y >= 0 ? 1 : -1);
        x = ox, y = oy;
    }
    uint32_t u = (uint32_t)lround((x * 0.5 + 0.5) * 126), v = (uint32_t)lround((y * 0.5 + 0.5) * 126);
    return u | v << 7;
}

static void oct_decode(uint32_t code, double n[3])
{
    double x = (double)(code & 127) / 126 * 2 - 1, y = (double)(code >> 7 & 127) / 126 * 2 - 1;
    double z = 1 - fabs(x) - fabs(y);
    if (z < 0) {
        double ox = (1 - fabs(y)) * (x >= 0 ? 1 : -1), oy = (1 - fabs(x)) * (y >= 0 ? 1 : -1);
        x = ox, y = oy;
    }
    double l = sqrt(x * x + y * y + z * z);
    n[0] = x / l, n[1] = y / l, n[2] = z / l;
}

double pn_leaf_plane_decode(uint32_t word, double m[3], double *offset)
{
    m[0] = m[1] = m[2] = 0;
    *offset = 0;
    if (!word)
        return 0;
    oct_decode(word & 0x3fff, m);
    *offset = ((double)(word >> 14 & 511) / 511 * 2 - 1) * HALF_DIAGONAL;
    return (double)(word >> 23) / 256;
}

uint32_t pn_leaf_plane_fit(const float (*tri)[9], const uint32_t *ids, uint32_t count, const double lo[3], double size,
                           double grow)
{
    if (count == 0)
        return 0;
    double clip_lo[3], clip_hi[3], mid[3];
    for (int k = 0; k < 3; k++) {
        clip_lo[k] = lo[k] - grow;
        clip_hi[k] = lo[k] + size + grow;
        mid[k] = lo[k] + 0.5 * size;
    }
    // Pass 0: the largest clipped piece, whose orientation the others take (a mesh's triangles need
    // not agree on their winding). Pass 1: the oriented sum of the pieces' area vectors (A m) and
    // their area-weighted centroid. Pass 2: the slab's half-thickness about the quantised plane.
    double ref[3] = {0, 0, 0}, best = -1, sum[3] = {0, 0, 0}, cen[3] = {0, 0, 0}, wsum = 0, m[3] = {0, 0, 0};
    double offq = 0, thick = 0;
    uint32_t code = 0;
    long oq = 0;
    for (int pass = 0; pass < 3; pass++) {
        if (pass == 2) {
            double len = sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
            // No area to fit: only degenerate pieces, or pieces that cancel (whose sum is left with
            // nothing but rounding, about 1e-16 of their areas in double; 1e-9 of the leaf's face
            // is far above that and far below any piece that can block a ray): the whole leaf.
            if (wsum <= 0 || !(len > 1e-9 * size * size))
                return PN_PLANE_SOLID;
            double nrm[3] = {sum[0] / len, sum[1] / len, sum[2] / len}, off = 0;
            code = oct_encode(nrm);
            oct_decode(code, m);
            for (int k = 0; k < 3; k++)
                off += m[k] * (cen[k] / wsum - mid[k]);
            oq = lround((fmax(-1, fmin(1, off / (HALF_DIAGONAL * size))) * 0.5 + 0.5) * 511);
            offq = ((double)oq / 511 * 2 - 1) * HALF_DIAGONAL * size;
        }
        for (uint32_t j = 0; j < count; j++) {
            double poly[CLIP_MAX][3], area[3];
            int n = clip_polygon(tri[ids[j]], clip_lo, clip_hi, poly, area);
            if (n < 0)
                return PN_PLANE_SOLID; // a piece the clip could not hold: no slab is known to hold it
            double a2 = area[0] * area[0] + area[1] * area[1] + area[2] * area[2];
            if (pass == 0 && a2 > best) {
                best = a2;
                memcpy(ref, area, sizeof ref);
            } else if (pass == 1) {
                double sign = area[0] * ref[0] + area[1] * ref[1] + area[2] * ref[2] < 0 ? -1 : 1, w = sqrt(a2);
                for (int k = 0; k < 3; k++) {
                    sum[k] += sign * area[k];
                    for (int q = 0; q < n; q++)
                        cen[k] += w / n * poly[q][k];
                }
                wsum += w;
            } else if (pass == 2) {
                for (int q = 0; q < n; q++) {
                    double dist = -offq;
                    for (int k = 0; k < 3; k++)
                        dist += m[k] * (poly[q][k] - mid[k]);
                    thick = fmax(thick, fabs(dist));
                }
            }
        }
    }
    // In 1/256 leaf, rounded up, plus one 1/256 of margin. (The shader's own rounding, which grows
    // with the coordinates' magnitude, is its traversal allowance eps, added there.) A slab as thick
    // as the leaf is wide holds all of it: solid.
    double tq = ceil(thick / size * 256) + 1;
    return tq >= 511 ? PN_PLANE_SOLID : code | (uint32_t)oq << 14 | (uint32_t)tq << 23;
}
