/* bench_fig9.c - picvr-bench-fig9: extrapolation accuracy of the paper's seven-point
 * scheme against a single-gradient exponential extrapolation (in the style of Jarosz
 * et al. 2008), as a function of the global density factor D (paper Fig. 9).
 *
 *   picvr-bench-fig9 [--out bench/results] [--entries N]
 *
 * The cache's entries are not exposed by the API, so this runs on the host, in double
 * precision, with the very formulas the shaders use (shaders/cache_math.glsl through
 * reference/cache_math_host.h: Eq. 6 sigma_v, Eq. 7-8 octant extrapolation), on an
 * irradiance field known in closed form:
 *   a homogeneous sphere of radius 64 voxels (spacing 1), sigma_t = D * 0.05 per voxel,
 *   lit by a sun (irradiance 1, direction (1,1,1)/sqrt 3): E_sun(x) = exp(-sigma_t c),
 *   c the chord from x to the sphere's surface toward the sun; with background
 *   (radiance 0.1 from every direction): + integral over the sphere of directions of
 *   0.1 exp(-sigma_t c(x, w)) dw, by a fixed 48 x 96 midpoint quadrature (the same for
 *   every point, so the field is smooth and consistent).
 * Entries: N random centres inside 0.9 R (fixed seed), local frame = the world axes
 * (the extinction gradient vanishes in a homogeneous medium, as in cache_create.comp),
 * Delta = 2 voxels (Table 1).
 *   seven-point: sigma_v per half-axis from E_0 and E(x +- Delta e_i) (Eq. 6), the
 *     prediction at offset p by Eq. 7 with Eq. 8's barycentric sigma (cm_ functions);
 *   single gradient: g = central differences of ln E over the same six points,
 *     ln E(p) = ln E_0 + g . p.
 *   seven-point-euclid (for comparison): the same six sigma_v with Eq. 7's distance
 *     taken as the Euclidean |p| instead of the |x|+|y|+|z| of cache_math.glsl's
 *     length1 (exact only for radial fields).
 * Test points: 16 per entry, uniformly distributed directions, distance uniform in
 * (0, 8] voxels (half the default maximum radius).
 * The sun is either diagonal to the frame or along one of its axes (+y).
 * Error: |E_pred - E| / (E + 1e-3), the floor (1e-3 of the unoccluded sun) keeps
 * points deep in shadow, below the cache's code for zero (1e-30), from dominating.
 * Output: fig9.csv (D, sun, background, scheme, mean and 90th percentile relative error)
 * and fig9.gp (gnuplot, writes fig9.png).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "reference/cache_math_host.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define RADIUS 64.0
#define KAPPA 0.05            /* opacity of the medium: sigma_t = D * KAPPA per voxel */
#define DELTA 2.0
#define TEST_DIST 8.0
#define TESTS_PER_ENTRY 16
#define BG_RADIANCE 0.1
#define N_THETA 48
#define N_PHI 96
#define ERROR_FLOOR 1e-3     /* of the unoccluded sun irradiance 1 */

static const double D_VALUES[] = {0.125, 0.25, 0.5, 1, 2, 4, 8, 16, 32, 64};
#define N_D (int)(sizeof D_VALUES / sizeof D_VALUES[0])

typedef struct v3 { double x, y, z; } v3;

static double dot(v3 a, v3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

/* Distance from x (inside) to the sphere's surface along the unit direction w. */
static double chord(v3 x, v3 w)
{
    double b = dot(x, w), c = dot(x, x) - RADIUS * RADIUS;
    double disc = b * b - c;
    return disc > 0 ? -b + sqrt(disc) : 0;
}

static int g_axis_sun;        /* 1: the sun along +y (a frame axis); 0: diagonal */

static double irradiance(v3 x, double sigma, int background)
{
    const double s = 1.0 / sqrt(3.0);
    v3 sun = {s, s, s};
    if (g_axis_sun) { sun.x = 0; sun.y = 1; sun.z = 0; }
    double e = exp(-sigma * chord(x, sun));
    if (!background) return e;
    double sum = 0;
    for (int i = 0; i < N_THETA; i++) {
        double th = M_PI * (i + 0.5) / N_THETA, st = sin(th), ct = cos(th);
        for (int j = 0; j < N_PHI; j++) {
            double ph = 2 * M_PI * (j + 0.5) / N_PHI;
            v3 w = {st * cos(ph), st * sin(ph), ct};
            sum += exp(-sigma * chord(x, w)) * st;
        }
    }
    return e + BG_RADIANCE * sum * (M_PI / N_THETA) * (2 * M_PI / N_PHI);
}

/* A small fixed-seed generator (splitmix64) for reproducible points. */
static double rnd(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return ((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
}

static v3 random_direction(uint64_t *st)
{
    double z = 2 * rnd(st) - 1, ph = 2 * M_PI * rnd(st), r = sqrt(1 - z * z);
    v3 w = {r * cos(ph), r * sin(ph), z};
    return w;
}

static v3 random_in_ball(uint64_t *st, double radius)
{
    v3 w = random_direction(st);
    double r = radius * cbrt(rnd(st));
    v3 x = {w.x * r, w.y * r, w.z * r};
    return x;
}

typedef struct entry {
    v3 c;
    double e0, ep[3], en[3];  /* E at the centre, at +Delta and -Delta along each axis */
} entry;

static void make_entry(entry *e, v3 c, double sigma, int bg)
{
    e->c = c;
    e->e0 = irradiance(c, sigma, bg);
    for (int i = 0; i < 3; i++) {
        v3 p = c, n = c;
        double *pp = i == 0 ? &p.x : i == 1 ? &p.y : &p.z;
        double *nn = i == 0 ? &n.x : i == 1 ? &n.y : &n.z;
        *pp += DELTA;
        *nn -= DELTA;
        e->ep[i] = irradiance(p, sigma, bg);
        e->en[i] = irradiance(n, sigma, bg);
    }
}

/* The paper's scheme: Eq. 6 per half-axis, Eq. 7-8 in the offset's octant. */
static double predict_seven(const entry *e, v3 p)
{
    double s[3], q[3] = {p.x, p.y, p.z};
    for (int i = 0; i < 3; i++)
        s[i] = q[i] >= 0 ? cm_sigma_v(e->e0, e->ep[i], DELTA) : cm_sigma_v(e->e0, e->en[i], DELTA);
    return exp(cm_log_extrapolate_octant(e->e0, s[0], s[1], s[2], p.x, p.y, p.z));
}

/* The same six sigma_v and Eq. 8, but Eq. 7's distance taken as the Euclidean |p| (for
   comparison with the shaders' |x|+|y|+|z|). */
static double predict_seven_euclid(const entry *e, v3 p)
{
    double s[3], q[3] = {p.x, p.y, p.z};
    for (int i = 0; i < 3; i++)
        s[i] = q[i] >= 0 ? cm_sigma_v(e->e0, e->ep[i], DELTA) : cm_sigma_v(e->e0, e->en[i], DELTA);
    return exp(cm_log_extrapolate(e->e0, cm_sigma_interp(s[0], s[1], s[2], p.x, p.y, p.z),
                                  cm_length3(p.x, p.y, p.z)));
}

/* One gradient of ln E from central differences; exponential extrapolation. */
static double predict_gradient(const entry *e, v3 p)
{
    double q[3] = {p.x, p.y, p.z}, l = log(e->e0);
    for (int i = 0; i < 3; i++) l += (log(e->ep[i]) - log(e->en[i])) / (2 * DELTA) * q[i];
    return exp(l);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static void run_condition(FILE *csv, double D, int bg, int entries)
{
    uint64_t st = 12345;
    double sigma = D * KAPPA;
    int n = entries * TESTS_PER_ENTRY;
    double *err7 = malloc(n * sizeof *err7), *errg = malloc(n * sizeof *errg);
    double *errl = malloc(n * sizeof *errl);
    double sum7 = 0, sumg = 0, suml = 0;
    for (int k = 0; k < entries; k++) {
        entry e;
        make_entry(&e, random_in_ball(&st, 0.9 * RADIUS), sigma, bg);
        for (int t = 0; t < TESTS_PER_ENTRY; t++) {
            v3 w = random_direction(&st);
            double r = TEST_DIST * (1 - rnd(&st));
            v3 p = {w.x * r, w.y * r, w.z * r}, x = {e.c.x + p.x, e.c.y + p.y, e.c.z + p.z};
            double truth = irradiance(x, sigma, bg);
            int i = k * TESTS_PER_ENTRY + t;
            err7[i] = fabs(predict_seven(&e, p) - truth) / (truth + ERROR_FLOOR);
            errg[i] = fabs(predict_gradient(&e, p) - truth) / (truth + ERROR_FLOOR);
            errl[i] = fabs(predict_seven_euclid(&e, p) - truth) / (truth + ERROR_FLOOR);
            suml += errl[i];
            sum7 += err7[i];
            sumg += errg[i];
        }
    }
    qsort(err7, n, sizeof *err7, cmp_double);
    qsort(errg, n, sizeof *errg, cmp_double);
    qsort(errl, n, sizeof *errl, cmp_double);
    const char *sun = g_axis_sun ? "axis" : "diagonal";
    fprintf(csv, "%g,%s,%s,seven-point,%.6g,%.6g,%d\n", D, sun, bg ? "on" : "off", sum7 / n,
            err7[(int)(0.9 * n)], n);
    fprintf(csv, "%g,%s,%s,single-gradient,%.6g,%.6g,%d\n", D, sun, bg ? "on" : "off",
            sumg / n, errg[(int)(0.9 * n)], n);
    fprintf(csv, "%g,%s,%s,seven-point-euclid,%.6g,%.6g,%d\n", D, sun, bg ? "on" : "off",
            suml / n, errl[(int)(0.9 * n)], n);
    fprintf(stderr, "  fig9 D=%-6g sun %-8s background %-3s seven-point %.4f "
            "single-gradient %.4f seven-point-euclid %.4f\n", D, sun, bg ? "on" : "off", sum7 / n,
            sumg / n, suml / n);
    free(err7);
    free(errg);
    free(errl);
}

static void write_gnuplot(const char *dir)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/fig9.gp", dir);
    FILE *f = fopen(path, "w");
    if (!f) return;
    fprintf(f,
        "set terminal pngcairo size 1100,550 font ',10'\nset output 'fig9.png'\n"
        "set datafile separator ','\nset logscale xy\nset grid\nset key top left\n"
        "set xlabel 'density factor D (sigma_t = 0.05 D per voxel)'\n"
        "set ylabel 'mean relative extrapolation error'\n"
        "set title 'Fig. 9: homogeneous sphere (R = 64 voxels), sun +- background, "
        "offsets up to %g voxels'\n"
        "set key outside right\n"
        "f(u,b,s) = sprintf(\"< awk -F, '$2==\\\"%%s\\\" && $3==\\\"%%s\\\" && $4==\\\"%%s\\\"' fig9.csv\", u, b, s)\n"
        , TEST_DIST);
    static const char *suns[2] = {"diagonal", "axis"}, *bgs[2] = {"off", "on"};
    static const char *schemes[3] = {"seven-point", "single-gradient", "seven-point-euclid"};
    fprintf(f, "plot");
    for (int u = 0; u < 2; u++)
        for (int b = 0; b < 2; b++)
            for (int k = 0; k < 3; k++)
                fprintf(f, "%s f('%s','%s','%s') using 1:5 with linespoints lw 2 dt %d lc %d "
                        "title '%s, sun %s%s'", u + b + k ? "," : "", suns[u], bgs[b],
                        schemes[k], 1 + b + 2 * u, 1 + k, schemes[k], suns[u],
                        b ? " + background" : "");
    fprintf(f, "\n");

    fclose(f);
}

static const pvc_option OPTIONS[] = {{"help", 0}, {"out", 1}, {"entries", 1}, {NULL, 0}};

typedef struct options {
    const char *out;          /* --out DIR: where fig9.csv and fig9.gp go */
    int entries;              /* --entries N: cache entries per condition, at least 10 */
} options;

static void usage(FILE *f)
{
    fprintf(f, "usage: picvr-bench-fig9 [--out DIR (default bench/results)] "
               "[--entries N (default 200)]\n");
}

static int apply_option(void *target, const char *name, const char *value)
{
    options *o = target;
    uint32_t n;
    if (!strcmp(name, "out")) o->out = value;
    else if (pvc_parse_u32(value, 0, 1000000, &n)) o->entries = n < 10 ? 10 : (int)n;
    else {
        pvc_bad_value(name, value);
        return 0;
    }
    return 1;
}

int main(int argc, char **argv)
{
    pvc_set_program("picvr-bench-fig9");
    options o = {"bench/results", 200};
    int status = pvc_parse_options(argc, argv, OPTIONS, apply_option, &o, usage);
    if (status >= 0) return status;
    char path[1024];
    snprintf(path, sizeof path, "%s/fig9.csv", o.out);
    FILE *csv = fopen(path, "w");
    if (!csv) { pvc_fail("cannot write %s", path); return 1; }
    fprintf(csv, "D,sun,background,scheme,mean_rel_error,p90_rel_error,points\n");
    for (g_axis_sun = 0; g_axis_sun < 2; g_axis_sun++)
        for (int bg = 0; bg < 2; bg++)
            for (int d = 0; d < N_D; d++)
                run_condition(csv, D_VALUES[d], bg, bg ? o.entries / 4 : o.entries);
    fclose(csv);
    write_gnuplot(o.out);
    fprintf(stderr, "picvr-bench-fig9: wrote %s and fig9.gp\n", path);
    return 0;
}
