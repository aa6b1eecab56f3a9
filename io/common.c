/* common.c - what the readers of picvr_io share (declared in io/internal.h, the public
 * part in picvr_io.h): error messages and status names; voxel types (sizes, names,
 * parsing) and layouts (byte sizes, every product checked); file name suffixes; byte
 * order; files read through zlib (plain and gzip alike).  Written to survive hostile
 * names and files (every reader is fuzzed): no fixed-size copies of the input, and a
 * buffer grows with the data actually read, so a tiny file claiming a huge layout never
 * makes a reader allocate the huge size up front. */
#include "picvr_io.h"
#include "io/internal.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <zlib.h>

/* First buffer size when reading; doubled as data arrives (up to the expected size). */
#define INITIAL_READ_BYTES ((size_t)16 << 20)

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

/* ---- names (pure functions on (pointer, length) pieces of a name) ---------------- */

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

int picvr_io_piece_ends_with(const char *s, size_t len, const char *suffix)
{
    size_t n = strlen(suffix);
    return len >= n && piece_equals(s + len - n, n, suffix);
}

picvr_io_status picvr_io_parse_type_piece(const char *s, size_t len, picvr_voxel_type *type)
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
    return picvr_io_parse_type_piece(text, strlen(text), type);
}

int picvr_io_has_suffix(const char *path, const char *suffix)
{
    size_t n = path ? strlen(path) : 0;
    return n && suffix && picvr_io_piece_ends_with(path, n, suffix);
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

/* ---- byte order ------------------------------------------------------------------ */

int picvr_io_host_is_little_endian(void)
{
    const uint16_t one = 1;
    unsigned char first;
    memcpy(&first, &one, 1);
    return first == 1;
}

void picvr_io_swap_bytes(unsigned char *data, size_t bytes, size_t voxel_size)
{
    for (size_t i = 0; i + voxel_size <= bytes; i += voxel_size)
        for (size_t a = 0, b = voxel_size - 1; a < b; a++, b--) {
            unsigned char t = data[i + a];
            data[i + a] = data[i + b];
            data[i + b] = t;
        }
}

/* ---- files through zlib ---------------------------------------------------------- */

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

/* Reads up to `expected` bytes into a buffer that grows as data arrives.  Returns
   the buffer (caller frees) and how many bytes came in *got. */
picvr_io_status picvr_io_gz_read_up_to(gzFile gz, const char *path, size_t expected,
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
        size_t want = cap - have < PICVR_IO_MAX_READ_CHUNK ? cap - have : PICVR_IO_MAX_READ_CHUNK;
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
picvr_io_status picvr_io_gz_check_end(gzFile gz, const char *path, size_t have,
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
