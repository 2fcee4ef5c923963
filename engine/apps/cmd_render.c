// penumbra render: scene -> G-buffer -> shadows -> shading -> EXR (+ PNG preview).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/commands.h"
#include "core/log.h"
#include "core/timer.h"
#include "accel/bvh.h"
#include "accel/pools.h"
#include "gpu/renderer.h"
#include "io/exr.h"
#include "io/file.h"
#include "io/json.h"
#include "io/png.h"

// Index = pn_shadow_mode for those implemented.
static const char *const MODES[] = {"none", "linespace", "hybrid", "exact-ls", "exact", NULL};
static const bool MODE_IMPLEMENTED[] = {true, true, true, true, true};

// Modes that walk the N-tree.
static bool uses_tree(int mode) { return mode >= PN_SHADOW_LINESPACE && mode <= PN_SHADOW_EXACT_LS; }
static const char *const TRAVERSALS[] = {"packet", "ray", NULL};
static const char *const SAMPLERS[] = {"grid", "stratified", NULL};

typedef struct render_opts {
    const char *scene, *output, *preview, *ray_dump;
    uint32_t width, height;
    bool has_cam_pos, has_cam_target, has_fov;
    float cam_pos[3], cam_target[3], fov;
    bool has_light_pos, has_light_normal, has_light_up, has_light_size, has_light_radiance;
    pn_light light;
    bool ground, aovs, json;
    long long seed, spp;
    int mode, traversal, sampler, tree_n, tree_d;
    uint64_t max_bytes;
    float exposure;
} render_opts;

void pn_print_render_help(void)
{
    printf("usage: penumbra render [SCENE] [options]\n"
           "  SCENE                 a glTF 2.0 file (.gltf, .glb) or builtin:NAME (default, plane);\n"
           "                        default builtin:default\n"
           "output:\n"
           "  -o, --output FILE     EXR to write (default: <scene name>.exr); channels R G B A\n"
           "                        (A = 1 where geometry is) and shadow.V, all 32-bit float\n"
           "  --aovs                also write P.X/Y/Z, N.X/Y/Z, albedo.R/G/B and Z (view depth)\n"
           "  --preview FILE        tone-mapped sRGB PNG of the radiance\n"
           "  --exposure E          preview exposure multiplier (default 1)\n"
           "  --size WxH            image size (default 1280x720)\n"
           "  --json                print one JSON object instead of the summary line\n"
           "  --ray-dump FILE       every shadow ray (origin, light sample, valid, blocked) as binary,\n"
           "                        for checks against an independent tracer; format in\n"
           "                        engine/apps/cmd_render.c\n"
           "camera (default: the file's first camera, else framing the scene's bounds):\n"
           "  --camera-pos X,Y,Z --camera-target X,Y,Z --fov DEG (vertical, default 45)\n"
           "light (one-sided rectangular Lambertian emitter; default above the scene, facing down):\n"
           "  --light-pos X,Y,Z     centre\n"
           "  --light-normal X,Y,Z  the side it emits to\n"
           "  --light-up X,Y,Z      orients its height axis\n"
           "  --light-size W,H      width and height\n"
           "  --light-radiance R[,G,B]\n"
           "scene:\n"
           "  --ground, --no-ground add or omit a receiver plane under the scene (default: on)\n"
           "  --seed S              fixes every random choice (default 1)\n"
           "shadows:\n"
           "  --mode M              linespace (default): line-space visibility, the paper's method;\n"
           "                        hybrid: line spaces, triangles tested exactly where rays start and end;\n"
           "                        exact-ls: line spaces skip empty space, set shafts test triangles (exact);\n"
           "                        exact: BVH and watertight triangle tests (the ground truth);\n"
           "                        none: unshadowed (V = 1)\n"
           "  --tree N,d            N-tree branching factor 2..16 and depth 1..6 (default 7,3)\n"
           "  --max-memory SIZE     refuse a tree whose pools exceed SIZE (MiB or K/M/G suffix;\n"
           "                        default: half the device's largest memory heap)\n"
           "  --spp S               shadow rays per pixel 1..4096 (default 25), a grid of U x V = S\n"
           "  --traversal ray|packet   each ray walks the tree alone (3D-DDA per level, default:\n"
           "                        faster on lavapipe) or the pixel's rays walk it together\n"
           "  --sampler grid|stratified   the paper's uniform grid, or jittered strata with a\n"
           "                        per-pixel rotated low-discrepancy set (default stratified)\n");
}

static int parse(int argc, char **argv, render_opts *o)
{
    *o = (render_opts){.width = 1280, .height = 720, .ground = true, .seed = 1, .spp = 25, .tree_n = 7, .tree_d = 3,
                       .exposure = 1.0f, .fov = 45.0f, .mode = PN_SHADOW_LINESPACE, .traversal = PN_TRAVERSAL_RAY,
                       .sampler = PN_SAMPLER_STRATIFIED};
    pn_args a = {argc, argv, 0};
    while (a.i < argc) {
        const char *v = NULL;
        bool err = false, ok = true;
        const char *arg = argv[a.i];
        if (pn_args_flag(&a, "--help") || pn_args_flag(&a, "-h")) {
            pn_print_render_help();
            return -1;
        } else if (pn_args_value(&a, "-o", &v, &err) || pn_args_value(&a, "--output", &v, &err)) {
            o->output = v;
        } else if (pn_args_value(&a, "--ray-dump", &v, &err)) {
            o->ray_dump = v;
        } else if (pn_args_value(&a, "--preview", &v, &err)) {
            o->preview = v;
        } else if (pn_args_value(&a, "--size", &v, &err)) {
            ok = v && pn_parse_size("--size", v, 16384, &o->width, &o->height);
        } else if (pn_args_value(&a, "--camera-pos", &v, &err)) {
            ok = o->has_cam_pos = v && pn_parse_floats("--camera-pos", v, o->cam_pos, 3);
        } else if (pn_args_value(&a, "--camera-target", &v, &err)) {
            ok = o->has_cam_target = v && pn_parse_floats("--camera-target", v, o->cam_target, 3);
        } else if (pn_args_value(&a, "--fov", &v, &err)) {
            ok = o->has_fov = v && pn_parse_float_range("--fov", v, 0.01f, 179.0f, &o->fov);
        } else if (pn_args_value(&a, "--light-pos", &v, &err)) {
            ok = o->has_light_pos = v && pn_parse_floats("--light-pos", v, o->light.pos, 3);
        } else if (pn_args_value(&a, "--light-normal", &v, &err)) {
            ok = o->has_light_normal = v && pn_parse_floats("--light-normal", v, o->light.normal, 3);
        } else if (pn_args_value(&a, "--light-up", &v, &err)) {
            ok = o->has_light_up = v && pn_parse_floats("--light-up", v, o->light.up, 3);
        } else if (pn_args_value(&a, "--light-size", &v, &err)) {
            ok = o->has_light_size = v && pn_parse_floats("--light-size", v, o->light.size, 2);
            if (ok && !(o->light.size[0] > 0 && o->light.size[1] > 0)) {
                pn_error("--light-size: width and height must be positive, got '%s'", v);
                ok = false;
            }
        } else if (pn_args_value(&a, "--light-radiance", &v, &err)) {
            ok = o->has_light_radiance = v && pn_parse_rgb("--light-radiance", v, o->light.radiance);
            if (ok && (o->light.radiance[0] < 0 || o->light.radiance[1] < 0 || o->light.radiance[2] < 0)) {
                pn_error("--light-radiance: must not be negative, got '%s'", v);
                ok = false;
            }
        } else if (pn_args_flag(&a, "--ground")) {
            o->ground = true;
        } else if (pn_args_flag(&a, "--no-ground")) {
            o->ground = false;
        } else if (pn_args_flag(&a, "--aovs")) {
            o->aovs = true;
        } else if (pn_args_flag(&a, "--json")) {
            o->json = true;
        } else if (pn_args_value(&a, "--exposure", &v, &err)) {
            ok = v && pn_parse_float_range("--exposure", v, 0.0f, 1e30f, &o->exposure);
        } else if (pn_args_value(&a, "--seed", &v, &err)) {
            ok = v && pn_parse_int_range("--seed", v, 0, 0xffffffffll, &o->seed);
        } else if (pn_args_value(&a, "--spp", &v, &err)) {
            ok = v && pn_parse_int_range("--spp", v, 1, 4096, &o->spp);
        } else if (pn_args_value(&a, "--tree", &v, &err)) {
            ok = v && pn_parse_tree("--tree", v, &o->tree_n, &o->tree_d);
        } else if (pn_args_value(&a, "--max-memory", &v, &err)) {
            ok = v && pn_parse_bytes("--max-memory", v, &o->max_bytes);
        } else if (pn_args_value(&a, "--mode", &v, &err)) {
            ok = v && (o->mode = pn_parse_choice("--mode", v, MODES)) >= 0;
        } else if (pn_args_value(&a, "--traversal", &v, &err)) {
            ok = v && (o->traversal = pn_parse_choice("--traversal", v, TRAVERSALS)) >= 0;
        } else if (pn_args_value(&a, "--sampler", &v, &err)) {
            ok = v && (o->sampler = pn_parse_choice("--sampler", v, SAMPLERS)) >= 0;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            pn_error("render: unknown option '%s' (see penumbra render --help)", arg);
            return PN_EXIT_USAGE;
        } else if (!o->scene) {
            o->scene = arg;
            a.i++;
        } else {
            pn_error("render: more than one scene given ('%s' and '%s')", o->scene, arg);
            return PN_EXIT_USAGE;
        }
        if (err || !ok)
            return PN_EXIT_USAGE;
    }
    if (!o->scene)
        o->scene = "builtin:default";
    if (o->ray_dump && o->mode == PN_SHADOW_NONE) {
        pn_error("--ray-dump: mode none traces no rays");
        return PN_EXIT_USAGE;
    }
    if (!MODE_IMPLEMENTED[o->mode]) {
        pn_error("--mode %s: not implemented in this build", MODES[o->mode]);
        return PN_EXIT_USAGE;
    }
    return PN_EXIT_OK;
}

// "<stem>.exr" from a path or builtin:NAME.
static void default_output(const char *scene, char *out, size_t n)
{
    const char *base = strncmp(scene, "builtin:", 8) == 0 ? scene + 8 : scene;
    const char *slash = strrchr(base, '/');
    base = slash ? slash + 1 : base;
    const char *dot = strrchr(base, '.');
    int len = dot && dot != base ? (int)(dot - base) : (int)strlen(base);
    snprintf(out, n, "%.*s.exr", len, base);
}

// Fails early, before any GPU work, when an output cannot be created.
static bool output_writable(const char *path)
{
    char tmp[4096];
    if (pn_file_tmp_path(path, tmp, sizeof tmp) != PN_OK)
        return false;
    FILE *f = fopen(tmp, "wb");
    if (!f) {
        pn_error("%s: cannot write here", path);
        return false;
    }
    fclose(f);
    remove(tmp);
    return true;
}

static float v3_len(const float v[3]) { return sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

static bool setup_view(const render_opts *o, const pn_scene *s, pn_camera *cam, pn_light *light)
{
    if (s->has_camera && !o->has_cam_pos && !o->has_cam_target)
        *cam = s->camera;
    else
        pn_camera_frame(s->bounds_min, s->bounds_max, o->fov, cam);
    if (o->has_fov)
        cam->yfov_deg = o->fov;
    if (o->has_cam_pos)
        memcpy(cam->pos, o->cam_pos, sizeof cam->pos);
    if (o->has_cam_target)
        memcpy(cam->target, o->cam_target, sizeof cam->target);
    float d[3] = {cam->target[0] - cam->pos[0], cam->target[1] - cam->pos[1], cam->target[2] - cam->pos[2]};
    float dl = v3_len(d);
    if (!(dl > 0) || !(fabsf(d[0]) + fabsf(d[2]) > 1e-6f * dl)) {
        // Looking straight up or down: pick an up vector that is not parallel to the view.
        if (!(dl > 0)) {
            pn_error("camera position and target coincide");
            return false;
        }
        cam->up[0] = 0, cam->up[1] = 0, cam->up[2] = -1;
    }

    pn_light_default(s->bounds_min, s->bounds_max, light);
    if (o->has_light_pos)
        memcpy(light->pos, o->light.pos, sizeof light->pos);
    if (o->has_light_normal) {
        float l = v3_len(o->light.normal);
        if (!(l > 0)) {
            pn_error("--light-normal: must not be zero");
            return false;
        }
        for (int k = 0; k < 3; k++)
            light->normal[k] = o->light.normal[k] / l;
    } else if (o->has_light_pos) {
        // A moved light still faces the scene's centre.
        for (int k = 0; k < 3; k++)
            light->normal[k] = 0.5f * (s->bounds_min[k] + s->bounds_max[k]) - light->pos[k];
        float l = v3_len(light->normal);
        if (!(l > 0))
            light->normal[0] = 0, light->normal[1] = -1, light->normal[2] = 0;
        else
            for (int k = 0; k < 3; k++)
                light->normal[k] /= l;
    }
    if (o->has_light_up)
        memcpy(light->up, o->light.up, sizeof light->up);
    float t[3], b[3];
    if (!pn_light_frame(light, t, b)) {
        if (o->has_light_up) {
            pn_error("--light-up: must not be zero or parallel to the light's normal");
            return false;
        }
        light->up[0] = 1, light->up[1] = 0, light->up[2] = 0; // default up was parallel: any other works
        if (!pn_light_frame(light, t, b))
            light->up[0] = 0, light->up[1] = 1;
    }
    if (o->has_light_size)
        memcpy(light->size, o->light.size, sizeof light->size);
    if (o->has_light_radiance)
        memcpy(light->radiance, o->light.radiance, sizeof light->radiance);
    return true;
}

typedef struct render_stats {
    pn_frame_times times;
    uint64_t covered;    // pixels holding geometry
    double rays_per_s;   // shadow rays (covered pixels x spp) per second of the shadow pass
    double build_ms;     // N-tree and line spaces
    pn_pool_bytes pools; // zero without a tree
    uint32_t subdivided;
    uint32_t culled; // triangles left out of the tree
    uint64_t exact_bytes; // triangle pools of the exact tests (triangles, BVH, candidate lists)
} render_stats;

static pn_result write_outputs(const render_opts *o, const char *output, const pn_scene *s, const pn_camera *cam,
                               const pn_light *light, const render_stats *st, const pn_frame_images *img)
{
    const pn_frame_times *t = &st->times;
    size_t px = (size_t)o->width * o->height;
    const int planes = 15;
    float *buf = malloc(px * planes * sizeof(float));
    if (!buf) {
        pn_error("%s: out of memory for the image", output);
        return PN_ERR_MEMORY;
    }
    float *pl[15];
    for (int c = 0; c < planes; c++)
        pl[c] = buf + (size_t)c * px;
    // Planar channels from the interleaved RGBA readback.
    for (size_t i = 0; i < px; i++) {
        for (int c = 0; c < 4; c++)
            pl[c][i] = img->radiance[4 * i + c];
        pl[4][i] = img->v[i];
        for (int c = 0; c < 3; c++) {
            pl[5 + c][i] = img->p[4 * i + c];
            pl[8 + c][i] = img->n[4 * i + c];
            pl[11 + c][i] = img->albedo[4 * i + c];
        }
        pl[14][i] = img->n[4 * i + 3];
    }
    static const char *const names[15] = {"R", "G", "B", "A", "shadow.V", "P.X", "P.Y", "P.Z",
                                          "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B", "Z"};
    pn_exr_channel ch[15];
    for (int c = 0; c < planes; c++)
        ch[c] = (pn_exr_channel){names[c], pl[c]};
#define V3(nm, v) {.name = nm, .type = PN_EXR_ATTR_V3F, .f = {(v)[0], (v)[1], (v)[2]}}
#define F1(nm, v) {.name = nm, .type = PN_EXR_ATTR_FLOAT, .f = {(float)(v)}}
    pn_exr_attr attrs[] = {
        {.name = "penumbra.scene", .type = PN_EXR_ATTR_STRING, .s = s->name},
        {.name = "penumbra.mode", .type = PN_EXR_ATTR_STRING, .s = MODES[o->mode]},
        {.name = "penumbra.triangles", .type = PN_EXR_ATTR_INT, .i = (int32_t)pn_scene_triangle_count(s)},
        {.name = "penumbra.seed", .type = PN_EXR_ATTR_INT, .i = (int32_t)o->seed},
        {.name = "penumbra.width", .type = PN_EXR_ATTR_INT, .i = (int32_t)o->width},
        {.name = "penumbra.height", .type = PN_EXR_ATTR_INT, .i = (int32_t)o->height},
        V3("penumbra.camera.pos", cam->pos),
        V3("penumbra.camera.target", cam->target),
        V3("penumbra.camera.up", cam->up),
        F1("penumbra.camera.fov", cam->yfov_deg),
        V3("penumbra.light.pos", light->pos),
        V3("penumbra.light.normal", light->normal),
        V3("penumbra.light.up", light->up),
        F1("penumbra.light.width", light->size[0]),
        F1("penumbra.light.height", light->size[1]),
        V3("penumbra.light.radiance", light->radiance),
        F1("penumbra.gpu_ms.gbuffer", t->gbuffer_ms),
        F1("penumbra.gpu_ms.shadow", t->shadow_ms),
        F1("penumbra.gpu_ms.shade", t->shade_ms),
        {.name = "penumbra.traversal", .type = PN_EXR_ATTR_STRING, .s = TRAVERSALS[o->traversal]},
        {.name = "penumbra.sampler", .type = PN_EXR_ATTR_STRING, .s = SAMPLERS[o->sampler]},
        {.name = "penumbra.spp", .type = PN_EXR_ATTR_INT, .i = (int32_t)o->spp},
        {.name = "penumbra.tree.n", .type = PN_EXR_ATTR_INT, .i = uses_tree(o->mode) ? o->tree_n : 0},
        {.name = "penumbra.tree.d", .type = PN_EXR_ATTR_INT, .i = uses_tree(o->mode) ? o->tree_d : 0},
        F1("penumbra.build_ms", st->build_ms),
        F1("penumbra.shadow_rays_per_s", st->rays_per_s),
    };
#undef V3
#undef F1
    pn_result r = pn_exr_write(output, (int)o->width, (int)o->height, ch, o->aovs ? planes : 5, attrs,
                               (int)(sizeof attrs / sizeof attrs[0]));
    free(buf);
    if (r != PN_OK || !o->preview)
        return r;
    uint8_t *rgb = malloc(px * 3);
    if (!rgb) {
        pn_error("%s: out of memory for the preview", o->preview);
        return PN_ERR_MEMORY;
    }
    pn_tonemap_srgb8(img->radiance, (int)o->width, (int)o->height, o->exposure, rgb);
    r = pn_png_write_rgb8(o->preview, (int)o->width, (int)o->height, rgb);
    free(rgb);
    return r;
}


// --ray-dump file: "PNRAYS1" and a zero byte, then uint32 width, height, spp, 0, then the floats
// of pn_renderer_ray_dump (little-endian): per pixel 4 (origin xyz, 1 where geometry is), then per
// pixel and sample 4 (light point xyz, flags as uint32 bits: 1 valid, 2 blocked).
static pn_result write_ray_dump(const render_opts *o, const pn_renderer *r)
{
    uint64_t floats;
    const float *data = pn_renderer_ray_dump(r, &floats);
    char tmp[4096];
    if (!data || pn_file_tmp_path(o->ray_dump, tmp, sizeof tmp) != PN_OK)
        return PN_ERR_INVALID;
    FILE *f = fopen(tmp, "wb");
    uint32_t header[6] = {0x41524e50u, 0x00315359u, o->width, o->height, (uint32_t)o->spp, 0}; // "PNRAYS1\0"
    bool ok = f && fwrite(header, sizeof header, 1, f) == 1 && fwrite(data, sizeof(float), floats, f) == floats;
    if (f && fclose(f) != 0)
        ok = false;
    if (!ok) {
        pn_error("%s: cannot write the ray dump", o->ray_dump);
        pn_file_discard(tmp);
        return PN_ERR_IO;
    }
    return pn_file_commit(tmp, o->ray_dump);
}

// Builds what the shadow mode needs, renders one frame and writes the outputs.
static int render_frame(const render_opts *o, const char *output, pn_gpu_device *dev, const pn_scene *scene,
                        const pn_camera *cam, const pn_light *light, render_stats *st)
{
    pn_ntree tree = {0};
    pn_pools pools = {0};
    pn_gpu_pools gpu_pools = {0};
    pn_bvh bvh = {0};
    pn_gpu_exact_pools exact = {0};
    pn_renderer renderer;
    pn_renderer_desc rd = {
        .width = o->width,
        .height = o->height,
        .mode = (pn_shadow_mode)o->mode,
        .traversal = (pn_traversal)o->traversal,
        .sampler = (pn_sampler)o->sampler,
        .spp = (uint32_t)o->spp,
        .seed = (uint32_t)o->seed,
        .dump_rays = o->ray_dump != NULL,
    };
    int rc = PN_EXIT_FAILURE;
    if (uses_tree(o->mode)) {
        uint64_t max_bytes = o->max_bytes ? o->max_bytes : pn_gpu_device_heap(dev) / 2;
        float corners[4][3];
        pn_light_corners(light, corners);
        pn_ntree_desc td = {.n = o->tree_n, .d = o->tree_d, .max_bytes = max_bytes, .cull_light = (const float(*)[3])corners,
                            .keep_candidates = o->mode != PN_SHADOW_LINESPACE};
        if (pn_ntree_build(scene, &td, &tree) != PN_OK)
            return PN_EXIT_FAILURE;
        st->build_ms = tree.build_ms;
        st->subdivided = tree.node_count;
        st->culled = tree.culled;
        rd.leaf_size = pn_ntree_cell_size(&tree, tree.d);
        if (pn_pools_pack(&tree, &pools) != PN_OK || pn_gpu_pools_create(dev, &pools, &gpu_pools) != PN_OK)
            goto done;
        st->pools = pools.bytes;
        rd.pools = &gpu_pools;
    }
    if (o->mode == PN_SHADOW_EXACT) {
        if (pn_bvh_build(scene, &bvh) != PN_OK) {
            pn_error("%s: out of memory building the BVH", scene->name);
            goto done;
        }
        st->build_ms += bvh.build_ms;
    }
    if (o->mode >= PN_SHADOW_HYBRID) {
        if (pn_gpu_exact_pools_create(dev, scene, o->mode == PN_SHADOW_EXACT ? &bvh : NULL, &tree, &exact) != PN_OK)
            goto done;
        st->exact_bytes = exact.bytes;
        rd.exact = &exact;
        rd.cand_first_node = tree.cand_first_node;
    }
    if (pn_renderer_create(dev, scene, &rd, &renderer) != PN_OK)
        goto done;
    pn_frame_images img;
    if (pn_renderer_render(&renderer, cam, light, &st->times) == PN_OK) {
        pn_renderer_images(&renderer, &img);
        size_t px = (size_t)o->width * o->height;
        for (size_t i = 0; i < px; i++)
            st->covered += img.radiance[4 * i + 3] > 0;
        if (st->times.shadow_ms > 0)
            st->rays_per_s = (double)st->covered * (double)o->spp / (st->times.shadow_ms * 1e-3);
        if (write_outputs(o, output, scene, cam, light, st, &img) == PN_OK &&
            (!o->ray_dump || write_ray_dump(o, &renderer) == PN_OK))
            rc = PN_EXIT_OK;
    }
    pn_renderer_destroy(&renderer);
done:
    pn_gpu_exact_pools_destroy(dev, &exact);
    pn_bvh_destroy(&bvh);
    pn_gpu_pools_destroy(dev, &gpu_pools);
    pn_pools_destroy(&pools);
    pn_ntree_destroy(&tree);
    return rc;
}

static void print_summary(const render_opts *o, const char *output, const pn_scene *scene, const render_stats *st,
                          double load_ms, unsigned validation_messages)
{
    const pn_frame_times *t = &st->times;
    bool tree = uses_tree(o->mode);
    if (o->json) {
        printf("{\"output\": ");
        pn_json_string(stdout, output);
        printf(", \"preview\": ");
        if (o->preview)
            pn_json_string(stdout, o->preview);
        else
            printf("null");
        printf(", \"scene\": ");
        pn_json_string(stdout, scene->name);
        printf(", \"width\": %u, \"height\": %u, \"triangles\": %u, \"mode\": \"%s\", \"traversal\": \"%s\", "
               "\"sampler\": \"%s\", \"spp\": %lld, \"seed\": %lld, ",
               o->width, o->height, pn_scene_triangle_count(scene), MODES[o->mode], TRAVERSALS[o->traversal],
               SAMPLERS[o->sampler], o->spp, o->seed);
        if (tree)
            printf("\"tree\": [%d, %d], \"subdivided_nodes\": %u, \"culled_triangles\": %u, \"build_ms\": %.3f, \"pool_bytes\": {\"tree\": %llu, "
                   "\"node\": %llu, \"linespace\": %llu, \"total\": %llu}, ",
                   o->tree_n, o->tree_d, st->subdivided, st->culled, st->build_ms, (unsigned long long)st->pools.tree,
                   (unsigned long long)st->pools.node, (unsigned long long)st->pools.linespace,
                   (unsigned long long)st->pools.total);
        else
            printf("\"tree\": null, \"build_ms\": %.3f, \"pool_bytes\": null, ", st->build_ms);
        printf("\"exact_pool_bytes\": %llu, ", (unsigned long long)st->exact_bytes);
        printf("\"load_ms\": %.3f, \"gpu_ms\": {\"gbuffer\": %.4f, \"shadow\": %.4f, \"shade\": %.4f}, "
               "\"covered_pixels\": %llu, \"shadow_rays_per_s\": %.6g, \"validation_messages\": %u}\n",
               load_ms, t->gbuffer_ms, t->shadow_ms, t->shade_ms, (unsigned long long)st->covered, st->rays_per_s,
               validation_messages);
        return;
    }
    printf("%s: %u triangles, %ux%u, mode %s", scene->name, pn_scene_triangle_count(scene), o->width, o->height,
           MODES[o->mode]);
    if (tree)
        printf(" LS(%d,%d) %s", o->tree_n, o->tree_d, TRAVERSALS[o->traversal]);
    if (o->mode != PN_SHADOW_NONE)
        printf(" %s %lld spp", SAMPLERS[o->sampler], o->spp);
    printf(" -> %s%s%s\n", output, o->preview ? ", " : "", o->preview ? o->preview : "");
    if (tree)
        printf("  tree: %u subdivided nodes, %.1f MiB of pools, built in %.1f ms; %u triangles left out "
               "(they cannot block a shadow ray)\n",
               st->subdivided, st->pools.total / 1048576.0, st->build_ms, st->culled);
    if (o->mode == PN_SHADOW_EXACT)
        printf("  BVH built in %.1f ms; triangle and BVH pools %.1f MiB\n", st->build_ms, st->exact_bytes / 1048576.0);
    printf("  gpu ms: gbuffer %.3f, shadow %.3f, shade %.3f | %.3g shadow rays/s | load %.1f ms\n", t->gbuffer_ms,
           t->shadow_ms, t->shade_ms, st->rays_per_s, load_ms);
}

int pn_cmd_render(int argc, char **argv)
{
    render_opts o;
    int rc = parse(argc, argv, &o);
    if (rc != PN_EXIT_OK)
        return rc < 0 ? PN_EXIT_OK : rc;
    char default_out[1024];
    const char *output = o.output;
    if (!output) {
        default_output(o.scene, default_out, sizeof default_out);
        output = default_out;
    }
    if (!output_writable(output) || (o.preview && !output_writable(o.preview)) ||
        (o.ray_dump && !output_writable(o.ray_dump)))
        return PN_EXIT_FAILURE;

    uint64_t t0 = pn_time_ns();
    pn_scene scene;
    if (pn_scene_load(o.scene, &scene) != PN_OK)
        return PN_EXIT_FAILURE;
    double load_ms = pn_ms_since(t0);
    pn_camera cam;
    pn_light light;
    // Camera and light frame the scene itself; the ground plane is added afterwards.
    if (!setup_view(&o, &scene, &cam, &light)) {
        pn_scene_destroy(&scene);
        return PN_EXIT_USAGE;
    }
    if (o.ground && pn_scene_add_ground(&scene, 6.0f) != PN_OK) {
        pn_error("%s: out of memory adding the ground plane", scene.name);
        pn_scene_destroy(&scene);
        return PN_EXIT_FAILURE;
    }

    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    render_stats st = {0};
    int exit_code = PN_EXIT_FAILURE;
    if (pn_gpu_device_create(&desc, &dev) == PN_OK) {
        exit_code = render_frame(&o, output, &dev, &scene, &cam, &light, &st);
        pn_gpu_device_destroy(&dev);
    }
    if (exit_code == PN_EXIT_OK)
        print_summary(&o, output, &scene, &st, load_ms, dev.validation_messages);
    pn_scene_destroy(&scene);
    if (dev.validation_messages) {
        pn_error("the Vulkan validation layer reported %u message(s)", dev.validation_messages);
        return PN_EXIT_VALIDATION;
    }
    return exit_code;
}
