/* internal.h - what the files of the picvr_io module in io/ share; private: not part of
 * picvr_io.h.  io/common.c defines the helpers every reader calls, io/raw.c the raw
 * reader that the dispatcher (io/picvr_io.c) falls back on, and io/formats_all.c or
 * io/formats_raw_nrrd.c (whichever the build links) the table of the other formats.
 * The readers call io/common.c and io/volume.c only, never the dispatcher. */
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

/* Largest single read() or gzread() request: gzread's length is an unsigned int, its
   result an int. */
#define PICVR_IO_MAX_READ_CHUNK ((size_t)1 << 30)

/* ---- io/common.c ------------------------------------------------------------------ */

/* Writes a message into err (err_size bytes, truncated); err NULL or err_size 0: nothing. */
PICVR_IO_PRINTF(3, 4)
void picvr_io_set_error(char *err, size_t err_size, const char *fmt, ...);

/* 1 when the piece s[0..len) ends in suffix (lower case), ASCII case-insensitive. */
int picvr_io_piece_ends_with(const char *s, size_t len, const char *suffix);

/* The voxel type the piece s[0..len) names, as picvr_io_parse_type reads it; BAD_TYPE
   for any other piece. */
picvr_io_status picvr_io_parse_type_piece(const char *s, size_t len, picvr_voxel_type *type);

/* 1 when path ends in suffix, ASCII case-insensitive; 0 for NULL. */
int picvr_io_has_suffix(const char *path, const char *suffix);

/* 1 on a little-endian host. */
int picvr_io_host_is_little_endian(void);

/* Reverses the byte order of each voxel_size-byte value in data[0..bytes). */
void picvr_io_swap_bytes(unsigned char *data, size_t bytes, size_t voxel_size);

/* Opens path for reading through zlib (plain or gzip alike) after stat(): a regular
   file, or also a FIFO when allow_fifo; *st receives its stat.  OPEN (not there, not a
   regular file) or OUT_OF_MEMORY (zlib's state), with a message. */
picvr_io_status picvr_io_gzopen(const char *path, int allow_fifo, gzFile *out, struct stat *st, char *err,
                                size_t err_size);

/* zlib's message for the last error on gz, without the "path: " prefix zlib puts in
   front (strerror for an I/O error); *errnum receives zlib's code. */
const char *picvr_io_gz_message(gzFile gz, const char *path, int *errnum);

/* Reads up to `expected` bytes of gz into a malloc'd buffer (*out, the caller frees it)
   that starts small and doubles as data arrive, so that a file claiming a huge size
   costs no more memory than the data it holds; *got: the bytes read.  READ or
   OUT_OF_MEMORY, with a message. */
picvr_io_status picvr_io_gz_read_up_to(gzFile gz, const char *path, size_t expected,
                                       unsigned char **out, size_t *got, char *err, size_t err_size);

/* After `have` of the `expected` bytes of gz: TRUNCATED when have < expected, TOO_LONG
   when data follow, TRUNCATED or READ when a gzip stream does not end cleanly (reading
   on verifies its check sum and length trailer); messages speak of "the layout". */
picvr_io_status picvr_io_gz_check_end(gzFile gz, const char *path, size_t have,
                                      size_t expected, char *err, size_t err_size);

/* ---- io/raw.c ----------------------------------------------------------------------- */

/* Reads path as a raw file of the given layout (NULL: picvr_io_parse_name's, from the
   file's name), as picvr_io.h describes for picvr_io_load.  path and volume are not NULL
   and *volume is zeroed (picvr_io_load sees to both); on failure it stays zeroed. */
picvr_io_status picvr_io_load_raw(const char *path, const picvr_io_layout *layout, picvr_io_volume *volume,
                                  char *err, size_t err_size);

/* ---- io/formats_all.c or io/formats_raw_nrrd.c -------------------------------------- */

/* A format picvr_io_load hands to its own reader: matches(path) is 1 for the files the
   reader takes (by name, or a folder for DICOM); load is called as picvr_io_load is. */
typedef struct picvr_io_format {
    int (*matches)(const char *path);
    picvr_io_status (*load)(const char *path, picvr_io_volume *volume, char *err, size_t err_size);
} picvr_io_format;

/* The formats of this build in the order picvr_io_load tries them, ended by an entry
   whose matches is NULL.  A build chooses its formats by the table it links:
   io/formats_all.c (NRRD, NIfTI, OpenVDB, DICOM) or io/formats_raw_nrrd.c (NRRD). */
extern const picvr_io_format picvr_io_formats[];

#ifdef __cplusplus
}
#endif
#endif /* PICVR_IO_INTERNAL_H */
