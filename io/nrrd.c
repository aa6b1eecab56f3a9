/* nrrd.c - the NRRD reader of picvr_io.h (picvr_io_load_nrrd, picvr_io_is_nrrd): .nrrd with
 * the data attached, .nhdr with a detached data file.  A reader of the documented format
 * (teem.sourceforge.net/nrrd/format.html), for the subset volumes use: magic
 * NRRD0001..NRRD0005; dimension 3; the sizes; a type picvr holds (int8, uint8, int16,
 * uint16, int32, float, double; uint32 and 64-bit integers are refused); encoding raw or
 * gzip; endian; spacings or space directions (their lengths are the spacing, their unit
 * vectors the orientation) and space origin; a data file relative to the header's
 * folder; byte skip (>= 0, or -1 for raw: the data ends the file).  Comments (#) and
 * key:=value pairs are skipped, fields the renderer does not use (kinds, units, labels,
 * ...) ignored.  Everything else is refused with a message, never guessed.  Written to
 * survive hostile files (it is fuzzed): every size checked, gzip data read into a buffer
 * that grows with the data actually read. */
#include "picvr_io.h"
#include "io/internal.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <zlib.h>

#define set_error picvr_io_set_error

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
        size_t want = expected - have < PICVR_IO_MAX_READ_CHUNK ? expected - have : PICVR_IO_MAX_READ_CHUNK;
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
    picvr_io_status s = total < expected ? PICVR_IO_ERROR_SIZE_OVERFLOW : picvr_io_gz_read_up_to(gz, path, total, &buf, &have, err, err_size);
    if (s == PICVR_IO_OK && gzdirect(gz)) {
        set_error(err, err_size, "%s: the NRRD data is not gzip although the header says so", path);
        s = PICVR_IO_ERROR_READ;
    }
    if (s == PICVR_IO_OK) s = picvr_io_gz_check_end(gz, path, have, total, err, err_size);
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

int picvr_io_is_nrrd(const char *path)
{
    return picvr_io_has_suffix(path, ".nrrd") || picvr_io_has_suffix(path, ".nhdr");
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
    if (vs > 1 && h.big_endian == picvr_io_host_is_little_endian()) picvr_io_swap_bytes(data, bytes, vs);
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
