/* test_extreme.c - extreme media, cameras and volumes: every call returns (the library
 * bounds its loops; the per-test watchdog catches a hang), the image is finite, values
 * are non-negative, alpha in [0, 1], and the stats are finite.  truncated_paths may be
 * non-zero here (it is reported, not asserted).
 */
#include "test_util.h"

#include <float.h>

/* Renders n iterations and checks the output; returns the image (w*h*4 floats). */
static float *render_checked(picvr_context *ctx, uint32_t w, uint32_t h, uint32_t n,
                             const char *what) {
    TU_OK(picvr_step_iterations(ctx, n));
    float *img = tu_read(ctx, w, h);
    tu_assert_image_valid(img, w, h, what);
    picvr_stats st = tu_stats_finite(ctx);
    if (st.iterations != n) fail_msg("%s: %u iterations, expected %u", what, st.iterations, n);
    print_message("    %-40s mean luminance %-11.4g truncated_paths %llu\n", what,
                  st.mean_luminance, (unsigned long long)st.truncated_paths);
    return img;
}

static void ball_lights(picvr_context *ctx) {
    picvr_light l[2];
    memset(l, 0, sizeof l);
    l[0].type = PICVR_LIGHT_DIRECTIONAL;
    l[0].direction[0] = 0.3f; l[0].direction[1] = 0.5f; l[0].direction[2] = 1;
    l[0].angular_diameter = 0.05f;
    l[0].color[0] = l[0].color[1] = l[0].color[2] = 1;
    l[0].intensity = 3;
    l[1].type = PICVR_LIGHT_SPHERE;
    l[1].position[0] = 30; l[1].position[2] = 20;
    l[1].radius = 4;
    l[1].color[0] = l[1].color[1] = l[1].color[2] = 1;
    l[1].intensity = 2;
    picvr_background bg = {{0.4f, 0.5f, 0.7f}, 0.5f};
    TU_OK(picvr_set_lights(ctx, l, 2, &bg));
}

/* Density factor 1e-6 .. 1e5 per world unit on a 24^3 ball with a soft shell (opacity
   = value): thin, ordinary, and so dense that the majorant of the shell bricks is
   orders of magnitude above sigma_t where the rays enter. */
void test_extreme_density_range_finite(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(21);
    tu_vol vol = tu_vol_ball(24);
    tu_upload(ctx, &vol);
    ball_lights(ctx);
    tu_set_camera(ctx, 0, 0, 40, 0, 0, 0, 40, 32, 32);
    const float D[] = {1e-6f, 1e-3f, 1.0f, 1e2f, 1e4f, 1e5f};
    for (size_t i = 0; i < sizeof D / sizeof D[0]; i++) {
        tu_tf_ramp(ctx, 0.9f, 0.9f, 0.9f, D[i]);
        char what[64];
        snprintf(what, sizeof what, "ball, D = %g", (double)D[i]);
        free(render_checked(ctx, 32, 32, 4, what));
    }
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* Dense (D = 1e5) ball lit by a delta sun straight from the camera's side, black
   background: the surface facing the camera and the sun is lit.  For single scattering
   in any medium that is optically thick, plane-parallel and seen and lit head-on,
   L = albedo E / (4 pi) integral sigma e^{-2 tau} dz = albedo E / (8 pi), whatever the
   depth profile of sigma.  With the sun behind the camera the view and the light make
   the same angle with the surface's normal, mu_s = mu_v, and the half-space form
   albedo E / (4 pi) mu_s / (mu_s + mu_v) is that same albedo E / (8 pi) at every lit
   point whatever its slope (the mean free path, 1e-5 voxels, makes the shell a plane).
   The central 12x12 pixels (all on the ball) must match it within 5 SE (Bhatia-Davis:
   a sample lies in [0, albedo E / (4 pi)]) plus 2 % for float32 positions at 1e5 per
   voxel (the stiff sweep's tolerance for its thick closed form, test_robust_sweep.c),
   and the check must reject the value off by 2 % beyond that allowance (tu_check_mean's
   power note).
   Thin (D = 1e-6) ball with background radiance 1: the image mean is the background
   within 1e-3 (the optical depth is < 3e-5). */
/* Regression: at D = 1e5 every sample used to hit MAX_TRACK_STEPS while crossing the
   empty part of a shell brick at the brick's majorant, so the lit surface rendered
   black.  Dense bricks are now tracked with voxel-level majorants. */
void test_dense_medium_surface_lit_thin_is_background(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(22);
    tu_vol vol = tu_vol_ball(24); /* box [-12,12]^3, shell radius 6 .. 9.6 */
    tu_upload(ctx, &vol);
    const double albedo = 0.9, E = 8 * M_PI;
    tu_tf_ramp(ctx, (float)albedo, (float)albedo, (float)albedo, 1e5f);
    tu_sun(ctx, 0, 0, 1, 1, 1, 1, (float)E, 0.0f);
    const uint32_t W = 32, H = 32;
    /* distance 60, fov 10: the image spans +-5.2 world units at the ball's centre */
    tu_set_camera(ctx, 0, 0, 60, 0, 0, 0, 10, W, H);
    float *img = render_checked(ctx, W, H, 64, "dense ball D = 1e5, sun from the camera");
    double ref = albedo * E / (8 * M_PI);
    double *expv = malloc((size_t)W * H * 4 * sizeof *expv);
    assert_non_null(expv);
    for (size_t p = 0; p < (size_t)W * H; p++) {
        for (int c = 0; c < 3; c++) expv[4 * p + c] = ref;
        expv[4 * p + 3] = 1.0;
    }
    int ok = tu_check_mean("dense: central 12x12, thick-medium value", img, expv, W, 1, 10, 10, 22, 22, 64,
                           2 * ref, 5.0, 0.02);
    free(expv);
    free(img);
    if (!ok) fail_msg("the dense ball's lit face differs from albedo E / (8 pi)");

    tu_tf_ramp(ctx, (float)albedo, (float)albedo, (float)albedo, 1e-6f);
    tu_sun(ctx, 0, 0, 1, 1, 1, 1, (float)E, 1.0f);
    img = render_checked(ctx, W, H, 8, "thin ball D = 1e-6, background 1");
    for (int c = 0; c < 3; c++) {
        double m = tu_region_mean(img, W, c, 0, 0, W, H);
        tu_power_note(m, 1.0, 1e-3);
        if (fabs(m - 1.0) > 1e-3) fail_msg("thin: channel %d mean %.6g, background 1", c, m);
    }
    free(img);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

void test_extreme_cameras_and_image_sizes_finite(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(23);
    tu_vol vol = tu_vol_ball(24);
    tu_upload(ctx, &vol);
    ball_lights(ctx);
    tu_tf_ramp(ctx, 0.9f, 0.9f, 0.9f, 1.0f);
    struct { const char *what; double p[3], t[3], fov; uint32_t w, h; float D; } cases[] = {
        {"camera at the centre (inside)", {0, 0, 0}, {1, 0, 0}, 60, 24, 24, 1.0f},
        {"camera inside, dense D = 1e3", {0, 0, 0}, {0.2, 1, 0}, 60, 24, 24, 1e3f},
        {"camera inside the shell", {0, 8, 0}, {0, 20, 3}, 90, 24, 24, 10.0f},
        {"camera on a box corner", {12, 12, 12}, {0, 0, 0}, 60, 24, 24, 1.0f},
        {"fov 1 degree", {0, 0, 40}, {0, 0, 0}, 1, 24, 24, 1.0f},
        {"fov 170 degrees", {0, 0, 40}, {0, 0, 0}, 170, 24, 24, 1.0f},
        {"fov 179 degrees", {0, 0, 13}, {0, 0, 0}, 179, 24, 24, 1.0f},
        {"fov 170 inside", {0, 0, 0}, {0, 0, -1}, 170, 24, 24, 5.0f},
        {"image 1x1", {0, 0, 40}, {0, 0, 0}, 40, 1, 1, 1.0f},
        {"image 1x64", {0, 0, 40}, {0, 0, 0}, 40, 1, 64, 1.0f},
        {"image 96x1", {0, 0, 40}, {0, 0, 0}, 40, 96, 1, 1.0f},
        {"camera far away (1e5)", {0, 0, 1e5}, {0, 0, 0}, 0.05, 16, 16, 1.0f},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        tu_tf_ramp(ctx, 0.9f, 0.9f, 0.9f, cases[i].D);
        tu_set_camera(ctx, cases[i].p[0], cases[i].p[1], cases[i].p[2], cases[i].t[0],
                      cases[i].t[1], cases[i].t[2], cases[i].fov, cases[i].w, cases[i].h);
        free(render_checked(ctx, cases[i].w, cases[i].h, 4, cases[i].what));
    }
    tu_vol_free(&vol);
    tu_finish(ctx);
}

void test_extreme_volumes_finite(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(24);
    ball_lights(ctx);
    picvr_volume_desc d;
    char what[80];

    /* tiny and degenerate shapes */
    const uint32_t shapes[][3] = {{1, 1, 1}, {1, 1, 64}, {64, 1, 1}, {2, 2, 2}};
    uint8_t line[64];
    for (int i = 0; i < 64; i++) line[i] = (uint8_t)(i * 4);
    for (size_t s = 0; s < sizeof shapes / sizeof shapes[0]; s++) {
        memset(&d, 0, sizeof d);
        memcpy(d.dims, shapes[s], sizeof d.dims);
        d.type = PICVR_VOXEL_UINT8;
        d.data = line;
        d.spacing[0] = d.spacing[1] = d.spacing[2] = 0.5f;
        TU_OK(picvr_upload_volume(ctx, &d));
        tu_tf_ramp(ctx, 0.9f, 0.9f, 0.9f, 5.0f);
        tu_set_camera(ctx, 3, 4, 40, 0, 0, 0, 60, 16, 16);
        snprintf(what, sizeof what, "volume %ux%ux%u", shapes[s][0], shapes[s][1], shapes[s][2]);
        free(render_checked(ctx, 16, 16, 4, what));
    }

    /* float32: constant data (its own min == max), huge values, denormals */
    static float f[16 * 16 * 16];
    const size_t nf = sizeof f / sizeof f[0];
    for (int k = 0; k < 3; k++) {
        uint64_t rs = 99;
        for (size_t i = 0; i < nf; i++) {
            if (k == 0) f[i] = 3.0f;
            else if (k == 1) f[i] = (float)((tu_rand01(&rs) * 2 - 1) * 1e38);
            else f[i] = (float)(tu_rand01(&rs) * FLT_MIN);
        }
        memset(&d, 0, sizeof d);
        d.dims[0] = d.dims[1] = d.dims[2] = 16;
        d.type = PICVR_VOXEL_FLOAT32;
        d.data = f;
        TU_OK(picvr_upload_volume(ctx, &d));
        tu_tf_ramp(ctx, 0.9f, 0.9f, 0.9f, 2.0f);
        tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 16, 16);
        const char *names[3] = {"float32 constant (min == max)", "float32 +-1e38",
                                "float32 denormal range"};
        free(render_checked(ctx, 16, 16, 4, names[k]));
    }

    /* spacing extremes with the density scaled to the same optical size, and not */
    tu_vol ball = tu_vol_ball(16);
    const struct { float sp[3]; float D; double dist; } sp[] = {
        {{1e-4f, 1e-4f, 1e-4f}, 1e4f, 40e-4},
        {{1e-4f, 1e-4f, 1e-4f}, 1e5f, 40e-4},
        {{1e3f, 1e3f, 1e3f}, 1e-3f, 40e3},
        {{1e3f, 1e3f, 1e3f}, 1e2f, 40e3},
        {{1, 1, 100}, 1.0f, 3000},
        {{0.01f, 1, 1}, 50.0f, 40},
    };
    for (size_t i = 0; i < sizeof sp / sizeof sp[0]; i++) {
        memcpy(ball.spacing, sp[i].sp, sizeof ball.spacing);
        tu_upload(ctx, &ball);
        tu_tf_ramp(ctx, 0.9f, 0.9f, 0.9f, sp[i].D);
        tu_set_camera(ctx, 0.3 * sp[i].dist, 0.2 * sp[i].dist, sp[i].dist, 0, 0, 0, 40, 16, 16);
        snprintf(what, sizeof what, "spacing %g,%g,%g D %g", (double)sp[i].sp[0],
                 (double)sp[i].sp[1], (double)sp[i].sp[2], (double)sp[i].D);
        free(render_checked(ctx, 16, 16, 4, what));
    }
    tu_vol_free(&ball);

    /* uint16 noise, full range, very dense */
    static uint16_t u[16 * 16 * 16];
    uint64_t rs = 5;
    for (size_t i = 0; i < sizeof u / sizeof u[0]; i++) u[i] = (uint16_t)tu_rand_u64(&rs);
    memset(&d, 0, sizeof d);
    d.dims[0] = d.dims[1] = d.dims[2] = 16;
    d.type = PICVR_VOXEL_UINT16;
    d.data = u;
    TU_OK(picvr_upload_volume(ctx, &d));
    tu_tf_ramp(ctx, 1, 1, 1, 1e5f);
    tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 16, 16);
    free(render_checked(ctx, 16, 16, 4, "uint16 noise D = 1e5"));
    tu_finish(ctx);
}
