#version 460
#extension GL_GOOGLE_include_directive : require
// The penumbra filter (--filter penumbra): after the interleaved filter's 3x3 window (filter.comp),
// a Gaussian as wide as the penumbra the pixel lies in, so that a penumbra tens of pixels wide is
// averaged over tens of pixels' samples instead of nine.
//
// The footprint. A blocker at segment parameter t casts a penumbra of width W = L t / (1 - t) on
// the receiver (L the light's extent seen from it: penumbra_width_of in shadow_frame.glsl); V runs
// across it from 0 to 1, so W bounds how fast V can vary at the pixel: the nearest of the pixel's
// blockers casts the narrowest penumbra and sets the bound (as axis-aligned filtering, Mehta, Wang
// and Ramamoorthi 2012, takes the largest of the blockers' slopes). The Gaussian's standard
// deviation, in world units on the receiver, is a share of it, width_scale / sqrt(n) with the
// pixel's n samples, at most max_radius / RADIUS_SIGMAS pixels. Its bias grows with its width
// (where V bends, at a penumbra's ends), and it must fall at least as fast as the noise it removes
// for filtered and unfiltered V to converge together: n^-1/4, the mean-square balance of a bend's
// bias (~ sigma) against the noise (~ 1 / (sigma^2 n)), kept a bias at 256 spp on the analytic
// penumbra (tests/test_penumbra_filter.c: 0.00035 against unfiltered's 0.00019), while n^-1/2
// leaves the footprint below half a pixel there. A contact shadow, whose blocker touches the
// receiver, has W -> 0 and stays sharp; a point light's V (samples 0) is exact and is left alone.
//
// Pixels whose rays met no blocker have no footprint of their own. At a penumbra's edge one pixel's
// few rays all pass by luck, and left alone it shows as a lit speck: such a pixel whose 3 x 3
// neighbours (the interleaving window; failing them, the outer ring of the 5 x 5) include one with
// a blocker takes the narrowest of their footprints (narrowest_neighbour: the nearest blocker any
// of the window's rays met bounds how fast V varies there, as a pixel's own nearest blocker does
// for it); and it lends its V to a penumbra pixel under that pixel's footprint. Measured with the
// widest of the footprints (the rule before stop 54; bench, the five standard views at 256 x 256,
// exact, reference MAE, 1 / 4 spp): against no dilation, the bunny 0.0215 / 0.0079 (0.0269 /
// 0.0090), the dragon 0.0177 / 0.0073 (0.0217 / 0.0077), the canopy 0.0431 / 0.0253 (0.0641 /
// 0.0255), Sponza 0.0270 / 0.0063 (0.0290 / 0.0060); a 5 x 5 ring lost on Sponza and the buddha at
// 1 spp (0.0332, 0.0178), and giving every pixel the widest footprint whose Gaussian reaches it (a
// dilation per 8 x 8 tile) more (at 1 spp the buddha 0.028 against 0.0175, Sponza 0.044 against
// 0.029): lit pixels beside an umbra whose nearest blocker casts a wide penumbra are pulled down,
// where one ray's noise leaves the range weight nothing to refuse.
//
// The Gaussian is separable, rows then columns, each tap weighted as the interleaved filter weighs
// its window (the same surface: filter_common.glsl) and by V itself (a neighbour whose V differs
// from the pixel's by more than its samples' noise allows lies across an edge the footprint did
// not see). Its cost is linear in the radius, clamped to max_radius pixels (the frame's budget).
// All weights are dimensionless: the same at every scale.
#include "interface.h"
#include "filter_common.glsl"

// A row of a block of PN_PENUMBRA_BLOCK_W x PN_PENUMBRA_BLOCK_H pixels (main).
layout(local_size_x = PN_PENUMBRA_BLOCK_W) in;

layout(set = 0, binding = PN_PENUMBRA_BINDING_P, rgba32f) uniform readonly image2D img_p;
layout(set = 0, binding = PN_PENUMBRA_BINDING_N, rgba32f) uniform readonly image2D img_n;
layout(set = 0, binding = PN_PENUMBRA_BINDING_COUNTS, rgba32ui) uniform readonly uimage2D img_counts;
layout(set = 0, binding = PN_PENUMBRA_BINDING_V, r32f) uniform image2D img_v;
layout(set = 0, binding = PN_PENUMBRA_BINDING_SIGMA, rg32f) uniform image2D img_sigma;
layout(set = 0, binding = PN_PENUMBRA_BINDING_SCRATCH, rg32f) uniform image2D img_scratch;
layout(set = 0, binding = PN_PENUMBRA_BINDING_TILES, r32ui) uniform readonly uimage2D img_tiles;
layout(set = 0, binding = PN_PENUMBRA_BINDING_LIST, std430) readonly buffer TileList
{
    uint groups[PN_TILE_LIST_HEADER];
    uint tiles[]; // each block's first pixel, x | y << 16
} list;

layout(push_constant) uniform PenumbraPushBlock { PenumbraPush pc; };
// With the temporal history the counts are its sums, as float bits (filter.comp's TEMPORAL): a
// pixel's samples are its sum over the frames.
layout(constant_id = PN_SPEC_PENUMBRA_TEMPORAL) const bool TEMPORAL = false;
// The stage, a pipeline each (penumbra_pass.c): llvmpipe runs both sides of an `if` (and of each
// `rows ?` below), so one pipeline for both stages did each stage's work and most of the other's.
layout(constant_id = PN_SPEC_PENUMBRA_STAGE) const uint STAGE = PN_PENUMBRA_STAGE_BLUR_X;

const float RADIUS_SIGMAS = PN_PENUMBRA_RADIUS_SIGMAS;
// Below half a pixel the Gaussian adds nothing to the interleaved filter's window.
const float MIN_SIGMA = 0.5;
// As filter.comp's range weight: a neighbour further than this many standard deviations of the
// difference of two pixels' V lies across an edge.
const float RANGE_SIGMAS = 2.5;
// The V this pass reads is the interleaved filter's, a weighted mean over up to 9 pixels' samples:
// its noise is that of about WINDOW_SAMPLES times the pixel's own samples. Measured (bench, the
// five standard views at 256 x 256, exact, 1 / 4 / 16 spp, reference MAE): 1 (one pixel's noise,
// a looser range weight) 0.0272 / 0.0090 / 0.0036 on the bunny and 0.0297 / 0.0066 / 0.0028 on
// Sponza; 3: 0.0269 / 0.0089 / 0.0035 and 0.0290 / 0.0062 / 0.0027, and lower on the dragon and
// buddha too; 9 (the whole window) higher again on all five at 1 spp.
const float WINDOW_SAMPLES = 3.0;

int reach(float sigma) { return min(int(ceil(PN_PENUMBRA_TAP_SIGMAS * sigma)), int(pc.max_radius)); }

// The samples one pixel's V is the mean of (adaptive sampling: its own valid rays, at least the first
// round's, as filter.comp counts them; with history, its sum over the frames, at least the frame's).
float pixel_samples(ivec2 px)
{
    if (TEMPORAL && pc.samples > 0u)
        return max(uintBitsToFloat(imageLoad(img_counts, px).y), float(pc.samples));
    return pc.adaptive != 0u ? float(max(imageLoad(img_counts, px).y, max(pc.samples, 1u))) : float(pc.samples);
}

// A pixel's footprint (world units, 0 without a blocker of its own) and whether it lends its V.
vec2 pixel_footprint(ivec2 px)
{
    vec2 s = imageLoad(img_sigma, px).xy;
    return vec2(max(s.x, 0.0), s.y);
}

// The narrowest footprint among a pixel's 3 x 3 neighbours with a blocker of their own, or where
// none has one among the 16 pixels of the 5 x 5's outer ring (0 if none of those has one either):
// the footprint of the pixel the Gaussian is centred on where it has no blocker of its own. Its
// rays all passed, but a neighbour's were blocked: it lies at a penumbra's edge, where one pixel's
// few rays all pass by luck. The nearest of the neighbours' blockers bounds how fast V can vary
// around it, as the pixel's own nearest blocker would. Before, the widest of them: where a far
// blocker's wide penumbra overlaps a near one's sharp shadow (a bumpy surface lit at a grazing
// angle), a lit pixel took the wide footprint and its Gaussian reached into the sharp shadow.
// Measured (bench, 512 x 512, exact, the five standard views, 1 / 2 / 4 spp, seeds 1 and 2): the
// edge leak fell on every mesh (seed 1: the bunny 0.83 / 0.73 / 0.62% -> 0.77 / 0.62 / 0.54%, the
// dragon 0.87 / 0.82 / 0.64% -> 0.82 / 0.68 / 0.53%; seed 2 alike), the canopy's stayed, and the
// reference MAE is within 0.0001 of before in every cell. A neighbour's footprint was clamped to
// max_radius / RADIUS_SIGMAS of that neighbour's pixels (filter.comp), so at a step in depth it can
// exceed the clamp in this pixel's: blur clamps it again (to this pixel's footprint facing the
// camera), so that the reach (PN_PENUMBRA_TAP_SIGMAS deviations) always fits max_radius.
//
// The 5 x 5's outer ring, since stop 56: on the lit side of a penumbra (V about 0.9) all nine of a
// window's rays pass at 1 spp with a probability of about 0.9^9 = 0.39, and such a pixel kept V = 1
// (on the dragon at 1 spp, 19.6% of the reference error sat in those pixels, 0.094 each). Only
// where the 3 x 3 has no blocker, and the narrowest of the ring's, so that no pixel's footprint is
// wider than before. Measured (bench, 512 x 512, exact, the five standard views, reference MAE at 1
// / 2 / 4 spp, seed 1): the bunny 0.0158 / 0.0099 / 0.0064 -> 0.0139 / 0.0092 / 0.0061, the dragon
// 0.0124 / 0.0084 / 0.0055 -> 0.0115 / 0.0081 / 0.0054, the buddha 0.0105 / 0.0064 / 0.0041 ->
// 0.0101 / 0.0062 / 0.0041, Sponza and the canopy within 0.0002 (seed 2 alike); the edge leak at 1
// spp at most 0.84% (seed 2: 0.91%, the bunny), the filter pass 1-3 ms more (the ring's 16 loads).
// The rings 3 and 4 pixels away further out gain under 0.0003 more. The 5 x 5 ring that lost before
// (above) took the widest footprint of all 24 pixels, for every pixel.
float narrowest_neighbour(ivec2 px, ivec2 size)
{
    // img_sigma: x the footprint (>= 0 with a blocker, -1 without), y 1 where the pixel has an
    // estimate of its own (0 on the background, whose x is 0, and 0 or 0.5 without a valid ray).
    // The pixel itself is left out: it has no blocker (the caller's condition). The pass runs only
    // in tiles with a blocker in some pixel's 5 x 5 (filter.comp's marks); before the marks every
    // lit pixel took these 24 loads (builtin:default at 1280 x 720, exact, 4 spp, medians of 5:
    // the filter pass 48.3 / 50.4 -> 40.5 / 42.3 ms with the marks, V the same bit for bit).
    float narrowest = -1.0;
    for (int ring = 1; ring <= PN_PENUMBRA_LEND_REACH && narrowest < 0.0; ring++)
        for (int dy = -ring; dy <= ring; dy++)
            // Along the ring's top and bottom rows every pixel, between them its two ends.
            for (int dx = -ring; dx <= ring; dx += abs(dy) == ring ? 1 : 2 * ring) {
                vec2 s = imageLoad(img_sigma, clamp(px + ivec2(dx, dy), ivec2(0), size - 1)).xy;
                bool blocked = s.y >= 1.0 && s.x >= 0.0;
                narrowest = blocked && (narrowest < 0.0 || s.x < narrowest) ? s.x : narrowest;
            }
    return max(narrowest, 0.0);
}

// Whether the pixel's tile is marked (filter.comp): a pixel within PN_PENUMBRA_LEND_REACH of it has
// a blocker of its own. Elsewhere narrowest_neighbour would find none: its 24 loads are spared (a
// listed block of 64 x 8 pixels holds 8 tiles, most of them quiet).
bool marked(ivec2 px)
{
    uint bits = imageLoad(img_tiles, px / ivec2(PN_PENUMBRA_BLOCK_W, PN_PENUMBRA_BLOCK_H)).x;
    return (bits >> uint((px.x % PN_PENUMBRA_BLOCK_W) / PN_PENUMBRA_MARK_W) & 1u) != 0u;
}

// The row pass's V as the column pass reads it, with whether the pixel lends it: the sign bit (V is
// in [0, 1], so -V, -0 included, tells it exactly). Along rows, as in filter.comp's window, a pixel
// lends only an estimate of its own (a valid ray: img_sigma's y = 1). Along columns also the V a
// pixel without one took from its neighbours where the light reaches above its horizon (y = 0.5):
// measured, leaving those out as well cost Sponza's 1 spp 0.0217 -> 0.0246 (bench, 512 x 512,
// reference MAE). Where the light cannot reach (y = 0) V is the convention 1, no estimate of
// anything: it neither lends nor is blurred (blur). Before, it was lent along columns and took its
// neighbours' V.
float row_value(float v, bool lends) { return lends ? v : -v; }
float row_v(float stored) { return abs(stored); }
bool row_lends(float stored) { return (floatBitsToUint(stored) >> 31u) == 0u; }

// The Gaussian along rows (img_v -> scratch, with the pixel's footprint) or columns (scratch ->
// img_v), over world distance on the pixel's surface: a surface seen at a grazing angle packs more
// of it into a pixel, and a Gaussian over pixels would reach across its penumbra.
void blur(ivec2 px, ivec2 size, bool rows)
{
    // The row pass leaves the footprint in pixels facing the camera (the EXR's): back to world units
    // below. Along rows a pixel without a footprint of its own takes its neighbours' narrowest.
    vec2 sc = rows ? vec2(0.0) : imageLoad(img_scratch, px).xy;
    vec2 own = rows ? imageLoad(img_sigma, px).xy : vec2(sc.y, row_lends(sc.x) ? 1.0 : 0.0);
    float lent = rows && own.x < 0.0 && marked(px) ? narrowest_neighbour(px, size) : 0.0;
    float v_p = rows ? imageLoad(img_v, px).x : row_v(sc.x);
    // Most pixels (lit, contact shadows, the background) have no footprint: they keep
    // their V before the positions and normals are loaded, as they would below (with filter.comp's
    // lit and dark windows, the filter pass 0.72-0.80x on the bunny and the dragon: filter.comp).
    if (!((own.x >= 0.0 ? own.x : lent) > 0.0)) {
        if (rows)
            imageStore(img_scratch, px, vec4(row_value(v_p, own.y > 0.0), 0.0, 0.0, 0.0));
        else
            imageStore(img_v, px, vec4(v_p));
        return;
    }
    vec4 p = imageLoad(img_p, px);
    vec4 n = imageLoad(img_n, px);
    float footprint_p = n.w * pc.pixel_angle;
    vec2 sp = !rows ? vec2(sc.y * footprint_p, own.y)
                    : own.x >= 0.0 ? own : vec2(min(lent, float(pc.max_radius) / RADIUS_SIGMAS * footprint_p), own.y);
    // The world length of one pixel along the pass's direction: the nearer of the two neighbours
    // (the other may lie across an edge), at least the footprint facing the camera; so the
    // footprint over the latter bounds it in pixels, and most pixels (lit, umbra, contact) leave
    // before loading a neighbour.
    ivec2 dir = rows ? ivec2(1, 0) : ivec2(0, 1);
    float sigma_px = sp.x / max(footprint_p, 1e-30);
    if (p.w > 0.0 && sigma_px >= MIN_SIGMA) {
        ivec2 a = clamp(px - dir, ivec2(0), size - 1), b = clamp(px + dir, ivec2(0), size - 1);
        float da = a == px ? 1e30 : distance(imageLoad(img_p, a).xyz, p.xyz);
        float db = b == px ? 1e30 : distance(imageLoad(img_p, b).xyz, p.xyz);
        sigma_px = sp.x / max(max(min(da, db), footprint_p), 1e-30);
    }
    // A pixel the light cannot reach (sp.y = 0) keeps the convention, as in filter.comp: its V
    // carries no light, and one its neighbours gave it would only be read as an error.
    if (p.w <= 0.0 || sp.y <= 0.0 || sigma_px < MIN_SIGMA) {
        if (rows)
            imageStore(img_scratch, px, vec4(row_value(v_p, sp.y > 0.0), max(sp.x, 0.0) / max(footprint_p, 1e-30), 0.0, 0.0));
        else
            imageStore(img_v, px, vec4(v_p));
        return;
    }
    // The noise of one pixel's V around the pixel's, at least that of V = 1 / n (so that a pixel
    // whose few rays all agreed by luck still takes its neighbours): two pixels differ by up to
    // RANGE_SIGMAS times sqrt 2 of it.
    float samples = pixel_samples(px) * WINDOW_SAMPLES;
    float spread = RANGE_SIGMAS * sqrt(2.0 * max(v_p * (1.0 - v_p), 1.0 / samples) / samples);
    // Taps every `step` pixels, half a standard deviation apart or closer: enough for a Gaussian
    // (its sum over such a lattice is its integral to a fraction of a percent) on a V the
    // interleaved filter already smoothed over 3 pixels, and it keeps the taps about
    // 4 PN_PENUMBRA_TAP_SIGMAS + 1 whatever the width (17 at most, just below a step of 2), so the
    // pass costs the same on any penumbra. A step of 0.75 deviations instead (7 taps): Sponza's
    // reference MAE at 1 spp 0.0137 -> 0.0152, the meshes' 2-4% higher (the same bench as the reach).
    int step = max(int(0.5 * sigma_px), 1);
    int r = reach(sigma_px) / step * step;
    float sum = 0.0, weight = 0.0;
    for (int k = -r; k <= r; k += step) {
        ivec2 q = px + k * dir;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)))
            continue;
        // Along columns the row pass's output: its V, whether it lends it (row_value) and its
        // footprint.
        vec4 qp = imageLoad(img_p, q), m = imageLoad(img_n, q);
        vec2 sc = rows ? vec2(0.0) : imageLoad(img_scratch, q).xy;
        vec2 sq = rows ? pixel_footprint(q) : vec2(sc.y * m.w * pc.pixel_angle, row_lends(sc.x) ? 1.0 : 0.0);
        float v_q = rows ? imageLoad(img_v, q).x : row_v(sc.x);
        // The narrower of the two footprints: a pixel next to a contact shadow does not reach
        // into it, nor the contact shadow's pixels into the wide penumbra beside them. Distances
        // scaled by it before squaring, so that nothing overflows or underflows.
        float sigma = sq.x > 0.0 ? min(sp.x, sq.x) : sp.x;
        vec3 x = sigma > 0.0 ? (qp.xyz - p.xyz) / sigma : vec3(0.0);
        float g = k == 0 ? 1.0 : (sigma > 0.0 ? exp(-0.5 * dot(x, x)) : 0.0);
        float w = g * surface_weight(p.xyz, n.xyz, footprint_p, qp.xyz, m.xyz, m.w * pc.pixel_angle, float(abs(k)));
        float d = abs(v_q - v_p) / spread;
        w *= max(1.0 - d * d, 0.0);
        w = qp.w > 0.0 && sq.y >= 1.0 ? w : 0.0;
        sum += w * v_q;
        weight += w;
    }
    float v = weight > 0.0 ? clamp(sum / weight, 0.0, 1.0) : v_p;
    if (rows)
        imageStore(img_scratch, px, vec4(row_value(v, sp.y > 0.0), sp.x / max(footprint_p, 1e-30), 0.0, 0.0));
    else
        imageStore(img_v, px, vec4(v));
}

void main()
{
    // A group per row of a listed block (filter.comp's list: the block's first pixel, the row
    // gl_WorkGroupID.y), or of the list's first in the warm-up frame (pn_penumbra_pass_begin leaves
    // it 0 where nothing is listed). The coordinates from a few adds: decoding them from block
    // indices (a shift, a multiply, a mask per axis) cost both passes 1 ms on the bunny's 512 x 512
    // view (bench, exact, 4 spp, every block run in image order: 17.2-17.7 against 15.9-16.2 ms).
    uint origin = list.tiles[gl_WorkGroupID.x];
    ivec2 px = ivec2((origin & 0xffffu) + gl_LocalInvocationID.x, (origin >> 16) + gl_WorkGroupID.y);
    ivec2 size = imageSize(img_v);
    bool inside = all(lessThan(px, size));
    if (inside)
        blur(px, size, STAGE == PN_PENUMBRA_STAGE_BLUR_X);
}
