// path_cache.glsl - a camera path that takes the multiply scattered cache at its k-th
// scatter event, k = LOOKUP_EVENT > 1 (cache.lookup_event; render_shade_cache.comp).
// Included by render.glsl after cache.glsl and cache_blend.glsl.
//
// The path is traced as plain path tracing does (path.glsl) up to its k-th event x_k,
// every event before it with its own direct light.  At x_k the cache is looked up as the
// lookup kernel does at the first event (render_lookup.comp): a hit adds x_k's direct
// light by next-event estimation and the cached multiply scattered part, both times the
// path's throughput beta_k (x_k's albedo and the roulette's 1/q included), and the path
// ends; a miss requests an entry at x_k (§5's locking) and the path goes on as plain
// path tracing.  Why later: a pixel's samples reach their k-th events at many points, so
// the error of any one entry reaches the pixel averaged with others' and weighted by the
// throughput of the first k - 1 events, where at the first event every sample of a pixel
// meets the same few entries.  The price: k - 1 more events per cached sample.
//
// Unbiased as k = 1 is: a hit replaces the expected value of the rest of the path at x_k
// (the in-scattered light there: direct plus multiply scattered, Eq. 1 of the path) by
// its estimate, with no roulette at x_k (the path ends with its expectation).  The blend
// (cache_blend.glsl) works at x_k as at the first event: C and P are the multiply
// scattered part at x_k in the pixel's units (beta_k included), P a plain continuation
// from x_k with x_k's own direct light left out (weight 0: shaded alike either way).
// Only with unlimited bounces (the host's rule): with a bounce limit an entry holds the
// light of the events a first event may still have, more than x_k may.

// P: a plain estimate of the multiply scattered part at the path's current event.
vec3 path_plain_rest(PathState s, inout Rng rng, inout bool truncated) {
    s.w_dir = 0.0;                  // x_k's own direct light is not part of C
    s.indirect = vec3(0.0);
    path_run(s, 1u, BOUNCES_UNLIMITED, rng, truncated);
    return s.indirect;
}

// The lookup at the path's current event (k >= 2, so its light goes to `indirect`);
// a hit ends the path.
void path_lookup(inout ScatterEvent e, inout PathState s) {
    float w = CACHE_BLEND ? pixel_blend_weight(e.px) : 0.0;
    if (CACHE_BLEND && blend_route(e.rng, w)) {      // the blend's plain sample: go on
        atomicAdd(cache_counters.routed, 1u);
        return;
    }
    vec3 E, aniso;
    bool near_centre;
    if (!render_cache_lookup(s.x, e.px, e.rng, E, aniso, near_centre)) return;   // a miss goes on
    Phase ph = phase_at(s.x, s.d);
    vec3 direct = s.beta * s.w_dir * direct_light(s.x, ph, e.rng, e.truncated);
    vec3 cached = s.beta * ms_inscattered(E, aniso, ph);
    if (CACHE_BLEND) {
        bool probed = blend_probe(e.rng);
        cached = blend_sample(e.idx, cached, w, probed, probed ? path_plain_rest(s, e.rng, e.truncated) : vec3(0.0));
    }
    s.indirect += direct + cached;
    s.done = true;
}

// The light scattered toward the camera at the camera ray's event e, as
// scattered_radiance(e.x, e.rd, 1, ...) returns it, with the cache at event LOOKUP_EVENT.
void cached_path(inout ScatterEvent e, out vec3 direct, out vec3 indirect, out uint events) {
    PathState s = path_begin(e.x, e.rd, 1u);
    path_run(s, 1u, LOOKUP_EVENT, e.rng, e.truncated);
    if (!s.done) path_lookup(e, s);
    path_run(s, 1u, BOUNCES_UNLIMITED, e.rng, e.truncated);
    direct = s.direct;
    indirect = s.indirect;
    events = s.events;
}
