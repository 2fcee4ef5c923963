// Building a pn_scene from a scene file's parts: a mesh primitive instanced into world space
// (vertices, normals, winding), the mesh's local triangles for per-object trees, textures widened
// to RGBA8, and the finished scene with its bounds. The glTF reader (gltf.cpp) reads and checks;
// everything it hands over here is already validated (indices in range, positions finite).
#pragma once
#include <stddef.h>
#include <stdint.h>

#include "scene/scene.h"

// What one scene may hold on the GPU: refusing early keeps a file that instances one big mesh many
// times from exhausting memory.
#define PN_SCENE_MAX_VERTICES (1ull << 27) // 4 GiB of pn_vertex
#define PN_SCENE_MAX_INDICES (1ull << 29)  // 2 GiB of indices

// A node's local -> world transform as the per-vertex loops use it.
typedef struct pn_scene_xform {
    double a[3][3];      // the upper 3x3, as rows
    double t[3];         // the translation
    double normal[3][3]; // cofactor matrix times sign(det): the inverse-transpose up to a scale
    double det;
} pn_scene_xform;

// Normalises v in place; false (v untouched) if it has no usable direction (zero, not finite).
bool pn_scene_unit3(double v[3]);

// From a column-major 4x4 matrix, m[col * 4 + row], as glTF stores node.matrix.
pn_scene_xform pn_scene_xform_from_matrix(const double m[16]);

// A scene under construction: `scene` holds what is built so far, its arrays grown with the
// capacities beside them. Start zeroed; end with pn_scene_build_finish or pn_scene_build_destroy.
typedef struct pn_scene_build {
    pn_scene scene;
    size_t vertex_cap, index_cap, draw_cap, material_cap, texture_cap, mesh_cap, object_cap;
    uint32_t *mesh_tri_cap; // per mesh, the triangles its soup has room for
} pn_scene_build;

// One triangle primitive of a mesh, in the primitive's own vertex numbering.
typedef struct pn_scene_build_prim {
    const float *positions; // vertex_count x 3, local, finite
    const float *normals;   // vertex_count x 3, or NULL: flat shading (three vertices per triangle)
    const float *uvs;       // vertex_count x 2, or NULL: uv 0
    uint64_t vertex_count;
    uint32_t *triangles; // triangle_count x 3, counter-clockwise; reordered in place when the
                         // transform mirrors, so that the front face stays the front face
    uint64_t triangle_count;
    uint32_t material;
    int64_t capture_mesh; // the scene mesh that keeps these local triangles (first instance), or -1
} pn_scene_build_prim;

// Appends the primitive under `xf` as one draw. PN_ERR_FORMAT when a vertex is not finite after the
// transform (its number in *bad_vertex), PN_ERR_MEMORY beyond the limits above or out of memory.
// Nothing is logged: the caller names the file and primitive.
pn_result pn_scene_build_add_prim(pn_scene_build *b, const pn_scene_build_prim *p, const pn_scene_xform *xf,
                                   uint64_t *bad_vertex);

// The primitive's world vertices under `xf` into vout (vertex_count of them, or 3 per triangle
// without normals): positions, normals by the inverse-transpose (zero or NaN ones repaired from a
// triangle using the vertex), flat normals without, uvs. The triangles as given (their winding
// already the world's). What add_prim writes, and pn_scene_pose again at another transform.
// PN_ERR_FORMAT (the vertex in *bad_vertex) when a position is not finite, PN_ERR_MEMORY.
pn_result pn_scene_build_place(const pn_scene_build_prim *p, const pn_scene_xform *xf, pn_vertex *vout,
                               uint64_t *bad_vertex);

// Appends an empty mesh (pn_scene.meshes) whose triangles the next primitives capture.
pn_result pn_scene_build_add_mesh(pn_scene_build *b, uint32_t *index);

// Appends an instance; its index and vertex ranges are the caller's (taken around its primitives).
pn_result pn_scene_build_add_object(pn_scene_build *b, const pn_scene_object *o);

pn_result pn_scene_build_add_material(pn_scene_build *b, const pn_material *m);

// Appends a texture converted to RGBA8 from `components` (1 grey, 2 grey+alpha, 3 RGB, 4 RGBA)
// samples of `bytes` (1, or 2: native-endian uint16, of which the high byte is kept).
pn_result pn_scene_build_add_texture(pn_scene_build *b, uint32_t width, uint32_t height, int components, int bytes,
                                 const uint8_t *samples, int32_t *index);

// Moves the scene into *out, arrays trimmed and the bounds of its referenced vertices computed
// (there must be a triangle); *b is left empty.
void pn_scene_build_finish(pn_scene_build *b, pn_scene *out);

void pn_scene_build_destroy(pn_scene_build *b);
