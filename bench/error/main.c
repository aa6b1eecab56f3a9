/* bench_error.c - picvr-bench-error: error against run time (issue 5; paper §8,
 * Table 2, Table 3, Fig. 10, Fig. 11).
 *
 *   picvr-bench-error [--scenes bench/scenes.txt] [--data ../shared/data]
 *       [--datasets bonsai,engine] [--lights paper1,paper3-bg] [--size 128x128]
 *       [--conditions plain,object,object-noprio,screen,screen-noprio]
 *       [--time MS] [--slice MS] [--repeats N] [--rotate MS] [--after MS]
 *       [--ref-chunk MS] [--ref-max-chunks N] [--bias bonsai] [--fig10 bonsai]
 *       [--out bench/results] [--refs bench/refs]
 *
 * For every dataset x light set-up of the matrix ("scene"):
 *  1. a reference: plain Monte Carlo (cache off, priorities off), rendered as
 *     independent chunks with seeds 1001, 1002, ... and stored as PFM files in
 *     REFS/<hash>/ where the hash is FNV-1a of the scene description (data file, TF,
 *     spacing, lights, size, camera; not the seed) and of the plain renderer's
 *     fingerprint (plain_fingerprint: a short deterministic render of the scene,
 *     hashed bit for bit).  The reference is the iteration-weighted mean of the
 *     chunks; its own per-pixel error is estimated from the spread between chunks
 *     (at least 4).  A reference whose RMSE (and
 *     relative RMSE) is not at least 10x below the smallest error measured against it
 *     is grown (more chunks, then the runs are repeated against it) or, beyond
 *     --ref-max-chunks, refused: the scene is left out of the tables (exit status 3).
 *  2. runs: per condition and repeat (seed 101 + repeat), a fresh context (empty
 *     cache) rendered with picvr_step in slices; after each slice the time spent in
 *     picvr_step (wall clock), the true RMSE and relative RMSE of the luminance
 *     against the reference, the paper's estimate (stats.est_error, est_rel_error),
 *     hit rate, entries and references are recorded in OUT/runs/<hash>_<cond>_rN.csv.
 *     Finished run files are reused (resumable) as long as the reference is the same.
 *  3. outputs in OUT: table2.csv/.md (plain error / cached error averaged over the
 *     run at equal time, per repeat pair, mean with min and max), table3.csv/.md
 *     (entries and references, object-space locking), fig11_<scene>.csv/.dat/.gp
 *     (error against time, all conditions), fig10_<scene>.* (camera turns 360
 *     degrees in --rotate ms, then stops; plain against object-space cache),
 *     bias.csv/.md (mean of the final images of independent seeds against the
 *     reference: bias split from variance).  The .gp files are gnuplot scripts that
 *     write the PNGs (make bench runs them).
 *
 * Error measures.  Luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of the linear image
 * (picvr_read_rgba32f).  RMSE = sqrt(mean_p (Y_p - Yref_p)^2); relative RMSE =
 * sqrt(mean_p ((Y_p - Yref_p) / (Yref_p + 0.01 mean(Yref)))^2), all pixels.
 *
 * Exit status: 0 ok, 1 runtime error, 2 usage error, 3 a reference was refused.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "picvr.h"
#include "presets.h"
#include "volume_io.h"

#define PROGRAM "picvr-bench-error"
#define EXIT_USAGE 2
#define EXIT_REFUSED 3
#define MAX_DATASETS 16
#define MAX_LIGHTS 16
#define MAX_REPEATS 32
#define NAME_LEN 64
#define PATH_LEN 1024
#define REF_FACTOR 10.0        /* reference error at least this far below */
#define REF_MIN_CHUNKS 4
#define REF_SEED0 1001u
#define FINGERPRINT_SEED 7u          /* plain_fingerprint: a seed no chunk or run uses */
#define FINGERPRINT_ITERATIONS 4u
#define RUN_SEED0 101u
#define FLOOR_FRACTION 1e-2    /* relative error floor, fraction of the mean */
#define GRID_POINTS 200        /* equal-time grid of the ratio average */
#define REF_ROUNDS 3           /* grow-the-reference attempts per scene */
/* The library's sources this binary was built from (the Makefile passes a checksum of
   picvr.h, picvr_vk.c and shaders/): part of every run file's signature, so that a
   finished run is never reused by a build whose cache or scheduler behaves otherwise. */
#ifndef PICVR_BENCH_BUILD
#define PICVR_BENCH_BUILD "unknown"
#endif

/* ---- small utilities ---------------------------------------------------------------- */

static void fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, PROGRAM ": error: ");
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

static int check(picvr_status s, const char *what)
{
    if (s == PICVR_OK) return 1;
    fail("%s: %s", what, picvr_status_string(s));
    return 0;
}

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static int make_dirs(const char *path)
{
    char buf[PATH_LEN];
    snprintf(buf, sizeof buf, "%s", path);
    for (char *p = buf + 1; *p; p++) {
        if (*p != '/') continue;
        *p = 0;
        if (mkdir(buf, 0755) != 0 && errno != EEXIST) return 0;
        *p = '/';
    }
    return mkdir(buf, 0755) == 0 || errno == EEXIST;
}

static int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static uint64_t fnv1a_bytes(const void *data, size_t size)
{
    const unsigned char *p = data;
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < size; i++) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

static uint64_t fnv1a(const char *s) { return fnv1a_bytes(s, strlen(s)); }

/* Whether `name` is in the comma-separated list (NULL list: everything is). */
static int in_list(const char *list, const char *name)
{
    if (!list) return 1;
    size_t n = strlen(name);
    for (const char *p = list; *p;) {
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        if (len == n && !strncmp(p, name, n)) return 1;
        if (!e) break;
        p = e + 1;
    }
    return 0;
}

static double luminance(const float *rgb)
{
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

/* ---- options ---------------------------------------------------------------------------- */

typedef struct options {
    const char *scenes_path, *data_dir, *out_dir, *refs_dir;
    const char *datasets, *lights, *conditions, *bias, *fig10;
    uint32_t width, height;
    double run_ms, slice_ms, rotate_ms, after_ms, ref_chunk_ms;
    double bias_ms;            /* > 0: separate long runs for the bias split */
    double warm_ms;            /* > 0: also the bias of a warm cache (--bias-warm) */
    picvr_cache_config cache;  /* of every cached run: curvature_limit (--curvature),
                                  medium_model (--medium) and the numbers of
                                  --cache-param (presets.h); zero: the library's
                                  defaults.  The mode comes from the condition */
    int repeats, ref_max_chunks;
    int list;                  /* --list: print the scenes and their reference folders */
} options;

static int self_test(void);

/* The cache's options as text, e.g. "medium default; curvature on; gamma 0.05" (the
   --cache-param numbers that are set, in table order): part of run signatures. */
static void cache_options_text(const picvr_cache_config *c, char *out, size_t size);

static void print_help(FILE *f)
{
    fprintf(f,
        "usage: " PROGRAM " [options]   (see the comment at the top of bench/bench_error.c)\n"
        "  --scenes FILE        scene file (default bench/scenes.txt)\n"
        "  --data DIR           data directory (default ../shared/data)\n"
        "  --datasets A,B       datasets of the scene file to run (default all)\n"
        "  --lights A,B         light set-ups of the scene file to run (default all)\n"
        "  --size WxH           image size (default 128x128)\n"
        "  --conditions A,B     of plain, object, object-noprio, screen, screen-noprio,\n"
        "                       plain-prio (default the first five; plain is the baseline)\n"
        "  --time MS            run length per condition (default 10000)\n"
        "  --slice MS           picvr_step budget between measurements (default 200)\n"
        "  --repeats N          repetitions, seeds 101, 102, ... (default 2)\n"
        "  --rotate MS          Fig. 10: camera turns 360 degrees in MS (default 4000;\n"
        "                       0: no Fig. 10)\n"
        "  --after MS           Fig. 10: rendering after the camera stops (default 6000)\n"
        "  --fig10 A,B          datasets with a Fig. 10 run (default bonsai)\n"
        "  --bias A,B           datasets whose final images are kept for the bias\n"
        "                       split (default bonsai)\n"
        "  --bias-time MS       bias from separate runs of MS (plain, object, screen);\n"
        "                       0: from the final images of the Table 2 runs (default)\n"
        "  --bias-warm MS       also the bias of a full cache: object and screen runs\n"
        "                       that first fill the cache for MS with creation at a\n"
        "                       0.85 share of the time, then restart the image (the\n"
        "                       cache is kept) and render --bias-time (or --time) MS\n"
        "  --curvature on|off   the cache's curvature limit of the radii (default: the\n"
        "                       library's, off)\n"
        "  --medium on|off      the cache's medium model along the normal axis (default:\n"
        "                       the library's, on)\n"
        "  --cache-param N=V    a number of picvr_cache_config for every cached run, by\n"
        "                       its field name: gamma, epsilon, delta_voxels,\n"
        "                       radius_min_voxels, radius_max_voxels, update_threshold\n"
        "                       (repeatable; default: the library's, picvr.h)\n"
        "  --ref-chunk MS       time per reference chunk (default 60000)\n"
        "  --ref-max-chunks N   refuse a reference that needs more (default 200)\n"
        "  --out DIR            results (default bench/results)\n"
        "  --refs DIR           reference cache (default bench/refs)\n"
        "  --list               print the selected scenes and reference folders, exit\n"
        "                       (loads each dataset to render its fingerprint)\n"
        "  --self-test          check the harness (ratios, reference, run signatures,\n"
        "                       defaults, fingerprint), exit\n");
}

static int parse_args(int argc, char **argv, options *o)
{
    /* Designated, not positional: a field added to `options` once shifted the defaults
       by one (repeats' 2 became medium = PICVR_SWITCH_OFF, so the "library default"
       runs of make bench-bias measured the paper's model; caught 2026-11-29). */
    *o = (options){.scenes_path = "bench/scenes.txt", .data_dir = "../shared/data",
                   .out_dir = "bench/results", .refs_dir = "bench/refs",
                   .conditions = "plain,object,object-noprio,screen,screen-noprio",
                   .bias = "bonsai", .fig10 = "bonsai", .width = 128, .height = 128,
                   .run_ms = 10000, .slice_ms = 200, .rotate_ms = 4000, .after_ms = 6000,
                   .ref_chunk_ms = 60000, .cache = {0}, .repeats = 2,
                   .ref_max_chunks = 200};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help")) { print_help(stdout); exit(0); }
        if (!strcmp(a, "--list")) { o->list = 1; continue; }
        if (!strcmp(a, "--self-test")) exit(self_test() ? 0 : 1);
        if (!v || strncmp(a, "--", 2) != 0) { print_help(stderr); return 0; }
        i++;
        if (!strcmp(a, "--scenes")) o->scenes_path = v;
        else if (!strcmp(a, "--data")) o->data_dir = v;
        else if (!strcmp(a, "--datasets")) o->datasets = v;
        else if (!strcmp(a, "--lights")) o->lights = v;
        else if (!strcmp(a, "--conditions")) o->conditions = v;
        else if (!strcmp(a, "--bias")) o->bias = v;
        else if (!strcmp(a, "--fig10")) o->fig10 = v;
        else if (!strcmp(a, "--out")) o->out_dir = v;
        else if (!strcmp(a, "--refs")) o->refs_dir = v;
        else if (!strcmp(a, "--size")) {
            if (sscanf(v, "%ux%u", &o->width, &o->height) != 2 || !o->width || !o->height) {
                fail("bad --size %s", v);
                return 0;
            }
        } else if (!strcmp(a, "--time")) o->run_ms = atof(v);
        else if (!strcmp(a, "--slice")) o->slice_ms = atof(v);
        else if (!strcmp(a, "--rotate")) o->rotate_ms = atof(v);
        else if (!strcmp(a, "--after")) o->after_ms = atof(v);
        else if (!strcmp(a, "--ref-chunk")) o->ref_chunk_ms = atof(v);
        else if (!strcmp(a, "--bias-time")) o->bias_ms = atof(v);
        else if (!strcmp(a, "--bias-warm")) o->warm_ms = atof(v);
        else if (!strcmp(a, "--curvature")) {
            if (!strcmp(v, "on")) o->cache.curvature_limit = PICVR_SWITCH_ON;
            else if (!strcmp(v, "off")) o->cache.curvature_limit = PICVR_SWITCH_OFF;
            else { fail("bad --curvature %s", v); return 0; }
        }
        else if (!strcmp(a, "--medium")) {
            if (!strcmp(v, "on")) o->cache.medium_model = PICVR_SWITCH_ON;
            else if (!strcmp(v, "off")) o->cache.medium_model = PICVR_SWITCH_OFF;
            else { fail("bad --medium %s", v); return 0; }
        }
        else if (!strcmp(a, "--cache-param")) {
            pvp_status ps = pvp_cache_param_set(&o->cache, v);
            if (ps != PVP_OK) {
                fail("--cache-param %s: %s", v, pvp_status_string(ps));
                return 0;
            }
        }
        else if (!strcmp(a, "--repeats")) o->repeats = atoi(v);
        else if (!strcmp(a, "--ref-max-chunks")) o->ref_max_chunks = atoi(v);
        else { fail("unknown option %s", a); print_help(stderr); return 0; }
    }
    if (o->run_ms <= 0 || o->slice_ms <= 0 || o->repeats < 1 || o->repeats > MAX_REPEATS ||
        o->ref_chunk_ms <= 0 || o->ref_max_chunks < REF_MIN_CHUNKS || o->rotate_ms < 0 ||
        o->after_ms < 0 || o->bias_ms < 0 || o->warm_ms < 0) {
        fail("an option is out of range");
        return 0;
    }
    if (!in_list(o->conditions, "plain")) {
        fail("--conditions must include plain (the baseline)");
        return 0;
    }
    return 1;
}

/* ---- conditions ------------------------------------------------------------------------- */

typedef struct condition {
    const char *name;
    picvr_cache_mode mode;
    picvr_switch priorities;
} condition;

/* plain is the paper's MCVR baseline: no cache, no priorities. */
static const condition CONDITIONS[] = {
    {"plain", PICVR_CACHE_NONE, PICVR_SWITCH_OFF},
    {"object", PICVR_CACHE_OBJECT_SPACE, PICVR_SWITCH_ON},
    {"object-noprio", PICVR_CACHE_OBJECT_SPACE, PICVR_SWITCH_OFF},
    {"screen", PICVR_CACHE_SCREEN_SPACE, PICVR_SWITCH_ON},
    {"screen-noprio", PICVR_CACHE_SCREEN_SPACE, PICVR_SWITCH_OFF},
    {"plain-prio", PICVR_CACHE_NONE, PICVR_SWITCH_ON},
};
#define N_CONDITIONS (int)(sizeof CONDITIONS / sizeof CONDITIONS[0])

static const condition *find_condition(const char *name)
{
    for (int i = 0; i < N_CONDITIONS; i++)
        if (!strcmp(CONDITIONS[i].name, name)) return &CONDITIONS[i];
    return NULL;
}

/* ---- scene file ---------------------------------------------------------------------------- */

typedef struct dataset_spec {
    char name[NAME_LEN], file[PATH_LEN], tf[NAME_LEN];
    float spacing;
} dataset_spec;

typedef struct scene_file {
    dataset_spec datasets[MAX_DATASETS];
    int n_datasets;
    char lights[MAX_LIGHTS][NAME_LEN];
    int n_lights;
    float camera[4];           /* azimuth, elevation, distance factor, fov */
} scene_file;

static int parse_scene_line(char *line, scene_file *sf, int lineno)
{
    char *tok = strtok(line, " \t\r\n");
    if (!tok || tok[0] == '#') return 1;
    if (!strcmp(tok, "dataset")) {
        if (sf->n_datasets >= MAX_DATASETS) return 0;
        dataset_spec *d = &sf->datasets[sf->n_datasets];
        char *name = strtok(NULL, " \t\r\n"), *file = strtok(NULL, " \t\r\n");
        char *tf = strtok(NULL, " \t\r\n"), *sp = strtok(NULL, " \t\r\n");
        if (!name || !file || !tf || !sp || !(atof(sp) > 0)) {
            fail("scene file line %d: dataset NAME FILE TF SPACING", lineno);
            return 0;
        }
        snprintf(d->name, sizeof d->name, "%s", name);
        snprintf(d->file, sizeof d->file, "%s", file);
        snprintf(d->tf, sizeof d->tf, "%s", tf);
        d->spacing = (float)atof(sp);
        sf->n_datasets++;
    } else if (!strcmp(tok, "lights")) {
        for (char *l; (l = strtok(NULL, " \t\r\n")) && sf->n_lights < MAX_LIGHTS;)
            snprintf(sf->lights[sf->n_lights++], NAME_LEN, "%s", l);
    } else if (!strcmp(tok, "camera")) {
        for (int i = 0; i < 4; i++) {
            char *v = strtok(NULL, " \t\r\n");
            if (!v) { fail("scene file line %d: camera AZ EL DIST FOV", lineno); return 0; }
            sf->camera[i] = (float)atof(v);
        }
    } else {
        fail("scene file line %d: unknown keyword %s", lineno, tok);
        return 0;
    }
    return 1;
}

static int read_scene_file(const char *path, scene_file *sf)
{
    memset(sf, 0, sizeof *sf);
    sf->camera[0] = PVP_DEFAULT_AZIMUTH;
    sf->camera[1] = PVP_DEFAULT_ELEVATION;
    sf->camera[2] = PVP_DEFAULT_DISTANCE;
    sf->camera[3] = PVP_DEFAULT_FOV;
    FILE *f = fopen(path, "r");
    if (!f) { fail("cannot read %s: %s", path, strerror(errno)); return 0; }
    char line[2048];
    int ok = 1;
    for (int n = 1; ok && fgets(line, sizeof line, f); n++) ok = parse_scene_line(line, sf, n);
    fclose(f);
    return ok;
}

/* ---- scenes -------------------------------------------------------------------------------- */

typedef struct scene {
    const dataset_spec *ds;
    const char *lights;
    uint32_t width, height;
    float camera[4];
    char key[2048];
    char hash[17];
    char id[128];              /* dataset_lights_WxH, for file names */
} scene;

/* The scene without its reference key (scene_key, once the volume is loaded). */
static void scene_init(scene *s, const dataset_spec *ds, const char *lights,
                       const options *o, const float camera[4])
{
    memset(s, 0, sizeof *s);
    s->ds = ds;
    s->lights = lights;
    s->width = o->width;
    s->height = o->height;
    memcpy(s->camera, camera, sizeof s->camera);
    snprintf(s->id, sizeof s->id, "%s_%s_%ux%u", ds->name, lights, s->width, s->height);
}

/* The key of the scene's reference folder: the scene description and the plain
   renderer's fingerprint. */
static void scene_key(scene *s, uint64_t fingerprint)
{
    snprintf(s->key, sizeof s->key,
             "picvr-bench-ref v3|plain=%016llx|%s|tf=%s|spacing=%g|lights=%s|%ux%u|"
             "camera=%g,%g,%g,%g", (unsigned long long)fingerprint, s->ds->file, s->ds->tf,
             s->ds->spacing, s->lights, s->width, s->height, s->camera[0], s->camera[1],
             s->camera[2], s->camera[3]);
    snprintf(s->hash, sizeof s->hash, "%016llx", (unsigned long long)fnv1a(s->key));
}

static int lights_have_background(const char *lights)
{
    size_t n = strlen(lights);
    return n > 3 && !strcmp(lights + n - 3, "-bg");
}

/* The light set-up's name without "-bg". */
static void lights_base(const char *lights, char *out, size_t size)
{
    snprintf(out, size, "%s", lights);
    if (lights_have_background(lights)) out[strlen(out) - 3] = 0;
}

/* ---- contexts --------------------------------------------------------------------------- */

static void log_message(picvr_log_level level, const char *message, void *user)
{
    (void)user;
    if (level >= PICVR_LOG_WARNING) fprintf(stderr, "\npicvr: %s\n", message);
}

typedef struct session {
    picvr_context *ctx;
    picvr_camera camera;       /* the scene's camera (the lights are placed for it) */
    float box_min[3], box_max[3];
} session;

static int orbit(const scene *s, const session *ss, float azimuth, picvr_camera *cam)
{
    pvp_status ps = pvp_orbit_camera(ss->box_min, ss->box_max, azimuth, s->camera[1],
                                     s->camera[2], s->camera[3], s->width, s->height, cam);
    if (ps != PVP_OK) fail("camera: %s", pvp_status_string(ps));
    return ps == PVP_OK;
}

static int set_look(const scene *s, session *ss)
{
    pvp_tf tf;
    pvp_lights lights;
    pvp_status ps = pvp_tf_preset(s->ds->tf, &tf);
    if (ps != PVP_OK) { fail("tf %s: %s", s->ds->tf, pvp_status_string(ps)); return 0; }
    ps = pvp_lights_preset(s->lights, ss->box_min, ss->box_max, &ss->camera, &lights);
    if (ps != PVP_OK) { fail("lights %s: %s", s->lights, pvp_status_string(ps)); return 0; }
    return check(picvr_set_transfer_function(ss->ctx, tf.points, tf.count, tf.density),
                 "picvr_set_transfer_function") &&
           check(picvr_set_lights(ss->ctx, lights.lights, lights.count, &lights.background),
                 "picvr_set_lights");
}

/* A fresh context (empty cache) with the scene set up for condition c and a seed.
   create_share > 0: the creation procedure's share of the time, at every hit rate
   (t_c,min = t_c,max; the warm-up of --bias-warm); 0: the defaults of Table 1.
   cache: the cache's options (options.cache; NULL: the library's defaults); its mode
   is the condition's. */
static int session_open(const scene *s, const pvio_volume *vol, const condition *c,
                        uint32_t seed, float create_share, const picvr_cache_config *cache,
                        session *ss)
{
    memset(ss, 0, sizeof *ss);
    picvr_config cfg = {0};
    cfg.seed = seed;
    cfg.log = log_message;
    if (cache) cfg.cache = *cache;
    cfg.cache.mode = c->mode;
    cfg.scheduler.priorities = c->priorities;
    cfg.scheduler.create_min = cfg.scheduler.create_max = create_share;
    if (!check(picvr_create(&cfg, &ss->ctx), "picvr_create")) return 0;
    picvr_volume_desc desc;
    pvio_to_desc(vol, &desc);
    int ok = check(picvr_upload_volume(ss->ctx, &desc), "picvr_upload_volume") &&
             check(picvr_volume_box(ss->ctx, ss->box_min, ss->box_max), "picvr_volume_box") &&
             orbit(s, ss, s->camera[0], &ss->camera) &&
             check(picvr_set_camera(ss->ctx, &ss->camera), "picvr_set_camera") &&
             set_look(s, ss);
    if (!ok) { picvr_destroy(ss->ctx); ss->ctx = NULL; }
    return ok;
}

static void session_close(session *ss)
{
    picvr_destroy(ss->ctx);
    ss->ctx = NULL;
}

/* Reads the linear image and reduces it to luminance (rows top to bottom). */
static int read_luminance(picvr_context *ctx, uint32_t w, uint32_t h, float *rgba, float *lum)
{
    size_t n = (size_t)w * h;
    if (!check(picvr_read_rgba32f(ctx, rgba, n * 16), "picvr_read_rgba32f")) return 0;
    for (size_t i = 0; i < n; i++) lum[i] = (float)luminance(rgba + 4 * i);
    return 1;
}

/* The plain renderer's fingerprint for scene s: FNV-1a of the linear image of a short
   deterministic render (FINGERPRINT_ITERATIONS whole passes with picvr_step_iterations,
   seed FINGERPRINT_SEED; no time budget, so bit for bit the same on one machine and
   driver).  It keys the references, so that a change of the library that leaves the
   plain image bit-identical (a refactor) keeps them, while any change of that image, by
   the kernel or by the host side, makes new ones; another device or driver gets its own
   references.  Costs a few iterations per scene. */
static int plain_fingerprint(const scene *s, const pvio_volume *vol, uint64_t *out)
{
    session ss;
    if (!session_open(s, vol, find_condition("plain"), FINGERPRINT_SEED, 0.0f, NULL, &ss)) return 0;
    size_t n = (size_t)s->width * s->height;
    float *rgba = malloc(n * 16);
    int ok = rgba != NULL &&
             check(picvr_step_iterations(ss.ctx, FINGERPRINT_ITERATIONS), "picvr_step_iterations") &&
             check(picvr_read_rgba32f(ss.ctx, rgba, n * 16), "picvr_read_rgba32f");
    if (!rgba) fail("out of memory");
    if (ok) *out = fnv1a_bytes(rgba, n * 16);
    free(rgba);
    session_close(&ss);
    return ok;
}

/* ---- PFM chunks --------------------------------------------------------------------------- */

/* PFM "PF", little-endian, RGB rows bottom up (as picvr-render --out-float). */
static int write_pfm(const char *path, const float *rgba, uint32_t w, uint32_t h)
{
    FILE *f = fopen(path, "wb");
    float *row = malloc((size_t)w * 12);
    int ok = f && row && fprintf(f, "PF\n%u %u\n-1.0\n", w, h) > 0;
    for (uint32_t y = h; ok && y-- > 0;) {
        for (uint32_t x = 0; x < w; x++)
            memcpy(row + 3 * x, rgba + ((size_t)y * w + x) * 4, 12);
        ok = fwrite(row, 12, w, f) == w;
    }
    if (f && fclose(f) != 0) ok = 0;
    free(row);
    if (!ok) fail("cannot write %s", path);
    return ok;
}

/* Reads a w x h little-endian PFM written as above into luminance, rows top down. */
static int read_pfm_luminance(const char *path, uint32_t w, uint32_t h, double *lum)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    char magic[3] = {0};
    unsigned fw = 0, fh = 0;
    float scale = 0;
    int ok = fscanf(f, "%2s %u %u %f", magic, &fw, &fh, &scale) == 4 &&
             !strcmp(magic, "PF") && fw == w && fh == h && scale < 0 && fgetc(f) == '\n';
    float *row = malloc((size_t)w * 12);
    for (uint32_t y = h; ok && row && y-- > 0;) {
        ok = fread(row, 12, w, f) == w;
        for (uint32_t x = 0; ok && x < w; x++) lum[(size_t)y * w + x] = luminance(row + 3 * x);
    }
    ok = ok && row;
    free(row);
    fclose(f);
    if (!ok) fail("%s is not a %ux%u little-endian PFM", path, w, h);
    return ok;
}

/* The "iterations" value of a chunk's JSON (ours or picvr-render --json). */
static long read_chunk_iterations(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    char buf[4096];
    size_t n = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[n] = 0;
    const char *p = strstr(buf, "\"iterations\":");
    return p ? atol(p + 13) : -1;
}

/* ---- reference ------------------------------------------------------------------------------ */

typedef struct reference {
    uint32_t width, height, chunks;
    uint64_t iterations;
    double *lum;               /* iteration-weighted mean luminance per pixel */
    double *var;               /* estimated variance of that mean per pixel */
    double mean_lum, rmse, rel_rmse;
    char dir[PATH_LEN];
} reference;

static void chunk_paths(const reference *r, uint32_t k, char *pfm, char *json)
{
    snprintf(pfm, PATH_LEN, "%s/chunk_%u.pfm", r->dir, REF_SEED0 + k);
    snprintf(json, PATH_LEN, "%s/chunk_%u.json", r->dir, REF_SEED0 + k);
}

/* Per pixel: sum n_k m_k and sum n_k m_k^2 over the chunks, in double. */
static int ref_accumulate(reference *r, double *s1, double *s2, double *chunk)
{
    size_t n = (size_t)r->width * r->height;
    char pfm[PATH_LEN], json[PATH_LEN];
    r->chunks = 0;
    r->iterations = 0;
    for (;; r->chunks++) {
        chunk_paths(r, r->chunks, pfm, json);
        long it = read_chunk_iterations(json);
        if (it <= 0 || !file_exists(pfm)) break;
        if (!read_pfm_luminance(pfm, r->width, r->height, chunk)) return 0;
        for (size_t i = 0; i < n; i++) {
            s1[i] += it * chunk[i];
            s2[i] += it * chunk[i] * chunk[i];
        }
        r->iterations += (uint64_t)it;
    }
    return 1;
}

/* Mean and error of the reference: with chunk means m_k of n_k samples, the per-sample
   variance is s^2 = sum n_k (m_k - m)^2 / (K - 1) and the mean's variance s^2 / sum n_k. */
static void ref_finish(reference *r, const double *s1, const double *s2)
{
    size_t n = (size_t)r->width * r->height;
    double N = (double)r->iterations, sum = 0, se = 0, sr = 0;
    for (size_t i = 0; i < n; i++) {
        r->lum[i] = N > 0 ? s1[i] / N : 0;
        double ss = s2[i] - s1[i] * r->lum[i];
        r->var[i] = r->chunks > 1 && ss > 0 ? ss / (r->chunks - 1) / N : 0;
        sum += r->lum[i];
    }
    r->mean_lum = sum / n;
    double floor = FLOOR_FRACTION * r->mean_lum;
    for (size_t i = 0; i < n; i++) {
        se += r->var[i];
        sr += r->var[i] / ((r->lum[i] + floor) * (r->lum[i] + floor));
    }
    r->rmse = sqrt(se / n);
    r->rel_rmse = sqrt(sr / n);
}

static int ref_load(reference *r)
{
    size_t n = (size_t)r->width * r->height;
    double *s1 = calloc(n, sizeof *s1), *s2 = calloc(n, sizeof *s2);
    double *chunk = malloc(n * sizeof *chunk);
    int ok = s1 && s2 && chunk && ref_accumulate(r, s1, s2, chunk);
    if (ok) ref_finish(r, s1, s2);
    free(s1);
    free(s2);
    free(chunk);
    return ok;
}

static int ref_open(const options *o, const scene *s, reference *r)
{
    memset(r, 0, sizeof *r);
    r->width = s->width;
    r->height = s->height;
    snprintf(r->dir, sizeof r->dir, "%s/%s", o->refs_dir, s->hash);
    size_t n = (size_t)r->width * r->height;
    r->lum = calloc(n, sizeof *r->lum);
    r->var = calloc(n, sizeof *r->var);
    if (!r->lum || !r->var || !make_dirs(r->dir)) {
        fail("cannot create %s", r->dir);
        return 0;
    }
    char path[PATH_LEN];
    snprintf(path, sizeof path, "%s/scene.txt", r->dir);
    FILE *f = fopen(path, "w");
    if (f) { fprintf(f, "%s\n", s->key); fclose(f); }
    return ref_load(r);
}

static void ref_close(reference *r)
{
    free(r->lum);
    free(r->var);
    memset(r, 0, sizeof *r);
}

/* Renders reference chunk k: plain Monte Carlo for o->ref_chunk_ms, seed 1001 + k. */
static int ref_render_chunk(const options *o, const scene *s, const pvio_volume *vol,
                            const reference *r, uint32_t k)
{
    session ss;
    if (!session_open(s, vol, find_condition("plain"), REF_SEED0 + k, 0.0f, NULL, &ss)) return 0;
    double spent = 0, last = 0;
    int ok = 1;
    while (ok && spent < o->ref_chunk_ms) {
        double t0 = now_ms();
        ok = check(picvr_step(ss.ctx, 1000.0), "picvr_step");
        spent += now_ms() - t0;
        if (spent - last > 10000 || spent >= o->ref_chunk_ms) {
            fprintf(stderr, "  reference %s chunk %u: %.0f/%.0f s\n", s->id, k + 1,
                    spent / 1e3, o->ref_chunk_ms / 1e3);
            last = spent;
        }
    }
    picvr_stats st;
    size_t n = (size_t)s->width * s->height;
    float *rgba = malloc(n * 16);
    char pfm[PATH_LEN], json[PATH_LEN], tmp[PATH_LEN];
    chunk_paths(r, k, pfm, json);
    snprintf(tmp, sizeof tmp, "%s.tmp", pfm);
    ok = ok && rgba && check(picvr_get_stats(ss.ctx, &st), "picvr_get_stats") &&
         check(picvr_read_rgba32f(ss.ctx, rgba, n * 16), "picvr_read_rgba32f") &&
         write_pfm(tmp, rgba, s->width, s->height) && rename(tmp, pfm) == 0;
    FILE *f = ok ? fopen(json, "w") : NULL;
    if (f) {
        fprintf(f, "{\"iterations\": %u, \"elapsed_ms\": %.3f, \"seed\": %u}\n",
                st.iterations, st.elapsed_ms, REF_SEED0 + k);
        ok = fclose(f) == 0;
    } else {
        ok = 0;
    }
    free(rgba);
    session_close(&ss);
    return ok;
}

static int ref_grow(const options *o, const scene *s, const pvio_volume *vol,
                    reference *r, uint32_t chunks)
{
    for (uint32_t k = r->chunks; k < chunks; k++)
        if (!ref_render_chunk(o, s, vol, r, k)) return 0;
    if (!ref_load(r)) return 0;
    fprintf(stderr, "  reference %s: %u chunks, %llu iterations, RMSE %.3g, rel. RMSE %.3g\n",
            s->id, r->chunks, (unsigned long long)r->iterations, r->rmse, r->rel_rmse);
    return 1;
}

/* ---- runs ------------------------------------------------------------------------------------- */

typedef struct row {
    double t_ms;               /* time spent in picvr_step since the run started */
    uint32_t iterations;
    double rmse, rel_rmse;     /* true errors; NaN while the camera moves */
    double est, est_rel;       /* the paper's estimate (stats) */
    double hit_rate, mean_lum;
    uint32_t entries, refs;
    int moving;
} row;

typedef struct run {
    row *rows;
    size_t n, cap;
} run;

static int run_push(run *r, const row *x)
{
    if (r->n == r->cap) {
        size_t cap = r->cap ? 2 * r->cap : 64;
        row *p = realloc(r->rows, cap * sizeof *p);
        if (!p) return 0;
        r->rows = p;
        r->cap = cap;
    }
    r->rows[r->n++] = *x;
    return 1;
}

static void run_free(run *r)
{
    free(r->rows);
    memset(r, 0, sizeof *r);
}

#define ROW_HEADER "t_ms,iterations,rmse,rel_rmse,est_error,est_rel_error,hit_rate," \
                   "mean_luminance,entries,refs,moving"

static void write_row(FILE *f, const row *x)
{
    fprintf(f, "%.3f,%u,%.9g,%.9g,%.9g,%.9g,%.6f,%.9g,%u,%u,%d\n", x->t_ms, x->iterations,
            x->rmse, x->rel_rmse, x->est, x->est_rel, x->hit_rate, x->mean_lum, x->entries,
            x->refs, x->moving);
}

static int parse_row(const char *line, row *x)
{
    return sscanf(line, "%lf,%u,%lf,%lf,%lf,%lf,%lf,%lf,%u,%u,%d", &x->t_ms, &x->iterations,
                  &x->rmse, &x->rel_rmse, &x->est, &x->est_rel, &x->hit_rate, &x->mean_lum,
                  &x->entries, &x->refs, &x->moving) == 11;
}

static const char *switch_name(picvr_switch s)
{
    return s == PICVR_SWITCH_ON ? "on" : s == PICVR_SWITCH_OFF ? "off" : "default";
}

static void cache_options_text(const picvr_cache_config *c, char *out, size_t size)
{
    int n = snprintf(out, size, "medium %s; curvature %s", switch_name(c->medium_model),
                     switch_name(c->curvature_limit));
    for (size_t i = 0; pvp_cache_param_name(i) && n > 0 && (size_t)n < size; i++)
        if (pvp_cache_param_get(c, i) > 0)
            n += snprintf(out + n, size - (size_t)n, "; %s %g", pvp_cache_param_name(i),
                          pvp_cache_param_get(c, i));
}

/* What a run file was measured with: the reference, the library build and the cache
   options (--medium, --curvature, --cache-param).  A file whose first line differs is
   run again. */
static void run_signature(const options *o, const reference *r, char *out, size_t size)
{
    char cache[256];
    cache_options_text(&o->cache, cache, sizeof cache);
    snprintf(out, size, "# reference %u chunks %llu iterations; library %s; %s", r->chunks,
             (unsigned long long)r->iterations, PICVR_BENCH_BUILD, cache);
}

/* Loads a finished run file measured with this signature; 0 if there is none. */
static int run_load(const options *o, const char *path, const reference *ref, run *out)
{
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    char line[1024], sig[512];
    run_signature(o, ref, sig, sizeof sig);
    size_t n = strlen(sig);
    int ok = fgets(line, sizeof line, f) && !strncmp(line, sig, n) &&
             (line[n] == '\n' || line[n] == 0), done = 0;
    while (ok && fgets(line, sizeof line, f)) {
        row x;
        if (!strncmp(line, "# done", 6)) done = 1;
        else if (parse_row(line, &x)) ok = run_push(out, &x);
    }
    fclose(f);
    if (!ok || !done || out->n == 0) { run_free(out); return 0; }
    return 1;
}

typedef struct errors { double rmse, rel_rmse; } errors;

static errors compare(const float *lum, const reference *ref)
{
    size_t n = (size_t)ref->width * ref->height;
    double floor = FLOOR_FRACTION * ref->mean_lum, se = 0, sr = 0;
    for (size_t i = 0; i < n; i++) {
        double e = lum[i] - ref->lum[i], rel = e / (ref->lum[i] + floor);
        se += e * e;
        sr += rel * rel;
    }
    errors out = {sqrt(se / n), sqrt(sr / n)};
    return out;
}

typedef struct run_spec {
    const scene *s;
    const pvio_volume *vol;
    const reference *ref;
    const condition *c;
    int repeat;
    int rotate;                /* Fig. 10: turn the camera, then stop */
    const char *path;          /* run file */
    const char *lum_path;      /* final luminance image, or NULL */
    const char *label;         /* progress prefix */
    double length_ms;          /* 0: o->run_ms */
    double warm_ms;            /* > 0: fill the cache first (--bias-warm, warm_up) */
} run_spec;

/* One measurement after a slice. */
static int measure(const run_spec *rs, session *ss, double t, int moving, float *rgba,
                   float *lum, row *x)
{
    picvr_stats st;
    if (!check(picvr_get_stats(ss->ctx, &st), "picvr_get_stats")) return 0;
    memset(x, 0, sizeof *x);
    x->t_ms = t;
    x->iterations = st.iterations;
    x->est = st.est_error;
    x->est_rel = st.est_rel_error;
    x->hit_rate = st.cache_hit_rate;
    x->mean_lum = st.mean_luminance;
    x->entries = st.cache_entries;
    x->refs = st.cache_refs;
    x->moving = moving;
    x->rmse = x->rel_rmse = NAN;
    if (moving) return 1;
    if (!read_luminance(ss->ctx, rs->s->width, rs->s->height, rgba, lum)) return 0;
    errors e = compare(lum, rs->ref);
    x->rmse = e.rmse;
    x->rel_rmse = e.rel_rmse;
    return 1;
}

/* A progress line; a warm-up (no image yet, rmse and est NaN) prints no errors. */
static void progress(const run_spec *rs, const row *x, double total, int final)
{
    static double last;
    double t = now_ms();
    if (!final && t - last < 2000) return;
    last = t;
    char errs[64] = "";
    if (isfinite(x->rmse) && isfinite(x->est))
        snprintf(errs, sizeof errs, " rmse=%.4g est=%.4g", x->rmse, x->est);
    fprintf(stderr, "%s t=%5.1f/%.0f s it=%5u%s hit=%.2f entries=%u%s\n", rs->label,
            x->t_ms / 1e3, total / 1e3, x->iterations, errs, x->hit_rate, x->entries,
            x->moving ? " (camera moving)" : "");
}

/* The camera for the slice starting at time t of a Fig. 10 run; *moving = 0 after. */
static int rotation_camera(const options *o, const run_spec *rs, const session *ss,
                           double t, picvr_camera *cam, int *moving)
{
    *moving = rs->rotate && t < o->rotate_ms;
    if (!*moving) { *cam = ss->camera; return 1; }
    return orbit(rs->s, ss, rs->s->camera[0] + (float)(360.0 * t / o->rotate_ms), cam);
}

static int write_luminance(const char *path, const float *lum, size_t n)
{
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(lum, sizeof *lum, n, f) == n;
    if (f && fclose(f) != 0) ok = 0;
    return ok;
}

static int run_slices(const options *o, const run_spec *rs, session *ss, FILE *f, run *out)
{
    size_t n = (size_t)rs->s->width * rs->s->height;
    float *rgba = malloc(n * 16), *lum = malloc(n * sizeof *lum);
    double total = rs->rotate ? o->rotate_ms + o->after_ms
                              : rs->length_ms > 0 ? rs->length_ms : o->run_ms, t = 0;
    int ok = rgba && lum, moving = 0;
    row x = {0};
    while (ok && t < total) {
        picvr_camera cam;
        ok = rotation_camera(o, rs, ss, t, &cam, &moving) &&
             check(picvr_set_camera(ss->ctx, &cam), "picvr_set_camera");
        double t0 = now_ms();
        ok = ok && check(picvr_step(ss->ctx, o->slice_ms), "picvr_step");
        t += now_ms() - t0;
        ok = ok && measure(rs, ss, t, moving, rgba, lum, &x) && run_push(out, &x);
        if (ok) { write_row(f, &x); fflush(f); progress(rs, &x, total, 0); }
    }
    if (ok) progress(rs, &x, total, 1);
    if (ok && rs->lum_path && !write_luminance(rs->lum_path, lum, n)) {
        fail("cannot write %s", rs->lum_path);
        ok = 0;
    }
    free(rgba);
    free(lum);
    return ok;
}

/* When the runs behind the tables were measured: the run files' modification times. */
static time_t first_run_time, last_run_time;

static void note_run_time(const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0) return;
    if (!first_run_time || st.st_mtime < first_run_time) first_run_time = st.st_mtime;
    if (st.st_mtime > last_run_time) last_run_time = st.st_mtime;
}

/* --bias-warm: fills the cache for rs->warm_ms with creation at PVP_WARM_CREATE_SHARE, then
   restarts the image at the library's default shares (Table 1); picvr_set_scheduler and
   picvr_reset keep the cache.  The run that follows measures the image of a full cache -
   the state a GPU reaches within seconds (the paper's §8), which on lavapipe takes
   minutes at the default 5-15 % creation share (README, "The irradiance cache") - and its
   error against time as an application would see it after filling the cache while the
   scene loads.  Until 2026-11-30 the run kept creation at 0.85 (its hit rate of 0.98
   still sent misses to creation), so it rendered 30x fewer iterations than plain Monte
   Carlo: its bias held, its error against time did not mean anything. */
static int warm_up(const run_spec *rs, session *ss)
{
    double t = 0;
    picvr_stats st = {0};
    while (t < rs->warm_ms) {
        double t0 = now_ms();
        if (!check(picvr_step(ss->ctx, fmin(1000.0, rs->warm_ms - t)), "picvr_step")) return 0;
        t += now_ms() - t0;
        if (!check(picvr_get_stats(ss->ctx, &st), "picvr_get_stats")) return 0;
        row x = {0};
        x.t_ms = t;
        x.hit_rate = st.cache_hit_rate;
        x.entries = st.cache_entries;
        x.rmse = x.est = NAN;
        progress(rs, &x, rs->warm_ms, 0);
    }
    fprintf(stderr, "%s warm-up done: %u entries, hit rate %.2f\n", rs->label,
            st.cache_entries, st.cache_hit_rate);
    picvr_scheduler_config defaults;
    memset(&defaults, 0, sizeof defaults);
    defaults.priorities = rs->c->priorities;
    return check(picvr_set_scheduler(ss->ctx, &defaults), "picvr_set_scheduler") &&
           check(picvr_reset(ss->ctx), "picvr_reset");
}

/* Runs one condition and repeat from an empty cache, or loads its finished file. */
static int do_run(const options *o, const run_spec *rs, run *out)
{
    memset(out, 0, sizeof *out);
    if (run_load(o, rs->path, rs->ref, out) && (!rs->lum_path || file_exists(rs->lum_path))) {
        fprintf(stderr, "%s reused %s\n", rs->label, rs->path);
        note_run_time(rs->path);
        return 1;
    }
    run_free(out);
    session ss;
    if (!session_open(rs->s, rs->vol, rs->c, RUN_SEED0 + (uint32_t)rs->repeat,
                      rs->warm_ms > 0 ? PVP_WARM_CREATE_SHARE : 0.0f, &o->cache, &ss))
        return 0;
    if (rs->warm_ms > 0 && !warm_up(rs, &ss)) { session_close(&ss); return 0; }
    char tmp[PATH_LEN], sig[512];
    snprintf(tmp, sizeof tmp, "%s.tmp", rs->path);
    FILE *f = fopen(tmp, "w");
    run_signature(o, rs->ref, sig, sizeof sig);
    int ok = f != NULL;
    if (ok) fprintf(f, "%s\n%s\n", sig, ROW_HEADER);
    ok = ok && run_slices(o, rs, &ss, f, out);
    if (f) {
        if (ok) fprintf(f, "# done\n");
        if (fclose(f) != 0) ok = 0;
    }
    ok = ok && rename(tmp, rs->path) == 0;
    if (!ok) fail("run %s failed", rs->path);
    else note_run_time(rs->path);
    session_close(&ss);
    return ok;
}

/* ---- equal-time comparison ----------------------------------------------------------------------- */

enum field { F_RMSE, F_REL, F_EST, F_EST_REL };

static double row_value(const row *x, enum field f)
{
    switch (f) {
    case F_RMSE: return x->rmse;
    case F_REL: return x->rel_rmse;
    case F_EST: return x->est;
    case F_EST_REL: return x->est_rel;
    }
    return NAN;
}

/* log(error) at time t, linear in t between measurements; NaN outside or while moving. */
static double log_at(const run *r, double t, enum field f)
{
    for (size_t i = 1; i < r->n; i++) {
        const row *a = &r->rows[i - 1], *b = &r->rows[i];
        if (t < a->t_ms || t > b->t_ms) continue;
        double va = row_value(a, f), vb = row_value(b, f);
        if (!(va > 0) || !(vb > 0)) return NAN;
        double w = b->t_ms > a->t_ms ? (t - a->t_ms) / (b->t_ms - a->t_ms) : 0;
        return (1 - w) * log(va) + w * log(vb);
    }
    return NAN;
}

static double first_time(const run *r)
{
    for (size_t i = 0; i < r->n; i++)
        if (!r->rows[i].moving) return r->rows[i].t_ms;
    return INFINITY;
}

/* The ratio a/b of two runs' errors, averaged over a uniform grid of equal times where
   both have a measurement (from the later first measurement to the earlier last). */
static double mean_ratio(const run *a, const run *b, enum field f)
{
    double lo = fmax(first_time(a), first_time(b));
    double hi = fmin(a->rows[a->n - 1].t_ms, b->rows[b->n - 1].t_ms), sum = 0;
    int count = 0;
    for (int i = 0; i < GRID_POINTS && hi > lo; i++) {
        double t = lo + (hi - lo) * i / (GRID_POINTS - 1);
        double la = log_at(a, t, f), lb = log_at(b, t, f);
        if (isfinite(la) && isfinite(lb)) { sum += exp(la - lb); count++; }
    }
    return count ? sum / count : NAN;
}

/* ---- per-scene results ------------------------------------------------------------------------------ */

typedef struct scene_result {
    const condition *conds[N_CONDITIONS];
    int n_conds;
    run runs[N_CONDITIONS][MAX_REPEATS];
    run rot[2][MAX_REPEATS];   /* Fig. 10: plain, object */
    int have_rot;
    int refused;
    double smallest_rmse, smallest_rel;
    char device[256];
} scene_result;

static void free_result(scene_result *r, int repeats)
{
    for (int c = 0; c < N_CONDITIONS; c++)
        for (int k = 0; k < repeats; k++) run_free(&r->runs[c][k]);
    for (int c = 0; c < 2; c++)
        for (int k = 0; k < repeats; k++) run_free(&r->rot[c][k]);
}

static void smallest_errors(const scene_result *r, int repeats, double *rmse, double *rel)
{
    *rmse = *rel = INFINITY;
    for (int c = 0; c < r->n_conds; c++)
        for (int k = 0; k < repeats; k++)
            for (size_t i = 0; i < r->runs[c][k].n; i++) {
                const row *x = &r->runs[c][k].rows[i];
                if (x->moving) continue;
                *rmse = fmin(*rmse, x->rmse);
                *rel = fmin(*rel, x->rel_rmse);
            }
}

static void run_path(const options *o, const scene *s, const char *cond, int rep,
                     const char *suffix, char *out)
{
    snprintf(out, PATH_LEN, "%s/runs/%s_%s_%s_r%d%s", o->out_dir, s->id, s->hash, cond, rep,
             suffix);
}

static int count_done, count_total;

static int run_all(const options *o, const scene *s, const pvio_volume *vol,
                   const reference *ref, scene_result *res)
{
    int bias = in_list(o->bias, s->ds->name);
    for (int c = 0; c < res->n_conds; c++)
        for (int k = 0; k < o->repeats; k++) {
            char path[PATH_LEN], lum[PATH_LEN], label[256];
            run_path(o, s, res->conds[c]->name, k, ".csv", path);
            run_path(o, s, res->conds[c]->name, k, ".lum", lum);
            snprintf(label, sizeof label, "[%d/%d] %s %s r%d", ++count_done, count_total,
                     s->id, res->conds[c]->name, k);
            run_spec rs = {s, vol, ref, res->conds[c], k, 0, path,
                           bias && o->bias_ms <= 0 ? lum : NULL, label, 0};
            run_free(&res->runs[c][k]);
            if (!do_run(o, &rs, &res->runs[c][k])) return 0;
        }
    return 1;
}

static int run_rotations(const options *o, const scene *s, const pvio_volume *vol,
                         const reference *ref, scene_result *res)
{
    static const char *names[2] = {"plain", "object"};
    for (int c = 0; c < 2; c++)
        for (int k = 0; k < o->repeats; k++) {
            char path[PATH_LEN], label[256];
            run_path(o, s, names[c], k, "_rotate.csv", path);
            snprintf(label, sizeof label, "[%d/%d] %s fig10 %s r%d", ++count_done,
                     count_total, s->id, names[c], k);
            run_spec rs = {s, vol, ref, find_condition(names[c]), k, 1, path, NULL, label, 0};
            run_free(&res->rot[c][k]);
            if (!do_run(o, &rs, &res->rot[c][k])) return 0;
        }
    res->have_rot = 1;
    return 1;
}

/* The conditions of the separate bias runs: plain (the control) and both lockings;
   with --bias-warm also both lockings from a full cache (rows "object-warm" etc.). */
static const char *BIAS_CONDITIONS[] = {"plain", "object", "screen"};
#define N_BIAS_CONDITIONS 3
#define N_WARM_CONDITIONS 2    /* BIAS_CONDITIONS[1..2] */

/* The bias runs: suffix "_bias" or, warm, "_warm" (files and bias.md rows). */
static int run_bias(const options *o, const scene *s, const pvio_volume *vol,
                    const reference *ref, int warm)
{
    double length = o->bias_ms > 0 ? o->bias_ms : o->run_ms;
    for (int c = warm ? 1 : 0; c < N_BIAS_CONDITIONS; c++)
        for (int k = 0; k < o->repeats; k++) {
            char path[PATH_LEN], lum[PATH_LEN], label[256];
            run_path(o, s, BIAS_CONDITIONS[c], k, warm ? "_warm.csv" : "_bias.csv", path);
            run_path(o, s, BIAS_CONDITIONS[c], k, warm ? "_warm.lum" : "_bias.lum", lum);
            snprintf(label, sizeof label, "[%d/%d] %s bias %s%s r%d", ++count_done,
                     count_total, s->id, BIAS_CONDITIONS[c], warm ? "-warm" : "", k);
            run_spec rs = {s, vol, ref, find_condition(BIAS_CONDITIONS[c]), k, 0, path, lum,
                           label, length, warm ? o->warm_ms : 0};
            run r = {0};
            int ok = do_run(o, &rs, &r);
            run_free(&r);
            if (!ok) return 0;
        }
    return 1;
}

/* Runs a scene against its reference; grows the reference until it is 10x below the
   smallest error measured (then the runs are repeated), or refuses it. */
static int run_scene(const options *o, const scene *s, const pvio_volume *vol,
                     scene_result *res)
{
    reference ref;
    int ok = ref_open(o, s, &ref);
    if (ok && ref.chunks < REF_MIN_CHUNKS) ok = ref_grow(o, s, vol, &ref, REF_MIN_CHUNKS);
    int base_done = count_done;
    for (int round = 0; ok && round < REF_ROUNDS; round++) {
        count_done = base_done;
        ok = run_all(o, s, vol, &ref, res);
        if (!ok) break;
        smallest_errors(res, o->repeats, &res->smallest_rmse, &res->smallest_rel);
        double sm = sqrt(fmax(res->smallest_rmse * res->smallest_rmse - ref.rmse * ref.rmse,
                              1e-30));
        double sr = sqrt(fmax(res->smallest_rel * res->smallest_rel -
                                  ref.rel_rmse * ref.rel_rmse, 1e-30));
        double need = fmax(REF_FACTOR * ref.rmse / sm, REF_FACTOR * ref.rel_rmse / sr);
        fprintf(stderr, "  %s: reference RMSE %.3g (rel %.3g), smallest measured %.3g "
                "(rel %.3g): %.1fx below\n", s->id, ref.rmse, ref.rel_rmse,
                res->smallest_rmse, res->smallest_rel, REF_FACTOR / need);
        if (need <= 1.0) { res->refused = 0; break; }
        uint32_t chunks = (uint32_t)ceil(ref.chunks * need * need * 1.1);
        res->refused = 1;
        if ((int)chunks > o->ref_max_chunks || round == REF_ROUNDS - 1) {
            fail("%s: the reference is not converged enough (needs %u chunks, limit %d): "
                 "left out of the tables", s->id, chunks, o->ref_max_chunks);
            break;
        }
        fprintf(stderr, "  growing the reference to %u chunks of %.0f s\n", chunks,
                o->ref_chunk_ms / 1e3);
        ok = ref_grow(o, s, vol, &ref, chunks);
    }
    if (ok && !res->refused && o->rotate_ms > 0 && in_list(o->fig10, s->ds->name))
        ok = run_rotations(o, s, vol, &ref, res);
    if (ok && !res->refused && o->bias_ms > 0 && in_list(o->bias, s->ds->name))
        ok = run_bias(o, s, vol, &ref, 0);
    if (ok && !res->refused && o->warm_ms > 0 && in_list(o->bias, s->ds->name))
        ok = run_bias(o, s, vol, &ref, 1);
    ref_close(&ref);
    return ok;
}

/* ---- outputs ------------------------------------------------------------------------------------------ */

typedef struct writers {
    FILE *t2csv, *t2md, *t3csv, *t3md, *bcsv, *bmd;
    const options *o;
} writers;

static double ratio_stats(const scene_result *r, int c, int repeats, enum field f,
                          double *mn, double *mx)
{
    double sum = 0;
    int n = 0;
    *mn = INFINITY;
    *mx = -INFINITY;
    for (int k = 0; k < repeats; k++) {
        double q = mean_ratio(&r->runs[0][k], &r->runs[c][k], f);
        if (!isfinite(q)) continue;
        sum += q;
        n++;
        *mn = fmin(*mn, q);
        *mx = fmax(*mx, q);
    }
    return n ? sum / n : NAN;
}

static double final_mean(const scene_result *r, int c, int repeats, enum field f)
{
    double sum = 0;
    for (int k = 0; k < repeats; k++) sum += row_value(&r->runs[c][k].rows[r->runs[c][k].n - 1], f);
    return sum / repeats;
}

static double final_hit(const scene_result *r, int c, int repeats)
{
    double sum = 0;
    for (int k = 0; k < repeats; k++) sum += r->runs[c][k].rows[r->runs[c][k].n - 1].hit_rate;
    return sum / repeats;
}

static void write_table2(const writers *w, const scene *s, const scene_result *r)
{
    int R = w->o->repeats;
    char base[NAME_LEN];
    lights_base(s->lights, base, sizeof base);
    for (int c = 1; c < r->n_conds; c++) {
        double tmin, tmax, emin, emax;
        double rt = ratio_stats(r, c, R, F_RMSE, &tmin, &tmax);
        double re = ratio_stats(r, c, R, F_EST, &emin, &emax);
        double d0, d1;
        double rtr = ratio_stats(r, c, R, F_REL, &d0, &d1);
        double rer = ratio_stats(r, c, R, F_EST_REL, &d0, &d1);
        fprintf(w->t2csv, "%s,%s,%s,%ux%u,%s,%.4f,%.4f,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,"
                "%.1f,%.6g,%.6g,%.4f\n", s->ds->name, base,
                lights_have_background(s->lights) ? "on" : "off", s->width, s->height,
                r->conds[c]->name, rt, re, R, tmin, tmax, emin, emax, rtr, rer,
                w->o->run_ms / 1e3, final_mean(r, 0, R, F_RMSE), final_mean(r, c, R, F_RMSE),
                final_hit(r, c, R));
        fprintf(w->t2md, "| %s | %s | %s | %ux%u | %s | %.2f (%.2f-%.2f) | %.2f (%.2f-%.2f) | "
                "%.2f | %.2f | %.3g | %.3g | %.2f |\n", s->ds->name, base,
                lights_have_background(s->lights) ? "on" : "off", s->width, s->height,
                r->conds[c]->name, rt, tmin, tmax, re, emin, emax, rtr, rer,
                final_mean(r, 0, R, F_RMSE), final_mean(r, c, R, F_RMSE), final_hit(r, c, R));
    }
    fflush(w->t2csv);
    fflush(w->t2md);
}

static void write_table3(const writers *w, const scene *s, const scene_result *r)
{
    int R = w->o->repeats;
    for (int c = 1; c < r->n_conds; c++) {
        if (r->conds[c]->mode != PICVR_CACHE_OBJECT_SPACE) continue;
        double e = 0, f = 0, it = 0;
        for (int k = 0; k < R; k++) {
            const row *x = &r->runs[c][k].rows[r->runs[c][k].n - 1];
            e += x->entries;
            f += x->refs;
            it += x->iterations;
        }
        e /= R; f /= R; it /= R;
        double h = final_hit(r, c, R);
        fprintf(w->t3csv, "%s,%s,%ux%u,%s,%.1f,%.0f,%.0f,%.2f,%.3f,%.0f\n", s->ds->name,
                s->lights, s->width, s->height, r->conds[c]->name, w->o->run_ms / 1e3, e, f,
                e > 0 ? f / e : 0, h, it);
        fprintf(w->t3md, "| %s | %s | %ux%u | %s | %.0f | %.0f | %.0f | %.2f | %.2f | %.0f |\n",
                s->ds->name, s->lights, s->width, s->height, r->conds[c]->name,
                w->o->run_ms / 1e3, e, f, e > 0 ? f / e : 0, h, it);
    }
    fflush(w->t3csv);
    fflush(w->t3md);
}

/* Mean over repeats of the error at time t (arithmetic mean of the interpolations). */
static double mean_at(const run *runs, int repeats, double t, enum field f)
{
    double sum = 0;
    for (int k = 0; k < repeats; k++) {
        double l = log_at(&runs[k], t, f);
        if (!isfinite(l)) return NAN;
        sum += exp(l);
    }
    return sum / repeats;
}

static void dat_value(FILE *f, double v)
{
    if (isfinite(v)) fprintf(f, " %.6g", v);
    else fprintf(f, " NaN");
}

/* fig11_<id>.dat: time, then mean true RMSE per condition, then mean estimate per
   condition; fig11_<id>.gp plots both panels into fig11_<id>.png. */
static void write_fig11(const options *o, const scene *s, const scene_result *r)
{
    char path[PATH_LEN];
    snprintf(path, sizeof path, "%s/fig11_%s.dat", o->out_dir, s->id);
    FILE *f = fopen(path, "w");
    if (!f) return;
    fprintf(f, "t_s");
    for (int c = 0; c < r->n_conds; c++) fprintf(f, " %s_rmse", r->conds[c]->name);
    for (int c = 0; c < r->n_conds; c++) fprintf(f, " %s_est", r->conds[c]->name);
    fprintf(f, "\n");
    for (double t = o->slice_ms; t <= o->run_ms + 1e-9; t += o->slice_ms) {
        fprintf(f, "%.3f", t / 1e3);
        for (int c = 0; c < r->n_conds; c++) dat_value(f, mean_at(r->runs[c], o->repeats, t, F_RMSE));
        for (int c = 0; c < r->n_conds; c++) dat_value(f, mean_at(r->runs[c], o->repeats, t, F_EST));
        fprintf(f, "\n");
    }
    fclose(f);
    snprintf(path, sizeof path, "%s/fig11_%s.gp", o->out_dir, s->id);
    if (!(f = fopen(path, "w"))) return;
    fprintf(f, "set terminal pngcairo size 1200,450 font ',10'\nset output 'fig11_%s.png'\n"
            "set termoption noenhanced\nset datafile missing 'NaN'\nset key autotitle columnhead top right\n"
            "set logscale y\nset grid\nset xlabel 'time in picvr_step (s)'\n"
            "set multiplot layout 1,2 title '%s %s %ux%u: error from an empty cache, static "
            "camera (mean of %d seeds)'\n", s->id, s->ds->name, s->lights, s->width,
            s->height, o->repeats);
    fprintf(f, "set ylabel 'true RMSE of luminance vs reference'\n"
            "plot for [i=2:%d] 'fig11_%s.dat' using 1:i with lines lw 2\n", 1 + r->n_conds, s->id);
    fprintf(f, "set ylabel 'estimate: stats.est_error (Eq. 5)'\n"
            "plot for [i=%d:%d] 'fig11_%s.dat' using 1:i with lines lw 2\nunset multiplot\n",
            2 + r->n_conds, 1 + 2 * r->n_conds, s->id);
    fclose(f);
    /* the long-format data behind the figure: every slice of every run */
    snprintf(path, sizeof path, "%s/fig11_%s.csv", o->out_dir, s->id);
    if (!(f = fopen(path, "w"))) return;
    fprintf(f, "condition,repeat,seed," ROW_HEADER "\n");
    for (int c = 0; c < r->n_conds; c++)
        for (int k = 0; k < o->repeats; k++)
            for (size_t i = 0; i < r->runs[c][k].n; i++) {
                fprintf(f, "%s,%d,%u,", r->conds[c]->name, k, RUN_SEED0 + k);
                write_row(f, &r->runs[c][k].rows[i]);
            }
    fclose(f);
}

static void write_fig10(const options *o, const scene *s, const scene_result *r)
{
    static const char *names[2] = {"plain", "object"};
    char path[PATH_LEN];
    snprintf(path, sizeof path, "%s/fig10_%s.csv", o->out_dir, s->id);
    FILE *f = fopen(path, "w");
    if (!f) return;
    fprintf(f, "condition,repeat,seed," ROW_HEADER "\n");
    for (int c = 0; c < 2; c++)
        for (int k = 0; k < o->repeats; k++)
            for (size_t i = 0; i < r->rot[c][k].n; i++) {
                fprintf(f, "%s,%d,%u,", names[c], k, RUN_SEED0 + k);
                write_row(f, &r->rot[c][k].rows[i]);
            }
    fclose(f);
    snprintf(path, sizeof path, "%s/fig10_%s.dat", o->out_dir, s->id);
    if (!(f = fopen(path, "w"))) return;
    fprintf(f, "t_s plain_rmse object_rmse plain_est object_est\n");
    double total = o->rotate_ms + o->after_ms;
    for (double t = o->slice_ms; t <= total + 1e-9; t += o->slice_ms) {
        fprintf(f, "%.3f", t / 1e3);
        for (int c = 0; c < 2; c++) dat_value(f, mean_at(r->rot[c], o->repeats, t, F_RMSE));
        for (int c = 0; c < 2; c++) dat_value(f, mean_at(r->rot[c], o->repeats, t, F_EST));
        fprintf(f, "\n");
    }
    fclose(f);
    snprintf(path, sizeof path, "%s/fig10_%s.gp", o->out_dir, s->id);
    if (!(f = fopen(path, "w"))) return;
    fprintf(f, "set terminal pngcairo size 800,500 font ',10'\nset output 'fig10_%s.png'\n"
            "set termoption noenhanced\nset datafile missing 'NaN'\nset key autotitle columnhead top right\n"
            "set logscale y\nset grid\nset xlabel 'time in picvr_step (s)'\n"
            "set ylabel 'error of luminance'\n"
            "set title '%s: camera turns 360 degrees in %.1f s, then stops (mean of %d seeds)'\n"
            "set arrow from %.3f, graph 0 to %.3f, graph 1 nohead dt 2\n"
            "plot 'fig10_%s.dat' using 1:2 with lines lw 2 title 'plain: true RMSE', "
            "'' using 1:3 with lines lw 2 title 'object cache: true RMSE', "
            "'' using 1:4 with lines dt 3 title 'plain: est_error', "
            "'' using 1:5 with lines dt 3 title 'object cache: est_error'\n",
            s->id, s->id, o->rotate_ms / 1e3, o->repeats, o->rotate_ms / 1e3,
            o->rotate_ms / 1e3, s->id);
    fclose(f);
}

/* Bias split from variance over R seeds: with the final images Y_k and their mean
   Ybar, per pixel s^2 = sample variance over k, so E[(Ybar - Yref)^2] = b^2 + s^2/R
   + var(Yref); rms_bias = sqrt(max(0, mean((Ybar-Yref)^2) - mean(s^2)/R - mean var_ref)).
   The relative bias of the image mean luminance is reported with its standard error. */
static int bias_one(const options *o, const scene *s, const reference *ref, const char *cond,
                    const char *suffix, double out[5])
{
    size_t n = (size_t)s->width * s->height;
    int R = o->repeats;
    float *img = malloc(n * sizeof *img);
    double *s1 = calloc(n, sizeof *s1), *s2 = calloc(n, sizeof *s2), m[MAX_REPEATS];
    int ok = img && s1 && s2 && R >= 2;
    for (int k = 0; ok && k < R; k++) {
        char path[PATH_LEN];
        run_path(o, s, cond, k, suffix, path);
        FILE *f = fopen(path, "rb");
        ok = f && fread(img, sizeof *img, n, f) == n;
        if (f) fclose(f);
        m[k] = 0;
        for (size_t i = 0; ok && i < n; i++) { s1[i] += img[i]; s2[i] += (double)img[i] * img[i]; m[k] += img[i]; }
        m[k] /= n;
    }
    if (ok) {
        double d2 = 0, v = 0, vr = 0, mm = 0, sm = 0;
        for (size_t i = 0; i < n; i++) {
            double mean = s1[i] / R, d = mean - ref->lum[i];
            d2 += d * d;
            v += (s2[i] - R * mean * mean) / (R - 1);
            vr += ref->var[i];
        }
        for (int k = 0; k < R; k++) mm += m[k] / R;
        for (int k = 0; k < R; k++) sm += (m[k] - mm) * (m[k] - mm) / (R - 1);
        out[0] = (mm - ref->mean_lum) / ref->mean_lum;
        out[1] = sqrt(sm / R) / ref->mean_lum;
        out[2] = sqrt(fmax(0, d2 / n - v / n / R - vr / n));
        out[3] = sqrt(d2 / n);
        out[4] = sqrt(v / n);
    }
    free(img);
    free(s1);
    free(s2);
    return ok;
}

/* The hit rate of the runs behind a bias row: the mean over the rows of each run file
   (suffix ".csv", "_bias.csv", "_warm.csv"), averaged over the repeats; NaN if a file
   is missing. */
static double bias_hit_rate(const options *o, const scene *s, const reference *ref,
                            const char *cond, const char *csv_suffix)
{
    double sum = 0;
    for (int k = 0; k < o->repeats; k++) {
        char path[PATH_LEN];
        run r = {0};
        run_path(o, s, cond, k, csv_suffix, path);
        if (!run_load(o, path, ref, &r)) return NAN;
        double h = 0;
        for (size_t i = 0; i < r.n; i++) h += r.rows[i].hit_rate / r.n;
        sum += h / o->repeats;
        run_free(&r);
    }
    return sum;
}

/* One row of bias.csv/.md: condition cond's final images (file suffix "<kind>.lum"),
   shown as cond + label_suffix. */
static void write_bias_row(const writers *w, const scene *s, const reference *ref,
                           const char *cond, const char *kind, const char *label_suffix,
                           double run_ms)
{
    double b[5];
    const options *o = w->o;
    char lum[64], csv[64];
    snprintf(lum, sizeof lum, "%s.lum", kind);
    snprintf(csv, sizeof csv, "%s.csv", kind);
    if (!bias_one(o, s, ref, cond, lum, b)) return;
    double hit = bias_hit_rate(o, s, ref, cond, csv);
    fprintf(w->bcsv, "%s,%s,%ux%u,%s%s,%d,%.1f,%.5f,%.5f,%.6g,%.6g,%.6g,%.6g,%.4f\n",
            s->ds->name, s->lights, s->width, s->height, cond, label_suffix, o->repeats,
            run_ms / 1e3, b[0], b[1], b[2], b[3], b[4], ref->rmse, hit);
    char rms[64];
    if (b[2] > 0) snprintf(rms, sizeof rms, "%.3g", b[2]);
    else snprintf(rms, sizeof rms, "below the noise");
    fprintf(w->bmd, "| %s | %s | %ux%u | %s%s | %.0f | %d | %.2f | %+.2f%% +- %.2f%% | %s | %.3g "
            "| %.3g | %.2g |\n", s->ds->name, s->lights, s->width, s->height, cond,
            label_suffix, run_ms / 1e3, o->repeats, hit, 100 * b[0], 100 * b[1], rms, b[3],
            b[4], ref->rmse);
}

static void write_bias(const writers *w, const scene *s, const scene_result *r)
{
    const options *o = w->o;
    if (!in_list(o->bias, s->ds->name) || o->repeats < 2) return;
    reference ref;
    if (!ref_open(o, s, &ref)) return;
    double warm_len = o->bias_ms > 0 ? o->bias_ms : o->run_ms;
    if (o->bias_ms > 0)
        for (int c = 0; c < N_BIAS_CONDITIONS; c++)
            write_bias_row(w, s, &ref, BIAS_CONDITIONS[c], "_bias", "", o->bias_ms);
    else
        for (int c = 0; c < r->n_conds; c++)
            write_bias_row(w, s, &ref, r->conds[c]->name, "", "", o->run_ms);
    if (o->warm_ms > 0)
        for (int c = 1; c < N_BIAS_CONDITIONS; c++)
            write_bias_row(w, s, &ref, BIAS_CONDITIONS[c], "_warm", "-warm", warm_len);
    fflush(w->bcsv);
    fflush(w->bmd);
    ref_close(&ref);
}

static FILE *open_out(const options *o, const char *name, const char *header)
{
    char path[PATH_LEN];
    snprintf(path, sizeof path, "%s/%s", o->out_dir, name);
    FILE *f = fopen(path, "w");
    if (!f) { fail("cannot write %s: %s", path, strerror(errno)); return NULL; }
    fputs(header, f);
    return f;
}

static int open_writers(const options *o, writers *w)
{
    char head[1024];
    snprintf(head, sizeof head,
             "%.0f s per run in %.0f ms slices, %d repeats (seeds %u..%u), time = wall time "
             "inside picvr_step; machine and date at the end.\n\n",
             o->run_ms / 1e3, o->slice_ms, o->repeats, RUN_SEED0, RUN_SEED0 + o->repeats - 1);
    memset(w, 0, sizeof *w);
    w->o = o;
    w->t2csv = open_out(o, "table2.csv", "dataset,lights,background,size,condition,ratio_true,"
                        "ratio_est,repeats,ratio_true_min,ratio_true_max,ratio_est_min,"
                        "ratio_est_max,ratio_true_rel,ratio_est_rel,run_s,final_rmse_plain,"
                        "final_rmse_cached,final_hit_rate\n");
    w->t2md = open_out(o, "table2.md", "");
    w->t3csv = open_out(o, "table3.csv", "dataset,lights,size,condition,run_s,entries,refs,"
                        "refs_per_entry,hit_rate,iterations\n");
    w->t3md = open_out(o, "table3.md", "");
    w->bcsv = open_out(o, "bias.csv", "dataset,lights,size,condition,repeats,run_s,"
                       "rel_mean_bias,rel_mean_bias_stderr,rms_bias,rms_total,rms_noise,"
                       "ref_rmse,hit_rate\n");
    w->bmd = open_out(o, "bias.md", "");
    if (!w->t2csv || !w->t2md || !w->t3csv || !w->t3md || !w->bcsv || !w->bmd) return 0;
    fprintf(w->t2md, "%s| dataset | lights | background | size | condition | ratio true RMSE "
            "(min-max) | ratio est_error (min-max) | ratio true rel. | ratio est. rel. | "
            "final RMSE plain | final RMSE cached | final hit rate |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|\n", head);
    fprintf(w->t3md, "%s| dataset | lights | size | condition | run s | entries | refs | "
            "refs/entry | hit rate | iterations |\n|---|---|---|---|---|---|---|---|---|---|\n",
            head);
    char warm[256] = "";
    if (o->warm_ms > 0)
        snprintf(warm, sizeof warm, "Rows \"-warm\": the cache was first filled for %.0f s "
                 "with creation at a %.2f share of the time, then the image restarted at the default shares (Table 1).\n\n",
                 o->warm_ms / 1e3, PVP_WARM_CREATE_SHARE);
    fprintf(w->bmd, "%s%s| dataset | lights | size | condition | run s | seeds | mean hit rate | "
            "mean luminance vs ref (+- s.e.) | RMS bias | RMS total (mean of seeds) | RMS noise "
            "(one seed) | RMSE of ref |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
            head, warm);
    return 1;
}

static void close_writers(writers *w, const char *device)
{
    char from[64] = "-", to[64] = "-", cache[256];
    cache_options_text(&w->o->cache, cache, sizeof cache);
    if (first_run_time) strftime(from, sizeof from, "%Y-%m-%d %H:%M", gmtime(&first_run_time));
    if (last_run_time) strftime(to, sizeof to, "%Y-%m-%d %H:%M UTC", gmtime(&last_run_time));
    FILE *md[3] = {w->t2md, w->t3md, w->bmd};
    for (int i = 0; i < 3; i++)
        if (md[i])
            fprintf(md[i], "\nRuns measured %s to %s on %ld CPU(s); device: %s; library "
                    "build %s (checksum of picvr.h, picvr_vk.c, shaders/); cache options: "
                    "%s (others: the library's defaults).\n", from, to,
                    sysconf(_SC_NPROCESSORS_ONLN), device, PICVR_BENCH_BUILD, cache);
    FILE *all[6] = {w->t2csv, w->t2md, w->t3csv, w->t3md, w->bcsv, w->bmd};
    for (int i = 0; i < 6; i++)
        if (all[i]) fclose(all[i]);
}

/* ---- self-test of the harness's arithmetic (--self-test; run by make bench) ---------- */

static int expect(int ok, const char *what)
{
    if (!ok) fail("self-test: %s", what);
    return ok;
}

/* Two runs whose errors are 2/sqrt(t) and 1/sqrt(t), sampled at different times: the
   ratio at equal time is 2 (within the interpolation error, < 0.5%). */
static int self_test_ratio(void)
{
    run a = {0}, b = {0};
    int ok = 1;
    for (int i = 1; ok && i <= 50; i++) {
        row x = {0}, y = {0};
        x.t_ms = 200.0 * i;
        y.t_ms = 330.0 * i;
        x.rmse = x.est = 2 / sqrt(x.t_ms);
        y.rmse = y.est = 1 / sqrt(y.t_ms);
        ok = run_push(&a, &x) && run_push(&b, &y);
    }
    double q = ok ? mean_ratio(&a, &b, F_RMSE) : NAN;
    run_free(&a);
    run_free(&b);
    return expect(fabs(q - 2) < 0.01, "mean_ratio of 2/sqrt(t) over 1/sqrt(t) is not 2");
}

/* One pixel, four chunks of n = 10 with means 1, 2, 3, 4: weighted mean 2.5, per-sample
   variance n * sum (m - 2.5)^2 / 3 = 50 / 3, variance of the mean (50/3) / 40. */
static int self_test_reference(void)
{
    reference r = {0};
    double s1 = 0, s2 = 0, lum, var;
    r.width = r.height = 1;
    r.lum = &lum;
    r.var = &var;
    r.chunks = 4;
    r.iterations = 40;
    for (int k = 1; k <= 4; k++) { s1 += 10.0 * k; s2 += 10.0 * k * k; }
    ref_finish(&r, &s1, &s2);
    return expect(fabs(lum - 2.5) < 1e-12, "reference mean") &&
           expect(fabs(var - 50.0 / 3.0 / 40.0) < 1e-12, "reference variance") &&
           expect(fabs(r.rmse - sqrt(50.0 / 3.0 / 40.0)) < 1e-12, "reference RMSE");
}

/* An image equal to the reference but 1 brighter in one pixel of four. */
static int self_test_compare(void)
{
    double ref_lum[4] = {1, 1, 1, 1}, ref_var[4] = {0};
    float lum[4] = {2, 1, 1, 1};
    reference r = {0};
    r.width = 2;
    r.height = 2;
    r.lum = ref_lum;
    r.var = ref_var;
    r.mean_lum = 1;
    errors e = compare(lum, &r);
    return expect(fabs(e.rmse - 0.5) < 1e-12, "RMSE") &&
           expect(fabs(e.rel_rmse - 0.5 / 1.01) < 1e-12, "relative RMSE");
}

/* Writes a finished one-row run file whose first line is `sig`. */
static int write_test_run(const char *path, const char *sig)
{
    FILE *f = fopen(path, "w");
    if (!f) return 0;
    fprintf(f, "%s\n%s\n200,1,0.1,0.2,0.1,0.2,0.5,0.04,10,100,0\n# done\n", sig, ROW_HEADER);
    return fclose(f) == 0;
}

/* Whether run_load with options o accepts the file at path (freeing what it read). */
static int test_run_loads(const options *o, const char *path, const reference *r)
{
    run x = {0};
    int ok = run_load(o, path, r, &x);
    run_free(&x);
    return ok;
}

/* A run file is reused only by a build and cache options that match its signature. */
static int self_test_signature(void)
{
    char path[PATH_LEN], sig[512];
    snprintf(path, sizeof path, "/tmp/picvr-bench-self-test-%ld.csv", (long)getpid());
    options on = {0}, off = {0}, finer = {0}, smaller = {0};
    on.cache.medium_model = PICVR_SWITCH_ON;
    off.cache.medium_model = PICVR_SWITCH_OFF;
    finer.cache.medium_model = PICVR_SWITCH_ON;
    smaller.cache.medium_model = PICVR_SWITCH_ON;
    int parsed = pvp_cache_param_set(&finer.cache, "gamma=0.05") == PVP_OK &&
                 pvp_cache_param_set(&smaller.cache, "radius_max_voxels=4") == PVP_OK &&
                 finer.cache.gamma == 0.05f && smaller.cache.radius_max_voxels == 4.0f &&
                 pvp_cache_param_set(&finer.cache, "gamma=0") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gamma=") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gamma") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gamma=1e39") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gamma=nan") == PVP_ERROR_BAD_ARGUMENT &&
                 pvp_cache_param_set(&finer.cache, "gam=0.1") == PVP_ERROR_UNKNOWN_NAME &&
                 pvp_cache_param_set(&finer.cache, "gamma=0.1x") == PVP_ERROR_BAD_ARGUMENT &&
                 finer.cache.gamma == 0.05f;
    reference r = {0};
    r.chunks = 3;
    r.iterations = 300;
    run_signature(&on, &r, sig, sizeof sig);
    int written = write_test_run(path, sig);
    int same = written && test_run_loads(&on, path, &r);
    int other = written && test_run_loads(&off, path, &r);
    int other_gamma = written && test_run_loads(&finer, path, &r);
    int other_radius = written && test_run_loads(&smaller, path, &r);
    /* a file from before the build was part of the signature */
    written = written && write_test_run(path, "# reference 3 chunks 300 iterations");
    int older = written && test_run_loads(&on, path, &r);
    remove(path);
    return expect(written, "cannot write the self-test's run file") &&
           expect(same, "a run file with the same signature is not reused") &&
           expect(!other, "a run file of other cache options is reused") &&
           expect(parsed, "--cache-param is parsed wrongly") &&
           expect(!other_gamma, "a run file of another gamma is reused") &&
           expect(!other_radius, "a run file of another radius_max_voxels is reused") &&
           expect(!older, "a run file without the library's build is reused");
}

/* The fingerprint that keys the references is the same on every call and tells scenes
   apart (a 16^3 sphere of density, 16x16 pixels, so it runs in the test suite). */
static int self_test_fingerprint(void)
{
    enum { N = 16 };
    static uint8_t voxels[N * N * N];
    for (int z = 0; z < N; z++)
        for (int y = 0; y < N; y++)
            for (int x = 0; x < N; x++) {
                double r = sqrt((x - 7.5) * (x - 7.5) + (y - 7.5) * (y - 7.5) + (z - 7.5) * (z - 7.5));
                voxels[(z * N + y) * N + x] = (uint8_t)(r < 6.0 ? 200 - 20 * r : 0);
            }
    pvio_volume vol = {{N, N, N}, PICVR_VOXEL_UINT8, {1, 1, 1}, voxels, sizeof voxels};
    dataset_spec ds = {"sphere", "sphere_16x16x16_uint8.raw", "ct-bonsai", 1.0f};
    options o = {0};
    o.width = o.height = 16;
    const float camera[4] = {35, 20, 1, 40};
    scene a, b;
    scene_init(&a, &ds, "paper1", &o, camera);
    scene_init(&b, &ds, "paper3", &o, camera);
    uint64_t fa = 0, fa2 = 1, fb = 0;
    int rendered = plain_fingerprint(&a, &vol, &fa) && plain_fingerprint(&a, &vol, &fa2) &&
                   plain_fingerprint(&b, &vol, &fb);
    return expect(rendered, "the fingerprint render failed") &&
           expect(fa == fa2, "the plain fingerprint differs between two renders") &&
           expect(fa != fb, "two light set-ups have the same plain fingerprint");
}

/* Whether no --cache-param number is set. */
static int params_unset(const picvr_cache_config *c)
{
    for (size_t i = 0; pvp_cache_param_name(i); i++)
        if (pvp_cache_param_get(c, i) != 0) return 0;
    return 1;
}

/* Without options every setting is its documented default (--help). */
static int self_test_defaults(void)
{
    char *argv[] = {PROGRAM, NULL};
    options o;
    return expect(parse_args(1, argv, &o), "no options are refused") &&
           expect(o.cache.medium_model == PICVR_SWITCH_DEFAULT &&
                  o.cache.curvature_limit == PICVR_SWITCH_DEFAULT &&
                  params_unset(&o.cache),
                  "the cache options are not the library's defaults") &&
           expect(o.repeats == 2 && o.ref_max_chunks == 200 && o.run_ms == 10000 &&
                  o.slice_ms == 200 && o.ref_chunk_ms == 60000 && o.warm_ms == 0 &&
                  o.bias_ms == 0 && o.width == 128 && o.height == 128,
                  "the defaults differ from --help");
}

static int self_test(void)
{
    int ok = self_test_ratio() & self_test_reference() & self_test_compare() &
             self_test_signature() & self_test_defaults() & self_test_fingerprint();
    fprintf(stderr, PROGRAM ": self-test %s\n", ok ? "passed" : "FAILED");
    return ok;
}

/* ---- main ----------------------------------------------------------------------------------------------- */

static int select_conditions(const options *o, scene_result *r)
{
    r->n_conds = 0;
    for (int i = 0; i < N_CONDITIONS; i++)
        if (in_list(o->conditions, CONDITIONS[i].name)) r->conds[r->n_conds++] = &CONDITIONS[i];
    return r->n_conds;
}

static void device_name(char *out, size_t size)
{
    picvr_context *ctx;
    picvr_config cfg = {0};
    snprintf(out, size, "unknown");
    if (picvr_create(&cfg, &ctx) != PICVR_OK) return;
    picvr_stats st;
    if (picvr_get_stats(ctx, &st) == PICVR_OK) snprintf(out, size, "%s", st.device_name);
    picvr_destroy(ctx);
}

static int load_dataset(const options *o, const dataset_spec *d, pvio_volume *vol)
{
    char path[PATH_LEN], err[256];
    snprintf(path, sizeof path, "%s/%s", o->data_dir, d->file);
    if (pvio_load(path, NULL, vol, err, sizeof err) != PVIO_OK) {
        fail("%s: %s", path, err);
        return 0;
    }
    vol->spacing[0] = vol->spacing[1] = vol->spacing[2] = d->spacing;
    return 1;
}

/* Sets up scene s of dataset d and light set-up `lights`, with its reference key. */
static int scene_open(const options *o, const scene_file *sf, const dataset_spec *d,
                      const char *lights, const pvio_volume *vol, scene *s)
{
    uint64_t fingerprint;
    scene_init(s, d, lights, o, sf->camera);
    if (!plain_fingerprint(s, vol, &fingerprint)) return 0;
    scene_key(s, fingerprint);
    return 1;
}

/* --list: the selected scenes and their reference folders (renders each fingerprint). */
static int list_scenes(const options *o, const scene_file *sf)
{
    for (int d = 0; d < sf->n_datasets; d++) {
        if (!in_list(o->datasets, sf->datasets[d].name)) continue;
        pvio_volume vol;
        if (!load_dataset(o, &sf->datasets[d], &vol)) return 0;
        int ok = 1;
        for (int l = 0; ok && l < sf->n_lights; l++) {
            if (!in_list(o->lights, sf->lights[l])) continue;
            scene s;
            ok = scene_open(o, sf, &sf->datasets[d], sf->lights[l], &vol, &s);
            if (ok) printf("%s %s/%s\n", s.id, o->refs_dir, s.hash);
        }
        pvio_free(&vol);
        if (!ok) return 0;
    }
    return 1;
}

int main(int argc, char **argv)
{
    options o;
    scene_file sf;
    if (!parse_args(argc, argv, &o)) return EXIT_USAGE;
    if (!read_scene_file(o.scenes_path, &sf)) return EXIT_USAGE;
    if (o.list) return list_scenes(&o, &sf) ? 0 : 1;
    char runs_dir[PATH_LEN];
    snprintf(runs_dir, sizeof runs_dir, "%s/runs", o.out_dir);
    if (!make_dirs(runs_dir) || !make_dirs(o.refs_dir)) {
        fail("cannot create %s or %s", runs_dir, o.refs_dir);
        return 1;
    }
    static scene_result res;
    int n_scenes = 0, n_fig10 = 0;
    select_conditions(&o, &res);
    for (int d = 0; d < sf.n_datasets; d++) {
        int first = 1;
        for (int l = 0; l < sf.n_lights; l++) {
            if (!in_list(o.datasets, sf.datasets[d].name) || !in_list(o.lights, sf.lights[l]))
                continue;
            n_scenes++;
            n_fig10 += first && o.rotate_ms > 0 && in_list(o.fig10, sf.datasets[d].name);
            first = 0;
        }
    }
    count_total = (n_scenes * res.n_conds + 2 * n_fig10) * o.repeats;
    int per_bias_scene = (o.bias_ms > 0 ? N_BIAS_CONDITIONS : 0) +
                         (o.warm_ms > 0 ? N_WARM_CONDITIONS : 0);
    if (per_bias_scene)
        for (int d = 0; d < sf.n_datasets; d++)
            for (int l = 0; l < sf.n_lights; l++)
                count_total += per_bias_scene * o.repeats *
                               (in_list(o.datasets, sf.datasets[d].name) &&
                                in_list(o.lights, sf.lights[l]) &&
                                in_list(o.bias, sf.datasets[d].name));
    fprintf(stderr, PROGRAM ": %d scenes x %d conditions x %d repeats at %ux%u, %.0f s each\n",
            n_scenes, res.n_conds, o.repeats, o.width, o.height, o.run_ms / 1e3);

    char device[256];
    device_name(device, sizeof device);
    writers w;
    if (!open_writers(&o, &w)) return 1;
    int ok = 1, refused = 0;
    for (int d = 0; ok && d < sf.n_datasets; d++) {
        if (!in_list(o.datasets, sf.datasets[d].name)) continue;
        pvio_volume vol;
        if (!(ok = load_dataset(&o, &sf.datasets[d], &vol))) break;
        int first = 1;
        for (int l = 0; ok && l < sf.n_lights; l++) {
            if (!in_list(o.lights, sf.lights[l])) continue;
            scene s;
            if (!(ok = scene_open(&o, &sf, &sf.datasets[d], sf.lights[l], &vol, &s))) break;
            fprintf(stderr, "scene %s (reference %s/%s)\n", s.id, o.refs_dir, s.hash);
            char fig10_list[NAME_LEN * 2];
            snprintf(fig10_list, sizeof fig10_list, "%s", first && o.fig10 ? o.fig10 : "");
            options so = o;
            so.fig10 = fig10_list;        /* Fig. 10 for the first light set-up only */
            first = 0;
            ok = run_scene(&so, &s, &vol, &res);
            if (ok && res.refused) refused = 1;
            if (ok && !res.refused) {
                write_table2(&w, &s, &res);
                write_table3(&w, &s, &res);
                write_bias(&w, &s, &res);
                write_fig11(&o, &s, &res);
                if (res.have_rot) write_fig10(&o, &s, &res);
            }
            res.have_rot = 0;
            free_result(&res, o.repeats);
        }
        pvio_free(&vol);
    }
    close_writers(&w, device);
    if (!ok) return 1;
    fprintf(stderr, PROGRAM ": results in %s\n", o.out_dir);
    return refused ? EXIT_REFUSED : 0;
}
