// libFuzzer target: the public API's array entry points (engine/api), the parts that touch no
// device: a scene from arrays (pn_api_scene_arrays, what penumbra_scene_create runs after its
// context check), objects moved by transform, the scene's lights, lights and points as
// penumbra_visibility checks them. The input is read as up to 4 meshes, each a header (vertex and
// index counts, flags for a transform and an alpha mask) and then floats and indices taken from
// the bytes that follow (zeros once they run out), so that counts, indices and values are all
// the fuzzer's.
//
// Beyond "no crash, no leak, no UB":
//   - a mesh the header's rules refuse (no vertices, an index count not a positive multiple of 3,
//     an index out of range, a non-finite or out-of-range coordinate, a mask without cutoff) fails
//     the whole scene; a scene that is made has as many triangles as its meshes, and its bounds
//     hold every vertex a triangle uses;
//   - set_transform either moves the object or leaves the scene's bounds exactly as they were;
//   - a light that is accepted has a unit normal and up (to 1e-5) and a frame;
//   - points are accepted exactly when every coordinate is finite, within 1e18, and every normal
//     finite and non-zero.
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "api/api_internal.h"
#include "core/log.h"
#include "fuzz_util.h"
#include "scene/light.h"

typedef struct reader {
    const uint8_t *d;
    size_t n, at;
} reader;

static uint8_t u8(reader *r) { return r->at < r->n ? r->d[r->at++] : 0; }
static uint32_t u32(reader *r)
{
    uint32_t v = 0;
    for (int k = 0; k < 4; k++)
        v |= (uint32_t)u8(r) << (8 * k);
    return v;
}
static float f32(reader *r)
{
    uint32_t b = u32(r);
    float f;
    memcpy(&f, &b, sizeof f);
    return f;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!getenv("PN_FUZZ_VERBOSE"))
        pn_log_set_level(PN_LOG_QUIET);
    reader r = {data, size, 0};
    uint32_t mesh_count = u8(&r) % 5; // 0 too: refused
    penumbra_mesh_desc meshes[4];
    float *pos[4] = {0}, *uvs[4] = {0}, tr[4][12];
    uint32_t *idx[4] = {0};
    uint8_t *alpha[4] = {0};
    uint64_t triangles = 0;
    for (uint32_t m = 0; m < mesh_count; m++) {
        uint8_t flags = u8(&r);
        uint32_t vc = u8(&r) % 33, ic = u8(&r) % 49;
        pos[m] = malloc(3 * (vc ? vc : 1) * sizeof(float));
        idx[m] = malloc((ic ? ic : 1) * sizeof(uint32_t));
        for (uint32_t k = 0; k < 3 * vc; k++) {
            // Small values mostly (a scene to build), the raw bits now and then (NaN, 1e30, denormals).
            pos[m][k] = (flags & 8) ? f32(&r) : (float)(int8_t)u8(&r) / 8.0f;
        }
        for (uint32_t k = 0; k < ic; k++) {
            idx[m][k] = (flags & 16) ? u32(&r) : u8(&r) % (vc + 2);
        }
        triangles += ic / 3;
        meshes[m] = (penumbra_mesh_desc){.positions = pos[m], .vertex_count = vc, .indices = idx[m], .index_count = ic};
        if (flags & 1) {
            for (int k = 0; k < 12; k++)
                tr[m][k] = (flags & 32) ? f32(&r) : (float)(int8_t)u8(&r) / 16.0f;
            meshes[m].transform = tr[m];
        }
        if (flags & 2) {
            uint32_t w = u8(&r) % 5, h = u8(&r) % 5;
            uvs[m] = malloc(2 * (vc ? vc : 1) * sizeof(float));
            alpha[m] = malloc((w * h) ? w * h : 1);
            for (uint32_t k = 0; k < 2 * vc; k++)
                uvs[m][k] = (float)(int8_t)u8(&r) / 32.0f;
            for (uint32_t k = 0; k < w * h; k++)
                alpha[m][k] = u8(&r);
            float cutoff = (float)u8(&r) / 200.0f;
            meshes[m].uvs = uvs[m], meshes[m].alpha = alpha[m];
            meshes[m].alpha_width = w, meshes[m].alpha_height = h, meshes[m].alpha_cutoff = cutoff;
        }
    }
    penumbra_scene *s = pn_api_scene_new(NULL, "fuzz");
    REQUIRE(s);
    pn_result res = pn_api_scene_arrays(s, meshes, mesh_count);
    bool rule_broken = mesh_count == 0;
    for (uint32_t m = 0; m < mesh_count; m++) {
        const penumbra_mesh_desc *d = &meshes[m];
        rule_broken = rule_broken || d->vertex_count == 0 || d->index_count == 0 || d->index_count % 3;
        for (uint32_t k = 0; k < d->index_count; k++)
            rule_broken = rule_broken || d->indices[k] >= d->vertex_count;
        for (uint32_t k = 0; k < 3 * d->vertex_count; k++)
            rule_broken = rule_broken || !isfinite(d->positions[k]) || fabsf(d->positions[k]) > 1e18f;
    }
    if (rule_broken)
        REQUIRE(res != PN_OK);
    if (res == PN_OK) {
        penumbra_scene_info info;
        REQUIRE(penumbra_scene_get_info(s, &info) == PENUMBRA_OK);
        REQUIRE(info.triangle_count == triangles && info.object_count == mesh_count);
        for (uint32_t i = 0; i < s->scene.index_count; i++) { // the bounds are the triangles' vertices'
            const float *x = s->scene.vertices[s->scene.indices[i]].pos;
            for (int k = 0; k < 3; k++)
                REQUIRE(x[k] >= info.bounds_min[k] && x[k] <= info.bounds_max[k]);
        }
        // A move, then the lights render would use, then a light and points from the input.
        float t[12];
        for (int k = 0; k < 12; k++)
            t[k] = (u8(&r) & 1) ? f32(&r) : (float)(int8_t)u8(&r) / 16.0f;
        float lo[3], hi[3];
        memcpy(lo, s->scene.bounds_min, sizeof lo), memcpy(hi, s->scene.bounds_max, sizeof hi);
        if (penumbra_scene_set_transform(s, u8(&r) % (mesh_count + 1), t) != PENUMBRA_OK)
            REQUIRE(!memcmp(lo, s->scene.bounds_min, sizeof lo) && !memcmp(hi, s->scene.bounds_max, sizeof hi));
        penumbra_light lights[2];
        uint32_t count = 0;
        if (penumbra_scene_lights(s, lights, 2, &count) == PENUMBRA_OK)
            REQUIRE(count == 1);
        penumbra_light in = {.kind = (penumbra_light_kind)(u8(&r) % 6)};
        float *fields[] = {in.position, in.normal, in.up};
        for (int f = 0; f < 3; f++)
            for (int k = 0; k < 3; k++)
                fields[f][k] = (u8(&r) & 1) ? f32(&r) : (float)(int8_t)u8(&r) / 16.0f;
        in.size[0] = (float)u8(&r) / 16, in.size[1] = (float)u8(&r) / 16;
        in.radius = (float)(int8_t)u8(&r) / 16, in.angle = (float)u8(&r) / 1000;
        in.cone[0] = (float)u8(&r) / 100, in.cone[1] = (float)u8(&r) / 100, in.range = (float)(int8_t)u8(&r);
        pn_light out;
        if (pn_api_light_in(&in, 0, &s->scene, &out)) {
            float tb[3], bt[3];
            double ln = sqrt((double)out.normal[0] * out.normal[0] + (double)out.normal[1] * out.normal[1] +
                             (double)out.normal[2] * out.normal[2]);
            double lu = sqrt((double)out.up[0] * out.up[0] + (double)out.up[1] * out.up[1] + (double)out.up[2] * out.up[2]);
            REQUIRE(fabs(ln - 1) < 1e-5 && fabs(lu - 1) < 1e-5 && pn_light_frame(&out, tb, bt));
        }
        float pts[2][3], nrm[2][3];
        bool ok = true;
        for (int i = 0; i < 2; i++)
            for (int k = 0; k < 3; k++) {
                pts[i][k] = f32(&r), nrm[i][k] = (float)(int8_t)u8(&r);
                ok = ok && isfinite(pts[i][k]) && fabsf(pts[i][k]) <= 1e18f;
            }
        for (int i = 0; i < 2; i++)
            ok = ok && (nrm[i][0] != 0 || nrm[i][1] != 0 || nrm[i][2] != 0);
        REQUIRE((pn_api_points_in(&pts[0][0], &nrm[0][0], 2) == PN_OK) == ok);
    }
    pn_api_scene_free(s);
    for (int m = 0; m < 4; m++)
        free(pos[m]), free(idx[m]), free(uvs[m]), free(alpha[m]);
    return 0;
}
