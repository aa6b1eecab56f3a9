/* presets.c - see presets.h.
 *
 * Exposure rule used for every light set-up.  At a scatter event in a medium of
 * albedo a, single scattering with the isotropic phase function gives the radiance
 *     L_out = a / (4 pi) * sum_i L_i * Omega_i * T_i,
 * with L_i the light's radiance, Omega_i its solid angle and T_i the shadow
 * transmittance (about 0.3-0.5 near a lit surface).  So each light is specified by
 * its "strength" S = L * Omega seen from the box centre (the irradiance it gives a
 * surface facing it) and its radiance is derived from its geometry: S of about 12-15
 * for a key light gives L_out of about 0.3-0.6.  Because everything scales with the
 * box radius R, the images look the same for any volume size. */
#include "presets.h"

#include <float.h>
#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI_F 3.14159265358979f

typedef struct vec3 { float x, y, z; } vec3;

static vec3 v3(float x, float y, float z) { vec3 r = {x, y, z}; return r; }
static vec3 add(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static vec3 sub(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static vec3 scale(vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static float dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static float length(vec3 a) { return sqrtf(dot(a, a)); }
static vec3 cross(vec3 a, vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static vec3 normalize(vec3 a)
{
    float l = length(a);
    return l > 0.0f ? scale(a, 1.0f / l) : v3(0.0f, 1.0f, 0.0f);
}
static void store(float out[3], vec3 a) { out[0] = a.x; out[1] = a.y; out[2] = a.z; }
static vec3 load(const float in[3]) { return v3(in[0], in[1], in[2]); }
static int vec_is_finite(vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

/* Any unit vector perpendicular to n (prefers the world's y axis as "up"). */
static vec3 perpendicular(vec3 n)
{
    vec3 helper = fabsf(n.y) < 0.95f ? v3(0.0f, 1.0f, 0.0f) : v3(1.0f, 0.0f, 0.0f);
    return normalize(cross(helper, n));
}

/* ---- transfer functions ------------------------------------------------------------ */

typedef struct tf_entry {
    const char *name, *description;
    float density;
    uint32_t count;
    picvr_tf_point points[PVP_MAX_TF_POINTS];  /* value, albedo, opacity, HG g (0 if left out) */
    uint32_t max_bounces;                      /* 0 (single scattering) if left out */
    pvp_window_kind window_kind;               /* PVP_WINDOW_RANGE if left out */
    float window[2];
} tf_entry;

/* Hounsfield-unit presets: values written in HU, normalized over the preset's window
   [lo, hi] (HU(v, lo, hi)).  Density 1 per mm: opacity 1 is a mean free path of 1 mm
   (bone is opaque within a millimetre), 0.02 one of 50 mm (soft tissue a translucent
   fog through a head).  Thresholds after the tissue ranges viewers' CT presets use: air
   -1000, lung -900..-500, fat -100..-50, soft tissue 20..80, contrast-filled vessels
   150..500, bone 300..1900. */
#define HU_(v, lo, hi) (((float)(v) - (float)(lo)) / ((float)(hi) - (float)(lo)))
#define HU(v, window) HU_(v, window)
#define BONE_W -1000, 2000
#define SOFT_W -1000, 1000
#define LUNG_W -1000, 200
#define ANGIO_W -1000, 1500
#define BONE_W_F -1000.0f, 2000.0f
#define SOFT_W_F -1000.0f, 1000.0f
#define LUNG_W_F -1000.0f, 200.0f
#define ANGIO_W_F -1000.0f, 1500.0f

#define GREY(g) {g, g, g}

/* Normalized data values; the thresholds follow the histograms of the data sets in
   ../shared/data (e.g. bonsai: air below 0.15, foliage and trunk above 0.25). */
static const tf_entry tf_table[] = {
    {"ct-bone", "CT in HU: bone white and opaque, soft tissue clear", 1.0f, 5,
     {{HU(-1000, BONE_W), {0.95f, 0.90f, 0.80f}, 0.00f},
      {HU(150, BONE_W), {0.95f, 0.90f, 0.80f}, 0.00f},
      {HU(300, BONE_W), {0.95f, 0.88f, 0.75f}, 0.50f},
      {HU(700, BONE_W), {1.00f, 0.97f, 0.92f}, 1.00f},
      {HU(2000, BONE_W), GREY(1.00f), 1.00f}},
     0, PVP_WINDOW_VALUE, {BONE_W_F}},
    {"ct-soft-tissue", "CT in HU: skin and fat faint, muscle and organs red, bone white", 1.0f, 7,
     {{HU(-1000, SOFT_W), {0.90f, 0.80f, 0.60f}, 0.00f},
      {HU(-500, SOFT_W), {0.90f, 0.80f, 0.60f}, 0.00f},
      {HU(-100, SOFT_W), {0.90f, 0.80f, 0.55f}, 0.005f},
      {HU(20, SOFT_W), {0.85f, 0.40f, 0.32f}, 0.03f},
      {HU(80, SOFT_W), {0.90f, 0.45f, 0.38f}, 0.06f},
      {HU(250, SOFT_W), {0.95f, 0.92f, 0.85f}, 1.00f},
      {HU(1000, SOFT_W), GREY(1.00f), 1.00f}},
     0, PVP_WINDOW_VALUE, {SOFT_W_F}},
    {"ct-lung", "CT in HU: the lungs' tissue and airways, the rest clear", 1.0f, 6,
     {{HU(-1000, LUNG_W), {0.95f, 0.70f, 0.65f}, 0.00f},
      {HU(-920, LUNG_W), {0.95f, 0.70f, 0.65f}, 0.00f},
      {HU(-800, LUNG_W), {0.95f, 0.72f, 0.66f}, 0.10f},
      {HU(-450, LUNG_W), {0.95f, 0.80f, 0.75f}, 0.60f},
      {HU(-300, LUNG_W), {0.95f, 0.80f, 0.75f}, 0.00f},
      {HU(200, LUNG_W), {0.95f, 0.80f, 0.75f}, 0.00f}},
     0, PVP_WINDOW_VALUE, {LUNG_W_F}},
    {"ct-angio", "CT angiography in HU: contrast-filled vessels red, bone ivory", 1.0f, 6,
     {{HU(-1000, ANGIO_W), {0.90f, 0.25f, 0.20f}, 0.00f},
      {HU(120, ANGIO_W), {0.90f, 0.25f, 0.20f}, 0.00f},
      {HU(200, ANGIO_W), {0.90f, 0.25f, 0.20f}, 0.40f},
      {HU(400, ANGIO_W), {0.95f, 0.35f, 0.30f}, 1.00f},
      {HU(700, ANGIO_W), {0.95f, 0.92f, 0.82f}, 1.00f},
      {HU(1500, ANGIO_W), GREY(1.00f), 1.00f}},
     0, PVP_WINDOW_VALUE, {ANGIO_W_F}},
    /* MR intensities have no physical unit: the window is the data's 1st to 99.5th
       percentile, background noise below a quarter of it clear, tissue a translucent
       cream that grows denser with the signal.  Density 0.5 per world unit (mm). */
    {"mr", "MR (or any scan without units): the data's 1st-99.5th percentiles, tissue cream", 0.5f, 5,
     {{0.00f, {0.92f, 0.82f, 0.72f}, 0.00f},
      {0.18f, {0.92f, 0.82f, 0.72f}, 0.00f},
      {0.30f, {0.92f, 0.80f, 0.70f}, 0.04f},
      {0.60f, {0.96f, 0.90f, 0.84f}, 0.30f},
      {1.00f, GREY(1.00f), 1.00f}},
     0, PVP_WINDOW_PERCENTILE, {0.01f, 0.995f}},
    {"ct-bonsai", "bonsai CT: air clear, green foliage, brown trunk, terracotta pot",
     1.0f, 8,
     {{0.00f, {0.45f, 0.68f, 0.25f}, 0.00f},
      {0.19f, {0.45f, 0.68f, 0.25f}, 0.00f},
      {0.27f, {0.42f, 0.68f, 0.25f}, 0.50f},
      {0.42f, {0.50f, 0.66f, 0.28f}, 0.85f},
      {0.52f, {0.62f, 0.45f, 0.28f}, 1.00f},
      {0.70f, {0.62f, 0.45f, 0.28f}, 1.00f},
      {0.78f, {0.85f, 0.52f, 0.36f}, 1.00f},
      {1.00f, {0.85f, 0.52f, 0.36f}, 1.00f}}},
    {"ct-dense", "CT without units (0..1 of its range): faint reddish soft tissue, dense white bone", 1.0f, 6,
     {{0.00f, {0.90f, 0.50f, 0.40f}, 0.00f},
      {0.20f, {0.90f, 0.50f, 0.40f}, 0.00f},
      {0.28f, {0.92f, 0.45f, 0.35f}, 0.04f},
      {0.48f, {0.95f, 0.60f, 0.50f}, 0.06f},
      {0.62f, {1.00f, 0.96f, 0.90f}, 1.00f},
      {1.00f, GREY(1.00f), 1.00f}}},
    {"ct-engine", "engine CT: translucent blue-grey casting, dense parts brass", 1.0f, 7,
     {{0.00f, {0.70f, 0.78f, 0.90f}, 0.00f},
      {0.12f, {0.70f, 0.78f, 0.90f}, 0.00f},
      {0.35f, {0.72f, 0.80f, 0.90f}, 0.02f},
      {0.50f, {0.75f, 0.80f, 0.88f}, 0.08f},
      {0.62f, {0.80f, 0.83f, 0.90f}, 0.12f},
      {0.70f, {0.95f, 0.80f, 0.50f}, 1.00f},
      {1.00f, {1.00f, 0.78f, 0.40f}, 1.00f}}},
    {"sim", "simulations (fuel, hydrogen, neghip): smooth blue-to-orange ramp", 1.0f, 6,
     {{0.00f, {0.25f, 0.45f, 0.95f}, 0.00f},
      {0.04f, {0.25f, 0.45f, 0.95f}, 0.00f},
      {0.25f, {0.35f, 0.75f, 0.85f}, 0.20f},
      {0.50f, {0.90f, 0.88f, 0.55f}, 0.45f},
      {0.75f, {0.98f, 0.62f, 0.25f}, 0.70f},
      {1.00f, {1.00f, 0.45f, 0.20f}, 1.00f}}},
    /* Disney cloud: values 0..1 (most voxels inside 0.5-0.6), spacing 3.33; a mean free
       path of 10 world units (3 voxels) at full density, 20 at the typical 0.5: an
       optical depth of 10-26 through the middle (6 on average straight down, 10 along
       z).  Clouds scatter forward (g about 0.8, Mie) and their look is multiple
       scattering.  Unlimited bounces (Russian roulette alone; with albedo 0.99,
       absorption ends a path after 100 events on average at most): unbiased, and no
       dearer than a limit of 64, which few paths through this cloud reach. */
    {"cloud", "clouds: white albedo 0.99, HG g 0.8, opacity = value, D = 0.1, unlimited bounces",
     0.1f, 2, {{0.00f, GREY(0.99f), 0.00f, 0.8f}, {1.00f, GREY(0.99f), 1.00f, 0.8f}},
     PICVR_BOUNCES_UNLIMITED},
    /* The same medium isotropic and single-scattering: the cloud of the benchmarks (the
       irradiance cache serves g = 0 only). */
    {"cloud-iso", "cloud isotropic (g 0), single scattering: the benchmarks' cloud", 0.1f, 2,
     {{0.00f, GREY(0.99f), 0.00f}, {1.00f, GREY(0.99f), 1.00f}}},
    /* The thin medium of the sampling benchmark (bench/bench_sampling.c, values 0..1,
       spacing 1): an optical depth of about 3 across its densest part. */
    {"thin", "thin smoke: grey albedo 0.8, opacity = value, D = 0.08", 0.08f, 2,
     {{0.00f, GREY(0.80f), 0.00f}, {1.00f, GREY(0.80f), 1.00f}}},
    {"ramp", "opacity = value, albedo 1, D = 1 (picvr's default)", 1.0f, 2,
     {{0.00f, GREY(1.00f), 0.00f}, {1.00f, GREY(1.00f), 1.00f}}},
};

#define TF_COUNT (sizeof tf_table / sizeof tf_table[0])

pvp_status pvp_tf_preset(const char *name, pvp_tf *tf)
{
    if (!name || !tf) return PVP_ERROR_NULL_POINTER;
    for (size_t i = 0; i < TF_COUNT; i++) {
        if (strcmp(name, tf_table[i].name) != 0) continue;
        memset(tf, 0, sizeof *tf);
        memcpy(tf->points, tf_table[i].points, sizeof tf->points);
        tf->count = tf_table[i].count;
        tf->density = tf_table[i].density;
        tf->max_bounces = tf_table[i].max_bounces;
        tf->window_kind = tf_table[i].window_kind;
        memcpy(tf->window, tf_table[i].window, sizeof tf->window);
        tf->needs_hu = tf_table[i].window_kind == PVP_WINDOW_VALUE;
        return PVP_OK;
    }
    return PVP_ERROR_UNKNOWN_NAME;
}

const char *pvp_tf_name(size_t index)
{
    return index < TF_COUNT ? tf_table[index].name : NULL;
}

const char *pvp_tf_description(size_t index)
{
    return index < TF_COUNT ? tf_table[index].description : NULL;
}

/* ---- light builders ------------------------------------------------------------------ */

/* Where the lights go: the box centre and radius, and the camera's frame. */
typedef struct scene_frame {
    vec3 centre;
    float radius;                   /* R, half the box diagonal */
    vec3 eye, forward, right, up;   /* camera position and basis (forward: to centre) */
    float tan_half_x, tan_half_y;   /* the view frustum's half-angles */
} scene_frame;

static const float WHITE[3] = {1.0f, 1.0f, 1.0f};

/* Solid angle of a sphere of radius r whose centre is at distance d (d > r). */
static float sphere_solid_angle(float r, float d)
{
    float s = r / d;
    return 2.0f * PI_F * (1.0f - sqrtf(1.0f - s * s));
}

/* Solid angle of an a x b rectangle seen face-on from distance d along its normal. */
static float rect_solid_angle(float a, float b, float d)
{
    return 4.0f * asinf(a * b / sqrtf((a * a + 4.0f * d * d) * (b * b + 4.0f * d * d)));
}

static picvr_light *next_light(pvp_lights *out)
{
    picvr_light *l = &out->lights[out->count++];
    memset(l, 0, sizeof *l);
    return l;
}

/* Whether a ball (centre p, radius r) reaches into the camera's view frustum. */
static int ball_in_view(const scene_frame *f, vec3 p, float r)
{
    vec3 q = sub(p, f->eye);
    float x = dot(q, f->right), y = dot(q, f->up), z = dot(q, f->forward);
    float nx = sqrtf(1.0f + f->tan_half_x * f->tan_half_x);
    float ny = sqrtf(1.0f + f->tan_half_y * f->tan_half_y);
    return (fabsf(x) - z * f->tan_half_x) / nx < r && (fabsf(y) - z * f->tan_half_y) / ny < r &&
           z > -r;
}

/* The nominal distance, or farther along `direction` (up to 4x) where a light of
   bounding radius r stays out of the picture, e.g. for wide images or a distant
   camera.  A light behind the volume cannot leave the view: it keeps its place. */
static float distance_out_of_view(const scene_frame *f, vec3 direction, float distance,
                                  float r)
{
    vec3 d = normalize(direction);
    for (float k = 1.0f; k <= 4.0f; k *= 1.05f)
        if (!ball_in_view(f, add(f->centre, scale(d, k * distance)), r)) return k * distance;
    return distance;
}

/* A sphere light along `direction` from the centre with strength S. */
static void add_sphere(pvp_lights *out, const scene_frame *f, vec3 direction,
                       float distance, float radius, const float color[3], float strength)
{
    distance = distance_out_of_view(f, direction, distance, radius);
    picvr_light *l = next_light(out);
    l->type = PICVR_LIGHT_SPHERE;
    store(l->position, add(f->centre, scale(normalize(direction), distance)));
    l->radius = radius;
    memcpy(l->color, color, sizeof l->color);
    l->intensity = strength / sphere_solid_angle(radius, distance);
}

/* A square rect light of side `size` facing the centre, with strength S. */
static void add_rect(pvp_lights *out, const scene_frame *f, vec3 direction,
                     float distance, float size, const float color[3], float strength)
{
    distance = distance_out_of_view(f, direction, distance, 0.7072f * size);
    vec3 towards_centre = scale(normalize(direction), -1.0f);
    vec3 u = perpendicular(towards_centre);
    vec3 v = cross(towards_centre, u);  /* cross(u, v) = towards_centre: lit side */
    picvr_light *l = next_light(out);
    l->type = PICVR_LIGHT_RECT;
    store(l->position, add(f->centre, scale(normalize(direction), distance)));
    store(l->edge_u, scale(u, size));
    store(l->edge_v, scale(v, size));
    memcpy(l->color, color, sizeof l->color);
    l->intensity = strength / rect_solid_angle(size, size, distance);
}

static void set_background(pvp_lights *out, float r, float g, float b, float intensity)
{
    out->background.color[0] = r;
    out->background.color[1] = g;
    out->background.color[2] = b;
    out->background.intensity = intensity;
}

/* A direction given in the camera's frame (x right, y up, z toward the camera). */
static vec3 camera_direction(const scene_frame *f, float x, float y, float z)
{
    return add(add(scale(f->right, x), scale(f->up, y)), scale(f->forward, -z));
}

/* Every set-up is placed in the camera's frame, like a photographer's light kit, so
   it lights the visible side from any --camera.  Directions are (x right, y up,
   z toward the camera).  Area lights are moved outward where needed so that none
   shows in the picture or stands between the camera and the volume. */

/* Paper set-up 1: one small, distant, very bright sphere (sharp shadows). */
static void build_paper1(const scene_frame *f, pvp_lights *out)
{
    float R = f->radius;
    add_sphere(out, f, camera_direction(f, -0.45f, 0.75f, 0.50f), 6.0f * R, 0.15f * R,
               WHITE, 20.0f);
}

/* Paper set-up 3: three large, very intense spheres close to the volume (left,
   right, above), just outside the default view. */
static void build_paper3(const scene_frame *f, pvp_lights *out)
{
    float R = f->radius;
    add_sphere(out, f, camera_direction(f, -0.95f, 0.30f, 0.40f), 1.7f * R, 0.5f * R,
               WHITE, 12.0f);
    add_sphere(out, f, camera_direction(f, 0.95f, -0.15f, 0.35f), 1.7f * R, 0.5f * R,
               WHITE, 12.0f);
    add_sphere(out, f, camera_direction(f, 0.20f, 1.00f, 0.35f), 1.7f * R, 0.5f * R,
               WHITE, 12.0f);
}

/* Paper set-up 4: four dim, large rects in a ring around the line of sight
   (left, right, above, below), tilted a little toward the camera: soft, even light. */
static void build_paper4(const scene_frame *f, pvp_lights *out)
{
    static const float ring[4][2] = {{-1, 0}, {1, 0}, {0, 1}, {0, -1}};
    float R = f->radius;
    for (int i = 0; i < 4; i++)
        add_rect(out, f, camera_direction(f, ring[i][0], ring[i][1], 0.35f), 2.0f * R,
                 2.0f * R, WHITE, 5.0f);
}

static void build_paper1_bg(const scene_frame *f, pvp_lights *out)
{
    build_paper1(f, out);
    set_background(out, 1.0f, 1.0f, 1.0f, 0.1f);
}

static void build_paper3_bg(const scene_frame *f, pvp_lights *out)
{
    build_paper3(f, out);
    set_background(out, 1.0f, 1.0f, 1.0f, 0.1f);
}

static void build_paper4_bg(const scene_frame *f, pvp_lights *out)
{
    build_paper4(f, out);
    set_background(out, 1.0f, 1.0f, 1.0f, 0.1f);
}

/* Photo studio: warm key sphere above left, cool fill rect right, dim blue-grey
   backdrop. */
static void build_studio(const scene_frame *f, pvp_lights *out)
{
    static const float warm[3] = {1.00f, 0.94f, 0.86f}, cool[3] = {0.85f, 0.92f, 1.00f};
    float R = f->radius;
    add_sphere(out, f, camera_direction(f, -0.55f, 0.65f, 0.55f), 3.0f * R, 0.3f * R,
               warm, 13.0f);
    add_rect(out, f, camera_direction(f, 0.85f, 0.05f, 0.50f), 3.0f * R, 1.5f * R,
             cool, 4.0f);
    set_background(out, 0.55f, 0.60f, 0.70f, 0.10f);
}

/* The sun (angular diameter of the real one) high over the left shoulder, blue sky. */
static void build_sun(const scene_frame *f, pvp_lights *out)
{
    picvr_light *l = next_light(out);
    l->type = PICVR_LIGHT_DIRECTIONAL;
    store(l->direction, normalize(camera_direction(f, -0.45f, 0.80f, 0.40f)));
    l->angular_diameter = 0.0093f;
    l->color[0] = 1.0f; l->color[1] = 0.96f; l->color[2] = 0.90f;
    l->intensity = 14.0f;  /* irradiance */
    set_background(out, 0.45f, 0.60f, 1.00f, 0.25f);
}

/* ---- Sun and sky ------------------------------------------------------------------------
   sun-sky is a clear day: the sun (a directional light of the real sun's angular diameter,
   warm white, PVP_SUN_ELEVATION degrees high) and the sky and ground as an equirectangular
   map (picvr_background's convention: row 0 the zenith +y, the centre column along -z).
   Sky: the analytic model of Preetham, Shirley and Smits ("A practical analytic model for
   daylight", SIGGRAPH 1999) at turbidity SKY_TURBIDITY (clear): luminance Y and CIE
   chromaticity x, y are each the zenith's value times the Perez distribution
       F(theta, gamma) / F(0, theta_s),  F = (1 + A e^(B / cos theta)) (1 + C e^(D gamma)
                                                                        + E cos^2 gamma),
   theta the view's zenith angle, gamma its angle to the sun, theta_s the sun's zenith
   angle, A-E and the zenith values the paper's fits in the turbidity (Appendix A.2);
   xyY -> XYZ -> linear sRGB (Rec. 709 primaries, D65).  That gives a Rayleigh-blue zenith,
   a brighter, paler horizon and the soft circumsolar glow (C e^(D gamma)); the sun's own
   disk is the directional light, not in the map.  Ground (below the horizon): a grey
   Lambertian plane of albedo GROUND_ALBEDO lit by the sun and the sky, radiance
   albedo / pi * (E_sun sin(elevation) + E_sky).  Scale: the map is normalized so that the
   sky's irradiance on a horizontal plane, E_sky, is SKY_FRACTION of the sun's normal
   irradiance SUN_IRRADIANCE (a clear sky at this elevation gives 15-25 % of the global
   light as diffuse; here E_sky / (E_sky + E_sun sin 35) = 0.21).  The map is built once
   with the sun at the centre column; env_rotation turns it (and the light's direction
   goes with it) to the azimuth the camera asks for. */
#define SKY_TURBIDITY 3.0f
#define SUN_IRRADIANCE 14.0f    /* as the sun preset's; a sunlit cloud about 1-2 */
#define SKY_FRACTION 0.15f      /* sky irradiance on a horizontal plane / SUN_IRRADIANCE */
#define GROUND_ALBEDO 0.15f
static const float SUN_COLOR[3] = {1.00f, 0.95f, 0.87f};

/* The Perez distribution with coefficients k[0..4] = A, B, C, D, E. */
static float perez(const float k[5], float cos_theta, float gamma)
{
    float cg = cosf(gamma);
    return (1.0f + k[0] * expf(k[1] / fmaxf(cos_theta, 1e-3f))) *
           (1.0f + k[2] * expf(k[3] * gamma) + k[4] * cg * cg);
}

/* Linear sRGB of Preetham's sky in direction w (w.y > 0), the sun at zenith angle
   theta_s in direction sun; relative units. */
static vec3 preetham(vec3 w, vec3 sun, float theta_s)
{
    const float T = SKY_TURBIDITY;
    /* Rows Y, x, y; columns A, B, C, D, E. */
    const float k[3][5] = {
        {0.1787f * T - 1.4630f, -0.3554f * T + 0.4275f, -0.0227f * T + 5.3251f,
         0.1206f * T - 2.5771f, -0.0670f * T + 0.3703f},
        {-0.0193f * T - 0.2592f, -0.0665f * T + 0.0008f, -0.0004f * T + 0.2125f,
         -0.0641f * T - 0.8989f, -0.0033f * T + 0.0452f},
        {-0.0167f * T - 0.2608f, -0.0950f * T + 0.0092f, -0.0079f * T + 0.2102f,
         -0.0441f * T - 1.6537f, -0.0109f * T + 0.0529f}};
    float t1 = theta_s, t2 = t1 * t1, t3 = t2 * t1;
    float chi = (4.0f / 9.0f - T / 120.0f) * (PI_F - 2.0f * theta_s);
    float zenith[3] = {
        (4.0453f * T - 4.9710f) * tanf(chi) - 0.2155f * T + 2.4192f,
        T * T * (0.00166f * t3 - 0.00375f * t2 + 0.00209f * t1) +
            T * (-0.02903f * t3 + 0.06377f * t2 - 0.03202f * t1 + 0.00394f) +
            (0.11693f * t3 - 0.21196f * t2 + 0.06052f * t1 + 0.25886f),
        T * T * (0.00275f * t3 - 0.00610f * t2 + 0.00317f * t1) +
            T * (-0.04214f * t3 + 0.08970f * t2 - 0.04153f * t1 + 0.00516f) +
            (0.15346f * t3 - 0.26756f * t2 + 0.06670f * t1 + 0.26688f)};
    float gamma = acosf(fminf(fmaxf(dot(w, sun), -1.0f), 1.0f)), v[3];
    for (int i = 0; i < 3; i++)
        v[i] = zenith[i] * perez(k[i], w.y, gamma) / perez(k[i], 1.0f, theta_s);
    float Y = v[0], X = v[1] / v[2] * Y, Z = (1.0f - v[1] - v[2]) / v[2] * Y;
    return v3(fmaxf(3.2406f * X - 1.5372f * Y - 0.4986f * Z, 0.0f),
              fmaxf(-0.9689f * X + 1.8758f * Y + 0.0415f * Z, 0.0f),
              fmaxf(0.0557f * X - 0.2040f * Y + 1.0570f * Z, 0.0f));
}

/* The direction of texel (column, row) of a width x height map (picvr.h's convention). */
static vec3 texel_direction(uint32_t column, uint32_t row, uint32_t width, uint32_t height)
{
    float theta = PI_F * ((float)row + 0.5f) / (float)height;
    float phi = 2.0f * PI_F * (((float)column + 0.5f) / (float)width - 0.5f);
    return v3(sinf(theta) * sinf(phi), cosf(theta), -sinf(theta) * cosf(phi));
}

static float sky_map[PVP_SKY_WIDTH * PVP_SKY_HEIGHT * 3];

/* Fills sky_map once (see "Sun and sky"), the sun in the centre column. */
static const float *sun_sky_map(void)
{
    static int built = 0;
    if (built) return sky_map;
    const uint32_t W = PVP_SKY_WIDTH, H = PVP_SKY_HEIGHT;
    float elevation = PVP_SUN_ELEVATION * PI_F / 180.0f, theta_s = 0.5f * PI_F - elevation;
    vec3 sun = v3(0.0f, sinf(elevation), -cosf(elevation));
    double irradiance = 0.0;  /* of the sky, unscaled, on a horizontal plane */
    for (uint32_t row = 0; row < H / 2; row++)
        for (uint32_t column = 0; column < W; column++) {
            vec3 w = texel_direction(column, row, W, H);
            vec3 L = preetham(w, sun, theta_s);
            store(&sky_map[3 * (row * W + column)], L);
            float solid_angle = 2.0f * PI_F / W * PI_F / H * sqrtf(1.0f - w.y * w.y);
            irradiance += (L.x * 0.2126f + L.y * 0.7152f + L.z * 0.0722f) * w.y * solid_angle;
        }
    float k = (float)(SKY_FRACTION * SUN_IRRADIANCE / irradiance);
    float ground = GROUND_ALBEDO / PI_F * SUN_IRRADIANCE * (sinf(elevation) + SKY_FRACTION);
    for (uint32_t i = 0; i < W * H * 3; i++)  /* rows 0 .. H/2 - 1: the sky */
        sky_map[i] = i < W * H / 2 * 3 ? k * sky_map[i] : ground;
    built = 1;
    return sky_map;
}

/* The sun over the camera's left shoulder (the azimuth of the sun preset) at
   PVP_SUN_ELEVATION, and the sky map turned to it. */
static void build_sun_sky(const scene_frame *f, pvp_lights *out)
{
    vec3 h = camera_direction(f, -0.45f, 0.0f, 0.40f);  /* its horizontal part: the azimuth */
    h.y = 0.0f;
    h = length(h) > 1e-6f ? normalize(h) : v3(0.0f, 0.0f, 1.0f);
    /* picvr turns the map by env_rotation about +y (right-handed): the centre column's
       horizontal direction (0, 0, -1) goes to (-sin a, 0, -cos a). */
    float a = atan2f(-h.x, -h.z), elevation = PVP_SUN_ELEVATION * PI_F / 180.0f;
    float c = cosf(elevation);
    picvr_light *l = next_light(out);
    l->type = PICVR_LIGHT_DIRECTIONAL;
    store(l->direction, v3(-sinf(a) * c, sinf(elevation), -cosf(a) * c));
    l->angular_diameter = 0.0093f;
    memcpy(l->color, SUN_COLOR, sizeof l->color);
    l->intensity = SUN_IRRADIANCE;
    set_background(out, 1.0f, 1.0f, 1.0f, 1.0f);
    out->background.environment = sun_sky_map();
    out->background.env_width = PVP_SKY_WIDTH;
    out->background.env_height = PVP_SKY_HEIGHT;
    out->background.env_rotation = a;
}

/* A point light just above the camera: irradiance S at the front of the volume. */
static void build_headlight(const scene_frame *f, pvp_lights *out)
{
    float R = f->radius;
    vec3 position = add(f->eye, scale(f->up, 0.1f * length(sub(f->eye, f->centre))));
    float d = length(sub(position, f->centre)) - 0.5f * R;
    if (d < 0.1f * R) d = 0.1f * R;
    picvr_light *l = next_light(out);
    l->type = PICVR_LIGHT_POINT;
    store(l->position, position);
    memcpy(l->color, WHITE, sizeof l->color);
    l->intensity = 16.0f * d * d;  /* radiant intensity I = E d^2 */
}

/* A point light just outside the volume's bounding sphere, above right in front:
   irradiance 8 at the centre, and a strong 1/d^2 falloff across the volume. */
static void build_point(const scene_frame *f, pvp_lights *out)
{
    float R = f->radius;
    vec3 position = add(f->centre, scale(normalize(camera_direction(f, 0.5f, 0.6f, 0.3f)), 1.05f * R));
    picvr_light *l = next_light(out);
    l->type = PICVR_LIGHT_POINT;
    store(l->position, position);
    memcpy(l->color, WHITE, sizeof l->color);
    l->intensity = 8.0f * 1.05f * 1.05f * R * R;  /* radiant intensity I = E d^2 */
}

typedef struct lights_entry {
    const char *name, *description;
    void (*build)(const scene_frame *f, pvp_lights *out);
} lights_entry;

static const lights_entry lights_table[] = {
    {"paper1", "one small, distant, very bright sphere light", build_paper1},
    {"paper3", "three large, very intense sphere lights close to the volume", build_paper3},
    {"paper4", "four dim, large rect lights surrounding the volume", build_paper4},
    {"paper1-bg", "paper1 plus a grey background", build_paper1_bg},
    {"paper3-bg", "paper3 plus a grey background", build_paper3_bg},
    {"paper4-bg", "paper4 plus a grey background", build_paper4_bg},
    {"studio", "warm key sphere + cool fill rect + dim background (the default)",
     build_studio},
    {"sun", "the sun (0.0093 rad) and a blue sky", build_sun},
    {"sun-sky", "the sun 35 degrees high and a clear sky (Preetham) over a grey ground",
     build_sun_sky},
    {"headlight", "a point light just above the camera", build_headlight},
    {"point", "a point light just outside the volume, above right in front", build_point},
};

#define LIGHTS_COUNT (sizeof lights_table / sizeof lights_table[0])

const char *pvp_lights_name(size_t index)
{
    return index < LIGHTS_COUNT ? lights_table[index].name : NULL;
}

const char *pvp_lights_description(size_t index)
{
    return index < LIGHTS_COUNT ? lights_table[index].description : NULL;
}

static int box_is_valid(const float box_min[3], const float box_max[3])
{
    for (int i = 0; i < 3; i++)
        if (!isfinite(box_min[i]) || !isfinite(box_max[i]) || box_max[i] < box_min[i])
            return 0;
    return 1;
}

/* Box centre and R; R is kept positive so a degenerate box still gives usable lights. */
static void box_sphere(const float box_min[3], const float box_max[3], vec3 *centre,
                       float *radius)
{
    vec3 lo = load(box_min), hi = load(box_max);
    *centre = scale(add(lo, hi), 0.5f);
    *radius = 0.5f * length(sub(hi, lo));
    if (!(*radius > 1e-6f)) *radius = 1e-6f;
}

/* Orbit position and up vector; up = d(position)/d(elevation), never parallel to
   the view direction, so the poles need no special case. */
static void orbit(vec3 centre, float azimuth_degrees, float elevation_degrees,
                  float distance, vec3 *eye, vec3 *up)
{
    float az = azimuth_degrees * PI_F / 180.0f, el = elevation_degrees * PI_F / 180.0f;
    vec3 dir = v3(cosf(el) * sinf(az), sinf(el), cosf(el) * cosf(az));
    *eye = add(centre, scale(dir, distance));
    *up = v3(-sinf(el) * sinf(az), cosf(el), -sinf(el) * cosf(az));
}

/* The camera's frame; a degenerate camera (eye at the centre, up along the view)
   falls back to the default orbit view or the world's y axis. */
static void camera_frame(const picvr_camera *camera, scene_frame *f)
{
    vec3 default_up;
    orbit(f->centre, PVP_DEFAULT_AZIMUTH, PVP_DEFAULT_ELEVATION, 2.9f * f->radius, &f->eye,
          &default_up);
    vec3 up = default_up;
    float fov = PVP_DEFAULT_FOV, aspect = 1.0f;
    if (camera && vec_is_finite(load(camera->position)) && vec_is_finite(load(camera->up)) &&
        length(sub(load(camera->position), f->centre)) > 1e-6f * f->radius) {
        f->eye = load(camera->position);
        up = length(load(camera->up)) > 0.0f ? load(camera->up) : v3(0.0f, 1.0f, 0.0f);
        if (camera->fov_y_degrees > 0.0f && camera->fov_y_degrees <= 179.0f)
            fov = camera->fov_y_degrees;
        if (camera->width > 0 && camera->height > 0)
            aspect = (float)camera->width / (float)camera->height;
    }
    f->forward = normalize(sub(f->centre, f->eye));
    f->right = cross(f->forward, normalize(up));
    f->right = length(f->right) > 1e-4f ? normalize(f->right)
                                        : perpendicular(scale(f->forward, -1.0f));
    f->up = cross(f->right, f->forward);
    f->tan_half_y = tanf(0.5f * fov * PI_F / 180.0f);
    f->tan_half_x = aspect * f->tan_half_y;
}

pvp_status pvp_lights_preset(const char *name, const float box_min[3],
                             const float box_max[3], const picvr_camera *camera,
                             pvp_lights *lights)
{
    if (!name || !box_min || !box_max || !lights) return PVP_ERROR_NULL_POINTER;
    const lights_entry *entry = NULL;
    for (size_t i = 0; i < LIGHTS_COUNT && !entry; i++)
        if (strcmp(name, lights_table[i].name) == 0) entry = &lights_table[i];
    if (!entry) return PVP_ERROR_UNKNOWN_NAME;
    if (!box_is_valid(box_min, box_max)) return PVP_ERROR_BAD_BOX;

    scene_frame f;
    box_sphere(box_min, box_max, &f.centre, &f.radius);
    camera_frame(camera, &f);
    memset(lights, 0, sizeof *lights);
    entry->build(&f, lights);
    return PVP_OK;
}

pvp_status pvp_orbit_camera(const float box_min[3], const float box_max[3],
                            float azimuth_degrees, float elevation_degrees,
                            float distance_factor, float fov_y_degrees,
                            uint32_t width, uint32_t height, picvr_camera *camera)
{
    static const float front[3] = {0.0f, 0.0f, 1.0f}, up[3] = {0.0f, 1.0f, 0.0f};
    return pvp_orbit_camera_frame(box_min, box_max, front, up, azimuth_degrees, elevation_degrees,
                                  distance_factor, fov_y_degrees, width, height, camera);
}

pvp_status pvp_orbit_camera_frame(const float box_min[3], const float box_max[3], const float front[3],
                                  const float up_axis[3], float azimuth_degrees, float elevation_degrees,
                                  float distance_factor, float fov_y_degrees, uint32_t width,
                                  uint32_t height, picvr_camera *camera)
{
    if (!box_min || !box_max || !front || !up_axis || !camera) return PVP_ERROR_NULL_POINTER;
    if (!box_is_valid(box_min, box_max)) return PVP_ERROR_BAD_BOX;
    if (!isfinite(azimuth_degrees) || !isfinite(elevation_degrees) ||
        !(distance_factor > 0.0f) || !isfinite(distance_factor) ||
        !(fov_y_degrees > 0.0f && fov_y_degrees <= 179.0f) || width < 1 || height < 1 ||
        width > PICVR_MAX_IMAGE_SIZE || height > PICVR_MAX_IMAGE_SIZE)
        return PVP_ERROR_BAD_ARGUMENT;
    vec3 zf = load(front), yf = load(up_axis);
    if (!vec_is_finite(zf) || !vec_is_finite(yf) || fabsf(length(zf) - 1.0f) > 1e-3f ||
        fabsf(length(yf) - 1.0f) > 1e-3f || fabsf(dot(zf, yf)) > 1e-3f)
        return PVP_ERROR_BAD_ARGUMENT;
    vec3 xf = cross(yf, zf);   /* the canonical frame's x = y x z, into the given one */

    /* The narrower of the vertical and horizontal half-angles decides the fit. */
    float half_v = 0.5f * fov_y_degrees * PI_F / 180.0f;
    float half_h = atanf((float)width / (float)height * tanf(half_v));
    float half = half_v < half_h ? half_v : half_h;

    vec3 centre, eye, up;
    float radius;
    box_sphere(box_min, box_max, &centre, &radius);
    orbit(v3(0.0f, 0.0f, 0.0f), azimuth_degrees, elevation_degrees,
          distance_factor * radius / sinf(half), &eye, &up);
    eye = add(centre, add(add(scale(xf, eye.x), scale(yf, eye.y)), scale(zf, eye.z)));
    up = add(add(scale(xf, up.x), scale(yf, up.y)), scale(zf, up.z));

    memset(camera, 0, sizeof *camera);
    store(camera->position, eye);
    store(camera->target, centre);
    store(camera->up, up);
    camera->fov_y_degrees = fov_y_degrees;
    camera->width = width;
    camera->height = height;
    return PVP_OK;
}

pvp_status pvp_patient_view(const char *name, float front[3], float up[3])
{
    static const struct { const char *name; float front[3], up[3]; } views[] = {
        {"anterior", {0, -1, 0}, {0, 0, 1}}, {"posterior", {0, 1, 0}, {0, 0, 1}},
        {"left", {1, 0, 0}, {0, 0, 1}},      {"right", {-1, 0, 0}, {0, 0, 1}},
        {"superior", {0, 0, 1}, {0, -1, 0}}, {"inferior", {0, 0, -1}, {0, -1, 0}},
    };
    if (!name || !front || !up) return PVP_ERROR_NULL_POINTER;
    for (size_t i = 0; i < sizeof views / sizeof views[0]; i++)
        if (!strcmp(name, views[i].name)) {
            memcpy(front, views[i].front, sizeof views[i].front);
            memcpy(up, views[i].up, sizeof views[i].up);
            return PVP_OK;
        }
    return PVP_ERROR_UNKNOWN_NAME;
}

pvp_status pvp_tf_rewindow(pvp_tf *tf, double from_lo, double from_hi, double to_lo, double to_hi)
{
    if (!tf) return PVP_ERROR_NULL_POINTER;
    double fs = from_hi - from_lo, ts = to_hi - to_lo;
    if (!(fs > 0.0) || !(ts > 0.0) || !isfinite(fs) || !isfinite(ts)) return PVP_ERROR_BAD_ARGUMENT;
    for (uint32_t i = 0; i < tf->count; i++) {
        double x = from_lo + (double)tf->points[i].value * fs;
        tf->points[i].value = (float)fmin(1.0, fmax(0.0, (x - to_lo) / ts));
    }
    return PVP_OK;
}

int pvp_is_hounsfield(const char *modality, double p005, double max)
{
    if (modality && !strcmp(modality, "CT")) return 1;
    return p005 >= -3100.0 && p005 <= -800.0 && max >= 0.0 && max <= 40000.0;
}

/* ---- transfer-function files ----------------------------------------------------------- */

#define TF_FILE_MAX_LINE 1024
#define TF_FILE_MAX_BYTES (1u << 20)   /* a table of 64 points is a few kB */

/* Parses exactly n finite floats separated by blanks from s (nothing else but blanks
   after them); returns how many were read, up to max. */
static int tf_floats(const char *s, float *v, int max)
{
    int n = 0;
    for (;;) {
        while (*s == ' ' || *s == '\t') s++;
        if (!*s || *s == '\n' || *s == '\r') return n;
        if (n == max) return max + 1;
        char *end;
        double x = strtod(s, &end);
        if (end == s || !isfinite(x) || fabs(x) > FLT_MAX) return -1;
        if (*end && *end != ' ' && *end != '\t' && *end != '\n' && *end != '\r') return -1;
        v[n++] = (float)x;
        s = end;
    }
}

#define TF_FAIL(...) do { if (err && err_size) snprintf(err, err_size, __VA_ARGS__); ok = 0; goto done; } while (0)

pvp_status pvp_tf_load(const char *path, pvp_tf *tf, char *err, size_t err_size)
{
    if (!path || !tf) return PVP_ERROR_NULL_POINTER;
    memset(tf, 0, sizeof *tf);
    FILE *f = fopen(path, "rb");
    if (!f) {
        if (err && err_size) snprintf(err, err_size, "%s: cannot open", path);
        return PVP_ERROR_UNKNOWN_NAME;
    }
    char line[TF_FILE_MAX_LINE + 2];
    int ok = 1, units_value = 0, lineno = 0;
    size_t total = 0;
    pvp_tf t;
    memset(&t, 0, sizeof t);
    t.density = 1.0f;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        size_t len = strlen(line);
        total += len;
        if (total > TF_FILE_MAX_BYTES) TF_FAIL("%s: larger than %u bytes", path, TF_FILE_MAX_BYTES);
        if (len == sizeof line - 1 && line[len - 1] != '\n') TF_FAIL("%s:%d: line longer than %d bytes", path, lineno, TF_FILE_MAX_LINE);
        if (memchr(line, '\0', len) != NULL && strlen(line) != len) TF_FAIL("%s:%d: a NUL byte", path, lineno);
        char *hash = strchr(line, '#');
        if (hash) *hash = '\0';
        char *s = line;
        while (*s == ' ' || *s == '\t') s++;
        if (!*s || *s == '\n' || *s == '\r') continue;
        if (!strncmp(s, "units", 5) && (s[5] == ' ' || s[5] == '\t')) {
            if (t.count) TF_FAIL("%s:%d: 'units' after the first point", path, lineno);
            char word[32];
            if (sscanf(s + 5, " %31s", word) != 1 || (strcmp(word, "normalized") && strcmp(word, "value")))
                TF_FAIL("%s:%d: units normalized or units value", path, lineno);
            units_value = !strcmp(word, "value");
            continue;
        }
        if (!strncmp(s, "density", 7) && (s[7] == ' ' || s[7] == '\t')) {
            float d;
            if (tf_floats(s + 7, &d, 1) != 1 || !(d >= 0.0f)) TF_FAIL("%s:%d: density D, D >= 0", path, lineno);
            t.density = d;
            continue;
        }
        if (!strncmp(s, "bounces", 7) && (s[7] == ' ' || s[7] == '\t')) {
            char word[32];
            char *endp;
            if (sscanf(s + 7, " %31s", word) != 1) TF_FAIL("%s:%d: bounces N or bounces unlimited", path, lineno);
            if (!strcmp(word, "unlimited")) t.max_bounces = PICVR_BOUNCES_UNLIMITED;
            else {
                unsigned long b = strtoul(word, &endp, 10);
                if (*endp || word[0] == '-' || b > 1000000ul) TF_FAIL("%s:%d: bounces N (0..1000000) or unlimited", path, lineno);
                t.max_bounces = (uint32_t)b;
            }
            continue;
        }
        float v[6] = {0, 0, 0, 0, 0, 0};
        int n = tf_floats(s, v, 6);
        if (n != 5 && n != 6) TF_FAIL("%s:%d: a point is 'value r g b opacity [g]'", path, lineno);
        if (t.count == PVP_MAX_TF_POINTS) TF_FAIL("%s:%d: more than %d points", path, lineno, PVP_MAX_TF_POINTS);
        if (t.count && v[0] < t.points[t.count - 1].value) TF_FAIL("%s:%d: values must not decrease", path, lineno);
        for (int c = 1; c <= 3; c++)
            if (!(v[c] >= 0.0f && v[c] <= 1.0f)) TF_FAIL("%s:%d: albedo r g b in [0, 1]", path, lineno);
        if (!(v[4] >= 0.0f)) TF_FAIL("%s:%d: opacity >= 0", path, lineno);
        if (!(v[5] > -1.0f && v[5] < 1.0f)) TF_FAIL("%s:%d: g in (-1, 1)", path, lineno);
        if (!units_value && !(v[0] >= 0.0f && v[0] <= 1.0f)) TF_FAIL("%s:%d: normalized values are in [0, 1] (or say 'units value')", path, lineno);
        picvr_tf_point *p = &t.points[t.count++];
        p->value = v[0];
        p->albedo[0] = v[1]; p->albedo[1] = v[2]; p->albedo[2] = v[3];
        p->opacity = v[4];
        p->g = v[5];
    }
    if (ferror(f)) TF_FAIL("%s: read error", path);
    if (t.count < 2) TF_FAIL("%s: at least two points", path);
    if (units_value) {   /* the window is the points' span; the points become 0..1 of it */
        float lo = t.points[0].value, hi = t.points[t.count - 1].value;
        double span = (double)hi - (double)lo;
        if (!(span > 0.0) || !isfinite(span)) TF_FAIL("%s: the points span no values (first = last)", path);
        for (uint32_t i = 0; i < t.count; i++)
            t.points[i].value = (float)fmin(1.0, fmax(0.0, ((double)t.points[i].value - lo) / span));
        t.window_kind = PVP_WINDOW_VALUE;
        t.window[0] = lo;
        t.window[1] = hi;
    }
done:
    fclose(f);
    if (!ok) return PVP_ERROR_BAD_ARGUMENT;
    *tf = t;
    return PVP_OK;
}

/* uint: a uint32_t field (a whole number), else a float. */
static const struct { const char *name; size_t offset; int uint; } cache_params[] = {
    {"gamma", offsetof(picvr_cache_config, gamma), 0},
    {"epsilon", offsetof(picvr_cache_config, epsilon), 0},
    {"delta_voxels", offsetof(picvr_cache_config, delta_voxels), 0},
    {"radius_min_voxels", offsetof(picvr_cache_config, radius_min_voxels), 0},
    {"radius_max_voxels", offsetof(picvr_cache_config, radius_max_voxels), 0},
    {"update_threshold", offsetof(picvr_cache_config, update_threshold), 0},
    {"lookup_event", offsetof(picvr_cache_config, lookup_event), 1},
};
#define CACHE_PARAMS (sizeof cache_params / sizeof cache_params[0])

const char *pvp_cache_param_name(size_t index)
{
    return index < CACHE_PARAMS ? cache_params[index].name : NULL;
}

float pvp_cache_param_get(const picvr_cache_config *c, size_t index)
{
    if (!c || index >= CACHE_PARAMS) return 0.0f;
    const char *field = (const char *)c + cache_params[index].offset;
    if (cache_params[index].uint) {
        uint32_t u;
        memcpy(&u, field, sizeof u);
        return (float)u;
    }
    float v;
    memcpy(&v, field, sizeof v);
    return v;
}

/* Rule: values must be positive and finite (0 is each field's default: leave the name
   out); a uint field takes whole numbers up to UINT32_MAX, which the library validates. */
pvp_status pvp_cache_param_set(picvr_cache_config *c, const char *name_value)
{
    if (!c || !name_value) return PVP_ERROR_NULL_POINTER;
    const char *eq = strchr(name_value, '=');
    size_t len = eq ? (size_t)(eq - name_value) : strlen(name_value);
    for (size_t i = 0; i < CACHE_PARAMS; i++) {
        if (strlen(cache_params[i].name) != len || strncmp(name_value, cache_params[i].name, len))
            continue;
        if (!eq) return PVP_ERROR_BAD_ARGUMENT;
        char *end;
        double v = strtod(eq + 1, &end);
        if (end == eq + 1 || *end || !(v > 0.0) || v > FLT_MAX) return PVP_ERROR_BAD_ARGUMENT;
        char *field = (char *)c + cache_params[i].offset;
        if (cache_params[i].uint) {
            if (v != floor(v) || v > (double)UINT32_MAX) return PVP_ERROR_BAD_ARGUMENT;
            uint32_t u = (uint32_t)v;
            memcpy(field, &u, sizeof u);
            return PVP_OK;
        }
        float f = (float)v;
        memcpy(field, &f, sizeof f);
        return PVP_OK;
    }
    return PVP_ERROR_UNKNOWN_NAME;
}

const char *pvp_status_string(pvp_status status)
{
    switch (status) {
    case PVP_OK: return "PVP_OK";
    case PVP_ERROR_NULL_POINTER: return "PVP_ERROR_NULL_POINTER";
    case PVP_ERROR_UNKNOWN_NAME: return "PVP_ERROR_UNKNOWN_NAME";
    case PVP_ERROR_BAD_BOX: return "PVP_ERROR_BAD_BOX";
    case PVP_ERROR_BAD_ARGUMENT: return "PVP_ERROR_BAD_ARGUMENT";
    }
    return "PVP_ERROR_UNKNOWN_STATUS";
}
