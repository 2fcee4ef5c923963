// penumbra bench's reports: the console table, bench.csv, bench.json and time_to_error.md (the
// plots are bench_plot.c's).
//
// Over 500 lines because the JSON writer names every field of a cell, a --max-error check
// and a --lights row (175 lines).
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/bench/bench.h"
#include "core/log.h"
#include "core/parallel.h"
#include "io/file.h"
#include "io/json.h"

// The console table: this header, then one pn_bench_print_row per cell as it is measured. Errors:
// "ref" against the converged reference, "bias" against exact with the same samples.
void pn_bench_print_header(void)
{
    printf("%-16s %-9s %5s %-9s %-9s %-6s %8s %8s %7s %9s [%7s %7s] %8s %7s %8s %7s %8s %6s %6s %7s %6s %6s\n", "view",
           "size", "spp", "mode", "tree", "filter", "build ms", "move ms", "MB", "shadow ms", "min", "max", "filter ms", "Mray/s", "ref MAE",
           "ref p99", "bias MAE", "bias mx", "/exact", "/embree", "edge%", "away%");
}

// A row's tree in the console: "N,d", "N,d obj" for per-object trees, "-" without a tree.
static void tree_cell(char *out, size_t n, int tn, int td, bool per_object)
{
    if (tn)
        snprintf(out, n, "%d,%d%s", tn, td, per_object ? " obj" : "");
    else
        snprintf(out, n, "-");
}

// A row's samples per pixel: "16", or "4:64" for adaptive samples.
static void spp_text(char *out, size_t n, const bench_row *r)
{
    if (r->spp_min)
        snprintf(out, n, "%u:%u", r->spp_min, r->spp);
    else
        snprintf(out, n, "%u", r->spp);
}

void pn_bench_print_row(const bench_row *r)
{
    char tree[16], filter[16] = "-", edge[16] = "-", away[16] = "-", spp[24];
    spp_text(spp, sizeof spp, r);
    tree_cell(tree, sizeof tree, r->n, r->d, r->per_object);
    if (r->project) // exact's configuration by projection: no tree, its column says how it walks
        snprintf(tree, sizeof tree, "project");
    if (r->filter != PN_FILTER_NONE) {
        snprintf(filter, sizeof filter, "%ux%u", r->tile_w, r->tile_h);
        snprintf(edge, sizeof edge, "%.2f", 100.0 * r->edge.share);
        snprintf(away, sizeof away, "%.2f", 100.0 * r->edge.away_share);
    }
    printf("%-16.16s %4ux%-4u %5s %-9s %-9s %-6s %8.1f %8.2f %7.1f %9.1f [%7.1f %7.1f] %8.2f %7.2f %8.4f %7.4f %8.4f %6.3f "
           "%6.2f %7.2f %6s %6s\n",
           r->scene, r->width, r->height, spp, MODE_NAME(r->mode), tree, filter, r->build_ms, r->move_ms, r->pool_mb,
           r->shadow_ms, r->shadow_min_ms, r->shadow_max_ms, r->filter_ms, r->rays_per_s / 1e6, r->ref.mae, r->ref.p99,
           r->bias.mae, r->bias.max, r->vs_exact, r->vs_embree, edge, away);
    fflush(stdout);
}

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

FILE *pn_bench_open_out(const char *dir, const char *name, char *path, char *tmp)
{
    snprintf(path, 4096, "%s/%s", dir, name);
    if (pn_file_tmp_path(path, tmp, 4096) != PN_OK)
        return NULL;
    FILE *f = fopen(tmp, "w");
    if (!f)
        pn_error("%s: cannot write: %s", path, strerror(errno));
    return f;
}

bool pn_bench_close_out(FILE *f, const char *path, const char *tmp)
{
    bool ok = fclose(f) == 0;
    if (!ok) {
        pn_error("%s: write failed", path);
        pn_file_discard(tmp);
        return false;
    }
    return pn_file_commit(tmp, path) == PN_OK;
}

void pn_bench_print_light_row(const bench_light_row *r)
{
    char tree[16];
    tree_cell(tree, sizeof tree, r->n, r->d, false);
    char err[64] = "";
    if (r->has_error)
        snprintf(err, sizeof err, "; radiance error %.4f MAE, %.4f RMSE", r->mae_rel, r->rmse_rel);
    printf("lights: %-16.16s %4ux%-4u %4u spp %-9s %-5s %-11s %2u lights %-6s: frame %8.1f ms (shadow %8.1f, shade "
           "%6.1f) = %5.2fx one light's, %4.2fx its lights' frames alone; tree/BVH %7.1f MB built in %7.1f ms, %u "
           "triangles left out%s\n",
           r->scene, r->width, r->height, r->spp, MODE_NAME(r->mode), tree, pn_filter_names[r->filter], r->lights,
           pn_split_names[r->split], r->frame_ms, r->shadow_ms, r->shade_ms, r->vs_one, r->vs_sum, r->pool_mb,
           r->build_ms, r->culled, err);
    fflush(stdout);
}

bool pn_bench_write_csv(const char *dir, const bench_rows *rows)
{
    char path[4096], tmp[4096];
    FILE *f = pn_bench_open_out(dir, "bench.csv", path, tmp);
    if (!f)
        return false;
    fprintf(f, "view,width,height,spp,mode,n,d,triangles,build_ms,pool_mb,gbuffer_ms,shadow_ms,shadow_min_ms,"
               "shadow_max_ms,shade_ms,rays_per_s,ref_mae,ref_rmse,ref_p99,ref_max,bias_mae,bias_rmse,bias_p99,"
               "bias_max,vs_exact,vs_embree,embree_ms,filter,tile_w,tile_h,filter_ms,edge_band,edge_grown,edge_share,"
               "away_pixels,away_grown,away_share,tree_kind,move_ms,spp_min,mean_rays,beyond_2se,traversal,projected,"
               "fallback,compile_ms\n");
    for (int i = 0; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        fprintf(f, "%s,%u,%u,%u,%s,%d,%d,%u,%.3f,%.3f,%.4f,%.4f,%.4f,%.4f,%.4f,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,"
                   "%.6g,%.4f,%.4f,%.4f,%s,%u,%u,%.4f,%zu,%zu,%.6g,%zu,%zu,%.6g,%s,%.4f,%u,%.4f,%.6g,%s,%.6g,%.6g,%.3f\n",
                r->scene, r->width, r->height, r->spp, MODE_NAME(r->mode), r->n, r->d, r->triangles, r->build_ms,
                r->pool_mb, r->gbuffer_ms, r->shadow_ms, r->shadow_min_ms, r->shadow_max_ms, r->shade_ms, r->rays_per_s,
                r->ref.mae, r->ref.rmse, r->ref.p99, r->ref.max, r->bias.mae, r->bias.rmse, r->bias.p99, r->bias.max,
                r->vs_exact, r->vs_embree, r->embree_ms, pn_filter_names[r->filter], r->tile_w, r->tile_h, r->filter_ms,
                r->edge.band, r->edge.grown, r->edge.share, r->edge.away, r->edge.away_grown, r->edge.away_share,
                r->n ? pn_bench_tree_kind_names[r->per_object] : "", r->move_ms, r->spp_min, r->mean_rays, r->beyond_2se,
                r->project ? "project" : "", r->projected, r->fallback, r->compile_ms);
    }
    return pn_bench_close_out(f, path, tmp);
}

static void json_metrics(FILE *f, const char *name, const pn_error_metrics *m)
{
    fprintf(f, "\"%s\": {\"mae\": %.6g, \"rmse\": %.6g, \"p99\": %.6g, \"max\": %.6g}", name, m->mae, m->rmse, m->p99,
            m->max);
}

static void json_tree(FILE *f, int n, int d)
{
    if (n)
        fprintf(f, "[%d, %d]", n, d);
    else
        fprintf(f, "null");
}

// "scene" or "object" for a row with a tree, null without one.
static void json_kind(FILE *f, int n, bool per_object)
{
    if (n)
        fprintf(f, "\"%s\"", pn_bench_tree_kind_names[per_object]);
    else
        fprintf(f, "null");
}

// The same view and size: one group of the matrix (all its modes, trees and spp).
static bool same_group(const bench_row *a, const bench_row *b)
{
    return !strcmp(a->scene, b->scene) && a->width == b->width && a->height == b->height;
}

const double pn_bench_error_levels[PN_BENCH_ERROR_LEVELS] = {0.05, 0.02, 0.01, 0.005};

// The end of the group whose first row is `first`: the matrix appends each group's rows together
// (bench_matrix.c), so a group is a run of consecutive rows.
int pn_bench_group_end(const bench_rows *rows, int first)
{
    int end = first + 1;
    while (end < rows->count && same_group(&rows->rows[end], &rows->rows[first]))
        end++;
    return end;
}

// A column of the time-to-error table: a mode with or without the filter, over the scene-wide tree
// or per-object trees, with uniform or adaptive samples.
typedef struct mode_filter {
    pn_shadow_mode mode;
    pn_filter filter;
    bool per_object;
    bool adaptive;
    bool project;
} mode_filter;

static bool in_column(const bench_row *r, mode_filter c)
{
    return r->mode == c.mode && r->filter == c.filter && r->per_object == c.per_object &&
           (r->spp_min != 0) == c.adaptive && r->project == c.project;
}

// The fastest row of rows [first, end) of column c whose reference MAE is at most `level` (a
// filtered cell's time includes its filter pass); NULL when none reaches it.
static const bench_row *fastest_within(const bench_rows *rows, int first, int end, mode_filter c, double level)
{
    const bench_row *best = NULL;
    for (int j = first; j < end; j++) {
        const bench_row *r = &rows->rows[j];
        if (in_column(r, c) && r->ref.mae <= level &&
            (!best || pn_bench_row_ms(r) < pn_bench_row_ms(best)))
            best = r;
    }
    return best;
}

// Per mode: two tree kinds (or for exact, its walk by projection), every filter, uniform and
// adaptive samples (group_modes).
enum { MAX_COLUMNS = 2 * (PN_FILTER_LAST + 1) * 2 * PN_SHADOW_MODE_COUNT };

// The columns present in rows [first, end), in the order of the mode table, each mode over the
// scene-wide tree first, unfiltered first, uniform samples first.
static int group_modes(const bench_rows *rows, int first, int end, mode_filter *out)
{
    int n = 0;
    for (int m = 0; m < PN_SHADOW_MODE_COUNT; m++)
        for (int k = 0; k < 2; k++)
            for (int f = PN_FILTER_NONE; f <= PN_FILTER_LAST; f++)
                for (int a = 0; a < 2; a++) {
                    // k = 1: per-object trees, or exact by projection (a mode has one or the other)
                    bool project = k == 1 && m == PN_SHADOW_REFERENCE;
                    mode_filter c = {(pn_shadow_mode)m, (pn_filter)f, k == 1 && !project, a == 1, project};
                    for (int j = first; j < end; j++)
                        if (in_column(&rows->rows[j], c)) {
                            out[n++] = c;
                            break;
                        }
                }
    return n;
}

static const mode_filter EXACT = {PN_SHADOW_REFERENCE, PN_FILTER_NONE, false, false};

// Embree as a user comparing with it would run it: the rays of unfiltered exact (a filter is not
// Embree's to run) at the least spp whose reference MAE is at most `level`, not at the spp whose
// exact cell timed fastest, which the machine's noise may make a larger one. That cell of rows
// [first, end), or NULL when none reaches the level or Embree did not trace its rays (--no-embree).
static const bench_row *embree_plain(const bench_rows *rows, int first, int end, double level)
{
    const bench_row *least = NULL;
    for (int j = first; j < end; j++) {
        const bench_row *r = &rows->rows[j];
        if (in_column(r, EXACT) && r->ref.mae <= level && (!least || r->spp < least->spp))
            least = r;
    }
    return least && least->embree_ms > 0 ? least : NULL;
}

// The fastest cell of rows [first, end) of any mode, tree, spp and filter whose reference MAE is at
// most `level` (its time as the table's: with the filter pass when filtered); NULL when none.
static const bench_row *fastest_any(const bench_rows *rows, int first, int end, double level)
{
    const bench_row *best = NULL;
    for (int j = first; j < end; j++) {
        const bench_row *r = &rows->rows[j];
        if (r->ref.mae <= level && (!best || pn_bench_row_ms(r) < pn_bench_row_ms(best)))
            best = r;
    }
    return best;
}

// A time-to-error entry's cell in bench.json, its object left open for the caller's fields.
static void json_tte_cell(FILE *f, const bench_row *r)
{
    fprintf(f, "{\"mode\": \"%s\", \"filter\": \"%s\", \"tree\": ", MODE_NAME(r->mode), pn_filter_names[r->filter]);
    json_tree(f, r->n, r->d);
    fprintf(f, ", \"tree_kind\": ");
    json_kind(f, r->n, r->per_object);
    fprintf(f, ", \"project\": %s", r->project ? "true" : "false");
    fprintf(f, ", \"spp\": %u, \"spp_min\": %u, \"mean_rays\": %.4f, \"shadow_ms\": %.4f, \"cell_ms\": %.4f, \"mae\": %.6g",
            r->spp, r->spp_min, r->mean_rays, r->shadow_ms, pn_bench_row_ms(r), r->ref.mae);
}

void pn_bench_context_get(const pn_gpu_device *dev, bench_context *ctx)
{
    *ctx = (bench_context){.driver_version = dev->props.driverVersion, .api_version = dev->props.apiVersion,
                           .threads = pn_parallel_threads()};
    snprintf(ctx->device, sizeof ctx->device, "%s", dev->props.deviceName);
    snprintf(ctx->driver, sizeof ctx->driver, "%s", dev->driver.driverName);
    snprintf(ctx->driver_info, sizeof ctx->driver_info, "%s", dev->driver.driverInfo);
    cpu_name(ctx->cpu, sizeof ctx->cpu);
}

bool pn_bench_write_json(const char *dir, const bench_opts *o, const bench_context *ctx, const bench_rows *rows)
{
    char path[4096], tmp[4096];
    FILE *f = pn_bench_open_out(dir, "bench.json", path, tmp);
    if (!f)
        return false;
    fprintf(f, "{\"context\": {\"device\": ");
    pn_json_string(f, ctx->device);
    // The driver by name and version (e.g. llvmpipe, "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"), so that
    // figures from two drivers are never mixed.
    fprintf(f, ", \"driver\": ");
    pn_json_string(f, ctx->driver);
    fprintf(f, ", \"driver_info\": ");
    pn_json_string(f, ctx->driver_info);
    fprintf(f, ", \"driver_version\": %u, \"api_version\": \"%u.%u.%u\", \"cpu\": ", ctx->driver_version,
            VK_API_VERSION_MAJOR(ctx->api_version), VK_API_VERSION_MINOR(ctx->api_version),
            VK_API_VERSION_PATCH(ctx->api_version));
    pn_json_string(f, ctx->cpu);
    fprintf(f, ", \"threads\": %u, \"repeat\": %d, \"warmup\": %d, \"traversal\": \"%s\", \"sampler\": \"%s\", "
               "\"seed\": %u, \"reference\": {\"mode\": \"%s\", \"spp\": %u, \"sampler\": \"stratified\", "
               "\"seed\": %u}, ",
            ctx->threads, o->repeat, o->warmup, pn_traversal_names[o->traversal],
            pn_sampler_names[o->sampler], o->seed, MODE_NAME(PN_SHADOW_REFERENCE), o->reference_spp, PN_REFERENCE_SEED);
    fprintf(f, "\"filters\": [");
    for (int i = 0; i < o->filter_count; i++)
        fprintf(f, "%s\"%s\"", i ? ", " : "", pn_filter_names[o->filters[i]]);
    fprintf(f, "], \"tile\": [%u, %u], \"views\": [", o->tile_w, o->tile_h);
    for (int i = 0; i < o->view_count; i++) {
        fprintf(f, "%s{\"name\": ", i ? ", " : "");
        pn_json_string(f, o->views[i].name);
        fprintf(f, ", \"source\": ");
        pn_json_string(f, o->views[i].source);
        fprintf(f, ", \"standard\": %s}", o->views[i].spec ? "true" : "false");
    }
    fprintf(f, "]}, \"results\": [\n");
    for (int i = 0; i < rows->count; i++) {
        const bench_row *r = &rows->rows[i];
        fprintf(f, "  {\"scene\": ");
        pn_json_string(f, r->scene);
        fprintf(f, ", \"width\": %u, \"height\": %u, \"spp\": %u, \"spp_min\": %u, \"mean_rays\": %.4f, ", r->width,
                r->height, r->spp, r->spp_min, r->mean_rays);
        if (r->beyond_2se >= 0)
            fprintf(f, "\"beyond_2se\": %.6g, ", r->beyond_2se);
        else
            fprintf(f, "\"beyond_2se\": null, ");
        fprintf(f, "\"mode\": \"%s\", \"tree\": ", MODE_NAME(r->mode));
        json_tree(f, r->n, r->d);
        fprintf(f, ", \"filter\": \"%s\", \"tile\": ", pn_filter_names[r->filter]);
        if (r->filter != PN_FILTER_NONE)
            fprintf(f, "[%u, %u]", r->tile_w, r->tile_h);
        else
            fprintf(f, "null");
        fprintf(f, ", \"tree_kind\": ");
        json_kind(f, r->n, r->per_object);
        fprintf(f, ", \"move_ms\": %.4f", r->move_ms);
        // The projection traversal's cells: its triangles per pixel and fallback share.
        if (r->project)
            fprintf(f, ", \"traversal\": \"project\", \"projected\": %.4f, \"fallback\": %.6g", r->projected, r->fallback);
        else
            fprintf(f, ", \"traversal\": null, \"projected\": null, \"fallback\": null");
        fprintf(f, ", \"triangles\": %u, \"build_ms\": %.3f, \"pool_mb\": %.3f, \"gpu_ms\": {\"gbuffer\": %.4f, "
                   "\"shadow\": %.4f, \"shadow_min\": %.4f, \"shadow_max\": %.4f, \"filter\": %.4f, \"shade\": %.4f}, "
                   "\"cell_ms\": %.4f, \"compile_ms\": %.3f, \"shadow_rays_per_s\": %.6g, ",
                r->triangles, r->build_ms, r->pool_mb, r->gbuffer_ms, r->shadow_ms, r->shadow_min_ms, r->shadow_max_ms,
                r->filter_ms, r->shade_ms, pn_bench_row_ms(r), r->compile_ms, r->rays_per_s);
        if (r->filter != PN_FILTER_NONE)
            fprintf(f, "\"edge_leak\": {\"band\": %zu, \"grown\": %zu, \"share\": %.6g, \"away\": %zu, "
                       "\"away_grown\": %zu, \"away_share\": %.6g}, ",
                    r->edge.band, r->edge.grown, r->edge.share, r->edge.away, r->edge.away_grown, r->edge.away_share);
        else
            fprintf(f, "\"edge_leak\": null, ");
        json_metrics(f, "reference", &r->ref);
        fprintf(f, ", ");
        json_metrics(f, "bias", &r->bias);
        fprintf(f, ", \"vs_exact\": %.4f, \"vs_embree\": %.4f, \"embree_ms\": %.4f}%s\n", r->vs_exact, r->vs_embree,
                r->embree_ms, i + 1 < rows->count ? "," : "");
    }
    fprintf(f, "], \"time_to_error\": [");
    const char *sep = "\n";
    for (int first = 0, end; first < rows->count; first = end) {
        end = pn_bench_group_end(rows, first);
        const bench_row *g0 = &rows->rows[first];
        mode_filter modes[MAX_COLUMNS];
        int nm = group_modes(rows, first, end, modes);
        for (int l = 0; l < PN_BENCH_ERROR_LEVELS; l++) {
            double level = pn_bench_error_levels[l];
            fprintf(f, "%s  {\"scene\": ", sep);
            sep = ",\n";
            pn_json_string(f, g0->scene);
            fprintf(f, ", \"width\": %u, \"height\": %u, \"level\": %g, \"modes\": [", g0->width, g0->height, level);
            const bench_row *ex = fastest_within(rows, first, end, EXACT, level);
            int k = 0;
            for (int m = 0; m < nm; m++) {
                const bench_row *r = fastest_within(rows, first, end, modes[m], level);
                if (!r)
                    continue;
                fprintf(f, "%s", k++ ? ", " : "");
                json_tte_cell(f, r);
                fprintf(f, ", \"vs_exact\": ");
                if (ex && ex->shadow_ms > 0)
                    fprintf(f, "%.4f}", pn_bench_row_ms(r) / ex->shadow_ms);
                else
                    fprintf(f, "null}");
            }
            fprintf(f, "], \"embree_ms\": ");
            if (ex && ex->embree_ms > 0)
                fprintf(f, "%.4f", ex->embree_ms);
            else
                fprintf(f, "null");
            // Embree run plain (embree_plain) and the fastest cell of all against it.
            const bench_row *plain = embree_plain(rows, first, end, level);
            const bench_row *best = fastest_any(rows, first, end, level);
            if (plain)
                fprintf(f, ", \"embree_plain_ms\": %.4f, \"embree_plain_spp\": %u", plain->embree_ms, plain->spp);
            else
                fprintf(f, ", \"embree_plain_ms\": null, \"embree_plain_spp\": null");
            fprintf(f, ", \"fastest\": ");
            if (best) {
                json_tte_cell(f, best);
                fprintf(f, "}");
            } else {
                fprintf(f, "null");
            }
            if (plain && best)
                fprintf(f, ", \"fastest_vs_embree_plain\": %.4f}", pn_bench_row_ms(best) / plain->embree_ms);
            else
                fprintf(f, ", \"fastest_vs_embree_plain\": null}");
        }
    }
    fprintf(f, "], \"lights\": [");
    for (int i = 0; i < rows->light_count; i++) {
        const bench_light_row *r = &rows->lights[i];
        fprintf(f, "%s\n  {\"scene\": ", i ? "," : "");
        pn_json_string(f, r->scene);
        fprintf(f, ", \"width\": %u, \"height\": %u, \"spp\": %u, \"mode\": \"%s\", \"filter\": \"%s\", \"tree\": ",
                r->width, r->height, r->spp, MODE_NAME(r->mode), pn_filter_names[r->filter]);
        json_tree(f, r->n, r->d);
        fprintf(f, ", \"lights\": %u, \"split\": \"%s\", \"frame_ms\": %.4f, \"shadow_ms\": %.4f, \"shade_ms\": %.4f, "
                   "\"vs_one\": %.4f, \"vs_sum\": %.4f, \"pool_mb\": %.4f, \"build_ms\": %.3f, \"culled\": %u, "
                   "\"radiance_error\": ",
                r->lights, pn_split_names[r->split], r->frame_ms, r->shadow_ms, r->shade_ms, r->vs_one, r->vs_sum,
                r->pool_mb, r->build_ms, r->culled);
        if (r->has_error)
            fprintf(f, "{\"mae_rel\": %.6f, \"rmse_rel\": %.6f}}", r->mae_rel, r->rmse_rel);
        else
            fprintf(f, "null}");
    }
    fprintf(f, "], \"quality\": [");
    for (int i = 0; i < rows->quality_count; i++) {
        const bench_quality *q = &rows->quality[i];
        fprintf(f, "%s\n  {\"scene\": ", i ? "," : "");
        pn_json_string(f, q->scene);
        fprintf(f, ", \"width\": %u, \"height\": %u, \"budget\": %g, \"pick\": {\"mode\": \"%s\", \"tree\": ", q->width,
                q->height, q->budget, MODE_NAME(q->mode));
        json_tree(f, q->n, q->d);
        fprintf(f, ", \"spp\": %u, \"spp_min\": %u, \"pixel_error\": %.9g, \"filter\": \"%s\", \"pilot_mae\": %.17g, \"shadow_ms\": %.4f, ",
                q->spp, q->spp_min, q->spp_min ? (double)q->choice.pixel_error : 0.0, pn_filter_names[q->filter],
                q->pilot_mae, q->shadow_ms);
        json_metrics(f, "reference", &q->ref);
        fprintf(f,
                "}, \"choose_ms\": %.1f, \"runoff\": %d, \"pilot\": [%u, %u], \"confirm\": [%u, %u], \"frame_sample\": [%u, %u], "
                "\"candidates\": %d, \"tried\": ",
                q->choose_ms, q->choice.runoff, q->choice.pilot_width, q->choice.pilot_height, q->choice.confirm_width,
                q->choice.confirm_height, q->choice.frame_sample_width, q->choice.frame_sample_height, q->choice.candidates);
        pn_quality_write_tried(f, &q->choice);
        fprintf(f, ", \"front\": ");
        if (q->has_best && q->best_ms > 0) {
            fprintf(f, "{\"mode\": \"%s\", \"tree\": ", MODE_NAME(q->best_mode));
            json_tree(f, q->best_n, q->best_d);
            fprintf(f, ", \"spp\": %u, \"spp_min\": %u, \"filter\": \"%s\", \"shadow_ms\": %.4f, \"mae\": %.6g}, \"side_by_side_ms\": [%.4f, %.4f], "
                       "\"vs_front\": %.4f}",
                    q->best_spp, q->best_spp_min, pn_filter_names[q->best_filter], q->best_ms, q->best_mae, q->pair_pick_ms, q->pair_front_ms,
                    q->pair_front_ms > 0 ? q->pair_pick_ms / q->pair_front_ms : 0.0);
        } else {
            fprintf(f, "null, \"vs_front\": null}");
        }
    }
    fprintf(f, "]}\n");
    return pn_bench_close_out(f, path, tmp);
}

// A cell in words, for the time-to-error table's fastest cell: "exact 8 spp filtered",
// "linespace LS(8,3) per object 4 spp".
static void cell_words(char *out, size_t n, const bench_row *r)
{
    char tree[48] = "";
    if (r->n)
        snprintf(tree, sizeof tree, " LS(%d,%d)%s", r->n, r->d, r->per_object ? " per object" : "");
    char spp[24];
    spp_text(spp, sizeof spp, r);
    if (r->project)
        snprintf(tree, sizeof tree, " by projection");
    snprintf(out, n, "%s%s %s spp%s", MODE_NAME(r->mode), tree, spp,
             r->filter == PN_FILTER_NONE ? "" : r->filter == PN_FILTER_INTERLEAVED ? " filtered" : " penumbra-filtered");
}

bool pn_bench_write_time_to_error(const char *dir, const bench_rows *rows)
{
    char path[4096], tmp[4096];
    FILE *f = pn_bench_open_out(dir, "time_to_error.md", path, tmp);
    if (!f)
        return false;
    for (int first = 0, end; first < rows->count; first = end) {
        end = pn_bench_group_end(rows, first);
        const bench_row *g0 = &rows->rows[first];
        mode_filter modes[MAX_COLUMNS];
        int nm = group_modes(rows, first, end, modes);
        for (int pass = 0; pass < 2; pass++) { // the file, then the console
            FILE *out = pass ? stdout : f;
            fprintf(out, "\n%s %ux%u (%u triangles): the fastest cell reaching each reference MAE, shadow pass ms "
                         "(+filter: shadow and filter passes) (configuration, x exact's time); Embree 3 plain: Embree on "
                         "the rays of unfiltered exact at the least spp reaching it, and the fastest cell over that time\n\n"
                         "| MAE <= |",
                    g0->scene, g0->width, g0->height, g0->triangles);
            for (int m = 0; m < nm; m++)
                fprintf(out, " %s%s%s%s%s |", MODE_NAME(modes[m].mode), pn_bench_project_suffix(modes[m].project),
                        pn_bench_filter_suffix(modes[m].filter), pn_bench_adaptive_suffix(modes[m].adaptive),
                        pn_bench_kind_suffix(modes[m].per_object));
            fprintf(out, " Embree 3, exact's rays | Embree 3 plain | fastest / Embree plain |\n|---|");
            for (int m = 0; m < nm + 3; m++)
                fprintf(out, "---|");
            fprintf(out, "\n");
            for (int l = 0; l < PN_BENCH_ERROR_LEVELS; l++) {
                double level = pn_bench_error_levels[l];
                const bench_row *ex = fastest_within(rows, first, end, EXACT, level);
                fprintf(out, "| %g |", level);
                for (int m = 0; m < nm; m++) {
                    const bench_row *r = fastest_within(rows, first, end, modes[m], level);
                    if (!r) {
                        fprintf(out, " - |");
                        continue;
                    }
                    char tree[32] = "";
                    if (r->n)
                        snprintf(tree, sizeof tree, "LS(%d,%d) ", r->n, r->d);
                    char spp[24];
                    spp_text(spp, sizeof spp, r);
                    fprintf(out, " %.1f (%s%s spp", pn_bench_row_ms(r), tree, spp);
                    if (r->spp_min)
                        fprintf(out, ", %.1f rays", r->mean_rays);
                    if (ex && ex->shadow_ms > 0)
                        fprintf(out, ", %.2fx", pn_bench_row_ms(r) / ex->shadow_ms);
                    fprintf(out, ") |");
                }
                if (ex && ex->embree_ms > 0 && ex->shadow_ms > 0)
                    fprintf(out, " %.1f (%u spp, %.2fx) |", ex->embree_ms, ex->spp, ex->embree_ms / ex->shadow_ms);
                else
                    fprintf(out, " - |");
                // Embree run plain, and the fastest cell of any mode, spp and filter against it
                // (below 1: penumbra is faster).
                const bench_row *plain = embree_plain(rows, first, end, level);
                const bench_row *best = fastest_any(rows, first, end, level);
                if (plain && best) {
                    char words[128];
                    cell_words(words, sizeof words, best);
                    fprintf(out, " %.1f (%u spp) | %.2fx (%s) |\n", plain->embree_ms, plain->spp,
                            pn_bench_row_ms(best) / plain->embree_ms, words);
                } else {
                    fprintf(out, " - | - |\n");
                }
            }
        }
    }
    return pn_bench_close_out(f, path, tmp);
}
