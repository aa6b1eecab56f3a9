/* fuzz_volume_io.c - libFuzzer harness for the raw and NRRD loaders (picvr_io_load and
 * picvr_io_parse_name of the raw and NRRD build: the Makefile's IO_RAW_SRC).
 *
 * Built by `make fuzz` with clang -fsanitize=fuzzer,address,undefined.  One input is
 *
 *     byte 0      flags: bit 0 gzip-compress the contents before writing the file,
 *                 bit 1 load with an explicit layout (bytes 1..4) instead of the name,
 *                 bit 2 also call picvr_io_parse_name on the raw name bytes with a tiny
 *                 error buffer (truncated messages),
 *                 bit 3 name the file NAME.nrrd, so that the NRRD reader takes it (its
 *                 header and data, attached; a detached one names any file it likes)
 *     bytes 1..4  explicit layout: dims (1 + byte % 8 each, so tiny files can match) and
 *                 type (byte 4 % 10: 0..9, including the invalid 0 and 9)
 *     then        a file name up to the first '\n' (any bytes; '/' and NUL are replaced
 *                 when the file is written, the raw bytes go to picvr_io_parse_name)
 *     then        the file contents (raw, or gzip data as is, or compressed by bit 0)
 *
 * Every call must return a status without a sanitizer report; on success the result is
 * checked for consistency (size == product of dims * voxel size) and fed to
 * picvr_io_value_range and picvr_io_to_desc.  Files go to a private directory under $TMPDIR.
 */
#include "picvr_io.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <zlib.h>

static char dir[256];

static void remove_dir(void) { if (dir[0]) rmdir(dir); }

static void make_dir(void) {
    if (dir[0]) return;
    const char *t = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/pvio-fuzz-XXXXXX", t && *t ? t : "/tmp");
    if (!mkdtemp(dir)) abort();
    atexit(remove_dir);
}

static void check(int cond, const char *what) {
    if (!cond) {
        fprintf(stderr, "fuzz_volume_io: invariant violated: %s\n", what);
        abort();
    }
}

static void use_volume(picvr_io_volume *v, const picvr_io_layout *want) {
    size_t vs = picvr_io_voxel_size(v->type);
    check(vs != 0, "loaded volume has a known type");
    check(v->size == (size_t)v->dims[0] * v->dims[1] * v->dims[2] * vs, "size == dims * voxel");
    if (want) {
        check(memcmp(v->dims, want->dims, sizeof v->dims) == 0, "dims as requested");
        check(v->type == want->type, "type as requested");
    }
    double lo = 0, hi = 0;
    size_t bad = 0;
    check(picvr_io_value_range(v, &lo, &hi, &bad) == PICVR_IO_OK, "value range of a loaded volume");
    check(lo <= hi, "min <= max");
    picvr_volume_desc d;
    check(picvr_io_to_desc(v, &d) == PICVR_IO_OK && d.data == v->data, "to_desc");
    picvr_io_free(v);
    check(v->data == NULL && v->size == 0, "free zeroes the volume");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 5) return 0;
    make_dir();
    const uint8_t flags = data[0];
    picvr_io_layout explicit_layout;
    for (int i = 0; i < 3; i++) explicit_layout.dims[i] = 1u + data[1 + i] % 8u;
    explicit_layout.type = (picvr_voxel_type)(data[4] % 10u);
    data += 5;
    size -= 5;

    const uint8_t *nl = memchr(data, '\n', size);
    size_t name_len = nl ? (size_t)(nl - data) : size;
    const uint8_t *body = nl ? nl + 1 : data + size;
    size_t body_len = nl ? size - name_len - 1 : 0;

    /* The raw name, NUL-terminated where it has a NUL (C strings end there). */
    char *raw = malloc(name_len + 1);
    if (!raw) return 0;
    memcpy(raw, data, name_len);
    raw[name_len] = 0;
    picvr_io_layout lay;
    char err[160];
    picvr_io_status st = picvr_io_parse_name(raw, &lay, err, sizeof err);
    check(st < PICVR_IO_STATUS_COUNT, "parse_name status in range");
    if (st == PICVR_IO_OK) {
        size_t bytes = 0;
        check(picvr_io_layout_bytes(&lay, &bytes, NULL, 0) == PICVR_IO_OK && bytes > 0,
              "a parsed layout is valid");
    } else {
        check(memchr(err, 0, sizeof err) != NULL, "error message terminated");
    }
    if (flags & 4) {
        char tiny[3];
        (void)picvr_io_parse_name(raw, &lay, tiny, sizeof tiny);
        picvr_voxel_type ty;
        (void)picvr_io_parse_type(raw, &ty);
    }

    /* The file: the name's bytes with '/' and NUL replaced, at most 200 of them. */
    size_t fl = name_len < 200 ? name_len : 200;
    char *path = malloc(strlen(dir) + fl + 2 + 5);
    if (!path) { free(raw); return 0; }
    size_t dl = strlen(dir);
    memcpy(path, dir, dl);
    path[dl] = '/';
    for (size_t i = 0; i < fl; i++) path[dl + 1 + i] = (data[i] == '/' || data[i] == 0) ? '_' : (char)data[i];
    path[dl + 1 + fl] = 0;
    if (flags & 8) strcat(path, ".nrrd");
    if (fl == 0 || strcmp(path + dl + 1, ".") == 0 || strcmp(path + dl + 1, "..") == 0) {
        free(raw); free(path);
        return 0;
    }
    int written = 0;
    if (flags & 1) {
        gzFile gz = gzopen(path, "wb");
        if (gz) {
            written = body_len == 0 || gzwrite(gz, body, (unsigned)body_len) == (int)body_len;
            written &= gzclose(gz) == Z_OK;
        }
    } else {
        FILE *f = fopen(path, "wb");
        if (f) {
            written = fwrite(body, 1, body_len, f) == body_len;
            written &= fclose(f) == 0;
        }
    }
    if (written) {
        picvr_io_volume v;
        st = picvr_io_load(path, NULL, &v, err, sizeof err);
        check(st < PICVR_IO_STATUS_COUNT, "load status in range");
        if (st == PICVR_IO_OK) use_volume(&v, NULL);
        else check(v.data == NULL && v.size == 0, "failed load leaves a zeroed volume");
        if (flags & 2) {
            st = picvr_io_load(path, &explicit_layout, &v, err, sizeof err);
            if (st == PICVR_IO_OK) use_volume(&v, &explicit_layout);
            else check(v.data == NULL, "failed load leaves a zeroed volume");
        }
    }
    unlink(path);
    free(raw);
    free(path);
    return 0;
}
