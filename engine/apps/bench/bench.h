// penumbra bench: the state its files share and the functions they call across each other.
//
//   cmd_bench.c     the command's entry (parse, device, scenes, reports)
//   bench_opts.c    the help text, the command line and --gbuffer
//   bench_views.c   the standard views, and the scenes of --scenes
//   bench_reference.c  the converged reference per view and size, cached on disk
//   bench_matrix.c  one view's matrix: the cells, the two errors, --work
//   bench_frames.c  what the matrix, --lights and --max-error share: timed frames, set-ups
//   bench_lights.c  --lights: frames of several lights over one tree
//   bench_quality.c --max-error: --quality auto's pick against the matrix's front
//   bench_peer.c    the CPU peer, Embree 3 (the only file of the bench that includes Embree)
//   bench_report.c  console table, bench.csv, bench.json, time_to_error.md
//   bench_plot.c    the gnuplot plots
//   bench_shard.c   --shard K/N's partial file, and --merge of the shards' partial files
//   bench_points.c  --points: the library's points in, V out beside the renderer
//   bench_sequence.c  --sequence: frames in motion, with the temporal history and without
#pragma once
#include <stdbool.h>
#include <stdio.h>
#include <stdint.h>

#include "apps/embree_peer.h"
#include "shadow/metrics.h"
#include "shadow/quality.h"
#include "apps/render_opts.h"
#include "shadow/setup.h"

// A cell's mode name.
#define MODE_NAME(m) (pn_shadow_mode_get(m)->name)

enum { MAX_LIST = 32, MAX_BUDGETS = 8 };

// The tree kinds of --tree-kinds, and their names in reports.
enum { PN_TREE_KIND_SCENE, PN_TREE_KIND_OBJECT };
// bench --sequence's kinds (bench_sequence.c): orbit, light, object, walk.
enum { PN_BENCH_SEQUENCES = 4 };
extern const char *const pn_bench_tree_kind_names[]; // "scene", "object", NULL

// A standard view (bench_views.c): camera and light in units of the object's bounding-sphere radius
// r, from its centre.
typedef struct pn_bench_view_spec {
    const char *name; // bunny, dragon, buddha, sponza, ...
    const char *file; // in the assets folder (pn_bench_assets_dir), or builtin:NAME
    float camera[3], target[3], fov;
    float light[3], aim[3]; // the light's centre and the point its normal faces
    float light_size;       // width = height
    bool ground;            // add render's ground plane under the object
    pn_light_kind kind;     // RECT; SUN: from the light's centre towards aim, sun_deg across;
                            // SPHERE: at the light's centre, light_size / 2 in radius
    float sun_deg;
} pn_bench_view_spec;

// What one group of the matrix renders: a scene and how it is seen.
typedef struct bench_view {
    char name[64];     // the standard view's name, or the scene file's base name
    char source[1024]; // glTF file or builtin:NAME
    const pn_bench_view_spec *spec; // NULL: render's default camera and light (--scenes)
} bench_view;

typedef struct bench_opts {
    bench_view views[MAX_LIST];
    int view_count;
    pn_shadow_mode modes[PN_SHADOW_MODE_COUNT];
    int mode_count;
    int trees[MAX_LIST][2];
    int tree_count;
    // --tree-kinds: an axis of the matrix for the line-space trees, the scene-wide tree (culled by
    // the view and lights) and per-object trees (one per mesh, shared by its instances, and a top
    // level; mode linespace only): kinds[PN_TREE_KIND_*] (default the scene-wide alone).
    bool kinds[2];
    uint32_t spps[MAX_LIST]; // ascending (adaptive entries by their MAX, after the uniform one of it)
    uint32_t spp_mins[MAX_LIST]; // per entry: adaptive samples' MIN (--spp MIN:MAX), 0 for uniform
    int spp_count;
    float pixel_error; // --pixel-error of the adaptive cells
    uint32_t sizes[MAX_LIST][2];
    int size_count;
    int repeat, warmup;
    pn_traversal traversal;
    // --traversal's list names project: exact is also measured with the projection traversal, a
    // configuration of its own ("exact/project"; its V is exact's, so its bias is 0 up to grazing
    // samples).
    bool project;
    pn_sampler sampler;
    pn_filter filters[PN_FILTER_LAST + 1]; // --filter: an axis of the matrix like spp (default none and interleaved)
    int filter_count;
    uint32_t tile_w, tile_h; // --tile: the interleaving tile and filter window of the filtered cells
    uint32_t reference_spp; // of the converged reference (PN_REFERENCE_SPP)
    uint32_t seed;          // --seed: the measured frames' (default 1; the reference has its own)
    const char *out_dir;
    const char *reference_dir; // --reference-cache: where converged references are cached (NULL: out_dir/reference)
    bool embree;
    double max_errors[MAX_BUDGETS]; // --max-error: check --quality auto against the matrix at each
    int max_error_count;
    uint32_t light_counts[MAX_LIST]; // --lights: frames of this many lights per configuration
    int light_count_count;
    bool edge_images;    // --edge-images: per filtered cell an EXR of V, V_raw, the reference and the edge classes
    bool work;           // --work: count each cell's work per pixel with the counting shader builds
    const char *gbuffer; // --shader shadow --gbuffer FILE.exr: P and N from a render's AOVs
    float *gb_p, *gb_n;  // its P (w = A) and N as RGBA planes
    uint32_t gb_width, gb_height;
    // --shard K/N: this run measures the cells whose index in one run's order is K-1 modulo N and
    // writes a partial file for --merge (0/0: no --shard).
    int shard_k, shard_n;
    bool points; // --points: the library's points in, V out beside the renderer (bench_points.c) alone
    // --sequence orbit,light,object,walk: instead of the matrix, frames in motion with the temporal
    // history beside the same frames without it (bench_sequence.c): which kinds, how many frames,
    // how far a frame goes (degrees; object and walk: percent of a radius), the history's length
    // (--history, frames).
    bool sequences[PN_BENCH_SEQUENCES]; // orbit, light, object, walk (bench_sequence.c)
    uint32_t seq_frames, seq_history;
    float seq_step;
} bench_opts;

// One cell of the matrix.
typedef struct bench_row {
    char scene[64]; // the view's name
    uint32_t width, height, spp;
    uint32_t spp_min;  // adaptive samples (spp_min:spp), 0 for uniform
    double mean_rays;  // the rays a covered pixel took on average (spp for uniform cells)
    // Adaptive cells: the share of covered pixels whose unfiltered V is further from the converged
    // reference than twice its estimated standard error (shadow.V_stderr): the estimate's honesty,
    // about 5% for a normal error; -1 for uniform cells.
    double beyond_2se;
    pn_shadow_mode mode;
    int n, d;
    bool per_object;         // the tree as per-object trees (--tree-kinds object)
    bool project;            // exact with the projection traversal (--traversal ...,project)
    // Project cells (else -1): per covered pixel the mean triangles its walk projected, and the
    // share of covered pixels whose budget ran out (their samples left traced as rays).
    double projected, fallback;
    pn_filter filter;        // with interleaved, tile_w x tile_h tiles
    uint32_t tile_w, tile_h; // 0 without a filter
    uint32_t triangles;
    double build_ms, pool_mb;
    // What moving one object costs the configuration's acceleration structures: a rebuild of all of
    // them (build_ms), except with per-object trees, where it is the top level's rebuild and upload
    // (timed). Moving the vertices and their G-buffer upload is the same for every configuration.
    double move_ms;
    double gbuffer_ms, shadow_ms, filter_ms, shade_ms; // medians (filter_ms 0 without a filter)
    double shadow_min_ms, shadow_max_ms;          // spread
    // The cell's pipelines readied (pn_frame_times.compile_ms) over its frames, untimed and timed:
    // what a first frame costs beyond its passes' times (llvmpipe compiles at first use).
    double compile_ms;
    double rays_per_s;
    pn_error_metrics ref;  // against the converged reference: what the user sees (bias and noise)
    pn_error_metrics bias; // against exact with the same pixels and light samples: the mode's bias
    double vs_exact, vs_embree;                   // shadow time ratios (lower is faster)
    double embree_ms;                             // Embree on exact's rays at this spp (0: not run)
    pn_edge_leak edge; // with a filter: how its error grows next to edges of geometry (metrics.h)
} bench_row;

// What a cell costs: its shadow pass and, with a filter, the filter pass (the passes the filter
// trades against each other); the time-to-error table, the plots' front and --max-error use it.
static inline double pn_bench_row_ms(const bench_row *r) { return r->shadow_ms + r->filter_ms; }

// A configuration's name in tables and plots: the mode, "+filter" for a filtered cell,
// "+adaptive" for adaptive samples and "/objects" with per-object trees.
static inline const char *pn_bench_filter_suffix(pn_filter f)
{
    return f == PN_FILTER_NONE ? "" : f == PN_FILTER_INTERLEAVED ? "+filter" : "+penumbra";
}
static inline const char *pn_bench_kind_suffix(bool per_object) { return per_object ? "/objects" : ""; }
static inline const char *pn_bench_adaptive_suffix(uint32_t spp_min) { return spp_min ? "+adaptive" : ""; }
static inline const char *pn_bench_project_suffix(bool project) { return project ? "/project" : ""; }

// --max-error: what --quality auto picked for one view, size and budget, next to the matrix's front.
typedef struct bench_quality {
    char scene[64];
    uint32_t width, height;
    double budget;
    pn_shadow_mode mode;     // the pick
    int n, d;
    uint32_t spp, spp_min;   // spp_min: adaptive samples spp_min:spp at choice.pixel_error, 0: uniform
    pn_filter filter;        // none or penumbra
    double pilot_mae;        // its pilot's estimate of the reference error
    pn_error_metrics ref;    // the pick rendered at full size, against the converged reference
    double shadow_ms;        // the pick's shadow pass at full size (and its filter pass, filtered)
    double choose_ms;        // the pilots' wall time
    pn_quality_choice choice; // all of --quality auto's pilots
    bool has_best;           // the matrix has a cell within the budget:
    pn_shadow_mode best_mode; // the fastest such cell
    int best_n, best_d;
    uint32_t best_spp, best_spp_min; // best_spp_min: an adaptive cell at the bench's --pixel-error
    pn_filter best_filter;
    double best_ms, best_mae; // best_ms: its shadow and filter passes
    // The pick and that cell timed in alternation at full size, the least of several frames each
    // (both the pick's cell time when it is that cell): the ratio the bench reports as vs_front.
    double pair_pick_ms, pair_front_ms;
} bench_quality;

// --lights: one configuration's frame with `lights` lights over one tree built for them.
typedef struct bench_light_row {
    char scene[64];
    uint32_t width, height, spp;
    pn_shadow_mode mode;
    int n, d;
    pn_filter filter;
    uint32_t lights;
    pn_split split;           // how the pixel's rays are shared among the lights
    double build_ms, pool_mb; // the tree (and BVH) for the set of lights
    uint32_t culled;          // triangles the tree leaves out for the set
    double frame_ms;          // median of G-buffer + shadow + filter + shading passes
    double shadow_ms, shade_ms;
    double vs_one; // frame_ms over the same configuration's with the view's one light (0: not measured)
    // frame_ms over the sum of the frames of each light of the set alone (same set-up, timed in the
    // same run): below 1 where sharing the G-buffer and the tree pays; "k lights cost at most k
    // times one light" means at most 1 here, whatever each light costs.
    double vs_sum;
    // The radiance's error against the set's converged reference (exact, --reference-spp rays per
    // light, another seed, even split), over the covered pixels, r + g + b per pixel, relative to
    // the reference's mean: MAE and RMSE. has_error false with --gbuffer (no albedo, no radiance).
    bool has_error;
    double mae_rel, rmse_rel;
} bench_light_row;

// Whether this run measures the cell of that index (every cell without --shard).
static inline bool pn_bench_owns(const bench_opts *o, int index)
{
    return o->shard_n <= 1 || index % o->shard_n == o->shard_k - 1;
}

// Of the cells 0 .. total-1, those this run measures.
static inline int pn_bench_share(const bench_opts *o, int total)
{
    if (o->shard_n <= 1)
        return total;
    return total >= o->shard_k ? (total - o->shard_k) / o->shard_n + 1 : 0;
}

// Where the run is in the matrix: cells are numbered in the order one unsharded run visits them
// (bench_matrix.c), and --shard keeps its share of them; the progress lines' counts and clock.
typedef struct bench_cells {
    int next;         // the index of the next cell of the matrix
    int total;        // the cells of the run: an estimate until every view is loaded
    int mine, done;   // of them, those this run measures (its shard's share), and those measured
    int *skipped;     // this run's cells whose configuration could not be set up (indices)
    int skip_count, skip_cap;
    uint64_t t0;      // when the first cell started
} bench_cells;

typedef struct bench_rows {
    bench_row *rows;
    int count, cap;
    bench_quality *quality;
    int quality_count, quality_cap;
    bench_light_row *lights;
    int light_count, light_cap;
    int *index; // per row its cell's index in one run's order (bench_cells.next); rows.count of them
    int index_cap;
    bench_cells cells;
} bench_rows;

// What bench.json says of the machine: filled from the device (pn_bench_context_get) or read back
// from a shard's partial file.
typedef struct bench_context {
    char device[256], driver[256], driver_info[256], cpu[256];
    uint32_t driver_version, api_version, threads;
} bench_context;

// ---------------------------------------------------------------------------------------------
// Options (bench_opts.c)

// Parses the command line into *o (defaults filled in; --quick applied): PN_EXIT_OK, -1 after
// --help, or an exit code.
int pn_bench_parse(int argc, char **argv, bench_opts *o);

// Reads o->gbuffer's P, A and N layers into o->gb_p and o->gb_n and sets the only size to the EXR's.
pn_result pn_bench_load_gbuffer(bench_opts *o);

// ---------------------------------------------------------------------------------------------
// The matrix (bench_matrix.c)


// The cells the matrix has for the view (scene NULL: before it is loaded, an upper bound that
// assumes every mode takes it).
int pn_bench_view_cells(const bench_opts *o, const pn_gpu_device *dev, const pn_scene *scene);

// One view's matrix: appends (and prints) a row per cell of this run's share (all without
// --shard), numbering them in rows->cells; rtc may be NULL (no CPU peer). An exit code.
int pn_bench_view(const bench_opts *o, pn_gpu_device *dev, pn_embree *rtc, const bench_view *view,
                  bench_rows *rows);

// What one view's matrix shares with --lights (bench_matrix.c, bench_lights.c).
// One configuration (a mode and tree) with every filter at every spp of the matrix over one set-up:
// a row per filter and spp with both errors. v_exact holds exact's V per filter and spp (the bias
// reference: exact with the same samples and the same filter), which exact itself stores there.
// exact_ms per filter and spp, embree_ms per spp (0: no peer).
typedef struct bench_group {
    const bench_opts *o;
    pn_gpu_device *dev;
    const pn_scene *scene;
    const pn_camera *cam;
    const pn_light *light;
    bench_row base;
    pn_renderer_desc frame;
    const float *v_conv;
    const uint8_t *mask;
    uint64_t covered;
    float *v_exact;
    double exact_ms[2 * MAX_LIST], embree_ms[MAX_LIST];
    pn_embree_scene *rtc; // traces exact's rays
    double move_ms;             // the configuration's (bench_row.move_ms)
} bench_group;

// ---------------------------------------------------------------------------------------------
// Timed frames and set-ups (bench_frames.c)

// Renders warm-up and timed frames of `lights`; fills the timing fields of `row` and leaves the
// last frame's images in the renderer.
pn_result pn_bench_time_frames(const bench_opts *o, pn_renderer *r, const pn_camera *cam, const pn_light *lights,
                               uint32_t light_count, bench_row *row);
// Appends the `size` bytes at `item` to the array *items of *count elements, doubling its capacity
// *cap when full (from 16). False when out of memory; the array is then unchanged.
bool pn_bench_append(void **items, int *count, int *cap, const void *item, size_t size);
// " LS(n,d)" (with " per object"), or "" for a mode without a tree.
void pn_bench_tree_label(char *out, size_t n, int tn, int td, bool per_object);
// Sets up one configuration of the matrix at full size for timing beside another.
pn_result pn_bench_setup_config(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                                const pn_renderer_desc *frame, pn_shadow_mode mode, int n, int d, uint32_t spp,
                                uint32_t spp_min, float pixel_error, pn_filter filter, pn_setup *s);

// ---------------------------------------------------------------------------------------------
// Several lights (bench_lights.c)

// The view's light turned about the vertical through `centre` in k even steps, light i with 2^-i
// of the first's radiance, together the one light's.
void pn_bench_light_set(const pn_light *light, const float centre[3], uint32_t k, pn_light *out);
// The set's converged reference radiance (rgba per pixel) into `out`.
pn_result pn_bench_lights_reference(const bench_group *g, const pn_light *set, uint32_t k, float *out);
// --lights rows of one configuration (refs[li]: light count li's reference, or NULL). An exit code.
int pn_bench_run_lights(const bench_group *g, const float centre[3], pn_shadow_mode mode, int tn, int td,
                        float *const *refs, bench_rows *rows);

// ---------------------------------------------------------------------------------------------
// --max-error (bench_quality.c)

// --quality auto against the matrix at one budget (rows from first_row are the group's). An exit code.
int pn_bench_check_quality(const bench_opts *o, pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                           const pn_light *light, const pn_renderer_desc *frame, const float *v_conv,
                           const uint8_t *mask, double budget, bench_rows *rows, int first_row);

// ---------------------------------------------------------------------------------------------
// --points (bench_points.c): per view, size, spp and tracing mode, the library's penumbra_visibility
// over the view's covered pixels beside the renderer's shadow pass; points.csv. An exit code.
int pn_bench_points(const bench_opts *o, pn_gpu_device *dev);

// ---------------------------------------------------------------------------------------------
// --sequence (bench_sequence.c): per view, size, sequence kind, tracing mode, filter and uniform
// spp, the frames of the sequence with the temporal history, without it and at once with the
// history's samples, each against its own converged reference; sequence.csv and seq_*.png. An
// exit code.
int pn_bench_sequences(const bench_opts *o, pn_gpu_device *dev);

// ---------------------------------------------------------------------------------------------
// Views (bench_views.c)

// Where the standard views' meshes are: $PN_ASSETS, else ../shared/assets.
const char *pn_bench_assets_dir(void);
// The standard view of that name, or NULL; pn_bench_view_spec_at(i) for i = 0.. until NULL.
const pn_bench_view_spec *pn_bench_view_spec_find(const char *name);
const pn_bench_view_spec *pn_bench_view_spec_at(int i);
// Fills *v with a standard view; false when its mesh is not in the assets folder.
bool pn_bench_view_standard(bench_view *v, const pn_bench_view_spec *spec);
// Fills *v with a scene file (or builtin:NAME) under render's default framing.
void pn_bench_view_scene(bench_view *v, const char *source);
// Loads the view's scene, places camera and light, adds the ground: pn_render_prepare's contract.
int pn_bench_view_prepare(const bench_view *v, pn_prepared_scene *out);

// ---------------------------------------------------------------------------------------------
// The converged reference (bench_reference.c)

// Exact at o->reference_spp stratified samples with PN_REFERENCE_SEED, from the cache under
// o->reference_dir (default o->out_dir/reference) or rendered (and cached): its V and coverage mask (w*h each).
pn_result pn_bench_reference(const bench_opts *o, pn_gpu_device *dev, const pn_scene *scene, const char *view,
                             const pn_camera *cam, const pn_light *light, uint32_t w, uint32_t h, float *v,
                             uint8_t *mask);

// ---------------------------------------------------------------------------------------------
// The CPU peer: Embree 3 (bench_peer.c)

// Traces the rays of an exact frame's ray dump (pixels x spp) on all cores, o->warmup + o->repeat
// times; prints the figures on stderr and returns the median time of the timed runs in ms.
double pn_bench_embree_time(const bench_opts *o, const pn_embree_scene *s, const float *dump, uint64_t px,
                            uint32_t spp);

// ---------------------------------------------------------------------------------------------
// Reports (bench_report.c)

// Prints the console table's header line.
void pn_bench_print_header(void);

// Prints one row of the console table (and flushes stdout).
void pn_bench_print_row(const bench_row *r);

// Prints one --lights row on the console.
void pn_bench_print_light_row(const bench_light_row *r);

// Opens dir/name for writing under a temporary name (path and tmp: 4096 bytes each); NULL, logged,
// on failure. pn_bench_close_out closes it and renames it into place (false, logged, on failure).
FILE *pn_bench_open_out(const char *dir, const char *name, char *path, char *tmp);
bool pn_bench_close_out(FILE *f, const char *path, const char *tmp);

// The end of the group (one view and size: all its modes, trees and spp) whose first row is
// `first`: the matrix appends each group's rows together, so a group is a run of rows.
int pn_bench_group_end(const bench_rows *rows, int first);

// Writes dir/bench.csv: one line per row. False (logged) on failure.
bool pn_bench_write_csv(const char *dir, const bench_rows *rows);

// Writes dir/bench.json: the device, CPU and options, then the rows. False (logged) on failure.
bool pn_bench_write_json(const char *dir, const bench_opts *o, const bench_context *ctx, const bench_rows *rows);

// The device's and machine's names for bench.json.
void pn_bench_context_get(const pn_gpu_device *dev, bench_context *ctx);

// (bench_plot.c) Writes per view and size a gnuplot .dat and .gp (reference error vs shadow time, log-log: a curve
// per mode and tree through its spp points, the Pareto front, Embree's time on exact's rays) and
// draws them as PNG with gnuplot when present. False (logged) on failure.
bool pn_bench_write_plots(const char *dir, const bench_rows *rows);

// The error levels of the time-to-error table.
extern const double pn_bench_error_levels[];
enum { PN_BENCH_ERROR_LEVELS = 4 };

// Prints and writes dir/time_to_error.md: per view and size, for each mode the fastest cell whose
// reference MAE reaches each level, its time relative to exact's, and Embree's on the same rays as
// exact's; then Embree run plain (the rays of unfiltered exact at the least spp reaching the level)
// and the fastest cell of any mode, spp and filter over that time. False (logged) on failure.
bool pn_bench_write_time_to_error(const char *dir, const bench_rows *rows);

// ---------------------------------------------------------------------------------------------
// Shards (bench_shard.c)

// The partial file of a --shard run, in its --out folder.
#define PN_BENCH_PARTIAL "bench_partial.txt"

// Writes dir/bench_partial.txt: the options that shape the results, the context, every field of
// every row with its cell index, and the cells skipped. False (logged) on failure.
bool pn_bench_write_partial(const char *dir, const bench_opts *o, const bench_context *ctx, const bench_rows *rows);

// penumbra bench --merge DIR... [--out DIR]: the shards' partial files into one run's reports. An
// exit code.
int pn_bench_merge(int argc, char **argv);
