// penumbra bench's reports: the console table, bench.csv, bench.json, and per scene, size and spp
// a gnuplot plot of error against shadow time with the Pareto front.
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/bench.h"
#include "core/log.h"
#include "core/parallel.h"
#include "io/file.h"
#include "io/json.h"

// The console table: this header, then one pn_bench_print_row per cell as it is measured.
void pn_bench_print_header(void)
{
    printf("%-28s %-9s %4s %-9s %-5s %8s %7s %9s [%7s %7s] %7s %8s %7s %6s %6s %6s\n", "scene", "size", "spp", "mode",
           "tree", "build ms", "MB", "shadow ms", "min", "max", "Mray/s", "MAE", "p99", "max", "/exact", "/embree");
}

void pn_bench_print_row(const bench_row *r)
{
    char tree[16] = "-";
    if (r->n)
        snprintf(tree, sizeof tree, "%d,%d", r->n, r->d);
    printf("%-28.28s %4ux%-4u %4u %-9s %-5s %8.1f %7.1f %9.1f [%7.1f %7.1f] %7.2f %8.4f %7.4f %6.3f %6.2f %6.2f\n",
           r->scene, r->width, r->height, r->spp, MODE_NAME(r->mode), tree, r->build_ms, r->pool_mb, r->shadow_ms,
           r->shadow_min_ms, r->shadow_max_ms, r->rays_per_s / 1e6, r->err.mae, r->err.p99, r->err.max, r->vs_exact,
           r->vs_embree);
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

bool pn_bench_write_csv(const char *dir, const bench_rows *rows)
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
                r->scene, r->width, r->height, r->spp, MODE_NAME(r->mode), r->n, r->d, r->triangles, r->build_ms,
                r->pool_mb, r->gbuffer_ms, r->shadow_ms, r->shadow_min_ms, r->shadow_max_ms, r->shade_ms, r->rays_per_s,
                r->err.mae, r->err.rmse, r->err.p99, r->err.max, r->err.over005, r->err.over02, r->vs_exact, r->vs_embree);
    }
    return close_out(f, path, tmp);
}

bool pn_bench_write_json(const char *dir, const bench_opts *o, const pn_gpu_device *dev, const bench_rows *rows)
{
    char path[4096], tmp[4096], cpu[256];
    FILE *f = open_out(dir, "bench.json", path, tmp);
    if (!f)
        return false;
    cpu_name(cpu, sizeof cpu);
    fprintf(f, "{\"context\": {\"device\": ");
    pn_json_string(f, dev->props.deviceName);
    // The driver by name and version (e.g. llvmpipe, "Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"), so that
    // figures from two drivers are never mixed.
    fprintf(f, ", \"driver\": ");
    pn_json_string(f, dev->driver.driverName);
    fprintf(f, ", \"driver_info\": ");
    pn_json_string(f, dev->driver.driverInfo);
    fprintf(f, ", \"driver_version\": %u, \"api_version\": \"%u.%u.%u\", \"cpu\": ", dev->props.driverVersion,
            VK_API_VERSION_MAJOR(dev->props.apiVersion), VK_API_VERSION_MINOR(dev->props.apiVersion),
            VK_API_VERSION_PATCH(dev->props.apiVersion));
    pn_json_string(f, cpu);
    fprintf(f, ", \"threads\": %u, \"repeat\": %d, \"warmup\": %d, \"traversal\": \"%s\", \"sampler\": \"%s\", "
               "\"scenes\": [",
            pn_parallel_threads(), o->repeat, o->warmup, pn_traversal_names[o->traversal],
            pn_sampler_names[o->sampler]);
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
                r->spp, MODE_NAME(r->mode));
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
bool pn_bench_write_plots(const char *dir, const bench_rows *rows)
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
                fprintf(f, "%.4f %.6g %s-LS(%d,%d)\n", r->shadow_ms, r->err.mae, MODE_NAME(r->mode), r->n, r->d);
            else
                fprintf(f, "%.4f %.6g %s\n", r->shadow_ms, r->err.mae, MODE_NAME(r->mode));
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
