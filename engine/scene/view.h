// Camera and area light: parameters, defaults derived from the scene's bounds, and the geometry
// both the CPU and the shaders need.
#pragma once
#include "scene/scene.h"

static inline bool pn_light_is_point(const pn_light *l) { return l->size[0] == 0 && l->size[1] == 0; }

// Frames the bounds: looks at their centre from the front and above (+Z, +Y; glTF's +Y is up)
// from a distance at which the bounding sphere fits the field of view.
void pn_camera_frame(const float bmin[3], const float bmax[3], float yfov_deg, pn_camera *out);

// A light above the bounds, tilted towards their centre, large enough to cast wide penumbrae, with
// a radiance that gives an irradiance of about pi at the top of the bounds.
void pn_light_default(const float bmin[3], const float bmax[3], pn_light *out);

// Orthonormal frame of the light: tangent (width axis) and bitangent (height axis) with
// cross(tangent, bitangent) = normal. Returns false when normal or up are degenerate.
bool pn_light_frame(const pn_light *l, float tangent[3], float bitangent[3]);

// The four corners, counter-clockwise seen from the emitting side.
void pn_light_corners(const pn_light *l, float corners[4][3]);

// Exact irradiance per unit radiance at point p with unit normal n from the one-sided emitter
// (polygon clipped to the receiver's upper hemisphere; zero behind the light). Double precision.
// For a point light, per unit intensity: cos(light) cos(receiver) / r^2.
double pn_light_irradiance(const pn_light *l, const double p[3], const double n[3]);
