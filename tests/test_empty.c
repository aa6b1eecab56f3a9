/* test_empty.c - exact results: nothing to scatter, nothing to light.
 *
 * No randomness can enter these images: a transparent volume, or a camera looking away,
 * shows the background radiance (colour * intensity) exactly; a scene without light
 * is exactly black.  The background colours are chosen so that colour * intensity and
 * every running mean are exact in float32, so the comparison is bit-exact.
 */
#include "test_util.h"

static const float BG_COL[3] = {0.25f, 0.5f, 0.75f}, BG_INT = 2.0f; /* radiance .5 1 1.5 */

/* A delta sun (invisible to camera rays), a sphere light out of view (so light
   selection, MIS and the background are all active) and the background. */
static void lights_with_background(picvr_context *ctx) {
    picvr_light l[2];
    memset(l, 0, sizeof l);
    l[0].type = PICVR_LIGHT_DIRECTIONAL;
    l[0].direction[0] = 1; l[0].direction[1] = 2; l[0].direction[2] = 3;
    l[0].color[0] = l[0].color[1] = l[0].color[2] = 1;
    l[0].intensity = 3;
    l[1].type = PICVR_LIGHT_SPHERE;
    l[1].position[0] = 60;
    l[1].radius = 2;
    l[1].color[0] = l[1].color[1] = l[1].color[2] = 1;
    l[1].intensity = 5;
    picvr_background bg = {{BG_COL[0], BG_COL[1], BG_COL[2]}, BG_INT};
    TU_OK(picvr_set_lights(ctx, l, 2, &bg));
}

static void assert_exact(const float *img, size_t npix, const float want[4], const char *what) {
    for (size_t p = 0; p < npix; p++)
        for (int c = 0; c < 4; c++)
            if (img[4 * p + c] != want[c])
                fail_msg("%s: pixel %zu channel %d is %.9g, expected exactly %.9g", what, p, c,
                         (double)img[4 * p + c], (double)want[c]);
}

void test_empty_volume_is_exact_background(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(0);
    tu_vol vol = tu_vol_ball(16);
    tu_upload(ctx, &vol);
    lights_with_background(ctx);
    tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 40, 24);
    const float want[4] = {BG_COL[0] * BG_INT, BG_COL[1] * BG_INT, BG_COL[2] * BG_INT, 0.0f};

    tu_tf_const(ctx, 1, 1, 1, 0.0f, 1.0f); /* opacity 0 everywhere */
    TU_OK(picvr_step_iterations(ctx, 7));
    float *img = tu_read(ctx, 40, 24);
    assert_exact(img, 40 * 24, want, "TF opacity 0");
    free(img);

    tu_tf_const(ctx, 1, 1, 1, 1.0f, 0.0f); /* density factor D = 0 */
    TU_OK(picvr_step_iterations(ctx, 7));
    img = tu_read(ctx, 40, 24);
    assert_exact(img, 40 * 24, want, "D = 0");
    free(img);

    tu_vol_free(&vol);
    vol = tu_vol_new(16, 16, 16, 1.0f, 0); /* all-zero voxels, default-like ramp TF */
    tu_upload(ctx, &vol);
    tu_tf_ramp(ctx, 1, 1, 1, 10.0f);
    TU_OK(picvr_step_iterations(ctx, 7));
    img = tu_read(ctx, 40, 24);
    assert_exact(img, 40 * 24, want, "zero voxels, opacity = value");
    free(img);
    picvr_stats st = tu_stats_finite(ctx);
    assert_int_equal(st.truncated_paths, 0);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

void test_no_light_black_background_is_exact_zero(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(0);
    tu_vol vol = tu_vol_ball(16);
    tu_upload(ctx, &vol);
    tu_tf_ramp(ctx, 1, 1, 1, 2.0f);
    tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 32, 32);
    const size_t np = 32 * 32;
    for (int round = 0; round < 4; round++) {
        const char *what = "";
        if (round == 0) {
            what = "default lights (none set)";
        } else if (round == 1) {
            what = "set_lights(NULL, 0, NULL)";
            TU_OK(picvr_set_lights(ctx, NULL, 0, NULL));
        } else if (round == 2) {
            what = "background of intensity 0";
            picvr_background bg = {{1, 1, 1}, 0.0f};
            TU_OK(picvr_set_lights(ctx, NULL, 0, &bg));
        } else {
            /* every light has zero power: selection by power must not divide 0 by 0 */
            what = "sun and sphere of intensity 0, black background";
            picvr_light l[2];
            memset(l, 0, sizeof l);
            l[0].type = PICVR_LIGHT_DIRECTIONAL;
            l[0].direction[2] = 1;
            l[0].color[0] = l[0].color[1] = l[0].color[2] = 1;
            l[1].type = PICVR_LIGHT_SPHERE;
            l[1].position[0] = 40;
            l[1].radius = 1;
            l[1].color[0] = l[1].color[1] = l[1].color[2] = 1;
            TU_OK(picvr_set_lights(ctx, l, 2, NULL));
        }
        TU_OK(picvr_step_iterations(ctx, 6));
        float *img = tu_read(ctx, 32, 32);
        tu_assert_finite(img, np * 4, what);
        double alpha = 0;
        for (size_t p = 0; p < np; p++) {
            for (int c = 0; c < 3; c++)
                if (img[4 * p + c] != 0.0f)
                    fail_msg("%s: pixel %zu channel %d is %g, expected exactly 0", what, p, c,
                             (double)img[4 * p + c]);
            if (img[4 * p + 3] < 0 || img[4 * p + 3] > 1)
                fail_msg("%s: alpha %g outside [0,1]", what, (double)img[4 * p + 3]);
            alpha += img[4 * p + 3];
        }
        free(img);
        assert_true(alpha > 0); /* the (dense) volume is there: coverage > 0 */
    }
    tu_stats_finite(ctx);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

void test_camera_looking_away_is_exact_background(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(0);
    tu_vol vol = tu_vol_ball(16);
    tu_upload(ctx, &vol);
    tu_tf_ramp(ctx, 1, 1, 1, 1.0f);
    lights_with_background(ctx);
    tu_set_camera(ctx, 0, 0, 40, 0, 0, 80, 40, 32, 32); /* the volume is behind */
    TU_OK(picvr_step_iterations(ctx, 5));
    float *img = tu_read(ctx, 32, 32);
    const float want[4] = {BG_COL[0] * BG_INT, BG_COL[1] * BG_INT, BG_COL[2] * BG_INT, 0.0f};
    assert_exact(img, 32 * 32, want, "camera looking away");
    free(img);
    tu_stats_finite(ctx);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

static double srgb_encode(double c) {
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

/* rgba8 = sRGB(1 - exp(-exposure * radiance)) * 255, alpha = coverage * 255; exposure
   <= 0 means 1.  Tolerance 1 LSB: the header does not fix the rounding. */
void test_rgba8_tone_mapping_formula(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(0);
    tu_vol vol = tu_vol_ball(8);
    tu_upload(ctx, &vol);
    tu_tf_const(ctx, 1, 1, 1, 0.0f, 1.0f);
    lights_with_background(ctx);
    tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 16, 8);
    TU_OK(picvr_step_iterations(ctx, 2));
    const float exposures[] = {1.0f, 0.0f, -1.0f, 2.0f, 0.25f};
    uint8_t px[16 * 8 * 4];
    for (size_t e = 0; e < sizeof exposures / sizeof exposures[0]; e++) {
        TU_OK(picvr_read_rgba8(ctx, px, sizeof px, exposures[e]));
        double ex = exposures[e] <= 0 ? 1.0 : exposures[e];
        for (int c = 0; c < 4; c++) {
            double want = c == 3 ? 0.0
                                 : 255.0 * srgb_encode(1.0 - exp(-ex * BG_COL[c] * BG_INT));
            for (size_t p = 0; p < 16 * 8; p++)
                if (fabs(px[4 * p + c] - want) > 1.0)
                    fail_msg("exposure %g: pixel %zu channel %d is %u, expected %.2f (+-1)",
                             (double)exposures[e], p, c, px[4 * p + c], want);
        }
    }
    tu_vol_free(&vol);
    tu_finish(ctx);
}
