/* fuzz_vdb.cpp - libFuzzer harness for the OpenVDB reader (io/vdb.cpp).
 *
 * The input is the file: written as x.vdb in a private folder under $TMPDIR, loaded with
 * the default grid choice and again by the name "density[1]" (a duplicate name's second
 * grid).  Every call must return a status without a sanitizer report; a refusal must
 * leave a message and a zeroed volume, a success a volume picvr accepts: float32, dims
 * 1..PICVR_IO_MAX_DIM, size = product of dims x 4, every value finite, spacing finite
 * and positive, unit direction vectors, a finite origin.  Built with a 64 MiB cap on the
 * densified volume (PICVR_IO_VDB_MAX_BYTES) so that a tiny file stating a wide bounding
 * box stays inside the fuzzer's memory limit; the cap's own check is the same code. */
#include "picvr_io.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <unistd.h>

static char dir[256], path[300];

static void remove_files()
{
    if (!dir[0]) return;
    unlink(path);
    rmdir(dir);
}

static void make_dir()
{
    if (dir[0]) return;
    const char *t = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/pvio-fuzz-vdb-XXXXXX", t && *t ? t : "/tmp");
    if (!mkdtemp(dir)) abort();
    snprintf(path, sizeof path, "%s/x.vdb", dir);
    atexit(remove_files);
}

static void check(bool cond, const char *what)
{
    if (!cond) {
        fprintf(stderr, "fuzz_vdb: invariant violated: %s\n", what);
        abort();
    }
}

static void load(const char *grid)
{
    picvr_io_volume v;
    memset(&v, 0x5a, sizeof v);
    char err[256];
    err[0] = '\0';
    picvr_io_status s = picvr_io_load_vdb(path, grid, &v, err, sizeof err);
    check(s >= PICVR_IO_OK && s < PICVR_IO_STATUS_COUNT, "a known status");
    if (s != PICVR_IO_OK) {
        static const picvr_io_volume zero = {};
        check(err[0] != '\0', "a refusal has a message");
        check(memcmp(&v, &zero, sizeof v) == 0, "a refusal zeroes the volume");
        return;
    }
    check(v.type == PICVR_VOXEL_FLOAT32 && v.data != nullptr, "float32 data");
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        check(v.dims[a] >= 1 && v.dims[a] <= PICVR_IO_MAX_DIM, "dims in range");
        n *= v.dims[a];
    }
    check(v.size == n * sizeof(float), "size == dims x 4");
    const float *f = static_cast<const float *>(v.data);
    for (size_t i = 0; i < n; i++) check(std::isfinite(f[i]), "finite values");
    for (int a = 0; a < 3; a++) {
        check(std::isfinite(v.spacing[a]) && v.spacing[a] > 0.0f, "positive spacing");
        check(std::isfinite(v.origin[a]), "finite origin");
        double len = 0.0;
        for (int c = 0; c < 3; c++) len += (double)v.direction[3 * a + c] * v.direction[3 * a + c];
        check(std::fabs(std::sqrt(len) - 1.0) < 1e-4, "unit direction");
    }
    check(v.value_scale == 1.0 && v.value_offset == 0.0 && v.modality[0] == '\0', "no rescale, no modality");
    check(memchr(v.warning, '\0', sizeof v.warning) != nullptr, "a terminated warning");
    picvr_io_free(&v);
    check(v.data == nullptr && v.size == 0, "free zeroes the volume");
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    make_dir();
    FILE *f = fopen(path, "wb");
    if (!f) abort();
    if (size && fwrite(data, 1, size, f) != size) abort();
    fclose(f);
    load(nullptr);
    load("density[1]");
    return 0;
}
