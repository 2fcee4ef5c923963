// What the bench's matrix, --lights and --max-error share: timed frames, a growing array, a tree's
// label and a configuration's set-up (bench.h).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/bench/bench.h"
#include "core/log.h"
#include "core/timer.h"

pn_result pn_bench_time_frames(const bench_opts *o, pn_renderer *r, const pn_camera *cam, const pn_light *lights,
                               uint32_t light_count, bench_row *row)
{
    double g[1000], s[1000], f[1000], h[1000];
    pn_frame_times t;
    row->compile_ms = 0;
    for (int i = 0; i < o->warmup; i++) {
        if (pn_renderer_render_lights(r, cam, lights, light_count, &t) != PN_OK)
            return PN_ERR_VULKAN;
        row->compile_ms += t.compile_ms;
    }
    for (int i = 0; i < o->repeat; i++) {
        if (pn_renderer_render_lights(r, cam, lights, light_count, &t) != PN_OK)
            return PN_ERR_VULKAN;
        row->compile_ms += t.compile_ms;
        g[i] = t.gbuffer_ms, s[i] = t.shadow_ms, f[i] = t.filter_ms, h[i] = t.shade_ms;
    }
    row->gbuffer_ms = pn_time_median(g, o->repeat);
    // Without a filter the interval between the shadow and shading passes holds no work, only the
    // timestamps' own overhead: 0, so that an unfiltered cell's time is its shadow pass.
    row->filter_ms = row->filter != PN_FILTER_NONE ? pn_time_median(f, o->repeat) : 0.0;
    row->shade_ms = pn_time_median(h, o->repeat);
    row->shadow_ms = pn_time_median(s, o->repeat); // sorts s
    row->shadow_min_ms = s[0];
    row->shadow_max_ms = s[o->repeat - 1];
    return PN_OK;
}

bool pn_bench_append(void **items, int *count, int *cap, const void *item, size_t size)
{
    if (*count == *cap) {
        int grown = *cap ? 2 * *cap : 16;
        void *n = realloc(*items, (size_t)grown * size);
        if (!n)
            return false;
        *items = n;
        *cap = grown;
    }
    memcpy((char *)*items + (size_t)(*count)++ * size, item, size);
    return true;
}

void pn_bench_tree_label(char *out, size_t n, int tn, int td, bool per_object)
{
    if (tn)
        snprintf(out, n, " LS(%d,%d)%s", tn, td, per_object ? " per object" : "");
    else
        out[0] = '\0';
}

pn_result pn_bench_setup_config(pn_gpu_device *dev, const pn_scene *scene, const pn_camera *cam, const pn_light *light,
                                const pn_renderer_desc *frame, pn_shadow_mode mode, int n, int d, uint32_t spp,
                                uint32_t spp_min, float pixel_error, pn_filter filter, pn_setup *s)
{
    pn_setup_desc sd = {.frame = *frame, .tree_n = n, .tree_d = d, .view = cam};
    sd.frame.mode = mode;
    sd.frame.filter = filter;
    sd.frame.spp = spp;
    sd.frame.spp_min = spp_min;
    sd.frame.pixel_error = spp_min ? pixel_error : frame->pixel_error;
    sd.frame.dump_rays = false;
    return pn_setup_create(dev, scene, light, &sd, s);
}
