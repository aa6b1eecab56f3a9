// path.glsl - the light scattered at a camera path's first scatter event, with the rest
// of the path (picvr_scattering.max_bounces > 0, USE_BOUNCES): a volumetric path tracer.
//
// At every scatter event x_k (k = 1, 2, ...; the first is the camera ray's, from delta
// tracking) the path adds next-event estimation: one light or the background chosen by
// power, its transmittance by (residual) ratio tracking, weighted by the power heuristic
// against the phase function's pdf (sample_one_light).  The phase-sampled direction then
// serves twice: as the other MIS strategy of x_k's direct light, and as the path's next
// segment, tracked by delta tracking: if it leaves the medium, it adds the emission it
// sees weighted against light sampling (phase_emission; the delta-tracking escape is an
// unbiased 0/1 estimate of that direction's transmittance) and the path ends; if it
// collides, x_{k+1} is the next scatter event.  At the last event the path may have, the
// phase sample's transmittance is estimated by ratio tracking instead (sample_phase:
// less variance, as single scattering always did).  Where equiangular sampling serves
// (USE_EQUIANGULAR with a point, sphere or rect light near the volume: forced_pmf < 1),
// every segment also draws a point toward it, as camera rays do, and the direct light
// along the segment is shared between the two strategies by MIS (segment_equiangular).
// Later segments draw no forced point (distance.glsl, b_sample).
//
// Weights.  The throughput beta_k = albedo(x_1) ... albedo(x_k) (RGB): delta tracking
// samples x_{k+1} with density sigma_t T, the phase sample is exact (f / pdf = 1), so
// each event leaves sigma_s / sigma_t = albedo.  Extinction is one scalar in picvr (the
// transfer function's opacity), so chromatic albedo is exact in this form: the free
// flights are the same for every channel and no spectral MIS is needed.
// Russian roulette: before a path goes on from its second (or a later) scatter event, it
// survives with probability q = min(1, max channel of beta) and what it gathers after
// that event is divided by q, which keeps every channel's expectation; the event itself
// is then the last and takes both strategies of its direct light.  Dim paths end early,
// bright ones (albedo near 1) go on until they leave the medium.
//
// Bound.  llvmpipe caps an invocation's loop iterations at 65535 in all, so the path's
// tracking loops draw from one pool (tracking.glsl, path_pool; limits.glsl, PATH_STEPS)
// and each event is charged scene.vertex_cost more for its other loops (lights, the
// environment's search).  A path that runs the pool dry ends there, and a continuation cut at its
// bound ends the path without what it would have seen: biased toward dark (never a leak
// of light through medium it could not track), and counted in stats.truncated_paths.

#include "specialization.glsl"
#include "limits.glsl"
#include "scene.glsl"
#include "sampling_math.glsl"
#include "random.glsl"
#include "clip.glsl"
#include "medium.glsl"
#include "phase.glsl"
#include "tracking.glsl"
#include "transmittance.glsl"
#include "lights.glsl"
#include "direct_light.glsl"
#include "distance.glsl"
#include "mutation.glsl"

#define BOUNCES_UNLIMITED 0xffffffffu

// In-scattered radiance at x by plain Monte Carlo: one light and one phase sample (MIS),
// from the pixel's pairs of purpose rng.event if set (cleared here: one event's).
vec3 direct_light(vec3 x, Phase ph, inout Rng rng, inout bool truncated) {
    vec3 L = sample_one_light(x, ph, rng, truncated);
    if (USE_PHASE_MIS) L += sample_phase(x, ph, rng, truncated);
    rng.event = 0u;
    return L;
}

// Equiangular sampling along a path's segment (USE_EQUIANGULAR), as along camera rays
// (distance.glsl): the segment from x along w over [t0, t1], where delta tracking drew
// t_a (-1: it passed).  The direct light of the points along the segment is estimated by
// both strategies, weighted by the power heuristic: returns A's weight (for the direct
// light of the event at t_a) and sets L_b to B's estimate, albedo included.  The light
// of later events keeps A alone (weight 1), as on camera rays.
float segment_equiangular(vec3 x, vec3 w, float t0, float t1, float t_a, inout Rng rng, inout bool truncated,
                          out vec3 L_b) {
    L_b = vec3(0.0);
    float u_light = rnd(rng), u = rnd(rng);
    float z;
    float t_b = b_sample(x, w, t0, t1, 0.0, u_light, u, z);
    float s_b = t_b >= 0.0 ? sigma_t(x + w * t_b) : 0.0;
    float T_b = s_b > 0.0 ? transmittance(x, w, t_b, rng, truncated) : 0.0;
    bool b_counts = s_b > 0.0 && T_b != 0.0;   // a ray-marched T_b may be negative
    float tb = b_counts ? t_b : -1.0;
    SegmentDepths sd = segment_depths(x, w, t0, max(t_a, tb), t_a, tb);
    vec2 p_b = b_pdfs(x, w, t0, t1, t_a, tb, sd, 0.0, z);
    float w_a = t_a >= 0.0 ? cm_mis_power(free_flight_proxy(sigma_t(x + w * t_a), sd.tau_min.x), p_b.x) : 1.0;
    if (b_counts) {
        float f_b = cm_eq_weight(T_b, s_b, free_flight_proxy(s_b, sd.tau_min.y), p_b.y);
        vec3 xb = x + w * t_b;
        if (f_b > 0.0) L_b = f_b * albedo_at(xb) * direct_light(xb, phase_at(xb, w), rng, truncated);
    }
    return w_a;
}

// A path between scatter events: at x, event number `events` (x counts `first`), not yet
// shaded, arrived along d with throughput beta (x's albedo included); w_dir the weight of
// x's direct light (its segment's MIS; the caller weights the first event's); done once
// the path has ended.  direct: the first event's own next-event estimate (the part the
// caller may weight against another strategy), indirect: the light of the events after
// it.  The bounce limit and Russian roulette count events from the camera, so a path
// begun at event 2 (cache-entry creation, cache_create.comp) ends where the camera path
// it stands for would.
struct PathState { vec3 x; vec3 d; vec3 beta; float w_dir; uint events; bool done; vec3 direct; vec3 indirect; };

PathState path_begin(vec3 x, vec3 d, uint first) {
    PathState s;
    s.x = x;
    s.d = d;
    s.beta = albedo_at(x);
    s.w_dir = 1.0;
    s.events = first;
    s.done = false;
    s.direct = vec3(0.0);
    s.indirect = vec3(0.0);
    return s;
}

// Shades the path's current event (its direct light) and moves it to the next; false
// when the path has ended (s.done).  first: the path's first event (path_begin's).
bool path_event(inout PathState s, uint first, inout Rng rng, inout bool truncated) {
    float b_max = max(s.beta.r, max(s.beta.g, s.beta.b));
    s.done = b_max <= 0.0;                           // nothing more can reach the camera
    // Rule: a path that ran the pool dry ends here with nothing more (its shadow rays
    // could not be tracked): biased toward dark, counted.
    if (!s.done && path_pool < scene.vertex_cost) { truncated = true; s.done = true; }
    if (s.done) return false;
    path_pool -= scene.vertex_cost;
    // Is this event the path's last?  At the bounce limit, or by Russian roulette from
    // the second event on: the path goes on with probability q and what it gathers
    // later is divided by q.  A last event still takes both MIS strategies of its
    // direct light (the phase sample by ratio tracking), so ending is unbiased.
    bool end = scene.max_bounces != BOUNCES_UNLIMITED && s.events > scene.max_bounces;
    float q = 1.0;
    if (!end && s.events >= 2u) {
        q = min(1.0, b_max);
        end = rnd(rng) >= q;
    }
    Phase ph = phase_at(s.x, s.d);
    // this event's pairs (rng.event, the camera's first event), then independent numbers
    vec3 L = sample_one_light(s.x, ph, rng, truncated);
    vec3 w = vec3(0.0);
    float t = -1.0;
    float w_next = 1.0;  // the next event's direct-light weight (its segment's MIS)
    if (end) {
        if (USE_PHASE_MIS) L += sample_phase(s.x, ph, rng, truncated);
        rng.event = 0u;
    } else {
        vec2 u = pair_or_rnd(rng, rng.event != 0u, rng.event + 2u);
        rng.event = 0u;
        w = phase_sample(ph, u.x, u.y);
        float t_light, t0 = 0.0, t1 = 0.0;
        int hit = nearest_area_light(s.x, w, 1e30, t_light);
        bool cut = false;
        if (box_interval(s.x, w, t0, t1)) {
            t1 = min(t1, t_light);
            if (t1 > t0) t = delta_track(s.x, w, t0, t1, rng, cut);
        }
        // Rule: a continuation cut at its loop bound neither escapes nor scatters:
        // the path ends without its emission (biased toward dark, counted).
        truncated = truncated || cut;
        if (t < 0.0 && !cut) L += phase_emission(s.x, w, hit, t_light, phase_eval(ph, w));
        end = cut;
        // equiangular only (b_sample); some light is served unless the variant has the
        // forced point and its share is all the light (forced_pmf = 1, exactly)
        if (USE_EQUIANGULAR && !(USE_FORCED && scene.forced_pmf >= 1.0) && !cut && t1 > t0) {
            vec3 L_b;
            w_next = segment_equiangular(s.x, w, t0, t1, t, rng, truncated, L_b);
            s.indirect += s.beta / q * L_b;
        }
    }
    if (s.events == first) s.direct = s.beta * L; else s.indirect += s.beta * s.w_dir * L;
    s.w_dir = w_next;
    s.done = end || t < 0.0;
    if (s.done) return false;
    s.x += w * t;
    s.d = w;
    s.events++;
    s.beta *= MUTATE(MUT_THROUGHPUT, albedo_at(s.x)) / q;                    // q > 0: the path survived with it
    return true;
}

// Traces the path (begun at event `first`) until it ends or stands at event `stop`, not
// yet shaded.
void path_run(inout PathState s, uint first, uint stop, inout Rng rng, inout bool truncated) {
    if (s.done) return;
    for (uint n = 0u; n < PATH_STEPS; n++) {
        if (s.events >= stop || !path_event(s, first, rng, truncated)) break;
    }
}

// The light scattered at x (the path's scatter event number `first`: 1 for a camera
// ray's; the ray arrives along d) back along the ray, albedo included: `direct` the light
// of x's own next-event estimate, `indirect` the light of the events after x (PathState).
// events: the number of the path's last scatter event.
void scattered_radiance(vec3 x, vec3 d, uint first, inout Rng rng, inout bool truncated, out vec3 direct,
                        out vec3 indirect, out uint events) {
    PathState s = path_begin(x, d, first);
    path_run(s, first, BOUNCES_UNLIMITED, rng, truncated);
    direct = s.direct;
    indirect = s.indirect;
    events = s.events;
}
