/* penumbra: soft shadows from area lights on Vulkan compute, as a C library.
 *
 * The public API, the only header a program that links penumbra includes (installed as
 * <penumbra.h>; pkg-config --cflags --libs penumbra, or CMake's find_package(penumbra) and the
 * target penumbra::penumbra). Everything under engine/ but engine/api is internal.
 *
 * The model: a context owns a Vulkan device; a scene holds triangles; lights are plain structs;
 * penumbra_visibility takes world-space points with normals and returns, per point and light, the
 * fraction of the light the point sees (V, 0..1), traced as `penumbra render` traces a pixel.
 *
 * Conventions:
 *  - Every function that can fail returns a penumbra_status; PENUMBRA_OK is 0. On failure,
 *    penumbra_context_error(ctx) holds one line naming the problem (the argument, the file, the
 *    index), until the next call on that context that fails.
 *  - Handles are opaque. A NULL handle, a NULL array with a non-zero count, a non-finite number or
 *    a value out of range is PENUMBRA_ERROR_INVALID_ARGUMENT, never a crash.
 *  - Descriptions are structs whose zero fields mean the default: pass NULL or `&(T){0}` for all
 *    defaults, and new fields never break a caller.
 *  - A context and what it made are used from one thread at a time. Two contexts may be used from
 *    two threads, unless both adopted the same VkQueue (penumbra_context_create_vulkan): a queue
 *    is externally synchronised, so their calls must then not overlap.
 *  - The library logs nothing to stderr unless asked (penumbra_context_desc.log_level).
 */
#ifndef PENUMBRA_H
#define PENUMBRA_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__) || defined(__clang__)
#define PENUMBRA_API __attribute__((visibility("default")))
#else
#define PENUMBRA_API
#endif

/* The version this header belongs to; penumbra_version() gives the linked library's. The ABI
 * changes only with the major version (the shared library's soname is libpenumbra.so.MAJOR). */
#define PENUMBRA_VERSION_MAJOR 0
#define PENUMBRA_VERSION_MINOR 1
#define PENUMBRA_VERSION_PATCH 0
#define PENUMBRA_VERSION (PENUMBRA_VERSION_MAJOR * 10000 + PENUMBRA_VERSION_MINOR * 100 + PENUMBRA_VERSION_PATCH)

/* PENUMBRA_VERSION of the library as linked: compare it with the header's at start-up. */
PENUMBRA_API uint32_t penumbra_version(void);

typedef enum penumbra_status {
    PENUMBRA_OK = 0,
    PENUMBRA_ERROR_INVALID_ARGUMENT = 1, /* a handle, size, value or name that cannot be used */
    PENUMBRA_ERROR_IO = 2,               /* a file could not be read */
    PENUMBRA_ERROR_FORMAT = 3,           /* a file's content is malformed or unsupported */
    PENUMBRA_ERROR_OUT_OF_MEMORY = 4,    /* host or device memory, or a size limit of the device */
    PENUMBRA_ERROR_VULKAN = 5,           /* no usable device, or a Vulkan call failed */
    PENUMBRA_ERROR_UNSUPPORTED = 6,      /* valid, but not offered by this device or build */
    /* penumbra_recorder_check: the recorded pass was cut short (lavapipe's shader loop budget):
     * record and submit it again; it then takes fewer samples per dispatch. */
    PENUMBRA_INCOMPLETE = 7,
} penumbra_status;

/* A constant name for a status ("PENUMBRA_OK", ...); "unknown status" for any other value. */
PENUMBRA_API const char *penumbra_status_string(penumbra_status status);

/* ------------------------------------------------------------------------------------------ */
/* Context: one Vulkan device and the last error. */

typedef struct penumbra_context penumbra_context;

typedef struct penumbra_context_desc {
    /* NULL or "": the best device with Vulkan 1.3 (a discrete GPU over an integrated one, a GPU
     * over lavapipe); else its index in Vulkan's enumeration ("1") or a case-insensitive part of
     * its name ("llvmpipe"). The environment variable PN_DEVICE is not read. */
    const char *device;
    /* Non-zero: the Khronos validation layer with synchronization validation; its error messages
     * are counted (penumbra_context_validation_messages). */
    int validation;
    /* What the library writes to stderr from this context's calls: 0 nothing (default), 1 errors,
     * 2 warnings too, 3 progress too. The last error is kept either way. */
    int log_level;
} penumbra_context_desc;

/* Creates the context and its device. On failure returns the status and still sets *out to a
 * context that holds only the message (read it with penumbra_context_error, then destroy it);
 * *out is NULL only when not even that could be allocated. desc may be NULL. */
PENUMBRA_API penumbra_status penumbra_context_create(const penumbra_context_desc *desc, penumbra_context **out);

/* Destroys the context (NULL is ignored). Scenes and recorders made on it may be destroyed before
 * or after (a garbage collector's order): the device goes with the last of them, and meanwhile
 * every other call on the context fails. */
PENUMBRA_API void penumbra_context_destroy(penumbra_context *ctx);

/* The message of the last failed call on ctx ("" if none failed); valid until the next call that
 * fails or the context's destruction. A constant message for NULL. */
PENUMBRA_API const char *penumbra_context_error(const penumbra_context *ctx);

/* The name of the context's device ("llvmpipe (LLVM 15.0.6, 256 bits)", "NVIDIA H100 ..."); ""
 * for a context that failed. */
PENUMBRA_API const char *penumbra_context_device(const penumbra_context *ctx);

/* With desc.validation: the warnings and errors the validation layer reported so far. */
PENUMBRA_API uint32_t penumbra_context_validation_messages(const penumbra_context *ctx);

/* ------------------------------------------------------------------------------------------ */
/* Scene: the triangles that cast shadows. */

typedef struct penumbra_scene penumbra_scene;

/* One mesh of a scene from arrays: positions in its own frame and a triangle list. */
typedef struct penumbra_mesh_desc {
    const float *positions;   /* xyz per vertex, vertex_count * 3 floats, finite */
    uint32_t vertex_count;
    const uint32_t *indices;  /* 3 per triangle, each < vertex_count; index_count a multiple of 3 */
    uint32_t index_count;
    /* Local to world, 3 rows of 4 (row-major: x_world[r] = t[4r] x + t[4r+1] y + t[4r+2] z + t[4r+3]);
     * NULL: identity. The mesh is one object, moved later with penumbra_scene_set_transform. */
    const float *transform;
    /* Optional alpha mask (a cut-out caster such as a leaf): uv per vertex (2 floats), a mask of
     * alpha_width x alpha_height bytes (row 0 at v = 0, repeating outside 0..1), and the cutoff in
     * (0, 1]: a ray passes where alpha / 255 is below it. NULL uvs: opaque. */
    const float *uvs;
    const uint8_t *alpha;
    uint32_t alpha_width, alpha_height;
    float alpha_cutoff;
} penumbra_mesh_desc;

/* A scene of mesh_count meshes (object i is mesh i). Copies the arrays; they may be freed after. */
PENUMBRA_API penumbra_status penumbra_scene_create(penumbra_context *ctx, const penumbra_mesh_desc *meshes,
                                                   uint32_t mesh_count, penumbra_scene **out);

/* A scene from a glTF 2.0 file (.gltf, .glb; its nodes with a mesh are its objects, its
 * KHR_lights_punctual and penumbra area lights its lights), or a built-in one ("builtin:default",
 * "builtin:plane", "builtin:penumbra", "builtin:canopy"). Loaded as `penumbra render` loads it
 * with --no-ground. */
PENUMBRA_API penumbra_status penumbra_scene_load(penumbra_context *ctx, const char *path, penumbra_scene **out);

/* Destroys the scene (NULL is ignored) and what the context built for it. */
PENUMBRA_API void penumbra_scene_destroy(penumbra_scene *scene);

typedef struct penumbra_scene_info {
    uint64_t triangle_count;
    uint32_t object_count;   /* arrays: mesh_count; glTF: nodes with a mesh; built-in: 1 */
    uint32_t light_count;    /* lights the file carries */
    float bounds_min[3], bounds_max[3];
} penumbra_scene_info;

PENUMBRA_API penumbra_status penumbra_scene_get_info(const penumbra_scene *scene, penumbra_scene_info *out);

/* Object `object`'s transform from now on (3 rows of 4, as penumbra_mesh_desc.transform; its
 * mesh's own positions are moved, not the current ones). The next visibility call rebuilds the
 * scene's acceleration structures, and only those: the pipelines and images it made stay
 * (penumbra_scene_last_times: compile_ms 0). */
PENUMBRA_API penumbra_status penumbra_scene_set_transform(penumbra_scene *scene, uint32_t object,
                                                          const float transform[12]);

/* ------------------------------------------------------------------------------------------ */
/* Lights. V does not depend on a light's power, so a light here has only its shape. */

typedef enum penumbra_light_kind {
    PENUMBRA_LIGHT_RECT = 0,   /* one-sided rectangle: position (centre), normal, up, size; size 0: a point */
    PENUMBRA_LIGHT_POINT = 1,  /* point (or spot: cone): position; hard shadows */
    PENUMBRA_LIGHT_SUN = 2,    /* directional: normal (direction of travel) and angle (angular diameter) */
    PENUMBRA_LIGHT_SPHERE = 3, /* sphere: position (centre) and radius */
    PENUMBRA_LIGHT_DISK = 4,   /* one-sided disk: position (centre), normal and radius */
} penumbra_light_kind;

typedef struct penumbra_light {
    penumbra_light_kind kind;
    float position[3];
    float normal[3]; /* the side a rectangle or disk emits to; a sun's and a spot's direction */
    float up[3];     /* a rectangle's height axis (projected onto its plane); zero: any */
    float size[2];   /* a rectangle's width and height */
    float radius;    /* sphere, disk */
    float angle;     /* sun: angular diameter in radians (0.0093 is the sun's) */
    float cone[2];   /* point: a spot's inner and outer half-angles in radians; 0, 0: no cone */
    float range;     /* point, sphere: where the light fades out (KHR_lights_punctual); 0: nowhere */
} penumbra_light;

/* The lights `penumbra render` uses for the scene without --light options: the file's own, else
 * one rectangle framed on the scene (or on its interior, for a room seen from inside). Writes at
 * most `capacity` lights to out (which may be NULL with capacity 0) and their number to *count. */
PENUMBRA_API penumbra_status penumbra_scene_lights(const penumbra_scene *scene, penumbra_light *out,
                                                   uint32_t capacity, uint32_t *count);

/* ------------------------------------------------------------------------------------------ */
/* Points in, visibility out. */

typedef struct penumbra_visibility_desc {
    /* A shadow mode of `penumbra render --mode` (NULL: "exact", the reference): "exact",
     * "linespace", "ls-leaf", "ls-plane", "hybrid", "exact-ls", "rayquery", "rtpipeline", "none".
     * Exact modes return the exact V of the samples; line-space modes trade accuracy for speed. */
    const char *mode;
    const char *traversal; /* NULL: "auto"; or "ray", "packet", "project" (render's --traversal) */
    const char *sampler;   /* NULL: "stratified"; or "grid" */
    uint32_t spp;          /* light samples per point, 1..4096; 0: 4, as render */
    uint32_t seed;         /* the samples' seed, as render's --seed; 0: 1, render's default */
    uint32_t tree_n, tree_d; /* line-space modes' N-tree: branching 2..16, depth 1..6; 0: 7 and 3 */
    /* The points are traced as the pixels of an image `width` points wide (point i is pixel
     * (i mod width, i / width)); a pixel's samples depend on where it is. 0: 1024.
     * To reproduce render's V for its pixels' P and N (render --aovs --filter none), pass its width
     * and the pixels in row order: V is then render's bit for bit. */
    uint32_t width;
    /* > 0: `--quality auto`'s choice replaces mode, spp and tree (traversal, sampler and seed stay
     * as given): the fastest configuration whose mean absolute error of V stays within max_error
     * (at most 1; against a converged exact reference), measured on pilot renders of the scene as
     * `penumbra render` frames it by default (the file's camera, an interior's, or one framing the
     * bounds) at 256x256, unfiltered, with uniform samples, under the call's one light (one only).
     * The choice is kept for the scene, light and budget; penumbra_scene_last_config tells it. */
    float max_error;
} penumbra_visibility_desc;

/* For point_count points (xyz each in `points`, a unit normal each in `normals`, the side the
 * point receives light from), the visibility of each of light_count lights: v[l * point_count + i]
 * for light l and point i, light_count * point_count floats. V is the fraction of the light's
 * samples that reach the point unblocked, among those above its horizon and in front of the
 * light; 0 where none is (a point facing away, behind a one-sided light, or under it: unlike
 * render's shadow.V layer, whose convention there is 1, where its radiance is 0 anyway).
 * The first call builds the acceleration structures for the scene and mode (for the line-space
 * modes, also for the lights: their tree leaves out what cannot block them) and readies the
 * pipelines; later calls reuse both while the mode, traversal, sampler, tree and row length stay
 * (other points, counts, samples and seeds; other lights too, but in the line-space modes; more
 * than 16 lights there are built for 16 at a time). penumbra_scene_last_times says what a call did.
 * desc may be NULL (the defaults). */
PENUMBRA_API penumbra_status penumbra_visibility(penumbra_context *ctx, penumbra_scene *scene,
                                                 const penumbra_visibility_desc *desc, const penumbra_light *lights,
                                                 uint32_t light_count, const float *points, const float *normals,
                                                 size_t point_count, float *v);

/* What the scene's last successful penumbra_visibility call took, in milliseconds. */
typedef struct penumbra_times {
    double build_ms;   /* acceleration structures it built (0 when the last call's were reused) */
    double compile_ms; /* pipelines it readied apart from the passes (created, run once over a tile) */
    double shadow_ms;  /* its shadow passes on the device (timestamps), all lights */
    double total_ms;   /* the call, wall-clock: checks, building, upload, passes, readback */
} penumbra_times;

PENUMBRA_API penumbra_status penumbra_scene_last_times(const penumbra_scene *scene, penumbra_times *out);

/* The description the scene's last successful penumbra_visibility call ran with: its defaults
 * filled in, and with max_error the configuration chosen (mode, traversal and sampler point to
 * constant names). Zeroed before the first call. */
PENUMBRA_API penumbra_status penumbra_scene_last_config(const penumbra_scene *scene, penumbra_visibility_desc *out);

/* ------------------------------------------------------------------------------------------ */
/* On the host's Vulkan device. Declared where <vulkan/vulkan.h> was included before this header. */

#ifdef VK_VERSION_1_0

/* The host's device, which penumbra then uses instead of making its own. */
typedef struct penumbra_vulkan_desc {
    VkInstance instance;         /* created for Vulkan 1.3 */
    VkPhysicalDevice physical_device;
    VkDevice device;             /* created with: Vulkan 1.3's dynamicRendering and synchronization2,
                                  * 1.2's hostQueryReset and bufferDeviceAddress, and shaderFloat64 */
    uint32_t queue_family;       /* a family with graphics, compute and timestamps */
    VkQueue queue;               /* penumbra submits its own work (builds, penumbra_visibility) here
                                  * and waits for it: the host must not use this queue from another
                                  * thread during a penumbra call (Vulkan's external synchronisation) */
    /* The device extensions the host enabled; penumbra uses VK_KHR_acceleration_structure with
     * VK_KHR_deferred_host_operations and VK_KHR_ray_query or VK_KHR_ray_tracing_pipeline (modes
     * rayquery, rtpipeline; their features enabled), and VK_EXT_memory_budget, where listed. */
    const char *const *enabled_extensions;
    uint32_t enabled_extension_count;
} penumbra_vulkan_desc;

/* A context on the host's device: as penumbra_context_create, but nothing is created but a command
 * pool of penumbra's own; penumbra_context_destroy leaves the device and instance to the host (it
 * waits for the queue to be idle). desc's device and validation are ignored (the host's instance
 * has its layers). */
PENUMBRA_API penumbra_status penumbra_context_create_vulkan(const penumbra_vulkan_desc *vulkan,
                                                            const penumbra_context_desc *desc, penumbra_context **out);

/* The shadow pass recorded into the host's command buffer, over the host's images. */
typedef struct penumbra_recorder penumbra_recorder;

typedef struct penumbra_recorder_desc {
    uint32_t width, height;  /* of the three images: 2D, one mip level, one layer */
    /* Views of the host's images, all used as storage images in VK_IMAGE_LAYOUT_GENERAL:
     * position: VK_FORMAT_R32G32B32A32_SFLOAT, world xyz, w > 0 where there is a point (elsewhere
     *           V is 0); normal: R32G32B32A32_SFLOAT, unit xyz facing the side that receives light;
     * visibility: R32_SFLOAT, written: V per pixel. */
    VkImageView position, normal, visibility;
    penumbra_visibility_desc shadow; /* mode, traversal, sampler, spp, tree (seed: per record; width:
                                      * the image's) */
    penumbra_light light;           /* the light V is of (one per recorder) */
    /* The temporal history (penumbra_recorder_record_view): how many frames' samples it holds
     * (older ones weigh less past that: an exponential window), 1..4096; 0: none, each recording
     * stands alone (penumbra_recorder_record). */
    uint32_t history_frames;
} penumbra_recorder_desc;

/* A frame's camera as the host drew its P, for the temporal history: V at a surface point does not
 * depend on the camera, so each recording adds its samples to those its pixels' points gathered in
 * earlier recordings, found through the previous recording's camera (P projected by its matrix,
 * the pixel there kept where it shows the same surface). A recorder's scene and light are fixed
 * (a moved object or light is a new recorder, whose history starts afresh), so the camera is all
 * the history needs: NRD's contract is per-pixel motion vectors, but V does not move with a
 * moving surface; it stays with the point, which P through the previous camera finds. */
typedef struct penumbra_view {
    float view_proj[16]; /* world to clip space, column-major (GLSL's mat4): clip x, y in -1..1
                          * across the image (x right, y down: Vulkan's), w > 0 in front */
    float eye[3];        /* the camera's position */
    float forward[3];    /* its unit viewing direction (a point's depth is dot(P - eye, forward)) */
    float pixel_angle;   /* a pixel's height per unit of depth: 2 tan(vertical fov / 2) / height */
} penumbra_view;

/* Builds what the mode needs for the scene as it is now (a later penumbra_scene_set_transform does
 * not reach the recorder: make a new one) and the pass's pipelines and buffers on the context's
 * device, which must be the host's (penumbra_context_create_vulkan). The recorder's descriptors
 * name the three views: they must outlive it. */
PENUMBRA_API penumbra_status penumbra_recorder_create(penumbra_context *ctx, penumbra_scene *scene,
                                                      const penumbra_recorder_desc *desc, penumbra_recorder **out);

/* Records the shadow pass with the given seed into cmd (recording, primary, on the context's queue
 * family). Synchronisation, stated:
 *  - before: position and normal written, all three images in VK_IMAGE_LAYOUT_GENERAL; the
 *    recorded commands begin with a global memory barrier from all commands' writes, so the host
 *    needs only the layout transitions;
 *  - after: V is written by the compute shader stage (VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
 *    VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT): the host's barrier from there to its reads;
 *  - the recorder's parameters are written at record time: record again only once the previous
 *    recording's submission has completed (then call penumbra_recorder_check; the recording ends
 *    with the barrier that makes its status visible to the host). */
PENUMBRA_API penumbra_status penumbra_recorder_record(penumbra_recorder *rec, VkCommandBuffer cmd, uint32_t seed);

/* As penumbra_recorder_record, for a recorder with a history (desc.history_frames > 0), with the
 * frame's camera: after the shadow pass the recorded commands add its samples to the history and
 * write V over all of them. The history counts the recordings as frames: each takes other strata
 * of a window of frames (keep the seed from frame to frame; another seed is another window). The
 * first recording, and the first after penumbra_recorder_history_drop, starts afresh. A recording
 * that penumbra_recorder_check reports INCOMPLETE is not counted: record the frame again. */
PENUMBRA_API penumbra_status penumbra_recorder_record_view(penumbra_recorder *rec, VkCommandBuffer cmd, uint32_t seed,
                                                           const penumbra_view *view);

/* The next recording starts the history afresh (a cut). */
PENUMBRA_API penumbra_status penumbra_recorder_history_drop(penumbra_recorder *rec);

/* After the recording's submission has completed: PENUMBRA_OK, or PENUMBRA_INCOMPLETE when a
 * dispatch was cut short (lavapipe's shader loop budget) and V is not whole: record and submit
 * again. */
PENUMBRA_API penumbra_status penumbra_recorder_check(penumbra_recorder *rec);

/* Destroys the recorder (NULL is ignored); its last recording must have completed. */
PENUMBRA_API void penumbra_recorder_destroy(penumbra_recorder *rec);

#endif /* VK_VERSION_1_0 */

#ifdef __cplusplus
}
#endif
#endif
