// The default view of a scene that encloses its own centre (an atrium, a church, a room): the
// camera inside at eye height looking along the longest open direction, the light where it lights
// what the camera sees. Found by casting a few rays on the CPU against every triangle.
#pragma once
#include <stdbool.h>

#include "scene/scene.h"

// Probe directions from the bounds' centre. A scene is an interior when at least
// PN_INTERIOR_ENCLOSED of them hit a surface that faces the centre (the inside of a room; the inside
// of a closed object such as the bunny faces away and does not count), and as many of the level
// ones (|y| <= 1/2): walls all round. The default scene has its ground below and a slab above its
// centre (0.75 of all directions) but open sides (0.53 of the level ones).
enum { PN_INTERIOR_PROBES = 64 };
#define PN_INTERIOR_ENCLOSED 0.75f

// The eye's height as a fraction of the clear height from the floor to the ceiling. The room is the
// only scale a file gives: glTF's unit is the metre, but the conference room is in centimetres.
#define PN_INTERIOR_EYE 0.25f

typedef struct pn_interior {
    float enclosed;   // the fraction of probe directions that hit a surface facing the centre
    float walled;     // the same of the level ones
    bool is_interior; // both >= PN_INTERIOR_ENCLOSED, and a floor below the centre
    // With is_interior only:
    float floor_y, ceiling_y; // below and above the camera; ceiling_y = bounds top when open
    bool open_above;          // no ceiling over the camera (Sponza's atrium): the light goes above
    pn_camera camera;         // yfov as given
    pn_light light;           // radiance for an irradiance of pi on the floor below the light
} pn_interior;

// Looks for an interior around the centre of s's bounds. Cost: about 100 rays against every
// triangle (0.1 s per million triangles on 2 cores).
void pn_interior_find(const pn_scene *s, float yfov_deg, pn_interior *out);
