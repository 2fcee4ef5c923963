// Clusters in the G-buffer pass (gpu/gbuffer_clusters.h): what a frame skips, and that skipping it
// leaves the picture as it was.
//  1. The choice: a finely cut sphere (closed, wound outwards: it culls its back faces) over an
//     open ground grid (it does not): seen from outside, clusters of the sphere's far side are
//     skipped and none of its near side's; looking away, nothing is kept; the ground keeps every
//     cluster in view (no back-face skip for an open mesh).
//     The margins on a cluster made here: the frustum's 2 pixels and the cone's slack.
//  2. Rendered: P, N and albedo at every pixel bit for bit against the same renderer drawing every
//     triangle (pn_gbuffer_pass.draw_all), from outside, close up with most of the sphere off the
//     image (the frustum skips there), grazing along the ground, from inside the sphere (no back
//     faces skipped), and after a move of the sphere's vertices into a part of the view its old
//     bounds were outside of (bounds not taken again would skip it).
#include <math.h>
#include <string.h>

#include "gpu/gbuffer_clusters.h"
#include "gpu/renderer.h"
#include "test_util.h"

enum { SIZE = 96, RINGS = 48, SEGMENTS = 96, GRID = 64 };

// A UV sphere of radius r at c, counter-clockwise seen from outside, as draw 0.
static void add_sphere(pn_scene *s, const float c[3], float r, uint32_t m)
{
    uint32_t nv = (RINGS + 1) * SEGMENTS, ni = 0;
    pn_vertex *v = calloc(nv, sizeof *v);
    uint32_t *idx = malloc(6u * RINGS * SEGMENTS * sizeof *idx);
    CHECK(v && idx);
    for (uint32_t i = 0; i <= RINGS; i++)
        for (uint32_t j = 0; j < SEGMENTS; j++) {
            double th = 3.14159265358979323846 * i / RINGS, ph = 2 * 3.14159265358979323846 * j / SEGMENTS;
            double st = i == 0 || i == RINGS ? 0.0 : sin(th), ct = i == 0 ? 1.0 : i == RINGS ? -1.0 : cos(th);
            double d[3] = {st * cos(ph), ct, st * sin(ph)}; // the poles one point each, exactly
            pn_vertex *p = &v[i * SEGMENTS + j];
            for (int k = 0; k < 3; k++)
                p->pos[k] = c[k] + r * (float)d[k], p->normal[k] = (float)d[k];
        }
    // The poles' rings are one point each (welded by position, so the surface is closed); the
    // zero-area triangles there are left out.
    for (uint32_t i = 0; i < RINGS; i++)
        for (uint32_t j = 0; j < SEGMENTS; j++) {
            uint32_t a = i * SEGMENTS + j, b = i * SEGMENTS + (j + 1) % SEGMENTS, a2 = a + SEGMENTS, b2 = b + SEGMENTS;
            if (i > 0)
                idx[ni++] = a, idx[ni++] = b, idx[ni++] = a2;
            if (i + 1 < RINGS)
                idx[ni++] = b, idx[ni++] = b2, idx[ni++] = a2;
        }
    CHECK(pn_scene_add_mesh(s, v, nv, idx, ni, m) == PN_OK);
    free(v), free(idx);
}

// The ground: a GRID x GRID grid at y = 0 over [-h, h]^2, facing up (open: never culls), as draw 1.
static void add_ground(pn_scene *s, float h, uint32_t m)
{
    uint32_t nv = (GRID + 1) * (GRID + 1), ni = 0;
    pn_vertex *v = calloc(nv, sizeof *v);
    uint32_t *idx = malloc(6u * GRID * GRID * sizeof *idx);
    CHECK(v && idx);
    for (uint32_t i = 0; i <= GRID; i++)
        for (uint32_t j = 0; j <= GRID; j++) {
            pn_vertex *p = &v[i * (GRID + 1) + j];
            p->pos[0] = -h + 2 * h * (float)j / GRID, p->pos[2] = -h + 2 * h * (float)i / GRID, p->normal[1] = 1;
        }
    for (uint32_t i = 0; i < GRID; i++)
        for (uint32_t j = 0; j < GRID; j++) {
            uint32_t a = i * (GRID + 1) + j, b = a + 1, a2 = a + GRID + 1, b2 = a2 + 1;
            idx[ni++] = a, idx[ni++] = a2, idx[ni++] = b;
            idx[ni++] = b, idx[ni++] = a2, idx[ni++] = b2;
        }
    CHECK(pn_scene_add_mesh(s, v, nv, idx, ni, m) == PN_OK);
    free(v), free(idx);
}

// Triangles of draw d kept for cam (and the runs' count through *runs).
static uint64_t kept(const pn_renderer *ren, uint32_t d, const pn_camera *cam, uint32_t *runs)
{
    const pn_gbuffer_pass *g = &ren->gbuffer;
    pn_gbuffer_push push = pn_gbuffer_camera(g, cam, SIZE, SIZE);
    uint64_t k = 0;
    *runs = pn_gbuffer_clusters_runs(&g->clusters, d, &push, SIZE, SIZE, pn_gbuffer_pass_culls(g, d, &push), g->runs, &k);
    return k;
}

// The G-buffer from cam with the clusters skipped as chosen, against every triangle drawn.
static void check_same(pn_renderer *ren, const pn_camera *cam, const char *what)
{
    pn_light light = {.kind = PN_LIGHT_RECT, .pos = {0, 20, 0}, .normal = {0, -1, 0}, .up = {0, 0, 1}, .size = {1, 1},
                      .radiance = {1, 1, 1}};
    pn_frame_times times;
    size_t n = 4u * SIZE * SIZE;
    float *ref = malloc(3 * n * sizeof *ref);
    CHECK(ref);
    pn_frame_images img;
    ren->gbuffer.draw_all = true;
    CHECK_MSG(pn_renderer_render(ren, cam, &light, &times) == PN_OK, "%s: render, every triangle", what);
    pn_renderer_images(ren, &img);
    memcpy(ref, img.p, n * sizeof *ref), memcpy(ref + n, img.n, n * sizeof *ref),
        memcpy(ref + 2 * n, img.albedo, n * sizeof *ref);
    ren->gbuffer.draw_all = false;
    CHECK_MSG(pn_renderer_render(ren, cam, &light, &times) == PN_OK, "%s: render, clusters skipped", what);
    pn_renderer_images(ren, &img);
    const float *got[3] = {img.p, img.n, img.albedo};
    int covered = 0, bad = 0;
    for (size_t i = 0; i < (size_t)SIZE * SIZE; i++) {
        covered += ref[4 * i + 3] > 0;
        bool same = true;
        for (int t = 0; t < 3; t++)
            same = same && memcmp(got[t] + 4 * i, ref + t * n + 4 * i, 4 * sizeof(float)) == 0;
        if (!same && bad++ < 4)
            fprintf(stderr, "%s: pixel (%zu, %zu): P (%g, %g, %g) w %g, every triangle drawn: (%g, %g, %g) w %g\n", what,
                    i % SIZE, i / SIZE, (double)img.p[4 * i], (double)img.p[4 * i + 1], (double)img.p[4 * i + 2],
                    (double)img.p[4 * i + 3], (double)ref[4 * i], (double)ref[4 * i + 1], (double)ref[4 * i + 2],
                    (double)ref[4 * i + 3]);
    }
    CHECK_MSG(bad == 0, "%s: %d pixels differ from every triangle drawn", what, bad);
    CHECK_MSG(covered > SIZE * SIZE / 8, "%s: only %d pixels covered: the view misses the scene", what, covered);
    free(ref);
}

int main(void)
{
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK)
        TEST_SKIP("no Vulkan device");
    pn_scene s;
    memset(&s, 0, sizeof s);
    snprintf(s.name, sizeof s.name, "sphere on a grid");
    uint32_t m;
    CHECK(pn_scene_add_material(&s, (float[4]){0.5f, 0.6f, 0.7f, 1}, &m) == PN_OK);
    s.materials[m].double_sided = false; // glTF's default: the sphere culls its back faces
    add_sphere(&s, (float[3]){0, 1, 0}, 1, m);
    add_ground(&s, 4, m);
    pn_scene_update_bounds(&s);
    pn_renderer_desc rd = {.width = SIZE, .height = SIZE, .mode = PN_SHADOW_NONE, .spp = 1};
    pn_renderer ren;
    if (pn_renderer_create(&dev, &s, &rd, &ren) != PN_OK) {
        CHECK_MSG(false, "renderer");
        pn_scene_destroy(&s);
        pn_gpu_device_destroy(&dev);
        return pn_test_result();
    }
    const uint64_t sphere = s.draws[0].index_count / 3, ground = s.draws[1].index_count / 3;
    CHECK_MSG(ren.gbuffer.cull[0].closed && !ren.gbuffer.cull[1].closed, "the sphere must cull, the ground not");

    // 1. The choice.
    const pn_camera outside = {.pos = {4, 3, 5}, .target = {0, 1, 0}, .up = {0, 1, 0}, .yfov_deg = 45};
    const pn_camera away = {.pos = {4, 3, 5}, .target = {8, 3, 10}, .up = {0, 1, 0}, .yfov_deg = 45};
    const pn_camera close = {.pos = {1.2f, 1.4f, 1.6f}, .target = {0.9f, 1.5f, 0.2f}, .up = {0, 1, 0}, .yfov_deg = 30};
    const pn_camera graze = {.pos = {-3.9f, 0.05f, -3.9f}, .target = {4, 0.02f, 4}, .up = {0, 1, 0}, .yfov_deg = 60};
    const pn_camera inside = {.pos = {0.2f, 1.1f, 0.1f}, .target = {-1, 1, 0.3f}, .up = {0, 1, 0}, .yfov_deg = 90};
    uint32_t runs;
    uint64_t k = kept(&ren, 0, &outside, &runs);
    // About half the sphere faces away; its clusters straddling the silhouette are kept.
    CHECK_MSG(k < sphere * 4 / 5 && k > sphere / 3 && runs > 0, "outside: %llu of the sphere's %llu triangles kept",
              (unsigned long long)k, (unsigned long long)sphere);
    // From below, the whole ground in view and facing away: an open mesh keeps all of it.
    const pn_camera below = {.pos = {0, -10, 0.01f}, .target = {0, 0, 0}, .up = {0, 1, 0}, .yfov_deg = 45};
    k = kept(&ren, 1, &below, &runs);
    CHECK_MSG(k == ground && runs == 1, "from below: %llu of the ground's %llu triangles kept in %u runs",
              (unsigned long long)k, (unsigned long long)ground, runs);
    CHECK_MSG(kept(&ren, 0, &away, &runs) == 0 && runs == 0, "looking away: the sphere kept");
    k = kept(&ren, 0, &close, &runs);
    CHECK_MSG(k < sphere / 3, "close up: %llu of the sphere's %llu triangles kept", (unsigned long long)k,
              (unsigned long long)sphere);
    pn_gbuffer_push in_push = pn_gbuffer_camera(&ren.gbuffer, &inside, SIZE, SIZE);
    CHECK_MSG(!pn_gbuffer_pass_culls(&ren.gbuffer, 0, &in_push), "inside: the sphere's back faces are its front");

    // The margins, on one cluster made here, seen from the origin along -z (90 degrees: x / -z is
    // the normalised x): a box half a pixel beyond the image's right edge is kept (the rasterizer's
    // rounding may reach it), 3 pixels beyond skipped; a cluster facing away by 0.3 degrees (within
    // the cone's 2^-7 rad slack) is kept, by 1 degree skipped, one facing the eye by 1 degree kept.
    {
        const pn_camera origin = {.pos = {0, 0, 0}, .target = {0, 0, -1}, .up = {0, 1, 0}, .yfov_deg = 90};
        pn_gbuffer_push push = pn_gbuffer_camera(&ren.gbuffer, &origin, SIZE, SIZE);
        pn_gbuffer_cluster one = {.index_count = 3, .radius = 1e-3f, .cutoff = 1.0f};
        uint32_t first[2] = {0, 1};
        pn_gbuffer_clusters c = {.items = &one, .first = first, .draw_count = 1};
        pn_gbuffer_run run;
        uint64_t k1;
        const double pixel = 2.0 / SIZE;
        const double beyond[2] = {0.5, 3.0}; // pixels
        for (int i = 0; i < 2; i++) {
            float x = (float)(10 * (1 + beyond[i] * pixel));
            one.min[0] = x, one.max[0] = x + 0.01f, one.min[1] = -0.1f, one.max[1] = 0.1f, one.min[2] = -10, one.max[2] = -10;
            uint32_t n = pn_gbuffer_clusters_runs(&c, 0, &push, SIZE, SIZE, false, &run, &k1);
            CHECK_MSG(n == (i == 0 ? 1u : 0u), "a box %.1f pixels beyond the image's edge: %u runs", beyond[i], n);
        }
        one.min[0] = -0.1f, one.max[0] = 0.1f; // in view: the facing alone decides
        const double tilt[3] = {0.3, 1.0, -1.0}; // degrees from edge-on, facing away (> 0)
        const uint32_t want[3] = {1, 0, 1};
        for (int i = 0; i < 3; i++) {
            double t = tilt[i] * 3.14159265358979323846 / 180;
            one.center[0] = 0, one.center[1] = 0, one.center[2] = -10;
            one.axis[0] = (float)cos(t), one.axis[1] = 0, one.axis[2] = (float)-sin(t); // . (0, 0, -1) = sin(t)
            one.cutoff = 0; // one normal
            uint32_t n = pn_gbuffer_clusters_runs(&c, 0, &push, SIZE, SIZE, true, &run, &k1);
            CHECK_MSG(n == want[i], "a cluster %.1f degrees from edge-on: %u runs, expected %u", tilt[i], n, want[i]);
        }
    }

    // 2. Rendered, bit for bit.
    check_same(&ren, &outside, "outside");
    check_same(&ren, &close, "close up");
    check_same(&ren, &graze, "grazing the ground");
    check_same(&ren, &inside, "inside the sphere");
    check_same(&ren, &below, "from below");
    // The sphere moved 6 to the side, into a narrow view its old bounds lie wholly outside of:
    // bounds not taken again would skip it there.
    const pn_camera moved_view = {.pos = {4, 3, 5}, .target = {-6, 1, 0}, .up = {0, 1, 0}, .yfov_deg = 20};
    CHECK_MSG(kept(&ren, 0, &moved_view, &runs) == 0, "the sphere in the narrow view before its move");
    uint32_t sphere_vertices = (RINGS + 1) * SEGMENTS;
    for (uint32_t i = 0; i < sphere_vertices; i++)
        s.vertices[i].pos[0] -= 6;
    pn_scene_update_bounds(&s);
    CHECK(pn_renderer_update_vertices(&ren, &s, 0, sphere_vertices) == PN_OK);
    CHECK_MSG(kept(&ren, 0, &moved_view, &runs) > 0, "the moved sphere skipped");
    check_same(&ren, &moved_view, "after the move");

    pn_renderer_destroy(&ren);
    pn_scene_destroy(&s);
    pn_gpu_device_destroy(&dev);
    return pn_test_result();
}
