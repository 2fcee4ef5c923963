// penumbra bench's converged reference: per view and size, exact at --reference-spp light samples
// (stratified, a seed no measured cell uses), rendered once and cached on disk. Every cell's
// `reference` error is measured against it: what a user sees, bias and noise together.
//
// The cache file is <out>/reference/<view>_<W>x<H>_<S>spp_<key>.exr with the channels shadow.V
// and A. The key hashes what changes the image: the exact shader's SPIR-V (ray origins, sampler,
// traversal) and the G-buffer's (P and N), the device and driver (its rasterizer places P), the
// scene's vertices and indices (and its alpha masks, if it has any), camera, light, size, samples,
// seed and an external G-buffer. Host
// code that turns these into GPU parameters (pn_light_to_gpu, pn_sample_grid, the G-buffer camera)
// is not hashed: a change there that alters images must bump the version string below. A file
// whose key matches is reused; one that cannot be read is rendered anew (with a warning).
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "apps/bench/bench.h"
#include "core/log.h"
#include "gpu/gbuffer_pass.h"
#include "core/timer.h"
#include "io/exr.h"

// FNV-1a, 64 bits: a cache key, not a defence against tampering.
static uint64_t fnv(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ p[i]) * 0x100000001b3ull;
    return h;
}

static uint64_t reference_key(const bench_opts *o, const pn_gpu_device *dev, const pn_scene *scene,
                              const pn_camera *cam, const pn_light *light, uint32_t w, uint32_t h)
{
    const pn_shadow_mode_info *exact = pn_shadow_mode_get(PN_SHADOW_REFERENCE);
    // "2": the G-buffer culls the back faces of closed single-sided meshes (gpu/gbuffer_cull.h),
    // which moves P where a mesh cuts itself without changing the raster pass's SPIR-V.
    uint64_t k = fnv(0xcbf29ce484222325ull, "penumbra converged reference 2", 30);
    k = fnv(k, exact->spirv, exact->spirv_size);
    for (int stage = 0; stage < 2; stage++) {
        size_t size;
        const uint32_t *code = pn_gbuffer_pass_spirv(stage, &size);
        k = fnv(k, code, size);
    }
    uint32_t device[3] = {dev->props.vendorID, dev->props.deviceID, dev->props.driverVersion};
    k = fnv(k, device, sizeof device);
    k = fnv(k, dev->props.pipelineCacheUUID, VK_UUID_SIZE);
    k = fnv(k, dev->driver.driverName, strlen(dev->driver.driverName));
    k = fnv(k, dev->driver.driverInfo, strlen(dev->driver.driverInfo));
    k = fnv(k, scene->vertices, (size_t)scene->vertex_count * sizeof *scene->vertices);
    k = fnv(k, scene->indices, (size_t)scene->index_count * sizeof *scene->indices);
    // Alpha masks cut shadows: which triangles are masked (the draws), by what cutoff and alpha. An
    // opaque scene hashes nothing more, so that its cached references keep their keys.
    bool masked = false;
    for (uint32_t i = 0; i < scene->material_count; i++)
        masked = masked || scene->materials[i].alpha_cutoff > 0;
    if (masked) {
        k = fnv(k, scene->draws, (size_t)scene->draw_count * sizeof *scene->draws);
        for (uint32_t i = 0; i < scene->material_count; i++) { // field by field: the struct has padding
            const pn_material *m = &scene->materials[i];
            k = fnv(k, m->base_color, sizeof m->base_color);
            k = fnv(k, &m->texture, sizeof m->texture);
            k = fnv(k, &m->alpha_cutoff, sizeof m->alpha_cutoff);
        }
        for (uint32_t i = 0; i < scene->texture_count; i++) {
            const pn_texture *t = &scene->textures[i];
            uint32_t size[2] = {t->width, t->height};
            k = fnv(k, size, sizeof size);
            k = fnv(k, t->rgba, (size_t)t->width * t->height * 4);
        }
    }
    k = fnv(k, cam, sizeof *cam);
    k = fnv(k, light, sizeof *light);
    uint32_t params[4] = {w, h, o->reference_spp, PN_REFERENCE_SEED};
    k = fnv(k, params, sizeof params);
    if (o->gbuffer) {
        k = fnv(k, o->gb_p, (size_t)w * h * 4 * sizeof(float));
        k = fnv(k, o->gb_n, (size_t)w * h * 4 * sizeof(float));
    }
    return k;
}

// Reads a cached reference of exactly this size into v and mask; false when it is not usable.
static bool read_cached(const char *path, uint32_t w, uint32_t h, float *v, uint8_t *mask)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return false;
    pn_exr_image img;
    if (pn_exr_read(path, &img) != PN_OK) {
        pn_warn("%s: the cached reference cannot be read: rendering it again", path);
        return false;
    }
    const float *cv = pn_exr_image_channel(&img, "shadow.V"), *ca = pn_exr_image_channel(&img, "A");
    bool ok = cv && ca && img.width == (int)w && img.height == (int)h;
    if (ok)
        for (size_t i = 0; i < (size_t)w * h; i++) {
            v[i] = cv[i];
            mask[i] = ca[i] > 0;
        }
    else
        pn_warn("%s: the cached reference lacks shadow.V or A or has another size: rendering it again", path);
    pn_exr_image_free(&img);
    return ok;
}

pn_result pn_bench_reference(const bench_opts *o, pn_gpu_device *dev, const pn_scene *scene, const char *view,
                             const pn_camera *cam, const pn_light *light, uint32_t w, uint32_t h, float *v,
                             uint8_t *mask)
{
    char dir[2048], path[4096];
    if (o->reference_dir)
        snprintf(dir, sizeof dir, "%s", o->reference_dir);
    else
        snprintf(dir, sizeof dir, "%s/reference", o->out_dir);
    if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
        pn_error("%s: cannot create the reference cache folder: %s", dir, strerror(errno));
        return PN_ERR_IO;
    }
    uint64_t key = reference_key(o, dev, scene, cam, light, w, h);
    snprintf(path, sizeof path, "%s/%s_%ux%u_%uspp_%016llx.exr", dir, view, w, h, o->reference_spp,
             (unsigned long long)key);
    for (char *c = path + strlen(dir) + 1; *c; c++)
        if (*c == ':' || *c == '/' || *c == ' ')
            *c = '_';
    if (read_cached(path, w, h, v, mask)) {
        fprintf(stderr, "bench: %s %ux%u: converged reference (exact, %u spp) from the cache %s\n", view, w, h,
                o->reference_spp, path);
        return PN_OK;
    }
    fprintf(stderr, "bench: %s %ux%u: rendering the converged reference (exact, %u spp, seed %u) into %s\n", view,
            w, h, o->reference_spp, PN_REFERENCE_SEED, path);
    uint64_t t0 = pn_time_ns();
    // Stratified whatever the cells use: the reference is the integral, and stratified converges fastest.
    pn_setup s;
    pn_setup_desc sd = {.frame = {.width = w, .height = h, .mode = PN_SHADOW_REFERENCE,
                                  .sampler = PN_SAMPLER_STRATIFIED, .spp = o->reference_spp,
                                  .seed = PN_REFERENCE_SEED}};
    PN_TRY(pn_setup_create(dev, scene, light, &sd, &s));
    pn_result r = o->gbuffer ? pn_renderer_set_gbuffer(&s.renderer, o->gb_p, o->gb_n) : PN_OK;
    pn_frame_times t;
    if (r == PN_OK)
        r = pn_renderer_render(&s.renderer, cam, light, &t);
    float *a = r == PN_OK ? malloc((size_t)w * h * sizeof *a) : NULL;
    if (r == PN_OK && !a)
        r = PN_ERR_MEMORY;
    if (r == PN_OK) {
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        for (size_t i = 0; i < (size_t)w * h; i++) {
            v[i] = img.v[i];
            mask[i] = img.p[4 * i + 3] > 0;
            a[i] = mask[i];
        }
        char spp[32];
        snprintf(spp, sizeof spp, "%u", o->reference_spp);
        pn_exr_attr attrs[3] = {{.name = "penumbra/reference", .type = PN_EXR_ATTR_STRING, .s = "exact, stratified"},
                                {.name = "penumbra/view", .type = PN_EXR_ATTR_STRING, .s = view},
                                {.name = "penumbra/spp", .type = PN_EXR_ATTR_STRING, .s = spp}};
        pn_exr_channel ch[2] = {{"A", a}, {"shadow.V", v}};
        // A cache that cannot be written costs the next run a render, not this one its result.
        // Shards of one run (--shard) that miss the same reference render it at once: pn_exr_write
        // writes a temporary name of its process and renames it, so each rename puts a whole file
        // (the same image: the render is deterministic) and no reader sees a part of one.
        if (pn_exr_write(path, (int)w, (int)h, ch, 2, attrs, 3) != PN_OK)
            pn_warn("%s: the reference is not cached", path);
        fprintf(stderr, "bench: %s %ux%u: reference rendered in %.1f s (shadow pass %.1f ms)\n", view, w, h,
                pn_ms_since(t0) * 1e-3, t.shadow_ms);
    }
    free(a);
    pn_setup_destroy(dev, &s);
    return r;
}
