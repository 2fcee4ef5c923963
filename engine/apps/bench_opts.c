// penumbra bench's command line: the option parser, --scenes folders, and the G-buffer of
// --shader shadow --gbuffer.
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "apps/args.h"
#include "apps/bench.h"
#include "apps/commands.h"
#include "core/log.h"
#include "io/exr.h"

static bool parse_list_u32(const char *opt, const char *s, uint32_t *out, int *count, uint32_t lo, uint32_t hi)
{
    char buf[1024];
    snprintf(buf, sizeof buf, "%s", s);
    *count = 0;
    for (char *tok = strtok(buf, ","); tok && *count < MAX_LIST; tok = strtok(NULL, ",")) {
        long long v;
        if (!pn_parse_int_range(opt, tok, lo, hi, &v))
            return false;
        out[(*count)++] = (uint32_t)v;
    }
    return *count > 0;
}

static bool add_scene_arg(bench_opts *o, const char *s)
{
    struct stat st;
    if (strncmp(s, "builtin:", 8) != 0 && stat(s, &st) == 0 && S_ISDIR(st.st_mode)) {
        DIR *dir = opendir(s);
        if (!dir) {
            pn_error("%s: cannot read the folder: %s", s, strerror(errno));
            return false;
        }
        // Sorted for a reproducible order.
        char *found[256];
        int n = 0;
        for (struct dirent *e; (e = readdir(dir)) && n < 256;) {
            size_t len = strlen(e->d_name);
            if (len > 4 && strcmp(e->d_name + len - 4, ".glb") == 0) {
                size_t sz = strlen(s) + len + 2;
                found[n] = malloc(sz);
                if (found[n])
                    snprintf(found[n++], sz, "%s/%s", s, e->d_name);
            }
        }
        closedir(dir);
        for (int i = 0; i < n; i++)
            for (int j = i + 1; j < n; j++)
                if (strcmp(found[j], found[i]) < 0) {
                    char *t = found[i];
                    found[i] = found[j];
                    found[j] = t;
                }
        // Kept in `owned` (freed at exit) while it has room; scenes beyond MAX_LIST are not used.
        int owned_cap = (int)(sizeof o->owned / sizeof o->owned[0]);
        for (int i = 0; i < n; i++) {
            if (o->scene_count < MAX_LIST && o->owned_count < owned_cap) {
                o->owned[o->owned_count++] = found[i];
                o->scenes[o->scene_count++] = found[i];
            } else {
                free(found[i]);
            }
        }
        if (n == 0)
            pn_warn("%s: no .glb files", s);
        return true;
    }
    if (o->scene_count < MAX_LIST)
        o->scenes[o->scene_count++] = s;
    return true;
}

int pn_bench_parse(int argc, char **argv, bench_opts *o)
{
    *o = (bench_opts){.repeat = 5, .warmup = 1, .traversal = PN_TRAVERSAL_RAY, .sampler = PN_SAMPLER_STRATIFIED,
                      .out_dir = "bench-out", .embree = true};
    bool quick = false;
    char scenes_buf[4096] = "";
    pn_args a = {argc, argv, 0};
    while (a.i < argc) {
        const char *v = NULL, *arg = argv[a.i];
        bool err = false, ok = true;
        if (pn_args_flag(&a, "--help") || pn_args_flag(&a, "-h")) {
            pn_print_bench_help();
            return -1;
        } else if (pn_args_flag(&a, "--quick")) {
            quick = true;
        } else if (pn_args_flag(&a, "--work")) {
            o->work = true;
        } else if (pn_args_flag(&a, "--no-embree")) {
            o->embree = false;
        } else if (pn_args_value(&a, "--scenes", &v, &err)) {
            snprintf(scenes_buf, sizeof scenes_buf, "%s", v ? v : "");
        } else if (pn_args_value(&a, "--modes", &v, &err)) {
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            o->mode_count = 0;
            for (char *tok = strtok(buf, ","); tok && ok && o->mode_count < PN_SHADOW_MODE_COUNT; tok = strtok(NULL, ",")) {
                int m = pn_shadow_mode_parse("--modes", tok);
                ok = m >= 0 && pn_shadow_mode_get((pn_shadow_mode)m)->traces;
                if (m >= 0 && !ok)
                    pn_error("--modes: %s has no shadows to measure", tok);
                if (ok)
                    o->modes[o->mode_count++] = (pn_shadow_mode)m;
            }
        } else if (pn_args_value(&a, "--trees", &v, &err)) {
            char buf[512];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            o->tree_count = 0;
            for (char *tok = strtok(buf, ":"); tok && ok && o->tree_count < MAX_LIST; tok = strtok(NULL, ":")) {
                ok = pn_parse_tree("--trees", tok, &o->trees[o->tree_count][0], &o->trees[o->tree_count][1]);
                o->tree_count += ok;
            }
        } else if (pn_args_value(&a, "--spp", &v, &err)) {
            ok = v && parse_list_u32("--spp", v, o->spps, &o->spp_count, 1, 4096);
        } else if (pn_args_value(&a, "--size", &v, &err)) {
            char buf[512];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            o->size_count = 0;
            for (char *tok = strtok(buf, ","); tok && ok && o->size_count < MAX_LIST; tok = strtok(NULL, ",")) {
                ok = pn_parse_size("--size", tok, 16384, &o->sizes[o->size_count][0], &o->sizes[o->size_count][1]);
                o->size_count += ok;
            }
        } else if (pn_args_value(&a, "--repeat", &v, &err)) {
            long long x = 0;
            ok = v && pn_parse_int_range("--repeat", v, 1, 1000, &x);
            o->repeat = (int)x;
        } else if (pn_args_value(&a, "--warmup", &v, &err)) {
            long long x = 0;
            ok = v && pn_parse_int_range("--warmup", v, 0, 100, &x);
            o->warmup = (int)x;
        } else if (pn_args_value(&a, "--traversal", &v, &err)) {
            int t = v ? pn_parse_choice("--traversal", v, pn_traversal_names) : -1;
            ok = t >= 0;
            o->traversal = ok ? (pn_traversal)t : o->traversal;
        } else if (pn_args_value(&a, "--sampler", &v, &err)) {
            int m = v ? pn_parse_choice("--sampler", v, pn_sampler_names) : -1;
            ok = m >= 0;
            o->sampler = ok ? (pn_sampler)m : o->sampler;
        } else if (pn_args_value(&a, "--max-error", &v, &err)) {
            float e = 0;
            ok = v && pn_parse_float_range("--max-error", v, 0.0f, 1.0f, &e);
            o->max_error = e;
        } else if (pn_args_value(&a, "--shader", &v, &err)) {
            ok = v && pn_parse_choice("--shader", v, (const char *const[]){"shadow", NULL}) == 0;
        } else if (pn_args_value(&a, "--gbuffer", &v, &err)) {
            o->gbuffer = v;
        } else if (pn_args_value(&a, "--out", &v, &err)) {
            o->out_dir = v;
        } else {
            pn_error("bench: unknown option '%s' (see penumbra bench --help)", arg);
            return PN_EXIT_USAGE;
        }
        if (err || !ok)
            return PN_EXIT_USAGE;
    }
    if (quick) {
        static const char *bunny = "../shared/assets/stanford-bunny-69k.glb";
        struct stat st;
        if (!scenes_buf[0])
            snprintf(scenes_buf, sizeof scenes_buf, "%s", stat(bunny, &st) == 0 ? bunny : "builtin:default");
        if (!o->size_count)
            o->sizes[0][0] = o->sizes[0][1] = 256, o->size_count = 1;
        if (!o->spp_count)
            o->spps[0] = 16, o->spp_count = 1;
        if (!o->tree_count)
            o->trees[0][0] = 6, o->trees[0][1] = 3, o->trees[1][0] = 7, o->trees[1][1] = 3, o->tree_count = 2;
        if (o->repeat == 5)
            o->repeat = 3;
    }
    if (!scenes_buf[0])
        snprintf(scenes_buf, sizeof scenes_buf, "builtin:default");
    // Scenes are comma-separated; the strings must outlive parsing, so they are kept in `owned`.
    char *copy = strdup(scenes_buf);
    if (!copy)
        return PN_EXIT_FAILURE;
    o->owned[o->owned_count++] = copy;
    for (char *tok = strtok(copy, ","); tok; tok = strtok(NULL, ","))
        if (!add_scene_arg(o, tok))
            return PN_EXIT_USAGE;
    if (!o->mode_count) {
        // Every mode that traces, the most expensive first (the table lists the cheapest first).
        for (int m = PN_SHADOW_MODE_COUNT - 1; m >= 0; m--)
            if (pn_shadow_mode_get((pn_shadow_mode)m)->traces)
                o->modes[o->mode_count++] = (pn_shadow_mode)m;
    }
    if (!o->tree_count)
        o->trees[0][0] = 6, o->trees[0][1] = 3, o->trees[1][0] = 7, o->trees[1][1] = 3, o->trees[2][0] = 8,
        o->trees[2][1] = 3, o->tree_count = 3;
    if (!o->spp_count)
        o->spps[0] = 25, o->spp_count = 1;
    if (!o->size_count)
        o->sizes[0][0] = o->sizes[0][1] = 512, o->size_count = 1;
    return PN_EXIT_OK;
}

// The G-buffer of --gbuffer: P.X/Y/Z with A as P.w, N.X/Y/Z, as the renderer's images hold them.
pn_result pn_bench_load_gbuffer(bench_opts *o)
{
    pn_exr_image img;
    if (pn_exr_read(o->gbuffer, &img) != PN_OK)
        return PN_ERR_IO;
    const char *names[7] = {"P.X", "P.Y", "P.Z", "A", "N.X", "N.Y", "N.Z"};
    const float *ch[7];
    for (int c = 0; c < 7; c++)
        if (!(ch[c] = pn_exr_image_channel(&img, names[c]))) {
            pn_error("%s: no %s channel (write it with render --aovs)", o->gbuffer, names[c]);
            pn_exr_image_free(&img);
            return PN_ERR_FORMAT;
        }
    size_t px = (size_t)img.width * img.height;
    o->gb_p = calloc(px * 4, sizeof(float));
    o->gb_n = calloc(px * 4, sizeof(float));
    if (!o->gb_p || !o->gb_n) {
        pn_exr_image_free(&img);
        return PN_ERR_MEMORY;
    }
    for (size_t i = 0; i < px; i++)
        for (int k = 0; k < 4; k++) {
            o->gb_p[4 * i + k] = ch[k][i];
            o->gb_n[4 * i + k] = k < 3 ? ch[4 + k][i] : 0.0f;
        }
    o->gb_width = (uint32_t)img.width;
    o->gb_height = (uint32_t)img.height;
    o->sizes[0][0] = o->gb_width, o->sizes[0][1] = o->gb_height, o->size_count = 1;
    pn_exr_image_free(&img);
    return PN_OK;
}
