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
// shadow on the ray: that is the method's loss of contact shadows, which hybrid mode repairs by
// testing that node's triangles exactly).
// End node: a shaft bit covers the whole line through a node, so a ray that ends inside a node (a
// light inside the scene's bounds) would be blocked by geometry beyond the light. The same rule
// applies: above the last level it descends, and the last-level node that holds the light sample
// is skipped (tested exactly in hybrid and exact-ls).
//
// Rounding: positions are floats. A point within `eps` of a patch edge or node face is treated as
// lying on it, and every patch it may belong to is looked up (any set bit counts), so rounding can
// only ever darken, never leak light. eps is a few ulps of the coordinates involved, expressed in
// node-local units where the node spans [0, N]^3.

const int LS_SKIP = 0;
const int LS_BLOCKED = 1;
const int LS_DESCEND = 2;
const int LS_INSIDE = 3; // a last-level node where the ray starts or ends: its line space cannot decide

// Node-local coordinates: the node spans [0, N]^3; the segment is o + t*d, t in [0, 1].
struct Local {
    vec3 o;
    vec3 d;
    float eps;
};

Local ls_local_box(vec3 node_min, float node_size, float n, vec3 o, vec3 d)
{
    float s = n / node_size;
    Local l;
    l.o = (o - node_min) * s;
    l.d = d * s;
    float mag = max(max(max(abs(o.x), abs(o.y)), abs(o.z)), max(max(abs(node_min.x), abs(node_min.y)), abs(node_min.z)));
    l.eps = 4.0 * (ulp_bound(mag + node_size) * s + ulp_bound(n));
    return l;
}

Local ls_local(Node node, float n, vec3 o, vec3 d) { return ls_local_box(node.min, node.size, n, o, d); }

// Entry and exit parameters of the line o + t*d through the box [-eps, N+eps]^3; false if it misses.
// llvmpipe (Mesa 22.3): every function here has a single exit and no break/continue, as that
// driver miscompiles early exits from functions inlined into loops (the caller's loop then ends
// early). Harmless on other drivers; re-check on Mesa 25.
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

// Component k of p (k < 3).
// llvmpipe: selects, not dynamic vector indexing, which that driver turns into branches.
float ls_comp(vec3 p, uint k) { return k == 0u ? p.x : (k == 1u ? p.y : p.z); }

// Shaft bit of patch (fa, ua, va) and patch (fb, ub, vb), fa != fb: ls_shaft without its integer
// divisions, since the faces are known here. Shafts are symmetric: the patch on the lower face
// comes first.
// llvmpipe: a vector integer division there becomes one scalar division per lane.
bool ls_bit_faces(TreeInfo t, uint ls, uint fa, uint ua, uint va, uint fb, uint ub, uint vb)
{
    uint n = t.n, n2 = n * n;
    bool swap = fb < fa;
    uint pa = va * n + ua, pb = vb * n + ub;
    uint bit = ls_face_pair(swap ? fb : fa, swap ? fa : fb) * n2 * n2 + (swap ? pb : pa) * n2 + (swap ? pa : pb);
    return ((t.ls_pool.words[ls + (bit >> 5)] >> (bit & 31u)) & 1u) != 0u;
}

// 1: some pair of patches (on different faces) holding the entry and the exit point has its bit set
// in the line space starting at word `ls`;
// 0: none has; -1: no pair on different faces (the segment lies in a face plane).
// One flat loop over the candidate pairs (usually exactly one: each point on one face, away from
// patch edges).
// llvmpipe: every loop body runs at least once per call, masked, and each iteration is charged
// against the invocation's loop budget, so a nest of loops for the rare case would cost every call
// several iterations there (on GPUs with real branches an untaken nest may cost little).
// The candidates: faces fa of pa (set bits of ra, lowest first),
// faces fb != fa of pb (set bits of rb), and in each face pair every combination of the patch cells
// the two points may belong to, counted by the odometer `o` (offsets of a_u, a_v, b_u, b_v in their
// ranges). Stops at the first set bit, which decides the result.
int ls_any_bit(TreeInfo t, uint ls, vec3 pa, vec3 pb, float eps)
{
    float fn = float(t.n);
    uint ma = ls_face_mask(pa, fn, eps), mb = ls_face_mask(pb, fn, eps);
    bool pair = false, bit = false;
    uint ra = ma;
    uint rb = mb & ~(ra & (0u - ra));
    uvec4 o = uvec4(0u);
    while (ra != 0u && !bit) {
        uint fa = uint(findLSB(ra)), fb = uint(findLSB(rb));
        uint ka = fa >> 1u, kb = min(fb, 5u) >> 1u;
        uvec2 ua = ls_cell_range(ls_comp(pa, (ka + 1u) % 3u), fn, eps), va = ls_cell_range(ls_comp(pa, (ka + 2u) % 3u), fn, eps);
        uvec2 ub = ls_cell_range(ls_comp(pb, (kb + 1u) % 3u), fn, eps), vb = ls_cell_range(ls_comp(pb, (kb + 2u) % 3u), fn, eps);
        uvec4 lo = uvec4(ua.x, va.x, ub.x, vb.x), span = uvec4(ua.y, va.y, ub.y, vb.y) - lo;
        if (rb != 0u) {
            pair = true;
            uvec4 c = lo + o;
            bit = ls_bit_faces(t, ls, fa, c.x, c.y, fb, c.z, c.w);
        }
        // Next combination (b_v fastest), then the next face pair.
        bool c3 = o.w >= span.w, c2 = c3 && o.z >= span.z, c1 = c2 && o.y >= span.y, c0 = c1 && o.x >= span.x;
        o.w = c3 ? 0u : o.w + 1u;
        o.z = c3 ? (c2 ? 0u : o.z + 1u) : o.z;
        o.y = c2 ? (c1 ? 0u : o.y + 1u) : o.y;
        o.x = c1 ? (c0 ? 0u : o.x + 1u) : o.x;
        if (c0 || rb == 0u) {
            o = uvec4(0u);
            rb &= rb - 1u;
            if (rb == 0u) {
                ra &= ra - 1u;
                rb = mb & ~(ra & (0u - ra));
            }
        }
    }
    return bit ? 1 : (pair ? 0 : -1);
}

// What the ray o + t*d, t in [t_start, 1], does at a subdivided node on `level` whose line space
// starts at word `ls`, given its node-local form l and ls_slabs' result (hit, t_in, t_out): the
// per-ray traversal computes those once per node and reuses them to set up the node's DDA. The
// rays of a pixel share o (the surface point) and differ in d, t_start and t_trust: the line space
// answers only for nodes the ray enters after t_trust (where it has risen clear of its surface);
// a last-level node entered before, or holding the ray's end, is LS_INSIDE.
int ls_classify_local(TreeInfo t, uint level, uint ls, Local l, bool hit, float t_in, float t_out, float t_start,
                      float t_trust)
{
    float n = float(t.n);
    bool last = level + 1u == t.d;
    int result = LS_SKIP;
    if (hit && t_in <= 1.0 && t_out >= t_start) {
        if (t_in <= t_trust || t_out >= 1.0) { // starts (or has not risen clear) or ends inside
            result = last ? LS_INSIDE : LS_DESCEND;
        } else {
            vec3 pa = clamp(l.o + t_in * l.d, vec3(0.0), vec3(n));
            vec3 pb = clamp(l.o + t_out * l.d, vec3(0.0), vec3(n));
            int bit = ls_any_bit(t, ls, pa, pb, l.eps);
            if (COUNT_WORK)
                work.y++;
            // In a face plane (bit < 0): walk the children instead.
            result = bit == 0 ? LS_SKIP : (bit < 0 || !last ? LS_DESCEND : LS_BLOCKED);
        }
    }
    return result;
}

int ls_classify(TreeInfo t, Node node, vec3 o, vec3 d, float t_start, float t_trust)
{
    float n = float(t.n);
    Local l = ls_local(node, n, o, d);
    float t_in, t_out;
    bool hit = ls_slabs(l, n, t_in, t_out);
    return ls_classify_local(t, node.level, node.linespace, l, hit, t_in, t_out, t_start, t_trust);
}
