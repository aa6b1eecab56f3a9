/* test_clip.c - the volume's placement (picvr_volume_desc.direction, origin) and clipping
 * (picvr_set_clip) against the closed form of single scattering in a homogeneous box
 * under a delta sun (test_single_scatter.c's, tu_sun_ray).
 *
 * A homogeneous box clipped by axis-aligned planes is again a homogeneous box, the
 * clipped one: its closed form is tu_sun_ray with that box.  A placed volume seen by a
 * camera and lit by a sun that are placed with it renders, in the volume's own frame,
 * the unplaced scene, whose closed form is known; a wrong orientation, a mirrored camera
 * basis or a sun turned the wrong way moves light between the image's quadrants (the
 * sun is off-axis), which the quadrant checks see.
 *
 * Tolerances as in test_single_scatter.c: z = 5 against the analytic bound on the
 * variance (every sample lies in [0, albedo E / (4 pi)]), 1e-4 relative for the
 * quadratures.
 */
#include "test_util.h"

#include <float.h>

/* 3x3 matrices as rows m[r][c]. */
static void mat_vec(const double m[3][3], const double v[3], double out[3]) {
    for (int r = 0; r < 3; r++) out[r] = m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2];
}

/* The placement of the tests below: a turn of 30 degrees about z after swapping x and y
   (a reflection, det -1, as a scan's LPS axes can be), and voxel (0,0,0)'s centre at
   (100, -50, 20).  world = rot local + shift. */
typedef struct placement {
    double rot[3][3], shift[3];
    float direction[9], origin[3];
} placement;

static placement make_placement(const tu_vol *vol) {
    placement p;
    const double c = cos(M_PI / 6), s = sin(M_PI / 6);
    const double rz[3][3] = {{c, -s, 0}, {s, c, 0}, {0, 0, 1}};
    const double swap[3][3] = {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}};
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 3; k++) {
            p.rot[r][k] = 0;
            for (int j = 0; j < 3; j++) p.rot[r][k] += rz[r][j] * swap[j][k];
        }
    for (int a = 0; a < 3; a++)
        for (int r = 0; r < 3; r++) p.direction[3 * a + r] = (float)p.rot[r][a];   /* axis a = column a */
    p.origin[0] = 100.0f; p.origin[1] = -50.0f; p.origin[2] = 20.0f;
    double bmin[3], bmax[3], v0[3], rv[3];
    tu_vol_box(vol, bmin, bmax);
    for (int i = 0; i < 3; i++) v0[i] = bmin[i] + 0.5 * vol->spacing[i];   /* voxel 0's centre */
    mat_vec(p.rot, v0, rv);
    for (int i = 0; i < 3; i++) p.shift[i] = p.origin[i] - rv[i];
    return p;
}

static void to_world_point(const placement *p, const double l[3], float out[3]) {
    double w[3];
    mat_vec(p->rot, l, w);
    for (int i = 0; i < 3; i++) out[i] = (float)(w[i] + p->shift[i]);
}

static void to_world_dir(const placement *p, const double l[3], double out[3]) { mat_vec(p->rot, l, out); }

/* A world plane that is the volume-frame plane nl . x + dl >= 0: n = rot nl, d = dl -
   n . shift (scaled by k: any positive length must do). */
static void to_world_plane(const placement *p, const double nl[3], double dl, double k, float out[4]) {
    double n[3];
    mat_vec(p->rot, nl, n);
    out[3] = (float)(k * (dl - (n[0] * p->shift[0] + n[1] * p->shift[1] + n[2] * p->shift[2])));
    for (int i = 0; i < 3; i++) out[i] = (float)(k * n[i]);
}

/* Renders the box scene and checks every channel, each quadrant and alpha against the
   closed form of s (in the volume's frame) seen by cam (also in that frame). */
static void check_against_closed_form(picvr_context *ctx, tu_sun_scene *s, const tu_cam *cam, int mirrored,
                                      uint32_t W, uint32_t H, uint32_t N, const char *what) {
    double *expv = tu_expected_image(cam, 4, tu_sun_ray, s);
    if (mirrored) {
        double *m = tu_mirror_x(expv, W, H);
        free(expv);
        expv = m;
    }
    TU_OK(picvr_step_iterations(ctx, N));
    float *img = tu_read(ctx, W, H);
    tu_assert_finite(img, (size_t)W * H * 4, what);
    int ok = 1;
    char label[128];
    for (int c = 0; c < 3; c++) {
        double M = s->albedo[c] * s->E[c] / (4 * M_PI);
        for (int q = 0; q < 4; q++) {
            uint32_t x0 = (q & 1) ? W / 2 : 0, y0 = (q & 2) ? H / 2 : 0;
            snprintf(label, sizeof label, "%s: quadrant %d channel %d", what, q, c);
            ok &= tu_check_mean(label, img, expv, W, c, x0, y0, x0 + W / 2, y0 + H / 2, N, M, 5.0, 1e-4);
        }
    }
    snprintf(label, sizeof label, "%s: per pixel", what);
    ok &= tu_check_chi2(label, img, expv, W, H, 1, N, s->albedo[1] * s->E[1] / (4 * M_PI), 5.0, NULL);
    snprintf(label, sizeof label, "%s: alpha", what);
    ok &= tu_check_mean(label, img, expv, W, 3, 0, 0, W, H, N, 1.0, 5.0, 1e-4);
    free(expv);
    free(img);
    if (!ok) fail_msg("%s: image differs from the closed form", what);
}

static void sun_scene(tu_sun_scene *s, const double bmin[3], const double bmax[3], const double l[3]) {
    memset(s, 0, sizeof *s);
    memcpy(s->bmin, bmin, sizeof s->bmin);
    memcpy(s->bmax, bmax, sizeof s->bmax);
    s->sigma = 0.15;
    double ll = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
    const double alb[3] = {1.0, 0.8, 0.5};
    for (int i = 0; i < 3; i++) {
        s->l[i] = l[i] / ll;
        s->albedo[i] = alb[i];
        s->E[i] = 2.0;
    }
}

static void set_sun(picvr_context *ctx, const double d[3]) {
    picvr_light sun;
    memset(&sun, 0, sizeof sun);
    sun.type = PICVR_LIGHT_DIRECTIONAL;
    for (int i = 0; i < 3; i++) sun.direction[i] = (float)d[i];
    sun.color[0] = sun.color[1] = sun.color[2] = 1.0f;
    sun.intensity = 2.0f;
    picvr_background black = {{0, 0, 0}, 0.0f, NULL, 0, 0, 0};
    TU_OK(picvr_set_lights(ctx, &sun, 1, &black));
}

/* The 16^3 cube of test_single_scatter.c clipped to x <= 3 and y >= -5, once by the clip
   box and once by two planes (one with a normal of length 2): the closed form of the box
   [-8,3] x [-5,8] x [-8,8].  Then clipping off again: the whole cube. */
void test_clip_cube_under_sun_closed_form(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(11);
    tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
    tu_upload(ctx, &vol);
    tu_tf_const(ctx, 1.0f, 0.8f, 0.5f, 1.0f, 0.15f);
    const double l[3] = {0.6, 0.45, 0.66};
    set_sun(ctx, l);
    const uint32_t W = 48, H = 48, N = 256;
    tu_cam cam = tu_set_camera(ctx, 0, 0, 30, 0, 0, 0, 38, W, H);   /* sees the whole front face */
    const double kept_min[3] = {-8, -5, -8}, kept_max[3] = {3, 8, 8};
    tu_sun_scene s;
    sun_scene(&s, kept_min, kept_max, l);

    picvr_clip clip;
    memset(&clip, 0, sizeof clip);
    clip.use_box = 1;
    const float bmin[3] = {-100, -5, -100}, bmax[3] = {3, 100, 100};
    memcpy(clip.box_min, bmin, sizeof bmin);
    memcpy(clip.box_max, bmax, sizeof bmax);
    TU_OK(picvr_set_clip(ctx, &clip));
    check_against_closed_form(ctx, &s, &cam, 0, W, H, N, "clip box");

    memset(&clip, 0, sizeof clip);
    clip.plane_count = 2;
    const float p0[4] = {-1, 0, 0, 3}, p1[4] = {0, 2, 0, 10};   /* x <= 3; 2y + 10 >= 0 */
    memcpy(clip.planes[0], p0, sizeof p0);
    memcpy(clip.planes[1], p1, sizeof p1);
    TU_OK(picvr_set_clip(ctx, &clip));
    check_against_closed_form(ctx, &s, &cam, 0, W, H, N, "clip planes");

    TU_OK(picvr_set_clip(ctx, NULL));
    const double all_min[3] = {-8, -8, -8}, all_max[3] = {8, 8, 8};
    sun_scene(&s, all_min, all_max, l);
    check_against_closed_form(ctx, &s, &cam, 0, W, H, N, "clip off");
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* An asymmetric 16 x 12 x 10 box with anisotropic spacing, turned and reflected
   (make_placement) and moved far from the origin; camera, sun and a clip plane given in
   world space as the placement maps them.  picvr_volume_box gives the box around the
   placed corners. */
void test_placed_volume_under_sun_closed_form(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(12);
    tu_vol vol = tu_vol_new(16, 12, 10, 1.0f, 255);
    vol.spacing[1] = 1.25f;   /* box 16 x 15 x 10 */
    placement p = make_placement(&vol);
    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    memcpy(d.dims, vol.dims, sizeof d.dims);
    memcpy(d.spacing, vol.spacing, sizeof d.spacing);
    d.type = PICVR_VOXEL_UINT8;
    d.data = vol.v;
    memcpy(d.direction, p.direction, sizeof d.direction);
    d.has_origin = 1;
    memcpy(d.origin, p.origin, sizeof d.origin);
    TU_OK(picvr_upload_volume(ctx, &d));
    tu_tf_const(ctx, 1.0f, 0.8f, 0.5f, 1.0f, 0.15f);

    double bmin[3], bmax[3];
    tu_vol_box(&vol, bmin, bmax);
    float got_min[3], got_max[3];
    TU_OK(picvr_volume_box(ctx, got_min, got_max));
    for (int r = 0; r < 3; r++) {   /* the corners' box, computed here corner by corner */
        double lo = 1e30, hi = -1e30;
        for (int k = 0; k < 8; k++) {
            double corner[3] = {(k & 1) ? bmax[0] : bmin[0], (k & 2) ? bmax[1] : bmin[1], (k & 4) ? bmax[2] : bmin[2]};
            float w[3];
            to_world_point(&p, corner, w);
            lo = fmin(lo, w[r]);
            hi = fmax(hi, w[r]);
        }
        assert_true(fabs(got_min[r] - lo) < 1e-3 && fabs(got_max[r] - hi) < 1e-3);
    }

    const double l[3] = {0.6, 0.45, 0.66};   /* the sun, in the volume's frame */
    double lw[3];
    to_world_dir(&p, l, lw);
    set_sun(ctx, lw);
    const uint32_t W = 48, H = 48, N = 256;
    const double cam_l[3] = {0, 0, 30}, target_l[3] = {0, 0, 0}, up_l[3] = {0, 1, 0};
    picvr_camera c;
    memset(&c, 0, sizeof c);
    double upw[3];
    to_world_point(&p, cam_l, c.position);
    to_world_point(&p, target_l, c.target);
    to_world_dir(&p, up_l, upw);
    for (int i = 0; i < 3; i++) c.up[i] = (float)upw[i];
    c.fov_y_degrees = 38.0f;
    c.width = W;
    c.height = H;
    TU_OK(picvr_set_camera(ctx, &c));
    /* the camera as the closed form sees it: in the volume's frame, up +y */
    picvr_camera cl = c;
    for (int i = 0; i < 3; i++) {
        cl.position[i] = (float)cam_l[i];
        cl.target[i] = (float)target_l[i];
        cl.up[i] = (float)up_l[i];
    }
    tu_cam cam = tu_cam_from(&cl);
    tu_sun_scene s;
    sun_scene(&s, bmin, bmax, l);
    /* The placement is a reflection, so the world's camera sees the volume-frame scene
       mirrored left to right (its right vector, cross(f, up), maps to minus the frame
       camera's): the image is the closed form mirrored. */
    check_against_closed_form(ctx, &s, &cam, 1, W, H, N, "placed volume");

    /* a world plane that is x <= 3 in the volume's frame, its normal scaled by 0.5 */
    picvr_clip clip;
    memset(&clip, 0, sizeof clip);
    clip.plane_count = 1;
    const double nl[3] = {-1, 0, 0};
    to_world_plane(&p, nl, 3.0, 0.5, clip.planes[0]);
    TU_OK(picvr_set_clip(ctx, &clip));
    double cmax[3] = {3, bmax[1], bmax[2]};
    sun_scene(&s, bmin, cmax, l);
    check_against_closed_form(ctx, &s, &cam, 1, W, H, N, "placed volume, clipped");
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* Hostile placements and clips: each refused with its status, the context unchanged (the
   same image as before, bit for bit, after the same iterations). */
void test_bad_placement_and_clip(void **state) {
    (void)state;
    picvr_context *ctx = tu_create(13);
    tu_vol vol = tu_vol_new(8, 8, 8, 1.0f, 200);
    tu_upload(ctx, &vol);
    tu_tf_const(ctx, 0.9f, 0.9f, 0.9f, 1.0f, 0.3f);
    tu_sun(ctx, 1, 1, 1, 1, 1, 1, 2, 0.2f);
    tu_set_camera(ctx, 0, 0, 20, 0, 0, 0, 40, 16, 16);
    TU_OK(picvr_step_iterations(ctx, 4));
    float *before = tu_read(ctx, 16, 16);

    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    d.dims[0] = d.dims[1] = d.dims[2] = 8;
    d.type = PICVR_VOXEL_UINT8;
    d.data = vol.v;
    const struct { float dir[9]; int has_origin; float origin[3]; picvr_status want; const char *what; } rows[] = {
        {{1, 0, 0, 1, 0, 0, 0, 0, 1}, 0, {0, 0, 0}, PICVR_ERROR_INVALID_ARGUMENT, "singular (two equal axes)"},
        {{1, 0, 0, 0.5f, 0.866f, 0, 0, 0, 1}, 0, {0, 0, 0}, PICVR_ERROR_INVALID_ARGUMENT, "sheared (gantry tilt)"},
        {{2, 0, 0, 0, 2, 0, 0, 0, 2}, 0, {0, 0, 0}, PICVR_ERROR_INVALID_ARGUMENT, "scaled axes (spacing belongs in spacing)"},
        {{1, 0, 0, 0, 1, 0, 0, 0, 0}, 0, {0, 0, 0}, PICVR_ERROR_INVALID_ARGUMENT, "a zero axis"},
        {{NAN, 0, 0, 0, 1, 0, 0, 0, 1}, 0, {0, 0, 0}, PICVR_ERROR_NON_FINITE, "NaN in direction"},
        {{1, 0, 0, 0, 1, 0, 0, 0, INFINITY}, 0, {0, 0, 0}, PICVR_ERROR_NON_FINITE, "infinity in direction"},
        {{0}, 1, {0, NAN, 0}, PICVR_ERROR_NON_FINITE, "NaN origin"},
        {{0}, 1, {FLT_MAX, 0, 0}, PICVR_ERROR_INVALID_ARGUMENT, "origin at the edge of float (the box leaves float)"},
    };
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        memcpy(d.direction, rows[i].dir, sizeof d.direction);
        d.has_origin = rows[i].has_origin;
        memcpy(d.origin, rows[i].origin, sizeof d.origin);
        picvr_status st = picvr_upload_volume(ctx, &d);
        if (st != rows[i].want)
            fail_msg("placement '%s': %s, expected %s", rows[i].what, picvr_status_string(st), picvr_status_string(rows[i].want));
    }
    picvr_clip clip;
    memset(&clip, 0, sizeof clip);
    clip.plane_count = PICVR_MAX_CLIP_PLANES + 1;
    for (uint32_t i = 0; i < PICVR_MAX_CLIP_PLANES + 1; i++) clip.planes[i % PICVR_MAX_CLIP_PLANES][0] = 1.0f;
    TU_EXPECT(picvr_set_clip(ctx, &clip), PICVR_ERROR_INVALID_ARGUMENT);   /* too many planes */
    memset(&clip, 0, sizeof clip);
    clip.plane_count = 1;
    clip.planes[0][0] = NAN;
    clip.planes[0][1] = 1.0f;
    TU_EXPECT(picvr_set_clip(ctx, &clip), PICVR_ERROR_INVALID_ARGUMENT);   /* NaN in a plane */
    clip.planes[0][0] = 0.0f;
    clip.planes[0][1] = 0.0f;
    TU_EXPECT(picvr_set_clip(ctx, &clip), PICVR_ERROR_INVALID_ARGUMENT);   /* zero normal */
    clip.planes[0][0] = 1e-30f;
    clip.planes[0][3] = 1e30f;
    TU_EXPECT(picvr_set_clip(ctx, &clip), PICVR_ERROR_INVALID_ARGUMENT);   /* d / |n| beyond float */
    clip.planes[0][0] = 1.0f;
    clip.planes[0][3] = INFINITY;
    TU_EXPECT(picvr_set_clip(ctx, &clip), PICVR_ERROR_INVALID_ARGUMENT);   /* infinite offset */
    memset(&clip, 0, sizeof clip);
    clip.use_box = 1;
    clip.box_min[0] = 1.0f;   /* min > max on x */
    TU_EXPECT(picvr_set_clip(ctx, &clip), PICVR_ERROR_INVALID_ARGUMENT);
    clip.box_min[0] = -INFINITY;
    TU_EXPECT(picvr_set_clip(ctx, &clip), PICVR_ERROR_INVALID_ARGUMENT);
    TU_EXPECT(picvr_set_clip(NULL, &clip), PICVR_ERROR_NULL_POINTER);

    TU_OK(picvr_reset(ctx));
    TU_OK(picvr_step_iterations(ctx, 4));
    float *after = tu_read(ctx, 16, 16);
    assert_memory_equal(before, after, 16 * 16 * 4 * sizeof(float));
    free(before);
    free(after);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* Renders a homogeneous 8^3 cube (albedo 0.8, tau 0.3 per voxel) lit by an asymmetric
   environment map alone (bright above, dim below, red toward one side, turned 0.7 rad),
   placed by dir (all zero: the identity), seen from a fixed world camera; returns the
   image. */
static float *cube_under_map(const float dir[9], uint32_t W, uint32_t H, uint32_t N) {
    picvr_context *ctx = tu_create(14);
    tu_vol vol = tu_vol_new(8, 8, 8, 1.0f, 255);
    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    memcpy(d.dims, vol.dims, sizeof d.dims);
    d.type = PICVR_VOXEL_UINT8;
    d.data = vol.v;
    memcpy(d.direction, dir, sizeof d.direction);
    TU_OK(picvr_upload_volume(ctx, &d));
    tu_tf_const(ctx, 0.8f, 0.8f, 0.8f, 1.0f, 0.3f);
    float map[8 * 4 * 3];
    for (int row = 0; row < 4; row++)
        for (int col = 0; col < 8; col++) {
            float *t = map + 3 * (row * 8 + col);
            float sky = row < 2 ? 2.0f : 0.1f;
            t[0] = sky * (col < 3 ? 2.0f : 1.0f);
            t[1] = t[2] = sky;
        }
    picvr_background bg = {{1, 1, 1}, 1.0f, map, 8, 4, 0.7f};
    TU_OK(picvr_set_lights(ctx, NULL, 0, &bg));
    tu_set_camera(ctx, 5, 8, 20, 0, 0, 0, 40, W, H);
    TU_OK(picvr_step_iterations(ctx, N));
    float *img = tu_read(ctx, W, H);
    tu_vol_free(&vol);
    tu_finish(ctx);
    return img;
}

/* The environment map stays in world space when the volume turns: a cube turned by a
   quarter turn about x (or reflected in its y-z plane) is the same cube, so under the same
   world camera and map the image must be the unturned cube's.  Compared per quadrant
   and channel: the mean of the per-pixel difference within 5 standard errors (from the
   spread of the differences: independent renders, independent pixels) plus 1e-3
   relative (float rounding of the turned directions).  A map left in the volume's frame
   turns the bright sky toward a side and fails by tens of standard errors. */
void test_placed_volume_environment_map(void **state) {
    (void)state;
    const uint32_t W = 32, H = 32, N = 128;
    const float identity[9] = {0}, quarter_x[9] = {1, 0, 0, 0, 0, 1, 0, -1, 0}, mirror_x[9] = {-1, 0, 0, 0, 1, 0, 0, 0, 1};
    float *a = cube_under_map(identity, W, H, N);
    const float *dirs[2] = {quarter_x, mirror_x};
    const char *names[2] = {"quarter turn about x", "reflection in y-z"};
    for (int k = 0; k < 2; k++) {
        float *b = cube_under_map(dirs[k], W, H, N);
        for (int q = 0; q < 4; q++)
            for (int c = 0; c < 3; c++) {
                uint32_t x0 = (q & 1) ? W / 2 : 0, y0 = (q & 2) ? H / 2 : 0;
                /* d = a - b per pixel: independent renders of equal expectation, so
                   the spread of d over the quadrant is the noise alone */
                double sa = 0, sd = 0, sd2 = 0, n = (double)(W / 2) * (H / 2);
                for (uint32_t y = y0; y < y0 + H / 2; y++)
                    for (uint32_t x = x0; x < x0 + W / 2; x++) {
                        size_t i = 4 * ((size_t)y * W + x) + (size_t)c;
                        double dv = (double)a[i] - (double)b[i];
                        sa += a[i];
                        sd += dv;
                        sd2 += dv * dv;
                    }
                double mean_d = sd / n, var_d = fmax(sd2 / n - mean_d * mean_d, 0.0) / (n - 1.0);
                double diff = fabs(mean_d), bound = 5.0 * sqrt(var_d) + 1e-3 * fabs(sa) / n;
                print_message("    %-22s quadrant %d channel %d: %.5f vs %.5f (bound %.5f)\n", names[k], q, c, sa / n,
                              (sa - sd) / n, bound);
                if (!(diff <= bound)) fail_msg("%s: quadrant %d channel %d differs from the unturned cube", names[k], q, c);
            }
        free(b);
    }
    free(a);
}
