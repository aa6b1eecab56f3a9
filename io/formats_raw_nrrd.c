/* formats_raw_nrrd.c - the format table of the raw and NRRD build of picvr_io (the
 * Makefile's IO_RAW_SRC: the bench programs and the raw/NRRD fuzz harness, which link
 * neither niftilib, GDCM nor OpenVDB): NRRD alone.  picvr_io_load then reads every other
 * file as raw, so a NIfTI, OpenVDB or DICOM name is refused by the raw reader's name
 * check (PICVR_IO_ERROR_BAD_NAME: "name must end in .raw or .raw.gz ...").  The full
 * build links io/formats_all.c instead. */
#include "picvr_io.h"
#include "io/internal.h"

#include <stddef.h>

const picvr_io_format picvr_io_formats[] = {
    {picvr_io_is_nrrd, picvr_io_load_nrrd},
    {NULL, NULL},
};
