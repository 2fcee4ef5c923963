// The penumbra filter's oracle (penumbra_oracle.h): its Gaussian's weights in double, with the
// float evaluation's rounding bounded.
#include "penumbra_oracle.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

// The shader's footprint of a pixel (view depth x pixel angle): one float product, which the
// double product of the two floats rounded to float is, bit for bit.
static double pixel_footprint(const penumbra_frame *f, int i)
{
    return (float)((double)f->n[4 * i + 3] * f->pixel_angle);
}

static bool covered(const penumbra_frame *f, int i) { return f->p[4 * i + 3] > 0; }

// A pixel has a footprint of its own where one of its valid rays was blocked (the nearest blocker's
// penumbra is then finite: filter.comp's penumbra_footprint); its row-pass footprint output is then
// that footprint over its pixel's, so the product gives it back within PENUMBRA_SIGMA_REL.
static bool own(const penumbra_frame *f, int i) { return covered(f, i) && f->valid[i] > 0 && f->v_raw[i] < 1.0f; }
static double own_footprint(const penumbra_frame *f, int i)
{
    return (double)f->scratch[2 * i + 1] * pixel_footprint(f, i);
}

double penumbra_centre_footprint(const penumbra_frame *f, int x, int y, int *ring)
{
    int i = y * f->width + x;
    *ring = own(f, i) ? 0 : -1;
    if (*ring == 0 || !covered(f, i)) // the background's footprint is 0 (filter.comp writes 0 there)
        return *ring == 0 ? own_footprint(f, i) : 0.0;
    // Without one: the narrowest of the 3 x 3 neighbours' own, else of the 16 of the 5 x 5's outer
    // ring (clamped to the image), 0 if none, at most max_radius / RADIUS_SIGMAS of the pixel's own
    // footprints (float's quotient and product).
    double narrowest = -1.0;
    for (int r = 1; r <= 2 && narrowest < 0.0; r++) {
        for (int dy = -r; dy <= r; dy++)
            for (int dx = -r; dx <= r; dx++) {
                if (abs(dx) != r && abs(dy) != r)
                    continue; // inside the ring
                int qx = x + dx < 0 ? 0 : x + dx >= f->width ? f->width - 1 : x + dx;
                int qy = y + dy < 0 ? 0 : y + dy >= f->height ? f->height - 1 : y + dy;
                int j = qy * f->width + qx;
                if (own(f, j) && (narrowest < 0.0 || own_footprint(f, j) < narrowest))
                    narrowest = own_footprint(f, j);
            }
        *ring = narrowest < 0.0 ? -1 : r;
    }
    double limit = (float)((double)(float)(f->max_radius / PENUMBRA_RADIUS_SIGMAS) * pixel_footprint(f, i));
    return fmin(fmax(narrowest, 0.0), limit);
}

double penumbra_row_v(float stored) { return fabs((double)stored); }
bool penumbra_row_lends(float stored) { return !signbit(stored); }

bool penumbra_lends(const penumbra_frame *f, int i, bool rows)
{
    return covered(f, i) && (f->valid[i] > 0 || (!rows && f->reaches[i] != 0));
}

// The footprints each pass reads, world units, and a bound on their relative error against the
// shader's floats. Rows: the centre's (above) and a tap's own (0 without one: no footprint), both
// recovered. Columns: the row pass's output in pixels times the pixel's footprint, one float
// product for the centre and two for a tap (pixels x view depth x pixel angle, in that order),
// recomputed here in float; 2u allows for the compiler fusing or reordering them.
static double column_footprint(const penumbra_frame *f, int i, bool centre)
{
    float y = f->scratch[2 * i + 1];
    if (centre)
        return (float)((double)y * pixel_footprint(f, i));
    return (float)((double)(float)((double)y * f->n[4 * i + 3]) * f->pixel_angle);
}

static double distance3(const float *a, const float *b)
{
    double s = 0.0;
    for (int k = 0; k < 3; k++)
        s += ((double)a[k] - b[k]) * ((double)a[k] - b[k]);
    return sqrt(s);
}

// A bound on |the shader's float weighted mean - the double one| for values in [0, 1], n weights of
// sum w in double and a bound dw on the sum of |each float weight - its double| (filter_oracle.c's
// filter_mean_tol for any count of taps): the float sums of w v and of w are within gamma_(n+1)
// of theirs, so the mean moves by at most (dw + 2 gamma w) / (w - dw - gamma w); the division adds
// 2.5 ulp (5u) of a mean <= 1. Twice that, for contraction and reordering. 1 (any value) where the
// weights' errors may reach their sum.
static double mean_tol(double w, double dw, int n)
{
    double g = (n + 1.1) * FLOAT_U;
    double den = w - dw - g * w;
    return den > 0 ? 2 * ((dw + 2 * g * w) / den + 5 * FLOAT_U) : 1;
}

// The shader's step and reach for a deviation of sigma_px pixels (penumbra_filter.comp's reach():
// ceil(TAP_SIGMAS sigma), at most max_radius; taps every max(floor(sigma / 2), 1) pixels, the
// reach a multiple of the step).
static void taps_of(double sigma_px, uint32_t max_radius, int *step, int *reach)
{
    double r = ceil(PENUMBRA_TAP_SIGMAS * sigma_px);
    *step = (int)fmax(floor(0.5 * sigma_px), 1);
    *reach = (int)fmin(r, max_radius) / *step * *step;
}

// penumbra_filter.comp's blur() at (x, y). Float error bounds, relative unless said:
//  - sigma_px: the footprint's (PENUMBRA_SIGMA_REL along rows, 2u along columns), a distance
//    (sqrt of a dot product: 6u before it, 3u after; sqrt 4.5 ulp, 9u, as Vulkan's
//    1 / inversesqrt: 12u) and the quotient (5u); twice that. A threshold inside
//    sigma_px (1 +- that) makes the pixel ambiguous (TAP_SIGMAS sigma adds nothing: a power of two);
//  - the spread: 1 - V (u), the product (u), 1 / samples and / samples (5u each) make 12u of sqrt's
//    argument, 6u after the sqrt, which adds 9u, and the product by RANGE_SIGMAS u: 16u, twice 32u
//    (the argument is at least 1 / samples^2: nothing flushes);
//  - a tap's Gaussian exp(-X / 2), X = |q - p|^2 / sigma^2: each component's difference (u) over
//    sigma (5u, and sigma's own error e) is within 6u + e, its square 2 (6u + e) + u, their sum 2u
//    more: 15u + 2e, twice 30u + 4e; exp adds 3 + X ulp (Vulkan's 3 + 2 |x|), 2u each, twice;
//    below FLT_MIN the result may flush to 0;
//  - its surface weight: filter_tap_at's bound (filter_common.glsl's surface_weight, shared with
//    filter.comp); its range weight: filter_range_weight_float's, on the spread's interval;
//  - the product of the three: 2u (u each), twice.
void penumbra_recompute(const penumbra_frame *f, int x, int y, bool rows, penumbra_pixel *o)
{
    const double u = FLOAT_U;
    int i = y * f->width + x;
    memset(o, 0, sizeof *o);
    o->v_in = rows ? f->v_window[i] : penumbra_row_v(f->scratch[2 * i]);
    o->v = o->v_in;
    int ring_p = -1;
    double fp = pixel_footprint(f, i);
    o->footprint = rows ? penumbra_centre_footprint(f, x, y, &ring_p) : column_footprint(f, i, true);
    double e_sigma = rows ? PENUMBRA_SIGMA_REL : 2 * u;
    // The background, and a pixel the light cannot reach (no valid ray, and the light below its
    // horizon), keep their V.
    if (!covered(f, i) || !penumbra_lends(f, i, false))
        return;
    // First over the pixel's footprint facing the camera, then over the world length of one pixel
    // along the pass: the nearer neighbour's distance (clamped to the image: the pixel itself, none),
    // at least that footprint. The second is at most the first.
    double e = 2 * (e_sigma + 12 * u + 5 * u);
    double s1 = o->footprint / fmax(fp, 1e-30);
    o->sigma_px = s1;
    if (s1 >= PENUMBRA_MIN_SIGMA) {
        int dx = rows ? 1 : 0, dy = rows ? 0 : 1;
        int ax = x - dx < 0 ? x : x - dx, ay = y - dy < 0 ? y : y - dy;
        int bx = x + dx >= f->width ? x : x + dx, by = y + dy >= f->height ? y : y + dy;
        int a = ay * f->width + ax, b = by * f->width + bx;
        double da = a == i ? 1e30 : distance3(&f->p[4 * a], &f->p[4 * i]);
        double db = b == i ? 1e30 : distance3(&f->p[4 * b], &f->p[4 * i]);
        o->sigma_px = o->footprint / fmax(fmax(fmin(da, db), fp), 1e-30);
    }
    o->sigma_err = e;
    // Either deviation near MIN_SIGMA, or the step's or the reach's integer near its threshold.
    bool near_min = (s1 * (1 - e) < PENUMBRA_MIN_SIGMA) != (s1 * (1 + e) < PENUMBRA_MIN_SIGMA) ||
                    (o->sigma_px * (1 - e) < PENUMBRA_MIN_SIGMA) != (o->sigma_px * (1 + e) < PENUMBRA_MIN_SIGMA);
    int step_lo, reach_lo, step_hi, reach_hi;
    taps_of(o->sigma_px * (1 - e) * (1 - u), f->max_radius, &step_lo, &reach_lo);
    taps_of(o->sigma_px * (1 + e) * (1 + u), f->max_radius, &step_hi, &reach_hi);
    o->ambiguous = near_min || step_lo != step_hi || reach_lo != reach_hi;
    if (o->sigma_px < PENUMBRA_MIN_SIGMA)
        return; // the window's V (rows) or the row pass's (columns), as it was
    o->filtered = true;
    taps_of(o->sigma_px, f->max_radius, &o->step, &o->reach);
    // The range weight's spread: the noise of one pixel's V, at least that of V = 1 / n, for the
    // window's WINDOW_SAMPLES times the pixel's samples, times sqrt 2 (two pixels' difference).
    double n = (double)f->samples * PENUMBRA_WINDOW_SAMPLES, vp = o->v_in;
    o->spread = PENUMBRA_RANGE_SIGMAS * sqrt(2 * fmax(vp * (1 - vp), 1 / n) / n);
    double s_lo = o->spread * (1 - 32 * u), s_hi = o->spread * (1 + 32 * u);
    filter_frame ff = {.width = f->width, .height = f->height, .pixel_angle = f->pixel_angle, .p = f->p, .n = f->n};
    const float *p = &f->p[4 * i];
    double sum = 0, dw = 0, w_hi_sum = 0;
    for (int k = -o->reach; k <= o->reach; k += o->step) {
        int qx = rows ? x + k : x, qy = rows ? y : y + k;
        if (qx < 0 || qy < 0 || qx >= f->width || qy >= f->height)
            continue;
        o->taps++;
        int j = qy * f->width + qx;
        filter_tap t;
        // Background taps lend nothing, nor those without a valid ray: along rows none of them,
        // along columns those the light cannot reach.
        if (!filter_tap_at(&ff, x, y, qx - x, qy - y, &t) || !penumbra_lends(f, j, rows))
            continue;
        double vq = rows ? f->v_window[j] : penumbra_row_v(f->scratch[2 * j]);
        // The narrower of the two footprints, the centre's where the tap has none of its own.
        double fq = rows ? (own(f, j) ? own_footprint(f, j) : 0.0) : column_footprint(f, j, false);
        double sigma = fq > 0 ? fmin(o->footprint, fq) : o->footprint;
        o->narrowed = o->narrowed || (fq > 0 && fq < o->footprint);
        double g = 1, g_lo = 1, g_hi = 1;
        if (k != 0) {
            double xx = 0;
            for (int c = 0; c < 3; c++) {
                double d = ((double)f->p[4 * j + c] - p[c]) / sigma;
                xx += d * d;
            }
            double ex = 30 * u + 4 * e_sigma, ulps = 2 * (3 + xx) * 2 * u;
            g = exp(-0.5 * xx);
            g_lo = exp(-0.5 * xx * (1 + ex)) * fmax(1 - ulps, 0);
            g_hi = fmin(exp(-0.5 * xx * (1 - ex)) * (1 + ulps), 1);
            g_lo = g_lo < FLT_MIN ? 0 : g_lo;
            g_hi = g_hi < FLT_MIN ? FLT_MIN : g_hi;
            o->gauss_between = o->gauss_between || filter_between(g);
        }
        double d = fabs(vq - vp), r = 1, r_lo = 1, r_hi = 1;
        if (d != 0) {
            double rr = d / o->spread;
            r = fmax(1 - rr * rr, 0);
            filter_range_weight_float(d, s_lo, s_hi, &r_lo, &r_hi);
            o->range_between = o->range_between || (g * t.w > 1e-3 && filter_between(r));
        }
        o->surface_between = o->surface_between || (g > 1e-3 && filter_between(t.w));
        double w = g * t.w * r;
        double w_lo = g_lo * fmax(t.w - t.err, 0) * r_lo * (1 - 4 * u);
        double w_hi = g_hi * (t.w + t.err) * r_hi * (1 + 4 * u);
        sum += w * vq;
        o->w += w;
        dw += fmax(w_hi - w, w - w_lo);
        w_hi_sum += w_hi;
    }
    o->v = o->w > 0 ? fmin(fmax(sum / o->w, 0), 1) : vp;
    // No tap can weigh anything in float: the shader keeps the pixel's V, exactly.
    o->tol = w_hi_sum > 0 ? mean_tol(o->w, dw, o->taps) : 0;
}
