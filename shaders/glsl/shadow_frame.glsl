// The skeleton of a shadow shader: the pixel, its chunk of rays, the counts. Include after
// shadow_common.glsl.

layout(set = 0, binding = PN_SHADOW_BINDING_P, rgba32f) uniform readonly image2D img_p;
layout(set = 0, binding = PN_SHADOW_BINDING_N, rgba32f) uniform readonly image2D img_n;
layout(set = 0, binding = PN_SHADOW_BINDING_V, r32f) uniform writeonly image2D img_v;
layout(set = 0, binding = PN_SHADOW_BINDING_ADAPT, rgba32ui) uniform uimage2D img_adapt;
layout(set = 0, binding = PN_SHADOW_BINDING_RAYS, rgba32ui) uniform uimage2D img_rays;
layout(std430, set = 0, binding = PN_SHADOW_BINDING_LISTS) buffer PixelLists { uint words[]; } pixel_lists;
layout(set = 0, binding = PN_SHADOW_BINDING_BLOCKERS, rg32f) uniform image2D img_blockers;

// This pixel's samples in this dispatch, [pixel_begin, pixel_end) (set by shadow_pixel): the chunk's,
// or in adaptive sampling's later rounds the part of the chunk between the samples the pixel has
// and its target, pixel_target; pixel_last: the dispatch ends the pixel's samples (of the round),
// so it writes V.
uint pixel_begin, pixel_end, pixel_target;
bool pixel_last;

// The pixel of this invocation: `local` is its place in its work group's PN_WORKGROUP-square tile
// of the image (each shader maps invocations to the tile as suits it). In adaptive sampling's later
// rounds the dispatch runs over a list of the pixels that go on instead (adaptive_decide), packed
// PN_WORKGROUP^2 to a work group in the order they were listed: the rest of the image costs
// nothing, and a SIMD group's lanes all have rays to trace (in a tile, a penumbra's pixels share
// their 4 x 2 SIMD groups with pixels that stopped). (-1, -1) past the list's end. Measured
// (512 x 512, exact, default scene): a dispatch over the whole image in which no pixel traced took
// 6.5 ms, as much as a sixth of a 4-sample round; over the tiles holding a pixel that goes on
// (dragon view, 4:64), 79% of the lanes of a SIMD group with work had any, and their rays were
// 72% of what full groups would trace. shadow_list_pixel: the list's i-th pixel.
ivec2 shadow_list_pixel(uint i)
{
    uint list = (CHUNK_LIST_IN - 1u) * PN_PIXEL_LIST_WORDS(params.tile_total);
    if (i >= pixel_lists.words[list + 3u])
        return ivec2(-1);
    uint packed = pixel_lists.words[list + 4u + i];
    return ivec2(packed & 0xffffu, packed >> 16u);
}
#ifndef PN_RAY_GENERATION // a ray generation shader has launch ids instead (shadow_rtpipeline.rgen)
ivec2 shadow_invocation_pixel(ivec2 local)
{
    if (CHUNK_LIST_IN == 0u)
        return ivec2(gl_WorkGroupID.xy) * PN_WORKGROUP + local;
    return shadow_list_pixel(gl_WorkGroupID.x * uint(PN_WORKGROUP * PN_WORKGROUP) + gl_LocalInvocationIndex);
}
#endif

const uint MAX_CHUNK = PN_MAX_CHUNK; // rays of one dispatch (shadow_pass.c keeps chunks at most this big)

// The chunk's rays: all start at the pixel's origin o; ray i ends at o + dir[i] (a light sample),
// and rises clear of its own surface at t_rise[i] (see shadow_origin).
vec3 dir[MAX_CHUNK];
float t_rise[MAX_CHUNK];
bool truncated = false; // llvmpipe: set when the loop budget ended a loop early
// Where each blocked ray met its blocker, as the segment parameter t in [0, 1): where a traversal
// blocks ray i it records the t of the hit, or of the node or leaf whose line space or slab decided
// it (the blocker lies beyond). shadow_finish turns their mean into the pixel's penumbra width for
// the filter.
float blocker_t[MAX_CHUNK];
void blocker_at(uint i, float t) { blocker_t[i] = min(blocker_t[i], max(t, 0.0)); }

// Work counters (the bench's --work): a separate build of each shadow shader, with COUNT_WORK on,
// counts per pixel the nodes visited (N-tree or BVH), line-space lookups, triangle tests and the
// deepest stack reached, over all its rays. Off, the increments compile away.
layout(constant_id = PN_SPEC_COUNT_WORK) const bool COUNT_WORK = false;
// The scene has alpha-masked casters (alpha.glsl): an opaque scene's pipeline has no alpha tests
// at all (they cost the dragon 2.5% at 16 spp when only a branch).
layout(constant_id = PN_SPEC_ALPHA) const bool ALPHA = false;
uvec4 work = uvec4(0u); // nodes, lookups, triangle tests, stack depth (max)

// Surface offsets against self-shadowing.
// 1. Float precision: the rasterizer interpolates the G-buffer position from the triangle's
//    vertices, so its error is a few ulps of the vertices' magnitude, not of p's own: on the seam of
//    the ground's two triangles lavapipe puts p 1.2e-7 below the plane, 2 ulps of the ground's
//    corners (0.6) but 14 of p (0.087), which an offset of 8 ulps of |p| left in shadow (a dark line
//    along the seam in exact mode). The scene's largest coordinate bounds every vertex's, so lifting
//    the origin by 8 ulps of max(|p|, scene_mag) along the normal puts it on the lit side of its own
//    triangle. Every mode starts its rays there.
// 2. Cell size (line-space modes): a shaft entered through a patch touches every cell within one
//    leaf (edge s) of the ray (its cross-section is one patch wide and cells are closed), and the
//    surface's own filled leaves reach one leaf beyond the surface. So no shaft of a node the ray
//    enters sees the surface it starts on once the ray is more than 3s away from the tangent plane
//    in the max norm, i.e. once n.(x - p) > 3 s |n|_1: at t_rise along the ray (not a shift along the
//    normal, which would move the penumbrae). rise_leaves is that 3 (RISE_SHAFT_LEAVES), or less for
//    a mode that meets only the leaves the ray itself crosses (ls-leaf, shadow_linespace.comp).
const float RISE_SHAFT_LEAVES = 3.0;
vec3 shadow_origin(vec3 p, vec3 nrm, float rise_leaves, out float rise)
{
    float mag = max(max(max(abs(p.x), abs(p.y)), abs(p.z)), params.scene_mag);
    rise = rise_leaves * params.leaf_size * (abs(nrm.x) + abs(nrm.y) + abs(nrm.z));
    return p + nrm * (8.0 * ulp_bound(mag));
}

// A light's share of the pixel's unshadowed irradiance, for the budgeted split (and whether it is
// zero, for the filter: shadow_finish). Every dispatch of every light evaluates it for all the
// lights, so it must cost little (light_irradiance's clipped
// edge sum, k^2 times a frame, cost more than the rays on simple scenes): radiance x area x
// cos(light) / r^2 at the light's centre, times the receiver's cosine averaged over the centre and
// the four corners (so a light half below the horizon keeps about its half), at most pi x radiance
// (the whole hemisphere). That is the irradiance once the light is small against its distance;
// nearer, only the counts are less well placed: any deterministic count of at least one ray keeps
// V unbiased. Zero exactly where light_irradiance is: no corner above the receiver's plane, or
// the pixel behind the light.
float light_weight(Light l, vec3 p, vec3 nrm)
{
    vec3 centre = 0.25 * (l.corners[0].xyz + l.corners[1].xyz + l.corners[2].xyz + l.corners[3].xyz);
    vec3 d = centre - p;
    uint kind = uint(l.corners[0].w);
    float radiance = l.radiance.r + l.radiance.g + l.radiance.b; // the error figures sum r, g and b
    if (kind == PN_LIGHT_SUN_ID) { // its irradiance, E cos(receiver), as light_irradiance
        float c = dot(nrm, -l.normal.xyz);
        return c > -sqrt(l.corners[1].w) ? max(radiance * max(c, 0.0), 1e-30) : 0.0;
    }
    if (kind == PN_LIGHT_SPHERE_ID) { // L pi (r / d)^2 cos(receiver) towards its centre, some part above
        float r = l.corners[1].w, len = length(d);
        if (!(len > r))
            return 0.0;
        float c = dot(nrm, d) / len, s = r / len;
        return c > -s ? max(radiance * 3.14159265 * s * s * max(c, 0.0), 1e-30) : 0.0;
    }
    if (kind != PN_LIGHT_OMNI_ID && dot(l.normal.xyz, -d) <= 0.0)
        return 0.0;
    // Unit directions: |d|^4 would leave float range for scenes far from the origin.
    float r2 = max(dot(d, d), 1e-30);
    float cos_r = max(dot(nrm, d), 0.0) * inversesqrt(r2);
    bool above = false;
    for (int c = 0; c < 4; c++) {
        vec3 dc = l.corners[c].xyz - p;
        float h = dot(nrm, dc);
        above = above || h > 0.0;
        cos_r += max(h, 0.0) * inversesqrt(max(dot(dc, dc), 1e-30));
    }
    if (!above)
        return 0.0;
    float area = length(cross(l.corners[1].xyz - l.corners[0].xyz, l.corners[3].xyz - l.corners[0].xyz));
    if (kind == PN_LIGHT_DISK_ID)
        area *= 0.78539816; // the disk in its square
    float cosines = (kind == PN_LIGHT_OMNI_ID ? 1.0 : dot(l.normal.xyz, -d) * inversesqrt(r2)) * (cos_r / 5.0);
    return max(radiance * min(area / r2 * cosines, 3.14159265), 1e-30);
}

// The rays this pixel traces for the dispatch's light in its budgeted split: a lit point light
// takes one (its V is exact with one ray); every lit area light at least one, so that its V is an
// unbiased estimate however dim it is; the rest of the budget goes to the area lights in
// proportion to their weight at the pixel (largest remainders round it, so the counts sum to the
// budget). Proportional to the irradiance is the split that minimises the variance of the
// radiance, sum_l E_l^2 V_l (1 - V_l) / n_l under sum_l n_l = B, when nothing is known of V. 0 for
// an unlit light: its term is zero whatever V is. Every dispatch of the frame computes the same
// counts from the same G-buffer texel.
uint budget_rays(vec3 p, vec3 nrm)
{
    float e[PN_MAX_LIGHTS];
    float total = 0.0;
    uint areas = 0u, points = 0u;
    for (uint j = 0u; j < params.light_count; j++) {
        Light l = params.lights[j];
        e[j] = light_weight(l, p, nrm);
        bool lit = e[j] > 0.0;
        points += lit && l.radiance.w != 0.0 ? 1u : 0u;
        areas += lit && l.radiance.w == 0.0 ? 1u : 0u;
        total += lit && l.radiance.w == 0.0 ? e[j] : 0.0;
    }
    uint me = chunk.light;
    if (!(e[me] > 0.0))
        return 0u;
    if (LIGHT.radiance.w != 0.0)
        return 1u;
    // The host makes the budget at least the light count (pn_shadow_pass_update).
    uint rest = params.budget - min(params.budget, points + areas);
    float share = float(rest) / total;
    uint given = 0u;
    for (uint j = 0u; j < params.light_count; j++)
        given += e[j] > 0.0 && params.lights[j].radiance.w == 0.0 ? uint(floor(e[j] * share)) : 0u;
    uint left = rest - min(rest, given);
    float mine = e[me] * share, frac_me = mine - floor(mine);
    uint ahead = 0u; // area lights whose remainder comes first
    for (uint j = 0u; j < params.light_count; j++) {
        float x = e[j] * share, f = x - floor(x);
        bool area = e[j] > 0.0 && params.lights[j].radiance.w == 0.0;
        ahead += area && (f > frac_me || (f == frac_me && j < me)) ? 1u : 0u;
    }
    return 1u + uint(floor(mine)) + (ahead < left ? 1u : 0u);
}

// The rays of this dispatch's chunk at this pixel: the chunk's, or under a budgeted split the part
// of the chunk below the pixel's own count for the light (possibly none).
uint chunk_count(vec3 p, vec3 nrm)
{
    uint end = pixel_end;
    if (SPLIT == PN_SPLIT_BUDGET_ID)
        end = min(end, budget_rays(p, nrm));
    return min(end - min(end, pixel_begin), MAX_CHUNK);
}

// The box, in the light's (s, t), of the part of the light above the receiver's plane through o
// with normal nrm (lo > hi if no part is). The height of the light's point (s, t) over that plane
// is affine in s and t (the light is a parallelogram), so the part above is the unit square
// clipped by a line: its box spans the corners above and the edges' crossings. Samples drawn in
// this box instead of the whole light are still uniform over the part above, which is all that
// V = visible / valid measures (the rest is invalid whatever is in the way): so a grazing pixel,
// which sees only a sliver of the light above its horizon, spends its rays on the sliver and gets
// the estimate that uniform samples over the whole light mostly discard or miss.
// A sun's, a sphere's and a disk's samples are warped onto a disk (light_warp): their box is the
// whole square, the samples below the horizon invalid.
void horizon_box(vec3 o, vec3 nrm, out vec2 lo, out vec2 hi)
{
    if (LIGHT_KIND == PN_LIGHT_SUN_ID || LIGHT_KIND == PN_LIGHT_SPHERE_ID || LIGHT_KIND == PN_LIGHT_DISK_ID) {
        lo = vec2(0.0);
        hi = vec2(1.0);
        return;
    }
    const vec2 square[4] = vec2[4](vec2(0.0, 0.0), vec2(1.0, 0.0), vec2(1.0, 1.0), vec2(0.0, 1.0));
    float h[4];
    for (int c = 0; c < 4; c++)
        h[c] = dot(patch_corners[c] - o, nrm);
    lo = vec2(1.0);
    hi = vec2(0.0);
    for (int c = 0; c < 4; c++) {
        int e = (c + 1) & 3;
        if (h[c] > 0.0) {
            lo = min(lo, square[c]);
            hi = max(hi, square[c]);
        }
        if ((h[c] > 0.0) != (h[e] > 0.0)) {
            // The crossing, from the corner above (h > 0 >= the other's h, so 0 < f <= 1): the
            // same point whichever end it starts from, and never outside the edge.
            bool up = h[c] > 0.0;
            float f = up ? h[c] / (h[c] - h[e]) : h[e] / (h[e] - h[c]);
            vec2 x = up ? mix(square[c], square[e], f) : mix(square[e], square[c], f);
            lo = min(lo, x);
            hi = max(hi, x);
        }
    }
}

// Sets the pixel's light patch (light_patch) and the box of the light's (s, t) its samples are
// drawn in: the part above its horizon (horizon_box), the whole light if none is.
void light_box(vec3 o, vec3 nrm, out vec2 box_lo, out vec2 box_hi)
{
    light_patch(o);
    horizon_box(o, nrm, box_lo, box_hi);
    if (any(greaterThan(box_lo, box_hi)))
        box_lo = vec2(0.0), box_hi = vec2(1.0); // none of the light is above: every ray is invalid
}

// Light sample k of the pixel: its (s, t) on the patch, the ray's direction d (it ends at o + d) and
// d's height over the receiver's plane; returns whether the ray carries light (above the receiver's
// horizon, in front of a one-sided light: an OMNI light emits every way, none reaches inside a
// sphere).
bool light_ray(uint k, PixelSampler ps, vec3 o, vec3 nrm, vec2 box_lo, vec2 box_hi, out vec2 st, out vec3 d, out float dn)
{
    st = light_warp(box_lo + light_sample(k, ps) * (box_hi - box_lo));
    d = light_point(st) - o;
    dn = dot(d, nrm);
    return dn > 0.0 && !patch_none && (LIGHT_KIND == PN_LIGHT_OMNI_ID || dot(patch_normal, -d) > 0.0);
}

// Fills dir and t_rise for the chunk's rays, from slot `base` of the per-ray arrays on (0 but in
// exact's tile walk, which holds several pixels' rays); returns the mask of valid rays (those that
// carry light: above the receiver's horizon and in front of the one-sided light), bit i for ray i
// of the pixel. `i` ends at the ray count (llvmpipe: unless the loop budget ran out). st_lo, st_hi:
// the box, in the light's (s, t), of the valid samples that rise clear before the light (empty,
// lo > hi, if none does).
uint chunk_rays_from(uint base, uvec2 pixel, vec3 o, vec3 nrm, float rise, uint count, out uint i, out vec2 st_lo,
                     out vec2 st_hi)
{
    uint valid_rays = 0u;
    st_lo = vec2(1.0);
    st_hi = vec2(0.0);
    vec2 box_lo, box_hi;
    light_box(o, nrm, box_lo, box_hi);
    PixelSampler ps = pixel_sampler(pixel);
    for (i = 0u; i < count; i++) {
        vec2 st;
        vec3 d;
        float dn;
        bool valid = light_ray(pixel_begin + i, ps, o, nrm, box_lo, box_hi, st, d, dn);
        valid_rays |= valid ? (1u << i) : 0u;
        dir[base + i] = d;
        t_rise[base + i] = valid ? rise / dn : 2.0;
        blocker_t[base + i] = 1.0;
        bool rises = valid && t_rise[base + i] < 1.0;
        st_lo = rises ? min(st_lo, st) : st_lo;
        st_hi = rises ? max(st_hi, st) : st_hi;
    }
    return valid_rays;
}

uint chunk_rays(uvec2 pixel, vec3 o, vec3 nrm, float rise, uint count, out uint i, out vec2 st_lo, out vec2 st_hi)
{
    return chunk_rays_from(0u, pixel, o, nrm, rise, count, i, st_lo, st_hi);
}

// The width of the penumbra a blocker at segment parameter t casts at the receiver o: the light's
// extent seen through the blocker's edge, L t / (1 - t) by similar triangles (the blocker t of the
// way to the light), with L the light's shorter side foreshortened as seen from o (the narrowest
// penumbra any edge's orientation gives). Across it V runs from 0 to 1, so two receiver points a
// distance x apart see V differ by about x / width: the filter's bound on what averaging them
// costs (filter.comp). The receiver's own tilt only widens the penumbra along the surface and is
// left out: the bound errs on the sharp side. PN_PENUMBRA_NONE without a blocker (V has no edge
// here); 0 for a point light (hard shadows).
float penumbra_width_of(vec3 c0, vec3 c1, vec3 c2, vec3 c3, vec3 normal, vec3 o, float t)
{
    vec3 d = 0.25 * (c0 + c1 + c2 + c3) - o;
    // The cosine from d scaled to a max norm of 1: its square neither overflows nor underflows at
    // any scale positions take (pn_scene_validate).
    float m = max(max(abs(d.x), abs(d.y)), abs(d.z));
    vec3 u = m > 0.0 ? d / m : vec3(0.0);
    float cos_l = m > 0.0 ? max(dot(normal, -u), 0.0) / length(u) : 0.0;
    float side = min(distance(c1, c0), distance(c3, c0)) * cos_l;
    return t < 1.0 ? side * (t / (1.0 - t)) : PN_PENUMBRA_NONE;
}

// A sphere's patch, else the light's own corners and normal (the patch's values, read from the
// uniform block as before the patch existed).
float penumbra_width(vec3 o, float t)
{
    if (LIGHT_KIND == PN_LIGHT_SPHERE_ID)
        return penumbra_width_of(patch_corners[0], patch_corners[1], patch_corners[2], patch_corners[3], patch_normal,
                                 o, t);
    return penumbra_width_of(LIGHT.corners[0].xyz, LIGHT.corners[1].xyz, LIGHT.corners[2].xyz, LIGHT.corners[3].xyz,
                             LIGHT.normal.xyz, o, t);
}

// Adaptive sampling's first round under an interleaved tile draws the tile's grid cells in order
// (light_sample), so the first half of its samples by index would be the light's lower rows of cells
// and the second its upper ones: their difference would measure how V varies across the light, not
// its noise. There the halves are the cells of the grid's two checkerboard colours instead, each
// spread over the whole light as a Sobol' sequence's halves are (adaptive_decide); a grid of one
// column (MIN = 2, or a prime MIN) has no better split than its two ends. Each half's counts
// are then kept in img_adapt from the round's first chunk on (shadow_store).
bool halves_by_parity()
{
    return SPP_MIN != 0u && params.tile_w * params.tile_h > 1u && pixel_target == SPP_MIN;
}

// V from the pixel's (visible, valid) counts: 1 without a valid ray (the light does not reach it,
// or its rays missed the sliver that does; shadow_finish tells the two apart for the filter).
float counts_v(uvec2 counts) { return counts.y > 0u ? float(counts.x) / float(counts.y) : params.unreached_v; }

void shadow_store(ivec2 px, vec3 o, uint count, uvec2 add, uvec2 half_add, float t_add, float nearest_t, bool cut_short);

// Adds the chunk's outcome to the pixel's counts; the last chunk writes V = visible / valid. The
// pixel's rays are in slots base .. base + count - 1 of the per-ray arrays (chunk_rays_from); bit
// i of valid_rays and blocked is its ray i.
void shadow_finish_from(uint base, ivec2 px, vec3 o, uint count, uint valid_rays, uint blocked, bool cut_short)
{
    if (params.dump_rays != 0u) {
        ivec2 size = imageSize(img_v);
        uint pixel = uint(px.y * size.x + px.x), pixels = uint(size.x * size.y);
        params.dump.v[pixel] = vec4(o, 1.0);
        for (uint i = 0u; i < count; i++) {
            uint flags = ((valid_rays >> i) & 1u) | (((blocked >> i) & 1u) << 1u);
            params.dump.v[pixels + pixel * params.spp + pixel_begin + i] = vec4(o + dir[base + i], uintBitsToFloat(flags));
        }
    }
    // Adaptive sampling's error estimate compares the two halves of a pixel's target samples
    // (adaptive_decide): the counts over its first pixel_target / 2, taken as they pass. Up to there
    // every earlier sample lies in the first half (a target is at least twice the samples the
    // pixel had when it was set), so those counts are the earlier ones plus this chunk's part;
    // beyond, they are what the chunk that reached the half kept (shadow_store). Except in the first
    // round under an interleaved tile (halves_by_parity).
    uint half_n = SPP_MIN != 0u ? pixel_target / 2u : 0u;
    uint below = half_n - min(half_n, pixel_begin); // this chunk's rays in the first half
    uint first_half = valid_rays & (below >= 32u ? ~0u : (1u << below) - 1u);
    if (halves_by_parity()) {
        uint even = 0u;
        for (uint i = 0u; i < count; i++) {
            uint k = pixel_begin + i;
            even |= (((k % params.grid_u) + (k / params.grid_u)) & 1u) == 0u ? 1u << i : 0u;
        }
        first_half = valid_rays & even;
    }
    float t_add = 0.0, nearest = 1.0;
    for (uint b = valid_rays & blocked; b != 0u; b &= b - 1u) {
        t_add += blocker_t[base + findLSB(b)];
        nearest = min(nearest, blocker_t[base + findLSB(b)]);
    }
    shadow_store(px, o, count, uvec2(bitCount(valid_rays & ~blocked), bitCount(valid_rays)),
                 uvec2(bitCount(first_half & ~blocked), bitCount(first_half)), t_add, nearest, cut_short);
}

void shadow_finish(ivec2 px, vec3 o, uint count, uint valid_rays, uint blocked, bool cut_short)
{
    shadow_finish_from(0u, px, o, count, valid_rays, blocked, cut_short);
}

// Adds a dispatch's outcome at the pixel to its counts: `add` (visible, valid) rays, `half_add` of
// them in the first half of its target samples (adaptive sampling), the blocked rays' summed t and
// their nearest t; after the pixel's last chunk writes V = visible / valid.
void shadow_store(ivec2 px, vec3 o, uint count, uvec2 add, uvec2 half_add, float t_add, float nearest_t, bool cut_short)
{
    if (COUNT_WORK) {
        ivec2 size = imageSize(img_v);
        uint pixel = uint(px.y * size.x + px.x);
        uvec4 before = chunk.first != 0u ? uvec4(0u) : params.work.v[pixel];
        params.work.v[pixel] = uvec4(before.xyz + work.xyz, max(before.w, work.w));
    }
    uvec4 earlier = chunk.first != 0u ? uvec4(0u) : imageLoad(img_counts, px); // the earlier chunks' counts
    uvec4 adapt = chunk.first != 0u ? uvec4(0u) : imageLoad(img_adapt, px);
    uvec2 counts = earlier.xy + add; // (visible, valid)
    if (cut_short || truncated || budget_spent())
        atomicOr(status.truncated, 1u);
    // The last chunk leaves the counts for the filter, with whether any of the light lies above the
    // receiver's horizon and in front of the light (light_weight is zero exactly where none does).
    // A pixel without a valid ray then tells two cases apart: the light cannot reach it (V is the
    // convention 1 and carries no light), or its rays missed the sliver that does (V unknown).
    uint reaches = 1u;
    if (pixel_last && counts.y == 0u)
        reaches = light_weight(LIGHT, o, imageLoad(img_n, px).xyz) > 0.0 ? 1u : 0u;
    // And the penumbra width at the pixel's mean blocker (as PCSS estimates it), as float bits: from
    // the sum of the blocked rays' t (kept in img_adapt, across adaptive sampling's rounds too),
    // which counts.y - counts.x of them are.
    float t_sum = uintBitsToFloat(adapt.z) + t_add;
    uint blocked_rays = counts.y - counts.x;
    uint half_n = SPP_MIN != 0u ? pixel_target / 2u : 0u;
    uvec2 half_counts = (pixel_begin <= half_n && !halves_by_parity() ? earlier.xy : adapt.xy) + half_add;
    // Uniform samples' last chunk carries nothing on: no store.
    if (SPP_MIN != 0u || !pixel_last)
        imageStore(img_adapt, px, uvec4(half_counts, floatBitsToUint(t_sum), pixel_begin + count));
    float w = pixel_last ? penumbra_width(o, blocked_rays > 0u ? t_sum / float(blocked_rays) : 1.0) : t_sum;
    imageStore(img_counts, px, uvec4(counts, reaches, floatBitsToUint(w)));
    // The nearest blocker of the blocked rays, over every chunk and round (t = 1 while none is
    // blocked), and after the pixel's last chunk the penumbra width it casts: the narrowest of the
    // pixel's, which bounds how fast V can change there (the penumbra filter's footprint,
    // filter.comp). The farthest is not kept: no filter reads it.
    vec2 nearest = chunk.first != 0u ? vec2(1.0, PN_PENUMBRA_NONE) : imageLoad(img_blockers, px).xy;
    nearest.x = min(nearest.x, nearest_t);
    if (pixel_last)
        nearest.y = nearest.x < 1.0 ? penumbra_width(o, nearest.x) : PN_PENUMBRA_NONE;
    imageStore(img_blockers, px, vec4(nearest, 0.0, 0.0));
    if (pixel_last)
        imageStore(img_v, px, vec4(counts_v(counts)));
}

// Adaptive sampling (--spp MIN:MAX): every pixel traces MIN samples, then rounds in which the
// pixels whose V is still uncertain trace up to a target of their own, MIN x 2^k <= MAX
// (shadow_pass.c records them). After each round a dispatch of the same shader traces no ray and
// decides, per pixel that took part: img_rays gets its target (the samples it has, if it stops),
// the standard error of its V, and whether it stopped.
//
// The error estimate. The samples are a Sobol' sequence (light_sample), so the pixel's first and
// second halves are each a (0, m - 1, 2)-net, stratified as the whole is; their V differ by
// d = V1 - V2, and (d / 2)^2 estimates the variance of their mean V from the pixel's own samples
// with the stratification taken into account (it is the variance of two independent half-nets'
// mean, which bounds the whole net's from above: a conservative estimate). One pixel's d has one
// degree of freedom, and two halves that agree by luck would stop a penumbra pixel early, so the
// estimate is pooled over the 3 x 3 neighbours that have one (a valid ray in both halves), each
// scaled to the pixel's sample count by n_q / n (variance falls at least as 1 / n), as the filter
// averages them too. A pixel stops once sqrt of the pooled estimate is below params.pixel_error.
// And one whose samples all agree (V 0 or 1) stops only if every neighbour's V is the same 0 or 1:
// a thin penumbra, or a small blocker between the samples, that its neighbours saw sends it on.
// A pixel with no valid ray in either half takes its neighbours' estimate; with none at all, it
// goes on while the light reaches above its horizon (counts.z). Under an interleaved tile the
// first round's halves are the grid's two checkerboard colours instead (halves_by_parity), each
// spread over the whole light; and under the penumbra filter a pixel goes on only where the
// filter cannot average (below).
//
// The target: twice the samples the pixel has (the rounds double), at most MAX. Measured, going
// straight to the count the estimate asks for instead (n (stderr / E)^(4/3) or ^2, rounded up to
// n x 2^k) saves walks of the tree but overshoots: on the bunny and the dragon (512 x 512, exact,
// 4:64, E 0.1 / 0.05 / 0.02) its time against the reference MAE fell on the same curve as
// doubling's, within the runs' noise. A round over a pixel's own range [samples, target) keeps
// the choice open (shadow_pixel).
void adaptive_decide(ivec2 px)
{
    // The decision that opens a frame resuming the previous one's rounds (chunk.first) writes every
    // pixel's V from the counts that frame left: V is rewritten every frame, and a pixel that goes on
    // no more traces nothing in this one.
    bool opens = chunk.first != 0u;
    if (imageLoad(img_p, px).w <= 0.0) {
        imageStore(img_rays, px, uvec4(0u, 0u, 1u, 0u));
        if (opens)
            imageStore(img_v, px, vec4(0.0));
        return;
    }
    // After the first decision the dispatch runs over the list of the pixels that took part in the
    // round just ended (shadow_invocation_pixel): a pixel that stopped earlier keeps its decision.
    uint done = imageLoad(img_adapt, px).w;
    uvec4 c = imageLoad(img_counts, px);
    if (opens)
        imageStore(img_v, px, vec4(counts_v(c.xy)));
    bool unanimous = c.y > 0u && (c.x == 0u || c.x == c.y), agree = true;
    ivec2 size = imageSize(img_v);
    float var_sum = 0.0;
    uint estimates = 0u;
    for (int dy = -1; dy <= 1; dy++) {
        for (int dx = -1; dx <= 1; dx++) {
            ivec2 q = px + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size)) || imageLoad(img_p, q).w <= 0.0)
                continue;
            uvec4 cq = imageLoad(img_counts, q), hq = imageLoad(img_adapt, q);
            // A neighbour that saw another V than the pixel's unanimous one.
            if (cq.y > 0u && cq.x * c.y != c.x * cq.y)
                agree = false;
            uint first = hq.y, second = cq.y - hq.y;
            if (first == 0u || second == 0u)
                continue;
            float d = float(hq.x) / float(first) - float(cq.x - hq.x) / float(second);
            var_sum += 0.25 * d * d * (float(hq.w) / float(done));
            estimates++;
        }
    }
    float stderr = estimates > 0u ? sqrt(var_sum / float(estimates)) : (c.z != 0u ? 1.0 : 0.0);
    bool stop = done >= params.spp || (stderr < params.pixel_error && (!unanimous || agree));
    // Under the penumbra filter (params.refine_narrow) only where the filter cannot average. It
    // averages a pixel's neighbours over the penumbra its nearest blocker casts (filter.comp,
    // penumbra_filter.comp), so where that penumbra spans pixels more rays buy what the filter gives
    // for free; where it is under REFINE_PIXELS pixels wide (facing the camera, as the filters
    // measure it) the filter leaves the pixel about its own samples: its Gaussian's deviation is a
    // quarter of the width over sqrt(n), a quarter of a pixel at 4 samples (the Gaussian acts from
    // half a pixel on, so from 4 pixels wide at 4 samples; the window averages below that), and
    // only rays lower its error. That is a contact, a crease, and above all the terminator of a
    // curved surface, where the horizon of the interpolated normal cuts the light and the mesh's own
    // facets block the rays just above it: on the dragon at 4 spp (512 x 512, exact, penumbra
    // filter) the pixels whose nearest blocker cast under half a pixel held 20% of the reference
    // error, 88% of them with the light across their horizon, where the reference itself varies
    // pixel to pixel (by 0.23 from its 3 x 3 mean, against 0.016 in the other penumbra pixels):
    // detail, not noise. The width only narrows as rays are added (the nearest blocker of them
    // all), so a pixel refined once stays eligible in the rounds that follow. A pixel without a
    // valid ray where the light reaches above its horizon has no width and goes on as before.
    // Measured (bench, 512 x 512, exact, penumbra filter, --pixel-error 0.02, reference MAE, mean
    // rays; uniform 4 spp: the dragon 0.00515, the bunny 0.00564): 4:16 with REFINE_PIXELS 1 / 2 /
    // 4, the dragon 0.00463 / 0.00450 / 0.00446 at 4.18 / 4.23 / 4.31 rays, the bunny 0.00521 /
    // 0.00518 / 0.00518 at 4.23 / 4.28 / 4.34 (before the filter counted a pixel's samples as at
    // least the first round's, filter.comp, which took 2's to 0.00451 and 0.00513). Not in a frame
    // that continues the previous one's (the demo's progressive refinement, chunk.decide 2): there
    // every uncertain pixel goes on, so that the picture converges as the rounds add up; and not
    // under the interleaved filter, whose fixed window averages no wider penumbra.
    if (params.refine_narrow != 0u && CHUNK_DECIDE == 1u) {
        const float REFINE_PIXELS = 2.0;
        float width = imageLoad(img_blockers, px).y; // PN_PENUMBRA_NONE without a blocker: V is smooth
        float pixel = imageLoad(img_n, px).w * params.pixel_angle;
        stop = stop || !(width < REFINE_PIXELS * pixel || (c.y == 0u && c.z != 0u));
    }
    // The frame's last decision (chunk.last) sets no target: no round follows it, so the rays image
    // holds the samples the pixel took. In a frame that continues the previous one's, a pixel that
    // had stopped early may go on there without reaching the most.
    uint target = stop || chunk.last != 0u ? done : min(2u * done, params.spp);
    imageStore(img_rays, px, uvec4(target, floatBitsToUint(stderr), stop ? 1u : 0u, 0u));
    // The pixel goes on the next round's list; a new work group for every PN_WORKGROUP^2 of them.
    if (!stop) {
        uint list = chunk.list_out * PN_PIXEL_LIST_WORDS(params.tile_total);
        uint i = atomicAdd(pixel_lists.words[list + 3u], 1u);
        pixel_lists.words[list + 4u + i] = uint(px.x) | (uint(px.y) << 16u);
        if (i % uint(PN_WORKGROUP * PN_WORKGROUP) == 0u)
            atomicAdd(pixel_lists.words[list], 1u);
    }
}

// Background pixels: V = 0. Returns false for them, for the pixels with no samples in this chunk
// (adaptive sampling), and in adaptive sampling's decision dispatches, for all. Sets pixel_begin,
// pixel_end, pixel_target and pixel_last.
bool shadow_pixel(ivec2 px, out vec3 p, out vec3 nrm)
{
    bool inside = all(greaterThanEqual(px, ivec2(0))) && all(lessThan(px, imageSize(img_v)));
    if (CHUNK_DECIDE != 0u) {
        if (inside)
            adaptive_decide(px);
        return false;
    }
    pixel_begin = chunk.sample_begin;
    pixel_end = chunk.sample_end;
    pixel_target = SPP_MIN; // the first round's
    pixel_last = chunk.last != 0u;
    // Adaptive sampling's later rounds: the part of the chunk between the pixel's samples and its
    // target, for the pixels that go on.
    if (CHUNK_LIST_IN != 0u && inside) {
        uvec4 rays = imageLoad(img_rays, px);
        if (rays.z != 0u)
            return false;
        pixel_target = rays.x;
        pixel_begin = max(pixel_begin, imageLoad(img_adapt, px).w);
        pixel_end = min(pixel_end, pixel_target);
        pixel_last = pixel_end == pixel_target;
        if (pixel_begin >= pixel_end)
            return false;
    }
    vec4 pw = inside ? imageLoad(img_p, px) : vec4(0.0);
    p = pw.xyz;
    nrm = inside ? imageLoad(img_n, px).xyz : vec3(0.0, 1.0, 0.0);
    if (inside && pw.w <= 0.0 && chunk.last != 0u) {
        imageStore(img_v, px, vec4(0.0));
        imageStore(img_counts, px, uvec4(0u)); // no rays (pn_frame_images.counts)
        imageStore(img_blockers, px, vec4(1.0, PN_PENUMBRA_NONE, 0.0, 0.0));
    }
    return inside && pw.w > 0.0;
}
