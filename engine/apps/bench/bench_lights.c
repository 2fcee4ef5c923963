// penumbra bench --lights: per configuration, frames of 1, k, ... lights over one tree built for
// each set, against the set's lights rendered each alone and the set's converged reference, with
// the even and the budgeted split.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/bench/bench.h"
#include "core/log.h"
#include "core/timer.h"

// --lights: the view's light turned about the vertical (+Y) axis through `centre` in k even steps,
// light i with 2^-i of the first's radiance and all together with the one light's (so the set
// lights the scene about as brightly as it): a bright light and dimmer ones, as real sets are, so
// that a budgeted split has shares to follow.
void pn_bench_light_set(const pn_light *light, const float centre[3], uint32_t k, pn_light *out)
{
    double weights = 2.0 - ldexp(1.0, 1 - (int)k); // sum of 2^-i, i < k
    for (uint32_t i = 0; i < k; i++) {
        double a = 2.0 * 3.14159265358979323846 * i / k, c = cos(a), s = sin(a);
        pn_light *l = &out[i];
        *l = *light;
        // Rotation about +Y: (x, z) -> (c x + s z, -s x + c z), positions about the centre.
        float dx = light->pos[0] - centre[0], dz = light->pos[2] - centre[2];
        l->pos[0] = centre[0] + (float)(c * dx + s * dz);
        l->pos[2] = centre[2] + (float)(-s * dx + c * dz);
        const float *v[2] = {light->normal, light->up};
        float *w[2] = {l->normal, l->up};
        for (int j = 0; j < 2; j++) {
            w[j][0] = (float)(c * v[j][0] + s * v[j][2]);
            w[j][2] = (float)(-s * v[j][0] + c * v[j][2]);
        }
        for (int ch = 0; ch < 3; ch++)
            l->radiance[ch] = (float)(light->radiance[ch] * ldexp(1.0, -(int)i) / weights);
    }
}

static bool push_light_row(bench_rows *rows, const bench_light_row *r)
{
    if (!pn_bench_append((void **)&rows->lights, &rows->light_count, &rows->light_cap, r, sizeof *r))
        return false;
    pn_bench_print_light_row(r);
    return true;
}

// The converged reference of a set of lights: exact, --reference-spp rays per light and pixel,
// stratified, a seed no measured frame uses, the even split, no filter. Its radiance (rgba per pixel)
// into `out`; not cached on disk (bench_reference.c caches one light's V).
pn_result pn_bench_lights_reference(const bench_group *g, const pn_light *set, uint32_t k, float *out)
{
    pn_setup s;
    pn_setup_desc sd = {.frame = {.width = g->frame.width, .height = g->frame.height, .mode = PN_SHADOW_REFERENCE,
                                  .sampler = PN_SAMPLER_STRATIFIED, .spp = g->o->reference_spp,
                                  .seed = PN_REFERENCE_SEED},
                        .light_count = k};
    uint64_t t0 = pn_time_ns();
    PN_TRY(pn_setup_create(g->dev, g->scene, set, &sd, &s));
    pn_frame_times t;
    pn_result r = pn_renderer_render_lights(&s.renderer, g->cam, set, k, &t);
    if (r == PN_OK) {
        pn_frame_images img;
        pn_renderer_images(&s.renderer, &img);
        memcpy(out, img.radiance, (size_t)g->frame.width * g->frame.height * 4 * sizeof *out);
        fprintf(stderr, "bench: %s %ux%u: converged reference of %u lights (exact, %u spp per light) in %.1f s\n",
                g->base.scene, g->frame.width, g->frame.height, k, g->o->reference_spp, pn_ms_since(t0) * 1e-3);
    }
    pn_setup_destroy(g->dev, &s);
    return r;
}

// The last frame's radiance against the reference (bench_light_row's mae_rel, rmse_rel).
static void lights_error(const pn_renderer *r, const float *ref, bench_light_row *row)
{
    pn_frame_images img;
    pn_renderer_images(r, &img);
    size_t px = (size_t)r->width * r->height, n = 0;
    double ae = 0, se = 0, level = 0;
    for (size_t i = 0; i < px; i++) {
        if (!(ref[4 * i + 3] > 0))
            continue;
        double want = (double)ref[4 * i] + ref[4 * i + 1] + ref[4 * i + 2];
        double d = (double)img.radiance[4 * i] + img.radiance[4 * i + 1] + img.radiance[4 * i + 2] - want;
        ae += fabs(d), se += d * d, level += want;
        n++;
    }
    row->has_error = n > 0 && level > 0;
    row->mae_rel = row->has_error ? ae / level : 0;
    row->rmse_rel = row->has_error ? sqrt(se / (double)n) / (level / (double)n) : 0;
}

// --lights for one configuration: per light count, a set-up whose tree is built for that set, and
// frames of all its lights timed as the matrix times its cells, with the even split and (several
// lights, stratified sampler) the budgeted one. refs[li]: light count li's reference radiance, or
// NULL (--gbuffer).
int pn_bench_run_lights(const bench_group *g, const float centre[3], pn_shadow_mode mode, int tn, int td,
                        float *const *refs, bench_rows *rows)
{
    const bench_opts *o = g->o;
    double one_ms = 0;
    for (int li = 0; li < o->light_count_count; li++) {
        uint32_t k = o->light_counts[li];
        pn_light set[PN_MAX_LIGHTS];
        pn_bench_light_set(g->light, centre, k, set);
        pn_setup_desc sd = {.frame = g->frame, .tree_n = tn, .tree_d = td, .light_count = k,
                            .view = o->gbuffer ? NULL : g->cam};
        sd.frame.mode = mode;
        sd.frame.spp = o->spps[0];
        sd.frame.filter = o->filters[0], sd.frame.tile_w = o->tile_w, sd.frame.tile_h = o->tile_h;
        pn_setup s;
        if (pn_setup_create(g->dev, g->scene, set, &sd, &s) != PN_OK)
            return PN_EXIT_FAILURE;
        bench_row t = {.filter = sd.frame.filter};
        bench_light_row r = {0};
        bool ok = (!o->gbuffer || pn_renderer_set_gbuffer(&s.renderer, o->gb_p, o->gb_n) == PN_OK) &&
                  pn_bench_time_frames(o, &s.renderer, g->cam, set, k, &t) == PN_OK;
        if (ok && refs[li])
            lights_error(&s.renderer, refs[li], &r); // the set's last frame, before the single lights'
        // Each light of the set alone, on the same set-up: what k separate frames would cost.
        double sum_ms = 0;
        for (uint32_t i = 0; i < k && ok; i++) {
            bench_row ti = {.filter = sd.frame.filter};
            ok = pn_bench_time_frames(o, &s.renderer, g->cam, &set[i], 1, &ti) == PN_OK;
            sum_ms += ti.gbuffer_ms + ti.shadow_ms + ti.filter_ms + ti.shade_ms;
        }
        r.width = g->frame.width, r.height = g->frame.height, r.spp = sd.frame.spp, r.mode = mode, r.n = tn, r.d = td;
        r.filter = sd.frame.filter, r.lights = k, r.build_ms = s.build_ms, r.culled = s.accel.tree.culled;
        r.pool_mb = pn_shadow_accel_gpu_bytes(&s.accel) / 1048576.0;
        r.shadow_ms = t.shadow_ms, r.shade_ms = t.shade_ms;
        snprintf(r.scene, sizeof r.scene, "%s", g->base.scene);
        r.frame_ms = t.gbuffer_ms + t.shadow_ms + t.filter_ms + t.shade_ms;
        if (k == 1)
            one_ms = r.frame_ms;
        r.vs_one = one_ms > 0 ? r.frame_ms / one_ms : 0;
        r.vs_sum = sum_ms > 0 ? r.frame_ms / sum_ms : 0;
        ok = ok && push_light_row(rows, &r);
        // The budgeted split over the same set-up and rays per pixel: it needs the stratified sampler
        // and no filter (one light alone gets the whole budget: the even split).
        if (ok && k > 1 && sd.frame.sampler == PN_SAMPLER_STRATIFIED) {
            bench_light_row b = r;
            bench_row tb = {.filter = PN_FILTER_NONE};
            ok = pn_renderer_set_filter(&s.renderer, PN_FILTER_NONE, o->tile_w, o->tile_h) == PN_OK &&
                 pn_renderer_set_split(&s.renderer, PN_SPLIT_BUDGET) == PN_OK &&
                 pn_bench_time_frames(o, &s.renderer, g->cam, set, k, &tb) == PN_OK;
            b.split = PN_SPLIT_BUDGET, b.filter = PN_FILTER_NONE, b.has_error = false;
            if (ok && refs[li])
                lights_error(&s.renderer, refs[li], &b);
            b.shadow_ms = tb.shadow_ms, b.shade_ms = tb.shade_ms;
            b.frame_ms = tb.gbuffer_ms + tb.shadow_ms + tb.filter_ms + tb.shade_ms;
            b.vs_one = one_ms > 0 ? b.frame_ms / one_ms : 0;
            b.vs_sum = sum_ms > 0 ? b.frame_ms / sum_ms : 0;
            ok = ok && push_light_row(rows, &b);
        }
        pn_setup_destroy(g->dev, &s);
        if (!ok)
            return PN_EXIT_FAILURE;
    }
    return PN_EXIT_OK;
}
