// Options shared by render and demo: defaults, parsing, help and the set-up they give. The view
// set-up and the prepared scene they shape are render_prepare.c's.
#include "apps/render_opts.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/log.h"
#include "gpu/renderer.h"

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
           "                        EXR gets shadow.rays and shadow.V_stderr. Under the penumbra\n"
           "                        filter only where it cannot average: the nearest blocker's\n"
           "                        penumbra under 2 pixels wide (contacts, creases, terminators)\n"
           "  --pixel-error E       adaptive: a pixel stops once the standard error of its V, from\n"
           "                        its own and its neighbours' samples, is below E (default %.3g);\n"
           "                        under the penumbra filter also where its penumbra is 2 pixels\n"
           "                        wide or more (not in the demo's refinement)\n"
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
           "                        (shadow.footprint with --aovs: its width, pixels; and\n"
           "                        shadow.V_window: V before it): the fastest\n"
           "                        to mean error 0.01 on the bench's views; none for a reference\n"
           "  --tile WxH            the tile and filter window, 1..8 each (default 3x3)\n"
           "  --split even|budget   several lights: S rays per pixel for each (default even), or S x\n"
           "                        lights rays per pixel in all, shared by each light's unshadowed\n"
           "                        irradiance at the pixel, at least one per light that reaches it\n"
           "                        (budget: stratified sampler; the filter defaults to none, the\n"
           "                        interleaved one shares one set of samples per tile)\n",
           (double)PN_DEFAULT_PIXEL_ERROR);
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
