// penumbra bench: the speed/accuracy trade measured side by side. A matrix of views x sizes x
// modes x trees x samples; every cell renders warm-up and repeated frames (GPU timestamps per pass,
// median and spread), and is compared with a converged exact reference (what the user sees) and
// with exact on the same pixels and light samples (the bias alone).
// Embree 3's rtcOccluded1 traces the very same rays on all cores as the CPU peer.
//
// This file: the help text and the command's entry; see bench.h for the other files.
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "apps/args.h"
#include "apps/bench.h"
#include "apps/commands.h"
#include "apps/render_opts.h"
#include "core/log.h"
#include "core/timer.h"

void pn_print_bench_help(void)
{
    printf("usage: penumbra bench [options]\n"
           "  Renders a matrix of views x sizes x modes x trees x filters x samples per pixel, each cell\n"
           "  with warm-up and repeated frames timed by GPU timestamps (median and spread), and measures\n"
           "  two errors of its V over the pixels with geometry (MAE, RMSE, p99, max):\n"
           "    reference: against the converged reference, exact at --reference-spp samples with a seed\n"
           "               of its own (cached in OUT/reference): what the user sees, bias and noise;\n"
           "    bias:      against exact with the same pixels and light samples: the mode's bias alone.\n"
           "  Embree 3 traces exact's rays on all cores as the CPU peer. Writes a console table, bench.csv,\n"
           "  bench.json, time_to_error.md (per mode the fastest cell reaching each error level) and a\n"
           "  log-log plot of reference error vs shadow time per view and size with the Pareto front.\n"
           "  --views V,...        standard views: bunny, dragon, buddha, sponza or all (default: all whose\n"
           "                       mesh is in $PN_ASSETS, else ../shared/assets)\n"
           "  --scenes A,B,...     other scenes (files, builtin:NAME, folders of .glb), framed as render does\n"
           "  --modes M,...        of the modes that trace (default: all the device can run)\n"
           "  --trees N,d:N,d:...  trees for the line-space modes (default 6,3:7,3:8,3)\n"
           "  --tree-kinds K,...   scene, object: an axis of the matrix (default scene). scene: one tree\n"
           "                       over the scene, culled by the view and light; object: a tree per mesh\n"
           "                       in its own frame, shared by its instances, and a top level (mode\n"
           "                       linespace only; see render --trees). Rows report what moving one\n"
           "                       object costs each: a rebuild, or with per-object trees the top level's\n"
           "                       rebuild and upload, timed\n"
           "  --spp S,...          samples per pixel, an axis of the matrix (default 1,4,16,64,4:64);\n"
           "                       MIN:MAX is an adaptive cell (render --spp MIN:MAX; no Embree peer)\n"
           "  --pixel-error E      the adaptive cells' target standard error per pixel (default %.3g)\n"
           "  --filter F,...       none, interleaved: an axis of the matrix (default both); a filtered cell's\n"
           "                       time is its shadow pass plus its filter pass, and it reports the share of\n"
           "                       pixels near edges of geometry whose error the filter grows by > 0.05\n"
           "  --tile WxH           the filtered cells' interleaving tile and window, 1..8 each (default 3x3)\n"
           "  --lights K,...       also time every configuration (first --spp and --filter) with K lights:\n"
           "                       the view's light turned about the vertical through the scene's centre in\n"
           "                       K even steps, light i with 2^-i of the first's radiance (together the\n"
           "                       view's light's), over one scene-wide tree (the first of --trees)\n"
           "                       built for the set, both --split even and budget with the set's radiance error against its converged reference;\n"
           "                       frame time, its ratios to the view's light alone and to the set's lights\n"
           "                       each alone, pools and build time (console and bench.json's \"lights\")\n"
           "  --edge-images        per filtered cell, OUT/edge_<cell>.exr: shadow.V, shadow.V_raw, reference.V,\n"
           "                       edge (0 away from edges, 1 edge, 2 within 2 px, 3 there with the error grown)\n"
           "                       and the filter's inputs: P, N, Z, shadow.valid and shadow.penumbra\n"
           "  --reference-spp S    samples of the converged reference (default %d)\n"
           "  --seed S             the measured frames' random choices (default 1): another seed, another\n"
           "                       draw of the samples, e.g. to see the errors' spread\n"
           "  --size WxH,...       image sizes (default 512x512)\n"
           "  --repeat R --warmup W   timed and untimed frames per cell (default 3 and 1)\n"
           "  --traversal auto|ray|packet  --sampler grid|stratified   (default auto, stratified)\n"
           "  --out DIR            where the CSV, JSON, tables, plots and reference cache go (default bench-out)\n"
           "  --reference-cache DIR   cache the converged references here instead of OUT/reference (runs\n"
           "                       with other outputs share them; a file's name holds a hash of what it depends on)\n"
           "  --no-embree          skip the CPU peer\n"
           "  --shader shadow --gbuffer FILE.exr\n"
           "                       shader level: the shadow pass alone over the P and N layers of an EXR\n"
           "                       (render --aovs of the same scene); the size is the EXR's\n"
           "  --work               per cell, one more frame with the shadow shader's counting build: per\n"
           "                       pixel nodes visited, line-space lookups, triangle tests and deepest\n"
           "                       stack; their distribution is printed and written as EXR layers work.*\n"
           "  --max-error E,...    also run --quality auto at each budget (reference MAE), render its pick at\n"
           "                       full size and compare it with the matrix's fastest cell within the budget\n"
           "  --quick              a small matrix (the bunny view or builtin:default, 256x256, 4 and 16 spp,\n"
           "                       LS(6,3) and LS(7,3), 3 repeats)\n",
           (double)PN_DEFAULT_PIXEL_ERROR, PN_REFERENCE_SPP);
}

// What --gbuffer allocated.
static void free_opts(bench_opts *o)
{
    free(o->gb_p);
    free(o->gb_n);
}

int pn_cmd_bench(int argc, char **argv)
{
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
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK) {
        free_opts(&o);
        return PN_EXIT_FAILURE;
    }
    pn_embree *rtc = o.embree ? pn_embree_create() : NULL;
    if (o.embree && !rtc)
        pn_warn("Embree could not start: the CPU peer is skipped");
    fprintf(stderr, "bench: %s, driver %s %s, Vulkan %u.%u\n", dev.props.deviceName, dev.driver.driverName,
            dev.driver.driverInfo, VK_API_VERSION_MAJOR(dev.props.apiVersion), VK_API_VERSION_MINOR(dev.props.apiVersion));
    pn_bench_print_header();
    bench_rows rows = {0};
    uint64_t t0 = pn_time_ns();
    for (int i = 0; i < o.view_count && rc == PN_EXIT_OK; i++)
        rc = pn_bench_view(&o, &dev, rtc, &o.views[i], &rows);
    // A failed run writes no results: its rows are a matrix with holes nobody asked for (a cell that
    // cannot be set up is skipped with a warning instead, and the run goes on).
    if (rc == PN_EXIT_OK && rows.count &&
        !(pn_bench_write_csv(o.out_dir, &rows) && pn_bench_write_json(o.out_dir, &o, &dev, &rows) &&
          pn_bench_write_time_to_error(o.out_dir, &rows) && pn_bench_write_plots(o.out_dir, &rows)))
        rc = PN_EXIT_FAILURE;
    if (rc == PN_EXIT_OK && rows.count)
        fprintf(stderr, "bench: %d cells in %.1f s; results in %s/bench.csv, bench.json, time_to_error.md and *.png\n",
                rows.count, pn_ms_since(t0) * 1e-3, o.out_dir);
    else
        fprintf(stderr, "bench: %d cells in %.1f s; no results written\n", rows.count, pn_ms_since(t0) * 1e-3);
    free(rows.rows);
    free(rows.quality);
    free(rows.lights);
    if (rtc)
        pn_embree_destroy(rtc);
    pn_gpu_device_destroy(&dev);
    free_opts(&o);
    if (dev.validation_messages) {
        pn_error("the Vulkan validation layer reported %u message(s)", dev.validation_messages);
        return PN_EXIT_VALIDATION;
    }
    return rc;
}
