/* test_robust_sweep.c - issue 6: stiff and extreme input across the whole pipeline.
 *
 * Every case renders, reads the image back with picvr_read_rgba32f and asserts:
 *   - every float finite, radiance >= 0, alpha in [0, 1];
 *   - every floating stat finite (tu_stats_finite), iterations as requested;
 *   - bounded time: the case (render + read + stats) ends within CASE_MAX_S seconds
 *     (a generous bound for a 2-core machine shared with other jobs; a runaway tracking
 *     loop on lavapipe takes minutes);
 *   - agreement with a closed form computed here in double precision, where one exists
 *     (most cases; the ones without are marked "finite only").
 * Statistics: tu_check_mean (test_util.h): |measured - expected| <= 5 SE + sys_rel *
 * |expected|, SE from the Bhatia-Davis bound of samples in [0, M] (or the empirical
 * block spread).  sys_rel is stated per case: 1e-4 covers the quadratures and float32
 * ray set-up in ordinary media; larger values are explained where they appear.
 *
 * Closed forms used (CONVENTIONS of picvr.h; single scattering, isotropic phase):
 *   Beer-Lambert (albedo 0, background 1): a sample is 1 with probability
 *     T = exp(-optical depth) and 0 otherwise (alpha is the complement), M = 1.
 *   Sun over a homogeneous box (tu_sun_ray): L = albedo E int sigma e^{-sigma (t-t0)}
 *     e^{-sigma s(t)} dt / (4 pi), samples in [0, albedo E / (4 pi)].
 *   Optically thick half-space seen through face n (outward), view cosine mu_v =
 *     -d.n, sun cosine mu_s = l.n: L = albedo E / (4 pi) mu_s / (mu_s + mu_v)
 *     (integrate sigma e^{-sigma t (1 + mu_v / mu_s)} dt); exact for sigma -> inf away
 *     from the face's edges (band ~ 1/sigma).
 */
#include "test_util.h"

#include <float.h>
#include <time.h>

#define CASE_MAX_S 60.0

static double now_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Renders n iterations, reads, checks finiteness/ranges/stats/time; returns the image. */
/* Renders n passes, by picvr_step_iterations or, timed, by picvr_step until every pixel
   has n samples and a second has passed (PICVR_DISTANCE_AUTO measures in timed rounds
   only, and chooses after its first few). */
static float *sweep_render_ex(picvr_context *ctx, uint32_t w, uint32_t h, uint32_t n, const char *what, int timed) {
    double t0 = now_s();
    picvr_stats st;
    if (timed) {
        do {
            TU_OK(picvr_step(ctx, 100.0));
            st = tu_stats_finite(ctx);
        } while ((st.iterations_min < n || st.elapsed_ms < 1000.0) && now_s() - t0 < CASE_MAX_S);
    } else {
        TU_OK(picvr_step_iterations(ctx, n));
    }
    float *img = tu_read(ctx, w, h);
    st = tu_stats_finite(ctx);
    double dt = now_s() - t0;
    tu_assert_image_valid(img, w, h, what);
    if (timed ? st.iterations_min < n : st.iterations != n)
        fail_msg("%s: %u iterations, expected %u", what, timed ? st.iterations_min : st.iterations, n);
    if (st.width != w || st.height != h) fail_msg("%s: stats size %ux%u", what, st.width, st.height);
    if (dt > CASE_MAX_S) fail_msg("%s: took %.1f s (bound %.0f s)", what, dt, CASE_MAX_S);
    print_message("    %-52s %6.2f s  mean L %-10.4g trunc %llu%s\n", what, dt, st.mean_luminance,
                  (unsigned long long)st.truncated_paths,
                  st.cache_entries ? " (cache)" : "");
    if (!isfinite(st.forced_share) || !isfinite(st.forced_efficiency) || st.forced_share < 0.0 ||
        st.forced_share > 1.0 || st.forced_efficiency < 0.0)
        fail_msg("%s: forced share %g, efficiency %g", what, st.forced_share, st.forced_efficiency);
    return img;
}

static float *sweep_render(picvr_context *ctx, uint32_t w, uint32_t h, uint32_t n, const char *what) {
    return sweep_render_ex(ctx, w, h, n, what, 0);
}

/* Checks RGB (bound M[c]) and alpha (bound 1) image means against expv. */
static int check_all(const char *what, const float *img, const double *expv, uint32_t w, uint32_t h,
                     uint32_t n, const double M[3], double sys_rel) {
    int ok = 1;
    char label[160];
    const char *cn[4] = {"R", "G", "B", "alpha"};
    for (int c = 0; c < 4; c++) {
        snprintf(label, sizeof label, "%s: %s", what, cn[c]);
        ok &= tu_check_mean(label, img, expv, w, c, 0, 0, w, h, n, c < 3 ? M[c] : 1.0, 5.0, sys_rel);
    }
    return ok;
}

static picvr_context *create_cache(uint32_t seed, picvr_cache_mode mode) {
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = seed;
    cfg.cache.mode = mode;
    return tu_create_config(&cfg);
}

static const char *mode_name(picvr_cache_mode m) {
    return m == PICVR_CACHE_OBJECT_SPACE ? "cache object" : m == PICVR_CACHE_SCREEN_SPACE ? "cache screen"
         : m == PICVR_CACHE_AUTO ? "cache auto" : "no cache";
}

/* ---- closed forms ------------------------------------------------------------------------ */


/* Optically thick half-space (see the top): the face the ray enters through. */
typedef struct thick {
    double bmin[3], bmax[3], l[3], albedo, E;
} thick;

static void thick_ray(const double o[3], const double d[3], void *user, double out[4]) {
    const thick *s = user;
    double t0, t1;
    out[0] = out[1] = out[2] = out[3] = 0;
    if (!tu_ray_box(o, d, s->bmin, s->bmax, &t0, &t1)) return;
    int axis = 0;
    double best = -INFINITY;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0) continue;
        double tn = ((d[a] > 0 ? s->bmin[a] : s->bmax[a]) - o[a]) / d[a];
        if (tn > best) { best = tn; axis = a; }
    }
    double mu_v = fabs(d[axis]), mu_s = (d[axis] > 0 ? -1 : 1) * s->l[axis];
    double L = mu_s > 0 ? s->albedo * s->E / (4 * M_PI) * mu_s / (mu_s + mu_v) : 0;
    out[0] = out[1] = out[2] = L;
    out[3] = 1;
}

/* ---- optical thickness ------------------------------------------------------------------- */

/* Beer-Lambert through an 8^3 cube with optical thickness tau per voxel from 1e-6 to 1e5
   (T along the axis from 1 - 8e-6 down to e^-800000 = 0).  Camera at z 14, fov 30: every
   ray enters the +z face.  sys_rel 1e-4 (quadrature, float32 D); at tau >= 10 T is 0 to
   double precision except for the grazing corner rays, and the check is then |mean| <=
   5 SE of a mean that is 0. */
void test_sweep_optical_thickness_beer_lambert(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(61);
    tu_vol vol = tu_vol_new(8, 8, 8, 1.0f, 255);
    tu_upload(ctx, &vol);
    tu_homog hm;
    tu_vol_box(&vol, hm.bmin, hm.bmax);
    tu_background_only(ctx, 1, 1, 1, 1);
    const uint32_t W = 24, H = 24, N = 64;
    tu_cam cam = tu_set_camera(ctx, 0.5, 0.3, 14, 0, 0, 0, 30, W, H);
    const float tau[] = {1e-6f, 1e-4f, 1e-2f, 1.0f, 10.0f, 1e3f, 1e5f};
    int ok = 1;
    for (size_t i = 0; i < sizeof tau / sizeof tau[0]; i++) {
        tu_tf_const(ctx, 0, 0, 0, 1.0f, tau[i]);
        hm.sigma = tau[i];
        char what[96];
        snprintf(what, sizeof what, "beer-lambert tau/voxel %g", (double)tau[i]);
        float *img = sweep_render(ctx, W, H, N, what);
        double *expv = tu_expected_image(&cam, 4, tu_homog_ray, &hm);
        const double M[3] = {1, 1, 1};
        ok &= check_all(what, img, expv, W, H, N, M, 1e-4);
        free(expv);
        free(img);
    }
    tu_vol_free(&vol);
    if (!ok) fail_msg("a transmittance differs from exp(-optical depth) (listed above)");
    tu_finish(ctx);
}

/* Single scattering under a delta sun from optically thin to optically thick, with the
   cache off and on.  tau <= 10 per voxel: tu_sun_ray (64-piece Gauss-Legendre, exact to
   1e-8 here).  tau >= 1e3: the thick half-space form (every ray enters the +z face, at
   least 1.3 voxels from its edges, i.e. > 1e3 mean free paths).  tau 1e-6: the image is
   ~1e-6 of the thick one: the medium is almost invisible.
   Tolerances: sys_rel 1e-4 for tau <= 10; 2 % for tau >= 1e3, where the mean free path
   (1e-3..1e-5 voxels) approaches the float32 resolution of positions near the face
   (ulp(4) = 4.8e-7): the depth of a scatter point and its shadow-ray length carry a
   relative rounding error up to ~5 % at tau 1e5, which averages out to well below 2 %
   for a smooth exponential.  With the cache on: 3 % at tau 1e-6 (test_cache measured
   <= 0.7 % bias for this scene at tau 0.15; Eq. 10's epsilon = 0.1 bounds one entry's
   extrapolation error, and the update procedure shrinks disagreeing entries); from tau
   0.5 up an explicit bound on the bias of the mean, explained below. */
static void sun_thickness_sweep(picvr_cache_mode mode, const float *tau, size_t ntau, uint32_t N) {
    picvr_context *ctx = mode == PICVR_CACHE_NONE ? tu_create(62) : create_cache(62, mode);
    const uint32_t W = 24, H = 24;
    const double l[3] = {0.3, 0.5, 1.0};
    const float albedo = 0.9f, E = 4.0f;
    int ok = 1;
    for (size_t i = 0; i < ntau; i++) {
        tu_sun_scene s;
        tu_sun_cube(ctx, 8, tau[i], albedo, l, E, 0.0f, &s);
        tu_cam cam = tu_set_camera(ctx, 0.4, -0.2, 14, 0, 0, 0, 30, W, H);
        char what[96];
        snprintf(what, sizeof what, "sun, tau/voxel %g, %s", (double)tau[i], mode_name(mode));
        float *img = sweep_render(ctx, W, H, N, what);
        double *expv;
        double sys;
        if (tau[i] <= 10) {
            expv = tu_expected_image(&cam, 4, tu_sun_ray, &s);
            sys = 1e-4;
        } else {
            thick th;
            memcpy(th.bmin, s.bmin, sizeof th.bmin);
            memcpy(th.bmax, s.bmax, sizeof th.bmax);
            memcpy(th.l, s.l, sizeof th.l);
            th.albedo = albedo;
            th.E = E;
            expv = tu_expected_image(&cam, 2, thick_ray, &th);
            sys = 0.02;
        }
        if (mode != PICVR_CACHE_NONE) sys = 0.03;
        double Mc = albedo * E / (4 * M_PI);
        const double M[3] = {Mc, Mc, Mc};
        if (mode != PICVR_CACHE_NONE && tau[i] >= 0.5f) {
            /* From tau 0.5 per voxel (optical depth 4 across the cube) up, a few dozen
               entries of radii up to 16 voxels cover the cube, placed where scheduling
               put them, so a run's bias varies more than its noise.  In dense media
               (tau >= 10) every scatter event lies within a few mean free paths of the
               lit face.  What keeps the cache honest there: an
               entry's offset is at most two mean free paths (entry_delta,
               cache_math.glsl), so Eq. 6 sees the field's own rate at any density; its
               largest radius scales with that offset (entry_r_max), so a flat-looking
               axis is not extrapolated over millions of mean free paths into faces lit
               from another direction; and the medium model (sigma_t_in_box) treats an
               offset point beyond the face, where E stops growing.  These cases use the
               cache little (tens of entries, hit rate about 0.2 at tau 10, none from
               tau 100), and the entries' placement depends on scheduling, so a run's
               bias varies more than its noise (docs/cache.md, "Dense media").
               The bound: outside the model's reach Eq. 10's epsilon bounds nothing, but
               the lit face is the worst a served lookup does here, and
               test_cache_full_dense_lit_face asserts an error per served lookup within 3 %
               there (the debug view's own measure); events the cache does not serve are
               unbiased, so the mean's bias is at most 3 % x the hit rate <= 3 %, plus the
               2 % of float32 positions in the thick closed form (above): 5 %, plus 5 SE of
               the image's noise (8x8 blocks, Student's t for their 8 degrees of freedom).
               Asserted: finite (above), the physical bound of single scattering under
               one sun, mean <= albedo E / (4 pi), and that bound. */
            double m = tu_region_mean(img, W, 1, 0, 0, W, H);
            double e = 0;
            for (size_t p = 0; p < (size_t)W * H; p++) e += expv[4 * p + 1];
            e /= (double)W * H;
            double se = tu_mean_se(img, expv, W, 1, 0, 0, W, H, N, 0.0);
            double bound = 0.05 * e + tu_student_quantile(tu_normal_cdf(5.0), 8) * se;
            print_message("    %s: mean %.4g, closed form %.4g (bias %+.2f %%, SE %.2f %%), bound 5 %% + 5 SE "
                          "= %.2f %%\n", what, m, e, 100 * (m / e - 1), 100 * se / e, 100 * bound / e);
            tu_power_note_rel(m, e, bound, 0.07);
            if (!(m <= Mc)) fail_msg("%s: mean %g above albedo E / (4 pi) = %g", what, m, Mc);
            if (!(fabs(m - e) <= bound)) fail_msg("%s: bias %+.1f %% beyond the bound", what, 100 * (m / e - 1));
            /* alpha is the camera ray's opacity, which the cache does not touch: the
               plain tolerances (1e-4, 2 % for the thick closed form) */
            char label[128];
            snprintf(label, sizeof label, "%s: alpha", what);
            ok &= tu_check_mean(label, img, expv, W, 3, 0, 0, W, H, N, 1.0, 5.0, tau[i] > 10 ? 0.02 : 1e-4);
        } else {
            ok &= check_all(what, img, expv, W, H, N, M, sys);
        }
        free(expv);
        free(img);
        if (mode != PICVR_CACHE_NONE) {
            /* the cache was used (entries exist where the medium scatters), and its debug
               view (entry centres, hit/miss fractions) is finite too */
            picvr_stats st = tu_stats_finite(ctx);
            if (tau[i] >= 0.5 && st.cache_entries == 0) fail_msg("%s: the cache made no entries", what);
            TU_OK(picvr_set_view(ctx, PICVR_VIEW_CACHE));
            TU_OK(picvr_step_iterations(ctx, 2));
            float *dbg = tu_read(ctx, W, H);
            tu_assert_finite(dbg, (size_t)W * H * 4, "cache debug view");
            free(dbg);
            TU_OK(picvr_set_view(ctx, PICVR_VIEW_IMAGE));
            print_message("    %s: %u entries, hit rate %.2f, debug view finite\n", what, st.cache_entries,
                          st.cache_hit_rate);
        }
    }
    if (!ok) fail_msg("%s: single scattering differs from the closed form (listed above)", mode_name(mode));
    tu_finish(ctx);
}

void test_sweep_optical_thickness_sun(void **state) {
    (void)state;
    const float tau[] = {1e-6f, 1e-2f, 1.0f, 10.0f, 1e3f, 1e4f, 1e5f};
    sun_thickness_sweep(PICVR_CACHE_NONE, tau, sizeof tau / sizeof tau[0], 64);
}

void test_sweep_optical_thickness_sun_cache(void **state) {
    (void)state;
    const float tau[] = {1e-6f, 0.5f, 10.0f, 100.0f, 1e3f, 1e4f, 1e5f};
    sun_thickness_sweep(PICVR_CACHE_OBJECT_SPACE, tau, sizeof tau / sizeof tau[0], 48);
    sun_thickness_sweep(PICVR_CACHE_SCREEN_SPACE, tau, sizeof tau / sizeof tau[0], 48);
    sun_thickness_sweep(PICVR_CACHE_AUTO, tau, sizeof tau / sizeof tau[0], 48);   /* the blend's routing */
}

/* ---- transfer functions ------------------------------------------------------------------ */

/* A hard surface: an x ramp volume (voxel value 8 i of 255, i = 0..31) and a TF that steps
   from opacity 0 to 1 between two adjacent control points at the same value v0 = 100/255
   (albedo 0, background 1).  sigma_t = D where the trilinear value >= v0, i.e. for voxel
   coordinate p_x >= p* = 0.5 + v0 * 255 / 8 = 13 (the ramp is linear between the
   centres), else 0.  Closed form: T = exp(-D * length of the ray inside the part of the
   box with x >= x*).  The expected image uses 16 x 16 jitter sub-samples per pixel (the
   step crosses pixels: the midpoint rule is off by <= 1/32 pixel column per row).
   Known, measured offsets of the surface (moving it toward smaller x):
   - the TF is tabulated in 4096 entries with linear interpolation: the step is smeared
     over 1/4095 in value = 0.008 voxels here;
   - uint8 volumes are filtered by lavapipe with 8-bit results (the filtered value is
     rounded to a multiple of 1/255): the surface moves by up to half a data unit over
     the slope (8 per voxel) = 1/16 voxel.  Measured with a 512-pixel scan across the
     step: -0.0645 voxels for uint8, -0.0078 for uint16 (this test's uint16 copy of the
     ramp, 8 i * 257, is exact in 16 bits).
   In the image (0.63 world units per pixel at the surface, 48 columns) a shift s of the
   surface changes the mean transmittance by about s / 0.63 / 48 times the contrast:
   sys_rel 0.3 % for uint16 (s 0.008 plus the quadrature), 1.5 % for uint8 (s 0.07).
   D = 1 and D = 1e3 (the dense side is a solid black block, 8 voxels = 8000 mean free
   paths deep). */
typedef struct step_scene {
    double bmin[3], bmax[3], xs, D;
} step_scene;

static void step_ray(const double o[3], const double d[3], void *user, double out[4]) {
    const step_scene *s = user;
    double lo[3] = {s->xs, s->bmin[1], s->bmin[2]}, t0, t1, T = 1;
    if (tu_ray_box(o, d, lo, s->bmax, &t0, &t1)) T = exp(-s->D * (t1 - t0));
    out[0] = out[1] = out[2] = T;
    out[3] = 1 - T;
}

void test_sweep_transfer_function_step_zero_and_max(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(63);
    tu_vol vol = tu_vol_new(32, 8, 8, 1.0f, 0);
    static uint16_t u16[32 * 8 * 8];
    for (uint32_t z = 0; z < 8; z++)
        for (uint32_t y = 0; y < 8; y++)
            for (uint32_t x = 0; x < 32; x++) {
                *tu_vox(&vol, x, y, z) = (uint8_t)(8 * x);
                u16[x + 32 * (y + 8 * z)] = (uint16_t)(8 * x * 257);
            }
    tu_background_only(ctx, 1, 1, 1, 1);
    const uint32_t W = 48, H = 16, N = 64;
    step_scene s;
    tu_vol_box(&vol, s.bmin, s.bmax);
    const double v0 = 100.0 / 255.0; /* between voxels 12 and 13: p* = 13 */
    s.xs = s.bmin[0] + 0.5 + v0 * 255.0 / 8.0;
    const float Ds[2] = {1.0f, 1e3f};
    int ok = 1;
    const double M[3] = {1, 1, 1};
    for (int type = 0; type < 2; type++) {
        if (type == 0) {
            picvr_volume_desc d;
            memset(&d, 0, sizeof d);
            d.dims[0] = 32; d.dims[1] = 8; d.dims[2] = 8;
            d.type = PICVR_VOXEL_UINT16;
            d.data = u16;
            TU_OK(picvr_upload_volume(ctx, &d));
        } else {
            tu_upload(ctx, &vol);
        }
        tu_cam cam = tu_set_camera(ctx, 0, 0, 40, 0, 0, 0, 16, W, H);
        for (int k = 0; k < 2; k++) {
            picvr_tf_point tf[2] = {{(float)v0, {0, 0, 0}, 0.0f}, {(float)v0, {0, 0, 0}, 1.0f}};
            TU_OK(picvr_set_transfer_function(ctx, tf, 2, Ds[k]));
            s.D = Ds[k];
            char what[96];
            snprintf(what, sizeof what, "TF step 0 -> 1 at one value, %s, D %g", type ? "uint8" : "uint16",
                     (double)Ds[k]);
            float *img = sweep_render(ctx, W, H, N, what);
            double *expv = tu_expected_image(&cam, 16, step_ray, &s);
            ok &= check_all(what, img, expv, W, H, N, M, type ? 0.015 : 0.003);
            /* the left third (x < x*) must be exactly the background: sigma_t = 0 there */
            for (uint32_t y = 0; y < H; y++)
                for (uint32_t x = 0; x < W / 3; x++)
                    if (img[4 * (y * W + x)] != 1.0f || img[4 * (y * W + x) + 3] != 0.0f)
                        fail_msg("%s: pixel (%u,%u) = %g alpha %g in front of the transparent side", what, x,
                                 y, (double)img[4 * (y * W + x)], (double)img[4 * (y * W + x) + 3]);
            free(expv);
            free(img);
        }
    }
    tu_cam cam = tu_set_camera(ctx, 0, 0, 40, 0, 0, 0, 16, W, H);

    /* All-zero TF (opacity 0 at every value, any D): exactly the background. */
    picvr_tf_point zero[2] = {{0.0f, {1, 1, 1}, 0.0f}, {1.0f, {1, 1, 1}, 0.0f}};
    TU_OK(picvr_set_transfer_function(ctx, zero, 2, 1e5f));
    tu_sun(ctx, 1, 1, 1, 1, 1, 1, 1e3f, 0.7f);
    float *img = sweep_render(ctx, W, H, 8, "all-zero TF, D 1e5, sun + background 0.7");
    for (size_t p = 0; p < (size_t)W * H; p++)
        if (img[4 * p] != 0.7f || img[4 * p + 1] != 0.7f || img[4 * p + 2] != 0.7f || img[4 * p + 3] != 0)
            fail_msg("all-zero TF: pixel %zu = (%g %g %g %g), expected exactly the background", p,
                     (double)img[4 * p], (double)img[4 * p + 1], (double)img[4 * p + 2], (double)img[4 * p + 3]);
    free(img);

    /* All-max TF (opacity 1 at every value, value-independent): a homogeneous block even
       where the data is 0: Beer-Lambert through the whole box. */
    picvr_tf_point full[1] = {{0.5f, {0, 0, 0}, 1.0f}};
    TU_OK(picvr_set_transfer_function(ctx, full, 1, 0.05f));
    tu_background_only(ctx, 1, 1, 1, 1);
    tu_homog hm;
    memcpy(hm.bmin, s.bmin, sizeof hm.bmin);
    memcpy(hm.bmax, s.bmax, sizeof hm.bmax);
    hm.sigma = (double)0.05f;
    img = sweep_render(ctx, W, H, N, "all-max TF (one point, opacity 1), D 0.05");
    double *expv = tu_expected_image(&cam, 4, tu_homog_ray, &hm);
    ok &= check_all("all-max TF", img, expv, W, H, N, M, 1e-4);
    free(expv);
    free(img);
    tu_vol_free(&vol);
    if (!ok) fail_msg("a TF case differs from its closed form (listed above)");
    tu_finish(ctx);
}

/* ---- lights ----------------------------------------------------------------------------- */

/* Sun intensities 1e-8 .. 1e8 on a tau = 0.15/voxel cube: the closed form scales
   linearly; sys_rel 1e-4 (quadrature; float32 keeps 1e8 * albedo / 4 pi exactly
   enough).  With the cache (object space) at 1e-8 and 1e8: 3 % as above, on 32x32
   pixels (16 blocks: the entries' noise is shared by neighbouring pixels, so only the
   blocks' spread measures it).  Without the cache 16x16 pixels and 256 samples: the
   analytic SE is 0.4 % of the mean.  Power claimed: 5 % (the sweep's resolution). */
void test_sweep_light_intensity(void **state) {
    (void)state;
    tu_power_claim(0.05);
    const float I[] = {1e-8f, 1e-4f, 1.0f, 1e4f, 1e8f};
    for (int pass = 0; pass < 2; pass++) {
        picvr_cache_mode mode = pass ? PICVR_CACHE_OBJECT_SPACE : PICVR_CACHE_NONE;
        picvr_context *ctx = pass ? create_cache(64, mode) : tu_create(64);
        int ok = 1;
        for (size_t i = 0; i < sizeof I / sizeof I[0]; i++) {
            if (pass && i != 0 && i != 4) continue;
            tu_sun_scene s;
            const double l[3] = {0.6, 0.45, 0.66};
            tu_sun_cube(ctx, 8, 0.15f, 0.8f, l, I[i], 0.0f, &s);
            const uint32_t W = pass ? 32 : 16, H = W, N = pass ? 64 : 256;
            tu_cam cam = tu_set_camera(ctx, 0, 0, 14, 0, 0, 0, 30, W, H);
            char what[96];
            snprintf(what, sizeof what, "sun intensity %g, %s", (double)I[i], mode_name(mode));
            float *img = sweep_render(ctx, W, H, N, what);
            double *expv = tu_expected_image(&cam, 4, tu_sun_ray, &s);
            double Mc = 0.8 * (double)I[i] / (4 * M_PI);
            const double M[3] = {Mc, Mc, Mc};
            ok &= check_all(what, img, expv, W, H, N, M, pass ? 0.03 : 1e-4);
            free(expv);
            free(img);
        }
        if (!ok) fail_msg("%s: a light intensity differs from the closed form", mode_name(mode));
        tu_finish(ctx);
    }
}

/* A point light inside a homogeneous medium, exactly on a voxel centre (voxel (4,4,4)
   of an 8^3 cube: world (0.5, 0.5, 0.5)).  Closed form:
     L = int sigma e^{-sigma (t - t0)} albedo I e^{-sigma r} / (4 pi r^2) dt,
   r = |x - c| (the shadow segment is inside the box), 8-point Gauss-Legendre on 256
   pieces split at the closest approach.  A sample is albedo I T / (4 pi r^2) at the
   scatter point: unbounded near the light, so the check is on the left quarter of the
   image, whose rays pass at least b_min from the light (computed from the pixel-corner
   rays, so M = albedo I / (4 pi b_min^2)); the whole image is checked finite only.
   sys_rel 1e-3 (the quadrature of the 1/r^2 peak). */
typedef struct inside_pt {
    double bmin[3], bmax[3], sigma, c[3], I, albedo;
    double o[3], d[3], t0;
} inside_pt;

static double inside_integrand(double t, void *user) {
    const inside_pt *s = user;
    double x[3] = {s->o[0] + t * s->d[0], s->o[1] + t * s->d[1], s->o[2] + t * s->d[2]};
    double r2 = 0;
    for (int i = 0; i < 3; i++) r2 += (x[i] - s->c[i]) * (x[i] - s->c[i]);
    return s->sigma * exp(-s->sigma * (t - s->t0)) * s->albedo * s->I * exp(-s->sigma * sqrt(r2)) /
           (4 * M_PI * r2);
}

static void inside_ray(const double o[3], const double d[3], void *user, double out[4]) {
    inside_pt s = *(const inside_pt *)user;
    double t0, t1;
    out[0] = out[1] = out[2] = out[3] = 0;
    if (!tu_ray_box(o, d, s.bmin, s.bmax, &t0, &t1)) return;
    memcpy(s.o, o, sizeof s.o);
    memcpy(s.d, d, sizeof s.d);
    s.t0 = t0;
    double tc = 0;
    for (int i = 0; i < 3; i++) tc += (s.c[i] - o[i]) * d[i];
    if (tc < t0) tc = t0;
    if (tc > t1) tc = t1;
    double L = tu_integrate(inside_integrand, &s, t0, tc, 128) + tu_integrate(inside_integrand, &s, tc, t1, 128);
    out[0] = out[1] = out[2] = L;
    out[3] = 1 - exp(-s.sigma * (t1 - t0));
}

static double ray_point_distance(const tu_cam *cam, double sx, double sy, const double c[3]) {
    double d[3], v[3], t = 0, r2 = 0;
    tu_cam_dir(cam, sx, sy, d);
    for (int i = 0; i < 3; i++) { v[i] = c[i] - cam->pos[i]; t += v[i] * d[i]; }
    for (int i = 0; i < 3; i++) r2 += (v[i] - t * d[i]) * (v[i] - t * d[i]);
    return sqrt(r2);
}

/* Power claimed: 5 % (the sweep's resolution: 24x24 pixels, 64 samples). */
void test_sweep_lights_inside_grazing_tiny_sun_none(void **state) {
    (void)state;
    tu_power_claim(0.05);
    picvr_context *ctx = tu_create(65);
    tu_vol vol = tu_vol_new(8, 8, 8, 1.0f, 255);
    tu_upload(ctx, &vol);
    const float D = 0.1f, albedo = 0.9f, I = 50.0f;
    tu_tf_const(ctx, albedo, albedo, albedo, 1.0f, D);
    int ok = 1;

    /* point light on the centre of voxel (4,4,4) */
    inside_pt ip;
    memset(&ip, 0, sizeof ip);
    tu_vol_box(&vol, ip.bmin, ip.bmax);
    ip.sigma = D; ip.I = I; ip.albedo = albedo;
    ip.c[0] = ip.c[1] = ip.c[2] = ip.bmin[0] + 4.5;
    picvr_light pt;
    memset(&pt, 0, sizeof pt);
    pt.type = PICVR_LIGHT_POINT;
    for (int i = 0; i < 3; i++) pt.position[i] = (float)ip.c[i];
    pt.color[0] = pt.color[1] = pt.color[2] = 1;
    pt.intensity = I;
    TU_OK(picvr_set_lights(ctx, &pt, 1, NULL));
    const uint32_t W = 32, H = 32, N = 128;
    tu_cam cam = tu_set_camera(ctx, 0, 0, 16, 0, 0, 0, 40, W, H);
    float *img = sweep_render(ctx, W, H, N, "point light on a voxel centre, inside");
    double *expv = tu_expected_image(&cam, 4, inside_ray, &ip);
    double bmin_d = INFINITY;
    for (uint32_t y = 0; y <= H; y++)
        for (uint32_t x = 0; x <= W / 4; x++) {
            double b = ray_point_distance(&cam, x, y, ip.c);
            if (b < bmin_d) bmin_d = b;
        }
    double Mp = albedo * I / (4 * M_PI * bmin_d * bmin_d);
    print_message("    left quarter: rays pass >= %.3f from the light, sample bound %.3g\n", bmin_d, Mp);
    ok &= tu_check_mean("point light inside: left quarter", img, expv, W, 1, 0, 0, W / 4, H, N, Mp, 5.0, 1e-3);
    free(expv);
    free(img);

    /* the camera inside too, next to the light (finite only: the pixel through the light
       has unbounded variance) */
    tu_set_camera(ctx, 0.5, 0.5, 2.0, 0.5, 0.5, 0.5, 60, 16, 16);
    free(sweep_render(ctx, 16, 16, 16, "point light and camera inside (finite only)"));
    /* a sphere light inside the volume around a voxel centre (finite only) */
    picvr_light sph = pt;
    sph.type = PICVR_LIGHT_SPHERE;
    sph.radius = 0.25f;
    picvr_background bg = {{0.2f, 0.3f, 0.4f}, 1.0f};
    TU_OK(picvr_set_lights(ctx, &sph, 1, &bg));
    tu_set_camera(ctx, 0, 0, 16, 0, 0, 0, 40, 16, 16);
    free(sweep_render(ctx, 16, 16, 16, "sphere light inside + background (finite only)"));

    /* grazing sun: exactly parallel to the +z face the camera looks at, and 1e-3 rad off
       it (tu_sun_ray; sys_rel 1e-4) */
    const double graze[2][3] = {{1, 0, 0}, {1, 0, 1e-3}};
    for (int g = 0; g < 2; g++) {
        tu_sun_scene s;
        tu_sun_cube(ctx, 8, D, albedo, graze[g], 3.0f, 0.0f, &s);
        tu_cam c2 = tu_set_camera(ctx, 0.3, 0.2, 14, 0, 0, 0, 30, 24, 24);
        char what[96];
        snprintf(what, sizeof what, "grazing sun (%g, 0, %g)", graze[g][0], graze[g][2]);
        img = sweep_render(ctx, 24, 24, 64, what);
        expv = tu_expected_image(&c2, 4, tu_sun_ray, &s);
        double Mc = albedo * 3.0 / (4 * M_PI);
        const double M[3] = {Mc, Mc, Mc};
        ok &= check_all(what, img, expv, 24, 24, 64, M, 1e-4);
        free(expv);
        free(img);
    }

    /* a sun of zero angular size (a delta light) and of 1e-6 rad (1 - cos is 1.25e-13:
       below float32 resolution; must behave as the delta sun, which differs by O(theta^2)) */
    const float ang[2] = {0.0f, 1e-6f};
    for (int k = 0; k < 2; k++) {
        tu_sun_scene s;
        const double l[3] = {0.2, 0.7, 0.5};
        tu_sun_cube(ctx, 8, D, albedo, l, 3.0f, ang[k], &s);
        tu_cam c2 = tu_set_camera(ctx, 0, 0, 14, 0, 0, 0, 30, 24, 24);
        char what[96];
        snprintf(what, sizeof what, "sun angular diameter %g rad", (double)ang[k]);
        img = sweep_render(ctx, 24, 24, 64, what);
        expv = tu_expected_image(&c2, 4, tu_sun_ray, &s);
        double Mc = albedo * 3.0 / (4 * M_PI);
        const double M[3] = {Mc, Mc, Mc};
        ok &= check_all(what, img, expv, 24, 24, 64, M, 1e-4);
        free(expv);
        free(img);
    }

    /* background only, medium transparent: exactly the background; no light at all,
       dense medium: exactly 0 (also the coverage is then 1 - T, not 0) */
    picvr_tf_point clear[1] = {{0.0f, {1, 1, 1}, 0.0f}};
    TU_OK(picvr_set_transfer_function(ctx, clear, 1, 1.0f));
    tu_background_only(ctx, 0.25f, 0.5f, 1.0f, 2.0f);
    tu_set_camera(ctx, 0, 0, 14, 0, 0, 0, 30, 16, 16);
    img = sweep_render(ctx, 16, 16, 8, "background only, transparent medium");
    for (size_t p = 0; p < 16 * 16; p++)
        if (img[4 * p] != 0.5f || img[4 * p + 1] != 1.0f || img[4 * p + 2] != 2.0f || img[4 * p + 3] != 0)
            fail_msg("background only: pixel %zu (%g %g %g %g)", p, (double)img[4 * p], (double)img[4 * p + 1],
                     (double)img[4 * p + 2], (double)img[4 * p + 3]);
    free(img);
    tu_tf_const(ctx, 0.9f, 0.9f, 0.9f, 1.0f, 1e3f);
    TU_OK(picvr_set_lights(ctx, NULL, 0, NULL));
    img = sweep_render(ctx, 16, 16, 8, "no light, dense medium");
    for (size_t p = 0; p < 16 * 16; p++)
        if (img[4 * p] != 0 || img[4 * p + 1] != 0 || img[4 * p + 2] != 0)
            fail_msg("no light: pixel %zu not exactly 0", p);
    free(img);
    tu_vol_free(&vol);
    if (!ok) fail_msg("a light case differs from its closed form (listed above)");
    tu_finish(ctx);
}

/* No light with the cache on (the irradiance field is exactly zero: the cache's log-space
   formulas must not produce NaN): the image is exactly 0 in both locking modes. */
void test_sweep_cache_zero_irradiance(void **state) {
    (void)state;
    for (int m = 0; m < 2; m++) {
        picvr_cache_mode mode = m ? PICVR_CACHE_SCREEN_SPACE : PICVR_CACHE_OBJECT_SPACE;
        picvr_context *ctx = create_cache(66, mode);
        tu_vol vol = tu_vol_ball(16);
        tu_upload(ctx, &vol);
        tu_tf_ramp(ctx, 0.9f, 0.9f, 0.9f, 2.0f);
        TU_OK(picvr_set_lights(ctx, NULL, 0, NULL));
        tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 40, 16, 16);
        char what[64];
        snprintf(what, sizeof what, "no light, %s", mode_name(mode));
        float *img = sweep_render(ctx, 16, 16, 16, what);
        for (size_t p = 0; p < 16 * 16; p++)
            if (img[4 * p] != 0 || img[4 * p + 1] != 0 || img[4 * p + 2] != 0)
                fail_msg("%s: pixel %zu = %g, expected exactly 0", what, p, (double)img[4 * p]);
        free(img);
        tu_vol_free(&vol);
        tu_finish(ctx);
    }
}

/* ---- volumes ---------------------------------------------------------------------------- */

/* Homogeneous boxes of extreme shapes and spacings, Beer-Lambert (background 1,
   albedo 0, opacity 1 at every value): T = exp(-D * chord).  Shapes 1x1x1, 1x64x1,
   2049x3x3 (the brick size grows so the majorant grid stays <= 64 per axis) and
   spacing (0.01, 10, 1); the density is chosen so that the optical depth across the
   view is about 1.  sys_rel 1e-4. */
void test_sweep_volume_shapes_and_spacing(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(67);
    tu_background_only(ctx, 1, 1, 1, 1);
    struct {
        const char *what;
        uint32_t n[3];
        float sp[3], D;
        double cam[3], tgt[3], fov;
        uint32_t w, h;
    } cases[] = {
        {"volume 1x1x1", {1, 1, 1}, {1, 1, 1}, 1.0f, {0.3, 0.2, 3}, {0, 0, 0}, 30, 16, 16},
        {"volume 1x64x1", {1, 64, 1}, {1, 1, 1}, 1.0f, {0.2, 3, 8}, {0, 0, 0}, 30, 8, 32},
        /* camera inside at the centre, looking down the long axis: chords up to 1024 voxels
           (bricks of 64 voxels), T smooth in the direction (the midpoint rule is exact
           enough) */
        {"volume 2049x3x3, inside along x", {2049, 3, 3}, {1, 1, 1}, 0.003f, {0, 0.2, 0.1}, {100, 0.2, 0.1}, 0.2, 16, 16},
        /* seen along x (chord 0.32 through 32 voxels of 0.01): box 0.32 x 320 x 32 */
        {"spacing (0.01, 10, 1) 32^3", {32, 32, 32}, {0.01f, 10, 1}, 3.0f, {400, 5, 3}, {0, 0, 0}, 50, 8, 64},
    };
    int ok = 1;
    const double M[3] = {1, 1, 1};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        tu_vol vol = tu_vol_new(cases[i].n[0], cases[i].n[1], cases[i].n[2], 1.0f, 255);
        memcpy(vol.spacing, cases[i].sp, sizeof vol.spacing);
        tu_upload(ctx, &vol);
        tu_homog hm;
        tu_vol_box(&vol, hm.bmin, hm.bmax);
        tu_vol_free(&vol);
        hm.sigma = cases[i].D;
        tu_tf_const(ctx, 0, 0, 0, 1.0f, cases[i].D);
        tu_cam cam = tu_set_camera(ctx, cases[i].cam[0], cases[i].cam[1], cases[i].cam[2], cases[i].tgt[0],
                                   cases[i].tgt[1], cases[i].tgt[2], cases[i].fov, cases[i].w, cases[i].h);
        float *img = sweep_render(ctx, cases[i].w, cases[i].h, 64, cases[i].what);
        double *expv = tu_expected_image(&cam, 4, tu_homog_ray, &hm);
        ok &= check_all(cases[i].what, img, expv, cases[i].w, cases[i].h, 64, M, 1e-4);
        free(expv);
        free(img);
    }
    if (!ok) fail_msg("an extreme volume shape differs from Beer-Lambert (listed above)");
    tu_finish(ctx);
}

/* float32 data spanning 1e-30 .. 1e30 and uint16 data using 12 bits, both built so that
   the normalized value is exactly k / 255 for a uint8 reference volume k (a ball), then
   Beer-Lambert against tu_absorption_ray (exact trilinear integral).
   float32: voxel k > 0 holds k / 255 * 1e30, k = 0 holds 1e-30 (and a few 1e-20 and
   1e-10: all normalize to 0 within 1e-40); value range left 0 (the data's own min..max
   = 1e-30..1e30), so the shader scale is 1e-30.  uint16: 16 k (0..4080, 12 bits), range
   0..4080.  sys_rel 1e-4 plus the float32 normalization (relative 1e-7). */
void test_sweep_float32_huge_range_and_uint16_12bit(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(68);
    tu_vol ref = tu_vol_ball(16);
    const size_t n = 16 * 16 * 16;
    float *f = malloc(n * sizeof *f);
    uint16_t *u = malloc(n * sizeof *u);
    assert_non_null(f); assert_non_null(u);
    size_t zeros = 0;
    for (size_t i = 0; i < n; i++) {
        uint8_t k = ref.v[i];
        if (k) f[i] = (float)(k / 255.0 * 1e30);
        else f[i] = (zeros++ % 3 == 0) ? 1e-30f : (zeros % 3 == 1) ? 1e-20f : 1e-10f;
        u[i] = (uint16_t)(16 * k);
    }
    /* the extremes are present: max 255 -> 1e30 exactly as k/255 * 1e30 */
    int has_max = 0;
    for (size_t i = 0; i < n; i++) has_max |= ref.v[i] == 255;
    assert_true(has_max && zeros > 0);
    tu_background_only(ctx, 1, 1, 1, 1);
    tu_tf_ramp(ctx, 0, 0, 0, 0.3f);
    tu_absorption ab;
    ab.vol = &ref;
    tu_vol_box(&ref, ab.bmin, ab.bmax);
    ab.D = (double)0.3f;
    const uint32_t W = 24, H = 24, N = 64;
    tu_cam cam = tu_set_camera(ctx, 1, 2, 30, 0, 0, 0, 40, W, H);
    double *expv = tu_expected_image(&cam, 4, tu_absorption_ray, &ab);
    const double M[3] = {1, 1, 1};
    int ok = 1;
    for (int k = 0; k < 2; k++) {
        picvr_volume_desc d;
        memset(&d, 0, sizeof d);
        d.dims[0] = d.dims[1] = d.dims[2] = 16;
        d.type = k ? PICVR_VOXEL_UINT16 : PICVR_VOXEL_FLOAT32;
        d.data = k ? (const void *)u : (const void *)f;
        if (k) { d.value_min = 0; d.value_max = 4080; }
        TU_OK(picvr_upload_volume(ctx, &d));
        const char *what = k ? "uint16, 12 bits used (0..4080)" : "float32 1e-30 .. 1e30";
        float *img = sweep_render(ctx, W, H, N, what);
        ok &= check_all(what, img, expv, W, H, N, M, 1e-4);
        free(img);
    }
    free(expv);
    free(f);
    free(u);
    tu_vol_free(&ref);
    if (!ok) fail_msg("a data range case differs from Beer-Lambert (listed above)");
    tu_finish(ctx);
}

/* ---- cameras and image sizes ------------------------------------------------------------ */

/* Beer-Lambert through a 16^3 cube (sigma 0.1, background 1) seen from inside, from the
   far side, looking away (exactly the background), with fov 1 and 170 degrees, and at
   image sizes 1x1 and 4096x16; the first, the 1x1 and the inside case also with the cache
   on (object space; albedo 0: the cache has nothing to store but must stay finite and
   unbiased: sys_rel 1e-4 as without it).  sys_rel 1e-4; fov 170: 2e-3, the midpoint
   quadrature over a pixel's jitter is coarser where the pixels are ~6 degrees wide. */
void test_sweep_cameras_and_image_sizes(void **state) {
    (void)state;
    for (int pass = 0; pass < 2; pass++) {
        picvr_context *ctx = pass ? create_cache(69, PICVR_CACHE_OBJECT_SPACE) : tu_create(69);
        tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
        tu_upload(ctx, &vol);
        tu_homog hm;
        tu_vol_box(&vol, hm.bmin, hm.bmax);
        tu_vol_free(&vol);
        hm.sigma = (double)0.1f;
        tu_tf_const(ctx, 0, 0, 0, 1.0f, 0.1f);
        tu_background_only(ctx, 1, 1, 1, 1);
        struct {
            const char *what;
            double p[3], t[3], fov;
            uint32_t w, h, n;
            double sys;
            int cache;
        } cases[] = {
            {"camera inside, off-centre", {2, -3, 1}, {5, 4, -2}, 60, 16, 16, 64, 1e-4, 1},
            {"camera at the far side (-z)", {0.5, 0.2, -30}, {0, 0, 0}, 30, 16, 16, 64, 1e-4, 0},
            {"camera looking away", {0, 0, 30}, {0, 0, 60}, 60, 16, 16, 4, 0, 0},
            {"fov 1 degree", {0.2, 0.1, 40}, {0, 0, 0}, 1, 16, 16, 64, 1e-4, 0},
            {"fov 170 degrees", {0.2, 0.1, 10}, {0, 0, 0}, 170, 32, 32, 64, 2e-3, 0},
            {"image 1x1", {0.1, 0.2, 30}, {0, 0, 0}, 10, 1, 1, 4096, 1e-4, 1},
            {"image 4096x16", {0, 0, 30}, {0, 0, 0}, 40, 4096, 16, 8, 1e-4, 0},
        };
        int ok = 1;
        const double M[3] = {1, 1, 1};
        for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
            if (pass && !cases[i].cache) continue;
            tu_cam cam = tu_set_camera(ctx, cases[i].p[0], cases[i].p[1], cases[i].p[2], cases[i].t[0],
                                       cases[i].t[1], cases[i].t[2], cases[i].fov, cases[i].w, cases[i].h);
            char what[96];
            snprintf(what, sizeof what, "%s, %s", cases[i].what, pass ? "cache object" : "no cache");
            float *img = sweep_render(ctx, cases[i].w, cases[i].h, cases[i].n, what);
            double *expv = tu_expected_image(&cam, cases[i].w > 1000 ? 2 : 4, tu_homog_ray, &hm);
            if (cases[i].sys == 0) { /* looking away: exactly the background */
                for (size_t p = 0; p < (size_t)cases[i].w * cases[i].h; p++)
                    if (img[4 * p] != 1.0f || img[4 * p + 3] != 0.0f)
                        fail_msg("%s: pixel %zu = %g, expected exactly the background", what, p, (double)img[4 * p]);
            } else {
                ok &= check_all(what, img, expv, cases[i].w, cases[i].h, cases[i].n, M, cases[i].sys);
            }
            free(expv);
            free(img);
        }
        if (!ok) fail_msg("a camera case differs from Beer-Lambert (listed above)");
        tu_finish(ctx);
    }
}

/* ---- long runs --------------------------------------------------------------------------- */

/* 2^16 samples in one pixel.  Scene: Beer-Lambert with T = exp(-1) on the pixel's rays
   (albedo 0, background 1): every sample is exactly 0 or 1 in R, G, B and the complement
   in alpha.  After N samples with k ones the exact mean is k / N, and:
   (1) R is within one float32 ulp of some k / N (|N R - round(N R)| <= N ulp(R), i.e.
       0.002 for N = 2^16): an accumulator that lost precision drifts from the lattice
       k / N by a random walk of its rounding errors (~ulp sqrt(N) / 2 = 7.5e-6 relative,
       so N R would be off by ~0.18, 90 times the bound: 2^16 samples show it as well as
       10^6 did, in a sixteenth of the time);
   (2) R + alpha = 1 within ulp(R) + ulp(alpha) (complementary samples);
   (3) R is within 5 standard errors of T (the mean still converges: a mean that stopped
       changing after 2^24 / ... samples would be stuck at an earlier value);
   (4) the mean keeps moving: the checks hold at N / 100, N / 10 and N (the run
       continues without reset), so the last 90 % of the samples changed it correctly.
   Cost: 2^16 passes of three dispatches each, of one workgroup. */
void test_sweep_long_run_precision(void **state) {
    (void)state;
    /* 2^16 passes of three dispatches each take a quarter of a minute on a CPU driver, and
       PICVR_LONG_RUN may ask for more: this test has its own budget. */
    tu_watchdog(900);
    picvr_context *ctx = tu_create(70);
    tu_vol vol = tu_vol_new(4, 4, 4, 1.0f, 255);
    tu_upload(ctx, &vol);
    tu_homog hm;
    tu_vol_box(&vol, hm.bmin, hm.bmax);
    tu_vol_free(&vol);
    hm.sigma = 0.25; /* exact in float32: the chord 4 along z gives T = e^-1 */
    tu_tf_const(ctx, 0, 0, 0, 1.0f, 0.25f);
    tu_background_only(ctx, 1, 1, 1, 1);
    tu_cam cam = tu_set_camera(ctx, 0, 0, 10, 0, 0, 0, 0.01, 1, 1);
    double ex[4];
    double *expv = tu_expected_image(&cam, 4, tu_homog_ray, &hm);
    memcpy(ex, expv, sizeof ex);
    free(expv);
    /* PICVR_LONG_RUN=N: N samples instead of 2^16 (10^6 for the old, longer run). */
    const char *env = getenv("PICVR_LONG_RUN");
    uint32_t total = env && atoi(env) > 0 ? (uint32_t)atoi(env) : 1u << 16;
    uint32_t done = 0;
    const uint32_t checkpoints[3] = {total / 100, total / 10, total};
    double t0 = now_s();
    for (int c = 0; c < 3; c++) {
        TU_OK(picvr_step_iterations(ctx, checkpoints[c] - done));
        done = checkpoints[c];
        float px[4];
        TU_OK(picvr_read_rgba32f(ctx, px, sizeof px));
        picvr_stats st = tu_stats_finite(ctx);
        if (st.iterations != done || st.iterations_min != done)
            fail_msg("after %u iterations: stats say %u (min %u)", done, st.iterations, st.iterations_min);
        tu_assert_finite(px, 4, "long run");
        double R = px[0], A = px[3], N = done;
        double ulp = nextafterf(px[0], 2.0f) - px[0], ulp_a = nextafterf(px[3], 2.0f) - px[3];
        double lattice = fabs(N * R - nearbyint(N * R));
        double sum_err = fabs(R + A - 1.0);
        double se = sqrt(ex[0] * (1 - ex[0]) / N);
        print_message("    N %-8u R %.8f (T %.8f, %.2f SE)  |N R - k| %.4f (bound %.4f)  |R + A - 1| %.2e  %.1f s\n",
                      done, R, ex[0], (R - ex[0]) / se, lattice, N * ulp, sum_err, now_s() - t0);
        if (px[0] != px[1] || px[0] != px[2]) fail_msg("R G B differ: samples are grey");
        if (lattice > N * ulp) fail_msg("N = %u: mean %.9g is not within 1 ulp of any k / N", done, R);
        if (sum_err > ulp + ulp_a) fail_msg("N = %u: R + alpha - 1 = %.3g (> 1 ulp each)", done, R + A - 1);
        if (fabs(R - ex[0]) > 5 * se + 1e-6) fail_msg("N = %u: mean %.8f, expected T = %.8f", done, R, ex[0]);
    }
    tu_finish(ctx);
}

/* A point light over a homogeneous 16^3 box (tu_point_light_ray, the closed form of
   test_sampling.c) at the extremes of the distance sampler: optical depth 1e-6 to 1e5
   across the box, the light inside the medium, on the camera's axis (in front of the box
   and inside it), 1e-6 above a face and 1e6 away.  Default samplers (MIS, residual).
   The seeds are those the sweep had before it took a sampler (tu_create's 70 + i).
   Tolerance: z = 5 with the empirical block spread, plus sys_rel 3e-3 (the 4x4 jitter
   quadrature of a smooth image) or 2e-2 where the light's sharp image peak falls inside
   the picture (the jitter quadrature of a pixel next to it), stated per row. */
typedef struct point_sweep_case {
    const char *name;
    double tau, p[3], I, sys_rel;
} point_sweep_case;

/* The cases of a point-light sweep with distance sampler ds and transmittance estimator
   te; *ok cleared on a failure. */
static void point_sweep(const point_sweep_case *cases, size_t n, picvr_distance_sampling ds,
                        picvr_transmittance_estimator te, uint32_t seed, int *ok) {
    const uint32_t W = 32, H = 32, N = 96;
    for (size_t i = 0; i < n; i++) {
        const point_sweep_case *c = &cases[i];
        picvr_config cfg;
        memset(&cfg, 0, sizeof cfg);
        cfg.seed = seed + (uint32_t)i;
        cfg.distance_sampling = ds;
        cfg.transmittance = te;
        picvr_context *ctx = tu_create_config(&cfg);
        tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
        tu_upload(ctx, &vol);
        tu_point_scene s;
        memset(&s, 0, sizeof s);
        tu_vol_box(&vol, s.bmin, s.bmax);
        s.sigma = (double)(float)(c->tau / 16.0);
        s.albedo = 0.8;
        s.I = c->I;
        tu_tf_const(ctx, 0.8f, 0.8f, 0.8f, 1.0f, (float)s.sigma);
        picvr_light l;
        memset(&l, 0, sizeof l);
        l.type = PICVR_LIGHT_POINT;
        for (int k = 0; k < 3; k++) { l.position[k] = (float)c->p[k]; s.p[k] = l.position[k]; l.color[k] = 1.0f; }
        l.intensity = (float)c->I;
        TU_OK(picvr_set_lights(ctx, &l, 1, NULL));
        tu_cam cam = tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 36, W, H);
        double *expv = tu_expected_image(&cam, 4, tu_point_light_ray, &s);
        float *img = sweep_render_ex(ctx, W, H, N, c->name, ds == PICVR_DISTANCE_AUTO);
        char label[160];
        snprintf(label, sizeof label, "point light, %s", c->name);
        *ok &= tu_check_mean(label, img, expv, W, 1, 0, 0, W, H, N, 0, 5.0, c->sys_rel);
        snprintf(label, sizeof label, "point light, %s: alpha", c->name);
        *ok &= tu_check_mean(label, img, expv, W, 3, 0, 0, W, H, N, 1.0, 5.0, 1e-4);
        free(img);
        free(expv);
        tu_vol_free(&vol);
        tu_finish(ctx);
    }
}

void test_sweep_point_light_extremes(void **state) {
    (void)state;
    static const point_sweep_case cases[] = {
        {"tau 1e-6, light inside", 1e-6, {2.0, 3.0, -1.0}, 40.0, 3e-3},
        {"tau 1e-6, light 0.5 above the top face", 1e-6, {0.0, 8.5, 0.0}, 40.0, 3e-3},
        {"tau 1, light 1e-6 above the top face", 1.0, {1.0, 8.000001, 0.5}, 40.0, 3e-3},
        {"tau 1, light 1e6 away", 1.0, {0.0, 1e6, 0.0}, 4e13, 3e-3},
        {"tau 1, light on the axis before the box", 1.0, {0.0, 0.0, 20.0}, 40.0, 2e-2},
        {"tau 1, light on the axis at the centre", 1.0, {0.0, 0.0, 0.0}, 40.0, 2e-2},
        {"tau 1e5, light inside", 1e5, {2.0, 3.0, -1.0}, 40.0, 3e-3},
        {"tau 1e5, light above the top face", 1e5, {0.0, 12.0, 0.0}, 40.0, 3e-3},
    };
    int ok = 1;
    point_sweep(cases, sizeof cases / sizeof cases[0], PICVR_DISTANCE_DEFAULT, PICVR_TRANSMITTANCE_DEFAULT, 70, &ok);
    if (!ok) fail_msg("a point light at an extreme differs from the closed form");
}

/* The forced point (PICVR_DISTANCE_FORCED) at the same extremes, with lights that
   equiangular sampling leaves to it (their 1/d^2 varies gently across the volume, so
   every strategy-B point is forced): optical depth 1e-6, 1 and 1e5 under a light 1e6
   away, and at 1 under one 8 bounding-sphere radii away on the camera's axis behind
   the camera (the rays run toward the light's foot).  Tolerances as above. */
void test_sweep_forced_extremes(void **state) {
    (void)state;
    static const point_sweep_case cases[] = {
        {"forced, tau 1e-6, light 1e6 away", 1e-6, {0.0, 1e6, 0.0}, 4e13, 3e-3},
        {"forced, tau 1, light 1e6 away", 1.0, {0.0, 1e6, 0.0}, 4e13, 3e-3},
        {"forced, tau 1e5, light 1e6 away", 1e5, {0.0, 1e6, 0.0}, 4e13, 3e-3},
        {"forced, tau 1, light on the axis 8 radii away", 1.0, {0.0, 0.0, 110.0}, 5000.0, 3e-3},
    };
    int ok = 1;
    point_sweep(cases, sizeof cases / sizeof cases[0], PICVR_DISTANCE_FORCED, PICVR_TRANSMITTANCE_DEFAULT, 80, &ok);
    if (!ok) fail_msg("the forced point at an extreme differs from the closed form");
}

/* Ray-marched transmittance (PICVR_TRANSMITTANCE_RAY_MARCHING) at the extremes: the
   forced point's shadow rays and end term through optical depth 1e-6 and 1 under a light
   1e6 away, and the default sampler's with the light inside a box of optical depth 1e5
   (every pivot darker than RM_DARK: Russian roulette decides each estimate) and 1e-6
   above the face of a thin one.  The medium is homogeneous, where the estimator is
   exact up to its roulette.  Tolerances as above. */
void test_sweep_ray_marching_extremes(void **state) {
    (void)state;
    static const point_sweep_case forced[] = {
        {"ray marching, forced, tau 1e-6, light 1e6 away", 1e-6, {0.0, 1e6, 0.0}, 4e13, 3e-3},
        {"ray marching, forced, tau 1, light 1e6 away", 1.0, {0.0, 1e6, 0.0}, 4e13, 3e-3},
    };
    static const point_sweep_case mis[] = {
        {"ray marching, tau 1e5, light inside", 1e5, {2.0, 3.0, -1.0}, 40.0, 3e-3},
        {"ray marching, tau 1e-6, light 1e-6 above the top face", 1e-6, {1.0, 8.000001, 0.5}, 40.0, 3e-3},
    };
    int ok = 1;
    point_sweep(forced, sizeof forced / sizeof forced[0], PICVR_DISTANCE_FORCED, PICVR_TRANSMITTANCE_RAY_MARCHING, 100, &ok);
    point_sweep(mis, sizeof mis / sizeof mis[0], PICVR_DISTANCE_DEFAULT, PICVR_TRANSMITTANCE_RAY_MARCHING, 110, &ok);
    if (!ok) fail_msg("ray-marched transmittance at an extreme differs from the closed form");
}

/* PICVR_DISTANCE_AUTO at the extremes of its measure (render.glsl, measure_spread: the
   spread scaled by the image's mean, clamped per sample): a thin cube (optical depth
   1e-6, the image nearly black, scale about 10^6) and a dense one (1e5) under a light
   1e6 away of intensity 4e13 (the forced point's kind), and under a light just above
   the cube (served by equiangular sampling: the ray-marching kind), rendered through
   picvr_step (the rounds that measure and
   probe), against the closed form with the tolerances above; the stats' forced share
   and efficiency finite (sweep_render_ex). */
void test_sweep_auto_extremes(void **state) {
    (void)state;
    static const point_sweep_case cases[] = {
        {"auto, tau 1e-6, light 1e6 away", 1e-6, {0.0, 1e6, 0.0}, 4e13, 3e-3},
        {"auto, tau 1e5, light 1e6 away", 1e5, {0.0, 1e6, 0.0}, 4e13, 3e-3},
        /* served by equiangular sampling: the second kind is ray marching (auto_rm) */
        {"auto, tau 1e-6, light just above", 1e-6, {0.0, 9.5, 0.0}, 40.0, 3e-3},
        {"auto, tau 1e5, light just above", 1e5, {0.0, 9.5, 0.0}, 40.0, 3e-3},
    };
    int ok = 1;
    point_sweep(cases, sizeof cases / sizeof cases[0], PICVR_DISTANCE_AUTO, PICVR_TRANSMITTANCE_DEFAULT, 90, &ok);
    if (!ok) fail_msg("PICVR_DISTANCE_AUTO at an extreme differs from the closed form");
}

/* ---- multiple scattering, the phase function, environment maps ---------------------------- */

/* A constant expected image (w*h*4 doubles: rgb = L[c], alpha unused). */
static double *const_image(uint32_t w, uint32_t h, const double L[3]) {
    double *e = malloc((size_t)w * h * 4 * sizeof *e);
    assert_non_null(e);
    for (size_t p = 0; p < (size_t)w * h; p++) {
        for (int c = 0; c < 3; c++) e[4 * p + c] = L[c];
        e[4 * p + 3] = 0;
    }
    return e;
}

/* HG phase function per steradian, cos theta between the directions of travel. */
static double sweep_hg(double g, double c) {
    double d = 1 + g * g - 2 * g * c;
    return (1 - g * g) / (4 * M_PI * d * sqrt(d));
}

/* Single scattering of a homogeneous box under a delta sun with an HG phase function:
   tu_sun_ray's isotropic closed form times 4 pi HG(g, l . d) (the phase value is the same
   at every point of a ray: cos theta = l . d, the light travelling along -l and the
   scattered light along -d). */
typedef struct hg_sun {
    tu_sun_scene s;
    double g;
} hg_sun;

static void hg_sun_ray(const double o[3], const double d[3], void *user, double out[4]) {
    const hg_sun *h = user;
    tu_sun_ray(o, d, (void *)&h->s, out);
    double f = 4 * M_PI * sweep_hg(h->g, h->s.l[0] * d[0] + h->s.l[1] * d[1] + h->s.l[2] * d[2]);
    for (int c = 0; c < 3; c++) out[c] *= f;
}

/* Mean of channel ch over the image and its standard error from the pixel spread (pixels
   are independent: picvr.h's random numbers are a hash of the pixel among others). */
static void pixel_mean_se(const float *img, uint32_t w, uint32_t h, int ch, double *mean, double *se) {
    double n = (double)w * h, s = 0, s2 = 0;
    for (size_t p = 0; p < (size_t)w * h; p++) s += img[4 * p + ch];
    *mean = s / n;
    for (size_t p = 0; p < (size_t)w * h; p++) s2 += (img[4 * p + ch] - *mean) * (img[4 * p + ch] - *mean);
    *se = sqrt(s2 / (n - 1) / n);
}

/* Stiff inputs of the path tracer.  Each row: the sweep's checks (finite, radiance >= 0,
   alpha in [0, 1], stats finite, iterations, time <= CASE_MAX_S) and, where one exists,
   a closed form:
   (1) g = +-0.9999 (picvr_tf_point.g): single scattering of a 16^3 cube (sigma 0.1,
       albedo 0.9) under a delta sun 30 degrees off the forward (g > 0: the sun behind the
       cube) or backward (g < 0: the sun behind the camera) peak, black background, against
       tu_sun_ray * 4 pi HG(g, l . d); sys_rel 2e-3 (float evaluation of HG at |g| near 1:
       1 - g^2 = 2e-4 loses ~1e-3 relative to rounding; l . d is 0.85..0.92 here, far from
       the peak).  Then the white furnace (albedo 1, background 1, unlimited bounces) with
       the same g: every pixel 1 (z = 5 on the 8x8 block spread, sys_rel 1e-4); with
       g = -0.9999 a path reverses at every event and bounces along a line many times.
   (2) Unlimited bounces, albedo 1, a dense medium (8^3 cube, sigma_t 1e4 per voxel):
       (a) the camera inside, at the centre, 4e4 mean free paths from every face: a path
       cannot leave within PICVR_PATH_STEPS (its displacement after n events is ~sqrt(n)
       mean free paths), so every sample ends at the bound: truncated_paths = samples
       exactly, image finite;
       (b) the camera outside (optical thickness 8e4 across): paths that enter diffuse;
       truncated_paths <= samples.
       In both, the radiance of a white furnace is L everywhere, so what a path has still
       to collect when it is cut is L times its throughput (1) at most, and what it
       collected is at most L in expectation: L (1 - truncated / samples) - 5 SE <= image
       mean <= L + 5 SE (SE from the pixel spread), whatever a cut path adds at its end
       (picvr.h leaves that open: "it ends (biased)"; path.glsl ends it with one more
       light and phase estimate, and the camera-inside image comes out at L).
   (2c) The light must still be physical where the bound cuts a path: a 16^3 cube whose
       outer 2 voxels are absorbing (albedo 0) and whose 12^3 core scatters (albedo 1),
       sigma_t 1e4 per voxel throughout, a sun and a background of 1, the camera inside
       the core.  No light crosses the shell (transmittance e^-2e4; whatever scatters in
       it is absorbed), so the core's radiance is 0 (to double precision) however long a
       path is.  Every path is cut (as in (a)), and what a cut path adds at its end may be
       biased low but must not be light that cannot arrive: every pixel <= 1e-6.
   (3) An environment map (256x128) with one texel of 1e30 and the rest 1e-30: 60 orders
       of magnitude in the importance sampling's table.  (a) intensity 1, 4 bounces:
       finite (pixels first, then the stats: the in-scattered radiance is ~1e25, whose
       square in a per-pixel variance overflows a float); (b) intensity 1e-27 (texel radiance 1e3, the rest
       1e-57, below float's range), single scattering of a thin cube (sigma 0.02) against
       the delta-sun closed form for the texel's centre direction with E = radiance * its
       solid angle: sys_rel 2e-3 (the texel's extent, 0.0245 rad: test_path.c measures it
       below 1e-3 for this scene).
   (4) 16384x1 and 1x16384 maps (PICVR_MAX_ENV_SIZE): constant ones in the white furnace
       (every pixel L, z = 5, sys_rel 1e-4), and a 16384x1 map of random texels
       (finite only). */
void test_sweep_path_extremes(void **state) {
    (void)state;
    int ok = 1;
    const uint32_t W = 32, H = 32;
    /* (1) g near +-1 */
    for (int sgn = 0; sgn < 2; sgn++) {
        const float g = sgn ? -0.9999f : 0.9999f;
        picvr_context *ctx = tu_create(201 + (uint32_t)sgn);
        tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
        tu_upload(ctx, &vol);
        hg_sun hs;
        memset(&hs, 0, sizeof hs);
        tu_vol_box(&vol, hs.s.bmin, hs.s.bmax);
        tu_vol_free(&vol);
        const float D = 0.1f, a = 0.9f, E = 50.0f;
        picvr_tf_point tf[2];
        memset(tf, 0, sizeof tf);
        for (int i = 0; i < 2; i++) {
            tf[i].value = (float)i;
            tf[i].albedo[0] = tf[i].albedo[1] = tf[i].albedo[2] = a;
            tf[i].opacity = 1;
            tf[i].g = g;
        }
        TU_OK(picvr_set_transfer_function(ctx, tf, 2, D));
        /* the sun 30 degrees off the view axis (0, 0, -1): toward -z for g > 0 (behind the
           cube), toward +z for g < 0 (behind the camera) */
        double l[3] = {sin(M_PI / 6) * 0.8, sin(M_PI / 6) * 0.6, (sgn ? 1 : -1) * cos(M_PI / 6)};
        picvr_light sun;
        memset(&sun, 0, sizeof sun);
        sun.type = PICVR_LIGHT_DIRECTIONAL;
        for (int i = 0; i < 3; i++) { sun.direction[i] = (float)l[i]; sun.color[i] = 1; }
        sun.intensity = E;
        TU_OK(picvr_set_lights(ctx, &sun, 1, NULL));
        hs.s.sigma = D;
        double ll = sqrt((double)sun.direction[0] * sun.direction[0] + (double)sun.direction[1] * sun.direction[1] +
                         (double)sun.direction[2] * sun.direction[2]);
        for (int i = 0; i < 3; i++) { hs.s.l[i] = sun.direction[i] / ll; hs.s.albedo[i] = a; hs.s.E[i] = E; }
        hs.g = g;
        tu_cam cam = tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 20, W, H);
        char what[96];
        snprintf(what, sizeof what, "g %g, single scattering, sun 30 deg off the peak", (double)g);
        float *img = sweep_render(ctx, W, H, 64, what);
        double *expv = tu_expected_image(&cam, 4, hg_sun_ray, &hs);
        char label[128];
        snprintf(label, sizeof label, "%s: G", what);
        ok &= tu_check_mean(label, img, expv, W, 1, 0, 0, W, H, 64, 0, 5.0, 2e-3);
        free(expv);
        free(img);
        /* the white furnace with the same g */
        tf[0].albedo[0] = tf[0].albedo[1] = tf[0].albedo[2] = 1;
        tf[1].albedo[0] = tf[1].albedo[1] = tf[1].albedo[2] = 1;
        TU_OK(picvr_set_transfer_function(ctx, tf, 2, 0.125f));
        tu_background_only(ctx, 1, 1, 1, 1);
        picvr_scattering sc;
        memset(&sc, 0, sizeof sc);
        sc.max_bounces = PICVR_BOUNCES_UNLIMITED;
        TU_OK(picvr_set_scattering(ctx, &sc));
        snprintf(what, sizeof what, "g %g, white furnace, unlimited bounces", (double)g);
        img = sweep_render(ctx, W, H, 64, what);
        const double one[3] = {1, 1, 1};
        expv = const_image(W, H, one);
        snprintf(label, sizeof label, "%s: G", what);
        ok &= tu_check_mean(label, img, expv, W, 1, 0, 0, W, H, 64, 0, 5.0, 1e-4);
        picvr_stats st = tu_stats_finite(ctx);
        print_message("    %s: mean path length %.3f\n", what, st.mean_path_length);
        if (st.truncated_paths) { print_message("    %s: %llu truncated paths\n", what, (unsigned long long)st.truncated_paths); ok = 0; }
        free(expv);
        free(img);
        tu_finish(ctx);
    }

    /* (2) dense, albedo 1, unlimited */
    {
        picvr_context *ctx = tu_create(203);
        tu_vol vol = tu_vol_new(8, 8, 8, 1.0f, 255);
        tu_upload(ctx, &vol);
        tu_vol_free(&vol);
        tu_tf_const(ctx, 1, 1, 1, 1.0f, 1e4f);
        tu_background_only(ctx, 1, 1, 1, 1);
        picvr_scattering sc;
        memset(&sc, 0, sizeof sc);
        sc.max_bounces = PICVR_BOUNCES_UNLIMITED;
        TU_OK(picvr_set_scattering(ctx, &sc));
        for (int inside = 1; inside >= 0; inside--) {
            const uint32_t w = inside ? 8 : 16, h = w, n = inside ? 2 : 4;
            if (inside) tu_set_camera(ctx, 0.1, 0.2, 0.05, 5, 3, -20, 60, w, h);
            else tu_set_camera(ctx, 3, 5, 20, 0, 0, 0, 30, w, h);
            const char *what = inside ? "dense 1e4/voxel, albedo 1, unlimited, camera inside"
                                      : "dense 1e4/voxel, albedo 1, unlimited, camera outside";
            float *img = sweep_render(ctx, w, h, n, what);
            picvr_stats st = tu_stats_finite(ctx);
            double samples = (double)w * h * n, f = (double)st.truncated_paths / samples;
            float lo = INFINITY, hi = -INFINITY;
            for (size_t p = 0; p < (size_t)w * h; p++) { lo = fminf(lo, img[4 * p]); hi = fmaxf(hi, img[4 * p]); }
            print_message("    %s: truncated %llu of %.0f samples, pixels %.6g .. %.6g, mean path length %.4g\n", what,
                          (unsigned long long)st.truncated_paths, samples, (double)lo, (double)hi, st.mean_path_length);
            if (inside ? st.truncated_paths != (uint64_t)samples : st.truncated_paths > (uint64_t)samples) {
                print_message("    FAIL: %s\n", inside ? "every sample must end at the step bound and be counted"
                                                      : "more truncated paths than samples");
                ok = 0;
            }
            if (!(st.mean_path_length > 0)) ok = 0;
            for (int c = 0; c < 3; c++) {
                double m, se;
                pixel_mean_se(img, w, h, c, &m, &se);
                double sef = sqrt(f * (1 - f) / samples); /* the measured truncated fraction's own error */
                int pass = m <= 1 + 5 * se + 1e-5 && m >= (1 - f) - 5 * sqrt(se * se + sef * sef) - 1e-5;
                print_message("    %s ch%d: mean %.5f (SE %.2g), truncated fraction %.4g: bound [%.5f, 1] %s\n",
                              inside ? "camera inside" : "camera outside", c, m, se, f, 1 - f, pass ? "ok" : "FAIL");
                ok &= pass;
            }
            free(img);
        }
        tu_finish(ctx);
    }
    /* (2c) a shielded core: nothing reaches it, so a cut path must not bring light */
    {
        picvr_context *ctx = tu_create(206);
        tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 128);
        for (uint32_t z = 2; z < 14; z++)
            for (uint32_t y = 2; y < 14; y++)
                for (uint32_t x = 2; x < 14; x++) *tu_vox(&vol, x, y, z) = 255;
        tu_upload(ctx, &vol);
        tu_vol_free(&vol);
        picvr_tf_point tf[2];
        memset(tf, 0, sizeof tf);
        tf[0].value = 128.0f / 255.0f; tf[0].opacity = 1;    /* the shell: albedo 0 */
        tf[1].value = 1.0f; tf[1].opacity = 1;               /* the core: albedo 1 */
        tf[1].albedo[0] = tf[1].albedo[1] = tf[1].albedo[2] = 1;
        TU_OK(picvr_set_transfer_function(ctx, tf, 2, 1e4f));
        tu_sun(ctx, 0.3, 1, 0.2, 1, 1, 1, 10, 1.0f);           /* a sun and a background of 1 */
        picvr_scattering sc;
        memset(&sc, 0, sizeof sc);
        sc.max_bounces = PICVR_BOUNCES_UNLIMITED;
        TU_OK(picvr_set_scattering(ctx, &sc));
        const uint32_t w = 8, h = 8, n = 2;
        tu_set_camera(ctx, 0.1, 0.2, 0.05, 5, 3, -20, 60, w, h);
        const char *what = "dense albedo-1 core in an absorbing shell, camera inside";
        float *img = sweep_render(ctx, w, h, n, what);
        picvr_stats st = tu_stats_finite(ctx);
        float hi = 0;
        for (size_t p = 0; p < (size_t)w * h; p++)
            for (int c = 0; c < 3; c++) hi = fmaxf(hi, img[4 * p + c]);
        int pass = hi <= 1e-6f;
        print_message("    %s: truncated %llu of %u samples, brightest pixel %.6g (must be 0: no light reaches the "
                      "core) %s\n", what, (unsigned long long)st.truncated_paths, w * h * n, (double)hi,
                      pass ? "ok" : "FAIL");
        ok &= pass;
        if (st.truncated_paths != (uint64_t)w * h * n) ok = 0;
        free(img);
        tu_finish(ctx);
    }

    /* (3) a map of 1e30 and 1e-30 */
    {
        const uint32_t EW = 256, EH = 128, COL = 200, ROW = 39;
        float *env = malloc((size_t)EW * EH * 3 * sizeof *env);
        assert_non_null(env);
        for (size_t i = 0; i < (size_t)EW * EH * 3; i++) env[i] = 1e-30f;
        for (int c = 0; c < 3; c++) env[3 * ((size_t)ROW * EW + COL) + c] = 1e30f;
        picvr_context *ctx = tu_create(204);
        tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
        tu_upload(ctx, &vol);
        tu_sun_scene s;
        memset(&s, 0, sizeof s);
        tu_vol_box(&vol, s.bmin, s.bmax);
        tu_vol_free(&vol);
        tu_tf_const(ctx, 0.9f, 0.9f, 0.9f, 1.0f, 0.1f);
        picvr_background bg;
        memset(&bg, 0, sizeof bg);
        bg.color[0] = bg.color[1] = bg.color[2] = 1;
        bg.intensity = 1;
        bg.environment = env;
        bg.env_width = EW;
        bg.env_height = EH;
        TU_OK(picvr_set_lights(ctx, NULL, 0, &bg));
        picvr_scattering sc;
        memset(&sc, 0, sizeof sc);
        sc.max_bounces = 4;
        TU_OK(picvr_set_scattering(ctx, &sc));
        tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 20, W, H);
        /* (a) pixels first, then the stats */
        double t0 = now_s();
        TU_OK(picvr_step_iterations(ctx, 16));
        float *img = tu_read(ctx, W, H);
        tu_assert_image_valid(img, W, H, "map 1e30 / 1e-30, 4 bounces");
        picvr_stats st;
        TU_OK(picvr_get_stats(ctx, &st));
        print_message("    map 1e30 / 1e-30, 4 bounces: %.2f s, mean L %.4g, est_error %.4g, est_rel_error %.4g, "
                      "mean path length %.4g, trunc %llu\n", now_s() - t0, st.mean_luminance, st.est_error,
                      st.est_rel_error, st.mean_path_length, (unsigned long long)st.truncated_paths);
        free(img);
        /* the stats too (as sweep_render asserts), recorded rather than fatal so that the
           rows below still run */
        if (!isfinite(st.mean_luminance) || !isfinite(st.est_error) || !isfinite(st.est_rel_error) ||
            !isfinite(st.mean_path_length)) {
            print_message("    FAIL map 1e30 / 1e-30: a stat is not finite (the pixels are)\n");
            ok = 0;
        }
        /* (b) intensity 1e-27, single scattering of a thin cube, closed form */
        bg.intensity = 1e-27f;
        TU_OK(picvr_set_lights(ctx, NULL, 0, &bg));
        TU_OK(picvr_set_scattering(ctx, NULL));
        const float D = 0.02f;
        tu_tf_const(ctx, 0.9f, 0.9f, 0.9f, 1.0f, D);
        tu_cam cam = tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 20, W, H);
        double th = M_PI * (ROW + 0.5) / EH, ph = 2 * M_PI * ((COL + 0.5) / EW - 0.5);
        double omega = (2 * M_PI / EW) * (cos(M_PI * ROW / EH) - cos(M_PI * (ROW + 1) / EH));
        double Erad = (double)(1e30f * 1e-27f) * omega; /* radiance * solid angle */
        s.sigma = D;
        s.l[0] = sin(th) * sin(ph); s.l[1] = cos(th); s.l[2] = -sin(th) * cos(ph);
        for (int c = 0; c < 3; c++) { s.albedo[c] = 0.9; s.E[c] = Erad; }
        img = sweep_render(ctx, W, H, 128, "map 1e30 / 1e-30 at intensity 1e-27, single scattering");
        double *expv = tu_expected_image(&cam, 2, tu_sun_ray, &s);
        ok &= tu_check_mean("map 1e30 / 1e-30 x 1e-27: G vs delta sun", img, expv, W, 1, 0, 0, W, H, 128, 0, 5.0, 2e-3);
        free(expv);
        free(img);
        free(env);
        tu_finish(ctx);
    }

    /* (4) 16384 x 1 and 1 x 16384 */
    {
        const uint32_t M = PICVR_MAX_ENV_SIZE;
        float *env = malloc((size_t)M * 3 * sizeof *env);
        assert_non_null(env);
        picvr_context *ctx = tu_create(205);
        tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
        tu_upload(ctx, &vol);
        tu_vol_free(&vol);
        tu_tf_const(ctx, 1, 1, 1, 1.0f, 0.125f);
        picvr_scattering sc;
        memset(&sc, 0, sizeof sc);
        sc.max_bounces = PICVR_BOUNCES_UNLIMITED;
        TU_OK(picvr_set_scattering(ctx, &sc));
        tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 20, W, H);
        const float tex[3] = {0.8f, 0.9f, 1.0f};
        for (uint32_t i = 0; i < M; i++)
            for (int c = 0; c < 3; c++) env[3 * i + c] = tex[c];
        for (int shape = 0; shape < 3; shape++) {
            picvr_background bg;
            memset(&bg, 0, sizeof bg);
            bg.color[0] = bg.color[1] = bg.color[2] = 1;
            bg.intensity = 1;
            bg.environment = env;
            bg.env_width = shape == 1 ? 1 : M;
            bg.env_height = shape == 1 ? M : 1;
            bg.env_rotation = 0.25f;
            if (shape == 2) { /* random texels: finite only */
                uint64_t rs = 5;
                for (uint32_t i = 0; i < M; i++)
                    for (int c = 0; c < 3; c++) env[3 * i + c] = (float)(tu_rand01(&rs) * tu_rand01(&rs) * 3);
            }
            TU_OK(picvr_set_lights(ctx, NULL, 0, &bg));
            const char *names[3] = {"white furnace, constant 16384x1 map", "white furnace, constant 1x16384 map",
                                    "random 16384x1 map (finite only)"};
            float *img = sweep_render(ctx, W, H, 32, names[shape]);
            if (shape < 2) {
                const double L[3] = {tex[0], tex[1], tex[2]};
                double *expv = const_image(W, H, L);
                for (int c = 0; c < 3; c++) {
                    char label[128];
                    snprintf(label, sizeof label, "%s ch%d", names[shape], c);
                    ok &= tu_check_mean(label, img, expv, W, c, 0, 0, W, H, 32, 0, 5.0, 1e-4);
                }
                free(expv);
            }
            free(img);
        }
        free(env);
        tu_finish(ctx);
    }
    if (!ok) fail_msg("a stiff path-tracing case failed (listed above)");
}

/* ---- clipping and placement ----------------------------------------------------------------- */

/* Beer-Lambert (albedo 0, background 1) through an 8^3 cube (tau 1 per voxel) under
   stiff clips, plain and with the cache in both modes: everything clipped away (two
   disjoint half-spaces: the background exactly, every pixel 1), a plane lying on a face
   of the box (the whole cube), a sliver 1e-3 thick at tau 1e5 per unit (optical depth
   100), a slab; and a volume placed 1e6 units from the origin, turned a quarter about x,
   seen by a camera placed with it (the frame's float coordinates stay small: the host
   maps in double).  Closed form tu_homog_ray with the kept box; sys_rel 1e-4 (1e-3 for
   the far placement: float32 rounding of camera inputs of magnitude 1e6). */
void test_sweep_clip_and_placement(void **state) {
    (void)state;
    for (int m = 0; m < 3; m++) {
        picvr_cache_mode mode = m == 0 ? PICVR_CACHE_NONE : m == 1 ? PICVR_CACHE_OBJECT_SPACE : PICVR_CACHE_SCREEN_SPACE;
        picvr_context *ctx = create_cache(67, mode);
        tu_vol vol = tu_vol_new(8, 8, 8, 1.0f, 255);
        tu_upload(ctx, &vol);
        tu_background_only(ctx, 1, 1, 1, 1);
        const uint32_t W = 16, H = 16, N = 32;
        tu_cam cam = tu_set_camera(ctx, 0.5, 0.3, 14, 0, 0, 0, 30, W, H);
        const struct { uint32_t planes; float p[2][4]; int box; float bmin[3], bmax[3]; float D; double kmin[3], kmax[3];
                       const char *what; } rows[] = {
            {2, {{1, 0, 0, -1}, {-1, 0, 0, -1}}, 0, {0}, {0}, 1.0f, {0, 0, 0}, {0, 0, 0}, "all clipped"},
            {1, {{-1, 0, 0, 4}}, 0, {0}, {0}, 1.0f, {-4, -4, -4}, {4, 4, 4}, "plane on a face"},
            {0, {{0}}, 1, {-9, -9, 0}, {9, 9, 1e-3f}, 1e5f, {-4, -4, 0}, {4, 4, 1e-3}, "sliver 1e-3 at tau 1e5"},
            {0, {{0}}, 1, {-9, -9, -0.5f}, {9, 9, 0.5f}, 1.0f, {-4, -4, -0.5}, {4, 4, 0.5}, "slab"},
        };
        int ok = 1;
        for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
            picvr_clip clip;
            memset(&clip, 0, sizeof clip);
            clip.plane_count = rows[i].planes;
            memcpy(clip.planes, rows[i].p, sizeof rows[i].p);
            clip.use_box = rows[i].box;
            memcpy(clip.box_min, rows[i].bmin, sizeof clip.box_min);
            memcpy(clip.box_max, rows[i].bmax, sizeof clip.box_max);
            TU_OK(picvr_set_clip(ctx, &clip));
            tu_tf_const(ctx, 0, 0, 0, 1.0f, rows[i].D);
            char what[96];
            snprintf(what, sizeof what, "clip: %s, %s", rows[i].what, mode_name(mode));
            float *img = sweep_render(ctx, W, H, N, what);
            if (i == 0) {
                for (size_t p = 0; p < (size_t)W * H; p++)
                    if (img[4 * p] != 1.0f || img[4 * p + 3] != 0.0f)
                        fail_msg("%s: pixel %zu = %g (alpha %g), expected exactly the background", what, p,
                                 (double)img[4 * p], (double)img[4 * p + 3]);
            } else {
                tu_homog hm = {{rows[i].kmin[0], rows[i].kmin[1], rows[i].kmin[2]},
                               {rows[i].kmax[0], rows[i].kmax[1], rows[i].kmax[2]}, rows[i].D};
                double *expv = tu_expected_image(&cam, 4, tu_homog_ray, &hm);
                const double M[3] = {1, 1, 1};
                ok &= check_all(what, img, expv, W, H, N, M, 1e-4);
                free(expv);
            }
            free(img);
        }
        TU_OK(picvr_set_clip(ctx, NULL));
        /* placed far away: axes x -> +x, y -> +z, z -> -y; origin ~1e6 */
        picvr_volume_desc d;
        memset(&d, 0, sizeof d);
        d.dims[0] = d.dims[1] = d.dims[2] = 8;
        d.type = PICVR_VOXEL_UINT8;
        d.data = vol.v;
        const float dir[9] = {1, 0, 0, 0, 0, 1, 0, -1, 0};
        memcpy(d.direction, dir, sizeof dir);
        d.has_origin = 1;
        const float origin[3] = {1e6f, -2e6f, 5e5f};
        memcpy(d.origin, origin, sizeof origin);
        TU_OK(picvr_upload_volume(ctx, &d));
        tu_tf_const(ctx, 0, 0, 0, 1.0f, 1.0f);
        /* centre = origin + rot (3.5, 3.5, 3.5); the local camera (0.5, 0.3, 14) maps to
           centre + (0.5, -14, 0.3), its up (0, 1, 0) to (0, 0, 1) */
        const double centre[3] = {1e6 + 3.5, -2e6 - 3.5, 5e5 + 3.5};
        picvr_camera c;
        memset(&c, 0, sizeof c);
        c.position[0] = (float)(centre[0] + 0.5);
        c.position[1] = (float)(centre[1] - 14.0);
        c.position[2] = (float)(centre[2] + 0.3);
        for (int k = 0; k < 3; k++) c.target[k] = (float)centre[k];
        c.up[2] = 1.0f;
        c.fov_y_degrees = 30.0f;
        c.width = W;
        c.height = H;
        TU_OK(picvr_set_camera(ctx, &c));
        char what[96];
        snprintf(what, sizeof what, "placed at 1e6, %s", mode_name(mode));
        float *img = sweep_render(ctx, W, H, N, what);
        tu_homog hm = {{-4, -4, -4}, {4, 4, 4}, 1.0};
        double *expv = tu_expected_image(&cam, 4, tu_homog_ray, &hm);
        const double M[3] = {1, 1, 1};
        ok &= check_all(what, img, expv, W, H, N, M, 1e-3);
        free(expv);
        free(img);
        tu_vol_free(&vol);
        tu_finish(ctx);
        if (!ok) fail_msg("a clipped or placed image differs from its closed form (listed above)");
    }
}

/* The multiply scattered cache (cache on, unlimited bounces, blend off so that the
   cache's own error shows) in the white furnace across optical thickness: an 8^3 cube of
   albedo 1 under a constant background L = 1, tau per voxel from 1e-6 (an almost empty
   medium: the cached fluences are ~1e-6 of the background's) to 4 (optical thickness 32,
   walks of hundreds of events).  Closed form: every pixel's expectation is L, whatever
   the density.  Checks: a valid image and finite stats (sweep_render); where no camera
   path and no creation sample was cut at its loop bound, the mean is L within
   5 SE + 6 % (tests/test_path.c allows 2 % in a 16^3 cube; this cube is only four
   offsets Delta wide, so every entry's seven points reach toward a face, where the
   fluence bends and Eq. 7's log-linear extrapolation errs most); where some were, the
   cut paths are biased toward dark (path.glsl's rule), so the mean may be lower but
   never above L + 5 SE + 6 %: the cache creates no light.  Swept with the lookup at the
   first scatter event and at the second (cache.lookup_event 2: the paths' walks go on
   past their first event, through the same stiff media, to a lookup there). */
/* One pass of the sweep with the cache looked up at scatter event k (cache.lookup_event). */
static int ms_furnace_sweep(uint32_t k, uint32_t seed) {
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = seed;
    cfg.cache.mode = PICVR_CACHE_OBJECT_SPACE;
    cfg.cache.blend = PICVR_SWITCH_OFF;
    cfg.cache.lookup_event = k;
    picvr_context *ctx = tu_create_config(&cfg);
    tu_vol vol = tu_vol_new(8, 8, 8, 1.0f, 255);
    tu_upload(ctx, &vol);
    tu_background_only(ctx, 1, 1, 1, 1);
    picvr_scattering sc;
    memset(&sc, 0, sizeof sc);
    sc.max_bounces = PICVR_BOUNCES_UNLIMITED;
    TU_OK(picvr_set_scattering(ctx, &sc));
    const uint32_t W = 16, H = 16, N = 96;
    tu_set_camera(ctx, 0.5, 0.3, 14, 0, 0, 0, 30, W, H);
    const float tau[] = {1e-6f, 1e-2f, 0.25f, 4.0f};
    int ok = 1;
    for (size_t i = 0; i < sizeof tau / sizeof tau[0]; i++) {
        tu_tf_const(ctx, 1, 1, 1, 1.0f, tau[i]);
        char what[96];
        snprintf(what, sizeof what, "ms cache furnace, lookup at event %u, tau/voxel %g", k, (double)tau[i]);
        float *img = sweep_render(ctx, W, H, N, what);
        picvr_stats st = tu_stats_finite(ctx);
        int cut = st.truncated_paths > 0 || st.cache_samples_truncated > 0;
        for (int c = 0; c < 3; c++) {
            double s1 = 0, s2 = 0, n = (double)W * H;
            for (size_t p = 0; p < (size_t)W * H; p++) {
                s1 += img[4 * p + c];
                s2 += (double)img[4 * p + c] * img[4 * p + c];
            }
            double mean = s1 / n, se = sqrt(fmax(s2 / n - mean * mean, 0.0) / (n - 1));
            double bound = 5 * se + 0.06;
            int good = cut ? mean <= 1.0 + bound : fabs(mean - 1.0) <= bound;
            print_message("    %s ch%d: mean %.5f (L 1), se %.2g, %u entries, hit rate %.2f, cut paths %llu, "
                          "cut creation samples %llu: %s\n", what, c, mean, se, st.cache_entries,
                          st.cache_hit_rate, (unsigned long long)st.truncated_paths,
                          (unsigned long long)st.cache_samples_truncated, good ? "ok" : "FAIL");
            ok &= good;
        }
        free(img);
    }
    tu_vol_free(&vol);
    tu_finish(ctx);
    return ok;
}

void test_sweep_ms_cache_furnace_thickness(void **state) {
    (void)state;
    int ok = ms_furnace_sweep(1, 63);
    ok &= ms_furnace_sweep(2, 64);
    if (!ok) fail_msg("the cached furnace is not L (listed above)");
}
