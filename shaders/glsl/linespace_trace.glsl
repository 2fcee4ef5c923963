// Line-space visibility of one segment (a shadow ray) through the N-tree, shared by the per-ray
// and the packet traversal so that both apply exactly the same rule:
//
// A ray that crosses a subdivided node from face to face looks up the shaft of its entry and exit
// patches. Bit clear: nothing in the node can block it (skip). Bit set on the last level that
// has line spaces (the node's children are leaves): the ray counts as blocked. Bit set above: the
// ray descends into the children it crosses.
//
// Start node: a ray that starts inside a node has no entry patch. Above the last level it descends;
// the last-level node that holds the origin is skipped, as in the paper (its geometry casts no
// shadow on the ray: that is the method's loss of contact shadows, which hybrid mode repairs).
// End node: a shaft bit covers the whole line through a node, so a ray that ends inside a node (a
// light inside the scene's bounds) would be blocked by geometry beyond the light. The same rule
// applies: above the last level it descends, and the last-level node that holds the light sample
// is skipped.
//
// Rounding: positions are floats. A point within `eps` of a patch edge or node face is treated as
// lying on it, and every patch it may belong to is looked up (any set bit counts), so rounding can
// only ever darken, never leak light. eps is a few ulps of the coordinates involved, expressed in
// node-local units where the node spans [0, N]^3.

const int LS_SKIP = 0;
const int LS_BLOCKED = 1;
const int LS_DESCEND = 2;

// Node-local coordinates: the node spans [0, N]^3; the segment is o + t*d, t in [0, 1].
struct Local {
    vec3 o;
    vec3 d;
    float eps;
};

Local ls_local(Node node, float n, vec3 o, vec3 d)
{
    float s = n / node.size;
    Local l;
    l.o = (o - node.min) * s;
    l.d = d * s;
    float mag = max(max(max(abs(o.x), abs(o.y)), abs(o.z)), max(max(abs(node.min.x), abs(node.min.y)), abs(node.min.z)));
    l.eps = 4.0 * (ulp_bound(mag + node.size) * s + ulp_bound(n));
    return l;
}

// Entry and exit parameters of the line o + t*d through the box [-eps, N+eps]^3; false if it misses.
// Every function here has a single exit and no break/continue: Mesa 22.3's llvmpipe miscompiles
// early exits from functions inlined into loops (the caller's loop then ends early).
bool ls_slabs(Local l, float n, out float t_in, out float t_out)
{
    t_in = -1e30;
    t_out = 1e30;
    bool hit = true;
    for (int k = 0; k < 3; k++) {
        if (l.d[k] == 0.0) {
            hit = hit && l.o[k] >= -l.eps && l.o[k] <= n + l.eps;
        } else {
            float a = (-l.eps - l.o[k]) / l.d[k], b = (n + l.eps - l.o[k]) / l.d[k];
            t_in = max(t_in, min(a, b));
            t_out = min(t_out, max(a, b));
        }
    }
    return hit && t_in <= t_out;
}

// The patch cells (along one face axis) that coordinate x may belong to.
uvec2 ls_cell_range(float x, float n, float eps)
{
    float hi = n - 1.0;
    return uvec2(clamp(floor(x - eps), 0.0, hi), clamp(floor(x + eps), 0.0, hi));
}

// Faces (bit f for face f) that boundary point p lies on, within eps.
uint ls_face_mask(vec3 p, float n, float eps)
{
    uint m = 0u;
    m |= p.x <= eps ? 1u : 0u;
    m |= p.x >= n - eps ? 2u : 0u;
    m |= p.y <= eps ? 4u : 0u;
    m |= p.y >= n - eps ? 8u : 0u;
    m |= p.z <= eps ? 16u : 0u;
    m |= p.z >= n - eps ? 32u : 0u;
    return m;
}

// 1: some pair of patches (on different faces) holding the entry and the exit point has its bit set;
// 0: none has; -1: no pair on different faces (the segment lies in a face plane).
int ls_any_bit(TreeInfo t, Node node, vec3 pa, vec3 pb, float eps)
{
    uint n = t.n;
    float fn = float(n);
    uint ma = ls_face_mask(pa, fn, eps), mb = ls_face_mask(pb, fn, eps);
    int result = -1;
    if (bitCount(ma) == 1 && bitCount(mb) == 1 && ma != mb) {
        // The common case, without loops: each point on one face, away from its patch edges.
        uint fa = uint(findLSB(ma)), fb = uint(findLSB(mb));
        uint ka = fa >> 1u, kb = fb >> 1u;
        uvec2 ua = ls_cell_range(pa[(ka + 1u) % 3u], fn, eps), va = ls_cell_range(pa[(ka + 2u) % 3u], fn, eps);
        uvec2 ub = ls_cell_range(pb[(kb + 1u) % 3u], fn, eps), vb = ls_cell_range(pb[(kb + 2u) % 3u], fn, eps);
        if (ua.x == ua.y && va.x == va.y && ub.x == ub.y && vb.x == vb.y)
            result = ls_bit(t, node, ls_shaft(n, ls_patch(n, fa, ua.x, va.x), ls_patch(n, fb, ub.x, vb.x))) ? 1 : 0;
    }
    if (result < 0) {
        // Near an edge or a patch boundary: every candidate pair of patches.
        bool pair = false, bit = false;
        for (uint fa = 0u; fa < 6u; fa++) {
            uint ka = fa >> 1u;
            uvec2 ua = ls_cell_range(pa[(ka + 1u) % 3u], fn, eps), va = ls_cell_range(pa[(ka + 2u) % 3u], fn, eps);
            for (uint fb = 0u; fb < 6u; fb++) {
                if ((ma & (1u << fa)) != 0u && (mb & (1u << fb)) != 0u && fb != fa) {
                    pair = true;
                    uint kb = fb >> 1u;
                    uvec2 ub = ls_cell_range(pb[(kb + 1u) % 3u], fn, eps), vb = ls_cell_range(pb[(kb + 2u) % 3u], fn, eps);
                    for (uint a_u = ua.x; a_u <= ua.y; a_u++)
                        for (uint a_v = va.x; a_v <= va.y; a_v++)
                            for (uint b_u = ub.x; b_u <= ub.y; b_u++)
                                for (uint b_v = vb.x; b_v <= vb.y; b_v++)
                                    bit = bit || ls_bit(t, node, ls_shaft(n, ls_patch(n, fa, a_u, a_v), ls_patch(n, fb, b_u, b_v)));
                }
            }
        }
        result = bit ? 1 : (pair ? 0 : -1);
    }
    return result;
}

// What the ray o + t*d, t in [t_start, 1], does at subdivided node `node`. The rays of a pixel share
// o (the surface point) and differ in d and t_start (where each has risen clear of the surface).
int ls_classify(TreeInfo t, Node node, vec3 o, vec3 d, float t_start)
{
    float n = float(t.n);
    Local l = ls_local(node, n, o, d);
    float t_in, t_out;
    bool last = node.level + 1u == t.d;
    int result = LS_SKIP;
    if (ls_slabs(l, n, t_in, t_out) && t_in <= 1.0 && t_out >= t_start) {
        if (t_in <= t_start || t_out >= 1.0) { // starts or ends inside
            result = last ? LS_SKIP : LS_DESCEND;
        } else {
            vec3 pa = clamp(l.o + t_in * l.d, vec3(0.0), vec3(n));
            vec3 pb = clamp(l.o + t_out * l.d, vec3(0.0), vec3(n));
            int bit = ls_any_bit(t, node, pa, pb, l.eps);
            // In a face plane (bit < 0): walk the children instead.
            result = bit == 0 ? LS_SKIP : (bit < 0 || !last ? LS_DESCEND : LS_BLOCKED);
        }
    }
    return result;
}
