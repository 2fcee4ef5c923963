// Embree 3 over penumbra's scenes and ray dumps (embree_peer.h).
#include "apps/embree_peer.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/timer.h"

struct pn_embree {
    RTCDevice device;
};

struct pn_embree_scene {
    RTCScene scene;
    double build_ms;
    const pn_scene *source;
    uint32_t *material; // per triangle, its draw's material (UINT32_MAX: none); NULL without masks
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

static bool masked(const pn_scene *s, uint32_t material)
{
    return material < s->material_count && s->materials[material].alpha_cutoff > 0;
}

// Is the point (1 - b1 - b2) a + b1 b + b2 c of triangle `tri` (Embree's barycentrics) cut out of
// its masked material? glTF's MASK read here on its own, apart from the engine's records
// (accel/alpha.c, alpha.glsl): alpha is the base colour's times the texel's, the texel the one
// nearest the point's uv with the texture repeating (u = 0 the image's left edge, v = 0 its first
// row), the uv interpolated in double from the vertices'; cut out below alphaCutoff.
static bool cut_out(const pn_scene *s, uint32_t material, uint32_t tri, double b1, double b2)
{
    const pn_material *m = &s->materials[material];
    double alpha = m->base_color[3];
    if (m->texture >= 0 && (uint32_t)m->texture < s->texture_count) {
        const pn_texture *t = &s->textures[m->texture];
        const float *ta = s->vertices[s->indices[3 * tri]].uv, *tb = s->vertices[s->indices[3 * tri + 1]].uv,
                    *tc = s->vertices[s->indices[3 * tri + 2]].uv;
        double b0 = 1.0 - b1 - b2;
        double u = b0 * ta[0] + b1 * tb[0] + b2 * tc[0], v = b0 * ta[1] + b1 * tb[1] + b2 * tc[1];
        // The texel's column and row, floor(u w) and floor(v h) taken modulo the size (repeat).
        double x = fmod(floor(u * t->width), t->width), y = fmod(floor(v * t->height), t->height);
        x += x < 0 ? t->width : 0;
        y += y < 0 ? t->height : 0;
        alpha *= t->rgba[4 * ((uint64_t)y * t->width + (uint64_t)x) + 3] / 255.0;
    }
    return alpha < m->alpha_cutoff;
}

// Embree's occlusion filter on the scene's geometry: a hit on a cut-out texel is no hit, and the
// ray goes on to the next. The N hits come as arrays of each field (rtcore_ray.h's RTCHitN_*
// accessors, which are C++ only): Ng x, y, z, u, v, then primID.
static void occluded_filter(const struct RTCFilterFunctionNArguments *args)
{
    const pn_embree_scene *es = args->geometryUserPtr;
    const float *f = (const float *)(const void *)args->hit;
    const unsigned *id = (const unsigned *)(const void *)args->hit;
    unsigned n = args->N;
    for (unsigned i = 0; i < n; i++) {
        if (args->valid[i] == 0)
            continue;
        uint32_t tri = id[5 * n + i], material = es->material[tri];
        if (masked(es->source, material) && cut_out(es->source, material, tri, f[3 * n + i], f[4 * n + i]))
            args->valid[i] = 0;
    }
}

// Per triangle, its draw's material; NULL when no triangle is masked (or out of memory: *ok false).
static uint32_t *triangle_materials(const pn_scene *scene, bool *ok)
{
    *ok = true;
    bool any = false;
    for (uint32_t d = 0; d < scene->draw_count; d++)
        any |= masked(scene, scene->draws[d].material) && scene->draws[d].index_count >= 3;
    if (!any)
        return NULL;
    uint32_t n = pn_scene_triangle_count(scene);
    uint32_t *material = malloc((n ? n : 1) * sizeof *material);
    if (!material) {
        *ok = false;
        return NULL;
    }
    memset(material, 0xff, (n ? n : 1) * sizeof *material);
    for (uint32_t d = 0; d < scene->draw_count; d++) {
        const pn_draw *dr = &scene->draws[d];
        for (uint32_t k = dr->first_index; k + 2 < dr->first_index + dr->index_count && k / 3 < n; k += 3)
            material[k / 3] = dr->material;
    }
    return material;
}

pn_embree_scene *pn_embree_scene_create(pn_embree *e, const pn_scene *scene)
{
    return pn_embree_scene_create_desc(e, scene, &(pn_embree_scene_desc){0});
}

pn_embree_scene *pn_embree_scene_create_desc(pn_embree *e, const pn_scene *scene, const pn_embree_scene_desc *desc)
{
    pn_embree_scene *s = malloc(sizeof *s);
    if (!s)
        return NULL;
    bool ok = true;
    *s = (pn_embree_scene){.source = scene, .material = desc->opaque ? NULL : triangle_materials(scene, &ok)};
    // Embree built without filter functions (EMBREE_FILTER_FUNCTION off) would ignore the masks.
    if (!ok || (s->material && !rtcGetDeviceProperty(e->device, RTC_DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED))) {
        free(s->material);
        free(s);
        return NULL;
    }
    uint64_t t0 = pn_time_ns();
    RTCScene rs = rtcNewScene(e->device);
    RTCGeometry g = rs ? rtcNewGeometry(e->device, RTC_GEOMETRY_TYPE_TRIANGLE) : NULL;
    if (!g) {
        if (rs)
            rtcReleaseScene(rs);
        free(s->material);
        free(s);
        return NULL;
    }
    // pn_vertex is 32 bytes with the position first: a strided view of the scene's own vertices
    // (Embree's 16-byte loads of a position stay inside its vertex).
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, scene->vertices, 0, sizeof(pn_vertex),
                               scene->vertex_count);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, scene->indices, 0, 12,
                               scene->index_count / 3);
    if (s->material) {
        rtcSetGeometryUserData(g, s);
        rtcSetGeometryOccludedFilterFunction(g, occluded_filter);
    }
    rtcCommitGeometry(g);
    rtcAttachGeometry(rs, g);
    rtcReleaseGeometry(g);
    rtcSetSceneBuildQuality(rs, RTC_BUILD_QUALITY_HIGH);
    rtcCommitScene(rs);
    if (rtcGetDeviceError(e->device) != RTC_ERROR_NONE) { // e.g. out of memory while building
        rtcReleaseScene(rs);
        free(s->material);
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
    free(s->material);
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
