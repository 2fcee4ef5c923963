// The filter's oracle (filter_oracle.h): filter.comp's weights in double, with the float
// evaluation's rounding bounded.
#include "filter_oracle.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

// A weight strictly between 0 and 1, i.e. neither keeping nor dropping its tap: more than 1e-3 from
// both, far beyond every rounding bound here, so that the double weight's verdict is the float's.
bool filter_between(double w) { return w > 1e-3 && w < 1 - 1e-3; }

// filter.comp's plane_offset: how far q leaves p's tangent plane, less 8 ulps of the magnitude, over
// the footprint; [*lo, *hi] holds the shader's float evaluation of it. In float, q - p rounds each
// component (u) and the dot product adds gamma_3 of s1 = sum |n_k (q_k - p_k)|: 4.1u s1 together;
// the allowance's product rounds by u of it, the subtraction by u of the result. The footprint (two
// products) and the division (2.5 ulp, Vulkan's bound for it) are relative: 7u. A point within the
// allowance gives exactly 0 in both (the clamp), p itself among them (footprint 0).
static double filter_offset(const float *p, const float *n, double footprint, const float *q, double *lo, double *hi)
{
    double mag = 0, d = 0, s1 = 0;
    for (int k = 0; k < 3; k++) {
        mag = fmax(mag, fmax(fabs(p[k]), fabs(q[k])));
        d += (double)n[k] * ((double)q[k] - p[k]);
        s1 += fabs((double)n[k] * ((double)q[k] - p[k]));
    }
    double allowance = 8 * fmax(mag, 1e-30) * 0x1p-23; // 8 ulp_bound(mag): 2^-23 is the float 1.1920929e-7
    double fp = fmax(footprint, 1e-30), u = FLOAT_U;
    double off_lo = fmax(fabs(d) - 4.1 * u * s1 - allowance * (1 + u), 0) * (1 - u);
    double off_hi = fmax(fabs(d) + 4.1 * u * s1 - allowance * (1 - u), 0) * (1 + u);
    *lo = off_lo / fp * (1 - 7 * u);
    *hi = off_hi / fp * (1 + 7 * u);
    return fmax(fabs(d) - allowance, 0) / fp;
}

// filter.comp's geometric weight: max(1 - rho^2, 0) c^2, 1 on the pixel's plane, 0 a footprint per
// pixel off it or across a right angle. It falls with rho and rises with c.
double filter_weight(double rho, double c) { return fmax(1 - rho * rho, 0) * c * c; }

// False outside the image or on the background (filter.comp skips those).
bool filter_tap_at(const filter_frame *f, int x, int y, int dx, int dy, filter_tap *t)
{
    int qx = x + dx, qy = y + dy;
    if (qx < 0 || qy < 0 || qx >= f->width || qy >= f->height || !(f->p[4 * (qy * f->width + qx) + 3] > 0))
        return false;
    const float *p = &f->p[4 * (y * f->width + x)], *n = &f->n[4 * (y * f->width + x)];
    const float *q = &f->p[4 * (qy * f->width + qx)], *m = &f->n[4 * (qy * f->width + qx)];
    double pixels = abs(dx) > abs(dy) ? abs(dx) : abs(dy);
    // The shader's footprints: view depth (N.w) x the float pixel angle x the pixel distance.
    double fp_p = (double)n[3] * f->pixel_angle * pixels, fp_q = (double)m[3] * f->pixel_angle * pixels;
    double lo1, hi1, lo2, hi2;
    double r1 = filter_offset(p, n, fp_p, q, &lo1, &hi1), r2 = filter_offset(q, m, fp_q, p, &lo2, &hi2);
    double nm = 0, s2 = 0;
    for (int k = 0; k < 3; k++) {
        nm += (double)n[k] * m[k];
        s2 += fabs((double)n[k] * m[k]);
    }
    t->rho = fmax(r1, r2);
    t->c = fmax(nm, 0);
    t->w = t->wgeo = filter_weight(t->rho, t->c);
    t->pen = 1;
    // The float weight: rho within the larger of the two offsets' intervals, c within gamma_3 s2
    // (3.1u s2) of its double, so w lies between w(rho_hi, c_lo) and w(rho_lo, c_hi);
    // the roundings of rho^2, 1 - rho^2, c c and the product add 4u where that is not exactly 0.
    double c_lo = fmax(nm - 3.1 * FLOAT_U * s2, 0), c_hi = fmax(nm + 3.1 * FLOAT_U * s2, 0);
    double w_lo = filter_weight(fmax(hi1, hi2), c_lo), w_hi = filter_weight(fmax(lo1, lo2), c_hi);
    t->err = fmax(w_hi - t->w, t->w - w_lo) + (w_hi > 0 ? 4 * FLOAT_U : 0);
    t->mag = 0;
    for (int k = 0; k < 3; k++)
        t->mag = fmax(t->mag, fmax(fabs(p[k]), fabs(q[k])));
    t->footprint = fmin(fp_p, fp_q);
    t->depth = fmin(n[3], m[3]);
    return true;
}

// filter.comp's penumbra_weight of taps p and q (pixel indices): max(1 - |q - p|^2 / (width / 2)^2, 0)
// with width the smaller of the two pixels' penumbra widths, 0 at width 0. *err bounds the shader's
// float evaluation against this double one: q - p rounds each component (u), the width's halving
// is exact, the division adds 2.5 ulp (5u) and the dot product gamma_3 (3.1u), so r^2 is within
// 2 (u + 5u) + 3.1u = 15.1u of its double, relative; 1 - r^2 adds u absolute. Twice that, for
// contraction and reordering.
static double filter_penumbra(const filter_frame *f, int p, int q, double *err)
{
    double width = fmin(f->penumbra[p], f->penumbra[q]) * FILTER_PENUMBRA_TOLERANCE, r2 = 0;
    if (!(width > 0)) {
        *err = 0;
        return 0;
    }
    for (int k = 0; k < 3; k++) {
        double r = ((double)f->p[4 * q + k] - f->p[4 * p + k]) / width;
        r2 += r * r;
    }
    *err = r2 * (1 + 15.1 * FLOAT_U) >= 1 ? (r2 * (1 - 15.1 * FLOAT_U) >= 1 ? 0 : 1) : 2 * (15.1 * FLOAT_U * r2 + FLOAT_U);
    return fmax(1 - r2, 0);
}

// filter.comp's spread for a window mean m: RANGE_SIGMAS standard deviations of the difference of
// two pixels' V, each the mean of `samples` Bernoulli trials of probability m; 0 for samples = 0 (a
// point light: V has no noise, only equal V average).
double filter_spread(double m, uint32_t samples)
{
    return samples ? FILTER_RANGE_SIGMAS * sqrt(2 * m * (1 - m) / samples) : 0;
}

// The spreads of the means in [m_lo, m_hi] (within [0, 1]) lie in [*lo, *hi]: m (1 - m) rises up to
// m = 1/2 and falls after it, so its extremes are at the interval's ends, or at 1/2 if inside.
void filter_spread_range(double m_lo, double m_hi, uint32_t samples, double *lo, double *hi)
{
    double a = filter_spread(m_lo, samples), b = filter_spread(m_hi, samples);
    *lo = fmin(a, b);
    *hi = m_lo <= 0.5 && m_hi >= 0.5 ? filter_spread(0.5, samples) : fmax(a, b);
}

// filter.comp's range weight of a neighbour whose V_raw differs from the pixel's by d: 1 at d = 0
// (the pixel itself and its equals), else max(1 - r^2, 0) with r = d over the spread, which is at
// least the shader's float 1e-30 (that only keeps the quotient finite). It rises with the spread.
double filter_range_weight(double d, double spread)
{
    if (d == 0)
        return 1;
    double r = d / fmax(spread, 1e-30f);
    return fmax(1 - r * r, 0);
}

// [*lo, *hi] holds the shader's float range weight for d != 0 and a float spread in [s_lo, s_hi].
// V_raw's values are ratios of sample counts (visible over valid), 0 or at least 1 / 1024 here, so
// the float d is 0 exactly when the double one is (even where denormals flush), and that case has no
// rounding. Otherwise the float d (one subtraction, u) and r (a division, 2.5 ulp: 5u) are within 6u
// relative, r^2 within u more and 1 - r^2 within u absolute (its result is at most 1); the clamp
// makes it exactly 0 where the float r^2 is surely 1 or more. Every constant twice, for contraction
// and reordering (as in filter_mean_tol).
void filter_range_weight_float(double d, double s_lo, double s_hi, double *lo, double *hi)
{
    const double u = FLOAT_U;
    double r_lo = d / fmax(s_hi, 1e-30f) * (1 - 12 * u), r_hi = d / fmax(s_lo, 1e-30f) * (1 + 12 * u);
    double x_lo = r_lo * r_lo * (1 - 2 * u), x_hi = r_hi * r_hi * (1 + 2 * u);
    *lo = x_hi >= 1 ? 0 : fmax(1 - x_hi - 2 * u, 0);
    *hi = x_lo >= 1 ? 0 : fmin(1 - x_lo + 2 * u, 1);
}

// A bound on |the shader's float weighted mean - the double one| for values in [0, 1], weights of
// sum W in double and a bound dw on the sum of |each float weight - its double|. The float sums of
// the window's w v and of w (at most 9 terms) are within gamma_10 of theirs, besides the weights'
// own errors: the mean moves by at most (dw + 2 gamma_10 W) / (W - dw - gamma_10 W) (|v - mean| <= 1
// for values in [0, 1]); the division adds 2.5 ulp (5u) of a mean <= 1. Twice the bound: the
// compiler may contract or reorder the float operations, which changes the constants above, not
// their order. 1 (any value) where the weights' errors may reach their sum.
static double filter_mean_tol(double w, double dw)
{
    double g10 = 10.1 * FLOAT_U;
    double den = w - dw - g10 * w;
    return den > 0 ? 2 * ((dw + 2 * g10 * w) / den + 5 * FLOAT_U) : 1;
}

// The relative error of the shader's float narrow = pc.narrow x max(width, view depth x pixel
// angle) x pow(samples, -3/4): two products (u each; the footprint's own product rounds by u too,
// which the factor 2 below covers, and the max is one of its arguments) and pow, which Vulkan lets
// inherit exp2(y log2 x)'s error: log2 within 3 ulp outside [0.5, 2] and 2^-21 absolute inside, y
// times it (u of the product, y |log2 x| u absolute), and exp2 within 3 + 2 |y log2 x| ulp. An
// absolute error e in the exponent is a relative one of e ln 2 in the result. Twice the whole, for
// contraction and reordering. Uniform samples only (the shader's pc.adaptive = 0): under adaptive
// sampling a pixel's own valid rays count instead, at least the first round's.
static double filter_narrow_rel(uint32_t samples)
{
    const double u = FLOAT_U, y = 0.75, l = log2((double)samples);
    double log_err = samples >= 1 && samples <= 2 ? 0x1p-21 : 3 * 2 * u * fabs(l);
    double pow_rel = (y * log_err + y * fabs(l) * u) * log(2.0) + (3 + 2 * y * fabs(l)) * 2 * u;
    return 2 * (2 * u + pow_rel);
}

// The window's Gaussian weight exp(-|q - p|^2 / (2 narrow^2)) of a tap, and [*lo, *hi] holding the
// shader's float evaluation: x^2 = |(q - p) / narrow|^2 rounds q - p per component (u), divides
// (2.5 ulp: 5u) and sums (gamma_3: 3.1u), besides narrow's own error twice: within
// r = 2 (narrow_rel + 6u) + 3.1u of x^2, relative, twice for contraction and reordering. So exp's
// argument a = x^2 / 2 lies in [a (1 - 2r), a (1 + 2r)], and exp adds 3 + 2 |a| ulp (Vulkan's bound,
// which does not keep exp of a negative below 1), twice; below, a denormal result may flush to 0.
// The ends are computed apart, so that a far tap (exp underflows) gives [0, FLT_MIN], not a
// product of 0 and infinity. narrow = 0 would give exactly 0 in both (no longer met: the penumbra
// counts as at least a pixel wide).
static double filter_gauss(const float *p, const float *q, double narrow, double narrow_rel, double *lo, double *hi)
{
    *lo = *hi = 0;
    if (!(narrow > 0))
        return 0;
    double x2 = 0;
    for (int k = 0; k < 3; k++) {
        double x = ((double)q[k] - p[k]) / narrow;
        x2 += x * x;
    }
    double a = 0.5 * x2, r = 2 * (2 * (narrow_rel + 6 * FLOAT_U) + 3.1 * FLOAT_U);
    double a_lo = a * (1 - r), a_hi = a * (1 + r), ulps = 2 * (3 + 2 * a_hi) * 2 * FLOAT_U;
    *lo = fmax(exp(-a_hi) * (1 - ulps) - FLT_MIN, 0);
    *hi = exp(-a_lo) * (1 + ulps) + FLT_MIN;
    return exp(-a);
}

// A three-valued verdict: surely false, within rounding of its threshold, surely true.
typedef enum { VERDICT_NO, VERDICT_MAYBE, VERDICT_YES } verdict;
static verdict verdict_or(verdict a, verdict b) { return a > b ? a : b; }

// Whether pixel (x + dx, y + dy), inside the image, shows an edge of geometry next to (x, y) as
// filter.comp's edge rule sees it: the background, or a surface weight below SURFACE_CONTINUES
// (within rounding of it: maybe). VERDICT_NO outside the image (the shader skips those).
static verdict filter_edge_at(const filter_frame *f, int x, int y, int dx, int dy)
{
    int qx = x + dx, qy = y + dy;
    if (qx < 0 || qy < 0 || qx >= f->width || qy >= f->height)
        return VERDICT_NO;
    filter_tap t;
    if (!filter_tap_at(f, x, y, dx, dy, &t))
        return VERDICT_YES; // the background
    if (t.wgeo + t.err < FILTER_SURFACE_CONTINUES)
        return VERDICT_YES;
    return t.wgeo - t.err < FILTER_SURFACE_CONTINUES ? VERDICT_MAYBE : VERDICT_NO;
}

// filter.comp at pixel (x, y), covered. Both loops are weighted means of the window's V_raw
// (filter_mean_tol): the first under the geometric weights, whose errors are filter_tap_at's; the
// second under wg wr, whose errors follow from intervals:
//  - the float mean lies within mean_tol of the double one, so its spread in filter_spread_range of
//    that interval; the float spread adds relative rounding: 1 - mean (u), the product (u) and the
//    division by samples (2.5 ulp: 5u) make 7u of sqrt's argument, half that after the sqrt, which
//    adds 4.5 ulp (9u: Vulkan's sqrt inherits 1 / inversesqrt's precision, 2 + 2.5 ulp), and the
//    product by RANGE_SIGMAS u: 13.5u, twice 27u. Denormals may flush to 0 (Vulkan allows it),
//    which moves the argument by less than 2 FLT_MIN (the product's and the quotient's) and the
//    spread by less than RANGE_SIGMAS sqrt(2 FLT_MIN) more. With samples = 0 the spread is exactly 0;
//  - each tap's range weight then lies in filter_range_weight_float's interval (exactly 1 at
//    d = 0), its geometric weight within err of t.w, and their float product within 2u (u, twice)
//    of the product of the intervals (all >= 0); the weight's error is the farther end's distance.
//
// Under the penumbra filter (f->narrow > 0) the geometric weight of each neighbour of a pixel with
// a blocker of its own also falls as a Gaussian of world distance, narrow = pc.narrow x its nearest
// blocker's penumbra width (at least the pixel's footprint) x samples^-3/4 wide, and the penumbra
// weight applies only where it would refuse a usable neighbour and an edge of geometry lies within
// the window or on the ring of 8 pixels CONTACT_REACH away (filter.comp's edge rule); where that
// verdict lies within rounding of a threshold, o->ambiguous says so and V is the verdict's (pen
// applies).
//
// At one sample a pixel, where the penumbra weight would not apply (filter.comp's near_edge is
// false: no edge of geometry in the window, nor on the ring, which it reads only where the penumbra
// weight would refuse), the range weight's spread is that of V's largest variance, a mean of 1/2,
// whatever the window's mean (o->widest; within rounding of the edge rule's threshold: ambiguous).
//
// A pixel without a valid ray keeps its V_raw where the light cannot reach it and otherwise takes
// the geometric mean of its neighbours'; a neighbour without a valid ray is no tap.
void filter_recompute(const filter_frame *f, int x, int y, filter_window *o)
{
    int lo_x = -((f->tile_w - 1) / 2), lo_y = -((f->tile_h - 1) / 2), k = 0;
    int i = y * f->width + x;
    float v_p = f->v_raw[i];
    bool unknown = f->valid[i] == 0, penumbra = f->narrow > 0;
    double sum = 0, dw = 0;
    memset(o, 0, sizeof *o);
    if (unknown && !f->reaches[i]) {
        o->v = v_p;
        return;
    }
    // The window's Gaussian: only for a pixel with an estimate and a blocker of its own.
    double narrow = -1, narrow_rel = 0;
    bool floored = false;
    if (penumbra && f->samples > 0 && !unknown && !(f->width_near[i] >= FLT_MAX)) {
        // The penumbra at least the pixel's footprint wide (view depth x pixel angle).
        double least = (double)f->n[4 * i + 3] * f->pixel_angle;
        narrow = (double)f->narrow * fmax(f->width_near[i], least) * pow((double)f->samples, -0.75);
        floored = least > f->width_near[i];
        narrow_rel = filter_narrow_rel(f->samples);
    }
    // First the taps, their penumbra weights and the edge rule's inputs, then the weights.
    double pen_err[FILTER_MAX_TAPS] = {0};
    verdict edge = VERDICT_NO, refuses = VERDICT_NO;
    for (int dy = lo_y; dy < lo_y + f->tile_h; dy++)
        for (int dx = lo_x; dx < lo_x + f->tile_w; dx++, k++) {
            int q = (y + dy) * f->width + x + dx;
            if (penumbra)
                edge = verdict_or(edge, filter_edge_at(f, x, y, dx, dy));
            o->in[k] = filter_tap_at(f, x, y, dx, dy, &o->t[k]) && f->valid[q] > 0;
            if (!o->in[k] || unknown)
                continue;
            filter_tap *t = &o->t[k];
            t->pen = filter_penumbra(f, i, q, &pen_err[k]);
            // It refuses below 1. The float 1 - r^2 is below 1 once r^2 is more than half an ulp
            // below 1 (2^-25) and within filter_penumbra's 2u or so of the double: surely beyond
            // 2^-22; exactly 1 at r = 0 (the pixel itself). Within that: ambiguous (cautious: a
            // refusal that small changes V by less than the bound, applied or not).
            double below = 1 - t->pen; // r^2, or 1 once r^2 >= 1
            refuses = verdict_or(refuses, below == 0 ? VERDICT_NO : below > 0x1p-22 ? VERDICT_YES : VERDICT_MAYBE);
        }
    // The edge rule: the ring is read only where the window showed no edge.
    verdict ring = VERDICT_NO;
    if (penumbra && refuses != VERDICT_NO && edge != VERDICT_YES)
        for (int dy = -FILTER_CONTACT_REACH; dy <= FILTER_CONTACT_REACH; dy += FILTER_CONTACT_REACH)
            for (int dx = -FILTER_CONTACT_REACH; dx <= FILTER_CONTACT_REACH; dx += FILTER_CONTACT_REACH)
                if (dx != 0 || dy != 0)
                    ring = verdict_or(ring, filter_edge_at(f, x, y, dx, dy));
    verdict applies = !penumbra ? VERDICT_YES : verdict_or(edge, ring);
    if (penumbra && refuses != VERDICT_NO) {
        o->refuses = refuses == VERDICT_YES;
        o->ambiguous = refuses == VERDICT_MAYBE || applies == VERDICT_MAYBE;
        o->lifted = o->refuses && applies == VERDICT_NO;
        o->ring = o->refuses && edge == VERDICT_NO && ring == VERDICT_YES;
    }
    // One sample a pixel where the penumbra weight would not apply (filter.comp's near_edge is
    // false): the spread of V's largest variance, 1/4 (a mean of 1/2). Where that verdict lies
    // within rounding: no verdict.
    verdict widest = VERDICT_NO;
    if (penumbra && f->samples == 1 && !unknown)
        widest = applies == VERDICT_NO ? VERDICT_YES : applies == VERDICT_MAYBE ? VERDICT_MAYBE : VERDICT_NO;
    o->widest = widest == VERDICT_YES;
    o->ambiguous = o->ambiguous || widest == VERDICT_MAYBE;
    // Without a refusal every usable tap's penumbra weight is 1: applying it changes nothing.
    bool pen_on = !unknown && applies != VERDICT_NO;
    int self = -lo_y * f->tile_w - lo_x;
    for (k = 0; k < f->tile_w * f->tile_h; k++) {
        if (!o->in[k])
            continue;
        filter_tap *t = &o->t[k];
        int dx = lo_x + k % f->tile_w, dy = lo_y + k / f->tile_w;
        const float *pp = &f->p[4 * i], *pq = &f->p[4 * ((y + dy) * f->width + x + dx)];
        // The weight's factors as intervals (all >= 0): the surface weight, the Gaussian, the
        // penumbra weight; each float product adds u, twice.
        double g = 1, g_lo = 1, g_hi = 1, pen = pen_on ? t->pen : 1, pe = pen_on ? pen_err[k] : 0;
        if (narrow >= 0 && k != self)
            g = filter_gauss(pp, pq, narrow, narrow_rel, &g_lo, &g_hi);
        double w_lo = fmax(t->wgeo - t->err, 0) * g_lo * fmax(pen - pe, 0);
        double w_hi = (t->wgeo + t->err) * g_hi * fmin(pen + pe, 1);
        t->w = t->wgeo * g * pen;
        t->err = fmax(w_hi * (1 + 4 * FLOAT_U) - t->w, t->w - w_lo * (1 - 4 * FLOAT_U));
        o->pen_between = o->pen_between || (pen_on && t->wgeo > 1e-3 && filter_between(t->pen));
        bool between = narrow >= 0 && t->wgeo > 1e-3 && filter_between(g);
        o->gauss_between = o->gauss_between || between;
        o->floored = o->floored || (floored && between);
        o->v_raw[k] = f->v_raw[(y + dy) * f->width + x + dx];
        o->d[k] = fabs((double)o->v_raw[k] - v_p);
        sum += t->w * o->v_raw[k];
        o->wg += t->w;
        dw += t->err;
    }
    o->mean = o->wg > 0 ? fmin(fmax(sum / o->wg, 0), 1) : v_p;
    o->mean_tol = filter_mean_tol(o->wg, dw);
    if (unknown) {
        o->v = o->wg > 0 ? o->mean : 1;
        o->tol = o->wg > 0 ? o->mean_tol : 0;
        return;
    }
    double m = o->widest ? 0.5 : o->mean, m_tol = o->widest ? 0 : o->mean_tol;
    o->spread = filter_spread(m, f->samples);
    double s_lo, s_hi;
    filter_spread_range(fmax(m - m_tol, 0), fmin(m + m_tol, 1), f->samples, &s_lo, &s_hi);
    const double rel = 27 * FLOAT_U, flush = FILTER_RANGE_SIGMAS * sqrt(2 * FLT_MIN);
    s_lo = f->samples ? fmax(s_lo * (1 - rel) - flush, 0) : 0;
    s_hi = f->samples ? s_hi * (1 + rel) + flush : 0;
    sum = dw = o->w = 0;
    o->range_between = false;
    for (k = 0; k < f->tile_w * f->tile_h; k++) {
        o->wr[k] = 0;
        if (!o->in[k])
            continue;
        const filter_tap *t = &o->t[k];
        o->wr[k] = filter_range_weight(o->d[k], o->spread);
        double w = t->w * o->wr[k], w_lo = fmax(t->w - t->err, 0), w_hi = t->w + t->err;
        if (o->d[k] != 0) {
            double wr_lo, wr_hi;
            filter_range_weight_float(o->d[k], s_lo, s_hi, &wr_lo, &wr_hi);
            w_lo *= wr_lo * (1 - 2 * FLOAT_U);
            w_hi *= wr_hi * (1 + 2 * FLOAT_U);
        }
        sum += w * o->v_raw[k];
        o->w += w;
        dw += fmax(w_hi - w, w - w_lo);
        o->range_between = o->range_between || (t->w > 1e-3 && filter_between(o->wr[k]));
        // The rule changed this tap's range weight from the window mean's (beyond rounding).
        o->widest_acted = o->widest_acted || (o->widest && t->w > 1e-3 && o->d[k] != 0 &&
                                              fabs(o->wr[k] - filter_range_weight(o->d[k], filter_spread(o->mean, f->samples))) > 1e-3);
    }
    o->v = o->w > 0 ? fmin(fmax(sum / o->w, 0), 1) : v_p;
    o->tol = filter_mean_tol(o->w, dw);
}
