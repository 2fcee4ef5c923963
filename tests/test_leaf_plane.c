// Leaf planes (accel/leaf_plane.h, ls-plane mode): the slab a word describes must hold every point of
// the leaf's triangles inside the leaf, since a ray that misses the slab is let through. Checked
// against points sampled on the triangles (a barycentric grid, the vertices and the edges), kept
// where they lie in the closed leaf box: an oracle that shares nothing with the fit's clipping.
//  - random soups of 1..12 triangles overlapping a leaf, at scales 1e-3..1e3 and offsets up to 1e4:
//    every sampled point within the decoded half-thickness of the decoded plane;
//  - flat leaves (triangles of one plane through the leaf): the normal is within 2 degrees of the
//    plane's (a 7+7-bit octahedral code), and the slab is thin: the tilt across the leaf's
//    half-diagonal, sin(2 deg) * sqrt(3)/2 = 0.030 leaf, plus the offset's quantum (sqrt(3)/511 / 2)
//    and two 1/256 of rounding up: at most 10/256 leaf;
//  - a triangle within the occupancy slack of the leaf is fitted as a thin slab, not a solid leaf;
//  - an empty leaf is 0; a leaf of degenerate triangles (no area) is solid.
#include <math.h>

#include "accel/leaf_plane.h"
#include "test_util.h"

static uint64_t rng = 0x9e3779b97f4a7c15ull;
static double uniform(void)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

// The largest distance of a sampled point of the triangles inside [lo, lo + size]^3 from the plane,
// in leaves, minus the word's half-thickness (> 0: a point outside the slab).
static double worst_excess(const float (*tri)[9], uint32_t count, const double lo[3], double size, uint32_t word)
{
    double m[3], off, thick = pn_leaf_plane_decode(word, m, &off), worst = -INFINITY;
    enum { G = 24 };
    for (uint32_t t = 0; t < count; t++)
        for (int i = 0; i <= G; i++)
            for (int j = 0; i + j <= G; j++) {
                double a = (double)i / G, b = (double)j / G, p[3];
                bool inside = true;
                for (int k = 0; k < 3; k++) {
                    p[k] = (1 - a - b) * tri[t][k] + a * tri[t][3 + k] + b * tri[t][6 + k];
                    inside = inside && p[k] >= lo[k] && p[k] <= lo[k] + size;
                }
                if (!inside)
                    continue;
                double dist = -off;
                for (int k = 0; k < 3; k++)
                    dist += m[k] * ((p[k] - lo[k]) / size - 0.5);
                worst = fmax(worst, fabs(dist) - thick);
            }
    return worst;
}

int main(void)
{
    // Random soups.
    int solid = 0, cases = 3000;
    double worst = -INFINITY;
    for (int c = 0; c < cases; c++) {
        double size = pow(10, -3 + 6 * uniform()), lo[3];
        for (int k = 0; k < 3; k++)
            lo[k] = (uniform() - 0.5) * 2e4 * (c % 2);
        uint32_t count = 1 + (uint32_t)(uniform() * 12), ids[12];
        float tri[12][9];
        for (uint32_t t = 0; t < count; t++) {
            ids[t] = t;
            // Vertices around the leaf (from -0.5 to 1.5 leaves), so triangles are clipped.
            for (int v = 0; v < 3; v++)
                for (int k = 0; k < 3; k++)
                    tri[t][3 * v + k] = (float)(lo[k] + size * (2 * uniform() - 0.5));
        }
        uint32_t w = pn_leaf_plane_fit((const float(*)[9])tri, ids, count, lo, size, 0);
        solid += w == PN_PLANE_SOLID;
        double e = worst_excess((const float(*)[9])tri, count, lo, size, w);
        worst = fmax(worst, e);
        CHECK_MSG(e <= 1e-6, "soup %d (%u triangles, leaf %g at %g): a point %g leaves outside the slab", c, count,
                  size, lo[0], e);
    }
    fprintf(stderr, "soups: %d leaves, %d solid, worst excess %.3g leaves (<= 0: inside)\n", cases, solid, worst);
    CHECK_MSG(solid < cases, "every soup came out solid: the fit never produced a plane");

    // Flat leaves: a grid of triangles on a random plane through the leaf.
    double worst_thick = 0, worst_angle = 0;
    for (int c = 0; c < 1000; c++) {
        double size = pow(10, -2 + 4 * uniform()), lo[3] = {1e3 * uniform(), -50, 3}, n[3], u[3], v[3], centre[3];
        double z = 2 * uniform() - 1, phi = 6.283185307179586 * uniform(), r = sqrt(1 - z * z);
        n[0] = r * cos(phi), n[1] = r * sin(phi), n[2] = z;
        double a[3] = {fabs(n[0]) < 0.9 ? 1 : 0, fabs(n[0]) < 0.9 ? 0 : 1, 0};
        u[0] = n[1] * a[2] - n[2] * a[1], u[1] = n[2] * a[0] - n[0] * a[2], u[2] = n[0] * a[1] - n[1] * a[0];
        double ul = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (int k = 0; k < 3; k++)
            u[k] /= ul;
        v[0] = n[1] * u[2] - n[2] * u[1], v[1] = n[2] * u[0] - n[0] * u[2], v[2] = n[0] * u[1] - n[1] * u[0];
        for (int k = 0; k < 3; k++)
            centre[k] = lo[k] + size * (0.3 + 0.4 * uniform());
        float tri[8][9];
        uint32_t ids[8];
        for (int t = 0; t < 8; t++) {
            ids[t] = (uint32_t)t;
            int gx = t / 2 % 2, gy = t / 4, upper = t % 2;
            double c0[2] = {gx - 1.0, gy - 1.0};
            double q[3][2] = {{c0[0], c0[1]}, {c0[0] + 1, c0[1] + upper}, {c0[0] + !upper, c0[1] + 1}};
            for (int vtx = 0; vtx < 3; vtx++)
                for (int k = 0; k < 3; k++)
                    tri[t][3 * vtx + k] = (float)(centre[k] + 1.2 * size * (q[vtx][0] * u[k] + q[vtx][1] * v[k]));
        }
        uint32_t w = pn_leaf_plane_fit((const float(*)[9])tri, ids, 8, lo, size, 0);
        double m[3], off, thick = pn_leaf_plane_decode(w, m, &off);
        double cosang = fabs(m[0] * n[0] + m[1] * n[1] + m[2] * n[2]), angle = acos(fmin(1, cosang)) * 57.29577951308232;
        worst_thick = fmax(worst_thick, thick);
        worst_angle = fmax(worst_angle, angle);
        CHECK_MSG(w != PN_PLANE_SOLID && thick <= 10.0 / 256, "flat leaf %d: half-thickness %g leaves", c, thick);
        CHECK_MSG(angle <= 2.0, "flat leaf %d: normal %g degrees off", c, angle);
        CHECK_MSG(worst_excess((const float(*)[9])tri, 8, lo, size, w) <= 1e-6, "flat leaf %d: a point outside", c);
    }
    fprintf(stderr, "flat: half-thickness at most %.4f leaves, normal within %.2f degrees\n", worst_thick, worst_angle);

    // A triangle that filled the leaf only within the occupancy test's slack (4 ulps above its top
    // face) is fitted, clipped to the grown box, not taken for a solid leaf.
    double lo[3] = {0, 0, 0}, slack = 4 * 0x1p-23;
    float above[1][9] = {{-1, -1, 1.0000001f, 3, -1, 1.0000001f, -1, 3, 1.0000001f}};
    uint32_t id0 = 0, w_above = pn_leaf_plane_fit((const float(*)[9])above, &id0, 1, lo, 1.0, slack);
    double m_above[3], off_above, thick_above = pn_leaf_plane_decode(w_above, m_above, &off_above);
    CHECK_MSG(w_above != PN_PLANE_SOLID && thick_above <= 2.0 / 256 && fabs(fabs(m_above[2]) - 1) < 1e-12,
              "a triangle within the slack gave word %08x (half-thickness %g)", w_above, thick_above);

    // Empty and degenerate leaves.
    CHECK(pn_leaf_plane_fit(NULL, NULL, 0, lo, 1.0, 0) == 0);
    float line[2][9] = {{0.1f, 0.1f, 0.1f, 0.5f, 0.5f, 0.5f, 0.9f, 0.9f, 0.9f},  // collinear
                        {0.2f, 0.5f, 0.5f, 0.2f, 0.5f, 0.5f, 0.2f, 0.5f, 0.5f}}; // one point
    uint32_t ids[2] = {0, 1};
    CHECK(pn_leaf_plane_fit((const float(*)[9])line, ids, 2, lo, 1.0, 0) == PN_PLANE_SOLID);
    return pn_test_result();
}
