// libFuzzer target: the demo's --script parser (apps/demo/demo_script.c, with the key names of
// demo_controls.c) on arbitrary bytes, without a window: the input is written to input.script in a
// private, otherwise empty folder and loaded with pn_demo_script_load, then checked against a
// scene of two objects with pn_demo_script_check, as cmd_demo does. The camera events are then applied
// to a demo's camera with the functions cmd_demo's apply_script calls (pn_demo_orbit, _pan, _zoom:
// they touch the camera alone).
//
// Beyond "no crash, no leak, no UB", what the parser accepts is what demo.h promises; a violated
// invariant aborts, which libFuzzer reports as a crash:
//   - on failure the script is zeroed (nothing to free);
//   - on success the input holds no NUL byte, there are as many events as non-blank, non-comment lines (each one an event, at
//     most one per line), sorted by frame and then by line, lines from 1 up to the input's last;
//   - every event is of a known kind with its own arguments: a key that pn_demo_key_parse gives
//     (a GLFW key, no modifier but shift); orbit and pan two finite numbers within 1e30; zoom one
//     finite positive factor; resize a whole width and height in 1..16384; move-object three
//     finite numbers; screenshot a non-empty file name, terminated within the event;
//   - pn_demo_script_check accepts exactly when every move-object names one of the scene's objects;
//   - after each orbit, pan and zoom the camera is still one render would take: position and
//     target finite, within PN_MAX_COORD of the origin, and apart.
// PN_FUZZ_VERBOSE=1 keeps the messages (silenced otherwise: millions of them).
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "apps/demo/demo.h"
#include "core/log.h"
#include "scene/scene.h"
#include "fuzz_util.h"

static char g_dir[256], g_path[512];
static pn_scene g_scene; // fuzz_scene's seed_nodes.gltf (two objects to move), loaded once

static void remove_files(void)
{
    remove(g_path);
    rmdir(g_dir);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc, (void)argv;
    const char *verbose = getenv("PN_FUZZ_VERBOSE");
    pn_log_set_level(verbose && *verbose == '1' ? PN_LOG_DEBUG : PN_LOG_QUIET);
    if (pn_scene_load(PN_FUZZ_SCRIPT_SCENE, &g_scene) != PN_OK || g_scene.object_count < 2)
        abort();
    pn_fuzz_make_dir(g_dir, sizeof g_dir, "fuzz_script");
    snprintf(g_path, sizeof g_path, "%s/input.script", g_dir);
    atexit(remove_files);
    return 0;
}


static bool whole(float v, float lo, float hi) { return v >= lo && v <= hi && v == floorf(v); }

static bool camera_ok(const pn_camera *c)
{
    bool apart = false;
    for (int k = 0; k < 3; k++) {
        if (!(fabsf(c->pos[k]) <= PN_MAX_COORD && fabsf(c->target[k]) <= PN_MAX_COORD))
            return false; // NaN included
        apart = apart || c->pos[k] != c->target[k];
    }
    return apart;
}

// Lines of the input as fgets sees them, and those that hold something besides a comment.
static void count_lines(const uint8_t *data, size_t size, uint32_t *lines, uint32_t *busy)
{
    *lines = *busy = 0;
    bool in_comment = false, content = false;
    for (size_t i = 0; i <= size; i++) {
        if (i == size || data[i] == '\n') {
            if (i < size || i == 0 || data[i - 1] != '\n')
                ++*lines; // a last line without '\n' counts; nothing after a final '\n' does not
            *busy += content;
            in_comment = content = false;
            continue;
        }
        if (data[i] == '#')
            in_comment = true;
        if (!in_comment && data[i] != ' ' && data[i] != '\t' && data[i] != '\r')
            content = true;
    }
    if (size == 0)
        *lines = 0;
}

static void check_event(const pn_demo_event *e)
{
    switch (e->kind) {
    case PN_DEMO_EVENT_KEY: {
        REQUIRE(e->mods == 0 || e->mods == GLFW_MOD_SHIFT);
        REQUIRE(e->key >= GLFW_KEY_SPACE && e->key <= GLFW_KEY_LAST);
        break;
    }
    case PN_DEMO_EVENT_ORBIT:
    case PN_DEMO_EVENT_PAN:
        REQUIRE(isfinite(e->a) && isfinite(e->b) && fabsf(e->a) <= 1e30f && fabsf(e->b) <= 1e30f);
        break;
    case PN_DEMO_EVENT_ZOOM: REQUIRE(isfinite(e->a) && e->a > 0 && e->a <= 1e30f); break;
    case PN_DEMO_EVENT_RESIZE: REQUIRE(whole(e->a, 1, 16384) && whole(e->b, 1, 16384)); break;
    case PN_DEMO_EVENT_MOVE_OBJECT:
        for (int k = 0; k < 3; k++)
            REQUIRE(isfinite(e->move[k]) && fabsf(e->move[k]) <= 1e30f);
        break;
    case PN_DEMO_EVENT_SCREENSHOT:
        REQUIRE(e->path[0] && memchr(e->path, '\0', sizeof e->path));
        break;
    default: REQUIRE(!"an event of unknown kind");
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    FILE *f = fopen(g_path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f) != 0) {
        perror("fuzz_script: cannot write the input file");
        exit(1);
    }
    pn_demo_script s;
    memset(&s, 0xA5, sizeof s); // the loader must zero it whatever it held
    if (pn_demo_script_load(g_path, &s) != PN_OK) {
        static const pn_demo_script zero;
        REQUIRE(memcmp(&s, &zero, sizeof s) == 0);
        return 0;
    }
    REQUIRE(!memchr(data, '\0', size)); // refused: it would cut a line short unseen
    uint32_t lines, busy;
    count_lines(data, size, &lines, &busy);
    REQUIRE(s.count == busy && s.next == 0 && (s.count == 0 || s.events));
    bool all_exist = true;
    for (uint32_t i = 0; i < s.count; i++) {
        const pn_demo_event *e = &s.events[i];
        REQUIRE(e->line >= 1 && e->line <= lines);
        if (i > 0) {
            const pn_demo_event *p = &s.events[i - 1];
            REQUIRE(p->frame < e->frame || (p->frame == e->frame && p->line < e->line));
        }
        check_event(e);
        if (e->kind == PN_DEMO_EVENT_MOVE_OBJECT && e->object >= g_scene.object_count)
            all_exist = false;
    }
    REQUIRE((pn_demo_script_check(&s, g_path, &g_scene) == PN_OK) == all_exist);

    // The camera moves, applied in order from the demo's start.
    pn_demo *d = calloc(1, sizeof *d);
    REQUIRE(d);
    d->camera = (pn_camera){.pos = {0, 1, 3}, .target = {0, 0, 0}, .up = {0, 1, 0}, .yfov_deg = 45};
    d->radius = 1;
    for (uint32_t i = 0; i < s.count; i++) {
        const pn_demo_event *e = &s.events[i];
        if (e->kind == PN_DEMO_EVENT_ORBIT)
            pn_demo_orbit(d, e->a, e->b);
        else if (e->kind == PN_DEMO_EVENT_PAN)
            pn_demo_pan(d, e->a, e->b);
        else if (e->kind == PN_DEMO_EVENT_ZOOM)
            pn_demo_zoom(d, e->a);
        else
            continue;
        REQUIRE(camera_ok(&d->camera));
    }
    free(d);
    pn_demo_script_destroy(&s);
    return 0;
}
