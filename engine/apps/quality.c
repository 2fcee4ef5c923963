#include "apps/quality.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "apps/metrics.h"
#include "apps/setup.h"
#include "core/log.h"

// The standard trees, coarse to fine; a mode tries the first pn_shadow_mode_info.auto_trees of
// them, modes in table order (cheapest first). A tree that does not fit max_bytes (or float
// precision) is skipped.
static const int TREES[][2] = {{6, 3}, {7, 3}, {8, 3}, {5, 4}};

// Renders one pilot frame; its V into v (when given) and its shadow time into ms.
static pn_result pilot(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                       const pn_setup_desc *sd, float *v, uint8_t *mask, double *ms)
{
    pn_setup s;
    pn_log_level level = pn_log_get_level();
    pn_log_set_level(PN_LOG_ERROR); // a refused candidate is not the user's error
    pn_result r = pn_setup_create(dev, scene, light, sd, &s);
    pn_log_set_level(level);
    if (r != PN_OK)
        return r;
    pn_frame_times t;
    r = pn_renderer_render(&s.renderer, cam, light, &t);
    if (r == PN_OK) {
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        size_t px = (size_t)sd->frame.width * sd->frame.height;
        for (size_t i = 0; i < px; i++) {
            v[i] = img.v[i];
            if (mask)
                mask[i] = img.p[4 * i + 3] > 0;
        }
        *ms = t.shadow_ms;
    }
    pn_setup_destroy(dev, &s);
    return r;
}

pn_result pn_quality_choose(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                            const pn_renderer_desc *frame, double max_error, uint64_t max_bytes, pn_quality_choice *out)
{
    memset(out, 0, sizeof *out);
    pn_setup_desc sd = {.frame = *frame, .max_bytes = max_bytes, .view = cam}; // as render builds it
    // A quarter of the pixels: a subsample of the picture at the same light samples per pixel.
    sd.frame.width = frame->width / 2 > 64 ? frame->width / 2 : (frame->width < 64 ? frame->width : 64);
    sd.frame.height = (uint32_t)fmax(1.0, round((double)frame->height * sd.frame.width / frame->width));
    sd.frame.dump_rays = false;
    out->pilot_width = sd.frame.width;
    out->pilot_height = sd.frame.height;
    size_t px = (size_t)sd.frame.width * sd.frame.height;
    float *ref = malloc(px * sizeof *ref), *v = malloc(px * sizeof *v);
    uint8_t *mask = malloc(px);
    pn_result r = ref && v && mask ? PN_OK : PN_ERR_MEMORY;
    sd.frame.mode = PN_SHADOW_REFERENCE;
    if (r == PN_OK)
        r = pilot(dev, scene, cam, light, &sd, ref, mask, &out->exact_ms);
    out->mode = PN_SHADOW_REFERENCE;
    out->pilot_ms = out->exact_ms;
    for (int m = 0; r == PN_OK && m < PN_SHADOW_MODE_COUNT; m++) {
        const pn_shadow_mode_info *info = pn_shadow_mode_get((pn_shadow_mode)m);
        if (!pn_shadow_mode_available(dev, (pn_shadow_mode)m, NULL))
            continue; // e.g. rayquery without ray queries: not a candidate here
        for (int t = 0; r == PN_OK && t < info->auto_trees && t < (int)(sizeof TREES / sizeof TREES[0]); t++) {
            sd.frame.mode = (pn_shadow_mode)m;
            sd.tree_n = info->needs.tree ? TREES[t][0] : 0;
            sd.tree_d = info->needs.tree ? TREES[t][1] : 0;
            double ms;
            if (pilot(dev, scene, cam, light, &sd, v, NULL, &ms) != PN_OK)
                continue; // does not fit: try the next
            pn_error_metrics e;
            if (!pn_error_compare(v, ref, mask, px, NULL, &e)) {
                r = PN_ERR_MEMORY;
                break;
            }
            if (out->candidates < PN_QUALITY_MAX_TRIED)
                out->tried[out->candidates] = (pn_quality_tried){(pn_shadow_mode)m, sd.tree_n, sd.tree_d, e.mae, ms};
            out->candidates++;
            pn_debug("quality: %s LS(%d,%d): pilot MAE %.4f in %.1f ms", info->name, sd.tree_n, sd.tree_d, e.mae, ms);
            if (e.mae <= max_error && ms < out->pilot_ms) {
                out->mode = (pn_shadow_mode)m;
                out->tree_n = sd.tree_n;
                out->tree_d = sd.tree_d;
                out->pilot_mae = e.mae;
                out->pilot_ms = ms;
            }
        }
    }
    free(ref), free(v), free(mask);
    return r;
}
