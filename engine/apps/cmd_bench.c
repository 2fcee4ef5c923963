// penumbra bench: the speed/accuracy trade measured side by side. A matrix of scenes x sizes x
// samples x modes x trees; every cell renders warm-up and repeated frames (GPU timestamps per pass,
// median and spread), and is compared with the exact mode on the same pixels and light samples.
// Embree 3's rtcOccluded1 traces the very same rays on all cores as the CPU peer.
#include <dirent.h>
#include <embree3/rtcore.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "apps/args.h"
#include "apps/commands.h"
#include "apps/metrics.h"
#include "apps/quality.h"
#include "apps/setup.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/timer.h"
#include "io/exr.h"
#include "io/file.h"
#include "io/json.h"

static const char *const MODE_NAMES[] = {"none", "linespace", "hybrid", "exact-ls", "exact", NULL};

enum { MAX_LIST = 32 };

typedef struct bench_opts {
    const char *scenes[MAX_LIST];
    int scene_count;
    int modes[5];
    int mode_count;
    int trees[MAX_LIST][2];
    int tree_count;
    uint32_t spps[MAX_LIST];
    int spp_count;
    uint32_t sizes[MAX_LIST][2];
    int size_count;
    int repeat, warmup;
    int traversal, sampler;
    const char *out_dir;
    bool embree;
    double max_error; // > 0: check --quality auto against the matrix at this budget
    bool work;           // --work: count each cell's work per pixel with the counting shader builds
    const char *gbuffer; // --shader shadow --gbuffer FILE.exr: P and N from a render's AOVs
    float *gb_p, *gb_n;  // its P (w = A) and N as RGBA planes
    uint32_t gb_width, gb_height;
    char *owned[256]; // scene paths found in --scenes folders
    int owned_count;
} bench_opts;

// One cell of the matrix.
typedef struct bench_row {
    char scene[256];
    uint32_t width, height, spp;
    int mode, n, d;
    uint32_t triangles;
    double build_ms, pool_mb;
    double gbuffer_ms, shadow_ms, shade_ms;       // medians
    double shadow_min_ms, shadow_max_ms;          // spread
    double rays_per_s;
    pn_error_metrics err;                         // against exact
    double vs_exact, vs_embree;                   // shadow time ratios (lower is faster)
} bench_row;

typedef struct bench_rows {
    bench_row *rows;
    int count, cap;
} bench_rows;

void pn_print_bench_help(void)
{
    printf("usage: penumbra bench [options]\n"
           "  Renders a matrix of scenes x sizes x samples x modes x trees, each with warm-up and repeated\n"
           "  frames timed by GPU timestamps (median and spread), compares every cell with exact on the\n"
           "  same pixels and light samples (MAE, RMSE, p99, max) and traces the same rays with Embree 3\n"
           "  on all cores. Writes a console table, bench.csv, bench.json and gnuplot plots of error vs\n"
           "  shadow time with the Pareto front.\n"
           "  --scenes A,B,...     scenes (files or builtin:NAME) or folders of .glb (default builtin:default)\n"
           "  --modes M,...        of linespace, hybrid, exact-ls, exact (default: all four)\n"
           "  --trees N,d:N,d:...  trees for the line-space modes (default 6,3:7,3:8,3)\n"
           "  --spp S,...          rays per pixel (default 25)\n"
           "  --size WxH,...       image sizes (default 512x512)\n"
           "  --repeat R --warmup W   timed and untimed frames per cell (default 5 and 1)\n"
           "  --traversal ray|packet  --sampler grid|stratified   (default ray, stratified)\n"
           "  --out DIR            where the CSV, JSON and plots go (default bench-out)\n"
           "  --no-embree          skip the CPU peer\n"
           "  --shader shadow --gbuffer FILE.exr\n"
           "                       shader level: the shadow pass alone over the P and N layers of an EXR\n"
           "                       (render --aovs of the same scene); the size is the EXR's\n"
           "  --work               per cell, one more frame with the shadow shader's counting build: per\n"
           "                       pixel nodes visited, line-space lookups, triangle tests and deepest\n"
           "                       stack; their distribution is printed and written as EXR layers work.*\n"
           "  --max-error E        also run --quality auto at this budget and compare its pick with the\n"
           "                       matrix's fastest cell within the budget\n"
           "  --quick              a small matrix (bunny or builtin:default, 256x256, 16 spp, LS(6,3) and\n"
           "                       LS(7,3), 3 repeats): under two minutes on a 2-core CPU with lavapipe\n");
}

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
        for (int i = 0; i < n; i++) {
            o->owned[o->owned_count++] = found[i];
            if (o->scene_count < MAX_LIST)
                o->scenes[o->scene_count++] = found[i];
        }
        if (n == 0)
            pn_warn("%s: no .glb files", s);
        return true;
    }
    if (o->scene_count < MAX_LIST)
        o->scenes[o->scene_count++] = s;
    return true;
}

static int parse(int argc, char **argv, bench_opts *o)
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
            for (char *tok = strtok(buf, ","); tok && ok && o->mode_count < 5; tok = strtok(NULL, ",")) {
                int m = pn_parse_choice("--modes", tok, MODE_NAMES);
                ok = m > 0;
                if (m == 0)
                    pn_error("--modes: none has no shadows to measure");
                if (ok)
                    o->modes[o->mode_count++] = m;
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
            ok = v && (o->traversal = pn_parse_choice("--traversal", v, (const char *const[]){"packet", "ray", NULL})) >= 0;
        } else if (pn_args_value(&a, "--sampler", &v, &err)) {
            ok = v && (o->sampler = pn_parse_choice("--sampler", v, (const char *const[]){"grid", "stratified", NULL})) >= 0;
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
        const int all[4] = {PN_SHADOW_EXACT, PN_SHADOW_EXACT_LS, PN_SHADOW_HYBRID, PN_SHADOW_LINESPACE};
        memcpy(o->modes, all, sizeof all);
        o->mode_count = 4;
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
static pn_result load_gbuffer(bench_opts *o)
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

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Renders warm-up and timed frames; fills the timing fields of `row` and leaves the last frame's
// images in the renderer.
static pn_result time_frames(const bench_opts *o, pn_renderer *r, const pn_camera *cam, const pn_light *light,
                             bench_row *row)
{
    double g[1000], s[1000], h[1000];
    pn_frame_times t;
    for (int i = 0; i < o->warmup; i++)
        if (pn_renderer_render(r, cam, light, &t) != PN_OK)
            return PN_ERR_VULKAN;
    for (int i = 0; i < o->repeat; i++) {
        if (pn_renderer_render(r, cam, light, &t) != PN_OK)
            return PN_ERR_VULKAN;
        g[i] = t.gbuffer_ms, s[i] = t.shadow_ms, h[i] = t.shade_ms;
    }
    row->gbuffer_ms = median(g, o->repeat);
    row->shade_ms = median(h, o->repeat);
    row->shadow_ms = median(s, o->repeat); // sorts s
    row->shadow_min_ms = s[0];
    row->shadow_max_ms = s[o->repeat - 1];
    return PN_OK;
}

// ---------------------------------------------------------------------------------------------
// The CPU peer: Embree 3 on the rays of the exact mode's ray dump.

typedef struct embree_job {
    RTCScene scene;
    const float *dump;
    uint64_t pixels, spp;
    uint64_t *rays, *blocked; // per thread
} embree_job;

static void embree_trace(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    embree_job *j = ctx;
    struct RTCIntersectContext ic;
    rtcInitIntersectContext(&ic);
    uint64_t rays = 0, blocked = 0;
    for (uint64_t p = begin; p < end; p++) {
        const float *o = j->dump + 4 * p;
        if (o[3] != 1.0f)
            continue;
        for (uint64_t k = 0; k < j->spp; k++) {
            const float *q = j->dump + 4 * (j->pixels + p * j->spp + k);
            uint32_t flags;
            memcpy(&flags, &q[3], 4);
            if (!(flags & 1))
                continue;
            struct RTCRay ray = {.org_x = o[0], .org_y = o[1], .org_z = o[2], .tnear = 0.0f, .dir_x = q[0] - o[0],
                                 .dir_y = q[1] - o[1], .dir_z = q[2] - o[2], .tfar = 1.0f, .mask = 0xffffffffu};
            rtcOccluded1(j->scene, &ic, &ray);
            rays++;
            blocked += ray.tfar < 0;
        }
    }
    __atomic_fetch_add(&j->rays[0], rays, __ATOMIC_RELAXED);
    __atomic_fetch_add(&j->blocked[0], blocked, __ATOMIC_RELAXED);
}

// ---------------------------------------------------------------------------------------------

static void print_row(const bench_row *r)
{
    char tree[16] = "-";
    if (r->n)
        snprintf(tree, sizeof tree, "%d,%d", r->n, r->d);
    printf("%-28.28s %4ux%-4u %4u %-9s %-5s %8.1f %7.1f %9.1f [%7.1f %7.1f] %7.2f %8.4f %7.4f %6.3f %6.2f %6.2f\n",
           r->scene, r->width, r->height, r->spp, MODE_NAMES[r->mode], tree, r->build_ms, r->pool_mb, r->shadow_ms,
           r->shadow_min_ms, r->shadow_max_ms, r->rays_per_s / 1e6, r->err.mae, r->err.p99, r->err.max, r->vs_exact,
           r->vs_embree);
    fflush(stdout);
}

static bool push_row(bench_rows *rows, const bench_row *r)
{
    if (rows->count == rows->cap) {
        int cap = rows->cap ? 2 * rows->cap : 64;
        bench_row *n = realloc(rows->rows, (size_t)cap * sizeof *n);
        if (!n)
            return false;
        rows->rows = n;
        rows->cap = cap;
    }
    rows->rows[rows->count++] = *r;
    print_row(r);
    return true;
}

// --quality auto against the matrix: the configuration it picks from its pilot, rendered in full and
// measured against exact, next to the fastest cell of this group that meets the same budget.
static void check_quality(const bench_opts *o, pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                          const pn_light *light, const pn_renderer_desc *frame, const float *v_ref, const uint8_t *mask,
                          bench_rows *rows, int first_row)
{
    const bench_row *best = NULL;
    for (int i = first_row; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        if (r->err.mae <= o->max_error && (!best || r->shadow_ms < best->shadow_ms))
            best = r;
    }
    pn_quality_choice q;
    if (pn_quality_choose(dev, scene, cam, light, frame, o->max_error, 0, &q) != PN_OK)
        return;
    pn_setup s;
    pn_setup_desc sd = {.frame = *frame, .tree_n = q.tree_n, .tree_d = q.tree_d, .view = cam};
    sd.frame.mode = (pn_shadow_mode)q.mode;
    bench_row row = rows->rows[first_row < rows->count ? first_row : 0];
    if (pn_setup_create(dev, scene, light, &sd, &s) != PN_OK)
        return;
    if (time_frames(o, &s.renderer, cam, light, &row) == PN_OK) {
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        pn_error_compare(img.v, v_ref, mask, (size_t)frame->width * frame->height, NULL, &row.err);
        printf("quality auto (max error %.4g): %s", o->max_error, MODE_NAMES[q.mode]);
        if (q.tree_n)
            printf(" LS(%d,%d)", q.tree_n, q.tree_d);
        printf(", shadow %.1f ms, MAE %.4f (pilot %.4f)", row.shadow_ms, row.err.mae, q.pilot_mae);
        if (best)
            printf("; the matrix's fastest within the budget: %s LS(%d,%d) %.1f ms: auto takes %.2fx its time\n",
                   MODE_NAMES[best->mode], best->n, best->d, best->shadow_ms, row.shadow_ms / best->shadow_ms);
        else
            printf("; no cell of the matrix meets the budget\n");
    }
    pn_setup_destroy(dev, &s);
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

// --work: one frame with the counting build of the cell's shadow shader; the distribution of each
// counter over the pixels with geometry, and the counters as EXR layers.
static void report_work(const bench_opts *o, pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                        const pn_light *light, pn_setup_desc sd, const char *label)
{
    sd.frame.count_work = true;
    sd.frame.dump_rays = false;
    pn_setup s;
    if (pn_setup_create(dev, scene, light, &sd, &s) != PN_OK)
        return;
    pn_frame_times t;
    if ((!o->gbuffer || pn_renderer_set_gbuffer(&s.renderer, o->gb_p, o->gb_n) == PN_OK) &&
        pn_renderer_render(&s.renderer, cam, light, &t) == PN_OK) {
        const uint32_t *w = pn_renderer_work(&s.renderer);
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        size_t px = (size_t)sd.frame.width * sd.frame.height, n = 0;
        uint32_t *vals = malloc(px * sizeof *vals);
        float *planes = calloc(px * 4, sizeof *planes);
        static const char *const names[4] = {"work.nodes", "work.lookups", "work.triangles", "work.depth"};
        printf("  work of %s per pixel (p50 / p90 / p99 / max):", label);
        for (int c = 0; c < 4 && vals && planes; c++) {
            n = 0;
            for (size_t i = 0; i < px; i++) {
                planes[c * px + i] = (float)w[4 * i + c];
                if (img.p[4 * i + 3] > 0)
                    vals[n++] = w[4 * i + c];
            }
            qsort(vals, n, sizeof *vals, cmp_u32);
            if (n)
                printf(" %s %u/%u/%u/%u", names[c] + 5, vals[n / 2], vals[(size_t)(0.9 * (double)(n - 1))],
                       vals[(size_t)(0.99 * (double)(n - 1))], vals[n - 1]);
        }
        printf("\n");
        if (vals && planes) {
            char path[4096];
            snprintf(path, sizeof path, "%s/work_%s.exr", o->out_dir, label);
            for (char *c = path + strlen(o->out_dir) + 1; *c; c++)
                if (*c == ':' || *c == '/' || *c == ',' || *c == ' ')
                    *c = '_';
            pn_exr_channel ch[4];
            for (int c = 0; c < 4; c++)
                ch[c] = (pn_exr_channel){names[c], planes + c * px};
            pn_exr_write(path, (int)sd.frame.width, (int)sd.frame.height, ch, 4, NULL, 0);
        }
        free(vals);
        free(planes);
    }
    pn_setup_destroy(dev, &s);
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

// One scene: its exact reference and Embree peer per size and spp, then every mode and tree.
static int bench_scene(const bench_opts *o, pn_gpu_device *dev, RTCDevice rtc, const char *source, bench_rows *rows)
{
    pn_scene scene;
    if (pn_scene_load(source, &scene) != PN_OK)
        return PN_EXIT_FAILURE;
    pn_camera cam;
    pn_light light;
    // Reproducible camera and light from the bounds, and the ground plane, as render's defaults.
    if (scene.has_camera)
        cam = scene.camera;
    else
        pn_camera_frame(scene.bounds_min, scene.bounds_max, 45.0f, &cam);
    pn_light_default(scene.bounds_min, scene.bounds_max, &light);
    if (pn_scene_add_ground(&scene, 6.0f) != PN_OK) {
        pn_scene_destroy(&scene);
        return PN_EXIT_FAILURE;
    }
    RTCScene rs = NULL;
    double embree_build_ms = 0;
    if (rtc) {
        uint64_t t0 = pn_time_ns();
        rs = rtcNewScene(rtc);
        RTCGeometry g = rtcNewGeometry(rtc, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, scene.vertices, 0, sizeof(pn_vertex),
                                   scene.vertex_count);
        rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, scene.indices, 0, 12,
                                   scene.index_count / 3);
        rtcCommitGeometry(g);
        rtcAttachGeometry(rs, g);
        rtcReleaseGeometry(g);
        rtcSetSceneBuildQuality(rs, RTC_BUILD_QUALITY_HIGH);
        rtcCommitScene(rs);
        embree_build_ms = pn_ms_since(t0);
    }
    int rc = PN_EXIT_OK;
    for (int si = 0; si < o->size_count && rc == PN_EXIT_OK; si++)
        for (int pi = 0; pi < o->spp_count && rc == PN_EXIT_OK; pi++) {
            uint32_t w = o->sizes[si][0], h = o->sizes[si][1], spp = o->spps[pi];
            size_t px = (size_t)w * h;
            pn_renderer_desc frame = {.width = w, .height = h, .traversal = (pn_traversal)o->traversal,
                                      .sampler = (pn_sampler)o->sampler, .spp = spp, .seed = 1};
            // The reference: exact, with its rays kept for Embree.
            pn_setup ref;
            pn_setup_desc rd = {.frame = frame};
            rd.frame.mode = PN_SHADOW_EXACT;
            rd.frame.dump_rays = rtc != NULL;
            bench_row base = {.width = w, .height = h, .spp = spp, .triangles = pn_scene_triangle_count(&scene)};
            snprintf(base.scene, sizeof base.scene, "%s", base_name(scene.name));
            fprintf(stderr, "bench: %s %ux%u %u spp: exact reference\n", scene.name, w, h, spp);
            if (pn_setup_create(dev, &scene, &light, &rd, &ref) != PN_OK ||
                (o->gbuffer && pn_renderer_set_gbuffer(&ref.renderer, o->gb_p, o->gb_n) != PN_OK)) {
                rc = PN_EXIT_FAILURE;
                break;
            }
            bench_row exact_row = base;
            exact_row.mode = PN_SHADOW_EXACT;
            float *v_ref = malloc(px * sizeof *v_ref);
            uint8_t *mask = malloc(px);
            if (!v_ref || !mask || time_frames(o, &ref.renderer, &cam, &light, &exact_row) != PN_OK) {
                free(v_ref), free(mask);
                pn_setup_destroy(dev, &ref);
                rc = PN_EXIT_FAILURE;
                break;
            }
            pn_frame_images img;
            pn_renderer_images(&ref.renderer, &img);
            uint64_t covered = 0;
            for (size_t i = 0; i < px; i++) {
                v_ref[i] = img.v[i];
                mask[i] = img.p[4 * i + 3] > 0;
                covered += mask[i];
            }
            double embree_ms = 0;
            uint64_t embree_rays = 0;
            if (rs) {
                uint64_t floats;
                const float *dump = pn_renderer_ray_dump(&ref.renderer, &floats);
                double times[1000];
                for (int r = 0; r < o->repeat + o->warmup; r++) {
                    uint64_t rays = 0, blocked = 0;
                    embree_job j = {rs, dump, px, spp, &rays, &blocked};
                    uint64_t t0 = pn_time_ns();
                    pn_parallel_for(px, 256, embree_trace, &j);
                    if (r >= o->warmup)
                        times[r - o->warmup] = pn_ms_since(t0);
                    embree_rays = rays;
                }
                embree_ms = median(times, o->repeat);
                fprintf(stderr, "bench: Embree (%u threads): %.1f ms for %llu rays (%.2f M rays/s; BVH %.0f ms)\n",
                        pn_parallel_threads(), embree_ms, (unsigned long long)embree_rays,
                        embree_rays / (embree_ms * 1e3), embree_build_ms);
            }
            double exact_ms = exact_row.shadow_ms;
            exact_row.build_ms = ref.build_ms;
            exact_row.pool_mb = ref.exact_bytes / 1048576.0;
            exact_row.rays_per_s = covered * (double)pn_shadow_samples(spp, &light) / (exact_ms * 1e-3);
            exact_row.vs_exact = 1.0;
            exact_row.vs_embree = embree_ms > 0 ? exact_ms / embree_ms : 0;
            pn_error_compare(v_ref, v_ref, mask, px, NULL, &exact_row.err);
            pn_setup_destroy(dev, &ref);
            int first_row = rows->count; // this group's rows start here
            if (o->work) {
                char label[512];
                snprintf(label, sizeof label, "%s_%ux%u_%uspp_exact", base.scene, w, h, spp);
                report_work(o, dev, &scene, &cam, &light, rd, label);
            }
            bool want_exact = false;
            for (int m = 0; m < o->mode_count; m++)
                want_exact = want_exact || o->modes[m] == PN_SHADOW_EXACT;
            if (want_exact)
                push_row(rows, &exact_row);
            // Every other mode and tree against it.
            for (int m = 0; m < o->mode_count && rc == PN_EXIT_OK; m++) {
                if (o->modes[m] == PN_SHADOW_EXACT)
                    continue;
                for (int ti = 0; ti < o->tree_count && rc == PN_EXIT_OK; ti++) {
                    pn_setup s;
                    pn_setup_desc sd = {.frame = frame, .tree_n = o->trees[ti][0], .tree_d = o->trees[ti][1],
                                        .view = o->gbuffer ? NULL : &cam}; // the tree models what the picture needs
                    sd.frame.mode = (pn_shadow_mode)o->modes[m];
                    bench_row row = base;
                    row.mode = o->modes[m];
                    row.n = o->trees[ti][0], row.d = o->trees[ti][1];
                    fprintf(stderr, "bench: %s %s LS(%d,%d)\n", scene.name, MODE_NAMES[row.mode], row.n, row.d);
                    if (pn_setup_create(dev, &scene, &light, &sd, &s) != PN_OK) {
                        pn_warn("bench: %s LS(%d,%d) skipped (see above)", MODE_NAMES[row.mode], row.n, row.d);
                        continue;
                    }
                    if (o->gbuffer && pn_renderer_set_gbuffer(&s.renderer, o->gb_p, o->gb_n) != PN_OK)
                        rc = PN_EXIT_FAILURE;
                    if (time_frames(o, &s.renderer, &cam, &light, &row) == PN_OK) {
                        pn_renderer_images(&s.renderer, &img);
                        row.build_ms = s.build_ms;
                        row.pool_mb = (s.pool_bytes.total + s.exact_bytes) / 1048576.0;
                        row.rays_per_s = covered * (double)pn_shadow_samples(spp, &light) / (row.shadow_ms * 1e-3);
                        row.vs_exact = row.shadow_ms / exact_ms;
                        row.vs_embree = embree_ms > 0 ? row.shadow_ms / embree_ms : 0;
                        pn_error_compare(img.v, v_ref, mask, px, NULL, &row.err);
                        push_row(rows, &row);
                        if (o->work) {
                            char label[512];
                            snprintf(label, sizeof label, "%s_%ux%u_%uspp_%s_LS%d_%d", base.scene, w, h, spp,
                                     MODE_NAMES[row.mode], row.n, row.d);
                            report_work(o, dev, &scene, &cam, &light, sd, label);
                        }
                    } else {
                        rc = PN_EXIT_FAILURE;
                    }
                    pn_setup_destroy(dev, &s);
                }
            }
            if (o->max_error > 0 && rc == PN_EXIT_OK)
                check_quality(o, dev, &scene, &cam, &light, &frame, v_ref, mask, rows, first_row);
            free(v_ref);
            free(mask);
        }
    if (rs)
        rtcReleaseScene(rs);
    pn_scene_destroy(&scene);
    return rc;
}

// ---------------------------------------------------------------------------------------------
// Outputs

static void cpu_name(char *out, size_t n)
{
    snprintf(out, n, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    char line[512];
    while (f && fgets(line, sizeof line, f))
        if (strncmp(line, "model name", 10) == 0) {
            char *c = strchr(line, ':');
            if (c) {
                snprintf(out, n, "%s", c + 2);
                out[strcspn(out, "\n")] = '\0';
            }
            break;
        }
    if (f)
        fclose(f);
}

static FILE *open_out(const char *dir, const char *name, char *path, char *tmp)
{
    snprintf(path, 4096, "%s/%s", dir, name);
    if (pn_file_tmp_path(path, tmp, 4096) != PN_OK)
        return NULL;
    FILE *f = fopen(tmp, "w");
    if (!f)
        pn_error("%s: cannot write: %s", path, strerror(errno));
    return f;
}

static bool close_out(FILE *f, const char *path, const char *tmp)
{
    bool ok = fclose(f) == 0;
    if (!ok) {
        pn_error("%s: write failed", path);
        pn_file_discard(tmp);
        return false;
    }
    return pn_file_commit(tmp, path) == PN_OK;
}

static bool write_csv(const char *dir, const bench_rows *rows)
{
    char path[4096], tmp[4096];
    FILE *f = open_out(dir, "bench.csv", path, tmp);
    if (!f)
        return false;
    fprintf(f, "scene,width,height,spp,mode,n,d,triangles,build_ms,pool_mb,gbuffer_ms,shadow_ms,shadow_min_ms,"
               "shadow_max_ms,shade_ms,rays_per_s,mae,rmse,p99,max,over005,over02,vs_exact,vs_embree\n");
    for (int i = 0; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        fprintf(f, "%s,%u,%u,%u,%s,%d,%d,%u,%.3f,%.3f,%.4f,%.4f,%.4f,%.4f,%.4f,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.4f,%.4f\n",
                r->scene, r->width, r->height, r->spp, MODE_NAMES[r->mode], r->n, r->d, r->triangles, r->build_ms,
                r->pool_mb, r->gbuffer_ms, r->shadow_ms, r->shadow_min_ms, r->shadow_max_ms, r->shade_ms, r->rays_per_s,
                r->err.mae, r->err.rmse, r->err.p99, r->err.max, r->err.over005, r->err.over02, r->vs_exact, r->vs_embree);
    }
    return close_out(f, path, tmp);
}

static bool write_json(const char *dir, const bench_opts *o, const pn_gpu_device *dev, const bench_rows *rows)
{
    char path[4096], tmp[4096], cpu[256];
    FILE *f = open_out(dir, "bench.json", path, tmp);
    if (!f)
        return false;
    cpu_name(cpu, sizeof cpu);
    fprintf(f, "{\"context\": {\"device\": ");
    pn_json_string(f, dev->props.deviceName);
    fprintf(f, ", \"driver_version\": %u, \"api_version\": \"%u.%u.%u\", \"cpu\": ", dev->props.driverVersion,
            VK_API_VERSION_MAJOR(dev->props.apiVersion), VK_API_VERSION_MINOR(dev->props.apiVersion),
            VK_API_VERSION_PATCH(dev->props.apiVersion));
    pn_json_string(f, cpu);
    fprintf(f, ", \"threads\": %u, \"repeat\": %d, \"warmup\": %d, \"traversal\": \"%s\", \"sampler\": \"%s\", "
               "\"scenes\": [",
            pn_parallel_threads(), o->repeat, o->warmup, o->traversal ? "ray" : "packet",
            o->sampler ? "stratified" : "grid");
    for (int i = 0; i < o->scene_count; i++) {
        fprintf(f, "%s", i ? ", " : "");
        pn_json_string(f, o->scenes[i]);
    }
    fprintf(f, "]}, \"results\": [\n");
    for (int i = 0; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        fprintf(f, "  {\"scene\": ");
        pn_json_string(f, r->scene);
        fprintf(f, ", \"width\": %u, \"height\": %u, \"spp\": %u, \"mode\": \"%s\", \"tree\": ", r->width, r->height,
                r->spp, MODE_NAMES[r->mode]);
        if (r->n)
            fprintf(f, "[%d, %d]", r->n, r->d);
        else
            fprintf(f, "null");
        fprintf(f, ", \"triangles\": %u, \"build_ms\": %.3f, \"pool_mb\": %.3f, \"gpu_ms\": {\"gbuffer\": %.4f, "
                   "\"shadow\": %.4f, \"shadow_min\": %.4f, \"shadow_max\": %.4f, \"shade\": %.4f}, \"shadow_rays_per_s\": "
                   "%.6g, \"error\": {\"mae\": %.6g, \"rmse\": %.6g, \"p99\": %.6g, \"max\": %.6g, \"over005\": %.6g, "
                   "\"over02\": %.6g}, \"vs_exact\": %.4f, \"vs_embree\": %.4f}%s\n",
                r->triangles, r->build_ms, r->pool_mb, r->gbuffer_ms, r->shadow_ms, r->shadow_min_ms, r->shadow_max_ms,
                r->shade_ms, r->rays_per_s, r->err.mae, r->err.rmse, r->err.p99, r->err.max, r->err.over005,
                r->err.over02, r->vs_exact, r->vs_embree, i + 1 < rows->count ? "," : "");
    }
    fprintf(f, "]}\n");
    return close_out(f, path, tmp);
}

// Per scene, size and spp: MAE against shadow time, one labelled point per configuration, and the
// Pareto front (no other point is both faster and more accurate) as a line.
static bool write_plots(const char *dir, const bench_rows *rows)
{
    bool ok = true;
    bool *done = calloc((size_t)rows->count + 1, 1);
    if (!done)
        return false;
    for (int i = 0; i < rows->count && ok; i++) {
        if (done[i])
            continue;
        const bench_row *g = &rows->rows[i];
        char stem[512], path[4096], tmp[4096];
        snprintf(stem, sizeof stem, "%s_%ux%u_%uspp", g->scene, g->width, g->height, g->spp);
        for (char *c = stem; *c; c++)
            if (*c == ':' || *c == '/')
                *c = '_';
        char name[600];
        snprintf(name, sizeof name, "%s.dat", stem);
        FILE *f = open_out(dir, name, path, tmp);
        if (!f)
            return free(done), false;
        // The group's points, then the front: sorted by time, keeping each point more accurate than
        // all faster ones.
        int idx[256], n = 0;
        for (int j = i; j < rows->count && n < 256; j++) {
            const bench_row *r = &rows->rows[j];
            if (!strcmp(r->scene, g->scene) && r->width == g->width && r->height == g->height && r->spp == g->spp) {
                done[j] = true;
                idx[n++] = j;
            }
        }
        for (int a = 0; a < n; a++)
            for (int b = a + 1; b < n; b++)
                if (rows->rows[idx[b]].shadow_ms < rows->rows[idx[a]].shadow_ms) {
                    int t = idx[a];
                    idx[a] = idx[b];
                    idx[b] = t;
                }
        fprintf(f, "# shadow_ms mae label\n");
        for (int a = 0; a < n; a++) {
            const bench_row *r = &rows->rows[idx[a]];
            if (r->n)
                fprintf(f, "%.4f %.6g %s-LS(%d,%d)\n", r->shadow_ms, r->err.mae, MODE_NAMES[r->mode], r->n, r->d);
            else
                fprintf(f, "%.4f %.6g %s\n", r->shadow_ms, r->err.mae, MODE_NAMES[r->mode]);
        }
        fprintf(f, "\n\n# Pareto front\n");
        double best = INFINITY;
        for (int a = 0; a < n; a++) {
            const bench_row *r = &rows->rows[idx[a]];
            if (r->err.mae < best) {
                best = r->err.mae;
                fprintf(f, "%.4f %.6g\n", r->shadow_ms, r->err.mae);
            }
        }
        ok = close_out(f, path, tmp);
        snprintf(name, sizeof name, "%s.gp", stem);
        char gp_path[4096];
        f = ok ? open_out(dir, name, gp_path, tmp) : NULL;
        if (!f)
            return free(done), false;
        // MAE is 0 for exact modes: the y axis is linear so that they show, at the bottom.
        fprintf(f, "set terminal pngcairo size 900,600\nset output '%s.png'\nset title '%s: error against exact vs shadow pass time'\n"
                   "set xlabel 'shadow pass (ms, median)'\nset ylabel 'mean absolute error of V'\nset logscale x\n"
                   "set grid\nset key top right\n"
                   "plot '%s.dat' index 0 using 1:2 with points pt 7 ps 1.5 title 'configurations', \\\n"
                   "     '' index 0 using 1:2:3 with labels offset 0,1 font ',8' notitle, \\\n"
                   "     '' index 1 using 1:2 with lines lw 2 title 'Pareto front'\n",
                stem, g->scene, stem);
        ok = close_out(f, gp_path, tmp);
        if (ok) {
            char cmd[8192];
            snprintf(cmd, sizeof cmd, "cd '%s' && gnuplot '%s.gp' 2>/dev/null", dir, stem);
            if (system(cmd) != 0)
                pn_warn("gnuplot could not draw %s.gp (is gnuplot-nox installed?)", stem);
        }
    }
    free(done);
    return ok;
}

int pn_cmd_bench(int argc, char **argv)
{
    bench_opts o;
    int rc = parse(argc, argv, &o);
    if (rc != PN_EXIT_OK) {
        for (int i = 0; i < o.owned_count; i++)
            free(o.owned[i]);
        return rc < 0 ? PN_EXIT_OK : rc;
    }
    if (o.gbuffer && load_gbuffer(&o) != PN_OK) {
        for (int i = 0; i < o.owned_count; i++)
            free(o.owned[i]);
        return PN_EXIT_FAILURE;
    }
    if (mkdir(o.out_dir, 0755) != 0 && errno != EEXIST) {
        pn_error("%s: cannot create the output folder: %s", o.out_dir, strerror(errno));
        return PN_EXIT_FAILURE;
    }
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK)
        return PN_EXIT_FAILURE;
    RTCDevice rtc = o.embree ? rtcNewDevice(NULL) : NULL;
    if (o.embree && !rtc)
        pn_warn("Embree could not start: the CPU peer is skipped");
    printf("%-28s %-9s %4s %-9s %-5s %8s %7s %9s [%7s %7s] %7s %8s %7s %6s %6s %6s\n", "scene", "size", "spp", "mode",
           "tree", "build ms", "MB", "shadow ms", "min", "max", "Mray/s", "MAE", "p99", "max", "/exact", "/embree");
    bench_rows rows = {0};
    uint64_t t0 = pn_time_ns();
    for (int i = 0; i < o.scene_count && rc == PN_EXIT_OK; i++)
        rc = bench_scene(&o, &dev, rtc, o.scenes[i], &rows);
    if (rows.count && !(write_csv(o.out_dir, &rows) && write_json(o.out_dir, &o, &dev, &rows) && write_plots(o.out_dir, &rows)))
        rc = PN_EXIT_FAILURE;
    fprintf(stderr, "bench: %d cells in %.1f s; results in %s/bench.csv, bench.json and *.png\n", rows.count,
            pn_ms_since(t0) * 1e-3, o.out_dir);
    free(rows.rows);
    if (rtc)
        rtcReleaseDevice(rtc);
    pn_gpu_device_destroy(&dev);
    for (int i = 0; i < o.owned_count; i++)
        free(o.owned[i]);
    free(o.gb_p);
    free(o.gb_n);
    if (dev.validation_messages) {
        pn_error("the Vulkan validation layer reported %u message(s)", dev.validation_messages);
        return PN_EXIT_VALIDATION;
    }
    return rc;
}
