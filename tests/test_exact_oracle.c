// The exact modes against an independent tracer: exact (our BVH, walked per pixel as a packet and
// per ray, and its watertight tests) and, where the
// device has ray queries, rayquery (the driver's acceleration structure and triangle test). Embree 3 traces the very rays the GPU traced (same
// G-buffer origins and light samples, read back with --ray-dump) with rtcOccluded1 over the same
// triangles, and the two must agree on at least 99.99% of the rays. Every disagreement must be a
// ray that passes within a tiny distance of a triangle edge (where the watertight test and
// Embree's test may round differently): within 1e-5 of the scene's size, checked by brute force
// over all edges. Scenes: the bunny and Sponza, each with the ground plane render adds.

#include "apps/embree_peer.h"
#include "gpu/device.h"
#include "io/exr.h"
#include "scene/scene.h"
#include "test_util.h"

static double seg_seg_dist2(const double p1[3], const double q1[3], const double p2[3], const double q2[3])
{
    // Closest points of two segments (Ericson, Real-Time Collision Detection, 5.1.9), in double.
    double d1[3], d2[3], r[3];
    for (int k = 0; k < 3; k++)
        d1[k] = q1[k] - p1[k], d2[k] = q2[k] - p2[k], r[k] = p1[k] - p2[k];
    double a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2], e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2];
    double f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2];
    double s, t;
    if (a <= 1e-300 && e <= 1e-300) {
        s = t = 0;
    } else if (a <= 1e-300) {
        s = 0, t = fmin(fmax(f / e, 0), 1);
    } else {
        double c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2];
        if (e <= 1e-300) {
            t = 0, s = fmin(fmax(-c / a, 0), 1);
        } else {
            double b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2], den = a * e - b * b;
            s = den != 0 ? fmin(fmax((b * f - c * e) / den, 0), 1) : 0;
            t = (b * s + f) / e;
            if (t < 0)
                t = 0, s = fmin(fmax(-c / a, 0), 1);
            else if (t > 1)
                t = 1, s = fmin(fmax((b - c) / a, 0), 1);
        }
    }
    double d2s = 0;
    for (int k = 0; k < 3; k++) {
        double x = p1[k] + d1[k] * s - (p2[k] + d2[k] * t);
        d2s += x * x;
    }
    return d2s;
}

static double nearest_edge(const pn_scene *s, const double o[3], const double q[3])
{
    double best = 1e300;
    for (uint32_t i = 0; i < s->index_count; i += 3)
        for (int e = 0; e < 3; e++) {
            const float *a = s->vertices[s->indices[i + e]].pos, *b = s->vertices[s->indices[i + (e + 1) % 3]].pos;
            double pa[3] = {a[0], a[1], a[2]}, pb[3] = {b[0], b[1], b[2]};
            double d = seg_seg_dist2(o, q, pa, pb);
            best = d < best ? d : best;
        }
    return sqrt(best);
}

static void check_scene_at(const char *path, const char *name, const char *mode, const char *traversal, uint32_t want_spp,
                           uint32_t w, uint32_t h_px)
{
    const char *dump = pn_test_tmp("oracle_rays.bin"), *exr = pn_test_tmp("oracle.exr");
    char args[2048];
    snprintf(args, sizeof args, "render %s --mode %s --traversal %s --size %ux%u --spp %u --ray-dump %s -o %s", path, mode,
             traversal, w, h_px, want_spp, dump, exr);
    int rc = pn_test_run(args);
    CHECK_MSG(rc == 0, "render exited %d", rc);
    FILE *f = fopen(dump, "rb");
    uint32_t h[6] = {0};
    CHECK(f && fread(h, sizeof h, 1, f) == 1);
    CHECK(h[0] == 0x41524e50u && h[2] == w && h[3] == h_px && h[4] == want_spp);
    uint64_t px = (uint64_t)h[2] * h[3], spp = h[4], floats = px * 4 * (1 + spp);
    float *data = malloc(floats * sizeof(float));
    CHECK(data && f && fread(data, sizeof(float), floats, f) == floats);
    if (f)
        fclose(f);

    pn_scene scene;
    CHECK(pn_scene_load(path, &scene) == PN_OK);
    CHECK(pn_scene_add_ground(&scene, 6.0f) == PN_OK); // as render does by default
    pn_embree *embree = pn_embree_create();
    pn_embree_scene *rs = embree ? pn_embree_scene_create(embree, &scene) : NULL;
    CHECK_MSG(rs, "Embree could not start or build the scene");
    uint8_t *hit = malloc(px * spp);
    CHECK(hit);
    if (rs && hit && data)
        pn_embree_trace_dump(rs, data, px, (uint32_t)spp, 0, px, hit, NULL);

    double size = 0;
    for (int k = 0; k < 3; k++)
        size = fmax(size, scene.bounds_max[k] - scene.bounds_min[k]);
    uint64_t rays = 0, agree = 0, gpu_only = 0, embree_only = 0, far_from_edge = 0, blocked = 0;
    double worst = 0;
    for (uint64_t p = 0; p < px && data && rs && hit; p++) {
        const float *o = data + 4 * p;
        if (o[3] != 1.0f)
            continue;
        for (uint64_t k = 0; k < spp; k++) {
            const float *q = data + 4 * (px + p * spp + k);
            uint32_t flags;
            memcpy(&flags, &q[3], 4);
            if (!(flags & 1))
                continue;
            bool e = hit[p * spp + k], gpu = (flags & 2) != 0;
            rays++;
            blocked += gpu;
            if (e == gpu) {
                agree++;
                continue;
            }
            gpu_only += gpu, embree_only += e;
            double od[3] = {o[0], o[1], o[2]}, qd[3] = {q[0], q[1], q[2]};
            double dist = nearest_edge(&scene, od, qd) / size;
            worst = dist > worst ? dist : worst;
            far_from_edge += dist > 1e-5;
        }
    }
    fprintf(stderr, "%s (%s, %u spp, %ux%u) %s: %llu rays (%llu blocked), Embree agrees on %llu (%.5f%%); blocked only on the GPU %llu, only "
                    "in Embree %llu; the farthest of those from an edge: %.2e of the scene size\n",
            mode, traversal, want_spp, w, h_px, name, (unsigned long long)rays, (unsigned long long)blocked, (unsigned long long)agree,
            rays ? 100.0 * agree / rays : 0, (unsigned long long)gpu_only, (unsigned long long)embree_only, worst);
    CHECK(rays > 100000 && blocked > rays / 50);
    CHECK_MSG(agree * 10000 >= rays * 9999, "%s: agreement below 99.99%%", name);
    CHECK_MSG(far_from_edge == 0, "%s: %llu disagreeing rays pass farther than 1e-5 from every edge", name,
              (unsigned long long)far_from_edge);
    pn_embree_scene_destroy(rs);
    pn_embree_destroy(embree);
    free(hit);
    pn_scene_destroy(&scene);
    free(data);
}

static void check_scene(const char *path, const char *name, const char *mode, const char *traversal, uint32_t want_spp)
{
    check_scene_at(path, name, mode, traversal, want_spp, 128, 128);
}

int main(void)
{
    const char *assets = pn_test_env("PN_ASSETS", "../shared/assets");
    char bunny[1024], sponza[1024];
    snprintf(bunny, sizeof bunny, "%s/stanford-bunny-69k.glb", assets);
    snprintf(sponza, sizeof sponza, "%s/dabrovic-sponza-66k.glb", assets);
    FILE *f = fopen(bunny, "rb");
    if (!f)
        TEST_SKIP("%s missing (../shared/assets not beside the project)", bunny);
    fclose(f);
    // exact both ways: the packet walk (the default) and each ray alone. The packet walk's pipeline
    // is sized to a dispatch's rays (PN_SPEC_PACKET_RAYS): 13 spp runs the one for 16 rays, 40 spp
    // a chunk of 32 and one of 8 on the pipeline for 32 (a pixel walking alone).
    check_scene(bunny, "bunny", "exact", "packet", 16);
    check_scene(sponza, "sponza", "exact", "packet", 16);
    check_scene(bunny, "bunny", "exact", "packet", 13);
    check_scene(bunny, "bunny", "exact", "packet", 40);
    // At 1-16 rays a pixel the packet walk is shared by a block of pixels (exact.glsl:
    // bvh_tile_blocked): 4 x 2 at 1 spp (8 rays a block), at 3 spp on the pipeline for 4 rays
    // (slots left empty) and at 4 (32 rays), 2 x 2 at 8, 2 x 1 at 13 (above) and 16; on sizes
    // that are no multiple of the block (blocks cut by the image's edge).
    check_scene_at(bunny, "bunny", "exact", "packet", 1, 404, 398);
    check_scene_at(bunny, "bunny", "exact", "packet", 3, 245, 229);
    check_scene_at(sponza, "sponza", "exact", "packet", 4, 190, 187);
    check_scene_at(bunny, "bunny", "exact", "packet", 8, 161, 141);
    check_scene_at(bunny, "bunny", "exact", "packet", 16, 113, 103);
    check_scene(bunny, "bunny", "exact", "ray", 16);
    check_scene(sponza, "sponza", "exact", "ray", 16);
    // exact by projection (--traversal project): every sample's answer from the triangles projected
    // onto the light, with the packet walk's test; 40 spp on the pipeline for 64 samples; and with
    // the budget run out at once, the samples left traced by the packet walk.
    check_scene(bunny, "bunny", "exact", "project", 16);
    check_scene(sponza, "sponza", "exact", "project", 40);
    setenv("PN_PROJECT_BUDGET", "0.001", 1);
    check_scene(bunny, "bunny", "exact", "project", 16);
    unsetenv("PN_PROJECT_BUDGET");
    // rayquery where the device has ray queries (Mesa 25's lavapipe does, 22.3's does not).
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    bool made = pn_gpu_device_create(&desc, &dev) == PN_OK;
    bool rq = made && dev.ray_query, rt = made && dev.ray_pipeline;
    pn_gpu_device_destroy(&dev);
    if (rq) {
        check_scene(bunny, "bunny", "rayquery", "auto", 16);
        check_scene(sponza, "sponza", "rayquery", "auto", 16);
    } else {
        fprintf(stderr, "rayquery: skipped, the device has no VK_KHR_ray_query (PN_MESA=stock, Mesa 22.3)\n");
    }
    // rtpipeline, the same structure through the device's ray-tracing pipeline.
    if (rt) {
        check_scene(bunny, "bunny", "rtpipeline", "auto", 16);
        check_scene(sponza, "sponza", "rtpipeline", "auto", 16);
    } else {
        fprintf(stderr, "rtpipeline: skipped, the device has no VK_KHR_ray_tracing_pipeline (PN_MESA=stock, Mesa 22.3)\n");
    }
    return pn_test_result();
}
