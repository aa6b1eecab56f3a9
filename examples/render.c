/* render.c - picvr-render, the command-line renderer.
 *
 *   picvr-render --volume bonsai_256x256x256_uint8.raw.gz --tf ct-bonsai \
 *                --lights studio --time 20000 --out bonsai.png
 *
 * Loads a raw volume (volume_io), sets up a transfer function, lights and an orbit
 * camera from presets (presets), renders progressively for a time or an exact number
 * of iterations while showing the estimated error, and writes PNG / PFM images, a
 * per-round CSV log and a JSON summary.  `picvr-render --help` lists every option.
 *
 * Exit status: 0 success, 1 runtime error, 2 usage error, 130 interrupted (Ctrl-C
 * stops rendering early; the outputs are still written).
 */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <stb/stb_image_write.h>

#include "picvr.h"
#include "presets.h"
#include "volume_io.h"

#define PROGRAM "picvr-render"
#define EXIT_USAGE 2
#define EXIT_INTERRUPTED 130

typedef struct options {
    const char *volume_path;
    int have_dims, have_type, have_spacing, have_range, have_density, have_time;
    uint32_t dims[3];
    picvr_voxel_type type;
    float spacing[3];
    float range[2];
    const char *tf_name, *lights_name;
    float density;
    uint32_t width, height;
    double time_ms, round_ms;
    uint32_t iterations;       /* 0: render for time_ms instead */
    uint32_t seed;
    const char *device;
    int validation;
    picvr_cache_mode cache;
    picvr_switch priorities;
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
} options;

/* Progress display state; also the log callback's user data, so library messages
   do not get glued onto a half-drawn progress line. */
typedef struct progress {
    int enabled, tty, line_open;
    double start_ms, next_line_ms;
} progress;

static volatile sig_atomic_t interrupted = 0;

static void on_interrupt(int sig)
{
    (void)sig;
    interrupted = 1;
}

/* First Ctrl-C: finish the current round and write the outputs; a second one kills. */
static void install_interrupt_handler(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_interrupt;
    sa.sa_flags = SA_RESETHAND;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static void fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, PROGRAM ": error: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

/* ---- usage ------------------------------------------------------------------------- */

static void print_help(FILE *f)
{
    fprintf(f,
        "usage: " PROGRAM " --volume FILE [options]\n"
        "Progressive Monte-Carlo volume rendering with picvr.\n\n"
        "input\n"
        "  --volume FILE          raw volume NAME_XxYxZ_TYPE.raw[.gz] (required)\n"
        "  --dims X,Y,Z           voxel counts, if not in the file name\n"
        "  --type u8|u16|f32      voxel type, if not in the file name\n"
        "  --spacing X,Y,Z        world size of a voxel (default 1,1,1)\n"
        "  --range MIN,MAX        data values mapped to 0..1 (default: the type's range;\n"
        "                         the data's min..max for f32)\n"
        "look\n"
        "  --tf PRESET            transfer function (default ramp)\n"
        "  --density D            override the preset's density factor D (per world unit)\n"
        "  --lights PRESET        light set-up (default studio)\n"
        "  --camera AZ,EL,DIST    orbit around the box centre: azimuth and elevation in\n"
        "                         degrees, distance as a factor of the distance at which\n"
        "                         the box just fills the view (default %g,%g,%g)\n"
        "  --fov DEG              vertical field of view (default %g)\n"
        "  --exposure E           tone-mapping exposure for the PNG (default 1)\n"
        "rendering\n"
        "  --size WxH             image size (default 512x512)\n"
        "  --time MS              render for MS milliseconds (default 5000)\n"
        "  --iterations N         render exactly N iterations instead (deterministic)\n"
        "  --round MS             time per round between statistics (default 100)\n"
        "  --seed N               random seed (default 0)\n"
        "  --cache off|object|screen  irradiance cache: off (plain Monte Carlo, the default\n"
        "                         for now), object- or screen-space locking\n"
        "  --priorities on|off    render the blocks with the largest expected error\n"
        "                         reduction first (Eq. 12; default on)\n"
        "  --shares CMIN,CMAX,UMIN,UMAX  device-time shares of cache-entry creation and\n"
        "                         update at hit rate 1 and 0 (paper §6; default\n"
        "                         0.05,0.15,0.01,0.02)\n"
        "  --warm MS              fill the cache for MS milliseconds first, creation at a\n"
        "                         0.85 share (as while a scene loads), then restart the\n"
        "                         image at the --shares (needs --cache object|screen)\n"
        "  --turns FILE,ID        take turns round by round with a second picvr-render\n"
        "                         given the same FILE and the other ID (0 or 1), so that\n"
        "                         two builds compared side by side share the machine's\n"
        "                         drift; FILE must hold 0 before either starts\n"
        "  --curvature on|off     shrink cache entries where the field bends within Delta\n"
        "                         (lit faces, shadow edges): less bias, far lower hit rate\n"
        "                         (default off: the paper's Eq. 9, 10 radii alone)\n"
        "  --medium on|off        place an entry's change along its normal axis within the\n"
        "                         medium, flat beyond a face (default on; off: the paper's\n"
        "                         Eq. 6, 7 literally, darker lit faces)\n"
        "  --samples N            Eq. 5's cap: at most N MIS samples per point of a new\n"
        "                         entry, a multiple of 128 (default 768; at most 768 on\n"
        "                         lavapipe, 8192 on a GPU): lower creates entries faster,\n"
        "                         noisier\n"
        "  --cache-param N=V      a number of picvr_cache_config by its name: gamma,\n"
        "                         epsilon, delta_voxels, radius_min_voxels,\n"
        "                         radius_max_voxels, update_threshold (repeatable; default\n"
        "                         Table 1's).  delta_voxels=1 radius_max_voxels=4 cut a full\n"
        "                         cache's error 3x on the cloud (docs/cache.md)\n"
        "  --debug-view cache     show where the cache is: hits green, misses red, entry\n"
        "                         centres white (needs --cache object|screen)\n"
        "  --debug-view error     the cache's error where it is used: R the cached, G a\n"
        "                         plain estimate at the same scatter events (read it with\n"
        "                         --out-float); prints the error per hit\n"
        "  --device NAME          Vulkan device whose name contains NAME\n"
        "  --validation           enable the Khronos validation layer\n"
        "output\n"
        "  --out FILE.png         tone-mapped sRGB image\n"
        "  --alpha                keep the coverage as PNG alpha (default: opaque RGB)\n"
        "  --out-float FILE.pfm   linear radiance, PFM\n"
        "  --log FILE.csv         statistics after every round\n"
        "  --json FILE            final statistics as JSON\n"
        "  --quiet                no progress on stderr (the summary still goes to stdout)\n"
        "  --help                 this text\n",
        PVP_DEFAULT_AZIMUTH, PVP_DEFAULT_ELEVATION, PVP_DEFAULT_DISTANCE, PVP_DEFAULT_FOV);
    fprintf(f, "\ntransfer functions (--tf)\n");
    for (size_t i = 0; pvp_tf_name(i); i++)
        fprintf(f, "  %-12s %s\n", pvp_tf_name(i), pvp_tf_description(i));
    fprintf(f, "\nlights (--lights), placed around the camera's view of the volume\n");
    for (size_t i = 0; pvp_lights_name(i); i++)
        fprintf(f, "  %-12s %s\n", pvp_lights_name(i), pvp_lights_description(i));
    fprintf(f, "\nExit status: 0 ok, 1 error, 2 usage error, 130 interrupted (outputs written).\n");
}

/* ---- parsing of option values (strict: the whole text must be consumed) ----------- */

static int parse_u32(const char *text, uint32_t min, uint32_t max, uint32_t *out)
{
    if (!text || text[0] < '0' || text[0] > '9') return 0;  /* strtoul takes "-1" */
    char *end;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 10);
    if (errno || *end || v < min || v > max) return 0;
    *out = (uint32_t)v;
    return 1;
}

static int parse_double(const char *text, double *out)
{
    if (!text || !*text) return 0;
    char *end;
    errno = 0;
    double v = strtod(text, &end);
    if (errno || *end || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

static int parse_float(const char *text, float *out)
{
    double v;
    if (!parse_double(text, &v) || fabs(v) > 3.0e38) return 0;
    *out = (float)v;
    return 1;
}

/* Splits a copy of text (in buf) at `sep` into exactly n pieces. */
static int split(const char *text, char sep, int n, char *buf, size_t buf_size,
                 char **pieces)
{
    if (!text || strlen(text) >= buf_size) return 0;
    strcpy(buf, text);
    char *p = buf;
    for (int i = 0; i < n; i++) {
        char *next = strchr(p, sep);
        if ((i < n - 1) != (next != NULL)) return 0;  /* too few or too many */
        if (next) *next = '\0';
        pieces[i] = p;
        p = next ? next + 1 : p;
    }
    return 1;
}

/* Exactly n floats separated by commas. */
static int parse_float_list(const char *text, int n, float *out)
{
    char buf[256], *pieces[3];
    if (n > 3 || !split(text, ',', n, buf, sizeof buf, pieces)) return 0;
    for (int i = 0; i < n; i++)
        if (!parse_float(pieces[i], &out[i])) return 0;
    return 1;
}

static int parse_dims(const char *text, uint32_t dims[3])
{
    char buf[64], *pieces[3];
    return split(text, ',', 3, buf, sizeof buf, pieces) &&
           parse_u32(pieces[0], 1, PVIO_MAX_DIM, &dims[0]) &&
           parse_u32(pieces[1], 1, PVIO_MAX_DIM, &dims[1]) &&
           parse_u32(pieces[2], 1, PVIO_MAX_DIM, &dims[2]);
}

static int parse_size(const char *text, uint32_t *width, uint32_t *height)
{
    char buf[64], *pieces[2];
    return split(text, 'x', 2, buf, sizeof buf, pieces) &&
           parse_u32(pieces[0], 1, PICVR_MAX_IMAGE_SIZE, width) &&
           parse_u32(pieces[1], 1, PICVR_MAX_IMAGE_SIZE, height);
}

static int positive_all(const float *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!(v[i] > 0.0f)) return 0;
    return 1;
}

/* Applies one option with its value; returns 0 and prints why on a bad value. */
static int apply_option(options *o, const char *name, const char *value)
{
    int ok = 1;
    if (!strcmp(name, "volume")) {
        o->volume_path = value;
    } else if (!strcmp(name, "dims")) {
        ok = o->have_dims = parse_dims(value, o->dims);
    } else if (!strcmp(name, "type")) {
        ok = o->have_type = pvio_parse_type(value, &o->type) == PVIO_OK;
    } else if (!strcmp(name, "spacing")) {
        ok = o->have_spacing = parse_float_list(value, 3, o->spacing) &&
                               positive_all(o->spacing, 3);
    } else if (!strcmp(name, "range")) {
        ok = o->have_range = parse_float_list(value, 2, o->range) &&
                             o->range[0] < o->range[1];
    } else if (!strcmp(name, "tf")) {
        pvp_tf probe;
        o->tf_name = value;
        if (pvp_tf_preset(value, &probe) != PVP_OK) {
            fail("unknown --tf '%s'; presets:", value);
            for (size_t i = 0; pvp_tf_name(i); i++) fprintf(stderr, " %s", pvp_tf_name(i));
            fputc('\n', stderr);
            return 0;
        }
    } else if (!strcmp(name, "density")) {
        ok = o->have_density = parse_float(value, &o->density) && o->density >= 0.0f;
    } else if (!strcmp(name, "lights")) {
        o->lights_name = value;
        ok = 0;
        for (size_t i = 0; pvp_lights_name(i) && !ok; i++)
            ok = !strcmp(value, pvp_lights_name(i));
        if (!ok) {
            fail("unknown --lights '%s'; presets:", value);
            for (size_t i = 0; pvp_lights_name(i); i++)
                fprintf(stderr, " %s", pvp_lights_name(i));
            fputc('\n', stderr);
            return 0;
        }
    } else if (!strcmp(name, "size")) {
        ok = parse_size(value, &o->width, &o->height);
    } else if (!strcmp(name, "time")) {
        ok = o->have_time = parse_double(value, &o->time_ms) && o->time_ms > 0.0;
    } else if (!strcmp(name, "iterations")) {
        ok = parse_u32(value, 1, UINT32_MAX, &o->iterations);
    } else if (!strcmp(name, "round")) {
        ok = parse_double(value, &o->round_ms) && o->round_ms > 0.0;
    } else if (!strcmp(name, "seed")) {
        ok = parse_u32(value, 0, UINT32_MAX, &o->seed);
    } else if (!strcmp(name, "debug-view")) {
        o->debug_view = value;
        ok = !strcmp(value, "cache") || !strcmp(value, "error") || !strcmp(value, "image");
    } else if (!strcmp(name, "cache")) {
        if (!strcmp(value, "none") || !strcmp(value, "off")) o->cache = PICVR_CACHE_NONE;
        else if (!strcmp(value, "object")) o->cache = PICVR_CACHE_OBJECT_SPACE;
        else if (!strcmp(value, "screen")) o->cache = PICVR_CACHE_SCREEN_SPACE;
        else ok = 0;
    } else if (!strcmp(name, "warm")) {
        ok = parse_double(value, &o->warm_ms) && o->warm_ms > 0.0;
    } else if (!strcmp(name, "turns")) {
        const char *comma = strrchr(value, ',');
        size_t len = comma ? (size_t)(comma - value) : 0;
        ok = len > 0 && len < sizeof o->turns_path && (!strcmp(comma + 1, "0") || !strcmp(comma + 1, "1"));
        if (ok) {
            memcpy(o->turns_path, value, len);
            o->turns_path[len] = '\0';
            o->turns_id = (unsigned)(comma[1] - '0');
        }
    } else if (!strcmp(name, "shares")) {
        char tail;
        ok = sscanf(value, "%f,%f,%f,%f%c", &o->shares[0], &o->shares[1], &o->shares[2], &o->shares[3],
                    &tail) == 4;
        for (int k = 0; ok && k < 4; k++) ok = o->shares[k] > 0.0f && o->shares[k] < 1.0f;
    } else if (!strcmp(name, "priorities") || !strcmp(name, "curvature") || !strcmp(name, "medium")) {
        picvr_switch *sw = name[0] == 'p' ? &o->priorities : name[0] == 'c' ? &o->curvature : &o->medium;
        if (!strcmp(value, "on")) *sw = PICVR_SWITCH_ON;
        else if (!strcmp(value, "off")) *sw = PICVR_SWITCH_OFF;
        else ok = 0;
    } else if (!strcmp(name, "samples")) {
        ok = parse_u32(value, 1, PICVR_CACHE_MAX_SAMPLES, &o->max_samples);
    } else if (!strcmp(name, "cache-param")) {
        ok = pvp_cache_param_set(&o->params, value) == PVP_OK;
    } else if (!strcmp(name, "device")) {
        o->device = value;
    } else if (!strcmp(name, "exposure")) {
        ok = parse_float(value, &o->exposure) && o->exposure > 0.0f;
    } else if (!strcmp(name, "camera")) {
        float c[3];
        ok = parse_float_list(value, 3, c) && c[2] > 0.0f;
        if (ok) { o->azimuth = c[0]; o->elevation = c[1]; o->distance = c[2]; }
    } else if (!strcmp(name, "fov")) {
        ok = parse_float(value, &o->fov) && o->fov > 0.0f && o->fov <= 179.0f;
    } else if (!strcmp(name, "out")) {
        o->out_png = value;
    } else if (!strcmp(name, "out-float")) {
        o->out_pfm = value;
    } else if (!strcmp(name, "log")) {
        o->log_path = value;
    } else if (!strcmp(name, "json")) {
        o->json_path = value;
    }
    if (!ok) fail("bad value for --%s: '%s' (see --help)", name, value);
    return ok;
}

static const char *const flag_options[] = {"validation", "quiet", "alpha", "help", NULL};
static const char *const value_options[] = {
    "volume", "dims", "type", "spacing", "range", "tf", "density", "lights", "size",
    "time", "iterations", "round", "seed", "cache", "priorities", "curvature", "medium", "samples", "cache-param", "shares", "warm", "turns", "debug-view", "device", "exposure", "camera", "fov", "out",
    "out-float", "log", "json", NULL};

static int in_list(const char *const *list, const char *name, size_t len)
{
    for (; *list; list++)
        if (strlen(*list) == len && !strncmp(*list, name, len)) return 1;
    return 0;
}

static void set_defaults(options *o)
{
    memset(o, 0, sizeof *o);
    o->tf_name = "ramp";
    o->lights_name = "studio";
    o->width = o->height = 512;
    o->time_ms = 5000.0;
    o->round_ms = 100.0;
    o->exposure = 1.0f;
    o->azimuth = PVP_DEFAULT_AZIMUTH;
    o->elevation = PVP_DEFAULT_ELEVATION;
    o->distance = PVP_DEFAULT_DISTANCE;
    o->fov = PVP_DEFAULT_FOV;
}

/* Returns -1 to go on rendering, else the exit status (0 after --help, 2 on errors).
   Accepts "--name value" and "--name=value". */
static int parse_options(int argc, char **argv, options *o)
{
    set_defaults(o);
    for (int i = 1; i < argc; i++) {
        const char *arg = argv[i];
        if (strncmp(arg, "--", 2) != 0) {
            fail("unexpected argument '%s' (see --help)", arg);
            return EXIT_USAGE;
        }
        const char *name = arg + 2, *eq = strchr(name, '=');
        size_t len = eq ? (size_t)(eq - name) : strlen(name);
        if (in_list(flag_options, name, len) && !eq) {
            if (!strcmp(name, "help")) {
                print_help(stdout);
                return EXIT_SUCCESS;
            }
            if (!strcmp(name, "validation")) o->validation = 1;
            if (!strcmp(name, "quiet")) o->quiet = 1;
            if (!strcmp(name, "alpha")) o->png_alpha = 1;
            continue;
        }
        if (!in_list(value_options, name, len)) {
            fail("unknown option '%s' (see --help)", arg);
            return EXIT_USAGE;
        }
        const char *value = eq ? eq + 1 : (i + 1 < argc ? argv[++i] : NULL);
        if (!value) {
            fail("--%s needs a value (see --help)", name);
            return EXIT_USAGE;
        }
        char key[32];
        snprintf(key, sizeof key, "%.*s", (int)len, name);
        if (!apply_option(o, key, value)) return EXIT_USAGE;
    }
    if (!o->volume_path) {
        fail("--volume FILE is required (see --help)");
        return EXIT_USAGE;
    }
    if (o->have_time && o->iterations) {
        fail("give --time or --iterations, not both");
        return EXIT_USAGE;
    }
    if (o->warm_ms > 0.0 && o->cache != PICVR_CACHE_OBJECT_SPACE && o->cache != PICVR_CACHE_SCREEN_SPACE) {
        fail("--warm fills the cache: give --cache object or --cache screen");
        return EXIT_USAGE;
    }
    return -1;
}

/* ---- volume ---------------------------------------------------------------------------- */

/* Layout from --dims/--type where given, the rest from the file name. */
static int resolve_layout(const options *o, pvio_layout *layout)
{
    char err[512];
    if (!(o->have_dims && o->have_type)) {
        if (pvio_parse_name(o->volume_path, layout, err, sizeof err) != PVIO_OK) {
            fail("%s", err);
            return 0;
        }
    }
    if (o->have_dims) memcpy(layout->dims, o->dims, sizeof layout->dims);
    if (o->have_type) layout->type = o->type;
    if (pvio_layout_bytes(layout, NULL, err, sizeof err) != PVIO_OK) {
        fail("%s", err);
        return 0;
    }
    return 1;
}

static const char *base_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

/* ---- progress and logging ------------------------------------------------------------- */

static void end_progress_line(progress *p)
{
    if (p->line_open) fputs("\r\033[K", stderr);
    p->line_open = 0;
}

static void log_message(picvr_log_level level, const char *message, void *user)
{
    static const char *const names[] = {"default", "debug", "info", "warning", "error"};
    end_progress_line(user);
    fprintf(stderr, "picvr %s: %s\n", level <= PICVR_LOG_ERROR ? names[level] : "?",
            message);
}

/* A redrawn bar on a terminal; otherwise about one line per second, so a captured
   log shows the error against time. */
static void show_progress(progress *p, double fraction, const picvr_stats *s)
{
    if (!p->enabled) return;
    double t = now_ms();
    double elapsed = (t - p->start_ms) / 1e3;
    if (p->tty) {
        char bar[31];
        int filled = (int)(fraction * 30.0 + 0.5);
        for (int i = 0; i < 30; i++) bar[i] = i < filled ? '#' : '.';
        bar[30] = '\0';
        fprintf(stderr, "\r%3.0f%% [%s] %6.1f s  %7u it  rel.err %.4f\033[K",
                fraction * 100.0, bar, elapsed, s->iterations, s->est_rel_error);
        p->line_open = 1;
    } else if (t >= p->next_line_ms) {
        fprintf(stderr, PROGRAM ": %7.1f s  %7u iterations  est_error %.5g  "
                "est_rel_error %.5g\n", elapsed, s->iterations, s->est_error,
                s->est_rel_error);
        p->next_line_ms = t + 1000.0;
    }
    fflush(stderr);
}

static int write_log_row(FILE *log, unsigned round, const picvr_stats *s)
{
    if (!log) return 1;
    fprintf(log, "%u,%.3f,%u,%.9g,%.9g,%.9g,%.9g,%u,%u,%.4f,%.4f,%.4f,%.4f,%.4f,%u\n", round,
            s->elapsed_ms, s->iterations, s->est_error, s->est_rel_error, s->samples_per_second,
            s->cache_hit_rate, s->cache_entries, s->cache_refs, s->fraction_render,
            s->fraction_create, s->fraction_update, s->target_create, s->target_update,
            s->cache_entries_capped);
    /* Flushed per row so `tail -f` works and a crash keeps what was measured. */
    return fflush(log) == 0;
}

/* ---- checked picvr calls ---------------------------------------------------------------- */

static int check(picvr_status st, const char *what)
{
    if (st == PICVR_OK) return 1;
    fail("%s: %s", what, picvr_status_string(st));
    return 0;
}

/* ---- rendering ------------------------------------------------------------------------ */

/* --turns FILE,ID: two picvr-render processes (two builds, say) render in turns, one
   round each, so that the drift of a shared machine falls on both alike and their
   iterations per second of rendering time make a paired ratio.  FILE holds a counter:
   ID 0 renders while it is even, ID 1 while it is odd; only the process whose turn it
   is writes it (a new file renamed over it, which is atomic).  A partner that has not
   passed the turn for 30 s has finished (or died): the process goes on alone. */
typedef struct turns {
    const char *path;        /* NULL: no turns */
    unsigned id;
    int alone;
    long seen;               /* the counter turn_wait last read: turn_pass writes seen + 1 */
} turns;

static long read_turn(const char *path)
{
    long v = -1;
    FILE *f = fopen(path, "r");
    if (f) {
        if (fscanf(f, "%ld", &v) != 1) v = -1;
        fclose(f);
    }
    return v;
}

static void turn_wait(turns *t)
{
    if (!t->path || t->alone) return;
    double start = now_ms();
    for (;;) {
        long v = read_turn(t->path);
        if (v >= 0 && (unsigned long)v % 2 == t->id) {
            t->seen = v;
            return;
        }
        if (now_ms() - start > 30000.0) {
            fprintf(stderr, "picvr-render: --turns: no turn for 30 s, going on alone\n");
            t->alone = 1;
            return;
        }
        struct timespec ms = {0, 1000000};
        nanosleep(&ms, NULL);
    }
}

static void turn_pass(turns *t)
{
    if (!t->path || t->alone) return;
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s.%u", t->path, t->id);
    FILE *f = fopen(tmp, "w");
    int ok = f && fprintf(f, "%ld\n", t->seen + 1) > 0;
    if (f && fclose(f) != 0) ok = 0;
    if (!ok || rename(tmp, t->path) != 0) {
        fprintf(stderr, "picvr-render: --turns: cannot write %s (%s), going on alone\n", t->path, strerror(errno));
        t->alone = 1;
    }
}

typedef struct render_state {
    picvr_context *ctx;
    FILE *log;
    progress *progress;
    unsigned round;
    picvr_stats stats;
    turns turns;
} render_state;

/* Statistics, the CSV row and the progress display after one round. */
static int finish_round(render_state *r, double fraction)
{
    if (!check(picvr_get_stats(r->ctx, &r->stats), "picvr_get_stats")) return 0;
    r->round++;
    if (!write_log_row(r->log, r->round, &r->stats)) {
        fail("writing the log: %s", strerror(errno));
        return 0;
    }
    show_progress(r->progress, fraction, &r->stats);
    return 1;
}

/* Rounds of picvr_step() until time_ms of rendering (time inside picvr_step). */
static int render_for_time(render_state *r, double time_ms, double round_ms)
{
    double rendered = 0.0;
    while (rendered < time_ms && !interrupted) {
        double want = time_ms - rendered < round_ms ? time_ms - rendered : round_ms;
        turn_wait(&r->turns);
        double t0 = now_ms();
        if (!check(picvr_step(r->ctx, want), "picvr_step")) return 0;
        rendered += now_ms() - t0;
        if (!finish_round(r, rendered >= time_ms ? 1.0 : rendered / time_ms)) return 0;
        turn_pass(&r->turns);
    }
    return 1;
}

/* Fills the cache for o->warm_ms at PVP_WARM_CREATE_SHARE, then switches to the shares of
   `run` and restarts the image: picvr_set_scheduler and picvr_reset keep the cache. */
static int warm_up(render_state *r, const options *o, const picvr_scheduler_config *run)
{
    picvr_scheduler_config warm = *run;
    warm.create_min = warm.create_max = PVP_WARM_CREATE_SHARE;
    warm.update_min = warm.update_max = 0.02f;
    if (!check(picvr_set_scheduler(r->ctx, &warm), "picvr_set_scheduler")) return 0;
    double done = 0.0;
    while (done < o->warm_ms && !interrupted) {
        double want = o->warm_ms - done < o->round_ms ? o->warm_ms - done : o->round_ms;
        turn_wait(&r->turns);
        double t0 = now_ms();
        if (!check(picvr_step(r->ctx, want), "picvr_step")) return 0;
        done += now_ms() - t0;
        turn_pass(&r->turns);
    }
    picvr_stats st;
    if (!check(picvr_get_stats(r->ctx, &st), "picvr_get_stats")) return 0;
    end_progress_line(r->progress);
    if (!o->quiet)
        fprintf(stderr, "picvr-render: warm-up %.1f s: %u cache entries, hit rate %.3f\n", done / 1e3,
                st.cache_entries, st.cache_hit_rate);
    return check(picvr_set_scheduler(r->ctx, run), "picvr_set_scheduler") &&
           check(picvr_reset(r->ctx), "picvr_reset");
}

/* Exactly `total` iterations, in chunks sized to take about round_ms each (the same
   seed and iteration count give the same image however they are chunked). */
static int render_iterations(render_state *r, uint32_t total, double round_ms)
{
    uint32_t done = 0, chunk = 1;
    while (done < total && !interrupted) {
        uint32_t n = total - done < chunk ? total - done : chunk;
        double t0 = now_ms();
        if (!check(picvr_step_iterations(r->ctx, n), "picvr_step_iterations")) return 0;
        double per_iteration = (now_ms() - t0) / n;
        done += n;
        if (!finish_round(r, (double)done / total)) return 0;
        /* Grow at most 4x per round so one fast measurement cannot overshoot. */
        double ideal = per_iteration > 0.0 ? round_ms / per_iteration : 4.0 * chunk;
        double limit = 4.0 * chunk;
        chunk = (uint32_t)(ideal < 1.0 ? 1.0 : ideal > limit ? limit : ideal);
    }
    return 1;
}

/* ---- outputs -------------------------------------------------------------------------- */

static int write_png(picvr_context *ctx, const options *o)
{
    size_t size = (size_t)o->width * o->height * 4;
    uint8_t *px = malloc(size);
    if (!px) {
        fail("out of memory for the image");
        return 0;
    }
    int ok = check(picvr_read_rgba8(ctx, px, size, o->exposure), "picvr_read_rgba8");
    int comp = o->png_alpha ? 4 : 3;
    if (ok && comp == 3) /* drop alpha in place: viewers would hide the background */
        for (size_t i = 0, n = (size_t)o->width * o->height; i < n; i++)
            memmove(px + 3 * i, px + 4 * i, 3);
    if (ok && !stbi_write_png(o->out_png, (int)o->width, (int)o->height, comp, px,
                              (int)o->width * comp)) {
        fail("cannot write %s", o->out_png);
        ok = 0;
    }
    free(px);
    return ok;
}

static void float_to_le(float v, unsigned char out[4])
{
    uint32_t u;
    memcpy(&u, &v, 4);
    for (int i = 0; i < 4; i++) out[i] = (unsigned char)(u >> (8 * i));
}

/* PFM: "PF", size, scale -1 (little-endian), RGB rows from the bottom up. */
static int write_pfm_file(const char *path, const float *rgba, uint32_t w, uint32_t h)
{
    FILE *f = fopen(path, "wb");
    unsigned char *row = malloc((size_t)w * 12);
    int ok = f && row && fprintf(f, "PF\n%u %u\n-1.0\n", w, h) > 0;
    for (uint32_t y = h; ok && y-- > 0;) {
        const float *src = rgba + (size_t)y * w * 4;
        for (uint32_t x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) float_to_le(src[4 * x + c], row + 12 * x + 4 * c);
        ok = fwrite(row, 12, w, f) == w;
    }
    if (f && fclose(f) != 0) ok = 0;
    free(row);
    if (!ok) fail("cannot write %s: %s", path, strerror(errno));
    return ok;
}

/* The linear RGBA float image (malloc'd; NULL after a reported failure). */
static float *read_float_image(picvr_context *ctx, const options *o)
{
    size_t size = (size_t)o->width * o->height * 16;
    float *px = malloc(size);
    if (!px) {
        fail("out of memory for the float image");
        return NULL;
    }
    if (!check(picvr_read_rgba32f(ctx, px, size), "picvr_read_rgba32f")) {
        free(px);
        return NULL;
    }
    return px;
}

static int write_pfm(picvr_context *ctx, const options *o)
{
    float *px = read_float_image(ctx, o);
    int ok = px && write_pfm_file(o->out_pfm, px, o->width, o->height);
    free(px);
    return ok;
}

/* --debug-view error: sum R / sum G - 1 over the image (picvr.h, PICVR_VIEW_CACHE_ERROR). */
static int print_cache_error(picvr_context *ctx, const options *o)
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
        fprintf(stderr, "picvr-render: cache error per hit %+.2f %% (mean served fraction %.3f)\n",
                100 * (r / g - 1), b / (double)n);
    else if (ok)
        fprintf(stderr, "picvr-render: cache error per hit: no scatter event was served yet\n");
    return ok;
}

static void json_string(FILE *f, const char *s)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\') fprintf(f, "\\%c", *p);
        else if (*p < 0x20) fprintf(f, "\\u%04x", *p);
        else fputc(*p, f);
    }
    fputc('"', f);
}

/* JSON has no NaN or infinity. */
static void json_number(FILE *f, double v)
{
    if (isfinite(v)) fprintf(f, "%.9g", v);
    else fputs("null", f);
}

static int write_json(const options *o, const picvr_stats *s)
{
    FILE *f = fopen(o->json_path, "w");
    if (!f) {
        fail("cannot write %s: %s", o->json_path, strerror(errno));
        return 0;
    }
    fprintf(f, "{\"iterations\": %u, \"iterations_min\": %u, \"iterations_mean\": ",
            s->iterations, s->iterations_min);
    json_number(f, s->iterations_mean);
    fputs(", \"elapsed_ms\": ", f);
    json_number(f, s->elapsed_ms);
    fputs(", \"samples_per_second\": ", f);
    json_number(f, s->samples_per_second);
    fputs(", \"est_error\": ", f);
    json_number(f, s->est_error);
    fputs(", \"est_rel_error\": ", f);
    json_number(f, s->est_rel_error);
    fputs(", \"mean_luminance\": ", f);
    json_number(f, s->mean_luminance);
    fprintf(f, ", \"truncated_paths\": %llu, \"validation_messages\": %u, "
            "\"validation_enabled\": %u, \"width\": %u, \"height\": %u, "
            "\"device_name\": ", (unsigned long long)s->truncated_paths,
            s->validation_messages, s->validation_enabled, s->width, s->height);
    char device[sizeof s->device_name + 1];
    snprintf(device, sizeof device, "%.*s", (int)sizeof s->device_name, s->device_name);
    json_string(f, device);
    fputs(", \"device_type\": ", f);
    json_string(f, picvr_device_type_string(s->device_type));
    fputs(", \"volume\": ", f);
    json_string(f, o->volume_path);
    fputs(", \"tf\": ", f);
    json_string(f, o->tf_name);
    fputs(", \"lights\": ", f);
    json_string(f, o->lights_name);
    fprintf(f, ", \"cache_entries\": %u, \"cache_nodes\": %u, \"cache_refs\": %u, "
            "\"cache_references\": %u, \"cache_full\": %u, \"cache_requests\": %u, "
            "\"pending_requests\": %u, \"cache_bytes\": %llu, \"cache_entries_capped\": %u, "
            "\"cache_samples\": %llu, \"cache_samples_truncated\": %llu, \"cache_lookups_cut\": %llu, "
            "\"cache_lookups_spilled\": %llu, \"cache_refs_per_entry\": ",
            s->cache_entries, s->cache_nodes, s->cache_refs, s->cache_refs, s->cache_full,
            s->cache_requests, s->cache_pending, (unsigned long long)s->cache_bytes,
            s->cache_entries_capped, (unsigned long long)s->cache_samples,
            (unsigned long long)s->cache_samples_truncated, (unsigned long long)s->cache_lookups_cut,
            (unsigned long long)s->cache_lookups_spilled);
    json_number(f, s->cache_refs_per_entry);
    fputs(", \"cache_hit_rate\": ", f);
    json_number(f, s->cache_hit_rate);
    fputs(", \"hit_rate\": ", f);
    json_number(f, s->cache_hit_rate);
    const char *shares[5] = {"fraction_render", "fraction_create", "fraction_update", "target_create", "target_update"};
    const double share[5] = {s->fraction_render, s->fraction_create, s->fraction_update, s->target_create, s->target_update};
    for (int i = 0; i < 5; i++) {
        fprintf(f, ", \"%s\": ", shares[i]);
        json_number(f, share[i]);
    }
    fprintf(f, ", \"priorities\": \"%s\"", o->priorities == PICVR_SWITCH_OFF ? "off" : "on");
    fprintf(f, ", \"curvature_limit\": \"%s\"", o->curvature == PICVR_SWITCH_ON ? "on" : "off");
    fprintf(f, ", \"medium_model\": \"%s\"", o->medium == PICVR_SWITCH_OFF ? "off" : "on");
    fprintf(f, ", \"max_samples\": %u", s->cache_max_samples);
    for (size_t i = 0; pvp_cache_param_name(i); i++)   /* those set by --cache-param */
        if (pvp_cache_param_get(&o->params, i) > 0)
            fprintf(f, ", \"%s\": %.9g", pvp_cache_param_name(i), pvp_cache_param_get(&o->params, i));
    fprintf(f, ", \"seed\": %u}\n", o->seed);
    if (fclose(f) != 0) {
        fail("cannot write %s: %s", o->json_path, strerror(errno));
        return 0;
    }
    return 1;
}

static void print_summary(const options *o, const picvr_stats *s)
{
    printf("%s: %ux%u, %u iterations in %.2f s (%.3g samples/s), est_rel_error %.4g, "
           "est_error %.4g, mean_luminance %.4g, device %.*s (%s)", base_name(o->volume_path),
           s->width, s->height, s->iterations, s->elapsed_ms / 1e3, s->samples_per_second,
           s->est_rel_error, s->est_error, s->mean_luminance,
           (int)sizeof s->device_name, s->device_name, picvr_device_type_string(s->device_type));
    if (s->truncated_paths) printf(", %llu truncated paths",
                                   (unsigned long long)s->truncated_paths);
    if (s->validation_messages) printf(", %u validation messages", s->validation_messages);
    if (s->cache_entries)
        printf(", cache %u entries (%u capped before Eq. 5), %.2f refs/entry, hit rate %.3f%s, "
               "device time render/create/update %.3f/%.3f/%.3f (targets create %.3f, update %.3f)",
               s->cache_entries, s->cache_entries_capped,
               s->cache_refs_per_entry, s->cache_hit_rate, s->cache_full ? " (full)" : "",
               s->fraction_render, s->fraction_create, s->fraction_update, s->target_create, s->target_update);
    if (s->cache_samples_truncated)
        printf(", %llu of %llu creation samples with a truncated transmittance estimate (biased)",
               (unsigned long long)s->cache_samples_truncated, (unsigned long long)s->cache_samples);
    if (s->cache_lookups_cut)
        printf(", %llu lookups cut at the octree walk's bound (entries ignored)",
               (unsigned long long)s->cache_lookups_cut);
    if (interrupted) printf(", interrupted");
    printf("\n");
}

/* ---- scene set-up ----------------------------------------------------------------------- */

/* Loads the volume file into host memory, with --spacing applied. */
static int load_volume(const options *o, const pvio_layout *layout, pvio_volume *vol)
{
    char err[512];
    if (pvio_load(o->volume_path, layout, vol, err, sizeof err) != PVIO_OK) {
        fail("%s", err);
        return 0;
    }
    if (o->have_spacing) memcpy(vol->spacing, o->spacing, sizeof vol->spacing);
    return 1;
}

static int upload_volume(picvr_context *ctx, const options *o, const pvio_volume *vol)
{
    picvr_volume_desc desc;
    pvio_to_desc(vol, &desc);
    if (o->have_range) {
        desc.value_min = o->range[0];
        desc.value_max = o->range[1];
    }
    return check(picvr_upload_volume(ctx, &desc), "picvr_upload_volume");
}

/* Camera from the orbit parameters, then the presets built around the volume's box. */
static int set_up_scene(picvr_context *ctx, const options *o)
{
    float box_min[3], box_max[3];
    if (!check(picvr_volume_box(ctx, box_min, box_max), "picvr_volume_box")) return 0;

    picvr_camera cam;
    pvp_status ps = pvp_orbit_camera(box_min, box_max, o->azimuth, o->elevation,
                                     o->distance, o->fov, o->width, o->height, &cam);
    if (ps != PVP_OK) {
        fail("camera: %s", pvp_status_string(ps));
        return 0;
    }
    if (!check(picvr_set_camera(ctx, &cam), "picvr_set_camera")) return 0;
    if (o->debug_view && !strcmp(o->debug_view, "cache") &&
        !check(picvr_set_view(ctx, PICVR_VIEW_CACHE), "picvr_set_view")) return 0;
    if (o->debug_view && !strcmp(o->debug_view, "error") &&
        !check(picvr_set_view(ctx, PICVR_VIEW_CACHE_ERROR), "picvr_set_view")) return 0;

    pvp_tf tf;
    if ((ps = pvp_tf_preset(o->tf_name, &tf)) != PVP_OK) {
        fail("--tf %s: %s", o->tf_name, pvp_status_string(ps));
        return 0;
    }
    float density = o->have_density ? o->density : tf.density;
    if (!check(picvr_set_transfer_function(ctx, tf.points, tf.count, density),
               "picvr_set_transfer_function"))
        return 0;

    pvp_lights lights;
    if ((ps = pvp_lights_preset(o->lights_name, box_min, box_max, &cam,
                                &lights)) != PVP_OK) {
        fail("--lights %s: %s", o->lights_name, pvp_status_string(ps));
        return 0;
    }
    return check(picvr_set_lights(ctx, lights.lights, lights.count, &lights.background),
                 "picvr_set_lights");
}

/* ---- main ------------------------------------------------------------------------------- */

static int render(const options *o, const pvio_layout *layout)
{
    progress prog = {0};
    prog.enabled = !o->quiet;
    prog.tty = isatty(STDERR_FILENO);

    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.device_name = o->device;
    cfg.validation = o->validation ? PICVR_SWITCH_ON : PICVR_SWITCH_DEFAULT;
    cfg.cache = o->params;                     /* --cache-param; the rest below */
    cfg.cache.mode = o->cache;
    cfg.scheduler.priorities = o->priorities;
    cfg.cache.curvature_limit = o->curvature;
    cfg.cache.medium_model = o->medium;
    cfg.cache.max_samples = o->max_samples;
    cfg.scheduler.create_min = o->shares[0];   /* 0 (not given): the defaults */
    cfg.scheduler.create_max = o->shares[1];
    cfg.scheduler.update_min = o->shares[2];
    cfg.scheduler.update_max = o->shares[3];
    cfg.seed = o->seed;
    cfg.log = log_message;
    cfg.log_user = &prog;

    render_state r;
    memset(&r, 0, sizeof r);
    r.progress = &prog;
    r.turns.path = o->turns_path[0] ? o->turns_path : NULL;
    r.turns.id = o->turns_id;
    int ok = 1;
    if (o->log_path) {
        r.log = fopen(o->log_path, "w");
        ok = r.log && fputs("round,elapsed_ms,iterations,est_error,est_rel_error,"
                            "samples_per_second,hit_rate,cache_entries,cache_refs,fraction_render,"
                            "fraction_create,fraction_update,target_create,target_update,"
                            "cache_entries_capped\n", r.log) >= 0;
        if (!ok) fail("cannot write %s: %s", o->log_path, strerror(errno));
    }
    /* The file first: a bad file should not cost a Vulkan start-up.  The host copy
       is freed right after the upload (picvr keeps its own). */
    pvio_volume vol = {{0, 0, 0}, PICVR_VOXEL_UINT8, {0, 0, 0}, NULL, 0};
    ok = ok && load_volume(o, layout, &vol);
    ok = ok && check(picvr_create(&cfg, &r.ctx), "picvr_create");
    ok = ok && upload_volume(r.ctx, o, &vol);
    pvio_free(&vol);
    ok = ok && set_up_scene(r.ctx, o);
    if (ok) {
        install_interrupt_handler();
        if (o->warm_ms > 0.0) ok = warm_up(&r, o, &cfg.scheduler);
        prog.start_ms = prog.next_line_ms = now_ms();
        ok = ok && (o->iterations ? render_iterations(&r, o->iterations, o->round_ms)
                                 : render_for_time(&r, o->time_ms, o->round_ms));
        end_progress_line(&prog);
    }
    ok = ok && (!o->out_png || write_png(r.ctx, o));
    ok = ok && (!o->out_pfm || write_pfm(r.ctx, o));
    ok = ok && (!o->debug_view || strcmp(o->debug_view, "error") || print_cache_error(r.ctx, o));
    ok = ok && (!o->json_path || write_json(o, &r.stats));
    if (ok) print_summary(o, &r.stats);

    if (r.log && fclose(r.log) != 0 && ok) {
        fail("cannot write %s: %s", o->log_path, strerror(errno));
        ok = 0;
    }
    picvr_destroy(r.ctx);
    if (!ok) return EXIT_FAILURE;
    return interrupted ? EXIT_INTERRUPTED : EXIT_SUCCESS;
}

int main(int argc, char **argv)
{
    options o;
    int status = parse_options(argc, argv, &o);
    if (status >= 0) return status;
    pvio_layout layout;
    if (!resolve_layout(&o, &layout)) return EXIT_USAGE;
    return render(&o, &layout);
}
