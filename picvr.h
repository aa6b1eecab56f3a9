/* picvr.h - progressive Monte-Carlo volume rendering with a GPU irradiance cache.
 *
 * picvr renders volumes (CT and MRI scans, simulations, clouds) with Monte-Carlo
 * single scattering (Exposure Render, Kroes et al. 2012) on Vulkan, progressively:
 * every call to picvr_step() adds samples to a running average per pixel and keeps
 * the per-pixel sample variance, so the image and its error estimate (Eq. 5 of
 * Khlebnikov et al., "Parallel Irradiance Caching for Interactive Monte-Carlo Direct
 * Volume Rendering", EuroVis 2014) improve while you watch.  The irradiance cache
 * and the three-procedure scheduler of that paper are built on top of this API.
 *
 * BUILDING.  One header (this file), one implementation file (picvr_vk.c, which
 * includes the parts in host/) and the SPIR-V of its compute kernels (picvr_shaders.h,
 * generated from shaders/ and committed); MIT licensed.  Either
 *   - in exactly one C or C++ file:  #define PICVR_IMPLEMENTATION
 *                                    #include "picvr.h"
 *   - or compile picvr_vk.c on its own (cc -c picvr_vk.c) and link it.
 * Link with -lvulkan -lm (and -pthread where the C library keeps threads apart).  It
 * compiles as C99, C11 or C++17 with gcc or clang, with no warning under -Wall -Wextra
 * -Wpedantic -Wshadow and no feature macro of the application's.  No global state: everything lives in a picvr_context.  Every
 * function returns a picvr_status; picvr_status_string() names it.  A config struct
 * means "the documented default" when zeroed: `= {0}` in C (and C++; there `= {}` also
 * keeps -Wextra quiet).
 *
 * ---------------------------------------------------------------------------------
 * EXAMPLE
 *
 *     picvr_context *ctx;
 *     picvr_config cfg = {0};                        // defaults: best device, seed 0
 *     if (picvr_create(&cfg, &ctx) != PICVR_OK) return 1;
 *
 *     picvr_volume_desc vol = {0};
 *     vol.dims[0] = 256; vol.dims[1] = 256; vol.dims[2] = 256;
 *     vol.type = PICVR_VOXEL_UINT8;                  // spacing 0 means 1,1,1
 *     vol.data = voxels;
 *     picvr_upload_volume(ctx, &vol);
 *
 *     picvr_tf_point tf[] = {                        // value, albedo rgb, opacity, g
 *         {0.00f, {1, 1, 1}, 0.0f, 0}, {0.20f, {0.9f, 0.6f, 0.4f}, 0.0f, 0},
 *         {0.35f, {0.9f, 0.6f, 0.4f}, 0.5f, 0}, {1.00f, {1, 1, 1}, 1.0f, 0}};
 *     picvr_set_transfer_function(ctx, tf, 4, 1.0f);  // D = 1 per world unit
 *
 *     picvr_light sun = {0};
 *     sun.type = PICVR_LIGHT_DIRECTIONAL;
 *     sun.direction[0] = 1; sun.direction[1] = 1; sun.direction[2] = 1; // toward the sun
 *     sun.angular_diameter = 0.0093f;                // radians (the real sun)
 *     sun.color[0] = sun.color[1] = sun.color[2] = 1; sun.intensity = 3;
 *     picvr_background sky = {{0.5f, 0.6f, 0.8f}, 0.5f, NULL, 0, 0, 0};  // no map
 *     picvr_set_lights(ctx, &sun, 1, &sky);
 *
 *     picvr_camera cam = {0};
 *     cam.position[2] = 500;                         // target 0,0,0; up 0,1,0 by default
 *     cam.width = 512; cam.height = 512;             // fov_y 0 means 40 degrees
 *     picvr_set_camera(ctx, &cam);
 *
 *     for (int i = 0; i < 20; i++) picvr_step(ctx, 100.0);   // about 2 s of rendering
 *     picvr_stats st; picvr_get_stats(ctx, &st);
 *     printf("%u iterations, relative error %.3f\n", st.iterations, st.est_rel_error);
 *     uint8_t *rgba = (uint8_t *)malloc(512 * 512 * 4);   // C and C++
 *     picvr_read_rgba8(ctx, rgba, 512 * 512 * 4, 1.0f);
 *     free(rgba);
 *     picvr_destroy(ctx);
 *
 * ---------------------------------------------------------------------------------
 * CONVENTIONS
 *
 * World space.  By default the volume's box is centred at the origin; its size along
 *   axis i is dims[i] * spacing[i] world units, so anisotropic spacing renders
 *   undistorted.  Voxel (0,0,0) is at the -x,-y,-z corner; x varies fastest in memory.
 *   picvr_volume_desc.direction turns the box (a rotation or a reflection, as a scan's
 *   orientation does) and has_origin places voxel (0,0,0)'s centre at origin, so that
 *   world space can be the embedding viewer's (a patient's LPS frame in mm, say).  The
 *   camera, lights, environment map and clip planes are all given in world space.
 *   picvr_volume_box() returns the box's world bounding box.
 * Sampling.  In the volume's own frame (world space when direction is the identity and
 *   has_origin 0) a point x has voxel coordinates p = (x - box_min) / spacing in
 *   [0, dims]; voxel i's centre is at p = i + 0.5; values are interpolated
 *   trilinearly with clamp-to-edge (a 3D texture with a linear sampler).
 * Clipping.  picvr_set_clip removes the medium outside up to PICVR_MAX_CLIP_PLANES
 *   half-spaces and a box: the clipped region is empty for every procedure (camera
 *   rays, shadow rays, paths and the cache alike), as if its voxels had opacity 0.
 * Camera.  f = normalize(target - position), r = normalize(cross(f, up)),
 *   u = cross(r, f), h = tan(fov_y / 2), a = width / height.  Pixel (x, y), y = 0
 *   the top row, shoots from `position` along normalize(f + (2 (x + jx) / width - 1)
 *   h a r + (1 - 2 (y + jy) / height) h u), with the jitter jx, jy uniform in [0,1).
 * Extinction.  sigma_t(x) = D * opacity(v(x)) per world unit, where v is the
 *   trilinearly interpolated data value normalized to [0,1], opacity() the
 *   transfer function and D the density factor (paper Fig. 9).  With spacing 1 the
 *   optical thickness of one voxel is D * opacity.  sigma_s = albedo * sigma_t.
 * Rendering.  Per pixel and iteration: one jittered primary ray, free-flight
 *   sampling by delta tracking against a per-brick majorant grid and, where point,
 *   sphere or rect lights fall off steeply across the volume, a second scatter
 *   location drawn by equiangular sampling toward them, the two combined by multiple
 *   importance sampling so that every ray through the medium gathers light (config
 *   distance_sampling); at each scatter location direct light from one light chosen
 *   by power (shadow ray by residual ratio tracking, config transmittance), isotropic
 *   phase function (isotropic, or Henyey-Greenstein per transfer-function point),
 *   multiple importance sampling (power heuristic) between light and phase sampling
 *   for area lights, a sun with angular size and the background (constant or an
 *   environment map).  A ray that leaves the volume sees the background (and area
 *   lights), weighted by its estimated transmittance.  Single scattering by default,
 *   as in Exposure Render; picvr_set_scattering makes paths of many scatter events
 *   (a volumetric path tracer).  Every estimator is unbiased (docs/sampling.md,
 *   docs/paths.md).
 * Units of lights (colour * intensity):  sphere and rectangle: emitted radiance;
 *   directional: irradiance on a plane facing the light; point: radiant intensity
 *   (W/sr); background: radiance from every direction.
 * Random numbers are a hash of (pixel, iteration, dimension, seed): the same seed
 *   and the same number of iterations give a bit-identical image on one device.
 * Accumulation restarts (iterations back to 0) whenever the camera, volume,
 *   transfer function, lights or clipping change, and on picvr_reset(); with
 *   scheduler.temporal_reuse a camera move keeps it, reprojected, instead.
 * The light field (config.field.mode PICVR_RENDER_FIELD, docs/field.md): instead of
 *   Monte Carlo, each step renders one deterministic, noise-free image in real time
 *   from light propagated through a grid of cells (a grid ratio of voxels per cell)
 *   along D global directions and iterated for multiple scattering (paper 002 carried
 *   to volumes).  It is biased, and converges toward the path-traced image as the grid
 *   and D are refined.  The first step after a change of what the light depends on
 *   rebuilds the field; a camera move only renders again.  picvr_read_field returns
 *   the cells.
 * Threading: a context is not thread-safe; use one per thread or lock around it.
 * Engines (README "In an engine", docs/engines.md): the application's VkDevice goes in
 *   (config.vulkan), scheduler.frames gives every pixel a sample in every step,
 *   picvr_step_begin / picvr_step_end let the thread work while the device renders,
 *   picvr_write_image puts the image into the application's VkImage on the device.
 *   picvr submits to config.vulkan's queue only inside its own calls (and, between
 *   picvr_step_begin and picvr_step_end, the one begun step's work runs there).
 *
 * ENVIRONMENT
 *   PICVR_DEVICE=<substring>  pick the Vulkan device whose name contains it
 *                             (config.device_name wins over it).  Default: a
 *                             discrete GPU, else an integrated one, else lavapipe.
 *   PICVR_VALIDATION=1        enable the Khronos validation layer unless
 *                             config.validation is PICVR_SWITCH_OFF
 *   PICVR_VALIDATION=0        disable it whatever config.validation says
 *   LP_NUM_THREADS            lavapipe's own thread count: on a CPU device it sizes the
 *                             cache's creation batch (one entry per thread)
 * No other environment variable is read.
 */
#ifndef PICVR_H
#define PICVR_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define PICVR_VERSION_MAJOR 0
#define PICVR_VERSION_MINOR 1

/* Limits checked by the API (a device may impose smaller ones; they are checked too). */
#define PICVR_MAX_LIGHTS 32          /* lights per picvr_set_lights() call */
#define PICVR_MAX_CLIP_PLANES 8      /* planes per picvr_set_clip() call (besides its box) */
#define PICVR_MAX_TF_POINTS 256      /* transfer-function control points */
#define PICVR_MAX_IMAGE_SIZE 16384   /* pixels per side */

typedef enum picvr_status {
    PICVR_OK = 0,
    PICVR_ERROR_NULL_POINTER,          /* a required pointer argument was NULL */
    PICVR_ERROR_INVALID_ARGUMENT,      /* an argument is out of its documented range */
    PICVR_ERROR_NON_FINITE,            /* a NaN or infinity in the input (voxels, parameters) */
    PICVR_ERROR_INVALID_DIMENSIONS,    /* a zero volume or image dimension */
    PICVR_ERROR_SIZE_OVERFLOW,         /* a byte size overflows size_t or a device limit */
    PICVR_ERROR_UNSUPPORTED_TYPE,      /* unknown voxel type, or not supported by the device */
    PICVR_ERROR_INVALID_TRANSFER_FUNCTION, /* empty, unsorted, out-of-range points */
    PICVR_ERROR_INVALID_LIGHT,         /* unknown type, negative intensity, degenerate shape */
    PICVR_ERROR_TOO_MANY_LIGHTS,       /* more than PICVR_MAX_LIGHTS */
    PICVR_ERROR_INVALID_CAMERA,        /* position == target, up parallel to view, bad fov */
    PICVR_ERROR_BUFFER_TOO_SMALL,      /* the output buffer cannot hold the image */
    PICVR_ERROR_NOT_READY,             /* picvr_step() before a volume and a camera were set */
    PICVR_ERROR_NO_DEVICE,             /* no Vulkan device (or none matching the name) */
    PICVR_ERROR_VULKAN,                /* a Vulkan call failed (see the log) */
    PICVR_ERROR_OUT_OF_HOST_MEMORY,
    PICVR_ERROR_OUT_OF_DEVICE_MEMORY,
    PICVR_ERROR_DEVICE_LOST,           /* the context must be destroyed */
    PICVR_ERROR_BUSY,                  /* a step begun by picvr_step_begin() has not been
                                          ended by picvr_step_end(); nothing was done */
    PICVR_ERROR_NO_STEP,               /* picvr_step_end() without picvr_step_begin() */
    PICVR_ERROR_TIMEOUT,               /* picvr_step_end(): the step's work is still
                                          running; call it again */
    PICVR_STATUS_COUNT
} picvr_status;

/* A static English name for the status ("PICVR_OK", ...); never NULL. */
const char *picvr_status_string(picvr_status status);

/* Severity of a log message; in picvr_config.log_level the least severe one passed on. */
typedef enum picvr_log_level {
    PICVR_LOG_DEFAULT = 0,         /* in picvr_config: PICVR_LOG_WARNING */
    PICVR_LOG_DEBUG, PICVR_LOG_INFO, PICVR_LOG_WARNING, PICVR_LOG_ERROR
} picvr_log_level;

typedef void (*picvr_log_fn)(picvr_log_level level, const char *message, void *user);

/* Host allocation hooks: both functions or neither (then malloc and free).  alloc is
   never asked for 0 bytes; free is never given NULL. */
typedef struct picvr_allocator {
    void *(*alloc)(size_t size, void *user);
    void (*free)(void *ptr, void *user);
    void *user;
} picvr_allocator;

/* The limits of cache.max_samples, cache.max_lookup_refs and cache.lookup_event (below). */
#define PICVR_CACHE_MAX_SAMPLES 8192u
#define PICVR_CACHE_MAX_SAMPLES_CPU 768u
#define PICVR_CACHE_MAX_LOOKUP_REFS 8192u
#define PICVR_CACHE_MAX_LOOKUP_EVENT 8u

/* The irradiance cache (paper §4-5).  Zero fields mean the Table 1 values. */
typedef enum picvr_cache_mode {
    PICVR_CACHE_DEFAULT = 0,       /* PICVR_CACHE_NONE: at equal time the cache does not
                                      yet beat plain Monte Carlo (docs/error.md) */
    PICVR_CACHE_NONE,              /* plain Monte Carlo, the baseline */
    PICVR_CACHE_OBJECT_SPACE,      /* cache, object-space locking (§5.1) */
    PICVR_CACHE_SCREEN_SPACE,      /* cache, screen-space locking (§5.2) */
    PICVR_CACHE_AUTO               /* object-space cache in the rounds where the scheduler
                                      measures that it pays (stats.auto_efficiency), plain
                                      rounds elsewhere; needs cache.blend on (docs/cache.md,
                                      "The automatic mode") */
} picvr_cache_mode;

/* An on/off field of a config struct whose zero value means its documented default. */
typedef enum picvr_switch {
    PICVR_SWITCH_DEFAULT = 0,      /* the documented default of the field */
    PICVR_SWITCH_ON,
    PICVR_SWITCH_OFF
} picvr_switch;

typedef struct picvr_cache_config {
    float gamma;               /* Eq. 5 estimation accuracy; 0: 0.1 */
    float epsilon;             /* Eq. 10 validity radius threshold; 0: 0.1 */
    float delta_voxels;        /* position offset Delta in voxels (of the smallest
                                  spacing); 0: 2.  It sets a full cache's error floor
                                  (docs/cache.md) */
    float radius_min_voxels;   /* least validity radius, in voxels; 0: 0.01 */
    float radius_max_voxels;   /* largest validity radius, in voxels; 0: 16.  Both bounds
                                  and Delta shrink in dense media (docs/cache.md) */
    uint32_t max_samples;      /* Eq. 5's cap: MIS samples per point at most, rounded up to
                                  a multiple of 128; 0: 768.  At most
                                  PICVR_CACHE_MAX_SAMPLES (PICVR_CACHE_MAX_SAMPLES_CPU on a
                                  CPU device); PICVR_ERROR_INVALID_ARGUMENT beyond */
    float update_threshold;    /* §4.3: predictions conflict when they differ by more than
                                  this relative amount; 0: 0.1 */
    float rebuild_interval_ms; /* octree rebuild period (§4.4); 0: 1000 */
    uint32_t superpixel_size;  /* screen-space locking: side of a square superpixel in
                                  pixels; 0: 32 */
    uint32_t max_entries;      /* entry pool; 0: 65536.  stats.cache_full says when a
                                  pool is full (sizes: docs/cache.md) */
    uint32_t max_nodes;        /* octree node pool; 0: 8 * max_entries, at least 8192 */
    uint32_t max_refs;         /* reference pool; 0: 16 * max_entries */
    uint32_t max_requests;     /* creation requests in flight at most (the request queue);
                                  0: 1000, Table 1's (what a round queues: docs/cache.md) */
    picvr_switch curvature_limit; /* ON: also shrink an entry's radii where its seven
                                  points show that the field is not exponential across
                                  Delta: less bias, a far lower hit rate.  Default OFF:
                                  Eq. 9, 10 alone, as in the paper (docs/cache.md) */
    picvr_switch medium_model; /* ON (default): where an entry's offset point lies beyond
                                  the medium's face, Eq. 6's change is placed over the
                                  part of Delta inside the medium.  OFF: the paper's Eq. 6,
                                  7 literally, which darken lit faces (docs/cache.md) */
    uint32_t max_lookup_refs;  /* references one octree walk (rendering's or the update's)
                                  visits at most; those beyond are ignored, the walk
                                  counted in stats.cache_lookups_cut.  0:
                                  PICVR_CACHE_MAX_LOOKUP_REFS, also the largest allowed
                                  (PICVR_ERROR_INVALID_ARGUMENT beyond; docs/cache.md) */
    picvr_switch blend;        /* ON (default): a fraction of the hits is also shaded
                                  plainly and blended in, so that the cached image
                                  converges to the unbiased one.  OFF: the paper's
                                  estimator, the cached shading alone, whose bias stays
                                  (docs/cache.md) */
    float probe_fraction;      /* with blend: the least probability of a probe at a hit;
                                  0: 0.125; (0, 1] */
    uint32_t lookup_event;     /* the scatter event k of a camera path at which the multiply
                                  scattered cache is looked up (unlimited bounces only;
                                  else the first); 0: 1, the first.  At most
                                  PICVR_CACHE_MAX_LOOKUP_EVENT (PICVR_ERROR_INVALID_ARGUMENT
                                  beyond; docs/cache.md) */
    picvr_cache_mode mode;     /* DEFAULT: NONE */
} picvr_cache_config;

/* The scheduler (paper §6, §7): how picvr_step splits device time between rendering,
   cache-entry creation and cache update.  Zero fields mean the Table 1 values. */

typedef struct picvr_scheduler_config {
    float create_min, create_max; /* t_c,min and t_c,max: creation's share of device time
                                  when the hit rate is 1 and 0; 0: 0.05 and 0.15 */
    float update_min, update_max; /* the same for the update procedure; 0: 0.01, 0.02 */
    float exponent;            /* e_c in t = t_min + (1 - h^e_c)(t_max - t_min); 0: 3 */
    float rounds_per_second;   /* scheduling rounds (one submission each); 0: 20 */
    float hit_rate_window_ms;  /* the hit rate h is measured over this window; 0: 100 */
    picvr_switch priorities;   /* Eq. 12 per-block rendering priorities; default ON */
    picvr_switch frames;       /* ON: after a reset a step returns only once every pixel
                                  holds a sample (stats.pixels_unsampled 0), lasting
                                  max(budget, the rest of that pass).  DEFAULT: OFF, a step
                                  keeps its budget (docs/engines.md) */
    picvr_switch temporal_reuse; /* ON: a camera move (same image size) reprojects the
                                  accumulation into the new view instead of discarding
                                  it (biased after a move, by a share that fades as new
                                  samples come).  DEFAULT: OFF, which allocates nothing
                                  for it (docs/engines.md) */
    uint32_t reuse_history;    /* the most samples a reprojected pixel keeps; 0: 16;
                                  at most 1 << 20 */
} picvr_scheduler_config;

/* The application's own Vulkan objects (sokol's sg_environment): all four handles or
   none.  picvr then creates no instance or device and never destroys these.  The queue
   must support compute; the device needs Vulkan 1.1, no optional feature or extension,
   and linear filtering of R8_UNORM, R16_UNORM and R32G32B32A32_SFLOAT images.  picvr
   submits to the queue only inside its own calls and waits for that work before
   returning (picvr_step_begin excepted: its work runs until picvr_step_end), so the
   queue may be shared with the application's work as long as no other thread uses it
   during a picvr call.  Work the application submits meanwhile runs after picvr's in
   queue order; picvr's image barriers (picvr_write_image) make its writes visible to
   every later command on the queue. */
typedef struct picvr_vulkan {
    void *instance;           /* VkInstance */
    void *physical_device;    /* VkPhysicalDevice */
    void *device;             /* VkDevice */
    void *queue;              /* VkQueue */
    uint32_t queue_family;    /* family index of queue */
} picvr_vulkan;

/* Where a camera ray gathers its light (the distance along the ray of its scatter
   event).  All are unbiased; docs/sampling.md measures them. */
typedef enum picvr_distance_sampling {
    PICVR_DISTANCE_DEFAULT = 0,    /* PICVR_DISTANCE_MIS */
    PICVR_DISTANCE_MIS,            /* delta tracking, and equiangular sampling toward the
                                      point, sphere and rect lights that fall off steeply
                                      across the volume, combined by MIS: every ray through
                                      the medium gathers light; low-discrepancy jitter */
    PICVR_DISTANCE_FREE_FLIGHT,    /* delta tracking alone, independent random numbers
                                      (the paper's baseline) */
    PICVR_DISTANCE_FORCED,         /* MIS as above plus a forced free flight (a collision
                                      inside the medium) for the suns and the lights
                                      equiangular sampling leaves out (with
                                      PICVR_TRANSMITTANCE_RAY_MARCHING also the
                                      background and environment map): every camera ray
                                      through the medium gathers their light.  For thin
                                      media (haze, smoke, thin clouds), where most rays
                                      pass without an event: there it reaches an error in
                                      a small fraction of the time; in dense clouds it
                                      costs more than it brings (docs/sampling.md).  Plain
                                      rendering only (the cache's rounds use MIS) */
    PICVR_DISTANCE_AUTO            /* MIS or FORCED, whichever reduces the error faster,
                                      measured as the image renders: each kind's variance
                                      per sample times its device time per sample, the
                                      other kind probed now and then (its samples added
                                      to the image only where they lower its variance;
                                      docs/sampling.md).  Where FORCED would serve no
                                      light with the default transmittance (every light
                                      served, or only the background), the second kind
                                      is FORCED with PICVR_TRANSMITTANCE_RAY_MARCHING
                                      instead; with ratio tracking chosen there, MIS with
                                      no measuring; with the cache on, MIS */
} picvr_distance_sampling;
/* How transmittance (shadow rays, and the camera ray with PICVR_DISTANCE_MIS) is
   estimated; all are unbiased. */
typedef enum picvr_transmittance_estimator {
    PICVR_TRANSMITTANCE_DEFAULT = 0, /* PICVR_TRANSMITTANCE_RESIDUAL */
    PICVR_TRANSMITTANCE_RESIDUAL,  /* residual ratio tracking (Novak et al. 2014), each
                                      brick's least extinction as the control */
    PICVR_TRANSMITTANCE_RATIO,     /* ratio tracking against the majorant (the paper's) */
    PICVR_TRANSMITTANCE_RAY_MARCHING /* unbiased ray marching (Kettunen et al. 2021): exact
                                      in a homogeneous medium, far less noisy in smooth
                                      ones, several times the cost per estimate: pays in
                                      thin media, where the shadow rays' noise dominates
                                      (docs/sampling.md) */
} picvr_transmittance_estimator;
/* What picvr_step renders (docs/field.md). */
typedef enum picvr_render_mode {
    PICVR_RENDER_DEFAULT = 0,      /* PICVR_RENDER_MC */
    PICVR_RENDER_MC,               /* progressive Monte Carlo: unbiased, converging */
    PICVR_RENDER_FIELD,            /* the light field (paper 002 carried to volumes): light
                                      propagated through a grid of cells along D global
                                      directions, iterated for multiple scattering; each
                                      step renders one deterministic, noise-free (biased)
                                      image from it.  The field is rebuilt by the first
                                      step after a change of the volume, transfer
                                      function, lights, background, scattering or clipping
                                      (stats.field_*); a camera move only renders again.
                                      picvr_step_begin makes the image before it returns
                                      (picvr_step_end then finds it done).  Sphere and
                                      rect lights act as points of their far-field
                                      intensity.  Not with the cache */
    PICVR_RENDER_FIELD_MC          /* from instant to exact: a step after a change (of the
                                      camera too, and picvr_reset) renders the field's
                                      image, as FIELD does; the steps after it, while
                                      nothing changes, add Monte-Carlo samples to it,
                                      the field counting as field.prior_samples samples
                                      of each pixel.  So a moving camera shows the field
                                      every frame, and a still one converges to the
                                      unbiased image from where the field left it (the
                                      field's share, prior / (prior + n) after n
                                      samples, falls as 1 / n).  Not with the cache */
} picvr_render_mode;

/* The light field.  Zero fields mean the defaults.  A context whose mode is not FIELD
   allocates and compiles nothing for it. */
typedef struct picvr_field_config {
    picvr_render_mode mode;   /* DEFAULT: MC */
    uint32_t grid_ratio;      /* voxels per cell along each axis, 1..8; 0: 8 */
    uint32_t directions;      /* D global directions (D / 2 over a hemisphere, each used
                                 both ways), even, 8..1024; 0: 32 */
    uint32_t max_passes;      /* with unlimited bounces: passes (bounces) at most, 1..1024;
                                 0: 64 */
    float tolerance;          /* with unlimited bounces: passes stop when no cell's
                                 fluence changes by more than this times the largest, in
                                 (0, 1); 0: 1e-3 */
    float step_voxels;        /* the image's ray-marching step in voxels (of the smallest
                                 spacing), in [0.125, 64]; 0: 2 */
    uint32_t prior_samples;   /* PICVR_RENDER_FIELD_MC: the samples per pixel the field
                                 image counts as when Monte Carlo goes on from it,
                                 1..1024; 0: 8 */
} picvr_field_config;

typedef struct picvr_config {
    const char *device_name;  /* substring of the device name; NULL: PICVR_DEVICE or auto */
    picvr_switch validation;  /* the Khronos validation layer with synchronization
                                 validation.  DEFAULT: on when PICVR_VALIDATION=1;
                                 ON: on unless PICVR_VALIDATION=0; OFF: off.  Messages:
                                 the log at PICVR_LOG_ERROR, stats.validation_messages.
                                 Ignored (OFF) with config.vulkan (docs/engines.md) */
    uint32_t seed;            /* random seed (0 is a valid seed) */
    picvr_log_fn log;         /* NULL: messages go to stderr */
    void *log_user;
    picvr_log_level log_level;/* least severe level passed on; DEFAULT: WARNING */
    picvr_allocator allocator;
    picvr_vulkan vulkan;      /* zero: picvr makes its own instance and device */
    picvr_cache_config cache; /* the irradiance cache; zero: defaults (see above) */
    picvr_scheduler_config scheduler; /* zero: defaults (see above) */
    picvr_distance_sampling distance_sampling; /* DEFAULT: MIS */
    picvr_transmittance_estimator transmittance; /* DEFAULT: RESIDUAL */
    uint32_t compile_threads; /* threads that may make pipelines at once (a drawing's
                                 first step, a scene change that needs a new variant):
                                 the calling thread and short-lived helpers, joined
                                 before the call returns; and PICVR_DISTANCE_AUTO makes
                                 its forced kind's pipelines on one thread of its own
                                 while the steps go on (picvr_destroy waits for it).
                                 0: the processors online; 1: the calling thread only,
                                 always; at most 16 are used */
    picvr_switch kernel_pruning; /* ON (default): before a pipeline variant is made,
                                 the calls its specialization constants make
                                 unreachable are left out of the SPIR-V the driver
                                 compiles (the same kernel, made several times faster
                                 on lavapipe: docs/performance.md); OFF: each kernel's
                                 whole SPIR-V, as embedded */
    picvr_field_config field; /* the light field; zero: Monte Carlo (see above) */
} picvr_config;

typedef struct picvr_context picvr_context;

/* Creates a context on the chosen device.  cfg may be NULL (all defaults).
   On failure *out is NULL and nothing leaks.  PICVR_ERROR_NO_DEVICE: no Vulkan driver
   loaded or no device qualifies (the log says which).  Without cfg->vulkan each context
   has its own VkInstance: an application that creates many contexts in turn keeps one
   VkInstance of its own alive meanwhile, or passes its device (NVIDIA's driver runs out
   of static TLS otherwise: docs/gpu.md). */
picvr_status picvr_create(const picvr_config *cfg, picvr_context **out);

/* Waits for the device, frees everything.  NULL is allowed. */
void picvr_destroy(picvr_context *ctx);

/* The configuration the context runs with: what picvr_create was given, with every
   zero field replaced by the default it resolved to (cache and scheduler values, log
   level, validation ON or OFF as it came out, the Vulkan handles in use).  The
   scheduler part follows picvr_set_scheduler.  device_name is the name of the device in
   use (valid while the context lives); log, log_user and allocator are as given. */
picvr_status picvr_get_config(const picvr_context *ctx, picvr_config *out);

/* ---- volume ------------------------------------------------------------------ */

/* Voxel types.  Signed 8- and 16-bit voxels are stored exactly (offset into the
   unsigned formats); int32, float16 and float64 are converted to float32 on upload
   (int32 exactly up to 2^24 in magnitude; float64 must fit a float). */
typedef enum picvr_voxel_type {
    PICVR_VOXEL_UINT8 = 1,
    PICVR_VOXEL_UINT16 = 2,
    PICVR_VOXEL_FLOAT32 = 3,
    PICVR_VOXEL_INT8 = 4,
    PICVR_VOXEL_INT16 = 5,     /* CT in Hounsfield units */
    PICVR_VOXEL_INT32 = 6,
    PICVR_VOXEL_FLOAT16 = 7,   /* IEEE 754 binary16, as uint16_t bits */
    PICVR_VOXEL_FLOAT64 = 8
} picvr_voxel_type;

typedef struct picvr_volume_desc {
    uint32_t dims[3];         /* voxels along x, y, z; each >= 1 and <= the device's
                                 maxImageDimension3D */
    picvr_voxel_type type;
    float spacing[3];         /* world size of a voxel; 0 means 1; must be finite and > 0 */
    const void *data;         /* dims[0]*dims[1]*dims[2] voxels, x fastest; copied */
    float value_min, value_max; /* data values that map to 0 and 1 for the transfer
                                 function; values outside clamp.  Both 0: 0..255 for uint8,
                                 0..65535 for uint16, -128..127 for int8, -32768..32767 for
                                 int16, the data's own min..max for int32, float16, float32
                                 and float64 (examples: docs/api.md) */
    float direction[9];       /* world unit vectors of the voxel x, y and z axes
                                 (direction[3a + c]: component c of axis a).  All 0: the
                                 identity.  Else orthonormal within 1e-3 (a rotation or a
                                 reflection): PICVR_ERROR_INVALID_ARGUMENT if singular or
                                 sheared (docs/api.md), PICVR_ERROR_NON_FINITE for NaN or
                                 infinity here or in origin */
    int has_origin;           /* 0: the box is centred at the world origin (origin is
                                 ignored); 1: voxel (0,0,0)'s centre is at origin */
    float origin[3];          /* world position of voxel (0,0,0)'s centre; finite */
} picvr_volume_desc;

/* Copies the voxels to a 3D image on the device and builds the majorant grid.
   float16, float32 and float64 data must be finite, and float64 within float's range
   (PICVR_ERROR_NON_FINITE otherwise).  On error the
   previous volume, if any, is kept.  Resets accumulation. */
picvr_status picvr_upload_volume(picvr_context *ctx, const picvr_volume_desc *desc);

/* The world-space bounding box of the current volume's box (centred at the origin unless
   the volume has an origin; turned boxes give the box around their eight corners). */
picvr_status picvr_volume_box(const picvr_context *ctx, float box_min[3], float box_max[3]);

/* ---- transfer function --------------------------------------------------------- */

typedef struct picvr_tf_point {
    float value;      /* normalized data value in [0,1]; points sorted by value
                         (equal values allowed: a step) */
    float albedo[3];  /* single-scattering albedo per channel, in [0,1] */
    float opacity;    /* extinction before the density factor, >= 0 (usually <= 1) */
    float g;          /* Henyey-Greenstein asymmetry of the phase function, in (-1, 1):
                         0 isotropic (the default), > 0 forward, < 0 backward scattering;
                         interpolated like albedo (a second lobe: picvr_scattering) */
} picvr_tf_point;

/* Piecewise-linear transfer function over the normalized data value; constant
   beyond the first and last points.  density is the global density factor D >= 0
   (0 makes the volume transparent).  Default before any call: opacity = value,
   albedo 1, D = 1.  Resets accumulation. */
picvr_status picvr_set_transfer_function(picvr_context *ctx, const picvr_tf_point *points,
                                         uint32_t count, float density);

/* ---- lights -------------------------------------------------------------------- */

typedef enum picvr_light_type {
    PICVR_LIGHT_SPHERE = 1,      /* position, radius > 0; emits radiance from its surface */
    PICVR_LIGHT_RECT = 2,        /* position = centre, edge_u/edge_v full edge vectors
                                    (not parallel); emits radiance on the side that
                                    cross(edge_u, edge_v) points to */
    PICVR_LIGHT_DIRECTIONAL = 3, /* direction (toward the light, any length > 0),
                                    angular_diameter in [0, pi) radians (0: a delta light) */
    PICVR_LIGHT_POINT = 4        /* position */
} picvr_light_type;

/* No struct of this header starts with an enum, so `= {0}` zeroes one in C and C++. */
typedef struct picvr_light {
    float color[3];          /* >= 0 */
    float intensity;         /* >= 0; see "Units of lights" above */
    picvr_light_type type;
    float position[3];
    float radius;
    float direction[3];
    float angular_diameter;
    float edge_u[3];
    float edge_v[3];
} picvr_light;

/* The background: light from every direction, seen by rays that leave the volume and
   lighting every scatter event.  Constant, or an environment map: radiance from
   direction w (pointing away from the volume, toward where the light comes from) =
   color * intensity * map(w'), where w' is w turned by -env_rotation about +y and
   map() the texel of an equirectangular (latitude-longitude) image holding w':
   column floor(width * (0.5 + atan2(w'.x, -w'.z) / (2 pi))), row floor(height *
   acos(w'.y) / pi), row 0 the top (+y, the zenith), so the image's centre column looks
   along -z and its middle row is the horizon.  Texels are constant over their solid
   angle (no filtering), and importance-sampled by luminance.  A 1x1 map is the constant
   background. */
typedef struct picvr_background {
    float color[3];          /* >= 0 */
    float intensity;         /* >= 0; radiance = color * intensity (* map) */
    const float *environment;/* NULL: constant.  Else env_width * env_height RGB texels,
                                3 floats each (linear radiance, finite, >= 0, not all 0),
                                rows top to bottom; copied */
    uint32_t env_width, env_height; /* each 1..PICVR_MAX_ENV_SIZE */
    float env_rotation;      /* radians, the map turned about +y (finite) */
} picvr_background;

/* Replaces all lights.  count may be 0; background may be NULL (black).  Default
   before any call: no lights, black background (a black image).  On error the
   previous lights are kept.  Resets accumulation. */
picvr_status picvr_set_lights(picvr_context *ctx, const picvr_light *lights, uint32_t count,
                              const picvr_background *background);

/* ---- clipping ------------------------------------------------------------------ */

typedef struct picvr_clip {
    uint32_t plane_count;     /* 0..PICVR_MAX_CLIP_PLANES */
    float planes[PICVR_MAX_CLIP_PLANES][4]; /* world space: plane i keeps the points x with
                                 n . x + d >= 0, n = planes[i][0..2] (non-zero, any
                                 length), d = planes[i][3] */
    int use_box;              /* 1: also keep only box_min <= x <= box_max (world axes) */
    float box_min[3], box_max[3];
} picvr_clip;

/* Sets the clipping: only the medium inside every plane's half-space and the box is
   rendered (see CONVENTIONS).  clip NULL or all zero: no clipping (the default; a scene
   without clipping compiles none of it).  PICVR_ERROR_INVALID_ARGUMENT for more than
   PICVR_MAX_CLIP_PLANES planes, a value that is not finite, a plane whose normal is 0,
   or box_min > box_max on some axis (an empty box).  A change resets
   accumulation and empties the cache (the removed medium changes the light everywhere);
   setting the same clipping again changes nothing.  The planes follow the volume: they
   are kept in world space and hold for a volume uploaded later.  On error nothing
   changes. */
picvr_status picvr_set_clip(picvr_context *ctx, const picvr_clip *clip);

/* ---- scattering ------------------------------------------------------------------ */

#define PICVR_BOUNCES_UNLIMITED 0xffffffffu
#define PICVR_MAX_ENV_SIZE 16384     /* environment map texels per side */

/* How light scatters in the medium.  Zero fields: single scattering, one lobe. */
typedef struct picvr_scattering {
    uint32_t max_bounces;    /* scatter events a camera path may have after its first: 0
                                single scattering (the paper's); n: paths of up to n + 1
                                scatter events; PICVR_BOUNCES_UNLIMITED: no limit but
                                Russian roulette (unbiased; docs/paths.md) */
    float back_g;            /* the second Henyey-Greenstein lobe's g, in (-1, 1) */
    float back_weight;       /* its weight w in [0, 1); 0: one lobe (picvr_tf_point.g).
                                The phase function: (1 - w) HG(g(x)) + w HG(back_g) */
} picvr_scattering;

/* Sets the scattering model (NULL: the defaults).  On error nothing changes.  Resets
   accumulation.  Paths: next-event estimation (one light or the background, chosen by
   power, MIS with phase sampling) at every scatter event, the phase-sampled direction
   continuing the path, Russian roulette from the second event on (unbiased;
   docs/paths.md).  A path is bounded by llvmpipe's loop limit: past PICVR_PATH_STEPS
   tracking steps in all it ends (biased, counted in stats.truncated_paths).  The
   irradiance cache, when on: with max_bounces = 0 it holds the single-scattered light
   for an isotropic phase function only (with any g != 0 or a second lobe the cache
   idles and picvr_step renders by plain Monte Carlo); with max_bounces > 0 it holds the
   multiply scattered light (the fluence of light that scattered at least once before
   reaching a point): at a camera path's first scatter event (or its
   cache.lookup_event-th) a hit adds the event's direct light and the cached part,
   weighted by the phase function to first order in direction, and the path ends there;
   a miss traces the path.  Entries are estimated by path tracing and refined while the
   image renders; on a CPU device an entry takes at most 128 samples per point at
   creation (stats.cache_max_samples; docs/cache.md, "The multiply scattered cache"). */
picvr_status picvr_set_scattering(picvr_context *ctx, const picvr_scattering *scattering);
#define PICVR_PATH_STEPS 49152u

/* ---- camera -------------------------------------------------------------------- */

typedef struct picvr_camera {
    float position[3];
    float target[3];         /* must differ from position */
    float up[3];             /* zero: 0,1,0; must not be parallel to target - position */
    float fov_y_degrees;     /* vertical field of view in (0, 179]; 0 means 40 */
    uint32_t width, height;  /* image size, 1..PICVR_MAX_IMAGE_SIZE each */
} picvr_camera;

/* Sets the pinhole camera and image size.  Resets accumulation unless the camera is
   identical to the current one. */
picvr_status picvr_set_camera(picvr_context *ctx, const picvr_camera *camera);

/* ---- rendering ------------------------------------------------------------------- */

/* Renders for about `milliseconds` of wall time, then returns; needs a volume and a
   camera.  The kernels are specialized to the scene (delta lights only, lights of one
   colour, dense media, the debug view): a step that meets a combination no earlier
   step had makes its pipelines first (outside the time budget; a context keeps 8 per
   procedure).  Frameless: the time is split into rounds (scheduler.rounds_per_second), each
   one submission in which the three procedures get the §6 shares of device time (with
   the cache) and rendering adds one sample to some 16x8-pixel blocks - chosen by the
   Eq. 12 priorities, or round robin with priorities off - so pixels may hold different
   sample counts (stats.iterations_min/_mean).  At least one round runs, even for 0 ms.
   A budget is kept to within about one round's misestimate of the device time. */
picvr_status picvr_step(picvr_context *ctx, double milliseconds);

/* The same as picvr_step, split so that the calling thread does not wait for the
   device: picvr_step_begin submits one round of about `milliseconds` of device time
   (sized by the scheduler's measured costs; with scheduler.frames on, at least the rest
   of the first pass) to the queue and returns at once.  picvr_step_end waits up to
   timeout_ns for it (0: poll; UINT64_MAX: until done), then accounts for it as
   picvr_step does; PICVR_ERROR_TIMEOUT means it is still running (the step stays
   begun).  Between the two, every other call on the context returns PICVR_ERROR_BUSY
   and does nothing, except picvr_destroy (which waits) and picvr_status_string.
   picvr_step_end without a begun step is PICVR_ERROR_NO_STEP. */
picvr_status picvr_step_begin(picvr_context *ctx, double milliseconds);
picvr_status picvr_step_end(picvr_context *ctx, uint64_t timeout_ns);

/* Makes the pipelines that the current volume, transfer function, lights, cache mode
   and view need, which the next picvr_step would otherwise make first: call it while a
   scene loads to keep that pause out of interaction.  Needs a volume; renders nothing.
   (A driver may still compile machine code at a pipeline's first dispatch, as lavapipe
   does: docs/lavapipe.md; this cannot move that.) */
picvr_status picvr_prepare(picvr_context *ctx);

/* Renders exactly `iterations` samples per pixel, whole passes over the image
   (priorities do not apply; deterministic without the cache; for tests and offline
   rendering).  With the cache, each pass is a round with a fixed split instead of the
   §6 time shares: the requests of one pass (up to cache.max_requests) become entries in
   the next, and 1/16 of the blocks run the update procedure. */
picvr_status picvr_step_iterations(picvr_context *ctx, uint32_t iterations);

typedef enum picvr_debug_view {
    PICVR_VIEW_IMAGE = 0,      /* the rendered image */
    PICVR_VIEW_CACHE = 1,      /* where the cache is: per pixel the fraction of scatter
                                  events served by the cache (green) or missed (red),
                                  entry centres white, background black; needs the
                                  cache on (PICVR_ERROR_NOT_READY otherwise) */
    PICVR_VIEW_CACHE_ERROR = 2 /* how wrong the cache is where it is used: at every
                                  scatter event the cache serves, R = the luminance it
                                  shades with, G = a plain Monte-Carlo estimate's at the
                                  same point, B = 1; elsewhere 0 (docs/cache.md).  Read
                                  it with picvr_read_rgba32f; needs the cache on */
} picvr_debug_view;

/* Replaces the scheduler's settings (NULL: all defaults), validated as in
   picvr_create; on an error nothing changes.  Keeps the cache, the accumulated image and
   the measured cost of each procedure; the shares apply from the next round, and credit
   owed under the old shares is dropped.  For example, fill the cache while a scene
   loads (create_min = create_max = 0.85, as `picvr-render --warm` does), then switch
   to the defaults for interaction.  Turning priorities on for the first time creates
   their pipeline (on a CPU device the driver compiles it at its first use). */
picvr_status picvr_set_scheduler(picvr_context *ctx, const picvr_scheduler_config *cfg);

/* Selects what picvr_step renders; resets accumulation.  The debug views are a
   pipeline variant of their own, made by the next step (the image's variant leaves
   their code out). */
picvr_status picvr_set_view(picvr_context *ctx, picvr_debug_view view);

/* Discards the accumulated image (iterations back to 0). */
picvr_status picvr_reset(picvr_context *ctx);

/* Reads the image, rows top to bottom, 4 bytes per pixel: colour tone-mapped as
   1 - exp(-exposure * radiance) then sRGB-encoded; alpha = the volume's opacity along
   the pixel's rays, 1 - transmittance (coverage, for compositing; estimated per sample,
   by the scatter events or by the transmittance estimate).  exposure <= 0 means 1.
   size must be >= width*height*4.  Before any iteration the image is all zero. */
picvr_status picvr_read_rgba8(picvr_context *ctx, uint8_t *pixels, size_t size, float exposure);

/* Reads the linear radiance (RGB) and coverage (A), 4 floats per pixel, rows top to
   bottom; size is in bytes and must be >= width*height*16. */
picvr_status picvr_read_rgba32f(picvr_context *ctx, float *pixels, size_t size);

/* PICVR_RENDER_FIELD: the field of the last step, for an application that keeps its
   own illumination volume (and for tests).  Its cells span the volume's box, x
   fastest, dims[0] x dims[1] x dims[2] (written when dims is not NULL), each 16 floats
   at its centre: its extinction sigma_t and albedo rgb (the classified medium, in the
   volume's own frame: world units along its axes), then per channel r, g, b the
   fluence phi of the scattered light and the background (W / m^2 when the lights are
   in W) and its first moment F (xyz, the volume's axes).  size is in bytes and must be
   >= 64 * the cells.  PICVR_ERROR_NOT_READY before the field's first step, or in
   another mode. */
picvr_status picvr_read_field(picvr_context *ctx, float *cells, size_t size, uint32_t dims[3]);

/* The image on the device, for engines: picvr_write_image writes the current image
   into a VkImage the application owns, with no host copy.  It needs the application's
   Vulkan objects (picvr_config.vulkan); the image must be on that VkDevice, 2D, with one
   mip level and one array layer, extent width x height equal to the camera's, usage
   including VK_IMAGE_USAGE_TRANSFER_DST_BIT, and owned by picvr_config.vulkan's queue
   family (or VK_SHARING_MODE_CONCURRENT).  picvr cannot check that a non-NULL handle
   is a live image of that device: passing anything else is undefined, as in Vulkan. */
typedef struct picvr_image_target {
    void *image;              /* VkImage */
    uint32_t width, height;   /* its extent: the camera's width and height */
    uint32_t format;          /* its VkFormat, one of
                                 R8G8B8A8_UNORM, R8G8B8A8_SRGB, B8G8R8A8_UNORM,
                                 B8G8R8A8_SRGB: the bytes of picvr_read_rgba8 (tone-mapped,
                                 sRGB-encoded; an _SRGB image samples as linear), in the
                                 format's channel order;
                                 R16G16B16A16_SFLOAT, R32G32B32A32_SFLOAT: the linear
                                 radiance and coverage of picvr_read_rgba32f */
    uint32_t old_layout;      /* the VkImageLayout the image is in when picvr's commands
                                 run; VK_IMAGE_LAYOUT_UNDEFINED: its contents are discarded */
    uint32_t new_layout;      /* the VkImageLayout picvr leaves it in (e.g.
                                 SHADER_READ_ONLY_OPTIMAL, PRESENT_SRC_KHR, GENERAL); not
                                 UNDEFINED or PREINITIALIZED */
    void *wait_semaphore;     /* a binary VkSemaphore picvr's submission waits on (at the
                                 transfer stage) before it writes the image, or NULL:
                                 e.g. a swapchain image's acquire semaphore */
    void *signal_semaphore;   /* a binary VkSemaphore the submission signals once the
                                 image is written, or NULL: e.g. the one vkQueuePresentKHR
                                 waits on */
    float exposure;           /* 8-bit formats, as in picvr_read_rgba8; <= 0 means 1 */
} picvr_image_target;

/* Writes the image into target->image: one submission to picvr_config.vulkan's queue
   (a tone-mapping dispatch into a buffer of picvr's, then a layout transition to
   TRANSFER_DST_OPTIMAL, a copy and a transition to new_layout, whose barrier makes the
   write visible to all later commands on that queue), waiting on wait_semaphore and
   signalling signal_semaphore.  Returns once that submission has completed, so the
   application may use the image in any command buffer it submits afterwards to the
   same queue (another queue: wait on signal_semaphore).  Without the application's
   device, or with a format, size or layout outside the above:
   PICVR_ERROR_INVALID_ARGUMENT (the log says which), and nothing is submitted. */
picvr_status picvr_write_image(picvr_context *ctx, const picvr_image_target *target);

/* Reads the number of samples each pixel has accumulated (rows top to bottom): with
   priorities on, picvr_step gives more to the pixels whose error falls fastest.
   `count` is the number of uint32_t that `counts` holds. */
picvr_status picvr_read_sample_counts(picvr_context *ctx, uint32_t *counts, size_t count);

/* The kind of device a context runs on (VkPhysicalDeviceType).  On PICVR_DEVICE_CPU
   (Mesa's lavapipe) cache.max_samples is capped at PICVR_CACHE_MAX_SAMPLES_CPU
   (llvmpipe's loop bound) and the creation batch is one entry per thread. */
typedef enum picvr_device_type {
    PICVR_DEVICE_OTHER = 0,
    PICVR_DEVICE_INTEGRATED_GPU,
    PICVR_DEVICE_DISCRETE_GPU,
    PICVR_DEVICE_VIRTUAL_GPU,
    PICVR_DEVICE_CPU
} picvr_device_type;

/* "cpu", "discrete-gpu", ... (a static string; "other" for unknown values). */
const char *picvr_device_type_string(picvr_device_type type);

typedef struct picvr_stats {
    uint32_t iterations;         /* blocks rendered since the last reset / blocks of the
                                    image: whole-image passes (see picvr_step) */
    uint32_t iterations_min;     /* fewest samples of any pixel */
    uint64_t pixels_unsampled;   /* pixels that hold no sample yet (black holes in the
                                    image); 0 after every step with scheduler.frames on */
    double iterations_mean;      /* mean samples per pixel */
    double elapsed_ms;           /* wall time spent in picvr_step* since the last reset */
    double samples_per_second;   /* pixel samples / elapsed time */
    double est_error;            /* image mean of 1.96*sqrt(S^2/N) of pixel luminance
                                    (left side of Eq. 5); pixels with N < 2 are excluded */
    double est_rel_error;        /* image mean of est_error_p / (L_p + 0.01 * mean L) */
    double mean_luminance;       /* image mean of the pixel luminance (Rec. 709) */
    uint64_t truncated_paths;    /* samples whose tracking loop hit its iteration bound
                                    (biased; should stay 0 outside extreme media) */
    double mean_path_length;     /* scatter events per camera sample (those that miss
                                    the medium count 0) since the last reset, over the
                                    samples, not the pixels alike (docs/paths.md) */
    /* irradiance cache (all 0 when the cache is off) */
    uint32_t cache_entries;      /* entries in the cache */
    uint32_t cache_nodes;        /* octree nodes in use */
    uint32_t cache_refs;         /* entry references in the octree */
    uint32_t cache_full;         /* 1 when a pool is full: the cache stops growing */
    double cache_refs_per_entry; /* references / entries (docs/cache.md) */
    uint32_t cache_entries_capped; /* entries stored although Eq. 5 still failed at the
                                    sample cap (cache_max_samples): their relative error
                                    may exceed the accuracy gamma asks for */
    uint64_t cache_samples;      /* irradiance samples the stored entries' seven points
                                    took (with bounces: paths, refinement's included;
                                    docs/cache.md) */
    uint64_t cache_samples_truncated; /* of those, samples whose transmittance estimate (with
                                    bounces: or path) was cut at its loop bound (biased,
                                    like truncated_paths; docs/cache.md) */
    uint64_t cache_lookups_cut;  /* scatter events whose octree walk (rendering or update)
                                    stopped at cache.max_lookup_refs, ignoring the entries
                                    beyond; 0 unless a node's list is pathologically long */
    uint64_t cache_lookups_spilled; /* scatter events whose octree walk (rendering or
                                    update) found more than 64 entries whose bounding
                                    sphere holds the point; those past the 64th were
                                    evaluated one at a time (same result, slower) */
    uint32_t cache_max_samples;  /* that cap in force: cache.max_samples after its default
                                    and the rounding to a multiple of 128; with bounces on
                                    a CPU device at most 128 (picvr_set_scattering) */
    uint32_t cache_requests;     /* creation requests issued in the last step */
    uint32_t cache_pending;      /* creation requests the last round queued, each holding
                                    its lock, for the next round's creation procedure */
    uint64_t cache_bytes;        /* device memory of the cache: its pools, locks, lookup
                                    queue and, with cache.blend, its sums (docs/cache.md) */
    double cache_hit_rate;       /* fraction of scatter events served by the cache in
                                    the last step */
    double cache_routed;         /* fraction of the scatter events reaching the cache that
                                    cache.blend sent to plain shading without a lookup
                                    (pixels where the cache's bias is established);
                                    a moving average over the recent cached rounds */
    double cache_gain;           /* the share of a plain sample's variance that a hit
                                    removes, measured at the blend's probes (moving
                                    average; 0 until measured) */
    double auto_efficiency;      /* PICVR_CACHE_AUTO: error reduction per device time of
                                    cached rounds over plain ones, E (> 1: the cache
                                    pays, cached rounds run); 0 until both are measured */
    double kernel_ms_plain[3];   /* device ms per rendered block of the rendering
                                    procedure's kernels (tracking, lookup, shading) in
                                    rounds without the cache (moving average; 0 where
                                    none ran or the device has no timestamps) */
    double kernel_ms_cached[3];  /* the same in rounds with the cache */
    double auto_cached_share;    /* share of the recent device time (docs/cache.md) spent
                                    in rounds that ran the cache: 1 with a forced cache,
                                    0 without, in between with PICVR_CACHE_AUTO */
    double forced_share;         /* share of the recent device time spent in rounds that
                                    drew the forced point: 1 with PICVR_DISTANCE_FORCED,
                                    0 without, with PICVR_DISTANCE_AUTO its second kind's
                                    (the forced point, or ray marching), the probes
                                    included */
    double forced_efficiency;    /* PICVR_DISTANCE_AUTO: error reduction per device time
                                    of its second kind over MIS (> 1: it pays); 0 until
                                    both are measured */
    /* scheduler: measured shares of device time over the last second, and the §6 targets */
    double fraction_render, fraction_create, fraction_update;
    double target_create, target_update;
    uint32_t validation_messages;/* Khronos validation messages seen by this context */
    uint32_t pipeline_variants;  /* pipeline variants the context holds: one per
                                    procedure it runs and scene it met, at most 8 per
                                    procedure (docs/api.md) */
    uint32_t field_builds;       /* PICVR_RENDER_FIELD: fields built by this context */
    uint32_t field_passes;       /* passes (scatter events) of the current field */
    double field_change;         /* its last pass's largest change of a cell's fluence,
                                    relative to the largest fluence */
    double field_build_ms;       /* wall time of its build */
    uint64_t field_bytes;        /* device memory of the field */
    uint32_t field_cells[3];     /* its grid */
    uint32_t validation_enabled; /* 1 when the validation layer is active */
    uint32_t width, height;
    char device_name[256];
    picvr_device_type device_type;
} picvr_stats;

/* Fills *stats (reduces the per-pixel statistics on the device). */
picvr_status picvr_get_stats(picvr_context *ctx, picvr_stats *stats);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_H */

/* One-file inclusion (stb style): in exactly one C or C++ file of the application,
       #define PICVR_IMPLEMENTATION
       #include "picvr.h"
   compiles the library there (picvr_vk.c, host/ and picvr_shaders.h must sit beside
   this header).  Every private name is prefixed picvr_ / PICVR_ and static. */
#if defined(PICVR_IMPLEMENTATION) && !defined(PICVR_IMPLEMENTATION_INCLUDED)
#define PICVR_IMPLEMENTATION_INCLUDED
#include "picvr_vk.c"
#endif
