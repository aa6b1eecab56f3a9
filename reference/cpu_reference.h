/* cpu_reference.h - an independent C11 + OpenMP implementation of picvr's per-pixel
 * algorithm (see CONVENTIONS in picvr.h), written without looking at the shaders.
 *
 * Two uses:
 *   - the CPU side of bench/bench_speed.c (samples/s on all cores);
 *   - a second implementation that the tests compare the Vulkan kernels against
 *     statistically (same scene, same estimator, different random numbers).
 *
 * Per pixel and iteration: jittered camera ray (picvr.h "Camera"), delta tracking
 * against a majorant grid of 4^3-voxel bricks (3D DDA, exponential steps restarted
 * at every cell boundary), at the collision albedo * direct light from one light
 * chosen by power, shadow transmittance by ratio tracking, isotropic phase function,
 * MIS (power heuristic) between light and phase sampling for sphere/rect lights, a
 * sun with angular size > 0 and the background.  Single scattering only.
 *
 * Choices the header leaves open (documented here so the GPU side can match them):
 *   - Area lights (sphere, rect) are opaque to every ray: a camera ray, phase ray or
 *     shadow ray that hits one stops there.  A rect's back side is black.  A point
 *     inside a sphere light sees its emission from every direction.
 *   - Camera rays that escape see the background and area lights, never a sun disk.
 *   - A tracking loop that runs past CREF_MAX_STEPS tentative collisions stops:
 *     free flight -> treated as escaping (background or area light, alpha 0); ratio
 *     tracking -> the transmittance estimate so far.  Both are biased (as on the
 *     GPU); such samples are counted in cref_render_stats.truncated_paths.
 *   - Light selection power (luminance of colour*intensity, times): sphere
 *     pi*4*pi*r^2, rect pi*area, point 4*pi, directional pi*R^2, background
 *     4*pi*pi*R^2, with R = half the diagonal of the volume box.
 *   - A sun of angular diameter a > 0 has radiance E / (pi sin^2(a/2)) over its
 *     cone, so that colour * intensity = E is the irradiance on a plane facing it
 *     (picvr.h's unit).
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
    double background[3];       /* radiance */
    double background_p_select;
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
} cref_render_stats;

/* Builds the scene from the public API structs (copies everything; the caller may
   free its buffers afterwards).  tf may be NULL with tf_count 0 (the API default:
   opacity = value, albedo 1, density 1); lights may be NULL with count 0;
   background may be NULL (black).  Validation is minimal (ranges, finiteness,
   degenerate shapes).  Returns PICVR_OK (0) or a picvr_status; on error *s is
   left zeroed and owns nothing. */
int cref_scene_init(cref_scene *s, const picvr_volume_desc *volume,
                    const picvr_tf_point *tf, uint32_t tf_count, float density,
                    const picvr_light *lights, uint32_t light_count,
                    const picvr_background *background,
                    const picvr_camera *camera, uint32_t seed);

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

/* Rec.709 luminance. */
double cref_luminance(const double rgb[3]);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_CPU_REFERENCE_H */
