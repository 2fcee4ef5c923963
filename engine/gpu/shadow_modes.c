// The shadow mode table: each mode's shader, specialisation and needs, and what a device can run.
#include "gpu/shadow_modes.h"

#include <stdio.h>
#include <string.h>

#include "accel/alpha.h"
#include "core/log.h"
#include "gpu/frame.h"
#include "shadow_exact_comp.h"
#include "shadow_linespace_comp.h"
#include "shadow_none_comp.h"
#include "shadow_rayquery_comp.h"

#define SHADER(name) .spirv = pn_spv_##name, .spirv_size = sizeof pn_spv_##name

// In enum order; the cheapest first among those that trace, which is the order --quality auto
// tries them in after exact (shadow/quality.c: climb_order). auto_trees counts the configurations
// --quality auto tries per mode: the first that many standard trees (apps/quality.c), or 1 for a
// mode without a tree; 0 never tries it.
static const pn_shadow_mode_info MODES[PN_SHADOW_MODE_COUNT] = {
    [PN_SHADOW_NONE] = {.name = "none", .help = "unshadowed (V = 1)", SHADER(shadow_none_comp)},
    [PN_SHADOW_LINESPACE] = {.name = "linespace",
                             .help = "line-space visibility, the paper's method",
                             SHADER(shadow_linespace_comp),
                             .variant = PN_VARIANT_LINESPACE,
                             .needs = {.tree = true, .exact_pools_if_masked = true},
                             .traces = true,
                             .objects = true,
                             .alpha_masks = true,
                             .auto_trees = 4},
    [PN_SHADOW_LEAF] = {.name = "ls-leaf",
                        .help = "line spaces down to the leaves: a filled leaf a ray crosses blocks it",
                        SHADER(shadow_linespace_comp),
                        .variant = PN_VARIANT_LEAF,
                        .needs = {.tree = true, .exact_pools_if_masked = true},
                        .traces = true,
                        .alpha_masks = true,
                        .auto_trees = 1},
    [PN_SHADOW_PLANE] = {.name = "ls-plane",
                         .help = "line spaces down to the leaves: a ray crossing a filled leaf's plane slab is blocked",
                         SHADER(shadow_linespace_comp),
                         .variant = PN_VARIANT_PLANE,
                         .needs = {.tree = true, .planes = true, .exact_pools_if_masked = true},
                         .traces = true,
                         .alpha_masks = true,
                         .auto_trees = 1},
    [PN_SHADOW_HYBRID] = {.name = "hybrid",
                          .help = "line spaces, triangles tested exactly where rays start and end",
                          SHADER(shadow_linespace_comp),
                          .variant = PN_VARIANT_HYBRID,
                          .needs = {.tree = true, .candidates = true, .exact_pools = true},
                          .traces = true,
                          .alpha_masks = true,
                          .auto_trees = 4},
    [PN_SHADOW_EXACT_LS] = {.name = "exact-ls",
                            .help = "line spaces skip empty space, set shafts test triangles (exact)",
                            SHADER(shadow_linespace_comp),
                            .variant = PN_VARIANT_EXACT_LS,
                            .needs = {.tree = true, .candidates = true, .exact_pools = true},
                            .traces = true,
                            .alpha_masks = true,
                            .exact = true,
                            .auto_trees = 1},
    [PN_SHADOW_EXACT] = {.name = "exact",
                         .help = "BVH and watertight triangle tests (the ground truth; default)",
                         SHADER(shadow_exact_comp),
                         .needs = {.bvh = true, .exact_pools = true},
                         .traces = true,
                         .alpha_masks = true,
                         .exact = true,
                         .packet_rays = true,
                         .auto_trees = 1},
    // Alpha-masked casters in a geometry of their own, not opaque: the shader tests each hit's
    // texel in the triangle pool (gpu/tlas.h); opaque scenes build no pool.
    [PN_SHADOW_RAYQUERY] = {.name = "rayquery",
                            .help = "the device's ray queries (VK_KHR_ray_query; Mesa 25 lavapipe, RTX, RDNA2+, Arc)",
                            SHADER(shadow_rayquery_comp),
                            .needs = {.tlas = true, .exact_pools_if_masked = true},
                            .traces = true,
                            .alpha_masks = true,
                            .exact = true,
                            .ray_query = true,
                            .auto_trees = 1},
    // The same structure through a ray generation shader per pixel; masked casters' texels in an
    // any-hit shader. The GPU vendor's own traversal (also where a driver has no ray queries): the peer
    // a GPU's exact must beat, as Embree is on a CPU.
    [PN_SHADOW_RTPIPELINE] = {.name = "rtpipeline",
                              .help = "the device's ray-tracing pipeline (VK_KHR_ray_tracing_pipeline; Mesa 25 lavapipe, "
                                      "NVIDIA, RDNA2+, Arc)",
                              .needs = {.tlas = true, .exact_pools_if_masked = true},
                              .traces = true,
                              .alpha_masks = true,
                              .exact = true,
                              .ray_pipeline = true,
                              .auto_trees = 1},
};

const char *const pn_traversal_names[] = {[PN_TRAVERSAL_RAY] = "ray", [PN_TRAVERSAL_PACKET] = "packet",
                                          [PN_TRAVERSAL_AUTO] = "auto",
                                          [PN_TRAVERSAL_PROJECT] = "project", NULL};

pn_traversal pn_traversal_fit(pn_shadow_mode mode, uint32_t spp_min, pn_traversal t)
{
    return t == PN_TRAVERSAL_PROJECT && (mode != PN_SHADOW_EXACT || spp_min) ? PN_TRAVERSAL_AUTO : t;
}

pn_traversal pn_traversal_resolve(pn_shadow_mode mode, pn_traversal t, uint32_t samples, uint32_t spp_min)
{
    if (t != PN_TRAVERSAL_AUTO)
        return t;
    if (mode != PN_SHADOW_EXACT)
        return PN_TRAVERSAL_RAY;
    return !spp_min && samples >= PN_PROJECT_AUTO_SAMPLES ? PN_TRAVERSAL_PROJECT : PN_TRAVERSAL_PACKET;
}
const char *const pn_filter_names[] = {[PN_FILTER_NONE] = "none", [PN_FILTER_INTERLEAVED] = "interleaved",
                                       [PN_FILTER_PENUMBRA] = "penumbra", NULL};
const char *const pn_split_names[] = {[PN_SPLIT_EVEN] = "even", [PN_SPLIT_BUDGET] = "budget", NULL};
const char *const pn_sampler_names[] = {[PN_SAMPLER_STRATIFIED] = "stratified", [PN_SAMPLER_GRID] = "grid", NULL};

const pn_shadow_mode_info *pn_shadow_mode_get(pn_shadow_mode m)
{
    return (int)m >= 0 && m < PN_SHADOW_MODE_COUNT ? &MODES[m] : NULL;
}

int pn_shadow_mode_parse(const char *opt, const char *name)
{
    char list[256] = "";
    for (int i = 0; i < PN_SHADOW_MODE_COUNT; i++) {
        if (strcmp(name, MODES[i].name) == 0)
            return i;
        strncat(list, i ? "|" : "", sizeof list - strlen(list) - 1);
        strncat(list, MODES[i].name, sizeof list - strlen(list) - 1);
    }
    pn_error("%s: expected one of %s, got '%s'", opt, list, name);
    return -1;
}

bool pn_shadow_mode_takes_scene(pn_shadow_mode m, const pn_scene *scene, char *why, size_t n)
{
    const pn_shadow_mode_info *mode = pn_shadow_mode_get(m);
    uint64_t masked = mode && mode->traces && !mode->alpha_masks ? pn_alpha_masked_triangles(scene) : 0;
    if (masked && why) {
        char takers[128] = ""; // the modes that test texels, from the table
        for (int i = 0; i < PN_SHADOW_MODE_COUNT; i++)
            if (MODES[i].alpha_masks)
                snprintf(takers + strlen(takers), sizeof takers - strlen(takers), "%s%s", takers[0] ? ", " : "",
                         MODES[i].name);
        snprintf(why, n,
                 "%s: %llu alpha-masked triangles: mode %s would shadow their cut-out texels (it answers rays from "
                 "line spaces, a cell holding one being filled); %s test the texels",
                 scene->name, (unsigned long long)masked, mode->name, takers);
    }
    return masked == 0;
}

bool pn_shadow_mode_available(const pn_gpu_device *dev, pn_shadow_mode m, const char **why)
{
    const pn_shadow_mode_info *info = pn_shadow_mode_get(m);
    const char *lack = !info                                    ? "no such mode"
                       : info->ray_query && !dev->ray_query       ? "ray queries (VK_KHR_ray_query)"
                       : info->ray_pipeline && !dev->ray_pipeline ? "ray-tracing pipelines (VK_KHR_ray_tracing_pipeline)"
                                                                  : NULL;
    if (why)
        *why = lack;
    return lack == NULL;
}

pn_shadow_needs pn_shadow_needs_for_scene(pn_shadow_needs needs, const pn_scene *scene)
{
    needs.exact_pools |= needs.exact_pools_if_masked && pn_alpha_masked_triangles(scene) > 0;
    return needs;
}

pn_shadow_needs pn_shadow_needs_all(const pn_gpu_device *dev)
{
    pn_shadow_needs all = {0};
    for (int i = 0; i < PN_SHADOW_MODE_COUNT; i++) {
        if (!pn_shadow_mode_available(dev, (pn_shadow_mode)i, NULL))
            continue;
        all.tree |= MODES[i].needs.tree;
        all.candidates |= MODES[i].needs.candidates;
        all.bvh |= MODES[i].needs.bvh;
        all.exact_pools |= MODES[i].needs.exact_pools;
        all.tlas |= MODES[i].needs.tlas;
        all.exact_pools_if_masked |= MODES[i].needs.exact_pools_if_masked;
        all.planes |= MODES[i].needs.planes;
    }
    return all;
}
