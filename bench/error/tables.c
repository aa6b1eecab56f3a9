/* tables.c - picvr-bench-error's outputs in OUT: table2.csv/.md (plain error over
 * cached error at equal time), table3.csv/.md (entries and references of object-space
 * locking), bias.csv/.md (bias split from variance), fig11_<scene>.csv/.dat/.gp (error
 * against time, every condition), fig10_<scene>.csv/.dat/.gp (a turning camera); the
 * .gp files are gnuplot scripts that draw the PNGs.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bench_error.h"
#include "cli.h"
#include "picvr.h"
#include "presets.h"

/* ---- equal-time comparison ----------------------------------------------------------------------- */


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
double mean_ratio(const run *a, const run *b, enum field f)
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

/* The smallest ratio plain / condition c over the equal-time grid, each time's errors the
   geometric mean over the repeats (so one noisy run does not make the worst time); NaN
   when no time has every repeat measured. */
double worst_ratio(const scene_result *r, int c, int repeats, enum field f)
{
    double lo = -INFINITY, hi = INFINITY, worst = INFINITY;
    for (int k = 0; k < repeats; k++) {
        const run *a = &r->runs[0][k], *b = &r->runs[c][k];
        lo = fmax(lo, fmax(first_time(a), first_time(b)));
        hi = fmin(hi, fmin(a->rows[a->n - 1].t_ms, b->rows[b->n - 1].t_ms));
    }
    for (int i = 0; i < GRID_POINTS && hi > lo; i++) {
        double t = lo + (hi - lo) * i / (GRID_POINTS - 1), d = 0;
        int ok = 1;
        for (int k = 0; k < repeats && ok; k++) {
            double la = log_at(&r->runs[0][k], t, f), lb = log_at(&r->runs[c][k], t, f);
            ok = isfinite(la) && isfinite(lb);
            d += la - lb;
        }
        if (ok) worst = fmin(worst, exp(d / repeats));
    }
    return isfinite(worst) ? worst : NAN;
}

/* ---- Table 2 and Table 3 ------------------------------------------------------------------ */

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
        double worst = worst_ratio(r, c, R, F_RMSE);
        fprintf(w->t2csv, "%s,%s,%s,%ux%u,%s,%.4f,%.4f,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,"
                "%.1f,%.6g,%.6g,%.4f,%.4f,\"%s\"\n", s->ds->name, base,
                lights_have_background(s->lights) ? "on" : "off", s->width, s->height,
                r->conds[c]->name, rt, re, R, tmin, tmax, emin, emax, rtr, rer,
                w->o->run_ms / 1e3, final_mean(r, 0, R, F_RMSE), final_mean(r, c, R, F_RMSE),
                final_hit(r, c, R), worst, w->device);
        fprintf(w->t2md, "| %s | %s | %s | %ux%u | %s | %.2f (%.2f-%.2f) | %.2f | %.2f (%.2f-%.2f) | "
                "%.2f | %.2f | %.3g | %.3g | %.2f |\n", s->ds->name, base,
                lights_have_background(s->lights) ? "on" : "off", s->width, s->height,
                r->conds[c]->name, rt, tmin, tmax, worst, re, emin, emax, rtr, rer,
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

/* ---- figures (gnuplot) ------------------------------------------------------------------ */

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

/* One figure's curves: n conditions, o->repeats runs of each. */
typedef struct curves {
    int n;
    const char *names[N_CONDITIONS];
    const run *runs[N_CONDITIONS];   /* runs[c][k] */
} curves;

static FILE *open_figure_file(const options *o, const char *figure, const scene *s,
                              const char *ext)
{
    char path[PATH_LEN];
    snprintf(path, sizeof path, "%s/%s_%s.%s", o->out_dir, figure, s->id, ext);
    return fopen(path, "w");
}

/* The long-format data behind a figure: every slice of every run. */
static void write_curves_csv(FILE *f, const curves *cv, int repeats)
{
    fprintf(f, "condition,repeat,seed," ROW_HEADER "\n");
    for (int c = 0; c < cv->n; c++)
        for (int k = 0; k < repeats; k++)
            for (size_t i = 0; i < cv->runs[c][k].n; i++) {
                fprintf(f, "%s,%d,%u,", cv->names[c], k, RUN_SEED0 + k);
                write_row(f, &cv->runs[c][k].rows[i]);
            }
}

/* Time, then the mean true RMSE per condition, then the mean estimate per condition,
   every slice_ms up to total_ms. */
static void write_curves_dat(FILE *f, const curves *cv, int repeats, double slice_ms,
                             double total_ms)
{
    fprintf(f, "t_s");
    for (int c = 0; c < cv->n; c++) fprintf(f, " %s_rmse", cv->names[c]);
    for (int c = 0; c < cv->n; c++) fprintf(f, " %s_est", cv->names[c]);
    fprintf(f, "\n");
    for (double t = slice_ms; t <= total_ms + 1e-9; t += slice_ms) {
        fprintf(f, "%.3f", t / 1e3);
        for (int c = 0; c < cv->n; c++) dat_value(f, mean_at(cv->runs[c], repeats, t, F_RMSE));
        for (int c = 0; c < cv->n; c++) dat_value(f, mean_at(cv->runs[c], repeats, t, F_EST));
        fprintf(f, "\n");
    }
}

/* fig10_<id> or fig11_<id>: .csv and .dat; the caller writes the .gp. */
static int write_curves(const options *o, const scene *s, const char *figure,
                        const curves *cv, double total_ms)
{
    FILE *f = open_figure_file(o, figure, s, "csv");
    if (!f) return 0;
    write_curves_csv(f, cv, o->repeats);
    fclose(f);
    if (!(f = open_figure_file(o, figure, s, "dat"))) return 0;
    write_curves_dat(f, cv, o->repeats, o->slice_ms, total_ms);
    fclose(f);
    return 1;
}

/* fig11_<id>: every condition from an empty cache; the .gp plots the true RMSE and
   the estimate side by side into fig11_<id>.png. */
static void write_fig11(const options *o, const scene *s, const scene_result *r)
{
    curves cv = {r->n_conds};
    for (int c = 0; c < r->n_conds; c++) {
        cv.names[c] = r->conds[c]->name;
        cv.runs[c] = r->runs[c];
    }
    FILE *f;
    if (!write_curves(o, s, "fig11", &cv, o->run_ms) || !(f = open_figure_file(o, "fig11", s, "gp")))
        return;
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
}

/* fig10_<id>: plain against the object-space cache while the camera turns, then
   stops; the .gp plots both errors into fig10_<id>.png. */
static void write_fig10(const options *o, const scene *s, const scene_result *r)
{
    curves cv = {2, {"plain", "object"}, {r->rot[0], r->rot[1]}};
    FILE *f;
    if (!write_curves(o, s, "fig10", &cv, o->rotate_ms + o->after_ms) ||
        !(f = open_figure_file(o, "fig10", s, "gp")))
        return;
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

/* ---- bias ------------------------------------------------------------------------------------ */

/* Per pixel, the sums s1, s2 of the R final images of condition cond (file suffix) and
   their squares; m[k]: the mean of image k. */
static int sum_final_images(const options *o, const scene *s, const char *cond,
                            const char *suffix, double *s1, double *s2, double *m)
{
    size_t n = (size_t)s->width * s->height;
    float *img = malloc(n * sizeof *img);
    int ok = img != NULL;
    for (int k = 0; ok && k < o->repeats; k++) {
        char path[PATH_LEN];
        run_path(o, s, cond, k, suffix, path);
        FILE *f = fopen(path, "rb");
        ok = f && pvc_read_floats_le(f, img, n);
        if (f) fclose(f);
        m[k] = 0;
        for (size_t i = 0; ok && i < n; i++) {
            s1[i] += img[i];
            s2[i] += (double)img[i] * img[i];
            m[k] += img[i];
        }
        m[k] /= n;
    }
    free(img);
    return ok;
}

/* Bias split from variance over R seeds: with the final images Y_k and their mean
   Ybar, per pixel s^2 = sample variance over k, so E[(Ybar - Yref)^2] = b^2 + s^2/R
   + var(Yref); rms_bias = sqrt(max(0, mean((Ybar-Yref)^2) - mean(s^2)/R - mean var_ref)).
   The relative bias of the image mean luminance is reported with its standard error.
   out: relative mean bias, its standard error, RMS bias, RMS total, RMS noise. */
static int bias_one(const options *o, const scene *s, const reference *ref, const char *cond,
                    const char *suffix, double out[5])
{
    size_t n = (size_t)s->width * s->height;
    int R = o->repeats;
    double *s1 = calloc(n, sizeof *s1), *s2 = calloc(n, sizeof *s2), m[MAX_REPEATS];
    int ok = s1 && s2 && R >= 2 && sum_final_images(o, s, cond, suffix, s1, s2, m);
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
    if (!pvc_in_list(o->bias, s->ds->name) || o->repeats < 2) return;
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

/* ---- the output files ---------------------------------------------------------------------- */

static FILE *open_out(const options *o, const char *name, const char *header)
{
    char path[PATH_LEN];
    snprintf(path, sizeof path, "%s/%s", o->out_dir, name);
    FILE *f = fopen(path, "w");
    if (!f) { pvc_fail("cannot write %s: %s", path, strerror(errno)); return NULL; }
    fputs(header, f);
    return f;
}

/* The Markdown tables' heads: the run settings, then the column names. */
static void write_markdown_heads(const writers *w)
{
    const options *o = w->o;
    char head[1024];
    snprintf(head, sizeof head,
             "%.0f s per run in %.0f ms slices, %d repeats (seeds %u..%u), time = wall time "
             "inside picvr_step; machine and date at the end.\n\n",
             o->run_ms / 1e3, o->slice_ms, o->repeats, RUN_SEED0, RUN_SEED0 + o->repeats - 1);
    fprintf(w->t2md, "%s| dataset | lights | background | size | condition | ratio true RMSE "
            "(min-max) | worst | ratio est_error (min-max) | ratio true rel. | ratio est. rel. | "
            "final RMSE plain | final RMSE cached | final hit rate |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
            "\n\"worst\": the smallest plain/condition ratio of true RMSE at any time of the run "
            "(errors at each time the geometric mean over the seeds).\n\n", head);
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
}

int open_writers(const options *o, writers *w, const char *device)
{
    memset(w, 0, sizeof *w);
    w->o = o;
    w->device = device;
    w->t2csv = open_out(o, "table2.csv", "dataset,lights,background,size,condition,ratio_true,"
                        "ratio_est,repeats,ratio_true_min,ratio_true_max,ratio_est_min,"
                        "ratio_est_max,ratio_true_rel,ratio_est_rel,run_s,final_rmse_plain,"
                        "final_rmse_cached,final_hit_rate,ratio_true_worst,device\n");
    w->t2md = open_out(o, "table2.md", "");
    w->t3csv = open_out(o, "table3.csv", "dataset,lights,size,condition,run_s,entries,refs,"
                        "refs_per_entry,hit_rate,iterations\n");
    w->t3md = open_out(o, "table3.md", "");
    w->bcsv = open_out(o, "bias.csv", "dataset,lights,size,condition,repeats,run_s,"
                       "rel_mean_bias,rel_mean_bias_stderr,rms_bias,rms_total,rms_noise,"
                       "ref_rmse,hit_rate\n");
    w->bmd = open_out(o, "bias.md", "");
    if (!w->t2csv || !w->t2md || !w->t3csv || !w->t3md || !w->bcsv || !w->bmd) return 0;
    write_markdown_heads(w);
    return 1;
}

void close_writers(writers *w, const char *device)
{
    char from[64] = "-", to[64] = "-", cache[256];
    time_t first_run_time, last_run_time;
    run_times(&first_run_time, &last_run_time);
    cache_options_text(&w->o->cache, cache, sizeof cache);
    if (first_run_time) strftime(from, sizeof from, "%Y-%m-%d %H:%M", gmtime(&first_run_time));
    if (last_run_time) strftime(to, sizeof to, "%Y-%m-%d %H:%M UTC", gmtime(&last_run_time));
    FILE *md[3] = {w->t2md, w->t3md, w->bmd};
    for (int i = 0; i < 3; i++)
        if (md[i])
            fprintf(md[i], "\nRuns measured %s to %s on %ld CPU(s); device: %s; library "
                    "build %s (checksum of picvr.h, picvr_vk.c, host/, shaders/); cache options: "
                    "%s (others: the library's defaults).\n", from, to,
                    sysconf(_SC_NPROCESSORS_ONLN), device, PICVR_BENCH_BUILD, cache);
    FILE *all[6] = {w->t2csv, w->t2md, w->t3csv, w->t3md, w->bcsv, w->bmd};
    for (int i = 0; i < 6; i++)
        if (all[i]) fclose(all[i]);
}

/* Every output of a scene that was not refused. */
void write_scene_outputs(const writers *w, const scene *s, const scene_result *r)
{
    write_table2(w, s, r);
    write_table3(w, s, r);
    write_bias(w, s, r);
    write_fig11(w->o, s, r);
    if (r->have_rot) write_fig10(w->o, s, r);
}
