// What the bench's shard files share (bench_shard.c writes a shard's partial file,
// bench_shard_read.c reads one back, bench_merge.c merges them): the format's version, the rows'
// fields and a partial file as read. Not for use outside engine/apps/bench/bench_shard*.c and
// bench_merge.c.
#pragma once
#include <stddef.h>

#include "apps/bench/bench.h"

enum { PARTIAL_VERSION = 1, MAX_OPT_LINES = 64 + MAX_LIST };

// ---------------------------------------------------------------------------------------------
// The rows' fields: one table that both the writer and the reader walk. Defined here, static (a
// copy in each of the two), because the reader needs its size as a constant (its token arrays),
// which a table behind an extern would not give.

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

// Reads dir/PN_BENCH_PARTIAL into *p; false, logged, when it is not a whole partial file of this
// penumbra (bench_shard_read.c). pn_bench_partial_free frees what it holds.
bool pn_bench_read_partial(const char *dir, partial *p);
void pn_bench_partial_free(partial *p);
