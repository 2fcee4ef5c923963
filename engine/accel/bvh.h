// A bounding volume hierarchy over the scene's triangles for exact shadow rays: built on the CPU
// with binned SAH, flattened depth-first for the GPU (after Aila and Laine's GPU traversal).
#pragma once
#include <stdint.h>

#include "core/error.h"
#include "interface.h"
#include "scene/scene.h"

// pn_bvh_node (32 bytes, shared with the shaders): interface.h.
//   count == 0: interior; its children are nodes first and first + 1.
//   count > 0:  leaf; triangles tri_index[first .. first + count).

typedef struct pn_bvh {
    pn_bvh_node *nodes;
    uint32_t node_count;
    uint32_t *tri_index; // triangle ids (scene order) in leaf order
    uint32_t triangles;
    uint32_t depth;      // longest root-to-leaf path, in nodes
    double build_ms;
} pn_bvh;

// Builds over all of the scene's triangles, multi-threaded. Degenerate triangles are kept (a
// segment or a point can still be grazed) and never break the build. The nodes and the triangle
// order are the same bytes on any number of threads (tests/test_determinism_pools.c).
pn_result pn_bvh_build(const pn_scene *scene, pn_bvh *out);
// The same over n boxes (lo xyz, hi xyz) instead of triangles: tri_index holds box indices (the
// per-object trees' top level, accel/objects.h).
pn_result pn_bvh_build_boxes(const float (*box)[6], uint32_t n, pn_bvh *out);
void pn_bvh_destroy(pn_bvh *bvh);

// Triangle vertices in scene order, 3 x vec4 per triangle (w = 0, but for an alpha-masked
// triangle's first vertex, whose w holds its mask record: accel/alpha.h, which follows them): the
// GPU's triangle pool.
pn_result pn_triangle_pool(const pn_scene *scene, float **out, uint64_t *bytes);
