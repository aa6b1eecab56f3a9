/* test_util.c - helpers of the picvr test suite (declared in test_util.h). */
#include "test_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

/* ---- context registry, per-test timing ---------------------------------------------- */

#define TU_MAX_LIVE 16
static picvr_context *tu_live[TU_MAX_LIVE];
static struct timespec tu_t_start;
/* The running test's comparisons, and those that would reject expected x 1.02 and x 0.98. */
static unsigned tu_cmp_count, tu_cmp_powerful;
static double tu_power_rel = 0.02;   /* the test's claimed resolution (tu_power_claim) */

void tu_register(picvr_context *ctx, int add) {
    for (int i = 0; i < TU_MAX_LIVE; i++) {
        if (add && !tu_live[i]) { tu_live[i] = ctx; return; }
        if (!add && tu_live[i] == ctx) { tu_live[i] = NULL; return; }
    }
}

static int tu_validation_expected(void) {
    const char *e = getenv("PICVR_VALIDATION");
    return !(e && strcmp(e, "0") == 0);
}

picvr_context *tu_create(uint32_t seed) {
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = seed;
    return tu_create_config(&cfg);
}

picvr_context *tu_create_config(const picvr_config *cfg_in) {
    picvr_config cfg = *cfg_in;
    cfg.validation = PICVR_SWITCH_ON;
    picvr_context *ctx = NULL;
    TU_OK(picvr_create(&cfg, &ctx));
    assert_non_null(ctx);
    tu_register(ctx, 1);
    if (tu_validation_expected()) {
        picvr_stats st;
        TU_OK(picvr_get_stats(ctx, &st));
        if (st.validation_enabled != 1)
            fail_msg("cfg.validation ON but stats.validation_enabled = %u",
                     st.validation_enabled);
    }
    return ctx;
}

int tu_device_is_cpu(void) {
    picvr_context *ctx = tu_create(0);
    picvr_stats st;
    TU_OK(picvr_get_stats(ctx, &st));
    int cpu = st.device_type == PICVR_DEVICE_CPU;
    tu_finish(ctx);
    return cpu;
}

void tu_finish(picvr_context *ctx) {
    picvr_stats st;
    TU_OK(picvr_get_stats(ctx, &st));
    tu_register(ctx, 0);
    picvr_destroy(ctx);
    if (st.validation_messages != 0)
        fail_msg("%u Khronos validation message(s) (see the log above)",
                 st.validation_messages);
}

/* A step that never returns would hang the whole suite: a per-test watchdog ends the
   process with a message instead (cmocka has no timeouts). */
#define TU_WATCHDOG_S 240
static void tu_on_alarm(int sig) {
    (void)sig;
    static const char msg[] = "\n[  FAILED  ] watchdog: a test ran longer than its "
                              "budget (TU_WATCHDOG_S or tu_watchdog; a picvr call did not return?)\n";
    ssize_t r = write(2, msg, sizeof msg - 1);
    (void)r;
    _exit(3);
}

void tu_watchdog(unsigned seconds) { alarm(seconds); }

int tu_setup(void **state) {
    (void)state;
    signal(SIGALRM, tu_on_alarm);
    alarm(TU_WATCHDOG_S);
    clock_gettime(CLOCK_MONOTONIC, &tu_t_start);
    tu_cmp_count = tu_cmp_powerful = 0;
    tu_power_rel = 0.02;
    return 0;
}

int tu_teardown(void **state) {
    (void)state;
    alarm(0);
    for (int i = 0; i < TU_MAX_LIVE; i++) {
        if (tu_live[i]) { picvr_destroy(tu_live[i]); tu_live[i] = NULL; }
    }
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    double s = (double)(t.tv_sec - tu_t_start.tv_sec) + 1e-9 * (double)(t.tv_nsec - tu_t_start.tv_nsec);
    print_message("    (%.2f s)\n", s);
    if (tu_cmp_count > 0 && tu_cmp_powerful == 0) {
        print_message("    NO POWER: none of this test's %u comparisons would reject its expected value "
                      "off by %g %% beyond its allowance, nor rejected a perturbed one\n", tu_cmp_count,
                      100 * tu_power_rel);
        fflush(stdout);
        return -1;
    }
    fflush(stdout);
    return 0;
}

/* ---- volumes ------------------------------------------------------------------------ */

tu_vol tu_vol_new(uint32_t nx, uint32_t ny, uint32_t nz, float spacing, uint8_t fill) {
    tu_vol v;
    v.dims[0] = nx; v.dims[1] = ny; v.dims[2] = nz;
    v.spacing[0] = v.spacing[1] = v.spacing[2] = spacing;
    v.v = malloc((size_t)nx * ny * nz);
    assert_non_null(v.v);
    memset(v.v, fill, (size_t)nx * ny * nz);
    return v;
}

void tu_vol_free(tu_vol *vol) {
    free(vol->v);
    vol->v = NULL;
}

tu_vol tu_vol_ball(uint32_t n) {
    tu_vol v = tu_vol_new(n, n, n, 1.0f, 0);
    double R = 0.4 * n, soft = 0.15 * n, c = 0.5 * n;
    for (uint32_t z = 0; z < n; z++)
        for (uint32_t y = 0; y < n; y++)
            for (uint32_t x = 0; x < n; x++) {
                double dx = x + 0.5 - c, dy = y + 0.5 - c, dz = z + 0.5 - c;
                double r = sqrt(dx * dx + dy * dy + dz * dz);
                double s = (R - r) / soft;
                s = s < 0 ? 0 : s > 1 ? 1 : s;
                *tu_vox(&v, x, y, z) = (uint8_t)lround(255.0 * s);
            }
    return v;
}

void tu_upload(picvr_context *ctx, const tu_vol *vol) {
    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    memcpy(d.dims, vol->dims, sizeof d.dims);
    memcpy(d.spacing, vol->spacing, sizeof d.spacing);
    d.type = PICVR_VOXEL_UINT8;
    d.data = vol->v;
    TU_OK(picvr_upload_volume(ctx, &d));
}

void tu_vol_box(const tu_vol *vol, double bmin[3], double bmax[3]) {
    for (int i = 0; i < 3; i++) {
        double s = vol->spacing[i] == 0 ? 1.0 : (double)vol->spacing[i];
        bmax[i] = 0.5 * vol->dims[i] * s;
        bmin[i] = -bmax[i];
    }
}

uint64_t tu_rand_u64(uint64_t *state) {
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

double tu_rand01(uint64_t *state) {
    return (double)(tu_rand_u64(state) >> 11) * (1.0 / 9007199254740992.0);
}

double tu_trilinear(const tu_vol *vol, const double p[3]) {
    int i0[3], i1[3];
    double f[3];
    for (int a = 0; a < 3; a++) {
        double q = p[a] - 0.5;
        double fl = floor(q);
        f[a] = q - fl;
        int n = (int)vol->dims[a];
        int lo = (int)fl, hi = lo + 1;
        i0[a] = lo < 0 ? 0 : lo > n - 1 ? n - 1 : lo;
        i1[a] = hi < 0 ? 0 : hi > n - 1 ? n - 1 : hi;
    }
    double r = 0;
    for (int c = 0; c < 8; c++) {
        uint32_t x = (uint32_t)((c & 1) ? i1[0] : i0[0]);
        uint32_t y = (uint32_t)((c & 2) ? i1[1] : i0[1]);
        uint32_t z = (uint32_t)((c & 4) ? i1[2] : i0[2]);
        double w = ((c & 1) ? f[0] : 1 - f[0]) * ((c & 2) ? f[1] : 1 - f[1]) *
                   ((c & 4) ? f[2] : 1 - f[2]);
        r += w * vol->v[x + (size_t)vol->dims[0] * (y + (size_t)vol->dims[1] * z)];
    }
    return r / 255.0;
}

static int tu_cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y ? 1 : 0;
}

double tu_value_integral(const tu_vol *vol, const double o[3], const double d[3],
                         double t0, double t1) {
    if (!(t1 > t0)) return 0;
    double bmin[3], bmax[3], sp[3];
    tu_vol_box(vol, bmin, bmax);
    for (int a = 0; a < 3; a++) sp[a] = vol->spacing[a] == 0 ? 1.0 : vol->spacing[a];
    size_t cap = 2 + (size_t)vol->dims[0] + vol->dims[1] + vol->dims[2] + 3;
    double *ts = malloc(cap * sizeof *ts); /* called from OpenMP threads: no cmocka asserts */
    if (!ts) abort();
    size_t n = 0;
    ts[n++] = t0;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0) continue;
        double pa = (o[a] + t0 * d[a] - bmin[a]) / sp[a];
        double pb = (o[a] + t1 * d[a] - bmin[a]) / sp[a];
        double lo = pa < pb ? pa : pb, hi = pa < pb ? pb : pa;
        for (long k = (long)floor(lo - 0.5); k <= (long)ceil(hi - 0.5); k++) {
            double pk = k + 0.5;
            if (pk <= lo || pk >= hi) continue;
            double t = (bmin[a] + pk * sp[a] - o[a]) / d[a];
            if (t > t0 && t < t1 && n < cap - 1) ts[n++] = t;
        }
    }
    ts[n++] = t1;
    qsort(ts, n, sizeof *ts, tu_cmp_double);
    static const double gx[3] = {-0.7745966692414834, 0.0, 0.7745966692414834};
    static const double gw[3] = {5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0};
    double sum = 0;
    for (size_t i = 0; i + 1 < n; i++) {
        double a = ts[i], b = ts[i + 1];
        if (!(b > a)) continue;
        double m = 0.5 * (a + b), hl = 0.5 * (b - a), s = 0;
        for (int g = 0; g < 3; g++) {
            double t = m + hl * gx[g], p[3];
            for (int k = 0; k < 3; k++) p[k] = (o[k] + t * d[k] - bmin[k]) / sp[k];
            s += gw[g] * tu_trilinear(vol, p);
        }
        sum += hl * s;
    }
    free(ts);
    return sum;
}

/* ---- transfer function, lights --------------------------------------------------------- */

void tu_tf_const(picvr_context *ctx, float ar, float ag, float ab, float opacity, float D) {
    picvr_tf_point tf[2] = {{0.0f, {ar, ag, ab}, opacity}, {1.0f, {ar, ag, ab}, opacity}};
    TU_OK(picvr_set_transfer_function(ctx, tf, 2, D));
}

void tu_tf_ramp(picvr_context *ctx, float ar, float ag, float ab, float D) {
    picvr_tf_point tf[2] = {{0.0f, {ar, ag, ab}, 0.0f}, {1.0f, {ar, ag, ab}, 1.0f}};
    TU_OK(picvr_set_transfer_function(ctx, tf, 2, D));
}

void tu_background_only(picvr_context *ctx, float r, float g, float b, float intensity) {
    picvr_background bg = {{r, g, b}, intensity};
    TU_OK(picvr_set_lights(ctx, NULL, 0, &bg));
}

/* One directional light toward d of colour (r, g, b), `intensity` and angular diameter
   `angular`, and the background bg (NULL: none). */
static void tu_set_sun(picvr_context *ctx, const double d[3], float r, float g, float b,
                       float intensity, float angular, const picvr_background *bg) {
    picvr_light sun;
    memset(&sun, 0, sizeof sun);
    sun.type = PICVR_LIGHT_DIRECTIONAL;
    for (int i = 0; i < 3; i++) sun.direction[i] = (float)d[i];
    sun.angular_diameter = angular;
    sun.color[0] = r; sun.color[1] = g; sun.color[2] = b;
    sun.intensity = intensity;
    TU_OK(picvr_set_lights(ctx, &sun, 1, bg));
}

void tu_sun(picvr_context *ctx, double dx, double dy, double dz, float r, float g, float b,
            float intensity, float bg_intensity) {
    const double d[3] = {dx, dy, dz};
    picvr_background bg = {{1, 1, 1}, bg_intensity};
    tu_set_sun(ctx, d, r, g, b, intensity, 0.0f, &bg);
}

void tu_sun_cube(picvr_context *ctx, uint32_t n, float D, float a, const double l_in[3],
                 float E, float angular, tu_sun_scene *s) {
    tu_vol vol = tu_vol_new(n, n, n, 1.0f, 255);
    tu_upload(ctx, &vol);
    memset(s, 0, sizeof *s);
    tu_vol_box(&vol, s->bmin, s->bmax);
    tu_vol_free(&vol);
    s->sigma = D;
    tu_tf_const(ctx, a, a, a, 1.0f, D);
    double l = sqrt(l_in[0] * l_in[0] + l_in[1] * l_in[1] + l_in[2] * l_in[2]);
    for (int c = 0; c < 3; c++) { s->l[c] = l_in[c] / l; s->albedo[c] = a; s->E[c] = E; }
    tu_set_sun(ctx, l_in, 1.0f, 1.0f, 1.0f, E, angular, NULL);
}

/* ---- camera -------------------------------------------------------------------------- */

static void tu_normalize(double v[3]) {
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    v[0] /= l; v[1] /= l; v[2] /= l;
}

static void tu_cross(const double a[3], const double b[3], double c[3]) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

tu_cam tu_cam_from(const picvr_camera *c) {
    tu_cam k;
    double up[3] = {c->up[0], c->up[1], c->up[2]};
    if (up[0] == 0 && up[1] == 0 && up[2] == 0) up[1] = 1;
    for (int i = 0; i < 3; i++) {
        k.pos[i] = c->position[i];
        k.f[i] = (double)c->target[i] - (double)c->position[i];
    }
    tu_normalize(k.f);
    tu_cross(k.f, up, k.r);
    tu_normalize(k.r);
    tu_cross(k.r, k.f, k.u);
    double fov = c->fov_y_degrees == 0 ? 40.0 : (double)c->fov_y_degrees;
    k.h = tan(0.5 * fov * M_PI / 180.0);
    k.a = (double)c->width / (double)c->height;
    k.w = c->width;
    k.hgt = c->height;
    return k;
}

tu_cam tu_set_camera(picvr_context *ctx, double px, double py, double pz, double tx,
                     double ty, double tz, double fov_deg, uint32_t w, uint32_t h) {
    picvr_camera c;
    memset(&c, 0, sizeof c);
    c.position[0] = (float)px; c.position[1] = (float)py; c.position[2] = (float)pz;
    c.target[0] = (float)tx; c.target[1] = (float)ty; c.target[2] = (float)tz;
    c.up[1] = 1.0f;
    c.fov_y_degrees = (float)fov_deg;
    c.width = w;
    c.height = h;
    TU_OK(picvr_set_camera(ctx, &c));
    return tu_cam_from(&c);
}

void tu_cam_dir(const tu_cam *c, double sx, double sy, double dir[3]) {
    double kx = (2.0 * sx / c->w - 1.0) * c->h * c->a;
    double ky = (1.0 - 2.0 * sy / c->hgt) * c->h;
    for (int i = 0; i < 3; i++) dir[i] = c->f[i] + kx * c->r[i] + ky * c->u[i];
    tu_normalize(dir);
}

double *tu_expected_image(const tu_cam *c, int sub, tu_ray_fn fn, void *user) {
    size_t np = (size_t)c->w * c->hgt;
    double *img = calloc(np * 4, sizeof *img);
    assert_non_null(img);
    long total = (long)np;
#pragma omp parallel for schedule(dynamic, 4)
    for (long p = 0; p < total; p++) {
        uint32_t x = (uint32_t)(p % c->w), y = (uint32_t)(p / c->w);
        double acc[4] = {0, 0, 0, 0};
        for (int j = 0; j < sub; j++)
            for (int i = 0; i < sub; i++) {
                double d[3], out[4] = {0, 0, 0, 0};
                tu_cam_dir(c, x + (i + 0.5) / sub, y + (j + 0.5) / sub, d);
                fn(c->pos, d, user, out);
                for (int k = 0; k < 4; k++) acc[k] += out[k];
            }
        for (int k = 0; k < 4; k++) img[4 * (size_t)p + k] = acc[k] / (sub * sub);
    }
    return img;
}

/* ---- geometry, quadrature ---------------------------------------------------------------- */

int tu_ray_box(const double o[3], const double d[3], const double bmin[3],
               const double bmax[3], double *t0, double *t1) {
    double lo = 0, hi = INFINITY;
    for (int i = 0; i < 3; i++) {
        if (d[i] == 0) {
            if (o[i] < bmin[i] || o[i] > bmax[i]) return 0;
            continue;
        }
        double a = (bmin[i] - o[i]) / d[i], b = (bmax[i] - o[i]) / d[i];
        if (a > b) { double t = a; a = b; b = t; }
        if (a > lo) lo = a;
        if (b < hi) hi = b;
    }
    if (!(hi > lo)) return 0;
    *t0 = lo;
    *t1 = hi;
    return 1;
}

double tu_box_exit(const double x[3], const double d[3], const double bmin[3],
                   const double bmax[3]) {
    double t = INFINITY;
    for (int i = 0; i < 3; i++) {
        double s;
        if (d[i] > 0) s = (bmax[i] - x[i]) / d[i];
        else if (d[i] < 0) s = (bmin[i] - x[i]) / d[i];
        else continue;
        if (s < t) t = s;
    }
    return t < 0 ? 0 : t;
}

double tu_segment_in_box(const double a[3], const double b[3], const double bmin[3],
                         const double bmax[3]) {
    double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, t0, t1;
    if (!tu_ray_box(a, d, bmin, bmax, &t0, &t1)) return 0;
    if (t1 > 1) t1 = 1;
    if (t1 <= t0) return 0;
    return (t1 - t0) * sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

double tu_integrate(double (*f)(double t, void *user), void *user, double a, double b,
                    int pieces) {
    static const double gx[4] = {0.1834346424956498, 0.5255324099163290,
                                 0.7966664774136267, 0.9602898564975363};
    static const double gw[4] = {0.3626837833783620, 0.3137066458778873,
                                 0.2223810344533745, 0.1012285362903763};
    double h = (b - a) / pieces, sum = 0;
    for (int p = 0; p < pieces; p++) {
        double m = a + (p + 0.5) * h, hl = 0.5 * h, s = 0;
        for (int g = 0; g < 4; g++) s += gw[g] * (f(m - hl * gx[g], user) + f(m + hl * gx[g], user));
        sum += hl * s;
    }
    return sum;
}

double tu_triangle_solid_angle(const double x[3], const double a[3], const double b[3],
                               const double c[3]) {
    double A[3], B[3], C[3], bc[3];
    for (int i = 0; i < 3; i++) { A[i] = a[i] - x[i]; B[i] = b[i] - x[i]; C[i] = c[i] - x[i]; }
    tu_cross(B, C, bc);
    double num = fabs(A[0] * bc[0] + A[1] * bc[1] + A[2] * bc[2]);
    double la = sqrt(A[0] * A[0] + A[1] * A[1] + A[2] * A[2]);
    double lb = sqrt(B[0] * B[0] + B[1] * B[1] + B[2] * B[2]);
    double lc = sqrt(C[0] * C[0] + C[1] * C[1] + C[2] * C[2]);
    double ab = A[0] * B[0] + A[1] * B[1] + A[2] * B[2];
    double ac = A[0] * C[0] + A[1] * C[1] + A[2] * C[2];
    double bcd = B[0] * C[0] + B[1] * C[1] + B[2] * C[2];
    double den = la * lb * lc + ab * lc + ac * lb + bcd * la;
    return 2.0 * atan2(num, den);
}

/* ---- images ---------------------------------------------------------------------------- */

unsigned tu_image_serial;

float *tu_read(picvr_context *ctx, uint32_t w, uint32_t h) {
    size_t bytes = (size_t)w * h * 4 * sizeof(float);
    float *img = malloc(bytes);
    assert_non_null(img);
    TU_OK(picvr_read_rgba32f(ctx, img, bytes));
    tu_image_serial++;
    return img;
}

void tu_assert_finite(const float *x, size_t n, const char *what) {
    for (size_t i = 0; i < n; i++)
        if (!isfinite(x[i]))
            fail_msg("%s: value %zu (pixel %zu channel %zu) is %f", what, i, i / 4, i % 4,
                     (double)x[i]);
}

void tu_assert_image_valid(const float *img, uint32_t w, uint32_t h, const char *what) {
    tu_assert_finite(img, (size_t)w * h * 4, what);
    for (size_t p = 0; p < (size_t)w * h; p++) {
        for (int c = 0; c < 3; c++)
            if (img[4 * p + c] < 0)
                fail_msg("%s: pixel %zu channel %d negative (%g)", what, p, c, (double)img[4 * p + c]);
        if (img[4 * p + 3] < 0 || img[4 * p + 3] > 1)
            fail_msg("%s: pixel %zu alpha %g outside [0,1]", what, p, (double)img[4 * p + 3]);
    }
}

void tu_homog_ray(const double o[3], const double d[3], void *user, double out[4]) {
    const tu_homog *h = user;
    double t0, t1, T = 1;
    if (tu_ray_box(o, d, h->bmin, h->bmax, &t0, &t1)) T = exp(-h->sigma * (t1 - t0));
    out[0] = out[1] = out[2] = T;
    out[3] = 1 - T;
}

picvr_stats tu_stats_finite(picvr_context *ctx) {
    picvr_stats st;
    TU_OK(picvr_get_stats(ctx, &st));
    double v[6] = {st.iterations_mean, st.elapsed_ms, st.samples_per_second, st.est_error,
                   st.est_rel_error, st.mean_luminance};
    const char *names[6] = {"iterations_mean", "elapsed_ms", "samples_per_second",
                            "est_error", "est_rel_error", "mean_luminance"};
    for (int i = 0; i < 6; i++)
        if (!isfinite(v[i])) fail_msg("stats.%s is not finite (%f)", names[i], v[i]);
    return st;
}

double tu_region_mean(const float *img, uint32_t w, int ch, uint32_t x0, uint32_t y0,
                      uint32_t x1, uint32_t y1) {
    double s = 0;
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = x0; x < x1; x++) s += img[4 * ((size_t)y * w + x) + ch];
    return s / ((double)(x1 - x0) * (y1 - y0));
}

/* The two standard errors of the header's comparison and the blocks behind the
   empirical one (nb < 4: no empirical SE, 0). */
static void mean_ses(const float *img, const double *expected, uint32_t w, int ch, uint32_t x0,
                     uint32_t y0, uint32_t x1, uint32_t y1, uint32_t n_iter, double M,
                     double *meas, double *expv, double *se_an, double *se_emp, uint32_t *nb_out) {
    double P = (double)(x1 - x0) * (y1 - y0);
    double sm = 0, se = 0, sv = 0;
    for (uint32_t y = y0; y < y1; y++)
        for (uint32_t x = x0; x < x1; x++) {
            size_t i = 4 * ((size_t)y * w + x) + (size_t)ch;
            double mu = expected[i];
            sm += img[i];
            se += mu;
            if (M > 0) sv += fmax(0.0, mu * (M - mu));
        }
    *meas = sm / P;
    *expv = se / P;
    *se_an = M > 0 ? sqrt(sv / n_iter) / P : 0;
    /* Empirical: residual means of whole 8x8 blocks inside the region. */
    *se_emp = 0;
    uint32_t nbx = (x1 - x0) / 8, nby = (y1 - y0) / 8, nb = nbx * nby;
    *nb_out = nb;
    if (nb >= 4) {
        double s1 = 0, s2 = 0;
        for (uint32_t by = 0; by < nby; by++)
            for (uint32_t bx = 0; bx < nbx; bx++) {
                double r = 0;
                for (uint32_t y = y0 + 8 * by; y < y0 + 8 * by + 8; y++)
                    for (uint32_t x = x0 + 8 * bx; x < x0 + 8 * bx + 8; x++) {
                        size_t i = 4 * ((size_t)y * w + x) + (size_t)ch;
                        r += img[i] - expected[i];
                    }
                r /= 64.0;
                s1 += r;
                s2 += r * r;
            }
        double mean = s1 / nb, var = (s2 - nb * mean * mean) / (nb - 1);
        *se_emp = sqrt(fmax(var, 0.0) / nb);
    }
}

static unsigned tu_partial_skip_count;

void tu_partial_skip(const char *what) {
    tu_partial_skip_count++;
    print_message("    PARTIAL SKIP: %s\n", what);
}

unsigned tu_partial_skips(void) { return tu_partial_skip_count; }

void tu_power_note_rel(double measured, double expected, double bound, double rel) {
    tu_cmp_count++;
    if (fabs(measured - (1 + rel) * expected) > bound && fabs(measured - (1 - rel) * expected) > bound)
        tu_cmp_powerful++;
}

void tu_power_shown(int rejected) {
    tu_cmp_count++;
    if (rejected) tu_cmp_powerful++;
}

void tu_power_note(double measured, double expected, double bound) {
    tu_power_note_rel(measured, expected, bound, tu_power_rel);
}

void tu_power_claim(double rel) { tu_power_rel = rel; }

double tu_power_claimed(void) { return tu_power_rel; }

int tu_check_cache_mean(const char *label, const float *img, const double *expected, uint32_t w,
                        uint32_t h, int ch, uint32_t n_iter, double epsilon, double gamma,
                        double hit_rate, uint32_t entries, double z) {
    double meas, expv, se_an, se_emp;
    uint32_t nb;
    mean_ses(img, expected, w, ch, 0, 0, w, h, n_iter, 0.0, &meas, &expv, &se_an, &se_emp, &nb);
    /* Rule: no entry means no entry noise (and no served lookup either). */
    double hit = fmin(fmax(hit_rate, 0.0), 1.0);
    double se_entries = entries > 0 ? gamma / (1 + gamma) / 1.96 / sqrt((double)entries) * fabs(expv) : 0.0;
    double se = sqrt(se_emp * se_emp + se_entries * se_entries);
    double t = nb >= 2 ? tu_student_quantile(tu_normal_cdf(z), (double)nb - 1) : INFINITY;
    double bias = epsilon * hit * fabs(expv), bound = bias + t * se, diff = meas - expv;
    int ok = isfinite(meas) && fabs(diff) <= bound;
    print_message("    %-44s ch%d measured %.6g expected %.6g diff %+.3f %% (SE %.3f %%: image %.3f %%, "
                  "entries %.3f %%); bound epsilon x hit %.3f %% + %.1f SE = %.3f %% %s\n",
                  label, ch, meas, expv, 100 * diff / expv, 100 * se / expv, 100 * se_emp / expv,
                  100 * se_entries / expv, 100 * bias / expv, t, 100 * bound / expv, ok ? "ok" : "FAIL");
    tu_power_note_rel(meas, expv, bound, epsilon * hit + fmax(tu_power_rel, 0.03));
    return ok;
}

int tu_pool_eligible(int student, uint32_t nb, double sys_abs, double se) {
    return (!student || nb >= 30) && sys_abs <= 0.1 * se;
}

double tu_mean_se(const float *img, const double *expected, uint32_t w, int ch, uint32_t x0,
                  uint32_t y0, uint32_t x1, uint32_t y1, uint32_t n_iter, double M) {
    double meas, expv, se_an, se_emp;
    uint32_t nb;
    mean_ses(img, expected, w, ch, x0, y0, x1, y1, n_iter, M, &meas, &expv, &se_an, &se_emp, &nb);
    return fmax(se_an, se_emp);
}

int tu_check_mean_ex(const char *label, const float *img, const double *expected, uint32_t w,
                     int ch, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1,
                     uint32_t n_iter, double M, double z, double sys_rel, tu_mean_result *res) {
    double meas, expv, se_an, se_emp;
    uint32_t nb;
    mean_ses(img, expected, w, ch, x0, y0, x1, y1, n_iter, M, &meas, &expv, &se_an, &se_emp, &nb);
    double sig = fmax(se_an, se_emp);
    /* An empirical SE from nb block means has nb - 1 degrees of freedom: where it is the
       larger, the bound is Student's t quantile at the normal z's two-sided p (with 3
       dof, z = 5 becomes t = 157; with 15, 8.3; with 63, 5.6), not z itself. */
    /* Rule: fewer than 16 blocks and an analytic bound: the bound with the normal z
       (pixels are independent samples; the spread of so few block means is printed, as
       a diagnostic only).  A caller whose pixels share noise (the cache's entries)
       gives at least 16 blocks. */
    if (nb < 16 && se_an > 0) { sig = se_an; }
    int student = se_emp > se_an && !(nb < 16 && se_an > 0);
    double z_eff = student ? tu_student_quantile(tu_normal_cdf(z), (double)nb - 1) : z;
    double bound = z_eff * sig + sys_rel * fabs(expv);
    double diff = meas - expv;
    int ok = isfinite(meas) && fabs(diff) <= bound;
    print_message("    %-44s ch%d measured %.6g expected %.6g diff %+.3g (%+.2f sigma; "
                  "se analytic %.3g empirical %.3g%s) bound %.3g %s\n",
                  label, ch, meas, expv, diff, sig > 0 ? diff / sig : 0.0, se_an, se_emp,
                  student ? (nb < 16 ? ", t quantile, FEW BLOCKS" : ", t quantile") : "",
                  bound, ok ? "ok" : "FAIL");
    if (tu_pool_eligible(student, nb, sys_rel * fabs(expv), sig))
        tu_pool_add(label, meas, expv, sig, img, tu_image_serial, x0, y0, x1, y1);
    tu_power_note_rel(meas, expv, bound, tu_power_rel + sys_rel);
    if (res) { res->measured = meas; res->expected = expv; res->se = sig; }
    return ok;
}

double tu_chi2(const float *img, const double *expected, uint32_t w, uint32_t h, int ch,
               uint32_t n_iter, double M, double z, double *limit) {
    /* Welford's mean and variance of the terms (P up to millions: no drift). */
    double mean = 0, m2 = 0;
    size_t P = (size_t)w * h;
    for (size_t p = 0; p < P; p++) {
        double mu = expected[4 * p + ch], r = img[4 * p + ch] - mu;
        /* The floor keeps a pixel whose expectation is 0 or M from dividing by 0: its
           variance bound is then 1e-4 M^2 / N, looser than the truth only where the
           pixel is exact anyway. */
        double var = fmax(mu * (M - mu), 1e-4 * M * M) / n_iter;
        double term = r * r / var, d = term - mean;
        mean += d / (double)(p + 1);
        m2 += d * (term - mean);
    }
    double s = P > 1 ? sqrt(m2 / (double)(P - 1)) : sqrt(2.0);
    if (limit) *limit = 1 + z * fmax(s, sqrt(2.0)) / sqrt((double)P);
    return mean;
}

int tu_check_chi2(const char *label, const float *img, const double *expected, uint32_t w,
                  uint32_t h, int ch, uint32_t n_iter, double M, double z, const double *perturbed) {
    double limit, red = tu_chi2(img, expected, w, h, ch, n_iter, M, z, &limit);
    double *mirrored = perturbed ? NULL : tu_mirror_x(expected, w, h);
    double power = tu_chi2(img, perturbed ? perturbed : mirrored, w, h, ch, n_iter, M, z, NULL);
    free(mirrored);
    int ok = isfinite(red) && red <= limit, powerful = isfinite(power) && power > limit;
    tu_power_shown(powerful);
    print_message("    %-44s ch%d chi2/P %.4g (limit %.4g, %g SE) %s; against the %s expectation %.4g %s\n",
                  label, ch, red, limit, z, ok ? "ok" : "FAIL", perturbed ? "perturbed" : "mirrored",
                  power, powerful ? "rejected" : "NOT REJECTED: the check has no power here");
    return ok && powerful;
}

double *tu_mirror_x(const double *expected, uint32_t w, uint32_t h) {
    double *m = malloc((size_t)w * h * 4 * sizeof *m);
    assert_non_null(m);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            for (int c = 0; c < 4; c++)
                m[4 * ((size_t)y * w + x) + c] = expected[4 * ((size_t)y * w + (w - 1 - x)) + c];
    return m;
}

/* ---- expected images shared by several tests ---- */


/* Finite sun of half-angle a: uniform radiance L over the cone with
   irradiance on a plane facing the sun = L pi sin^2(a) = E (the header's unit), so
   L = E / (pi sin^2 a) and the in-scattered radiance is L / (4 pi) int_cone T dw.
   The cone integral: 4-point Gauss-Legendre in cos(theta) x 16 midpoints in phi. */
static double cone_transmittance_integral(const tu_sun_scene *s, const double x[3]) {
    static const double gx[4] = {-0.8611363115940526, -0.3399810435848563,
                                 0.3399810435848563, 0.8611363115940526};
    static const double gw[4] = {0.3478548451374538, 0.6521451548625461,
                                 0.6521451548625461, 0.3478548451374538};
    const int nphi = 16;
    double cmin = cos(s->half_angle), sum = 0;
    for (int i = 0; i < 4; i++) {
        double u = 0.5 * (1 + cmin) + 0.5 * (1 - cmin) * gx[i], sn = sqrt(1 - u * u);
        double wu = 0.5 * (1 - cmin) * gw[i];
        for (int j = 0; j < nphi; j++) {
            double ph = 2 * M_PI * (j + 0.5) / nphi, w[3];
            for (int k = 0; k < 3; k++)
                w[k] = u * s->l[k] + sn * (cos(ph) * s->e1[k] + sin(ph) * s->e2[k]);
            sum += wu * (2 * M_PI / nphi) * exp(-s->sigma * tu_box_exit(x, w, s->bmin, s->bmax));
        }
    }
    return sum;
}

static double tu_sun_integrand(double t, void *user) {
    const tu_sun_scene *s = user;
    double x[3] = {s->o[0] + t * s->d[0], s->o[1] + t * s->d[1], s->o[2] + t * s->d[2]};
    double in; /* int over directions of (radiance / E) * T, i.e. in-scatter per unit E */
    if (s->half_angle > 0) {
        double sa = sin(s->half_angle);
        in = cone_transmittance_integral(s, x) / (M_PI * sa * sa);
    } else {
        in = exp(-s->sigma * tu_box_exit(x, s->l, s->bmin, s->bmax));
    }
    return s->sigma * exp(-s->sigma * (t - s->t0)) * in / (4 * M_PI);
}

void tu_sun_ray(const double o[3], const double d[3], void *user, double out[4]) {
    tu_sun_scene s = *(const tu_sun_scene *)user;
    double t0, t1;
    out[0] = out[1] = out[2] = out[3] = 0;
    if (!tu_ray_box(o, d, s.bmin, s.bmax, &t0, &t1)) return;
    memcpy(s.o, o, sizeof s.o);
    memcpy(s.d, d, sizeof s.d);
    s.t0 = t0;
    double J = tu_integrate(tu_sun_integrand, &s, t0, t1, s.half_angle > 0 ? 8 : 64);
    for (int c = 0; c < 3; c++) out[c] = s.albedo[c] * s.E[c] * J;
    out[3] = 1 - exp(-s.sigma * (t1 - t0));
}


void tu_absorption_ray(const double o[3], const double d[3], void *user, double out[4]) {
    const tu_absorption *s = user;
    double t0, t1, T = 1;
    if (tu_ray_box(o, d, s->bmin, s->bmax, &t0, &t1))
        T = exp(-s->D * tu_value_integral(s->vol, o, d, t0, t1));
    out[0] = out[1] = out[2] = T;
    out[3] = 1 - T;
}

/* ---- a point light over a homogeneous box (test_sampling.c, test_robust_sweep.c) ---- */

typedef struct tu_point_ray_state {
    const tu_point_scene *s;
    double o[3], d[3], t0, delta, D;
} tu_point_ray_state;

/* The integrand in theta: t = Delta + D tan theta, dt / |x - p|^2 = dtheta / D. */
static double tu_point_integrand(double theta, void *user) {
    const tu_point_ray_state *r = (const tu_point_ray_state *)user;
    const tu_point_scene *s = r->s;
    double t = r->delta + r->D * tan(theta), x[3];
    for (int i = 0; i < 3; i++) x[i] = r->o[i] + t * r->d[i];
    double in = tu_segment_in_box(x, s->p, s->bmin, s->bmax);
    return s->albedo * s->sigma * exp(-s->sigma * (t - r->t0)) * s->I / (4.0 * M_PI * r->D) * exp(-s->sigma * in);
}

void tu_point_light_ray(const double o[3], const double d[3], void *user, double out[4]) {
    const tu_point_scene *s = (const tu_point_scene *)user;
    double t0, t1;
    out[0] = out[1] = out[2] = out[3] = 0.0;
    if (!tu_ray_box(o, d, s->bmin, s->bmax, &t0, &t1)) return;
    tu_point_ray_state r;
    r.s = s;
    r.t0 = t0;
    double oc[3], perp[3];
    for (int i = 0; i < 3; i++) { r.o[i] = o[i]; r.d[i] = d[i]; oc[i] = s->p[i] - o[i]; }
    r.delta = oc[0] * d[0] + oc[1] * d[1] + oc[2] * d[2];
    for (int i = 0; i < 3; i++) perp[i] = oc[i] - r.delta * d[i];
    r.D = sqrt(perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2]);
    if (r.D < 1e-9) r.D = 1e-9;
    double ta = atan2(t0 - r.delta, r.D), tb = atan2(t1 - r.delta, r.D);
    /* a dense medium: the integrand is below e^-60 beyond 60 mean free paths */
    if (s->sigma * (t1 - t0) > 60.0) tb = atan2(t0 + 60.0 / s->sigma - r.delta, r.D);
    double L = tu_integrate(tu_point_integrand, &r, ta, tb, 64);
    out[0] = out[1] = out[2] = L;
    out[3] = 1.0 - exp(-s->sigma * (t1 - t0));
}

