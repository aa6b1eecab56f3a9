/* runs.c - picvr-bench-error's runs: per condition and repeat, a fresh context (empty
 * cache) rendered with picvr_step in slices, each slice measured against the scene's
 * reference and appended to OUT/runs/<scene>_<hash>_<condition>_r<repeat>.csv, whose
 * first line (its signature: the reference, the library build, the cache options)
 * decides whether a later invocation may reuse the finished file.  run_scene grows the
 * reference until it is converged enough for the errors measured against it.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "bench_error.h"
#include "cli.h"
#include "picvr.h"
#include "presets.h"

/* ---- rows and run files ------------------------------------------------------------------ */

int run_push(run *r, const row *x)
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

void run_free(run *r)
{
    free(r->rows);
    memset(r, 0, sizeof *r);
}

void write_row(FILE *f, const row *x)
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
void cache_options_text(const picvr_cache_config *c, char *out, size_t size)
{
    int n = snprintf(out, size, "medium %s; curvature %s", pvc_switch_name(c->medium_model),
                     pvc_switch_name(c->curvature_limit));
    for (size_t i = 0; pvp_cache_param_name(i) && n > 0 && (size_t)n < size; i++)
        if (pvp_cache_param_get(c, i) > 0)
            n += snprintf(out + n, size - (size_t)n, "; %s %g", pvp_cache_param_name(i),
                          pvp_cache_param_get(c, i));
}

/* What a run file was measured with: the reference, the library build and the cache
   options (--medium, --curvature, --cache-param).  A file whose first line differs is
   run again. */
void run_signature(const options *o, const reference *r, char *out, size_t size)
{
    char cache[256];
    cache_options_text(&o->cache, cache, sizeof cache);
    snprintf(out, size, "# reference %u chunks %llu iterations (its variance removed); library %s; %s", r->chunks,
             (unsigned long long)r->iterations, PICVR_BENCH_BUILD, cache);
}

/* Loads a finished run file measured with this signature; 0 if there is none. */
int run_load(const options *o, const char *path, const reference *ref, run *out)
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

errors compare(const float *lum, const reference *ref)
{
    size_t n = (size_t)ref->width * ref->height;
    double floor = FLOOR_FRACTION * ref->mean_lum, se = 0, sr = 0;
    for (size_t i = 0; i < n; i++) {
        double e = lum[i] - ref->lum[i], d = ref->lum[i] + floor, rel = e / d;
        se += e * e - ref->var[i];
        sr += rel * rel - ref->var[i] / (d * d);
    }
    errors out = {sqrt(fmax(se / n, 0.0)), sqrt(fmax(sr / n, 0.0))};
    return out;
}

/* ---- one run ------------------------------------------------------------------------------- */

typedef struct run_spec {
    const scene *s;
    const picvr_io_volume *vol;
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
    if (!pvc_check(picvr_get_stats(ss->ctx, &st), "picvr_get_stats")) return 0;
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
    double t = pvc_now_ms();
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

/* The final luminance image: n float32, little-endian, rows top to bottom. */
static int write_luminance(const char *path, const float *lum, size_t n)
{
    FILE *f = fopen(path, "wb");
    int ok = f && pvc_write_floats_le(f, lum, n);
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
             pvc_check(picvr_set_camera(ss->ctx, &cam), "picvr_set_camera");
        double t0 = pvc_now_ms();
        ok = ok && pvc_check(picvr_step(ss->ctx, o->slice_ms), "picvr_step");
        t += pvc_now_ms() - t0;
        ok = ok && measure(rs, ss, t, moving, rgba, lum, &x) && run_push(out, &x);
        if (ok) { write_row(f, &x); fflush(f); progress(rs, &x, total, 0); }
    }
    if (ok) progress(rs, &x, total, 1);
    if (ok && rs->lum_path && !write_luminance(rs->lum_path, lum, n)) {
        pvc_fail("cannot write %s", rs->lum_path);
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

void run_times(time_t *first, time_t *last)
{
    *first = first_run_time;
    *last = last_run_time;
}

/* --bias-warm: fills the cache for rs->warm_ms with creation at PVP_WARM_CREATE_SHARE, then
   restarts the image at the library's default shares (Table 1); picvr_set_scheduler and
   picvr_reset keep the cache.  The run that follows measures the image of a full cache
   (the state a GPU reaches quickly, the paper's §8, and a CPU device only after a long
   time at the default creation share) and its error against time as an application
   would see it after filling the cache while the scene loads.  The measured part runs
   at the default shares, so that its iterations compare with plain Monte Carlo's. */
static int warm_up(const run_spec *rs, session *ss)
{
    double t = 0;
    picvr_stats st = {0};
    while (t < rs->warm_ms) {
        double t0 = pvc_now_ms();
        if (!pvc_check(picvr_step(ss->ctx, fmin(1000.0, rs->warm_ms - t)), "picvr_step")) return 0;
        t += pvc_now_ms() - t0;
        if (!pvc_check(picvr_get_stats(ss->ctx, &st), "picvr_get_stats")) return 0;
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
    return pvc_check(picvr_set_scheduler(ss->ctx, &defaults), "picvr_set_scheduler") &&
           pvc_check(picvr_reset(ss->ctx), "picvr_reset");
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
    if (!ok) pvc_fail("run %s failed", rs->path);
    else note_run_time(rs->path);
    session_close(&ss);
    return ok;
}

/* ---- a scene's runs ------------------------------------------------------------------------ */

void free_result(scene_result *r, int repeats)
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

void run_path(const options *o, const scene *s, const char *cond, int rep,
                     const char *suffix, char *out)
{
    snprintf(out, PATH_LEN, "%s/runs/%s_%s_%s_r%d%s", o->out_dir, s->id, s->hash, cond, rep,
             suffix);
}

/* The progress counter "[done/total]" of the run labels. */
static int count_done, count_total;

void set_run_count(int total) { count_total = total; }

/* One condition's repeats of a scene, each run (or loaded, when finished) in turn. */
typedef struct repeat_set {
    const condition *c;
    const char *suffix;       /* of the files: ..._r<k><suffix>.csv and .lum */
    const char *label;        /* in the progress lines, between the scene and r<k> */
    int keep_lum;             /* write the final luminance image (.lum) */
    int rotate;               /* Fig. 10 */
    double length_ms, warm_ms; /* as in run_spec */
} repeat_set;

/* Runs o->repeats repeats into runs[] (NULL: each is dropped once its file is done). */
static int run_repeats(const options *o, const scene *s, const picvr_io_volume *vol,
                       const reference *ref, const repeat_set *set, run *runs)
{
    for (int k = 0; k < o->repeats; k++) {
        char path[PATH_LEN], lum[PATH_LEN], label[256], suffix[64];
        snprintf(suffix, sizeof suffix, "%s.csv", set->suffix);
        run_path(o, s, set->c->name, k, suffix, path);
        snprintf(suffix, sizeof suffix, "%s.lum", set->suffix);
        run_path(o, s, set->c->name, k, suffix, lum);
        snprintf(label, sizeof label, "[%d/%d] %s %s r%d", ++count_done, count_total, s->id,
                 set->label, k);
        run_spec rs = {s, vol, ref, set->c, k, set->rotate, path, set->keep_lum ? lum : NULL,
                       label, set->length_ms, set->warm_ms};
        run dropped = {0}, *out = runs ? &runs[k] : &dropped;
        run_free(out);
        int ok = do_run(o, &rs, out);
        run_free(&dropped);
        if (!ok) return 0;
    }
    return 1;
}

/* Table 2's matrix: every selected condition; the final images kept for the bias
   split unless it has runs of its own (--bias-time). */
static int run_all(const options *o, const scene *s, const picvr_io_volume *vol,
                   const reference *ref, scene_result *res)
{
    int keep_lum = pvc_in_list(o->bias, s->ds->name) && o->bias_ms <= 0;
    for (int c = 0; c < res->n_conds; c++) {
        repeat_set set = {res->conds[c], "", res->conds[c]->name, keep_lum, 0, 0, 0};
        if (!run_repeats(o, s, vol, ref, &set, res->runs[c])) return 0;
    }
    return 1;
}

/* Fig. 10: plain and object-space locking while the camera turns, then stops. */
static int run_rotations(const options *o, const scene *s, const picvr_io_volume *vol,
                         const reference *ref, scene_result *res)
{
    static const char *names[2] = {"plain", "object"};
    for (int c = 0; c < 2; c++) {
        char label[64];
        snprintf(label, sizeof label, "fig10 %s", names[c]);
        repeat_set set = {find_condition(names[c]), "_rotate", label, 0, 1, 0, 0};
        if (!run_repeats(o, s, vol, ref, &set, res->rot[c])) return 0;
    }
    res->have_rot = 1;
    return 1;
}

/* The conditions of the separate bias runs: plain (the control) and both lockings;
   with --bias-warm also both lockings from a full cache (rows "object-warm" etc.). */
const char *const BIAS_CONDITIONS[N_BIAS_CONDITIONS] = {"plain", "object", "screen"};

/* The bias runs: suffix "_bias" or, warm, "_warm" (files and bias.md rows). */
static int run_bias(const options *o, const scene *s, const picvr_io_volume *vol,
                    const reference *ref, int warm)
{
    double length = o->bias_ms > 0 ? o->bias_ms : o->run_ms;
    for (int c = warm ? 1 : 0; c < N_BIAS_CONDITIONS; c++) {
        char label[64];
        snprintf(label, sizeof label, "bias %s%s", BIAS_CONDITIONS[c], warm ? "-warm" : "");
        repeat_set set = {find_condition(BIAS_CONDITIONS[c]), warm ? "_warm" : "_bias", label,
                          1, 0, length, warm ? o->warm_ms : 0};
        if (!run_repeats(o, s, vol, ref, &set, NULL)) return 0;
    }
    return 1;
}

/* How many times the reference's error must shrink to lie --ref-factor below the
   smallest error measured against it (compare() already took the reference's own
   variance out of that error); at most 1: converged enough. */
static double reference_shortfall(const options *o, const reference *ref, scene_result *res, const scene *s,
                                  int repeats)
{
    smallest_errors(res, repeats, &res->smallest_rmse, &res->smallest_rel);
    double sm = fmax(res->smallest_rmse, 1e-15), sr = fmax(res->smallest_rel, 1e-15);
    double need = fmax(o->ref_factor * ref->rmse / sm, o->ref_factor * ref->rel_rmse / sr);
    fprintf(stderr, "  %s: reference RMSE %.3g (rel %.3g), smallest measured %.3g "
            "(rel %.3g): %.1fx below\n", s->id, ref->rmse, ref->rel_rmse,
            res->smallest_rmse, res->smallest_rel, o->ref_factor / need);
    return need;
}

/* Table 2's runs against ref, growing ref (and running again) until it is converged
   enough; res->refused when that would take more than --ref-max-chunks chunks or
   REF_ROUNDS rounds. */
static int run_converged(const options *o, const scene *s, const picvr_io_volume *vol,
                         reference *ref, scene_result *res)
{
    int base_done = count_done;
    for (int round = 0; round < REF_ROUNDS; round++) {
        count_done = base_done;
        if (!run_all(o, s, vol, ref, res)) return 0;
        double need = reference_shortfall(o, ref, res, s, o->repeats);
        res->refused = need > 1.0;
        if (!res->refused) return 1;
        uint32_t chunks = (uint32_t)ceil(ref->chunks * need * need * 1.1);
        if ((int)chunks > o->ref_max_chunks || round == REF_ROUNDS - 1) {
            pvc_fail("%s: the reference is not converged enough (needs %u chunks, limit %d): "
                     "left out of the tables", s->id, chunks, o->ref_max_chunks);
            return 1;
        }
        fprintf(stderr, "  growing the reference to %u chunks of %.0f s\n", chunks,
                o->ref_chunk_ms / 1e3);
        if (!ref_grow(o, s, vol, ref, chunks)) return 0;
    }
    return 1;
}

int run_scene(const options *o, const scene *s, const picvr_io_volume *vol, scene_result *res)
{
    reference ref;
    int ok = ref_open(o, s, &ref);
    uint32_t min_chunks = (uint32_t)o->ref_min_chunks;
    if (ok && ref.chunks < min_chunks) ok = ref_grow(o, s, vol, &ref, min_chunks);
    ok = ok && run_converged(o, s, vol, &ref, res);
    int bias = !res->refused && pvc_in_list(o->bias, s->ds->name);
    if (ok && !res->refused && o->rotate_ms > 0 && pvc_in_list(o->fig10, s->ds->name))
        ok = run_rotations(o, s, vol, &ref, res);
    if (ok && bias && o->bias_ms > 0) ok = run_bias(o, s, vol, &ref, 0);
    if (ok && bias && o->warm_ms > 0) ok = run_bias(o, s, vol, &ref, 1);
    ref_close(&ref);
    return ok;
}
