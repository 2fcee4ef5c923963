// The shading pass: pipeline and dispatch of albedo / pi x E x V per pixel.
#include "gpu/shade_pass.h"

#include <assert.h>
#include <math.h>
#include <string.h>

#include "core/log.h"
#include "shade_comp.h"

pn_light_gpu pn_light_to_gpu(const pn_light *l)
{
    float q[4][3];
    pn_light_corners(l, q);
    pn_light_gpu g;
    memset(&g, 0, sizeof g);
    for (int i = 0; i < 4; i++)
        memcpy(g.corners[i], q[i], sizeof q[i]);
    float n = sqrtf(l->normal[0] * l->normal[0] + l->normal[1] * l->normal[1] + l->normal[2] * l->normal[2]);
    for (int k = 0; k < 3; k++) {
        g.normal[k] = n > 0 ? l->normal[k] / n : 0;
        g.radiance[k] = l->radiance[k];
    }
    g.radiance[3] = pn_light_is_point(l) ? 1.0f : 0.0f; // light.glsl: radiance is then an intensity
    assert(pn_light_kind_get(l->kind)); // a light made without its kind: zero-initialise pn_light
    g.corners[0][3] = (float)pn_light_kind_get(l->kind)->gpu_id;
    if (l->kind == PN_LIGHT_SUN) { // its Snyder form (light.glsl)
        float sh = sinf(0.5f * l->angle);
        g.corners[1][3] = sh * sh;
    }
    if (l->kind == PN_LIGHT_SPHERE)
        g.corners[1][3] = l->radius;
    if (l->kind == PN_LIGHT_OMNI || l->kind == PN_LIGHT_SPHERE) // its range window (light.glsl); 0: none
        g.corners[3][3] = l->range > 0 ? l->range : 0.0f;
    if (l->kind == PN_LIGHT_OMNI) { // the spot's cone as cosines; none: every cosine is inside
        bool cone = l->cone[1] > 0;
        g.corners[1][3] = cone ? cosf(l->cone[1]) : -2.0f;
        g.corners[2][3] = cone ? cosf(l->cone[0]) : -1.0f;
    }
    return g;
}

pn_result pn_shade_pass_create(pn_gpu_device *dev, uint32_t width, uint32_t height, const pn_gpu_image *p,
                               const pn_gpu_image *n, const pn_gpu_image *albedo, const pn_gpu_image *v,
                               const pn_gpu_image *radiance, pn_shade_pass *out)
{
    memset(out, 0, sizeof *out);
    out->width = width, out->height = height;
    VkImageView images[PN_SHADE_BINDING_COUNT];
    images[PN_SHADE_BINDING_P] = p->view;
    images[PN_SHADE_BINDING_N] = n->view;
    images[PN_SHADE_BINDING_ALBEDO] = albedo->view;
    images[PN_SHADE_BINDING_V] = v->view;
    images[PN_SHADE_BINDING_OUT] = radiance->view;
    return pn_gpu_compute_create_images(dev, NULL, 0, images, PN_SHADE_BINDING_COUNT, sizeof(pn_shade_push), NULL,
                                        &out->compute);
}

// The light's kind as the shaders read it (pn_light_to_gpu).
static uint32_t gpu_kind(const pn_light_gpu *l) { return (uint32_t)l->corners[0][3]; }

pn_result pn_shade_pass_prepare(pn_gpu_device *dev, pn_shade_pass *s, const pn_light_gpu *lights, uint32_t count,
                                uint32_t *made)
{
    *made = 0;
    for (uint32_t i = 0; i < count; i++) {
        uint32_t kind = gpu_kind(&lights[i]);
        if (kind >= PN_LIGHT_KIND_IDS) {
            pn_error("a light of kind %u: the shading pass knows %d kinds", kind, PN_LIGHT_KIND_IDS);
            return PN_ERR_INVALID;
        }
        if (s->by_kind[kind])
            continue;
        const VkSpecializationMapEntry entry = {.constantID = PN_SPEC_LIGHT_KIND, .offset = 0, .size = 4};
        VkSpecializationInfo spec = {.mapEntryCount = 1, .pMapEntries = &entry, .dataSize = 4, .pData = &kind};
        PN_TRY(pn_gpu_compute_pipeline(dev, &s->compute, pn_spv_shade_comp, sizeof pn_spv_shade_comp, &spec,
                                       &s->by_kind[kind]));
        (*made)++;
    }
    return PN_OK;
}

void pn_shade_pass_destroy(pn_gpu_device *dev, pn_shade_pass *s)
{
    pn_gpu_compute_destroy(dev, &s->compute);
    memset(s, 0, sizeof *s);
}

void pn_shade_pass_record(VkCommandBuffer cmd, const pn_shade_pass *s, const pn_light_gpu *light, bool accumulate)
{
    pn_shade_push push = {.light = *light, .accumulate = accumulate};
    pn_gpu_compute c = s->compute;
    c.pipeline = s->by_kind[gpu_kind(light)]; // made by pn_shade_pass_prepare
    assert(c.pipeline);
    pn_gpu_compute_dispatch_rows(cmd, &c, sizeof push, &push, s->width, s->height, s->one_tile);
}
