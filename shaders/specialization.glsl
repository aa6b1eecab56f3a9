// specialization.glsl - every specialization constant of the kernels, declared here and
// nowhere else, so that one place lists what a pipeline variant can leave out.  The host
// passes all of them to every pipeline of a procedure (host/pipelines.c,
// picvr_create_variant), each at the id of its name in host/internal.h's enum
// (PICVR_SPEC_<name>); `make check-layout` fails where a name's id differs between the
// two or one side lacks it.  A kernel ignores the constants it does not use.  Most come
// from the key of a procedure's variant (picvr_variant_key: the scene leaves out what it
// does not need, so llvmpipe's kernels stay small), a few are fixed per context.  The
// defaults are what a pipeline made without specialization runs.  Every kernel that
// reads the scene includes this first (the subject files include it too).
#ifndef SPECIALIZATION_GLSL_ONCE
#define SPECIALIZATION_GLSL_ONCE 1
#include "limits.glsl"

// Scenes whose lights are all delta lights (point, zero-size sun) and that have no
// background need no phase-sampled rays at all (direct_light.glsl).
layout(constant_id = 0) const bool USE_PHASE_MIS = true;

// Voxel-level majorants (majorant.glsl, fine_majorant): the host turns the voxel-level
// path on only when some brick needs it (majorant * brick diagonal > FINE_THRESHOLD).
// Compiled out otherwise: its eight texel fetches alone make llvmpipe's kernel much
// slower (docs/performance.md).
layout(constant_id = 1) const bool USE_FINE = true;

// The creation procedure's most rounds of 128 samples per point (cache_create.comp), set
// from cache.max_samples: at most 6 on a CPU device (creation's loop budget there), up
// to 64 on a GPU, which has no such bound.
layout(constant_id = 2) const uint CREATE_MAX_ROUNDS = 6u;

// The debug views' code (views.glsl) is compiled into the cached rendering procedure
// only in the variant that renders them (picvr_set_view): in every variant it would slow
// llvmpipe's kernel, as the error view inlines a second copy of the direct-light
// sampling (docs/performance.md, "Design choices, measured").
layout(constant_id = 3) const bool USE_DEBUG_VIEW = false;

// The lights' channel when they share one chromaticity (scene.light_log_k; 3: colours
// differ, every channel is extrapolated; cache.glsl, predict).
layout(constant_id = 4) const uint MONO_CHANNEL = 3u;
// The locking mode, fixed per context (true: screen space, §5.2; cache.glsl).
layout(constant_id = 5) const bool SCREEN_LOCKING = false;
// cache.max_lookup_refs, fixed per context: the most references an octree walk visits
// (cache.glsl, walk_next, which says why the walk is bounded in total), at most the
// default (picvr.h).
layout(constant_id = 6) const uint CACHE_MAX_LOOKUP_REFS = 8192u;

// Equiangular sampling and its MIS with delta tracking along camera rays and path
// segments (distance.glsl; false: delta tracking only).
layout(constant_id = 7) const bool USE_EQUIANGULAR = false;

// Transmittance by residual ratio tracking (true) or plain ratio tracking (false, the
// paper's Exposure Render estimator; tracking.glsl).
layout(constant_id = 8) const bool USE_RESIDUAL = true;

// The camera sample from the pixel's low-discrepancy sequences (random.glsl: the jitter,
// B's distance and choice, the first free flight, the first events' direct light; false:
// independent numbers, the paper's baseline as picvr_config.distance_sampling
// FREE_FLIGHT renders it).
layout(constant_id = 9) const bool USE_QMC = true;

// Paths of more than one scatter event (path.glsl).
layout(constant_id = 10) const bool USE_BOUNCES = false;

// Henyey-Greenstein lobes (phase.glsl; false: isotropic, f = 1 / (4 pi), the paper's;
// the host turns it on when some g or the second lobe is not 0).
layout(constant_id = 11) const bool USE_HG = false;

// The environment map (background.glsl; false: the constant scene.background).
layout(constant_id = 12) const bool USE_ENV_MAP = false;

// Temporal reuse (picvr_scheduler_config.temporal_reuse): the rendering kernels keep
// each pixel's mean scatter depth (render.glsl, accumulate_depth).
layout(constant_id = 13) const bool USE_REUSE = false;

// Clip planes (picvr_set_clip; clip.glsl; false: none, nothing of them compiled).
layout(constant_id = 14) const bool USE_CLIP = false;

// The consistent blend of cache hits with plain probes (cache.blend, cache_blend.glsl),
// fixed per context.
layout(constant_id = 15) const bool CACHE_BLEND = true;

// The loop iterations each multiply scattered creation sample adds to its invocation's
// pools (cache_create.comp, "Loop budget on a CPU device"; the host's
// picvr_create_sample_steps); PATH_STEPS on a GPU.
layout(constant_id = 16) const uint CREATE_SAMPLE_STEPS = PATH_STEPS;

// The scatter event of a camera path at which the cache is looked up (cache.lookup_event,
// with the multiply scattered cache and unlimited bounces; else 1): at the first, the
// lookup kernel; at a later one, the shading kernel (render_shade_cache.comp), to which
// the tracking kernel then queues every event (render.glsl).
layout(constant_id = 17) const uint LOOKUP_EVENT = 1u;

// The forced point of camera rays (PICVR_DISTANCE_FORCED with a light that equiangular
// sampling does not serve; distance.glsl, b_sample: scene.forced_pmf is its share;
// false: equiangular sampling alone).  Plain rendering only: in the cache's
// rounds a hit shades the camera ray's event from the cache, and a plain forced point
// beside it would bring back the noise the cache removes.
layout(constant_id = 18) const bool USE_FORCED = false;

// PICVR_DISTANCE_AUTO's measure of each kind's variance (render.glsl, measure_spread): in
// both of its rendering variants (the forced point's and the one without), nowhere else.
layout(constant_id = 19) const bool USE_MEASURE = false;

// Transmittance by unbiased ray marching in the rendering kernels
// (PICVR_TRANSMITTANCE_RAY_MARCHING; transmittance.glsl; false: ratio tracking, residual
// with USE_RESIDUAL).  Entry creation always ray-marches.
layout(constant_id = 20) const bool USE_RAY_MARCHING = false;

#endif
