#version 450
// render.comp - the rendering procedure (paper §3, §4.1): one progressive iteration,
// one sample per pixel, 16x8-pixel blocks of 128 threads.  Single scattering as in
// Exposure Render: a jittered camera ray, delta tracking to one scatter event (Eq. 1),
// direct light there with one light sample and one phase sample combined by MIS,
// then a running average per pixel plus Welford statistics of luminance for Eq. 5.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 16, local_size_y = 8) in;

// Specialization: scenes whose lights are all delta lights (point, zero-size sun) and
// that have no background need no phase-sampled rays at all.
layout(constant_id = 0) const bool USE_PHASE_MIS = true;

#include "common.glsl"

layout(set = 0, binding = 4, std430) buffer AccumMean { vec4 accum_mean[]; };  // rgb, coverage
layout(set = 0, binding = 5, std430) buffer AccumComp { vec4 accum_comp[]; };  // Kahan terms
layout(set = 0, binding = 6, std430) buffer AccumStat { vec4 accum_stat[]; };  // lum mean, M2, n, bad

layout(push_constant) uniform Push { uint iteration; uint seed; } pc;

// Light-sampling strategy: one light (or the background) chosen by power.
// Returns f * L * T * w / pdf with f = 1/(4 pi) the isotropic phase function.
vec3 sample_one_light(vec3 x, inout Rng rng, inout bool truncated) {
    uint li = select_light(rnd(rng));
    float u1 = rnd(rng), u2 = rnd(rng);
    vec3 w;
    vec3 L;
    float dist = 1e30;
    float a;            // pmf * solid-angle pdf; 0 marks a delta light
    float pmf;
    if (li == uint(MAX_LIGHTS)) {
        pmf = scene.background.w;
        if (pmf <= 0.0) return vec3(0.0);
        w = uniform_sphere(u1, u2);
        L = scene.background.rgb;
        a = pmf * INV_4PI;
    } else {
        Light l = scene.lights[li];
        int type = int(l.p0.w);
        pmf = l.p1.w;
        L = l.p1.xyz;
        if (type == LIGHT_SPHERE) {
            vec3 to = l.p0.xyz - x;
            float d2 = dot(to, to), r2 = l.p2.w * l.p2.w;
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
            vec3 q = l.p0.xyz + (u1 - 0.5) * l.p2.xyz + (u2 - 0.5) * l.p3.xyz;
            vec3 to = q - x;
            float d = length(to);
            if (d <= 0.0) return vec3(0.0);
            w = to / d;
            L = area_light_radiance(li, w);
            // Rule: grazing samples (cos < 1e-7) carry vanishing solid angle; drop them
            // rather than divide by ~0.
            vec3 n = normalize(cross(l.p2.xyz, l.p3.xyz));
            if (abs(dot(n, w)) < 1e-7 || all(equal(L, vec3(0.0)))) return vec3(0.0);
            float th;
            if (nearest_area_light(x, w, d * (1.0 - 1e-4), th) >= 0) return vec3(0.0);
            dist = d;
            a = pmf * light_pdf(li, x, w, d);
        } else if (type == LIGHT_DIRECTIONAL) {
            float omc = l.p2.w;
            w = omc > 0.0 ? sample_cone(l.p0.xyz, omc, u1, u2) : l.p0.xyz;
            a = omc > 0.0 ? pmf * light_pdf(li, x, w, 0.0) : 0.0;
            float th;
            if (nearest_area_light(x, w, 1e30, th) >= 0) return vec3(0.0);
        } else {   // point light: intensity / d^2
            vec3 to = l.p0.xyz - x;
            // Rule: the distance is clamped to 1e-3 of the smallest voxel spacing so a
            // light on a scatter point gives a large but finite value.
            float min_d = 1e-3 * scene.cell_size.w;
            float d2 = max(dot(to, to), min_d * min_d);
            float d = sqrt(d2);
            w = to / d;
            float th;
            if (nearest_area_light(x, w, d, th) >= 0) return vec3(0.0);
            dist = d;
            L = l.p1.xyz / d2;
            a = 0.0;
        }
    }
    if (all(equal(L, vec3(0.0)))) return vec3(0.0);
    float T = transmittance(x, w, dist, rng, truncated);
    if (a <= 0.0) return INV_4PI * L * T / pmf;                       // delta light
    float mis = USE_PHASE_MIS ? power_weight(a, INV_4PI) : 1.0;
    return INV_4PI * L * T * (mis / a);
}

// Phase-sampling strategy: f / pdf = 1 for the isotropic phase function, so the
// estimate is L * T * w.  The direction sees the nearest area light or, escaping,
// the background plus every sun cone that contains it.
vec3 sample_phase(vec3 x, inout Rng rng, inout bool truncated) {
    vec3 w = uniform_sphere(rnd(rng), rnd(rng));
    float t_hit;
    int hit = nearest_area_light(x, w, 1e30, t_hit);
    vec3 Le = vec3(0.0);
    if (hit >= 0) {
        uint i = uint(hit);
        Le = area_light_radiance(i, w) *
             power_weight(INV_4PI, scene.lights[i].p1.w * light_pdf(i, x, w, t_hit));
    } else {
        Le = scene.background.rgb * power_weight(INV_4PI, scene.background.w * INV_4PI);
        for (uint i = 0u; i < scene.grid.w; i++) {
            Light l = scene.lights[i];
            if (int(l.p0.w) != LIGHT_DIRECTIONAL || l.p2.w <= 0.0) continue;
            if (1.0 - dot(w, l.p0.xyz) <= l.p2.w)
                Le += l.p1.xyz * power_weight(INV_4PI, l.p1.w * light_pdf(i, x, w, 0.0));
        }
    }
    if (all(equal(Le, vec3(0.0)))) return vec3(0.0);
    return Le * transmittance(x, w, t_hit, rng, truncated);
}

vec3 camera_ray(uvec2 px, inout Rng rng) {
    float jx = rnd(rng), jy = rnd(rng);
    float h = scene.cam_pos.w, aspect = scene.cam_fwd.w;
    float sx = (2.0 * (float(px.x) + jx) / float(scene.image.x) - 1.0) * h * aspect;
    float sy = (1.0 - 2.0 * (float(px.y) + jy) / float(scene.image.y)) * h;
    return normalize(scene.cam_fwd.xyz + sx * scene.cam_right.xyz + sy * scene.cam_up.xyz);
}

// Kahan-compensated running mean (precise: no reassociation by the compiler), so
// that after millions of samples an update of relative size 1e-7 is not lost.
void accumulate(uint idx, vec3 radiance, float coverage, bool bad) {
    vec4 s = accum_stat[idx];
    uint n = floatBitsToUint(s.z) + 1u;
    precise vec4 m = accum_mean[idx];
    precise vec4 c = accum_comp[idx];
    precise vec4 y = (vec4(radiance, coverage) - m) / float(n) - c;
    precise vec4 t = m + y;
    c = (t - m) - y;
    accum_mean[idx] = t;
    accum_comp[idx] = c;
    // Welford update of the luminance mean and M2 (Eq. 5 and Eq. 12 need S^2).
    float lum = dot(radiance, vec3(0.2126, 0.7152, 0.0722));
    precise float delta = lum - s.x;
    precise float mean = s.x + delta / float(n);
    precise float m2 = s.y + delta * (lum - mean);
    uint nbad = floatBitsToUint(s.w) + (bad ? 1u : 0u);
    accum_stat[idx] = vec4(mean, m2, uintBitsToFloat(n), uintBitsToFloat(nbad));
}

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= scene.image.x || px.y >= scene.image.y) return;
    uint idx = px.y * scene.image.x + px.x;
    Rng rng = rng_init(idx, pc.iteration, pc.seed);

    vec3 ro = scene.cam_pos.xyz;
    vec3 rd = camera_ray(px, rng);
    bool truncated = false;

    float t_light;
    int light_hit = nearest_area_light(ro, rd, 1e30, t_light);
    float t = -1.0, t0, t1;
    if (box_interval(ro, rd, t0, t1)) {
        t1 = min(t1, t_light);
        if (t1 > t0) t = delta_track(ro, rd, t0, t1, rng, truncated);
    }

    vec3 radiance;
    float coverage = 0.0;
    if (t >= 0.0) {
        vec3 x = ro + rd * t;
        vec3 Ls = sample_one_light(x, rng, truncated);
        if (USE_PHASE_MIS) Ls += sample_phase(x, rng, truncated);
        radiance = albedo_at(x) * Ls;
        coverage = 1.0;
    } else if (light_hit >= 0) {
        radiance = area_light_radiance(uint(light_hit), rd);
    } else {
        radiance = scene.background.rgb;
    }
    // Rule: a non-finite sample (only possible from extreme user input overflowing
    // float) is replaced by 0 and counted with the truncated ones; it never reaches
    // the image.
    bool bad = truncated;
    if (any(isnan(radiance)) || any(isinf(radiance))) { radiance = vec3(0.0); bad = true; }
    accumulate(idx, radiance, coverage, bad);
}
