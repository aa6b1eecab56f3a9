/* test_field.c - the light field on the device (PICVR_RENDER_FIELD, docs/field.md)
 * against closed forms and picvr's own Monte-Carlo image.
 *
 * The field image is deterministic (no random number enters it), so each check is a
 * bound on its discretisation, derived next to the check, not a statistical test.
 */
#include "test_util.h"
#include "../reference/field_reference.h"   /* fref_direction: the field's directions */

static picvr_context *field_context(uint32_t ratio, uint32_t directions, float tolerance, uint32_t seed) {
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = seed;
    cfg.field.mode = PICVR_RENDER_FIELD;
    cfg.field.grid_ratio = ratio;
    cfg.field.directions = directions;
    cfg.field.tolerance = tolerance;
    cfg.field.max_passes = 1024;
    return tu_create_config(&cfg);
}

static void set_bounces(picvr_context *ctx, uint32_t max_bounces) {
    picvr_scattering sc;
    memset(&sc, 0, sizeof sc);
    sc.max_bounces = max_bounces;
    TU_OK(picvr_set_scattering(ctx, &sc));
}

/* An opacity ramp over the data value with albedo a and asymmetry g everywhere. */
static void tf_ramp_g(picvr_context *ctx, float a, float g, float D) {
    picvr_tf_point tf[2] = {{0.0f, {a, a, a}, 0.0f, g}, {1.0f, {a, a, a}, 1.0f, g}};
    TU_OK(picvr_set_transfer_function(ctx, tf, 2, D));
}

/* An empty volume (opacity 0, or D = 0) renders the background exactly: no step adds
   anything and T stays 1. */
void test_field_empty_renders_background(void **state) {
    (void)state;
    picvr_context *ctx = field_context(2, 16, 0.0f, 0);
    tu_vol vol = tu_vol_ball(16);
    tu_upload(ctx, &vol);
    tu_background_only(ctx, 0.25f, 0.5f, 0.75f, 2.0f);   /* exact in float */
    tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 40, 24);
    const float want[4] = {0.5f, 1.0f, 1.5f, 0.0f};
    for (int run = 0; run < 2; run++) {
        if (run == 0) tu_tf_const(ctx, 1, 1, 1, 0.0f, 1.0f);
        else tu_tf_const(ctx, 1, 1, 1, 1.0f, 0.0f);
        TU_OK(picvr_step(ctx, 10.0));
        float *img = tu_read(ctx, 40, 24);
        for (size_t p = 0; p < 40 * 24; p++)
            for (int c = 0; c < 4; c++)
                if (img[4 * p + c] != want[c])
                    fail_msg("%s: pixel %zu channel %d: %.9g, expected exactly %.9g", run ? "D = 0" : "opacity 0", p,
                             c, (double)img[4 * p + c], (double)want[c]);
        free(img);
    }
    picvr_stats st = tu_stats_finite(ctx);
    assert_int_equal(st.field_builds, 2);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* Single scattering of a homogeneous cube under a sun along an axis, against the
   closed form (tu_sun_ray).  The derived bound: the sun's optical depth is held per
   cell at its centre and the light toward the camera is interpolated in its logarithm
   (extended within half a cell of the faces); lit along an axis that logarithm is
   linear in the depth (the isotropic phase function is constant), so the interpolation
   is exact at any grid ratio.  What remains is the camera ray's midpoint rule: a step
   takes the light at its middle, the sun's transmittance changes along the step at a
   rate of at most sigma (|cos| <= 1), and a step's optical depth is at most 0.25
   (FIELD_TAU_STEP against the brick's majorant), so its relative error is at most
   0.25^2 / 24 = 2.6e-3; float rounding adds ~1e-6 per step over ~30 steps.  The check:
   every pixel within 3e-3 of the closed form, relative to the image's largest value. */
void test_field_sun_cube_closed_form(void **state) {
    (void)state;
    const uint32_t ratios[2] = {1, 4};
    for (int r = 0; r < 2; r++) {
        picvr_context *ctx = field_context(ratios[r], 16, 0.0f, 0);
        tu_sun_scene s;
        const double l_in[3] = {0.0, 1.0, 0.0};
        tu_sun_cube(ctx, 16, 0.1f, 0.8f, l_in, 3.0f, 0.0f, &s);
        tu_cam cam = tu_set_camera(ctx, 20, 14, 26, 0, 0, 0, 40, 48, 40);
        TU_OK(picvr_step(ctx, 10.0));
        float *img = tu_read(ctx, 48, 40);
        tu_assert_image_valid(img, 48, 40, "field sun cube");
        double *want = tu_expected_image(&cam, 1, tu_sun_ray, &s);
        double top = 0.0, worst = 0.0;
        for (size_t p = 0; p < 48 * 40; p++) top = fmax(top, want[4 * p]);
        assert_true(top > 0.0);
        for (size_t p = 0; p < 48 * 40; p++)
            for (int c = 0; c < 3; c++) worst = fmax(worst, fabs(img[4 * p + c] - want[4 * p + c]) / top);
        print_message("field sun cube, grid ratio %u: largest error %.2e of the image's peak (bound 3e-3)\n",
                      ratios[r], worst);
        assert_true(worst <= 3e-3);
        free(want);
        free(img);
        tu_finish(ctx);
    }
}

/* The white furnace: albedo 1 and a uniform background L, so the radiance is L
   everywhere whatever the density.  phi = 4 pi L and F = 0 is the fixed point of every
   pass (each gathered line holds L: its source a L = L and its end L), with delta-M too
   (a' = 1 when a = 1), and the image of that field is L.  With unlimited bounces the
   passes converge to it; the check is every pixel within 1e-3 of L, at optical depths
   from 0.1 to 20 across the ball, isotropic and at g = 0.85. */
void test_field_white_furnace(void **state) {
    (void)state;
    const float densities[3] = {0.01f, 0.3f, 2.0f};   /* per voxel at value 1 */
    const float gs[2] = {0.0f, 0.85f};
    for (int gi = 0; gi < 2; gi++)
        for (int di = 0; di < 3; di++) {
            picvr_context *ctx = field_context(2, 16, 1e-6f, 0);
            tu_vol vol = tu_vol_ball(16);
            tu_upload(ctx, &vol);
            tf_ramp_g(ctx, 1.0f, gs[gi], densities[di]);
            tu_background_only(ctx, 1, 1, 1, 1.5f);
            set_bounces(ctx, PICVR_BOUNCES_UNLIMITED);
            tu_set_camera(ctx, 10, 8, 24, 0, 0, 0, 40, 32, 32);
            TU_OK(picvr_step(ctx, 10.0));
            float *img = tu_read(ctx, 32, 32);
            double worst = 0.0;
            for (size_t p = 0; p < 32 * 32; p++)
                for (int c = 0; c < 3; c++) worst = fmax(worst, fabs(img[4 * p + c] / 1.5 - 1.0));
            picvr_stats st = tu_stats_finite(ctx);
            print_message("field furnace, D %g, g %g: %u passes, largest error %.2e (bound 1e-3)\n", densities[di],
                          gs[gi], st.field_passes, worst);
            assert_true(worst <= 1e-3);
            free(img);
            tu_vol_free(&vol);
            tu_finish(ctx);
        }
}
