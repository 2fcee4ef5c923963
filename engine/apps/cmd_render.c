// penumbra render: scene -> G-buffer -> shadows -> shading -> EXR (+ PNG preview).
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/commands.h"
#include "apps/gbuffer_file.h"
#include "shadow/metrics.h"
#include "apps/options.h"
#include "shadow/quality.h"
#include "apps/render_opts.h"
#include "apps/render_output.h"
#include "apps/render_sequence.h"
#include "shadow/setup.h"
#include "core/log.h"
#include "core/timer.h"
#include "io/file.h"
#include "io/json.h"

// The options render shares with demo (apps/render_opts.h), plus its outputs: apps/options.h.
typedef pn_render_cmd_opts render_opts;

void pn_print_render_help(void)
{
    printf("usage: penumbra render [SCENE] [options]\n"
           "  SCENE                 a glTF 2.0 file (.gltf, .glb) or builtin:NAME (default, plane);\n"
           "                        default builtin:default\n"
           "output:\n"
           "  -o, --output FILE     EXR to write (default: <scene name>.exr); channels R G B A\n"
           "                        (A = 1 where geometry is) and shadow.V, all 32-bit float\n"
           "  --aovs                also write P.X/Y/Z, N.X/Y/Z, albedo.R/G/B, Z (view depth) and, with one\n"
           "                        light, shadow.valid (the rays above the horizon and in front of the light)\n"
           "                        and shadow.penumbra (the penumbra width at the mean blocker the filter\n"
           "                        reads, in world units; 3.4e38 where no ray was blocked); with\n"
           "                        --filter penumbra also shadow.footprint (its Gaussian's width,\n"
           "                        pixels) and shadow.V_window (V before its Gaussian: the\n"
           "                        interleaved filter's window's)\n"
           "  --preview FILE        tone-mapped sRGB PNG of the radiance\n"
           "  --exposure E          preview exposure multiplier (default 1)\n"
           "  --size WxH            image size (default 1280x720)\n"
           "  --json                print one JSON object instead of the summary line\n"
           "  --gbuffer FILE.exr    shadows for the points of a G-buffer instead of the raster pass's:\n"
           "                        the P.X/Y/Z, A and N.X/Y/Z layers of an EXR (render --aovs, or\n"
           "                        another renderer's); the size is the EXR's, the camera and view\n"
           "                        culling play no part, and the picture's albedo is black\n"
           "  --ray-dump FILE       every shadow ray (origin, light sample, valid, blocked) as binary,\n"
           "                        for checks against an independent tracer; format in\n"
           "                        engine/apps/cmd_render.c\n"
           "sequences (animated glTF):\n"
           "  --frames A:B[:STEP]   frames A, A+STEP, ... B, frame f at time f / fps, one EXR each: -o\n"
           "                        names them with the frame number as %%d or %%0Nd (shot.%%04d.exr); the\n"
           "                        shadow structure is built once (per-object trees: their top level\n"
           "                        follows the animation) with a line per frame and the time left\n"
           "  --fps F               frames per second of --frames (default 24)\n"
           "  --shard K/N           render every N-th frame from the K-th (1 <= K <= N): N jobs under a\n"
           "                        runner (GNU parallel, a Slurm array) render the sequence between them;\n"
           "                        with --temporal the K-th of N consecutive runs, after rendering (not\n"
           "                        writing) --history frames before its first\n"
           "  --temporal            each frame adds its samples to those its pixels' surface points\n"
           "                        gathered in the frames before (V does not depend on the camera),\n"
           "                        found through the last frame's camera; dropped where the point was\n"
           "                        not in view, where an object moved within the point's pyramid to\n"
           "                        the light, and for a light that changed; consecutive frames share\n"
           "                        the strata of a window of them (a frame's number picks its share);\n"
           "                        the EXR gets shadow.history, the samples behind each pixel's V\n"
           "  --history N           the most frames' samples the history holds, 1..4096 (default 32);\n"
           "                        beyond them older samples weigh less (an exponential window)\n"
           "quality:\n"
           "  --quality auto|manual auto: choose --mode, --tree, --spp and the filter from pilot renders\n"
           "                        (the same framing at about 128x128) against a converged exact\n"
           "                        reference (1024 samples): the fastest configuration whose mean\n"
           "                        absolute error of V stays within --max-error, uniform samples\n"
           "                        unfiltered or with the penumbra filter (--filter none: unfiltered\n"
           "                        only) or adaptive ones (--spp 4:256 at pixel errors 32x down to 1x\n"
           "                        the budget); its --spp (and --pixel-error) and filter replace yours\n"
           "                        (default manual)\n"
           "  --max-error E         the error budget of --quality auto, in [0, 1] (default 0.01; one\n"
           "                        no configuration reaches takes the least error found)\n"
           "  --no-view-cull        build the N-tree over all of the scene, not just over the box of\n"
           "                        the visible receivers and the light (which holds every shadow ray)\n");
    pn_render_opts_print_help();
}

int pn_render_parse(int argc, char **argv, render_opts *o)
{
    *o = (render_opts){.r = pn_render_opts_default(), .max_error = 0.01, .view_cull = true,
                       .seq = {.fps = 24, .shard_k = 1, .shard_n = 1, .history = 32}};
    pn_args a = {argc, argv, 0};
    bool history_given = false;
    while (a.i < argc) {
        const char *v = NULL;
        bool err = false;
        const char *arg = argv[a.i];
        if (pn_args_flag(&a, "--help") || pn_args_flag(&a, "-h")) {
            pn_print_render_help();
            return -1;
        } else if (pn_args_value(&a, "-o", &v, &err) || pn_args_value(&a, "--output", &v, &err)) {
            o->output = v;
        } else if (pn_args_value(&a, "--gbuffer", &v, &err)) {
            o->gbuffer = v;
        } else if (pn_args_value(&a, "--ray-dump", &v, &err)) {
            o->ray_dump = v;
        } else if (pn_args_value(&a, "--preview", &v, &err)) {
            o->preview = v;
        } else if (pn_args_flag(&a, "--aovs")) {
            o->aovs = true;
        } else if (pn_args_flag(&a, "--no-view-cull")) {
            o->view_cull = false;
        } else if (pn_args_value(&a, "--quality", &v, &err)) {
            int q = v ? pn_parse_choice("--quality", v, (const char *const[]){"manual", "auto", NULL}) : -1;
            if (q < 0)
                return PN_EXIT_USAGE;
            o->auto_quality = q == 1;
        } else if (pn_args_value(&a, "--max-error", &v, &err)) {
            float e;
            if (!v || !pn_parse_float_range("--max-error", v, 0.0f, 1.0f, &e))
                return PN_EXIT_USAGE;
            o->max_error = e;
        } else if (pn_args_flag(&a, "--json")) {
            o->json = true;
        } else if (pn_args_value(&a, "--frames", &v, &err)) {
            if (!v || !pn_parse_frames(v, &o->seq))
                return PN_EXIT_USAGE;
        } else if (pn_args_value(&a, "--fps", &v, &err)) {
            float fps;
            if (!v || !pn_parse_float_range("--fps", v, 1e-3f, 1e4f, &fps))
                return PN_EXIT_USAGE;
            o->seq.fps = fps;
        } else if (pn_args_flag(&a, "--temporal")) {
            o->seq.temporal = true;
        } else if (pn_args_value(&a, "--history", &v, &err)) {
            if (!v || !pn_parse_int_range("--history", v, 1, PN_HISTORY_MAX_FRAMES, &o->seq.history))
                return PN_EXIT_USAGE;
            history_given = true;
        } else if (pn_args_value(&a, "--shard", &v, &err)) {
            if (!v || !pn_parse_shard("--shard", v, &o->seq.shard_k, &o->seq.shard_n))
                return PN_EXIT_USAGE;
        } else if (pn_render_opts_parse(&a, &o->r, &err)) {
            // a shared option
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
        if (err)
            return PN_EXIT_USAGE;
    }
    if (!o->scene)
        o->scene = "builtin:default";
    if ((o->seq.temporal || history_given) && !o->seq.on) {
        pn_error("%s: carries samples from frame to frame of --frames, which is not given",
                 o->seq.temporal ? "--temporal" : "--history");
        return PN_EXIT_USAGE;
    }
    if (history_given && !o->seq.temporal) {
        pn_error("--history: the length of --temporal's history, which is not given");
        return PN_EXIT_USAGE;
    }
    if (o->seq.shard_n > 1 && !o->seq.on) {
        pn_error("--shard: shares out the frames of --frames, which is not given");
        return PN_EXIT_USAGE;
    }
    if (o->seq.on) {
        const char *clash = o->r.has_time ? "--time" : o->preview ? "--preview" : o->ray_dump ? "--ray-dump"
                          : o->auto_quality ? "--quality auto" : NULL;
        if (clash) {
            pn_error("--frames: %s is for one frame", clash);
            return PN_EXIT_USAGE;
        }
        if (!o->output) {
            pn_error("--frames: give -o with the frame number, e.g. -o shot.%%04d.exr");
            return PN_EXIT_USAGE;
        }
        if (!pn_frame_pattern_ok("-o", o->output))
            return PN_EXIT_USAGE;
    }
    if (o->gbuffer && (o->seq.on || o->auto_quality)) {
        pn_error("--gbuffer: the frame is the file's G-buffer: not with %s", o->seq.on ? "--frames" : "--quality auto");
        return PN_EXIT_USAGE;
    }
    if (o->ray_dump && !pn_shadow_mode_get(o->r.mode)->traces) {
        pn_error("--ray-dump: mode %s traces no rays", pn_shadow_mode_get(o->r.mode)->name);
        return PN_EXIT_USAGE;
    }
    pn_renderer_desc frame = pn_render_opts_setup(&o->r).frame;
    frame.dump_rays = o->ray_dump != NULL;
    if (pn_renderer_check_split(&frame) != PN_OK || pn_shadow_check_samples(&frame) != PN_OK)
        return PN_EXIT_USAGE;
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

typedef struct render_stats {
    pn_frame_times times;
    uint64_t covered;    // pixels holding geometry
    double rays_per_s;   // shadow rays (covered pixels x pn_shadow_samples) per second of the shadow pass
    double mean_rays;    // adaptive samples: the rays a covered pixel took, on average (0 otherwise)
    double build_ms;     // N-tree and line spaces
    pn_pool_bytes pools; // zero without a tree
    uint32_t subdivided;
    uint32_t trees, objects; // per-object trees: trees, and objects in the top level
    uint32_t culled; // triangles left out of the tree
    uint64_t exact_bytes; // triangle pools of the exact tests (triangles, BVH, candidate lists)
    uint32_t culled_box;        // of those, outside the view's receivers and the light
    bool quality_auto;          // --quality auto chose the mode and tree
    pn_quality_choice quality;
} render_stats;

static pn_result write_outputs(const render_opts *o, const char *output, const pn_scene *s, const pn_camera *cam,
                               const pn_light *lights, uint32_t light_count, const render_stats *st,
                               const pn_frame_images *img)
{
    pn_render_record rec = {.opts = &o->r, .scene = s, .camera = cam, .lights = lights, .light_count = light_count,
                            .times = st->times,
                            .build_ms = st->build_ms, .rays_per_s = st->rays_per_s};
    pn_result r = pn_render_write_exr(output, &rec, img, o->aovs, NULL, 0);
    if (r != PN_OK || !o->preview)
        return r;
    return pn_render_write_png(o->preview, img->radiance, o->r.width, o->r.height, o->r.exposure);
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
    uint32_t header[6] = {0x41524e50u, 0x00315359u, o->r.width, o->r.height, (uint32_t)o->r.spp, 0}; // "PNRAYS1\0"
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
                        const pn_camera *cam, const pn_light *lights, uint32_t light_count,
                        const pn_gbuffer_file *gb, render_stats *st)
{
    const pn_render_opts *p = &o->r;
    pn_setup_desc sd = pn_render_opts_setup(p);
    sd.frame.dump_rays = o->ray_dump != NULL;
    sd.frame.keep_window = o->aovs; // shadow.V_window, with the penumbra filter
    sd.view = o->view_cull && !gb ? cam : NULL; // the camera sees none of a file's G-buffer
    sd.light_count = light_count;
    pn_setup s;
    if (pn_setup_create(dev, scene, lights, &sd, &s) != PN_OK)
        return PN_EXIT_FAILURE;
    st->build_ms = s.build_ms;
    st->subdivided = s.accel.tree.node_count;
    for (uint32_t i = 0; i < s.accel.objects.tree_count; i++)
        st->subdivided += s.accel.objects.trees[i].node_count;
    for (uint32_t i = 0; i < s.accel.objects.tree_count; i++) // (a mesh no moving object instances has none)
        st->trees += s.accel.objects.trees[i].node_count > 0;
    st->objects = s.accel.objects.placed;
    st->culled = s.accel.desc.per_object ? s.accel.objects.culled : s.accel.tree.culled;
    st->culled_box = s.accel.tree.culled_box;
    st->pools = s.pool_bytes;
    st->exact_bytes = s.exact_bytes;
    int rc = PN_EXIT_FAILURE;
    pn_frame_images img;
    if ((!gb || pn_renderer_set_gbuffer(&s.renderer, gb->p, gb->n) == PN_OK) &&
        pn_renderer_render_lights(&s.renderer, cam, lights, light_count, &st->times) == PN_OK) {
        pn_renderer_images(&s.renderer, &img);
        size_t px = (size_t)p->width * p->height;
        uint64_t rays = 0;
        for (size_t i = 0; i < px; i++) {
            st->covered += img.radiance[4 * i + 3] > 0;
            rays += img.rays ? img.rays[4 * i] : 0;
        }
        // Every light's rays over the whole shadow time; adaptively, the rays the pixels took (one
        // light: the rays image is the last light's).
        if (img.rays && light_count == 1) {
            st->mean_rays = st->covered ? (double)rays / (double)st->covered : 0;
            st->rays_per_s = st->times.shadow_ms > 0 ? (double)rays / (st->times.shadow_ms * 1e-3) : 0;
        } else {
            for (uint32_t i = 0; i < light_count; i++)
                st->rays_per_s += pn_shadow_rays_per_s(st->covered, (uint32_t)p->spp, &lights[i], st->times.shadow_ms);
        }
        if (write_outputs(o, output, scene, cam, lights, light_count, st, &img) == PN_OK &&
            (!o->ray_dump || write_ray_dump(o, &s.renderer) == PN_OK))
            rc = PN_EXIT_OK;
    }
    pn_setup_destroy(dev, &s);
    return rc;
}

static void print_summary(const render_opts *o, const char *output, const pn_scene *scene, const render_stats *st,
                          double load_ms, unsigned validation_messages)
{
    const pn_frame_times *t = &st->times;
    const pn_shadow_mode_info *mode = pn_shadow_mode_get(o->r.mode);
    bool tree = mode->needs.tree;
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
               "\"sampler\": \"%s\", \"spp\": %lld, \"seed\": %lld, \"filter\": \"%s\", \"split\": \"%s\", ",
               o->r.width, o->r.height, pn_scene_triangle_count(scene), mode->name,
               pn_traversal_names[pn_traversal_resolve(o->r.mode, o->r.traversal, o->r.spp, o->r.spp_min)], pn_sampler_names[o->r.sampler],
               o->r.spp, o->r.seed,
               pn_filter_names[o->r.filter], pn_split_names[o->r.split]);
        if (o->r.spp_min)
            printf("\"spp_min\": %lld, \"pixel_error\": %.6g, \"mean_rays\": %.6g, ", o->r.spp_min,
                   (double)o->r.pixel_error, st->mean_rays);
        if (o->r.filter != PN_FILTER_NONE)
            printf("\"tile\": [%u, %u], ", o->r.tile_w, o->r.tile_h);
        else
            printf("\"tile\": null, ");
        if (tree) {
            printf("\"per_object_trees\": %u, \"objects\": %u, ", st->trees, st->objects);
            printf("\"tree\": [%d, %d], \"subdivided_nodes\": %u, \"culled_triangles\": %u, \"culled_by_view\": %u, \"build_ms\": %.3f, \"pool_bytes\": {\"tree\": %llu, "
                   "\"node\": %llu, \"linespace\": %llu, \"planes\": %llu, \"total\": %llu}, ",
                   o->r.tree_n, o->r.tree_d, st->subdivided, st->culled, st->culled_box, st->build_ms, (unsigned long long)st->pools.tree,
                   (unsigned long long)st->pools.node, (unsigned long long)st->pools.linespace,
                   (unsigned long long)st->pools.planes, (unsigned long long)st->pools.total);
        } else {
            printf("\"tree\": null, \"build_ms\": %.3f, \"pool_bytes\": null, ", st->build_ms);
        }
        printf("\"exact_pool_bytes\": %llu, ", (unsigned long long)st->exact_bytes);
        if (st->quality_auto) {
            const pn_quality_choice *q = &st->quality;
            printf("\"quality\": {\"max_error\": %.6g, \"within\": %s, \"pilot_mae\": %.17g, \"pilot_se\": %.17g, "
                   "\"pilot_shadow_ms\": %.17g, \"pilot_reference_ms\": %.4f, \"reference_spp\": %d, \"candidates\": %d, "
                   "\"runoff\": %d, \"pilot\": [%u, %u], \"frame_sample\": [%u, %u], \"filter\": \"%s\", \"tried\": ",
                   o->max_error, q->within ? "true" : "false", q->pilot_mae, q->pilot_se, q->pilot_ms, q->reference_ms,
                   PN_REFERENCE_SPP, q->candidates, q->runoff, q->pilot_width, q->pilot_height, q->frame_sample_width,
                   q->frame_sample_height,
                   pn_filter_names[q->filter]);
            pn_quality_write_tried(stdout, q);
            printf("}, ");
        }
        printf("\"load_ms\": %.3f, \"gpu_ms\": {\"gbuffer\": %.4f, \"shadow\": %.4f, \"filter\": %.4f, "
               "\"shade\": %.4f}, \"compile_ms\": %.3f, \"covered_pixels\": %llu, \"shadow_rays_per_s\": %.6g, "
               "\"validation_messages\": %u}\n",
               load_ms, t->gbuffer_ms, t->shadow_ms, t->filter_ms, t->shade_ms, t->compile_ms,
               (unsigned long long)st->covered, st->rays_per_s, validation_messages);
        return;
    }
    printf("%s: %u triangles, %ux%u, mode %s", scene->name, pn_scene_triangle_count(scene), o->r.width, o->r.height,
           mode->name);
    if (tree)
        printf(" LS(%d,%d)%s %s", o->r.tree_n, o->r.tree_d, o->r.per_object ? " per object" : "",
               pn_traversal_names[pn_traversal_resolve(o->r.mode, o->r.traversal, o->r.spp, o->r.spp_min)]);
    if (mode->traces && o->r.spp_min)
        printf(" adaptive %lld:%lld spp to a pixel error of %g", o->r.spp_min, o->r.spp, (double)o->r.pixel_error);
    if (mode->traces && o->r.spp_min && st->mean_rays > 0) // one light: its rays image
        printf(" (%.1f rays per pixel)", st->mean_rays);
    if (mode->traces && !o->r.spp_min)
        printf(" %s %lld spp%s", pn_sampler_names[o->r.sampler], o->r.spp,
               o->r.split == PN_SPLIT_BUDGET ? " per light, budgeted split" : "");
    if (o->r.filter != PN_FILTER_NONE)
        printf(" filter %s %ux%u", pn_filter_names[o->r.filter], o->r.tile_w, o->r.tile_h);
    printf(" -> %s%s%s\n", output, o->preview ? ", " : "", o->preview ? o->preview : "");
    if (tree && st->trees)
        printf("  per-object trees: %u for %u objects, %u subdivided nodes, %.1f MiB of pools, built in %.1f ms; "
               "%u triangles of no object left out (they cannot block a shadow ray)\n",
               st->trees, st->objects, st->subdivided, st->pools.total / 1048576.0, st->build_ms, st->culled);
    else if (tree)
        printf("  tree: %u subdivided nodes, %.1f MiB of pools, built in %.1f ms; %u triangles left out "
               "(they cannot block a shadow ray; %u of them outside the view and light)\n",
               st->subdivided, st->pools.total / 1048576.0, st->build_ms, st->culled, st->culled_box);
    if (mode->needs.tlas)
        printf("  acceleration structure built on the device in %.1f ms (Morton sort included); %.1f MiB\n",
               st->build_ms, st->exact_bytes / 1048576.0);
    if (mode->needs.bvh)
        printf("  BVH built in %.1f ms; triangle and BVH pools %.1f MiB\n", st->build_ms, st->exact_bytes / 1048576.0);
    printf("  gpu ms: gbuffer %.3f, shadow %.3f, filter %.3f, shade %.3f | %.3g shadow rays/s | load %.1f ms | "
           "pipelines readied in %.1f ms, apart\n",
           t->gbuffer_ms, t->shadow_ms, t->filter_ms, t->shade_ms, st->rays_per_s, load_ms, t->compile_ms);
}

int pn_cmd_render(int argc, char **argv)
{
    render_opts o;
    int rc = pn_render_parse(argc, argv, &o);
    if (rc != PN_EXIT_OK)
        return rc < 0 ? PN_EXIT_OK : rc;
    char default_out[4096];
    const char *output = o.output;
    if (o.seq.on) { // the first frame's name stands for them all
        pn_frame_name(o.output, o.seq.first, default_out, sizeof default_out);
        output = default_out;
    } else if (!output) {
        default_output(o.scene, default_out, sizeof default_out);
        output = default_out;
    }
    if (!pn_render_output_writable(output) || (o.preview && !pn_render_output_writable(o.preview)) ||
        (o.ray_dump && !pn_render_output_writable(o.ray_dump)))
        return PN_EXIT_FAILURE;

    pn_prepared_scene prep;
    rc = pn_render_prepare(&o.r, o.scene, &prep);
    if (rc != PN_EXIT_OK)
        return rc;
    pn_scene scene = prep.scene;
    pn_camera cam = prep.camera;
    double load_ms = prep.load_ms;
    pn_gbuffer_file gb = {0};
    if (o.gbuffer) {
        if (pn_gbuffer_file_read(o.gbuffer, &gb) != PN_OK) {
            pn_scene_destroy(&scene);
            return PN_EXIT_FAILURE;
        }
        o.r.width = gb.width, o.r.height = gb.height;
    }

    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    render_stats st = {0};
    int exit_code = PN_EXIT_FAILURE;
    pn_quality_choice choice = {0};
    if (pn_gpu_device_create(&desc, &dev) == PN_OK) {
        exit_code = PN_EXIT_OK;
        if (o.auto_quality && prep.light_count > 1) {
            pn_error("--quality auto chooses for one light; this render has %u", prep.light_count);
            exit_code = PN_EXIT_USAGE;
        } else if (o.auto_quality) {
            // The frame's filter says whether auto may choose one (--filter none: unfiltered only).
            pn_renderer_desc frame = pn_render_opts_setup(&o.r).frame;
            if (pn_quality_choose(&dev, &scene, &cam, &prep.lights[0], &frame, o.max_error, o.r.max_bytes, 0, false, &choice) == PN_OK) {
                o.r.mode = choice.mode;
                o.r.spp = choice.spp;
                o.r.spp_min = choice.spp_min;
                o.r.pixel_error = choice.spp_min ? choice.pixel_error : o.r.pixel_error;
                // The pick's error was measured with its filter (none or penumbra): the frame is that one.
                o.r.filter = choice.filter;
                o.r.traversal = pn_traversal_fit(o.r.mode, o.r.spp_min, o.r.traversal);
                if (choice.tree_n)
                    o.r.tree_n = choice.tree_n, o.r.tree_d = choice.tree_d;
                if (!o.json) {
                    char tree[32] = "";
                    if (choice.tree_n)
                        snprintf(tree, sizeof tree, " LS(%d,%d)", choice.tree_n, choice.tree_d);
                    char spp[64];
                    if (choice.spp_min)
                        snprintf(spp, sizeof spp, "%u:%u spp to a pixel error of %g", choice.spp_min, choice.spp,
                                 (double)choice.pixel_error);
                    else
                        snprintf(spp, sizeof spp, "%u spp", choice.spp);
                    printf("quality auto: %s%s at %s, filter %s (pilot %ux%u, %d pilots: MAE %.4f against the "
                           "converged reference, budget %.4f; shadow and filter %.1f ms on the pilot)\n",
                           pn_shadow_mode_get(choice.mode)->name, tree, spp, pn_filter_names[choice.filter],
                           choice.pilot_width, choice.pilot_height, choice.candidates, choice.pilot_mae, o.max_error,
                           choice.pilot_ms);
                }
            } else {
                exit_code = PN_EXIT_FAILURE;
            }
        }
        st.quality_auto = o.auto_quality;
        st.quality = choice;
        if (exit_code == PN_EXIT_OK && o.seq.on)
            exit_code = pn_render_sequence(&o, &prep, &dev);
        else if (exit_code == PN_EXIT_OK)
            exit_code = render_frame(&o, output, &dev, &scene, &cam, prep.lights, prep.light_count,
                                     o.gbuffer ? &gb : NULL, &st);
        pn_gpu_device_destroy(&dev);
    }
    if (exit_code == PN_EXIT_OK && !o.seq.on)
        print_summary(&o, output, &scene, &st, load_ms, dev.validation_messages);
    pn_scene_destroy(o.seq.on ? &prep.scene : &scene);
    pn_gbuffer_file_free(&gb);
    if (dev.validation_messages) {
        pn_error("the Vulkan validation layer reported %u message(s)", dev.validation_messages);
        return PN_EXIT_VALIDATION;
    }
    return exit_code;
}
