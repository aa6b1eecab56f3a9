/* test_voxel_types.c - the voxel types beyond uint8, uint16 and float32.
 *
 * Each type is checked against one the renderer already had, holding the same values:
 * int8 and int16 against uint8 and uint16 shifted by 128 and 32768 (stored alike, so the
 * value map must undo the shift exactly), int32, float16 and float64 against float32
 * (converted to float32 on upload).  The two renders use the same seed and scene, so
 * the images must be bit-identical: any difference in storage, in the value range or in
 * the value map shows.  Values are chosen exactly representable in every type of a pair
 * (float16 includes subnormals).  Then the hostile inputs of the new types: a NaN or
 * infinite float16 or float64 voxel, a float64 beyond float's range, an unknown type:
 * their status codes, and the previous volume kept.
 */
#include "test_util.h"

#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define VT_N 20

/* A smooth field in [0, 1] on a VT_N^3 grid (a soft ball with a ripple), voxel i. */
static double vt_field(size_t i) {
    uint32_t x = (uint32_t)(i % VT_N), y = (uint32_t)(i / VT_N % VT_N), z = (uint32_t)(i / (VT_N * VT_N));
    double dx = x - 9.5, dy = y - 9.5, dz = z - 9.5;
    double r = sqrt(dx * dx + dy * dy + dz * dz) / 9.0;
    double v = (1.0 - r) * (0.8 + 0.2 * sin(0.9 * x + 0.4 * y));
    return v < 0.0 ? 0.0 : v > 1.0 ? 1.0 : v;
}

/* Renders the volume desc (a fixed scene: ramp transfer function, a sun and a
   background, 24x24, 6 passes, seed 7) into rgba (24 * 24 * 4 floats). */
static void vt_render(const picvr_volume_desc *d, float *rgba) {
    picvr_context *ctx = tu_create(7);
    TU_OK(picvr_upload_volume(ctx, d));
    tu_tf_ramp(ctx, 0.9f, 0.8f, 0.7f, 0.6f);
    tu_sun(ctx, 0.3, 1.0, 0.5, 1, 1, 1, 3.0f, 0.4f);
    picvr_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position[0] = 20; cam.position[1] = 12; cam.position[2] = 45;
    cam.width = cam.height = 24;
    TU_OK(picvr_set_camera(ctx, &cam));
    TU_OK(picvr_step_iterations(ctx, 6));
    TU_OK(picvr_read_rgba32f(ctx, rgba, 24 * 24 * 16));
    tu_finish(ctx);
}

static picvr_volume_desc vt_desc(picvr_voxel_type t, const void *data, float lo, float hi) {
    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    d.dims[0] = d.dims[1] = d.dims[2] = VT_N;
    d.type = t;
    d.data = data;
    d.value_min = lo;
    d.value_max = hi;
    return d;
}

/* The two descs render bit-identical images (and not a black one). */
static void vt_same(const char *what, const picvr_volume_desc *a, const picvr_volume_desc *b) {
    static float ia[24 * 24 * 4], ib[24 * 24 * 4];
    vt_render(a, ia);
    vt_render(b, ib);
    double sum = 0.0;
    for (int i = 0; i < 24 * 24 * 4; i++) sum += ia[i];
    print_message("    %s: image sum %.6g, %s\n", what, sum, memcmp(ia, ib, sizeof ia) ? "DIFFERENT" : "bit-identical");
    assert_true(sum > 0.0);
    if (memcmp(ia, ib, sizeof ia)) fail_msg("%s: the images differ", what);
}

enum { VT_VOX = VT_N * VT_N * VT_N };

void test_voxel_types_signed_match_unsigned(void **state) {
    (void)state;
    static int16_t s16[VT_VOX];
    static uint16_t u16[VT_VOX];
    static int8_t s8[VT_VOX];
    static uint8_t u8[VT_VOX];
    for (size_t i = 0; i < VT_VOX; i++) {
        double f = vt_field(i);
        s16[i] = (int16_t)lrint(-1000.0 + 3000.0 * f);    /* Hounsfield units, air to bone */
        u16[i] = (uint16_t)(s16[i] + 32768);
        s8[i] = (int8_t)lrint(-128.0 + 255.0 * f);
        u8[i] = (uint8_t)(s8[i] + 128);
    }
    picvr_volume_desc a = vt_desc(PICVR_VOXEL_INT16, s16, -1000.0f, 2000.0f);
    picvr_volume_desc b = vt_desc(PICVR_VOXEL_UINT16, u16, 31768.0f, 34768.0f);
    vt_same("int16 window -1000..2000 vs uint16 shifted", &a, &b);
    a = vt_desc(PICVR_VOXEL_INT16, s16, 0.0f, 0.0f);          /* the defaults: the type's range */
    b = vt_desc(PICVR_VOXEL_UINT16, u16, 0.0f, 0.0f);
    vt_same("int16 default range vs uint16 default range", &a, &b);
    a = vt_desc(PICVR_VOXEL_INT8, s8, 0.0f, 0.0f);
    b = vt_desc(PICVR_VOXEL_UINT8, u8, 0.0f, 0.0f);
    vt_same("int8 default range vs uint8 default range", &a, &b);
    a = vt_desc(PICVR_VOXEL_INT8, s8, -50.0f, 100.0f);
    b = vt_desc(PICVR_VOXEL_UINT8, u8, 78.0f, 228.0f);
    vt_same("int8 window -50..100 vs uint8 shifted", &a, &b);
}

/* A binary16 bit pattern of a value that binary16 holds exactly (|v| < 65504). */
static uint16_t vt_half(double v) {
    uint16_t sign = v < 0.0 ? 0x8000u : 0u;
    v = fabs(v);
    if (v == 0.0) return sign;
    int e;
    double m = frexp(v, &e);            /* v = m 2^e, m in [0.5, 1) */
    if (e - 1 < -14) return (uint16_t)(sign | (uint16_t)lrint(v * 16777216.0));   /* subnormal: v / 2^-24 */
    return (uint16_t)(sign | (uint16_t)((e + 14) << 10) | (uint16_t)(lrint(m * 2048.0) - 1024));
}

void test_voxel_types_converted_match_float32(void **state) {
    (void)state;
    static float f32[VT_VOX];
    static int32_t s32[VT_VOX];
    static double f64[VT_VOX];
    static uint16_t f16[VT_VOX];
    for (size_t i = 0; i < VT_VOX; i++) {
        double f = vt_field(i);
        s32[i] = (int32_t)lrint(-3000.0 + 9000.0 * f);
        f32[i] = (float)s32[i];
    }
    picvr_volume_desc a = vt_desc(PICVR_VOXEL_INT32, s32, 0.0f, 0.0f);
    picvr_volume_desc b = vt_desc(PICVR_VOXEL_FLOAT32, f32, 0.0f, 0.0f);
    vt_same("int32 vs float32 (the data's range)", &a, &b);
    for (size_t i = 0; i < VT_VOX; i++) {
        double f = ldexp(lrint(vt_field(i) * 1024.0), -10) * 3.0 - 1.0;   /* multiples of 3/1024 */
        f64[i] = f;
        f32[i] = (float)f;
    }
    a = vt_desc(PICVR_VOXEL_FLOAT64, f64, 0.0f, 0.0f);
    b = vt_desc(PICVR_VOXEL_FLOAT32, f32, 0.0f, 0.0f);
    vt_same("float64 vs float32", &a, &b);
    for (size_t i = 0; i < VT_VOX; i++) {
        /* multiples of 1/256 up to 4: binary16 exact; every 7th voxel a subnormal 2^-24 k */
        double f = i % 7 == 3 ? ldexp((double)(i % 1000), -24) : ldexp(lrint(vt_field(i) * 1024.0), -8);
        f16[i] = vt_half(f);
        f32[i] = (float)f;
    }
    a = vt_desc(PICVR_VOXEL_FLOAT16, f16, 0.0f, 0.0f);
    b = vt_desc(PICVR_VOXEL_FLOAT32, f32, 0.0f, 0.0f);
    vt_same("float16 (subnormals included) vs float32", &a, &b);
    a = vt_desc(PICVR_VOXEL_FLOAT16, f16, 0.5f, 2.0f);
    b = vt_desc(PICVR_VOXEL_FLOAT32, f32, 0.5f, 2.0f);
    vt_same("float16 vs float32, range 0.5..2", &a, &b);
}

void test_voxel_types_hostile(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(3);
    static uint8_t ok[8 * 8 * 8];
    memset(ok, 200, sizeof ok);
    picvr_volume_desc good;
    memset(&good, 0, sizeof good);
    good.dims[0] = good.dims[1] = good.dims[2] = 8;
    good.type = PICVR_VOXEL_UINT8;
    good.data = ok;
    good.spacing[0] = good.spacing[1] = good.spacing[2] = 2.0f;
    TU_OK(picvr_upload_volume(ctx, &good));
    float bmin[3], bmax[3];
    TU_OK(picvr_volume_box(ctx, bmin, bmax));

    static uint16_t h[4 * 4 * 4];
    static double d[4 * 4 * 4];
    picvr_volume_desc bad;
    memset(&bad, 0, sizeof bad);
    bad.dims[0] = bad.dims[1] = bad.dims[2] = 4;
    const struct { picvr_voxel_type t; int which; uint16_t half; double dbl; picvr_status want; const char *what; } rows[] = {
        {PICVR_VOXEL_FLOAT16, 0, 0x7e00u, 0, PICVR_ERROR_NON_FINITE, "float16 NaN"},
        {PICVR_VOXEL_FLOAT16, 0, 0x7c00u, 0, PICVR_ERROR_NON_FINITE, "float16 +Inf"},
        {PICVR_VOXEL_FLOAT16, 0, 0xfc00u, 0, PICVR_ERROR_NON_FINITE, "float16 -Inf"},
        {PICVR_VOXEL_FLOAT64, 1, 0, NAN, PICVR_ERROR_NON_FINITE, "float64 NaN"},
        {PICVR_VOXEL_FLOAT64, 1, 0, INFINITY, PICVR_ERROR_NON_FINITE, "float64 Inf"},
        {PICVR_VOXEL_FLOAT64, 1, 0, 1e300, PICVR_ERROR_NON_FINITE, "float64 beyond float"},
        {PICVR_VOXEL_FLOAT64, 1, 0, -1e39, PICVR_ERROR_NON_FINITE, "float64 below -FLT_MAX"},
        {(picvr_voxel_type)9, 1, 0, 0, PICVR_ERROR_UNSUPPORTED_TYPE, "type 9"},
        {(picvr_voxel_type)0, 1, 0, 0, PICVR_ERROR_UNSUPPORTED_TYPE, "type 0"},
    };
    for (size_t r = 0; r < sizeof rows / sizeof rows[0]; r++) {
        for (int i = 0; i < 64; i++) { h[i] = 0x3c00u; d[i] = 1.0; }   /* 1.0 everywhere */
        h[37] = rows[r].half;
        d[37] = rows[r].dbl;
        bad.type = rows[r].t;
        bad.data = rows[r].which ? (const void *)d : (const void *)h;
        picvr_status s = picvr_upload_volume(ctx, &bad);
        print_message("    %-24s %s\n", rows[r].what, picvr_status_string(s));
        if (s != rows[r].want) fail_msg("%s: %s, expected %s", rows[r].what, picvr_status_string(s), picvr_status_string(rows[r].want));
        float m0[3], m1[3];
        TU_OK(picvr_volume_box(ctx, m0, m1));                 /* the previous volume is kept */
        for (int a = 0; a < 3; a++) assert_true(m0[a] == bmin[a] && m1[a] == bmax[a]);
    }
    tu_finish(ctx);
}

/* Stiff values of the new types: int16 and int8 alternating between their extremes
   (default ranges: the whole type), int32 at +-2^31 (converted to float32: +-2.1e9, a
   range the value map must still resolve), float64 at +-FLT_MAX: every pixel finite. */
void test_voxel_types_extremes(void **state) {
    (void)state;
    static int16_t s16[VT_VOX];
    static int8_t s8[VT_VOX];
    static int32_t s32[VT_VOX];
    static double f64[VT_VOX];
    for (size_t i = 0; i < VT_VOX; i++) {
        int odd = (int)((i + i / VT_N + i / (VT_N * VT_N)) & 1u);
        s16[i] = odd ? INT16_MAX : INT16_MIN;
        s8[i] = odd ? INT8_MAX : INT8_MIN;
        s32[i] = odd ? INT32_MAX : INT32_MIN;
        f64[i] = odd ? (double)FLT_MAX : -(double)FLT_MAX;
    }
    const picvr_volume_desc cases[4] = {vt_desc(PICVR_VOXEL_INT16, s16, 0.0f, 0.0f), vt_desc(PICVR_VOXEL_INT8, s8, 0.0f, 0.0f),
                                        vt_desc(PICVR_VOXEL_INT32, s32, 0.0f, 0.0f), vt_desc(PICVR_VOXEL_FLOAT64, f64, 0.0f, 0.0f)};
    static const char *names[4] = {"int16 extremes", "int8 extremes", "int32 +-2^31", "float64 +-FLT_MAX"};
    static float img[24 * 24 * 4];
    for (int c = 0; c < 4; c++) {
        vt_render(&cases[c], img);
        double sum = 0.0;
        for (int i = 0; i < 24 * 24 * 4; i++) {
            if (!isfinite(img[i])) fail_msg("%s: pixel value %d not finite", names[c], i);
            sum += img[i];
        }
        print_message("    %-20s image sum %.6g, every pixel finite\n", names[c], sum);
    }
}
