// penumbra bench's shards: --shard K/N writes its rows to a partial file beside its reports, and
// --merge reads the N partial files back into the reports one unsharded run would write.
//
// The partial file (PN_BENCH_PARTIAL) is line-based text, one record a line, tokens separated by
// one space, so that C reads it back without a JSON parser:
//   penumbra-bench-partial 1          the format and its version
//   shard K N / cells TOTAL           which share of a matrix of TOTAL cells
//   opt NAME VALUE... / view ...      every option that shapes the cells and reports: two shards of
//                                     one run have the same lines, in the same order
//   context NAME VALUE                the device and machine, for bench.json
//   fields NAME...                    the row fields' names, in the order of the rows' tokens
//   row INDEX VALUE...                a measured cell and its number in one run's order
//   skip INDEX                        a cell of the share whose configuration could not be set up
//   end                               the file is whole
// Strings are written "=" then their bytes with '%', spaces and control characters as %XX (so an
// empty string is "="); doubles as %.17g, which strtod reads back to the same bits, so that the
// merged errors equal the shards' to the last digit.
#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "apps/args.h"
#include "apps/bench/bench.h"
#include "core/log.h"
#include "io/file.h"

enum { PARTIAL_VERSION = 1, MAX_OPT_LINES = 64 + MAX_LIST };

static void put_str(FILE *f, const char *s)
{
    fputc('=', f);
    for (const unsigned char *c = (const unsigned char *)s; *c; c++)
        if (*c <= ' ' || *c == '%' || *c == 0x7f)
            fprintf(f, "%%%02X", *c);
        else
            fputc(*c, f);
}

// A "=..." token back into out (n bytes); false when it is not one or does not fit.
static bool get_str(const char *tok, char *out, size_t n)
{
    if (tok[0] != '=')
        return false;
    size_t len = 0;
    for (const char *c = tok + 1; *c; c++) {
        unsigned x = (unsigned char)*c;
        if (*c == '%') {
            if (sscanf(c + 1, "%2x", &x) != 1 || !c[1] || !c[2])
                return false;
            c += 2;
        }
        if (len + 1 >= n)
            return false;
        out[len++] = (char)x;
    }
    out[len] = 0;
    return true;
}

// ---------------------------------------------------------------------------------------------
// The rows' fields: one table that both the writer and the reader walk.

typedef enum { F_STR64, F_U32, F_I32, F_BOOL, F_F64, F_SIZE, F_MODE, F_FILTER } field_type;
typedef struct row_field {
    const char *name;
    field_type type;
    size_t offset;
} row_field;

#define FIELD(name, type, member) {name, type, offsetof(bench_row, member)}
#define METRICS(p, m)                                                                                                  \
    FIELD(p "_pixels", F_SIZE, m.pixels), FIELD(p "_mae", F_F64, m.mae), FIELD(p "_rmse", F_F64, m.rmse),              \
        FIELD(p "_p99", F_F64, m.p99), FIELD(p "_max", F_F64, m.max), FIELD(p "_over005", F_F64, m.over005),           \
        FIELD(p "_over02", F_F64, m.over02)
static const row_field row_fields[] = {
    FIELD("scene", F_STR64, scene),          FIELD("width", F_U32, width),
    FIELD("height", F_U32, height),          FIELD("spp", F_U32, spp),
    FIELD("spp_min", F_U32, spp_min),        FIELD("mean_rays", F_F64, mean_rays),
    FIELD("beyond_2se", F_F64, beyond_2se),  FIELD("mode", F_MODE, mode),
    FIELD("n", F_I32, n),                    FIELD("d", F_I32, d),
    FIELD("per_object", F_BOOL, per_object), FIELD("filter", F_FILTER, filter),
    FIELD("project", F_BOOL, project),       FIELD("projected", F_F64, projected),
    FIELD("fallback", F_F64, fallback),
    FIELD("tile_w", F_U32, tile_w),          FIELD("tile_h", F_U32, tile_h),
    FIELD("triangles", F_U32, triangles),    FIELD("build_ms", F_F64, build_ms),
    FIELD("pool_mb", F_F64, pool_mb),        FIELD("move_ms", F_F64, move_ms),
    FIELD("gbuffer_ms", F_F64, gbuffer_ms),  FIELD("shadow_ms", F_F64, shadow_ms),
    FIELD("filter_ms", F_F64, filter_ms),    FIELD("shade_ms", F_F64, shade_ms),
    FIELD("shadow_min_ms", F_F64, shadow_min_ms), FIELD("shadow_max_ms", F_F64, shadow_max_ms),
    FIELD("compile_ms", F_F64, compile_ms),
    FIELD("rays_per_s", F_F64, rays_per_s),  METRICS("ref", ref),
    METRICS("bias", bias),                   FIELD("vs_exact", F_F64, vs_exact),
    FIELD("vs_embree", F_F64, vs_embree),    FIELD("embree_ms", F_F64, embree_ms),
    FIELD("edge_band", F_SIZE, edge.band),   FIELD("edge_grown", F_SIZE, edge.grown),
    FIELD("edge_share", F_F64, edge.share),  FIELD("edge_away", F_SIZE, edge.away),
    FIELD("edge_away_grown", F_SIZE, edge.away_grown), FIELD("edge_away_share", F_F64, edge.away_share),
};
enum { ROW_FIELDS = sizeof row_fields / sizeof row_fields[0] };

static void put_field(FILE *f, const bench_row *r, const row_field *fd)
{
    const char *p = (const char *)r + fd->offset;
    switch (fd->type) {
    case F_STR64: put_str(f, p); break;
    case F_U32: fprintf(f, "%u", *(const uint32_t *)p); break;
    case F_I32: fprintf(f, "%d", *(const int *)p); break;
    case F_BOOL: fprintf(f, "%d", *(const bool *)p ? 1 : 0); break;
    case F_F64: fprintf(f, "%.17g", *(const double *)p); break;
    case F_SIZE: fprintf(f, "%zu", *(const size_t *)p); break;
    case F_MODE: fprintf(f, "%s", MODE_NAME(*(const pn_shadow_mode *)p)); break;
    case F_FILTER: fprintf(f, "%s", pn_filter_names[*(const pn_filter *)p]); break;
    }
}

static bool get_field(const char *tok, bench_row *r, const row_field *fd)
{
    char *p = (char *)r + fd->offset, *end = NULL;
    errno = 0;
    switch (fd->type) {
    case F_STR64: return get_str(tok, p, 64);
    case F_U32: {
        unsigned long long x = strtoull(tok, &end, 10);
        *(uint32_t *)p = (uint32_t)x;
        return *end == 0 && end != tok && x <= UINT32_MAX && tok[0] != '-';
    }
    case F_I32: {
        long x = strtol(tok, &end, 10);
        *(int *)p = (int)x;
        return *end == 0 && end != tok && x >= -2147483647L && x <= 2147483647L;
    }
    case F_BOOL:
        *(bool *)p = tok[0] == '1';
        return (tok[0] == '0' || tok[0] == '1') && !tok[1];
    case F_F64: *(double *)p = strtod(tok, &end); return *end == 0 && end != tok;
    case F_SIZE: {
        unsigned long long x = strtoull(tok, &end, 10);
        *(size_t *)p = (size_t)x;
        return *end == 0 && end != tok && tok[0] != '-';
    }
    case F_MODE:
        for (int m = 0; m < PN_SHADOW_MODE_COUNT; m++)
            if (!strcmp(tok, MODE_NAME((pn_shadow_mode)m))) {
                *(pn_shadow_mode *)p = (pn_shadow_mode)m;
                return true;
            }
        return false;
    case F_FILTER:
        for (int i = 0; pn_filter_names[i]; i++)
            if (!strcmp(tok, pn_filter_names[i])) {
                *(pn_filter *)p = (pn_filter)i;
                return true;
            }
        return false;
    }
    return false;
}

// ---------------------------------------------------------------------------------------------
// Writing

// The options that shape the cells and the reports, one "opt" or "view" line each. Not here: what
// does not change a result (--out, --reference-cache, --shard itself).
static void put_opts(FILE *f, const bench_opts *o)
{
    fprintf(f, "opt repeat %d\nopt warmup %d\nopt traversal %s\nopt sampler %s\nopt seed %u\nopt reference_spp %u\n",
            o->repeat, o->warmup, pn_traversal_names[o->traversal], pn_sampler_names[o->sampler], o->seed,
            o->reference_spp);
    fprintf(f, "opt pixel_error %.9g\nopt tile %u %u\nopt filters", (double)o->pixel_error, o->tile_w, o->tile_h);
    for (int i = 0; i < o->filter_count; i++)
        fprintf(f, " %s", pn_filter_names[o->filters[i]]);
    fprintf(f, "\nopt modes");
    for (int i = 0; i < o->mode_count; i++)
        fprintf(f, " %s", MODE_NAME(o->modes[i]));
    fprintf(f, "\nopt trees");
    for (int i = 0; i < o->tree_count; i++)
        fprintf(f, " %d,%d", o->trees[i][0], o->trees[i][1]);
    fprintf(f, "\nopt tree_kinds %d %d\nopt spp", o->kinds[PN_TREE_KIND_SCENE], o->kinds[PN_TREE_KIND_OBJECT]);
    for (int i = 0; i < o->spp_count; i++)
        fprintf(f, " %u:%u", o->spp_mins[i], o->spps[i]);
    fprintf(f, "\nopt sizes");
    for (int i = 0; i < o->size_count; i++)
        fprintf(f, " %ux%u", o->sizes[i][0], o->sizes[i][1]);
    fprintf(f, "\nopt embree %d\nopt work %d\nopt edge_images %d\nopt gbuffer ", o->embree, o->work, o->edge_images);
    put_str(f, o->gbuffer ? o->gbuffer : "");
    fprintf(f, "\n");
    for (int i = 0; i < o->view_count; i++) {
        fprintf(f, "view ");
        put_str(f, o->views[i].name);
        fprintf(f, " ");
        put_str(f, o->views[i].source);
        fprintf(f, " %d\n", o->views[i].spec != NULL);
    }
}

bool pn_bench_write_partial(const char *dir, const bench_opts *o, const bench_context *ctx, const bench_rows *rows)
{
    char path[4096], tmp[4096];
    FILE *f = pn_bench_open_out(dir, PN_BENCH_PARTIAL, path, tmp);
    if (!f)
        return false;
    fprintf(f, "penumbra-bench-partial %d\nshard %d %d\ncells %d\n", PARTIAL_VERSION, o->shard_k, o->shard_n,
            rows->cells.next);
    put_opts(f, o);
    const char *names[4] = {"device", "driver", "driver_info", "cpu"};
    const char *values[4] = {ctx->device, ctx->driver, ctx->driver_info, ctx->cpu};
    for (int i = 0; i < 4; i++) {
        fprintf(f, "context %s ", names[i]);
        put_str(f, values[i]);
        fprintf(f, "\n");
    }
    fprintf(f, "context driver_version %u\ncontext api_version %u\ncontext threads %u\nfields", ctx->driver_version,
            ctx->api_version, ctx->threads);
    for (int i = 0; i < ROW_FIELDS; i++)
        fprintf(f, " %s", row_fields[i].name);
    fprintf(f, "\n");
    for (int r = 0; r < rows->count; r++) {
        fprintf(f, "row %d", rows->index[r]);
        for (int i = 0; i < ROW_FIELDS; i++) {
            fputc(' ', f);
            put_field(f, &rows->rows[r], &row_fields[i]);
        }
        fprintf(f, "\n");
    }
    for (int i = 0; i < rows->cells.skip_count; i++)
        fprintf(f, "skip %d\n", rows->cells.skipped[i]);
    fprintf(f, "end\n");
    return pn_bench_close_out(f, path, tmp);
}

// ---------------------------------------------------------------------------------------------
// Reading

typedef struct partial {
    const char *dir;
    int k, n, total;
    char *opt_lines[MAX_OPT_LINES]; // as written, to compare shards
    int opt_count;
    bench_opts o; // what the reports need of the options
    bench_context ctx;
    bench_rows rows; // with rows.index
    int *skipped;
    int skip_count, skip_cap;
} partial;

static void partial_free(partial *p)
{
    for (int i = 0; i < p->opt_count; i++)
        free(p->opt_lines[i]);
    free(p->rows.rows);
    free(p->rows.index);
    free(p->skipped);
}

// Splits line (modified) at spaces into at most max tokens; the count, or max + 1 when more.
static int split(char *line, char **tok, int max)
{
    int n = 0;
    for (char *s = strtok(line, " "); s; s = strtok(NULL, " ")) {
        if (n == max)
            return max + 1;
        tok[n++] = s;
    }
    return n;
}

static int choice(const char *s, const char *const *names)
{
    for (int i = 0; names[i]; i++)
        if (!strcmp(s, names[i]))
            return i;
    return -1;
}

// An "opt" line that the reports read (the others are only compared).
static bool read_opt(char **tok, int nt, bench_opts *o)
{
    const char *name = tok[1];
    if (!strcmp(name, "repeat") && nt == 3)
        return sscanf(tok[2], "%d", &o->repeat) == 1;
    if (!strcmp(name, "warmup") && nt == 3)
        return sscanf(tok[2], "%d", &o->warmup) == 1;
    if (!strcmp(name, "seed") && nt == 3)
        return sscanf(tok[2], "%u", &o->seed) == 1;
    if (!strcmp(name, "reference_spp") && nt == 3)
        return sscanf(tok[2], "%u", &o->reference_spp) == 1;
    if (!strcmp(name, "tile") && nt == 4)
        return sscanf(tok[2], "%u", &o->tile_w) == 1 && sscanf(tok[3], "%u", &o->tile_h) == 1;
    if (!strcmp(name, "traversal") && nt == 3) {
        int t = choice(tok[2], pn_traversal_names);
        o->traversal = t >= 0 ? (pn_traversal)t : o->traversal;
        return t >= 0;
    }
    if (!strcmp(name, "sampler") && nt == 3) {
        int s = choice(tok[2], pn_sampler_names);
        o->sampler = s >= 0 ? (pn_sampler)s : o->sampler;
        return s >= 0;
    }
    if (!strcmp(name, "filters")) {
        o->filter_count = 0;
        for (int i = 2; i < nt; i++) {
            int f = choice(tok[i], pn_filter_names);
            if (f < 0 || o->filter_count == PN_FILTER_LAST + 1)
                return false;
            o->filters[o->filter_count++] = (pn_filter)f;
        }
        return true;
    }
    return true;
}

// Reads dir/PN_BENCH_PARTIAL into *p; false (logged, naming the file and line) when it is missing,
// of another version, cut short or damaged.
static bool read_partial(const char *dir, partial *p)
{
    *p = (partial){.dir = dir};
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, PN_BENCH_PARTIAL);
    struct stat st;
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
        pn_error("--merge: %s: not a folder", dir);
        return false;
    }
    FILE *f = fopen(path, "r");
    if (!f) {
        pn_error("--merge: %s: no %s (%s): not the --out folder of a bench --shard run", dir, PN_BENCH_PARTIAL,
                 strerror(errno));
        return false;
    }
    char *line = NULL;
    size_t cap = 0;
    int lineno = 0, nfields = 0;
    const row_field *order[ROW_FIELDS];
    bool ok = true, header = false, shard = false, cells = false, end = false;
    const char *why = "";
    enum { MAX_TOK = ROW_FIELDS + 2 };
    char *tok[MAX_TOK];
    while (ok && !end && getline(&line, &cap, f) > 0) {
        lineno++;
        line[strcspn(line, "\n")] = 0;
        char *copy = strdup(line);
        int nt = split(line, tok, MAX_TOK);
        if (!copy || nt == 0 || nt > MAX_TOK) {
            ok = false, why = copy ? "an empty or overlong line" : "out of memory";
        } else if (!header) {
            ok = nt == 2 && !strcmp(tok[0], "penumbra-bench-partial");
            why = "not a bench partial file";
            if (ok && atoi(tok[1]) != PARTIAL_VERSION)
                ok = false, why = "another version of the partial file (written by another penumbra)";
            header = true;
        } else if (!strcmp(tok[0], "shard")) {
            ok = nt == 3 && sscanf(tok[1], "%d", &p->k) == 1 && sscanf(tok[2], "%d", &p->n) == 1 && p->n >= 1 &&
                 p->k >= 1 && p->k <= p->n;
            why = "a bad shard line";
            shard = true;
        } else if (!strcmp(tok[0], "cells")) {
            ok = nt == 2 && sscanf(tok[1], "%d", &p->total) == 1 && p->total >= 0;
            why = "a bad cells line";
            cells = true;
        } else if (!strcmp(tok[0], "opt") || !strcmp(tok[0], "view")) {
            ok = p->opt_count < MAX_OPT_LINES && nt >= 2;
            why = "too many option lines";
            if (ok)
                p->opt_lines[p->opt_count++] = copy, copy = NULL;
            if (ok && !strcmp(tok[0], "opt")) {
                ok = read_opt(tok, nt, &p->o);
                why = "a bad option line";
            } else if (ok) {
                bench_view *v = &p->o.views[p->o.view_count];
                ok = nt == 4 && p->o.view_count < MAX_LIST && get_str(tok[1], v->name, sizeof v->name) &&
                     get_str(tok[2], v->source, sizeof v->source);
                why = "a bad view line";
                if (ok) {
                    v->spec = atoi(tok[3]) ? pn_bench_view_spec_find(v->name) : NULL;
                    p->o.view_count++;
                }
            }
        } else if (!strcmp(tok[0], "context") && nt == 3) {
            bench_context *c = &p->ctx;
            const char *n = tok[1];
            why = "a bad context line";
            if (!strcmp(n, "device"))
                ok = get_str(tok[2], c->device, sizeof c->device);
            else if (!strcmp(n, "driver"))
                ok = get_str(tok[2], c->driver, sizeof c->driver);
            else if (!strcmp(n, "driver_info"))
                ok = get_str(tok[2], c->driver_info, sizeof c->driver_info);
            else if (!strcmp(n, "cpu"))
                ok = get_str(tok[2], c->cpu, sizeof c->cpu);
            else if (!strcmp(n, "driver_version"))
                ok = sscanf(tok[2], "%u", &c->driver_version) == 1;
            else if (!strcmp(n, "api_version"))
                ok = sscanf(tok[2], "%u", &c->api_version) == 1;
            else if (!strcmp(n, "threads"))
                ok = sscanf(tok[2], "%u", &c->threads) == 1;
        } else if (!strcmp(tok[0], "fields")) {
            // Every field this penumbra has, each once: a file from a penumbra with other fields is
            // refused rather than merged with zeros.
            nfields = nt - 1;
            ok = nfields == ROW_FIELDS;
            why = "another set of row fields (written by another penumbra)";
            for (int i = 0; ok && i < nfields; i++) {
                order[i] = NULL;
                for (int j = 0; j < ROW_FIELDS; j++)
                    if (!strcmp(tok[1 + i], row_fields[j].name))
                        order[i] = &row_fields[j];
                for (int j = 0; j < i && order[i]; j++)
                    if (order[j] == order[i])
                        order[i] = NULL;
                ok = order[i] != NULL;
            }
        } else if (!strcmp(tok[0], "row")) {
            bench_row r = {0};
            int index = -1;
            ok = nfields && nt == nfields + 2 && sscanf(tok[1], "%d", &index) == 1 && index >= 0;
            why = "a row before the fields line or with another count of values";
            for (int i = 0; ok && i < nfields; i++)
                if (!get_field(tok[2 + i], &r, order[i])) {
                    // The field's name, kept for the message (row_fields is static).
                    why = order[i]->name;
                    ok = false;
                }
            int n = p->rows.count, icap = p->rows.index_cap;
            ok = ok && pn_bench_append((void **)&p->rows.index, &n, &icap, &index, sizeof index) &&
                 pn_bench_append((void **)&p->rows.rows, &p->rows.count, &p->rows.cap, &r, sizeof r);
            p->rows.index_cap = icap;
        } else if (!strcmp(tok[0], "skip")) {
            int index = -1;
            ok = nt == 2 && sscanf(tok[1], "%d", &index) == 1 && index >= 0 &&
                 pn_bench_append((void **)&p->skipped, &p->skip_count, &p->skip_cap, &index, sizeof index);
            why = "a bad skip line";
        } else if (!strcmp(tok[0], "end")) {
            end = true;
        } else {
            ok = false, why = "an unknown line";
        }
        free(copy);
    }
    free(line);
    fclose(f);
    if (!ok) {
        pn_error("--merge: %s:%d: %s%s", path, lineno, strchr(why, ' ') ? "" : "a bad value of ", why);
        return false;
    }
    if (!header || !shard || !cells || !nfields || !end) {
        pn_error("--merge: %s: cut short (no %s line): the shard did not finish", path,
                 !header ? "header" : !shard ? "shard" : !cells ? "cells" : !nfields ? "fields" : "end");
        return false;
    }
    return true;
}

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
        if (!read_partial(dirs[read], &p[read]))
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
        partial_free(&p[i]);
    free(p);
    free(merged.rows);
    free(merged.index);
    free(dirs);
    return rc;
}
