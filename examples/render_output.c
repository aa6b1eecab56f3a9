/* render_output.c - picvr-render's outputs: the tone-mapped PNG, the linear PFM, the
 * cache's error figure of --debug-view error, the JSON summary (a table of the
 * statistics, the scene's names and the configuration the library resolved) and the
 * summary line on stdout.
 */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <stb/stb_image_write.h>

#include "cli.h"
#include "picvr.h"
#include "render.h"

/* ---- images ------------------------------------------------------------------------- */

int render_write_png(picvr_context *ctx, const render_options *o)
{
    size_t size = (size_t)o->width * o->height * 4;
    uint8_t *px = malloc(size);
    if (!px) {
        pvc_fail("out of memory for the image");
        return 0;
    }
    int ok = pvc_check(picvr_read_rgba8(ctx, px, size, o->exposure), "picvr_read_rgba8");
    int comp = o->png_alpha ? 4 : 3, w = (int)o->width, h = (int)o->height;
    if (ok && comp == 3) /* drop alpha in place: viewers would hide the background */
        for (size_t i = 0, n = (size_t)o->width * o->height; i < n; i++)
            memmove(px + 3 * i, px + 4 * i, 3);
    /* the format the extension names (checked when the options were read) */
    const char *path = o->out_png;
    int written = !ok ? 0
                : pvc_has_extension(path, ".png")   ? stbi_write_png(path, w, h, comp, px, w * comp)
                : pvc_has_extension(path, ".tga")   ? stbi_write_tga(path, w, h, comp, px)
                : pvc_has_extension(path, ".bmp")   ? stbi_write_bmp(path, w, h, comp, px)
                                                    : stbi_write_jpg(path, w, h, comp, px, 95);
    if (ok && !written) {
        pvc_fail("cannot write %s", o->out_png);
        ok = 0;
    }
    free(px);
    return ok;
}

/* The linear RGBA float image (malloc'd; NULL after a reported failure). */
static float *read_float_image(picvr_context *ctx, const render_options *o)
{
    size_t size = (size_t)o->width * o->height * 16;
    float *px = malloc(size);
    if (!px) {
        pvc_fail("out of memory for the float image");
        return NULL;
    }
    if (!pvc_check(picvr_read_rgba32f(ctx, px, size), "picvr_read_rgba32f")) {
        free(px);
        return NULL;
    }
    return px;
}

int render_write_pfm(picvr_context *ctx, const render_options *o)
{
    float *px = read_float_image(ctx, o);
    int ok = px != NULL;
    if (ok && pvc_has_extension(o->out_pfm, ".exr")) {
        char err[256] = "";
        ok = render_write_exr(o->out_pfm, px, o->width, o->height, err, sizeof err);
        if (!ok) pvc_fail("cannot write %s: %s", o->out_pfm, err);
    } else if (ok && pvc_has_extension(o->out_pfm, ".hdr")) {   /* Radiance RGBE: RGB, alpha dropped in place */
        for (size_t i = 0, n = (size_t)o->width * o->height; i < n; i++) memmove(px + 3 * i, px + 4 * i, 3 * sizeof(float));
        ok = stbi_write_hdr(o->out_pfm, (int)o->width, (int)o->height, 3, px) != 0;
        if (!ok) pvc_fail("cannot write %s", o->out_pfm);
    } else if (ok) {
        ok = pvc_write_pfm(o->out_pfm, px, o->width, o->height);
    }
    free(px);
    return ok;
}

/* --debug-view error: sum R / sum G - 1 over the image (picvr.h, PICVR_VIEW_CACHE_ERROR). */
int render_print_cache_error(picvr_context *ctx, const render_options *o)
{
    size_t n = (size_t)o->width * o->height;
    float *px = read_float_image(ctx, o);
    int ok = px != NULL;
    double r = 0, g = 0, b = 0;
    for (size_t i = 0; ok && i < n; i++) {
        r += px[4 * i];
        g += px[4 * i + 1];
        b += px[4 * i + 2];
    }
    free(px);
    /* Rule: no hit yet (g = 0) prints no ratio rather than dividing by 0. */
    if (ok && g > 0)
        fprintf(stderr, "%s: cache error per hit %+.2f %% (mean served fraction %.3f)\n",
                pvc_program(), 100 * (r / g - 1), b / (double)n);
    else if (ok)
        fprintf(stderr, "%s: cache error per hit: no scatter event was served yet\n", pvc_program());
    return ok;
}


/* ---- the JSON summary ----------------------------------------------------------------- */

typedef struct scattering_summary {
    picvr_scattering scattering;  /* as set: --bounces (else the preset's), --phase-back */
    float g;                      /* --g; NaN (null): the transfer function's own per point */
} scattering_summary;

typedef struct env_summary {
    const char *file;             /* --env; NULL: the --lights preset's background */
    float rotation_degrees, intensity;
} env_summary;

/* The "config" object: what the library resolved, then what picvr-render set besides
   (the scattering and the environment map are not part of picvr_config). */
typedef struct run_config {
    picvr_config library;
    scattering_summary scattering;
    env_summary environment;
} run_config;

/* What --json writes: the final statistics, the scene's names and the configuration
   the library resolved (picvr_get_config: every default filled in). */
/* --frames: the budget, the orbit and each frame; the largest hole count and the mean
   estimated error over the frames. */
typedef struct frames_summary {
    uint32_t count;
    double frame_ms;
    float orbit_deg;
    uint64_t pixels_unsampled_max;
    double est_rel_error_mean, ms_mean;
    pvc_json_array per_frame;
} frames_summary;

typedef struct summary {
    picvr_stats stats;
    run_config config;
    const char *device_type, *volume, *tf, *lights;
    uint32_t seed;
    frames_summary frames;
} summary;

#define CACHE(member) offsetof(picvr_cache_config, member)
static const pvc_json_field CACHE_FIELDS[] = {
    {"mode", PVC_JSON_CACHE_MODE, CACHE(mode)},
    {"gamma", PVC_JSON_F32, CACHE(gamma)},
    {"epsilon", PVC_JSON_F32, CACHE(epsilon)},
    {"delta_voxels", PVC_JSON_F32, CACHE(delta_voxels)},
    {"radius_min_voxels", PVC_JSON_F32, CACHE(radius_min_voxels)},
    {"radius_max_voxels", PVC_JSON_F32, CACHE(radius_max_voxels)},
    {"max_samples", PVC_JSON_U32, CACHE(max_samples)},
    {"update_threshold", PVC_JSON_F32, CACHE(update_threshold)},
    {"rebuild_interval_ms", PVC_JSON_F32, CACHE(rebuild_interval_ms)},
    {"superpixel_size", PVC_JSON_U32, CACHE(superpixel_size)},
    {"max_entries", PVC_JSON_U32, CACHE(max_entries)},
    {"max_nodes", PVC_JSON_U32, CACHE(max_nodes)},
    {"max_refs", PVC_JSON_U32, CACHE(max_refs)},
    {"max_requests", PVC_JSON_U32, CACHE(max_requests)},
    {"curvature_limit", PVC_JSON_SWITCH, CACHE(curvature_limit)},
    {"medium_model", PVC_JSON_SWITCH, CACHE(medium_model)},
    {"max_lookup_refs", PVC_JSON_U32, CACHE(max_lookup_refs)},
};
#undef CACHE

#define SCHEDULER(member) offsetof(picvr_scheduler_config, member)
static const pvc_json_field SCHEDULER_FIELDS[] = {
    {"create_min", PVC_JSON_F32, SCHEDULER(create_min)},
    {"create_max", PVC_JSON_F32, SCHEDULER(create_max)},
    {"update_min", PVC_JSON_F32, SCHEDULER(update_min)},
    {"update_max", PVC_JSON_F32, SCHEDULER(update_max)},
    {"exponent", PVC_JSON_F32, SCHEDULER(exponent)},
    {"rounds_per_second", PVC_JSON_F32, SCHEDULER(rounds_per_second)},
    {"hit_rate_window_ms", PVC_JSON_F32, SCHEDULER(hit_rate_window_ms)},
    {"priorities", PVC_JSON_SWITCH, SCHEDULER(priorities)},
    {"frames", PVC_JSON_SWITCH, SCHEDULER(frames)},
    {"temporal_reuse", PVC_JSON_SWITCH, SCHEDULER(temporal_reuse)},
    {"reuse_history", PVC_JSON_U32, SCHEDULER(reuse_history)},
};
#undef SCHEDULER

#define COUNT(table) (sizeof table / sizeof table[0])

#define FRAME(member) offsetof(render_frame, member)
static const pvc_json_field FRAME_FIELDS[] = {
    {"ms", PVC_JSON_F64, FRAME(ms)},
    {"pixels_unsampled", PVC_JSON_U64, FRAME(pixels_unsampled)},
    {"est_rel_error", PVC_JSON_F64, FRAME(est_rel_error)},
    {"samples_per_pixel", PVC_JSON_F64, FRAME(samples_per_pixel)},
};
#undef FRAME

#define FRAMES(member) offsetof(frames_summary, member)
static const pvc_json_field FRAMES_FIELDS[] = {
    {"count", PVC_JSON_U32, FRAMES(count)},
    {"frame_ms", PVC_JSON_F64, FRAMES(frame_ms)},
    {"orbit_degrees", PVC_JSON_F32, FRAMES(orbit_deg)},
    {"pixels_unsampled_max", PVC_JSON_U64, FRAMES(pixels_unsampled_max)},
    {"est_rel_error_mean", PVC_JSON_F64, FRAMES(est_rel_error_mean)},
    {"ms_mean", PVC_JSON_F64, FRAMES(ms_mean)},
    {"per_frame", PVC_JSON_ARRAY, FRAMES(per_frame), COUNT(FRAME_FIELDS), FRAME_FIELDS},
};
#undef FRAMES

#define SCATTERING(member) offsetof(scattering_summary, member)
static const pvc_json_field SCATTERING_FIELDS[] = {
    {"max_bounces", PVC_JSON_BOUNCES, SCATTERING(scattering.max_bounces)},
    {"back_g", PVC_JSON_F32, SCATTERING(scattering.back_g)},
    {"back_weight", PVC_JSON_F32, SCATTERING(scattering.back_weight)},
    {"g", PVC_JSON_F32, SCATTERING(g)},
};
#undef SCATTERING

#define ENV(member) offsetof(env_summary, member)
static const pvc_json_field ENV_FIELDS[] = {
    {"file", PVC_JSON_STRING, ENV(file)},
    {"rotation_degrees", PVC_JSON_F32, ENV(rotation_degrees)},
    {"intensity", PVC_JSON_F32, ENV(intensity)},
};
#undef ENV

/* The application's pointers (log, allocator, Vulkan handles) and the device name it
   asked for are left out: the device in use is the summary's device_name. */
#define CONFIG(member) offsetof(run_config, library.member)
static const pvc_json_field CONFIG_FIELDS[] = {
    {"seed", PVC_JSON_U32, CONFIG(seed)},
    {"validation", PVC_JSON_SWITCH, CONFIG(validation)},
    {"log_level", PVC_JSON_LOG_LEVEL, CONFIG(log_level)},
    {"distance_sampling", PVC_JSON_DISTANCE, CONFIG(distance_sampling)},
    {"transmittance", PVC_JSON_TRANSMITTANCE, CONFIG(transmittance)},
    {"cache", PVC_JSON_OBJECT, CONFIG(cache), COUNT(CACHE_FIELDS), CACHE_FIELDS},
    {"scheduler", PVC_JSON_OBJECT, CONFIG(scheduler), COUNT(SCHEDULER_FIELDS), SCHEDULER_FIELDS},
    {"scattering", PVC_JSON_OBJECT, offsetof(run_config, scattering), COUNT(SCATTERING_FIELDS),
     SCATTERING_FIELDS},
    {"environment", PVC_JSON_OBJECT, offsetof(run_config, environment), COUNT(ENV_FIELDS),
     ENV_FIELDS},
};
#undef CONFIG

/* The keys up to "config" are those of earlier versions, in their order; newer ones
   follow it. */
#define AT(member) offsetof(summary, member)
static const pvc_json_field SUMMARY_FIELDS[] = {
    {"iterations", PVC_JSON_U32, AT(stats.iterations)},
    {"iterations_min", PVC_JSON_U32, AT(stats.iterations_min)},
    {"iterations_mean", PVC_JSON_F64, AT(stats.iterations_mean)},
    {"elapsed_ms", PVC_JSON_F64, AT(stats.elapsed_ms)},
    {"samples_per_second", PVC_JSON_F64, AT(stats.samples_per_second)},
    {"est_error", PVC_JSON_F64, AT(stats.est_error)},
    {"est_rel_error", PVC_JSON_F64, AT(stats.est_rel_error)},
    {"mean_luminance", PVC_JSON_F64, AT(stats.mean_luminance)},
    {"truncated_paths", PVC_JSON_U64, AT(stats.truncated_paths)},
    {"validation_messages", PVC_JSON_U32, AT(stats.validation_messages)},
    {"validation_enabled", PVC_JSON_U32, AT(stats.validation_enabled)},
    {"width", PVC_JSON_U32, AT(stats.width)},
    {"height", PVC_JSON_U32, AT(stats.height)},
    {"device_name", PVC_JSON_CHARS, AT(stats.device_name), sizeof ((picvr_stats *)NULL)->device_name},
    {"device_type", PVC_JSON_STRING, AT(device_type)},
    {"volume", PVC_JSON_STRING, AT(volume)},
    {"tf", PVC_JSON_STRING, AT(tf)},
    {"lights", PVC_JSON_STRING, AT(lights)},
    {"cache_entries", PVC_JSON_U32, AT(stats.cache_entries)},
    {"cache_nodes", PVC_JSON_U32, AT(stats.cache_nodes)},
    {"cache_refs", PVC_JSON_U32, AT(stats.cache_refs)},
    {"cache_references", PVC_JSON_U32, AT(stats.cache_refs)},
    {"cache_full", PVC_JSON_U32, AT(stats.cache_full)},
    {"cache_requests", PVC_JSON_U32, AT(stats.cache_requests)},
    {"pending_requests", PVC_JSON_U32, AT(stats.cache_pending)},
    {"cache_bytes", PVC_JSON_U64, AT(stats.cache_bytes)},
    {"cache_entries_capped", PVC_JSON_U32, AT(stats.cache_entries_capped)},
    {"cache_samples", PVC_JSON_U64, AT(stats.cache_samples)},
    {"cache_samples_truncated", PVC_JSON_U64, AT(stats.cache_samples_truncated)},
    {"cache_lookups_cut", PVC_JSON_U64, AT(stats.cache_lookups_cut)},
    {"cache_lookups_spilled", PVC_JSON_U64, AT(stats.cache_lookups_spilled)},
    {"cache_refs_per_entry", PVC_JSON_F64, AT(stats.cache_refs_per_entry)},
    {"cache_hit_rate", PVC_JSON_F64, AT(stats.cache_hit_rate)},
    {"hit_rate", PVC_JSON_F64, AT(stats.cache_hit_rate)},
    {"cache_routed", PVC_JSON_F64, AT(stats.cache_routed)},
    {"cache_gain", PVC_JSON_F64, AT(stats.cache_gain)},
    {"auto_efficiency", PVC_JSON_F64, AT(stats.auto_efficiency)},
    {"auto_cached_share", PVC_JSON_F64, AT(stats.auto_cached_share)},
    {"forced_share", PVC_JSON_F64, AT(stats.forced_share)},
    {"forced_efficiency", PVC_JSON_F64, AT(stats.forced_efficiency)},
    {"field_builds", PVC_JSON_U32, AT(stats.field_builds)},
    {"field_passes", PVC_JSON_U32, AT(stats.field_passes)},
    {"field_change", PVC_JSON_F64, AT(stats.field_change)},
    {"field_build_ms", PVC_JSON_F64, AT(stats.field_build_ms)},
    {"field_bytes", PVC_JSON_U64, AT(stats.field_bytes)},
    {"kernel_ms_plain_track", PVC_JSON_F64, AT(stats.kernel_ms_plain[0])},
    {"kernel_ms_plain_shade", PVC_JSON_F64, AT(stats.kernel_ms_plain[2])},
    {"kernel_ms_cached_track", PVC_JSON_F64, AT(stats.kernel_ms_cached[0])},
    {"kernel_ms_cached_lookup", PVC_JSON_F64, AT(stats.kernel_ms_cached[1])},
    {"kernel_ms_cached_shade", PVC_JSON_F64, AT(stats.kernel_ms_cached[2])},
    {"fraction_render", PVC_JSON_F64, AT(stats.fraction_render)},
    {"fraction_create", PVC_JSON_F64, AT(stats.fraction_create)},
    {"fraction_update", PVC_JSON_F64, AT(stats.fraction_update)},
    {"target_create", PVC_JSON_F64, AT(stats.target_create)},
    {"target_update", PVC_JSON_F64, AT(stats.target_update)},
    {"priorities", PVC_JSON_SWITCH, AT(config.library.scheduler.priorities)},
    {"curvature_limit", PVC_JSON_SWITCH, AT(config.library.cache.curvature_limit)},
    {"medium_model", PVC_JSON_SWITCH, AT(config.library.cache.medium_model)},
    {"max_samples", PVC_JSON_U32, AT(stats.cache_max_samples)},
    {"seed", PVC_JSON_U32, AT(seed)},
    {"config", PVC_JSON_OBJECT, AT(config), COUNT(CONFIG_FIELDS), CONFIG_FIELDS},
    {"mean_path_length", PVC_JSON_F64, AT(stats.mean_path_length)},
    {"pixels_unsampled", PVC_JSON_U64, AT(stats.pixels_unsampled)},
    {"frames", PVC_JSON_OBJECT, AT(frames), COUNT(FRAMES_FIELDS), FRAMES_FIELDS},
};
#undef AT

/* The --frames part of the summary (all zero without --frames). */
static frames_summary summarize_frames(const render_options *o, const render_frames *frames)
{
    frames_summary f;
    memset(&f, 0, sizeof f);
    f.count = (uint32_t)frames->length;
    f.frame_ms = o->frames ? o->frame_ms : 0.0;
    f.orbit_deg = o->orbit_deg;
    f.per_frame.items = frames->items;
    f.per_frame.length = frames->length;
    f.per_frame.stride = sizeof(render_frame);
    size_t known = 0;
    for (size_t i = 0; i < frames->length; i++) {
        const render_frame *r = &frames->items[i];
        if (r->pixels_unsampled > f.pixels_unsampled_max) f.pixels_unsampled_max = r->pixels_unsampled;
        if (isfinite(r->est_rel_error)) {
            f.est_rel_error_mean += r->est_rel_error;
            known++;
        }
        f.ms_mean += r->ms / (double)frames->length;
    }
    /* the mean over the frames whose error is known; none: unknown (null) */
    f.est_rel_error_mean = known ? f.est_rel_error_mean / (double)known : NAN;
    return f;
}

int render_write_json(picvr_context *ctx, const render_options *o, const picvr_stats *stats,
                      const render_frames *frames)
{
    summary s = {*stats, {{0}}, picvr_device_type_string(stats->device_type), o->volume_path,
                 o->tf_name, o->lights_name, o->seed, summarize_frames(o, frames)};
    if (!pvc_check(picvr_get_config(ctx, &s.config.library), "picvr_get_config")) return 0;
    scattering_summary sc = {{o->bounces, o->phase_back[0], o->phase_back[1]},
                             o->have_g ? o->g : NAN};
    env_summary env = {o->env_path, o->env_rotate, o->env_intensity};
    s.config.scattering = sc;
    s.config.environment = env;
    FILE *f = fopen(o->json_path, "w");
    if (f) {
        pvc_json_write(f, &s, SUMMARY_FIELDS, COUNT(SUMMARY_FIELDS));
        fputc('\n', f);
    }
    if (!f || fclose(f) != 0) {
        pvc_fail("cannot write %s: %s", o->json_path, strerror(errno));
        return 0;
    }
    return 1;
}

/* ---- the summary line ------------------------------------------------------------------ */

static const char *base_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

void render_print_summary(const render_options *o, const picvr_stats *s, int interrupted)
{
    printf("%s: %ux%u, %u iterations in %.2f s (%.3g samples/s), est_rel_error %.4g, "
           "est_error %.4g, mean_luminance %.4g, device %.*s (%s)", base_name(o->volume_path),
           s->width, s->height, s->iterations, s->elapsed_ms / 1e3, s->samples_per_second,
           s->est_rel_error, s->est_error, s->mean_luminance,
           (int)sizeof s->device_name, s->device_name, picvr_device_type_string(s->device_type));
    if (s->mean_path_length > 0.0) printf(", mean path %.3g scatter events", s->mean_path_length);
    if (s->truncated_paths) printf(", %llu truncated paths",
                                   (unsigned long long)s->truncated_paths);
    if (s->validation_messages) printf(", %u validation messages", s->validation_messages);
    if (s->cache_entries)
        printf(", cache %u entries (%u capped before Eq. 5), %.2f refs/entry, hit rate %.3f%s, "
               "device time render/create/update %.3f/%.3f/%.3f (targets create %.3f, update %.3f)",
               s->cache_entries, s->cache_entries_capped,
               s->cache_refs_per_entry, s->cache_hit_rate, s->cache_full ? " (full)" : "",
               s->fraction_render, s->fraction_create, s->fraction_update, s->target_create, s->target_update);
    if (s->kernel_ms_cached[0] > 0)
        printf(", cached rounds' kernels track/lookup/shade %.3g/%.3g/%.3g ms per block",
               s->kernel_ms_cached[0], s->kernel_ms_cached[1], s->kernel_ms_cached[2]);
    if (s->kernel_ms_plain[0] > 0)
        printf(", plain rounds' kernels track/shade %.3g/%.3g ms per block", s->kernel_ms_plain[0],
               s->kernel_ms_plain[2]);
    if (s->cache_entries)
        printf(", blend routed %.3f, gain of a hit %.3f, cached share of time %.3f (efficiency %.2f)",
               s->cache_routed, s->cache_gain, s->auto_cached_share, s->auto_efficiency);
    if (s->forced_share > 0.0 || s->forced_efficiency > 0.0)
        printf(", forced point's share of time %.3f (efficiency %.3g)", s->forced_share, s->forced_efficiency);
    if (s->cache_samples_truncated)
        printf(", %llu of %llu creation samples with a truncated transmittance estimate (biased)",
               (unsigned long long)s->cache_samples_truncated, (unsigned long long)s->cache_samples);
    if (s->cache_lookups_cut)
        printf(", %llu lookups cut at the octree walk's bound (entries ignored)",
               (unsigned long long)s->cache_lookups_cut);
    if (interrupted) printf(", interrupted");
    printf("\n");
}
