// transmittance.glsl - the transmittance along a shadow ray: residual or plain ratio
// tracking (tracking.glsl) in the rendering kernels by default, unbiased ray marching in
// entry creation (TRANSMITTANCE_RAY_MARCHING, defined by cache_create.comp before it
// includes this) and in the rendering kernels of PICVR_TRANSMITTANCE_RAY_MARCHING
// (specialization.glsl, USE_RAY_MARCHING).
#ifndef TRANSMITTANCE_GLSL_ONCE
#define TRANSMITTANCE_GLSL_ONCE 1
#include "specialization.glsl"
#include "limits.glsl"
#include "scene.glsl"
#include "random.glsl"
#include "clip.glsl"
#include "medium.glsl"
#include "majorant.glsl"
#include "tracking.glsl"
#include "mutation.glsl"

// ---- unbiased ray-marching transmittance ----
// Kettunen et al. 2021, "An Unbiased Ray-Marching Transmittance Estimator", simplified.
// Why in creation: ratio tracking against tight majorants is nearly a 0/1
// estimate, so Eq. 5 needs thousands of samples wherever the light arrives through the
// medium; most entries then miss it at the sample cap, and their noise darkens the image
// where several entries meet (docs/cache.md, "Entry noise and the dark pot").  This
// estimator is exact in a homogeneous medium and low-variance elsewhere, but costs
// several ratio-tracking samples, so the renderer keeps residual ratio tracking unless
// the caller asks for it (PICVR_TRANSMITTANCE_RAY_MARCHING: it pays where the noise of
// the shadow rays and of the end term dominates, in thin media; docs/sampling.md).
// RM_BUDGET is the most loop iterations (DDA steps plus samples, all orders) one
// estimate may take (a kernel may define it before including this file); the pool
// rm_pool holds the iterations all of an invocation's estimates may still take
// together: set by entry creation before its first estimate; in the rendering kernels
// RM_RENDER_POOL, or with USE_BOUNCES the path's pool (tracking.glsl, path_pool), which
// its tracking loops share.  An estimate takes at most min(RM_BUDGET, rm_pool); past that it is
// truncated (biased, flagged like a tracking loop at its bound).  Why a pool:
// llvmpipe's cap bounds the sum over an invocation, not each estimate, and most
// estimates take a few dozen iterations, so a long ray through many bricks may use
// what the short ones left, which a fixed share per estimate would cut (docs/cache.md,
// "Guards on creation's estimates").
#ifndef RM_BUDGET
#define RM_BUDGET MAX_TRACK_STEPS
#endif
// A rendering invocation without bounces makes at most six estimates (the end term's two,
// a light and a phase sample's shadow rays at each of the two points), so this pool
// never cuts one, and with the tracking loops stays far below llvmpipe's 65535.
#define RM_RENDER_POOL (6u * RM_BUDGET)
#define RM_TAU_STEP 0.5     // majorant optical depth per stratum (at most one per voxel)
#define RM_COMB_SAMPLES 192.0 // long rays: strata at least (t1 - t0) / this apart
uint rm_pool = RM_RENDER_POOL;  // iterations left to this invocation's estimates (above)

// X, an unbiased estimate of the optical depth of [t0, t1]: a stratified comb.  Each
// non-empty brick the ray crosses gets n equal strata with one jittered sample each, n
// from the brick's majorant depth over RM_TAU_STEP, at most one per smallest voxel
// spacing or per 1/RM_COMB_SAMPLES of the segment, whichever is longer (so that a comb
// across a large volume stays within RM_BUDGET); empty bricks (majorant 0, so sigma_t =
// 0) are skipped.  E[X] = tau exactly.
float comb_optical_depth(vec3 ro, vec3 rd, float t0, float t1, inout Rng rng, inout uint steps,
                         uint limit, inout bool truncated) {
    Dda d = coarse_start(ro, rd, t0);
    float t = t0, tau = 0.0;
    float h_min = max(scene.min_spacing, (t1 - t0) / RM_COMB_SAMPLES);
    while (true) {
        if (steps >= limit) { truncated = true; break; }
        steps++;
        float maj = cell_majorant(d);
        if (maj <= 0.0) {
            float jump = empty_skip(d, rd);
            if (jump > 0.0) {
                t += jump;
                if (t >= t1) break;
                d = coarse_start(ro, rd, t);
                continue;
            }
        }
        float t_cell = min(dda_exit(d), t1);
        float len = t_cell - t;
        if (maj > 0.0 && len > 0.0) {
            float n_max = max(ceil(len / h_min), 1.0);
            uint n = uint(clamp(ceil(maj * len / RM_TAU_STEP), 1.0, n_max));
            if (steps + n > limit) { truncated = true; n = limit - steps; }
            float h = len / float(max(n, 1u));
            float u = rnd(rng);
            float s = 0.0;
            for (uint i = 0u; i < n; i++) s += sigma_t(ro + rd * (t + (float(i) + u) * h));
            tau += s * h;
            steps += n;
        }
        t = t_cell;
        if (t >= t1 || !dda_advance(d)) break;
    }
    return tau;
}

// The estimator: ray_marching_series.glsl (its rules for every degenerate case are
// there), fed with combs of this ray.  Past RM_BUDGET steps (or the pool) the combs are
// cut and the estimate flagged as truncated.
#define RM_PARAMS vec3 ro, vec3 rd, float t0, float t1, inout Rng rng, inout bool truncated, \
                  inout uint steps, uint limit
#define RM_COMB() comb_optical_depth(ro, rd, t0, t1, rng, steps, limit, truncated)
#define RM_RND() rnd(rng)
#define RM_TRUNCATE() truncated = true
#include "ray_marching_series.glsl"

// The pool an estimate draws from: entry creation's rm_pool; in a rendering kernel with
// bounces the path's pool, shared with its tracking loops.  RM_ON: every shadow ray of
// the kernel is ray-marched.
#ifdef TRANSMITTANCE_RAY_MARCHING
#define RM_SHARES_PATH_POOL false
#define RM_ON true
#else
#define RM_SHARES_PATH_POOL USE_BOUNCES
#define RM_ON USE_RAY_MARCHING
#endif

// Rule: the estimate may be negative or above 1 (rarely; ray_marching_series.glsl); its
// callers keep its sign (a sample dropped where T <= 0 would bias the mean).
float ray_marching_transmittance(vec3 ro, vec3 rd, float t0, float t1, inout Rng rng,
                                 inout bool truncated) {
    uint pool = RM_SHARES_PATH_POOL ? path_pool : rm_pool;
    uint steps = 0u, limit = min(RM_BUDGET, pool);
    float T = cm_ray_marching_series(ro, rd, t0, t1, rng, truncated, steps, limit);
    if (RM_SHARES_PATH_POOL) path_pool -= steps;   // steps <= limit <= the pool
    else rm_pool -= steps;
    return T;
}

// Transmittance from x along unit w over distance dist (only the part inside the box).
float transmittance(vec3 x, vec3 w, float dist, inout Rng rng, inout bool truncated) {
    float t0, t1;
    if (!box_interval(x, w, t0, t1)) return 1.0;
    t1 = min(t1, dist);
    if (t1 <= t0) return 1.0;
    if (RM_ON) return MUTATE_POW(MUT_TRANSMITTANCE, ray_marching_transmittance(x, w, t0, t1, rng, truncated));
    return MUTATE_POW(MUT_TRANSMITTANCE, ratio_track(x, w, t0, t1, rng, truncated));
}

#endif
