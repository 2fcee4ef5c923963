// Several lights in one frame (pn_renderer_render_lights) against single-light frames:
//  1. Linearity: light transport is linear in the emitters, so the radiance of a frame lit by A and
//     B is the sum of the frames lit by A alone and by B alone. With the same samples (every light's
//     samples are a function of the seed and the pixel only) the sum is exact up to the float
//     rounding of the shading pass's one addition per light: all terms are >= 0, so a relative
//     error of 2^-24 per addition, far under the 1e-4 required on every pixel. Each light's V in
//     the pair's frame must equal its single frame's V bit for bit. Every tracing mode is checked
//     with and without the interleaved filter, exact also with the penumbra filter, its window kept
//     or not (where the lights' planes lie in the readback buffer); the line-space modes over one tree built for the set {A, B}
//     (the tree depends on the set of lights, not on which of them a frame traces).
//  2. The tree of a set of lights: a triangle may be left out only when it cannot block a ray to
//     any light of the set. The default scene's ground plane cannot block rays to a light above
//     it, so it is left out for A; a light below the ground (facing up, through it) makes it a
//     blocker: the set {A, C} must keep it, and keep every triangle either light alone keeps.
//  3. The budgeted split (--split budget): spp x lights rays per pixel, shared by each light's
//     unshadowed irradiance, at least one per lit light.
//     a. Counts: with light B at 1e-4 of A's radiance, B's share of the 2 x 8 - 2 rays left after
//        one each rounds to none, so B gets exactly one ray: its V is 0 or 1 on every pixel (with
//        the even split's 8 rays, some pixels see a fraction: the guard). A point light takes one
//        ray under both splits, so its V is the same bit for bit.
//     b. Variance: with B at 1/20 of A, budget's radiance is closer to a converged reference
//        (exact, 1024 rays per light, another seed) than even's at the same rays per pixel:
//        proportional allocation minimises sum E_l^2 V_l (1 - V_l) / n_l. And it is unbiased: the
//        mean signed error over the pixels is within 4 standard errors of zero.
// The scene is the built-in default with its ground; validation layer on, any message fails.
#include "shadow/setup.h"
#include "test_util.h"

enum { W = 96, H = 72 };

typedef struct frame {
    float radiance[4 * W * H];
    float v[2][W * H]; // per light
    uint32_t lights;
} frame;

static bool render(pn_setup *s, const pn_camera *cam, const pn_light *lights, uint32_t count, frame *out)
{
    pn_frame_times t;
    pn_result r = pn_renderer_render_lights(&s->renderer, cam, lights, count, &t);
    CHECK_MSG(r == PN_OK, "render with %u lights: %s", count, pn_result_str(r));
    if (r != PN_OK)
        return false;
    pn_frame_images img;
    pn_renderer_images(&s->renderer, &img);
    CHECK(img.light_count == count);
    memcpy(out->radiance, img.radiance, sizeof out->radiance);
    for (uint32_t i = 0; i < count && i < 2; i++)
        memcpy(out->v[i], img.v_light[i], sizeof out->v[i]);
    out->lights = count;
    return true;
}

static void light_at(const float pos[3], const float normal[3], float w, float h, const float radiance[3], pn_light *l)
{
    memset(l, 0, sizeof *l);
    memcpy(l->pos, pos, sizeof l->pos);
    memcpy(l->normal, normal, sizeof l->normal);
    l->up[0] = 0, l->up[1] = 0, l->up[2] = 1;
    if (fabsf(normal[2]) > 0.9f)
        l->up[0] = 1, l->up[2] = 0;
    l->size[0] = w, l->size[1] = h;
    memcpy(l->radiance, radiance, sizeof l->radiance);
}

// Linearity for one mode and filter: frames of A, B and {A, B} over one set-up.
static void check_linearity(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light ab[2],
                            pn_shadow_mode mode, pn_filter filter, bool keep_window)
{
    const char *name = pn_shadow_mode_get(mode)->name;
    pn_setup_desc sd = {.frame = {.width = W, .height = H, .mode = mode, .spp = 4, .seed = 7, .filter = filter,
                                  .keep_window = keep_window},
                        .tree_n = 6, .tree_d = 2, .light_count = 2};
    pn_setup s;
    pn_result r = pn_setup_create(dev, scene, ab, &sd, &s);
    CHECK_MSG(r == PN_OK, "%s: set-up: %s", name, pn_result_str(r));
    if (r != PN_OK)
        return;
    static frame fa, fb, fab;
    if (render(&s, cam, &ab[0], 1, &fa) && render(&s, cam, &ab[1], 1, &fb) && render(&s, cam, ab, 2, &fab)) {
        double worst = 0;
        uint64_t off = 0, v_off = 0, lit_a = 0, lit_b = 0, shadowed = 0;
        for (int i = 0; i < W * H; i++) {
            for (int c = 0; c < 3; c++) {
                double sum = (double)fa.radiance[4 * i + c] + fb.radiance[4 * i + c];
                double d = fabs(fab.radiance[4 * i + c] - sum);
                CHECK_MSG(fa.radiance[4 * i + c] >= 0 && fb.radiance[4 * i + c] >= 0, "%s: negative radiance", name);
                if (sum > 0)
                    worst = fmax(worst, d / sum);
                if (d > 1e-4 * sum && off++ < 5)
                    fprintf(stderr, "  %s: pixel %d channel %d: %.9g, the single frames sum to %.9g\n", name, i, c,
                            fab.radiance[4 * i + c], sum);
            }
            v_off += fab.v[0][i] != fa.v[0][i];
            v_off += fab.v[1][i] != fb.v[0][i];
            lit_a += fa.radiance[4 * i] > 0;
            lit_b += fb.radiance[4 * i] > 0;
            // Covered pixels (alpha) in some light's shadow: the background has V = 0 too.
            shadowed += fab.radiance[4 * i + 3] > 0 && (fa.v[0][i] < 1 || fb.v[0][i] < 1);
        }
        fprintf(stderr, "%-9s filter %-11s%s: worst relative difference %.2e over %d px (%llu lit by A, %llu by B, "
                        "%llu with some shadow); V per light off on %llu px\n",
                name, pn_filter_names[filter], keep_window ? " (window kept)" : "", worst, W * H, (unsigned long long)lit_a, (unsigned long long)lit_b,
                (unsigned long long)shadowed, (unsigned long long)v_off);
        CHECK_MSG(off == 0, "%s filter %s: %llu channels differ from the sum of the single-light frames by more "
                  "than 1e-4 relative", name, pn_filter_names[filter], (unsigned long long)off);
        CHECK_MSG(v_off == 0, "%s filter %s: a light's V differs between its single frame and the pair's on %llu px",
                  name, pn_filter_names[filter], (unsigned long long)v_off);
        // The check means something only where both lights reach and cast shadows.
        CHECK_MSG(lit_a > W * H / 4 && lit_b > W * H / 4 && shadowed > W * H / 20,
                  "%s: the lights light too little of the frame (%llu, %llu px) or cast too little shadow (%llu px)",
                  name, (unsigned long long)lit_a, (unsigned long long)lit_b, (unsigned long long)shadowed);
    }
    pn_setup_destroy(dev, &s);
}

static pn_result setup(pn_gpu_device *dev, const pn_scene *scene, const pn_light *lights, uint32_t light_count,
                       pn_shadow_mode mode, uint32_t spp, uint32_t seed, pn_split split, pn_setup *s)
{
    pn_setup_desc sd = {.frame = {.width = W, .height = H, .mode = mode, .spp = spp, .seed = seed, .split = split},
                        .tree_n = 6, .tree_d = 2, .light_count = light_count};
    pn_result r = pn_setup_create(dev, scene, lights, &sd, s);
    CHECK_MSG(r == PN_OK, "%s set-up, %s split: %s", pn_shadow_mode_get(mode)->name, pn_split_names[split],
              pn_result_str(r));
    return r;
}

// 3a: light B dim or a point light: the rays each light gets show in its V.
static void check_budget_counts(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light ab[2],
                                pn_shadow_mode mode)
{
    const char *name = pn_shadow_mode_get(mode)->name;
    static frame even, budget;
    // B dim: one ray under budget.
    pn_light dim[2] = {ab[0], ab[1]};
    for (int c = 0; c < 3; c++)
        dim[1].radiance[c] = ab[0].radiance[c] * 1e-4f;
    pn_setup s;
    if (setup(dev, scene, dim, 2, mode, 8, 3, PN_SPLIT_EVEN, &s) != PN_OK)
        return;
    bool ok = render(&s, cam, dim, 2, &even) && pn_renderer_set_split(&s.renderer, PN_SPLIT_BUDGET) == PN_OK &&
              render(&s, cam, dim, 2, &budget);
    pn_setup_destroy(dev, &s);
    CHECK_MSG(ok, "%s: dim pair", name);
    if (!ok)
        return;
    uint64_t fractional_even = 0, fractional_budget = 0, covered = 0;
    for (int i = 0; i < W * H; i++) {
        if (!(budget.radiance[4 * i + 3] > 0))
            continue;
        covered++;
        fractional_even += even.v[1][i] > 0 && even.v[1][i] < 1;
        fractional_budget += budget.v[1][i] > 0 && budget.v[1][i] < 1;
    }
    fprintf(stderr, "%s budget counts: the dim light's V is a fraction on %llu px with the even split, %llu with "
                    "the budget (of %llu covered)\n",
            name, (unsigned long long)fractional_even, (unsigned long long)fractional_budget,
            (unsigned long long)covered);
    CHECK_MSG(fractional_even > covered / 50, "%s: too few penumbra pixels of the dim light to tell (%llu)", name,
              (unsigned long long)fractional_even);
    CHECK_MSG(fractional_budget == 0, "%s: the dim light got more than one ray on %llu px", name,
              (unsigned long long)fractional_budget);

    // B a point light: one ray under either split.
    pn_light point[2] = {ab[0], ab[1]};
    point[1].size[0] = point[1].size[1] = 0;
    if (setup(dev, scene, point, 2, mode, 8, 3, PN_SPLIT_EVEN, &s) != PN_OK)
        return;
    ok = render(&s, cam, point, 2, &even) && pn_renderer_set_split(&s.renderer, PN_SPLIT_BUDGET) == PN_OK &&
         render(&s, cam, point, 2, &budget);
    pn_setup_destroy(dev, &s);
    CHECK_MSG(ok, "%s: area and point light", name);
    uint64_t differ = 0, hard = 0;
    for (int i = 0; ok && i < W * H; i++) {
        differ += even.v[1][i] != budget.v[1][i];
        hard += budget.radiance[4 * i + 3] > 0 && budget.v[1][i] == 0;
    }
    CHECK_MSG(ok && differ == 0 && hard > 0, "%s: the point light's V differs between the splits on %llu px (%llu px in "
              "its shadow)", name, (unsigned long long)differ, (unsigned long long)hard);
}

// 3b: error against a converged reference, even and budget at the same rays per pixel. Light A and
// three dim lights (copies of B moved about), each 1/60 of A's light over the frame: the even split
// gives A 8 of a pixel's 32 rays, the budget about 29, where the radiance's noise is.
enum { ERR_LIGHTS = 4 };
static void check_budget_error(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light ab[2],
                               float ext)
{
    static frame ref, even, budget;
    pn_light set[ERR_LIGHTS] = {ab[0], ab[1], ab[1], ab[1]};
    set[2].pos[0] -= 0.6f * ext, set[3].pos[2] -= 0.6f * ext;
    pn_setup s;
    if (setup(dev, scene, set, 2, PN_SHADOW_NONE, 1, 1, PN_SPLIT_EVEN, &s) != PN_OK)
        return;
    // The scale from the unshadowed frames (mode none) of A and of each dim light alone.
    bool ok = render(&s, cam, &set[0], 1, &ref);
    double sum_a = 0;
    for (int i = 0; ok && i < W * H; i++)
        sum_a += ref.radiance[4 * i] + ref.radiance[4 * i + 1] + ref.radiance[4 * i + 2];
    for (int l = 1; ok && l < ERR_LIGHTS; l++) {
        ok = render(&s, cam, &set[l], 1, &even);
        double sum_l = 0;
        for (int i = 0; ok && i < W * H; i++)
            sum_l += even.radiance[4 * i] + even.radiance[4 * i + 1] + even.radiance[4 * i + 2];
        ok = ok && sum_l > 0;
        for (int c = 0; ok && c < 3; c++)
            set[l].radiance[c] = (float)(set[l].radiance[c] * sum_a / sum_l / 60.0);
    }
    pn_setup_destroy(dev, &s);
    CHECK_MSG(ok && sum_a > 0, "budget error: unshadowed frames");
    if (!(ok && sum_a > 0))
        return;
    if (setup(dev, scene, set, ERR_LIGHTS, PN_SHADOW_EXACT, 1024, 101, PN_SPLIT_EVEN, &s) != PN_OK)
        return;
    ok = render(&s, cam, set, ERR_LIGHTS, &ref) && pn_renderer_set_spp(&s.renderer, 8) == PN_OK;
    // Two seeds, so that the figures do not hang on one draw; per pixel the error of the sum of
    // its channels (the three carry one V per light: not independent).
    double ae[2] = {0}, se[2] = {0}, sum = 0, level = 0;
    uint64_t n = 0;
    for (uint32_t seed = 5; ok && seed < 7; seed++) {
        pn_renderer_set_seed(&s.renderer, seed);
        ok = pn_renderer_set_split(&s.renderer, PN_SPLIT_EVEN) == PN_OK &&
             render(&s, cam, set, ERR_LIGHTS, &even) &&
             pn_renderer_set_split(&s.renderer, PN_SPLIT_BUDGET) == PN_OK &&
             render(&s, cam, set, ERR_LIGHTS, &budget);
        for (int i = 0; ok && i < W * H; i++) {
            if (!(ref.radiance[4 * i + 3] > 0))
                continue;
            double r = 0, d[2] = {0};
            for (int c = 0; c < 3; c++) {
                r += ref.radiance[4 * i + c];
                d[0] += even.radiance[4 * i + c];
                d[1] += budget.radiance[4 * i + c];
            }
            for (int k = 0; k < 2; k++) {
                d[k] -= r;
                ae[k] += fabs(d[k]), se[k] += d[k] * d[k];
            }
            sum += d[1], level += r;
            n++;
        }
    }
    pn_setup_destroy(dev, &s);
    CHECK_MSG(ok && n > 0, "budget error: frames");
    if (!(ok && n > 0))
        return;
    double mae[2] = {ae[0] / (double)n, ae[1] / (double)n}, rmse[2] = {sqrt(se[0] / (double)n), sqrt(se[1] / (double)n)};
    double mean = sum / (double)n, sd = sqrt(fmax(se[1] / (double)n - mean * mean, 0.0)), std_err = sd / sqrt((double)n);
    fprintf(stderr, "budget error (exact, 4 lights, 8 rays per light and pixel, 2 seeds, against 1024 with another "
                    "seed; radiance r+g+b): MAE %.4g even, %.4g budget (%.3fx); RMSE %.4g even, %.4g budget (%.3fx); "
                    "budget's mean signed error %.3g (standard error %.3g; mean r+g+b %.4g)\n",
            mae[0], mae[1], mae[1] / mae[0], rmse[0], rmse[1], rmse[1] / rmse[0], mean, std_err, level / (double)n);
    // Where A's rays go from 8 to about 29, its noise falls by sqrt(8/29) = 0.53 if it fell as
    // 1/sqrt(n); on this scene the error falls more slowly than that (pixels near the light's
    // horizon have few valid rays either way), so 0.85 leaves room for it and still fails a split
    // that misplaces the rays (the dim lights alone would be worse than even).
    CHECK_MSG(mae[1] < 0.85 * mae[0] && rmse[1] < 0.85 * rmse[0],
              "the budgeted split's error (MAE %.4g, RMSE %.4g) is not under 0.85 x the even split's (%.4g, %.4g)",
              mae[1], rmse[1], mae[0], rmse[0]);
    CHECK_MSG(fabs(mean) < 4 * std_err, "the budgeted split is biased: mean error %.3g, standard error %.3g", mean,
              std_err);
}

// The culled triangles of the scene's tree for a set of lights.
static uint32_t culled(const pn_scene *scene, const pn_light *lights, uint32_t count, pn_shadow_accel *out)
{
    pn_shadow_accel_desc ad = {.needs = {.tree = true}, .tree_n = 4, .tree_d = 2, .light = lights,
                               .light_count = count};
    pn_result r = pn_shadow_accel_build(scene, &ad, out);
    CHECK_MSG(r == PN_OK, "tree for %u lights: %s", count, pn_result_str(r));
    return r == PN_OK ? out->tree.culled : 0;
}

int main(void)
{
    // Camera and lights frame the scene itself, then the ground goes under it (as render does).
    pn_scene scene;
    if (pn_scene_load("builtin:default", &scene) != PN_OK) {
        CHECK_MSG(false, "the default scene");
        return pn_test_result();
    }
    pn_camera cam;
    pn_camera_frame(scene.bounds_min, scene.bounds_max, 45.0f, &cam);
    // The scene's own default light (above, tilted), and a second one low at the side, coloured,
    // smaller: their shadows fall in other directions.
    pn_light ab[2];
    pn_light_default(scene.bounds_min, scene.bounds_max, &ab[0]);
    float ext = 0, c[3];
    for (int k = 0; k < 3; k++) {
        ext = fmaxf(ext, scene.bounds_max[k] - scene.bounds_min[k]);
        c[k] = 0.5f * (scene.bounds_min[k] + scene.bounds_max[k]);
    }
    float pos_b[3] = {c[0] + 0.3f * ext, scene.bounds_max[1] * 0.5f + 0.15f * ext, c[2] + 0.2f * ext};
    float nb[3] = {c[0] - pos_b[0], c[1] - pos_b[1] - 0.1f * ext, c[2] - pos_b[2]};
    float nl = sqrtf(nb[0] * nb[0] + nb[1] * nb[1] + nb[2] * nb[2]);
    for (int k = 0; k < 3; k++)
        nb[k] /= nl;
    light_at(pos_b, nb, 0.05f * ext, 0.08f * ext, (float[3]){2.0f, 1.0f, 0.5f}, &ab[1]);
    if (pn_scene_add_ground(&scene, 6.0f) != PN_OK) {
        CHECK_MSG(false, "the ground plane");
        pn_scene_destroy(&scene);
        return pn_test_result();
    }

    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK) {
        pn_scene_destroy(&scene);
        TEST_SKIP("no Vulkan device");
    }
    const pn_shadow_mode modes[] = {PN_SHADOW_EXACT, PN_SHADOW_LINESPACE, PN_SHADOW_HYBRID, PN_SHADOW_RAYQUERY,
                                    PN_SHADOW_RTPIPELINE};
    for (size_t m = 0; m < sizeof modes / sizeof modes[0]; m++) {
        const char *lack = NULL;
        if (!pn_shadow_mode_available(&dev, modes[m], &lack)) {
            fprintf(stderr, "%s: not on this device (%s)\n", pn_shadow_mode_get(modes[m])->name, lack);
            continue;
        }
        check_linearity(&dev, &scene, &cam, ab, modes[m], PN_FILTER_NONE, false);
        check_linearity(&dev, &scene, &cam, ab, modes[m], PN_FILTER_INTERLEAVED, false);
    }
    // The penumbra filter, with and without its window kept (keep_window: three more planes of the
    // readback buffer before the lights' own, pn_renderer_images).
    check_linearity(&dev, &scene, &cam, ab, PN_SHADOW_EXACT, PN_FILTER_PENUMBRA, false);
    check_linearity(&dev, &scene, &cam, ab, PN_SHADOW_EXACT, PN_FILTER_PENUMBRA, true);

    // 3. The budgeted split.
    check_budget_counts(&dev, &scene, &cam, ab, PN_SHADOW_EXACT);
    check_budget_counts(&dev, &scene, &cam, ab, PN_SHADOW_LINESPACE);
    check_budget_error(&dev, &scene, &cam, ab, ext);

    // 2. A light under the ground, facing up: the ground's plane separates it from the scene.
    pn_light below;
    float pos_c[3] = {c[0], scene.bounds_min[1] - 0.5f * ext, c[2]}, up[3] = {0, 1, 0};
    light_at(pos_c, up, 0.1f * ext, 0.1f * ext, (float[3]){1, 1, 1}, &below);
    pn_light ac[2] = {ab[0], below};
    pn_shadow_accel ta, tc, tac;
    uint32_t ca = culled(&scene, &ac[0], 1, &ta), cc = culled(&scene, &ac[1], 1, &tc), cac = culled(&scene, ac, 2, &tac);
    fprintf(stderr, "tree culling: %u triangles left out for the light above, %u for the one below, %u for both\n",
            ca, cc, cac);
    // The ground (two triangles) is left out for A; with C it can block, so the set keeps it; and
    // the set leaves out no more than either light alone.
    CHECK_MSG(ca >= 2, "the ground is not left out for the light above (%u culled)", ca);
    CHECK_MSG(cac + 2 <= ca && cac <= cc, "the set {above, below} leaves out %u triangles: more than %u - 2 or %u",
              cac, ca, cc);
    pn_shadow_accel_destroy(NULL, &ta);
    pn_shadow_accel_destroy(NULL, &tc);
    pn_shadow_accel_destroy(NULL, &tac);

    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    pn_gpu_device_destroy(&dev);
    pn_scene_destroy(&scene);
    return pn_test_result();
}
