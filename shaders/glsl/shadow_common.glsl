// Shared by the shadow shaders: parameters, light samples and the surface offset.
// ShadowParams and ShadowChunk are declared in interface.h, once for C and GLSL.
#include "pools.glsl"
#include "hash.glsl"

layout(set = 0, binding = PN_SHADOW_BINDING_PARAMS, std140) uniform ShadowParamsBlock { ShadowParams params; };

// The shadow pass runs in chunks of at most PN_MAX_CHUNK light samples (the size of the per-ray
// arrays, on every device), one dispatch each, accumulating counts.
// llvmpipe (Mesa 22.3): every shader invocation has a budget of 65535 loop iterations summed over
// all its loops, and every loop silently ends once it is spent, so a pixel's whole traversal may not
// fit in one dispatch. A shader that finds its loops cut short sets `status.truncated`; the host then
// renders the frame again with smaller chunks (engine/gpu/shadow_pass.c), so a result is never
// wrong. Other drivers have no such budget (pn_gpu_device_loop_budget). engine/gpu/llvmpipe.md.
layout(push_constant) uniform ShadowChunkBlock { ShadowChunk chunk; };

// The pipeline of a uniform frame (PN_SPEC_UNIFORM, shadow_pass.c: spp_min 0 and the even split):
// every pixel takes the chunk's samples, so adaptive sampling's rounds, pixel lists and decisions
// and the budgeted split compile away. On lavapipe they were a third of exact's compile at its
// first dispatch (the default render's 4-ray pipeline: 1.7-1.9 s against 2.35-2.45 s with them;
// engine/gpu/llvmpipe.md). The shaders read spp_min, the split, the chunk's decide and list_in
// through these names only.
layout(constant_id = PN_SPEC_UNIFORM) const bool UNIFORM = false;
#define SPP_MIN (UNIFORM ? 0u : params.spp_min)
#define SPLIT (UNIFORM ? uint(PN_SPLIT_EVEN_ID) : params.split)
#define CHUNK_DECIDE (UNIFORM ? 0u : chunk.decide)
#define CHUNK_LIST_IN (UNIFORM ? 0u : chunk.list_in)

// llvmpipe: true if this invocation's loop budget ran out: a loop of `canary` (= 2) iterations, a
// bound the compiler cannot see, completes only while budget is left. Call it after all other
// loops. Always false on drivers without the budget.
bool budget_spent()
{
    uint iterations = 0u;
    for (uint j = 0u; j < params.canary; j++)
        iterations++;
    return iterations != params.canary;
}

layout(set = 0, binding = PN_SHADOW_BINDING_COUNTS, rgba32ui) uniform uimage2D img_counts; // (visible, valid) so far
layout(std430, set = 0, binding = PN_SHADOW_BINDING_STATUS) buffer Status { uint truncated; } status;
layout(set = 0, binding = PN_SHADOW_BINDING_LINEAGE, rgba32ui) uniform readonly uimage2D img_lineage;

const uint SAMPLER_GRID = PN_SAMPLER_GRID_ID;
const uint SAMPLER_STRATIFIED = PN_SAMPLER_STRATIFIED_ID;


// Point k of the two-dimensional Sobol' sequence (van der Corput in base 2, and the Pascal
// matrix's dimension), digitally shifted by `shift` (a hash of it XORed into each axis).
// Every prefix of 2^m points is a (0, m, 2)-net: each of the 2^m equal strata of any shape
// (2^a x 2^b, a + b = m) holds one point, and a shift keeps that. So any count n is as evenly
// spread as a jittered grid of n at a power of two, and close to it between them, which the R2
// sequence of the stratified sampler is not at small n.
// The Sobol' sequence's two coordinates of point k as 32-bit fractions, unshifted.
uvec2 sobol_bits(uint k)
{
    uint x = bitfieldReverse(k), y = 0u;
    for (uint v = 1u << 31u, i = k; i != 0u; i >>= 1u, v ^= v >> 1u)
        y ^= (i & 1u) != 0u ? v : 0u;
    return uvec2(x, y);
}

vec2 sobol_sample(uint k, uint shift)
{
    uvec2 b = sobol_bits(k);
    uint x = b.x, y = b.y;
    x ^= pcg(shift), y ^= pcg(shift ^ 0x9e3779b9u);
    // The top 24 bits: floats of [0, 1) exactly (a 32-bit value would round up to 1.0).
    return vec2(float(x >> 8u), float(y >> 8u)) * (1.0 / 16777216.0);
}

// What light_sample draws alike for all of a pixel's samples: the tile's hash (which also gives the
// R2 jitters' rotation), the tile's shear of the pixel's place in it and the Sobol' shift. Made once per pixel
// (pixel_sampler) before its samples' loop instead of per sample, which hashed the tile 4 times
// and the cell twice more for each sample even for a 1 x 1 tile, where only the rotation is used.
// The same values, so the same samples bit for bit. Measured (bench, exact and linespace 6,3 on the
// bunny, dragon and Sponza at 256 x 256, 1 / 4 / 16 spp, filter none and penumbra, 5 repeats, two
// runs of each build taken in turn): the shadow pass's time over the 36 cells 2833 -> 2480 ms
// (0.875x), 33 cells faster; exact 16 spp 0.77-0.96x.
struct PixelSampler {
    uint h;          // the tile's hash
    uvec2 sheared;   // (u0, v0) below; 0 for a 1 x 1 tile
    uint sobol;      // the Sobol' sequence's shift (budgeted split, adaptive)
    uint rot;        // the jitters' rotation: the tile's hash, drawn per frame under the frame window
};

PixelSampler pixel_sampler(uvec2 pixel)
{
    PixelSampler ps;
    uvec2 tile_size = uvec2(params.tile_w, params.tile_h);
    uvec2 tile = pixel / tile_size, member = pixel % tile_size;
    ps.h = tile_hash(tile, params.seed);
    // Under the temporal history a pixel draws the samples of the lineage it continues
    // (history.comp: the surface point followed through the camera's moves, keyed where it was
    // first seen), so that the frames' samples of one surface point are one key's frame window,
    // complementary strata of the light, as a still camera's are. Drawn by the pixel it now lies
    // in, a moving point's samples came from different pixels' strata, no more complementary than
    // independent ones (engine/gpu/README.md, the temporal history). Only without an interleaved
    // tile, where the key is all of a pixel's sampler (no position in a tile): under one, a pixel
    // keeps its own samples, whose tile-mates' are complementary within the frame, which the
    // filter's window relies on (and no lineage is chosen: history.comp's stage 1 runs only then).
    if (params.frame_side != 0u && tile_size.x * tile_size.y == 1u)
        ps.h = imageLoad(img_lineage, ivec2(pixel)).x;
    // The temporal history's frame window (light_sample): frame f moves every pixel to the tile
    // position f mod T further on (a bijection of the tile: each frame's tile still holds every
    // sub-cell once), so that over T consecutive frames each pixel takes every sub-cell of each
    // cell, not the same 1/T of the light whose mean its history would converge to.
    if (params.frame_side != 0u) {
        uint t = params.frame % (tile_size.x * tile_size.y);
        member = (member + uvec2(t % tile_size.x, t / tile_size.x)) % tile_size;
    }
    // The Sobol' shift is the pixel's own: under an interleaved tile the samples an adaptive pixel
    // adds beyond the first round must not be its tile-mates' (they would err together, in blocks
    // of the tile). For a 1 x 1 tile the tile's hash is the pixel's; a uniform frame under a tile
    // draws no Sobol' point, so only adaptive sampling pays for the second hash.
    bool own = tile_size.x * tile_size.y > 1u && SPP_MIN != 0u;
    // With the temporal history's frame window the seed stays from frame to frame (its strata are
    // the window's); the Sobol' points take the frame into their shift instead, a new set a frame.
    ps.sobol = pcg((own ? pcg(pixel.x + pcg(pixel.y + pcg(params.seed))) : ps.h) + chunk.light);
    ps.rot = ps.h;
    if (params.frame_side != 0u) {
        ps.sobol = pcg(ps.sobol ^ pcg(params.frame + 0x27d4eb2du));
        ps.rot = pcg(ps.h ^ pcg(params.frame + 0x165667b1u));
    }
    ps.sheared = uvec2(0u);
    if (tile_size.x * tile_size.y > 1u) {
        if ((pcg(ps.h ^ 0x2545f491u) & 1u) == 0u) {
            ps.sheared.x = (member.x + member.y) % tile_size.x;
            ps.sheared.y = (member.y + ps.sheared.x) % tile_size.y;
        } else {
            ps.sheared.y = (member.y + member.x) % tile_size.y;
            ps.sheared.x = (member.x + ps.sheared.y) % tile_size.x;
        }
    }
    return ps;
}

// Light sample k of this pixel as (s, t) in [0,1)^2 over the light's width and height.
// Grid: the centres of a grid_u x grid_v grid, the paper's uniform grid (bilinear interpolation of the
// corner directions is the same point). Stratified: one jittered point per grid cell; the jitters are
// the R2 low-discrepancy sequence (additive recurrence with the plastic constant) rotated per pixel
// (Cranley-Patterson), so neighbouring pixels use different jitters and banding becomes fine noise.
// Interleaved (a tile_w x tile_h tile of more than one pixel, --filter interleaved): the tile's T
// pixels share one set of spp * T samples. Each grid cell (i, j) splits into tile_w x tile_h
// sub-cells; the pixel at (cx, cy) in its tile takes, in cell (i, j), the sub-cell
//     (u0 + j + a, v0 + i + b) mod (tile_w, tile_h),   a = hash(tile, i), b = hash(tile, j),
// with u0 = (cx + cy) mod tile_w, v0 = (cy + u0) mod tile_h in half the tiles (a hash of the tile
// chooses) and the mirror image v0 = (cy + cx) mod tile_h, u0 = (cx + v0) mod tile_w in the others.
// (u0, v0) is a bijection of the tile (two shears; for 3x3, (cx + cy, cx + 2 cy) or (2 cx + cy,
// cx + cy) mod 3) and the rest a translation, so:
//  - the union over the tile is one point per sub-cell of every cell, a stratified set of
//    spp * T samples, and every pixel's own spp are one per cell;
//  - along a row of cells (i runs) the pixel's sub-cell row steps by one, and along a column of
//    cells its sub-cell column: its own samples spread over the sub-cell rows of each cell row and
//    the columns of each cell column, as the per-pixel rotation of the R2 jitters spreads a 1 x 1
//    tile's;
//  - the shear gives the pixels of one row of the tile, and of one column, different sub-cell rows
//    and columns (for odd square tiles; others get part of it): each column of the tile meets every
//    sub-cell row and column. So a window that straddles two tiles side by side or one above the
//    other still holds each sub-cell row and column of a cell equally often; only a sub-cell itself
//    may be taken twice and another not at all (a window over four tiles keeps no such count). No
//    map avoids that: a window across a tile boundary sees every sub-cell only if the map repeats
//    with the tile's period along the boundary. With the translation alone the 3 pixels of a tile
//    row shared their sub-cell row in every cell, and where V follows the light's height (a
//    grazing-lit wall) they showed as dashes 3 pixels wide. With the shear, the pixels that share a
//    sub-cell row lie along a diagonal of the tile, so the mirror image in half the tiles: the
//    noise has no direction (adjacent pixels' errors on the Sponza wall correlate by -0.18 and -0.17
//    horizontally and vertically, +0.02 along either diagonal; one shear everywhere: +0.17 along
//    one; the translation alone: +0.25 horizontally);
//  - a and b are drawn per tile, so the pixels at one position in the tile do not take the same
//    sub-cells in every tile. Before (issue 33) one shift per cell served every tile: where the
//    filter averages nothing (its weights decline, e.g. on Sponza's grazing-lit wall), each
//    position's fixed subset of sub-cells showed as a regular grid with the tile's period
//    (tests/tile_pattern.sh).
// The jitters are the R2 sequence rotated per tile, the union's point k * T + sub-cell. Measured
// (bench --seed 1, 2, 3, exact, 256x256; filtered reference MAE, mean of the seeds, one shift per
// cell -> now): bunny 4 spp 0.0113 -> 0.0109, 16 spp 0.0045 -> 0.0040; dragon 4 spp 0.0095 ->
// 0.0087, 16 spp 0.0041 -> 0.0034. On Sponza's wall V_raw's RMS error fell from 0.060 to 0.035
// (unfiltered, per-pixel samples: 0.032; engine/gpu/README.md, the filter).
// Any tile_w x tile_h window holds one pixel of each position in the tile, so the filter's window
// sees spp * T samples spread over the sub-cells of every cell.
// A 1 x 1 tile gives the per-pixel sampler exactly. chunk_rays maps (s, t) into the pixel's
// horizon_box, which keeps the strata: they become the box's.
vec2 light_sample(uint k, PixelSampler ps)
{
    uint i = k % params.grid_u, j = k / params.grid_u;
    uvec2 tile_size = uvec2(params.tile_w, params.tile_h);
    uint tiles = tile_size.x * tile_size.y;
    // The pixel's sub-cell of cell (i, j) (above): the tile's shear (pixel_sampler), then its
    // translation for the cell, reduced before the sum, which then cannot wrap. 0 for a 1 x 1 tile.
    uvec2 sub2 = uvec2(0u);
    if (tiles > 1u) {
        uint a = pcg(ps.h ^ pcg(i + 0x68e31da4u)), b = pcg(ps.h ^ pcg(j + 0xb5297a4du));
        uvec2 shift = uvec2(j + a % tile_size.x, i + b % tile_size.y);
        sub2 = (ps.sheared + shift) % tile_size;
    }
    uint sub = sub2.x + tile_size.x * sub2.y;
    // Budgeted split and adaptive sampling: each pixel draws its own number of samples per light
    // (chunk_count, adaptive_decide), so there is no grid to stratify (but in the first round under
    // a tile, below); the Sobol' sequence is stratified at every power of two, and each half of it
    // too (adaptive_decide's estimate).
    // Adaptive sampling under a filter (an interleaved tile) keeps the tile for its first round, the
    // spp_min samples every pixel takes (the grid is spp_min's then: shadow_pass.c), so that the
    // filter's window sees the same stratified set as a uniform frame of spp_min: the round is that
    // frame's rays, bit for bit. The samples a pixel adds beyond it are its own Sobol' points from
    // spp_min on (pixel_sampler's shift is the pixel's), drawn independently of the first round:
    // each is uniform over the light, so their mean with the first round's is unbiased, though the
    // whole is not one nested net as a Sobol' prefix is.
    if (SPLIT == PN_SPLIT_BUDGET_ID || (SPP_MIN != 0u && (tiles == 1u || k >= SPP_MIN)))
        return sobol_sample(k, ps.sobol);
    // The temporal history's frame window (frame_side != 0): each sub-cell splits again into F =
    // frame_side^2 parts (a power of two at least the history's frames: renderer_frame.c), and
    // frame f takes the part of the Sobol' point (f + h) mod F, h a hash of the tile, the cell and
    // the sub-cell that the frames share (the seed stays), while pixel_sampler moves every pixel f mod T
    // positions on in its tile (T its pixels). So each frame's tile takes every sub-cell once, as
    // without the window; any T consecutive frames give each pixel every sub-cell of each cell;
    // and any F consecutive frames give each sub-cell every part once, in the order of a (0,
    // 2)-sequence, whose runs are spread over the sub-cell rather than along its rows: the tile's
    // samples over them are the stratified set of F times the frame's, as one frame of that many
    // would draw, where a new seed a frame drew independent sets of the few. Under an even tile a
    // pixel is in a sub-cell every T frames, which gave it only the parts of one residue of T: there
    // the frame's part steps by one more every T frames (frame_part, the host's), so that its steps
    // are odd, coprime to F. Each frame's sample is still uniform over its cell (h is uniform over
    // the pixels), and its jitter's rotation is drawn per frame. Measured (the default scene at
    // 320 x 180, 4 spp a frame, reference MAE after 16 frames, unfiltered / penumbra filter): a new
    // seed a frame 0.00116 / 0.00101; the window 0.00074 / 0.00067 (rows of parts in turn instead of
    // the (0, 2)-sequence: 0.00189 / 0.00088); 64 spp at once 0.00080 / 0.00050. The sub-cell in
    // h (since stop 74; one offset per tile and cell before): otherwise a frame's tile-mates all
    // took the same part, the same place within their sub-cells, a grid a frame that the filter's
    // window averaged worse than jittered points. bench --sequence light (every frame drops its
    // history, so each is its own samples alone; bunny 256x256, penumbra, 1 spp, 8 frames): the
    // mean MAE 4.0% above the frame without the window before, 1.4% now; test_temporal's first
    // still frame under the filter .00769 -> .00681, its 16th .00188 -> .00196 (a pixel's own
    // frames no longer take consecutive parts: the trade, for frames in motion). Masks, not
    // remainders: llvmpipe divides integers lane by lane.
    uvec2 window = uvec2(max(params.frame_side, 1u));
    uint rot = ps.rot;
    uvec2 sub_f = uvec2(0u);
    if (params.frame_side > 1u) {
        uint mask = params.frame_side * params.frame_side - 1u;
        uint k = (params.frame_part + pcg(ps.h ^ pcg(i + pcg(j + pcg(sub + 0x85ebca6bu))))) & mask;
        sub_f = sobol_bits(k) >> uvec2(32 - findMSB(params.frame_side));
    }
    vec2 jitter = vec2(0.5);
    if (params.sampler_kind == SAMPLER_STRATIFIED) {
        vec2 rotation = vec2(float(rot & 0xffffu), float(rot >> 16u)) / 65536.0;
        const vec2 alpha = vec2(0.7548776662466927, 0.5698402909980532); // 1/g, 1/g^2, g = plastic number
        jitter = fract(rotation + alpha * float(k * tiles + sub + 1u));
    }
    uvec2 c = uvec2(i * tile_size.x + sub2.x, j * tile_size.y + sub2.y);
    // A count whose grid is u x 2u (shadow_pass.c: 2, 8, 32, 128, ...) has cells twice as wide as
    // they are tall, stratified along their width only at its scale. So the two cells (of the
    // sub-cells' grid, the tile's union) that make a square take opposite halves of their width,
    // the pair's choice drawn per square and tile: a two-point net per square, each sample still
    // uniform over its cell. Only under a square tile, whose sub-cells keep the cells' shape (a
    // 2 x 3 tile's are three times as wide as tall). Measured (bench, 512 x 512, exact, the five standard
    // views, reference MAE; tests/sample_strata.sh checks the nets): unfiltered 2 spp 2-12% lower,
    // 32 spp 2.5-28% (the canopy .0158 -> .0113: before, its 32 spp lay far above the line through
    // 16 and 64), 8 spp 0.2-1.2%; under the penumbra filter, whose 3 x 3 window already mixes nine
    // pixels' strata, -1.4% to +1.0%; square counts unchanged, bit for bit.
    if (params.sampler_kind == SAMPLER_STRATIFIED && params.grid_v == 2u * params.grid_u && tile_size.x == tile_size.y) {
        // (Under the frame window the pairs' choice is drawn per frame too, as the rotation is.)
        uint half_x = (pcg(rot ^ pcg(c.x + pcg(c.y >> 1u) + 0x3c6ef372u)) ^ c.y) & 1u;
        jitter.x = (float(half_x) + jitter.x) * 0.5;
    }
    vec2 cell = vec2(c * window + sub_f);
    return (cell + jitter) / vec2(params.grid_u * tile_size.x * window.x, params.grid_v * tile_size.y * window.y);
}

// The light this dispatch traces (ShadowChunk.light; the pass runs once per light).
#define LIGHT params.lights[chunk.light]
#define LIGHT_KIND uint(LIGHT.corners[0].w)

// The parallelogram this pixel's light samples lie in (light_point, counter-clockwise seen from
// the side it emits to) and that side's normal: the light's own, or for a sphere a square of the
// pixel's own (light_patch). patch_none: the point is inside the sphere, no ray carries light.
vec3 patch_corners[4];
vec3 patch_normal;
bool patch_none;
float patch_k;   // SPHERE: 1 - cos(theta_max) of the cone the sphere subtends from the point
float patch_tan; // SPHERE: tan(theta_max)

// Sets the patch for the pixel at o. A sphere of centre c and radius r, at distance d: the cone of
// half-angle theta_max (sin = r / d) touches it along its tangent circle, at distance d - r^2 / d
// along the axis with radius r sqrt(d^2 - r^2) / d; the square round that circle, facing o, holds
// every ray's end (light_warp puts them on that circle's disk: the segment to it differs from the
// one to the sphere's near side only within the sphere, where no geometry is).
void light_patch(vec3 o)
{
    patch_none = false;
    patch_normal = LIGHT.normal.xyz;
    for (int c = 0; c < 4; c++)
        patch_corners[c] = LIGHT.corners[c].xyz;
    if (LIGHT_KIND != PN_LIGHT_SPHERE_ID)
        return;
    vec3 a = LIGHT.corners[0].xyz - o;
    float r = LIGHT.corners[1].w, d = length(a); // below FLT_MAX: positions are within 1e18
    if (!(d > r)) {
        patch_none = true;
        return;
    }
    vec3 w = a / d;
    float s = r / d, cos_max = sqrt(max(1.0 - s * s, 0.0));
    patch_k = s * s / (1.0 + cos_max); // 1 - cos, without cancelling when the sphere is small or far
    patch_tan = s / max(cos_max, 1e-30);
    vec3 m = o + (d - r * s) * w;
    float rho = r * cos_max;
    vec3 t = normalize(cross(w, abs(w.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
    patch_normal = -w;
    vec3 b = cross(patch_normal, t); // t x b = the normal, as pn_light_frame
    patch_corners[0] = m - rho * t - rho * b;
    patch_corners[1] = m + rho * t - rho * b;
    patch_corners[2] = m + rho * t + rho * b;
    patch_corners[3] = m - rho * t + rho * b;
}

// The concentric map (Shirley and Chiu) of the unit square onto the unit disk: it keeps areas and
// so the strata (each maps to a piece of the disk of the same area, compact).
vec2 concentric(vec2 st)
{
    vec2 a = 2.0 * st - 1.0;
    if (a.x == 0.0 && a.y == 0.0)
        return vec2(0.0);
    const float quarter_pi = 0.78539816;
    float r, phi;
    if (abs(a.x) > abs(a.y)) {
        r = a.x;
        phi = quarter_pi * (a.y / a.x);
    } else {
        r = a.y;
        phi = 2.0 * quarter_pi - quarter_pi * (a.x / a.y);
    }
    return r * vec2(cos(phi), sin(phi));
}

// A light sample's (s, t) in the patch (light_point) from the sampler's: the same for a rectangle;
// for a sun or a disk the disk inscribed in its square (uniform by area); for a sphere the point where the
// direction drawn uniformly by solid angle over its cone meets the tangent circle's disk: from the
// disk point x of radius u^(1/2), cos(theta) = 1 - u (1 - cos theta_max), and the point lies at
// tan(theta) / tan(theta_max) of the disk's radius. The result stays in the unit square (clamped
// against rounding), so the patch's corners bound every point.
vec2 light_warp(vec2 st)
{
    uint kind = LIGHT_KIND;
    if (kind != PN_LIGHT_SUN_ID && kind != PN_LIGHT_SPHERE_ID && kind != PN_LIGHT_DISK_ID)
        return st;
    vec2 x = concentric(st);
    if (kind == PN_LIGHT_SPHERE_ID) {
        float u = dot(x, x), uk = u * patch_k;
        float scale = u > 0.0 ? sqrt(uk * (2.0 - uk)) / (1.0 - uk) / patch_tan / sqrt(u) : 0.0;
        x *= scale;
    }
    return clamp(0.5 + 0.5 * x, 0.0, 1.0);
}

vec3 light_point(vec2 st)
{
    // Corners 0..3 at (s,t) = (0,0), (1,0), (1,1), (0,1): bilinear = exact point on the parallelogram.
    vec3 a = mix(patch_corners[0], patch_corners[1], st.x);
    vec3 b = mix(patch_corners[3], patch_corners[2], st.x);
    return mix(a, b, st.y);
}

// Upper bound of the spacing of floats near |x| (one ulp).
float ulp_bound(float x) { return max(abs(x), 1e-30) * 1.1920929e-7; }

