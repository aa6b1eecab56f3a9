/* nifti.c - the NIfTI-1 / NIfTI-2 reader of picvr_io.h (picvr_io_load_nifti).
 *
 * Written to survive hostile files (it is fuzzed: tests/fuzz/fuzz_nifti.c), in three steps:
 *   1. The header (348 bytes for NIfTI-1 and ANALYZE 7.5, 540 for NIfTI-2) is read here,
 *      through zlib (plain and gzip files alike), decoded field by field at the offsets of
 *      the specifications in the file's byte order, and checked: magic, dim[0] 3..7,
 *      dims 1..PICVR_IO_MAX_DIM, only a time axis beyond the third, a datatype picvr holds,
 *      finite voxel sizes, a whole vox_offset past the header, every size product checked.
 *   2. niftilib (nifti2_io: nifti_convert_n1hdr2nim / nifti_convert_n2hdr2nim) turns the
 *      checked header into its nifti_image: byte swapping, the qform quaternion's matrix,
 *      the sform, the units code.  Only after step 1, because niftilib trusts the header:
 *      it indexes dim[1..dim[0]] without a bound, converts vox_offset with an unchecked
 *      cast and prints on stderr (whatever its debug level) for some errors that step 1
 *      rules out.  Given no file name, it opens no file.
 *   3. The voxels of the first 3D volume are read here, not by nifti_image_read /
 *      nifti_image_load: those resolve names by trying other files (x.nii missing: x.hdr),
 *      read header extensions into buffers sized by the header, and allocate the whole
 *      claimed image before reading it, which a lying .nii.gz would turn into gigabytes.
 *      Here a plain file's size is checked before any allocation, and a compressed file's
 *      buffer grows only with the data that actually decompress.  niftilib swaps the
 *      bytes (nifti_swap_Nbytes) when the file's order is not the host's.
 * niftilib's global debug level is left as the application set it: at its default (1)
 * the calls made here print nothing.  The ASCII variant (.nia) is not read.
 *
 * Geometry: the voxel-to-world matrix M is the sform when sform_code > 0, else the qform
 * when qform_code > 0, else diag(pixdim[1..3]) (NIfTI-1's "method 1", also for ANALYZE
 * 7.5).  spacing[a] = |column a|, axis a = column a / |column a|, origin = the translation
 * (the centre of voxel (0,0,0)); metres and micrometres (xyzt_units) become mm; RAS becomes
 * LPS by negating every x and y component.  Non-finite values, a zero column and (nearly)
 * parallel axes are refused; a pixdim that disagrees with the matrix, a shear, a dropped
 * time axis are said in volume->warning. */
#include "picvr_io.h"
#include "io/internal.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <zlib.h>

#include <nifti2_io.h>

#define set_error picvr_io_set_error

#define NII1_HEADER 348
#define NII2_HEADER 540
/* First buffer size when reading compressed data; doubled as data arrives. */
#define FIRST_READ_BYTES ((size_t)1 << 20)
/* Largest single gzread() request: its length is an unsigned int, its result an int. */
#define READ_CHUNK ((size_t)1 << 30)
/* Relative difference between the matrix's voxel size and pixdim that is reported. */
#define SPACING_TOLERANCE 1e-3
/* Smallest |determinant| of the three unit axes: below it the axes are (nearly) parallel. */
#define MIN_AXES_DETERMINANT 1e-6
/* Largest |dot product| of two unit axes before a sheared matrix is reported. */
#define SHEAR_TOLERANCE 1e-3

/* The header fields picvr reads, in host order, from either version. */
typedef struct nii_header {
    int version;                /* 0 ANALYZE 7.5, 1 NIfTI-1, 2 NIfTI-2 */
    int swapped;                /* the file's byte order is not the host's */
    int onefile;                /* magic n+1 / n+2: the voxels follow in the same file */
    size_t header_bytes;        /* 348 or 540 */
    int64_t dim[8];
    int datatype;
    double pixdim[8];
    double vox_offset;          /* a float in NIfTI-1, an int64 in NIfTI-2 */
    double scl_slope, scl_inter;
    int qform_code, sform_code; /* 0 for ANALYZE */
    double quatern[3], qoffset[3];
} nii_header;

/* ---- reading numbers at the specifications' offsets ------------------------------ */

static int host_is_little_endian(void)
{
    const uint16_t one = 1;
    unsigned char first;
    memcpy(&first, &one, 1);
    return first == 1;
}

/* The n-byte unsigned number at p, in the host's byte order (swapped 0) or the other. */
static uint64_t get_uint(const unsigned char *p, int n, int swapped)
{
    int file_little = host_is_little_endian() != swapped;
    uint64_t v = 0;
    for (int i = 0; i < n; i++) {
        unsigned b = file_little ? p[n - 1 - i] : p[i];
        v = (v << 8) | b;
    }
    return v;
}

static int64_t get_i16(const unsigned char *p, int sw) { return (int16_t)(uint16_t)get_uint(p, 2, sw); }
static int64_t get_i32(const unsigned char *p, int sw) { return (int32_t)(uint32_t)get_uint(p, 4, sw); }
static int64_t get_i64(const unsigned char *p, int sw) { return (int64_t)get_uint(p, 8, sw); }

static double get_f32(const unsigned char *p, int sw)
{
    uint32_t u = (uint32_t)get_uint(p, 4, sw);
    float f;
    memcpy(&f, &u, 4);
    return f;
}

static double get_f64(const unsigned char *p, int sw)
{
    uint64_t u = get_uint(p, 8, sw);
    double d;
    memcpy(&d, &u, 8);
    return d;
}

/* Decodes raw[0..header_bytes) (the version and order already known). */
static void decode_header(const unsigned char *raw, nii_header *h)
{
    int sw = h->swapped;
    if (h->header_bytes == NII1_HEADER) {
        for (int i = 0; i < 8; i++) {
            h->dim[i] = get_i16(raw + 40 + 2 * i, sw);
            h->pixdim[i] = get_f32(raw + 76 + 4 * i, sw);
        }
        h->datatype = (int)get_i16(raw + 70, sw);
        h->vox_offset = get_f32(raw + 108, sw);
        if (h->version == 0) return;    /* ANALYZE 7.5: the rest is not NIfTI */
        h->scl_slope = get_f32(raw + 112, sw);
        h->scl_inter = get_f32(raw + 116, sw);
        h->qform_code = (int)get_i16(raw + 252, sw);
        h->sform_code = (int)get_i16(raw + 254, sw);
        for (int i = 0; i < 3; i++) {
            h->quatern[i] = get_f32(raw + 256 + 4 * i, sw);
            h->qoffset[i] = get_f32(raw + 268 + 4 * i, sw);
        }
    } else {
        for (int i = 0; i < 8; i++) {
            h->dim[i] = get_i64(raw + 16 + 8 * i, sw);
            h->pixdim[i] = get_f64(raw + 104 + 8 * i, sw);
        }
        h->datatype = (int)get_i16(raw + 12, sw);
        h->vox_offset = (double)get_i64(raw + 168, sw);
        h->scl_slope = get_f64(raw + 176, sw);
        h->scl_inter = get_f64(raw + 184, sw);
        h->qform_code = (int)get_i32(raw + 344, sw);
        h->sform_code = (int)get_i32(raw + 348, sw);
        for (int i = 0; i < 3; i++) {
            h->quatern[i] = get_f64(raw + 352 + 8 * i, sw);
            h->qoffset[i] = get_f64(raw + 376 + 8 * i, sw);
        }
    }
}

/* ---- files -------------------------------------------------------------------------- */

#define gz_message picvr_io_gz_message

/* Opens a regular file for reading through zlib (plain or gzip); *size: its size on disk. */
static picvr_io_status open_file(const char *path, gzFile *out, long long *size, char *err, size_t err_size)
{
    struct stat st;
    picvr_io_status status = picvr_io_gzopen(path, 0, out, &st, err, err_size);
    if (status == PICVR_IO_OK) *size = (long long)st.st_size;
    return status;
}

static picvr_io_status read_some(gzFile gz, const char *path, void *buf, size_t n, size_t *got,
                                 char *err, size_t err_size)
{
    size_t have = 0;
    while (have < n) {
        size_t want = n - have < READ_CHUNK ? n - have : READ_CHUNK;
        int r = gzread(gz, (unsigned char *)buf + have, (unsigned)want);
        if (r < 0) {
            int errnum;
            set_error(err, err_size, "%s: read error: %s", path, gz_message(gz, path, &errnum));
            return PICVR_IO_ERROR_READ;
        }
        if (r == 0) break;
        have += (size_t)r;
    }
    *got = have;
    return PICVR_IO_OK;
}

/* Reads `expected` bytes into a malloc'd buffer.  known_available: the plain file's
   bytes from here on were checked, so the buffer is allocated at once; otherwise
   (compressed) it starts small and doubles as data arrives, so a header that lies about
   the size costs no more memory than the data actually in the file. */
static picvr_io_status read_data(gzFile gz, const char *path, size_t expected, int known_available,
                                 unsigned char **out, char *err, size_t err_size)
{
    size_t cap = known_available || expected < FIRST_READ_BYTES ? expected : FIRST_READ_BYTES;
    unsigned char *buf = malloc(cap ? cap : 1);
    size_t have = 0;
    if (!buf) goto out_of_memory;
    for (;;) {
        size_t got = 0;
        picvr_io_status st = read_some(gz, path, buf + have, cap - have, &got, err, err_size);
        if (st != PICVR_IO_OK) {
            free(buf);
            return st;
        }
        have += got;
        if (have < cap || cap == expected) break;   /* the end of the data, or all of it */
        size_t next = cap > expected / 2 ? expected : cap * 2;
        unsigned char *grown = realloc(buf, next);
        if (!grown) goto out_of_memory;
        buf = grown;
        cap = next;
    }
    if (have < expected) {
        int errnum = Z_OK;
        const char *msg = gz_message(gz, path, &errnum);
        if (errnum == Z_BUF_ERROR)
            set_error(err, err_size, "%s: truncated gzip data (%s) after %zu of the %zu data bytes",
                      path, msg, have, expected);
        else
            set_error(err, err_size, "%s: truncated: %zu of the %zu data bytes the header gives",
                      path, have, expected);
        free(buf);
        return PICVR_IO_ERROR_TRUNCATED;
    }
    *out = buf;
    return PICVR_IO_OK;

out_of_memory:
    set_error(err, err_size, "%s: out of memory for %zu bytes", path, expected);
    free(buf);
    return PICVR_IO_ERROR_OUT_OF_MEMORY;
}

/* When the data ended the stream, a gzip file must end cleanly: reading on verifies its
   check sum and length.  Bytes after the data (later volumes, padding) are not read. */
static picvr_io_status check_stream_end(gzFile gz, const char *path, char *err, size_t err_size)
{
    unsigned char extra;
    int n = gzread(gz, &extra, 1);
    int errnum = Z_OK;
    if (n < 0) {
        set_error(err, err_size, "%s: read error: %s", path, gz_message(gz, path, &errnum));
        return PICVR_IO_ERROR_READ;
    }
    if (n > 0) return PICVR_IO_OK;
    const char *msg = gz_message(gz, path, &errnum);
    if (errnum == Z_BUF_ERROR) {
        set_error(err, err_size, "%s: truncated gzip data (%s); check sum not verified", path, msg);
        return PICVR_IO_ERROR_TRUNCATED;
    }
    if (errnum != Z_OK) {
        set_error(err, err_size, "%s: read error: %s", path, msg);
        return PICVR_IO_ERROR_READ;
    }
    return PICVR_IO_OK;
}

/* The .img beside path, a .hdr or .hdr.gz (same letter case; with or without .gz, the
   header's way first); *alt: the other candidate.  Both malloc'd; NULL when out of memory. */
static char *image_names(const char *path, char **alt)
{
    size_t n = strlen(path);
    int gz = picvr_io_has_suffix(path, ".hdr.gz");
    char *a = malloc(n + 4), *b = malloc(n + 4);
    if (!a || !b) {
        free(a);
        free(b);
        return NULL;
    }
    memcpy(a, path, n + 1);
    char *ext = a + n - (gz ? 6 : 3);   /* "hdr" */
    ext[0] = ext[0] == 'H' ? 'I' : 'i';
    ext[1] = ext[1] == 'D' ? 'M' : 'm';
    ext[2] = ext[2] == 'R' ? 'G' : 'g';
    memcpy(b, a, n + 1);
    if (gz) b[n - 3] = '\0';            /* x.img.gz, else x.img */
    else memcpy(b + n, ext[0] == 'I' ? ".GZ" : ".gz", 4);   /* x.img, else x.img.gz */
    *alt = b;
    return a;
}

/* ---- header checks ------------------------------------------------------------------ */

static int picvr_type_of(int datatype, picvr_voxel_type *type)
{
    switch (datatype) {
    case NIFTI_TYPE_UINT8: *type = PICVR_VOXEL_UINT8; return 1;
    case NIFTI_TYPE_INT8: *type = PICVR_VOXEL_INT8; return 1;
    case NIFTI_TYPE_UINT16: *type = PICVR_VOXEL_UINT16; return 1;
    case NIFTI_TYPE_INT16: *type = PICVR_VOXEL_INT16; return 1;
    case NIFTI_TYPE_INT32: *type = PICVR_VOXEL_INT32; return 1;
    case NIFTI_TYPE_FLOAT32: *type = PICVR_VOXEL_FLOAT32; return 1;
    case NIFTI_TYPE_FLOAT64: *type = PICVR_VOXEL_FLOAT64; return 1;
    default: return 0;
    }
}

static const char *datatype_name(int datatype)
{
    switch (datatype) {
    case NIFTI_TYPE_UINT32: return "uint32";
    case NIFTI_TYPE_INT64: return "int64";
    case NIFTI_TYPE_UINT64: return "uint64";
    case NIFTI_TYPE_FLOAT128: return "float128";
    case NIFTI_TYPE_COMPLEX64: return "complex64";
    case NIFTI_TYPE_COMPLEX128: return "complex128";
    case NIFTI_TYPE_COMPLEX256: return "complex256";
    case NIFTI_TYPE_RGB24: return "rgb24";
    case NIFTI_TYPE_RGBA32: return "rgba32";
    case DT_BINARY: return "binary (1 bit)";
    case DT_UNKNOWN: return "unknown";
    default: return "not a NIfTI type";
    }
}

/* Reads and checks the header of `path` (the gzFile stays open at byte header_bytes). */
static picvr_io_status read_header(gzFile gz, const char *path, unsigned char raw[NII2_HEADER],
                                   nii_header *h, char *err, size_t err_size)
{
    memset(h, 0, sizeof *h);
    size_t got = 0;
    picvr_io_status st = read_some(gz, path, raw, NII1_HEADER, &got, err, err_size);
    if (st != PICVR_IO_OK) return st;
    if (got < 4) {
        set_error(err, err_size, "%s: truncated: %zu bytes, a NIfTI header has %d (NIfTI-1) or %d (NIfTI-2)",
                  path, got, NII1_HEADER, NII2_HEADER);
        return PICVR_IO_ERROR_TRUNCATED;
    }
    /* sizeof_hdr in the host's byte order, else in the other one: the file's order. */
    int64_t native = (int64_t)get_uint(raw, 4, 0), reversed = (int64_t)get_uint(raw, 4, 1);
    if (native == NII1_HEADER || native == NII2_HEADER) {
        h->header_bytes = (size_t)native;
        h->swapped = 0;
    } else if (reversed == NII1_HEADER || reversed == NII2_HEADER) {
        h->header_bytes = (size_t)reversed;
        h->swapped = 1;
    } else {
        set_error(err, err_size, "%s: not a NIfTI file (header size field %lld; 348 or 540 expected)",
                  path, (long long)(int32_t)(uint32_t)native);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    if (got < NII1_HEADER) {
        set_error(err, err_size, "%s: truncated: %zu bytes, the NIfTI header has %zu", path, got, h->header_bytes);
        return PICVR_IO_ERROR_TRUNCATED;
    }
    if (h->header_bytes == NII2_HEADER) {
        st = read_some(gz, path, raw + NII1_HEADER, NII2_HEADER - NII1_HEADER, &got, err, err_size);
        if (st != PICVR_IO_OK) return st;
        if (got < NII2_HEADER - NII1_HEADER) {
            set_error(err, err_size, "%s: truncated: %zu bytes, the NIfTI-2 header has %d", path,
                      (size_t)NII1_HEADER + got, NII2_HEADER);
            return PICVR_IO_ERROR_TRUNCATED;
        }
    }

    /* The magic: as niftilib's NIFTI_VERSION reads it ("n+1", "ni1", "n+2", "ni2"); a
       348-byte header without one is ANALYZE 7.5. */
    const unsigned char *magic = raw + (h->header_bytes == NII1_HEADER ? 344 : 4);
    int version = magic[0] == 'n' && magic[3] == '\0' && (magic[1] == 'i' || magic[1] == '+') &&
                  magic[2] >= '1' && magic[2] <= '9' ? magic[2] - '0' : 0;
    if (h->header_bytes == NII1_HEADER && version > 1) {
        set_error(err, err_size, "%s: a 348-byte header with the magic of NIfTI-%d", path, version);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    if (h->header_bytes == NII2_HEADER && version != 2) {
        set_error(err, err_size, "%s: a 540-byte header without the NIfTI-2 magic (n+2 or ni2)", path);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    h->version = version;
    h->onefile = version > 0 && magic[1] == '+';
    decode_header(raw, h);

    if (h->dim[0] < 3 || h->dim[0] > 7) {
        set_error(err, err_size, "%s: dim[0] = %lld: picvr reads 3D volumes (dim[0] 3..7, a 4D file's first volume)",
                  path, (long long)h->dim[0]);
        return PICVR_IO_ERROR_BAD_DIMS;
    }
    for (int i = 1; i <= 3; i++)
        if (h->dim[i] < 1 || h->dim[i] > (int64_t)PICVR_IO_MAX_DIM) {
            set_error(err, err_size, "%s: dim[%d] = %lld, must be 1..%u", path, i, (long long)h->dim[i],
                      PICVR_IO_MAX_DIM);
            return PICVR_IO_ERROR_BAD_DIMS;
        }
    /* Beyond x, y, z: a time axis (only its first volume is read), nothing else. */
    int64_t nvox = h->dim[1] * h->dim[2] * h->dim[3];   /* < 2^48: no overflow */
    for (int i = 4; i <= h->dim[0]; i++) {
        if (h->dim[i] < 1) {
            set_error(err, err_size, "%s: dim[%d] = %lld, must be at least 1", path, i, (long long)h->dim[i]);
            return PICVR_IO_ERROR_BAD_DIMS;
        }
        if (i > 4 && h->dim[i] != 1) {
            set_error(err, err_size, "%s: dim[%d] = %lld: vector or multi-component data are not read "
                      "(only a time axis, dim[4], beyond x, y, z)", path, i, (long long)h->dim[i]);
            return PICVR_IO_ERROR_BAD_DIMS;
        }
        if (nvox > INT64_MAX / 16 / h->dim[i]) {   /* niftilib multiplies them in an int64 */
            set_error(err, err_size, "%s: %lld time points of %lldx%lldx%lld voxels do not fit in 64 bits", path,
                      (long long)h->dim[i], (long long)h->dim[1], (long long)h->dim[2], (long long)h->dim[3]);
            return PICVR_IO_ERROR_SIZE_OVERFLOW;
        }
        nvox *= h->dim[i];
    }
    picvr_voxel_type type;
    if (!picvr_type_of(h->datatype, &type)) {
        set_error(err, err_size, "%s: NIfTI datatype %d (%s) is not one picvr holds "
                  "(uint8, int8, uint16, int16, int32, float32, float64)", path, h->datatype,
                  datatype_name(h->datatype));
        return PICVR_IO_ERROR_BAD_TYPE;
    }
    for (int i = 1; i <= 3; i++)
        if (!isfinite(h->pixdim[i])) {
            set_error(err, err_size, "%s: pixdim[%d] is not a finite number", path, i);
            return PICVR_IO_ERROR_BAD_HEADER;
        }
    /* NIfTI-1's float offset must also fit niftilib's int conversion. */
    double max_offset = h->header_bytes == NII1_HEADER ? (double)INT_MAX : 9007199254740992.0;
    if (!(h->vox_offset >= 0.0) || h->vox_offset > max_offset || h->vox_offset != floor(h->vox_offset)) {
        set_error(err, err_size, "%s: vox_offset %g is not a byte offset (a whole number, 0..%.0f)", path,
                  h->vox_offset, max_offset);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    /* The specification asks a one-file dataset for 352 (NIfTI-1) or 544 (NIfTI-2) at
       least; an offset inside the header is refused, not guessed (niftilib reads from 348). */
    if (h->onefile && h->vox_offset < (double)h->header_bytes) {
        set_error(err, err_size, "%s: vox_offset %.0f is inside the %zu-byte header", path, h->vox_offset,
                  h->header_bytes);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    return PICVR_IO_OK;
}

/* ---- geometry ----------------------------------------------------------------------- */

static void add_warning(picvr_io_volume *v, const char *fmt, ...) PICVR_IO_PRINTF(2, 3);
static void add_warning(picvr_io_volume *v, const char *fmt, ...)
{
    size_t n = strlen(v->warning);
    if (n + 3 >= sizeof v->warning) return;
    if (n) {
        memcpy(v->warning + n, "; ", 3);
        n += 2;
    }
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(v->warning + n, sizeof v->warning - n, fmt, ap);
    va_end(ap);
}

/* Spacing, direction and origin of volume from the voxel-to-world matrix m (RAS, in the
   file's unit), converted to mm and LPS.  pixdim: the header's voxel sizes (compared). */
static picvr_io_status set_geometry(picvr_io_volume *v, const nii_header *h, const nifti_image *nim,
                                    const char *path, char *err, size_t err_size)
{
    double m[3][4];
    const char *source;
    if (nim->sform_code > 0) {
        source = "sform";
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++) m[r][c] = nim->sto_xyz.m[r][c];
    } else {
        for (int a = 1; a <= 3; a++)
            if (!(h->pixdim[a] > 0.0)) {
                set_error(err, err_size, "%s: pixdim[%d] = %g: voxel sizes must be positive "
                          "(there is no sform to give them)", path, a, h->pixdim[a]);
                return PICVR_IO_ERROR_BAD_HEADER;
            }
        if (nim->qform_code > 0) {
            source = "qform";
            for (int i = 0; i < 3; i++)
                if (!isfinite(h->quatern[i]) || !isfinite(h->qoffset[i])) {
                    set_error(err, err_size, "%s: the qform's quaternion or offset is not finite", path);
                    return PICVR_IO_ERROR_BAD_HEADER;
                }
            double q2 = h->quatern[0] * h->quatern[0] + h->quatern[1] * h->quatern[1] +
                        h->quatern[2] * h->quatern[2];
            if (q2 > 1.0 + 1e-6)
                add_warning(v, "qform quaternion (b,c,d) longer than 1 (%g): normalized", sqrt(q2));
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 4; c++) m[r][c] = nim->qto_xyz.m[r][c];
        } else {   /* ANALYZE 7.5, or NIfTI with neither code set: the scaled identity */
            source = "pixdim";
            memset(m, 0, sizeof m);
            for (int a = 0; a < 3; a++) m[a][a] = h->pixdim[a + 1];
            if (h->version == 0) add_warning(v, "ANALYZE 7.5 header: no orientation, axes taken as RAS");
            else add_warning(v, "no qform or sform: axes taken as RAS");
        }
    }
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            if (!isfinite(m[r][c])) {
                set_error(err, err_size, "%s: the %s has a value that is not finite", path, source);
                return PICVR_IO_ERROR_BAD_HEADER;
            }

    double unit = 1.0;   /* to mm */
    switch (nim->xyz_units) {
    case NIFTI_UNITS_METER: unit = 1000.0; break;
    case NIFTI_UNITS_MICRON: unit = 0.001; break;
    case NIFTI_UNITS_UNKNOWN: case NIFTI_UNITS_MM: break;
    default: add_warning(v, "unknown space unit code %d, taken as mm", nim->xyz_units); break;
    }

    double len[3], axis[3][3];
    for (int a = 0; a < 3; a++) {
        len[a] = sqrt(m[0][a] * m[0][a] + m[1][a] * m[1][a] + m[2][a] * m[2][a]);
        if (!(len[a] > 0.0) || !isfinite(len[a])) {
            set_error(err, err_size, "%s: the %s's axis %d has length %g", path, source, a, len[a]);
            return PICVR_IO_ERROR_BAD_HEADER;
        }
        for (int c = 0; c < 3; c++) axis[a][c] = m[c][a] / len[a];
    }
    double det = axis[0][0] * (axis[1][1] * axis[2][2] - axis[1][2] * axis[2][1]) -
                 axis[0][1] * (axis[1][0] * axis[2][2] - axis[1][2] * axis[2][0]) +
                 axis[0][2] * (axis[1][0] * axis[2][1] - axis[1][1] * axis[2][0]);
    if (!(fabs(det) >= MIN_AXES_DETERMINANT)) {
        set_error(err, err_size, "%s: the %s's axes are (nearly) parallel", path, source);
        return PICVR_IO_ERROR_BAD_HEADER;
    }
    double shear = 0.0;
    for (int a = 0; a < 3; a++)
        for (int b = a + 1; b < 3; b++) {
            double d = fabs(axis[a][0] * axis[b][0] + axis[a][1] * axis[b][1] + axis[a][2] * axis[b][2]);
            if (d > shear) shear = d;
        }
    if (shear > SHEAR_TOLERANCE) add_warning(v, "the %s is sheared (axes not orthogonal), kept as it is", source);
    int differs = 0;
    for (int a = 0; a < 3; a++)
        if (!(fabs(len[a] - h->pixdim[a + 1]) <= SPACING_TOLERANCE * len[a])) differs = 1;
    if (differs)
        add_warning(v, "voxel size %gx%gx%g from the %s, pixdim says %gx%gx%g: the %s's taken", len[0], len[1],
                    len[2], source, h->pixdim[1], h->pixdim[2], h->pixdim[3], source);

    /* RAS (NIfTI) to LPS (picvr_io_volume): negate the x and y components. */
    static const double lps[3] = {-1.0, -1.0, 1.0};
    for (int a = 0; a < 3; a++) {
        v->spacing[a] = (float)(len[a] * unit);
        v->origin[a] = (float)(lps[a] * m[a][3] * unit);
        for (int c = 0; c < 3; c++) v->direction[3 * a + c] = (float)(lps[c] * axis[a][c]);
        if (!(v->spacing[a] > 0.0f) || !isfinite(v->spacing[a]) || !isfinite(v->origin[a])) {
            set_error(err, err_size, "%s: the %s's voxel size or origin is beyond float", path, source);
            return PICVR_IO_ERROR_BAD_HEADER;
        }
    }
    return PICVR_IO_OK;
}

/* ---- the loader ----------------------------------------------------------------------- */

int picvr_io_is_nifti(const char *path)
{
    return picvr_io_has_suffix(path, ".nii") || picvr_io_has_suffix(path, ".nii.gz") ||
           picvr_io_has_suffix(path, ".hdr") || picvr_io_has_suffix(path, ".hdr.gz");
}

picvr_io_status picvr_io_load_nifti(const char *path, picvr_io_volume *volume, char *err, size_t err_size)
{
    if (volume) memset(volume, 0, sizeof *volume);
    if (!path || !volume) {
        set_error(err, err_size, "no file name or output given");
        return PICVR_IO_ERROR_NULL_POINTER;
    }
    gzFile gz = NULL;
    long long file_size = 0;
    picvr_io_status st = open_file(path, &gz, &file_size, err, err_size);
    if (st != PICVR_IO_OK) return st;

    unsigned char raw[NII2_HEADER];
    nii_header h;
    nifti_image *nim = NULL;
    unsigned char *data = NULL;
    char *img = NULL, *img_alt = NULL;
    const char *data_path = path;
    st = read_header(gz, path, raw, &h, err, err_size);
    if (st != PICVR_IO_OK) goto done;

    picvr_voxel_type type = PICVR_VOXEL_UINT8;
    picvr_type_of(h.datatype, &type);
    picvr_io_layout layout = {{(uint32_t)h.dim[1], (uint32_t)h.dim[2], (uint32_t)h.dim[3]}, type};
    size_t bytes = 0;
    if (picvr_io_layout_bytes(&layout, &bytes, NULL, 0) != PICVR_IO_OK) {
        set_error(err, err_size, "%s: a volume of %ux%ux%u %s does not fit in memory", path, layout.dims[0],
                  layout.dims[1], layout.dims[2], picvr_io_type_name(type));
        st = PICVR_IO_ERROR_SIZE_OVERFLOW;
        goto done;
    }

    /* niftilib's image of the checked header (no file name: it opens nothing). */
    if (h.header_bytes == NII1_HEADER) {
        nifti_1_header n1;
        memcpy(&n1, raw, sizeof n1);
        nim = nifti_convert_n1hdr2nim(n1, NULL);
    } else {
        nifti_2_header n2;
        memcpy(&n2, raw, sizeof n2);
        nim = nifti_convert_n2hdr2nim(n2, NULL);
    }
    if (!nim) {
        set_error(err, err_size, "%s: niftilib could not convert the header", path);
        st = PICVR_IO_ERROR_BAD_HEADER;
        goto done;
    }
    if (nim->nx != h.dim[1] || nim->ny != h.dim[2] || nim->nz != h.dim[3] || nim->datatype != h.datatype ||
        (size_t)nim->nbyper != picvr_io_voxel_size(type) ||
        (nim->byteorder != nifti_short_order()) != h.swapped) {
        set_error(err, err_size, "%s: niftilib reads the header differently (dims, type or byte order)", path);
        st = PICVR_IO_ERROR_BAD_HEADER;
        goto done;
    }
    st = set_geometry(volume, &h, nim, path, err, err_size);
    if (st != PICVR_IO_OK) goto done;

    /* Where the voxels are: after the header (n+1, n+2), or in the .img beside the .hdr. */
    double offset = h.vox_offset;
    if (!h.onefile) {
        if (!picvr_io_has_suffix(path, ".hdr") && !picvr_io_has_suffix(path, ".hdr.gz")) {
            set_error(err, err_size, "%s: the header says its voxels are in a separate .img file (magic %s), "
                      "but its name does not end in .hdr", path, h.version ? "ni1/ni2" : "none: ANALYZE 7.5");
            st = PICVR_IO_ERROR_BAD_HEADER;
            goto done;
        }
        img = image_names(path, &img_alt);
        if (!img) {
            set_error(err, err_size, "%s: out of memory", path);
            st = PICVR_IO_ERROR_OUT_OF_MEMORY;
            goto done;
        }
        gzclose(gz);
        gz = NULL;
        struct stat sb;
        if (stat(img, &sb) != 0 && stat(img_alt, &sb) == 0) {
            char *t = img;
            img = img_alt;
            img_alt = t;
        }
        data_path = img;
        st = open_file(data_path, &gz, &file_size, err, err_size);
        if (st != PICVR_IO_OK) {
            if (stat(data_path, &sb) != 0)
                set_error(err, err_size, "%s: its data file %s (or %s) cannot be opened: %s", path, img, img_alt,
                          strerror(errno));
            goto done;
        }
    }
    if (gzdirect(gz)) {   /* plain: the size is known, so check it before any allocation */
        if ((double)file_size < offset || (unsigned long long)file_size - (unsigned long long)offset < bytes) {
            set_error(err, err_size, "%s: truncated: %lld bytes, the header needs %zu data bytes from byte %.0f",
                      data_path, file_size, bytes, offset);
            st = PICVR_IO_ERROR_TRUNCATED;
            goto done;
        }
    }
    if (offset > (double)LONG_MAX || gzseek(gz, (z_off_t)offset, SEEK_SET) < 0) {
        int errnum;
        set_error(err, err_size, "%s: cannot reach the data at byte %.0f: %s", data_path, offset,
                  gz_message(gz, data_path, &errnum));
        st = PICVR_IO_ERROR_TRUNCATED;
        goto done;
    }
    st = read_data(gz, data_path, bytes, gzdirect(gz), &data, err, err_size);
    if (st == PICVR_IO_OK && !gzdirect(gz)) st = check_stream_end(gz, data_path, err, err_size);
    if (st != PICVR_IO_OK) goto done;

    if (h.swapped && nim->swapsize > 1) nifti_swap_Nbytes((int64_t)(bytes / (size_t)nim->nbyper), nim->swapsize, data);
    volume->dims[0] = layout.dims[0];
    volume->dims[1] = layout.dims[1];
    volume->dims[2] = layout.dims[2];
    volume->type = type;
    volume->data = data;
    volume->size = bytes;
    data = NULL;
    /* NIfTI's world is RAS, here LPS; without a qform or sform the axes are RAS by the
       specification's convention (method 1), said in the warning. */
    volume->patient_frame = 1;
    volume->has_origin = 1;
    volume->value_scale = 1.0;
    volume->value_offset = 0.0;
    if (h.version > 0 && isfinite(h.scl_slope) && h.scl_slope != 0.0) {
        volume->value_scale = h.scl_slope;
        if (isfinite(h.scl_inter)) volume->value_offset = h.scl_inter;
        else add_warning(volume, "scl_inter is not finite: 0 taken");
    }
    if (h.dim[0] >= 4 && h.dim[4] > 1)
        add_warning(volume, "4D file: the first of %lld volumes read, the others dropped", (long long)h.dim[4]);

done:
    if (gz) gzclose(gz);
    if (nim) nifti_image_free(nim);
    free(data);
    free(img);
    free(img_alt);
    if (st != PICVR_IO_OK) memset(volume, 0, sizeof *volume);
    return st;
}
