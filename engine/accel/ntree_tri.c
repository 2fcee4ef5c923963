// The triangle tests of the N-tree build (ntree.h): a triangle against a cell (closed overlap), and
// whether a triangle can block any segment of the scene or to its lights (culling).
#include <math.h>

#include "accel/ntree.h"

// Triangle-box overlap (Akenine-Moller 2001), closed: touching counts as overlapping.

static bool axis_separates(const double v0[3], const double v1[3], const double v2[3], const double a[3],
                           const double h[3])
{
    double p0 = v0[0] * a[0] + v0[1] * a[1] + v0[2] * a[2];
    double p1 = v1[0] * a[0] + v1[1] * a[1] + v1[2] * a[2];
    double p2 = v2[0] * a[0] + v2[1] * a[1] + v2[2] * a[2];
    double mn = fmin(p0, fmin(p1, p2)), mx = fmax(p0, fmax(p1, p2));
    double r = h[0] * fabs(a[0]) + h[1] * fabs(a[1]) + h[2] * fabs(a[2]);
    return mn > r || mx < -r; // a zero axis gives 0 > 0: never separates
}

bool pn_tri_box_overlap(const double tv[3][3], const double lo[3], const double hi[3])
{
    double c[3], h[3], v[3][3];
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * (lo[k] + hi[k]);
        h[k] = 0.5 * (hi[k] - lo[k]);
    }
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++)
            v[i][k] = tv[i][k] - c[k];
    // Box face normals: the triangle's bounds against the box.
    for (int k = 0; k < 3; k++) {
        double mn = fmin(v[0][k], fmin(v[1][k], v[2][k])), mx = fmax(v[0][k], fmax(v[1][k], v[2][k]));
        if (mn > h[k] || mx < -h[k])
            return false;
    }
    double e[3][3];
    for (int k = 0; k < 3; k++) {
        e[0][k] = v[1][k] - v[0][k];
        e[1][k] = v[2][k] - v[1][k];
        e[2][k] = v[0][k] - v[2][k];
    }
    // Edge x box axis: 9 axes.
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) {
            double axis[3] = {0, 0, 0}, unit[3] = {0, 0, 0};
            unit[k] = 1;
            axis[0] = e[i][1] * unit[2] - e[i][2] * unit[1];
            axis[1] = e[i][2] * unit[0] - e[i][0] * unit[2];
            axis[2] = e[i][0] * unit[1] - e[i][1] * unit[0];
            if (axis_separates(v[0], v[1], v[2], axis, h))
                return false;
        }
    // The triangle's plane.
    double nrm[3] = {e[0][1] * e[1][2] - e[0][2] * e[1][1], e[0][2] * e[1][0] - e[0][0] * e[1][2],
                     e[0][0] * e[1][1] - e[0][1] * e[1][0]};
    return !axis_separates(v[0], v[1], v[2], nrm, h);
}

// Can triangle v block a segment between two points of the scene, or between one and a light?
// Not if its plane has the scene's bounds and all the lights (`corners` points) on one closed side:
// such a segment then stays in that closed half-space and meets the plane at most where it starts,
// on the plane. With several lights the plane must have them all on that side, or a ray to one of
// them could cross it: the tree is then the same for every light of the set.
bool pn_ntree_can_block(const float v[9], const float lo[3], const float hi[3], const float (*light)[3],
                        uint32_t corners)
{
    double e0[3], e1[3], n[3];
    for (int k = 0; k < 3; k++) {
        e0[k] = (double)v[3 + k] - v[k];
        e1[k] = (double)v[6 + k] - v[k];
    }
    n[0] = e0[1] * e1[2] - e0[2] * e1[1];
    n[1] = e0[2] * e1[0] - e0[0] * e1[2];
    n[2] = e0[0] * e1[1] - e0[1] * e1[0];
    if (n[0] == 0 && n[1] == 0 && n[2] == 0)
        return true; // degenerate: no plane to argue with
    bool below = false, above = false;
    for (uint32_t i = 0; i < 8 + corners; i++) {
        double x[3];
        for (int k = 0; k < 3; k++)
            x[k] = i < 8 ? ((i >> k) & 1 ? hi[k] : lo[k]) : light[i - 8][k];
        double side = n[0] * (x[0] - v[0]) + n[1] * (x[1] - v[1]) + n[2] * (x[2] - v[2]);
        below = below || side < 0;
        above = above || side > 0;
    }
    return below && above;
}
