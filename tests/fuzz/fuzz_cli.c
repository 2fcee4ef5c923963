// libFuzzer target: the command-line parsers of render, build and diff (apps/options.h), without
// a GPU or any file. The input is a command line, one argument per line; the first selects the
// parser (render, build or diff; anything else is parsed as render's arguments too).
//
// Beyond "no crash, no leak, no UB": a parser either accepts (PN_EXIT_OK), prints its help (-1)
// or refuses (PN_EXIT_USAGE); what it accepts is within the documented ranges; and for render,
// the camera and light that pn_render_setup_view builds from accepted options over a built-in
// scene are finite, or it refuses them. A violation aborts, which libFuzzer reports as a crash.
// PN_FUZZ_VERBOSE=1 keeps the parsers' messages (silenced otherwise).
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/options.h"
#include "core/log.h"
#include "gpu/renderer.h"
#include "scene/scene.h"
#include "scene/view.h"
#include "fuzz_util.h"

enum { MAX_ARGS = 64 };

static pn_scene g_scene; // builtin:default, loaded once

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    const char *verbose = getenv("PN_FUZZ_VERBOSE");
    pn_log_set_level(verbose && *verbose == '1' ? PN_LOG_DEBUG : PN_LOG_QUIET);
    if (pn_scene_load("builtin:default", &g_scene) != PN_OK)
        abort();
    // --help prints to stdout: keep the fuzzer's output readable.
    if (!(verbose && *verbose == '1') && !freopen("/dev/null", "w", stdout))
        abort();
    return 0;
}


static bool finite3(const float v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

static void check_render(const pn_render_cmd_opts *o)
{
    const pn_render_opts *r = &o->r;
    REQUIRE(o->scene && pn_shadow_mode_get(r->mode) && (!o->ray_dump || pn_shadow_mode_get(r->mode)->traces));
    REQUIRE(r->width >= 1 && r->width <= 16384 && r->height >= 1 && r->height <= 16384);
    REQUIRE(r->spp >= 1 && r->spp <= 4096 && r->tree_n >= 2 && r->tree_n <= 16 && r->tree_d >= 1 && r->tree_d <= 6);
    REQUIRE(r->traversal >= 0 && pn_traversal_names[r->traversal]);
    REQUIRE(r->sampler >= 0 && pn_sampler_names[r->sampler]);
    REQUIRE(isfinite(r->fov) && r->fov > 0 && r->fov < 180 && isfinite(r->exposure) && r->exposure >= 0);
    REQUIRE(o->max_error >= 0 && o->max_error <= 1);

    pn_camera cam;
    pn_light lights[PN_MAX_LIGHTS];
    uint32_t count = 0;
    if (!pn_render_setup_view(r, &g_scene, &cam, lights, &count))
        return; // refused, with a message
    REQUIRE(count >= 1 && count <= PN_MAX_LIGHTS && (r->light_count == 0 || count == r->light_count));
    REQUIRE(finite3(cam.pos) && finite3(cam.target) && finite3(cam.up));
    REQUIRE(cam.yfov_deg > 0 && cam.yfov_deg < 180);
    float view[3] = {cam.target[0] - cam.pos[0], cam.target[1] - cam.pos[1], cam.target[2] - cam.pos[2]};
    REQUIRE(finite3(view) && (view[0] != 0 || view[1] != 0 || view[2] != 0));
    // Every light, whether from --light groups or the default light changed by --light-*.
    for (uint32_t k = 0; k < count; k++) {
        const pn_light light = lights[k];
        REQUIRE(finite3(light.pos) && finite3(light.normal) && finite3(light.up) && finite3(light.radiance));
        // Both sides positive, or both 0 (a point light).
        REQUIRE(isfinite(light.size[0]) && isfinite(light.size[1]) &&
                ((light.size[0] > 0 && light.size[1] > 0) || pn_light_is_point(&light)));
        REQUIRE(light.radiance[0] >= 0 && light.radiance[1] >= 0 && light.radiance[2] >= 0);
        float len = sqrtf(light.normal[0] * light.normal[0] + light.normal[1] * light.normal[1] +
                          light.normal[2] * light.normal[2]);
        REQUIRE(fabsf(len - 1.0f) < 1e-3f);
        float t[3], b[3], corners[4][3];
        REQUIRE(pn_light_frame(&light, t, b));
        pn_light_corners(&light, corners);
        for (int i = 0; i < 4; i++)
            REQUIRE(finite3(corners[i]));
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    // One argument per line (a NUL ends an argument early, as it would in argv).
    char *buf = malloc(size + 1);
    if (!buf)
        return 0;
    memcpy(buf, data, size);
    buf[size] = '\0';
    char *argv[MAX_ARGS + 1];
    int argc = 0;
    for (char *p = buf; argc < MAX_ARGS;) {
        argv[argc++] = p;
        char *nl = memchr(p, '\n', (size_t)(buf + size - p));
        if (!nl)
            break;
        *nl = '\0';
        p = nl + 1;
    }
    argv[argc] = NULL;

    // argv[0] picks the parser; render also takes it as an argument when it names none.
    int rc;
    if (!strcmp(argv[0], "build")) {
        pn_build_opts o;
        rc = pn_build_parse(argc - 1, argv + 1, &o);
        if (rc == PN_EXIT_OK)
            REQUIRE(o.scene && o.tree_n >= 2 && o.tree_n <= 16 && o.tree_d >= 1 && o.tree_d <= 6);
    } else if (!strcmp(argv[0], "diff")) {
        pn_diff_opts o;
        rc = pn_diff_parse(argc - 1, argv + 1, &o);
        if (rc == PN_EXIT_OK) {
            REQUIRE(o.files[0] && o.files[1] && o.channel && o.channel[0]);
            for (int k = 0; k < 6; k++)
                REQUIRE(!o.fail_set[k] || (isfinite(o.fail_threshold[k]) && o.fail_threshold[k] >= 0));
        }
    } else {
        bool named = !strcmp(argv[0], "render");
        pn_render_cmd_opts o;
        rc = pn_render_parse(argc - named, argv + named, &o);
        if (rc == PN_EXIT_OK)
            check_render(&o);
    }
    REQUIRE(rc == PN_EXIT_OK || rc == PN_EXIT_USAGE || rc == -1);
    free(buf);
    return 0;
}
