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
   closed form (tu_sun_ray).  The model is exact here, so the bound is float rounding:
   the sun's optical depth is exact at each cell's centre, and the light toward the
   camera is interpolated in its logarithm (extended within half a cell of the faces),
   which is linear in the depth (the isotropic phase function is constant), at any grid
   ratio; each camera step integrates the light as exponential between its ends, exact
   for that.  Float keeps ~1e-6 per step over ~30 steps: the check is every pixel within
   1e-4 of the closed form, relative to the image's largest value. */
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
        print_message("field sun cube, grid ratio %u: largest error %.2e of the image's peak (bound 1e-4)\n",
                      ratios[r], worst);
        assert_true(worst <= 1e-4);
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

/* Energy bookkeeping of one pass: a purely absorbing homogeneous cube (albedo 0) under a
   uniform background L = 1, one scatter event (one pass), read back with
   picvr_read_field.
   (1) Each cell's fluence is the discrete model's: the sum over the D directions, each
   way, of 4 pi / D times e^(-sigma s), s the chord from the cell's centre back to the
   box along the direction, computed here in double: within 1e-5 (float sums of ~32
   terms).
   (2) The power the medium absorbs from the field, the sum over cells of sigma h^3 phi,
   against the power the beams of the same directions lose crossing the cube, the sum
   of 4 pi / D times the integral over the plane normal to each direction of
   1 - e^(-sigma l) (l the chord; a lattice of 1/8 voxel).  The field takes each
   direction's radiance at the cells' centres, the midpoint rule over each cell: exact
   to second order where the radiance is smooth, first order in the cells a kink of it
   crosses (the planes where a direction's entry face changes).  So the difference must
   fall at least 1.6 times (first order: 2) when the cells halve, and stay below
   sigma h / 8 = 2.5e-2 on the coarser grid. */
static double energy_difference(uint32_t ratio, double *worst_cell) {
    const uint32_t half = 16, n = 16 / ratio;
    const double sigma = 0.1, h = (double)ratio;   /* per voxel; a cell's side */
    picvr_context *ctx = field_context(ratio, 2 * half, 0.0f, 0);
    tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
    tu_upload(ctx, &vol);
    tu_tf_const(ctx, 0, 0, 0, 1.0f, (float)sigma);
    tu_background_only(ctx, 1, 1, 1, 1.0f);
    tu_set_camera(ctx, 0, 0, 40, 0, 0, 0, 40, 8, 8);
    TU_OK(picvr_step(ctx, 1.0));
    uint32_t dims[3], cells = n * n * n;
    float *f = malloc((size_t)cells * 64);
    assert_non_null(f);
    TU_OK(picvr_read_field(ctx, f, (size_t)cells * 64, dims));
    assert_true(dims[0] == n && dims[1] == n && dims[2] == n);
    double bmin[3], bmax[3], absorbed = 0.0, lost = 0.0;
    tu_vol_box(&vol, bmin, bmax);
    *worst_cell = 0.0;
    for (uint32_t c = 0; c < cells; c++) {
        double x[3] = {bmin[0] + (c % n + 0.5) * h, bmin[1] + (c / n % n + 0.5) * h, bmin[2] + (c / (n * n) + 0.5) * h};
        double phi = 0.0;
        for (uint32_t k = 0; k < 2 * half; k++) {
            double w[3];
            fref_direction(k / 2, half, w);
            double back[3] = {k & 1 ? w[0] : -w[0], k & 1 ? w[1] : -w[1], k & 1 ? w[2] : -w[2]};
            phi += 4.0 * M_PI / (2.0 * half) * exp(-sigma * tu_box_exit(x, back, bmin, bmax));
        }
        *worst_cell = fmax(*worst_cell, fabs(f[16 * c + 4] / phi - 1.0));
        absorbed += (double)f[16 * c] * h * h * h * f[16 * c + 4];   /* sigma h^3 phi_r */
    }
    const double step = 0.125, R = 14.0;   /* lattice spacing; R > the box's half-diagonal */
    for (uint32_t k = 0; k < half; k++) {
        double w[3], u[3], v[3];
        fref_direction(k, half, w);
        double a[3] = {fabs(w[0]) < 0.9 ? 1.0 : 0.0, fabs(w[0]) < 0.9 ? 0.0 : 1.0, 0.0};
        u[0] = a[1] * w[2] - a[2] * w[1]; u[1] = a[2] * w[0] - a[0] * w[2]; u[2] = a[0] * w[1] - a[1] * w[0];
        double nu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (int i = 0; i < 3; i++) u[i] /= nu;
        v[0] = w[1] * u[2] - w[2] * u[1]; v[1] = w[2] * u[0] - w[0] * u[2]; v[2] = w[0] * u[1] - w[1] * u[0];
        double sum = 0.0;
        int m = (int)(R / step);
        for (int j = -m; j < m; j++)
            for (int i = -m; i < m; i++) {
                double o[3], t0, t1;
                for (int q = 0; q < 3; q++) o[q] = (i + 0.5) * step * u[q] + (j + 0.5) * step * v[q] - 2.0 * R * w[q];
                if (tu_ray_box(o, w, bmin, bmax, &t0, &t1)) sum += -expm1(-sigma * (t1 - t0));
            }
        lost += 2.0 * (4.0 * M_PI / (2.0 * half)) * sum * step * step;   /* both ways: the same chords */
    }
    free(f);
    tu_vol_free(&vol);
    tu_finish(ctx);
    return fabs(absorbed / lost - 1.0);
}

void test_field_energy_one_pass(void **state) {
    (void)state;
    double cell2, cell1;
    double coarse = energy_difference(2, &cell2), fine = energy_difference(1, &cell1);
    print_message("field energy: cells' fluence within %.1e / %.1e of the model; absorbed vs lost %.2e (sigma h 0.2), "
                  "%.2e (0.1)\n", cell2, cell1, coarse, fine);
    assert_true(cell2 <= 1e-5 && cell1 <= 1e-5);
    assert_true(coarse <= 2.5e-2 && fine * 1.6 <= coarse);
}

/* The field image against picvr's own converged Monte-Carlo image of a small cloud
   (a soft ball, albedo 0.9, optical depth ~3 through its centre, a sun and a sky,
   unlimited bounces, g = 0.5), over the pixels the medium covers, relative to their
   mean.  The Monte-Carlo noise is measured from two images of independent seeds and
   taken out.  Refining the grid and the directions together must lower the error at
   every step of the ladder. */
static void small_cloud(picvr_context *ctx, const tu_vol *vol) {
    tu_upload(ctx, vol);
    tf_ramp_g(ctx, 0.9f, 0.5f, 0.25f);
    tu_sun(ctx, 0.4, 1.0, 0.3, 1.0f, 1.0f, 1.0f, 3.0f, 0.5f);   /* a sun and a grey sky */
    set_bounces(ctx, PICVR_BOUNCES_UNLIMITED);
    tu_set_camera(ctx, 14, 6, 40, 0, 0, 0, 36, 48, 48);
}

void test_field_approaches_monte_carlo(void **state) {
    (void)state;
    tu_vol vol = tu_vol_ball(32);
    const uint32_t px = 48 * 48;
    float *mc[2];
    for (int k = 0; k < 2; k++) {
        picvr_context *ctx = tu_create(101 + 7 * k);
        small_cloud(ctx, &vol);
        TU_OK(picvr_step_iterations(ctx, tu_device_is_cpu() ? 1024 : 8192));
        mc[k] = tu_read(ctx, 48, 48);
        tu_finish(ctx);
    }
    picvr_context *bctx = field_context(2, 16, 0.0f, 0);
    small_cloud(bctx, &vol);
    tu_tf_const(bctx, 1, 1, 1, 0.0f, 1.0f);   /* the background alone */
    TU_OK(picvr_step(bctx, 1.0));
    float *bg = tu_read(bctx, 48, 48);
    tu_finish(bctx);
    /* the covered pixels, their mean and the reference's noise */
    double mean = 0.0, noise = 0.0;
    uint32_t covered = 0;
    int *use = calloc(px, sizeof *use);
    assert_non_null(use);
    for (uint32_t p = 0; p < px; p++) {
        double r = 0.5 * (mc[0][4 * p] + mc[1][4 * p]);
        if (fabs(r - bg[4 * p]) <= 1e-3 * bg[4 * p]) continue;
        use[p] = 1;
        covered++;
        for (int c = 0; c < 3; c++) {
            mean += 0.5 * (mc[0][4 * p + c] + mc[1][4 * p + c]);
            double d = mc[0][4 * p + c] - mc[1][4 * p + c];
            noise += 0.25 * d * d;   /* the mean of two: a quarter of the difference's variance */
        }
    }
    assert_true(covered > px / 8);
    mean /= 3.0 * covered;
    noise /= 3.0 * covered;
    const uint32_t ratio[3] = {8, 4, 2}, dirs[3] = {8, 16, 32};
    double last = INFINITY;
    for (int s = 0; s < 3; s++) {
        picvr_context *ctx = field_context(ratio[s], dirs[s], 1e-4f, 0);
        small_cloud(ctx, &vol);
        TU_OK(picvr_step(ctx, 1.0));
        float *img = tu_read(ctx, 48, 48);
        double se = 0.0;
        for (uint32_t p = 0; p < px; p++)
            if (use[p])
                for (int c = 0; c < 3; c++) {
                    double d = img[4 * p + c] - 0.5 * (mc[0][4 * p + c] + mc[1][4 * p + c]);
                    se += d * d;
                }
        se /= 3.0 * covered;
        double err = sqrt(fmax(se - noise, 0.0)) / mean;
        print_message("field vs Monte Carlo: grid ratio %u, D %u: relative RMSE %.4f (Monte Carlo's own %.4f)\n", ratio[s],
                      dirs[s], err, sqrt(noise) / mean);
        assert_true(err < last);
        last = err;
        free(img);
        tu_finish(ctx);
    }
    assert_true(last < 0.05);
    free(use);
    free(bg);
    free(mc[0]);
    free(mc[1]);
    tu_vol_free(&vol);
}

/* Deterministic: the seed changes nothing, and so does a second step. */
void test_field_deterministic(void **state) {
    (void)state;
    tu_vol vol = tu_vol_ball(24);
    float *img[3];
    for (int k = 0; k < 2; k++) {
        picvr_context *ctx = field_context(4, 16, 0.0f, k ? 12345u : 0u);
        small_cloud(ctx, &vol);
        TU_OK(picvr_step(ctx, 1.0));
        img[k] = tu_read(ctx, 48, 48);
        if (k == 1) {
            TU_OK(picvr_step(ctx, 1.0));
            img[2] = tu_read(ctx, 48, 48);
        }
        tu_finish(ctx);
    }
    assert_memory_equal(img[0], img[1], 48 * 48 * 16);
    assert_memory_equal(img[1], img[2], 48 * 48 * 16);
    for (int k = 0; k < 3; k++) free(img[k]);
    tu_vol_free(&vol);
}

/* Hostile configuration rows: each bad field of picvr_field_config gets its status and
   no context; picvr_read_field's misuse its status; a Monte-Carlo context holds nothing
   of the field. */
void test_field_config_errors(void **state) {
    (void)state;
    struct { const char *what; picvr_field_config f; picvr_cache_mode cache; picvr_status want; } rows[] = {
        {"grid ratio 9", {PICVR_RENDER_FIELD, 9, 0, 0, 0.0f, 0.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"directions 7", {PICVR_RENDER_FIELD, 0, 7, 0, 0.0f, 0.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"directions odd", {PICVR_RENDER_FIELD, 0, 33, 0, 0.0f, 0.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"directions 1026", {PICVR_RENDER_FIELD, 0, 1026, 0, 0.0f, 0.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"passes 1025", {PICVR_RENDER_FIELD, 0, 0, 1025, 0.0f, 0.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"tolerance 1", {PICVR_RENDER_FIELD, 0, 0, 0, 1.0f, 0.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"tolerance -1e-3", {PICVR_RENDER_FIELD, 0, 0, 0, -1e-3f, 0.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"tolerance NaN", {PICVR_RENDER_FIELD, 0, 0, 0, NAN, 0.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_NON_FINITE},
        {"step 0.1", {PICVR_RENDER_FIELD, 0, 0, 0, 0.0f, 0.1f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"step 65", {PICVR_RENDER_FIELD, 0, 0, 0, 0.0f, 65.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"step inf", {PICVR_RENDER_FIELD, 0, 0, 0, 0.0f, INFINITY}, PICVR_CACHE_DEFAULT, PICVR_ERROR_NON_FINITE},
        {"with the cache", {PICVR_RENDER_FIELD, 0, 0, 0, 0.0f, 0.0f}, PICVR_CACHE_OBJECT_SPACE, PICVR_ERROR_INVALID_ARGUMENT},
        {"field-mc with the cache", {PICVR_RENDER_FIELD_MC, 0, 0, 0, 0.0f, 0.0f}, PICVR_CACHE_AUTO,
         PICVR_ERROR_INVALID_ARGUMENT},
        {"mode 4", {(picvr_render_mode)4, 0, 0, 0, 0.0f, 0.0f}, PICVR_CACHE_DEFAULT, PICVR_ERROR_INVALID_ARGUMENT},
        {"prior 1025", {PICVR_RENDER_FIELD_MC, 0, 0, 0, 0.0f, 0.0f, 1025}, PICVR_CACHE_DEFAULT,
         PICVR_ERROR_INVALID_ARGUMENT},
    };
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        picvr_config cfg;
        memset(&cfg, 0, sizeof cfg);
        cfg.field = rows[i].f;
        cfg.cache.mode = rows[i].cache;
        picvr_context *ctx = (picvr_context *)1;
        picvr_status s = picvr_create(&cfg, &ctx);
        if (s != rows[i].want || ctx != NULL)
            fail_msg("%s: %s, expected %s", rows[i].what, picvr_status_string(s), picvr_status_string(rows[i].want));
    }
    /* the defaults resolved */
    picvr_context *ctx = field_context(0, 0, 0.0f, 0);
    picvr_config got;
    TU_OK(picvr_get_config(ctx, &got));
    assert_int_equal(got.field.mode, PICVR_RENDER_FIELD);
    assert_true(got.field.grid_ratio >= 1 && got.field.grid_ratio <= 8 && got.field.directions >= 8 &&
                got.field.tolerance > 0.0f && got.field.step_voxels > 0.0f);
    float one[16];
    uint32_t dims[3];
    assert_int_equal(picvr_read_field(ctx, one, sizeof one, dims), PICVR_ERROR_NOT_READY);   /* no step yet */
    tu_vol vol = tu_vol_ball(16);
    small_cloud(ctx, &vol);
    TU_OK(picvr_step(ctx, 1.0));
    assert_int_equal(picvr_read_field(NULL, one, sizeof one, dims), PICVR_ERROR_NULL_POINTER);
    assert_int_equal(picvr_read_field(ctx, NULL, sizeof one, dims), PICVR_ERROR_NULL_POINTER);
    assert_int_equal(picvr_read_field(ctx, one, sizeof one, dims), PICVR_ERROR_BUFFER_TOO_SMALL);
    picvr_stats st = tu_stats_finite(ctx);
    assert_true(st.field_builds == 1 && st.field_bytes > 0 && st.field_passes >= 1);
    tu_finish(ctx);
    /* leave out what a scene does not need: single scattering of the lights alone (no
       background light) runs no pass and holds no scattered field; a background brings
       them back */
    ctx = field_context(0, 0, 0.0f, 0);
    {
        tu_sun_scene sun;
        const double l_in[3] = {0.0, 1.0, 0.0};
        tu_sun_cube(ctx, 16, 0.1f, 0.8f, l_in, 3.0f, 0.0f, &sun);
        tu_set_camera(ctx, 20, 14, 26, 0, 0, 0, 40, 16, 16);
        TU_OK(picvr_step(ctx, 1.0));
        picvr_stats dark = tu_stats_finite(ctx);
        tu_sun(ctx, 0, 1, 0, 1, 1, 1, 3.0f, 0.5f);   /* the same sun and a grey background */
        TU_OK(picvr_step(ctx, 1.0));
        picvr_stats lit = tu_stats_finite(ctx);
        print_message("field leave-out: %u passes and %llu bytes without background light, %u and %llu with it\n",
                      dark.field_passes, (unsigned long long)dark.field_bytes, lit.field_passes,
                      (unsigned long long)lit.field_bytes);
        assert_true(dark.field_passes == 0 && lit.field_passes == 1 && dark.field_bytes < lit.field_bytes);
        float cells_dark[16 * 8];
        TU_OK(picvr_read_field(ctx, cells_dark, sizeof cells_dark, dims));
    }
    tu_finish(ctx);
    /* a Monte-Carlo context has no field */
    ctx = tu_create(0);
    small_cloud(ctx, &vol);
    TU_OK(picvr_step_iterations(ctx, 1));
    st = tu_stats_finite(ctx);
    assert_true(st.field_builds == 0 && st.field_bytes == 0);
    assert_int_equal(picvr_read_field(ctx, one, sizeof one, dims), PICVR_ERROR_NOT_READY);
    tu_finish(ctx);
    tu_vol_free(&vol);
}

/* The stiff sweep: optical depth per cell from 1e-6 to 1e5, everything clipped, the
   volume 1e6 from the origin: every image finite and non-negative, alpha in [0, 1],
   every stat finite.  Closed forms where they apply: single scattering of the cube
   (tu_sun_ray, as above: the model is exact there, 1e-4 of the peak, plus the part of a
   ray past T = 1e-3, taken as radiating its last step's light: at most 1e-3 of the
   peak; so 1.1e-3) at optical depths 1e-6 and 1 per cell; at 1e5 per cell the cube is a half-space lit from above,
   L = a E / (4 pi) / (1 + mu_v) on its top face (mu_v the view cosine), which the model
   keeps exactly too (the logarithm's slope extends the centres' light to the face, and
   a step integrates it as exponential), but in float: the centres' logarithms, near
   -5e4 and -1.5e5, are held to 0.004 and 0.016, so the face's carries ~0.01: within
   1e-2 on the top face's pixels away from its edges.  With multiple scattering, at most 1 / (1 - a) times the single's bound
   a E / (4 pi). */
void test_field_stiff_sweep(void **state) {
    (void)state;
    const double taus[3] = {1e-6, 1.0, 1e5};   /* per cell (2 voxels) */
    for (int i = 0; i < 3; i++)
        for (int unlimited = 0; unlimited < 2; unlimited++) {
            picvr_context *ctx = field_context(2, 16, 0.0f, 0);
            tu_sun_scene s;
            const double l_in[3] = {0.0, 1.0, 0.0};
            tu_sun_cube(ctx, 16, (float)(taus[i] / 2.0), 0.8f, l_in, 3.0f, 0.0f, &s);
            if (unlimited) set_bounces(ctx, PICVR_BOUNCES_UNLIMITED);
            tu_cam cam = tu_set_camera(ctx, 20, 14, 26, 0, 0, 0, 40, 32, 32);
            TU_OK(picvr_step(ctx, 1.0));
            float *img = tu_read(ctx, 32, 32);
            tu_assert_image_valid(img, 32, 32, "field stiff sweep");
            picvr_stats st = tu_stats_finite(ctx);
            double *want = tu_expected_image(&cam, 1, tu_sun_ray, &s);
            double top = 0.0, worst = 0.0, most = 0.0;
            for (size_t p = 0; p < 32 * 32; p++) top = fmax(top, want[4 * p]);
            for (size_t p = 0; p < 32 * 32; p++) {
                most = fmax(most, img[4 * p]);
                worst = fmax(worst, fabs(img[4 * p] - want[4 * p]) / fmax(top, 1e-30));
            }
            print_message("field stiff sweep, tau %g per cell, %s: %u passes, largest %.3g, error %.2e of the peak\n",
                          taus[i], unlimited ? "unlimited" : "single", st.field_passes, most, worst);
            if (!unlimited && taus[i] < 1e3) assert_true(worst <= 1.1e-3);
            if (!unlimited && taus[i] > 1e3) {   /* the half-space's top face */
                double worst_top = 0.0;
                int seen = 0;
                for (uint32_t y = 0; y < 32; y++)
                    for (uint32_t x = 0; x < 32; x++) {
                        double dir[3], t0, t1, e[3];
                        tu_cam_dir(&cam, x + 0.5, y + 0.5, dir);
                        if (!tu_ray_box(cam.pos, dir, s.bmin, s.bmax, &t0, &t1)) continue;
                        for (int q = 0; q < 3; q++) e[q] = cam.pos[q] + dir[q] * t0;
                        if (fabs(e[1] - s.bmax[1]) > 1e-6 || fabs(e[0]) > 7.0 || fabs(e[2]) > 7.0) continue;
                        double expect = 0.8 * 3.0 / (4.0 * M_PI) / (1.0 - dir[1]);
                        worst_top = fmax(worst_top, fabs(img[4 * (y * 32 + x)] / expect - 1.0));
                        seen++;
                    }
                print_message("field stiff sweep, half-space top face: %d pixels, largest relative error %.2e (bound 1e-2)\n",
                              seen, worst_top);
                assert_true(seen > 20 && worst_top <= 1e-2);
            }
            /* any multiple scattering of albedo 0.8 at most 1 / (1 - 0.8) times the single's bound */
            assert_true(most <= (unlimited ? 5.0 : 1.0) * 0.8 * 3.0 / (4.0 * M_PI) * 1.0001);
            free(want);
            free(img);
            tu_finish(ctx);
        }
    /* everything clipped: the background, exactly */
    picvr_context *ctx = field_context(2, 16, 0.0f, 0);
    tu_vol vol = tu_vol_ball(16);
    tu_upload(ctx, &vol);
    tf_ramp_g(ctx, 0.9f, 0.3f, 5.0f);
    tu_background_only(ctx, 0.25f, 0.5f, 0.75f, 2.0f);
    picvr_clip clip;
    memset(&clip, 0, sizeof clip);
    clip.plane_count = 1;
    clip.planes[0][0] = 1.0f;
    clip.planes[0][3] = -100.0f;   /* keeps x >= 100: nothing of the box */
    TU_OK(picvr_set_clip(ctx, &clip));
    tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 16, 16);
    TU_OK(picvr_step(ctx, 1.0));
    float *img = tu_read(ctx, 16, 16);
    for (size_t p = 0; p < 16 * 16; p++)
        assert_true(img[4 * p] == 0.5f && img[4 * p + 1] == 1.0f && img[4 * p + 2] == 1.5f && img[4 * p + 3] == 0.0f);
    free(img);
    tu_finish(ctx);
    /* the volume 1e6 from the origin, the camera and a point light beside it */
    ctx = field_context(2, 16, 0.0f, 0);
    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    memcpy(d.dims, vol.dims, sizeof d.dims);
    memcpy(d.spacing, vol.spacing, sizeof d.spacing);
    d.type = PICVR_VOXEL_UINT8;
    d.data = vol.v;
    d.has_origin = 1;
    d.origin[0] = 1e6f;
    d.origin[1] = -2e6f;
    d.origin[2] = 5e5f;
    TU_OK(picvr_upload_volume(ctx, &d));
    tf_ramp_g(ctx, 0.9f, 0.6f, 0.5f);
    picvr_light l;
    memset(&l, 0, sizeof l);
    l.type = PICVR_LIGHT_POINT;
    l.position[0] = 1e6f + 8.0f;
    l.position[1] = -2e6f + 40.0f;
    l.position[2] = 5e5f + 8.0f;
    l.color[0] = l.color[1] = l.color[2] = 1.0f;
    l.intensity = 1e4f;
    picvr_background bg = {{1, 1, 1}, 0.1f};
    TU_OK(picvr_set_lights(ctx, &l, 1, &bg));
    set_bounces(ctx, PICVR_BOUNCES_UNLIMITED);
    tu_set_camera(ctx, 1e6 + 8, -2e6 + 8, 5e5 + 60, 1e6 + 8, -2e6 + 8, 5e5 + 8, 40, 32, 32);
    TU_OK(picvr_step(ctx, 1.0));
    img = tu_read(ctx, 32, 32);
    tu_assert_image_valid(img, 32, 32, "field, volume 1e6 away");
    double sum = 0.0;
    for (size_t p = 0; p < 32 * 32; p++) sum += img[4 * p];
    assert_true(sum > 32 * 32 * 0.1 * 0.5);   /* lit, not black */
    tu_stats_finite(ctx);
    free(img);
    tu_finish(ctx);
    tu_vol_free(&vol);
}

/* From instant to exact (PICVR_RENDER_FIELD_MC): the step after a change shows the
   field's image, bit for bit the image PICVR_RENDER_FIELD makes; the steps after it add
   Monte-Carlo samples to it, the field counting as prior = 8 samples per pixel, so the
   first pass changes a pixel by at most a ninth of one sample's difference from the
   field (no jump: checked to 1e-3 of it, float rounding) and the image converges to
   Monte Carlo's: after n passes the field's share is 8 / (8 + n).  Checked against two
   Monte-Carlo images of other seeds (their noise removed, as above): after 256 passes
   the error is that of Monte Carlo with 256 samples (their noise, the field's 3 % share
   of its own error adds nothing visible): within 1.2 times the estimate made from the
   two images' spread, whose own relative spread over ~3000 values is a few per cent.
   A camera move shows the field again. */
void test_field_hands_over_to_monte_carlo(void **state) {
    (void)state;
    tu_vol vol = tu_vol_ball(24);
    const uint32_t px = 48 * 48, n = 256;
    float *mc[2];
    for (int k = 0; k < 2; k++) {
        picvr_context *ctx = tu_create(301 + k);
        small_cloud(ctx, &vol);
        TU_OK(picvr_step_iterations(ctx, 1024));
        mc[k] = tu_read(ctx, 48, 48);
        tu_finish(ctx);
    }
    picvr_context *fctx = field_context(0, 0, 0.0f, 0);
    small_cloud(fctx, &vol);
    TU_OK(picvr_step(fctx, 1.0));
    float *field = tu_read(fctx, 48, 48);
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = 7;
    cfg.field.mode = PICVR_RENDER_FIELD_MC;
    picvr_context *ctx = tu_create_config(&cfg);
    small_cloud(ctx, &vol);
    TU_OK(picvr_step(ctx, 1.0));   /* the field */
    float *first = tu_read(ctx, 48, 48);
    assert_memory_equal(first, field, px * 16);
    TU_OK(picvr_step_iterations(ctx, 1));   /* one pass of Monte Carlo from it */
    float *one = tu_read(ctx, 48, 48);
    picvr_stats st = tu_stats_finite(ctx);
    assert_true(st.iterations_min == 9);   /* the prior's 8 and one sample */
    TU_OK(picvr_step_iterations(ctx, n - 1));
    float *img = tu_read(ctx, 48, 48);
    double mean = 0.0, noise = 0.0, e_field = 0.0, e_img = 0.0, jump = 0.0, sample_dev = 0.0;
    uint32_t covered = 0;
    for (uint32_t p = 0; p < px; p++)
        for (int c = 0; c < 3; c++) {
            size_t i = 4 * (size_t)p + c;
            double ref = 0.5 * (mc[0][i] + mc[1][i]), d = mc[0][i] - mc[1][i];
            if (ref <= 0.0) continue;
            covered++;
            mean += ref;
            noise += 0.25 * d * d;
            e_field += (field[i] - ref) * (field[i] - ref);
            e_img += (img[i] - ref) * (img[i] - ref);
            jump += fabs(one[i] - field[i]);
            sample_dev += fabs(9.0 * one[i] - 8.0 * field[i] - field[i]);   /* |x - field|: the sample's own */
        }
    assert_true(covered > 0);
    mean /= covered;
    double ef = sqrt(fmax(e_field / covered - noise / covered, 0.0)) / mean;
    double ei = sqrt(fmax(e_img / covered - noise / covered, 0.0)) / mean;
    double mc_own = sqrt(4.0 * noise / covered * 1024.0 / n / 2.0) / mean;   /* one image of n samples */
    print_message("field to Monte Carlo: the field %.4f, after %u passes %.4f (Monte Carlo's own at %u samples %.4f); "
                  "first pass moved the image %.3g, a ninth of its sample's %.3g\n", ef, n, ei, n, mc_own,
                  jump / covered, sample_dev / covered);
    assert_true(ei <= 1.2 * mc_own);
    assert_true(fabs(jump - sample_dev / 9.0) <= 1e-3 * sample_dev + 1e-6);
    /* a camera move: the field again, for the new view */
    tu_set_camera(ctx, -10, 4, 40, 0, 0, 0, 36, 48, 48);
    tu_set_camera(fctx, -10, 4, 40, 0, 0, 0, 36, 48, 48);
    TU_OK(picvr_step(ctx, 1.0));
    TU_OK(picvr_step(fctx, 1.0));
    float *a = tu_read(ctx, 48, 48), *b = tu_read(fctx, 48, 48);
    assert_memory_equal(a, b, px * 16);
    free(a);
    free(b);
    free(first);
    free(one);
    free(img);
    free(field);
    free(mc[0]);
    free(mc[1]);
    tu_finish(ctx);
    tu_finish(fctx);
    tu_vol_free(&vol);
}
