// penumbra bench: the state its files share and the functions they call across each other.
//
//   cmd_bench.c     help text and the command's entry (parse, device, scenes, reports)
//   bench_opts.c    the command line and --gbuffer
//   bench_matrix.c  one scene's matrix: timed frames, error against exact, --work, --max-error
//   bench_peer.c    the CPU peer, Embree 3 (the only file of the bench that includes Embree)
//   bench_report.c  console table, bench.csv, bench.json and gnuplot plots
#pragma once
#include <stdbool.h>
#include <stdint.h>

#include "apps/metrics.h"
#include "apps/render_opts.h"
#include "apps/setup.h"

// A cell's mode name.
#define MODE_NAME(m) (pn_shadow_mode_get(m)->name)

enum { MAX_LIST = 32 };

typedef struct bench_opts {
    const char *scenes[MAX_LIST];
    int scene_count;
    pn_shadow_mode modes[PN_SHADOW_MODE_COUNT];
    int mode_count;
    int trees[MAX_LIST][2];
    int tree_count;
    uint32_t spps[MAX_LIST];
    int spp_count;
    uint32_t sizes[MAX_LIST][2];
    int size_count;
    int repeat, warmup;
    pn_traversal traversal;
    pn_sampler sampler;
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
    pn_shadow_mode mode;
    int n, d;
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

// ---------------------------------------------------------------------------------------------
// Options (bench_opts.c)

// Parses the command line into *o (defaults filled in; --quick applied): PN_EXIT_OK, -1 after
// --help, or an exit code; o->owned must be freed in every case.
int pn_bench_parse(int argc, char **argv, bench_opts *o);

// Reads o->gbuffer's P, A and N layers into o->gb_p and o->gb_n and sets the only size to the EXR's.
pn_result pn_bench_load_gbuffer(bench_opts *o);

// ---------------------------------------------------------------------------------------------
// The matrix (bench_matrix.c)

typedef struct pn_bench_embree pn_bench_embree; // an Embree device (bench_peer.c)

// Median of v[0..n) (sorts v).
double pn_bench_median(double *v, int n);

// One scene's matrix: appends (and prints) a row per cell; rtc may be NULL (no CPU peer). An exit code.
int pn_bench_scene(const bench_opts *o, pn_gpu_device *dev, pn_bench_embree *rtc, const char *source, bench_rows *rows);

// ---------------------------------------------------------------------------------------------
// The CPU peer: Embree 3 (bench_peer.c)

typedef struct pn_bench_embree_scene pn_bench_embree_scene; // Embree's BVH of one pn_scene

// An Embree device, or NULL when Embree could not start.
pn_bench_embree *pn_bench_embree_create(void);

// Releases the device made by pn_bench_embree_create.
void pn_bench_embree_destroy(pn_bench_embree *e);

// Builds Embree's BVH over the scene's triangles, sharing its buffers (scene must outlive it); NULL on failure.
pn_bench_embree_scene *pn_bench_embree_scene_create(pn_bench_embree *e, pn_scene *scene);

// Releases a scene made by pn_bench_embree_scene_create.
void pn_bench_embree_scene_destroy(pn_bench_embree_scene *s);

// Traces the rays of an exact frame's ray dump (pixels x spp) on all cores, o->warmup + o->repeat
// times; prints the figures on stderr and returns the median time of the timed runs in ms.
double pn_bench_embree_time(const bench_opts *o, const pn_bench_embree_scene *s, const float *dump, uint64_t px,
                            uint32_t spp);

// ---------------------------------------------------------------------------------------------
// Reports (bench_report.c)

// Prints the console table's header line.
void pn_bench_print_header(void);

// Prints one row of the console table (and flushes stdout).
void pn_bench_print_row(const bench_row *r);

// Writes dir/bench.csv: one line per row. False (logged) on failure.
bool pn_bench_write_csv(const char *dir, const bench_rows *rows);

// Writes dir/bench.json: the device, CPU and options, then the rows. False (logged) on failure.
bool pn_bench_write_json(const char *dir, const bench_opts *o, const pn_gpu_device *dev, const bench_rows *rows);

// Writes per scene, size and spp a gnuplot .dat and .gp (error vs shadow time with the Pareto
// front) and draws them as PNG with gnuplot when present. False (logged) on failure.
bool pn_bench_write_plots(const char *dir, const bench_rows *rows);
