// The demo's image: how frames add up (the renderers' temporal history, adaptive refinement), the
// views composed from the last frame, the N-tree cell overlay, and the overlay text with the live
// figures.
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "apps/demo/demo.h"
#include "apps/demo/font.h"
#include "io/png.h"

pn_result pn_demo_image_create(uint32_t width, uint32_t height, pn_demo_image *out)
{
    memset(out, 0, sizeof *out);
    out->width = width;
    out->height = height;
    size_t px = (size_t)width * height;
    // One allocation per plane keeps the code plain; at 1280x720 all of it is about 35 MB.
    out->rad = calloc(px * 4, sizeof(float));
    out->v = calloc(px, sizeof(float));
    out->vx = calloc(px, sizeof(float));
    out->p = calloc(px * 4, sizeof(float));
    out->rgba = calloc(px, 4);
    out->rgb = calloc(px, 3);
    if (!out->rad || !out->v || !out->vx || !out->p || !out->rgba || !out->rgb) {
        pn_demo_image_destroy(out);
        pn_error("demo: out of memory for a %ux%u image", width, height);
        return PN_ERR_MEMORY;
    }
    return PN_OK;
}

void pn_demo_image_destroy(pn_demo_image *img)
{
    free(img->rad), free(img->v), free(img->vx), free(img->p);
    free(img->rgba), free(img->rgb);
    memset(img, 0, sizeof *img);
}

// Progressive refinement with adaptive samples (demo.h): instead of averaging frames
// of new samples, each frame continues the last one's (pn_renderer_set_continue) with twice the
// most samples and the pixel error over sqrt(2) (a pixel's samples double, so its standard error
// can fall by that), so the rays go to the pixels still uncertain and none to those already
// settled (lit, umbra, or a penumbra within the error). Frame k: MAX x 2^k up to
// REFINE_MAX_SAMPLES, then the image is held.
enum { REFINE_MAX_SAMPLES = 4096 };

bool pn_demo_refines_adaptively(const pn_demo *d)
{
    return d->accumulate && d->opts.spp_min && d->light_count == 1 && d->view != PN_DEMO_ERROR &&
           pn_shadow_mode_get(d->opts.mode)->traces;
}

bool pn_demo_temporal(const pn_demo *d)
{
    return d->accumulate && !pn_demo_refines_adaptively(d) && d->opts.sampler != PN_SAMPLER_GRID;
}

// Frames rendered after a change before holding the image. The grid sampler repeats the same
// samples, so its first frame is final; adaptive refinement holds once its most samples would
// pass REFINE_MAX_SAMPLES; the history after accumulate_max frames (as many as it holds).
uint32_t pn_demo_accumulate_limit(const pn_demo *d)
{
    if (!d->accumulate)
        return UINT32_MAX; // every frame renders anew (live timings), each on its own
    if (pn_demo_refines_adaptively(d)) {
        uint32_t frames = 1;
        for (long long spp = d->opts.spp * 2; spp <= REFINE_MAX_SAMPLES; spp *= 2)
            frames++;
        return frames < d->accumulate_max ? frames : d->accumulate_max;
    }
    return d->opts.sampler == PN_SAMPLER_GRID ? 1 : d->accumulate_max;
}

void pn_demo_image_add(pn_demo_image *img, const pn_frame_images *frame, const float *v_exact)
{
    size_t px = (size_t)img->width * img->height;
    img->frames++;
    // The frame holds every earlier sample already (the renderer's history, or adaptive samples
    // continued): it is the image, bit for bit (the screenshot tests rely on it).
    memcpy(img->rad, frame->radiance, px * 4 * sizeof(float));
    memcpy(img->v, frame->v, px * sizeof(float));
    if (v_exact)
        memcpy(img->vx, v_exact, px * sizeof(float));
    memcpy(img->p, frame->p, px * 4 * sizeof(float));
}

// ---------------------------------------------------------------------------------------------
// Views

static const uint8_t BACKGROUND[3] = {24, 24, 32}; // where no geometry is, in the V and error views

// Linear [0, 1] to sRGB-encoded bytes, so that grey levels show V proportionally in light.
static void srgb_lut(uint8_t lut[256])
{
    for (int i = 0; i < 256; i++) {
        double x = i / 255.0;
        double s = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
        lut[i] = (uint8_t)floor(s * 255.0 + 0.5);
    }
}

static uint8_t unit_byte(float x) { return (uint8_t)(x <= 0 ? 0 : x >= 1 ? 255 : x * 255.0f + 0.5f); }

// Error heat map: black (0), purple, orange, pale yellow (0.5 and above).
static void heat(float err, uint8_t out[3])
{
    static const float STOPS[4][3] = {{0, 0, 0}, {0.5f, 0, 0.55f}, {1, 0.5f, 0}, {1, 1, 0.65f}};
    float t = fminf(fmaxf(err / 0.5f, 0), 1) * 3;
    int k = t >= 3 ? 2 : (int)t;
    float f = t - (float)k;
    for (int c = 0; c < 3; c++)
        out[c] = unit_byte(STOPS[k][c] + f * (STOPS[k + 1][c] - STOPS[k][c]));
}

// The cell of the tree that world point p falls into, at most `max_level` deep: the walk from the
// root ends at a leaf (filled or empty) or at max_level. Returns a hash of the cell's level and
// coordinates (neighbouring pixels with different hashes lie in different cells) and its level;
// 0 outside the root box, which holds only the triangles that can block a ray (a culled ground
// plane lies outside).
static uint64_t cell_at(const pn_ntree *t, const float p[3], int max_level, int *level)
{
    int n = t->n;
    uint32_t n3 = (uint32_t)(n * n * n);
    double lo[3] = {t->root_min[0], t->root_min[1], t->root_min[2]}, size = t->root_size;
    for (int k = 0; k < 3; k++)
        if (!(p[k] >= lo[k] && p[k] <= lo[k] + size))
            return 0;
    uint32_t node = 0;
    uint64_t h = 0x9e3779b97f4a7c15ull;
    for (int l = 0; l < max_level; l++) {
        double cs = size / n;
        int c[3];
        for (int k = 0; k < 3; k++) {
            double x = floor(((double)p[k] - lo[k]) / cs);
            c[k] = x < 0 ? 0 : x > n - 1 ? n - 1 : (int)x;
            lo[k] += c[k] * cs;
        }
        size = cs;
        uint32_t child = (uint32_t)((c[2] * n + c[1]) * n + c[0]);
        h = (h ^ (child + 1)) * 0x100000001b3ull; // FNV-style: the path of child indices
        uint32_t entry = t->children[(size_t)node * n3 + child];
        *level = l + 1;
        if (entry < PN_CELL_NODE(0)) // a leaf: empty or filled
            return h ^ ((uint64_t)entry << 63);
        node = entry - PN_CELL_NODE(0);
    }
    return h;
}

// Tints each pixel by the level of its cell and darkens the borders between cells. Surface points
// always sit in filled leaves at depth d, whose cells are often smaller than a pixel: each pixel
// walks down only to the deepest level whose cells are still at least 6 pixels wide there, so the
// grid coarsens with distance and every border drawn is visible.
static void cells_overlay(const pn_demo *d, uint8_t *rgba)
{
    static const uint8_t LEVEL[6][3] = {{60, 120, 255}, {0, 200, 200}, {60, 200, 60},
                                        {230, 200, 0},  {255, 120, 0}, {230, 40, 40}};
    const pn_ntree *t = &d->accel.tree;
    const pn_demo_image *img = &d->image;
    uint32_t w = img->width, h = img->height;
    if (!t->children)
        return;
    uint64_t *ids = malloc((size_t)w * h * sizeof *ids);
    if (!ids)
        return;
    // Pixels per world unit at distance 1 from the eye.
    float px_per_unit = (float)h / (2.0f * tanf(d->camera.yfov_deg * 0.5f * 3.14159265f / 180.0f));
    for (size_t i = 0; i < (size_t)w * h; i++) {
        ids[i] = 0;
        const float *p = &img->p[4 * i];
        if (p[3] <= 0)
            continue;
        float dx = p[0] - d->camera.pos[0], dy = p[1] - d->camera.pos[1], dz = p[2] - d->camera.pos[2];
        float cell_px = (float)t->root_size * px_per_unit / sqrtf(dx * dx + dy * dy + dz * dz);
        int max_level = 0;
        while (max_level < t->d && (cell_px /= (float)t->n) >= 6.0f)
            max_level++;
        int level = 0;
        if (max_level == 0 || !(ids[i] = cell_at(t, p, max_level, &level)))
            continue;
        const uint8_t *c = LEVEL[(level - 1) % 6];
        for (int k = 0; k < 3; k++)
            rgba[4 * i + k] = (uint8_t)((rgba[4 * i + k] * 3 + c[k] * 2) / 5);
    }
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            if (!ids[i])
                continue;
            bool border = (x + 1 < w && ids[i + 1] && ids[i + 1] != ids[i]) ||
                          (y + 1 < h && ids[i + w] && ids[i + w] != ids[i]);
            if (border)
                for (int k = 0; k < 3; k++)
                    rgba[4 * i + k] = (uint8_t)(rgba[4 * i + k] / 4);
        }
    free(ids);
}

void pn_demo_compose(pn_demo *d)
{
    pn_demo_image *img = &d->image;
    size_t px = (size_t)img->width * img->height;
    uint8_t *out = img->rgba;
    if (d->view == PN_DEMO_SHADED) {
        // The render command's tone mapper: the shaded view is its --preview, byte for byte.
        pn_tonemap_srgb8(img->rad, (int)img->width, (int)img->height, d->opts.exposure, img->rgb);
        for (size_t i = 0; i < px; i++) {
            memcpy(out + 4 * i, img->rgb + 3 * i, 3);
            out[4 * i + 3] = 255;
        }
    } else {
        uint8_t lut[256];
        srgb_lut(lut);
        for (size_t i = 0; i < px; i++) {
            uint8_t *o = out + 4 * i;
            o[3] = 255;
            if (img->p[4 * i + 3] <= 0) {
                memcpy(o, BACKGROUND, 3);
            } else if (d->view == PN_DEMO_VISIBILITY) {
                o[0] = o[1] = o[2] = lut[unit_byte(img->v[i])];
            } else {
                heat(fabsf(img->v[i] - img->vx[i]), o);
            }
        }
    }
    if (d->cells)
        cells_overlay(d, out);
}

// ---------------------------------------------------------------------------------------------
// Overlay text

static const char *view_name(const pn_demo *d)
{
    switch (d->view) {
    case PN_DEMO_VISIBILITY: return "visibility V";
    case PN_DEMO_ERROR: return "error |V - V_exact|";
    default: return "shaded";
    }
}

// "linespace LS(7,3) ray stratified 25 spp"
static void params_text(const pn_demo *d, char *out, size_t n)
{
    const pn_render_opts *o = &d->opts;
    const pn_shadow_mode_info *mode = pn_shadow_mode_get(o->mode);
    int at = snprintf(out, n, "%s", mode->name);
    if (mode->needs.tree && at >= 0 && (size_t)at < n)
        at += snprintf(out + at, n - (size_t)at, " LS(%d,%d)%s %s", d->accel.desc.tree_n, d->accel.desc.tree_d,
                       d->accel.desc.per_object ? " per object" : "", pn_traversal_names[pn_traversal_resolve(o->mode, o->traversal, o->spp, o->spp_min)]);
    if (at >= 0 && (size_t)at < n && o->spp_min) // adaptive: the most of the frame shown (refined: raised)
        at += snprintf(out + at, n - (size_t)at, " %s %lld:%u spp%s", pn_sampler_names[o->sampler], o->spp_min,
                       d->renderer.desc.spp, o->filter != PN_FILTER_NONE ? " filtered" : "");
    else if (at >= 0 && (size_t)at < n)
        at += snprintf(out + at, n - (size_t)at, " %s %lld spp%s", pn_sampler_names[o->sampler], o->spp,
                       o->filter != PN_FILTER_NONE ? " filtered" : "");
    if (d->light_count > 1 && at >= 0 && (size_t)at < n) // which light the light keys move
        snprintf(out + at, n - (size_t)at, " light %u/%u", d->light_sel + 1, d->light_count);
}

void pn_demo_title(const pn_demo *d, char *out, size_t n)
{
    char params[128];
    params_text(d, params, sizeof params);
    const pn_demo_stats *s = &d->stats;
    snprintf(out, n,
             "penumbra demo - %s - gpu ms gbuffer %.1f shadow %.1f filter %.1f shade %.1f - %.2f M rays/s - pools %.1f "
             "MB - %u frames - %.1f fps",
             params, s->times.gbuffer_ms, s->times.shadow_ms, s->times.filter_ms, s->times.shade_ms, s->rays_per_s * 1e-6,
             pn_shadow_accel_gpu_bytes(&d->accel) / 1048576.0, d->image.frames,
             s->frame_ms > 0 ? 1000.0 / s->frame_ms : 0.0);
}

static void text_block(uint8_t *pixels, int w, int h, int x, int y, int scale, const char *text, const uint8_t rgb[3],
                       bool bgra)
{
    int cols, lines;
    pn_font_measure(text, &cols, &lines);
    // Darkened box behind the text: readable over any image.
    int pad = 3 * scale;
    int x1 = x + cols * PN_FONT_CELL_W * scale + pad, y1 = y + lines * PN_FONT_CELL_H * scale + pad;
    for (int py = y - pad > 0 ? y - pad : 0; py < y1 && py < h; py++)
        for (int px = x - pad > 0 ? x - pad : 0; px < x1 && px < w; px++) {
            uint8_t *p = pixels + ((size_t)py * w + px) * 4;
            p[0] = (uint8_t)(p[0] / 3), p[1] = (uint8_t)(p[1] / 3), p[2] = (uint8_t)(p[2] / 3);
        }
    uint8_t c[3] = {rgb[bgra ? 2 : 0], rgb[1], rgb[bgra ? 0 : 2]};
    pn_font_draw(pixels, w, h, x, y, scale, c, text);
}

void pn_demo_draw_overlay(const pn_demo *d, uint8_t *pixels, bool bgra)
{
    static const uint8_t WHITE[3] = {235, 235, 235}, YELLOW[3] = {255, 215, 80};
    int w = (int)d->image.width, h = (int)d->image.height;
    int scale = h >= 700 ? 2 : 1;
    int x = 4 * scale, y = 4 * scale;
    char text[2048];
    if (d->show_hud) {
        const pn_demo_stats *s = &d->stats;
        char params[128];
        params_text(d, params, sizeof params);
        int at = 0;
#define ADD(...) at += snprintf(text + at, sizeof text - (size_t)at, __VA_ARGS__)
        ADD("%s  %u triangles  %ux%u\n", d->scene.name, pn_scene_triangle_count(&d->scene), d->image.width,
            d->image.height);
        ADD("%s  seed %lld\n", params, d->opts.seed);
        ADD("gpu ms: gbuffer %.2f  shadow %.2f  filter %.2f  shade %.2f", s->times.gbuffer_ms, s->times.shadow_ms,
            s->times.filter_ms, s->times.shade_ms);
        if (d->view == PN_DEMO_ERROR && d->opts.mode != PN_SHADOW_REFERENCE)
            ADD("  exact shadow %.2f", s->exact_shadow_ms);
        ADD("\n%.2f M shadow rays/s  pools %.1f MB\n", s->rays_per_s * 1e-6,
            pn_shadow_accel_gpu_bytes(&d->accel) / 1048576.0);
        ADD("frame %.0f ms (render %.0f, compose %.0f, present %.0f)  %.1f fps\n", s->frame_ms, s->render_ms,
            s->compose_ms, s->present_ms, s->frame_ms > 0 ? 1000.0 / s->frame_ms : 0.0);
        ADD("last renderer set-up %.0f ms (pipelines, scene upload)\n", d->renderer_ms);
        if (!d->accumulate)
            ADD("accumulation off\n");
        else if (d->history_on)
            ADD("history: %.1f samples a pixel (of at most %u frames'); %u frames since a change%s\n",
                d->history_samples, d->accumulate_max, d->image.frames,
                d->image.frames >= pn_demo_accumulate_limit(d) ? " (held)" : "");
        else
            ADD("accumulated %u of %u frames%s%s\n", d->image.frames, pn_demo_accumulate_limit(d),
                pn_demo_refines_adaptively(d) ? " (adaptive samples continued)" : "",
                d->image.frames >= pn_demo_accumulate_limit(d) ? " (held)" : "");
        ADD("view %s%s\n", view_name(d), d->cells ? " + tree cells" : "");
        if (d->scene.object_count > 0) {
            // What a move costs the frame: per-object trees rebuild the top level only.
            const pn_demo_move *m = &d->last_move;
            ADD("object %u (0-%u; O: next, shift+arrows: move)", d->object_sel, d->scene.object_count - 1);
            if (m->count && !m->rebuild)
                ADD("  last move %.2f ms (top level %.2f + upload %.2f, no tree rebuilt)", m->total_ms, m->top_ms,
                    m->top_upload_ms);
            else if (m->count && d->accel.desc.per_object)
                ADD("  last move %.2f ms; the rest's culling lost: trees rebuilt in the background", m->total_ms);
            else if (m->count)
                ADD("  last move %.2f ms + the tree rebuilt in the background (--trees object: top level only)",
                    m->total_ms);
            ADD("\n");
        }
        if (d->view == PN_DEMO_ERROR)
            ADD("error vs exact: MAE %.4f  p99 %.3f  max %.3f\n", s->error_mae, s->error_p99, s->error_max);
        ADD("H: controls");
#undef ADD
        text_block(pixels, w, h, x, y, scale, text, WHITE, bgra);
        int cols, lines;
        pn_font_measure(text, &cols, &lines);
        y += (lines * PN_FONT_CELL_H + 3) * scale;
    }
    if (d->build_message[0]) {
        text_block(pixels, w, h, x, y, scale, d->build_message, YELLOW, bgra);
        y += (PN_FONT_CELL_H + 3) * scale;
    }
    if (d->show_help) {
        pn_demo_controls_text(text, sizeof text);
        size_t len = strlen(text);
        if (len && text[len - 1] == '\n')
            text[len - 1] = '\0';
        text_block(pixels, w, h, x, y + 3 * scale, scale, text, WHITE, bgra);
    }
}
