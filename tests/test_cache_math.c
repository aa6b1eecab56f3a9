/* test_cache_math.c - the irradiance cache's numerical core (shaders/cache_math.glsl,
 * paper §4.2, §4.3) compiled on the host, against closed forms, in double precision
 * (cm_*, relative tolerance 1e-12) and in float (cmf_*, the shaders' precision,
 * relative tolerance 1e-5).  Every test runs both instantiations through one table of
 * function pointers (float arguments are rounded from the double test values).
 *
 *  - exponential field: along each half-axis E(x) = E0 exp(-s x) with a different s
 *    per half-axis; Eq. 6 recovers s, Eq. 7 reproduces the field at any distance
 *    inside the radius, and Eq. 7 + 8 reproduce exactly a field whose logarithm is
 *    linear in the local coordinates of an octant, E0 exp(-(sx|x| + sy|y| + sz|z|)),
 *    for equal and for different sigmas per half-axis (and the axis field on an axis);
 *  - validity radius (Eq. 9, 10): the extrapolation at R equals (1 + eps) E_delta for a
 *    growing field and (1 - eps) E_delta for a decaying one (R equals the literal
 *    Eq. 9); clamping to [r_min, r_max]; the Fig. 4 radius of the interpolated sigma_v;
 *  - ellipsoid radius r(x), Eq. 11 weights (1 at the centre, 0 on the edge, monotone),
 *    the log-space average (identical entries return their value);
 *  - Fig. 6 radius reduction (the event ends just outside, common factor);
 *  - the curvature limit of the radius: no limit for any exponential field; for a field
 *    whose logarithm is quadratic, the secant's error at the limited radius is exactly
 *    ln(1 + eps); a lit face and a shadow edge are limited, a flat shadow is not;
 *  - the medium model of the normal axis: a homogeneous medium keeps the paper's model
 *    exactly (f = 1, u = x); at a lit and at an unlit face (medium up to s < delta,
 *    air beyond, a collimated light along the axis) Eq. 7 on the stretched coordinate
 *    reproduces the field exactly over [0, delta] and stays within eps of it out to the
 *    radius of Eq. 10; the octant bound keeps any mix of axes within the estimates;
 *  - degenerate inputs (zero, equal, 1e-30 / 1e30 ratios, delta 1e-20, zero and
 *    infinite radii, a fully shadowed entry, NaN and inf everywhere): every output is
 *    finite and equals the rule documented in cache_math.glsl.
 * Pure arithmetic, no GPU: well under a second.
 */
#include "test_util.h"

#include "reference/cache_math_host.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* ---- both instantiations behind one table --------------------------------------- */

#define CMT_A1 double a
#define CMT_A2 double a, double b
#define CMT_A3 double a, double b, double c
#define CMT_A4 double a, double b, double c, double d
#define CMT_A5 double a, double b, double c, double d, double e
#define CMT_A6 double a, double b, double c, double d, double e, double f
#define CMT_A7 double a, double b, double c, double d, double e, double f, double g
#define CMT_A10                                                                          \
    double a, double b, double c, double d, double e, double f, double g, double h,      \
        double i, double j
#define CMT_F1 (float)a
#define CMT_F2 (float)a, (float)b
#define CMT_F3 (float)a, (float)b, (float)c
#define CMT_F4 (float)a, (float)b, (float)c, (float)d
#define CMT_F5 (float)a, (float)b, (float)c, (float)d, (float)e
#define CMT_F6 (float)a, (float)b, (float)c, (float)d, (float)e, (float)f
#define CMT_F7 (float)a, (float)b, (float)c, (float)d, (float)e, (float)f, (float)g
#define CMT_F10                                                                          \
    (float)a, (float)b, (float)c, (float)d, (float)e, (float)f, (float)g, (float)h,      \
        (float)i, (float)j

#define CMT_FUNCS(X)                                                                     \
    X(1, ln_irradiance)                                                                  \
    X(1, irradiance_from_ln)                                                             \
    X(1, san_ln)                                                                         \
    X(1, san_len)                                                                        \
    X(1, san_coord)                                                                      \
    X(1, san_sigma)                                                                      \
    X(3, half_axis)                                                                      \
    X(3, sigma_v_ln)                                                                     \
    X(3, sigma_v)                                                                        \
    X(3, ln_extrapolate)                                                                 \
    X(3, log_extrapolate)                                                                \
    X(3, extrapolate)                                                                    \
    X(6, sigma_interp)                                                                   \
    X(5, validity_radius_sigma)                                                          \
    X(6, validity_radius)                                                                \
    X(10, interp_validity_radius)                                                        \
    X(3, length3)                                                                        \
    X(3, length1)                                                                        \
    X(7, log_extrapolate_octant)                                                         \
    X(6, ellipsoid_norm)                                                                 \
    X(6, ellipsoid_radius)                                                               \
    X(1, weight_norm)                                                                    \
    X(2, weight)                                                                         \
    X(2, weighted_ln)                                                                    \
    X(2, log_average_finalize)                                                           \
    X(6, reduce_factor)                                                                  \
    X(3, reduced_radius)                                                                 \
    X(2, entry_delta)                                                                    \
    X(3, entry_r_min)                                                                    \
    X(3, entry_r_max)                                                                    \
    X(7, curvature_radius)                                                               \
    X(1, medium_fraction)                                                                \
    X(3, medium_coord)                                                                   \
    X(7, medium_bound)                                                                   \
    X(1, stat_sample)                                                                    \
    X(1, stat_count)                                                                     \
    X(1, stat_m2)                                                                        \
    X(4, stat_merge_mean)                                                                \
    X(6, stat_merge_m2)

#define CMT_MEMBER(n, name) double (*name)(CMT_A##n);
#define CMT_WRAP(n, name) \
    static double cmt_f_##name(CMT_A##n) { return (double)cmf_##name(CMT_F##n); }
#define CMT_INIT_D(n, name) .name = cm_##name,
#define CMT_INIT_F(n, name) .name = cmt_f_##name,

typedef struct cmt_impl {
    const char *prec;
    double tol;         /* relative tolerance of the exact closed forms */
    double ulp;         /* machine epsilon of the instantiation */
    bool (*log_average_valid)(double);
    bool (*eq5_met)(double, double, double, double);
    CMT_FUNCS(CMT_MEMBER)
} cmt_impl;

CMT_FUNCS(CMT_WRAP)
static bool cmt_f_log_average_valid(double a) { return cmf_log_average_valid((float)a); }
static bool cmt_f_eq5_met(CMT_A4) { return cmf_eq5_met(CMT_F4); }

static const cmt_impl cmt_impls[2] = {
    {.prec = "double", .tol = 1e-12, .ulp = DBL_EPSILON,
     .log_average_valid = cm_log_average_valid, .eq5_met = cm_eq5_met, CMT_FUNCS(CMT_INIT_D)},
    {.prec = "float", .tol = 1e-5, .ulp = FLT_EPSILON,
     .log_average_valid = cmt_f_log_average_valid, .eq5_met = cmt_f_eq5_met, CMT_FUNCS(CMT_INIT_F)},
};

/* Deterministic random numbers (splitmix64), uniform in [0, 1). */
static double cmt_rand01(uint64_t *state) {
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

/* ---- checks ----------------------------------------------------------------------- */

static double cmt_max_rel[2];   /* largest relative error seen per precision (printed) */

#define CMT_FINITE(im, what, v)                                                          \
    do {                                                                                 \
        double v_ = (v);                                                                 \
        if (!isfinite(v_)) fail_msg("[%s] %s = %g is not finite", (im)->prec, what, v_); \
    } while (0)

/* |got - want| <= tol (|want| + floor) */
static void cmt_close(const cmt_impl *im, const char *what, double got, double want,
                      double tol, double floor) {
    if (!isfinite(got)) fail_msg("[%s] %s = %g is not finite", im->prec, what, got);
    double err = fabs(got - want) / (fabs(want) + floor);
    int k = im == &cmt_impls[0] ? 0 : 1;
    if (err > cmt_max_rel[k] && floor == 0 && tol <= im->tol) cmt_max_rel[k] = err;
    if (!(err <= tol))
        fail_msg("[%s] %s = %.17g, expected %.17g (relative error %.3g > %.3g)", im->prec,
                 what, got, want, err, tol);
}
#define CMT_REL(im, what, got, want) cmt_close(im, what, got, want, (im)->tol, 0)

/* |got - want| <= atol */
static void cmt_abs(const cmt_impl *im, const char *what, double got, double want, double atol) {
    if (!(fabs(got - want) <= atol))
        fail_msg("[%s] %s = %.17g, expected %.17g (absolute error %.3g > %.3g)", im->prec, what,
                 got, want, fabs(got - want), atol);
}

static void cmt_exact(const cmt_impl *im, const char *what, double got, double want) {
    if (!(got == want))
        fail_msg("[%s] %s = %.17g, expected exactly %.17g", im->prec, what, got, want);
}

/* The constants rounded to the instantiation's precision. */
static double cmt_r(const cmt_impl *im, double v) {
    return im == &cmt_impls[0] ? v : (double)(float)v;
}

/* ---- 1. exponential field: Eq. 6, 7, 8 --------------------------------------------- */

static void exponential_field(const cmt_impl *im) {
    const double E0s[3] = {1.0, 3.7e-3, 250.0};
    /* s per half-axis +x, -x, +y, -y, +z, -z: decaying, growing, weak, steep, flat */
    const double s[6] = {0.7, -0.3, 0.05, -1.2, 0.0, 2.5};
    const double delta = 2.0, eps = 0.1, rmin = 0.01, rmax = 16.0;
    char what[160];
    for (int k = 0; k < 3; k++) {
        double E0 = E0s[k];
        double sig[6], R[6];
        for (int h = 0; h < 6; h++) {
            double Ed = E0 * exp(-s[h] * delta);
            sig[h] = im->sigma_v(E0, Ed, delta);
            snprintf(what, sizeof what, "E0 %g half-axis %d: sigma_v", E0, h);
            /* absolute error of a difference of logs: scale by 1 + |s| */
            cmt_close(im, what, sig[h], s[h], im->tol, 1.0);
            if (s[h] == 0.0) cmt_exact(im, "sigma_v of a flat field", sig[h], 0.0);
            R[h] = im->validity_radius(E0, Ed, delta, eps, rmin, rmax);
            CMT_FINITE(im, "radius", R[h]);
            if (!(R[h] >= delta * (1 - 4 * im->ulp) && R[h] <= rmax))
                fail_msg("[%s] radius %g outside [delta, r_max]", im->prec, R[h]);
            /* Eq. 7 at distances up to the radius */
            for (int j = 0; j <= 16; j++) {
                double x = R[h] * j / 16.0;
                double want = E0 * exp(-s[h] * x);
                snprintf(what, sizeof what, "E0 %g half-axis %d: E(%g)", E0, h, x);
                CMT_REL(im, what, im->extrapolate(E0, sig[h], x), want);
                snprintf(what, sizeof what, "E0 %g half-axis %d: ln E(%g)", E0, h, x);
                cmt_close(im, what, im->log_extrapolate(E0, sig[h], x), log(want), im->tol,
                          1.0);
                /* the same with the point on the axis, through Eq. 8 (other sigmas
                   deliberately different): on an axis sigma_interp is that axis's */
                double p[3] = {0, 0, 0};
                p[h / 2] = (h % 2) ? -x : x;
                double sx = sig[0 + (p[0] < 0)], sy = sig[2 + (p[1] < 0)],
                       sz = sig[4 + (p[2] < 0)];
                if (x > 0) {
                    snprintf(what, sizeof what, "E0 %g half-axis %d: octant E(%g)", E0, h, x);
                    CMT_REL(im, what,
                            im->irradiance_from_ln(im->log_extrapolate_octant(
                                E0, sx, sy, sz, p[0], p[1], p[2])),
                            want);
                }
            }
        }
        /* Eq. 7 + 8 with three equal sigmas: E0 exp(-s (|x| + |y| + |z|)) anywhere in
           the octant (the distance of Eq. 7 is length1, see cache_math.glsl) */
        const double sc[3] = {0.4, -0.25, 1.5};
        uint64_t rng = 12345u + (uint64_t)k;
        for (int c = 0; c < 3; c++) {
            double Ed = E0 * exp(-sc[c] * delta);
            double sv = im->sigma_v(E0, Ed, delta);
            double Rc = im->validity_radius(E0, Ed, delta, eps, rmin, rmax);
            for (int t = 0; t < 200; t++) {
                double u[3], n2 = 0;
                for (int i = 0; i < 3; i++) {
                    u[i] = 2 * cmt_rand01(&rng) - 1;
                    n2 += u[i] * u[i];
                }
                double rr = Rc * cmt_rand01(&rng) / sqrt(n2 > 1e-12 ? n2 : 1e-12);
                double p[3] = {u[0] * rr, u[1] * rr, u[2] * rr};
                double dist = fabs(p[0]) + fabs(p[1]) + fabs(p[2]);
                double want = E0 * exp(-sc[c] * dist);
                snprintf(what, sizeof what, "E0 %g equal sigma %g: octant E at |x| %g", E0,
                         sc[c], dist);
                CMT_REL(im, what,
                        im->irradiance_from_ln(
                            im->log_extrapolate_octant(E0, sv, sv, sv, p[0], p[1], p[2])),
                        want);
                snprintf(what, sizeof what, "equal sigma %g: sigma_interp", sc[c]);
                cmt_close(im, what, im->sigma_interp(sv, sv, sv, p[0], p[1], p[2]), sc[c],
                          im->tol, 1.0);
            }
        }
    }
    /* A log-linear field with a different sigma on each of the six half-axes (a light
       front crossing the entry obliquely): Eq. 6 on the six offset points, then Eq. 7 + 8
       reproduce it exactly at random points of every octant. */
    {
        const double E0 = 2.5, delta = 0.5, s6[6] = {0.7, -0.7, 0.2, -0.2, -1.3, 1.3};
        double sig[6];
        for (int h = 0; h < 6; h++) sig[h] = im->sigma_v(E0, E0 * exp(-s6[h] * delta), delta);
        uint64_t rng = 777;
        for (int t = 0; t < 200; t++) {
            double p[3];
            for (int i = 0; i < 3; i++) p[i] = 6 * (cmt_rand01(&rng) - 0.5);
            int hx = p[0] < 0, hy = 2 + (p[1] < 0), hz = 4 + (p[2] < 0);
            double want = E0 * exp(-(s6[hx] * fabs(p[0]) + s6[hy] * fabs(p[1]) + s6[hz] * fabs(p[2])));
            snprintf(what, sizeof what, "log-linear field at (%g, %g, %g)", p[0], p[1], p[2]);
            CMT_REL(im, what,
                    im->irradiance_from_ln(im->log_extrapolate_octant(E0, sig[hx], sig[hy], sig[hz], p[0], p[1], p[2])),
                    want);
        }
    }
    /* Eq. 8 with different sigmas against the formula, signs of coordinates ignored */
    const double q[4][3] = {{1, 2, 3}, {-1, 0.5, -4}, {0, -2, 0}, {1e-3, 1e3, -7}};
    for (int t = 0; t < 4; t++) {
        double a = fabs(q[t][0]), b = fabs(q[t][1]), c = fabs(q[t][2]);
        double want = (0.3 * a - 1.1 * b + 2.0 * c) / (a + b + c);
        snprintf(what, sizeof what, "Eq. 8 at (%g, %g, %g)", q[t][0], q[t][1], q[t][2]);
        cmt_close(im, what, im->sigma_interp(0.3, -1.1, 2.0, q[t][0], q[t][1], q[t][2]), want,
                  im->tol, 1.0);
    }
    /* centre: the mean of the three */
    cmt_close(im, "Eq. 8 at the centre", im->sigma_interp(0.3, -1.1, 2.0, 0, 0, 0),
              (0.3 - 1.1 + 2.0) / 3, im->tol, 1.0);
    cmt_close(im, "Eq. 8 at 1e-35 from the centre", im->sigma_interp(0.3, -1.1, 2.0, 1e-35, 0, 0),
              (0.3 - 1.1 + 2.0) / 3, im->tol, 1.0);
}

/* ---- 2. validity radius: Eq. 9, 10 and Fig. 4 --------------------------------------- */

static void validity_radius(const cmt_impl *im) {
    const double delta = 2.0;
    const double lo = 1e-12, hi = 1e12;   /* no clamping */
    const double eps_list[3] = {0.1, 0.01, 0.5};
    const double s_list[8] = {0.7, -0.3, 1e-3, -1e-3, 2.5, -2.5, 10.0, -20.0};
    const double E0s[3] = {1.0, 2e-6, 4e3};
    char what[160];
    for (int ie = 0; ie < 3; ie++)
        for (int is = 0; is < 8; is++)
            for (int k = 0; k < 3; k++) {
                double eps = eps_list[ie], s = s_list[is], E0 = E0s[k];
                double Ed = E0 * exp(-s * delta);
                double sv = im->sigma_v(E0, Ed, delta);
                double R = im->validity_radius(E0, Ed, delta, eps, lo, hi);
                /* the defining property: E(R) = (1 + eps) E_delta if E0 <= E_delta,
                   (1 - eps) E_delta otherwise, for the extrapolation and (the field being
                   exactly exponential) for the field itself */
                double ER = (E0 <= Ed ? 1 + eps : 1 - eps) * Ed;
                snprintf(what, sizeof what, "eps %g s %g E0 %g: extrapolation at R = %g", eps,
                         s, E0, R);
                CMT_REL(im, what, im->extrapolate(E0, sv, R), ER);
                /* the field itself at the radius of the exact sigma_v = s (with the
                   estimated one, float's error of sigma_v, ~1e-7 |ln E0| / delta, would
                   move R by L / s^2 times that) */
                double Rs = im->validity_radius_sigma(s, delta, eps, lo, hi);
                snprintf(what, sizeof what, "eps %g s %g E0 %g: field at R(s) = %g", eps, s,
                         E0, Rs);
                CMT_REL(im, what, E0 * exp(-s * Rs), ER);
                /* the literal Eq. 9 */
                double eq9 = delta * log(ER / E0) / log(Ed / E0);
                snprintf(what, sizeof what, "eps %g s %g E0 %g: R vs Eq. 9", eps, s, E0);
                /* the float radius inherits sigma_v's error amplified by L / (sigma R) */
                double tol = im->tol * (1 + 1 / (fabs(s) * delta));
                cmt_close(im, what, R, eq9, tol, 0);
                if (!(R >= delta)) fail_msg("[%s] R = %g < delta", im->prec, R);
                /* same from sigma_v directly */
                cmt_exact(im, "validity_radius vs validity_radius_sigma",
                          im->validity_radius_sigma(sv, delta, eps, lo, hi), R);
            }
    /* steeper fields give smaller radii (eps 0.1), both signs */
    double prev_d = INFINITY, prev_g = INFINITY;
    for (int j = 0; j <= 40; j++) {
        double s = 1e-4 * pow(10.0, j / 8.0);
        double Rd = im->validity_radius_sigma(s, delta, 0.1, lo, hi);
        double Rg = im->validity_radius_sigma(-s, delta, 0.1, lo, hi);
        if (!(Rd <= prev_d && Rg <= prev_g && Rd > Rg))
            fail_msg("[%s] radius not monotone in |sigma_v| at %g (%g, %g)", im->prec, s, Rd,
                     Rg);
        prev_d = Rd;
        prev_g = Rg;
    }
    /* Table 1 clamping (voxels): flat -> 16, steep -> just above delta, small delta and a
       steep field -> r_min */
    double rmin = CM_R_MIN_VOXELS, rmax = CM_R_MAX_VOXELS;
    cmt_exact(im, "flat field radius", im->validity_radius(3, 3, 2, 0.1, rmin, rmax),
              cmt_r(im, rmax));
    cmt_exact(im, "weak field radius (>= r_max)",
              im->validity_radius_sigma(1e-3, 2, 0.1, rmin, rmax), cmt_r(im, rmax));
    CMT_REL(im, "steep field radius", im->validity_radius_sigma(50, 2, 0.1, rmin, rmax),
            2 + -log(0.9) / 50);
    cmt_exact(im, "tiny delta, steep field: r_min",
              im->validity_radius_sigma(100, 1e-3, 0.1, rmin, rmax), cmt_r(im, rmin));
    cmt_exact(im, "delta >= r_max: r_max", im->validity_radius_sigma(5, 20, 0.1, rmin, rmax),
              cmt_r(im, rmax));
    cmt_exact(im, "eps 0, decaying: R = delta",
              im->validity_radius_sigma(0.5, 2, 0, rmin, rmax), 2);
    cmt_exact(im, "eps 0, flat: r_max", im->validity_radius_sigma(0, 2, 0, rmin, rmax),
              cmt_r(im, rmax));

    /* Fig. 4: the radius of the interpolated sigma_v */
    {
        double sx = 0.01, sy = 5.0, sz = -0.2, d = 2.0, eps = 0.1;
        /* on an axis: the axis radius */
        cmt_exact(im, "interp radius on +x",
                  im->interp_validity_radius(sx, sy, sz, 3, 0, 0, d, eps, rmin, rmax),
                  im->validity_radius_sigma(sx, d, eps, rmin, rmax));
        cmt_exact(im, "interp radius on -y",
                  im->interp_validity_radius(sx, sy, sz, 0, -1, 0, d, eps, rmin, rmax),
                  im->validity_radius_sigma(sy, d, eps, rmin, rmax));
        /* equal sigmas: the common radius everywhere */
        cmt_close(im, "interp radius, equal sigmas",
                  im->interp_validity_radius(0.8, 0.8, 0.8, 1, -2, 0.5, d, eps, rmin, rmax),
                  im->validity_radius_sigma(0.8, d, eps, rmin, rmax), im->tol, 0);
        /* a high ratio (Fig. 4 left): smaller than the ellipsoid in between the axes */
        double rx = im->validity_radius_sigma(sx, d, eps, rmin, rmax);
        double ry = im->validity_radius_sigma(sy, d, eps, rmin, rmax);
        double rz = im->validity_radius_sigma(sz, d, eps, rmin, rmax);
        double Ri = im->interp_validity_radius(sx, sy, sz, 1, 1, 0, d, eps, rmin, rmax);
        double Re = im->ellipsoid_radius(1, 1, 0, rx, ry, rz);
        if (!(Ri < Re)) fail_msg("[%s] Fig. 4: interp radius %g >= ellipsoid %g", im->prec, Ri, Re);
        /* its defining property along the direction u (|u|_1 = 1, since the radius is
           compared with the distance of Eq. 7, length1): ln E(R u) - ln E(delta u) =
           ln(1 -+ eps), the extrapolation itself at delta standing for E_delta */
        const double dirs[3][3] = {{1, 1, 0}, {0.3, -2, 1}, {-1, 0.2, -0.7}};
        for (int t = 0; t < 3; t++) {
            double n = fabs(dirs[t][0]) + fabs(dirs[t][1]) + fabs(dirs[t][2]);
            double u[3] = {dirs[t][0] / n, dirs[t][1] / n, dirs[t][2] / n};
            double s = im->sigma_interp(sx, sy, sz, u[0], u[1], u[2]);
            double R = im->interp_validity_radius(sx, sy, sz, u[0], u[1], u[2], d, eps, 1e-12,
                                                  1e12);
            double lR = im->log_extrapolate_octant(1.0, sx, sy, sz, R * u[0], R * u[1], R * u[2]);
            double ld = im->log_extrapolate_octant(1.0, sx, sy, sz, d * u[0], d * u[1], d * u[2]);
            snprintf(what, sizeof what, "Fig. 4 radius along (%g, %g, %g)", u[0], u[1], u[2]);
            cmt_close(im, what, exp(lR - ld), s <= 0 ? 1 + eps : 1 - eps, 10 * im->tol, 0);
        }
    }
}

/* ---- 3. ellipsoid radius, weights, log-space average ------------------------------- */

static void weights_and_average(const cmt_impl *im) {
    char what[160];
    const double rx = 3, ry = 1.5, rz = 8;
    /* axes */
    cmt_close(im, "r(x) on x", im->ellipsoid_radius(2, 0, 0, rx, ry, rz), rx, im->tol, 0);
    cmt_close(im, "r(x) on y", im->ellipsoid_radius(0, -0.1, 0, rx, ry, rz), ry, im->tol, 0);
    cmt_close(im, "r(x) on z", im->ellipsoid_radius(0, 0, 1e6, rx, ry, rz), rz, im->tol, 0);
    cmt_close(im, "r(x) on the diagonal of xy", im->ellipsoid_radius(1, 1, 0, rx, ry, rz),
              1 / sqrt(0.5 / (rx * rx) + 0.5 / (ry * ry)), im->tol, 0);
    cmt_exact(im, "r(x) at the centre: the smallest radius",
              im->ellipsoid_radius(0, 0, 0, rx, ry, rz), ry);
    /* consistency: rho = |x| / r(x); the point r(x) x / |x| lies on the boundary */
    uint64_t rng = 777;
    for (int t = 0; t < 300; t++) {
        double p[3];
        for (int i = 0; i < 3; i++) p[i] = 20 * (cmt_rand01(&rng) - 0.5);
        cmt_close(im, "length1", im->length1(p[0], p[1], p[2]), fabs(p[0]) + fabs(p[1]) + fabs(p[2]), im->tol, 0);
        double len = im->length3(p[0], p[1], p[2]);
        cmt_close(im, "length3", len, sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), im->tol, 0);
        double r = im->ellipsoid_radius(p[0], p[1], p[2], rx, ry, rz);
        double rho = im->ellipsoid_norm(p[0], p[1], p[2], rx, ry, rz);
        double want = sqrt(p[0] * p[0] / (rx * rx) + p[1] * p[1] / (ry * ry) +
                           p[2] * p[2] / (rz * rz));
        cmt_close(im, "ellipsoid_norm", rho, want, im->tol, 0);
        cmt_close(im, "|x| / r(x)", len / r, want, 4 * im->tol, 0);
        double b = r / len;
        cmt_close(im, "norm of the boundary point",
                  im->ellipsoid_norm(b * p[0], b * p[1], b * p[2], rx, ry, rz), 1, 4 * im->tol, 0);
        /* the two forms of the weight agree */
        cmt_abs(im, "weight(dist, r) vs weight_norm(rho)", im->weight(len, r),
                im->weight_norm(rho), 10 * im->tol);
    }
    /* weights: 1 at the centre, 0 on and beyond the edge, 1/2 halfway, monotone */
    cmt_exact(im, "w at the centre", im->weight(0, 2.5), 1);
    cmt_exact(im, "w on the edge", im->weight(2.5, 2.5), 0);
    cmt_exact(im, "w beyond the edge", im->weight(7, 2.5), 0);
    cmt_exact(im, "w halfway", im->weight_norm(0.5), 0.5);
    cmt_exact(im, "w(rho 0)", im->weight_norm(0), 1);
    cmt_exact(im, "w(rho 1)", im->weight_norm(1), 0);
    double prev = 2;
    for (int j = 0; j <= 1200; j++) {
        double rho = j / 1000.0;
        double w = im->weight_norm(rho);
        double d = rho < 1 ? 1 - rho : 0;
        snprintf(what, sizeof what, "w(%g)", rho);
        cmt_abs(im, what, w, 3 * d * d - 2 * d * d * d, 4 * im->ulp);
        if (!(w <= prev && w >= 0 && w <= 1))
            fail_msg("[%s] weight not monotone in [0, 1] at rho %g: %g after %g", im->prec, rho,
                     w, prev);
        prev = w;
    }
    /* log-space average: identical entries return their value, whatever the weights */
    const double Es[4] = {1.0, 3.25e-7, 812.5, 1e25};
    for (int k = 0; k < 4; k++) {
        double sw = 0, swl = 0;
        for (int j = 0; j < 9; j++) {
            double w = im->weight_norm(0.1 * j);
            sw += w;
            swl += im->weighted_ln(w, im->ln_irradiance(Es[k]));
        }
        snprintf(what, sizeof what, "average of identical %g", Es[k]);
        CMT_REL(im, what, im->log_average_finalize(swl, sw), Es[k]);
        if (!im->log_average_valid(sw)) fail_msg("[%s] %s: not a hit", im->prec, what);
    }
    /* two entries, equal weights: the geometric mean; weights 3:1 */
    CMT_REL(im, "geometric mean of 2 and 8",
            im->log_average_finalize(im->weighted_ln(0.5, log(2)) + im->weighted_ln(0.5, log(8)), 1.0),
            4.0);
    CMT_REL(im, "weighted 3:1 of 2 and 32",
            im->log_average_finalize(im->weighted_ln(0.75, log(2)) + im->weighted_ln(0.25, log(32)),
                                     1.0),
            pow(2, 0.75) * pow(32, 0.25));
    /* no hit: sum_w = 0, tiny, negative, NaN, inf -> 0 */
    const double bad_w[6] = {0, 1e-13, -1, NAN, INFINITY, -INFINITY};
    for (int j = 0; j < 6; j++) {
        snprintf(what, sizeof what, "finalize with sum_w %g", bad_w[j]);
        cmt_exact(im, what, im->log_average_finalize(3.0, bad_w[j]), 0);
        if (im->log_average_valid(bad_w[j]))
            fail_msg("[%s] sum_w %g counted as a hit", im->prec, bad_w[j]);
    }
    /* overflowing or NaN numerators */
    cmt_exact(im, "finalize(1e30, 1)", im->log_average_finalize(1e30, 1),
              im->irradiance_from_ln(CM_LN_E_MAX));
    cmt_exact(im, "finalize(-1e30, 1e-6)", im->log_average_finalize(-1e30, 1e-6), 0);
    cmt_exact(im, "finalize(NaN, 1)", im->log_average_finalize(NAN, 1), 0);
    cmt_exact(im, "finalize(-inf, 1)", im->log_average_finalize(-INFINITY, 1), 0);
    CMT_FINITE(im, "finalize(+inf, 1)", im->log_average_finalize(INFINITY, 1));
    /* weighted_ln sanitizes: weight clamped to [0, 1], NaN -> 0 */
    cmt_exact(im, "weighted_ln(NaN, 5)", im->weighted_ln(NAN, 5), 0);
    cmt_exact(im, "weighted_ln(2, 5)", im->weighted_ln(2, 5), 5);
    cmt_exact(im, "weighted_ln(-1, 5)", im->weighted_ln(-1, 5), 0);
    cmt_exact(im, "weighted_ln(1, NaN)", im->weighted_ln(1, NAN), cmt_r(im, CM_LN_E_MIN));
}

/* ---- 4. Fig. 6 radius reduction ---------------------------------------------------- */

static void radius_reduction(const cmt_impl *im) {
    const double rx = 3, ry = 1.5, rz = 8, rmin = 0.01;
    uint64_t rng = 4242;
    char what[160];
    for (int t = 0; t < 300; t++) {
        double p[3];
        for (int i = 0; i < 3; i++) p[i] = 2 * cmt_rand01(&rng) - 1;
        double rho0 = sqrt(p[0] * p[0] / (rx * rx) + p[1] * p[1] / (ry * ry) +
                           p[2] * p[2] / (rz * rz));
        double f = im->reduce_factor(p[0], p[1], p[2], rx, ry, rz);
        double nx = im->reduced_radius(rx, f, rmin), ny = im->reduced_radius(ry, f, rmin),
               nz = im->reduced_radius(rz, f, rmin);
        if (rho0 >= 1) {
            cmt_exact(im, "factor for a point outside", f, 1);
            cmt_exact(im, "unchanged radius", nx, rx);
            continue;
        }
        snprintf(what, sizeof what, "factor at rho %g", rho0);
        cmt_close(im, what, f, rho0 * (1 - 1e-4), 4 * im->tol, 0);
        if (nx > rmin && ny > rmin && nz > rmin) {
            /* common factor: the shape is kept */
            cmt_close(im, "ratio x/y kept", nx / ny, rx / ry, 4 * im->tol, 0);
            cmt_close(im, "ratio x/z kept", nx / nz, rx / rz, 4 * im->tol, 0);
            /* the event ends just outside: rho' = 1 / (1 - 1e-4), weight 0 */
            double rho1 = im->ellipsoid_norm(p[0], p[1], p[2], nx, ny, nz);
            snprintf(what, sizeof what, "event's rho after the reduction (rho0 %g)", rho0);
            cmt_close(im, what, rho1, 1 / (1 - 1e-4), 8 * im->tol, 0);
            if (!(rho1 > 1)) fail_msg("[%s] event still inside: rho %g", im->prec, rho1);
            cmt_exact(im, "weight of the event after the reduction",
                      im->weight(im->length3(p[0], p[1], p[2]),
                                 im->ellipsoid_radius(p[0], p[1], p[2], nx, ny, nz)),
                      0);
        }
        if (!(nx <= rx && ny <= ry && nz <= rz && nx >= cmt_r(im, rmin) * (1 - im->ulp)))
            fail_msg("[%s] reduced radii (%g %g %g) not in [r_min, r]", im->prec, nx, ny, nz);
    }
    /* the event at the centre: every radius -> r_min */
    double f0 = im->reduce_factor(0, 0, 0, rx, ry, rz);
    cmt_exact(im, "factor at the centre", f0, 0);
    cmt_exact(im, "radius after an event at the centre", im->reduced_radius(rx, f0, rmin),
              cmt_r(im, rmin));
    /* never grows: a radius already below r_min stays */
    cmt_exact(im, "radius below r_min", im->reduced_radius(0.005, 0.5, rmin), cmt_r(im, 0.005));
    /* NaN coordinates: far away, no change; NaN factor: no change */
    cmt_exact(im, "factor for a NaN event", im->reduce_factor(NAN, 0, 0, rx, ry, rz), 1);
    cmt_exact(im, "radius with a NaN factor", im->reduced_radius(rx, NAN, rmin), rx);
}

/* ---- 5. degenerate inputs ------------------------------------------------------------ */

static void degenerate(const cmt_impl *im) {
    const double LNMIN = cmt_r(im, CM_LN_E_MIN), LNMAX = cmt_r(im, CM_LN_E_MAX);
    const double rmin = CM_R_MIN_VOXELS, rmax = CM_R_MAX_VOXELS, eps = CM_EPS;
    const double L_up = log(1 + eps), L_dn = -log(1 - eps);
    char what[160];

    /* E0 = 0 and E_delta = 0, both 0, equal */
    cmt_exact(im, "sigma_v(0, 0)", im->sigma_v(0, 0, 2), 0);
    cmt_exact(im, "radius(0, 0)", im->validity_radius(0, 0, 2, eps, rmin, rmax), cmt_r(im, rmax));
    cmt_exact(im, "sigma_v(5, 5)", im->sigma_v(5, 5, 2), 0);
    cmt_exact(im, "radius(5, 5)", im->validity_radius(5, 5, 2, eps, rmin, rmax), cmt_r(im, rmax));
    {   /* E0 = 0 < E_delta = 1: growing from the floor, through E_delta at delta */
        double s = im->sigma_v(0, 1, 2);
        cmt_exact(im, "sigma_v(0, 1)", s, LNMIN / 2);
        cmt_exact(im, "E(0) from E0 = 0", im->extrapolate(0, s, 0), 0);
        cmt_exact(im, "ln E(0) from E0 = 0", im->log_extrapolate(0, s, 0), LNMIN);
        cmt_close(im, "E(delta) from E0 = 0", im->extrapolate(0, s, 2), 1, 100 * im->tol, 0);
        cmt_close(im, "radius(0, 1)", im->validity_radius(0, 1, 2, eps, 1e-12, 1e12),
                  2 + L_up / (-LNMIN / 2), im->tol, 0);
    }
    {   /* E0 = 1 > E_delta = 0: decaying to the code for 0 at delta */
        double s = im->sigma_v(1, 0, 2);
        cmt_exact(im, "sigma_v(1, 0)", s, -LNMIN / 2);
        cmt_exact(im, "E(delta) with E_delta = 0", im->extrapolate(1, s, 2), 0);
        cmt_exact(im, "E(5) with E_delta = 0", im->extrapolate(1, s, 5), 0);
        cmt_close(im, "radius(1, 0)", im->validity_radius(1, 0, 2, eps, 1e-12, 1e12),
                  2 + L_dn / (-LNMIN / 2), im->tol, 0);
    }
    /* ratios 1e-30 and 1e30 (irradiances inside (1e-30, 1e30)) */
    {
        double s = im->sigma_v(1e10, 1e-20, 2);
        cmt_close(im, "sigma_v for ratio 1e-30", s, log(1e30) / 2, im->tol, 0);
        CMT_REL(im, "E(delta) for ratio 1e-30", im->extrapolate(1e10, s, 2), 1e-20);
        cmt_close(im, "radius for ratio 1e-30", im->validity_radius(1e10, 1e-20, 2, eps, 1e-12, 1e12),
                  2 + L_dn / (log(1e30) / 2), im->tol, 0);
        s = im->sigma_v(1e-20, 1e10, 2);
        cmt_close(im, "sigma_v for ratio 1e30", s, -log(1e30) / 2, im->tol, 0);
        CMT_REL(im, "E(delta) for ratio 1e30", im->extrapolate(1e-20, s, 2), 1e10);
        /* at the bounds: 1 -> 1e30 and 1 -> 1e-30 (the latter is the code for 0) */
        cmt_exact(im, "sigma_v(1, 1e30)", im->sigma_v(1, 1e30, 2), -LNMAX / 2);
        cmt_exact(im, "sigma_v(1, 1e-30)", im->sigma_v(1, 1e-30, 2), -LNMIN / 2);
        cmt_exact(im, "sigma_v(1e-30, 1e30)", im->sigma_v(1e-30, 1e30, 2), (LNMIN - LNMAX) / 2);
        /* beyond the bounds: clamped */
        cmt_exact(im, "sigma_v(1e-40, 1e35)", im->sigma_v(1e-40, 1e35, 2), (LNMIN - LNMAX) / 2);
    }
    /* delta 1e-20 (and 0, negative, NaN): delta is taken as 1e-12 */
    {
        const double bad_d[4] = {1e-20, 0, -1, NAN};
        for (int j = 0; j < 4; j++) {
            double s = im->sigma_v(1, exp(-1), bad_d[j]);
            snprintf(what, sizeof what, "sigma_v with delta %g", bad_d[j]);
            cmt_close(im, what, s, 1 / 1e-12, im->tol, 0);
            snprintf(what, sizeof what, "radius with delta %g", bad_d[j]);
            cmt_exact(im, what, im->validity_radius(1, exp(-1), bad_d[j], eps, rmin, rmax),
                      cmt_r(im, rmin));
            snprintf(what, sizeof what, "E(16) with delta %g", bad_d[j]);
            cmt_exact(im, what, im->extrapolate(1, s, 16), 0);
            snprintf(what, sizeof what, "E(0) with delta %g", bad_d[j]);
            cmt_exact(im, what, im->extrapolate(1, s, 0), 1);
        }
        /* delta inf -> 1e12 >= r_max: r_max; sigma ~ 1e-12 */
        cmt_exact(im, "radius with delta inf", im->validity_radius(1, 0.5, INFINITY, eps, rmin, rmax),
                  cmt_r(im, rmax));
        cmt_close(im, "sigma_v with delta inf", im->sigma_v(1, exp(-1), INFINITY), 1e-12, im->tol, 0);
    }
    /* NaN and inf irradiances: NaN/negative -> 0, +inf -> 1e30 */
    cmt_exact(im, "ln_irradiance(NaN)", im->ln_irradiance(NAN), LNMIN);
    cmt_exact(im, "ln_irradiance(-3)", im->ln_irradiance(-3), LNMIN);
    cmt_exact(im, "ln_irradiance(-inf)", im->ln_irradiance(-INFINITY), LNMIN);
    cmt_exact(im, "ln_irradiance(inf)", im->ln_irradiance(INFINITY), LNMAX);
    cmt_exact(im, "ln_irradiance(1e-30)", im->ln_irradiance(1e-30), LNMIN);
    cmt_exact(im, "irradiance_from_ln(code for 0)", im->irradiance_from_ln(LNMIN), 0);
    cmt_exact(im, "irradiance_from_ln(NaN)", im->irradiance_from_ln(NAN), 0);
    cmt_exact(im, "irradiance_from_ln(-inf)", im->irradiance_from_ln(-INFINITY), 0);
    cmt_close(im, "irradiance_from_ln(+inf)", im->irradiance_from_ln(INFINITY), 1e30, 1e-6, 0);
    cmt_close(im, "irradiance_from_ln(1000)", im->irradiance_from_ln(1000), 1e30, 1e-6, 0);
    cmt_exact(im, "sigma_v(NaN, 1)", im->sigma_v(NAN, 1, 2), LNMIN / 2);
    cmt_exact(im, "sigma_v(1, NaN)", im->sigma_v(1, NAN, 2), -LNMIN / 2);
    cmt_exact(im, "sigma_v(inf, 1)", im->sigma_v(INFINITY, 1, 2), LNMAX / 2);
    cmt_exact(im, "sigma_v(NaN, NaN)", im->sigma_v(NAN, NAN, 2), 0);
    /* NaN sigma, eps, distance */
    cmt_exact(im, "radius with sigma NaN: delta", im->validity_radius_sigma(NAN, 2, eps, rmin, rmax), 2);
    cmt_exact(im, "radius with sigma inf: delta", im->validity_radius_sigma(INFINITY, 2, eps, rmin, rmax), 2);
    cmt_exact(im, "radius with sigma NaN, delta < r_min", im->validity_radius_sigma(NAN, 1e-5, eps, rmin, rmax),
              cmt_r(im, rmin));
    cmt_exact(im, "radius with eps NaN", im->validity_radius_sigma(0.5, 2, NAN, rmin, rmax), 2);
    cmt_exact(im, "radius with eps NaN, flat", im->validity_radius_sigma(0, 2, NAN, rmin, rmax), cmt_r(im, rmax));
    cmt_exact(im, "radius with r_max NaN", im->validity_radius_sigma(0, 2, eps, rmin, NAN), cmt_r(im, rmin));
    /* r_min NaN -> 1e-12: R = delta + L / sigma below Table 1's r_min is kept */
    cmt_close(im, "radius with r_min NaN", im->validity_radius_sigma(100, 1e-3, eps, NAN, rmax),
              1e-3 + L_dn / 100, im->tol, 0);
    cmt_exact(im, "ln_extrapolate at a NaN distance, decaying", im->ln_extrapolate(1.5, 0.5, NAN), LNMIN);
    cmt_exact(im, "ln_extrapolate at a NaN distance, growing", im->ln_extrapolate(1.5, -0.5, NAN), LNMAX);
    cmt_exact(im, "ln_extrapolate with sigma NaN", im->ln_extrapolate(1.5, NAN, 3), 1.5);
    cmt_exact(im, "ln_extrapolate with ln E0 NaN", im->ln_extrapolate(NAN, 0, 3), LNMIN);
    cmt_exact(im, "sigma_interp with a NaN sigma", im->sigma_interp(NAN, 1, 1, 1, 1, 0), 0.5);

    /* zero and infinite radii */
    cmt_exact(im, "r(x) with a zero radius", im->ellipsoid_radius(1, 0, 0, 0, 1, 1), cmt_r(im, 1e-12));
    cmt_exact(im, "w with a zero radius", im->weight(1, 0), 0);
    cmt_exact(im, "w at the centre with a zero radius", im->weight(0, 0), 1);
    cmt_exact(im, "r(x) with infinite radii", im->ellipsoid_radius(1, 1, 1, INFINITY, INFINITY, INFINITY),
              cmt_r(im, 1e12));
    cmt_abs(im, "w with infinite radii",
            im->weight_norm(im->ellipsoid_norm(1, 1, 1, INFINITY, INFINITY, INFINITY)), 1,
            10 * im->ulp);
    cmt_exact(im, "r(x) with NaN radius", im->ellipsoid_radius(1, 0, 0, NAN, 1, 1), cmt_r(im, 1e-12));
    cmt_exact(im, "w of a NaN point", im->weight_norm(im->ellipsoid_norm(NAN, 0, 0, 1, 1, 1)), 0);
    cmt_exact(im, "w(NaN, 1)", im->weight(NAN, 1), 0);
    cmt_exact(im, "w_norm(NaN)", im->weight_norm(NAN), 0);

    /* a fully shadowed entry: all seven irradiances 0 */
    {
        double sig[6], R[6];
        for (int h = 0; h < 6; h++) {
            sig[h] = im->sigma_v(0, 0, 2);
            R[h] = im->validity_radius(0, 0, 2, eps, rmin, rmax);
            cmt_exact(im, "shadowed sigma_v", sig[h], 0);
            cmt_exact(im, "shadowed radius", R[h], cmt_r(im, rmax));
        }
        uint64_t rng = 99;
        double sw = 0, swl = 0;
        for (int t = 0; t < 200; t++) {
            double p[3];
            for (int i = 0; i < 3; i++) p[i] = 30 * (cmt_rand01(&rng) - 0.5);
            double sx = sig[0 + (p[0] < 0)], sy = sig[2 + (p[1] < 0)], sz = sig[4 + (p[2] < 0)];
            double l = im->log_extrapolate_octant(0, sx, sy, sz, p[0], p[1], p[2]);
            cmt_exact(im, "shadowed ln E", l, LNMIN);
            cmt_exact(im, "shadowed E", im->irradiance_from_ln(l), 0);
            double r = im->ellipsoid_radius(p[0], p[1], p[2], R[0 + (p[0] < 0)],
                                            R[2 + (p[1] < 0)], R[4 + (p[2] < 0)]);
            double w = im->weight(im->length3(p[0], p[1], p[2]), r);
            sw += w;
            swl += im->weighted_ln(w, l);
        }
        cmt_exact(im, "shadowed average", im->log_average_finalize(swl, sw), 0);
        /* next to a lit entry: the geometric mean is dragged to ~0, not dropped */
        double E = im->log_average_finalize(im->weighted_ln(0.5, LNMIN) + im->weighted_ln(0.5, 0), 1);
        cmt_close(im, "shadowed + lit (E 1), equal weights", E, 1e-15, 1e-5, 0);
    }

    /* every function, every argument from a list of specials: finite outputs within
       their documented ranges */
    const double sp[] = {0,     -0.0,  1e-45, 1e-38, 1e-30,    1e-20,     1e-12, 0.01,
                         0.5,   1,     2,     16,    1e12,     1e20,      1e30,  1e38,
                         -1e-30, -1,   -16,   -1e30, INFINITY, -INFINITY, NAN};
    const int ns = (int)(sizeof sp / sizeof sp[0]);
    uint64_t rng = 2024;
#define CMT_PICK sp[(int)(cmt_rand01(&rng) * ns) % ns]
    for (int t = 0; t < 20000; t++) {
        double a = CMT_PICK, b = CMT_PICK, c = CMT_PICK, d = CMT_PICK, e = CMT_PICK;
        double f = CMT_PICK, g = CMT_PICK, h = CMT_PICK, i = CMT_PICK, j = CMT_PICK;
        double v;
#define CMT_IN(what, val, lo_, hi_)                                                     \
    do {                                                                                \
        v = (val);                                                                      \
        if (!isfinite(v) || v < (lo_) || v > (hi_))                                     \
            fail_msg("[%s] %s(%g, %g, %g, %g, %g, %g, %g, %g, %g, %g) = %g not in "     \
                     "[%g, %g]", im->prec, what, a, b, c, d, e, f, g, h, i, j, v,        \
                     (double)(lo_), (double)(hi_));                                     \
    } while (0)
        const double SMAX = CM_SIGMA_V_MAX * (1 + 1e-6), BIG = 1e300;
        CMT_IN("ln_irradiance", im->ln_irradiance(a), LNMIN, LNMAX);
        CMT_IN("irradiance_from_ln", im->irradiance_from_ln(a), 0, 1.0001e30);
        CMT_IN("san_ln", im->san_ln(a), LNMIN, LNMAX);
        CMT_IN("san_len", im->san_len(a), 0.99e-12, 1.0001e12);
        CMT_IN("san_coord", im->san_coord(a), 0, 1.0001e12);
        CMT_IN("san_sigma", im->san_sigma(a), -SMAX, SMAX);
        CMT_IN("half_axis", im->half_axis(a, 1, 2), 1, 2);
        CMT_IN("sigma_v_ln", im->sigma_v_ln(a, b, c), -SMAX, SMAX);
        CMT_IN("sigma_v", im->sigma_v(a, b, c), -SMAX, SMAX);
        CMT_IN("ln_extrapolate", im->ln_extrapolate(a, b, c), LNMIN, LNMAX);
        CMT_IN("log_extrapolate", im->log_extrapolate(a, b, c), LNMIN, LNMAX);
        CMT_IN("extrapolate", im->extrapolate(a, b, c), 0, 1.0001e30);
        CMT_IN("sigma_interp", im->sigma_interp(a, b, c, d, e, f), -SMAX, SMAX);
        CMT_IN("validity_radius_sigma", im->validity_radius_sigma(a, b, c, d, e), 0.99e-12, 1.0001e12);
        CMT_IN("validity_radius", im->validity_radius(a, b, c, d, e, f), 0.99e-12, 1.0001e12);
        CMT_IN("validity_radius (Table 1)", im->validity_radius(a, b, c, eps, rmin, rmax),
               cmt_r(im, rmin), cmt_r(im, rmax));
        CMT_IN("interp_validity_radius", im->interp_validity_radius(a, b, c, d, e, f, g, h, i, j),
               0.99e-12, 1.0001e12);
        CMT_IN("length3", im->length3(a, b, c), 0, 1.8e12);
        CMT_IN("length1", im->length1(a, b, c), 0, 3.1e12);
        CMT_IN("log_extrapolate_octant", im->log_extrapolate_octant(a, b, c, d, e, f, g), LNMIN, LNMAX);
        CMT_IN("ellipsoid_norm", im->ellipsoid_norm(a, b, c, d, e, f), 0, 1.8e24);
        CMT_IN("ellipsoid_radius", im->ellipsoid_radius(a, b, c, d, e, f), 0.99e-12, 1.0001e12);
        CMT_IN("weight_norm", im->weight_norm(a), 0, 1);
        CMT_IN("weight", im->weight(a, b), 0, 1);
        CMT_IN("weighted_ln", im->weighted_ln(a, b), LNMIN, LNMAX);
        CMT_IN("log_average_finalize", im->log_average_finalize(a, b), 0, 1.0001e30);
        CMT_IN("reduce_factor", im->reduce_factor(a, b, c, d, e, f), 0, 1);
        CMT_IN("reduced_radius", im->reduced_radius(a, b, c), 0.99e-12, 1.0001e12);
        CMT_IN("entry_delta", im->entry_delta(a, b), 0.99e-12, cmt_r(im, im->san_len(a)));
        CMT_IN("entry_r_min", im->entry_r_min(a, b, c), 0.99e-12, cmt_r(im, im->san_len(a)));
        (void)BIG;
#undef CMT_IN
    }
#undef CMT_PICK
}

/* The entry's own offset (entry_delta, entry_r_min): Table 1's Delta up to one extinction
   per voxel, two mean free paths beyond; and with it Eq. 6 and Eq. 9/10 on the field of a
   dense medium, E(x) = E0 exp(-sigma_t x) along the inward axis: the offset point sees
   E_delta / E0 = e^-2 (resolvable by Monte Carlo) instead of e^-(2 sigma_t) (e^-20000
   at 1e4 per voxel: below every float), sigma_v = sigma_t exactly, and the radius is
   where the extrapolation is eps below E_delta, clamped to the scaled minimum. */
static void entry_offset(const cmt_impl *im) {
    const double D = 2, rmin = 0.01, rmax = 16, eps = 0.1;
    const double sig[] = {0, 0.1, 0.5, 1, 1.0000001, 10, 100, 1e4, 1e5, 1e8};
    for (size_t i = 0; i < sizeof sig / sizeof sig[0]; i++) {
        double s = sig[i];
        char what[96];
        double de = im->entry_delta(D, s);
        double want = s <= 1 ? D : fmax(2 / s, D * 1e-5);
        snprintf(what, sizeof what, "entry_delta(2, %g)", s);
        CMT_REL(im, what, de, want);
        snprintf(what, sizeof what, "entry_r_min(0.01, delta_e, 2) at sigma %g", s);
        CMT_REL(im, what, im->entry_r_min(rmin, de, D), rmin * want / D);
        /* the maximum radius scales the same way: 16 voxels at <= 1 per voxel, 16
           offsets of two mean free paths beyond */
        snprintf(what, sizeof what, "entry_r_max(16, delta_e, 2) at sigma %g", s);
        CMT_REL(im, what, im->entry_r_max(rmax, de, D), rmax * want / D);
        /* beyond 1e5 per voxel the floor D 1e-5 makes E_delta / E0 smaller than e^-2 */
        if (s <= 0 || s > 1e5) continue;
        /* the exact field: E_delta = E0 exp(-sigma_t delta_e), E0 = 1 */
        double Ed = exp(-s * de);
        snprintf(what, sizeof what, "E_delta / E0 at sigma %g", s);
        cmt_close(im, what, Ed, s <= 1 ? exp(-s * D) : exp(-2.0), 1e-5, 0);
        snprintf(what, sizeof what, "Eq. 6 sigma_v at sigma %g", s);
        cmt_close(im, what, im->sigma_v(1, Ed, de), s, im == &cmt_impls[0] ? 1e-9 : 2e-4, 0);
        double rm = im->entry_r_min(rmin, de, D);
        double R = im->validity_radius(1, Ed, de, eps, rm, rmax);
        double Rexp = fmin(fmax(de - log(1 - eps) / s, rm), rmax);
        snprintf(what, sizeof what, "Eq. 9/10 radius at sigma %g", s);
        cmt_close(im, what, R, Rexp, im == &cmt_impls[0] ? 1e-9 : 2e-4, 0);
        if (Rexp > rm && Rexp < rmax) {   /* unclamped: the extrapolation there is (1 - eps) E_delta */
            snprintf(what, sizeof what, "E(R) / E_delta at sigma %g", s);
            cmt_close(im, what, im->extrapolate(1, s, R) / Ed, 1 - eps, im == &cmt_impls[0] ? 1e-9 : 1e-3, 0);
        }
    }
    /* rules */
    cmt_exact(im, "entry_delta, sigma NaN", im->entry_delta(D, NAN), D);
    cmt_exact(im, "entry_delta, sigma -1", im->entry_delta(D, -1), D);
    cmt_exact(im, "entry_delta, sigma inf", im->entry_delta(D, INFINITY), cmt_r(im, D * 1e-5));
    cmt_exact(im, "entry_delta, sigma 1e38", im->entry_delta(D, 1e38), cmt_r(im, D * 1e-5));
    cmt_exact(im, "entry_delta, delta NaN", im->entry_delta(NAN, 1), cmt_r(im, 1e-12));
    cmt_exact(im, "entry_r_min, delta_e > Delta", im->entry_r_min(rmin, 5, D), cmt_r(im, rmin));
    cmt_exact(im, "entry_r_min, NaN", im->entry_r_min(rmin, NAN, D), cmt_r(im, 1e-12));
    cmt_exact(im, "entry_r_max, delta_e > Delta", im->entry_r_max(rmax, 5, D), cmt_r(im, rmax));
    /* NaN delta_e reads as 1e-12 (san_len): r_max 1e-12 / Delta */
    CMT_REL(im, "entry_r_max, NaN", im->entry_r_max(rmax, NAN, D), rmax * 1e-12 / D);
}

/* ---- curvature limit of the radius (cache_math.glsl, curvature_radius) -------------- */

static void curvature_limit(const cmt_impl *im) {
    const double D = 2.0, eps = 0.1, L = log(1.1), lo = 1e-12, hi = 1e12;
    char what[160];
    /* every exponential field: ln E linear along the axis, m = 0 (in float up to the
       rounding of the logs, far below 8 L = 0.76): no limit */
    const double s_list[6] = {0.0, 0.7, -0.3, 5.0, -20.0, 1e-4};
    const double E0s[3] = {1.0, 2e-6, 4e3};
    for (int is = 0; is < 6; is++)
        for (int k = 0; k < 3; k++) {
            double s = s_list[is], l0 = log(E0s[k]);
            snprintf(what, sizeof what, "exponential field s %g E0 %g: no limit", s, E0s[k]);
            cmt_exact(im, what, im->curvature_radius(l0 + s * D, l0, l0 - s * D, D, eps, lo, hi),
                      cmt_r(im, hi));
        }
    /* quadratic ln E(x) = a - g x - kappa x^2 / 2: m = kappa D^2.  Above 8 L the radius r
       satisfies the defining property kappa r (D - r) / 2 = L (the largest error of the
       one-sided secant within r) and r < D / 2; at or below 8 L there is no limit */
    const double m_list[7] = {0.1, 0.7, 8 * log(1.1) * 1.0001, 1.0, 3.0, 30.0, 100.0};
    double prev = INFINITY;
    for (int j = 0; j < 7; j++)
        for (int sign = -1; sign <= 1; sign += 2) {
            double kappa = sign * m_list[j] / (D * D), a = 0.4, g = -1.3;
            double lp = a - g * D - kappa * D * D / 2, lm = a + g * D - kappa * D * D / 2;
            double r = im->curvature_radius(lm, a, lp, D, eps, lo, hi);
            snprintf(what, sizeof what, "quadratic field m %g sign %d", m_list[j], sign);
            if (m_list[j] <= 8 * L) { cmt_exact(im, what, r, cmt_r(im, hi)); continue; }
            /* the float logs carry ~1e-7 absolute error, m ~1e-7 relative; r's
               sensitivity grows near m = 8 L, where dr/dm diverges */
            double tol = im == &cmt_impls[0] ? 1e-9 : (m_list[j] < 0.8 ? 2e-2 : 1e-4);
            cmt_close(im, what, fabs(kappa) * r * (D - r) / 2, L, tol, 0);
            if (!(r < D / 2)) fail_msg("[%s] %s: r = %g not below delta / 2", im->prec, what, r);
            if (sign > 0) {
                if (!(r <= prev)) fail_msg("[%s] r not monotone in m at %g", im->prec, m_list[j]);
                prev = r;
            }
        }
    /* a lit face: the centre 0.5 mean free paths deep in a half-space of extinction 1
       under a sun along the axis, the outward point (D = 2) in air: ln E = -x inside,
       flat outside, m = 1.5 > 8 L: limited, below D / 2 */
    double r = im->curvature_radius(-2.5, -0.5, 0.0, D, eps, lo, hi);
    if (!(r < D / 2 && r > 0.1)) fail_msg("[%s] lit face: r = %g", im->prec, r);
    /* shadow edge: E_0 = 0 next to lit points, or a lit centre next to a zero: r_min */
    double rmin = CM_R_MIN_VOXELS, rmax = CM_R_MAX_VOXELS, z = CM_LN_E_MIN;
    cmt_exact(im, "E0 = 0, lit on one side", im->curvature_radius(z, z, 0.0, D, eps, rmin, rmax),
              cmt_r(im, rmin));
    cmt_exact(im, "E0 = 0, lit on both sides", im->curvature_radius(1.0, z, 0.0, D, eps, rmin, rmax),
              cmt_r(im, rmin));
    cmt_exact(im, "lit centre, zero on one side", im->curvature_radius(z, 0.0, -0.1, D, eps, rmin, rmax),
              cmt_r(im, rmin));
    /* a fully shadowed stretch (all three zero) is flat: no limit */
    cmt_exact(im, "all zero", im->curvature_radius(z, z, z, D, eps, rmin, rmax), cmt_r(im, rmax));
    /* rules: eps 0 -> any curvature gives r_min, NaN eps counts as 0; NaN logs are the
       code for 0; delta NaN -> 1e-12; every output finite and within [r_min, r_max] */
    cmt_exact(im, "eps 0, slight curvature", im->curvature_radius(0.01, 0.0, 0.01, D, 0.0, rmin, rmax),
              cmt_r(im, rmin));
    cmt_exact(im, "eps NaN", im->curvature_radius(0.01, 0.0, 0.01, D, NAN, rmin, rmax), cmt_r(im, rmin));
    cmt_exact(im, "NaN logs (all zero)", im->curvature_radius(NAN, NAN, NAN, D, eps, rmin, rmax),
              cmt_r(im, rmax));
    const double bad[6] = {NAN, INFINITY, -INFINITY, 0.0, 1e30, -1e30};
    for (int i = 0; i < 6; i++)
        for (int j = 0; j < 6; j++) {
            double v = im->curvature_radius(bad[i], 0.0, bad[j], bad[(i + j) % 6], bad[j], rmin, rmax);
            snprintf(what, sizeof what, "degenerate %d %d", i, j);
            CMT_FINITE(im, what, v);
            if (!(v >= cmt_r(im, rmin) && v <= cmt_r(im, rmax)))
                fail_msg("[%s] %s: %g outside [r_min, r_max]", im->prec, what, v);
        }
}

/* ---- the medium model of the normal axis (medium_fraction, medium_coord, medium_bound) */

static void medium_model(const cmt_impl *im) {
    const double D = 2.0, eps = 0.1, L = log(1.1);
    char what[160];
    /* f counts the probes in the medium (midpoints of eighths of D): all 8 in a medium of
       any extinction, homogeneous or not, give exactly 1, so Eq. 7 stays exact there and
       an axis that never leaves the medium is never stretched */
    cmt_exact(im, "all probes in the medium", im->medium_fraction(8.0), 1.0);
    cmt_exact(im, "more than all", im->medium_fraction(9.0), 1.0);
    for (int k = 1; k < 8; k++) {
        snprintf(what, sizeof what, "%d of 8 probes", k);
        cmt_exact(im, what, im->medium_fraction(k), cmt_r(im, k / 8.0));
    }
    for (double x = 0; x < 40; x += 0.37)
        cmt_exact(im, "f = 1: u = x", im->medium_coord(x, 1.0, D), cmt_r(im, x));
    /* a face at s: medium of extinction sigma on [0, s], air on (s, D]; a collimated light
       along the axis, from the air (lit face: E grows towards the face) or from the medium
       (unlit face: E falls towards it); flat in the air.  Closed form:
       ln E(x) = ln E0 +- sigma min(x, s).  The entry's estimates are exact; n_in counts the
       probes (k + 1/2) h < s, h = D / 8.  Faces on a probe boundary (s = k h) give f = s / D
       and the model is exact; between probes f = s' / D with |s' - s| <= h / 2, and the
       model's ln E is off by at most sigma h / 2 (at x = min(s, s'), linear elsewhere). */
    const double h = D / 8;
    const double svals[8] = {0.25, 0.75, 1.0, 1.75, 0.3, 0.8, 1.1, 1.7};
    for (int k = 0; k < 8; k++)
        for (int lit = 0; lit <= 1; lit++) {
            double s = svals[k], sigma = 1.3, lnE0 = log(0.02), sign = lit ? 1.0 : -1.0;
            double lnEd = lnE0 + sign * sigma * s;
            int n_in = 0;
            for (int p = 0; p < 8; p++) n_in += (p + 0.5) * h < s;
            double f = im->medium_fraction(n_in);
            int on_boundary = fabs(s / h - floor(s / h + 0.5)) < 1e-12;
            double tol = on_boundary ? (im == &cmt_impls[0] ? 1e-12 : 2e-6) : sigma * h / 2 + 2e-6;
            snprintf(what, sizeof what, "face at %g (%s): f", s, lit ? "lit" : "unlit");
            if (on_boundary) cmt_close(im, what, f, s / D, im->tol, 0);
            else if (!(fabs(f * D - s) <= h / 2 + 1e-12)) fail_msg("[%s] %s = %g", im->prec, what, f);
            double sv = im->sigma_v_ln(lnE0, lnEd, D);                    /* Eq. 6 */
            for (double x = 0; x <= D; x += D / 64) {
                double want = lnE0 + sign * sigma * fmin(x, s);
                double got = im->ln_extrapolate(lnE0, sv, im->medium_coord(x, f, D));
                snprintf(what, sizeof what, "face at %g (%s): ln E at x = %g", s, lit ? "lit" : "unlit", x);
                if (on_boundary) cmt_close(im, what, got, want, tol, 1.0);
                else if (!(fabs(got - want) <= tol)) fail_msg("[%s] %s: %g, closed form %g", im->prec, what, got, want);
            }
            /* beyond delta, out to Eq. 10's radius, the model stays within eps of E_delta */
            double R = im->validity_radius_sigma(sv, D, eps, CM_R_MIN_VOXELS, CM_R_MAX_VOXELS);
            for (double x = D; x <= R; x += (R - D) / 16 + 1e-9) {
                double got = im->ln_extrapolate(lnE0, sv, im->medium_coord(x, f, D));
                snprintf(what, sizeof what, "face at %g (%s): beyond delta x = %g", s, lit ? "lit" : "unlit", x);
                if (!(fabs(got - lnEd) <= (lit ? L : -log(1 - eps)) * (1 + 1e-5)))
                    fail_msg("[%s] %s: ln E %g, E_delta's %g", im->prec, what, got, lnEd);
            }
        }
    /* continuity and monotonicity of u in x and f; x <= u <= max(x, D) */
    for (double f = 0.125; f <= 1.0; f += 0.0625) {
        double prev = -1;
        for (double x = 0; x < 3 * D; x += D / 50) {
            double u = im->medium_coord(x, f, D);
            if (!(u >= x * (1 - 1e-6) && u <= fmax(x, D) * (1 + 1e-6) && u >= prev))
                fail_msg("[%s] medium_coord(%g, %g) = %g", im->prec, x, f, u);
            prev = u;
        }
    }
    /* the octant bound: any mix of axes stays within [min, max] of ln E0 and the three
       offset estimates, widened by L; inside that range it changes nothing */
    uint64_t rng = 77;
    for (int i = 0; i < 2000; i++) {
        double l0 = -20 + 30 * cmt_rand01(&rng), sx = -8 + 16 * cmt_rand01(&rng);
        double sy = -8 + 16 * cmt_rand01(&rng), sz = -8 + 16 * cmt_rand01(&rng);
        double l = -80 + 160 * cmt_rand01(&rng);
        double lo = fmin(fmin(l0, l0 - sx * D), fmin(l0 - sy * D, l0 - sz * D)) - L;
        double hi = fmax(fmax(l0, l0 - sx * D), fmax(l0 - sy * D, l0 - sz * D)) + L;
        double want = fmin(fmax(l, fmax(lo, CM_LN_E_MIN)), fmin(hi, CM_LN_E_MAX));
        cmt_close(im, "medium_bound", im->medium_bound(l, l0, sx, sy, sz, D, eps), want,
                  im == &cmt_impls[0] ? 1e-12 : 1e-5, 1.0);
    }
    /* rules */
    cmt_exact(im, "n_in NaN: the paper's secant", im->medium_fraction(NAN), 1.0);
    cmt_exact(im, "n_in inf", im->medium_fraction(INFINITY), 1.0);
    cmt_exact(im, "n_in -inf", im->medium_fraction(-INFINITY), cmt_r(im, 0.125));
    cmt_exact(im, "n_in 0: leaves at once", im->medium_fraction(0.0), cmt_r(im, 0.125));
    cmt_exact(im, "n_in negative", im->medium_fraction(-3.0), cmt_r(im, 0.125));
    cmt_exact(im, "n_in 0.5: clamped", im->medium_fraction(0.5), cmt_r(im, 0.125));
    cmt_exact(im, "f NaN: u = x", im->medium_coord(0.7, NAN, D), cmt_r(im, 0.7));
    cmt_close(im, "x NaN: far", im->medium_coord(NAN, 0.5, D), CM_LEN_MAX, 1e-6, 0);
    const double bad[7] = {NAN, INFINITY, -INFINITY, 0.0, 1e30, -1e30, 1e-30};
    for (int i = 0; i < 7; i++)
        for (int j = 0; j < 7; j++) {
            double v[3] = {im->medium_fraction(bad[i] + bad[j]),
                           im->medium_coord(bad[i], bad[j], bad[(i + 2 * j) % 7]),
                           im->medium_bound(bad[i], bad[j], bad[(i + j) % 7], 1.0, bad[(i + 3) % 7],
                                            bad[(j + 1) % 7], bad[(i + j + 2) % 7])};
            for (int k = 0; k < 3; k++) {
                snprintf(what, sizeof what, "degenerate %d %d (%d)", i, j, k);
                CMT_FINITE(im, what, v[k]);
            }
            if (!(v[0] >= cmt_r(im, 0.125) && v[0] <= 1.0)) fail_msg("[%s] f = %g", im->prec, v[0]);
            if (!(v[2] >= cmt_r(im, CM_LN_E_MIN) && v[2] <= cmt_r(im, CM_LN_E_MAX)))
                fail_msg("[%s] bound = %g", im->prec, v[2]);
        }
}

/* ---- Eq. 5's sample statistics (stat_merge_mean, stat_merge_m2, eq5_met) ------------- */

enum { CMT_THREADS = 128 };   /* cache_create.comp's workgroup */

/* The creation procedure's statistics, step for step: each of 128 threads takes `rounds`
   samples (sample r * 128 + t) by Welford's update, then the workgroup merges them
   pairwise at strides 64, 32, ..., 1.  Returns n, mean and m2 in out[3]. */
static void cmt_workgroup_stats(const cmt_impl *im, const double *x, int rounds, double out[3]) {
    double mean[CMT_THREADS], m2[CMT_THREADS], n[CMT_THREADS];
    for (int t = 0; t < CMT_THREADS; t++) {
        mean[t] = m2[t] = 0.0;
        for (int r = 0; r < rounds; r++) {
            double l = im->stat_sample(x[r * CMT_THREADS + t]);
            m2[t] = im->stat_merge_m2(r, mean[t], m2[t], 1.0, l, 0.0);
            mean[t] = im->stat_merge_mean(r, mean[t], 1.0, l);
        }
        n[t] = rounds;
    }
    for (int stride = CMT_THREADS / 2; stride > 0; stride >>= 1)
        for (int i = 0; i < stride; i++) {
            double m = im->stat_merge_mean(n[i], mean[i], n[i + stride], mean[i + stride]);
            m2[i] = im->stat_merge_m2(n[i], mean[i], m2[i], n[i + stride], mean[i + stride],
                                      m2[i + stride]);
            mean[i] = m;
            n[i] += n[i + stride];
        }
    out[0] = n[0]; out[1] = mean[0]; out[2] = m2[0];
}

/* The rule the creation procedure used before (float sums of l and l^2 per thread, summed
   over the workgroup, S^2 = (E[l^2] - E[l]^2) N / (N - 1), clamped at 0): the control that
   shows what the merge is for. */
static double cmt_textbook_variance_float(const double *x, int rounds) {
    float s[CMT_THREADS], q[CMT_THREADS];
    for (int t = 0; t < CMT_THREADS; t++) {
        s[t] = q[t] = 0.0f;
        for (int r = 0; r < rounds; r++) {
            float l = (float)x[r * CMT_THREADS + t];
            s[t] += l; q[t] += l * l;
        }
    }
    for (int stride = CMT_THREADS / 2; stride > 0; stride >>= 1)
        for (int i = 0; i < stride; i++) { s[i] += s[i + stride]; q[i] += q[i + stride]; }
    float N = (float)(rounds * CMT_THREADS), mean = s[0] / N;
    float var = q[0] / N - mean * mean;
    return (var > 0.0f ? var : 0.0f) * N / (N - 1.0f);
}

static void sample_statistics(const cmt_impl *im) {
    char what[160];
    const int rounds_list[3] = {1, 6, 64};       /* one round, the CPU cap, the GPU cap */
    const double spreads[4] = {0.3, 1e-2, 1e-4, 1e-6};   /* relative half-width of the samples */
    /* Merged S^2 against the exact S^2 of the same (rounded) samples, by precision and
       spread: double 1e-9; float 2e-4 down to 1e-4 of spread and 0.1 at 1e-6, where the
       samples differ by only a few float steps of 1.2e-7 and each deviation l - mean
       carries up to half a step of rounding (measured when written: float at most 3.7e-5
       and 3.4e-2, double 1.6e-11). */
    double *x = malloc(sizeof(double) * 64 * CMT_THREADS);
    assert_non_null(x);
    double worst_textbook = 0.0, worst_merge = 0.0;   /* textbook: relative; merge: of its bound */
    for (int ri = 0; ri < 3; ri++)
        for (int si = 0; si < 4; si++) {
            int rounds = rounds_list[ri], N = rounds * CMT_THREADS;
            uint64_t rng = 77u + 13u * (uint64_t)(ri * 4 + si);
            const double mu = 1.7;
            for (int i = 0; i < N; i++) {
                double v = mu * (1.0 + spreads[si] * (2.0 * tu_rand01(&rng) - 1.0));
                x[i] = cmt_r(im, v);
            }
            long double m = 0.0L, q = 0.0L;             /* exact reference: two passes */
            for (int i = 0; i < N; i++) m += x[i];
            m /= N;
            for (int i = 0; i < N; i++) q += ((long double)x[i] - m) * ((long double)x[i] - m);
            double s2_ref = (double)(q / (N - 1));
            double st[3];
            cmt_workgroup_stats(im, x, rounds, st);
            cmt_exact(im, "merged count", st[0], N);
            snprintf(what, sizeof what, "%d rounds, spread %g: mean", rounds, spreads[si]);
            cmt_close(im, what, st[1], (double)m, im == &cmt_impls[0] ? 1e-12 : 1e-6, 0);
            double tol = im == &cmt_impls[0] ? 1e-9 : (spreads[si] >= 1e-4 ? 2e-4 : 0.1);
            snprintf(what, sizeof what, "%d rounds, spread %g: S^2", rounds, spreads[si]);
            cmt_close(im, what, st[2] / (N - 1), s2_ref, tol, 0);
            double e_merge = fabs(st[2] / (N - 1) - s2_ref) / s2_ref / tol;
            if (e_merge > worst_merge) worst_merge = e_merge;
            if (im == &cmt_impls[1] && spreads[si] <= 1e-4) {
                double e = fabs(cmt_textbook_variance_float(x, rounds) - s2_ref) / s2_ref;
                if (e > worst_textbook) worst_textbook = e;
            }
        }
    print_message("    %s: merged S^2 within %.2g of its bound\n", im->prec, worst_merge);
    if (im == &cmt_impls[1]) {
        print_message("    float S^2 at spreads <= 1e-4: the textbook E[l^2] - E[l]^2 is off by up "
                      "to %.3g of S^2\n", worst_textbook);
        /* The control: the rounding that the merge avoids is real, at least 10x what the
           merge is allowed. */
        if (!(worst_textbook > 10 * 0.1)) fail_msg("the textbook formula's error %g: no control", worst_textbook);
    }
    free(x);

    /* Identical samples: S^2 exactly 0, so Eq. 5 holds at any gamma > 0. */
    double same[6 * CMT_THREADS], st[3];
    for (int i = 0; i < 6 * CMT_THREADS; i++) same[i] = cmt_r(im, 0.3183);
    cmt_workgroup_stats(im, same, 6, st);
    cmt_exact(im, "identical samples: m2", st[2], 0.0);
    cmt_exact(im, "identical samples: mean", st[1], cmt_r(im, 0.3183));
    if (!im->eq5_met(st[0], st[1], st[2], 1e-7)) fail_msg("[%s] identical samples fail Eq. 5", im->prec);

    /* Eq. 5's boundary: 1.96 sqrt(S^2 / n) = gamma / (gamma + 1) mean at m2 = m2_edge. */
    const double n = 768, mean = 2.0, gamma = 0.1;
    double h = gamma / (gamma + 1) * mean / 1.96;
    double m2_edge = h * h * n * (n - 1);
    if (!im->eq5_met(n, mean, 0.99 * m2_edge, gamma)) fail_msg("[%s] Eq. 5 inside the edge", im->prec);
    if (im->eq5_met(n, mean, 1.01 * m2_edge, gamma)) fail_msg("[%s] Eq. 5 outside the edge", im->prec);

    /* The rules. */
    if (!im->eq5_met(n, 0.0, 0.0, gamma)) fail_msg("[%s] a fully shadowed point must pass", im->prec);
    if (im->eq5_met(n, -1e-3, 0.0, gamma)) fail_msg("[%s] a negative mean passed", im->prec);
    if (im->eq5_met(1.0, mean, 0.0, gamma)) fail_msg("[%s] one sample passed", im->prec);
    if (im->eq5_met(NAN, mean, 0.0, gamma)) fail_msg("[%s] n NaN passed", im->prec);
    if (!im->eq5_met(n, mean, 0.0, NAN)) fail_msg("[%s] gamma NaN: no spread must pass", im->prec);
    if (im->eq5_met(n, mean, m2_edge, NAN)) fail_msg("[%s] gamma NaN: spread passed", im->prec);
    if (!im->eq5_met(n, mean, 0.99 * mean * mean / 3.8416 * n * (n - 1), INFINITY))
        fail_msg("[%s] gamma inf: the limit 1 of gamma / (gamma + 1)", im->prec);
    cmt_exact(im, "sample NaN", im->stat_sample(NAN), 0.0);
    cmt_exact(im, "sample +inf", im->stat_sample(INFINITY), cmt_r(im, CM_STAT_MAX));
    cmt_exact(im, "sample -inf", im->stat_sample(-INFINITY), -cmt_r(im, CM_STAT_MAX));
    cmt_exact(im, "sample 1e30", im->stat_sample(1e30), cmt_r(im, CM_STAT_MAX));
    cmt_exact(im, "merge of empty sets: mean", im->stat_merge_mean(0, 5, 0, 7), 0.0);
    cmt_exact(im, "merge of empty sets: m2", im->stat_merge_m2(0, 5, 1, 0, 7, 1), 0.0);
    cmt_exact(im, "merge with an empty set", im->stat_merge_mean(3, 5, 0, 7), 5.0);
    cmt_exact(im, "one sample each", im->stat_merge_m2(1, 1, 0, 1, 3, 0), 2.0);
    const double bad[8] = {NAN, INFINITY, -INFINITY, 0.0, 1e30, -1e30, 1e-30, 5e5};
    for (int i = 0; i < 8; i++)
        for (int j = 0; j < 8; j++) {
            double v[3] = {im->stat_merge_mean(bad[i], bad[j], bad[(i + j) % 8], bad[(i + 3) % 8]),
                           im->stat_merge_m2(bad[i], bad[j], bad[(i + 1) % 8], bad[(j + 2) % 8],
                                             bad[(i + j) % 8], bad[(i + 5) % 8]),
                           im->stat_count(bad[i] + bad[j])};
            for (int k = 0; k < 3; k++) {
                snprintf(what, sizeof what, "degenerate statistics %d %d (%d)", i, j, k);
                CMT_FINITE(im, what, v[k]);
            }
            if (!(v[1] >= 0.0 && v[1] <= cmt_r(im, CM_STAT_M2_MAX))) fail_msg("[%s] m2 = %g", im->prec, v[1]);
            (void)im->eq5_met(bad[i], bad[j], bad[(i + 1) % 8], bad[(j + 3) % 8]);
        }
    /* The largest merge the bounds allow stays finite in float: N_MAX samples split in
       halves at -MAX and +MAX, each half with the largest m2. */
    double big = im->stat_merge_m2(CM_STAT_N_MAX / 2, -CM_STAT_MAX, CM_STAT_M2_MAX,
                                   CM_STAT_N_MAX / 2, CM_STAT_MAX, CM_STAT_M2_MAX);
    CMT_FINITE(im, "largest merge", big);
}

/* ---- the cmocka tests ---------------------------------------------------------------- */

void test_cache_math_medium_model(void **state) {
    (void)state;
    for (int k = 0; k < 2; k++) medium_model(&cmt_impls[k]);
}

void test_cache_math_curvature_radius(void **state) {
    (void)state;
    for (int k = 0; k < 2; k++) curvature_limit(&cmt_impls[k]);
}


void test_cache_math_entry_offset(void **state) {
    (void)state;
    for (int k = 0; k < 2; k++) entry_offset(&cmt_impls[k]);
}

void test_cache_math_exponential_field(void **state) {
    (void)state;
    for (int k = 0; k < 2; k++) exponential_field(&cmt_impls[k]);
}

void test_cache_math_validity_radius(void **state) {
    (void)state;
    for (int k = 0; k < 2; k++) validity_radius(&cmt_impls[k]);
}

void test_cache_math_weights_and_average(void **state) {
    (void)state;
    for (int k = 0; k < 2; k++) weights_and_average(&cmt_impls[k]);
}

void test_cache_math_radius_reduction(void **state) {
    (void)state;
    for (int k = 0; k < 2; k++) radius_reduction(&cmt_impls[k]);
}

void test_cache_math_degenerate_inputs(void **state) {
    (void)state;
    for (int k = 0; k < 2; k++) degenerate(&cmt_impls[k]);
    print_message("    largest relative error in the checks at the base tolerance: "
                  "double %.2g, float %.2g\n",
                  cmt_max_rel[0], cmt_max_rel[1]);
}

void test_cache_math_sample_statistics(void **state) {
    (void)state;
    for (int k = 0; k < 2; k++) sample_statistics(&cmt_impls[k]);
}
