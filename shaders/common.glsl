// common.glsl - shared code of the picvr kernels: scene layout, random numbers,
// volume and transfer-function lookups, majorant-grid traversal, delta and ratio
// tracking (paper Eq. 1-3), light sampling with MIS.  One procedure per .comp file
// includes this.  Names follow the paper: sigma_t (extinction), tau (optical depth).
//
// Loop bounds: llvmpipe silently truncates loops past 65535 total iterations per
// invocation (../shared/LAVAPIPE.md), so every tracking loop runs at most
// MAX_TRACK_STEPS iterations; a loop that hits the bound sets `truncated` and the
// sample is counted in the stats.  A render invocation runs at most three tracking
// loops (primary, light sample, phase sample): 3 * 4096 << 65535.

#define PI 3.14159265358979
#include "sampling_math.glsl"
#define INV_4PI 0.0795774715459477
#ifndef MAX_TRACK_STEPS
#define MAX_TRACK_STEPS 4096u   // a kernel may lower it before including this file
#endif
#define TF_SIZE 4096.0
#define MAX_LIGHTS 32
#define GPU_CLIP_PLANES 14   // PICVR_GPU_CLIP_PLANES: PICVR_MAX_CLIP_PLANES + the clip box's 6
#define PDF_CAP 1e18   // a light whose solid-angle pdf exceeds this acts as a delta light

// Specialization: scenes whose lights are all delta lights (point, zero-size sun) and
// that have no background need no phase-sampled rays at all.
layout(constant_id = 0) const bool USE_PHASE_MIS = true;

#define LIGHT_SPHERE 1
#define LIGHT_RECT 2
#define LIGHT_DIRECTIONAL 3
#define LIGHT_POINT 4

// One light, packed by host/lights.c (picvr_pack_light); host mirror picvr_gpu_light.
struct Light {
    vec3 pos;      int type;     // position (sphere/rect centre, point) or unit direction
                                 // toward the light (directional); LIGHT_*
    vec3 radiance; float pmf;    // radiance (area; directional: E / (pi sin^2 half angle)),
                                 // irradiance (delta directional) or intensity (point);
                                 // the probability of choosing this light
    vec3 edge_u;   float size;   // rect edge_u; sphere radius, or 1 - cos(half angle) for
                                 // directional (0: a delta light)
    vec3 edge_v;   float area;   // rect edge_v and area
    float cdf;     float eq_pmf;  // upper end of its interval; the probability of choosing
                                 // it for equiangular sampling (0: not served)
    float eq_cdf;  float unused0; // upper end of its equiangular interval
};

// The scene (host mirror: picvr_gpu_scene in host/internal.h; `make check-layout`
// compares every member's offset).  Each line is one 16-byte std140 slot.
layout(set = 0, binding = 0, std140) uniform Scene {
    vec3 cam_pos;    float tan_half_fov;      // tan(fov_y / 2)
    vec3 cam_fwd;    float aspect;            // width / height
    vec4 cam_right;                           // xyz; w unused
    vec4 cam_up;                              // xyz; w unused
    vec3 box_min;    float density;           // world box min; density factor D (Fig. 9)
    vec3 box_size;   float bound_radius;      // world box size; radius of its bounding sphere
    vec3 cell_size;  float min_spacing;       // world size of a majorant cell; smallest spacing
    uvec3 grid;      uint light_count;        // majorant grid dims; number of lights
    uvec4 image;                              // x width, y height
    uvec4 dims;                               // xyz voxel dims
    vec3 background; float background_pmf;    // rgb radiance; probability of choosing it
    vec4 value_map;                           // normalized value = clamp(texel * x + y, 0, 1)
    float gamma; float epsilon; float delta; float update_threshold;
                                              // Eq. 5's gamma, Eq. 10's epsilon, Delta (world),
                                              // §4.3's conflict threshold
    float radius_min; float radius_max;       // validity radius bounds (world)
    uint curvature_limit; uint medium_model;  // 1: on (cache_math.glsl, curvature_radius and
                                              // medium_fraction)
    uint max_entries; uint max_nodes; uint max_refs; uint max_requests; // pool capacities
    uint superpixel_side; uint superpixels_per_row; uint superpixel_count; // §5.2
    float probe_fraction;                     // the consistent blend's least probe
                                              // probability (cache_blend.glsl)
    uint debug_view; uint view_unused0; uint view_unused1; uint view_unused2; // VIEW_*
    vec3 light_log_k; float mono_channel;     // lights of one chromaticity k (host/lights.c,
                                              // picvr_light_chromaticity): ln(k_c / k_m)
                                              // (CM_LN_E_MIN - CM_LN_E_MAX where k_c = 0);
                                              // the channel m, also MONO_CHANNEL
    uint max_bounces; float back_g; float back_weight; uint vertex_cost;
                                              // picvr_scattering (0xffffffff: unlimited);
                                              // path-pool charge per path vertex (path.glsl)
    uint env_w; uint env_h; float env_unused0; float env_unused1; // environment map texels
    Light lights[MAX_LIGHTS];
    vec4 env_basis[3];                        // rows (xyz) of the map's frame from the
                                              // volume's: the volume's orientation, then
                                              // the map's rotation about world +y
    vec4 clip[GPU_CLIP_PLANES];               // the volume's frame: keep dot(xyz, x) + w >= 0
    uint clip_count; uint clip_unused0; uint clip_unused1; uint clip_unused2;
} scene;

layout(set = 0, binding = 1) uniform sampler3D volume_tex;   // normalized data value
layout(set = 0, binding = 2) uniform sampler1D tf_tex;       // rgb albedo, a opacity
layout(set = 0, binding = 3, std430) readonly buffer Majorant { float majorant[]; };

// ---- random numbers: a counter-based hash of (pixel, iteration, dimension, seed) ----
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// key and counter: the hash stream of one sample.  lattice_key and index: the sample's
// place in its pixel's low-discrepancy sequence (qmc below).
struct Rng { uint key; uint counter; uint lattice_key; uint index; };

Rng rng_init(uint pixel, uint iteration, uint seed) {
    Rng r;
    r.key = pcg_hash(pixel ^ pcg_hash(iteration ^ pcg_hash(seed + 0x9e3779b9u)));
    r.counter = 0u;
    r.lattice_key = pcg_hash(pixel ^ pcg_hash(seed + 0x7f4a7c15u));
    r.index = iteration;
    return r;
}

// Dimension dim (0-2) of sample `index` of a randomly shifted Kronecker sequence, the
// R3 sequence (Roberts 2018: frac(shift + n alpha), alpha_d = g^-d, g the root of
// x^4 = x + 1): successive samples of a pixel fill its 3D space evenly, so smooth
// integrands over these dimensions (the pixel's jitter, the equiangular distance)
// converge faster than with independent numbers.  The shift is uniform and fixed per
// pixel (lattice_key), so every sample is uniform on its own and the estimate stays
// unbiased.  32-bit fixed point: n alpha mod 1 is exact for any n.
// Specialization: the pixel's jitter from the sequence (false: independent numbers, the
// paper's baseline as picvr_config.distance_sampling FREE_FLIGHT renders it).
layout(constant_id = 9) const bool USE_QMC = true;

float qmc(Rng r, uint dim) {
    uint alpha = dim == 0u ? 3518319154u : dim == 1u ? 2882110346u : 2360945575u;
    uint x = r.index * alpha + pcg_hash(r.lattice_key + dim * 0x9e3779b9u);
    return float(x >> 8u) * (1.0 / 16777216.0);
}

// Uniform in [0,1): 24 random bits, so 1 - u is never 0.
float rnd(inout Rng r) {
    uint h = pcg_hash(r.key ^ pcg_hash(r.counter * 0x68bc21ebu + 0x02e5be93u));
    r.counter++;
    return float(h >> 8u) * (1.0 / 16777216.0);
}

// ---- geometry helpers ----
vec3 uniform_sphere(float u1, float u2) {
    float z = 1.0 - 2.0 * u1;
    float r = sqrt(max(0.0, 1.0 - z * z));
    float phi = 2.0 * PI * u2;
    return vec3(r * cos(phi), r * sin(phi), z);
}

// Orthonormal basis around unit n (Duff et al. 2017, branchless).
void basis(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}

// A direction at angle acos(cos_t) from unit axis, at azimuth 2 pi u.
vec3 around(vec3 axis, float cos_t, float u) {
    float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    float phi = 2.0 * PI * u;
    vec3 t, b;
    basis(axis, t, b);
    return normalize(cos_t * axis + sin_t * (cos(phi) * t + sin(phi) * b));
}

// Uniform direction in the cone of solid angle 2 pi omc around unit axis, where
// omc = 1 - cos(half angle) is passed directly so tiny cones keep their precision:
// sin^2 = (1 - cos)(1 + cos) = u omc (2 - u omc).
vec3 sample_cone(vec3 axis, float omc, float u1, float u2) {
    float one_minus_cos = u1 * omc;
    float cos_t = 1.0 - one_minus_cos;
    float sin_t = sqrt(max(0.0, one_minus_cos * (2.0 - one_minus_cos)));
    float phi = 2.0 * PI * u2;
    vec3 t, b;
    basis(axis, t, b);
    return normalize(cos_t * axis + sin_t * (cos(phi) * t + sin(phi) * b));
}

// 1 / d with |d| >= 1e-30 (keeps slab tests finite for axis-parallel rays).
vec3 safe_inverse(vec3 d) {
    vec3 s = mix(vec3(-1.0), vec3(1.0), greaterThanEqual(d, vec3(0.0)));
    return 1.0 / (s * max(abs(d), vec3(1e-30)));
}

// Specialization: clip planes (picvr_set_clip; false: none, nothing of them compiled).
layout(constant_id = 14) const bool USE_CLIP = false;

// Ray / clip plane: narrows [t0, t1] to where dot(n, x) + w >= 0.  A ray parallel to the
// plane (dot(n, rd) = 0) keeps all or nothing by its origin's side; the division is by a
// non-zero number only.
void clip_interval(vec4 plane, vec3 ro, vec3 rd, inout float t0, inout float t1) {
    float s = dot(plane.xyz, ro) + plane.w, c = dot(plane.xyz, rd);
    if (c > 0.0) t0 = max(t0, -s / c);
    else if (c < 0.0) t1 = min(t1, -s / c);
    else if (s < 0.0) t1 = t0;
}

// Ray / volume box (and the clip planes, whose region with the box is convex, so one
// interval): [t0, t1] clipped to t >= 0; false when missed.  Every tracking loop starts
// here, so a clipped region is empty for all of them.
bool box_interval(vec3 ro, vec3 rd, out float t0, out float t1) {
    vec3 inv = safe_inverse(rd);
    vec3 a = (scene.box_min - ro) * inv;
    vec3 b = (scene.box_min + scene.box_size - ro) * inv;
    vec3 lo = min(a, b), hi = max(a, b);
    t0 = max(max(lo.x, lo.y), max(lo.z, 0.0));
    t1 = min(min(hi.x, hi.y), hi.z);
    if (USE_CLIP)
        for (uint i = 0u; i < scene.clip_count; i++) clip_interval(scene.clip[i], ro, rd, t0, t1);
    return t1 > t0;
}

// x is inside every clip plane (always true without USE_CLIP).
bool inside_clip(vec3 x) {
    if (USE_CLIP)
        for (uint i = 0u; i < scene.clip_count; i++)
            if (dot(scene.clip[i].xyz, x) + scene.clip[i].w < 0.0) return false;
    return true;
}

// picvr_debug_view (picvr.h): what the rendering procedure writes.
#define VIEW_IMAGE 0u
#define VIEW_CACHE 1u
#define VIEW_CACHE_ERROR 2u
// Specialization: the debug views' code is compiled into the cached rendering procedure
// only in the variant that renders them (picvr_set_view): in every variant it would slow
// llvmpipe's kernel, as the error view inlines a second copy of the direct-light
// sampling (docs/performance.md, "Design choices, measured").
layout(constant_id = 3) const bool USE_DEBUG_VIEW = false;

// Rec. 709 luminance: the scalar of Eq. 5, Eq. 12, the update's conflicts and the
// error view.
float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }

// ---- medium: sigma_t(x) = D * opacity(v(x)) per world unit ----
vec4 transfer(float v) {
    return texture(tf_tex, (clamp(v, 0.0, 1.0) * (TF_SIZE - 1.0) + 0.5) / TF_SIZE);
}

float data_value(vec3 x) {
    float texel = texture(volume_tex, (x - scene.box_min) / scene.box_size).r;
    return clamp(texel * scene.value_map.x + scene.value_map.y, 0.0, 1.0);
}

float sigma_t(vec3 x) { return scene.density * transfer(data_value(x)).a; }

// sigma_t with nothing outside the volume's box, as the tracking loops see it (they
// clip every ray to the box).  sigma_t alone reads the texture clamped to its edge, so
// a probe beyond a face of a volume whose border voxels are dense would find medium
// there: the cache's probes around an entry (its normal, Delta and medium fractions)
// use this one.
float sigma_t_in_box(vec3 x) {
    vec3 hi = scene.box_min + scene.box_size;
    return all(greaterThanEqual(x, scene.box_min)) && all(lessThanEqual(x, hi)) && inside_clip(x) ? sigma_t(x) : 0.0;
}

vec3 albedo_at(vec3 x) { return transfer(data_value(x)).rgb; }

// ---- the phase function (picvr_tf_point.g, picvr_scattering's second lobe) ----
// Specialization: Henyey-Greenstein lobes (false: isotropic, f = 1 / (4 pi), the paper's;
// the host turns it on when some g or the second lobe is not 0).
layout(constant_id = 11) const bool USE_HG = false;
// g per transfer-function entry (host/transfer.c); a 4-float placeholder without USE_HG.
layout(set = 0, binding = 18, std430) readonly buffer TfPhase { float tf_g[]; };

// The phase function at a scatter point: d the direction the light travels into it (the
// ray's), g the first lobe's asymmetry there.  cos(theta) = dot(d, w) for a scattered
// direction w, so g > 0 scatters forward.
struct Phase { vec3 d; float g; };

// g at x, interpolated between table entries as the texture interpolates the albedo.
Phase phase_at(vec3 x, vec3 d) {
    Phase ph;
    ph.d = d;
    ph.g = 0.0;
    if (USE_HG) {
        float f = data_value(x) * (TF_SIZE - 1.0);
        uint i = min(uint(f), uint(TF_SIZE) - 2u);
        ph.g = mix(tf_g[i], tf_g[i + 1u], clamp(f - float(i), 0.0, 1.0));
    }
    return ph;
}

// The phase function's value (per steradian) for the scattered direction w; also the
// solid-angle pdf of phase_sample, which samples it exactly.
float phase_eval(Phase ph, vec3 w) {
    if (!USE_HG) return INV_4PI;
    return cm_phase_eval(ph.g, scene.back_g, scene.back_weight, dot(ph.d, w));
}

// A direction drawn from the phase function (exactly: f / pdf = 1).
vec3 phase_sample(Phase ph, float u1, float u2) {
    if (!USE_HG) return uniform_sphere(u1, u2);
    return around(ph.d, cm_phase_sample_cos(ph.g, scene.back_g, scene.back_weight, u1), u2);
}

// ---- majorant grids: bricks (coarse) and voxels (fine) ----
// Coarse: one majorant per brick of `brick` voxels (with a one-voxel apron), plus an
// empty-space distance.  Fine, used only inside bricks where delta tracking would take
// many steps (dense media: majorant * length > FINE_THRESHOLD): the dual grid of voxel
// centres, where the trilinear value is a convex combination of the 8 corner texels,
// so D * max(opacity over [min, max] of the corners) bounds sigma_t exactly.
#define FINE_THRESHOLD 64.0
// Specialization constant: the host turns the voxel-level path on only when some brick
// needs it (majorant * brick diagonal > FINE_THRESHOLD).  Compiled out otherwise: its
// eight texel fetches alone make llvmpipe's kernel much slower (docs/performance.md).
layout(constant_id = 1) const bool USE_FINE = true;

layout(set = 0, binding = 8, std430) readonly buffer TfRangeMax { float tf_range_max[]; };

struct Dda {
    ivec3 cell;
    ivec3 stp;
    ivec3 hi;       // last valid cell per axis (the first is 0)
    vec3 t_next;    // ray parameter of the next boundary per axis
    vec3 t_delta;   // ray parameter across one cell per axis
};

// DDA over cells of size cs whose cell (0,0,0) starts at origin.
Dda dda_start(vec3 ro, vec3 rd, float t, vec3 origin, vec3 cs, ivec3 hi) {
    Dda d;
    vec3 p = (ro + rd * t - origin) / cs;
    d.hi = hi;
    d.cell = clamp(ivec3(floor(p)), ivec3(0), hi);
    d.stp = ivec3(mix(vec3(-1.0), vec3(1.0), greaterThanEqual(rd, vec3(0.0))));
    vec3 inv = safe_inverse(rd);
    vec3 boundary = (vec3(d.cell) + vec3(greaterThan(d.stp, ivec3(0)))) * cs + origin;
    d.t_next = max((boundary - ro) * inv, vec3(t));
    d.t_delta = abs(cs * inv);
    return d;
}

Dda coarse_start(vec3 ro, vec3 rd, float t) {
    return dda_start(ro, rd, t, scene.box_min, scene.cell_size, ivec3(scene.grid) - 1);
}

// Fine cells are shifted by half a voxel (dual grid), so cell j spans voxel centres
// j-1 .. j (texels clamped at the border); there are dims + 1 of them per axis.
Dda fine_start(vec3 ro, vec3 rd, float t) {
    vec3 spacing = scene.box_size / vec3(scene.dims.xyz);
    return dda_start(ro, rd, t, scene.box_min - 0.5 * spacing, spacing, ivec3(scene.dims.xyz));
}

uint cell_index(Dda d) {
    uvec3 c = uvec3(d.cell);
    return c.x + scene.grid.x * (c.y + scene.grid.y * c.z);
}

float cell_majorant(Dda d) { return majorant[cell_index(d)]; }

float texel_value(ivec3 q) {
    q = clamp(q, ivec3(0), ivec3(scene.dims.xyz) - 1);
    return clamp(texelFetch(volume_tex, q, 0).r * scene.value_map.x + scene.value_map.y, 0.0, 1.0);
}

// Largest table opacity over entries [lo, hi] (sparse table: level k holds the max of
// 2^k entries), with one entry of margin each side as on the host.
float opacity_range_max(float vmin, float vmax) {
    int lo = max(int(floor(vmin * (TF_SIZE - 1.0))) - 1, 0);
    int hi = min(int(ceil(vmax * (TF_SIZE - 1.0))) + 1, int(TF_SIZE) - 1);
    int k = findMSB(hi - lo + 1);
    int n = int(TF_SIZE);
    return max(tf_range_max[k * n + lo], tf_range_max[k * n + hi - (1 << k) + 1]);
}

// Written out (no loop) so it does not count against llvmpipe's loop budget.
float fine_majorant(Dda f) {
    ivec3 j = f.cell - 1;
    float a = texel_value(j),                 b = texel_value(j + ivec3(1, 0, 0));
    float c = texel_value(j + ivec3(0, 1, 0)), d = texel_value(j + ivec3(1, 1, 0));
    float e = texel_value(j + ivec3(0, 0, 1)), g = texel_value(j + ivec3(1, 0, 1));
    float h = texel_value(j + ivec3(0, 1, 1)), k = texel_value(j + ivec3(1, 1, 1));
    float vmin = min(min(min(a, b), min(c, d)), min(min(e, g), min(h, k)));
    float vmax = max(max(max(a, b), max(c, d)), max(max(e, g), max(h, k)));
    return scene.density * opacity_range_max(vmin, vmax) * 1.001;
}

// Empty-space skipping.  The second half of the majorant buffer holds, per empty
// cell, the Chebyshev distance k (in cells) to the nearest non-empty cell.  From any
// point p of cell c, a move of less than m = k - 1 cells along every axis stays in
// cells within distance m of c, all empty; so the ray may jump by
// t = m / max_i(|rd_i| / cell_size_i) and restart the DDA there.  Returns 0 when
// no jump is possible (k < 2).
float empty_skip(Dda d, vec3 rd) {
    uint cells = scene.grid.x * scene.grid.y * scene.grid.z;
    float m = majorant[cells + cell_index(d)] - 1.0;
    if (m < 1.0) return 0.0;
    vec3 speed = abs(rd) / scene.cell_size;     // cells per unit of t, per axis
    return m / max(max(speed.x, speed.y), max(speed.z, 1e-30));
}

float dda_exit(Dda d) { return min(d.t_next.x, min(d.t_next.y, d.t_next.z)); }

// Moves to the next cell; false when the ray leaves the grid.
bool dda_advance(inout Dda d) {
    if (d.t_next.x <= d.t_next.y && d.t_next.x <= d.t_next.z) {
        d.cell.x += d.stp.x; d.t_next.x += d.t_delta.x;
    } else if (d.t_next.y <= d.t_next.z) {
        d.cell.y += d.stp.y; d.t_next.y += d.t_delta.y;
    } else {
        d.cell.z += d.stp.z; d.t_next.z += d.t_delta.z;
    }
    return all(greaterThanEqual(d.cell, ivec3(0))) && all(lessThanEqual(d.cell, d.hi));
}

// One ratio-tracking collision with extinction s under majorant m: T *= 1 - s / m (Eq.
// 2), and Russian roulette below 0.1, which ends long, dark paths early without bias
// (a survivor is raised to 0.1).  Returns true when the path ended (T = 0).
bool ratio_collide(inout float T, float s, float m, inout Rng rng) {
    // s <= m by construction; the clamp keeps T >= 0 under rounding
    T *= clamp(1.0 - s / m, 0.0, 1.0);
    if (T < 0.1) {
        if (T <= 0.0 || rnd(rng) >= T * 10.0) { T = 0.0; return true; }
        T = 0.1;
    }
    return false;
}

// Specialization: transmittance by residual ratio tracking (true) or plain ratio
// tracking (false, the paper's Exposure Render estimator).
layout(constant_id = 8) const bool USE_RESIDUAL = true;

// The control extinction of residual ratio tracking in coarse cell d: the cell's
// minorant (the third part of the majorant buffer; 0 where the transfer function
// reaches 0 over the cell's value range), so sigma_t - control lies in [0, majorant -
// control] everywhere in the cell.
float cell_minorant(Dda d) {
    uint cells = scene.grid.x * scene.grid.y * scene.grid.z;
    return majorant[2u * cells + cell_index(d)];
}

// The control c of cell d whose majorant is maj: its minorant with USE_RESIDUAL (at most
// maj; 0 in empty cells), else 0.
float cell_control(Dda d, float maj) { return USE_RESIDUAL && maj > 0.0 ? min(cell_minorant(d), maj) : 0.0; }

// One tentative collision at t under majorant m and control c (the minorant with
// USE_RESIDUAL, else 0).  Delta tracking: real with probability sigma_t / m (returns
// true); below the control c <= sigma_t that holds without looking sigma_t up.  Ratio
// tracking: T takes the weight 1 - (sigma_t - c) / (m - c) (residual ratio tracking,
// Novak et al. 2014, "Residual ratio tracking for estimating attenuation in participating
// media", §5: the control's part exp(-c l) is applied exactly by the caller along the
// way, the residual part is ratio-tracked, so E[T] = exp(-tau)); returns true when T
// fell to 0.
bool tentative_collision(bool ratio, vec3 x, float m, float c, inout float T, inout Rng rng) {
    if (!ratio) {
        float u = rnd(rng) * m;
        return u < c || u < sigma_t(x);
    }
    return ratio_collide(T, sigma_t(x) - c, m - c, rng);
}

// The next tentative collision after t under majorant m and control c: delta tracking
// at rate m, ratio tracking at rate m - c (the residual); t_end when the rate is 0.  Ratio
// tracking's T takes the control's attenuation up to there.  -log(1 - u) is finite
// because u < 1 (rnd has 24 bits).
float next_tentative(bool ratio, float t, float t_end, float m, float c, inout float T, inout Rng rng) {
    float rate = ratio ? m - c : m;
    float t_try = rate > 0.0 ? t - log(1.0 - rnd(rng)) / rate : t_end;
    if (ratio && c > 0.0) T *= exp(-c * (min(t_try, t_end) - t));
    return t_try;
}

// Specialization: paths of more than one scatter event (shaders/path.glsl).
layout(constant_id = 10) const bool USE_BOUNCES = false;
// With USE_BOUNCES, the loop iterations this invocation's tracking loops may still take
// together (llvmpipe's cap is on their sum, and a path runs two of them per scatter
// event): each loop runs at most min(MAX_TRACK_STEPS, path_pool) and takes what it ran.
#define PATH_STEPS 49152u   // picvr.h: PICVR_PATH_STEPS
uint path_pool = PATH_STEPS;

// Tracking through one dense brick at voxel resolution, from t to t_end, with the
// brick's control c (it bounds sigma_t from below in each voxel too), sharing the
// caller's step counter and its bound.  Returns true when the walk ended the whole track:
// a real collision (delta tracking; t holds it) or a zero transmittance (ratio tracking).
bool fine_segment(bool ratio, vec3 ro, vec3 rd, inout float t, float t_end, float c, inout float T,
                  inout Rng rng, inout uint steps, uint limit) {
    Dda f = fine_start(ro, rd, t);
    float m = max(fine_majorant(f), c);
    for (; steps < limit; steps++) {
        float t_seg = min(dda_exit(f), t_end);
        float t_try = next_tentative(ratio, t, t_seg, m, c, T, rng);
        if (t_try < t_seg) {
            t = t_try;
            if (tentative_collision(ratio, ro + rd * t, m, c, T, rng)) return true;
            continue;
        }
        t = t_seg;
        if (t >= t_end || !dda_advance(f)) { t = t_end; return false; }
        m = max(fine_majorant(f), c);
    }
    return false;
}

// Delta (Woodcock) tracking (ratio false) or ratio tracking (ratio true) in [t0, t1]:
// one walk through the majorant grid for both; every caller passes a constant, so each
// compiles to its own loop.  Free flights restart at cell boundaries (the exponential
// distribution is memoryless), so each cell uses its own majorant and, with
// USE_RESIDUAL, its minorant as the control (residual ratio tracking; delta tracking
// saves lookups with it).  One flat loop: every iteration is one tentative collision,
// cell step or empty-space jump (also inside fine_segment), so that SIMD lanes advance
// together, and all count against one bound (MAX_TRACK_STEPS, and the path's pool);
// past it the track is truncated (biased, counted) and treated as passing.  Returns, for
// delta tracking, the distance of a real collision or -1 when the ray passes; for ratio
// tracking, the transmittance estimate (Eq. 2).
float track(bool ratio, vec3 ro, vec3 rd, float t0, float t1, inout Rng rng, inout bool truncated) {
    Dda d = coarse_start(ro, rd, t0);
    float t = t0, T = 1.0;
    float maj = cell_majorant(d);
    float c = cell_control(d, maj);
    uint limit = USE_BOUNCES ? min(MAX_TRACK_STEPS, path_pool) : MAX_TRACK_STEPS;
    uint i = 0u;
    bool ended = false;      // a collision (delta) or a zero transmittance (ratio)
    bool passed = false;     // the ray left [t0, t1]
    for (; i < limit; i++) {
        float t_cell = min(dda_exit(d), t1);
        if (maj > 0.0) {
            if (USE_FINE && (ratio ? maj - c : maj) * (t_cell - t) > FINE_THRESHOLD) {
                if (fine_segment(ratio, ro, rd, t, t_cell, c, T, rng, i, limit)) { ended = true; break; }
                if (i >= limit) break;
            } else {
                float t_try = next_tentative(ratio, t, t_cell, maj, c, T, rng);
                if (t_try < t_cell) {
                    t = t_try;
                    if (tentative_collision(ratio, ro + rd * t, maj, c, T, rng)) { ended = true; break; }
                    continue;
                }
            }
            // a control alone does not end a path: roulette it as a collision would
            if (ratio && T < 0.1 && ratio_collide(T, 0.0, 1.0, rng)) { ended = true; break; }
        } else {
            float jump = empty_skip(d, rd);
            if (jump > 0.0) {
                t += jump;
                if (t >= t1) { passed = true; break; }
                d = coarse_start(ro, rd, t);
                maj = cell_majorant(d);
                c = cell_control(d, maj);
                continue;
            }
        }
        t = t_cell;
        if (t >= t1 || !dda_advance(d)) { passed = true; break; }
        maj = cell_majorant(d);
        c = cell_control(d, maj);
    }
    if (USE_BOUNCES) path_pool -= min(i + 1u, path_pool);
    if (ended) return ratio ? 0.0 : t;
    if (!passed) truncated = true;
    return ratio ? T : -1.0;
}

float delta_track(vec3 ro, vec3 rd, float t0, float t1, inout Rng rng, inout bool truncated) {
    return track(false, ro, rd, t0, t1, rng, truncated);
}

float ratio_track(vec3 ro, vec3 rd, float t0, float t1, inout Rng rng, inout bool truncated) {
    return track(true, ro, rd, t0, t1, rng, truncated);
}

#ifdef TRANSMITTANCE_RAY_MARCHING
// ---- unbiased ray-marching transmittance (entry creation) ----
// Kettunen et al. 2021, "An Unbiased Ray-Marching Transmittance Estimator", simplified.
// Why, in creation only: ratio tracking against tight majorants is nearly a 0/1
// estimate, so Eq. 5 needs thousands of samples wherever the light arrives through the
// medium; most entries then miss it at the sample cap, and their noise darkens the image
// where several entries meet (docs/cache.md, "Entry noise and the dark pot").  This
// estimator is exact in a homogeneous medium and low-variance elsewhere, but costs
// several ratio-tracking samples, so the renderer keeps ratio tracking (one sample per
// pixel and iteration, no Eq. 5).
// A kernel that defines TRANSMITTANCE_RAY_MARCHING defines RM_BUDGET, the most loop
// iterations (DDA steps plus samples, all orders) one estimate may take, and sets the
// pool rm_pool before its first estimate: the iterations all its estimates may still
// take together.  An estimate takes at most min(RM_BUDGET, rm_pool); past that it is
// truncated (biased, flagged like a tracking loop at its bound).  Why a pool:
// llvmpipe's cap bounds the sum over an invocation, not each estimate, and most
// estimates take a few dozen iterations, so a long ray through many bricks may use
// what the short ones left, which a fixed share per estimate would cut (docs/cache.md,
// "Guards on creation's estimates").
#define RM_TAU_STEP 0.5     // majorant optical depth per stratum (at most one per voxel)
#define RM_COMB_SAMPLES 192.0 // long rays: strata at least (t1 - t0) / this apart
#define RM_DARK 6.9         // pivots darker than exp(-6.9) = 1e-3 go to Russian roulette
#define RM_MAX_ORDER 16u
uint rm_pool;               // iterations left to this invocation's estimates (see above)

// X, an unbiased estimate of the optical depth of [t0, t1]: a stratified comb.  Each
// non-empty brick the ray crosses gets n equal strata with one jittered sample each, n
// from the brick's majorant depth over RM_TAU_STEP, at most one per smallest voxel
// spacing or per 1/RM_COMB_SAMPLES of the segment, whichever is longer (so that a comb
// across a large volume stays within RM_BUDGET); empty bricks (majorant 0, so sigma_t =
// 0) are skipped.  E[X] = tau exactly.
float comb_optical_depth(vec3 ro, vec3 rd, float t0, float t1, inout Rng rng, inout uint steps,
                         uint limit, inout bool truncated) {
    Dda d = coarse_start(ro, rd, t0);
    float t = t0, tau = 0.0;
    float h_min = max(scene.min_spacing, (t1 - t0) / RM_COMB_SAMPLES);
    while (true) {
        if (steps >= limit) { truncated = true; break; }
        steps++;
        float maj = cell_majorant(d);
        if (maj <= 0.0) {
            float jump = empty_skip(d, rd);
            if (jump > 0.0) {
                t += jump;
                if (t >= t1) break;
                d = coarse_start(ro, rd, t);
                continue;
            }
        }
        float t_cell = min(dda_exit(d), t1);
        float len = t_cell - t;
        if (maj > 0.0 && len > 0.0) {
            float n_max = max(ceil(len / h_min), 1.0);
            uint n = uint(clamp(ceil(maj * len / RM_TAU_STEP), 1.0, n_max));
            if (steps + n > limit) { truncated = true; n = limit - steps; }
            float h = len / float(max(n, 1u));
            float u = rnd(rng);
            float s = 0.0;
            for (uint i = 0u; i < n; i++) s += sigma_t(ro + rd * (t + (float(i) + u) * h));
            tau += s * h;
            steps += n;
        }
        t = t_cell;
        if (t >= t1 || !dda_advance(d)) break;
    }
    return tau;
}

// exp(-tau) = exp(-c) sum_k (c - tau)^k / k! about a pivot c = X_0 (one comb).  The
// k-th power is estimated by the product of k further independent combs, so each term
// is unbiased given c; the first order is always taken, order k >= 2 with probability
// p_k = min(1, |W_{k-1}|) (Russian roulette on the weighted term W, which carries 1 /
// (p_1 ... p_k)), so the sum is unbiased too (tests/test_beer_lambert.c checks this
// loop, copied, against exp(-tau) on combs that miss thin sheets).  Rules: a pivot
// darker than RM_DARK survives with probability exp(RM_DARK - c) and is then weighted
// by its inverse (unbiased; these paths are dim); past RM_MAX_ORDER orders or RM_BUDGET
// steps the estimate is truncated and flagged.  The estimate may be negative (rarely,
// where a comb misses much of the medium); the caller's mean stays unbiased.  Never a
// shortcut on c = 0: a pivot may miss a thin sheet that the next comb finds.
float ray_marching_transmittance(vec3 ro, vec3 rd, float t0, float t1, inout Rng rng,
                                 inout bool truncated) {
    uint steps = 0u, limit = min(RM_BUDGET, rm_pool);
    float c = comb_optical_depth(ro, rd, t0, t1, rng, steps, limit, truncated);
    float base = exp(-c);
    if (c > RM_DARK) {
        if (rnd(rng) >= exp(RM_DARK - c)) { rm_pool -= steps; return 0.0; }
        base = exp(-RM_DARK);            // exp(-c) / exp(RM_DARK - c), without overflow
    }
    float sum = 1.0, term = 1.0;
    for (uint k = 1u; k <= RM_MAX_ORDER; k++) {
        float p = k == 1u ? 1.0 : min(1.0, abs(term));
        if (p < 1.0 && rnd(rng) >= p) break;
        float X = comb_optical_depth(ro, rd, t0, t1, rng, steps, limit, truncated);
        term *= (c - X) / (float(k) * p);
        sum += term;
        if (k == RM_MAX_ORDER) truncated = true;
    }
    rm_pool -= steps;                    // steps <= limit <= rm_pool
    return base * sum;
}
#endif

// Transmittance from x along unit w over distance dist (only the part inside the box).
float transmittance(vec3 x, vec3 w, float dist, inout Rng rng, inout bool truncated) {
    float t0, t1;
    if (!box_interval(x, w, t0, t1)) return 1.0;
    t1 = min(t1, dist);
    if (t1 <= t0) return 1.0;
#ifdef TRANSMITTANCE_RAY_MARCHING
    return ray_marching_transmittance(x, w, t0, t1, rng, truncated);
#else
    return ratio_track(x, w, t0, t1, rng, truncated);
#endif
}

// ---- the background: constant, or an environment map (picvr.h, picvr_background) ----
// Specialization: the environment map (false: the constant scene.background).
layout(constant_id = 12) const bool USE_ENV_MAP = false;
// Temporal reuse (picvr_scheduler_config.temporal_reuse): the rendering kernels keep
// each pixel's mean scatter depth (render.glsl, accumulate_depth).
layout(constant_id = 13) const bool USE_REUSE = false;
// Built by host/environment.c: per texel (rows top to bottom) 4 floats, its radiance
// (colour * intensity included) and the solid-angle pdf of env_sample in it; then the
// marginal CDF over rows (env_h + 1 values, 0 .. 1), then per row the CDF over its
// columns (env_w + 1 values each).  A 4-float placeholder without USE_ENV_MAP.
layout(set = 0, binding = 19, std430) readonly buffer Environment { float env[]; };

// The texel that holds direction w (the volume's frame): w' = env_basis w (into world
// space, then turned by -rotation about +y), column from atan2(w'.x, -w'.z), row from
// acos(w'.y) (row 0 the zenith).  Edges clamp.
uint env_texel(vec3 w) {
    vec3 e = vec3(dot(scene.env_basis[0].xyz, w), dot(scene.env_basis[1].xyz, w), dot(scene.env_basis[2].xyz, w));
    float u = 0.5 + atan(e.x, -e.z) * (0.5 / PI);
    float v = acos(clamp(e.y, -1.0, 1.0)) * (1.0 / PI);
    uint col = min(uint(max(u, 0.0) * float(scene.env_w)), scene.env_w - 1u);
    uint row = min(uint(max(v, 0.0) * float(scene.env_h)), scene.env_h - 1u);
    return row * scene.env_w + col;
}

// Radiance arriving from direction w (w points away from the scene).
vec3 background_radiance(vec3 w) {
    if (!USE_ENV_MAP) return scene.background;
    uint i = env_texel(w);
    return vec3(env[4u * i], env[4u * i + 1u], env[4u * i + 2u]);
}

// The radiance arriving from w and the solid-angle pdf of background_sample for it, from
// one texel lookup.
vec3 background_radiance_pdf(vec3 w, out float pdf) {
    if (!USE_ENV_MAP) { pdf = INV_4PI; return scene.background; }
    uint i = env_texel(w);
    pdf = env[4u * i + 3u];
    return vec3(env[4u * i], env[4u * i + 1u], env[4u * i + 2u]);
}

// The largest i < n with cdf[base + i] <= u, for cdf[base] = 0 <= u < 1 = cdf[base + n]:
// the interval [cdf[i], cdf[i + 1]) holding u, never one of zero width.  At most
// log2(PICVR_MAX_ENV_SIZE) + 1 iterations.
uint env_search(uint base, uint n, float u) {
    uint lo = 0u, hi = n;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (env[base + mid] <= u) lo = mid; else hi = mid;
    }
    return lo;
}

// u's position in [a, b) rescaled to [0, 1): the second use of one random number.
float env_rescale(float u, float a, float b) { return b > a ? clamp((u - a) / (b - a), 0.0, 0.99999994) : 0.5; }

// A direction drawn from the background in proportion to its luminance times solid
// angle (exact for the constant one: uniform on the sphere), and its solid-angle pdf.
// In a texel: uniform in azimuth and in cos(theta), so uniform in solid angle.
vec3 background_sample(float u1, float u2, out float pdf, out vec3 radiance) {
    if (!USE_ENV_MAP) { pdf = INV_4PI; radiance = scene.background; return uniform_sphere(u1, u2); }
    uint W = scene.env_w, H = scene.env_h;
    uint marginal = 4u * W * H;
    uint row = env_search(marginal, H, u1);
    uint cond = marginal + H + 1u + row * (W + 1u);
    uint col = env_search(cond, W, u2);
    float a = env_rescale(u1, env[marginal + row], env[marginal + row + 1u]);
    float b = env_rescale(u2, env[cond + col], env[cond + col + 1u]);
    float c0 = cos(PI * float(row) / float(H)), c1 = cos(PI * float(row + 1u) / float(H));
    float cos_t = clamp(mix(c0, c1, a), -1.0, 1.0);
    float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    float phi = 2.0 * PI * ((float(col) + b) / float(W) - 0.5);
    vec3 wr = vec3(sin_t * sin(phi), cos_t, -sin_t * cos(phi));        // w'
    // back into the volume's frame: env_basis is orthonormal, its inverse its transpose
    vec3 w = wr.x * scene.env_basis[0].xyz + wr.y * scene.env_basis[1].xyz + wr.z * scene.env_basis[2].xyz;
    uint i = row * W + col;            // the texel's own values, whatever w rounds to
    pdf = env[4u * i + 3u];
    radiance = vec3(env[4u * i], env[4u * i + 1u], env[4u * i + 2u]);
    return w;
}

// ---- lights ----

// Nearest hit of the ray with any sphere or rect light in (0, tmax): the light's
// index or -1; *t_hit is its distance.  Area lights are opaque emitters.
int nearest_area_light(vec3 x, vec3 w, float tmax, out float t_hit) {
    int hit = -1;
    t_hit = tmax;
    for (uint i = 0u; i < scene.light_count; i++) {
        Light l = scene.lights[i];
        int type = l.type;
        if (type == LIGHT_SPHERE) {
            // Numerically stable ray/sphere test (Haines et al., Ray Tracing Gems
            // ch. 7): the discriminant from the closest-approach vector, not b^2 - c,
            // which loses r^2 against |oc|^2 for distant lights in float.
            float r = l.size;
            vec3 oc = x - l.pos;
            float b = dot(oc, w);
            vec3 f = oc - b * w;
            float disc = r * r - dot(f, f);
            if (disc < 0.0) continue;
            float s = sqrt(disc);
            float c = dot(oc, oc) - r * r;
            float q = b < 0.0 ? s - b : -b - s;   // -b - sign(b) s: no cancellation
            float r1 = q, r2 = q != 0.0 ? c / q : 0.0;
            float t = c > 0.0 ? min(r1, r2) : max(r1, r2);   // outside: near hit; inside: exit
            if (t > 0.0 && t < t_hit) { t_hit = t; hit = int(i); }
        } else if (type == LIGHT_RECT) {
            vec3 n = cross(l.edge_u, l.edge_v);
            float denom = dot(n, w);
            if (abs(denom) < 1e-30) continue;
            float t = dot(l.pos - x, n) / denom;
            if (t <= 0.0 || t >= t_hit) continue;
            // Parallelogram coordinates in the dual basis (edges need not be
            // perpendicular): q = su U + sv V with |n|^2 = dot(n, U x V).
            vec3 q = x + w * t - l.pos;
            float nn = dot(n, n);
            float su = dot(q, cross(l.edge_v, n)) / nn;
            float sv = dot(q, cross(n, l.edge_u)) / nn;
            if (abs(su) <= 0.5 && abs(sv) <= 0.5) { t_hit = t; hit = int(i); }
        }
    }
    return hit;
}

// Radiance leaving area light i toward -w at its hit point (rects are one-sided).
vec3 area_light_radiance(uint i, vec3 w) {
    Light l = scene.lights[i];
    if (l.type == LIGHT_RECT && dot(cross(l.edge_u, l.edge_v), w) >= 0.0) return vec3(0.0);
    return l.radiance;
}

// Solid-angle pdf of light i's sampling strategy for direction w from x, with the
// hit distance t (sphere, rect).  Capped at PDF_CAP.
float light_pdf(uint i, vec3 x, vec3 w, float t) {
    Light l = scene.lights[i];
    int type = l.type;
    if (type == LIGHT_SPHERE) {
        vec3 oc = l.pos - x;
        float d2 = dot(oc, oc), r2 = l.size * l.size;
        if (d2 <= r2) return INV_4PI;                 // inside: uniform sphere sampling
        float sin2 = r2 / d2;
        float omc = sin2 / (1.0 + sqrt(max(0.0, 1.0 - sin2)));  // 1 - cos, no cancellation
        return min(1.0 / (2.0 * PI * max(omc, 1e-30)), PDF_CAP);
    }
    if (type == LIGHT_RECT) {
        vec3 n = normalize(cross(l.edge_u, l.edge_v));
        float cos_l = abs(dot(n, w));
        return min(t * t / max(l.area * cos_l, 1e-30), PDF_CAP);
    }
    if (type == LIGHT_DIRECTIONAL) return min(1.0 / (2.0 * PI * max(l.size, 1e-30)), PDF_CAP);
    return 0.0;
}

// Power-heuristic MIS weight of a strategy with pdf a against one with pdf b, written
// as a / (a^2 + b^2) * a so that neither huge nor tiny pdfs overflow.
float power_weight(float a, float b) {
    if (a <= 0.0) return 0.0;
    float r = b / a;
    return 1.0 / (1.0 + r * r);
}

// Picks one light (or the background, index MAX_LIGHTS) by the precomputed
// power-proportional probabilities.
uint select_light(float u) {
    for (uint i = 0u; i < scene.light_count; i++)
        if (u < scene.lights[i].cdf) return i;
    return uint(MAX_LIGHTS);
}

// ---- camera: the pinhole model documented in picvr.h ----
vec3 camera_ray(uvec2 px, inout Rng rng) {
    float jx = USE_QMC ? qmc(rng, 0u) : rnd(rng);
    float jy = USE_QMC ? qmc(rng, 1u) : rnd(rng);
    float h = scene.tan_half_fov, aspect = scene.aspect;
    float sx = (2.0 * (float(px.x) + jx) / float(scene.image.x) - 1.0) * h * aspect;
    float sy = (1.0 - 2.0 * (float(px.y) + jy) / float(scene.image.y)) * h;
    return normalize(scene.cam_fwd + sx * scene.cam_right.xyz + sy * scene.cam_up.xyz);
}

// ---- direct lighting at a point (Eq. 4 integrand) ----
// Light-sampling strategy: one light (or the background) chosen by power.
// Returns f * L * T * w / pdf with f the phase function ph (1/(4 pi) when isotropic).
vec3 sample_one_light(vec3 x, Phase ph, inout Rng rng, inout bool truncated) {
    uint li = select_light(rnd(rng));
    float u1 = rnd(rng), u2 = rnd(rng);
    vec3 w;
    vec3 L;
    float dist = 1e30;
    float a;            // pmf * solid-angle pdf; 0 marks a delta light
    float pmf;
    if (li == uint(MAX_LIGHTS)) {
        pmf = scene.background_pmf;
        if (pmf <= 0.0) return vec3(0.0);
        float pdf;
        w = background_sample(u1, u2, pdf, L);
        // Rule: a direction of pdf 0 (a black texel, never drawn) adds nothing.
        if (pdf <= 0.0) return vec3(0.0);
        a = pmf * pdf;
    } else {
        Light l = scene.lights[li];
        int type = l.type;
        pmf = l.pmf;
        L = l.radiance;
        if (type == LIGHT_SPHERE) {
            vec3 to = l.pos - x;
            float d2 = dot(to, to), r2 = l.size * l.size;
            if (d2 <= r2) {
                w = uniform_sphere(u1, u2);
            } else {
                float sin2 = r2 / d2;
                float omc = sin2 / (1.0 + sqrt(max(0.0, 1.0 - sin2)));
                w = sample_cone(to * inversesqrt(d2), omc, u1, u2);
            }
            int h = nearest_area_light(x, w, 1e30, dist);
            if (h != int(li)) return vec3(0.0);      // occluded by another light (or grazing miss)
            a = pmf * light_pdf(li, x, w, dist);
        } else if (type == LIGHT_RECT) {
            vec3 q = l.pos + (u1 - 0.5) * l.edge_u + (u2 - 0.5) * l.edge_v;
            vec3 to = q - x;
            float d = length(to);
            if (d <= 0.0) return vec3(0.0);
            w = to / d;
            L = area_light_radiance(li, w);
            // Rule: grazing samples (cos < 1e-7) carry vanishing solid angle; drop them
            // rather than divide by ~0.
            vec3 n = normalize(cross(l.edge_u, l.edge_v));
            if (abs(dot(n, w)) < 1e-7 || all(equal(L, vec3(0.0)))) return vec3(0.0);
            float th;
            if (nearest_area_light(x, w, d * (1.0 - 1e-4), th) >= 0) return vec3(0.0);
            dist = d;
            a = pmf * light_pdf(li, x, w, d);
        } else if (type == LIGHT_DIRECTIONAL) {
            float omc = l.size;
            w = omc > 0.0 ? sample_cone(l.pos, omc, u1, u2) : l.pos;
            a = omc > 0.0 ? pmf * light_pdf(li, x, w, 0.0) : 0.0;
            float th;
            if (nearest_area_light(x, w, 1e30, th) >= 0) return vec3(0.0);
        } else {   // point light: intensity / d^2
            vec3 to = l.pos - x;
            // Rule: the distance is clamped to 1e-3 of the smallest voxel spacing so a
            // light on a scatter point gives a large but finite value.
            float min_d = 1e-3 * scene.min_spacing;
            float d2 = max(dot(to, to), min_d * min_d);
            float d = sqrt(d2);
            w = to / d;
            float th;
            if (nearest_area_light(x, w, d, th) >= 0) return vec3(0.0);
            dist = d;
            L = l.radiance / d2;
            a = 0.0;
        }
    }
    if (all(equal(L, vec3(0.0)))) return vec3(0.0);
    float f = phase_eval(ph, w);
    // Rule: a direction the phase function does not scatter into needs no shadow ray.
    if (f <= 0.0) return vec3(0.0);
    float T = transmittance(x, w, dist, rng, truncated);
    if (a <= 0.0) return f * L * T / pmf;                             // delta light
    float mis = USE_PHASE_MIS ? power_weight(a, f) : 1.0;
    return f * L * T * (mis / a);
}

// The emission a phase-sampled direction w from x sees (hit: the area light it hits
// first, at t_hit, or -1), weighted by the power heuristic against light sampling; f is
// the phase pdf of w.  An escaping direction sees the background and every sun cone
// that contains it.
vec3 phase_emission(vec3 x, vec3 w, int hit, float t_hit, float f) {
    if (hit >= 0) {
        uint i = uint(hit);
        return area_light_radiance(i, w) * power_weight(f, scene.lights[i].pmf * light_pdf(i, x, w, t_hit));
    }
    vec3 Le = vec3(0.0);
    if (scene.background_pmf > 0.0) {
        float pdf;
        vec3 L = background_radiance_pdf(w, pdf);
        Le = L * power_weight(f, scene.background_pmf * pdf);
    }
    for (uint i = 0u; i < scene.light_count; i++) {
        Light l = scene.lights[i];
        if (l.type != LIGHT_DIRECTIONAL || l.size <= 0.0) continue;
        if (1.0 - dot(w, l.pos) <= l.size)
            Le += l.radiance * power_weight(f, l.pmf * light_pdf(i, x, w, 0.0));
    }
    return Le;
}

// Phase-sampling strategy: f / pdf = 1 (phase_sample is exact), so the estimate is
// Le * T * w, the transmittance by ratio tracking.
vec3 sample_phase(vec3 x, Phase ph, inout Rng rng, inout bool truncated) {
    float u1 = rnd(rng), u2 = rnd(rng);
    vec3 w = phase_sample(ph, u1, u2);
    float t_hit;
    int hit = nearest_area_light(x, w, 1e30, t_hit);
    vec3 Le = phase_emission(x, w, hit, t_hit, phase_eval(ph, w));
    if (all(equal(Le, vec3(0.0)))) return vec3(0.0);
    return Le * transmittance(x, w, t_hit, rng, truncated);
}

// Irradiance (Eq. 4) at x from all lights: one light sample and one phase sample,
// combined by MIS, with the isotropic phase function (the cache's quantity: creation
// runs only where the phase function is isotropic); both estimators include f = 1/(4 pi),
// so E = 4 pi * (sum).  Separate streams for the two samples, so that a caller can replay
// the same light and phase choices at several points (common random numbers,
// cache_create.comp).
vec3 irradiance_sample(vec3 x, Rng light_rng, Rng phase_rng, inout bool truncated) {
    Phase iso = Phase(vec3(0.0, 0.0, 1.0), 0.0);
    vec3 s = sample_one_light(x, iso, light_rng, truncated);
    if (USE_PHASE_MIS) s += sample_phase(x, iso, phase_rng, truncated);
    return 4.0 * PI * s;
}
