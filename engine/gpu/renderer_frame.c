// One frame: G-buffer, per light shadow, filter and shading, the readback; recorded, submitted and
// waited for, warmed up first over one tile when pipelines have not run yet, and timed.
#include "gpu/renderer.h"

#include <math.h>
#include <string.h>

#include "core/log.h"
#include "core/timer.h"
#include "gpu/renderer_internal.h"

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

// G-buffer, then per light shadow -> filter (with one) -> shade (adding to the radiance), then the
// readback, with a timestamp after each pass. Per light: `samples` traced per pixel
// (pn_shadow_samples) and the filter's `noise_samples` (pn_filter_noise_samples).
// With the temporal history, `hist` says per light whether it drops its history and the most
// samples its sums hold (NULL without).
typedef struct history_frame {
    bool fresh;  // no previous frame: every pixel starts its own lineage (pn_history_pass_record_choose)
    bool follow; // pixels continue lineages: no interleaved tile (the same)
    bool drop[PN_MAX_LIGHTS];
    float cap[PN_MAX_LIGHTS];
} history_frame;

static void record_frame(pn_renderer *r, VkCommandBuffer cmd, const pn_gbuffer_push *camera, const pn_light_gpu *lights,
                         const uint32_t *samples, const uint32_t *noise_samples, uint32_t light_count, float yfov_deg,
                         const history_frame *hist, bool one_tile)
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
    if (hist)
        pn_history_pass_record_start(cmd, &r->history);
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
        if (hist && hist->follow && i == 0) // P, N -> each pixel's previous pixel and lineage (its time: the shadow's)
            pn_history_pass_record_choose(cmd, &r->history, hist->fresh);
        pn_shadow_pass_record(cmd, &r->shadow, samples[i], i); // P, N -> V raw
        VkImageMemoryBarrier2 raw_ready[3] = {
            pn_gpu_image_barrier(&r->v_raw, COMPUTE, WRITE, COMPUTE, READ, GENERAL, GENERAL),
            pn_gpu_image_barrier(&r->shadow.counts, COMPUTE, WRITE, COMPUTE, READ, GENERAL, GENERAL), // the filter's
            pn_gpu_image_barrier(&r->shadow.blockers, COMPUTE, WRITE, COMPUTE, READ, GENERAL, GENERAL), // the penumbra's
        };
        pn_gpu_cmd_barrier(cmd, NULL, 3, raw_ready);
        timestamp(r, cmd, ts + TS_SHADOW);
        if (hist) {
            // The frame's samples added to the history (its time counts in the filter's): it
            // rewrites V_raw where there is history, and writes the counts the filters read.
            const VkMemoryBarrier2 rw = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                         .srcStageMask = COMPUTE,
                                         .srcAccessMask = WRITE,
                                         .dstStageMask = COMPUTE,
                                         .dstAccessMask = READ | WRITE};
            pn_gpu_cmd_barrier(cmd, &rw, 0, NULL);
            float tile = filtered(r) ? (float)(pn_filter_tile(r->desc.tile_w) * pn_filter_tile(r->desc.tile_h)) : 1.0f;
            pn_history_pass_record(cmd, &r->history, i, hist->drop[i], hist->cap[i], tile, hist->follow);
            pn_gpu_cmd_barrier(cmd, &rw, 0, NULL);
        }
        if (filtered(r)) {
            // The penumbra filter's footprints narrow with each pixel's samples (its counts, the
            // history's where there is one: filter.comp).
            bool penumbra = r->desc.filter == PN_FILTER_PENUMBRA;
            float narrow = penumbra ? (float)pn_penumbra_window_scale() : 0.0f;
            // The filter pass's set holds its footprints; under the penumbra filter it writes V only
            // where a pixel is not lit.
            pn_penumbra_pass_begin(cmd, &r->penumbra, penumbra ? &r->v : NULL);
            pn_filter_pass_record(cmd, &r->filter, noise_samples[i], pn_shadow_adaptive(&r->shadow, samples[i]),
                                  yfov_deg, narrow, (float)pn_penumbra_width_scale()); // P, N, V raw -> V
            VkImageMemoryBarrier2 v_ready = pn_gpu_image_barrier(&r->v, COMPUTE, WRITE, COMPUTE, READ, GENERAL, GENERAL);
            pn_gpu_cmd_barrier(cmd, NULL, 1, &v_ready);
            if (penumbra) {
                // The Gaussian's input and the window's blockers, for their oracles.
                if (r->desc.keep_window && !one_tile && i + 1 == light_count)
                    pn_renderer_record_window_copy(r, cmd);
                pn_penumbra_pass_record(cmd, &r->penumbra, noise_samples[i],
                                        pn_shadow_adaptive(&r->shadow, samples[i]), yfov_deg); // V -> V
                pn_gpu_cmd_barrier(cmd, NULL, 1, &v_ready);
            }
        }
        timestamp(r, cmd, ts + TS_FILTER);
        pn_shade_pass_record(cmd, &r->shade, &lights[i], i > 0); // P, N, albedo, V -> radiance
        timestamp(r, cmd, ts + TS_SHADE);
        if (light_count > 1 && !one_tile)
            pn_renderer_record_light_copy(r, cmd, i);
    }

    if (!one_tile) // nothing of the warm-up frame is read
        pn_renderer_record_readback(r, cmd);
}

// PN_PIPELINE_LOG: each pass's time in the warm-up frame, where llvmpipe compiles its pipelines
// (their creation leaves the LLVM compile to the first dispatch): a row `first-use <pass> 0 <ms>`.
static void log_first_use(pn_renderer *r, uint32_t light_count)
{
    uint64_t ts[TS_COUNT];
    uint32_t used = TS_LIGHT + 3 * light_count;
    if (vkGetQueryPoolResults(r->dev->device, r->timestamps, 0, used, sizeof ts, ts, sizeof ts[0],
                              VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT) != VK_SUCCESS)
        return;
    double period_ms = r->dev->props.limits.timestampPeriod * 1e-6;
    pn_gpu_first_use_log(r->dev, "gbuffer", (double)(ts[TS_GBUFFER] - ts[TS_START]) * period_ms);
    static const char *const PASS[3] = {"shadow", "filter", "shade"};
    uint64_t prev = ts[TS_GBUFFER];
    for (uint32_t i = 0; i < light_count; i++)
        for (int k = 0; k < 3; k++) {
            uint64_t t = ts[TS_LIGHT + 3 * i + k];
            pn_gpu_first_use_log(r->dev, PASS[k], (double)(t - prev) * period_ms);
            prev = t;
        }
}

// The frame once over its first tile, every pass and pipeline it will run, so that the driver
// compiles what it compiles at a pipeline's first use (llvmpipe: all of it, 1.3 s of a 1.5 s first
// frame of the default scene on a cold shader cache) outside the frame's own times. Its images are
// all rewritten by the frame that follows. *compile_ms: its wall-clock time and the creation time
// pending. Ignores the loop budget's flag (the frame itself retries as it needs).
static pn_result warm_up(pn_renderer *r, const pn_gbuffer_push *cam, const pn_light_gpu *l, const uint32_t *samples,
                         const uint32_t *noise_samples, uint32_t light_count, float yfov_deg,
                         const history_frame *hist, double *compile_ms)
{
    uint64_t t0 = pn_time_ns();
    bool *one_tile[5] = {&r->shadow.one_tile, &r->filter.one_tile, &r->penumbra.one_tile, &r->shade.one_tile,
                         &r->history.one_tile};
    for (int i = 0; i < 5; i++)
        *one_tile[i] = true;
    VkResult vr = vkResetCommandBuffer(r->cmd, 0);
    VkCommandBufferBeginInfo bi = {.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO,
                                   .flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT};
    if (vr == VK_SUCCESS)
        vr = vkBeginCommandBuffer(r->cmd, &bi);
    if (vr == VK_SUCCESS) {
        record_frame(r, r->cmd, cam, l, samples, noise_samples, light_count, yfov_deg, hist, true);
        vr = vkEndCommandBuffer(r->cmd);
    }
    for (int i = 0; i < 5; i++)
        *one_tile[i] = false;
    VkSubmitInfo si = {.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO, .commandBufferCount = 1, .pCommandBuffers = &r->cmd};
    if (vr == VK_SUCCESS)
        vr = vkQueueSubmit(r->dev->queue, 1, &si, VK_NULL_HANDLE);
    if (vr == VK_SUCCESS)
        vr = vkQueueWaitIdle(r->dev->queue);
    VK_CHECK(vr);
    if (vr == VK_SUCCESS && r->dev->pipeline_log)
        log_first_use(r, light_count);
    *compile_ms = r->compile_pending_ms + pn_ms_since(t0);
    r->compile_pending_ms = 0;
    r->cold = false;
    r->shadow_made = r->shadow.pipelines_made;
    return PN_OK;
}

// The temporal history's part of a frame before it is recorded: its images for the frame's lights,
// its parameters (the last frame's camera, the boxes of what moved, the lights) and which lights
// drop their history. (The last frame's P is the pass's own copy: history.comp.)
static pn_result history_begin(pn_renderer *r, const pn_gbuffer_push *cam, const pn_light_gpu *l,
                               const uint32_t *samples, uint32_t light_count, float yfov_deg, history_frame *hf)
{
    pn_gpu_device *dev = r->dev;
    if (r->history.layers != light_count) {
        // A history per light: made again for another count (the queue is idle between frames). The
        // filters' sets are written anew whatever the views' handles (a new view may reuse the
        // destroyed one's), and on any failure nothing is left half made: the next frame starts over.
        uint64_t t0 = pn_time_ns();
        pn_history_pass_destroy(dev, &r->history);
        r->filter.images[PN_FILTER_BINDING_COUNTS] = VK_NULL_HANDLE;
        r->penumbra.images[PN_PENUMBRA_BINDING_COUNTS] = VK_NULL_HANDLE;
        r->shadow.lineage_view = VK_NULL_HANDLE;
        pn_result res = pn_history_pass_create(dev, r->width, r->height, light_count, &r->p, &r->n, &r->shadow.counts,
                                               &r->v_raw, &r->history);
        if (res == PN_OK)
            res = pn_filter_pass_set_counts(dev, &r->filter, r->history.out.view, true);
        if (res == PN_OK)
            res = pn_penumbra_pass_set_counts(dev, &r->penumbra, r->history.out.view, true);
        if (res != PN_OK) {
            pn_history_pass_destroy(dev, &r->history);
            return res;
        }
        r->compile_pending_ms += pn_ms_since(t0);
        r->cold = true; // the filters' pipelines for the history's counts, not run yet
        r->history_prev = false;
    }
    pn_shadow_pass_set_lineage(dev, &r->shadow, &r->history.lineage);
    bool fresh = !r->history_prev || r->history_drop || light_count != r->history_light_count;
    // Until this frame has ended: a frame that fails after its G-buffer pass leaves P, the sums and
    // the camera out of step, and the next one starts afresh.
    r->history_prev = false;
    pn_history_params *hp = pn_history_pass_params(&r->history);
    memcpy(hp->prev_view_proj, r->history_camera.view_proj, sizeof hp->prev_view_proj);
    memcpy(hp->prev_eye, r->history_camera.eye, sizeof hp->prev_eye);
    memcpy(hp->prev_forward, r->history_camera.forward, sizeof hp->prev_forward);
    memcpy(hp->view_proj, cam->view_proj, sizeof hp->view_proj);
    hp->frame = r->history_frame, hp->seed = r->desc.seed; // as the shadow pass's (a new lineage's key)
    hp->pixel_angle = (float)pn_pixel_angle(yfov_deg, r->height);
    hp->prev_pixel_angle = r->history_angle;
    hp->depth_from_eye = 0; // the G-buffer's N.w
    pn_history_pass_set_boxes(&r->history, &r->history_boxes, r->shadow.scene_mag,
                              r->shadow.mode->needs.tree ? r->desc.leaf_size : 0.0);
    hf->fresh = fresh;
    hp->drop_mask = 0;
    for (uint32_t i = 0; i < light_count; i++) {
        hp->lights[i] = l[i];
        hf->drop[i] = fresh || memcmp(&l[i], &r->history_lights[i], sizeof l[i]) != 0;
        hf->cap[i] = (float)r->history_frames * (float)(samples[i] ? samples[i] : 1);
        hp->drop_mask |= hf->drop[i] ? 1u << i : 0u;
    }
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
    PN_TRY(pn_renderer_reserve_readback(r, light_count));
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
        // Adaptive: the first round's, which every pixel took (the filter counts a pixel's own rays
        // where it took more).
        // (The shadow pass takes spp_min from the desc below: pn_shadow_pass_update.)
        bool adaptive = r->desc.spp_min && samples[i] > r->desc.spp_min;
        noise_samples[i] = pn_filter_noise_samples(adaptive ? r->desc.spp_min : spp, &lights[i]);
    }
    // The temporal history: consecutive frames share the strata of a window of them (light_sample).
    uint32_t tiles = filtered(r) ? pn_filter_tile(r->desc.tile_w) * pn_filter_tile(r->desc.tile_h) : 1;
    pn_shadow_pass_set_frame(&r->shadow, r->history_frames, r->history_frame, tiles);
    // The queue is idle between frames (pn_renderer_render waits), so the host may rewrite them.
    pn_shadow_pass_update(&r->shadow, &r->desc, l, light_count, (float)pn_pixel_angle(camera->yfov_deg, r->height));
    uint64_t t0 = pn_time_ns();
    for (uint32_t i = 0; i < light_count; i++)
        PN_TRY(pn_shadow_pass_prepare(dev, &r->shadow, samples[i]));
    uint32_t shade_made;
    PN_TRY(pn_shade_pass_prepare(dev, &r->shade, l, light_count, &shade_made));
    double compile_ms = 0;
    if (r->shadow.pipelines_made != r->shadow_made || shade_made) {
        r->cold = true;
        r->compile_pending_ms += pn_ms_since(t0);
    }
    history_frame hf_store, *hist = r->history_frames ? &hf_store : NULL;
    if (hist) {
        PN_TRY(history_begin(r, &cam, l, samples, light_count, camera->yfov_deg, hist));
        hist->follow = tiles == 1; // lineages where the shadow pass samples without a tile
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
        PN_TRY(warm_up(r, &cam, l, samples, noise_samples, light_count, camera->yfov_deg, hist, &compile_ms));
    }
    // Only adaptive sampling writes the rays image (not a point light's single sample, nor mode none).
    r->rays_written = r->shadow.mode->traces && pn_shadow_adaptive(&r->shadow, samples[light_count - 1]);
    // Continued: the last frame's counts stay and its rounds go on (pn_shadow_pass_record).
    bool adaptive_one = r->rays_written && light_count == 1;
    // The first round's samples depend on the filter's tile too (interleaved under a filter).
    uint32_t tile = r->desc.filter != PN_FILTER_NONE
                        ? pn_filter_tile(r->desc.tile_w) << 8 | pn_filter_tile(r->desc.tile_h)
                        : 0;
    bool same = r->continuable_spp_min == r->desc.spp_min && r->continuable_seed == r->desc.seed &&
                r->continuable_tile == tile;
    // (Not under the temporal history: the history holds the last frame's samples already.)
    r->shadow.resume_from = r->continue_next && !hist && adaptive_one && same && r->continuable_spp &&
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
        record_frame(r, r->cmd, &cam, l, samples, noise_samples, light_count, camera->yfov_deg, hist, false);
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
    if (hist) {
        // This frame's sums, camera and lights are the next frame's previous ones.
        pn_history_pass_flip(&r->history);
        r->history_prev = true, r->history_drop = false, r->history_boxes.count = 0;
        r->history_camera = cam;
        r->history_angle = (float)pn_pixel_angle(camera->yfov_deg, r->height);
        memcpy(r->history_lights, l, light_count * sizeof l[0]);
        r->history_light_count = light_count;
        r->history_frame++;
    }
    r->continuable_spp = adaptive_one ? samples[0] : 0;
    r->continuable_spp_min = r->desc.spp_min, r->continuable_seed = r->desc.seed, r->continuable_tile = tile;

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
