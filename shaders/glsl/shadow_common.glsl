// Shared by the shadow shaders: parameters, light samples and the surface offset.
// ShadowParams mirrors pn_shadow_params in engine/gpu/renderer.c.
#include "pools.glsl"

struct BvhNodeData {
    vec3 min;
    uint first;
    vec3 max;
    uint count;
};

// Triangle and BVH pools for the exact tests (engine/accel/bvh.h), reached by address.
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TriPool { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer BvhPool { BvhNodeData nodes[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer IndexPool { uint ids[]; };
// Per pixel: origin (xyz) and 1 where geometry is; then per pixel and sample: the light point (xyz)
// and flags (bit 0 valid, bit 1 blocked) as float bits. Mirrors pn_ray_dump in renderer.h.
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer RayDump { vec4 v[]; };
// Per pixel: nodes visited, line-space lookups, triangle tests, deepest stack (COUNT_WORK builds).
layout(buffer_reference, std430, buffer_reference_align = 16) buffer WorkCounts { uvec4 v[]; };

layout(set = 0, binding = 3, std140) uniform ShadowParams {
    TreeInfo tree;      // 64 bytes
    vec4 corners[4];    // light corners, counter-clockwise seen from the emitting side
    vec4 light_normal;  // xyz: emitting side
    uint spp;           // rays per pixel = grid_u * grid_v
    uint grid_u;        // samples across the light's width
    uint grid_v;        // samples across its height
    uint sampler_kind;  // 0 grid, 1 stratified
    uint seed;
    float leaf_size;    // edge of a leaf cell (level d), world units
    uint canary;        // 2: the iteration count of the loop-budget canary (see budget_spent)
    uint pad1;
    TriPool tris;          // 3 vec4 per triangle, scene order
    BvhPool bvh;           // exact mode
    IndexPool bvh_tris;    // triangle ids in BVH leaf order
    IndexPool cand_offset; // per leaf of the last-level N-tree nodes: first candidate (ntree.h)
    IndexPool cand_tris;   // candidate triangle ids
    RayDump dump;          // with dump_rays: every ray, for tests against an independent tracer
    uint dump_rays;
    uint cand_first;       // the first last-level node (they are numbered consecutively)
    WorkCounts work;       // COUNT_WORK builds only
    uvec2 pad3;
} params;

// The shadow pass runs in chunks of light samples, one dispatch each, accumulating counts: llvmpipe
// (Mesa 22.3) gives every shader invocation a budget of 65535 loop iterations summed over all its
// loops and silently ends every loop once it is spent, so a pixel's whole traversal cannot run in
// one dispatch. A shader that finds its loops cut short sets `status.truncated`; the host then
// renders the frame again with smaller chunks (engine/gpu/renderer.c), so a result is never wrong.
layout(push_constant) uniform Chunk {
    uint sample_begin; // light samples [sample_begin, sample_end) in this dispatch
    uint sample_end;
    uint first;        // 1: counts start at zero
    uint last;         // 1: write V = visible / valid
} chunk;

// True if this invocation's loop budget ran out: a loop of `canary` (= 2) iterations, a bound the
// compiler cannot see, completes only while budget is left. Call it after all other loops.
bool budget_spent()
{
    uint iterations = 0u;
    for (uint j = 0u; j < params.canary; j++)
        iterations++;
    return iterations != params.canary;
}

layout(set = 0, binding = 4, rg32ui) uniform uimage2D img_counts; // (visible, valid) so far
layout(std430, set = 0, binding = 5) buffer Status { uint truncated; } status;

const uint SAMPLER_GRID = 0u;
const uint SAMPLER_STRATIFIED = 1u;

// PCG hash (O'Neill): decorrelates pixels and seeds.
uint pcg(uint v)
{
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Light sample k of this pixel as (s, t) in [0,1)^2 over the light's width and height.
// Grid: the centres of a grid_u x grid_v grid, the paper's uniform grid (bilinear interpolation of the
// corner directions is the same point). Stratified: one jittered point per grid cell; the jitters are
// the R2 low-discrepancy sequence (additive recurrence with the plastic constant) rotated per pixel
// (Cranley-Patterson), so neighbouring pixels use different jitters and banding becomes fine noise.
vec2 light_sample(uint k, uvec2 pixel)
{
    uint i = k % params.grid_u, j = k / params.grid_u;
    vec2 jitter = vec2(0.5);
    if (params.sampler_kind == SAMPLER_STRATIFIED) {
        uint h = pcg(pixel.x + pcg(pixel.y + pcg(params.seed)));
        vec2 rotation = vec2(float(h & 0xffffu), float(h >> 16u)) / 65536.0;
        const vec2 alpha = vec2(0.7548776662466927, 0.5698402909980532); // 1/g, 1/g^2, g = plastic number
        jitter = fract(rotation + alpha * float(k + 1u));
    }
    return (vec2(i, j) + jitter) / vec2(params.grid_u, params.grid_v);
}

vec3 light_point(vec2 st)
{
    // Corners 0..3 at (s,t) = (0,0), (1,0), (1,1), (0,1): bilinear = exact point on the parallelogram.
    vec3 a = mix(params.corners[0].xyz, params.corners[1].xyz, st.x);
    vec3 b = mix(params.corners[3].xyz, params.corners[2].xyz, st.x);
    return mix(a, b, st.y);
}

// Upper bound of the spacing of floats near |x| (one ulp).
float ulp_bound(float x) { return max(abs(x), 1e-30) * 1.1920929e-7; }

