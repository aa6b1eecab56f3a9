/* main.c - picvr-bench-error: error against run time (the paper's §8, Table 2,
 * Table 3, Fig. 10, Fig. 11); its options and the driver over the scene matrix.
 *
 *   picvr-bench-error [--scenes bench/scenes.txt] [--data ../shared/data]
 *       [--datasets bonsai,engine] [--lights paper1,paper3-bg] [--size 128x128]
 *       [--conditions plain,object,object-noprio,screen,screen-noprio,plain-prio,auto,object-k2]
 *       [--time MS] [--slice MS] [--repeats N] [--rotate MS] [--after MS]
 *       [--ref-chunk MS] [--ref-min-chunks N] [--ref-max-chunks N] [--bias bonsai] [--fig10 bonsai]
 *       [--out bench/results] [--refs bench/refs]
 *
 * For every dataset x light set-up of the matrix ("scene"):
 *  1. a reference: plain Monte Carlo (cache off, priorities off), rendered as
 *     independent chunks with seeds 1001, 1002, ... and stored as luminance files
 *     (references.c) in REFS/<hash>/ where the hash is FNV-1a of the scene description (data file, TF,
 *     spacing, lights, size, camera; not the seed) and of the plain renderer's
 *     fingerprint (plain_fingerprint: a short deterministic render of the scene,
 *     hashed bit for bit).  The reference is the iteration-weighted mean of the
 *     chunks; its own per-pixel error is estimated from the spread between chunks
 *     (at least 4).  A reference whose RMSE (and relative RMSE) is not at least
 *     --ref-factor (10) times below the smallest error measured against it is grown (more chunks, then
 *     the runs are repeated against it) or, beyond --ref-max-chunks, refused: the
 *     scene is left out of the tables (exit status 3).
 *  2. runs: per condition and repeat (seed 101 + repeat), a fresh context (empty
 *     cache) rendered with picvr_step in slices; after each slice the time spent in
 *     picvr_step (wall clock), the true RMSE and relative RMSE of the luminance
 *     against the reference, the paper's estimate (stats.est_error, est_rel_error),
 *     hit rate, entries and references are recorded in
 *     OUT/runs/<scene>_<hash>_<cond>_rN.csv.  Finished run files are reused
 *     (resumable) as long as their signature (reference, library build, cache
 *     options) is the same.
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
 * sqrt(mean_p ((Y_p - Yref_p) / (Yref_p + 0.01 mean(Yref)))^2), all pixels, each
 * mean less the reference's own variance (var_p, from its chunks' spread): the
 * reference is independent of the run, so E[(Y - Yref)^2] = MSE(Y) + var(Yref), and
 * the difference is an unbiased estimate of the run's own mean squared error (taken
 * >= 0).  This lets a reference a few times below the runs' error serve (--ref-factor).
 *
 * The files of bench/error/ and what each holds: bench_error.h.
 *
 * Exit status: 0 ok, 1 runtime error, 2 usage error, 3 a reference was refused.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_error.h"
#include "cli.h"
#include "picvr.h"
#include "presets.h"
#include "picvr_io.h"

/* ---- options ---------------------------------------------------------------------------- */

static void print_help(FILE *f)
{
    fprintf(f,
        "usage: " PROGRAM " [options]   (see the comment at the top of bench/error/main.c)\n"
        "  --scenes FILE        scene file (default bench/scenes.txt)\n"
        "  --data DIR           data directory (default ../shared/data)\n"
        "  --datasets A,B       datasets of the scene file to run (default all)\n"
        "  --lights A,B         light set-ups of the scene file to run (default all)\n"
        "  --size WxH           image size (default 128x128)\n"
        "  --conditions A,B     of plain, object, object-noprio, screen, screen-noprio,\n"
        "                       plain-prio, auto, object-k2 (the multiply scattered\n"
        "                       cache at a path's second event; default the first five;\n"
        "                       plain is the baseline)\n"
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
        "                       radius_min_voxels, radius_max_voxels, update_threshold,\n"
        "                       lookup_event\n"
        "                       (repeatable; default: the library's, picvr.h)\n"
        "  --ref-chunk MS       time per reference chunk (default 60000)\n"
        "  --ref-min-chunks N   render at least N chunks before the runs (default 4, at\n"
        "                       least 4): for long runs, so that the reference need not\n"
        "                       grow after them (which repeats the runs)\n"
        "  --ref-max-chunks N   refuse a reference that needs more (default 200)\n"
        "  --ref-factor F       the reference's RMSE at least F times below the smallest\n"
        "                       error measured against it (default 10; the errors have\n"
        "                       the reference's own variance taken out)\n"
        "  --out DIR            results (default bench/results)\n"
        "  --refs DIR           reference cache (default bench/refs)\n"
        "  --list               print the selected scenes and reference folders, exit\n"
        "                       (loads each dataset to render its fingerprint)\n"
        "  --self-test          check the harness (ratios, reference, run signatures,\n"
        "                       defaults, fingerprint), exit\n");
}

static const pvc_option OPTIONS[] = {
    {"help", 0}, {"list", 0}, {"self-test", 0},
    {"scenes", 1}, {"data", 1}, {"datasets", 1}, {"lights", 1}, {"conditions", 1},
    {"bias", 1}, {"fig10", 1}, {"out", 1}, {"refs", 1}, {"size", 1}, {"time", 1},
    {"slice", 1}, {"rotate", 1}, {"after", 1}, {"ref-chunk", 1}, {"bias-time", 1},
    {"bias-warm", 1}, {"curvature", 1}, {"medium", 1}, {"cache-param", 1}, {"repeats", 1},
    {"ref-min-chunks", 1}, {"ref-max-chunks", 1}, {"ref-factor", 1}, {NULL, 0}};

/* The options that name files, folders and selections of the matrix. */
static int apply_name_option(void *target, const char *name, const char *value)
{
    options *o = target;
    const struct { const char *name; const char **field; } names[] = {
        {"scenes", &o->scenes_path}, {"data", &o->data_dir}, {"datasets", &o->datasets},
        {"lights", &o->lights}, {"conditions", &o->conditions}, {"bias", &o->bias},
        {"fig10", &o->fig10}, {"out", &o->out_dir}, {"refs", &o->refs_dir}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(name, names[i].name)) {
            *names[i].field = value;
            return 1;
        }
    return -1;
}

/* The durations in milliseconds (their ranges: options_consistent). */
static int apply_time_option(void *target, const char *name, const char *value)
{
    options *o = target;
    const struct { const char *name; double *field; } times[] = {
        {"time", &o->run_ms}, {"slice", &o->slice_ms}, {"rotate", &o->rotate_ms},
        {"after", &o->after_ms}, {"ref-chunk", &o->ref_chunk_ms}, {"bias-time", &o->bias_ms},
        {"bias-warm", &o->warm_ms}};
    for (size_t i = 0; i < sizeof times / sizeof times[0]; i++)
        if (!strcmp(name, times[i].name)) return pvc_parse_double(value, times[i].field);
    return -1;
}

/* The image size, the repeats and the limit of the reference's chunks. */
static int apply_count_option(void *target, const char *name, const char *value)
{
    options *o = target;
    uint32_t n;
    if (!strcmp(name, "size")) return pvc_parse_size(value, PICVR_MAX_IMAGE_SIZE, &o->width, &o->height);
    if (!strcmp(name, "repeats")) {
        if (!pvc_parse_u32(value, 1, MAX_REPEATS, &n)) return 0;
        o->repeats = (int)n;
        return 1;
    }
    if (!strcmp(name, "ref-min-chunks")) {
        if (!pvc_parse_u32(value, REF_MIN_CHUNKS, INT32_MAX, &n)) return 0;
        o->ref_min_chunks = (int)n;
        return 1;
    }
    if (!strcmp(name, "ref-max-chunks")) {
        if (!pvc_parse_u32(value, REF_MIN_CHUNKS, INT32_MAX, &n)) return 0;
        o->ref_max_chunks = (int)n;
        return 1;
    }
    if (!strcmp(name, "ref-factor")) {
        if (pvc_parse_double(value, &o->ref_factor) && o->ref_factor >= 1.0) return 1;
        pvc_fail("--ref-factor %s: a number >= 1", value);
        return 0;
    }
    return -1;
}

/* The cache options of every cached run. */
static int apply_cache_option(void *target, const char *name, const char *value)
{
    options *o = target;
    if (!strcmp(name, "curvature")) return pvc_parse_switch(value, &o->cache.curvature_limit);
    if (!strcmp(name, "medium")) return pvc_parse_switch(value, &o->cache.medium_model);
    return -1;
}

/* Applies one option of OPTIONS; returns 0 after reporting a bad value. */
static int apply_option(void *target, const char *name, const char *value)
{
    options *o = target;
    if (!strcmp(name, "list")) {
        o->list = 1;
        return 1;
    }
    if (!strcmp(name, "self-test")) {
        o->self_test = 1;
        return 1;
    }
    if (!strcmp(name, "cache-param")) {
        pvp_status ps = pvp_cache_param_set(&o->cache, value);
        if (ps != PVP_OK) pvc_fail("--cache-param %s: %s", value, pvp_status_string(ps));
        return ps == PVP_OK;
    }
    static const pvc_group_fn groups[] = {apply_name_option, apply_time_option,
                                          apply_count_option, apply_cache_option};
    return pvc_apply_by_group(groups, sizeof groups / sizeof groups[0], o, name, value);
}

/* The rules between options; returns 0 after saying which one is broken. */
static int options_consistent(const options *o)
{
    if (o->run_ms <= 0 || o->slice_ms <= 0 || o->repeats < 1 || o->repeats > MAX_REPEATS ||
        o->ref_chunk_ms <= 0 || o->ref_min_chunks < REF_MIN_CHUNKS ||
        o->ref_max_chunks < o->ref_min_chunks || o->rotate_ms < 0 ||
        o->after_ms < 0 || o->bias_ms < 0 || o->warm_ms < 0) {
        pvc_fail("an option is out of range");
        return 0;
    }
    if (!pvc_in_list(o->conditions, "plain")) {
        pvc_fail("--conditions must include plain (the baseline)");
        return 0;
    }
    return 1;
}

int parse_args(int argc, char **argv, options *o)
{
    *o = (options){.scenes_path = "bench/scenes.txt", .data_dir = "../shared/data",
                   .out_dir = "bench/results", .refs_dir = "bench/refs",
                   .conditions = "plain,object,object-noprio,screen,screen-noprio",
                   .bias = "bonsai", .fig10 = "bonsai", .width = 128, .height = 128,
                   .run_ms = 10000, .slice_ms = 200, .rotate_ms = 4000, .after_ms = 6000,
                   .ref_chunk_ms = 60000, .cache = {0}, .repeats = 2,
                   .ref_min_chunks = REF_MIN_CHUNKS, .ref_max_chunks = 200,
                   .ref_factor = 10.0};
    int status = pvc_parse_options(argc, argv, OPTIONS, apply_option, o, print_help);
    if (status < 0 && !options_consistent(o)) return EXIT_USAGE;
    return status;
}

/* ---- the matrix ---------------------------------------------------------------------------- */

static int select_conditions(const options *o, scene_result *r)
{
    r->n_conds = 0;
    for (int i = 0; i < N_CONDITIONS; i++)
        if (pvc_in_list(o->conditions, CONDITIONS[i].name)) r->conds[r->n_conds++] = &CONDITIONS[i];
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

static int load_dataset(const options *o, const dataset_spec *d, picvr_io_volume *vol)
{
    char path[PATH_LEN], err[256];
    snprintf(path, sizeof path, "%s/%s", o->data_dir, d->file);
    if (picvr_io_load(path, NULL, vol, err, sizeof err) != PICVR_IO_OK) {
        pvc_fail("%s: %s", path, err);
        return 0;
    }
    vol->spacing[0] = vol->spacing[1] = vol->spacing[2] = d->spacing;
    return 1;
}

/* Sets up scene s of dataset d and light set-up `lights`, with its reference key. */
static int scene_open(const options *o, const scene_file *sf, const dataset_spec *d,
                      const char *lights, const picvr_io_volume *vol, scene *s)
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
        if (!pvc_in_list(o->datasets, sf->datasets[d].name)) continue;
        picvr_io_volume vol;
        if (!load_dataset(o, &sf->datasets[d], &vol)) return 0;
        int ok = 1;
        for (int l = 0; ok && l < sf->n_lights; l++) {
            if (!pvc_in_list(o->lights, sf->lights[l])) continue;
            scene s;
            ok = scene_open(o, sf, &sf->datasets[d], sf->lights[l], &vol, &s);
            if (ok) printf("%s %s/%s\n", s.id, o->refs_dir, s.hash);
        }
        picvr_io_free(&vol);
        if (!ok) return 0;
    }
    return 1;
}

/* The selected scenes: datasets x light set-ups. */
static int count_scenes(const options *o, const scene_file *sf)
{
    int n = 0;
    for (int d = 0; d < sf->n_datasets; d++)
        for (int l = 0; l < sf->n_lights; l++)
            n += pvc_in_list(o->datasets, sf->datasets[d].name) && pvc_in_list(o->lights, sf->lights[l]);
    return n;
}

/* The runs the matrix holds (the denominator of the progress counter). */
static int count_runs(const options *o, const scene_file *sf, int n_conds)
{
    int total = 0;
    int per_bias_scene = (o->bias_ms > 0 ? N_BIAS_CONDITIONS : 0) +
                         (o->warm_ms > 0 ? N_WARM_CONDITIONS : 0);
    for (int d = 0; d < sf->n_datasets; d++) {
        if (!pvc_in_list(o->datasets, sf->datasets[d].name)) continue;
        int first = 1;
        for (int l = 0; l < sf->n_lights; l++) {
            if (!pvc_in_list(o->lights, sf->lights[l])) continue;
            total += n_conds * o->repeats;
            if (first && o->rotate_ms > 0 && pvc_in_list(o->fig10, sf->datasets[d].name))
                total += 2 * o->repeats;
            if (pvc_in_list(o->bias, sf->datasets[d].name)) total += per_bias_scene * o->repeats;
            first = 0;
        }
    }
    return total;
}

/* Every selected light set-up of dataset d, with the dataset loaded; *refused when a
   scene's reference was refused. */
static int run_dataset(const options *o, const scene_file *sf, int d, const writers *w,
                       scene_result *res, int *refused)
{
    picvr_io_volume vol;
    if (!load_dataset(o, &sf->datasets[d], &vol)) return 0;
    int ok = 1, first = 1;
    for (int l = 0; ok && l < sf->n_lights; l++) {
        if (!pvc_in_list(o->lights, sf->lights[l])) continue;
        scene s;
        if (!(ok = scene_open(o, sf, &sf->datasets[d], sf->lights[l], &vol, &s))) break;
        fprintf(stderr, "scene %s (reference %s/%s)\n", s.id, o->refs_dir, s.hash);
        char fig10_list[NAME_LEN * 2];
        snprintf(fig10_list, sizeof fig10_list, "%s", first && o->fig10 ? o->fig10 : "");
        options so = *o;
        so.fig10 = fig10_list;        /* Fig. 10 for the first light set-up only */
        first = 0;
        ok = run_scene(&so, &s, &vol, res);
        if (ok && res->refused) *refused = 1;
        if (ok && !res->refused) write_scene_outputs(w, &s, res);
        res->have_rot = 0;
        free_result(res, o->repeats);
    }
    picvr_io_free(&vol);
    return ok;
}

int main(int argc, char **argv)
{
    pvc_set_program(PROGRAM);
    options o;
    scene_file sf;
    int status = parse_args(argc, argv, &o);
    if (status >= 0) return status;
    if (o.self_test) return self_test() ? 0 : 1;
    if (!read_scene_file(o.scenes_path, &sf)) return EXIT_USAGE;
    if (o.list) return list_scenes(&o, &sf) ? 0 : 1;
    char runs_dir[PATH_LEN];
    snprintf(runs_dir, sizeof runs_dir, "%s/runs", o.out_dir);
    if (!make_dirs(runs_dir) || !make_dirs(o.refs_dir)) {
        pvc_fail("cannot create %s or %s", runs_dir, o.refs_dir);
        return 1;
    }
    static scene_result res;
    select_conditions(&o, &res);
    set_run_count(count_runs(&o, &sf, res.n_conds));
    fprintf(stderr, PROGRAM ": %d scenes x %d conditions x %d repeats at %ux%u, %.0f s each\n",
            count_scenes(&o, &sf), res.n_conds, o.repeats, o.width, o.height, o.run_ms / 1e3);
    char device[256];
    device_name(device, sizeof device);
    writers w;
    if (!open_writers(&o, &w, device)) return 1;
    int ok = 1, refused = 0;
    for (int d = 0; ok && d < sf.n_datasets; d++)
        if (pvc_in_list(o.datasets, sf.datasets[d].name))
            ok = run_dataset(&o, &sf, d, &w, &res, &refused);
    close_writers(&w, device);
    if (!ok) return 1;
    fprintf(stderr, PROGRAM ": results in %s\n", o.out_dir);
    return refused ? EXIT_REFUSED : 0;
}
