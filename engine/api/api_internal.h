// What the API's files share: the opaque handles' contents and the call bracket that turns the
// engine's logged errors into the context's last error and a status.
#pragma once
#include <stdbool.h>

#include "gpu/device.h" // Vulkan first: penumbra.h declares its Vulkan entry points after it
#include "api/penumbra.h"
#include "core/log.h"
#include "scene/scene.h"
#include "shadow/setup.h"

// The farthest a coordinate may lie from the origin, as render's options allow (apps/render_opts.h):
// beyond it the float products of the light's frame and the ray setup overflow.
#define PN_API_MAX_COORD 1e18f

struct penumbra_context {
    bool ok;              // the device was created; a failed context holds only its message
    int log_level;        // penumbra_context_desc.log_level
    // Scenes and recorders made on it and not destroyed yet: penumbra_context_destroy with some
    // left (closing) defers the device's destruction to the last one's (pn_api_context_release),
    // so that a scene destroyed after its context (a garbage collector's order) frees nothing twice.
    uint32_t live;
    bool closing;
    char error[1024];     // the last failed call's message
    pn_gpu_device dev;    // must not move: the validation messenger points at it
};

// One mesh or glTF object as penumbra_scene_set_transform moves it: its vertices [first, first +
// count) of the scene are `base` moved by `base_to_world`'s inverse then the new transform, always
// from the base, so that rounding does not add up over moves (arrays: base holds the mesh's own
// positions and base_to_world is the identity; files: the positions as loaded, and the node's
// transform). cur_to_world: the transform now.
typedef struct pn_api_object {
    uint32_t first_vertex, vertex_count;
    float (*base)[3];
    double base_to_world[3][4], cur_to_world[3][4];
} pn_api_object;

// What the scene's visibility calls keep between them, in two parts, each rebuilt only when its own
// key changes: the acceleration structures (the mode's needs; the lights only where the mode has an
// N-tree, which leaves out what cannot block them) and the renderer over them (its image of points,
// kept while the rows are as long and no more of them are needed: the rest are empty pixels).
typedef struct pn_api_key {
    int mode, traversal, sampler, tree_n, tree_d;
    uint32_t width, height, light_count;
    uint64_t scene_version;
    pn_light lights[PN_MAX_LIGHTS];
} pn_api_key;

// A visibility description checked and resolved (its key's lights and size are the caller's).
typedef struct pn_api_config {
    pn_api_key key;
    uint32_t spp, seed;
} pn_api_config;

struct penumbra_scene {
    penumbra_context *ctx;
    pn_scene scene;
    pn_api_object *objects;
    uint32_t object_count;
    uint64_t version; // bumped by every change to the triangles
    bool accel_built;     // `accel` holds what accel_key describes
    pn_api_key accel_key; // mode, tree, scene version and (a tree's) lights
    pn_shadow_accel accel;
    bool renderer_made;   // `renderer` is made over `accel` as frame_key says
    bool renderer_stale;  // `accel` was built again since: the renderer takes it (pn_renderer_set_accel)
    pn_api_key frame_key; // mode, traversal, sampler, width; its height the most rows so far
    pn_renderer renderer;
    penumbra_times times; // of the last successful visibility call
    penumbra_visibility_desc config; // what it ran with (penumbra_scene_last_config)
    // max_error's choice (shadow/quality.h), kept while its key holds: the light, the budget,
    // traversal, sampler, seed and the scene version.
    bool chosen;
    pn_api_key choice_key;
    float choice_error;
    int choice_mode, choice_tree_n, choice_tree_d;
    uint32_t choice_spp, choice_seed;
};

// The bracket of every API call on a context: messages go to the context's log level and the
// first error to a scratch line, which becomes ctx->error when the call fails.
typedef struct pn_api_call {
    penumbra_context *ctx;
    pn_log_capture capture;
    char message[1024];
} pn_api_call;

void pn_api_begin(pn_api_call *call, penumbra_context *ctx);
// Ends the call: maps r to a status and, on failure, keeps the message (or r's name when
// nothing was logged) as the context's last error.
penumbra_status pn_api_end(pn_api_call *call, pn_result r);

// A scene or recorder of ctx is gone: the context goes too if it was destroyed meanwhile.
void pn_api_context_release(penumbra_context *ctx);

// Checks a pointer argument: logs "<fn>: <name> is NULL" and returns false for NULL.
bool pn_api_need(const void *p, const char *fn, const char *name);

// True when the context can take calls; logs why not otherwise (NULL, or failed at creation).
bool pn_api_context_ok(const penumbra_context *ctx, const char *fn);

// A public light as the engine's, checked and completed (unit normal and up, a sun placed beyond
// the scene's bounds); logs what is wrong with light `index` and returns false.
bool pn_api_light_in(const penumbra_light *in, uint32_t index, const pn_scene *scene, pn_light *out);

// The pieces of penumbra_scene_create and penumbra_visibility that touch no device, apart for the
// fuzzer (tests/fuzz/fuzz_api.c): a scene handle (ctx may be NULL: messages are then dropped), the
// arrays checked and added to it (logs what is wrong; PN_ERR_INVALID), the points checked.
penumbra_scene *pn_api_scene_new(penumbra_context *ctx, const char *name);
pn_result pn_api_scene_arrays(penumbra_scene *s, const penumbra_mesh_desc *meshes, uint32_t mesh_count);
void pn_api_scene_free(penumbra_scene *s);
pn_result pn_api_points_in(const float *points, const float *normals, size_t count);

// The description checked against the device and scene (names, ranges, the mode's needs); logs.
pn_result pn_api_config_in(const penumbra_context *ctx, const penumbra_scene *s, const penumbra_visibility_desc *d,
                           pn_api_config *c);

// Frees the acceleration structures and renderer the scene's visibility calls keep.
void pn_api_scene_drop_built(penumbra_scene *scene);
