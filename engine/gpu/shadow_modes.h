// The shadow modes, one row each in one table (shadow_modes.c): name, shader and specialisation,
// what the mode needs built, whether its answer is exact. The CLI, the renderer, setup, bench, demo
// and tests all read the table; nothing compares modes by their enum order.
// Adding a mode: a value here, its row in shadow_modes.c, its shader in shaders/glsl (every .comp
// there is compiled and embedded as pn_spv_<name>_comp), its tests.
#pragma once
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "gpu/device.h"
#include "interface.h" // PN_TRAVERSAL_*, PN_SAMPLER_*: values the shaders test
#include "scene/scene.h"

typedef enum pn_shadow_mode {
    PN_SHADOW_NONE,      // V = 1: unshadowed
    PN_SHADOW_LINESPACE, // line-space visibility, the paper's method
    PN_SHADOW_LEAF,      // line spaces down to the leaves: a filled leaf the ray crosses blocks it
    PN_SHADOW_PLANE,     // line spaces down to the leaves: a filled leaf's plane slab the ray crosses blocks it
    PN_SHADOW_HYBRID,    // line spaces, and the triangles exactly where the ray starts and ends
    PN_SHADOW_EXACT_LS,  // line spaces skip empty space; set shafts test their triangles exactly
    PN_SHADOW_EXACT,     // BVH and watertight triangle tests: the reference
    PN_SHADOW_RAYQUERY,  // the device's ray queries through its own acceleration structure
    PN_SHADOW_RTPIPELINE, // the device's ray-tracing pipeline through the same structure
    PN_SHADOW_MODE_COUNT
} pn_shadow_mode;

// The mode every error is measured against (bench, --quality auto, the demo's error view).
#define PN_SHADOW_REFERENCE PN_SHADOW_EXACT

typedef enum pn_traversal {
    PN_TRAVERSAL_RAY = PN_TRAVERSAL_RAY_ID,
    PN_TRAVERSAL_PACKET = PN_TRAVERSAL_PACKET_ID,
    PN_TRAVERSAL_AUTO = PN_TRAVERSAL_AUTO_ID,
    PN_TRAVERSAL_PROJECT = PN_TRAVERSAL_PROJECT_ID,
} pn_traversal;
typedef enum pn_sampler { PN_SAMPLER_GRID = PN_SAMPLER_GRID_ID, PN_SAMPLER_STRATIFIED = PN_SAMPLER_STRATIFIED_ID } pn_sampler;

// Command-line names indexed by the enum value, NULL-terminated (for pn_parse_choice).
extern const char *const pn_traversal_names[];
extern const char *const pn_sampler_names[];

// The traversal a mode's shader runs for a light of `samples` samples per pixel (pn_shadow_samples;
// spp_min > 0: adaptive): auto is, for exact, project from PN_PROJECT_AUTO_SAMPLES uniform samples
// on and packet below (one BVH walk per pixel: 1.8x the per-ray walk's speed on the dragon,
// engine/gpu/llvmpipe.md), and ray for the line-space modes (their packet walk is the slower one
// on lavapipe); ray, packet and project are taken as given.
pn_traversal pn_traversal_resolve(pn_shadow_mode mode, pn_traversal t, uint32_t samples, uint32_t spp_min);
// Exact's projection traversal is auto's from this many samples: measured (engine/gpu/README.md,
// the projection traversal; 256x256, lavapipe) at 256 spp 0.81x, 1.06x and 0.95x the packet walk's
// time on the bunny, dragon and Sponza views, at 1024 0.45x, 0.68x, 0.62x; at 64, 0.93-1.40x.
#define PN_PROJECT_AUTO_SAMPLES 256
// --traversal project where the frame can take it (exact, uniform samples), else auto: for
// configurations chosen by --quality auto under a frame that asked for project.
pn_traversal pn_traversal_fit(pn_shadow_mode mode, uint32_t spp_min, pn_traversal t);

// What a mode needs built before it can render (shadow/setup.c builds it).
typedef struct pn_shadow_needs {
    bool tree;        // the N-tree and its line-space pools
    bool candidates;  // the tree's per-leaf triangle lists
    bool bvh;         // a BVH over all triangles
    bool exact_pools; // triangles, BVH and candidate lists on the GPU, for exact triangle tests
    bool planes;      // the tree's leaf planes (ls-plane)
    bool tlas;        // a device-built acceleration structure (gpu/tlas.h)
    // exact_pools, but only on a scene with alpha-masked casters: the triangle pool holds their
    // texels (accel/alpha.h), which rayquery tests at its hits and the line-space modes in the
    // leaves holding them (with those leaves' candidate lists); an opaque scene's rays never read it.
    bool exact_pools_if_masked;
} pn_shadow_needs;

typedef struct pn_shadow_mode_info {
    const char *name;          // on the command line and in every output
    const char *help;          // one line for --help
    const uint32_t *spirv;     // its shadow shader (NULL for ray_pipeline)
    size_t spirv_size;         // bytes
    int32_t variant;           // the shader's MODE specialisation constant (PN_VARIANT_*)
    pn_shadow_needs needs;
    bool traces;               // traces shadow rays (every mode but none)
    bool exact;                // its V equals exact ray tracing's for the same samples
    // Runs over per-object trees (accel/objects.h, --trees object): it decides from line spaces
    // alone, in each object's frame. The others read candidate lists, leaf planes or the leaf size
    // of one world-space tree.
    bool objects;
    // Its shader's packet walk unrolls its per-ray loops to the most rays a pixel has in a dispatch
    // (PN_SPEC_PACKET_RAYS): the shadow pass makes a pipeline per size (exact).
    bool packet_rays;
    // Tests the texels of alpha-masked casters (pn_material.alpha_cutoff) where rays hit them: the
    // exact modes and rayquery at every hit, the line-space modes in the leaves holding a masked
    // triangle (their tree marks them and keeps their triangles: linespace_leaf.glsl). Every
    // tracing mode has it; a new one without it would refuse scenes with masked casters
    // (pn_shadow_mode_takes_scene), as per-object trees do (shadow/setup.c).
    bool alpha_masks;
    // What the device must have: ray queries (VK_KHR_ray_query, in its compute shader), or
    // ray-tracing pipelines (VK_KHR_ray_tracing_pipeline: the mode traces through one made of the
    // shadow_rtpipeline.* shaders, gpu/raytrace.h, instead of a compute shader).
    bool ray_query;
    bool ray_pipeline;
    uint8_t auto_trees;        // --quality auto tries the first this many of its standard trees
                               // (a mode without a tree: 1 tries it once, 0 not at all)
} pn_shadow_mode_info;

// The row of mode m; NULL for a value outside the table.
const pn_shadow_mode_info *pn_shadow_mode_get(pn_shadow_mode m);

// The mode called `name`; -1, with a message naming `opt` and listing the modes, for no mode.
int pn_shadow_mode_parse(const char *opt, const char *name);

// `needs` as they apply to `scene`: with exact_pools_if_masked, exact_pools on a scene with
// alpha-masked casters (shadow/setup.c builds, and the renderer asks for, what this returns).
pn_shadow_needs pn_shadow_needs_for_scene(pn_shadow_needs needs, const pn_scene *scene);

// Every mode's needs together, of the modes `dev` can run: a set-up from which any of them can
// render (the demo switches modes without rebuilding).
pn_shadow_needs pn_shadow_needs_all(const pn_gpu_device *dev);

// True if mode m can render `scene`; else false with a message in why[0..n) (when given): a mode
// without alpha_masks on a scene with alpha-masked casters.
bool pn_shadow_mode_takes_scene(pn_shadow_mode m, const pn_scene *scene, char *why, size_t n);

// True if `dev` can run mode m; else false with *why (when given) saying what it lacks.
bool pn_shadow_mode_available(const pn_gpu_device *dev, pn_shadow_mode m, const char **why);
