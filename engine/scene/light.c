// The kinds of light (light.h): the table, corners, placing a sun, irradiance.
#include "scene/light.h"

#include <math.h>
#include <string.h>
#include <strings.h>

#include "interface.h"

static const pn_light_kind_info KINDS[PN_LIGHT_KIND_COUNT] = {
    [PN_LIGHT_RECT] = {"rect",
                       "uniform by area over the rectangle, within the box of its part above the receiver's horizon",
                       "Lambert's edge sum over the rectangle clipped to the receiver's hemisphere: exact; a point: "
                       "I cos(light) cos(receiver) / r^2",
                       "the rectangle", PN_LIGHT_RECT_ID, false},
    [PN_LIGHT_OMNI] = {"omni", "the point itself (one sample)",
                       "I cos(receiver) / r^2 times a spot's falloff: exact", "the point", PN_LIGHT_OMNI_ID, true},
    [PN_LIGHT_SUN] = {"sun",
                      "uniform by area over a disk 1e5 bounding radii away (concentric map of the square's strata): "
                      "directions within the angular diameter, to 1e-5 of it",
                      "E cos(receiver) at the disk's centre: exact while all of the disk is above the horizon",
                      "the scene's bounds and the far disk: any blocker in the scene", PN_LIGHT_SUN_ID, false},
    [PN_LIGHT_SPHERE] = {"sphere",
                         "uniform by solid angle over the cone the sphere subtends from the receiver (concentric map "
                         "of the square's strata), ending on the disk of its tangent circle",
                         "Snyder's closed form for a sphere, the part below the receiver's horizon cut off: exact",
                         "the sphere's bounding box", PN_LIGHT_SPHERE_ID, false},
    [PN_LIGHT_DISK] = {"disk", "uniform by area over the disk (concentric map of the square's strata)",
                       "Lambert's edge sum over a regular polygon of PN_LIGHT_DISK_SIDES sides and the disk's area, "
                       "clipped to the receiver's hemisphere (tests/test_light_kinds.c bounds its error)",
                       "the square round the disk", PN_LIGHT_DISK_ID, false},
};

const pn_light_kind_info *pn_light_kind_get(pn_light_kind kind)
{
    return (unsigned)kind < PN_LIGHT_KIND_COUNT ? &KINDS[kind] : NULL;
}

bool pn_light_kind_parse(const char *name, pn_light_kind *out)
{
    for (int k = 0; k < PN_LIGHT_KIND_COUNT; k++)
        if (strcasecmp(name, KINDS[k].name) == 0) {
            *out = (pn_light_kind)k;
            return true;
        }
    return false;
}

bool pn_light_frame(const pn_light *l, float t[3], float b[3])
{
    const float *n = l->normal;
    float nn = sqrtf(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(nn > 0))
        return false;
    float un[3] = {n[0] / nn, n[1] / nn, n[2] / nn};
    float d = l->up[0] * un[0] + l->up[1] * un[1] + l->up[2] * un[2];
    for (int k = 0; k < 3; k++)
        b[k] = l->up[k] - d * un[k];
    float bl = sqrtf(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    float ul = sqrtf(l->up[0] * l->up[0] + l->up[1] * l->up[1] + l->up[2] * l->up[2]);
    // up nearly parallel to the normal leaves no usable height axis.
    if (!(bl > 1e-4f * ul))
        return false;
    for (int k = 0; k < 3; k++)
        b[k] /= bl;
    // t = b x n, so that t x b = n.
    t[0] = b[1] * un[2] - b[2] * un[1];
    t[1] = b[2] * un[0] - b[0] * un[2];
    t[2] = b[0] * un[1] - b[1] * un[0];
    return true;
}

void pn_light_corners(const pn_light *l, float q[4][3])
{
    float t[3], b[3];
    // A point's and a sphere's corners are its centre (light_patch makes a sphere's per pixel).
    if (l->kind == PN_LIGHT_OMNI || l->kind == PN_LIGHT_SPHERE || !pn_light_frame(l, t, b)) {
        for (int i = 0; i < 4; i++)
            memcpy(q[i], l->pos, sizeof q[i]);
        return;
    }
    const float s[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    // A disk's square is its diameter wide, whatever its size says.
    float w = l->kind == PN_LIGHT_DISK ? 2 * l->radius : l->size[0], h = l->kind == PN_LIGHT_DISK ? 2 * l->radius : l->size[1];
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++)
            q[i][k] = l->pos[k] + 0.5f * (s[i][0] * w * t[k] + s[i][1] * h * b[k]);
}

static double d3_dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

bool pn_light_place_sun(pn_light *l, const float lo[3], const float hi[3])
{
    double c[3], r2 = 0, len = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * ((double)lo[k] + hi[k]);
        r2 += 0.25 * ((double)hi[k] - lo[k]) * ((double)hi[k] - lo[k]);
        len += (double)l->normal[k] * l->normal[k];
    }
    // Seen from a point of the bounds (within r of c) the disk's centre is off its direction from c
    // by at most r / D = 1e-5 radians: 1e-5 of the angular diameter as a fraction of a 1-radian one,
    // 0.1% of the sun's 0.53 degrees. Its points are float values of magnitude about D, an ulp of
    // D apart: 1.2e-7 D, a direction error of 1.2e-7 radians. A flat or point-like scene still gets
    // a distance (the framing's floor, view.c).
    double r = fmax(sqrt(r2), 1e-20 * fmax(fmax(fabs(c[0]), fabs(c[1])), fabs(c[2])));
    double D = 1e5 * (r > 0 ? r : 1.0);
    len = sqrt(len);
    if (!(len > 0) || !(D + fmax(fmax(fabs(c[0]), fabs(c[1])), fabs(c[2])) < 1e17))
        return false;
    for (int k = 0; k < 3; k++)
        l->pos[k] = (float)(c[k] - D * l->normal[k] / len);
    l->size[0] = l->size[1] = (float)(2.0 * D * tan(0.5 * (double)l->angle));
    return true;
}

void pn_light_reach(const pn_light *l, float pts[8][3])
{
    if (l->kind == PN_LIGHT_SPHERE) { // the corners of its bounding box
        for (int i = 0; i < 8; i++)
            for (int k = 0; k < 3; k++)
                pts[i][k] = l->pos[k] + ((i >> k) & 1 ? l->radius : -l->radius);
        return;
    }
    pn_light_corners(l, pts);
    memcpy(pts[4], pts, 4 * sizeof pts[0]);
}

double pn_light_sphere_irradiance(double cos_theta, double sin2_sigma)
{
    // Snyder (1996), as Lagarde and de Rousiers (2014) write it: pi sin^2 s cos t while the whole
    // cap is above the horizon (cos^2 t > sin^2 s), else the part above, in closed form.
    const double pi = 3.14159265358979323846;
    if (!(sin2_sigma > 0))
        return 0;
    if (cos_theta * cos_theta > sin2_sigma)
        return cos_theta > 0 ? pi * sin2_sigma * cos_theta : 0;
    double sin_theta = sqrt(fmax(1 - cos_theta * cos_theta, 0));
    double x = sqrt(1 / sin2_sigma - 1);
    double y = -x * cos_theta / sin_theta;
    double sy = sin_theta * sqrt(fmax(1 - y * y, 0));
    double e = (cos_theta * acos(fmin(fmax(y, -1), 1)) - x * sy) * sin2_sigma + atan(sy / x);
    return e > 0 ? e : 0;
}

double pn_light_spot(const pn_light *l, double c)
{
    if (l->kind != PN_LIGHT_OMNI || !(l->cone[1] > 0))
        return 1.0;
    double ci = cos((double)l->cone[0]), co = cos((double)l->cone[1]);
    double scale = 1.0 / fmax(0.001, ci - co);
    double a = fmin(fmax((c - co) * scale, 0.0), 1.0);
    return a * a;
}

double pn_light_range_window(const pn_light *l, double d)
{
    if (!(l->range > 0) || (l->kind != PN_LIGHT_OMNI && l->kind != PN_LIGHT_SPHERE))
        return 1.0;
    double x = d / l->range;
    return fmin(fmax(1 - x * x * x * x, 0.0), 1.0);
}

double pn_light_irradiance(const pn_light *l, const double p[3], const double n[3])
{
    if (l->kind == PN_LIGHT_SUN) { // per unit E: the sphere's form over its projected solid angle
        double ln[3] = {l->normal[0], l->normal[1], l->normal[2]};
        double c = -d3_dot(n, ln) / sqrt(d3_dot(ln, ln)), s = sin(0.5 * (double)l->angle);
        if (!(s > 0))
            return c > 0 ? c : 0;
        return pn_light_sphere_irradiance(c, s * s) / (3.14159265358979323846 * s * s);
    }
    if (l->kind == PN_LIGHT_SPHERE) { // per unit radiance
        double a[3] = {l->pos[0] - p[0], l->pos[1] - p[1], l->pos[2] - p[2]};
        double d2 = d3_dot(a, a), r2 = (double)l->radius * l->radius;
        if (!(d2 > r2))
            return 0; // inside the light
        return pn_light_sphere_irradiance(d3_dot(n, a) / sqrt(d2), r2 / d2) * pn_light_range_window(l, sqrt(d2));
    }
    if (l->kind == PN_LIGHT_OMNI) { // I cos(receiver) / r^2 times the spot's falloff, per unit I
        double to_p[3] = {p[0] - l->pos[0], p[1] - l->pos[1], p[2] - l->pos[2]};
        double r2 = d3_dot(to_p, to_p), cr = -d3_dot(n, to_p);
        if (!(cr > 0) || !(r2 > 0))
            return 0;
        double ln = sqrt((double)l->normal[0] * l->normal[0] + (double)l->normal[1] * l->normal[1] +
                         (double)l->normal[2] * l->normal[2]);
        double axis_cos = ln > 0 ? (to_p[0] * l->normal[0] + to_p[1] * l->normal[1] + to_p[2] * l->normal[2]) /
                                       (ln * sqrt(r2))
                                 : 1.0;
        return cr / (r2 * sqrt(r2)) * pn_light_spot(l, axis_cos) * pn_light_range_window(l, sqrt(r2));
    }
    float qf[4][3];
    pn_light_corners(l, qf);
    double ln[3] = {l->normal[0], l->normal[1], l->normal[2]};
    double to_p[3] = {p[0] - l->pos[0], p[1] - l->pos[1], p[2] - l->pos[2]};
    if (d3_dot(ln, to_p) <= 0) // one-sided: nothing behind or in the light's plane
        return 0;
    if (pn_light_is_point(l)) { // I cos(light) cos(receiver) / r^2, ln unit
        double r2 = d3_dot(to_p, to_p), cr = -d3_dot(n, to_p);
        return cr > 0 ? d3_dot(ln, to_p) * cr / (r2 * r2) : 0;
    }
    double in[PN_LIGHT_DISK_SIDES][3];
    int sides = 4;
    if (l->kind == PN_LIGHT_DISK) {
        // The regular polygon of the same area: radius r sqrt(a / sin a), a = 2 pi / sides.
        float t[3], bt[3];
        pn_light_frame(l, t, bt);
        sides = PN_LIGHT_DISK_SIDES;
        double a = 2 * 3.14159265358979323846 / sides, rr = (double)l->radius * sqrt(a / sin(a));
        for (int i = 0; i < sides; i++)
            for (int k = 0; k < 3; k++)
                in[i][k] = (double)l->pos[k] - p[k] + rr * (cos(a * i) * t[k] + sin(a * i) * bt[k]);
    } else {
        for (int i = 0; i < 4; i++)
            for (int k = 0; k < 3; k++)
                in[i][k] = (double)qf[i][k] - p[k];
    }
    // Clip the polygon (relative to p) to the receiver's upper hemisphere, n . x >= 0.
    double out[PN_LIGHT_DISK_SIDES + 4][3];
    int m = 0;
    for (int i = 0; i < sides; i++) {
        const double *a = in[i], *b = in[(i + 1) % sides];
        double da = d3_dot(n, a), db = d3_dot(n, b);
        if (da >= 0)
            memcpy(out[m++], a, sizeof out[0]);
        if ((da >= 0) != (db >= 0)) {
            double t = da / (da - db);
            for (int k = 0; k < 3; k++)
                out[m][k] = a[k] + t * (b[k] - a[k]);
            m++;
        }
    }
    // Lambert's edge sum: E/L = 1/2 sum_i angle(r_i, r_i+1) * (unit normal of the edge's plane . n).
    double sum = 0;
    for (int i = 0; i < m; i++) {
        const double *a = out[i], *b = out[(i + 1) % m];
        double c[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
        double cl = sqrt(d3_dot(c, c));
        if (cl > 0)
            sum += atan2(cl, d3_dot(a, b)) * d3_dot(c, n) / cl;
    }
    return 0.5 * fabs(sum);
}
