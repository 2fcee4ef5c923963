// penumbra bench's command line: the help text, the option parser, --scenes folders, and the
// G-buffer of --shader shadow --gbuffer.
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "apps/args.h"
#include "apps/bench/bench.h"
#include "apps/gbuffer_file.h"
#include "apps/commands.h"
#include "apps/render_opts.h"
#include "core/log.h"
#include "io/exr.h"

// --spp S,...: uniform counts S, or adaptive MIN:MAX (MAX = MIN x 2^k, render_opts.c), sorted by
// the most rays, a uniform count before the adaptive entries that reach it.
static bool parse_spp_list(const char *s, bench_opts *o)
{
    char buf[1024];
    snprintf(buf, sizeof buf, "%s", s);
    o->spp_count = 0;
    for (char *tok = strtok(buf, ","); tok; tok = strtok(NULL, ",")) {
        if (o->spp_count == MAX_LIST) {
            pn_error("--spp: more than %d values", MAX_LIST);
            return false;
        }
        long long lo = 0, hi;
        char *colon = strchr(tok, ':');
        if (colon) {
            *colon = 0;
            if (!pn_parse_int_range("--spp", tok, 1, 4096, &lo) || !pn_parse_int_range("--spp", colon + 1, 1, 4096, &hi))
                return false;
            long long ratio = hi % lo == 0 ? hi / lo : 0;
            if (ratio < 2 || (ratio & (ratio - 1)) != 0) {
                pn_error("--spp %lld:%lld: adaptive samples need MAX = MIN x 2, 4, 8, ... (e.g. 4:64)", lo, hi);
                return false;
            }
        } else if (!pn_parse_int_range("--spp", tok, 1, 4096, &hi)) {
            return false;
        }
        int at = o->spp_count;
        for (int i = 0; i < o->spp_count; i++) {
            if (o->spps[i] == (uint32_t)hi && o->spp_mins[i] == (uint32_t)lo) {
                pn_error("--spp: %s is listed twice", colon ? "an adaptive entry" : "a count");
                return false;
            }
            if (at == o->spp_count && (o->spps[i] > hi || (o->spps[i] == hi && o->spp_mins[i] > lo)))
                at = i;
        }
        memmove(&o->spps[at + 1], &o->spps[at], (size_t)(o->spp_count - at) * sizeof o->spps[0]);
        memmove(&o->spp_mins[at + 1], &o->spp_mins[at], (size_t)(o->spp_count - at) * sizeof o->spp_mins[0]);
        o->spps[at] = (uint32_t)hi, o->spp_mins[at] = (uint32_t)lo;
        o->spp_count++;
    }
    return o->spp_count > 0;
}

static bool add_view(bench_opts *o, const bench_view *v)
{
    if (o->view_count == MAX_LIST) {
        pn_error("bench: more than %d views and scenes", MAX_LIST);
        return false;
    }
    o->views[o->view_count++] = *v;
    return true;
}

// A scene file, builtin:NAME, or a folder of .glb files (sorted, for a reproducible order).
static bool add_scene_arg(bench_opts *o, const char *s)
{
    bench_view v;
    struct stat st;
    if (strncmp(s, "builtin:", 8) != 0 && stat(s, &st) == 0 && S_ISDIR(st.st_mode)) {
        DIR *dir = opendir(s);
        if (!dir) {
            pn_error("%s: cannot read the folder: %s", s, strerror(errno));
            return false;
        }
        int first = o->view_count, n = 0;
        bool ok = true;
        for (struct dirent *e; ok && (e = readdir(dir));) {
            size_t len = strlen(e->d_name);
            if (len > 4 && strcmp(e->d_name + len - 4, ".glb") == 0) {
                char path[1024];
                snprintf(path, sizeof path, "%s/%s", s, e->d_name);
                pn_bench_view_scene(&v, path);
                ok = add_view(o, &v);
                n++;
            }
        }
        closedir(dir);
        for (int i = first; i < o->view_count; i++)
            for (int j = i + 1; j < o->view_count; j++)
                if (strcmp(o->views[j].source, o->views[i].source) < 0) {
                    bench_view t = o->views[i];
                    o->views[i] = o->views[j];
                    o->views[j] = t;
                }
        if (n == 0)
            pn_warn("%s: no .glb files", s);
        return ok;
    }
    pn_bench_view_scene(&v, s);
    return add_view(o, &v);
}

// A standard view by name, or `all` of them; a view whose mesh is missing is an error when named.
static bool add_view_arg(bench_opts *o, const char *name)
{
    bench_view v;
    if (strcmp(name, "all") == 0) {
        for (int i = 0; pn_bench_view_spec_at(i); i++)
            if (!pn_bench_view_standard(&v, pn_bench_view_spec_at(i)))
                pn_warn("bench: view %s skipped: %s is missing", v.name, v.source);
            else if (!add_view(o, &v))
                return false;
        return true;
    }
    const pn_bench_view_spec *spec = pn_bench_view_spec_find(name);
    if (!spec) {
        pn_error("--views: no standard view '%s' (have: bunny, dragon, buddha, sponza, bunny-sun, bunny-sphere, "
                 "canopy, all)",
                 name);
        return false;
    }
    if (!pn_bench_view_standard(&v, spec)) {
        pn_error("--views: %s: its mesh %s is missing (set PN_ASSETS to the folder of ../shared/assets)", name,
                 v.source);
        return false;
    }
    return add_view(o, &v);
}

const char *const pn_bench_tree_kind_names[] = {"scene", "object", NULL};

void pn_print_bench_help(void)
{
    printf("usage: penumbra bench [options]\n"
           "  Renders a matrix of views x sizes x modes x trees x filters x samples per pixel, each cell\n"
           "  with warm-up and repeated frames timed by GPU timestamps (median and spread), and measures\n"
           "  two errors of its V over the pixels with geometry (MAE, RMSE, p99, max):\n"
           "    reference: against the converged reference, exact at --reference-spp samples with a seed\n"
           "               of its own (cached in OUT/reference): what the user sees, bias and noise;\n"
           "    bias:      against exact with the same pixels and light samples: the mode's bias alone.\n"
           "  Embree 3 traces exact's rays on all cores as the CPU peer. Writes a console table, bench.csv,\n"
           "  bench.json, time_to_error.md (per mode the fastest cell reaching each error level) and a\n"
           "  log-log plot of reference error vs shadow time per view and size with the Pareto front.\n"
           "  --views V,...        standard views: bunny, dragon, buddha, sponza, bunny-sun, bunny-sphere (the\n"
           "                       bunny's under a sun and a sphere light), canopy (builtin:canopy, alpha-\n"
           "                       masked leaves) or all (default: all whose mesh is in $PN_ASSETS, else\n"
           "                       ../shared/assets, and canopy)\n"
           "  --scenes A,B,...     other scenes (files, builtin:NAME, folders of .glb), framed as render does\n"
           "  --modes M,...        of the modes that trace (default: all the device can run)\n"
           "  --trees N,d:N,d:...  trees for the line-space modes (default 6,3:7,3:8,3)\n"
           "  --tree-kinds K,...   scene, object: an axis of the matrix (default scene). scene: one tree\n"
           "                       over the scene, culled by the view and light; object: a tree per mesh\n"
           "                       in its own frame, shared by its instances, and a top level (mode\n"
           "                       linespace only; see render --trees). Rows report what moving one\n"
           "                       object costs each: a rebuild, or with per-object trees the top level's\n"
           "                       rebuild and upload, timed\n"
           "  --spp S,...          samples per pixel, an axis of the matrix (default 1,4,16,64,4:64);\n"
           "                       MIN:MAX is an adaptive cell (render --spp MIN:MAX; no Embree peer)\n"
           "  --pixel-error E      the adaptive cells' target standard error per pixel (default %.3g)\n"
           "  --filter F,...       none, interleaved, penumbra: an axis of the matrix (default none and\n"
           "                       interleaved); a filtered cell's\n"
           "                       time is its shadow pass plus its filter pass, and it reports the share of\n"
           "                       pixels near edges of geometry whose error the filter grows by > 0.05\n"
           "  --tile WxH           the filtered cells' interleaving tile and window, 1..8 each (default 3x3)\n"
           "  --lights K,...       also time every configuration (first --spp and --filter) with K lights:\n"
           "                       the view's light turned about the vertical through the scene's centre in\n"
           "                       K even steps, light i with 2^-i of the first's radiance (together the\n"
           "                       view's light's), over one scene-wide tree (the first of --trees)\n"
           "                       built for the set, both --split even and budget with the set's radiance error against its converged reference;\n"
           "                       frame time, its ratios to the view's light alone and to the set's lights\n"
           "                       each alone, pools and build time (console and bench.json's \"lights\")\n"
           "  --edge-images        per filtered cell, OUT/edge_<cell>.exr: shadow.V, shadow.V_raw, reference.V,\n"
           "                       edge (0 away from edges, 1 edge, 2 within 2 px, 3 there with the error grown)\n"
           "                       and the filter's inputs: P, N, Z, shadow.valid and shadow.penumbra\n"
           "  --reference-spp S    samples of the converged reference (default %d)\n"
           "  --seed S             the measured frames' random choices (default 1): another seed, another\n"
           "                       draw of the samples, e.g. to see the errors' spread\n"
           "  --size WxH,...       image sizes (default 512x512)\n"
           "  --repeat R --warmup W   timed and untimed frames per cell (default 3 and 1)\n"
           "  --traversal auto|ray|packet[,project]  --sampler grid|stratified   (default auto,\n"
           "                       stratified); project: exact also by projection, a configuration\n"
           "                       of its own (exact/project: its triangles per pixel and fallback\n"
           "                       share in bench.json), uniform cells only\n"
           "  --out DIR            where the CSV, JSON, tables, plots and reference cache go (default bench-out)\n"
           "  --reference-cache DIR   cache the converged references here instead of OUT/reference (runs\n"
           "                       with other outputs share them; a file's name holds a hash of what it depends on)\n"
           "  --no-embree          skip the CPU peer\n"
           "  --shard K/N          measure the cells whose number in one run's order is K-1 modulo N\n"
           "                       (1 <= K <= N; exact's cells are rendered in every shard, the others'\n"
           "                       bias reference) and write OUT/" PN_BENCH_PARTIAL " beside the usual\n"
           "                       outputs; share the references with --reference-cache. Not with\n"
           "                       --lights or --max-error\n"
           "  --merge DIR... [--out DIR]\n"
           "                       the partial files of the N shards' --out folders into the CSV, JSON,\n"
           "                       time-to-error table, plots and console table one run would write\n"
           "  --shader shadow --gbuffer FILE.exr\n"
           "                       shader level: the shadow pass alone over the P and N layers of an EXR\n"
           "                       (render --aovs of the same scene); the size is the EXR's\n"
           "  --points             instead of the matrix: per view, size, spp and mode, the library's\n"
           "                       penumbra_visibility over the view's covered pixels as points beside\n"
           "                       the renderer's shadow pass (time per point and per pixel; points.csv)\n"
           "  --sequence K,...     instead of the matrix: sequences of frames in motion, K orbit (the\n"
           "                       camera turns about the vertical through its target; one inside the\n"
           "                       scene's bounds, as Sponza's, looks round where it stands) or light (the\n"
           "                       light turns about the view's centre; modes without a tree, which is\n"
           "                       culled by the light) or object (the scene's first object crosses the\n"
           "                       light, --sequence-step percent of its radius a frame) or walk (the\n"
           "                       camera walks towards its target, that percent of the view's radius\n"
           "                       a frame): per view, size, mode, filter and spp, every frame with the\n"
           "                       temporal history (render --temporal), alone, and at once with\n"
           "                       min(k+1, history) x spp, each against its own converged reference\n"
           "                       (cached); sequence.csv, seq_*.png. Defaults under it:\n"
           "                       --modes exact --filter penumbra --spp 1\n"
           "  --sequence-frames F  frames of a sequence (default 64)\n"
           "  --sequence-step DEG  degrees a frame turns (default 2; object, walk: percent of a radius)\n"
           "  --history N          the history's length in frames (default 32, as render's)\n"
           "  --work               per cell, one more frame with the shadow shader's counting build: per\n"
           "                       pixel nodes visited, line-space lookups, triangle tests and deepest\n"
           "                       stack; their distribution is printed and written as EXR layers work.*\n"
           "                       (exact's packet walk at 1-16 rays a pixel walks a block of pixels\n"
           "                       together: a block's work is counted at its first covered pixel)\n"
           "  --max-error E,...    also run --quality auto at each budget (reference MAE), render its pick at\n"
           "                       full size and compare it with the matrix's fastest cell within the budget\n"
           "  --quick              a small matrix (the bunny view or builtin:default, 256x256, 4 and 16 spp,\n"
           "                       LS(6,3) and LS(7,3), 3 repeats)\n",
           (double)PN_DEFAULT_PIXEL_ERROR, PN_REFERENCE_SPP);
}

int pn_bench_parse(int argc, char **argv, bench_opts *o)
{
    *o = (bench_opts){.repeat = 3, .warmup = 1, .traversal = PN_TRAVERSAL_AUTO, .sampler = PN_SAMPLER_STRATIFIED,
                      .reference_spp = PN_REFERENCE_SPP, .pixel_error = PN_DEFAULT_PIXEL_ERROR, .seed = 1, .out_dir = "bench-out", .embree = true,
                      .tile_w = 3, .tile_h = 3, .kinds = {[PN_TREE_KIND_SCENE] = true}};
    bool quick = false;
    char scenes_buf[4096] = "", views_buf[512] = "";
    pn_args a = {argc, argv, 0};
    while (a.i < argc) {
        const char *v = NULL, *arg = argv[a.i];
        bool err = false, ok = true;
        if (pn_args_flag(&a, "--help") || pn_args_flag(&a, "-h")) {
            pn_print_bench_help();
            return -1;
        } else if (pn_args_flag(&a, "--quick")) {
            quick = true;
        } else if (pn_args_flag(&a, "--edge-images")) {
            o->edge_images = true;
        } else if (pn_args_flag(&a, "--work")) {
            o->work = true;
        } else if (pn_args_flag(&a, "--points")) {
            o->points = true;
        } else if (pn_args_value(&a, "--sequence", &v, &err)) {
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            int count = 0;
            for (char *tok = strtok(buf, ","); tok && ok; tok = strtok(NULL, ","), count++) {
                bool orbit = strcmp(tok, "orbit") == 0, light = strcmp(tok, "light") == 0,
                     object = strcmp(tok, "object") == 0, walk = strcmp(tok, "walk") == 0;
                if (!orbit && !light && !object && !walk)
                    pn_error("--sequence: expected orbit, light, object or walk, got '%s'", tok);
                ok = orbit || light || object || walk;
                o->sequences[0] |= orbit, o->sequences[1] |= light, o->sequences[2] |= object;
                o->sequences[3] |= walk;
            }
            ok = ok && count > 0;
        } else if (pn_args_value(&a, "--sequence-frames", &v, &err)) {
            long long x = 0;
            ok = v && pn_parse_int_range("--sequence-frames", v, 1, 4096, &x);
            o->seq_frames = (uint32_t)x;
        } else if (pn_args_value(&a, "--sequence-step", &v, &err)) {
            ok = v && pn_parse_float_range("--sequence-step", v, -90.0f, 90.0f, &o->seq_step);
        } else if (pn_args_value(&a, "--history", &v, &err)) {
            long long x = 0;
            ok = v && pn_parse_int_range("--history", v, 1, PN_HISTORY_MAX_FRAMES, &x);
            o->seq_history = (uint32_t)x;
        } else if (pn_args_flag(&a, "--no-embree")) {
            o->embree = false;
        } else if (pn_args_value(&a, "--scenes", &v, &err)) {
            ok = v && strlen(v) < sizeof scenes_buf;
            if (v && !ok)
                pn_error("--scenes: the list is longer than %zu characters", sizeof scenes_buf - 1);
            snprintf(scenes_buf, sizeof scenes_buf, "%s", v ? v : "");
        } else if (pn_args_value(&a, "--views", &v, &err)) {
            ok = v && strlen(v) < sizeof views_buf;
            if (v && !ok)
                pn_error("--views: the list is longer than %zu characters", sizeof views_buf - 1);
            snprintf(views_buf, sizeof views_buf, "%s", v ? v : "");
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
            for (char *tok = strtok(buf, ":"); tok && ok; tok = strtok(NULL, ":")) {
                if (o->tree_count == MAX_LIST) {
                    pn_error("--trees: more than %d trees", MAX_LIST);
                    return PN_EXIT_USAGE;
                }
                ok = pn_parse_tree("--trees", tok, &o->trees[o->tree_count][0], &o->trees[o->tree_count][1]);
                for (int i = 0; ok && i < o->tree_count; i++)
                    if (o->trees[i][0] == o->trees[o->tree_count][0] && o->trees[i][1] == o->trees[o->tree_count][1]) {
                        pn_error("--trees: %s is listed twice", tok);
                        ok = false;
                    }
                o->tree_count += ok;
            }
        } else if (pn_args_value(&a, "--tree-kinds", &v, &err)) {
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            o->kinds[PN_TREE_KIND_SCENE] = o->kinds[PN_TREE_KIND_OBJECT] = false;
            int count = 0;
            for (char *tok = strtok(buf, ","); tok && ok; tok = strtok(NULL, ",")) {
                int k = pn_parse_choice("--tree-kinds", tok, pn_bench_tree_kind_names);
                ok = k >= 0 && !o->kinds[k];
                if (k >= 0 && !ok)
                    pn_error("--tree-kinds: %s is listed twice", tok);
                if (ok)
                    o->kinds[k] = true, count++;
            }
            if (ok && !count)
                pn_error("--tree-kinds: expected scene, object or both, got '%s'", v ? v : "");
            ok = ok && count > 0;
        } else if (pn_args_value(&a, "--spp", &v, &err)) {
            ok = v && parse_spp_list(v, o);
        } else if (pn_args_value(&a, "--pixel-error", &v, &err)) {
            ok = v && pn_parse_float_range("--pixel-error", v, 0.0f, 1.0f, &o->pixel_error);
        } else if (pn_args_value(&a, "--reference-spp", &v, &err)) {
            long long x = 0;
            ok = v && pn_parse_int_range("--reference-spp", v, 16, 4096, &x);
            o->reference_spp = (uint32_t)x;
        } else if (pn_args_value(&a, "--seed", &v, &err)) {
            long long x = 0;
            ok = v && pn_parse_int_range("--seed", v, 0, 0xffffffffll, &x);
            if (ok && x == PN_REFERENCE_SEED)
                pn_error("--seed %lld is the converged reference's: its errors would not be independent", x);
            ok = ok && x != PN_REFERENCE_SEED;
            o->seed = (uint32_t)x;
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
            // A list: its walk for every mode, and project for exact's configuration by projection.
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            ok = v != NULL && *v;
            for (char *tok = strtok(buf, ","); ok && tok; tok = strtok(NULL, ",")) {
                int t = pn_parse_choice("--traversal", tok, pn_traversal_names);
                ok = t >= 0;
                if (t == PN_TRAVERSAL_PROJECT)
                    o->project = true;
                else if (ok)
                    o->traversal = (pn_traversal)t;
            }
        } else if (pn_args_value(&a, "--sampler", &v, &err)) {
            int m = v ? pn_parse_choice("--sampler", v, pn_sampler_names) : -1;
            ok = m >= 0;
            o->sampler = ok ? (pn_sampler)m : o->sampler;
        } else if (pn_args_value(&a, "--filter", &v, &err)) {
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            o->filter_count = 0;
            for (char *tok = strtok(buf, ","); tok && ok; tok = strtok(NULL, ",")) {
                int f = pn_parse_choice("--filter", tok, pn_filter_names);
                ok = f >= 0;
                for (int i = 0; ok && i < o->filter_count; i++)
                    if (o->filters[i] == (pn_filter)f) {
                        pn_error("--filter: %s is listed twice", tok);
                        ok = false;
                    }
                if (ok)
                    o->filters[o->filter_count++] = (pn_filter)f;
            }
            ok = ok && o->filter_count > 0;
        } else if (pn_args_value(&a, "--lights", &v, &err)) {
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            o->light_count_count = 0;
            for (char *tok = strtok(buf, ","); tok && ok; tok = strtok(NULL, ",")) {
                long long x = 0;
                ok = o->light_count_count < MAX_LIST && pn_parse_int_range("--lights", tok, 1, PN_MAX_LIGHTS, &x);
                if (ok)
                    o->light_counts[o->light_count_count++] = (uint32_t)x;
            }
            ok = ok && o->light_count_count > 0;
        } else if (pn_args_value(&a, "--tile", &v, &err)) {
            ok = v && pn_parse_size("--tile", v, PN_FILTER_MAX_TILE, &o->tile_w, &o->tile_h);
        } else if (pn_args_value(&a, "--max-error", &v, &err)) {
            char buf[256];
            snprintf(buf, sizeof buf, "%s", v ? v : "");
            o->max_error_count = 0;
            for (char *tok = strtok(buf, ","); tok && ok && o->max_error_count < MAX_BUDGETS; tok = strtok(NULL, ",")) {
                float e = 0;
                ok = pn_parse_float_range("--max-error", tok, 1e-6f, 1.0f, &e);
                o->max_errors[o->max_error_count++] = e;
            }
            ok = ok && o->max_error_count > 0;
        } else if (pn_args_value(&a, "--shader", &v, &err)) {
            ok = v && pn_parse_choice("--shader", v, (const char *const[]){"shadow", NULL}) == 0;
        } else if (pn_args_value(&a, "--gbuffer", &v, &err)) {
            o->gbuffer = v;
        } else if (pn_args_value(&a, "--out", &v, &err)) {
            o->out_dir = v;
        } else if (pn_args_value(&a, "--reference-cache", &v, &err)) {
            o->reference_dir = v;
        } else if (pn_args_value(&a, "--shard", &v, &err)) {
            ok = v && pn_parse_shard("--shard", v, &o->shard_k, &o->shard_n);
        } else {
            pn_error("bench: unknown option '%s' (see penumbra bench --help)", arg);
            return PN_EXIT_USAGE;
        }
        if (err || !ok)
            return PN_EXIT_USAGE;
    }
    if (quick) {
        if (!scenes_buf[0] && !views_buf[0]) {
            bench_view bunny;
            if (pn_bench_view_standard(&bunny, pn_bench_view_spec_find("bunny")))
                snprintf(views_buf, sizeof views_buf, "bunny");
            else
                snprintf(scenes_buf, sizeof scenes_buf, "builtin:default");
        }
        if (!o->size_count)
            o->sizes[0][0] = o->sizes[0][1] = 256, o->size_count = 1;
        if (!o->spp_count)
            o->spps[0] = 4, o->spps[1] = 16, o->spp_count = 2;
        if (!o->tree_count)
            o->trees[0][0] = 6, o->trees[0][1] = 3, o->trees[1][0] = 7, o->trees[1][1] = 3, o->tree_count = 2;
    }
    // The standard views unless scenes or views were named; builtin:default when none of their
    // meshes is here (the built-in views, always here, are not a bench of meshes).
    bool defaulted = !scenes_buf[0] && !views_buf[0];
    if (defaulted)
        snprintf(views_buf, sizeof views_buf, "all");
    for (char *tok = strtok(views_buf, ","); tok; tok = strtok(NULL, ","))
        if (!add_view_arg(o, tok))
            return PN_EXIT_USAGE;
    for (char *tok = strtok(scenes_buf, ","); tok; tok = strtok(NULL, ","))
        if (!add_scene_arg(o, tok))
            return PN_EXIT_USAGE;
    bool meshes = false;
    for (int i = 0; i < o->view_count; i++)
        meshes = meshes || strncmp(o->views[i].source, "builtin:", 8) != 0;
    if (!o->view_count || (defaulted && !meshes)) {
        pn_warn("bench: none of the standard views' meshes is in %s: measuring builtin:default",
                pn_bench_assets_dir());
        if (!add_scene_arg(o, "builtin:default"))
            return PN_EXIT_USAGE;
    }
    bool sequence = false;
    for (int k = 0; k < PN_BENCH_SEQUENCES; k++)
        sequence = sequence || o->sequences[k];
    if ((o->seq_frames || o->seq_step != 0.0f || o->seq_history) && !sequence) {
        pn_error("--sequence-frames, --sequence-step and --history shape --sequence, which is not given");
        return PN_EXIT_USAGE;
    }
    if (sequence && (o->points || o->shard_n || o->light_count_count || o->max_error_count || o->gbuffer)) {
        pn_error("--sequence: not with --points, --shard, --lights, --max-error or --gbuffer (it renders its own frames)");
        return PN_EXIT_USAGE;
    }
    if (sequence) {
        // What the targets name: exact, 1 spp a frame, the penumbra filter, 64 frames of 2
        // degrees, the history of render --temporal.
        if (!o->mode_count)
            o->modes[o->mode_count++] = PN_SHADOW_REFERENCE;
        if (!o->spp_count)
            o->spps[0] = 1, o->spp_count = 1;
        if (!o->filter_count)
            o->filters[0] = PN_FILTER_PENUMBRA, o->filter_count = 1;
        o->seq_frames = o->seq_frames ? o->seq_frames : 64;
        o->seq_step = o->seq_step != 0.0f ? o->seq_step : 2.0f;
        o->seq_history = o->seq_history ? o->seq_history : 32;
    }
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
        o->spps[0] = 1, o->spps[1] = 4, o->spps[2] = 16, o->spps[3] = 64, o->spps[4] = 64, o->spp_mins[4] = 4,
        o->spp_count = 5;
    if (!o->size_count)
        o->sizes[0][0] = o->sizes[0][1] = 512, o->size_count = 1;
    if (!o->filter_count)
        o->filters[0] = PN_FILTER_NONE, o->filters[1] = PN_FILTER_INTERLEAVED, o->filter_count = 2;
    // --lights and --max-error measure against the whole of a view's matrix, which no shard has.
    if (o->shard_n && (o->light_count_count || o->max_error_count)) {
        pn_error("--shard: not with %s (it needs the whole matrix of a view; run it unsharded)",
                 o->light_count_count ? "--lights" : "--max-error");
        return PN_EXIT_USAGE;
    }
    if (o->gbuffer && o->view_count != 1) {
        pn_error("--gbuffer: name the one scene its G-buffer was rendered from (--scenes or --views)");
        return PN_EXIT_USAGE;
    }
    // A reference with fewer samples than about 4x the cells' is not converged against them: its own
    // noise would dominate their reference error.
    if (o->reference_spp < 4 * o->spps[o->spp_count - 1])
        pn_warn("--reference-spp %u is below 4x the largest --spp (%u): the reference errors include its own noise",
                o->reference_spp, o->spps[o->spp_count - 1]);
    return PN_EXIT_OK;
}

// The G-buffer of --gbuffer (apps/gbuffer_file.h).
pn_result pn_bench_load_gbuffer(bench_opts *o)
{
    pn_gbuffer_file g;
    pn_result r = pn_gbuffer_file_read(o->gbuffer, &g);
    if (r != PN_OK)
        return r;
    o->gb_p = g.p, o->gb_n = g.n; // freed with the options, as before
    o->gb_width = g.width;
    o->gb_height = g.height;
    o->sizes[0][0] = o->gb_width, o->sizes[0][1] = o->gb_height, o->size_count = 1;
    return PN_OK;
}
