/* picvr_io.c - the dispatcher of picvr_io.h: picvr_io_load chooses the reader of a file by
 * its name or content (the format table of io/formats_*.c, in its order) and calls it;
 * a file no format claims, or any file given with a layout, is read as raw (io/raw.c).
 * Which formats a build reads is a choice of files to link (the Makefile's IO_SRC and
 * IO_RAW_SRC), not a compile-time switch: this file is the same in every build.  No
 * reader calls back into it. */
#include "picvr_io.h"
#include "io/internal.h"

#include <string.h>

/* The first format of this build that claims path, or NULL. */
static const picvr_io_format *format_of(const char *path)
{
    for (const picvr_io_format *f = picvr_io_formats; f->matches; f++)
        if (f->matches(path)) return f;
    return NULL;
}

picvr_io_status picvr_io_load(const char *path, const picvr_io_layout *layout, picvr_io_volume *volume,
                              char *err, size_t err_size)
{
    if (volume) memset(volume, 0, sizeof *volume);
    if (!path || !volume) {
        picvr_io_set_error(err, err_size, "no file name or output given");
        return PICVR_IO_ERROR_NULL_POINTER;
    }
    const picvr_io_format *format = layout ? NULL : format_of(path);
    if (format) return format->load(path, volume, err, err_size);
    return picvr_io_load_raw(path, layout, volume, err, err_size);
}
