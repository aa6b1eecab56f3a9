/* test_util.h - shared helpers of the picvr test suite (cmocka).
 *
 * One binary (build/picvr-tests) is built from all tests/test_*.c; test_main.c runs
 * one cmocka group with every test listed in TU_ALL_TESTS below.  Helpers live in
 * test_util.c.
 *
 * Statistics used throughout (see tu_check_mean): a rendered pixel is the mean of N
 * independent samples (the header: random numbers are a hash of pixel, iteration,
 * dimension, seed).  The expected value of every pixel is computed in the test in
 * double precision from a closed form or a deterministic quadrature, integrated over
 * the pixel's jitter.  The image (or region) mean is compared with the expected mean
 * within z standard errors, z = 5 unless stated (two-sided p = 6e-7 per comparison for
 * a normal mean of ~1e5 samples; fixed seeds make every run reproducible anyway).
 * The standard error is the larger of
 *   - an analytic bound: when every sample lies in [0, M] (Bernoulli samples, or a
 *     delta light with ratio-tracking weights in [0, 1]), Var <= mu (M - mu)
 *     (Bhatia-Davis, exact for Bernoulli samples), summed over pixels; and
 *   - an empirical one: the spread of the residual means of 8x8 pixel blocks,
 *     which stays valid if the implementation correlates neighbouring pixels
 *     (e.g. coherent sampling within a subgroup; that does not bias the mean).
 * Where the empirical one is used it has (blocks - 1) degrees of freedom, and the bound
 * is Student's t quantile at the same two-sided p as z.  With fewer than 16 blocks and
 * an analytic bound, the analytic bound alone is used (a spread of 3 to 15 block means
 * is too noisy to bound anything; it is printed).  docs/testing.md has the whole
 * scheme: the per-pixel check, power, the pooled check and the mutation builds.
 */
#ifndef PICVR_TEST_UTIL_H
#define PICVR_TEST_UTIL_H

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "picvr.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ---- every test of the suite (defined in tests/test_*.c) -------------------------- */
#define TU_ALL_TESTS(X)                                             \
    /* test_sampling.c */                                           \
    X(test_sampling_equiangular_pdf_integrates_to_one)              \
    X(test_sampling_equiangular_histogram_matches_pdf)              \
    X(test_sampling_mis_weights_sum_to_one)                         \
    X(test_sampling_extreme_inputs)                                 \
    X(test_sampling_forced_norm_and_inversion)                      \
    X(test_sampling_forced_pdf_integrates_and_histogram)            \
    X(test_sampling_forced_extreme_inputs)                          \
    X(test_sampling_sobol_pairs_stratified_and_uniform)             \
    X(test_sampling_point_light_thin_closed_form)                   \
    X(test_sampling_point_light_inside_closed_form)                 \
    X(test_sampling_point_light_forced_closed_form)                 \
    X(test_sampling_sun_forced_closed_form)                         \
    X(test_sampling_auto_closed_form_and_choice)                    \
    X(test_sampling_auto_ray_marching_kind)                         \
    X(test_sampling_auto_variant_made_beside_steps)                    \
    X(test_sampling_residual_transmittance_heterogeneous)           \
    /* test_cache_math.c */                                         \
    X(test_cache_math_exponential_field)                            \
    X(test_cache_math_validity_radius)                              \
    X(test_cache_math_weights_and_average)                          \
    X(test_cache_math_radius_reduction)                             \
    X(test_cache_math_degenerate_inputs)                            \
    X(test_cache_math_entry_offset)                                 \
    X(test_cache_math_curvature_radius)                             \
    X(test_cache_math_medium_model)                                 \
    X(test_cache_math_sample_statistics)                            \
    /* test_cache.c */                                              \
    X(test_cache_off_by_default_allocates_nothing)                  \
    X(test_cache_homogeneous_sun_matches_closed_form)               \
    X(test_cache_blend_converges)                                   \
    X(test_cache_auto_mode)                                         \
    X(test_cache_rebuild_keeps_new_entries)                         \
    X(test_cache_lookup_sees_long_lists)                            \
    X(test_cache_lookup_bound_cuts_walks)                           \
    X(test_cache_oriented_box_insertion)                            \
    X(test_cache_coloured_suns_match_closed_form)                   \
    X(test_cache_one_chromaticity_suns_match_closed_form)           \
    X(test_cache_variants_switch_and_replace)                       \
    X(test_pipelines_made_for_the_scene)                            \
    X(test_cache_moments_only_with_bounces)                         \
    X(test_cache_curvature_limit_matches_closed_form )               \
    X(test_cache_screen_space_locking_matches_closed_form)          \
    X(test_cache_invalidation_and_camera_keeps_cache)               \
    X(test_cache_pool_full_is_reported_and_safe)                    \
    X(test_cache_capped_entries_counted)                            \
    X(test_cache_points_stop_on_their_own)                          \
    X(test_cache_truncated_samples_counted)                         \
    X(test_cache_debug_view)                                        \
    X(test_cache_full_dense_lit_face)                               \
    X(test_cache_extrapolation_exact_in_log_linear_light)           \
    /* test_scheduler.c */                                          \
    X(test_scheduler_shares_follow_hit_rate)                        \
    X(test_scheduler_measured_shares_track_targets)                 \
    X(test_scheduler_update_runs_after_cold_compile)                \
    X(test_scheduler_priorities_favour_lit_blocks)                  \
    X(test_render_kernels_finish_every_pixel_once)                  \
    X(test_scheduler_step_budget)                                   \
    X(test_scheduler_no_deadlock_with_tiny_pools)                   \
    X(test_scheduler_set_scheduler_switches_shares)                 \
    X(test_scheduler_config_errors)                                 \
    /* test_api_errors.c */                                         \
    X(test_status_strings_non_null_and_distinct)                    \
    X(test_device_type_reported)                                    \
    X(test_create_destroy_errors)                                   \
    X(test_step_before_volume_and_camera_is_not_ready)              \
    X(test_bad_inputs_rejected_and_state_kept)                      \
    X(test_bad_inputs_rest_of_api_and_device_limits)                \
    X(test_calls_in_wrong_order)                                    \
    X(test_create_config_errors)                                    \
    X(test_get_config_resolves_defaults)                            \
    X(test_compile_threads_change_nothing)                          \
    X(test_kernel_pruning_changes_nothing)                          \
    /* test_accumulation.c */                                       \
    X(test_image_zero_before_first_iteration)                       \
    X(test_changes_reset_accumulation_identical_camera_does_not)    \
    X(test_stats_counters_and_step_time)                            \
    X(test_volume_box_and_anisotropic_spacing)                      \
    /* test_empty.c */                                              \
    X(test_empty_volume_is_exact_background)                        \
    X(test_no_light_black_background_is_exact_zero)                 \
    X(test_camera_looking_away_is_exact_background)                 \
    X(test_rgba8_tone_mapping_formula)                              \
    /* test_determinism.c */                                        \
    X(test_same_seed_bit_identical_different_seed_differs)          \
    X(test_error_estimate_halves_with_4x_iterations)                \
    /* test_beer_lambert.c */                                       \
    X(test_beer_lambert_homogeneous_cube)                           \
    X(test_beer_lambert_optical_depth_5)                            \
    X(test_beer_lambert_uint16_and_float32_volumes)                 \
    X(test_beer_lambert_loose_majorant_and_brick_apron)             \
    X(test_ray_marching_estimator_unbiased)                         \
    /* test_single_scatter.c */                                     \
    X(test_single_scatter_delta_sun_coloured)                       \
    X(test_single_scatter_small_sun_closed_form)                    \
    X(test_single_scatter_wide_sun_irradiance_unit)                 \
    /* test_area_lights.c */                                        \
    X(test_point_light_single_scatter_closed_form)                  \
    X(test_sphere_light_matches_point_light)                        \
    X(test_light_combinations_in_one_context)                       \
    X(test_rect_light_facing_closed_form_and_back_side_dark)        \
    X(test_area_lights_forced_closed_form)                          \
    X(test_sphere_light_seen_directly_near_and_far)                 \
    /* test_extreme.c */                                            \
    X(test_extreme_density_range_finite)                            \
    X(test_dense_medium_surface_lit_thin_is_background)             \
    X(test_extreme_cameras_and_image_sizes_finite)                  \
    X(test_extreme_volumes_finite)                                  \
    /* test_field.c */                                              \
    X(test_field_empty_renders_background)                          \
    X(test_field_sun_cube_closed_form)                              \
    X(test_field_white_furnace)                                     \
    X(test_field_energy_one_pass)                                   \
    X(test_field_approaches_monte_carlo)                            \
    X(test_field_deterministic)                                     \
    X(test_field_config_errors)                                     \
    X(test_field_stiff_sweep)                                       \
    X(test_field_hands_over_to_monte_carlo)                         \
    /* test_field_reference.c */                                    \
    X(test_field_reference_empty_renders_background)                \
    X(test_field_reference_sun_cube_closed_form)                    \
    X(test_field_reference_white_furnace)                           \
    X(test_field_reference_sweep_energy)                            \
    X(test_field_reference_every_cell_crossed)                      \
    X(test_field_reference_bad_input)                               \
    X(test_field_reference_refinement_ladder)                       \
    X(test_field_reference_approaches_path_tracer)                  \
    X(test_field_reference_forward_scattering_storage)              \
    X(test_field_reference_point_light_and_map)                     \
    /* test_cpu_reference.c */                                      \
    X(test_gpu_matches_cpu_reference_area_light_background)         \
    X(test_gpu_matches_cpu_reference_point_light_equiangular)       \
    X(test_cpu_reference_hg_phase_function)                         \
    X(test_cpu_reference_environment_map)                           \
    X(test_cpu_reference_white_furnace)                             \
    X(test_cpu_reference_environment_constant_is_background)        \
    X(test_cpu_reference_single_scatter_unchanged)                  \
    X(test_cpu_reference_environment_single_scatter_closed_form)    \
    X(test_cpu_reference_roulette_unbiased)                         \
    X(test_cpu_reference_albedo_per_bounce)                         \
    X(test_gpu_matches_cpu_reference_forced)                        \
    X(test_gpu_matches_cpu_reference_ray_marching)                  \
    X(test_gpu_matches_cpu_reference_bounces_forward_hg)            \
    X(test_gpu_matches_cpu_reference_bounces_chromatic)             \
    X(test_gpu_matches_cpu_reference_environment_map)               \
    X(test_gpu_matches_cpu_reference_bounces_point_light_equiangular) \
    /* test_voxel_types.c */                                        \
    X(test_voxel_types_signed_match_unsigned)                       \
    X(test_voxel_types_converted_match_float32)                     \
    X(test_voxel_types_hostile)                                     \
    X(test_voxel_types_extremes)                                    \
    /* test_phase.c */                                              \
    X(test_phase_hg_integrates_to_one)                              \
    X(test_phase_hg_sample_inverts_cdf)                             \
    X(test_phase_hg_sample_mean_is_g)                               \
    X(test_phase_hg_histogram_matches_pdf)                          \
    X(test_phase_two_lobe_mix)                                      \
    X(test_phase_extreme_inputs)                                    \
    /* test_path.c: multiple scattering, the phase function, environment maps */ \
    X(test_path_white_furnace_homogeneous)                          \
    X(test_path_white_furnace_heterogeneous)                        \
    X(test_path_white_furnace_forward_g09)                          \
    X(test_path_white_furnace_two_lobes)                            \
    X(test_path_white_furnace_constant_env_map)                     \
    X(test_path_bounces_albedo_08_match_reference)                  \
    X(test_path_cache_ms_white_furnace)                             \
    X(test_path_cache_ms_albedo_09_match_reference)                 \
    X(test_path_cache_ms_refines)                                   \
    X(test_path_cache_ms_later_event)                               \
    X(test_path_env_one_hot_equals_directional)                     \
    X(test_path_env_constant_map_equals_constant_background)        \
    X(test_path_env_smooth_map_single_scatter_closed_form)          \
    X(test_path_mean_path_length)                                   \
    X(test_path_default_scattering_bit_identical)                   \
    X(test_bad_inputs_scattering_and_environment)                   \
    /* test_real_data.c */                                          \
    X(test_real_data_fuel_smoke)                                    \
    /* test_robust_sweep.c (issue 6) */                             \
    X(test_sweep_point_light_extremes)                              \
    X(test_sweep_forced_extremes)                                   \
    X(test_sweep_ray_marching_extremes)                             \
    X(test_sweep_auto_extremes)                                     \
    X(test_sweep_path_extremes)                                     \
    X(test_sweep_optical_thickness_beer_lambert)                    \
    X(test_sweep_optical_thickness_sun)                             \
    X(test_sweep_optical_thickness_sun_cache)                       \
    X(test_sweep_transfer_function_step_zero_and_max)               \
    X(test_sweep_light_intensity)                                   \
    X(test_sweep_lights_inside_grazing_tiny_sun_none)               \
    X(test_sweep_cache_zero_irradiance)                             \
    X(test_sweep_volume_shapes_and_spacing)                         \
    X(test_sweep_float32_huge_range_and_uint16_12bit)               \
    X(test_sweep_cameras_and_image_sizes)                           \
    X(test_sweep_long_run_precision)                            \
    X(test_sweep_clip_and_placement)                                \
    X(test_sweep_ms_cache_furnace_thickness)                        \
    /* test_engine.c */                                             \
    X(test_frames_leave_no_hole)                                    \
    X(test_frames_turned_on_later)                                  \
    X(test_step_begin_end)                                          \
    X(test_write_image_formats)                                     \
    X(test_write_image_bad_targets)                                 \
    X(test_reuse_moves_the_image)                                   \
    X(test_reuse_lowers_the_error_of_moving_frames)                 \
    X(test_reuse_extreme_moves)                                     \
    X(test_reuse_is_deterministic)                                  \
    /* test_nrrd.c */                                               \
    X(test_nrrd_reads_layout_values_and_geometry)                   \
    X(test_nrrd_refuses_bad_headers)                                \
    X(test_volume_io_percentile_range)                              \
    /* test_clip.c: placement and clipping */                      \
    X(test_clip_cube_under_sun_closed_form)                         \
    X(test_placed_volume_under_sun_closed_form)                     \
    X(test_bad_placement_and_clip)                                  \
    X(test_placed_volume_environment_map)                           \
    /* test_nifti.c */                                              \
    X(test_nifti_reads_types_and_scaling)                           \
    X(test_nifti_sform_geometry)                                    \
    X(test_nifti_qform_and_identity_geometry)                       \
    X(test_nifti_nifti2_4d_and_big_endian)                          \
    X(test_nifti_hdr_img_pairs)                                     \
    X(test_nifti_refuses_bad_files)                                 \
    X(test_nifti_is_nifti)                                          \
    X(test_nifti_nibabel_files)                                     \
    /* test_dicom.c */                                              \
    X(test_dicom_reads_geometry_and_values)                         \
    X(test_dicom_shuffled_names_load_identically)                   \
    X(test_dicom_uneven_spacing_and_tilt)                           \
    X(test_dicom_rescale_per_slice_to_float)                        \
    X(test_dicom_two_series_takes_larger)                           \
    X(test_dicom_refusals)                                          \
    X(test_dicom_real_ct_small)                                     \
    /* test_vdb.c */                                                \
    X(test_vdb_reads_values_and_geometry)                           \
    X(test_vdb_selects_grids)                                       \
    X(test_vdb_refuses_bad_files)                                   \
    X(test_vdb_disney_cloud)                                        \
    X(test_vdb_is_vdb)                                              \
    /* test_high_resolution.c: 0.5 % resolved */                   \
    X(test_high_resolution_beer_lambert)                            \
    X(test_high_resolution_single_scatter)                          \
    X(test_high_resolution_white_furnace)                           \
    X(test_high_resolution_cache)                                   \
    /* test_stats.c: the quantiles; the pooled check last, as it */ \
    /* reads every comparison the tests before it registered */     \
    X(test_stats_quantiles)                                         \
    X(test_stats_pooled_z)

#define TU_DECLARE(name) void name(void **state);
TU_ALL_TESTS(TU_DECLARE)
#undef TU_DECLARE

/* ---- context ---------------------------------------------------------------------- */

/* Creates a context with cfg.validation = 1 and the given seed (asserts PICVR_OK and,
   unless PICVR_VALIDATION=0, that the validation layer is active).  The context is
   registered so that the per-test teardown destroys it if the test fails early. */
picvr_context *tu_create(uint32_t seed);
/* Same with the caller's config (validation is forced on). */
picvr_context *tu_create_config(const picvr_config *cfg);
/* Adds (1) or removes (0) a context made by picvr_create itself (an application's
   device: validation is the first context's) to those the teardown destroys. */
void tu_register(picvr_context *ctx, int add);
/* Asserts picvr_get_stats().validation_messages == 0, then destroys the context. */
void tu_finish(picvr_context *ctx);
/* 1 when picvr picks a CPU device (lavapipe's llvmpipe, SwiftShader), by its name. */
int tu_device_is_cpu(void);
/* A part of a test left out (a data file absent, a row for another kind of device):
   printed as "PARTIAL SKIP: what" and counted; test_main prints the count after the
   suite ("picvr-tests: N partial skips") and run_tests.sh adds it to the skipped
   total, so the suite never shrinks without a word. */
void tu_partial_skip(const char *what);
unsigned tu_partial_skips(void);
/* Per-test setup/teardown: timing (printed) and destruction of leftover contexts. */
/* Gives the running test `seconds` from now instead of the default watchdog budget:
   for a test whose work is long by design (the budget still catches a hang). */
void tu_watchdog(unsigned seconds);
int tu_setup(void **state);
int tu_teardown(void **state);

/* Asserts that a picvr call returns the expected status (prints the names). */
#define TU_EXPECT(call, expected)                                                       \
    do {                                                                               \
        picvr_status tu_s_ = (call);                                                   \
        if (tu_s_ != (expected))                                                       \
            fail_msg("%s:%d: %s returned %s, expected %s", __FILE__, __LINE__, #call,  \
                     picvr_status_string(tu_s_), picvr_status_string(expected));       \
    } while (0)
#define TU_OK(call) TU_EXPECT(call, PICVR_OK)

/* ---- volumes ----------------------------------------------------------------------- */

/* A uint8 volume built in the test (x fastest). */
typedef struct tu_vol {
    uint32_t dims[3];
    float spacing[3];
    uint8_t *v;
} tu_vol;

tu_vol tu_vol_new(uint32_t nx, uint32_t ny, uint32_t nz, float spacing, uint8_t fill);
void tu_vol_free(tu_vol *vol);
static inline uint8_t *tu_vox(tu_vol *vol, uint32_t x, uint32_t y, uint32_t z) {
    return &vol->v[x + (size_t)vol->dims[0] * (y + (size_t)vol->dims[1] * z)];
}
/* A ball: value 255 * clamp((R - r) / (soft), 0, 1) with R = 0.4 * n, soft = 0.15 * n. */
tu_vol tu_vol_ball(uint32_t n);
/* Uploads as PICVR_VOXEL_UINT8 (asserts OK). */
void tu_upload(picvr_context *ctx, const tu_vol *vol);
/* World box of a volume per the CONVENTIONS (centred at the origin). */
void tu_vol_box(const tu_vol *vol, double bmin[3], double bmax[3]);

/* Deterministic random numbers for building volumes (splitmix64). */
uint64_t tu_rand_u64(uint64_t *state);
double tu_rand01(uint64_t *state);

/* Trilinear normalized value (voxel/255) at voxel coordinate p, clamp to edge,
   voxel i's centre at p = i + 0.5 (the CONVENTIONS). */
double tu_trilinear(const tu_vol *vol, const double p[3]);
/* Exact integral of the trilinear value along o + t d, t in [t0, t1] (world units;
   d need not be unit, the integral is over t): the interpolant is a cubic in t
   between the planes p = k + 0.5, so 3-point Gauss-Legendre per piece is exact. */
double tu_value_integral(const tu_vol *vol, const double o[3], const double d[3],
                         double t0, double t1);

/* ---- transfer function, lights ----------------------------------------------------- */

/* Opacity constant `opacity`, albedo constant. */
void tu_tf_const(picvr_context *ctx, float ar, float ag, float ab, float opacity, float D);
/* Opacity = normalized value (linear ramp 0..1), albedo constant. */
void tu_tf_ramp(picvr_context *ctx, float ar, float ag, float ab, float D);
/* Only a background (no lights). */
void tu_background_only(picvr_context *ctx, float r, float g, float b, float intensity);
/* One delta sun (angular diameter 0), direction toward the sun, plus a background. */
void tu_sun(picvr_context *ctx, double dx, double dy, double dz, float r, float g, float b,
            float intensity, float bg_intensity);

/* ---- camera ------------------------------------------------------------------------ */

/* The camera of the CONVENTIONS in double precision. */
typedef struct tu_cam {
    double pos[3], f[3], r[3], u[3], h, a;
    uint32_t w, hgt;
} tu_cam;

/* Builds a picvr_camera (up 0,1,0) and sets it (asserts OK); returns the double basis. */
tu_cam tu_set_camera(picvr_context *ctx, double px, double py, double pz, double tx,
                     double ty, double tz, double fov_deg, uint32_t w, uint32_t h);
tu_cam tu_cam_from(const picvr_camera *c);
/* Unit direction of the ray through image point (sx, sy) = (x + jx, y + jy). */
void tu_cam_dir(const tu_cam *c, double sx, double sy, double dir[3]);

/* Expected image: for every pixel, the mean of fn over sub x sub midpoint jitters.
   fn writes the expected RGBA of one ray (o = camera position, d unit).  Returns a
   malloc'ed w*h*4 doubles array. */
typedef void (*tu_ray_fn)(const double o[3], const double d[3], void *user, double out[4]);
double *tu_expected_image(const tu_cam *c, int sub, tu_ray_fn fn, void *user);

/* Single scattering of a homogeneous box under a sun (closed form, tu_ray_fn): albedo
   and E per channel, half_angle 0 for a delta sun (e1, e2: a frame around l for a
   finite one).  Radiance = albedo E int sigma e^{-sigma (t - t0)} (1/4pi) T_sun dt. */
typedef struct tu_sun_scene {
    double bmin[3], bmax[3], sigma, l[3], albedo[3], E[3];
    double half_angle;      /* 0: delta sun */
    double e1[3], e2[3];    /* frame around l (finite sun) */
    /* per ray */
    double o[3], d[3], t0;
} tu_sun_scene;
void tu_sun_ray(const double o[3], const double d[3], void *user, double out[4]);
/* A homogeneous n^3 cube of sigma_t = D (value 1, opacity 1 everywhere), albedo a, a sun
   toward l_in (any length) of irradiance E and angular diameter `angular` (radians; 0: a
   delta sun), black background.  Fills *s for tu_sun_ray (a delta sun's closed form; a
   caller with angular > 0 sets half_angle, e1 and e2 itself). */
void tu_sun_cube(picvr_context *ctx, uint32_t n, float D, float a, const double l_in[3],
                 float E, float angular, tu_sun_scene *s);

/* Pure absorption of a volume (albedo 0, background 1): T = exp(-D int value dt),
   alpha 1 - T (tu_ray_fn). */
typedef struct tu_absorption {
    const tu_vol *vol;
    double bmin[3], bmax[3], D;
} tu_absorption;
void tu_absorption_ray(const double o[3], const double d[3], void *user, double out[4]);

/* ---- geometry, quadrature ------------------------------------------------------------ */

/* Slab test: returns 1 and the overlap [*t0, *t1] of t >= 0 with the box, else 0. */
int tu_ray_box(const double o[3], const double d[3], const double bmin[3],
               const double bmax[3], double *t0, double *t1);
/* Distance from x (inside or on the box) along unit d to the box exit. */
double tu_box_exit(const double x[3], const double d[3], const double bmin[3],
                   const double bmax[3]);
/* Length of the part of segment a->b inside the box. */
double tu_segment_in_box(const double a[3], const double b[3], const double bmin[3],
                         const double bmax[3]);
/* Integral of f over [a, b]: `pieces` equal pieces, 8-point Gauss-Legendre each. */
double tu_integrate(double (*f)(double t, void *user), void *user, double a, double b,
                    int pieces);
/* A homogeneous absorbing box (extinction sigma, albedo 0) in front of background 1. */
typedef struct tu_homog {
    double bmin[3], bmax[3], sigma;
} tu_homog;
/* Beer-Lambert through a tu_homog (user): rgb = T, alpha = 1 - T; for tu_expected_image. */
void tu_homog_ray(const double o[3], const double d[3], void *user, double out[4]);
/* Single scattering of a homogeneous box (extinction sigma, grey albedo) lit by a point
   light of intensity I at p, black background: L = int albedo sigma e^{-sigma (t - t0)}
   I / (4 pi |x - p|^2) e^{-sigma s(x)} dt (s: the part of x->p in the box), by
   Gauss-Legendre in the angle seen from the light (test_sampling.c); alpha = 1 - T. */
typedef struct tu_point_scene {
    double bmin[3], bmax[3], sigma, albedo, I, p[3];
} tu_point_scene;
void tu_point_light_ray(const double o[3], const double d[3], void *user, double out[4]);
/* Solid angle of the triangle (a, b, c) seen from x (Van Oosterom-Strackee). */
double tu_triangle_solid_angle(const double x[3], const double a[3], const double b[3],
                               const double c[3]);

/* ---- images ----------------------------------------------------------------------- */

/* Reads rgba32f (w*h*4 floats, malloc'ed; asserts OK) and counts the read in
   tu_image_serial (the pool tells a new image at a reused address from the old one). */
float *tu_read(picvr_context *ctx, uint32_t w, uint32_t h);
extern unsigned tu_image_serial;
/* Rec. 709 luminance. */
static inline double tu_lum(double r, double g, double b) {
    return 0.2126 * r + 0.7152 * g + 0.0722 * b;
}
/* Fails (with the first offending index) unless all n floats are finite. */
void tu_assert_finite(const float *x, size_t n, const char *what);
/* Fails unless the w x h RGBA image is finite, radiance >= 0 and alpha in [0, 1]. */
void tu_assert_image_valid(const float *img, uint32_t w, uint32_t h, const char *what);
/* Reads stats (asserts OK) and checks every floating field is finite. */
picvr_stats tu_stats_finite(picvr_context *ctx);
/* Mean of channel ch over the pixel rectangle [x0,x1) x [y0,y1) of an RGBA image. */
double tu_region_mean(const float *img, uint32_t w, int ch, uint32_t x0, uint32_t y0,
                      uint32_t x1, uint32_t y1);

/* The statistical comparison described at the top.  Compares the mean of channel ch
   of the rendered image over [x0,x1) x [y0,y1) with the mean of the expected image
   (w*h*4 doubles).  M > 0: every sample of that channel lies in [0, M] (analytic
   bound); M <= 0: empirical bound only.  Passes when
   |measured - expected| <= z * SE + sys_rel * |expected|.  Prints one line.
   Returns 1 on pass; *res (may be NULL) receives the numbers. */
typedef struct tu_mean_result {
    double measured, expected, se;
} tu_mean_result;
int tu_check_mean_ex(const char *label, const float *img, const double *expected, uint32_t w,
                     int ch, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                     uint32_t n_iter, double M, double z, double sys_rel, tu_mean_result *res);
/* Every statistical comparison notes its outcome here (tu_check_mean does so itself; a
   test comparing by other means calls it with its own bound).  The per-test teardown
   fails a test that made comparisons of which none would reject its expected value
   times 1.02 and times 0.98, and none of whose perturbation checks (tu_power_shown)
   rejected: each statistical test shows that it can see a 2 % error or a perturbed
   image (the power check).  A comparison whose expected value is 0 counts, but cannot show
   power. */
void tu_power_note(double measured, double expected, double bound);
/* The same with the relative error rel the comparison claims to see (tu_power_note: 0.02). */
void tu_power_note_rel(double measured, double expected, double bound, double rel);
/* A perturbation check the test asserts (its image against a mirrored expectation, an
   opposite rotation, a flipped phase): counts as a comparison, and as one that shows
   power when the perturbed expectation was rejected. */
void tu_power_shown(int rejected);
/* The relative error this test claims to see, 2 % unless it calls this (a robustness
   sweep sized for seconds per case claims 5 %); reset before every test.  A comparison
   with a systematic allowance (sys_rel) claims that much more. */
void tu_power_claim(double rel);
double tu_power_claimed(void);

/* A cached image's mean (channel ch, the whole w x h image) against its closed form.
   A lookup the cache serves is off by at most epsilon (relative) where the field follows
   the cache's model: Eq. 10's validity radius bounds the first-order extrapolation's
   error (docs/cache.md); events the cache does not serve are unbiased.  So the mean's
   bias is at most epsilon * hit_rate * |expected| (hit_rate: an upper bound on the
   fraction of events served, e.g. the last step's rate while the cache fills).  Each
   entry carries creation's noise: Eq. 5 stops when 1.96 cv / sqrt(n) < gamma / (1 +
   gamma), so an entry's relative SE is at most gamma / (1 + gamma) / 1.96, and the
   image mean averages `entries` independent entries (SE divided by sqrt(entries)).
   With the image's own SE (8x8 blocks; Student's t for their degrees of freedom) the
   bound is that bias + z SE, both stated in the printed line.  Power: noted for an
   error of epsilon * hit_rate + 3 % (a 3 % error beyond what the cache may do: the
   entries' SE bound and Student's t for 64 blocks leave up to 2 % of noise margin at
   the default gamma, so 2 % beyond would sit at the edge; a 2 % error of the cache
   itself is the job of the high-resolution cache test, at epsilon 0.005). */
int tu_check_cache_mean(const char *label, const float *img, const double *expected, uint32_t w,
                        uint32_t h, int ch, uint32_t n_iter, double epsilon, double gamma,
                        double hit_rate, uint32_t entries, double z);
/* The SE of that comparison alone (no print, nothing pooled): for sizing a render. */
double tu_mean_se(const float *img, const double *expected, uint32_t w, int ch, uint32_t x0,
                  uint32_t y0, uint32_t x1, uint32_t y1, uint32_t n_iter, double M);
#define tu_check_mean(label, img, expected, w, ch, x0, y0, x1, y1, n, M, z, sys) \
    tu_check_mean_ex(label, img, expected, w, ch, x0, y0, x1, y1, n, M, z, sys, NULL)

/* Per-pixel structure check: chi2 / P, the mean over the P pixels of the terms
   (measured - expected)^2 / (max(mu (M - mu), 1e-4 M^2) / N), with M the bound on a
   sample as above: an upper bound on the variance (exact for Bernoulli samples), so a
   term is <= 1 in expectation.  The limit is 1 + z s / sqrt(P), z standard errors of
   that mean (s: the terms' own standard deviation, at least sqrt 2, the normal's), so
   it holds for small N and skewed samples too.  Passes when chi2 / P is within the limit
   AND the check shows its power: the perturbed expectation (NULL: the expected image
   mirrored left-right; a caller whose scene is symmetric passes its own) must exceed
   the same limit.  A misplaced, flipped or mis-scaled volume gives terms of the size of
   the image contrast squared over the variance, far above the limit. */
int tu_check_chi2(const char *label, const float *img, const double *expected, uint32_t w,
                  uint32_t h, int ch, uint32_t n_iter, double M, double z, const double *perturbed);
/* chi2 / P as above; *limit (may be NULL) receives the limit at z standard errors. */
double tu_chi2(const float *img, const double *expected, uint32_t w, uint32_t h, int ch,
               uint32_t n_iter, double M, double z, double *limit);
/* The expected image mirrored left-right (the default perturbation above). */
double *tu_mirror_x(const double *expected, uint32_t w, uint32_t h);

/* ---- statistics (test_stats.c) ------------------------------------------------------ */

double tu_normal_cdf(double z);
/* Phi^-1(p); p outside (0, 1) gives -40 or 40. */
double tu_normal_quantile(double p);
/* Student's t quantile: P(T <= t) = p, p in (0.5, 1), nu degrees of freedom. */
double tu_student_quantile(double p, double nu);
/* The normal z of the same two-sided tail as t with nu degrees of freedom. */
double tu_student_as_z(double t, double nu);
/* The chi-square quantile with k degrees of freedom whose upper tail is the normal
   upper tail at z (Wilson-Hilferty). */
double tu_chi2_quantile_upper(double k, double z);
/* Registers one comparison with the pooled check (test_stats.c says what it pools):
   measured, expected, their SE (> 0), and the pixels compared (img, tu_image_serial,
   the rectangle; img NULL: not pixels of an image, never correlated with another
   entry).  tu_check_mean registers its own; a test comparing by other means calls
   this. */
/* Whether a comparison may join the pool: its SE analytic (student 0) or resting on at
   least 30 blocks (nb; Student's t within 3 % of the normal at the z used), and its
   allowed systematic error sys_abs (absolute) under a tenth of its SE, so that the
   pool's z values are those of unbiased comparisons. */
int tu_pool_eligible(int student, uint32_t nb, double sys_abs, double se);
void tu_pool_add(const char *label, double measured, double expected, double se,
                 const void *img, unsigned serial, uint32_t x0, uint32_t y0, uint32_t x1,
                 uint32_t y1);
size_t tu_pool_count(void);

#endif /* PICVR_TEST_UTIL_H */
