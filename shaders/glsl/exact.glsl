// Exact shadow rays: watertight ray-triangle test (Woop, Benthin, Wald 2013), the BVH traversal
// (a short explicit stack, any hit) and the triangle pools. Mirrors engine/accel/bvh.h.
// Include after shadow_common.glsl (uses ShadowParams).
#include "alpha.glsl"

// BvhNodeData (interface.h, pn_bvh_node on the C side): interior (count == 0): children first and
// first + 1; leaf: triangles bvh_tris[first .. first + count).
#define BvhNode BvhNodeData

// The ray in the shear-transformed frame of the watertight test: permuted so that z is the
// dominant axis of d, and sheared so that d becomes (0, 0, 1).
struct WRay {
    vec3 o;
    ivec3 k;  // kx, ky, kz
    vec3 s;   // Sx, Sy, Sz
};

WRay wray(vec3 o, vec3 d)
{
    vec3 ad = abs(d);
    int kz = ad.x > ad.y ? (ad.x > ad.z ? 0 : 2) : (ad.y > ad.z ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1, ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < 0.0) { // keep the winding: swap x and y
        int tmp = kx;
        kx = ky;
        ky = tmp;
    }
    WRay r;
    r.o = o;
    r.k = ivec3(kx, ky, kz);
    r.s = vec3(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    return r;
}

// Does the ray hit triangle (a, b, c) at t in (t_min, t_max)? Two-sided. Edges and vertices are
// shared without gaps: the edge functions are exact in sign, recomputed in double when zero.
// t_frac: (T, det), the hit's t = T / det where it hits (divided only for the hit that blocks).
bool wt_hit(WRay r, vec3 a, vec3 b, vec3 c, float t_min, float t_max, out vec2 t_frac, out vec3 uvw)
{
    vec3 A = a - r.o, B = b - r.o, C = c - r.o;
    float Ax = A[r.k.x] - r.s.x * A[r.k.z], Ay = A[r.k.y] - r.s.y * A[r.k.z];
    float Bx = B[r.k.x] - r.s.x * B[r.k.z], By = B[r.k.y] - r.s.y * B[r.k.z];
    float Cx = C[r.k.x] - r.s.x * C[r.k.z], Cy = C[r.k.y] - r.s.y * C[r.k.z];
    float U = Cx * By - Cy * Bx, V = Ax * Cy - Ay * Cx, W = Bx * Ay - By * Ax;
    if (U == 0.0 || V == 0.0 || W == 0.0) {
        U = float(double(Cx) * double(By) - double(Cy) * double(Bx));
        V = float(double(Ax) * double(Cy) - double(Ay) * double(Cx));
        W = float(double(Bx) * double(Ay) - double(By) * double(Ax));
    }
    bool hit = !((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0));
    float det = U + V + W;
    hit = hit && det != 0.0;
    float T = U * (r.s.z * A[r.k.z]) + V * (r.s.z * B[r.k.z]) + W * (r.s.z * C[r.k.z]);
    // t = T / det; compare without dividing (flip both for a negative determinant).
    float sd = det < 0.0 ? -1.0 : 1.0;
    t_frac = vec2(T, det);
    uvw = vec3(U, V, W); // the hit's barycentric weights of a, b, c, times det
    return hit && T * sd > t_min * det * sd && T * sd < t_max * det * sd;
}

// The last hit tri_hit found as (T, det): where bvh_blocked and leaf_blocked met their blocker.
vec2 hit_frac = vec2(1.0);
float last_hit_t() { return hit_frac.x / hit_frac.y; }

bool tri_hit(WRay r, uint tri, float t_min, float t_max)
{
    if (COUNT_WORK)
        work.z++;
    vec2 t_frac;
    vec3 uvw;
    vec4 a = params.tris.v[3u * tri];
    bool hit = wt_hit(r, a.xyz, params.tris.v[3u * tri + 1u].xyz, params.tris.v[3u * tri + 2u].xyz, t_min, t_max,
                      t_frac, uvw);
    uint rec = ALPHA ? floatBitsToUint(a.w) : 0u; // alpha_record: a masked triangle's hit may be on a cut-out texel
    if (hit && rec != 0u)
        hit = !alpha_cut(rec, uvw / t_frac.y);
    hit_frac = hit ? t_frac : hit_frac;
    return hit;
}

// Slab test of the box against the ray's t range; the far distance is grown by 2 gamma(3) (Ize
// 2013) so that rounding never loses a box the ray touches.
bool box_hit(vec3 lo, vec3 hi, vec3 o, vec3 inv_d, float t_min, float t_max)
{
    vec3 t0 = (lo - o) * inv_d, t1 = (hi - o) * inv_d;
    vec3 tn = min(t0, t1), tf = max(t0, t1);
    float near = max(max(tn.x, tn.y), max(tn.z, t_min));
    float far = min(min(tf.x, tf.y), min(tf.z, t_max)) * 1.0000004;
    return near <= far;
}

vec3 safe_inverse(vec3 d)
{
    // A zero component gets a huge finite inverse of the right sign: no 0 * inf = NaN in the slabs.
    return vec3(d.x != 0.0 ? 1.0 / d.x : 1e30, d.y != 0.0 ? 1.0 / d.y : 1e30, d.z != 0.0 ? 1.0 / d.z : 1e30);
}

const int BVH_STACK = PN_BVH_STACK;
uint bvh_stack[BVH_STACK];

// Any hit of the segment o + t*d, t in (t_min, t_max), against the BVH.
// llvmpipe: `truncated` (declared by the including shader) is set if the loop budget cut the walk
// short.
bool bvh_blocked(vec3 o, vec3 d, float t_min, float t_max)
{
    WRay r = wray(o, d);
    vec3 inv_d = safe_inverse(d);
    int sp = 0;
    uint node = 0u;
    bool hit = false, done = false;
    while (!hit && !done) {
        BvhNode nd = params.bvh.nodes[node];
        if (COUNT_WORK)
            work = uvec4(work.x + 1u, work.yz, max(work.w, uint(sp)));
        bool enter = box_hit(nd.min, nd.max, o, inv_d, t_min, t_max);
        if (enter && nd.count == 0u) {
            bvh_stack[sp] = nd.first + 1u; // the far child waits; depth <= BVH_STACK (bvh.c)
            sp++;
            node = nd.first;
        } else {
            if (enter)
                for (uint i = nd.first; i < nd.first + nd.count; i++)
                    hit = hit || tri_hit(r, params.bvh_tris.ids[i], t_min, t_max);
            done = sp == 0;
            if (!done) {
                sp--;
                node = bvh_stack[sp];
            }
        }
    }
    truncated = truncated || (!hit && !done);
    return hit;
}

// Any hit among the triangles of leaf `cell` (child index) of last-level N-tree node `node`.
bool leaf_blocked(uint node, uint cell, uint n3, WRay r, float t_min, float t_max)
{
    uint k = (node - params.cand_first) * n3 + cell;
    uint begin = params.cand_offset.ids[k], end = params.cand_offset.ids[k + 1u];
    bool hit = false;
    for (uint i = begin; i < end; i++)
        hit = hit || tri_hit(r, params.cand_tris.ids[i], t_min, t_max);
    return hit;
}

// ---------------------------------------------------------------------------------------------
// Packet walk (--traversal packet, exact's default): the chunk's rays share their origin o and
// end on the light, so they walk the BVH once together, each node carrying the bit mask of the
// rays that entered it. A node is loaded once for all of them, and only the rays of its mask are
// tested against its children's boxes; a leaf's triangle is set up once and tested against the
// rays of the leaf's mask. The rays of one pixel share most of their walk: on the dragon view
// (16 spp) a pixel's walk loads a quarter of the nodes its rays' separate walks do (llvmpipe.md).

// The triangle test of the packet, in o's frame (A = a - o, ...): ray o + t d hits the triangle at
// t = det / S with det = A.(B x C) and S = s_ab + s_bc + s_ca, s_xy = d.(X x Y), and inside it iff
// the three s_xy have det's sign (they are det / t times the hit's barycentric coordinates). It is
// two-sided and watertight as Woop's: a shared edge's s is the same products of the same floats
// with the sign flipped (`precise` keeps the compiler from fusing the two triangles' crosses
// differently), so a ray on the edge is inside at least one of them. It may differ from wt_hit's
// answer for a ray that grazes an edge (within rounding of it): exact either way.
struct PacketTri {
    vec3 nab, nbc, nca; // A x B, B x C, C x A
    float det;          // A.(B x C)
};

PacketTri packet_tri(vec3 o, vec3 a, vec3 b, vec3 c)
{
    precise vec3 A = a - o, B = b - o, C = c - o;
    precise vec3 nab = cross(A, B), nbc = cross(B, C), nca = cross(C, A);
    PacketTri t;
    t.nab = nab, t.nbc = nbc, t.nca = nca;
    t.det = dot(A, nbc);
    return t;
}

// The edge values of direction d and their sum S, times det's sign (all >= 0 inside).
vec4 packet_edges(PacketTri t, vec3 d)
{
    vec3 s = vec3(dot(d, t.nab), dot(d, t.nbc), dot(d, t.nca));
    float sum = s.x + s.y + s.z;
    return t.det < 0.0 ? -vec4(s, sum) : vec4(s, sum);
}

// A hit at t in (0, 1): inside, and sigma S > |det| > 0.
bool packet_hit(PacketTri t, vec4 e) { return all(greaterThanEqual(e.xyz, vec3(0.0))) && e.w > abs(t.det) && t.det != 0.0; }

// The chunk's frustum: apex o, corner directions D[c] to the parallelogram its samples lie in.
// Every ray's end o + d lies within `delta` of that parallelogram: the sample point is a bilinear
// mix of the light's corners (a few ulps of their magnitude off, plus how far the stored corners
// are from a parallelogram) and d = point - o rounds once more (an ulp of |o| or the corners'):
// 16 ulps of the larger magnitude, as a Euclidean distance, bound the rounding with room.
struct Frustum {
    vec3 D[4];         // corner directions
    float delta, dmax; // dmax: bound of |d| over the rays
};

Frustum frustum_make(vec3 o, vec2 st_lo, vec2 st_hi)
{
    Frustum f;
    vec3 q[4];
    q[0] = light_point(st_lo);
    q[1] = light_point(vec2(st_hi.x, st_lo.y));
    q[2] = light_point(st_hi);
    q[3] = light_point(vec2(st_lo.x, st_hi.y));
    float mag = max(max(abs(o.x), abs(o.y)), abs(o.z));
    f.dmax = 0.0;
    for (int c = 0; c < 4; c++) {
        mag = max(mag, max(max(abs(q[c].x), abs(q[c].y)), abs(q[c].z)));
        f.D[c] = q[c] - o;
        f.dmax = max(f.dmax, length(f.D[c]));
    }
    vec3 twist = patch_corners[2] - patch_corners[1] - patch_corners[3] + patch_corners[0];
    f.delta = 16.0 * ulp_bound(mag) + length(twist);
    f.dmax += f.delta;
    return f;
}

// A leaf triangle against the rays `live`: returns those it blocks. The frustum's four corner
// directions first: an edge that all four see outside misses every ray, and a triangle that all
// four see inside (and between o and the light) blocks every ray (each ray's direction is a convex
// combination of the corners', and the edge values and S are linear in d). Both only beyond a
// margin, |n_e| times delta plus the dots' rounding over |d| <= dmax, so that no ray's own test
// would disagree. Otherwise each ray is tested.
// The frustum's four corners against triangle t (above): whether it misses every ray, whether it
// covers every ray (`masked`: an alpha-masked triangle never covers), and the least S of the
// corners, lo_s (a covering triangle's hit is at most t = |det| / lo_s along every ray).
void packet_corners(Frustum f, PacketTri t, bool masked, out bool misses, out bool covers, out float lo_s)
{
    float slack = f.delta + 8.0 * ulp_bound(f.dmax);
    vec3 tol = vec3(length(t.nab), length(t.nbc), length(t.nca)) * slack;
    float tol_s = tol.x + tol.y + tol.z;
    vec4 lo = vec4(1e38), hi = vec4(-1e38);
    for (int c = 0; c < 4; c++) {
        vec4 e = packet_edges(t, f.D[c]);
        lo = min(lo, e);
        hi = max(hi, e);
    }
    float adet = abs(t.det);
    misses = t.det == 0.0 || any(lessThan(hi.xyz, -tol)) || hi.w < adet - tol_s;
    covers = !misses && !masked && all(greaterThan(lo.xyz, tol)) && lo.w > adet + tol_s;
    lo_s = lo.w;
}

// Ray direction d against triangle t, as every walk tests it: inside, between o and the light, and
// on an opaque texel of a masked triangle (rec: its alpha record, 0 if opaque). S (e.w) is set for
// the hit's t = |det| / S.
bool packet_ray_hits(PacketTri t, vec3 d, uint rec, out float s)
{
    vec4 e = packet_edges(t, d);
    bool hit = packet_hit(t, e);
    if (hit && rec != 0u) // the weights of a, b, c are s_bc, s_ca, s_ab over S
        hit = !alpha_cut(rec, e.yzx / e.w);
    s = e.w;
    return hit;
}

uint packet_leaf_tri(Frustum f, vec3 o, uint tri, uint live)
{
    vec4 a = params.tris.v[3u * tri]; // w: the triangle's alpha record (alpha.glsl), 0 if opaque
    PacketTri t = packet_tri(o, a.xyz, params.tris.v[3u * tri + 1u].xyz, params.tris.v[3u * tri + 2u].xyz);
    if (COUNT_WORK)
        work.z++;
    float adet = abs(t.det), lo_s;
    uint rec = ALPHA ? floatBitsToUint(a.w) : 0u; // masked: every ray's hit is tested against its texel
    bool misses, covers;
    packet_corners(f, t, rec != 0u, misses, covers, lo_s);
    uint hits = covers ? live : 0u;
    for (uint m = hits; m != 0u; m &= m - 1u)
        blocker_at(findLSB(m), adet / lo_s);
    for (uint m = misses || covers ? 0u : live; m != 0u; m &= m - 1u) {
        uint j = findLSB(m);
        if (COUNT_WORK)
            work.z++;
        float s;
        bool hit = packet_ray_hits(t, dir[j], rec, s);
        hits |= hit ? (1u << j) : 0u;
        if (hit)
            blocker_at(j, adet / s);
    }
    return hits;
}

uint mask_stack[BVH_STACK], first_stack[BVH_STACK], count_stack[BVH_STACK];

// The most rays a pixel has in this dispatch, a power of two up to MAX_CHUNK (the shadow pass
// makes a pipeline for each size a frame needs: pn_shadow_pass_prepare). llvmpipe: the per-ray
// slab tests of a step run over rays 0 .. PACKET_RAYS - 1, unrolled, a ray outside the node's mask
// masked off, so that every ray's inverse direction has a constant index and stays in registers;
// looping over the mask's set bits instead indexes that array per lane, a scalar load per lane
// and word (llvmpipe.md, fact 5). Measured (dragon 512x512, Mesa 25; llvmpipe.md): 4 spp 226 -> 201
// ms, 16 spp 506 -> 466 ms; at 32 rays (64 spp) no change either way.
layout(constant_id = PN_SPEC_PACKET_RAYS) const uint PACKET_RAYS = MAX_CHUNK;

// A packet walk's step once both children a and b of its node are tested (ma, mb: the rays that
// entered each): it goes on into the nearer along `towards` and stacks the other with its rays.
// Returns whether no ray entered either (the walk pops).
bool packet_descend(BvhNode a, BvhNode b, uint ma, uint mb, vec3 towards, inout int sp, out uint first, out uint count,
                    out uint mask)
{
    bool b_first = dot((b.min + b.max) - (a.min + a.max), towards) < 0.0;
    BvhNode near = b_first ? b : a, far = b_first ? a : b;
    uint m_near = b_first ? mb : ma, m_far = b_first ? ma : mb;
    if (m_near != 0u && m_far != 0u) {
        first_stack[sp] = far.first; // depth <= BVH_STACK (bvh.c)
        count_stack[sp] = far.count;
        mask_stack[sp] = m_far;
        sp++;
    }
    bool go_near = m_near != 0u;
    first = go_near ? near.first : far.first;
    count = go_near ? near.count : far.count;
    mask = go_near ? m_near : m_far;
    return mask == 0u;
}

// The next node of a packet walk from its stack; returns whether the walk is done (nothing stacked,
// or every ray blocked).
bool packet_pop(uint live, inout int sp, inout uint first, inout uint count, inout uint mask)
{
    bool done = sp == 0 || live == 0u;
    if (!done) {
        sp--;
        first = first_stack[sp];
        count = count_stack[sp];
        mask = mask_stack[sp];
    }
    return done;
}

// The chunk's rays `live` (their samples in [box_lo, box_hi] of the light's (s, t)) through the
// BVH together; returns those blocked. Each step tests both
// children of a node against the rays that entered it (one slab test per ray and child), goes on
// into the nearer one along the light's direction and leaves the other on the stack with its rays.
uint bvh_packet_blocked(vec3 o, uint live, vec2 box_lo, vec2 box_hi)
{
    Frustum f = frustum_make(o, box_lo, box_hi);
    vec3 towards = f.D[0] + f.D[1] + f.D[2] + f.D[3];
    vec3 inv_dir[PACKET_RAYS];
    [[unroll]] for (uint j = 0u; j < PACKET_RAYS; j++)
        inv_dir[j] = safe_inverse(dir[j]);
    uint blocked = 0u;
    int sp = 0;
    BvhNode root = params.bvh.nodes[0];
    uint first = root.first, count = root.count, mask = 0u;
    [[unroll]] for (uint j = 0u; j < PACKET_RAYS; j++)
        mask |= uint(box_hit(root.min, root.max, o, inv_dir[j], 0.0, 1.0)) << j;
    mask &= live;
    bool done = mask == 0u;
    while (!done) {
        mask &= live;
        bool pop = true;
        if (count == 0u && mask != 0u) {
            BvhNode a = params.bvh.nodes[first], b = params.bvh.nodes[first + 1u];
            if (COUNT_WORK)
                work = uvec4(work.x + 2u, work.yz, max(work.w, uint(sp)));
            uint ma = 0u, mb = 0u;
            [[unroll]] for (uint j = 0u; j < PACKET_RAYS; j++) {
                ma |= uint(box_hit(a.min, a.max, o, inv_dir[j], 0.0, 1.0)) << j;
                mb |= uint(box_hit(b.min, b.max, o, inv_dir[j], 0.0, 1.0)) << j;
            }
            pop = packet_descend(a, b, ma & mask, mb & mask, towards, sp, first, count, mask);
        } else if (mask != 0u) {
            for (uint i = first; i < first + count && (mask & live) != 0u; i++) {
                uint hits = packet_leaf_tri(f, o, params.bvh_tris.ids[i], mask & live);
                blocked |= hits;
                live &= ~hits;
            }
        }
        if (pop)
            done = packet_pop(live, sp, first, count, mask);
    }
    truncated = truncated || !done;
    return blocked;
}

// ---------------------------------------------------------------------------------------------
// Tile walk (exact's packet traversal at 1-16 rays a pixel): a pixel's few rays share little of
// their walk (../shared/docs/PLATFORM.md: at 1 spp a ray cost 3.3x one at 16), so the walk is
// shared by a block of pixels instead, 4 x 2 of them at up to 4 rays a pixel, 2 x 2 at 8 and 2 x 1
// at 16 (the block's rays fill at most the per-ray arrays' MAX_CHUNK): all the block's rays (each
// from its own pixel's origin) walk the BVH together as above, a node loaded once for all the rays
// that entered it. Each ray is tested as the pixel's own packet walk tests it (the slab test from
// its origin, the triangle set up once per pixel in that origin's frame: packet_tri), so the
// blocked rays are the same bit for bit (the packet walk's corner cull and umbra shortcut only
// decide what every ray's own test would); the blocker each records, the first its walk meets,
// may be another. llvmpipe: a step tests only the pixels of the block
// with a ray in the node's mask (an `if` per pixel, skipped when no lane of the SIMD group has
// one), each pixel's rays unrolled at constant indices (fact 5). Measured (512 x 512, penumbra
// filter, shadow ms, per pixel -> per block; llvmpipe.md): bunny 1 / 2 / 4 / 8 / 16 spp 63 -> 46,
// 89 -> 68, 136 -> 115, 227 -> 190, 372 -> 349; dragon 95 -> 69, 128 -> 105, 183 -> 168,
// 277 -> 263, 445 -> 451; Sponza 79 -> 46, 119 -> 79, 177 -> 130, 271 -> 199, 432 -> 382.
// At 32 rays (and in the pipeline for 32) a block of one pixel: no block walk (shadow_exact.comp).
const uint TILE_W = PACKET_RAYS <= 4u ? 4u : PACKET_RAYS <= 16u ? 2u : 1u, TILE_H = PACKET_RAYS <= 8u ? 2u : 1u;
const uint TILE_PIXELS = TILE_W * TILE_H;
// The block's rays: pixel k's in slots k * PACKET_RAYS .. (k + 1) * PACKET_RAYS - 1 (the tile walk
// runs only where they fit the per-ray arrays: TILE_PIXELS * PACKET_RAYS <= MAX_CHUNK).
const uint TILE_RAYS = TILE_PIXELS * PACKET_RAYS < MAX_CHUNK ? TILE_PIXELS * PACKET_RAYS : MAX_CHUNK;
const uint PIXEL_RAYS = PACKET_RAYS < 32u ? (1u << PACKET_RAYS) - 1u : ~0u; // a pixel's slots, as a mask
vec3 tile_o[TILE_PIXELS]; // each pixel's origin

// The block's rays `live` through the BVH together; returns those blocked. `towards`: roughly the
// light's direction, the near child entered first.
uint bvh_tile_blocked(uint live, vec3 towards)
{
    vec3 inv_dir[TILE_RAYS];
    [[unroll]] for (uint j = 0u; j < TILE_RAYS; j++)
        inv_dir[j] = safe_inverse(dir[j]);
    uint blocked = 0u;
    int sp = 0;
    BvhNode root = params.bvh.nodes[0];
    uint first = root.first, count = root.count, mask = 0u;
    [[unroll]] for (uint j = 0u; j < TILE_RAYS; j++)
        mask |= uint(box_hit(root.min, root.max, tile_o[j / PACKET_RAYS], inv_dir[j], 0.0, 1.0)) << j;
    mask &= live;
    bool done = mask == 0u;
    while (!done) {
        mask &= live;
        bool pop = true;
        if (count == 0u && mask != 0u) {
            BvhNode a = params.bvh.nodes[first], b = params.bvh.nodes[first + 1u];
            if (COUNT_WORK)
                work = uvec4(work.x + 2u, work.yz, max(work.w, uint(sp)));
            uint ma = 0u, mb = 0u;
            [[unroll]] for (uint k = 0u; k < TILE_PIXELS; k++) {
                if (((mask >> (k * PACKET_RAYS)) & PIXEL_RAYS) != 0u) {
                    vec3 o = tile_o[k];
                    [[unroll]] for (uint r = 0u; r < PACKET_RAYS; r++) {
                        uint j = k * PACKET_RAYS + r;
                        ma |= uint(box_hit(a.min, a.max, o, inv_dir[j], 0.0, 1.0)) << j;
                        mb |= uint(box_hit(b.min, b.max, o, inv_dir[j], 0.0, 1.0)) << j;
                    }
                }
            }
            pop = packet_descend(a, b, ma & mask, mb & mask, towards, sp, first, count, mask);
        } else if (mask != 0u) {
            for (uint i = first; i < first + count && (mask & live) != 0u; i++) {
                uint tri = params.bvh_tris.ids[i];
                vec4 a = params.tris.v[3u * tri]; // w: the triangle's alpha record (alpha.glsl), 0 if opaque
                vec3 b = params.tris.v[3u * tri + 1u].xyz, c = params.tris.v[3u * tri + 2u].xyz;
                uint rec = ALPHA ? floatBitsToUint(a.w) : 0u, m = mask & live;
                [[unroll]] for (uint k = 0u; k < TILE_PIXELS; k++) {
                    if (((m >> (k * PACKET_RAYS)) & PIXEL_RAYS) != 0u) {
                        // The set-up and each ray's test (packet_leaf_tri's, less the rays its corners decide).
                        if (COUNT_WORK)
                            work.z += 1u + bitCount((m >> (k * PACKET_RAYS)) & PIXEL_RAYS);
                        PacketTri t = packet_tri(tile_o[k], a.xyz, b, c);
                        [[unroll]] for (uint r = 0u; r < PACKET_RAYS; r++) {
                            uint j = k * PACKET_RAYS + r;
                            float s;
                            uint hit = uint(packet_ray_hits(t, dir[j], rec, s)) & (m >> j) & 1u;
                            blocked |= hit << j;
                            blocker_t[j] = hit != 0u ? min(blocker_t[j], max(abs(t.det) / s, 0.0)) : blocker_t[j];
                        }
                    }
                }
                live &= ~blocked;
            }
        }
        if (pop)
            done = packet_pop(live, sp, first, count, mask);
    }
    truncated = truncated || !done;
    return blocked;
}
