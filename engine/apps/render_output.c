// EXR and PNG output of a rendered frame, shared by render and demo.
#include "apps/render_output.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "shadow/setup.h"
#include "core/log.h"
#include "io/file.h"
#include "io/png.h"

bool pn_render_output_writable(const char *path)
{
    // The output is renamed over `path` at the end: that fails for a folder (after all the work),
    // and would replace a device node or a FIFO (as root, /dev/null itself). Only a regular file
    // or a new name will do.
    struct stat st;
    size_t n = strlen(path);
    if (n == 0) {
        pn_error("empty output file name");
        return false;
    }
    if (path[n - 1] == '/' || (stat(path, &st) == 0 && S_ISDIR(st.st_mode))) {
        pn_error("%s: cannot write: is a folder, not a file name", path);
        return false;
    }
    if (lstat(path, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISLNK(st.st_mode)) {
        pn_error("%s: cannot write: exists and is not a regular file", path);
        return false;
    }
    char tmp[4096];
    if (pn_file_tmp_path(path, tmp, sizeof tmp) != PN_OK)
        return false;
    FILE *f = fopen(tmp, "wb");
    if (!f) {
        pn_error("%s: cannot write here: %s", path, strerror(errno));
        return false;
    }
    fclose(f);
    remove(tmp);
    return true;
}

pn_result pn_render_write_exr(const char *path, const pn_render_record *rec, const pn_frame_images *img, bool aovs,
                              const pn_exr_attr *extra, int extra_count)
{
    const pn_render_opts *o = rec->opts;
    const pn_frame_times *t = &rec->times;
    const pn_camera *cam = rec->camera;
    const pn_light *light = &rec->lights[0];
    uint32_t lights = rec->light_count ? rec->light_count : 1;
    size_t px = (size_t)o->width * o->height;
    enum { PLANES = 17, ADAPTIVE = 2, FOOTPRINT = 1, HISTORY = 1, EXTRA = ADAPTIVE + FOOTPRINT + HISTORY };
    float *buf = malloc(px * (PLANES + EXTRA) * sizeof(float));
    if (!buf) {
        pn_error("%s: out of memory for the image", path);
        return PN_ERR_MEMORY;
    }
    float *pl[PLANES + EXTRA];
    for (int c = 0; c < PLANES + EXTRA; c++)
        pl[c] = buf + (size_t)c * px;
    // Planar channels from the interleaved RGBA readback.
    for (size_t i = 0; i < px; i++) {
        for (int c = 0; c < 4; c++)
            pl[c][i] = img->radiance[4 * i + c];
        pl[4][i] = img->v[i];
        for (int c = 0; c < 3; c++) {
            pl[5 + c][i] = img->p[4 * i + c];
            pl[8 + c][i] = img->n[4 * i + c];
            pl[11 + c][i] = img->albedo[4 * i + c];
        }
        pl[14][i] = img->n[4 * i + 3];
        pl[15][i] = (float)img->counts[4 * i + 1];
        memcpy(&pl[16][i], &img->counts[4 * i + 3], sizeof(float));
        if (img->rays) {
            pl[17][i] = (float)img->rays[4 * i];
            memcpy(&pl[18][i], &img->rays[4 * i + 1], sizeof(float));
        }
        if (img->footprint)
            pl[19][i] = img->footprint[2 * i + 1];
        if (img->history)
            pl[20][i] = img->history[4 * i + 1];
    }
    static const char *const names[PLANES] = {"R", "G", "B", "A", "shadow.V", "P.X", "P.Y", "P.Z",
                                              "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B", "Z",
                                              "shadow.valid", "shadow.penumbra"};
    // RGBA and V; with a filter the unfiltered V, so that a user can compare; then the AOVs. With
    // several lights a V (and V_raw) per light, already planar.
    pn_exr_channel ch[PLANES + EXTRA + 1 + 2 * PN_MAX_LIGHTS]; // 1: shadow.V_window
    char light_names[PN_MAX_LIGHTS][2][32];
    int count = 0;
    for (int c = 0; c < PLANES; c++) {
        if (c == 4 && lights > 1) {
            for (uint32_t i = 0; i < lights && i < img->light_count; i++) {
                snprintf(light_names[i][0], sizeof light_names[i][0], "shadow.V.%u", i);
                ch[count++] = (pn_exr_channel){light_names[i][0], img->v_light[i]};
                if (img->v_raw_light[i]) {
                    snprintf(light_names[i][1], sizeof light_names[i][1], "shadow.V_raw.%u", i);
                    ch[count++] = (pn_exr_channel){light_names[i][1], img->v_raw_light[i]};
                }
            }
            continue;
        }
        if (c == 5 && img->v_raw && lights == 1)
            ch[count++] = (pn_exr_channel){"shadow.V_raw", img->v_raw}; // already planar
        // shadow.valid: the rays of the pixel above its horizon and in front of the light, which V
        // is the share of; shadow.penumbra: the penumbra width the filter reads (the last light's
        // counts: one light only).
        if (c < 5 || (aovs && (c < 15 || lights == 1)))
            ch[count++] = (pn_exr_channel){names[c], pl[c]};
    }
    // Adaptive samples: the rays each pixel took and the standard error of its unfiltered V, from
    // its own and its neighbours' samples (adaptive_decide in shadow_frame.glsl); the last light's,
    // so one light only, as shadow.valid.
    if (img->rays && lights == 1) {
        ch[count++] = (pn_exr_channel){"shadow.rays", pl[17]};
        ch[count++] = (pn_exr_channel){"shadow.V_stderr", pl[18]};
    }
    // The penumbra filter's footprint: the standard deviation, in pixels, of the Gaussian it
    // averaged V over at each pixel (below 0.5: the interleaved filter's window alone; 0 where no
    // pixel of its 3x3 had a blocker); the last light's.
    if (aovs && img->footprint && lights == 1)
        ch[count++] = (pn_exr_channel){"shadow.footprint", pl[19]};
    // And the V its Gaussian averaged: the interleaved filter's window's (already planar; where
    // the renderer kept it, desc.keep_window), for checks of the Gaussian alone.
    if (aovs && img->v_window && lights == 1)
        ch[count++] = (pn_exr_channel){"shadow.V_window", img->v_window};
    // The temporal history: the valid samples behind each pixel's V over the frames (the last
    // light's): its own frame's where it has none (uncovered, or where something moved).
    if (img->history && lights == 1)
        ch[count++] = (pn_exr_channel){"shadow.history", pl[20]};
    bool tree = pn_shadow_mode_get(o->mode)->needs.tree;
#define V3(nm, v) {.name = nm, .type = PN_EXR_ATTR_V3F, .f = {(v)[0], (v)[1], (v)[2]}}
#define F1(nm, v) {.name = nm, .type = PN_EXR_ATTR_FLOAT, .f = {(float)(v)}}
    const pn_exr_attr attrs[] = {
        {.name = "penumbra.scene", .type = PN_EXR_ATTR_STRING, .s = rec->scene->name},
        {.name = "penumbra.mode", .type = PN_EXR_ATTR_STRING, .s = pn_shadow_mode_get(o->mode)->name},
        {.name = "penumbra.triangles", .type = PN_EXR_ATTR_INT, .i = (int32_t)pn_scene_triangle_count(rec->scene)},
        {.name = "penumbra.seed", .type = PN_EXR_ATTR_INT, .i = (int32_t)o->seed},
        {.name = "penumbra.width", .type = PN_EXR_ATTR_INT, .i = (int32_t)o->width},
        {.name = "penumbra.height", .type = PN_EXR_ATTR_INT, .i = (int32_t)o->height},
        V3("penumbra.camera.pos", cam->pos),
        V3("penumbra.camera.target", cam->target),
        V3("penumbra.camera.up", cam->up),
        F1("penumbra.camera.fov", cam->yfov_deg),
        V3("penumbra.light.pos", light->pos),
        V3("penumbra.light.normal", light->normal),
        V3("penumbra.light.up", light->up),
        F1("penumbra.light.width", light->size[0]),
        F1("penumbra.light.height", light->size[1]),
        V3("penumbra.light.radiance", light->radiance),
        {.name = "penumbra.light.kind", .type = PN_EXR_ATTR_STRING, .s = pn_light_kind_get(light->kind)->name},
        F1("penumbra.light.angle", light->angle * 180.0f / 3.14159265f), // a sun's diameter, degrees
        F1("penumbra.light.range", light->range), // an omni's or sphere's range (KHR_lights_punctual); 0: none
        {.name = "penumbra.light.cone", .type = PN_EXR_ATTR_V3F, // a spot's inner and outer angles, degrees
         .f = {light->cone[0] * 180.0f / 3.14159265f, light->cone[1] * 180.0f / 3.14159265f, 0}},
        F1("penumbra.gpu_ms.gbuffer", t->gbuffer_ms),
        F1("penumbra.gpu_ms.shadow", t->shadow_ms),
        F1("penumbra.gpu_ms.filter", t->filter_ms),
        F1("penumbra.gpu_ms.shade", t->shade_ms),
        // Pipelines readied before the frame ran (pn_frame_times.compile_ms): not in the passes' times.
        F1("penumbra.compile_ms", t->compile_ms),
        {.name = "penumbra.traversal",
         .type = PN_EXR_ATTR_STRING,
         .s = pn_traversal_names[pn_traversal_resolve(o->mode, o->traversal, o->spp, o->spp_min)]},
        {.name = "penumbra.sampler", .type = PN_EXR_ATTR_STRING, .s = pn_sampler_names[o->sampler]},
        {.name = "penumbra.spp", .type = PN_EXR_ATTR_INT, .i = (int32_t)o->spp},
        {.name = "penumbra.spp_min", .type = PN_EXR_ATTR_INT, .i = (int32_t)o->spp_min},
        F1("penumbra.pixel_error", o->spp_min ? o->pixel_error : 0.0f),
        {.name = "penumbra.filter", .type = PN_EXR_ATTR_STRING, .s = pn_filter_names[o->filter]},
        {.name = "penumbra.split", .type = PN_EXR_ATTR_STRING, .s = pn_split_names[o->split]},
        {.name = "penumbra.tile.w", .type = PN_EXR_ATTR_INT, .i = o->filter ? (int32_t)o->tile_w : 0},
        {.name = "penumbra.tile.h", .type = PN_EXR_ATTR_INT, .i = o->filter ? (int32_t)o->tile_h : 0},
        {.name = "penumbra.tree.n", .type = PN_EXR_ATTR_INT, .i = tree ? o->tree_n : 0},
        {.name = "penumbra.tree.d", .type = PN_EXR_ATTR_INT, .i = tree ? o->tree_d : 0},
        F1("penumbra.build_ms", rec->build_ms),
        F1("penumbra.shadow_rays_per_s", rec->rays_per_s),
        {.name = "penumbra.lights", .type = PN_EXR_ATTR_INT, .i = (int32_t)lights},
    };
#undef V3
#undef F1
    // Lights 1.. as penumbra.light.i.*: the six attributes of light 0's geometry, and its kind.
    enum { BASE = sizeof attrs / sizeof attrs[0], MAX_EXTRA = 16, PER_LIGHT = 6 };
    pn_exr_attr all[BASE + (PER_LIGHT + 1) * PN_MAX_LIGHTS + MAX_EXTRA];
    static const char *const fields[PER_LIGHT] = {"pos", "normal", "up", "width", "height", "radiance"};
    char kind_names[PN_MAX_LIGHTS][40];
    char attr_names[PN_MAX_LIGHTS][PER_LIGHT][40];
    memcpy(all, attrs, sizeof attrs);
    int n = BASE;
    for (uint32_t i = 1; i < lights; i++) {
        const pn_light *l = &rec->lights[i];
        const float *v3[PER_LIGHT] = {l->pos, l->normal, l->up, NULL, NULL, l->radiance};
        for (int f = 0; f < PER_LIGHT; f++) {
            snprintf(attr_names[i][f], sizeof attr_names[i][f], "penumbra.light.%u.%s", i, fields[f]);
            pn_exr_attr a = {.name = attr_names[i][f], .type = v3[f] ? PN_EXR_ATTR_V3F : PN_EXR_ATTR_FLOAT};
            if (v3[f])
                memcpy(a.f, v3[f], sizeof a.f);
            else
                a.f[0] = l->size[f == 3 ? 0 : 1];
            all[n++] = a;
        }
        snprintf(kind_names[i], sizeof kind_names[i], "penumbra.light.%u.kind", i);
        all[n++] = (pn_exr_attr){.name = kind_names[i], .type = PN_EXR_ATTR_STRING, .s = pn_light_kind_get(l->kind)->name};
    }
    if (extra_count > MAX_EXTRA)
        extra_count = MAX_EXTRA;
    if (extra_count > 0)
        memcpy(all + n, extra, (size_t)extra_count * sizeof *extra);
    pn_result r = pn_exr_write(path, (int)o->width, (int)o->height, ch, count, all, n + extra_count);
    free(buf);
    return r;
}

pn_result pn_render_write_png(const char *path, const float *radiance, uint32_t width, uint32_t height, float exposure)
{
    uint8_t *rgb = malloc((size_t)width * height * 3);
    if (!rgb) {
        pn_error("%s: out of memory for the preview", path);
        return PN_ERR_MEMORY;
    }
    pn_tonemap_srgb8(radiance, (int)width, (int)height, exposure, rgb);
    pn_result r = pn_png_write_rgb8(path, (int)width, (int)height, rgb);
    free(rgb);
    return r;
}
