// --stats FILE: the process's resident memory and the device memory in use, every N frames, with
// the configuration they belong to, so that a long run shows whether either grows (tests/demo_soak.sh).
#include <errno.h>
#include <string.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <sys/resource.h>
#include <unistd.h>

#include "apps/demo/demo.h"

// Resident pages now: the second field of /proc/self/statm (Linux); 0 elsewhere.
static uint64_t resident_bytes(void)
{
    FILE *f = fopen("/proc/self/statm", "r");
    if (!f)
        return 0;
    unsigned long long size = 0, resident = 0;
    int fields = fscanf(f, "%llu %llu", &size, &resident);
    fclose(f);
    long page = sysconf(_SC_PAGESIZE);
    return fields == 2 && page > 0 ? resident * (uint64_t)page : 0;
}

pn_demo_memory pn_demo_memory_now(const pn_demo *d)
{
#if defined(__GLIBC__)
    // Free memory back to the system first, so that the resident figure is what is in use: glibc
    // keeps the pages of freed chunks resident, and how many depends on where the long-lived
    // allocations fell (the device's pipelines, kept from the warm-up on: gpu/compute.h), not on
    // what is held; without this the same run's figure at one point of the cycle crept up by
    // 16-23 MiB over 4000 frames while the bytes malloc'd grew by 5.6.
    malloc_trim(0);
#endif
    pn_demo_memory m = {.rss_bytes = resident_bytes(),
                        .device_bytes = d->dev.memory_bytes,
                        .device_allocations = d->dev.memory_allocations};
    // Linux counts ru_maxrss in KiB, and updates its high-water mark lazily: it can lag the
    // resident figure just read.
    struct rusage ru;
    if (getrusage(RUSAGE_SELF, &ru) == 0)
        m.peak_rss_bytes = (uint64_t)ru.ru_maxrss * 1024;
    if (m.peak_rss_bytes < m.rss_bytes)
        m.peak_rss_bytes = m.rss_bytes;
#if defined(__GLIBC__) && (__GLIBC__ > 2 || __GLIBC_MINOR__ >= 33)
    // What malloc has handed out and not had back, over all its arenas: unlike the resident figure,
    // free memory glibc keeps (per-thread arenas, fragmentation) does not count.
    struct mallinfo2 mi = mallinfo2();
    m.heap_bytes = mi.uordblks + mi.hblkhd;
    m.heap = true;
#endif
    VkDeviceSize usage;
    if (d->dev.device && pn_gpu_device_heap_usage(&d->dev, &usage))
        m.heap_usage_bytes = usage, m.heap_usage = true;
    return m;
}

static const char *const VIEW_NAMES[] = {"shaded", "visibility", "error"};

// What the device memory depends on, as one word: mode, tree, traversal, sampler, spp, filter,
// view (the error view adds an exact renderer), image size. Samples with the same word must hold
// the same device memory.
static void config_word(const pn_demo *d, char *out, size_t n)
{
    const pn_render_opts *o = &d->opts;
    snprintf(out, n, "%s,LS(%d;%d)%s,%s,%s,spp%lld,%s,%s,%ux%u", pn_shadow_mode_get(o->mode)->name,
             d->accel.desc.tree_n, d->accel.desc.tree_d, d->accel.desc.per_object ? "objects" : "",
             pn_traversal_names[o->traversal], pn_sampler_names[o->sampler], o->spp, pn_filter_names[o->filter],
             VIEW_NAMES[d->view], d->image.width, d->image.height);
}

pn_result pn_demo_stats_open(pn_demo *d, const char *path, uint32_t every)
{
    d->stats_file = fopen(path, "w");
    if (!d->stats_file) {
        pn_error("%s: cannot write the stats: %s", path, strerror(errno));
        return PN_ERR_IO;
    }
    d->stats_every = every;
    fprintf(d->stats_file,
            "# penumbra demo --stats: one sample every %u frames, after the frame was presented.\n"
            "# rss, peak_rss: the process's resident memory (/proc/self/statm, getrusage); malloc: bytes allocated\n"
            "# with malloc and not freed, by every library in the process (glibc's mallinfo2; -1: none);\n"
            "# device, allocations: penumbra's live VkDeviceMemory; heap_usage: the driver's VK_EXT_memory_budget\n"
            "# figure (-1: none); pools: the drawn tree's; building: a tree build running on the worker. Bytes.\n"
            "frame\trss\tpeak_rss\tmalloc\tdevice\tallocations\theap_usage\tpools\tbuilding\tconfig\n",
            every);
    fflush(d->stats_file);
    return PN_OK;
}

void pn_demo_stats_sample(pn_demo *d)
{
    if (!d->stats_file)
        return;
    pn_demo_memory m = pn_demo_memory_now(d);
    char config[256];
    config_word(d, config, sizeof config);
    fprintf(d->stats_file, "%llu\t%llu\t%llu\t%lld\t%llu\t%u\t%lld\t%llu\t%d\t%s\n", (unsigned long long)d->frame,
            (unsigned long long)m.rss_bytes, (unsigned long long)m.peak_rss_bytes, m.heap ? (long long)m.heap_bytes : -1LL,
            (unsigned long long)m.device_bytes,
            m.device_allocations, m.heap_usage ? (long long)m.heap_usage_bytes : -1LL,
            (unsigned long long)pn_shadow_accel_gpu_bytes(&d->accel),
            atomic_load(&d->builder.state) != PN_DEMO_BUILD_IDLE, config);
    fflush(d->stats_file);
}

void pn_demo_stats_close(pn_demo *d)
{
    if (d->stats_file && fclose(d->stats_file) != 0)
        pn_error("cannot finish the stats file: %s", strerror(errno));
    d->stats_file = NULL;
}
