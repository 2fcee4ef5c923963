// The filter pass (--filter interleaved): pipeline, push constants and its dispatch.
#include "gpu/filter_pass.h"

#include <math.h>
#include <string.h>

#include "filter_comp.h"
#include "gpu/frame.h"
#include "gpu/penumbra_pass.h"

// The pipeline specialised for a tile_w x tile_h window, its set pointed at f's images.
static pn_result create_pipeline(pn_gpu_device *dev, const pn_filter_pass *f, uint32_t tile_w, uint32_t tile_h,
                                 pn_gpu_compute *out)
{
    if (tile_w < 1 || tile_w > PN_FILTER_MAX_TILE || tile_h < 1 || tile_h > PN_FILTER_MAX_TILE)
        return PN_ERR_INVALID;
    int32_t values[3] = {(int32_t)tile_w, (int32_t)tile_h, f->temporal ? VK_TRUE : VK_FALSE};
    VkSpecializationMapEntry entries[3] = {{.constantID = PN_SPEC_TILE_W, .offset = 0, .size = 4},
                                           {.constantID = PN_SPEC_TILE_H, .offset = 4, .size = 4},
                                           {.constantID = PN_SPEC_FILTER_TEMPORAL, .offset = 8, .size = 4}};
    VkSpecializationInfo spec = {.mapEntryCount = 3, .pMapEntries = entries, .dataSize = sizeof values, .pData = values};
    return pn_gpu_compute_create_images_buffer(dev, pn_spv_filter_comp, sizeof pn_spv_filter_comp, f->images,
                                               PN_FILTER_BINDING_COUNT, PN_FILTER_BINDING_LIST, f->list,
                                               sizeof(pn_filter_push), &spec, out);
}

pn_result pn_filter_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, uint32_t tile_w,
                                uint32_t tile_h, const pn_gpu_image *p, const pn_gpu_image *n,
                                const pn_gpu_image *v_raw, const pn_gpu_image *counts, const pn_gpu_image *blockers,
                                const pn_penumbra_pass *penumbra, const pn_gpu_image *v, pn_filter_pass *out)
{
    memset(out, 0, sizeof *out);
    out->width = width, out->height = height;
    out->images[PN_FILTER_BINDING_P] = p->view;
    out->images[PN_FILTER_BINDING_N] = n->view;
    out->images[PN_FILTER_BINDING_V_RAW] = v_raw->view;
    out->images[PN_FILTER_BINDING_V] = v->view;
    out->images[PN_FILTER_BINDING_COUNTS] = counts->view;
    out->images[PN_FILTER_BINDING_BLOCKERS] = blockers->view;
    out->images[PN_FILTER_BINDING_SIGMA] = penumbra->sigma.view;
    out->images[PN_FILTER_BINDING_TILES] = penumbra->tiles.view;
    out->images[PN_FILTER_BINDING_SCRATCH] = penumbra->scratch.view;
    out->list = penumbra->list.buffer;
    PN_TRY(create_pipeline(dev, out, tile_w, tile_h, &out->compute));
    out->tile_w = tile_w, out->tile_h = tile_h;
    return PN_OK;
}

void pn_filter_pass_destroy(pn_gpu_device *dev, pn_filter_pass *f)
{
    pn_gpu_compute_destroy(dev, &f->compute);
    memset(f, 0, sizeof *f);
}

pn_result pn_filter_pass_set_tile(pn_gpu_device *dev, pn_filter_pass *f, uint32_t tile_w, uint32_t tile_h)
{
    if (tile_w == f->tile_w && tile_h == f->tile_h)
        return PN_OK;
    // The old pipeline stays if the new one cannot be made.
    pn_gpu_compute fresh;
    PN_TRY(create_pipeline(dev, f, tile_w, tile_h, &fresh));
    pn_gpu_compute_destroy(dev, &f->compute);
    f->compute = fresh;
    f->tile_w = tile_w, f->tile_h = tile_h;
    return PN_OK;
}

void pn_filter_pass_record(VkCommandBuffer cmd, const pn_filter_pass *f, uint32_t samples, bool adaptive,
                           float yfov_deg, float narrow, float width_scale)
{
    pn_filter_push push = {
        .pixel_angle = (float)pn_pixel_angle(yfov_deg, f->height),
        .samples = samples,
        .adaptive = adaptive,
        .narrow = narrow,
        .width_scale = width_scale,
        .max_radius = pn_penumbra_max_radius(f->height),
    };
    pn_gpu_compute_dispatch_rows(cmd, &f->compute, sizeof push, &push, f->width, f->height, f->one_tile);
}

pn_result pn_filter_pass_set_counts(pn_gpu_device *dev, pn_filter_pass *f, VkImageView counts, bool temporal)
{
    if (counts == f->images[PN_FILTER_BINDING_COUNTS] && temporal == f->temporal)
        return PN_OK;
    pn_filter_pass was = *f;
    f->images[PN_FILTER_BINDING_COUNTS] = counts, f->temporal = temporal;
    pn_gpu_compute fresh;
    pn_result r = create_pipeline(dev, f, f->tile_w, f->tile_h, &fresh);
    if (r != PN_OK) {
        *f = was;
        return r;
    }
    pn_gpu_compute_destroy(dev, &f->compute);
    f->compute = fresh;
    return PN_OK;
}
