// Per-object line spaces (--trees object): every mesh of the scene gets its own N-tree and line
// spaces, built once in the mesh's own frame and shared by all its instances; the triangles that no
// object holds (a --ground plane, a built-in scene) form one more tree, in world space. A top level,
// a BVH over the objects' world boxes, finds the objects a shadow ray may meet, and the ray is
// carried into each one's frame (shadow_linespace.comp). Moving an object rebuilds the top level
// only (pn_objects_update), never a line space.
//
// The trees are not culled by light or view (the scene-wide tree's cull_light and keep_box): a
// mesh's tree must serve every instance wherever it stands and whatever lights it.
//
// Model only what moves: in an animated scene (scene/anim.h) only the objects an animation moves
// get trees of their own; the still ones join the triangles of no object in the one world-space
// tree, so that a frame costs a top-level rebuild. In a scene without animation every object gets
// one (any may be moved by hand).
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "accel/bvh.h"
#include "accel/ntree.h"
#include "accel/pools.h"
#include "interface.h"
#include "scene/scene.h"

// One instance: which tree, the map into its frame and its box in world space.
typedef struct pn_object_instance {
    uint32_t tree;           // into pn_objects.trees
    float to_local[3][4];    // world -> the tree's frame (rows of an affine map)
    float box[6];            // world-space box of its triangles (lo xyz, hi xyz)
    double world_leaf;       // the largest extent along a world axis of one of its tree's leaves
    uint32_t object;         // into the scene's objects (its object_count for the rest)
    double inv_rows;         // the largest row sum of |to_local|'s linear part: how much a world
                             // coordinate's rounding grows carried into the tree's frame
} pn_object_instance;

typedef struct pn_objects {
    uint32_t tree_count;      // the scene's meshes, plus one for the rest when there is any
    pn_ntree *trees;
    pn_pools *pools;
    uint32_t instance_count;  // the scene's objects, plus the rest's
    pn_object_instance *instances; // the first `placed` are in use: those not left out as flat
    uint32_t placed;
    pn_bvh top;               // over the instances' boxes
    pn_pool_bytes bytes;      // of every tree's pools together
    uint64_t top_bytes;       // object table, top BVH and its index list
    uint32_t culled;          // triangles of no object left out (they cannot block a shadow ray)
    // What they were judged against (pn_ntree_can_block): the scene's bounds at build and the
    // lights' corners; pn_objects_cull_holds asks again after objects moved.
    float cull_box[6];
    float cull_light[8 * PN_MAX_LIGHTS][3];
    uint32_t cull_light_corners;
    double leaf_size;         // the smallest world_leaf: rays rise clear of their surface by it, and
                              // by world_leaf before the instance's own tree may block them
    double build_ms;          // trees, line spaces and top level
    double update_ms;         // the last top-level rebuild alone (instances and BVH)
} pn_objects;

// Builds one tree per mesh (desc: N, d, size limits) and the top level. The triangles of no object
// are culled as pn_ntree_build does with desc's lights (their tree is the scene's own, not shared):
// a ground plane under everything is left out. desc's keep_box is ignored (objects move). Logs and leaves *out zeroed on failure.
pn_result pn_objects_build(const pn_scene *scene, const pn_ntree_desc *desc, pn_objects *out);

// Recomputes every instance's map and box from the scene's object transforms and rebuilds the top
// level: what a moving object costs. The trees stay.
pn_result pn_objects_update(const pn_scene *scene, pn_objects *objects);

// Whether the rest's culling still holds for the scene as it stands, after objects moved: every
// triangle of no object left out at build must still have the scene's bounds and the lights on one
// closed side of its plane. Moving objects changes neither the rest's triangles nor the lights, only
// the bounds, and an object moved across such a plane (under the ground) could meet rays the
// left-out triangle would block. False: rebuild (pn_objects_build) before drawing the moved scene.
// O(1) while the bounds stay within those of the build, else one test per triangle of no object.
bool pn_objects_cull_holds(const pn_scene *scene, const pn_objects *objects);

// Whether object `object`'s tree would still resolve its leaves in float with the object's world
// box reaching `world_mag` from the origin (the rule pn_objects_update enforces): the demo asks it
// before moving an object, since a float move does not undo exactly. True for an object left out
// (flat) or not found.
bool pn_objects_resolves(const pn_objects *objects, uint32_t object, float world_mag);

void pn_objects_destroy(pn_objects *objects);
