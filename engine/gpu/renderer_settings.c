// The settings that change between frames (pn_renderer_set_*), each checked as pn_renderer_create
// checks its description, and what a frame leaves for the caller besides its images (ray dump,
// work counts).
#include "gpu/renderer.h"

#include <math.h>

#include "core/log.h"
#include "core/timer.h"
#include "gpu/renderer_internal.h"

void pn_renderer_set_leaf_size(pn_renderer *r, double leaf_size)
{
    // The rays rise by the leaf extent (shadow_origin): every pixel's line-space V moves with it.
    if (leaf_size != r->desc.leaf_size)
        r->history_drop = true;
    r->desc.leaf_size = leaf_size;
}

void pn_renderer_set_seed(pn_renderer *r, uint32_t seed) { r->desc.seed = seed; }

void pn_renderer_set_accel(pn_renderer *r, const pn_scene *scene, const pn_renderer_desc *accel)
{
    r->desc.pools = accel->pools;
    r->desc.objects = accel->objects;
    r->desc.exact = accel->exact;
    r->desc.tlas = accel->tlas;
    r->desc.leaf_size = accel->leaf_size;
    r->desc.cand_first_node = accel->cand_first_node;
    r->shadow.scene_mag = pn_scene_magnitude(scene);
    if (r->shadow.mode->needs.tlas && accel->tlas)
        pn_gpu_compute_write_tlas(r->dev, &r->shadow.compute, PN_SHADOW_BINDING_TLAS, accel->tlas->tlas);
}

pn_result pn_renderer_set_filter(pn_renderer *r, pn_filter filter, uint32_t tile_w, uint32_t tile_h)
{
    if ((unsigned)filter > PN_FILTER_LAST || pn_filter_tile(tile_w) > PN_FILTER_MAX_TILE ||
        pn_filter_tile(tile_h) > PN_FILTER_MAX_TILE) {
        pn_error("filter %d with tile %ux%u: the tile's edges must be 1..%d", (int)filter, tile_w, tile_h,
                 PN_FILTER_MAX_TILE);
        return PN_ERR_INVALID;
    }
    pn_renderer_desc d = r->desc;
    d.filter = filter;
    PN_TRY(pn_renderer_check_split(&d));
    // The queue is idle between frames (pn_renderer_render waits), so the filter's pipeline may be
    // replaced and the shading pass's set rewritten; the readback buffer always has room for V_raw
    // (create_targets).
    uint64_t t0 = pn_time_ns();
    PN_TRY(pn_filter_pass_set_tile(r->dev, &r->filter, pn_filter_tile(tile_w), pn_filter_tile(tile_h)));
    // Another filter, or another tile's pipeline, may run passes not run yet: warmed up first.
    if (filter != r->desc.filter || tile_w != r->desc.tile_w || tile_h != r->desc.tile_h) {
        r->cold = true;
        r->compile_pending_ms += pn_ms_since(t0);
    }
    r->desc.filter = filter, r->desc.tile_w = tile_w, r->desc.tile_h = tile_h;
    pn_gpu_compute_write_image(r->dev, &r->shade.compute, PN_SHADE_BINDING_V,
                               filter != PN_FILTER_NONE ? r->v.view : r->v_raw.view);
    return PN_OK;
}

pn_result pn_renderer_set_spp(pn_renderer *r, uint32_t spp)
{
    if (spp == 0 || (r->desc.dump_rays && spp > r->shadow.dump_spp)) {
        pn_error("spp %u: must be at least 1 and, while rays are dumped, at most the ray dump's %u", spp,
                 r->shadow.dump_spp);
        return PN_ERR_INVALID;
    }
    return pn_renderer_set_adaptive(r, r->desc.spp_min, spp, r->desc.pixel_error);
}

pn_result pn_renderer_set_adaptive(pn_renderer *r, uint32_t spp_min, uint32_t spp, float pixel_error)
{
    pn_renderer_desc d = r->desc;
    d.spp_min = spp_min, d.spp = spp, d.pixel_error = pixel_error;
    PN_TRY(pn_shadow_check_samples(&d));
    r->desc = d;
    return PN_OK;
}

void pn_renderer_set_continue(pn_renderer *r, bool on) { r->continue_next = on; }

pn_result pn_renderer_set_dump_rays(pn_renderer *r, bool on)
{
    if (on && (!r->shadow.ray_dump.mapped || r->desc.spp > r->shadow.dump_spp)) {
        pn_error("ray dumps need a renderer created with dump_rays and at most its %u spp", r->shadow.dump_spp);
        return PN_ERR_INVALID;
    }
    pn_renderer_desc d = r->desc;
    d.dump_rays = on;
    PN_TRY(pn_renderer_check_split(&d));
    PN_TRY(pn_shadow_check_samples(&d));
    r->desc.dump_rays = on;
    return PN_OK;
}

pn_result pn_renderer_set_split(pn_renderer *r, pn_split split)
{
    pn_renderer_desc d = r->desc;
    d.split = split;
    PN_TRY(pn_renderer_check_split(&d));
    PN_TRY(pn_shadow_check_samples(&d));
    r->desc.split = split;
    return PN_OK;
}

const float *pn_renderer_ray_dump(const pn_renderer *r, uint64_t *floats)
{
    bool on = r->desc.dump_rays && r->shadow.ray_dump.mapped;
    *floats = on ? (uint64_t)r->width * r->height * (1 + r->desc.spp) * 4 : 0;
    return on ? r->shadow.ray_dump.mapped : NULL;
}

pn_result pn_renderer_set_gbuffer(pn_renderer *r, const float *p, const float *n)
{
    pn_gbuffer_upload_destroy(r->dev, &r->upload);
    if (!p || !n)
        return PN_OK;
    return pn_gbuffer_upload_create(r->dev, r->width, r->height, p, n, &r->upload);
}

const uint32_t *pn_renderer_work(const pn_renderer *r) { return r->shadow.work.mapped; }

pn_result pn_renderer_set_history(pn_renderer *r, uint32_t frames)
{
    if (frames > PN_HISTORY_MAX_FRAMES) {
        pn_error("history of %u frames: at most %d", frames, PN_HISTORY_MAX_FRAMES);
        return PN_ERR_INVALID;
    }
    if (frames == 0 && r->history_frames) {
        // The filters read the shadow pass's counts again (the queue is idle between frames); the
        // history's images go. Turned on, the next frame makes them for its lights (renderer_frame.c).
        PN_TRY(pn_filter_pass_set_counts(r->dev, &r->filter, r->shadow.counts.view, false));
        PN_TRY(pn_penumbra_pass_set_counts(r->dev, &r->penumbra, r->shadow.counts.view, false));
        pn_history_pass_destroy(r->dev, &r->history);
        pn_shadow_pass_set_lineage(r->dev, &r->shadow, NULL);
    }
    if ((frames == 0) != (r->history_frames == 0)) {
        r->cold = true; // pipelines not run yet
        r->history_prev = false;
    }
    r->history_frames = frames;
    return pn_renderer_reserve_readback(r, r->light_count ? r->light_count : 1);
}

void pn_renderer_history_drop(pn_renderer *r) { r->history_drop = true; }

void pn_renderer_set_history_frame(pn_renderer *r, uint32_t frame) { r->history_frame = frame; }

void pn_renderer_history_moved(pn_renderer *r, const double lo[3], const double hi[3])
{
    pn_history_boxes_add(&r->history_boxes, lo, hi);
}
