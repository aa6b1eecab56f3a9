/* volume.c - what a caller does with a loaded picvr_io_volume (picvr_io.h): free it, its
 * value range and percentiles (every voxel type, non-finite values left out), and the
 * picvr_volume_desc that points at it (picvr_io_to_desc, a sheared z axis replaced). */
#include "picvr_io.h"
#include "io/internal.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

void picvr_io_free(picvr_io_volume *volume)
{
    if (!volume) return;
    free(volume->data);
    memset(volume, 0, sizeof *volume);
}

/* IEEE binary16 to double (every half is exact in a double). */
static double half_value(uint16_t h)
{
    int e = (h >> 10) & 31, m = h & 1023;
    double v = e == 0 ? ldexp(m, -24) : e == 31 ? (m ? NAN : INFINITY) : ldexp(1024 + m, e - 25);
    return (h & 0x8000) ? -v : v;
}

/* One voxel's value (host byte order), as a double. */
static double voxel_value(picvr_voxel_type type, const unsigned char *p)
{
    switch (type) {
    case PICVR_VOXEL_UINT8: return *p;
    case PICVR_VOXEL_INT8: return (int8_t)*p;
    case PICVR_VOXEL_UINT16: { uint16_t u; memcpy(&u, p, 2); return u; }
    case PICVR_VOXEL_INT16: { int16_t u; memcpy(&u, p, 2); return u; }
    case PICVR_VOXEL_FLOAT16: { uint16_t u; memcpy(&u, p, 2); return half_value(u); }
    case PICVR_VOXEL_INT32: { int32_t u; memcpy(&u, p, 4); return u; }
    case PICVR_VOXEL_FLOAT32: { float f; memcpy(&f, p, 4); return f; }
    case PICVR_VOXEL_FLOAT64: { double f; memcpy(&f, p, 8); return f; }
    }
    return NAN;
}

static int compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

picvr_io_status picvr_io_percentile_range(const picvr_io_volume *volume, double lo_frac, double hi_frac, double *lo, double *hi)
{
    if (!volume || !volume->data || !lo || !hi) return PICVR_IO_ERROR_NULL_POINTER;
    size_t voxel = picvr_io_voxel_size(volume->type);
    if (voxel == 0) return PICVR_IO_ERROR_BAD_TYPE;
    if (!(lo_frac >= 0.0 && lo_frac < hi_frac && hi_frac <= 1.0)) return PICVR_IO_ERROR_BAD_DIMS;
    size_t count = volume->size / voxel, want = count < ((size_t)1 << 20) ? count : ((size_t)1 << 20);
    double *v = (double *)malloc((want ? want : 1) * sizeof(double));
    if (!v) return PICVR_IO_ERROR_OUT_OF_MEMORY;
    size_t n = 0;
    for (size_t k = 0; k < want; k++) {   /* voxel k * count / want: evenly spaced, exact when want == count */
        size_t i = (size_t)(((unsigned long long)k * count) / want);
        double x = voxel_value(volume->type, (const unsigned char *)volume->data + voxel * i);
        if (isfinite(x)) v[n++] = x;
    }
    if (n == 0) {
        free(v);
        return PICVR_IO_ERROR_BAD_TYPE;
    }
    qsort(v, n, sizeof *v, compare_doubles);
    *lo = v[(size_t)(lo_frac * (double)(n - 1) + 0.5)];
    *hi = v[(size_t)(hi_frac * (double)(n - 1) + 0.5)];
    if (!(*hi > *lo)) *hi = *lo + 1.0;   /* rule: one value (a constant volume) maps to [v, v + 1] */
    free(v);
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_value_range(const picvr_io_volume *volume, double *min, double *max,
                             size_t *non_finite)
{
    if (!volume || !volume->data) return PICVR_IO_ERROR_NULL_POINTER;
    size_t voxel = picvr_io_voxel_size(volume->type);
    if (voxel == 0) return PICVR_IO_ERROR_BAD_TYPE;
    size_t count = volume->size / voxel, bad = 0;
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < count; i++) {
        double v = voxel_value(volume->type, (const unsigned char *)volume->data + voxel * i);
        if (!isfinite(v)) {
            bad++;
            continue;
        }
        if (v < lo) lo = v;
        if (v > hi) hi = v;
    }
    if (lo > hi) lo = hi = 0.0; /* no finite value at all */
    if (min) *min = lo;
    if (max) *max = hi;
    if (non_finite) *non_finite = bad;
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_to_desc_sheared(const picvr_io_volume *volume, picvr_volume_desc *desc,
                                         double *shear_degrees)
{
    if (shear_degrees) *shear_degrees = 0.0;
    if (!volume || !desc) return PICVR_IO_ERROR_NULL_POINTER;
    memset(desc, 0, sizeof *desc);
    memcpy(desc->dims, volume->dims, sizeof desc->dims);
    desc->type = volume->type;
    memcpy(desc->spacing, volume->spacing, sizeof desc->spacing);
    desc->data = volume->data;
    memcpy(desc->direction, volume->direction, sizeof desc->direction);
    desc->has_origin = volume->has_origin;
    memcpy(desc->origin, volume->origin, sizeof desc->origin);
    const float *x = volume->direction, *y = volume->direction + 3, *z = volume->direction + 6;
    double n[3] = {(double)x[1] * y[2] - (double)x[2] * y[1], (double)x[2] * y[0] - (double)x[0] * y[2],
                   (double)x[0] * y[1] - (double)x[1] * y[0]};
    double ln = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), lz = sqrt((double)z[0] * z[0] + (double)z[1] * z[1] + (double)z[2] * z[2]);
    if (!(ln > 0.5) || !(lz > 0.5)) return PICVR_IO_OK;   /* degenerate axes: picvr refuses them */
    double c = (n[0] * z[0] + n[1] * z[1] + n[2] * z[2]) / (ln * lz);
    double angle = acos(fmin(1.0, fabs(c))) * 180.0 / 3.14159265358979323846;
    if (angle > 0.01) {   /* sheared: the normal on z's side */
        for (int i = 0; i < 3; i++) desc->direction[6 + i] = (float)((c < 0.0 ? -n[i] : n[i]) / ln);
        if (shear_degrees) *shear_degrees = angle;
    }
    return PICVR_IO_OK;
}

picvr_io_status picvr_io_to_desc(const picvr_io_volume *volume, picvr_volume_desc *desc)
{
    return picvr_io_to_desc_sheared(volume, desc, NULL);
}
