/* cache_math_host.h - the C prelude of shaders/cache_math.glsl and
 * shaders/sampling_math.glsl: compiles the very same
 * source twice on the host, in double precision (functions cm_<name>, as in the
 * shaders) and in float (functions cmf_<name>, the shaders' precision).  All functions
 * are static inline, so any number of translation units may include this header.
 * The macro contract (real, CM_FN, CM_API, CM_REAL, cm_log ...) is described at the top
 * of cache_math.glsl.
 * Each instantiation also compiles the host-only formulas at the end of this file (the
 * file includes itself with CM_HOST_FORMULAS defined): closed forms that the tests and
 * bench/bench_fig9.c use and the kernels do not, written in the same common subset, so
 * that the shaders' cache_math.glsl holds only what the library runs. */
#ifndef CM_HOST_FORMULAS
#ifndef PICVR_CACHE_MATH_HOST_H
#define PICVR_CACHE_MATH_HOST_H

#include <math.h>
#include <stdbool.h>

#define CM_API static inline
#define CM_REAL(x) ((real)(x))
#define cm_isfinite(x) isfinite(x)

/* ---- double: cm_<name> ---- */
#define real double
#define CM_FN(name) cm_##name
#define cm_log(x) log(x)
#define cm_exp(x) exp(x)
#define cm_sqrt(x) sqrt(x)
#define cm_abs(x) fabs(x)
#define cm_min(a, b) fmin(a, b)
#define cm_max(a, b) fmax(a, b)
#define cm_clamp(x, lo, hi) fmin(fmax(x, lo), hi)
#define cm_atan2(y, x) atan2(y, x)
#define cm_tan(x) tan(x)
#include "shaders/cache_math.glsl"
#define CM_HOST_FORMULAS 1
#include "cache_math_host.h"
#undef CM_HOST_FORMULAS
#include "shaders/sampling_math.glsl"
/* shaders/sobol.glsl: integers only, so compiled once (cm_sobol_*) */
#include <stdint.h>
typedef uint32_t cm_uint;
static inline cm_uint cm_bitrev(cm_uint x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0f0f0f0fu) | ((x & 0x0f0f0f0fu) << 4);
    x = ((x >> 8) & 0x00ff00ffu) | ((x & 0x00ff00ffu) << 8);
    return (x >> 16) | (x << 16);
}
#include "shaders/sobol.glsl"
#undef real
#undef CM_FN
#undef cm_log
#undef cm_exp
#undef cm_sqrt
#undef cm_abs
#undef cm_min
#undef cm_max
#undef cm_clamp
#undef cm_atan2
#undef cm_tan

/* ---- float: cmf_<name> ---- */
#define real float
#define CM_FN(name) cmf_##name
#define cm_log(x) logf(x)
#define cm_exp(x) expf(x)
#define cm_sqrt(x) sqrtf(x)
#define cm_abs(x) fabsf(x)
#define cm_min(a, b) fminf(a, b)
#define cm_max(a, b) fmaxf(a, b)
#define cm_clamp(x, lo, hi) fminf(fmaxf(x, lo), hi)
#define cm_atan2(y, x) atan2f(y, x)
#define cm_tan(x) tanf(x)
#include "shaders/cache_math.glsl"
#define CM_HOST_FORMULAS 1
#include "cache_math_host.h"
#undef CM_HOST_FORMULAS
#include "shaders/sampling_math.glsl"
#undef real
#undef CM_FN
#undef cm_log
#undef cm_exp
#undef cm_sqrt
#undef cm_abs
#undef cm_min
#undef cm_max
#undef cm_clamp
#undef cm_atan2
#undef cm_tan

/* The constants (CM_EPS, CM_LN_E_MIN, ...) expand to CM_REAL(x) where they are used;
   both instantiations above are already expanded, so from here on CM_REAL is the plain
   literal and the constants are doubles in host code. */
#undef CM_REAL
#define CM_REAL(x) (x)

#endif /* PICVR_CACHE_MATH_HOST_H */

#else /* CM_HOST_FORMULAS: the host-only formulas, once per instantiation */

/* The radius of the half-axis on the point's side: r_pos for c >= 0 (the centre and
   -0 included), r_neg for c < 0 (and for NaN).  (The kernels pick the half-axis's
   index instead: cache.glsl, zone_at.) */
CM_API real CM_FN(half_axis)(real c, real r_pos, real r_neg) {
    return c >= CM_REAL(0.0) ? r_pos : r_neg;
}

/* Eq. 7: E(x) = E_0 exp(-sigma_v x) = irradiance_from_ln(log_extrapolate): in
   [0, 1e30], exactly 0 where the log is at the code for 0.  (The kernels average the
   logs first, Eq. 11, and take the exp once: log_average_finalize.) */
CM_API real CM_FN(extrapolate)(real E0, real sigma, real dist) {
    return CM_FN(irradiance_from_ln)(CM_FN(log_extrapolate)(E0, sigma, dist));
}

/* |x| without overflow or underflow: M sqrt(sum (x_i / M)^2), M = max |x_i|.
   Rules: coordinates by san_coord; 0 at the centre (max |x_i| <= CM_CENTRE). */
CM_API real CM_FN(length3)(real x, real y, real z) {
    real a = CM_FN(san_coord)(x), b = CM_FN(san_coord)(y), c = CM_FN(san_coord)(z);
    real m = cm_max(a, cm_max(b, c));
    if (!(m > CM_CENTRE)) return CM_REAL(0.0);
    a = a / m; b = b / m; c = c / m;
    return m * cm_sqrt(a * a + b * b + c * c);
}

/* ln E at local coordinates (x, y, z) of the octant whose half-axes have sx, sy, sz:
   Eq. 7 with sigma = sigma_interp (Eq. 8) and the distance length1.  (The kernels add
   the medium model's stretch of the normal coordinate: cache.glsl, predict.) */
CM_API real CM_FN(log_extrapolate_octant)(real E0, real sx, real sy, real sz,
                                          real x, real y, real z) {
    return CM_FN(log_extrapolate)(E0, CM_FN(sigma_interp)(sx, sy, sz, x, y, z),
                                  CM_FN(length1)(x, y, z));
}

/* One term w ln E_k of Eq. 11's numerator.  Rules: w NaN -> 0, clamped to [0, 1];
   ln E by san_ln; so each term lies in [-69.1, 69.1]. */
CM_API real CM_FN(weighted_ln)(real w, real lnE) {
    real ws = cm_isfinite(w) ? cm_clamp(w, CM_REAL(0.0), CM_REAL(1.0)) : CM_REAL(0.0);
    return ws * CM_FN(san_ln)(lnE);
}

#endif /* CM_HOST_FORMULAS */
