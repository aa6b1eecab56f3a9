// transmittance.glsl - the transmittance along a shadow ray: ratio tracking
// (tracking.glsl) in the rendering kernels, unbiased ray marching in entry creation
// (TRANSMITTANCE_RAY_MARCHING, defined by cache_create.comp before it includes this).
#ifndef TRANSMITTANCE_GLSL_ONCE
#define TRANSMITTANCE_GLSL_ONCE 1
#include "scene.glsl"
#include "random.glsl"
#include "clip.glsl"
#include "medium.glsl"
#include "majorant.glsl"
#include "tracking.glsl"
#include "mutation.glsl"

#ifdef TRANSMITTANCE_RAY_MARCHING
// ---- unbiased ray-marching transmittance (entry creation) ----
// Kettunen et al. 2021, "An Unbiased Ray-Marching Transmittance Estimator", simplified.
// Why, in creation only: ratio tracking against tight majorants is nearly a 0/1
// estimate, so Eq. 5 needs thousands of samples wherever the light arrives through the
// medium; most entries then miss it at the sample cap, and their noise darkens the image
// where several entries meet (docs/cache.md, "Entry noise and the dark pot").  This
// estimator is exact in a homogeneous medium and low-variance elsewhere, but costs
// several ratio-tracking samples, so the renderer keeps ratio tracking (one sample per
// pixel and iteration, no Eq. 5).
// A kernel that defines TRANSMITTANCE_RAY_MARCHING defines RM_BUDGET, the most loop
// iterations (DDA steps plus samples, all orders) one estimate may take, and sets the
// pool rm_pool before its first estimate: the iterations all its estimates may still
// take together.  An estimate takes at most min(RM_BUDGET, rm_pool); past that it is
// truncated (biased, flagged like a tracking loop at its bound).  Why a pool:
// llvmpipe's cap bounds the sum over an invocation, not each estimate, and most
// estimates take a few dozen iterations, so a long ray through many bricks may use
// what the short ones left, which a fixed share per estimate would cut (docs/cache.md,
// "Guards on creation's estimates").
#define RM_TAU_STEP 0.5     // majorant optical depth per stratum (at most one per voxel)
#define RM_COMB_SAMPLES 192.0 // long rays: strata at least (t1 - t0) / this apart
uint rm_pool;               // iterations left to this invocation's estimates (see above)

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

float ray_marching_transmittance(vec3 ro, vec3 rd, float t0, float t1, inout Rng rng,
                                 inout bool truncated) {
    uint steps = 0u, limit = min(RM_BUDGET, rm_pool);
    float T = cm_ray_marching_series(ro, rd, t0, t1, rng, truncated, steps, limit);
    rm_pool -= steps;                    // steps <= limit <= rm_pool
    return T;
}
#endif

// Transmittance from x along unit w over distance dist (only the part inside the box).
float transmittance(vec3 x, vec3 w, float dist, inout Rng rng, inout bool truncated) {
    float t0, t1;
    if (!box_interval(x, w, t0, t1)) return 1.0;
    t1 = min(t1, dist);
    if (t1 <= t0) return 1.0;
#ifdef TRANSMITTANCE_RAY_MARCHING
    return MUTATE_POW(MUT_TRANSMITTANCE, ray_marching_transmittance(x, w, t0, t1, rng, truncated));
#else
    return MUTATE_POW(MUT_TRANSMITTANCE, ratio_track(x, w, t0, t1, rng, truncated));
#endif
}

#endif
