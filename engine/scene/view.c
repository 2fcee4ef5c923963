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
    *out = (pn_light){0}; // a rectangle
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

