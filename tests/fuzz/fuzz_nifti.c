/* fuzz_nifti.c - libFuzzer harness for the NIfTI reader of io/nifti.c (picvr_io_load_nifti).
 *
 * Built with clang -fsanitize=fuzzer,address,undefined.  One input is
 *
 *     byte 0      flags: bit 0 gzip-compress the file's bytes before writing them (so the
 *                 fuzzer mutates the NIfTI bytes, not the deflate stream),
 *                 bit 1 name the file x.nii.gz instead of x.nii (the name alone decides
 *                 nothing: zlib reads plain and gzip data under either name),
 *                 bit 2 write a .hdr/.img pair: x.hdr gets the first 348 bytes (540 when
 *                 the first four say 540 in either byte order), x.img the rest,
 *                 bit 3 also load with a 3-byte error buffer (truncated messages)
 *     then        the file's bytes
 *
 * The seeds in tests/fuzz/corpus_nifti/ are this byte followed by small NIfTI files.
 * Every call must return a status without a sanitizer report; a refusal must leave the
 * volume zeroed with a message; a loaded volume must be consistent: a type picvr holds,
 * dims 1..PICVR_IO_MAX_DIM, size == dims * voxel size, finite spacing > 0, unit
 * directions, a finite origin, a finite non-zero value_scale and finite value_offset,
 * patient_frame 1, terminated strings.  Files go to a private directory under $TMPDIR.
 */
#include "picvr_io.h"

#include <math.h>
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
    snprintf(dir, sizeof dir, "%s/pvio-fuzz-nifti-XXXXXX", t && *t ? t : "/tmp");
    if (!mkdtemp(dir)) abort();
    atexit(remove_dir);
}

static void check(int cond, const char *what) {
    if (!cond) {
        fprintf(stderr, "fuzz_nifti: invariant violated: %s\n", what);
        abort();
    }
}

static int write_file(const char *path, const uint8_t *data, size_t n, int gz) {
    int ok = 0;
    if (gz) {
        gzFile f = gzopen(path, "wb");
        if (f) {
            ok = n == 0 || gzwrite(f, data, (unsigned)n) == (int)n;
            ok &= gzclose(f) == Z_OK;
        }
    } else {
        FILE *f = fopen(path, "wb");
        if (f) {
            ok = n == 0 || fwrite(data, 1, n, f) == n;
            ok &= fclose(f) == 0;
        }
    }
    return ok;
}

static void check_volume(picvr_io_volume *v) {
    size_t vs = picvr_io_voxel_size(v->type);
    check(vs != 0 && v->type != PICVR_VOXEL_FLOAT16, "a NIfTI type picvr holds");
    for (int i = 0; i < 3; i++) check(v->dims[i] >= 1 && v->dims[i] <= PICVR_IO_MAX_DIM, "dims in range");
    check(v->size == (size_t)v->dims[0] * v->dims[1] * v->dims[2] * vs, "size == dims * voxel");
    check(v->data != NULL, "data");
    for (int a = 0; a < 3; a++) {
        check(isfinite(v->spacing[a]) && v->spacing[a] > 0.0f, "finite spacing > 0");
        check(isfinite(v->origin[a]), "finite origin");
        double len = 0.0;
        for (int c = 0; c < 3; c++) {
            check(isfinite(v->direction[3 * a + c]), "finite direction");
            len += (double)v->direction[3 * a + c] * v->direction[3 * a + c];
        }
        check(fabs(sqrt(len) - 1.0) < 1e-5, "unit directions");
    }
    check(isfinite(v->value_scale) && v->value_scale != 0.0 && isfinite(v->value_offset), "finite scaling");
    check(memchr(v->warning, 0, sizeof v->warning) != NULL, "warning terminated");
    check(v->modality[0] == '\0', "no modality");
    check(v->patient_frame == 1, "NIfTI's world is the patient frame");
    double lo = 0, hi = 0;
    check(picvr_io_value_range(v, &lo, &hi, NULL) == PICVR_IO_OK && lo <= hi, "value range");
    picvr_io_free(v);
    check(v->data == NULL && v->size == 0, "free zeroes the volume");
}

static void load(const char *path, size_t err_size) {
    char err[256];
    picvr_io_volume v, zero;
    memset(&zero, 0, sizeof zero);
    memset(err, 0, sizeof err);
    picvr_io_status st = picvr_io_load_nifti(path, &v, err, err_size);
    check(st < PICVR_IO_STATUS_COUNT, "status in range");
    if (st == PICVR_IO_OK) {
        check_volume(&v);
    } else {
        check(memcmp(&v, &zero, sizeof v) == 0, "a refusal leaves the volume zeroed");
        check(memchr(err, 0, err_size) != NULL && err[0] != '\0', "a message, terminated");
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 1) return 0;
    make_dir();
    const uint8_t flags = data[0];
    data++;
    size--;
    char path[512], img[512];
    int pair = (flags & 4) != 0;
    snprintf(path, sizeof path, "%s/x.%s", dir, pair ? "hdr" : (flags & 2) ? "nii.gz" : "nii");
    snprintf(img, sizeof img, "%s/x.img", dir);
    int written;
    if (pair) {
        size_t split = 348;
        if (size >= 4) {
            uint32_t le = (uint32_t)data[0] | (uint32_t)data[1] << 8 | (uint32_t)data[2] << 16 | (uint32_t)data[3] << 24;
            uint32_t be = (uint32_t)data[3] | (uint32_t)data[2] << 8 | (uint32_t)data[1] << 16 | (uint32_t)data[0] << 24;
            if (le == 540 || be == 540) split = 540;
        }
        if (split > size) split = size;
        written = write_file(path, data, split, flags & 1) && write_file(img, data + split, size - split, flags & 1);
    } else {
        written = write_file(path, data, size, flags & 1);
    }
    if (written) {
        load(path, 256);
        if (flags & 8) load(path, 3);
    }
    unlink(path);
    if (pair) unlink(img);
    return 0;
}
