/* bench_sampling.c - picvr-bench-sampling: the plain renderer's efficiency, before and
 * after its distance sampling and transmittance estimator, side by side in one run; or,
 * with --bounces, the path tracer's error against run time per bounce count.
 *
 *   picvr-bench-sampling [--scenes thin,bonsai,engine,cloud] [--data ../shared/data]
 *       [--size 256x256] [--time MS] [--slice MS] [--ref-time MS] [--ref-chunks N]
 *       [--seed 101] [--out bench/results/sampling] [--write-thin FILE]
 *       [--before paper|mis] [--after default|forced|auto|forced-rm]
 *       [--bounces 0,1,4,unlimited]
 *
 * With --bounces the conditions are those picvr_scattering.max_bounces values (the
 * default sampler), each against its own reference (their converged images differ);
 * the table adds each reference's mean luminance over the first condition's (how much
 * brighter the light of more scatter events makes the image) and the scatter events per
 * camera sample (stats.mean_path_length).  Results go to OUT/paths.md, .csv.
 *
 * Conditions ("before" and "after"): picvr_config.distance_sampling FREE_FLIGHT with
 * transmittance RATIO (the paper's Exposure Render estimator; --before paper, the
 * default) or the default MIS (equiangular sampling alone; --before mis) against the
 * defaults (--after default: MIS, residual ratio tracking) or FORCED (MIS with the
 * forced point; --after forced).  Both
 * plain Monte Carlo (cache off, priorities off: whole passes, so every pixel has the
 * same sample count).
 *
 * Per scene:
 *  1. a reference: the "after" renderer, in --ref-chunks independent contexts (seeds
 *     1001, ...) of --ref-time / chunks each, averaged; its own error is estimated from
 *     the spread between chunks and removed from the measured errors in quadrature
 *     (err_true^2 = err_measured^2 - err_ref^2; the reference's error is reported).
 *  2. the two conditions, seed 101 (--seed), in two live contexts stepped in turn, one --slice
 *     each, until each has spent --time ms inside picvr_step: both see the same machine
 *     load.  After every slice: time, passes, relative RMSE of the luminance against the
 *     reference, the image mean against the reference's mean.
 *  3. per condition: the time to a true relative RMSE of 0.05, 0.02 and 0.01 (the first
 *     measurement at or below, interpolated in log-log with the one before; where the run
 *     ends first, extrapolated by err ~ t^-1/2 from the last quarter of the run and marked
 *     '~'), the variance per sample (relative RMSE^2 x samples per pixel, averaged over
 *     the last half of the run) and samples per second (pixels x passes / s): which of the
 *     two moved.  Printed as a Markdown table and written to OUT/sampling.md, .csv.
 *
 * With --frames N (the engine's case): real-time frames (scheduler.frames on, --frame-ms
 * each) while the camera turns --orbit degrees a frame, temporal reuse off against on,
 * stepped in turn frame by frame (both see the same machine load), with the --tf
 * preset's bounces.  At --checkpoints frames evenly spaced (the last included) the true
 * relative RMSE against a reference of that frame's view (each --ref-time, made first);
 * every frame its wall time, samples per pixel and pixels without a sample.  Results:
 * OUT/frames.md, .csv.
 *
 * Relative RMSE = sqrt(mean_p ((Y_p - Yref_p) / (Yref_p + 0.01 mean(Yref)))^2), Y the
 * Rec. 709 luminance of picvr_read_rgba32f, as picvr-bench-error defines it.
 *
 * The thin scene is built here: a 64^3 float32 smooth density (a Gaussian blob modulated
 * by slow sines, values 0..1), the `thin` transfer function (albedo 0.8, optical depth
 * about 3 across its densest part), the `point` light (a point light just outside the
 * volume), no background.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "picvr.h"
#include "presets.h"
#include "picvr_io.h"

#define PROGRAM "picvr-bench-sampling"
#define MAX_SLICES 4096
#define N_TARGETS 3
static const double TARGETS[N_TARGETS] = {0.05, 0.02, 0.01};

typedef struct options {
    const char *scenes, *data, *out, *write_thin;
    uint32_t width, height;
    double time_ms, slice_ms, ref_ms;
    uint32_t ref_chunks, seed;
    const char *bounces;      /* NULL: the before/after comparison */
    const char *before;       /* the "before" sampler: "paper" or "mis" */
    const char *after;        /* the "after" sampler: "default" or "forced" */
    uint32_t frames, checkpoints; /* --frames: the engine's case (0: not) */
    double frame_ms, orbit_deg;
    const char *field;        /* --field RATIO:D,...: the light field's measurements (NULL: not) */
} options;

/* One condition of a run: the sampler, and the bounce count. */
typedef struct condition {
    char name[32];
    int before;               /* 1: the paper's sampler (FREE_FLIGHT, RATIO); 2: MIS (the default
                                 sampler, named); 3: FORCED; 0: the defaults */
    uint32_t bounces;         /* picvr_scattering.max_bounces */
    int frames, reuse;        /* scheduler.frames and .temporal_reuse on (priorities on) */
    int field;                /* PICVR_RENDER_FIELD, with */
    uint32_t field_ratio, field_dirs; /* this grid ratio and D (0: the library's defaults) */
} condition;
#define MAX_CONDITIONS 8

typedef struct scene_def {
    const char *name, *file, *tf, *lights;
    float spacing;
    float density_scale;      /* the preset's density times this */
} scene_def;

/* The benchmark family (make bench-family, docs/sampling.md): the thin medium at three
   optical depths (about 0.1, 1 and 10 through its centre; family_depth() measures it) under
   each light of family_lights().  Names "fam-<depth>-<light>". */
static const char *const FAMILY_DEPTHS[] = {"0.1", "1", "10"};
static const char *const FAMILY_LIGHTS[] = {"pt1.2", "pt2", "pt4", "pt8", "sphere", "rect", "sun", "sky", "env"};
#define N_FAMILY_DEPTHS (sizeof FAMILY_DEPTHS / sizeof FAMILY_DEPTHS[0])
#define N_FAMILY_LIGHTS (sizeof FAMILY_LIGHTS / sizeof FAMILY_LIGHTS[0])

static const scene_def SCENES[] = {
    {"thin", NULL, "thin", "point", 1.0f, 1.0f},
    {"thin-sun", NULL, "thin", "sun", 1.0f, 1.0f},
    {"thin-sun-0.1", NULL, "thin", "sun", 1.0f, 0.1f},
    {"thin-sun-10", NULL, "thin", "sun", 1.0f, 10.0f},
    {"thin-headlight", NULL, "thin", "headlight", 1.0f, 1.0f},
    {"thin-headlight-0.1", NULL, "thin", "headlight", 1.0f, 0.1f},
    {"bonsai", "bonsai_256x256x256_uint8.raw.gz", "ct-bonsai", "paper1", 1.0f, 1.0f},
    {"engine", "engine_pvm_256x256x256_uint8.raw.gz", "ct-engine", "paper3", 1.0f, 1.0f},
    {"aneurism", "aneurism_256x256x256_uint8.raw.gz", "ct-dense", "studio", 1.0f, 1.0f},
    {"cloud", "wdas_cloud_sixteenth_126x86x154_float32.raw.gz", "cloud-iso", "sun", 3.33f, 1.0f},
    {"cloud-sky", "wdas_cloud_sixteenth_126x86x154_float32.raw.gz", "cloud", "sun-sky", 3.33f, 1.0f},
    {"bonsai-paper3", "bonsai_256x256x256_uint8.raw.gz", "ct-bonsai", "paper3", 1.0f, 1.0f},
    {"bonsai-paper4", "bonsai_256x256x256_uint8.raw.gz", "ct-bonsai", "paper4", 1.0f, 1.0f},
    {"engine-paper1", "engine_pvm_256x256x256_uint8.raw.gz", "ct-engine", "paper1", 1.0f, 1.0f},
    {"engine-paper4", "engine_pvm_256x256x256_uint8.raw.gz", "ct-engine", "paper4", 1.0f, 1.0f},
};
#define N_SCENES (sizeof SCENES / sizeof SCENES[0])

/* ---- the scene ------------------------------------------------------------------------- */

/* The thin medium: exp(-r^2 / (2 (0.3 n)^2)) (0.75 + 0.25 sin sin sin), in [0, 1]. */
static float *make_thin_volume(uint32_t n)
{
    float *v = (float *)malloc((size_t)n * n * n * sizeof(float));
    if (!v) return NULL;
    double c = 0.5 * (n - 1), s = 0.3 * n, two_pi = 6.283185307179586;
    for (uint32_t z = 0; z < n; z++)
        for (uint32_t y = 0; y < n; y++)
            for (uint32_t x = 0; x < n; x++) {
                double dx = x - c, dy = y - c, dz = z - c;
                double blob = exp(-(dx * dx + dy * dy + dz * dz) / (2.0 * s * s));
                double wave = sin(two_pi * 3.0 * x / n) * sin(two_pi * 2.0 * y / n) * sin(two_pi * 2.5 * z / n);
                v[x + (size_t)n * (y + (size_t)n * z)] = (float)(blob * (0.75 + 0.25 * wave));
            }
    return v;
}

typedef struct loaded_scene {
    picvr_io_volume vol;
    float *thin;
    picvr_volume_desc desc;
    pvp_tf tf;
    pvp_lights lights;
    picvr_camera cam;
} loaded_scene;

/* ---- the family ---------------------------------------------------------------------- */

static void v3_normalize(float v[3])
{
    float l = sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; i++) v[i] = l > 0.0f ? v[i] / l : 0.0f;
}

/* The family's light `name` (FAMILY_LIGHTS) for the box centred on the origin with
   bounding-sphere radius R, placed in the camera's frame as the presets are (x right, y
   up, z toward the camera; the local lights above right in front).  Each gives about the
   same irradiance at the centre (8), so the images are alike in brightness:
     ptK     a point light at K R from the centre, intensity 8 (K R)^2;
     sphere  radius 0.25 R at 2 R, radiance 8 / (pi / 64);
     rect    a square of side R at 2 R facing the centre, radiance 8 / 0.25;
     sun     the sun preset's sun (0.0093 rad), without its sky;
     sky     a white constant background of radiance 1, alone;
     env     the sun-sky preset's map (Preetham sky over a grey ground), without its sun.
   Returns 0 for an unknown name. */
static int family_lights(const char *name, const float box_min[3], const float box_max[3], const picvr_camera *cam,
                         pvp_lights *out)
{
    memset(out, 0, sizeof *out);
    float R = 0.0f, fw[3], rt[3], up[3] = {0.0f, 1.0f, 0.0f}, dir[3];
    for (int i = 0; i < 3; i++) {
        float h = 0.5f * (box_max[i] - box_min[i]);
        R += h * h;
        fw[i] = cam->target[i] - cam->position[i];
    }
    R = sqrtf(R);
    v3_normalize(fw);
    rt[0] = fw[1] * up[2] - fw[2] * up[1];
    rt[1] = fw[2] * up[0] - fw[0] * up[2];
    rt[2] = fw[0] * up[1] - fw[1] * up[0];
    v3_normalize(rt);
    up[0] = rt[1] * fw[2] - rt[2] * fw[1];
    up[1] = rt[2] * fw[0] - rt[0] * fw[2];
    up[2] = rt[0] * fw[1] - rt[1] * fw[0];
    for (int i = 0; i < 3; i++) dir[i] = 0.5f * rt[i] + 0.6f * up[i] - 0.3f * fw[i];
    v3_normalize(dir);
    picvr_light *l = &out->lights[0];
    for (int i = 0; i < 3; i++) l->color[i] = 1.0f;
    if (!strncmp(name, "pt", 2)) {
        float k = (float)atof(name + 2);
        if (!(k > 1.0f)) return 0;
        l->type = PICVR_LIGHT_POINT;
        for (int i = 0; i < 3; i++) l->position[i] = dir[i] * k * R;
        l->intensity = 8.0f * k * R * k * R;
        out->count = 1;
    } else if (!strcmp(name, "sphere")) {
        l->type = PICVR_LIGHT_SPHERE;
        for (int i = 0; i < 3; i++) l->position[i] = dir[i] * 2.0f * R;
        l->radius = 0.25f * R;
        l->intensity = 8.0f * 64.0f / 3.14159265f;
        out->count = 1;
    } else if (!strcmp(name, "rect")) {
        l->type = PICVR_LIGHT_RECT;
        /* edges perpendicular to dir, u = dir x up and v = dir x u: cross(v, u) = -dir,
           so with edge_u = v and edge_v = u the lit side faces the centre */
        float u[3] = {dir[1] * up[2] - dir[2] * up[1], dir[2] * up[0] - dir[0] * up[2], dir[0] * up[1] - dir[1] * up[0]};
        v3_normalize(u);
        float v[3] = {dir[1] * u[2] - dir[2] * u[1], dir[2] * u[0] - dir[0] * u[2], dir[0] * u[1] - dir[1] * u[0]};
        for (int i = 0; i < 3; i++) {
            l->position[i] = dir[i] * 2.0f * R;
            l->edge_u[i] = v[i] * R;
            l->edge_v[i] = u[i] * R;
        }
        l->intensity = 8.0f / 0.25f;
        out->count = 1;
    } else if (!strcmp(name, "sun") || !strcmp(name, "env")) {
        pvp_lights preset;
        if (pvp_lights_preset(!strcmp(name, "sun") ? "sun" : "sun-sky", box_min, box_max, cam, &preset) != PVP_OK)
            return 0;
        if (!strcmp(name, "sun")) {
            for (uint32_t i = 0; i < preset.count; i++)
                if (preset.lights[i].type == PICVR_LIGHT_DIRECTIONAL) out->lights[out->count++] = preset.lights[i];
        } else {
            out->background = preset.background;
        }
    } else if (!strcmp(name, "sky")) {
        for (int i = 0; i < 3; i++) out->background.color[i] = 1.0f;
        out->background.intensity = 1.0f;
    } else {
        return 0;
    }
    return 1;
}

/* The thin volume's optical depth through its centre along x at density D (the `thin`
   preset: sigma_t = D * value). */
static double family_depth(const float *v, uint32_t n, double D)
{
    double s = 0.0;
    for (uint32_t x = 0; x < n; x++) s += v[x + (size_t)n * (n / 2 + (size_t)n * (n / 2))];
    return D * s;
}

/* The scene named "fam-<depth>-<light>" into *sd (its strings in buf); 0 when the name is
   not a family member. */
static int family_scene(const char *name, scene_def *sd, char *buf, size_t size)
{
    for (size_t d = 0; d < N_FAMILY_DEPTHS; d++)
        for (size_t l = 0; l < N_FAMILY_LIGHTS; l++) {
            char want[64];
            snprintf(want, sizeof want, "fam-%s-%s", FAMILY_DEPTHS[d], FAMILY_LIGHTS[l]);
            if (strcmp(want, name)) continue;
            snprintf(buf, size, "fam:%s", FAMILY_LIGHTS[l]);
            sd->name = name;
            sd->file = NULL;
            sd->tf = "thin";
            sd->lights = buf;
            sd->spacing = 1.0f;
            sd->density_scale = -(float)atof(FAMILY_DEPTHS[d]);   /* < 0: a target depth */
            return 1;
        }
    return 0;
}

static int load_scene(const options *o, const scene_def *sd, loaded_scene *ls)
{
    memset(ls, 0, sizeof *ls);
    if (!sd->file) {
        ls->thin = make_thin_volume(64);
        if (!ls->thin) { pvc_fail("out of memory"); return 0; }
        ls->desc.dims[0] = ls->desc.dims[1] = ls->desc.dims[2] = 64;
        ls->desc.type = PICVR_VOXEL_FLOAT32;
        ls->desc.data = ls->thin;
        ls->desc.value_min = 0.0f;
        ls->desc.value_max = 1.0f;
    } else {
        char path[4096], err[256];
        snprintf(path, sizeof path, "%s/%s", o->data, sd->file);
        if (picvr_io_load(path, NULL, &ls->vol, err, sizeof err) != PICVR_IO_OK) { pvc_fail("%s: %s", path, err); return 0; }
        memcpy(ls->desc.dims, ls->vol.dims, sizeof ls->desc.dims);
        ls->desc.type = ls->vol.type;
        ls->desc.data = ls->vol.data;
    }
    for (int i = 0; i < 3; i++) ls->desc.spacing[i] = sd->spacing;
    float box_min[3], box_max[3];
    for (int i = 0; i < 3; i++) {
        box_max[i] = 0.5f * ls->desc.dims[i] * sd->spacing;
        box_min[i] = -box_max[i];
    }
    if (pvp_tf_preset(sd->tf, &ls->tf)) { pvc_fail("%s: presets", sd->name); return 0; }
    /* density_scale < 0: the family's target optical depth through the centre */
    if (sd->density_scale < 0.0f && ls->thin)
        ls->tf.density *= (float)(-sd->density_scale / family_depth(ls->thin, 64, ls->tf.density));
    else
        ls->tf.density *= sd->density_scale;
    if (ls->thin)
        fprintf(stderr, "%s: optical depth %.3g through the centre\n", sd->name, family_depth(ls->thin, 64, ls->tf.density));
    if (pvp_orbit_camera(box_min, box_max, PVP_DEFAULT_AZIMUTH, PVP_DEFAULT_ELEVATION,
                         PVP_DEFAULT_DISTANCE, PVP_DEFAULT_FOV, o->width, o->height, &ls->cam)) {
        pvc_fail("%s: camera", sd->name);
        return 0;
    }
    int lights_ok = strncmp(sd->lights, "fam:", 4)
                        ? pvp_lights_preset(sd->lights, box_min, box_max, &ls->cam, &ls->lights) == PVP_OK
                        : family_lights(sd->lights + 4, box_min, box_max, &ls->cam, &ls->lights);
    if (!lights_ok) {
        pvc_fail("%s: lights", sd->name);
        return 0;
    }
    return 1;
}

static void free_scene(loaded_scene *ls)
{
    picvr_io_free(&ls->vol);
    free(ls->thin);
}

/* The condition code of an --after sampler: "forced" 3, "auto" 4, "forced-rm" 5, else the
   default 0. */
static int after_kind(const char *after)
{
    return !strcmp(after, "forced") ? 3 : !strcmp(after, "auto") ? 4 : !strcmp(after, "forced-rm") ? 5 : 0;
}

static picvr_context *open_context(const loaded_scene *ls, uint32_t seed, const condition *cd)
{
    int before = cd->before;   /* 1: the paper's sampler, 2: the default (MIS), 3: forced, 4: auto,
                                  5: forced with ray-marched transmittance */
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = seed;
    cfg.cache.mode = PICVR_CACHE_NONE;
    cfg.scheduler.priorities = cd->frames ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF;
    cfg.scheduler.frames = cd->frames ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF;
    cfg.scheduler.temporal_reuse = cd->reuse ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF;
    if (before == 1) {
        cfg.distance_sampling = PICVR_DISTANCE_FREE_FLIGHT;
        cfg.transmittance = PICVR_TRANSMITTANCE_RATIO;
    }
    if (before == 3) cfg.distance_sampling = PICVR_DISTANCE_FORCED;
    if (before == 4) cfg.distance_sampling = PICVR_DISTANCE_AUTO;
    if (before == 5) {
        cfg.distance_sampling = PICVR_DISTANCE_FORCED;
        cfg.transmittance = PICVR_TRANSMITTANCE_RAY_MARCHING;
    }
    if (cd->field) {
        cfg.field.mode = PICVR_RENDER_FIELD;
        cfg.field.grid_ratio = cd->field_ratio;
        cfg.field.directions = cd->field_dirs;
    }
    picvr_context *ctx = NULL;
    if (!pvc_check(picvr_create(&cfg, &ctx), "picvr_create")) return NULL;
    if (!pvc_check(picvr_upload_volume(ctx, &ls->desc), "picvr_upload_volume") ||
        !pvc_check(picvr_set_transfer_function(ctx, ls->tf.points, ls->tf.count, ls->tf.density), "transfer function") ||
        !pvc_check(picvr_set_lights(ctx, ls->lights.lights, ls->lights.count, &ls->lights.background), "lights") ||
        !pvc_check(picvr_set_camera(ctx, &ls->cam), "camera") ||
        !pvc_check(picvr_set_scattering(ctx, &(picvr_scattering){cd->bounces, 0.0f, 0.0f}), "scattering") ||
        !pvc_check(picvr_prepare(ctx), "picvr_prepare") ||
        !pvc_check(picvr_step_iterations(ctx, 1), "warm-up") || !pvc_check(picvr_reset(ctx), "picvr_reset")) {
        picvr_destroy(ctx);
        return NULL;
    }
    return ctx;
}

/* ---- images ---------------------------------------------------------------------------- */

static int read_luminance(picvr_context *ctx, size_t pixels, float *rgba, double *lum)
{
    if (!pvc_check(picvr_read_rgba32f(ctx, rgba, pixels * 16), "picvr_read_rgba32f")) return 0;
    for (size_t p = 0; p < pixels; p++)
        lum[p] = 0.2126 * rgba[4 * p] + 0.7152 * rgba[4 * p + 1] + 0.0722 * rgba[4 * p + 2];
    return 1;
}

static double mean_of(const double *v, size_t n)
{
    double s = 0.0;
    for (size_t i = 0; i < n; i++) s += v[i];
    return n ? s / (double)n : 0.0;
}

/* Relative RMSE of y against ref (the definition at the top). */
static double rel_rmse(const double *y, const double *ref, size_t n, double ref_mean)
{
    double s = 0.0, floor_ = 0.01 * ref_mean;
    for (size_t p = 0; p < n; p++) {
        double d = (y[p] - ref[p]) / (ref[p] + floor_);
        s += d * d;
    }
    return sqrt(s / (double)n);
}

typedef struct reference {
    double *lum;        /* per pixel */
    double *var;        /* per pixel: the variance of lum (from the chunks' spread) */
    double mean;        /* image mean luminance */
    double rel_err;     /* its own relative RMSE, from the spread of its chunks */
    uint64_t passes;
} reference;

/* The reference (step 1 at the top): chunks averaged by their pass counts; the error of
   the mean from the chunks' spread, sum_k n_k (y_k - y)^2 / ((K - 1) N) per pixel. */
static int make_reference(const options *o, const loaded_scene *ls, const condition *cd, reference *ref)
{
    size_t pixels = (size_t)o->width * o->height;
    uint32_t K = o->ref_chunks < 2 ? 2 : o->ref_chunks;
    double *chunk = (double *)calloc(pixels * K, sizeof(double));
    float *rgba = (float *)malloc(pixels * 16);
    uint32_t *passes = (uint32_t *)calloc(K, sizeof(uint32_t));
    ref->lum = (double *)calloc(pixels, sizeof(double));
    ref->var = (double *)calloc(pixels, sizeof(double));
    if (!chunk || !rgba || !passes || !ref->lum || !ref->var) { pvc_fail("out of memory"); free(chunk); free(rgba); free(passes); return 0; }
    int ok = 1;
    uint64_t total = 0;
    for (uint32_t k = 0; k < K && ok; k++) {
        condition after = *cd;
        after.before = after_kind(o->after) == 4 ? 3 : after_kind(o->after);   /* auto: the forced renderer */
        picvr_context *ctx = open_context(ls, 1001 + k, &after);
        ok = ctx != NULL;
        double spent = 0.0;
        while (ok && spent < o->ref_ms / K) {
            double t0 = pvc_now_ms();
            ok = pvc_check(picvr_step(ctx, 1000.0), "picvr_step");
            spent += pvc_now_ms() - t0;
        }
        picvr_stats st;
        if (ok) ok = pvc_check(picvr_get_stats(ctx, &st), "picvr_get_stats") && read_luminance(ctx, pixels, rgba, chunk + k * pixels);
        if (ok) { passes[k] = st.iterations; total += st.iterations; }
        picvr_destroy(ctx);
    }
    if (ok) {
        double var_sum = 0.0;
        for (size_t p = 0; p < pixels; p++) {
            double m = 0.0;
            for (uint32_t k = 0; k < K; k++) m += passes[k] * chunk[k * pixels + p];
            ref->lum[p] = m / (double)total;
        }
        ref->mean = mean_of(ref->lum, pixels);
        for (size_t p = 0; p < pixels; p++) {
            double v = 0.0;
            for (uint32_t k = 0; k < K; k++) {
                double d = chunk[k * pixels + p] - ref->lum[p];
                v += passes[k] * d * d;
            }
            v /= (double)(K - 1) * (double)total;   /* variance of the weighted mean */
            ref->var[p] = v;
            double r = ref->lum[p] + 0.01 * ref->mean;
            var_sum += v / (r * r);
        }
        ref->rel_err = sqrt(var_sum / (double)pixels);
        ref->passes = total;
    }
    free(chunk);
    free(rgba);
    free(passes);
    return ok;
}

/* ---- the side-by-side runs --------------------------------------------------------------- */

typedef struct run {
    picvr_context *ctx;
    int n;
    double t_ms[MAX_SLICES], err[MAX_SLICES], mean_ratio[MAX_SLICES];
    uint32_t passes[MAX_SLICES];
    double spent;
    double path_length;       /* stats.mean_path_length at the end */
    double forced_share, forced_efficiency;   /* PICVR_DISTANCE_AUTO's, at the end */
} run;

static int measure(run *r, const reference *ref, size_t pixels, float *rgba, double *lum)
{
    picvr_stats st;
    if (!pvc_check(picvr_get_stats(r->ctx, &st), "picvr_get_stats") || !read_luminance(r->ctx, pixels, rgba, lum)) return 0;
    double e = rel_rmse(lum, ref->lum, pixels, ref->mean);
    double e2 = e * e - ref->rel_err * ref->rel_err;   /* the reference's own error, in quadrature */
    r->t_ms[r->n] = r->spent;
    r->err[r->n] = sqrt(e2 > 0.0 ? e2 : 0.0);
    r->mean_ratio[r->n] = ref->mean > 0.0 ? mean_of(lum, pixels) / ref->mean : 0.0;
    r->passes[r->n] = st.iterations;
    r->path_length = st.mean_path_length;
    r->forced_share = st.forced_share;
    r->forced_efficiency = st.forced_efficiency;
    r->n++;
    return 1;
}

/* The time to reach target (step 3 at the top); *extrapolated set when the run ended
   first.  -1 when no estimate is possible. */
static double time_to(const run *r, double target, int *extrapolated)
{
    *extrapolated = 0;
    for (int i = 0; i < r->n; i++) {
        if (r->err[i] > target) continue;
        if (i == 0 || r->err[i - 1] <= 0.0 || r->err[i] <= 0.0) return r->t_ms[i];
        double a = log(r->err[i - 1]), b = log(r->err[i]), f = (log(target) - a) / (b - a);
        return exp(log(r->t_ms[i - 1]) + f * (log(r->t_ms[i]) - log(r->t_ms[i - 1])));
    }
    /* err ~ c t^-1/2: c from the last quarter of the run */
    int from = r->n - (r->n + 3) / 4;
    double c = 0.0;
    int k = 0;
    for (int i = from; i < r->n; i++)
        if (r->err[i] > 0.0) { c += r->err[i] * sqrt(r->t_ms[i]); k++; }
    if (!k) return -1.0;
    c /= k;
    *extrapolated = 1;
    return (c / target) * (c / target);
}

/* Relative RMSE^2 x samples per pixel over the last half of the run. */
static double variance_per_sample(const run *r)
{
    double s = 0.0;
    int k = 0;
    for (int i = r->n / 2; i < r->n; i++) { s += r->err[i] * r->err[i] * r->passes[i]; k++; }
    return k ? s / k : 0.0;
}

/* The conditions of a run: before and after, or the --bounces list (at most
   MAX_CONDITIONS; 0 on a bad list). */
static int parse_conditions(const options *o, condition *cd)
{
    if (!o->bounces) {
        memset(cd, 0, 2 * sizeof *cd);
        snprintf(cd[0].name, sizeof cd[0].name, "before");
        cd[0].before = strcmp(o->before, "mis") ? 1 : 2;
        snprintf(cd[1].name, sizeof cd[1].name, "after");
        cd[1].before = after_kind(o->after);
        return 2;
    }
    char list[256];
    snprintf(list, sizeof list, "%s", o->bounces);
    char *save = NULL;
    int n = 0;
    for (char *tok = strtok_r(list, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
        if (n == MAX_CONDITIONS) return 0;
        memset(&cd[n], 0, sizeof cd[n]);
        if (!strcmp(tok, "unlimited")) cd[n].bounces = PICVR_BOUNCES_UNLIMITED;
        else if (!pvc_parse_u32(tok, 0, 1000000, &cd[n].bounces)) return 0;
        snprintf(cd[n].name, sizeof cd[n].name, "%s bounces", tok);
        n++;
    }
    return n;
}

static int run_scene(const options *o, const scene_def *sd, FILE *md, FILE *csv)
{
    condition cd[MAX_CONDITIONS];
    int nc = parse_conditions(o, cd);
    if (!nc) { pvc_fail("bad --bounces list '%s'", o->bounces); return 0; }
    loaded_scene ls;
    if (!load_scene(o, sd, &ls)) return 0;
    size_t pixels = (size_t)o->width * o->height;
    /* one reference per bounce count (before and after share theirs) */
    static reference ref[MAX_CONDITIONS];
    memset(ref, 0, sizeof ref);
    int ok = 1, ref_of[MAX_CONDITIONS];
    for (int c = 0; c < nc && ok; c++) {
        ref_of[c] = c;
        for (int k = 0; k < c; k++)
            if (cd[k].bounces == cd[c].bounces) { ref_of[c] = k; break; }
        if (ref_of[c] != c) continue;
        double t0 = pvc_now_ms();
        ok = make_reference(o, &ls, &cd[c], &ref[c]);
        if (ok) fprintf(stderr, "%s, %s: reference of %llu passes in %.0f s, relative RMSE %.4f\n", sd->name, cd[c].name,
                        (unsigned long long)ref[c].passes, (pvc_now_ms() - t0) / 1000.0, ref[c].rel_err);
    }
    static run runs[MAX_CONDITIONS];
    memset(runs, 0, sizeof runs);
    float *rgba = (float *)malloc(pixels * 16);
    double *lum = (double *)malloc(pixels * sizeof(double));
    if (!rgba || !lum) { pvc_fail("out of memory"); ok = 0; }
    for (int c = 0; c < nc && ok; c++) ok = (runs[c].ctx = open_context(&ls, o->seed, &cd[c])) != NULL;
    for (int busy = 1; ok && busy;) {
        busy = 0;
        for (int c = 0; c < nc && ok; c++) {
            run *r = &runs[c];
            if (r->spent >= o->time_ms || r->n >= MAX_SLICES) continue;
            busy = 1;
            double s0 = pvc_now_ms();
            ok = pvc_check(picvr_step(r->ctx, o->slice_ms), "picvr_step");
            r->spent += pvc_now_ms() - s0;
            if (ok) ok = measure(r, &ref[ref_of[c]], pixels, rgba, lum);
        }
    }
    if (ok) {
        for (int c = 0; c < nc; c++) {
            const run *r = &runs[c];
            const reference *rf = &ref[ref_of[c]];
            double last_t = r->t_ms[r->n - 1] / 1000.0;
            double sps = pixels * (double)r->passes[r->n - 1] / last_t;
            fprintf(md, "| %s | %s |", sd->name, cd[c].name);
            for (int k = 0; k < N_TARGETS; k++) {
                int ex;
                double t = time_to(r, TARGETS[k], &ex);
                if (t < 0.0) fprintf(md, " - |");
                else fprintf(md, " %s%.3g |", ex ? "~" : "", t / 1000.0);
            }
            fprintf(md, " %.3g | %.3g | %.4f | %.4f | %.3f | %.3f | %.3f / %.3g |\n", variance_per_sample(r), sps / 1e6,
                    r->err[r->n - 1], r->mean_ratio[r->n - 1], ref[0].mean > 0.0 ? rf->mean / ref[0].mean : 0.0,
                    r->path_length, r->forced_share, r->forced_efficiency);
            for (int i = 0; i < r->n; i++)
                fprintf(csv, "%s,%s,%.1f,%u,%.6f,%.6f\n", sd->name, cd[c].name, r->t_ms[i], r->passes[i], r->err[i],
                        r->mean_ratio[i]);
        }
        for (int c = 0; c < nc; c++)
            if (ref_of[c] == c)
                fprintf(md, "|  | reference (%s): %llu passes, relative RMSE %.4f (removed in quadrature) | | | | | | | | | | |\n",
                        cd[c].name, (unsigned long long)ref[c].passes, ref[c].rel_err);
        fflush(md);
        fflush(csv);
    }
    for (int c = 0; c < nc; c++) picvr_destroy(runs[c].ctx);
    free(rgba);
    free(lum);
    for (int c = 0; c < nc; c++) { free(ref[c].lum); free(ref[c].var); }
    free_scene(&ls);
    return ok;
}

/* ---- the engine's case: orbiting frames, temporal reuse off and on ------------------------ */

/* The camera of frame f: the default orbit turned by f * orbit_deg. */
static int frame_camera(const options *o, const loaded_scene *ls, uint32_t f, picvr_camera *cam)
{
    float box_min[3], box_max[3];
    for (int i = 0; i < 3; i++) {
        box_max[i] = 0.5f * ls->desc.dims[i] * ls->desc.spacing[i];
        box_min[i] = -box_max[i];
    }
    float az = (float)fmod(PVP_DEFAULT_AZIMUTH + f * o->orbit_deg, 360.0);
    return pvp_orbit_camera(box_min, box_max, az, PVP_DEFAULT_ELEVATION, PVP_DEFAULT_DISTANCE, PVP_DEFAULT_FOV,
                            o->width, o->height, cam) == PVP_OK;
}

typedef struct frame_row { double ms, spp, err; uint64_t holes; } frame_row;

static int run_frames(const options *o, const scene_def *sd, FILE *md, FILE *csv)
{
    loaded_scene ls;
    if (!load_scene(o, sd, &ls)) return 0;
    size_t pixels = (size_t)o->width * o->height;
    uint32_t K = o->checkpoints < 1 ? 1 : o->checkpoints > o->frames ? o->frames : o->checkpoints;
    enum { NC = 3 };   /* Monte Carlo with reuse off and on, the field (its defaults) */
    condition cd[NC];
    memset(cd, 0, sizeof cd);
    for (int c = 0; c < NC; c++) {
        snprintf(cd[c].name, sizeof cd[c].name, c == 2 ? "field" : c ? "reuse on" : "reuse off");
        cd[c].bounces = ls.tf.max_bounces;
        cd[c].frames = c < 2;
        cd[c].reuse = c == 1;
        cd[c].field = c == 2;   /* the library's default grid and directions */
    }
    reference *ref = (reference *)calloc(K, sizeof *ref);
    uint32_t *at = (uint32_t *)calloc(K, sizeof *at);
    frame_row *rows = (frame_row *)calloc(NC * (size_t)o->frames, sizeof *rows);
    float *rgba = (float *)malloc(pixels * 16);
    double *lum = (double *)malloc(pixels * sizeof(double));
    int ok = ref && at && rows && rgba && lum;
    if (!ok) pvc_fail("out of memory");
    for (uint32_t k = 0; k < K && ok; k++) {   /* checkpoints: frames (k + 1) N / K - 1 */
        at[k] = (uint32_t)(((uint64_t)(k + 1) * o->frames) / K) - 1;
        condition rc = cd[0];
        rc.frames = 0;   /* the reference: whole passes, priorities off */
        double t0 = pvc_now_ms();
        ok = frame_camera(o, &ls, at[k], &ls.cam) && make_reference(o, &ls, &rc, &ref[k]);
        if (ok) fprintf(stderr, "%s: reference of frame %u: %llu passes in %.0f s, relative RMSE %.4f\n", sd->name, at[k],
                        (unsigned long long)ref[k].passes, (pvc_now_ms() - t0) / 1000.0, ref[k].rel_err);
    }
    picvr_context *ctx[NC] = {NULL, NULL, NULL};
    if (ok) ok = frame_camera(o, &ls, 0, &ls.cam);
    for (int c = 0; c < NC && ok; c++) ok = (ctx[c] = open_context(&ls, o->seed, &cd[c])) != NULL;
    for (uint32_t f = 0, k = 0; f < o->frames && ok; f++) {
        picvr_camera cam;
        ok = frame_camera(o, &ls, f, &cam);
        for (int c = 0; c < NC && ok; c++) {
            frame_row *r = &rows[(size_t)c * o->frames + f];
            picvr_stats st;
            double t0 = pvc_now_ms();
            ok = pvc_check(picvr_set_camera(ctx[c], &cam), "picvr_set_camera") &&
                 pvc_check(picvr_step(ctx[c], o->frame_ms), "picvr_step");
            r->ms = pvc_now_ms() - t0;
            ok = ok && pvc_check(picvr_get_stats(ctx[c], &st), "picvr_get_stats");
            r->spp = st.iterations_mean;
            r->holes = st.pixels_unsampled;
            r->err = NAN;
            if (ok && k < K && f == at[k]) {
                ok = read_luminance(ctx[c], pixels, rgba, lum);
                double e = rel_rmse(lum, ref[k].lum, pixels, ref[k].mean);
                double e2 = e * e - ref[k].rel_err * ref[k].rel_err;   /* the reference's own error removed */
                r->err = sqrt(e2 > 0.0 ? e2 : 0.0);
            }
        }
        if (k < K && f == at[k]) k++;
    }
    if (ok) {
        for (int c = 0; c < NC; c++) {
            const frame_row *r = rows + (size_t)c * o->frames;
            double ms = 0.0;
            uint64_t holes = 0;
            for (uint32_t f = 0; f < o->frames; f++) {
                ms += r[f].ms / o->frames;
                holes = r[f].holes > holes ? r[f].holes : holes;
                fprintf(csv, "%s,%s,%u,%.2f,%.3f,%llu,%.6f\n", sd->name, cd[c].name, f, r[f].ms, r[f].spp,
                        (unsigned long long)r[f].holes, r[f].err);
            }
            fprintf(md, "| %s | %s | %.1f | %llu |", sd->name, cd[c].name, ms, (unsigned long long)holes);
            for (uint32_t k = 0; k < K; k++) fprintf(md, " %.4f (%.1f spp) |", r[at[k]].err, r[at[k]].spp);
            fprintf(md, "\n");
        }
        for (uint32_t k = 0; k < K; k++)
            fprintf(md, "|  | reference of frame %u: %llu passes, relative RMSE %.4f (removed in quadrature) |\n", at[k],
                    (unsigned long long)ref[k].passes, ref[k].rel_err);
    }
    for (int c = 0; c < NC; c++) picvr_destroy(ctx[c]);
    for (uint32_t k = 0; ref && k < K; k++) { free(ref[k].lum); free(ref[k].var); }
    free(ref);
    free(at);
    free(rows);
    free(rgba);
    free(lum);
    free_scene(&ls);
    return ok;
}

/* ---- the light field (--field): build, rebuild and frame times, error against Monte Carlo ---- */

/* The turn of light k's direction (a directional light) by deg about the world's y. */
static void turn_sun(picvr_light *l, double deg)
{
    double a = deg * 3.14159265358979 / 180.0, c = cos(a), s = sin(a);
    double x = l->direction[0], z = l->direction[2];
    l->direction[0] = (float)(c * x + s * z);
    l->direction[2] = (float)(-s * x + c * z);
}

/* The median wall time of picvr_step over n frames of the current camera. */
static double median_frame_ms(picvr_context *ctx, int n, int *ok)
{
    double t[16];
    if (n > 16) n = 16;
    for (int i = 0; i < n && *ok; i++) {
        double t0 = pvc_now_ms();
        *ok = pvc_check(picvr_step(ctx, 1.0), "picvr_step");
        t[i] = pvc_now_ms() - t0;
    }
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && t[j] < t[j - 1]; j--) { double x = t[j]; t[j] = t[j - 1]; t[j - 1] = x; }
    return t[n / 2];
}

/* The relative RMSE over the pixels the medium covers (where the reference differs from
   the background alone by more than 1e-3 of the background's mean), relative to their
   mean: the measure, with the reference's own noise there (its per-pixel
   variance) removed in quadrature; *noise gets that noise. */
static double covered_rmse(const double *y, const reference *ref, const double *bg, size_t n, double *noise)
{
    double bg_mean = mean_of(bg, n), s = 0.0, m = 0.0, v = 0.0;
    size_t k = 0;
    for (size_t p = 0; p < n; p++) {
        if (fabs(ref->lum[p] - bg[p]) <= 1e-3 * bg_mean) continue;
        s += (y[p] - ref->lum[p]) * (y[p] - ref->lum[p]);
        v += ref->var[p];
        m += ref->lum[p];
        k++;
    }
    if (!k || !(m > 0.0)) { *noise = 0.0; return 0.0; }
    *noise = sqrt(v / k) / (m / k);
    return sqrt(fmax(s - v, 0.0) / k) / (m / k);
}

static int run_field(const options *o, const scene_def *sd, FILE *md, FILE *csv)
{
    loaded_scene ls;
    if (!load_scene(o, sd, &ls)) return 0;
    size_t pixels = (size_t)o->width * o->height;
    condition mc;
    memset(&mc, 0, sizeof mc);
    snprintf(mc.name, sizeof mc.name, "monte carlo");
    mc.bounces = ls.tf.max_bounces;
    reference ref;
    memset(&ref, 0, sizeof ref);
    static run r;
    memset(&r, 0, sizeof r);
    float *rgba = (float *)malloc(pixels * 16);
    double *lum = (double *)malloc(pixels * sizeof(double)), *bg = (double *)malloc(pixels * sizeof(double));
    int ok = rgba && lum && bg;
    if (!ok) pvc_fail("out of memory");
    double t0 = pvc_now_ms();
    ok = ok && make_reference(o, &ls, &mc, &ref);
    if (ok) fprintf(stderr, "%s: reference of %llu passes in %.0f s, relative RMSE %.4f\n", sd->name,
                    (unsigned long long)ref.passes, (pvc_now_ms() - t0) / 1000.0, ref.rel_err);
    /* Monte Carlo's error against time, for "worth N s of Monte Carlo" */
    ok = ok && (r.ctx = open_context(&ls, o->seed, &mc)) != NULL;
    while (ok && r.spent < o->time_ms && r.n < MAX_SLICES) {
        double s0 = pvc_now_ms();
        ok = pvc_check(picvr_step(r.ctx, o->slice_ms), "picvr_step");
        r.spent += pvc_now_ms() - s0;
        if (ok) ok = measure(&r, &ref, pixels, rgba, lum);
    }
    picvr_destroy(r.ctx);
    /* the background alone (the field image of an empty medium is exactly it) */
    condition fc;
    memset(&fc, 0, sizeof fc);
    fc.field = 1;
    fc.bounces = ls.tf.max_bounces;
    if (ok) {
        loaded_scene empty = ls;
        empty.tf.density = 0.0f;
        picvr_context *ctx = open_context(&empty, o->seed, &fc);
        ok = ctx && pvc_check(picvr_step(ctx, 1.0), "picvr_step") && read_luminance(ctx, pixels, rgba, bg);
        picvr_destroy(ctx);
    }
    char list[256];
    snprintf(list, sizeof list, "%s", o->field);
    char *save = NULL;
    static const uint32_t sizes[3][2] = {{320, 180}, {640, 360}, {1280, 720}};
    double cov_noise = 0.0;
    for (char *tok = strtok_r(list, ",", &save); tok && ok; tok = strtok_r(NULL, ",", &save)) {
        if (sscanf(tok, "%u:%u", &fc.field_ratio, &fc.field_dirs) != 2) { pvc_fail("--field: RATIO:D, not '%s'", tok); ok = 0; break; }
        picvr_context *ctx = open_context(&ls, o->seed, &fc);   /* its warm-up step builds the field */
        picvr_stats st, st2;
        ok = ctx && pvc_check(picvr_get_stats(ctx, &st), "picvr_get_stats");
        ok = ok && pvc_check(picvr_step(ctx, 1.0), "picvr_step") && read_luminance(ctx, pixels, rgba, lum);
        double err = ok ? rel_rmse(lum, ref.lum, pixels, ref.mean) : 0.0;
        double cov = ok ? covered_rmse(lum, &ref, bg, pixels, &cov_noise) : 0.0;
        int ex = 0;
        double worth = ok ? time_to(&r, err, &ex) : -1.0;
        double frame[3];
        for (int k = 0; k < 3 && ok; k++) {
            picvr_camera cam = ls.cam;
            cam.width = sizes[k][0];
            cam.height = sizes[k][1];
            ok = pvc_check(picvr_set_camera(ctx, &cam), "picvr_set_camera");
            frame[k] = median_frame_ms(ctx, 7, &ok);
        }
        /* a sun move (5 degrees), then a transfer-function change (density x 1.2) */
        double sun_ms = -1.0, tf_ms = -1.0;
        uint32_t sun_passes = 0, tf_passes = 0;
        for (uint32_t i = 0; i < ls.lights.count && ok; i++) {
            if (ls.lights.lights[i].type != PICVR_LIGHT_DIRECTIONAL) continue;
            picvr_light moved[PICVR_MAX_LIGHTS];
            memcpy(moved, ls.lights.lights, ls.lights.count * sizeof moved[0]);
            turn_sun(&moved[i], 5.0);
            ok = pvc_check(picvr_set_lights(ctx, moved, ls.lights.count, &ls.lights.background), "picvr_set_lights") &&
                 pvc_check(picvr_step(ctx, 1.0), "picvr_step") && pvc_check(picvr_get_stats(ctx, &st2), "stats");
            sun_ms = st2.field_build_ms;
            sun_passes = st2.field_passes;
            break;
        }
        if (ok) {
            ok = pvc_check(picvr_set_transfer_function(ctx, ls.tf.points, ls.tf.count, 1.2f * ls.tf.density), "tf") &&
                 pvc_check(picvr_step(ctx, 1.0), "picvr_step") && pvc_check(picvr_get_stats(ctx, &st2), "stats");
            tf_ms = st2.field_build_ms;
            tf_passes = st2.field_passes;
        }
        if (ok) {
            fprintf(md, "| %s | %u | %u | %ux%ux%u | %.1f | %.2f (%u) | %.2f (%u) | %.2f (%u) | %.1f | %.1f | %.1f | %.4f | %.4f | %s%.3g |\n",
                    sd->name, fc.field_ratio, fc.field_dirs, st.field_cells[0], st.field_cells[1], st.field_cells[2],
                    st.field_bytes / 1048576.0, st.field_build_ms / 1000.0, st.field_passes, sun_ms / 1000.0, sun_passes,
                    tf_ms / 1000.0, tf_passes, frame[0], frame[1], frame[2], err, cov, ex ? "~" : "", worth / 1000.0);
            fprintf(csv, "%s,%u,%u,%.1f,%u,%.1f,%.1f,%.2f,%.2f,%.2f,%.6f,%.6f,%.1f\n", sd->name, fc.field_ratio, fc.field_dirs,
                    st.field_build_ms, st.field_passes, sun_ms, tf_ms, frame[0], frame[1], frame[2], err, cov, worth);
            fflush(md);
            fflush(csv);
        }
        picvr_destroy(ctx);
    }
    if (ok)
        fprintf(md, "|  | reference: %llu passes, relative RMSE %.4f, %.4f over the covered pixels (both removed "
                    "in quadrature); Monte Carlo for %.0f s to %.4f |\n", (unsigned long long)ref.passes, ref.rel_err,
                cov_noise, r.spent / 1000.0, r.n ? r.err[r.n - 1] : 0.0);
    free(ref.lum);
    free(ref.var);
    free(rgba);
    free(lum);
    free(bg);
    free_scene(&ls);
    return ok;
}

/* ---- options ---------------------------------------------------------------------------- */

static void print_help(FILE *f)
{
    fprintf(f,
        "usage: " PROGRAM " [options]   (see the comment at the top of bench/bench_sampling.c)\n"
        "  --scenes A,B     of thin (point), thin-sun, thin-sun-0.1, thin-sun-10 (density x 0.1,\n"
        "                   x 10), thin-headlight, thin-headlight-0.1, bonsai (paper1),\n"
        "                   engine (paper3), aneurism (studio), cloud (sun), cloud-sky,\n"
        "                   bonsai-paper3, bonsai-paper4, engine-paper1, engine-paper4\n"
        "                   (default thin)\n"
        "  --data DIR       data directory (default ../shared/data)\n"
        "  --size WxH       image size (default 256x256)\n"
        "  --time MS        time per condition inside picvr_step (default 60000)\n"
        "  --slice MS       picvr_step budget between measurements (default 500)\n"
        "  --ref-time MS    the reference's rendering time (default 240000)\n"
        "  --ref-chunks N   independent contexts of the reference (default 4)\n"
        "  --seed N         seed of both conditions' runs (default 101)\n"
        "  --out DIR        sampling.md and sampling.csv go there (default bench/results/sampling)\n"
        "  --write-thin F   write the thin medium to F (name it thin_64x64x64_float32.raw for\n"
        "                   picvr-render --volume) and exit\n"
        "  --before KIND    the \"before\" sampler: paper (free flight, ratio tracking; the\n"
        "                   default) or mis (the default sampler: equiangular sampling alone)\n"
        "  --after KIND     the \"after\" sampler: default, forced (PICVR_DISTANCE_FORCED), auto or\n"
        "                   forced-rm (forced with PICVR_TRANSMITTANCE_RAY_MARCHING)\n"
        "  --bounces LIST   compare these max_bounces values (0,1,4,unlimited) instead of the\n"
        "                   two samplers; results in OUT/paths.md, .csv\n"
        "  --frames N       the engine's case instead: N real-time frames, temporal reuse off\n"
        "                   and on; results in OUT/frames.md, .csv\n"
        "  --frame-ms MS    each frame's budget (default 16)\n"
        "  --orbit DEG      the camera's turn per frame (default 1)\n"
        "  --checkpoints K  frames measured against a reference of their view (default 3)\n"
        "  --field LIST     the light field instead, per RATIO:D of the list (e.g. 8:32,4:64):\n"
        "                   build, rebuild after a sun move and a transfer-function change,\n"
        "                   frame times at 320x180, 640x360 and 1280x720, error against the\n"
        "                   reference at --size, and the Monte-Carlo time to that error\n"
        "                   (--time, --slice); results in OUT/field.md, .csv\n");
}

static const pvc_option OPTIONS[] = {
    {"help", 0}, {"scenes", 1}, {"data", 1}, {"size", 1}, {"time", 1}, {"slice", 1},
    {"ref-time", 1}, {"ref-chunks", 1}, {"seed", 1}, {"out", 1}, {"write-thin", 1}, {"bounces", 1}, {"before", 1}, {"after", 1},
    {"frames", 1}, {"frame-ms", 1}, {"orbit", 1}, {"checkpoints", 1}, {"field", 1}, {NULL, 0}};

static int apply_option(void *target, const char *name, const char *value)
{
    options *o = (options *)target;
    if (!strcmp(name, "scenes")) o->scenes = value;
    else if (!strcmp(name, "data")) o->data = value;
    else if (!strcmp(name, "out")) o->out = value;
    else if (!strcmp(name, "write-thin")) o->write_thin = value;
    else if (!strcmp(name, "bounces")) o->bounces = value;
    else if (!strcmp(name, "field")) o->field = value;
    else if (!strcmp(name, "before")) {
        if (strcmp(value, "paper") && strcmp(value, "mis")) { pvc_bad_value(name, value); return 0; }
        o->before = value;
    }
    else if (!strcmp(name, "after")) {
        if (strcmp(value, "default") && strcmp(value, "forced") && strcmp(value, "auto") && strcmp(value, "forced-rm")) {
            pvc_bad_value(name, value);
            return 0;
        }
        o->after = value;
    }
    else if (!strcmp(name, "size")) return pvc_parse_size(value, PICVR_MAX_IMAGE_SIZE, &o->width, &o->height) ? 1 : (pvc_bad_value(name, value), 0);
    else if (!strcmp(name, "ref-chunks")) return pvc_parse_u32(value, 2, 1000, &o->ref_chunks) ? 1 : (pvc_bad_value(name, value), 0);
    else if (!strcmp(name, "seed")) return pvc_parse_u32(value, 0, 999, &o->seed) ? 1 : (pvc_bad_value(name, value), 0);
    else if (!strcmp(name, "frames")) return pvc_parse_u32(value, 1, 100000, &o->frames) ? 1 : (pvc_bad_value(name, value), 0);
    else if (!strcmp(name, "checkpoints")) return pvc_parse_u32(value, 1, 100, &o->checkpoints) ? 1 : (pvc_bad_value(name, value), 0);
    else if (!strcmp(name, "frame-ms") || !strcmp(name, "orbit")) {
        double v;
        if (!pvc_parse_double(value, &v) || !(v >= 0.0)) { pvc_bad_value(name, value); return 0; }
        if (!strcmp(name, "frame-ms")) o->frame_ms = v;
        else o->orbit_deg = v;
    }
    else {
        double v;
        if (!pvc_parse_double(value, &v) || !(v > 0.0)) { pvc_bad_value(name, value); return 0; }
        if (!strcmp(name, "time")) o->time_ms = v;
        else if (!strcmp(name, "slice")) o->slice_ms = v;
        else o->ref_ms = v;
    }
    return 1;
}

int main(int argc, char **argv)
{
    pvc_set_program(PROGRAM);
    options o = {"thin", "../shared/data", "bench/results/sampling", NULL, 256, 256, 60000.0, 500.0, 240000.0, 4, 101, NULL,
                 "paper", "default", 0, 3, 16.0, 1.0, NULL};
    int rc = pvc_parse_options(argc, argv, OPTIONS, apply_option, &o, print_help);
    if (rc >= 0) return rc;
    if (o.write_thin) {   /* raw float32, x fastest, host byte order as picvr-render reads it */
        float *v = make_thin_volume(64);
        FILE *f = v ? fopen(o.write_thin, "wb") : NULL;
        int ok = f && fwrite(v, sizeof(float), 64 * 64 * 64, f) == 64 * 64 * 64;
        if (f && fclose(f) != 0) ok = 0;
        free(v);
        if (!ok) pvc_fail("cannot write %s", o.write_thin);
        return ok ? 0 : 1;
    }
    char path[4096];
    snprintf(path, sizeof path, "mkdir -p '%s'", o.out);
    if (system(path) != 0) { pvc_fail("cannot make %s", o.out); return 1; }
    const char *stem = o.field ? "field" : o.frames ? "frames" : o.bounces ? "paths" : "sampling";
    snprintf(path, sizeof path, "%s/%s.md", o.out, stem);
    FILE *md = fopen(path, "w");
    snprintf(path, sizeof path, "%s/%s.csv", o.out, stem);
    FILE *csv = fopen(path, "w");
    if (!md || !csv) { pvc_fail("cannot write to %s", o.out); return 1; }
    if (o.field) {
        fprintf(md, "error at %ux%u against Monte Carlo's converged image; build and rebuild times in s (passes); "
                    "frame times the median of 7; 'worth': the Monte-Carlo time to the same error (bench relative RMSE; "
                    "'~' extrapolated)\n\n", o.width, o.height);
        fprintf(md, "| scene | grid ratio | D | cells | MiB | build | sun moved 5 deg | density x 1.2 | frame 320x180 ms | "
                    "640x360 | 1280x720 | relative RMSE | covered-pixel RMSE | worth s of Monte Carlo |\n");
        fprintf(md, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        fprintf(csv, "scene,ratio,directions,build_ms,passes,sun_ms,tf_ms,frame320,frame640,frame1280,rel_rmse,covered_rmse,worth_ms\n");
    } else if (o.frames) {
        fprintf(md, "%ux%u, %u frames of %.0f ms, the camera turning %.2f degrees a frame, seed %u; true relative "
                    "RMSE at the checkpoint frames (samples per pixel then)\n\n", o.width, o.height, o.frames, o.frame_ms,
                o.orbit_deg, o.seed);
        fprintf(md, "| scene | condition | mean frame, ms | most pixels unsampled |");
        for (uint32_t k = 0; k < o.checkpoints; k++) fprintf(md, " frame %u |", (k + 1) * o.frames / o.checkpoints - 1);
        fprintf(md, "\n|---|---|---|---|");
        for (uint32_t k = 0; k < o.checkpoints; k++) fprintf(md, "---|");
        fprintf(md, "\n");
        fprintf(csv, "scene,condition,frame,ms,spp,pixels_unsampled,rel_rmse\n");
    } else {
        fprintf(md, "%ux%u, %.0f s per condition side by side (slices of %.0f ms), seed %u; time in s to a true "
                    "relative RMSE; '~': extrapolated by err ~ t^-1/2\n\n", o.width, o.height, o.time_ms / 1000.0, o.slice_ms, o.seed);
        fprintf(md, "| scene | condition | t(0.05) | t(0.02) | t(0.01) | variance per sample | Msamples/s | final rel. RMSE | "
                    "mean / reference | reference mean / first's | scatter events per sample | forced share / E |\n");
        fprintf(md, "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        fprintf(csv, "scene,condition,ms,passes,rel_rmse,mean_ratio\n");
    }
    int ok = 1;
    char list[1024];
    snprintf(list, sizeof list, "%s", o.scenes);
    char *save = NULL;
    for (char *tok = strtok_r(list, ",", &save); tok && ok; tok = strtok_r(NULL, ",", &save)) {
        const scene_def *sd = NULL;
        static scene_def fam;
        static char fam_lights[64];
        for (size_t i = 0; i < N_SCENES; i++)
            if (!strcmp(SCENES[i].name, tok)) sd = &SCENES[i];
        if (!sd && family_scene(tok, &fam, fam_lights, sizeof fam_lights)) sd = &fam;
        if (!sd) { pvc_fail("unknown scene '%s'", tok); ok = 0; break; }
        ok = o.field ? run_field(&o, sd, md, csv) : o.frames ? run_frames(&o, sd, md, csv) : run_scene(&o, sd, md, csv);
    }
    fclose(md);
    fclose(csv);
    if (ok) {
        snprintf(path, sizeof path, "%s/%s.md", o.out, stem);
        FILE *f = fopen(path, "r");
        int ch;
        while (f && (ch = fgetc(f)) != EOF) putchar(ch);
        if (f) fclose(f);
    }
    return ok ? 0 : 1;
}
