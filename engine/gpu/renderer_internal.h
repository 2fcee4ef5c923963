// What the renderer's files share (renderer.c: create and destroy; renderer_frame.c: recording,
// submit and warm-up; renderer_readback.c: the readback buffer; renderer_settings.c: the setters):
// the timestamps' and the readback buffer's layout, and the readback's recording. Not for use
// outside engine/gpu/renderer*.c.
#pragma once
#include "gpu/renderer.h"

// Timestamps: the frame's start, the G-buffer's end, then per light the ends of its shadow, filter
// and shading passes (TS_LIGHT + 3 i + TS_*).
enum { TS_START, TS_GBUFFER, TS_LIGHT, TS_SHADOW = 0, TS_FILTER = 1, TS_SHADE = 2, TS_COUNT = TS_LIGHT + 3 * PN_MAX_LIGHTS };

// The frame's images in the readback buffer, in floats per pixel: P, N, albedo and radiance (rgba),
// V and V_raw, the shadow pass's counts and its adaptive rays image (rgba32ui), the penumbra
// filter's footprint (rg) and, with desc.keep_window, its Gaussian's input (one float) and the
// shadow pass's nearest blockers (rg), which are last so that they take room only where kept
// (pn_renderer_readback_floats); with several lights each light's V and V_raw follow
// (pn_renderer_images).
enum { PN_READBACK_COUNTS = 4 * 4 + 2, PN_READBACK_RAYS = PN_READBACK_COUNTS + 4,
       PN_READBACK_FOOTPRINT = PN_READBACK_RAYS + 4, PN_READBACK_V_WINDOW = PN_READBACK_FOOTPRINT + 2,
       PN_READBACK_BLOCKERS = PN_READBACK_V_WINDOW + 1, PN_READBACK_FLOATS_PER_PIXEL = PN_READBACK_BLOCKERS + 2 };

static inline bool filtered(const pn_renderer *r) { return r->desc.filter != PN_FILTER_NONE; }
// Whether the frame keeps the penumbra filter's window (V before its Gaussian, the nearest blockers).
static inline bool keeps_window(const pn_renderer *r)
{
    return r->desc.filter == PN_FILTER_PENUMBRA && r->desc.keep_window;
}
// The frame's images' floats per pixel in the readback buffer, where the lights' planes start: the
// window's three only where kept (without them 28 floats, 112 bytes a pixel instead of 124: at
// 3840 x 2160 0.93 GB instead of 1.03).
// With the temporal history, its counts (rgba: the sums' float bits; pn_frame_images.history)
// follow them, before the lights' planes.
static inline uint32_t pn_renderer_readback_history(const pn_renderer *r)
{
    return keeps_window(r) ? PN_READBACK_FLOATS_PER_PIXEL : PN_READBACK_V_WINDOW;
}
static inline uint32_t pn_renderer_readback_floats(const pn_renderer *r)
{
    return pn_renderer_readback_history(r) + (r->history_frames ? 4 : 0);
}

// A plane of the readback buffer holds one float (or one channel) per pixel, its pixel count
// rounded up to a multiple of 4: every plane then starts 16 bytes aligned, as a copy of an RGBA32
// image must (vkCmdCopyImageToBuffer's bufferOffset, a multiple of the texel size), whatever the
// frame's size (the API's point images: any count of points).
static inline size_t pn_renderer_readback_plane(const pn_renderer *r)
{
    return ((size_t)r->width * r->height + 3) & ~(size_t)3;
}

// The readback buffer holds room for the frame's images with light_count lights (grown, never
// shrunk; renderer_readback.c).
pn_result pn_renderer_reserve_readback(pn_renderer *r, uint32_t light_count);
// Records the copies of the frame's images to the readback buffer, made visible to the host.
void pn_renderer_record_readback(pn_renderer *r, VkCommandBuffer cmd);
// Records the copy of V as the interleaved filter left it, before the penumbra filter's Gaussian
// rewrites it, and of the shadow pass's nearest blockers, which the window read, to their places in
// the readback buffer (desc.keep_window).
void pn_renderer_record_window_copy(pn_renderer *r, VkCommandBuffer cmd);
// Records the copy of light i's V (and V_raw with a filter) to its place in the readback buffer.
void pn_renderer_record_light_copy(pn_renderer *r, VkCommandBuffer cmd, uint32_t i);
