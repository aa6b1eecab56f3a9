/* cli.c - the command-line plumbing of picvr's example and bench programs: option
 * tables, strict value parsers, messages, a monotonic clock, PFM images and JSON
 * output (the contract is in cli.h).
 */
#include "cli.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

/* ---- messages ---------------------------------------------------------------------- */

static const char *program_name = "picvr";

void pvc_set_program(const char *name) { program_name = name; }

const char *pvc_program(void) { return program_name; }

void pvc_fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "%s: error: ", program_name);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

void pvc_bad_value(const char *name, const char *value)
{
    pvc_fail("bad value for --%s: '%s' (see --help)", name, value);
}

double pvc_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* ---- options ------------------------------------------------------------------------ */

/* The table's row whose name is the first len characters of text; NULL if none. */
static const pvc_option *find_option(const pvc_option *options, const char *text, size_t len)
{
    for (; options->name; options++)
        if (strlen(options->name) == len && !strncmp(options->name, text, len)) return options;
    return NULL;
}

/* The option at argv[*next] (advancing *next past it and its value): its row, and
   *value (NULL for a flag); NULL after reporting a usage error. */
static const pvc_option *next_option(int argc, char **argv, int *next, const pvc_option *options,
                                     const char *positional, const char **value)
{
    const char *arg = argv[(*next)++];
    if (strncmp(arg, "--", 2) != 0) {
        const pvc_option *opt = positional ? find_option(options, positional, strlen(positional)) : NULL;
        if (opt && opt->takes_value) {   /* a bare argument: the value of `positional` */
            *value = arg;
            return opt;
        }
        pvc_fail("unexpected argument '%s' (see --help)", arg);
        return NULL;
    }
    const char *text = arg + 2, *eq = strchr(text, '=');
    const pvc_option *opt = find_option(options, text, eq ? (size_t)(eq - text) : strlen(text));
    if (!opt || (eq && !opt->takes_value)) {
        pvc_fail("unknown option '%s' (see --help)", arg);
        return NULL;
    }
    *value = NULL;
    if (!opt->takes_value) return opt;
    if (eq) *value = eq + 1;
    else if (*next < argc) *value = argv[(*next)++];
    else {
        pvc_fail("--%s needs a value (see --help)", opt->name);
        return NULL;
    }
    return opt;
}

int pvc_parse_options(int argc, char **argv, const pvc_option *options, pvc_apply_fn apply,
                      void *target, void (*help)(FILE *))
{
    return pvc_parse_options_positional(argc, argv, options, NULL, apply, target, help);
}

int pvc_parse_options_positional(int argc, char **argv, const pvc_option *options, const char *positional,
                                 pvc_apply_fn apply, void *target, void (*help)(FILE *))
{
    for (int next = 1; next < argc;) {
        const char *value;
        const pvc_option *opt = next_option(argc, argv, &next, options, positional, &value);
        if (!opt) return PVC_EXIT_USAGE;
        if (!strcmp(opt->name, "help")) {
            help(stdout);
            return 0;
        }
        if (!apply(target, opt->name, value)) return PVC_EXIT_USAGE;
    }
    return -1;
}

int pvc_apply_by_group(const pvc_group_fn *groups, size_t count, void *target, const char *name,
                       const char *value)
{
    int applied = -1;
    for (size_t i = 0; i < count && applied < 0; i++) applied = groups[i](target, name, value);
    if (applied < 0) pvc_fail("--%s: no group of options applies it", name);
    else if (!applied) pvc_bad_value(name, value);
    return applied > 0;
}

/* ---- values --------------------------------------------------------------------------- */

int pvc_parse_u32(const char *text, uint32_t min, uint32_t max, uint32_t *out)
{
    if (!text || text[0] < '0' || text[0] > '9') return 0;  /* strtoull takes "-1" */
    char *end;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 10);
    if (errno || *end || v < min || v > max) return 0;
    *out = (uint32_t)v;
    return 1;
}

int pvc_parse_double(const char *text, double *out)
{
    if (!text || !*text) return 0;
    char *end;
    errno = 0;
    double v = strtod(text, &end);
    if (errno || *end || !isfinite(v)) return 0;
    *out = v;
    return 1;
}

int pvc_parse_float(const char *text, float *out)
{
    double v;
    if (!pvc_parse_double(text, &v) || fabs(v) > 3.0e38) return 0;
    *out = (float)v;
    return 1;
}

#define MAX_LIST 8

/* Splits a copy of text (in buf) at sep into exactly n pieces. */
static int split(const char *text, char sep, int n, char *buf, size_t buf_size, char **pieces)
{
    if (!text || n < 1 || n > MAX_LIST || strlen(text) >= buf_size) return 0;
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

int pvc_parse_floats(const char *text, int n, float *out)
{
    char buf[256], *pieces[MAX_LIST];
    float v[MAX_LIST];
    if (!split(text, ',', n, buf, sizeof buf, pieces)) return 0;
    for (int i = 0; i < n; i++)
        if (!pvc_parse_float(pieces[i], &v[i])) return 0;
    memcpy(out, v, (size_t)n * sizeof *v);
    return 1;
}

int pvc_parse_u32s(const char *text, int n, uint32_t min, uint32_t max, uint32_t *out)
{
    char buf[256], *pieces[MAX_LIST];
    uint32_t v[MAX_LIST];
    if (!split(text, ',', n, buf, sizeof buf, pieces)) return 0;
    for (int i = 0; i < n; i++)
        if (!pvc_parse_u32(pieces[i], min, max, &v[i])) return 0;
    memcpy(out, v, (size_t)n * sizeof *v);
    return 1;
}

int pvc_parse_size(const char *text, uint32_t max, uint32_t *width, uint32_t *height)
{
    char buf[64], *pieces[2];
    uint32_t w, h;
    if (!split(text, 'x', 2, buf, sizeof buf, pieces) || !pvc_parse_u32(pieces[0], 1, max, &w) ||
        !pvc_parse_u32(pieces[1], 1, max, &h))
        return 0;
    *width = w;
    *height = h;
    return 1;
}

int pvc_parse_switch(const char *text, picvr_switch *out)
{
    if (!text) return 0;
    if (!strcmp(text, "on")) *out = PICVR_SWITCH_ON;
    else if (!strcmp(text, "off")) *out = PICVR_SWITCH_OFF;
    else return 0;
    return 1;
}

int pvc_parse_bounces(const char *text, uint32_t *out)
{
    if (text && !strcmp(text, "unlimited")) {
        *out = PICVR_BOUNCES_UNLIMITED;
        return 1;
    }
    return pvc_parse_u32(text, 0, PICVR_BOUNCES_UNLIMITED - 1, out);
}

const char *pvc_switch_name(picvr_switch s)
{
    return s == PICVR_SWITCH_ON ? "on" : s == PICVR_SWITCH_OFF ? "off" : "default";
}

int pvc_parse_cache_mode(const char *text, picvr_cache_mode *out)
{
    if (!text) return 0;
    if (!strcmp(text, "off") || !strcmp(text, "none")) *out = PICVR_CACHE_NONE;
    else if (!strcmp(text, "object")) *out = PICVR_CACHE_OBJECT_SPACE;
    else if (!strcmp(text, "screen")) *out = PICVR_CACHE_SCREEN_SPACE;
    else if (!strcmp(text, "auto")) *out = PICVR_CACHE_AUTO;
    else return 0;
    return 1;
}

const char *pvc_cache_mode_name(picvr_cache_mode mode)
{
    switch (mode) {
    case PICVR_CACHE_DEFAULT: return "default";
    case PICVR_CACHE_NONE: return "none";
    case PICVR_CACHE_OBJECT_SPACE: return "object";
    case PICVR_CACHE_SCREEN_SPACE: return "screen";
    case PICVR_CACHE_AUTO: return "auto";
    }
    return "?";
}

const char *pvc_log_level_name(picvr_log_level level)
{
    static const char *const names[] = {"default", "debug", "info", "warning", "error"};
    return level >= PICVR_LOG_DEFAULT && level <= PICVR_LOG_ERROR ? names[level] : "?";
}

static const char *const DISTANCE_NAMES[] = {"default", "mis", "free-flight", "forced", "auto"};
static const char *const TRANSMITTANCE_NAMES[] = {"default", "residual", "ratio", "ray-marching"};

const char *pvc_distance_sampling_name(picvr_distance_sampling d)
{
    return d >= PICVR_DISTANCE_DEFAULT && d <= PICVR_DISTANCE_AUTO ? DISTANCE_NAMES[d] : "?";
}

const char *pvc_transmittance_name(picvr_transmittance_estimator t)
{
    return t >= PICVR_TRANSMITTANCE_DEFAULT && t <= PICVR_TRANSMITTANCE_RAY_MARCHING ? TRANSMITTANCE_NAMES[t] : "?";
}

int pvc_parse_distance_sampling(const char *text, picvr_distance_sampling *out)
{
    for (int i = 1; i <= PICVR_DISTANCE_AUTO; i++)
        if (!strcmp(text, DISTANCE_NAMES[i])) { *out = (picvr_distance_sampling)i; return 1; }
    return 0;
}

int pvc_parse_transmittance(const char *text, picvr_transmittance_estimator *out)
{
    for (int i = 1; i <= PICVR_TRANSMITTANCE_RAY_MARCHING; i++)
        if (!strcmp(text, TRANSMITTANCE_NAMES[i])) { *out = (picvr_transmittance_estimator)i; return 1; }
    return 0;
}

int pvc_parse_render_mode(const char *text, picvr_render_mode *out)
{
    static const char *const names[] = {"default", "mc", "field", "field-mc"};
    for (int i = PICVR_RENDER_MC; i <= PICVR_RENDER_FIELD_MC; i++)
        if (!strcmp(text, names[i])) { *out = (picvr_render_mode)i; return 1; }
    return 0;
}

int pvc_in_list(const char *list, const char *name)
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

/* ---- images and float arrays -------------------------------------------------------- */

#define FLOAT_CHUNK 1024

void pvc_floats_to_le(const float *v, size_t n, unsigned char *bytes)
{
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, &v[i], 4);
        for (int b = 0; b < 4; b++) bytes[4 * i + b] = (unsigned char)(u >> (8 * b));
    }
}

void pvc_floats_from_bytes(const unsigned char *bytes, size_t n, int big_endian, float *v)
{
    for (size_t i = 0; i < n; i++) {
        uint32_t u = 0;
        for (int b = 0; b < 4; b++) u |= (uint32_t)bytes[4 * i + (big_endian ? 3 - b : b)] << (8 * b);
        memcpy(&v[i], &u, 4);
    }
}

int pvc_write_floats_le(FILE *f, const float *v, size_t n)
{
    unsigned char bytes[4 * FLOAT_CHUNK];
    for (size_t done = 0; done < n;) {
        size_t k = n - done < FLOAT_CHUNK ? n - done : FLOAT_CHUNK;
        pvc_floats_to_le(v + done, k, bytes);
        if (fwrite(bytes, 4, k, f) != k) return 0;
        done += k;
    }
    return 1;
}

/* n floats of the given byte order (1: big-endian) from f. */
static int read_floats(FILE *f, float *v, size_t n, int big_endian)
{
    unsigned char bytes[4 * FLOAT_CHUNK];
    for (size_t done = 0; done < n;) {
        size_t k = n - done < FLOAT_CHUNK ? n - done : FLOAT_CHUNK;
        if (fread(bytes, 4, k, f) != k) return 0;
        pvc_floats_from_bytes(bytes, k, big_endian, v + done);
        done += k;
    }
    return 1;
}

int pvc_read_floats_le(FILE *f, float *v, size_t n) { return read_floats(f, v, n, 0); }

int pvc_write_pfm(const char *path, const float *rgba, uint32_t width, uint32_t height)
{
    errno = 0;
    FILE *f = fopen(path, "wb");
    float *row = malloc((size_t)width * 12);
    int ok = f && row && fprintf(f, "PF\n%u %u\n-1.0\n", width, height) > 0;
    for (uint32_t y = height; ok && y-- > 0;) {
        const float *src = rgba + (size_t)y * width * 4;
        for (uint32_t x = 0; x < width; x++) memcpy(row + 3 * x, src + 4 * x, 12);
        ok = pvc_write_floats_le(f, row, (size_t)width * 3);
    }
    if (f && fclose(f) != 0) ok = 0;
    free(row);
    if (!ok) pvc_fail("cannot write %s: %s", path, errno ? strerror(errno) : "out of memory");
    return ok;
}

int pvc_read_pfm(const char *path, uint32_t width, uint32_t height, float *rgb)
{
    FILE *f = fopen(path, "rb");
    char magic[3] = {0};
    unsigned w = 0, h = 0;
    float scale = 0;
    int ok = f && fscanf(f, "%2s %u %u %f", magic, &w, &h, &scale) == 4 && !strcmp(magic, "PF") &&
             w == width && h == height && scale != 0 && fgetc(f) == '\n';
    for (uint32_t y = height; ok && y-- > 0;)
        ok = read_floats(f, rgb + (size_t)y * width * 3, (size_t)width * 3, scale > 0);
    if (f) fclose(f);
    if (!ok) pvc_fail("%s is not a %ux%u RGB PFM", path, width, height);
    return ok;
}

/* ---- JSON ---------------------------------------------------------------------------- */

/* The n characters at s as a JSON string literal, escaped. */
static void json_escaped(FILE *f, const char *s, size_t n)
{
    fputc('"', f);
    for (const unsigned char *p = (const unsigned char *)s; p < (const unsigned char *)s + n; p++) {
        if (*p == '"' || *p == '\\') fprintf(f, "\\%c", *p);
        else if (*p < 0x20) fprintf(f, "\\u%04x", *p);
        else fputc(*p, f);
    }
    fputc('"', f);
}

void pvc_json_string(FILE *f, const char *s) { json_escaped(f, s, strlen(s)); }

/* JSON has no NaN or infinity. */
static void json_number(FILE *f, double v)
{
    if (isfinite(v)) fprintf(f, "%.9g", v);
    else fputs("null", f);
}

/* The name an enum row's value is written as. */
static const char *enum_name(const pvc_json_field *field, const char *p)
{
    picvr_switch sw;
    picvr_cache_mode mode;
    picvr_log_level level;
    picvr_distance_sampling distance;
    picvr_transmittance_estimator transmittance;
    switch (field->type) {
    case PVC_JSON_SWITCH: memcpy(&sw, p, sizeof sw); return pvc_switch_name(sw);
    case PVC_JSON_CACHE_MODE: memcpy(&mode, p, sizeof mode); return pvc_cache_mode_name(mode);
    case PVC_JSON_LOG_LEVEL: memcpy(&level, p, sizeof level); return pvc_log_level_name(level);
    case PVC_JSON_DISTANCE: memcpy(&distance, p, sizeof distance); return pvc_distance_sampling_name(distance);
    case PVC_JSON_TRANSMITTANCE:
        memcpy(&transmittance, p, sizeof transmittance);
        return pvc_transmittance_name(transmittance);
    default: return "?";
    }
}

/* The value of one row, at base + field->offset. */
static void json_value(FILE *f, const char *base, const pvc_json_field *field)
{
    const char *p = base + field->offset, *str;
    uint32_t u32;
    uint64_t u64;
    float f32;
    double f64;
    switch (field->type) {
    case PVC_JSON_U32: memcpy(&u32, p, sizeof u32); fprintf(f, "%u", u32); break;
    case PVC_JSON_U64: memcpy(&u64, p, sizeof u64); fprintf(f, "%llu", (unsigned long long)u64); break;
    case PVC_JSON_BOUNCES:
        memcpy(&u32, p, sizeof u32);
        if (u32 == PICVR_BOUNCES_UNLIMITED) fputs("\"unlimited\"", f);
        else fprintf(f, "%u", u32);
        break;
    case PVC_JSON_F32: memcpy(&f32, p, sizeof f32); json_number(f, f32); break;
    case PVC_JSON_F64: memcpy(&f64, p, sizeof f64); json_number(f, f64); break;
    case PVC_JSON_CHARS: json_escaped(f, p, strnlen(p, field->count)); break;
    case PVC_JSON_STRING:
        memcpy(&str, p, sizeof str);
        if (str) pvc_json_string(f, str);
        else fputs("null", f);
        break;
    case PVC_JSON_SWITCH:
    case PVC_JSON_CACHE_MODE:
    case PVC_JSON_LOG_LEVEL:
    case PVC_JSON_DISTANCE:
    case PVC_JSON_TRANSMITTANCE: pvc_json_string(f, enum_name(field, p)); break;
    case PVC_JSON_OBJECT: pvc_json_write(f, p, field->fields, field->count); break;
    case PVC_JSON_ARRAY: {
        const pvc_json_array *a = (const pvc_json_array *)p;
        fputc('[', f);
        for (size_t i = 0; i < a->length; i++) {
            fputs(i ? ", " : "", f);
            pvc_json_write(f, (const char *)a->items + i * a->stride, field->fields, field->count);
        }
        fputc(']', f);
        break;
    }
    }
}

void pvc_json_write(FILE *f, const void *base, const pvc_json_field *fields, size_t count)
{
    fputc('{', f);
    for (size_t i = 0; i < count; i++) {
        fputs(i ? ", " : "", f);
        pvc_json_string(f, fields[i].name);
        fputs(": ", f);
        json_value(f, base, &fields[i]);
    }
    fputc('}', f);
}

int pvc_has_extension(const char *path, const char *ext)
{
    size_t n = path ? strlen(path) : 0, k = strlen(ext);
    if (n < k) return 0;
    for (size_t i = 0; i < k; i++) {
        int a = (unsigned char)path[n - k + i], b = (unsigned char)ext[i];
        if (a >= 'A' && a <= 'Z') a += 'a' - 'A';
        if (a != b) return 0;
    }
    return 1;
}

int pvc_check_writable(const char *path)
{
    int fd = open(path, O_WRONLY);   /* an existing file: kept as it is */
    int created = 0;
    if (fd < 0 && errno == ENOENT) {
        fd = open(path, O_WRONLY | O_CREAT | O_EXCL, 0666);
        created = fd >= 0;
    }
    if (fd < 0) {
        pvc_fail("cannot write %s: %s", path, strerror(errno));
        return 0;
    }
    close(fd);
    if (created) unlink(path);
    return 1;
}
