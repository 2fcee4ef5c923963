// --filter interleaved on the default scene (render's framing, 480x360, exact), checked against
// the filter's oracle (filter_oracle.h, shared with test_extremes.c):
//  - V stays in [0, 1] and 0 on the background, and the filter changes some pixels;
//  - the penumbra width is FLT_MAX exactly where no valid ray was blocked (V_raw = 1), and finite
//    and not negative where one was;
//  - on every covered pixel the filtered V is what filter.comp documents, recomputed in double from
//    the frame's own P, N, view depth, V_raw, valid counts and penumbra widths, within the oracle's
//    bound on the shader's float rounding; the range and the penumbra weights both act on some taps;
//  - a pixel the light cannot reach keeps V = 1; at 4 spp every pixel the light reaches above its
//    horizon has a valid ray (the samples are drawn in the part above, shadow_frame.glsl's
//    horizon_box); at 1 spp some miss it, and those take their neighbours' V;
//  - so is a window other than 3x3 (2x4: even, so off centre, and not square), whose pipeline the
//    renderer specialises for it (filter_pass.c);
//  - the filter pays: against the converged reference (exact, 1024 spp, another seed) the filtered
//    V's mean error is below the unfiltered V's of the same frame;
//  - `penumbra render` writes the same V and V_raw into its EXR, bit for bit.
// Validation layer on: any message fails.
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/render_opts.h"
#include "filter_oracle.h"
#include "gpu/shadow_pass.h"
#include "io/exr.h"
#include "shadow/setup.h"
#include "test_util.h"

enum { W = 480, H = 360 };
#define REFERENCE_SEED 46524401 // the converged reference's: no measured frame uses it

typedef struct frame {
    float *p, *n, *v, *v_raw, *width;
    uint32_t *valid;
    bool *reaches;
    filter_frame view;
} frame;

typedef struct tally {
    uint64_t covered, off, changed, range, pen, kept, borrowed, no_ray;
    double diff_max, tol_max;
} tally;

static pn_setup_desc frame_desc(const pn_render_opts *o, const pn_camera *cam)
{
    pn_setup_desc sd = pn_render_opts_setup(o);
    sd.view = cam; // as render culls
    sd.light_count = 1;
    return sd;
}

// Renders one frame of the prepared scene under `o`; copies what the filter saw into *f.
static bool render_frame(pn_gpu_device *dev, const pn_prepared_scene *prep, const pn_render_opts *o, frame *f)
{
    pn_setup s;
    pn_setup_desc sd = frame_desc(o, &prep->camera);
    if (pn_setup_create(dev, &prep->scene, prep->lights, &sd, &s) != PN_OK) {
        CHECK_MSG(false, "set-up failed");
        return false;
    }
    pn_frame_times t;
    pn_result r = pn_renderer_render(&s.renderer, &prep->camera, &prep->lights[0], &t);
    CHECK_MSG(r == PN_OK, "render: %s", pn_result_str(r));
    pn_frame_images img;
    pn_renderer_images(&s.renderer, &img);
    size_t px = (size_t)W * H;
    f->p = malloc(px * 4 * sizeof(float)), f->n = malloc(px * 4 * sizeof(float));
    f->v = malloc(px * sizeof(float)), f->v_raw = malloc(px * sizeof(float)), f->width = malloc(px * sizeof(float));
    f->valid = malloc(px * sizeof(uint32_t)), f->reaches = malloc(px * sizeof(bool));
    bool ok = r == PN_OK && f->p && f->n && f->v && f->v_raw && f->width && f->valid && f->reaches;
    if (ok) {
        memcpy(f->p, img.p, px * 4 * sizeof(float));
        memcpy(f->n, img.n, px * 4 * sizeof(float));
        memcpy(f->v, img.v, px * sizeof(float));
        // Unfiltered, V is V_raw (the renderer keeps no second copy).
        memcpy(f->v_raw, img.v_raw ? img.v_raw : img.v, px * sizeof(float));
        for (size_t i = 0; i < px; i++) {
            f->valid[i] = img.counts[4 * i + 1];
            f->reaches[i] = img.counts[4 * i + 2] != 0;
            memcpy(&f->width[i], &img.counts[4 * i + 3], sizeof(float));
        }
        const pn_camera *cam = &prep->camera;
        f->view = (filter_frame){
            .width = W,
            .height = H,
            .tile_w = (int)o->tile_w,
            .tile_h = (int)o->tile_h,
            .samples = pn_filter_noise_samples((uint32_t)o->spp, &prep->lights[0]), // as renderer.c passes it
            .eye_mag = fmaxf(fabsf(cam->pos[0]), fmaxf(fabsf(cam->pos[1]), fabsf(cam->pos[2]))),
            .pixel_angle = (float)(2.0 * tan(0.5 * cam->yfov_deg * 3.14159265358979323846 / 180.0) / H),
            .p = f->p,
            .n = f->n,
            .v = f->v,
            .v_raw = f->v_raw,
            .valid = f->valid,
            .reaches = f->reaches,
            .penumbra = f->width,
        };
    }
    pn_setup_destroy(dev, &s);
    return ok;
}

static void frame_free(frame *f)
{
    free(f->p), free(f->n), free(f->v), free(f->v_raw), free(f->width), free(f->valid), free(f->reaches);
    memset(f, 0, sizeof *f);
}

// Every covered pixel of a filtered frame against the oracle.
static tally check_frame(const char *name, const frame *f)
{
    tally t = {0};
    uint64_t bad = 0, bad_width = 0, finite_widths = 0;
    float widest = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int i = y * W + x;
            float v = f->v[i], raw = f->v_raw[i];
            bool geo = f->p[4 * i + 3] > 0;
            if (!(v >= 0 && v <= 1) || (!geo && v != 0) || !(raw >= 0 && raw <= 1)) {
                if (bad++ < 5)
                    fprintf(stderr, "  %s: pixel (%d, %d): V = %g, V_raw = %g (geometry %d)\n", name, x, y, v, raw, geo);
                continue;
            }
            if (!geo)
                continue;
            t.covered++;
            t.changed += v != raw;
            if (f->valid[i] > 0) {
                // No valid ray blocked exactly where V_raw is 1; then the width is FLT_MAX.
                bool none = raw == 1.0f, infinite = f->width[i] == FLT_MAX;
                bad_width += none != infinite || !(f->width[i] >= 0);
                finite_widths += !infinite;
                widest = !infinite && f->width[i] > widest ? f->width[i] : widest;
            }
            filter_window o;
            filter_recompute(&f->view, x, y, &o);
            double d = fabs(v - o.v);
            t.diff_max = fmax(t.diff_max, d);
            t.tol_max = fmax(t.tol_max, o.tol);
            t.range += o.range_between;
            t.pen += o.pen_between;
            t.no_ray += f->valid[i] == 0;
            t.kept += f->valid[i] == 0 && !f->reaches[i];
            t.borrowed += f->valid[i] == 0 && f->reaches[i] && o.wg > 0;
            if (d > o.tol && t.off++ < 5)
                fprintf(stderr, "  %s: pixel (%d, %d): V = %.9f, recomputed %.9f (|difference| %.3g > %.3g)\n", name, x, y,
                        v, o.v, d, o.tol);
        }
    fprintf(stderr, "%s: %llu covered pixels, |V - recomputed| max %.2e (bound max %.2e), %llu changed, %llu with range "
                    "and %llu with penumbra weights between 0 and 1; without a valid ray: %llu keep V = 1, %llu take "
                    "their neighbours' V\n",
            name, (unsigned long long)t.covered, t.diff_max, t.tol_max, (unsigned long long)t.changed,
            (unsigned long long)t.range, (unsigned long long)t.pen, (unsigned long long)t.kept,
            (unsigned long long)t.borrowed);
    CHECK_MSG(bad == 0, "%s: %llu values outside [0, 1] or on the background", name, (unsigned long long)bad);
    CHECK_MSG(t.covered > (uint64_t)W * H / 2, "%s: %llu covered pixels", name, (unsigned long long)t.covered);
    CHECK_MSG(t.off == 0, "%s: %llu pixels off the recomputed filter", name, (unsigned long long)t.off);
    CHECK_MSG(t.changed > 0, "%s: the filter changed nothing", name);
    CHECK_MSG(bad_width == 0, "%s: %llu pixels whose penumbra width disagrees with V_raw", name,
              (unsigned long long)bad_width);
    CHECK_MSG(finite_widths > 100 && widest > 0, "%s: %llu finite penumbra widths, widest %g", name,
              (unsigned long long)finite_widths, widest);
    return t;
}

// The mean |V - reference| over covered pixels.
static double mae(const float *v, const frame *ref)
{
    double sum = 0;
    uint64_t n = 0;
    for (int i = 0; i < W * H; i++)
        if (ref->p[4 * i + 3] > 0)
            sum += fabs((double)v[i] - ref->v[i]), n++;
    return n ? sum / (double)n : 0;
}

// `penumbra render` with the same options writes the same V and V_raw, bit for bit.
static void check_cli(const frame *f)
{
    const char *exr = pn_test_tmp("filter.exr");
    char args[1024];
    snprintf(args, sizeof args,
             "render builtin:default --size %dx%d --fov 45 --mode exact --spp 4 --filter interleaved --tile 3x3 --aovs -o %s",
             W, H, exr);
    int rc = pn_test_run(args);
    CHECK_MSG(rc == 0, "render exited %d", rc);
    pn_exr_image img;
    if (rc != 0 || pn_exr_read(exr, &img) != PN_OK) {
        CHECK_MSG(false, "%s: cannot read", exr);
        return;
    }
    const float *v = pn_exr_image_channel(&img, "shadow.V"), *raw = pn_exr_image_channel(&img, "shadow.V_raw");
    CHECK_MSG(v && raw && img.width == W && img.height == H, "%s: no shadow.V or shadow.V_raw at %dx%d", exr, W, H);
    if (v && raw && img.width == W && img.height == H) {
        CHECK_MSG(memcmp(v, f->v, sizeof(float) * W * H) == 0, "the EXR's shadow.V is not the frame's");
        CHECK_MSG(memcmp(raw, f->v_raw, sizeof(float) * W * H) == 0, "the EXR's shadow.V_raw is not the frame's");
    }
    pn_exr_image_free(&img);
}

int main(void)
{
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK) {
        CHECK_MSG(false, "no Vulkan device");
        return pn_test_result();
    }
    pn_render_opts o = pn_render_opts_default();
    o.width = W, o.height = H, o.fov = 45, o.has_fov = true;
    o.mode = PN_SHADOW_REFERENCE, o.has_mode = true;
    o.filter = PN_FILTER_INTERLEAVED, o.has_filter = true;
    pn_prepared_scene prep;
    if (pn_render_prepare(&o, "builtin:default", &prep) != PN_EXIT_OK) {
        CHECK_MSG(false, "builtin:default did not load");
        pn_gpu_device_destroy(&dev);
        return pn_test_result();
    }
    frame f4 = {0}, f1 = {0}, f24 = {0}, ref = {0};
    o.spp = 4, o.tile_w = 3, o.tile_h = 3;
    if (render_frame(&dev, &prep, &o, &f4)) {
        tally t = check_frame("4 spp, 3x3", &f4);
        CHECK_MSG(t.range > 0, "the range weight never acted");
        CHECK_MSG(t.pen > 0, "the penumbra weight never acted");
        CHECK_MSG(t.kept > 0, "the rule for pixels below the light's plane never acted");
        // At 4 spp every pixel the light reaches has a valid ray: its samples are one per quarter of
        // the box of the part of the light above its horizon, and that part holds a whole quarter.
        CHECK_MSG(t.borrowed == 0, "%llu pixels the light reaches without a valid ray at 4 spp",
                  (unsigned long long)t.borrowed);
        check_cli(&f4);
    }
    // At 1 spp a grazing pixel's one sample misses the part above (about half of its box) now and
    // then: those pixels take their neighbours' V.
    o.spp = 1;
    if (render_frame(&dev, &prep, &o, &f1)) {
        tally t = check_frame("1 spp, 3x3", &f1);
        CHECK_MSG(t.borrowed > 0, "the rule for pixels the light reaches without a valid ray never acted");
    }
    o.spp = 4, o.tile_w = 2, o.tile_h = 4;
    if (render_frame(&dev, &prep, &o, &f24)) {
        tally t = check_frame("4 spp, 2x4", &f24);
        CHECK_MSG(t.range > 0 && t.pen > 0, "2x4: range weights %llu, penumbra weights %llu between 0 and 1",
                  (unsigned long long)t.range, (unsigned long long)t.pen);
    }
    o.spp = 1024, o.seed = REFERENCE_SEED, o.filter = PN_FILTER_NONE;
    if (f4.v && render_frame(&dev, &prep, &o, &ref)) {
        double mae_f = mae(f4.v, &ref), mae_r = mae(f4.v_raw, &ref);
        fprintf(stderr, "MAE against the converged reference, 4 spp: filtered %.4f, unfiltered %.4f\n", mae_f, mae_r);
        CHECK_MSG(mae_f < mae_r, "the filter does not lower the error: %.4f against %.4f", mae_f, mae_r);
    }
    frame_free(&f4), frame_free(&f1), frame_free(&f24), frame_free(&ref);
    pn_scene_destroy(&prep.scene);
    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    pn_gpu_device_destroy(&dev);
    return pn_test_result();
}
