/* selftest.c - picvr-bench-error --self-test (run by make test and make bench): the
 * harness's arithmetic (equal-time ratios, a reference's mean and error, RMSE), its
 * bookkeeping (which run files are reused, the defaults of its options), its PFM
 * files (the byte order the header declares) and the fingerprint that keys the
 * references (a 16^3 volume at 16x16, rendered on the device).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "bench_error.h"
#include "cli.h"
#include "picvr.h"
#include "presets.h"
#include "picvr_io.h"

static int expect(int ok, const char *what)
{
    if (!ok) pvc_fail("self-test: %s", what);
    return ok;
}

/* Two runs whose errors are 2/sqrt(t) and 1/sqrt(t), sampled at different times: the
   ratio at equal time is 2 (within the interpolation error, < 0.5%). */
static int self_test_ratio(void)
{
    run a = {0}, b = {0};
    int ok = 1;
    for (int i = 1; ok && i <= 50; i++) {
        row x = {0}, y = {0};
        x.t_ms = 200.0 * i;
        y.t_ms = 330.0 * i;
        x.rmse = x.est = 2 / sqrt(x.t_ms);
        y.rmse = y.est = 1 / sqrt(y.t_ms);
        ok = run_push(&a, &x) && run_push(&b, &y);
    }
    double q = ok ? mean_ratio(&a, &b, F_RMSE) : NAN;
    run_free(&a);
    run_free(&b);
    return expect(fabs(q - 2) < 0.01, "mean_ratio of 2/sqrt(t) over 1/sqrt(t) is not 2");
}

/* Two repeats of plain 2/sqrt(t) against a condition at 1/sqrt(t) that, in repeat 0
   only, is 8/sqrt(t) from 4 s to 6 s: the worst time's geometric mean of the ratios is
   sqrt(2/8 * 2/1) = 0.707 (the repeat average keeps one run's dip from being the
   worst alone), everywhere else 2. */
static int self_test_worst(void)
{
    static scene_result r;
    memset(&r, 0, sizeof r);
    int ok = 1;
    for (int k = 0; k < 2; k++)
        for (int i = 1; ok && i <= 50; i++) {
            row x = {0}, y = {0};
            x.t_ms = y.t_ms = 200.0 * i;
            x.rmse = 2 / sqrt(x.t_ms);
            y.rmse = (k == 0 && y.t_ms >= 4000 && y.t_ms <= 6000 ? 8 : 1) / sqrt(y.t_ms);
            ok = run_push(&r.runs[0][k], &x) && run_push(&r.runs[1][k], &y);
        }
    double q = ok ? worst_ratio(&r, 1, 2, F_RMSE) : NAN;
    for (int k = 0; k < 2; k++) { run_free(&r.runs[0][k]); run_free(&r.runs[1][k]); }
    return expect(fabs(q - sqrt(0.5)) < 0.01, "worst_ratio of the dip is not 0.707");
}

/* One pixel, four chunks of n = 10 with means 1, 2, 3, 4: weighted mean 2.5, per-sample
   variance n * sum (m - 2.5)^2 / 3 = 50 / 3, variance of the mean (50/3) / 40. */
static int self_test_reference(void)
{
    reference r = {0};
    double s1 = 0, s2 = 0, lum, var;
    r.width = r.height = 1;
    r.lum = &lum;
    r.var = &var;
    r.chunks = 4;
    r.iterations = 40;
    for (int k = 1; k <= 4; k++) { s1 += 10.0 * k; s2 += 10.0 * k * k; }
    ref_finish(&r, &s1, &s2);
    return expect(fabs(lum - 2.5) < 1e-12, "reference mean") &&
           expect(fabs(var - 50.0 / 3.0 / 40.0) < 1e-12, "reference variance") &&
           expect(fabs(r.rmse - sqrt(50.0 / 3.0 / 40.0)) < 1e-12, "reference RMSE");
}

/* An image equal to the reference but 1 brighter in one pixel of four. */
static int self_test_compare(void)
{
    double ref_lum[4] = {1, 1, 1, 1}, ref_var[4] = {0};
    float lum[4] = {2, 1, 1, 1};
    reference r = {0};
    r.width = 2;
    r.height = 2;
    r.lum = ref_lum;
    r.var = ref_var;
    r.mean_lum = 1;
    errors e = compare(lum, &r);
    int ok = expect(fabs(e.rmse - 0.5) < 1e-12, "RMSE") &&
             expect(fabs(e.rel_rmse - 0.5 / 1.01) < 1e-12, "relative RMSE");
    /* the reference's variance comes off the mean square: (1 - 4 * 0.04) / 4 */
    for (int i = 0; i < 4; i++) ref_var[i] = 0.04;
    e = compare(lum, &r);
    return ok && expect(fabs(e.rmse - sqrt(0.84 / 4)) < 1e-12, "RMSE less the reference's variance");
}

/* Writes a finished one-row run file whose first line is `sig`. */
static int write_test_run(const char *path, const char *sig)
{
    FILE *f = fopen(path, "w");
    if (!f) return 0;
    fprintf(f, "%s\n%s\n200,1,0.1,0.2,0.1,0.2,0.5,0.04,10,100,0\n# done\n", sig, ROW_HEADER);
    return fclose(f) == 0;
}

/* Whether run_load with options o accepts the file at path (freeing what it read). */
static int test_run_loads(const options *o, const char *path, const reference *r)
{
    run x = {0};
    int ok = run_load(o, path, r, &x);
    run_free(&x);
    return ok;
}

/* A run file is reused only by a build and cache options that match its signature. */
static int self_test_signature(void)
{
    char path[PATH_LEN], sig[512];
    snprintf(path, sizeof path, "/tmp/picvr-bench-self-test-%ld.csv", (long)getpid());
    options on = {0}, off = {0}, finer = {0}, smaller = {0};
    on.cache.medium_model = PICVR_SWITCH_ON;
    off.cache.medium_model = PICVR_SWITCH_OFF;
    finer.cache.medium_model = PICVR_SWITCH_ON;
    smaller.cache.medium_model = PICVR_SWITCH_ON;
    int parsed = pvp_cache_param_set(&finer.cache, "gamma=0.05") == PVP_OK &&
                 pvp_cache_param_set(&smaller.cache, "radius_max_voxels=4") == PVP_OK &&
                 finer.cache.gamma == 0.05f && smaller.cache.radius_max_voxels == 4.0f &&
                 pvp_cache_param_set(&finer.cache, "gamma=0") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gamma=") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gamma") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gamma=1e39") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gamma=nan") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gam=0.1") == PVP_ERROR_UNKNOWN_NAME &&
                 pvp_cache_param_set(&finer.cache, "gamma=0.1x") == PVP_ERROR_BAD_ARGUMENT &&
                 finer.cache.gamma == 0.05f;
    reference r = {0};
    r.chunks = 3;
    r.iterations = 300;
    run_signature(&on, &r, sig, sizeof sig);
    int written = write_test_run(path, sig);
    int same = written && test_run_loads(&on, path, &r);
    int other = written && test_run_loads(&off, path, &r);
    int other_gamma = written && test_run_loads(&finer, path, &r);
    int other_radius = written && test_run_loads(&smaller, path, &r);
    /* a file from before the build was part of the signature */
    written = written && write_test_run(path, "# reference 3 chunks 300 iterations");
    int older = written && test_run_loads(&on, path, &r);
    remove(path);
    return expect(written, "cannot write the self-test's run file") &&
           expect(same, "a run file with the same signature is not reused") &&
           expect(!other, "a run file of other cache options is reused") &&
           expect(parsed, "--cache-param is parsed wrongly") &&
           expect(!other_gamma, "a run file of another gamma is reused") &&
           expect(!other_radius, "a run file of another radius_max_voxels is reused") &&
           expect(!older, "a run file without the library's build is reused");
}

/* The fingerprint that keys the references is the same on every call and tells scenes
   apart (a 16^3 sphere of density, 16x16 pixels, so it runs in the test suite). */
static int self_test_fingerprint(void)
{
    enum { N = 16 };
    static uint8_t voxels[N * N * N];
    for (int z = 0; z < N; z++)
        for (int y = 0; y < N; y++)
            for (int x = 0; x < N; x++) {
                double r = sqrt((x - 7.5) * (x - 7.5) + (y - 7.5) * (y - 7.5) + (z - 7.5) * (z - 7.5));
                voxels[(z * N + y) * N + x] = (uint8_t)(r < 6.0 ? 200 - 20 * r : 0);
            }
    picvr_io_volume vol = {{N, N, N}, PICVR_VOXEL_UINT8, {1, 1, 1}, voxels, sizeof voxels};
    dataset_spec ds = {"sphere", "sphere_16x16x16_uint8.raw", "ct-bonsai", 1.0f};
    options o = {0};
    o.width = o.height = 16;
    const float camera[4] = {35, 20, 1, 40};
    scene a, b;
    scene_init(&a, &ds, "paper1", &o, camera);
    scene_init(&b, &ds, "paper3", &o, camera);
    uint64_t fa = 0, fa2 = 1, fb = 0;
    int rendered = plain_fingerprint(&a, &vol, &fa) && plain_fingerprint(&a, &vol, &fa2) &&
                   plain_fingerprint(&b, &vol, &fb);
    return expect(rendered, "the fingerprint render failed") &&
           expect(fa == fa2, "the plain fingerprint differs between two renders") &&
           expect(fa != fb, "two light set-ups have the same plain fingerprint");
}

/* A PFM is written little-endian with scale -1, whatever the host; one that declares
   big-endian (a positive scale) is read as such. */
static int self_test_pfm(void)
{
    char path[PATH_LEN];
    snprintf(path, sizeof path, "/tmp/picvr-bench-self-test-%ld.pfm", (long)getpid());
    const float rgba[8] = {1.0f, 2.0f, 0.5f, 1.0f, -3.0f, 0.25f, 4.0f, 0.0f};
    const unsigned char expected[] = {'P', 'F', '\n', '2', ' ', '1', '\n', '-', '1', '.', '0',
                                      '\n', 0x00, 0x00, 0x80, 0x3f};   /* 1.0f, little-endian */
    unsigned char bytes[sizeof expected] = {0};
    float rgb[6] = {0};
    int written = pvc_write_pfm(path, rgba, 2, 1);
    FILE *f = fopen(path, "rb");
    int header = f && fread(bytes, 1, sizeof bytes, f) == sizeof bytes &&
                 !memcmp(bytes, expected, sizeof bytes);
    if (f) fclose(f);
    int read_le = written && pvc_read_pfm(path, 2, 1, rgb) && rgb[0] == 1.0f &&
                  rgb[2] == 0.5f && rgb[3] == -3.0f && rgb[5] == 4.0f;
    const unsigned char big[] = {'P', 'F', '\n', '1', ' ', '1', '\n', '1', '\n', 0x3f, 0x80, 0,
                                 0, 0x40, 0, 0, 0, 0xbf, 0, 0, 0};  /* 1, 2, -0.5 */
    f = fopen(path, "wb");
    int big_written = f && fwrite(big, 1, sizeof big, f) == sizeof big;
    if (f && fclose(f) != 0) big_written = 0;
    int read_be = big_written && pvc_read_pfm(path, 1, 1, rgb) && rgb[0] == 1.0f &&
                  rgb[1] == 2.0f && rgb[2] == -0.5f;
    remove(path);
    return expect(written && header, "a PFM is not written little-endian with scale -1") &&
           expect(read_le, "a little-endian PFM is read wrongly") &&
           expect(read_be, "a big-endian PFM is read wrongly");
}

/* A reference of two chunks in the older RGB format: loading it gives the chunks'
   iteration-weighted mean luminance, rewrites each chunk as luminance (removing the
   PFM), and loading again from the luminance files gives the same reference. */
static int self_test_chunk_formats(void)
{
    reference r = {0};
    double lum[2], var[2], first[2];
    char path[PATH_LEN];
    r.width = 2;
    r.height = 1;
    r.lum = lum;
    r.var = var;
    snprintf(r.dir, sizeof r.dir, "/tmp/picvr-bench-self-test-ref-%ld", (long)getpid());
    int made = make_dirs(r.dir);
    for (int k = 0; made && k < 2; k++) {
        const float grey = k ? 3.0f : 1.0f;    /* luminance of a grey pixel is its value */
        const float rgba[8] = {grey, grey, grey, 1, 2 * grey, 2 * grey, 2 * grey, 1};
        snprintf(path, sizeof path, "%s/chunk_%u.pfm", r.dir, REF_SEED0 + k);
        made = pvc_write_pfm(path, rgba, 2, 1);
        snprintf(path, sizeof path, "%s/chunk_%u.json", r.dir, REF_SEED0 + k);
        FILE *f = made ? fopen(path, "w") : NULL;
        made = f && fprintf(f, "{\"iterations\": %d}\n", k ? 30 : 10) > 0 && fclose(f) == 0;
    }
    int loaded = made && ref_load(&r) && r.chunks == 2 && r.iterations == 40;
    memcpy(first, lum, sizeof first);
    snprintf(path, sizeof path, "%s/chunk_%u.pfm", r.dir, REF_SEED0);
    int converted = loaded && !file_exists(path);
    snprintf(path, sizeof path, "%s/chunk_%u.lum.gz", r.dir, REF_SEED0 + 1);
    converted = converted && file_exists(path);
    int again = converted && ref_load(&r) && r.chunks == 2 && !memcmp(first, lum, sizeof first);
    for (int k = 0; k < 2; k++) {
        const char *ext[] = {"pfm", "lum.gz", "json"};
        for (int e = 0; e < 3; e++) {
            snprintf(path, sizeof path, "%s/chunk_%u.%s", r.dir, REF_SEED0 + k, ext[e]);
            remove(path);
        }
    }
    rmdir(r.dir);
    return expect(loaded && fabs(first[0] - 2.5) < 1e-6 && fabs(first[1] - 5.0) < 1e-6,
                  "an RGB reference chunk is loaded wrongly") &&
           expect(converted, "an RGB reference chunk is not rewritten as luminance") &&
           expect(again, "a luminance reference chunk does not load as it was written");
}

/* Without options every setting is its documented default (--help). */
static int self_test_defaults(void)
{
    char *argv[] = {PROGRAM, NULL};
    options o;
    char cache[256] = "";
    int parsed = parse_args(1, argv, &o) < 0;
    if (parsed) cache_options_text(&o.cache, cache, sizeof cache);
    return expect(parsed, "no options are refused") &&
           expect(!strcmp(cache, "medium default; curvature default"),
                  "the cache options are not the library's defaults") &&
           expect(o.repeats == 2 && o.ref_min_chunks == 4 && o.ref_max_chunks == 200 && o.run_ms == 10000 &&
                  o.slice_ms == 200 && o.ref_chunk_ms == 60000 && o.warm_ms == 0 &&
                  o.bias_ms == 0 && o.width == 128 && o.height == 128,
                  "the defaults differ from --help");
}

int self_test(void)
{
    int ok = self_test_ratio() & self_test_worst() & self_test_reference() & self_test_compare() &
             self_test_signature() & self_test_defaults() & self_test_pfm() &
             self_test_fingerprint() & self_test_chunk_formats();
    fprintf(stderr, PROGRAM ": self-test %s\n", ok ? "passed" : "FAILED");
    return ok;
}
