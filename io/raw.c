/* raw.c - the reader of headerless raw files (picvr_io_parse_name, and picvr_io_load_raw,
 * which picvr_io_load calls for a file no format of io/formats_*.c claims): voxels x
 * fastest, little-endian, plain or gzip, the layout given or taken from the file's name
 * NAME_XxYxZ_TYPE.raw[.gz].  The file (after gzip decompression) must hold exactly the
 * layout's byte count.  Written to survive hostile names and files (it is fuzzed): no
 * fixed-size copies of the name, every size product checked, and the buffer grows with
 * the data actually read (picvr_io_gz_read_up_to). */
#include "picvr_io.h"
#include "io/internal.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <zlib.h>

/* Longest piece of a file name quoted in a message, so messages stay readable. */
#define NAME_QUOTE_MAX 120

#define set_error picvr_io_set_error

/* ---- name parsing (pure functions on (pointer, length) pieces of the name) ------ */

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
    if (picvr_io_piece_ends_with(base, len, ".gz")) len -= 3;
    if (!picvr_io_piece_ends_with(base, len, ".raw")) {
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
    if (picvr_io_parse_type_piece(base + type_sep, len - type_sep, &parsed.type) != PICVR_IO_OK) {
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

/* Files are little-endian; swap multi-byte voxels on a big-endian host. */
static void little_endian_to_host(unsigned char *data, size_t bytes, size_t voxel_size)
{
    if (voxel_size < 2 || picvr_io_host_is_little_endian()) return;
    picvr_io_swap_bytes(data, bytes, voxel_size);
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

/* The whole file, exactly `expected` bytes after decompression, into a malloc'd buffer. */
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
        status = picvr_io_gz_read_up_to(gz, path, expected, &buf, &have, err, err_size);
    if (status == PICVR_IO_OK)
        status = picvr_io_gz_check_end(gz, path, have, expected, err, err_size);
    gzclose(gz);
    if (status != PICVR_IO_OK) {
        free(buf);
        return status;
    }
    *data = buf;
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_load_raw(const char *path, const picvr_io_layout *layout, picvr_io_volume *volume,
                                  char *err, size_t err_size)
{
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
