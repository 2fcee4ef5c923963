// The shadow pass recorded into the host's command buffer over the host's images: the engine's
// pass (gpu/shadow_pass.h) with the host's views in place of the renderer's P, N and V, and the
// acceleration structures built for the recorder alone.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel/alpha.h"
#include "api/api_internal.h"
#include "gpu/history_pass.h"
#include "gpu/resources.h"
#include "gpu/shade_pass.h"
#include "gpu/shadow_pass.h"

struct penumbra_recorder {
    penumbra_context *ctx;
    pn_shadow_accel accel;
    pn_renderer_desc rd;    // what the pass is made for (filter none; the seed set per record)
    pn_gpu_image p, n, v;   // the host's views, wrapped: penumbra owns no image, memory or view
    pn_shadow_pass pass;
    bool pass_made;
    pn_light light;
    uint32_t samples;       // pn_shadow_samples of the light
    // The temporal history (desc.history_frames > 0): its pass over the host's P, N and V, and
    // the frame it is at. A recording's frame counts once the next recording finds it was not
    // cut short (pending: penumbra_recorder_check clears it for a retry).
    pn_history_pass history;
    uint32_t history_frames, frame;
    // Drops asked for (penumbra_recorder_history_drop) and those a counted recording made.
    uint32_t drops_asked, drops_done, pending_drops;
    bool history_made, has_prev, pending;
    penumbra_view prev, pending_view;
};

static void recorder_free(penumbra_recorder *rec)
{
    pn_gpu_device *dev = &rec->ctx->dev;
    if (rec->history_made)
        pn_history_pass_destroy(dev, &rec->history);
    if (rec->pass_made)
        pn_shadow_pass_destroy(dev, &rec->pass);
    pn_shadow_accel_destroy(dev, &rec->accel);
    penumbra_context *ctx = rec->ctx;
    free(rec);
    pn_api_context_release(ctx); // last: it may free the context
}

static pn_result recorder_make(penumbra_recorder *rec, const penumbra_scene *s, const penumbra_recorder_desc *d)
{
    const char *fn = "penumbra_recorder_create";
    pn_gpu_device *dev = &rec->ctx->dev;
    uint32_t max_dim = dev->props.limits.maxImageDimension2D;
    if (!d->position || !d->normal || !d->visibility || d->width == 0 || d->height == 0 || d->width > max_dim ||
        d->height > max_dim) {
        pn_error("%s: the three image views and a size of 1..%u on each side are needed (got %ux%u%s)", fn, max_dim,
                 d->width, d->height, !d->position || !d->normal || !d->visibility ? ", a NULL view" : "");
        return PN_ERR_INVALID;
    }
    pn_api_config c;
    PN_TRY(pn_api_config_in(rec->ctx, s, &d->shadow, &c));
    if (!pn_api_light_in(&d->light, 0, &s->scene, &rec->light))
        return PN_ERR_INVALID;
    rec->rd = (pn_renderer_desc){.width = d->width, .height = d->height, .mode = (pn_shadow_mode)c.key.mode,
                                 .traversal = (pn_traversal)c.key.traversal, .sampler = (pn_sampler)c.key.sampler,
                                 .spp = c.spp, .filter = PN_FILTER_NONE, .split = PN_SPLIT_EVEN,
                                 .unreached_zero = true}; // V as penumbra_visibility's
    PN_TRY(pn_shadow_check_samples(&rec->rd));
    // As pn_setup_create builds them, for this one light and no view (the host's points are anywhere).
    const pn_shadow_mode_info *mode = pn_shadow_mode_get(rec->rd.mode);
    pn_shadow_accel_desc ad = {.needs = mode->needs,
                               .tree_n = c.key.tree_n ? c.key.tree_n : 7,
                               .tree_d = c.key.tree_d ? c.key.tree_d : 3,
                               .max_bytes = pn_gpu_device_pool_budget(dev),
                               .max_pool_bytes = pn_gpu_device_max_buffer(dev),
                               .light = &rec->light,
                               .light_count = 1};
    PN_TRY(pn_shadow_accel_build(&s->scene, &ad, &rec->accel));
    PN_TRY(pn_shadow_accel_upload(dev, &s->scene, &rec->accel));
    pn_shadow_accel_bind(&rec->accel, &rec->rd);
    VkExtent2D extent = {d->width, d->height};
    rec->p = (pn_gpu_image){.view = d->position, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .extent = extent, .mip_levels = 1};
    rec->n = (pn_gpu_image){.view = d->normal, .format = VK_FORMAT_R32G32B32A32_SFLOAT, .extent = extent, .mip_levels = 1};
    rec->v = (pn_gpu_image){.view = d->visibility, .format = VK_FORMAT_R32_SFLOAT, .extent = extent, .mip_levels = 1};
    PN_TRY(pn_shadow_pass_create(dev, &rec->rd, &rec->p, &rec->n, &rec->v, pn_scene_magnitude(&s->scene),
                                 pn_alpha_masked_triangles(&s->scene) > 0, &rec->pass));
    rec->pass_made = true;
    rec->samples = pn_shadow_samples(rec->rd.spp, &rec->light);
    if (d->history_frames > PN_HISTORY_MAX_FRAMES) {
        pn_error("%s: a history of %u frames: at most %d", fn, d->history_frames, PN_HISTORY_MAX_FRAMES);
        return PN_ERR_INVALID;
    }
    rec->history_frames = d->history_frames;
    if (rec->history_frames) {
        PN_TRY(pn_history_pass_create(dev, d->width, d->height, 1, &rec->p, &rec->n, &rec->pass.counts, &rec->v,
                                      &rec->history));
        rec->history_made = true;
        pn_shadow_pass_set_lineage(dev, &rec->pass, &rec->history.lineage);
    }
    // Its pipelines now, not while the host records.
    pn_light_gpu l = pn_light_to_gpu(&rec->light);
    // No camera: the pixel angle serves only adaptive sampling under a filter, which it has neither of.
    pn_shadow_pass_update(&rec->pass, &rec->rd, &l, 1, 0.0f);
    return pn_shadow_pass_prepare(dev, &rec->pass, rec->samples);
}

penumbra_status penumbra_recorder_create(penumbra_context *ctx, penumbra_scene *s, const penumbra_recorder_desc *d,
                                         penumbra_recorder **out)
{
    const char *fn = "penumbra_recorder_create";
    pn_api_call call;
    pn_api_begin(&call, ctx);
    if (out)
        *out = NULL;
    if (!pn_api_context_ok(ctx, fn) || !pn_api_need(s, fn, "scene") || !pn_api_need(d, fn, "desc") ||
        !pn_api_need(out, fn, "out"))
        return pn_api_end(&call, PN_ERR_INVALID);
    if (!ctx->dev.adopted) {
        pn_error("%s: the context made its own device; recording into the host's command buffer needs a context on "
                 "the host's device (penumbra_context_create_vulkan)", fn);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    if (s->ctx != ctx) {
        pn_error("%s: the scene belongs to another context", fn);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    penumbra_recorder *rec = calloc(1, sizeof *rec);
    if (!rec)
        return pn_api_end(&call, PN_ERR_MEMORY);
    rec->ctx = ctx;
    ctx->live++;
    pn_result r = recorder_make(rec, s, d);
    if (r != PN_OK) {
        recorder_free(rec);
        return pn_api_end(&call, r);
    }
    *out = rec;
    return pn_api_end(&call, PN_OK);
}

// The history's parameters for this recording (the previous recording's camera, this one's) and
// whether it starts afresh. A pending recording (not reported cut short) becomes the previous
// frame first.
static bool history_begin(penumbra_recorder *rec, const penumbra_view *view)
{
    if (rec->pending) {
        pn_history_pass_flip(&rec->history);
        rec->prev = rec->pending_view, rec->has_prev = true, rec->frame++;
        rec->drops_done = rec->pending_drops;
        rec->pending = false;
    }
    bool fresh = !rec->has_prev || rec->drops_asked != rec->drops_done;
    rec->pending_drops = rec->drops_asked;
    pn_history_params *hp = pn_history_pass_params(&rec->history);
    memcpy(hp->prev_view_proj, rec->prev.view_proj, sizeof hp->prev_view_proj);
    memcpy(hp->view_proj, view->view_proj, sizeof hp->view_proj);
    hp->frame = rec->frame, hp->seed = rec->rd.seed; // as the shadow pass's (a new lineage's key)
    hp->drop_mask = fresh ? 1u : 0u;
    for (int k = 0; k < 3; k++) {
        hp->prev_eye[k] = rec->prev.eye[k], hp->prev_forward[k] = rec->prev.forward[k];
        hp->eye[k] = view->eye[k], hp->forward[k] = view->forward[k];
    }
    hp->prev_eye[3] = hp->prev_forward[3] = hp->eye[3] = hp->forward[3] = 0.0f;
    hp->pixel_angle = view->pixel_angle, hp->prev_pixel_angle = rec->prev.pixel_angle;
    hp->depth_from_eye = 1; // the host's N has no depth
    hp->box_count = 0;      // a recorder's scene does not move
    hp->lights[0] = pn_light_to_gpu(&rec->light);
    pn_shadow_pass_set_frame(&rec->pass, rec->history_frames, rec->frame, 1);
    return fresh;
}

static penumbra_status record(penumbra_recorder *rec, VkCommandBuffer cmd, uint32_t seed, const penumbra_view *view,
                              const char *fn)
{
    pn_api_call call;
    pn_api_begin(&call, rec ? rec->ctx : NULL);
    if (!pn_api_need(rec, fn, "recorder") || !pn_api_need(cmd, fn, "cmd"))
        return pn_api_end(&call, PN_ERR_INVALID);
    if (view ? !rec->history_frames : rec->history_frames != 0) {
        pn_error("%s: %s", fn,
                 view ? "the recorder has no history (desc.history_frames 0): penumbra_recorder_record"
                      : "the recorder keeps a history: penumbra_recorder_record_view, with the frame's camera");
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    if (view && !(view->pixel_angle > 0.0f && isfinite(view->pixel_angle))) {
        pn_error("%s: view.pixel_angle %g: a pixel's height per unit of depth, above 0", fn, (double)view->pixel_angle);
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    rec->rd.seed = seed;
    bool fresh = view ? history_begin(rec, view) : false;
    pn_light_gpu l = pn_light_to_gpu(&rec->light);
    // The parameters are host-written: the previous recording has completed (the header's contract).
    pn_shadow_pass_update(&rec->pass, &rec->rd, &l, 1, 0.0f);
    pn_result r = pn_shadow_pass_prepare(&rec->ctx->dev, &rec->pass, rec->samples); // a chunk halved: its pipeline
    if (r == PN_OK) {
        pn_shadow_pass_begin_frame(&rec->pass);
        // The header's contract: every earlier write (the host's P and N, its layout transitions)
        // before the pass reads; the pass's own barriers start from its own images only.
        VkMemoryBarrier2 before = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                   .srcStageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                   .srcAccessMask = VK_ACCESS_2_MEMORY_WRITE_BIT,
                                   .dstStageMask = rec->pass.stage | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                   .dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                                                    VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_UNIFORM_READ_BIT};
        pn_gpu_cmd_barrier(cmd, &before, 0, NULL);
        if (view) {
            pn_history_pass_record_start(cmd, &rec->history);
            pn_history_pass_record_choose(cmd, &rec->history, fresh); // no filter: no tile
        }
        pn_shadow_pass_record(cmd, &rec->pass, rec->samples, 0);
        if (view) {
            // The frame's V and counts (shadow_finish) before the history adds to them.
            VkMemoryBarrier2 ready = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                      .srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | rec->pass.stage,
                                      .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                      .dstStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                      .dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                                                       VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
            pn_gpu_cmd_barrier(cmd, &ready, 0, NULL);
            pn_history_pass_record(cmd, &rec->history, 0, fresh,
                                   (float)rec->history_frames * (float)(rec->samples ? rec->samples : 1), 1.0f, true);
            rec->pending = true, rec->pending_view = *view;
        }
        // The pass's status flag (the loop budget's canary), read by penumbra_recorder_check once
        // the submission is done: a fence alone does not make a shader's write visible to the host.
        VkMemoryBarrier2 after = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                  .srcStageMask = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | rec->pass.stage,
                                  .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                  .dstStageMask = VK_PIPELINE_STAGE_2_HOST_BIT,
                                  .dstAccessMask = VK_ACCESS_2_HOST_READ_BIT};
        pn_gpu_cmd_barrier(cmd, &after, 0, NULL);
    }
    return pn_api_end(&call, r);
}

penumbra_status penumbra_recorder_record(penumbra_recorder *rec, VkCommandBuffer cmd, uint32_t seed)
{
    return record(rec, cmd, seed, NULL, "penumbra_recorder_record");
}

penumbra_status penumbra_recorder_record_view(penumbra_recorder *rec, VkCommandBuffer cmd, uint32_t seed,
                                              const penumbra_view *view)
{
    const char *fn = "penumbra_recorder_record_view";
    if (!view) {
        pn_api_call call;
        pn_api_begin(&call, rec ? rec->ctx : NULL);
        pn_api_need(view, fn, "view");
        return pn_api_end(&call, PN_ERR_INVALID);
    }
    return record(rec, cmd, seed, view, fn);
}

penumbra_status penumbra_recorder_history_drop(penumbra_recorder *rec)
{
    pn_api_call call;
    pn_api_begin(&call, rec ? rec->ctx : NULL);
    if (!pn_api_need(rec, "penumbra_recorder_history_drop", "recorder"))
        return pn_api_end(&call, PN_ERR_INVALID);
    rec->drops_asked++;
    return pn_api_end(&call, PN_OK);
}

penumbra_status penumbra_recorder_check(penumbra_recorder *rec)
{
    const char *fn = "penumbra_recorder_check";
    pn_api_call call;
    pn_api_begin(&call, rec ? rec->ctx : NULL);
    if (!pn_api_need(rec, fn, "recorder"))
        return pn_api_end(&call, PN_ERR_INVALID);
    bool retry = false;
    pn_result r = pn_shadow_pass_end_frame(&rec->pass, &retry);
    if (retry)
        rec->pending = false; // V is not whole: the frame is recorded again, and counts once
    if (r == PN_OK && retry) {
        pn_api_end(&call, PN_OK);
        snprintf(rec->ctx->error, sizeof rec->ctx->error,
                 "%s: a dispatch ran out of the device's shader loop budget: record and submit again (%u samples per "
                 "dispatch from now on)", fn, rec->pass.chunk);
        return PENUMBRA_INCOMPLETE;
    }
    return pn_api_end(&call, r);
}

void penumbra_recorder_destroy(penumbra_recorder *rec)
{
    if (!rec)
        return;
    pn_api_call call;
    pn_api_begin(&call, rec->ctx);
    recorder_free(rec);
    pn_log_set_capture(NULL); // not pn_api_end: the context may be gone with its last recorder
}
