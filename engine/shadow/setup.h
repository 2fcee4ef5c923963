// Everything one shadow configuration needs on the GPU, built from a scene: the N-tree and its pools
// (line-space modes), the BVH (exact), the triangle pools (exact tests) and the renderer. Shared by
// render, bench and demo.
#pragma once
#include "accel/bvh.h"
#include "accel/pools.h"
#include "gpu/exact_pools.h"
#include "gpu/pools.h"
#include "gpu/renderer.h"
#include "gpu/tlas.h"
#include "scene/view.h"

// ---------------------------------------------------------------------------------------------
// The acceleration structures of the shadow modes, built in two steps so that the CPU part can run
// on a worker thread while the device keeps rendering (the demo rebuilds trees that way):
// pn_shadow_accel_build touches no Vulkan object; pn_shadow_accel_upload uses the queue, so it runs
// on the thread that renders.

typedef struct pn_shadow_accel_desc {
    pn_shadow_needs needs;  // what to build: a mode's (gpu/shadow_modes.h) or several modes' together
    int tree_n, tree_d;
    uint64_t max_bytes;     // refuse a tree whose pools exceed this (0: no limit)
    uint64_t max_pool_bytes; // ... or with one pool larger than this (0: no limit; set it to
                             // pn_gpu_device_max_buffer: every pool is one buffer)
    const pn_light *light;  // the tree leaves out triangles that cannot block a ray to any of these
    uint32_t light_count;   // lights at `light` (0 counts as 1)
    const float *keep_box;  // and, when given (lo xyz, hi xyz), those wholly outside this box
    const pn_bvh *reuse_bvh; // for needs.bvh: put this one in the exact pools instead of building one
                             // (not owned; must outlive the accel)
    bool per_object;         // needs.tree as one tree per mesh and a top level (accel/objects.h), of
                             // line spaces only: the renderer binds them for linespace mode alone
} pn_shadow_accel_desc;

typedef struct pn_shadow_accel {
    pn_shadow_accel_desc desc; // its needs as they apply to the scene (pn_shadow_needs_for_scene)
    pn_ntree tree;             // zero without needs.tree, and with per_object
    pn_pools pools;
    pn_objects objects;        // with needs.tree and per_object
    pn_gpu_objects gpu_objects; // after upload, with per_object
    pn_bvh bvh;                // built for needs.bvh without reuse_bvh
    const pn_bvh *exact_bvh;   // the BVH of the exact pools: &bvh, desc.reuse_bvh or NULL (&bvh: as
                               // of the build or the upload; the struct may move in between)
    double build_ms;           // N-tree with line spaces, and BVH
    pn_gpu_pools gpu_pools;    // after upload, with needs.tree
    pn_gpu_exact_pools exact;  // after upload, with needs.exact_pools
    pn_gpu_tlas tlas;          // after upload, with needs.tlas (built on the device)
} pn_shadow_accel;

// CPU part: tree, pools and BVH. Thread-safe (no Vulkan). Logs and leaves *out zeroed on failure.
pn_result pn_shadow_accel_build(const pn_scene *scene, const pn_shadow_accel_desc *desc, pn_shadow_accel *out);
// GPU part: uploads what was built. On failure the CPU part stays; destroy frees both.
pn_result pn_shadow_accel_upload(pn_gpu_device *dev, const pn_scene *scene, pn_shadow_accel *a);
// Points a renderer description at the uploaded pools (pools, leaf size, exact pools, candidates).
void pn_shadow_accel_bind(const pn_shadow_accel *a, pn_renderer_desc *rd);
// Bytes of the GPU pools: N-tree pools plus exact pools.
uint64_t pn_shadow_accel_gpu_bytes(const pn_shadow_accel *a);
// `dev` may be NULL when nothing was uploaded.
void pn_shadow_accel_destroy(pn_gpu_device *dev, pn_shadow_accel *a);

// ---------------------------------------------------------------------------------------------
// Accel and renderer in one call, for one frame configuration.

typedef struct pn_setup_desc {
    pn_renderer_desc frame; // size, mode, traversal, sampler, spp, seed, dump_rays (pools filled in here)
    int tree_n, tree_d;
    uint64_t max_bytes;     // for the tree's pools; 0: half the device's heap
    // Model only what the picture needs: with a camera, the tree leaves out triangles outside the
    // box of the visible receivers (from a G-buffer pass) and the lights, which holds every shadow ray.
    const pn_camera *view;
    // The size of that G-buffer pass (0: the frame's): a pilot smaller than the frame keeps what the
    // frame keeps (shadow/quality.c), so that it can render the frame's pixels on the same tree.
    uint32_t view_width, view_height;
    uint32_t light_count; // lights at pn_setup_create's `light` (0 counts as 1)
    bool per_object;      // the tree as per-object trees (pn_shadow_accel_desc.per_object)
} pn_setup_desc;

// The box of what the camera sees (P of every pixel with geometry, from a G-buffer pass at the
// frame's size) and the lights: every shadow ray of the picture lies in it.
pn_result pn_view_box(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *lights,
                      uint32_t light_count, const pn_renderer_desc *frame, float box[6]);

typedef struct pn_setup {
    pn_shadow_accel accel;
    pn_renderer renderer;
    double build_ms;          // N-tree with line spaces, or BVH
    pn_pool_bytes pool_bytes; // of the N-tree (zero without one), or of all per-object trees
    uint64_t exact_bytes;     // triangle, BVH and candidate pools
} pn_setup;

// Builds what desc.frame.mode needs (the tree culls triangles that cannot block a ray to any of the
// desc.light_count lights at `light`) and creates the renderer. Logs and fails as the pieces do.
pn_result pn_setup_create(pn_gpu_device *dev, const pn_scene *scene, const pn_light *light, const pn_setup_desc *desc,
                          pn_setup *out);
void pn_setup_destroy(pn_gpu_device *dev, pn_setup *s);
// The structures built again for the scene as it is now (moved geometry, a moved camera's view),
// the renderer kept (its temporal history with it): the scene's vertices [first_vertex, +
// vertex_count) copied to its G-buffer pass and the new structures bound (pn_renderer_set_accel).
// On failure s is as it was.
pn_result pn_setup_rebuild(pn_gpu_device *dev, const pn_scene *scene, const pn_light *light, const pn_setup_desc *desc,
                           uint32_t first_vertex, uint32_t vertex_count, pn_setup *s);
