/* bench_error.h - the internal interface between the files of picvr-bench-error
 * (bench/error/): its options, the scene matrix, the converged references, the runs
 * measured against them and the tables and figures drawn from those runs.  What the
 * program measures and writes is described at the top of main.c.
 *
 *   main.c        options, the driver over the scene matrix, --list
 *   scenes.c      conditions, the scene file, scenes, contexts, the plain fingerprint
 *   references.c  the converged references (PFM chunks in REFS/<hash>/)
 *   runs.c        running, resuming and signing runs; growing the reference
 *   tables.c      equal-time ratios, tables, CSV, Markdown, gnuplot scripts
 *   selftest.c    --self-test: the harness's arithmetic and bookkeeping
 */
#ifndef PICVR_BENCH_ERROR_H
#define PICVR_BENCH_ERROR_H

#include <stdint.h>
#include <stdio.h>
#include <time.h>

#include "picvr.h"
#include "picvr_io.h"

#define PROGRAM "picvr-bench-error"
#define EXIT_USAGE 2
#define EXIT_REFUSED 3
#define MAX_DATASETS 16
#define MAX_LIGHTS 16
#define MAX_REPEATS 32
#define NAME_LEN 64
#define PATH_LEN 1024
#define REF_MIN_CHUNKS 4
#define REF_SEED0 1001u
#define FINGERPRINT_SEED 7u    /* plain_fingerprint: a seed no chunk or run uses */
#define FINGERPRINT_ITERATIONS 4u
#define RUN_SEED0 101u
#define FLOOR_FRACTION 1e-2    /* relative error floor, fraction of the mean */
#define GRID_POINTS 200        /* equal-time grid of the ratio average */
#define REF_ROUNDS 3           /* grow-the-reference attempts per scene */
#define N_CONDITIONS 8         /* rows of CONDITIONS */
#define N_BIAS_CONDITIONS 3    /* rows of BIAS_CONDITIONS */
#define N_WARM_CONDITIONS 2    /* BIAS_CONDITIONS[1..2] */
/* The library's sources this binary was built from (the Makefile passes a checksum of
   picvr.h, picvr_vk.c and shaders/): part of every run file's signature, so that a
   finished run is never reused by a build whose cache or scheduler behaves otherwise. */
#ifndef PICVR_BENCH_BUILD
#define PICVR_BENCH_BUILD "unknown"
#endif

/* Luminance Y = 0.2126 R + 0.7152 G + 0.0722 B of a linear RGB pixel. */
static inline double luminance(const float *rgb)
{
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

/* ---- options (main.c) -------------------------------------------------------------- */

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
    int repeats, ref_min_chunks, ref_max_chunks;
    double ref_factor;         /* --ref-factor: the reference's error this far below the runs' */
    int list;                  /* --list: print the scenes and their reference folders */
    int self_test;             /* --self-test: check the harness and exit */
} options;

/* Parses the command line into *o (defaults first).  Returns -1 to go on, else the
   exit status: 0 after --help, EXIT_USAGE after a reported error. */
int parse_args(int argc, char **argv, options *o);

/* ---- conditions, scenes and contexts (scenes.c) ------------------------------------- */

typedef struct condition {
    const char *name;
    picvr_cache_mode mode;
    picvr_switch priorities;
    uint32_t lookup_event;     /* cache.lookup_event; 0: --cache-param's or the library's */
} condition;

extern const condition CONDITIONS[N_CONDITIONS];
const condition *find_condition(const char *name);   /* NULL: no such condition */

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

int read_scene_file(const char *path, scene_file *sf);

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
void scene_init(scene *s, const dataset_spec *ds, const char *lights, const options *o,
                const float camera[4]);
/* The key of the scene's reference folder: the scene description and the plain
   renderer's fingerprint. */
void scene_key(scene *s, uint64_t fingerprint);

/* Whether the light set-up's name ends in "-bg"; its name without "-bg". */
int lights_have_background(const char *lights);
void lights_base(const char *lights, char *out, size_t size);

typedef struct session {
    picvr_context *ctx;
    picvr_camera camera;       /* the scene's camera (the lights are placed for it) */
    float box_min[3], box_max[3];
} session;

int session_open(const scene *s, const picvr_io_volume *vol, const condition *c, uint32_t seed,
                 float create_share, const picvr_cache_config *cache, session *ss);
void session_close(session *ss);

/* The scene's orbit camera turned to `azimuth` degrees. */
int orbit(const scene *s, const session *ss, float azimuth, picvr_camera *cam);

/* Reads the linear image into rgba and reduces it to luminance (rows top to bottom). */
int read_luminance(picvr_context *ctx, uint32_t w, uint32_t h, float *rgba, float *lum);

int plain_fingerprint(const scene *s, const picvr_io_volume *vol, uint64_t *out);

/* ---- references (references.c) ------------------------------------------------------- */

typedef struct reference {
    uint32_t width, height, chunks;
    uint64_t iterations;
    double *lum;               /* iteration-weighted mean luminance per pixel */
    double *var;               /* estimated variance of that mean per pixel */
    double mean_lum, rmse, rel_rmse;
    char dir[PATH_LEN];
} reference;

/* Opens (creating its folder) and loads the chunks there are of scene s's reference. */
int ref_open(const options *o, const scene *s, reference *r);
void ref_close(reference *r);
/* Loads the chunks there are in r->dir (r->width, r->height, r->lum and r->var set). */
int ref_load(reference *r);
/* Renders chunks up to `chunks` in all, then loads the reference again. */
int ref_grow(const options *o, const scene *s, const picvr_io_volume *vol, reference *r,
             uint32_t chunks);
/* The mean and error of the reference from the per-pixel sums over its chunks. */
void ref_finish(reference *r, const double *s1, const double *s2);

int make_dirs(const char *path);
int file_exists(const char *path);

/* ---- runs (runs.c) --------------------------------------------------------------------- */

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

#define ROW_HEADER "t_ms,iterations,rmse,rel_rmse,est_error,est_rel_error,hit_rate," \
                   "mean_luminance,entries,refs,moving"

int run_push(run *r, const row *x);
void run_free(run *r);
void write_row(FILE *f, const row *x);

/* The cache's options as text, e.g. "medium default; curvature on; gamma 0.05" (the
   --cache-param numbers that are set, in table order): part of run signatures. */
void cache_options_text(const picvr_cache_config *c, char *out, size_t size);
/* What a run file was measured with: its first line. */
void run_signature(const options *o, const reference *r, char *out, size_t size);
/* Loads a finished run file measured with this signature; 0 if there is none. */
int run_load(const options *o, const char *path, const reference *ref, run *out);

typedef struct errors { double rmse, rel_rmse; } errors;
errors compare(const float *lum, const reference *ref);

/* OUT/runs/<scene id>_<hash>_<condition>_r<repeat><suffix>. */
void run_path(const options *o, const scene *s, const char *cond, int rep, const char *suffix,
              char *out);

/* The conditions of the separate bias runs: plain (the control) and both lockings. */
extern const char *const BIAS_CONDITIONS[N_BIAS_CONDITIONS];

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

void free_result(scene_result *r, int repeats);

/* The progress counter "[done/total]": the number of runs the matrix holds. */
void set_run_count(int total);
/* When the runs behind the tables were measured (0: none): their files' times. */
void run_times(time_t *first, time_t *last);

/* Runs a scene against its reference, growing or refusing the reference (runs.c). */
int run_scene(const options *o, const scene *s, const picvr_io_volume *vol, scene_result *res);

/* ---- tables and figures (tables.c) ---------------------------------------------------- */

enum field { F_RMSE, F_REL, F_EST, F_EST_REL };

/* The ratio a/b of two runs' errors, averaged over equal times. */
/* Table 2's ratio_true_worst: the smallest ratio plain (runs[0]) / condition c over the
   equal-time grid, each time's errors the geometric mean over the repeats. */
double worst_ratio(const scene_result *r, int c, int repeats, enum field f);
double mean_ratio(const run *a, const run *b, enum field f);

typedef struct writers {
    FILE *t2csv, *t2md, *t3csv, *t3md, *bcsv, *bmd;
    const options *o;
    const char *device;        /* the device's name, Table 2's column */
} writers;

int open_writers(const options *o, writers *w, const char *device);
void close_writers(writers *w, const char *device);
/* Every output of a scene that was not refused: Table 2, Table 3, bias, Fig. 11 and,
   when it has rotation runs, Fig. 10. */
void write_scene_outputs(const writers *w, const scene *s, const scene_result *r);

/* ---- --self-test (selftest.c) ---------------------------------------------------------- */

int self_test(void);

#endif /* PICVR_BENCH_ERROR_H */
