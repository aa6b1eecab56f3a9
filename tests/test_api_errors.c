/* test_api_errors.c - bad inputs give the specific documented picvr_status, and leave the
 * context working with its previous state.
 *
 * Where picvr.h allows more than one code the most specific one is expected (listed in
 * the report to the library author):
 *   - a NaN or infinity anywhere in the input (spacing, value range, TF point, density,
 *     light or camera parameter) -> PICVR_ERROR_NON_FINITE ("a NaN or infinity in the
 *     input (voxels, parameters)");
 *   - a volume dimension above the device's maxImageDimension3D, an image side above
 *     PICVR_MAX_IMAGE_SIZE -> PICVR_ERROR_SIZE_OVERFLOW ("overflows size_t or a device
 *     limit"); a zero dimension -> PICVR_ERROR_INVALID_DIMENSIONS;
 *   - more than PICVR_MAX_TF_POINTS points -> PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
 *   - negative spacing, negative density -> PICVR_ERROR_INVALID_ARGUMENT;
 *   - background with a negative intensity or colour -> PICVR_ERROR_INVALID_LIGHT.
 * The fields of multiple scattering and environment maps (test_bad_inputs_scattering_and_
 * environment), by the same rules:
 *   - picvr_tf_point.g outside (-1, 1) -> PICVR_ERROR_INVALID_TRANSFER_FUNCTION (as the
 *     other out-of-range TF fields); picvr_scattering.back_g outside (-1, 1),
 *     back_weight outside [0, 1) -> PICVR_ERROR_INVALID_ARGUMENT; NaN or infinity in any
 *     of them, in a texel or in env_rotation -> PICVR_ERROR_NON_FINITE;
 *   - an environment map side of 0 -> PICVR_ERROR_INVALID_DIMENSIONS, above
 *     PICVR_MAX_ENV_SIZE -> PICVR_ERROR_SIZE_OVERFLOW (checked before any texel is read);
 *   - a negative texel or an all-black map ("not all 0") -> PICVR_ERROR_INVALID_LIGHT (as a
 *     negative background colour).
 */
#include "test_util.h"

#include <float.h>

void test_status_strings_non_null_and_distinct(void **state) {
    (void)state;
    const char *names[PICVR_STATUS_COUNT];
    for (int s = 0; s < PICVR_STATUS_COUNT; s++) {
        names[s] = picvr_status_string((picvr_status)s);
        if (!names[s] || !names[s][0]) fail_msg("picvr_status_string(%d) is NULL or empty", s);
        for (int t = 0; t < s; t++)
            if (strcmp(names[s], names[t]) == 0)
                fail_msg("statuses %d and %d share the name \"%s\"", t, s, names[s]);
    }
    assert_string_equal(picvr_status_string(PICVR_OK), "PICVR_OK");
    assert_string_equal(picvr_status_string(PICVR_ERROR_NON_FINITE), "PICVR_ERROR_NON_FINITE");
    const int bad[] = {PICVR_STATUS_COUNT, PICVR_STATUS_COUNT + 1, 1000, -1, INT32_MAX};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        const char *n = picvr_status_string((picvr_status)bad[i]);
        if (!n || !n[0]) fail_msg("picvr_status_string(%d) (out of range) is NULL or empty", bad[i]);
    }
}

/* picvr_device_type_string names every type distinctly, "other" out of range; the stats
   report the type of the device in use, and the name the Vulkan driver gives agrees with
   it for the drivers we know (lavapipe and SwiftShader are CPU devices). */
void test_device_type_reported(void **state) {
    (void)state;
    const char *names[PICVR_DEVICE_CPU + 1];
    for (int t = 0; t <= PICVR_DEVICE_CPU; t++) {
        names[t] = picvr_device_type_string((picvr_device_type)t);
        if (!names[t] || !names[t][0]) fail_msg("picvr_device_type_string(%d) is NULL or empty", t);
        for (int u = 0; u < t; u++)
            if (strcmp(names[t], names[u]) == 0) fail_msg("types %d and %d share \"%s\"", u, t, names[t]);
    }
    assert_string_equal(picvr_device_type_string(PICVR_DEVICE_CPU), "cpu");
    assert_string_equal(picvr_device_type_string((picvr_device_type)99), "other");
    assert_string_equal(picvr_device_type_string((picvr_device_type)-1), "other");
    picvr_context *ctx = tu_create(0);
    picvr_stats st;
    TU_OK(picvr_get_stats(ctx, &st));
    print_message("    %s: %s\n", st.device_name, picvr_device_type_string(st.device_type));
    assert_true((unsigned)st.device_type <= PICVR_DEVICE_CPU);
    if (strstr(st.device_name, "llvmpipe") || strstr(st.device_name, "SwiftShader"))
        assert_int_equal(st.device_type, PICVR_DEVICE_CPU);
    tu_finish(ctx);
}

static void *dummy_alloc(size_t size, void *user) { (void)user; return malloc(size); }
static void free_hook(void *p, void *user) { (void)user; free(p); }

void test_create_destroy_errors(void **state) {
    (void)state;
    picvr_destroy(NULL); /* allowed */
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.validation = PICVR_SWITCH_ON;
    TU_EXPECT(picvr_create(&cfg, NULL), PICVR_ERROR_NULL_POINTER);

    picvr_context *ctx = (picvr_context *)&cfg; /* must be overwritten with NULL */
    cfg.device_name = "no-such-device-7f3a9c";
    TU_EXPECT(picvr_create(&cfg, &ctx), PICVR_ERROR_NO_DEVICE);
    assert_null(ctx);

    /* "all three functions or none" */
    ctx = (picvr_context *)&cfg;
    cfg.device_name = NULL;
    cfg.allocator.alloc = dummy_alloc;
    TU_EXPECT(picvr_create(&cfg, &ctx), PICVR_ERROR_INVALID_ARGUMENT);
    assert_null(ctx);

    /* A good context still comes up afterwards. */
    ctx = tu_create(0);
    tu_finish(ctx);
}

void test_step_before_volume_and_camera_is_not_ready(void **state) {
    (void)state;
    tu_vol vol = tu_vol_ball(8);
    picvr_context *a = tu_create(0);
    TU_EXPECT(picvr_step(a, 1.0), PICVR_ERROR_NOT_READY);
    TU_EXPECT(picvr_step_iterations(a, 1), PICVR_ERROR_NOT_READY);
    tu_set_camera(a, 0, 0, 20, 0, 0, 0, 30, 8, 8);
    TU_EXPECT(picvr_step_iterations(a, 1), PICVR_ERROR_NOT_READY); /* camera only */
    tu_upload(a, &vol);
    TU_OK(picvr_step_iterations(a, 1));
    tu_finish(a);

    picvr_context *b = tu_create(0);
    tu_upload(b, &vol);
    TU_EXPECT(picvr_step(b, 1.0), PICVR_ERROR_NOT_READY); /* volume only */
    TU_EXPECT(picvr_step_iterations(b, 1), PICVR_ERROR_NOT_READY);
    tu_set_camera(b, 0, 0, 20, 0, 0, 0, 30, 8, 8);
    TU_OK(picvr_step_iterations(b, 1));
    tu_finish(b);
    tu_vol_free(&vol);
}

/* ---- the table --------------------------------------------------------------------------- */

#define W 16
#define H 16

typedef struct table_state {
    picvr_context *ctx;
    const tu_vol *vol;
    float baseline[W * H * 4];
    float img[W * H * 4];
    int failures, rows;
    /* the baseline's transfer function, background and scattering model: BASE_TF, BASE_BG
       and (use_scattering 0) none set, unless a test changes them (the scattering and
       environment rows, which must also keep a non-default state) */
    picvr_tf_point tf[2];
    picvr_background bg;
    picvr_scattering scattering;
    int use_scattering;
} table_state;

/* The baseline scene: ball volume, coloured ramp TF, sun + background, 16x16 camera. */
static const picvr_tf_point BASE_TF[2] = {{0.0f, {0.9f, 0.8f, 0.7f}, 0.0f},
                                          {1.0f, {0.9f, 0.8f, 0.7f}, 1.0f}};
static const picvr_background BASE_BG = {{0.5f, 0.6f, 0.8f}, 0.5f};

static picvr_light base_sun(void) {
    picvr_light sun;
    memset(&sun, 0, sizeof sun);
    sun.type = PICVR_LIGHT_DIRECTIONAL;
    sun.direction[0] = 1; sun.direction[1] = 1; sun.direction[2] = 1;
    sun.color[0] = sun.color[1] = sun.color[2] = 1;
    sun.intensity = 3;
    return sun;
}

static picvr_camera base_camera(void) {
    picvr_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position[2] = 20;
    cam.up[1] = 1;
    cam.fov_y_degrees = 40;
    cam.width = W;
    cam.height = H;
    return cam;
}

/* Sets the whole baseline scene (used at the start and to recover after a failed row,
   so that one failure does not cascade into the following rows). */
static void set_baseline(table_state *t) {
    tu_upload(t->ctx, t->vol);
    TU_OK(picvr_set_transfer_function(t->ctx, t->tf, 2, 0.5f));
    picvr_light sun = base_sun();
    TU_OK(picvr_set_lights(t->ctx, &sun, 1, &t->bg));
    if (t->use_scattering) TU_OK(picvr_set_scattering(t->ctx, &t->scattering));
    picvr_camera cam = base_camera();
    TU_OK(picvr_set_camera(t->ctx, &cam));
}

/* After a failed call the context must still render, and (the previous volume, TF,
   lights and camera kept) give exactly the baseline image: same seed, same iteration
   count -> bit-identical. */
static void check_row(table_state *t, const char *row, picvr_status got, picvr_status want) {
    int failures = t->failures;
    t->rows++;
    if (got != want) {
        print_message("    FAIL %-52s returned %s, expected %s\n", row, picvr_status_string(got),
                      picvr_status_string(want));
        t->failures++;
    }
    picvr_status s1 = picvr_reset(t->ctx);
    picvr_status s2 = picvr_step_iterations(t->ctx, 2);
    picvr_status s3 = picvr_read_rgba32f(t->ctx, t->img, sizeof t->img);
    if (s1 || s2 || s3) {
        print_message("    FAIL after %-46s the context no longer renders (%s, %s, %s)\n", row,
                      picvr_status_string(s1), picvr_status_string(s2), picvr_status_string(s3));
        t->failures++;
    } else if (got == PICVR_OK && want != PICVR_OK) {
        /* the call was (wrongly) accepted: the state changed legitimately */
    } else if (memcmp(t->img, t->baseline, sizeof t->img) != 0) {
        print_message("    FAIL after %-46s the image changed (state not kept)\n", row);
        t->failures++;
    }
    if (t->failures != failures) set_baseline(t);
}

#define ROW(t, name, want, call) check_row((t), (name), (call), (want))

static picvr_volume_desc good_desc(const uint8_t *data) {
    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    d.dims[0] = d.dims[1] = d.dims[2] = 8;
    d.type = PICVR_VOXEL_UINT8;
    d.data = data;
    return d;
}

/* A fresh table: a context (seed 9) with the baseline scene (a ball of radius 8). */
static table_state *table_begin(tu_vol *vol) {
    static table_state T;
    memset(&T, 0, sizeof T);
    memcpy(T.tf, BASE_TF, sizeof T.tf);
    T.bg = BASE_BG;
    T.ctx = tu_create(9);
    *vol = tu_vol_ball(8);
    T.vol = vol;
    set_baseline(&T);
    return &T;
}

void test_bad_inputs_rejected_and_state_kept(void **state) {
    (void)state;
    tu_vol vol;
    table_state *t = table_begin(&vol);   /* baseline scene */
    picvr_context *ctx = t->ctx;
    picvr_tf_point tf[2];
    memcpy(tf, BASE_TF, sizeof tf);
    picvr_light sun = base_sun();
    picvr_background bg = BASE_BG;
    picvr_camera cam = base_camera();
    TU_OK(picvr_step_iterations(ctx, 2));
    TU_OK(picvr_read_rgba32f(ctx, t->baseline, sizeof t->baseline));
    tu_assert_finite(t->baseline, W * H * 4, "baseline");

    uint8_t u8[8 * 8 * 8];
    memset(u8, 100, sizeof u8);
    float f32[8 * 8 * 8];
    for (int i = 0; i < 8 * 8 * 8; i++) f32[i] = (float)i;
    uint8_t rgba8[W * H * 4];
    float rgba32[W * H * 4];
    picvr_stats st;
    float bmin[3], bmax[3];
    picvr_volume_desc d;

    /* -- NULL pointers -- */
    d = good_desc(u8);
    ROW(t, "upload_volume(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_upload_volume(NULL, &d));
    ROW(t, "upload_volume(NULL desc)", PICVR_ERROR_NULL_POINTER, picvr_upload_volume(ctx, NULL));
    d.data = NULL;
    ROW(t, "upload_volume(desc.data NULL)", PICVR_ERROR_NULL_POINTER, picvr_upload_volume(ctx, &d));
    ROW(t, "volume_box(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_volume_box(NULL, bmin, bmax));
    ROW(t, "volume_box(NULL box_min)", PICVR_ERROR_NULL_POINTER, picvr_volume_box(ctx, NULL, bmax));
    ROW(t, "volume_box(NULL box_max)", PICVR_ERROR_NULL_POINTER, picvr_volume_box(ctx, bmin, NULL));
    ROW(t, "set_transfer_function(NULL ctx)", PICVR_ERROR_NULL_POINTER,
        picvr_set_transfer_function(NULL, tf, 2, 1));
    ROW(t, "set_transfer_function(NULL points, count 2)", PICVR_ERROR_NULL_POINTER,
        picvr_set_transfer_function(ctx, NULL, 2, 1));
    ROW(t, "set_lights(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_set_lights(NULL, &sun, 1, &bg));
    ROW(t, "set_lights(NULL lights, count 1)", PICVR_ERROR_NULL_POINTER,
        picvr_set_lights(ctx, NULL, 1, &bg));
    ROW(t, "set_camera(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_set_camera(NULL, &cam));
    ROW(t, "set_camera(NULL camera)", PICVR_ERROR_NULL_POINTER, picvr_set_camera(ctx, NULL));
    ROW(t, "step(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_step(NULL, 1.0));
    ROW(t, "step_iterations(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_step_iterations(NULL, 1));
    ROW(t, "reset(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_reset(NULL));
    ROW(t, "read_rgba8(NULL ctx)", PICVR_ERROR_NULL_POINTER,
        picvr_read_rgba8(NULL, rgba8, sizeof rgba8, 1));
    ROW(t, "read_rgba8(NULL pixels)", PICVR_ERROR_NULL_POINTER,
        picvr_read_rgba8(ctx, NULL, sizeof rgba8, 1));
    ROW(t, "read_rgba32f(NULL ctx)", PICVR_ERROR_NULL_POINTER,
        picvr_read_rgba32f(NULL, rgba32, sizeof rgba32));
    ROW(t, "read_rgba32f(NULL pixels)", PICVR_ERROR_NULL_POINTER,
        picvr_read_rgba32f(ctx, NULL, sizeof rgba32));
    ROW(t, "get_stats(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_get_stats(NULL, &st));
    ROW(t, "get_stats(NULL stats)", PICVR_ERROR_NULL_POINTER, picvr_get_stats(ctx, NULL));
    ROW(t, "set_scheduler(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_set_scheduler(NULL, NULL));

    /* -- scheduler (the full list of bad settings: test_scheduler_config_errors) -- */
    picvr_scheduler_config sc;
    memset(&sc, 0, sizeof sc);
    sc.create_min = NAN;
    ROW(t, "set_scheduler(create_min NaN)", PICVR_ERROR_NON_FINITE, picvr_set_scheduler(ctx, &sc));
    memset(&sc, 0, sizeof sc);
    sc.create_max = 0.8f;
    sc.update_max = 0.2f;
    ROW(t, "set_scheduler(rendering under 10 %)", PICVR_ERROR_INVALID_ARGUMENT, picvr_set_scheduler(ctx, &sc));

    /* -- volume -- */
    for (int a = 0; a < 3; a++) {
        d = good_desc(u8);
        d.dims[a] = 0;
        char name[64];
        snprintf(name, sizeof name, "upload_volume(dims[%d] = 0)", a);
        ROW(t, name, PICVR_ERROR_INVALID_DIMENSIONS, picvr_upload_volume(ctx, &d));
    }
    /* The data pointer is a small buffer: the sizes must be rejected before any read. */
    d = good_desc(u8);
    d.dims[0] = d.dims[1] = d.dims[2] = 65536; /* 2^48 bytes; above any maxImageDimension3D */
    ROW(t, "upload_volume(65536^3 uint8)", PICVR_ERROR_SIZE_OVERFLOW, picvr_upload_volume(ctx, &d));
    d.type = PICVR_VOXEL_FLOAT32;
    d.data = f32;
    ROW(t, "upload_volume(65536^3 float32)", PICVR_ERROR_SIZE_OVERFLOW, picvr_upload_volume(ctx, &d));
    d.dims[0] = d.dims[1] = d.dims[2] = UINT32_MAX; /* ~2^98 bytes: overflows size_t */
    ROW(t, "upload_volume(UINT32_MAX^3 float32)", PICVR_ERROR_SIZE_OVERFLOW,
        picvr_upload_volume(ctx, &d));
    d = good_desc(u8);
    d.dims[0] = UINT32_MAX; d.dims[1] = d.dims[2] = 1;
    ROW(t, "upload_volume(UINT32_MAX x 1 x 1 uint8)", PICVR_ERROR_SIZE_OVERFLOW,
        picvr_upload_volume(ctx, &d));
    d = good_desc(u8);
    d.dims[0] = 2; d.dims[1] = 2; d.dims[2] = UINT32_MAX / 2;
    ROW(t, "upload_volume(2 x 2 x 2^31 uint8)", PICVR_ERROR_SIZE_OVERFLOW,
        picvr_upload_volume(ctx, &d));
    d = good_desc(u8);
    d.type = (picvr_voxel_type)0;
    ROW(t, "upload_volume(type 0)", PICVR_ERROR_UNSUPPORTED_TYPE, picvr_upload_volume(ctx, &d));
    d.type = (picvr_voxel_type)99;
    ROW(t, "upload_volume(type 99)", PICVR_ERROR_UNSUPPORTED_TYPE, picvr_upload_volume(ctx, &d));
    const float nonfinite[3] = {NAN, INFINITY, -INFINITY};
    const char *nf_name[3] = {"NaN", "+Inf", "-Inf"};
    for (int k = 0; k < 3; k++) {
        float saved = f32[300];
        f32[300] = nonfinite[k];
        d = good_desc(u8);
        d.type = PICVR_VOXEL_FLOAT32;
        d.data = f32;
        char name[64];
        snprintf(name, sizeof name, "upload_volume(float32 voxel %s)", nf_name[k]);
        ROW(t, name, PICVR_ERROR_NON_FINITE, picvr_upload_volume(ctx, &d));
        /* Explicit range: the voxels must still be checked ("float32 data must be
           finite"), also when the range is given. */
        d.value_min = 0; d.value_max = 511;
        snprintf(name, sizeof name, "upload_volume(float32 voxel %s, range set)", nf_name[k]);
        ROW(t, name, PICVR_ERROR_NON_FINITE, picvr_upload_volume(ctx, &d));
        f32[300] = saved;
    }
    d = good_desc(u8);
    d.spacing[0] = 1; d.spacing[1] = NAN; d.spacing[2] = 1;
    ROW(t, "upload_volume(spacing NaN)", PICVR_ERROR_NON_FINITE, picvr_upload_volume(ctx, &d));
    d.spacing[1] = INFINITY;
    ROW(t, "upload_volume(spacing Inf)", PICVR_ERROR_NON_FINITE, picvr_upload_volume(ctx, &d));
    d.spacing[1] = -1;
    ROW(t, "upload_volume(spacing -1)", PICVR_ERROR_INVALID_ARGUMENT, picvr_upload_volume(ctx, &d));
    d = good_desc(u8);
    d.value_min = NAN; d.value_max = 1;
    ROW(t, "upload_volume(value_min NaN)", PICVR_ERROR_NON_FINITE, picvr_upload_volume(ctx, &d));

    /* -- transfer function -- */
    picvr_tf_point bad[3] = {{0.0f, {1, 1, 1}, 0.0f}, {0.6f, {1, 1, 1}, 0.5f}, {0.3f, {1, 1, 1}, 1.0f}};
    ROW(t, "set_transfer_function(unsorted)", PICVR_ERROR_INVALID_TRANSFER_FUNCTION,
        picvr_set_transfer_function(ctx, bad, 3, 1));
    ROW(t, "set_transfer_function(count 0)", PICVR_ERROR_INVALID_TRANSFER_FUNCTION,
        picvr_set_transfer_function(ctx, tf, 0, 1));
    static picvr_tf_point many[PICVR_MAX_TF_POINTS + 1];
    for (int i = 0; i <= PICVR_MAX_TF_POINTS; i++) {
        many[i].value = (float)i / (PICVR_MAX_TF_POINTS + 1);
        many[i].albedo[0] = many[i].albedo[1] = many[i].albedo[2] = 1;
        many[i].opacity = 0.5f;
    }
    ROW(t, "set_transfer_function(count MAX + 1)", PICVR_ERROR_INVALID_TRANSFER_FUNCTION,
        picvr_set_transfer_function(ctx, many, PICVR_MAX_TF_POINTS + 1, 1));
    picvr_tf_point one[2];
    struct { const char *name; int field; float v; picvr_status want; } tfrows[] = {
        {"set_transfer_function(value -0.1)", 0, -0.1f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},
        {"set_transfer_function(value 1.1)", 0, 1.1f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},
        {"set_transfer_function(albedo 1.5)", 1, 1.5f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},
        {"set_transfer_function(albedo -0.1)", 1, -0.1f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},
        {"set_transfer_function(opacity -1)", 2, -1.0f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},
        {"set_transfer_function(value NaN)", 0, NAN, PICVR_ERROR_NON_FINITE},
        {"set_transfer_function(albedo NaN)", 1, NAN, PICVR_ERROR_NON_FINITE},
        {"set_transfer_function(opacity Inf)", 2, INFINITY, PICVR_ERROR_NON_FINITE},
    };
    for (size_t i = 0; i < sizeof tfrows / sizeof tfrows[0]; i++) {
        memcpy(one, tf, sizeof one);
        if (tfrows[i].field == 0) one[1].value = tfrows[i].v;
        else if (tfrows[i].field == 1) one[1].albedo[1] = tfrows[i].v;
        else one[1].opacity = tfrows[i].v;
        if (tfrows[i].field == 0 && tfrows[i].v < 0) one[0].value = -0.2f; /* keep sorted */
        ROW(t, tfrows[i].name, tfrows[i].want, picvr_set_transfer_function(ctx, one, 2, 1));
    }
    ROW(t, "set_transfer_function(density -1)", PICVR_ERROR_INVALID_ARGUMENT,
        picvr_set_transfer_function(ctx, tf, 2, -1.0f));
    ROW(t, "set_transfer_function(density NaN)", PICVR_ERROR_NON_FINITE,
        picvr_set_transfer_function(ctx, tf, 2, NAN));
    ROW(t, "set_transfer_function(density Inf)", PICVR_ERROR_NON_FINITE,
        picvr_set_transfer_function(ctx, tf, 2, INFINITY));

    /* -- lights -- */
    picvr_light l;
    picvr_light sphere;
    memset(&sphere, 0, sizeof sphere);
    sphere.type = PICVR_LIGHT_SPHERE;
    sphere.position[0] = 20;
    sphere.radius = 1;
    sphere.color[0] = sphere.color[1] = sphere.color[2] = 1;
    sphere.intensity = 10;
    picvr_light rect = sphere;
    rect.type = PICVR_LIGHT_RECT;
    rect.radius = 0;
    rect.edge_u[1] = 2;
    rect.edge_v[2] = 2;
    picvr_light point = sphere;
    point.type = PICVR_LIGHT_POINT;

    l = sun; l.intensity = -1;
    ROW(t, "set_lights(intensity -1)", PICVR_ERROR_INVALID_LIGHT, picvr_set_lights(ctx, &l, 1, &bg));
    l = sun; l.color[1] = -0.5f;
    ROW(t, "set_lights(colour -0.5)", PICVR_ERROR_INVALID_LIGHT, picvr_set_lights(ctx, &l, 1, &bg));
    l = point; l.position[1] = NAN;
    ROW(t, "set_lights(point position NaN)", PICVR_ERROR_NON_FINITE,
        picvr_set_lights(ctx, &l, 1, &bg));
    l = sphere; l.position[2] = INFINITY;
    ROW(t, "set_lights(sphere position Inf)", PICVR_ERROR_NON_FINITE,
        picvr_set_lights(ctx, &l, 1, &bg));
    l = sun; l.intensity = INFINITY;
    ROW(t, "set_lights(intensity Inf)", PICVR_ERROR_NON_FINITE, picvr_set_lights(ctx, &l, 1, &bg));
    l = sun; l.direction[0] = NAN;
    ROW(t, "set_lights(direction NaN)", PICVR_ERROR_NON_FINITE, picvr_set_lights(ctx, &l, 1, &bg));
    l = sphere; l.radius = 0;
    ROW(t, "set_lights(sphere radius 0)", PICVR_ERROR_INVALID_LIGHT,
        picvr_set_lights(ctx, &l, 1, &bg));
    l = sphere; l.radius = -1;
    ROW(t, "set_lights(sphere radius -1)", PICVR_ERROR_INVALID_LIGHT,
        picvr_set_lights(ctx, &l, 1, &bg));
    l = rect; l.edge_v[1] = 4; l.edge_v[2] = 0; /* parallel to edge_u */
    ROW(t, "set_lights(rect parallel edges)", PICVR_ERROR_INVALID_LIGHT,
        picvr_set_lights(ctx, &l, 1, &bg));
    l = rect; l.edge_u[1] = 0;
    ROW(t, "set_lights(rect zero edge)", PICVR_ERROR_INVALID_LIGHT,
        picvr_set_lights(ctx, &l, 1, &bg));
    l = sun; l.direction[0] = l.direction[1] = l.direction[2] = 0;
    ROW(t, "set_lights(directional zero direction)", PICVR_ERROR_INVALID_LIGHT,
        picvr_set_lights(ctx, &l, 1, &bg));
    l = sun; l.angular_diameter = (float)M_PI;
    ROW(t, "set_lights(angular_diameter pi)", PICVR_ERROR_INVALID_LIGHT,
        picvr_set_lights(ctx, &l, 1, &bg));
    l = sun; l.angular_diameter = -0.1f;
    ROW(t, "set_lights(angular_diameter -0.1)", PICVR_ERROR_INVALID_LIGHT,
        picvr_set_lights(ctx, &l, 1, &bg));
    l = sun; l.type = (picvr_light_type)0;
    ROW(t, "set_lights(type 0)", PICVR_ERROR_INVALID_LIGHT, picvr_set_lights(ctx, &l, 1, &bg));
    l = sun; l.type = (picvr_light_type)99;
    ROW(t, "set_lights(type 99)", PICVR_ERROR_INVALID_LIGHT, picvr_set_lights(ctx, &l, 1, &bg));
    static picvr_light lots[PICVR_MAX_LIGHTS + 1];
    for (int i = 0; i <= PICVR_MAX_LIGHTS; i++) lots[i] = point;
    ROW(t, "set_lights(count MAX + 1)", PICVR_ERROR_TOO_MANY_LIGHTS,
        picvr_set_lights(ctx, lots, PICVR_MAX_LIGHTS + 1, &bg));
    lots[3].intensity = -1; /* the last valid count with one bad light: still rejected */
    ROW(t, "set_lights(MAX lights, one negative)", PICVR_ERROR_INVALID_LIGHT,
        picvr_set_lights(ctx, lots, PICVR_MAX_LIGHTS, &bg));
    picvr_background bbad = bg;
    bbad.intensity = -1;
    ROW(t, "set_lights(background intensity -1)", PICVR_ERROR_INVALID_LIGHT,
        picvr_set_lights(ctx, &sun, 1, &bbad));
    bbad = bg; bbad.color[2] = NAN;
    ROW(t, "set_lights(background colour NaN)", PICVR_ERROR_NON_FINITE,
        picvr_set_lights(ctx, &sun, 1, &bbad));

    /* -- camera -- */
    picvr_camera c;
    c = cam; c.width = 0;
    ROW(t, "set_camera(width 0)", PICVR_ERROR_INVALID_DIMENSIONS, picvr_set_camera(ctx, &c));
    c = cam; c.height = 0;
    ROW(t, "set_camera(height 0)", PICVR_ERROR_INVALID_DIMENSIONS, picvr_set_camera(ctx, &c));
    c = cam; c.width = PICVR_MAX_IMAGE_SIZE + 1;
    ROW(t, "set_camera(width MAX + 1)", PICVR_ERROR_SIZE_OVERFLOW, picvr_set_camera(ctx, &c));
    c = cam; c.height = UINT32_MAX;
    ROW(t, "set_camera(height UINT32_MAX)", PICVR_ERROR_SIZE_OVERFLOW, picvr_set_camera(ctx, &c));
    c = cam; memcpy(c.target, c.position, sizeof c.target);
    ROW(t, "set_camera(position == target)", PICVR_ERROR_INVALID_CAMERA, picvr_set_camera(ctx, &c));
    c = cam; c.up[0] = 0; c.up[1] = 0; c.up[2] = -3; /* parallel to the view (0,0,-1) */
    ROW(t, "set_camera(up parallel to view)", PICVR_ERROR_INVALID_CAMERA, picvr_set_camera(ctx, &c));
    c = cam; c.fov_y_degrees = 180;
    ROW(t, "set_camera(fov 180)", PICVR_ERROR_INVALID_CAMERA, picvr_set_camera(ctx, &c));
    c = cam; c.fov_y_degrees = 179.5f;
    ROW(t, "set_camera(fov 179.5)", PICVR_ERROR_INVALID_CAMERA, picvr_set_camera(ctx, &c));
    c = cam; c.fov_y_degrees = -10;
    ROW(t, "set_camera(fov -10)", PICVR_ERROR_INVALID_CAMERA, picvr_set_camera(ctx, &c));
    c = cam; c.position[0] = NAN;
    ROW(t, "set_camera(position NaN)", PICVR_ERROR_NON_FINITE, picvr_set_camera(ctx, &c));
    c = cam; c.fov_y_degrees = NAN;
    ROW(t, "set_camera(fov NaN)", PICVR_ERROR_NON_FINITE, picvr_set_camera(ctx, &c));

    /* -- read buffers -- */
    ROW(t, "read_rgba8(size w*h*4 - 1)", PICVR_ERROR_BUFFER_TOO_SMALL,
        picvr_read_rgba8(ctx, rgba8, sizeof rgba8 - 1, 1));
    ROW(t, "read_rgba8(size 0)", PICVR_ERROR_BUFFER_TOO_SMALL, picvr_read_rgba8(ctx, rgba8, 0, 1));
    ROW(t, "read_rgba32f(size w*h*16 - 1)", PICVR_ERROR_BUFFER_TOO_SMALL,
        picvr_read_rgba32f(ctx, rgba32, sizeof rgba32 - 1));
    ROW(t, "read_rgba32f(size w*h*4 floats as bytes/4)", PICVR_ERROR_BUFFER_TOO_SMALL,
        picvr_read_rgba32f(ctx, rgba32, W * H * 4));

    /* -- the good calls still work (the rows above changed nothing) -- */
    d = good_desc(u8);
    TU_OK(picvr_upload_volume(ctx, &d));
    tu_upload(ctx, &vol);
    check_row(t, "re-upload of the baseline volume", PICVR_OK, PICVR_OK);

    print_message("    %d rows, %d failure(s)\n", t->rows, t->failures);
    tu_vol_free(&vol);
    if (t->failures) fail_msg("%d of %d rows failed (listed above)", t->failures, t->rows);
    tu_finish(ctx);
}

/* ---- issue 6: the rest of the API, configs, wrong order, device limits ------------------- */

/* The functions and arguments the table above does not reach: picvr_set_view, the step
   time, read exposure, huge products of valid-looking numbers (spacing x dims, density x
   opacity), a volume larger than the device can allocate.  Same rules: the specific code,
   then the context renders the bit-identical baseline image. */
void test_bad_inputs_rest_of_api_and_device_limits(void **state) {
    (void)state;
    tu_vol vol;
    table_state *t = table_begin(&vol);
    picvr_context *ctx = t->ctx;
    TU_OK(picvr_step_iterations(ctx, 2));
    TU_OK(picvr_read_rgba32f(ctx, t->baseline, sizeof t->baseline));

    /* set_view */
    ROW(t, "set_view(NULL ctx)", PICVR_ERROR_NULL_POINTER, picvr_set_view(NULL, PICVR_VIEW_IMAGE));
    ROW(t, "set_view(3)", PICVR_ERROR_INVALID_ARGUMENT, picvr_set_view(ctx, (picvr_debug_view)3));
    ROW(t, "set_view(-1)", PICVR_ERROR_INVALID_ARGUMENT, picvr_set_view(ctx, (picvr_debug_view)-1));
    ROW(t, "set_view(CACHE) with the cache off", PICVR_ERROR_NOT_READY,
        picvr_set_view(ctx, PICVR_VIEW_CACHE));
    ROW(t, "set_view(CACHE_ERROR) with the cache off", PICVR_ERROR_NOT_READY,
        picvr_set_view(ctx, PICVR_VIEW_CACHE_ERROR));

    /* step time: NaN/Inf are non-finite input, negative is out of range */
    ROW(t, "step(NaN ms)", PICVR_ERROR_NON_FINITE, picvr_step(ctx, NAN));
    ROW(t, "step(+Inf ms)", PICVR_ERROR_NON_FINITE, picvr_step(ctx, INFINITY));
    ROW(t, "step(-Inf ms)", PICVR_ERROR_NON_FINITE, picvr_step(ctx, -INFINITY));
    ROW(t, "step(-1 ms)", PICVR_ERROR_INVALID_ARGUMENT, picvr_step(ctx, -1.0));
    ROW(t, "step_iterations(0) is a no-op", PICVR_OK, picvr_step_iterations(ctx, 0));

    /* read buffers: a size that wraps when multiplied */
    uint8_t rgba8[W * H * 4];
    ROW(t, "read_rgba8(size SIZE_MAX)", PICVR_OK, picvr_read_rgba8(ctx, rgba8, SIZE_MAX, 1));
    /* "exposure <= 0 means 1": 0 and -1 give exactly the exposure-1 bytes */
    uint8_t ref8[W * H * 4], got8[W * H * 4];
    TU_OK(picvr_reset(ctx));
    TU_OK(picvr_step_iterations(ctx, 2));
    TU_OK(picvr_read_rgba8(ctx, ref8, sizeof ref8, 1.0f));
    const float expo[2] = {0.0f, -1.0f};
    for (int i = 0; i < 2; i++) {
        TU_OK(picvr_read_rgba8(ctx, got8, sizeof got8, expo[i]));
        if (memcmp(got8, ref8, sizeof ref8) != 0) fail_msg("read_rgba8(exposure %g) differs from exposure 1", (double)expo[i]);
    }

    /* volumes: a box whose size overflows a float, voxel sizes at the float limits, a
       value range given reversed, volumes larger than one device allocation */
    uint8_t u8[8 * 8 * 8];
    memset(u8, 100, sizeof u8);
    picvr_volume_desc d = good_desc(u8);
    d.spacing[0] = 3e38f; d.spacing[1] = d.spacing[2] = 1;
    ROW(t, "upload_volume(spacing 3e38: box size overflows)", PICVR_ERROR_INVALID_ARGUMENT,
        picvr_upload_volume(ctx, &d));
    d.spacing[0] = d.spacing[1] = d.spacing[2] = 1e38f;
    ROW(t, "upload_volume(spacing 1e38^3: diagonal overflows)", PICVR_ERROR_INVALID_ARGUMENT,
        picvr_upload_volume(ctx, &d));
    d = good_desc(u8);
    d.value_min = 10; d.value_max = 5;
    ROW(t, "upload_volume(value_min > value_max)", PICVR_ERROR_INVALID_ARGUMENT, picvr_upload_volume(ctx, &d));
    d.value_min = -INFINITY; d.value_max = 5;
    ROW(t, "upload_volume(value_min -Inf)", PICVR_ERROR_NON_FINITE, picvr_upload_volume(ctx, &d));
    /* Within maxImageDimension3D (>= 2048 on every Vulkan device) but 8 GiB / 32 GiB:
       above maxMemoryAllocationSize (2 GiB on lavapipe) -> OUT_OF_DEVICE_MEMORY before
       anything is allocated or read (the data pointer is a small buffer). */
    picvr_stats st;
    TU_OK(picvr_get_stats(ctx, &st));
    d = good_desc(u8);
    d.dims[0] = d.dims[1] = d.dims[2] = 2048;
    ROW(t, "upload_volume(2048^3 uint8 = 8 GiB)", PICVR_ERROR_OUT_OF_DEVICE_MEMORY, picvr_upload_volume(ctx, &d));
    d.type = PICVR_VOXEL_FLOAT32;
    d.value_min = 0; d.value_max = 1;
    /* float32 voxels are scanned for finiteness before the device is asked: the size
       check must come first (reading 32 GiB from an 2 KiB buffer would crash) */
    ROW(t, "upload_volume(2048^3 float32 = 32 GiB)", PICVR_ERROR_OUT_OF_DEVICE_MEMORY,
        picvr_upload_volume(ctx, &d));

    /* transfer function: sigma_t = D * opacity overflows a float */
    picvr_tf_point big[2] = {{0.0f, {1, 1, 1}, 1e30f}, {1.0f, {1, 1, 1}, 1e30f}};
    ROW(t, "set_transfer_function(opacity 1e30, D 1e30)", PICVR_ERROR_INVALID_ARGUMENT,
        picvr_set_transfer_function(ctx, big, 2, 1e30f));
    picvr_tf_point sub[1] = {{0.5f, {1, 1, 1}, 1e-40f}}; /* denormal opacity: valid */
    TU_OK(picvr_set_transfer_function(ctx, sub, 1, 1.0f)); /* accepted: state changes */
    set_baseline(t);

    /* lights: NULL background with lights is valid ("background may be NULL") */
    picvr_light sun = base_sun();
    TU_OK(picvr_set_lights(ctx, NULL, 0, NULL)); /* accepted: state changes */
    set_baseline(t);
    picvr_light l = sun;
    l.type = PICVR_LIGHT_SPHERE; l.radius = NAN;
    ROW(t, "set_lights(sphere radius NaN)", PICVR_ERROR_NON_FINITE, picvr_set_lights(ctx, &l, 1, NULL));
    l = sun; l.angular_diameter = NAN;
    ROW(t, "set_lights(angular_diameter NaN)", PICVR_ERROR_NON_FINITE, picvr_set_lights(ctx, &l, 1, NULL));
    l = sun; l.type = PICVR_LIGHT_RECT; l.edge_u[0] = 1; l.edge_v[1] = INFINITY;
    ROW(t, "set_lights(rect edge Inf)", PICVR_ERROR_NON_FINITE, picvr_set_lights(ctx, &l, 1, NULL));

    /* camera: up NaN, target Inf */
    picvr_camera c = base_camera();
    c.up[1] = NAN;
    ROW(t, "set_camera(up NaN)", PICVR_ERROR_NON_FINITE, picvr_set_camera(ctx, &c));
    c = base_camera(); c.target[2] = -INFINITY;
    ROW(t, "set_camera(target -Inf)", PICVR_ERROR_NON_FINITE, picvr_set_camera(ctx, &c));
    c = base_camera(); c.width = PICVR_MAX_IMAGE_SIZE; c.height = PICVR_MAX_IMAGE_SIZE;
    /* 16384^2 pixels x 16 bytes = 4 GiB per plane: above maxStorageBufferRange on
       lavapipe (128 MiB) and on most GPUs (<= 4 GiB - 1) */
    ROW(t, "set_camera(16384 x 16384: planes exceed the device)", PICVR_ERROR_SIZE_OVERFLOW,
        picvr_set_camera(ctx, &c));

    print_message("    %d rows, %d failure(s)\n", t->rows, t->failures);
    tu_vol_free(&vol);
    if (t->failures) fail_msg("%d of %d rows failed (listed above)", t->failures, t->rows);
    tu_finish(ctx);
}

/* ---- multiple scattering, the phase function, environment maps -------------------------- */

#define ENV_BIG (PICVR_MAX_ENV_SIZE + 1)
static float env_ones[ENV_BIG * 3];   /* a valid map of up to ENV_BIG texels (all 1) */

/* The rows of the new fields against the table's current baseline; `pass` names it.
   Every row starts from the baseline's own TF, background and scattering model and
   changes one thing. */
static void scattering_environment_rows(table_state *t, const char *pass) {
    picvr_context *ctx = t->ctx;
    picvr_light sun = base_sun();
    char name[192];
#define PROW(want, call, ...)                                                        \
    do {                                                                             \
        int n_ = snprintf(name, sizeof name, "[%s] ", pass);                         \
        snprintf(name + n_, sizeof name - (size_t)n_, __VA_ARGS__);                  \
        ROW(t, name, (want), (call));                                                \
    } while (0)
    picvr_scattering sc0;
    memset(&sc0, 0, sizeof sc0);
    if (t->use_scattering) sc0 = t->scattering;
    picvr_scattering sc;

    /* NULL context */
    PROW(PICVR_ERROR_NULL_POINTER, picvr_set_scattering(NULL, &sc0), "set_scattering(NULL ctx)");
    PROW(PICVR_ERROR_NULL_POINTER, picvr_set_scattering(NULL, NULL), "set_scattering(NULL ctx, NULL)");

    /* picvr_tf_point.g, on either point */
    const struct { float g; picvr_status want; } grows[] = {
        {1.0f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},  {-1.0f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},
        {1.5f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},  {-7.0f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},
        {1.0000001f, PICVR_ERROR_INVALID_TRANSFER_FUNCTION},
        {NAN, PICVR_ERROR_NON_FINITE}, {INFINITY, PICVR_ERROR_NON_FINITE}, {-INFINITY, PICVR_ERROR_NON_FINITE},
    };
    for (size_t i = 0; i < sizeof grows / sizeof grows[0]; i++)
        for (int pt = 0; pt < 2; pt++) {
            picvr_tf_point tf[2];
            memcpy(tf, t->tf, sizeof tf);
            tf[pt].g = grows[i].g;
            PROW(grows[i].want, picvr_set_transfer_function(ctx, tf, 2, 0.5f),
                 "set_transfer_function(point %d g %g)", pt, (double)grows[i].g);
        }

    /* picvr_scattering: back_g in (-1, 1), back_weight in [0, 1) */
    const struct { float back_g, back_weight; picvr_status want; } srows[] = {
        {1.0f, 0.2f, PICVR_ERROR_INVALID_ARGUMENT},   {-1.0f, 0.2f, PICVR_ERROR_INVALID_ARGUMENT},
        {2.5f, 0.2f, PICVR_ERROR_INVALID_ARGUMENT},   {-1.0000001f, 0.2f, PICVR_ERROR_INVALID_ARGUMENT},
        {NAN, 0.2f, PICVR_ERROR_NON_FINITE},          {INFINITY, 0.2f, PICVR_ERROR_NON_FINITE},
        {-INFINITY, 0.2f, PICVR_ERROR_NON_FINITE},
        {NAN, 0.0f, PICVR_ERROR_NON_FINITE},          /* a NaN anywhere, even in an unused lobe */
        {-0.3f, -0.1f, PICVR_ERROR_INVALID_ARGUMENT}, {-0.3f, -1e-30f, PICVR_ERROR_INVALID_ARGUMENT},
        {-0.3f, 1.0f, PICVR_ERROR_INVALID_ARGUMENT},  {-0.3f, 1.5f, PICVR_ERROR_INVALID_ARGUMENT},
        {-0.3f, NAN, PICVR_ERROR_NON_FINITE},         {-0.3f, INFINITY, PICVR_ERROR_NON_FINITE},
        {-0.3f, -INFINITY, PICVR_ERROR_NON_FINITE},
    };
    for (size_t i = 0; i < sizeof srows / sizeof srows[0]; i++) {
        sc = sc0;
        sc.back_g = srows[i].back_g;
        sc.back_weight = srows[i].back_weight;
        PROW(srows[i].want, picvr_set_scattering(ctx, &sc), "set_scattering(back_g %g, back_weight %g)",
             (double)srows[i].back_g, (double)srows[i].back_weight);
    }
    sc = sc0;   /* a bad weight with unlimited bounces: nothing of it applies */
    sc.max_bounces = PICVR_BOUNCES_UNLIMITED;
    sc.back_weight = 1.0f;
    PROW(PICVR_ERROR_INVALID_ARGUMENT, picvr_set_scattering(ctx, &sc), "set_scattering(unlimited, back_weight 1)");

    /* environment maps: 8x4 texels unless stated */
    float map[8 * 4 * 3];
    for (int i = 0; i < 8 * 4 * 3; i++) map[i] = 0.5f + 0.01f * (float)i;
    picvr_background b;
#define ENV(w_, h_, data_) (b = t->bg, b.environment = (data_), b.env_width = (w_), b.env_height = (h_), &b)
    PROW(PICVR_ERROR_INVALID_DIMENSIONS, picvr_set_lights(ctx, &sun, 1, ENV(0, 4, map)), "set_lights(env width 0)");
    PROW(PICVR_ERROR_INVALID_DIMENSIONS, picvr_set_lights(ctx, &sun, 1, ENV(8, 0, map)), "set_lights(env height 0)");
    PROW(PICVR_ERROR_INVALID_DIMENSIONS, picvr_set_lights(ctx, &sun, 1, ENV(0, 0, map)), "set_lights(env 0 x 0)");
    /* above the limit with a buffer that holds the texels (a library that accepted the
       size reads valid memory and only the code is wrong) */
    PROW(PICVR_ERROR_SIZE_OVERFLOW, picvr_set_lights(ctx, &sun, 1, ENV(ENV_BIG, 1, env_ones)),
         "set_lights(env width MAX + 1)");
    PROW(PICVR_ERROR_SIZE_OVERFLOW, picvr_set_lights(ctx, &sun, 1, ENV(1, ENV_BIG, env_ones)),
         "set_lights(env height MAX + 1)");
    /* a small buffer: the size must be rejected before any texel is read (UINT32_MAX^2 *
       12 bytes also overflows 64 bits) */
    PROW(PICVR_ERROR_SIZE_OVERFLOW, picvr_set_lights(ctx, &sun, 1, ENV(UINT32_MAX, UINT32_MAX, map)),
         "set_lights(env UINT32_MAX x UINT32_MAX)");
    PROW(PICVR_ERROR_SIZE_OVERFLOW, picvr_set_lights(ctx, &sun, 1, ENV(65536, 65536, map)),
         "set_lights(env 65536 x 65536)");
    const struct { float v; picvr_status want; const char *what; } trows[] = {
        {NAN, PICVR_ERROR_NON_FINITE, "NaN"}, {INFINITY, PICVR_ERROR_NON_FINITE, "+Inf"},
        {-INFINITY, PICVR_ERROR_NON_FINITE, "-Inf"}, {-1.0f, PICVR_ERROR_INVALID_LIGHT, "-1"},
        {-1e-30f, PICVR_ERROR_INVALID_LIGHT, "-1e-30"},
    };
    for (size_t i = 0; i < sizeof trows / sizeof trows[0]; i++)
        for (int where = 0; where < 2; where++) {   /* the first texel's R, a middle texel's G */
            size_t k = where ? 3 * 13 + 1 : 0;
            float saved = map[k];
            map[k] = trows[i].v;
            PROW(trows[i].want, picvr_set_lights(ctx, &sun, 1, ENV(8, 4, map)), "set_lights(env texel %zu = %s)",
                 k / 3, trows[i].what);
            map[k] = saved;
        }
    float black[8 * 4 * 3];
    memset(black, 0, sizeof black);
    PROW(PICVR_ERROR_INVALID_LIGHT, picvr_set_lights(ctx, &sun, 1, ENV(8, 4, black)), "set_lights(env all black)");
    PROW(PICVR_ERROR_INVALID_LIGHT, picvr_set_lights(ctx, NULL, 0, ENV(8, 4, black)),
         "set_lights(no lights, env all black)");
    const float rots[3] = {NAN, INFINITY, -INFINITY};
    for (int i = 0; i < 3; i++) {
        b = t->bg;
        b.environment = map; b.env_width = 8; b.env_height = 4;
        b.env_rotation = rots[i];
        PROW(PICVR_ERROR_NON_FINITE, picvr_set_lights(ctx, &sun, 1, &b), "set_lights(env_rotation %g)", (double)rots[i]);
    }
    b = t->bg;   /* a constant background: the rotation is unused, but a NaN anywhere */
    b.environment = NULL; b.env_width = 0; b.env_height = 0;
    b.env_rotation = NAN;
    PROW(PICVR_ERROR_NON_FINITE, picvr_set_lights(ctx, &sun, 1, &b), "set_lights(no env, env_rotation NaN)");
#undef ENV
#undef PROW
}

/* Hostile values of every new field (picvr_tf_point.g, picvr_scattering, the environment
   map of picvr_background), the table's rules: the specific code, then the context renders
   the bit-identical baseline image.  Twice: over the default baseline (one lobe, g 0,
   single scattering, constant background), and over a baseline that uses the new fields
   (TF g 0.5 and -0.2, scattering {2, -0.3, 0.2}, a 16x8 map rotated by 0.4), so that a
   rejected call must also keep that state rather than fall back to the defaults.  Valid
   values at the edges are accepted. */
void test_bad_inputs_scattering_and_environment(void **state) {
    (void)state;
    for (size_t i = 0; i < ENV_BIG * 3; i++) env_ones[i] = 1.0f;
    tu_vol vol;
    table_state *t = table_begin(&vol);
    picvr_context *ctx = t->ctx;
    TU_OK(picvr_step_iterations(ctx, 2));
    TU_OK(picvr_read_rgba32f(ctx, t->baseline, sizeof t->baseline));
    scattering_environment_rows(t, "default");

    /* valid: NULL and explicit zeros are the default model, the image is the baseline's */
    picvr_scattering sc;
    memset(&sc, 0, sizeof sc);
    ROW(t, "set_scattering(ctx, NULL) on the default state", PICVR_OK, picvr_set_scattering(ctx, NULL));
    ROW(t, "set_scattering(zeros) on the default state", PICVR_OK, picvr_set_scattering(ctx, &sc));
    /* valid edges (accepted: the state changes, so the baseline is set again after) */
    sc.max_bounces = PICVR_BOUNCES_UNLIMITED - 1; sc.back_g = -0.9999f; sc.back_weight = 0.9999f;
    TU_OK(picvr_set_scattering(ctx, &sc));
    sc.max_bounces = PICVR_BOUNCES_UNLIMITED; sc.back_g = 0.9999f; sc.back_weight = 0.0f;
    TU_OK(picvr_set_scattering(ctx, &sc));
    TU_OK(picvr_set_scattering(ctx, NULL));
    picvr_tf_point tfe[2];
    memcpy(tfe, t->tf, sizeof tfe);
    tfe[0].g = -0.9999f; tfe[1].g = 0.9999f;
    TU_OK(picvr_set_transfer_function(ctx, tfe, 2, 0.5f));
    picvr_light sun = base_sun();
    picvr_background b = t->bg;
    b.environment = env_ones; b.env_width = 1; b.env_height = 1;
    TU_OK(picvr_set_lights(ctx, &sun, 1, &b));
    b.env_width = PICVR_MAX_ENV_SIZE; b.env_height = 1; b.env_rotation = -1e3f;
    TU_OK(picvr_set_lights(ctx, &sun, 1, &b));
    b.env_width = 1; b.env_height = PICVR_MAX_ENV_SIZE; b.env_rotation = 0;
    TU_OK(picvr_set_lights(ctx, &sun, 1, &b));
    set_baseline(t);
    check_row(t, "the default state set again", PICVR_OK, PICVR_OK);

    /* a baseline that uses the new fields */
    static float map[16 * 8 * 3];
    for (int r = 0; r < 8; r++)
        for (int c = 0; c < 16; c++)
            for (int k = 0; k < 3; k++)
                map[3 * (r * 16 + c) + k] = 0.2f + 0.1f * (float)k + 0.5f * (float)(r < 4) * (0.5f + 0.5f * (float)sin(c * 0.4));
    t->tf[0].g = 0.5f;
    t->tf[1].g = -0.2f;
    t->bg.environment = map;
    t->bg.env_width = 16;
    t->bg.env_height = 8;
    t->bg.env_rotation = 0.4f;
    t->scattering.max_bounces = 2;
    t->scattering.back_g = -0.3f;
    t->scattering.back_weight = 0.2f;
    t->use_scattering = 1;
    float first[W * H * 4];
    memcpy(first, t->baseline, sizeof first);
    set_baseline(t);
    TU_OK(picvr_reset(ctx));
    TU_OK(picvr_step_iterations(ctx, 2));
    TU_OK(picvr_read_rgba32f(ctx, t->baseline, sizeof t->baseline));
    tu_assert_finite(t->baseline, W * H * 4, "baseline with the new fields");
    if (memcmp(first, t->baseline, sizeof first) == 0)
        fail_msg("the baseline with g, two lobes, 2 bounces and a map renders the default image: the rows "
                 "below could not tell a reset to the defaults");
    scattering_environment_rows(t, "g, two lobes, map");

    print_message("    %d rows, %d failure(s)\n", t->rows, t->failures);
    tu_vol_free(&vol);
    if (t->failures) fail_msg("%d of %d rows failed (listed above)", t->failures, t->rows);
    tu_finish(ctx);
}

/* Calls in the wrong order on fresh contexts: each gives NOT_READY (or OK where the
   header allows it), and the context then works normally. */
void test_calls_in_wrong_order(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(3);
    float bmin[3], bmax[3];
    float px[16];
    uint8_t px8[16];
    picvr_stats st;
    TU_EXPECT(picvr_volume_box(ctx, bmin, bmax), PICVR_ERROR_NOT_READY);   /* no volume */
    TU_EXPECT(picvr_read_rgba32f(ctx, px, sizeof px), PICVR_ERROR_NOT_READY); /* no camera */
    TU_EXPECT(picvr_read_rgba8(ctx, px8, sizeof px8, 1), PICVR_ERROR_NOT_READY);
    TU_OK(picvr_get_stats(ctx, &st));                                      /* all zero */
    if (st.iterations != 0 || st.width != 0 || st.mean_luminance != 0) fail_msg("stats of a fresh context not zero");
    TU_OK(picvr_reset(ctx));                                               /* nothing to reset */
    TU_OK(picvr_set_view(ctx, PICVR_VIEW_IMAGE));
    /* lights and TF before a volume are valid and kept */
    tu_tf_ramp(ctx, 0.9f, 0.9f, 0.9f, 1.0f);
    tu_sun(ctx, 0, 0, 1, 1, 1, 1, 3, 0.5f);
    TU_EXPECT(picvr_step_iterations(ctx, 1), PICVR_ERROR_NOT_READY);
    tu_set_camera(ctx, 0, 0, 20, 0, 0, 0, 30, 2, 2);
    TU_OK(picvr_read_rgba32f(ctx, px, sizeof px));                         /* zero image */
    for (int i = 0; i < 16; i++) if (px[i] != 0) fail_msg("image before any iteration not zero");
    tu_vol vol = tu_vol_ball(8);
    tu_upload(ctx, &vol);
    TU_OK(picvr_step_iterations(ctx, 2));
    TU_OK(picvr_read_rgba32f(ctx, px, sizeof px));
    tu_assert_finite(px, 16, "after the wrong-order calls");
    TU_OK(picvr_volume_box(ctx, bmin, bmax));
    /* destroy in the middle of nothing, twice over contexts */
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* Bad picvr_config fields: picvr_create returns the code, *out is NULL, nothing leaks
   (make test-asan checks), and a good context comes up afterwards. */
void test_create_config_errors(void **state) {
    (void)state;
    picvr_config base;
    memset(&base, 0, sizeof base);
    base.validation = PICVR_SWITCH_ON;
    int failures = 0, n = 0;
#define CFG_ROW(label, want, stmt)                                                                 \
    do {                                                                                           \
        picvr_config cfg = base;                                                                   \
        stmt;                                                                                      \
        picvr_context *out = (picvr_context *)&cfg;                                                \
        picvr_status got = picvr_create(&cfg, &out);                                               \
        n++;                                                                                       \
        if (got != (want) || out != NULL) {                                                        \
            print_message("    FAIL %-50s returned %s (out %s), expected %s\n", label,              \
                          picvr_status_string(got), out ? "set" : "NULL", picvr_status_string(want)); \
            failures++;                                                                            \
            if (got == PICVR_OK) picvr_destroy(out);                                               \
        }                                                                                          \
    } while (0)
    CFG_ROW("log_level 99", PICVR_ERROR_INVALID_ARGUMENT, cfg.log_level = (picvr_log_level)99);
    CFG_ROW("validation 7", PICVR_ERROR_INVALID_ARGUMENT, cfg.validation = (picvr_switch)7);
    CFG_ROW("distance_sampling 5", PICVR_ERROR_INVALID_ARGUMENT, cfg.distance_sampling = (picvr_distance_sampling)5);
    CFG_ROW("distance_sampling -1", PICVR_ERROR_INVALID_ARGUMENT, cfg.distance_sampling = (picvr_distance_sampling)-1);
    CFG_ROW("transmittance 4", PICVR_ERROR_INVALID_ARGUMENT, cfg.transmittance = (picvr_transmittance_estimator)4);
    CFG_ROW("transmittance -1", PICVR_ERROR_INVALID_ARGUMENT, cfg.transmittance = (picvr_transmittance_estimator)-1);
    CFG_ROW("kernel_pruning 3", PICVR_ERROR_INVALID_ARGUMENT, cfg.kernel_pruning = (picvr_switch)3);
    CFG_ROW("kernel_pruning -1", PICVR_ERROR_INVALID_ARGUMENT, cfg.kernel_pruning = (picvr_switch)-1);
    CFG_ROW("vulkan.device without instance/queue", PICVR_ERROR_INVALID_ARGUMENT, cfg.vulkan.device = (void *)&cfg);
    CFG_ROW("allocator free only", PICVR_ERROR_INVALID_ARGUMENT, cfg.allocator.free = free_hook);
    /* cache */
    CFG_ROW("cache.mode 99", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.mode = (picvr_cache_mode)99);
    CFG_ROW("cache.mode AUTO + 1", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.mode = (picvr_cache_mode)(PICVR_CACHE_AUTO + 1));
    CFG_ROW("cache.mode AUTO, blend OFF", PICVR_ERROR_INVALID_ARGUMENT,
            (cfg.cache.mode = PICVR_CACHE_AUTO, cfg.cache.blend = PICVR_SWITCH_OFF));
    CFG_ROW("cache.gamma NaN", PICVR_ERROR_NON_FINITE, cfg.cache.gamma = NAN);
    CFG_ROW("cache.epsilon -0.1", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.epsilon = -0.1f);
    CFG_ROW("cache.epsilon 1", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.epsilon = 1.0f);
    CFG_ROW("cache.delta_voxels Inf", PICVR_ERROR_NON_FINITE, cfg.cache.delta_voxels = INFINITY);
    CFG_ROW("cache.radius_max < radius_min", PICVR_ERROR_INVALID_ARGUMENT,
            (cfg.cache.radius_min_voxels = 4, cfg.cache.radius_max_voxels = 2));
    CFG_ROW("cache.rebuild_interval_ms -1", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.rebuild_interval_ms = -1);
    CFG_ROW("cache.superpixel_size 5000", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.superpixel_size = 5000);
    CFG_ROW("cache.curvature_limit 7", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.curvature_limit = (picvr_switch)7);
    CFG_ROW("cache.medium_model 7", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.medium_model = (picvr_switch)7);
    CFG_ROW("cache.max_lookup_refs 8193", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.max_lookup_refs = 8193);
    CFG_ROW("cache.lookup_event 9", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.lookup_event = PICVR_CACHE_MAX_LOOKUP_EVENT + 1);
    CFG_ROW("cache.lookup_event UINT32_MAX", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.lookup_event = UINT32_MAX);
    CFG_ROW("cache.blend 7", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.blend = (picvr_switch)7);
    CFG_ROW("cache.probe_fraction 1.5", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.probe_fraction = 1.5f);
    CFG_ROW("cache.probe_fraction -0.1", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.probe_fraction = -0.1f);
    CFG_ROW("cache.probe_fraction NaN", PICVR_ERROR_NON_FINITE, cfg.cache.probe_fraction = NAN);
    CFG_ROW("cache.max_entries 2^25", PICVR_ERROR_SIZE_OVERFLOW, cfg.cache.max_entries = 1u << 25);
    CFG_ROW("cache.max_nodes 100 (< pre-built top)", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.max_nodes = 100);
    CFG_ROW("cache.max_refs 1", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.max_refs = 1);
    CFG_ROW("cache.max_samples 8193", PICVR_ERROR_INVALID_ARGUMENT, cfg.cache.max_samples = PICVR_CACHE_MAX_SAMPLES + 1);
    /* more than 6 rounds of the creation procedure would pass llvmpipe's loop bound */
    if (tu_device_is_cpu())
        CFG_ROW("cache.max_samples 769 on a CPU device", PICVR_ERROR_INVALID_ARGUMENT,
                (cfg.cache.mode = PICVR_CACHE_OBJECT_SPACE, cfg.cache.max_samples = PICVR_CACHE_MAX_SAMPLES_CPU + 1));
    else
        tu_partial_skip("the row cache.max_samples 769 is for CPU devices");
    /* a pool larger than the device's storage-buffer range: the cache on, the pool
       cannot be created.  2^28 nodes x 16 B = 4 GiB, above every device's (a uint32);
       2^24 entries x 144 B = 2.25 GiB is above lavapipe's 128 MiB but within an
       NVIDIA H200's 4 GiB, where such a context is valid (2026-11-30) */
    CFG_ROW("cache pool 2^28 nodes (4 GiB)", PICVR_ERROR_SIZE_OVERFLOW,
            (cfg.cache.mode = PICVR_CACHE_OBJECT_SPACE, cfg.cache.max_nodes = 1u << 28));
    if (tu_device_is_cpu())
        CFG_ROW("cache pool 2^24 entries (2 GiB) on a CPU device", PICVR_ERROR_SIZE_OVERFLOW,
                (cfg.cache.mode = PICVR_CACHE_OBJECT_SPACE, cfg.cache.max_entries = 1u << 24));
    else
        tu_partial_skip("the row cache pool 2^24 entries is for CPU devices");
    /* scheduler (zero = default; shares are fractions of device time) */
    CFG_ROW("scheduler.priorities 7", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.priorities = (picvr_switch)7);
    CFG_ROW("scheduler.frames 7", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.frames = (picvr_switch)7);
    CFG_ROW("scheduler.frames -1", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.frames = (picvr_switch)-1);
    CFG_ROW("scheduler.temporal_reuse 3", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.temporal_reuse = (picvr_switch)3);
    CFG_ROW("scheduler.reuse_history 2^20+1", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.reuse_history = (1u << 20) + 1);
    CFG_ROW("scheduler.reuse_history UINT32_MAX", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.reuse_history = UINT32_MAX);
    CFG_ROW("scheduler.create_min NaN", PICVR_ERROR_NON_FINITE, cfg.scheduler.create_min = NAN);
    CFG_ROW("scheduler.create_max Inf", PICVR_ERROR_NON_FINITE, cfg.scheduler.create_max = INFINITY);
    CFG_ROW("scheduler.create_min -0.1", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.create_min = -0.1f);
    CFG_ROW("scheduler.create_min 0.5 > create_max 0.2", PICVR_ERROR_INVALID_ARGUMENT,
            (cfg.scheduler.create_min = 0.5f, cfg.scheduler.create_max = 0.2f));
    CFG_ROW("scheduler.create_min 0.2 > default max 0.15", PICVR_ERROR_INVALID_ARGUMENT,
            cfg.scheduler.create_min = 0.2f);
    CFG_ROW("scheduler.update_min 0.5 > update_max 0.1", PICVR_ERROR_INVALID_ARGUMENT,
            (cfg.scheduler.update_min = 0.5f, cfg.scheduler.update_max = 0.1f));
    CFG_ROW("scheduler.update_max 1.5", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.update_max = 1.5f);
    CFG_ROW("scheduler.create_max 0.9 + update_max 0.2 > 1", PICVR_ERROR_INVALID_ARGUMENT,
            (cfg.scheduler.create_max = 0.9f, cfg.scheduler.update_max = 0.2f));
    CFG_ROW("scheduler.exponent -3", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.exponent = -3);
    CFG_ROW("scheduler.exponent NaN", PICVR_ERROR_NON_FINITE, cfg.scheduler.exponent = NAN);
    CFG_ROW("scheduler.rounds_per_second -1", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.rounds_per_second = -1);
    CFG_ROW("scheduler.hit_rate_window_ms NaN", PICVR_ERROR_NON_FINITE, cfg.scheduler.hit_rate_window_ms = NAN);
    CFG_ROW("scheduler.create_max 0.6 + update_max 0.4 (render < 10%)", PICVR_ERROR_INVALID_ARGUMENT,
            (cfg.scheduler.create_max = 0.6f, cfg.scheduler.update_max = 0.4f));
    CFG_ROW("scheduler.rounds_per_second 0.5", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.rounds_per_second = 0.5f);
    CFG_ROW("scheduler.rounds_per_second 5000", PICVR_ERROR_INVALID_ARGUMENT, cfg.scheduler.rounds_per_second = 5000);
#undef CFG_ROW
    print_message("    %d config rows, %d failure(s)\n", n, failures);
    if (failures) fail_msg("%d of %d config rows failed (listed above)", failures, n);
    /* valid edge values are accepted, and the contexts render */
    picvr_config ok = base;
    ok.scheduler.create_min = ok.scheduler.create_max = 0.1f;   /* min == max */
    ok.scheduler.update_min = 1e-6f; ok.scheduler.update_max = 0.8f - 1e-6f;   /* render keeps 10% */
    ok.scheduler.priorities = PICVR_SWITCH_OFF;
    picvr_context *ctx = tu_create_config(&ok);
    tu_vol vol = tu_vol_ball(8);
    tu_upload(ctx, &vol);
    tu_tf_ramp(ctx, 0.9f, 0.9f, 0.9f, 1.0f);
    tu_sun(ctx, 0, 0, 1, 1, 1, 1, 3, 0.5f);
    tu_set_camera(ctx, 0, 0, 20, 0, 0, 0, 30, 8, 8);
    TU_OK(picvr_step_iterations(ctx, 2));
    float *img = tu_read(ctx, 8, 8);
    tu_assert_finite(img, 8 * 8 * 4, "context after the config rows");
    free(img);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* picvr_get_config gives every zero field the default picvr.h documents for it (the
   values are written out here from the header, not read from the library), follows
   picvr_set_scheduler, and hands out Vulkan handles that a second context can run on
   (picvr_config.vulkan: that context must not destroy them). */
void test_get_config_resolves_defaults(void **state) {
    (void)state;
    picvr_context *a = tu_create(3);
    picvr_config c;
    TU_EXPECT(picvr_get_config(NULL, &c), PICVR_ERROR_NULL_POINTER);
    TU_EXPECT(picvr_get_config(a, NULL), PICVR_ERROR_NULL_POINTER);
    TU_OK(picvr_get_config(a, &c));
    assert_int_equal(c.seed, 3);
    assert_non_null(c.device_name);
    assert_int_equal(c.log_level, PICVR_LOG_WARNING);
    assert_int_equal(c.distance_sampling, PICVR_DISTANCE_MIS);   /* the header: DEFAULT is MIS */
    assert_int_equal(c.transmittance, PICVR_TRANSMITTANCE_RESIDUAL);
    assert_int_equal(c.kernel_pruning, PICVR_SWITCH_ON);          /* the header: DEFAULT is ON */
    picvr_stats st;
    TU_OK(picvr_get_stats(a, &st));
    assert_int_equal(c.validation, st.validation_enabled ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF);
    assert_string_equal(c.device_name, st.device_name);
    assert_int_equal(c.cache.mode, PICVR_CACHE_NONE);
    assert_true(c.cache.gamma == 0.1f && c.cache.epsilon == 0.1f && c.cache.delta_voxels == 2.0f);
    assert_true(c.cache.radius_min_voxels == 0.01f && c.cache.radius_max_voxels == 16.0f);
    assert_true(c.cache.update_threshold == 0.1f && c.cache.rebuild_interval_ms == 1000.0f);
    assert_int_equal(c.cache.max_samples, 768);
    assert_int_equal(c.cache.superpixel_size, 32);
    assert_int_equal(c.cache.max_entries, 65536);
    assert_int_equal(c.cache.max_nodes, 8 * 65536);
    assert_int_equal(c.cache.max_refs, 16 * 65536);
    assert_int_equal(c.cache.max_requests, 1000);
    assert_int_equal(c.cache.max_lookup_refs, PICVR_CACHE_MAX_LOOKUP_REFS);
    assert_int_equal(c.cache.lookup_event, 1);
    assert_int_equal(c.cache.curvature_limit, PICVR_SWITCH_OFF);
    assert_int_equal(c.cache.medium_model, PICVR_SWITCH_ON);
    assert_int_equal(c.cache.blend, PICVR_SWITCH_ON);
    assert_true(c.cache.probe_fraction == 0.125f);
    assert_true(c.scheduler.create_min == 0.05f && c.scheduler.create_max == 0.15f);
    assert_true(c.scheduler.update_min == 0.01f && c.scheduler.update_max == 0.02f);
    assert_true(c.scheduler.exponent == 3.0f && c.scheduler.rounds_per_second == 20.0f);
    assert_true(c.scheduler.hit_rate_window_ms == 100.0f);
    assert_int_equal(c.scheduler.priorities, PICVR_SWITCH_ON);
    assert_int_equal(c.scheduler.frames, PICVR_SWITCH_OFF);
    assert_int_equal(c.scheduler.temporal_reuse, PICVR_SWITCH_OFF);
    assert_int_equal(c.scheduler.reuse_history, 16);
    assert_non_null(c.vulkan.instance);
    assert_non_null(c.vulkan.physical_device);
    assert_non_null(c.vulkan.device);
    assert_non_null(c.vulkan.queue);

    picvr_scheduler_config sc;
    memset(&sc, 0, sizeof sc);
    sc.priorities = PICVR_SWITCH_OFF;
    sc.create_max = 0.5f;
    TU_OK(picvr_set_scheduler(a, &sc));
    TU_OK(picvr_get_config(a, &c));
    assert_int_equal(c.scheduler.priorities, PICVR_SWITCH_OFF);
    assert_true(c.scheduler.create_max == 0.5f && c.scheduler.create_min == 0.05f);

    /* a second context on the first one's device renders, and leaves it working */
    picvr_config b_cfg;
    memset(&b_cfg, 0, sizeof b_cfg);
    b_cfg.vulkan = c.vulkan;
    picvr_context *b = NULL;
    TU_OK(picvr_create(&b_cfg, &b));
    picvr_config bc;
    TU_OK(picvr_get_config(b, &bc));
    assert_ptr_equal(bc.vulkan.device, c.vulkan.device);
    tu_vol vol = tu_vol_ball(8);
    picvr_context *both[2] = {b, a};
    for (int i = 0; i < 2; i++) {
        tu_upload(both[i], &vol);
        tu_set_camera(both[i], 0, 0, 20, 0, 0, 0, 30, 8, 8);
        tu_background_only(both[i], 1, 1, 1, 1);
        TU_OK(picvr_step_iterations(both[i], 2));
        TU_OK(picvr_get_stats(both[i], &st));
        assert_int_equal(st.iterations, 2);
        if (i == 0) picvr_destroy(b);
    }
    tu_vol_free(&vol);
    tu_finish(a);
}
