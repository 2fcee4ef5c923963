// penumbra bench's CPU peer: Embree 3's rtcOccluded1 traces the very same rays as the exact mode
// on all cores. The only file of the bench that includes Embree; the rest sees opaque handles.
#include <embree3/rtcore.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/bench.h"
#include "core/parallel.h"
#include "core/timer.h"

struct pn_bench_embree {
    RTCDevice device;
};

struct pn_bench_embree_scene {
    RTCScene scene;
    double build_ms; // Embree's BVH
};

pn_bench_embree *pn_bench_embree_create(void)
{
    RTCDevice rtc = rtcNewDevice(NULL);
    if (!rtc)
        return NULL;
    pn_bench_embree *e = malloc(sizeof *e);
    if (!e) {
        rtcReleaseDevice(rtc);
        return NULL;
    }
    e->device = rtc;
    return e;
}

void pn_bench_embree_destroy(pn_bench_embree *e)
{
    rtcReleaseDevice(e->device);
    free(e);
}

pn_bench_embree_scene *pn_bench_embree_scene_create(pn_bench_embree *e, pn_scene *scene)
{
    pn_bench_embree_scene *s = malloc(sizeof *s);
    if (!s)
        return NULL;
    RTCDevice rtc = e->device;
    uint64_t t0 = pn_time_ns();
    RTCScene rs = rtcNewScene(rtc);
    RTCGeometry g = rtcNewGeometry(rtc, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, scene->vertices, 0, sizeof(pn_vertex),
                               scene->vertex_count);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, scene->indices, 0, 12,
                               scene->index_count / 3);
    rtcCommitGeometry(g);
    rtcAttachGeometry(rs, g);
    rtcReleaseGeometry(g);
    rtcSetSceneBuildQuality(rs, RTC_BUILD_QUALITY_HIGH);
    rtcCommitScene(rs);
    s->build_ms = pn_ms_since(t0);
    s->scene = rs;
    return s;
}

void pn_bench_embree_scene_destroy(pn_bench_embree_scene *s)
{
    rtcReleaseScene(s->scene);
    free(s);
}

// The CPU peer: Embree 3 on the rays of the exact mode's ray dump.

typedef struct embree_job {
    RTCScene scene;
    const float *dump;
    uint64_t pixels, spp;
    uint64_t *rays, *blocked; // per thread
} embree_job;

static void embree_trace(void *ctx, uint64_t begin, uint64_t end, unsigned thread)
{
    embree_job *j = ctx;
    struct RTCIntersectContext ic;
    rtcInitIntersectContext(&ic);
    uint64_t rays = 0, blocked = 0;
    for (uint64_t p = begin; p < end; p++) {
        const float *o = j->dump + 4 * p;
        if (o[3] != 1.0f)
            continue;
        for (uint64_t k = 0; k < j->spp; k++) {
            const float *q = j->dump + 4 * (j->pixels + p * j->spp + k);
            uint32_t flags;
            memcpy(&flags, &q[3], 4);
            if (!(flags & 1))
                continue;
            struct RTCRay ray = {.org_x = o[0], .org_y = o[1], .org_z = o[2], .tnear = 0.0f, .dir_x = q[0] - o[0],
                                 .dir_y = q[1] - o[1], .dir_z = q[2] - o[2], .tfar = 1.0f, .mask = 0xffffffffu};
            rtcOccluded1(j->scene, &ic, &ray);
            rays++;
            blocked += ray.tfar < 0;
        }
    }
    __atomic_fetch_add(&j->rays[0], rays, __ATOMIC_RELAXED);
    __atomic_fetch_add(&j->blocked[0], blocked, __ATOMIC_RELAXED);
}

double pn_bench_embree_time(const bench_opts *o, const pn_bench_embree_scene *s, const float *dump, uint64_t px,
                            uint32_t spp)
{
    RTCScene rs = s->scene;
    double embree_ms = 0;
    uint64_t embree_rays = 0;
    double times[1000];
    for (int r = 0; r < o->repeat + o->warmup; r++) {
        uint64_t rays = 0, blocked = 0;
        embree_job j = {rs, dump, px, spp, &rays, &blocked};
        uint64_t t0 = pn_time_ns();
        pn_parallel_for(px, 256, embree_trace, &j);
        if (r >= o->warmup)
            times[r - o->warmup] = pn_ms_since(t0);
        embree_rays = rays;
    }
    embree_ms = pn_bench_median(times, o->repeat);
    fprintf(stderr, "bench: Embree (%u threads): %.1f ms for %llu rays (%.2f M rays/s; BVH %.0f ms)\n",
            pn_parallel_threads(), embree_ms, (unsigned long long)embree_rays,
            embree_rays / (embree_ms * 1e3), s->build_ms);
    return embree_ms;
}
