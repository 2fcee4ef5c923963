// Camera and light: defaults framed from the scene's bounds, light corners and irradiance.
#include "scene/view.h"

#include <math.h>
#include <string.h>

static void v3_normalize(float v[3])
{
    float l = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (l > 0)
        for (int k = 0; k < 3; k++)
            v[k] /= l;
}

static void bounds_sphere(const float lo[3], const float hi[3], float c[3], float *r)
{
    float d2 = 0;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5f * (lo[k] + hi[k]);
        d2 += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    }
    *r = 0.5f * sqrtf(d2);
    // A flat or point-like scene still needs a finite, positive framing radius.
    float mag = fmaxf(fmaxf(fabsf(c[0]), fabsf(c[1])), fabsf(c[2]));
    if (!(*r > mag * 0x1p-20f))
        *r = fmaxf(mag * 0x1p-20f, 1.0f);
}

void pn_camera_frame(const float lo[3], const float hi[3], float yfov_deg, pn_camera *out)
{
    float c[3], r;
    bounds_sphere(lo, hi, c, &r);
    float dir[3] = {0.45f, 0.55f, 1.0f}; // front, right and above: shows the ground's shadows
    v3_normalize(dir);
    float half = 0.5f * yfov_deg * 3.14159265f / 180.0f;
    float dist = 1.05f * r / sinf(half);
    for (int k = 0; k < 3; k++) {
        out->pos[k] = c[k] + dir[k] * dist;
        out->target[k] = c[k];
    }
    out->up[0] = 0, out->up[1] = 1, out->up[2] = 0;
    out->yfov_deg = yfov_deg;
}

void pn_light_default(const float lo[3], const float hi[3], pn_light *out)
{
    float c[3], r;
    bounds_sphere(lo, hi, c, &r);
    // Off to the side and a bounds radius above the top: shadows fall at an angle, long enough
    // to show their penumbrae; a light half the scene's size makes those penumbrae wide.
    out->pos[0] = c[0] + 0.5f * r;
    out->pos[1] = hi[1] + 1.0f * r;
    out->pos[2] = c[2] + 0.3f * r;
    for (int k = 0; k < 3; k++)
        out->normal[k] = c[k] - out->pos[k];
    v3_normalize(out->normal);
    out->up[0] = 0, out->up[1] = 0, out->up[2] = -1;
    out->size[0] = out->size[1] = 0.5f * r;
    // Radiance chosen so that the top centre of the bounds receives an irradiance of pi: a white
    // Lambertian surface there reflects a radiance of about 1, a good exposure for the preview.
    out->radiance[0] = out->radiance[1] = out->radiance[2] = 1.0f;
    double p[3] = {c[0], hi[1], c[2]}, n[3] = {0, 1, 0};
    double e = pn_light_irradiance(out, p, n);
    if (e > 0)
        for (int k = 0; k < 3; k++)
            out->radiance[k] = (float)(3.14159265358979 / e);
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
    if (!pn_light_frame(l, t, b)) {
        for (int i = 0; i < 4; i++)
            memcpy(q[i], l->pos, sizeof q[i]);
        return;
    }
    const float s[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++)
            q[i][k] = l->pos[k] + 0.5f * (s[i][0] * l->size[0] * t[k] + s[i][1] * l->size[1] * b[k]);
}

static double d3_dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

double pn_light_irradiance(const pn_light *l, const double p[3], const double n[3])
{
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
    // Clip the polygon (relative to p) to the receiver's upper hemisphere, n . x >= 0.
    double in[4][3], out[8][3];
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++)
            in[i][k] = (double)qf[i][k] - p[k];
    int m = 0;
    for (int i = 0; i < 4; i++) {
        const double *a = in[i], *b = in[(i + 1) % 4];
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
