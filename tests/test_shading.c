// Shading is right: the rendered radiance of a Lambertian plane under the rectangular light equals
// albedo/pi * E with E computed independently here:
//  1. light parallel to the plane: the closed-form form factor of a rectangle seen from a point
//     under one of its corners (Howell's catalogue, configuration B-3), combined over the four
//     corner rectangles with signs;
//  2. a tilted light cut by the plane's horizon: brute-force quadrature of cos*cos'/r^2 over the
//     light's area, so the hemisphere clipping is checked too;
//  3. a light facing away: exactly zero;
//  4. a point light: the inverse square law with the emitter's and receiver's cosines.
// No occluders, so V = 1 and shadow.V must be 1 on every covered pixel.
#include "io/exr.h"
#include "test_util.h"

#define PI 3.14159265358979323846

// Form factor from a point to a parallel a x b rectangle at distance c whose corner is straight above it.
static double corner_ff(double a, double b, double c)
{
    double A = a / c, B = b / c;
    double sa = sqrt(1 + A * A), sb = sqrt(1 + B * B);
    return (A / sa * atan(B / sa) + B / sb * atan(A / sb)) / (2 * PI);
}

static double signed_ff(double dx, double dz, double c)
{
    double s = (dx < 0 ? -1 : 1) * (dz < 0 ? -1 : 1);
    return s * corner_ff(fabs(dx), fabs(dz), c);
}

// Rectangle [x0,x1] x [z0,z1] at height c above the point (px, 0, pz), facing down.
static double parallel_ff(double px, double pz, double x0, double x1, double z0, double z1, double c)
{
    return signed_ff(x1 - px, z1 - pz, c) - signed_ff(x0 - px, z1 - pz, c) - signed_ff(x1 - px, z0 - pz, c) +
           signed_ff(x0 - px, z0 - pz, c);
}

// Brute force: E/L = integral over the light of max(0, cos) * max(0, cos') / r^2 dA, midpoint rule.
static double quadrature_e(const double p[3], const double n[3], const double centre[3], const double t[3],
                           const double b[3], const double ln[3], double w, double h, int steps)
{
    double sum = 0, da = (w / steps) * (h / steps);
    for (int i = 0; i < steps; i++)
        for (int j = 0; j < steps; j++) {
            double u = ((i + 0.5) / steps - 0.5) * w, v = ((j + 0.5) / steps - 0.5) * h;
            double q[3], d[3];
            for (int k = 0; k < 3; k++) {
                q[k] = centre[k] + u * t[k] + v * b[k];
                d[k] = q[k] - p[k];
            }
            double r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], r = sqrt(r2);
            double cr = (d[0] * n[0] + d[1] * n[1] + d[2] * n[2]) / r;
            double cl = -(d[0] * ln[0] + d[1] * ln[1] + d[2] * ln[2]) / r;
            if (cr > 0 && cl > 0)
                sum += cr * cl / r2 * da;
        }
    return sum;
}

typedef struct frame {
    pn_exr_image img;
    const float *r, *g, *b, *a, *v, *px, *py, *pz, *ar, *ag, *ab;
} frame;

static int render(const char *name, const char *light_args, frame *f)
{
    char args[2048];
    const char *out = pn_test_tmp(name);
    snprintf(args, sizeof args,
             "render builtin:plane --no-ground --size 64x64 --aovs --camera-pos 0,2.5,0.01 --camera-target 0,0,0 "
             "--fov 50 %s -o %s",
             light_args, out);
    int rc = pn_test_run(args);
    CHECK_MSG(rc == 0, "render exited %d", rc);
    if (rc != 0 || pn_exr_read(out, &f->img) != PN_OK)
        return 0;
    const char *names[11] = {"R", "G", "B", "A", "shadow.V", "P.X", "P.Y", "P.Z", "albedo.R", "albedo.G", "albedo.B"};
    const float **dst[11] = {&f->r, &f->g, &f->b, &f->a, &f->v, &f->px, &f->py, &f->pz, &f->ar, &f->ag, &f->ab};
    for (int i = 0; i < 11; i++) {
        *dst[i] = pn_exr_image_channel(&f->img, names[i]);
        CHECK_MSG(*dst[i] != NULL, "channel %s missing", names[i]);
        if (!*dst[i])
            return 0;
    }
    return f->img.width * f->img.height;
}

int main(void)
{
    const double L[3] = {2, 3, 4};
    // 1. Parallel light: centre (0.2, 0.5, 0.1), facing down, width 0.6 along -x x ... the rectangle
    //    spans x in [-0.1, 0.5] and z in [-0.1, 0.3] whatever the orientation of its axes.
    frame f;
    int n = render("shade_parallel.exr",
                   "--light-pos 0.2,0.5,0.1 --light-normal 0,-1,0 --light-up 0,0,-1 --light-size 0.6,0.4 "
                   "--light-radiance 2,3,4",
                   &f);
    int covered = 0;
    double worst = 0;
    for (int i = 0; i < n; i++) {
        if (f.a[i] != 1.0f)
            continue;
        covered++;
        CHECK_MSG(f.v[i] == 1.0f, "pixel %d: V = %g without occluders", i, f.v[i]);
        CHECK_MSG(fabs(f.py[i]) < 1e-6, "pixel %d: P.Y = %g off the plane", i, f.py[i]);
        double ff = parallel_ff(f.px[i], f.pz[i], -0.1, 0.5, -0.1, 0.3, 0.5 - f.py[i]);
        const float *rgb[3] = {f.r, f.g, f.b}, *alb[3] = {f.ar, f.ag, f.ab};
        for (int c = 0; c < 3; c++) {
            // Outgoing radiance = albedo/pi * E = albedo/pi * (pi * L * F) = albedo * L * F.
            double want = alb[c][i] * L[c] * ff;
            double rel = fabs(rgb[c][i] - want) / want;
            if (rel > worst)
                worst = rel;
            CHECK_MSG(rel < 1e-3, "pixel %d channel %d: radiance %.7g, closed form %.7g (rel %.2e)", i, c,
                      rgb[c][i], want, rel);
        }
        CHECK_MSG(fabs(f.ar[i] - 0.5) < 1e-3, "pixel %d: albedo %g, material says 0.5", i, f.ar[i]);
    }
    fprintf(stderr, "parallel light: %d covered pixels, worst relative error %.2e\n", covered, worst);
    CHECK_MSG(covered > 1000, "only %d pixels show the plane", covered);
    pn_exr_image_free(&f.img);

    // 2. A light tilted by 60 degrees whose lower part dips below the plane: points see only the part
    //    above their horizon. Normal (0,-cos60,sin60)... facing down and towards +z.
    double th = 60 * PI / 180;
    double ln[3] = {0, -cos(th), sin(th)};
    double centre[3] = {0.1, 0.15, -0.3};
    char largs[512];
    snprintf(largs, sizeof largs,
             "--light-pos %.17g,%.17g,%.17g --light-normal %.17g,%.17g,%.17g --light-up 0,1,0 --light-size 0.8,0.5 "
             "--light-radiance 2,3,4",
             centre[0], centre[1], centre[2], ln[0], ln[1], ln[2]);
    n = render("shade_tilted.exr", largs, &f);
    // Light frame as documented: bitangent = up projected on the light plane, tangent = b x n.
    double bt[3] = {0, 1, 0}, d = bt[0] * ln[0] + bt[1] * ln[1] + bt[2] * ln[2];
    for (int k = 0; k < 3; k++)
        bt[k] -= d * ln[k];
    double bl = sqrt(bt[0] * bt[0] + bt[1] * bt[1] + bt[2] * bt[2]);
    for (int k = 0; k < 3; k++)
        bt[k] /= bl;
    double tg[3] = {bt[1] * ln[2] - bt[2] * ln[1], bt[2] * ln[0] - bt[0] * ln[2], bt[0] * ln[1] - bt[1] * ln[0]};
    int checked = 0, lit = 0;
    worst = 0;
    for (int i = 0; i < n; i += 37) {
        if (f.a[i] != 1.0f)
            continue;
        double p[3] = {f.px[i], f.py[i], f.pz[i]}, nn[3] = {0, 1, 0};
        double e = quadrature_e(p, nn, centre, tg, bt, ln, 0.8, 0.5, 1500);
        double want = f.ar[i] * L[0] * e / PI;
        checked++;
        if (want > 0)
            lit++;
        double err = fabs(f.r[i] - want);
        // Relative 1e-3 where lit; the quadrature itself is good to ~1e-5 of the peak here.
        double tol = 1e-3 * want + 1e-6;
        if (want > 0 && err / want > worst)
            worst = err / want;
        CHECK_MSG(err <= tol, "tilted, pixel %d at (%.3f, %.3f): radiance %.7g, quadrature %.7g", i, p[0], p[2],
                  f.r[i], want);
    }
    fprintf(stderr, "tilted light: %d pixels checked against quadrature (%d lit), worst relative error %.2e\n",
            checked, lit, worst);
    CHECK(checked > 50 && lit > 20);
    pn_exr_image_free(&f.img);

    // 3. Facing away from the plane: one-sided, so nothing arrives.
    n = render("shade_away.exr", "--light-pos 0,0.5,0 --light-normal 0,1,0 --light-size 1,1 --light-radiance 5", &f);
    covered = 0;
    for (int i = 0; i < n; i++)
        if (f.a[i] == 1.0f) {
            covered++;
            CHECK_MSG(f.r[i] == 0.0f && f.g[i] == 0.0f && f.b[i] == 0.0f, "pixel %d lit from behind the light", i);
        }
    CHECK(covered > 1000);
    pn_exr_image_free(&f.img);

    // 4. A point light (--light-size 0,0), tilted: --light-radiance is its intensity I along the
    //    normal, so E = I cos(light) cos(receiver) / r^2 (inverse square law, cosine emitter).
    double pn_[3] = {0.3, -1, 0.2}, pl = sqrt(0.09 + 1 + 0.04), pp[3] = {0.1, 0.4, -0.2};
    n = render("shade_point.exr",
               "--light-pos 0.1,0.4,-0.2 --light-normal 0.3,-1,0.2 --light-size 0,0 --light-radiance 2,3,4", &f);
    covered = 0;
    worst = 0;
    for (int i = 0; i < n; i++) {
        if (f.a[i] != 1.0f)
            continue;
        covered++;
        double dp[3] = {f.px[i] - pp[0], f.py[i] - pp[1], f.pz[i] - pp[2]};
        double r2 = dp[0] * dp[0] + dp[1] * dp[1] + dp[2] * dp[2], r = sqrt(r2);
        double cl = (pn_[0] * dp[0] + pn_[1] * dp[1] + pn_[2] * dp[2]) / (pl * r), cr = -dp[1] / r;
        double e = cl > 0 && cr > 0 ? cl * cr / r2 : 0;
        const float *rgb[3] = {f.r, f.g, f.b}, *alb[3] = {f.ar, f.ag, f.ab};
        for (int c = 0; c < 3; c++) {
            double want = alb[c][i] / PI * L[c] * e, rel = want > 0 ? fabs(rgb[c][i] - want) / want : rgb[c][i];
            worst = rel > worst ? rel : worst;
            CHECK_MSG(rel < 1e-3, "point light, pixel %d channel %d: radiance %.7g, inverse square %.7g", i, c,
                      rgb[c][i], want);
        }
    }
    fprintf(stderr, "point light: %d covered pixels, worst relative error %.2e\n", covered, worst);
    CHECK(covered > 1000);
    pn_exr_image_free(&f.img);
    return pn_test_result();
}
