// distance.glsl - where a camera ray's light is gathered (paper §3, Eq. 4 along the ray):
// free-flight sampling by delta tracking combined with equiangular sampling toward the
// lights (Kulla and Fajardo 2012) by multiple importance sampling, so that a ray through
// thin medium still gathers the in-scattered light of a nearby light.  The scalar
// formulas are in sampling_math.glsl; USE_EQUIANGULAR (specialization.glsl) turns it on.
//
// The estimator.  Along the camera ray over its medium segment [t0, t1] the pixel sees
//   L = int_t0^t1 T(t) sigma_s(t) L_s(t) dt + T(t1) L_end,
// (L_s in-scattered radiance, L_end the area light or background at the end).  Per
// camera sample:
//  A. delta tracking draws t_A with density p_A(t) = sigma_t(t) T(t) (or passes); its
//     estimate of the integral, albedo L_s(t_A), is weighted by w_A(t_A);
//  B. equiangular sampling draws t_B with density p_B(t) (a mixture over the lights it
//     serves, chosen by eq_pmf); its estimate is w_B(t_B) T^(t_B) sigma_s(t_B)
//     L_s(t_B) / p_B(t_B), with T^ an unbiased transmittance estimate (residual ratio
//     tracking) from random numbers drawn after t_B;
//  C. the end term T^(t1) L_end, with T^(t1) = T^(t_B) times an independent estimate
//     over [t_B, t1] (unbiased: disjoint segments, independent estimates).
// The weights are the power heuristic's, w_A = q^2 / (q^2 + p_B^2) and w_B = p_B^2 /
// (q^2 + p_B^2), with q(t) = sigma_t(t) exp(-tau_min(t)), a deterministic proxy of p_A
// (tau_min: the minorant's optical depth from t0, so q >= p_A: B's weight is never
// overstated where the proxy is loose, and B's estimate stays bounded by T^ / T there).
// Unbiasedness: E[A] = int w_A(t) sigma_s T L_s dt (delta tracking's density cancels
// sigma_t T), E[B] = int w_B(t) sigma_s T L_s dt (E[T^(t)] = T(t), independent of the
// choice of t), and w_A + w_B = 1 at every t where either density is positive
// (sampling_math.glsl, mis_power: a point only A reaches gets w_A = 1 there), so
// E[A + B] = the integral, whatever q is; q close to p_A only makes the variance small.
// Delta tracking's escape contributes nothing (the end term is C), and the coverage is
// 1 - T^(t1).
// Leave-out: USE_EQUIANGULAR is on only when some light is served (host/pipelines.c,
// picvr_update_equiangular: a point, sphere or rect light whose 1/d^2 falls off steeply
// across the volume); otherwise the camera ray is the paper's delta tracking alone.
#ifndef DISTANCE_GLSL_ONCE
#define DISTANCE_GLSL_ONCE 1
#include "specialization.glsl"
#include "limits.glsl"
#include "scene.glsl"
#include "sampling_math.glsl"
#include "majorant.glsl"
#include "tracking.glsl"

// The perpendicular from light i's centre to the ray: x = Delta, y = D (at least
// 1e-3 of the smallest voxel spacing, the floor the point light's distance has).
vec2 eq_foot(uint i, vec3 ro, vec3 rd) {
    vec3 oc = scene.lights[i].pos - ro;
    float delta = dot(oc, rd);
    float D = length(oc - delta * rd);
    return vec2(delta, max(D, 1e-3 * scene.min_spacing));
}

// The angle span (sampling_math.glsl, eq_span) of [t0, t1] from light i, and its foot f.
float eq_light_span(uint i, vec3 ro, vec3 rd, float t0, float t1, out vec2 f) {
    f = eq_foot(i, ro, rd);
    return cm_eq_span(t0 - f.x, t1 - f.x, f.y);
}

// p_B at ta and at tb: the mixture over the served lights of eq_pmf * equiangular
// density, each light's foot and span computed once for both points.
vec2 eq_mixture_pdfs(vec3 ro, vec3 rd, float t0, float t1, float ta, float tb) {
    vec2 p = vec2(0.0);
    for (uint i = 0u; i < scene.light_count; i++) {
        float pmf = scene.lights[i].eq_pmf;
        if (pmf <= 0.0) continue;
        vec2 f;
        float span = eq_light_span(i, ro, rd, t0, t1, f);
        float a = t0 - f.x;                       // s = a + x, as sampled
        p += pmf * vec2(cm_eq_pdf(a + (ta - t0), f.y, span), cm_eq_pdf(a + (tb - t0), f.y, span));
    }
    return p;
}

// t_B: one served light chosen by eq_cdf (u_light), then an equiangular distance toward
// it in [t0, t1] (u); -1 when the segment is degenerate for it (its span is 0).
float eq_sample(vec3 ro, vec3 rd, float t0, float t1, float u_light, float u) {
    uint pick = uint(MAX_LIGHTS);
    for (uint i = 0u; i < scene.light_count; i++) {
        if (scene.lights[i].eq_pmf <= 0.0) continue;
        pick = i;                                 // the last served light takes rounding
        if (u_light < scene.lights[i].eq_cdf) break;
    }
    if (pick == uint(MAX_LIGHTS)) return -1.0;
    vec2 f;
    float span = eq_light_span(pick, ro, rd, t0, t1, f);
    if (span <= 0.0) return -1.0;
    return clamp(t0 + cm_eq_advance(t0 - f.x, t1 - f.x, f.y, span, u), t0, t1);
}

// tau_min at ta and at tb (both in [t0, t1]; a negative one is skipped): the minorant's
// optical depth from t0, by a walk through the coarse grid
// (no random numbers).  Empty cells add nothing.  Bounded like the tracking loops; a
// walk cut short leaves the depths where it stopped (only the proxy q changes).
vec2 minorant_depths(vec3 ro, vec3 rd, float t0, float ta, float tb) {
    float t_end = max(ta, tb);
    vec2 tau = vec2(0.0);
    if (t_end <= t0) return tau;
    Dda d = coarse_start(ro, rd, t0);
    float t = t0, acc = 0.0;
    for (uint i = 0u; i < MAX_TRACK_STEPS; i++) {
        float t_cell = min(dda_exit(d), t_end);
        float maj = cell_majorant(d);
        float rate = maj > 0.0 ? min(cell_minorant(d), maj) : 0.0;   // empty: 0
        if (ta >= t && ta <= t_cell) tau.x = acc + rate * (ta - t);
        if (tb >= t && tb <= t_cell) tau.y = acc + rate * (tb - t);
        acc += rate * (t_cell - t);
        t = t_cell;
        if (t >= t_end || !dda_advance(d)) break;
    }
    return tau;
}

// q(t) = sigma_t exp(-tau_min), the free-flight proxy density (underflows to 0 deep in
// dense media, where mis_power's rules apply).
float free_flight_proxy(float sigma, float tau_min) { return sigma * exp(-min(tau_min, 87.0)); }

#endif
