/* cache_math_host.h - the C prelude of shaders/cache_math.glsl and
 * shaders/sampling_math.glsl: compiles the very same
 * source twice on the host, in double precision (functions cm_<name>, as in the
 * shaders) and in float (functions cmf_<name>, the shaders' precision).  All functions
 * are static inline, so any number of translation units may include this header.
 * The macro contract (real, CM_FN, CM_API, CM_REAL, cm_log ...) is described at the top
 * of cache_math.glsl. */
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
