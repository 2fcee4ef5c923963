// Options and view set-up shared by render and demo.
#include "apps/render_opts.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/log.h"
#include "core/timer.h"
#include "gpu/renderer.h"
#include "scene/interior.h"

pn_render_opts pn_render_opts_default(void)
{
    return (pn_render_opts){.width = 1280, .height = 720, .ground = true, .seed = 1, .spp = 4, .pixel_error = PN_DEFAULT_PIXEL_ERROR, .tree_n = 7,
                            .tree_d = 3, .exposure = 1.0f, .fov = 45.0f, .mode = PN_SHADOW_EXACT,
                            .traversal = PN_TRAVERSAL_AUTO, .sampler = PN_SAMPLER_STRATIFIED,
                            .filter = PN_FILTER_PENUMBRA, .tile_w = 3, .tile_h = 3};
}

// One --light group: position:normal:up:size:radiance, each comma-separated, radiance R or R,G,B.
// Checked here as far as the value alone allows; pn_render_setup_view checks the geometry.
// --move-object I:DX,DY,DZ
static bool parse_move(const char *v, pn_render_opts *o)
{
    if (o->move_count == PN_MAX_MOVES) {
        pn_error("--move-object: at most %d moves", PN_MAX_MOVES);
        return false;
    }
    char buf[256];
    const char *colon = strchr(v, ':');
    if (!colon || (size_t)(colon - v) >= sizeof buf) {
        pn_error("--move-object: expected OBJECT:DX,DY,DZ (e.g. 3:0.1,0,0), got '%s'", v);
        return false;
    }
    memcpy(buf, v, (size_t)(colon - v));
    buf[colon - v] = '\0';
    long long index;
    if (!pn_parse_int_range("--move-object object", buf, 0, UINT32_MAX, &index) ||
        !pn_parse_floats("--move-object offset", colon + 1, o->moves[o->move_count].delta, 3))
        return false;
    o->moves[o->move_count++].object = (uint32_t)index;
    return true;
}


// --spp S, or MIN:MAX for adaptive samples: MAX = MIN x 2^k (the rounds double), both 1..4096.
static bool parse_spp(const char *v, pn_render_opts *o)
{
    const char *colon = strchr(v, ':');
    if (!colon) {
        o->spp_min = 0;
        return pn_parse_int_range("--spp", v, 1, 4096, &o->spp);
    }
    char lo[32];
    size_t n = (size_t)(colon - v);
    if (n >= sizeof lo) {
        pn_error("--spp %s: expected S or MIN:MAX", v);
        return false;
    }
    memcpy(lo, v, n);
    lo[n] = 0;
    long long a, b;
    if (!pn_parse_int_range("--spp", lo, 1, 4096, &a) || !pn_parse_int_range("--spp", colon + 1, 1, 4096, &b))
        return false;
    long long ratio = b % a == 0 ? b / a : 0;
    if (ratio < 2 || (ratio & (ratio - 1)) != 0) {
        pn_error("--spp %s: adaptive samples need MAX = MIN x 2, 4, 8, ... (each round doubles), e.g. 4:64", v);
        return false;
    }
    o->spp_min = a, o->spp = b;
    return true;
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
        // 0,0 is a point light (hard shadows); a segment (one side zero) has neither area nor a point.
        if (ok && !pn_light_is_point(&o->light) && !(o->light.size[0] > 0 && o->light.size[1] > 0)) {
            pn_error("--light-size: width and height must both be positive, or both 0 for a point light, got '%s'", v);
            ok = false;
        }
    } else if (pn_args_value(a, "--light-radiance", &v, err)) {
        ok = o->has_light_radiance = v && pn_parse_rgb("--light-radiance", v, o->light.radiance);
        if (ok && (o->light.radiance[0] < 0 || o->light.radiance[1] < 0 || o->light.radiance[2] < 0)) {
            pn_error("--light-radiance: must not be negative, got '%s'", v);
            ok = false;
        }
    } else if (pn_args_value(a, "--light", &v, err)) {
        ok = v && pn_parse_light_group(v, o);
    } else if (pn_args_flag(a, "--ground")) {
        o->ground = true;
    } else if (pn_args_flag(a, "--no-ground")) {
        o->ground = false;
    } else if (pn_args_value(a, "--exposure", &v, err)) {
        ok = v && pn_parse_float_range("--exposure", v, 0.0f, 1e30f, &o->exposure);
    } else if (pn_args_value(a, "--seed", &v, err)) {
        ok = v && pn_parse_int_range("--seed", v, 0, 0xffffffffll, &o->seed);
    } else if (pn_args_value(a, "--spp", &v, err)) {
        ok = v && parse_spp(v, o);
    } else if (pn_args_value(a, "--pixel-error", &v, err)) {
        ok = v && pn_parse_float_range("--pixel-error", v, 0.0f, 1.0f, &o->pixel_error);
    } else if (pn_args_value(a, "--tree", &v, err)) {
        ok = v && pn_parse_tree("--tree", v, &o->tree_n, &o->tree_d);
        o->mode = ok && !o->has_mode ? PN_SHADOW_LINESPACE : o->mode; // a tree is for line space
    } else if (pn_args_value(a, "--trees", &v, err)) {
        static const char *const trees[] = {"scene", "object", NULL};
        int t = v ? pn_parse_choice("--trees", v, trees) : -1;
        ok = t >= 0;
        o->per_object = t == 1;
        o->mode = o->per_object && !o->has_mode ? PN_SHADOW_LINESPACE : o->mode; // their only mode
    } else if (pn_args_value(a, "--move-object", &v, err)) {
        ok = v && parse_move(v, o);
    } else if (pn_args_value(a, "--time", &v, err)) {
        ok = v && pn_parse_time(v, o);
    } else if (pn_args_value(a, "--node-transform", &v, err)) {
        ok = v && pn_parse_node_transform(v, o);
    } else if (pn_args_value(a, "--max-memory", &v, err)) {
        ok = v && pn_parse_bytes("--max-memory", v, &o->max_bytes);
    } else if (pn_args_value(a, "--mode", &v, err)) {
        int m = v ? pn_shadow_mode_parse("--mode", v) : -1;
        ok = m >= 0;
        o->mode = ok ? (pn_shadow_mode)m : o->mode;
        o->has_mode = ok;
    } else if (pn_args_value(a, "--traversal", &v, err)) {
        int t = v ? pn_parse_choice("--traversal", v, pn_traversal_names) : -1;
        ok = t >= 0;
        o->traversal = ok ? (pn_traversal)t : o->traversal;
    } else if (pn_args_value(a, "--sampler", &v, err)) {
        int m = v ? pn_parse_choice("--sampler", v, pn_sampler_names) : -1;
        ok = m >= 0;
        o->sampler = ok ? (pn_sampler)m : o->sampler;
    } else if (pn_args_value(a, "--filter", &v, err)) {
        int m = v ? pn_parse_choice("--filter", v, pn_filter_names) : -1;
        ok = m >= 0;
        o->filter = ok ? (pn_filter)m : o->filter;
        o->has_filter = ok;
    } else if (pn_args_value(a, "--split", &v, err)) {
        int m = v ? pn_parse_choice("--split", v, pn_split_names) : -1;
        ok = m >= 0;
        o->split = ok ? (pn_split)m : o->split;
        // A budgeted split gives every pixel its own sample counts, which a tile's interleaving
        // cannot share: unless asked for, no filter (the renderer refuses one).
        if (ok && o->split == PN_SPLIT_BUDGET && !o->has_filter)
            o->filter = PN_FILTER_NONE;
    } else if (pn_args_value(a, "--tile", &v, err)) {
        ok = v && pn_parse_size("--tile", v, PN_FILTER_MAX_TILE, &o->tile_w, &o->tile_h);
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
           "  --light-size W,H      width and height; 0,0 is a point light (hard shadows; --light-radiance\n"
           "                        is then its radiant intensity along the normal, W/sr; one ray per pixel)\n"
           "  --light-radiance R[,G,B]\n"
           "  --light P:N:U:S:R     a whole light in one group: position, normal, up, size and radiance as\n"
           "                        above (e.g. 0,4,0:0,-1,0:0,0,1:1,1:10); repeat for up to 16 lights,\n"
           "                        which replace the default one (not combined with --light-*). The\n"
           "                        radiance sums every light's term; the EXR has one V per light\n"
           "                        (shadow.V.0, shadow.V.1, ...). Other kinds (scene/light.h):\n"
           "                        omni:P:I  a point emitting intensity I every way\n"
           "                        spot:P:DIR:INNER,OUTER:I  the same within a cone (degrees, glTF's falloff)\n"
           "                        sphere:P:R:L  a sphere of radius R and radiance L\n"
           "                        disk:P:N:U:R:L  a one-sided disk of radius R facing N\n"
           "                        sun:DIR:DIAMETER:E  light travelling along DIR from a disk DIAMETER\n"
           "                        degrees across (0.53 is the sun's), E the irradiance facing it\n"
           "                        omni, spot and sphere take a RANGE last: glTF's, the light fading\n"
           "                        out to nothing there\n"
           "scene:\n"
           "  --ground, --no-ground add or omit a receiver plane under the scene (default: on)\n"
           "  --move-object I:DX,DY,DZ   move object I (the file's I-th node with a mesh, in the\n"
           "                        order of its scene's hierarchy) by DX,DY,DZ; repeatable\n"
           "  --time SECONDS        an animated glTF at that time (its animations' keys; before the\n"
           "                        first key the first, after the last the last); the default camera,\n"
           "                        light and ground are framed on its rest pose\n"
           "  --node-transform N:TX,TY,TZ:QX,QY,QZ,QW:SX,SY,SZ   glTF node N (one an animation\n"
           "                        reaches) at this translation, rotation and scale; repeatable\n"
           "  --seed S              fixes every random choice (default 1)\n"
           "shadows:\n");
    // The modes from their table (gpu/shadow_modes.c), the tracing ones first, then none.
    for (int pass = 0; pass < 2; pass++)
        for (int m = 0; m < PN_SHADOW_MODE_COUNT; m++) {
            const pn_shadow_mode_info *info = pn_shadow_mode_get((pn_shadow_mode)m);
            if (info->traces == (pass == 0))
                printf("  %-21s %s: %s\n", m == PN_SHADOW_LINESPACE ? "--mode M" : "", info->name, info->help);
        }
    printf("  --tree N,d            N-tree branching factor 2..16 and depth 1..6 (default 7,3); without\n"
           "                        --mode it selects --mode linespace, the default being exact\n"
           "  --trees scene|object  one N-tree over the whole scene (default), or one per mesh in its\n"
           "                        own frame, shared by its instances, under a top-level BVH over the\n"
           "                        objects (linespace mode, selected by it without --mode; a moving\n"
           "                        object rebuilds only the top level)\n"
           "  --max-memory SIZE     refuse a tree whose pools exceed SIZE (MiB or K/M/G suffix;\n"
           "                        default: half the device's largest memory heap)\n"
           "  --spp S               shadow rays per pixel 1..4096 (default 4), a grid of U x V = S\n"
           "  --spp MIN:MAX         adaptive: MIN rays per pixel, then rounds that double the rays of\n"
           "                        the pixels whose V is still uncertain, up to MAX = MIN x 2^k; the\n"
           "                        EXR gets shadow.rays and shadow.V_stderr\n"
           "  --pixel-error E       adaptive: a pixel stops once the standard error of its V, from\n"
           "                        its own and its neighbours' samples, is below E (default %.3g)\n"
           "  --traversal auto|ray|packet|project   each ray walks the tree alone, or the pixel's\n"
           "                        rays walk it together; project (exact): one walk of the pixel's\n"
           "                        pyramid to the light projects its triangles onto it, answering\n"
           "                        every sample at once (up to 1024 a walk), rays past a budget;\n"
           "                        default auto: for exact packet, project from 256 spp; ray for\n"
           "                        the line-space modes (the fastest of each on lavapipe)\n"
           "  --sampler grid|stratified   the paper's uniform grid, or jittered strata with a\n"
           "                        per-pixel rotated low-discrepancy set (default stratified)\n"
           "  --filter none|interleaved|penumbra   interleaved: the pixels of each tile share the light's\n"
           "                        samples (each traces S of the tile's S x W x H) and a filter\n"
           "                        averages V over the tile across the pixel's own surface where\n"
           "                        V agrees up to the samples' noise; the EXR keeps the\n"
           "                        unfiltered V as shadow.V_raw. penumbra (default): interleaved,\n"
           "                        then a Gaussian over the pixel's surface as wide as the\n"
           "                        penumbra its nearest blocker casts, narrowing as 1/sqrt(S)\n"
           "                        (shadow.footprint with --aovs: its width, pixels): the fastest\n"
           "                        to mean error 0.01 on the bench's views; none for a reference\n"
           "  --tile WxH            the tile and filter window, 1..8 each (default 3x3)\n"
           "  --split even|budget   several lights: S rays per pixel for each (default even), or S x\n"
           "                        lights rays per pixel in all, shared by each light's unshadowed\n"
           "                        irradiance at the pixel, at least one per light that reaches it\n"
           "                        (budget: stratified sampler; the filter defaults to none, the\n"
           "                        interleaved one shares one set of samples per tile)\n",
           (double)PN_DEFAULT_PIXEL_ERROR);
}

// Normalises v in double precision, so that neither huge (1e30) nor tiny (1e-30) components
// overflow or underflow on the way; false for a zero or non-finite vector.
static bool v3_unit(const float v[3], float out[3])
{
    double l = sqrt((double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2]);
    if (!(l > 0) || !isfinite(l))
        return false;
    for (int k = 0; k < 3; k++)
        out[k] = (float)(v[k] / l);
    return true;
}

// Logs and returns false when a point is farther than PN_MAX_COORD from the origin along an axis.
static bool in_range(const char *what, const float v[3])
{
    for (int k = 0; k < 3; k++)
        if (!(fabsf(v[k]) <= PN_MAX_COORD)) {
            pn_error("%s (%g, %g, %g) is beyond %g from the origin, where float arithmetic overflows", what,
                     (double)v[0], (double)v[1], (double)v[2], (double)PN_MAX_COORD);
            return false;
        }
    return true;
}

// Logs and returns false when the light's centre or a corner is out of range (in_range).
static bool light_in_range(const char *what, const pn_light *l)
{
    char name[96];
    snprintf(name, sizeof name, "%s's position", what);
    if (!in_range(name, l->pos))
        return false;
    float corners[4][3];
    pn_light_corners(l, corners);
    snprintf(name, sizeof name, "a corner of %s", what);
    for (int i = 0; i < 4; i++)
        if (!in_range(name, corners[i]))
            return false;
    return true;
}

// --light-pos/-normal/-up/-size/-radiance: changes to the one default light.
static bool light_flags_given(const pn_render_opts *o)
{
    return o->has_light_pos || o->has_light_normal || o->has_light_up || o->has_light_size || o->has_light_radiance;
}

static bool default_light(const pn_render_opts *o, const pn_scene *s, const pn_interior *interior, pn_light *lights,
                          uint32_t *light_count);

bool pn_render_setup_view(const pn_render_opts *o, const pn_scene *s, pn_camera *cam, pn_light *lights,
                          uint32_t *light_count)
{
    // A scene that encloses its centre (an atrium, a room) is seen from inside, by the camera and
    // the light its interior gives (scene/interior.h), unless the file or the options place them.
    bool frame = !(s->has_camera && !o->has_cam_pos && !o->has_cam_target);
    bool default_one = o->light_count == 0 && (s->light_count == 0 || light_flags_given(o));
    pn_interior interior = {0};
    if (frame || default_one)
        pn_interior_find(s, o->fov, &interior);
    if (!frame)
        *cam = s->camera;
    else if (interior.is_interior)
        *cam = interior.camera;
    else
        pn_camera_frame(s->bounds_min, s->bounds_max, o->fov, cam);
    if (!pn_render_finish_camera(o, cam))
        return false;

    bool light_flags = light_flags_given(o);
    if (o->light_count > 0 && light_flags) {
        pn_error("--light and --light-pos/-normal/-up/-size/-radiance: give each light as one --light group, or "
                 "change the one default light with the others");
        return false;
    }
    // The --light groups, else the scene file's lights unless --light-* asks for the default one.
    const pn_light *given = o->light_count ? o->lights : s->lights;
    uint32_t count = o->light_count ? o->light_count : light_flags ? 0 : s->light_count;
    if (count > PN_MAX_LIGHTS) {
        pn_error("%s: %u lights; a frame takes at most %d", s->name, count, PN_MAX_LIGHTS);
        return false;
    }
    if (count > 0) {
        for (uint32_t i = 0; i < count; i++) {
            char what[300];
            if (o->light_count)
                snprintf(what, sizeof what, "--light %u", i + 1);
            else
                snprintf(what, sizeof what, "%s: light %u", s->name, i);
            if (!pn_render_finish_light(what, &given[i], s->bounds_min, s->bounds_max, &lights[i]))
                return false;
        }
        *light_count = count;
        return true;
    }
    return default_light(o, s, &interior, lights, light_count);
}

bool pn_render_finish_camera(const pn_render_opts *o, pn_camera *cam)
{
    if (o->has_fov)
        cam->yfov_deg = o->fov;
    if (o->has_cam_pos)
        memcpy(cam->pos, o->cam_pos, sizeof cam->pos);
    if (o->has_cam_target)
        memcpy(cam->target, o->cam_target, sizeof cam->target);
    // (A framing camera can land out of range too: a huge scene seen through a narrow --fov.)
    if (!in_range("camera position", cam->pos) || !in_range("camera target", cam->target))
        return false;
    float d[3] = {cam->target[0] - cam->pos[0], cam->target[1] - cam->pos[1], cam->target[2] - cam->pos[2]};
    float dl = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]); // in range: no overflow
    // The view matrix (cglm) takes a direction shorter than FLT_EPSILON for zero.
    if (!(dl >= FLT_EPSILON)) {
        pn_error("camera position and target coincide or nearly (%g apart; the view needs %g)", (double)dl,
                 (double)FLT_EPSILON);
        return false;
    }
    if (!(fabsf(d[0]) + fabsf(d[2]) > 1e-6f * dl)) // looking straight up or down: an up vector not parallel to the view
        cam->up[0] = 0, cam->up[1] = 0, cam->up[2] = -1;
    return true;
}

bool pn_render_finish_light(const char *what, const pn_light *given, const float lo[3], const float hi[3], pn_light *l)
{
    *l = *given;
    float t[3], b[3];
    if (!v3_unit(given->normal, l->normal) || !v3_unit(given->up, l->up) || !pn_light_frame(l, t, b)) {
        pn_error("%s: the normal and up must not be zero, nor parallel to each other", what);
        return false;
    }
    if (l->kind == PN_LIGHT_SUN && !pn_light_place_sun(l, lo, hi)) {
        pn_error("%s: a sun needs the scene within 1e12 of its size from the origin", what);
        return false;
    }
    return light_in_range(what, l);
}

// The one light framed on the scene (or its interior), changed by --light-*.
static bool default_light(const pn_render_opts *o, const pn_scene *s, const pn_interior *interior, pn_light *lights,
                          uint32_t *light_count)
{
    *light_count = 1;
    pn_light *light = &lights[0];
    if (interior->is_interior)
        *light = interior->light;
    else
        pn_light_default(s->bounds_min, s->bounds_max, light);
    if (o->has_light_pos)
        memcpy(light->pos, o->light.pos, sizeof light->pos);
    if (!in_range("light position", light->pos))
        return false;
    if (o->has_light_normal) {
        if (!v3_unit(o->light.normal, light->normal)) {
            pn_error("--light-normal: must not be zero");
            return false;
        }
    } else if (o->has_light_pos) {
        // A moved light still faces the scene's centre.
        float to_centre[3];
        for (int k = 0; k < 3; k++)
            to_centre[k] = 0.5f * (s->bounds_min[k] + s->bounds_max[k]) - light->pos[k];
        if (!v3_unit(to_centre, light->normal))
            light->normal[0] = 0, light->normal[1] = -1, light->normal[2] = 0;
    }
    // Only its direction matters: unit length keeps pn_light_frame's float products in range.
    if (o->has_light_up && !v3_unit(o->light.up, light->up)) {
        pn_error("--light-up: must not be zero or parallel to the light's normal");
        return false;
    }
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
    if (o->has_light_size) {
        // A point light emits its radiant intensity as radiance x area did: without
        // --light-radiance, the default light's intensity along its normal, so the picture keeps
        // its brightness and only the penumbrae go.
        if (pn_light_is_point(&o->light))
            for (int k = 0; k < 3; k++)
                light->radiance[k] *= light->size[0] * light->size[1];
        memcpy(light->size, o->light.size, sizeof light->size);
    }
    if (o->has_light_radiance)
        memcpy(light->radiance, o->light.radiance, sizeof light->radiance);
    return light_in_range("the light", light);
}

pn_setup_desc pn_render_opts_setup(const pn_render_opts *o)
{
    return (pn_setup_desc){
        .frame = {.width = o->width,
                  .height = o->height,
                  .mode = o->mode,
                  .traversal = o->traversal,
                  .sampler = o->sampler,
                  .filter = o->filter,
                  .split = o->split,
                  .tile_w = o->tile_w,
                  .tile_h = o->tile_h,
                  .spp = (uint32_t)o->spp,
                  .spp_min = (uint32_t)o->spp_min,
                  .pixel_error = o->pixel_error,
                  .seed = (uint32_t)o->seed},
        .tree_n = o->tree_n,
        .tree_d = o->tree_d,
        .max_bytes = o->max_bytes,
        .per_object = o->per_object,
    };
}

int pn_render_prepare(const pn_render_opts *o, const char *source, pn_prepared_scene *out)
{
    memset(out, 0, sizeof *out);
    uint64_t t0 = pn_time_ns();
    if (pn_scene_load(source, &out->scene) != PN_OK)
        return PN_EXIT_FAILURE;
    out->load_ms = pn_ms_since(t0);
    for (uint32_t i = 0; i < o->node_transform_count; i++) {
        const pn_node_transform *x = &o->node_transforms[i];
        if (pn_scene_set_node_transform(&out->scene, x->node, x->t, x->r, x->s) != PN_OK) {
            pn_scene_destroy(&out->scene);
            return PN_EXIT_USAGE;
        }
    }
    out->file_camera = out->scene.has_camera && !o->has_cam_pos && !o->has_cam_target;
    out->file_lights = o->light_count == 0 && !light_flags_given(o) && out->scene.light_count > 0;
    for (uint32_t i = 0; i < o->move_count; i++)
        if (pn_scene_move_object(&out->scene, o->moves[i].object, o->moves[i].delta) != PN_OK) {
            pn_scene_destroy(&out->scene);
            return PN_EXIT_USAGE;
        }
    if (o->move_count && pn_scene_validate(&out->scene) != PN_OK) { // a move may leave float range
        pn_scene_destroy(&out->scene);
        return PN_EXIT_USAGE;
    }
    memcpy(out->object_min, out->scene.bounds_min, sizeof out->object_min);
    memcpy(out->object_max, out->scene.bounds_max, sizeof out->object_max);
    // Camera and light frame the scene itself; the ground plane is added afterwards.
    if (!pn_render_setup_view(o, &out->scene, &out->camera, out->lights, &out->light_count)) {
        pn_scene_destroy(&out->scene);
        return PN_EXIT_USAGE;
    }
    if (o->ground && pn_scene_add_ground(&out->scene, 6.0f) != PN_OK) {
        pn_error("%s: out of memory adding the ground plane", out->scene.name);
        pn_scene_destroy(&out->scene);
        return PN_EXIT_FAILURE;
    }
    if (o->has_time || o->node_transform_count) {
        int rc = pn_render_pose(o, out, o->has_time ? o->time : NAN);
        if (rc != PN_EXIT_OK) {
            pn_scene_destroy(&out->scene);
            return rc;
        }
    }
    return PN_EXIT_OK;
}
