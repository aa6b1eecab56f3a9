// background.glsl - the background (picvr_background, picvr.h): a constant radiance or
// an environment map, its lookup by direction and its sampling in proportion to
// luminance times solid angle (the map's CDFs from host/environment.c).
#ifndef BACKGROUND_GLSL_ONCE
#define BACKGROUND_GLSL_ONCE 1
#include "specialization.glsl"
#include "scene.glsl"
#include "geometry.glsl"

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

#endif
