// cache_math.glsl - the numerical core of the irradiance cache (paper §4.2, §4.3:
// Eq. 6-11, the Fig. 4 discard radius and the Fig. 6 radius reduction), written once
// in the common subset of C and GLSL.  The shaders compile it in float (this file
// defines the GLSL side of its macros); the host tests compile it twice, in double and
// in float, through the prelude reference/cache_math_host.h.  It holds what the kernels
// use; formulas that only the tests and benchmarks use (closed forms they compare
// against) are in that prelude, in the same subset.
//
// Common-subset rules: scalar code only; no out-parameters (a function returns one
// scalar, several values mean one call per axis); no vectors, structs, arrays, casts or
// `static`; literals through CM_REAL(); every function defined before its first use.
// Macros (GLSL side in c_subset.glsl; the C prelude defines the same set):
//   real          float (GLSL) / double or float (C)
//   CM_FN(name)   function name: cm_<name> in GLSL and in C double, cmf_<name> in C float
//   CM_API        storage class: empty (GLSL) / static inline (C)
//   CM_REAL(x)    a literal of type real
//   cm_log cm_exp cm_sqrt cm_abs cm_min cm_max cm_clamp cm_isfinite
//
// Units: the functions are unit-free; lengths (delta, distances, coordinates, radii)
// only need one common unit (voxels in Table 1, world units in the shaders); sigma_v is
// per that unit.  Table 1 values are given in voxels below.
//
// Guard policy (every log, ratio, division and exp): inputs are sanitized first, so
// that no intermediate is ever inf or NaN (Vulkan lets a compiler assume there are
// none), and every output is finite.  Each sanitizer tests cm_isfinite first; only in
// the non-finite branch does a comparison pick the bound (IEEE on the host gives the
// rules below for NaN; a GPU compiler that folds NaN comparisons may pick the other
// bound, still finite):
//   irradiance E      NaN or <= CM_E_MIN (incl. negative) -> 0, i.e. ln E = CM_LN_E_MIN;
//                     >= CM_E_MAX (incl. +inf) -> CM_E_MAX.  So ln E lies in
//                     [CM_LN_E_MIN, CM_LN_E_MAX] = [ln 1e-30, ln 1e30], and ln E =
//                     CM_LN_E_MIN is the code for E = 0 (irradiance_from_ln maps every
//                     ln E <= ln 2e-30 back to exactly 0).
//   length (delta, radius, r_min, r_max)   NaN -> CM_LEN_MIN; clamped to
//                     [CM_LEN_MIN, CM_LEN_MAX] = [1e-12, 1e12] (a zero radius becomes
//                     1e-12, an infinite one 1e12).
//   coordinate or distance    |c|, NaN -> CM_LEN_MAX ("far away": weight 0, no radius
//                     reduction), clamped to CM_LEN_MAX.
//   sigma_v           NaN -> 0; clamped to [-CM_SIGMA_V_MAX, CM_SIGMA_V_MAX].
// With these bounds |sigma_v| <= CM_LN_E_RANGE / delta <= CM_SIGMA_V_MAX = 1.4e14 and
// |sigma_v * x| <= 1.4e26, finite in float.  Squares are taken only of numbers scaled
// to [0, 1] or of ratios <= 1e12, so float never overflows either.

#include "c_subset.glsl"

#if !defined(CM_GLSL) || !defined(CACHE_MATH_GLSL_ONCE)

#ifdef CM_GLSL
#define CACHE_MATH_GLSL_ONCE 1
#define real float
#else
#if !defined(real) || !defined(CM_FN) || !defined(CM_API) || !defined(CM_REAL) || \
    !defined(cm_log) || !defined(cm_isfinite) || !defined(cm_clamp)
#error "cache_math.glsl: include reference/cache_math_host.h (it defines the C side of the macros)"
#endif
#endif

#ifndef CM_CONSTANTS
#define CM_CONSTANTS 1
// Table 1 (voxels).
#define CM_EPS           CM_REAL(0.1)     // validity radius threshold epsilon
#define CM_DELTA_VOXELS  CM_REAL(2.0)     // position offset Delta
#define CM_R_MIN_VOXELS  CM_REAL(0.01)    // minimum influence zone radius
#define CM_R_MAX_VOXELS  CM_REAL(16.0)    // maximum influence zone radius
// Guard bounds (see the policy above).
#define CM_E_MIN         CM_REAL(1e-30)   // irradiance at or below this counts as 0
#define CM_E_MAX         CM_REAL(1e30)
#define CM_LN_E_MIN      CM_REAL(-69.07755278982137)   // ln(1e-30): the code for E = 0
#define CM_LN_E_MAX      CM_REAL(69.07755278982137)    // ln(1e30)
#define CM_LN_E_RANGE    CM_REAL(138.15510557964274)   // CM_LN_E_MAX - CM_LN_E_MIN
#define CM_LN_E_ZERO     CM_REAL(-68.38440560926142)   // ln(2e-30): at or below, E reads 0
#define CM_LEN_MIN       CM_REAL(1e-12)
#define CM_LEN_MAX       CM_REAL(1e12)
#define CM_SIGMA_V_MAX   CM_REAL(1.3815510557964274e14) // CM_LN_E_RANGE / CM_LEN_MIN
#define CM_EPS_MAX       CM_REAL(0.99)    // epsilon is clamped to [0, CM_EPS_MAX]
#define CM_CENTRE        CM_REAL(1e-30)   // largest |coordinate| <= this: the entry centre
#define CM_W_MIN         CM_REAL(1e-12)   // sum of weights <= this: no cache hit
#define CM_REDUCE_MARGIN CM_REAL(1e-4)    // Fig. 6: the point ends 1e-4 outside
#endif

// ---- sanitizers ---------------------------------------------------------------------

// Irradiance -> ln E in [CM_LN_E_MIN, CM_LN_E_MAX].  Rule: NaN, negative, 0 and
// anything <= CM_E_MIN give CM_LN_E_MIN (the code for 0); +inf and >= CM_E_MAX give
// CM_LN_E_MAX.  The log is taken only of a number in (CM_E_MIN, CM_E_MAX).
CM_API real CM_FN(ln_irradiance)(real E) {
    if (!cm_isfinite(E)) return E > CM_REAL(0.0) ? CM_LN_E_MAX : CM_LN_E_MIN;
    if (E <= CM_E_MIN) return CM_LN_E_MIN;
    if (E >= CM_E_MAX) return CM_LN_E_MAX;
    return cm_clamp(cm_log(E), CM_LN_E_MIN, CM_LN_E_MAX);
}

// ln E -> E.  Rule: l <= CM_LN_E_ZERO = ln(2e-30), -inf and NaN give exactly 0, so the
// code for 0 (CM_LN_E_MIN) reads back as 0 even after the rounding of a weighted mean
// of such codes (a factor-2 margin in E: the relative rounding of Eq. 11's mean of
// logs is ~1e-6 in float, far below ln 2 / 69); l is capped at CM_LN_E_MAX (+inf
// included), so the exp never overflows (E <= 1e30).  Irradiances in (2e-30, 1e30)
// round-trip through ln_irradiance.
CM_API real CM_FN(irradiance_from_ln)(real l) {
    if (!cm_isfinite(l)) return l > CM_REAL(0.0) ? CM_E_MAX : CM_REAL(0.0);
    if (l <= CM_LN_E_ZERO) return CM_REAL(0.0);
    return cm_exp(cm_min(l, CM_LN_E_MAX));
}

// A logarithm of irradiance from elsewhere (e.g. a stored one).  Rule: NaN -> the code
// for 0; clamped to [CM_LN_E_MIN, CM_LN_E_MAX].
CM_API real CM_FN(san_ln)(real l) {
    if (!cm_isfinite(l)) return l > CM_REAL(0.0) ? CM_LN_E_MAX : CM_LN_E_MIN;
    return cm_clamp(l, CM_LN_E_MIN, CM_LN_E_MAX);
}

// A length (delta, radius).  Rule: NaN -> CM_LEN_MIN; clamped to [CM_LEN_MIN, CM_LEN_MAX]
// (0 or negative -> CM_LEN_MIN, +inf -> CM_LEN_MAX).
CM_API real CM_FN(san_len)(real v) {
    if (!cm_isfinite(v)) return v > CM_REAL(0.0) ? CM_LEN_MAX : CM_LEN_MIN;
    return cm_clamp(v, CM_LEN_MIN, CM_LEN_MAX);
}

// |coordinate| or distance.  Rule: NaN or +-inf -> CM_LEN_MAX (far away); capped there.
CM_API real CM_FN(san_coord)(real c) {
    if (!cm_isfinite(c)) return CM_LEN_MAX;
    return cm_min(cm_abs(c), CM_LEN_MAX);
}

// A virtual extinction coefficient.  Rule: NaN -> 0 (no gradient information);
// +-inf and beyond -> +-CM_SIGMA_V_MAX.
CM_API real CM_FN(san_sigma)(real s) {
    if (!cm_isfinite(s)) {
        if (s > CM_REAL(0.0)) return CM_SIGMA_V_MAX;
        if (s < CM_REAL(0.0)) return -CM_SIGMA_V_MAX;
        return CM_REAL(0.0);
    }
    return cm_clamp(s, -CM_SIGMA_V_MAX, CM_SIGMA_V_MAX);
}

// ---- Eq. 6: virtual extinction along one half-axis ----------------------------------

// sigma_v = -ln(E_delta / E_0) / delta = (ln E_0 - ln E_delta) / delta, from the logs.
// Rules: logs sanitized by san_ln, delta by san_len, hence
//   |sigma_v| <= CM_LN_E_RANGE / delta (138.2 / delta) <= CM_SIGMA_V_MAX;
//   E_delta = E_0 (equal logs, both zero included) -> exactly 0 (flat field);
//   the difference of logs, not the log of a ratio, so 1e30 / 1e-30 cannot overflow.
CM_API real CM_FN(sigma_v_ln)(real lnE0, real lnEd, real delta) {
    real l0 = CM_FN(san_ln)(lnE0);
    real ld = CM_FN(san_ln)(lnEd);
    real d = CM_FN(san_len)(delta);
    return (l0 - ld) / d;
}

// Eq. 6 from irradiances.  Rules (through ln_irradiance, with 0 coded as 1e-30):
//   E_0 = 0 < E_delta:  sigma_v = -(ln E_delta - ln 1e-30) / delta < 0 (growing field;
//                       the extrapolation still passes through E_delta at delta);
//   E_delta = 0 < E_0:  sigma_v = (ln E_0 - ln 1e-30) / delta > 0;
//   both 0 (shadow), E_delta = E_0:  0;
//   NaN, negative -> 0 irradiance; +inf -> 1e30; delta: NaN/<= 0 -> 1e-12, cap 1e12.
CM_API real CM_FN(sigma_v)(real E0, real Ed, real delta) {
    return CM_FN(sigma_v_ln)(CM_FN(ln_irradiance)(E0), CM_FN(ln_irradiance)(Ed), delta);
}

// ---- Eq. 7: extrapolation ---------------------------------------------------------

// ln E(x) = ln E_0 - sigma_v x, at distance x >= 0 from the centre (|x| is used).
// Rules: inputs sanitized (san_ln, san_sigma, san_coord); the result is clamped to
// [CM_LN_E_MIN, CM_LN_E_MAX], so it is finite for every input; E_0 = 0 starts from
// CM_LN_E_MIN (a decaying or flat field stays at the code for 0, a growing one rises
// from 1e-30).  Eq. 11 averages these logs: a zero entry takes part with
// ln E = CM_LN_E_MIN and drags the geometric mean towards 0 (as a true zero would),
// rather than being dropped (which would let light leak into shadow).
CM_API real CM_FN(ln_extrapolate)(real lnE0, real sigma, real dist) {
    real l0 = CM_FN(san_ln)(lnE0);
    real s = CM_FN(san_sigma)(sigma);
    real x = CM_FN(san_coord)(dist);
    return cm_clamp(l0 - s * x, CM_LN_E_MIN, CM_LN_E_MAX);      // |s x| <= 1.4e26
}

// The same from E_0 (as the entry stores it): ln(E_0 exp(-sigma_v x)).
CM_API real CM_FN(log_extrapolate)(real E0, real sigma, real dist) {
    return CM_FN(ln_extrapolate)(CM_FN(ln_irradiance)(E0), sigma, dist);
}

// ---- Eq. 8: barycentric interpolation within an octant -----------------------------

// sigma_v(x,y,z) = (sx |x| + sy |y| + sz |z|) / (|x| + |y| + |z|), where sx, sy, sz
// belong to the half-axes of the point's octant.  Computed as a convex combination
// with weights |x|/s etc. in [0, 1] (no overflow; equal sigmas give that sigma).
// Rules: sigmas by san_sigma, coordinates by san_coord; at the centre
// (|x| + |y| + |z| <= 3 CM_CENTRE) the direction is undefined and the mean
// (sx + sy + sz) / 3 is returned (any finite value gives E_0 at distance 0).
CM_API real CM_FN(sigma_interp)(real sx, real sy, real sz, real x, real y, real z) {
    real a = CM_FN(san_coord)(x), b = CM_FN(san_coord)(y), c = CM_FN(san_coord)(z);
    real s0 = CM_FN(san_sigma)(sx), s1 = CM_FN(san_sigma)(sy), s2 = CM_FN(san_sigma)(sz);
    real s = a + b + c;                                         // <= 3e12
    if (!(s > CM_REAL(3.0) * CM_CENTRE)) return (s0 + s1 + s2) / CM_REAL(3.0);
    return s0 * (a / s) + s1 * (b / s) + s2 * (c / s);
}

// ---- Eq. 9, 10: validity radius -------------------------------------------------------

// Eq. 9 and 10 in terms of sigma_v.  With ln(E_delta / E_0) = -sigma_v delta and
// E_R = (1 +- eps) E_delta:
//   R = delta ln(E_R / E_0) / ln(E_delta / E_0)
//     = delta (ln(1 +- eps) - sigma_v delta) / (-sigma_v delta)
//     = delta + L / |sigma_v|,   L = ln(1 + eps)  if sigma_v <= 0 (E_0 <= E_delta),
//                                L = -ln(1 - eps) if sigma_v > 0  (E_0 > E_delta).
// Meaning (checked by the tests): R is the distance at which the extrapolation Eq. 7
// reaches E_R, i.e. E_0 exp(-sigma_v R) = (1 + eps) E_delta for a growing field and
// (1 - eps) E_delta for a decaying one: it differs by exactly eps, relative to the
// estimate E_delta at delta, from that estimate, in the direction of the change.  So
// R >= delta always, and inside the zone the extrapolation stays between E_0 and E_R
// (it cannot overflow there).  Then R is clamped to [r_min, r_max].
// Rules: sigma_v = 0 (E_delta = E_0, flat in this direction, both zero included) ->
//   r_max (R = infinity); also whenever delta + L/|sigma_v| >= r_max, decided without
//   dividing (L >= |sigma_v| (r_max - delta)), and whenever delta >= r_max;
//   sigma_v non-finite (NaN, +-inf) -> delta clamped to [r_min, r_max] (the limit
//   |sigma_v| -> infinity: an unknown or infinitely steep field gets the smallest
//   radius the formula can give); finite sigma_v is clamped to +-CM_SIGMA_V_MAX;
//   eps: NaN -> 0, clamped to [0, CM_EPS_MAX] (eps = 0 gives R = delta, or r_max when
//   flat); delta: san_len; r_min: san_len; r_max: san_len, then at least r_min
//   (NaN r_max -> r_min).
CM_API real CM_FN(validity_radius_sigma)(real sigma, real delta, real eps, real r_min,
                                         real r_max) {
    real lo = CM_FN(san_len)(r_min);
    real hi = cm_max(CM_FN(san_len)(r_max), lo);
    real d = CM_FN(san_len)(delta);
    if (!cm_isfinite(sigma)) return cm_clamp(d, lo, hi);
    real s = CM_FN(san_sigma)(sigma);
    real e = cm_isfinite(eps) ? cm_clamp(eps, CM_REAL(0.0), CM_EPS_MAX) : CM_REAL(0.0);
    real L = s <= CM_REAL(0.0) ? cm_log(CM_REAL(1.0) + e) : -cm_log(CM_REAL(1.0) - e);
    real a = cm_abs(s);
    if (d >= hi) return hi;
    if (L >= a * (hi - d)) return hi;                           // includes a = 0
    return cm_clamp(d + L / a, lo, hi);                         // a > 0 here
}

// Eq. 9, 10 for one half-axis from the estimates E_0 (centre) and E_delta (at delta):
// validity_radius_sigma(sigma_v(E0, Ed, delta), ...) - equal to the literal Eq. 9 for
// positive finite irradiances; the zero, NaN and inf rules are those of sigma_v (e.g.
// E_0 = 0 < E_delta: sigma_v = -(ln E_delta + 69.08)/delta, R just above delta).
CM_API real CM_FN(validity_radius)(real E0, real Ed, real delta, real eps, real r_min,
                                   real r_max) {
    return CM_FN(validity_radius_sigma)(CM_FN(sigma_v)(E0, Ed, delta), delta, eps, r_min,
                                        r_max);
}

// Fig. 4: the validity radius of the interpolated sigma_v, beyond which an entry's
// influence is discarded.  Derivation: in the direction of the point, the entry's
// model is Eq. 7 with sigma = sigma_v(x,y,z) of Eq. 8, whose value at distance delta
// is E'_delta = E_0 exp(-sigma delta) (exactly E_delta on an axis).  Eq. 9 and 10 with
// E'_delta in place of E_delta give, as above, R(sigma) = delta + L(sigma) / |sigma|,
// clamped to [r_min, r_max]: the distance along this direction at which the
// extrapolation has moved eps beyond its own value at delta.  On an axis it equals that
// axis's radius (before any Fig. 6 reduction); between axes with sigmas of opposite
// sign or very different size it can be far smaller than the ellipsoid (Fig. 4 left).
// Keep the point only if its distance |x| <= this radius.  Rules: those of
// sigma_interp and validity_radius_sigma.
CM_API real CM_FN(interp_validity_radius)(real sx, real sy, real sz, real x, real y,
                                          real z, real delta, real eps, real r_min,
                                          real r_max) {
    return CM_FN(validity_radius_sigma)(CM_FN(sigma_interp)(sx, sy, sz, x, y, z), delta,
                                        eps, r_min, r_max);
}

// ---- §4.2: anisotropic (ellipsoidal) radius, Eq. 11 weight ----------------------------

// The distance that multiplies Eq. 8's sigma_v in Eq. 7: |x| + |y| + |z|, Eq. 8's own
// denominator, so that sigma_v(x,y,z) (|x| + |y| + |z|) = sx |x| + sy |y| + sz |z|.
// With it Eq. 7 + 8 reproduce exactly any field whose logarithm is linear in the local
// coordinates within the octant (a light front: E0 exp(-g . x)), the first-order model
// of every smooth field.  The Euclidean |x| would multiply the exponent by
// |x| / (|x| + |y| + |z|) off the axes, down to 1/sqrt(3) on a diagonal: a first-order
// error that made the seven-point scheme less accurate than a single-gradient
// extrapolation (docs/error.md, "Extrapolation accuracy").  The paper writes Eq. 7 for
// one dimension only.
// Rules: coordinates by san_coord, so the sum is at most 3 CM_LEN_MAX.
CM_API real CM_FN(length1)(real x, real y, real z) {
    return CM_FN(san_coord)(x) + CM_FN(san_coord)(y) + CM_FN(san_coord)(z);
}

// The normalized ellipsoidal distance rho = |x| / r(x) = sqrt(sum x_i^2 / r_i^2) of the
// point in its octant (radii of the half-axes on the point's side): rho < 1 inside,
// 1 on the boundary.  Computed as M sqrt(sum (x_i / M / r_i)^2), M = max |x_i|: the
// largest term has x_i / M = 1 and r_i <= 1e12, so no underflow; rho <= 1.8e24.
// Rules: coordinates by san_coord (NaN -> far away: rho huge), radii by san_len (0 ->
// 1e-12, inf -> 1e12); 0 at the centre.
CM_API real CM_FN(ellipsoid_norm)(real x, real y, real z, real rx, real ry, real rz) {
    real a = CM_FN(san_coord)(x), b = CM_FN(san_coord)(y), c = CM_FN(san_coord)(z);
    real m = cm_max(a, cm_max(b, c));
    if (!(m > CM_CENTRE)) return CM_REAL(0.0);
    real qa = a / m / CM_FN(san_len)(rx);
    real qb = b / m / CM_FN(san_len)(ry);
    real qc = c / m / CM_FN(san_len)(rz);
    return m * cm_sqrt(qa * qa + qb * qb + qc * qc);
}

// §4.2: r(x) = |x| (x_x^2/r_x^2 + x_y^2/r_y^2 + x_z^2/r_z^2)^(-1/2), the distance from
// the centre to the ellipsoid boundary in the direction of x; depends only on the
// direction.  Computed as |u| / sqrt(sum u_i^2 / r_i^2) with u = x / max|x_i| (so it
// is finite for all sanitized inputs) and clamped to [min r_i, max r_i], where it lies
// mathematically.  Rules: radii by san_len; at the centre (direction undefined) the
// smallest of the three radii.
CM_API real CM_FN(ellipsoid_radius)(real x, real y, real z, real rx, real ry, real rz) {
    real a = CM_FN(san_coord)(x), b = CM_FN(san_coord)(y), c = CM_FN(san_coord)(z);
    real ra = CM_FN(san_len)(rx), rb = CM_FN(san_len)(ry), rc = CM_FN(san_len)(rz);
    real rlo = cm_min(ra, cm_min(rb, rc)), rhi = cm_max(ra, cm_max(rb, rc));
    real m = cm_max(a, cm_max(b, c));
    if (!(m > CM_CENTRE)) return rlo;
    a = a / m; b = b / m; c = c / m;
    real qa = a / ra, qb = b / rb, qc = c / rc;                 // largest >= 1e-12
    real r = cm_sqrt(a * a + b * b + c * c) / cm_sqrt(qa * qa + qb * qb + qc * qc);
    return cm_clamp(r, rlo, rhi);
}

// Eq. 11 weight from rho = |x| / r(x): w = 3 d^2 - 2 d^3, d = 1 - rho clamped to
// [0, 1]: 1 at the centre, 0 on and beyond the boundary, decreasing in between.
// Rule: NaN -> 0.
CM_API real CM_FN(weight_norm)(real rho) {
    if (!cm_isfinite(rho)) return CM_REAL(0.0);
    real d = cm_clamp(CM_REAL(1.0) - rho, CM_REAL(0.0), CM_REAL(1.0));
    return d * d * (CM_REAL(3.0) - CM_REAL(2.0) * d);
}

// Eq. 11 weight from the distance |x| and the radius r(x) in its direction.
// Rules: dist by san_coord (NaN -> far: 0), r by san_len (0 -> 1e-12).
CM_API real CM_FN(weight)(real dist, real r) {
    return CM_FN(weight_norm)(CM_FN(san_coord)(dist) / CM_FN(san_len)(r));   // <= 1e24
}

// ---- Eq. 11: log-space weighted average ------------------------------------------------
// The sums sum_k w_k ln E_k and sum_k w_k are taken in cache.glsl (eval_entry), from
// weight and the logs of Eq. 7.

// True when the sum of weights makes a cache hit: finite and > CM_W_MIN (1e-12).
CM_API bool CM_FN(log_average_valid)(real sum_w) {
    return cm_isfinite(sum_w) && sum_w > CM_W_MIN;
}

// Eq. 11: E = exp(sum_k w_k ln E_k / sum_k w_k).  Rules: no hit (log_average_valid
// false: sum_w <= 1e-12, NaN or inf) -> 0, and the caller must shade by Monte Carlo;
// sum_wlog NaN or -inf -> 0, +inf -> 1e30; the mean log is clamped to
// [CM_LN_E_MIN, CM_LN_E_MAX] (rounding, or weights not in [0, 1]), so E is in
// [0, 1e30] and a mean at the code for 0 (e.g. all entries fully shadowed) gives
// exactly 0 (irradiance_from_ln's margin absorbs the rounding of the mean).  The division is by at least 1e-12.
CM_API real CM_FN(log_average_finalize)(real sum_wlog, real sum_w) {
    if (!CM_FN(log_average_valid)(sum_w)) return CM_REAL(0.0);
    if (!cm_isfinite(sum_wlog)) return sum_wlog > CM_REAL(0.0) ? CM_E_MAX : CM_REAL(0.0);
    // |sum_wlog| <= 1e24 (no change for valid sums: |sum_wlog| <= 69.1 sum_w and
    // sum_w <= number of entries), so the quotient is <= 1e36: finite in float.
    real num = cm_clamp(sum_wlog, CM_REAL(-1e24), CM_REAL(1e24));
    return CM_FN(irradiance_from_ln)(cm_clamp(num / sum_w, CM_LN_E_MIN, CM_LN_E_MAX));
}

// ---- §4.3, Fig. 6: radius reduction ------------------------------------------------

// The common factor f for the three radii of the event's octant, so that the event P
// at local coordinates (x, y, z) ends just outside the reduced section.  Derivation:
// scaling all three radii by f scales rho = |P| / r(P) (ellipsoid_norm) by 1/f, so
// f = rho puts P exactly on the boundary, where the Eq. 11 weight is 0; the reduction
// of radius i is r_i (1 - rho), and the shape of the section (the ratios of its radii)
// is kept, the new section passing through P - the reduction "proportional to P's
// coordinates" read as: along the ray through P, the boundary moves exactly to P.  We
// take f = rho (1 - CM_REDUCE_MARGIN), so that P lies robustly outside (new rho =
// 1 / (1 - 1e-4)) despite rounding.  Rules: P on or outside the boundary (rho >= 1, or
// NaN coordinates: far away) -> 1 (no change); P at the centre (rho = 0) -> 0 (no
// positive radius excludes it: reduced_radius then gives r_min).
CM_API real CM_FN(reduce_factor)(real x, real y, real z, real rx, real ry, real rz) {
    real rho = CM_FN(ellipsoid_norm)(x, y, z, rx, ry, rz);
    if (!(rho < CM_REAL(1.0))) return CM_REAL(1.0);
    return cm_clamp(rho * (CM_REAL(1.0) - CM_REDUCE_MARGIN), CM_REAL(0.0),
                    CM_REAL(1.0));
}

// One reduced radius: f r, but not below r_min and never larger than r.  Rules: r and
// r_min by san_len; f NaN -> 1 (no change), clamped to [0, 1].  When the r_min floor
// applies, P may stay inside (the zone cannot shrink further).
CM_API real CM_FN(reduced_radius)(real r, real f, real r_min) {
    real rs = CM_FN(san_len)(r);
    real fs = cm_isfinite(f) ? cm_clamp(f, CM_REAL(0.0), CM_REAL(1.0)) : CM_REAL(1.0);
    return cm_min(rs, cm_max(CM_FN(san_len)(r_min), fs * rs));
}

// ---- the entry's own offset: Delta of Eq. 6 at most CM_DELTA_MFP mean free paths ------

// Table 1's Delta = 2 voxels presumes that the irradiance changes on the scale of voxels.
// In a medium denser than one extinction per voxel it falls by e^-(sigma_t Delta) over
// the offset: at 10 per voxel by e^-20, which a few hundred Monte-Carlo samples at the
// offset point cannot resolve (the estimate E_delta is 0 or one lucky sample), so Eq. 6
// and 10 get sigma_v and the radii wrong and bias the cache (tests/test_robust_sweep.c,
// docs/robustness.md).  So each entry takes
//   delta_e = min(Delta, CM_DELTA_MFP / sigma_local),
// sigma_local the largest extinction at the centre and at the six Table 1 offset points:
// at most two mean free paths, where E_delta / E_0 >= e^-2 for light along the axis.
// Scenes with sigma_t <= 1 per voxel (CM_DELTA_MFP / Delta) keep Table 1's Delta exactly.
// Rules: sigma_local <= 0, NaN or below the threshold -> Delta (san_len); +inf or any
// larger value -> at least CM_DELTA_FLOOR Delta (1e-5: two offset points stay distinct
// in float near the box, and the ratio of lengths stays far from underflow); decided
// without forming sigma_local * Delta (which could overflow).
#ifndef CM_DELTA_CONSTANTS
#define CM_DELTA_CONSTANTS 1
#define CM_DELTA_MFP     CM_REAL(2.0)     // the offset in mean free paths, at most
#define CM_DELTA_FLOOR   CM_REAL(1e-5)    // delta_e >= this * Delta
#endif
CM_API real CM_FN(entry_delta)(real delta, real sigma_local) {
    real d = CM_FN(san_len)(delta);
    real lo = cm_max(d * CM_DELTA_FLOOR, CM_LEN_MIN);
    if (!cm_isfinite(sigma_local)) return sigma_local > CM_REAL(0.0) ? lo : d;
    if (!(sigma_local > CM_DELTA_MFP / d)) return d;           // CM_DELTA_MFP / d <= 2e12
    return cm_clamp(CM_DELTA_MFP / sigma_local, lo, d);         // sigma_local > 2e-12
}

// The entry's minimum radius: Table 1's r_min scaled like its offset, r_min delta_e /
// Delta, so that an entry in a dense medium is not forced to cover hundreds of mean free
// paths (r_min = 0.01 voxel is 100 of them at 1e4 per voxel).  Equals r_min when
// delta_e = Delta.  Rules: lengths by san_len; the ratio delta_e / Delta is clamped to
// [0, 1] (an entry never gets a larger minimum); the result is at least CM_LEN_MIN.
CM_API real CM_FN(entry_r_min)(real r_min, real delta_e, real delta) {
    real q = cm_clamp(CM_FN(san_len)(delta_e) / CM_FN(san_len)(delta), CM_REAL(0.0), CM_REAL(1.0));
    return cm_max(CM_FN(san_len)(r_min) * q, CM_LEN_MIN);
}

// The entry's maximum radius, scaled the same way: r_max delta_e / Delta (entry_r_min's
// arithmetic and rules).  Why: where the offset is two mean free paths, a flat estimate
// along an axis says that the field is flat over those two mean free paths, not over
// Table 1's 16 voxels - 160 to 1.6e6 mean free paths at 10 to 1e5 per voxel, across
// which an entry at one face of a dense cube extrapolates into the next face, lit from
// another side, and darkens it (tests/test_robust_sweep.c).
// Equals r_max when delta_e = Delta (every scene up to one extinction per voxel).
CM_API real CM_FN(entry_r_max)(real r_max, real delta_e, real delta) {
    return CM_FN(entry_r_min)(r_max, delta_e, delta);
}

// ---- the curvature limit of the validity radius (picvr's addition to Eq. 9, 10) -------

// Eq. 9 and 10 bound the extrapolation error beyond delta by eps, trusting that the field
// is exponential between the centre and the offset point.  The seven points can test
// that: along each axis of the frame the estimates at -delta, 0 and +delta give the
// second difference of ln E,
//   m = |ln E(+delta) + ln E(-delta) - 2 ln E_0|,
// which is 0 for every exponential field (ln E linear).  For a field whose logarithm is
// quadratic, curvature kappa = m / delta^2, Eq. 6's one-sided secant misses ln E inside
// the offset by kappa r (delta - r) / 2, up to m / 8 at delta / 2.  Where m / 8 exceeds
// L = ln(1 + eps) the exponential model fails within the offset itself - at a lit face
// (the outward offset point lies in air, where E stops growing, so Eq. 6 underestimates
// the growth toward the face) and at a shadow edge (E = 0 on one side) - and both
// half-axes of that axis get the radius at which the secant's error reaches L:
//   kappa r (delta - r) / 2 = L   =>   r = delta (1 - sqrt(1 - 8 L / m)) / 2 < delta / 2,
// computed as 4 delta L / (m (1 + sqrt(1 - 8 L / m))) (no cancellation for large m);
// elsewhere no limit (r_max).  Why: with the paper's Eq. 6, 7 and Eq. 9, 10 alone a full
// cache darkens lit faces and shadow edges; the limit removes most of that bias, but the
// entries shrink so much (a zero next to a lit estimate gives r_min) that the hit rate
// stays low.  The medium model (medium_fraction) removes that bias without shrinking
// anything, so the limit is off by default (cfg.cache.curvature_limit; docs/cache.md,
// "The bias of a full cache").
// Rules: logs by san_ln (E = 0 is ln 1e-30, so a zero next to a positive estimate gives
// m >= 69 - |ln E|, hence r below 3e-3 delta: r_min in practice; all three zero: m = 0,
// no limit); eps: NaN -> 0, clamped to [0, CM_EPS_MAX] (eps = 0: any curvature gives
// r_min); delta, r_min by san_len; r_max by san_len, at least r_min.  m <= 4 CM_LN_E_RANGE.
CM_API real CM_FN(curvature_radius)(real lnEm, real lnE0, real lnEp, real delta, real eps,
                                    real r_min, real r_max) {
    real lo = CM_FN(san_len)(r_min);
    real hi = cm_max(CM_FN(san_len)(r_max), lo);
    real d = CM_FN(san_len)(delta);
    real e = cm_isfinite(eps) ? cm_clamp(eps, CM_REAL(0.0), CM_EPS_MAX) : CM_REAL(0.0);
    real L = cm_log(CM_REAL(1.0) + e);
    real m = cm_abs(CM_FN(san_ln)(lnEp) + CM_FN(san_ln)(lnEm) - CM_REAL(2.0) * CM_FN(san_ln)(lnE0));
    if (!(m > CM_REAL(8.0) * L)) return hi;                     // includes m = 0
    real q = CM_REAL(8.0) * L / m;                              // in [0, 1), m > 0 here
    return cm_clamp(CM_REAL(4.0) * d * L / (m * (CM_REAL(1.0) + cm_sqrt(CM_REAL(1.0) - q))), lo, hi);
}

// ---- the medium fraction of a half-axis (picvr's addition: lit and unlit faces) -------

// Eq. 6's secant assumes that ln E changes evenly over delta.  Where the half-axis
// leaves the medium within delta (at a face: the offset point lies in air), the light
// is attenuated inside the medium and nowhere else, so the whole change
// ln(E_delta / E_0) happens over the first s = f delta and the field is flat beyond.
// f is the part of delta that lies in the medium: the fraction of CM_F_PROBES probes, at
// the midpoints of equal parts of delta, where the extinction is not zero (n_in of them).
// Used on the normal axis n (the extinction gradient), the one that crosses faces; along
// t and b the extinction is constant to first order.
// Why: with the paper's secant the lit faces of a dense object are extrapolated too
// dark (the outward offset point in air makes the secant half as steep as the field
// inside; tests/test_cache.c, test_cache_full_dense_lit_face).
// Why a count and not the optical depth: f = tau / (sigma_0 delta), the length of medium
// *of the centre's density*, would stretch axes that never leave the medium: entries
// sit at scatter events, where the extinction is high, so sigma_0 tends to exceed the
// extinction along the axis and f < 1 (docs/cache.md, "Entry noise and the dark pot").
// Rules: n_in NaN or +inf -> 1 (the paper's secant), -inf -> CM_F_MIN; n_in >=
// CM_F_PROBES -> exactly 1 (a homogeneous medium keeps Eq. 7 exact); n_in <= 0 (the axis
// leaves the medium at once) -> CM_F_MIN; otherwise n_in / CM_F_PROBES, at least CM_F_MIN.
#ifndef CM_F_CONSTANTS
#define CM_F_CONSTANTS 1
#define CM_F_PROBES CM_REAL(8.0)
#define CM_F_MIN CM_REAL(0.125)   // one probe: the quadrature's resolution
#endif
CM_API real CM_FN(medium_fraction)(real n_in) {
    if (!cm_isfinite(n_in)) return n_in < CM_REAL(0.0) ? CM_F_MIN : CM_REAL(1.0);
    if (n_in >= CM_F_PROBES) return CM_REAL(1.0);
    return cm_clamp(n_in / CM_F_PROBES, CM_F_MIN, CM_REAL(1.0));
}

// The coordinate along a half-axis at which Eq. 7 and 8 evaluate the model: the change
// of the secant happens over [0, f delta] and none over [f delta, delta]; beyond delta
// the paper's slope continues:  u = min(x / f, delta) + max(x - delta, 0).
// f = 1 gives u = x (the paper); continuous in f and x; x <= u <= max(x, delta), and
// sigma_v u equals ln(E_0 / E_delta) at x = f delta, so on its own axis the model passes
// through both estimates.  Off the axes Eq. 8 with these coordinates can leave the range
// of the estimates (each axis may contribute its whole change at once), so the shader
// bounds the result by medium_bound.  Rules: x by san_coord; f NaN -> 1, clamped to
// [CM_F_MIN, 1]; delta by san_len; finite (u <= 2 CM_LEN_MAX).
CM_API real CM_FN(medium_coord)(real x, real f, real delta) {
    real a = CM_FN(san_coord)(x);
    real fs = cm_isfinite(f) ? cm_clamp(f, CM_F_MIN, CM_REAL(1.0)) : CM_REAL(1.0);
    real d = CM_FN(san_len)(delta);
    if (fs >= CM_REAL(1.0)) return a;
    return cm_min(a / fs, d) + cm_max(a - d, CM_REAL(0.0));
}

// The range the stretched model may take in an octant: ln E between the smallest and the
// largest of ln E_0 and the three offset estimates ln E_0 - sigma_i delta, widened by L =
// ln(1 + eps) (the paper's own model moves at most that far beyond them inside its
// validity radius).  Returns l clamped to it.  Rules: logs by san_ln, sigmas by
// san_sigma, delta by san_len, eps NaN -> 0, clamped to [0, CM_EPS_MAX]; the result lies
// in [CM_LN_E_MIN, CM_LN_E_MAX].
CM_API real CM_FN(medium_bound)(real l, real lnE0, real sx, real sy, real sz, real delta, real eps) {
    real l0 = CM_FN(san_ln)(lnE0);
    real lx = CM_FN(ln_extrapolate)(l0, sx, delta), ly = CM_FN(ln_extrapolate)(l0, sy, delta);
    real lz = CM_FN(ln_extrapolate)(l0, sz, delta);
    real e = cm_isfinite(eps) ? cm_clamp(eps, CM_REAL(0.0), CM_EPS_MAX) : CM_REAL(0.0);
    real L = cm_log(CM_REAL(1.0) + e);
    real lo = cm_min(cm_min(l0, lx), cm_min(ly, lz)) - L;
    real hi = cm_max(cm_max(l0, lx), cm_max(ly, lz)) + L;
    return cm_clamp(CM_FN(san_ln)(l), cm_max(lo, CM_LN_E_MIN), cm_min(hi, CM_LN_E_MAX));
}

// ---- Eq. 5's sample statistics (cache_create.comp) -----------------------------------
// Eq. 5 needs the spread S^2 of each point's samples.  A set of samples is kept as
// (n, mean, m2) with m2 = sum (l - mean)^2, and two sets are merged by the pairwise rule
// of Chan, Golub and LeVeque (one sample is the set (1, l, 0): Welford's update).  The
// textbook E[l^2] - E[l]^2 from float sums subtracts two numbers that agree to every digit
// once the samples agree to about 1e-4 of their mean (float's 6e-8 per rounding, ~1e3
// terms), which turns S^2 into rounding noise and flips Eq. 5 either way at a small
// gamma; the merge never subtracts two large numbers, so S^2 keeps its digits (and is
// exactly 0 for identical samples).
// Rules (so that no square or sum can overflow float and every output is finite):
//   sample l    NaN -> 0; clamped to [-CM_STAT_MAX, CM_STAT_MAX] (+-inf to the bound);
//   count n     NaN or negative -> 0; capped at CM_STAT_N_MAX;
//   mean        as a sample;  m2  NaN or negative -> 0; capped at CM_STAT_M2_MAX;
//   a merge of two empty sets (n_a + n_b = 0) gives mean 0 and m2 0.
// Then |mean_b - mean_a| <= 2e15, the merge's term d^2 n_a n_b / n <= 4e30 * 1e6 / 2 =
// 2e36 (n_a n_b / n <= min(n_a, n_b)), so its sum with two m2 <= CM_STAT_M2_MAX stays
// below 4e36, far under float's 3.4e38.
#ifndef CM_STAT_CONSTANTS
#define CM_STAT_CONSTANTS 1
#define CM_STAT_MAX    CM_REAL(1e15)
#define CM_STAT_N_MAX  CM_REAL(1e6)
#define CM_STAT_M2_MAX CM_REAL(1e36)
#endif
CM_API real CM_FN(stat_sample)(real l) {
    if (!cm_isfinite(l)) return l > CM_REAL(0.0) ? CM_STAT_MAX : (l < CM_REAL(0.0) ? -CM_STAT_MAX : CM_REAL(0.0));
    return cm_clamp(l, -CM_STAT_MAX, CM_STAT_MAX);
}

CM_API real CM_FN(stat_count)(real n) {
    if (!cm_isfinite(n)) return n > CM_REAL(0.0) ? CM_STAT_N_MAX : CM_REAL(0.0);
    return cm_clamp(n, CM_REAL(0.0), CM_STAT_N_MAX);
}

CM_API real CM_FN(stat_m2)(real m2) {
    if (!cm_isfinite(m2)) return m2 > CM_REAL(0.0) ? CM_STAT_M2_MAX : CM_REAL(0.0);
    return cm_clamp(m2, CM_REAL(0.0), CM_STAT_M2_MAX);
}

// The mean of the union of two sets: mean_a + (mean_b - mean_a) n_b / n.
CM_API real CM_FN(stat_merge_mean)(real n_a, real mean_a, real n_b, real mean_b) {
    real na = CM_FN(stat_count)(n_a), nb = CM_FN(stat_count)(n_b);
    real ma = CM_FN(stat_sample)(mean_a), mb = CM_FN(stat_sample)(mean_b);
    if (na + nb <= CM_REAL(0.0)) return CM_REAL(0.0);
    return ma + (mb - ma) * (nb / (na + nb));
}

// The m2 of the union of two sets: m2_a + m2_b + (mean_b - mean_a)^2 n_a n_b / n.
CM_API real CM_FN(stat_merge_m2)(real n_a, real mean_a, real m2_a, real n_b, real mean_b,
                                 real m2_b) {
    real na = CM_FN(stat_count)(n_a), nb = CM_FN(stat_count)(n_b);
    real d = CM_FN(stat_sample)(mean_b) - CM_FN(stat_sample)(mean_a);
    if (na + nb <= CM_REAL(0.0)) return CM_REAL(0.0);
    return CM_FN(stat_m2)(CM_FN(stat_m2)(m2_a) + CM_FN(stat_m2)(m2_b) + d * d * (na * (nb / (na + nb))));
}

// Eq. 5 for a set of n samples:  1.96 sqrt(S^2 / n) <= gamma / (gamma + 1) mean, with the
// sample variance S^2 = m2 / (n - 1).  Rules: n < 2 -> not met (no spread to judge);
// mean 0 with m2 0 (a fully shadowed point) -> met; a negative mean -> not met; gamma NaN
// or negative -> 0 (met only without spread), +inf -> 1 (gamma / (gamma + 1) -> 1).
CM_API bool CM_FN(eq5_met)(real n, real mean, real m2, real gamma) {
    real nn = CM_FN(stat_count)(n);
    if (nn < CM_REAL(2.0)) return false;
    real g = cm_isfinite(gamma) ? cm_max(gamma, CM_REAL(0.0)) : (gamma > CM_REAL(0.0) ? CM_REAL(1.0) : CM_REAL(0.0));
    real rel = cm_isfinite(gamma) ? g / (g + CM_REAL(1.0)) : g;
    real s2 = CM_FN(stat_m2)(m2) / (nn - CM_REAL(1.0));
    return CM_REAL(1.96) * cm_sqrt(s2 / nn) <= rel * CM_FN(stat_sample)(mean);
}

#ifdef CM_GLSL
#undef real
#endif

#endif // !CM_GLSL || !CACHE_MATH_GLSL_ONCE
