// The kinds of light as one table, as the shadow modes are (gpu/shadow_modes.h): for each, how a
// shadow ray's light sample is drawn, its unshadowed irradiance at a point, and the box its rays can
// reach. A new kind is a row, its sampling (shadow_common.glsl, light_warp), its irradiance (here
// and in light.glsl) and its tests. Every shadow mode takes every kind: they all draw their rays
// from the same samples over the same parallelogram (chunk_rays), and bound them by its corners.
#pragma once
#include <stdbool.h>

#include "scene/scene.h"

typedef struct pn_light_kind_info {
    const char *name;       // as --light and the EXR header spell it
    const char *sampling;   // how a ray's point on the light is drawn
    const char *irradiance; // how pn_light_irradiance computes the unshadowed irradiance, how exact
    const char *reach;      // the box its rays can reach (what a tree must keep)
    unsigned gpu_id;        // PN_LIGHT_*_ID (interface.h)
    bool point;             // every ray ends at one point: one sample, hard shadows
} pn_light_kind_info;

const pn_light_kind_info *pn_light_kind_get(pn_light_kind kind);

// The kind by its name; false if there is none.
bool pn_light_kind_parse(const char *name, pn_light_kind *out);

// A point: every ray ends at one point (OMNI, a rectangle of size 0, a sun of diameter 0): one
// sample gives V exactly.
static inline bool pn_light_is_point(const pn_light *l)
{
    return l->kind == PN_LIGHT_OMNI || (l->kind == PN_LIGHT_SUN && l->angle == 0) ||
           (l->kind == PN_LIGHT_RECT && l->size[0] == 0 && l->size[1] == 0);
}

// Orthonormal frame of the light: tangent (width axis) and bitangent (height axis) with
// cross(tangent, bitangent) = normal. Returns false when normal or up are degenerate.
bool pn_light_frame(const pn_light *l, float tangent[3], float bitangent[3]);

// The four corners of the parallelogram its samples lie in, counter-clockwise seen from the
// emitting side: a rectangle's own; a sun's, the square round its far disk; a point's, pos four
// times; a sphere's, its centre four times (each receiver point has its own square, light_patch).
void pn_light_corners(const pn_light *l, float corners[4][3]);

// Points whose hull holds every point a ray to the light can end at (the "reach" of the table):
// the four corners twice, or a sphere's bounding box.
void pn_light_reach(const pn_light *l, float pts[8][3]);

// Irradiance from a sphere of unit radiance subtending a cone of half-angle s (sin2_sigma = sin^2 s)
// whose axis makes angle t (cos_theta) with the receiver's normal, the part below the horizon cut
// off: Snyder's closed form. A sun is the same sphere far away.
double pn_light_sphere_irradiance(double cos_theta, double sin2_sigma);

// Places a sun for a scene with bounds lo..hi: its disk, seen from every point of the bounds at its
// angular diameter to 1e-5 of it, 1e5 bounding radii away against its direction of travel. False
// when the scene is too large for that to stay within float range (beyond 1e12 across).
bool pn_light_place_sun(pn_light *l, const float lo[3], const float hi[3]);

// Unshadowed irradiance at point p with unit normal n, per unit of l->radiance, double precision:
// RECT per unit radiance (polygon clipped to the receiver's upper hemisphere; zero behind the
// light), a RECT point per unit intensity, cos(light) cos(receiver) / r^2; OMNI per unit intensity,
// cos(receiver) / r^2 times a spot's falloff; SUN per unit of its irradiance, SPHERE per unit
// radiance: pn_light_sphere_irradiance (exact, the part below the horizon cut off).
double pn_light_irradiance(const pn_light *l, const double p[3], const double n[3]);

// KHR_lights_punctual's range window at distance d from the light's centre (the extension's
// recommended falloff, which the inverse square is multiplied by): clamp(1 - (d / range)^4, 0, 1),
// so the light fades to nothing at `range`. 1 without a range (0) and for the kinds that
// have none (only OMNI and SPHERE take one).
double pn_light_range_window(const pn_light *l, double d);

// A spot's falloff at the cosine c of the angle from its axis, as KHR_lights_punctual's reference
// has it: 1 inside the inner cone, 0 outside the outer, between them the square of the ramp linear
// in the cosine (its scale at most 1000). 1 without a cone.
double pn_light_spot(const pn_light *l, double c);
