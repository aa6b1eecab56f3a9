/* cpu_reference.c - plain C11 + OpenMP reference of picvr's per-pixel algorithm.
 * See cpu_reference.h for what it computes and the choices it makes; picvr.h
 * CONVENTIONS for the definitions (world space, sampling, camera, units).
 *
 * Numerics: everything geometric is double; voxels are floats in [0,1].  Every
 * division, log and sqrt carries a comment with the rule that keeps it finite.
 * All loops are bounded (CREF_MAX_STEPS tentative collisions per tracked ray, the
 * DDA by the number of bricks a line can cross, binary searches by log2(count)).
 */
#include "cpu_reference.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#define PI 3.14159265358979323846
#define INV_4PI (1.0 / (4.0 * PI))   /* isotropic phase function = its sampling pdf */

/* ==== small vector helpers ========================================================= */

static inline double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void cross3(const double a[3], const double b[3], double out[3])
{
    double c0 = a[1] * b[2] - a[2] * b[1];
    double c1 = a[2] * b[0] - a[0] * b[2];
    double c2 = a[0] * b[1] - a[1] * b[0];
    out[0] = c0; out[1] = c1; out[2] = c2;
}

static inline void sub3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[0] - b[0]; out[1] = a[1] - b[1]; out[2] = a[2] - b[2];
}

/* out = o + t d */
static inline void ray_at(const double o[3], const double d[3], double t, double out[3])
{
    out[0] = o[0] + t * d[0]; out[1] = o[1] + t * d[1]; out[2] = o[2] + t * d[2];
}

/* Normalizes v in place; returns its old length.  Rule: a zero (or non-finite)
   vector is left unchanged and 0 is returned, so callers test the result. */
static inline double normalize3(double v[3])
{
    double len = sqrt(dot3(v, v));          /* sqrt of a sum of squares: >= 0 */
    if (!(len > 0.0) || !isfinite(len)) return 0.0;
    v[0] /= len; v[1] /= len; v[2] /= len;  /* len > 0 checked above */
    return len;
}

/* Orthonormal basis around the unit vector n (Duff et al. 2017, "Building an
   orthonormal basis, revisited"): no branch on a threshold, no normalization. */
static void onb(const double n[3], double b1[3], double b2[3])
{
    double sign = n[2] >= 0.0 ? 1.0 : -1.0;
    double a = -1.0 / (sign + n[2]);        /* |sign + n.z| >= 1: same signs */
    double b = n[0] * n[1] * a;
    b1[0] = 1.0 + sign * n[0] * n[0] * a; b1[1] = sign * b; b1[2] = -sign * n[0];
    b2[0] = b; b2[1] = sign + n[1] * n[1] * a; b2[2] = -n[1];
}

/* Direction at polar angle acos(cos_t) and azimuth phi around the unit axis. */
static void dir_around(const double axis[3], double cos_t, double sin_t, double phi,
                       double out[3])
{
    double b1[3], b2[3];
    onb(axis, b1, b2);
    double c = cos(phi) * sin_t, s = sin(phi) * sin_t;
    for (int k = 0; k < 3; k++) out[k] = c * b1[k] + s * b2[k] + cos_t * axis[k];
}

double cref_luminance(const double rgb[3])
{
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

/* ==== random numbers =============================================================== */

/* Counter-based: the stream of a sample is a hash of (seed, pixel, iteration); draw k
   is a hash of (stream key, k).  splitmix64's finalizer passes BigCrush as a counter
   hash and needs no state beyond the counter. */
typedef struct rng_t {
    uint64_t key;
    uint64_t dim;
} rng_t;

static inline uint64_t mix64(uint64_t z)
{
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static inline rng_t rng_make(uint32_t seed, uint64_t pixel, uint64_t iteration)
{
    rng_t r;
    r.key = mix64(mix64(mix64((uint64_t)seed) ^ pixel) ^ (iteration * 0xD6E8FEB86659FD93ull));
    r.dim = 0;
    return r;
}

/* Uniform in [0, 1 - 2^-53]: 1 - u > 0 always, so log(1 - u) is finite. */
static inline double rng_next(rng_t *r)
{
    uint64_t h = mix64(r->key ^ (++r->dim * 0xD1B54A32D192ED03ull));
    return (double)(h >> 11) * 0x1.0p-53;
}

/* Exponential free path for majorant m > 0 (caller checks).  -log1p(-u) is finite
   because u <= 1 - 2^-53. */
static inline double exp_step(rng_t *r, double m)
{
    return -log1p(-rng_next(r)) / m;
}

/* ==== transfer function ============================================================ */

/* Largest i with tf[i].value <= v, or -1 if v < tf[0].value.  Bounded binary search. */
static int tf_segment(const picvr_tf_point *tf, uint32_t count, double v)
{
    if (v < tf[0].value) return -1;
    uint32_t lo = 0, hi = count - 1;        /* invariant: tf[lo].value <= v */
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo + 1) / 2;
        if (tf[mid].value <= v) lo = mid; else hi = mid - 1;
    }
    return (int)lo;
}

double cref_tf_eval(const picvr_tf_point *tf, uint32_t count, double v, double albedo[3])
{
    return cref_tf_eval_ex(tf, count, v, albedo, NULL);
}

double cref_tf_eval_ex(const picvr_tf_point *tf, uint32_t count, double v, double albedo[3],
                       double *g)
{
    if (!(v >= 0.0)) v = 0.0;               /* also maps NaN to 0 */
    if (v > 1.0) v = 1.0;
    int i = tf_segment(tf, count, v);
    const picvr_tf_point *a, *b;
    double t;
    if (i < 0) {                            /* before the first point: constant */
        a = b = &tf[0]; t = 0.0;
    } else if ((uint32_t)i == count - 1) {  /* at or after the last point: constant */
        a = b = &tf[count - 1]; t = 0.0;
    } else {
        a = &tf[i]; b = &tf[i + 1];
        /* tf[i].value <= v < tf[i+1].value, so the denominator is > 0 */
        t = (v - a->value) / ((double)b->value - a->value);
    }
    if (albedo)
        for (int k = 0; k < 3; k++)
            albedo[k] = a->albedo[k] + t * ((double)b->albedo[k] - a->albedo[k]);
    if (g) *g = a->g + t * ((double)b->g - a->g);
    return a->opacity + t * ((double)b->opacity - a->opacity);
}

double cref_tf_max_opacity(const picvr_tf_point *tf, uint32_t count, double lo, double hi)
{
    if (lo > hi) { double t = lo; lo = hi; hi = t; }
    double m = cref_tf_eval(tf, count, lo, NULL);
    double mh = cref_tf_eval(tf, count, hi, NULL);
    if (mh > m) m = mh;
    /* closed interval: a step exactly at lo also contributes its lower side (which
       only makes the bound looser, never wrong) */
    for (uint32_t i = 0; i < count; i++)
        if (tf[i].value >= lo && tf[i].value <= hi && tf[i].opacity > m) m = tf[i].opacity;
    return m;
}

/* ==== volume sampling ============================================================== */

static inline float voxel(const cref_scene *s, int x, int y, int z)
{
    return s->voxels[(size_t)x + (size_t)s->dims[0] * ((size_t)y + (size_t)s->dims[1] * (size_t)z)];
}

/* Trilinear, clamp-to-edge (picvr.h "Sampling": voxel i's centre at p = i + 0.5). */
static inline double sample_value(const cref_scene *s, const double x[3])
{
    int i0[3], i1[3];
    double f[3];
    for (int a = 0; a < 3; a++) {
        int n = (int)s->dims[a];
        double q = (x[a] - s->box_min[a]) * s->inv_spacing[a] - 0.5;
        /* clamp before the int conversion (no overflow, NaN -> -1); beyond [-1, n]
           clamp-to-edge gives the edge voxel anyway */
        if (!(q > -1.0)) q = -1.0;
        if (q > (double)n) q = (double)n;
        double fl = floor(q);
        int i = (int)fl;
        f[a] = q - fl;
        i0[a] = i < 0 ? 0 : (i > n - 1 ? n - 1 : i);
        i1[a] = i + 1 < 0 ? 0 : (i + 1 > n - 1 ? n - 1 : i + 1);
    }
    /* a + t (b - a): exact when a == b, so a constant region stays exactly constant */
    double c00 = voxel(s, i0[0], i0[1], i0[2]), c10 = voxel(s, i1[0], i0[1], i0[2]);
    double c01 = voxel(s, i0[0], i1[1], i0[2]), c11 = voxel(s, i1[0], i1[1], i0[2]);
    double d00 = voxel(s, i0[0], i0[1], i1[2]), d10 = voxel(s, i1[0], i0[1], i1[2]);
    double d01 = voxel(s, i0[0], i1[1], i1[2]), d11 = voxel(s, i1[0], i1[1], i1[2]);
    double c0 = c00 + f[0] * (c10 - c00), c1 = c01 + f[0] * (c11 - c01);
    double d0 = d00 + f[0] * (d10 - d00), d1 = d01 + f[0] * (d11 - d01);
    double c = c0 + f[1] * (c1 - c0), d = d0 + f[1] * (d1 - d0);
    return c + f[2] * (d - c);
}

double cref_sample_value(const cref_scene *s, const double x[3])
{
    return sample_value(s, x);
}

static inline double sigma_t_at(const cref_scene *s, const double x[3])
{
    return s->density * cref_tf_eval(s->tf, s->tf_count, sample_value(s, x), NULL);
}

double cref_sigma_t(const cref_scene *s, const double x[3])
{
    return sigma_t_at(s, x);
}

/* ==== majorant grid ================================================================ */

/* Smallest float >= x (the grid stores floats; a bound must not round down). */
static float float_up(double x)
{
    float f = (float)x;
    if ((double)f < x) f = nextafterf(f, INFINITY);
    return f;
}

int cref_majorant_build(const float *voxels, const uint32_t dims[3],
                        const picvr_tf_point *tf, uint32_t tf_count, double density,
                        uint32_t brick, cref_majorant *out)
{
    if (!voxels || !dims || !tf || !out) return PICVR_ERROR_NULL_POINTER;
    memset(out, 0, sizeof *out);
    if (brick == 0 || tf_count == 0 || !(density >= 0.0)) return PICVR_ERROR_INVALID_ARGUMENT;
    if (!dims[0] || !dims[1] || !dims[2]) return PICVR_ERROR_INVALID_DIMENSIONS;
    uint32_t g[3];
    for (int a = 0; a < 3; a++) g[a] = (dims[a] + brick - 1) / brick;  /* brick >= 1 */
    size_t n = (size_t)g[0] * g[1] * g[2];
    float *m = malloc(n * sizeof *m);
    if (!m) return PICVR_ERROR_OUT_OF_HOST_MEMORY;

    /* Trilinear interpolation at voxel coordinate p in brick b's span [bB, bB+B)
       reads voxels floor(p - 0.5) .. floor(p - 0.5) + 1, i.e. bB-1 .. bB+B: a
       1-voxel apron.  The interpolated value lies in [min, max] of those voxels, and
       the opacity's max over that interval is exact for a piecewise-linear TF. */
    long gz = (long)g[2];
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (long bz = 0; bz < gz; bz++) {
        for (uint32_t by = 0; by < g[1]; by++) {
            for (uint32_t bx = 0; bx < g[0]; bx++) {
                long lo[3], hi[3];
                long b3[3] = {bx, by, bz};
                for (int a = 0; a < 3; a++) {
                    lo[a] = b3[a] * (long)brick - 1;
                    hi[a] = b3[a] * (long)brick + (long)brick;
                    if (lo[a] < 0) lo[a] = 0;
                    if (hi[a] > (long)dims[a] - 1) hi[a] = (long)dims[a] - 1;
                }
                float vmin = INFINITY, vmax = -INFINITY;
                for (long z = lo[2]; z <= hi[2]; z++)
                    for (long y = lo[1]; y <= hi[1]; y++) {
                        const float *row = voxels + (size_t)dims[0] * ((size_t)y + (size_t)dims[1] * (size_t)z);
                        for (long x = lo[0]; x <= hi[0]; x++) {
                            if (row[x] < vmin) vmin = row[x];
                            if (row[x] > vmax) vmax = row[x];
                        }
                    }
                double sig = density * cref_tf_max_opacity(tf, tf_count, vmin, vmax);
                m[(size_t)bx + (size_t)g[0] * ((size_t)by + (size_t)g[1] * (size_t)bz)] = float_up(sig);
            }
        }
    }
    out->brick = brick;
    memcpy(out->dims, g, sizeof g);
    out->sigma_max = m;
    return PICVR_OK;
}

void cref_majorant_free(cref_majorant *m)
{
    if (!m) return;
    free(m->sigma_max);
    memset(m, 0, sizeof *m);
}

/* ==== ray / box ===================================================================== */

int cref_intersect_box(const cref_scene *s, const double o[3], const double d[3],
                       double *t0_out, double *t1_out)
{
    double t0 = -INFINITY, t1 = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            /* parallel to the slab: inside it or a miss (no division by 0) */
            if (o[a] < s->box_min[a] || o[a] > s->box_max[a]) return 0;
            continue;
        }
        double inv = 1.0 / d[a];            /* d[a] != 0 */
        double ta = (s->box_min[a] - o[a]) * inv, tb = (s->box_max[a] - o[a]) * inv;
        if (ta > tb) { double t = ta; ta = tb; tb = t; }
        if (ta > t0) t0 = ta;
        if (tb < t1) t1 = tb;
    }
    if (!(t0 <= t1)) return 0;
    *t0_out = t0; *t1_out = t1;
    return 1;
}

/* ==== 3D DDA over the majorant grid ================================================= */

/* Walks the bricks a ray crosses in [t_start, t_end] (world distance along a unit
   direction), one segment [ta, tb] with its majorant per call.  Boundary times are
   recomputed from the origin every step (no accumulated error).  The walk is bounded
   by the number of bricks a line can cross (sum of the grid dims) plus slack. */
typedef struct dda_t {
    const cref_majorant *m;
    double g0[3], dg[3];                    /* brick coordinates at t = 0, per unit t */
    int cell[3], step[3];
    double t, t_end;
    int left;                               /* cells still allowed */
} dda_t;

static void dda_init(dda_t *w, const cref_scene *s, const double o[3], const double d[3],
                     double t_start, double t_end)
{
    const cref_majorant *m = &s->majorant;
    w->m = m;
    w->t = t_start;
    w->t_end = t_end;
    w->left = (int)(m->dims[0] + m->dims[1] + m->dims[2]) + 4;
    double inv_b = 1.0 / (double)m->brick;  /* brick >= 1 */
    for (int a = 0; a < 3; a++) {
        w->g0[a] = (o[a] - s->box_min[a]) * s->inv_spacing[a] * inv_b;
        w->dg[a] = d[a] * s->inv_spacing[a] * inv_b;
        w->step[a] = w->dg[a] > 0.0 ? 1 : (w->dg[a] < 0.0 ? -1 : 0);
        double g = w->g0[a] + t_start * w->dg[a];
        double gmax = (double)m->dims[a] - 1.0;
        /* clamp before the int conversion: rounding may put g just outside */
        if (!(g >= 0.0)) g = 0.0;
        if (g > gmax) g = gmax;
        w->cell[a] = (int)floor(g);
    }
}

/* Next segment; 0 when the walk is over. */
static int dda_next(dda_t *w, double *ta, double *tb, double *maj)
{
    if (!(w->t < w->t_end) || w->left-- <= 0) return 0;
    double t_next = INFINITY;
    int axis = -1;
    for (int a = 0; a < 3; a++) {
        if (w->step[a] == 0) continue;      /* never crosses this axis' planes */
        double boundary = (double)(w->cell[a] + (w->step[a] > 0 ? 1 : 0));
        double tc = (boundary - w->g0[a]) / w->dg[a];   /* dg != 0 when step != 0 */
        if (tc < t_next) { t_next = tc; axis = a; }
    }
    const cref_majorant *m = w->m;
    *maj = m->sigma_max[(size_t)w->cell[0] +
                        (size_t)m->dims[0] * ((size_t)w->cell[1] + (size_t)m->dims[1] * (size_t)w->cell[2])];
    *ta = w->t;
    double end = t_next < w->t_end ? t_next : w->t_end;
    if (end < w->t) end = w->t;             /* rounding at a boundary: empty segment */
    *tb = end;
    w->t = end;
    if (axis >= 0 && t_next < w->t_end) {
        w->cell[axis] += w->step[axis];
        if (w->cell[axis] < 0 || w->cell[axis] >= (int)m->dims[axis]) w->t = w->t_end;
    }
    return 1;
}

/* ==== tracking ====================================================================== */

enum { TRACK_ESCAPED = 0, TRACK_COLLIDED = 1, TRACK_TRUNCATED = 2 };

/* Delta tracking from o along unit d over [t0, t1]: exponential steps against each
   brick's majorant, restarted at the brick's entry (memoryless, so exact).  A
   tentative collision is real with probability sigma_t / majorant.  *budget is what
   is left of the path's free-flight steps (CREF_PATH_STEPS in all); the ray is cut
   (TRACK_TRUNCATED) past CREF_MAX_STEPS of its own or when the budget runs out. */
static int delta_track(const cref_scene *s, const double o[3], const double d[3],
                       double t0, double t1, rng_t *rng, int *budget, double *t_hit,
                       uint64_t *viol)
{
    dda_t w;
    dda_init(&w, s, o, d, t0, t1);
    double ta, tb, m;
    int steps = 0;
    while (dda_next(&w, &ta, &tb, &m)) {
        if (!(m > 0.0)) continue;           /* empty brick: skip it whole */
        double t = ta;
        for (;;) {
            t += exp_step(rng, m);          /* m > 0 */
            if (t >= tb) break;
            if (++steps > CREF_MAX_STEPS || --*budget < 0) return TRACK_TRUNCATED;
            double x[3];
            ray_at(o, d, t, x);
            double sig = sigma_t_at(s, x);
            if (sig > m) (*viol)++;
            if (rng_next(rng) * m < sig) { *t_hit = t; return TRACK_COLLIDED; }
        }
    }
    return TRACK_ESCAPED;
}

/* Ratio tracking: product of (1 - sigma_t / majorant) over tentative collisions.
   Below T = 0.01 an unbiased Russian roulette (survive with probability T / 0.01,
   then weight 0.01) ends hopeless rays early.  *truncated is set when the step bound
   is hit; the estimate so far is returned then (biased high, as on the GPU). */
static double ratio_track(const cref_scene *s, const double o[3], const double d[3],
                          double t0, double t1, rng_t *rng, int *truncated, uint64_t *viol)
{
    dda_t w;
    dda_init(&w, s, o, d, t0, t1);
    double ta, tb, m, T = 1.0;
    int steps = 0;
    while (dda_next(&w, &ta, &tb, &m)) {
        if (!(m > 0.0)) continue;
        double t = ta;
        for (;;) {
            t += exp_step(rng, m);          /* m > 0 */
            if (t >= tb) break;
            if (++steps > CREF_MAX_STEPS) { *truncated = 1; return T; }
            double x[3];
            ray_at(o, d, t, x);
            double sig = sigma_t_at(s, x);
            if (sig > m) { (*viol)++; sig = m; }
            T *= 1.0 - sig / m;             /* m > 0; factor in [0, 1] */
            if (T < 0.01) {
                if (!(T > 0.0) || rng_next(rng) * 0.01 >= T) return 0.0;
                T = 0.01;
            }
        }
    }
    return T;
}

/* Transmittance from a point along unit d up to distance tmax, clipped to the box. */
static double transmittance(const cref_scene *s, const double o[3], const double d[3],
                            double tmax, rng_t *rng, int *truncated, uint64_t *viol)
{
    double t0, t1;
    if (!cref_intersect_box(s, o, d, &t0, &t1)) return 1.0;
    if (t0 < 0.0) t0 = 0.0;
    if (t1 > tmax) t1 = tmax;
    if (!(t0 < t1)) return 1.0;
    return ratio_track(s, o, d, t0, t1, rng, truncated, viol);
}

double cref_transmittance_ratio(const cref_scene *s, const double origin[3],
                                const double dir[3], double tmax, uint64_t sample)
{
    double d[3] = {dir[0], dir[1], dir[2]};
    if (normalize3(d) == 0.0) return 1.0;
    rng_t rng = rng_make(s->seed ^ 0x5A17u, sample, 0xFFFFFFFFull);
    int trunc = 0;
    uint64_t viol = 0;
    return transmittance(s, origin, d, tmax, &rng, &trunc, &viol);
}

double cref_transmittance_quadrature(const cref_scene *s, const double origin[3],
                                     const double dir[3], double tmax, double step)
{
    double d[3] = {dir[0], dir[1], dir[2]};
    if (normalize3(d) == 0.0) return 1.0;
    double t0, t1;
    if (!cref_intersect_box(s, origin, d, &t0, &t1)) return 1.0;
    if (t0 < 0.0) t0 = 0.0;
    if (t1 > tmax) t1 = tmax;
    if (!(t0 < t1)) return 1.0;
    if (!(step > 0.0)) {
        double sp = s->spacing[0];
        if (s->spacing[1] < sp) sp = s->spacing[1];
        if (s->spacing[2] < sp) sp = s->spacing[2];
        step = 0.05 * sp;
    }
    double n = ceil((t1 - t0) / step);      /* step > 0 */
    if (n < 1.0) n = 1.0;
    if (n > 1e8) n = 1e8;                   /* bound the loop */
    double dt = (t1 - t0) / n, tau = 0.0;   /* n >= 1 */
    for (long i = 0; i < (long)n; i++) {
        double x[3];
        ray_at(origin, d, t0 + (i + 0.5) * dt, x);
        tau += sigma_t_at(s, x) * dt;
    }
    return exp(-tau);
}

/* ==== area lights: intersection ==================================================== */

typedef struct light_hit {
    int idx;            /* light index, -1 for none */
    double t;
    int front;          /* rect: hit its emitting side; sphere: always 1 */
    double cos_l;       /* rect: cosine at the light */
} light_hit;

/* Ray (unit d) / sphere: nearest t > 0, or INFINITY. */
static double hit_sphere(const cref_light *L, const double o[3], const double d[3])
{
    double oc[3];
    sub3(o, L->pos, oc);
    double b = dot3(oc, d);
    double c = dot3(oc, oc) - L->radius * L->radius;
    double disc = b * b - c;
    if (disc < 0.0) return INFINITY;
    double sq = sqrt(disc);                 /* disc >= 0 checked */
    double t = -b - sq;
    if (t > 0.0) return t;
    t = -b + sq;                            /* inside the sphere: the far side */
    return t > 0.0 ? t : INFINITY;
}

/* Ray (unit d) / parallelogram centre +- edge_u/2 +- edge_v/2: t or INFINITY. */
static double hit_rect(const cref_light *L, const double o[3], const double d[3],
                       double *cos_l)
{
    double dn = dot3(d, L->normal);
    if (fabs(dn) < 1e-12) return INFINITY;  /* parallel to the plane: no division */
    double co[3];
    sub3(L->pos, o, co);
    double t = dot3(co, L->normal) / dn;    /* |dn| >= 1e-12 */
    if (!(t > 0.0)) return INFINITY;
    double q[3], xv[3], xu[3];
    ray_at(o, d, t, q);
    sub3(q, L->pos, q);
    /* q = a eu + b ev in the dual basis: dot(eu, ev x n) = dot(n, eu x ev) = area */
    cross3(L->edge_v, L->normal, xv);
    cross3(L->normal, L->edge_u, xu);
    double a = dot3(q, xv) / L->area, b = dot3(q, xu) / L->area;  /* area > 0 (validated) */
    if (fabs(a) > 0.5 || fabs(b) > 0.5) return INFINITY;
    *cos_l = -dn;
    return t;
}

/* Nearest area light (sphere or rect) hit by the ray within (0, tmax). */
static light_hit nearest_area_light(const cref_scene *s, const double o[3],
                                    const double d[3], double tmax)
{
    light_hit h = {-1, tmax, 0, 0.0};
    for (uint32_t i = 0; i < s->light_count; i++) {
        const cref_light *L = &s->lights[i];
        double t, c = 1.0;
        if (L->type == PICVR_LIGHT_SPHERE) t = hit_sphere(L, o, d);
        else if (L->type == PICVR_LIGHT_RECT) t = hit_rect(L, o, d, &c);
        else continue;
        if (t < h.t) {
            h.idx = (int)i; h.t = t;
            h.front = L->type == PICVR_LIGHT_SPHERE || c > 0.0;
            h.cos_l = c;
        }
    }
    return h;
}

/* ==== phase function ================================================================== */
/*
 * Henyey-Greenstein with cos = dot(direction the light travels before, direction
 * after).  A path traced from the camera travels along d (toward the scatter point) and
 * gathers light arriving from w (pointing away from the point, toward the light): the
 * light travels along -w, then along -d, so cos = dot(-w, -d) = dot(d, w), and sampling
 * draws w around the axis d.  g > 0 is forward scattering.
 */

/* The largest float below 1: picvr.h takes g in (-1, 1) as floats, so clamping into
   [-HG_G_MAX, HG_G_MAX] changes no valid input and keeps 1 - |g| >= 2^-24. */
#define HG_G_MAX (1.0 - 0x1.0p-24)

/* Rule: NaN -> 0 (isotropic), else clamped into [-HG_G_MAX, HG_G_MAX]. */
static inline double hg_clamp_g(double g)
{
    if (!(g == g)) return 0.0;
    return g > HG_G_MAX ? HG_G_MAX : (g < -HG_G_MAX ? -HG_G_MAX : g);
}

double cref_hg_eval(double g, double cos_t)
{
    g = hg_clamp_g(g);
    if (!(cos_t >= -1.0)) cos_t = -1.0;     /* also NaN */
    if (cos_t > 1.0) cos_t = 1.0;
    /* 1 + g^2 - 2 g cos as a sum of two terms >= 0 (no cancellation near |g| = 1):
       g >= 0: (1 - g)^2 + 2 g (1 - cos);  g < 0: (1 + g)^2 + 2 |g| (1 + cos).
       So den >= (1 - |g|)^2 >= 2^-48 > 0. */
    double den = g >= 0.0 ? (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - cos_t)
                          : (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 + cos_t);
    return INV_4PI * (1.0 - g) * (1.0 + g) / (den * sqrt(den));   /* den > 0 */
}

double cref_hg_sample(double g, double u)
{
    g = hg_clamp_g(g);
    if (!(u >= 0.0)) u = 0.0;
    if (u > 1.0) u = 1.0;
    /* Inverse CDF cos = (1 + g^2 - ((1 - g^2) / (1 + g s))^2) / (2 g) with s = 2u - 1,
       rearranged so that nothing divides by g (exact at g = 0: cos = s):
         cos = (s + g) / a + g (1 - g^2) (1 - s^2) / (2 a^2),  a = 1 + g s,
       with 1 - s^2 = 4 u (1 - u) (no cancellation) and a >= 1 - |g| >= 2^-24 > 0. */
    double s = 2.0 * u - 1.0;
    double a = 1.0 + g * s;
    double c = (s + g) / a + 2.0 * g * (1.0 - g) * (1.0 + g) * u * (1.0 - u) / (a * a);
    return c > 1.0 ? 1.0 : (c < -1.0 ? -1.0 : c);   /* rounding only */
}

/* The phase function at one scatter point: (1 - back_w) HG(g) + back_w HG(back_g). */
typedef struct phase_t {
    double g, back_g, back_w;
} phase_t;

static double phase_eval(const phase_t *p, double cos_t)
{
    double f = cref_hg_eval(p->g, cos_t);
    if (p->back_w > 0.0) f = (1.0 - p->back_w) * f + p->back_w * cref_hg_eval(p->back_g, cos_t);
    return f;
}

static int phase_isotropic(const phase_t *p)
{
    return p->g == 0.0 && (p->back_w == 0.0 || p->back_g == 0.0);
}

/* The uniform sphere from two uniforms: z = 1 - 2 u1, phi = 2 pi u2. */
static void sphere_dir(double u1, double u2, double w[3])
{
    double z = 1.0 - 2.0 * u1;
    double r = sqrt(1.0 - z * z > 0.0 ? 1.0 - z * z : 0.0);  /* clamped >= 0 */
    double phi = 2.0 * PI * u2;
    w[0] = r * cos(phi); w[1] = r * sin(phi); w[2] = z;
}

/* Uniform direction on the sphere (z drawn first, then phi). */
static void sample_sphere_dir(rng_t *rng, double w[3])
{
    double u1 = rng_next(rng);
    double u2 = rng_next(rng);
    sphere_dir(u1, u2, w);
}

/* A direction drawn exactly from the phase function around the unit path direction d,
   so that the sampling density is phase_eval(dot(d, w)): the back lobe when
   u_lobe < back_w, cos from the lobe's inverse CDF with u1, azimuth 2 pi u2.  An
   isotropic phase function uses the uniform sphere (sphere_dir(u1, u2)). */
static void phase_dir(const phase_t *p, const double d[3], double u_lobe, double u1,
                      double u2, double w[3])
{
    if (phase_isotropic(p)) { sphere_dir(u1, u2, w); return; }
    double g = p->back_w > 0.0 && u_lobe < p->back_w ? p->back_g : p->g;
    double c = cref_hg_sample(g, u1);
    double s2 = (1.0 - c) * (1.0 + c);      /* sin^2 without cancellation, >= 0 */
    dir_around(d, c, sqrt(s2 > 0.0 ? s2 : 0.0), 2.0 * PI * u2, w);
}

/* phase_dir with the sample's random numbers: the lobe's (only when the phase function
   is not isotropic and back_w > 0), then u1, u2; an isotropic phase function draws
   what single scattering always drew. */
static void phase_sample_dir(const phase_t *p, const double d[3], rng_t *rng, double w[3])
{
    double ul = !phase_isotropic(p) && p->back_w > 0.0 ? rng_next(rng) : 1.0;
    double u1 = rng_next(rng);
    double u2 = rng_next(rng);
    phase_dir(p, d, ul, u1, u2, w);
}

double cref_phase_eval(double g, double back_g, double back_weight, double cos_t)
{
    phase_t p = {g, back_g, back_weight};
    return phase_eval(&p, cos_t);
}

void cref_phase_sample(double g, double back_g, double back_weight, const double d[3],
                       double u_lobe, double u1, double u2, double w[3])
{
    phase_t p = {g, back_g, back_weight};
    phase_dir(&p, d, u_lobe, u1, u2, w);
}

/* ==== background: constant or environment map ========================================= */
/*
 * Map convention (picvr.h, above picvr_background): w' = R_y(-rotation) w with the
 * right-handed R_y(a) = [[cos a, 0, sin a], [0, 1, 0], [-sin a, 0, cos a]] (a > 0 turns
 * +z toward +x); column floor(W (0.5 + atan2(w'.x, -w'.z) / 2pi)), row
 * floor(H acos(w'.y) / pi), both clamped into the map (the edges phi = +-pi, theta = pi
 * land in the last column / row).  Texel j covers phi in 2pi [c/W - 1/2, (c+1)/W - 1/2],
 * theta in pi [r/H, (r+1)/H], solid angle Omega_j = (2pi/W)(cos theta_r - cos
 * theta_{r+1}).  Light sampling picks texel j with probability lum_j Omega_j / total
 * (lum_j: luminance of colour * intensity * texel_j; total = sum_j lum_j Omega_j, the
 * integral of the background's luminance over the sphere), then uniform in phi and in
 * cos theta within it: density lum_j / total per steradian.
 */

/* Luminance of texel i's radiance. */
static inline double env_lum(const cref_scene *s, size_t i)
{
    const float *t = s->env.texels + 3 * i;
    return 0.2126 * s->background[0] * t[0] + 0.7152 * s->background[1] * t[1] +
           0.0722 * s->background[2] * t[2];
}

/* cos theta_r - cos theta_{r+1} = 2 sin((theta_r + theta_{r+1})/2) sin(pi / 2H): > 0. */
static inline double env_dcos(const cref_env *e, uint32_t row)
{
    double h = PI / (double)e->height;      /* height >= 1 */
    return 2.0 * sin(h * (row + 0.5)) * sin(0.5 * h);
}

static inline double env_texel_omega(const cref_env *e, uint32_t row)
{
    return 2.0 * PI / (double)e->width * env_dcos(e, row);  /* width >= 1 */
}

int cref_env_texel(const cref_scene *s, const double w[3], uint32_t *col, uint32_t *row)
{
    const cref_env *e = &s->env;
    *col = *row = 0;
    if (!e->texels) return 0;
    double x = e->rot_cos * w[0] - e->rot_sin * w[2];   /* w' = R_y(-a) w */
    double z = e->rot_sin * w[0] + e->rot_cos * w[2];
    double y = w[1];
    if (!(y >= -1.0)) y = -1.0;             /* also NaN */
    if (y > 1.0) y = 1.0;
    double u = 0.5 + atan2(x, -z) / (2.0 * PI);   /* atan2 is defined everywhere */
    double v = acos(y) / PI;
    double c = floor(u * e->width), r = floor(v * e->height);
    if (!(c >= 0.0)) c = 0.0;               /* NaN (non-finite w) -> texel 0 */
    if (!(r >= 0.0)) r = 0.0;
    *col = c > e->width - 1.0 ? e->width - 1 : (uint32_t)c;
    *row = r > e->height - 1.0 ? e->height - 1 : (uint32_t)r;
    return 1;
}

double cref_background_eval(const cref_scene *s, const double w[3], double rgb[3])
{
    uint32_t c, r;
    if (!cref_env_texel(s, w, &c, &r)) {
        memcpy(rgb, s->background, 3 * sizeof *rgb);
        return INV_4PI;
    }
    size_t i = (size_t)r * s->env.width + c;
    for (int k = 0; k < 3; k++) rgb[k] = s->background[k] * s->env.texels[3 * i + (size_t)k];
    /* rule: a black background (total 0) has density 0: light sampling never picks it */
    return s->env.total > 0.0 ? env_lum(s, i) / s->env.total : 0.0;
}

/* Texel of the map whose CDF interval holds u * total: the first i with
   cdf[i] > u total (a black texel's interval is empty, so it is never chosen); a u that
   rounds onto the end takes the last texel of non-zero weight.  Bounded binary search. */
static size_t env_pick(const cref_env *e, double u)
{
    size_t n = (size_t)e->width * e->height, lo = 0, hi = n - 1;
    double target = u * e->total;
    if (!(target < e->cdf[n - 1])) return e->last_texel;
    while (lo < hi) {                       /* invariant: cdf[hi] > target */
        size_t mid = lo + (hi - lo) / 2;
        if (e->cdf[mid] > target) hi = mid; else lo = mid + 1;
    }
    return lo;
}

double cref_background_sample(const cref_scene *s, double u1, double u2, double u3,
                              double w[3], double rgb[3])
{
    const cref_env *e = &s->env;
    if (!e->texels) {                       /* constant: uniform sphere */
        sphere_dir(u1, u2, w);
        memcpy(rgb, s->background, 3 * sizeof *rgb);
        return INV_4PI;
    }
    if (!(e->total > 0.0)) {                /* black: nothing to sample */
        w[0] = 0.0; w[1] = 1.0; w[2] = 0.0;
        rgb[0] = rgb[1] = rgb[2] = 0.0;
        return 0.0;
    }
    size_t i = env_pick(e, u1);
    uint32_t col = (uint32_t)(i % e->width), row = (uint32_t)(i / e->width);
    double phi = 2.0 * PI * ((col + u2) / e->width - 0.5);
    double h = PI / e->height;
    double cos_t = cos(h * row) - u3 * env_dcos(e, row);
    double s2 = (1.0 - cos_t) * (1.0 + cos_t);
    double sin_t = sqrt(s2 > 0.0 ? s2 : 0.0);
    double wx = sin_t * sin(phi), wz = -sin_t * cos(phi);   /* w' in map space */
    w[0] = e->rot_cos * wx + e->rot_sin * wz;                /* w = R_y(a) w' */
    w[1] = cos_t;
    w[2] = -e->rot_sin * wx + e->rot_cos * wz;
    for (int k = 0; k < 3; k++) rgb[k] = s->background[k] * e->texels[3 * i + (size_t)k];
    return env_lum(s, i) / e->total;        /* total > 0 */
}

/* Draws a background direction with the sample's random numbers: two for a constant
   background (the uniform sphere, as single scattering always drew), three for a map. */
static double background_sample(const cref_scene *s, rng_t *rng, double w[3], double rgb[3])
{
    double u1 = rng_next(rng), u2 = rng_next(rng);
    double u3 = s->env.texels ? rng_next(rng) : 0.0;
    return cref_background_sample(s, u1, u2, u3, w, rgb);
}

/* ==== lights: sampling and MIS ======================================================= */
/*
 * Power heuristic, written so that no pdf is ever divided by.  f is the phase
 * function's value for the direction, which is also the density of phase sampling
 * (exact sampling); p_l = p_select * p_light(w):
 *   light sample:  f L T w_l / p_l = f L T p_l / (p_l^2 + f^2)
 *   phase sample:  f L T w_f / f   =   L T f^2 / (p_l^2 + f^2)
 * For a light sampled uniformly in a solid angle Omega (sphere cone, sun cone),
 * p_light = 1/Omega; multiplying through by Omega^2:
 *   light: f (L Omega) T p_sel / (p_sel^2 + (f Omega)^2)
 *   phase:   (L Omega) T f^2 Omega / (p_sel^2 + (f Omega)^2)
 * which stays finite for tiny cones and is exact for the delta sun (Omega = 0,
 * L Omega = E): light term = f E T / p_sel.  For a rect, p_light = d^2 / (A cos):
 *   light: f L T p_sel d^2 A cos / ((p_sel d^2)^2 + (f A cos)^2)
 *   phase:   L T (f A cos)^2     / ((p_sel d^2)^2 + (f A cos)^2)
 * The background uses the general form with p_light = its sampling density.
 * Denominators are > 0 whenever the sample can carry light (p_sel > 0 for a light
 * with power; f > 0 always; cos > 0 and d > 0 for a rect); each is guarded anyway.
 */

static inline double mis_cone_light(double f, double p_sel, double omega)
{
    double fo = f * omega, den = p_sel * p_sel + fo * fo;
    return den > 0.0 ? f * p_sel / den : 0.0;          /* rule: den > 0 */
}

static inline double mis_cone_phase(double f, double p_sel, double omega)
{
    double fo = f * omega, den = p_sel * p_sel + fo * fo;
    return den > 0.0 ? f * fo / den : 0.0;
}

static inline double mis_rect_light(double f, double p_sel, double d2, double a_cos)
{
    double x = p_sel * d2, y = f * a_cos;
    double den = x * x + y * y;
    return den > 0.0 ? f * x * a_cos / den : 0.0;
}

static inline double mis_rect_phase(double f, double p_sel, double d2, double a_cos)
{
    double x = p_sel * d2, y = f * a_cos;
    double den = x * x + y * y;
    return den > 0.0 ? y * y / den : 0.0;
}

/* p_l = p_sel * density of the light's sampling at the direction. */
static inline double mis_density_light(double f, double p_l)
{
    double den = p_l * p_l + f * f;
    return den > 0.0 ? f * p_l / den : 0.0;
}

static inline double mis_density_phase(double f, double p_l)
{
    double den = p_l * p_l + f * f;
    return den > 0.0 ? f * f / den : 0.0;
}

/* Solid angle a sphere light subtends from x: 4 pi inside it; else the cone
   2 pi (1 - cos_max), 1 - cos_max computed as sin^2 / (1 + cos) (no cancellation).
   one_minus_cos (outside only), axis and dist describe the cone. */
static double sphere_omega(const cref_light *L, const double x[3], double *one_minus_cos,
                           double axis[3], double *dist)
{
    sub3(L->pos, x, axis);
    double d = normalize3(axis);
    *dist = d;
    if (!(d > L->radius)) { *one_minus_cos = 2.0; return 4.0 * PI; }
    double s2 = (L->radius / d) * (L->radius / d);    /* d > radius > 0 */
    double cmax = sqrt(1.0 - s2 > 0.0 ? 1.0 - s2 : 0.0);
    *one_minus_cos = s2 / (1.0 + cmax);     /* 1 + cmax >= 1 */
    return 2.0 * PI * *one_minus_cos;
}

/* Uniform direction in the cone of the unit axis with 1 - cos(half angle) = omc. */
static void sample_cone_dir(rng_t *rng, const double axis[3], double omc, double w[3])
{
    double u = rng_next(rng) * omc;         /* 1 - cos(theta) in [0, omc) */
    double cos_t = 1.0 - u;
    double s2 = u * (2.0 - u);              /* sin^2 = (1-cos)(1+cos), no cancellation */
    double sin_t = sqrt(s2 > 0.0 ? s2 : 0.0);
    dir_around(axis, cos_t, sin_t, 2.0 * PI * rng_next(rng), w);
}

/* Picks a light by power with one random number; -1 for none, light_count for the
   background.  The scan is bounded by light_count + 1. */
static int pick_light(const cref_scene *s, double u)
{
    double acc = 0.0;
    int last = -1;
    for (uint32_t i = 0; i <= s->light_count; i++) {
        double p = i < s->light_count ? s->lights[i].p_select : s->background_p_select;
        if (!(p > 0.0)) continue;
        acc += p;
        last = (int)i;
        if (u < acc) return (int)i;
    }
    return last;                            /* rounding: acc may end just below 1 */
}

/* A light sample before its phase value and transmittance: direction w, distance tl
   to the light (INFINITY: at infinity), radiance-like rad (colour * intensity, the
   map's texel, L Omega for a sun) and the rest of the estimator's weight as a function
   of the phase value f. */
typedef struct light_dir {
    double w[3], tl, rad[3];
    int kind;                   /* 0 none, 1 cone (omega), 2 rect (d2, a_cos), 3 density
                                   (p_l), 4 point (d2) */
    double omega, d2, a_cos, p_l, p_sel;
} light_dir;

/* Draws the direction toward sphere light L from x (uniform in its cone; inside it,
   the uniform sphere and the far surface). */
static void sample_sphere_light(const cref_light *L, const double x[3], rng_t *rng,
                                light_dir *ld)
{
    double omc, axis[3], dist;
    ld->omega = sphere_omega(L, x, &omc, axis, &dist);
    if (omc >= 2.0) {
        sample_sphere_dir(rng, ld->w);
        ld->tl = hit_sphere(L, x, ld->w);
    } else {
        sample_cone_dir(rng, axis, omc, ld->w);
        ld->tl = hit_sphere(L, x, ld->w);
        if (!isfinite(ld->tl)) {            /* grazing sample missed by rounding */
            double c = dot3(ld->w, axis);
            ld->tl = dist * (c > 0.0 ? c : 0.0);
        }
    }
    ld->kind = 1;
}

/* Draws a point of rect L uniformly by area; kind 0 when it cannot light x (x on the
   light, or its back side). */
static void sample_rect_light(const cref_light *L, const double x[3], rng_t *rng,
                              light_dir *ld)
{
    double y[3], v[3];
    double a = rng_next(rng) - 0.5, b = rng_next(rng) - 0.5;
    for (int i = 0; i < 3; i++) y[i] = L->pos[i] + a * L->edge_u[i] + b * L->edge_v[i];
    sub3(y, x, v);
    double d2 = dot3(v, v);
    if (!(d2 > 1e-30)) return;              /* on the light: direction undefined */
    ld->tl = sqrt(d2);                      /* d2 > 0 */
    for (int i = 0; i < 3; i++) ld->w[i] = v[i] / ld->tl;
    double cos_l = -dot3(ld->w, L->normal);
    if (!(cos_l > 0.0)) return;             /* back side: one-sided emitter */
    ld->d2 = d2;
    ld->a_cos = L->area * cos_l;
    ld->kind = 2;
}

/* Chooses a light (or the background) by power and draws a direction toward it. */
static void choose_light_dir(const cref_scene *s, const double x[3], rng_t *rng,
                             light_dir *ld, int *li_out)
{
    memset(ld, 0, sizeof *ld);
    ld->tl = INFINITY;
    int li = pick_light(s, rng_next(rng));
    *li_out = li;
    if (li < 0) return;
    if ((uint32_t)li == s->light_count) {
        double pdf = background_sample(s, rng, ld->w, ld->rad);
        ld->p_l = s->background_p_select * pdf;
        ld->kind = ld->p_l > 0.0 ? 3 : 0;
        return;
    }
    const cref_light *L = &s->lights[li];
    memcpy(ld->rad, L->radiance, sizeof ld->rad);
    ld->p_sel = L->p_select;
    if (L->type == PICVR_LIGHT_SPHERE) {
        sample_sphere_light(L, x, rng, ld);
    } else if (L->type == PICVR_LIGHT_RECT) {
        sample_rect_light(L, x, rng, ld);
    } else if (L->type == PICVR_LIGHT_DIRECTIONAL) {
        if (L->omega > 0.0) sample_cone_dir(rng, L->dir, 1.0 - L->cos_half, ld->w);
        else memcpy(ld->w, L->dir, sizeof ld->w);
        ld->omega = L->omega;               /* the radiance field holds L Omega = E */
        ld->kind = 1;
    } else {                                /* point: I T / d^2, light sampling only */
        double v[3];
        sub3(L->pos, x, v);
        double d2 = dot3(v, v);
        if (!(d2 > 1e-30)) return;          /* at the light: singular, skip */
        ld->tl = sqrt(d2);
        for (int i = 0; i < 3; i++) ld->w[i] = v[i] / ld->tl;
        ld->d2 = d2;
        ld->kind = 4;
    }
    if (L->type == PICVR_LIGHT_SPHERE)      /* a cone light's weight needs L Omega */
        for (int i = 0; i < 3; i++) ld->rad[i] *= ld->omega;
}

/* The estimator's scalar weight of a light sample for phase value f. */
static double light_weight(const light_dir *ld, double f)
{
    switch (ld->kind) {
    case 1: return mis_cone_light(f, ld->p_sel, ld->omega);
    case 2: return mis_rect_light(f, ld->p_sel, ld->d2, ld->a_cos);
    case 3: return mis_density_light(f, ld->p_l);
    case 4: {
        double den = ld->d2 * ld->p_sel;    /* d2 > 1e-30, p_sel > 0 (picked) */
        return den > 0.0 ? f / den : 0.0;
    }
    default: return 0.0;
    }
}

/* Light-sampling estimate (RGB, before the throughput) at the scatter point x, for a
   path arriving along unit d with phase function ph. */
static void light_sample(const cref_scene *s, const double x[3], const double d[3],
                         const phase_t *ph, rng_t *rng, double out[3], int *trunc,
                         uint64_t *viol)
{
    out[0] = out[1] = out[2] = 0.0;
    light_dir ld;
    int li;
    choose_light_dir(s, x, rng, &ld, &li);
    if (ld.kind == 0) return;
    double k = light_weight(&ld, phase_eval(ph, dot3(d, ld.w)));
    if (!(k > 0.0)) return;
    /* area lights are opaque: another one in front blocks this sample */
    light_hit h = nearest_area_light(s, x, ld.w, INFINITY);
    if (h.idx >= 0 && h.idx != li && h.t < ld.tl * (1.0 - 1e-9)) return;
    double T = transmittance(s, x, ld.w, ld.tl, rng, trunc, viol);
    for (int i = 0; i < 3; i++) out[i] = ld.rad[i] * k * T;
}

/* MIS-weighted radiance that a phase-sampled ray from x along unit w brings when the
   medium lets it through: the area light h it hits (front side; the back of a rect is
   black) or, escaping, the background plus every sun cone around w.  f: the phase
   value (= the phase-sampling density) of w. */
static void escape_radiance(const cref_scene *s, const double x[3], const double w[3],
                            const light_hit *h, double f, double L[3])
{
    L[0] = L[1] = L[2] = 0.0;
    if (h->idx >= 0) {
        const cref_light *A = &s->lights[h->idx];
        if (!h->front) return;
        double k;
        if (A->type == PICVR_LIGHT_SPHERE) {
            double omc, axis[3], dist;
            double omega = sphere_omega(A, x, &omc, axis, &dist);
            k = omega * mis_cone_phase(f, A->p_select, omega);
        } else {
            k = mis_rect_phase(f, A->p_select, h->t * h->t, A->area * h->cos_l);
        }
        for (int i = 0; i < 3; i++) L[i] = A->radiance[i] * k;
        return;
    }
    double bg[3];
    double p_env = cref_background_eval(s, w, bg);
    double k = mis_density_phase(f, s->background_p_select * p_env);
    for (int i = 0; i < 3; i++) L[i] = bg[i] * k;
    for (uint32_t j = 0; j < s->light_count; j++) {
        const cref_light *D = &s->lights[j];
        if (D->type != PICVR_LIGHT_DIRECTIONAL || !(D->omega > 0.0)) continue;
        if (dot3(w, D->dir) < D->cos_half) continue;
        double kd = mis_cone_phase(f, D->p_select, D->omega);  /* radiance holds E */
        for (int i = 0; i < 3; i++) L[i] += D->radiance[i] * kd;
    }
}

/* Phase-sampling estimate of the last scatter event of a path (RGB, before the
   throughput): one direction from the phase function, its escape radiance times a
   ratio-tracking transmittance estimate (the path does not continue). */
static void phase_sample_last(const cref_scene *s, const double x[3], const double d[3],
                              const phase_t *ph, rng_t *rng, double out[3], int *trunc,
                              uint64_t *viol)
{
    out[0] = out[1] = out[2] = 0.0;
    double w[3], L[3];
    phase_sample_dir(ph, d, rng, w);
    light_hit h = nearest_area_light(s, x, w, INFINITY);
    escape_radiance(s, x, w, &h, phase_eval(ph, dot3(d, w)), L);
    if (!(L[0] > 0.0 || L[1] > 0.0 || L[2] > 0.0)) return;  /* skip the shadow ray */
    double T = transmittance(s, x, w, h.t, rng, trunc, viol);
    for (int i = 0; i < 3; i++) out[i] = L[i] * T;
}

/* ==== paths ============================================================================ */

typedef struct sample_flags {
    int truncated;
    int scattered;
    uint64_t events;            /* scatter events of the sample's path */
} sample_flags;

/* The medium at x: albedo (RGB) and phase function. */
static void medium_at(const cref_scene *s, const double x[3], double albedo[3], phase_t *ph)
{
    cref_tf_eval_ex(s->tf, s->tf_count, sample_value(s, x), albedo, &ph->g);
    ph->back_g = s->back_g;
    ph->back_w = s->back_weight;
}

/* Russian roulette before the path continues from its k-th scatter event, k >= 2:
   survive with q = min(1, max channel of tp), then tp /= q.  Returns 0 when the path
   ends (also when tp is all zero: nothing more can arrive).  No random number is
   drawn when q = 1. */
static int roulette(double tp[3], rng_t *rng)
{
    double q = tp[0] > tp[1] ? tp[0] : tp[1];
    if (tp[2] > q) q = tp[2];
    if (!(q > 0.0)) return 0;
    if (q >= 1.0) return 1;
    if (rng_next(rng) >= q) return 0;
    for (int i = 0; i < 3; i++) tp[i] /= q;                  /* q > 0 */
    return 1;
}

/* Continues a path from x along a phase-sampled unit w by delta tracking.  Returns 1
   with *x moved to the next collision; 0 when the path ends, after adding
   tp * the MIS-weighted escape radiance to rgb when the ray escaped (nothing when it
   was cut: fl->truncated). */
static int continue_path(const cref_scene *s, double x[3], const double w[3], double f,
                         const double tp[3], rng_t *rng, int *budget, double rgb[3],
                         sample_flags *fl, uint64_t *viol)
{
    light_hit h = nearest_area_light(s, x, w, INFINITY);
    double t0, t1, th;
    int r = TRACK_ESCAPED;
    if (cref_intersect_box(s, x, w, &t0, &t1)) {
        if (t0 < 0.0) t0 = 0.0;
        if (t1 > h.t) t1 = h.t;
        if (t0 < t1) r = delta_track(s, x, w, t0, t1, rng, budget, &th, viol);
    }
    if (r == TRACK_COLLIDED) {
        ray_at(x, w, th, x);
        return 1;
    }
    if (r == TRACK_TRUNCATED) { fl->truncated = 1; return 0; }
    double L[3];
    escape_radiance(s, x, w, &h, f, L);
    for (int i = 0; i < 3; i++) rgb[i] += tp[i] * L[i];
    return 0;
}

/* A path from its first scatter event x (reached along unit d): at every event the
   throughput takes the albedo and a light sample is added; the last allowed event
   (max_bounces + 1) adds a phase sample with a ratio-tracking transmittance, earlier
   ones continue along a phase-sampled direction by delta tracking (Russian roulette
   from the second event on; a path whose throughput is 0 in every channel ends).
   Bounded: every event after the first costs >= 1 step of *budget. */
static void trace_path(const cref_scene *s, const double x0[3], const double d0[3],
                       rng_t *rng, int *budget, double rgb[3], sample_flags *fl,
                       uint64_t *viol)
{
    double x[3] = {x0[0], x0[1], x0[2]}, d[3] = {d0[0], d0[1], d0[2]};
    double tp[3] = {1.0, 1.0, 1.0};
    const int unlimited = s->max_bounces == PICVR_BOUNCES_UNLIMITED;
    const uint64_t last = (uint64_t)s->max_bounces + 1;
    for (uint64_t k = 1;; k++) {
        double albedo[3], a[3];
        phase_t ph;
        fl->events++;
        medium_at(s, x, albedo, &ph);
        for (int i = 0; i < 3; i++) tp[i] *= albedo[i];
        light_sample(s, x, d, &ph, rng, a, &fl->truncated, viol);
        for (int i = 0; i < 3; i++) rgb[i] += tp[i] * a[i];
        if (!unlimited && k >= last) {
            phase_sample_last(s, x, d, &ph, rng, a, &fl->truncated, viol);
            for (int i = 0; i < 3; i++) rgb[i] += tp[i] * a[i];
            return;
        }
        if (!(tp[0] > 0.0 || tp[1] > 0.0 || tp[2] > 0.0)) return;  /* nothing can arrive */
        if (k >= 2 && !s->roulette_off && !roulette(tp, rng)) return;
        double w[3];
        phase_sample_dir(&ph, d, rng, w);
        double f = phase_eval(&ph, dot3(d, w));
        if (!continue_path(s, x, w, f, tp, rng, budget, rgb, fl, viol)) return;
        memcpy(d, w, sizeof d);
    }
}

/* ==== one sample ===================================================================== */

void cref_camera_ray(const cref_scene *s, uint32_t px, uint32_t py, double jx, double jy,
                     double dir[3])
{
    double sx = (2.0 * (px + jx) / s->camera.width - 1.0) * s->cam_h * s->cam_aspect;
    double sy = (1.0 - 2.0 * (py + jy) / s->camera.height) * s->cam_h;   /* dims >= 1 */
    for (int i = 0; i < 3; i++) dir[i] = s->cam_f[i] + sx * s->cam_r[i] + sy * s->cam_u[i];
    normalize3(dir);                        /* length >= 1: f is unit and orthogonal */
}

static void render_sample(const cref_scene *s, uint32_t px, uint32_t py, uint64_t iteration,
                          double rgb[3], double *alpha, sample_flags *fl, uint64_t *viol)
{
    rng_t rng = rng_make(s->seed, (uint64_t)py * s->camera.width + px, iteration);
    double jx = rng_next(&rng), jy = rng_next(&rng);
    double d[3];
    cref_camera_ray(s, px, py, jx, jy, d);
    const double *o = s->cam_pos;
    rgb[0] = rgb[1] = rgb[2] = 0.0;
    *alpha = 0.0;
    int budget = CREF_PATH_STEPS;

    /* an area light in front of the volume hides it: track only up to the light */
    light_hit h = nearest_area_light(s, o, d, INFINITY);
    double t0, t1, th;
    int r = TRACK_ESCAPED;
    if (cref_intersect_box(s, o, d, &t0, &t1)) {
        if (t0 < 0.0) t0 = 0.0;
        if (t1 > h.t) t1 = h.t;
        if (t0 < t1) r = delta_track(s, o, d, t0, t1, &rng, &budget, &th, viol);
    }
    if (r == TRACK_TRUNCATED) fl->truncated = 1;   /* then treated as escaping */
    if (r != TRACK_COLLIDED) {
        if (h.idx >= 0) {
            if (h.front) memcpy(rgb, s->lights[h.idx].radiance, 3 * sizeof *rgb);
        } else {
            cref_background_eval(s, d, rgb);
        }
        return;
    }
    double x[3];
    ray_at(o, d, th, x);
    *alpha = 1.0;
    fl->scattered = 1;
    trace_path(s, x, d, &rng, &budget, rgb, fl, viol);
}

/* ==== render loop ===================================================================== */

int cref_render_ex(const cref_scene *s, uint32_t first_iteration, uint32_t iterations,
                   float *rgba_mean_out, double *lum_m2_out, cref_render_stats *stats)
{
    if (!s || !rgba_mean_out) return PICVR_ERROR_NULL_POINTER;
    if (!s->voxels || !s->majorant.sigma_max) return PICVR_ERROR_NOT_READY;
    const uint32_t W = s->camera.width, H = s->camera.height;
    uint64_t n_trunc = 0, n_scat = 0, n_viol = 0, n_events = 0;
    long rows = (long)H;
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : n_trunc, n_scat, n_viol, n_events)
#endif
    for (long py = 0; py < rows; py++) {
        for (uint32_t px = 0; px < W; px++) {
            /* Welford running mean (RGBA) and M2 (luminance) over this pixel's samples */
            double mean[4] = {0, 0, 0, 0}, mean_y = 0.0, m2 = 0.0;
            for (uint32_t k = 0; k < iterations; k++) {
                double rgb[3], alpha;
                sample_flags fl = {0, 0, 0};
                uint64_t viol = 0;
                render_sample(s, px, (uint32_t)py, (uint64_t)first_iteration + k, rgb, &alpha,
                              &fl, &viol);
                n_trunc += (uint64_t)fl.truncated;
                n_scat += (uint64_t)fl.scattered;
                n_events += fl.events;
                n_viol += viol;
                double inv_n = 1.0 / (double)(k + 1);     /* k + 1 >= 1 */
                for (int c = 0; c < 3; c++) mean[c] += (rgb[c] - mean[c]) * inv_n;
                mean[3] += (alpha - mean[3]) * inv_n;
                double y = cref_luminance(rgb), dy = y - mean_y;
                mean_y += dy * inv_n;
                m2 += dy * (y - mean_y);
            }
            size_t p = (size_t)py * W + px;
            for (int c = 0; c < 4; c++) rgba_mean_out[4 * p + c] = (float)mean[c];
            if (lum_m2_out) lum_m2_out[p] = m2;
        }
    }
    if (stats) {
        stats->samples = (uint64_t)W * H * iterations;
        stats->scattered = n_scat;
        stats->truncated_paths = n_trunc;
        stats->majorant_violations = n_viol;
        stats->scatter_events = n_events;
        /* rule: 0 without samples (no division by 0) */
        stats->mean_path_length = stats->samples > 0 ? (double)n_events / (double)stats->samples : 0.0;
    }
    return PICVR_OK;
}

int cref_render(const cref_scene *s, uint32_t iterations, float *rgba_mean_out,
                double *lum_m2_out)
{
    return cref_render_ex(s, 0, iterations, rgba_mean_out, lum_m2_out, NULL);
}

/* ==== scene setup ===================================================================== */

static int finite3(const float v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

/* Converts the voxels to normalized floats per picvr_volume_desc's value_min/max. */
static int load_volume(cref_scene *s, const picvr_volume_desc *v)
{
    if (!v->data) return PICVR_ERROR_NULL_POINTER;
    if (!v->dims[0] || !v->dims[1] || !v->dims[2]) return PICVR_ERROR_INVALID_DIMENSIONS;
    size_t n = v->dims[0];
    if ((size_t)v->dims[1] > SIZE_MAX / n) return PICVR_ERROR_SIZE_OVERFLOW;
    n *= v->dims[1];
    if ((size_t)v->dims[2] > SIZE_MAX / sizeof(float) / n) return PICVR_ERROR_SIZE_OVERFLOW;
    n *= v->dims[2];
    if (v->type != PICVR_VOXEL_UINT8 && v->type != PICVR_VOXEL_UINT16 &&
        v->type != PICVR_VOXEL_FLOAT32)
        return PICVR_ERROR_UNSUPPORTED_TYPE;
    for (int a = 0; a < 3; a++) {
        double sp = v->spacing[a] == 0.0f ? 1.0 : v->spacing[a];
        if (!isfinite(sp) || !(sp > 0.0)) return PICVR_ERROR_INVALID_ARGUMENT;
        s->dims[a] = v->dims[a];
        s->spacing[a] = sp;
        s->inv_spacing[a] = 1.0 / sp;       /* sp > 0 */
        s->box_max[a] = 0.5 * v->dims[a] * sp;
        s->box_min[a] = -s->box_max[a];
    }
    if (!isfinite(v->value_min) || !isfinite(v->value_max)) return PICVR_ERROR_NON_FINITE;
    const float *f32 = v->data;
    double lo = v->value_min, hi = v->value_max;
    if (v->type == PICVR_VOXEL_FLOAT32)
        for (size_t i = 0; i < n; i++)
            if (!isfinite(f32[i])) return PICVR_ERROR_NON_FINITE;
    if (lo == 0.0 && hi == 0.0) {           /* documented defaults */
        if (v->type == PICVR_VOXEL_UINT8) hi = 255.0;
        else if (v->type == PICVR_VOXEL_UINT16) hi = 65535.0;
        else {
            lo = INFINITY; hi = -INFINITY;
            for (size_t i = 0; i < n; i++) {
                if (f32[i] < lo) lo = f32[i];
                if (f32[i] > hi) hi = f32[i];
            }
        }
    } else if (lo == hi) {
        return PICVR_ERROR_INVALID_ARGUMENT;
    }
    /* Rule: a constant float32 volume (own range empty) maps to 0. */
    double scale = hi != lo ? 1.0 / (hi - lo) : 0.0;
    s->voxels = malloc(n * sizeof(float));
    if (!s->voxels) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    const uint8_t *u8 = v->data;
    const uint16_t *u16 = v->data;
    for (size_t i = 0; i < n; i++) {
        double x = v->type == PICVR_VOXEL_UINT8 ? u8[i]
                 : v->type == PICVR_VOXEL_UINT16 ? u16[i] : f32[i];
        double t = (x - lo) * scale;
        s->voxels[i] = (float)(t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t));
    }
    return PICVR_OK;
}

static int load_tf(cref_scene *s, const picvr_tf_point *tf, uint32_t count, float density)
{
    if (!tf || count == 0) {                /* API default: opacity = value, albedo 1 */
        picvr_tf_point def[2] = {{0.0f, {1, 1, 1}, 0.0f, 0.0f}, {1.0f, {1, 1, 1}, 1.0f, 0.0f}};
        memcpy(s->tf, def, sizeof def);
        s->tf_count = 2;
        s->density = 1.0;
        return PICVR_OK;
    }
    if (count > PICVR_MAX_TF_POINTS) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
    if (!isfinite(density) || density < 0.0f) return PICVR_ERROR_INVALID_ARGUMENT;
    for (uint32_t i = 0; i < count; i++) {
        const picvr_tf_point *p = &tf[i];
        if (!isfinite(p->value) || !finite3(p->albedo) || !isfinite(p->opacity) ||
            !isfinite(p->g))
            return PICVR_ERROR_NON_FINITE;
        if (p->value < 0.0f || p->value > 1.0f || p->opacity < 0.0f ||
            !(p->g > -1.0f && p->g < 1.0f) || (i > 0 && p->value < tf[i - 1].value))
            return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
        for (int k = 0; k < 3; k++)
            if (p->albedo[k] < 0.0f || p->albedo[k] > 1.0f)
                return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
    }
    memcpy(s->tf, tf, count * sizeof *tf);
    s->tf_count = count;
    s->density = density;
    return PICVR_OK;
}

/* Luminance of colour*intensity times the geometric factor of the header's power
   list (the selection weight before normalization). */
static double light_power(const cref_light *L, double R)
{
    double y = cref_luminance(L->radiance);
    switch (L->type) {
    case PICVR_LIGHT_SPHERE: return y * PI * 4.0 * PI * L->radius * L->radius;
    case PICVR_LIGHT_RECT: return y * PI * L->area;
    case PICVR_LIGHT_POINT: return y * 4.0 * PI;
    default: return y * PI * R * R;         /* directional */
    }
}

static int load_light(cref_light *L, const picvr_light *in)
{
    memset(L, 0, sizeof *L);
    if (!finite3(in->color) || !isfinite(in->intensity) || !finite3(in->position) ||
        !isfinite(in->radius) || !finite3(in->direction) || !isfinite(in->angular_diameter) ||
        !finite3(in->edge_u) || !finite3(in->edge_v))
        return PICVR_ERROR_NON_FINITE;
    if (in->intensity < 0.0f || in->color[0] < 0.0f || in->color[1] < 0.0f || in->color[2] < 0.0f)
        return PICVR_ERROR_INVALID_LIGHT;
    L->type = in->type;
    for (int k = 0; k < 3; k++) {
        L->radiance[k] = (double)in->color[k] * in->intensity;
        L->pos[k] = in->position[k];
        L->edge_u[k] = in->edge_u[k];
        L->edge_v[k] = in->edge_v[k];
        L->dir[k] = in->direction[k];
    }
    switch (in->type) {
    case PICVR_LIGHT_SPHERE:
        if (!(in->radius > 0.0f)) return PICVR_ERROR_INVALID_LIGHT;
        L->radius = in->radius;
        return PICVR_OK;
    case PICVR_LIGHT_RECT:
        cross3(L->edge_u, L->edge_v, L->normal);
        L->area = normalize3(L->normal);
        if (!(L->area > 0.0)) return PICVR_ERROR_INVALID_LIGHT;   /* parallel edges */
        return PICVR_OK;
    case PICVR_LIGHT_DIRECTIONAL: {
        if (normalize3(L->dir) == 0.0) return PICVR_ERROR_INVALID_LIGHT;
        double a = in->angular_diameter;
        if (!(a >= 0.0 && a < PI)) return PICVR_ERROR_INVALID_LIGHT;
        double sh = sin(0.25 * a);
        double omc = 2.0 * sh * sh;         /* 1 - cos(a/2) without cancellation */
        L->cos_half = 1.0 - omc;
        L->omega = 2.0 * PI * omc;          /* 0 for a = 0: a delta light */
        /* colour * intensity is the irradiance E on a plane facing the sun, so the
           radiance is E / (pi sin^2 h) and L * Omega = E * 2 / (2 - omc); the
           "radiance" field holds L * Omega (E itself for the delta sun). */
        if (omc > 0.0)
            for (int k = 0; k < 3; k++) L->radiance[k] *= 2.0 / (2.0 - omc);
        return PICVR_OK;
    }
    case PICVR_LIGHT_POINT:
        return PICVR_OK;
    default:
        return PICVR_ERROR_INVALID_LIGHT;
    }
}

/* Copies the environment map of bg (non-NULL environment) and builds its sampling
   CDF over texels, x fastest: cdf[i] = sum_{j <= i} lum_j Omega_j with the luminance of
   colour * intensity * texel (s->background must hold colour * intensity).  The
   texels must be finite and >= 0, not all 0; width and height 1..PICVR_MAX_ENV_SIZE. */
static int load_env(cref_scene *s, const picvr_background *bg)
{
    cref_env *e = &s->env;
    uint32_t W = bg->env_width, H = bg->env_height;
    if (W == 0 || H == 0) return PICVR_ERROR_INVALID_DIMENSIONS;
    if (W > PICVR_MAX_ENV_SIZE || H > PICVR_MAX_ENV_SIZE) return PICVR_ERROR_INVALID_ARGUMENT;
    if (!isfinite(bg->env_rotation)) return PICVR_ERROR_NON_FINITE;
    size_t n = (size_t)W * H;               /* <= 2^28: no overflow below */
    int any = 0;
    for (size_t i = 0; i < 3 * n; i++) {
        float v = bg->environment[i];
        if (!isfinite(v)) return PICVR_ERROR_NON_FINITE;
        if (v < 0.0f) return PICVR_ERROR_INVALID_LIGHT;
        any |= v > 0.0f;
    }
    if (!any) return PICVR_ERROR_INVALID_LIGHT;
    e->texels = malloc(3 * n * sizeof *e->texels);
    e->cdf = malloc(n * sizeof *e->cdf);
    if (!e->texels || !e->cdf) return PICVR_ERROR_OUT_OF_HOST_MEMORY;  /* cref_free frees */
    memcpy(e->texels, bg->environment, 3 * n * sizeof *e->texels);
    e->width = W;
    e->height = H;
    e->rot_cos = cos((double)bg->env_rotation);
    e->rot_sin = sin((double)bg->env_rotation);
    double acc = 0.0;
    for (uint32_t r = 0; r < H; r++) {
        double omega = env_texel_omega(e, r);
        for (uint32_t c = 0; c < W; c++) {
            size_t i = (size_t)r * W + c;
            double wgt = env_lum(s, i) * omega;
            if (wgt > 0.0) e->last_texel = i;
            acc += wgt;
            e->cdf[i] = acc;
        }
    }
    e->total = acc;                         /* 0 when colour * intensity is black */
    return PICVR_OK;
}

static int load_lights(cref_scene *s, const picvr_light *lights, uint32_t count,
                       const picvr_background *bg)
{
    if (count > PICVR_MAX_LIGHTS) return PICVR_ERROR_TOO_MANY_LIGHTS;
    if (count > 0 && !lights) return PICVR_ERROR_NULL_POINTER;
    for (uint32_t i = 0; i < count; i++) {
        int st = load_light(&s->lights[i], &lights[i]);
        if (st != PICVR_OK) return st;
    }
    s->light_count = count;
    if (bg) {
        if (!finite3(bg->color) || !isfinite(bg->intensity)) return PICVR_ERROR_NON_FINITE;
        if (bg->intensity < 0.0f || bg->color[0] < 0.0f || bg->color[1] < 0.0f ||
            bg->color[2] < 0.0f)
            return PICVR_ERROR_INVALID_LIGHT;
        for (int k = 0; k < 3; k++) s->background[k] = (double)bg->color[k] * bg->intensity;
        if (bg->environment) {
            int st = load_env(s, bg);
            if (st != PICVR_OK) return st;
        }
    }
    /* selection probabilities: power / total (all 0 when everything is black); the
       background's power is pi R^2 times the integral of its luminance over the
       sphere (4 pi lum for a constant one) */
    double R2 = dot3(s->box_max, s->box_max);   /* half-diagonal squared */
    double bg_int = s->env.texels ? s->env.total : cref_luminance(s->background) * 4.0 * PI;
    double total = 0.0, bg_power = bg_int * PI * R2;
    for (uint32_t i = 0; i < count; i++) total += light_power(&s->lights[i], sqrt(R2));
    total += bg_power;
    if (!(total > 0.0) || !isfinite(total)) return total > 0.0 ? PICVR_ERROR_INVALID_LIGHT : PICVR_OK;
    for (uint32_t i = 0; i < count; i++)
        s->lights[i].p_select = light_power(&s->lights[i], sqrt(R2)) / total;  /* total > 0 */
    s->background_p_select = bg_power / total;
    return PICVR_OK;
}

static int load_camera(cref_scene *s, const picvr_camera *c)
{
    if (!c) return PICVR_ERROR_NULL_POINTER;
    picvr_camera cam = *c;
    if (!finite3(cam.position) || !finite3(cam.target) || !finite3(cam.up) ||
        !isfinite(cam.fov_y_degrees))
        return PICVR_ERROR_NON_FINITE;
    if (cam.width == 0 || cam.height == 0) return PICVR_ERROR_INVALID_DIMENSIONS;
    if (cam.width > PICVR_MAX_IMAGE_SIZE || cam.height > PICVR_MAX_IMAGE_SIZE)
        return PICVR_ERROR_INVALID_ARGUMENT;
    if (cam.fov_y_degrees == 0.0f) cam.fov_y_degrees = 40.0f;
    if (!(cam.fov_y_degrees > 0.0f && cam.fov_y_degrees <= 179.0f)) return PICVR_ERROR_INVALID_CAMERA;
    if (cam.up[0] == 0.0f && cam.up[1] == 0.0f && cam.up[2] == 0.0f) cam.up[1] = 1.0f;
    double up[3];
    for (int k = 0; k < 3; k++) {
        s->cam_pos[k] = cam.position[k];
        s->cam_f[k] = (double)cam.target[k] - cam.position[k];
        up[k] = cam.up[k];
    }
    if (normalize3(s->cam_f) == 0.0 || normalize3(up) == 0.0) return PICVR_ERROR_INVALID_CAMERA;
    cross3(s->cam_f, up, s->cam_r);
    if (normalize3(s->cam_r) < 1e-6) return PICVR_ERROR_INVALID_CAMERA;  /* up ~ parallel */
    cross3(s->cam_r, s->cam_f, s->cam_u);
    s->cam_h = tan(0.5 * cam.fov_y_degrees * PI / 180.0);  /* fov <= 179: finite */
    s->cam_aspect = (double)cam.width / cam.height;         /* height >= 1 */
    s->camera = cam;
    return PICVR_OK;
}

int cref_scene_init(cref_scene *s, const picvr_volume_desc *volume,
                    const picvr_tf_point *tf, uint32_t tf_count, float density,
                    const picvr_light *lights, uint32_t light_count,
                    const picvr_background *background,
                    const picvr_camera *camera, uint32_t seed)
{
    if (!s) return PICVR_ERROR_NULL_POINTER;
    memset(s, 0, sizeof *s);
    if (!volume || !camera) return PICVR_ERROR_NULL_POINTER;
    int st = load_volume(s, volume);
    if (st == PICVR_OK) st = load_tf(s, tf, tf_count, density);
    if (st == PICVR_OK) st = load_lights(s, lights, light_count, background);
    if (st == PICVR_OK) st = load_camera(s, camera);
    if (st == PICVR_OK)
        st = cref_majorant_build(s->voxels, s->dims, s->tf, s->tf_count, s->density,
                                 CREF_BRICK, &s->majorant);
    if (st != PICVR_OK) {
        cref_free(s);
        return st;
    }
    s->seed = seed;
    return PICVR_OK;
}

int cref_scene_set_scattering(cref_scene *s, const picvr_scattering *sc)
{
    if (!s) return PICVR_ERROR_NULL_POINTER;
    picvr_scattering def = {0};
    if (!sc) sc = &def;
    if (!isfinite(sc->back_g) || !isfinite(sc->back_weight)) return PICVR_ERROR_NON_FINITE;
    if (!(sc->back_g > -1.0f && sc->back_g < 1.0f) ||
        !(sc->back_weight >= 0.0f && sc->back_weight < 1.0f))
        return PICVR_ERROR_INVALID_ARGUMENT;
    s->max_bounces = sc->max_bounces;
    s->back_g = sc->back_g;
    s->back_weight = sc->back_weight;
    return PICVR_OK;
}

void cref_free(cref_scene *s)
{
    if (!s) return;
    free(s->voxels);
    free(s->env.texels);
    free(s->env.cdf);
    cref_majorant_free(&s->majorant);
    memset(s, 0, sizeof *s);
}
