// camera.glsl - the camera ray of a pixel: the pinhole model documented in picvr.h,
// jittered within the pixel by the pixel's low-discrepancy sequence (USE_QMC) or by
// independent random numbers.
#ifndef CAMERA_GLSL_ONCE
#define CAMERA_GLSL_ONCE 1
#include "specialization.glsl"
#include "scene.glsl"
#include "random.glsl"

vec3 camera_ray(uvec2 px, inout Rng rng) {
    float jx = USE_QMC ? qmc(rng, 0u) : rnd(rng);
    float jy = USE_QMC ? qmc(rng, 1u) : rnd(rng);
    float h = scene.tan_half_fov, aspect = scene.aspect;
    float sx = (2.0 * (float(px.x) + jx) / float(scene.image.x) - 1.0) * h * aspect;
    float sy = (1.0 - 2.0 * (float(px.y) + jy) / float(scene.image.y)) * h;
    return normalize(scene.cam_fwd + sx * scene.cam_right.xyz + sy * scene.cam_up.xyz);
}

#endif
