// penumbra bench's CPU peer: Embree 3 (apps/embree_peer.h) traces the very same rays as the exact
// mode on all cores, timed as the cells are.
#include <stdio.h>

#include "apps/bench/bench.h"
#include "core/parallel.h"
#include "core/timer.h"

// The CPU peer: Embree 3 on the rays of the exact mode's ray dump.

typedef struct embree_job {
    const pn_embree_scene *scene;
    const float *dump;
    uint64_t pixels;
    uint32_t spp;
    uint64_t rays; // over all threads
} embree_job;

static void embree_trace(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    embree_job *j = ctx;
    uint64_t rays = pn_embree_trace_dump(j->scene, j->dump, j->pixels, j->spp, begin, end, NULL, NULL);
    __atomic_fetch_add(&j->rays, rays, __ATOMIC_RELAXED);
}

double pn_bench_embree_time(const bench_opts *o, const pn_embree_scene *s, const float *dump, uint64_t px,
                            uint32_t spp)
{
    double embree_ms = 0;
    uint64_t embree_rays = 0;
    double times[1000];
    for (int r = 0; r < o->repeat + o->warmup; r++) {
        embree_job j = {s, dump, px, spp, 0};
        uint64_t t0 = pn_time_ns();
        pn_parallel_for(px, 256, embree_trace, &j);
        if (r >= o->warmup)
            times[r - o->warmup] = pn_ms_since(t0);
        embree_rays = j.rays;
    }
    embree_ms = pn_time_median(times, o->repeat);
    fprintf(stderr, "bench: Embree (%u threads): %.1f ms for %llu rays (%.2f M rays/s; BVH %.0f ms)\n",
            pn_parallel_threads(), embree_ms, (unsigned long long)embree_rays,
            embree_rays / (embree_ms * 1e3), pn_embree_scene_build_ms(s));
    return embree_ms;
}
