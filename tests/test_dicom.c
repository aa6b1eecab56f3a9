/* test_dicom.c - the DICOM series reader (picvr_io_load_dicom, io/dicom*.cpp): synthetic CT
 * series written by tests/dicom_writer.cpp into private folders, read back and compared
 * with the attributes written (geometry computed here from the orientation and positions
 * asked for, values from dw_value); the warnings for uneven spacing, gantry tilt, several
 * series and non-DICOM files; refusals, each with its status and a zeroed volume; and a
 * real file, pydicom's CT_small.dcm, when installed. */
#include "test_util.h"

#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include "dicom_writer.h"
#include "picvr_io.h"

#define DEG (M_PI / 180.0)

/* Skips the test in a build without GDCM (PICVR_IO_NO_DICOM: the reader answers
   PICVR_IO_ERROR_UNSUPPORTED to any path, where the real one says OPEN). */
static void skip_without_gdcm(void) {
    picvr_io_volume v;
    if (picvr_io_load_dicom("/nonexistent/picvr-dicom-probe", &v, NULL, 0) == PICVR_IO_ERROR_UNSUPPORTED) {
        print_message("dicom: built without GDCM: skipped\n");
        skip();
    }
}

/* A private folder under $TMPDIR. */
static void make_dir(char *dir, size_t size) {
    const char *t = getenv("TMPDIR");
    snprintf(dir, size, "%s/pvio-dicom-XXXXXX", t && *t ? t : "/tmp");
    assert_non_null(mkdtemp(dir));
}

/* Removes the folder's files, then the folder. */
static void remove_dir(const char *dir) {
    DIR *d = opendir(dir);
    assert_non_null(d);
    struct dirent *e;
    char p[1024];
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        unlink(p);
    }
    closedir(d);
    assert_int_equal(rmdir(dir), 0);
}

static void write_text(const char *dir, const char *name, const char *text) {
    char p[1024];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    FILE *f = fopen(p, "wb");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static const char *file_in(const char *dir, const char *name) {
    static char p[1024];
    snprintf(p, sizeof p, "%s/%s", dir, name);
    return p;
}

static void assert_near(double got, double want, double tol, const char *what) {
    if (!(fabs(got - want) <= tol)) fail_msg("%s: %.9g, expected %.9g (+-%g)", what, got, want, tol);
}

static void assert_zeroed(const picvr_io_volume *v) {
    picvr_io_volume zero;
    memset(&zero, 0, sizeof zero);
    assert_memory_equal(v, &zero, sizeof zero);
}

/* Every voxel equals dw_value of the writer's slice slice_of_z[z] (z: the volume's
   slice index). */
static void assert_values(const picvr_io_volume *v, const uint32_t *slice_of_z, int is_signed) {
    for (uint32_t z = 0; z < v->dims[2]; z++)
        for (uint32_t y = 0; y < v->dims[1]; y++)
            for (uint32_t x = 0; x < v->dims[0]; x++) {
                size_t i = x + (size_t)v->dims[0] * (y + (size_t)v->dims[1] * z);
                int32_t got = is_signed ? ((const int16_t *)v->data)[i] : ((const uint16_t *)v->data)[i];
                int32_t want = dw_value(x, y, slice_of_z[z], is_signed);
                if (got != want) fail_msg("voxel (%u,%u,%u): %d, expected %d", x, y, z, got, want);
            }
}

/* An oblique orientation: row cosine r = (cos 30, sin 30, 0), column cosine
   c = (-sin 30 cos 20, cos 30 cos 20, sin 20); their normal worked out by hand,
   n = r x c = (sin 30 sin 20, -cos 30 sin 20, cos 20).  Positions step -2.5 mm along n
   (SliceThickness says 5), so slice 0 is the highest: the volume's first slice is the
   writer's last, and the origin that slice's position. */
void test_dicom_reads_geometry_and_values(void **state) {
    (void)state;
    skip_without_gdcm();
    char dir[512], err[512];
    make_dir(dir, sizeof dir);
    dw_series s;
    dw_defaults(&s, dir);
    const double r[3] = {cos(30 * DEG), sin(30 * DEG), 0};
    const double c[3] = {-sin(30 * DEG) * cos(20 * DEG), cos(30 * DEG) * cos(20 * DEG), sin(20 * DEG)};
    const double n[3] = {sin(30 * DEG) * sin(20 * DEG), -cos(30 * DEG) * sin(20 * DEG), cos(20 * DEG)};
    memcpy(s.iop, r, sizeof r);
    memcpy(s.iop + 3, c, sizeof c);
    for (int i = 0; i < 3; i++) s.step[i] = -2.5 * n[i];
    s.slice_thickness = 5.0;
    assert_int_equal(dw_write_series(&s, NULL), 0);

    picvr_io_volume v;
    assert_int_equal(picvr_io_load_dicom(dir, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.dims[0], 8);
    assert_int_equal(v.dims[1], 6);
    assert_int_equal(v.dims[2], 5);
    assert_int_equal(v.type, PICVR_VOXEL_INT16);
    assert_int_equal(v.size, 8 * 6 * 5 * 2);
    assert_near(v.spacing[0], 0.5, 1e-6, "spacing x (column spacing, PixelSpacing[1])");
    assert_near(v.spacing[1], 0.75, 1e-6, "spacing y (row spacing, PixelSpacing[0])");
    assert_near(v.spacing[2], 2.5, 1e-5, "spacing z (positions, not SliceThickness)");
    for (int i = 0; i < 3; i++) {
        assert_near(v.direction[i], r[i], 1e-6, "direction x");
        assert_near(v.direction[3 + i], c[i], 1e-6, "direction y");
        assert_near(v.direction[6 + i], n[i], 1e-6, "direction z");
        assert_near(v.origin[i], s.ipp0[i] + 4 * s.step[i], 1e-4, "origin: the last slice written");
    }
    assert_true(v.value_scale == 1.0 && v.value_offset == -1024.0);
    assert_string_equal(v.modality, "CT");
    assert_int_equal(v.patient_frame, 1);
    assert_string_equal(v.warning, "");
    const uint32_t slice_of_z[5] = {4, 3, 2, 1, 0};
    assert_values(&v, slice_of_z, 1);
    picvr_io_free(&v);
    assert_zeroed(&v);

    assert_int_equal(picvr_io_is_dicom(dir), 1);
    assert_int_equal(picvr_io_is_dicom("/nowhere/ct/S001.DCM"), 1);
    assert_int_equal(picvr_io_is_dicom("/nowhere/ct/S001.nrrd"), 0);
    assert_int_equal(picvr_io_is_dicom(NULL), 0);
    remove_dir(dir);
}

static void assert_same_volume(const picvr_io_volume *a, const picvr_io_volume *b) {
    assert_memory_equal(a->dims, b->dims, sizeof a->dims);
    assert_int_equal(a->type, b->type);
    assert_int_equal(a->size, b->size);
    assert_memory_equal(a->data, b->data, a->size);
    assert_memory_equal(a->spacing, b->spacing, sizeof a->spacing);
    assert_memory_equal(a->origin, b->origin, sizeof a->origin);
    assert_memory_equal(a->direction, b->direction, sizeof a->direction);
    assert_true(a->value_scale == b->value_scale && a->value_offset == b->value_offset);
    assert_string_equal(a->modality, b->modality);
    assert_string_equal(a->warning, b->warning);
}

/* File names in a random order against the positions (and InstanceNumber running
   against them, as the writer always does) load byte-identical to names in position
   order; loading through one of the files gives the same volume as the folder. */
void test_dicom_shuffled_names_load_identically(void **state) {
    (void)state;
    skip_without_gdcm();
    char sorted_dir[512], shuffled_dir[512], err[512];
    make_dir(sorted_dir, sizeof sorted_dir);
    make_dir(shuffled_dir, sizeof shuffled_dir);
    dw_series s;
    dw_defaults(&s, sorted_dir);
    s.slices = 9;
    s.is_signed = 0;
    s.intercept = 0;
    assert_int_equal(dw_write_series(&s, NULL), 0);
    s.dir = shuffled_dir;
    s.shuffle_seed = 12345;
    uint32_t file_of_slice[9];
    assert_int_equal(dw_write_series(&s, file_of_slice), 0);
    int moved = 0;
    for (int k = 0; k < 9; k++) moved += file_of_slice[k] != (uint32_t)k;
    assert_true(moved >= 4);

    picvr_io_volume a, b, c;
    assert_int_equal(picvr_io_load_dicom(sorted_dir, &a, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(a.type, PICVR_VOXEL_UINT16);
    assert_true(a.value_scale == 1.0 && a.value_offset == 0.0);
    const uint32_t identity[9] = {0, 1, 2, 3, 4, 5, 6, 7, 8};
    assert_values(&a, identity, 0);
    assert_int_equal(picvr_io_load_dicom(shuffled_dir, &b, err, sizeof err), PICVR_IO_OK);
    assert_same_volume(&a, &b);
    assert_int_equal(picvr_io_load_dicom(file_in(shuffled_dir, "s006.dcm"), &c, err, sizeof err), PICVR_IO_OK);
    assert_same_volume(&a, &c);
    picvr_io_free(&a);
    picvr_io_free(&b);
    picvr_io_free(&c);
    remove_dir(sorted_dir);
    remove_dir(shuffled_dir);
}

/* Positions 0, 2.5, 5, 8, 10.5 along z: loaded with the median spacing 2.5 and the
   warning; a 15 degree gantry tilt (positions stepping 2.5 mm in z and 2.5 tan 15 in
   y under an axial orientation): the z axis along the step, (0, sin 15, cos 15), its
   spacing the step's length 2.5 / cos 15, and the warning. */
void test_dicom_uneven_spacing_and_tilt(void **state) {
    (void)state;
    skip_without_gdcm();
    char dir[512], err[512];
    make_dir(dir, sizeof dir);
    dw_series s;
    dw_defaults(&s, dir);
    double pos[15];
    const double z[5] = {0, 2.5, 5, 8, 10.5};
    for (int k = 0; k < 5; k++) {
        pos[3 * k] = -10;
        pos[3 * k + 1] = 20;
        pos[3 * k + 2] = z[k];
    }
    s.positions = pos;
    assert_int_equal(dw_write_series(&s, NULL), 0);
    picvr_io_volume v;
    assert_int_equal(picvr_io_load_dicom(dir, &v, err, sizeof err), PICVR_IO_OK);
    print_message("uneven: %s\n", v.warning);
    assert_non_null(strstr(v.warning, "uneven slice spacing (2.5 .. 3 mm)"));
    assert_near(v.spacing[2], 2.5, 1e-6, "median spacing");
    assert_near(v.direction[8], 1.0, 1e-7, "no tilt: z axis (0,0,1)");
    picvr_io_free(&v);
    remove_dir(dir);

    make_dir(dir, sizeof dir);
    dw_defaults(&s, dir);
    s.step[1] = 2.5 * tan(15 * DEG);
    s.step[2] = 2.5;
    assert_int_equal(dw_write_series(&s, NULL), 0);
    assert_int_equal(picvr_io_load_dicom(dir, &v, err, sizeof err), PICVR_IO_OK);
    print_message("tilt: %s\n", v.warning);
    assert_non_null(strstr(v.warning, "gantry tilt of 15 degrees"));
    assert_non_null(strstr(v.warning, "not orthogonal"));
    assert_null(strstr(v.warning, "uneven"));
    assert_near(v.direction[6], 0.0, 1e-6, "tilted z axis x");
    assert_near(v.direction[7], sin(15 * DEG), 1e-6, "tilted z axis y");
    assert_near(v.direction[8], cos(15 * DEG), 1e-6, "tilted z axis z");
    assert_near(v.direction[0], 1.0, 1e-7, "x axis the row cosine");
    assert_near(v.direction[4], 1.0, 1e-7, "y axis the column cosine");
    assert_near(v.spacing[2], 2.5 / cos(15 * DEG), 1e-5, "tilted step length");
    for (int i = 0; i < 3; i++) assert_near(v.origin[i], s.ipp0[i], 1e-5, "origin");
    picvr_io_free(&v);
    remove_dir(dir);
}

/* Slopes differing between slices: float32 with each slice's rescale applied, scale 1,
   offset 0, and the warning. */
void test_dicom_rescale_per_slice_to_float(void **state) {
    (void)state;
    skip_without_gdcm();
    char dir[512], err[512];
    make_dir(dir, sizeof dir);
    dw_series s;
    dw_defaults(&s, dir);
    const double slopes[5] = {1, 2, 1, 0.5, 1};
    s.slopes = slopes;
    s.intercept = -1000;
    assert_int_equal(dw_write_series(&s, NULL), 0);
    picvr_io_volume v;
    assert_int_equal(picvr_io_load_dicom(dir, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.type, PICVR_VOXEL_FLOAT32);
    assert_int_equal(v.size, 8 * 6 * 5 * 4);
    assert_true(v.value_scale == 1.0 && v.value_offset == 0.0);
    assert_non_null(strstr(v.warning, "rescale differs"));
    const float *f = (const float *)v.data;
    for (uint32_t k = 0; k < 5; k++)
        for (uint32_t y = 0; y < 6; y++)
            for (uint32_t x = 0; x < 8; x++)
                assert_near(f[x + 8 * (y + 6 * k)], dw_value(x, y, k, 1) * slopes[k] - 1000.0, 0.0, "rescaled voxel");
    picvr_io_free(&v);
    remove_dir(dir);
}

/* A folder with a 5-slice series, a 3-slice one (4 columns) and a text file: the
   folder gives the larger series and says so; a file of the smaller one gives that
   one, without the folder's warnings. */
void test_dicom_two_series_takes_larger(void **state) {
    (void)state;
    skip_without_gdcm();
    char dir[512], err[512];
    make_dir(dir, sizeof dir);
    dw_series s;
    dw_defaults(&s, dir);
    assert_int_equal(dw_write_series(&s, NULL), 0);
    dw_defaults(&s, dir);
    s.prefix = "t";
    s.series_uid = "2.25.2000";
    s.cols = 4;
    s.slices = 3;
    assert_int_equal(dw_write_series(&s, NULL), 0);
    write_text(dir, "notes.txt", "not a DICOM file\n");

    picvr_io_volume v;
    assert_int_equal(picvr_io_load_dicom(dir, &v, err, sizeof err), PICVR_IO_OK);
    print_message("two series: %s\n", v.warning);
    assert_int_equal(v.dims[0], 8);
    assert_int_equal(v.dims[2], 5);
    assert_non_null(strstr(v.warning, "series 2.25.1000 (5 slices) read, 1 other series"));
    assert_non_null(strstr(v.warning, "1 files skipped: not DICOM images"));
    picvr_io_free(&v);
    assert_int_equal(picvr_io_load_dicom(file_in(dir, "t001.dcm"), &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.dims[0], 4);
    assert_int_equal(v.dims[2], 3);
    assert_string_equal(v.warning, "");
    const uint32_t identity[3] = {0, 1, 2};
    assert_values(&v, identity, 1);
    picvr_io_free(&v);
    remove_dir(dir);
}

static void expect_refusal(const char *what, const char *path, picvr_io_status want, const char *in_message) {
    char err[512] = "";
    picvr_io_volume v;
    memset(&v, 0xab, sizeof v);
    picvr_io_status st = picvr_io_load_dicom(path, &v, err, sizeof err);
    print_message("dicom: %-22s -> %s: %s\n", what, picvr_io_status_string(st), err);
    assert_int_equal(st, want);
    assert_true(err[0] != '\0');
    if (in_message) assert_non_null(strstr(err, in_message));
    assert_zeroed(&v);
}

/* Each refused with its status, a message naming the file, and a zeroed volume. */
void test_dicom_refusals(void **state) {
    (void)state;
    skip_without_gdcm();
    char dir[512];
    make_dir(dir, sizeof dir);
    expect_refusal("empty folder", dir, PICVR_IO_ERROR_OPEN, dir);
    write_text(dir, "a.txt", "hello\n");
    write_text(dir, "b.dcm", "DICM? no: plain text pretending\n");
    expect_refusal("no DICOM in folder", dir, PICVR_IO_ERROR_BAD_HEADER, "no DICOM image");
    expect_refusal("a non-DICOM .dcm", file_in(dir, "b.dcm"), PICVR_IO_ERROR_BAD_HEADER, "b.dcm");
    expect_refusal("no such path", file_in(dir, "missing"), PICVR_IO_ERROR_OPEN, "missing");
    remove_dir(dir);

    dw_series s;
    make_dir(dir, sizeof dir);
    dw_defaults(&s, dir);
    s.odd_rows_slice = 2;
    assert_int_equal(dw_write_series(&s, NULL), 0);
    expect_refusal("a slice with 7 rows", dir, PICVR_IO_ERROR_BAD_HEADER, "s002.dcm: 7 rows x 8 columns");
    remove_dir(dir);

    make_dir(dir, sizeof dir);
    dw_defaults(&s, dir);
    double pos[15];
    const double z[5] = {0, 2.5, 5, 5, 7.5};
    for (int k = 0; k < 5; k++) {
        pos[3 * k] = pos[3 * k + 1] = 0;
        pos[3 * k + 2] = z[k];
    }
    s.positions = pos;
    assert_int_equal(dw_write_series(&s, NULL), 0);
    expect_refusal("duplicate position", dir, PICVR_IO_ERROR_BAD_HEADER, "duplicate slice position");
    remove_dir(dir);

    make_dir(dir, sizeof dir);
    dw_defaults(&s, dir);
    assert_int_equal(dw_write_series(&s, NULL), 0);
    struct stat st;
    assert_int_equal(stat(file_in(dir, "s003.dcm"), &st), 0);
    assert_int_equal(truncate(file_in(dir, "s003.dcm"), st.st_size - 10), 0);
    expect_refusal("a truncated slice", dir, PICVR_IO_ERROR_TRUNCATED, "s003.dcm");
    remove_dir(dir);

    picvr_io_volume v;
    assert_int_equal(picvr_io_load_dicom(NULL, &v, NULL, 0), PICVR_IO_ERROR_NULL_POINTER);
    assert_zeroed(&v);
    assert_int_equal(picvr_io_load_dicom("x.dcm", NULL, NULL, 0), PICVR_IO_ERROR_NULL_POINTER);
}

/* pydicom's CT_small.dcm (Debian python3-pydicom), a real CT slice.  Expected values
   read with pydicom 2.3 (dcmread(...).Rows, .PixelSpacing, .ImagePositionPatient,
   .RescaleSlope/Intercept, .pixel_array[row, column]): 128 x 128 int16, PixelSpacing
   0.661468\0.661468, position (-158.135803, -179.035797, -75.699997), axial identity
   orientation, slope 1, intercept -1024, SliceThickness 5 (the one slice's spacing);
   pixel_array[0,0] = 175, [0,1] = 180, [1,0] = 186, [127,127] = 909, [64,32] = 1378. */
void test_dicom_real_ct_small(void **state) {
    (void)state;
    skip_without_gdcm();
    const char *path = "/usr/lib/python3/dist-packages/pydicom/data/test_files/CT_small.dcm";
    if (access(path, R_OK) != 0) {
        print_message("dicom: %s absent (apt-get install python3-pydicom): skipped\n", path);
        skip();
    }
    char err[512];
    picvr_io_volume v;
    picvr_io_status st = picvr_io_load_dicom(path, &v, err, sizeof err);
    if (st != PICVR_IO_OK) fail_msg("%s: %s", picvr_io_status_string(st), err);
    print_message("CT_small: %s\n", v.warning);
    assert_int_equal(v.dims[0], 128);
    assert_int_equal(v.dims[1], 128);
    assert_int_equal(v.dims[2], 1);
    assert_int_equal(v.type, PICVR_VOXEL_INT16);
    assert_string_equal(v.modality, "CT");
    assert_true(v.value_scale == 1.0 && v.value_offset == -1024.0);
    assert_near(v.spacing[0], 0.661468, 1e-6, "spacing x");
    assert_near(v.spacing[1], 0.661468, 1e-6, "spacing y");
    assert_near(v.spacing[2], 5.0, 1e-6, "one slice: SliceThickness");
    assert_near(v.origin[0], -158.135803, 1e-4, "origin x");
    assert_near(v.origin[1], -179.035797, 1e-4, "origin y");
    assert_near(v.origin[2], -75.699997, 1e-4, "origin z");
    const float id[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    assert_memory_equal(v.direction, id, sizeof id);
    const int16_t *d = (const int16_t *)v.data;
    assert_int_equal(d[0], 175);
    assert_int_equal(d[1], 180);
    assert_int_equal(d[128], 186);
    assert_int_equal(d[127 + 128 * 127], 909);
    assert_int_equal(d[32 + 128 * 64], 1378);
    picvr_io_free(&v);
}
