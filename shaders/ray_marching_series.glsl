// ray_marching_series.glsl - the unbiased ray-marching transmittance estimator (after
// Kettunen et al. 2021, "An Unbiased Ray-Marching Transmittance Estimator"), its power
// series about a pivot, written in the common subset of C and GLSL (rules at the top of
// cache_math.glsl) so that tests/test_beer_lambert.c runs this very code in double on
// optical-depth profiles it knows exactly.
//
// The includer supplies the medium through hooks, defined before each include:
//   RM_PARAMS     the parameter list of the function below (the ray, the generator);
//   RM_COMB()     X, one unbiased estimate of the segment's optical depth tau (a
//                 stratified comb: transmittance.glsl, comb_optical_depth), E[X] = tau;
//   RM_RND()      a uniform number in [0, 1);
//   RM_TRUNCATE() a statement that flags the estimate as truncated (biased).
// and then has CM_FN(ray_marching_series).
//
// exp(-tau) = exp(-c) sum_k (c - tau)^k / k! about a pivot c = X_0 (one comb).  The k-th
// power is estimated by the product of k further independent combs, so each term is
// unbiased given c; the first order is always taken, order k >= 2 with probability p_k =
// min(1, |W_{k-1}|) (Russian roulette on the weighted term W, which carries 1 / (p_1 ...
// p_k)), so the sum is unbiased too.  Rules for the degenerate cases:
//   - a pivot darker than RM_DARK survives with probability exp(RM_DARK - c) and is then
//     weighted by its inverse (unbiased; these paths are dim), written as exp(-RM_DARK)
//     so that nothing overflows however dense the medium;
//   - past RM_MAX_ORDER orders the series is cut and flagged (the roulette makes that
//     vanishingly rare: |W_k| falls like tau-spread^k / k!);
//   - the estimate may be negative (rarely, where a comb misses much of the medium); the
//     caller's mean stays unbiased;
//   - never a shortcut on c = 0: a pivot may miss a thin sheet that the next comb finds.
#include "c_subset.glsl"

#define RM_DARK 6.9         // pivots darker than exp(-6.9) = 1e-3 go to Russian roulette
#define RM_MAX_ORDER 16

#ifdef CM_GLSL
#define real float
#endif

CM_API real CM_FN(ray_marching_series)(RM_PARAMS) {
    real c = RM_COMB();
    real base = cm_exp(-c);
    if (c > CM_REAL(RM_DARK)) {
        if (RM_RND() >= cm_exp(CM_REAL(RM_DARK) - c)) return CM_REAL(0.0);
        base = cm_exp(CM_REAL(-RM_DARK));   // exp(-c) / exp(RM_DARK - c), without overflow
    }
    real sum = CM_REAL(1.0), term = CM_REAL(1.0);
    for (int k = 1; k <= RM_MAX_ORDER; k++) {
        real p = k == 1 ? CM_REAL(1.0) : cm_min(CM_REAL(1.0), cm_abs(term));
        if (p < CM_REAL(1.0) && RM_RND() >= p) break;
        real X = RM_COMB();
        term *= (c - X) / (CM_REAL(k) * p);
        sum += term;
        if (k == RM_MAX_ORDER) RM_TRUNCATE();
    }
    return base * sum;
}

#ifdef CM_GLSL
#undef real
#endif
