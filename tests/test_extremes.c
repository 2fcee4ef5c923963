// Numerical extremes: every shadow mode against an exact oracle computed here in double, over a
// sweep of scales (1e-4 .. 1e6), translations (1e5, 1e7), light placements (along each axis and each
// diagonal, grazing, touching and cutting through geometry, a point light, a light larger than the
// scene), trees (N = 2 and 16, d = 1 and the largest that fits), 1 and 1024 samples, receivers on
// cell boundaries, cell corners and the root box's faces, and degenerate and single-triangle scenes;
// and per-object trees (linespace, --trees object): one mesh instanced translated, scaled
// non-uniformly and turned, and at half size, two of them cutting through each other, with the
// receiver and a block as the rest (GEO_OBJECTS), at scales 1e-4, 1 and 1e4 and at 1e4 and 1e5, ray and
// packet traversal, with receivers also on the objects' faces and their trees' lattices in world.
//
// Every case renders twice per mode: once through the raster pass (receivers wherever the camera
// sees geometry) and once with a crafted G-buffer (pn_renderer_set_gbuffer: receivers on the
// tree's lattice, aligned with light samples so that ray directions have exact zero components).
// For each pixel the oracle counts, over the grid sampler's light samples (which it computes as the
// shader does, in the box of the part of the light above the pixel's horizon), the rays that are surely valid, surely free and surely blocked under the mode's
// documented bound (engine/shadow/README.md, "Accuracy at the extremes"), and requires
//     free_sure / (valid + unsure) <= V <= (valid - blocked_sure + unsure) / (valid + unsure)
// plus: every V finite and in [0,1], background V = 0, radiance finite and >= 0, mode none V = 1.
// Exact mode renders once more through the raster pass with the filter (--filter interleaved): its V
// against filter.comp's weights recomputed here, and the same local scene's frames against each
// other at every scale and shift, with a scene of its own for weights between 0 and 1 (the section
// "The filter" below).
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
// Per-object trees: each tree is in its object's frame, where a leaf of edge l spans at most
// world_leaf = l max_r sum_c |A[r][c]| along a world axis (A its to_world), a last-level node N
// times that, and a ray rises by its object's world_leaf (objects_blocked). So linespace's bounds
// hold with s = the largest world_leaf of the instances (the rest's included) and the slack scaled
// as the leaf; the oracle's triangles are the world ones. The case also requires that the build
// made per-object trees (one per mesh, one for the rest, every object placed), so that it cannot
// pass on the scene-wide tree.
//
// Over 500 lines because its double-precision oracle of every mode, its filter oracle and
// its sweep of scenes are written here, independent of the code they check.
#include "shadow/setup.h"
#include "gpu/device.h"
#include "gpu/shadow_pass.h"
#include "filter_oracle.h"
#include "test_util.h"
#include <float.h>

// Every mode of the table (gpu/shadow_modes.c) is checked; its bound follows from its row: exact
// modes must match the oracle, the others within the line-space dilation.
enum { MODES = PN_SHADOW_MODE_COUNT };
#define MODE_NAME(mi) (pn_shadow_mode_get((pn_shadow_mode)(mi))->name)

enum { GEO_FULL, GEO_DEGENERATE, GEO_SINGLE, GEO_FILTER, GEO_OBJECTS };
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
    bool filter_only;   // only the filter's checks (run_filter_case): its own scene, GEO_FILTER
} sweep_case;

// ---------------------------------------------------------------------------------------------
// Geometry in local coordinates: a 4x4 receiver at y = 0, a 0.5x0.5 occluder at y = 0.5 above the
// origin, and a closed block standing on the receiver (contact shadows).

typedef struct tri {
    double v[3][3];
} tri;

static void push_quad(tri *out, int *n, const double a[3], const double b[3], const double c[3], const double d[3])
{
    out[(*n)++] = (tri){{{a[0], a[1], a[2]}, {b[0], b[1], b[2]}, {c[0], c[1], c[2]}}};
    out[(*n)++] = (tri){{{a[0], a[1], a[2]}, {c[0], c[1], c[2]}, {d[0], d[1], d[2]}}};
}

// The filter's scene (filter_pair). In the sweep's scenes every surface is axis-aligned and every
// step of depth is many footprints high, so each of the filter's weights is 0 or 1 (measured) and
// equal weights say nothing of the values between. Here, on the 4x4 receiver, a vault of six
// facets 10 degrees apart (a circle of radius 2 from -30 to 30 degrees, meeting the receiver at 30
// degrees) and a step 0.04 high (about a fifth of the footprint at this framing) give neighbours
// with cosines and plane offsets strictly between; three bars at y = 1.2 cast penumbrae (the
// light: 1 x 1 at y = 3) across the vault, the step and the creases, so that V_raw varies within
// those windows.
static int filter_triangles(tri *out)
{
    int n = 0;
    const double deg = 3.14159265358979323846 / 180;
    push_quad(out, &n, (double[3]){-2, 0, -2}, (double[3]){2, 0, -2}, (double[3]){2, 0, 2}, (double[3]){-2, 0, 2});
    for (int k = 0; k < 6; k++) { // the vault: axis at x = -0.8, y = -2 cos 30, along z
        double a0 = (-30 + 10 * k) * deg, a1 = (-20 + 10 * k) * deg, y0 = 2 * cos(a0) - 2 * cos(30 * deg),
               y1 = 2 * cos(a1) - 2 * cos(30 * deg), x0 = -.8 + 2 * sin(a0), x1 = -.8 + 2 * sin(a1);
        push_quad(out, &n, (double[3]){x0, y0, -1.8}, (double[3]){x1, y1, -1.8}, (double[3]){x1, y1, 1.8},
                  (double[3]){x0, y0, 1.8});
    }
    const double lo[3] = {.6, 0, -1.8}, hi[3] = {1.8, .04, .2}; // the step: top and four walls
    push_quad(out, &n, (double[3]){lo[0], hi[1], lo[2]}, (double[3]){hi[0], hi[1], lo[2]},
              (double[3]){hi[0], hi[1], hi[2]}, (double[3]){lo[0], hi[1], hi[2]});
    for (int s = 0; s < 2; s++) {
        double x = s ? hi[0] : lo[0], z = s ? hi[2] : lo[2];
        push_quad(out, &n, (double[3]){x, 0, lo[2]}, (double[3]){x, hi[1], lo[2]}, (double[3]){x, hi[1], hi[2]},
                  (double[3]){x, 0, hi[2]});
        push_quad(out, &n, (double[3]){lo[0], 0, z}, (double[3]){lo[0], hi[1], z}, (double[3]){hi[0], hi[1], z},
                  (double[3]){hi[0], 0, z});
    }
    for (int b = 0; b < 3; b++) { // the bars
        double x = -1.35 + 1.1 * b;
        push_quad(out, &n, (double[3]){x, 1.2, -1.5}, (double[3]){x + .3, 1.2, -1.5}, (double[3]){x + .3, 1.2, 1.5},
                  (double[3]){x, 1.2, 1.5});
    }
    return n;
}

// In local coordinates: GEO_FULL, GEO_DEGENERATE and GEO_SINGLE as above; GEO_OBJECTS the triangles
// of no object (the receiver and the block; its occluders are object_triangles' instances).
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
    if (geometry == GEO_FILTER)
        return filter_triangles(out);
    const double(*quads[2])[3] = {quad_r, quad_o};
    for (int q = 0; q < 2; q++) {
        if (geometry == GEO_OBJECTS && q == 1)
            continue; // the occluders are the objects (object_triangles)
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

// The objects of GEO_OBJECTS (per-object trees, accel/objects.h): one mesh, a flat octahedron
// (vertices at +-0.25 on x and z, +-0.1 on y; no face parallel to its tree's cells, whose filled
// leaves then step along every face) in its own frame, instanced three times over the receiver:
// translated; scaled by (1.7, 0.6, 1.3), tilted 20 degrees about x and turned 35 about y, cutting
// through the first (add_objects checks that they cross); and at half size turned 90 degrees
// about z, standing on edge above the block. Each instance's map is
// R_y(yaw) R_x(pitch) R_z(roll) diag(scale) x + t in local coordinates, then the case's world map.
enum { OBJECT_COUNT = 3, OBJECT_MESH_TRIS = 8 };

typedef struct placement {
    double scale[3], yaw, pitch, roll, t[3]; // degrees
} placement;

static const placement PLACEMENTS[OBJECT_COUNT] = {
    {{1, 1, 1}, 0, 0, 0, {-.55, .55, .3}},
    {{1.7, .6, 1.3}, 35, 20, 0, {-.3, .62, .1}},
    {{.5, .5, .5}, 0, 0, 90, {.75, .75, 0}},
};

static int object_triangles(tri *out)
{
    const double r[3] = {.25, .1, .25}; // the vertices: +-r[k] on axis k
    int n = 0;
    for (int f = 0; f < 8; f++) {
        double v[3][3] = {{0}};
        int sx = f & 1 ? -1 : 1, sy = f & 2 ? -1 : 1, sz = f & 4 ? -1 : 1;
        v[0][0] = sx * r[0];
        v[1][1] = sy * r[1];
        v[2][2] = sz * r[2];
        int b = sx * sy * sz > 0 ? 1 : 2; // counter-clockwise seen from outside
        out[n++] = (tri){{{v[0][0], v[0][1], v[0][2]}, {v[b][0], v[b][1], v[b][2]}, {v[3 - b][0], v[3 - b][1], v[3 - b][2]}}};
    }
    return n;
}

// Object i's map from its mesh's frame to world, as the scene stores it (float, as the glTF loader
// rounds a node's world matrix): the placement, then the case's scale, signed permutation and shift.
static void object_to_world(const sweep_case *c, int i, float out[3][4])
{
    const placement *p = &PLACEMENTS[i];
    const double deg = 3.14159265358979323846 / 180;
    double a[3] = {p->yaw * deg, p->pitch * deg, p->roll * deg}, cs[3], sn[3];
    for (int k = 0; k < 3; k++) { // exact 0 and 1 at right angles
        cs[k] = fabs(cos(a[k])) < 1e-12 ? 0 : cos(a[k]);
        sn[k] = fabs(sin(a[k])) < 1e-12 ? 0 : sin(a[k]);
    }
    const double ry[3][3] = {{cs[0], 0, sn[0]}, {0, 1, 0}, {-sn[0], 0, cs[0]}};
    const double rx[3][3] = {{1, 0, 0}, {0, cs[1], -sn[1]}, {0, sn[1], cs[1]}};
    const double rz[3][3] = {{cs[2], -sn[2], 0}, {sn[2], cs[2], 0}, {0, 0, 1}};
    double yx[3][3], m[3][3];
    for (int r = 0; r < 3; r++)
        for (int j = 0; j < 3; j++) {
            yx[r][j] = 0;
            for (int k = 0; k < 3; k++)
                yx[r][j] += ry[r][k] * rx[k][j];
        }
    for (int r = 0; r < 3; r++)
        for (int j = 0; j < 3; j++) {
            m[r][j] = 0;
            for (int k = 0; k < 3; k++)
                m[r][j] += yx[r][k] * rz[k][j];
            m[r][j] *= p->scale[j];
        }
    for (int k = 0; k < 3; k++) {
        for (int j = 0; j < 3; j++)
            out[k][j] = (float)(c->scale * c->sign[k] * m[c->axis[k]][j]);
        out[k][3] = (float)(c->shift + c->scale * c->sign[k] * p->t[c->axis[k]]);
    }
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

// horizon_box (shadow_frame.glsl) in double: the box, in the light's (s, t), of the part of the light
// above the plane through g with normal nrm (the whole light if no part is), and in *dst how far the
// shader's float box may lie from it in s or t. The shader's heights of the corners over the plane
// err by at most dh = 2 e |n|_1 (its origin and corners are within e of these). A corner within dh
// of the plane may go either way; then the box gains or loses the corner, or a crossing next to it,
// which lies within dh / (|h_a - h_b| - 2 dh) of it along the edge. A crossing's f = h_a / (h_a - h_b)
// moves by at most 2 dh / (|h_a - h_b| - 2 dh) when both heights do. An edge with both ends within
// dh of the plane (the light's edge in the plane, within rounding) leaves the box unknown: dst = 1.
// The float divisions and lerps add a few 2^-24: 2^-20 covers them.
static void oracle_horizon_box(const oracle *o, const double g[3], const double nrm[3], double lo[2], double hi[2],
                               double *dst)
{
    static const double square[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    double h[4], d[3], dh = 2 * o->e * (fabs(nrm[0]) + fabs(nrm[1]) + fabs(nrm[2]));
    bool near = false;
    for (int c = 0; c < 4; c++) {
        sub3(o->corners[c], g, d);
        h[c] = dot3(d, nrm);
        near = near || fabs(h[c]) <= dh;
    }
    lo[0] = lo[1] = 1;
    hi[0] = hi[1] = 0;
    *dst = 0;
    for (int c = 0; c < 4; c++) {
        int n = (c + 1) & 3;
        bool up = h[c] > 0;
        if (up)
            for (int k = 0; k < 2; k++)
                lo[k] = fmin(lo[k], square[c][k]), hi[k] = fmax(hi[k], square[c][k]);
        if (up != (h[n] > 0)) {
            double f = up ? h[c] / (h[c] - h[n]) : h[n] / (h[n] - h[c]);
            for (int k = 0; k < 2; k++) {
                double x = up ? square[c][k] + f * (square[n][k] - square[c][k])
                              : square[n][k] + f * (square[c][k] - square[n][k]);
                lo[k] = fmin(lo[k], x), hi[k] = fmax(hi[k], x);
            }
        }
        if (up != (h[n] > 0) || fabs(h[c]) <= dh || fabs(h[n]) <= dh) {
            double gap = fabs(h[c] - h[n]) - 2 * dh;
            *dst = fmax(*dst, gap > 0 ? 2 * dh / gap : 1);
        }
    }
    if (lo[0] > hi[0] || lo[1] > hi[1]) { // no part above: the whole light, all of it invalid
        lo[0] = lo[1] = 0;
        hi[0] = hi[1] = 1;
        *dst = near ? 1 : 0;
    }
    *dst = fmin(*dst + 0x1p-20, 1);
}

static bounds pixel_bounds(const oracle *o, const double g[3], const double nrm[3])
{
    // The samples lie in the box of the part of the light above g's horizon, up to dst in s and t:
    // up to dst times the light's sides in world units, added to the slack of every sample.
    double box_lo[2], box_hi[2], dst, s0[3], t0[3];
    oracle_horizon_box(o, g, nrm, box_lo, box_hi, &dst);
    sub3(o->corners[1], o->corners[0], s0);
    sub3(o->corners[3], o->corners[0], t0);
    const double e = o->e + dst * (len3(s0) + len3(t0));
    double node = o->n * o->leaf;
    const pn_shadow_mode_info *mode = pn_shadow_mode_get(o->mode);
    double dil = mode->needs.tree && !mode->exact ? 2 * (o->leaf + o->slack) : 0;
    double free_r = sqrt(3.0) * (dil + e); // Euclidean radius of the max-norm dilation, + slack
    double e_euclid = sqrt(3.0) * e;
    double n1 = fabs(nrm[0]) + fabs(nrm[1]) + fabs(nrm[2]);
    uint32_t valid = 0, unsure = 0, free_sure = 0, blocked_sure = 0;
    for (uint32_t j = 0; j < o->grid_v; j++)
        for (uint32_t i = 0; i < o->grid_u; i++) {
            double s = box_lo[0] + (i + 0.5) / o->grid_u * (box_hi[0] - box_lo[0]);
            double t = box_lo[1] + (j + 0.5) / o->grid_v * (box_hi[1] - box_lo[1]), q[3];
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
            if (dn <= -e || ln <= -e)
                continue;
            if (!(dn > e && ln > e)) {
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
                        counts = dot3(nrm, gx) > (3 + o->n) * o->leaf * n1 * (1 + 0x1p-10) + 2 * e &&
                                 inf_q > node * (1 + 0x1p-10) + 2 * e;
                    else if (o->mode == PN_SHADOW_LEAF) {
                        double qx[3], m1 = fabs(o->light_n[0]) + fabs(o->light_n[1]) + fabs(o->light_n[2]);
                        sub3(x, q, qx);
                        counts = dot3(nrm, gx) > 1.25 * o->leaf * n1 * (1 + 0x1p-10) + 2 * e &&
                                 dot3(o->light_n, qx) > 1.25 * o->leaf * m1 * (1 + 0x1p-10) + 2 * e;
                    }
                    else if (o->mode == PN_SHADOW_PLANE)
                        counts = inf_g > 2 * o->leaf * (1 + 0x1p-10) + 2 * e &&
                                 inf_q > 2 * o->leaf * (1 + 0x1p-10) + 2 * e;
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

// Appends world-space triangles w (double) as one draw: float positions, the face normal, and the
// float triangles to world[] (the oracle's).
static void append_triangles(pn_scene *sc, const tri *w, int n, uint32_t material, tri *world)
{
    pn_vertex v[3 * 64];
    uint32_t idx[3 * 64];
    for (int i = 0; i < n; i++) {
        double e0[3], e1[3], nrm[3];
        sub3(w[i].v[1], w[i].v[0], e0);
        sub3(w[i].v[2], w[i].v[0], e1);
        cross3(e0, e1, nrm);
        double nl = len3(nrm);
        for (int j = 0; j < 3; j++) {
            pn_vertex *pv = &v[3 * i + j];
            memset(pv, 0, sizeof *pv);
            for (int k = 0; k < 3; k++) {
                pv->pos[k] = (float)w[i].v[j][k];
                pv->normal[k] = nl > 0 ? (float)(nrm[k] / nl) : (k == 1);
                world[i].v[j][k] = pv->pos[k];
            }
            idx[3 * i + j] = 3 * i + j;
        }
    }
    CHECK(pn_scene_add_mesh(sc, v, 3 * n, idx, 3 * n, material) == PN_OK);
}

// GEO_OBJECTS: the mesh of object_triangles (float, its own frame) and its instances, each with
// its triangles also in the world-space list (computed in double from the float local triangles
// and the float map, then rounded, as the glTF loader does). Appends them to world[] after *count.
static void add_objects(const sweep_case *c, pn_scene *sc, uint32_t material, tri *world, int *count)
{
    tri local[OBJECT_MESH_TRIS];
    int n = object_triangles(local);
    sc->meshes = calloc(1, sizeof *sc->meshes);
    sc->objects = calloc(OBJECT_COUNT, sizeof *sc->objects);
    float(*tris)[3][3] = sc->meshes ? malloc(sizeof *tris * n) : NULL;
    CHECK(sc->meshes && sc->objects && tris);
    if (!sc->meshes || !sc->objects || !tris)
        exit(1);
    sc->meshes[0] = (pn_scene_mesh){tris, (uint32_t)n};
    sc->mesh_count = 1;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                tris[i][j][k] = (float)local[i].v[j][k];
    for (int o = 0; o < OBJECT_COUNT; o++) {
        pn_scene_object *obj = &sc->objects[sc->object_count++];
        *obj = (pn_scene_object){.mesh = 0, .node = (uint32_t)o, .first_index = sc->index_count,
                                 .first_vertex = sc->vertex_count};
        object_to_world(c, o, obj->to_world);
        tri w[OBJECT_MESH_TRIS];
        for (int i = 0; i < n; i++)
            for (int j = 0; j < 3; j++)
                for (int r = 0; r < 3; r++)
                    w[i].v[j][r] = (double)obj->to_world[r][0] * tris[i][j][0] + (double)obj->to_world[r][1] * tris[i][j][1] +
                                   (double)obj->to_world[r][2] * tris[i][j][2] + (double)obj->to_world[r][3];
        append_triangles(sc, w, n, material, world + *count);
        *count += n;
        obj->index_count = sc->index_count - obj->first_index;
        obj->vertex_count = sc->vertex_count - obj->first_vertex;
    }
    // The first two instances cut through each other: an edge of one crosses a face of the other.
    const tri *a = world + *count - OBJECT_COUNT * n, *b = a + n;
    bool cut = false;
    for (int i = 0; i < n && !cut; i++)
        for (int e = 0; e < 3 && !cut; e++)
            for (int j = 0; j < n && !cut; j++) {
                double x[3];
                cut = crosses_sure(a[i].v[e], a[i].v[(e + 1) % 3], &b[j], 0, x) ||
                      crosses_sure(b[i].v[e], b[i].v[(e + 1) % 3], &a[j], 0, x);
            }
    CHECK_MSG(cut, "%s: objects 0 and 1 do not cut through each other", c->name);
}

static void build_scene(const sweep_case *c, pn_scene *sc, tri *world, int *count)
{
    memset(sc, 0, sizeof *sc);
    snprintf(sc->name, sizeof sc->name, "extremes:%s", c->name);
    tri local[64], w[64];
    int n = local_triangles(c->geometry, local);
    for (int i = 0; i < n; i++)
        for (int j = 0; j < 3; j++)
            to_world(c, local[i].v[j], w[i].v[j]);
    const float grey[4] = {0.8f, 0.8f, 0.8f, 1};
    uint32_t m = 0;
    CHECK(pn_scene_add_material(sc, grey, &m) == PN_OK);
    append_triangles(sc, w, n, m, world);
    *count = n;
    if (c->geometry == GEO_OBJECTS)
        add_objects(c, sc, m, world, count);
    pn_scene_update_bounds(sc);
}

static void make_light(const sweep_case *c, pn_light *l)
{
    *l = (pn_light){0};
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

// Receivers on a tree's lattice, up to `limit` in all: the root box's corners, then cell corners
// (a third of them on the root box's faces), mapped to world by `map` (an object's to_world; NULL:
// the tree is in world space).
static void lattice_receivers(receivers *rc, const pn_ntree *tree, const float (*map)[4], uint32_t limit,
                              const double up_w[3])
{
    if (!tree || !tree->node_count)
        return;
    uint32_t keep = rc->limit;
    rc->limit = limit < keep ? limit : keep;
    double cells = pow(tree->n, tree->d), leaf = tree->root_size / cells;
    uint32_t st = 12345;
    for (int tries = -8; rc->count < rc->limit && tries < 100000; tries++) {
        double ijk[3], l[3], w[3];
        if (tries < 0) { // the root box's corners
            for (int k = 0; k < 3; k++)
                l[k] = tree->root_min[k] + (((tries + 8) >> k) & 1) * tree->root_size;
        } else {
            for (int k = 0; k < 3; k++)
                ijk[k] = (double)(lcg(&st) % ((uint32_t)cells + 1));
            if (tries % 3 == 0) // on a face of the root box
                ijk[lcg(&st) % 3] = (lcg(&st) & 1) ? cells : 0;
            for (int k = 0; k < 3; k++)
                l[k] = tree->root_min[k] + ijk[k] * leaf;
        }
        for (int r = 0; r < 3; r++)
            w[r] = map ? (double)map[r][0] * l[0] + (double)map[r][1] * l[1] + (double)map[r][2] * l[2] + map[r][3] : l[r];
        add_receiver(rc, w, up_w);
    }
    rc->limit = keep;
}

// The crafted G-buffer: a grid on the receiver plane, points aligned with light samples (exact zero
// direction components when the light's corners are dyadic), and points on the tree's lattice:
// cell corners, the root box's corners and faces. With per-object trees (`objs`; `tree` NULL),
// on every tree's lattice in world: the rest's, and each object's through its map, sharing what is
// left of the receivers evenly.
static void crafted_gbuffer(const sweep_case *c, const pn_scene *scene, const pn_light *light, const pn_ntree *tree,
                            const pn_objects *objs, float *P, float *N)
{
    memset(P, 0, sizeof(float) * 4 * SIZE * SIZE);
    memset(N, 0, sizeof(float) * 4 * SIZE * SIZE);
    double up_l[3] = {0, 1, 0}, up_w[3];
    to_world_dir(c, up_l, up_w);
    bool culled = (tree && tree->culled) || (objs && objs->culled);
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
    // The tree's lattice, or the trees'.
    lattice_receivers(&rc, tree, NULL, rc.limit, up_w);
    if (objs) {
        // Points on every object's faces, with the faces' normals: their rays leave the surface of
        // a tree in its object's frame, and rise by that object's leaves (objects_blocked).
        static const double bary[4][3] = {{1 / 3., 1 / 3., 1 / 3.}, {2 / 3., 1 / 6., 1 / 6.}, {1 / 6., 2 / 3., 1 / 6.},
                                          {1 / 6., 1 / 6., 2 / 3.}};
        for (uint32_t i = 0; i < scene->object_count; i++) {
            const pn_scene_object *ob = &scene->objects[i];
            for (uint32_t t = ob->first_index; t < ob->first_index + ob->index_count; t += 3)
                for (int b = 0; b < 4; b++) {
                    double w[3] = {0, 0, 0}, nrm[3];
                    for (int j = 0; j < 3; j++)
                        for (int k = 0; k < 3; k++)
                            w[k] += bary[b][j] * scene->vertices[scene->indices[t + j]].pos[k];
                    for (int k = 0; k < 3; k++)
                        nrm[k] = scene->vertices[scene->indices[t]].normal[k];
                    add_receiver(&rc, w, nrm);
                }
        }
        bool rest = objs->tree_count > scene->mesh_count;
        uint32_t lattices = scene->object_count + rest;
        for (uint32_t i = 0; i < lattices; i++) {
            uint32_t limit = rc.count + (rc.limit - rc.count) / (lattices - i);
            if (i < scene->object_count)
                lattice_receivers(&rc, &objs->trees[scene->objects[i].mesh], (const float(*)[4])scene->objects[i].to_world,
                                  limit, up_w);
            else
                lattice_receivers(&rc, &objs->trees[scene->mesh_count], NULL, limit, up_w);
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

// ---------------------------------------------------------------------------------------------
// The filter (--filter interleaved, shaders/glsl/filter.comp) at the extremes. Every case that
// renders also renders exact mode through the raster pass with the filter on (3x3 tile), and:
//  1. check_filter_frame: the filtered V is finite, in [0, 1], 0 on the background, and on every
//     covered pixel the weighted mean that filter.comp documents, recomputed here in double from
//     the frame's own P, N (w = view depth), coverage, V_raw and light samples per pixel (as
//     filter_oracle.h, shared with test_filter.c: an implementation of the weights from their documentation),
//     within a bound on the float evaluation's rounding;
//  2. filter_pair: the weights are scale-invariant. Cases that are the same local scene at another
//     scale or translation (same_local_scene) must give the same filtered V on the GPU wherever the
//     two frames have the same V_raw and the same surfaces over the pixel's whole window, within a
//     bound derived from the rounding of positions at each magnitude (loose, and counted apart,
//     where that rounding is not small against the pixel's footprint). With the same V_raw the
//     range weights differ only through the windows' means, i.e. through the geometric weights.

#define FILTER_TILE 3
#define FILTER_TAPS (FILTER_TILE * FILTER_TILE)

// A filtered frame of the sweep with its storage; `view` points into it for the filter's oracle
// (filter_oracle.h, shared with test_filter.c): extreme_frame_bind.
typedef struct extreme_frame {
    filter_frame view;
    bool rendered;
    float p[4 * SIZE * SIZE], n[4 * SIZE * SIZE], v[SIZE * SIZE], v_raw[SIZE * SIZE];
    uint32_t valid[SIZE * SIZE];
    bool reaches[SIZE * SIZE];
    float width[SIZE * SIZE];
    uint64_t range_between; // check_filter_frame's count of pixels with a range weight between 0 and 1
    uint64_t pen_between;   // ... with a penumbra weight between 0 and 1
} extreme_frame;

static void extreme_frame_bind(extreme_frame *e, uint32_t samples, float eye_mag, float pixel_angle)
{
    e->view = (filter_frame){.width = SIZE, .height = SIZE, .tile_w = FILTER_TILE, .tile_h = FILTER_TILE,
                             .samples = samples, .eye_mag = eye_mag, .pixel_angle = pixel_angle,
                             .p = e->p, .n = e->n, .v = e->v, .v_raw = e->v_raw, .valid = e->valid,
                             .reaches = e->reaches, .penumbra = e->width};
}

// Requirement 1 on one filtered frame. Returns how many covered pixels have a range weight between
// 0 and 1 (filter_window.range_between).
static uint64_t check_filter_frame(const sweep_case *c, const extreme_frame *f)
{
    uint64_t covered = 0, bad = 0, off = 0, alone = 0, changed = 0, range = 0, pen = 0, no_ray = 0, borrowed = 0;
    double diff_max = 0, tol_max = 0;
    for (int y = 0; y < SIZE; y++)
        for (int x = 0; x < SIZE; x++) {
            int px = y * SIZE + x;
            float v = f->v[px], raw = f->v_raw[px];
            bool geo = f->p[4 * px + 3] > 0;
            if (!(isfinite(v) && v >= 0 && v <= 1) || (!geo && v != 0) || !(isfinite(raw) && raw >= 0 && raw <= 1)) {
                if (bad++ < 5)
                    fprintf(stderr, "  %s filter: pixel %u: V = %g, V_raw = %g (geometry %d)\n", c->name, px, v, raw, geo);
                continue;
            }
            if (!geo)
                continue;
            covered++;
            filter_window o;
            filter_recompute(&f->view, x, y, &o);
            double d = fabs(v - o.v);
            diff_max = fmax(diff_max, d);
            tol_max = fmax(tol_max, o.tol);
            // The pixel's own geometric weight is |n|^4 = 1 up to rounding: a sum at most that means
            // no neighbour continued its surface, and the filter kept the pixel's own V.
            alone += f->valid[px] > 0 && o.wg <= 1 + 16 * FLOAT_U;
            no_ray += f->valid[px] == 0;
            borrowed += f->valid[px] == 0 && f->reaches[px] && o.wg > 0;
            changed += v != raw;
            range += o.range_between;
            pen += o.pen_between;
            if (d > o.tol && off++ < 5)
                fprintf(stderr, "  %s filter: pixel (%d, %d): V = %.9f, recomputed %.9f (|difference| %.3g > %.3g;"
                                " mean %.9f +- %.3g, spread %.6g, W %.6g of geometric %.6g)\n",
                        c->name, x, y, v, o.v, d, o.tol, o.mean, o.mean_tol, o.spread, o.w, o.wg);
        }
    fprintf(stderr, "  filter    %dx%d exact spp %u (samples %u): %llu px, |V - recomputed| max %.2e (bound max %.2e),"
                    " %llu px alone on their surface, %llu changed, %llu with range and %llu with penumbra weights between 0 and 1,"
                    " %llu without a valid ray (%llu taking their neighbours' V)\n",
            FILTER_TILE, FILTER_TILE, c->spp, f->view.samples, (unsigned long long)covered, diff_max, tol_max,
            (unsigned long long)alone, (unsigned long long)changed, (unsigned long long)range, (unsigned long long)pen,
            (unsigned long long)no_ray, (unsigned long long)borrowed);
    CHECK_MSG(bad == 0 && off == 0, "%s filter: %llu bad values, %llu of %llu pixels off the recomputed filter", c->name,
              (unsigned long long)bad, (unsigned long long)off, (unsigned long long)covered);
    CHECK_MSG(covered > 0, "%s filter: no covered pixels", c->name);
    ((extreme_frame *)f)->pen_between = pen;
    return range;
}

// Exact mode through the raster pass with the filter on; false if it could not render (checked).
static bool render_filtered(pn_gpu_device *dev, const sweep_case *c, const pn_scene *scene, const pn_shadow_accel *acc,
                            const pn_camera *cam, const pn_light *light, extreme_frame *out)
{
    pn_renderer_desc rd = {.width = SIZE, .height = SIZE, .mode = PN_SHADOW_REFERENCE,
                           .traversal = c->packet ? PN_TRAVERSAL_PACKET : PN_TRAVERSAL_AUTO, // auto: exact walks as a packet (by projection from 256 samples)
                           .sampler = PN_SAMPLER_GRID, .spp = c->spp, .seed = 1,
                           .filter = PN_FILTER_INTERLEAVED, .tile_w = FILTER_TILE, .tile_h = FILTER_TILE};
    pn_shadow_accel_bind(acc, &rd);
    rd.objects = NULL; // per-object trees serve linespace only (renderer.c)
    pn_renderer ren;
    pn_result r = pn_renderer_create(dev, scene, &rd, &ren);
    CHECK_MSG(r == PN_OK, "%s filter: renderer: %s", c->name, pn_result_str(r));
    if (r != PN_OK)
        return false;
    pn_frame_times times;
    r = pn_renderer_render(&ren, cam, light, &times);
    CHECK_MSG(r == PN_OK, "%s filter: render: %s", c->name, pn_result_str(r));
    pn_frame_images img;
    pn_renderer_images(&ren, &img);
    CHECK_MSG(img.v_raw != NULL, "%s filter: no V_raw", c->name);
    if (r == PN_OK && img.v_raw) {
        memcpy(out->p, img.p, sizeof out->p);
        memcpy(out->n, img.n, sizeof out->n);
        memcpy(out->v, img.v, sizeof out->v);
        memcpy(out->v_raw, img.v_raw, sizeof out->v_raw);
        for (int i = 0; i < SIZE * SIZE; i++)
            out->valid[i] = img.counts[4 * i + 1], out->reaches[i] = img.counts[4 * i + 2] != 0,
            memcpy(&out->width[i], &img.counts[4 * i + 3], sizeof(float));
        // The samples as renderer.c passes them to the filter.
        extreme_frame_bind(out, pn_filter_noise_samples(rd.spp ? rd.spp : 1, light),
                           fmaxf(fabsf(cam->pos[0]), fmaxf(fabsf(cam->pos[1]), fabsf(cam->pos[2]))),
                           (float)(2.0 * tan(0.5 * cam->yfov_deg * 3.14159265358979323846 / 180.0) / SIZE));
        out->rendered = true;
    }
    pn_renderer_destroy(&ren);
    return out->rendered;
}

// Cases that are the same local scene (geometry, light, samples; the camera frames the scene's
// bounds, so it follows) up to a uniform scale and translation.
static bool same_local_scene(const sweep_case *a, const sweep_case *b)
{
    bool same = a->spp == b->spp && a->geometry == b->geometry && a->packet == b->packet;
    for (int k = 0; k < 3; k++)
        same = same && a->axis[k] == b->axis[k] && a->sign[k] == b->sign[k] && a->light_pos[k] == b->light_pos[k] &&
               a->light_normal[k] == b->light_normal[k] && a->light_up[k] == b->light_up[k];
    return same && a->light_size[0] == b->light_size[0] && a->light_size[1] == b->light_size[1];
}

typedef struct filter_pair_stats {
    uint64_t tight, loose;                 // pixels compared with a bound below / above FILTER_TIGHT
    uint64_t partial;                      // tight ones with a geometric weight strictly between 0 and 1
    uint64_t range;                        // tight ones with a range weight strictly between 0 and 1
    uint64_t skip_geometry, skip_v_raw;    // windows whose surfaces or V_raw differ
    double width_rel;                      // largest relative difference of the local penumbra widths
    uint64_t width_none;                   // taps with a width in one frame and none in the other
    double tight_diff, tight_bound, loose_diff;
} filter_pair_stats;

// A pixel whose bound is 2^-10 or less counts as compared (the others apart): that is 1/64 of V_raw's
// step at the pairs' 16 samples per pixel, so a weight that followed the scale would show; a larger
// bound is no test of the weights.
#define FILTER_TIGHT 0x1p-10

// Requirement 2: frame b (case cb) against frame a (case ca, the same local scene at scale 1 and no
// shift), pixel by pixel.
//
// A pixel is compared when, over its whole window, the two frames cover the same pixels, with the
// same surface (normals within 1e-4, local positions (P - shift) / scale within a quarter of the
// footprint plus the slack below: the camera's rounding moves the pixel grid by a fraction of a
// pixel) and exactly the same V_raw. Then both filtered V are means of the same values and only
// their weights can differ: |V_a - V_b| <= tol_a + tol_b + sum_j |w_a,j - w_b,j| / W_b, with tol
// the float-against-double bounds of filter_recompute and w the double weights wg wr of each frame
// (the double means of the same values differ by sum_j (w_b,j - w_a,j)(v_j - V_a) / W_b).
// The geometric weights differ only by the rounding of positions at each magnitude, as the shader
// sees it, by dg_j at most:
//  - a neighbour on the pixel's own plane (rho_a = 0: within 8 ulps of it at scale 1) is there in
//    b too, and the shader takes 8 ulps of the magnitude off the offset, which is the premise of
//    filter.comp (the rasterizer's positions are within 8 ulps of the plane): rho_b = 0 as well,
//    at any magnitude, and the weights differ by the cosines only;
//  - elsewhere each frame's offset is within 16 ulps below the true one (8 of rounding, 8 taken
//    off), and the true ones differ by the camera's rounding, which moves p and q by the same slack
//    (e = 16 ulp(M), M with the camera's position, as the file's oracle): |rho_b - rho_a| <=
//    U = 3 (A_a + A_b) with A = e / footprint; the footprints (view depths) differ by e each, a
//    relative delta = e_a / depth_a + e_b / depth_b. Then wg_b lies in f([(rho_a - U)+ / (1 + delta),
//    (rho_a + U)(1 + delta)]) c_b^2 with f(rho) = max(1 - rho^2, 0) (filter_weight).
// The range weights see the same d_j (the same V_raw) and differ only through the first loop's
// means, which are means of the same values under the geometric weights: |mean_b - mean_a| <=
// sum_j dg_j / Wg_b, as above (no float terms: both are filter_recompute's doubles; the floats'
// errors are in tol_a and tol_b). So spread_b lies in filter_spread_range of that interval, wr_b,j
// between the range weights of its ends (they rise with the spread), wg_b,j within dg_j of wg_a,j,
// and w_b,j in the product of the two intervals (all >= 0): |w_a,j - w_b,j| is at most the distance
// from w_a,j to the farther end.
// Where that bound is not small, i.e. the rounding at that magnitude is not small against the
// footprint, the shader keeps weights that depend on rounding, on purpose (filter.comp,
// plane_offset); such pixels (bound above FILTER_TIGHT) are checked against their loose bound and
// counted apart.
static void filter_pair(const sweep_case *ca, const extreme_frame *fa, const sweep_case *cb, const extreme_frame *fb,
                        filter_pair_stats *st)
{
    filter_pair_stats s = {0};
    int lo = -(FILTER_TILE - 1) / 2;
    uint64_t off = 0;
    for (int y = 0; y < SIZE; y++)
        for (int x = 0; x < SIZE; x++) {
            int px = y * SIZE + x;
            if (!(fa->p[4 * px + 3] > 0) || !(fb->p[4 * px + 3] > 0))
                continue;
            bool same_geometry = true, same_v = true;
            for (int dy = lo; dy < lo + FILTER_TILE; dy++)
                for (int dx = lo; dx < lo + FILTER_TILE; dx++) {
                    int qx = x + dx, qy = y + dy, q = qy * SIZE + qx;
                    if (qx < 0 || qy < 0 || qx >= SIZE || qy >= SIZE)
                        continue;
                    bool ga = fa->p[4 * q + 3] > 0, gb = fb->p[4 * q + 3] > 0;
                    if (ga != gb) {
                        same_geometry = false;
                        continue;
                    }
                    if (!ga)
                        continue;
                    double nn = 0, dist = 0, mag_a = 0, mag_b = 0;
                    for (int k = 0; k < 3; k++) {
                        nn += (double)fa->n[4 * q + k] * fb->n[4 * q + k];
                        double la = (fa->p[4 * q + k] - ca->shift) / ca->scale, lb = (fb->p[4 * q + k] - cb->shift) / cb->scale;
                        dist = fmax(dist, fabs(la - lb));
                        mag_a = fmax(mag_a, fabs(fa->p[4 * q + k]));
                        mag_b = fmax(mag_b, fabs(fb->p[4 * q + k]));
                    }
                    mag_a = fmax(mag_a, fa->view.eye_mag);
                    mag_b = fmax(mag_b, fb->view.eye_mag);
                    double fp_local = (double)fa->n[4 * q + 3] / ca->scale * fa->view.pixel_angle;
                    double slack = 16 * mag_a * 0x1p-23 / ca->scale + 16 * mag_b * 0x1p-23 / cb->scale;
                    if (nn < 1 - 1e-4 || dist > 0.25 * fp_local + slack)
                        same_geometry = false;
                    if (fa->v_raw[q] != fb->v_raw[q] || (fa->valid[q] == 0) != (fb->valid[q] == 0) ||
                        fa->reaches[q] != fb->reaches[q])
                        same_v = false;
                }
            if (!same_geometry) {
                s.skip_geometry++;
                continue;
            }
            if (!same_v) {
                s.skip_v_raw++;
                continue;
            }
            filter_window wa, wb;
            filter_recompute(&fa->view, x, y, &wa);
            filter_recompute(&fb->view, x, y, &wb);
            // The geometric weights' differences (the same surfaces: the same taps in both).
            double dg[FILTER_TAPS] = {0}, dg_sum = 0;
            bool partial = false;
            for (int k = 0; k < FILTER_TAPS; k++) {
                if (!wa.in[k] || !wb.in[k])
                    continue;
                const filter_tap *ta = &wa.t[k], *tb = &wb.t[k];
                partial = partial || filter_between(ta->wgeo);
                dg[k] = fabs(ta->c * ta->c - tb->c * tb->c);
                if (ta->rho != 0) {
                    double ma = fmax(ta->mag, fa->view.eye_mag), mb = fmax(tb->mag, fb->view.eye_mag);
                    double ea = 16 * ma * 0x1p-23, eb = 16 * mb * 0x1p-23;
                    double u = 3 * (ea / ta->footprint + eb / tb->footprint);
                    double delta = ea / ta->depth + eb / tb->depth;
                    double rlo = fmax(ta->rho - u, 0) / (1 + delta), rhi = (ta->rho + u) * (1 + delta);
                    double flo = filter_weight(rlo, tb->c), fhi = filter_weight(rhi, tb->c);
                    dg[k] = fmax(fmax(flo - ta->wgeo, ta->wgeo - fhi), 0);
                }
                // The penumbra weights: the widths come from each frame's own blocker distances, the
                // first hit its BVH walk found, and a BVH built at another magnitude may find another
                // blocker of the same ray first (their spread is printed below: about 1e-5 relative
                // where the two BVHs match, up to 0.4 where they do not). So the frames' own weights
                // bound their difference; a width in one frame only would be a blocked ray in one
                // only, which the equal V_raw rules out, and is checked.
                dg[k] = dg[k] * tb->pen + ta->wgeo * fabs(ta->pen - tb->pen);
                dg_sum += dg[k];
                double wa_w = fa->width[(y + k / FILTER_TILE + lo) * SIZE + x + k % FILTER_TILE + lo];
                double wb_w = fb->width[(y + k / FILTER_TILE + lo) * SIZE + x + k % FILTER_TILE + lo];
                if (wa_w < FLT_MAX && wb_w < FLT_MAX && wa_w > 0)
                    s.width_rel = fmax(s.width_rel, fabs(wb_w / cb->scale - wa_w / ca->scale) / (wa_w / ca->scale));
                s.width_none += (wa_w == FLT_MAX) != (wb_w == FLT_MAX);
            }
            // The range weights', through frame b's mean.
            double dm = wb.wg > 0 ? dg_sum / wb.wg : 1, s_lo, s_hi, dw = 0;
            filter_spread_range(fmax(wa.mean - dm, 0), fmin(wa.mean + dm, 1), fb->view.samples, &s_lo, &s_hi);
            for (int k = 0; k < FILTER_TAPS; k++) {
                if (!wa.in[k] || !wb.in[k])
                    continue;
                double w_a = wa.t[k].w * wa.wr[k];
                // (dg bounds the product of the geometric and the penumbra weights.)
                double w_lo = fmax(wa.t[k].w - dg[k], 0) * filter_range_weight(wa.d[k], s_lo);
                double w_hi = (wa.t[k].w + dg[k]) * filter_range_weight(wa.d[k], s_hi);
                dw += fmax(w_hi - w_a, w_a - w_lo);
            }
            double weight_bound = wb.w > 0 ? dw / wb.w : 1, bound = wa.tol + wb.tol + weight_bound;
            double d = fabs((double)fa->v[px] - fb->v[px]);
            if (weight_bound <= FILTER_TIGHT) {
                s.tight++;
                s.partial += partial;
                s.range += wa.range_between;
                s.tight_diff = fmax(s.tight_diff, d);
                s.tight_bound = fmax(s.tight_bound, bound);
            } else {
                s.loose++;
                s.loose_diff = fmax(s.loose_diff, d);
            }
            if (d > bound && off++ < 5)
                fprintf(stderr, "  %s against %s: pixel (%d, %d): filtered V %.9f against %.9f (|difference| %.3g > %.3g;"
                                " means %.9f, %.9f)\n",
                        cb->name, ca->name, x, y, fb->v[px], fa->v[px], d, bound, wb.mean, wa.mean);
        }
    fprintf(stderr, "filter scale invariance, %s against %s: %llu px compared (%llu with geometric and %llu with range"
                    " weights between 0 and 1; |dV| max %.2e, bound max %.2e), %llu px where rounding is not small"
                    " against the footprint (|dV| max %.3f); skipped: %llu px whose window differs in surfaces, %llu in"
                    " V_raw\n",
            cb->name, ca->name, (unsigned long long)s.tight, (unsigned long long)s.partial, (unsigned long long)s.range,
            s.tight_diff, s.tight_bound, (unsigned long long)s.loose, s.loose_diff, (unsigned long long)s.skip_geometry,
            (unsigned long long)s.skip_v_raw);
    fprintf(stderr, "  penumbra widths, %s against %s: local widths within %.2e relative, %llu taps with one in one frame only\n",
            cb->name, ca->name, s.width_rel, (unsigned long long)s.width_none);
    CHECK_MSG(s.width_none == 0, "%s against %s: %llu taps have a penumbra width in one frame only", cb->name, ca->name,
              (unsigned long long)s.width_none);
    CHECK_MSG(off == 0, "%s against %s: %llu pixels' filtered V differ beyond the bound", cb->name, ca->name,
              (unsigned long long)off);
    st->tight += s.tight;
    st->partial += s.partial;
    st->range += s.range;
    st->loose += s.loose;
    st->skip_geometry += s.skip_geometry;
    st->skip_v_raw += s.skip_v_raw;
    st->tight_diff = fmax(st->tight_diff, s.tight_diff);
    st->tight_bound = fmax(st->tight_bound, s.tight_bound);
    st->loose_diff = fmax(st->loose_diff, s.loose_diff);
}

// A case's scene, its light and the log line that names it; then pn_scene_validate's verdict.
static pn_result open_case(const sweep_case *c, const char *what, pn_scene *scene, tri *world, int *tri_count,
                           pn_light *light)
{
    build_scene(c, scene, world, tri_count);
    make_light(c, light);
    fprintf(stderr, "case %s%s\n", c->name, what);
    return pn_scene_validate(scene);
}

// A filter_only case: its scene with the BVH only (exact mode), the filtered frame and its check.
static void run_filter_case(pn_gpu_device *dev, const sweep_case *c, extreme_frame *filtered)
{
    pn_scene scene;
    tri world[64];
    int tri_count = 0;
    pn_light light;
    pn_result r = open_case(c, " (the filter only)", &scene, world, &tri_count, &light);
    CHECK_MSG(r == PN_OK, "%s: validate returned %s", c->name, pn_result_str(r));
    pn_shadow_accel acc;
    memset(&acc, 0, sizeof acc);
    pn_shadow_accel_desc ad = {.needs = pn_shadow_needs_all(dev), .light = &light};
    ad.needs.tree = ad.needs.candidates = false;
    if (r == PN_OK) {
        r = pn_shadow_accel_build(&scene, &ad, &acc);
        CHECK_MSG(r == PN_OK, "%s: BVH build failed: %s", c->name, pn_result_str(r));
    }
    if (r == PN_OK) {
        r = pn_shadow_accel_upload(dev, &scene, &acc);
        CHECK_MSG(r == PN_OK, "%s: upload failed: %s", c->name, pn_result_str(r));
    }
    pn_camera cam;
    pn_camera_frame(scene.bounds_min, scene.bounds_max, 45, &cam);
    if (r == PN_OK && render_filtered(dev, c, &scene, &acc, &cam, &light, filtered))
        filtered->range_between = check_filter_frame(c, filtered);
    pn_shadow_accel_destroy(dev, &acc);
    pn_scene_destroy(&scene);
}

static void run_case(pn_gpu_device *dev, const sweep_case *c, extreme_frame *filtered)
{
    pn_scene scene;
    tri world[64];
    int tri_count = 0;
    pn_light light;
    // Scene-level precision refusal (pn_scene_validate): the scene must be refused exactly when
    // expected, with the message the log shows.
    pn_result vr = open_case(c, "", &scene, world, &tri_count, &light);
    CHECK_MSG((vr != PN_OK) == (c->expect == EXPECT_SCENE_REFUSED), "%s: validate returned %s", c->name,
              pn_result_str(vr));
    if (vr != PN_OK) {
        pn_scene_destroy(&scene);
        return;
    }

    // One set of acceleration structures serves every mode: the N-tree as the line-space modes
    // build it (with the per-leaf triangle lists of hybrid and exact-ls), the BVH and the exact
    // pools. d = 0 finds the largest depth that fits. GEO_OBJECTS builds per-object trees instead
    // (accel/objects.h), which serve linespace alone: the other tree modes are not run.
    bool per_object = c->geometry == GEO_OBJECTS;
    float corners[4][3];
    pn_light_corners(&light, corners);
    uint64_t max_bytes = pn_gpu_device_pool_budget(dev), max_pool = pn_gpu_device_max_buffer(dev);
    pn_shadow_accel acc;
    memset(&acc, 0, sizeof acc);
    int d = c->tree_d;
    pn_result tr = PN_ERR_INVALID;
    for (int try_d = d ? d : PN_NTREE_MAX_DEPTH; try_d >= (d ? d : 1); try_d--) {
        pn_shadow_accel_desc ad = {.needs = pn_shadow_needs_all(dev), .tree_n = c->tree_n, .tree_d = try_d,
                                   .max_bytes = max_bytes, .max_pool_bytes = max_pool, .light = &light,
                                   .per_object = per_object};
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
    const pn_ntree *tree = tr == PN_OK && !per_object ? &acc.tree : NULL;
    const pn_objects *objs = tr == PN_OK && per_object ? &acc.objects : NULL;
    if (objs) {
        // Really per-object trees: one per mesh and one for the rest (the block: the receiver alone
        // would be culled), every instance placed (none is flat), and no scene-wide tree.
        bool rest = objs->tree_count > scene.mesh_count;
        CHECK_MSG(rest && objs->tree_count == scene.mesh_count + 1 && objs->placed == scene.object_count + rest &&
                      acc.tree.node_count == 0,
                  "%s: per-object trees: %u trees for %u meshes, %u placed of %u objects (rest %s), scene-wide tree %u"
                  " nodes", c->name, objs->tree_count, scene.mesh_count, objs->placed, scene.object_count,
                  rest ? "built" : "absent", acc.tree.node_count);
    }

    float *P = malloc(sizeof(float) * 4 * SIZE * SIZE), *N = malloc(sizeof(float) * 4 * SIZE * SIZE);
    float *exact_v[2] = {malloc(sizeof(float) * SIZE * SIZE), malloc(sizeof(float) * SIZE * SIZE)};
    CHECK(P && N && exact_v[0] && exact_v[1]);
    if (!P || !N || !exact_v[0] || !exact_v[1])
        exit(1);
    crafted_gbuffer(c, &scene, &light, tree, objs, P, N);

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
    if (objs) {
        // Per-object trees: a tree's leaf (edge l, in its frame) spans at most world_leaf = l max_r
        // sum_c |A[r][c]| along a world axis, and its slack (its frame's units) likewise; the bounds
        // hold with every instance's (shadow_linespace.comp, objects_blocked: a ray rises by its
        // object's world leaf), so with the largest: s = max world_leaf.
        double lo = INFINITY;
        for (uint32_t i = 0; i < objs->placed; i++) {
            const pn_object_instance *in = &objs->instances[i];
            const pn_ntree *t = &objs->trees[in->tree];
            o.leaf = fmax(o.leaf, in->world_leaf);
            o.slack = fmax(o.slack, t->slack * in->world_leaf / pn_ntree_cell_size(t, t->d));
            lo = fmin(lo, in->world_leaf);
        }
        fprintf(stderr, "  per-object trees: %u trees, %u placed, world leaves %.4g to %.4g (leaf_size %.4g), %u culled\n",
                objs->tree_count, objs->placed, lo, o.leaf, objs->leaf_size, objs->culled);
    }

    pn_camera cam;
    pn_camera_frame(scene.bounds_min, scene.bounds_max, 45, &cam);
    // Exact first: the others' error is measured against it on the same pixels and samples. Then
    // exact again with the projection traversal (--traversal project), held to exact's bound.
    int order[MODES + 1] = {PN_SHADOW_REFERENCE, PN_SHADOW_REFERENCE}, ordered = 2;
    for (int m = 0; m < MODES; m++)
        if (m != PN_SHADOW_REFERENCE)
            order[ordered++] = m;
    for (int oi = 0; oi < ordered; oi++) {
        int mi = order[oi];
        pn_shadow_mode mode = (pn_shadow_mode)mi;
        bool project = oi == 1;
        bool exact = mode == PN_SHADOW_REFERENCE && !project; // the frames the others are compared with
        const char *name = project ? "exact/project" : MODE_NAME(mi);
        bool tree_mode = pn_shadow_mode_get(mode)->needs.tree;
        const char *lack;
        if (!pn_shadow_mode_available(dev, mode, &lack)) {
            fprintf(stderr, "  %-9s skipped: the device lacks %s\n", MODE_NAME(mi), lack);
            continue;
        }
        if (objs && tree_mode && mode != PN_SHADOW_LINESPACE) {
            fprintf(stderr, "  %-9s skipped: per-object trees serve linespace only\n", MODE_NAME(mi));
            continue;
        }
        if (tree_mode && !tree && !objs)
            continue; // refused above, as expected or reported
        pn_renderer_desc rd = {.width = SIZE, .height = SIZE, .mode = mode,
                               .traversal = c->packet ? PN_TRAVERSAL_PACKET : PN_TRAVERSAL_AUTO, // auto: exact walks as a packet (by projection from 256 samples)
                               .sampler = PN_SAMPLER_GRID, .spp = c->spp, .seed = 1};
        if (project)
            rd.traversal = PN_TRAVERSAL_PROJECT;
        pn_shadow_accel_bind(&acc, &rd);
        if (mode != PN_SHADOW_LINESPACE)
            rd.objects = NULL; // per-object trees serve linespace only (renderer.c)
        else if (objs)
            CHECK_MSG(rd.objects && !rd.pools, "%s: linespace not bound to the per-object trees", c->name);
        pn_renderer ren;
        pn_result r = pn_renderer_create(dev, &scene, &rd, &ren);
        CHECK_MSG(r == PN_OK, "%s %s: renderer: %s", c->name, name, pn_result_str(r));
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
            if (exact)
                memcpy(exact_v[pass], img.v, sizeof(float) * SIZE * SIZE);
            check_frame(c, mi, &o, &img, exact ? NULL : exact_v[pass], pass ? "crafted" : "raster",
                        &st[pass]);
        }
        for (int pass = 0; pass < 2; pass++) {
            CHECK_MSG(st[pass].violations == 0 && st[pass].bad_values == 0,
                      "%s %s %s: %llu of %llu pixels outside the bound, %llu bad values", c->name, name,
                      pass ? "crafted" : "raster", (unsigned long long)st[pass].violations,
                      (unsigned long long)st[pass].pixels, (unsigned long long)st[pass].bad_values);
            CHECK_MSG(st[pass].pixels > 0, "%s %s: no receivers checked", c->name, name);
        }
        // The projection decides each sample with the packet walk's own test: exact's V, but for a
        // sample within rounding of an edge (one sample of a pixel at most, here none was).
        CHECK_MSG(!project || fmax(st[0].err_max, st[1].err_max) <= 1.0 / c->spp + 1e-6,
                  "%s exact/project: |V - exact| up to %.4f, more than one sample", c->name,
                  fmax(st[0].err_max, st[1].err_max));
        double px = (double)(st[0].pixels + st[1].pixels);
        fprintf(stderr, "  %-13s LS(%d,%d) spp %u: %llu px, bound width %.3f, |V - exact| mean %.4f max %.3f\n",
                name, c->tree_n, d, c->spp, (unsigned long long)px,
                (st[0].width_sum + st[1].width_sum) / fmax(1.0, (double)(st[0].lit_pixels + st[1].lit_pixels)),
                (st[0].err_sum + st[1].err_sum) / px, fmax(st[0].err_max, st[1].err_max));
        pn_renderer_destroy(&ren);
    }
    // The filter over the raster pass (check_filter_frame; main compares the cases' frames).
    const char *lack;
    if (pn_shadow_mode_available(dev, PN_SHADOW_REFERENCE, &lack) &&
        render_filtered(dev, c, &scene, &acc, &cam, &light, filtered))
        filtered->range_between = check_filter_frame(c, filtered);
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
#define FILTER_LIGHT {0, 3, 0}, {0, -1, 0}, {0, 0, 1}, {1, 1}

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
        // Per-object trees (linespace; the other modes without a tree): one mesh instanced three
        // times, translated, scaled non-uniformly and turned (cutting through the first), and
        // turned at half size; the receiver and the block are the rest. Far from the origin the
        // rest's tree, in world space, limits the depth as the scene-wide tree's does, and so do
        // the objects' leaves carried into world space (pn_objects_update): at 1e5 even LS(2,2)'s
        // are under 16 float steps of the squeezed instance (6.8), at 1e4 LS(3,2)'s are not.
        {"objects", 1, 0, ID, ABOVE, 6, 3, 16, GEO_OBJECTS, EXPECT_RENDER, false, 1024},
        {"objects packet", 1, 0, ID, ABOVE, 6, 3, 16, GEO_OBJECTS, EXPECT_RENDER, true, 1024},
        {"objects scale 1e4", 1e4, 0, ID, ABOVE, 6, 3, 16, GEO_OBJECTS, EXPECT_RENDER, false, 1024},
        {"objects scale 1e-4 packet", 1e-4, 0, ID, ABOVE, 6, 3, 16, GEO_OBJECTS, EXPECT_RENDER, true, 1024},
        {"objects at 1e5, LS(6,3)", 1, 1e5, ID, ABOVE, 6, 3, 16, GEO_OBJECTS, EXPECT_TREE_REFUSED, false, 1024},
        {"objects at 1e5, LS(2,2)", 1, 1e5, ID, ABOVE, 2, 2, 16, GEO_OBJECTS, EXPECT_TREE_REFUSED, false, 1024},
        {"objects at 1e4, LS(3,2)", 1, 1e4, ID, ABOVE, 3, 2, 16, GEO_OBJECTS, EXPECT_RENDER, false, 1024},
        {"objects at 1e4, LS(3,2) packet", 1, 1e4, ID, ABOVE, 3, 2, 16, GEO_OBJECTS, EXPECT_RENDER, true, 1024},
        // The filter's own scene (filter_triangles) at scale 1, at the sweep's extremes of scale, and
        // shifted to 1e4 and 1e5, where 16 ulps of the coordinates are a tenth of a footprint and
        // about one.
        {"filter scene", 1, 0, ID, FILTER_LIGHT, 6, 3, 16, GEO_FILTER, EXPECT_RENDER, false, 0, true},
        {"filter scene 1e-4", 1e-4, 0, ID, FILTER_LIGHT, 6, 3, 16, GEO_FILTER, EXPECT_RENDER, false, 0, true},
        {"filter scene 1e6", 1e6, 0, ID, FILTER_LIGHT, 6, 3, 16, GEO_FILTER, EXPECT_RENDER, false, 0, true},
        {"filter scene at 1e4", 1, 1e4, ID, FILTER_LIGHT, 6, 3, 16, GEO_FILTER, EXPECT_RENDER, false, 0, true},
        {"filter scene at 1e5", 1, 1e5, ID, FILTER_LIGHT, 6, 3, 16, GEO_FILTER, EXPECT_RENDER, false, 0, true},
    };
    pn_gpu_device_desc desc = pn_gpu_device_desc_from_env();
    pn_gpu_device dev;
    if (pn_gpu_device_create(&desc, &dev) != PN_OK)
        TEST_SKIP("no Vulkan device");
    int n = (int)(sizeof cases / sizeof cases[0]);
    extreme_frame *filtered = calloc((size_t)n, sizeof *filtered);
    CHECK(filtered);
    if (!filtered)
        exit(1);
    // Arguments: run only the cases whose name contains one of them (the fast tier's subset); an
    // argument that matches no case (a renamed one) fails rather than test nothing.
    for (int k = 1; k < argc; k++) {
        bool matched = false;
        for (int i = 0; i < n && !matched; i++)
            matched = strstr(cases[i].name, argv[k]) != NULL;
        CHECK_MSG(matched, "no case is named like '%s'", argv[k]);
    }
    for (int i = 0; i < n; i++) {
        bool run = argc < 2;
        for (int k = 1; k < argc && !run; k++)
            run = strstr(cases[i].name, argv[k]) != NULL;
        if (run)
            (cases[i].filter_only ? run_filter_case : run_case)(&dev, &cases[i], &filtered[i]);
    }
    pn_gpu_device_destroy(&dev);
    // The filter's scale invariance: every case that is a scaled or shifted copy of a case at scale
    // 1 without shift is compared with the first such (filter_pair); of copies at the same scale
    // and shift (the same frame: exact mode does not read the tree) only the first.
    filter_pair_stats fps = {0};
    int pairs = 0;
    for (int i = 0; i < n; i++) {
        if (!filtered[i].rendered || (cases[i].scale == 1 && cases[i].shift == 0))
            continue;
        int ref = -1;
        bool repeated = false;
        for (int j = 0; j < n; j++) {
            if (j == i || !filtered[j].rendered || !same_local_scene(&cases[i], &cases[j]))
                continue;
            repeated = repeated || (j < i && cases[j].scale == cases[i].scale && cases[j].shift == cases[i].shift);
            if (ref < 0 && cases[j].scale == 1 && cases[j].shift == 0)
                ref = j;
        }
        if (ref >= 0 && !repeated) {
            filter_pair(&cases[ref], &filtered[ref], &cases[i], &filtered[i], &fps);
            pairs++;
        }
    }
    uint64_t frames_range = 0, frames_pen = 0;
    for (int i = 0; i < n; i++)
        frames_range += filtered[i].range_between, frames_pen += filtered[i].pen_between;
    fprintf(stderr, "filter scale invariance, %d pairs: %llu px compared (%llu with geometric and %llu with range weights"
                    " between 0 and 1; |dV| max %.2e, bound max %.2e), %llu px where rounding is not small against the"
                    " footprint (|dV| max %.3f); skipped %llu + %llu px; %llu px of the filtered frames with range"
                    " weights between 0 and 1\n",
            pairs, (unsigned long long)fps.tight, (unsigned long long)fps.partial, (unsigned long long)fps.range,
            fps.tight_diff, fps.tight_bound, (unsigned long long)fps.loose, fps.loose_diff,
            (unsigned long long)fps.skip_geometry, (unsigned long long)fps.skip_v_raw, (unsigned long long)frames_range);
    // The whole sweep has such pairs (scale 1e-4, 1e4, 1e6 and at 1e5 against base, degenerate 1e-4
    // against degenerate, the filter scene's copies against it): they must compare pixels, some with
    // geometric weights between 0 and 1 (the filter scene's) and some with range weights between 0
    // and 1 (penumbrae, where neighbours' V_raw differ by less than the spread), or the check says
    // nothing of them.
    // The recomputed penumbra weight must act somewhere too (the bars' penumbrae), or requirement 1
    // says nothing of it.
    if (argc < 2)
        CHECK_MSG(frames_pen > 0, "filter: no pixel of the filtered frames has a penumbra weight between 0 and 1");
    if (argc < 2)
        CHECK_MSG(fps.tight > 0 && fps.partial > 0 && fps.range > 0 && frames_range > 0,
                  "filter scale invariance: %d pairs, %llu pixels compared, %llu with geometric and %llu with range"
                  " weights between 0 and 1 (%llu in the filtered frames)", pairs, (unsigned long long)fps.tight,
                  (unsigned long long)fps.partial, (unsigned long long)fps.range, (unsigned long long)frames_range);
    free(filtered);
    CHECK_MSG(dev.validation_messages == 0, "%u validation messages", dev.validation_messages);
    return pn_test_result();
}
