/* test_accumulation.c - progressive accumulation, resets, stats counters, the volume box. */
#include "test_util.h"

#include <time.h>

static picvr_context *small_scene(uint32_t seed, tu_vol *vol) {
    picvr_context *ctx = tu_create(seed);
    *vol = tu_vol_ball(16);
    tu_upload(ctx, vol);
    tu_tf_ramp(ctx, 0.9f, 0.8f, 0.7f, 1.0f);
    tu_sun(ctx, 1, 1, 1, 1, 1, 1, 3, 0.5f);
    tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 24, 16);
    return ctx;
}

static uint32_t iterations(picvr_context *ctx) {
    picvr_stats st;
    TU_OK(picvr_get_stats(ctx, &st));
    return st.iterations;
}

/* "Before any iteration the image is all zero" (rgba8 and rgba32f), also after a reset. */
void test_image_zero_before_first_iteration(void **state) {
    (void)state;
    tu_vol vol;
    picvr_context *ctx = small_scene(0, &vol);
    for (int round = 0; round < 2; round++) {
        assert_int_equal(iterations(ctx), 0);
        float *img = tu_read(ctx, 24, 16);
        uint8_t px[24 * 16 * 4];
        TU_OK(picvr_read_rgba8(ctx, px, sizeof px, 1.0f));
        for (size_t i = 0; i < 24 * 16 * 4; i++) {
            if (img[i] != 0.0f) fail_msg("round %d: rgba32f[%zu] = %g before any iteration", round, i, (double)img[i]);
            if (px[i] != 0) fail_msg("round %d: rgba8[%zu] = %u before any iteration", round, i, px[i]);
        }
        free(img);
        TU_OK(picvr_step_iterations(ctx, 2));
        img = tu_read(ctx, 24, 16);
        double m = tu_region_mean(img, 24, 1, 0, 0, 24, 16);
        free(img);
        assert_true(m > 0); /* the scene is lit: the image is not zero after rendering */
        TU_OK(picvr_reset(ctx));
    }
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* "Accumulation restarts (iterations back to 0) whenever the camera, volume, transfer
   function or lights change, and on picvr_reset().  [set_camera] resets accumulation
   unless the camera is identical to the current one." */
void test_changes_reset_accumulation_identical_camera_does_not(void **state) {
    (void)state;
    tu_vol vol;
    picvr_context *ctx = small_scene(0, &vol);
    TU_OK(picvr_step_iterations(ctx, 3));
    assert_int_equal(iterations(ctx), 3);

    tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 24, 16); /* identical */
    assert_int_equal(iterations(ctx), 3);
    TU_OK(picvr_step_iterations(ctx, 1));
    assert_int_equal(iterations(ctx), 4);

    tu_set_camera(ctx, 0, 0.5, 30, 0, 0, 0, 40, 24, 16); /* moved */
    assert_int_equal(iterations(ctx), 0);
    TU_OK(picvr_step_iterations(ctx, 2));
    tu_set_camera(ctx, 0, 0.5, 30, 0, 0, 0, 41, 24, 16); /* fov */
    assert_int_equal(iterations(ctx), 0);
    TU_OK(picvr_step_iterations(ctx, 2));
    tu_set_camera(ctx, 0, 0.5, 30, 0, 0, 0, 41, 24, 17); /* size */
    assert_int_equal(iterations(ctx), 0);
    TU_OK(picvr_step_iterations(ctx, 2));
    assert_int_equal(iterations(ctx), 2);

    tu_sun(ctx, 1, 1, 1, 1, 1, 1, 3.5f, 0.5f); /* lights */
    assert_int_equal(iterations(ctx), 0);
    TU_OK(picvr_step_iterations(ctx, 2));
    tu_tf_ramp(ctx, 0.9f, 0.8f, 0.7f, 1.5f); /* transfer function */
    assert_int_equal(iterations(ctx), 0);
    TU_OK(picvr_step_iterations(ctx, 2));
    tu_upload(ctx, &vol); /* volume */
    assert_int_equal(iterations(ctx), 0);
    TU_OK(picvr_step_iterations(ctx, 2));
    TU_OK(picvr_reset(ctx));
    assert_int_equal(iterations(ctx), 0);
    /* A rejected call is not a change (the previous state is kept). */
    TU_OK(picvr_step_iterations(ctx, 2));
    picvr_camera bad;
    memset(&bad, 0, sizeof bad);
    bad.width = 4; bad.height = 4; /* position == target */
    TU_EXPECT(picvr_set_camera(ctx, &bad), PICVR_ERROR_INVALID_CAMERA);
    TU_OK(picvr_step_iterations(ctx, 1));
    assert_int_equal(iterations(ctx), 3);
    picvr_stats st;
    TU_OK(picvr_get_stats(ctx, &st));
    assert_int_equal(st.width, 24);
    assert_int_equal(st.height, 17);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

static double now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return 1e3 * (double)t.tv_sec + 1e-6 * (double)t.tv_nsec;
}

void test_stats_counters_and_step_time(void **state) {
    (void)state;
    tu_vol vol;
    picvr_context *ctx = small_scene(0, &vol);
    TU_OK(picvr_step_iterations(ctx, 5));
    picvr_stats st = tu_stats_finite(ctx);
    assert_int_equal(st.iterations, 5);
    assert_int_equal(st.iterations_min, 5);
    assert_true(st.iterations_mean == 5.0);
    assert_int_equal(st.width, 24);
    assert_int_equal(st.height, 16);
    assert_true(st.elapsed_ms > 0);
    assert_true(st.samples_per_second > 0);
    assert_true(st.device_name[0] != 0);
    assert_true(memchr(st.device_name, 0, sizeof st.device_name) != NULL);
    assert_true(st.est_error >= 0 && st.est_rel_error >= 0 && st.mean_luminance > 0);
    print_message("    device \"%s\", %.3g samples/s\n", st.device_name, st.samples_per_second);

    /* picvr_step: at least one iteration, for "about" the requested time.  Allowed:
       the request + 1000 ms (one iteration of this 24x16 image takes well under that;
       shaders were compiled by the first call above). */
    const double req = 100.0;
    double t0 = now_ms();
    TU_OK(picvr_step(ctx, req));
    double dt = now_ms() - t0;
    picvr_stats st2 = tu_stats_finite(ctx);
    print_message("    picvr_step(%.0f ms) took %.1f ms, %u iterations\n", req, dt,
                  st2.iterations - st.iterations);
    assert_true(st2.iterations >= st.iterations + 1);
    assert_true(st2.elapsed_ms > st.elapsed_ms);
    assert_true(dt <= req + 1000.0);
    /* A tiny request still renders one round, which samples at least one block. */
    TU_OK(picvr_step(ctx, 0.0));
    picvr_stats st3 = tu_stats_finite(ctx);
    assert_true(st3.iterations_mean > st2.iterations_mean);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* Box per the CONVENTIONS: centred, size dims * spacing, spacing 0 means 1.  Then an
   anisotropic volume (16 x 8 x 32 voxels of 1 x 2 x 0.5: the box is a 16-cube) with a
   random two-level structure is checked pixel by pixel against the exact absorption
   (albedo 0, background 1: Bernoulli samples, see test_beer_lambert.c): a voxel placed
   with the wrong spacing or offset changes the per-pixel transmittance. */

void test_volume_box_and_anisotropic_spacing(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(11);
    float bmin[3], bmax[3];
    uint8_t v[16 * 12 * 8];
    memset(v, 7, sizeof v);
    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    d.dims[0] = 16; d.dims[1] = 12; d.dims[2] = 8;
    d.type = PICVR_VOXEL_UINT8;
    d.data = v;
    d.spacing[0] = 1; d.spacing[1] = 2; d.spacing[2] = 0.5f;
    TU_OK(picvr_upload_volume(ctx, &d));
    TU_OK(picvr_volume_box(ctx, bmin, bmax));
    const float want1[3] = {8, 12, 2};
    for (int i = 0; i < 3; i++) {
        assert_true(bmin[i] == -want1[i]);
        assert_true(bmax[i] == want1[i]);
    }
    d.spacing[0] = d.spacing[1] = d.spacing[2] = 0; /* 0 means 1 */
    TU_OK(picvr_upload_volume(ctx, &d));
    TU_OK(picvr_volume_box(ctx, bmin, bmax));
    const float want2[3] = {8, 6, 4};
    for (int i = 0; i < 3; i++) {
        assert_true(bmin[i] == -want2[i]);
        assert_true(bmax[i] == want2[i]);
    }

    tu_vol vol = tu_vol_new(16, 8, 32, 1.0f, 32);
    vol.spacing[1] = 2.0f;
    vol.spacing[2] = 0.5f;
    uint64_t rs = 777;
    for (size_t i = 0; i < (size_t)16 * 8 * 32; i++) vol.v[i] = (tu_rand_u64(&rs) & 1) ? 255 : 32;
    tu_upload(ctx, &vol);
    tu_absorption a;
    a.vol = &vol;
    tu_vol_box(&vol, a.bmin, a.bmax);
    a.D = (double)(float)(1.5 / (16 * 0.5 * (1 + 32.0 / 255)));
    tu_tf_ramp(ctx, 0, 0, 0, (float)a.D);
    tu_background_only(ctx, 1, 1, 1, 1);
    const uint32_t Wd = 48, Ht = 48, N = 256;
    /* distance 22 to the front face, half-extent 22 tan 15 deg = 5.9 < 8: no silhouette */
    tu_cam cam = tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 30, Wd, Ht);
    double *expv = tu_expected_image(&cam, 4, tu_absorption_ray, &a);
    TU_OK(picvr_step_iterations(ctx, N));
    float *img = tu_read(ctx, Wd, Ht);
    tu_assert_finite(img, (size_t)Wd * Ht * 4, "anisotropic");
    /* z = 5 Bernoulli bound; sys_rel 5e-3 for 8-bit texture filtering weights (see
       test_beer_lambert_loose_majorant_and_brick_apron); per pixel chi2 / P within 5 SE
       of its mean (tu_check_chi2), and the mirrored expectation rejected. */
    int ok = tu_check_mean("anisotropic: image", img, expv, Wd, 0, 0, 0, Wd, Ht, N, 1.0, 5.0, 5e-3);
    ok &= tu_check_chi2("anisotropic: per pixel", img, expv, Wd, Ht, 0, N, 1.0, 5.0, NULL);
    free(img);
    free(expv);
    tu_vol_free(&vol);
    if (!ok) fail_msg("anisotropic volume: transmittance differs from the closed form");
    tu_finish(ctx);
}
