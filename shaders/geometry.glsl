// geometry.glsl - directions and bases: uniform sphere and cone sampling, an
// orthonormal basis around a direction, and the safe reciprocal the slab tests of the
// box, the clip planes and the grid walks divide by.
#ifndef GEOMETRY_GLSL_ONCE
#define GEOMETRY_GLSL_ONCE 1
#include "scene.glsl"

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

#endif
