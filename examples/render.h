/* render.h - picvr-render's options and its outputs, shared by examples/render.c
 * (options, rendering, main) and examples/render_output.c (PNG, PFM, the --debug-view
 * error figure, the JSON summary and the summary line on stdout).
 */
#ifndef PICVR_RENDER_H
#define PICVR_RENDER_H

#include <stddef.h>
#include <stdint.h>

#include "picvr.h"

/* The command line, parsed (render.c, `picvr-render --help`). */
typedef struct render_options {
    const char *volume_path;
    int have_dims, have_type, have_spacing, have_range, have_density, have_time;
    uint32_t dims[3];
    picvr_voxel_type type;
    float spacing[3];
    float range[2];
    int range_auto;            /* --range auto: the data's 0.5th and 99.5th percentiles */
    const char *tf_name, *lights_name;
    int have_tf;               /* --tf given; else a default from the file (render.c, choose_tf) */
    float wl[2];               /* --wl WIDTH,LEVEL in the data's physical units */
    int have_wl;
    const char *view;          /* --view anterior|...: the patient frame's views */
    float up[3];               /* --up +x|-x|+y|-y|+z|-z */
    int have_up;
    picvr_clip clip;           /* --clip-plane (repeatable), --clip-box; world space */
    const char *grid;          /* --grid NAME: the OpenVDB grid */
    float density;
    int have_bounces, have_g;
    uint32_t bounces;          /* --bounces, else the --tf preset's (resolved after parsing) */
    float g;                   /* --g: one HG g over the whole transfer function */
    float phase_back[2];       /* --phase-back G,W: back_g, back_weight (0,0: one lobe) */
    const char *env_path;      /* --env FILE.hdr; NULL: the --lights preset's background */
    float env_rotate, env_intensity; /* --env-rotate (degrees), --env-intensity */
    int have_env_rotate, have_env_intensity;
    uint32_t width, height;
    double time_ms, round_ms;
    uint32_t iterations;       /* 0: render for time_ms instead */
    uint32_t frames;           /* --frames N: N real-time frames of frame_ms instead; 0: no */
    double frame_ms;           /* --frame-ms: each frame's budget (default 16) */
    float orbit_deg;           /* --orbit: the camera's azimuth step per frame, degrees */
    int have_frame_ms, have_orbit;
    picvr_switch reuse;        /* --reuse: scheduler.temporal_reuse */
    uint32_t seed;
    const char *device;
    int validation;
    picvr_cache_mode cache;
    picvr_switch priorities;
    picvr_distance_sampling distance_sampling;   /* --sampling; 0: the library's default */
    picvr_transmittance_estimator transmittance; /* --transmittance */
    picvr_render_mode render_mode; /* --render mc|field */
    uint32_t field_ratio, field_directions; /* --field-ratio, --field-directions; 0: defaults */
    float field_step;          /* --field-step (voxels); 0: the default */
    picvr_switch curvature;
    picvr_switch medium;
    uint32_t max_samples;     /* --samples: the cache's Eq. 5 cap per point; 0: default */
    picvr_cache_config params; /* --cache-param: its numbers (presets.h); 0: defaults */
    float shares[4];          /* --shares: create_min, create_max, update_min, update_max */
    double warm_ms;           /* --warm: fill the cache first at PVP_WARM_CREATE_SHARE; 0: no */
    char turns_path[1024];    /* --turns FILE,ID: take turns with a second process; "": no */
    unsigned turns_id;
    const char *debug_view;
    float exposure;
    float azimuth, elevation, distance, fov;
    const char *out_png, *out_pfm, *log_path, *json_path;
    int png_alpha, quiet;
} render_options;

/* One frame of --frames: its wall time (picvr_step alone) and the image after it. */
typedef struct render_frame {
    double ms;
    uint64_t pixels_unsampled;
    double est_rel_error;
    double samples_per_pixel;
} render_frame;

/* The frames of a --frames run (length 0 otherwise). */
typedef struct render_frames {
    render_frame *items;
    size_t length;
} render_frames;

/* Each reads the final image or statistics of ctx and writes one output of o; returns
   0 after reporting a failure. */
int render_write_png(picvr_context *ctx, const render_options *o);         /* --out */
int render_write_pfm(picvr_context *ctx, const render_options *o);         /* --out-float */
int render_print_cache_error(picvr_context *ctx, const render_options *o); /* --debug-view error */
int render_write_json(picvr_context *ctx, const render_options *o,         /* --json */
                      const picvr_stats *stats, const render_frames *frames);

/* The one-line summary on stdout; interrupted: the run was stopped by Ctrl-C. */
void render_print_summary(const render_options *o, const picvr_stats *stats, int interrupted);

/* Writes RGBA float pixels (row 0 the top) as OpenEXR (examples/exr_write.cpp); 0 with
   err filled on failure. */
#ifdef __cplusplus
extern "C"
#endif
int render_write_exr(const char *path, const float *rgba, uint32_t width, uint32_t height,
                     char *err, size_t err_size);

#endif /* PICVR_RENDER_H */
