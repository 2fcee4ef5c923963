// Alpha-masked casters (glTF alphaMode MASK): a quad at y = 0.5 textured with an 8 x 8 checkerboard
// of alpha 0 and 255 over a 4 x 4 ground at y = 0, an omni light straight above at (0, 2, 0).
// Oracle, in double: a ground point g's ray to the light crosses y = 0.5 at 0.75 g; inside the
// quad its uv is (0.75 g.x + 0.5, 0.75 g.z + 0.5) and the nearest texel decides: V = 0 under an
// opaque texel, 1 under a cut-out one or beside the quad (pixels within 1e-4 of a texel's edge in
// uv are left out). Checked for every mode that takes the scene, with both traversals (rayquery
// where the device has ray queries; the line-space modes test the leaves holding masked triangles
// exactly); the G-buffer shows no surface where the quad is cut out (seen from above, every quad
// pixel is an opaque texel's). Under an area light the mean V of the ground under the pattern is
// its open share, computed exactly here (within 4 standard errors of the mean), and the line-space
// modes give exact's V pixel for pixel (the quad is the only caster). Per-object trees refuse the scene, naming the masked
// triangles; BLEND casts as MASK at 0.5; a mask whose texture cannot be read is skipped with a
// warning and renders opaque.
// rayquery's V must also equal exact's bit for bit on every pixel but those the oracle leaves out:
// the same rays, but the driver's triangle test and barycentrics, not exact's watertight ones, so
// a ray within rounding of a triangle's or a texel's edge may go the other way (none did here, on
// Mesa 25's lavapipe). Once more on the scene with the ground masked too (a mask without a
// texture, alpha 1: opaque everywhere), whose acceleration structure has no opaque geometry.
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "gpu/device.h"
#include "io/exr.h"
#include "test_png.h"
#include "test_util.h"

// Writes an 8 x 8 RGBA PNG, white, alpha 255 on texels with (x + y) even, else 0.
static bool write_checker_png(const char *path)
{
    unsigned char rgba[8 * 8 * 4];
    for (int i = 0; i < 64; i++) {
        rgba[4 * i] = rgba[4 * i + 1] = rgba[4 * i + 2] = 255;
        rgba[4 * i + 3] = (i % 8 + i / 8) % 2 == 0 ? 255 : 0;
    }
    return pn_test_write_png(path, 8, 8, rgba);
}

// The ground (material 0, opaque, or with ground_masked alpha-masked without a texture at alpha 1)
// and the masked quad (material 1, `mode`, the texture `image`).
static const char *write_scene(const char *name, const char *mode, const char *image, bool ground_masked)
{
    // 8 positions, 8 uvs, 12 indices: ground corners, then the quad's.
    const float pos[8][3] = {{-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2},
                             {-0.5f, 0.5f, -0.5f}, {0.5f, 0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}, {-0.5f, 0.5f, 0.5f}};
    const float uv[8][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0, 0}, {1, 0}, {1, 1}, {0, 1}};
    const uint16_t idx[12] = {0, 2, 1, 0, 3, 2, 4, 6, 5, 4, 7, 6}; // counter-clockwise from above
    unsigned char bin[96 + 64 + 24];
    memcpy(bin, pos, 96);
    memcpy(bin + 96, uv, 64);
    memcpy(bin + 160, idx, 24);
    char data[400];
    pn_test_base64(bin, sizeof bin, data);
    const char *path = pn_test_tmp(name);
    FILE *f = fopen(path, "w");
    if (!f)
        return NULL;
    fprintf(f,
            "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
            "\"meshes\":[{\"primitives\":["
            "{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":2,\"material\":0},"
            "{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":3,\"material\":1}]}],"
            "\"materials\":[{%s\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.8,0.8,0.8,1]}},"
            "{\"alphaMode\":\"%s\",\"alphaCutoff\":0.5,\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],"
            "\"textures\":[{\"source\":0,\"sampler\":0}],\"samplers\":[{\"magFilter\":9728,\"minFilter\":9728}],"
            "\"images\":[{\"uri\":\"%s\"}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\","
            "\"min\":[-2,0,-2],\"max\":[2,0.5,2]},{\"bufferView\":1,\"componentType\":5126,\"count\":8,\"type\":\"VEC2\"},"
            "{\"bufferView\":2,\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"},"
            "{\"bufferView\":2,\"byteOffset\":12,\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"}],"
            "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":96},{\"buffer\":0,\"byteOffset\":96,\"byteLength\":64},"
            "{\"buffer\":0,\"byteOffset\":160,\"byteLength\":24}],"
            "\"buffers\":[{\"byteLength\":184,\"uri\":\"data:application/octet-stream;base64,%s\"}]}",
            ground_masked ? "\"alphaMode\":\"MASK\",\"alphaCutoff\":0.5," : "", mode, image, data);
    fclose(f);
    return path;
}

// The start of a text file (what a command wrote to stderr), "" if there is none.
static void read_text(const char *path, char *out, size_t cap)
{
    FILE *f = fopen(path, "r");
    size_t n = f ? fread(out, 1, cap - 1, f) : 0;
    out[n] = 0;
    if (f)
        fclose(f);
}

// 1 where the quad's texel at (u, v) is opaque, 0 cut out, -1 within `m` of a texel edge (in uv).
static int texel(double u, double v, double m)
{
    double x = u * 8, y = v * 8;
    if (fabs(x - round(x)) < 8 * m || fabs(y - round(y)) < 8 * m)
        return -1;
    return ((int)floor(x) + (int)floor(y)) % 2 == 0;
}

typedef struct counts {
    int ground, under, quad, wrong, wrong_quad;
    int pixels;
    float *v;      // with keep: every pixel's V (malloc'd)
    uint8_t *edge; // with keep: 1 on a ground pixel the oracle leaves out (within 1e-4 of an edge)
} counts;

static counts check_render(const char *gltf, const char *mode, const char *extra, const char *cam, bool keep)
{
    counts c = {0};
    const char *exr = pn_test_tmp("alpha.exr");
    char args[2048];
    snprintf(args, sizeof args,
             "render %s --no-ground --size 240x180 %s --fov 40 --mode %s --spp 1 --filter none --aovs "
             "--light omni:0,2,0:5 %s -o %s >/dev/null",
             gltf, cam, mode, extra, exr);
    pn_exr_image img;
    if (pn_test_run(args) != 0 || pn_exr_read(exr, &img) != PN_OK) {
        CHECK_MSG(false, "%s failed", args);
        return c;
    }
    const float *v = pn_exr_image_channel(&img, "shadow.V"), *px = pn_exr_image_channel(&img, "P.X"),
                *py = pn_exr_image_channel(&img, "P.Y"), *pz = pn_exr_image_channel(&img, "P.Z"),
                *a = pn_exr_image_channel(&img, "A");
    CHECK(v && px && py && pz && a);
    c.pixels = img.width * img.height;
    if (keep && v) {
        c.v = malloc(c.pixels * sizeof *c.v);
        c.edge = calloc(c.pixels, 1);
        CHECK(c.v && c.edge);
        if (c.v)
            memcpy(c.v, v, c.pixels * sizeof *c.v);
    }
    for (int i = 0; v && px && py && pz && a && i < img.width * img.height; i++) {
        if (a[i] <= 0)
            continue;
        double x = px[i], y = py[i], z = pz[i];
        if (fabs(y - 0.5) < 1e-4) { // the quad itself: only its opaque texels are surfaces
            int t = texel(x + 0.5, z + 0.5, 0.25 / 8);
            c.quad++;
            c.wrong_quad += t == 0;
            continue;
        }
        if (fabs(y) > 1e-4)
            continue;
        c.ground++;
        double cx = 0.75 * x, cz = 0.75 * z;
        int expect = 1;
        if (fabs(cx) < 0.5 && fabs(cz) < 0.5) {
            int t = texel(cx + 0.5, cz + 0.5, 1e-4);
            if (t < 0) {
                if (c.edge)
                    c.edge[i] = 1;
                continue;
            }
            c.under++;
            expect = t ? 0 : 1;
        } else if (fabs(fabs(cx) - 0.5) < 1e-4 || fabs(fabs(cz) - 0.5) < 1e-4) {
            if (c.edge)
                c.edge[i] = 1;
            continue;
        }
        c.wrong += v[i] != (float)expect;
    }
    pn_exr_image_free(&img);
    printf("%s %s %s: %d ground pixels (%d under the quad), %d with V off the checkerboard; %d quad pixels, %d on "
           "cut-out texels\n",
           gltf, mode, extra, c.ground, c.under, c.wrong, c.quad, c.wrong_quad);
    return c;
}

static void counts_free(counts *c)
{
    free(c->v);
    free(c->edge);
}

// The device's traversal (r: rayquery or rtpipeline, `mode`) against exact (x) on the same scene
// and view: V bit for bit on every pixel but those the oracle leaves out, where the two triangle
// tests' rounding may differ (the header).
static void check_same_v(const char *what, const char *mode, const counts *x, const counts *r)
{
    int differ = 0, off_edge = 0;
    for (int i = 0; x->v && r->v && x->edge && i < x->pixels && i < r->pixels; i++)
        if (x->v[i] != r->v[i]) {
            differ++;
            off_edge += !x->edge[i];
        }
    printf("%s: %s's V differs from exact's on %d pixels, %d of them off the edges\n", what, mode, differ, off_edge);
    CHECK_MSG(x->v && r->v && x->pixels == r->pixels && off_edge == 0,
              "%s: %s's V differs from exact's on %d pixels away from every edge", what, mode, off_edge);
}

// Renders `gltf` under a 2 x 2 rectangle at (0, 2, 0) facing down, 16 spp, and returns per pixel
// its shadow.V, P.X, P.Y, P.Z and A (5 x width x height floats, to free), or NULL.
enum { AREA_V, AREA_X, AREA_Y, AREA_Z, AREA_A, AREA_FIELDS };
static float *area_v(const char *gltf, const char *mode, int *count)
{
    const char *exr = pn_test_tmp("alpha_area.exr");
    char args[2048];
    snprintf(args, sizeof args,
             "render %s --no-ground --size 160x120 --camera-pos 2.2,1.2,1.6 --camera-target 0,0,0 --fov 40 --mode %s "
             "--spp 16 --filter none --aovs --light rect:0,2,0:0,-1,0:0,0,1:2,2:1 -o %s >/dev/null",
             gltf, mode, exr);
    pn_exr_image img;
    if (pn_test_run(args) != 0 || pn_exr_read(exr, &img) != PN_OK)
        return NULL;
    const float *ch[AREA_FIELDS] = {pn_exr_image_channel(&img, "shadow.V"), pn_exr_image_channel(&img, "P.X"),
                                     pn_exr_image_channel(&img, "P.Y"), pn_exr_image_channel(&img, "P.Z"),
                                     pn_exr_image_channel(&img, "A")};
    *count = img.width * img.height;
    bool all = ch[0] && ch[1] && ch[2] && ch[3] && ch[4];
    float *out = all ? malloc((size_t)*count * AREA_FIELDS * sizeof *out) : NULL;
    for (int i = 0; out && i < *count; i++)
        for (int f = 0; f < AREA_FIELDS; f++)
            out[AREA_FIELDS * i + f] = ch[f][i];
    pn_exr_image_free(&img);
    return out;
}

// The open share of the square of half-width 0.25 round (cx, cz) in the quad's plane: the
// checkerboard's cut-out texels (texel(), (x + y) odd) and everything beside the quad, exactly,
// summed over the texel columns and rows it overlaps.
static double open_share(double cx, double cz)
{
    double blocked = 0;
    for (int i = -5; i < 5; i++)
        for (int j = -5; j < 5; j++) {
            if (((i + 4) + (j + 4)) % 2 != 0) // texel (i + 4, j + 4) of the 8 x 8 grid is cut out
                continue;
            double x0 = fmax(i / 8.0, cx - 0.25), x1 = fmin((i + 1) / 8.0, cx + 0.25);
            double z0 = fmax(j / 8.0, cz - 0.25), z1 = fmin((j + 1) / 8.0, cz + 0.25);
            if (i >= -4 && i < 4 && j >= -4 && j < 4 && x1 > x0 && z1 > z0)
                blocked += (x1 - x0) * (z1 - z0);
        }
    return 1 - blocked / 0.25;
}

int main(void)
{
    const char *png = pn_test_tmp("checker.png");
    CHECK(write_checker_png(png));
    // pn_test_tmp's names are reused after a few calls: the scenes' paths are copied.
    char gltf[1024], blend[1024];
    char gltf_all[1024];
    const char *g = write_scene("alpha.gltf", "MASK", "checker.png", false);
    snprintf(gltf, sizeof gltf, "%s", g ? g : "");
    const char *b = write_scene("alpha_blend.gltf", "BLEND", "checker.png", false);
    snprintf(blend, sizeof blend, "%s", b ? b : "");
    const char *all = write_scene("alpha_all.gltf", "MASK", "checker.png", true);
    snprintf(gltf_all, sizeof gltf_all, "%s", all ? all : "");
    CHECK(g && b && all);
    if (!g || !b || !all)
        return pn_test_result();
    // From the side and low, the ground under the quad shows through its cut-out texels.
    const char *side = "--camera-pos 2.2,1.2,1.6 --camera-target 0,0,0";
    pn_gpu_device_desc dd = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    bool made = pn_gpu_device_create(&dd, &dev) == PN_OK;
    bool ray_query = made && dev.ray_query, ray_pipeline = made && dev.ray_pipeline;
    pn_gpu_device_destroy(&dev);
    if (!ray_query)
        printf("rayquery: skipped, the device has no VK_KHR_ray_query (PN_MESA=stock, Mesa 22.3)\n");
    if (!ray_pipeline)
        printf("rtpipeline: skipped, the device has no VK_KHR_ray_tracing_pipeline (PN_MESA=stock, Mesa 22.3)\n");
    // The scene with an opaque ground in every mode, then (exact, rayquery) the one with every
    // triangle masked. The line-space modes test the quad's leaves exactly (they hold its masked
    // triangles), so they too draw the checkerboard without a pixel off; the ground's own leaves are
    // where rays start, culled or skipped, so nothing else blocks.
    const char *runs[][3] = {{gltf, "exact", ""},          {gltf, "exact", "--traversal ray"},
                             {gltf, "exact-ls", ""},       {gltf, "exact-ls", "--traversal packet"},
                             {gltf, "rayquery", ""},       {gltf, "rtpipeline", ""},
                             {gltf, "linespace", ""},
                             {gltf, "linespace", "--traversal packet"}, {gltf, "linespace", "--tree 4,2"},
                             {gltf, "ls-leaf", ""},        {gltf, "ls-plane", "--traversal packet"},
                             {gltf, "hybrid", ""},         {gltf_all, "exact", ""},
                             {gltf_all, "rayquery", ""},   {gltf_all, "rtpipeline", ""}};
    counts exact = {0};
    for (size_t r = 0; r < sizeof runs / sizeof runs[0]; r++) {
        // The device's own traversals (rayquery, rtpipeline) against exact's V.
        bool rt = strcmp(runs[r][1], "rtpipeline") == 0, rq = rt || strcmp(runs[r][1], "rayquery") == 0;
        if ((rq && !rt && !ray_query) || (rt && !ray_pipeline))
            continue;
        // exact's V (its default traversal), for rayquery's on the same scene.
        bool keep = rq || (strcmp(runs[r][1], "exact") == 0 && runs[r][2][0] == 0);
        counts c = check_render(runs[r][0], runs[r][1], runs[r][2], side, keep);
        CHECK_MSG(c.under > 500 && c.wrong == 0, "%s %s %s: %d of %d ground pixels off the checkerboard's shadow",
                  runs[r][0], runs[r][1], runs[r][2], c.wrong, c.ground);
        CHECK_MSG(c.quad > 200 && c.wrong_quad == 0, "%s %s: %d quad pixels on cut-out texels", runs[r][0], runs[r][1],
                  c.wrong_quad);
        if (rq)
            check_same_v(runs[r][0], runs[r][1], &exact, &c);
        if (keep && !rq) {
            counts_free(&exact);
            exact = c;
        } else {
            counts_free(&c);
        }
    }
    counts_free(&exact);
    // Under an area light, penumbrae cross the pattern. The masked quad is the scene's only caster,
    // so every answer of the line-space modes that could block a ray comes from the exact test of
    // its leaves: the same V as exact's, pixel for pixel, and the ground under the quad is neither
    // fully lit nor fully shadowed (half its texels are open).
    int np = 0, ne = 0;
    float *ve = area_v(gltf, "exact", &ne);
    CHECK(ve != NULL);
    // The mean V over the ground is the open share of the light: a ground point g sees the light
    // through the square of half-width 0.25 round 3 g / 4 in the quad's plane (the light is 2 wide at
    // height 2, the quad at 0.5), a linear map, so V(g) is the square's open area share (open_share,
    // exact). Per pixel the 16 stratified samples estimate it with a standard error of at most
    // 0.5 / sqrt(16); over n pixels the mean's is at most 0.125 / sqrt(n): 4 of those bound the
    // difference of the means.
    int partial = 0, n = 0;
    double sum_v = 0, sum_open = 0;
    for (int i = 0; ve && i < ne; i++) {
        const float *q = &ve[AREA_FIELDS * i];
        if (!(q[AREA_A] > 0) || fabs(q[AREA_Y]) > 1e-4)
            continue;
        partial += q[AREA_V] > 0.25f && q[AREA_V] < 0.75f;
        double open = open_share(0.75 * q[AREA_X], 0.75 * q[AREA_Z]);
        if (open >= 1) // beside the quad's shadow: no texel to judge
            continue;
        sum_v += q[AREA_V], sum_open += open;
        n++;
    }
    double bound = n ? 4 * 0.125 / sqrt(n) : 0;
    printf("area light, exact: %d ground pixels under the pattern, mean V %.4f, mean open share %.4f (bound %.4f); "
           "%d pixels with V in (0.25, 0.75)\n",
           n, n ? sum_v / n : 0, n ? sum_open / n : 0, bound, partial);
    CHECK_MSG(n > 2000 && fabs(sum_v - sum_open) / n < bound, "mean V %.4f against the open share %.4f over %d pixels",
              n ? sum_v / n : 0, n ? sum_open / n : 0, n);
    CHECK_MSG(partial > 1000, "the pattern's penumbrae: %d pixels with V in (0.25, 0.75)", partial);
    const char *area_modes[] = {"linespace", "ls-leaf", "ls-plane", "hybrid", "exact-ls"};
    for (size_t m = 0; ve && m < sizeof area_modes / sizeof area_modes[0]; m++) {
        float *vm = area_v(gltf, area_modes[m], &np);
        int differ = 0;
        for (int i = 0; vm && np == ne && i < ne; i++)
            differ += vm[AREA_FIELDS * i + AREA_V] != ve[AREA_FIELDS * i + AREA_V];
        printf("area light, %s: %d of %d pixels differ from exact\n", area_modes[m], differ, ne);
        CHECK_MSG(vm && np == ne && differ == 0, "%s under an area light: %d pixels differ from exact", area_modes[m], differ);
        free(vm);
    }
    free(ve);

    counts c = check_render(blend, "exact", "", side, false);
    CHECK_MSG(c.under > 500 && c.wrong == 0, "BLEND as MASK at 0.5: %d pixels off", c.wrong);

    // Per-object trees, which keep no triangles to test texels, refuse the scene, naming it and the
    // masked triangles.
    const char *refuse[] = {"linespace --trees object"};
    for (size_t m = 0; m < sizeof refuse / sizeof refuse[0]; m++) {
        char args[2048];
        snprintf(args, sizeof args, "render %s --size 32x32 --mode %s -o %s 2>%s >/dev/null", gltf, refuse[m],
                 pn_test_tmp("refused.exr"), pn_test_tmp("refused.txt"));
        remove(pn_test_tmp("refused.exr"));
        int rc = pn_test_run(args);
        char msg[1024];
        read_text(pn_test_tmp("refused.txt"), msg, sizeof msg);
        FILE *out = fopen(pn_test_tmp("refused.exr"), "rb");
        CHECK_MSG(rc != 0 && strstr(msg, "2 alpha-masked triangles") && !out, "--mode %s: exit %d, '%s'", refuse[m], rc,
                  msg);
        if (out)
            fclose(out);
    }

    // A mask whose texture cannot be read: warned, skipped (the quad casts as an opaque one).
    char broken[1024];
    snprintf(broken, sizeof broken, "%s", write_scene("alpha_broken.gltf", "MASK", "missing.png", false));
    char args[2048];
    snprintf(args, sizeof args, "render %s --size 32x32 -o %s 2>%s >/dev/null", broken, pn_test_tmp("broken.exr"),
             pn_test_tmp("broken.txt"));
    int rc = pn_test_run(args);
    char msg[2048];
    read_text(pn_test_tmp("broken.txt"), msg, sizeof msg);
    CHECK_MSG(rc == 0 && strstr(msg, "the mask is skipped"), "unreadable alpha texture: exit %d, '%s'", rc, msg);
    return pn_test_result();
}
