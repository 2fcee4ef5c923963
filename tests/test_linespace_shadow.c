// Line-space shadows against the analytic penumbra (builtin:penumbra: a 0.5x0.5 occluder at
// height 0.5 over a receiver at y = 0, under a parallel 0.5x0.5 light at height 1.5).
//
// Oracle: for a receiver point g and a light sample q, the ray is blocked by the occluder iff it
// crosses the square at y = 0.5 (exact, computed here). The line space may only over-occlude, and by
// a bounded amount: a ray is declared blocked when its last-level shaft touches a filled leaf, and
// every point of a shaft lies within one leaf edge s (max norm) of the ray, while the occluder's
// filled leaves reach one leaf beyond it. So a ray blocked by the line space passes within 2s (max
// norm, plus the tree's float slack) of the occluder: it crosses the occluder dilated into the box
// [-0.25-D, 0.25+D] x [0.5-D, 0.5+D] x [-0.25-D, 0.25+D], D = 2s(1 + 2^-10) (the 2^-10 covers the
// float rounding of positions, which is below 2^-20 relative here).
// Hence, per pixel:    V_exact(dilated) <= V_rendered <= V_exact(occluder)
// where both sides are computed over the same light samples the shader uses:
//  - grid sampler: the grid-cell centres, so the bounds are exact counts over those samples;
//  - stratified sampler: one sample per grid cell at an unknown jitter, so the bounds are counted
//    over whole cells: a cell counts as surely blocked only if the whole cell is blocked, surely
//    free only if the whole cell is free (blocked sets are convex: checking its corners and the
//    box suffices, see cell_state). The bound widens with the number of boundary cells, i.e. with
//    the sample count, as it must.
// Neither the start-node skip nor the start offset can lose this occluder: it is 0.5 above the
// receiver, while the offset is 3s and a last-level node is N*s tall (both checked below).
#include "io/exr.h"
#include "test_util.h"

static const double OCC_H = 0.5, OCC_HALF = 0.25, LIGHT_H = 1.5, LIGHT_HALF = 0.25;

// Does the segment g -> q cross the box [lo, hi] (closed)? Slab test in double.
static bool segment_hits_box(const double g[3], const double q[3], const double lo[3], const double hi[3])
{
    double t0 = 0, t1 = 1;
    for (int k = 0; k < 3; k++) {
        double d = q[k] - g[k];
        if (d == 0) {
            if (g[k] < lo[k] || g[k] > hi[k])
                return false;
            continue;
        }
        double a = (lo[k] - g[k]) / d, b = (hi[k] - g[k]) / d;
        if (a > b) {
            double t = a; a = b; b = t;
        }
        t0 = a > t0 ? a : t0;
        t1 = b < t1 ? b : t1;
    }
    return t0 <= t1;
}

static bool blocked(const double g[3], const double q[3], double dilate)
{
    double lo[3] = {-OCC_HALF - dilate, OCC_H - dilate, -OCC_HALF - dilate};
    double hi[3] = {OCC_HALF + dilate, OCC_H + dilate, OCC_HALF + dilate};
    return segment_hits_box(g, q, lo, hi);
}

static void light_point(double s, double t, double q[3])
{
    q[0] = -LIGHT_HALF + 2 * LIGHT_HALF * s;
    q[1] = LIGHT_H;
    q[2] = -LIGHT_HALF + 2 * LIGHT_HALF * t;
}

// For a light-grid cell [s0,s1]x[t0,t1]: 1 if every ray to it is blocked, 0 if none is, -1 if mixed.
// The set of light points whose ray from g crosses the (convex) box is convex, so "all blocked" is
// decided by the 4 corners, and "none blocked" by the box's projection from g onto the light plane
// (an axis-aligned rectangle here, as the box and light are axis-aligned and g is below both).
static int cell_state(const double g[3], double s0, double s1, double t0, double t1, double dilate)
{
    int n = 0;
    const double cs[4][2] = {{s0, t0}, {s1, t0}, {s1, t1}, {s0, t1}};
    for (int i = 0; i < 4; i++) {
        double q[3];
        light_point(cs[i][0], cs[i][1], q);
        n += blocked(g, q, dilate);
    }
    if (n == 4)
        return 1;
    // Projection of the box from g onto y = LIGHT_H: extreme over the box's corners.
    double plo[2] = {1e30, 1e30}, phi[2] = {-1e30, -1e30};
    for (int c = 0; c < 8; c++) {
        double x = (c & 1) ? OCC_HALF + dilate : -OCC_HALF - dilate;
        double y = (c & 2) ? OCC_H + dilate : OCC_H - dilate;
        double z = (c & 4) ? OCC_HALF + dilate : -OCC_HALF - dilate;
        double k = (LIGHT_H - g[1]) / (y - g[1]);
        double px = g[0] + (x - g[0]) * k, pz = g[2] + (z - g[2]) * k;
        plo[0] = fmin(plo[0], px), phi[0] = fmax(phi[0], px);
        plo[1] = fmin(plo[1], pz), phi[1] = fmax(phi[1], pz);
    }
    double q0[3], q1[3];
    light_point(s0, t0, q0);
    light_point(s1, t1, q1);
    bool apart = q1[0] < plo[0] || q0[0] > phi[0] || q1[2] < plo[1] || q0[2] > phi[1];
    return apart ? 0 : (n == 0 ? -1 : -1);
}

typedef struct result {
    int checked, lit, dark, penumbra, violations;
    double worst_excess;
} result;

static result run(const char *sampler, int n, int d, int spp_side, const char *traversal)
{
    result res = {0};
    char out[256], args[2048];
    snprintf(out, sizeof out, "%s", pn_test_tmp("ls_penumbra.exr"));
    snprintf(args, sizeof args,
             "render builtin:penumbra --no-ground --size 96x96 --aovs --camera-pos 0,3,3 --camera-target 0,0,0 "
             "--light-pos 0,%g,0 --light-normal 0,-1,0 --light-up 0,0,-1 --light-size %g,%g --tree %d,%d --spp %d "
             "--sampler %s --traversal %s --filter none -o %s",
             LIGHT_H, 2 * LIGHT_HALF, 2 * LIGHT_HALF, n, d, spp_side * spp_side, sampler, traversal, out);
    int rc = pn_test_run(args);
    CHECK_MSG(rc == 0, "render exited %d", rc);
    pn_exr_image img;
    if (rc != 0 || pn_exr_read(out, &img) != PN_OK)
        return res;
    const float *a = pn_exr_image_channel(&img, "A"), *v = pn_exr_image_channel(&img, "shadow.V");
    const float *px = pn_exr_image_channel(&img, "P.X"), *py = pn_exr_image_channel(&img, "P.Y");
    const float *pz = pn_exr_image_channel(&img, "P.Z");
    CHECK(a && v && px && py && pz);
    if (!(a && v && px && py && pz)) {
        pn_exr_image_free(&img);
        return res;
    }
    // The root box of the scene's bounds [-2,2] x [0,0.5] x [-2,2] is a cube of edge 4 (+ ulps).
    double leaf = 4.0 / pow(n, d);
    double dilate = 2 * leaf * (1 + 0x1p-10);
    CHECK_MSG(3 * leaf < OCC_H && 4.0 / pow(n, d - 1) < OCC_H, "test geometry: the occluder must clear the start zone");
    bool grid = strcmp(sampler, "grid") == 0;
    int cells = spp_side * spp_side;
    for (int i = 0; i < img.width * img.height; i++) {
        if (a[i] != 1.0f || py[i] != 0.0f) // receiver pixels only (the occluder is at 0.5)
            continue;
        double g[3] = {px[i], py[i], pz[i]};
        // Bounds on the number of visible samples: lo from the dilated occluder, hi from the exact one.
        int vis_lo = 0, vis_hi = 0;
        for (int jj = 0; jj < spp_side; jj++)
            for (int ii = 0; ii < spp_side; ii++) {
                double s0 = (double)ii / spp_side, s1 = (double)(ii + 1) / spp_side;
                double t0 = (double)jj / spp_side, t1 = (double)(jj + 1) / spp_side;
                if (grid) {
                    double q[3];
                    light_point(0.5 * (s0 + s1), 0.5 * (t0 + t1), q);
                    vis_lo += !blocked(g, q, dilate);
                    vis_hi += !blocked(g, q, 0);
                } else {
                    vis_lo += cell_state(g, s0, s1, t0, t1, dilate) == 0; // surely free even dilated
                    vis_hi += cell_state(g, s0, s1, t0, t1, 0) != 1;      // possibly free
                }
            }
        double lo = (double)vis_lo / cells, hi = (double)vis_hi / cells;
        res.checked++;
        if (v[i] < lo || v[i] > hi) {
            if (res.violations++ < 8)
                fprintf(stderr, "  %s/%s pixel %d at (%.4f, %.4f): V %.4f outside [%.4f, %.4f]\n", sampler, traversal, i,
                        g[0], g[2], v[i], lo, hi);
            double ex = v[i] < lo ? lo - v[i] : v[i] - hi;
            res.worst_excess = ex > res.worst_excess ? ex : res.worst_excess;
        }
        res.lit += v[i] == 1.0f;
        res.dark += v[i] == 0.0f;
        res.penumbra += v[i] > 0.0f && v[i] < 1.0f;
    }
    fprintf(stderr, "%s sampler, %s traversal, LS(%d,%d), %d spp: %d receiver pixels, %d lit, %d umbra, %d penumbra, "
                    "%d outside the bounds\n",
            sampler, traversal, n, d, cells, res.checked, res.lit, res.dark, res.penumbra, res.violations);
    pn_exr_image_free(&img);
    return res;
}

int main(void)
{
    const char *traversals[] = {"ray", "packet"};
    for (int k = 0; k < 2; k++) {
        result r = run("grid", 8, 3, 8, traversals[k]);
        CHECK_MSG(r.violations == 0, "grid/%s: %d pixels outside the derived bounds (worst by %.4f)", traversals[k],
                  r.violations, r.worst_excess);
        // The view shows all three regions: fully lit (exactly 1), umbra (exactly 0) and penumbra.
        CHECK(r.checked > 2000 && r.lit > 500 && r.dark > 50 && r.penumbra > 200);
        r = run("stratified", 8, 3, 8, traversals[k]);
        CHECK_MSG(r.violations == 0, "stratified/%s: %d pixels outside the derived bounds (worst by %.4f)", traversals[k],
                  r.violations, r.worst_excess);
        CHECK(r.checked > 2000 && r.lit > 500 && r.dark > 50 && r.penumbra > 200);
    }
    return pn_test_result();
}
