/* test_nifti.c - the NIfTI-1 / NIfTI-2 reader of io/nifti.c (picvr_io_load_nifti): files
 * written here byte by byte at the offsets of the specifications (nifti1.h: the 348-byte
 * header, magic "n+1"/"ni1" at 344; nifti2.h: the 540-byte header, magic "n+2\0\r\n\032\n"
 * at 4), not by niftilib's writer, read back and compared with the values, voxel sizes,
 * orientation and origin written, converted by hand from RAS to picvr's LPS; malformed
 * headers, each refused with its status and a zeroed volume; and, when python3-nibabel
 * is installed, three of its real test files against values nibabel gives. */
#include "test_util.h"

#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include "picvr_io.h"

static char nii_dir[256];

/* ---- an independent writer ----------------------------------------------------------- */

/* The header fields the tests set; the writer puts them at the specification's offsets. */
typedef struct nii_spec {
    int version;            /* 1: NIfTI-1 (348 bytes), 2: NIfTI-2 (540 bytes) */
    int big_endian;
    const char *magic;      /* NULL: "n+1" / "n+2"; "" writes no magic (ANALYZE 7.5) */
    int64_t dim[8];
    int datatype;
    double pixdim[8];
    double vox_offset;      /* 0: 352 / 544, right after the header and its 4 extension bytes */
    double scl_slope, scl_inter;
    int qform_code, sform_code;
    double quatern[3], qoffset[3];
    double srow[3][4];
    int xyzt_units;
    int32_t sizeof_hdr;     /* 0: 348 / 540 */
} nii_spec;

static void put(unsigned char *p, uint64_t v, int n, int big) {
    for (int i = 0; i < n; i++) p[big ? n - 1 - i : i] = (unsigned char)(v >> (8 * i));
}
static void put_f32(unsigned char *p, double d, int big) {
    float f = (float)d;
    uint32_t u;
    memcpy(&u, &f, 4);
    put(p, u, 4, big);
}
static void put_f64(unsigned char *p, double d, int big) {
    uint64_t u;
    memcpy(&u, &d, 8);
    put(p, u, 8, big);
}

/* Writes the header into out (548 bytes at least); returns its size (348 or 540). */
static size_t make_header(const nii_spec *s, unsigned char *out) {
    int be = s->big_endian;
    size_t size = s->version == 2 ? 540 : 348;
    memset(out, 0, 548);
    put(out, (uint32_t)(s->sizeof_hdr ? s->sizeof_hdr : (int32_t)size), 4, be);
    if (s->version == 2) {
        memcpy(out + 4, s->magic ? s->magic : "n+2\0\r\n\032\n", s->magic ? strlen(s->magic) + 1 : 8);
        put(out + 12, (uint16_t)s->datatype, 2, be);
        for (int i = 0; i < 8; i++) {
            put(out + 16 + 8 * i, (uint64_t)s->dim[i], 8, be);
            put_f64(out + 104 + 8 * i, s->pixdim[i], be);
        }
        put(out + 168, (uint64_t)(int64_t)(s->vox_offset ? s->vox_offset : 544), 8, be);
        put_f64(out + 176, s->scl_slope, be);
        put_f64(out + 184, s->scl_inter, be);
        put(out + 344, (uint32_t)s->qform_code, 4, be);
        put(out + 348, (uint32_t)s->sform_code, 4, be);
        for (int i = 0; i < 3; i++) {
            put_f64(out + 352 + 8 * i, s->quatern[i], be);
            put_f64(out + 376 + 8 * i, s->qoffset[i], be);
            for (int c = 0; c < 4; c++) put_f64(out + 400 + 32 * i + 8 * c, s->srow[i][c], be);
        }
        put(out + 500, (uint32_t)s->xyzt_units, 4, be);
    } else {
        for (int i = 0; i < 8; i++) {
            put(out + 40 + 2 * i, (uint16_t)s->dim[i], 2, be);
            put_f32(out + 76 + 4 * i, s->pixdim[i], be);
        }
        put(out + 70, (uint16_t)s->datatype, 2, be);
        put_f32(out + 108, s->vox_offset ? s->vox_offset : 352, be);
        put_f32(out + 112, s->scl_slope, be);
        put_f32(out + 116, s->scl_inter, be);
        out[123] = (unsigned char)s->xyzt_units;
        put(out + 252, (uint16_t)s->qform_code, 2, be);
        put(out + 254, (uint16_t)s->sform_code, 2, be);
        for (int i = 0; i < 3; i++) {
            put_f32(out + 256 + 4 * i, s->quatern[i], be);
            put_f32(out + 268 + 4 * i, s->qoffset[i], be);
            for (int c = 0; c < 4; c++) put_f32(out + 280 + 16 * i + 4 * c, s->srow[i][c], be);
        }
        const char *m = s->magic ? s->magic : "n+1";
        memcpy(out + 344, m, strlen(m));
    }
    return size;
}

/* A 3D spec: dims, datatype, unit pixdim, no qform or sform, version 1 little-endian. */
static nii_spec spec3(int64_t nx, int64_t ny, int64_t nz, int datatype) {
    nii_spec s;
    memset(&s, 0, sizeof s);
    s.version = 1;
    s.dim[0] = 3;
    s.dim[1] = nx;
    s.dim[2] = ny;
    s.dim[3] = nz;
    for (int i = 4; i < 8; i++) s.dim[i] = 1;
    s.datatype = datatype;
    for (int i = 0; i < 8; i++) s.pixdim[i] = 1.0;
    s.xyzt_units = 2;   /* mm */
    return s;
}

static int host_big_endian(void) {
    const uint16_t one = 1;
    unsigned char first;
    memcpy(&first, &one, 1);
    return first == 0;
}

static const char *nii_path(const char *name) {
    static char path[512];
    if (!nii_dir[0]) {
        snprintf(nii_dir, sizeof nii_dir, "%s/pvio-nifti-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        assert_non_null(mkdtemp(nii_dir));
    }
    snprintf(path, sizeof path, "%s/%s", nii_dir, name);
    return path;
}

/* Writes bytes[0..n) to name, gzip-compressed when gz; returns the path. */
static const char *write_bytes(const char *name, const void *bytes, size_t n, int gz) {
    const char *path = nii_path(name);
    if (gz) {
        gzFile f = gzopen(path, "wb");
        assert_non_null(f);
        if (n) assert_int_equal(gzwrite(f, bytes, (unsigned)n), (int)n);
        assert_int_equal(gzclose(f), Z_OK);
    } else {
        FILE *f = fopen(path, "wb");
        assert_non_null(f);
        if (n) assert_int_equal(fwrite(bytes, 1, n, f), n);
        fclose(f);
    }
    return path;
}

/* A one-file dataset: header, zero bytes up to vox_offset, then `n` data bytes. */
static const char *write_nii(const char *name, const nii_spec *s, const void *data, size_t n, int gz) {
    unsigned char head[548];
    size_t hs = make_header(s, head);
    size_t off = s->vox_offset > 0 ? (size_t)s->vox_offset : hs + 4;
    unsigned char *buf = (unsigned char *)calloc(1, off + n + 1);
    assert_non_null(buf);
    memcpy(buf, head, hs < off ? hs : off);
    if (n) memcpy(buf + off, data, n);
    const char *path = write_bytes(name, buf, off + n, gz);
    free(buf);
    return path;
}

static void remove_file(const char *name) { unlink(nii_path(name)); }

/* Removes the (emptied) private folder; the next file makes a new one. */
static void remove_dir(void) {
    if (nii_dir[0]) rmdir(nii_dir);
    nii_dir[0] = '\0';
}

/* Every refusal leaves the volume zeroed. */
static void assert_zeroed(const picvr_io_volume *v) {
    picvr_io_volume zero;
    memset(&zero, 0, sizeof zero);
    assert_memory_equal(v, &zero, sizeof zero);
}

static void assert_near(double got, double want, double tol, const char *what) {
    if (!(fabs(got - want) <= tol)) fail_msg("%s: %.9g, expected %.9g (tolerance %g)", what, got, want, tol);
}

static void assert_geometry(const picvr_io_volume *v, const double spacing[3], const double dir[9],
                            const double origin[3], double tol) {
    for (int i = 0; i < 3; i++) {
        assert_near(v->spacing[i], spacing[i], tol * spacing[i], "spacing");
        assert_near(v->origin[i], origin[i], tol * (1.0 + fabs(origin[i])), "origin");
    }
    for (int i = 0; i < 9; i++) assert_near(v->direction[i], dir[i], tol, "direction");
}

/* ---- reading ---------------------------------------------------------------------------- */

/* Every datatype picvr holds, NIfTI-1 little-endian .nii, values and layout; uint8 with
   scl_slope 2 / scl_inter -1, int16 with 0.5 / 1024 (value_scale and value_offset are the
   header's float32 numbers exactly); float32 as .nii.gz; slope 0 and NaN mean none. */
void test_nifti_reads_types_and_scaling(void **state) {
    (void)state;
    char err[512] = "";
    picvr_io_volume v;
    const uint8_t u8[12] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 255};
    nii_spec s = spec3(3, 2, 2, 2);
    s.scl_slope = 2.0;
    s.scl_inter = -1.0;
    const char *p = write_nii("u8.nii", &s, u8, sizeof u8, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.dims[0], 3);
    assert_int_equal(v.dims[1], 2);
    assert_int_equal(v.dims[2], 2);
    assert_int_equal(v.type, PICVR_VOXEL_UINT8);
    assert_int_equal(v.size, sizeof u8);
    assert_memory_equal(v.data, u8, sizeof u8);
    assert_true(v.value_scale == 2.0 && v.value_offset == -1.0);
    assert_string_equal(v.modality, "");
    assert_int_equal(v.patient_frame, 1);
    assert_non_null(strstr(v.warning, "no qform or sform"));
    picvr_io_free(&v);
    /* picvr_io_load takes a .nii to this reader */
    assert_int_equal(picvr_io_load(p, NULL, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.type, PICVR_VOXEL_UINT8);
    assert_memory_equal(v.data, u8, sizeof u8);
    assert_true(v.value_scale == 2.0);
    picvr_io_free(&v);

    const int16_t i16[8] = {-32768, -300, -1, 0, 1, 2, 1000, 32767};
    s = spec3(2, 2, 2, 4);
    s.scl_slope = 0.5;
    s.scl_inter = 1024.0;
    s.big_endian = host_big_endian();   /* the data are written in the host's order */
    p = write_nii("i16.nii", &s, i16, sizeof i16, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.type, PICVR_VOXEL_INT16);
    assert_memory_equal(v.data, i16, sizeof i16);
    assert_true(v.value_scale == 0.5 && v.value_offset == 1024.0);
    picvr_io_free(&v);

    float f32[24];
    for (int i = 0; i < 24; i++) f32[i] = (float)(i * 0.25 - 2.0);
    f32[5] = NAN;   /* kept as it is */
    s = spec3(4, 3, 2, 16);
    s.big_endian = host_big_endian();
    s.scl_slope = 0.0;   /* none */
    s.scl_inter = 7.0;
    p = write_nii("f32.nii.gz", &s, f32, sizeof f32, 1);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.type, PICVR_VOXEL_FLOAT32);
    assert_memory_equal(v.data, f32, sizeof f32);
    assert_true(v.value_scale == 1.0 && v.value_offset == 0.0);
    picvr_io_free(&v);

    /* the other types, and a NaN slope (nibabel's "no scaling") */
    const struct { int dt; picvr_voxel_type t; size_t size; } types[] = {
        {256, PICVR_VOXEL_INT8, 1}, {512, PICVR_VOXEL_UINT16, 2}, {8, PICVR_VOXEL_INT32, 4}, {64, PICVR_VOXEL_FLOAT64, 8}};
    unsigned char bytes[8 * 8];
    for (size_t i = 0; i < sizeof bytes; i++) bytes[i] = (unsigned char)(i * 37 + 11);
    for (size_t k = 0; k < sizeof types / sizeof types[0]; k++) {
        s = spec3(2, 2, 2, types[k].dt);
        s.big_endian = host_big_endian();
        s.scl_slope = NAN;
        s.scl_inter = 3.0;
        p = write_nii("t.nii", &s, bytes, 8 * types[k].size, 0);
        assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
        assert_int_equal(v.type, types[k].t);
        assert_int_equal(v.size, 8 * types[k].size);
        assert_memory_equal(v.data, bytes, 8 * types[k].size);
        assert_true(v.value_scale == 1.0 && v.value_offset == 0.0);
        picvr_io_free(&v);
    }
    const char *names[] = {"u8.nii", "i16.nii", "f32.nii.gz", "t.nii"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) remove_file(names[i]);
    remove_dir();
}

/* A rotation, anisotropic voxels and an origin in the sform, computed by hand:
   R = Rz(30 deg) Rx(90 deg) has columns (c, s, 0), (0, 0, 1), (s, -c, 0), c = cos 30,
   s = sin 30; voxel sizes 0.5, 2, 3; translation (10, -20, 30) mm (RAS).  In LPS the
   x and y components change sign: axes (-c, -s, 0), (0, 0, 1), (-s, c, 0), origin
   (-10, 20, 30).  Tolerance 1e-6 relative (the sform is float32 in NIfTI-1).  The same
   in metres and micrometres (xyzt_units 1, 3) gives mm; a pixdim that disagrees with the
   sform is reported in the warning and the sform kept; the sform wins over a qform. */
void test_nifti_sform_geometry(void **state) {
    (void)state;
    const double c = sqrt(3.0) / 2.0, sn = 0.5;
    const double cols[3][3] = {{c, sn, 0}, {0, 0, 1}, {sn, -c, 0}}, sp[3] = {0.5, 2.0, 3.0}, t[3] = {10, -20, 30};
    const double want_dir[9] = {-c, -sn, 0, 0, 0, 1, -sn, c, 0}, want_origin[3] = {-10, 20, 30};
    const uint8_t data[24] = {1};
    char err[512] = "";
    picvr_io_volume v;
    for (int units = 0; units < 3; units++) {
        const double scale = units == 0 ? 1.0 : units == 1 ? 1e-3 : 1e3;   /* file unit per mm */
        nii_spec s = spec3(2, 3, 4, 2);
        s.xyzt_units = units == 0 ? 2 : units == 1 ? 1 : 3;
        s.sform_code = 1;
        s.qform_code = 1;   /* ignored: the sform comes first */
        s.quatern[0] = 1.0;
        for (int a = 0; a < 3; a++) {
            s.pixdim[a + 1] = sp[a] * scale;
            for (int r = 0; r < 3; r++) s.srow[r][a] = cols[a][r] * sp[a] * scale;
            s.srow[a][3] = t[a] * scale;
        }
        const char *p = write_nii("sform.nii", &s, data, sizeof data, 0);
        assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
        assert_geometry(&v, sp, want_dir, want_origin, 1e-6);
        assert_int_equal(v.patient_frame, 1);
        assert_string_equal(v.warning, "");
        picvr_io_free(&v);
    }
    /* NIfTI-2 (double precision): same geometry, tolerance float rounding (1e-7) */
    nii_spec s = spec3(2, 3, 4, 2);
    s.version = 2;
    s.sform_code = 4;
    for (int a = 0; a < 3; a++) {
        s.pixdim[a + 1] = sp[a];
        for (int r = 0; r < 3; r++) s.srow[r][a] = cols[a][r] * sp[a];
        s.srow[a][3] = t[a];
    }
    const char *p = write_nii("sform2.nii", &s, data, sizeof data, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_geometry(&v, sp, want_dir, want_origin, 1e-7);
    picvr_io_free(&v);
    /* pixdim 1, 1, 1 against sform sizes 0.5, 2, 3: the sform's, said in the warning */
    s.pixdim[1] = s.pixdim[2] = s.pixdim[3] = 1.0;
    p = write_nii("sform2.nii", &s, data, sizeof data, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_geometry(&v, sp, want_dir, want_origin, 1e-7);
    assert_non_null(strstr(v.warning, "pixdim"));
    picvr_io_free(&v);
    remove_file("sform.nii");
    remove_file("sform2.nii");
    remove_dir();
}

/* Rodrigues' formula R = cos(t) I + sin(t) [u]x + (1 - cos(t)) u u^T: the rotation the
   quaternion (cos(t/2), u sin(t/2)) stands for, computed without the quaternion formula
   niftilib uses. */
static void rotation(const double u_in[3], double angle, double R[3][3]) {
    double n = sqrt(u_in[0] * u_in[0] + u_in[1] * u_in[1] + u_in[2] * u_in[2]);
    double u[3] = {u_in[0] / n, u_in[1] / n, u_in[2] / n}, co = cos(angle), si = sin(angle);
    double K[3][3] = {{0, -u[2], u[1]}, {u[2], 0, -u[0]}, {-u[1], u[0], 0}};
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 3; k++) R[r][k] = (r == k ? co : 0.0) + si * K[r][k] + (1.0 - co) * u[r] * u[k];
}

/* qform only (sform_code 0, its rows garbage): the rotation by 50 degrees about
   (1, -2, 0.5) with qfac -1 (pixdim[0]), voxel sizes 0.8, 0.9, 1.5, offset (-5, 7, 11):
   M = R diag(0.8, 0.9, -1.5), then LPS.  Tolerance 1e-6 (float32 quaternion).  Then no
   qform and no sform: the pixdim-scaled identity, which is diag(-1, -1, 1) in LPS. */
void test_nifti_qform_and_identity_geometry(void **state) {
    (void)state;
    const double axis[3] = {1.0, -2.0, 0.5}, angle = 50.0 * M_PI / 180.0, sp[3] = {0.8, 0.9, 1.5};
    const double qoff[3] = {-5, 7, 11};
    double R[3][3];
    rotation(axis, angle, R);
    double n = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    nii_spec s = spec3(3, 2, 2, 2);
    s.qform_code = 1;
    s.sform_code = 0;
    s.pixdim[0] = -1.0;
    for (int i = 0; i < 3; i++) {
        s.quatern[i] = axis[i] / n * sin(angle / 2.0);
        s.qoffset[i] = qoff[i];
        s.pixdim[i + 1] = sp[i];
        for (int c = 0; c < 4; c++) s.srow[i][c] = 1e30;   /* not used */
    }
    double want_dir[9], want_origin[3] = {-qoff[0], -qoff[1], qoff[2]};
    for (int a = 0; a < 3; a++)
        for (int c = 0; c < 3; c++) want_dir[3 * a + c] = (c < 2 ? -1.0 : 1.0) * (a == 2 ? -1.0 : 1.0) * R[c][a];
    const uint8_t data[12] = {0};
    char err[512] = "";
    picvr_io_volume v;
    const char *p = write_nii("q.nii", &s, data, sizeof data, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_geometry(&v, sp, want_dir, want_origin, 1e-6);
    assert_string_equal(v.warning, "");
    picvr_io_free(&v);
    /* the same in NIfTI-2, big-endian */
    s.version = 2;
    s.big_endian = 1;
    p = write_nii("q2.nii", &s, data, sizeof data, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_geometry(&v, sp, want_dir, want_origin, 1e-7);
    picvr_io_free(&v);

    nii_spec id = spec3(3, 2, 2, 2);
    id.pixdim[1] = 0.25;
    id.pixdim[2] = 4.0;
    id.pixdim[3] = 1.5;
    p = write_nii("id.nii", &id, data, sizeof data, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    const double id_sp[3] = {0.25, 4.0, 1.5}, id_dir[9] = {-1, 0, 0, 0, -1, 0, 0, 0, 1}, zero[3] = {0, 0, 0};
    assert_geometry(&v, id_sp, id_dir, zero, 0.0);
    assert_int_equal(v.patient_frame, 1);
    assert_non_null(strstr(v.warning, "no qform or sform"));
    picvr_io_free(&v);
    remove_file("q.nii");
    remove_file("q2.nii");
    remove_file("id.nii");
    remove_dir();
}

/* NIfTI-2 little-endian float64 with a double scl_slope (0.1 exactly as a double), a 4D
   file (the first of 3 volumes kept, said in the warning; plain and gzip), and
   big-endian files (NIfTI-1 int16 and float32, NIfTI-2 uint16), converted to host order. */
void test_nifti_nifti2_4d_and_big_endian(void **state) {
    (void)state;
    char err[512] = "";
    picvr_io_volume v;
    double f64[6] = {-1.5, 0.0, 1e300, -2.25, 3.0, 1e-300};
    nii_spec s = spec3(3, 1, 2, 64);
    s.version = 2;
    s.big_endian = host_big_endian();
    s.scl_slope = 0.1;
    s.scl_inter = -1e10;
    const char *p = write_nii("n2.nii", &s, f64, sizeof f64, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_int_equal(v.type, PICVR_VOXEL_FLOAT64);
    assert_memory_equal(v.data, f64, sizeof f64);
    assert_true(v.value_scale == 0.1 && v.value_offset == -1e10);
    picvr_io_free(&v);

    uint8_t t4[2 * 2 * 2 * 3];
    for (int i = 0; i < 24; i++) t4[i] = (uint8_t)(100 + i);
    s = spec3(2, 2, 2, 2);
    s.dim[0] = 4;
    s.dim[4] = 3;
    for (int gz = 0; gz < 2; gz++) {
        p = write_nii(gz ? "t4.nii.gz" : "t4.nii", &s, t4, sizeof t4, gz);
        assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
        assert_int_equal(v.size, 8);
        assert_memory_equal(v.data, t4, 8);
        assert_non_null(strstr(v.warning, "4D"));
        assert_non_null(strstr(v.warning, "3 volumes"));
        picvr_io_free(&v);
    }
    /* dim[0] = 5 with dim[4] = dim[5] = 1: one volume, no warning */
    s.dim[0] = 5;
    s.dim[4] = 1;
    p = write_nii("t5.nii", &s, t4, 8, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_null(strstr(v.warning, "4D"));
    picvr_io_free(&v);

    /* big-endian int16 -300, 2, 32767, -32768 written byte by byte */
    const uint8_t be16[8] = {0xfe, 0xd4, 0x00, 0x02, 0x7f, 0xff, 0x80, 0x00};
    const int16_t want16[4] = {-300, 2, 32767, -32768};
    s = spec3(2, 2, 1, 4);
    s.big_endian = 1;
    s.scl_slope = 1.5;
    s.scl_inter = -3.0;
    s.sform_code = 2;
    s.pixdim[1] = 2.0;
    s.srow[0][0] = 2.0;
    s.srow[1][1] = 1.0;
    s.srow[2][2] = 1.0;
    s.srow[0][3] = 5.0;
    p = write_nii("be16.nii", &s, be16, sizeof be16, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, want16, sizeof want16);
    assert_true(v.value_scale == 1.5 && v.value_offset == -3.0);
    assert_true(v.spacing[0] == 2.0f && v.origin[0] == -5.0f && v.direction[0] == -1.0f);
    picvr_io_free(&v);
    /* big-endian float32 1.0 (3f800000), -2.5 (c0200000), gzip */
    const uint8_t bef[8] = {0x3f, 0x80, 0x00, 0x00, 0xc0, 0x20, 0x00, 0x00};
    const float wantf[2] = {1.0f, -2.5f};
    s = spec3(2, 1, 1, 16);
    s.big_endian = 1;
    p = write_nii("bef.nii.gz", &s, bef, sizeof bef, 1);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, wantf, sizeof wantf);
    picvr_io_free(&v);
    /* big-endian NIfTI-2 uint16 513 (0x0201), 65535 */
    const uint8_t beu[4] = {0x02, 0x01, 0xff, 0xff};
    const uint16_t wantu[2] = {513, 65535};
    s = spec3(1, 2, 1, 512);
    s.version = 2;
    s.big_endian = 1;
    p = write_nii("beu.nii", &s, beu, sizeof beu, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, wantu, sizeof wantu);
    picvr_io_free(&v);
    const char *names[] = {"n2.nii", "t4.nii", "t4.nii.gz", "t5.nii", "be16.nii", "bef.nii.gz", "beu.nii"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) remove_file(names[i]);
    remove_dir();
}

/* Header and data in two files: x.hdr (magic "ni1", vox_offset 8: data from byte 8 of
   x.img), X.HDR with X.IMG, x.hdr with x.img.gz, an ANALYZE 7.5 header (no magic: the
   identity, said in the warning), and a NIfTI-2 pair ("ni2"). */
void test_nifti_hdr_img_pairs(void **state) {
    (void)state;
    char err[512] = "";
    picvr_io_volume v;
    const uint8_t img[8 + 6] = {0xee, 0xee, 0xee, 0xee, 0xee, 0xee, 0xee, 0xee, 1, 2, 3, 4, 5, 6};
    unsigned char head[548];
    nii_spec s = spec3(3, 2, 1, 2);
    s.magic = "ni1";
    s.vox_offset = 8;
    size_t hs = make_header(&s, head);
    const char *p;
    write_bytes("pair.img", img, sizeof img, 0);
    p = write_bytes("pair.hdr", head, hs, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, img + 8, 6);
    picvr_io_free(&v);
    write_bytes("UP.IMG", img, sizeof img, 0);
    p = write_bytes("UP.HDR", head, hs, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, img + 8, 6);
    picvr_io_free(&v);
    write_bytes("gzp.img.gz", img, sizeof img, 1);
    p = write_bytes("gzp.hdr", head, hs, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, img + 8, 6);
    picvr_io_free(&v);

    s.magic = "";   /* ANALYZE 7.5 */
    s.vox_offset = 0;
    s.pixdim[1] = 3.0;
    hs = make_header(&s, head);
    put_f32(head + 108, 0.0, 0);   /* vox_offset 0: the data start the .img */
    write_bytes("an.img", img + 8, 6, 0);
    p = write_bytes("an.hdr", head, hs, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, img + 8, 6);
    assert_true(v.spacing[0] == 3.0f && v.direction[0] == -1.0f && v.direction[8] == 1.0f);
    assert_non_null(strstr(v.warning, "ANALYZE"));
    picvr_io_free(&v);

    s = spec3(3, 2, 1, 2);
    s.version = 2;
    s.magic = "ni2";
    s.vox_offset = 8;
    hs = make_header(&s, head);
    write_bytes("n2p.img", img, sizeof img, 0);
    p = write_bytes("n2p.hdr", head, hs, 0);
    assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
    assert_memory_equal(v.data, img + 8, 6);
    picvr_io_free(&v);
    const char *names[] = {"pair.img", "pair.hdr", "UP.IMG", "UP.HDR", "gzp.img.gz", "gzp.hdr",
                           "an.img", "an.hdr", "n2p.img", "n2p.hdr"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) remove_file(names[i]);
    remove_dir();
}

/* ---- refusals -------------------------------------------------------------------------- */

typedef enum { F_PLAIN, F_GZ, F_GZ_CUT, F_GZ_CORRUPT, F_GZ_NO_TRAILER } file_kind;

static void expect_refusal(const char *what, const char *path, picvr_io_status want) {
    char err[512] = "";
    picvr_io_volume v;
    memset(&v, 0x5a, sizeof v);
    picvr_io_status st = picvr_io_load_nifti(path, &v, err, sizeof err);
    print_message("nifti: %-40s -> %s: %s\n", what, picvr_io_status_string(st), err);
    if (st != want) fail_msg("%s: %s, expected %s (%s)", what, picvr_io_status_string(st), picvr_io_status_string(want), err);
    assert_true(err[0] != '\0');
    assert_zeroed(&v);
}

/* A file made from spec with `data_bytes` zero data bytes, written as kind says. */
static const char *bad_file(const nii_spec *s, size_t data_bytes, file_kind kind) {
    unsigned char head[548];
    size_t hs = make_header(s, head);
    /* the data right after the header unless vox_offset is a sensible place for them */
    size_t off = s->vox_offset >= (double)(hs + 4) && s->vox_offset < 4096 ? (size_t)s->vox_offset : hs + 4;
    size_t n = off + data_bytes;
    unsigned char *buf = (unsigned char *)calloc(1, n + 1);
    assert_non_null(buf);
    memcpy(buf, head, hs < n ? hs : n);
    for (size_t i = off; i < n; i++) buf[i] = (unsigned char)(i * 7);
    const char *name = kind == F_PLAIN ? "bad.nii" : "bad.nii.gz";
    const char *path;
    if (kind == F_PLAIN) path = write_bytes(name, buf, n, 0);
    else {
        uLongf cap = compressBound((uLong)n) + 64;
        unsigned char *z = (unsigned char *)malloc(cap);
        z_stream zs;
        memset(&zs, 0, sizeof zs);
        assert_int_equal(deflateInit2(&zs, 6, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY), Z_OK);
        zs.next_in = buf;
        zs.avail_in = (uInt)n;
        zs.next_out = z;
        zs.avail_out = (uInt)cap;
        assert_int_equal(deflate(&zs, Z_FINISH), Z_STREAM_END);
        size_t zn = zs.total_out;
        deflateEnd(&zs);
        if (kind == F_GZ_CUT) zn = zn / 2 + 4;           /* in the middle of the data */
        if (kind == F_GZ_NO_TRAILER) zn -= 8;            /* all data, no CRC and length */
        if (kind == F_GZ_CORRUPT) z[zn - 6] ^= 0x55;     /* a wrong check sum in the trailer */
        path = write_bytes(name, z, zn, 0);
        free(z);
    }
    free(buf);
    return path;
}

/* Every malformed or unsupported file is refused with its status, a message and a
   zeroed volume.  Headers claiming far more data than the file holds (32767^3 float64 in
   NIfTI-1, 65535^3 float64 in NIfTI-2: some 2^48 bytes, more than malloc can give) come
   back TRUNCATED, not OUT_OF_MEMORY, plain or gzip: nothing of the claimed size is
   allocated. */
void test_nifti_refuses_bad_files(void **state) {
    (void)state;
    const nii_spec ok = spec3(4, 4, 2, 2);
    const size_t ok_bytes = 32;
    struct row { const char *what; nii_spec s; size_t bytes; file_kind kind; picvr_io_status want; } rows[64];
    int n = 0;
#define ROW(w, mod, b, k, st)                                   \
    do {                                                        \
        nii_spec s_ = ok;                                       \
        mod;                                                    \
        rows[n].what = (w);                                     \
        rows[n].s = s_;                                         \
        rows[n].bytes = (b);                                    \
        rows[n].kind = (k);                                     \
        rows[n].want = (st);                                    \
        n++;                                                    \
    } while (0)
    ROW("valid (the control)", (void)0, ok_bytes, F_PLAIN, PICVR_IO_OK);
    ROW("truncated data", (void)0, ok_bytes - 1, F_PLAIN, PICVR_IO_ERROR_TRUNCATED);
    ROW("truncated data, gzip", (void)0, ok_bytes - 1, F_GZ, PICVR_IO_ERROR_TRUNCATED);
    ROW("gzip cut in the data", s_.dim[3] = 64, 64 * 16, F_GZ_CUT, PICVR_IO_ERROR_TRUNCATED);
    ROW("gzip without its trailer", (void)0, ok_bytes, F_GZ_NO_TRAILER, PICVR_IO_ERROR_TRUNCATED);
    ROW("gzip with a wrong trailer", (void)0, ok_bytes, F_GZ_CORRUPT, PICVR_IO_ERROR_READ);
    ROW("claims 32767^3 float64", (s_.dim[1] = s_.dim[2] = s_.dim[3] = 32767, s_.datatype = 64), 64, F_PLAIN,
        PICVR_IO_ERROR_TRUNCATED);
    ROW("claims 32767^3 float64, gzip", (s_.dim[1] = s_.dim[2] = s_.dim[3] = 32767, s_.datatype = 64), 4096, F_GZ,
        PICVR_IO_ERROR_TRUNCATED);
    ROW("NIfTI-2 claims 65535^3 float64, gzip",
        (s_.version = 2, s_.dim[1] = s_.dim[2] = s_.dim[3] = 65535, s_.datatype = 64), 4096, F_GZ,
        PICVR_IO_ERROR_TRUNCATED);
    ROW("NIfTI-2 dim 65536", (s_.version = 2, s_.dim[2] = 65536), ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("NIfTI-2 dim 2^31", (s_.version = 2, s_.dim[1] = (int64_t)1 << 31), ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("NIfTI-2 dim 2^62", (s_.version = 2, s_.dim[3] = (int64_t)1 << 62), ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("NIfTI-2 dim[4] 2^60", (s_.version = 2, s_.dim[0] = 4, s_.dim[4] = (int64_t)1 << 60), ok_bytes, F_PLAIN,
        PICVR_IO_ERROR_SIZE_OVERFLOW);
    ROW("dim -1 (65535 as int16)", s_.dim[1] = -1, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("dim 0", s_.dim[2] = 0, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("dim[0] = 2", s_.dim[0] = 2, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("dim[0] = 8", s_.dim[0] = 8, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("dim[0] = 0", s_.dim[0] = 0, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("dim[5] = 3 (vectors)", (s_.dim[0] = 5, s_.dim[5] = 3), ok_bytes * 3, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("dim[4] = 0", (s_.dim[0] = 4, s_.dim[4] = 0), ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_DIMS);
    ROW("datatype uint32", s_.datatype = 768, ok_bytes * 4, F_PLAIN, PICVR_IO_ERROR_BAD_TYPE);
    ROW("datatype int64", s_.datatype = 1024, ok_bytes * 8, F_PLAIN, PICVR_IO_ERROR_BAD_TYPE);
    ROW("datatype rgb24", s_.datatype = 128, ok_bytes * 3, F_PLAIN, PICVR_IO_ERROR_BAD_TYPE);
    ROW("datatype complex64", s_.datatype = 32, ok_bytes * 8, F_PLAIN, PICVR_IO_ERROR_BAD_TYPE);
    ROW("datatype binary", s_.datatype = 1, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_TYPE);
    ROW("datatype 0", s_.datatype = 0, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_TYPE);
    ROW("datatype 12345", s_.datatype = 12345, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_TYPE);
    ROW("pixdim NaN", s_.pixdim[2] = NAN, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("pixdim inf, NIfTI-2", (s_.version = 2, s_.pixdim[3] = INFINITY), ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("pixdim 0 without sform", s_.pixdim[1] = 0.0, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("pixdim -2 with a qform", (s_.qform_code = 1, s_.pixdim[1] = -2.0), ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("qform quaternion NaN", (s_.qform_code = 1, s_.quatern[1] = NAN), ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("sform column of length 0", (s_.sform_code = 1, s_.srow[0][0] = 1, s_.srow[2][2] = 1), ok_bytes, F_PLAIN,
        PICVR_IO_ERROR_BAD_HEADER);
    ROW("sform with NaN", (s_.sform_code = 1, s_.srow[0][0] = s_.srow[1][1] = s_.srow[2][2] = 1, s_.srow[1][3] = NAN),
        ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("sform with parallel axes", (s_.sform_code = 1, s_.srow[0][0] = s_.srow[0][1] = s_.srow[2][2] = 1), ok_bytes,
        F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("NIfTI-2 sform column beyond float", (s_.version = 2, s_.sform_code = 1, s_.srow[0][0] = 1e300,
        s_.srow[1][1] = s_.srow[2][2] = 1), ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("vox_offset NaN", s_.vox_offset = NAN, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("vox_offset 352.5", s_.vox_offset = 352.5, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("vox_offset 100 (in the header)", s_.vox_offset = 100, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("NIfTI-2 vox_offset -16", (s_.version = 2, s_.vox_offset = -16), ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("vox_offset past the end", s_.vox_offset = 1e9, ok_bytes, F_PLAIN, PICVR_IO_ERROR_TRUNCATED);
    ROW("vox_offset past the end, gzip", s_.vox_offset = 1e9, ok_bytes, F_GZ, PICVR_IO_ERROR_TRUNCATED);
    ROW("sizeof_hdr 349", s_.sizeof_hdr = 349, ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("magic n+3 in a 348-byte header", s_.magic = "n+3", ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("540-byte header with magic n+1", (s_.version = 2, s_.magic = "n+1"), ok_bytes, F_PLAIN,
        PICVR_IO_ERROR_BAD_HEADER);
    ROW("no magic (ANALYZE) in a .nii", s_.magic = "", ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
    ROW("two-file magic ni1 in a .nii", s_.magic = "ni1", ok_bytes, F_PLAIN, PICVR_IO_ERROR_BAD_HEADER);
#undef ROW
    for (int i = 0; i < n; i++) {
        const char *p = bad_file(&rows[i].s, rows[i].bytes, rows[i].kind);
        if (rows[i].want == PICVR_IO_OK) {
            char err[512] = "";
            picvr_io_volume v;
            assert_int_equal(picvr_io_load_nifti(p, &v, err, sizeof err), PICVR_IO_OK);
            picvr_io_free(&v);
            continue;
        }
        expect_refusal(rows[i].what, p, rows[i].want);
    }
    remove_file("bad.nii");
    remove_file("bad.nii.gz");

    expect_refusal("empty file", write_bytes("empty.nii", "", 0, 0), PICVR_IO_ERROR_TRUNCATED);
    expect_refusal("empty gzip file", write_bytes("empty.nii.gz", "", 0, 1), PICVR_IO_ERROR_TRUNCATED);
    expect_refusal("text file", write_bytes("text.nii", "hello, this is not a NIfTI file at all\n", 39, 0),
                   PICVR_IO_ERROR_BAD_HEADER);
    expect_refusal("missing file", nii_path("nowhere.nii"), PICVR_IO_ERROR_OPEN);
    expect_refusal("a folder", nii_dir, PICVR_IO_ERROR_OPEN);
    unsigned char head[548];
    size_t hs = make_header(&ok, head);
    expect_refusal("header cut (347 bytes)", write_bytes("cut.nii", head, 347, 0), PICVR_IO_ERROR_TRUNCATED);
    expect_refusal("header cut (347 bytes), gzip", write_bytes("cut.nii.gz", head, 347, 1), PICVR_IO_ERROR_TRUNCATED);
    nii_spec s = ok;
    s.version = 2;
    hs = make_header(&s, head);
    expect_refusal("NIfTI-2 header cut (539 bytes)", write_bytes("cut.nii", head, 539, 0), PICVR_IO_ERROR_TRUNCATED);
    expect_refusal("NIfTI-2 header cut (400 bytes)", write_bytes("cut.nii", head, 400, 0), PICVR_IO_ERROR_TRUNCATED);
    s = ok;
    s.magic = "ni1";
    s.vox_offset = 0;
    hs = make_header(&s, head);
    put_f32(head + 108, 0.0, 0);
    expect_refusal(".hdr without its .img", write_bytes("alone.hdr", head, hs, 0), PICVR_IO_ERROR_OPEN);
    write_bytes("short.img", "\1\2\3", 3, 0);
    expect_refusal(".img too short", write_bytes("short.hdr", head, hs, 0), PICVR_IO_ERROR_TRUNCATED);
    expect_refusal("two-file header named .dat", write_bytes("pair.dat", head, hs, 0), PICVR_IO_ERROR_BAD_HEADER);
    const char *names[] = {"cut.nii", "cut.nii.gz", "empty.nii", "empty.nii.gz", "text.nii", "alone.hdr",
                           "short.img", "short.hdr", "pair.dat"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) remove_file(names[i]);

    char err[64];
    picvr_io_volume v;
    assert_int_equal(picvr_io_load_nifti(NULL, &v, err, sizeof err), PICVR_IO_ERROR_NULL_POINTER);
    assert_zeroed(&v);
    assert_int_equal(picvr_io_load_nifti("x.nii", NULL, err, sizeof err), PICVR_IO_ERROR_NULL_POINTER);
    /* a message cut to a tiny buffer, and no buffer at all */
    char tiny[4];
    assert_int_equal(picvr_io_load_nifti(nii_path("nowhere.nii"), &v, tiny, sizeof tiny), PICVR_IO_ERROR_OPEN);
    assert_true(strlen(tiny) == 3);
    assert_int_equal(picvr_io_load_nifti(nii_path("nowhere.nii"), &v, NULL, 0), PICVR_IO_ERROR_OPEN);
    remove_dir();
}

void test_nifti_is_nifti(void **state) {
    (void)state;
    assert_true(picvr_io_is_nifti("a.nii"));
    assert_true(picvr_io_is_nifti("dir/a.NII"));
    assert_true(picvr_io_is_nifti("a.nii.gz"));
    assert_true(picvr_io_is_nifti("a.Nii.Gz"));
    assert_true(picvr_io_is_nifti("a.hdr"));
    assert_false(picvr_io_is_nifti("a.img"));
    assert_false(picvr_io_is_nifti("a.nii.bz2"));
    assert_false(picvr_io_is_nifti("a.nrrd"));
    assert_false(picvr_io_is_nifti("nii"));
    assert_false(picvr_io_is_nifti(""));
    assert_false(picvr_io_is_nifti(NULL));
}

/* ---- nibabel's test files ---------------------------------------------------------------- */

#define NIBABEL_DATA "/usr/lib/python3/dist-packages/nibabel/tests/data/"

/* Three real files (Debian python3-nibabel), skipped when absent.  Expected values come
   from nibabel 5.0: img.shape, img.get_sform() (column norms = spacing, normalized
   columns = axes, last column = origin, then x and y negated into LPS), and the stored
   (unscaled) values np.asanyarray(img.dataobj)[..., 0] at a few voxels and their sum.
   Tolerance 1e-6 relative (the sforms are float32). */
void test_nifti_nibabel_files(void **state) {
    (void)state;
    static const struct {
        const char *file;
        uint32_t dims[3];
        const char *warning;   /* a piece the warning must hold, or "" for none */
        double spacing[3], dir[9], origin[3];
        struct { size_t index; int16_t value; } voxels[4];
        long long sum;
    } files[] = {
        {"anatomical.nii", {33, 41, 25}, "", {2.0, 2.0, 2.0}, {1, 0, 0, 0, -1, 0, 0, 0, 1}, {-32.0, 40.0, -16.0},
         {{0, 10712}, {16912, 11881}, {33824, 2971}, {7106, 11825}}, 284166082LL},
        {"example4d.nii.gz", {128, 96, 24}, "first of 2 volumes", {2.0, 2.0000000529526707, 2.1999991881052705},
         {1.0, 3.357357826796873e-19, 4.127740444480465e-18, -3.3573577379063435e-19, -0.9868557191872288,
          0.1616038041243386, -4.1277399374418254e-18, 0.16160380301852809, 0.986855719368312},
         {-117.8551025390625, 35.72294235229492, -7.248798370361328},
         {{0, 0}, {153664, 265}, {294911, 0}, {52266, 452}}, 50994397LL},
        {"example_nifti2.nii.gz", {32, 20, 12}, "first of 2 volumes", {2.0, 2.0000000529526707, 2.1999991881052705},
         {1.0, 3.357357826796873e-19, 4.127740444480465e-18, -3.3573577379063435e-19, -0.9868557191872288,
          0.1616038041243386, -4.1277399374418254e-18, 0.16160380301852809, 0.986855719368312},
         {-117.8551025390625, 35.72294235229492, -7.248798370361328},
         {{0, 424}, {4176, 265}, {7679, 484}, {1450, 419}}, 3461748LL},
    };
    int found = 0, nfiles = (int)(sizeof files / sizeof files[0]);
    for (int f = 0; f < nfiles; f++) {
        char path[512];
        snprintf(path, sizeof path, "%s%s", NIBABEL_DATA, files[f].file);
        found += access(path, R_OK) == 0;
    }
    if (!found) {   /* none: the whole test is skipped (counted by cmocka) */
        print_message("    no file of python3-nibabel in %s: skipped\n", NIBABEL_DATA);
        skip();
    }
    for (int f = 0; f < nfiles; f++) {
        char path[512];
        snprintf(path, sizeof path, "%s%s", NIBABEL_DATA, files[f].file);
        if (access(path, R_OK) != 0) {
            char what[600];
            snprintf(what, sizeof what, "%s absent (apt-get install python3-nibabel)", path);
            tu_partial_skip(what);
            continue;
        }
        char err[512] = "";
        picvr_io_volume v;
        picvr_io_status st = picvr_io_load_nifti(path, &v, err, sizeof err);
        if (st != PICVR_IO_OK) fail_msg("%s: %s: %s", files[f].file, picvr_io_status_string(st), err);
        assert_memory_equal(v.dims, files[f].dims, sizeof v.dims);
        assert_int_equal(v.type, PICVR_VOXEL_INT16);
        assert_true(v.value_scale == 1.0 && v.value_offset == 0.0);
        assert_geometry(&v, files[f].spacing, files[f].dir, files[f].origin, 1e-6);
        if (files[f].warning[0]) assert_non_null(strstr(v.warning, files[f].warning));
        else assert_string_equal(v.warning, "");
        const int16_t *d = (const int16_t *)v.data;
        for (int k = 0; k < 4; k++) assert_int_equal(d[files[f].voxels[k].index], files[f].voxels[k].value);
        long long sum = 0;
        for (size_t i = 0; i < v.size / 2; i++) sum += d[i];
        assert_int_equal(sum, files[f].sum);
        picvr_io_free(&v);
    }
}
