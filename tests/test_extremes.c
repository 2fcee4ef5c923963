// Numerical extremes: every shadow mode against an exact oracle computed here in double, over a
// sweep of scales (1e-4 .. 1e6), translations (1e5, 1e7), light placements (along each axis and each
// diagonal, grazing, touching and cutting through geometry, a point light, a light larger than the
// scene), trees (N = 2 and 16, d = 1 and the largest that fits), 1 and 1024 samples, receivers on
// cell boundaries, cell corners and the root box's faces, and degenerate and single-triangle scenes.
//
// Every case renders twice per mode: once through the raster pass (receivers wherever the camera
// sees geometry) and once with a crafted G-buffer (pn_renderer_set_gbuffer: receivers on the
// tree's lattice, aligned with light samples so that ray directions have exact zero components).
// For each pixel the oracle counts, over the grid sampler's light samples (which it computes as the
// shader does), the rays that are surely valid, surely free and surely blocked under the mode's
// documented bound (README, "Accuracy at the extremes"), and requires
//     free_sure / (valid + unsure) <= V <= (valid - blocked_sure + unsure) / (valid + unsure)
// plus: every V finite and in [0,1], background V = 0, radiance finite and >= 0, mode none V = 1.
//
// Float slack (world units): e = 16 ulp(M), M the largest coordinate magnitude in the case. The
// shader lifts ray origins by 8 ulps (shadow_frame.glsl), computes light samples with 3 lerps of
// coordinates below M (<= 3 ulps) and ray directions with one subtraction (1 ulp); 16 covers their
// sum with margin and is a property of float, not of one scene. Orientation predicates are called
// "sure" only when their value exceeds its perturbation bound for points moved by e (orient_bound).
// Bounds per mode (s = leaf edge, N = branching factor, n = the pixel's unit normal):
//  - exact, exact-ls: a ray that surely crosses a triangle is blocked; a ray farther than e from
//    every triangle is free.
//  - hybrid: surely crossing => blocked; free unless it passes within 2 s (max norm, + the tree's
//    slack) of a triangle: the line space over-occludes by at most that (test_linespace_shadow.c).
//  - linespace: free as hybrid; blocked when it surely crosses a triangle at a point x beyond the
//    nodes the paper's method skips: n.(x - g) > (3 + N) s |n|_1 (past its rise, shadow_frame.glsl,
//    and out of any last-level node entered before it) and |x - q|_inf > N s (not in the node of the
//    light sample q). Nearer blockers are the method's documented loss of contact shadows.
//  - ls-leaf: free as hybrid (a filled leaf the ray crosses holds a triangle within the dilation);
//    blocked when it surely crosses a triangle at x past its rise, n.(x - g) > 1.25 s |n|_1
//    (shadow_linespace.comp, RISE_LEAVES), and as far in front of the light's plane,
//    m.(x - q) > 1.25 s |m|_1 for the light's emitting normal m (leaf_t_fall).
//  - ls-plane: free as hybrid (the slab it crosses lies in a leaf holding a triangle); blocked when
//    it surely crosses a triangle at x more than 2 s (max norm) from both g and q: only the leaves
//    within 1.5 leaves of the origin or the end may be taken for the surface the ray leaves
//    (leaf_plane_blocks), and a point of such a leaf is within 2 s of it.
// A triangle whose plane is the receiver's own tangent plane through g cannot block g's rays (they
// leave the plane at g); it is skipped, as the shaders' origin offsets skip it.
#include "apps/setup.h"
#include "gpu/device.h"
#include "test_util.h"

// Every mode of the table (gpu/shadow_modes.c) is checked; its bound follows from its row: exact
// modes must match the oracle, the others within the line-space dilation.
enum { MODES = PN_SHADOW_MODE_COUNT };
#define MODE_NAME(mi) (pn_shadow_mode_get((pn_shadow_mode)(mi))->name)

enum { GEO_FULL, GEO_DEGENERATE, GEO_SINGLE };
enum { EXPECT_RENDER, EXPECT_SCENE_REFUSED, EXPECT_TREE_REFUSED };

#define SIZE 32 // G-buffer edge, pixels

typedef struct sweep_case {
    const char *name;
    double scale, shift;  // world = shift * (1,1,1) + scale * (signed permutation of local)
    int axis[3], sign[3]; // world[k] = sign[k] * local[axis[k]] (before scale and shift)
    double light_pos[3], light_normal[3], light_up[3], light_size[2]; // local
    int tree_n, tree_d;   // tree_d = 0: the largest d the memory limit accepts
    uint32_t spp;
    int geometry;
    int expect;
    bool packet;
    uint32_t receivers; // crafted receivers at most (fewer for large spp: the oracle is O(spp))
} sweep_case;

// ---------------------------------------------------------------------------------------------
// Geometry in local coordinates: a 4x4 receiver at y = 0, a 0.5x0.5 occluder at y = 0.5 above the
// origin, and a closed block standing on the receiver (contact shadows).

typedef struct tri {
    double v[3][3];
} tri;

static int local_triangles(int geometry, tri *out)
{
    static const double quad_r[4][3] = {{-2, 0, -2}, {2, 0, -2}, {2, 0, 2}, {-2, 0, 2}};
    static const double quad_o[4][3] = {{-.25, .5, -.25}, {.25, .5, -.25}, {.25, .5, .25}, {-.25, .5, .25}};
    int n = 0;
    if (geometry == GEO_SINGLE) {
        // Tilted: a flat scene under a light above would have its one triangle culled (it cannot
        // block rays between points of its own plane and the light).
        out[n++] = (tri){{{-.25, .4, -.25}, {.25, .6, -.25}, {0, .5, .25}}};
        return n;
    }
    const double(*quads[2])[3] = {quad_r, quad_o};
    for (int q = 0; q < 2; q++) {
        out[n++] = (tri){{{quads[q][0][0], quads[q][0][1], quads[q][0][2]},
                          {quads[q][1][0], quads[q][1][1], quads[q][1][2]},
                          {quads[q][2][0], quads[q][2][1], quads[q][2][2]}}};
        out[n++] = (tri){{{quads[q][0][0], quads[q][0][1], quads[q][0][2]},
                          {quads[q][2][0], quads[q][2][1], quads[q][2][2]},
                          {quads[q][3][0], quads[q][3][1], quads[q][3][2]}}};
    }
    // Block [0.5, 1] x [0, 0.5] x [-0.25, 0.25]: 6 faces.
    const double lo[3] = {.5, 0, -.25}, hi[3] = {1, .5, .25};
    for (int axis = 0; axis < 3; axis++)
        for (int side = 0; side < 2; side++) {
            int u = (axis + 1) % 3, v = (axis + 2) % 3;
            double c[4][3];
            for (int i = 0; i < 4; i++) {
                c[i][axis] = side ? hi[axis] : lo[axis];
                c[i][u] = (i == 1 || i == 2) ? hi[u] : lo[u];
                c[i][v] = (i >= 2) ? hi[v] : lo[v];
            }
            out[n++] = (tri){{{c[0][0], c[0][1], c[0][2]}, {c[1][0], c[1][1], c[1][2]}, {c[2][0], c[2][1], c[2][2]}}};
            out[n++] = (tri){{{c[0][0], c[0][1], c[0][2]}, {c[2][0], c[2][1], c[2][2]}, {c[3][0], c[3][1], c[3][2]}}};
        }
    if (geometry == GEO_DEGENERATE) {
        out[n++] = (tri){{{-.6, .3, .1}, {-.6, .3, .1}, {-.3, .35, .2}}};   // repeated vertex
        out[n++] = (tri){{{-.6, .3, -.2}, {-.4, .3, 0}, {-.2, .3, .2}}};    // collinear
        out[n++] = (tri){{{0, .8, 0}, {0, .8, 0}, {0, .8, 0}}};             // a point, on rays to the light
        out[n++] = (tri){{{-1, .25, 0}, {1, .25, 0}, {0, .25, 1e-9}}};      // a sliver of 1e-9 relative width
        out[n++] = (tri){{{-1, .25, .5}, {1, .25, .5}, {0, .25, .5}}};      // collinear along x
    }
    return n;
}

static void to_world_dir(const sweep_case *c, const double l[3], double w[3])
{
    for (int k = 0; k < 3; k++)
        w[k] = c->sign[k] * l[c->axis[k]];
}

static void to_world(const sweep_case *c, const double l[3], double w[3])
{
    to_world_dir(c, l, w);
    for (int k = 0; k < 3; k++)
        w[k] = c->shift + c->scale * w[k];
}

// ---------------------------------------------------------------------------------------------
// Double-precision geometry.

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void sub3(const double a[3], const double b[3], double o[3])
{
    for (int k = 0; k < 3; k++)
        o[k] = a[k] - b[k];
}
static void cross3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}
static double len3(const double a[3]) { return sqrt(dot3(a, a)); }

// det[b - a, c - a, d - a]
static double orient(const double a[3], const double b[3], const double c[3], const double d[3])
{
    double u[3], v[3], w[3], x[3];
    sub3(b, a, u);
    sub3(c, a, v);
    sub3(d, a, w);
    cross3(v, w, x);
    return dot3(u, x);
}

// Largest change of orient(a,b,c,d) when each point moves by at most e (Euclidean): each edge
// vector changes by at most 2e; expand det(u + du, v + dv, w + dw) and bound each term by the
// product of the lengths (Hadamard).
static double orient_bound(const double a[3], const double b[3], const double c[3], const double d[3], double e)
{
    double u[3], v[3], w[3];
    sub3(b, a, u);
    sub3(c, a, v);
    sub3(d, a, w);
    double lu = len3(u), lv = len3(v), lw = len3(w), h = 2 * e;
    return h * (lv * lw + lu * lw + lu * lv) + h * h * (lu + lv + lw) + h * h * h;
}

// -1, 0 (unsure) or +1: the sign of orient under perturbations of e.
static int orient_sure(const double a[3], const double b[3], const double c[3], const double d[3], double e)
{
    double o = orient(a, b, c, d), bound = orient_bound(a, b, c, d, e);
    return o > bound ? 1 : (o < -bound ? -1 : 0);
}

// Does segment g-q surely cross triangle t (for every perturbation of e)? Then *x = crossing point.
static bool crosses_sure(const double g[3], const double q[3], const tri *t, double e, double x[3])
{
    int s1 = orient_sure(t->v[0], t->v[1], t->v[2], g, e), s2 = orient_sure(t->v[0], t->v[1], t->v[2], q, e);
    if (s1 == 0 || s2 == 0 || s1 == s2)
        return false;
    int e1 = orient_sure(g, q, t->v[0], t->v[1], e), e2 = orient_sure(g, q, t->v[1], t->v[2], e),
        e3 = orient_sure(g, q, t->v[2], t->v[0], e);
    if (e1 == 0 || e1 != e2 || e2 != e3)
        return false;
    double o1 = orient(t->v[0], t->v[1], t->v[2], g), o2 = orient(t->v[0], t->v[1], t->v[2], q);
    double tt = o1 / (o1 - o2);
    for (int k = 0; k < 3; k++)
        x[k] = g[k] + tt * (q[k] - g[k]);
    return true;
}

static double dist_point_segment(const double p[3], const double a[3], const double b[3])
{
    double ab[3], ap[3];
    sub3(b, a, ab);
    sub3(p, a, ap);
    double l2 = dot3(ab, ab), t = l2 > 0 ? dot3(ap, ab) / l2 : 0;
    t = t < 0 ? 0 : (t > 1 ? 1 : t);
    double d[3];
    for (int k = 0; k < 3; k++)
        d[k] = a[k] + t * ab[k] - p[k];
    return len3(d);
}

// Distance between segments p1-q1 and p2-q2 (Ericson, Real-Time Collision Detection, 5.1.9).
static double dist_segment_segment(const double p1[3], const double q1[3], const double p2[3], const double q2[3])
{
    double d1[3], d2[3], r[3];
    sub3(q1, p1, d1);
    sub3(q2, p2, d2);
    sub3(p1, p2, r);
    double a = dot3(d1, d1), e = dot3(d2, d2), f = dot3(d2, r);
    if (a <= 0 || e <= 0)
        return a <= 0 ? dist_point_segment(p1, p2, q2) : dist_point_segment(p2, p1, q1);
    double c = dot3(d1, r), b = dot3(d1, d2), den = a * e - b * b;
    double s = den > 0 ? (b * f - c * e) / den : 0;
    s = s < 0 ? 0 : (s > 1 ? 1 : s);
    double t = (b * s + f) / e;
    if (t < 0) {
        t = 0;
        s = -c / a;
    } else if (t > 1) {
        t = 1;
        s = (b - c) / a;
    }
    s = s < 0 ? 0 : (s > 1 ? 1 : s);
    double d[3];
    for (int k = 0; k < 3; k++)
        d[k] = p1[k] + d1[k] * s - (p2[k] + d2[k] * t);
    return len3(d);
}

// Distance from p to triangle t (its plane where p projects inside, else its edges; a degenerate
// triangle is its edges).
static double dist_point_triangle(const double p[3], const tri *t)
{
    double e0[3], e1[3], nrm[3], ap[3];
    sub3(t->v[1], t->v[0], e0);
    sub3(t->v[2], t->v[0], e1);
    cross3(e0, e1, nrm);
    double nl = len3(nrm);
    if (nl > 0) {
        sub3(p, t->v[0], ap);
        double h = dot3(ap, nrm) / nl, proj[3];
        for (int k = 0; k < 3; k++)
            proj[k] = p[k] - h * nrm[k] / nl;
        bool inside = true;
        for (int i = 0; i < 3; i++) {
            double a[3], b[3], c[3];
            sub3(t->v[(i + 1) % 3], t->v[i], a);
            sub3(proj, t->v[i], b);
            cross3(a, b, c);
            inside = inside && dot3(c, nrm) >= 0;
        }
        if (inside)
            return fabs(h);
    }
    double d = INFINITY;
    for (int i = 0; i < 3; i++)
        d = fmin(d, dist_point_segment(p, t->v[i], t->v[(i + 1) % 3]));
    return d;
}

// Distance between segment g-q and triangle t: 0 if it meets the triangle's interior, else the least
// of its end points' distances and its distances to the edges.
static double dist_segment_triangle(const double g[3], const double q[3], const tri *t)
{
    double o1 = orient(t->v[0], t->v[1], t->v[2], g), o2 = orient(t->v[0], t->v[1], t->v[2], q);
    if ((o1 <= 0 && o2 >= 0) || (o1 >= 0 && o2 <= 0)) {
        double e1 = orient(g, q, t->v[0], t->v[1]), e2 = orient(g, q, t->v[1], t->v[2]),
               e3 = orient(g, q, t->v[2], t->v[0]);
        if ((e1 >= 0 && e2 >= 0 && e3 >= 0) || (e1 <= 0 && e2 <= 0 && e3 <= 0))
            if (o1 != o2) // not both zero (a segment in the plane is handled by the edges below)
                return 0;
    }
    double d = fmin(dist_point_triangle(g, t), dist_point_triangle(q, t));
    for (int i = 0; i < 3; i++)
        d = fmin(d, dist_segment_segment(g, q, t->v[i], t->v[(i + 1) % 3]));
    return d;
}

// ---------------------------------------------------------------------------------------------
// The oracle for one pixel.

typedef struct oracle {
    const tri *tris; // world space, float-rounded vertices as the GPU has them
    int tri_count;
    double lo[64][3], hi[64][3]; // per-triangle boxes
    double corners[4][3];        // the light's corners as the shader has them (float)
    double light_n[3];
    uint32_t grid_u, grid_v;
    double e;                   // float slack, world units
    pn_shadow_mode mode;
    double leaf, slack;         // tree (line-space modes)
    int n;
} oracle;

typedef struct bounds {
    double lo, hi;
    bool any_valid; // some sample may be valid
} bounds;

static bool own_plane(const oracle *o, const tri *t, const double g[3], const double nrm[3])
{
    double e0[3], e1[3], tn[3], c[3];
    sub3(t->v[1], t->v[0], e0);
    sub3(t->v[2], t->v[0], e1);
    cross3(e0, e1, tn);
    double tl = len3(tn);
    if (!(tl > 0))
        return false;
    cross3(tn, nrm, c);
    // Parallel to the receiver's normal (sine below 1e-6: normals are floats) and through g.
    double ag[3];
    sub3(g, t->v[0], ag);
    return len3(c) <= 1e-6 * tl && fabs(dot3(ag, tn)) / tl <= o->e;
}

static bounds pixel_bounds(const oracle *o, const double g[3], const double nrm[3])
{
    double node = o->n * o->leaf;
    const pn_shadow_mode_info *mode = pn_shadow_mode_get(o->mode);
    double dil = mode->needs.tree && !mode->exact ? 2 * (o->leaf + o->slack) : 0;
    double free_r = sqrt(3.0) * (dil + o->e); // Euclidean radius of the max-norm dilation, + slack
    double e_euclid = sqrt(3.0) * o->e;
    double n1 = fabs(nrm[0]) + fabs(nrm[1]) + fabs(nrm[2]);
    uint32_t valid = 0, unsure = 0, free_sure = 0, blocked_sure = 0;
    for (uint32_t j = 0; j < o->grid_v; j++)
        for (uint32_t i = 0; i < o->grid_u; i++) {
            double s = (i + 0.5) / o->grid_u, t = (j + 0.5) / o->grid_v, q[3];
            for (int k = 0; k < 3; k++) {
                double a = o->corners[0][k] + s * (o->corners[1][k] - o->corners[0][k]);
                double b = o->corners[3][k] + s * (o->corners[2][k] - o->corners[3][k]);
                q[k] = a + t * (b - a);
            }
            double d[3], back[3];
            sub3(q, g, d);
            sub3(g, q, back);
            double dn = dot3(d, nrm), ln = dot3(o->light_n, back);
            // The shader's dn and ln are within e of these (its q and origin are): a sample is
            // surely invalid (carries no light) at -e or below, surely valid above e.
            if (dn <= -o->e || ln <= -o->e)
                continue;
            if (!(dn > o->e && ln > o->e)) {
                unsure++;
                continue;
            }
            valid++;
            bool blocked = false, near = false;
            double slo[3], shi[3];
            for (int k = 0; k < 3; k++) {
                slo[k] = fmin(g[k], q[k]) - free_r;
                shi[k] = fmax(g[k], q[k]) + free_r;
            }
            for (int ti = 0; ti < o->tri_count && !blocked; ti++) {
                const tri *tr = &o->tris[ti];
                if (own_plane(o, tr, g, nrm))
                    continue;
                bool overlap = true;
                for (int k = 0; k < 3; k++)
                    overlap = overlap && o->lo[ti][k] <= shi[k] && o->hi[ti][k] >= slo[k];
                if (!overlap)
                    continue;
                double x[3];
                if (crosses_sure(g, q, tr, e_euclid, x)) {
                    bool counts = true;
                    double gx[3], inf_q = 0, inf_g = 0;
                    sub3(x, g, gx);
                    for (int k = 0; k < 3; k++) {
                        inf_q = fmax(inf_q, fabs(x[k] - q[k]));
                        inf_g = fmax(inf_g, fabs(gx[k]));
                    }
                    if (o->mode == PN_SHADOW_LINESPACE)
                        counts = dot3(nrm, gx) > (3 + o->n) * o->leaf * n1 * (1 + 0x1p-10) + 2 * o->e &&
                                 inf_q > node * (1 + 0x1p-10) + 2 * o->e;
                    else if (o->mode == PN_SHADOW_LEAF) {
                        double qx[3], m1 = fabs(o->light_n[0]) + fabs(o->light_n[1]) + fabs(o->light_n[2]);
                        sub3(x, q, qx);
                        counts = dot3(nrm, gx) > 1.25 * o->leaf * n1 * (1 + 0x1p-10) + 2 * o->e &&
                                 dot3(o->light_n, qx) > 1.25 * o->leaf * m1 * (1 + 0x1p-10) + 2 * o->e;
                    }
                    else if (o->mode == PN_SHADOW_PLANE)
                        counts = inf_g > 2 * o->leaf * (1 + 0x1p-10) + 2 * o->e &&
                                 inf_q > 2 * o->leaf * (1 + 0x1p-10) + 2 * o->e;
                    if (counts)
                        blocked = true;
                    near = true;
                } else if (!near && dist_segment_triangle(g, q, tr) <= free_r) {
                    near = true;
                }
            }
            blocked_sure += blocked;
            free_sure += !near;
        }
    bounds b = {0, 1, valid + unsure > 0};
    if (valid + unsure > 0) {
        b.lo = (double)free_sure / (valid + unsure);
        b.hi = (double)(valid - blocked_sure + unsure) / (valid + unsure);
    }
    return b;
}

// ---------------------------------------------------------------------------------------------
// One case.

typedef struct stats {
    uint64_t pixels, violations, bad_values;
    uint64_t lit_pixels;        // with samples that may carry light
    double width_sum;           // sum of (hi - lo) over those: how tight the oracle is
    double err_sum, err_max;    // |V - V_exact| over pixels, same G-buffer (exact rendered first)
} stats;

static void build_scene(const sweep_case *c, pn_scene *sc, tri *world, int *count)
{
    memset(sc, 0, sizeof *sc);
    snprintf(sc->name, sizeof sc->name, "extremes:%s", c->name);
    tri local[64];
    int n = local_triangles(c->geometry, local);
    pn_vertex v[3 * 64];
    uint32_t idx[3 * 64];
    for (int i = 0; i < n; i++) {
        double w[3][3], e0[3], e1[3], nrm[3];
        for (int j = 0; j < 3; j++)
            to_world(c, local[i].v[j], w[j]);
        sub3(w[1], w[0], e0);
        sub3(w[2], w[0], e1);
        cross3(e0, e1, nrm);
        double nl = len3(nrm);
        for (int j = 0; j < 3; j++) {
            pn_vertex *pv = &v[3 * i + j];
            memset(pv, 0, sizeof *pv);
            for (int k = 0; k < 3; k++) {
                pv->pos[k] = (float)w[j][k];
                pv->normal[k] = nl > 0 ? (float)(nrm[k] / nl) : (k == 1);
                world[i].v[j][k] = pv->pos[k];
            }
            idx[3 * i + j] = 3 * i + j;
        }
    }
    const float grey[4] = {0.8f, 0.8f, 0.8f, 1};
    uint32_t m = 0;
    CHECK(pn_scene_add_material(sc, grey, &m) == PN_OK);
    CHECK(pn_scene_add_mesh(sc, v, 3 * n, idx, 3 * n, m) == PN_OK);
    pn_scene_update_bounds(sc);
    *count = n;
}

static void make_light(const sweep_case *c, pn_light *l)
{
    double p[3], nl = len3(c->light_normal), nn[3], nw[3], uw[3];
    to_world(c, c->light_pos, p);
    for (int k = 0; k < 3; k++)
        nn[k] = c->light_normal[k] / nl;
    to_world_dir(c, nn, nw);
    to_world_dir(c, c->light_up, uw);
    for (int k = 0; k < 3; k++) {
        l->pos[k] = (float)p[k];
        l->normal[k] = (float)nw[k];
        l->up[k] = (float)uw[k];
        l->radiance[k] = 1;
    }
    l->size[0] = (float)(c->scale * c->light_size[0]);
    l->size[1] = (float)(c->scale * c->light_size[1]);
}

// Tiny deterministic generator for lattice coordinates.
static uint32_t lcg(uint32_t *state)
{
    *state = *state * 1664525u + 1013904223u;
    return *state >> 8;
}

// Receivers must be points of the scene's bounds when the tree left out triangles that cannot
// block (ntree.c, can_block): that proof covers segments from there to the light. Without culled
// triangles any point may receive.
typedef struct receivers {
    float *P, *N;
    uint32_t count, limit;
    const float *lo, *hi; // NULL: anywhere
} receivers;

static void add_receiver(receivers *rc, const double w[3], const double nrm[3])
{
    if (rc->count >= rc->limit)
        return;
    for (int k = 0; k < 3 && rc->lo; k++)
        if (!((float)w[k] >= rc->lo[k] && (float)w[k] <= rc->hi[k]))
            return;
    float *P = rc->P, *N = rc->N;
    uint32_t *count = &rc->count;
    for (int k = 0; k < 3; k++) {
        P[4 * *count + k] = (float)w[k];
        N[4 * *count + k] = (float)nrm[k];
    }
    P[4 * *count + 3] = 1;
    N[4 * *count + 3] = 1;
    (*count)++;
}

// The crafted G-buffer: a grid on the receiver plane, points aligned with light samples (exact zero
// direction components when the light's corners are dyadic), and points on the tree's lattice:
// cell corners, the root box's corners and faces.
static void crafted_gbuffer(const sweep_case *c, const pn_scene *scene, const pn_light *light, const pn_ntree *tree,
                            float *P, float *N)
{
    memset(P, 0, sizeof(float) * 4 * SIZE * SIZE);
    memset(N, 0, sizeof(float) * 4 * SIZE * SIZE);
    double up_l[3] = {0, 1, 0}, up_w[3];
    to_world_dir(c, up_l, up_w);
    bool culled = tree && tree->culled;
    receivers rc = {P, N, 0, c->receivers < SIZE * SIZE ? c->receivers : SIZE * SIZE, culled ? scene->bounds_min : NULL,
                    culled ? scene->bounds_max : NULL};
    // Aligned with the light's samples: same coordinates as the sample on the two axes other than
    // the receiver plane's normal.
    float corners[4][3];
    pn_light_corners(light, corners);
    uint32_t gu, gv;
    pn_sample_grid(c->spp, &gu, &gv);
    double origin_l[3] = {0, 0, 0}, origin_w[3];
    to_world(c, origin_l, origin_w);
    int plane_axis = up_w[0] != 0 ? 0 : (up_w[1] != 0 ? 1 : 2);
    for (uint32_t k = 0; k < gu * gv && k < 8; k++) {
        double s = (k % gu + 0.5) / gu, t = (k / gu + 0.5) / gv, w[3];
        for (int a = 0; a < 3; a++) {
            double x0 = corners[0][a] + s * (corners[1][a] - corners[0][a]);
            double x1 = corners[3][a] + s * (corners[2][a] - corners[3][a]);
            w[a] = a == plane_axis ? origin_w[a] : x0 + t * (x1 - x0);
        }
        add_receiver(&rc, w, up_w);
    }
    // The receiver plane.
    for (int j = 0; j < 16; j++)
        for (int i = 0; i < 16; i++) {
            double l[3] = {-1.5 + 0.25 * i, 0, -1.75 + 0.25 * j}, w[3];
            to_world(c, l, w);
            add_receiver(&rc, w, up_w);
        }
    // The tree's lattice.
    if (tree && tree->node_count) {
        double cells = pow(tree->n, tree->d), leaf = tree->root_size / cells;
        uint32_t st = 12345;
        for (int corner = 0; corner < 8; corner++) {
            double w[3];
            for (int k = 0; k < 3; k++)
                w[k] = tree->root_min[k] + ((corner >> k) & 1) * tree->root_size;
            add_receiver(&rc, w, up_w);
        }
        for (int tries = 0; rc.count < rc.limit && tries < 100000; tries++) {
            double ijk[3], w[3];
            for (int k = 0; k < 3; k++)
                ijk[k] = (double)(lcg(&st) % ((uint32_t)cells + 1));
            if (tries % 3 == 0) // on a face of the root box
                ijk[lcg(&st) % 3] = (lcg(&st) & 1) ? cells : 0;
            for (int k = 0; k < 3; k++)
                w[k] = tree->root_min[k] + ijk[k] * leaf;
            add_receiver(&rc, w, up_w);
        }
    }
}

// Checks one rendered frame against the oracle; `exact_v` (may be NULL) is exact mode's V on the
// same G-buffer.
static void check_frame(const sweep_case *c, int mi, const oracle *o, const pn_frame_images *img, const float *exact_v,
                        const char *what, stats *st)
{
    for (uint32_t px = 0; px < SIZE * SIZE; px++) {
        float v = img->v[px];
        bool geo = img->p[4 * px + 3] > 0;
        if (!(isfinite(v) && v >= 0 && v <= 1) || (!geo && v != 0)) {
            if (st->bad_values++ < 5)
                fprintf(stderr, "  %s %s %s: pixel %u: V = %g (geometry %d)\n", c->name, MODE_NAME(mi), what, px, v, geo);
            continue;
        }
        for (int k = 0; k < 4; k++) {
            float r = img->radiance[4 * px + k];
            if (!(isfinite(r) && r >= 0) || (!geo && r != 0)) {
                if (st->bad_values++ < 5)
                    fprintf(stderr, "  %s %s %s: pixel %u: radiance[%d] = %g\n", c->name, MODE_NAME(mi), what, px, k, r);
            }
        }
        if (!geo)
            continue;
        st->pixels++;
        if (exact_v) {
            double e = fabs((double)v - exact_v[px]);
            st->err_sum += e;
            st->err_max = fmax(st->err_max, e);
        }
        double g[3], n[3];
        for (int k = 0; k < 3; k++) {
            g[k] = img->p[4 * px + k];
            n[k] = img->n[4 * px + k];
        }
        if (o->mode == PN_SHADOW_NONE) {
            st->violations += v != 1;
            continue;
        }
        bounds b = pixel_bounds(o, g, n);
        // V is float(visible) / float(valid): within 2^-23 relative of the counts' ratio.
        double tol = 0x1p-22;
        bool ok = b.any_valid ? (v >= b.lo - tol && v <= b.hi + tol) : v == 1;
        st->width_sum += b.any_valid ? b.hi - b.lo : 0;
        st->lit_pixels += b.any_valid;
        if (!ok && st->violations++ < 5)
            fprintf(stderr, "  %s %s %s: pixel %u at (%.9g %.9g %.9g) n (%g %g %g): V = %.6f outside [%.6f, %.6f]\n",
                    c->name, MODE_NAME(mi), what, px, g[0], g[1], g[2], n[0], n[1], n[2], v, b.lo, b.hi);
    }
}

static void run_case(pn_gpu_device *dev, const sweep_case *c)
{
    pn_scene scene;
    tri world[64];
    int tri_count = 0;
    build_scene(c, &scene, world, &tri_count);
    pn_light light;
    make_light(c, &light);
    fprintf(stderr, "case %s\n", c->name);

    // Scene-level precision refusal (pn_scene_validate): the scene must be refused exactly when
    // expected, with the message the log shows.
    pn_result vr = pn_scene_validate(&scene);
    CHECK_MSG((vr != PN_OK) == (c->expect == EXPECT_SCENE_REFUSED), "%s: validate returned %s", c->name,
              pn_result_str(vr));
    if (vr != PN_OK) {
        pn_scene_destroy(&scene);
        return;
    }

    // One set of acceleration structures serves every mode: the N-tree as the line-space modes
    // build it (with the per-leaf triangle lists of hybrid and exact-ls), the BVH and the exact
    // pools. d = 0 finds the largest depth that fits.
    float corners[4][3];
    pn_light_corners(&light, corners);
    uint64_t max_bytes = pn_gpu_device_pool_budget(dev), max_pool = pn_gpu_device_max_buffer(dev);
    pn_shadow_accel acc;
    memset(&acc, 0, sizeof acc);
    int d = c->tree_d;
    pn_result tr = PN_ERR_INVALID;
    for (int try_d = d ? d : PN_NTREE_MAX_DEPTH; try_d >= (d ? d : 1); try_d--) {
        pn_shadow_accel_desc ad = {.needs = pn_shadow_needs_all(dev), .tree_n = c->tree_n, .tree_d = try_d,
                                   .max_bytes = max_bytes, .max_pool_bytes = max_pool, .light = &light};
        pn_log_level level = pn_log_get_level();
        if (!d)
            pn_log_set_level(PN_LOG_QUIET); // the deeper trees' refusals are expected here
        tr = pn_shadow_accel_build(&scene, &ad, &acc);
        pn_log_set_level(level);
        if (tr == PN_OK) {
            d = try_d;
            break;
        }
        // Deeper trees are refused by the memory limit, or for leaves too small for float here.
        CHECK_MSG(tr == PN_ERR_MEMORY || tr == PN_ERR_UNSUPPORTED || c->tree_d,
                  "%s: LS(%d,%d) failed with %s, not a limit", c->name, c->tree_n, try_d, pn_result_str(tr));
    }
    CHECK_MSG((tr != PN_OK) == (c->expect == EXPECT_TREE_REFUSED), "%s: LS(%d,%d) build returned %s", c->name,
              c->tree_n, d, pn_result_str(tr));
    if (!c->tree_d && tr == PN_OK)
        fprintf(stderr, "  largest depth for N=%d: %d (%u subdivided nodes)\n", c->tree_n, d, acc.tree.node_count);
    if (tr != PN_OK) { // the modes without a tree still render
        pn_shadow_accel_desc ad = {.needs = pn_shadow_needs_all(dev), .light = &light};
        ad.needs.tree = ad.needs.candidates = false;
        tr = pn_shadow_accel_build(&scene, &ad, &acc);
        CHECK_MSG(tr == PN_OK, "%s: BVH build failed", c->name);
        if (tr != PN_OK) { // nothing to render: the case has failed, the next one runs
            pn_scene_destroy(&scene);
            return;
        }
        tr = PN_ERR_INVALID; // still: no tree
    }
    // The build kept every pool within the device's limits, so the upload must succeed; if it does
    // not, the case has failed and is left (rendering without pools would crash).
    pn_result up = pn_shadow_accel_upload(dev, &scene, &acc);
    CHECK_MSG(up == PN_OK, "%s: upload failed: %s", c->name, pn_result_str(up));
    if (up != PN_OK) {
        pn_shadow_accel_destroy(dev, &acc);
        pn_scene_destroy(&scene);
        return;
    }
    const pn_ntree *tree = tr == PN_OK ? &acc.tree : NULL;

    float *P = malloc(sizeof(float) * 4 * SIZE * SIZE), *N = malloc(sizeof(float) * 4 * SIZE * SIZE);
    float *exact_v[2] = {malloc(sizeof(float) * SIZE * SIZE), malloc(sizeof(float) * SIZE * SIZE)};
    CHECK(P && N && exact_v[0] && exact_v[1]);
    if (!P || !N || !exact_v[0] || !exact_v[1])
        exit(1);
    crafted_gbuffer(c, &scene, &light, tree, P, N);

    oracle o = {.tris = world, .tri_count = tri_count, .n = c->tree_n};
    for (int i = 0; i < tri_count; i++)
        for (int k = 0; k < 3; k++) {
            o.lo[i][k] = fmin(world[i].v[0][k], fmin(world[i].v[1][k], world[i].v[2][k]));
            o.hi[i][k] = fmax(world[i].v[0][k], fmax(world[i].v[1][k], world[i].v[2][k]));
        }
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++)
            o.corners[i][k] = corners[i][k];
    for (int k = 0; k < 3; k++)
        o.light_n[k] = light.normal[k];
    pn_sample_grid(c->spp, &o.grid_u, &o.grid_v);
    // M: the largest coordinate magnitude of geometry, light and receivers.
    double mag = 0;
    for (int i = 0; i < tri_count; i++)
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                mag = fmax(mag, fabs(world[i].v[j][k]));
    for (int i = 0; i < 4; i++)
        for (int k = 0; k < 3; k++)
            mag = fmax(mag, fabs(o.corners[i][k]));
    for (int i = 0; i < SIZE * SIZE; i++)
        for (int k = 0; k < 3; k++)
            mag = fmax(mag, fabs(P[4 * i + k]));
    o.e = 16 * ((double)nextafterf((float)mag, INFINITY) - (float)mag);
    if (tree) {
        o.leaf = tree->root_size / pow(tree->n, tree->d);
        o.slack = tree->slack;
    }

    pn_camera cam;
    pn_camera_frame(scene.bounds_min, scene.bounds_max, 45, &cam);
    // Exact first: the others' error is measured against it on the same pixels and samples.
    int order[MODES] = {PN_SHADOW_REFERENCE}, ordered = 1;
    for (int m = 0; m < MODES; m++)
        if (m != PN_SHADOW_REFERENCE)
            order[ordered++] = m;
    for (int oi = 0; oi < MODES; oi++) {
        int mi = order[oi];
        pn_shadow_mode mode = (pn_shadow_mode)mi;
        bool tree_mode = pn_shadow_mode_get(mode)->needs.tree;
        const char *lack;
        if (!pn_shadow_mode_available(dev, mode, &lack)) {
            fprintf(stderr, "  %-9s skipped: the device lacks %s\n", MODE_NAME(mi), lack);
            continue;
        }
        if (tree_mode && !tree)
            continue; // refused above, as expected or reported
        pn_renderer_desc rd = {.width = SIZE, .height = SIZE, .mode = mode,
                               .traversal = c->packet ? PN_TRAVERSAL_PACKET : PN_TRAVERSAL_RAY,
                               .sampler = PN_SAMPLER_GRID, .spp = c->spp, .seed = 1};
        pn_shadow_accel_bind(&acc, &rd);
        pn_renderer ren;
        pn_result r = pn_renderer_create(dev, &scene, &rd, &ren);
        CHECK_MSG(r == PN_OK, "%s %s: renderer: %s", c->name, MODE_NAME(mi), pn_result_str(r));
        if (r != PN_OK)
            continue;
        o.mode = mode;
        stats st[2] = {{0}};
        for (int pass = 0; pass < 2; pass++) { // raster G-buffer, crafted G-buffer
            pn_frame_times times;
            if (pass == 1)
                CHECK(pn_renderer_set_gbuffer(&ren, P, N) == PN_OK);
            CHECK(pn_renderer_render(&ren, &cam, &light, &times) == PN_OK);
            pn_frame_images img;
            pn_renderer_images(&ren, &img);
            if (mode == PN_SHADOW_REFERENCE)
                memcpy(exact_v[pass], img.v, sizeof(float) * SIZE * SIZE);
            check_frame(c, mi, &o, &img, mode == PN_SHADOW_REFERENCE ? NULL : exact_v[pass], pass ? "crafted" : "raster",
                        &st[pass]);
        }
        for (int pass = 0; pass < 2; pass++) {
            CHECK_MSG(st[pass].violations == 0 && st[pass].bad_values == 0,
                      "%s %s %s: %llu of %llu pixels outside the bound, %llu bad values", c->name, MODE_NAME(mi),
                      pass ? "crafted" : "raster", (unsigned long long)st[pass].violations,
                      (unsigned long long)st[pass].pixels, (unsigned long long)st[pass].bad_values);
            CHECK_MSG(st[pass].pixels > 0, "%s %s: no receivers checked", c->name, MODE_NAME(mi));
        }
        double px = (double)(st[0].pixels + st[1].pixels);
        fprintf(stderr, "  %-9s LS(%d,%d) spp %u: %llu px, bound width %.3f, |V - exact| mean %.4f max %.3f\n",
                MODE_NAME(mi), c->tree_n, d, c->spp, (unsigned long long)px,
                (st[0].width_sum + st[1].width_sum) / fmax(1.0, (double)(st[0].lit_pixels + st[1].lit_pixels)),
                (st[0].err_sum + st[1].err_sum) / px, fmax(st[0].err_max, st[1].err_max));
        pn_renderer_destroy(&ren);
    }
    free(P);
    free(N);
    free(exact_v[0]);
    free(exact_v[1]);
    pn_shadow_accel_destroy(dev, &acc);
    pn_scene_destroy(&scene);
}

// ---------------------------------------------------------------------------------------------

#define ID {0, 1, 2}, {1, 1, 1}
#define ABOVE {0, 1.5, 0}, {0, -1, 0}, {0, 0, 1}, {.5, .5}

int main(int argc, char **argv)
{
    const sweep_case cases[] = {
        // Scale and translation.
        {"base", 1, 0, ID, ABOVE, 6, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"scale 1e-4", 1e-4, 0, ID, ABOVE, 6, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"scale 1e4", 1e4, 0, ID, ABOVE, 6, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"scale 1e6", 1e6, 0, ID, ABOVE, 6, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"at 1e5, LS(6,3)", 1, 1e5, ID, ABOVE, 6, 3, 16, GEO_FULL, EXPECT_TREE_REFUSED, false, 1024},
        {"at 1e5, LS(2,3)", 1, 1e5, ID, ABOVE, 2, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"at 1e7", 1, 1e7, ID, ABOVE, 2, 1, 16, GEO_FULL, EXPECT_SCENE_REFUSED, false, 1024},
        // The light along each axis (the scene turned): spp 1 puts the one sample at the light's
        // centre, straight above receivers at x = z = 0 (two zero direction components).
        {"light +Y", 1, 0, ID, ABOVE, 6, 3, 1, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"light +Y packet", 1, 0, ID, ABOVE, 6, 3, 16, GEO_FULL, EXPECT_RENDER, true, 1024},
        {"light -Y", 1, 0, {0, 1, 2}, {1, -1, 1}, ABOVE, 6, 3, 1, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"light +X", 1, 0, {1, 0, 2}, {1, 1, 1}, ABOVE, 6, 3, 1, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"light -X", 1, 0, {1, 0, 2}, {-1, 1, 1}, ABOVE, 6, 3, 1, GEO_FULL, EXPECT_RENDER, true, 1024},
        {"light +Z", 1, 0, {0, 2, 1}, {1, 1, 1}, ABOVE, 6, 3, 1, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"light -Z", 1, 0, {0, 2, 1}, {1, 1, -1}, ABOVE, 6, 3, 1, GEO_FULL, EXPECT_RENDER, false, 1024},
        // Along each diagonal from the occluder (the lower four light the receiver from behind).
        {"diagonal +++", 1, 0, ID, {1, 1.5, 1}, {-1, -1, -1}, {0, 1, 0}, {.5, .5}, 4, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"diagonal -+-", 1, 0, ID, {-1, 1.5, -1}, {1, -1, 1}, {0, 1, 0}, {.5, .5}, 4, 3, 16, GEO_FULL, EXPECT_RENDER, true, 1024},
        {"diagonal ++-", 1, 0, ID, {1, 1.5, -1}, {-1, -1, 1}, {0, 1, 0}, {.5, .5}, 4, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"diagonal -++", 1, 0, ID, {-1, 1.5, 1}, {1, -1, -1}, {0, 1, 0}, {.5, .5}, 4, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"diagonal +-+", 1, 0, ID, {1, -.5, 1}, {-1, 1, -1}, {0, 1, 0}, {.5, .5}, 4, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"diagonal ---", 1, 0, ID, {-1, -.5, -1}, {1, 1, 1}, {0, 1, 0}, {.5, .5}, 4, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        // Grazing: the light's centre at 0.1 above the receiver plane, facing along it; then exactly
        // in it (spp 9: a row of samples on the receiver's horizon, which carry no light).
        {"grazing", 1, 0, ID, {3, .1, 0}, {-1, 0, 0}, {0, 1, 0}, {.5, .5}, 6, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"grazing, in the plane", 1, 0, ID, {3, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {.5, .5}, 6, 3, 9, GEO_FULL, EXPECT_RENDER, false, 1024},
        // Touching: in the occluder's plane, meeting its edge and overlapping the block's top face.
        {"touching", 1, 0, ID, {.5, .5, 0}, {0, -1, 0}, {0, 0, 1}, {.5, .5}, 6, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        // Intersecting: tilted through the occluder and the block.
        {"intersecting", 1, 0, ID, {.5, .4, 0}, {-1, -1, 0}, {0, 0, 1}, {1, 1}, 6, 3, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        // A point light (hard shadows) and a light far larger than the scene.
        {"point light", 1, 0, ID, {0, 1.5, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0}, 6, 3, 4, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"light 20x20", 1, 0, ID, {0, 1.5, 0}, {0, -1, 0}, {0, 0, 1}, {20, 20}, 6, 3, 64, GEO_FULL, EXPECT_RENDER, false, 512},
        // Trees at the extremes of N and d.
        {"LS(2,1)", 1, 0, ID, ABOVE, 2, 1, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"LS(2,max)", 1, 0, ID, ABOVE, 2, 0, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"LS(16,1)", 1, 0, ID, ABOVE, 16, 1, 16, GEO_FULL, EXPECT_RENDER, false, 1024},
        {"LS(16,max)", 1, 0, ID, ABOVE, 16, 0, 16, GEO_FULL, EXPECT_RENDER, true, 1024},
        // Sample counts.
        {"spp 1024", 1, 0, ID, ABOVE, 6, 3, 1024, GEO_FULL, EXPECT_RENDER, false, 40},
        // Degenerate triangles; a single-triangle scene.
        {"degenerate", 1, 0, ID, ABOVE, 6, 3, 16, GEO_DEGENERATE, EXPECT_RENDER, false, 1024},
        {"degenerate 1e-4", 1e-4, 0, ID, ABOVE, 8, 2, 16, GEO_DEGENERATE, EXPECT_RENDER, false, 1024},
        {"single triangle", 1, 0, ID, ABOVE, 6, 3, 16, GEO_SINGLE, EXPECT_RENDER, false, 1024},
        {"single triangle LS(16,max)", 1, 0, ID, ABOVE, 16, 0, 4, GEO_SINGLE, EXPECT_RENDER, false, 1024},
    };
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK)
        TEST_SKIP("no Vulkan device");
    int n = (int)(sizeof cases / sizeof cases[0]);
    for (int i = 0; i < n; i++)
        if (argc < 2 || strstr(cases[i].name, argv[1]))
            run_case(&dev, &cases[i]);
    pn_gpu_device_destroy(&dev);
    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    return pn_test_result();
}
