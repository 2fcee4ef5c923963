// The temporal history (pn_renderer_set_history, issue 63), at the renderer, exact mode, the
// Stanford bunny on its ground (builtin:default without the asset), 128 x 96, 4 spp a frame:
//  1. A still camera: each frame's history holds every earlier frame's samples (the valid sums
//     grow by a frame's a frame), and V converges: against a converged reference (exact, 1024
//     samples, another seed) the MAE after 16 frames is under 0.4 times the first frame's,
//     unfiltered within 1.25 times that of one frame of 64 samples (the frame window's strata:
//     light_sample), and under the penumbra filter no worse than 64 samples unfiltered.
//  2. A camera orbit (2 degrees a frame): the pixels keep their history through the camera's
//     motion (on average more than 5 frames' worth after 8 frames), and the last frame's error
//     against its own converged reference is below the first frame's and no more than that of the
//     same frame without history (history_share keeps what resampling would spoil). A pixel without history (uncovered, off
//     the last frame's image) has, bit for bit, the V of the same frame rendered with the history
//     dropped, and there must be such pixels and pixels with history.
//  3. A moving object: 8 still frames, then the bunny moves and the next frame drops the history
//     where the pyramid to the light meets its box before or after. Pixels that keep it have, bit
//     for bit, the V of the same frame of a sequence where nothing moved (their rays meet the
//     bunny in neither place); pixels that drop it, the V of the frame rendered with all history
//     dropped. And the bound holds: wherever that dropped frame's V differs from the one where
//     nothing moved (the same samples, the bunny moved: V changed), the history was dropped. Some
//     pixels must keep it and some drop it.
//  4. A light that moves drops its history everywhere: the frame after is, bit for bit, the frame
//     rendered with the history dropped ("no trace of the old shadow").
//  5. Lineages (unfiltered): a pan of exactly 3 pixels over the ground seen from above, whose
//     penumbra pixels then draw the samples of the pixel their point was in (check_pan).
// Validation layer on, any message fails.
#include <math.h>

#include "shadow/metrics.h"
#include "shadow/setup.h"
#include "test_util.h"

enum { W = 128, H = 96, PX = W * H, SPP = 4 };

typedef struct frame {
    float v[PX];
    float samples[PX]; // the history's valid samples (this frame's included), 0 without history
    uint32_t own[PX];  // this frame's valid samples
    uint8_t covered[PX];
} frame;

static bool setup(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light, uint32_t spp,
                  uint32_t seed, pn_filter filter, uint32_t history, pn_setup *s)
{
    pn_setup_desc sd = {.frame = {.width = W, .height = H, .mode = PN_SHADOW_EXACT, .traversal = PN_TRAVERSAL_AUTO,
                                  .sampler = PN_SAMPLER_STRATIFIED, .spp = spp, .seed = seed, .filter = filter},
                        .tree_n = 6, .tree_d = 3, .view = cam};
    pn_result r = pn_setup_create(dev, scene, light, &sd, s);
    if (r == PN_OK && history)
        r = pn_renderer_set_history(&s->renderer, history);
    CHECK_MSG(r == PN_OK, "set-up: %s", pn_result_str(r));
    return r == PN_OK;
}

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
    for (size_t i = 0; i < PX; i++) {
        out->covered[i] = img.p[4 * i + 3] > 0;
        out->own[i] = img.counts[4 * i + 1];
        out->samples[i] = img.history ? img.history[4 * i + 1] : 0.0f;
    }
    return true;
}

static double mae(const frame *f, const float *reference)
{
    double sum = 0;
    size_t n = 0;
    for (size_t i = 0; i < PX; i++)
        if (f->covered[i])
            sum += fabs((double)f->v[i] - reference[i]), n++;
    return n ? sum / (double)n : 0.0;
}

// A pixel with history: more samples than its own frame's.
static bool kept(const frame *f, size_t i) { return f->samples[i] > (float)f->own[i]; }

static bool reference(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                      frame *scratch, float *out)
{
    pn_setup s;
    if (!setup(dev, scene, cam, light, PN_REFERENCE_SPP, PN_REFERENCE_SEED, PN_FILTER_NONE, 0, &s))
        return false;
    bool ok = render(&s, cam, light, scratch);
    pn_setup_destroy(dev, &s);
    memcpy(out, scratch->v, sizeof scratch->v);
    return ok;
}

// 1. A still camera, unfiltered and filtered.
static void check_still(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                        const float *ref, frame *f, frame *g)
{
    const pn_filter filters[2] = {PN_FILTER_NONE, PN_FILTER_PENUMBRA};
    double unfiltered_once = 0;
    for (int k = 0; k < 2; k++) {
        pn_setup s;
        if (!setup(dev, scene, cam, light, 64, 1, filters[k], 0, &s))
            return;
        bool ok = render(&s, cam, light, g);
        pn_setup_destroy(dev, &s);
        double once = mae(g, ref);
        if (k == 0)
            unfiltered_once = once;
        if (!ok || !setup(dev, scene, cam, light, SPP, 1, filters[k], 32, &s))
            return;
        double first = 0;
        bool grows = true;
        static float total[PX];
        memset(total, 0, sizeof total);
        for (uint32_t frame_no = 0; frame_no < 16 && ok; frame_no++) {
            ok = render(&s, cam, light, f);
            if (frame_no == 0)
                first = mae(f, ref);
            // Every covered pixel holds every frame's valid samples (16 frames of 4 stay within the
            // cap of 32 frames' worth, and a still camera's history lies on the point itself).
            for (size_t i = 0; ok && i < PX; i++) {
                total[i] += (float)f->own[i];
                grows = grows && (!f->covered[i] || f->samples[i] == total[i]);
            }
        }
        pn_setup_destroy(dev, &s);
        double last = mae(f, ref);
        fprintf(stderr, "still camera, %s: MAE frame 1 %.5f, frame 16 %.5f (%.2fx), 64 spp at once %.5f (%.2fx)\n",
                pn_filter_names[filters[k]], first, last, last / first, once, last / once);
        CHECK_MSG(grows, "%s: a pixel's history lacks a frame's samples", pn_filter_names[filters[k]]);
        CHECK_MSG(last < 0.4 * first, "%s: 16 frames' MAE %.5f, the first's %.5f", pn_filter_names[filters[k]], last,
                  first);
        if (k == 0)
            CHECK_MSG(last <= 1.25 * once, "%s: 16 frames of 4 spp %.5f against 64 spp at once %.5f",
                      pn_filter_names[filters[k]], last, once);
        else
            CHECK_MSG(last <= unfiltered_once, "filtered 16 frames %.5f against 64 spp unfiltered at once %.5f", last,
                      unfiltered_once);
    }
}

// The camera k steps into an orbit of `step` degrees a frame round the target, about the vertical.
static pn_camera orbit(const pn_camera *c, int k, double step)
{
    pn_camera o = *c;
    double a = k * step * 3.14159265358979 / 180.0, ca = cos(a), sa = sin(a);
    double dx = c->pos[0] - c->target[0], dz = c->pos[2] - c->target[2];
    o.pos[0] = (float)(c->target[0] + ca * dx - sa * dz);
    o.pos[2] = (float)(c->target[2] + sa * dx + ca * dz);
    return o;
}

// The same frame with no history anywhere: the renderer's history dropped, its frame number kept.
static bool render_dropped(pn_setup *s, const pn_camera *cam, const pn_light *light, uint32_t frame_no, frame *out)
{
    pn_renderer_history_drop(&s->renderer);
    pn_renderer_set_history_frame(&s->renderer, frame_no);
    return render(s, cam, light, out);
}

// 2. A camera orbit.
static void check_orbit(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                        frame *f, frame *g, float *ref)
{
    enum { FRAMES = 8 };
    const double step = 2.0;
    pn_camera last_cam = orbit(cam, FRAMES - 1, step), first_cam = orbit(cam, 0, step);
    if (!reference(dev, scene, &first_cam, light, g, ref))
        return;
    pn_setup s;
    if (!setup(dev, scene, cam, light, SPP, 1, PN_FILTER_NONE, 32, &s))
        return;
    bool ok = render(&s, &first_cam, light, f);
    double first = mae(f, ref);
    for (int k = 1; k < FRAMES && ok; k++) {
        pn_camera c = orbit(cam, k, step);
        ok = render(&s, &c, light, f);
    }
    // The last frame again with its history dropped: a fresh renderer's frame of the same number.
    pn_setup t;
    ok = ok && setup(dev, scene, cam, light, SPP, 1, PN_FILTER_NONE, 32, &t);
    if (ok) {
        ok = render_dropped(&t, &last_cam, light, FRAMES - 1, g);
        pn_setup_destroy(dev, &t);
    }
    pn_setup_destroy(dev, &s);
    size_t with = 0, without = 0, same = 0, covered = 0;
    double samples = 0;
    for (size_t i = 0; ok && i < PX; i++) {
        if (!f->covered[i] || f->own[i] == 0)
            continue;
        covered++;
        samples += f->samples[i] / (double)f->own[i];
        if (kept(f, i)) {
            with++;
        } else {
            without++;
            same += memcmp(&f->v[i], &g->v[i], sizeof(float)) == 0;
        }
    }
    static frame alone; // the frame without history, for its error
    memcpy(&alone, g, sizeof alone);
    if (!ok || !reference(dev, scene, &last_cam, light, g, ref))
        return;
    double last = mae(f, ref), without_history = mae(&alone, ref);
    fprintf(stderr, "orbit of %d frames, %.0f degrees each: frames of history %.2f a pixel, %zu pixels with history, "
                    "%zu without; MAE frame 1 %.5f, frame %d %.5f (%.2fx; without history %.5f)\n",
            FRAMES, step, samples / (double)covered, with, without, first, FRAMES, last, last / first, without_history);
    CHECK_MSG(with > 0 && without > 0, "%zu pixels with history, %zu without: nothing to check", with, without);
    CHECK_MSG(same == without, "%zu of %zu pixels without history differ from the frame with it dropped",
              without - same, without);
    CHECK_MSG(samples / (double)covered > 5.0, "%.2f frames of history a pixel after %d frames",
              samples / (double)covered, FRAMES);
    CHECK_MSG(last <= without_history && last < first, "orbit: frame %d's MAE %.5f with history, %.5f without, frame 1's %.5f",
              FRAMES, last, without_history, first);
}

// The box of object `o`'s vertices.
static void object_box(const pn_scene *scene, uint32_t o, double lo[3], double hi[3])
{
    const pn_scene_object *ob = &scene->objects[o];
    for (int k = 0; k < 3; k++)
        lo[k] = INFINITY, hi[k] = -INFINITY;
    for (uint32_t v = ob->first_vertex; v < ob->first_vertex + ob->vertex_count; v++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], scene->vertices[v].pos[k]);
            hi[k] = fmax(hi[k], scene->vertices[v].pos[k]);
        }
}

// 8 still frames, then frame 8 with the bunny moved by `delta` (moved: history told, structures
// rebuilt), or not; `drop`: frame 8 with all history dropped.
static bool sequence(pn_gpu_device *dev, pn_scene *scene, const pn_camera *cam, const pn_light *light, bool moved,
                     bool drop, const float delta[3], frame *out)
{
    pn_setup s;
    if (!setup(dev, scene, cam, light, SPP, 1, PN_FILTER_NONE, 32, &s))
        return false;
    bool ok = true;
    for (int k = 0; k < 8 && ok; k++)
        ok = render(&s, cam, light, out);
    const pn_scene_object *ob = &scene->objects[0];
    if (ok && moved) {
        double lo[3], hi[3];
        object_box(scene, 0, lo, hi);
        pn_renderer_history_moved(&s.renderer, lo, hi);
        ok = pn_scene_move_object(scene, 0, delta) == PN_OK;
        object_box(scene, 0, lo, hi);
        pn_renderer_history_moved(&s.renderer, lo, hi);
        pn_setup_desc sd = {.frame = s.renderer.desc, .tree_n = 6, .tree_d = 3, .view = cam};
        ok = ok && pn_setup_rebuild(dev, scene, light, &sd, ob->first_vertex, ob->vertex_count, &s) == PN_OK;
    }
    if (ok && drop)
        pn_renderer_history_drop(&s.renderer);
    ok = ok && render(&s, cam, light, out);
    pn_setup_destroy(dev, &s);
    if (moved) { // the scene as it was
        const float back[3] = {-delta[0], -delta[1], -delta[2]};
        ok = pn_scene_move_object(scene, 0, back) == PN_OK && ok;
    }
    CHECK_MSG(ok, "the moving object's sequence");
    return ok;
}

// 3. A moving object.
static void check_moving_object(pn_gpu_device *dev, pn_scene *scene, const pn_camera *cam, const pn_light *light,
                                frame *frames)
{
    frame *a = &frames[0], *still = &frames[1], *a_drop = &frames[2], *still_drop = &frames[3];
    double lo[3], hi[3];
    object_box(scene, 0, lo, hi);
    const float delta[3] = {(float)(0.15 * (hi[0] - lo[0])), 0.0f, 0.0f};
    if (!sequence(dev, scene, cam, light, true, false, delta, a) || !sequence(dev, scene, cam, light, false, false, delta, still) ||
        !sequence(dev, scene, cam, light, true, true, delta, a_drop) ||
        !sequence(dev, scene, cam, light, false, true, delta, still_drop))
        return;
    size_t with = 0, without = 0, kept_differ = 0, dropped_differ = 0, changed = 0, changed_kept = 0;
    for (size_t i = 0; i < PX; i++) {
        if (!a->covered[i])
            continue;
        bool k = kept(a, i);
        with += k, without += !k;
        if (k)
            kept_differ += memcmp(&a->v[i], &still->v[i], sizeof(float)) != 0;
        else
            dropped_differ += memcmp(&a->v[i], &a_drop->v[i], sizeof(float)) != 0;
        bool v_changed = memcmp(&a_drop->v[i], &still_drop->v[i], sizeof(float)) != 0;
        changed += v_changed;
        changed_kept += v_changed && k;
    }
    fprintf(stderr, "moving object: %zu pixels keep their history, %zu drop it; V changed at %zu (the same samples)\n",
            with, without, changed);
    CHECK_MSG(with > 0 && without > 0, "%zu pixels kept, %zu dropped: nothing to check", with, without);
    CHECK_MSG(changed > 0, "the move changed no pixel's V: nothing to check");
    CHECK_MSG(kept_differ == 0, "%zu pixels that kept their history differ from the frame where nothing moved",
              kept_differ);
    CHECK_MSG(dropped_differ == 0, "%zu pixels that dropped their history differ from the frame without history",
              dropped_differ);
    CHECK_MSG(changed_kept == 0, "%zu pixels whose V the move changed kept their history", changed_kept);
}

// 4. A light that moves.
static void check_light_jump(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                             frame *f, frame *g)
{
    pn_setup s, t;
    if (!setup(dev, scene, cam, light, SPP, 1, PN_FILTER_PENUMBRA, 32, &s))
        return;
    bool ok = true;
    for (int k = 0; k < 8 && ok; k++)
        ok = render(&s, cam, light, f);
    pn_light moved = *light;
    moved.pos[0] += 0.5f * moved.size[0];
    ok = ok && render(&s, cam, &moved, f);
    pn_setup_destroy(dev, &s);
    if (!ok || !setup(dev, scene, cam, light, SPP, 1, PN_FILTER_PENUMBRA, 32, &t))
        return;
    ok = render_dropped(&t, cam, &moved, 8, g);
    pn_setup_destroy(dev, &t);
    size_t differ = 0, kept_px = 0;
    for (size_t i = 0; ok && i < PX; i++) {
        differ += memcmp(&f->v[i], &g->v[i], sizeof(float)) != 0;
        kept_px += f->covered[i] && kept(f, i);
    }
    fprintf(stderr, "light moved: %zu pixels kept history, %zu differ from the frame without\n", kept_px, differ);
    CHECK_MSG(ok && kept_px == 0 && differ == 0, "light moved: %zu pixels kept history, %zu differ", kept_px, differ);
}

// 5. Samples that follow the surface point (the lineage: history.comp's choosing stage,
// shadow_common.glsl's pixel_sampler). A camera looking straight down on the ground pans by
// exactly K pixels' footprint at the ground's depth: every ground point then shows K pixels on,
// in a pixel that continues the lineage of the pixel it was in. Unfiltered (no tile), so the
// moved frame's pixel p draws the samples the still camera's pixel p + s draws in the same frame
// (s the shift back), at the same point and with the same history: the two V agree bit for bit
// but for rays whose origins' rounding flips them. Samples drawn by the pixel, as before the
// lineage, differ wherever V is fractional: the same two frames with their history dropped (each
// pixel then starts its own lineage) show how often.
static void check_pan(pn_gpu_device *dev, const pn_scene *scene, const float lo[3], const float hi[3],
                      const pn_light *light)
{
    enum { K = 3 };
    pn_camera top = {.target = {0.5f * (lo[0] + hi[0]), lo[1], 0.5f * (lo[2] + hi[2])}, .up = {0, 0, -1}, .yfov_deg = 45};
    float extent = fmaxf(hi[0] - lo[0], hi[2] - lo[2]), depth = 2.5f * extent;
    memcpy(top.pos, top.target, sizeof top.pos);
    top.pos[1] += depth;
    // A pixel's footprint at the ground, which lies a hair below lo[1] (pn_scene_add_ground: 2^-12
    // of the scene's largest extent).
    double largest = fmax(fmax(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2]);
    double footprint = 2.0 * (depth + largest * 0x1p-12) * tan(22.5 * 3.14159265358979 / 180.0) / H;
    pn_camera moved = top;
    moved.pos[0] = (float)(top.pos[0] + K * footprint), moved.target[0] = (float)(top.target[0] + K * footprint);
    static float p_still[4 * PX], p_moved[4 * PX];
    static frame still, pan, still_own, pan_own;
    bool ok = true;
    for (int run = 0; run < 4 && ok; run++) {
        pn_setup s;
        if (!setup(dev, scene, &top, light, SPP, 1, PN_FILTER_NONE, 32, &s))
            return;
        frame *f = (frame *[4]){&still, &pan, &still_own, &pan_own}[run];
        const pn_camera *second = run % 2 ? &moved : &top;
        ok = render(&s, &top, light, f);
        if (run >= 2)
            ok = ok && render_dropped(&s, second, light, 1, f);
        else
            ok = ok && render(&s, second, light, f);
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        if (ok && run < 2)
            memcpy(run == 0 ? p_still : p_moved, img.p, sizeof p_still);
        pn_setup_destroy(dev, &s);
    }
    if (!ok)
        return;
    // The shift back: where the moved frame's ground points lie in the still one's.
    int best_s = 0, best_match = -1;
    const int shifts[4][2] = {{K, 0}, {-K, 0}, {0, K}, {0, -K}};
    for (int k = 0; k < 4; k++) {
        int match = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                int u = x + shifts[k][0], v = y + shifts[k][1];
                if (u < 0 || v < 0 || u >= W || v >= H)
                    continue;
                const float *a = &p_moved[4 * (y * W + x)], *b = &p_still[4 * (v * W + u)];
                match += a[3] > 0 && b[3] > 0 && fabsf(a[0] - b[0]) + fabsf(a[2] - b[2]) < 0.01 * footprint;
            }
        if (match > best_match)
            best_match = match, best_s = k;
    }
    size_t penumbra = 0, same = 0, same_own = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int u = x + shifts[best_s][0], v = y + shifts[best_s][1];
            if (u < 0 || v < 0 || u >= W || v >= H)
                continue;
            size_t i = (size_t)y * W + x, j = (size_t)v * W + u;
            const float *a = &p_moved[4 * i], *b = &p_still[4 * j];
            // Ground in both (below the bunny's lowest vertex), the same point, V fractional.
            bool ground = a[3] > 0 && b[3] > 0 && a[1] < lo[1] && b[1] < lo[1] &&
                          fabsf(a[0] - b[0]) + fabsf(a[2] - b[2]) < 0.01 * footprint;
            if (!ground || !(still.v[j] > 0.0f && still.v[j] < 1.0f) || !kept(&pan, i))
                continue;
            penumbra++;
            same += memcmp(&pan.v[i], &still.v[j], sizeof(float)) == 0;
            same_own += memcmp(&pan_own.v[i], &still_own.v[j], sizeof(float)) == 0;
        }
    fprintf(stderr, "pan of %d pixels: %zu ground pixels in the penumbra; V as the still camera's pixel %d, %d "
                    "on: %zu with the lineage; %zu drawn by the pixel (both histories dropped)\n",
            K, penumbra, shifts[best_s][0], shifts[best_s][1], same, same_own);
    CHECK_MSG(best_match > PX / 4, "pan: only %d ground pixels moved by %d pixels", best_match, K);
    CHECK_MSG(penumbra > 100, "pan: %zu penumbra pixels on the ground: nothing to check", penumbra);
    CHECK_MSG(same >= penumbra * 0.95, "pan: %zu of %zu penumbra pixels draw the samples of the point's pixel", same,
              penumbra);
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
    float lo[3], hi[3]; // the bunny's bounds
    memcpy(lo, scene.bounds_min, sizeof lo), memcpy(hi, scene.bounds_max, sizeof hi);
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
    fprintf(stderr, "scene %s, %dx%d, exact, %d spp a frame\n", path, W, H, SPP);
    frame *frames = malloc(4 * sizeof *frames);
    float *ref = malloc(PX * sizeof *ref);
    if (frames && ref && reference(&dev, &scene, &cam, &light, &frames[0], ref)) {
        check_still(&dev, &scene, &cam, &light, ref, &frames[0], &frames[1]);
        check_orbit(&dev, &scene, &cam, &light, &frames[0], &frames[1], ref);
        if (scene.object_count > 0)
            check_moving_object(&dev, &scene, &cam, &light, frames);
        else
            CHECK_MSG(false, "%s has no object to move", path);
        check_light_jump(&dev, &scene, &cam, &light, &frames[0], &frames[1]);
        check_pan(&dev, &scene, lo, hi, &light);
    } else {
        CHECK_MSG(false, "out of memory, or no reference");
    }
    free(frames), free(ref);
    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    pn_gpu_device_destroy(&dev);
    pn_scene_destroy(&scene);
    return pn_test_result();
}
