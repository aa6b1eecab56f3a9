/* test_cpu_reference.c - the Vulkan renderer against the independent C/OpenMP
 * reference (reference/cpu_reference.h) on one small scene that takes every estimator path:
 * a structured volume with a coloured transfer function, a sphere light (MIS between
 * light and phase sampling), a sun with an angular size and a background.
 *
 * Both images are unbiased estimates of the same expectation with independent random
 * numbers, so the per-channel image and quadrant means of the difference are compared
 * within 5 standard errors, taken from the spread of the 8x8-block means of the
 * difference image (this covers the noise of both images).  Per pixel, the luminance
 * differences are compared with the reference's own per-pixel variance (Welford M2),
 * see R below.
 */
#include "test_util.h"

#if defined(__has_include)
#if __has_include("reference/cpu_reference.h")
#define TU_HAVE_CREF 1
#endif
#endif

#ifdef TU_HAVE_CREF
#include "reference/cpu_reference.h"

/* The comparison described at the top, for lights l[0..1] and the background bg. */
static void gpu_cpu_case(const picvr_light l[2], const picvr_background *bg, uint32_t seed) {
    const uint32_t W = 48, H = 48, N = 128;
    picvr_context *ctx = tu_create(seed);
    tu_vol vol = tu_vol_ball(24);
    picvr_volume_desc vd;
    memset(&vd, 0, sizeof vd);
    memcpy(vd.dims, vol.dims, sizeof vd.dims);
    memcpy(vd.spacing, vol.spacing, sizeof vd.spacing);
    vd.type = PICVR_VOXEL_UINT8;
    vd.data = vol.v;
    picvr_tf_point tf[3] = {{0.0f, {0.9f, 0.6f, 0.4f}, 0.0f},
                            {0.4f, {0.5f, 0.9f, 0.7f}, 0.2f},
                            {1.0f, {0.95f, 0.95f, 0.95f}, 1.0f}};
    const float D = 0.5f;
    picvr_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position[0] = 5; cam.position[1] = 3; cam.position[2] = 40;
    cam.up[1] = 1;
    cam.fov_y_degrees = 40;
    cam.width = W;
    cam.height = H;

    TU_OK(picvr_upload_volume(ctx, &vd));
    TU_OK(picvr_set_transfer_function(ctx, tf, 3, D));
    TU_OK(picvr_set_lights(ctx, l, 2, bg));
    TU_OK(picvr_set_camera(ctx, &cam));
    TU_OK(picvr_step_iterations(ctx, N));
    float *gpu = tu_read(ctx, W, H);
    tu_assert_finite(gpu, (size_t)W * H * 4, "gpu");
    picvr_stats st = tu_stats_finite(ctx);

    cref_scene s;
    int rc = cref_scene_init(&s, &vd, tf, 3, D, l, 2, bg, &cam, seed + 1000);
    if (rc != PICVR_OK) fail_msg("cref_scene_init: %s", picvr_status_string((picvr_status)rc));
    float *cpu = malloc((size_t)W * H * 4 * sizeof *cpu);
    double *m2 = malloc((size_t)W * H * sizeof *m2);
    double *cpu_d = malloc((size_t)W * H * 4 * sizeof *cpu_d);
    assert_non_null(cpu); assert_non_null(m2); assert_non_null(cpu_d);
    cref_render_stats cst;
    memset(&cst, 0, sizeof cst);
    rc = cref_render_ex(&s, 0, N, cpu, m2, &cst);
    if (rc != PICVR_OK) fail_msg("cref_render_ex: %s", picvr_status_string((picvr_status)rc));
    /* The reference must itself be in its unbiased regime for the comparison to mean
       anything. */
    assert_int_equal(cst.truncated_paths, 0);
    assert_int_equal(cst.majorant_violations, 0);
    for (size_t i = 0; i < (size_t)W * H * 4; i++) cpu_d[i] = cpu[i];

    int ok = 1;
    const char *cn[4] = {"R", "G", "B", "alpha"};
    for (int c = 0; c < 4; c++) {
        char label[64];
        snprintf(label, sizeof label, "gpu vs cpu: image %s", cn[c]);
        ok &= tu_check_mean(label, gpu, cpu_d, W, c, 0, 0, W, H, N, 0, 5.0, 0);
    }
    for (int q = 0; q < 4; q++) {
        uint32_t x0 = (q & 1) ? W / 2 : 0, y0 = (q & 2) ? H / 2 : 0;
        char label[64];
        snprintf(label, sizeof label, "gpu vs cpu: quadrant %d G", q);
        ok &= tu_check_mean(label, gpu, cpu_d, W, 1, x0, y0, x0 + W / 2, y0 + H / 2, N, 0, 5.0, 0);
    }
    /* Per pixel: R = sum_p (L_gpu - L_cpu)^2 / sum_p 2 S_p^2 / N.  A ratio of sums, not
       a sum of ratios: pixels where one run saw no rare event (S_p ~ 0) cannot blow it
       up.  Both renderers have the same per-pixel variance (seen: R = 1.00-1.11 for
       GPU/GPU, CPU/CPU and GPU/CPU pairs of seeds), so R ~ 1; limit 1.5.  Power: the
       same statistic against the mirrored reference image is ~2.4 in this scene. */
    double sd = 0, sv = 0, sdm = 0;
    for (size_t p = 0; p < (size_t)W * H; p++) {
        size_t pm = (p / W) * W + (W - 1 - p % W);
        double lg = tu_lum(gpu[4 * p], gpu[4 * p + 1], gpu[4 * p + 2]);
        double lc = tu_lum(cpu[4 * p], cpu[4 * p + 1], cpu[4 * p + 2]);
        double lm = tu_lum(cpu[4 * pm], cpu[4 * pm + 1], cpu[4 * pm + 2]);
        sd += (lg - lc) * (lg - lc);
        sdm += (lg - lm) * (lg - lm);
        sv += 2 * (m2[p] / (N - 1)) / N;
    }
    double R = sd / sv;
    print_message("    gpu vs cpu: per-pixel luminance R %.4g (limit 1.5) %s; mirrored %.4g\n", R,
                  R <= 1.5 ? "ok" : "FAIL", sdm / sv);
    print_message("    gpu %.3g samples/s, truncated %llu; cpu truncated %llu\n",
                  st.samples_per_second, (unsigned long long)st.truncated_paths,
                  (unsigned long long)cst.truncated_paths);
    ok &= R <= 1.5;
    assert_int_equal(st.truncated_paths, 0);
    cref_free(&s);
    free(gpu); free(cpu); free(m2); free(cpu_d);
    tu_vol_free(&vol);
    if (!ok) fail_msg("the Vulkan image differs from the CPU reference");
    tu_finish(ctx);
}

/* The comparison with `first` as the first light, then a sun with an angular size
   (MIS between light and phase sampling) and a background. */
static void gpu_cpu_case_with_sun(const picvr_light *first, uint32_t seed) {
    picvr_light l[2];
    memset(l, 0, sizeof l);
    l[0] = *first;
    l[1].type = PICVR_LIGHT_DIRECTIONAL;
    l[1].direction[0] = -1; l[1].direction[1] = 1; l[1].direction[2] = 0.5f;
    l[1].angular_diameter = 0.2f;
    l[1].color[0] = 0.6f; l[1].color[1] = 0.7f; l[1].color[2] = 1;
    l[1].intensity = 1.5f;
    picvr_background bg = {{0.3f, 0.4f, 0.6f}, 0.7f};
    gpu_cpu_case(l, &bg, seed);
}

/* A sphere light (MIS between light and phase sampling): the renderer's delta tracking
   (the sphere's 1/d^2 varies too little across the volume for equiangular sampling). */
void test_gpu_matches_cpu_reference_area_light_background(void **state) {
    (void)state;
    picvr_light sphere;
    memset(&sphere, 0, sizeof sphere);
    sphere.type = PICVR_LIGHT_SPHERE;
    sphere.position[0] = 25; sphere.position[1] = 10; sphere.position[2] = 20;
    sphere.radius = 4;
    sphere.color[0] = 1; sphere.color[1] = 0.8f; sphere.color[2] = 0.6f;
    sphere.intensity = 3;
    gpu_cpu_case_with_sun(&sphere, 31);
}

/* A point light inside the ball's bounding sphere, so that camera rays also sample
   toward it by equiangular sampling (MIS with delta tracking, residual ratio tracking,
   the background through the camera ray's transmittance estimate): against the
   reference's delta tracking and ratio tracking. */
void test_gpu_matches_cpu_reference_point_light_equiangular(void **state) {
    (void)state;
    picvr_light point;
    memset(&point, 0, sizeof point);
    point.type = PICVR_LIGHT_POINT;
    point.position[0] = 8; point.position[1] = 13; point.position[2] = 5;
    point.color[0] = 1; point.color[1] = 0.8f; point.color[2] = 0.6f;
    point.intensity = 300;
    gpu_cpu_case_with_sun(&point, 37);
}

#else

void test_gpu_matches_cpu_reference_area_light_background(void **state) {
    (void)state;
    print_message("    reference/cpu_reference.h not found: skipped\n");
    skip();
}

void test_gpu_matches_cpu_reference_point_light_equiangular(void **state) {
    (void)state;
    print_message("    reference/cpu_reference.h not found: skipped\n");
    skip();
}

#endif
