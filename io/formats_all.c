/* formats_all.c - the format table of the full picvr_io build (libpicvr_io.a): the files
 * picvr_io_load hands to a reader other than the raw one, NRRD, NIfTI, OpenVDB and DICOM,
 * tried in this order.  The raw and NRRD build links io/formats_raw_nrrd.c instead. */
#include "picvr_io.h"
#include "io/internal.h"

#include <stddef.h>

/* picvr_io_load names no grid: the reader's default (picvr_io_load_vdb). */
static picvr_io_status load_vdb_default_grid(const char *path, picvr_io_volume *volume, char *err,
                                             size_t err_size)
{
    return picvr_io_load_vdb(path, NULL, volume, err, err_size);
}

const picvr_io_format picvr_io_formats[] = {
    {picvr_io_is_nrrd, picvr_io_load_nrrd},
    {picvr_io_is_nifti, picvr_io_load_nifti},
    {picvr_io_is_vdb, load_vdb_default_grid},
    {picvr_io_is_dicom, picvr_io_load_dicom},   /* last: it takes any folder */
    {NULL, NULL},
};
