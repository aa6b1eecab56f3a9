/* fuzz_dicom.cpp - libFuzzer harness for the DICOM reader (io/dicom*.cpp).
 *
 * Built with clang++ -fsanitize=fuzzer,address,undefined, linked with the readers' shared
 * helpers (the Makefile's IO_COMMON_SRC) and GDCM.  One input is the bytes of one file,
 * written as x.dcm in a private folder under $TMPDIR and loaded twice: through the file
 * (its series) and through the folder.  Every call must return a status without a
 * sanitizer report; a failure must leave the volume zeroed with a message; a success
 * must be consistent (size == product of dims * voxel size, dims in 1..PICVR_IO_MAX_DIM,
 * positive finite spacing, finite geometry, strings terminated) and is fed to
 * picvr_io_value_range and picvr_io_to_desc.  Seeds: tests/fuzz/corpus_dicom (small
 * slices of tests/dicom_writer.cpp).
 */
#include "picvr_io.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unistd.h>

static char dir[256];
static char file[300];

static void remove_dir() {
    if (file[0]) unlink(file);
    if (dir[0]) rmdir(dir);
}

static void make_dir() {
    if (dir[0]) return;
    const char *t = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/pvio-fuzz-dicom-XXXXXX", t && *t ? t : "/tmp");
    if (!mkdtemp(dir)) abort();
    snprintf(file, sizeof file, "%s/x.dcm", dir);
    atexit(remove_dir);
}

static void check(bool cond, const char *what) {
    if (!cond) {
        fprintf(stderr, "fuzz_dicom: invariant violated: %s\n", what);
        abort();
    }
}

static bool terminated(const char *s, size_t n) { return memchr(s, '\0', n) != nullptr; }

static void load_and_check(const char *path) {
    picvr_io_volume v;
    char err[512];
    err[0] = '\0';
    picvr_io_status st = picvr_io_load_dicom(path, &v, err, sizeof err);
    if (st != PICVR_IO_OK) {
        picvr_io_volume zero;
        memset(&zero, 0, sizeof zero);
        check(memcmp(&v, &zero, sizeof v) == 0, "a failed load leaves the volume zeroed");
        check(err[0] != '\0', "a failed load says why");
        check(st > PICVR_IO_OK && st < PICVR_IO_STATUS_COUNT, "a known status");
        return;
    }
    size_t vs = picvr_io_voxel_size(v.type);
    check(vs != 0, "loaded volume has a known type");
    for (int i = 0; i < 3; i++) {
        check(v.dims[i] >= 1 && v.dims[i] <= PICVR_IO_MAX_DIM, "dims in 1..PICVR_IO_MAX_DIM");
        check(v.spacing[i] > 0.0f && std::isfinite(v.spacing[i]), "spacing positive and finite");
        check(std::isfinite(v.origin[i]), "origin finite");
    }
    for (int i = 0; i < 9; i++) check(std::isfinite(v.direction[i]), "direction finite");
    check(v.data != nullptr, "data");
    check(v.size == (size_t)v.dims[0] * v.dims[1] * v.dims[2] * vs, "size == dims * voxel");
    check(std::isfinite(v.value_scale) && v.value_scale != 0.0 && std::isfinite(v.value_offset), "rescale finite");
    check(terminated(v.modality, sizeof v.modality) && terminated(v.warning, sizeof v.warning), "strings terminated");
    double lo = 0, hi = 0;
    size_t bad = 0;
    check(picvr_io_value_range(&v, &lo, &hi, &bad) == PICVR_IO_OK, "value range of a loaded volume");
    check(lo <= hi, "min <= max");
    picvr_volume_desc d;
    check(picvr_io_to_desc(&v, &d) == PICVR_IO_OK && d.data == v.data, "to_desc");
    picvr_io_free(&v);
    check(v.data == nullptr && v.size == 0, "free zeroes the volume");
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    make_dir();
    FILE *f = fopen(file, "wb");
    if (!f) abort();
    if (size && fwrite(data, 1, size, f) != size) abort();
    if (fclose(f) != 0) abort();
    load_and_check(file);
    load_and_check(dir);
    return 0;
}
