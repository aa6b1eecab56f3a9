// direct_light.glsl - direct light at a scatter point (the integrand of paper Eq. 4): one
// light (or the background) sampled by power and one phase-function sample, combined by
// MIS, each with its shadow ray's transmittance; and the irradiance the cache stores.
#ifndef DIRECT_LIGHT_GLSL_ONCE
#define DIRECT_LIGHT_GLSL_ONCE 1
#include "specialization.glsl"
#include "scene.glsl"
#include "random.glsl"
#include "geometry.glsl"
#include "phase.glsl"
#include "transmittance.glsl"
#include "background.glsl"
#include "lights.glsl"
#include "mutation.glsl"

// Light-sampling strategy: one light (or the background) chosen by power.
// Returns f * L * T * w / pdf with f the phase function ph (1/(4 pi) when isotropic).
// The choice and the direction come from the pixel's pairs of purpose rng.event where
// it is set (random.glsl), else from independent numbers.
vec3 sample_one_light(vec3 x, Phase ph, inout Rng rng, inout bool truncated) {
    bool q = rng.event != 0u;
    uint li = select_light(one_or_rnd(rng, q, rng.event + 1u));
    vec2 u = pair_or_rnd(rng, q, rng.event);
    float u1 = u.x, u2 = u.y;
    vec3 w;
    vec3 L;
    float dist = 1e30;
    float a;            // pmf * solid-angle pdf; 0 marks a delta light
    float pmf;
    if (li == uint(MAX_LIGHTS)) {
        pmf = scene.background_pmf;
        if (pmf <= 0.0) return vec3(0.0);
        float pdf;
        w = background_sample(u1, u2, pdf, L);
        // Rule: a direction of pdf 0 (a black texel, never drawn) adds nothing.
        if (pdf <= 0.0) return vec3(0.0);
        a = pmf * pdf;
    } else {
        Light l = scene.lights[li];
        int type = l.type;
        pmf = l.pmf;
        L = l.radiance;
        if (type == LIGHT_SPHERE) {
            vec3 to = l.pos - x;
            float d2 = dot(to, to), r2 = l.size * l.size;
            if (d2 <= r2) {
                w = uniform_sphere(u1, u2);
            } else {
                float sin2 = r2 / d2;
                float omc = sin2 / (1.0 + sqrt(max(0.0, 1.0 - sin2)));
                w = sample_cone(to * inversesqrt(d2), omc, u1, u2);
            }
            int h = nearest_area_light(x, w, 1e30, dist);
            if (h != int(li)) return vec3(0.0);      // occluded by another light (or grazing miss)
            a = pmf * light_pdf(li, x, w, dist);
        } else if (type == LIGHT_RECT) {
            vec3 q = l.pos + (u1 - 0.5) * l.edge_u + (u2 - 0.5) * l.edge_v;
            vec3 to = q - x;
            float d = length(to);
            if (d <= 0.0) return vec3(0.0);
            w = to / d;
            L = area_light_radiance(li, w);
            // Rule: grazing samples (cos < 1e-7) carry vanishing solid angle; drop them
            // rather than divide by ~0.
            vec3 n = normalize(cross(l.edge_u, l.edge_v));
            if (abs(dot(n, w)) < 1e-7 || all(equal(L, vec3(0.0)))) return vec3(0.0);
            float th;
            if (nearest_area_light(x, w, d * (1.0 - 1e-4), th) >= 0) return vec3(0.0);
            dist = d;
            a = pmf * light_pdf(li, x, w, d);
        } else if (type == LIGHT_DIRECTIONAL) {
            float omc = l.size;
            w = omc > 0.0 ? sample_cone(l.pos, omc, u1, u2) : l.pos;
            a = omc > 0.0 ? pmf * light_pdf(li, x, w, 0.0) : 0.0;
            float th;
            if (nearest_area_light(x, w, 1e30, th) >= 0) return vec3(0.0);
        } else {   // point light: intensity / d^2
            vec3 to = l.pos - x;
            // Rule: the distance is clamped to 1e-3 of the smallest voxel spacing so a
            // light on a scatter point gives a large but finite value.
            float min_d = 1e-3 * scene.min_spacing;
            float d2 = max(dot(to, to), min_d * min_d);
            float d = sqrt(d2);
            w = to / d;
            float th;
            if (nearest_area_light(x, w, d, th) >= 0) return vec3(0.0);
            dist = d;
            L = l.radiance / d2;
            a = 0.0;
        }
    }
    if (all(equal(L, vec3(0.0)))) return vec3(0.0);
    float f = phase_eval(ph, w);
    // Rule: a direction the phase function does not scatter into needs no shadow ray.
    if (f <= 0.0) return vec3(0.0);
    float T = transmittance(x, w, dist, rng, truncated);
    if (a <= 0.0) return f * MUTATE(MUT_DIRECT, L) * T / pmf;         // delta light
    float mis = USE_PHASE_MIS ? power_weight(a, f) : 1.0;
    return f * MUTATE(MUT_DIRECT, L) * T * (mis / a);
}

// The emission a phase-sampled direction w from x sees (hit: the area light it hits
// first, at t_hit, or -1), weighted by the power heuristic against light sampling; f is
// the phase pdf of w.  An escaping direction sees the background and every sun cone
// that contains it.
vec3 phase_emission(vec3 x, vec3 w, int hit, float t_hit, float f) {
    if (hit >= 0) {
        uint i = uint(hit);
        return MUTATE(MUT_PHASE, area_light_radiance(i, w) * power_weight(f, scene.lights[i].pmf * light_pdf(i, x, w, t_hit)));
    }
    vec3 Le = vec3(0.0);
    if (scene.background_pmf > 0.0) {
        float pdf;
        vec3 L = background_radiance_pdf(w, pdf);
        Le = L * power_weight(f, scene.background_pmf * pdf);
    }
    for (uint i = 0u; i < scene.light_count; i++) {
        Light l = scene.lights[i];
        if (l.type != LIGHT_DIRECTIONAL || l.size <= 0.0) continue;
        if (1.0 - dot(w, l.pos) <= l.size)
            Le += l.radiance * power_weight(f, l.pmf * light_pdf(i, x, w, 0.0));
    }
    return MUTATE(MUT_PHASE, Le);
}

// Phase-sampling strategy: f / pdf = 1 (phase_sample is exact), so the estimate is
// Le * T * w, the transmittance by ratio tracking.  Its direction from the pair of
// purpose rng.event + 2 where that is set.
vec3 sample_phase(vec3 x, Phase ph, inout Rng rng, inout bool truncated) {
    vec2 u = pair_or_rnd(rng, rng.event != 0u, rng.event + 2u);
    float u1 = u.x, u2 = u.y;
    vec3 w = phase_sample(ph, u1, u2);
    float t_hit;
    int hit = nearest_area_light(x, w, 1e30, t_hit);
    vec3 Le = phase_emission(x, w, hit, t_hit, phase_eval(ph, w));
    if (all(equal(Le, vec3(0.0)))) return vec3(0.0);
    return Le * transmittance(x, w, t_hit, rng, truncated);
}

// Irradiance (Eq. 4) at x from all lights: one light sample and one phase sample,
// combined by MIS, with the isotropic phase function (the cache's quantity: creation
// runs only where the phase function is isotropic); both estimators include f = 1/(4 pi),
// so E = 4 pi * (sum).  Separate streams for the two samples, so that a caller can replay
// the same light and phase choices at several points (common random numbers,
// cache_create.comp).
vec3 irradiance_sample(vec3 x, Rng light_rng, Rng phase_rng, inout bool truncated) {
    Phase iso = Phase(vec3(0.0, 0.0, 1.0), 0.0);
    vec3 s = sample_one_light(x, iso, light_rng, truncated);
    if (USE_PHASE_MIS) s += sample_phase(x, iso, phase_rng, truncated);
    return 4.0 * PI * s;
}

#endif
