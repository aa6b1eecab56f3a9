// phase.glsl - the phase function at a scatter point: isotropic (the paper's), or
// Henyey-Greenstein lobes with g per transfer-function entry (picvr_tf_point.g) and
// picvr_scattering's second lobe; its value and exact sampling.  The formulas are in
// sampling_math.glsl (tests/test_phase.c).
#ifndef PHASE_GLSL_ONCE
#define PHASE_GLSL_ONCE 1
#include "specialization.glsl"
#include "scene.glsl"
#include "sampling_math.glsl"
#include "geometry.glsl"
#include "medium.glsl"

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

#endif
