// Projection traversal (--traversal project, exact's): one walk of the BVH per pixel answers every
// light sample of the pixel at once. Include after exact.glsl.
//
// A shadow ray answers one sample; where the pyramid from the pixel to the light holds few
// triangles, each triangle inside it can answer all the samples instead. The packet walk's
// triangle test (packet_tri, packet_edges: the ray o + t d hits iff the three edge values s_xy =
// d.(X x Y) have det's sign and their sum exceeds |det|) is linear in the ray's direction d, and d
// runs over the light's parallelogram affinely in its (s, t): so the samples a triangle blocks are
// those whose (s, t) lie in the intersection of four half-planes of the light, the triangle
// projected from the pixel onto the light and cut where it crosses the plane through the pixel and
// the light's own plane, with no vertex projected at all (a vertex near the pixel's plane, which a
// projection would magnify without bound, changes nothing). Each sample is then decided by the
// very test the packet walk gives its ray (the same products of the same floats): V equals exact's
// with the same samples.
//
// The samples' bit masks: `todo`, the valid samples not yet blocked (a sample below the pixel's
// horizon or behind a one-sided light is invalid from the start). The walk ends when none is left
// (umbra). A node is entered when its box meets the pyramid (its four side planes, the pixel's
// plane and the light's), and skipped when every sample its box's projection covers is blocked
// already (the coverage cull). Which samples a triangle may block is bounded by its vertices
// projected onto the light's plane (a bound only: the decision is each sample's own test); that box
// names the strata cells to test for a rectangle's uniform samples, else the groups of
// PROJECT_GROUP consecutive samples whose boxes it meets. Under a point light (one sample)
// shadow_project.comp traces its ray instead.
//
// The budget: the walk counts the triangles it tests; past params.project_budget per sample, the
// pixel traces its remaining samples as rays with the packet walk (a dense mesh under a large
// light puts thousands of tiny triangles in one pyramid). The samples already blocked stay
// blocked.

// Samples of one dispatch: a pipeline for each power of two the frame needs, up to
// PN_PROJECT_MAX_SAMPLES (shadow_pass.c: pn_shadow_pass_prepare keeps chunks at most that big).
layout(constant_id = PN_SPEC_PROJECT_SAMPLES) const uint PROJECT_MAX = PN_PROJECT_MAX_SAMPLES;
const uint PROJECT_GROUP = 8u;                   // samples per group box
const uint PROJECT_GROUPS = PROJECT_MAX / PROJECT_GROUP;
const uint PROJECT_WORDS = PROJECT_MAX / 32u;

vec3 proj_dir[PROJECT_MAX];     // sample k's ray: o + proj_dir[k] is its point on the light
vec4 proj_box[PROJECT_GROUPS];  // the (s, t) box of each group's valid samples (lo.xy, hi.zw; lo > hi: none)
uint proj_todo[PROJECT_WORDS];  // valid samples not yet blocked
uint proj_blocked[PROJECT_WORDS];
uint proj_left, proj_valid;     // samples in proj_todo, valid samples
float proj_t_sum, proj_nearest; // the blocked samples' summed t and the nearest (shadow_store)
// The samples' strata (a rectangle's light with a grid or stratified sampler, uniform samples):
// sample k lies in cell (k % grid_u, k / grid_u) of the grid_u x grid_v grid over the samples'
// box of the light's (s, t) (light_sample, chunk_rays), so a triangle's shadow box gives the cells
// and so the samples to test directly. Otherwise (a disk, sun or sphere, whose samples are warped,
// or the Sobol' samples of the budgeted split) the groups' boxes do.
bool proj_grid;
vec2 proj_cell_lo, proj_cell_scale; // cell coordinates of (s, t): (st - lo) * scale
uint proj_k0;                       // the dispatch's first sample: bit i is sample proj_k0 + i

// The pixel's light plane in the light's (s, t): a point's ray direction is base + s e1 + t e2
// (the patch's parallelogram; its twist, the corners' rounding, is in the frustum's delta).
struct ProjPlane {
    vec3 base, e1, e2;
    vec3 up;         // unit, from the pixel towards the light's plane (against its emitting normal)
    float height;    // the light's plane above the pixel along `up` (the farthest corner's)
    vec3 e1d, e2d;   // dual vectors: (s, t) of a point x of the plane are (x - corner 0).e1d, .e2d
    vec2 st_o;       // (s, t) of the pixel's foot, (o - corner 0).e1d, .e2d
    float e_len;     // max(|e1d|, |e2d|): world lengths on the plane to (s, t)
    float st_slack;  // the samples' stray off the parallelogram (the frustum's delta) in (s, t)
};

// The slack of a box of projected points in (s, t) (proj_covered, proj_tri): `mag` bounds the
// terms their coordinates were summed from (|st_o| and k |x| |e_d|), which round within a few ulps
// of it; the samples' own (s, t) in [0, 1] within a few ulps of 1, and their points lie within
// the frustum's delta of the parallelogram.
float proj_margin(ProjPlane pl, float mag) { return 3.8e-6 + 16.0 * 1.1920929e-7 * mag + pl.st_slack; }

ProjPlane proj_plane(vec3 o, float delta)
{
    ProjPlane pl;
    pl.base = patch_corners[0] - o;
    pl.e1 = patch_corners[1] - patch_corners[0];
    pl.e2 = patch_corners[3] - patch_corners[0];
    pl.up = -patch_normal;
    pl.height = 0.0;
    for (int c = 0; c < 4; c++)
        pl.height = max(pl.height, dot(pl.up, patch_corners[c] - o));
    // The dual vectors from the unit edges, then scaled: |e1 x e2|^2 is the fourth power of the
    // light's size, past float's range for a sun's far disk at scale 1e6 (its square is 3.5e10
    // across), where e1d, e2d themselves are well within it.
    float s1 = length(pl.e1), s2 = length(pl.e2);
    vec3 u1 = s1 > 0.0 ? pl.e1 / s1 : vec3(0.0), u2 = s2 > 0.0 ? pl.e2 / s2 : vec3(0.0);
    vec3 nn = cross(u1, u2);
    float n2 = dot(nn, nn);
    pl.e1d = n2 > 0.0 ? cross(u2, nn) / (n2 * s1) : vec3(0.0);
    pl.e2d = n2 > 0.0 ? cross(nn, u1) / (n2 * s2) : vec3(0.0);
    pl.st_o = vec2(dot(-pl.base, pl.e1d), dot(-pl.base, pl.e2d));
    pl.e_len = max(length(pl.e1d), length(pl.e2d));
    pl.st_slack = delta * pl.e_len;
    return pl;
}

// Marks sample k blocked at segment parameter t.
void proj_block(uint k, float t)
{
    uint w = k / 32u, bit = 1u << (k % 32u);
    proj_todo[w] &= ~bit;
    proj_blocked[w] |= bit;
    proj_left--;
    proj_t_sum += t;
    proj_nearest = min(proj_nearest, t);
}

// The bits [k_lo, k_hi) of the dispatch's samples that lie in word w.
uint proj_run(uint w, uint k_lo, uint k_hi)
{
    uint from = max(k_lo, 32u * w) - 32u * w, to = min(k_hi, 32u * w + 32u) - 32u * w;
    return from >= to ? 0u : (to == 32u ? ~0u : (1u << to) - 1u) & ~((1u << from) - 1u);
}

// The cells of the strata grid (proj_grid) that meet the (s, t) box [lo, hi]: c_lo .. c_hi.
void proj_cells(vec2 lo, vec2 hi, out ivec2 c_lo, out ivec2 c_hi)
{
    vec2 g = vec2(params.grid_u, params.grid_v);
    c_lo = ivec2(clamp(floor((lo - proj_cell_lo) * proj_cell_scale), vec2(0.0), g - 1.0));
    c_hi = ivec2(clamp(floor((hi - proj_cell_lo) * proj_cell_scale), vec2(0.0), g - 1.0));
}

// Row `row`'s samples in cells c_lo.x .. c_hi.x as bits [k_lo, k_hi) of the dispatch (a run of at
// most grid_u bits, over as many words as it spans).
void proj_row(int row, ivec2 c_lo, ivec2 c_hi, uint words, out uint k_lo, out uint k_hi)
{
    k_lo = uint(row) * params.grid_u + uint(c_lo.x);
    k_hi = min(uint(row) * params.grid_u + uint(c_hi.x) + 1u, proj_k0 + words * 32u);
    k_lo = max(k_lo, proj_k0) - proj_k0;
    k_hi = k_hi > proj_k0 ? k_hi - proj_k0 : 0u;
}

// Is any sample left to decide in the (s, t) box [lo, hi]?
bool proj_open_in(vec2 lo, vec2 hi, uint words, uint groups)
{
    bool open = false;
    ivec2 c_lo = ivec2(0), c_hi = ivec2(-1);
    if (proj_grid)
        proj_cells(lo, hi, c_lo, c_hi);
    for (int row = c_lo.y; row <= c_hi.y && !open; row++) {
        uint k_lo, k_hi;
        proj_row(row, c_lo, c_hi, words, k_lo, k_hi);
        for (uint w = k_lo / 32u; k_lo < k_hi && w <= (k_hi - 1u) / 32u; w++)
            open = open || (proj_todo[w] & proj_run(w, k_lo, k_hi)) != 0u;
    }
    for (uint g = 0u; !proj_grid && g < groups && !open; g++) {
        uint todo = (proj_todo[g / 4u] >> (8u * (g % 4u))) & 0xffu;
        vec4 b = proj_box[g];
        open = todo != 0u && all(lessThanEqual(b.xy, hi)) && all(lessThanEqual(lo, b.zw));
    }
    return open;
}

// The slab tests of a node's box against the pyramid: outside one of its four side planes (each
// through o and an edge of the frustum's parallelogram), behind the pixel's plane parallel to the
// light, or beyond the light's plane. A ray's direction is within delta of the parallelogram and
// its points have t in [0, 1], so a plane's margin is |n| delta and the dot products' rounding.
bool proj_enters(Frustum f, vec3 side[4], ProjPlane pl, vec3 o, vec3 lo, vec3 hi)
{
    vec3 c = 0.5 * (lo + hi) - o, h = 0.5 * (hi - lo);
    float mag = max(max(abs(c.x), abs(c.y)), abs(c.z)) + max(max(h.x, h.y), h.z);
    float slack = f.delta + 8.0 * ulp_bound(max(mag, f.dmax));
    bool inside = true;
    for (int i = 0; i < 4; i++) // unit normals (proj_walk)
        inside = inside && dot(side[i], c) + dot(abs(side[i]), h) >= -slack;
    float hc = dot(pl.up, c), hr = dot(abs(pl.up), h);
    return inside && hc + hr >= -slack && hc - hr <= pl.height + slack;
}

// Is every sample the node's box could block already blocked? Its corners projected from o onto
// the light's plane bound its shadow there (all of them in front of the pixel's plane: a box
// reaching behind it projects without bound, and is kept).
bool proj_covered(ProjPlane pl, vec3 o, vec3 lo, vec3 hi, uint words, uint groups)
{
    vec2 st_lo = vec2(1e30), st_hi = vec2(-1e30);
    bool bounded = true;
    float mag = 1.0 + max(abs(pl.st_o.x), abs(pl.st_o.y));
    for (int c = 0; c < 8; c++) {
        vec3 x = vec3((c & 1) != 0 ? hi.x : lo.x, (c & 2) != 0 ? hi.y : lo.y, (c & 4) != 0 ? hi.z : lo.z) - o;
        float h = dot(pl.up, x), k = pl.height / max(h, 1e-30);
        vec2 st = pl.st_o + k * vec2(dot(x, pl.e1d), dot(x, pl.e2d));
        mag = max(mag, k * length(x) * pl.e_len);
        // A corner on or behind the pixel's plane projects without bound (and one barely in
        // front may overflow): nothing is culled.
        bounded = bounded && h > 0.0 && !any(isinf(st)) && !any(isnan(st)) && !isinf(mag);
        st_lo = min(st_lo, st);
        st_hi = max(st_hi, st);
    }
    float m = proj_margin(pl, mag);
    return bounded && !proj_open_in(st_lo - m, st_hi + m, words, groups);
}

// Triangle `tri` against the samples left: blocks those it covers.
// a.w: the triangle's alpha record (alpha.glsl), 0 if opaque.
void proj_tri(Frustum f, ProjPlane pl, vec3 o, vec2 st_lo, vec2 st_hi, uint words, uint groups, vec4 a, vec3 b, vec3 c)
{
    PacketTri t = packet_tri(o, a.xyz, b, c);
    if (COUNT_WORK)
        work.y++;
    // The frustum's corners first, as packet_leaf_tri: a triangle that misses them all beyond the
    // margin misses every sample; one that holds them all (opaque) blocks every sample left.
    float adet = abs(t.det), lo_s;
    uint rec = ALPHA ? floatBitsToUint(a.w) : 0u; // masked: each sample's hit is tested against its texel
    bool misses, covers;
    packet_corners(f, t, rec != 0u, misses, covers, lo_s);
    if (misses)
        return;
    if (covers) {
        for (uint w = 0u; w < words; w++)
            for (uint m = proj_todo[w]; m != 0u; m &= m - 1u)
                proj_block(32u * w + uint(findLSB(m)), adet / lo_s);
        return;
    }
    // The samples to test: those in the box of the triangle's shadow on the light, its vertices
    // projected from o onto the light's plane (the part beyond the light's plane only shrinks it).
    // A vertex not in front of the pixel's plane projects without bound: then the samples' box.
    // The projected coordinates round within a few ulps of the terms' magnitudes; the samples'
    // (s, t) within a few ulps of 1.
    vec3 x[3] = vec3[3](a.xyz - o, b - o, c - o);
    vec2 r_lo = vec2(1e30), r_hi = vec2(-1e30);
    float mag = 1.0 + max(abs(pl.st_o.x), abs(pl.st_o.y));
    bool bounded = true;
    for (int v = 0; v < 3; v++) {
        float h = dot(pl.up, x[v]), k = pl.height / max(h, 1e-30);
        vec2 st = pl.st_o + k * vec2(dot(x[v], pl.e1d), dot(x[v], pl.e2d));
        mag = max(mag, k * length(x[v]) * pl.e_len);
        bounded = bounded && h > 0.0 && !any(isinf(st)) && !any(isnan(st)) && !isinf(mag);
        r_lo = min(r_lo, st);
        r_hi = max(r_hi, st);
    }
    float margin = proj_margin(pl, mag);
    r_lo = bounded ? r_lo - margin : st_lo;
    r_hi = bounded ? r_hi + margin : st_hi;
    // The cells of the shadow's box, row by row.
    ivec2 c_lo = ivec2(0), c_hi = ivec2(-1);
    if (proj_grid)
        proj_cells(r_lo, r_hi, c_lo, c_hi);
    for (int row = c_lo.y; row <= c_hi.y; row++) {
        uint k_lo, k_hi;
        proj_row(row, c_lo, c_hi, words, k_lo, k_hi);
        for (uint w = k_lo / 32u; k_lo < k_hi && w <= (k_hi - 1u) / 32u; w++) {
            for (uint m = proj_todo[w] & proj_run(w, k_lo, k_hi); m != 0u; m &= m - 1u) {
                uint k = 32u * w + uint(findLSB(m));
                float s;
                if (packet_ray_hits(t, proj_dir[k], rec, s))
                    proj_block(k, adet / s);
            }
        }
    }
    for (uint gi = 0u; !proj_grid && gi < groups; gi++) {
        uint todo = (proj_todo[gi / 4u] >> (8u * (gi % 4u))) & 0xffu;
        vec4 b = proj_box[gi];
        bool meets = all(lessThanEqual(b.xy, r_hi)) && all(lessThanEqual(r_lo, b.zw));
        for (uint m = meets ? todo : 0u; m != 0u; m &= m - 1u) {
            uint k = gi * PROJECT_GROUP + uint(findLSB(m));
            float s;
            if (packet_ray_hits(t, proj_dir[k], rec, s))
                proj_block(k, adet / s);
        }
    }
}

// The walk, shared by the subgroup: its pixels (a 4 x 2 block on llvmpipe, shadow_project.comp) walk
// the BVH together through the union of their pyramids, which for neighbouring pixels to one light
// are nearly the same. Each pixel tests every node's box and triangle against its own pyramid and
// samples, and only the nodes that some pixel enters are visited, so the walk's control flow never
// diverges (the node and the triangle are the same for every lane).
// llvmpipe: both sides of a divergent `if` run (fact 3): with a walk per pixel, a step cost every
// lane's interior and leaf work. Measured (bunny view 256x256, 16 spp, budget off): per-pixel walks
// 868 ms, the shared walk 590 ms (engine/gpu/llvmpipe.md).
// The near child first along the first lane's light direction. Returns whether this pixel's budget
// of triangles ran out before every sample was decided.
bool proj_walk(Frustum f, ProjPlane pl, vec3 o, vec2 st_lo, vec2 st_hi, uint words, uint groups, uint budget, bool live_walk)
{
    vec3 side[4];
    vec3 inside = f.D[0] + f.D[1] + f.D[2] + f.D[3];
    for (int i = 0; i < 4; i++) {
        // Unit normals, the corner directions scaled to a max norm of 1 first (a sun's are 1e11
        // long at scale 1e6: their cross product's square leaves float's range). A degenerate
        // frustum's side is 0 and rejects nothing.
        vec3 a = f.D[i] / max(max(max(abs(f.D[i].x), abs(f.D[i].y)), abs(f.D[i].z)), 1e-30);
        vec3 b = f.D[(i + 1) & 3] / max(max(max(abs(f.D[(i + 1) & 3].x), abs(f.D[(i + 1) & 3].y)), abs(f.D[(i + 1) & 3].z)), 1e-30);
        vec3 n = cross(a, b);
        float len = length(n);
        n = len > 0.0 ? n / len : vec3(0.0);
        side[i] = dot(n, inside) < 0.0 ? -n : n;
    }
    vec3 towards = subgroupBroadcastFirst(inside);
    uint projected = 0u;
    int sp = 0;
    BvhNode root = params.bvh.nodes[0];
    uint first = root.first, count = root.count;
    live_walk = live_walk && proj_left != 0u;
    bool here = live_walk && proj_enters(f, side, pl, o, root.min, root.max); // this pixel's pyramid meets the node
    bool done = !subgroupAny(here);
    while (!done) {
        first = subgroupBroadcastFirst(first);
        count = subgroupBroadcastFirst(count);
        bool pop = true;
        if (count == 0u) {
            BvhNode a = params.bvh.nodes[first], b = params.bvh.nodes[first + 1u];
            if (COUNT_WORK && here)
                work = uvec4(work.x + 2u, work.yz, max(work.w, uint(sp)));
            bool b_first = dot((b.min + b.max) - (a.min + a.max), towards) < 0.0;
            BvhNode near = b_first ? b : a, far = b_first ? a : b;
            bool e_near = here && live_walk && proj_enters(f, side, pl, o, near.min, near.max);
            bool e_far = here && live_walk && proj_enters(f, side, pl, o, far.min, far.max);
            // The coverage cull, once some sample of the pixel is blocked.
            bool some = proj_left < proj_valid;
            e_near = e_near && !(some && proj_covered(pl, o, near.min, near.max, words, groups));
            e_far = e_far && !(some && proj_covered(pl, o, far.min, far.max, words, groups));
            bool any_near = subgroupAny(e_near), any_far = subgroupAny(e_far);
            if (any_near && any_far) {
                first_stack[sp] = far.first; // depth <= BVH_STACK (bvh.c)
                count_stack[sp] = far.count;
                mask_stack[sp] = e_far ? 1u : 0u;
                sp++;
            }
            first = any_near ? near.first : far.first;
            count = any_near ? near.count : far.count;
            here = any_near ? e_near : e_far;
            pop = !any_near && !any_far;
        } else {
            for (uint i = first; i < first + count; i++) {
                uint tri = subgroupBroadcastFirst(params.bvh_tris.ids[i]);
                vec4 v0 = params.tris.v[3u * tri], v1 = params.tris.v[3u * tri + 1u], v2 = params.tris.v[3u * tri + 2u];
                bool on = here && proj_left != 0u && projected <= budget;
                if (on)
                    proj_tri(f, pl, o, st_lo, st_hi, words, groups, v0, v1.xyz, v2.xyz);
                projected += on ? 1u : 0u;
            }
            live_walk = live_walk && proj_left != 0u && projected <= budget;
        }
        if (pop) {
            done = sp == 0 || !subgroupAny(live_walk);
            if (!done) {
                sp--;
                first = first_stack[sp];
                count = count_stack[sp];
                here = live_walk && mask_stack[sp] != 0u;
            }
        }
    }
    return proj_left != 0u && projected > budget;
}

// The pixel's samples of this dispatch by projection; after the budget, its remaining samples as
// rays through the packet walk, 32 at a time.
// `mine`: the lane has a pixel with samples in this dispatch; a lane without one still takes part in
// the subgroup's walk, deciding nothing.
void project_pixel(ivec2 px, vec3 p, vec3 nrm, bool mine)
{
    float rise;
    vec3 o = shadow_origin(p, nrm, 0.0, rise); // exact tests every ray from its origin: no rise
    uint end = pixel_end;
    if (SPLIT == PN_SPLIT_BUDGET_ID)
        end = min(end, budget_rays(p, nrm));
    uint count = mine ? min(end - min(end, pixel_begin), PROJECT_MAX) : 0u;
    vec2 box_lo, box_hi;
    light_box(o, nrm, box_lo, box_hi);
    uint words = (count + 31u) / 32u, groups = (count + PROJECT_GROUP - 1u) / PROJECT_GROUP, valid_count = 0u;
    vec2 st_lo = vec2(1.0), st_hi = vec2(0.0);
    uint valid[PROJECT_WORDS];
    for (uint w = 0u; w < PROJECT_WORDS; w++)
        valid[w] = proj_blocked[w] = 0u;
    for (uint gi = 0u; gi < groups; gi++)
        proj_box[gi] = vec4(1.0, 1.0, 0.0, 0.0);
    PixelSampler ps = pixel_sampler(uvec2(px));
    uint i;
    for (i = 0u; i < count; i++) {
        vec2 st;
        vec3 d;
        float dn;
        bool ok = light_ray(pixel_begin + i, ps, o, nrm, box_lo, box_hi, st, d, dn);
        proj_dir[i] = d;
        valid[i / 32u] |= ok ? 1u << (i % 32u) : 0u;
        valid_count += ok ? 1u : 0u;
        vec4 b = proj_box[i / PROJECT_GROUP];
        proj_box[i / PROJECT_GROUP] = ok ? vec4(min(b.xy, st), max(b.zw, st)) : b;
        st_lo = ok ? min(st_lo, st) : st_lo;
        st_hi = ok ? max(st_hi, st) : st_hi;
    }
    for (uint w = 0u; w < PROJECT_WORDS; w++)
        proj_todo[w] = valid[w];
    proj_left = proj_valid = valid_count;
    proj_grid = LIGHT_KIND == PN_LIGHT_RECT_ID && SPLIT != PN_SPLIT_BUDGET_ID && SPP_MIN == 0u;
    vec2 extent = box_hi - box_lo;
    proj_grid = proj_grid && all(greaterThan(extent, vec2(0.0)));
    proj_cell_lo = box_lo;
    proj_cell_scale = proj_grid ? vec2(params.grid_u, params.grid_v) / extent : vec2(0.0);
    proj_k0 = pixel_begin;
    proj_t_sum = 0.0;
    proj_nearest = 1.0;
    bool fallback = false;
    // Every lane of the subgroup takes part in the shared walk (shadow_project.comp), with or
    // without samples of its own.
    Frustum f = frustum_make(o, st_lo, st_hi);
    ProjPlane pl = proj_plane(o, f.delta);
    uint budget = uint(params.project_budget * float(count));
    fallback = proj_walk(f, pl, o, st_lo, st_hi, words, groups, budget, valid_count > 0u);
    if (!mine)
        return;
    for (uint w = 0u; fallback && w < words; w++) {
        uint live = proj_todo[w];
        if (live == 0u)
            continue;
        [[unroll]] for (uint j = 0u; j < MAX_CHUNK; j++) {
            dir[j] = proj_dir[min(32u * w + j, PROJECT_MAX - 1u)];
            blocker_t[j] = 1.0;
        }
        uint hits = bvh_packet_blocked(o, live, st_lo, st_hi);
        for (uint m = hits; m != 0u; m &= m - 1u)
            proj_block(32u * w + uint(findLSB(m)), blocker_t[findLSB(m)]);
    }
    if (COUNT_WORK && fallback)
        work.w |= PN_WORK_FALLBACK;
    if (params.dump_rays != 0u) {
        ivec2 size = imageSize(img_v);
        uint pixel = uint(px.y * size.x + px.x), pixels = uint(size.x * size.y);
        params.dump.v[pixel] = vec4(o, 1.0);
        for (uint k = 0u; k < count; k++) {
            uint flags = ((valid[k / 32u] >> (k % 32u)) & 1u) | (((proj_blocked[k / 32u] >> (k % 32u)) & 1u) << 1u);
            params.dump.v[pixels + pixel * params.spp + pixel_begin + k] = vec4(o + proj_dir[k], uintBitsToFloat(flags));
        }
    }
    uint blocked = 0u;
    for (uint w = 0u; w < words; w++)
        blocked += uint(bitCount(proj_blocked[w]));
    shadow_store(px, o, count, uvec2(valid_count - blocked, valid_count), uvec2(0u), proj_t_sum, proj_nearest, i < count);
}
