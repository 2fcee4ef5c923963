#include "apps/setup.h"

#include <string.h>

#include "core/log.h"

static bool uses_tree(pn_shadow_mode m) { return m >= PN_SHADOW_LINESPACE && m <= PN_SHADOW_EXACT_LS; }

pn_result pn_setup_create(pn_gpu_device *dev, const pn_scene *scene, const pn_light *light, const pn_setup_desc *desc,
                          pn_setup *s)
{
    memset(s, 0, sizeof *s);
    pn_renderer_desc rd = desc->frame;
    pn_result r = PN_OK;
    if (uses_tree(rd.mode)) {
        float corners[4][3];
        pn_light_corners(light, corners);
        pn_ntree_desc td = {.n = desc->tree_n,
                            .d = desc->tree_d,
                            .max_bytes = desc->max_bytes ? desc->max_bytes : pn_gpu_device_heap(dev) / 2,
                            .cull_light = (const float(*)[3])corners,
                            .keep_candidates = rd.mode != PN_SHADOW_LINESPACE};
        r = pn_ntree_build(scene, &td, &s->tree);
        if (r == PN_OK) {
            s->build_ms = s->tree.build_ms;
            rd.leaf_size = pn_ntree_cell_size(&s->tree, s->tree.d);
            rd.cand_first_node = s->tree.cand_first_node;
            r = pn_pools_pack(&s->tree, &s->pools);
        }
        if (r == PN_OK)
            r = pn_gpu_pools_create(dev, &s->pools, &s->gpu_pools);
        s->pool_bytes = s->pools.bytes;
        rd.pools = &s->gpu_pools;
    }
    if (r == PN_OK && rd.mode == PN_SHADOW_EXACT) {
        r = pn_bvh_build(scene, &s->bvh);
        if (r != PN_OK)
            pn_error("%s: out of memory building the BVH", scene->name);
        s->build_ms = s->bvh.build_ms;
    }
    if (r == PN_OK && rd.mode >= PN_SHADOW_HYBRID) {
        r = pn_gpu_exact_pools_create(dev, scene, rd.mode == PN_SHADOW_EXACT ? &s->bvh : NULL, &s->tree, &s->exact);
        s->exact_bytes = s->exact.bytes;
        rd.exact = &s->exact;
    }
    if (r == PN_OK)
        r = pn_renderer_create(dev, scene, &rd, &s->renderer);
    if (r != PN_OK)
        pn_setup_destroy(dev, s);
    return r;
}

void pn_setup_destroy(pn_gpu_device *dev, pn_setup *s)
{
    pn_renderer_destroy(&s->renderer);
    pn_gpu_exact_pools_destroy(dev, &s->exact);
    pn_bvh_destroy(&s->bvh);
    pn_gpu_pools_destroy(dev, &s->gpu_pools);
    pn_pools_destroy(&s->pools);
    pn_ntree_destroy(&s->tree);
    memset(s, 0, sizeof *s);
}
