// Adaptive samples (--spp MIN:MAX, issue 35), through `penumbra render` and its EXRs:
//  1. The rounds add up: with --pixel-error 0 no pixel stops, and every pixel's V is bit for bit
//     the V of MAX samples of the same Sobol' sequence traced in one go (the budgeted split with one
//     light draws them, through another path of the shader: chunk_count, no rounds, no tile lists),
//     in exact and linespace mode; every pixel took MAX rays.
//  2. The stopping rule as stated (adaptive_decide in shadow_frame.glsl): each covered pixel took
//     MIN x 2^k <= MAX rays, and one that stopped before MAX has a standard error below the target.
//  3. Rays where they matter: against a converged reference (exact, 1024 samples, another seed,
//     no filter), adaptive 4:64's unfiltered V has a lower MAE than uniform samples with at least
//     as many rays per pixel as adaptive took on average.
//  4. The estimate's honesty, printed (not asserted): the share of pixels whose error exceeds twice
//     their estimated standard error.
//  5. Bad input: MAX not MIN x 2^k, the budgeted split, the grid sampler: a message and exit 2.
//  6. Where nothing is sampled adaptively (mode none; a point light, whose one sample is exact) the
//     EXR has no shadow.rays or shadow.V_stderr: there is no such estimate to give.
//  7. Under the penumbra filter (4:16): the first round is the uniform frame's, interleaved over the
//     filter's tile (every pixel that took 4 rays has the V_raw of --spp 4 with the same seed, bit
//     for bit); more rays go only where the filter cannot average (every pixel that took more has
//     its nearest blocker's penumbra under 2 pixels wide, from shadow.footprint: the Gaussian's
//     deviation, width scale x width / sqrt(valid rays)), and some pixels take them; there the
//     filtered V is closer to the converged reference than the uniform frame's; and a pixel no
//     refined pixel's samples can reach through the filter is filtered as in the uniform frame, V
//     bit for bit (the filter counts a pixel's samples as at least the first round's).
// The scene is the Stanford bunny from ../shared/assets (builtin:default without it), 128 x 96.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gpu/penumbra_pass.h"
#include "io/exr.h"
#include "test_util.h"

static char g_scene[1024];
static const char *const SIZE = "--size 128x96";

static bool render(const char *out, const char *args)
{
    char cmd[3000];
    snprintf(cmd, sizeof cmd, "render %s %s -o %s %s >/dev/null", g_scene, SIZE, out, args);
    int rc = pn_test_run(cmd);
    CHECK_MSG(rc == 0, "render %s: exit %d", args, rc);
    return rc == 0;
}

static const float *channel(const pn_exr_image *img, const char *name)
{
    const float *c = pn_exr_image_channel(img, name);
    CHECK_MSG(c != NULL, "no channel %s", name);
    return c;
}

// 1. --pixel-error 0: rounds up to MAX for every pixel, equal to MAX samples in one go.
static void check_rounds_add_up(const char *mode)
{
    char label[64];
    snprintf(label, sizeof label, "%s", mode);
    const char *a = pn_test_tmp("adaptive_all.exr"), *b = pn_test_tmp("adaptive_budget.exr");
    char args[512];
    snprintf(args, sizeof args, "--mode %s --spp 4:32 --pixel-error 0 --filter none --seed 5", mode);
    if (!render(a, args))
        return;
    snprintf(args, sizeof args, "--mode %s --spp 32 --split budget --filter none --seed 5", mode);
    if (!render(b, args))
        return;
    pn_exr_image x, y;
    if (pn_exr_read(a, &x) != PN_OK || pn_exr_read(b, &y) != PN_OK) {
        CHECK_MSG(0, "%s: cannot read the renders", label);
        return;
    }
    const float *va = channel(&x, "shadow.V"), *vb = channel(&y, "shadow.V"), *rays = channel(&x, "shadow.rays");
    const float *alpha = channel(&x, "A");
    if (va && vb && rays && alpha) {
        size_t px = (size_t)x.width * x.height, differ = 0, wrong_rays = 0, covered = 0;
        for (size_t i = 0; i < px; i++) {
            differ += memcmp(&va[i], &vb[i], sizeof(float)) != 0;
            covered += alpha[i] > 0;
            wrong_rays += rays[i] != (alpha[i] > 0 ? 32.0f : 0.0f);
        }
        fprintf(stderr, "%s: %zu covered pixels, %zu V differ from one-go, %zu rays counts wrong\n", label, covered,
                differ, wrong_rays);
        CHECK_MSG(covered > px / 4, "%s: the scene covers only %zu of %zu pixels", label, covered, px);
        CHECK_MSG(differ == 0, "%s: %zu pixels' V differ from the same samples traced in one go", label, differ);
        CHECK_MSG(wrong_rays == 0, "%s: %zu pixels did not take 32 rays (0 on the background)", label, wrong_rays);
    }
    pn_exr_image_free(&x);
    pn_exr_image_free(&y);
}

// Mean absolute error of `v` against `ref` over the covered pixels.
static double mae(const float *v, const float *ref, const float *alpha, size_t px)
{
    double sum = 0;
    size_t n = 0;
    for (size_t i = 0; i < px; i++)
        if (alpha[i] > 0)
            sum += fabs((double)v[i] - ref[i]), n++;
    return n ? sum / (double)n : 0;
}

// 2-4 against the converged reference.
static void check_against_reference(void)
{
    const char *ref_path = pn_test_tmp("adaptive_ref.exr"), *ad_path = pn_test_tmp("adaptive_4_64.exr");
    if (!render(ref_path, "--mode exact --spp 1024 --filter none --seed 101") ||
        !render(ad_path, "--mode exact --spp 4:64 --pixel-error 0.02 --filter none --seed 3"))
        return;
    pn_exr_image ref, ad;
    if (pn_exr_read(ref_path, &ref) != PN_OK || pn_exr_read(ad_path, &ad) != PN_OK) {
        CHECK_MSG(0, "cannot read the renders");
        return;
    }
    const float *vr = channel(&ref, "shadow.V"), *va = channel(&ad, "shadow.V"), *rays = channel(&ad, "shadow.rays");
    const float *se = channel(&ad, "shadow.V_stderr"), *alpha = channel(&ad, "A");
    if (!vr || !va || !rays || !se || !alpha)
        goto done;
    size_t px = (size_t)ad.width * ad.height, covered = 0, bad_rays = 0, bad_stop = 0, beyond = 0, stopped = 0;
    double total_rays = 0;
    const float target = 0.02f; // the render's --pixel-error
    for (size_t i = 0; i < px; i++) {
        if (alpha[i] <= 0)
            continue;
        covered++;
        total_rays += rays[i];
        bool power = false;
        for (float n = 4; n <= 64; n *= 2)
            power = power || rays[i] == n;
        bad_rays += !power;
        if (rays[i] < 64) {
            stopped++;
            bad_stop += !(se[i] < target);
        }
        beyond += fabsf(va[i] - vr[i]) > 2.0f * se[i];
    }
    double mean_rays = covered ? total_rays / (double)covered : 0;
    CHECK_MSG(bad_rays == 0, "%zu pixels took a ray count that is not 4 x 2^k <= 64", bad_rays);
    CHECK_MSG(bad_stop == 0, "%zu of %zu pixels stopped before 64 rays with a standard error of %g or more", bad_stop,
              stopped, (double)target);
    fprintf(stderr, "adaptive 4:64: %.2f rays per pixel on average, %zu of %zu pixels stopped early; "
            "%.2f%% of pixels off by more than 2 estimated standard errors\n",
            mean_rays, stopped, covered, 100.0 * (double)beyond / (double)(covered ? covered : 1));
    // 3. Uniform samples at the next whole count at or above the mean.
    int uniform = (int)ceil(mean_rays);
    const char *un_path = pn_test_tmp("adaptive_uniform.exr");
    char args[256];
    snprintf(args, sizeof args, "--mode exact --spp %d --filter none --seed 3", uniform);
    pn_exr_image un;
    if (render(un_path, args) && pn_exr_read(un_path, &un) == PN_OK) {
        const float *vu = channel(&un, "shadow.V");
        if (vu) {
            double e_ad = mae(va, vr, alpha, px), e_un = mae(vu, vr, alpha, px);
            fprintf(stderr, "reference MAE: adaptive 4:64 %.5f (%.2f rays), uniform %d spp %.5f\n", e_ad, mean_rays,
                    uniform, e_un);
            CHECK_MSG(e_ad < e_un, "adaptive's MAE %.5f is not below uniform %d spp's %.5f", e_ad, uniform, e_un);
        }
        pn_exr_image_free(&un);
    }
done:
    pn_exr_image_free(&ref);
    pn_exr_image_free(&ad);
}

static void check_bad_input(void)
{
    const char *out = pn_test_tmp("adaptive_bad.exr");
    static const char *const bad[] = {"--spp 4:12", "--spp 8:4", "--spp 4:64 --split budget",
                                      "--spp 4:64 --sampler grid", "--spp 4:64 --pixel-error -1"};
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        remove(out);
        char cmd[2000];
        snprintf(cmd, sizeof cmd, "render %s %s -o %s %s 2>/dev/null", g_scene, SIZE, out, bad[i]);
        int rc = pn_test_run(cmd);
        CHECK_MSG(rc == 2, "%s: exit %d, expected 2 (bad usage)", bad[i], rc);
        FILE *f = fopen(out, "rb");
        CHECK_MSG(f == NULL, "%s: wrote %s", bad[i], out);
        if (f)
            fclose(f);
    }
}

static void check_not_adaptive(const char *label, const char *args)
{
    const char *out = pn_test_tmp("adaptive_none.exr");
    if (!render(out, args))
        return;
    pn_exr_image x;
    if (pn_exr_read(out, &x) != PN_OK) {
        CHECK_MSG(0, "%s: cannot read %s", label, out);
        return;
    }
    CHECK_MSG(!pn_exr_image_channel(&x, "shadow.rays") && !pn_exr_image_channel(&x, "shadow.V_stderr"),
              "%s: the EXR has adaptive channels", label);
    CHECK_MSG(pn_exr_image_channel(&x, "shadow.V") != NULL, "%s: no shadow.V", label);
    pn_exr_image_free(&x);
}

// 7. Adaptive samples under the penumbra filter, against uniform ones and the reference of 2-4.
static void check_under_filter(void)
{
    const char *ref_path = pn_test_tmp("adaptive_ref.exr"), *ad_path = pn_test_tmp("adaptive_filter_4_16.exr");
    const char *un_path = pn_test_tmp("adaptive_filter_4.exr");
    if (!render(ad_path, "--mode exact --spp 4:16 --pixel-error 0.02 --filter penumbra --aovs --seed 3") ||
        !render(un_path, "--mode exact --spp 4 --filter penumbra --seed 3"))
        return;
    pn_exr_image ref = {0}, ad = {0}, un = {0}; // a failed read leaves its image zeroed
    if (pn_exr_read(ref_path, &ref) != PN_OK || pn_exr_read(ad_path, &ad) != PN_OK || pn_exr_read(un_path, &un) != PN_OK)
        CHECK_MSG(0, "filtered: cannot read the renders (the reference is check_against_reference's)");
    const float *vr = channel(&ref, "shadow.V"), *va = channel(&ad, "shadow.V"), *vu = channel(&un, "shadow.V");
    const float *raw_a = channel(&ad, "shadow.V_raw"), *raw_u = channel(&un, "shadow.V_raw");
    const float *rays = channel(&ad, "shadow.rays"), *valid = channel(&ad, "shadow.valid");
    const float *footprint = channel(&ad, "shadow.footprint"), *alpha = channel(&ad, "A");
    if (ref.data && ad.data && un.data && vr && va && vu && raw_a && raw_u && rays && valid && footprint && alpha) {
        size_t px = (size_t)ad.width * ad.height, first = 0, differ = 0, refined = 0, wide = 0, bad_rays = 0;
        size_t apart = 0, apart_partial = 0, apart_differ = 0, first_partial = 0;
        double err_a = 0, err_u = 0;
        const float scale = pn_penumbra_width_scale();
        for (size_t i = 0; i < px; i++) {
            if (alpha[i] <= 0)
                continue;
            bad_rays += rays[i] != 4 && rays[i] != 8 && rays[i] != 16;
            if (rays[i] == 4) {
                first++;
                first_partial += raw_u[i] > 0 && raw_u[i] < 1;
                differ += memcmp(&raw_a[i], &raw_u[i], sizeof(float)) != 0;
                continue;
            }
            refined++;
            err_a += fabs((double)va[i] - vr[i]);
            err_u += fabs((double)vu[i] - vr[i]);
            // The rule's one exception: a pixel with no valid ray in the first round where the light
            // reaches goes on whatever its width (it has none); such a pixel has at most rays - 4
            // valid ones, and is left out of the width's check.
            if (valid[i] + 4.0f <= rays[i])
                continue;
            // The nearest blocker's penumbra in pixels facing the camera, from the Gaussian's
            // deviation over its valid rays (penumbra_footprint); it only narrows as rays are added,
            // so the decision's was at least as wide. A relative margin for the float rounding.
            float width = footprint[i] * sqrtf(fmaxf(valid[i], 4.0f)) / scale; // as filter.comp counts them
            wide += !(width < 2.0f * (1.0f + 1e-4f));
        }
        // Beyond the filter's reach of every refined pixel: the Gaussian's rows then columns
        // (max_radius each way), the footprints they take from the window pass's 5 x 5 ring and
        // the window itself (2 and 1 more): a box of max_radius + 3 pixels, one pixel to spare.
        int reach = (int)pn_penumbra_max_radius((uint32_t)ad.height) + 4;
        for (int y = 0; y < ad.height; y++) {
            for (int x = 0; x < ad.width; x++) {
                size_t i = (size_t)y * ad.width + x;
                if (alpha[i] <= 0)
                    continue;
                bool near = false;
                for (int qy = y - reach; qy <= y + reach && !near; qy++)
                    for (int qx = x - reach; qx <= x + reach && !near; qx++)
                        near = qy >= 0 && qy < ad.height && qx >= 0 && qx < ad.width &&
                               rays[(size_t)qy * ad.width + qx] > 4;
                if (near)
                    continue;
                apart++;
                apart_partial += raw_u[i] > 0 && raw_u[i] < 1;
                apart_differ += memcmp(&va[i], &vu[i], sizeof(float)) != 0;
            }
        }
        fprintf(stderr, "filtered 4:16: %zu pixels beyond the filter's reach of a refined one (%zu with partial "
                "V_raw), %zu V differ from uniform 4\n", apart, apart_partial, apart_differ);
        CHECK_MSG(apart_partial > 0, "filtered: no pixel with a partial V_raw lies beyond the reach of the refined");
        CHECK_MSG(apart_differ == 0, "filtered: %zu of %zu pixels beyond the reach of a refined one have another V "
                  "than uniform 4's", apart_differ, apart);
        fprintf(stderr, "filtered 4:16: %zu pixels stopped after the first round (%zu V_raw differ from uniform 4), "
                "%zu refined (%zu with a penumbra 2 pixels wide or more); over those, MAE %.4f against uniform "
                "4's %.4f\n", first, differ, refined, wide, refined ? err_a / (double)refined : 0.0,
                refined ? err_u / (double)refined : 0.0);
        CHECK_MSG(bad_rays == 0, "filtered: %zu pixels took a ray count that is not 4, 8 or 16", bad_rays);
        CHECK_MSG(first_partial > 0, "filtered: no pixel that stopped at 4 rays has a partial V_raw");
        CHECK_MSG(differ == 0, "filtered: %zu of %zu pixels that stopped at 4 rays (%zu with a partial V_raw) have "
                  "another V_raw than uniform 4", differ, first, first_partial);
        CHECK_MSG(refined > 0, "filtered: no pixel took more than 4 rays");
        CHECK_MSG(wide == 0, "filtered: %zu of %zu refined pixels have a penumbra 2 pixels wide or more", wide, refined);
        CHECK_MSG(err_a < err_u, "filtered: the refined pixels' MAE %.4f is not below uniform 4's %.4f",
                  refined ? err_a / (double)refined : 0.0, refined ? err_u / (double)refined : 0.0);
    }
    pn_exr_image_free(&ref);
    pn_exr_image_free(&ad);
    pn_exr_image_free(&un);
}

int main(void)
{
    pn_test_scene(g_scene, sizeof g_scene, "stanford-bunny-69k.glb");
    check_bad_input();
    check_rounds_add_up("exact");
    check_rounds_add_up("linespace");
    check_against_reference();
    check_under_filter();
    check_not_adaptive("mode none", "--mode none --spp 4:32");
    check_not_adaptive("point light", "--mode exact --spp 4:32 --light-size 0,0");
    return pn_test_result();
}
