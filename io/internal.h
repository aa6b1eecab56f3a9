/* internal.h - helpers shared by the readers of the picvr_io module in io/;
 * private: not part of picvr_io.h. */
#ifndef PICVR_IO_INTERNAL_H
#define PICVR_IO_INTERNAL_H

#include <stddef.h>

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

#ifdef __cplusplus
}
#endif
#endif /* PICVR_IO_INTERNAL_H */
