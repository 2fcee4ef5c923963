// Progressive refinement by adaptive samples (pn_renderer_set_continue: the demo's accumulation
// with --spp MIN:MAX), at the renderer, in exact and linespace mode:
//  1. Frames add up: with pixel error 0 no pixel stops, and a frame of 4:8 continued to 4:32 has,
//     bit for bit, the V of one frame of 4:32 (the same Sobol' samples of every pixel), and every
//     covered pixel took 32 rays.
//  2. Only uncertain pixels trace: a frame of 4:16 at pixel error E continued to 4:32 at E / sqrt(2)
//     decides first over the counts the first frame left, so a pixel that reached 16 there (its
//     standard error was estimated over its neighbours' final counts, the ones the continued
//     decision pools) takes what the stopping rule (shadow_frame.glsl, adaptive_decide), replayed
//     here on the CPU, makes of that error and of the counts: 32 rays where it goes on, 16 where
//     it stops. Every other pixel takes its rays or twice them, never fewer. Some pixels must go on
//     and some stop, or the check proves nothing.
//  3. The picture converges: against a converged reference (exact, 1024 samples, another seed), the
//     MAE of V falls from the first frame to the third continued one.
//  4. Continuing is only ever a choice: a uniform frame, one that does not raise the most samples, or
//     one of another seed, asked to continue, is a frame of its own (pn_renderer.resumed false, and
//     bit for bit where the samples are the same); in 1. the continued frame did resume.
//  5. Under the penumbra filter, a frame refines only where the filter cannot average (a penumbra
//     under 2 pixels: adaptive_decide), but a continued one by the error alone: more pixels that
//     stopped at 4 rays in the first frame go on in the continued one than the first frame refined
//     (the wide penumbrae's; with the rule in the continued frame too, 16 against 302), so that the
//     picture keeps converging as the demo's refinement adds frames.
// The scene is the Stanford bunny from ../shared/assets (builtin:default without it) on its ground,
// 128 x 96; validation layer on, any message fails.
#include "shadow/metrics.h"
#include "shadow/setup.h"
#include "test_util.h"

enum { W = 128, H = 96, PX = W * H };

typedef struct frame {
    float v[PX];
    uint32_t counts[4 * PX], rays[4 * PX];
    bool has_rays;
    uint8_t covered[PX];
} frame;

static bool render(pn_setup *s, const pn_camera *cam, const pn_light *light, frame *out)
{
    pn_frame_times t;
    pn_result r = pn_renderer_render(&s->renderer, cam, light, &t);
    CHECK_MSG(r == PN_OK, "render: %s", pn_result_str(r));
    if (r != PN_OK)
        return false;
    pn_frame_images img;
    pn_renderer_images(&s->renderer, &img);
    memcpy(out->v, img.v, sizeof out->v);
    memcpy(out->counts, img.counts, sizeof out->counts);
    out->has_rays = img.rays != NULL;
    if (img.rays)
        memcpy(out->rays, img.rays, sizeof out->rays);
    for (size_t i = 0; i < PX; i++)
        out->covered[i] = img.p[4 * i + 3] > 0;
    return true;
}

static bool setup(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                  pn_shadow_mode mode, uint32_t spp_min, uint32_t spp, float error, uint32_t seed, pn_setup *s)
{
    pn_setup_desc sd = {.frame = {.width = W, .height = H, .mode = mode, .traversal = PN_TRAVERSAL_AUTO,
                                  .sampler = PN_SAMPLER_STRATIFIED, .spp = spp, .spp_min = spp_min,
                                  .pixel_error = error, .seed = seed, .filter = PN_FILTER_NONE},
                        .tree_n = 6, .tree_d = 3, .view = cam};
    pn_result r = pn_setup_create(dev, scene, light, &sd, s);
    CHECK_MSG(r == PN_OK, "%s set-up: %s", pn_shadow_mode_get(mode)->name, pn_result_str(r));
    return r == PN_OK;
}

static size_t differing_v(const frame *a, const frame *b)
{
    size_t n = 0;
    for (size_t i = 0; i < PX; i++)
        n += memcmp(&a->v[i], &b->v[i], sizeof(float)) != 0;
    return n;
}

// 1. With pixel error 0, 4:8 continued to 4:32 equals 4:32 in one frame.
static void check_frames_add_up(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                                const pn_light *light, pn_shadow_mode mode, frame *f, frame *g)
{
    const char *name = pn_shadow_mode_get(mode)->name;
    pn_setup s;
    if (!setup(dev, scene, cam, light, mode, 4, 8, 0.0f, 5, &s))
        return;
    bool ok = render(&s, cam, light, f) && pn_renderer_set_adaptive(&s.renderer, 4, 32, 0.0f) == PN_OK;
    pn_renderer_set_continue(&s.renderer, true);
    ok = ok && render(&s, cam, light, f);
    bool resumed = s.renderer.resumed; // else the two frames below are both of their own: equal anyway
    pn_renderer_set_continue(&s.renderer, false);
    ok = ok && render(&s, cam, light, g); // 4:32 in one frame, same set-up and seed
    CHECK_MSG(!ok || (resumed && !s.renderer.resumed), "%s: the continued frame did not resume (%d), or the one "
              "not asked to did (%d)", name, resumed, s.renderer.resumed);
    pn_setup_destroy(dev, &s);
    if (!ok)
        return;
    size_t covered = 0, wrong_rays = 0;
    for (size_t i = 0; i < PX; i++) {
        covered += f->covered[i];
        wrong_rays += f->rays[4 * i] != (f->covered[i] ? 32u : 0u);
    }
    size_t differ = differing_v(f, g);
    fprintf(stderr, "%s: 4:8 continued to 4:32 at error 0: %zu covered pixels, %zu V differ from 4:32 in one frame, "
                    "%zu rays counts wrong\n",
            name, covered, differ, wrong_rays);
    CHECK_MSG(f->has_rays && covered > PX / 4, "%s: rays image %d, %zu covered pixels", name, f->has_rays, covered);
    CHECK_MSG(differ == 0, "%s: %zu pixels' V differ from the same samples in one frame", name, differ);
    CHECK_MSG(wrong_rays == 0, "%s: %zu pixels did not take 32 rays (0 on the background)", name, wrong_rays);
}

// adaptive_decide's rule on the CPU, from a frame's counts and its last decision's standard errors:
// does pixel i stop under pixel error `error` and at most `spp` samples?
static bool stops(const frame *f, int x, int y, float error, uint32_t spp)
{
    size_t i = (size_t)y * W + x;
    const uint32_t *c = &f->counts[4 * i];
    uint32_t done = f->rays[4 * i];
    float stderr_v;
    memcpy(&stderr_v, &f->rays[4 * i + 1], sizeof stderr_v);
    bool unanimous = c[1] > 0 && (c[0] == 0 || c[0] == c[1]), agree = true;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            int qx = x + dx, qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= W || qy >= H || !f->covered[(size_t)qy * W + qx])
                continue;
            const uint32_t *cq = &f->counts[4 * ((size_t)qy * W + qx)];
            if (cq[1] > 0 && (uint64_t)cq[0] * c[1] != (uint64_t)c[0] * cq[1])
                agree = false;
        }
    return done >= spp || (stderr_v < error && (!unanimous || agree));
}

// 2. and 3. A frame at E, continued with twice the samples at E / sqrt(2), three times.
static void check_uncertain_first(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                                  const pn_light *light, pn_shadow_mode mode, const float *reference, frame *f,
                                  frame *g)
{
    const char *name = pn_shadow_mode_get(mode)->name;
    const float e0 = 0.05f;
    pn_setup s;
    if (!setup(dev, scene, cam, light, mode, 4, 16, e0, 5, &s))
        return;
    if (!render(&s, cam, light, f)) {
        pn_setup_destroy(dev, &s);
        return;
    }
    pn_error_metrics m;
    double mae[4] = {0};
    CHECK(pn_error_compare(f->v, reference, f->covered, PX, NULL, &m));
    mae[0] = m.mae;
    uint32_t spp = 16;
    float e = e0;
    for (int k = 1; k <= 3; k++) {
        spp *= 2;
        e *= 0.70710678f;
        if (pn_renderer_set_adaptive(&s.renderer, 4, spp, e) != PN_OK)
            break;
        pn_renderer_set_continue(&s.renderer, true);
        if (!render(&s, cam, light, g))
            break;
        if (k == 1) {
            // The continued frame's one round: the pixels at 16 as the rule decides on the first
            // frame's figures; the others once more or not at all.
            size_t on = 0, stopped = 0, wrong = 0, others = 0, others_on = 0, others_wrong = 0;
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++) {
                    size_t i = (size_t)y * W + x;
                    uint32_t before = f->rays[4 * i], after = g->rays[4 * i];
                    if (!f->covered[i])
                        continue;
                    if (before < 16) {
                        others++;
                        others_on += after == 2 * before;
                        others_wrong += after != before && after != 2 * before;
                        continue;
                    }
                    bool stop = stops(f, x, y, e, spp);
                    on += !stop, stopped += stop;
                    wrong += after != (stop ? before : 2 * before);
                }
            fprintf(stderr, "%s: 4:16 at %g continued to 4:32 at %g: of the pixels at 16, %zu went on and %zu stopped, "
                            "%zu not as the rule decides; of the %zu others, %zu went on, %zu neither kept nor doubled "
                            "their rays\n",
                    name, (double)e0, (double)e, on, stopped, wrong, others, others_on, others_wrong);
            CHECK_MSG(on > 0 && stopped > 0 && others > on + stopped,
                      "%s: %zu pixels went on, %zu stopped, %zu others: the check proves nothing", name, on, stopped,
                      others);
            CHECK_MSG(wrong == 0 && others_wrong == 0, "%s: %zu pixels at 16 not as the rule decides, %zu others "
                      "neither kept nor doubled their rays", name, wrong, others_wrong);
        }
        CHECK(pn_error_compare(g->v, reference, g->covered, PX, NULL, &m));
        mae[k] = m.mae;
        uint64_t rays = 0, covered = 0;
        for (size_t i = 0; i < PX; i++)
            rays += g->rays[4 * i], covered += g->covered[i];
        fprintf(stderr, "%s: frame %d (4:%u at %.4f): reference MAE %.5f, %.1f rays per pixel\n", name, k, spp,
                (double)e, mae[k], covered ? (double)rays / (double)covered : 0.0);
    }
    pn_setup_destroy(dev, &s);
    fprintf(stderr, "%s: reference MAE %.5f after the first frame, %.5f after three continued\n", name, mae[0], mae[3]);
    CHECK_MSG(mae[3] > 0 && mae[3] < mae[0], "%s: the continued frames' MAE %.5f is not below the first's %.5f", name,
              mae[3], mae[0]);
}

// 4. Asked to continue where it cannot, a frame is its own.
static void check_not_continued(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                                frame *f, frame *g)
{
    pn_setup s;
    if (!setup(dev, scene, cam, light, PN_SHADOW_EXACT, 4, 16, 0.05f, 5, &s))
        return;
    // The same most samples: nothing to continue.
    bool ok = render(&s, cam, light, f);
    pn_renderer_set_continue(&s.renderer, true);
    ok = ok && render(&s, cam, light, g);
    if (ok)
        CHECK_MSG(!s.renderer.resumed && differing_v(f, g) == 0,
                  "a frame asked to continue without more samples resumed, or differs from its own");
    // Uniform samples: nothing adaptive to continue.
    ok = ok && pn_renderer_set_adaptive(&s.renderer, 0, 16, 0.05f) == PN_OK && render(&s, cam, light, f);
    pn_renderer_set_continue(&s.renderer, true);
    ok = ok && render(&s, cam, light, g);
    if (ok)
        CHECK_MSG(!s.renderer.resumed && differing_v(f, g) == 0 && !g->has_rays,
                  "a uniform frame asked to continue resumed, or differs from its own");
    // Another seed: the counts are another draw's.
    ok = ok && pn_renderer_set_adaptive(&s.renderer, 4, 16, 0.05f) == PN_OK && render(&s, cam, light, f);
    pn_renderer_set_seed(&s.renderer, 6);
    ok = ok && pn_renderer_set_adaptive(&s.renderer, 4, 32, 0.05f) == PN_OK;
    pn_renderer_set_continue(&s.renderer, true);
    ok = ok && render(&s, cam, light, g);
    if (ok)
        CHECK_MSG(!s.renderer.resumed, "a frame of another seed asked to continue resumed the last one's counts");
    pn_setup_destroy(dev, &s);
}

// 5. The penumbra filter's rule in a first frame and not in a continued one.
static void check_filtered_continues(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                                     const pn_light *light, frame *f, frame *g)
{
    pn_setup s;
    if (!setup(dev, scene, cam, light, PN_SHADOW_EXACT, 4, 16, 0.05f, 5, &s))
        return;
    bool ok = pn_renderer_set_filter(&s.renderer, PN_FILTER_PENUMBRA, 3, 3) == PN_OK && render(&s, cam, light, f);
    ok = ok && pn_renderer_set_adaptive(&s.renderer, 4, 32, 0.05f) == PN_OK;
    pn_renderer_set_continue(&s.renderer, true);
    ok = ok && render(&s, cam, light, g);
    if (ok && f->has_rays && g->has_rays) {
        size_t refined = 0, went_on = 0;
        for (size_t i = 0; i < PX; i++) {
            refined += f->covered[i] && f->rays[4 * i] > 4;
            went_on += f->covered[i] && f->rays[4 * i] == 4 && g->rays[4 * i] > 4;
        }
        fprintf(stderr, "penumbra filter: %zu pixels refined in the first frame, %zu that stopped at 4 went on in "
                "the continued one\n", refined, went_on);
        CHECK_MSG(s.renderer.resumed, "penumbra filter: the continued frame did not resume");
        CHECK_MSG(refined > 0, "penumbra filter: no pixel refined in the first frame");
        CHECK_MSG(went_on > refined, "penumbra filter: %zu pixels that stopped at 4 rays went on in the continued "
                  "frame, no more than the %zu the first frame refined", went_on, refined);
    } else {
        CHECK_MSG(ok, "penumbra filter: the frames");
    }
    pn_setup_destroy(dev, &s);
}

int main(void)
{
    char path[1024];
    pn_test_scene(path, sizeof path, "stanford-bunny-69k.glb");
    pn_scene scene;
    if (pn_scene_load(path, &scene) != PN_OK) {
        CHECK_MSG(false, "%s", path);
        return pn_test_result();
    }
    pn_camera cam;
    pn_camera_frame(scene.bounds_min, scene.bounds_max, 45.0f, &cam);
    pn_light light;
    pn_light_default(scene.bounds_min, scene.bounds_max, &light);
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
    frame *f = malloc(sizeof *f), *g = malloc(sizeof *g);
    float *reference = malloc(PX * sizeof *reference);
    pn_setup s;
    if (f && g && reference &&
        setup(&dev, &scene, &cam, &light, PN_SHADOW_EXACT, 0, PN_REFERENCE_SPP, 0.0f, PN_REFERENCE_SEED, &s)) {
        bool ok = render(&s, &cam, &light, f);
        pn_setup_destroy(&dev, &s);
        memcpy(reference, f->v, PX * sizeof *reference);
        fprintf(stderr, "scene %s, %dx%d\n", path, W, H);
        const pn_shadow_mode modes[] = {PN_SHADOW_EXACT, PN_SHADOW_LINESPACE};
        for (size_t m = 0; ok && m < sizeof modes / sizeof modes[0]; m++) {
            check_frames_add_up(&dev, &scene, &cam, &light, modes[m], f, g);
            check_uncertain_first(&dev, &scene, &cam, &light, modes[m], reference, f, g);
        }
        if (ok) {
            check_not_continued(&dev, &scene, &cam, &light, f, g);
            check_filtered_continues(&dev, &scene, &cam, &light, f, g);
        }
    } else {
        CHECK_MSG(false, "out of memory, or no reference set-up");
    }
    free(f), free(g), free(reference);
    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    pn_gpu_device_destroy(&dev);
    pn_scene_destroy(&scene);
    return pn_test_result();
}
