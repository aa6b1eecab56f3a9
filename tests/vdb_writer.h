/* vdb_writer.h - a test-only OpenVDB writer (tests/vdb_writer.cpp, through OpenVDB's own
 * io::File): files with the grids, voxels, transforms and compression a test asks for,
 * read back by picvr_io_load_vdb. */
#ifndef PICVR_VDB_WRITER_H
#define PICVR_VDB_WRITER_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vdbw_type { VDBW_FLOAT, VDBW_DOUBLE, VDBW_VEC3S } vdbw_type;

typedef struct vdbw_voxel {
    int32_t ijk[3];   /* index coordinates */
    double value;     /* VDBW_VEC3S: (value, value, value) */
} vdbw_voxel;

typedef struct vdbw_grid {
    const char *name;
    vdbw_type type;
    double background;
    const vdbw_voxel *active;      /* set and activated, in order */
    size_t active_count;
    const vdbw_voxel *inactive;    /* values stored in leaves but left inactive */
    size_t inactive_count;
    int has_tile;                  /* 1: an active 8x8x8 tile (a level-1 tile) at tile_ijk */
    int32_t tile_ijk[3];           /* a multiple of 8 */
    double tile_value;
    /* Transform: world = matrix * index + translation (column vectors; matrix row-major,
       matrix[3*r + c] is row r, column c).  All zero: the identity. */
    double matrix[9];
    double translation[3];
    int frustum;                   /* 1: a non-linear frustum transform instead */
    int half;                      /* 1: values saved as 16-bit floats */
    int share_tree_of;             /* k > 0: share the tree of grid k-1 (written as an instance) */
} vdbw_grid;

/* Compression of the whole file: -1 OpenVDB's default (blosc and active mask), else a
   mask of VDBW_ZIP, VDBW_ACTIVE_MASK, VDBW_BLOSC (0: none). */
#define VDBW_ZIP 1
#define VDBW_ACTIVE_MASK 2
#define VDBW_BLOSC 4

/* Writes the grids to path.  0 on success, else -1 and a message in err. */
int vdbw_write(const char *path, const vdbw_grid *grids, size_t count, int compression,
               char *err, size_t err_size);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_VDB_WRITER_H */
