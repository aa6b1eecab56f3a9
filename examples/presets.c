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
} tf_entry;

#define GREY(g) {g, g, g}

/* Normalized data values; the thresholds follow the histograms of the data sets in
   ../shared/data (e.g. bonsai: air below 0.15, foliage and trunk above 0.25). */
static const tf_entry tf_table[] = {
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
    {"ct-bone", "generic CT: faint reddish soft tissue, dense white bone", 1.0f, 6,
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
    if (!box_min || !box_max || !camera) return PVP_ERROR_NULL_POINTER;
    if (!box_is_valid(box_min, box_max)) return PVP_ERROR_BAD_BOX;
    if (!isfinite(azimuth_degrees) || !isfinite(elevation_degrees) ||
        !(distance_factor > 0.0f) || !isfinite(distance_factor) ||
        !(fov_y_degrees > 0.0f && fov_y_degrees <= 179.0f) || width < 1 || height < 1 ||
        width > PICVR_MAX_IMAGE_SIZE || height > PICVR_MAX_IMAGE_SIZE)
        return PVP_ERROR_BAD_ARGUMENT;

    /* The narrower of the vertical and horizontal half-angles decides the fit. */
    float half_v = 0.5f * fov_y_degrees * PI_F / 180.0f;
    float half_h = atanf((float)width / (float)height * tanf(half_v));
    float half = half_v < half_h ? half_v : half_h;

    vec3 centre, eye, up;
    float radius;
    box_sphere(box_min, box_max, &centre, &radius);
    orbit(centre, azimuth_degrees, elevation_degrees,
          distance_factor * radius / sinf(half), &eye, &up);

    memset(camera, 0, sizeof *camera);
    store(camera->position, eye);
    store(camera->target, centre);
    store(camera->up, up);
    camera->fov_y_degrees = fov_y_degrees;
    camera->width = width;
    camera->height = height;
    return PVP_OK;
}

static const struct { const char *name; size_t offset; } cache_params[] = {
    {"gamma", offsetof(picvr_cache_config, gamma)},
    {"epsilon", offsetof(picvr_cache_config, epsilon)},
    {"delta_voxels", offsetof(picvr_cache_config, delta_voxels)},
    {"radius_min_voxels", offsetof(picvr_cache_config, radius_min_voxels)},
    {"radius_max_voxels", offsetof(picvr_cache_config, radius_max_voxels)},
    {"update_threshold", offsetof(picvr_cache_config, update_threshold)},
};
#define CACHE_PARAMS (sizeof cache_params / sizeof cache_params[0])

const char *pvp_cache_param_name(size_t index)
{
    return index < CACHE_PARAMS ? cache_params[index].name : NULL;
}

float pvp_cache_param_get(const picvr_cache_config *c, size_t index)
{
    if (!c || index >= CACHE_PARAMS) return 0.0f;
    float v;
    memcpy(&v, (const char *)c + cache_params[index].offset, sizeof v);
    return v;
}

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
        float f = (float)v;
        memcpy((char *)c + cache_params[i].offset, &f, sizeof f);
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
