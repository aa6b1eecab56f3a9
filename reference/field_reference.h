/* field_reference.h - a C reference of the light field of paper 002 carried to
 * participating media: radiance propagated through a grid of cells along D global
 * directions, each a sweep of parallel rays, iterated for multiple scattering; and a
 * deterministic camera ray marched through the stored field.  Double precision, one
 * thread, small grids: it fixes the discrete model and is the oracle the device's
 * field is tested against.  stb style: `#define FREF_IMPLEMENTATION` in one file.
 *
 * The discrete model (what the device must reproduce):
 *   - Cells: n[0] x n[1] x n[2] cubes of side h, the grid's corner at the origin; in
 *     each a constant extinction sigma_t and albedo a (the transfer function applied
 *     first, so a cell's sigma_t is the mean of the classified voxels it holds).
 *   - Directions: D = 2 * half global directions, a Fibonacci set over the upper
 *     hemisphere (z > 0), each used both ways; each stands for the solid angle 4 pi / D.
 *   - A sweep along direction w: parallel rays on a square lattice of spacing h / 2 in
 *     the plane normal to w, covering the grid's projection.  A lattice of spacing s
 *     has a point within s / sqrt 2 of any point, and every cell's projection contains
 *     a disk of radius h / 2, so each cell is crossed by at least one ray of every
 *     direction (s / sqrt 2 = 0.354 h < h / 2).  A ray enters with the boundary
 *     radiance (the background) and crosses cell i over length l with optical depth
 *     tau = sigma_t l; with the cell's source J (radiance scattered into w, per unit
 *     of extinction: albedo times the in-scattered radiance) the exact solution of
 *     dL/ds = sigma_t (J - L) is
 *         L_out = J + (L_in - J) e^-tau,
 *         mean over the segment = J + (L_in - J) (1 - e^-tau) / tau,
 *     and the cell's radiance along w is the length-weighted mean of its segments.
 *   - Phase function: Henyey-Greenstein of one g for the whole grid (g = 0: isotropic).
 *     Directions below are those the light travels along; p(cos) with cos the cosine
 *     between the light's direction before and after scattering.
 *   - Lights: one delta sun (unit direction toward it, irradiance E), point lights
 *     (intensity I) and the background: constant, or a function of direction (an
 *     environment map).  A sweep along w enters with the background seen looking along
 *     -w (one sample per direction); a camera ray that escapes sees it along its own
 *     direction.  A point light's transmittance is held per cell as its value at the
 *     cell's centre, exact along the line to the light through constant cells; its
 *     in-scattered radiance at x is I / d^2 T p, d = |x - light| (rule: d >= 1e-3 h).
 *     The sun's transmittance per cell is a sweep of its own along the sun's direction
 *     (no source, entering with 1); its in-scattered radiance into direction o is
 *     E T p(o . s), s = -sun_dir its light's direction, exact for every g.
 *   - The scattered field per cell: its fluence phi = sum over the D directions of
 *     4 pi / D times the cell's radiance along them, and with FREF_STORE_MOMENT its
 *     first moment F = the same sum of the radiance times the direction.  The
 *     in-scattered radiance into o is taken as (phi + 3 g F . o) / 4 pi: the first two
 *     spherical-harmonic bands of the radiance, (phi + 3 F . w) / 4 pi, convolved with
 *     Henyey-Greenstein, whose band-l factor is g^l.  Rule: it is clamped at 0 (a
 *     peaked field's two bands can go negative).  FREF_STORE_FLUENCE keeps phi alone
 *     (isotropic in-scattering of the scattered light, the sun's still exact).
 *   - delta-M (fref_config.delta_m; Wiscombe 1977): a forward-peaked phase function is
 *     split as f delta(forward) + (1 - f) HG(g'), f = g^2, g' = (g - f) / (1 - f): its
 *     first two moments kept, and the peak, which two bands cannot hold, counted as
 *     light that was not scattered.  The sweeps of the scattered field then run in the
 *     scaled medium sigma' = sigma (1 - f a), a' = a (1 - f) / (1 - f a), g', with the
 *     sun's transmittance T' through it in their source.  The camera's view keeps the
 *     true medium and phase function: the scattered field as (phi + 3 g F . o) / 4 pi
 *     (the peak's f L(o) plus (1 - f) HG(g') of the two bands has first moment g), and
 *     the sun as E T' p(o . s) (T' - T is light the peak scattered forward, which the
 *     camera's event scatters again: two events).  With one bounce there is no
 *     multiple scattering to approximate, and delta-M is off.
 *   - Bounces b (scatter events per path, as picvr_scattering.max_bounces + 1, the
 *     camera's included): pass 1 sweeps the background with no source; pass k + 1
 *     sweeps with the source J(w) = a (the lights' in-scattered radiance into w + the
 *     scattered field's of pass k), the point lights' at the cell's centre.
 *     Unlimited: iterated until no cell's phi moves by more than tol (relative to the
 *     largest), at most max_iterations.
 *   - Rendering: a camera ray (direction d, from the camera on) crosses the cells front
 *     to back; a segment of optical depth tau adds T (1 - e^-tau) a L_s(-d) of its cell,
 *     the point lights' 1/d^2 and direction taken at the segment's middle, and
 *     multiplies T by e^-tau; the background along d is added times the final T.
 *
 * Conserved exactly by this model (the tests): an empty grid renders the background;
 * with albedo 1, a background L and no sun, phi = 4 pi L and F = 0 (radiance L
 * everywhere) is the fixed point of every sweep, whatever g (the white furnace), so the
 * converged field renders L at any density; one sweep's absorbed power equals the power
 * its rays carry in minus out.
 *
 * Numerics: (1 - e^-tau) / tau is 1 - tau / 2 below tau = 1e-6 (no 0 / 0), and every
 * exp takes tau >= 0.  A cell no ray crossed (impossible with the lattice above; kept
 * as a rule) takes its source J as its radiance.
 */
#ifndef FIELD_REFERENCE_H
#define FIELD_REFERENCE_H

#include <stdint.h>

typedef struct fref_grid {
    uint32_t n[3];
    double h;               /* cell side (world units) */
    const double *sigma_t;  /* n[0] n[1] n[2] values, x fastest; >= 0 */
    const double *albedo;   /* the same layout; in [0, 1] */
    double g;               /* Henyey-Greenstein asymmetry of every cell, in (-1, 1) */
} fref_grid;

#define FREF_MAX_POINTS 4

typedef struct fref_lights {
    double sun_dir[3];      /* unit, toward the sun */
    double sun_irradiance;  /* 0: no sun */
    double background;      /* constant radiance of every escaping direction (sky NULL) */
    /* the radiance seen looking along unit w (an environment map); NULL: background */
    double (*sky)(const double w[3], void *user);
    void *sky_user;
    uint32_t point_count;   /* point lights, <= FREF_MAX_POINTS */
    double point_pos[FREF_MAX_POINTS][3];   /* grid coordinates (the grid's corner at 0) */
    double point_intensity[FREF_MAX_POINTS];
} fref_lights;

#define FREF_BOUNCES_UNLIMITED 0xffffffffu
#define FREF_STORE_FLUENCE 0u   /* phi per cell */
#define FREF_STORE_MOMENT 1u    /* phi and its first moment F per cell */

typedef struct fref_config {
    uint32_t half_directions;   /* D / 2 >= 1 */
    uint32_t bounces;           /* >= 1, or FREF_BOUNCES_UNLIMITED */
    double tol;                 /* unlimited: stop when phi's largest change is below tol * its max */
    uint32_t max_iterations;    /* unlimited: at most this many sweeps of all directions */
    uint32_t store;             /* FREF_STORE_* */
    uint32_t delta_m;           /* 1: the scattered field's sweeps in the delta-M scaled
                                   medium (below); the camera's view stays exact */
} fref_config;

typedef struct fref_field {
    uint32_t n[3];
    uint32_t store;         /* FREF_STORE_* */
    double *T_sun;          /* the sun's transmittance, cell means */
    double *T_scaled;       /* delta-M: through the scaled medium (the sweeps' source); else NULL */
    double *T_point;        /* point light k's transmittance from cell c's centre at [k * cells + c] */
    double *T_point_scaled; /* delta-M: the same through the scaled medium; else NULL */
    int multiple;           /* bounces > 1 (delta-M's camera view of the sun takes T_scaled) */
    double *phi;            /* fluence of the scattered light and the background, cell means */
    double *F;              /* FREF_STORE_MOMENT: its first moment, 3 per cell; else NULL */
    uint32_t iterations;    /* sweeps of all directions made */
    double last_change;     /* the last iteration's largest change of phi relative to its max */
} fref_field;

/* 0 on success, -1 on bad input or no memory (*out then holds nothing to free). */
int fref_build(const fref_grid *g, const fref_lights *l, const fref_config *c, fref_field *out);
void fref_free(fref_field *f);

/* The radiance scattered at x (in cell `cell`) into direction o (unit, the light's
   direction after scattering), per unit of scattering: the lights' and the scattered
   field's. */
double fref_in_scatter(const fref_grid *g, const fref_field *f, const fref_lights *l, uint64_t cell, const double x[3],
                       const double o[3]);

/* The radiance that reaches ro from along -rd (rd unit) through the field. */
double fref_render_ray(const fref_grid *g, const fref_field *f, const fref_lights *l, const double ro[3],
                       const double rd[3]);

/* One sweep along unit w of a grid with cell sources J (NULL: none) entering with
   radiance L_in: each cell's mean radiance along w into L (n cells), and the power the
   rays carry in, carry out and that the cells absorb (sigma_t times the integral of L
   over each segment, times each ray's cross-section), for the energy check. */
void fref_sweep(const fref_grid *g, const double w[3], const double *J, double L_in, double *L, double *power_in,
                double *power_out, double *power_absorbed);

/* The k-th of the half directions (unit, z > 0). */
void fref_direction(uint32_t k, uint32_t half, double w[3]);

#endif

#ifdef FREF_IMPLEMENTATION
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define FREF_PI 3.14159265358979323846

/* (1 - e^-tau) / tau; tau >= 0.  Rule: below 1e-6 its series 1 - tau / 2 (no 0 / 0). */
static double fref_mean_factor(double tau) {
    return tau < 1e-6 ? 1.0 - 0.5 * tau : -expm1(-tau) / tau;
}

void fref_direction(uint32_t k, uint32_t half, double w[3]) {
    /* Fibonacci points on the hemisphere: z uniform in (0, 1) (equal areas), azimuth by
       the golden angle */
    double z = 1.0 - (k + 0.5) / half;
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    double phi = (double)k * FREF_PI * (3.0 - sqrt(5.0));
    w[0] = r * cos(phi);
    w[1] = r * sin(phi);
    w[2] = z;
}

/* An orthonormal basis u, v of the plane normal to unit w. */
static void fref_basis(const double w[3], double u[3], double v[3]) {
    double a[3] = {fabs(w[0]) < 0.9 ? 1.0 : 0.0, fabs(w[0]) < 0.9 ? 0.0 : 1.0, 0.0};
    u[0] = a[1] * w[2] - a[2] * w[1];
    u[1] = a[2] * w[0] - a[0] * w[2];
    u[2] = a[0] * w[1] - a[1] * w[0];
    double nu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int i = 0; i < 3; i++) u[i] /= nu;
    v[0] = w[1] * u[2] - w[2] * u[1];
    v[1] = w[2] * u[0] - w[0] * u[2];
    v[2] = w[0] * u[1] - w[1] * u[0];
}

/* The ray ro + t rd against the grid's box: [t0, t1]; 0 when it misses. */
static int fref_box(const fref_grid *g, const double ro[3], const double rd[3], double *t0, double *t1) {
    double a = 0.0, b = INFINITY;
    for (int i = 0; i < 3; i++) {
        double size = g->n[i] * g->h;
        if (rd[i] == 0.0) {
            if (ro[i] < 0.0 || ro[i] > size) return 0;
            continue;
        }
        double ta = (0.0 - ro[i]) / rd[i], tb = (size - ro[i]) / rd[i];
        if (ta > tb) { double s = ta; ta = tb; tb = s; }
        if (ta > a) a = ta;
        if (tb < b) b = tb;
    }
    *t0 = a;
    *t1 = b;
    return b > a;
}

/* Calls visit(cell, t, length, user) for each cell the ray crosses within [tmin, tmax],
   front to back (3D DDA; t where it enters the cell); the callback returns 0 to stop. */
typedef int (*fref_visit)(uint64_t cell, double t, double length, void *user);
static void fref_walk(const fref_grid *g, const double ro[3], const double rd[3], double tmin, double tmax,
                      fref_visit visit, void *user) {
    double t0, t1;
    if (!fref_box(g, ro, rd, &t0, &t1)) return;
    t0 = fmax(t0, tmin);
    t1 = fmin(t1, tmax);
    if (!(t1 > t0)) return;
    int c[3], step[3];
    double next[3], delta[3];
    for (int i = 0; i < 3; i++) {
        double p = (ro[i] + rd[i] * (t0 + 1e-12 * g->h)) / g->h;
        c[i] = (int)floor(p);
        if (c[i] < 0) c[i] = 0;
        if (c[i] >= (int)g->n[i]) c[i] = (int)g->n[i] - 1;
        step[i] = rd[i] > 0.0 ? 1 : -1;
        /* Rule: an axis the ray does not move along never has the next boundary */
        if (rd[i] == 0.0) { next[i] = INFINITY; delta[i] = INFINITY; continue; }
        double boundary = (c[i] + (rd[i] > 0.0 ? 1 : 0)) * g->h;
        next[i] = (boundary - ro[i]) / rd[i];
        delta[i] = g->h / fabs(rd[i]);
    }
    double t = t0;
    while (t < t1) {
        int a = next[0] < next[1] ? (next[0] < next[2] ? 0 : 2) : (next[1] < next[2] ? 1 : 2);
        double te = fmin(next[a], t1);
        uint64_t cell = ((uint64_t)c[2] * g->n[1] + (uint64_t)c[1]) * g->n[0] + (uint64_t)c[0];
        if (te > t && !visit(cell, t, te - t, user)) return;
        t = te;
        next[a] += delta[a];
        c[a] += step[a];
        if (c[a] < 0 || c[a] >= (int)g->n[a]) return;
    }
}

typedef struct fref_sweep_ray {
    const fref_grid *g;
    const double *J;
    double L;            /* the radiance the ray carries */
    double *sum_L, *sum_l;
    double absorbed;     /* sigma_t times the integral of L, this ray */
} fref_sweep_ray;

static int fref_sweep_visit(uint64_t cell, double t, double l, void *user) {
    (void)t;
    fref_sweep_ray *r = (fref_sweep_ray *)user;
    double s = r->g->sigma_t[cell], J = r->J ? r->J[cell] : 0.0;
    double tau = s * l;
    double mean = J + (r->L - J) * fref_mean_factor(tau);
    r->sum_L[cell] += l * mean;
    r->sum_l[cell] += l;
    r->absorbed += s * l * mean;
    r->L = J + (r->L - J) * exp(-tau);
    return 1;
}

void fref_sweep(const fref_grid *g, const double w[3], const double *J, double L_in, double *L, double *power_in,
                double *power_out, double *power_absorbed) {
    uint64_t cells = (uint64_t)g->n[0] * g->n[1] * g->n[2];
    double *sum_l = (double *)calloc(cells, sizeof(double));
    memset(L, 0, cells * sizeof(double));
    if (power_in) *power_in = 0.0;
    if (power_out) *power_out = 0.0;
    if (power_absorbed) *power_absorbed = 0.0;
    if (!sum_l) return;   /* rule: no memory, no sweep (L all 0); fref_build checks first */
    double u[3], v[3], centre[3], radius = 0.0;
    fref_basis(w, u, v);
    for (int i = 0; i < 3; i++) {
        centre[i] = 0.5 * g->n[i] * g->h;
        radius += centre[i] * centre[i];
    }
    radius = sqrt(radius);
    double s = 0.5 * g->h, area = s * s;
    int m = (int)ceil(radius / s);
    double pin = 0.0, pout = 0.0, pabs = 0.0;
    for (int j = -m; j <= m; j++)
        for (int i = -m; i <= m; i++) {
            double ro[3];
            for (int k = 0; k < 3; k++) ro[k] = centre[k] + (i + 0.5) * s * u[k] + (j + 0.5) * s * v[k] - 2.0 * radius * w[k];
            double t0, t1;
            if (!fref_box(g, ro, w, &t0, &t1)) continue;
            fref_sweep_ray r = {g, J, L_in, L, sum_l, 0.0};
            fref_walk(g, ro, w, 0.0, INFINITY, fref_sweep_visit, &r);
            pin += L_in * area;
            pout += r.L * area;
            pabs += r.absorbed * area;
        }
    for (uint64_t c = 0; c < cells; c++)
        L[c] = sum_l[c] > 0.0 ? L[c] / sum_l[c] : (J ? J[c] : 0.0);   /* rule: no ray crossed it */
    free(sum_l);
    if (power_in) *power_in = pin;
    if (power_out) *power_out = pout;
    if (power_absorbed) *power_absorbed = pabs;
}

/* Henyey-Greenstein, normalized over the sphere; cos between the directions before and
   after.  Rule: the denominator 1 + g^2 - 2 g cos >= (1 - |g|)^2 > 0 for |g| < 1. */
static double fref_hg(double g, double cos) {
    double den = 1.0 + g * g - 2.0 * g * cos;
    return (1.0 - g * g) / (4.0 * FREF_PI * den * sqrt(den));
}

/* The background seen looking along unit w. */
static double fref_background(const fref_lights *l, const double w[3]) {
    return l->sky ? l->sky(w, l->sky_user) : l->background;
}

/* As fref_in_scatter, with the lights' transmittances (T the sun's, Tp the points')
   and the asymmetry g given; h the cell side. */
static double fref_in_scatter_with(const fref_grid *grid, double g, const double *T, const double *Tp, const fref_field *f,
                                   const fref_lights *l, uint64_t cell, const double x[3], const double o[3]) {
    double L = 0.0;
    uint64_t cells = (uint64_t)grid->n[0] * grid->n[1] * grid->n[2];
    if (l->sun_irradiance > 0.0)
        L += l->sun_irradiance * T[cell] * fref_hg(g, -(o[0] * l->sun_dir[0] + o[1] * l->sun_dir[1] + o[2] * l->sun_dir[2]));
    for (uint32_t k = 0; k < l->point_count; k++) {
        double s[3], d2 = 0.0;
        for (int i = 0; i < 3; i++) { s[i] = x[i] - l->point_pos[k][i]; d2 += s[i] * s[i]; }
        double dmin = 1e-3 * grid->h;   /* rule: a light on the point gives a large, finite value */
        double d = sqrt(fmax(d2, dmin * dmin));
        double cos = (s[0] * o[0] + s[1] * o[1] + s[2] * o[2]) / d;
        L += l->point_intensity[k] / (d * d) * Tp[k * cells + cell] * fref_hg(g, fmax(-1.0, fmin(1.0, cos)));
    }
    double band = f->phi[cell];
    if (f->F) band += 3.0 * g * (f->F[3 * cell] * o[0] + f->F[3 * cell + 1] * o[1] + f->F[3 * cell + 2] * o[2]);
    return L + fmax(band, 0.0) / (4.0 * FREF_PI);   /* rule: two bands clamped at 0 */
}

double fref_in_scatter(const fref_grid *g, const fref_field *f, const fref_lights *l, uint64_t cell, const double x[3],
                       const double o[3]) {
    int scaled = f->T_scaled && f->multiple;
    return fref_in_scatter_with(g, g->g, scaled ? f->T_scaled : f->T_sun, scaled ? f->T_point_scaled : f->T_point, f, l, cell,
                                x, o);
}

/* The centre of cell c. */
static void fref_centre(const fref_grid *g, uint64_t c, double x[3]) {
    x[0] = ((double)(c % g->n[0]) + 0.5) * g->h;
    x[1] = ((double)(c / g->n[0] % g->n[1]) + 0.5) * g->h;
    x[2] = ((double)(c / ((uint64_t)g->n[0] * g->n[1])) + 0.5) * g->h;
}

typedef struct fref_depth_walk { const fref_grid *g; double tau; } fref_depth_walk;
static int fref_depth_visit(uint64_t cell, double t, double l, void *user) {
    (void)t;
    fref_depth_walk *r = (fref_depth_walk *)user;
    r->tau += r->g->sigma_t[cell] * l;
    return 1;
}

/* Each point light's transmittance from every cell's centre, exact along the line
   through the constant cells, into T (point_count x cells). */
static void fref_point_transmittance(const fref_grid *g, const fref_lights *l, double *T) {
    uint64_t cells = (uint64_t)g->n[0] * g->n[1] * g->n[2];
    for (uint32_t k = 0; k < l->point_count; k++)
        for (uint64_t c = 0; c < cells; c++) {
            double x[3], w[3], d = 0.0;
            fref_centre(g, c, x);
            for (int i = 0; i < 3; i++) { w[i] = l->point_pos[k][i] - x[i]; d += w[i] * w[i]; }
            d = sqrt(d);
            fref_depth_walk r = {g, 0.0};
            if (d > 0.0) {   /* rule: a light at the centre itself: T = 1 */
                for (int i = 0; i < 3; i++) w[i] /= d;
                fref_walk(g, x, w, 0.0, d, fref_depth_visit, &r);
            }
            T[k * cells + c] = exp(-r.tau);
        }
}

/* One pass: every direction swept with the source of the field so far (src: NULL for
   none), into phi (and F). */
static void fref_pass(const fref_grid *g, const fref_lights *l, uint32_t half, const fref_field *src, double *J,
                      double *L, double *phi, double *F) {
    uint64_t cells = (uint64_t)g->n[0] * g->n[1] * g->n[2];
    memset(phi, 0, cells * sizeof(double));
    if (F) memset(F, 0, 3 * cells * sizeof(double));
    double weight = 4.0 * FREF_PI / (2.0 * half);
    for (uint32_t k = 0; k < 2 * half; k++) {
        double w[3];
        fref_direction(k / 2, half, w);
        if (k & 1) for (int i = 0; i < 3; i++) w[i] = -w[i];
        if (src)
            for (uint64_t c = 0; c < cells; c++) {
                double x[3];
                fref_centre(g, c, x);
                J[c] = g->albedo[c] * fref_in_scatter_with(g, g->g, src->T_scaled ? src->T_scaled : src->T_sun,
                                                           src->T_point_scaled ? src->T_point_scaled : src->T_point, src, l,
                                                           c, x, w);
            }
        double back[3] = {-w[0], -w[1], -w[2]};
        fref_sweep(g, w, src ? J : NULL, fref_background(l, back), L, NULL, NULL, NULL);
        for (uint64_t c = 0; c < cells; c++) {
            phi[c] += weight * L[c];
            if (F) for (int i = 0; i < 3; i++) F[3 * c + i] += weight * L[c] * w[i];
        }
    }
}

int fref_build(const fref_grid *g, const fref_lights *l, const fref_config *c, fref_field *out) {
    memset(out, 0, sizeof *out);
    if (!g || !l || !c || !g->sigma_t || !g->albedo || !(g->h > 0.0) || !g->n[0] || !g->n[1] || !g->n[2] ||
        !c->half_directions || !c->bounces || !(fabs(g->g) < 1.0) || c->store > FREF_STORE_MOMENT ||
        l->point_count > FREF_MAX_POINTS)
        return -1;
    uint64_t cells = (uint64_t)g->n[0] * g->n[1] * g->n[2];
    size_t points = (l->point_count ? l->point_count : 1) * cells;
    int moment = c->store == FREF_STORE_MOMENT;
    int dm = c->delta_m && g->g != 0.0 && c->bounces > 1;   /* one event: nothing to scale */
    /* everything at once, so that one path frees it all (free(NULL) is nothing) */
    out->T_sun = (double *)calloc(cells, sizeof(double));
    out->T_point = (double *)calloc(points, sizeof(double));
    out->phi = (double *)calloc(cells, sizeof(double));
    out->F = moment ? (double *)calloc(3 * cells, sizeof(double)) : NULL;
    out->T_scaled = dm ? (double *)calloc(cells, sizeof(double)) : NULL;
    out->T_point_scaled = dm ? (double *)calloc(points, sizeof(double)) : NULL;
    double *phi2 = (double *)calloc(cells, sizeof(double)), *F2 = moment ? (double *)calloc(3 * cells, sizeof(double)) : NULL;
    double *J = (double *)calloc(cells, sizeof(double)), *L = (double *)calloc(cells, sizeof(double));
    double *sigma2 = dm ? (double *)malloc(cells * sizeof(double)) : NULL;
    double *albedo2 = dm ? (double *)malloc(cells * sizeof(double)) : NULL;
    if (!out->T_sun || !out->T_point || !out->phi || (moment && (!out->F || !F2)) || !phi2 || !J || !L ||
        (dm && (!out->T_scaled || !out->T_point_scaled || !sigma2 || !albedo2))) {
        fref_free(out);
        free(phi2); free(F2); free(J); free(L); free(sigma2); free(albedo2);
        return -1;
    }
    out->n[0] = g->n[0]; out->n[1] = g->n[1]; out->n[2] = g->n[2];
    out->store = c->store;
    out->multiple = c->bounces > 1;
    double toward[3] = {-l->sun_dir[0], -l->sun_dir[1], -l->sun_dir[2]};
    if (l->sun_irradiance > 0.0) fref_sweep(g, toward, NULL, 1.0, out->T_sun, NULL, NULL, NULL);
    fref_point_transmittance(g, l, out->T_point);
    /* delta-M: the sweeps' medium; rule: 1 - f a >= 1 - f > 0 for |g| < 1 */
    fref_grid scaled = *g;
    if (dm) {
        double f = g->g * g->g;
        for (uint64_t i = 0; i < cells; i++) {
            double a = g->albedo[i];
            sigma2[i] = g->sigma_t[i] * (1.0 - f * a);
            albedo2[i] = a * (1.0 - f) / (1.0 - f * a);
        }
        scaled.sigma_t = sigma2;
        scaled.albedo = albedo2;
        scaled.g = (g->g - f) / (1.0 - f);
        if (l->sun_irradiance > 0.0) fref_sweep(&scaled, toward, NULL, 1.0, out->T_scaled, NULL, NULL, NULL);
        fref_point_transmittance(&scaled, l, out->T_point_scaled);
        g = &scaled;
    }
    /* pass 1: the background, attenuated */
    fref_pass(g, l, c->half_directions, NULL, J, L, out->phi, out->F);
    uint32_t it = 1, limit = c->bounces == FREF_BOUNCES_UNLIMITED ? c->max_iterations : c->bounces;
    double change = 0.0;
    while (it < limit) {
        fref_pass(g, l, c->half_directions, out, J, L, phi2, F2);
        double top = 0.0;
        change = 0.0;
        for (uint64_t i = 0; i < cells; i++) {
            change = fmax(change, fabs(phi2[i] - out->phi[i]));
            top = fmax(top, phi2[i]);
        }
        double *swap = out->phi; out->phi = phi2; phi2 = swap;
        swap = out->F; out->F = F2; F2 = swap;
        it++;
        change = top > 0.0 ? change / top : 0.0;   /* rule: an all-dark field has converged */
        if (c->bounces == FREF_BOUNCES_UNLIMITED && change <= c->tol) break;
    }
    free(phi2); free(F2); free(J); free(L); free(sigma2); free(albedo2);
    out->iterations = it;
    out->last_change = change;
    return 0;
}

void fref_free(fref_field *f) {
    free(f->T_sun);
    free(f->T_scaled);
    free(f->T_point);
    free(f->T_point_scaled);
    free(f->phi);
    free(f->F);
    memset(f, 0, sizeof *f);
}

typedef struct fref_camera_ray {
    const fref_grid *g;
    const fref_field *f;
    const fref_lights *l;
    double ro[3], rd[3];
    double o[3];         /* toward the camera */
    double T, L;
} fref_camera_ray;

static int fref_camera_visit(uint64_t cell, double t, double l, void *user) {
    fref_camera_ray *r = (fref_camera_ray *)user;
    double e = exp(-r->g->sigma_t[cell] * l), x[3];
    for (int i = 0; i < 3; i++) x[i] = r->ro[i] + r->rd[i] * (t + 0.5 * l);   /* the segment's middle */
    r->L += r->T * (1.0 - e) * r->g->albedo[cell] * fref_in_scatter(r->g, r->f, r->l, cell, x, r->o);
    r->T *= e;
    return r->T > 0.0;
}

double fref_render_ray(const fref_grid *g, const fref_field *f, const fref_lights *l, const double ro[3],
                       const double rd[3]) {
    fref_camera_ray r = {g, f, l, {ro[0], ro[1], ro[2]}, {rd[0], rd[1], rd[2]}, {-rd[0], -rd[1], -rd[2]}, 1.0, 0.0};
    fref_walk(g, ro, rd, 0.0, INFINITY, fref_camera_visit, &r);
    return r.L + r.T * fref_background(l, rd);
}
#endif
