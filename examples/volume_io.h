/* volume_io.h - load headerless raw volumes (optionally gzip-compressed) for picvr.
 *
 * File names carry the layout, as in the Open SciVis data sets:
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
    float spacing[3];          /* 1,1,1 after loading; the caller may change it */
    void *data;                /* dims[0]*dims[1]*dims[2] voxels, x fastest, host order */
    size_t size;               /* bytes in data */
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

/* Frees volume->data and zeroes *volume.  NULL and zeroed volumes are allowed. */
void pvio_free(pvio_volume *volume);

/* Smallest and largest voxel value, ignoring NaN and infinities, and the number of
   those non-finite values (float types only; picvr rejects them).  Either output may be
   NULL.  An all-non-finite volume gives min = max = 0. */
pvio_status pvio_value_range(const pvio_volume *volume, double *min, double *max,
                             size_t *non_finite);

/* Fills a picvr_volume_desc that points at volume's data (value range left 0:
   picvr's default for the type). */
pvio_status pvio_to_desc(const pvio_volume *volume, picvr_volume_desc *desc);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_VOLUME_IO_H */
