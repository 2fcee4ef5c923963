#version 460
#extension GL_GOOGLE_include_directive : require
// The temporal history (--temporal), once per light after its shadow pass: each pixel's samples of
// earlier frames carried to it and added to its own, so that the filters and the shading read V
// over all of them. Frames without an interleaved tile (unfiltered) choose each pixel's previous
// pixel once before their shadow passes instead (STAGE 1, choose: its lineage), and the lights'
// passes take that choice (STAGE 2).
//
// V at a surface point depends on the scene and the light, never on the camera: when only the
// camera moved, every earlier sample of the point is still a sample of its V. So the point is
// found in the previous frame (its P through the previous camera's matrix, the nearest pixel
// there) and that pixel's sums taken, where it shows the same surface (the filters' own test,
// filter_common.glsl: within a footprint of each other's tangent plane, normals within 30
// degrees; the choice is the first stage's, shared by the lights). A point the previous frame did not show (uncovered this frame, or off its image)
// starts from its own samples. Where geometry moved (HistoryParams' boxes: each moved object's
// bounds before and after), V can change only at points whose rays to the light can meet it: the
// pyramid from the point to the light meets a box. Those points drop their history; everywhere
// else it carries on unchanged. A light that changed drops its history as a whole (drop).
//
// The sums hold at most `cap` samples: beyond it the earlier ones are scaled down to leave room
// for this frame's, so that a sample's weight falls geometrically with its age and a stale or
// resampled one fades (an exponential window of about cap / samples frames).
#include "interface.h"
#include "filter_common.glsl"
#include "hash.glsl"

layout(local_size_x = PN_ROW_GROUP) in;

layout(set = 0, binding = PN_HISTORY_BINDING_P, rgba32f) uniform readonly image2D img_p;
layout(set = 0, binding = PN_HISTORY_BINDING_N, rgba32f) uniform readonly image2D img_n;
layout(set = 0, binding = PN_HISTORY_BINDING_PREV_P, rgba32f) uniform readonly image2D img_prev_p;
layout(set = 0, binding = PN_HISTORY_BINDING_COUNTS, rgba32ui) uniform readonly uimage2D img_counts;
layout(set = 0, binding = PN_HISTORY_BINDING_V_RAW, r32f) uniform image2D img_v_raw;
layout(set = 0, binding = PN_HISTORY_BINDING_STORE_IN, rgba32ui) uniform readonly uimage2DArray img_store_in;
layout(set = 0, binding = PN_HISTORY_BINDING_STORE_OUT, rgba32ui) uniform writeonly uimage2DArray img_store_out;
layout(set = 0, binding = PN_HISTORY_BINDING_OUT, rgba32ui) uniform writeonly uimage2D img_out;
layout(std140, set = 0, binding = PN_HISTORY_BINDING_PARAMS) uniform HistoryParamsBlock { HistoryParams params; };
layout(set = 0, binding = PN_HISTORY_BINDING_POS_OUT, rgba32f) uniform writeonly image2D img_pos_out;

layout(set = 0, binding = PN_HISTORY_BINDING_LINEAGE, rgba32ui) uniform uimage2D img_lineage;
layout(set = 0, binding = PN_HISTORY_BINDING_TRAIL, rgba32ui) uniform readonly uimage2D img_trail;
layout(set = 0, binding = PN_HISTORY_BINDING_TRAIL_OUT, rgba32ui) uniform writeonly uimage2D img_trail_out;

layout(push_constant) uniform HistoryPushBlock { HistoryPush pc; };

// The stage (PN_SPEC_HISTORY_STAGE): 0 adds a light's samples to its history (after its shadow
// pass), choosing the previous pixel itself; 1 chooses each pixel's previous pixel and lineage
// (once a frame, before the shadow passes); 2 adds a light's samples from the pixel 1 chose.
layout(constant_id = PN_SPEC_HISTORY_STAGE) const uint STAGE = 0u;

// As filter.comp's: a neighbour whose surface weight is below this does not continue the surface.
const float SURFACE_CONTINUES = 0.75;
// And a previous pixel's point counts only within this many footprints of the point (either's):
// on a surface seen at up to 60 degrees from its normal the four pixels round the point's place
// lie that near; beyond, the surface is seen at a grazing angle (a silhouette, a terminator seen
// edge-on), where one pixel spans more of it than V stays the same over.
const float NEAR = 2.0;

// Whether the pyramid from p to light l (its four corners; a sphere's centre with its radius
// grown round it) meets the box [lo, hi]: a separating-axis test over the box's axes, the
// pyramid's faces (a light with an area: its plane and the four planes through p and an edge) and
// the cross products of the direction to the light with the box's axes. It leaves out the other
// pairs of edges, so it may find a meeting where there is none (the history then goes for
// nothing), never the reverse. A gap is trusted only beyond the rounding of its terms.
bool pyramid_meets_box(vec3 p, Light l, vec3 lo, vec3 hi)
{
    uint kind = uint(l.corners[0].w);
    float radius = kind == PN_LIGHT_SPHERE_ID ? l.corners[1].w : 0.0;
    vec3 c[4] = vec3[4](l.corners[0].xyz, l.corners[1].xyz, l.corners[2].xyz, l.corners[3].xyz);
    vec3 centre = 0.25 * (c[0] + c[1] + c[2] + c[3]);
    vec3 mid = 0.5 * (lo + hi), ext = 0.5 * (hi - lo), d = centre - p;
    vec3 axes[11];
    axes[0] = vec3(1, 0, 0), axes[1] = vec3(0, 1, 0), axes[2] = vec3(0, 0, 1);
    axes[3] = cross(d, axes[0]), axes[4] = cross(d, axes[1]), axes[5] = cross(d, axes[2]);
    // A parallelogram's plane and sides (all zero for a point or a sphere, which leave them out).
    bool area = kind == PN_LIGHT_RECT_ID || kind == PN_LIGHT_SUN_ID || kind == PN_LIGHT_DISK_ID;
    axes[6] = area ? cross(c[1] - c[0], c[3] - c[0]) : vec3(0.0);
    for (int i = 0; i < 4; i++)
        axes[7 + i] = area ? cross(c[(i + 1) & 3] - c[i], c[i] - p) : vec3(0.0);
    for (int k = 0; k < 11; k++) {
        vec3 a = axes[k];
        float r = radius * length(a);
        float pa = dot(p, a), lmin = pa, lmax = pa;
        for (int i = 0; i < 4; i++) {
            float x = dot(c[i], a);
            lmin = min(lmin, x - r), lmax = max(lmax, x + r);
        }
        float bc = dot(mid, a), be = dot(ext, abs(a));
        float tol = 8.0 * ulp_bound(max(max(abs(lmin), abs(lmax)), abs(bc) + be));
        if (lmax < bc - be - tol || lmin > bc + be + tol)
            return false;
    }
    return true;
}

// Octahedral unit normals in a uint (the store's w): 16 bits a coordinate.
uint pack_normal(vec3 n)
{
    n /= max(abs(n.x) + abs(n.y) + abs(n.z), 1e-30);
    vec2 e = n.z >= 0.0 ? n.xy : (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    return packSnorm2x16(e);
}
vec3 unpack_normal(uint u)
{
    vec2 e = unpackSnorm2x16(u);
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return normalize(n);
}

// The previous frame's pixel q as the history reads it: its point (w: covered), normal and view
// depth, and its sums and where their samples lie (the store).
struct Earlier {
    vec4 p;
    vec3 n;
    float footprint;
    vec2 sums, offset;
};
Earlier earlier(ivec2 q)
{
    Earlier e;
    e.p = imageLoad(img_prev_p, q);
    uvec4 h = imageLoad(img_store_in, ivec3(q, int(pc.light)));
    e.sums = uintBitsToFloat(h.xy);
    e.offset = unpackHalf2x16(h.z);
    e.n = unpack_normal(h.w);
    e.footprint = dot(e.p.xyz - params.prev_eye.xyz, params.prev_forward.xyz) * params.prev_pixel_angle;
    return e;
}

// How much of the history to keep, as a factor of its samples: their mean lies `offset` pixels
// from the point (their places as carried), so it is off by about |grad V| times that, where the
// gradient is the earlier means' across the chosen pixel's neighbours on the same surface (in the
// previous frame), and by half that again for their spread about the mean (each lies within
// about that of it). With a share a of history off by b and the frame's n samples of a
// variance var each, the mean squared error a^2 b^2 + var (1 - a) / n is least at a = var / (2 n
// b^2): where V varies little over the offset (a still camera's history has none) all of it is
// kept, at a contact shadow's edge almost none. Measured (tests/test_temporal.c's orbit: the
// bunny's set-up, 128 x 96, 8 frames, unfiltered; at 256 spp a frame the error is the
// resampling's alone): 2 degrees a frame, MAE 0.00635 keeping all of it, 0.00098 so.
float history_share(ivec2 q, Earlier c, vec2 offset, float own)
{
    vec2 prev = c.sums;
    ivec2 size = imageSize(img_p);
    float vq = prev.x / prev.y;
    vec2 g = vec2(0.0);
    for (int axis = 0; axis < 2; axis++) {
        // The means on either side, and where their samples lie (central or one-sided differences).
        float lo_v = vq, hi_v = vq, lo_c = float(q[axis]) + c.offset[axis], hi_c = lo_c;
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            ivec2 q_e = q;
            q_e[axis] += sgn;
            if (any(lessThan(q_e, ivec2(0))) || any(greaterThanEqual(q_e, size)))
                continue;
            Earlier e = earlier(q_e);
            if (e.p.w > 0.0 && e.sums.y > 0.0 &&
                surface_weight(c.p.xyz, c.n, c.footprint, e.p.xyz, e.n, e.footprint, 1.0) >= SURFACE_CONTINUES) {
                float at = float(q_e[axis]) + e.offset[axis];
                if (sgn < 0)
                    lo_v = e.sums.x / e.sums.y, lo_c = at;
                else
                    hi_v = e.sums.x / e.sums.y, hi_c = at;
            }
        }
        g[axis] = hi_c - lo_c > 0.5 ? (hi_v - lo_v) / (hi_c - lo_c) : 0.0;
    }
    float b = abs(dot(g, offset)) + 0.5 * length(g) * length(offset);
    // A sample's variance from the history's mean (at least that of one sample more, so that a
    // mean of 0 or 1 still counts as uncertain).
    float var = max(vq * (1.0 - vq), 1.0 / (prev.y + own));
    // The frame's noise the history's bias is weighed against is what the filter after leaves of
    // it: averaged over its window's pixels (pc.noise_pixels), whose interleaved samples are the
    // frame's too. Weighed against the pixel's own noise alone, the share kept too much bias where
    // a filter follows (measured: the default scene at 320 x 180, 9 spp a frame, an orbit of 2
    // degrees a frame, frame 31's MAE against its converged reference 0.00200 with history and
    // 0.00146 without; see engine/gpu/README.md for the figures since).
    float a = var / max(2.0 * own * max(pc.noise_pixels, 1.0) * b * b, 1e-30), kept = prev.y / (prev.y + own);
    return a < kept ? a * own / ((1.0 - a) * prev.y) : 1.0;
}

// The previous frame's pixel q as the choice reads it: its point (w: covered), normal and view
// depth, and its lineage (the previous frame's, as light 0's adding stage kept it).
struct Trail {
    vec4 p;
    vec3 n;
    float footprint;
    uint key;
    vec2 offset;
};
Trail trail(ivec2 q)
{
    Trail t;
    t.p = imageLoad(img_prev_p, q);
    uvec4 l = imageLoad(img_trail, q);
    t.key = l.x;
    t.offset = unpackHalf2x16(l.z);
    t.n = unpack_normal(l.w);
    t.footprint = dot(t.p.xyz - params.prev_eye.xyz, params.prev_forward.xyz) * params.prev_pixel_angle;
    return t;
}

// The point's place in the previous frame's pixels (x, y; w: in front of its camera).
vec3 previous_place(vec3 p, ivec2 size)
{
    vec4 clip = params.prev_view_proj * vec4(p, 1.0);
    return vec3((clip.xy / clip.w * 0.5 + 0.5) * vec2(size) - 0.5, clip.w);
}

uint pack_pixel(ivec2 q) { return uint(q.x) | uint(q.y) << 16u; }
ivec2 unpack_pixel(uint u) { return ivec2(u & 0xffffu, u >> 16u); }

// A lineage started at px this frame: its own key (hash.glsl), no previous pixel, its point the
// pixel's centre.
uvec4 fresh_lineage(ivec2 px, vec4 p, vec4 n)
{
    return uvec4(lineage_key(uvec2(px), params.seed, params.frame), PN_HISTORY_NONE, packHalf2x16(vec2(0.0)),
                 pack_normal(p.w > 0.0 ? n.xyz : vec3(0.0, 0.0, 1.0)));
}

// Stage 1: each pixel's previous pixel, and the lineage of the samples it draws.
// Every pixel of the previous frame carries a lineage: a sampler key (drawn where and when it began:
// shadow_common.glsl's pixel_sampler draws the pixel's samples by it) and the point it follows, kept
// as where that point lies from the pixel's centre. The point's place this frame is the pixel's P through this frame's
// camera, plus that offset. A pixel takes, of the four previous pixels round its own point's place
// in the previous frame (its P through the previous camera) that show the same surface (the
// filters' test), the one whose followed point now lies nearest to its centre (the nearest pixel
// first: where that point lies within half a pixel, as a still camera's all do, the others are not
// read). Its history is taken from there for every light (the adding stage), and where that point
// lies in this pixel (it rounds to it: one pixel at most for each previous one) the pixel continues
// the lineage, so a surface point's samples over the frames are one pixel's frame window,
// complementary strata of the light, however the camera moved. Elsewhere (a pixel uncovered this
// frame, off the last frame's image, a fresh history, the surface magnified so that two pixels
// took one) the pixel starts a lineage of its own at its centre, keyed by the pixel and the frame:
// its samples are those of the same frame with its history dropped, bit for bit.
void choose(ivec2 px, ivec2 size, vec4 p, vec4 n)
{
    uvec4 lineage = fresh_lineage(px, p, n);
    if (p.w > 0.0 && pc.drop == 0u) {
        float depth = params.depth_from_eye != 0u ? dot(p.xyz - params.eye.xyz, params.forward.xyz) : n.w;
        float footprint = depth * params.pixel_angle, best = 1e30;
        vec3 at = previous_place(p.xyz, size);
        ivec2 q0 = ivec2(floor(at.xy)), nearest = ivec2(floor(at.xy + 0.5)), chosen = ivec2(-1);
        Trail picked;
        vec2 offset = vec2(0.0);
        for (int k = -1; k < 4 && at.z > 0.0 && best > 0.25; k++) {
            ivec2 q = k < 0 ? nearest : q0 + ivec2(k & 1, k >> 1);
            if ((k >= 0 && q == nearest) || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)))
                continue;
            Trail e = trail(q);
            vec3 gap = (e.p.xyz - p.xyz) / max(max(footprint, e.footprint), 1e-30);
            // Where the followed point lies now, from this pixel's centre.
            vec4 clip = params.view_proj * vec4(e.p.xyz, 1.0);
            vec2 d = (clip.xy / clip.w * 0.5 + 0.5) * vec2(size) - 0.5 + e.offset - vec2(px);
            if (e.p.w > 0.0 && clip.w > 0.0 &&
                surface_weight(p.xyz, n.xyz, footprint, e.p.xyz, e.n, e.footprint, 1.0) >= SURFACE_CONTINUES &&
                dot(gap, gap) <= NEAR * NEAR && dot(d, d) < best) {
                best = dot(d, d);
                offset = d, chosen = q, picked = e;
            }
        }
        if (chosen.x >= 0) {
            lineage.y = pack_pixel(chosen);
            // The lineage only where some light keeps history there (it holds samples, does not
            // drop its history this frame, and the pixel's pyramid to it meets no moved box: the
            // adding stage's own tests but the light's reach, which the shadow pass tells it), and
            // only in the one pixel its point rounds to (half-open, so that a point half-way between
            // two pixels lands in one of them). Where no light keeps it the pixel's samples are the
            // frame's own as with its history dropped, bit for bit.
            bool held = false;
            vec3 reach = vec3((NEAR + 1.0) * footprint);
            for (int layer = 0; layer < imageSize(img_store_in).z && !held; layer++) {
                held = (params.drop_mask >> uint(layer) & 1u) == 0u &&
                       uintBitsToFloat(imageLoad(img_store_in, ivec3(chosen, layer)).y) > 0.0;
                for (uint b = 0u; held && b < params.box_count; b++)
                    held = !pyramid_meets_box(p.xyz, params.lights[layer], params.box_lo[b].xyz - reach,
                                              params.box_hi[b].xyz + reach);
            }
            if (held && all(greaterThanEqual(offset, vec2(-0.5))) && all(lessThan(offset, vec2(0.5))))
                lineage.x = picked.key, lineage.z = packHalf2x16(offset);
        }
    }
    imageStore(img_lineage, px, lineage);
}

void main()
{
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(img_p);
    if (any(greaterThanEqual(px, size)))
        return;
    vec4 p = imageLoad(img_p, px), n = imageLoad(img_n, px);
    if (STAGE == 1u) {
        choose(px, size, p, n);
        return;
    }
    int layer = int(pc.light);
    // Stage 0 chose nothing: every pixel's lineage starts here (for a later frame without a tile).
    uvec4 lineage = STAGE == 2u ? imageLoad(img_lineage, px) : fresh_lineage(px, p, n);
    // This frame's P and lineages for the next frame's choice: the pass keeps its own copies (one
    // of two, taken in turn as the sums are), so the renderer copies nothing between frames and the
    // library's recorder, whose P is the host's, needs nothing of it.
    if (pc.light == 0u) {
        imageStore(img_pos_out, px, p);
        imageStore(img_trail_out, px, lineage);
    }
    uvec4 counts = imageLoad(img_counts, px);
    vec2 own = vec2(counts.xy);
    vec2 prev = vec2(0.0);
    // A pixel on the background has no samples; one the light cannot reach (counts.z 0) keeps V's
    // convention and no history.
    bool carry = p.w > 0.0 && counts.z != 0u && pc.drop == 0u && (STAGE == 0u || lineage.y != PN_HISTORY_NONE);
    // The boxes grown by the reach of the earlier pixels whose samples the history may hold
    // (within NEAR footprints of the point, and their offset within a pixel more).
    Light l = params.lights[pc.light];
    float depth = params.depth_from_eye != 0u ? dot(p.xyz - params.eye.xyz, params.forward.xyz) : n.w;
    vec3 reach = vec3((NEAR + 1.0) * depth * params.pixel_angle);
    for (uint b = 0u; carry && b < params.box_count; b++)
        carry = !pyramid_meets_box(p.xyz, l, params.box_lo[b].xyz - reach, params.box_hi[b].xyz + reach);
    // Where the history's samples lie relative to the pixel's centre, in pixels (the store's z):
    // 0 for the frame's own.
    vec2 offset = vec2(0.0);
    if (carry) {
        vec3 at = previous_place(p.xyz, size);
        ivec2 chosen = ivec2(-1);
        Earlier picked;
        if (STAGE == 2u) {
            // The previous pixel the choice took (stage 1), its sums and where their samples lie.
            chosen = unpack_pixel(lineage.y);
            picked = earlier(chosen);
            prev = picked.sums, offset = vec2(chosen) + picked.offset - at.xy;
        } else {
            // Of the four pixels round the point's place in the previous frame, the one on the same
            // surface whose samples lie nearest to it (a camera moving by a fraction of a pixel a
            // frame keeps choosing the same pixel, and its samples fall behind the surface a
            // fraction a frame: their place, carried along, says when a neighbour's lie nearer).
            // The nearest pixel first: where its samples lie within half a pixel (a still
            // camera's, all), the others are not read.
            ivec2 q0 = ivec2(floor(at.xy)), nearest = ivec2(floor(at.xy + 0.5));
            float footprint = depth * params.pixel_angle, best = 1e30;
            for (int k = -1; k < 4 && at.z > 0.0 && best > 0.25; k++) {
                ivec2 q = k < 0 ? nearest : q0 + ivec2(k & 1, k >> 1);
                if ((k >= 0 && q == nearest) || any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)))
                    continue;
                Earlier e = earlier(q);
                vec3 gap = (e.p.xyz - p.xyz) / max(max(footprint, e.footprint), 1e-30);
                vec2 d = vec2(q) + e.offset - at.xy;
                if (e.p.w > 0.0 && surface_weight(p.xyz, n.xyz, footprint, e.p.xyz, e.n, e.footprint, 1.0) >= SURFACE_CONTINUES &&
                    dot(gap, gap) <= NEAR * NEAR && dot(d, d) < best) {
                    best = dot(d, d);
                    prev = e.sums, offset = d, chosen = q, picked = e;
                }
            }
        }
        // (Where the samples lie on the point itself, as under a still camera, all of it: no
        // gradient to measure.)
        if (chosen.x >= 0 && prev.y > 0.0 && own.y > 0.0 && offset != vec2(0.0))
            prev *= history_share(chosen, picked, offset, own.y);
    }
    // Room for this frame's samples within the cap: the earlier ones scaled to what is left.
    if (prev.y + own.y > pc.cap && prev.y > 0.0)
        prev *= max(pc.cap - own.y, 0.0) / prev.y;
    vec2 sum = prev + own;
    offset = sum.y > 0.0 ? offset * (prev.y / sum.y) : vec2(0.0);
    imageStore(img_store_out, ivec3(px, layer),
               uvec4(floatBitsToUint(sum), packHalf2x16(offset), pack_normal(p.w > 0.0 ? n.xyz : vec3(0.0, 0.0, 1.0))));
    imageStore(img_out, px, uvec4(floatBitsToUint(sum.x), floatBitsToUint(sum.y), counts.z, counts.w));
    // V over all of them (as shadow_finish's visible / valid); a pixel without history keeps the
    // shadow pass's V bit for bit.
    if (prev.y > 0.0)
        imageStore(img_v_raw, px, vec4(sum.x / sum.y));
}
