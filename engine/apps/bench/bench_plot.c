// penumbra bench's plots: per view and size a log-log gnuplot plot of reference error against the
// cells' time, a curve per configuration, the Pareto front and Embree; drawn as PNG by gnuplot.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/bench/bench.h"
#include "core/log.h"
#include "core/parallel.h"
#include "io/file.h"

// A configuration's name in the plot's key: mode, filter, adaptive, kind and tree.
static void config_label(char *out, size_t n, const bench_row *r)
{
    if (r->n)
        snprintf(out, n, "%s%s%s%s LS(%d,%d)", MODE_NAME(r->mode), pn_bench_filter_suffix(r->filter),
                 pn_bench_adaptive_suffix(r->spp_min), pn_bench_kind_suffix(r->per_object), r->n, r->d);
    else
        snprintf(out, n, "%s%s%s%s", MODE_NAME(r->mode), pn_bench_project_suffix(r->project),
                 pn_bench_filter_suffix(r->filter), pn_bench_adaptive_suffix(r->spp_min));
}

// Log-log position of a point in [0,1]^2 of the plot's ranges, for label placement.
typedef struct plot_box {
    double x0, x1, y0, y1;
} plot_box;

static void to_unit(const plot_box *b, double x, double y, double *u, double *v)
{
    // A range of one value (a single point) maps to 0 instead of dividing by zero.
    *u = b->x1 > b->x0 ? (log10(x) - b->x0) / (b->x1 - b->x0) : 0;
    *v = b->y1 > b->y0 ? (log10(y) - b->y0) / (b->y1 - b->y0) : 0;
}

// Log axes cannot show 0: an error of 0 (never against the converged reference, but a cell could
// match it) is drawn at 1e-5, far below any level the bench reports, and a time of 0 ms (a frame
// below the timestamps' resolution) at 1 us.
static double plot_err(double e) { return fmax(e, 1e-5); }
static double plot_ms(double ms) { return fmax(ms, 1e-3); }

// Per view and size: reference MAE against the cell's time (shadow pass, plus the filter pass of a
// filtered cell), log-log; a curve per mode, tree and filter through
// its spp points (labelled with the spp where the label does not overlap another), the Pareto front
// over every cell (no other cell both faster and more accurate), and Embree on exact's rays.
bool pn_bench_write_plots(const char *dir, const bench_rows *rows)
{
    int *idx = malloc((2 * (size_t)rows->count + 1) * sizeof *idx); // the group's rows, then its configurations' heads
    if (!idx)
        return false;
    bool ok = true;
    for (int first = 0, end; first < rows->count && ok; first = end) {
        end = pn_bench_group_end(rows, first);
        const bench_row *g0 = &rows->rows[first];
        int n = 0;
        for (int j = first; j < end; j++)
            idx[n++] = j;
        char stem[512], path[4096], tmp[4096], name[600];
        snprintf(stem, sizeof stem, "%s_%ux%u", g0->scene, g0->width, g0->height);
        for (char *c = stem; *c; c++)
            if (*c == ':' || *c == '/' || *c == ' ')
                *c = '_';
        snprintf(name, sizeof name, "%s.dat", stem);
        FILE *f = pn_bench_open_out(dir, name, path, tmp);
        if (!f) {
            ok = false;
            break;
        }
        // Blocks (gnuplot indices): one per configuration, in the order measured (spp ascending
        // within each); then the front; then Embree.
        plot_box box = {INFINITY, -INFINITY, INFINITY, -INFINITY};
        int configs = 0;
        int *heads = idx + n; // the first row of each configuration (idx has room: n + configs <= 2n)
        for (int a = 0; a < n; a++) {
            const bench_row *r = &rows->rows[idx[a]];
            box.x0 = fmin(box.x0, log10(plot_ms(pn_bench_row_ms(r))));
            box.x1 = fmax(box.x1, log10(plot_ms(pn_bench_row_ms(r))));
            box.y0 = fmin(box.y0, log10(plot_err(r->ref.mae)));
            box.y1 = fmax(box.y1, log10(plot_err(r->ref.mae)));
            if (r->embree_ms > 0) {
                box.x0 = fmin(box.x0, log10(r->embree_ms));
                box.x1 = fmax(box.x1, log10(r->embree_ms));
            }
            bool new_config = a == 0 || rows->rows[idx[a - 1]].mode != r->mode || rows->rows[idx[a - 1]].n != r->n ||
                              rows->rows[idx[a - 1]].d != r->d || rows->rows[idx[a - 1]].filter != r->filter ||
                              rows->rows[idx[a - 1]].per_object != r->per_object ||
                              rows->rows[idx[a - 1]].spp_min != r->spp_min;
            if (new_config) {
                if (configs)
                    fprintf(f, "\n\n");
                char title[64];
                config_label(title, sizeof title, r);
                fprintf(f, "# %s: ms (shadow + filter) reference_mae spp\n", title);
                heads[configs++] = idx[a];
            }
            fprintf(f, "%.4f %.6g %u\n", plot_ms(pn_bench_row_ms(r)), plot_err(r->ref.mae), r->spp);
        }
        // The front: sorted by time, each cell more accurate than every faster one.
        int *order = malloc((size_t)n * sizeof *order);
        if (!order) {
            fclose(f);
            pn_file_discard(tmp);
            ok = false;
            break;
        }
        for (int a = 0; a < n; a++)
            order[a] = idx[a];
        for (int a = 0; a < n; a++)
            for (int b = a + 1; b < n; b++) {
                const bench_row *x = &rows->rows[order[a]], *y = &rows->rows[order[b]];
                double tx = pn_bench_row_ms(x), ty = pn_bench_row_ms(y);
                if (ty < tx || (ty == tx && y->ref.mae < x->ref.mae)) {
                    int t = order[a];
                    order[a] = order[b];
                    order[b] = t;
                }
            }
        fprintf(f, "\n\n# Pareto front: ms (shadow + filter) reference_mae\n");
        double best = INFINITY;
        for (int a = 0; a < n; a++) {
            const bench_row *r = &rows->rows[order[a]];
            if (r->ref.mae < best) {
                best = r->ref.mae;
                fprintf(f, "%.4f %.6g\n", plot_ms(pn_bench_row_ms(r)), plot_err(r->ref.mae));
            }
        }
        fprintf(f, "\n\n# Embree 3 on exact's rays: embree_ms reference_mae spp\n");
        int embree_points = 0;
        for (int a = 0; a < n; a++) {
            const bench_row *r = &rows->rows[idx[a]];
            if (r->mode == PN_SHADOW_REFERENCE && r->embree_ms > 0) {
                fprintf(f, "%.4f %.6g %u\n", r->embree_ms, plot_err(r->ref.mae), r->spp);
                embree_points++;
            }
        }
        if (!embree_points)
            fprintf(f, "nan nan 0\n");
        ok = pn_bench_close_out(f, path, tmp);
        snprintf(name, sizeof name, "%s.gp", stem);
        char gp_path[4096];
        f = ok ? pn_bench_open_out(dir, name, gp_path, tmp) : NULL;
        if (!f) {
            free(order);
            ok = false;
            break;
        }
        fprintf(f, "set terminal pngcairo size 1000,700\nset output '%s.png'\n"
                   "set title '%s %ux%u: error against the converged reference vs shadow (+ filter) pass time'\n"
                   "set xlabel 'shadow pass + filter pass (ms, medians)'\nset ylabel 'mean absolute error of V (reference)'\n"
                   "set logscale xy\nset grid\nset key outside right top\n",
                stem, g0->scene, g0->width, g0->height);
        // spp labels, greedily: the front's cells first, then the rest in order; a label is kept only
        // if its box (in the plot's log-log unit square) overlaps no label kept before it.
        double placed[512][2];
        int np = 0;
        const double lw = 0.045, lh = 0.035; // a label's box, as a share of the axes
        for (int pass = 0; pass < 2; pass++)
            for (int a = 0; a < n && np < 512; a++) {
                const bench_row *r = &rows->rows[order[a]];
                bool on_front = true;
                for (int b = 0; b < a && on_front; b++)
                    on_front = rows->rows[order[b]].ref.mae > r->ref.mae;
                if (on_front != (pass == 0))
                    continue;
                double u, v;
                to_unit(&box, plot_ms(pn_bench_row_ms(r)), plot_err(r->ref.mae), &u, &v);
                u += 0.01, v += 0.01; // the label sits above and right of its point
                bool clear = true;
                for (int k = 0; k < np && clear; k++)
                    clear = fabs(placed[k][0] - u) > lw || fabs(placed[k][1] - v) > lh;
                if (!clear)
                    continue;
                placed[np][0] = u, placed[np][1] = v, np++;
                fprintf(f, "set label '%u' at %.4f,%.6g offset 0.5,0.5 font ',8'\n", r->spp, plot_ms(pn_bench_row_ms(r)),
                        plot_err(r->ref.mae));
            }
        fprintf(f, "plot ");
        for (int c = 0; c < configs; c++) {
            char title[64];
            config_label(title, sizeof title, &rows->rows[heads[c]]);
            fprintf(f, "'%s.dat' index %d using 1:2 with linespoints pt %d ps 1.2 title '%s', \\\n     ", stem, c,
                    5 + c % 9, title);
        }
        fprintf(f, "'%s.dat' index %d using 1:2 with lines lw 3 lc rgb 'black' dt 2 title 'Pareto front'", stem,
                configs);
        if (embree_points)
            fprintf(f, ", \\\n     '%s.dat' index %d using 1:2 with points pt 3 ps 2 lc rgb 'red' "
                       "title 'Embree 3 (CPU), exact''s rays'",
                    stem, configs + 1);
        fprintf(f, "\n");
        free(order);
        ok = pn_bench_close_out(f, gp_path, tmp);
        if (ok) {
            char cmd[8192];
            snprintf(cmd, sizeof cmd, "cd '%s' && gnuplot '%s.gp' 2>/dev/null", dir, stem);
            if (system(cmd) != 0)
                pn_warn("gnuplot could not draw %s.gp (is gnuplot-nox installed?)", stem);
        }
    }
    free(idx);
    return ok;
}
