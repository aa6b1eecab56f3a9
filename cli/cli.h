/* cli.h - the command-line plumbing that picvr's example and bench programs share
 * (picvr-render, picvr-bench-error, picvr-bench-speed, picvr-bench-fig9).
 *
 *   - options from a table: "--name value", "--name=value" and flags
 *     (pvc_parse_options);
 *   - strict parsers of option values: the whole text must be a valid value
 *     (numbers, comma lists X,Y,Z, sizes WxH, on/off switches, cache modes);
 *   - messages on stderr prefixed with the program's name (pvc_fail);
 *   - a monotonic clock in milliseconds;
 *   - the PFM image format (RGB floats, little-endian: header scale -1) and raw
 *     little-endian float32 arrays;
 *   - JSON output from tables of {name, type, offset} rows that describe a struct
 *     (pvc_json_write).
 *
 * Plain C11 + POSIX.  picvr.h is used for its types only, except pvc_check (inline,
 * so a program that does not call it need not link the library).
 */
#ifndef PICVR_CLI_H
#define PICVR_CLI_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "picvr.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- messages ---------------------------------------------------------------------- */

/* The name that prefixes every message (set once, first thing in main). */
void pvc_set_program(const char *name);
const char *pvc_program(void);

/* "PROGRAM: error: <message>" and a newline on stderr. */
void pvc_fail(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

/* "PROGRAM: error: bad value for --NAME: 'VALUE' (see --help)". */
void pvc_bad_value(const char *name, const char *value);

/* 1 for PICVR_OK; otherwise reports "WHAT: <status>" and returns 0. */
static inline int pvc_check(picvr_status status, const char *what)
{
    if (status == PICVR_OK) return 1;
    pvc_fail("%s: %s", what, picvr_status_string(status));
    return 0;
}

/* Milliseconds of CLOCK_MONOTONIC (an arbitrary origin: for differences only). */
double pvc_now_ms(void);

/* 1 if the program may write `path` (an output file it will write after a long render),
   else 0 after pvc_fail naming the path and the reason (a missing folder, a folder in
   the way, no permission, a read-only file system).  An existing file is opened for
   writing without truncating it; a new one is created and removed again. */
int pvc_check_writable(const char *path);

/* ---- options ------------------------------------------------------------------------ */

/* One row of a program's option table, which ends with a row whose name is NULL. */
typedef struct pvc_option {
    const char *name;         /* without the leading "--" */
    int takes_value;          /* 0: a flag */
} pvc_option;

#define PVC_EXIT_USAGE 2

/* Applies one option to target (value NULL for a flag): 1 applied, 0 a bad value that
   the function has reported (pvc_bad_value or a message of its own). */
typedef int (*pvc_apply_fn)(void *target, const char *name, const char *value);

/* Reads argv[1..] against the table: "--name value", "--name=value" and flags, each
   handed to apply in order.  The option "help" (when the table has it) calls
   help(stdout) and stops.  Returns -1 after applying every option, 0 after --help,
   PVC_EXIT_USAGE after a usage error it reported (an argument that does not start
   with "--", an option not in the table, a missing value, a flag given "=value", a
   value apply refused). */
int pvc_parse_options(int argc, char **argv, const pvc_option *options, pvc_apply_fn apply,
                      void *target, void (*help)(FILE *));

/* pvc_parse_options, where an argument that does not start with "--" is the value of
   the option named positional (picvr-render scan.nii.gz: --volume scan.nii.gz). */
int pvc_parse_options_positional(int argc, char **argv, const pvc_option *options, const char *positional,
                                 pvc_apply_fn apply, void *target, void (*help)(FILE *));

/* A program's options in groups: a group applies the options it knows like a
   pvc_apply_fn but reports nothing, and returns -1 for an option not its own. */
typedef int (*pvc_group_fn)(void *target, const char *name, const char *value);

/* Applies the option by the first of the count groups that knows it: 1 applied; 0
   after reporting a bad value (pvc_bad_value) or an option no group knows. */
int pvc_apply_by_group(const pvc_group_fn *groups, size_t count, void *target, const char *name,
                       const char *value);

/* ---- values (1: parsed into *out; 0: not a valid value, *out unchanged) ------------- */

int pvc_parse_u32(const char *text, uint32_t min, uint32_t max, uint32_t *out);
int pvc_parse_double(const char *text, double *out);          /* finite */
int pvc_parse_float(const char *text, float *out);            /* finite as a float */

/* Exactly n (1..8) comma-separated numbers: "X,Y,Z". */
int pvc_parse_floats(const char *text, int n, float *out);
int pvc_parse_u32s(const char *text, int n, uint32_t min, uint32_t max, uint32_t *out);

/* "WxH", both 1..max. */
int pvc_parse_size(const char *text, uint32_t max, uint32_t *width, uint32_t *height);

/* "on" or "off". */
int pvc_parse_switch(const char *text, picvr_switch *out);

/* picvr_scattering.max_bounces: "unlimited" (PICVR_BOUNCES_UNLIMITED) or a count N,
   0 <= N < PICVR_BOUNCES_UNLIMITED. */
int pvc_parse_bounces(const char *text, uint32_t *out);

/* "on", "off" or "default". */
const char *pvc_switch_name(picvr_switch s);

/* "off" (or "none"), "object", "screen" or "auto". */
int pvc_parse_cache_mode(const char *text, picvr_cache_mode *out);

/* "default", "none", "object", "screen" or "auto". */
const char *pvc_cache_mode_name(picvr_cache_mode mode);

/* "default", "debug", "info", "warning", "error"; "?" for another value. */
const char *pvc_log_level_name(picvr_log_level level);
/* "default", "mis", "free-flight", "forced", "auto" and "default", "residual", "ratio",
   "ray-marching" ("?" otherwise);
   the parsers take the names but "default". */
const char *pvc_distance_sampling_name(picvr_distance_sampling d);
const char *pvc_transmittance_name(picvr_transmittance_estimator t);
int pvc_parse_distance_sampling(const char *text, picvr_distance_sampling *out);
int pvc_parse_transmittance(const char *text, picvr_transmittance_estimator *out);
/* "mc", "field" or "field-mc" (picvr_field_config.mode). */
int pvc_parse_render_mode(const char *text, picvr_render_mode *out);

/* Whether name is one of the comma-separated list's items (a NULL list holds all). */
int pvc_in_list(const char *list, const char *name);

/* ---- images and float arrays -------------------------------------------------------- */

/* n floats as IEEE-754 little-endian bytes, whatever the host's byte order. */
int pvc_write_floats_le(FILE *f, const float *v, size_t n);
int pvc_read_floats_le(FILE *f, float *v, size_t n);
/* The same packing in memory: n floats to 4 n little-endian bytes, and 4 n bytes of the
   given order (1: big-endian) to n floats. */
void pvc_floats_to_le(const float *v, size_t n, unsigned char *bytes);
void pvc_floats_from_bytes(const unsigned char *bytes, size_t n, int big_endian, float *v);

/* Writes rgba (width * height RGBA floats, rows top to bottom) as an RGB PFM: "PF",
   the size, scale -1 (little-endian), rows bottom to top.  Reports a failure. */
int pvc_write_pfm(const char *path, const float *rgba, uint32_t width, uint32_t height);

/* Reads an RGB PFM of exactly width x height, in the byte order its scale declares
   (negative: little-endian), into rgb (width * height * 3 floats, rows top to
   bottom).  Reports a failure. */
int pvc_read_pfm(const char *path, uint32_t width, uint32_t height, float *rgb);

/* ---- JSON ---------------------------------------------------------------------------- */

/* The type of a value at an offset of the struct a table describes. */
typedef enum pvc_json_type {
    PVC_JSON_U32,             /* uint32_t */
    PVC_JSON_U64,             /* uint64_t */
    PVC_JSON_F32,             /* float, written as %.9g; NaN and infinities as null */
    PVC_JSON_F64,             /* double, likewise */
    PVC_JSON_CHARS,           /* char[count], up to its first NUL */
    PVC_JSON_STRING,          /* const char * (NULL: null) */
    PVC_JSON_SWITCH,          /* picvr_switch, by pvc_switch_name */
    PVC_JSON_CACHE_MODE,      /* picvr_cache_mode, by pvc_cache_mode_name */
    PVC_JSON_LOG_LEVEL,       /* picvr_log_level, by pvc_log_level_name */
    PVC_JSON_DISTANCE,        /* picvr_distance_sampling, by pvc_distance_sampling_name */
    PVC_JSON_TRANSMITTANCE,   /* picvr_transmittance_estimator, by pvc_transmittance_name */
    PVC_JSON_BOUNCES,         /* uint32_t max_bounces: a number, "unlimited" for
                                 PICVR_BOUNCES_UNLIMITED */
    PVC_JSON_OBJECT,          /* a struct described by fields[count] */
    PVC_JSON_ARRAY            /* a pvc_json_array of structs described by fields[count] */
} pvc_json_type;

/* An array of structs for PVC_JSON_ARRAY: `length` items `stride` bytes apart. */
typedef struct pvc_json_array {
    const void *items;
    size_t length, stride;
} pvc_json_array;

/* One row of a table that describes a struct as a JSON object. */
typedef struct pvc_json_field {
    const char *name;
    pvc_json_type type;
    size_t offset;            /* offsetof(the struct, the member) */
    size_t count;             /* CHARS: the array's size; OBJECT, ARRAY: rows in fields */
    const struct pvc_json_field *fields; /* OBJECT, ARRAY: the table of the (item) struct */
} pvc_json_field;

/* Writes the struct at base as one JSON object on one line, {"name": value, ...},
   its members in the table's order. */
void pvc_json_write(FILE *f, const void *base, const pvc_json_field *fields, size_t count);

/* 1 when path ends in ext (".png", ...), ASCII case-insensitive. */
int pvc_has_extension(const char *path, const char *ext);

/* A JSON string literal, escaped. */
void pvc_json_string(FILE *f, const char *s);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_CLI_H */
