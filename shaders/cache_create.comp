#version 450
// cache_create.comp - the cache-entry creation procedure (paper §4.2, §7): one
// workgroup of 128 threads per request.  Each thread estimates the irradiance (Eq. 4,
// sample_points; with USE_BOUNCES the multiply scattered fluence, fluence_ms_sample
// below, one point per lane: sample_points_ms)
// at the centre and at the six points offset by Delta along the local axes (at most two
// mean free paths: entry_delta in cache_math.glsl), by Monte
// Carlo with MIS (one light sample + one phase sample per point and round, transmittance
// by unbiased ray marching).  Each point takes rounds of 128 samples until its own Eq. 5
// holds or CREATE_MAX_ROUNDS is reached (the cap, cache.max_samples / 128; an entry with
// a point stopped at the cap is counted in `capped`).  Then
// thread 0 derives sigma_v (Eq. 6) and the radii (Eq. 9, 10, and the curvature limit
// of cache_math.glsl when turned on), and 27 threads insert
// the entry into the octree (one per node its bounding box may overlap); the request's lock
// (node or superpixel) is released.  Requests beyond this round's budget only unlock.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 128) in;

// Transmittance by unbiased ray marching (transmittance.glsl, ray_marching_transmittance), not
// ratio tracking: far fewer samples meet Eq. 5.
// Loop budget (llvmpipe truncates past 65535 loop iterations per invocation, summed over
// all loops): the estimates' combs share the pool rm_pool = CREATE_MAX_ROUNDS * 7 points
// * 2 estimates * RM_POOL_PER_ESTIMATE, one estimate taking at most RM_BUDGET of it; their
// order loops add at most RM_MAX_ORDER each: 6*7*2*(640+16) = 55104, plus the light
// loops (at most 4 * 32 per sample: 5376) and the reductions (about 350).  So on a CPU
// device at most 6 rounds, 6 * 128 = 768 samples per point (the default cap; the host
// rejects more there).  CREATE_MAX_ROUNDS, a specialization constant, is set from
// cache.max_samples; a GPU has no such bound (the host allows up to 64 rounds).
#define TRANSMITTANCE_RAY_MARCHING
#define RM_POOL_PER_ESTIMATE 640u
#define RM_BUDGET 4096u

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
#include "tracking.glsl"
#include "transmittance.glsl"
#include "background.glsl"
#include "lights.glsl"
#include "direct_light.glsl"
#include "distance.glsl"
#include "path.glsl"
#include "cache.glsl"

// sched_round: the scheduler's round; budget: requests to turn into entries this round
// (the §6 creation share); the other queued requests are dropped and their locks released;
// trusted_entries: the entries complete before this round (the host's last count).
// budget with REFINE_FLAG set: a refinement dispatch (refine_main), budget's other bits
// the first entry to refine.
layout(push_constant) uniform Push { uint sched_round; uint seed; uint budget; uint trusted_entries; } pc;
const uint REFINE_FLAG = 0x80000000u;

// With USE_BOUNCES the cache holds the multiply scattered light (render_lookup.comp): at
// x, the fluence of light that scattered at least once in the medium before reaching x,
//     E_ms(x) = integral over the sphere of L_ind(x, w) dw,
// L_ind the radiance arriving from w made of paths of two or more scatter events (x
// the first).  One sample: w uniform on the sphere (pdf 1 / (4 pi)), delta tracking from x
// along w to the next scatter event x' (it samples x' with density sigma_t T, leaving the
// albedo sigma_s / sigma_t as the weight), whose light scattered back toward x, albedo
// included, is the path tracer's from its second event on (path.glsl, scattered_radiance
// with first = 2: the same bounce limit, roulette and next-event estimation as a camera
// path): 4 pi times that, and 0 where the ray leaves the medium (what it sees there is
// direct light, shaded at every event).  The field is positive and smooth, so Eq. 5-11
// apply to it unchanged.  Without equiangular sampling along the first segment (its key
// leaves it out): unbiased all the same, with the variance near point lights that it
// would remove.
//
// Recursive use (final gathering): with unlimited bounces, where the cache already
// covers x' (entries of earlier rounds, pc.trusted_entries) the sample ends there: x''s
// direct light by next-event estimation plus its cached E_ms(x') / (4 pi), albedo
// included, as a camera path's hit is shaded (render_lookup.comp).  A sample then costs
// one free flight, one shadow ray and one lookup instead of a whole path, so the cache
// converges progressively.  Its bias: an entry's error is the albedo-weighted mean of
// the cache's errors at its samples' hits, plus its own noise; so with errors of at most
// b at the hits and albedo a, an entry made from them errs by at most a * b in the
// cached part (the part the hits carry), and the errors do not grow from generation to
// generation; the blend (cache_blend.glsl) removes what reaches the image.  With a bounce
// limit the entries of x' would hold one event too many, so a path is traced in full.
//
// Loop budget on a CPU device: each sample adds half of CREATE_SAMPLE_STEPS (a
// specialization constant) to path_pool, which its tracking loops draw from, a quarter
// to rm_pool, which its ray-marched
// transmittances draw from, and its lookup's walk takes at most a quarter (walk_cap, two
// iterations per reference), so that an invocation's MS_LANE_SAMPLES * CREATE_MAX_ROUNDS
// samples (sample_points_ms, refine_main) stay within llvmpipe's cap (the host sets it:
// picvr_create_sample_steps; on a GPU, which has no such cap, PATH_STEPS).  The pools
// carry over from sample to sample (the caller empties them before an invocation's
// first): what short paths leave, a long one later may use, and the sum stays within the
// cap.  A path that still runs dry is cut (path.glsl: biased toward dark, counted in
// cache_samples_truncated).
// Multiply scattered samples an invocation takes per round (sample_points_ms; the host's
// PICVR_CACHE_MS_LANE_SAMPLES, for CREATE_SAMPLE_STEPS).
const uint MS_LANE_SAMPLES = 8u;

// w: the sample's direction (the first moment's sample is the returned value times w).
vec3 fluence_ms_sample(vec3 x, inout Rng rng, inout bool truncated, out vec3 w) {
    path_pool += CREATE_SAMPLE_STEPS / 2u;   // carried over: see the loop budget above
    rm_pool += CREATE_SAMPLE_STEPS / 4u;
    walk_cap = min(CACHE_MAX_LOOKUP_REFS, CREATE_SAMPLE_STEPS / 8u);
    float u1 = rnd(rng), u2 = rnd(rng);
    w = uniform_sphere(u1, u2);
    float t_light, t0 = 0.0, t1 = 0.0;
    nearest_area_light(x, w, 1e30, t_light);
    if (!box_interval(x, w, t0, t1)) return vec3(0.0);
    t1 = min(t1, t_light);
    if (!(t1 > t0)) return vec3(0.0);
    bool cut = false;
    float t = delta_track(x, w, t0, t1, rng, cut);
    truncated = truncated || cut;
    if (t < 0.0) return vec3(0.0);
    vec3 x1 = x + w * t;
    if (scene.max_bounces == BOUNCES_UNLIMITED && pc.trusted_entries > 0u) {
        vec3 E, aniso;
        uint node;
        bool near_centre;
        if (cache_lookup(x1, E, aniso, node, near_centre)) {
            Phase ph = phase_at(x1, w);
            return 4.0 * PI * albedo_at(x1) * (direct_light(x1, ph, rng, truncated) + ms_inscattered(E, aniso, ph));
        }
    }
    vec3 direct, indirect;
    uint events;
    scattered_radiance(x1, w, 2u, rng, truncated, direct, indirect, events);
    return 4.0 * PI * (direct + indirect);
}


shared vec4 s_red[128];          // reduction scratch: (mean, m2, n) statistics or RGB sums
shared bool s_done;
shared bool s_point_done[7];     // point k met Eq. 5 in an earlier round: it stops sampling
shared uint s_truncated;         // samples whose transmittance estimate hit its loop bound
shared vec3 s_E[7];
shared uint s_entry;             // the stored entry's index and radii, for the inserters
shared float s_radius[6];
shared vec2 s_f;                 // medium fraction of +n, -n
shared vec3 s_aniso;             // with USE_BOUNCES: the centre's F / E (entry_moments)
shared uint s_rounds[7];         // the rounds of 128 samples each point took

// Sums s_red over the workgroup: into s_red[0] with lanes = 1, or with lanes = 8 into
// s_red[0..7], s_red[k] the sum over the invocations with lid & 7 == k (the multiply
// scattered layout: sample_points_ms).
void reduce_red(uint lanes) {
    for (uint stride = 64u; stride >= lanes; stride >>= 1u) {
        barrier();
        if (gl_LocalInvocationID.x < stride) s_red[gl_LocalInvocationID.x] += s_red[gl_LocalInvocationID.x + stride];
    }
    barrier();
}

// Merges the sample statistics s_red = (mean, m2, n, -) over the workgroup (Chan et al.'s
// pairwise rule, cache_math.glsl), into s_red[0] or s_red[0..7] as reduce_red does.
void reduce_stats(uint lanes) {
    for (uint stride = 64u; stride >= lanes; stride >>= 1u) {
        barrier();
        uint i = gl_LocalInvocationID.x;
        if (i < stride) {
            vec4 a = s_red[i], b = s_red[i + stride];
            s_red[i] = vec4(CM_FN(stat_merge_mean)(a.z, a.x, b.z, b.x),
                            CM_FN(stat_merge_m2)(a.z, a.x, a.y, b.z, b.x, b.y), a.z + b.z, 0.0);
        }
    }
    barrier();
}

// Point k of an entry centred at x0 with offset delta: the centre (k = 0), then the six
// offset points in half-axis order +t, -t, +b, -b, +n, -n of the local frame.
vec3 entry_point(vec3 x0, vec3 axis[3], float delta, uint k) {
    return k == 0u ? x0 : x0 + ((k & 1u) == 1u ? delta : -delta) * axis[(k - 1u) / 2u];
}

// The centre's first moment over its fluence, a = F / E in luminance, from the sum of
// the first-moment samples over n samples.  Rules: E = 0 gives a = 0 (nothing to
// weight); |a| > 1, possible only from noise (|F| <= E for any radiance), is scaled back
// to 1; a non-finite a (only from extreme input) is 0.
vec3 first_moment(vec3 F_sum, float n, float E_lum) {
    vec3 a = E_lum > 0.0 ? F_sum / (n * E_lum) : vec3(0.0);
    float len = length(a);
    if (!(len <= 1.0)) a = len < 3.0e38 ? a / len : vec3(0.0);
    return a;
}

// The single-scattered irradiance (Eq. 4) at the seven points p: every invocation
// samples each point still sampling once per round (uniform over the workgroup).  Leaves
// s_E, s_rounds and s_point_done.
void sample_points(vec3 p[7], uint req) {
    uint lid = gl_LocalInvocationID.x;
    // Per point: the RGB sum (the stored mean) and, for Eq. 5, the luminance samples'
    // running mean and m2 (Welford; cache_math.glsl, "Eq. 5's sample statistics").
    // Eq. 5 is a rule per estimate, so a point stops sampling once its own estimate meets
    // it (s_point_done) while the others go on: an entry costs fewer samples than when
    // all seven wait for the last, at a hit rate per entry at least as high (docs/cache.md,
    // "Eq. 5 per point").  The common random numbers (below) still tie the points that
    // sample in a round; a stopped point shares with the others the rounds it took.
    vec3 sum[7];
    float lmean[7], lm2[7];
    for (uint k = 0u; k < 7u; k++) { sum[k] = vec3(0.0); lmean[k] = 0.0; lm2[k] = 0.0; }
    uint truncated = 0u;             // this thread's samples with a truncated estimate
    bool converged = false;
    float gamma = scene.gamma;
    uint point_rounds[7];            // rounds each point took (uniform over the workgroup)
    for (uint k = 0u; k < 7u; k++) point_rounds[k] = 0u;
    for (uint round = 0u; round < CREATE_MAX_ROUNDS; round++) {
        // Common random numbers: in one round a thread estimates every point still
        // sampling with the same random streams (same light, point on it and phase
        // direction), so the
        // ratios E_Delta / E_0 of Eq. 6 and 10 are far less noisy than the points'
        // errors and a smooth field is not mistaken for a steep one.  Each point's
        // estimate stays unbiased.  Two streams, so that the phase sample does not
        // depend on how many numbers the light sample's tracking consumed.
        Rng light_rng = rng_init(req * 128u + lid, pc.sched_round * CREATE_MAX_ROUNDS + round, pc.seed ^ 0x5bd1e995u);
        Rng phase_rng = rng_init(req * 128u + lid, pc.sched_round * CREATE_MAX_ROUNDS + round, pc.seed ^ 0x2545f491u);
        for (uint k = 0u; k < 7u; k++) {
            if (s_point_done[k]) continue;           // uniform over the workgroup
            bool cut = false;
            vec3 e = irradiance_sample(p[k], light_rng, phase_rng, cut);
            if (cut) truncated++;
            // Rule: a non-finite sample (only from extreme input) counts as 0.
            if (any(isnan(e)) || any(isinf(e))) e = vec3(0.0);
            float l = CM_FN(stat_sample)(luminance(e));
            float n_before = float(point_rounds[k]);
            point_rounds[k]++;
            lm2[k] = CM_FN(stat_merge_m2)(n_before, lmean[k], lm2[k], 1.0, l, 0.0);
            lmean[k] = CM_FN(stat_merge_mean)(n_before, lmean[k], 1.0, l);
            sum[k] += e;
        }
        // Eq. 5 at every point still sampling: 1.96 sqrt(S^2(N)/N) <= gamma/(gamma+1) E(N),
        // on the merged statistics (cache_math.glsl, eq5_met; rule: a point with E = 0 and
        // S = 0, fully shadowed, passes); the entry is done when all seven are.
        for (uint k = 0u; k < 7u; k++) {
            if (s_point_done[k]) continue;           // uniform
            s_red[lid] = vec4(lmean[k], lm2[k], float(point_rounds[k]), 0.0);
            reduce_stats(1u);
            bool ok = CM_FN(eq5_met)(s_red[0].z, s_red[0].x, s_red[0].y, gamma);
            barrier();
            if (lid == 0u && ok) s_point_done[k] = true;
            barrier();
        }
        converged = true;
        for (uint k = 0u; k < 7u; k++) converged = converged && s_point_done[k];
        if (converged) break;
    }
    if (truncated > 0u) atomicAdd(s_truncated, truncated);   // rare: no reduction
    // Mean RGB irradiance at the seven points.  Rule: a negative mean (ray marching's
    // estimates may be negative; only a mean of noise about 0 could be) is stored as 0.
    for (uint k = 0u; k < 7u; k++) {
        float N = float(point_rounds[k] * 128u);
        s_red[lid] = vec4(sum[k], 0.0);
        reduce_red(1u);
        if (lid == 0u) { s_E[k] = max(s_red[0].xyz / N, vec3(0.0)); s_rounds[k] = point_rounds[k]; }
        barrier();
    }
}

// One multiply scattered sample of a lane (sample_points_ms, refine_main) at p from
// random stream `stream` of rng_init(stream, key, salt).  Rule: a non-finite sample (only
// from extreme input) counts as 0.  The centre's lanes add its first-moment sample.
vec3 ms_lane_sample(vec3 p, uint stream, uint key, uint salt, bool centre, inout uint truncated, inout vec3 moment) {
    Rng rng = rng_init(stream, key, salt);
    bool cut = false;
    vec3 w;
    vec3 e = fluence_ms_sample(p, rng, cut, w);
    if (cut) truncated++;
    if (any(isnan(e)) || any(isinf(e))) e = vec3(0.0);
    if (centre) moment += luminance(e) * w;
    return e;
}

// The multiply scattered fluence at the seven points p, one point per lane: of each 8
// consecutive invocations (a SIMD group on llvmpipe, subgroup size 8) lane k = lid & 7
// samples point k (the eighth idles), and the 16 groups (slot = lid >> 3) take
// MS_LANE_SAMPLES samples each per round: 128 per point and round, sample i = 8 slot + m
// drawing the stream creation gives sample i at every point (the common random numbers
// of Eq. 6).  So the lanes of a SIMD group follow nearly the same path from points Delta
// apart and end together, where lanes of independent paths (an invocation running its
// seven points in turn) would wait for the longest path of their group: a sample is a
// whole path of tens of events in a cloud, and coherence is the main lever on this
// driver (docs/lavapipe.md).  Eq. 5 per point as in sample_points; the lanes of a
// finished point idle.  Leaves s_E, s_rounds, s_point_done and the first moment s_aniso.
void sample_points_ms(vec3 p[7], uint req) {
    uint lid = gl_LocalInvocationID.x, k = lid & 7u, slot = lid >> 3u;
    vec3 sum = vec3(0.0), moment = vec3(0.0);   // moment: the centre's first-moment sum
    float lmean = 0.0, lm2 = 0.0, n = 0.0;      // Eq. 5's statistics (Welford)
    uint truncated = 0u, rounds = 0u;
    path_pool = 0u;                             // fluence_ms_sample's pools start empty
    rm_pool = 0u;
    for (uint round = 0u; round < CREATE_MAX_ROUNDS; round++) {
        if (k < 7u && !s_point_done[k]) {
            rounds++;
            for (uint m = 0u; m < MS_LANE_SAMPLES; m++) {
                vec3 e = ms_lane_sample(p[k], req * 128u + slot * MS_LANE_SAMPLES + m,
                                        pc.sched_round * CREATE_MAX_ROUNDS + round, pc.seed ^ 0x2545f491u,
                                        k == 0u, truncated, moment);
                float l = CM_FN(stat_sample)(luminance(e));
                lm2 = CM_FN(stat_merge_m2)(n, lmean, lm2, 1.0, l, 0.0);
                lmean = CM_FN(stat_merge_mean)(n, lmean, 1.0, l);
                n += 1.0;
                sum += e;
            }
        }
        s_red[lid] = vec4(lmean, lm2, n, 0.0);
        reduce_stats(8u);
        if (lid < 7u && !s_point_done[lid] && CM_FN(eq5_met)(s_red[lid].z, s_red[lid].x, s_red[lid].y, scene.gamma))
            s_point_done[lid] = true;
        barrier();
        bool converged = true;
        for (uint q = 0u; q < 7u; q++) converged = converged && s_point_done[q];
        if (converged) break;                    // uniform
    }
    if (truncated > 0u) atomicAdd(s_truncated, truncated);   // rare: no reduction
    // Rule: a negative mean is stored as 0, as in sample_points.
    s_red[lid] = vec4(sum, 0.0);
    reduce_red(8u);
    if (lid < 7u) {
        s_E[lid] = max(s_red[lid].xyz / float(rounds * 128u), vec3(0.0));
        s_rounds[lid] = rounds;
    }
    barrier();
    s_red[lid] = vec4(moment, 0.0);
    reduce_red(8u);
    if (lid == 0u) s_aniso = first_moment(s_red[0].xyz, float(rounds * 128u), luminance(s_E[0]));
    barrier();
}

// Progressive refinement of multiply scattered entries (USE_BOUNCES; the host dispatches
// it only then): workgroup i adds one creation round, 128 samples of fluence_ms_sample,
// at each of the seven points of entry (first + i) mod trusted_entries to their running
// means, with creation's common random numbers, and recomputes Eq. 6's sigma_v from them;
// the centre's first moment a likewise.  entry_moments[e].w holds the sample count N.  The
// offset points' old means come back from the stored values exactly:
// E_delta = E_0 exp(-sigma_v delta) (Eq. 6 inverted, in logs).  The radii stay as
// creation and the update procedure left them, so the octree is untouched.  The entry's
// noise falls as 1 / sqrt(N), in its value and in its gradients, whose noise the
// exponential extrapolation of Eq. 7 turns into a bias (E_0 exp(-sigma_v x) is convex in
// sigma_v); so the cache converges with time and the image's cached part with it.
// Refinement's samples gather from the cache as creation's do (a sample ending at a hit
// costs a flight, a shadow ray and a lookup, a whole path in a cloud of albedo 0.99 tens
// of events).  So what a lookup gets wrong is fed back into the entries: with lookups
// biased by b and a share s = albedo x (the part of a sample's light taken from hits),
// repeated refinement tends to entries biased by about b s / (1 - s).  b, the
// extrapolation's error, falls as the entries' noise does; what is left reaches the image
// only through the cached part, which the blend corrects.  A lookup may read an entry
// while another workgroup of the dispatch writes it: a mix of its old and new fields,
// each an estimate of the same quantity between the two.  Rules: an entry with
// N >= REFINE_MAX_SAMPLES (float counts stay exact) is left as it is; N counts the
// centre's samples and is taken for every point (on a CPU device every point takes one
// round at creation; on a GPU Eq. 5 may stop a point earlier, which only weights its
// old mean a little too much); a non-finite sample counts
// as 0 and a negative mean is stored as 0, as in creation; |a| > 1 is scaled back to 1.
const float REFINE_MAX_SAMPLES = 16777216.0;
void refine_main() {
    uint lid = gl_LocalInvocationID.x, k = lid & 7u, slot = lid >> 3u;   // sample_points_ms' layout
    uint e = ((pc.budget & ~REFINE_FLAG) + gl_WorkGroupID.x) % max(pc.trusted_entries, 1u);
    float N_old = entry_moments[e].w;
    if (!(N_old < REFINE_MAX_SAMPLES)) return;                // uniform over the workgroup
    lookup_entry_limit = pc.trusted_entries;
    vec3 x0 = entries[e].pos_rmax.xyz, n = entries[e].normal, t, b;
    float delta = entries[e].e0.w;
    basis(n, t, b);
    vec3 axis[3] = vec3[3](t, b, n);
    vec3 sum = vec3(0.0), moment = vec3(0.0);
    uint truncated = 0u;
    if (lid == 0u) s_truncated = 0u;
    barrier();
    if (k < 7u) {
        vec3 p = entry_point(x0, axis, delta, k);
        path_pool = 0u;                                       // creation's loop budget
        rm_pool = 0u;
        for (uint m = 0u; m < MS_LANE_SAMPLES; m++)
            sum += ms_lane_sample(p, e * 128u + slot * MS_LANE_SAMPLES + m, pc.sched_round, pc.seed ^ 0x68e31da4u,
                                  k == 0u, truncated, moment);
    }
    if (truncated > 0u) atomicAdd(s_truncated, truncated);
    float n_new = 128.0, N = N_old + n_new;
    s_red[lid] = vec4(sum, 0.0);
    reduce_red(8u);
    if (lid < 7u) {
        vec3 E_old = entries[e].e0.xyz;
        if (lid > 0u)
            for (uint c = 0u; c < 3u; c++)
                E_old[c] = CM_FN(irradiance_from_ln)(CM_FN(ln_irradiance)(E_old[c]) -
                                                     entries[e].sigma_v[(lid - 1u) * 3u + c] * delta);
        s_E[lid] = max((E_old * N_old + s_red[lid].xyz) / N, vec3(0.0));
    }
    barrier();
    s_red[lid] = vec4(moment, 0.0);
    reduce_red(8u);
    if (lid == 0u) {
        vec4 old = entry_moments[e];
        vec3 F = old.xyz * luminance(entries[e].e0.xyz) * N_old + s_red[0].xyz;   // sums of F
        vec3 a = first_moment(F, N, luminance(s_E[0]));
        for (uint h = 0u; h < 6u; h++)
            for (uint c = 0u; c < 3u; c++)
                entries[e].sigma_v[h * 3u + c] = CM_FN(sigma_v)(s_E[0][c], s_E[1u + h][c], delta);   // Eq. 6
        entries[e].e0.xyz = s_E[0];
        entry_moments[e] = vec4(a, N);
        atomicAdd(cache_counters.point_rounds, 7u);
        if (s_truncated > 0u) atomicAdd(cache_counters.truncated, s_truncated);
    }
}

void main() {
    if (USE_BOUNCES && (pc.budget & REFINE_FLAG) != 0u) {
        refine_main();
        return;
    }
    uint req = gl_WorkGroupID.x;
    uint lid = gl_LocalInvocationID.x;
    // The indirect dispatch has one workgroup per valid request (dispatch_x).
    uint locked = requests[req].node;
    // A full pool (entries, nodes or references) stops growth: no estimation is spent
    // on an entry that could not be stored.  Read once, so the branch is uniform.
    if (lid == 0u) { s_done = cache_counters.full != 0u; s_truncated = 0u; }
    barrier();
    bool full = s_done;
    barrier();
    if (req >= pc.budget || full) {                  // uniform over the workgroup
        if (lid == 0u) cache_unlock(locked);
        return;
    }
    vec3 x0 = requests[req].pos.xyz;
    rm_pool = CREATE_MAX_ROUNDS * 7u * 2u * RM_POOL_PER_ESTIMATE;   // with USE_BOUNCES: per sample
    lookup_entry_limit = pc.trusted_entries;

    vec3 n = entry_normal(x0), t, b;
    basis(n, t, b);
    vec3 axis[3] = vec3[3](t, b, n);
    // The entry's offset (cache_math.glsl, entry_delta): Table 1's Delta, or two mean free
    // paths of the densest of the centre and the six Table 1 offset points if shorter.
    float sigma_local = sigma_t_in_box(x0);
    for (uint k = 0u; k < 3u; k++) {
        sigma_local = max(sigma_local, sigma_t_in_box(x0 + scene.delta * axis[k]));
        sigma_local = max(sigma_local, sigma_t_in_box(x0 - scene.delta * axis[k]));
    }
    float delta = CM_FN(entry_delta)(scene.delta, sigma_local);
    vec3 p[7];
    for (uint k = 0u; k < 7u; k++) p[k] = entry_point(x0, axis, delta, k);

    // The medium fraction of the half-axes +n and -n (cache_math.glsl, medium_fraction):
    // how many of 8 probes, at the midpoints of eighths of Delta, lie in the medium.  1
    // (the paper's secant) when the medium model is off.
    if (lid < 2u) {
        float f = 1.0;
        if (scene.medium_model != 0u) {
            vec3 dir = lid == 0u ? n : -n;
            float n_in = 0.0;
            for (uint k = 0u; k < 8u; k++)
                if (sigma_t_in_box(x0 + (float(k) + 0.5) * 0.125 * delta * dir) > 0.0) n_in += 1.0;
            f = CM_FN(medium_fraction)(n_in);
        }
        s_f[lid] = f;
    }
    barrier();

    if (lid < 7u) s_point_done[lid] = false;
    barrier();
    if (USE_BOUNCES) sample_points_ms(p, req);
    else sample_points(p, req);
    bool converged = true;           // every point met Eq. 5
    uint point_rounds_sum = 0u;
    for (uint k = 0u; k < 7u; k++) {
        converged = converged && s_point_done[k];
        point_rounds_sum += s_rounds[k];
    }

    if (lid == 0u) {
        uint e = atomicAdd(cache_counters.entry_count, 1u);
        if (e >= scene.max_entries) {
            atomicExchange(cache_counters.full, 1u);
            s_done = false;                              // no insertion
        } else {
            // Stored although Eq. 5 still failed at the cap: counted, so that a user can
            // see how many entries carry more than gamma's error (stats.cache_entries_capped).
            if (!converged) atomicAdd(cache_counters.capped, 1u);
            // The samples it took, and those with an estimate cut at RM_BUDGET or
            // RM_MAX_ORDER (biased; stats.cache_samples, cache_samples_truncated).
            atomicAdd(cache_counters.point_rounds, point_rounds_sum);
            if (s_truncated > 0u) atomicAdd(cache_counters.truncated, s_truncated);
            float eps = scene.epsilon;
            float rmin = CM_FN(entry_r_min)(scene.radius_min, delta, scene.delta);
            float rmax_cap = CM_FN(entry_r_max)(scene.radius_max, delta, scene.delta);
            float rmax = 0.0;
            for (uint h = 0u; h < 6u; h++) {
                float r = rmax_cap;
                for (uint c = 0u; c < 3u; c++) {
                    float e0 = s_E[0][c], ed = s_E[1u + h][c];
                    entries[e].sigma_v[h * 3u + c] = CM_FN(sigma_v)(e0, ed, delta);          // Eq. 6
                    r = min(r, CM_FN(validity_radius)(e0, ed, delta, eps, rmin, rmax_cap)); // Eq. 9, 10
                    if (scene.curvature_limit != 0u) {   // the curvature limit of this axis
                        uint ax = h / 2u;
                        r = min(r, CM_FN(curvature_radius)(CM_FN(ln_irradiance)(s_E[2u + 2u * ax][c]),
                                                           CM_FN(ln_irradiance)(e0),
                                                           CM_FN(ln_irradiance)(s_E[1u + 2u * ax][c]),
                                                           delta, eps, rmin, rmax_cap));
                    }
                }
                entries[e].radius[h] = floatBitsToUint(r);
                s_radius[h] = r;
                rmax = max(rmax, r);
            }
            entries[e].e0 = vec4(s_E[0], delta);         // w: the entry's own Delta
            // w: the centre's sample count (refine_main)
            if (USE_BOUNCES) entry_moments[e] = vec4(s_aniso, float(s_rounds[0] * 128u));
            entries[e].normal = n;
            entries[e].medium_f = packUnorm2x16(vec2(1.0) - s_f);
            entries[e].pos_rmax = vec4(x0, rmax);
            s_entry = e;
            s_done = true;
        }
    }
    memoryBarrierBuffer();
    barrier();
    if (s_done && lid < 27u)
        insert_cell(s_entry, x0, n, vec3(s_radius[0], s_radius[2], s_radius[4]),
                    vec3(s_radius[1], s_radius[3], s_radius[5]), lid);
    barrier();
    if (lid == 0u) cache_unlock(locked);
}
