#include "gpu/filter_pass.h"

#include <math.h>
#include <string.h>

#include "filter_comp.h"

pn_result pn_filter_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, const pn_gpu_image *p,
                                const pn_gpu_image *n, const pn_gpu_image *v_raw, const pn_gpu_image *counts,
                                const pn_gpu_image *v, pn_filter_pass *out)
{
    memset(out, 0, sizeof *out);
    out->width = width, out->height = height;
    VkImageView images[PN_FILTER_BINDING_COUNT];
    images[PN_FILTER_BINDING_P] = p->view;
    images[PN_FILTER_BINDING_N] = n->view;
    images[PN_FILTER_BINDING_V_RAW] = v_raw->view;
    images[PN_FILTER_BINDING_V] = v->view;
    images[PN_FILTER_BINDING_COUNTS] = counts->view;
    return pn_gpu_compute_create_images(dev, pn_spv_filter_comp, sizeof pn_spv_filter_comp, images,
                                        PN_FILTER_BINDING_COUNT, sizeof(pn_filter_push), &out->compute);
}

void pn_filter_pass_destroy(pn_gpu_device *dev, pn_filter_pass *f)
{
    pn_gpu_compute_destroy(dev, &f->compute);
    memset(f, 0, sizeof *f);
}

void pn_filter_pass_record(VkCommandBuffer cmd, const pn_filter_pass *f, uint32_t tile_w, uint32_t tile_h,
                           uint32_t samples, float yfov_deg)
{
    pn_filter_push push = {
        .pixel_angle = (float)(2.0 * tan(0.5 * yfov_deg * 3.14159265358979323846 / 180.0) / f->height),
        .tile_w = tile_w,
        .tile_h = tile_h,
        .samples = samples,
    };
    uint32_t gx = (f->width + PN_WORKGROUP - 1) / PN_WORKGROUP, gy = (f->height + PN_WORKGROUP - 1) / PN_WORKGROUP;
    pn_gpu_compute_dispatch(cmd, &f->compute, sizeof push, &push, gx, gy, 1);
}
