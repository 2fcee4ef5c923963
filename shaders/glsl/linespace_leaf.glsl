// The line-space modes' last-level verdicts and leaf tests: which verdict blocks or is walked in
// each MODE, ls-plane's slab test and the leaf test every walk calls (leaf_blocks). Part of
// shadow_linespace.comp (uses its MODE constants); included after linespace_trace.glsl.

// Alpha-masked casters (ALPHA): a line space, and a filled leaf, cannot tell a cut-out texel from a
// solid one. So a last-level node with a leaf holding a masked triangle is walked, never blocked
// by its line space, and such a leaf is tested exactly, texels and all (leaf_blocked); the other
// leaves keep their mode's rule. Bit b of params.alpha_bits (pn_ntree.alpha_bits): per last-level
// node n^3 + 1 bits, the node's first, then one per leaf.
bool alpha_bit(uint b) { return ((params.alpha_bits.ids[b >> 5u] >> (b & 31u)) & 1u) != 0u; }
bool alpha_node(uint node, uint n3) { return ALPHA && alpha_bit((node - params.cand_first) * (n3 + 1u)); }
bool alpha_leaf(uint node, uint cell, uint n3) { return ALPHA && alpha_bit((node - params.cand_first) * (n3 + 1u) + 1u + cell); }

// A last-level verdict per mode. LS_BLOCKED blocks in linespace and hybrid (unless the node holds an
// alpha-masked leaf); in the other modes the ray walks the node's leaves instead. LS_INSIDE is
// skipped by the paper's rule, and walked in the others. A walked last-level node decides each
// filled leaf the ray crosses (leaf_blocks). `node`: the classified node (last-level if c is
// LS_BLOCKED); blocks: ls_blocks' answer.
bool ls_blocks(int c, uint node, uint n3) { return c == LS_BLOCKED && (LINESPACE || HYBRID) && !alpha_node(node, n3); }
bool ls_walks(int c, bool blocks) { return c == LS_DESCEND || (!LINESPACE && c == LS_INSIDE) || (c == LS_BLOCKED && !blocks); }

// ls-plane: does filled leaf `cell` of last-level node `node` block the ray? lo: the ray's origin
// in the node's local frame (the node spans [0, N]^3, a leaf is 1), ld its direction there, eps
// the rounding allowance of those coordinates (ls_local_box); [t_in, t_out]: where the ray is in
// the leaf grown by eps (ls_slabs), so that a crossing on the leaf's boundary is seen from either
// side.
// The leaf's slab (its plane, within the stored thickness) holds every point of its triangles, so a
// ray that misses the slab inside the leaf misses them. A ray that crosses it is blocked, except
// in the leaves around its origin (within 1.5 leaves of it in the max norm) whose slab holds the
// origin up to OWN_SLACK, and those around its end whose slab holds the end: there the slab may be
// the surface the ray leaves (or the one the light lies on), which it does not cross again. A
// neighbouring leaf's plane is fitted to the origin's surface where it curves: for curvature
// radius R it passes beside the origin by about r^2 / (2 R) at distance r <= 1.5 leaves, so
// OWN_SLACK = 0.5 leaf covers radii down to 2.25 leaves (finer curvature is below what the tree
// resolves). What this gives up is a blocker within 2 leaves of the origin or the light sample.
const float OWN_SLACK = 0.5;
const float HALF_DIAGONAL = 0.8660254; // of a unit cube, sqrt(3)/2: the range of a plane's offset
// Farther leaves count as the origin's surface only if they are planar, i.e. no thicker than a plane
// through the leaf comes out of the fit (at most 10/256 leaf, the 7+7-bit normal's tilt across the
// leaf: tests/test_leaf_plane.c), and their slab holds the origin: a ray leaving a point of a
// plane does not cross that plane again (it only grazes the slab when it is nearly in the plane).
const uint PLANAR_THICKNESS = 10u;
bool leaf_plane_blocks(uint node, uint cell, uint n3, vec3 lo, vec3 ld, float eps, float t_in, float t_out)
{
    uint n = params.tree.n;
    uint w = params.tree.plane_pool.ids[(node - params.cand_first) * n3 + cell];
    vec3 mid = vec3(uvec3(cell % n, (cell / n) % n, cell / (n * n))) + 0.5;
    // Decoding as pn_leaf_plane_decode (accel/leaf_plane.h): octahedral normal (7 + 7 bits),
    // offset from the leaf's centre in [-sqrt(3)/2, sqrt(3)/2] (9 bits), half-thickness in 1/256
    // leaf (9 bits).
    vec2 e = vec2(float(w & 127u), float((w >> 7u) & 127u)) / 126.0 * 2.0 - 1.0;
    vec3 m = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    m.xy = m.z < 0.0 ? (1.0 - abs(m.yx)) * mix(vec2(-1.0), vec2(1.0), greaterThanEqual(m.xy, vec2(0.0))) : m.xy;
    m = normalize(m);
    float off = (float((w >> 14u) & 511u) / 511.0 * 2.0 - 1.0) * HALF_DIAGONAL;
    // The slab grown by the rounding of both the point's coordinates and the leaf's centre, each
    // within eps (ls_local_box).
    float slab = float(w >> 23u) / 256.0 + 2.0 * eps;
    float d_o = dot(m, lo - mid) - off, dm = dot(m, ld);
    float d0 = d_o + max(t_in, 0.0) * dm, d1 = d_o + min(t_out, 1.0) * dm;
    bool crosses = min(d0, d1) <= slab && max(d0, d1) >= -slab;
    bool near_o = all(lessThanEqual(abs(lo - mid), vec3(1.5 + eps)));
    bool near_e = all(lessThanEqual(abs(lo + ld - mid), vec3(1.5 + eps)));
    bool planar = (w >> 23u) <= PLANAR_THICKNESS;
    bool own = (near_o && abs(d_o) <= slab + OWN_SLACK) || (planar && abs(d_o) <= slab) ||
               (near_e && abs(d_o + dm) <= slab);
    return crosses && !own;
}

// ls-leaf at the light's end, as at the ray's start: the ray x(t) = o + t d lies (1 - t) n_L.(-d)
// in front of the light's plane (n_L its emitting normal), so a leaf it enters before
// t_fall = 1 - RISE_LEAVES s |n_L|_1 / n_L.(-d) lies wholly in front of the light (by the argument of
// RISE_LEAVES); a later one may hold the surface the light is mounted on, and does not block.
float leaf_t_fall(vec3 d)
{
    // An OMNI light has no emitting side: its point is mounted on whatever surface the ray ends at,
    // seen along the ray (n_L = -d / |d|, the plane through the point facing the ray).
    vec3 nl = LIGHT_KIND == PN_LIGHT_OMNI_ID ? normalize(-d) : patch_normal;
    return 1.0 - RISE_LEAVES * params.leaf_size * (abs(nl.x) + abs(nl.y) + abs(nl.z)) / dot(nl, -d);
}

// Is filled leaf `cell` of last-level node `node` tested against its triangles? In hybrid and
// exact-ls every walked leaf is; in the other modes a leaf holding an alpha-masked triangle.
bool leaf_exact(uint node, uint cell, uint n3) { return HYBRID || EXACT_LS || alpha_leaf(node, cell, n3); }

// Does filled leaf `cell` of walked last-level node `node` block ray (o, d)? See MODE.
bool leaf_blocks(uint node, uint cell, uint n3, vec3 o, vec3 d, vec3 lo, vec3 ld, float eps, float t_in, float t_out)
{
    bool blocks = LINESPACE || (LEAF && t_in < leaf_t_fall(d));
    if (leaf_exact(node, cell, n3))
        blocks = leaf_blocked(node, cell, n3, wray(o, d), 0.0, 1.0);
    else if (PLANE)
        blocks = leaf_plane_blocks(node, cell, n3, lo, ld, eps, t_in, t_out);
    return blocks;
}
