// mutation.glsl - deliberate errors, for `make test-power` only (tools/test_power.sh):
// it builds the library once per mutation with -DPICVR_MUTATION=<id>
// -DPICVR_MUTATION_FACTOR=<f> and shows that the statistical tests fail on each.  A
// build without PICVR_MUTATION (every other build, picvr_shaders.h included) compiles
// each MUTATE(id, x) to x: the SPIR-V is the same as without the calls.
#ifndef MUTATION_GLSL_ONCE
#define MUTATION_GLSL_ONCE 1

#define MUT_RENDER 1          // a sample's radiance (render.glsl, accumulate_sample)
#define MUT_CACHE 2           // the cache's looked-up irradiance (cache.glsl, cache_lookup)
#define MUT_DIRECT 3          // one light sample's direct light (direct_light.glsl, sample_one_light)
#define MUT_TRANSMITTANCE 4   // a shadow ray's transmittance T, as T^f (transmittance.glsl)
#define MUT_PHASE 5           // what a phase-sampled direction sees, MIS-weighted (direct_light.glsl, phase_emission)
#define MUT_EXTRAPOLATION 6   // the interpolated sigma_v of Eq. 8 (cache.glsl, predict)
#define MUT_THROUGHPUT 7      // a path's throughput at each later event (path.glsl, path_event)

#ifdef PICVR_MUTATION
#define MUTATE(id, x) ((PICVR_MUTATION == (id)) ? (x) * PICVR_MUTATION_FACTOR : (x))
#define MUTATE_POW(id, x) ((PICVR_MUTATION == (id) && (x) > 0.0) ? pow((x), PICVR_MUTATION_FACTOR) : (x))
#else
#define MUTATE(id, x) (x)
#define MUTATE_POW(id, x) (x)
#endif

#endif
