/* test_determinism.c - reproducibility and the error estimate. */
#include "test_util.h"
#include <unistd.h>

/* A scene that uses every random dimension: structured volume, sun with an angular
   size, sphere light (MIS), background. */
static void varied_scene(picvr_context *ctx, tu_vol *vol) {
    *vol = tu_vol_ball(20);
    tu_upload(ctx, vol);
    picvr_tf_point tf[3] = {{0.0f, {0.9f, 0.7f, 0.5f}, 0.0f},
                            {0.5f, {0.6f, 0.9f, 0.8f}, 0.3f},
                            {1.0f, {1.0f, 1.0f, 1.0f}, 1.0f}};
    TU_OK(picvr_set_transfer_function(ctx, tf, 3, 0.8f));
    picvr_light l[2];
    memset(l, 0, sizeof l);
    l[0].type = PICVR_LIGHT_DIRECTIONAL;
    l[0].direction[0] = 1; l[0].direction[1] = 2; l[0].direction[2] = 1;
    l[0].angular_diameter = 0.1f;
    l[0].color[0] = 1; l[0].color[1] = 0.9f; l[0].color[2] = 0.8f;
    l[0].intensity = 2;
    l[1].type = PICVR_LIGHT_SPHERE;
    l[1].position[0] = -20; l[1].position[1] = 5; l[1].position[2] = 10;
    l[1].radius = 3;
    l[1].color[0] = l[1].color[1] = l[1].color[2] = 1;
    l[1].intensity = 4;
    picvr_background bg = {{0.3f, 0.4f, 0.6f}, 0.5f};
    TU_OK(picvr_set_lights(ctx, l, 2, &bg));
    tu_set_camera(ctx, 0, 0, 40, 0, 0, 0, 35, 32, 32);
}

void test_same_seed_bit_identical_different_seed_differs(void **state) {
    (void)state;
    const uint32_t N = 12;
    const size_t nf = 32 * 32 * 4;
    tu_vol va, vb, vc;
    picvr_context *a = tu_create(42);
    varied_scene(a, &va);
    picvr_context *b = tu_create(42);
    varied_scene(b, &vb);
    TU_OK(picvr_step_iterations(a, N));
    TU_OK(picvr_step_iterations(b, N / 2)); /* split differently: still N iterations */
    TU_OK(picvr_step_iterations(b, N - N / 2));
    float *ia = tu_read(a, 32, 32), *ib = tu_read(b, 32, 32);
    tu_assert_finite(ia, nf, "seed 42 (a)");
    size_t ndiff = 0;
    for (size_t i = 0; i < nf; i++) ndiff += memcmp(&ia[i], &ib[i], sizeof(float)) != 0;
    if (ndiff) fail_msg("same seed, same iterations: %zu of %zu floats differ", ndiff, nf);

    /* Same context after a reset: identical again. */
    TU_OK(picvr_reset(a));
    TU_OK(picvr_step_iterations(a, N));
    float *ia2 = tu_read(a, 32, 32);
    if (memcmp(ia, ia2, nf * sizeof(float)) != 0)
        fail_msg("same context, reset and re-rendered: the image differs");

    picvr_context *c = tu_create(43);
    varied_scene(c, &vc);
    TU_OK(picvr_step_iterations(c, N));
    float *ic = tu_read(c, 32, 32);
    ndiff = 0;
    for (size_t i = 0; i < nf; i++) ndiff += ia[i] != ic[i];
    print_message("    seed 43 vs 42: %zu of %zu floats differ\n", ndiff, nf);
    /* Pixels that miss the ball show the exact background whatever the seed; the ball
       covers ~1/3 of the image, and there every noisy value differs: require 10 %. */
    assert_true(ndiff > nf / 10);
    free(ia); free(ib); free(ia2); free(ic);
    tu_vol_free(&va); tu_vol_free(&vb); tu_vol_free(&vc);
    tu_finish(a);
    tu_finish(b);
    tu_finish(c);
}

/* est_error = image mean of 1.96 sqrt(S^2 / N) of the pixel luminance.  On Bernoulli
   samples (homogeneous cube, albedo 0, background 1: see test_beer_lambert.c) the
   per-pixel standard deviation is exactly sqrt(T (1 - T)), so
     est_error(N) ~= 1.96 mean_p sqrt(T_p (1 - T_p) / N),
   within the O(1/N) bias of S and a relative spread of ~1/sqrt(2 N P) (0.3 % here):
   tolerance 5 %.  Going from N to 4N halves it: ratio in [1.7, 2.3] (the brief).
   est_rel_error = mean_p est_error_p / (L_p + 0.01 mean L): checked finite, and within
   10 % of the same plug-in prediction (Jensen bias of 1/L_p ~1-3 % at these N). */
typedef struct homog2 { double bmin[3], bmax[3], sigma; } homog2;
static void homog2_ray(const double o[3], const double d[3], void *user, double out[4]) {
    const homog2 *h = user;
    double t0, t1, T = 1;
    if (tu_ray_box(o, d, h->bmin, h->bmax, &t0, &t1)) T = exp(-h->sigma * (t1 - t0));
    out[0] = out[1] = out[2] = T;
    out[3] = 1 - T;
}

void test_error_estimate_halves_with_4x_iterations(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(5);
    tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
    tu_upload(ctx, &vol);
    homog2 h = {{-8, -8, -8}, {8, 8, 8}, (double)(float)(1.0 / 16)};
    tu_tf_const(ctx, 0, 0, 0, 1.0f, (float)h.sigma);
    tu_background_only(ctx, 1, 1, 1, 1);
    const uint32_t W = 32, H = 32, N = 64;
    tu_cam cam = tu_set_camera(ctx, 0, 0, 20, 0, 0, 0, 40, W, H);
    double *expv = tu_expected_image(&cam, 4, homog2_ray, &h);
    double pred_abs[2] = {0, 0}, pred_rel[2] = {0, 0}, meanT = 0;
    for (size_t p = 0; p < (size_t)W * H; p++) meanT += expv[4 * p];
    meanT /= (double)W * H;
    for (int k = 0; k < 2; k++) {
        uint32_t n = k ? 4 * N : N;
        for (size_t p = 0; p < (size_t)W * H; p++) {
            double T = expv[4 * p], e = 1.96 * sqrt(T * (1 - T) / n);
            pred_abs[k] += e;
            pred_rel[k] += e / (T + 0.01 * meanT);
        }
        pred_abs[k] /= (double)W * H;
        pred_rel[k] /= (double)W * H;
    }
    TU_OK(picvr_step_iterations(ctx, N));
    picvr_stats s1 = tu_stats_finite(ctx);
    TU_OK(picvr_step_iterations(ctx, 3 * N));
    picvr_stats s4 = tu_stats_finite(ctx);
    assert_int_equal(s4.iterations, 4 * N);
    double ratio = s1.est_error / s4.est_error;
    print_message("    est_error N=%u %.5g (predicted %.5g), 4N %.5g (predicted %.5g), ratio %.3f\n",
                  N, s1.est_error, pred_abs[0], s4.est_error, pred_abs[1], ratio);
    print_message("    est_rel_error N %.5g (predicted %.5g), 4N %.5g (predicted %.5g)\n",
                  s1.est_rel_error, pred_rel[0], s4.est_rel_error, pred_rel[1]);
    assert_true(ratio >= 1.7 && ratio <= 2.3);
    assert_true(fabs(s1.est_error / pred_abs[0] - 1) <= 0.05);
    assert_true(fabs(s4.est_error / pred_abs[1] - 1) <= 0.05);
    assert_true(isfinite(s1.est_rel_error) && s1.est_rel_error > 0);
    assert_true(isfinite(s4.est_rel_error) && s4.est_rel_error > 0);
    assert_true(fabs(s4.est_rel_error / pred_rel[1] - 1) <= 0.10);
    free(expv);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* One scene of test_kernel_pruning_changes_nothing: varied_scene with the features the
   case turns on (case c: 0 as is; 1 unlimited bounces, two HG lobes and an environment
   map; 2 the forced distance point and ray-marched shadow rays; 3 a clip plane, an HG g
   per TF point and a point light, equiangular where it falls off), rendered N
   iterations with config.kernel_pruning `pruning`; the image. */
static float *pruning_case(int c, picvr_switch pruning, uint32_t N) {
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = 77 + (uint32_t)c;
    cfg.kernel_pruning = pruning;
    if (c == 2) {
        cfg.distance_sampling = PICVR_DISTANCE_FORCED;
        cfg.transmittance = PICVR_TRANSMITTANCE_RAY_MARCHING;
    }
    picvr_context *ctx = tu_create_config(&cfg);
    tu_vol vol;
    varied_scene(ctx, &vol);
    static float env[8 * 4 * 3];
    if (c == 1) {
        for (int i = 0; i < 8 * 4 * 3; i++) env[i] = 0.2f + 0.1f * (float)(i % 7);
        picvr_scattering sc = {PICVR_BOUNCES_UNLIMITED, -0.3f, 0.25f};
        TU_OK(picvr_set_scattering(ctx, &sc));
        picvr_background bg = {{1.0f, 1.0f, 1.0f}, 0.8f, env, 8, 4, 0.5f};
        TU_OK(picvr_set_lights(ctx, NULL, 0, &bg));
    }
    if (c == 3) {
        picvr_clip clip;
        memset(&clip, 0, sizeof clip);
        clip.planes[0][0] = 1.0f;
        clip.planes[0][3] = 2.0f;
        clip.plane_count = 1;
        TU_OK(picvr_set_clip(ctx, &clip));
        picvr_tf_point tf[2] = {{0.0f, {0.9f, 0.7f, 0.5f}, 0.0f, 0.6f}, {1.0f, {1.0f, 1.0f, 1.0f}, 1.0f, -0.2f}};
        TU_OK(picvr_set_transfer_function(ctx, tf, 2, 0.8f));
    }
    if (c == 3) {
        picvr_light l;
        memset(&l, 0, sizeof l);
        l.type = PICVR_LIGHT_POINT;
        l.position[0] = 2;
        l.position[1] = 3;
        l.color[0] = l.color[1] = l.color[2] = 1;
        l.intensity = 50;
        TU_OK(picvr_set_lights(ctx, &l, 1, NULL));
    }
    TU_OK(picvr_step_iterations(ctx, N));
    float *img = tu_read(ctx, 32, 32);
    tu_assert_finite(img, 32 * 32 * 4, "kernel pruning");
    tu_vol_free(&vol);
    tu_finish(ctx);
    return img;
}

/* picvr_config.kernel_pruning (host/spirv.c): leaving out the calls a variant's
   constants make unreachable changes nothing the device computes.  Each case renders
   the same seed's image bit for bit with pruning on and off; the cases between them
   take both ways the constants a plain scene turns (bounces, HG lobes, the environment
   map, the forced point, ray marching, clipping, equiangular sampling).  The cached
   kernels are left to the cache's tests against closed forms, all of which run pruned:
   a cached image is not bit-reproducible (the entries' order in the pool follows the
   threads' timing; two runs with pruning on differ in a few pixels). */
void test_kernel_pruning_changes_nothing(void **state) {
    (void)state;
    const uint32_t N = 4;
    const size_t nf = 32 * 32 * 4;
    int ok = 1;
    for (int c = 0; c < 4; c++) {
        float *on = pruning_case(c, PICVR_SWITCH_DEFAULT, N), *off = pruning_case(c, PICVR_SWITCH_OFF, N);
        size_t ndiff = 0;
        double mean = 0;
        for (size_t i = 0; i < nf; i++) {
            ndiff += memcmp(&on[i], &off[i], sizeof(float)) != 0;
            mean += on[i];
        }
        print_message("    case %d: %zu of %zu floats differ, mean %.5g\n", c, ndiff, nf, mean / (double)nf);
        if (ndiff) ok = 0;
        if (!(mean > 0)) fail_msg("case %d renders a black image: nothing compared", c);
        free(on);
        free(off);
    }
    if (!ok) fail_msg("pruned kernels render another image than whole ones (listed above)");
}

/* picvr_config.compile_threads: the threads that make pipelines change nothing the
   device computes.  Contexts with 1 thread (the calling one) and UINT32_MAX (16 are
   used) render the same seed's image bit for bit; a cached context, whose first step
   makes five pipelines in one batch, renders a finite image with 16; and
   picvr_get_config gives what each runs with (0: the processors online, at most 16). */
void test_compile_threads_change_nothing(void **state) {
    (void)state;
    const uint32_t N = 6, given[2] = {1u, UINT32_MAX}, want[2] = {1u, 16u};
    const size_t nf = 32 * 32 * 4;
    float *img[2];
    for (int i = 0; i < 2; i++) {
        picvr_config cfg;
        memset(&cfg, 0, sizeof cfg);
        cfg.seed = 42;
        cfg.compile_threads = given[i];
        picvr_context *ctx = tu_create_config(&cfg);
        picvr_config got;
        TU_OK(picvr_get_config(ctx, &got));
        assert_int_equal(got.compile_threads, want[i]);
        tu_vol vol;
        varied_scene(ctx, &vol);
        TU_OK(picvr_step_iterations(ctx, N));
        img[i] = tu_read(ctx, 32, 32);
        tu_assert_finite(img[i], nf, "compile_threads");
        tu_vol_free(&vol);
        tu_finish(ctx);
    }
    if (memcmp(img[0], img[1], nf * sizeof(float)) != 0)
        fail_msg("compile_threads %u renders another image than 1", given[1]);
    for (int i = 0; i < 2; i++) free(img[i]);

    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = 42;
    cfg.compile_threads = UINT32_MAX;
    cfg.cache.mode = PICVR_CACHE_OBJECT_SPACE;
    picvr_context *ctx = tu_create_config(&cfg);
    tu_vol vol;
    varied_scene(ctx, &vol);
    TU_OK(picvr_step_iterations(ctx, N));
    float *c = tu_read(ctx, 32, 32);
    tu_assert_image_valid(c, 32, 32, "cached, 16 compile threads");
    free(c);
    tu_vol_free(&vol);
    tu_finish(ctx);

    picvr_context *d = tu_create(1);
    picvr_config got;
    TU_OK(picvr_get_config(d, &got));
#if defined(_SC_NPROCESSORS_ONLN)
    long online = sysconf(_SC_NPROCESSORS_ONLN);
    uint32_t expect = online < 1 ? 1u : online > 16 ? 16u : (uint32_t)online;
    if (got.compile_threads != expect)
        fail_msg("compile_threads 0 resolved to %u, not the %u processors online", got.compile_threads, expect);
#endif
    tu_finish(d);
}
