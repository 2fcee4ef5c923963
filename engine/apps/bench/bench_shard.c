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
//
// This file writes it; bench_shard_read.c reads it back and bench_merge.c merges the shards.
#include <stdio.h>

#include "apps/bench/bench.h"
#include "apps/bench/bench_shard.h"

static void put_str(FILE *f, const char *s)
{
    fputc('=', f);
    for (const unsigned char *c = (const unsigned char *)s; *c; c++)
        if (*c <= ' ' || *c == '%' || *c == 0x7f)
            fprintf(f, "%%%02X", *c);
        else
            fputc(*c, f);
}

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
