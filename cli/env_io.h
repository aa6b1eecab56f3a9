/* env_io.h - load Radiance .hdr (RGBE) environment maps for picvr.
 *
 * A map is an equirectangular Radiance picture: a header that starts "#?RADIANCE\n" or
 * "#?RGBE\n" and ends with a blank line, the size line "-Y H +X W" (rows top to bottom,
 * the only orientation accepted), then W x H RGBE texels, flat or in new-style RLE
 * scanlines.  stb_image decodes it, but only after this module has checked the whole
 * file: stb_image trusts its input (on a truncated file it reads zeros or leaves texels
 * uninitialised, and a zero RLE count hangs it), so every scanline's runs are walked,
 * bounds-checked, first.
 *
 * Every function validates its input and reports problems as a status plus an
 * optional message; none of them crashes or hangs, whatever the bytes (it is fuzzed:
 * tests/fuzz/fuzz_env_io.c).  Independent of the Vulkan library: only picvr.h's
 * PICVR_MAX_ENV_SIZE is used.  Not thread-safe (stb_image's failure reason is global).
 */
#ifndef PICVR_ENV_IO_H
#define PICVR_ENV_IO_H

#include <stddef.h>
#include <stdint.h>

#include "picvr.h"

#ifdef __cplusplus
extern "C" {
#endif

#define PVENV_MAX_SIZE PICVR_MAX_ENV_SIZE   /* largest accepted texel count a side */

typedef enum pvenv_status {
    PVENV_OK = 0,
    PVENV_ERROR_NULL_POINTER,  /* a required argument was NULL */
    PVENV_ERROR_READ,          /* the file cannot be opened or read (or is 2 GiB or more) */
    PVENV_ERROR_EMPTY,         /* no bytes at all */
    PVENV_ERROR_NOT_HDR,       /* no Radiance magic (OpenEXR and others) */
    PVENV_ERROR_NO_SIZE_LINE,  /* no "-Y H +X W" line after the header's blank line */
    PVENV_ERROR_BAD_SIZE,      /* a side outside 1..PVENV_MAX_SIZE */
    PVENV_ERROR_CORRUPT,       /* pixel data truncated or corrupt (too large for stb_image) */
    PVENV_ERROR_DECODE,        /* stb_image refused it, or its size line is ambiguous */
    PVENV_ERROR_BLACK,         /* every texel is black (nothing to light with) */
    PVENV_STATUS_COUNT
} pvenv_status;

/* A static English name for the status ("PVENV_OK", ...); never NULL. */
const char *pvenv_status_string(pvenv_status status);

/* Parses a whole .hdr file held in memory (data: size bytes; NULL is allowed when size
   is 0).  On success *rgb is width x height linear RGB texels (3 floats each, finite
   and >= 0, rows top to bottom, x fastest, malloc'd: free with pvenv_free or free()),
   *width and *height are in 1..PVENV_MAX_SIZE, and at least one value is > 0.  On
   failure *rgb is NULL, *width = *height = 0, and err (err_size bytes, may be NULL)
   receives why, without a file name, e.g. "the pixel data is truncated or corrupt". */
pvenv_status pvenv_parse_hdr(const unsigned char *data, size_t size, float **rgb,
                             uint32_t *width, uint32_t *height, char *err, size_t err_size);

/* Reads the file at path and parses it as pvenv_parse_hdr does.  Messages name the
   file: "cannot read PATH: REASON" (PVENV_ERROR_READ), else "PATH: REASON". */
pvenv_status pvenv_load_hdr(const char *path, float **rgb, uint32_t *width,
                            uint32_t *height, char *err, size_t err_size);

/* Frees texels returned by pvenv_parse_hdr or pvenv_load_hdr; NULL is allowed. */
void pvenv_free(float *rgb);

#ifdef __cplusplus
}
#endif
#endif /* PICVR_ENV_IO_H */
