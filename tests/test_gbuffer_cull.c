// Back faces in the G-buffer pass (gpu/gbuffer_cull.h): which draws cull them, and that culling
// leaves the picture as it was.
//  1. The analysis on cubes built here: closed and wound outwards (shared vertices; split per
//     face, welded by position; far from the origin; with a degenerate triangle) culls; a missing
//     triangle, a flipped one, a cube wound inwards, a second part wound inwards beside a larger
//     outward one, an alpha-masked or a double-sided material do not.
//  2. The per-frame test: an eye outside the box culls, inside it or with a corner of the box
//     before the near plane (or within the margin of its rounding) does not; a mirroring move turns culling off.
//  3. Rendered (the raster pass itself): a closed cube seen from outside, from inside, and mirrored
//     by a move of its vertices, its P at every pixel against the first hit of the pixel's ray on the
//     box computed here (slabs, in double). Culling that removed visible faces (from inside, or
//     the mirrored cube's, or the wrong winding) leaves pixels uncovered or shows the far side.
#include <math.h>
#include <string.h>

#include "gpu/gbuffer_cull.h"
#include "gpu/renderer.h"
#include "test_util.h"

enum { SIZE = 64 };

// The unit cube's corners (i bit k: coordinate k at hi) and its faces, counter-clockwise seen
// from outside.
static const int FACES[6][4] = {
    {0, 4, 6, 2}, {1, 3, 7, 5}, // x = lo, x = hi
    {0, 1, 5, 4}, {2, 6, 7, 3}, // y = lo, y = hi
    {0, 2, 3, 1}, {4, 5, 7, 6}, // z = lo, z = hi
};

typedef struct cube_opts {
    double lo[3], hi[3];
    bool split;     // four vertices per face instead of eight shared
    bool inward;    // every triangle wound the other way
    int drop;       // a triangle left out (-1: none)
    int flip;       // a triangle wound the other way (-1: none)
    bool degenerate; // a zero-area triangle added
} cube_opts;

// Appends the cube to s as one draw of material m.
static void add_cube(pn_scene *s, const cube_opts *o, uint32_t m)
{
    pn_vertex v[24];
    uint32_t idx[40], nv = 0, ni = 0;
    memset(v, 0, sizeof v);
    for (int i = 0; i < (o->split ? 24 : 8); i++) {
        int corner = o->split ? FACES[i / 4][i % 4] : i;
        for (int k = 0; k < 3; k++)
            v[i].pos[k] = (float)(corner >> k & 1 ? o->hi[k] : o->lo[k]);
        v[i].normal[1] = 1;
        nv++;
    }
    for (int f = 0; f < 6; f++) {
        uint32_t q[4];
        for (int i = 0; i < 4; i++)
            q[i] = o->split ? (uint32_t)(4 * f + i) : (uint32_t)FACES[f][i];
        const uint32_t tri[2][3] = {{q[0], q[1], q[2]}, {q[0], q[2], q[3]}};
        for (int t = 0; t < 2; t++) {
            int number = 2 * f + t;
            if (number == o->drop)
                continue;
            bool flip = o->inward != (number == o->flip);
            idx[ni++] = tri[t][0], idx[ni++] = tri[t][flip ? 2 : 1], idx[ni++] = tri[t][flip ? 1 : 2];
        }
    }
    if (o->degenerate)
        idx[ni++] = 0, idx[ni++] = 0, idx[ni++] = o->split ? 1 : 4;
    CHECK(pn_scene_add_mesh(s, v, nv, idx, ni, m) == PN_OK);
}

static void new_scene(pn_scene *s, float alpha_cutoff, uint32_t *m)
{
    memset(s, 0, sizeof *s);
    snprintf(s->name, sizeof s->name, "cube");
    CHECK(pn_scene_add_material(s, (float[4]){0.5f, 0.5f, 0.5f, 1}, m) == PN_OK);
    s->materials[*m].alpha_cutoff = alpha_cutoff;
    s->materials[*m].double_sided = false; // as glTF's default material
}

// Whether the analysis lets draw `draw` of s cull.
static bool culls(const pn_scene *s, uint32_t draw)
{
    pn_gbuffer_cull c;
    CHECK(pn_gbuffer_cull_analyse(s, &s->draws[draw], &c) == PN_OK);
    return c.closed && c.outward;
}

static bool cube_culls(const cube_opts *o, float alpha_cutoff)
{
    pn_scene s;
    uint32_t m;
    new_scene(&s, alpha_cutoff, &m);
    add_cube(&s, o, m);
    bool r = culls(&s, 0);
    pn_scene_destroy(&s);
    return r;
}

static void check_analysis(void)
{
    const cube_opts base = {.lo = {-1, -1, -1}, .hi = {1, 1, 1}, .drop = -1, .flip = -1};
    cube_opts o = base;
    CHECK_MSG(cube_culls(&o, 0), "a closed outward cube does not cull");
    o.split = true;
    CHECK_MSG(cube_culls(&o, 0), "a closed outward cube with vertices per face does not cull");
    o = base, o.degenerate = true;
    CHECK_MSG(cube_culls(&o, 0), "a closed cube with a degenerate triangle does not cull");
    o = base;
    for (int k = 0; k < 3; k++)
        o.lo[k] = 1e6 + 0.25 * k, o.hi[k] = 1e6 + 0.25 * k + 0.5; // 0.5 wide at 1e6: 8 ulps
    CHECK_MSG(cube_culls(&o, 0), "a closed cube at 1e6 does not cull");
    o = base, o.drop = 5;
    CHECK_MSG(!cube_culls(&o, 0), "a cube without a triangle culls");
    o = base, o.split = true, o.drop = 0;
    CHECK_MSG(!cube_culls(&o, 0), "a split cube without a triangle culls");
    o = base, o.flip = 7;
    CHECK_MSG(!cube_culls(&o, 0), "a cube with a flipped triangle culls");
    o = base, o.inward = true;
    CHECK_MSG(!cube_culls(&o, 0), "a cube wound inwards culls");
    o = base;
    CHECK_MSG(!cube_culls(&o, 0.5f), "an alpha-masked cube culls");
    pn_scene ds;
    uint32_t dm;
    new_scene(&ds, 0, &dm);
    ds.materials[dm].double_sided = true;
    add_cube(&ds, &base, dm);
    CHECK_MSG(!culls(&ds, 0), "a double-sided cube culls");
    pn_scene_destroy(&ds);
    // Two parts in one draw: a large outward cube and a small inward one beside it. Their total
    // volume is positive; the small one's faces seen from outside are back faces.
    pn_scene s;
    uint32_t m;
    new_scene(&s, 0, &m);
    pn_vertex v[16];
    uint32_t idx[72], ni = 0;
    memset(v, 0, sizeof v);
    for (int part = 0; part < 2; part++)
        for (int i = 0; i < 8; i++)
            for (int k = 0; k < 3; k++)
                v[8 * part + i].pos[k] = part == 0 ? (i >> k & 1 ? 2.0f : -2.0f) : (i >> k & 1 ? 5.5f : 4.5f);
    for (int part = 0; part < 2; part++)
        for (int f = 0; f < 6; f++) {
            const int *q = FACES[f];
            const int tri[2][3] = {{q[0], q[1], q[2]}, {q[0], q[2], q[3]}};
            for (int t = 0; t < 2; t++) {
                idx[ni++] = (uint32_t)(8 * part + tri[t][0]);
                idx[ni++] = (uint32_t)(8 * part + tri[t][part ? 2 : 1]);
                idx[ni++] = (uint32_t)(8 * part + tri[t][part ? 1 : 2]);
            }
        }
    CHECK(pn_scene_add_mesh(&s, v, 16, idx, ni, m) == PN_OK);
    CHECK_MSG(!culls(&s, 0), "an outward cube beside an inward one culls");
    pn_scene_destroy(&s);
}

static void check_frame_test(void)
{
    pn_scene s;
    uint32_t m;
    new_scene(&s, 0, &m);
    add_cube(&s, &(cube_opts){.lo = {-1, -1, -1}, .hi = {1, 1, 1}, .drop = -1, .flip = -1}, m);
    pn_gbuffer_cull c;
    CHECK(pn_gbuffer_cull_analyse(&s, &s.draws[0], &c) == PN_OK);
    const float fwd[3] = {0, 0, -1};
    CHECK_MSG(pn_gbuffer_cull_back(&c, (float[3]){0, 0, 5}, fwd, 1.0f), "eye outside: no culling");
    CHECK_MSG(!pn_gbuffer_cull_back(&c, (float[3]){0, 0, 0.5f}, fwd, 0.01f), "eye inside: culling");
    CHECK_MSG(!pn_gbuffer_cull_back(&c, (float[3]){0, 0, 5}, fwd, 4.0f), "corners before the near plane: culling");
    CHECK_MSG(!pn_gbuffer_cull_back(&c, (float[3]){0, 0, 5}, fwd, 3.999f), "corners within the margin: culling");
    CHECK_MSG(!pn_gbuffer_cull_back(&c, (float[3]){0, 0, 5}, (float[3]){0, 0, 1}, 1.0f), "box behind the eye: culling");
    // A move: translated, it still culls; mirrored in x, its faces turn inside out.
    for (uint32_t i = 0; i < s.vertex_count; i++)
        s.vertices[i].pos[1] += 10;
    pn_gbuffer_cull_moved(&s, &s.draws[0], &c);
    CHECK_MSG(c.outward && pn_gbuffer_cull_back(&c, (float[3]){0, 10, 5}, fwd, 1.0f), "translated: no culling");
    for (uint32_t i = 0; i < s.vertex_count; i++)
        s.vertices[i].pos[0] = -s.vertices[i].pos[0] * 2;
    pn_gbuffer_cull_moved(&s, &s.draws[0], &c);
    CHECK_MSG(!c.outward && !pn_gbuffer_cull_back(&c, (float[3]){0, 10, 5}, fwd, 1.0f), "mirrored: culling");
    pn_scene_destroy(&s);
}

// The first hit of the ray e + t d (t > 0) on the box lo..hi's surface, in double: the entry from
// outside, the exit from inside. False where it misses.
static bool box_hit(const double e[3], const double d[3], const double lo[3], const double hi[3], double hit[3])
{
    double t0 = -INFINITY, t1 = INFINITY;
    for (int k = 0; k < 3; k++) {
        double a = (lo[k] - e[k]) / d[k], b = (hi[k] - e[k]) / d[k];
        t0 = fmax(t0, fmin(a, b)), t1 = fmin(t1, fmax(a, b));
    }
    double t = t0 > 0 ? t0 : t1;
    if (!(t0 <= t1 && t > 0))
        return false;
    for (int k = 0; k < 3; k++)
        hit[k] = e[k] + t * d[k];
    return true;
}

// Renders the scene's G-buffer from cam and checks P at every pixel against box_hit. Pixels whose
// ray passes within a pixel's width of an edge of the box may take either side: skipped.
static void check_render(pn_gpu_device *dev, pn_renderer *ren, const pn_camera *cam, const double lo[3], const double hi[3],
                         const char *what)
{
    pn_light light = {.kind = PN_LIGHT_RECT, .pos = {0, 20, 0}, .normal = {0, -1, 0}, .up = {0, 0, 1}, .size = {1, 1},
                      .radiance = {1, 1, 1}};
    pn_frame_times times;
    (void)dev;
    CHECK_MSG(pn_renderer_render(ren, cam, &light, &times) == PN_OK, "%s: render", what);
    pn_frame_images img;
    pn_renderer_images(ren, &img);
    double e[3], f[3], r[3], u[3];
    for (int k = 0; k < 3; k++)
        e[k] = cam->pos[k], f[k] = cam->target[k] - cam->pos[k];
    double fl = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    for (int k = 0; k < 3; k++)
        f[k] /= fl;
    // right = f x up, up' = right x f (the camera's up is +y in every view here)
    r[0] = -f[2], r[1] = 0, r[2] = f[0];
    double rl = sqrt(r[0] * r[0] + r[2] * r[2]);
    r[0] /= rl, r[2] /= rl;
    u[0] = r[1] * f[2] - r[2] * f[1], u[1] = r[2] * f[0] - r[0] * f[2], u[2] = r[0] * f[1] - r[1] * f[0];
    double th = tan(0.5 * cam->yfov_deg * 3.14159265358979323846 / 180.0), size = 0;
    for (int k = 0; k < 3; k++)
        size = fmax(size, hi[k] - lo[k]);
    int checked = 0, bad = 0;
    for (int y = 0; y < SIZE; y++)
        for (int x = 0; x < SIZE; x++) {
            double sx = (2.0 * (x + 0.5) / SIZE - 1) * th, sy = (1 - 2.0 * (y + 0.5) / SIZE) * th, d[3], hit[3];
            for (int k = 0; k < 3; k++)
                d[k] = f[k] + sx * r[k] + sy * u[k];
            bool hits = box_hit(e, d, lo, hi, hit);
            // Near an edge (two coordinates at the box's faces within a pixel's footprint there) either side may win.
            double dist = 0;
            for (int k = 0; hits && k < 3; k++)
                dist += (hit[k] - e[k]) * (hit[k] - e[k]);
            double margin = 2 * sqrt(dist) * 2 * th / SIZE + 1e-6 * size;
            int at_face = 0;
            for (int k = 0; hits && k < 3; k++)
                at_face += fabs(hit[k] - lo[k]) < margin || fabs(hit[k] - hi[k]) < margin;
            bool near_silhouette = false;
            if (!hits) { // a miss close to the box: the rays a pixel's width around it
                for (int dy = -1; dy <= 1 && !near_silhouette; dy++)
                    for (int dx = -1; dx <= 1 && !near_silhouette; dx++) {
                        double d2[3], h2[3], ox = sx + dx * 2 * th / SIZE, oy = sy + dy * 2 * th / SIZE;
                        for (int k = 0; k < 3; k++)
                            d2[k] = f[k] + ox * r[k] + oy * u[k];
                        near_silhouette = box_hit(e, d2, lo, hi, h2);
                    }
            }
            if (at_face > 1 || near_silhouette)
                continue;
            const float *p = img.p + 4 * (y * SIZE + x);
            checked++;
            bool ok = hits ? p[3] == 1.0f : p[3] == 0.0f;
            for (int k = 0; ok && hits && k < 3; k++)
                ok = fabs(p[k] - hit[k]) <= 1e-3 * size;
            if (!ok && bad++ < 4)
                fprintf(stderr, "%s: pixel (%d, %d): P (%g, %g, %g) w %g, expected %s (%g, %g, %g)\n", what, x, y, (double)p[0],
                        (double)p[1], (double)p[2], (double)p[3], hits ? "a hit at" : "none", hits ? hit[0] : 0,
                        hits ? hit[1] : 0, hits ? hit[2] : 0);
        }
    CHECK_MSG(bad == 0 && checked > SIZE * SIZE / 2, "%s: %d of %d pixels off the box's first hit", what, bad, checked);
}

static void check_rendered(void)
{
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK)
        TEST_SKIP("no Vulkan device");
    pn_scene s;
    uint32_t m;
    new_scene(&s, 0, &m);
    const double lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
    add_cube(&s, &(cube_opts){.lo = {-1, -1, -1}, .hi = {1, 1, 1}, .drop = -1, .flip = -1}, m);
    pn_scene_update_bounds(&s);
    pn_renderer_desc rd = {.width = SIZE, .height = SIZE, .mode = PN_SHADOW_NONE, .spp = 1};
    pn_renderer ren;
    if (pn_renderer_create(&dev, &s, &rd, &ren) != PN_OK) {
        CHECK_MSG(false, "renderer");
        pn_scene_destroy(&s);
        pn_gpu_device_destroy(&dev);
        return;
    }
    CHECK_MSG(ren.gbuffer.cull[0].closed && ren.gbuffer.cull[0].outward, "the cube's draw may not cull");

    const pn_camera outside = {.pos = {2.5f, 1.8f, 4.0f}, .target = {0, 0, 0}, .up = {0, 1, 0}, .yfov_deg = 45};
    const pn_camera inside = {.pos = {0.3f, -0.2f, 0.5f}, .target = {-1, 0.1f, -0.6f}, .up = {0, 1, 0}, .yfov_deg = 90};
    // The outside view culls (its near plane 1% before the bounding sphere), the inside one not.
    pn_gbuffer_push po = pn_gbuffer_camera(&ren.gbuffer, &outside, SIZE, SIZE), pi = pn_gbuffer_camera(&ren.gbuffer, &inside, SIZE, SIZE);
    CHECK_MSG(pn_gbuffer_pass_culls(&ren.gbuffer, 0, &po) && !pn_gbuffer_pass_culls(&ren.gbuffer, 0, &pi),
              "culling seen from outside %d, from inside %d", pn_gbuffer_pass_culls(&ren.gbuffer, 0, &po),
              pn_gbuffer_pass_culls(&ren.gbuffer, 0, &pi));
    check_render(&dev, &ren, &outside, lo, hi, "outside");
    check_render(&dev, &ren, &inside, lo, hi, "inside");
    // Mirrored by a move (x -> -x: the box is the same, its triangles now wound inwards).
    for (uint32_t i = 0; i < s.vertex_count; i++)
        s.vertices[i].pos[0] = -s.vertices[i].pos[0];
    CHECK(pn_renderer_update_vertices(&ren, &s, 0, s.vertex_count) == PN_OK);
    CHECK_MSG(!ren.gbuffer.cull[0].outward && !pn_gbuffer_pass_culls(&ren.gbuffer, 0, &po), "the mirrored cube still culls");
    check_render(&dev, &ren, &outside, lo, hi, "mirrored, outside");
    pn_renderer_destroy(&ren);
    pn_scene_destroy(&s);
    pn_gpu_device_destroy(&dev);
}

int main(void)
{
    check_analysis();
    check_frame_test();
    check_rendered();
    return pn_test_result();
}
