/* volume_io.h - load headerless raw volumes (optionally gzip-compressed) for picvr.
 *
 * NRRD files (.nrrd, .nhdr) carry their layout and geometry in their header
 * (pvio_load_nrrd).  Raw files' names carry the layout, as in the Open SciVis data sets:
 *     NAME_XxYxZ_TYPE.raw  or  NAME_XxYxZ_TYPE.raw.gz
 * with TYPE one of uint8, uint16, float32, int8, int16, int32, float16, float64 (or
 * u8, u16, f32, i8, i16, i32, f16, f64), e.g.
 * "bonsai_256x256x256_uint8.raw.gz".  Voxels are stored x fastest, multi-byte values
 * little-endian.  zlib reads plain and gzip files alike.
 *
 * Every function validates its input and reports problems as a status plus an
 * optional message; none of them crashes, whatever the file name or contents.
 * Independent of the Vulkan library: only picvr.h's types are used.
 */
#ifndef PICVR_VOLUME_IO_H
#define PICVR_VOLUME_IO_H

#include <stddef.h>
#include <stdint.h>

#include "picvr.h"

#ifdef __cplusplus
extern "C" {
#endif

#define PVIO_MAX_DIM 65535u   /* largest accepted voxel count along one axis */

typedef enum pvio_status {
    PVIO_OK = 0,
    PVIO_ERROR_NULL_POINTER,   /* a required argument was NULL */
    PVIO_ERROR_BAD_NAME,       /* the file name does not match NAME_XxYxZ_TYPE.raw[.gz] */
    PVIO_ERROR_BAD_DIMS,       /* a dimension is outside 1..PVIO_MAX_DIM */
    PVIO_ERROR_BAD_TYPE,       /* unknown voxel type */
    PVIO_ERROR_SIZE_OVERFLOW,  /* the byte size of the volume does not fit in size_t */
    PVIO_ERROR_OPEN,           /* the file cannot be opened (or is not a regular file) */
    PVIO_ERROR_READ,           /* an I/O error or corrupt gzip data */
    PVIO_ERROR_TRUNCATED,      /* fewer bytes than the layout needs */
    PVIO_ERROR_TOO_LONG,       /* more bytes than the layout needs */
    PVIO_ERROR_OUT_OF_MEMORY,
    PVIO_ERROR_BAD_HEADER,     /* a NRRD header that is malformed or asks for what is not read */
    PVIO_STATUS_COUNT
} pvio_status;

/* How the voxels are laid out: enough to know the file's exact byte size. */
typedef struct pvio_layout {
    uint32_t dims[3];
    picvr_voxel_type type;
} pvio_layout;

/* A loaded volume.  data is malloc'd (free it with pvio_free). */
typedef struct pvio_volume {
    uint32_t dims[3];
    picvr_voxel_type type;
    float spacing[3];          /* the file's (NRRD), else 1,1,1; the caller may change it */
    void *data;                /* dims[0]*dims[1]*dims[2] voxels, x fastest, host order */
    size_t size;               /* bytes in data */
    float origin[3];           /* world position of voxel 0's centre (NRRD space origin; 0) */
    float direction[9];        /* unit vectors of the x, y, z axes in world space, three
                                  floats each (NRRD space directions; else the identity) */
} pvio_volume;

/* A static English name for the status ("PVIO_OK", ...); never NULL. */
const char *pvio_status_string(pvio_status status);

/* Bytes per voxel of type, or 0 for an unknown type. */
size_t pvio_voxel_size(picvr_voxel_type type);

/* The canonical name of type ("uint8", "int16", "float32", ...), or "unknown". */
const char *pvio_type_name(picvr_voxel_type type);

/* Parses a type name or its abbreviation ("uint8"/"u8", "int16"/"i16", "float64"/"f64",
   ...; ASCII case-insensitive). */
pvio_status pvio_parse_type(const char *text, picvr_voxel_type *type);

/* Checks that every dimension is in 1..PVIO_MAX_DIM and the type is known, and
   returns the volume's byte size in *bytes (may be NULL).  err (err_size bytes,
   may be NULL) receives a message on failure. */
pvio_status pvio_layout_bytes(const pvio_layout *layout, size_t *bytes,
                              char *err, size_t err_size);

/* Reads the layout from a path "DIR/NAME_XxYxZ_TYPE.raw[.gz]"; only the last path
   component is looked at.  The result is validated as by pvio_layout_bytes(). */
pvio_status pvio_parse_name(const char *path, pvio_layout *layout,
                            char *err, size_t err_size);

/* Loads a volume.  layout NULL: taken from the file name.  The file (after gzip
   decompression, if compressed) must hold exactly the layout's byte count; the gzip
   check sum is verified.  On failure *volume is zeroed and nothing leaks. */
pvio_status pvio_load(const char *path, const pvio_layout *layout, pvio_volume *volume,
                      char *err, size_t err_size);

/* Loads a NRRD volume: NAME.nrrd (header and data in one file) or NAME.nhdr (the header
   names its data file), raw or gzip-encoded, 3 dimensions, a type picvr holds; spacing,
   orientation and origin from the header.  pvio_load calls it for those two extensions
   (with layout NULL).  Unsupported features (other encodings, line skip, data file
   lists) are refused with a message.  On failure *volume is zeroed and nothing leaks. */
pvio_status pvio_load_nrrd(const char *path, pvio_volume *volume, char *err, size_t err_size);

/* 1 when path names a NRRD file (ends in .nrrd or .nhdr, ASCII case-insensitive): its
   header, not its name, gives the layout. */
int pvio_is_nrrd(const char *path);

/* Frees volume->data and zeroes *volume.  NULL and zeroed volumes are allowed. */
void pvio_free(pvio_volume *volume);

/* Smallest and largest voxel value, ignoring NaN and infinities, and the number of
   those non-finite values (float types only; picvr rejects them).  Either output may be
   NULL.  An all-non-finite volume gives min = max = 0. */
pvio_status pvio_value_range(const pvio_volume *volume, double *min, double *max,
                             size_t *non_finite);

/* The lo_frac and hi_frac quantiles (0 <= lo_frac < hi_frac <= 1) of the finite voxels:
   the sorted values at index round(frac (n - 1)), from at most 2^20 voxels evenly spaced
   through the volume (every voxel of a smaller one).  A range of one value (a constant volume) is widened to
   [v, v + 1].  PVIO_ERROR_BAD_TYPE for an unknown type or no finite voxel. */
pvio_status pvio_percentile_range(const pvio_volume *volume, double lo_frac, double hi_frac, double *lo, double *hi);

/* Fills a picvr_volume_desc that points at volume's data (value range left 0:
   picvr's default for the type). */
pvio_status pvio_to_desc(const pvio_volume *volume, picvr_volume_desc *desc);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_VOLUME_IO_H */
