// penumbra demo: the state the demo's files share. One pn_demo lives on cmd_demo's stack; GLFW
// callbacks reach it through glfwSetWindowUserPointer.
//
//   cmd_demo.c       options, window, the frame loop
//   demo_controls.c  key bindings (one table for --help, the H overlay and the script), camera,
//                    light and object moves
//   demo_image.c     accumulation, views (shaded, visibility, error, N-tree cells), overlay text
//   demo_builder.c   N-tree rebuilds on a worker thread
//   demo_script.c    --script files
//   demo_stats.c     --stats files: resident and device memory every N frames
#pragma once
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>

#include "apps/render_opts.h"
#include "shadow/setup.h"
#include "gpu/swapchain.h"

// penumbra demo's command line: render's options (apps/render_opts.h) and the demo's own.
typedef struct pn_demo_opts {
    pn_render_opts r;
    const char *scene, *screenshot, *script, *save_prefix;
    const char *stats;      // --stats FILE: memory samples (demo_stats.c), NULL: none
    long long stats_every;  // frames between them
    long long frames; // 0: until the window closes
    long long accumulate_max;
    bool accumulate, hud, vsync;
} pn_demo_opts;

// Parses the command line (demo_opts.c): PN_EXIT_OK, PN_EXIT_USAGE, or -1 after printing the help.
int pn_demo_parse(int argc, char **argv, pn_demo_opts *o);

typedef enum pn_demo_view {
    PN_DEMO_SHADED = 0,     // tone-mapped radiance
    PN_DEMO_VISIBILITY = 1, // V alone, grey
    PN_DEMO_ERROR = 2,      // |V - V_exact|, with an exact renderer beside the current one
} pn_demo_view;

// ---------------------------------------------------------------------------------------------
// Accumulation and composition (demo_image.c)

typedef struct pn_demo_image {
    uint32_t width, height;
    uint32_t frames;           // rendered since the last restart (the image is held at the limit)
    float *rad, *v, *vx;       // the last frame's radiance (rgba), V, exact V (error view)
    float *p;                  // world positions of the last frame (rgba, w = 1 on geometry)
    uint8_t *rgba;             // the composed frame without overlay text, row 0 at the top
    uint8_t *rgb;              // scratch for the tone mapper and PNG output
} pn_demo_image;

pn_result pn_demo_image_create(uint32_t width, uint32_t height, pn_demo_image *out);
void pn_demo_image_destroy(pn_demo_image *img);
// Takes one frame (and the exact renderer's V when given) as the image: every earlier frame's
// samples are in it already (the renderer's temporal history, or adaptive samples continued).
void pn_demo_image_add(pn_demo_image *img, const pn_frame_images *frame, const float *v_exact);

struct pn_demo;
// How frames add up (demo_image.c). Accumulation is the renderers' temporal history
// (pn_renderer_set_history): each frame adds its samples to those its pixels' surface points
// gathered before, through camera moves; the history drops only what a light change or a moved
// object's bounds reach. Adaptive samples (--spp MIN:MAX, one light, a mode that traces; not in
// the error view, whose exact renderer must draw the same samples) refine instead by continuing
// the first frame's where V is uncertain; the grid sampler repeats its samples (nothing to add).
bool pn_demo_refines_adaptively(const struct pn_demo *d);
bool pn_demo_temporal(const struct pn_demo *d);
// Frames rendered after a change before the image is held (nothing left to add).
uint32_t pn_demo_accumulate_limit(const struct pn_demo *d);

// ---------------------------------------------------------------------------------------------
// N-tree builds on a worker thread (demo_builder.c). The worker only runs pn_shadow_accel_build
// (CPU, no Vulkan); the frame loop uploads the result and swaps it in.

typedef enum pn_demo_build_state { PN_DEMO_BUILD_IDLE, PN_DEMO_BUILD_RUNNING, PN_DEMO_BUILD_DONE } pn_demo_build_state;

typedef struct pn_demo_builder {
    pthread_t thread;
    atomic_int state;          // pn_demo_build_state; DONE is set by the worker, IDLE by poll
    // What the build reads: `snapshot`, or the demo's own scene when it has no objects to move.
    // Stays after poll, for the upload (exact pools and the device's acceleration structure must
    // hold the triangles the BVH was built over), until the next start.
    const pn_scene *scene;
    // The geometry at start: vertices, objects and bounds copied (the frame loop moves objects
    // while the worker builds), the rest (indices, meshes' local triangles, materials) shared.
    pn_scene snapshot;
    pn_shadow_accel_desc desc; // desc.light points to `lights`
    pn_light lights[PN_MAX_LIGHTS];
    pn_shadow_accel result;
    pn_result status;
    uint64_t start_ns;
} pn_demo_builder;

// Starts building `desc` (its lights and the scene's moving parts are copied). The builder must be idle.
pn_result pn_demo_builder_start(pn_demo_builder *b, const pn_scene *scene, const pn_shadow_accel_desc *desc);
// Non-blocking: when a build has finished, joins the worker, moves the result to *out (zeroed on
// failure), stores its status and returns true.
bool pn_demo_builder_poll(pn_demo_builder *b, pn_shadow_accel *out, pn_result *status);
// Blocks until a running build is done (poll then takes it at once).
void pn_demo_builder_wait(const pn_demo_builder *b);
// Seconds since the running build started.
double pn_demo_builder_elapsed(const pn_demo_builder *b);
// Waits for a running build and discards it.
void pn_demo_builder_destroy(pn_demo_builder *b);

// ---------------------------------------------------------------------------------------------
// Scripts (demo_script.c). One event per line, applied before frame FRAME (0 = the first) renders:
//     frame FRAME key [shift+]KEY     a key press, KEY as in the controls (M, 1, -, left, pageup, ...)
//     frame FRAME orbit YAW PITCH     turn the camera around its target, degrees
//     frame FRAME pan X Y             move camera and target, in view heights at the target
//     frame FRAME zoom F              distance to the target times F
//     frame FRAME resize W H          resize the window
//     frame FRAME move-object I DX DY DZ   move object I (as --move-object counts) by DX,DY,DZ
//     frame FRAME screenshot FILE     save frame FRAME (without the overlay text) as PNG, after
//                                     any tree rebuild running or due (the scene as it stands)
// '#' starts a comment; blank lines are ignored.

typedef enum pn_demo_event_kind {
    PN_DEMO_EVENT_KEY,
    PN_DEMO_EVENT_ORBIT,
    PN_DEMO_EVENT_PAN,
    PN_DEMO_EVENT_ZOOM,
    PN_DEMO_EVENT_RESIZE,
    PN_DEMO_EVENT_SCREENSHOT,
    PN_DEMO_EVENT_MOVE_OBJECT,
} pn_demo_event_kind;

typedef struct pn_demo_event {
    uint32_t frame;
    uint32_t line; // in the file, for ordering events of one frame and for messages
    pn_demo_event_kind kind;
    int key, mods;   // KEY
    float a, b;      // ORBIT, PAN, ZOOM (a), RESIZE (a x b)
    uint32_t object; // MOVE_OBJECT: which, and by how much in world space
    float move[3];
    char path[1024]; // SCREENSHOT
} pn_demo_event;

typedef struct pn_demo_script {
    pn_demo_event *events; // sorted by frame, then line
    uint32_t count, next;
} pn_demo_script;

// Parses the file; logs "FILE:LINE: problem" and fails on the first bad line.
pn_result pn_demo_script_load(const char *path, pn_demo_script *out);
// What needs the scene (read after the script): every move-object names one of its objects. Logs
// "FILE:LINE: problem" and fails on the first that does not.
pn_result pn_demo_script_check(const pn_demo_script *s, const char *path, const pn_scene *scene);
void pn_demo_script_destroy(pn_demo_script *s);

// ---------------------------------------------------------------------------------------------
// The demo

typedef struct pn_demo_stats {
    pn_frame_times times;       // of the current mode's renderer
    double exact_shadow_ms;     // of the exact renderer (error view)
    double rays_per_s;          // shadow rays of the current renderer per second of its shadow pass
    double frame_ms;            // wall time of the last rendered frame, input to present
    double render_ms, compose_ms, present_ms;
    double error_mae, error_p99, error_max; // error view, over pixels with geometry
    double move_ms;             // objects moved before this frame: their whole update (0: none)
    bool building;              // a tree build ran on the worker thread (sharing the cores)
} pn_demo_stats;

// Boxes of moved geometry (pn_history_boxes, before and after each move) for the history: `more`
// added to `b`.
void pn_demo_boxes_join(pn_history_boxes *b, const pn_history_boxes *more);

// Objects moved between two frames, and what bringing the frame up to them cost (wall ms).
typedef struct pn_demo_move {
    uint32_t count;       // moves (key presses, script events)
    uint32_t object;      // the last one moved
    uint32_t first, end;  // the vertices they moved: one range over all of them
    double scene_ms;      // pn_scene_move_object: world vertices, transforms, bounds (CPU)
    double vertices_ms;   // the renderers' G-buffer vertices, clip planes and scene_mag
    double top_ms;        // per-object trees: the top level rebuilt (CPU: instances, BVH over their boxes)
    double top_upload_ms; // and uploaded (object table, BVH), the rest's culling checked
    double total_ms;
    bool rebuild;         // a tree rebuild on the worker thread follows (scene-wide tree, BVH and
                          // device acceleration structure; or per-object trees whose rest's culling no longer holds)
    pn_history_boxes boxes; // the moved objects' boxes, before and after
} pn_demo_move;

// Memory (demo_stats.c): the process's and the device's, as --stats samples them.
typedef struct pn_demo_memory {
    uint64_t rss_bytes;           // resident now (/proc/self/statm; 0 where it cannot be read)
    uint64_t peak_rss_bytes;      // the most resident so far (getrusage)
    uint64_t heap_bytes;          // malloc'd and not freed, every library's (glibc: mallinfo2)
    bool heap;                    // ... where the C library tells
    uint64_t device_bytes;        // penumbra's live VkDeviceMemory (pn_gpu_device.memory_bytes)
    uint32_t device_allocations;
    uint64_t heap_usage_bytes;    // the driver's VK_EXT_memory_budget heapUsage, summed over heaps
                                  // (lavapipe: the machine's memory in use, other processes' too)
    bool heap_usage;              // ... when the device has the extension
} pn_demo_memory;

enum { PN_DEMO_RECORDS = 4096 }; // frames (120 bytes each)

typedef struct pn_demo {
    // What is shown: the render options (size, mode, traversal, sampler, spp, seed, tree, exposure)
    // change live; camera and light are the moving parts.
    pn_render_opts opts;
    pn_scene scene;
    pn_camera camera, camera_home;
    pn_light lights[PN_MAX_LIGHTS], lights_home[PN_MAX_LIGHTS];
    uint32_t light_count;    // 1 unless --light groups or the scene file give more
    uint32_t light_sel;      // the light the light keys move (L selects the next)
    float center[3], radius; // the scene's bounding sphere (without the ground), for step sizes
    pn_demo_view view;
    bool cells;              // N-tree cell overlay
    bool accumulate;         // progressive refinement while nothing changes (adaptive samples: by
                             // continuing them where V is uncertain, cmd_demo.c refines_adaptively)
    uint32_t accumulate_max; // frames, then the image is held; the history holds as many frames' samples
    bool history_on;         // the renderers keep a temporal history now (pn_demo_temporal)
    double history_samples;  // the last frame's mean samples behind a covered pixel's V (last light)
    bool show_help, show_hud;
    uint32_t object_sel;     // the object the object keys move (O selects the next)

    GLFWwindow *window;
    pn_gpu_device dev;
    pn_swapchain swapchain;
    pn_bvh bvh;               // built once; the exact pools of every tree use it
    pn_shadow_accel accel;    // the tree being drawn with
    pn_demo_builder builder;
    int want_n, want_d;       // the tree the user asked for
    bool want_rebuild;        // a light moved and the tree's culling depends on it, or an object moved
    bool scene_moved;         // an object moved: `bvh` is no longer the scene's (rebuilds make their own)
    pn_demo_move move;        // moved since the last frame, not yet in the renderers and trees
    pn_demo_move last_move;   // the last one brought into the frame, for the figures
    // What moved while the shadow structures did not follow yet (a rebuild on the worker thread):
    // the boxes of moves since the running build started, and of those it holds. The history
    // takes the latter when the build is swapped in, where shadows change.
    pn_history_boxes moved_pending, moved_building;
    char build_message[160];  // shown while a rebuild runs, after one failed, or why a key did nothing
    pn_renderer renderer;     // the current mode
    pn_renderer exact;        // exact mode, for the error view (zeroed otherwise)
    double renderer_ms;       // time the last renderer (re)creation took
    pn_demo_image image;

    // Set by the controls, consumed by the frame loop.
    bool renderer_dirty;      // recreate the renderers (mode, traversal, sampler, spp, view)
    bool restart;             // restart accumulation (camera, light, anything shown)
    bool save;                // P: write EXR + PNG of this frame
    bool quit;
    uint32_t saved;           // P presses so far, numbers the files

    // Mouse
    int drag;                 // 0 none, 1 orbit, 2 pan
    double mouse_x, mouse_y;

    uint64_t frame;           // frames presented
    uint64_t refined_rays;    // adaptive refinement: the rays the frames continued so far took
    pn_demo_stats stats;
    // The last PN_DEMO_RECORDS rendered frames' figures, for the medians printed at exit: a ring,
    // so that a demo left running for hours holds the same memory as after a minute.
    pn_demo_stats *records;
    size_t record_count;      // held, at most PN_DEMO_RECORDS
    uint64_t record_total;    // rendered frames recorded in all; the next goes to [total % PN_DEMO_RECORDS]
    const char *save_prefix;  // P writes <prefix>-NNNN.exr/.png
    FILE *stats_file;         // --stats: a sample every stats_every frames (NULL: none)
    uint32_t stats_every;
    pn_demo_memory end_memory; // after the last frame, for the summary (the device is gone by then)
} pn_demo;

// Controls (demo_controls.c)

// A key press (GLFW key and modifiers), from the window or a script.
void pn_demo_key(pn_demo *d, int key, int mods, bool repeat);
void pn_demo_orbit(pn_demo *d, float yaw_deg, float pitch_deg);
void pn_demo_pan(pn_demo *d, float x, float y); // view heights at the target's distance
void pn_demo_zoom(pn_demo *d, float factor);
// Moves object `index` (pn_scene.objects) by `delta` in world space: the scene's vertices, transform
// and bounds now, the renderers and trees before the next frame (demo_trees.c). Logs and returns false
// for no such object, or a move beyond PN_MAX_COORD from the origin.
bool pn_demo_move_object(pn_demo *d, uint32_t index, const float delta[3]);
// Parses a key name as scripts write it ("M", "shift+N", "-", "left", "pageup"); false if unknown.
bool pn_demo_key_parse(const char *name, int *key, int *mods);
// The controls, one per line, for --help and the H overlay. Writes at most n bytes.
void pn_demo_controls_text(char *out, size_t n);

// Trees (demo_trees.c), called by the frame loop before each frame.
// What a tree for the demo is built with: every mode's needs, so that a mode switch never rebuilds.
pn_shadow_accel_desc pn_demo_tree_desc(const pn_demo *d, int n, int depth);
// Swaps in a finished rebuild (renderer_dirty set) and starts the next one when the wanted tree
// (want_n, want_d, want_rebuild) differs.
pn_result pn_demo_update_tree(pn_demo *d);
// pn_demo_update_tree until no build runs or is due (a script's screenshot waits for it).
pn_result pn_demo_settle_tree(pn_demo *d);
// Brings the renderers and trees up to the objects moved since the last frame, and reports the cost.
pn_result pn_demo_apply_moves(pn_demo *d);

// Composition (demo_image.c): the frame as shown, without text, into d->image.rgba.
void pn_demo_compose(pn_demo *d);
// The overlay text (figures, build progress, help) drawn into `pixels` (the swapchain's staging
// memory, in its byte order).
void pn_demo_draw_overlay(const pn_demo *d, uint8_t *pixels, bool bgra);
// The one-line summary used as the window title.
void pn_demo_title(const pn_demo *d, char *out, size_t n);

// Memory (demo_stats.c): as --stats samples it.
pn_demo_memory pn_demo_memory_now(const pn_demo *d);
// Opens FILE for --stats and writes its header; logs and fails when it cannot.
pn_result pn_demo_stats_open(pn_demo *d, const char *path, uint32_t every);
// One line: after frame d->frame was presented. The file is flushed, so that a demo killed midway
// leaves every sample before.
void pn_demo_stats_sample(pn_demo *d);
void pn_demo_stats_close(pn_demo *d);
