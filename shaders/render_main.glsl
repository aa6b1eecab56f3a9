// render_main.glsl - the body of the rendering procedure, compiled twice: render.comp
// (plain Monte Carlo) and render_cache.comp (with the irradiance cache, PICVR_CACHE).
// Two SPIR-V modules rather than a specialization constant, so that the plain
// variant declares no cache buffers at all ("leave out what a scene does not need").
layout(local_size_x = 16, local_size_y = 8) in;

#include "common.glsl"
#include "queue.glsl"
#ifdef PICVR_CACHE
#include "cache.glsl"
#endif

layout(set = 0, binding = 4, std430) buffer AccumMean { vec4 accum_mean[]; };  // rgb, coverage
layout(set = 0, binding = 5, std430) buffer AccumComp { vec4 accum_comp[]; };  // Kahan terms
layout(set = 0, binding = 6, std430) buffer AccumStat { vec4 accum_stat[]; };  // lum mean, M2, n, bad

// round: the scheduler's round (keys the screen-space locking counters); request_cap:
// creation requests this round may issue (the creation budget of the next round).
layout(push_constant) uniform Push { uint round; uint seed; uint request_cap; uint pad; } pc;

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
    float lum = luminance(radiance);
    precise float delta = lum - s.x;
    precise float mean = s.x + delta / float(n);
    precise float m2 = s.y + delta * (lum - mean);
    uint nbad = floatBitsToUint(s.w) + (bad ? 1u : 0u);
    accum_stat[idx] = vec4(mean, m2, uintBitsToFloat(n), uintBitsToFloat(nbad));
}

// In-scattered radiance at x by plain Monte Carlo: one light and one phase sample (MIS).
vec3 direct_light(vec3 x, inout Rng rng, inout bool truncated) {
    vec3 L = sample_one_light(x, rng, truncated);
    if (USE_PHASE_MIS) L += sample_phase(x, rng, truncated);
    return L;
}

#ifdef PICVR_CACHE
// PICVR_VIEW_CACHE_ERROR at a hit: (luminance of the cached shading, luminance of a plain
// estimate at the same point, 1).  The plain sample uses the numbers after the hit's, so
// it is independent of the choice of x and unbiased.
vec3 cache_error_sample(vec3 x, vec3 cached, inout Rng rng, inout bool truncated) {
    return vec3(luminance(cached), luminance(albedo_at(x) * direct_light(x, rng, truncated)), 1.0);
}
#endif

void main() {
    // One workgroup per queued block (block_select.comp), one thread per pixel.
    uvec2 px = block_origin(render_queue.blocks[gl_WorkGroupID.x].x, scene.image.xy) + gl_LocalInvocationID.xy;
    if (px.x >= scene.image.x || px.y >= scene.image.y) return;
    uint idx = px.y * scene.image.x + px.x;
    // Random numbers keyed by (pixel, sample index): every pixel's n-th sample is the
    // same whichever round or block order produced it.
    Rng rng = rng_init(idx, floatBitsToUint(accum_stat[idx].z), pc.seed);

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
        vec3 Ls;
#ifdef PICVR_CACHE
        vec3 E;
        uint node;
        bool near_centre;
        bool hit = cache_lookup(x, E, node, near_centre);
        if (SCREEN_LOCKING) count_ray(px, !hit, pc.round);
        if (hit) {
            Ls = E * INV_4PI;                 // isotropic phase: L_s = E / (4 pi)
            atomicAdd(cache_counters.hits, 1u);
        } else {
            cache_request(x, node, px, pc.round, rnd(rng), pc.request_cap);
            Ls = direct_light(x, rng, truncated);
            atomicAdd(cache_counters.misses, 1u);
        }
#else
        Ls = direct_light(x, rng, truncated);
#endif
        radiance = albedo_at(x) * Ls;
        coverage = 1.0;
#ifdef PICVR_CACHE
        if (USE_DEBUG_VIEW && scene.view.x == VIEW_CACHE)
            radiance = near_centre ? vec3(1.0) : hit ? vec3(0.1, 0.8, 0.2) : vec3(0.8, 0.1, 0.1);
        if (USE_DEBUG_VIEW && scene.view.x == VIEW_CACHE_ERROR)
            radiance = hit ? cache_error_sample(x, radiance, rng, truncated) : vec3(0.0);
#endif
#ifdef PICVR_CACHE
    } else if (USE_DEBUG_VIEW && scene.view.x != VIEW_IMAGE) {
        radiance = vec3(0.0);
#endif
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
