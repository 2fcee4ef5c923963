// Options and view set-up shared by render and demo.
#include "apps/render_opts.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/log.h"
#include "gpu/renderer.h"

const char *const pn_mode_names[] = {"none", "linespace", "hybrid", "exact-ls", "exact", NULL};
const char *const pn_traversal_names[] = {"packet", "ray", NULL};
const char *const pn_sampler_names[] = {"grid", "stratified", NULL};

pn_render_opts pn_render_opts_default(void)
{
    return (pn_render_opts){.width = 1280, .height = 720, .ground = true, .seed = 1, .spp = 25, .tree_n = 7,
                            .tree_d = 3, .exposure = 1.0f, .fov = 45.0f, .mode = PN_SHADOW_LINESPACE,
                            .traversal = PN_TRAVERSAL_RAY, .sampler = PN_SAMPLER_STRATIFIED};
}

bool pn_render_opts_parse(pn_args *a, pn_render_opts *o, bool *err)
{
    const char *v = NULL;
    bool ok = true;
    if (pn_args_value(a, "--size", &v, err)) {
        ok = v && pn_parse_size("--size", v, 16384, &o->width, &o->height);
    } else if (pn_args_value(a, "--camera-pos", &v, err)) {
        ok = o->has_cam_pos = v && pn_parse_floats("--camera-pos", v, o->cam_pos, 3);
    } else if (pn_args_value(a, "--camera-target", &v, err)) {
        ok = o->has_cam_target = v && pn_parse_floats("--camera-target", v, o->cam_target, 3);
    } else if (pn_args_value(a, "--fov", &v, err)) {
        ok = o->has_fov = v && pn_parse_float_range("--fov", v, 0.01f, 179.0f, &o->fov);
    } else if (pn_args_value(a, "--light-pos", &v, err)) {
        ok = o->has_light_pos = v && pn_parse_floats("--light-pos", v, o->light.pos, 3);
    } else if (pn_args_value(a, "--light-normal", &v, err)) {
        ok = o->has_light_normal = v && pn_parse_floats("--light-normal", v, o->light.normal, 3);
    } else if (pn_args_value(a, "--light-up", &v, err)) {
        ok = o->has_light_up = v && pn_parse_floats("--light-up", v, o->light.up, 3);
    } else if (pn_args_value(a, "--light-size", &v, err)) {
        ok = o->has_light_size = v && pn_parse_floats("--light-size", v, o->light.size, 2);
        if (ok && !(o->light.size[0] > 0 && o->light.size[1] > 0)) {
            pn_error("--light-size: width and height must be positive, got '%s'", v);
            ok = false;
        }
    } else if (pn_args_value(a, "--light-radiance", &v, err)) {
        ok = o->has_light_radiance = v && pn_parse_rgb("--light-radiance", v, o->light.radiance);
        if (ok && (o->light.radiance[0] < 0 || o->light.radiance[1] < 0 || o->light.radiance[2] < 0)) {
            pn_error("--light-radiance: must not be negative, got '%s'", v);
            ok = false;
        }
    } else if (pn_args_flag(a, "--ground")) {
        o->ground = true;
    } else if (pn_args_flag(a, "--no-ground")) {
        o->ground = false;
    } else if (pn_args_value(a, "--exposure", &v, err)) {
        ok = v && pn_parse_float_range("--exposure", v, 0.0f, 1e30f, &o->exposure);
    } else if (pn_args_value(a, "--seed", &v, err)) {
        ok = v && pn_parse_int_range("--seed", v, 0, 0xffffffffll, &o->seed);
    } else if (pn_args_value(a, "--spp", &v, err)) {
        ok = v && pn_parse_int_range("--spp", v, 1, 4096, &o->spp);
    } else if (pn_args_value(a, "--tree", &v, err)) {
        ok = v && pn_parse_tree("--tree", v, &o->tree_n, &o->tree_d);
    } else if (pn_args_value(a, "--max-memory", &v, err)) {
        ok = v && pn_parse_bytes("--max-memory", v, &o->max_bytes);
    } else if (pn_args_value(a, "--mode", &v, err)) {
        ok = v && (o->mode = pn_parse_choice("--mode", v, pn_mode_names)) >= 0;
    } else if (pn_args_value(a, "--traversal", &v, err)) {
        ok = v && (o->traversal = pn_parse_choice("--traversal", v, pn_traversal_names)) >= 0;
    } else if (pn_args_value(a, "--sampler", &v, err)) {
        ok = v && (o->sampler = pn_parse_choice("--sampler", v, pn_sampler_names)) >= 0;
    } else {
        return false;
    }
    if (!ok)
        *err = true;
    return true;
}

void pn_render_opts_print_help(void)
{
    printf("camera (default: the file's first camera, else framing the scene's bounds):\n"
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

static float v3_len(const float v[3]) { return sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

bool pn_render_setup_view(const pn_render_opts *o, const pn_scene *s, pn_camera *cam, pn_light *light)
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
