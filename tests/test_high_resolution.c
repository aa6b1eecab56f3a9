/* test_high_resolution.c - one comparison each with a closed form, sized to see a bias
 * of 0.5 %: the image mean's standard error is at most 0.05 % of the mean, so the
 * 5-sigma bound is at most 0.25 % and a renderer off by 0.5 % lands 10 SE away.
 *
 * Each test renders a pilot, reads the standard error the comparison will have
 * (tu_mean_se: the analytic bound where the samples are bounded, else the spread of 64
 * block means), and renders on to the iteration count that brings it to the target,
 * bounded by a cap that the test asserts it did not need.  It then asserts its power:
 * the same comparison against the closed form times 1.005 (and 0.995) must fail.
 *   - Beer-Lambert: absorption only, background 1 (Bernoulli samples, the variance
 *     exact); camera rays by delta tracking.
 *   - single scattering under a delta sun: the light sample, its shadow ray's ratio
 *     tracking, the phase function, the free-flight distance.
 *   - the white furnace: albedo 1 in a constant white sky, unlimited bounces: every
 *     pixel is exactly the sky's radiance whatever the medium does, so any loss or gain
 *     of energy anywhere on a path (next-event estimation, phase sampling and its MIS,
 *     transmittance, throughput, roulette) moves the mean.
 * The quadratures of the expected images use 16 x 16 jitter sub-samples; their error and
 * float32 ray set-up stay under sys_rel = 1e-5, a sixth of the SE.
 */
#include "test_util.h"

#define HR_REL_SE 5e-4      /* the target: SE / mean */
#define HR_SYS 1e-5

/* Renders the scene (already set up) until the SE of channel ch's image mean is at most
   HR_REL_SE of the expected mean: a pilot of n0 iterations, then the rest in one step.
   Returns the image (malloc'ed) and the iterations in *n. */
static float *render_to_precision(picvr_context *ctx, const tu_cam *cam, const double *expv,
                                  int ch, double M, uint32_t n0, uint32_t n_cap, uint32_t *n,
                                  const char *name) {
    uint32_t W = cam->w, H = cam->hgt;
    TU_OK(picvr_step_iterations(ctx, n0));
    float *img = tu_read(ctx, W, H);
    double se = tu_mean_se(img, expv, W, ch, 0, 0, W, H, n0, M);
    double mean = tu_region_mean(img, W, ch, 0, 0, W, H);
    free(img);
    /* SE falls as 1/sqrt(N); 10 % margin for the pilot's own noise in an empirical SE. */
    double need = 1.1 * (double)n0 * pow(se / (HR_REL_SE * fabs(mean)), 2.0);
    if (!(need < (double)n_cap))
        fail_msg("%s: the pilot's SE %.3g (mean %.4g) needs %.3g iterations, more than the "
                 "cap %u", name, se, mean, need, n_cap);
    uint32_t total = need > n0 ? (uint32_t)ceil(need) : n0;
    if (total > n0) TU_OK(picvr_step_iterations(ctx, total - n0));
    picvr_stats st = tu_stats_finite(ctx);
    assert_int_equal(st.iterations, total);
    if (st.truncated_paths != 0)
        fail_msg("%s: %llu truncated paths", name, (unsigned long long)st.truncated_paths);
    print_message("    %s: pilot SE %.3g %% of the mean after %u iterations; %u iterations in all\n",
                  name, 100 * se / fabs(mean), n0, total);
    *n = total;
    return tu_read(ctx, W, H);
}

/* The comparison, its resolution (SE <= HR_REL_SE of the mean) and its power: against
   the closed form times 1 +- 0.005 the same bound must fail. */
static void check_high_resolution(const char *name, const float *img, const double *expv,
                                  uint32_t W, uint32_t H, int ch, uint32_t n, double M) {
    tu_mean_result r;
    char label[96];
    snprintf(label, sizeof label, "%s: image mean", name);
    int ok = tu_check_mean_ex(label, img, expv, W, ch, 0, 0, W, H, n, M, 5.0, HR_SYS, &r);
    double rel = r.se / fabs(r.expected);
    /* The bound tu_check_mean used (t_63 where the empirical SE is the larger: 5.6). */
    double z = M > 0 ? 5.0 : tu_student_quantile(tu_normal_cdf(5.0), 63);
    double bound = z * r.se + HR_SYS * fabs(r.expected);
    double up = fabs(r.measured - 1.005 * r.expected), down = fabs(r.measured - 0.995 * r.expected);
    print_message("    %s: SE %.4f %% of the mean (target %.3f %%); against the closed form "
                  "x 1.005 off by %.1f SE, x 0.995 by %.1f SE (bound %.1f SE)\n",
                  name, 100 * rel, 100 * HR_REL_SE, up / r.se, down / r.se, bound / r.se);
    if (!(rel <= HR_REL_SE * 1.05))
        fail_msg("%s: SE %.4g %% of the mean, more than the %.3g %% this test is sized for",
                 name, 100 * rel, 100 * HR_REL_SE);
    if (!(up > bound && down > bound))
        fail_msg("%s: a 0.5 %% bias would pass this comparison (no power)", name);
    if (!ok) fail_msg("%s: the image mean differs from the closed form", name);
}

/* render_to_precision, then check_high_resolution; frees expv. */
static void render_and_check(picvr_context *ctx, const tu_cam *cam, double *expv, int ch, double M,
                             uint32_t n_cap, const char *name, const char *label) {
    uint32_t n;
    float *img = render_to_precision(ctx, cam, expv, ch, M, 64, n_cap, &n, name);
    tu_assert_image_valid(img, cam->w, cam->hgt, name);
    check_high_resolution(label, img, expv, cam->w, cam->hgt, ch, n, M);
    free(img);
    free(expv);
}

/* Homogeneous 16^3 cube (box [-8, 8]^3), optical depth 0.5 along the axis (T = 0.61:
   the most relative information per Bernoulli sample among depths that still exercise
   the tracking), camera on +z at 20, fov 40: every ray enters the front face. */
void test_high_resolution_beer_lambert(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(601);
    tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
    tu_upload(ctx, &vol);
    tu_homog hm;
    tu_vol_box(&vol, hm.bmin, hm.bmax);
    hm.sigma = (double)(float)(0.5 / 16.0);
    tu_tf_const(ctx, 0, 0, 0, 1.0f, (float)hm.sigma);
    tu_background_only(ctx, 1, 1, 1, 1);
    const uint32_t W = 64, H = 64;
    tu_cam cam = tu_set_camera(ctx, 0, 0, 20, 0, 0, 0, 40, W, H);
    double *expv = tu_expected_image(&cam, 16, tu_homog_ray, &hm);
    render_and_check(ctx, &cam, expv, 0, 1.0, 4000, "beer-lambert", "high-resolution beer-lambert tau 0.5");
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* The same cube, sigma_t = 0.1 (optical depth 1.6 along an axis), albedo 1, a white
   delta sun of irradiance 2 toward (0.6, 0.45, 0.66), black background; camera on +z at
   30, fov 20.  A sample is 0 or M = E / (4 pi) times a ratio-tracking weight in [0, 1]
   (test_single_scatter.c), so the analytic SE bounds it. */
void test_high_resolution_single_scatter(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(602);
    tu_sun_scene s;
    const double l[3] = {0.6, 0.45, 0.66};
    tu_sun_cube(ctx, 16, 0.1f, 1.0f, l, 2.0f, 0.0f, &s);
    const uint32_t W = 64, H = 64;
    tu_cam cam = tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 20, W, H);
    double *expv = tu_expected_image(&cam, 16, tu_sun_ray, &s);
    double M = s.albedo[1] * s.E[1] / (4 * M_PI);
    render_and_check(ctx, &cam, expv, 1, M, 6000, "single scatter", "high-resolution single scatter");
    tu_finish(ctx);
}

static void furnace_ray(const double o[3], const double d[3], void *user, double out[4]) {
    (void)o; (void)d; (void)user;
    out[0] = out[1] = out[2] = 1.0;     /* the sky's radiance, medium or not */
    out[3] = 0.0;                       /* alpha is not compared */
}

/* The cube with sigma_t = 0.125 (optical depth 2 across: paths of several events),
   albedo 1, isotropic, unlimited bounces, sky of radiance 1, no light; camera on +z at
   30, fov 20 (every pixel sees the medium).  The samples are not bounded (MIS weights,
   roulette's 1 / q), so the SE is the spread of the 64 block means. */
void test_high_resolution_white_furnace(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(603);
    tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
    tu_upload(ctx, &vol);
    tu_tf_const(ctx, 1, 1, 1, 1.0f, 0.125f);
    tu_background_only(ctx, 1, 1, 1, 1);
    picvr_scattering sc;
    memset(&sc, 0, sizeof sc);
    sc.max_bounces = PICVR_BOUNCES_UNLIMITED;
    TU_OK(picvr_set_scattering(ctx, &sc));
    const uint32_t W = 64, H = 64;
    tu_cam cam = tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 20, W, H);
    double *expv = tu_expected_image(&cam, 1, furnace_ray, NULL);
    render_and_check(ctx, &cam, expv, 1, 0.0, 6000, "white furnace", "high-resolution white furnace");
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* The cache, resolved to a 2 % error.  The cube under the delta sun (sigma_t 0.15,
   albedo 0.8), with the consistent blend off so that the image is the cache's alone,
   and small parameters: epsilon 0.005 and gamma 0.01.  Its error then has two parts:
   - a bias of at most epsilon per lookup: Eq. 10's validity radius is where the
     extrapolation's estimated error reaches epsilon, and a lookup inside it errs by
     less (docs/cache.md); in this medium ln E is linear along the sun (Eq. 7 exact)
     but at the box's edges, so epsilon bounds it;
   - each entry's own estimate, within gamma / (1 + gamma) at 95 % (Eq. 5): random
     between entries, an SE of gamma / (1 + gamma) / 1.96 / sqrt(entries) on the image
     mean (an entry's error is shared by every pixel that looks it up, so this adds to
     the pixels' spread rather than showing in it).
   The bound is epsilon + 5 SE (the two SEs in quadrature); a cache off by 2 % misses it. */
void test_high_resolution_cache(void **state) {
    (void)state;
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = 604;
    cfg.cache.mode = PICVR_CACHE_OBJECT_SPACE;
    cfg.cache.max_requests = 16;
    cfg.cache.blend = PICVR_SWITCH_OFF;
    const double eps = 0.005, gamma = 0.01;
    cfg.cache.epsilon = (float)eps;
    cfg.cache.gamma = (float)gamma;
    picvr_context *ctx = tu_create_config(&cfg);
    tu_sun_scene s;
    const double l[3] = {0.6, 0.45, 0.66};
    tu_sun_cube(ctx, 16, 0.15f, 0.8f, l, 2.0f, 0.0f, &s);
    const uint32_t W = 64, H = 64, N = 256;
    tu_cam cam = tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 20, W, H);
    double *expv = tu_expected_image(&cam, 16, tu_sun_ray, &s);
    for (int i = 0; i < 8; i++) TU_OK(picvr_step_iterations(ctx, N / 8));
    picvr_stats st = tu_stats_finite(ctx);
    print_message("    cache: %u entries, full %u, hit rate %.3f (last step)\n", st.cache_entries,
                  st.cache_full, st.cache_hit_rate);
    assert_int_equal(st.cache_full, 0);
    if (!(st.cache_hit_rate > 0.9)) fail_msg("hit rate %.3f after %u iterations", st.cache_hit_rate, N);
    float *img = tu_read(ctx, W, H);
    tu_assert_image_valid(img, W, H, "cache");
    double meas = tu_region_mean(img, W, 1, 0, 0, W, H), expm = 0;
    for (size_t p = 0; p < (size_t)W * H; p++) expm += expv[4 * p + 1];
    expm /= (double)W * H;
    double se_px = tu_mean_se(img, expv, W, 1, 0, 0, W, H, N, 0.0);
    double se_entries = gamma / (1 + gamma) / 1.96 / sqrt((double)st.cache_entries) * expm;
    double se = sqrt(se_px * se_px + se_entries * se_entries);
    double z = tu_student_quantile(tu_normal_cdf(5.0), 63);     /* 64 blocks */
    double bound = eps * expm + z * se, diff = meas - expm;
    print_message("    cached image mean %.6g, closed form %.6g, relative difference %+.4f %%; SE %.4f %% "
                  "(pixels %.4f %%, entries %.4f %%); bound epsilon + %.1f SE = %.3f %%; a 2 %% error "
                  "would be off by %.3f %% or %.3f %%\n",
                  meas, expm, 100 * diff / expm, 100 * se / expm, 100 * se_px / expm,
                  100 * se_entries / expm, z, 100 * bound / expm,
                  100 * fabs(meas - 1.02 * expm) / expm, 100 * fabs(meas - 0.98 * expm) / expm);
    if (!(fabs(meas - 1.02 * expm) > bound && fabs(meas - 0.98 * expm) > bound))
        fail_msg("a cache off by 2 %% would pass this comparison (no power)");
    if (!(fabs(diff) <= bound)) fail_msg("the cached image differs from the closed form");
    free(img);
    free(expv);
    tu_finish(ctx);
}
