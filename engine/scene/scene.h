// The scene as every stage sees it: one indexed triangle list in world space, split into draws by
// material, plus materials, decoded textures, an optional camera and the bounds.
#pragma once
#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "core/error.h"

typedef struct pn_vertex {
    float pos[3];    // world space
    float normal[3]; // world space, unit length
    float uv[2];     // TEXCOORD_0, or 0
} pn_vertex;

typedef struct pn_material {
    float base_color[4]; // glTF baseColorFactor, linear (default 1,1,1,1)
    int32_t texture;     // index into pn_scene.textures for baseColorTexture, or -1
    // Alpha-masked (glTF alphaMode MASK, and BLEND taken as MASK at 0.5): the surface is cut out
    // where base_color[3] x the texture's alpha is below this; 0: opaque.
    float alpha_cutoff;
    // Both sides drawn whatever the view (glTF doubleSided true; every material made in code). A
    // single-sided one (glTF's default) lets the G-buffer cull back faces where that cannot open
    // a surface (gpu/gbuffer_cull.h); elsewhere its back faces are drawn too.
    bool double_sided;
} pn_material;

typedef struct pn_texture {
    uint32_t width, height;
    uint8_t *rgba; // width*height*4 bytes, sRGB-encoded as glTF stores base colour
} pn_texture;

// A contiguous range of the index buffer drawn with one material.
typedef struct pn_draw {
    uint32_t first_index;
    uint32_t index_count;
    uint32_t material;
} pn_draw;

typedef struct pn_camera {
    float pos[3];
    float target[3];
    float up[3];
    float yfov_deg; // vertical field of view
} pn_camera;

// The kinds of light (scene/light.h holds their table: sampling, irradiance, reach).
typedef enum pn_light_kind {
    PN_LIGHT_RECT, // a one-sided Lambertian rectangle; size 0,0: a point emitting as one (cosine lobe)
    PN_LIGHT_OMNI, // a point emitting the same intensity every way (glTF's point), or into a cone (spot)
    PN_LIGHT_SUN,  // a directional light with an angular diameter (glTF's directional)
    PN_LIGHT_SPHERE, // a sphere of uniform radiance (glTF's point with a radius)
    PN_LIGHT_DISK,   // a one-sided Lambertian disk
    PN_LIGHT_KIND_COUNT
} pn_light_kind;

// One light. Zero-initialised fields give a rectangle (the kind every option and file had first).
typedef struct pn_light {
    float pos[3];      // centre (SUN: placed by pn_light_place_sun, far beyond the scene)
    float normal[3];   // unit; the side it emits to (OMNI: a spot's axis; SUN: the light's direction of travel)
    float up[3];       // orients the height axis (projected onto the light's plane)
    float size[2];     // width, height: both positive, or both 0 (a point). SUN: its far disk's square
    float radiance[3]; // emitted radiance, linear RGB; for a point, radiant intensity (W/sr: for RECT
                       // the limit of radiance x area along the normal, falling off with the cosine);
                       // SUN: the irradiance on a plane facing it (as glTF's lux)
    pn_light_kind kind;
    float angle;   // SUN: angular diameter, radians (0.53 degrees is the sun's)
    float cone[2]; // OMNI: a spot's inner and outer cone half-angles, radians; 0, 0: no cone
    float radius;  // SPHERE, DISK: the radius (pos the centre; a disk's size is the square round it)
    float range;   // OMNI, SPHERE: KHR_lights_punctual's range, where the light fades out (its
                   // window, pn_light_range_window); 0: it reaches everywhere
} pn_light;

// A mesh in its own frame, as a scene file's nodes instance it: the triangles' positions as a soup
// (3 per triangle), in the order each instance's triangles have in the world-space list. The
// per-object N-trees (--trees object) are built over these, once per mesh, whatever its instances.
typedef struct pn_scene_mesh {
    float (*tris)[3][3];
    uint32_t triangle_count;
} pn_scene_mesh;

// One instance of a mesh: a glTF node with a mesh. Its triangles are also in the world-space list
// (the raster pass and the exact modes read that), with vertices of their own.
typedef struct pn_scene_object {
    uint32_t mesh;             // into pn_scene.meshes
    uint32_t node;             // the glTF node, for messages
    float to_world[3][4];      // local -> world: x_world[r] = to_world[r][0..2] . x + to_world[r][3]
    uint32_t first_index, index_count;   // its triangles in pn_scene.indices
    uint32_t first_vertex, vertex_count; // and the vertices they use
} pn_scene_object;

// Lights a scene file may carry (glTF node extras, scene/gltf.cpp); a frame has at most as many.
enum { PN_SCENE_MAX_LIGHTS = 16 };

// A scene file's node hierarchy and animations (scene/anim.h).
typedef struct pn_scene_anim pn_scene_anim;

typedef struct pn_scene {
    char name[256]; // the file path or "builtin:NAME"
    pn_vertex *vertices;
    uint32_t vertex_count;
    uint32_t *indices; // triangle list, index_count = 3 * triangle count
    uint32_t index_count;
    pn_draw *draws;
    uint32_t draw_count;
    pn_material *materials;
    uint32_t material_count;
    pn_texture *textures;
    uint32_t texture_count;
    bool has_camera; // the file's first camera, if it had one
    pn_camera camera;
    // The file's lights, in node order: KHR_lights_punctual's, and area lights in node extras
    // ("penumbra_light", engine/apps/README.md).
    uint32_t light_count;
    pn_light lights[PN_SCENE_MAX_LIGHTS];
    float bounds_min[3], bounds_max[3]; // of all vertices that are referenced by a triangle
    // The instancing structure of a scene file (glTF nodes with a mesh, in traversal order), for
    // per-object trees. Built-in scenes have none: they count as one object, the whole scene.
    pn_scene_mesh *meshes;
    uint32_t mesh_count;
    pn_scene_object *objects;
    uint32_t object_count;
    // With glTF animations: the nodes, channels and what they move, kept in the nodes' frames
    // (scene/anim.h, pn_scene_pose); NULL without.
    pn_scene_anim *anim;
} pn_scene;

// Loads `source`: a path ending in .gltf or .glb, or "builtin:NAME". On failure logs one message
// naming the source and the problem, leaves *out zeroed and returns an error.
pn_result pn_scene_load(const char *source, pn_scene *out);

// glTF 2.0 loader (scene/gltf.cpp, the project's only C++ file). Same contract as pn_scene_load.
pn_result pn_gltf_load(const char *path, pn_scene *out);

// Built-in scenes generated in code: "default" (the showcase), "plane" (one 2x2 quad at y=0 on
// the XZ plane, centred at the origin, normal +Y; a receiver for tests), "penumbra" (a 4x4
// receiver at y=0 under a 0.5x0.5 occluder at y=0.5, both centred on the y axis), "canopy" (a
// pergola under alpha-masked leaf quads on a 6x6 ground at y=0, in metres: opaque and masked casters
// together, one 256x256 texture). Returns PN_ERR_INVALID for an unknown name.
pn_result pn_builtin_load(const char *name, pn_scene *out);

// Lists the built-in scene names, NULL-terminated.
const char *const *pn_builtin_names(void);

void pn_scene_destroy(pn_scene *scene);

static inline uint32_t pn_scene_triangle_count(const pn_scene *s) { return s->index_count / 3; }

// The largest |coordinate| of the bounds, which bounds every vertex's: what the shadow rays' origin
// offset scales with (ShadowParams.scene_mag; the renderer and the library's recorder).
static inline float pn_scene_magnitude(const pn_scene *s)
{
    float mag = 0;
    for (int k = 0; k < 3; k++)
        mag = fmaxf(mag, fmaxf(fabsf(s->bounds_min[k]), fabsf(s->bounds_max[k])));
    return mag;
}

// Recomputes bounds_min/max from the vertices referenced by indices.
void pn_scene_update_bounds(pn_scene *scene);

// Appends a material and returns its index. PN_ERR_MEMORY on allocation failure.
pn_result pn_scene_add_material(pn_scene *scene, const float base_color[4], uint32_t *index);

// Appends a texture of width x height RGBA8 texels (sRGB, as pn_texture) and returns its index for
// pn_material.texture. Takes rgba (malloc'd): the scene frees it, and so does a failure (PN_ERR_MEMORY).
pn_result pn_scene_add_texture(pn_scene *scene, uint32_t width, uint32_t height, uint8_t *rgba, int32_t *index);

// Appends triangles (positions and normals given per vertex, already in world space) as one draw.
pn_result pn_scene_add_mesh(pn_scene *scene, const pn_vertex *vertices, uint32_t vertex_count,
                            const uint32_t *indices, uint32_t index_count, uint32_t material);

// Adds the receiver plane the CLI's --ground asks for: a square on y = bounds_min.y - gap, centred
// under the bounds, `scale` times their largest horizontal extent wide. Updates the bounds.
pn_result pn_scene_add_ground(pn_scene *scene, float scale);

// Moves object `index` by `delta` in world space: its vertices, its transform and the bounds (the
// demo's and --move-object's moving objects). PN_ERR_INVALID, logged, for no such object.
pn_result pn_scene_move_object(pn_scene *scene, uint32_t index, const float delta[3]);
// The box of object `index`'s triangles (index < object_count).
void pn_scene_object_bounds(const pn_scene *scene, uint32_t index, float lo[3], float hi[3]);

// Validates what every stage relies on: finite positions, indices in range, at least one triangle.
// Logs the problem with the scene name.
pn_result pn_scene_validate(const pn_scene *scene);
