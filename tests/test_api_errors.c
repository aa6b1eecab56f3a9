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

static void *dummy_alloc(size_t size, void *user) { (void)user; return malloc(size); }

void test_create_destroy_errors(void **state) {
    (void)state;
    picvr_destroy(NULL); /* allowed */
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.validation = 1;
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
    TU_OK(picvr_set_transfer_function(t->ctx, BASE_TF, 2, 0.5f));
    picvr_light sun = base_sun();
    TU_OK(picvr_set_lights(t->ctx, &sun, 1, &BASE_BG));
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

void test_bad_inputs_rejected_and_state_kept(void **state) {
    (void)state;
    static table_state T;
    memset(&T, 0, sizeof T);
    table_state *t = &T;
    t->ctx = tu_create(9);
    picvr_context *ctx = t->ctx;

    /* Baseline scene. */
    tu_vol vol = tu_vol_ball(8);
    t->vol = &vol;
    set_baseline(t);
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
