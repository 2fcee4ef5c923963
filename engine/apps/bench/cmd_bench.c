// penumbra bench: the speed/accuracy trade measured side by side. A matrix of views x sizes x
// modes x trees x samples; every cell renders warm-up and repeated frames (GPU timestamps per pass,
// median and spread), and is compared with a converged exact reference (what the user sees) and
// with exact on the same pixels and light samples (the bias alone).
// Embree 3's rtcOccluded1 traces the very same rays on all cores as the CPU peer.
//
// This file: the command's entry; see bench.h for the other files.
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "apps/args.h"
#include "apps/bench/bench.h"
#include "apps/commands.h"
#include "apps/render_opts.h"
#include "core/log.h"
#include "core/timer.h"

// What --gbuffer allocated.
static void free_opts(bench_opts *o)
{
    free(o->gb_p);
    free(o->gb_n);
}

// The matrix of every view (the default run), its reports and, with --shard, the partial file.
static int run_matrix(const bench_opts *o, pn_gpu_device *dev)
{
    int rc = PN_EXIT_OK;
    pn_embree *rtc = o->embree ? pn_embree_create() : NULL;
    if (o->embree && !rtc)
        pn_warn("Embree could not start: the CPU peer is skipped");
    fprintf(stderr, "bench: %s, driver %s %s, Vulkan %u.%u\n", dev->props.deviceName, dev->driver.driverName,
            dev->driver.driverInfo, VK_API_VERSION_MAJOR(dev->props.apiVersion), VK_API_VERSION_MINOR(dev->props.apiVersion));
    pn_bench_print_header();
    bench_rows rows = {0};
    uint64_t t0 = pn_time_ns();
    // The progress lines' count of cells: each view's upper bound until it is loaded.
    for (int i = 0; i < o->view_count; i++)
        rows.cells.total += pn_bench_view_cells(o, dev, NULL);
    rows.cells.mine = pn_bench_share(o, rows.cells.total);
    rows.cells.t0 = t0;
    if (o->shard_n)
        fprintf(stderr, "bench: shard %d/%d: about %d of the matrix's %d cells\n", o->shard_k, o->shard_n,
                rows.cells.mine, rows.cells.total);
    for (int i = 0; i < o->view_count && rc == PN_EXIT_OK; i++)
        rc = pn_bench_view(o, dev, rtc, &o->views[i], &rows);
    bench_context ctx;
    pn_bench_context_get(dev, &ctx);
    // A failed run writes no results: its rows are a matrix with holes nobody asked for (a cell that
    // cannot be set up is skipped with a warning instead, and the run goes on). A shard's partial
    // file is written last, even for no rows, so that --merge finds every shard.
    if (rc == PN_EXIT_OK && rows.count &&
        !(pn_bench_write_csv(o->out_dir, &rows) && pn_bench_write_json(o->out_dir, o, &ctx, &rows) &&
          pn_bench_write_time_to_error(o->out_dir, &rows) && pn_bench_write_plots(o->out_dir, &rows)))
        rc = PN_EXIT_FAILURE;
    if (rc == PN_EXIT_OK && o->shard_n && !pn_bench_write_partial(o->out_dir, o, &ctx, &rows))
        rc = PN_EXIT_FAILURE;
    if (rc == PN_EXIT_OK && o->shard_n)
        fprintf(stderr, "bench: shard %d/%d: %d cells measured; partial result in %s/%s\n", o->shard_k, o->shard_n,
                rows.count, o->out_dir, PN_BENCH_PARTIAL);
    if (rc == PN_EXIT_OK && rows.count)
        fprintf(stderr, "bench: %d cells in %.1f s; results in %s/bench.csv, bench.json, time_to_error.md and *.png\n",
                rows.count, pn_ms_since(t0) * 1e-3, o->out_dir);
    else
        fprintf(stderr, "bench: %d cells in %.1f s; no results written\n", rows.count, pn_ms_since(t0) * 1e-3);
    free(rows.rows);
    free(rows.quality);
    free(rows.lights);
    free(rows.index);
    free(rows.cells.skipped);
    if (rtc)
        pn_embree_destroy(rtc);
    return rc;
}

int pn_cmd_bench(int argc, char **argv)
{
    for (int i = 0; i < argc; i++)
        if (strcmp(argv[i], "--merge") == 0)
            return pn_bench_merge(argc, argv);
    bench_opts o;
    int rc = pn_bench_parse(argc, argv, &o);
    if (rc != PN_EXIT_OK)
        return rc < 0 ? PN_EXIT_OK : rc;
    if (o.gbuffer && pn_bench_load_gbuffer(&o) != PN_OK) {
        free_opts(&o);
        return PN_EXIT_FAILURE;
    }
    if (mkdir(o.out_dir, 0755) != 0 && errno != EEXIST) {
        pn_error("%s: cannot create the output folder: %s", o.out_dir, strerror(errno));
        free_opts(&o);
        return PN_EXIT_FAILURE;
    }
    // A shard's partial file from an earlier run in this folder goes first: a shard that fails now
    // must not leave one behind that --merge would take for this run's share.
    char partial[4096];
    snprintf(partial, sizeof partial, "%s/%s", o.out_dir, PN_BENCH_PARTIAL);
    if (o.shard_n && unlink(partial) != 0 && errno != ENOENT) {
        pn_error("%s: cannot remove the previous partial file: %s", partial, strerror(errno));
        free_opts(&o);
        return PN_EXIT_FAILURE;
    }
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK) {
        free_opts(&o);
        return PN_EXIT_FAILURE;
    }
    rc = o.points ? pn_bench_points(&o, &dev)
         : o.sequences[0] || o.sequences[1] || o.sequences[2] || o.sequences[3] ? pn_bench_sequences(&o, &dev)
                                              : run_matrix(&o, &dev);
    pn_gpu_device_destroy(&dev);
    free_opts(&o);
    if (dev.validation_messages) {
        pn_error("the Vulkan validation layer reported %u message(s)", dev.validation_messages);
        return PN_EXIT_VALIDATION;
    }
    return rc;
}
