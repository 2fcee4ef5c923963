// What a shadow mode needs built for a scene and its lights, built, uploaded and bound to a
// renderer.
#include "shadow/setup.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "accel/alpha.h"
#include "core/log.h"

pn_result pn_shadow_accel_build(const pn_scene *scene, const pn_shadow_accel_desc *desc, pn_shadow_accel *out)
{
    memset(out, 0, sizeof *out);
    out->desc = *desc;
    out->desc.needs = pn_shadow_needs_for_scene(desc->needs, scene); // what upload and bind read
    pn_result r = PN_OK;
    // Every light's reach (the points whose hull holds every end of its rays, scene/light.h): a
    // triangle stays if it can block a ray to any of them.
    float corners[8 * PN_MAX_LIGHTS][3];
    uint32_t lights = desc->light_count ? desc->light_count : 1;
    for (uint32_t i = 0; desc->needs.tree && i < lights && i < PN_MAX_LIGHTS; i++)
        pn_light_reach(&desc->light[i], &corners[8 * i]);
    uint32_t light_corners = 8 * (lights < PN_MAX_LIGHTS ? lights : PN_MAX_LIGHTS);
    // Alpha-masked casters: the tree marks the leaves holding them and keeps their triangles, which
    // the line-space modes test exactly (with their texels) against the triangle pool.
    uint8_t *masked = NULL;
    if (desc->needs.tree && (r = pn_alpha_triangle_flags(scene, &masked)) != PN_OK)
        return r;
    if (masked && desc->per_object) {
        pn_error("%s: %llu alpha-masked triangles: per-object trees (--trees object) keep no triangles to test their "
                 "texels; use one scene-wide tree (--trees scene)",
                 scene->name, (unsigned long long)pn_alpha_masked_triangles(scene));
        free(masked);
        return PN_ERR_UNSUPPORTED;
    }
    if (desc->needs.tree && desc->per_object) {
        // Line spaces only: no candidate lists or leaf planes; the renderer binds per-object trees
        // for linespace alone.
        pn_ntree_desc td = {.n = desc->tree_n, .d = desc->tree_d, .max_bytes = desc->max_bytes,
                            .max_pool_bytes = desc->max_pool_bytes, .cull_light = (const float(*)[3])corners,
                            .cull_light_corners = light_corners};
        r = pn_objects_build(scene, &td, &out->objects);
        if (r == PN_OK)
            out->build_ms += out->objects.build_ms;
    } else if (desc->needs.tree) {
        pn_ntree_desc td = {.n = desc->tree_n,
                            .d = desc->tree_d,
                            .max_bytes = desc->max_bytes,
                            .max_pool_bytes = desc->max_pool_bytes,
                            .cull_light = (const float(*)[3])corners,
                            .cull_light_corners = light_corners,
                            .keep_box = desc->keep_box,
                            .keep_candidates = desc->needs.candidates,
                            .leaf_planes = desc->needs.planes,
                            .masked = masked};
        r = pn_ntree_build(scene, &td, &out->tree);
        if (r == PN_OK) {
            out->build_ms += out->tree.build_ms;
            r = pn_pools_pack(&out->tree, &out->pools);
        }
    }
    free(masked);
    if (r == PN_OK && desc->needs.bvh && desc->reuse_bvh) {
        out->exact_bvh = desc->reuse_bvh;
    } else if (r == PN_OK && desc->needs.bvh) {
        r = pn_bvh_build(scene, &out->bvh);
        if (r != PN_OK)
            pn_error("%s: out of memory building the BVH", scene->name);
        out->build_ms += out->bvh.build_ms;
        out->exact_bvh = &out->bvh;
    }
    if (r != PN_OK)
        pn_shadow_accel_destroy(NULL, out);
    return r;
}

pn_result pn_shadow_accel_upload(pn_gpu_device *dev, const pn_scene *scene, pn_shadow_accel *a)
{
    if (a->desc.needs.tree && a->desc.per_object)
        PN_TRY(pn_gpu_objects_create(dev, &a->objects, &a->gpu_objects));
    else if (a->desc.needs.tree)
        PN_TRY(pn_gpu_pools_create(dev, &a->pools, &a->gpu_pools));
    // Re-pointed here: an accel built on a worker is handed over by value (the demo's), its own
    // BVH with it.
    if (a->exact_bvh)
        a->exact_bvh = a->desc.reuse_bvh ? a->desc.reuse_bvh : &a->bvh;
    if (a->desc.needs.exact_pools)
        PN_TRY(pn_gpu_exact_pools_create(dev, scene, a->exact_bvh, &a->tree, &a->exact));
    if (a->desc.needs.tlas) {
        PN_TRY(pn_gpu_tlas_create(dev, scene, &a->tlas));
        a->build_ms += a->tlas.build_ms;
    }
    return PN_OK;
}

void pn_shadow_accel_bind(const pn_shadow_accel *a, pn_renderer_desc *rd)
{
    bool tree = a->desc.needs.tree && !a->desc.per_object;
    rd->pools = tree ? &a->gpu_pools : NULL;
    rd->objects = a->desc.needs.tree && a->desc.per_object ? &a->gpu_objects : NULL;
    rd->leaf_size = tree ? pn_ntree_cell_size(&a->tree, a->tree.d) : a->objects.leaf_size;
    rd->exact = a->desc.needs.exact_pools ? &a->exact : NULL;
    rd->cand_first_node = a->tree.cand_first_node;
    rd->tlas = a->desc.needs.tlas ? &a->tlas : NULL;
}

uint64_t pn_shadow_accel_gpu_bytes(const pn_shadow_accel *a)
{
    return a->pools.bytes.total + a->objects.bytes.total + a->objects.top_bytes + a->exact.bytes + a->tlas.bytes;
}

void pn_shadow_accel_destroy(pn_gpu_device *dev, pn_shadow_accel *a)
{
    if (dev) {
        pn_gpu_exact_pools_destroy(dev, &a->exact);
        pn_gpu_tlas_destroy(dev, &a->tlas);
        pn_gpu_pools_destroy(dev, &a->gpu_pools);
        pn_gpu_objects_destroy(dev, &a->gpu_objects);
    }
    pn_objects_destroy(&a->objects);
    pn_bvh_destroy(&a->bvh);
    pn_pools_destroy(&a->pools);
    pn_ntree_destroy(&a->tree);
    memset(a, 0, sizeof *a);
}

// The structures desc.frame.mode needs, built and uploaded into *a (zeroed on failure).
static pn_result build_accel(pn_gpu_device *dev, const pn_scene *scene, const pn_light *light, const pn_setup_desc *desc,
                             pn_shadow_accel *a)
{
    memset(a, 0, sizeof *a);
    const pn_shadow_mode_info *mode = pn_shadow_mode_get(desc->frame.mode);
    if (!mode) {
        pn_error("shadow mode %d does not exist", (int)desc->frame.mode);
        return PN_ERR_INVALID;
    }
    if (desc->per_object && !mode->objects) {
        pn_error("%s: per-object trees (--trees object) serve mode linespace only, not %s", scene->name, mode->name);
        return PN_ERR_INVALID;
    }
    pn_shadow_accel_desc ad = {
        .needs = mode->needs,
        .tree_n = desc->tree_n,
        .tree_d = desc->tree_d,
        .max_bytes = desc->max_bytes ? desc->max_bytes : pn_gpu_device_pool_budget(dev),
        .max_pool_bytes = pn_gpu_device_max_buffer(dev),
        .light = light,
        .light_count = desc->light_count ? desc->light_count : 1,
        .per_object = desc->per_object,
    };
    float box[6];
    pn_result r = PN_OK;
    if (desc->view && ad.needs.tree && !ad.per_object) {
        pn_renderer_desc view = desc->frame;
        view.width = desc->view_width ? desc->view_width : view.width;
        view.height = desc->view_height ? desc->view_height : view.height;
        r = pn_view_box(dev, scene, desc->view, light, ad.light_count, &view, box);
        ad.keep_box = box;
    }
    if (r == PN_OK)
        r = pn_shadow_accel_build(scene, &ad, a);
    if (r == PN_OK) {
        r = pn_shadow_accel_upload(dev, scene, a);
        if (r != PN_OK)
            pn_shadow_accel_destroy(dev, a);
    }
    return r;
}

// The figures a setup keeps of its structures.
static void note_accel(pn_setup *s)
{
    s->pool_bytes = s->accel.desc.per_object ? s->accel.objects.bytes : s->accel.pools.bytes;
    s->build_ms = s->accel.build_ms; // with the device's acceleration structure
    s->exact_bytes = s->accel.exact.bytes + s->accel.tlas.bytes;
}

pn_result pn_setup_create(pn_gpu_device *dev, const pn_scene *scene, const pn_light *light, const pn_setup_desc *desc,
                          pn_setup *s)
{
    memset(s, 0, sizeof *s);
    PN_TRY(build_accel(dev, scene, light, desc, &s->accel));
    note_accel(s);
    pn_renderer_desc rd = desc->frame;
    pn_shadow_accel_bind(&s->accel, &rd);
    pn_result r = pn_renderer_create(dev, scene, &rd, &s->renderer);
    if (r != PN_OK)
        pn_setup_destroy(dev, s);
    return r;
}

pn_result pn_setup_rebuild(pn_gpu_device *dev, const pn_scene *scene, const pn_light *light, const pn_setup_desc *desc,
                           uint32_t first_vertex, uint32_t vertex_count, pn_setup *s)
{
    pn_shadow_accel fresh;
    PN_TRY(build_accel(dev, scene, light, desc, &fresh));
    pn_result r = vertex_count ? pn_renderer_update_vertices(&s->renderer, scene, first_vertex, vertex_count) : PN_OK;
    if (r != PN_OK) {
        pn_shadow_accel_destroy(dev, &fresh);
        return r;
    }
    // The queue is idle between frames: the old structures go once the renderer reads the new.
    pn_shadow_accel old = s->accel;
    s->accel = fresh;
    pn_renderer_desc rd = {0};
    pn_shadow_accel_bind(&s->accel, &rd);
    pn_renderer_set_accel(&s->renderer, scene, &rd);
    pn_shadow_accel_destroy(dev, &old);
    note_accel(s);
    return PN_OK;
}

void pn_setup_destroy(pn_gpu_device *dev, pn_setup *s)
{
    pn_renderer_destroy(&s->renderer);
    pn_shadow_accel_destroy(dev, &s->accel);
    memset(s, 0, sizeof *s);
}

pn_result pn_view_box(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *lights,
                      uint32_t light_count, const pn_renderer_desc *frame, float box[6])
{
    pn_renderer_desc rd = {.width = frame->width, .height = frame->height, .mode = PN_SHADOW_NONE, .spp = 1};
    pn_renderer r;
    PN_TRY(pn_renderer_create(dev, scene, &rd, &r));
    pn_frame_times t;
    pn_result res = pn_renderer_render(&r, cam, &lights[0], &t); // the G-buffer only (mode none)
    if (res == PN_OK) {
        for (int k = 0; k < 3; k++)
            box[k] = INFINITY, box[3 + k] = -INFINITY;
        for (uint32_t i = 0; i < (light_count ? light_count : 1); i++) {
            float corners[8][3];
            pn_light_reach(&lights[i], corners);
            for (int c = 0; c < 8; c++)
                for (int k = 0; k < 3; k++) {
                    box[k] = corners[c][k] < box[k] ? corners[c][k] : box[k];
                    box[3 + k] = corners[c][k] > box[3 + k] ? corners[c][k] : box[3 + k];
                }
        }
        pn_frame_images img;
        pn_renderer_images(&r, &img);
        size_t px = (size_t)frame->width * frame->height;
        // Grown below by 4 ulps of the largest coordinate: the G-buffer's positions are interpolated
        // in float, a few ulps off the surfaces they sample.
        for (size_t i = 0; i < px; i++)
            if (img.p[4 * i + 3] > 0)
                for (int k = 0; k < 3; k++) {
                    float v = img.p[4 * i + k];
                    box[k] = v < box[k] ? v : box[k];
                    box[3 + k] = v > box[3 + k] ? v : box[3 + k];
                }
        float mag = 0;
        for (int k = 0; k < 6; k++)
            mag = fabsf(box[k]) > mag ? fabsf(box[k]) : mag;
        float grow = 4 * (nextafterf(mag, INFINITY) - mag);
        for (int k = 0; k < 3; k++)
            box[k] -= grow, box[3 + k] += grow;
    }
    pn_renderer_destroy(&r);
    return res;
}
