/* internal.h - helpers shared by the readers of the picvr_io module in io/;
 * private: not part of picvr_io.h. */
#ifndef PICVR_IO_INTERNAL_H
#define PICVR_IO_INTERNAL_H

#include <stddef.h>
#include <sys/stat.h>

#include <zlib.h>

#include "picvr_io.h"

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__)
#define PICVR_IO_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define PICVR_IO_PRINTF(f, a)
#endif

/* Writes a message into err (err_size bytes, truncated); err NULL or err_size 0: nothing. */
PICVR_IO_PRINTF(3, 4)
void picvr_io_set_error(char *err, size_t err_size, const char *fmt, ...);

/* 1 when path ends in suffix, ASCII case-insensitive; 0 for NULL. */
int picvr_io_has_suffix(const char *path, const char *suffix);

/* Opens path for reading through zlib (plain or gzip alike) after stat(): a regular
   file, or also a FIFO when allow_fifo; *st receives its stat.  OPEN (not there, not a
   regular file) or OUT_OF_MEMORY (zlib's state), with a message. */
picvr_io_status picvr_io_gzopen(const char *path, int allow_fifo, gzFile *out, struct stat *st, char *err,
                                size_t err_size);

/* zlib's message for the last error on gz, without the "path: " prefix zlib puts in
   front (strerror for an I/O error); *errnum receives zlib's code. */
const char *picvr_io_gz_message(gzFile gz, const char *path, int *errnum);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_IO_INTERNAL_H */
