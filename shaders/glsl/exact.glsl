// Exact shadow rays: watertight ray-triangle test (Woop, Benthin, Wald 2013), the BVH traversal
// (a short explicit stack, any hit) and the triangle pools. Mirrors engine/accel/bvh.h.
// Include after shadow_common.glsl (uses ShadowParams).

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
bool wt_hit(WRay r, vec3 a, vec3 b, vec3 c, float t_min, float t_max, out vec2 t_frac)
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
    bool hit = wt_hit(r, params.tris.v[3u * tri].xyz, params.tris.v[3u * tri + 1u].xyz,
                      params.tris.v[3u * tri + 2u].xyz, t_min, t_max, t_frac);
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
