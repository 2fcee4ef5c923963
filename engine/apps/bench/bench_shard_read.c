// Reads a bench shard's partial file (PN_BENCH_PARTIAL, whose format bench_shard.c describes)
// back: the strings and row fields as bench_shard.c wrote them, every line checked, so that a
// file cut short, damaged or written by another penumbra is refused with its line.
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "apps/bench/bench_shard.h"
#include "core/log.h"

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
// Reading

void pn_bench_partial_free(partial *p)
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
bool pn_bench_read_partial(const char *dir, partial *p)
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
