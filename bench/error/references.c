/* references.c - picvr-bench-error's converged references: plain Monte Carlo rendered
 * as independent chunks (seeds 1001, 1002, ...) and kept in REFS/<hash>/ as
 * chunk_<seed>.lum.gz (the chunk's luminance: a gzip-compressed grayscale PFM) with
 * chunk_<seed>.json (its iterations).  Only luminance is kept because every error of the
 * bench is one of luminance; it makes the references small enough to be committed
 * (bench/refs/), so that they are rendered once.  Chunks of the older RGB format
 * (chunk_<seed>.pfm) are still read, and rewritten in the new one when read.  The
 * reference is the iteration-weighted mean of the chunks' luminance; its own per-pixel
 * error is estimated from the spread between chunks.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <zlib.h>

#include "bench_error.h"
#include "cli.h"
#include "picvr.h"

/* ---- files ------------------------------------------------------------------------------ */

int make_dirs(const char *path)
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

int file_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* ---- PFM chunks --------------------------------------------------------------------------- */

/* Reads a w x h RGB PFM into luminance, rows top down. */
static int read_pfm_luminance(const char *path, uint32_t w, uint32_t h, double *lum)
{
    size_t n = (size_t)w * h;
    float *rgb = malloc(n * 12);
    int ok = rgb != NULL && pvc_read_pfm(path, w, h, rgb);
    if (!rgb) pvc_fail("out of memory");
    for (size_t i = 0; ok && i < n; i++) lum[i] = luminance(rgb + 3 * i);
    free(rgb);
    return ok;
}

/* Writes a w x h luminance image (rows top down) as a gzip-compressed grayscale PFM
   ("Pf", little endian, rows bottom up as PFM has them), first to a temporary name so
   that a chunk is never half there. */
static int write_lum_gz(const char *path, const float *lum, uint32_t w, uint32_t h)
{
    char tmp[PATH_LEN];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    gzFile f = gzopen(tmp, "wb9");
    unsigned char *row = malloc((size_t)w * 4);
    char head[64];
    int len = snprintf(head, sizeof head, "Pf\n%u %u\n-1.0\n", w, h);
    int ok = f && row && gzwrite(f, head, (unsigned)len) == len;
    for (uint32_t y = h; ok && y-- > 0;) {
        pvc_floats_to_le(lum + (size_t)y * w, w, row);
        ok = gzwrite(f, row, w * 4) == (int)(w * 4);
    }
    if (f && gzclose(f) != Z_OK) ok = 0;
    free(row);
    ok = ok && rename(tmp, path) == 0;
    if (!ok) pvc_fail("cannot write %s", path);
    return ok;
}

/* Reads what write_lum_gz wrote; any other size or format, or a value that is not
   finite, is an error. */
static int read_lum_gz(const char *path, uint32_t w, uint32_t h, double *lum)
{
    gzFile f = gzopen(path, "rb");
    unsigned char *row = malloc((size_t)w * 4);
    float *v = malloc((size_t)w * sizeof *v);
    char head[64] = {0}, expect[64];
    int len = snprintf(expect, sizeof expect, "Pf\n%u %u\n-1.0\n", w, h);
    int ok = f && row && v && gzread(f, head, (unsigned)len) == len && !memcmp(head, expect, (size_t)len);
    for (uint32_t y = h; ok && y-- > 0;) {
        ok = gzread(f, row, w * 4) == (int)(w * 4);
        if (ok) pvc_floats_from_bytes(row, w, 0, v);
        for (uint32_t x = 0; ok && x < w; x++) {
            ok = isfinite(v[x]);
            lum[(size_t)y * w + x] = v[x];
        }
    }
    if (f) gzclose(f);
    free(row);
    free(v);
    if (!ok) pvc_fail("%s is not a %ux%u luminance chunk", path, w, h);
    return ok;
}

/* A chunk's luminance from either format; an RGB chunk is rewritten as luminance (and
   its PFM removed) once read. */
static int read_chunk(const char *lum_path, const char *pfm_path, uint32_t w, uint32_t h, double *lum)
{
    if (file_exists(lum_path)) return read_lum_gz(lum_path, w, h, lum);
    size_t n = (size_t)w * h;
    float *lumf = malloc(n * sizeof *lumf);
    int ok = lumf && read_pfm_luminance(pfm_path, w, h, lum);
    for (size_t i = 0; ok && i < n; i++) lumf[i] = (float)lum[i];
    ok = ok && write_lum_gz(lum_path, lumf, w, h) && remove(pfm_path) == 0;
    free(lumf);
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

static void chunk_paths(const reference *r, uint32_t k, char *lum, char *pfm, char *json)
{
    snprintf(lum, PATH_LEN, "%s/chunk_%u.lum.gz", r->dir, REF_SEED0 + k);
    snprintf(pfm, PATH_LEN, "%s/chunk_%u.pfm", r->dir, REF_SEED0 + k);
    snprintf(json, PATH_LEN, "%s/chunk_%u.json", r->dir, REF_SEED0 + k);
}

/* Per pixel: sum n_k m_k and sum n_k m_k^2 over the chunks, in double. */
static int ref_accumulate(reference *r, double *s1, double *s2, double *chunk)
{
    size_t n = (size_t)r->width * r->height;
    char lum[PATH_LEN], pfm[PATH_LEN], json[PATH_LEN];
    r->chunks = 0;
    r->iterations = 0;
    for (;; r->chunks++) {
        chunk_paths(r, r->chunks, lum, pfm, json);
        long it = read_chunk_iterations(json);
        if (it <= 0 || (!file_exists(lum) && !file_exists(pfm))) break;
        if (!read_chunk(lum, pfm, r->width, r->height, chunk)) return 0;
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
void ref_finish(reference *r, const double *s1, const double *s2)
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

int ref_load(reference *r)
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

int ref_open(const options *o, const scene *s, reference *r)
{
    memset(r, 0, sizeof *r);
    r->width = s->width;
    r->height = s->height;
    snprintf(r->dir, sizeof r->dir, "%s/%s", o->refs_dir, s->hash);
    size_t n = (size_t)r->width * r->height;
    r->lum = calloc(n, sizeof *r->lum);
    r->var = calloc(n, sizeof *r->var);
    if (!r->lum || !r->var || !make_dirs(r->dir)) {
        pvc_fail("cannot create %s", r->dir);
        return 0;
    }
    char path[PATH_LEN];
    snprintf(path, sizeof path, "%s/scene.txt", r->dir);
    FILE *f = fopen(path, "w");
    if (f) { fprintf(f, "%s\n", s->key); fclose(f); }
    return ref_load(r);
}

void ref_close(reference *r)
{
    free(r->lum);
    free(r->var);
    memset(r, 0, sizeof *r);
}

/* picvr_step in 1 s steps for o->ref_chunk_ms of wall time, with a progress line
   about every 10 s. */
static int render_chunk_time(const options *o, const scene *s, picvr_context *ctx, uint32_t k)
{
    double spent = 0, last = 0;
    while (spent < o->ref_chunk_ms) {
        double t0 = pvc_now_ms();
        if (!pvc_check(picvr_step(ctx, 1000.0), "picvr_step")) return 0;
        spent += pvc_now_ms() - t0;
        if (spent - last > 10000 || spent >= o->ref_chunk_ms) {
            fprintf(stderr, "  reference %s chunk %u: %.0f/%.0f s\n", s->id, k + 1,
                    spent / 1e3, o->ref_chunk_ms / 1e3);
            last = spent;
        }
    }
    return 1;
}

/* Chunk k's files: its luminance and its JSON. */
static int write_chunk(const reference *r, uint32_t k, picvr_context *ctx)
{
    picvr_stats st;
    size_t n = (size_t)r->width * r->height;
    float *rgba = malloc(n * 16), *lum = malloc(n * sizeof *lum);
    char lum_path[PATH_LEN], pfm[PATH_LEN], json[PATH_LEN];
    chunk_paths(r, k, lum_path, pfm, json);
    int ok = rgba && lum && pvc_check(picvr_get_stats(ctx, &st), "picvr_get_stats") &&
             read_luminance(ctx, r->width, r->height, rgba, lum);
    ok = ok && write_lum_gz(lum_path, lum, r->width, r->height);
    free(rgba);
    free(lum);
    FILE *f = ok ? fopen(json, "w") : NULL;
    if (!f) return 0;
    fprintf(f, "{\"iterations\": %u, \"elapsed_ms\": %.3f, \"seed\": %u}\n", st.iterations,
            st.elapsed_ms, REF_SEED0 + k);
    return fclose(f) == 0;
}

/* Renders reference chunk k: plain Monte Carlo for o->ref_chunk_ms, seed 1001 + k. */
static int ref_render_chunk(const options *o, const scene *s, const picvr_io_volume *vol,
                            const reference *r, uint32_t k)
{
    session ss;
    if (!session_open(s, vol, find_condition("plain"), REF_SEED0 + k, 0.0f, NULL, &ss)) return 0;
    int ok = render_chunk_time(o, s, ss.ctx, k) && write_chunk(r, k, ss.ctx);
    session_close(&ss);
    return ok;
}

int ref_grow(const options *o, const scene *s, const picvr_io_volume *vol,
                    reference *r, uint32_t chunks)
{
    for (uint32_t k = r->chunks; k < chunks; k++)
        if (!ref_render_chunk(o, s, vol, r, k)) return 0;
    if (!ref_load(r)) return 0;
    fprintf(stderr, "  reference %s: %u chunks, %llu iterations, RMSE %.3g, rel. RMSE %.3g\n",
            s->id, r->chunks, (unsigned long long)r->iterations, r->rmse, r->rel_rmse);
    return 1;
}

