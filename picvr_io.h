/* picvr_io.h - picvr's file readers: volumes from NIfTI-1/2 (.nii, .nii.gz, .hdr/.img),
 * NRRD (.nrrd, .nhdr), DICOM series (a folder of slices), OpenVDB (.vdb) and headerless
 * raw files (.raw, .raw.gz), each with its geometry (spacing, orientation, origin in the
 * patient's LPS frame where the file has one) and its value mapping (rescale to
 * Hounsfield units).  A module of its own (io/, build/libpicvr_io.a): picvr.h's core
 * takes voxels in memory, and an application with its own loader links none of this.
 *
 *     picvr_io_volume v;
 *     char err[512];
 *     if (picvr_io_load("scan.nii.gz", NULL, &v, err, sizeof err) != PICVR_IO_OK) {
 *         fprintf(stderr, "%s\n", err);
 *         return 1;
 *     }
 *     picvr_volume_desc desc;
 *     picvr_io_to_desc(&v, &desc);        // voxels, spacing, orientation and origin
 *     desc.value_min = (float)((-1000 - v.value_offset) / v.value_scale);  // a CT window
 *     desc.value_max = (float)((2000 - v.value_offset) / v.value_scale);   // in HU
 *     picvr_upload_volume(ctx, &desc);    // picvr copies the voxels
 *     picvr_io_free(&v);
 *
 * Raw files' names carry the layout, as in the Open SciVis data sets:
 *     NAME_XxYxZ_TYPE.raw  or  NAME_XxYxZ_TYPE.raw.gz
 * with TYPE one of uint8, uint16, float32, int8, int16, int32, float16, float64 (or
 * u8, u16, f32, i8, i16, i32, f16, f64), e.g.
 * "bonsai_256x256x256_uint8.raw.gz".  Voxels are stored x fastest, multi-byte values
 * little-endian.  zlib reads plain and gzip files alike.
 *
 * Every function validates its input and reports problems as a status plus an
 * optional message; none of them crashes, whatever the file name or contents (each
 * reader is fuzzed: make fuzz).  Only picvr.h's types are used, no Vulkan.  Link:
 * build/libpicvr_io.a with -lnifti2 -lznz (niftilib), -lgdcmMSFF -lgdcmDSED -lgdcmDICT
 * -lgdcmIOD -lgdcmCommon (GDCM), -lopenvdb -ltbb -lImath-3_1 -lblosc (OpenVDB), -lz
 * -lstdc++ (the Makefile's IO_LIBS).
 */
#ifndef PICVR_IO_H
#define PICVR_IO_H

#include <stddef.h>
#include <stdint.h>

#include "picvr.h"

#ifdef __cplusplus
extern "C" {
#endif

#define PICVR_IO_MAX_DIM 65535u   /* largest accepted voxel count along one axis */

typedef enum picvr_io_status {
    PICVR_IO_OK = 0,
    PICVR_IO_ERROR_NULL_POINTER,   /* a required argument was NULL */
    PICVR_IO_ERROR_BAD_NAME,       /* the file name does not match NAME_XxYxZ_TYPE.raw[.gz] */
    PICVR_IO_ERROR_BAD_DIMS,       /* a dimension is outside 1..PICVR_IO_MAX_DIM */
    PICVR_IO_ERROR_BAD_TYPE,       /* unknown voxel type */
    PICVR_IO_ERROR_SIZE_OVERFLOW,  /* the byte size of the volume does not fit in size_t */
    PICVR_IO_ERROR_OPEN,           /* the file cannot be opened (or is not a regular file) */
    PICVR_IO_ERROR_READ,           /* an I/O error or corrupt gzip data */
    PICVR_IO_ERROR_TRUNCATED,      /* fewer bytes than the layout needs */
    PICVR_IO_ERROR_TOO_LONG,       /* more bytes than the layout needs */
    PICVR_IO_ERROR_OUT_OF_MEMORY,
    PICVR_IO_ERROR_BAD_HEADER,     /* a header (NRRD, NIfTI, DICOM, VDB) that is malformed or asks
                                      for what is not read */
    PICVR_IO_ERROR_UNSUPPORTED,    /* this build has no reader for the format (built without it) */
    PICVR_IO_STATUS_COUNT
} picvr_io_status;

/* How the voxels are laid out: enough to know the file's exact byte size. */
typedef struct picvr_io_layout {
    uint32_t dims[3];
    picvr_voxel_type type;
} picvr_io_layout;

/* A loaded volume.  data is malloc'd (free it with picvr_io_free). */
typedef struct picvr_io_volume {
    uint32_t dims[3];
    picvr_voxel_type type;
    float spacing[3];          /* the file's (NRRD, NIfTI and DICOM: mm), else 1,1,1; the
                                  caller may change it */
    void *data;                /* dims[0]*dims[1]*dims[2] voxels, x fastest, host order */
    size_t size;               /* bytes in data */
    float origin[3];           /* world position of voxel 0's centre (NRRD space origin; 0) */
    float direction[9];        /* unit vectors of the x, y, z axes in world space, three
                                  floats each (NRRD space directions; else the identity) */
    /* World space of origin and direction is the patient frame of DICOM: LPS (+x toward the
       patient's left, +y posterior, +z superior), in the file's length unit (mm for medical
       files).  Readers of RAS files (NIfTI, NRRD "right-anterior-superior") negate x and y. */
    double value_scale;        /* physical value = stored value * value_scale + value_offset */
    double value_offset;       /* (NIfTI scl_slope/scl_inter, DICOM rescale to Hounsfield
                                  units); 1 and 0 when the file has none */
    char modality[8];          /* "CT", "MR", ... where the file says (DICOM), else "" */
    int has_origin;            /* 1: origin is the file's (NIfTI, DICOM, OpenVDB, NRRD with a
                                  space origin); 0: the file places nothing (raw), and
                                  picvr_io_to_desc leaves the box centred at the origin */
    int patient_frame;         /* 1: world space is the patient's LPS frame (DICOM, NIfTI,
                                  NRRD in an anatomical space), so views such as anterior
                                  mean something; 0: the file's own axes */
    char warning[256];         /* what the reader noticed and accepted (gantry tilt, uneven
                                  slice spacing, a dropped time axis), else "" */
} picvr_io_volume;

/* A static English name for the status ("PICVR_IO_OK", ...); never NULL. */
const char *picvr_io_status_string(picvr_io_status status);

/* Bytes per voxel of type, or 0 for an unknown type. */
size_t picvr_io_voxel_size(picvr_voxel_type type);

/* The canonical name of type ("uint8", "int16", "float32", ...), or "unknown". */
const char *picvr_io_type_name(picvr_voxel_type type);

/* Parses a type name or its abbreviation ("uint8"/"u8", "int16"/"i16", "float64"/"f64",
   ...; ASCII case-insensitive). */
picvr_io_status picvr_io_parse_type(const char *text, picvr_voxel_type *type);

/* Checks that every dimension is in 1..PICVR_IO_MAX_DIM and the type is known, and
   returns the volume's byte size in *bytes (may be NULL).  err (err_size bytes,
   may be NULL) receives a message on failure. */
picvr_io_status picvr_io_layout_bytes(const picvr_io_layout *layout, size_t *bytes,
                              char *err, size_t err_size);

/* Reads the layout from a path "DIR/NAME_XxYxZ_TYPE.raw[.gz]"; only the last path
   component is looked at.  The result is validated as by picvr_io_layout_bytes(). */
picvr_io_status picvr_io_parse_name(const char *path, picvr_io_layout *layout,
                            char *err, size_t err_size);

/* Loads a volume.  layout NULL: by the file's extension a NRRD, NIfTI, OpenVDB (its
   default grid) or DICOM (a folder or .dcm) file through its reader below, else a raw
   file whose layout is taken from the file name.  The file (after gzip
   decompression, if compressed) must hold exactly the layout's byte count; the gzip
   check sum is verified.  On failure *volume is zeroed and nothing leaks. */
picvr_io_status picvr_io_load(const char *path, const picvr_io_layout *layout, picvr_io_volume *volume,
                      char *err, size_t err_size);

/* Loads a NRRD volume: NAME.nrrd (header and data in one file) or NAME.nhdr (the header
   names its data file), raw or gzip-encoded, 3 dimensions, a type picvr holds; spacing,
   orientation and origin from the header.  picvr_io_load calls it for those two extensions
   (with layout NULL).  Unsupported features (other encodings, line skip, data file
   lists) are refused with a message.  On failure *volume is zeroed and nothing leaks. */
picvr_io_status picvr_io_load_nrrd(const char *path, picvr_io_volume *volume, char *err, size_t err_size);

/* Loads a NIfTI-1 or NIfTI-2 volume (.nii, .nii.gz, or a .hdr/.img pair, either also
   gzip-compressed), the header read and checked here before niftilib converts it: the
   first 3D volume (a 4D file's later volumes are dropped, said in volume->warning);
   spacing, axes and origin from the sform (sform_code > 0), else the qform, else
   diag(pixdim) (the specification's method 1, also ANALYZE 7.5, said in warning):
   spacing = the matrix's column lengths, axes = its unit columns, origin = its
   translation; metres and micrometres (xyzt_units) converted to mm; RAS converted to
   LPS; patient_frame 1; a pixdim differing from the matrix by more than 1e-3 relative is
   said in warning.  scl_slope/scl_inter into value_scale/value_offset (slope 0 or not
   finite: none).  Refused: dim[0] outside 3..7, a dimension beyond the time axis other
   than 1, other datatypes (BAD_TYPE), non-finite pixdim or matrix, a zero-length or
   nearly parallel axis, a vox_offset inside the header, the ASCII .nia form.  Headers
   that lie about their size are refused before any allocation.  On failure *volume is
   zeroed and nothing leaks. */
picvr_io_status picvr_io_load_nifti(const char *path, picvr_io_volume *volume, char *err, size_t err_size);

/* 1 when path ends in .nii, .nii.gz, .hdr or .hdr.gz (ASCII case-insensitive). */
int picvr_io_is_nifti(const char *path);

/* Loads a DICOM series through GDCM.  path: a folder (the series with the most slices in
   it, the others said in volume->warning) or one slice file (the series that file
   belongs to, from its folder).  Each file's structure is checked before GDCM reads it
   (element lengths within their containers, a compressed stream's own header against
   the DICOM header): only proper DICOM files (preamble, DICM, meta group); bare data sets
   and ACR-NEMA files are refused, and so are multi-frame files.  Single-frame grey
   images (MONOCHROME1 values kept as stored, said in warning).  Slices are sorted by
   their position along the slice normal (not by name or InstanceNumber), the slice
   spacing is the median of the position differences (not SliceThickness; a one-slice
   volume takes SliceThickness, else 1); uneven spacing and gantry tilt are accepted and
   said in volume->warning, a tilt giving a z axis that is not orthogonal (see
   picvr_io_to_desc_sheared); rescale slope/intercept give value_scale/value_offset
   (Hounsfield units for CT; slices with different rescales are converted to float32;
   RT Dose's DoseGridScaling is not applied); the modality (CT, MR, ...) is copied;
   patient_frame 1.  Statuses: OPEN for an empty folder, BAD_HEADER for no DICOM image or
   a malformed one, TRUNCATED for a cut-off slice, SIZE_OVERFLOW for a volume over
   PICVR_IO_DICOM_MAX_BYTES (16 GiB; a compile-time setting).  GDCM's trace output is off during the
   call (process-wide flags, restored).  On failure *volume is zeroed and nothing leaks.
   PICVR_IO_ERROR_UNSUPPORTED in a build without GDCM (PICVR_IO_NO_DICOM). */
picvr_io_status picvr_io_load_dicom(const char *path, picvr_io_volume *volume, char *err, size_t err_size);

/* 1 when path is a folder or ends in .dcm (ASCII case-insensitive). */
int picvr_io_is_dicom(const char *path);

/* Loads one scalar grid of an OpenVDB file (.vdb) through OpenVDB, densified over the
   grid's active voxel bounding box into float32: inactive voxels get the background, not
   their stored values; non-finite values become 0 (counted in warning).  grid: the grid's
   name ("name[N]" picks among duplicates), or NULL for "density" if it is a float or
   double grid, else the first float grid, else the first double grid (converted, said in
   warning).  Spacing, orientation and origin from the grid's linear transform (voxel
   centres are at integer index coordinates, so origin is voxel (0,0,0)'s centre);
   patient_frame 0 (the file's own frame).  Every byte OpenVDB will read is checked first
   (OpenVDB trusts the counts and lengths in a file).  Refused: files without grid
   offsets (written by io::Stream) and format versions outside 222..224 (BAD_HEADER),
   non-linear transforms, an empty grid or one spanning more than PICVR_IO_MAX_DIM voxels
   (BAD_DIMS), more than 4 GiB (SIZE_OVERFLOW), a cut-off file (TRUNCATED).  Side effect:
   openvdb::initialize(), and the "__delayedload" metadata type is unregistered process-wide
   (its parser trusts counts; it serves memory-mapped loading only, not used here).  On
   failure *volume is zeroed and nothing leaks.  PICVR_IO_ERROR_UNSUPPORTED in a build
   without OpenVDB (PICVR_IO_NO_VDB). */
picvr_io_status picvr_io_load_vdb(const char *path, const char *grid, picvr_io_volume *volume, char *err, size_t err_size);

/* 1 when path ends in .vdb (ASCII case-insensitive). */
int picvr_io_is_vdb(const char *path);

/* 1 when path names a NRRD file (ends in .nrrd or .nhdr, ASCII case-insensitive): its
   header, not its name, gives the layout. */
int picvr_io_is_nrrd(const char *path);

/* Frees volume->data and zeroes *volume.  NULL and zeroed volumes are allowed. */
void picvr_io_free(picvr_io_volume *volume);

/* Smallest and largest voxel value, ignoring NaN and infinities, and the number of
   those non-finite values (float types only; picvr rejects them).  Either output may be
   NULL.  An all-non-finite volume gives min = max = 0. */
picvr_io_status picvr_io_value_range(const picvr_io_volume *volume, double *min, double *max,
                             size_t *non_finite);

/* The lo_frac and hi_frac quantiles (0 <= lo_frac < hi_frac <= 1) of the finite voxels:
   the sorted values at index round(frac (n - 1)), from at most 2^20 voxels evenly spaced
   through the volume (every voxel of a smaller one).  A range of one value (a constant volume) is widened to
   [v, v + 1].  PICVR_IO_ERROR_BAD_TYPE for an unknown type or no finite voxel. */
picvr_io_status picvr_io_percentile_range(const picvr_io_volume *volume, double lo_frac, double hi_frac, double *lo, double *hi);

/* Fills a picvr_volume_desc that points at volume's data (value range left 0:
   picvr's default for the type), with its placement: direction, and origin where the
   file has one (volume->has_origin).  picvr takes only orthonormal axes: a sheared z axis (a gantry-tilted series) is
   replaced by the normal of the x and y axes, on the side of the given one, and
   *shear_degrees (may be NULL) receives the angle between them (0 otherwise); the
   rendering is then without tilt correction. */
picvr_io_status picvr_io_to_desc_sheared(const picvr_io_volume *volume, picvr_volume_desc *desc,
                                         double *shear_degrees);

/* picvr_io_to_desc_sheared without the angle. */
picvr_io_status picvr_io_to_desc(const picvr_io_volume *volume, picvr_volume_desc *desc);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_IO_H */
