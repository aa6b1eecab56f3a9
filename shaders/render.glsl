// render.glsl - the rendering procedure's shared code (paper §4.1), as three kernels so
// that each runs only the work its invocations share (a wavefront, in GPU terms):
//   render_track.comp   one thread per pixel of the queued blocks: tracks the primary
//                       ray; a ray that leaves the volume is finished there, a scatter
//                       event is queued for the cache lookup (cached) or for shading;
//   render_lookup.comp  (cached only) one thread per queued event: a hit is shaded from
//                       the cache, a miss requests an entry and is queued for shading;
//   render_shade.comp   one thread per queued event: plain Monte Carlo shading.
// Split, the shading and lookup kernels see only live events (llvmpipe runs 8 lanes
// under one mask, a GPU 32: in one kernel a single scattering or missing lane makes the
// whole group run the rays), and each kernel is smaller (docs/cache.md, "The rendering
// procedure as three kernels").
// The shared code it uses, in dependency order (each file includes what it uses, once).
#include "specialization.glsl"
#include "scene.glsl"
#include "sampling_math.glsl"
#include "random.glsl"
#include "geometry.glsl"
#include "clip.glsl"
#include "views.glsl"
#include "medium.glsl"
#include "phase.glsl"
#include "majorant.glsl"
#include "atomic64.glsl"
#include "tracking.glsl"
#include "transmittance.glsl"
#include "background.glsl"
#include "lights.glsl"
#include "camera.glsl"
#include "direct_light.glsl"
#include "distance.glsl"
#include "path.glsl"
#include "queue.glsl"
#include "mutation.glsl"

layout(set = 0, binding = 4, std430) buffer AccumMean { vec4 accum_mean[]; };  // rgb, coverage
layout(set = 0, binding = 5, std430) buffer AccumComp { vec4 accum_comp[]; };  // Kahan terms
layout(set = 0, binding = 6, std430) buffer AccumStat { vec4 accum_stat[]; };  // lum mean, M2, n, bad
layout(set = 0, binding = 20, std430) buffer AccumDepth { vec2 accum_depth[]; };  // mean t, count (uint bits)

// The event queues of one dispatch of the rendering procedure, one buffer each so that
// each stays within maxStorageBufferRange as the image does: for shading (binding 16),
// and with the cache for the lookup (binding 17, declared by the kernels that use it,
// PICVR_CACHE).  A queue's head: xyz the indirect dispatch of its kernel (x counts
// workgroups), w the events queued; then EVENT_WORDS words per event: the pixel, the
// scatter distance t (float bits) and the pixel's random-number counter after tracking,
// with bit 31 the `truncated` flag (the counter fits in 31 bits: tracking draws a few
// numbers per step of at most MAX_TRACK_STEPS, far below 2^31).  Rule: a dispatch
// renders each block at most once
// (block_select.comp), so a queue never holds more than one event per pixel and cannot
// overflow.
layout(set = 0, binding = 16, std430) buffer ShadeQueue { uvec4 head; uint ev[]; } shade_queue;
#ifdef PICVR_CACHE
layout(set = 0, binding = 17, std430) buffer LookupQueue { uvec4 head; uint ev[]; } lookup_queue;
#endif
#define EVENT_WORDS 3u
// Threads per workgroup of the event kernels: one dispatch holds at most MAX_QUEUE
// (65535) blocks of 128 pixels, so 128 keeps its workgroups within the 65535 that
// every Vulkan device allows.
#define EVENT_GROUP 128u

// round: the scheduler's round (keys the screen-space locking counters); request_cap:
// creation requests this round may issue (the creation budget of the next round).
// flags: ROUND_* below; spread_scale: 1 / the image's mean luminance (ROUND_MEASURE).
layout(push_constant) uniform Push { uint round; uint seed; uint request_cap; uint flags; float spread_scale; } pc;

// PICVR_DISTANCE_AUTO (variants with USE_MEASURE; host/schedule.c, picvr_dauto_flags):
// the round adds the spread of its samples to render_queue.spread (measure_spread), of
// every pixel in a probe and of one pixel in MEASURE_STRIDE otherwise (the atomics of
// every sample cost the round several per cent on lavapipe).
#define ROUND_MEASURE 2u
// A probe: the round measures its samples and adds none to the image (the kind that is
// not rendering, measured against the image's means).
#define ROUND_PROBE 4u
// A probe whose samples also go to the image: its kind's variance is below twice the
// chosen kind's, so they lower the mean's variance (host/schedule.c, picvr_dauto_flags).
#define ROUND_KEEP 8u
#define MEASURE_STRIDE 8u

// A probe that adds nothing: its samples go to the measure alone.
bool round_discards() {
    return USE_MEASURE && (pc.flags & (ROUND_PROBE | ROUND_KEEP)) == ROUND_PROBE;
}

// PICVR_DISTANCE_AUTO's measure of a sample's variance (host/schedule.c, picvr_dauto_account):
// with m the pixel's running mean of n >= 2 samples and S^2 = M2 / (n - 1), the sample's
// squared deviation d^2 = (lum - m)^2 has expectation v + Var(m) (the sample is
// independent of the earlier ones, and m is unbiased whichever kind made it), and S^2 / n
// is an unbiased estimate of Var(m).  Both are scaled by the image's mean luminance (a
// pixel's own running mean, near 0 while a thin medium's rare events are unseen, made
// the ratios explode).  Their sums, in units of 2^-16 (rounded to the nearest), and the
// count of samples go to render_queue.spread and totals.w; the host takes
// v = (sum d^2 - sum S^2/n) / count.  Rules: n < 2 (no mean to measure against, or no
// S^2) or a scale that is not > 0 -> not counted; each term is clamped to 2^16 (a firefly
// 256 times the image's mean counts as a large sample and never overflows a sum: fewer
// than 2^32 units per term).
void measure_spread(vec4 s, float lum) {
    uint n = floatBitsToUint(s.z);
    float scale = pc.spread_scale;
    if (n < 2u || !(scale > 0.0)) return;
    float d = (lum - s.x) * scale;
    float var_mean = max(s.y, 0.0) / (float(n - 1u) * float(n)) * (scale * scale);
    ATOMIC_ADD64(render_queue.spread.x, render_queue.spread.y, uint(min(d * d, 65535.0) * 65536.0 + 0.5))
    ATOMIC_ADD64(render_queue.spread.z, render_queue.spread.w, uint(min(var_mean, 65535.0) * 65536.0 + 0.5))
    atomicAdd(render_queue.totals.w, 1u);
}

// Kahan-compensated running mean (precise: no reassociation by the compiler), so
// that after millions of samples an update of relative size 1e-7 is not lost.
void accumulate(uint idx, vec3 radiance, float coverage, bool bad) {
    vec4 s = accum_stat[idx];
    if (USE_MEASURE && (pc.flags & ROUND_MEASURE) != 0u) {
        bool probe = (pc.flags & ROUND_PROBE) != 0u;
        if (probe || idx % MEASURE_STRIDE == pc.round % MEASURE_STRIDE) measure_spread(s, luminance(radiance));
        if (round_discards()) return;
    }
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
    // Rule: M2 saturates at the largest float (a pixel brighter than ~1e19, where the
    // squares overflow): its error estimate is then finite but too small, never Inf.
    // delta (lum - mean) >= 0, so the sum is never NaN.
    precise float m2 = min(s.y + delta * (lum - mean), 3.4028235e38);
    uint nbad = floatBitsToUint(s.w) + (bad ? 1u : 0u);
    accum_stat[idx] = vec4(mean, m2, uintBitsToFloat(n), uintBitsToFloat(nbad));
}

// With USE_REUSE: the running mean of the camera ray's scatter distance t over the
// pixel's samples that scattered (the depth that host/reproject.c moves it by).
// Rule: t < 0 (the ray passed) and non-finite t leave the mean alone.
void accumulate_depth(uint idx, float t) {
    if (!USE_REUSE || !(t >= 0.0) || isinf(t) || round_discards()) return;
    vec2 d = accum_depth[idx];
    uint n = floatBitsToUint(d.y) + 1u;
    accum_depth[idx] = vec2(d.x + (t - d.x) / float(n), uintBitsToFloat(n));
}

// Rule: a non-finite sample (only possible from extreme user input overflowing float)
// is replaced by 0 and counted with the truncated ones; it never reaches the image.
void accumulate_sample(uint idx, vec3 radiance, float coverage, bool truncated) {
    bool bad = truncated;
    if (any(isnan(radiance)) || any(isinf(radiance))) { radiance = vec3(0.0); bad = true; }
    accumulate(idx, MUTATE(MUT_RENDER, radiance), coverage, bad);
}

// Random numbers keyed by (pixel, sample index): every pixel's n-th sample is the same
// whichever round, block order or kernel produced it.
Rng pixel_rng(uint idx) { return rng_init(idx, floatBitsToUint(accum_stat[idx].z), pc.seed); }

struct ScatterEvent { uint idx; uvec2 px; vec3 rd; float t; vec3 x; Rng rng; bool truncated; };

// Plain Monte Carlo's single-scattered light at the event e, albedo included: one light
// and one phase sample, combined by MIS.
vec3 event_direct(inout ScatterEvent e) {
    e.rng.event = QMC_EVENT_A;
    return albedo_at(e.x) * direct_light(e.x, phase_at(e.x, e.rd), e.rng, e.truncated);
}

// A plain estimate of what the cache holds at the event e, albedo included, for the
// consistent blend's probes and the cache-error view: the direct light (single
// scattering), or with USE_BOUNCES the light of the path's later scatter events (the
// multiply scattered part: the event's own direct light is shaded at every event, cached
// or not, so it is left out of the difference).
vec3 plain_cached_part(inout ScatterEvent e) {
    if (!USE_BOUNCES) return event_direct(e);
    vec3 direct, indirect;
    uint events;
    scattered_radiance(e.x, e.rd, 1u, e.rng, e.truncated, direct, indirect, events);
    return indirect;
}

// The kernels that shade from the cache: the lookup at the first scatter event
// (PICVR_CACHE_SHADING) and, with cache.lookup_event > 1, the shading kernel that looks
// up at a later one (PICVR_CACHE_PATHS, render_shade_cache.comp).
#if defined(PICVR_CACHE_SHADING) || defined(PICVR_CACHE_PATHS)
#include "cache.glsl"
#include "cache_blend.glsl"
#endif
#if defined(PICVR_CACHE_SHADING) || defined(PICVR_CACHE_PATHS)
// The rendering procedure's lookup at x for pixel px (at the first scatter event or a
// later one): counts the hit or miss (and screen-space locking's ray) and on a miss
// requests an entry under the context's locking (§5.1, §5.2).
bool render_cache_lookup(vec3 x, uvec2 px, inout Rng rng, out vec3 E, out vec3 aniso, out bool near_centre) {
    uint node;
    bool hit = cache_lookup(x, E, aniso, node, near_centre);
    if (SCREEN_LOCKING) count_ray(px, !hit, pc.round);
    if (hit) {
        atomicAdd(cache_counters.hits, 1u);
    } else {
        cache_request(x, node, px, pc.round, rnd(rng), pc.request_cap);
        atomicAdd(cache_counters.misses, 1u);
    }
    return hit;
}
#endif
#ifdef PICVR_CACHE_PATHS
#include "path_cache.glsl"
#endif

// The light scattered toward the camera at the event e (albedo included) and the event's
// scatter events: the direct light alone, or with USE_BOUNCES the whole path
// (path.glsl; in render_shade_cache.comp with the cache looked up at its LOOKUP_EVENT-th
// event, path_cache.glsl), `direct` its first event's own part.
vec3 event_radiance(inout ScatterEvent e, out vec3 direct, out uint events) {
    events = 1u;
    if (!USE_BOUNCES) {
        direct = event_direct(e);
        return direct;
    }
    vec3 indirect;
    e.rng.event = QMC_EVENT_A;
#ifdef PICVR_CACHE_PATHS
    if (LOOKUP_EVENT > 1u) {
        cached_path(e, direct, indirect, events);
        return direct + indirect;
    }
#endif
    scattered_radiance(e.x, e.rd, 1u, e.rng, e.truncated, direct, indirect, events);
    return direct + indirect;
}

// Adds a path's scatter events to the 64-bit counter of picvr_stats.mean_path_length.
void count_events(uint n) {
    if (n == 0u || round_discards()) return;
    ATOMIC_ADD64(render_queue.totals.y, render_queue.totals.z, n)
}

// A scatter event, as the event kernels take it up again: t < 0 (only with
// USE_EQUIANGULAR, where every ray through the volume is queued) when delta tracking
// passed.

// Queue Q (shade_queue or lookup_queue) gains the event (idx, t, rng, truncated): a
// macro, as GLSL passes no buffers to functions.
#define QUEUE_EVENT(Q, idx, t, rng, truncated) {                                        \
    uint slot_ = atomicAdd(Q.head.w, 1u);                                               \
    if (slot_ % EVENT_GROUP == 0u) atomicAdd(Q.head.x, 1u);                             \
    Q.ev[slot_ * EVENT_WORDS] = (idx);                                                  \
    Q.ev[slot_ * EVENT_WORDS + 1u] = floatBitsToUint(t);                                \
    Q.ev[slot_ * EVENT_WORDS + 2u] = ((rng).counter & 0x7fffffffu) | ((truncated) ? 0x80000000u : 0u); }

// The event of words (idx, t, w) taken up again.  The camera ray is drawn again from
// the pixel's random numbers (the same draws, so the same ray), then the numbers go on
// where tracking left them.
ScatterEvent unpack_event(uint idx, uint t_bits, uint w) {
    ScatterEvent e;
    e.idx = idx;
    e.px = uvec2(idx % scene.image.x, idx / scene.image.x);
    e.rng = pixel_rng(idx);
    e.rd = camera_ray(e.px, e.rng);
    e.t = uintBitsToFloat(t_bits);
    e.x = scene.cam_pos + e.rd * max(e.t, 0.0);
    e.rng.counter = w & 0x7fffffffu;
    e.truncated = (w & 0x80000000u) != 0u;
    return e;
}

// This invocation's event of queue Q into e; returns from main past the queue's end.
#define LOAD_EVENT(Q, e) {                                                              \
    uint i_ = gl_GlobalInvocationID.x;                                                  \
    if (i_ >= Q.head.w) return;                                                         \
    e = unpack_event(Q.ev[i_ * EVENT_WORDS], Q.ev[i_ * EVENT_WORDS + 1u], Q.ev[i_ * EVENT_WORDS + 2u]); }

// What a camera ray sees at the end of its medium segment [t0, t1]: the nearest area
// light, else the background.  t0 >= t1 when it misses the volume.
struct CameraSegment { float t0; float t1; vec3 end_radiance; };

CameraSegment camera_segment(vec3 rd) {
    CameraSegment c;
    float t_light;
    int light_hit = nearest_area_light(scene.cam_pos, rd, 1e30, t_light);
    c.end_radiance = light_hit >= 0 ? area_light_radiance(uint(light_hit), rd) : background_radiance(rd);
    if (!box_interval(scene.cam_pos, rd, c.t0, c.t1)) { c.t0 = 0.0; c.t1 = 0.0; }
    c.t1 = min(c.t1, t_light);
    return c;
}

// Parts B and C of an equiangular camera sample (distance.glsl) and part A's weight.
// T_end < 0: part C was left out (nothing to see at the end of the segment).
struct CameraSample { float w_a; float t_b; float f_b; float T_end; };

CameraSample camera_sample(ScatterEvent e, CameraSegment seg, bool need_end, inout Rng rng, inout bool truncated) {
    vec3 ro = scene.cam_pos;
    // The forced share's two more walks (the segment's depth, the point), once per
    // camera ray, come out of the path's loop pool (tracking.glsl): a walk crosses at
    // most grid.x + grid.y + grid.z cells.
    float f = USE_FORCED ? scene.forced_pmf : 0.0;
    if (USE_BOUNCES && f > 0.0)
        path_pool -= min(path_pool, 2u * (scene.grid.x + scene.grid.y + scene.grid.z));
    CameraSample c;
    float u_light = one_or_rnd(rng, true, QMC_B_CHOICE);
    float z;
    c.t_b = b_sample(ro, e.rd, seg.t0, seg.t1, f, u_light, qmc(rng, 2u), z);
    c.f_b = 0.0;
    // B's transmittance is needed where it lands in medium, or for the end term
    float s_b = c.t_b >= 0.0 ? sigma_t(ro + e.rd * c.t_b) : 0.0;
    // An estimate cut at its loop bound is 0 (tracking.glsl, track): B then contributes
    // nothing and the end is seen as black (biased dark, counted in `truncated`).
    float T_b = 1.0;
    if (s_b > 0.0 || (need_end && c.t_b >= 0.0)) T_b = transmittance(ro, e.rd, c.t_b, rng, truncated);
    // the end term: T^(t_B) times an independent estimate over [t_B, t1]
    float t_mid = max(c.t_b, seg.t0);
    c.T_end = -1.0;
    if (need_end)
        c.T_end = T_b != 0.0 ? T_b * transmittance(ro + e.rd * t_mid, e.rd, seg.t1 - t_mid, rng, truncated) : 0.0;
    // T_b != 0, not > 0: a ray-marched estimate may be negative (transmittance.glsl)
    bool b_counts = s_b > 0.0 && T_b != 0.0;
    float t_b_counts = b_counts ? c.t_b : -1.0;
    SegmentDepths sd = segment_depths(ro, e.rd, seg.t0, max(e.t, t_b_counts), e.t, t_b_counts);
    vec2 p_b = b_pdfs(ro, e.rd, seg.t0, seg.t1, e.t, t_b_counts, sd, f, z);
    c.w_a = 1.0;
    if (e.t >= 0.0) c.w_a = cm_mis_power(free_flight_proxy(sigma_t(e.x), sd.tau_min.x), p_b.x);
    if (b_counts) c.f_b = cm_eq_weight(T_b, s_b, free_flight_proxy(s_b, sd.tau_min.y), p_b.y);
    return c;
}

// The radiance of an equiangular camera sample; when a_known, part A's scattered radiance
// (albedo included) is Ls_a, its direct part (weighted against B), plus rest_a, the light
// of later scatter events (weight 1: the multiply scattered cache's part); else A is
// shaded here by plain Monte Carlo (when delta tracking collided).  B is shaded by plain
// Monte Carlo.  coverage: 1 - T^(t1) in [0, 1], or delta tracking's 0/1 outcome (also
// unbiased) where part C is left out: nothing but black is seen at the end of the segment.
vec3 finish_camera_sample(inout ScatterEvent e, bool a_known, vec3 Ls_a, vec3 rest_a, out float coverage,
                          out uint events) {
    CameraSegment seg = camera_segment(e.rd);
    bool need_end = any(greaterThan(seg.end_radiance, vec3(0.0)));
    CameraSample c = camera_sample(e, seg, need_end, e.rng, e.truncated);
    vec3 L = need_end ? c.T_end * seg.end_radiance : vec3(0.0);
    events = 0u;
    if (e.t >= 0.0) {
        // B estimates the direct part only, so only A's direct part is weighted against
        // it; the light of later scatter events has A alone as its estimator (weight 1).
        vec3 all_a = Ls_a + rest_a;
        if (!a_known) all_a = event_radiance(e, Ls_a, events);
        else events = 1u;
        L += c.w_a * Ls_a + (all_a - Ls_a);
    }
    if (c.f_b > 0.0) {
        vec3 xb = scene.cam_pos + e.rd * c.t_b;
        e.rng.event = QMC_EVENT_B;
        L += c.f_b * albedo_at(xb) * direct_light(xb, phase_at(xb, e.rd), e.rng, e.truncated);
    }
    // Rule: a ray-marched T_end outside [0, 1] (rare) is clamped in the coverage alone;
    // the radiance keeps it
    coverage = need_end ? clamp(1.0 - c.T_end, 0.0, 1.0) : (e.t >= 0.0 ? 1.0 : 0.0);
    return L;
}
