/* test_real_data.c - smoke test on a real data set: fuel injection, 64^3 uint8
 * ($PICVR_DATA/fuel_64x64x64_uint8.raw.gz).  The test binary is not linked with zlib,
 * so the file is decompressed by `gunzip -c` through popen().  Skipped (and counted as
 * skipped) when PICVR_DATA is unset or lacks the file: the data folder is optional. */
#include "test_util.h"

#include <stdio.h>
#include <unistd.h>

void test_real_data_fuel_smoke(void **state) {
    (void)state;
    const char *dir = getenv("PICVR_DATA");
    if (!dir || !*dir) {
        print_message("    PICVR_DATA is not set: skipped\n");
        skip();
        return;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/fuel_64x64x64_uint8.raw.gz", dir);
    if (access(path, R_OK) != 0) {
        print_message("    %s not found: skipped\n", path);
        skip();
        return;
    }
    const size_t n = 64 * 64 * 64;
    char cmd[4200];
    snprintf(cmd, sizeof cmd, "gunzip -c '%s'", path);
    FILE *f = popen(cmd, "r");
    if (!f) fail_msg("popen(%s) failed", cmd);
    uint8_t *v = malloc(n + 1);
    assert_non_null(v);
    size_t got = fread(v, 1, n + 1, f);
    int rc = pclose(f);
    if (rc != 0 || got != n)
        fail_msg("%s: exit status %d, %zu bytes (expected %zu)", cmd, rc, got, n);

    picvr_context *ctx = tu_create(0);
    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    d.dims[0] = d.dims[1] = d.dims[2] = 64;
    d.type = PICVR_VOXEL_UINT8;
    d.data = v;
    TU_OK(picvr_upload_volume(ctx, &d));
    free(v); /* "copied" */
    float bmin[3], bmax[3];
    TU_OK(picvr_volume_box(ctx, bmin, bmax));
    for (int i = 0; i < 3; i++) assert_true(bmin[i] == -32.0f && bmax[i] == 32.0f);
    /* Default transfer function (opacity = value, albedo 1, D = 1); a sun and a black
       background, so any light in the image was scattered by the volume. */
    tu_sun(ctx, 1, 2, 1.5, 1, 1, 1, 4, 0.0f);
    const uint32_t W = 64, H = 64;
    tu_set_camera(ctx, 40, 50, 110, 0, 0, 0, 40, W, H);
    TU_OK(picvr_step_iterations(ctx, 8));
    float *img = tu_read(ctx, W, H);
    tu_assert_finite(img, (size_t)W * H * 4, "fuel");
    double lum = 0, alpha = 0;
    size_t lit = 0;
    for (size_t p = 0; p < (size_t)W * H; p++) {
        double l = tu_lum(img[4 * p], img[4 * p + 1], img[4 * p + 2]);
        lum += l;
        alpha += img[4 * p + 3];
        lit += l > 0;
    }
    picvr_stats st = tu_stats_finite(ctx);
    print_message("    fuel: mean luminance %.4g, mean alpha %.4g, %zu lit pixels, %.3g samples/s\n",
                  lum / (W * H), alpha / (W * H), lit, st.samples_per_second);
    free(img);
    assert_true(lum > 0);
    assert_true(alpha > 0);
    assert_true(lit >= 16);
    assert_int_equal(st.truncated_paths, 0); /* an ordinary medium */
    tu_finish(ctx);
}
