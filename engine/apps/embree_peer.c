// Embree 3 over penumbra's scenes and ray dumps (embree_peer.h).
#include "apps/embree_peer.h"

#include <embree3/rtcore.h>
#include <stdlib.h>
#include <string.h>

#include "core/timer.h"

struct pn_embree {
    RTCDevice device;
};

struct pn_embree_scene {
    RTCScene scene;
    double build_ms;
};

pn_embree *pn_embree_create(void)
{
    RTCDevice rtc = rtcNewDevice(NULL);
    if (!rtc)
        return NULL;
    pn_embree *e = malloc(sizeof *e);
    if (!e) {
        rtcReleaseDevice(rtc);
        return NULL;
    }
    e->device = rtc;
    return e;
}

void pn_embree_destroy(pn_embree *e)
{
    if (!e)
        return;
    rtcReleaseDevice(e->device);
    free(e);
}

pn_embree_scene *pn_embree_scene_create(pn_embree *e, const pn_scene *scene)
{
    pn_embree_scene *s = malloc(sizeof *s);
    if (!s)
        return NULL;
    uint64_t t0 = pn_time_ns();
    RTCScene rs = rtcNewScene(e->device);
    RTCGeometry g = rs ? rtcNewGeometry(e->device, RTC_GEOMETRY_TYPE_TRIANGLE) : NULL;
    if (!g) {
        if (rs)
            rtcReleaseScene(rs);
        free(s);
        return NULL;
    }
    // pn_vertex is 32 bytes with the position first: a strided view of the scene's own vertices
    // (Embree's 16-byte loads of a position stay inside its vertex).
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, scene->vertices, 0, sizeof(pn_vertex),
                               scene->vertex_count);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, scene->indices, 0, 12,
                               scene->index_count / 3);
    rtcCommitGeometry(g);
    rtcAttachGeometry(rs, g);
    rtcReleaseGeometry(g);
    rtcSetSceneBuildQuality(rs, RTC_BUILD_QUALITY_HIGH);
    rtcCommitScene(rs);
    if (rtcGetDeviceError(e->device) != RTC_ERROR_NONE) { // e.g. out of memory while building
        rtcReleaseScene(rs);
        free(s);
        return NULL;
    }
    s->build_ms = pn_ms_since(t0);
    s->scene = rs;
    return s;
}

void pn_embree_scene_destroy(pn_embree_scene *s)
{
    if (!s)
        return;
    rtcReleaseScene(s->scene);
    free(s);
}

double pn_embree_scene_build_ms(const pn_embree_scene *s) { return s->build_ms; }

uint64_t pn_embree_trace_dump(const pn_embree_scene *s, const float *dump, uint64_t px, uint32_t spp, uint64_t begin,
                              uint64_t end, uint8_t *blocked, uint64_t *blocked_count)
{
    struct RTCIntersectContext ic;
    rtcInitIntersectContext(&ic);
    uint64_t rays = 0, hits = 0;
    for (uint64_t p = begin; p < end; p++) {
        const float *o = dump + 4 * p;
        if (blocked)
            memset(blocked + p * spp, 0, spp);
        if (o[3] != 1.0f)
            continue;
        for (uint64_t k = 0; k < spp; k++) {
            const float *q = dump + 4 * (px + p * spp + k);
            uint32_t flags;
            memcpy(&flags, &q[3], 4);
            if (!(flags & 1))
                continue;
            // The segment from the origin to the light sample, unnormalised: t in [0, 1] as in the shader.
            struct RTCRay ray = {.org_x = o[0], .org_y = o[1], .org_z = o[2], .tnear = 0.0f, .dir_x = q[0] - o[0],
                                 .dir_y = q[1] - o[1], .dir_z = q[2] - o[2], .tfar = 1.0f, .mask = 0xffffffffu};
            rtcOccluded1(s->scene, &ic, &ray);
            bool hit = ray.tfar < 0; // Embree's mark of an occluded ray
            rays++;
            hits += hit;
            if (blocked)
                blocked[p * spp + k] = hit;
        }
    }
    if (blocked_count)
        *blocked_count = hits;
    return rays;
}
