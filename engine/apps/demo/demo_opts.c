// penumbra demo: its help and command line (the window, frames and knobs are in cmd_demo.c).
#include <stdio.h>
#include <string.h>

#include "apps/commands.h"
#include "apps/demo/demo.h"
#include "core/log.h"

void pn_print_demo_help(void)
{
    printf("usage: penumbra demo [SCENE] [options]\n"
           "  Opens a window and runs render's passes every frame, with the camera, light and shadow\n"
           "  parameters under live control. SCENE as for render (default builtin:default).\n"
           "window and run:\n"
           "  --size WxH            initial window size (default 800x450)\n"
           "  --frames N            exit after N frames (default: when the window closes)\n"
           "  --screenshot FILE     save the last frame as PNG (the image as shown, without the text)\n"
           "  --script FILE         replay key presses and camera moves (format below)\n"
           "  --no-accumulate       every frame stands alone (default: the temporal history, as\n"
           "                        render --temporal: each frame adds its samples to those its\n"
           "                        pixels' surface points gathered before, through camera moves;\n"
           "                        a light change drops its own, an object move what its bounds\n"
           "                        reach. With --spp MIN:MAX frames continue the adaptive samples)\n"
           "  --accumulate-max N    the history's length in frames (its samples a window of N\n"
           "                        frames'), and the frames after a change before the image is\n"
           "                        held (default 256)\n"
           "  --no-hud              start without the figures (I toggles them)\n"
           "  --no-vsync            present without waiting for the display when the surface allows\n"
           "  --save-prefix P       P saves P-NNNN.exr (every parameter in the header) and P-NNNN.png\n"
           "                        (default penumbra-demo)\n"
           "  --stats FILE          write memory samples to FILE (tab-separated, a header first): every\n"
           "                        --stats-every frames and after the last, the frame, the process's\n"
           "                        resident and peak resident bytes, the bytes malloc'd and not freed\n"
           "                        (glibc), penumbra's live device memory\n"
           "                        (bytes, allocations), the driver's heap usage (VK_EXT_memory_budget;\n"
           "                        -1 without it), the tree's pools, whether a tree build runs, and the\n"
           "                        configuration (mode, tree, traversal, sampler, spp, filter, view,\n"
           "                        size). The summary at exit gives the same figures\n"
           "  --stats-every N       frames between samples (default 100)\n"
           "  --exposure E          tone-mapping exposure multiplier (default 1)\n"
           "  --spp S               as below, but 4 by default: accumulation adds samples over frames\n");
    pn_render_opts_print_help();
    char controls[4096];
    pn_demo_controls_text(controls, sizeof controls);
    printf("controls:\n%s", controls);
    printf("script (--script FILE): one event per line, applied before frame N (0 the first) renders;\n"
           "'#' starts a comment:\n"
           "  frame N key [shift+]KEY   a key as above (letters, digits, ',-./;=[]', left, right, up,\n"
           "                            down, pageup, pagedown, escape, space)\n"
           "  frame N orbit YAW PITCH   turn the camera around its target, degrees (+ right, + up)\n"
           "  frame N pan X Y           move the scene on screen by X, Y view heights (y down)\n"
           "  frame N zoom F            multiply the distance to the target by F\n"
           "  frame N resize W H        resize the window\n"
           "  frame N move-object I DX DY DZ\n"
           "                            move object I (the file's I-th node with a mesh, as render's\n"
           "                            --move-object counts) by DX,DY,DZ in world space. It costs a\n"
           "                            top-level rebuild with --trees object (no line space), a tree\n"
           "                            rebuild on a worker thread with the scene-wide tree; stdout\n"
           "                            says what it cost\n"
           "  frame N screenshot FILE   save frame N (without the text) as PNG, once the tree builds\n"
           "                            running or due (N, D, a light or an object moved) are done\n"
           "The frame counter counts presented frames. PN_VALIDATION=1 makes any validation message\n"
           "an exit code of 3, as for render.\n");
}

int pn_demo_parse(int argc, char **argv, pn_demo_opts *o)
{
    *o = (pn_demo_opts){.r = pn_render_opts_default(), .accumulate = true, .accumulate_max = 256, .hud = true,
                     .vsync = true, .save_prefix = "penumbra-demo", .stats_every = 100};
    // Render's defaults but a smaller window and fewer rays per frame: accumulation adds samples.
    // 4 a frame (issue 63, measured in engine/apps/demo/README.md): orbiting builtin:default at
    // 1280x720 a frame takes 283 ms against 372 at 9, and from frame 8 its V is within 0.0010 of
    // the converged reference, half of 16 samples unfiltered's error (9: 0.0007).
    o->r.width = 800, o->r.height = 450, o->r.spp = 4;
    pn_args a = {argc, argv, 0};
    while (a.i < argc) {
        const char *v = NULL, *arg = argv[a.i];
        bool err = false, ok = true;
        if (pn_args_flag(&a, "--help") || pn_args_flag(&a, "-h")) {
            pn_print_demo_help();
            return -1;
        } else if (pn_args_value(&a, "--frames", &v, &err)) {
            ok = v && pn_parse_int_range("--frames", v, 1, 1ll << 40, &o->frames);
        } else if (pn_args_value(&a, "--screenshot", &v, &err)) {
            o->screenshot = v;
        } else if (pn_args_value(&a, "--script", &v, &err)) {
            o->script = v;
        } else if (pn_args_value(&a, "--save-prefix", &v, &err)) {
            o->save_prefix = v;
        } else if (pn_args_value(&a, "--stats", &v, &err)) {
            o->stats = v;
        } else if (pn_args_value(&a, "--stats-every", &v, &err)) {
            ok = v && pn_parse_int_range("--stats-every", v, 1, 1 << 30, &o->stats_every);
        } else if (pn_args_value(&a, "--accumulate-max", &v, &err)) {
            ok = v && pn_parse_int_range("--accumulate-max", v, 1, 1 << 20, &o->accumulate_max);
        } else if (pn_args_flag(&a, "--no-accumulate")) {
            o->accumulate = false;
        } else if (pn_args_flag(&a, "--no-hud")) {
            o->hud = false;
        } else if (pn_args_flag(&a, "--no-vsync")) {
            o->vsync = false;
        } else if (pn_render_opts_parse(&a, &o->r, &err)) {
            // a shared option
        } else if (arg[0] == '-' && arg[1] != '\0') {
            pn_error("demo: unknown option '%s' (see penumbra demo --help)", arg);
            return PN_EXIT_USAGE;
        } else if (!o->scene) {
            o->scene = arg;
            a.i++;
        } else {
            pn_error("demo: more than one scene given ('%s' and '%s')", o->scene, arg);
            return PN_EXIT_USAGE;
        }
        if (err || !ok)
            return PN_EXIT_USAGE;
    }
    if (!o->scene)
        o->scene = "builtin:default";
    if (!pn_shadow_mode_get(o->r.mode)->traces) {
        pn_error("demo: --mode %s casts no shadows to look at; pick a mode that traces rays (penumbra render --help)",
                 pn_shadow_mode_get(o->r.mode)->name);
        return PN_EXIT_USAGE;
    }
    if (o->r.per_object && !pn_shadow_mode_get(o->r.mode)->objects) {
        pn_error("demo: per-object trees (--trees object) serve mode linespace only, not %s",
                 pn_shadow_mode_get(o->r.mode)->name);
        return PN_EXIT_USAGE;
    }
    pn_renderer_desc frame = pn_render_opts_setup(&o->r).frame;
    if (pn_renderer_check_split(&frame) != PN_OK || pn_shadow_check_samples(&frame) != PN_OK)
        return PN_EXIT_USAGE;
    return PN_EXIT_OK;
}
