// The shadow pass: pipeline, parameters, and the dispatches of a frame's chunks and adaptive
// rounds.
#include "gpu/shadow_pass.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/log.h"
#include "gpu/pools.h"
#include "shadow_project_comp.h"
#include "shadow_rtpipeline_rahit.h"
#include "shadow_rtpipeline_rchit.h"
#include "shadow_rtpipeline_rgen.h"
#include "shadow_rtpipeline_rmiss.h"

uint32_t pn_shadow_samples(uint32_t spp, const pn_light *light) { return pn_light_is_point(light) ? 1 : spp; }

uint32_t pn_filter_noise_samples(uint32_t spp, const pn_light *light) { return pn_light_is_point(light) ? 0 : spp; }

double pn_shadow_rays_per_s(uint64_t covered_pixels, uint32_t spp, const pn_light *light, double shadow_ms)
{
    return shadow_ms > 0 ? (double)covered_pixels * pn_shadow_samples(spp, light) / (shadow_ms * 1e-3) : 0;
}

bool pn_shadow_adaptive(const pn_shadow_pass *s, uint32_t samples) { return s->spp_min && samples > s->spp_min; }

pn_result pn_shadow_check_samples(const pn_renderer_desc *d)
{
    if (d->traversal == PN_TRAVERSAL_PROJECT) {
        // The projection walk answers one pixel's samples together: exact's triangles, and every
        // pixel's uniform samples (adaptive rounds would walk the pyramid again for each).
        if (d->mode != PN_SHADOW_EXACT) {
            pn_error("--traversal project is exact's: it projects the triangles of exact's BVH (got --mode %s)",
                     pn_shadow_mode_get(d->mode)->name);
            return PN_ERR_INVALID;
        }
        if (d->spp_min) {
            pn_error("--traversal project answers all of a pixel's samples in one walk: it takes uniform samples, "
                     "not adaptive ones (--spp %u:%u)", d->spp_min, d->spp);
            return PN_ERR_INVALID;
        }
    }
    if (!d->spp_min)
        return PN_OK;
    uint32_t ratio = d->spp_min <= d->spp && d->spp % d->spp_min == 0 ? d->spp / d->spp_min : 0;
    if (ratio == 0 || (ratio & (ratio - 1)) != 0) {
        pn_error("adaptive samples %u:%u: the most must be the least times a power of two (e.g. 4:64)", d->spp_min,
                 d->spp);
        return PN_ERR_INVALID;
    }
    if (d->split != PN_SPLIT_EVEN || d->dump_rays || d->sampler != PN_SAMPLER_STRATIFIED) {
        pn_error("adaptive samples draw a number of rays per pixel of their own: they need the even split, the "
                 "stratified sampler and no ray dump (got split %s, sampler %s%s)",
                 pn_split_names[d->split], pn_sampler_names[d->sampler], d->dump_rays ? ", ray dump" : "");
        return PN_ERR_INVALID;
    }
    if (!(d->pixel_error >= 0.0f)) {
        pn_error("pixel error %g: must be at least 0", (double)d->pixel_error);
        return PN_ERR_INVALID;
    }
    return PN_OK;
}

float pn_project_budget(void)
{
    // Measured (engine/gpu/README.md, the projection traversal): PN_PROJECT_BUDGET sets it for
    // such measurements.
    const char *env = getenv("PN_PROJECT_BUDGET");
    float b = env ? strtof(env, NULL) : 0.0f;
    return b > 0.0f ? b : PN_PROJECT_BUDGET_DEFAULT;
}

uint32_t pn_shadow_budget(uint32_t spp, uint32_t light_count) { return (spp ? spp : 1) * (light_count ? light_count : 1); }

void pn_sample_grid(uint32_t spp, uint32_t *grid_u, uint32_t *grid_v)
{
    uint32_t u = 1;
    for (uint32_t i = 1; i * i <= spp; i++)
        if (spp % i == 0)
            u = i;
    *grid_u = u;
    *grid_v = spp / u;
}

// The shadow shaders' specialisation (interface.h), in pn_shadow_pass.spec_data.
static const VkSpecializationMapEntry SPEC_ENTRIES[7] = {{.constantID = PN_SPEC_TRAVERSAL, .offset = 0, .size = 4},
                                                         {.constantID = PN_SPEC_VARIANT, .offset = 4, .size = 4},
                                                         {.constantID = PN_SPEC_COUNT_WORK, .offset = 8, .size = 4},
                                                         {.constantID = PN_SPEC_PACKET_RAYS, .offset = 12, .size = 4},
                                                         {.constantID = PN_SPEC_ALPHA, .offset = 16, .size = 4},
                                                         {.constantID = PN_SPEC_PROJECT_SAMPLES, .offset = 20, .size = 4},
                                                         {.constantID = PN_SPEC_UNIFORM, .offset = 24, .size = 4}};

pn_result pn_shadow_pass_create(pn_gpu_device *dev, const pn_renderer_desc *desc, const pn_gpu_image *p,
                                const pn_gpu_image *n, const pn_gpu_image *v, float scene_mag, bool alpha_masks,
                                pn_shadow_pass *out)
{
    memset(out, 0, sizeof *out);
    out->mode = pn_shadow_mode_get(desc->mode);
    out->width = desc->width, out->height = desc->height;
    out->dump_spp = desc->dump_rays ? desc->spp : 0;
    out->scene_mag = scene_mag;
    out->loop_budget = pn_gpu_device_loop_budget(dev);
    // Every device: at most PN_MAX_CHUNK (32) samples per dispatch, the size of the shader's per-ray
    // arrays; 25 spp run in one dispatch.
    // llvmpipe (Mesa 22.3): small enough that a pixel's loops stay below the budget of 65535
    // iterations (a ray takes tens), halved by pn_shadow_pass_end_frame when that is not enough.
    // There the per-ray walk balances its 8 lanes better the more rays each has, and the packet
    // walk does fewer walks, so the chunk starts at the maximum.
    out->chunk = PN_MAX_CHUNK;
    // The projection walk answers up to PN_PROJECT_MAX_SAMPLES samples of a pixel in one dispatch
    // (its bit masks); its rays after the budget run 32 at a time within it.
    out->project_chunk = PN_PROJECT_MAX_SAMPLES;
    // The pass's own pipeline is the one for the fewest samples: under auto, exact's packet walk
    // (the projection's pipelines are made for the frames that take it: pn_shadow_pass_prepare).
    int32_t traversal = (int32_t)pn_traversal_resolve(desc->mode, desc->traversal, 0, 0);
    const VkDescriptorType IMAGE = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    // Every shadow shader sees the same set (interface.h): P, N, V, the parameters, counts, status;
    // the modes that trace the device's acceleration structure also see it.
    const VkDescriptorSetLayoutBinding bindings[PN_SHADOW_BINDING_COUNT + 1] = {
        {.binding = PN_SHADOW_BINDING_P, .descriptorType = IMAGE},
        {.binding = PN_SHADOW_BINDING_N, .descriptorType = IMAGE},
        {.binding = PN_SHADOW_BINDING_V, .descriptorType = IMAGE},
        {.binding = PN_SHADOW_BINDING_PARAMS, .descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER},
        {.binding = PN_SHADOW_BINDING_COUNTS, .descriptorType = IMAGE},
        {.binding = PN_SHADOW_BINDING_STATUS, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
        {.binding = PN_SHADOW_BINDING_ADAPT, .descriptorType = IMAGE},
        {.binding = PN_SHADOW_BINDING_RAYS, .descriptorType = IMAGE},
        {.binding = PN_SHADOW_BINDING_LISTS, .descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
        {.binding = PN_SHADOW_BINDING_BLOCKERS, .descriptorType = IMAGE},
        {.binding = PN_SHADOW_BINDING_LINEAGE, .descriptorType = IMAGE},
        {.binding = PN_SHADOW_BINDING_TLAS, .descriptorType = VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR},
    };
    bool tlas = out->mode->needs.tlas; // only those modes have the last binding
    out->sized_rays = out->mode->packet_rays && traversal == PN_TRAVERSAL_PACKET_ID;
    out->project = traversal == PN_TRAVERSAL_PROJECT_ID;
    // The projection walk is a shader of its own (exact's, shared by the subgroup: vote and ballot).
    out->spirv = out->project ? pn_spv_shadow_project_comp : out->mode->spirv;
    out->spirv_size = out->project ? sizeof pn_spv_shadow_project_comp : out->mode->spirv_size;
    const VkSubgroupFeatureFlags VOTES = VK_SUBGROUP_FEATURE_VOTE_BIT | VK_SUBGROUP_FEATURE_BALLOT_BIT;
    bool votes = (dev->subgroup.supportedOperations & VOTES) == VOTES &&
                 (dev->subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT);
    if (out->project && !votes) {
        pn_error("--traversal project: %s lacks subgroup vote and ballot in compute shaders", dev->props.deviceName);
        return PN_ERR_UNSUPPORTED;
    }
    // Auto: exact's frames of many samples take the projection (pn_traversal_resolve), where the
    // device can run it.
    out->auto_project = desc->traversal == PN_TRAVERSAL_AUTO && desc->mode == PN_SHADOW_EXACT && votes;
    memcpy(out->spec_data,
           (int32_t[7]){traversal, out->mode->variant, desc->count_work ? 1 : 0, PN_MAX_CHUNK, alpha_masks ? 1 : 0,
                        PN_PROJECT_MAX_SAMPLES, 0},
           sizeof out->spec_data);
    VkSpecializationInfo spec = {.mapEntryCount = 7, .pMapEntries = SPEC_ENTRIES, .dataSize = sizeof out->spec_data,
                                 .pData = out->spec_data}; // the ray-tracing pipeline's: for any frame
    const VkBufferUsageFlags ADDRESSED = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT;
    uint64_t px = (uint64_t)desc->width * desc->height;
    bool ray = out->mode->ray_pipeline;
    out->stage = ray ? VK_PIPELINE_STAGE_2_RAY_TRACING_SHADER_BIT_KHR : VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
    pn_result r = pn_gpu_compute_create(dev,
                                        &(pn_gpu_compute_desc){.spirv = NULL, // pn_shadow_pass_prepare's
                                                               .spirv_size = out->spirv_size,
                                                               .bindings = bindings,
                                                               .binding_count = PN_SHADOW_BINDING_COUNT + tlas,
                                                               .push_size = sizeof(pn_shadow_chunk),
                                                               .spec = &spec,
                                                               .stages = ray ? PN_GPU_RAY_STAGES : 0},
                                        &out->compute);
    // The any-hit shader only where masked casters can call it (their geometry alone is not opaque).
    pn_gpu_ray_shaders shaders = {
        pn_spv_shadow_rtpipeline_rgen, pn_spv_shadow_rtpipeline_rmiss, pn_spv_shadow_rtpipeline_rchit,
        alpha_masks ? pn_spv_shadow_rtpipeline_rahit : NULL, sizeof pn_spv_shadow_rtpipeline_rgen,
        sizeof pn_spv_shadow_rtpipeline_rmiss, sizeof pn_spv_shadow_rtpipeline_rchit,
        sizeof pn_spv_shadow_rtpipeline_rahit};
    if (r == PN_OK && ray)
        r = pn_gpu_ray_pipeline_create(dev, &out->compute, &shaders, &spec, &out->ray);
    if (r == PN_OK)
        r = pn_gpu_buffer_create(dev, "shadow pass's parameters", sizeof(pn_shadow_params), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, PN_GPU_HOST_UPLOAD,
                                 &out->params);
    out->tiles_across = (desc->width + PN_WORKGROUP - 1) / PN_WORKGROUP;
    out->tile_total = out->tiles_across * ((desc->height + PN_WORKGROUP - 1) / PN_WORKGROUP);
    if (r == PN_OK)
        r = pn_gpu_buffer_create(dev, "shadow pass's pixel lists", 2 * PN_PIXEL_LIST_WORDS(out->tile_total) * 4,
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                                     VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                 PN_GPU_DEVICE_LOCAL, &out->lists);
    if (r == PN_OK)
        r = pn_gpu_buffer_create(dev, "shadow pass's status", sizeof(uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, PN_GPU_HOST_READBACK,
                                 &out->status);
    if (r == PN_OK && desc->count_work)
        r = pn_gpu_buffer_create(dev, "shadow pass's work counts", px * 16, ADDRESSED, PN_GPU_HOST_READBACK, &out->work);
    if (r == PN_OK && desc->dump_rays) {
        r = pn_gpu_buffer_create(dev, "ray dump", px * (1 + desc->spp) * 16, ADDRESSED, PN_GPU_HOST_READBACK, &out->ray_dump);
        if (r == PN_OK)
            memset(out->ray_dump.mapped, 0, px * (1 + desc->spp) * 16);
    }
    const char *names[2] = {"shadow pass's adaptive image", "shadow pass's ray count image"};
    pn_gpu_image *extra[2] = {&out->adapt, &out->rays};
    for (int i = 0; i < 2 && r == PN_OK; i++)
        r = pn_gpu_image_create(dev,
                                &(pn_gpu_image_desc){.name = names[i],
                                                     .format = VK_FORMAT_R32G32B32A32_UINT,
                                                     .width = desc->width,
                                                     .height = desc->height,
                                                     .usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT},
                                extra[i]);
    if (r == PN_OK)
        r = pn_gpu_image_create(dev,
                                &(pn_gpu_image_desc){.name = "shadow pass's count image",
                                                     .format = VK_FORMAT_R32G32B32A32_UINT,
                                                     .width = desc->width,
                                                     .height = desc->height,
                                                     // read back with the frame (pn_frame_images.counts)
                                                     .usage = VK_IMAGE_USAGE_STORAGE_BIT |
                                                              VK_IMAGE_USAGE_TRANSFER_SRC_BIT},
                                &out->counts);
    if (r == PN_OK)
        r = pn_gpu_image_create(dev,
                                &(pn_gpu_image_desc){.name = "shadow pass's blocker image",
                                                     .format = VK_FORMAT_R32G32_SFLOAT,
                                                     .width = desc->width,
                                                     .height = desc->height,
                                                     // read back with keep_window (pn_frame_images.blockers)
                                                     .usage = VK_IMAGE_USAGE_STORAGE_BIT |
                                                              VK_IMAGE_USAGE_TRANSFER_SRC_BIT},
                                &out->blockers);
    if (r != PN_OK) {
        pn_shadow_pass_destroy(dev, out);
        return r;
    }
    pn_gpu_compute *c = &out->compute;
    pn_gpu_compute_write_image(dev, c, PN_SHADOW_BINDING_P, p->view);
    pn_gpu_compute_write_image(dev, c, PN_SHADOW_BINDING_N, n->view);
    pn_gpu_compute_write_image(dev, c, PN_SHADOW_BINDING_V, v->view);
    pn_gpu_compute_write_uniform(dev, c, PN_SHADOW_BINDING_PARAMS, out->params.buffer);
    pn_gpu_compute_write_image(dev, c, PN_SHADOW_BINDING_COUNTS, out->counts.view);
    pn_gpu_compute_write_buffer(dev, c, PN_SHADOW_BINDING_STATUS, out->status.buffer);
    pn_gpu_compute_write_image(dev, c, PN_SHADOW_BINDING_ADAPT, out->adapt.view);
    pn_gpu_compute_write_image(dev, c, PN_SHADOW_BINDING_RAYS, out->rays.view);
    pn_gpu_compute_write_buffer(dev, c, PN_SHADOW_BINDING_LISTS, out->lists.buffer);
    pn_gpu_compute_write_image(dev, c, PN_SHADOW_BINDING_BLOCKERS, out->blockers.view);
    pn_shadow_pass_set_lineage(dev, out, NULL);
    if (tlas)
        pn_gpu_compute_write_tlas(dev, c, PN_SHADOW_BINDING_TLAS, desc->tlas->tlas);
    return PN_OK;
}

void pn_shadow_pass_set_lineage(pn_gpu_device *dev, pn_shadow_pass *s, const pn_gpu_image *lineage)
{
    // Without a history the binding still needs an image of its format; the shaders read it only
    // under the frame window (frame_side), which only a history sets.
    VkImageView view = lineage ? lineage->view : s->rays.view;
    if (view != s->lineage_view)
        pn_gpu_compute_write_image(dev, &s->compute, PN_SHADOW_BINDING_LINEAGE, view);
    s->lineage_view = view;
}

void pn_shadow_pass_destroy(pn_gpu_device *dev, pn_shadow_pass *s)
{
    // by_rays and by_samples are the device's pipelines (pn_gpu_compute_pipeline).
    pn_gpu_ray_pipeline_destroy(dev, &s->ray);
    pn_gpu_compute_destroy(dev, &s->compute);
    pn_gpu_image_destroy(dev, &s->counts);
    pn_gpu_image_destroy(dev, &s->adapt);
    pn_gpu_image_destroy(dev, &s->rays);
    pn_gpu_image_destroy(dev, &s->blockers);
    pn_gpu_buffer_destroy(dev, &s->params);
    pn_gpu_buffer_destroy(dev, &s->status);
    pn_gpu_buffer_destroy(dev, &s->lists);
    pn_gpu_buffer_destroy(dev, &s->work);
    pn_gpu_buffer_destroy(dev, &s->ray_dump);
    memset(s, 0, sizeof *s);
}

void pn_shadow_pass_update(pn_shadow_pass *s, const pn_renderer_desc *desc, const pn_light_gpu *lights,
                           uint32_t light_count, float pixel_angle)
{
    pn_shadow_params sp = {0};
    if (desc->pools)
        sp.tree = desc->pools->info;
    if (desc->objects) {
        sp.object_count = desc->objects->count;
        sp.objects = desc->objects->table.address;
        sp.top = desc->objects->top.address;
        sp.top_ids = desc->objects->top_ids.address;
    }
    for (uint32_t i = 0; i < light_count && i < PN_MAX_LIGHTS; i++)
        sp.lights[i] = lights[i];
    sp.spp = desc->spp ? desc->spp : 1;
    sp.light_count = light_count;
    sp.split = (uint32_t)desc->split;
    sp.budget = pn_shadow_budget(sp.spp, light_count); // at least the light count: budget_rays relies on it
    // Adaptive under a filter: the grid of the first round, the tile's interleaved strata (light_sample).
    pn_sample_grid(desc->spp_min && desc->filter != PN_FILTER_NONE ? desc->spp_min : sp.spp, &sp.grid_u, &sp.grid_v);
    sp.sampler_kind = (uint32_t)desc->sampler;
    sp.seed = desc->seed;
    sp.leaf_size = (float)desc->leaf_size;
    sp.scene_mag = s->scene_mag;
    sp.project_budget = pn_project_budget();
    sp.canary = 2; // llvmpipe: the loop-budget canary's iteration count (shadow_common.glsl)
    // Exact's packet walk shares a block of pixels (shadow_exact.comp) until the loop budget once ran
    // out (pn_shadow_pass_end_frame).
    sp.block_walk = s->block_walk_off ? 0 : 1;
    sp.pixel_angle = pixel_angle;
    sp.refine_narrow = desc->filter == PN_FILTER_PENUMBRA;
    sp.unreached_v = desc->unreached_zero ? 0.0f : 1.0f;
    sp.frame = s->frame;
    sp.frame_side = s->frame_side;
    sp.frame_part = s->frame_part;
    if (desc->exact) {
        const pn_gpu_exact_pools *e = desc->exact;
        sp.tris = e->tris.address;
        sp.bvh = e->bvh_nodes.address;
        sp.bvh_tris = e->bvh_tris.address;
        sp.cand_offset = e->cand_offset.address;
        sp.cand_tris = e->cand_tris.address;
        sp.alpha_bits = e->alpha_bits.address;
    }
    if (desc->tlas) // rayquery, rtpipeline: its masked geometry's triangle ids (0 for an opaque scene)
        sp.masked_tris = desc->tlas->masked_tris.address;
    sp.dump = s->ray_dump.address;
    sp.cand_first = desc->cand_first_node;
    sp.dump_rays = desc->dump_rays;
    sp.work = s->work.address;
    sp.spp_min = s->spp_min = desc->spp_min;
    s->uniform = desc->spp_min == 0 && desc->split != PN_SPLIT_BUDGET;
    sp.pixel_error = desc->pixel_error;
    sp.tiles_across = s->tiles_across;
    sp.tile_total = s->tile_total;
    // Interleaved sampling only where a filter gathers the tile's samples again: every pixel's
    // samples under uniform sampling, the first round's under adaptive (light_sample).
    bool tiled = desc->filter != PN_FILTER_NONE;
    sp.tile_w = tiled ? pn_filter_tile(desc->tile_w) : 1;
    sp.tile_h = tiled ? pn_filter_tile(desc->tile_h) : 1;
    memcpy(s->params.mapped, &sp, sizeof sp);
}

// k with 2^k the smallest power of two >= rays.
static uint32_t rays_size(uint32_t rays)
{
    uint32_t k = 0;
    while ((1u << k) < rays)
        k++;
    return k;
}

// Whether a light of `samples` samples per pixel takes the projection walk this frame: as asked
// (--traversal project), or under auto for exact's uniform frames of many samples.
static bool frame_project(const pn_shadow_pass *s, uint32_t samples)
{
    return s->project || (s->auto_project && pn_traversal_resolve(PN_SHADOW_EXACT, PN_TRAVERSAL_AUTO, samples,
                                                                  s->spp_min) == PN_TRAVERSAL_PROJECT);
}

// Makes *slot (when not made yet): the pass's shader, or the projection's (project), with spec_data
// but for the packet rays and the projection's samples where not 0, and this frame's uniform flag.
static pn_result make(pn_gpu_device *dev, pn_shadow_pass *s, bool project, uint32_t rays, uint32_t samples,
                      VkPipeline *slot)
{
    if (*slot)
        return PN_OK;
    int32_t data[7];
    memcpy(data, s->spec_data, sizeof data);
    if (project)
        data[0] = PN_TRAVERSAL_PROJECT_ID;
    if (rays)
        data[3] = (int32_t)rays;
    if (samples)
        data[5] = (int32_t)samples;
    data[6] = s->uniform ? 1 : 0;
    VkSpecializationInfo spec = {.mapEntryCount = 7, .pMapEntries = SPEC_ENTRIES, .dataSize = sizeof data, .pData = data};
    s->pipelines_made++;
    const uint32_t *spirv = project ? pn_spv_shadow_project_comp : s->spirv;
    size_t size = project ? sizeof pn_spv_shadow_project_comp : s->spirv_size;
    return pn_gpu_compute_pipeline(dev, &s->compute, spirv, size, &spec, slot);
}

pn_result pn_shadow_pass_prepare(pn_gpu_device *dev, pn_shadow_pass *s, uint32_t samples)
{
    if (s->ray.pipeline)
        return PN_OK; // made with the pass
    int u = s->uniform ? 1 : 0;
    if (frame_project(s, samples)) {
        // The projection traversal's per-sample arrays sized to the dispatch's samples: private
        // arrays of 1024 samples cost a frame of 16 spp a third more (default scene, lavapipe).
        // With --traversal project the pass's own pipeline holds the most.
        uint32_t k = rays_size(samples < s->project_chunk ? samples : s->project_chunk);
        k = k < 5 ? 0 : k - 5;
        if (s->project && (32u << k) >= PN_PROJECT_MAX_SAMPLES)
            return make(dev, s, true, 0, 0, &s->own[u]);
        return make(dev, s, true, 0, 32u << k, &s->by_samples[u][k]);
    }
    if (!s->sized_rays)
        return make(dev, s, false, 0, 0, &s->own[u]);
    // The dispatches' rays per pixel: the chunk's, or fewer in the frame's first (or only) round.
    // The pipeline for the most rays (own) is made only for the frames that take it: a frame of
    // 4 spp never runs it, and it is the largest of the shadow pipelines to create (141 ms on
    // lavapipe with Mesa's cache off, the default render's).
    uint32_t rounds[2] = {pn_shadow_adaptive(s, samples) ? s->spp_min : samples, samples};
    for (int i = 0; i < 2; i++) {
        uint32_t k = rays_size(rounds[i] < s->chunk ? rounds[i] : s->chunk);
        bool most = (1u << k) >= PN_MAX_CHUNK;
        PN_TRY(make(dev, s, false, most ? 0 : 1u << k, 0, most ? &s->own[u] : &s->by_rays[u][k]));
    }
    return PN_OK;
}

// The pipeline for a dispatch of at most `rays` rays per pixel: the smallest made that holds them.
static VkPipeline pipeline_for(const pn_shadow_pass *s, uint32_t rays, bool project)
{
    int u = s->uniform ? 1 : 0;
    for (uint32_t k = rays_size(rays), j = k < 5 ? 0 : k - 5; project && j < PN_PROJECT_SIZES; j++)
        if (s->by_samples[u][j])
            return s->by_samples[u][j];
    for (uint32_t k = rays_size(rays); s->sized_rays && (1u << k) < PN_MAX_CHUNK; k++)
        if (s->by_rays[u][k])
            return s->by_rays[u][k];
    return s->own[u];
}

// Each dispatch reads the counts the previous one wrote (see ShadowChunk in interface.h), and an
// indirect one its group count.
static void between_dispatches(VkCommandBuffer cmd, const pn_shadow_pass *s)
{
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = s->stage,
                                           .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                           .dstStageMask = s->stage | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                                           .dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                                                            VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                                                            VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT},
                       0, NULL);
}

// A dispatch of the shadow shader: over every tile of the image (ch.list_in 0), or over the pixels
// of list ch.list_in - 1, as many groups as the list fills.
static void dispatch(VkCommandBuffer cmd, const pn_shadow_pass *s, const pn_shadow_chunk *ch, bool project)
{
    if (s->ray.pipeline) {
        // One ray generation invocation per pixel of the tiles (its launch id), or per place in
        // the list: the list's length is known only on the device, so the launch covers the
        // longest (every pixel) and the places past its end return at once (shadow_list_pixel).
        uint32_t side = PN_WORKGROUP, groups_y = s->tile_total / s->tiles_across;
        // The list's places run along the rows of a launch as wide as the image's tiles' pixels,
        // one row per row of tiles (a launch's width is bounded like a compute dispatch's).
        uint32_t w = s->one_tile ? 1 : s->tiles_across, h = s->one_tile ? 1 : groups_y;
        if (ch->list_in == 0)
            pn_gpu_ray_trace(cmd, &s->compute, &s->ray, sizeof *ch, ch, w * side, h * side);
        else
            pn_gpu_ray_trace(cmd, &s->compute, &s->ray, sizeof *ch, ch, w * side * side, h);
        return;
    }
    // A uniform frame's pipeline has no rounds, lists or decisions (shadow_common.glsl: UNIFORM).
    assert(!s->uniform || (ch->list_in == 0 && ch->decide == 0));
    pn_gpu_compute c = s->compute;
    c.pipeline = pipeline_for(s, ch->sample_end - ch->sample_begin, project);
    assert(c.pipeline); // pn_shadow_pass_prepare's
    if (ch->list_in == 0) {
        uint32_t gy = s->tile_total / s->tiles_across;
        pn_gpu_compute_dispatch(cmd, &c, sizeof *ch, ch, s->one_tile ? 1 : s->tiles_across, s->one_tile ? 1 : gy, 1);
        return;
    }
    VkDeviceSize offset = (VkDeviceSize)(ch->list_in - 1) * PN_PIXEL_LIST_WORDS(s->tile_total) * 4;
    pn_gpu_compute_dispatch_indirect(cmd, &c, sizeof *ch, ch, s->lists.buffer, offset);
}

// Samples [begin, end) of every pixel in chunks; adaptively (list_in > 0), over the pixels of list
// list_in - 1, each tracing the part of each chunk between its samples and its target. The chunks
// start at multiples of the chunk size, so that a round's range [n, 2n) falls in as few as it can:
// each costs a pixel a walk of the tree.
static void record_samples(VkCommandBuffer cmd, const pn_shadow_pass *s, uint32_t begin, uint32_t end,
                           uint32_t list_in, uint32_t light, bool project)
{
    uint32_t chunk = project ? s->project_chunk : s->chunk;
    if (list_in)
        begin -= begin % chunk;
    for (uint32_t b = begin; b < end; b += chunk) {
        uint32_t e = end - b > chunk ? b + chunk : end;
        pn_shadow_chunk ch = {.sample_begin = b, .sample_end = e, .first = b == 0 && !list_in, .last = e == end,
                              .light = light, .list_in = list_in};
        if (b > begin)
            between_dispatches(cmd, s);
        dispatch(cmd, s, &ch, project);
    }
}

// Empties pixel list k for a decision to fill, after every earlier use of the lists.
static void reset_list(VkCommandBuffer cmd, const pn_shadow_pass *s, uint32_t k)
{
    const VkPipelineStageFlags2 STAGE = s->stage, COPY = VK_PIPELINE_STAGE_2_COPY_BIT;
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = STAGE | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                                           .srcAccessMask = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                           .dstStageMask = COPY,
                                           .dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT},
                       0, NULL);
    const uint32_t empty[4] = {0, 1, 1, 0}; // VkDispatchIndirectCommand (0, 1, 1) and no pixels
    vkCmdUpdateBuffer(cmd, s->lists.buffer, k * PN_PIXEL_LIST_WORDS(s->tile_total) * 4, sizeof empty, empty);
    pn_gpu_cmd_barrier(cmd,
                       &(VkMemoryBarrier2){.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                                           .srcStageMask = COPY,
                                           .srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                           .dstStageMask = STAGE,
                                           .dstAccessMask = VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                                                            VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT},
                       0, NULL);
}

// The passes around the shadow pass order their work against the compute stage. A ray-tracing
// pass bridges to it: before its first launch, everything earlier (the G-buffer's P and N, V's
// discard, the previous light's reads) before its shaders; after its last, its writes before
// compute (the filter, the shading), from which the renderer's own barriers chain on.
static void bridge(VkCommandBuffer cmd, const pn_shadow_pass *s, bool begin)
{
    if (s->stage == VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT)
        return;
    const VkAccessFlags2 RW = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
    VkMemoryBarrier2 b = {.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER_2,
                          .srcStageMask = begin ? VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT : s->stage,
                          .srcAccessMask = begin ? VK_ACCESS_2_MEMORY_WRITE_BIT : VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                          .dstStageMask = begin ? s->stage : VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                          .dstAccessMask = RW | (begin ? VK_ACCESS_2_UNIFORM_READ_BIT : 0)};
    pn_gpu_cmd_barrier(cmd, &b, 0, NULL);
}

static void record(VkCommandBuffer cmd, const pn_shadow_pass *s, uint32_t samples, uint32_t light);

void pn_shadow_pass_record(VkCommandBuffer cmd, const pn_shadow_pass *s, uint32_t samples, uint32_t light)
{
    bridge(cmd, s, true);
    record(cmd, s, samples, light);
    bridge(cmd, s, false);
}

static void record(VkCommandBuffer cmd, const pn_shadow_pass *s, uint32_t samples, uint32_t light)
{
    const VkPipelineStageFlags2 STAGE = s->stage;
    uint32_t spp = s->mode->traces ? samples : 1;
    bool resume = s->resume_from != 0; // the renderer sets it only for an adaptive frame with more samples
    // The counts and the adaptive images are rewritten from the first chunk on: discard what the
    // previous frame (or light) left; resumed, keep it, after all of that frame's work on them.
    VkImageMemoryBarrier2 fresh[4];
    const pn_gpu_image *images[4] = {&s->counts, &s->adapt, &s->rays, &s->blockers};
    for (int i = 0; i < 4; i++)
        fresh[i] = pn_gpu_image_barrier(images[i], VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                                        STAGE, VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                                        resume ? VK_IMAGE_LAYOUT_GENERAL : VK_IMAGE_LAYOUT_UNDEFINED,
                                        VK_IMAGE_LAYOUT_GENERAL);
    pn_gpu_cmd_barrier(cmd, NULL, 4, fresh);
    if (!pn_shadow_adaptive(s, spp)) {
        record_samples(cmd, s, 0, spp, 0, light, frame_project(s, spp));
        return;
    }
    // Adaptive: the first round over the image, then after each round a decision over its pixels,
    // which sets each pixel's target and lists the pixels that go on, and the next round over that
    // list, from MIN up to MAX (each pixel traces its own part); the two lists alternate. A target
    // at least doubles, so after log2(MAX / MIN) rounds every pixel is done; the last decision only
    // gives the final estimates. Resumed, the first round is the previous frame's and the rounds
    // that follow it are only those from its most samples to this frame's: a pixel that stopped
    // early there doubles once per round from where it stopped. The first decision runs over the
    // whole image (list_in 0) and writes every pixel's V from its counts (.first), as V is rewritten
    // every frame (renderer.c discards it) and a pixel that goes on no more traces nothing.
    if (!resume)
        record_samples(cmd, s, 0, s->spp_min, 0, light, false);
    uint32_t rounds = 0;
    for (uint32_t n = resume ? s->resume_from : s->spp_min; n < spp; n *= 2)
        rounds++;
    uint32_t list_in = 0, out = 0;
    for (uint32_t decision = 1;; decision++) {
        reset_list(cmd, s, out);
        between_dispatches(cmd, s);
        // The last decision only reports (.last): a pixel's rays are the samples it took.
        dispatch(cmd, s,
                 &(pn_shadow_chunk){.light = light, .decide = resume ? 2 : 1, .list_in = list_in, .list_out = out,
                                    .first = resume && decision == 1, .last = decision > rounds},
                 false);
        if (decision > rounds)
            break;
        between_dispatches(cmd, s);
        record_samples(cmd, s, s->spp_min, spp, 1 + out, light, false);
        list_in = 1 + out;
        out ^= 1;
    }
}

void pn_shadow_pass_begin_frame(pn_shadow_pass *s) { *(volatile uint32_t *)s->status.mapped = 0; }

pn_result pn_shadow_pass_end_frame(pn_shadow_pass *s, bool *retry)
{
    *retry = false;
    if (*(volatile uint32_t *)s->status.mapped == 0)
        return PN_OK;
    // llvmpipe: a dispatch ran out of the loop budget: its counts are incomplete, so the frame is
    // rendered again with half the samples per dispatch. Only llvmpipe has such a budget
    // (pn_gpu_device_loop_budget); elsewhere the canary never fires, and if it did the frame would
    // be wrong, so it is an error there.
    if (!s->loop_budget || (s->chunk == 1 && s->project_chunk == 1)) {
        pn_error("a single shadow ray's traversal exceeds the device's shader loop budget; try a smaller N or d");
        return PN_ERR_UNSUPPORTED;
    }
    // Both walks' chunks: the frame may have taken either (the projection's for its many samples).
    s->chunk = s->chunk > 1 ? s->chunk / 2 : 1;
    s->project_chunk = s->project_chunk > 1 ? s->project_chunk / 2 : 1;
    // llvmpipe (Mesa 22.3): a block of pixels walks their rays together (shadow_exact.comp), and
    // halving the chunk shrinks a block's walk too little (at one ray a pixel it still walks 8
    // pixels' rays): from here on each pixel walks alone, as the halving assumes. The parameters
    // are host memory, read by the frame recorded again.
    s->block_walk_off = true;
    ((pn_shadow_params *)s->params.mapped)->block_walk = 0;
    pn_info("shadow pass cut short by the shader loop budget: retrying with %u samples per dispatch", s->chunk);
    *retry = true;
    return PN_OK;
}

void pn_shadow_pass_set_frame(pn_shadow_pass *p, uint32_t history_frames, uint32_t frame, uint32_t tile_pixels)
{
    uint32_t side = 1;
    while (side < 64 && side * side < history_frames)
        side *= 2;
    uint32_t f = frame + (tile_pixels % 2 == 0 ? frame / tile_pixels : 0);
    p->frame = frame, p->frame_side = history_frames ? side : 0;
    p->frame_part = f & (side * side - 1);
}
