#version 460
#extension GL_GOOGLE_include_directive : require
// Geometry-aware filter of V over the interleaved-sampling tile (--filter interleaved). Every
// window of tile_w x tile_h pixels holds one pixel of each position in the tile (light_sample in
// shadow_common.glsl), so the window centred on a pixel sees spp * tile_w * tile_h light samples
// spread over the sub-cells of every cell: stratified where it covers one tile, and where it
// straddles two, each cell's sub-cell rows and columns equally often (odd square tiles, 3x3 the
// default). Neighbours count only where they continue the pixel's own surface, so a shadow does not
// leak across an edge of geometry, and only where their V could be the pixel's own up to the
// samples' noise, so a sharp shadow edge on one surface stays sharp. Background stays 0; V stays in
// [0, 1] (a weighted mean of values in [0, 1] with weights >= 0 and the pixel's own weight 1).
//
// And neighbours count only as far as V cannot change between them by more than a fraction of a
// penumbra (penumbra_weight), so that a penumbra narrower than the window keeps its shape.
//
// A pixel none of whose rays was valid (every sample below its horizon or behind the light) has no
// estimate of V: its V_raw is the convention 1. It lends nothing to its neighbours. Where the light
// does reach above its horizon (counts.z, shadow_finish), its rays only missed that sliver (rare:
// they are drawn in the box of the part above, horizon_box, which that part fills at least half
// of; it takes fewer than 4 samples, or the budgeted split's single rays), and it takes its
// neighbours' V on the same surface: the converged V there is the sliver's, and a grazing
// sliver is mostly blocked, which the convention's 1 contradicts. Where the light cannot reach it,
// it keeps the convention: V carries no light there.
#include "interface.h"
#include "filter_common.glsl"

layout(local_size_x = PN_ROW_GROUP) in;

layout(set = 0, binding = PN_FILTER_BINDING_P, rgba32f) uniform readonly image2D img_p;
layout(set = 0, binding = PN_FILTER_BINDING_N, rgba32f) uniform readonly image2D img_n;
layout(set = 0, binding = PN_FILTER_BINDING_V_RAW, r32f) uniform readonly image2D img_v_raw;
layout(set = 0, binding = PN_FILTER_BINDING_V, r32f) uniform writeonly image2D img_v;
layout(set = 0, binding = PN_FILTER_BINDING_COUNTS, rgba32ui) uniform readonly uimage2D img_counts;
layout(set = 0, binding = PN_FILTER_BINDING_BLOCKERS, rg32f) uniform readonly image2D img_blockers;
// With the penumbra filter (pc.narrow > 0): its footprint and whether the pixel lends its V, for
// its Gaussian (penumbra_filter.comp), written here where the pixel's counts and blockers are read
// anyway: a dispatch of its own cost lavapipe about as much as one of the Gaussian's.
layout(set = 0, binding = PN_FILTER_BINDING_SIGMA, rg32f) uniform writeonly image2D img_sigma;
// With the penumbra filter: the tiles a pixel with a blocker lends its footprint to (below), marked
// and listed once each: the Gaussian runs only there.
layout(set = 0, binding = PN_FILTER_BINDING_TILES, r32ui) uniform uimage2D img_tiles;
// With the penumbra filter: the row pass's output, where it is not the frame's clear value
// (PN_PENUMBRA_SCRATCH_CLEAR): the row pass writes it only in the marked blocks.
layout(set = 0, binding = PN_FILTER_BINDING_SCRATCH, rg32f) uniform writeonly image2D img_scratch;
layout(set = 0, binding = PN_FILTER_BINDING_LIST, std430) buffer TileList
{
    uint groups[PN_TILE_LIST_HEADER]; // VkDispatchIndirectCommand: the count of tiles, 1, 1
    uint tiles[];                     // x | y << 16
} list;

layout(push_constant) uniform FilterPushBlock { FilterPush pc; };
// The window, fixed per pipeline (filter_pass.c builds one for the tile in use): with constant
// bounds the compiler unrolls the loops and keeps the window's weights in registers. Measured on
// lavapipe (bench, buddha, line space, 4 spp, 512 x 512): the pass took 12.3 ms with the window in
// push constants and 9.0 ms specialised.
layout(constant_id = PN_SPEC_TILE_W) const int TILE_W = 3;
layout(constant_id = PN_SPEC_TILE_H) const int TILE_H = 3;
// With the temporal history (history.comp) the counts are its sums over the frames, as float bits
// (their x and y; z and w this frame's), and a pixel's samples are its own sum: a pixel with long
// history is filtered as its many samples allow, one just uncovered as its frame's few.
layout(constant_id = PN_SPEC_FILTER_TEMPORAL) const bool TEMPORAL = false;
// The visible and valid samples of counts c. Either way 0 is the bits 0 and equal sums equal bits,
// so the tests of counts against 0 and each other below hold for both.
vec2 sums(uvec4 c) { return TEMPORAL ? uintBitsToFloat(c.xy) : vec2(c.xy); }

// How much of a neighbour q the pixel p may take, from how far V can differ between them on one
// surface: V runs from 0 to 1 across a penumbra's width (the narrower of the two pixels', from
// their mean blocker: shadow_finish), so over their distance it changes by up to distance / width.
// The weight is 1 where that is nothing and falls to 0 once it reaches PENUMBRA_TOLERANCE.
// Averaging across a penumbra narrower than the window blurs a sharp shadow: a contact shadow most
// of all, where the blocker touches the receiver and the width goes to 0. The range weight (below)
// cannot see that at a few samples, where the noise is as large as the step. Where no blocker is
// near, V is smooth and the window averages freely. Dimensionless: the same at every scale.
// Measured (bench, exact, 4 spp, default scene; edge leak / reference MAE): without this weight
// 3.2% / 0.0089; tolerance 1: 2.0% / 0.0088; 0.5: 0.8% / 0.0088; 0.25: 0.7% / 0.0091 (the
// window no longer averages the noise away).
//
// Under the penumbra filter it acts only near an edge of geometry: within the window (any
// --tile; an even one reaches one pixel further right and down) or within CONTACT_REACH pixels (the
// ring below, which adds nothing to windows of 5 x 5 and more). A
// penumbra narrower than the window is cast by a blocker close to the receiver, and a blocker that
// close shows in the picture beside it: at a contact, a crease or a step in depth the window
// meets. Elsewhere the width comes from the nearest blocker of one pixel's few rays, which at 1-4
// samples misjudges it: one ray that meets a bump's or a crease's own shadow makes it tiny where V
// is smooth at the pixel's scale, and refusing the neighbours then leaves the pixel with its own
// few samples. The Gaussian that follows (penumbra_filter.comp) still takes the narrower
// footprint, and the range weight still refuses what the samples say differs. Measured (bench,
// 512 x 512, exact, the default 3 x 3 window, the five standard views, reference MAE at 1 / 2 / 4
// spp, edge leak at 1 spp; before: stop 53 with narrowest_neighbour, penumbra_filter.comp):
// the bunny 0.0172 / 0.0109 / 0.0067 -> 0.0157 / 0.0100 / 0.0064 (leak 0.77 -> 0.86%), the dragon
// 0.0136 / 0.0091 / 0.0058 -> 0.0125 / 0.0085 / 0.0057 (0.82 -> 0.93%), the buddha 0.0108 ->
// 0.0104, Sponza and the canopy within 0.0002 (the canopy's leak 0.21 -> 0.44%); with --seed 2
// alike (the bunny's leak 0.90 -> 0.98%). Refusing nowhere instead: the bunny 0.0147, the dragon
// 0.0110 at 1 spp, but a leak of 1.4-2.9% on the meshes; only within 1 pixel of an edge (the
// window itself): 1.45-1.66%.
const float PENUMBRA_TOLERANCE = 0.5;
const int CONTACT_REACH = 2;
// A neighbour whose surface weight (filter_common.glsl: (1 - rho^2) c^2) is below this does not
// continue the pixel's surface: on its own, normals more than 30 degrees apart (c^2 < 3/4), or
// either point off the other's tangent plane by more than half a footprint per pixel between them
// (rho > 1/2); a mix of the two below either bound. The pixel's own tap counts only where its
// normal is not a unit vector (a degenerate triangle's): the weight then acts as before stop 54.
const float SURFACE_CONTINUES = 0.75;
// Whether a pixel inside the image (coverage q.w, surface weight w against the pixel's) shows an
// edge of geometry: the background, or a surface that does not continue the pixel's.
bool shows_edge(float coverage, float w) { return coverage <= 0.0 || w < SURFACE_CONTINUES; }
float penumbra_weight(vec3 p, uint width_p, vec3 q, uint width_q)
{
    float width = min(uintBitsToFloat(width_p), uintBitsToFloat(width_q)) * PENUMBRA_TOLERANCE;
    // Scaled before squaring, so that neither overflows nor underflows; 0 for a point light's
    // (width 0: V is a step).
    vec3 r = width > 0.0 ? (q - p) / width : vec3(1.0);
    return max(1.0 - dot(r, r), 0.0);
}

// The window's first offset: odd tiles are centred, even ones reach one pixel further right and
// down. Scalars: the validation layer's folding of specialisation constants takes no vectors.
const int LO_X = -(TILE_W - 1) / 2, LO_Y = -(TILE_H - 1) / 2;

// Whether every pixel of the window with an estimate of V saw all of its rays blocked (dark) or
// none (filtered's lit and dark windows).
bool window_agrees(ivec2 px, ivec2 size, bool dark)
{
    bool same = true;
    for (int dy = LO_Y; dy < LO_Y + TILE_H; dy++) {
        for (int dx = LO_X; dx < LO_X + TILE_W; dx++) {
            uvec2 cq = imageLoad(img_counts, clamp(px + ivec2(dx, dy), ivec2(0), size - 1)).xy;
            same = same && (cq.y == 0u || cq.x == (dark ? 0u : cq.y));
        }
    }
    return same;
}

// A pixel's outputs: V, and with the penumbra filter its footprint and whether it lends V (sigma).
void store(ivec2 px, float v, vec2 sigma)
{
    imageStore(img_v, px, vec4(v));
    if (pc.narrow > 0.0)
        imageStore(img_sigma, px, vec4(sigma, 0.0, 0.0));
}

void covered_or_not(ivec2 px, ivec2 size);
void covered(ivec2 px, ivec2 size, uvec4 counts_p, float width_near);
void covered_pixel(ivec2 px, ivec2 size, vec4 p, uvec4 counts_p, float width_near);
float filtered(ivec2 px, ivec2 size, vec4 p, uvec4 counts_p, float width_near, float own_samples);
float window_mean(ivec2 px, ivec2 size, vec4 p, uvec4 counts_p, float width_near, float own_samples);

void main()
{
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(img_v);
    if (all(lessThan(px, size)))
        covered_or_not(px, size);
}

// Every exit below is structured (no early return): llvmpipe miscompiled the early returns of this
// pass once functions were inlined into it (pixels without a valid ray took their neighbours'
// V where the convention's 1 was theirs: engine/gpu/llvmpipe.md, fact 7).
void covered_or_not(ivec2 px, ivec2 size)
{
    uvec4 counts_p = imageLoad(img_counts, px);
    // The penumbra filter's: from the nearest blocker's penumbra (-1 without a blocker, and without
    // a valid ray); a pixel lends its V where it has an estimate.
    float width_near = pc.narrow > 0.0 ? imageLoad(img_blockers, px).y : PN_PENUMBRA_NONE;
    // Lit, with its window (filtered): V is 1 and it has no footprint, without its position and
    // normal (a pixel with rays is covered: shadow_frame.glsl). Most of an image, and these passes
    // are bound by their own pixels' loads and stores (engine/gpu/llvmpipe.md): under the penumbra
    // filter the frame cleared V and the footprints to these (PN_PENUMBRA_LIT_V, _FOOTPRINT), and
    // the pixel stores nothing.
    if (counts_p.y > 0u && counts_p.x == counts_p.y && width_near >= PN_PENUMBRA_NONE && pc.samples > 0u &&
        window_agrees(px, size, false)) {
        if (pc.narrow <= 0.0)
            store(px, 1.0, vec2(PN_PENUMBRA_LIT_FOOTPRINT, 1.0));
    } else
        covered(px, size, counts_p, width_near);
}

// A pixel whose window is not all lit: the background's V is 0, a covered pixel's filtered.
void covered(ivec2 px, ivec2 size, uvec4 counts_p, float width_near)
{
    vec4 p = imageLoad(img_p, px);
    if (p.w <= 0.0)
        store(px, 0.0, vec2(0.0));
    else
        covered_pixel(px, size, p, counts_p, width_near);
}

void covered_pixel(ivec2 px, ivec2 size, vec4 p, uvec4 counts_p, float width_near)
{
    bool unknown = counts_p.y == 0u; // no valid ray: no estimate of V
    vec4 n = imageLoad(img_n, px);
    float footprint_p = n.w * pc.pixel_angle;
    // Adaptive: the pixel's valid rays, at least the first round's (as uniform samples count a pixel
    // whose rays fell partly below its horizon), so that a pixel no round refined is filtered as in
    // the uniform frame of MIN samples, whose rays its first round's are.
    // With history, its sum, at least the frame's own (a point light's V, samples 0, has no noise).
    float own_samples = (pc.adaptive != 0u || TEMPORAL) && pc.samples > 0u ? max(sums(counts_p).y, float(pc.samples))
                                                                            : float(pc.samples);
    vec2 sigma = vec2(0.0);
    if (pc.narrow > 0.0) {
        // What the pixel lends the Gaussian (penumbra_filter.comp): 1 its V, an estimate of its own;
        // 0.5 a V this window takes from its neighbours below (no valid ray, but the light reaches
        // above its horizon), lent along columns only, after the row pass; 0 nothing (the light
        // cannot reach it: V is the convention 1).
        sigma = vec2(unknown ? -1.0 : penumbra_footprint(width_near, footprint_p, own_samples, pc.width_scale, pc.max_radius),
                     unknown ? (counts_p.z != 0u ? 0.5 : 0.0) : 1.0);
        // A pixel with a blocker of its own lends its footprint to the pixels without one up to
        // PN_PENUMBRA_LEND_REACH away (narrowest_neighbour in penumbra_filter.comp): it marks the
        // tiles those lie in (at most 2 x 2, a bit each in their block's texel), and the first to
        // mark a block lists it. Only in a marked tile does a pixel have a footprint, its own or
        // lent, so only there can the Gaussian change one: its two passes run over the listed
        // blocks alone, and search a lit pixel's neighbours only in a marked tile. Every pixel
        // with a blocker takes this (one to four atomics: about 1.4 ms of builtin:default's 1280
        // x 720 frame).
        if (sigma.x >= 0.0) {
            const ivec2 TILE = ivec2(PN_PENUMBRA_MARK_W, PN_PENUMBRA_BLOCK_H);
            const int PER_BLOCK = PN_PENUMBRA_BLOCK_W / PN_PENUMBRA_MARK_W;
            ivec2 lo = max(px - PN_PENUMBRA_LEND_REACH, ivec2(0)) / TILE;
            ivec2 hi = min(px + PN_PENUMBRA_LEND_REACH, size - 1) / TILE;
            for (int ty = lo.y; ty <= hi.y; ty++)
                for (int tx = lo.x; tx <= hi.x; tx++) {
                    ivec2 block = ivec2(tx / PER_BLOCK, ty);
                    uint bit = 1u << uint(tx % PER_BLOCK);
                    // A load first: most of a tile's blockers find it marked, and spare the atomic.
                    if ((imageLoad(img_tiles, block).x & bit) == 0u && imageAtomicOr(img_tiles, block, bit) == 0u)
                        list.tiles[atomicAdd(list.groups[0], 1u)] =
                            uint(block.x * PN_PENUMBRA_BLOCK_W) | uint(block.y * PN_PENUMBRA_BLOCK_H) << 16;
                }
        }
    }
    float v = filtered(px, size, p, counts_p, width_near, own_samples);
    store(px, v, sigma);
    // What the row pass would leave outside the marked blocks (penumbra_filter.comp's row_value, no
    // footprint), where the clear value is not it. Outside them a pixel with a valid ray has V 1
    // and lends it, the clear value, wherever the window reaches no further than the marks
    // (PN_PENUMBRA_LEND_REACH): a blocked ray in its window would have marked its block. So only a
    // pixel without one stores it (or every pixel, under a wider window); in a marked block the
    // row pass rewrites it. A store for every pixel cost about 5 ms at 1280 x 720.
    const bool WIDE = max(TILE_W, TILE_H) > 2 * PN_PENUMBRA_LEND_REACH + 1;
    float row_out = sigma.y > 0.0 ? v : -v;
    if (pc.narrow > 0.0 && (unknown || WIDE) && row_out != PN_PENUMBRA_SCRATCH_CLEAR)
        imageStore(img_scratch, px, vec4(row_out, 0.0, 0.0, 0.0));
}

// V of a covered pixel p (counts counts_p, nearest blocker's penumbra width_near, samples
// own_samples: main's): the window's geometry- and V-weighted mean.
float filtered(ivec2 px, ivec2 size, vec4 p, uvec4 counts_p, float width_near, float own_samples)
{
    bool unknown = counts_p.y == 0u;
    float v;
    if (unknown && counts_p.z == 0u)
        v = imageLoad(img_v_raw, px).x;
    // Lit or in umbra with its whole window: where every pixel of the window with an estimate saw
    // the pixel's V of 1 (or 0), every weighted mean of them below is that V, bit for bit (the sums
    // of w and of w V are the same numbers). The window's counts tell it (pixels off the image or
    // on the background have no rays: counts 0), without the positions and normals: a third of the
    // window's loads, for most of an image. Taps clamped to the image's edge only count twice.
    // llvmpipe: the full window below runs for the 8 pixels of a SIMD group unless all of them
    // leave here. Measured with penumbra_filter.comp's early exit (bench, 512 x 512, exact, 1 and
    // 4 spp, the penumbra filter's whole pass, two runs alternated, V the same bit for bit): the
    // bunny 22.4 -> 17.9 ms, dragon 22.2 -> 16.0; Sponza 29.2 -> 29.2 (its wide penumbrae leave
    // few windows all lit or all dark at 1-4 spp).
    else if (!unknown && (counts_p.x == 0u || counts_p.x == counts_p.y) && window_agrees(px, size, counts_p.x == 0u))
        v = counts_p.x == 0u ? 0.0 : 1.0;
    else
        v = window_mean(px, size, p, counts_p, width_near, own_samples);
    return v;
}

// filtered's: the window's mean.
float window_mean(ivec2 px, ivec2 size, vec4 p, uvec4 counts_p, float width_near, float own_samples)
{
    bool unknown = counts_p.y == 0u;
    vec4 n = imageLoad(img_n, px); // covered_pixel's load again: in the cache
    float footprint_p = n.w * pc.pixel_angle;
    // Under the penumbra filter (pc.narrow > 0) the window's weights also fall as a Gaussian of
    // world distance: narrow x n^-3/4 of the nearest blocker's penumbra (pn_penumbra_window_scale).
    // At a few samples it is pixels wide and the window averages as before; as the samples grow
    // it narrows below a pixel, so that the window's average, like the penumbra filter's Gaussian,
    // converges to the unfiltered V (measured: on the canopy view at 256 x 256 and 256 spp the
    // fixed window's MAE was 0.0037 against unfiltered's 0.0029, narrowing 0.0024). A pixel
    // without a blocker of its own (or with no estimate) keeps the window.
    //
    // The penumbra counts as at least a pixel wide (since stop 56): the window's Gaussian is never
    // narrower than pc.narrow (2) pixels x n^-3/4 (at 1 spp two pixels, at 4 spp 0.7: the
    // neighbours' weight 0.37 along the axes; from 16 spp a quarter of a pixel, which leaves the
    // neighbours nothing, exp(-8), so convergence is as before; the demo's accumulation narrows it
    // with pc.narrow). The nearest blocker of a pixel's few rays may lie a hair away (a bump's or a
    // crease's own shadow: a penumbra under a pixel wide) where V is smooth at the pixel's scale,
    // and the window then kept the pixel's one ray: on the dragon at 1 spp 9.7% of the reference
    // error sat in pixels away from an edge of geometry whose blocker cast under half a pixel, at V
    // 0.02 where the reference is 0.27. Where the shadow is truly that sharp a blocker that close
    // shows beside it, and the penumbra weight refuses there (the edge rule below); the range
    // weight refuses what the samples say differs. Measured (bench, 512 x 512, exact, the five
    // standard views, reference MAE at 1 / 2 / 4 spp, seed 1, with the Gaussian's ring 2 pixels
    // away, penumbra_filter.comp): the bunny 0.0139 / 0.0092 / 0.0061 -> 0.0131 / 0.0086 / 0.0056,
    // the dragon 0.0115 / 0.0081 / 0.0054 -> 0.0111 / 0.0076 / 0.0051, the buddha 0.0101 / 0.0062
    // / 0.0041 -> 0.0098 / 0.0061 / 0.0039, Sponza and the canopy within 0.0001; 8 and 16 spp
    // within 0.0001; the edge leak at 1 spp at most 0.85% (seed 2: 0.94%, the bunny). Half a pixel
    // gains only at 1 spp; 1.5 and 2 pixels no more than 1, with more leak; 2 pixels x n^-1/2 the
    // same as n^-3/4 at 1-4 spp.
    float narrow = -1.0;
    if (pc.narrow > 0.0 && pc.samples > 0u && !unknown)
        narrow = width_near >= PN_PENUMBRA_NONE ? -1.0
                                                : pc.narrow * max(width_near, footprint_p) * pow(own_samples, -0.75);
    // First the geometry's weights (and the window's V under them), then V's own: see below.
    float wg[TILE_W * TILE_H], vq[TILE_W * TILE_H], pw[TILE_W * TILE_H];
    bool refuses = false, near_edge = false;
    int k = 0;
    for (int dy = LO_Y; dy < LO_Y + TILE_H; dy++) {
        for (int dx = LO_X; dx < LO_X + TILE_W; dx++, k++) {
            // Loaded unconditionally (clamped to the image) and discarded after: lavapipe runs
            // invocations side by side in SIMD lanes, where a branch around the loads costs more
            // than the loads (measured: 13.5 ms branching, 12.3 ms not, same window).
            ivec2 qx = clamp(px + ivec2(dx, dy), ivec2(0), size - 1);
            vec4 q = imageLoad(img_p, qx);
            uvec4 counts_q = imageLoad(img_counts, qx);
            vec4 m = imageLoad(img_n, qx);
            // Inside the image, not background, and with an estimate of V (a valid ray).
            bool usable = qx == px + ivec2(dx, dy) && q.w > 0.0 && counts_q.y > 0u;
            float pixels = float(max(abs(dx), abs(dy)));
            // On the pixel's own surface (filter_common.glsl).
            float w = surface_weight(p.xyz, n.xyz, footprint_p, q.xyz, m.xyz, m.w * pc.pixel_angle, pixels);
            near_edge = near_edge || (qx == px + ivec2(dx, dy) && shows_edge(q.w, w));
            // A pixel without an estimate of its own takes its neighbours' V however steep: any of
            // it is nearer than the convention's 1.
            pw[k] = unknown ? 1.0 : penumbra_weight(p.xyz, counts_p.w, q.xyz, counts_q.w);
            refuses = refuses || (usable && pw[k] < 1.0);
            if (narrow >= 0.0 && (dx != 0 || dy != 0)) {
                // Scaled before squaring: nothing overflows or underflows.
                vec3 x = narrow > 0.0 ? (q.xyz - p.xyz) / narrow : vec3(0.0);
                w *= narrow > 0.0 ? exp(-0.5 * dot(x, x)) : 0.0;
            }
            wg[k] = usable ? w : 0.0;
            // V_raw as shadow_finish wrote it (visible / valid), from the counts already loaded.
            vec2 sq = sums(counts_q);
            vq[k] = usable ? sq.x / sq.y : 0.0;
        }
    }
    // Under the penumbra filter the penumbra weight refuses only near an edge of geometry (above):
    // the window's pixels tell within one pixel; beyond it, where the weight would refuse a
    // neighbour and the window showed no edge, the eight pixels CONTACT_REACH away along the axes
    // and diagonals. An edge that passes within CONTACT_REACH pixels but outside the window
    // crosses the ring of sixteen around it, and these eight catch it but where it only grazes a
    // corner. Measured against all sixteen: the same MAE and edge leak to the digits above on the
    // five views, the filter pass 20.5 against 21.0 ms before this rule (mean of 45 cells, three
    // alternated runs), where all sixteen cost 2-7 ms more.
    if (pc.narrow > 0.0 && refuses && !near_edge) {
        for (int dy = -CONTACT_REACH; dy <= CONTACT_REACH; dy += CONTACT_REACH) {
            for (int dx = -CONTACT_REACH; dx <= CONTACT_REACH; dx += CONTACT_REACH) {
                ivec2 d = ivec2(dx, dy), qx = clamp(px + d, ivec2(0), size - 1);
                if ((dx == 0 && dy == 0) || qx != px + d)
                    continue;
                vec4 q = imageLoad(img_p, qx), m = imageLoad(img_n, qx);
                float w = surface_weight(p.xyz, n.xyz, footprint_p, q.xyz, m.xyz, m.w * pc.pixel_angle,
                                         float(max(abs(dx), abs(dy))));
                near_edge = near_edge || shows_edge(q.w, w);
            }
        }
    }
    bool guard = pc.narrow <= 0.0 || near_edge;
    float sum = 0.0, weight = 0.0;
    for (int j = 0; j < k; j++) {
        wg[j] *= guard ? pw[j] : 1.0;
        sum += wg[j] * vq[j];
        weight += wg[j];
    }
    // Without an estimate of its own, the geometric mean of its neighbours' (the convention 1 if
    // none has one).
    float v = 1.0;
    if (unknown) {
        v = weight > 0.0 ? clamp(sum / weight, 0.0, 1.0) : 1.0;
    } else {
        float v_p = vq[-LO_Y * TILE_W - LO_X]; // the pixel's own tap (dx = dy = 0), covered and inside
        // V's own weight (a cross-bilateral range term): a shadow edge sharper than the window (a contact
        // shadow, the sharp end of a penumbra) must not be averaged away. One pixel's V is the mean of
        // `samples` Bernoulli trials, so where the window's pixels see the same V (estimated by `mean`,
        // their geometry-weighted V) one pixel's standard deviation is sigma = sqrt(V (1 - V) / samples)
        // and two pixels differ by sigma sqrt 2. They differ by more than RANGE_SIGMAS times that with a
        // probability of about 1% (a normal tail; stratification only narrows it), so a neighbour that far
        // from the pixel sees another V: a shadow edge lies between them. The weight falls from 1 at equal
        // V to 0 there. Pixels with fewer valid rays (samples below their horizon) are noisier than this
        // assumes and are filtered a little less. All dimensionless: the same at every scale. Measured
        // (bench, standard views, 4 and 16 spp): 2.5 sigmas keeps the MAE of 3 and halves the edge leak;
        // 2 cuts the leak again but loses 4 spp's noise reduction; 4 blurs contact shadows again.
        const float RANGE_SIGMAS = 2.5;
        float mean = weight > 0.0 ? clamp(sum / weight, 0.0, 1.0) : v_p;
        // samples = 0: V has no noise (a point light), so only equal V averages and V stays as it is.
        // Adaptive sampling: each pixel's own valid rays, at least the first round's (own_samples).
        float samples = own_samples;
        // One sample a pixel (since stop 57), under the penumbra filter and away from edges of geometry
        // (the edge rule's near_edge): V is 0 or 1, and two pixels that see the same V differ by 1 with
        // a probability of 2 V (1 - V), one in five at V = 0.9. The window's mean over 9 single samples
        // cannot tell that V: at a mean of 0.9 the test above refused a neighbour that differs by 1
        // (weight 0.11), so a pixel whose one ray passed by luck on the lit side of a penumbra kept its
        // 1. There V's variance is taken at its largest, 1/4, whatever the mean: such a neighbour
        // weighs 0.68. Under adaptive sampling (1:MAX) for a pixel its first round left at one sample:
        // its neighbours mostly hold one too, and a refined one's V is nearer its mean, which 1/4
        // bounds the variance of as well. Measured (bench, 512 x 512, exact, the five standard views,
        // reference MAE at 1 spp, seeds 1 / 2): the bunny 0.0131 / 0.0131 -> 0.0123 / 0.0122, the
        // dragon 0.0111 / 0.0112 -> 0.0108 / 0.0109, the buddha 0.0098 / 0.0099 -> 0.0098 / 0.0098,
        // Sponza 0.0150 / 0.0151 -> 0.0137 / 0.0138, the canopy 0.0264 / 0.0258 -> 0.0267 / 0.0261; the
        // edge leak at most 0.97% (the dragon, seed 1; the bunny, seed 2). Tried and dropped: the same
        // at 2 samples as well, the bunny and Sponza lower but the buddha 0.0061 -> 0.0063, and at 4,
        // higher on three views (the buddha 0.0039 -> 0.0042); no range weight at all at one sample
        // away from edges, Sponza 0.0117 but the canopy 0.0278 and the dragon's leak 1.03%; near edges
        // too, leaks of 1.1-1.3%.
        float var = mean * (1.0 - mean);
        if (pc.narrow > 0.0 && pc.samples == 1u && own_samples == 1.0 && !near_edge)
            var = 0.25;
        float spread = pc.samples == 0u ? 0.0 : RANGE_SIGMAS * sqrt(2.0 * var / samples);
        sum = 0.0;
        weight = 0.0;
        for (int j = 0; j < k; j++) {
            float d = abs(vq[j] - v_p);
            float r = d / max(spread, 1e-30);
            float w = wg[j] * (d == 0.0 ? 1.0 : max(1.0 - r * r, 0.0));
            sum += w * vq[j];
            weight += w;
        }
        // weight is about 1 or more: the pixel itself has rho = 0, c = 1 and d = 0, unless its normal is
        // not a unit vector (a degenerate triangle's); then it keeps its own V.
        v = weight > 0.0 ? clamp(sum / weight, 0.0, 1.0) : v_p;
    }
    return v;
}
