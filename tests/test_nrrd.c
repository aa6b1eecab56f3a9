/* test_nrrd.c - the NRRD loader of io/nrrd.c and its percentile range (picvr_io_load_nrrd, and picvr_io_load
 * by extension): files written here byte by byte from the format's specification
 * (teem.sourceforge.net/nrrd/format.html), read back and compared with the values,
 * spacings, orientation and origin written; and malformed or unsupported headers, each
 * refused with its status and a zeroed volume. */
#include "test_util.h"

#include <unistd.h>
#include <zlib.h>

#include "picvr_io.h"

static char nrrd_dir[256];

/* A file in a private folder: header text, then `n` data bytes (gzip-compressed when
   gz). */
static const char *write_nrrd(const char *name, const char *header, const void *data, size_t n, int gz) {
    static char path[512];
    if (!nrrd_dir[0]) {
        snprintf(nrrd_dir, sizeof nrrd_dir, "%s/pvio-nrrd-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        assert_non_null(mkdtemp(nrrd_dir));
    }
    snprintf(path, sizeof path, "%s/%s", nrrd_dir, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs(header, f);
    if (gz) {
        uLongf cap = compressBound((uLong)n) + 32;
        unsigned char *z = (unsigned char *)malloc(cap);
        z_stream s;
        memset(&s, 0, sizeof s);
        assert_int_equal(deflateInit2(&s, 6, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);   /* gzip */
        s.next_in = (Bytef *)data;
        s.avail_in = (uInt)n;
        s.next_out = z;
        s.avail_out = (uInt)cap;
        assert_int_equal(deflate(&s, Z_FINISH), Z_STREAM_END);
        fwrite(z, 1, s.total_out, f);
        deflateEnd(&s);
        free(z);
    } else if (n) {
        fwrite(data, 1, n, f);
    }
    fclose(f);
    return path;
}

static void remove_nrrd(const char *name) {
    char path[512];
    snprintf(path, sizeof path, "%s/%s", nrrd_dir, name);
    unlink(path);
}

/* Little-endian uint8 with spacings; big-endian int16 with space directions (a rotation
   and scale) and an origin; gzip float32 attached; a detached header with its data file
   beside it, raw with byte skip 4 and -1, and gzip. */
void test_nrrd_reads_layout_values_and_geometry(void **state) {
    (void)state;
    char err[512];
    picvr_io_volume v;
    const uint8_t u8[12] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 255};
    const char *p = write_nrrd("a.nrrd", "NRRD0004\n# a comment\ntype: uchar\ndimension: 3\nsizes: 3 2 2\n"
                               "spacings: 0.5 2 1.25\nencoding: raw\nkey:=value\n\n", u8, sizeof u8, 0);
    assert_int_equal(picvr_io_load(p, NULL, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.dims[0], 3);
    assert_int_equal(v.dims[1], 2);
    assert_int_equal(v.dims[2], 2);
    assert_int_equal(v.type, PICVR_VOXEL_UINT8);
    assert_true(v.spacing[0] == 0.5f && v.spacing[1] == 2.0f && v.spacing[2] == 1.25f);
    assert_true(v.direction[0] == 1.0f && v.direction[4] == 1.0f && v.direction[8] == 1.0f && v.direction[1] == 0.0f);
    assert_memory_equal(v.data, u8, sizeof u8);
    picvr_io_free(&v);

    /* big-endian int16: -300, 2, 32767, -32768 as written byte by byte */
    const uint8_t be[8] = {0xfe, 0xd4, 0x00, 0x02, 0x7f, 0xff, 0x80, 0x00};
    p = write_nrrd("b.nrrd", "NRRD0005\ntype: short\ndimension: 3\nspace: right-anterior-superior\nsizes: 2 2 1\n"
                   "endian: big\nencoding: raw\nspace directions: (0,3,0) (-4,0,0) (0,0,0.5)\n"
                   "space origin: (10.5,-2,7)\nkinds: domain domain domain\n\n", be, sizeof be, 0);
    assert_int_equal(picvr_io_load(p, NULL, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.type, PICVR_VOXEL_INT16);
    const int16_t want16[4] = {-300, 2, 32767, -32768};
    assert_memory_equal(v.data, want16, sizeof want16);
    assert_true(v.spacing[0] == 3.0f && v.spacing[1] == 4.0f && v.spacing[2] == 0.5f);
    /* the header's RAS axes and origin in LPS: x and y negated */
    const float dir[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};
    assert_memory_equal(v.direction, dir, sizeof dir);
    assert_true(v.origin[0] == -10.5f && v.origin[1] == 2.0f && v.origin[2] == 7.0f);
    assert_int_equal(v.patient_frame, 1);
    picvr_io_free(&v);

    float f32[24];
    for (int i = 0; i < 24; i++) f32[i] = (float)(i * 0.25 - 2.0);
    p = write_nrrd("c.nrrd", "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: gzip\n\n",
                   f32, sizeof f32, 1);
    assert_int_equal(picvr_io_load(p, NULL, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.type, PICVR_VOXEL_FLOAT32);
    assert_memory_equal(v.data, f32, sizeof f32);
    picvr_io_free(&v);

    /* detached: the data file beside the header, byte skip 4 (raw) */
    uint8_t skipped[16] = {9, 9, 9, 9};
    memcpy(skipped + 4, u8, sizeof u8);
    write_nrrd("d.raw", "", skipped, sizeof skipped, 0);
    p = write_nrrd("d.nhdr", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 2 2\nencoding: raw\nbyte skip: 4\n"
                   "data file: d.raw\n", NULL, 0, 0);
    assert_int_equal(picvr_io_load(p, NULL, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, u8, sizeof u8);
    picvr_io_free(&v);
    /* byte skip -1: the data ends the file */
    p = write_nrrd("e.nhdr", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 2 2\nencoding: raw\nbyte skip: -1\n"
                   "datafile: d.raw\n", NULL, 0, 0);
    assert_int_equal(picvr_io_load(p, NULL, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, u8, sizeof u8);
    picvr_io_free(&v);
    /* gzip detached, byte skip in the decompressed stream */
    write_nrrd("f.raw.gz", "", skipped, sizeof skipped, 1);
    p = write_nrrd("f.nhdr", "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 2 2\nencoding: gz\nbyte skip: 4\n"
                   "data file: f.raw.gz\n", NULL, 0, 0);
    assert_int_equal(picvr_io_load(p, NULL, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, u8, sizeof u8);
    picvr_io_value_range(&v, NULL, NULL, NULL);
    picvr_io_free(&v);
    const char *names[] = {"a.nrrd", "b.nrrd", "c.nrrd", "d.raw", "d.nhdr", "e.nhdr", "f.raw.gz", "f.nhdr"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) remove_nrrd(names[i]);
}

/* Each malformed or unsupported file is refused with its status, a message, and a
   zeroed volume. */
void test_nrrd_refuses_bad_headers(void **state) {
    (void)state;
    const uint8_t data[64] = {0};
    const char *ok_head = "type: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n";
    char head[1024];
    struct { const char *what, *header; size_t bytes; int gz; picvr_io_status want; } rows[] = {
        {"no magic", "NRRX0004\ntype: uchar\n\n", 8, 0, PICVR_IO_ERROR_BAD_HEADER},
        {"magic NRRD0009", "NRRD0009\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", 8, 0, PICVR_IO_ERROR_BAD_HEADER},
        {"dimension 2", "NRRD0004\ntype: uchar\ndimension: 2\nsizes: 2 2\nencoding: raw\n\n", 4, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"a size 0", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 0 2\nencoding: raw\n\n", 0, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"a size 70000", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 70000 2\nencoding: raw\n\n", 8, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"a size 2.5", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2.5 2\nencoding: raw\n\n", 8, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"two sizes", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2\nencoding: raw\n\n", 8, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"type uint32", "NRRD0004\ntype: uint\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nendian: little\n\n", 32, 0, PICVR_IO_ERROR_BAD_TYPE},
        {"type int64", "NRRD0004\ntype: longlong\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", 64, 0, PICVR_IO_ERROR_BAD_TYPE},
        {"encoding ascii", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: ascii\n\n", 8, 0, PICVR_IO_ERROR_BAD_HEADER},
        {"no endian for int16", "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n", 16, 0, PICVR_IO_ERROR_BAD_HEADER},
        {"endian middle", "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nendian: middle\n\n", 16, 0, PICVR_IO_ERROR_BAD_HEADER},
        {"no encoding", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\n\n", 8, 0, PICVR_IO_ERROR_BAD_HEADER},
        {"truncated data", NULL, 7, 0, PICVR_IO_ERROR_TRUNCATED},
        {"data too long", NULL, 9, 0, PICVR_IO_ERROR_TOO_LONG},
        {"gzip said, raw given", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\n\n", 8, 0, PICVR_IO_ERROR_READ},
        {"gzip truncated", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 4\nencoding: gzip\n\n", 8, 1, PICVR_IO_ERROR_TRUNCATED},
        {"byte skip -1 with gzip", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\nbyte skip: -1\n\n", 8, 1, PICVR_IO_ERROR_BAD_HEADER},
        {"byte skip -2", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nbyte skip: -2\n\n", 8, 0, PICVR_IO_ERROR_BAD_HEADER},
        {"byte skip past the end", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nbyte skip: 4\n\n", 8, 0, PICVR_IO_ERROR_TRUNCATED},
        {"line skip 1", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nline skip: 1\n\n", 8, 0, PICVR_IO_ERROR_BAD_HEADER},
        {"data file LIST", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: LIST\n", 0, 0, PICVR_IO_ERROR_BAD_HEADER},
        {"data file missing", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: nowhere.raw\n", 0, 0, PICVR_IO_ERROR_OPEN},
        {"no blank line, no data file", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n", 0, 0, PICVR_IO_ERROR_TRUNCATED},
        {"spacing NaN", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspacings: 1 nan 1\n\n", 8, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"spacing 0", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspacings: 1 0 1\n\n", 8, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"spacing 1e300", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspacings: 1 1e300 1\n\n", 8, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"a zero direction", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace directions: (1,0,0) (0,0,0) (0,0,1)\n\n", 8, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"direction none", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace directions: none (0,1,0) (0,0,1)\n\n", 8, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"origin of two", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nspace origin: (1,2)\n\n", 8, 0, PICVR_IO_ERROR_BAD_DIMS},
        {"a line without a colon", "NRRD0004\ntype uchar\n\n", 8, 0, PICVR_IO_ERROR_BAD_HEADER},
    };
    char err[512];
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        const char *h = rows[i].header;
        if (!h) {
            snprintf(head, sizeof head, "NRRD0004\n%s\n", ok_head);
            h = head;
        }
        const char *p = write_nrrd("bad.nrrd", h, data, rows[i].bytes, rows[i].gz);
        picvr_io_volume v;
        err[0] = '\0';
        picvr_io_status s = picvr_io_load(p, NULL, &v, err, sizeof err);
        print_message("nrrd: %-30s -> %s: %s\n", rows[i].what, picvr_io_status_string(s), err);
        assert_int_equal(s, rows[i].want);
        assert_true(err[0] != '\0');
        assert_null(v.data);
        assert_int_equal(v.dims[0], 0);
    }
    /* a header line longer than the reader takes */
    char *longline = (char *)malloc(10000);
    memcpy(longline, "NRRD0004\n# ", 11);
    memset(longline + 11, 'x', 9000);
    strcpy(longline + 9011, "\ntype: uchar\n\n");
    picvr_io_volume v;
    const char *p = write_nrrd("bad.nrrd", longline, data, 8, 0);
    assert_int_equal(picvr_io_load(p, NULL, &v, err, sizeof err), PICVR_IO_ERROR_BAD_HEADER);
    free(longline);
    remove_nrrd("bad.nrrd");
    rmdir(nrrd_dir);
}

/* picvr_io_percentile_range (picvr-render --range auto): a CT-like int16 volume of 900 voxels
   of air (-1000) and 100 of tissue 0, 10, ..., 990: the 0.5th percentile is the air,
   the 99.5th the sorted value at index round(0.995 x 999) = 994 (940: the convention
   of picvr_io_percentile_range, nearest rank); a constant volume widens to [v, v+1];
   no finite voxel and bad fractions are refused. */
void test_volume_io_percentile_range(void **state) {
    (void)state;
    int16_t ct[1000];
    for (int i = 0; i < 900; i++) ct[i] = -1000;
    for (int i = 0; i < 100; i++) ct[900 + i] = (int16_t)(10 * i);
    picvr_io_volume v;
    memset(&v, 0, sizeof v);
    v.dims[0] = 10; v.dims[1] = 10; v.dims[2] = 10;
    v.type = PICVR_VOXEL_INT16;
    v.data = ct;
    v.size = sizeof ct;
    double lo = 0, hi = 0;
    assert_int_equal(picvr_io_percentile_range(&v, 0.005, 0.995, &lo, &hi), PICVR_IO_OK);
    assert_true(lo == -1000.0 && hi == 940.0);
    assert_int_equal(picvr_io_percentile_range(&v, 0.0, 1.0, &lo, &hi), PICVR_IO_OK);
    assert_true(lo == -1000.0 && hi == 990.0);
    float c[8] = {2.5f, 2.5f, 2.5f, 2.5f, 2.5f, 2.5f, 2.5f, NAN};
    v.dims[0] = v.dims[1] = v.dims[2] = 2;
    v.type = PICVR_VOXEL_FLOAT32;
    v.data = c;
    v.size = sizeof c;
    assert_int_equal(picvr_io_percentile_range(&v, 0.005, 0.995, &lo, &hi), PICVR_IO_OK);
    assert_true(lo == 2.5 && hi == 3.5);
    for (int i = 0; i < 8; i++) c[i] = NAN;
    assert_int_equal(picvr_io_percentile_range(&v, 0.005, 0.995, &lo, &hi), PICVR_IO_ERROR_BAD_TYPE);
    assert_int_equal(picvr_io_percentile_range(&v, 0.5, 0.5, &lo, &hi), PICVR_IO_ERROR_BAD_DIMS);
    assert_int_equal(picvr_io_percentile_range(&v, -0.1, 0.5, &lo, &hi), PICVR_IO_ERROR_BAD_DIMS);
    assert_int_equal(picvr_io_percentile_range(&v, 0.1, NAN, &lo, &hi), PICVR_IO_ERROR_BAD_DIMS);
    assert_int_equal(picvr_io_percentile_range(NULL, 0.1, 0.5, &lo, &hi), PICVR_IO_ERROR_NULL_POINTER);
}
