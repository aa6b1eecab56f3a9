// distance.glsl - where a camera ray's light is gathered (paper §3, Eq. 4 along the ray):
// free-flight sampling by delta tracking combined by multiple importance sampling with a
// second point drawn inside the ray's medium, equiangular toward the lights that fall off
// steeply across the volume (Kulla and Fajardo 2012) or forced free flight (a collision
// conditioned to fall in the segment) for the rest of the light, so that a ray through
// thin medium still gathers the in-scattered light of every light.  The scalar formulas
// are in sampling_math.glsl; USE_EQUIANGULAR (specialization.glsl) turns strategy B on.
//
// The estimator.  Along the camera ray over its medium segment [t0, t1] the pixel sees
//   L = int_t0^t1 T(t) sigma_s(t) L_s(t) dt + T(t1) L_end,
// (L_s in-scattered radiance, L_end the area light or background at the end).  Per
// camera sample:
//  A. delta tracking draws t_A with density p_A(t) = sigma_t(t) T(t) (or passes); its
//     estimate of the integral, albedo L_s(t_A), is weighted by w_A(t_A);
//  B. draws t_B with density p_B(t), a mixture: with probability f = scene.forced_pmf
//     the forced density p_F (sampling_math.glsl, forced_norm), else equiangular toward
//     a served light chosen by eq_pmf, so p_B = f p_F + (1 - f) sum eq_pmf p_eq (b_sample,
//     b_pdfs); its estimate is w_B(t_B) T^(t_B) sigma_s(t_B)
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
// Leave-out: USE_EQUIANGULAR is on only when B has something to draw for (host/lights.c,
// picvr_update_equiangular: a point, sphere or rect light whose 1/d^2 falls off steeply
// across the volume, or with PICVR_DISTANCE_FORCED a sun or light it does not serve,
// whose share f gets the forced point; never the background, which rays that pass see);
// without light, or with PICVR_DISTANCE_FREE_FLIGHT, the camera ray is the paper's delta
// tracking alone.  The forced share's walks run only where f > 0.  A camera ray whose
// segment holds no medium at all ends in the tracking kernel (render_track.glsl): B
// would draw nothing there and T = 1 exactly, so both estimators agree.
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

// The coarse-grid walk of a camera ray's segment from t0 to t_end (no random numbers):
// the minorant's optical depth from t0 (tau_min, for the proxy q) and the majorant's
// (tau_maj, for p_F) at ta and tb (in [t0, t_end]; a negative one is skipped), the
// majorant at ta and tb (maj), and the majorant's depth at t_end (tau_maj_end).
// Bounded like the tracking loops; a walk cut short leaves the depths where it stopped
// (the pdfs of points past it read 0 majorant: they are never drawn there either, as
// forced_sample walks the same cells).  Empty space is jumped over as tracking jumps it
// (majorant.glsl, empty_skip): it adds nothing to either depth.
struct SegmentDepths { vec2 tau_min; vec2 tau_maj; vec2 maj; float tau_maj_end; };

// s with point k's (0: ta, 1: tb) depths and majorant set.
SegmentDepths segment_capture(SegmentDepths s, uint k, float tau_min, float tau_maj, float maj) {
    s.tau_min[k] = tau_min;
    s.tau_maj[k] = tau_maj;
    s.maj[k] = maj;
    return s;
}

SegmentDepths segment_depths(vec3 ro, vec3 rd, float t0, float t_end, float ta, float tb) {
    SegmentDepths s;
    s.tau_min = vec2(0.0);
    s.tau_maj = vec2(0.0);
    s.maj = vec2(0.0);
    s.tau_maj_end = 0.0;
    if (t_end <= t0) return s;
    Dda d = coarse_start(ro, rd, t0);
    float t = t0, acc_min = 0.0, acc_maj = 0.0;
    for (uint i = 0u; i < MAX_TRACK_STEPS; i++) {
        float maj = max(cell_majorant(d), 0.0);
        float jump = maj > 0.0 ? 0.0 : empty_skip(d, rd);
        if (jump > 0.0) {
            // empty space skipped as tracking skips it: a point in it sees the depths
            // reached so far and no majorant (p_F 0: forced_sample never lands there)
            float t_jump = min(t + jump, t_end);
            if (ta >= t && ta <= t_jump) s = segment_capture(s, 0u, acc_min, acc_maj, 0.0);
            if (tb >= t && tb <= t_jump) s = segment_capture(s, 1u, acc_min, acc_maj, 0.0);
            t = t_jump;
            if (t >= t_end) break;
            d = coarse_start(ro, rd, t);
            continue;
        }
        float t_cell = min(dda_exit(d), t_end);
        float rate = maj > 0.0 ? min(cell_minorant(d), maj) : 0.0;   // empty: 0
        if (ta >= t && ta <= t_cell)
            s = segment_capture(s, 0u, acc_min + rate * (ta - t), acc_maj + maj * (ta - t), maj);
        if (tb >= t && tb <= t_cell)
            s = segment_capture(s, 1u, acc_min + rate * (tb - t), acc_maj + maj * (tb - t), maj);
        acc_min += rate * (t_cell - t);
        acc_maj += maj * (t_cell - t);
        t = t_cell;
        if (t >= t_end || !dda_advance(d)) break;
    }
    s.tau_maj_end = acc_maj;
    return s;
}

// The forced distance (sampling_math.glsl, forced_norm): the point of [t0, t1] where the
// majorant's depth from t0 reaches forced_depth(u, Z, tau_total), tau_total the
// segment's depth (segment_depths' tau_maj_end) and Z = forced_norm(tau_total); -1 when
// the segment holds no medium (Z = 0).  The walk is segment_depths' (the same cells and
// sums), so the pdf it computes at the point is the density the point was drawn with.
float forced_sample(vec3 ro, vec3 rd, float t0, float t1, float tau_total, float z, float u) {
    if (!(z > 0.0)) return -1.0;
    float target = cm_forced_depth(u, z, tau_total);
    Dda d = coarse_start(ro, rd, t0);
    float t = t0, acc = 0.0, last = -1.0;
    for (uint i = 0u; i < MAX_TRACK_STEPS; i++) {
        float maj = max(cell_majorant(d), 0.0);
        float jump = maj > 0.0 ? 0.0 : empty_skip(d, rd);
        if (jump > 0.0) {                 // segment_depths' skip, step for step
            t = min(t + jump, t1);
            if (t >= t1) break;
            d = coarse_start(ro, rd, t);
            continue;
        }
        float t_cell = min(dda_exit(d), t1);
        float step = maj * (t_cell - t);
        if (maj > 0.0) {
            if (acc + step >= target) return clamp(t + (target - acc) / maj, t, t_cell);
            last = t_cell;                // rounding: the last cell with medium takes u -> 1
        }
        acc += step;
        t = t_cell;
        if (t >= t1 || !dda_advance(d)) break;
    }
    return last;
}

// Strategy B's draw on the segment [t0, t1]: with probability f a forced distance, else
// an equiangular one toward a served light chosen by eq_cdf (u_light rescaled to [0, 1)
// for that choice).  f is scene.forced_pmf on camera rays in variants with USE_FORCED
// (the share of the light that equiangular sampling does not serve, host/lights.c; plain
// rendering only, specialization.glsl), else 0, and 0 on a path's later segments
// (path.glsl: the forced point serves the camera ray's first event, where the gap to a
// converged image is).  Returns t_B (-1: none, a degenerate segment); z is the
// segment's Z for p_F (0 when f = 0: no walk).
float b_sample(vec3 ro, vec3 rd, float t0, float t1, float f, float u_light, float u, out float z) {
    z = 0.0;
    float tau_total = 0.0;
    if (f > 0.0) {
        tau_total = segment_depths(ro, rd, t0, t1, -1.0, -1.0).tau_maj_end;
        z = cm_forced_norm(tau_total);
    }
    if (u_light < f) return forced_sample(ro, rd, t0, t1, tau_total, z, u);
    return eq_sample(ro, rd, t0, t1, (u_light - f) / (1.0 - f), u);   // f < 1 here
}

// B's density at ta and tb (the mixture f p_F + (1 - f) sum eq_pmf p_eq), with sd the
// segment's walk to max(ta, tb), f and z b_sample's.
vec2 b_pdfs(vec3 ro, vec3 rd, float t0, float t1, float ta, float tb, SegmentDepths sd, float f, float z) {
    vec2 p = f < 1.0 ? (1.0 - f) * eq_mixture_pdfs(ro, rd, t0, t1, ta, tb) : vec2(0.0);
    if (f > 0.0)
        p += f * vec2(ta >= 0.0 ? cm_forced_pdf(sd.maj.x, sd.tau_maj.x, z) : 0.0,
                      tb >= 0.0 ? cm_forced_pdf(sd.maj.y, sd.tau_maj.y, z) : 0.0);
    return p;
}

// q(t) = sigma_t exp(-tau_min), the free-flight proxy density (underflows to 0 deep in
// dense media, where mis_power's rules apply).
float free_flight_proxy(float sigma, float tau_min) { return sigma * exp(-min(tau_min, 87.0)); }

#endif
