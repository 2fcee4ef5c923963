// Camera and light defaults derived from the scene's bounds (the lights themselves: light.h).
#pragma once
#include "scene/light.h"
#include "scene/scene.h"

// Frames the bounds: looks at their centre from the front and above (+Z, +Y; glTF's +Y is up)
// from a distance at which the bounding sphere fits the field of view.
void pn_camera_frame(const float bmin[3], const float bmax[3], float yfov_deg, pn_camera *out);

// A light above the bounds, tilted towards their centre, large enough to cast wide penumbrae, with
// a radiance that gives an irradiance of about pi at the top of the bounds.
void pn_light_default(const float bmin[3], const float bmax[3], pn_light *out);
