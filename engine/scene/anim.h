// Animated scenes: a scene file's node hierarchy and its glTF animations (node translation,
// rotation and scale; LINEAR, STEP and CUBICSPLINE), kept so that the scene can be placed at
// another time without loading it again (pn_scene_pose). What an animation moves is kept in its
// node's frame: the objects under an animated node (their primitives' local vertices), the
// punctual lights and the camera on one. The rest of the scene stays as loaded.
//
// Times outside an animation's keys take its first or last key. Every animation of the file plays
// at once (exporters write one per object), from time 0 in the file's seconds.
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "scene/scene.h"

typedef enum pn_anim_path { PN_ANIM_TRANSLATION, PN_ANIM_ROTATION, PN_ANIM_SCALE } pn_anim_path;
typedef enum pn_anim_interp { PN_ANIM_LINEAR, PN_ANIM_STEP, PN_ANIM_CUBICSPLINE } pn_anim_interp;

// One animation channel: a node's translation, rotation or scale over time.
typedef struct pn_anim_channel {
    uint32_t node;
    pn_anim_path path;
    pn_anim_interp interp;
    uint32_t keys;
    float *times;  // keys, finite and strictly increasing
    float *values; // keys x 3 (4 for a rotation, x,y,z,w), finite; CUBICSPLINE: keys x 3 of them
                   // (in-tangent, value, out-tangent), as glTF stores them
} pn_anim_channel;

// A node of the file: its parent and its rest transform (what the file says without animation).
typedef struct pn_anim_node {
    int32_t parent; // -1: a root of the scene (or not in it)
    bool matrix;    // the file gives a matrix (m), which animations may not target
    double m[16];   // column-major, as glTF: with `matrix`
    double t[3], r[4], s[3]; // translation, rotation (x,y,z,w), scale: without it
    bool posed;     // it or an ancestor is animated or given a transform: pn_scene_pose places it
} pn_anim_node;

// A primitive of an object under a posed node, in its node's frame: what pn_scene_pose transforms
// into the scene's vertices [first_vertex, first_vertex + its vertex count (3 per triangle
// without normals)).
typedef struct pn_anim_prim {
    uint32_t node;
    uint32_t object; // into pn_scene.objects
    uint32_t first_vertex;
    float *positions, *normals, *uvs; // vertex_count x 3, x 3 or NULL, x 2 or NULL
    uint32_t *triangles;              // triangle_count x 3, the winding as the scene has it
    uint32_t vertex_count, triangle_count;
    bool mirrored; // its transform mirrored at load (the winding was swapped): a pose must too
} pn_anim_prim;

struct pn_scene_anim {
    pn_anim_node *nodes; // the file's nodes, by their index
    uint32_t node_count;
    uint32_t *order; // the scene's nodes, parents before children
    uint32_t order_count;
    pn_anim_channel *channels;
    uint32_t channel_count;
    pn_anim_prim *prims;
    uint32_t prim_count;
    int32_t light_node[PN_SCENE_MAX_LIGHTS]; // the node of pn_scene.lights[i] if a punctual light, else -1
    int32_t camera_node;                     // the node of pn_scene.camera, or -1
    double start, end;                       // the first and last key time of every channel
};

// A node's local matrix from translation, rotation (a quaternion, normalised here: exporters round)
// and scale, T R S, column-major. False if the quaternion is zero or not finite.
bool pn_trs_matrix(const double t[3], const double q[4], const double s[3], double m[16]);

// out = a b, column-major 4x4 (out may not alias a or b).
void pn_mat4_mul(const double a[16], const double b[16], double out[16]);

// A node's frame from its world transform: its origin, its -Z axis (where glTF's cameras and
// lights look) and its +Y axis, both normalised. False if either has no direction.
bool pn_node_frame(const double w[16], double pos[3], double fwd[3], double up[3]);

// The value of channel c at `time` (3 numbers, 4 for a rotation): LINEAR interpolates (a rotation
// by slerp), STEP holds the key before, CUBICSPLINE is glTF's Hermite spline (a rotation then
// normalised); before the first key the first, after the last the last. At a key's own time, the
// key's value exactly.
void pn_anim_sample(const pn_anim_channel *c, double time, double out[4]);

// What pn_scene_pose changed, for the renderers and the report.
typedef struct pn_pose_report {
    uint32_t first_vertex, end_vertex; // the scene's vertices it rewrote, [first, end); empty: none
    uint32_t objects;                  // objects placed
    double ms;                         // CPU time
} pn_pose_report;

// Places every posed node's objects, lights and camera at `time` (seconds; NAN: the rest
// transforms, with the overrides of pn_scene_set_node_transform): their world vertices, object
// transforms, the scene's lights and camera, and the bounds. A scene without animation data is
// left as it is. PN_ERR_INVALID (logged) when a pose mirrors a primitive that was not mirrored at
// load, or the reverse (its winding would face inside out), or moves a vertex out of float range.
pn_result pn_scene_pose(pn_scene *s, double time, pn_pose_report *report);

// Gives node `node` this rest translation, rotation and scale (a --node-transform), replacing the
// file's. PN_ERR_INVALID (logged) for a node the scene does not pose (no animation reaches it: its
// objects were not kept in its frame) or one given as a matrix.
pn_result pn_scene_set_node_transform(pn_scene *s, uint32_t node, const double t[3], const double r[4],
                                      const double scale[3]);

// Whether the scene has animation channels.
static inline bool pn_scene_animated(const pn_scene *s) { return s->anim && s->anim->channel_count > 0; }

// Frees the animation and everything it holds (scene.c, beside pn_scene_destroy, which calls it).
void pn_scene_anim_destroy(pn_scene_anim *a);
