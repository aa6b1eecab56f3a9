/* test_stats.c - the suite's statistics: quantiles of the normal and Student-t
 * distributions, and the pooled check of every closed-form comparison.
 *
 * Pooling.  Each statistical comparison of a rendered mean with its closed form (or an
 * independent reference) registers its z = (measured - expected) / SE with tu_pool_add
 * (tu_check_mean does so itself).  A bias common to many tests, each too small to fail
 * its own bound, moves all those z the same way; test_stats_pooled_z, which runs last,
 * sees it in
 *   - the mean: Z = sum z / sqrt(K), N(0, 1) for K independent unbiased comparisons, and
 *   - the sum of squares: sum z^2 against the chi-square quantile with K degrees of
 *     freedom (Wilson-Hilferty),
 * both at the suite's z = 5 (two-sided p = 6e-7), and
 *   - the common relative bias b, weighted by precision: b = sum(r_i / s_i^2) /
 *     sum(1 / s_i^2), r_i = (measured - expected) / expected, s_i = SE / |expected|,
 *     with SE(b) = sum(1 / s_i^2)^(-1/2).  A renderer off by a factor 1 + b moves every
 *     r_i by b, and this is the most powerful test of that; the plain mean of z weighs
 *     a 0.06 % comparison like a 5 % one and dilutes it.
 * The SEs are upper bounds (the larger
 * of the analytic and the empirical one), so the z are if anything under-dispersed and
 * both checks are conservative.  Comparisons of the same pixels (another channel of the
 * same image, a quadrant inside an image already registered) are correlated: only the
 * first one over any pixel of an image counts.  A comparison that allows a systematic
 * error larger than a tenth of its SE (sys_rel in tu_check_mean) is not pooled: its
 * allowed offset, summed over many tests, would move Z by itself.
 */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* ---- quantiles ----------------------------------------------------------------------- */

double tu_normal_cdf(double z) { return 0.5 * erfc(-z / sqrt(2.0)); }

/* Upper tail 1 - Phi(z), accurate far out in the tail (erfc, not 1 - cdf). */
static double normal_upper(double z) { return 0.5 * erfc(z / sqrt(2.0)); }

double tu_normal_quantile(double p) {
    /* Bisection on the cdf: 200 halvings of [-40, 40] reach double precision; p outside
       (0, 1) gives the interval's end (never NaN). */
    double lo = -40, hi = 40;
    if (!(p > 0)) return lo;
    if (!(p < 1)) return hi;
    for (int i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        if (tu_normal_cdf(mid) < p) lo = mid; else hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* Regularized incomplete beta I_x(a, b) by its continued fraction (modified Lentz),
   using the symmetry I_x(a, b) = 1 - I_{1-x}(b, a) where the fraction converges slowly. */
static double beta_fraction(double x, double a, double b) {
    const double tiny = 1e-300;
    double c = 1, d = 1 - (a + b) * x / (a + 1);
    if (fabs(d) < tiny) d = tiny;
    d = 1 / d;
    double h = d;
    for (int m = 1; m <= 500; m++) {
        double m2 = 2.0 * m;
        double num = m * (b - m) * x / ((a + m2 - 1) * (a + m2));
        d = 1 + num * d; if (fabs(d) < tiny) d = tiny;
        c = 1 + num / c; if (fabs(c) < tiny) c = tiny;
        d = 1 / d; h *= d * c;
        num = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1));
        d = 1 + num * d; if (fabs(d) < tiny) d = tiny;
        c = 1 + num / c; if (fabs(c) < tiny) c = tiny;
        d = 1 / d;
        double del = d * c;
        h *= del;
        if (fabs(del - 1) < 1e-15) break;
    }
    return h;
}

static double incomplete_beta(double x, double a, double b) {
    if (x <= 0) return 0;
    if (x >= 1) return 1;
    double lbt = lgamma(a + b) - lgamma(a) - lgamma(b) + a * log(x) + b * log1p(-x);
    if (x < (a + 1) / (a + b + 2)) return exp(lbt) * beta_fraction(x, a, b) / a;
    return 1 - exp(lbt) * beta_fraction(1 - x, b, a) / b;
}

/* Upper tail P(T > t) of Student's t with nu degrees of freedom, t >= 0. */
static double student_upper(double t, double nu) {
    return 0.5 * incomplete_beta(nu / (nu + t * t), 0.5 * nu, 0.5);
}

double tu_student_quantile(double p, double nu) {
    /* The t with P(T <= t) = p, p in (0.5, 1): bisection on the upper tail, which is
       monotone; [0, 1e8] holds every quantile used (nu >= 1, p <= 1 - 1e-12). */
    double lo = 0, hi = 1e8, q = 1 - p;
    for (int i = 0; i < 300; i++) {
        double mid = 0.5 * (lo + hi);
        if (student_upper(mid, nu) > q) lo = mid; else hi = mid;
    }
    return 0.5 * (lo + hi);
}

double tu_student_as_z(double t, double nu) {
    /* The normal z with the same two-sided tail: Phi^-1 of the t's cdf, by the upper
       tail so that |t| of 50 with 3 dof still maps to a finite z. */
    double q = student_upper(fabs(t), nu);
    double lo = 0, hi = 40;
    for (int i = 0; i < 200; i++) {
        double mid = 0.5 * (lo + hi);
        if (normal_upper(mid) > q) lo = mid; else hi = mid;
    }
    return t < 0 ? -0.5 * (lo + hi) : 0.5 * (lo + hi);
}

double tu_chi2_quantile_upper(double k, double z) {
    /* Wilson-Hilferty: (X / k)^(1/3) is normal with mean 1 - 2 / (9k) and variance
       2 / (9k); relative error under 1 % for k >= 3 at z <= 5. */
    double v = 2.0 / (9.0 * k), c = 1 - v + z * sqrt(v);
    return k * c * c * c;
}

/* ---- the pool ------------------------------------------------------------------------- */

#define TU_POOL_MAX 8192
typedef struct tu_pool_entry {
    double z, r, s;         /* z; relative residual and relative SE (s 0: no relative) */
    const void *img;
    unsigned serial;
    uint32_t x0, y0, x1, y1;
} tu_pool_entry;
static tu_pool_entry tu_pool[TU_POOL_MAX];
static size_t tu_pool_n, tu_pool_skipped;

void tu_pool_add(const char *label, double measured, double expected, double se,
                 const void *img, unsigned serial, uint32_t x0, uint32_t y0, uint32_t x1,
                 uint32_t y1) {
    (void)label;
    /* Rule: a comparison without a positive finite SE, or with a non-finite value, has
       no z (it failed or passed on its own terms); it is not pooled. */
    if (!(se > 0) || !isfinite(se) || !isfinite(measured) || !isfinite(expected)) {
        tu_pool_skipped++;
        return;
    }
    for (size_t i = 0; i < tu_pool_n && img; i++) {
        const tu_pool_entry *e = &tu_pool[i];
        if (e->img == img && e->serial == serial && x0 < e->x1 && e->x0 < x1 && y0 < e->y1 &&
            e->y0 < y1) {
            tu_pool_skipped++;
            return;
        }
    }
    if (tu_pool_n == TU_POOL_MAX) { tu_pool_skipped++; return; }
    tu_pool_entry e = {(measured - expected) / se, 0, 0, img, serial, x0, y0, x1, y1};
    /* Rule: an expected value of 0 has no relative bias; it still counts in the z sums. */
    if (fabs(expected) > 0) {
        e.r = (measured - expected) / fabs(expected);
        e.s = se / fabs(expected);
    }
    tu_pool[tu_pool_n++] = e;
}

size_t tu_pool_count(void) { return tu_pool_n; }

typedef struct pool_summary {
    size_t K;
    double Z, sum_z2;       /* sum z / sqrt(K), sum z^2 */
    double b, se_b;         /* the common relative bias and its SE (se_b 0: none) */
} pool_summary;

/* Accumulated in long double: thousands of terms of very different weights. */
static pool_summary pool_stats(void) {
    long double s = 0, s2 = 0, wr = 0, w = 0;
    for (size_t i = 0; i < tu_pool_n; i++) {
        const tu_pool_entry *e = &tu_pool[i];
        s += e->z;
        s2 += (long double)e->z * e->z;
        if (e->s > 0) {
            long double wi = 1.0L / ((long double)e->s * e->s);
            w += wi;
            wr += wi * e->r;
        }
    }
    pool_summary p = {tu_pool_n, 0, (double)s2, 0, 0};
    if (p.K) p.Z = (double)(s / sqrtl((long double)p.K));
    if (w > 0) { p.b = (double)(wr / w); p.se_b = (double)(1.0L / sqrtl(w)); }
    return p;
}

/* ---- tests ------------------------------------------------------------------------------ */

/* The quantile functions against tabulated values (Abramowitz and Stegun 26.7 and
   26.2; chi-square from the same tables) to the table's digits. */
void test_stats_quantiles(void **state) {
    (void)state;
    struct { double p, nu, t; } t[] = {
        {0.975, 3, 3.182446}, {0.975, 15, 2.131450}, {0.995, 7, 3.499483},
        {0.9995, 3, 12.92398}, {0.975, 1, 12.70620}, {0.975, 1000, 1.962339},
    };
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++) {
        double q = tu_student_quantile(t[i].p, t[i].nu);
        print_message("    t quantile p %.4f nu %.0f: %.6f (table %.6f)\n", t[i].p, t[i].nu, q, t[i].t);
        assert_true(fabs(q - t[i].t) < 2e-5 * t[i].t);
        /* back to z: the t's own p as a normal quantile */
        double z = tu_student_as_z(q, t[i].nu);
        assert_true(fabs(z - tu_normal_quantile(t[i].p)) < 1e-6);
    }
    assert_true(fabs(tu_normal_quantile(0.975) - 1.959964) < 1e-6);
    assert_true(fabs(tu_normal_quantile(1 - 2.866516e-7) - 5.0) < 1e-5);
    /* chi-square upper quantiles, p = 0.001: k 10 -> 29.588, k 100 -> 149.449 */
    double z3 = tu_normal_quantile(0.999);
    assert_true(fabs(tu_chi2_quantile_upper(10, z3) - 29.588) < 0.01 * 29.588);
    assert_true(fabs(tu_chi2_quantile_upper(100, z3) - 149.449) < 0.002 * 149.449);
}

/* The pooled check over every comparison the run has registered (it runs last in
   TU_ALL_TESTS; a filtered run registers few and skips it, saying so).  Power: the
   common relative bias must be resolved to 0.5 % / 10, so that a renderer off by 0.5 %
   lands at least 10 SE(b) away from 0 and fails whatever the noise (5 of them for the
   noise, 5 for the bound). */
void test_stats_pooled_z(void **state) {
    (void)state;
    pool_summary p = pool_stats();
    if (p.K < 20) {
        print_message("    %zu pooled comparisons (a filtered run): too few to pool, skipped\n", p.K);
        skip();
    }
    double q = tu_chi2_quantile_upper((double)p.K, 5.0);
    double zb = p.se_b > 0 ? p.b / p.se_b : 0;
    print_message("    %zu comparisons pooled (%zu correlated, loose or without SE left out)\n"
                  "    Z = sum z / sqrt(K) = %+.3f (bound 5); sum z^2 = %.1f (chi-square K = %zu, "
                  "p 6e-7 quantile %.1f)\n"
                  "    common relative bias %+.5f %% +- %.5f %% (%+.2f SE, bound 5); a 0.5 %% bias "
                  "would be %.1f SE (power: at least 10)\n",
                  p.K, tu_pool_skipped, p.Z, p.sum_z2, p.K, q, 100 * p.b, 100 * p.se_b, zb,
                  p.se_b > 0 ? 0.005 / p.se_b : 0.0);
    if (!(p.se_b > 0) || 0.005 / p.se_b < 10)
        fail_msg("the pool cannot resolve a 0.5 %% common bias (SE %.4g %%)", 100 * p.se_b);
    if (!(fabs(p.Z) <= 5.0 && p.sum_z2 <= q && fabs(zb) <= 5.0))
        fail_msg("the pooled comparisons show a common bias or too much spread");
}
