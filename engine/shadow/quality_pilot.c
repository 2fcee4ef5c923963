// --quality auto's pilot frames, references and frame samples (quality_pilot.h).
#include "shadow/quality_pilot.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "scene/view.h"

// Renders the set-up's frame `frames` times, plus once more first with warm_up (a set-up's first
// frame pays for first touches of its pools, which would count against it); V (and the coverage
// into mask, when given) of the last, the least shadow time into ms.
pn_result pn_pilot_frame(pn_setup *s, const pn_camera *cam, const pn_light *light, size_t px, bool warm_up,
                             int frames, float *v, uint8_t *mask, double *ms)
{
    pn_frame_times t;
    if (warm_up)
        PN_TRY(pn_renderer_render(&s->renderer, cam, light, &t));
    *ms = INFINITY;
    for (int i = 0; i < frames; i++) {
        PN_TRY(pn_renderer_render(&s->renderer, cam, light, &t));
        *ms = fmin(*ms, t.shadow_ms + t.filter_ms); // a filtered configuration pays for its filter
    }
    pn_frame_images img;
    pn_renderer_images(&s->renderer, &img);
    for (size_t i = 0; i < px; i++) {
        v[i] = img.v[i];
        if (mask)
            mask[i] = img.p[4 * i + 3] > 0;
    }
    return PN_OK;
}

// A set-up that may be refused (a tree too large for the budget): quietly, it is not the user's error.
pn_result pn_pilot_quiet_setup(pn_gpu_device *dev, const pn_scene *scene, const pn_light *light,
                               const pn_setup_desc *sd, pn_setup *s)
{
    pn_log_level level = pn_log_get_level();
    pn_log_set_level(PN_LOG_ERROR);
    pn_setup_desc fit = *sd; // --traversal project walks exact's uniform samples; the others as auto
    fit.frame.traversal = pn_traversal_fit(fit.frame.mode, fit.frame.spp_min, fit.frame.traversal);
    pn_result r = pn_setup_create(dev, scene, light, &fit, s);
    pn_log_set_level(level);
    return r;
}

pn_result pn_pilot_size_init(pn_pilot_size *p, const pn_renderer_desc *frame, double scale, uint64_t max_bytes,
                                 uint32_t reference_spp, const pn_camera *cam)
{
    memset(p, 0, sizeof *p);
    p->used = true;
    p->scale = scale;
    // As render builds it, the tree keeping what the frame's pixels see (a filtered pilot renders
    // those on it: pn_frame_sample).
    p->sd = (pn_setup_desc){.frame = *frame, .max_bytes = max_bytes, .view = cam, .view_width = frame->width,
                            .view_height = frame->height};
    p->sd.frame.width = (uint32_t)fmax(1.0, round(frame->width * scale));
    p->sd.frame.height = (uint32_t)fmax(1.0, round(frame->height * scale));
    p->sd.frame.dump_rays = false;
    p->sd.frame.count_work = false;
    p->sd.frame.spp_min = 0; // uniform unless a pilot says otherwise (and the references always)
    p->sd.frame.pixel_error = 0;
    p->sd.frame.filter = PN_FILTER_NONE; // unfiltered unless a pilot says otherwise
    p->px = (size_t)p->sd.frame.width * p->sd.frame.height;
    p->reference_spp = reference_spp;
    p->ref = malloc(p->px * sizeof *p->ref);
    p->v = malloc(p->px * sizeof *p->v);
    p->mask = malloc(p->px);
    return p->ref && p->v && p->mask ? PN_OK : PN_ERR_MEMORY;
}

void pn_pilot_size_free(pn_pilot_size *p) { free(p->ref), free(p->v), free(p->mask); }

// The converged reference of a pilot size's frame desc sd: exact, reference_spp stratified samples,
// its own seed; over the G-buffer gp, gn where given (pn_renderer_set_gbuffer), else the raster's.
static pn_result render_reference(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                                  const pn_light *light, const pn_setup_desc *sd, uint32_t reference_spp,
                                  const float *gp, const float *gn, size_t px, float *ref, uint8_t *mask, double *ms)
{
    pn_setup_desc rd = *sd;
    rd.frame.mode = PN_SHADOW_REFERENCE;
    rd.frame.sampler = PN_SAMPLER_STRATIFIED;
    rd.frame.spp = reference_spp;
    rd.frame.seed = PN_REFERENCE_SEED;
    rd.frame.filter = PN_FILTER_NONE; // converged: the pixel's own samples, nothing borrowed
    rd.view = NULL;
    pn_setup s;
    PN_TRY(pn_setup_create(dev, scene, light, &rd, &s));
    pn_result r = gp ? pn_renderer_set_gbuffer(&s.renderer, gp, gn) : PN_OK;
    if (r == PN_OK)
        r = pn_pilot_frame(&s, cam, light, px, false, 1, ref, mask, ms);
    pn_setup_destroy(dev, &s);
    return r;
}

pn_result pn_pilot_reference(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                                 pn_pilot_size *p)
{
    if (p->ready)
        return PN_OK;
    pn_result r = render_reference(dev, scene, cam, light, &p->sd, p->reference_spp, NULL, NULL, p->px, p->ref,
                                   p->mask, &p->reference_ms);
    p->ready = r == PN_OK;
    return r;
}

// The standard error of an MAE over a sample of the picture's pixels, taking their errors as
// independent (neighbouring penumbra pixels are not quite).
double pn_pilot_mae_se(const pn_error_metrics *e)
{
    return sqrt(fmax(e->rmse * e->rmse - e->mae * e->mae, 0.0) / (double)(e->pixels ? e->pixels : 1));
}

// A cell's pixel: a fixed hash of the cell (Wellons' lowbias32), the same in every run.
static uint32_t cell_hash(uint32_t x)
{
    x ^= x >> 16, x *= 0x7feb352du, x ^= x >> 15, x *= 0x846ca68bu, x ^= x >> 16;
    return x;
}

// used: some pilot is filtered (the pilot's own pixels serve where it is the frame).
pn_result pn_frame_sample_init(pn_frame_sample *fs, const pn_renderer_desc *frame, const pn_pilot_size *pilot,
                                   bool filtered)
{
    memset(fs, 0, sizeof *fs);
    fs->used = filtered && pilot->scale < 1.0;
    fs->width = frame->width, fs->height = frame->height;
    fs->cells_w = pilot->sd.frame.width, fs->cells_h = pilot->sd.frame.height;
    fs->count = (size_t)fs->cells_w * fs->cells_h;
    if (!fs->used)
        return PN_OK;
    fs->index = malloc(fs->count * sizeof *fs->index);
    fs->ref = malloc(fs->count * sizeof *fs->ref);
    fs->v = malloc(fs->count * sizeof *fs->v);
    fs->mask = malloc(fs->count);
    if (!fs->index || !fs->ref || !fs->v || !fs->mask)
        return PN_ERR_MEMORY;
    // Cell (i, j) spans columns [i W / cw, (i + 1) W / cw) and rows alike: the pilot is no larger
    // than the frame, so every cell holds a pixel.
    for (uint32_t j = 0; j < fs->cells_h; j++)
        for (uint32_t i = 0; i < fs->cells_w; i++) {
            uint64_t x0 = (uint64_t)i * fs->width / fs->cells_w, x1 = (uint64_t)(i + 1) * fs->width / fs->cells_w;
            uint64_t y0 = (uint64_t)j * fs->height / fs->cells_h, y1 = (uint64_t)(j + 1) * fs->height / fs->cells_h;
            uint32_t h = cell_hash(cell_hash(j * fs->cells_w + i) ^ PN_REFERENCE_SEED);
            uint64_t x = x0 + (h & 0xffffu) % (x1 - x0), y = y0 + (h >> 16) % (y1 - y0);
            fs->index[(size_t)j * fs->cells_w + i] = (uint32_t)(y * fs->width + x);
        }
    return PN_OK;
}

void pn_frame_sample_free(pn_frame_sample *fs) { free(fs->index), free(fs->ref), free(fs->v), free(fs->mask); }

// The reference at the sampled pixels, once: the frame's G-buffer (mode none traces nothing), its
// positions and normals at those pixels, and the reference over them.
pn_result pn_frame_sample_reference(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam,
                                        const pn_light *light, const pn_pilot_size *pilot, pn_frame_sample *fs)
{
    if (fs->ready)
        return PN_OK;
    pn_renderer_desc gd = {.width = fs->width, .height = fs->height, .mode = PN_SHADOW_NONE, .spp = 1};
    pn_renderer g;
    PN_TRY(pn_renderer_create(dev, scene, &gd, &g));
    float *gp = malloc(fs->count * 4 * sizeof *gp), *gn = malloc(fs->count * 4 * sizeof *gn);
    pn_frame_times t;
    pn_result r = gp && gn ? pn_renderer_render(&g, cam, light, &t) : PN_ERR_MEMORY;
    if (r == PN_OK) {
        pn_frame_images img;
        pn_renderer_images(&g, &img);
        for (size_t k = 0; k < fs->count; k++) {
            memcpy(gp + 4 * k, img.p + 4 * (size_t)fs->index[k], 4 * sizeof *gp);
            memcpy(gn + 4 * k, img.n + 4 * (size_t)fs->index[k], 4 * sizeof *gn);
        }
    }
    pn_renderer_destroy(&g);
    if (r == PN_OK)
        r = render_reference(dev, scene, cam, light, &pilot->sd, pilot->reference_spp, gp, gn, fs->count, fs->ref,
                             fs->mask, &fs->reference_ms);
    free(gp), free(gn);
    fs->ready = r == PN_OK;
    return r;
}

// The error of a configuration's frame (r: a renderer of the frame's size) at the sampled pixels.
pn_result pn_frame_sample_error(pn_renderer *r, const pn_camera *cam, const pn_light *light, pn_frame_sample *fs,
                                    double *mae, double *se)
{
    pn_frame_times t;
    PN_TRY(pn_renderer_render(r, cam, light, &t));
    pn_frame_images img;
    pn_renderer_images(r, &img);
    for (size_t k = 0; k < fs->count; k++)
        fs->v[k] = img.v[fs->index[k]];
    pn_error_metrics e;
    if (!pn_error_compare(fs->v, fs->ref, fs->mask, fs->count, NULL, &e))
        return PN_ERR_MEMORY;
    *mae = e.mae;
    *se = pn_pilot_mae_se(&e);
    return PN_OK;
}

// The error of the set-up's current frame at pilot size p: MAE against p's reference and the
// standard error of that MAE as an estimate of the full frame's (0 when p is the frame itself: the
// same image). A smaller pilot's MAE is the mean of a sample of the picture's per-pixel errors; the
// standard error takes them as independent, which neighbouring penumbra pixels are not quite.
pn_result pn_pilot_error(pn_setup *s, const pn_camera *cam, const pn_light *light, pn_pilot_size *p, bool timed,
                             bool warm_up, double *mae, double *se, double *ms)
{
    PN_TRY(pn_pilot_frame(s, cam, light, p->px, warm_up, timed ? PN_PILOT_TIMED_FRAMES : 1, p->v, NULL, ms));
    pn_error_metrics e;
    if (!pn_error_compare(p->v, p->ref, p->mask, p->px, NULL, &e))
        return PN_ERR_MEMORY;
    *mae = e.mae;
    *se = p->scale < 1.0 ? pn_pilot_mae_se(&e) : 0.0;
    return PN_OK;
}
