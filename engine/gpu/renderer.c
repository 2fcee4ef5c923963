// One frame: G-buffer, per light shadow, filter and shading, the readback; and the frame's
// settings.
//
// Over 500 lines because the frame's recording, its readback and the settings that change
// between frames (pn_renderer_set_*) share the renderer's private images and barriers.
#include "gpu/renderer.h"

#include <math.h>
#include <string.h>

#include "accel/alpha.h"
#include "core/log.h"
#include "core/timer.h"

// Timestamps: the frame's start, the G-buffer's end, then per light the ends of its shadow, filter
// and shading passes (TS_LIGHT + 3 i + TS_*).
enum { TS_START, TS_GBUFFER, TS_LIGHT, TS_SHADOW = 0, TS_FILTER = 1, TS_SHADE = 2, TS_COUNT = TS_LIGHT + 3 * PN_MAX_LIGHTS };

// The frame's images in the readback buffer, in floats per pixel: P, N, albedo and radiance (rgba),
// V and V_raw, the shadow pass's counts and its adaptive rays image (rgba32ui), the penumbra
// filter's footprint (rg); with several lights each light's V and V_raw follow
// (pn_renderer_images).
enum { PN_READBACK_COUNTS = 4 * 4 + 2, PN_READBACK_RAYS = PN_READBACK_COUNTS + 4,
       PN_READBACK_FOOTPRINT = PN_READBACK_RAYS + 4, PN_READBACK_FLOATS_PER_PIXEL = PN_READBACK_FOOTPRINT + 2 };

// A plane of the readback buffer holds one float (or one channel) per pixel, its pixel count
// rounded up to a multiple of 4: every plane then starts 16 bytes aligned, as a copy of an RGBA32
// image must (vkCmdCopyImageToBuffer's bufferOffset, a multiple of the texel size), whatever the
// frame's size (the API's point images: any count of points).
static size_t readback_plane(const pn_renderer *r)
{
    return ((size_t)r->width * r->height + 3) & ~(size_t)3;
}

static pn_result reserve_readback(pn_renderer *r, uint32_t light_count);

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
        {&r->v, VK_FORMAT_R32_SFLOAT, comp, 0, "visibility image"},
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
    PN_TRY(reserve_readback(r, 1));
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

// The largest |coordinate| of the scene's bounds: it bounds every vertex's, which the shadow rays'
// origin offset scales with (shadow_frame.glsl).
static float scene_magnitude(const pn_scene *scene)
{
    float mag = 0;
    for (int k = 0; k < 3; k++)
        mag = fmaxf(mag, fmaxf(fabsf(scene->bounds_min[k]), fabsf(scene->bounds_max[k])));
    return mag;
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
        r = pn_shadow_pass_create(dev, desc, &out->p, &out->n, &out->v_raw, scene_magnitude(scene),
                                  pn_alpha_masked_triangles(scene) > 0, &out->shadow);
    if (r == PN_OK)
        r = pn_penumbra_pass_create(dev, desc->width, desc->height, &out->p, &out->n, &out->shadow.counts, &out->v,
                                    &out->penumbra);
    if (r == PN_OK)
        r = pn_filter_pass_create(dev, desc->width, desc->height, pn_filter_tile(desc->tile_w),
                                  pn_filter_tile(desc->tile_h), &out->p, &out->n, &out->v_raw, &out->shadow.counts,
                                  &out->shadow.blockers, &out->penumbra.sigma, &out->v, &out->filter);
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
    r->shadow.scene_mag = scene_magnitude(scene);
    return PN_OK;
}

void pn_renderer_set_leaf_size(pn_renderer *r, double leaf_size) { r->desc.leaf_size = leaf_size; }

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

// ---------------------------------------------------------------------------------------------
// The frame

static bool filtered(const pn_renderer *r) { return r->desc.filter != PN_FILTER_NONE; }

// Copies every image to the readback buffer and makes it, the shadow pass's status flag and its
// ray dump visible to the host. The V the frame gives (filtered with a filter) goes to V's place;
// with a filter, the shadow pass's own V follows the radiance.
static void record_readback(pn_renderer *r, VkCommandBuffer cmd)
{
    const VkPipelineStageFlags2 COLOR = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    const VkPipelineStageFlags2 COPY = VK_PIPELINE_STAGE_2_COPY_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL, SRC = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    const VkAccessFlags2 READ = VK_ACCESS_2_TRANSFER_READ_BIT;
    const VkAccessFlags2 STORAGE = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
    const pn_gpu_image *v = filtered(r) ? &r->v : &r->v_raw;
    const pn_gpu_image *src[6] = {&r->p, &r->n, &r->albedo, v, &r->radiance, &r->v_raw};
    int count = filtered(r) ? 6 : 5;
    VkImageMemoryBarrier2 to_copy[8] = {
        pn_gpu_image_barrier(&r->p, COLOR | COMPUTE, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(&r->n, COLOR | COMPUTE, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(&r->albedo, COLOR | COMPUTE, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(v, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(&r->radiance, COMPUTE, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(&r->v_raw, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC),
    };
    to_copy[count] = pn_gpu_image_barrier(&r->shadow.counts, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC);
    to_copy[count + 1] = pn_gpu_image_barrier(&r->shadow.rays, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC);
    pn_gpu_cmd_barrier(cmd, NULL, (uint32_t)count + 2, to_copy);
    if (r->desc.filter == PN_FILTER_PENUMBRA) {
        // The footprint (the last light's), left in SRC: the next frame's penumbra pass discards it.
        VkImageMemoryBarrier2 b = pn_gpu_image_barrier(&r->penumbra.scratch, COMPUTE, STORAGE, COPY, READ, GENERAL, SRC);
        pn_gpu_cmd_barrier(cmd, NULL, 1, &b);
        VkBufferImageCopy copy = {
            .bufferOffset = (VkDeviceSize)PN_READBACK_FOOTPRINT * 4 * readback_plane(r),
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, r->penumbra.scratch.image, SRC, r->readback.buffer, 1, &copy);
    }
    VkDeviceSize px = readback_plane(r), offset = 0;
    for (int i = 0; i < count; i++) {
        VkBufferImageCopy copy = {
            .bufferOffset = offset,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, src[i]->image, SRC, r->readback.buffer, 1, &copy);
        offset += px * (src[i]->format == VK_FORMAT_R32_SFLOAT ? 4 : 16);
    }
    // The shadow pass's counts and rays (the last light's), at their place after V_raw's, filtered
    // or not.
    const pn_gpu_image *shadow[2] = {&r->shadow.counts, &r->shadow.rays};
    for (int i = 0; i < 2; i++) {
        VkBufferImageCopy copy = {
            .bufferOffset = (PN_READBACK_COUNTS + 4 * i) * 4 * px,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, shadow[i]->image, SRC, r->readback.buffer, 1, &copy);
    }
    // Back to the shadow pass's layout after the copy: a frame that continues this one's adaptive
    // samples (pn_renderer_set_continue) takes counts, half counts and rays from GENERAL.
    VkImageMemoryBarrier2 back[2] = {
        pn_gpu_image_barrier(&r->shadow.counts, COPY, VK_ACCESS_2_NONE, COMPUTE, STORAGE, SRC, GENERAL),
        pn_gpu_image_barrier(&r->shadow.rays, COPY, VK_ACCESS_2_NONE, COMPUTE, STORAGE, SRC, GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, 2, back);
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){
                           .sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                           .srcStageMask = COPY | COMPUTE,
                           .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                           .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
                           .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT,
                       },
                       0, NULL);
}

// A timestamp after everything recorded before it. llvmpipe takes a timestamp query's value when it
// next flushes, not where the command stands: followed by the next pass's dispatch, a timestamp
// counted that dispatch in the interval before it (measured: the shading pass's time showed in the
// filter's interval, and the filter's in the shadow pass's). The barrier after it flushes at once;
// elsewhere it costs a pipeline drain between passes, which the timestamps imply anyway.
static void timestamp(pn_renderer *r, VkCommandBuffer cmd, uint32_t index)
{
    const VkPipelineStageFlags2 ALL = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    vkCmdWriteTimestamp2(cmd, ALL, r->timestamps, index);
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = ALL,
                                           .dstStageMask = ALL},
                       0, NULL);
}

// Copies light `i`'s V (and V_raw with a filter) to its place after the readback's images
// (pn_renderer_images), in the GENERAL layout the passes keep them in.
static void record_light_copy(pn_renderer *r, VkCommandBuffer cmd, uint32_t i)
{
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, COPY = VK_PIPELINE_STAGE_2_COPY_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL, SRC = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    const VkAccessFlags2 WRITE = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, READ = VK_ACCESS_2_TRANSFER_READ_BIT;
    const pn_gpu_image *src[2] = {filtered(r) ? &r->v : &r->v_raw, &r->v_raw};
    uint32_t count = filtered(r) ? 2 : 1;
    VkImageMemoryBarrier2 to_copy[2] = {
        pn_gpu_image_barrier(src[0], COMPUTE, WRITE, COPY, READ, GENERAL, SRC),
        pn_gpu_image_barrier(src[1], COMPUTE, WRITE, COPY, READ, GENERAL, SRC),
    };
    pn_gpu_cmd_barrier(cmd, NULL, count, to_copy);
    VkDeviceSize px = readback_plane(r);
    for (uint32_t k = 0; k < count; k++) {
        VkBufferImageCopy copy = {
            .bufferOffset = (PN_READBACK_FLOATS_PER_PIXEL + 2 * i + k) * 4 * px,
            .imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1},
            .imageExtent = {r->width, r->height, 1},
        };
        vkCmdCopyImageToBuffer(cmd, src[k]->image, SRC, r->readback.buffer, 1, &copy);
    }
    // Back to the passes' layout, after the copy: the next light rewrites them, the readback reads
    // them from GENERAL.
    VkImageMemoryBarrier2 back[2] = {
        pn_gpu_image_barrier(src[0], COPY, VK_ACCESS_2_NONE, COMPUTE | COPY, WRITE | READ, SRC, GENERAL),
        pn_gpu_image_barrier(src[1], COPY, VK_ACCESS_2_NONE, COMPUTE | COPY, WRITE | READ, SRC, GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, count, back);
}

// G-buffer, then per light shadow -> filter (with one) -> shade (adding to the radiance), then the
// readback, with a timestamp after each pass. Per light: `samples` traced per pixel
// (pn_shadow_samples) and the filter's `noise_samples` (pn_filter_noise_samples).
static void record_frame(pn_renderer *r, VkCommandBuffer cmd, const pn_gbuffer_push *camera, const pn_light_gpu *lights,
                         const uint32_t *samples, const uint32_t *noise_samples, uint32_t light_count, float yfov_deg,
                         bool one_tile)
{
    const VkPipelineStageFlags2 ALL = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    const VkPipelineStageFlags2 COMPUTE = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    const VkImageLayout GENERAL = VK_IMAGE_LAYOUT_GENERAL;
    const VkAccessFlags2 WRITE = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, READ = VK_ACCESS_2_SHADER_STORAGE_READ_BIT;
    vkCmdResetQueryPool(cmd, r->timestamps, 0, TS_COUNT);
    // V, its raw form and the radiance are fully rewritten: discard the previous frame's
    // (UNDEFINED) after all of its work on them. The G-buffer pass does the same for its targets.
    VkImageMemoryBarrier2 start[3] = {
        pn_gpu_image_barrier(&r->v_raw, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COMPUTE, WRITE, VK_IMAGE_LAYOUT_UNDEFINED,
                             GENERAL),
        pn_gpu_image_barrier(&r->radiance, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COMPUTE, WRITE, VK_IMAGE_LAYOUT_UNDEFINED,
                             GENERAL),
        pn_gpu_image_barrier(&r->v, ALL, VK_ACCESS_2_MEMORY_WRITE_BIT, COMPUTE, WRITE, VK_IMAGE_LAYOUT_UNDEFINED,
                             GENERAL),
    };
    pn_gpu_cmd_barrier(cmd, NULL, filtered(r) ? 3 : 2, start);
    timestamp(r, cmd, TS_START);

    // The warm-up frame: every pass over the first tile (warm_up), which holds what the frame
    // itself writes there (a ray dump's and the work counts' pixels included).
    pn_gbuffer_targets targets = {&r->p, &r->n, &r->albedo, &r->depth, r->width, r->height, one_tile};
    if (r->upload.buffer.buffer)
        pn_gbuffer_upload_record(cmd, &r->upload, &targets);
    else
        pn_gbuffer_pass_record(cmd, &r->gbuffer, &targets, camera);
    timestamp(r, cmd, TS_GBUFFER);

    for (uint32_t i = 0; i < light_count; i++) {
        if (i > 0) {
            // The previous light's V and V_raw were read by its filter, shading and copy, and its
            // radiance written: all of that before this light rewrites them or adds to it.
            pn_gpu_cmd_barrier(cmd,
                               &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                                   .srcStageMask = COMPUTE | VK_PIPELINE_STAGE_2_COPY_BIT,
                                                   .srcAccessMask = WRITE,
                                                   .dstStageMask = COMPUTE,
                                                   .dstAccessMask = READ | WRITE},
                               0, NULL);
        }
        uint32_t ts = TS_LIGHT + 3 * i;
        pn_shadow_pass_record(cmd, &r->shadow, samples[i], i); // P, N -> V raw
        VkImageMemoryBarrier2 raw_ready[3] = {
            pn_gpu_image_barrier(&r->v_raw, COMPUTE, WRITE, COMPUTE, READ, GENERAL, GENERAL),
            pn_gpu_image_barrier(&r->shadow.counts, COMPUTE, WRITE, COMPUTE, READ, GENERAL, GENERAL), // the filter's
            pn_gpu_image_barrier(&r->shadow.blockers, COMPUTE, WRITE, COMPUTE, READ, GENERAL, GENERAL), // the penumbra's
        };
        pn_gpu_cmd_barrier(cmd, NULL, 3, raw_ready);
        timestamp(r, cmd, ts + TS_SHADOW);
        if (filtered(r)) {
            // Under the penumbra filter the footprints narrow with the samples of the accumulated
            // picture (pn_renderer_set_accumulated): the laws' factors for `frames` times as many.
            bool penumbra = r->desc.filter == PN_FILTER_PENUMBRA;
            double frames = r->accumulated > 1 ? (double)r->accumulated : 1.0;
            float narrow = penumbra ? (float)(pn_penumbra_window_scale() * pow(frames, -0.75)) : 0.0f;
            pn_penumbra_pass_begin(cmd, &r->penumbra); // the filter pass's set holds its footprints
            pn_filter_pass_record(cmd, &r->filter, noise_samples[i], pn_shadow_adaptive(&r->shadow, samples[i]),
                                  yfov_deg, narrow, (float)(pn_penumbra_width_scale() / sqrt(frames))); // P, N, V raw -> V
            VkImageMemoryBarrier2 v_ready = pn_gpu_image_barrier(&r->v, COMPUTE, WRITE, COMPUTE, READ, GENERAL, GENERAL);
            pn_gpu_cmd_barrier(cmd, NULL, 1, &v_ready);
            if (penumbra) {
                pn_penumbra_pass_record(cmd, &r->penumbra, noise_samples[i],
                                        pn_shadow_adaptive(&r->shadow, samples[i]), yfov_deg); // V -> V
                pn_gpu_cmd_barrier(cmd, NULL, 1, &v_ready);
            }
        }
        timestamp(r, cmd, ts + TS_FILTER);
        pn_shade_pass_record(cmd, &r->shade, &lights[i], i > 0); // P, N, albedo, V -> radiance
        timestamp(r, cmd, ts + TS_SHADE);
        if (light_count > 1 && !one_tile)
            record_light_copy(r, cmd, i);
    }

    if (!one_tile) // nothing of the warm-up frame is read
        record_readback(r, cmd);
}

// The readback buffer holds the frame's images and, with several lights, every light's V and V_raw.
static pn_result reserve_readback(pn_renderer *r, uint32_t light_count)
{
    VkDeviceSize px = readback_plane(r);
    VkDeviceSize bytes = px * 4 * (PN_READBACK_FLOATS_PER_PIXEL + (light_count > 1 ? 2 * light_count : 0));
    if (r->readback.size >= bytes)
        return PN_OK;
    pn_gpu_buffer_destroy(r->dev, &r->readback);
    return pn_gpu_buffer_create(r->dev, "frame's readback buffer", bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                PN_GPU_HOST_READBACK, &r->readback);
}

// The frame once over its first tile, every pass and pipeline it will run, so that the driver
// compiles what it compiles at a pipeline's first use (llvmpipe: all of it, 1.3 s of a 1.5 s first
// frame of the default scene on a cold shader cache) outside the frame's own times. Its images are
// all rewritten by the frame that follows. *compile_ms: its wall-clock time and the creation time
// pending. Ignores the loop budget's flag (the frame itself retries as it needs).
static pn_result warm_up(pn_renderer *r, const pn_gbuffer_push *cam, const pn_light_gpu *l, const uint32_t *samples,
                         const uint32_t *noise_samples, uint32_t light_count, float yfov_deg, double *compile_ms)
{
    uint64_t t0 = pn_time_ns();
    bool *one_tile[4] = {&r->shadow.one_tile, &r->filter.one_tile, &r->penumbra.one_tile, &r->shade.one_tile};
    for (int i = 0; i < 4; i++)
        *one_tile[i] = true;
    VkResult vr = vkResetCommandBuffer(r->cmd, 0);
    VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                   .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
    if (vr == VK_SUCCESS)
        vr = vkBeginCommandBuffer(r->cmd, &bi);
    if (vr == VK_SUCCESS) {
        record_frame(r, r->cmd, cam, l, samples, noise_samples, light_count, yfov_deg, true);
        vr = vkEndCommandBuffer(r->cmd);
    }
    for (int i = 0; i < 4; i++)
        *one_tile[i] = false;
    VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &r->cmd};
    if (vr == VK_SUCCESS)
        vr = vkQueueSubmit(r->dev->queue, 1, &si, VK_NULL_HANDLE);
    if (vr == VK_SUCCESS)
        vr = vkQueueWaitIdle(r->dev->queue);
    VK_CHECK(vr);
    *compile_ms = r->compile_pending_ms + pn_ms_since(t0);
    r->compile_pending_ms = 0;
    r->cold = false;
    r->shadow_made = r->shadow.pipelines_made;
    return PN_OK;
}

pn_result pn_renderer_render_lights(pn_renderer *r, const pn_camera *camera, const pn_light *lights,
                                    uint32_t light_count, pn_frame_times *times)
{
    if (light_count < 1 || light_count > PN_MAX_LIGHTS) {
        pn_error("%u lights: a frame has 1 to %d", light_count, PN_MAX_LIGHTS);
        return PN_ERR_INVALID;
    }
    pn_gpu_device *dev = r->dev;
    PN_TRY(reserve_readback(r, light_count));
    r->light_count = light_count;
    pn_gbuffer_push cam = pn_gbuffer_camera(&r->gbuffer, camera, r->width, r->height);
    pn_light_gpu l[PN_MAX_LIGHTS];
    uint32_t samples[PN_MAX_LIGHTS], noise_samples[PN_MAX_LIGHTS], spp = r->desc.spp ? r->desc.spp : 1;
    for (uint32_t i = 0; i < light_count; i++) {
        l[i] = pn_light_to_gpu(&lights[i]);
        // A budgeted split: up to the whole budget for one light; each pixel stops at its own count.
        samples[i] = r->desc.split == PN_SPLIT_BUDGET && !pn_light_is_point(&lights[i])
                         ? pn_shadow_budget(spp, light_count)
                         : pn_shadow_samples(spp, &lights[i]);
        noise_samples[i] = pn_filter_noise_samples(spp, &lights[i]);
    }
    // The queue is idle between frames (pn_renderer_render waits), so the host may rewrite them.
    pn_shadow_pass_update(&r->shadow, &r->desc, l, light_count);
    uint64_t t0 = pn_time_ns();
    for (uint32_t i = 0; i < light_count; i++)
        PN_TRY(pn_shadow_pass_prepare(dev, &r->shadow, samples[i]));
    double compile_ms = 0;
    if (r->shadow.pipelines_made != r->shadow_made) {
        r->cold = true;
        r->compile_pending_ms += pn_ms_since(t0);
    }
    // A frame that continues the last one's counts cannot be warmed up: the warm-up's shadow pass
    // starts its images afresh and would lose them. It reports what was created for it, and a
    // pipeline made for it runs first within it (the demo's refinement, below 32 samples); so
    // does every frame of a renderer made with no_warm_up.
    if (r->cold && (r->continue_next || r->desc.no_warm_up)) {
        compile_ms = r->compile_pending_ms;
        r->compile_pending_ms = 0;
        r->cold = false;
        r->shadow_made = r->shadow.pipelines_made;
    } else if (r->cold) {
        PN_TRY(warm_up(r, &cam, l, samples, noise_samples, light_count, camera->yfov_deg, &compile_ms));
    }
    // Only adaptive sampling writes the rays image (not a point light's single sample, nor mode none).
    r->rays_written = r->shadow.mode->traces && pn_shadow_adaptive(&r->shadow, samples[light_count - 1]);
    // Continued: the last frame's counts stay and its rounds go on (pn_shadow_pass_record).
    bool adaptive_one = r->rays_written && light_count == 1;
    bool same = r->continuable_spp_min == r->desc.spp_min && r->continuable_seed == r->desc.seed;
    r->shadow.resume_from = r->continue_next && adaptive_one && same && r->continuable_spp &&
                                    samples[0] > r->continuable_spp
                                ? r->continuable_spp
                                : 0;
    r->resumed = r->shadow.resume_from != 0;
    r->continue_next = false;
    r->continuable_spp = 0; // until this frame has ended
    // llvmpipe: the frame is recorded again only when the shadow pass ran out of the loop budget
    // (pn_shadow_pass_end_frame); on other drivers this loop runs once.
    bool retry = true;
    while (retry) {
        pn_shadow_pass_begin_frame(&r->shadow);
        VK_CHECK(vkResetCommandBuffer(r->cmd, 0));
        VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                       .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
        VK_CHECK(vkBeginCommandBuffer(r->cmd, &bi));
        record_frame(r, r->cmd, &cam, l, samples, noise_samples, light_count, camera->yfov_deg, false);
        VK_CHECK(vkEndCommandBuffer(r->cmd));
        VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &r->cmd};
        VK_CHECK(vkQueueSubmit(dev->queue, 1, &si, VK_NULL_HANDLE));
        VK_CHECK(vkQueueWaitIdle(dev->queue));
        PN_TRY(pn_shadow_pass_end_frame(&r->shadow, &retry));
        // A continued frame cut short has added to the counts it resumed from: its retry is a
        // frame of its own, from the first samples.
        r->resumed = r->resumed && !retry;
        r->shadow.resume_from = 0;
    }
    r->continuable_spp = adaptive_one ? samples[0] : 0;
    r->continuable_spp_min = r->desc.spp_min, r->continuable_seed = r->desc.seed;

    uint64_t ts[TS_COUNT];
    uint32_t used = TS_LIGHT + 3 * light_count;
    VK_CHECK(vkGetQueryPoolResults(dev->device, r->timestamps, 0, used, sizeof ts, ts, sizeof ts[0],
                                   VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    double period_ms = dev->props.limits.timestampPeriod * 1e-6;
    memset(times, 0, sizeof *times);
    times->compile_ms = compile_ms;
    times->gbuffer_ms = (double)(ts[TS_GBUFFER] - ts[TS_START]) * period_ms;
    uint64_t prev = ts[TS_GBUFFER];
    for (uint32_t i = 0; i < light_count; i++) {
        const uint64_t *t = &ts[TS_LIGHT + 3 * i];
        times->shadow_ms += (double)(t[TS_SHADOW] - prev) * period_ms;
        times->filter_ms += (double)(t[TS_FILTER] - t[TS_SHADOW]) * period_ms;
        times->shade_ms += (double)(t[TS_SHADE] - t[TS_FILTER]) * period_ms;
        // The next light's interval starts after this one's copy of V (with several lights).
        prev = t[TS_SHADE];
    }
    return PN_OK;
}

pn_result pn_renderer_render(pn_renderer *r, const pn_camera *camera, const pn_light *light, pn_frame_times *times)
{
    return pn_renderer_render_lights(r, camera, light, 1, times);
}

void pn_renderer_images(const pn_renderer *r, pn_frame_images *out)
{
    size_t px = readback_plane(r);
    const float *base = r->readback.mapped;
    memset(out, 0, sizeof *out);
    out->p = base;
    out->n = out->p + 4 * px;
    out->albedo = out->n + 4 * px;
    out->v = out->albedo + 4 * px;
    out->radiance = out->v + px;
    out->v_raw = filtered(r) ? out->radiance + 4 * px : NULL;
    out->counts = (const uint32_t *)(base + PN_READBACK_COUNTS * px);
    out->rays = r->rays_written ? (const uint32_t *)(base + PN_READBACK_RAYS * px) : NULL;
    out->footprint = r->desc.filter == PN_FILTER_PENUMBRA ? base + PN_READBACK_FOOTPRINT * px : NULL;
    out->light_count = r->light_count ? r->light_count : 1;
    if (out->light_count == 1) {
        out->v_light[0] = out->v;
        out->v_raw_light[0] = out->v_raw;
        return;
    }
    // Several lights: each one's V and V_raw after the images (record_light_copy); V is light 0's.
    for (uint32_t i = 0; i < out->light_count; i++) {
        out->v_light[i] = base + (PN_READBACK_FLOATS_PER_PIXEL + 2 * i) * px;
        out->v_raw_light[i] = filtered(r) ? out->v_light[i] + px : NULL;
    }
    out->v = out->v_light[0];
    out->v_raw = out->v_raw_light[0];
}

void pn_renderer_set_seed(pn_renderer *r, uint32_t seed) { r->desc.seed = seed; }

void pn_renderer_set_accumulated(pn_renderer *r, uint32_t frames) { r->accumulated = frames; }

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
