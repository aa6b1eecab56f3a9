/* bench_speed.c - picvr-bench-speed: samples/s of the Vulkan kernel against the
 * C/OpenMP reference (reference/cpu_reference.c), side by side on one scene.
 *
 *   picvr-bench-speed --volume bonsai_256x256x256_uint8.raw.gz [--size 512]
 *                     [--iterations-gpu N] [--iterations-cpu N] [--json FILE] [--quick]
 *   picvr-bench-speed --volume FILE --first-step K [--pruning]
 *
 * Scene (fixed, so runs compare): the volume, a transfer function with opacity 0
 * below 0.15 ramping to 1 at 0.4, albedo 0.8, density 1; one sphere area light plus
 * a sky background; a square image seen from a fixed 3/4 view.
 *
 * GPU: the public picvr API; a warm-up (shader compilation, first-touch costs), a
 * calibration that picks N for about 4 s (unless --iterations-gpu), then the timed
 * picvr_step_iterations(ctx, N) (it returns when the device is done).
 * CPU: cref_render() on omp_get_max_threads() threads, timed with CLOCK_MONOTONIC;
 * one untimed iteration picks N for about 2 s (unless --iterations-cpu).
 *
 * --first-step K: the time to the first image instead (the scene's pipelines are made
 * by the first step): K pairs of contexts, one made with config.compile_threads = 1
 * (the calling thread alone), the other with 0 (the processors online), alternating,
 * each timed from picvr_create to the end of its first picvr_step_iterations(ctx, 1)
 * (volume upload included), plain and with the cache (object-space); prints each
 * condition's median and their ratio.  With --pruning the pairs differ in
 * config.kernel_pruning instead (OFF against the default ON, both with compile_threads 0).  Run it with the shader cache warm (a first run
 * of the pair warms it) or cold (MESA_SHADER_CACHE_DISABLE=true).
 *
 * Sanity check: both images' mean luminance must agree within 3 % plus 4 standard
 * errors (the standard error from the CPU's per-pixel sample variance).  Exit status:
 * 0 ok, 1 runtime error, 2 usage error, 3 the two renderers disagree.
 */
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "picvr.h"
#include "reference/cpu_reference.h"
#include "picvr_io.h"

#define PROGRAM "picvr-bench-speed"
#define EXIT_USAGE 2
#define EXIT_MISMATCH 3
#define GPU_TARGET_S 4.0         /* timed GPU run length when N is chosen here */
#define GPU_TARGET_QUICK_S 0.5
#define CPU_TARGET_S 2.0         /* timed CPU run length when its N is chosen here */
#define CPU_TARGET_QUICK_S 0.3
#define REL_TOLERANCE 0.03       /* systematic allowance between the two renderers */

typedef struct options {
    const char *volume_path, *json_path, *device;
    uint32_t width, height;
    uint32_t iterations_gpu;     /* 0: calibrate */
    uint32_t iterations_cpu;     /* 0: calibrate (at least 2) */
    uint32_t seed;
    uint32_t first_step;         /* --first-step K: K pairs; 0: the speed run */
    int pruning;                 /* --pruning: the pairs differ in kernel_pruning */
    int quick;
    int have_size;               /* --size was given (--quick keeps it) */
} options;

typedef struct result {
    uint32_t iterations;
    double seconds, ms_per_iteration, msamples_per_s, mean_luminance, mean_alpha;
    uint64_t truncated;
} result;

/* Seconds of the monotonic clock. */
static double now_s(void) { return pvc_now_ms() * 1e-3; }

static void usage(FILE *f)
{
    fprintf(f,
            "usage: " PROGRAM " --volume FILE [options]\n"
            "  --volume FILE          NAME_XxYxZ_TYPE.raw[.gz] (bonsai_256x256x256_uint8.raw.gz)\n"
            "  --size N | WxH         image size (default 512)\n"
            "  --iterations-gpu N     timed GPU iterations (default: about %.0f s worth)\n"
            "  --iterations-cpu N     timed CPU iterations (default: about %.0f s worth, >= 2)\n"
            "  --seed N               random seed (default 1)\n"
            "  --device NAME          Vulkan device name substring\n"
            "  --json FILE            write the figures as JSON\n"
            "  --quick                smoke run: 128x128, ~%.1f s GPU, ~%.1f s CPU\n"
            "  --first-step K         time to the first image, compile_threads 1 against 0, K pairs\n"
            "  --pruning              with --first-step: kernel_pruning OFF against ON instead\n",
            GPU_TARGET_S, CPU_TARGET_S, GPU_TARGET_QUICK_S, CPU_TARGET_QUICK_S);
}

/* --size N (a square) or WxH. */
static int parse_size(const char *text, uint32_t *w, uint32_t *h)
{
    if (text && !strchr(text, 'x')) {
        if (!pvc_parse_u32(text, 1, PICVR_MAX_IMAGE_SIZE, w)) return 0;
        *h = *w;
        return 1;
    }
    return pvc_parse_size(text, PICVR_MAX_IMAGE_SIZE, w, h);
}

static const pvc_option OPTIONS[] = {
    {"help", 0}, {"quick", 0}, {"volume", 1}, {"json", 1}, {"device", 1}, {"size", 1},
    {"iterations-gpu", 1}, {"iterations-cpu", 1}, {"seed", 1}, {"first-step", 1}, {"pruning", 0}, {NULL, 0}};

/* Applies one option of OPTIONS; returns 0 after reporting a bad value. */
static int apply_option(void *target, const char *name, const char *value)
{
    options *o = target;
    int ok = 1;
    if (!strcmp(name, "quick")) o->quick = 1;
    else if (!strcmp(name, "volume")) o->volume_path = value;
    else if (!strcmp(name, "json")) o->json_path = value;
    else if (!strcmp(name, "device")) o->device = value;
    else if (!strcmp(name, "size")) ok = o->have_size = parse_size(value, &o->width, &o->height);
    else if (!strcmp(name, "iterations-gpu")) ok = pvc_parse_u32(value, 1, 1000000, &o->iterations_gpu);
    else if (!strcmp(name, "iterations-cpu")) ok = pvc_parse_u32(value, 1, 1000000, &o->iterations_cpu);
    else if (!strcmp(name, "seed")) ok = pvc_parse_u32(value, 0, UINT32_MAX, &o->seed);
    else if (!strcmp(name, "first-step")) ok = pvc_parse_u32(value, 1, 1000, &o->first_step);
    else if (!strcmp(name, "pruning")) o->pruning = 1;
    if (!ok) pvc_bad_value(name, value);
    return ok;
}

/* Returns -1 to go on, else the exit status (0 after --help, EXIT_USAGE). */
static int parse_args(int argc, char **argv, options *o)
{
    memset(o, 0, sizeof *o);
    o->width = o->height = 512;
    o->seed = 1;
    int status = pvc_parse_options(argc, argv, OPTIONS, apply_option, o, usage);
    if (status >= 0) return status;
    if (!o->volume_path) {
        pvc_fail("--volume is required");
        return EXIT_USAGE;
    }
    if (o->quick && !o->have_size) o->width = o->height = 128;
    if (o->iterations_cpu == 1) o->iterations_cpu = 2;   /* a sample variance needs 2 */
    return -1;
}

/* ---- the fixed scene ------------------------------------------------------------- */

static const picvr_tf_point bench_tf[] = {
    {0.00f, {0.8f, 0.8f, 0.8f}, 0.0f},
    {0.15f, {0.8f, 0.8f, 0.8f}, 0.0f},
    {0.40f, {0.8f, 0.8f, 0.8f}, 1.0f},
    {1.00f, {0.8f, 0.8f, 0.8f}, 1.0f},
};
#define BENCH_TF_COUNT 4u
#define BENCH_DENSITY 1.0f

/* Positions scale with the box's half-diagonal so any volume is framed alike
   (for bonsai, R = 221.7: the light sits ~1.8 R from the centre, the camera ~2.9 R). */
static void bench_lights(float R, picvr_light *sphere, picvr_background *sky)
{
    memset(sky, 0, sizeof *sky);   /* no environment map */
    memset(sphere, 0, sizeof *sphere);
    sphere->type = PICVR_LIGHT_SPHERE;
    sphere->position[0] = 1.0f * R; sphere->position[1] = 1.3f * R; sphere->position[2] = 0.7f * R;
    sphere->radius = 0.25f * R;
    sphere->color[0] = 1.0f; sphere->color[1] = 0.92f; sphere->color[2] = 0.8f;
    sphere->intensity = 60.0f;   /* irradiance at the centre ~ 60 pi (0.25/1.8)^2 = 3.6 */
    sky->color[0] = 0.35f; sky->color[1] = 0.45f; sky->color[2] = 0.6f;
    sky->intensity = 0.6f;
}

static void bench_camera(float R, uint32_t w, uint32_t h, picvr_camera *cam)
{
    memset(cam, 0, sizeof *cam);
    cam->position[0] = 1.7f * R; cam->position[1] = 1.1f * R; cam->position[2] = 2.0f * R;
    cam->up[1] = 1.0f;
    cam->fov_y_degrees = 40.0f;
    cam->width = w; cam->height = h;
}

/* ---- statistics ----------------------------------------------------------------- */

static double luminance_f(const float *p)
{
    return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
}

static void image_means(const float *rgba, size_t n, double *lum, double *alpha)
{
    double s = 0.0, a = 0.0;
    for (size_t i = 0; i < n; i++) { s += luminance_f(rgba + 4 * i); a += rgba[4 * i + 3]; }
    *lum = n ? s / (double)n : 0.0;
    *alpha = n ? a / (double)n : 0.0;
}

/* Variance of the image-mean luminance with k samples per pixel, from the CPU's
   per-pixel M2 over n_cpu samples: sum_p S_p^2 / (k P^2). */
static double mean_variance(const double *m2, size_t n, uint32_t n_cpu, uint32_t k)
{
    double v = 0.0;
    for (size_t i = 0; i < n; i++) v += m2[i] / (double)(n_cpu - 1);  /* n_cpu >= 2 */
    return v / ((double)k * (double)n * (double)n);
}

/* ---- the two runs ---------------------------------------------------------------- */

/* The figures of a timed run of n iterations of an npix-pixel image img (RGBA). */
static void set_result(result *r, uint32_t n, double secs, uint64_t truncated, const float *img,
                       size_t npix)
{
    r->iterations = n;
    r->seconds = secs;
    r->ms_per_iteration = 1e3 * secs / n;
    r->msamples_per_s = secs > 0.0 ? (double)npix * n / secs * 1e-6 : 0.0;
    r->truncated = truncated;
    image_means(img, npix, &r->mean_luminance, &r->mean_alpha);
}

/* Seconds for n iterations (picvr_step_iterations returns after the device is done). */
/* The fixed scene into ctx: volume, transfer function, the light and sky, the camera. */
static int set_scene(picvr_context *ctx, const picvr_volume_desc *vol, const picvr_light *light,
                     const picvr_background *sky, const picvr_camera *cam)
{
    return pvc_check(picvr_upload_volume(ctx, vol), "picvr_upload_volume") &&
           pvc_check(picvr_set_transfer_function(ctx, bench_tf, BENCH_TF_COUNT, BENCH_DENSITY),
                     "picvr_set_transfer_function") &&
           pvc_check(picvr_set_lights(ctx, light, 1, sky), "picvr_set_lights") &&
           pvc_check(picvr_set_camera(ctx, cam), "picvr_set_camera");
}

static int gpu_time(picvr_context *ctx, uint32_t n, double *seconds)
{
    double t0 = now_s();
    if (!pvc_check(picvr_step_iterations(ctx, n), "picvr_step_iterations")) return 0;
    *seconds = now_s() - t0;
    return 1;
}

static int run_gpu(const options *o, const picvr_volume_desc *vol, const picvr_light *light,
                   const picvr_background *sky, const picvr_camera *cam, result *r,
                   char device_name[256])
{
    picvr_config cfg = {0};
    cfg.seed = o->seed;
    cfg.device_name = o->device;
    picvr_context *ctx = NULL;
    if (!pvc_check(picvr_create(&cfg, &ctx), "picvr_create")) return 0;
    int ok = set_scene(ctx, vol, light, sky, cam);
    double secs = 0.0;
    /* warm-up: pipeline compilation and first-touch costs stay out of the timing */
    ok = ok && gpu_time(ctx, 3, &secs);
    uint32_t n = o->iterations_gpu;
    if (ok && n == 0) {
        /* calibrate: double k until a batch takes >= 0.25 s (bounded), then scale */
        double target = o->quick ? GPU_TARGET_QUICK_S : GPU_TARGET_S;
        uint32_t k = 1;
        for (int round = 0; ok && round < 20; round++) {
            ok = gpu_time(ctx, k, &secs);
            if (secs >= 0.25 || secs >= target || k >= (1u << 19)) break;
            k *= 2;
        }
        double per = secs / k;              /* k >= 1 */
        double want = per > 0.0 ? target / per : 1e6;
        n = want < 1.0 ? 1u : want > 1e6 ? 1000000u : (uint32_t)want;
    }
    ok = ok && pvc_check(picvr_reset(ctx), "picvr_reset") && gpu_time(ctx, n, &secs);
    picvr_stats st;
    memset(&st, 0, sizeof st);
    ok = ok && pvc_check(picvr_get_stats(ctx, &st), "picvr_get_stats");
    size_t npix = (size_t)cam->width * cam->height;
    float *img = ok ? malloc(npix * 16) : NULL;
    if (ok && !img) { pvc_fail("out of memory"); ok = 0; }
    ok = ok && pvc_check(picvr_read_rgba32f(ctx, img, npix * 16), "picvr_read_rgba32f");
    if (ok) {
        set_result(r, n, secs, st.truncated_paths, img, npix);
        snprintf(device_name, 256, "%s", st.device_name);
        if (st.iterations != n)
            fprintf(stderr, PROGRAM ": warning: stats report %u iterations, expected %u\n",
                    st.iterations, n);
    }
    free(img);
    picvr_destroy(ctx);
    return ok;
}

/* --first-step: seconds from picvr_create to the end of the first one-iteration step. */
static int first_step_time(const options *o, const picvr_volume_desc *vol, const picvr_light *light,
                           const picvr_background *sky, const picvr_camera *cam, uint32_t threads,
                           picvr_switch pruning, int cached, double *seconds)
{
    picvr_config cfg = {0};
    cfg.seed = o->seed;
    cfg.device_name = o->device;
    cfg.compile_threads = threads;
    cfg.kernel_pruning = pruning;
    cfg.cache.mode = cached ? PICVR_CACHE_OBJECT_SPACE : PICVR_CACHE_NONE;
    picvr_context *ctx = NULL;
    double t0 = now_s();
    if (!pvc_check(picvr_create(&cfg, &ctx), "picvr_create")) return 0;
    int ok = set_scene(ctx, vol, light, sky, cam) &&
             pvc_check(picvr_step_iterations(ctx, 1), "picvr_step_iterations");
    *seconds = now_s() - t0;
    picvr_destroy(ctx);
    return ok;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* --first-step K: plain, then cached; the two thread settings alternate so that both
   see the machine's load alike. */
static int run_first_step(const options *o, const picvr_volume_desc *vol, const picvr_light *light,
                          const picvr_background *sky, const picvr_camera *cam)
{
    uint32_t k = o->first_step;
    double *t = malloc(2 * (size_t)k * sizeof *t);
    if (!t) { pvc_fail("out of memory"); return 0; }
    int ok = 1;
    for (int cached = 0; cached < 2 && ok; cached++) {
        /* condition a (one thread, or pruning off) against b (the defaults) */
        uint32_t threads_a = o->pruning ? 0u : 1u;
        picvr_switch pruning_a = o->pruning ? PICVR_SWITCH_OFF : PICVR_SWITCH_DEFAULT;
        for (uint32_t i = 0; i < k && ok; i++)
            ok = first_step_time(o, vol, light, sky, cam, threads_a, pruning_a, cached, &t[i]) &&
                 first_step_time(o, vol, light, sky, cam, 0u, PICVR_SWITCH_DEFAULT, cached, &t[k + i]);
        if (!ok) break;
        qsort(t, k, sizeof *t, cmp_double);
        qsort(t + k, k, sizeof *t, cmp_double);
        double one = t[k / 2], all = t[k + k / 2];
        if (o->pruning)
            printf("first image, %s: kernel_pruning OFF %.3f s, ON %.3f s (medians of %u): %.2fx\n",
                   cached ? "cached" : "plain", one, all, k, all > 0.0 ? one / all : 0.0);
        else
            printf("first image, %s: compile_threads 1 %.3f s, 0 (processors online) %.3f s "
                   "(medians of %u): %.2fx\n", cached ? "cached" : "plain", one, all, k,
                   all > 0.0 ? one / all : 0.0);
    }
    free(t);
    return ok;
}

static int run_cpu(const options *o, const picvr_volume_desc *vol, const picvr_light *light,
                   const picvr_background *sky, const picvr_camera *cam, result *r,
                   double **m2_out)
{
    cref_scene s;
    int st = cref_scene_init(&s, vol, bench_tf, BENCH_TF_COUNT, BENCH_DENSITY, light, 1, sky,
                             cam, o->seed);
    if (st != PICVR_OK) return pvc_check((picvr_status)st, "cref_scene_init");
    size_t npix = (size_t)cam->width * cam->height;
    float *img = malloc(npix * 4 * sizeof *img);
    double *m2 = malloc(npix * sizeof *m2);
    int ok = img && m2;
    if (!ok) pvc_fail("out of memory");
    cref_render_stats rs;
    uint32_t n = o->iterations_cpu;
    double t0, secs = 0.0;
    if (ok && n == 0) {
        /* calibrate with one iteration (also warms caches and the thread pool) */
        double target = o->quick ? CPU_TARGET_QUICK_S : CPU_TARGET_S;
        t0 = now_s();
        ok = pvc_check((picvr_status)cref_render_ex(&s, 0, 1, img, NULL, NULL), "cref_render");
        secs = now_s() - t0;
        double want = secs > 0.0 ? target / secs : 1000.0;
        n = want < 2.0 ? 2u : want > 1000.0 ? 1000u : (uint32_t)want;
    }
    t0 = now_s();
    ok = ok && pvc_check((picvr_status)cref_render_ex(&s, 0, n, img, m2, &rs), "cref_render");
    secs = now_s() - t0;
    if (ok) {
        set_result(r, n, secs, rs.truncated_paths, img, npix);
        if (rs.majorant_violations)
            fprintf(stderr, PROGRAM ": warning: %llu majorant violations in the CPU reference\n",
                    (unsigned long long)rs.majorant_violations);
        *m2_out = m2;
        m2 = NULL;
    }
    free(img);
    free(m2);
    cref_free(&s);
    return ok;
}

/* ---- output ---------------------------------------------------------------------- */

static void json_result(FILE *f, const char *name, const result *r)
{
    fprintf(f,
            "  \"%s\": {\"iterations\": %u, \"seconds\": %.6f, \"ms_per_iteration\": %.4f, "
            "\"msamples_per_s\": %.4f, \"mean_luminance\": %.8g, \"mean_alpha\": %.6f, "
            "\"truncated_paths\": %llu},\n",
            name, r->iterations, r->seconds, r->ms_per_iteration, r->msamples_per_s,
            r->mean_luminance, r->mean_alpha, (unsigned long long)r->truncated);
}

static int write_json(const options *o, const char *device, int threads, const result *g,
                      const result *c, double ratio, double rel_diff, double rel_sigma, int agree)
{
    FILE *f = fopen(o->json_path, "w");
    if (!f) { pvc_fail("cannot write %s", o->json_path); return 0; }
    fprintf(f, "{\n  \"program\": \"" PROGRAM "\",\n  \"volume\": ");
    pvc_json_string(f, o->volume_path);
    fprintf(f, ",\n  \"device\": ");
    pvc_json_string(f, device);
    fprintf(f, ",\n  \"cpu_threads\": %d,\n  \"width\": %u,\n  \"height\": %u,\n  \"seed\": %u,\n"
               "  \"quick\": %s,\n",
            threads, o->width, o->height, o->seed, o->quick ? "true" : "false");
    json_result(f, "gpu", g);
    json_result(f, "cpu", c);
    fprintf(f, "  \"speedup_gpu_over_cpu\": %.4f,\n  \"luminance_rel_diff\": %.6f,\n"
               "  \"luminance_rel_sigma\": %.6f,\n  \"agree\": %s\n}\n",
            ratio, rel_diff, rel_sigma, agree ? "true" : "false");
    int ok = !ferror(f);
    if (fclose(f) != 0) ok = 0;
    if (!ok) pvc_fail("cannot write %s", o->json_path);
    return ok;
}

static void print_result(const char *name, const result *r, uint32_t w, uint32_t h)
{
    printf("%-4s %6u iterations in %7.3f s: %9.3f ms per %ux%u iteration, %9.3f Msamples/s, "
           "mean luminance %.6f (alpha %.4f), truncated %llu\n",
           name, r->iterations, r->seconds, r->ms_per_iteration, w, h, r->msamples_per_s,
           r->mean_luminance, r->mean_alpha, (unsigned long long)r->truncated);
}

int main(int argc, char **argv)
{
    pvc_set_program(PROGRAM);
    options o;
    int status = parse_args(argc, argv, &o);
    if (status >= 0) {
        if (status) usage(stderr);
        return status;
    }

    char err[256];
    picvr_io_volume vol;
    if (picvr_io_load(o.volume_path, NULL, &vol, err, sizeof err) != PICVR_IO_OK) {
        pvc_fail("%s", err);
        return 1;
    }
    picvr_volume_desc desc;
    picvr_io_to_desc(&vol, &desc);
    double hx = 0.5 * vol.dims[0] * vol.spacing[0], hy = 0.5 * vol.dims[1] * vol.spacing[1];
    double hz = 0.5 * vol.dims[2] * vol.spacing[2];
    float R = (float)sqrt(hx * hx + hy * hy + hz * hz);   /* box half-diagonal */

    picvr_light light;
    picvr_background sky;
    picvr_camera cam;
    bench_lights(R, &light, &sky);
    bench_camera(R, o.width, o.height, &cam);

    int threads = omp_get_max_threads();
    printf(PROGRAM ": %s (%ux%ux%u %s), %ux%u image%s\n", o.volume_path, vol.dims[0],
           vol.dims[1], vol.dims[2], picvr_io_type_name(vol.type), o.width, o.height,
           o.quick ? ", quick" : "");
    fflush(stdout);

    if (o.first_step) {
        int done = run_first_step(&o, &desc, &light, &sky, &cam);
        picvr_io_free(&vol);
        return done ? 0 : 1;
    }

    result g, c;
    memset(&g, 0, sizeof g);
    memset(&c, 0, sizeof c);
    char device[256] = "";
    double *m2 = NULL;
    int ok = run_gpu(&o, &desc, &light, &sky, &cam, &g, device);
    if (ok) {
        printf("GPU device: %s\n", device);
        print_result("GPU", &g, o.width, o.height);
        fflush(stdout);
    }
    ok = ok && run_cpu(&o, &desc, &light, &sky, &cam, &c, &m2);
    picvr_io_free(&vol);
    if (!ok) { free(m2); return 1; }
    printf("CPU threads: %d\n", threads);
    print_result("CPU", &c, o.width, o.height);

    size_t npix = (size_t)o.width * o.height;
    double ratio = c.ms_per_iteration > 0.0 && g.ms_per_iteration > 0.0
                 ? c.ms_per_iteration / g.ms_per_iteration : 0.0;
    /* relative difference of the mean luminance, and its standard error from the
       CPU's per-pixel variance (the GPU's variance taken equal per sample) */
    double var = mean_variance(m2, npix, c.iterations, c.iterations) +
                 mean_variance(m2, npix, c.iterations, g.iterations);
    free(m2);
    double denom = c.mean_luminance > 1e-12 ? c.mean_luminance : 1e-12;  /* rule: no /0 */
    double rel_diff = (g.mean_luminance - c.mean_luminance) / denom;
    double rel_sigma = sqrt(var) / denom;
    int agree = fabs(rel_diff) <= REL_TOLERANCE + 4.0 * rel_sigma;
    printf("speed-up GPU/CPU: %.2fx (GPU %.3f vs CPU %.3f Msamples/s)\n", ratio,
           g.msamples_per_s, c.msamples_per_s);
    printf("mean luminance: GPU %.6f, CPU %.6f, relative difference %+.4f "
           "(standard error %.4f, tolerance %.4f): %s\n",
           g.mean_luminance, c.mean_luminance, rel_diff, rel_sigma,
           REL_TOLERANCE + 4.0 * rel_sigma, agree ? "agree" : "DISAGREE");
    if (o.json_path && !write_json(&o, device, threads, &g, &c, ratio, rel_diff, rel_sigma, agree))
        return 1;
    return agree ? 0 : EXIT_MISMATCH;
}
