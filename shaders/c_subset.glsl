// c_subset.glsl - the GLSL side of the macros of the files written in the common subset
// of C and GLSL (cache_math.glsl, sampling_math.glsl; their rules are at the top of
// cache_math.glsl).  Each such file defines `real` itself (float in GLSL) and undefines
// it at its end; reference/cache_math_host.h defines the C side of all of them.  In C
// this file defines nothing.
#if defined(GL_core_profile) || defined(GL_SPIRV) || defined(VULKAN) || defined(GL_ES)
#define CM_GLSL 1
#endif

#if defined(CM_GLSL) && !defined(C_SUBSET_GLSL_ONCE)
#define C_SUBSET_GLSL_ONCE 1
#define CM_FN(name) cm_##name
#define CM_API
#define CM_REAL(x) float(x)
#define cm_log(x) log(x)
#define cm_exp(x) exp(x)
#define cm_sqrt(x) sqrt(x)
#define cm_abs(x) abs(x)
#define cm_min(a, b) min(a, b)
#define cm_max(a, b) max(a, b)
#define cm_clamp(x, lo, hi) clamp(x, lo, hi)
#define cm_atan2(y, x) atan(y, x)
#define cm_tan(x) tan(x)
// Exponent-bit test instead of isnan/isinf, which a compiler may fold to false under
// the Vulkan rule that lets it assume no NaN or inf.
#define cm_isfinite(x) ((floatBitsToUint(x) & 0x7f800000u) != 0x7f800000u)
#endif
