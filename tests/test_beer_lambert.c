/* test_beer_lambert.c - transmittance of absorbing media against exp(-optical depth).
 *
 * Scene: albedo 0 (no scattered light), no lights, background radiance 1.  A sample is
 * then exactly 1 (the ray escaped, sees the background) or 0 (it collided): a
 * Bernoulli variable with mean T = exp(-integral of sigma_t) along the pixel ray, so
 * the per-sample variance is exactly T (1 - T) (analytic bound M = 1 in
 * tu_check_mean).  Alpha ("fraction of samples that scattered", coverage for
 * compositing) is the complementary Bernoulli variable with mean 1 - T.
 * The expected pixel values integrate T over the pixel's jitter with sub x sub
 * midpoint sub-samples, ray/box intersection and optical depth in double precision.
 * A tracking loop cut short, or a majorant below sigma_t somewhere, biases these.
 */
#include "test_util.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>



/* Renders n iterations, checks the image mean (RGB, alpha), the four quadrants, that
   R == G == B bit for bit (each sample is 0 or 1 in all channels), truncated_paths == 0.
   sys_rel: allowed systematic relative error (stated by the caller). */
static void check_transmittance_image(picvr_context *ctx, const tu_cam *cam,
                                      const double *expv, uint32_t n, double sys_rel,
                                      const char *name) {
    uint32_t w = cam->w, h = cam->hgt;
    TU_OK(picvr_step_iterations(ctx, n));
    float *img = tu_read(ctx, w, h);
    tu_assert_finite(img, (size_t)w * h * 4, name);
    int ok = 1;
    char label[128];
    snprintf(label, sizeof label, "%s: image radiance", name);
    ok &= tu_check_mean(label, img, expv, w, 0, 0, 0, w, h, n, 1.0, 5.0, sys_rel);
    snprintf(label, sizeof label, "%s: image alpha (1 - T)", name);
    ok &= tu_check_mean(label, img, expv, w, 3, 0, 0, w, h, n, 1.0, 5.0, sys_rel);
    for (int q = 0; q < 4; q++) {
        uint32_t x0 = (q & 1) ? w / 2 : 0, y0 = (q & 2) ? h / 2 : 0;
        snprintf(label, sizeof label, "%s: quadrant %d radiance", name, q);
        ok &= tu_check_mean(label, img, expv, w, 0, x0, y0, x0 + w / 2, y0 + h / 2, n, 1.0,
                            5.0, sys_rel);
    }
    for (size_t p = 0; p < (size_t)w * h; p++)
        if (img[4 * p] != img[4 * p + 1] || img[4 * p] != img[4 * p + 2])
            fail_msg("%s: pixel %zu has R %g G %g B %g; albedo 0 and a white background "
                     "make every sample grey", name, p, (double)img[4 * p],
                     (double)img[4 * p + 1], (double)img[4 * p + 2]);
    picvr_stats st = tu_stats_finite(ctx);
    if (st.truncated_paths != 0)
        fail_msg("%s: truncated_paths = %llu in a moderate medium", name,
                 (unsigned long long)st.truncated_paths);
    assert_int_equal(st.iterations, n);
    free(img);
    if (!ok) fail_msg("%s: transmittance differs from exp(-optical depth)", name);
}

/* Homogeneous 16^3 cube (box [-8,8]^3), camera on the +z axis at distance 20 facing the
   +z face, fov 40: every pixel ray enters through the front face (half-extent at the
   face 12 tan 20 deg = 4.4 < 8); the corner rays leave through the side faces. */
static void homogeneous_case(double tau_axis, uint32_t N, const char *name) {
    picvr_context *ctx = tu_create(1);
    tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
    tu_upload(ctx, &vol);
    tu_homog hm;
    tu_vol_box(&vol, hm.bmin, hm.bmax);
    hm.sigma = (double)(float)(tau_axis / 16.0); /* the device gets D as a float */
    tu_tf_const(ctx, 0, 0, 0, 1.0f, (float)hm.sigma);
    tu_background_only(ctx, 1, 1, 1, 1);
    tu_cam cam = tu_set_camera(ctx, 0, 0, 20, 0, 0, 0, 40, 48, 48);
    /* sys_rel 1e-4: 8x8 midpoint quadrature of a smooth function over the jitter and
       float32 ray setup; negligible against the 5-sigma bound (~0.5-8 % here). */
    double *expv = tu_expected_image(&cam, 8, tu_homog_ray, &hm);
    check_transmittance_image(ctx, &cam, expv, N, 1e-4, name);
    free(expv);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

void test_beer_lambert_homogeneous_cube(void **state) {
    (void)state;
    homogeneous_case(1.0, 256, "beer-lambert tau 1");
}

void test_beer_lambert_optical_depth_5(void **state) {
    (void)state;
    /* T = e^-5 = 0.0067 on the axis: ~5 real collisions per sample; any cap on the
       tracking loop or an error in the exponential step shows as a large relative
       bias.  A Bernoulli sample's relative SD is sqrt((1 - T) / T) ~ 10 here, so the
       image mean needs 4096 passes (9.4e6 samples) for an SE of 0.33 % of T: the 5-SE
       bound is 1.6 %, and a 2 % bias is rejected (the power note). */
    homogeneous_case(5.0, 4096, "beer-lambert tau 5");
}

/* The same homogeneous medium given as uint16 (full range and 12-bit range) and as
   float32 with an explicit value range, at the normalized value 0.6 with opacity =
   value: a wrong normalization changes sigma_t and the transmittance by a lot. */
void test_beer_lambert_uint16_and_float32_volumes(void **state) {
    (void)state;
    const size_t n = 16 * 16 * 16;
    uint16_t *u16 = malloc(n * sizeof *u16);
    uint16_t *u12 = malloc(n * sizeof *u12);
    float *f32 = malloc(n * sizeof *f32);
    assert_non_null(u16); assert_non_null(u12); assert_non_null(f32);
    for (size_t i = 0; i < n; i++) {
        u16[i] = 39321;   /* 153 * 257 = 0.6 * 65535 exactly */
        u12[i] = 2457;    /* 0.6 * 4095 exactly */
        f32[i] = 7.0f;    /* (7 - 4) / (9 - 4) = 0.6 */
    }
    struct { const char *name; picvr_voxel_type type; const void *data; float lo, hi; } cases[] = {
        {"uint16 0..65535", PICVR_VOXEL_UINT16, u16, 0, 0},
        {"uint16 12-bit 0..4095", PICVR_VOXEL_UINT16, u12, 0, 4095},
        {"float32 4..9", PICVR_VOXEL_FLOAT32, f32, 4, 9},
    };
    picvr_context *ctx = tu_create(2);
    const double v0 = 0.6, tau_axis = 1.0;
    const float D = (float)(tau_axis / (16 * v0));
    tu_tf_ramp(ctx, 0, 0, 0, D);
    tu_background_only(ctx, 1, 1, 1, 1);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        picvr_volume_desc d;
        memset(&d, 0, sizeof d);
        d.dims[0] = d.dims[1] = d.dims[2] = 16;
        d.type = cases[c].type;
        d.data = cases[c].data;
        d.value_min = cases[c].lo;
        d.value_max = cases[c].hi;
        TU_OK(picvr_upload_volume(ctx, &d));
        tu_cam cam = tu_set_camera(ctx, 0, 0, 20, 0, 0, 0, 40, 32, 32);
        tu_homog hm = {{-8, -8, -8}, {8, 8, 8}, (double)D * v0};
        double *expv = tu_expected_image(&cam, 8, tu_homog_ray, &hm);
        /* sys_rel 1e-3: the normalized value 0.6 is computed in float32 on the device
           (and a UNORM texture holds it to 2^-16); the 5-sigma bound is ~1.5 %. */
        check_transmittance_image(ctx, &cam, expv, 256, 1e-3, cases[c].name);
        free(expv);
        TU_OK(picvr_reset(ctx));
    }
    free(u16); free(u12); free(f32);
    tu_finish(ctx);
}

/* A structured medium whose majorant grid cannot be tight:
 *   x-index < 8: every voxel randomly 255 or 32 (sigma varies 8x inside every brick);
 *   x-index >= 8: all 32, next to the random half: trilinear interpolation reaches half
 *   a voxel into these bricks with values up to 255, so a majorant grid without the
 *   one-voxel apron is too low there.
 * 16^3 voxels of spacing 2 (box [-16,16]^3); opacity = value, albedo 0.  A nearly
 * orthographic camera (distance 400, fov 4) looks down -z, so the rays of the central
 * columns run inside the interpolation strip x in [0, 1] world (p_x in [8, 8.5]) for
 * their whole length.  Optical depth ~3 through the random half, ~0.7 through the
 * other.  Besides the image mean and quadrants, every pixel column is checked on its
 * own (64 pixels x 256 samples, analytic Bernoulli bound, z = 5). */
void test_beer_lambert_loose_majorant_and_brick_apron(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(3);
    tu_vol vol = tu_vol_new(16, 16, 16, 2.0f, 32);
    uint64_t rs = 12345;
    for (uint32_t z = 0; z < 16; z++)
        for (uint32_t y = 0; y < 16; y++)
            for (uint32_t x = 0; x < 8; x++)
                *tu_vox(&vol, x, y, z) = (tu_rand_u64(&rs) & 1) ? 255 : 32;
    tu_upload(ctx, &vol);
    tu_absorption s;
    s.vol = &vol;
    tu_vol_box(&vol, s.bmin, s.bmax);
    s.D = (double)(float)(3.0 / (32.0 * 0.5 * (1.0 + 32.0 / 255.0)));
    tu_tf_ramp(ctx, 0, 0, 0, (float)s.D);
    tu_background_only(ctx, 1, 1, 1, 1);
    const uint32_t W = 64, H = 64, N = 256;
    tu_cam cam = tu_set_camera(ctx, 0, 0, 400, 0, 0, 0, 4, W, H);
    double *expv = tu_expected_image(&cam, 4, tu_absorption_ray, &s);
    /* sys_rel 5e-3: the device may interpolate a UNORM8 texture with 8-bit fixed-point
       weights (Vulkan subTexelPrecisionBits); in this 8x-contrast volume that moves
       sigma_t by up to ~0.2 % locally.  The 5-sigma bounds are 1-2 % (image) and
       3-6 % (single columns). */
    const double sys = 5e-3;
    check_transmittance_image(ctx, &cam, expv, N, sys, "loose majorant");
    /* check_transmittance_image rendered N iterations: the image is still there. */
    float *img = tu_read(ctx, W, H);
    int ok = 1;
    for (uint32_t x = 0; x < W; x++) {
        char label[64];
        snprintf(label, sizeof label, "loose majorant: column %u", x);
        ok &= tu_check_mean(label, img, expv, W, 0, x, 0, x + 1, H, N, 1.0, 5.0, sys);
    }
    /* Per-pixel structure: the Bernoulli variance is exact, so chi2 / P is 1 within
       5 SE of its mean (tu_check_chi2); the mirrored expectation must be rejected. */
    ok &= tu_check_chi2("loose majorant: per pixel", img, expv, W, H, 0, N, 1.0, 5.0, NULL);
    free(img);
    free(expv);
    tu_vol_free(&vol);
    if (!ok) fail_msg("per-column or per-pixel transmittance differs from the closed form");
    tu_finish(ctx);
}

/* ---- entry creation's unbiased ray-marching estimator, on the host -------------------
   The estimator itself is shaders/ray_marching_series.glsl, the code the creation kernel
   runs, compiled here in double with combs of 1D extinction profiles whose optical depth
   is known: bricks of 8 voxels with a majorant each, a stratified comb (n strata per
   non-empty brick, n = ceil(majorant depth / RMH_TAU_STEP), at most one per voxel: the
   rule of transmittance.glsl's comb_optical_depth, whose only property the series needs
   is E[X] = tau).  The mean of many estimates must be exp(-tau) within 4.5 standard
   errors (the SE from 4e5 estimates, so the normal quantile holds: two-sided p = 7e-6
   per profile).  Profiles with thin sheets make many combs miss the medium; the same
   series with a shortcut "pivot 0 -> transmittance 1" (a bug found in a trial) must fail
   the check there, which shows the test can see such a bias. */

#define RMH_TAU_STEP 0.5

typedef struct {
    const char *name;
    int bricks;             /* of 8 voxels */
    double sheet_sigma;     /* extinction inside a sheet */
    double sheet_width;     /* one sheet per brick, centred at voxel 3.7 of the brick */
    double base_sigma;      /* homogeneous extinction everywhere (0: only the sheets) */
} rmh_profile;

static double rmh_sigma(const rmh_profile *p, double x) {
    double in_brick = fmod(x, 8.0);
    double s = p->base_sigma;
    if (fabs(in_brick - 3.7) < 0.5 * p->sheet_width) s += p->sheet_sigma;
    return s;
}

static double rmh_tau(const rmh_profile *p) {
    return p->bricks * (8.0 * p->base_sigma + p->sheet_sigma * p->sheet_width);
}

/* One estimator's combs.  shortcut: once the pivot (the first comb) is 0, every later
   comb returns 0 as well, so every term of the series is 0 and the estimate is exactly
   1: the shortcut's result, through the real series. */
typedef struct {
    const rmh_profile *p;
    uint64_t *rng;
    int shortcut, combs;
    double pivot;
} rmh_state;

static double rmh_comb(rmh_state *st) {
    const rmh_profile *p = st->p;
    double tau = 0.0, maj = p->base_sigma + p->sheet_sigma;
    int first = st->combs++ == 0;
    if (st->shortcut && !first && st->pivot <= 0.0) return 0.0;
    if (maj > 0.0) {
        for (int b = 0; b < p->bricks; b++) {
            double len = 8.0;
            int n = (int)fmin(fmax(ceil(maj * len / RMH_TAU_STEP), 1.0), ceil(len / 1.0));
            double h = len / n, u = tu_rand01(st->rng), s = 0.0;
            for (int i = 0; i < n; i++) s += rmh_sigma(p, 8.0 * b + (i + u) * h);
            tau += s * h;
        }
    }
    if (first) st->pivot = tau;
    return tau;
}

/* shaders/ray_marching_series.glsl in double, with the hooks above. */
#define real double
#define CM_API static
#define CM_FN(name) rmh_##name
#define CM_REAL(x) ((double)(x))
#define cm_exp(x) exp(x)
#define cm_min(a, b) fmin(a, b)
#define cm_abs(x) fabs(x)
#define RM_PARAMS rmh_state *st
#define RM_COMB() rmh_comb(st)
#define RM_RND() tu_rand01(st->rng)
#define RM_TRUNCATE() (void)0
#include "shaders/ray_marching_series.glsl"
#undef real
#undef CM_API
#undef CM_FN
#undef CM_REAL
#undef cm_exp
#undef cm_min
#undef cm_abs

static double rmh_estimate(const rmh_profile *p, uint64_t *rng, int shortcut) {
    rmh_state st = {p, rng, shortcut, 0, 0.0};
    return rmh_ray_marching_series(&st);
}

/* Mean and standard error of n estimates; returns (mean - exp(-tau)) / se. */
static double rmh_z(const rmh_profile *p, int n, int shortcut, uint64_t seed, double *mean_out) {
    uint64_t rng = seed;
    double m = 0.0, m2 = 0.0;
    for (int i = 1; i <= n; i++) {   /* Welford */
        double v = rmh_estimate(p, &rng, shortcut), d = v - m;
        m += d / i;
        m2 += d * (v - m);
    }
    /* se at least 1e-12 relative: a zero-variance profile differs from exp(-tau) by
       rounding only */
    double want = exp(-rmh_tau(p)), se = fmax(sqrt(m2 / (n - 1) / n), 1e-12 * want);
    *mean_out = m;
    return (m - want) / se;
}

void test_ray_marching_estimator_unbiased(void **state) {
    (void)state;
    const rmh_profile profiles[] = {
        {"homogeneous, tau 2", 4, 0.0, 0.0, 1.0 / 16},
        {"homogeneous, tau 12 (dark roulette)", 5, 0.0, 0.0, 0.3},
        {"dense thin sheets (1 in 3 combs hits each)", 3, 3.0, 0.3, 0.0},
        {"faint thin sheets (one sample per brick)", 4, 0.05, 0.5, 0.0},
        {"sheets in a medium", 4, 2.0, 0.4, 0.05},
    };
    const int n = 400000;
    for (size_t k = 0; k < sizeof profiles / sizeof profiles[0]; k++) {
        double mean;
        double z = rmh_z(&profiles[k], n, 0, 1234 + k, &mean);
        print_message("    %-44s tau %.3f  mean %.6f  exp(-tau) %.6f  z %+.2f\n", profiles[k].name,
                      rmh_tau(&profiles[k]), mean, exp(-rmh_tau(&profiles[k])), z);
        if (!(fabs(z) <= 4.5)) fail_msg("%s: %+.2f standard errors from exp(-tau)", profiles[k].name, z);
    }
    /* The test's power: the shortcut's bias on the faint sheets (the pivot misses them
       all in (15/16)^4 = 77 % of the estimates) is far beyond 4.5 standard errors. */
    double mean, z = rmh_z(&profiles[3], n, 1, 99, &mean);
    print_message("    with the shortcut, faint sheets: mean %.6f, z %+.1f (must fail)\n", mean, z);
    if (!(z > 10.0)) fail_msg("the check did not see the shortcut's bias (z %+.2f)", z);
}
