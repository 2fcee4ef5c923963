// The contract between the C side and the shaders, in one file both include: every struct the two
// share (with its GPU layout), every binding number, specialisation id and constant. C includes it
// as "interface.h" (engine/gpu/interface_check.c pins the layouts with _Static_assert, and
// tests/test_interface.c reads every struct back through a GPU probe); GLSL includes it like any
// other include. Field macros expand to C arrays or GLSL vectors, so a field is written once.
#ifndef PN_INTERFACE_H
#define PN_INTERFACE_H

// ---------------------------------------------------------------------------------------------
// Constants

// The shadow passes' compute work groups are PN_WORKGROUP x PN_WORKGROUP pixels.
#define PN_WORKGROUP 8
// The image passes' (filters, shade, history): a row of PN_ROW_GROUP pixels. On llvmpipe each of
// its SIMD groups is 8 pixels of one row, as in an 8 x 8 group, but a group's loads run along
// rows of each image instead of across 8 of them. Measured (builtin:default 1280 x 720, medians of
// 5): the shade pass 20.9-21.6 ms as 8 x 8, 18.2-18.6 as 32 x 2, 17.7 as 64 x 1 (16 x 16: 28).
#define PN_ROW_GROUP 64
// Light samples one shadow dispatch traces at most (the shader's per-ray arrays hold this many).
#define PN_MAX_CHUNK 32
// Lights of one frame at most (ShadowParams.lights). The shadow and shading passes run once per
// light; the tree and the G-buffer are shared.
#define PN_MAX_LIGHTS 16
// Deepest N-tree (root = depth 0 .. PN_NTREE_MAX_DEPTH); the line-space walk's stack holds one DDA
// per level.
#define PN_NTREE_MAX_DEPTH 6
// Entries of the BVH walk's stack; the builder keeps trees shallower than this (accel/bvh.c).
#define PN_BVH_STACK 64
// Tree-pool entries: empty cell, filled leaf, and subdivided child i as PN_CELL_FIRST_NODE + i.
#define PN_CELL_EMPTY 0u
#define PN_CELL_FILLED 1u
#define PN_CELL_FIRST_NODE 2u

// Specialisation constant ids and their values.
#define PN_SPEC_TRAVERSAL 0 // shadow shaders: how a pixel's rays walk the N-tree
#define PN_TRAVERSAL_RAY_ID 0    // each ray alone (3D-DDA per level)
#define PN_TRAVERSAL_PACKET_ID 1 // the pixel's rays together (line space: slice by slice; exact: one BVH walk)
#define PN_TRAVERSAL_AUTO_ID 2   // host only: the faster for the mode (pn_traversal_resolve)
#define PN_TRAVERSAL_PROJECT_ID 3 // exact: the pixel's triangles projected onto the light, all samples at once (project.glsl)
// Samples of one pixel in one dispatch of the projection traversal (its bit masks: 32 words).
#define PN_PROJECT_MAX_SAMPLES 1024
// Work counters' w (the deepest stack) with this bit: the projection traversal's budget ran out at
// the pixel, whose remaining samples were traced as rays.
#define PN_WORK_FALLBACK 0x80000000u
#define PN_SPEC_VARIANT 1 // shadow_linespace.comp: which line-space mode
#define PN_VARIANT_LINESPACE 0 // the paper's method
#define PN_VARIANT_HYBRID 1    // exact triangles where the ray starts and ends
#define PN_VARIANT_EXACT_LS 2  // line spaces only skip empty space
#define PN_VARIANT_LEAF 3      // set last-level shafts walked down to the leaves; a filled leaf blocks
#define PN_VARIANT_PLANE 4     // the same walk, from the origin; a filled leaf's plane slab decides
#define PN_SPEC_COUNT_WORK 2   // shadow shaders: count work per pixel (a 32-bit bool)
#define PN_SPEC_PACKET_RAYS 3  // exact.glsl: the most rays of a pixel in one dispatch (a power of two)
#define PN_SPEC_ALPHA 4        // shadow shaders: the scene has alpha-masked casters (a 32-bit bool)
#define PN_SPEC_PROJECT_SAMPLES 5 // project.glsl: the most samples of a pixel in one dispatch (32 x 2^k)
#define PN_SPEC_UNIFORM 6     // shadow shaders: a uniform frame's pipeline (a 32-bit bool; shadow_common.glsl)
#define PN_SPEC_TEXTURE_COUNT 0 // gbuffer.frag: size of the texture array
#define PN_SPEC_TILE_W 0 // filter.comp: the window (the interleaving tile), 1..PN_FILTER_MAX_TILE
#define PN_SPEC_TILE_H 1
#define PN_SPEC_LIGHT_KIND 0 // shade.comp: the light's kind (PN_LIGHT_*_ID), a pipeline per kind a frame has

// ShadowParams.sampler_kind. Zero is each enum's default on the command line.
#define PN_SAMPLER_STRATIFIED_ID 0 // jittered strata, per-pixel rotated R2 jitters (the default)
#define PN_SAMPLER_GRID_ID 1 // the paper's uniform grid
// ShadowParams.split: how a pixel's rays are shared among several lights.
// Light.corners[0].w: the light's kind (scene/light.h, the kinds' table).
#define PN_LIGHT_RECT_ID 0 // a one-sided Lambertian parallelogram; all corners equal: a point emitting as one
#define PN_LIGHT_OMNI_ID 1 // a point emitting the same intensity every way, or into a spot's cone
#define PN_LIGHT_SUN_ID 2  // a directional light with an angular diameter: a disk far beyond the scene
#define PN_LIGHT_SPHERE_ID 3 // a sphere of uniform radiance: each point samples the cone it subtends
#define PN_LIGHT_DISK_ID 4   // a one-sided Lambertian disk: the square round it, samples mapped onto it
#define PN_LIGHT_KIND_IDS 5  // the kinds' count
#define PN_LIGHT_DISK_SIDES 64 // light_irradiance integrates a disk as a regular polygon of as many sides and the same area

#define PN_SPLIT_EVEN_ID 0   // spp rays for every light
#define PN_SPLIT_BUDGET_ID 1 // a budget of rays per pixel, shared by each light's unshadowed irradiance

// Descriptor bindings, set 0 of each pass.
#define PN_GBUFFER_BINDING_MATERIALS 0 // storage buffer of Material
#define PN_GBUFFER_BINDING_TEXTURES 1  // combined image samplers [PN_SPEC_TEXTURE_COUNT]
#define PN_SHADOW_BINDING_P 0       // rgba32f: world position, w = 1 where geometry is
#define PN_SHADOW_BINDING_N 1       // rgba32f: normal, w = view depth
#define PN_SHADOW_BINDING_V 2       // r32f: visibility out
#define PN_SHADOW_BINDING_PARAMS 3  // uniform ShadowParams
#define PN_SHADOW_BINDING_COUNTS 4  // rgba32ui: (visible, valid) samples so far, between chunks; after
                                    // the last, (visible, valid, reaches, 0) for the filter (shadow_finish)
#define PN_SHADOW_BINDING_STATUS 5  // storage buffer: uint truncated (llvmpipe: loop budget spent)
#define PN_SHADOW_BINDING_ADAPT 6   // rgba32ui: (visible, valid) over the first half of the pixel's samples,
                                    // the blocked rays' summed t (float bits), the samples so far (shadow_finish)
#define PN_SHADOW_BINDING_RAYS 7    // rgba32ui: adaptive sampling's target samples for the pixel, the standard
                                    // error of its V (float bits), whether it stopped (adaptive_decide)
#define PN_SHADOW_BINDING_LISTS 8   // storage buffer: adaptive sampling's two lists of pixels (below)
#define PN_SHADOW_BINDING_BLOCKERS 9 // rg32f: the blocked rays' nearest blocker as segment parameter t
                                     // (1 without one), and after a pixel's last chunk the penumbra
                                     // width it casts, world units (shadow_finish; the penumbra filter's)
#define PN_SHADOW_BINDING_LINEAGE 10 // rgba32ui: under the temporal history, the sampler key of the
                                     // lineage each pixel continues (history.comp, x); without it
                                     // bound to RAYS and never read (frame_side 0)
#define PN_SHADOW_BINDING_COUNT 11
#define PN_SHADOW_BINDING_TLAS 11   // acceleration structure: only the modes whose needs.tlas is set
#define PN_SHADE_BINDING_P 0
#define PN_SHADE_BINDING_N 1
#define PN_SHADE_BINDING_ALBEDO 2
#define PN_SHADE_BINDING_V 3
#define PN_SHADE_BINDING_OUT 4 // rgba32f: radiance out
#define PN_SHADE_BINDING_COUNT 5
#define PN_FILTER_BINDING_P 0     // rgba32f: world position, w = 1 where geometry is
#define PN_FILTER_BINDING_N 1     // rgba32f: normal, w = view depth
#define PN_FILTER_BINDING_V_RAW 2 // r32f: the shadow pass's V
#define PN_FILTER_BINDING_V 3     // r32f: filtered V out
#define PN_FILTER_BINDING_COUNTS 4 // rgba32ui: the shadow pass's (visible, valid, reaches) per pixel
#define PN_FILTER_BINDING_BLOCKERS 5 // rg32f: the shadow pass's nearest blocker (with the penumbra filter)
#define PN_FILTER_BINDING_SIGMA 6    // rg32f: out, with the penumbra filter: its footprint per pixel
                                     // (PN_PENUMBRA_BINDING_SIGMA)
#define PN_FILTER_BINDING_TILES 7    // r32ui, with the penumbra filter: a texel per block of
                                     // PN_PENUMBRA_BLOCK_W x PN_PENUMBRA_BLOCK_H pixels, a bit per
                                     // PN_PENUMBRA_MARK_W x _BLOCK_H tile of it set where a pixel within
                                     // PN_PENUMBRA_LEND_REACH of the tile has a blocker of its own (the
                                     // pass sets them, the frame clears them)
#define PN_FILTER_BINDING_LIST 8     // storage buffer, with the penumbra filter: out, the marked blocks
                                     // (PN_PENUMBRA_BINDING_LIST)
#define PN_FILTER_BINDING_SCRATCH 9  // rg32f, with the penumbra filter: out, the row pass's output where
                                     // it is not a lit pixel's (PN_PENUMBRA_SCRATCH_CLEAR)
#define PN_FILTER_BINDING_COUNT 10
// The penumbra filter (--filter penumbra, penumbra_filter.comp): after the interleaved filter, a
// separable Gaussian as wide as the penumbra.
#define PN_PENUMBRA_BINDING_P 0        // rgba32f: world position, w = 1 where geometry is
#define PN_PENUMBRA_BINDING_N 1        // rgba32f: normal, w = view depth
#define PN_PENUMBRA_BINDING_COUNTS 2   // rgba32ui: the shadow pass's (visible, valid, reaches, width)
#define PN_PENUMBRA_BINDING_V 3        // r32f: the interleaved filter's V in, the penumbra filter's out
#define PN_PENUMBRA_BINDING_SIGMA 4    // rg32f: the pixel's own footprint (world units; -1 without a
                                       // blocker), 1 where it lends its V (geometry and a valid ray):
                                       // the interleaved filter's pass writes it (filter.comp)
#define PN_PENUMBRA_BINDING_SCRATCH 5  // rg32f: the row pass's V and the pixel's footprint (in pixels facing
                                       // the camera: world units over view depth x pixel angle; the EXR's)
#define PN_PENUMBRA_BINDING_LIST 6     // storage buffer: the marked blocks (PN_TILE_LIST_*), the Gaussian's
                                       // dispatches' groups (the interleaved filter's pass fills it)
#define PN_PENUMBRA_BINDING_TILES 7    // r32ui: the marks (PN_FILTER_BINDING_TILES), read
#define PN_PENUMBRA_BINDING_COUNT 8
// What the frame clears the row pass's output to (PN_PENUMBRA_BINDING_SCRATCH): a lit pixel's, V 1
// lent and no footprint. The row pass runs only in the marked blocks; elsewhere the interleaved
// filter's pass writes it where it differs at a covered pixel (no valid ray; the background's is
// never read: it lends nothing), so the column pass reads it as the row pass would have left it.
#define PN_PENUMBRA_SCRATCH_CLEAR 1.0
// What the frame clears V (PN_FILTER_BINDING_V) and the footprints (PN_FILTER_BINDING_SIGMA: x; y is
// 1, it lends its V) to under the penumbra filter: a lit pixel's, V 1 and no blocker of its own.
// The interleaved filter's pass leaves them there (filter.comp's lit pixels: most of an image).
#define PN_PENUMBRA_LIT_V 1.0
#define PN_PENUMBRA_LIT_FOOTPRINT -1.0
// The list of marked blocks: a VkDispatchIndirectCommand (the blocks, PN_PENUMBRA_BLOCK_H, 1) and a
// word of padding, then each block's first pixel as x | y << 16, in the order their first marks
// came; the frame empties it with the marks. Only a marked block holds a pixel the Gaussian changes
// (penumbra_filter.comp), so its two dispatches run a group per row of each listed block.
#define PN_TILE_LIST_HEADER 4
// The farthest pixel (in x and y) whose footprint a pixel without a blocker takes: the 5 x 5's
// outer ring (narrowest_neighbour in penumbra_filter.comp).
#define PN_PENUMBRA_LEND_REACH 2
// The blocks of PN_FILTER_BINDING_TILES, in pixels: PN_ROW_GROUP x 8, eight of the Gaussian's work
// groups (a row each, as every image pass's: its loads run along image rows).
#define PN_PENUMBRA_BLOCK_W PN_ROW_GROUP
#define PN_PENUMBRA_BLOCK_H 8
// A block's marks, a bit per tile of PN_PENUMBRA_MARK_W x PN_PENUMBRA_BLOCK_H pixels (bit x / MARK_W
// within the block): the row pass searches a lit pixel's neighbours for a footprint only in a
// marked tile (one of llvmpipe's SIMD rows of 8 lanes: the search is skipped where all 8 agree).
#define PN_PENUMBRA_MARK_W 8
// The temporal history (--temporal, history.comp): after each light's shadow pass, the pixel's
// samples of earlier frames carried to it and added to its own.
#define PN_HISTORY_BINDING_P 0         // rgba32f: this frame's world position, w = 1 where geometry is
#define PN_HISTORY_BINDING_N 1         // rgba32f: this frame's normal, w = view depth
#define PN_HISTORY_BINDING_PREV_P 2    // rgba32f: the previous frame's positions (its P, as its pass kept it)
#define PN_HISTORY_BINDING_COUNTS 3    // rgba32ui: this frame's counts (the shadow pass's)
#define PN_HISTORY_BINDING_V_RAW 4     // r32f: the shadow pass's V, rewritten where history adds to it
#define PN_HISTORY_BINDING_STORE_IN 5  // rgba32ui array, a layer per light: up to the previous frame, per
                                       // pixel the float bits of the sums of visible and valid samples,
                                       // where their samples lie (half floats, pixels from its centre)
                                       // and the pixel's normal (octahedral, 16-bit snorm)
#define PN_HISTORY_BINDING_STORE_OUT 6 // rgba32ui array: the same up to this frame
#define PN_HISTORY_BINDING_OUT 7       // rgba32ui: what the filters read in the counts' place: the
                                       // float bits of the sums of visible and valid samples, then
                                       // this frame's counts.z and counts.w
#define PN_HISTORY_BINDING_PARAMS 8    // uniform HistoryParams
#define PN_HISTORY_BINDING_POS_OUT 9   // rgba32f: this frame's P kept for the next frame (light 0's pass)
#define PN_HISTORY_BINDING_LINEAGE 10  // rgba32ui: this frame's lineage per pixel (the choosing stage's
                                       // out, the shadow pass's and the adding stage's in): its sampler
                                       // key (hash.glsl), the previous pixel whose history it takes
                                       // (x | y << 16; PN_HISTORY_NONE: none), where the lineage's
                                       // point lies (half floats, pixels from its centre) and the
                                       // pixel's normal (octahedral)
#define PN_HISTORY_BINDING_TRAIL 11    // rgba32ui: the previous frame's lineages (the choice reads them)
#define PN_HISTORY_BINDING_TRAIL_OUT 12 // rgba32ui: this frame's, for the next (light 0's adding stage)
#define PN_HISTORY_BINDING_COUNT 13
#define PN_HISTORY_NONE 0xffffffffu
// history.comp's stage, a pipeline each: 0 adds a light's samples (choosing its previous pixel),
// 1 chooses each pixel's previous pixel and lineage (once a frame, before the shadow passes, in
// frames without an interleaved tile), 2 adds a light's samples from that choice.
#define PN_SPEC_HISTORY_STAGE 0
// The most boxes of moved geometry one frame drops history under (more are merged on the host).
#define PN_HISTORY_MAX_BOXES 32
// filter.comp and penumbra_filter.comp: the counts they read are the history's (float sums).
#define PN_SPEC_FILTER_TEMPORAL 2
#define PN_SPEC_PENUMBRA_TEMPORAL 0
// penumbra_filter.comp: its stage, a pipeline each (PN_PENUMBRA_STAGE_*, a 32-bit uint).
#define PN_SPEC_PENUMBRA_STAGE 1
// Its stages, one dispatch each.
#define PN_PENUMBRA_STAGE_BLUR_X 0    // the Gaussian along rows, V -> scratch
#define PN_PENUMBRA_STAGE_BLUR_Y 1    // and along columns, scratch -> V
#define PN_PENUMBRA_STAGES 2
// The Gaussian's deviation is at most max_radius / this many pixels (filter_common.glsl:
// penumbra_footprint), so that RADIUS_SIGMAS of it (its weight there exp(-3.1)) fit the frame's
// budget of max_radius pixels.
#define PN_PENUMBRA_RADIUS_SIGMAS 2.5
// Its taps reach this many deviations (its weight there exp(-2)), within the above. Beyond 2
// deviations lies 1.8% of the weight of taps half a deviation apart, so the taps beyond it average
// little more, and 2 of the 11 taps go. Measured (bench, 512 x 512, exact, penumbra filter, the
// five standard views at 1 / 2 / 4 spp): the reference MAE within 0.00005 of 2.5's in every cell,
// the edge leak within 0.02%; Sponza's filter pass 31.2 against 35.7 ms at 1 spp and 29.6 against
// 31.5 ms at 4 spp (means of 4 alternated runs of 9 frames; runs ranged 26-35 ms), the bunny's
// within the noise. A power of two: reach() multiplies by it exactly.
#define PN_PENUMBRA_TAP_SIGMAS 2.0
// The largest tile edge (--tile): a window of 8 x 8 = 64 neighbours per pixel already costs the
// filter pass more than a few light samples would (filter.comp loads three images per neighbour).
#define PN_FILTER_MAX_TILE 8
// The penumbra width (counts.w, shadow_finish) of a pixel whose rays met no blocker: FLT_MAX.
#define PN_PENUMBRA_NONE 3.4028234663852886e38

// ---------------------------------------------------------------------------------------------
// Field macros

#ifdef GL_core_profile // GLSL
#extension GL_EXT_buffer_reference : require
#define PN_STRUCT(glsl_name, c_name) struct glsl_name
#define PN_END(glsl_name, c_name) ;
#define PN_UINT(x) uint x;
#define PN_INT(x) int x;
#define PN_FLOAT(x) float x;
#define PN_VEC3(x) vec3 x;
#define PN_VEC4(x) vec4 x;
#define PN_VEC4S(x, n) vec4 x[n];
#define PN_UVEC2(x) uvec2 x;
#define PN_UVEC4(x) uvec4 x;
#define PN_MAT4(x) mat4 x;
#define PN_ADDR(type, x) type x; // a buffer reference: a 64-bit device address
#define PN_MEMBER(glsl_type, c_type, x) glsl_type x;
#define PN_MEMBERS(glsl_type, c_type, x, n) glsl_type x[n];
#else // C
#include <stdint.h>
#define PN_STRUCT(glsl_name, c_name) typedef struct c_name
#define PN_END(glsl_name, c_name) c_name;
#define PN_UINT(x) uint32_t x;
#define PN_INT(x) int32_t x;
#define PN_FLOAT(x) float x;
#define PN_VEC3(x) float x[3];
#define PN_VEC4(x) float x[4];
#define PN_VEC4S(x, n) float x[n][4];
#define PN_UVEC2(x) uint32_t x[2];
#define PN_UVEC4(x) uint32_t x[4];
#define PN_MAT4(x) float x[16]; // column-major, as cglm's mat4
#define PN_ADDR(type, x) uint64_t x;
#define PN_MEMBER(glsl_type, c_type, x) c_type x;
#define PN_MEMBERS(glsl_type, c_type, x, n) c_type x[n];
#endif

// ---------------------------------------------------------------------------------------------
// Structs. Layouts: std430 in storage buffers and push constants, std140 in the uniform block;
// padding is explicit so that both rules give the C layout (interface_check.c asserts it).

// One subdivided N-tree node in the node pool (accel/pools.h has the pools' layout). 32 bytes.
PN_STRUCT(Node, pn_gpu_node) {
    PN_VEC3(min)       // box corner; the box is a cube
    PN_FLOAT(size)     // edge length
    PN_UINT(children)  // first entry of its children group in the tree pool
    PN_UINT(level)     // root = 0
    PN_UINT(linespace) // first word of its line space in the line-space pool
    PN_UINT(parent)    // node index, 0xffffffff for the root
} PN_END(Node, pn_gpu_node)

// A BVH node (accel/bvh.h): a leaf when count > 0 (triangles first..first+count of the BVH's
// order), else an inner node whose children are first and first + 1. 32 bytes.
PN_STRUCT(BvhNodeData, pn_bvh_node) {
    PN_VEC3(min)
    PN_UINT(first)
    PN_VEC3(max)
    PN_UINT(count)
} PN_END(BvhNodeData, pn_bvh_node)

#ifdef GL_core_profile
// The pools, reached by address: none is bound by a storage-buffer range limit.
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer NodePool { Node nodes[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer TreePool { uint entries[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer LinespacePool { uint words[]; };
// Triangles as 3 vec4 each (xyz), scene order.
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer TriPool { vec4 v[]; };
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer BvhPool { BvhNodeData nodes[]; };
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer IndexPool { uint ids[]; };
// Per pixel: origin (xyz) and 1 where geometry is; then per pixel and sample: the light point (xyz)
// and flags (bit 0 valid, bit 1 blocked) as float bits (pn_renderer_ray_dump).
layout(buffer_reference, std430, buffer_reference_align = 16) writeonly buffer RayDump { vec4 v[]; };
// Per pixel: nodes visited, line-space lookups, triangle tests, deepest stack (COUNT_WORK builds).
layout(buffer_reference, std430, buffer_reference_align = 16) buffer WorkCounts { uvec4 v[]; };
#endif

// Everything a shader needs to walk the N-tree's pools. 64 bytes.
PN_STRUCT(TreeInfo, pn_gpu_tree_info) {
    PN_VEC3(root_min)
    PN_FLOAT(root_size)
    PN_UINT(n)
    PN_UINT(d)
    PN_UINT(ls_words)   // 32-bit words per line space
    PN_UINT(node_count)
    PN_ADDR(NodePool, node_pool)
    PN_ADDR(TreePool, tree_pool)
    PN_ADDR(LinespacePool, ls_pool)
    PN_ADDR(IndexPool, plane_pool) // with leaf planes (ls-plane): one word per leaf of the last-level nodes
} PN_END(TreeInfo, pn_gpu_tree_info)

// One object of the per-object trees (--trees object, accel/objects.h): the N-tree of its mesh, in
// the mesh's own frame, and the map from world space into that frame. 128 bytes.
PN_STRUCT(ObjectData, pn_gpu_object) {
    PN_MEMBER(TreeInfo, pn_gpu_tree_info, tree)
    PN_VEC4S(to_local, 3) // rows of the world -> local affine map: x_local[r] = dot(to_local[r].xyz, x) + to_local[r].w
    PN_FLOAT(rise_scale)  // its leaves' world extent over ShadowParams.leaf_size (>= 1): how much
                          // farther than the finest tree's a ray rises before this tree may block it
    PN_UINT(pad0)
    PN_UINT(pad1)
    PN_UINT(pad2)
} PN_END(ObjectData, pn_gpu_object)

#ifdef GL_core_profile
layout(buffer_reference, std430, buffer_reference_align = 16) readonly buffer ObjectPool { ObjectData objects[]; };
#endif

// A light of the frame: the parallelogram its samples are drawn over, and its kind. 96 bytes.
//   corners[i].xyz: counter-clockwise seen from the emitting side (a sun's: the square round its far
//     disk; all equal for a point); corners[0].w: PN_LIGHT_*_ID;
//   OMNI: corners[1].w, corners[2].w the cosines of a spot's outer and inner cone angles (-2, -1
//     without a cone); SUN: corners[1].w sin^2 of half its diameter; SPHERE: every corner its
//     centre, corners[1].w its radius (each point's own square: light_patch); DISK: the corners
//     of the square round it
//   normal: unit, the emitting side (xyz; a spot's axis, a sun's direction of travel)
//   radiance: rgb; w = 1: a point (RECT with all corners equal, or OMNI), rgb its intensity (W/sr);
//     SUN: rgb the irradiance on a plane facing it
PN_STRUCT(Light, pn_light_gpu) {
    PN_VEC4S(corners, 4)
    PN_VEC4(normal)
    PN_VEC4(radiance)
} PN_END(Light, pn_light_gpu)

// The shading pass's push constants: one light's term of the sum over lights. 112 bytes.
PN_STRUCT(ShadePush, pn_shade_push) {
    PN_MEMBER(Light, pn_light_gpu, light)
    PN_UINT(accumulate) // 0: the first light, writes the radiance; 1: adds to it
    PN_UINT(pad0)
    PN_UINT(pad1)
    PN_UINT(pad2)
} PN_END(ShadePush, pn_shade_push)

// A glTF material as the G-buffer pass reads it. 32 bytes.
PN_STRUCT(Material, pn_material_gpu) {
    PN_VEC4(base_color)
    PN_INT(texture)       // -1: none
    PN_FLOAT(alpha_cutoff) // > 0: alpha-masked, the surface is cut out where base_color.a x texture.a is below it
    PN_INT(pad1)
    PN_INT(pad2)
} PN_END(Material, pn_material_gpu)

// G-buffer pass push constants, per draw. 112 bytes.
PN_STRUCT(GBufferPush, pn_gbuffer_push) {
    PN_MAT4(view_proj) // world -> Vulkan clip space (y down, depth 0..1)
    PN_VEC4(eye)       // camera position (xyz)
    PN_VEC4(forward)   // unit view direction (xyz): view depth = dot(P - eye, forward)
    PN_UINT(material)  // index into the materials
    PN_UINT(pad0)
    PN_UINT(pad1)
    PN_UINT(pad2)
} PN_END(GBufferPush, pn_gbuffer_push)

// The shadow pass's uniform block (std140). 272 + 96 PN_MAX_LIGHTS bytes.
PN_STRUCT(ShadowParams, pn_shadow_params) {
    PN_MEMBER(TreeInfo, pn_gpu_tree_info, tree)
    PN_UINT(spp)           // rays per pixel = grid_u * grid_v (adaptive: the most; the grid is then
                           // spp_min's under a filter's tile, the first round's)
    PN_UINT(grid_u)        // samples across the light's width
    PN_UINT(grid_v)        // samples across its height
    PN_UINT(sampler_kind)  // PN_SAMPLER_*_ID
    PN_UINT(seed)
    PN_FLOAT(leaf_size)    // edge of a leaf cell (level d), world units
    PN_UINT(canary)        // llvmpipe: 2, the iteration count of the loop-budget canary (shadow_common.glsl)
    PN_FLOAT(scene_mag)    // largest |coordinate| of the scene's bounds: bounds every vertex (shadow_origin)
    PN_ADDR(TriPool, tris)          // triangles of the exact tests
    PN_ADDR(BvhPool, bvh)           // exact mode
    PN_ADDR(IndexPool, bvh_tris)    // triangle ids in BVH leaf order
    PN_ADDR(IndexPool, cand_offset) // per leaf of the last-level N-tree nodes: first candidate (ntree.h)
    PN_ADDR(IndexPool, cand_tris)   // candidate triangle ids
    PN_ADDR(RayDump, dump)          // with dump_rays: every ray, for tests against an independent tracer
    PN_UINT(dump_rays)
    PN_UINT(cand_first)             // the first last-level node (they are numbered consecutively)
    PN_ADDR(WorkCounts, work)       // COUNT_WORK builds only
    PN_UINT(tile_w)                 // interleaved sampling: the tile whose pixels share the light's
    PN_UINT(tile_h)                 // strata (1 x 1: every pixel has all of them; light_sample)
    PN_UINT(object_count)           // per-object trees: objects in `objects`; 0: the one tree in `tree`
    PN_UINT(split)                  // PN_SPLIT_*_ID: how a pixel's rays are shared among the lights
    PN_ADDR(ObjectPool, objects)    // per-object trees: the objects, each with its tree
    PN_ADDR(BvhPool, top)           // a BVH over the objects' world boxes
    PN_ADDR(IndexPool, top_ids)     // object indices in the top BVH's leaf order
    PN_UINT(light_count)            // lights in `lights`
    PN_UINT(budget)                 // PN_SPLIT_BUDGET_ID: rays per pixel over all the lights
    PN_UINT(spp_min)                // adaptive sampling (--spp MIN:MAX): the first round's samples;
                                    // 0: every pixel takes spp (adaptive_decide, shadow_frame.glsl)
    PN_FLOAT(pixel_error)           // adaptive: a pixel stops once its V's standard error is below this
    PN_UINT(tiles_across)           // work groups across the image (its PN_WORKGROUP-square tiles)
    PN_UINT(tile_total)             // and in all: a pixel list holds this many groups' pixels
    PN_ADDR(IndexPool, alpha_bits)  // with alpha-masked casters: which leaves of the last-level nodes
                                    // hold one (pn_ntree.alpha_bits), tested exactly in every mode
    PN_ADDR(IndexPool, masked_tris) // rayquery, alpha-masked casters: the triangle id (scene order) of each
                                    // primitive of the acceleration structure's masked geometry (gpu/tlas.h)
    PN_FLOAT(project_budget)        // --traversal project: triangles a pixel may test per sample before its
                                    // remaining samples are traced as rays (project.glsl)
    PN_UINT(block_walk)             // exact's packet walk may share a block of pixels (shadow_exact.comp:
                                    // tile_main); 0 once the loop budget ran out (llvmpipe.md)
    PN_FLOAT(pixel_angle)           // a pixel's footprint per unit of view depth: 2 tan(yfov / 2) / height
                                    // (adaptive_decide under the penumbra filter)
    PN_UINT(refine_narrow)          // 1: the penumbra filter: adaptive rounds refine only where it cannot
                                    // average (adaptive_decide)
    PN_FLOAT(unreached_v)           // V where no sample carries light: 1 (render's convention) or 0
                                    // (the library's; pn_renderer_desc.unreached_zero; counts_v)
    PN_UINT(frame)                  // the temporal history's frame number (light_sample's frame window)
    PN_UINT(frame_side)             // its frame window (0: none): each sub-cell splits into frame_side^2
                                    // parts (a power of two) that consecutive frames take in turn
    PN_UINT(frame_part)             // the part this frame starts from (light_sample)
                                    // (the lights start at a multiple of 16 bytes, as std140 puts them)
    PN_MEMBERS(Light, pn_light_gpu, lights, PN_MAX_LIGHTS) // the frame's lights; a dispatch traces ShadowChunk.light
} PN_END(ShadowParams, pn_shadow_params)

// The filter pass's push constants (filter.comp). 32 bytes. Its window is specialised
// (PN_SPEC_TILE_W, PN_SPEC_TILE_H).
PN_STRUCT(FilterPush, pn_filter_push) {
    PN_FLOAT(pixel_angle) // a pixel's footprint per unit of view depth: 2 tan(yfov / 2) / height
    PN_UINT(samples)      // light samples per pixel (the shadow pass's): the noise of one pixel's V;
                          // 0 for a point light, whose V has none; adaptive: the first round's, MIN
    PN_UINT(adaptive)     // 1: pixels took samples of their own number (adaptive sampling): the
                          // noise of each pixel's V is that of its own valid rays, or of MIN where
                          // fewer (a pixel's first round, as uniform samples count it)
    PN_FLOAT(narrow)      // > 0 (the penumbra filter's window scale): the window's weights also fall as
                          // a Gaussian of the nearest blocker's penumbra, narrowing with the samples;
                          // and the pass writes the penumbra filter's footprints
    PN_FLOAT(width_scale) // the penumbra filter's Gaussian at 1 sample, in penumbra widths (PenumbraPush)
    PN_UINT(max_radius)   // the most pixels its taps may lie from the pixel
    PN_UINT(pad0)
    PN_UINT(pad1)
} PN_END(FilterPush, pn_filter_push)

// The penumbra filter's push constants (penumbra_filter.comp). 32 bytes.
PN_STRUCT(PenumbraPush, pn_penumbra_push) {
    PN_FLOAT(pixel_angle) // a pixel's footprint per unit of view depth: 2 tan(yfov / 2) / height
    PN_UINT(samples)      // light samples per pixel (FilterPush.samples); 0 for a point light
    PN_UINT(adaptive)     // 1: each pixel's own valid rays count instead, at least `samples`
                          // (FilterPush.adaptive)
    PN_UINT(max_radius)   // the most pixels a tap may lie from the pixel (the frame's budget)
    PN_UINT(pad0)
    PN_UINT(pad1)
    PN_UINT(pad2)
    PN_UINT(pad3)
} PN_END(PenumbraPush, pn_penumbra_push)

// The temporal history's frame (history.comp, std140). 1136 + 96 PN_MAX_LIGHTS bytes.
PN_STRUCT(HistoryParams, pn_history_params) {
    PN_MAT4(prev_view_proj) // the previous frame's world -> clip (GBufferPush.view_proj)
    PN_VEC4(prev_eye)       // and its camera (GBufferPush.eye, forward): a point's view depth
    PN_VEC4(prev_forward)
    PN_UINT(box_count)      // boxes of geometry that moved since the previous frame
    PN_FLOAT(pixel_angle)   // this frame's pixel footprint per unit of view depth
    PN_FLOAT(prev_pixel_angle)
    PN_UINT(depth_from_eye) // 1: a point's view depth is dot(P - eye, forward) below (the library's
                            // recorder: the host's N has no depth); 0: N.w (the renderer's G-buffer)
    PN_VEC4S(box_lo, PN_HISTORY_MAX_BOXES) // xyz, padded outward on the host (history_pass.c)
    PN_VEC4S(box_hi, PN_HISTORY_MAX_BOXES)
    PN_MEMBERS(Light, pn_light_gpu, lights, PN_MAX_LIGHTS) // this frame's lights
    PN_VEC4(eye)            // this frame's camera, with depth_from_eye
    PN_VEC4(forward)
    PN_MAT4(view_proj)      // this frame's world -> clip: which pixel a previous pixel's point lands in
    PN_UINT(frame)          // the shadow passes' frame number and seed (ShadowParams'): a new
    PN_UINT(seed)           // lineage's key (hash.glsl)
    PN_UINT(drop_mask)      // bit i: light i drops its history this frame (HistoryPush.drop, for the choice)
    PN_UINT(pad0)
} PN_END(HistoryParams, pn_history_params)

// The temporal history's push constants: one light per dispatch. 16 bytes.
PN_STRUCT(HistoryPush, pn_history_push) {
    PN_UINT(light) // the light (its layer of the store, its entry of HistoryParams.lights)
    PN_UINT(drop)  // 1: no history for this light (it moved, or the history was reset)
    PN_FLOAT(cap)  // the most samples the sums hold: older samples weigh less beyond it
    PN_FLOAT(noise_pixels) // the pixels a filter after averages a frame's noise over (1: none)
} PN_END(HistoryPush, pn_history_push)

// The shadow pass's push constants: one chunk of one light's samples per dispatch, or adaptive
// sampling's decision between two rounds. 32 bytes.
PN_STRUCT(ShadowChunk, pn_shadow_chunk) {
    PN_UINT(sample_begin) // light samples [sample_begin, sample_end) in this dispatch
    PN_UINT(sample_end)
    PN_UINT(first)        // 1: counts start at zero; with decide: it opens a frame that resumes the
                          // previous one's rounds, and writes every pixel's V
    PN_UINT(last)         // 1: write V = visible / valid; with decide: the frame's last decision,
                          // which only reports (a pixel's rays: the samples it took)
    PN_UINT(light)        // the light of ShadowParams.lights whose visibility this dispatch computes
    PN_UINT(decide)       // adaptive: 1 = no rays; decide which pixels go on after the round just
                          // ended (adaptive_decide); 2 the same in a frame that continues the
                          // previous one's, where no refine_narrow rule applies
    PN_UINT(list_in)      // 0: a work group per tile of the image; 1 + k: an invocation per pixel of
                          // list k (indirect)
    PN_UINT(list_out)     // decide: the list (0 or 1) that gets the pixels that go on
} PN_END(ShadowChunk, pn_shadow_chunk)

// The adaptive pixel lists (PN_SHADOW_BINDING_LISTS), as uint words: list k (0, 1) at
// k * PN_PIXEL_LIST_WORDS: a VkDispatchIndirectCommand (groups, 1, 1) and the count of pixels, then
// the pixels as x | y << 16, a work group of PN_WORKGROUP^2 per PN_WORKGROUP^2 of them.
#define PN_PIXEL_LIST_WORDS(tile_total) (4u + (tile_total) * PN_WORKGROUP * PN_WORKGROUP)

#endif
