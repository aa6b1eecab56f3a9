// sampling_math.glsl - the scalar formulas of distance sampling along a ray: equiangular
// sampling toward a light (Kulla and Fajardo 2012, "Importance Sampling Techniques for
// Path Tracing in Participating Media", §4), its pdf, and the weights that combine it
// with free-flight (delta-tracking) sampling by multiple importance sampling (Veach's
// power heuristic).  Written
// in the common subset of C and GLSL (its rules are at the top of cache_math.glsl):
// the shaders compile it in float, tests/test_sampling.c in double and float.
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

#ifdef CM_GLSL
#undef real
#endif

#endif // !CM_GLSL || !SAMPLING_MATH_GLSL_ONCE
