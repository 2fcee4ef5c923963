// The penumbra filter's Gaussian (penumbra_filter.comp) against its oracle (penumbra_oracle.h),
// pixel by pixel, on small frames (exact mode, 1 and 4 spp, --filter penumbra): builtin:default at
// 240x160 (contact shadows, the sphere's curved receiver, the table's legs) and the analytic
// penumbra of test_penumbra_filter.c at 384x384, whose height gives a max_radius of 12, so that
// its widest footprints (4.8 pixels) take taps every 2 pixels.
//
// Each pass is checked from the floats it read, so that neither bound carries the other's error:
//  - the interleaved window before it (filter.comp under the penumbra filter: its Gaussian over
//    the nearest blocker's penumbra, taken as at least a pixel wide, which the contacts must
//    reach, and the penumbra weight only within CONTACT_REACH pixels of an edge of geometry) against filter_oracle.c, from the frame's P, N, counts and nearest blockers
//    (pn_frame_images.blockers), every covered pixel within the oracle's bound; the rule must both
//    lift refusals and keep some that only its ring of pixels 2 away justifies. Written against the
//    old rule (the weight everywhere), without the window's Gaussian or without the ring, the
//    oracle puts 356-602 pixels of builtin:default at 1 spp off the shader;
//  - the footprint the row pass centres on: a pixel without a blocked ray of its own takes the
//    narrowest of its 3 x 3 neighbours', failing them of the 5 x 5's outer ring (relative bound:
//    the recovered footprints' 6u and the quotient's 5u, twice);
//  - the row pass's V (pn_frame_images.footprint's first channel) from the interleaved window's V
//    (pn_frame_images.v_window, the renderer's desc.keep_window), and the column pass's V (the
//    frame's) from the row pass's V and footprint; where the Gaussian does not run (a deviation
//    below MIN_SIGMA, the background) bit for bit, else within the oracle's bound on the float
//    evaluation (penumbra_oracle.c: each weight's rounding, propagated through the weighted mean);
//  - pixels whose deviation lies within its float error of a threshold of the shader's integer
//    choices (MIN_SIGMA, the step, the reach) are left out, counted, and must be fewer than 1 in
//    1000 of those filtered: that error is some 1e-5 relative, so a few in 10^5 are expected; and
//    so are those whose float weights may all be 0 or not (taps on a surface at right angles, next
//    to a pixel without a valid ray of its own, which lends nothing to itself), fewer than 1 in 100;
//  - the weights act: taps with a range, a surface and a Gaussian weight strictly inside (0, 1), a
//    tap's narrower footprint, and (on the analytic penumbra) a step of 2.
// Validation layer on: any message fails.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/args.h"
#include "apps/render_opts.h"
#include "gpu/shadow_pass.h"
#include "interface.h" // PN_PENUMBRA_SCRATCH_CLEAR
#include "penumbra_oracle.h"
#include "shadow/setup.h"
#include "test_util.h"

typedef struct frame {
    float *p, *n, *v, *v_raw, *v_window, *scratch;
    uint32_t *valid, *reaches;
    penumbra_frame view;
    // The interleaved window's inputs (filter_oracle.h): the light's reach as bools, the penumbra
    // widths at the mean and at the nearest blocker.
    bool *reaches_b;
    float *width_mean, *width_near;
    filter_frame window;
} frame;

typedef struct tally {
    uint64_t covered, compared, filtered, ambiguous, weightless, off, bits_off, lend_off, no_lend;
    uint64_t range, surface, gauss, narrowed, step2;
    double diff_max, tol_max, ratio_max;
} tally;

static void frame_free(frame *f)
{
    free(f->p), free(f->n), free(f->v), free(f->v_raw), free(f->v_window), free(f->scratch), free(f->valid), free(f->reaches);
    free(f->reaches_b), free(f->width_mean), free(f->width_near);
    memset(f, 0, sizeof *f);
}

// Renders one frame of `scene` under the render options in `args` (a space-separated command line)
// and copies what the Gaussian read and wrote into *f.
static bool render_frame(pn_gpu_device *dev, const char *scene, const char *args, frame *f)
{
    char line[1024], *argv[64];
    snprintf(line, sizeof line, "%s", args);
    int argc = 0;
    for (char *t = strtok(line, " "); t && argc < 64; t = strtok(NULL, " "))
        argv[argc++] = t;
    pn_render_opts o = pn_render_opts_default();
    pn_args a = {argc, argv, 0};
    bool err = false;
    while (a.i < argc && pn_render_opts_parse(&a, &o, &err) && !err) {
    }
    CHECK_MSG(a.i == argc && !err, "options '%s' did not parse", args);
    pn_prepared_scene prep;
    if (a.i != argc || err || pn_render_prepare(&o, scene, &prep) != PN_EXIT_OK) {
        CHECK_MSG(false, "%s did not load", scene);
        return false;
    }
    pn_setup_desc sd = pn_render_opts_setup(&o);
    sd.view = &prep.camera; // as render culls
    sd.light_count = 1;
    sd.frame.keep_window = true;
    pn_setup s;
    bool made = pn_setup_create(dev, &prep.scene, prep.lights, &sd, &s) == PN_OK, ok = made;
    CHECK_MSG(made, "set-up failed");
    pn_frame_times t;
    pn_result r = ok ? pn_renderer_render(&s.renderer, &prep.camera, &prep.lights[0], &t) : PN_ERR_INVALID;
    CHECK_MSG(!ok || r == PN_OK, "render: %s", pn_result_str(r));
    ok = ok && r == PN_OK;
    pn_frame_images img;
    if (ok) {
        pn_renderer_images(&s.renderer, &img);
        CHECK_MSG(img.v_window && img.footprint && img.v_raw && img.blockers,
                  "the Gaussian's input, its row pass or the window's blockers are missing");
        ok = img.v_window && img.footprint && img.v_raw && img.blockers;
    }
    size_t px = (size_t)o.width * o.height;
    if (ok) {
        f->p = malloc(px * 4 * sizeof(float)), f->n = malloc(px * 4 * sizeof(float));
        f->v = malloc(px * sizeof(float)), f->v_raw = malloc(px * sizeof(float));
        f->v_window = malloc(px * sizeof(float)), f->scratch = malloc(px * 2 * sizeof(float));
        f->valid = malloc(px * sizeof(uint32_t)), f->reaches = malloc(px * sizeof(uint32_t));
        f->reaches_b = malloc(px * sizeof(bool));
        f->width_mean = malloc(px * sizeof(float)), f->width_near = malloc(px * sizeof(float));
        ok = f->p && f->n && f->v && f->v_raw && f->v_window && f->scratch && f->valid && f->reaches && f->reaches_b &&
             f->width_mean && f->width_near;
        CHECK(ok);
    }
    if (ok) {
        memcpy(f->p, img.p, px * 4 * sizeof(float));
        memcpy(f->n, img.n, px * 4 * sizeof(float));
        memcpy(f->v, img.v, px * sizeof(float));
        memcpy(f->v_raw, img.v_raw, px * sizeof(float));
        memcpy(f->v_window, img.v_window, px * sizeof(float));
        memcpy(f->scratch, img.footprint, px * 2 * sizeof(float));
        for (size_t i = 0; i < px; i++) {
            f->valid[i] = img.counts[4 * i + 1], f->reaches[i] = img.counts[4 * i + 2];
            f->reaches_b[i] = f->reaches[i] != 0;
            memcpy(&f->width_mean[i], &img.counts[4 * i + 3], sizeof(float));
            f->width_near[i] = img.blockers[2 * i + 1];
        }
        f->view = (penumbra_frame){
            .width = (int)o.width,
            .height = (int)o.height,
            .samples = pn_filter_noise_samples((uint32_t)o.spp, &prep.lights[0]), // as renderer_frame.c passes it
            .max_radius = pn_penumbra_max_radius(o.height),
            .pixel_angle = (float)pn_pixel_angle(prep.camera.yfov_deg, o.height), // as penumbra_pass.c
            .p = f->p,
            .n = f->n,
            .v_raw = f->v_raw,
            .valid = f->valid,
            .reaches = f->reaches,
            .v_window = f->v_window,
            .scratch = f->scratch,
            .v = f->v,
        };
        f->window = (filter_frame){
            .width = (int)o.width,
            .height = (int)o.height,
            .tile_w = 3,
            .tile_h = 3,
            .samples = f->view.samples,
            .pixel_angle = f->view.pixel_angle, // as filter_pass.c passes it
            .p = f->p,
            .n = f->n,
            .v = f->v_window,
            .v_raw = f->v_raw,
            .valid = f->valid,
            .reaches = f->reaches_b,
            .penumbra = f->width_mean,
            .narrow = pn_penumbra_window_scale(), // renderer_frame.c's, one frame accumulated
            .width_near = f->width_near,
        };
        CHECK_MSG(f->view.samples > 0, "an area light's frame has no samples");
        ok = f->view.samples > 0;
    }
    if (made)
        pn_setup_destroy(dev, &s);
    pn_scene_destroy(&prep.scene);
    if (!ok)
        frame_free(f);
    return ok;
}

// One pass over every pixel against the oracle.
static void check_pass(const char *name, const frame *f, bool rows, tally *t)
{
    const penumbra_frame *v = &f->view;
    for (int y = 0; y < v->height; y++)
        for (int x = 0; x < v->width; x++) {
            int i = y * v->width + x;
            penumbra_pixel o;
            // The background: neither pass reads its row output (a tap there weighs 0, and it
            // lends nothing), so outside the marked blocks the row pass does not run and the
            // frame's clear value stays (PN_PENUMBRA_SCRATCH_CLEAR: interface.h); inside them it is
            // the row pass's, its V unlent. Its V is the interleaved window's, bit for bit.
            if (v->p[4 * i + 3] <= 0) {
                float s = v->scratch[2 * i], w = v->v_window[i];
                bool row_ok = (s == PN_PENUMBRA_SCRATCH_CLEAR && v->scratch[2 * i + 1] == 0.0f) ||
                              (penumbra_row_v(s) == w && !penumbra_row_lends(s));
                bool ok = rows ? row_ok : v->v[i] == w;
                if (!ok && t->bits_off++ < 5)
                    fprintf(stderr, "  %s (%d, %d): the background's %s %.9g, its window's V %.9g\n", name, x, y,
                            rows ? "row output" : "V", rows ? s : v->v[i], w);
                continue;
            }
            penumbra_recompute(v, x, y, rows, &o);
            float got = rows ? (float)penumbra_row_v(v->scratch[2 * i]) : v->v[i];
            t->covered++;
            // The row pass marks the pixels that lend nothing along columns.
            bool lends = penumbra_lends(v, i, false);
            t->no_lend += rows && v->p[4 * i + 3] > 0 && !lends;
            if (rows && penumbra_row_lends(v->scratch[2 * i]) != lends && t->lend_off++ < 5)
                fprintf(stderr, "  %s (%d, %d): lends %d, expected %d\n", name, x, y, !lends, lends);
            if (o.ambiguous) {
                t->ambiguous++;
                continue;
            }
            // The float weights may all be 0 (then the pass keeps its input) or not: a neighbour on
            // a surface at right angles to the pixel's has a surface weight of 0 in double and
            // within rounding of it in float (its normals' cosine). Left out and counted as well.
            if (o.filtered && o.tol >= 1) {
                t->weightless++;
                continue;
            }
            t->compared++;
            if (!o.filtered) { // the pass keeps its input, bit for bit
                if (got != (float)o.v_in && t->bits_off++ < 5)
                    fprintf(stderr, "  %s (%d, %d): kept %.9g, got %.9g\n", name, x, y, o.v_in, got);
                continue;
            }
            t->filtered++;
            double diff = fabs(got - o.v);
            t->diff_max = fmax(t->diff_max, diff);
            t->tol_max = fmax(t->tol_max, o.tol);
            t->ratio_max = o.tol > 0 ? fmax(t->ratio_max, diff / o.tol) : t->ratio_max;
            if (diff > o.tol && t->off++ < 5)
                fprintf(stderr, "  %s (%d, %d): V %.9g, oracle %.9g +- %.3g (sigma %.4f px, step %d, reach %d, %d taps)\n",
                        name, x, y, got, o.v, o.tol, o.sigma_px, o.step, o.reach, o.taps);
            t->range += o.range_between, t->surface += o.surface_between, t->gauss += o.gauss_between;
            t->narrowed += o.narrowed, t->step2 += o.step >= 2;
        }
}

// The interleaved window under the penumbra filter (filter.comp with pc.narrow > 0), the Gaussian's
// input, against filter_oracle.c's recomputation on every covered pixel: its own Gaussian over the
// nearest blocker's penumbra and the edge rule, which applies the penumbra weight only within
// CONTACT_REACH pixels of an edge of geometry. Pixels whose verdict lies within rounding of a
// threshold are left out, counted, and must be fewer than 1 in 1000. The rule must act both ways:
// pixels where it lifts a refusal and pixels where only the ring finds the edge.
static void check_window(const char *name, const frame *f, bool analytic)
{
    const filter_frame *w = &f->window;
    uint64_t covered = 0, compared = 0, ambiguous = 0, off = 0, lifted = 0, kept = 0, ring = 0, gauss = 0, pen = 0;
    uint64_t floored = 0, widest = 0, widest_acted = 0;
    double diff_max = 0, tol_max = 0;
    for (int y = 0; y < w->height; y++)
        for (int x = 0; x < w->width; x++) {
            int i = y * w->width + x;
            if (!(w->p[4 * i + 3] > 0))
                continue;
            covered++;
            filter_window o;
            filter_recompute(w, x, y, &o);
            if (o.ambiguous) {
                ambiguous++;
                continue;
            }
            compared++;
            lifted += o.lifted, kept += o.refuses && !o.lifted, ring += o.ring;
            gauss += o.gauss_between, pen += o.pen_between, floored += o.floored;
            widest += o.widest, widest_acted += o.widest_acted;
            double d = fabs(w->v[i] - o.v);
            diff_max = fmax(diff_max, d), tol_max = fmax(tol_max, o.tol);
            if (d > o.tol && off++ < 5)
                fprintf(stderr, "  %s, window (%d, %d): V %.9g, oracle %.9g +- %.3g (refuses %d, lifted %d, ring %d)\n", name,
                        x, y, w->v[i], o.v, o.tol, o.refuses, o.lifted, o.ring);
        }
    fprintf(stderr,
            "%s, window: %llu covered pixels compared, %llu ambiguous; max |V - oracle| %.3g, max bound %.3g; the penumbra "
            "weight would refuse at %llu, applies at %llu (the ring's edge %llu), lifted at %llu; taps strictly weighted: "
            "Gaussian %llu (at its floor %llu), penumbra %llu; V's variance at its largest %llu (a weight changed %llu)\n",
            name, (unsigned long long)compared, (unsigned long long)ambiguous, diff_max, tol_max,
            (unsigned long long)(kept + lifted), (unsigned long long)kept, (unsigned long long)ring,
            (unsigned long long)lifted, (unsigned long long)gauss, (unsigned long long)floored, (unsigned long long)pen,
            (unsigned long long)widest, (unsigned long long)widest_acted);
    CHECK_MSG(off == 0, "%s, window: %llu pixels off the oracle", name, (unsigned long long)off);
    CHECK_MSG(ambiguous * 1000 < covered, "%s, window: %llu of %llu pixels ambiguous", name,
              (unsigned long long)ambiguous, (unsigned long long)covered);
    CHECK_MSG(lifted > 0 && kept > 0 && ring > 0, "%s, window: the edge rule lifted %llu refusals, kept %llu (%llu by the ring)",
              name, (unsigned long long)lifted, (unsigned long long)kept, (unsigned long long)ring);
    // builtin:default's contact shadows make the window's Gaussian a few pixels wide; the analytic
    // penumbra's blocker is far, which at 1 spp leaves it far wider than the window.
    CHECK_MSG((analytic || gauss > 0) && pen > 0, "%s, window: the Gaussian (%llu) or the penumbra weight (%llu) never acted",
              name, (unsigned long long)gauss, (unsigned long long)pen);
    // Its contacts also hold pixels whose nearest blocker casts a penumbra under a pixel, which
    // the Gaussian takes as a pixel wide.
    CHECK_MSG(analytic || floored > 0, "%s, window: the Gaussian never took its floor", name);
    // At one sample, away from edges of geometry, the range weight takes V's largest variance:
    // it must change some neighbour's weight from the window mean's (at more samples it never acts).
    CHECK_MSG(w->samples != 1 || widest_acted > 0, "%s, window: V's variance never taken at its largest", name);
}

// The row pass's footprint output: where the pixel has no blocked ray of its own, the narrowest of its
// 3 x 3 neighbours', else of the 5 x 5's outer ring, over its pixel's footprint (0 if none; 0 on the
// background). Counts the pixels that took a neighbour's, from either ring.
static void check_dilation(const char *name, const frame *f, uint64_t dilated[2])
{
    const penumbra_frame *v = &f->view;
    uint64_t off = 0;
    dilated[0] = dilated[1] = 0;
    for (int y = 0; y < v->height; y++)
        for (int x = 0; x < v->width; x++) {
            int i = y * v->width + x;
            int ring = -1;
            double fp = (float)((double)v->n[4 * i + 3] * v->pixel_angle);
            double want = penumbra_centre_footprint(v, x, y, &ring);
            want = v->p[4 * i + 3] > 0 ? want / fp : 0.0;
            if (ring == 0)
                continue; // the footprint is the pixel's own: recovered from this very output
            double got = v->scratch[2 * i + 1];
            if (want > 0)
                dilated[ring - 1]++;
            if (fabs(got - want) > 2 * (PENUMBRA_SIGMA_REL + 5 * FLOAT_U) * want && off++ < 5)
                fprintf(stderr, "  %s (%d, %d): footprint %.9g px, oracle %.9g (ring %d)\n", name, x, y, got, want, ring);
        }
    fprintf(stderr, "%s: footprints from the 3 x 3 neighbours %llu, from the 5 x 5's outer ring %llu\n", name,
            (unsigned long long)dilated[0], (unsigned long long)dilated[1]);
    CHECK_MSG(off == 0, "%s: %llu dilated footprints off their oracle", name, (unsigned long long)off);
}

static void check_frame(const char *name, const frame *f, bool analytic)
{
    check_window(name, f, analytic);
    uint64_t dilated[2];
    check_dilation(name, f, dilated);
    tally r = {0}, c = {0};
    check_pass(name, f, true, &r);
    check_pass(name, f, false, &c);
    const tally *ts[2] = {&r, &c};
    for (int k = 0; k < 2; k++) {
        const tally *t = ts[k];
        const char *pass = k == 0 ? "rows" : "columns";
        fprintf(stderr,
                "%s, %s: %llu pixels compared (%llu filtered), left out: %llu ambiguous, %llu weightless; max |V - oracle| %.3g, "
                "max bound %.3g, max |diff| / bound %.3f; taps strictly weighted: range %llu, surface %llu, "
                "Gaussian %llu; narrowed %llu, step >= 2 %llu\n",
                name, pass, (unsigned long long)t->compared, (unsigned long long)t->filtered,
                (unsigned long long)t->ambiguous, (unsigned long long)t->weightless, t->diff_max, t->tol_max, t->ratio_max, (unsigned long long)t->range,
                (unsigned long long)t->surface, (unsigned long long)t->gauss, (unsigned long long)t->narrowed,
                (unsigned long long)t->step2);
        CHECK_MSG(t->off == 0, "%s, %s: %llu pixels off the oracle", name, pass, (unsigned long long)t->off);
        CHECK_MSG(t->bits_off == 0, "%s, %s: %llu unfiltered pixels changed", name, pass, (unsigned long long)t->bits_off);
        CHECK_MSG(t->lend_off == 0, "%s, %s: %llu pixels marked as lending wrongly", name, pass, (unsigned long long)t->lend_off);
        CHECK_MSG(t->ambiguous * 1000 < t->filtered && t->weightless * 100 < t->filtered,
                  "%s, %s: %llu ambiguous and %llu weightless pixels left out, %llu filtered", name, pass,
                  (unsigned long long)t->ambiguous, (unsigned long long)t->weightless, (unsigned long long)t->filtered);
        CHECK_MSG(t->filtered > 500, "%s, %s: only %llu pixels filtered", name, pass, (unsigned long long)t->filtered);
        CHECK_MSG(t->range > 0 && t->gauss > 0, "%s, %s: the range or the Gaussian weight never acted", name, pass);
    }
    // A plane's surface weight is 1 (builtin:penumbra's receiver); the widest footprints lie along
    // the analytic penumbra's rows (its columns are foreshortened, 45 degrees).
    CHECK_MSG(analytic || r.surface + c.surface > 0, "%s: the surface weight never acted", name);
    CHECK_MSG(!analytic || r.step2 + c.step2 > 0, "%s: no pixel took taps 2 pixels apart", name);
    CHECK_MSG(r.narrowed + c.narrowed > 0, "%s: no tap took its narrower footprint", name);
    // builtin:default's sphere and table legs turn away from the light: pixels that lend nothing.
    fprintf(stderr, "%s: %llu covered pixels lend nothing along columns\n", name, (unsigned long long)r.no_lend);
    CHECK_MSG(analytic || r.no_lend > 0, "%s: no pixel the light cannot reach", name);
    CHECK_MSG(dilated[0] > 0 && dilated[1] > 0, "%s: no pixel took a footprint from the 3 x 3 (%llu) or the 5 x 5's outer ring (%llu)",
              name, (unsigned long long)dilated[0], (unsigned long long)dilated[1]);
}

int main(void)
{
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK) {
        CHECK_MSG(false, "no Vulkan device");
        return pn_test_result();
    }
    static const char *const ANALYTIC = "--no-ground --size 384x384 --camera-pos 0,3,3 --camera-target 0,0,0 --fov 40 "
                                        "--light-pos 0,1.5,0 --light-normal 0,-1,0 --light-up 0,0,-1 "
                                        "--light-size 0.5,0.5 --mode exact --filter penumbra --seed 1";
    static const char *const DEFAULT = "--size 240x160 --mode exact --filter penumbra --seed 1";
    for (int spp = 1; spp <= 4; spp *= 4) {
        char args[512], name[64];
        frame f = {0};
        snprintf(args, sizeof args, "%s --spp %d", DEFAULT, spp);
        snprintf(name, sizeof name, "default, %d spp", spp);
        if (render_frame(&dev, "builtin:default", args, &f))
            check_frame(name, &f, false);
        frame_free(&f);
        snprintf(args, sizeof args, "%s --spp %d", ANALYTIC, spp);
        snprintf(name, sizeof name, "analytic penumbra, %d spp", spp);
        if (render_frame(&dev, "builtin:penumbra", args, &f))
            check_frame(name, &f, true);
        frame_free(&f);
    }
    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    pn_gpu_device_destroy(&dev);
    return pn_test_result();
}
