/* cpu_reference.h - an independent C11 + OpenMP implementation of picvr's per-pixel
 * algorithm (see CONVENTIONS in picvr.h), written without looking at the shaders.
 *
 * Two uses:
 *   - the CPU side of bench/bench_speed.c (samples/s on all cores);
 *   - a second implementation that the tests compare the Vulkan kernels against
 *     statistically (same scene, same expectation, different random numbers).
 *
 * Per pixel and iteration: a jittered camera ray (picvr.h "Camera"), delta tracking
 * against a majorant grid of 4^3-voxel bricks (3D DDA, exponential steps restarted at
 * every cell boundary) to the first scatter event, then a path (picvr_scattering):
 *   - at every scatter event the throughput (RGB, 1 at the first event) is multiplied
 *     by the albedo there, and next-event estimation adds throughput * one light or the
 *     background chosen by power, shadow transmittance by ratio tracking, weighted by
 *     MIS (power heuristic) against phase sampling for sphere/rect lights, a sun with
 *     angular size > 0 and the background (point lights and delta suns: light
 *     sampling alone);
 *   - the phase function is (1 - back_weight) HG(g(x)) + back_weight HG(back_g), g(x)
 *     interpolated from the transfer function like the albedo; it is sampled exactly,
 *     so the phase-sampling density is the phase value;
 *   - the last allowed event (max_bounces + 1; never with PICVR_BOUNCES_UNLIMITED)
 *     draws one phase direction and adds the MIS-weighted radiance it sees (area light,
 *     or background plus sun cones) times a ratio-tracking transmittance estimate:
 *     with max_bounces = 0 this is the single scattering of Exposure Render, with the
 *     same random numbers as before the paths existed (g = 0, one lobe: the same
 *     image up to rounding);
 *   - an earlier event continues the path along a phase-sampled direction by delta
 *     tracking: a collision is the next event, an escaping ray adds throughput * the
 *     same MIS-weighted radiance it sees (no transmittance factor: escaping has
 *     probability T);
 *   - before continuing from event k >= 2, Russian roulette: survive with
 *     q = min(1, max channel of the throughput), throughput /= q (no random number is
 *     drawn when q = 1); a path whose throughput is 0 in every channel ends.
 * The background is constant or an equirectangular environment map (picvr.h, above
 * picvr_background), importance-sampled by luminance (see "Environment map" below).
 * cref_render_stats.mean_path_length counts the scatter events per camera sample: the
 * events a path processes (next-event estimation there), so a path that Russian
 * roulette ends before its continuation ray is traced adds none.
 *
 * Choices the header leaves open (documented here so the GPU side can match them):
 *   - Area lights (sphere, rect) are opaque to every ray: a camera ray, phase ray,
 *     path continuation or shadow ray that hits one stops there.  A rect's back side is
 *     black.  A point inside a sphere light sees its emission from every direction.
 *   - Camera rays that escape see the background and area lights, never a sun disk;
 *     rays after a scatter event (phase samples, path continuations) see sun cones too.
 *   - Scattering angle: cos = dot(d, w) for a path travelling along d (from the camera
 *     side into the event) that gathers light from direction w (toward the light):
 *     the light travels along -w, then along -d.  With g > 0, a sun behind the medium
 *     as seen from the camera makes it bright.
 *   - The rotation of the map: w' = R_y(-env_rotation) w with the right-handed
 *     R_y(a) = [[cos a, 0, sin a], [0, 1, 0], [-sin a, 0, cos a]] (a > 0 turns +z
 *     toward +x; w' = (cos a w.x - sin a w.z, w.y, sin a w.x + cos a w.z)).
 *   - Texel indices are clamped into the map: phi = +pi and theta = pi fall in the last
 *     column / row.
 *   - Light selection power (luminance of colour*intensity, times): sphere
 *     pi*4*pi*r^2, rect pi*area, point 4*pi, directional pi*R^2, background
 *     pi*R^2 * (integral of its luminance over the sphere: 4*pi for a constant one,
 *     sum_j lum_j Omega_j for a map), with R = half the diagonal of the volume box.
 *     (This sets the variance, not the expectation.)
 *   - A sun of angular diameter a > 0 has radiance E / (pi sin^2(a/2)) over its
 *     cone, so that colour * intensity = E is the irradiance on a plane facing it
 *     (picvr.h's unit).
 *   - A tracking loop that runs past CREF_MAX_STEPS tentative collisions stops:
 *     free flight -> the camera ray is treated as escaping (background or area light,
 *     alpha 0), a path continuation ends the path with nothing more; ratio tracking ->
 *     the transmittance estimate so far.  A path also ends when its free-flight
 *     tracking (camera ray and continuations, not shadow rays) has taken
 *     CREF_PATH_STEPS (= PICVR_PATH_STEPS) tentative collisions in all.  All of these
 *     are biased (as on the GPU); such samples are counted in
 *     cref_render_stats.truncated_paths.
 *   - Alpha (coverage) is 1 when the camera ray collides, else 0, whatever the path
 *     does after.
 *   - Russian roulette is decided at an event, before its continuation ray is drawn
 *     and traced (picvr.h says "from the third scatter event on"; read here as: the
 *     third event is reached only by paths that survive it).  Where it is decided
 *     changes the variance and mean_path_length, not the expectation.
 *
 * Environment map.  Texel j (row r, column c) covers phi in 2pi [c/W - 1/2,
 * (c+1)/W - 1/2] and theta in pi [r/H, (r+1)/H], solid angle Omega_j = (2pi/W)
 * (cos theta_r - cos theta_{r+1}).  Light sampling picks texel j with probability
 * lum_j Omega_j / total (lum_j the luminance of colour * intensity * texel j, total the
 * sum over texels), then a direction uniform in phi and cos theta within the texel:
 * density lum_j / total per steradian, 0 exactly where the background is black, so
 * phase-sampled rays that escape there take full weight.  A 1x1 map is the uniform
 * sphere, as the constant background.
 *
 * Numerics: HG is evaluated as (1 - g)(1 + g) / (4 pi den^1.5) with den written as a
 * sum of two non-negative terms ((1 - |g|)^2 + 2 |g| (1 -+ cos)), and sampled by an
 * inverse CDF rearranged so that it never divides by g (exact at g = 0); g is clamped
 * into +-(1 - 2^-24), which changes no float in (-1, 1).
 *
 * Nothing here is thread-safe to mutate; cref_render() only reads the scene.
 */
#ifndef PICVR_CPU_REFERENCE_H
#define PICVR_CPU_REFERENCE_H

#include <stddef.h>
#include <stdint.h>

#include "picvr.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CREF_BRICK 4            /* voxels per majorant-brick side */
#define CREF_MAX_STEPS 4096     /* tentative collisions per tracked ray */
#define CREF_PATH_STEPS PICVR_PATH_STEPS /* free-flight tentative collisions per path */

/* Majorant grid: one max of sigma_t (per world unit) per brick of brick^3 voxels,
   including a 1-voxel apron on every side (trilinear interpolation at a point of
   the brick reads voxels up to one voxel outside it). */
typedef struct cref_majorant {
    uint32_t brick;             /* voxels per brick side */
    uint32_t dims[3];           /* bricks per axis = ceil(volume dims / brick) */
    float *sigma_max;           /* dims[0]*dims[1]*dims[2], x fastest; rounded up */
} cref_majorant;

/* One light, preprocessed (read-only; filled by cref_scene_init). */
typedef struct cref_light {
    picvr_light_type type;
    double radiance[3];         /* colour*intensity: L (area), E (sun), I (point) */
    double pos[3];              /* sphere centre, rect centre, point position */
    double radius;              /* sphere */
    double edge_u[3], edge_v[3];/* rect full edges */
    double normal[3];           /* rect: unit cross(edge_u, edge_v) */
    double area;                /* rect: |cross(edge_u, edge_v)| */
    double dir[3];              /* directional: unit vector toward the light */
    double cos_half;            /* directional: cos(angular_diameter / 2) */
    double omega;               /* directional: cone solid angle; 0 for a delta sun */
    double p_select;            /* probability of picking this light for light sampling */
} cref_light;

/* Environment map (read-only; filled by cref_scene_init).  texels NULL: constant. */
typedef struct cref_env {
    uint32_t width, height;
    float *texels;              /* width*height RGB as given, rows top to bottom; the
                                   radiance is cref_scene.background * texel */
    double *cdf;                /* running sum of lum_j Omega_j, x fastest */
    double total;               /* cdf's last value (0 when the background is black) */
    size_t last_texel;          /* the last texel of non-zero weight */
    double rot_cos, rot_sin;    /* of env_rotation */
} cref_env;

typedef struct cref_scene {
    /* volume */
    uint32_t dims[3];
    double spacing[3];
    double inv_spacing[3];
    double box_min[3], box_max[3];
    float *voxels;              /* normalized to [0,1], x fastest */
    /* transfer function */
    picvr_tf_point tf[PICVR_MAX_TF_POINTS];
    uint32_t tf_count;
    double density;             /* D */
    cref_majorant majorant;
    /* lights: lights[0..light_count-1], then the background's selection probability */
    cref_light lights[PICVR_MAX_LIGHTS];
    uint32_t light_count;
    double background[3];       /* colour * intensity: the radiance, or the map's scale */
    double background_p_select;
    cref_env env;
    /* scattering (cref_scene_set_scattering; zero: single scattering, one lobe) */
    uint32_t max_bounces;       /* PICVR_BOUNCES_UNLIMITED: Russian roulette only */
    double back_g, back_weight;
    int roulette_off;           /* tests only: 1 turns Russian roulette off (the same
                                   expectation, longer paths; bounded by max_bounces and
                                   CREF_PATH_STEPS) */
    /* camera (defaults resolved: up 0,1,0 when zero, fov 40 when 0) */
    picvr_camera camera;
    double cam_pos[3], cam_f[3], cam_r[3], cam_u[3], cam_h, cam_aspect;
    uint32_t seed;
} cref_scene;

typedef struct cref_render_stats {
    uint64_t samples;           /* pixel samples rendered */
    uint64_t scattered;         /* samples whose primary ray collided (alpha 1) */
    uint64_t truncated_paths;   /* samples with a tracking loop cut at CREF_MAX_STEPS */
    uint64_t majorant_violations; /* sigma_t > majorant seen (must stay 0) */
    uint64_t scatter_events;    /* scatter events of all paths */
    double mean_path_length;    /* scatter_events / samples (misses count 0); 0 if none */
} cref_render_stats;

/* Builds the scene from the public API structs (copies everything, the environment
   map included; the caller may free its buffers afterwards).  tf may be NULL with
   tf_count 0 (the API default: opacity = value, albedo 1, g 0, density 1); lights may
   be NULL with count 0; background may be NULL (black), its environment NULL
   (constant).  Validation is minimal (ranges, finiteness, degenerate shapes, g in
   (-1, 1)).  The scattering starts as single scattering with one lobe (see
   cref_scene_set_scattering).  Returns PICVR_OK (0) or a picvr_status; on error *s is
   left zeroed and owns nothing. */
int cref_scene_init(cref_scene *s, const picvr_volume_desc *volume,
                    const picvr_tf_point *tf, uint32_t tf_count, float density,
                    const picvr_light *lights, uint32_t light_count,
                    const picvr_background *background,
                    const picvr_camera *camera, uint32_t seed);

/* Sets the scattering model as picvr_set_scattering does (NULL: the defaults, single
   scattering, one lobe).  back_g in (-1, 1), back_weight in [0, 1); on error nothing
   changes.  Returns PICVR_OK or a picvr_status. */
int cref_scene_set_scattering(cref_scene *s, const picvr_scattering *scattering);

/* Frees what cref_scene_init allocated and zeroes *s.  NULL is allowed. */
void cref_free(cref_scene *s);

/* Renders `iterations` samples per pixel (iterations 0 .. iterations-1) on all
   OpenMP threads.  rgba_mean_out: width*height*4 floats, rows top to bottom, the
   mean linear radiance RGB and coverage A.  lum_m2_out (may be NULL): width*height
   doubles, Welford's M2 of the Rec.709 luminance of the samples, so the sample
   variance is M2 / (iterations - 1).  Returns PICVR_OK or a picvr_status. */
int cref_render(const cref_scene *s, uint32_t iterations, float *rgba_mean_out,
                double *lum_m2_out);

/* As cref_render, for iterations first_iteration .. first_iteration+iterations-1
   (independent batches of one seed), with optional statistics. */
int cref_render_ex(const cref_scene *s, uint32_t first_iteration, uint32_t iterations,
                   float *rgba_mean_out, double *lum_m2_out, cref_render_stats *stats);

/* ---- building blocks, exposed for tests ------------------------------------------ */

/* Transfer function, exactly piecewise linear, constant beyond the end points; at a
   step (equal values) the later point wins at that value.  albedo may be NULL. */
double cref_tf_eval(const picvr_tf_point *tf, uint32_t count, double v, double albedo[3]);

/* As cref_tf_eval, also the interpolated Henyey-Greenstein g (g may be NULL). */
double cref_tf_eval_ex(const picvr_tf_point *tf, uint32_t count, double v, double albedo[3],
                       double *g);

/* Max of the opacity over v in [lo, hi]: the end points and every control point in
   between (exact for a piecewise-linear function). */
double cref_tf_max_opacity(const picvr_tf_point *tf, uint32_t count, double lo, double hi);

/* Majorant grid builder.  voxels: normalized [0,1] floats, x fastest.  brick >= 1.
   Returns PICVR_OK or a picvr_status; free with cref_majorant_free. */
int cref_majorant_build(const float *voxels, const uint32_t dims[3],
                        const picvr_tf_point *tf, uint32_t tf_count, double density,
                        uint32_t brick, cref_majorant *out);
void cref_majorant_free(cref_majorant *m);

/* Normalized data value v(x) and sigma_t(x) = D * opacity(v(x)) at a world point. */
double cref_sample_value(const cref_scene *s, const double x[3]);
double cref_sigma_t(const cref_scene *s, const double x[3]);

/* Camera ray of pixel (px, py) with jitter (jx, jy) in [0,1): unit direction. */
void cref_camera_ray(const cref_scene *s, uint32_t px, uint32_t py, double jx, double jy,
                     double dir[3]);

/* Ray / volume box: 1 and the parameter interval [*t0, *t1] (t0 may be negative)
   for a hit, 0 for a miss.  dir need not be unit. */
int cref_intersect_box(const cref_scene *s, const double origin[3], const double dir[3],
                       double *t0, double *t1);

/* One ratio-tracking estimate of the transmittance from origin along dir (normalized
   here) over world distance [0, tmax], through the majorant grid, with the random
   stream `sample` (different values give independent estimates).  Only the volume
   attenuates (lights do not occlude here).  Returns a value in [0, 1]; 1 for a zero
   dir. */
double cref_transmittance_ratio(const cref_scene *s, const double origin[3],
                                const double dir[3], double tmax, uint64_t sample);

/* Deterministic transmittance exp(-integral of sigma_t) by the midpoint rule with
   steps of at most `step` world units (0 means 0.05 * the smallest spacing); the
   closed form that tests hold the estimators against. */
double cref_transmittance_quadrature(const cref_scene *s, const double origin[3],
                                     const double dir[3], double tmax, double step);

/* Henyey-Greenstein phase function (per steradian) at cos = dot(direction the light
   travels before, after); g > 0 forward.  g is clamped into +-(1 - 2^-24), cos into
   [-1, 1]; NaN g means 0.  Finite and > 0 for every input. */
double cref_hg_eval(double g, double cos_t);

/* The cos of a direction drawn exactly from HG(g) with the uniform u in [0, 1]
   (inverse CDF; increasing in u: u = 0 gives -1, u = 1 gives 1).  In [-1, 1]. */
double cref_hg_sample(double g, double u);

/* The phase function (1 - back_weight) HG(g) + back_weight HG(back_g) at cos, as the
   renderer evaluates it at a scatter point. */
double cref_phase_eval(double g, double back_g, double back_weight, double cos_t);

/* The renderer's phase sampling: a unit direction w drawn exactly from cref_phase_eval
   around the unit path direction d (cos = dot(d, w)) with the uniforms u_lobe (the back
   lobe when u_lobe < back_weight), u1 (cos) and u2 (azimuth); an isotropic phase
   function (g = 0 and no back lobe of g != 0) takes the uniform sphere z = 1 - 2 u1,
   phi = 2 pi u2 in world axes instead. */
void cref_phase_sample(double g, double back_g, double back_weight, const double d[3],
                       double u_lobe, double u1, double u2, double w[3]);

/* The background's radiance arriving from unit direction w (toward where the light
   comes from) into rgb, and the density per steradian with which light sampling draws
   w: 1/(4 pi) for a constant background; for a map lum_j / total (0 for a black
   texel or background). */
double cref_background_eval(const cref_scene *s, const double w[3], double rgb[3]);

/* Draws a direction from the background's sampling density with the uniforms u1, u2,
   u3 in [0, 1) (constant: the uniform sphere from u1, u2; map: the texel from u1, phi
   and cos theta within it from u2, u3); writes its radiance and returns the density
   (0, w = +y and black when a map's background is black). */
double cref_background_sample(const cref_scene *s, double u1, double u2, double u3,
                              double w[3], double rgb[3]);

/* The environment-map texel (column, row) holding unit direction w; returns 0 (both 0)
   for a constant background. */
int cref_env_texel(const cref_scene *s, const double w[3], uint32_t *col, uint32_t *row);

/* Rec.709 luminance. */
double cref_luminance(const double rgb[3]);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_CPU_REFERENCE_H */
