/* test_phase.c - the Henyey-Greenstein phase function and its two-lobe mix, the formulas
 * at the end of shaders/sampling_math.glsl, compiled on the host in double (cm_) and in
 * float (cmf_, the shaders' precision) through reference/cache_math_host.h:
 *   - the density integrates to 1 over the sphere (quadrature in double);
 *   - the sampler inverts the CDF of that same density (quadrature), and the float
 *     sampler matches the double one to a few float spacings;
 *   - the sample mean of cos is g;
 *   - the histogram of the samples matches the density (chi-square over bins whose
 *     expected counts come from integrating the density, so sampler and density are
 *     tied);
 *   - the same for the two-lobe mix;
 *   - every function stays finite and in range for extreme and non-finite input.
 * All random numbers come from fixed seeds (splitmix64), so every run is identical.
 */
#include "test_util.h"

#include "reference/cache_math_host.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* The asymmetries of the single-lobe tests (the task's list): both signs, isotropic,
   moderate, strongly forward, and 0.999, whose peak in cos is ~5e-7 wide. */
static const double PH_G[] = {-0.99, -0.5, 0.0, 0.3, 0.9, 0.999};
#define N_PH_G (sizeof PH_G / sizeof PH_G[0])

/* One phase function: a single lobe (w = 0) or the mix; f = 1 evaluates and samples in
   float. */
typedef struct ph_case {
    double g, back_g, w;
    int f;
} ph_case;

/* The parameters the float code actually sees (its inputs rounded to float). */
static ph_case ph_as_used(ph_case c) {
    if (c.f) { c.g = (float)c.g; c.back_g = (float)c.back_g; c.w = (float)c.w; }
    return c;
}

/* The density of cos on [-1, 1]: 2 pi phase_eval, in the case's precision (cos rounded
   to float in float). */
static double ph_density(double c, void *user) {
    const ph_case *p = (const ph_case *)user;
    if (p->f) return 2.0 * M_PI * (double)cmf_phase_eval((float)p->g, (float)p->back_g, (float)p->w, (float)c);
    return 2.0 * M_PI * cm_phase_eval(p->g, p->back_g, p->w, c);
}

/* The same in double at the float case's parameters: the exact density the float
   sampler is meant to follow. */
static double ph_density_exact(double c, void *user) {
    ph_case d = ph_as_used(*(const ph_case *)user);
    d.f = 0;
    return ph_density(c, &d);
}

/* Integral of fn over [lo, hi] in cos, split at 0 and at +-(1 - 2^-k), k = 1 .. 60, so
   that the pieces shrink geometrically toward both ends, where a lobe peaks (width
   (1 - |g|)^2 / (2 |g|) in cos); 2 x 8-point Gauss-Legendre per piece.  Each piece
   spans at most a factor 2 in the distance to its end, where the integrand (a power
   -3/2 of (1 - |g|)^2 + 2 |g| y) changes by at most 2^1.5: the rule's error there is far
   below 1e-12 relative. */
static double ph_integrate(double (*fn)(double, void *), void *user, double lo, double hi) {
    double cuts[130];
    int n = 0;
    cuts[n++] = lo;
    for (int k = 1; k <= 60; k++)
        for (int s = -1; s <= 1; s += 2) {
            double c = s * (1.0 - ldexp(1.0, -k));
            if (c > lo && c < hi) cuts[n++] = c;
        }
    if (0.0 > lo && 0.0 < hi) cuts[n++] = 0.0;
    cuts[n++] = hi;
    for (int i = 1; i < n; i++)   /* insertion sort */
        for (int j = i; j > 0 && cuts[j] < cuts[j - 1]; j--) { double t = cuts[j]; cuts[j] = cuts[j - 1]; cuts[j - 1] = t; }
    double sum = 0.0;
    for (int i = 0; i + 1 < n; i++)
        if (cuts[i + 1] > cuts[i]) sum += tu_integrate(fn, user, cuts[i], cuts[i + 1], 2);
    return sum;
}

/* One uniform in [0, 1): 53 bits in double, 24 in float (so that it never rounds to
   1.0f). */
static double ph_uniform(uint64_t *rng, int f) {
    return f ? (double)(tu_rand_u64(rng) >> 40) * (1.0 / 16777216.0) : tu_rand01(rng);
}

static double ph_sample(const ph_case *p, double u) {
    if (p->f) return (double)cmf_phase_sample_cos((float)p->g, (float)p->back_g, (float)p->w, (float)u);
    return cm_phase_sample_cos(p->g, p->back_g, p->w, u);
}

static const char *ph_prec(const ph_case *p) { return p->f ? "float" : "double"; }

/* ---- the checks, one case each ------------------------------------------------------- */

/* 2 pi int_{-1}^{1} phase = 1.  Double: 1e-9 relative (the quadrature's error is below
   1e-12, the density's rounding ~1e-16 relative, so 1e-9 still catches any wrong
   constant or exponent, which are off by percent).  Float: 1e-4 for the single lobes
   up to g = 0.9 (the density's float rounding is a few 1e-7 relative; the rest is the
   rounding of the quadrature's nodes in cos to float, whose spacing 6e-8 near the peak
   is not small against the peak's width), 2e-3 for |g| >= 0.99, where the peak in cos is
   only 5e-5 (0.99) or 5e-7 (0.999) wide, i.e. 8 float spacings for 0.999: the value
   then reflects the float grid of cos, not the formula (the double check covers it). */
static int ph_check_integral(const ph_case *p) {
    double I = ph_integrate(ph_density, (void *)p, -1.0, 1.0);
    double big = fmax(fabs(p->g), p->w > 0 ? fabs(p->back_g) : 0.0);
    double tol = !p->f ? 1e-9 : big >= 0.99 ? 2e-3 : 1e-4;
    int ok = fabs(I - 1.0) <= tol;
    print_message("    g %g, back_g %g, w %g, %s: 2 pi int phase = %.12f (tol %g) %s\n", p->g, p->back_g, p->w,
                  ph_prec(p), I, tol, ok ? "ok" : "FAIL");
    return ok;
}

/* The sample mean of cos over N = 2e5 uniform u equals the mean cosine (1 - w) g + w
   back_g (at the float parameters in float) within 5 standard errors, the standard
   error from the sample variance: a two-sided false failure probability of 6e-7 per
   case for the normal mean of 2e5 bounded samples.  Float's rounding of each sample
   (<= a few 6e-8, nearly symmetric) shifts the mean far less than the smallest standard
   error here (5.8e-5 for g = 0.999). */
static int ph_check_mean(const ph_case *p, uint64_t seed) {
    enum { N = 200000 };
    uint64_t rng = seed;
    double s = 0.0, s2 = 0.0, shift = p->g;   /* sums of (cos - shift): no cancellation */
    for (int n = 0; n < N; n++) {
        double c = ph_sample(p, ph_uniform(&rng, p->f)) - shift;
        s += c;
        s2 += c * c;
    }
    double mean = s / N, var = (s2 - s * mean) / (N - 1), se = sqrt(fmax(var, 0.0) / N);
    ph_case e = ph_as_used(*p);
    double expect = (1.0 - e.w) * e.g + e.w * e.back_g;
    mean += shift;
    int ok = fabs(mean - expect) <= 5.0 * se;
    print_message("    g %g, back_g %g, w %g, %s: mean cos %.7f, expected %.7f, se %.2g, z %.2f %s\n", p->g, p->back_g,
                  p->w, ph_prec(p), mean, expect, se, se > 0 ? (mean - expect) / se : 0.0, ok ? "ok" : "FAIL");
    return ok;
}

/* The upper 1e-4 quantile of chi-square with df degrees of freedom, by Wilson and
   Hilferty's cube-root normal approximation (z = 3.7190, the normal's upper 1e-4 point;
   within 1 % of the exact quantile for df >= 10, and on the high side of it for large
   z, so the false-failure rate stays near 1e-4 per histogram). */
static double chi2_upper_1e4(int df) {
    double k = 2.0 / (9.0 * df);
    double t = 1.0 - k + 3.7190 * sqrt(k);
    return df * t * t * t;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Chi-square of the histogram of N = 2e5 samples against the density's integral over
   each bin.  Bin edges: cos = -1 + k / 10 and, toward both ends, geometrically
   1 -+ 2^(1 - j/2) (j = 1 .. 60 in double: down to 2e-9 from the end, so that the peak
   of g = 0.999, 5e-7 wide, spans several bins); adjacent bins are then merged until
   each expects >= 20 samples.  In float the edges stop 1e-6 from the ends (17 float
   spacings) and each is moved to the midpoint between two neighbouring floats: a float
   sample is the exact one rounded to nearest, and rounding never carries a sample
   across such an edge, so float's grid of cos adds no bias to any bin.  Expected counts
   come from the density in double at the float case's parameters (the exact law the
   float sampler is meant to follow; the float density's accuracy is the integral
   check's business).  Rejects above the upper 1e-4 quantile (fixed seeds: reproducible;
   a density that differs from its sampler by 2 % over a bin of 5000 expected samples
   already adds ~10 to the statistic). */
static int ph_check_histogram(const ph_case *p, uint64_t seed) {
    enum { N = 200000, MAXE = 200 };
    double edges[MAXE];
    int ne = 0;
    edges[ne++] = -1.0;
    edges[ne++] = 1.0;
    for (int k = 1; k < 20; k++) edges[ne++] = -1.0 + k / 10.0;
    double ymin = p->f ? 1e-6 : 2e-9;
    for (int j = 1; j <= 60; j++) {
        double y = 2.0 * pow(2.0, -0.5 * j);
        if (y < ymin) break;
        edges[ne++] = 1.0 - y;
        edges[ne++] = -1.0 + y;
    }
    if (p->f)
        for (int i = 0; i < ne; i++) {
            if (edges[i] <= -1.0 || edges[i] >= 1.0) continue;
            float lo = (float)edges[i], hi = nextafterf(lo, 2.0f);
            edges[i] = 0.5 * ((double)lo + (double)hi);
        }
    qsort(edges, (size_t)ne, sizeof edges[0], cmp_double);
    int m = 1;   /* drop duplicates */
    for (int i = 1; i < ne; i++)
        if (edges[i] > edges[m - 1]) edges[m++] = edges[i];
    ne = m;
    /* expected probabilities, then merge until each bin expects >= 20 samples */
    double prob[MAXE];
    for (int i = 0; i + 1 < ne; i++) prob[i] = ph_integrate(ph_density_exact, (void *)p, edges[i], edges[i + 1]);
    double me[MAXE], mp[MAXE];
    int K = 0;
    me[0] = edges[0];
    double acc = 0.0;
    for (int i = 0; i + 1 < ne; i++) {
        acc += prob[i];
        if (acc * N >= 20.0) { mp[K] = acc; me[++K] = edges[i + 1]; acc = 0.0; }
    }
    if (acc > 0.0) {   /* the last remainder joins the last bin */
        if (K > 0) { mp[K - 1] += acc; me[K] = 1.0; }
        else { mp[0] = acc; me[++K] = 1.0; }
    }
    me[K] = 1.0;
    long count[MAXE] = {0};
    uint64_t rng = seed;
    int outside = 0;
    for (int n = 0; n < N; n++) {
        double c = ph_sample(p, ph_uniform(&rng, p->f));
        if (!(c >= -1.0 && c <= 1.0)) { outside++; continue; }
        int lo = 0, hi = K;   /* the bin k with me[k] <= c < me[k + 1] (c = 1: the last) */
        while (hi - lo > 1) {
            int mid = (lo + hi) / 2;
            if (c >= me[mid]) lo = mid; else hi = mid;
        }
        count[lo]++;
    }
    double chi2 = 0.0, total = 0.0;
    for (int k = 0; k < K; k++) {
        double e = mp[k] * N;
        total += mp[k];
        chi2 += (count[k] - e) * (count[k] - e) / e;
    }
    double limit = chi2_upper_1e4(K - 1);
    int ok = outside == 0 && chi2 <= limit;
    print_message("    g %g, back_g %g, w %g, %s: chi2 %.1f, df %d, limit %.1f, total probability %.10f%s %s\n", p->g,
                  p->back_g, p->w, ph_prec(p), chi2, K - 1, limit, total, outside ? ", samples outside [-1, 1]" : "",
                  ok ? "ok" : "FAIL");
    return ok;
}

/* ---- the tests --------------------------------------------------------------------- */

void test_phase_hg_integrates_to_one(void **state) {
    (void)state;
    int ok = 1;
    for (size_t i = 0; i < N_PH_G; i++)
        for (int f = 0; f <= 1; f++) {
            ph_case p = {PH_G[i], 0.0, 0.0, f};
            ok &= ph_check_integral(&p);
        }
    /* single lobes through hg_eval itself: the same numbers as phase_eval at w = 0 */
    for (size_t i = 0; i < N_PH_G; i++)
        for (int k = 0; k <= 20; k++) {
            double c = -1.0 + k / 10.0;
            if (cm_hg_eval(PH_G[i], c) != cm_phase_eval(PH_G[i], 0.3, 0.0, c)) ok = 0;
            if (cmf_hg_eval((float)PH_G[i], (float)c) != cmf_phase_eval((float)PH_G[i], 0.3f, 0.0f, (float)c)) ok = 0;
        }
    if (!ok) fail_msg("the HG density does not integrate to 1");
}

/* The sampler inverts the CDF of the density it is tested with: for u on a grid (ends
   included) and g in the list plus 1e-8, -1e-8 and +-0.9999 (near the clamp),
   2 pi int_{-1}^{cos(u)} p = u within 1e-9 in double (the quadrature's error is below
   1e-12, and the sampler's own rounding, ~1e-16 in cos, times a density <= 1e6 for
   |g| <= 0.999 is ~1e-10; +-0.9999's peak density 1e8 makes that 1e-8: 1e-7).  In float, where the
   CDF's slope at the peak turns one float spacing of cos into percents of u, the float
   sample is compared with the double sample at the same (float) g and u instead: within
   8 x 2^-24 absolute.  2^-24 is float's spacing of cos in [0.5, 1), the grid the result
   is rounded to next to either end; cos is formed as 1 - (1 - cos) or (1 + cos) - 1, so
   its error is absolute everywhere: that one rounding plus the roundings of the ~15
   operations that form 1 -+ cos (<= 2), each relative.  Their first-order bound, ~40 x
   2^-24, assumes every rounding goes the same way, which independent roundings do not;
   8 x 2^-24 leaves a margin over what they reach on dense u grids, and any formula
   error (a wrong factor, a cancellation that the rearranged form avoids) is orders of
   magnitude above it.  Both samplers are nondecreasing in u, and u = 0 and u = 1 give
   exactly -1 and 1. */
void test_phase_hg_sample_inverts_cdf(void **state) {
    (void)state;
    static const double gs[] = {-0.99, -0.5, 0.0, 0.3, 0.9, 0.999, 1e-8, -1e-8, 0.9999, -0.9999};
    enum { NU = 400 };
    double worst_cdf = 0.0, worst_ulp = 0.0;
    int ok = 1;
    for (size_t i = 0; i < sizeof gs / sizeof gs[0]; i++) {
        double g = gs[i];
        ph_case p = {g, 0.0, 0.0, 0};
        double tol = fabs(g) > 0.9995 ? 1e-7 : 1e-9;
        double prev = -2.0, prevf = -2.0;
        for (int k = 0; k <= NU; k++) {
            /* u on [0, 1], denser toward both ends (where the CDF's inverse is steepest) */
            double t = (double)k / NU;
            double u = t * t * (3.0 - 2.0 * t);
            double c = cm_hg_sample_cos(g, u);
            double F = c <= -1.0 ? 0.0 : ph_integrate(ph_density, &p, -1.0, c);
            double e = fabs(F - u);
            if (e > worst_cdf) worst_cdf = e;
            if (!(e <= tol)) { print_message("    g %g, u %.17g: cos %.17g, CDF %.17g\n", g, u, c, F); ok = 0; }
            if (c < prev) { print_message("    g %g: not monotone at u %.17g\n", g, u); ok = 0; }
            prev = c;
            float gf = (float)g, uf = (float)u;
            double cf = (double)cmf_hg_sample_cos(gf, uf), cd = cm_hg_sample_cos((double)gf, (double)uf);
            double eu = fabs(cf - cd) * 16777216.0;
            if (eu > worst_ulp) worst_ulp = eu;
            if (!(eu <= 8.0)) { print_message("    float g %g, u %.9g: cos %.9g, double %.17g\n", g, u, cf, cd); ok = 0; }
            if (cf < prevf) { print_message("    float g %g: not monotone at u %.9g\n", g, u); ok = 0; }
            prevf = cf;
        }
        if (cm_hg_sample_cos(g, 0.0) != -1.0 || cm_hg_sample_cos(g, 1.0) != 1.0 || cmf_hg_sample_cos((float)g, 0.0f) != -1.0f ||
            cmf_hg_sample_cos((float)g, 1.0f) != 1.0f) {
            print_message("    g %g: u = 0 / 1 do not give -1 / 1\n", g);
            ok = 0;
        }
    }
    print_message("    worst |CDF(sample(u)) - u| %.3g (double); worst |float - double| %.2f x 2^-24\n", worst_cdf, worst_ulp);
    if (!ok) fail_msg("the HG sampler does not invert the CDF of the HG density");
}

void test_phase_hg_sample_mean_is_g(void **state) {
    (void)state;
    int ok = 1;
    for (size_t i = 0; i < N_PH_G; i++)
        for (int f = 0; f <= 1; f++) {
            ph_case p = {PH_G[i], 0.0, 0.0, f};
            ok &= ph_check_mean(&p, 0x5eed0000ull + 16 * i + (uint64_t)f);
        }
    if (!ok) fail_msg("the mean cosine of the HG samples is not g");
}

void test_phase_hg_histogram_matches_pdf(void **state) {
    (void)state;
    int ok = 1;
    for (size_t i = 0; i < N_PH_G; i++)
        for (int f = 0; f <= 1; f++) {
            ph_case p = {PH_G[i], 0.0, 0.0, f};
            ok &= ph_check_histogram(&p, 0xc4150000ull + 16 * i + (uint64_t)f);
        }
    if (!ok) fail_msg("the HG samples do not follow the HG density");
}

/* The mix of a forward lobe g = 0.8 and a back lobe -0.3 at weights 0.2, 0 (the main
   lobe only) and 0.999 (nearly only the back lobe; 200 of the 2e5 samples come from
   the main lobe, which the chi-square's bins still see at the forward end): integral,
   mean (0.8 * 0.8 + 0.2 * (-0.3) = 0.58 at w = 0.2) and histogram, checks and
   tolerances as for the single lobes.  Also: w = 1 takes the back lobe alone, and u
   just below w or 1 still gives a cos in [-1, 1]. */
void test_phase_two_lobe_mix(void **state) {
    (void)state;
    static const double ws[] = {0.2, 0.0, 0.999};
    int ok = 1;
    for (size_t i = 0; i < sizeof ws / sizeof ws[0]; i++)
        for (int f = 0; f <= 1; f++) {
            ph_case p = {0.8, -0.3, ws[i], f};
            ok &= ph_check_integral(&p);
            ok &= ph_check_mean(&p, 0x0111e000ull + 16 * i + (uint64_t)f);
            ok &= ph_check_histogram(&p, 0x0222e000ull + 16 * i + (uint64_t)f);
        }
    /* w = 1: the back lobe's own sample for every u (the rescaled u is u itself) */
    for (int k = 0; k < 16; k++) {
        double u = k / 16.0;
        if (cm_phase_sample_cos(0.8, -0.3, 1.0, u) != cm_hg_sample_cos(-0.3, u)) ok = 0;
        if (cm_phase_sample_cos(0.8, -0.3, 0.0, u) != cm_hg_sample_cos(0.8, u)) ok = 0;
    }
    double c1 = cm_phase_sample_cos(0.8, -0.3, 1.0, 1.0), c2 = cm_phase_sample_cos(0.8, -0.3, 0.2, nextafter(0.2, 0.0));
    float c3 = cmf_phase_sample_cos(0.8f, -0.3f, 0.2f, nextafterf(0.2f, 0.0f)), c4 = cmf_phase_sample_cos(0.8f, -0.3f, 0.2f, 1.0f);
    if (!(c1 >= -1.0 && c1 <= 1.0 && c2 >= -1.0 && c2 <= 1.0 && c3 >= -1.0f && c3 <= 1.0f && c4 >= -1.0f && c4 <= 1.0f)) ok = 0;
    if (!ok) fail_msg("the two-lobe phase function does not match its sampler");
}

/* Extreme and non-finite inputs: every result finite, samples in [-1, 1], densities
   > 0 (the clamp of g keeps them so), in double and float.  The documented rules:
   g NaN or +-inf is isotropic (density 1 / (4 pi), sample 2u - 1); g beyond the clamp
   (+-1, +-2, +-0.9999999) acts as +-CM_HG_G_MAX; cos NaN counts as 0; u NaN counts as
   0 (sample -1); back_weight NaN counts as 0 (the main lobe alone).  g = +-1e-8 has
   no 0/0: in double its sample and density match the first-order forms cos = x + 1.5 g
   (1 - x^2) (x = 2u - 1) and p = (1 + 3 g cos) / (4 pi) within 1e-15 (the second-order
   terms are ~1e-16); in float its sample is within 1e-7 of x (the 1.5e-8 shift plus
   one float spacing, 6e-8, of rounding). */
void test_phase_extreme_inputs(void **state) {
    (void)state;
    const double gs[] = {0.9999999, -0.9999999, 1e-8, -1e-8, 0.0, -0.0, 1.0, -1.0, 2.0, -2.0, 0.999999, -0.999999,
                         1e-40, INFINITY, -INFINITY, NAN};
    const double us[] = {0.0, 1.0 - 1.0 / 16777216.0, 0.5, 1e-30, 1.0, -0.5, 2.0, INFINITY, -INFINITY, NAN};
    const double cs[] = {1.0, -1.0, 0.0, 1.0 - 1e-12, -1.0 + 1e-12, 0.999999, 2.0, -2.0, INFINITY, -INFINITY, NAN};
    const double ws[] = {0.0, 0.2, 1.0, 1e-30, 1.0 - 1e-12, -1.0, 2.0, INFINITY, NAN};
    const size_t ng = sizeof gs / sizeof gs[0], nu = sizeof us / sizeof us[0], nc = sizeof cs / sizeof cs[0],
                 nw = sizeof ws / sizeof ws[0];
    int ok = 1;
    for (size_t i = 0; i < ng; i++) {
        double g = gs[i];
        float gf = (float)g;
        for (size_t j = 0; j < nu; j++) {
            double c = cm_hg_sample_cos(g, us[j]);
            float cf = cmf_hg_sample_cos(gf, (float)us[j]);
            if (!(c >= -1.0 && c <= 1.0) || !(cf >= -1.0f && cf <= 1.0f)) {
                print_message("    hg_sample_cos(%g, %g) = %g / %g\n", g, us[j], c, (double)cf);
                ok = 0;
            }
        }
        for (size_t j = 0; j < nc; j++) {
            double p = cm_hg_eval(g, cs[j]);
            float pf = cmf_hg_eval(gf, (float)cs[j]);
            if (!(isfinite(p) && p > 0.0 && isfinite(pf) && pf > 0.0f)) {
                print_message("    hg_eval(%g, %g) = %g / %g\n", g, cs[j], p, (double)pf);
                ok = 0;
            }
        }
        for (size_t k = 0; k < ng; k++)
            for (size_t l = 0; l < nw; l++) {
                for (size_t j = 0; j < nu; j++) {
                    double c = cm_phase_sample_cos(g, gs[k], ws[l], us[j]);
                    float cf = cmf_phase_sample_cos(gf, (float)gs[k], (float)ws[l], (float)us[j]);
                    if (!(c >= -1.0 && c <= 1.0) || !(cf >= -1.0f && cf <= 1.0f)) {
                        print_message("    phase_sample_cos(%g, %g, %g, %g) = %g / %g\n", g, gs[k], ws[l], us[j], c, (double)cf);
                        ok = 0;
                    }
                }
                for (size_t j = 0; j < nc; j++) {
                    double p = cm_phase_eval(g, gs[k], ws[l], cs[j]);
                    float pf = cmf_phase_eval(gf, (float)gs[k], (float)ws[l], (float)cs[j]);
                    if (!(isfinite(p) && p > 0.0 && isfinite(pf) && pf > 0.0f)) {
                        print_message("    phase_eval(%g, %g, %g, %g) = %g / %g\n", g, gs[k], ws[l], cs[j], p, (double)pf);
                        ok = 0;
                    }
                }
            }
    }
    /* the documented rules */
    const double iso = 1.0 / (4.0 * M_PI);
    assert_true(fabs(cm_hg_eval(NAN, 0.7) - iso) < 1e-16 && fabs(cm_hg_eval(INFINITY, -0.2) - iso) < 1e-16);
    assert_true(fabs(cm_hg_eval(0.0, 0.3) - iso) < 1e-16 && fabs((double)cmf_hg_eval(0.0f, 0.3f) - iso) < 1e-8);
    assert_true(cm_hg_sample_cos(NAN, 0.25) == -0.5 && cmf_hg_sample_cos(NAN, 0.25f) == -0.5f);
    assert_true(cm_hg_sample_cos(0.5, NAN) == -1.0 && cmf_hg_sample_cos(0.5f, NAN) == -1.0f);
    assert_true(cm_hg_eval(0.4, NAN) == cm_hg_eval(0.4, 0.0));
    assert_true(cm_hg_eval(2.0, 1.0) == cm_hg_eval(0.999999, 1.0) && cm_hg_eval(-1.0, -1.0) == cm_hg_eval(-0.999999, -1.0));
    assert_true(cm_phase_eval(0.5, -0.5, NAN, 0.2) == cm_hg_eval(0.5, 0.2));
    assert_true(cm_phase_sample_cos(0.5, -0.5, NAN, 0.3) == cm_hg_sample_cos(0.5, 0.3));
    /* the peak at the clamp: huge, finite, (1 + a) / (4 pi (1 - a)^2) */
    double a = 0.999999, peak = (1.0 + a) / (4.0 * M_PI * (1.0 - a) * (1.0 - a));
    assert_true(fabs(cm_hg_eval(0.9999999, 1.0) / peak - 1.0) < 1e-9);
    assert_true(fabs(cm_hg_eval(-0.9999999, -1.0) / peak - 1.0) < 1e-9);
    float fa = 0.999999f;
    double fpeak = (1.0 + fa) / (4.0 * M_PI * (1.0 - fa) * (1.0 - fa));
    assert_true(fabs((double)cmf_hg_eval(0.9999999f, 1.0f) / fpeak - 1.0) < 1e-5);
    /* g = +-1e-8: the first-order isotropic forms */
    for (int k = 0; k <= 8; k++) {
        double u = k / 8.0, x = 2.0 * u - 1.0;
        for (int s = -1; s <= 1; s += 2) {
            double g = s * 1e-8;
            if (!(fabs(cm_hg_sample_cos(g, u) - (x + 1.5 * g * (1.0 - x * x))) <= 1e-15)) ok = 0;
            if (!(fabs(cm_hg_eval(g, x) / ((1.0 + 3.0 * g * x) * iso) - 1.0) <= 1e-15)) ok = 0;
            if (!(fabs((double)cmf_hg_sample_cos((float)g, (float)u) - x) <= 1e-7)) ok = 0;
        }
    }
    if (!ok) fail_msg("a phase function result is out of range for an extreme input");
}
