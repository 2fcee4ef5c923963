// Triangles in Morton order of their centroids, as flat vertex triples: the input of a device-built
// acceleration structure. Some builders (Mesa 25's lavapipe) split their input at the middle index
// without sorting, so the order decides the tree's quality (engine/gpu/llvmpipe.md).
#pragma once
#include <stdint.h>

#include "core/error.h"
#include "scene/scene.h"

// *xyz: 9 floats per triangle (three vertices), triangles sorted by the 30-bit Morton code of their
// centroid in the scene's bounds (ties in scene order); *order: the scene's triangle index of each
// (may be NULL). Both malloc'd. PN_ERR_MEMORY on failure, with nothing allocated.
pn_result pn_triangles_morton(const pn_scene *scene, float **xyz, uint32_t **order, uint32_t *count);
