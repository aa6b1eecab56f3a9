#version 450
// render_lookup.comp - the rendering procedure's cache lookup (paper §4.1, §5; see
// render.glsl): one thread per queued scatter event.  A covered event is shaded from
// the extrapolated fluence (Eq. 7, 8, 11) with the isotropic phase function, blended
// with a plain estimate so that the image converges (CACHE_BLEND, cache_blend.glsl); a miss
// requests a new entry under the context's locking (§5.1, §5.2) and is queued for
// plain Monte-Carlo shading (render_shade.comp).  What the cache holds: the direct
// (single-scattered) light, or with USE_BOUNCES the multiply scattered light, the fluence
// of light that scattered at least once before reaching x (cache_create.comp); a hit then
// shades the event's direct light by next-event estimation as plain shading does (sharp
// shadows, the phase function's lobe toward the sun) and adds the cached part in place
// of the rest of the path, which ends there.  The debug views shade here, misses too, in
// their own variant (USE_DEBUG_VIEW).
#extension GL_GOOGLE_include_directive : require
#define PICVR_CACHE 1
#define PICVR_CACHE_SHADING 1
#include "render.glsl"
layout(local_size_x = EVENT_GROUP, local_size_y = 1) in;

// PICVR_VIEW_CACHE_ERROR at a hit: (luminance of the cached part, luminance of a plain
// estimate of it at the same point, 1).  The plain sample uses the numbers after the
// hit's, so it is independent of the choice of x and unbiased.
vec3 cache_error_sample(inout ScatterEvent e, vec3 cached) {
    return vec3(luminance(cached), luminance(plain_cached_part(e)), 1.0);
}

void main() {
    ScatterEvent e;
    LOAD_EVENT(lookup_queue, e)
    bool blend = CACHE_BLEND && !(USE_DEBUG_VIEW && scene.debug_view != VIEW_IMAGE);
    float w = blend ? pixel_blend_weight(e.px) : 0.0;
    if (blend && blend_route(e.rng, w)) {
        atomicAdd(cache_counters.routed, 1u);
        QUEUE_EVENT(shade_queue, e.idx, e.t, e.rng, e.truncated)
        return;
    }
    vec3 E, aniso;
    bool near_centre;
    bool hit = render_cache_lookup(e.x, e.px, e.rng, E, aniso, near_centre);
    vec3 Ls;
    vec3 albedo = albedo_at(e.x);
    vec3 direct = vec3(0.0);            // the event's own direct light, with USE_BOUNCES
    if (hit) {
        // isotropic phase: L_s = E / (4 pi); multiply scattered: to first order in
        // direction, and the event's direct light as event_direct shades it
        Phase ph = phase_at(e.x, e.rd);
        Ls = USE_BOUNCES ? ms_inscattered(E, aniso, ph) : E * INV_4PI;
        e.rng.event = QMC_EVENT_A;
        if (USE_BOUNCES) direct = albedo * direct_light(e.x, ph, e.rng, e.truncated);
    } else {
        if (!USE_DEBUG_VIEW) {
            QUEUE_EVENT(shade_queue, e.idx, e.t, e.rng, e.truncated)
            return;
        }
        e.rng.event = QMC_EVENT_A;
        Ls = direct_light(e.x, phase_at(e.x, e.rd), e.rng, e.truncated);
    }
    vec3 cached = albedo * Ls;
    if (blend && hit) cached = blend_hit(e, cached, w);
    vec3 radiance = direct + cached;
    float coverage = 1.0;
    uint events;
    // the part weighted against the camera ray's equiangular sample is the direct light
    if (USE_EQUIANGULAR && !(USE_DEBUG_VIEW && scene.debug_view != VIEW_IMAGE))
        radiance = USE_BOUNCES ? finish_camera_sample(e, true, direct, cached, coverage, events)
                               : finish_camera_sample(e, true, cached, vec3(0.0), coverage, events);
    if (USE_DEBUG_VIEW && scene.debug_view == VIEW_CACHE)
        radiance = near_centre ? vec3(1.0) : hit ? vec3(0.1, 0.8, 0.2) : vec3(0.8, 0.1, 0.1);
    if (USE_DEBUG_VIEW && scene.debug_view == VIEW_CACHE_ERROR)
        radiance = hit ? cache_error_sample(e, cached) : vec3(0.0);
    count_events(1u);
    accumulate_sample(e.idx, radiance, coverage, e.truncated);
    accumulate_depth(e.idx, e.t);
}
