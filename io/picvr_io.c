/* picvr_io.c - see picvr_io.h.  Written to survive hostile names and files (it is
 * fuzzed): no fixed-size copies of the input, every size product checked, and the
 * buffer grows with the data actually read, so a tiny file claiming a huge layout
 * never makes us allocate the huge size up front. */
#include "picvr_io.h"
#include "io/internal.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <zlib.h>

/* Longest piece of a file name quoted in a message, so messages stay readable. */
#define NAME_QUOTE_MAX 120
/* First buffer size when reading; doubled as data arrives (up to the layout size). */
#define INITIAL_READ_BYTES ((size_t)16 << 20)
/* Largest single gzread() request: its length is an unsigned int, its result an int. */
#define MAX_READ_CHUNK ((size_t)1 << 30)

#define set_error picvr_io_set_error

void picvr_io_set_error(char *err, size_t err_size, const char *fmt, ...)
{
    if (!err || err_size == 0) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, err_size, fmt, ap);
    va_end(ap);
}

const char *picvr_io_status_string(picvr_io_status status)
{
    switch (status) {
    case PICVR_IO_OK: return "PICVR_IO_OK";
    case PICVR_IO_ERROR_NULL_POINTER: return "PICVR_IO_ERROR_NULL_POINTER";
    case PICVR_IO_ERROR_BAD_NAME: return "PICVR_IO_ERROR_BAD_NAME";
    case PICVR_IO_ERROR_BAD_DIMS: return "PICVR_IO_ERROR_BAD_DIMS";
    case PICVR_IO_ERROR_BAD_TYPE: return "PICVR_IO_ERROR_BAD_TYPE";
    case PICVR_IO_ERROR_SIZE_OVERFLOW: return "PICVR_IO_ERROR_SIZE_OVERFLOW";
    case PICVR_IO_ERROR_OPEN: return "PICVR_IO_ERROR_OPEN";
    case PICVR_IO_ERROR_READ: return "PICVR_IO_ERROR_READ";
    case PICVR_IO_ERROR_TRUNCATED: return "PICVR_IO_ERROR_TRUNCATED";
    case PICVR_IO_ERROR_TOO_LONG: return "PICVR_IO_ERROR_TOO_LONG";
    case PICVR_IO_ERROR_OUT_OF_MEMORY: return "PICVR_IO_ERROR_OUT_OF_MEMORY";
    case PICVR_IO_ERROR_BAD_HEADER: return "PICVR_IO_ERROR_BAD_HEADER";
    case PICVR_IO_ERROR_UNSUPPORTED: return "PICVR_IO_ERROR_UNSUPPORTED";
    case PICVR_IO_STATUS_COUNT: break;
    }
    return "PICVR_IO_ERROR_UNKNOWN_STATUS";
}

size_t picvr_io_voxel_size(picvr_voxel_type type)
{
    switch (type) {
    case PICVR_VOXEL_UINT8: case PICVR_VOXEL_INT8: return 1;
    case PICVR_VOXEL_UINT16: case PICVR_VOXEL_INT16: case PICVR_VOXEL_FLOAT16: return 2;
    case PICVR_VOXEL_FLOAT32: case PICVR_VOXEL_INT32: return 4;
    case PICVR_VOXEL_FLOAT64: return 8;
    }
    return 0;
}

const char *picvr_io_type_name(picvr_voxel_type type)
{
    switch (type) {
    case PICVR_VOXEL_UINT8: return "uint8";
    case PICVR_VOXEL_UINT16: return "uint16";
    case PICVR_VOXEL_FLOAT32: return "float32";
    case PICVR_VOXEL_INT8: return "int8";
    case PICVR_VOXEL_INT16: return "int16";
    case PICVR_VOXEL_INT32: return "int32";
    case PICVR_VOXEL_FLOAT16: return "float16";
    case PICVR_VOXEL_FLOAT64: return "float64";
    }
    return "unknown";
}

/* ---- name parsing (pure functions on (pointer, length) pieces of the name) ------ */

static int ascii_lower(int c)
{
    return (c >= 'A' && c <= 'Z') ? c - 'A' + 'a' : c;
}

/* Case-insensitive comparison of the piece s[0..len) with a NUL-terminated word. */
static int piece_equals(const char *s, size_t len, const char *word)
{
    if (strlen(word) != len) return 0;
    for (size_t i = 0; i < len; i++)
        if (ascii_lower((unsigned char)s[i]) != word[i]) return 0;
    return 1;
}

static int piece_ends_with(const char *s, size_t len, const char *suffix)
{
    size_t n = strlen(suffix);
    return len >= n && piece_equals(s + len - n, n, suffix);
}

static picvr_io_status parse_type_piece(const char *s, size_t len, picvr_voxel_type *type)
{
    static const struct { const char *name, *abbrev; picvr_voxel_type type; } names[] = {
        {"uint8", "u8", PICVR_VOXEL_UINT8},       {"uint16", "u16", PICVR_VOXEL_UINT16},
        {"float32", "f32", PICVR_VOXEL_FLOAT32},  {"int8", "i8", PICVR_VOXEL_INT8},
        {"int16", "i16", PICVR_VOXEL_INT16},      {"int32", "i32", PICVR_VOXEL_INT32},
        {"float16", "f16", PICVR_VOXEL_FLOAT16},  {"float64", "f64", PICVR_VOXEL_FLOAT64}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (piece_equals(s, len, names[i].name) || piece_equals(s, len, names[i].abbrev)) {
            *type = names[i].type;
            return PICVR_IO_OK;
        }
    return PICVR_IO_ERROR_BAD_TYPE;
}

picvr_io_status picvr_io_parse_type(const char *text, picvr_voxel_type *type)
{
    if (!text || !type) return PICVR_IO_ERROR_NULL_POINTER;
    return parse_type_piece(text, strlen(text), type);
}

/* Decimal digits only.  Stops accumulating once past PICVR_IO_MAX_DIM, so any number of
   digits is safe: BAD_NAME for a non-digit or an empty piece, BAD_DIMS for 0 or a
   value above the limit. */
static picvr_io_status parse_dim_piece(const char *s, size_t len, uint32_t *dim)
{
    if (len == 0) return PICVR_IO_ERROR_BAD_NAME;
    uint32_t v = 0;
    int too_big = 0;
    for (size_t i = 0; i < len; i++) {
        if (s[i] < '0' || s[i] > '9') return PICVR_IO_ERROR_BAD_NAME;
        if (!too_big) {
            v = v * 10u + (uint32_t)(s[i] - '0');
            if (v > PICVR_IO_MAX_DIM) too_big = 1;
        }
    }
    if (too_big || v == 0) return PICVR_IO_ERROR_BAD_DIMS;
    *dim = v;
    return PICVR_IO_OK;
}

/* "XxYxZ" -> three dims.  BAD_NAME beats BAD_DIMS so a malformed piece is reported
   as such even when an earlier number is out of range. */
static picvr_io_status parse_dims_piece(const char *s, size_t len, uint32_t dims[3])
{
    picvr_io_status worst = PICVR_IO_OK;
    size_t start = 0;
    int axis = 0;
    for (size_t i = 0; i <= len; i++) {
        if (i < len && s[i] != 'x' && s[i] != 'X') continue;
        if (axis == 3) return PICVR_IO_ERROR_BAD_NAME; /* a fourth number */
        picvr_io_status st = parse_dim_piece(s + start, i - start, &dims[axis]);
        if (st == PICVR_IO_ERROR_BAD_NAME) return st;
        if (st != PICVR_IO_OK) worst = st;
        axis++;
        start = i + 1;
    }
    if (axis != 3) return PICVR_IO_ERROR_BAD_NAME;
    return worst;
}

picvr_io_status picvr_io_layout_bytes(const picvr_io_layout *layout, size_t *bytes,
                              char *err, size_t err_size)
{
    if (!layout) {
        set_error(err, err_size, "no layout given");
        return PICVR_IO_ERROR_NULL_POINTER;
    }
    size_t total = picvr_io_voxel_size(layout->type);
    if (total == 0) {
        set_error(err, err_size, "unknown voxel type %d", (int)layout->type);
        return PICVR_IO_ERROR_BAD_TYPE;
    }
    for (int i = 0; i < 3; i++) {
        uint32_t d = layout->dims[i];
        if (d < 1 || d > PICVR_IO_MAX_DIM) {
            set_error(err, err_size, "dimension %d is %lu, must be 1..%u", i,
                      (unsigned long)d, PICVR_IO_MAX_DIM);
            return PICVR_IO_ERROR_BAD_DIMS;
        }
        if (total > SIZE_MAX / d) {
            set_error(err, err_size, "volume %lux%lux%lu %s does not fit in memory",
                      (unsigned long)layout->dims[0], (unsigned long)layout->dims[1],
                      (unsigned long)layout->dims[2], picvr_io_type_name(layout->type));
            return PICVR_IO_ERROR_SIZE_OVERFLOW;
        }
        total *= d;
    }
    if (bytes) *bytes = total;
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_parse_name(const char *path, picvr_io_layout *layout,
                            char *err, size_t err_size)
{
    if (!path || !layout) {
        set_error(err, err_size, "no file name given");
        return PICVR_IO_ERROR_NULL_POINTER;
    }
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    size_t len = strlen(base);
    int quote = len > NAME_QUOTE_MAX ? NAME_QUOTE_MAX : (int)len;

    /* NAME_XxYxZ_TYPE.raw[.gz]: peel the suffixes, then read the last two '_' fields. */
    if (piece_ends_with(base, len, ".gz")) len -= 3;
    if (!piece_ends_with(base, len, ".raw")) {
        set_error(err, err_size, "'%.*s': name must end in .raw or .raw.gz "
                  "(NAME_XxYxZ_TYPE.raw[.gz]); otherwise give --dims and --type", quote, base);
        return PICVR_IO_ERROR_BAD_NAME;
    }
    len -= 4;

    size_t type_sep = len;
    while (type_sep > 0 && base[type_sep - 1] != '_') type_sep--;
    if (type_sep == 0) {
        set_error(err, err_size, "'%.*s': no _XxYxZ_TYPE before .raw", quote, base);
        return PICVR_IO_ERROR_BAD_NAME;
    }
    size_t dims_start = type_sep - 1;
    while (dims_start > 0 && base[dims_start - 1] != '_') dims_start--;

    picvr_io_layout parsed = {{0, 0, 0}, PICVR_VOXEL_UINT8};
    if (parse_type_piece(base + type_sep, len - type_sep, &parsed.type) != PICVR_IO_OK) {
        set_error(err, err_size, "'%.*s': unknown voxel type '%.*s' "
                  "(use uint8, uint16, float32, int8, int16, int32, float16, float64 or u8, u16, f32, i8, i16, i32, f16, f64)", quote, base,
                  (int)(len - type_sep > 20 ? 20 : len - type_sep), base + type_sep);
        return PICVR_IO_ERROR_BAD_TYPE;
    }
    picvr_io_status st = parse_dims_piece(base + dims_start, type_sep - 1 - dims_start,
                                      parsed.dims);
    if (st == PICVR_IO_ERROR_BAD_NAME) {
        set_error(err, err_size, "'%.*s': expected dimensions XxYxZ (e.g. 256x256x128) "
                  "before _TYPE", quote, base);
        return st;
    }
    if (st != PICVR_IO_OK) {
        set_error(err, err_size, "'%.*s': every dimension must be 1..%u", quote, base,
                  PICVR_IO_MAX_DIM);
        return st;
    }
    st = picvr_io_layout_bytes(&parsed, NULL, err, err_size);
    if (st == PICVR_IO_OK) *layout = parsed;
    return st;
}

/* ---- loading ------------------------------------------------------------------- */

static int host_is_little_endian(void)
{
    const uint16_t one = 1;
    unsigned char first;
    memcpy(&first, &one, 1);
    return first == 1;
}

/* Files are little-endian; swap multi-byte voxels on a big-endian host. */
static void little_endian_to_host(unsigned char *data, size_t bytes, size_t voxel_size)
{
    if (voxel_size < 2 || host_is_little_endian()) return;
    for (size_t i = 0; i + voxel_size <= bytes; i += voxel_size)
        for (size_t a = 0, b = voxel_size - 1; a < b; a++, b--) {
            unsigned char t = data[i + a];
            data[i + a] = data[i + b];
            data[i + b] = t;
        }
}

/* zlib's message for the last error, without the "path: " prefix zlib puts in front
   (our messages already start with the path). */
#define gz_message picvr_io_gz_message

const char *picvr_io_gz_message(gzFile gz, const char *path, int *errnum)
{
    const char *msg = gzerror(gz, errnum);
    if (*errnum == Z_ERRNO) return strerror(errno);
    if (!msg) return "unknown error";
    size_t n = strlen(path);
    if (strncmp(msg, path, n) == 0 && msg[n] == ':' && msg[n + 1] == ' ') msg += n + 2;
    return msg;
}

/* Reads up to `expected` bytes into a buffer that grows as data arrives.  Returns
   the buffer (caller frees) and how many bytes came in *got. */
static picvr_io_status read_up_to(gzFile gz, const char *path, size_t expected,
                              unsigned char **out, size_t *got, char *err, size_t err_size)
{
    size_t cap = expected < INITIAL_READ_BYTES ? expected : INITIAL_READ_BYTES;
    unsigned char *buf = malloc(cap);
    size_t have = 0;
    if (!buf) goto out_of_memory;
    for (;;) {
        if (have == cap) {
            if (cap == expected) break;
            size_t next = cap > expected / 2 ? expected : cap * 2;
            unsigned char *grown = realloc(buf, next);
            if (!grown) goto out_of_memory;
            buf = grown;
            cap = next;
        }
        size_t want = cap - have < MAX_READ_CHUNK ? cap - have : MAX_READ_CHUNK;
        int n = gzread(gz, buf + have, (unsigned)want);
        if (n < 0) {
            int errnum;
            set_error(err, err_size, "%s: read error: %s", path, gz_message(gz, path, &errnum));
            free(buf);
            return PICVR_IO_ERROR_READ;
        }
        if (n == 0) break;
        have += (size_t)n;
    }
    *out = buf;
    *got = have;
    return PICVR_IO_OK;

out_of_memory:
    set_error(err, err_size, "%s: out of memory for %zu bytes", path, expected);
    free(buf);
    return PICVR_IO_ERROR_OUT_OF_MEMORY;
}

/* After `have` bytes: the file must end here, and a gzip stream must end cleanly
   (reading on verifies its CRC and length trailer). */
static picvr_io_status check_end_of_data(gzFile gz, const char *path, size_t have,
                                     size_t expected, char *err, size_t err_size)
{
    int errnum = Z_OK;
    if (have < expected) {
        const char *msg = gz_message(gz, path, &errnum);
        if (errnum == Z_BUF_ERROR) {
            set_error(err, err_size, "%s: truncated gzip data (%s) after %zu of %zu bytes",
                      path, msg, have, expected);
        } else {
            set_error(err, err_size, "%s: truncated: %zu bytes, the layout needs %zu",
                      path, have, expected);
        }
        return PICVR_IO_ERROR_TRUNCATED;
    }
    unsigned char extra;
    int n = gzread(gz, &extra, 1);
    if (n < 0) {
        set_error(err, err_size, "%s: read error: %s", path, gz_message(gz, path, &errnum));
        return PICVR_IO_ERROR_READ;
    }
    if (n > 0) {
        set_error(err, err_size, "%s: too long: more than the %zu bytes the layout needs",
                  path, expected);
        return PICVR_IO_ERROR_TOO_LONG;
    }
    const char *msg = gz_message(gz, path, &errnum);
    if (errnum == Z_BUF_ERROR) {
        set_error(err, err_size, "%s: truncated gzip data (%s); check sum not verified",
                  path, msg);
        return PICVR_IO_ERROR_TRUNCATED;
    }
    if (errnum != Z_OK) {
        set_error(err, err_size, "%s: read error: %s", path, msg);
        return PICVR_IO_ERROR_READ;
    }
    return PICVR_IO_OK;
}

/* For an uncompressed regular file the size is known up front: a precise early error. */
static picvr_io_status check_plain_file_size(gzFile gz, const struct stat *st, const char *path,
                                         size_t expected, char *err, size_t err_size)
{
    if (!S_ISREG(st->st_mode) || !gzdirect(gz)) return PICVR_IO_OK;
    if (st->st_size < 0) return PICVR_IO_OK;
    uintmax_t actual = (uintmax_t)st->st_size;
    if (actual < expected) {
        set_error(err, err_size, "%s: truncated: %ju bytes, the layout needs %zu",
                  path, actual, expected);
        return PICVR_IO_ERROR_TRUNCATED;
    }
    if (actual > expected) {
        set_error(err, err_size, "%s: too long: %ju bytes, the layout needs %zu",
                  path, actual, expected);
        return PICVR_IO_ERROR_TOO_LONG;
    }
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_gzopen(const char *path, int allow_fifo, gzFile *out, struct stat *st, char *err,
                                size_t err_size)
{
    if (stat(path, st) != 0) {
        set_error(err, err_size, "%s: %s", path, strerror(errno));
        return PICVR_IO_ERROR_OPEN;
    }
    if (!S_ISREG(st->st_mode) && !(allow_fifo && S_ISFIFO(st->st_mode))) {
        set_error(err, err_size, "%s: not a regular file", path);
        return PICVR_IO_ERROR_OPEN;
    }
    errno = 0;
    gzFile gz = gzopen(path, "rb");
    if (!gz) {
        set_error(err, err_size, "%s: %s", path, errno ? strerror(errno) : "cannot open");
        return errno ? PICVR_IO_ERROR_OPEN : PICVR_IO_ERROR_OUT_OF_MEMORY;
    }
    gzbuffer(gz, 1u << 18);   /* fewer system calls than the 8 KiB default */
    *out = gz;
    return PICVR_IO_OK;
}

static picvr_io_status read_volume_file(const char *path, size_t expected, unsigned char **data,
                                    char *err, size_t err_size)
{
    struct stat st;
    gzFile gz;
    picvr_io_status opened = picvr_io_gzopen(path, 1, &gz, &st, err, err_size);
    if (opened != PICVR_IO_OK) return opened;
    unsigned char *buf = NULL;
    size_t have = 0;
    picvr_io_status status = check_plain_file_size(gz, &st, path, expected, err, err_size);
    if (status == PICVR_IO_OK)
        status = read_up_to(gz, path, expected, &buf, &have, err, err_size);
    if (status == PICVR_IO_OK)
        status = check_end_of_data(gz, path, have, expected, err, err_size);
    gzclose(gz);
    if (status != PICVR_IO_OK) {
        free(buf);
        return status;
    }
    *data = buf;
    return PICVR_IO_OK;
}

/* ---- NRRD (.nrrd with the data attached, .nhdr with a detached data file) -------------
 * A reader of the documented format (teem.sourceforge.net/nrrd/format.html), for the
 * subset volumes use: magic NRRD0001..NRRD0005; dimension 3; the sizes; a type picvr
 * holds (int8, uint8, int16, uint16, int32, float, double; uint32 and 64-bit integers
 * are refused); encoding raw or gzip; endian; spacings or space directions (their
 * lengths are the spacing, their unit vectors the orientation) and space origin; a data
 * file relative to the header's folder; byte skip (>= 0, or -1 for raw: the data ends
 * the file).  Comments (#) and key:=value pairs are skipped, fields the renderer does
 * not use (kinds, units, labels, ...) ignored.  Everything else is refused with a
 * message, never guessed. */

#define NRRD_MAX_HEADER 65536   /* bytes of header read at most */
#define NRRD_MAX_LINE 4096

typedef struct nrrd_header {
    int dimension, have_sizes, have_type, have_encoding, gzip, big_endian, have_endian;
    uint32_t dims[3];
    picvr_voxel_type type;
    double spacing[3], direction[9], origin[3];
    int have_directions, have_origin;
    int flip_x, flip_y;        /* the header's "space" is RAS or LAS: negated into LPS */
    int anatomical;            /* the header's "space" is RAS, LAS or LPS */
    long long byte_skip;
    char data_file[1024];
} nrrd_header;

static const char *trim(char *s)
{
    while (*s == ' ' || *s == '\t') s++;
    size_t n = strlen(s);
    while (n > 0 && (s[n - 1] == ' ' || s[n - 1] == '\t' || s[n - 1] == '\r' || s[n - 1] == '\n')) s[--n] = '\0';
    return s;
}

static int nrrd_type(const char *v, picvr_voxel_type *t)
{
    static const struct { const char *name; picvr_voxel_type type; } names[] = {
        {"signed char", PICVR_VOXEL_INT8}, {"int8", PICVR_VOXEL_INT8}, {"int8_t", PICVR_VOXEL_INT8},
        {"uchar", PICVR_VOXEL_UINT8}, {"unsigned char", PICVR_VOXEL_UINT8}, {"uint8", PICVR_VOXEL_UINT8},
        {"uint8_t", PICVR_VOXEL_UINT8}, {"short", PICVR_VOXEL_INT16}, {"short int", PICVR_VOXEL_INT16},
        {"signed short", PICVR_VOXEL_INT16}, {"signed short int", PICVR_VOXEL_INT16}, {"int16", PICVR_VOXEL_INT16},
        {"int16_t", PICVR_VOXEL_INT16}, {"ushort", PICVR_VOXEL_UINT16}, {"unsigned short", PICVR_VOXEL_UINT16},
        {"unsigned short int", PICVR_VOXEL_UINT16}, {"uint16", PICVR_VOXEL_UINT16}, {"uint16_t", PICVR_VOXEL_UINT16},
        {"int", PICVR_VOXEL_INT32}, {"signed int", PICVR_VOXEL_INT32}, {"int32", PICVR_VOXEL_INT32},
        {"int32_t", PICVR_VOXEL_INT32}, {"float", PICVR_VOXEL_FLOAT32}, {"double", PICVR_VOXEL_FLOAT64}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (!strcmp(v, names[i].name)) {
            *t = names[i].type;
            return 1;
        }
    return 0;
}

/* "(a,b,c)" into v[3]; 0 unless three finite numbers. */
static int nrrd_vector(const char **p, double v[3])
{
    const char *s = *p;
    while (*s == ' ' || *s == '\t') s++;
    if (*s++ != '(') return 0;
    for (int i = 0; i < 3; i++) {
        char *end;
        errno = 0;
        v[i] = strtod(s, &end);
        if (end == s || errno == ERANGE || !isfinite(v[i])) return 0;
        s = end;
        while (*s == ' ' || *s == '\t') s++;
        if (*s++ != (i < 2 ? ',' : ')')) return 0;
    }
    *p = s;
    return 1;
}

/* Three numbers separated by blanks: finite and positive (spacings) or >= 1 (sizes). */
static int nrrd_numbers(const char *s, double v[3], int sizes)
{
    for (int i = 0; i < 3; i++) {
        char *end;
        errno = 0;
        v[i] = strtod(s, &end);
        if (end == s || errno == ERANGE || !isfinite(v[i]) || !(v[i] > 0.0)) return 0;
        if (sizes && (v[i] != floor(v[i]) || v[i] > PICVR_IO_MAX_DIM)) return 0;
        s = end;
    }
    while (*s == ' ' || *s == '\t') s++;
    return *s == '\0';
}

static picvr_io_status nrrd_field(nrrd_header *h, const char *key, const char *v, const char *path, char *err, size_t err_size)
{
    double n[3];
    if (!strcmp(key, "dimension")) {
        if (strcmp(v, "3")) {
            set_error(err, err_size, "%s: NRRD dimension %s: picvr reads 3-dimensional volumes", path, v);
            return PICVR_IO_ERROR_BAD_DIMS;
        }
        h->dimension = 3;
    } else if (!strcmp(key, "sizes")) {
        if (!nrrd_numbers(v, n, 1)) {
            set_error(err, err_size, "%s: NRRD sizes '%s': three sizes in 1..%u", path, v, PICVR_IO_MAX_DIM);
            return PICVR_IO_ERROR_BAD_DIMS;
        }
        for (int i = 0; i < 3; i++) h->dims[i] = (uint32_t)n[i];
        h->have_sizes = 1;
    } else if (!strcmp(key, "type")) {
        if (!nrrd_type(v, &h->type)) {
            set_error(err, err_size, "%s: NRRD type '%s' is not one picvr holds", path, v);
            return PICVR_IO_ERROR_BAD_TYPE;
        }
        h->have_type = 1;
    } else if (!strcmp(key, "encoding")) {
        if (!strcmp(v, "raw")) h->gzip = 0;
        else if (!strcmp(v, "gzip") || !strcmp(v, "gz")) h->gzip = 1;
        else {
            set_error(err, err_size, "%s: NRRD encoding '%s' is not read (raw and gzip are)", path, v);
            return PICVR_IO_ERROR_BAD_HEADER;
        }
        h->have_encoding = 1;
    } else if (!strcmp(key, "endian")) {
        if (strcmp(v, "little") && strcmp(v, "big")) {
            set_error(err, err_size, "%s: NRRD endian '%s'", path, v);
            return PICVR_IO_ERROR_BAD_HEADER;
        }
        h->big_endian = !strcmp(v, "big");
        h->have_endian = 1;
    } else if (!strcmp(key, "spacings")) {
        if (!nrrd_numbers(v, n, 0)) {
            set_error(err, err_size, "%s: NRRD spacings '%s': three positive numbers", path, v);
            return PICVR_IO_ERROR_BAD_DIMS;
        }
        for (int i = 0; i < 3; i++) h->spacing[i] = n[i];
    } else if (!strcmp(key, "space")) {
        /* Only the three anatomical spaces have a fixed relation to LPS; any other space
           (scanner-xyz, 3D-right-handed, ...) is taken as it is. */
        int ras = !strcmp(v, "right-anterior-superior") || !strcmp(v, "RAS");
        int las = !strcmp(v, "left-anterior-superior") || !strcmp(v, "LAS");
        h->flip_x = ras;
        h->flip_y = ras || las;
        h->anatomical = ras || las || !strcmp(v, "left-posterior-superior") || !strcmp(v, "LPS");
    } else if (!strcmp(key, "space directions")) {
        const char *s = v;
        for (int a = 0; a < 3; a++) {
            double d[3];
            double len = nrrd_vector(&s, d) ? sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) : 0.0;
            if (!(len > 0.0) || !isfinite(len)) {
                set_error(err, err_size, "%s: NRRD space directions '%s': three non-zero vectors (a,b,c)", path, v);
                return PICVR_IO_ERROR_BAD_DIMS;
            }
            h->spacing[a] = len;
            for (int c = 0; c < 3; c++) h->direction[3 * a + c] = d[c] / len;
        }
        h->have_directions = 1;
    } else if (!strcmp(key, "space origin")) {
        const char *s = v;
        if (!nrrd_vector(&s, h->origin)) {
            set_error(err, err_size, "%s: NRRD space origin '%s': (x,y,z)", path, v);
            return PICVR_IO_ERROR_BAD_DIMS;
        }
        h->have_origin = 1;
    } else if (!strcmp(key, "byte skip")) {
        char *end;
        errno = 0;
        h->byte_skip = strtoll(v, &end, 10);
        if (end == v || *end || errno == ERANGE || h->byte_skip < -1) {
            set_error(err, err_size, "%s: NRRD byte skip '%s'", path, v);
            return PICVR_IO_ERROR_BAD_HEADER;
        }
    } else if (!strcmp(key, "line skip") || !strcmp(key, "lineskip")) {
        if (strcmp(v, "0")) {
            set_error(err, err_size, "%s: NRRD line skip %s is not read", path, v);
            return PICVR_IO_ERROR_BAD_HEADER;
        }
    } else if (!strcmp(key, "data file") || !strcmp(key, "datafile")) {
        if (!*v || strlen(v) >= sizeof h->data_file || !strcmp(v, "LIST") || strchr(v, '%')) {
            set_error(err, err_size, "%s: NRRD data file '%s' is not read (one file name is)", path, v);
            return PICVR_IO_ERROR_BAD_HEADER;
        }
        snprintf(h->data_file, sizeof h->data_file, "%s", v);
    }
    return PICVR_IO_OK;   /* other fields describe what picvr does not use */
}

/* Reads the header: fields until the blank line (attached data follows it) or the end
   of the file (.nhdr); *data_at is the offset after the blank line. */
static picvr_io_status nrrd_read_header(FILE *f, const char *path, nrrd_header *h, long *data_at, char *err, size_t err_size)
{
    char line[NRRD_MAX_LINE];
    memset(h, 0, sizeof *h);
    h->spacing[0] = h->spacing[1] = h->spacing[2] = 1.0;
    h->direction[0] = h->direction[4] = h->direction[8] = 1.0;
    if (!fgets(line, sizeof line, f) || strncmp(line, "NRRD000", 7) || line[7] < '1' || line[7] > '5' ||
        (line[8] != '\n' && line[8] != '\r')) {
        set_error(err, err_size, "%s: not a NRRD file (no NRRD0001..NRRD0005 magic line)", path);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    while (fgets(line, sizeof line, f)) {
        long at = ftell(f);
        if (at < 0 || at > NRRD_MAX_HEADER || !strchr(line, '\n')) {
            set_error(err, err_size, "%s: NRRD header line too long, or header over %d bytes", path, NRRD_MAX_HEADER);
            return PICVR_IO_ERROR_BAD_HEADER;
        }
        if (line[0] == '\n' || (line[0] == '\r' && line[1] == '\n')) {
            *data_at = at;
            return PICVR_IO_OK;
        }
        if (line[0] == '#') continue;
        if (strstr(line, ":=")) continue;   /* key/value pairs */
        char *colon = strstr(line, ": ");
        if (!colon) {
            set_error(err, err_size, "%s: NRRD header line without 'field: value': %.60s", path, trim(line));
            return PICVR_IO_ERROR_BAD_HEADER;
        }
        *colon = '\0';
        picvr_io_status st = nrrd_field(h, trim(line), trim(colon + 2), path, err, err_size);
        if (st != PICVR_IO_OK) return st;
    }
    if (ferror(f)) {
        set_error(err, err_size, "%s: read error: %s", path, strerror(errno));
        return PICVR_IO_ERROR_READ;
    }
    *data_at = -1;   /* no blank line: a detached header */
    return PICVR_IO_OK;
}

/* Exactly `expected` bytes of fd from its position, then the end of the file. */
static picvr_io_status read_raw_exact(int fd, const char *path, size_t expected, unsigned char **out, char *err, size_t err_size)
{
    unsigned char *buf = malloc(expected ? expected : 1);
    if (!buf) {
        set_error(err, err_size, "%s: out of memory for %zu bytes", path, expected);
        return PICVR_IO_ERROR_OUT_OF_MEMORY;
    }
    size_t have = 0;
    while (have < expected) {
        size_t want = expected - have < MAX_READ_CHUNK ? expected - have : MAX_READ_CHUNK;
        ssize_t n = read(fd, buf + have, want);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) {
            set_error(err, err_size, "%s: read error: %s", path, strerror(errno));
            free(buf);
            return PICVR_IO_ERROR_READ;
        }
        if (n == 0) {
            set_error(err, err_size, "%s: truncated: %zu data bytes, the header needs %zu", path, have, expected);
            free(buf);
            return PICVR_IO_ERROR_TRUNCATED;
        }
        have += (size_t)n;
    }
    unsigned char extra;
    if (read(fd, &extra, 1) > 0) {
        set_error(err, err_size, "%s: too long: more than the %zu data bytes the header gives", path, expected);
        free(buf);
        return PICVR_IO_ERROR_TOO_LONG;
    }
    *out = buf;
    return PICVR_IO_OK;
}

/* The data of header h in file `path` from byte `offset`: raw or gzip, byte skip
   applied (to the file for raw, to the decompressed stream for gzip). */
static picvr_io_status nrrd_read_data(const char *path, long offset, const nrrd_header *h, size_t expected,
                                  unsigned char **out, char *err, size_t err_size)
{
    int fd = open(path, O_RDONLY);
    if (fd < 0) {
        set_error(err, err_size, "%s: %s", path, strerror(errno));
        return PICVR_IO_ERROR_OPEN;
    }
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        set_error(err, err_size, "%s: not a regular file", path);
        close(fd);
        return PICVR_IO_ERROR_OPEN;
    }
    long long skip = h->byte_skip;
    if (skip == -1 && h->gzip) {
        set_error(err, err_size, "%s: NRRD byte skip -1 with gzip encoding (the format forbids it)", path);
        close(fd);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    if (!h->gzip) {   /* raw: the skip is in the file; -1: the data ends it */
        /* Rule: a skip past the file's end (also one that would overflow) is truncation. */
        long long start = skip == -1 ? (long long)st.st_size - (long long)expected
                        : skip > (long long)st.st_size ? -1 : offset + skip;
        if (start < offset || lseek(fd, (off_t)start, SEEK_SET) < 0) {
            set_error(err, err_size, "%s: truncated: the file is shorter than its %zu data bytes", path, expected);
            close(fd);
            return PICVR_IO_ERROR_TRUNCATED;
        }
        picvr_io_status s = read_raw_exact(fd, path, expected, out, err, err_size);
        close(fd);
        return s;
    }
    if (lseek(fd, (off_t)offset, SEEK_SET) < 0) {
        set_error(err, err_size, "%s: %s", path, strerror(errno));
        close(fd);
        return PICVR_IO_ERROR_READ;
    }
    gzFile gz = gzdopen(fd, "rb");
    if (!gz) {
        close(fd);
        set_error(err, err_size, "%s: out of memory", path);
        return PICVR_IO_ERROR_OUT_OF_MEMORY;
    }
    size_t total = expected + (size_t)skip, have = 0;
    unsigned char *buf = NULL;
    picvr_io_status s = total < expected ? PICVR_IO_ERROR_SIZE_OVERFLOW : read_up_to(gz, path, total, &buf, &have, err, err_size);
    if (s == PICVR_IO_OK && gzdirect(gz)) {
        set_error(err, err_size, "%s: the NRRD data is not gzip although the header says so", path);
        s = PICVR_IO_ERROR_READ;
    }
    if (s == PICVR_IO_OK) s = check_end_of_data(gz, path, have, total, err, err_size);
    gzclose(gz);   /* closes fd */
    if (s != PICVR_IO_OK) {
        free(buf);
        return s;
    }
    if (skip > 0) memmove(buf, buf + skip, expected);
    *out = buf;
    return PICVR_IO_OK;
}

/* The detached data file's path: relative names are next to the header. */
static void nrrd_data_path(const char *header_path, const char *name, char *out, size_t size)
{
    const char *slash = strrchr(header_path, '/');
    if (name[0] == '/' || !slash) snprintf(out, size, "%s", name);
    else snprintf(out, size, "%.*s/%s", (int)(slash - header_path), header_path, name);
}

static void swap_bytes(unsigned char *data, size_t bytes, size_t voxel_size)
{
    for (size_t i = 0; i + voxel_size <= bytes; i += voxel_size)
        for (size_t a = 0, b = voxel_size - 1; a < b; a++, b--) {
            unsigned char t = data[i + a];
            data[i + a] = data[i + b];
            data[i + b] = t;
        }
}

int picvr_io_has_suffix(const char *path, const char *suffix)
{
    size_t n = path ? strlen(path) : 0;
    return n && suffix && piece_ends_with(path, n, suffix);
}

int picvr_io_is_nrrd(const char *path)
{
    size_t n = path ? strlen(path) : 0;
    return n && (piece_ends_with(path, n, ".nrrd") || piece_ends_with(path, n, ".nhdr"));
}

picvr_io_status picvr_io_load_nrrd(const char *path, picvr_io_volume *volume, char *err, size_t err_size)
{
    if (volume) memset(volume, 0, sizeof *volume);
    if (!path || !volume) {
        set_error(err, err_size, "no file name or output given");
        return PICVR_IO_ERROR_NULL_POINTER;
    }
    FILE *f = fopen(path, "rb");
    if (!f) {
        set_error(err, err_size, "%s: %s", path, strerror(errno));
        return PICVR_IO_ERROR_OPEN;
    }
    nrrd_header h;
    long data_at = -1;
    picvr_io_status st = nrrd_read_header(f, path, &h, &data_at, err, err_size);
    fclose(f);
    if (st != PICVR_IO_OK) return st;
    if (!h.dimension || !h.have_sizes || !h.have_type || !h.have_encoding) {
        set_error(err, err_size, "%s: the NRRD header lacks one of dimension, sizes, type, encoding", path);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    size_t vs = picvr_io_voxel_size(h.type);
    if (vs > 1 && !h.have_endian) {
        set_error(err, err_size, "%s: the NRRD header gives no endian for %zu-byte voxels", path, vs);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    picvr_io_layout layout = {{h.dims[0], h.dims[1], h.dims[2]}, h.type};
    size_t bytes = 0;
    if ((st = picvr_io_layout_bytes(&layout, &bytes, err, err_size)) != PICVR_IO_OK) return st;
    char data_path[4096];
    if (h.data_file[0]) nrrd_data_path(path, h.data_file, data_path, sizeof data_path);
    else if (data_at < 0) {
        set_error(err, err_size, "%s: a NRRD header without data: no blank line and no data file", path);
        return PICVR_IO_ERROR_TRUNCATED;
    }
    unsigned char *data = NULL;
    st = nrrd_read_data(h.data_file[0] ? data_path : path, h.data_file[0] ? 0 : data_at, &h, bytes, &data, err, err_size);
    if (st != PICVR_IO_OK) return st;
    if (vs > 1 && h.big_endian == host_is_little_endian()) swap_bytes(data, bytes, vs);
    memcpy(volume->dims, h.dims, sizeof volume->dims);
    volume->type = h.type;
    for (int i = 0; i < 3; i++) {
        volume->spacing[i] = (float)h.spacing[i];
        volume->origin[i] = (float)h.origin[i];
    }
    for (int i = 0; i < 9; i++) volume->direction[i] = (float)h.direction[i];
    for (int a = 0; a < 3; a++) {            /* RAS or LAS into LPS */
        if (h.flip_x) volume->direction[3 * a + 0] = 0.0f - volume->direction[3 * a + 0];   /* 0 stays +0 */
        if (h.flip_y) volume->direction[3 * a + 1] = 0.0f - volume->direction[3 * a + 1];
    }
    if (h.flip_x) volume->origin[0] = 0.0f - volume->origin[0];
    if (h.flip_y) volume->origin[1] = 0.0f - volume->origin[1];
    volume->value_scale = 1.0;
    volume->patient_frame = h.anatomical;
    volume->has_origin = h.have_origin;
    volume->data = data;
    volume->size = bytes;
    if (!(volume->spacing[0] > 0.0f && volume->spacing[1] > 0.0f && volume->spacing[2] > 0.0f) ||
        !isfinite(volume->spacing[0] + volume->spacing[1] + volume->spacing[2])) {
        set_error(err, err_size, "%s: a spacing beyond float", path);
        picvr_io_free(volume);
        return PICVR_IO_ERROR_BAD_DIMS;
    }
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_load(const char *path, const picvr_io_layout *layout, picvr_io_volume *volume,
                      char *err, size_t err_size)
{
    if (volume) memset(volume, 0, sizeof *volume);
    if (!path || !volume) {
        set_error(err, err_size, "no file name or output given");
        return PICVR_IO_ERROR_NULL_POINTER;
    }
    if (!layout && picvr_io_is_nrrd(path)) return picvr_io_load_nrrd(path, volume, err, err_size);
    /* The readers of other files (io/nifti.c, io/dicom.cpp, io/vdb.cpp); a build of this
       file alone (the raw and NRRD fuzzer) leaves them out with PICVR_IO_RAW_NRRD_ONLY. */
#ifndef PICVR_IO_RAW_NRRD_ONLY
    if (!layout && picvr_io_is_nifti(path)) return picvr_io_load_nifti(path, volume, err, err_size);
    if (!layout && picvr_io_is_vdb(path)) return picvr_io_load_vdb(path, NULL, volume, err, err_size);
    if (!layout && picvr_io_is_dicom(path)) return picvr_io_load_dicom(path, volume, err, err_size);
#endif
    picvr_io_layout from_name;
    if (!layout) {
        picvr_io_status st = picvr_io_parse_name(path, &from_name, err, err_size);
        if (st != PICVR_IO_OK) return st;
        layout = &from_name;
    }
    size_t bytes = 0;
    picvr_io_status st = picvr_io_layout_bytes(layout, &bytes, err, err_size);
    if (st != PICVR_IO_OK) return st;

    unsigned char *data = NULL;
    st = read_volume_file(path, bytes, &data, err, err_size);
    if (st != PICVR_IO_OK) return st;
    little_endian_to_host(data, bytes, picvr_io_voxel_size(layout->type));

    memcpy(volume->dims, layout->dims, sizeof volume->dims);
    volume->type = layout->type;
    volume->spacing[0] = volume->spacing[1] = volume->spacing[2] = 1.0f;
    volume->direction[0] = volume->direction[4] = volume->direction[8] = 1.0f;
    volume->value_scale = 1.0;
    volume->data = data;
    volume->size = bytes;
    return PICVR_IO_OK;
}

void picvr_io_free(picvr_io_volume *volume)
{
    if (!volume) return;
    free(volume->data);
    memset(volume, 0, sizeof *volume);
}

/* ---- helpers for callers --------------------------------------------------------- */

/* IEEE binary16 to double (every half is exact in a double). */
static double half_value(uint16_t h)
{
    int e = (h >> 10) & 31, m = h & 1023;
    double v = e == 0 ? ldexp(m, -24) : e == 31 ? (m ? NAN : INFINITY) : ldexp(1024 + m, e - 25);
    return (h & 0x8000) ? -v : v;
}

/* One voxel's value (host byte order), as a double. */
static double voxel_value(picvr_voxel_type type, const unsigned char *p)
{
    switch (type) {
    case PICVR_VOXEL_UINT8: return *p;
    case PICVR_VOXEL_INT8: return (int8_t)*p;
    case PICVR_VOXEL_UINT16: { uint16_t u; memcpy(&u, p, 2); return u; }
    case PICVR_VOXEL_INT16: { int16_t u; memcpy(&u, p, 2); return u; }
    case PICVR_VOXEL_FLOAT16: { uint16_t u; memcpy(&u, p, 2); return half_value(u); }
    case PICVR_VOXEL_INT32: { int32_t u; memcpy(&u, p, 4); return u; }
    case PICVR_VOXEL_FLOAT32: { float f; memcpy(&f, p, 4); return f; }
    case PICVR_VOXEL_FLOAT64: { double f; memcpy(&f, p, 8); return f; }
    }
    return NAN;
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

picvr_io_status picvr_io_percentile_range(const picvr_io_volume *volume, double lo_frac, double hi_frac, double *lo, double *hi)
{
    if (!volume || !volume->data || !lo || !hi) return PICVR_IO_ERROR_NULL_POINTER;
    size_t voxel = picvr_io_voxel_size(volume->type);
    if (voxel == 0) return PICVR_IO_ERROR_BAD_TYPE;
    if (!(lo_frac >= 0.0 && lo_frac < hi_frac && hi_frac <= 1.0)) return PICVR_IO_ERROR_BAD_DIMS;
    size_t count = volume->size / voxel, want = count < ((size_t)1 << 20) ? count : ((size_t)1 << 20);
    double *v = (double *)malloc((want ? want : 1) * sizeof(double));
    if (!v) return PICVR_IO_ERROR_OUT_OF_MEMORY;
    size_t n = 0;
    for (size_t k = 0; k < want; k++) {   /* voxel k * count / want: evenly spaced, exact when want == count */
        size_t i = (size_t)(((unsigned long long)k * count) / want);
        double x = voxel_value(volume->type, (const unsigned char *)volume->data + voxel * i);
        if (isfinite(x)) v[n++] = x;
    }
    if (n == 0) {
        free(v);
        return PICVR_IO_ERROR_BAD_TYPE;
    }
    qsort(v, n, sizeof *v, compare_doubles);
    *lo = v[(size_t)(lo_frac * (double)(n - 1) + 0.5)];
    *hi = v[(size_t)(hi_frac * (double)(n - 1) + 0.5)];
    if (!(*hi > *lo)) *hi = *lo + 1.0;   /* rule: one value (a constant volume) maps to [v, v + 1] */
    free(v);
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_value_range(const picvr_io_volume *volume, double *min, double *max,
                             size_t *non_finite)
{
    if (!volume || !volume->data) return PICVR_IO_ERROR_NULL_POINTER;
    size_t voxel = picvr_io_voxel_size(volume->type);
    if (voxel == 0) return PICVR_IO_ERROR_BAD_TYPE;
    size_t count = volume->size / voxel, bad = 0;
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < count; i++) {
        double v = voxel_value(volume->type, (const unsigned char *)volume->data + voxel * i);
        if (!isfinite(v)) {
            bad++;
            continue;
        }
        if (v < lo) lo = v;
        if (v > hi) hi = v;
    }
    if (lo > hi) lo = hi = 0.0; /* no finite value at all */
    if (min) *min = lo;
    if (max) *max = hi;
    if (non_finite) *non_finite = bad;
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_to_desc_sheared(const picvr_io_volume *volume, picvr_volume_desc *desc,
                                         double *shear_degrees)
{
    if (shear_degrees) *shear_degrees = 0.0;
    if (!volume || !desc) return PICVR_IO_ERROR_NULL_POINTER;
    memset(desc, 0, sizeof *desc);
    memcpy(desc->dims, volume->dims, sizeof desc->dims);
    desc->type = volume->type;
    memcpy(desc->spacing, volume->spacing, sizeof desc->spacing);
    desc->data = volume->data;
    memcpy(desc->direction, volume->direction, sizeof desc->direction);
    desc->has_origin = volume->has_origin;
    memcpy(desc->origin, volume->origin, sizeof desc->origin);
    const float *x = volume->direction, *y = volume->direction + 3, *z = volume->direction + 6;
    double n[3] = {(double)x[1] * y[2] - (double)x[2] * y[1], (double)x[2] * y[0] - (double)x[0] * y[2],
                   (double)x[0] * y[1] - (double)x[1] * y[0]};
    double ln = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), lz = sqrt((double)z[0] * z[0] + (double)z[1] * z[1] + (double)z[2] * z[2]);
    if (!(ln > 0.5) || !(lz > 0.5)) return PICVR_IO_OK;   /* degenerate axes: picvr refuses them */
    double c = (n[0] * z[0] + n[1] * z[1] + n[2] * z[2]) / (ln * lz);
    double angle = acos(fmin(1.0, fabs(c))) * 180.0 / 3.14159265358979323846;
    if (angle > 0.01) {   /* sheared: the normal on z's side */
        for (int i = 0; i < 3; i++) desc->direction[6 + i] = (float)((c < 0.0 ? -n[i] : n[i]) / ln);
        if (shear_degrees) *shear_degrees = angle;
    }
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_to_desc(const picvr_io_volume *volume, picvr_volume_desc *desc)
{
    return picvr_io_to_desc_sheared(volume, desc, NULL);
}
