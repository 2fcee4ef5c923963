// Points in, visibility out: the points become the G-buffer of a frame as wide as the caller's
// rows (pn_renderer_set_gbuffer, the bench's shader-level path), traced by render's shadow pass
// with filter none; V is read back per light. What a scene's last call built is kept for the next.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "api/api_internal.h"
#include "core/timer.h"
#include "scene/interior.h"
#include "scene/view.h"
#include "shadow/quality.h"

// The default row length: rows of 1024 points keep a million points within lavapipe's and every
// GPU's image size (16384). Fixed, not the count's: calls with other counts then keep the renderer
// (its rows past the points' are empty pixels, which cost next to nothing), and a point's samples
// do not depend on how many came with it.
// The samples' seed by default: render's --seed default, so that a zeroed description traces
// what `penumbra render` does (issue 65: seed 0 traced other samples than the README's seed 1).
enum { DEFAULT_WIDTH = 1024, DEFAULT_SPP = 4, MAX_SPP = 4096, DEFAULT_SEED = 1 };

static int parse_name(const char *fn, const char *field, const char *name, const char *const *names, int fallback)
{
    if (!name)
        return fallback;
    for (int i = 0; names[i]; i++)
        if (strcmp(names[i], name) == 0)
            return i;
    char list[256] = "";
    for (int i = 0; names[i]; i++)
        snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s", i ? "|" : "", names[i]);
    pn_error("%s: %s: expected one of %s, got '%s'", fn, field, list, name);
    return -1;
}

pn_result pn_api_config_in(const penumbra_context *ctx, const penumbra_scene *s, const penumbra_visibility_desc *d,
                           pn_api_config *c)
{
    const char *fn = "penumbra_visibility";
    memset(c, 0, sizeof *c); // the key is compared with memcmp: its padding too
    int mode = d->mode ? pn_shadow_mode_parse("penumbra_visibility: mode", d->mode) : PN_SHADOW_REFERENCE;
    int traversal = parse_name(fn, "traversal", d->traversal, pn_traversal_names, PN_TRAVERSAL_AUTO);
    int sampler = parse_name(fn, "sampler", d->sampler, pn_sampler_names, PN_SAMPLER_STRATIFIED);
    if (mode < 0 || traversal < 0 || sampler < 0)
        return PN_ERR_INVALID;
    c->spp = d->spp ? d->spp : DEFAULT_SPP;
    if (c->spp > MAX_SPP) {
        pn_error("%s: spp %u: expected 1..%d", fn, c->spp, MAX_SPP);
        return PN_ERR_INVALID;
    }
    c->seed = d->seed ? d->seed : DEFAULT_SEED;
    int n = d->tree_n ? (int)d->tree_n : 7, depth = d->tree_d ? (int)d->tree_d : 3;
    if (n < 2 || n > 16 || depth < 1 || depth > 6) {
        pn_error("%s: tree %u,%u: expected a branching factor 2..16 and a depth 1..6", fn, d->tree_n, d->tree_d);
        return PN_ERR_INVALID;
    }
    const char *lack;
    if (!pn_shadow_mode_available(&ctx->dev, (pn_shadow_mode)mode, &lack)) {
        pn_error("%s: mode %s needs %s, which %s does not offer", fn, pn_shadow_mode_get(mode)->name, lack,
                 ctx->dev.props.deviceName);
        return PN_ERR_UNSUPPORTED;
    }
    char why[512];
    if (!pn_shadow_mode_takes_scene((pn_shadow_mode)mode, &s->scene, why, sizeof why)) {
        pn_error("%s", why);
        return PN_ERR_INVALID;
    }
    const pn_shadow_mode_info *info = pn_shadow_mode_get(mode);
    bool tree = info->needs.tree;
    c->key = (pn_api_key){.mode = mode, .traversal = traversal, .sampler = sampler,
                          .tree_n = tree ? n : 0, .tree_d = tree ? depth : 0, .scene_version = s->version};
    return PN_OK;
}

pn_result pn_api_points_in(const float *p, const float *nrm, size_t count)
{
    const char *fn = "penumbra_visibility";
    for (size_t i = 0; i < count; i++) {
        const float *x = p + 3 * i, *n = nrm + 3 * i;
        bool ok = true;
        for (int k = 0; k < 3; k++)
            ok = ok && isfinite(x[k]) && fabsf(x[k]) <= PN_API_MAX_COORD && isfinite(n[k]);
        if (!ok || !(n[0] != 0 || n[1] != 0 || n[2] != 0)) {
            pn_error("%s: point %zu: (%g, %g, %g) with normal (%g, %g, %g): %s", fn, i, (double)x[0], (double)x[1],
                     (double)x[2], (double)n[0], (double)n[1], (double)n[2],
                     ok ? "the normal is zero" : "not finite, or beyond 1e18 from the origin");
            return PN_ERR_INVALID;
        }
    }
    return PN_OK;
}

// The acceleration structures for the key's mode and lights, kept while they serve (a rebuild
// takes the renderer made over them too).
static pn_result ensure_accel(penumbra_scene *s, const pn_api_config *c, penumbra_times *t)
{
    const pn_shadow_mode_info *mode = pn_shadow_mode_get(c->key.mode);
    pn_api_key key = {.mode = c->key.mode, .tree_n = c->key.tree_n, .tree_d = c->key.tree_d,
                      .scene_version = s->version};
    if (mode->needs.tree) { // its tree culls by the lights' reach (shadow/setup.h)
        key.light_count = c->key.light_count;
        memcpy(key.lights, c->key.lights, sizeof key.lights);
    }
    if (s->accel_built && memcmp(&s->accel_key, &key, sizeof key) == 0)
        return PN_OK;
    // The structures alone: a renderer for the same mode takes the new ones (ensure_renderer), so
    // that a move costs its rebuild and no renderer (issue 65: 370-551 ms warm per move before).
    pn_gpu_device *dev = &s->ctx->dev;
    if (s->accel_built)
        pn_shadow_accel_destroy(dev, &s->accel);
    s->accel_built = false;
    s->renderer_stale = s->renderer_made;
    uint64_t t0 = pn_time_ns();
    // As pn_setup_create builds them, without a view to cull by: the points are anywhere.
    pn_shadow_accel_desc ad = {.needs = mode->needs,
                               .tree_n = c->key.tree_n ? c->key.tree_n : 7,
                               .tree_d = c->key.tree_d ? c->key.tree_d : 3,
                               .max_bytes = pn_gpu_device_pool_budget(dev),
                               .max_pool_bytes = pn_gpu_device_max_buffer(dev),
                               .light = c->key.lights,
                               .light_count = c->key.light_count};
    PN_TRY(pn_shadow_accel_build(&s->scene, &ad, &s->accel));
    pn_result r = pn_shadow_accel_upload(dev, &s->scene, &s->accel);
    if (r != PN_OK) {
        pn_shadow_accel_destroy(dev, &s->accel);
        return r;
    }
    s->accel_built = true;
    s->accel_key = key;
    t->build_ms += pn_ms_since(t0);
    return PN_OK;
}

// A renderer `width` points to a row with at least `height` rows over the structures, kept while
// the rows are as long and no more of them are wanted; its samples and seed set for this call.
static pn_result ensure_renderer(penumbra_scene *s, const pn_api_config *c)
{
    pn_api_key key = {.mode = c->key.mode, .traversal = c->key.traversal, .sampler = c->key.sampler,
                      .width = c->key.width};
    if (s->renderer_made && memcmp(&s->frame_key, &key, sizeof key) == 0 && s->renderer.height >= c->key.height) {
        PN_TRY(pn_renderer_set_spp(&s->renderer, c->spp));
        pn_renderer_set_seed(&s->renderer, c->seed);
        if (s->renderer_stale) { // the same mode over structures built again (a move)
            pn_renderer_desc rd = {0};
            pn_shadow_accel_bind(&s->accel, &rd);
            pn_renderer_set_accel(&s->renderer, &s->scene, &rd);
            s->renderer_stale = false;
        }
        return PN_OK;
    }
    if (s->renderer_made)
        pn_renderer_destroy(&s->renderer);
    s->renderer_made = false;
    pn_renderer_desc rd = {.width = c->key.width, .height = c->key.height, .mode = (pn_shadow_mode)c->key.mode,
                           .traversal = (pn_traversal)c->key.traversal, .sampler = (pn_sampler)c->key.sampler,
                           .spp = c->spp, .seed = c->seed, .filter = PN_FILTER_NONE, .split = PN_SPLIT_EVEN,
                           .unreached_zero = true}; // penumbra.h: V 0 where no sample is above the horizon
    pn_shadow_accel_bind(&s->accel, &rd);
    PN_TRY(pn_renderer_create(&s->ctx->dev, &s->scene, &rd, &s->renderer));
    s->renderer_made = true;
    s->renderer_stale = false;
    s->frame_key = key;
    return PN_OK;
}

// render's default view of the scene: the file's camera, an interior's, else one framing the bounds.
static void default_camera(const pn_scene *scene, pn_camera *cam)
{
    pn_interior interior = {0};
    if (!scene->has_camera)
        pn_interior_find(scene, 45.0f, &interior);
    if (scene->has_camera)
        *cam = scene->camera;
    else if (interior.is_interior)
        *cam = interior.camera;
    else
        pn_camera_frame(scene->bounds_min, scene->bounds_max, 45.0f, cam);
}

// max_error: --quality auto's pick (shadow/quality.h) for the one light, kept while its key holds,
// put into c in place of the description's mode, samples and tree.
static pn_result choose(penumbra_scene *s, float max_error, const pn_light *light, pn_api_config *c)
{
    const char *fn = "penumbra_visibility";
    pn_api_key key = {.traversal = c->key.traversal, .sampler = c->key.sampler, .light_count = 1,
                      .scene_version = s->version};
    key.lights[0] = *light;
    if (!s->chosen || s->choice_error != max_error || s->choice_seed != c->seed ||
        memcmp(&s->choice_key, &key, sizeof key) != 0) {
        s->chosen = false;
        pn_quality_choice *q = malloc(sizeof *q); // its record of every pilot: tens of KiB
        if (!q) {
            pn_error("%s: out of memory for --quality auto's record", fn);
            return PN_ERR_MEMORY;
        }
        pn_camera cam;
        default_camera(&s->scene, &cam);
        // Unfiltered and uniform: a point's V is its own samples' (no neighbours to filter or to
        // decide adaptive rounds by).
        pn_renderer_desc frame = {.width = 256, .height = 256, .mode = PN_SHADOW_REFERENCE,
                                  .traversal = (pn_traversal)c->key.traversal, .sampler = (pn_sampler)c->key.sampler,
                                  .spp = 1, .seed = c->seed, .filter = PN_FILTER_NONE, .split = PN_SPLIT_EVEN};
        pn_result r = pn_quality_choose(&s->ctx->dev, &s->scene, &cam, light, &frame, max_error, 0, 0, true, q);
        if (r == PN_OK) {
            s->chosen = true;
            s->choice_key = key;
            s->choice_error = max_error;
            s->choice_seed = c->seed;
            s->choice_mode = (int)q->mode;
            s->choice_spp = q->spp;
            s->choice_tree_n = q->tree_n, s->choice_tree_d = q->tree_d;
            pn_info("quality auto: %s at %u spp (pilot MAE %.4f, budget %.4f%s)", pn_shadow_mode_get(q->mode)->name,
                    q->spp, q->pilot_mae, (double)max_error, q->within ? "" : ": none met it, the least error");
        }
        free(q);
        PN_TRY(r);
    }
    c->key.mode = s->choice_mode;
    c->spp = s->choice_spp;
    bool tree = pn_shadow_mode_get(s->choice_mode)->needs.tree;
    c->key.tree_n = tree ? s->choice_tree_n : 0, c->key.tree_d = tree ? s->choice_tree_d : 0;
    c->key.traversal = (int)pn_traversal_fit((pn_shadow_mode)c->key.mode, 0, (pn_traversal)c->key.traversal);
    return PN_OK;
}

// One frame of up to PN_MAX_LIGHTS lights over the points' G-buffer (gp, gn: the renderer's size).
static pn_result trace(penumbra_scene *s, const pn_api_config *c, const float *gp, const float *gn, pn_frame_images *img,
                       penumbra_times *t)
{
    pn_renderer *r = &s->renderer;
    PN_TRY(pn_renderer_set_gbuffer(r, gp, gn));
    // The camera only places the raster pass, which the points replace.
    pn_camera cam;
    pn_camera_frame(s->scene.bounds_min, s->scene.bounds_max, 45.0f, &cam);
    pn_frame_times times;
    PN_TRY(pn_renderer_render_lights(r, &cam, c->key.lights, c->key.light_count, &times));
    pn_renderer_images(r, img);
    t->compile_ms += times.compile_ms;
    t->shadow_ms += times.shadow_ms;
    return PN_OK;
}

penumbra_status penumbra_visibility(penumbra_context *ctx, penumbra_scene *s, const penumbra_visibility_desc *desc,
                                    const penumbra_light *lights, uint32_t light_count, const float *points,
                                    const float *normals, size_t count, float *v)
{
    const char *fn = "penumbra_visibility";
    uint64_t t0 = pn_time_ns();
    penumbra_times times = {0};
    pn_api_call call;
    pn_api_begin(&call, ctx);
    if (!pn_api_context_ok(ctx, fn) || !pn_api_need(s, fn, "scene") || !pn_api_need(lights, fn, "lights"))
        return pn_api_end(&call, PN_ERR_INVALID);
    if (s->ctx != ctx) {
        pn_error("%s: the scene belongs to another context", fn);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    if (light_count == 0) {
        pn_error("%s: light_count is 0", fn);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    pn_api_config c;
    pn_result r = pn_api_config_in(ctx, s, desc ? desc : &(penumbra_visibility_desc){0}, &c);
    if (r != PN_OK)
        return pn_api_end(&call, r);
    pn_light *in = malloc((size_t)light_count * sizeof *in);
    if (!in)
        return pn_api_end(&call, PN_ERR_MEMORY);
    for (uint32_t l = 0; l < light_count; l++)
        if (!pn_api_light_in(&lights[l], l, &s->scene, &in[l])) {
            free(in);
            return pn_api_end(&call, PN_ERR_INVALID);
        }
    float max_error = desc ? desc->max_error : 0;
    if (max_error != 0 && !(max_error > 0 && max_error <= 1)) {
        pn_error("%s: max_error %g: expected 0 (off) or a mean error in (0, 1]", fn, (double)max_error);
        free(in);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    if (max_error > 0 && light_count != 1) {
        pn_error("%s: max_error chooses for one light; this call has %u", fn, light_count);
        free(in);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    if (count == 0) { // nothing to trace: the description and lights are checked all the same
        free(in);
        return pn_api_end(&call, PN_OK);
    }
    if (!pn_api_need(points, fn, "points") || !pn_api_need(normals, fn, "normals") || !pn_api_need(v, fn, "v")) {
        free(in);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    // The points' image: `width` to a row, as the caller laid them out (its samples depend on it).
    // Checked before a point is read: a count larger than the caller's arrays is refused here when
    // no device could take it, not read past their end first.
    uint32_t max_dim = ctx->dev.props.limits.maxImageDimension2D;
    uint64_t width = desc && desc->width ? desc->width : DEFAULT_WIDTH;
    uint64_t height = (count + width - 1) / width;
    if (width > max_dim || height > max_dim) {
        pn_error("%s: %zu points at %llu to a row make an image of %llu x %llu; %s takes at most %u x %u: use longer "
                 "rows (desc.width) or split the call",
                 fn, count, (unsigned long long)width, (unsigned long long)width, (unsigned long long)height,
                 ctx->dev.props.deviceName, max_dim, max_dim);
        free(in);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    if (pn_api_points_in(points, normals, count) != PN_OK) {
        free(in);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    c.key.width = (uint32_t)width, c.key.height = (uint32_t)height;
    if (max_error > 0)
        r = choose(s, max_error, &in[0], &c);
    float *gp = NULL, *gn = NULL;
    size_t pixels = 0;
    // A frame takes PN_MAX_LIGHTS lights: more go in frames of their own.
    for (uint32_t first = 0; r == PN_OK && first < light_count; first += PN_MAX_LIGHTS) {
        uint32_t k = light_count - first < PN_MAX_LIGHTS ? light_count - first : PN_MAX_LIGHTS;
        memset(c.key.lights, 0, sizeof c.key.lights);
        memcpy(c.key.lights, in + first, k * sizeof *in);
        c.key.light_count = k;
        r = ensure_accel(s, &c, &times);
        if (r == PN_OK)
            r = ensure_renderer(s, &c);
        // The points' G-buffer at the renderer's size: rows past the points' are empty pixels.
        size_t need = (size_t)s->renderer.width * s->renderer.height;
        if (r == PN_OK && need != pixels) {
            free(gp), free(gn);
            pixels = need;
            gp = calloc(4 * pixels, sizeof *gp), gn = calloc(4 * pixels, sizeof *gn);
            if (!gp || !gn) {
                pn_error("%s: out of memory for the G-buffer of %zu points", fn, count);
                r = PN_ERR_MEMORY;
            }
            for (size_t i = 0; r == PN_OK && i < count; i++) {
                memcpy(gp + 4 * i, points + 3 * i, 3 * sizeof(float));
                gp[4 * i + 3] = 1; // a point here; the padding stays background (V 0, unread)
                memcpy(gn + 4 * i, normals + 3 * i, 3 * sizeof(float));
            }
        }
        pn_frame_images img;
        if (r == PN_OK)
            r = trace(s, &c, gp, gn, &img, &times);
        for (uint32_t l = 0; r == PN_OK && l < k; l++)
            memcpy(v + (size_t)(first + l) * count, img.v_light[l], count * sizeof *v);
        if (r != PN_OK)
            pn_api_scene_drop_built(s); // whatever failed, the next call starts afresh
    }
    free(gp), free(gn), free(in);
    times.total_ms = pn_ms_since(t0);
    if (r == PN_OK) {
        s->times = times;
        s->config = (penumbra_visibility_desc){.mode = pn_shadow_mode_get(c.key.mode)->name,
                                               .traversal = pn_traversal_names[c.key.traversal],
                                               .sampler = pn_sampler_names[c.key.sampler],
                                               .spp = c.spp, .seed = c.seed,
                                               .tree_n = (uint32_t)c.key.tree_n, .tree_d = (uint32_t)c.key.tree_d,
                                               .width = c.key.width, .max_error = max_error};
    }
    return pn_api_end(&call, r);
}

penumbra_status penumbra_scene_last_config(const penumbra_scene *s, penumbra_visibility_desc *out)
{
    if (!s || !out)
        return PENUMBRA_ERROR_INVALID_ARGUMENT; // no context to hold a message: the status says it
    *out = s->config;
    return PENUMBRA_OK;
}

penumbra_status penumbra_scene_last_times(const penumbra_scene *s, penumbra_times *out)
{
    if (!s || !out)
        return PENUMBRA_ERROR_INVALID_ARGUMENT; // no context to hold a message: the status says it
    *out = s->times;
    return PENUMBRA_OK;
}
