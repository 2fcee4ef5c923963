// penumbra bench --merge: the N shards' partial files (read by bench_shard_read.c) checked to be
// one run's, each cell once, and their rows written as the reports one unsharded run would write.
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "apps/args.h"
#include "apps/bench/bench_shard.h"
#include "core/log.h"

// ---------------------------------------------------------------------------------------------
// Merging

// Checks that p[0..nd) are the N shards of one run, each once, and that together they hold every
// cell once (a row or a skip, each in its shard's share); then fills *merged with their rows in one
// run's order (pointers into the shards' rows). False, logged, otherwise.
static bool check_shards(const partial *p, int nd, bench_rows *merged)
{
    for (int i = 1; i < nd; i++) {
        const partial *a = &p[0], *b = &p[i];
        if (a->n != b->n || a->total != b->total) {
            pn_error("--merge: %s is shard %d/%d of %d cells, %s shard %d/%d of %d: not shards of one run", b->dir,
                     b->k, b->n, b->total, a->dir, a->k, a->n, a->total);
            return false;
        }
        int lines = a->opt_count > b->opt_count ? a->opt_count : b->opt_count;
        for (int l = 0; l < lines; l++)
            if (l >= a->opt_count || l >= b->opt_count || strcmp(a->opt_lines[l], b->opt_lines[l]) != 0) {
                pn_error("--merge: %s and %s are shards of different runs: '%s' against '%s'", a->dir, b->dir,
                         l < a->opt_count ? a->opt_lines[l] : "(nothing)",
                         l < b->opt_count ? b->opt_lines[l] : "(nothing)");
                return false;
            }
        if (strcmp(a->ctx.device, b->ctx.device) || strcmp(a->ctx.driver_info, b->ctx.driver_info))
            pn_warn("--merge: %s ran on %s (%s), %s on %s (%s): bench.json names the first; their times do not compare",
                    a->dir, a->ctx.device, a->ctx.driver_info, b->dir, b->ctx.device, b->ctx.driver_info);
    }
    int n = p[0].n, total = p[0].total;
    char missing[512] = "";
    size_t len = 0;
    for (int k = 1; k <= n; k++) {
        int at = -1;
        for (int i = 0; i < nd; i++)
            if (p[i].k == k) {
                if (at >= 0) {
                    pn_error("--merge: %s and %s are both shard %d/%d", p[at].dir, p[i].dir, k, n);
                    return false;
                }
                at = i;
            }
        if (at < 0 && len + 16 < sizeof missing)
            len += (size_t)snprintf(missing + len, sizeof missing - len, "%s%d/%d", len ? ", " : "", k, n);
    }
    if (len) {
        pn_error("--merge: shard %s missing (give the --out folders of all %d shards)", missing, n);
        return false;
    }
    // Which shard holds each cell, and the row (or NULL for a skipped cell).
    int *holder = malloc((size_t)(total ? total : 1) * sizeof *holder);
    const bench_row **row = calloc((size_t)(total ? total : 1), sizeof *row);
    bool ok = holder && row;
    if (!ok)
        pn_error("--merge: out of memory");
    for (int c = 0; ok && c < total; c++)
        holder[c] = -1;
    for (int i = 0; ok && i < nd; i++)
        for (int j = 0; ok && j < p[i].rows.count + p[i].skip_count; j++) {
            bool is_row = j < p[i].rows.count;
            int c = is_row ? p[i].rows.index[j] : p[i].skipped[j - p[i].rows.count];
            if (c >= total || c % n != p[i].k - 1) {
                pn_error("--merge: %s holds cell %d, which is not shard %d/%d's of %d cells", p[i].dir, c, p[i].k, n,
                         total);
                ok = false;
            } else if (holder[c] >= 0) {
                pn_error("--merge: %s holds cell %d twice", p[i].dir, c);
                ok = false;
            } else {
                holder[c] = i;
                row[c] = is_row ? &p[i].rows.rows[j] : NULL;
            }
        }
    for (int c = 0; ok && c < total; c++)
        if (holder[c] < 0) {
            pn_error("--merge: cell %d is in none of the shards (shard %d/%d's, %s, is incomplete)", c, c % n + 1, n,
                     p[0].dir);
            for (int i = 0; i < nd; i++)
                if (p[i].k == c % n + 1)
                    pn_error("--merge: %s lacks cell %d", p[i].dir, c);
            ok = false;
        }
    for (int c = 0; ok && c < total; c++)
        if (row[c]) {
            int count = merged->count, icap = merged->index_cap;
            ok = pn_bench_append((void **)&merged->index, &count, &icap, &c, sizeof c) &&
                 pn_bench_append((void **)&merged->rows, &merged->count, &merged->cap, row[c], sizeof *row[c]);
            merged->index_cap = icap;
            if (!ok)
                pn_error("--merge: out of memory");
        }
    free(holder);
    free(row);
    return ok;
}

int pn_bench_merge(int argc, char **argv)
{
    const char *out = "bench-out";
    const char **dirs = calloc((size_t)argc, sizeof *dirs);
    int nd = 0;
    if (!dirs) {
        pn_error("--merge: out of memory");
        return PN_EXIT_FAILURE;
    }
    bool in_merge = false;
    for (int i = 0; i < argc; i++) {
        if (!strcmp(argv[i], "--merge")) {
            in_merge = true;
        } else if (!strcmp(argv[i], "--out")) {
            if (i + 1 >= argc) {
                pn_error("--out: expected a folder");
                free(dirs);
                return PN_EXIT_USAGE;
            }
            out = argv[++i];
            in_merge = false;
        } else if (in_merge && strncmp(argv[i], "--", 2) != 0) {
            dirs[nd++] = argv[i];
        } else {
            pn_error("bench --merge: '%s': a merge takes its options from the shards' partial files (usage: "
                     "penumbra bench --merge DIR... [--out DIR])",
                     argv[i]);
            free(dirs);
            return PN_EXIT_USAGE;
        }
    }
    if (!nd) {
        pn_error("bench --merge: no shard folders (usage: penumbra bench --merge DIR... [--out DIR])");
        free(dirs);
        return PN_EXIT_USAGE;
    }
    partial *p = calloc((size_t)nd, sizeof *p);
    bench_rows merged = {0};
    int rc = p ? PN_EXIT_OK : PN_EXIT_FAILURE, read = 0;
    for (; rc == PN_EXIT_OK && read < nd; read++)
        if (!pn_bench_read_partial(dirs[read], &p[read]))
            rc = PN_EXIT_FAILURE;
    if (rc == PN_EXIT_OK && !check_shards(p, nd, &merged))
        rc = PN_EXIT_FAILURE;
    // Everything checked: only now the output folder, so that bad input leaves nothing behind.
    if (rc == PN_EXIT_OK && mkdir(out, 0755) != 0 && errno != EEXIST) {
        pn_error("%s: cannot create the output folder: %s", out, strerror(errno));
        rc = PN_EXIT_FAILURE;
    }
    if (rc == PN_EXIT_OK) {
        fprintf(stderr, "bench: merging %d shards of %d cells: %d rows\n", nd, p[0].total, merged.count);
        pn_bench_print_header();
        for (int i = 0; i < merged.count; i++)
            pn_bench_print_row(&merged.rows[i]);
        if (merged.count &&
            !(pn_bench_write_csv(out, &merged) && pn_bench_write_json(out, &p[0].o, &p[0].ctx, &merged) &&
              pn_bench_write_time_to_error(out, &merged) && pn_bench_write_plots(out, &merged)))
            rc = PN_EXIT_FAILURE;
        if (rc == PN_EXIT_OK && merged.count)
            fprintf(stderr, "bench: %d cells merged; results in %s/bench.csv, bench.json, time_to_error.md and *.png\n",
                    merged.count, out);
        else
            fprintf(stderr, "bench: %d cells merged; no results written\n", merged.count);
    }
    for (int i = 0; i < read; i++)
        pn_bench_partial_free(&p[i]);
    free(p);
    free(merged.rows);
    free(merged.index);
    free(dirs);
    return rc;
}
