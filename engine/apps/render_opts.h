// The options that describe a render, shared by `render` and `demo`: size, camera, light, shadow
// mode and its parameters; and the camera and light they set up for a scene.
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "apps/args.h"
#include "shadow/setup.h"
#include "gpu/shadow_modes.h"
#include "scene/anim.h"
#include "scene/view.h"

// --pixel-error's default: adaptive sampling's target standard error of a pixel's V.
#define PN_DEFAULT_PIXEL_ERROR 0.02f

// --move-object options at most.
enum { PN_MAX_MOVES = 16 };

// The camera and light feed float arithmetic that squares distances (the view matrix, the light's
// corners, the shading integral): beyond this distance from the origin those squares overflow.
// The same limit pn_scene_validate puts on the scene's positions (and the demo on moved objects).
#define PN_MAX_COORD 1e18f

// --node-transform: glTF node `node`'s translation, rotation (x,y,z,w) and scale.
typedef struct pn_node_transform {
    uint32_t node;
    double t[3], r[4], s[3];
} pn_node_transform;

// The parameters of one render. The has_* flags mark what the command line set explicitly; the
// rest comes from the scene (pn_render_setup_view).
typedef struct pn_render_opts {
    uint32_t width, height;
    bool has_cam_pos, has_cam_target, has_fov;
    float cam_pos[3], cam_target[3], fov;
    bool has_light_pos, has_light_normal, has_light_up, has_light_size, has_light_radiance;
    pn_light light; // only the fields whose has_light_* flag is set
    // --light groups, each a whole light (position:normal:up:size:radiance); they replace the
    // scene's lights and cannot be combined with --light-*.
    uint32_t light_count;
    pn_light lights[PN_MAX_LIGHTS];
    bool ground;
    long long seed, spp;
    long long spp_min;  // --spp MIN:MAX: MIN (spp is MAX); 0: every pixel takes spp
    float pixel_error;  // --pixel-error: adaptive sampling's target standard error of V per pixel
    pn_shadow_mode mode;
    pn_traversal traversal;
    pn_sampler sampler;
    pn_filter filter;
    bool has_filter;    // --filter given: --split budget otherwise turns the filter off
    bool has_mode;      // --mode given: --tree and --trees object otherwise choose linespace
    uint32_t tile_w, tile_h;
    pn_split split;     // --split: how several lights share a pixel's rays
    int tree_n, tree_d;
    bool per_object;    // --trees object: one tree per mesh and a top level (accel/objects.h)
    // --move-object I:DX,DY,DZ: object I (the file's I-th node with a mesh) moved by that much in
    // world space after loading, before the view is framed.
    uint32_t move_count;
    struct {
        uint32_t object;
        float delta[3];
    } moves[PN_MAX_MOVES];
    uint64_t max_bytes; // 0: half the device's largest heap
    float exposure;     // of the tone-mapped PNG
    // Animated scenes (scene/anim.h, apps/anim_opts.c): --time SECONDS poses the scene at that
    // time; --node-transform gives a node the file animates its translation, rotation and scale.
    bool has_time;
    double time;
    uint32_t node_transform_count;
    pn_node_transform node_transforms[PN_MAX_MOVES];
} pn_render_opts;

// The defaults render documents: 1280x720, exact, auto traversal, stratified, 4 spp (with the
// filter the front of the bench's time-to-error tables at reference MAE 0.02 on its four views:
// engine/apps/bench/README.md), LS(7,3) for the line-space modes, seed 1, the interleaved filter over 3x3
// tiles (engine/gpu/README.md: it lowers the error against the converged reference at 4-64 spp on the bench's
// views), ground on, exposure 1, 45 degree field of
// view.
pn_render_opts pn_render_opts_default(void);

// If argv[a->i] is one of the shared options (--size, --camera-*, --fov, --light-*, --ground,
// --no-ground, --exposure, --seed, --spp, --pixel-error, --tree, --trees, --move-object, --max-memory, --mode, --traversal, --sampler, --filter, --tile, --split),
// consumes it and returns true; a bad value is logged and sets *err.
bool pn_render_opts_parse(pn_args *a, pn_render_opts *o, bool *err);

// Prints the help of the camera, light, scene and shadow options (the sections both commands share).
void pn_render_opts_print_help(void);

// Parses one --light group into o->lights (apps/light_opts.c); logs the problem and returns false.
bool pn_parse_light_group(const char *v, pn_render_opts *o);

// Camera and lights from the scene's bounds (and camera), overridden by the options: the --light
// groups, else one light (the default above the scene, changed by --light-*). Call before the
// ground plane is added: the defaults frame the scene itself. Logs and returns false for a
// degenerate camera or light. lights has room for PN_MAX_LIGHTS. (This, the finishing, the
// prepared scene and its posing below: apps/render_prepare.c.)
bool pn_render_setup_view(const pn_render_opts *o, const pn_scene *s, pn_camera *cam, pn_light *lights,
                          uint32_t *light_count);

// The camera as the options finish it (--fov, --camera-pos, --camera-target over `cam`, an up
// vector that is not along the view), and a light the scene or --light gives as the frame takes it
// (unit normal and up, a sun placed for the bounds lo..hi); both log what is wrong (`what` names
// the light) and return false.
bool pn_render_finish_camera(const pn_render_opts *o, pn_camera *cam);
bool pn_render_finish_light(const char *what, const pn_light *given, const float lo[3], const float hi[3], pn_light *l);

// The one translation of the options into a set-up: frame size, mode, traversal, sampler, samples,
// seed, tree and memory limit. The caller adds what is its own (view culling, ray dumps).
pn_setup_desc pn_render_opts_setup(const pn_render_opts *o);

// A scene ready to render as the options say: loaded (glTF file or builtin:NAME), camera and light
// framed on the scene itself, then the ground plane added under it (--ground).
typedef struct pn_prepared_scene {
    pn_scene scene;
    pn_camera camera;
    pn_light lights[PN_MAX_LIGHTS]; // light_count of them (1 unless --light groups say otherwise)
    uint32_t light_count;
    float object_min[3], object_max[3]; // the scene's bounds before the ground plane
    double load_ms;
    // Animated scenes: the framing (camera and light by default, the ground) is the rest pose's;
    // the file's camera and lights, where in use, follow their nodes (pn_render_pose).
    bool file_camera, file_lights;
    pn_pose_report pose; // the last pose
} pn_prepared_scene;

// Logs what went wrong and returns PN_EXIT_FAILURE (unreadable scene, out of memory) or
// PN_EXIT_USAGE (a camera or light the options make degenerate); *out holds nothing then.
// An animated scene is framed at its rest pose and then posed at --time (or with
// --node-transform's alone): pn_render_pose.
int pn_render_prepare(const pn_render_opts *o, const char *source, pn_prepared_scene *out);

// --time SECONDS (apps/anim_opts.c).
bool pn_parse_time(const char *v, pn_render_opts *o);
// --node-transform NODE:TX,TY,TZ:QX,QY,QZ,QW:SX,SY,SZ.
bool pn_parse_node_transform(const char *v, pn_render_opts *o);

// Poses the prepared scene at `time` (NAN: the rest, with --node-transform's): its objects, and
// the file's camera and lights where the frame uses them (else the framing stays). Returns
// PN_EXIT_OK, or logs and returns PN_EXIT_USAGE (a pose out of range).
int pn_render_pose(const pn_render_opts *o, pn_prepared_scene *p, double time);
