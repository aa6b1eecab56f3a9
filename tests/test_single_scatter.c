/* test_single_scatter.c - single scattering of a homogeneous medium under a delta sun.
 *
 * Closed form (CONVENTIONS: sigma_s = albedo sigma_t, isotropic phase 1/(4 pi),
 * directional light = irradiance E = colour * intensity on a plane facing it, single
 * scattering only, black background):
 *   L_c = integral_{t0}^{t1} albedo_c sigma e^{-sigma (t - t0)} E_c / (4 pi)
 *                                 e^{-sigma s(x(t))} dt,
 * s(x) = distance from x to the box exit toward the sun.  s(x(t)) is piecewise linear
 * in t; the integral is evaluated with 8-point Gauss-Legendre on 64 pieces per ray
 * (relative error < 1e-6 here), for 4x4 jitter sub-samples per pixel.
 *
 * Variance: with one light and a black background the light is chosen with
 * probability 1; a sample is 0 (escape) or albedo_c E_c / (4 pi) times a ratio-tracking
 * weight in [0, 1], so every sample lies in [0, M_c], M_c = albedo_c E_c / (4 pi), and
 * Var <= mu (M_c - mu) (analytic bound of tu_check_mean).
 */
#include "test_util.h"

typedef struct sun_scene {
    double bmin[3], bmax[3], sigma, l[3], albedo[3], E[3];
    /* per ray */
    double o[3], d[3], t0;
} sun_scene;

static double sun_integrand(double t, void *user) {
    const sun_scene *s = user;
    double x[3] = {s->o[0] + t * s->d[0], s->o[1] + t * s->d[1], s->o[2] + t * s->d[2]};
    double sd = tu_box_exit(x, s->l, s->bmin, s->bmax);
    return s->sigma * exp(-s->sigma * (t - s->t0)) * exp(-s->sigma * sd) / (4 * M_PI);
}

static void sun_ray(const double o[3], const double d[3], void *user, double out[4]) {
    sun_scene s = *(const sun_scene *)user;
    double t0, t1;
    out[0] = out[1] = out[2] = out[3] = 0;
    if (!tu_ray_box(o, d, s.bmin, s.bmax, &t0, &t1)) return;
    memcpy(s.o, o, sizeof s.o);
    memcpy(s.d, d, sizeof s.d);
    s.t0 = t0;
    double J = tu_integrate(sun_integrand, &s, t0, t1, 64);
    for (int c = 0; c < 3; c++) out[c] = s.albedo[c] * s.E[c] * J;
    out[3] = 1 - exp(-s.sigma * (t1 - t0));
}

/* Homogeneous 16^3 cube (box [-8,8]^3), sigma_t = 0.15 (optical depth 2.4 along an
   axis), albedo (1, 0.8, 0.5), sun toward (0.6, 0.45, 0.66) with colour (1, 0.6, 0.3)
   and intensity 2.  Camera on the +z axis at 30, fov 20: every pixel sees the front
   face (half-extent 22 tan 10 deg = 3.9 < 8).  Channels, alpha (coverage = 1 - T,
   Bernoulli) and the four quadrants (the sun is off-axis, so a mirrored image or a
   wrong sun direction changes them) are checked. */
void test_single_scatter_delta_sun_coloured(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(4);
    tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
    tu_upload(ctx, &vol);
    sun_scene s;
    memset(&s, 0, sizeof s);
    tu_vol_box(&vol, s.bmin, s.bmax);
    const float alb[3] = {1.0f, 0.8f, 0.5f}, col[3] = {1.0f, 0.6f, 0.3f}, inten = 2.0f;
    const float D = 0.15f;
    s.sigma = D;
    tu_tf_const(ctx, alb[0], alb[1], alb[2], 1.0f, D);
    double l[3] = {0.6, 0.45, 0.66}, ll = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    for (int i = 0; i < 3; i++) {
        s.l[i] = l[i] / ll;
        s.albedo[i] = alb[i];
        s.E[i] = (double)col[i] * inten;
    }
    tu_sun(ctx, l[0], l[1], l[2], col[0], col[1], col[2], inten, 0.0f);
    const uint32_t W = 64, H = 64, N = 256;
    tu_cam cam = tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 20, W, H);
    double *expv = tu_expected_image(&cam, 4, sun_ray, &s);

    TU_OK(picvr_step_iterations(ctx, N));
    float *img = tu_read(ctx, W, H);
    tu_assert_finite(img, (size_t)W * H * 4, "single scatter");
    /* Tolerance: z = 5 with the analytic bound above (the 5-sigma bound is ~1 % of the
       mean), plus sys_rel 1e-4 for the quadratures. */
    int ok = 1;
    const char *cn[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; c++) {
        double M = s.albedo[c] * s.E[c] / (4 * M_PI);
        char label[64];
        snprintf(label, sizeof label, "delta sun: image %s", cn[c]);
        ok &= tu_check_mean(label, img, expv, W, c, 0, 0, W, H, N, M, 5.0, 1e-4);
        for (int q = 0; q < 4; q++) {
            uint32_t x0 = (q & 1) ? W / 2 : 0, y0 = (q & 2) ? H / 2 : 0;
            snprintf(label, sizeof label, "delta sun: quadrant %d %s", q, cn[c]);
            ok &= tu_check_mean(label, img, expv, W, c, x0, y0, x0 + W / 2, y0 + H / 2, N, M,
                                5.0, 1e-4);
        }
    }
    /* Per-pixel structure (G channel): the variance bound is an upper bound, so
       chi2 / P <= ~1; limit 1.5. */
    double Mg = s.albedo[1] * s.E[1] / (4 * M_PI);
    ok &= tu_check_chi2("delta sun: per pixel", img, expv, W, H, 1, N, Mg, 1.5);
    double *mir = tu_mirror_x(expv, W, H);
    tu_check_chi2("(power check: mirrored expectation)", img, mir, W, H, 1, N, Mg, 1.5);
    free(mir);
    ok &= tu_check_mean("delta sun: alpha (1 - T)", img, expv, W, 3, 0, 0, W, H, N, 1.0, 5.0,
                        1e-4);
    picvr_stats st = tu_stats_finite(ctx);
    if (st.truncated_paths != 0)
        fail_msg("truncated_paths = %llu", (unsigned long long)st.truncated_paths);
    /* mean_luminance is the image mean of the Rec. 709 luminance of the same image. */
    double lum = 0;
    for (size_t p = 0; p < (size_t)W * H; p++)
        lum += tu_lum(img[4 * p], img[4 * p + 1], img[4 * p + 2]);
    lum /= (double)W * H;
    print_message("    stats.mean_luminance %.6g, from the image %.6g\n", st.mean_luminance, lum);
    assert_true(fabs(st.mean_luminance - lum) <= 1e-4 * lum);
    free(img);
    free(expv);
    tu_vol_free(&vol);
    if (!ok) fail_msg("single scattering under a delta sun differs from the closed form");
    tu_finish(ctx);
}
