// penumbra demo: render's passes in a window, every frame, with the knobs live.
//
// One frame: script events and window input -> (swapchain and renderers recreated if the size or
// a parameter changed; moved objects brought into the renderers and trees; a finished background
// tree swapped in) -> pn_renderer_render (and the exact
// renderer in the error view) -> accumulate -> compose on the CPU (tone map or view, cell overlay)
// -> copy into the acquired swapchain image with the overlay text -> present.
//
// Over 500 lines because the window loop, its GLFW callbacks, the swapchain copy and the
// end-of-run summary share the loop's state; trees and moves are demo_trees.c's.
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "apps/commands.h"
#include "apps/demo/demo.h"
#include "shadow/metrics.h"
#include "apps/render_output.h"
#include "core/timer.h"
#include "io/png.h"

// ---------------------------------------------------------------------------------------------
// Window input: GLFW callbacks find the demo through the window's user pointer.

static void on_key(GLFWwindow *window, int key, int scancode, int action, int mods)
{
    if (action == GLFW_PRESS || action == GLFW_REPEAT)
        pn_demo_key(glfwGetWindowUserPointer(window), key, mods, action == GLFW_REPEAT);
}

static void on_button(GLFWwindow *window, int button, int action, int mods)
{
    pn_demo *d = glfwGetWindowUserPointer(window);
    if (action == GLFW_RELEASE) {
        d->drag = 0;
        return;
    }
    glfwGetCursorPos(window, &d->mouse_x, &d->mouse_y);
    d->drag = button == GLFW_MOUSE_BUTTON_LEFT && !(mods & GLFW_MOD_SHIFT) ? 1 : 2;
}

static void on_cursor(GLFWwindow *window, double x, double y)
{
    pn_demo *d = glfwGetWindowUserPointer(window);
    double dx = x - d->mouse_x, dy = y - d->mouse_y;
    d->mouse_x = x, d->mouse_y = y;
    if (d->drag == 1)
        pn_demo_orbit(d, (float)(-0.3 * dx), (float)(0.3 * dy)); // the scene follows the mouse
    else if (d->drag == 2 && d->image.height > 0)
        pn_demo_pan(d, (float)(dx / d->image.height), (float)(dy / d->image.height));
}

static void on_scroll(GLFWwindow *window, double x, double y)
{
    pn_demo_zoom(glfwGetWindowUserPointer(window), powf(0.9f, (float)y));
}

static void on_glfw_error(int code, const char *message) { pn_warn("GLFW: %s", message); }

// ---------------------------------------------------------------------------------------------
// Renderers (the trees they draw with are kept up by demo_trees.c)

static pn_result create_renderers(pn_demo *d)
{
    pn_renderer_destroy(&d->renderer);
    pn_renderer_destroy(&d->exact);
    uint64_t t0 = pn_time_ns();
    pn_renderer_desc rd = pn_render_opts_setup(&d->opts).frame;
    rd.width = d->swapchain.extent.width;
    rd.height = d->swapchain.extent.height;
    pn_shadow_accel_bind(&d->accel, &rd);
    // Frame after frame: a switch's first frame carries its compile, as the user sees it.
    rd.no_warm_up = true;
    PN_TRY(pn_renderer_create(&d->dev, &d->scene, &rd, &d->renderer));
    if (d->view == PN_DEMO_ERROR && rd.mode != PN_SHADOW_REFERENCE) {
        rd.mode = PN_SHADOW_REFERENCE;
        PN_TRY(pn_renderer_create(&d->dev, &d->scene, &rd, &d->exact));
    }
    d->renderer_ms = pn_ms_since(t0);
    d->renderer_dirty = false;
    d->restart = true;
    d->history_on = false; // render() turns it on
    return PN_OK;
}

// ---------------------------------------------------------------------------------------------
// Frames

// The renderers' temporal history on or off as pn_demo_temporal says (accumulation toggled, a
// sampler or view that changes it); renderers made anew start without one (create_renderers).
// It holds accumulate_max frames' samples, as many as a still view renders before it is held.
static pn_result set_history(pn_demo *d)
{
    bool on = pn_demo_temporal(d);
    if (on == d->history_on)
        return PN_OK;
    uint32_t frames = !on ? 0 : d->accumulate_max < PN_HISTORY_MAX_FRAMES ? d->accumulate_max : PN_HISTORY_MAX_FRAMES;
    PN_TRY(pn_renderer_set_history(&d->renderer, frames));
    if (d->exact.dev)
        PN_TRY(pn_renderer_set_history(&d->exact, frames));
    d->history_on = on;
    return PN_OK;
}

static pn_result render(pn_demo *d)
{
    if (d->restart || !d->accumulate)
        d->image.frames = 0;
    d->restart = false;
    PN_TRY(set_history(d));
    bool refine = pn_demo_refines_adaptively(d), continued = refine && d->image.frames > 0;
    // One seed throughout: the history's frames take other strata of a window of frames (their
    // numbers go on by one a frame, in both renderers alike), adaptive refinement continues the
    // same samples.
    uint32_t seed = (uint32_t)d->opts.seed;
    pn_renderer_set_seed(&d->renderer, seed);
    if (d->opts.spp_min) {
        uint32_t k = refine ? d->image.frames : 0;
        float error = d->opts.pixel_error * powf(0.5f, 0.5f * (float)k);
        PN_TRY(pn_renderer_set_adaptive(&d->renderer, (uint32_t)d->opts.spp_min, (uint32_t)d->opts.spp << k, error));
        pn_renderer_set_continue(&d->renderer, continued);
    }
    if (!continued)
        d->refined_rays = 0;
    pn_demo_stats *s = &d->stats;
    PN_TRY(pn_renderer_render_lights(&d->renderer, &d->camera, d->lights, d->light_count, &s->times));
    pn_frame_images frame;
    pn_renderer_images(&d->renderer, &frame);
    const float *v_exact = NULL;
    if (d->view == PN_DEMO_ERROR) {
        v_exact = frame.v; // exact mode: its own reference
        if (d->exact.dev) {
            pn_frame_times t;
            pn_frame_images exact;
            pn_renderer_set_seed(&d->exact, seed); // same samples: the error is the method's alone
            PN_TRY(pn_renderer_render_lights(&d->exact, &d->camera, d->lights, d->light_count, &t));
            pn_renderer_images(&d->exact, &exact);
            v_exact = exact.v;
            s->exact_shadow_ms = t.shadow_ms;
        }
    }
    pn_demo_image_add(&d->image, &frame, v_exact);

    size_t px = (size_t)d->image.width * d->image.height, covered = 0;
    uint8_t *mask = d->view == PN_DEMO_ERROR ? malloc(px) : NULL;
    uint64_t rays = 0;
    double history = 0;
    for (size_t i = 0; i < px; i++) {
        bool geometry = frame.p[4 * i + 3] > 0;
        covered += geometry;
        rays += frame.rays ? frame.rays[4 * i] : 0;
        history += frame.history && geometry ? frame.history[4 * i + 1] : 0;
        if (mask)
            mask[i] = geometry;
    }
    d->history_samples = covered ? history / (double)covered : 0;
    s->rays_per_s = 0;
    if (frame.rays && d->light_count == 1) {
        // Adaptive: the rays the pixels took (in all, when the frame resumed the last one's: this
        // frame's are the new ones).
        uint64_t before = d->renderer.resumed && rays >= d->refined_rays ? d->refined_rays : 0;
        s->rays_per_s = s->times.shadow_ms > 0 ? (double)(rays - before) / (s->times.shadow_ms * 1e-3) : 0;
        d->refined_rays = refine ? rays : 0;
    } else {
        for (uint32_t i = 0; i < d->light_count; i++)
            s->rays_per_s += pn_shadow_rays_per_s(covered, (uint32_t)d->opts.spp, &d->lights[i], s->times.shadow_ms);
    }
    pn_error_metrics m;
    if (mask && pn_error_compare(d->image.v, d->image.vx, mask, px, NULL, &m))
        s->error_mae = m.mae, s->error_p99 = m.p99, s->error_max = m.max;
    free(mask);
    return PN_OK;
}

static pn_result write_png(pn_demo *d, const char *path)
{
    const pn_demo_image *img = &d->image;
    size_t px = (size_t)img->width * img->height;
    for (size_t i = 0; i < px; i++)
        memcpy(img->rgb + 3 * i, img->rgba + 4 * i, 3);
    return pn_png_write_rgb8(path, (int)img->width, (int)img->height, img->rgb);
}

// P: the frame as EXR (radiance and V over every sample the history holds, shadow.history the
// samples behind each pixel, G-buffer AOVs, every parameter in the header) and as PNG (the view
// as shown, without text).
static void save_frame(pn_demo *d)
{
    char exr[1100], png[1100];
    d->saved++;
    snprintf(exr, sizeof exr, "%s-%04u.exr", d->save_prefix, d->saved);
    snprintf(png, sizeof png, "%s-%04u.png", d->save_prefix, d->saved);
    pn_frame_images frame;
    pn_renderer_images(&d->renderer, &frame);
    frame.radiance = d->image.rad;
    frame.v = d->image.v;
    pn_render_record rec = {.opts = &d->opts, .scene = &d->scene, .camera = &d->camera, .lights = d->lights, .light_count = d->light_count,
                            .times = d->stats.times, .build_ms = d->accel.build_ms, .rays_per_s = d->stats.rays_per_s};
    static const char *const VIEWS[] = {"shaded", "visibility", "error"};
    const pn_exr_attr extra[] = {
        {.name = "penumbra.demo.accumulated_frames", .type = PN_EXR_ATTR_INT, .i = (int32_t)d->image.frames},
        {.name = "penumbra.demo.seeds", .type = PN_EXR_ATTR_STRING,
         .s = pn_demo_refines_adaptively(d) ? "seed (adaptive samples continued over the accumulated frames)"
              : d->history_on ? "seed, every frame: the history's frames take the strata of a window of frames"
                              : "seed"},
        // The history's length in frames (0: none), as render --temporal's penumbra.history.
        {.name = "penumbra.history", .type = PN_EXR_ATTR_INT, .i = d->history_on ? (int32_t)d->renderer.history_frames : 0},
        {.name = "penumbra.demo.view", .type = PN_EXR_ATTR_STRING, .s = VIEWS[d->view]},
        // Refined adaptively: the most samples and the pixel error of the frame saved (render_lights'
        // penumbra.spp and penumbra.pixel_error are the first frame's).
        {.name = "penumbra.demo.refined_spp", .type = PN_EXR_ATTR_INT,
         .i = pn_demo_refines_adaptively(d) ? (int32_t)d->renderer.desc.spp : 0},
        {.name = "penumbra.demo.refined_pixel_error", .type = PN_EXR_ATTR_FLOAT,
         .f = {pn_demo_refines_adaptively(d) ? d->renderer.desc.pixel_error : 0.0f}},
        {.name = "penumbra.demo.cells_overlay", .type = PN_EXR_ATTR_INT, .i = d->cells},
        {.name = "penumbra.exposure", .type = PN_EXR_ATTR_FLOAT, .f = {d->opts.exposure}},
        {.name = "penumbra.pool_bytes", .type = PN_EXR_ATTR_FLOAT, .f = {(float)pn_shadow_accel_gpu_bytes(&d->accel)}},
    };
    d->opts.width = d->image.width, d->opts.height = d->image.height;
    if (pn_render_write_exr(exr, &rec, &frame, true, extra, (int)(sizeof extra / sizeof extra[0])) == PN_OK &&
        write_png(d, png) == PN_OK)
        pn_info("saved %s and %s", exr, png);
}

// Copies the composed frame into the staging memory in the swapchain's byte order, draws the text.
static void fill_staging(pn_demo *d)
{
    uint8_t *dst = d->swapchain.staging.mapped;
    const uint8_t *src = d->image.rgba;
    size_t px = (size_t)d->image.width * d->image.height;
    if (d->swapchain.bgra)
        for (size_t i = 0; i < px; i++) {
            dst[4 * i + 0] = src[4 * i + 2];
            dst[4 * i + 1] = src[4 * i + 1];
            dst[4 * i + 2] = src[4 * i + 0];
            dst[4 * i + 3] = 255;
        }
    else
        memcpy(dst, src, px * 4);
    pn_demo_draw_overlay(d, dst, d->swapchain.bgra);
}

static void record_stats(pn_demo *d)
{
    // Whole at the first frame: the ring never grows after (tests/demo_soak.sh watches the memory).
    if (!d->records && !(d->records = malloc(PN_DEMO_RECORDS * sizeof *d->records)))
        return; // no medians at exit; not worth failing the demo for
    d->records[d->record_total++ % PN_DEMO_RECORDS] = d->stats;
    if (d->record_count < PN_DEMO_RECORDS)
        d->record_count++;
}

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

typedef enum frame_set { ALL_FRAMES, FRAMES_MOVED, FRAMES_STILL, FRAMES_BUILDING, FRAMES_IDLE } frame_set;

static bool in_set(const pn_demo_stats *s, frame_set which)
{
    switch (which) {
    case FRAMES_MOVED: return s->move_ms > 0;
    case FRAMES_STILL: return !(s->move_ms > 0);
    case FRAMES_BUILDING: return s->building;
    case FRAMES_IDLE: return !s->building;
    default: return true;
    }
}

// Median of one field (a double at byte offset `field` of pn_demo_stats) over the rendered frames
// of a set (objects moved or not before the frame, a tree build running or not); *count (when
// given) gets how many.
static double median(const pn_demo *d, size_t field, frame_set which, size_t *count)
{
    double *v = malloc((d->record_count ? d->record_count : 1) * sizeof *v);
    size_t n = 0;
    for (size_t i = 0; v && i < d->record_count; i++)
        if (in_set(&d->records[i], which))
            memcpy(&v[n++], (const char *)&d->records[i] + field, sizeof *v);
    if (count)
        *count = n;
    if (!v || n == 0) {
        free(v);
        return 0;
    }
    qsort(v, n, sizeof *v, by_value);
    double m = v[n / 2];
    free(v);
    return m;
}

static void print_summary(const pn_demo *d, const pn_demo_opts *o, uint32_t width, uint32_t height)
{
    printf("demo: %llu frames, the last %ux%u%s%s\n", (unsigned long long)d->frame, width, height,
           o->screenshot ? " -> " : "", o->screenshot ? o->screenshot : "");
    const pn_demo_memory *m = &d->end_memory;
    printf("  memory after the last frame: resident %.1f MiB (peak %.1f MiB); device %.2f MiB in %u allocations",
           m->rss_bytes / 1048576.0, m->peak_rss_bytes / 1048576.0, m->device_bytes / 1048576.0, m->device_allocations);
    if (m->heap_usage)
        printf(" (the driver's heap usage %.2f MiB)", m->heap_usage_bytes / 1048576.0);
    printf("\n");
    if (d->record_count == 0)
        return;
#define MED(f) median(d, offsetof(pn_demo_stats, f), ALL_FRAMES, NULL)
    if (d->record_total > d->record_count)
        printf("  of %llu rendered frames, the last %zu:\n", (unsigned long long)d->record_total, d->record_count);
    printf("  medians of %zu rendered frames: frame %.1f ms (render %.1f, compose %.1f, present %.1f); "
           "gpu ms gbuffer %.2f, shadow %.2f, filter %.2f, shade %.2f; %.3g shadow rays/s\n",
           d->record_count, MED(frame_ms), MED(render_ms), MED(compose_ms), MED(present_ms), MED(times.gbuffer_ms),
           MED(times.shadow_ms), MED(times.filter_ms), MED(times.shade_ms), MED(rays_per_s));
#undef MED
    // What moves and rebuilds cost the frame: with against without.
    size_t moved, still, building, idle;
    double moved_ms = median(d, offsetof(pn_demo_stats, frame_ms), FRAMES_MOVED, &moved);
    double move_ms = median(d, offsetof(pn_demo_stats, move_ms), FRAMES_MOVED, NULL);
    double still_ms = median(d, offsetof(pn_demo_stats, frame_ms), FRAMES_STILL, &still);
    double building_ms = median(d, offsetof(pn_demo_stats, frame_ms), FRAMES_BUILDING, &building);
    double idle_ms = median(d, offsetof(pn_demo_stats, frame_ms), FRAMES_IDLE, &idle);
    if (moved > 0)
        printf("  frames with objects moved: %zu, median frame %.1f ms (the move's update %.2f ms); without: %zu, "
               "median frame %.1f ms\n",
               moved, moved_ms, move_ms, still, still_ms);
    if (building > 0)
        printf("  frames while a tree build ran on the worker: %zu, median frame %.1f ms; the others: %zu, median "
               "frame %.1f ms\n",
               building, building_ms, idle, idle_ms);
}

// Applies the script's events for this frame; returns the path of a screenshot asked for, or NULL.
static const char *apply_script(pn_demo *d, pn_demo_script *script)
{
    const char *shot = NULL;
    for (; script->next < script->count && script->events[script->next].frame <= d->frame; script->next++) {
        const pn_demo_event *e = &script->events[script->next];
        switch (e->kind) {
        case PN_DEMO_EVENT_KEY: pn_demo_key(d, e->key, e->mods, false); break;
        case PN_DEMO_EVENT_ORBIT: pn_demo_orbit(d, e->a, e->b); break;
        case PN_DEMO_EVENT_PAN: pn_demo_pan(d, e->a, e->b); break;
        case PN_DEMO_EVENT_ZOOM: pn_demo_zoom(d, e->a); break;
        case PN_DEMO_EVENT_RESIZE: glfwSetWindowSize(d->window, (int)e->a, (int)e->b); break;
        case PN_DEMO_EVENT_SCREENSHOT: shot = e->path; break;
        case PN_DEMO_EVENT_MOVE_OBJECT: pn_demo_move_object(d, e->object, e->move); break;
        }
    }
    return shot;
}

// Brings the swapchain to the window's size (recreating it when `recreate` or the size differs),
// then what depends on the size: the image buffers and the renderers.
static pn_result fit_window(pn_demo *d, int width, int height, bool recreate)
{
    VkExtent2D e = d->swapchain.extent;
    if (recreate || e.width != (uint32_t)width || e.height != (uint32_t)height)
        PN_TRY(pn_swapchain_recreate(&d->swapchain, (uint32_t)width, (uint32_t)height));
    e = d->swapchain.extent;
    if (e.width == 0 || e.height == 0)
        return PN_OK;
    if (e.width != d->image.width || e.height != d->image.height) {
        pn_demo_image_destroy(&d->image);
        PN_TRY(pn_demo_image_create(e.width, e.height, &d->image));
        d->opts.width = e.width, d->opts.height = e.height;
        d->renderer_dirty = true;
    }
    return PN_OK;
}

static pn_result create_swapchain(pn_demo *d, bool vsync)
{
    VkSurfaceKHR surface;
    VK_CHECK(glfwCreateWindowSurface(d->dev.instance, d->window, NULL, &surface));
    int fw, fh;
    glfwGetFramebufferSize(d->window, &fw, &fh);
    pn_swapchain_desc sd = {.surface = surface, .width = (uint32_t)fw, .height = (uint32_t)fh, .vsync = vsync};
    return pn_swapchain_create(&d->dev, &sd, &d->swapchain);
}

static int run(pn_demo *d, const pn_demo_opts *o, pn_demo_script *script)
{
    glfwSetWindowUserPointer(d->window, d);
    glfwSetKeyCallback(d->window, on_key);
    glfwSetMouseButtonCallback(d->window, on_button);
    glfwSetCursorPosCallback(d->window, on_cursor);
    glfwSetScrollCallback(d->window, on_scroll);

    uint32_t ext_count = 0;
    const char **exts = glfwGetRequiredInstanceExtensions(&ext_count); // GLFW logs why when it fails
    if (!exts) {
        pn_error("demo: GLFW cannot use Vulkan with this window system (see GLFW's message above)");
        return PN_EXIT_FAILURE;
    }
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    desc.present = true;
    desc.instance_extensions = exts;
    desc.instance_extension_count = ext_count;
    desc.can_present = glfwGetPhysicalDevicePresentationSupport;
    if (pn_gpu_device_create(&desc, &d->dev) != PN_OK)
        return PN_EXIT_FAILURE;
    if (create_swapchain(d, o->vsync) != PN_OK)
        return PN_EXIT_FAILURE;

    // The first tree is built before the first frame, as render builds it.
    if (pn_bvh_build(&d->scene, &d->bvh) != PN_OK) {
        pn_error("%s: out of memory building the BVH", d->scene.name);
        return PN_EXIT_FAILURE;
    }
    pn_shadow_accel_desc td = pn_demo_tree_desc(d, d->opts.tree_n, d->opts.tree_d);
    if (pn_shadow_accel_build(&d->scene, &td, &d->accel) != PN_OK ||
        pn_shadow_accel_upload(&d->dev, &d->scene, &d->accel) != PN_OK)
        return PN_EXIT_FAILURE;
    d->want_n = d->opts.tree_n, d->want_d = d->opts.tree_d;

    bool stale = false; // the swapchain must be recreated (out of date or suboptimal)
    int fw, fh;
    while (!d->quit && !glfwWindowShouldClose(d->window)) {
        uint64_t t0 = pn_time_ns();
        d->stats.move_ms = 0;
        const char *shot = apply_script(d, script);
        bool held = d->image.frames >= pn_demo_accumulate_limit(d) && !d->restart && !d->renderer_dirty;
        bool building = atomic_load(&d->builder.state) != PN_DEMO_BUILD_IDLE;
        // Nothing to refine: wait for input instead of spinning (still wakes for the build's progress).
        if (held && !building && !shot && !d->save && !o->frames)
            glfwWaitEventsTimeout(0.1);
        else
            glfwPollEvents();

        glfwGetFramebufferSize(d->window, &fw, &fh);
        // Minimised: nothing to draw into (some window systems keep the size, so ask for both).
        if (fw == 0 || fh == 0 || glfwGetWindowAttrib(d->window, GLFW_ICONIFIED)) {
            glfwWaitEventsTimeout(0.1);
            continue;
        }
        if (fit_window(d, fw, fh, stale) != PN_OK)
            return PN_EXIT_FAILURE;
        stale = false;
        if (d->swapchain.extent.width == 0)
            continue;
        if (pn_demo_apply_moves(d) != PN_OK || (shot ? pn_demo_settle_tree(d) : pn_demo_update_tree(d)) != PN_OK)
            return PN_EXIT_FAILURE;
        if (d->renderer_dirty && create_renderers(d) != PN_OK)
            return PN_EXIT_FAILURE;

        uint64_t t1 = pn_time_ns();
        d->stats.building = atomic_load(&d->builder.state) != PN_DEMO_BUILD_IDLE;
        held = d->image.frames >= pn_demo_accumulate_limit(d) && !d->restart;
        if (!held) {
            if (render(d) != PN_OK)
                return PN_EXIT_FAILURE;
            d->stats.render_ms = pn_ms_since(t1);
            uint64_t t2 = pn_time_ns();
            pn_demo_compose(d);
            d->stats.compose_ms = pn_ms_since(t2);
        }
        if (shot)
            write_png(d, shot);
        if (d->save) {
            save_frame(d);
            d->save = false;
        }

        uint64_t t3 = pn_time_ns();
        if (pn_swapchain_acquire(&d->swapchain, &stale) != PN_OK)
            return PN_EXIT_FAILURE;
        if (stale)
            continue; // out of date: recreate, then draw this frame again
        fill_staging(d);
        if (pn_swapchain_present(&d->swapchain, &stale) != PN_OK)
            return PN_EXIT_FAILURE;
        d->stats.present_ms = pn_ms_since(t3);
        if (!held) {
            d->stats.frame_ms = pn_ms_since(t0);
            record_stats(d);
        }
        char title[512];
        pn_demo_title(d, title, sizeof title);
        glfwSetWindowTitle(d->window, title);
        d->frame++;
        if (d->stats_every && d->frame % d->stats_every == 0)
            pn_demo_stats_sample(d);
        if (o->frames && d->frame >= (uint64_t)o->frames)
            break;
    }
    if (d->stats_every && d->frame % d->stats_every != 0)
        pn_demo_stats_sample(d); // the last frame's
    d->end_memory = pn_demo_memory_now(d);
    if (o->screenshot && d->image.frames > 0 && write_png(d, o->screenshot) != PN_OK)
        return PN_EXIT_FAILURE;
    return PN_EXIT_OK;
}

int pn_cmd_demo(int argc, char **argv)
{
    pn_demo_opts o;
    int rc = pn_demo_parse(argc, argv, &o);
    if (rc != PN_EXIT_OK)
        return rc < 0 ? PN_EXIT_OK : rc;
    if ((o.screenshot && !pn_render_output_writable(o.screenshot)) || (o.stats && !pn_render_output_writable(o.stats)))
        return PN_EXIT_FAILURE;
    pn_demo_script script = {0};
    if (o.script && pn_demo_script_load(o.script, &script) != PN_OK)
        return PN_EXIT_USAGE;

    pn_demo d = {.opts = o.r, .accumulate = o.accumulate,
                 .accumulate_max = (uint32_t)o.accumulate_max, .show_hud = o.hud, .save_prefix = o.save_prefix};
    atomic_init(&d.builder.state, PN_DEMO_BUILD_IDLE);
    // As render prepares it: camera and light frame the scene itself, the ground plane comes after.
    pn_prepared_scene prep;
    int prc = pn_render_prepare(&o.r, o.scene, &prep);
    if (prc != PN_EXIT_OK) {
        pn_demo_script_destroy(&script);
        return prc;
    }
    d.scene = prep.scene, d.camera = prep.camera, d.light_count = prep.light_count;
    if (o.script && pn_demo_script_check(&script, o.script, &d.scene) != PN_OK) {
        pn_scene_destroy(&d.scene);
        pn_demo_script_destroy(&script);
        return PN_EXIT_USAGE;
    }
    memcpy(d.lights, prep.lights, sizeof d.lights);
    d.camera_home = d.camera;
    memcpy(d.lights_home, d.lights, sizeof d.lights_home);
    float r2 = 0; // orbiting centres on the object, not on the ground
    for (int k = 0; k < 3; k++) {
        d.center[k] = 0.5f * (prep.object_min[k] + prep.object_max[k]);
        float e = prep.object_max[k] - prep.object_min[k];
        r2 += e * e;
    }
    d.radius = 0.5f * sqrtf(r2) > 0 ? 0.5f * sqrtf(r2) : 1.0f;
    if (o.stats && pn_demo_stats_open(&d, o.stats, (uint32_t)o.stats_every) != PN_OK) {
        pn_scene_destroy(&d.scene);
        pn_demo_script_destroy(&script);
        return PN_EXIT_FAILURE;
    }

    glfwSetErrorCallback(on_glfw_error);
    int exit_code = PN_EXIT_FAILURE;
    if (!glfwInit()) {
        pn_error("demo: cannot open a window (no display? without one, run it under xvfb-run -a)");
    } else {
        glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
        d.window = glfwCreateWindow((int)o.r.width, (int)o.r.height, "penumbra demo", NULL, NULL);
        if (!d.window)
            pn_error("demo: cannot create a %ux%u window", o.r.width, o.r.height);
        else
            exit_code = run(&d, &o, &script);
    }

    uint32_t last_width = d.image.width, last_height = d.image.height;
    // Teardown in reverse: the worker, what uses the device, the swapchain and its surface (before
    // the window they belong to), the device, the window.
    pn_demo_builder_destroy(&d.builder);
    pn_renderer_destroy(&d.renderer);
    pn_renderer_destroy(&d.exact);
    if (d.dev.device) {
        pn_shadow_accel_destroy(&d.dev, &d.accel);
        pn_swapchain_destroy(&d.swapchain);
    }
    pn_bvh_destroy(&d.bvh);
    pn_demo_image_destroy(&d.image);
    pn_gpu_device_destroy(&d.dev);
    if (d.window)
        glfwDestroyWindow(d.window);
    glfwTerminate();
    pn_scene_destroy(&d.scene);
    pn_demo_script_destroy(&script);
    pn_demo_stats_close(&d);
    if (exit_code == PN_EXIT_OK)
        print_summary(&d, &o, last_width, last_height);
    free(d.records);
    if (d.dev.validation_messages) {
        pn_error("the Vulkan validation layer reported %u message(s)", d.dev.validation_messages);
        return PN_EXIT_VALIDATION;
    }
    return exit_code;
}
