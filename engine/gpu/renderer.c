// The renderer's life: checks of its description, creation of its targets and passes, the scene's
// moved vertices, destruction. The frame itself is renderer_frame.c's, its readback
// renderer_readback.c's, the settings that change between frames renderer_settings.c's.
#include "gpu/renderer.h"

#include <math.h>
#include <string.h>

#include "accel/alpha.h"
#include "core/log.h"
#include "core/timer.h"
#include "gpu/renderer_internal.h"

// ---------------------------------------------------------------------------------------------
// Targets

static pn_result create_targets(pn_renderer *r)
{
    pn_gpu_device *dev = r->dev;
    const VkFormat RGBA32F = VK_FORMAT_R32G32B32A32_SFLOAT;
    const VkImageUsageFlags gbuf = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT |
                                   VK_IMAGE_USAGE_TRANSFER_DST_BIT | // pn_renderer_set_gbuffer
                                   VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    const VkImageUsageFlags comp = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    struct {
        pn_gpu_image *img;
        VkFormat format;
        VkImageUsageFlags usage;
        VkImageAspectFlags aspect;
        const char *name;
    } t[] = {
        {&r->p, RGBA32F, gbuf, 0, "G-buffer's position image"},
        {&r->n, RGBA32F, gbuf, 0, "G-buffer's normal image"},
        {&r->albedo, RGBA32F, gbuf, 0, "G-buffer's albedo image"},
        {&r->depth, VK_FORMAT_D32_SFLOAT, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_IMAGE_ASPECT_DEPTH_BIT,
         "depth image"},
        {&r->v_raw, VK_FORMAT_R32_SFLOAT, comp, 0, "raw visibility image"},
        {&r->v, VK_FORMAT_R32_SFLOAT, comp | VK_IMAGE_USAGE_TRANSFER_DST_BIT, 0, "visibility image"}, // cleared: penumbra_pass.h
        {&r->radiance, RGBA32F, comp, 0, "radiance image"},
    };
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++)
        PN_TRY(pn_gpu_image_create(dev,
                                   &(pn_gpu_image_desc){.name = t[i].name,
                                                        .format = t[i].format,
                                                        .width = r->width,
                                                        .height = r->height,
                                                        .usage = t[i].usage,
                                                        .aspect = t[i].aspect},
                                   t[i].img));
    PN_TRY(pn_renderer_reserve_readback(r, 1));
    VkQueryPoolCreateInfo qi = {
        .sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO,
        .queryType = VK_QUERY_TYPE_TIMESTAMP,
        .queryCount = TS_COUNT,
    };
    VK_CHECK(vkCreateQueryPool(dev->device, &qi, NULL, &r->timestamps));
    VkCommandBufferAllocateInfo ai = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO,
        .commandPool = dev->cmd_pool,
        .level = VK_COMMAND_BUFFER_LEVEL_PRIMARY,
        .commandBufferCount = 1,
    };
    VK_CHECK(vkAllocateCommandBuffers(dev->device, &ai, &r->cmd));
    return PN_OK;
}

// ---------------------------------------------------------------------------------------------

// A budgeted split gives each pixel its own number of rays per light: no tile can share one set of
// samples (interleaving), no grid fits every count, and the ray dump holds spp rays per pixel.
pn_result pn_renderer_check_split(const pn_renderer_desc *d)
{
    if ((unsigned)d->split > PN_SPLIT_BUDGET) {
        pn_error("split %d: even or budget", (int)d->split);
        return PN_ERR_INVALID;
    }
    if (d->split == PN_SPLIT_BUDGET && (d->filter != PN_FILTER_NONE || d->sampler != PN_SAMPLER_STRATIFIED || d->dump_rays)) {
        pn_error("the budgeted split draws a number of rays per pixel and light of its own: it needs filter none, "
                 "the stratified sampler and no ray dump (got filter %s, sampler %s%s)",
                 pn_filter_names[d->filter], pn_sampler_names[d->sampler], d->dump_rays ? ", ray dump" : "");
        return PN_ERR_INVALID;
    }
    return PN_OK;
}

pn_result pn_renderer_create(pn_gpu_device *dev, const pn_scene *scene, const pn_renderer_desc *desc,
                             pn_renderer *out)
{
    memset(out, 0, sizeof *out);
    out->dev = dev;
    out->desc = *desc;
    out->width = desc->width;
    out->height = desc->height;
    const pn_shadow_mode_info *mode = pn_shadow_mode_get(desc->mode);
    if (!mode) {
        pn_error("shadow mode %d does not exist", (int)desc->mode);
        return PN_ERR_INVALID;
    }
    const char *lack;
    if (!pn_shadow_mode_available(dev, desc->mode, &lack)) {
        pn_error("%s: mode %s needs %s, which this device lacks (Mesa 25's lavapipe has them: ci/deps.sh)",
                 dev->props.deviceName, mode->name, lack);
        return PN_ERR_UNSUPPORTED;
    }
    char why[512];
    if (!pn_shadow_mode_takes_scene(desc->mode, scene, why, sizeof why)) {
        pn_error("%s", why);
        return PN_ERR_UNSUPPORTED;
    }
    if (mode->needs.tlas && !desc->tlas) {
        pn_error("%s shadows need the device's acceleration structure", mode->name);
        return PN_ERR_INVALID;
    }
    if (mode->needs.tree && !desc->pools && !desc->objects) {
        pn_error("%s shadows need the N-tree's pools", mode->name);
        return PN_ERR_INVALID;
    }
    if (desc->objects && !mode->objects) {
        pn_error("%s shadows need one scene-wide tree: per-object trees (--trees object) serve linespace only",
                 mode->name);
        return PN_ERR_INVALID;
    }
    if (mode->needs.planes && !desc->pools->has_planes) {
        pn_error("%s shadows need the N-tree's leaf planes", mode->name);
        return PN_ERR_INVALID;
    }
    if (pn_shadow_needs_for_scene(mode->needs, scene).exact_pools && !desc->exact) {
        pn_error("%s shadows need the triangle pools of the exact tests", mode->name);
        return PN_ERR_INVALID;
    }
    if (desc->objects && pn_alpha_masked_triangles(scene)) {
        pn_error("%s shadows of alpha-masked casters need one scene-wide tree with its masked leaves (per-object trees "
                 "keep no triangles to test)",
                 mode->name);
        return PN_ERR_INVALID;
    }
    if ((unsigned)desc->filter > PN_FILTER_LAST ||
        pn_filter_tile(desc->tile_w) > PN_FILTER_MAX_TILE || pn_filter_tile(desc->tile_h) > PN_FILTER_MAX_TILE) {
        pn_error("filter %d with tile %ux%u: the tile's edges must be 1..%d", (int)desc->filter, desc->tile_w,
                 desc->tile_h, PN_FILTER_MAX_TILE);
        return PN_ERR_INVALID;
    }
    PN_TRY(pn_renderer_check_split(desc));
    PN_TRY(pn_shadow_check_samples(desc));
    if (desc->spp == 0 && mode->traces) {
        pn_error("spp must be at least 1");
        return PN_ERR_INVALID;
    }
    const VkPhysicalDeviceLimits *lim = &dev->props.limits;
    if (desc->width == 0 || desc->height == 0 || desc->width > lim->maxImageDimension2D ||
        desc->height > lim->maxImageDimension2D) {
        pn_error("image size %ux%u outside the device's 1..%u", desc->width, desc->height, lim->maxImageDimension2D);
        return PN_ERR_INVALID;
    }
    pn_result r = pn_gbuffer_pass_create(dev, scene, &out->gbuffer);
    if (r == PN_OK)
        r = create_targets(out);
    // The compute passes' creation is mostly their pipelines' (with their own few buffers and
    // images): the first frame reports it with their first run (warm_up). The G-buffer pass's
    // includes the scene's upload and is left out.
    uint64_t t0 = pn_time_ns();
    if (r == PN_OK)
        r = pn_shadow_pass_create(dev, desc, &out->p, &out->n, &out->v_raw, pn_scene_magnitude(scene),
                                  pn_alpha_masked_triangles(scene) > 0, &out->shadow);
    if (r == PN_OK)
        r = pn_penumbra_pass_create(dev, desc->width, desc->height, &out->p, &out->n, &out->shadow.counts, &out->v,
                                    &out->penumbra);
    if (r == PN_OK)
        r = pn_filter_pass_create(dev, desc->width, desc->height, pn_filter_tile(desc->tile_w),
                                  pn_filter_tile(desc->tile_h), &out->p, &out->n, &out->v_raw, &out->shadow.counts,
                                  &out->shadow.blockers, &out->penumbra, &out->v, &out->filter);
    if (r == PN_OK)
        r = pn_shade_pass_create(dev, desc->width, desc->height, &out->p, &out->n, &out->albedo,
                                 desc->filter != PN_FILTER_NONE ? &out->v : &out->v_raw, &out->radiance, &out->shade);
    out->cold = true;
    out->compile_pending_ms = pn_ms_since(t0);
    if (r != PN_OK)
        pn_renderer_destroy(out);
    return r;
}

pn_result pn_renderer_update_vertices(pn_renderer *r, const pn_scene *scene, uint32_t first, uint32_t count)
{
    // The queue is idle between frames (pn_renderer_render waits); the shadow pass writes its
    // parameters, scene_mag among them, at every frame (pn_shadow_pass_update).
    PN_TRY(pn_gbuffer_pass_update_vertices(r->dev, &r->gbuffer, scene, first, count));
    r->shadow.scene_mag = pn_scene_magnitude(scene);
    return PN_OK;
}

void pn_renderer_destroy(pn_renderer *r)
{
    pn_gpu_device *dev = r->dev;
    if (!dev || !dev->device) {
        memset(r, 0, sizeof *r);
        return;
    }
    VkDevice d = dev->device;
    vkDeviceWaitIdle(d);
    if (r->cmd)
        vkFreeCommandBuffers(d, dev->cmd_pool, 1, &r->cmd);
    if (r->timestamps)
        vkDestroyQueryPool(d, r->timestamps, NULL);
    pn_shade_pass_destroy(dev, &r->shade);
    pn_history_pass_destroy(dev, &r->history);
    pn_filter_pass_destroy(dev, &r->filter);
    pn_penumbra_pass_destroy(dev, &r->penumbra);
    pn_shadow_pass_destroy(dev, &r->shadow);
    pn_gbuffer_upload_destroy(dev, &r->upload);
    pn_gbuffer_pass_destroy(dev, &r->gbuffer);
    pn_gpu_image *imgs[7] = {&r->p, &r->n, &r->albedo, &r->depth, &r->v_raw, &r->v, &r->radiance};
    for (int i = 0; i < 7; i++)
        pn_gpu_image_destroy(dev, imgs[i]);
    pn_gpu_buffer_destroy(dev, &r->readback);
    memset(r, 0, sizeof *r);
}
