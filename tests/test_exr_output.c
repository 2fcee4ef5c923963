// The render's EXR is right: read back with OpenEXRCore (through the engine's reader for the
// pixels and directly for the attributes) and checked by Debian's exrheader; channel names and
// attributes as documented; no NaN or Inf anywhere; the --json summary has the documented keys.
#include <float.h>
#include <openexr.h>

#include "io/exr.h"
#include "test_util.h"

// The default render filters (--filter penumbra), so its unfiltered V is there too, and the
// penumbra filter's footprint and the V its Gaussian averaged.
static const char *const CHANNELS[] = {"R", "G", "B", "A", "shadow.V", "P.X", "P.Y", "P.Z",
                                       "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B", "Z", "shadow.V_raw",
                                       "shadow.valid", "shadow.penumbra", "shadow.footprint",
                                       "shadow.V_window"};
static const char *const ATTRS[] = {"penumbra.scene", "penumbra.mode", "penumbra.triangles",
                                    "penumbra.camera.pos", "penumbra.camera.target", "penumbra.camera.fov",
                                    "penumbra.light.pos", "penumbra.light.normal", "penumbra.light.up",
                                    "penumbra.light.width", "penumbra.light.height", "penumbra.light.radiance",
                                    "penumbra.gpu_ms.gbuffer", "penumbra.gpu_ms.shadow", "penumbra.gpu_ms.shade",
                                    "penumbra.compile_ms"};
#define COUNT(a) (int)(sizeof(a) / sizeof((a)[0]))

static void check_attributes(const char *path)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_context_t ctx;
    CHECK(exr_start_read(&ctx, path, &init) == EXR_ERR_SUCCESS);
    for (int i = 0; i < COUNT(ATTRS); i++) {
        const exr_attribute_t *attr = NULL;
        CHECK_MSG(exr_get_attribute_by_name(ctx, 0, ATTRS[i], &attr) == EXR_ERR_SUCCESS && attr, "attribute %s", ATTRS[i]);
    }
    const char *scene = NULL;
    CHECK(exr_attr_get_string(ctx, 0, "penumbra.scene", NULL, &scene) == EXR_ERR_SUCCESS);
    CHECK(scene && strcmp(scene, "builtin:default") == 0);
    const char *gpu[3] = {"penumbra.gpu_ms.gbuffer", "penumbra.gpu_ms.shadow", "penumbra.gpu_ms.shade"};
    for (int i = 0; i < 3; i++) {
        float ms = -1;
        CHECK(exr_attr_get_float(ctx, 0, gpu[i], &ms) == EXR_ERR_SUCCESS);
        CHECK_MSG(ms > 0 && isfinite(ms), "%s = %g", gpu[i], ms);
    }
    // A render's one frame is its renderer's first: its pipelines were readied (created, then run
    // over one tile) before it, and that time is reported apart from the passes'.
    float compile = -1;
    CHECK(exr_attr_get_float(ctx, 0, "penumbra.compile_ms", &compile) == EXR_ERR_SUCCESS);
    CHECK_MSG(compile > 0 && isfinite(compile), "penumbra.compile_ms = %g", compile);
    int tris = 0;
    CHECK(exr_attr_get_int(ctx, 0, "penumbra.triangles", &tris) == EXR_ERR_SUCCESS && tris > 100);
    exr_finish(&ctx);
}

static void check_exrheader(const char *path)
{
    char cmd[1200], out[65536] = "";
    snprintf(cmd, sizeof cmd, "exrheader '%s' 2>&1", path);
    FILE *p = popen(cmd, "r");
    CHECK(p != NULL);
    if (!p)
        return;
    size_t n = fread(out, 1, sizeof out - 1, p);
    out[n] = '\0';
    CHECK_MSG(pclose(p) == 0, "exrheader failed:\n%s", out);
    for (int i = 0; i < COUNT(CHANNELS); i++) {
        char line[64];
        snprintf(line, sizeof line, "    %s, 32-bit floating-point", CHANNELS[i]);
        CHECK_MSG(strstr(out, line) != NULL, "exrheader does not list channel %s", CHANNELS[i]);
    }
    for (int i = 0; i < COUNT(ATTRS); i++)
        CHECK_MSG(strstr(out, ATTRS[i]) != NULL, "exrheader does not list %s", ATTRS[i]);
    CHECK(strstr(out, "dataWindow (type box2i): (0 0) - (199 119)") != NULL);
}

int main(void)
{
    const char *exr = pn_test_tmp("output_default.exr"), *png = pn_test_tmp("output_default.png");
    const char *json = pn_test_tmp("output_default.json");
    remove(exr);
    char args[2048];
    snprintf(args, sizeof args, "render builtin:default --size 200x120 --aovs --json -o %s --preview %s > %s", exr,
             png, json);
    CHECK(pn_test_run(args) == 0);

    pn_exr_image img;
    CHECK(pn_exr_read(exr, &img) == PN_OK);
    CHECK(img.width == 200 && img.height == 120);
    CHECK_MSG(img.channel_count == COUNT(CHANNELS), "%d channels", img.channel_count);
    const float *ch[COUNT(CHANNELS)];
    for (int i = 0; i < COUNT(CHANNELS); i++) {
        ch[i] = pn_exr_image_channel(&img, CHANNELS[i]);
        CHECK_MSG(ch[i] != NULL, "channel %s missing", CHANNELS[i]);
        if (!ch[i])
            return pn_test_result();
    }
    int px = img.width * img.height, covered = 0, nonfinite = 0, lit = 0;
    for (int i = 0; i < px; i++) {
        for (int c = 0; c < COUNT(CHANNELS); c++)
            nonfinite += !isfinite(ch[c][i]);
        float a = ch[3][i], v = ch[4][i];
        CHECK_MSG(a == 0.0f || a == 1.0f, "A = %g at %d", a, i);
        CHECK_MSG(v >= 0.0f && v <= 1.0f && ch[15][i] >= 0.0f && ch[15][i] <= 1.0f, "shadow.V = %g, V_raw = %g at %d",
                  v, ch[15][i], i);
        // shadow.valid: a whole number of rays, V_raw their visible share (1 with none), 0 on the background
        float valid = ch[16][i], visible = ch[15][i] * valid;
        CHECK_MSG(valid >= 0 && valid == floorf(valid) && (a == 1.0f || valid == 0), "shadow.valid = %g at %d", valid, i);
        CHECK_MSG(valid > 0 ? fabsf(visible - roundf(visible)) < 1e-3f : a == 0.0f || ch[15][i] == 1.0f,
                  "V_raw = %g of %g valid rays at %d", ch[15][i], valid, i);
        // shadow.penumbra: FLT_MAX exactly where no valid ray was blocked, else a width >= 0; 0 on the
        // background
        float width = ch[17][i];
        CHECK_MSG(a == 1.0f ? width >= 0 && (width == FLT_MAX) == (valid == 0 || ch[15][i] == 1.0f) : width == 0,
                  "shadow.penumbra = %g with V_raw %g of %g valid rays at %d", width, ch[15][i], valid, i);
        // shadow.footprint: the penumbra filter's deviation in pixels, >= 0, 0 on the background
        float fp = ch[18][i];
        CHECK_MSG(fp >= 0 && (a == 1.0f || fp == 0), "shadow.footprint = %g at %d", fp, i);
        // shadow.V_window: the interleaved filter's V, before the Gaussian: in [0, 1], 0 on the background
        float vw = ch[19][i];
        CHECK_MSG(vw >= 0 && vw <= 1 && (a == 1.0f || vw == 0), "shadow.V_window = %g at %d", vw, i);
        if (a == 1.0f) {
            covered++;
            double nl = sqrt(ch[8][i] * ch[8][i] + ch[9][i] * ch[9][i] + ch[10][i] * ch[10][i]);
            CHECK_MSG(fabs(nl - 1) < 1e-3, "|N| = %g at %d", nl, i);
            CHECK_MSG(ch[14][i] > 0, "Z = %g at %d", ch[14][i], i);
            CHECK_MSG(ch[0][i] >= 0 && ch[1][i] >= 0 && ch[2][i] >= 0, "negative radiance at %d", i);
            lit += ch[0][i] > 0;
        } else {
            CHECK_MSG(ch[0][i] == 0 && ch[14][i] == 0, "background pixel %d not zero", i);
        }
    }
    CHECK_MSG(nonfinite == 0, "%d non-finite values", nonfinite);
    CHECK_MSG(covered > px / 4 && covered < px, "%d of %d pixels covered", covered, px);
    CHECK_MSG(lit > covered / 2, "only %d of %d covered pixels lit", lit, covered);
    pn_exr_image_free(&img);
    check_attributes(exr);
    check_exrheader(exr);

    // Preview: a PNG of the same size (IHDR width/height, big-endian at bytes 16..23).
    FILE *f = fopen(png, "rb");
    unsigned char hdr[24] = {0};
    CHECK(f && fread(hdr, 1, 24, f) == 24);
    if (f)
        fclose(f);
    CHECK(memcmp(hdr + 1, "PNG", 3) == 0);
    CHECK((hdr[16] << 24 | hdr[17] << 16 | hdr[18] << 8 | hdr[19]) == 200);
    CHECK((hdr[20] << 24 | hdr[21] << 16 | hdr[22] << 8 | hdr[23]) == 120);

    // --json: one object with the documented keys.
    char js[4096] = "";
    f = fopen(json, "r");
    CHECK(f != NULL);
    if (f) {
        size_t n = fread(js, 1, sizeof js - 1, f);
        js[n] = '\0';
        fclose(f);
    }
    const char *keys[] = {"\"output\":", "\"width\": 200", "\"height\": 120", "\"triangles\":", "\"gpu_ms\": {",
                          "\"gbuffer\":", "\"shadow\":", "\"shade\":"};
    for (int i = 0; i < COUNT(keys); i++)
        CHECK_MSG(strstr(js, keys[i]) != NULL, "JSON lacks %s: %s", keys[i], js);
    CHECK(js[0] == '{' && strchr(js, '\n') == js + strlen(js) - 1);

    // Two --light groups with the filter: a V and a V_raw per light (no plain shadow.V), the count
    // and the second light's parameters in the header.
    const char *two = pn_test_tmp("output_two_lights.exr");
    remove(two);
    snprintf(args, sizeof args, "render builtin:default --size 64x48 --spp 4 --filter interleaved "
             "--light 0,3,0:0,-1,0:0,0,1:1,1:5 --light 2,2,1:-1,-1,0:0,0,1:0.5,0.25:1,2,3 -o %s > /dev/null", two);
    CHECK(pn_test_run(args) == 0);
    pn_exr_image img2;
    CHECK(pn_exr_read(two, &img2) == PN_OK);
    const char *per_light[] = {"shadow.V.0", "shadow.V.1", "shadow.V_raw.0", "shadow.V_raw.1", "R", "A"};
    for (int i = 0; i < COUNT(per_light); i++)
        CHECK_MSG(pn_exr_image_channel(&img2, per_light[i]) != NULL, "two lights: channel %s missing", per_light[i]);
    CHECK_MSG(pn_exr_image_channel(&img2, "shadow.V") == NULL, "two lights: a plain shadow.V too");
    CHECK_MSG(img2.channel_count == 8, "two lights: %d channels, expected R G B A and 4 V", img2.channel_count);
    pn_exr_image_free(&img2);
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    exr_context_t ctx;
    CHECK(exr_start_read(&ctx, two, &init) == EXR_ERR_SUCCESS);
    int32_t lights = 0;
    CHECK(exr_attr_get_int(ctx, 0, "penumbra.lights", &lights) == EXR_ERR_SUCCESS && lights == 2);
    exr_attr_v3f_t pos = {0};
    CHECK(exr_attr_get_v3f(ctx, 0, "penumbra.light.1.pos", &pos) == EXR_ERR_SUCCESS);
    CHECK_MSG(pos.x == 2 && pos.y == 2 && pos.z == 1, "penumbra.light.1.pos = (%g, %g, %g)", pos.x, pos.y, pos.z);
    float w = 0;
    CHECK(exr_attr_get_float(ctx, 0, "penumbra.light.1.width", &w) == EXR_ERR_SUCCESS && w == 0.5f);
    exr_finish(&ctx);
    return pn_test_result();
}
