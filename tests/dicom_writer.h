/* dicom_writer.h - test-only writer of synthetic DICOM CT series (GDCM), for
 * tests/test_dicom.c and the seeds of tests/fuzz/fuzz_dicom.cpp.
 *
 * Every attribute is written explicitly as its DICOM string or binary value (not
 * through gdcm::ImageWriter's geometry conversions), so a test's expectations come from
 * the values it asked for, independently of the reader under test.  Explicit VR
 * little endian, uncompressed; one single-frame slice per file, named
 * PREFIX%03d.dcm by file index. */
#ifndef PICVR_DICOM_WRITER_H
#define PICVR_DICOM_WRITER_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct dw_series {
    const char *dir;            /* existing folder to write into */
    const char *prefix;         /* file names PREFIX000.dcm, PREFIX001.dcm, ... */
    const char *series_uid;     /* SeriesInstanceUID; SOPInstanceUIDs are SERIES.k */
    uint32_t cols, rows, slices;
    double pixel_spacing[2];    /* PixelSpacing as DICOM orders it: row spacing, column spacing */
    double slice_thickness;     /* SliceThickness (0: not written) */
    double iop[6];              /* ImageOrientationPatient: row cosine, column cosine */
    double ipp0[3], step[3];    /* slice k at ipp0 + k step (when positions is NULL) */
    const double *positions;    /* else 3 * slices values: slice k's ImagePositionPatient */
    double slope, intercept;    /* RescaleSlope/Intercept of every slice */
    const double *slopes;       /* else per slice (slices values; intercept shared) */
    int is_signed;              /* int16 pixels (PixelRepresentation 1), else uint16 */
    uint32_t shuffle_seed;      /* 0: slice k in file k; else files named in a random order */
    int odd_rows_slice;         /* >= 0: that slice is written with rows + 1 rows */
    const char *photometric;    /* NULL: MONOCHROME2 */
} dw_series;

/* Stored value of voxel (x, y) of slice k (k in position order, as given), for
   signed (int16) or unsigned (uint16) series: distinct enough that a swapped, flipped or
   misordered slice changes them. */
static inline int32_t dw_value(uint32_t x, uint32_t y, uint32_t k, int is_signed) {
    int32_t v = (int32_t)((x * 7u + y * 131u + k * 1009u) % 4001u);
    return is_signed ? v - 2000 : v;
}

/* Fills s with a default series: 8 columns x 6 rows x 5 slices, int16, PixelSpacing
   0.75\0.5, axial identity orientation, positions (-10, 20, 30 + 2.5 k), slope 1,
   intercept -1024, series uid "2.25.1000", prefix "s". */
void dw_defaults(dw_series *s, const char *dir);

/* Writes the series; returns 0, or -1 (and prints why to stderr) on failure.  The
   file index of slice k is in file_of_slice[k] when that is not NULL. */
int dw_write_series(const dw_series *s, uint32_t *file_of_slice);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_DICOM_WRITER_H */
