// sampling_math.glsl - the scalar formulas of distance sampling along a ray: equiangular
// sampling toward a light (Kulla and Fajardo 2012, "Importance Sampling Techniques for
// Path Tracing in Participating Media", §4), its pdf, and the weights that combine it
// with free-flight (delta-tracking) sampling by multiple importance sampling (Veach's
// power heuristic).  Written
// in the common subset of C and GLSL (its rules are at the top of cache_math.glsl):
// the shaders compile it in float, tests/test_sampling.c in double and float.  At its
// end, the Henyey-Greenstein phase function and its two-lobe mix (evaluation and
// inverse-CDF sampling of the scattering cosine; tests/test_phase.c).
//
// Geometry.  The ray x(t) = o + t w (w unit), a light's centre c.  Delta = dot(c - o, w)
// is the parameter of the foot of the perpendicular from c to the ray and D its length
// (the caller clamps D to a small positive floor).  An offset s = t - Delta; the segment
// [t0, t1] is a = t0 - Delta .. b = t1 - Delta.  Equiangular sampling draws the angle
// theta = atan(s / D) uniformly in [theta_a, theta_b]:
//   pdf(t) = D / (Theta (D^2 + s^2)),   Theta = theta_b - theta_a,
// so the pdf is proportional to 1 / |x(t) - c|^2, the falloff of a point light, which
// cancels in the estimate.
//
// Guards: every function returns a finite number for any input.  A degenerate segment
// (b <= a, non-finite input) has Theta = 0: the strategy does not sample there and its
// pdf is 0 on it, which the MIS weights below handle.
#include "c_subset.glsl"

#if !defined(CM_GLSL) || !defined(SAMPLING_MATH_GLSL_ONCE)

#ifdef CM_GLSL
#define SAMPLING_MATH_GLSL_ONCE 1
#define real float
#else
#if !defined(real) || !defined(CM_FN) || !defined(cm_atan2) || !defined(cm_tan)
#error "sampling_math.glsl: include reference/cache_math_host.h (it defines the C side of the macros)"
#endif
#endif

// Theta, the angle that [a, b] subtends from the light, as one atan2: theta_b - theta_a
// = atan2(D (b - a), D^2 + a b) (the difference formula of atan, exact in (0, pi) since
// the first argument is positive), which keeps its precision when both angles are near
// +-pi/2 (a light far along the ray), where the difference of two atans cancels.
// Rule: b <= a, D <= 0 or a non-finite input give 0.
CM_API real CM_FN(eq_span)(real a, real b, real D) {
    if (!cm_isfinite(a) || !cm_isfinite(b) || !cm_isfinite(D)) return CM_REAL(0.0);
    if (!(b > a) || !(D > CM_REAL(0.0))) return CM_REAL(0.0);
    real span = cm_atan2(D * (b - a), D * D + a * b);
    return cm_isfinite(span) ? cm_max(span, CM_REAL(0.0)) : CM_REAL(0.0);
}

// The sample's distance x = s - a into the segment for u in [0, 1), in [0, b - a]:
// s = D tan(theta_a + phi), phi = u Theta, written by the addition formula of tan as
//   x = tan(phi) (a^2 + D^2) / (D - a tan(phi))
// (exact for any phi in [0, pi) with theta_a + phi inside (-pi/2, pi/2)).  For phi <
// pi/2 and a < 0 (the light beside or beyond the segment's start) its denominator is a
// sum, so x keeps its precision where D tan(theta) near theta = -pi/2 would lose it (a
// light far behind, on the ray's line), and t = t0 + x needs no subtraction of the
// foot's large parameter.  Rules: span <= 0 gives 0 (the caller does not use it); a
// zero denominator or an overflow falls back to D tan(theta) - a, and if that is not
// finite either, to the nearer end; the result is clamped to [0, b - a].
CM_API real CM_FN(eq_advance)(real a, real b, real D, real span, real u) {
    if (!(span > CM_REAL(0.0)) || !(b > a)) return CM_REAL(0.0);
    u = cm_clamp(u, CM_REAL(0.0), CM_REAL(1.0));
    real tp = cm_tan(u * span);
    real den = D - a * tp;
    real len = b - a;
    real x = den != CM_REAL(0.0) ? tp * ((a * a + D * D) / den) : len;
    if (!cm_isfinite(x) || den == CM_REAL(0.0)) x = D * cm_tan(cm_atan2(a, D) + u * span) - a;
    if (!cm_isfinite(x)) x = u < CM_REAL(0.5) ? CM_REAL(0.0) : len;
    return cm_clamp(x, CM_REAL(0.0), len);
}

// The pdf (per unit of t) of the offset s.  Rule: span <= 0 (no sampling) gives 0; D^2
// + s^2 stays finite for |s|, D < 1e19 (the caller's world is far smaller).
CM_API real CM_FN(eq_pdf)(real s, real D, real span) {
    if (!(span > CM_REAL(0.0)) || !cm_isfinite(s) || !(D > CM_REAL(0.0))) return CM_REAL(0.0);
    real d2 = D * D + s * s;
    if (!(d2 > CM_REAL(0.0)) || !cm_isfinite(d2)) return CM_REAL(0.0);
    return D / (span * d2);
}

// The power-heuristic weight (exponent 2) of the strategy that drew a sample, whose
// (proxy) density there is p_own, against the other strategy's p_other:
// p_own^2 / (p_own^2 + p_other^2), as 1 / (1 + r^2) with r = p_other / p_own so that no
// square overflows.  The weights of the two strategies at any point sum to 1, which is
// all unbiasedness needs, whatever the proxies are.  Rules: both 0 gives 1 to the
// strategy that drew it (the other cannot reach that point); p_own 0 (p_other > 0)
// gives 0; r beyond 1e18 gives 0; NaN counts as 0, +inf as the larger.
CM_API real CM_FN(mis_power)(real p_own, real p_other) {
    if (!cm_isfinite(p_own) || !cm_isfinite(p_other)) {
        if (cm_isfinite(p_own) || !(p_own > CM_REAL(0.0))) return CM_REAL(0.0);   // p_other inf, or p_own NaN
        return CM_REAL(1.0);                                                      // p_own inf, p_other finite
    }
    p_own = cm_max(p_own, CM_REAL(0.0));
    p_other = cm_max(p_other, CM_REAL(0.0));
    if (!(p_own > CM_REAL(0.0))) return p_other > CM_REAL(0.0) ? CM_REAL(0.0) : CM_REAL(1.0);
    real r = p_other / p_own;
    if (!(r < CM_REAL(1e18))) return CM_REAL(0.0);
    return CM_REAL(1.0) / (CM_REAL(1.0) + r * r);
}

// The weight of an equiangular sample whose transmittance estimate is T, extinction
// sigma, free-flight proxy density q and equiangular density p: mis_power(p, q) * T *
// sigma / p.  Rule: p <= 0 (the strategy could not draw it) or a non-finite result
// gives 0.
CM_API real CM_FN(eq_weight)(real T, real sigma, real q, real p) {
    if (!(p > CM_REAL(0.0)) || !cm_isfinite(p)) return CM_REAL(0.0);
    real w = CM_FN(mis_power)(p, q);
    if (!(w > CM_REAL(0.0))) return CM_REAL(0.0);
    real v = T * sigma / p * w;
    return cm_isfinite(v) ? v : CM_REAL(0.0);
}

// ---- forced in-segment distance sampling ---------------------------------------------
//
// A distance t in a ray's medium segment [t0, t1] drawn with density proportional to
// m(t) exp(-tau(t)), m the majorant (piecewise constant over the coarse grid) and tau(t)
// its optical depth from t0: free flight against the majorant, conditioned on colliding
// inside the segment ("forced"),
//   p_F(t) = m(t) exp(-tau(t)) / Z,   Z = 1 - exp(-tau(t1)),
// sampled by inversion, tau(t) = -ln(1 - u Z).  Every ray whose segment crosses medium
// gets a point however thin the medium is (as tau(t1) -> 0, p_F -> m / tau(t1): uniform
// in optical depth), and in thick medium p_F tends to free flight's own density.  Both
// Z and the inversion are computed so that they keep their relative precision as
// tau -> 0, where 1 - exp(-tau) and ln(1 - u Z) round to 0 in float (tau < 6e-8), on a
// GPU as in C.

// Z = 1 - exp(-tau) = -expm1(-tau).  Below tau = 1/2 by its Taylor series in nested
// form, tau (1 - tau/2 (1 - tau/3 (...))) to the tau^15 term (the rest is below 2e-18
// of Z): no cancellation, and no log or exp near 1, whose GPU versions are only
// absolutely accurate there (GLSL allows an error of 2^-21 for log in [0.5, 2], twice
// ln e itself at tau = 1e-6, by which a Kahan form (e - 1) tau / ln e divides).  From
// 1/2 on, 1 - exp(-tau) >= 0.39 keeps its relative precision directly.  Rules: tau NaN
// or <= 0 gives 0 (no medium: nothing to sample); tau = +inf gives 1; the result is
// clamped to [0, 1].
CM_API real CM_FN(forced_norm)(real tau) {
    if (!(tau > CM_REAL(0.0))) return CM_REAL(0.0);
    if (!cm_isfinite(tau)) return CM_REAL(1.0);
    if (tau < CM_REAL(0.5)) {
        real s = CM_REAL(1.0);
        for (int k = 15; k >= 2; k--) s = CM_REAL(1.0) - tau / CM_REAL(k) * s;
        return tau * s;
    }
    return cm_clamp(CM_REAL(1.0) - cm_exp(-tau), CM_REAL(0.0), CM_REAL(1.0));
}

// The optical depth of the forced sample for u in [0, 1): -ln(1 - y), y = u Z.  Below
// y = 1/16 as 2 atanh(s), s = y / (2 - y) <= 0.033, by its series to the s^11 term (the
// rest is below 1e-19 of it; no log near 1, as above); from 1/16 on as -ln(1 - y), where
// 1 - y is exact to an ulp and the depth is >= 0.06.  Rules: u non-finite -> 0, clamped
// to [0, 1]; Z outside (0, 1] or non-finite gives 0 (the caller does not sample there);
// 1 - y <= 0 (u Z = 1) or a non-finite result gives tau_total; the result is clamped to
// [0, tau_total] (tau_total: the segment's depth, of which Z was computed).
CM_API real CM_FN(forced_depth)(real u, real z, real tau_total) {
    if (!(z > CM_REAL(0.0)) || !(z <= CM_REAL(1.0))) return CM_REAL(0.0);
    real hi = cm_isfinite(tau_total) ? cm_max(tau_total, CM_REAL(0.0)) : CM_REAL(0.0);
    u = cm_isfinite(u) ? cm_clamp(u, CM_REAL(0.0), CM_REAL(1.0)) : CM_REAL(0.0);
    real y = u * z;
    real d;
    if (y < CM_REAL(0.0625)) {
        real s = y / (CM_REAL(2.0) - y);
        real s2 = s * s;
        d = CM_REAL(2.0) * s * (CM_REAL(1.0) + s2 * (CM_REAL(1.0) / CM_REAL(3.0) + s2 * (CM_REAL(1.0) / CM_REAL(5.0) +
            s2 * (CM_REAL(1.0) / CM_REAL(7.0) + s2 * (CM_REAL(1.0) / CM_REAL(9.0) + s2 / CM_REAL(11.0))))));
    } else {
        real w = CM_REAL(1.0) - y;
        if (!(w > CM_REAL(0.0))) return hi;
        d = -cm_log(w);
    }
    return cm_isfinite(d) ? cm_clamp(d, CM_REAL(0.0), hi) : hi;
}

// p_F at a point where the majorant is m and its depth from t0 is tau: m exp(-tau) / Z.
// Rules: Z <= 0 or non-finite, m <= 0 or non-finite (no medium there: the strategy cannot
// draw the point) give 0; tau NaN or < 0 counts as 0; the exponent is capped at 87 (exp
// stays a normal float); a non-finite result gives 0.
CM_API real CM_FN(forced_pdf)(real m, real tau, real z) {
    if (!(z > CM_REAL(0.0)) || !cm_isfinite(z)) return CM_REAL(0.0);
    if (!(m > CM_REAL(0.0)) || !cm_isfinite(m)) return CM_REAL(0.0);
    real t = tau > CM_REAL(0.0) ? cm_min(tau, CM_REAL(87.0)) : CM_REAL(0.0);
    real p = m * cm_exp(-t) / z;
    return cm_isfinite(p) ? p : CM_REAL(0.0);
}

// ---- Henyey-Greenstein phase function ------------------------------------------------
//
//   p_g(cos) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos)^(3/2))   per steradian,
// cos the cosine between the propagation direction before the scattering and after it;
// g > 0 scatters forward and is the mean cosine.  2 pi p_g(cos) is the density of cos on
// [-1, 1], and its CDF F(cos) = (1 - g^2) / (2 g) (1 / sqrt(1 + g^2 - 2 g cos) - 1 / (1 +
// g)) is inverted exactly by hg_sample_cos.
//
// Inputs are sanitized first (each rule is also stated at its function): g non-finite
// -> 0 (isotropic), then clamped to [-CM_HG_G_MAX, CM_HG_G_MAX]; cos non-finite -> 0,
// clamped to [-1, 1]; u non-finite -> 0, clamped to [0, 1]; a lobe weight non-finite ->
// 0, clamped to [0, 1].  Every output is finite; every density is > 0.
//
// CM_HG_G_MAX = 1 - 1e-6 keeps (1 - |g|)^2 >= 1e-12 and the peak density (1 + |g|) /
// (4 pi (1 - |g|)^2) <= 1.6e11, finite in float with room for the caller's products, and
// 1 - |g| exact in float.  It costs nothing a float cosine could show: such a lobe is
// ~1e-6 rad wide, far below the 3.5e-4 rad that the float spacing of cos near 1 (6e-8)
// resolves, so its float samples are cos = 1 (a delta) either way.

#ifndef CM_PHASE_CONSTANTS
#define CM_PHASE_CONSTANTS 1
#define CM_HG_G_MAX      CM_REAL(0.999999)                    // |g| is clamped to this
#define CM_INV_4PI       CM_REAL(0.07957747154594767)         // 1 / (4 pi)
#define CM_ONE_BELOW     CM_REAL(0.999999940395355224609375)  // 1 - 2^-24: largest float < 1
#endif

// g sanitized: non-finite -> 0 (isotropic), then clamped to [-CM_HG_G_MAX, CM_HG_G_MAX].
CM_API real CM_FN(hg_g)(real g) {
    if (!cm_isfinite(g)) return CM_REAL(0.0);
    return cm_clamp(g, -CM_HG_G_MAX, CM_HG_G_MAX);
}

// The HG density per steradian.  With a = |g| and c' = sign(g) cos (the cosine to the
// lobe's peak), the base 1 + g^2 - 2 g cos is computed as (1 - a)^2 + 2 a (1 - c'): a sum
// of two terms >= 0, so at the peak (cos -> sign(g), |g| -> 1), where the textbook form
// subtracts two numbers near 2 to get ~(1 - a)^2, it keeps full relative precision; the
// numerator 1 - g^2 is (1 - a)(1 + a) for the same reason.  The base is >= 1e-12 (the
// clamp of g), so the result lies in [(1 - a) / (4 pi (1 + a)^2), 1.6e11], > 0.
// Rules: g as in hg_g; cos non-finite -> 0, clamped to [-1, 1].
CM_API real CM_FN(hg_eval)(real g, real cos_theta) {
    g = CM_FN(hg_g)(g);
    real c = cm_isfinite(cos_theta) ? cm_clamp(cos_theta, CM_REAL(-1.0), CM_REAL(1.0)) : CM_REAL(0.0);
    real a = cm_abs(g);
    real cp = g < CM_REAL(0.0) ? -c : c;
    real om = CM_REAL(1.0) - a;
    real d = om * om + CM_REAL(2.0) * a * (CM_REAL(1.0) - cp);
    return CM_INV_4PI * om * (CM_REAL(1.0) + a) / (d * cm_sqrt(d));
}

// The exact inverse of the HG CDF: cos for u in [0, 1] (u = 0 gives -1, u = 1 gives 1,
// nondecreasing in u).  The textbook form cos = (1 + g^2 - t^2) / (2 g), t = (1 - g^2) /
// (1 - g + 2 g u), is 0/0 at g -> 0 and subtracts numbers near 2 at |g| -> 1.  Factoring
// (1 + g)^2 - t^2 and t^2 - (1 - g)^2 instead (the 1/g cancels) gives, with v = 1 - u and
// q = 1 - g + 2 g u,
//   1 - cos = 2 v (1 + g u)     ((1 - g) / q)^2,
//   1 + cos = 2 u (1 - g + g u) ((1 + g) / q)^2,
// with every factor a sum of terms >= 0 for |g| < 1: q = (1 - g) v + (1 + g) u, 1 + g u
// = v + (1 + g) u, 1 - g + g u = (1 - g) v + u.  So both distances to the ends carry
// full relative precision for every g (g = 0 gives exactly 1 - 2v and 2u - 1, the
// isotropic sample, with no special case), and cos is formed from the smaller of the two,
// 1 - (1 - cos) or (1 + cos) - 1: one rounding at the peak.  q >= 1e-6 (the clamp of g).
// Rules: g as in hg_g; u non-finite -> 0 (cos = -1), clamped to [0, 1]; the result is
// clamped to [-1, 1].
CM_API real CM_FN(hg_sample_cos)(real g, real u) {
    g = CM_FN(hg_g)(g);
    u = cm_isfinite(u) ? cm_clamp(u, CM_REAL(0.0), CM_REAL(1.0)) : CM_REAL(0.0);
    real v = CM_REAL(1.0) - u;
    real gm = CM_REAL(1.0) - g;
    real gp = CM_REAL(1.0) + g;
    real q = gm * v + gp * u;
    real rm = gm / q;
    real rp = gp / q;
    real m = CM_REAL(2.0) * v * (v + gp * u) * rm * rm;   // 1 - cos
    real p = CM_REAL(2.0) * u * (gm * v + u) * rp * rp;   // 1 + cos
    real c = m < p ? CM_REAL(1.0) - m : p - CM_REAL(1.0);
    return cm_clamp(c, CM_REAL(-1.0), CM_REAL(1.0));
}

// A lobe weight sanitized: non-finite -> 0, clamped to [0, 1].
CM_API real CM_FN(phase_weight)(real w) {
    return cm_isfinite(w) ? cm_clamp(w, CM_REAL(0.0), CM_REAL(1.0)) : CM_REAL(0.0);
}

// The two-lobe phase function per steradian: (1 - w) p_g(cos) + w p_back_g(cos), w =
// back_weight.  Rules: w as in phase_weight; g, back_g and cos as in hg_eval.
CM_API real CM_FN(phase_eval)(real g, real back_g, real back_weight, real cos_theta) {
    real w = CM_FN(phase_weight)(back_weight);
    return (CM_REAL(1.0) - w) * CM_FN(hg_eval)(g, cos_theta) + w * CM_FN(hg_eval)(back_g, cos_theta);
}

// A cos sample of the two-lobe mix from one uniform u: the back lobe when u < w (w =
// back_weight), with u / w as its uniform, else the main lobe with (u - w) / (1 - w).
// The chosen lobe has probability w (or 1 - w) and its rescaled uniform is uniform on
// [0, 1), so 2 pi phase_eval(cos) is exactly the density of the result.  Rules: w as in
// phase_weight, and w = 1 always picks the back lobe (no 0/0 at u = 1); u non-finite ->
// 0, clamped to [0, 1]; a rescaled uniform >= 1 (only by rounding, or u = 1: at most one
// ulp of probability) becomes CM_ONE_BELOW.
CM_API real CM_FN(phase_sample_cos)(real g, real back_g, real back_weight, real u) {
    real w = CM_FN(phase_weight)(back_weight);
    u = cm_isfinite(u) ? cm_clamp(u, CM_REAL(0.0), CM_REAL(1.0)) : CM_REAL(0.0);
    bool back = u < w || !(w < CM_REAL(1.0));
    real r = back ? u / w : (u - w) / (CM_REAL(1.0) - w);
    r = r < CM_REAL(1.0) ? r : CM_ONE_BELOW;
    return CM_FN(hg_sample_cos)(back ? back_g : g, r);
}

#ifdef CM_GLSL
#undef real
#endif

#endif // !CM_GLSL || !SAMPLING_MATH_GLSL_ONCE
