/* test_vdb.c - the OpenVDB reader (picvr_io_load_vdb, io/vdb.cpp): files written here with
 * OpenVDB's own writer (tests/vdb_writer.cpp) are read back and compared, voxel by voxel,
 * with a dense volume built in the test from the voxels, tile and background written, and
 * their spacing, orientation and origin with the transform computed here; grid choice;
 * refusals, each with its status and a zeroed volume; and the Disney cloud against its
 * dense copy made with OpenVDB's copyToArray ($PICVR_DATA, else ../shared/data). */
#include "test_util.h"

#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "picvr_io.h"
#include "vdb_writer.h"

static char vdb_dir[256];
static char vdb_written[32][64];
static int vdb_written_count;

/* path of `name` in a private folder made on first use (removed by vdb_cleanup). */
static const char *vdb_path(const char *name) {
    static char path[512];
    if (!vdb_dir[0]) {
        snprintf(vdb_dir, sizeof vdb_dir, "%s/pvio-vdb-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        assert_non_null(mkdtemp(vdb_dir));
    }
    int known = 0;
    for (int i = 0; i < vdb_written_count; i++) known |= !strcmp(vdb_written[i], name);
    if (!known && vdb_written_count < 32) snprintf(vdb_written[vdb_written_count++], sizeof vdb_written[0], "%s", name);
    snprintf(path, sizeof path, "%s/%s", vdb_dir, name);
    return path;
}

static void vdb_cleanup(void) {
    char path[4096];
    for (int i = 0; i < vdb_written_count; i++) {
        snprintf(path, sizeof path, "%s/%s", vdb_dir, vdb_written[i]);
        unlink(path);
    }
    vdb_written_count = 0;
    if (vdb_dir[0]) rmdir(vdb_dir);
    vdb_dir[0] = '\0';
}

static const char *write_vdb(const char *name, const vdbw_grid *grids, size_t n, int compression) {
    char err[512] = "";
    const char *p = vdb_path(name);
    int rc = vdbw_write(p, grids, n, compression, err, sizeof err);
    if (rc != 0) print_message("vdbw_write: %s\n", err);
    assert_int_equal(rc, 0);
    return p;
}

static void write_bytes(const char *path, const void *data, size_t n) {
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    if (n) assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
}

static unsigned char *read_bytes(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long size = ftell(f);
    assert_true(size > 0);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = (unsigned char *)malloc((size_t)size);
    assert_int_equal(fread(b, 1, (size_t)size, f), (size_t)size);
    fclose(f);
    *n = (size_t)size;
    return b;
}

static int is_zeroed(const picvr_io_volume *v) {
    static const picvr_io_volume zero;
    return !memcmp(v, &zero, sizeof zero);
}

/* world = A index + t with A = Rz(angle) diag(s): the rotation by `angle` about +z (x
   toward y), then the translation. */
static void make_transform(double angle, const double s[3], const double t[3], double a[9], double tr[3]) {
    const double c = cos(angle), n = sin(angle);
    const double r[9] = {c, -n, 0, n, c, 0, 0, 0, 1};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) a[3 * i + j] = r[3 * i + j] * s[j];
    memcpy(tr, t, 3 * sizeof(double));
}

/* One float grid with voxels at the corners of its bounding box and inside, an inactive
   voxel holding a non-background value, an active 8^3 tile, a NaN, a rotated anisotropic
   transform, and a second grid after it; written with every compression and half
   floats.  Every voxel of the bounding box is compared with the dense volume built here
   (background, then tile, then active voxels), and the geometry with A and t. */
void test_vdb_reads_values_and_geometry(void **state) {
    (void)state;
    const double voxel[3] = {0.5, 0.5, 2.0}, shift[3] = {10.0, -20.0, 30.0};
    double a[9], t[3];
    make_transform(M_PI / 2, voxel, shift, a, t);
    const vdbw_voxel active[] = {{{-3, 2, 5}, 1.5}, {{4, 6, 9}, -2.25}, {{10, 3, 7}, 3.0}, {{0, 10, 6}, NAN},
                                 {{2, 12, 14}, 0.5}};
    const vdbw_voxel inactive[] = {{{1, 2, 5}, 9.0}, {{-2, 3, 6}, -7.0}};
    vdbw_grid g[2];
    memset(g, 0, sizeof g);
    g[0].name = "smoke";
    g[0].type = VDBW_FLOAT;
    g[0].background = 0.125;
    g[0].active = active;
    g[0].active_count = sizeof active / sizeof active[0];
    g[0].inactive = inactive;
    g[0].inactive_count = sizeof inactive / sizeof inactive[0];
    g[0].has_tile = 1;
    g[0].tile_ijk[0] = g[0].tile_ijk[1] = g[0].tile_ijk[2] = 8;
    g[0].tile_value = 0.75;
    memcpy(g[0].matrix, a, sizeof a);
    memcpy(g[0].translation, t, sizeof t);
    const vdbw_voxel other[] = {{{100, 100, 100}, 42.0}};
    g[1].name = "other";
    g[1].type = VDBW_FLOAT;
    g[1].active = other;
    g[1].active_count = 1;

    /* the expected dense volume over the active bbox [-3,2,5]..[15,15,15] */
    const int lo[3] = {-3, 2, 5}, dims[3] = {19, 14, 11};
    const size_t count = (size_t)dims[0] * dims[1] * dims[2];
    float *want = (float *)malloc(count * sizeof(float));
    for (size_t i = 0; i < count; i++) want[i] = 0.125f;
    for (int z = 8; z < 16; z++)
        for (int y = 8; y < 16; y++)
            for (int x = 8; x < 16; x++) want[(x - lo[0]) + dims[0] * ((y - lo[1]) + dims[1] * (z - lo[2]))] = 0.75f;
    for (size_t k = 0; k < g[0].active_count; k++) {
        const int32_t *c = active[k].ijk;
        float v = isnan(active[k].value) ? 0.0f : (float)active[k].value;   /* NaN becomes 0 */
        want[(c[0] - lo[0]) + dims[0] * ((c[1] - lo[1]) + dims[1] * (c[2] - lo[2]))] = v;
    }
    /* expected geometry: spacing |A e_a|, direction A e_a / |A e_a|, origin A lo + t */
    float spacing[3], direction[9], origin[3];
    for (int ax = 0; ax < 3; ax++) {
        double len = sqrt(a[ax] * a[ax] + a[3 + ax] * a[3 + ax] + a[6 + ax] * a[6 + ax]);
        spacing[ax] = (float)len;
        for (int c = 0; c < 3; c++) direction[3 * ax + c] = (float)(a[3 * c + ax] / len);
        origin[ax] = (float)(a[3 * ax] * lo[0] + a[3 * ax + 1] * lo[1] + a[3 * ax + 2] * lo[2] + t[ax]);
    }
    assert_true(fabsf(direction[1] - 1.0f) < 1e-6f && fabsf(direction[3] + 1.0f) < 1e-6f);   /* x -> +y, y -> -x */

    const struct { const char *what; int compression, half; } modes[] = {
        {"default (blosc, active mask)", -1, 0}, {"none", 0, 0}, {"zip", VDBW_ZIP, 0},
        {"zip + active mask", VDBW_ZIP | VDBW_ACTIVE_MASK, 0}, {"blosc", VDBW_BLOSC, 0},
        {"active mask", VDBW_ACTIVE_MASK, 0}, {"half floats", -1, 1}, {"half floats, zip", VDBW_ZIP, 1}};
    char err[512];
    for (size_t m = 0; m < sizeof modes / sizeof modes[0]; m++) {
        g[0].half = modes[m].half;
        const char *p = write_vdb("values.vdb", g, 2, modes[m].compression);
        picvr_io_volume v;
        err[0] = '\0';
        picvr_io_status s = picvr_io_load_vdb(p, NULL, &v, err, sizeof err);
        print_message("vdb: %-28s -> %s %s [%s]\n", modes[m].what, picvr_io_status_string(s), err, v.warning);
        assert_int_equal(s, PICVR_IO_OK);
        assert_int_equal(v.dims[0], dims[0]);
        assert_int_equal(v.dims[1], dims[1]);
        assert_int_equal(v.dims[2], dims[2]);
        assert_int_equal(v.type, PICVR_VOXEL_FLOAT32);
        assert_int_equal(v.size, count * sizeof(float));
        assert_memory_equal(v.data, want, count * sizeof(float));
        for (int i = 0; i < 3; i++) {
            assert_true(fabsf(v.spacing[i] - spacing[i]) < 1e-6f);
            assert_true(fabsf(v.origin[i] - origin[i]) < 1e-5f);
        }
        for (int i = 0; i < 9; i++) assert_true(fabsf(v.direction[i] - direction[i]) < 1e-6f);
        assert_true(v.value_scale == 1.0 && v.value_offset == 0.0);
        assert_string_equal(v.modality, "");
        assert_non_null(strstr(v.warning, "1 non-finite"));
        picvr_io_free(&v);
    }
    free(want);

    /* an identity transform: spacing 1, identity directions, origin = the index of the
       first voxel (VDB voxel centres sit at integer index coordinates) */
    const vdbw_voxel one[] = {{{-5, 7, 123}, 2.0}};
    vdbw_grid id;
    memset(&id, 0, sizeof id);
    id.name = "density";
    id.active = one;
    id.active_count = 1;
    picvr_io_volume v;
    assert_int_equal(picvr_io_load_vdb(write_vdb("one.vdb", &id, 1, -1), NULL, &v, err, sizeof err), PICVR_IO_OK);
    assert_true(v.dims[0] == 1 && v.dims[1] == 1 && v.dims[2] == 1 && ((float *)v.data)[0] == 2.0f);
    assert_true(v.origin[0] == -5.0f && v.origin[1] == 7.0f && v.origin[2] == 123.0f);
    assert_true(v.spacing[0] == 1.0f && v.spacing[1] == 1.0f && v.spacing[2] == 1.0f);
    assert_true(v.direction[0] == 1.0f && v.direction[4] == 1.0f && v.direction[8] == 1.0f && v.direction[1] == 0.0f);
    assert_string_equal(v.warning, "");
    picvr_io_free(&v);
    vdb_cleanup();
}

/* Loads grid `name` of p and checks its only voxel's value. */
static void expect_grid(const char *p, const char *name, double value) {
    char err[512] = "";
    picvr_io_volume v;
    picvr_io_status s = picvr_io_load_vdb(p, name, &v, err, sizeof err);
    if (s != PICVR_IO_OK) print_message("vdb: %s grid %s: %s\n", p, name ? name : "(default)", err);
    assert_int_equal(s, PICVR_IO_OK);
    assert_true(((float *)v.data)[0] == (float)value);
    picvr_io_free(&v);
}

static void expect_refused(const char *p, const char *name, picvr_io_status want, const char *in_message) {
    char err[512] = "";
    picvr_io_volume v;
    memset(&v, 0xab, sizeof v);
    picvr_io_status s = picvr_io_load_vdb(p, name, &v, err, sizeof err);
    print_message("vdb: grid %-12s -> %s: %s\n", name ? name : "(default)", picvr_io_status_string(s), err);
    assert_int_equal(s, want);
    assert_true(err[0] != '\0');
    assert_true(is_zeroed(&v));
    if (in_message) assert_non_null(strstr(err, in_message));
}

/* By name (also "name[N]" for duplicates); else "density" if it is a float (or double)
   grid; else the first float grid; else the first double grid (converted, said in the
   warning); instances read their parent's tree with their own transform; a vector grid or
   a missing name is refused, the message listing the file's grids. */
void test_vdb_selects_grids(void **state) {
    (void)state;
    vdbw_voxel vox[9];
    vdbw_grid g[4];
    for (int i = 0; i < 9; i++) {
        memset(&vox[i], 0, sizeof vox[i]);
        vox[i].value = i + 1;
    }
#define GRID(k, n, ty, vi)                                                             \
    do {                                                                               \
        memset(&g[k], 0, sizeof g[k]);                                                \
        g[k].name = (n);                                                               \
        g[k].type = (ty);                                                              \
        g[k].active = &vox[vi];                                                        \
        g[k].active_count = 1;                                                         \
    } while (0)
    GRID(0, "temperature", VDBW_FLOAT, 0);
    GRID(1, "density", VDBW_FLOAT, 1);
    GRID(2, "v", VDBW_VEC3S, 2);
    const char *p = write_vdb("a.vdb", g, 3, -1);
    expect_grid(p, NULL, 2);
    expect_grid(p, "density", 2);
    expect_grid(p, "temperature", 1);
    expect_refused(p, "v", PICVR_IO_ERROR_BAD_HEADER, "not a float");
    expect_refused(p, "nope", PICVR_IO_ERROR_BAD_HEADER, "'temperature'");

    GRID(0, "v", VDBW_VEC3S, 2);
    GRID(1, "b", VDBW_DOUBLE, 3);
    GRID(2, "a", VDBW_FLOAT, 4);
    p = write_vdb("b.vdb", g, 3, -1);
    expect_grid(p, NULL, 5);                 /* the first float grid, not the double before it */
    expect_grid(p, "b", 4);
    p = write_vdb("c.vdb", g, 2, -1);
    expect_grid(p, NULL, 4);                 /* no float grid: the first double grid */
    char err[512];
    picvr_io_volume v;
    vdbw_voxel big[2] = {{{0, 0, 0}, 4.0}, {{1, 0, 0}, 1e300}};
    g[1].active = big;
    g[1].active_count = 2;
    p = write_vdb("c.vdb", g, 2, -1);
    assert_int_equal(picvr_io_load_vdb(p, NULL, &v, err, sizeof err), PICVR_IO_OK);
    assert_true(((float *)v.data)[0] == 4.0f && ((float *)v.data)[1] == 0.0f);   /* beyond float: 0 */
    assert_non_null(strstr(v.warning, "float64"));
    assert_non_null(strstr(v.warning, "1 non-finite"));
    picvr_io_free(&v);

    GRID(0, "density", VDBW_VEC3S, 2);
    GRID(1, "x", VDBW_FLOAT, 5);
    expect_grid(write_vdb("d.vdb", g, 2, -1), NULL, 6);   /* "density" is not scalar */

    GRID(0, "density", VDBW_FLOAT, 6);
    GRID(1, "density", VDBW_FLOAT, 7);
    p = write_vdb("e.vdb", g, 2, -1);
    expect_grid(p, NULL, 7);
    expect_grid(p, "density", 7);
    expect_grid(p, "density[0]", 7);
    expect_grid(p, "density[1]", 8);

    /* an instance: its own transform (voxel size 2), the tree of its parent */
    GRID(0, "density", VDBW_FLOAT, 8);
    GRID(1, "copy", VDBW_FLOAT, 0);
    g[1].share_tree_of = 1;
    g[1].matrix[0] = g[1].matrix[4] = g[1].matrix[8] = 2.0;
    p = write_vdb("f.vdb", g, 2, -1);
    picvr_io_status s = picvr_io_load_vdb(p, "copy", &v, err, sizeof err);
    if (s != PICVR_IO_OK) print_message("vdb: instance: %s\n", err);
    assert_int_equal(s, PICVR_IO_OK);
    assert_true(((float *)v.data)[0] == 9.0f && v.spacing[0] == 2.0f && v.spacing[2] == 2.0f);
    picvr_io_free(&v);

    GRID(0, "v", VDBW_VEC3S, 2);
    expect_refused(write_vdb("g.vdb", g, 1, -1), NULL, PICVR_IO_ERROR_BAD_HEADER, "no float or double grid");
#undef GRID
    vdb_cleanup();
}

/* Each refused file: its status, a message, a zeroed volume.  Also every proper prefix of
   a valid two-grid file (TRUNCATED) and a few corrupted bytes. */
void test_vdb_refuses_bad_files(void **state) {
    (void)state;
    char err[512];
    picvr_io_volume v;
    assert_int_equal(picvr_io_load_vdb(NULL, NULL, &v, err, sizeof err), PICVR_IO_ERROR_NULL_POINTER);
    assert_int_equal(picvr_io_load_vdb("x.vdb", NULL, NULL, err, sizeof err), PICVR_IO_ERROR_NULL_POINTER);
    expect_refused(vdb_path("missing.vdb"), NULL, PICVR_IO_ERROR_OPEN, "missing.vdb");
    expect_refused(vdb_dir, NULL, PICVR_IO_ERROR_OPEN, NULL);   /* a folder */
    const char *nrrd = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n\n\1";
    write_bytes(vdb_path("text.vdb"), nrrd, strlen(nrrd));
    expect_refused(vdb_path("text.vdb"), NULL, PICVR_IO_ERROR_BAD_HEADER, "not a VDB file");
    write_bytes(vdb_path("empty.vdb"), "", 0);
    expect_refused(vdb_path("empty.vdb"), NULL, PICVR_IO_ERROR_TRUNCATED, NULL);

    vdbw_grid g;
    memset(&g, 0, sizeof g);
    g.name = "density";
    expect_refused(write_vdb("nothing.vdb", &g, 1, -1), NULL, PICVR_IO_ERROR_BAD_DIMS, "no active voxels");
    const vdbw_voxel wide[] = {{{0, 0, 0}, 1.0}, {{70000, 0, 0}, 1.0}};
    g.active = wide;
    g.active_count = 2;
    expect_refused(write_vdb("wide.vdb", &g, 1, -1), NULL, PICVR_IO_ERROR_BAD_DIMS, "70001");
    const vdbw_voxel huge[] = {{{0, 0, 0}, 1.0}, {{2000, 2000, 2000}, 1.0}};
    g.active = huge;
    expect_refused(write_vdb("huge.vdb", &g, 1, -1), NULL, PICVR_IO_ERROR_SIZE_OVERFLOW, "2001x2001x2001");
    g.active_count = 1;
    g.frustum = 1;
    expect_refused(write_vdb("frustum.vdb", &g, 1, -1), NULL, PICVR_IO_ERROR_BAD_HEADER, "linear");
    g.frustum = 0;

    /* every proper prefix of a valid file */
    const vdbw_voxel some[] = {{{0, 0, 0}, 1.0}, {{9, 3, 1}, 2.0}, {{40, 0, 7}, 3.0}};
    vdbw_grid two[2];
    memcpy(&two[0], &g, sizeof g);
    two[0].active = some;
    two[0].active_count = 3;
    memcpy(&two[1], &two[0], sizeof g);
    two[1].name = "second";
    size_t n = 0;
    unsigned char *bytes = read_bytes(write_vdb("whole.vdb", two, 2, -1), &n);
    const char *cut = vdb_path("cut.vdb");
    for (size_t len = 0; len < n; len++) {
        write_bytes(cut, bytes, len);
        memset(&v, 0xab, sizeof v);
        err[0] = '\0';
        picvr_io_status s = picvr_io_load_vdb(cut, NULL, &v, err, sizeof err);
        if (s != PICVR_IO_ERROR_TRUNCATED) print_message("vdb: prefix of %zu of %zu bytes: %s: %s\n", len, n,
                                                         picvr_io_status_string(s), err);
        assert_int_equal(s, PICVR_IO_ERROR_TRUNCATED);
        assert_true(err[0] != '\0' && is_zeroed(&v));
    }
    write_bytes(cut, bytes, n);
    assert_int_equal(picvr_io_load_vdb(cut, "second", &v, err, sizeof err), PICVR_IO_OK);
    picvr_io_free(&v);

    /* corrupted header fields */
    const struct { const char *what; size_t at; unsigned char value; } edits[] = {
        {"magic", 1, 'X'}, {"format version 221", 8, 221}, {"format version 225", 8, 225},
        {"no grid offsets", 20, 0}, {"uuid", 25, 'g'}};
    for (size_t i = 0; i < sizeof edits / sizeof edits[0]; i++) {
        unsigned char save = bytes[edits[i].at];
        bytes[edits[i].at] = edits[i].value;
        write_bytes(cut, bytes, n);
        print_message("vdb: corrupted %s\n", edits[i].what);
        expect_refused(cut, NULL, PICVR_IO_ERROR_BAD_HEADER, NULL);
        bytes[edits[i].at] = save;
    }
    free(bytes);
    vdb_cleanup();
}

/* The data folder: $PICVR_DATA, else ../shared/data from the repository root or
   ../../shared/data from build/. */
static const char *data_dir(void) {
    static const char *const tries[] = {NULL, "../shared/data", "../../shared/data"};
    struct stat st;
    for (size_t i = 0; i < sizeof tries / sizeof tries[0]; i++) {
        const char *d = i == 0 ? getenv("PICVR_DATA") : tries[i];
        if (d && stat(d, &st) == 0 && S_ISDIR(st.st_mode)) return d;
    }
    return NULL;
}

/* wdas_cloud_sixteenth.vdb (Disney cloud, 1/16 resolution): dims 126x86x154 (the active
   bounding box), voxel size 3.33 (README; 10/3 in the file), identity axes, origin = voxel
   size x index (-66,-21,-90), and every voxel equal to the dense copy beside it (OpenVDB's
   copyToArray, README). */
void test_vdb_disney_cloud(void **state) {
    (void)state;
    const char *dir = data_dir();
    char vdb[512], raw[512], err[512];
    if (dir) {
        snprintf(vdb, sizeof vdb, "%s/wdas_cloud_sixteenth.vdb", dir);
        snprintf(raw, sizeof raw, "%s/wdas_cloud_sixteenth_126x86x154_float32.raw.gz", dir);
    }
    if (!dir || access(vdb, R_OK) != 0 || access(raw, R_OK) != 0) {
        print_message("    no shared/data/wdas_cloud_sixteenth files: skipped\n");
        skip();
    }
    picvr_io_volume v;
    picvr_io_status s = picvr_io_load_vdb(vdb, NULL, &v, err, sizeof err);
    if (s != PICVR_IO_OK) print_message("vdb: %s\n", err);
    assert_int_equal(s, PICVR_IO_OK);
    assert_int_equal(v.dims[0], 126);
    assert_int_equal(v.dims[1], 86);
    assert_int_equal(v.dims[2], 154);
    const int lo[3] = {-66, -21, -90};
    for (int a = 0; a < 3; a++) {
        assert_true(fabs(v.spacing[a] - 3.33) < 0.005 && v.spacing[a] == v.spacing[0]);
        assert_true(fabs(v.origin[a] - (double)v.spacing[0] * lo[a]) < 1e-3);
        for (int c = 0; c < 3; c++) assert_true(v.direction[3 * a + c] == (a == c ? 1.0f : 0.0f));
    }
    assert_string_equal(v.warning, "");
    const size_t count = (size_t)126 * 86 * 154;
    float *want = (float *)malloc(count * sizeof(float));
    gzFile gz = gzopen(raw, "rb");
    assert_non_null(gz);
    assert_int_equal(gzread(gz, want, (unsigned)(count * sizeof(float))), (int)(count * sizeof(float)));
    gzclose(gz);
    size_t differ = 0, nonzero = 0;
    const float *got = (const float *)v.data;
    for (size_t i = 0; i < count; i++) {
        differ += got[i] != want[i];
        nonzero += got[i] > 0.0f;
    }
    print_message("vdb: cloud: %zu of %zu voxels differ from the dense copy; %zu > 0\n", differ, count, nonzero);
    assert_int_equal(differ, 0);
    assert_int_equal(nonzero, 363037);   /* README */
    free(want);
    picvr_io_free(&v);
}

void test_vdb_is_vdb(void **state) {
    (void)state;
    assert_true(picvr_io_is_vdb("a.vdb") && picvr_io_is_vdb("dir/B.VDB") && picvr_io_is_vdb("x.Vdb"));
    assert_false(picvr_io_is_vdb("a.vdb.gz") || picvr_io_is_vdb("vdb") || picvr_io_is_vdb("a.nrrd") ||
                 picvr_io_is_vdb("") || picvr_io_is_vdb(NULL));
}
