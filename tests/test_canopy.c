// builtin:canopy, the bench's alpha-masked view (engine/scene/builtin.c, bench_views.c), at the
// renderer under the bench's own camera and light:
//  1. The scene: one 256 x 256 leaf texture whose alpha is 0 or 255 with both well represented, the
//     leaves' material masked at 0.5 with it; the view needs no assets (PN_ASSETS pointing nowhere).
//  2. exact and exact-ls, each with both traversals, give the same V and sample counts bit for bit:
//     both are exact, and the mask is the same texel test in both.
//  3. The mask matters: on the ground pixels in the leaves' shadow (a leafless copy sees more of the
//     light there than a copy whose leaves are opaque, alpha_cutoff 0), the masked canopy's mean V
//     lies strictly between the two, well clear of each. With the same rays (the same ground pixels,
//     samples and seed), a ray blocked by the masked leaves is blocked by opaque ones, and one the
//     leafless scene blocks is blocked by both: V is ordered pixel by pixel too.
// 128 x 128, 16 samples, unfiltered; validation layer on, any message fails.
#include "apps/bench/bench.h"
#include "shadow/setup.h"
#include "test_util.h"

enum { W = 128, H = 128, PX = W * H, SPP = 16 };

// A masked canopy must let through and hold back a good part of the light: a mean V within this of
// the opaque or the leafless one would be a mask that cuts out (nearly) nothing or everything.
#define MIN_MARGIN 0.1

typedef struct frame {
    float v[PX];
    uint32_t counts[4 * PX];
    float p[4 * PX];
} frame;

static bool render(pn_gpu_device *dev, const pn_prepared_scene *ps, pn_shadow_mode mode, pn_traversal traversal,
                   frame *out)
{
    pn_setup_desc sd = {.frame = {.width = W, .height = H, .mode = mode, .traversal = traversal,
                                  .sampler = PN_SAMPLER_STRATIFIED, .spp = SPP, .seed = 1, .filter = PN_FILTER_NONE},
                        .tree_n = 6, .tree_d = 3, .view = &ps->camera};
    pn_setup s;
    pn_result r = pn_setup_create(dev, &ps->scene, &ps->lights[0], &sd, &s);
    CHECK_MSG(r == PN_OK, "%s set-up: %s", pn_shadow_mode_get(mode)->name, pn_result_str(r));
    if (r != PN_OK)
        return false;
    pn_frame_times t;
    r = pn_renderer_render(&s.renderer, &ps->camera, &ps->lights[0], &t);
    CHECK_MSG(r == PN_OK, "%s render: %s", pn_shadow_mode_get(mode)->name, pn_result_str(r));
    if (r == PN_OK) {
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        memcpy(out->v, img.v, sizeof out->v);
        memcpy(out->counts, img.counts, sizeof out->counts);
        memcpy(out->p, img.p, sizeof out->p);
    }
    pn_setup_destroy(dev, &s);
    return r == PN_OK;
}

// The leaves' material: the scene's one masked material.
static int leaf_material(const pn_scene *s)
{
    int found = -1;
    for (uint32_t i = 0; i < s->material_count; i++)
        if (s->materials[i].alpha_cutoff > 0) {
            CHECK_MSG(found < 0, "more than one masked material");
            found = (int)i;
        }
    return found;
}

// 1. The scene's mask.
static void check_scene(const pn_scene *s, int leaf)
{
    CHECK_MSG(s->texture_count == 1, "%u textures", s->texture_count);
    if (s->texture_count != 1 || leaf < 0)
        return;
    const pn_texture *t = &s->textures[0];
    CHECK(t->width == 256 && t->height == 256);
    CHECK(s->materials[leaf].texture == 0 && s->materials[leaf].alpha_cutoff == 0.5f);
    size_t opaque = 0, other = 0, n = (size_t)t->width * t->height;
    for (size_t i = 0; i < n; i++) {
        opaque += t->rgba[4 * i + 3] == 255;
        other += t->rgba[4 * i + 3] != 255 && t->rgba[4 * i + 3] != 0;
    }
    printf("builtin:canopy: %u triangles, %ux%u texture, %.3f of its texels opaque\n", pn_scene_triangle_count(s),
           t->width, t->height, (double)opaque / (double)n);
    CHECK_MSG(other == 0, "%zu texels neither cut out nor opaque", other);
    CHECK_MSG(opaque > n / 4 && opaque < 3 * n / 4, "%zu of %zu texels opaque", opaque, n);
}

static bool is_ground(const frame *f, size_t i) { return f->p[4 * i + 3] > 0 && fabsf(f->p[4 * i + 1]) < 1e-4f; }

// 2. Every exact configuration gives exact's V and counts, bit for bit.
static void check_exact_modes(pn_gpu_device *dev, const pn_prepared_scene *ps, const frame *exact, frame *f)
{
    const struct {
        pn_shadow_mode mode;
        pn_traversal traversal;
        const char *name;
    } runs[] = {{PN_SHADOW_EXACT, PN_TRAVERSAL_RAY, "exact, per ray"},
                {PN_SHADOW_EXACT_LS, PN_TRAVERSAL_AUTO, "exact-ls"},
                {PN_SHADOW_EXACT_LS, PN_TRAVERSAL_PACKET, "exact-ls, packet"}};
    for (size_t r = 0; r < sizeof runs / sizeof runs[0]; r++) {
        if (!render(dev, ps, runs[r].mode, runs[r].traversal, f))
            continue;
        size_t v = 0, c = 0;
        for (size_t i = 0; i < PX; i++) {
            v += memcmp(&f->v[i], &exact->v[i], sizeof(float)) != 0;
            c += memcmp(&f->counts[4 * i], &exact->counts[4 * i], 2 * sizeof(uint32_t)) != 0;
        }
        printf("%s: %zu pixels whose V and %zu whose counts differ from exact's\n", runs[r].name, v, c);
        CHECK_MSG(v == 0 && c == 0, "%s: %zu V and %zu counts off exact's", runs[r].name, v, c);
    }
}

// 3. Masked leaves between opaque and none.
static void check_mask_matters(pn_gpu_device *dev, pn_prepared_scene *ps, int leaf, const frame *masked,
                               frame *opaque, frame *none)
{
    ps->scene.materials[leaf].alpha_cutoff = 0;
    bool ok = render(dev, ps, PN_SHADOW_EXACT, PN_TRAVERSAL_AUTO, opaque);
    ps->scene.materials[leaf].alpha_cutoff = 0.5f;
    // Leafless: the draws of the leaf material left out of the index list. They are the scene's
    // last (builtin.c adds the leaves last), so shortening the list drops exactly them.
    uint32_t index_count = ps->scene.index_count, draw_count = ps->scene.draw_count;
    while (ps->scene.draw_count && ps->scene.draws[ps->scene.draw_count - 1].material == (uint32_t)leaf)
        ps->scene.index_count = ps->scene.draws[--ps->scene.draw_count].first_index;
    CHECK_MSG(ps->scene.index_count < index_count, "no leaf draw at the end of the scene");
    ok = ok && render(dev, ps, PN_SHADOW_EXACT, PN_TRAVERSAL_AUTO, none);
    ps->scene.index_count = index_count, ps->scene.draw_count = draw_count;
    if (!ok)
        return;
    double sum[3] = {0, 0, 0};
    size_t n = 0, unordered = 0;
    for (size_t i = 0; i < PX; i++) {
        if (!is_ground(masked, i) || !is_ground(opaque, i) || !is_ground(none, i))
            continue;
        if (!(opaque->v[i] < none->v[i])) // not in the leaves' shadow
            continue;
        n++;
        sum[0] += opaque->v[i], sum[1] += masked->v[i], sum[2] += none->v[i];
        unordered += !(opaque->v[i] <= masked->v[i] && masked->v[i] <= none->v[i]);
    }
    double mean[3];
    for (int k = 0; k < 3; k++)
        mean[k] = n ? sum[k] / (double)n : 0;
    printf("%zu ground pixels in the leaves' shadow: mean V opaque leaves %.4f, masked %.4f, none %.4f; %zu out of "
           "that order\n",
           n, mean[0], mean[1], mean[2], unordered);
    CHECK_MSG(n > PX / 8, "only %zu ground pixels in the leaves' shadow", n);
    CHECK_MSG(mean[0] + MIN_MARGIN < mean[1] && mean[1] + MIN_MARGIN < mean[2],
              "mean V: opaque %.4f, masked %.4f, leafless %.4f", mean[0], mean[1], mean[2]);
    CHECK_MSG(unordered == 0, "%zu pixels whose V is not between the opaque and the leafless one", unordered);
}

int main(void)
{
    // The view must not need the shared assets.
    setenv("PN_ASSETS", "/nonexistent", 1);
    const pn_bench_view_spec *spec = pn_bench_view_spec_find("canopy");
    CHECK(spec);
    bench_view view;
    if (!spec || !pn_bench_view_standard(&view, spec)) {
        CHECK_MSG(false, "the canopy view is not available without assets");
        return pn_test_result();
    }
    CHECK(strcmp(view.source, "builtin:canopy") == 0);
    pn_prepared_scene ps;
    if (pn_bench_view_prepare(&view, &ps) != PN_EXIT_OK) {
        CHECK_MSG(false, "preparing the canopy view");
        return pn_test_result();
    }
    int leaf = leaf_material(&ps.scene);
    CHECK_MSG(leaf >= 0, "no masked material");
    check_scene(&ps.scene, leaf);
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK) {
        pn_scene_destroy(&ps.scene);
        TEST_SKIP("no Vulkan device");
    }
    frame *exact = malloc(sizeof *exact), *f = malloc(sizeof *f), *g = malloc(sizeof *g);
    if (exact && f && g && leaf >= 0 && render(&dev, &ps, PN_SHADOW_EXACT, PN_TRAVERSAL_AUTO, exact)) {
        check_exact_modes(&dev, &ps, exact, f);
        check_mask_matters(&dev, &ps, leaf, exact, f, g);
    } else {
        CHECK_MSG(false, "out of memory, or no exact render");
    }
    free(exact), free(f), free(g);
    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    pn_gpu_device_destroy(&dev);
    pn_scene_destroy(&ps.scene);
    return pn_test_result();
}
