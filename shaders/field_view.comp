#version 450
#extension GL_GOOGLE_include_directive : require
// field_view.comp - the light each cell scatters toward the camera (field.glsl,
// field_view), made before each image: one thread per cell, at its centre, the
// direction o toward the camera from there.  Per unit of scattering: each light's
// irradiance (as a point or a delta sun) times its transmittance exp(-tau) times the
// phase function, plus the scattered field's two bands (phi + 3 g1 F . o) / 4 pi.  With
// delta-M and more than one event the lights' transmittance is the scaled medium's (the
// reference's rule: T' - T is light the peak scattered forward, which the camera's
// event scatters again).  The image interpolates the logarithm, which is linear where
// a light's transmittance falls exponentially; rule: the radiance is floored at 1e-30
// (ln = -69) so that a dark cell has a finite logarithm.  Cells with no medium near
// them (never read) are skipped.
layout(local_size_x = 256) in;
#include "field.glsl"
#include "phase.glsl"

void main() {
    uint c = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256u + gl_LocalInvocationID.x;
    if (c >= fp.n.w || cells[2u * c + 1u].w == 0.0) return;
    vec3 x = field_centre(field_cell_of(c));
    vec3 v = scene.cam_pos - x;
    float dv = length(v);
    vec3 o = dv > 0.0 ? v / dv : -scene.cam_fwd;   // rule: a camera at the centre looks along cam_fwd
    vec4 ph = cells[2u * c + 1u];                   // g, g1
    bool scaled = (fp.flags & (FIELD_DELTA_M | FIELD_MULTIPLE)) == (FIELD_DELTA_M | FIELD_MULTIPLE);
    vec3 s = vec3(0.0);
    for (uint i = 0u; i < scene.light_count; i++) {
        vec3 toward;
        float dist;
        vec3 e = field_light_irradiance(i, x, toward, dist);
        vec4 tau = light_t[i * fp.n.w + c];
        float cosine = dot(-toward, o);   // the light travels along -toward, then along o
        float p = USE_HG ? cm_phase_eval(ph.x, scene.back_g, scene.back_weight, cosine) : INV_4PI;
        s += e * exp(-(scaled ? tau.yzw : vec3(tau.x))) * p;
    }
    vec4 r = field_in[3u * c], gr = field_in[3u * c + 1u], b = field_in[3u * c + 2u];
    float g1 = USE_HG ? ph.y : 0.0;
    vec3 band = vec3(r.x, gr.x, b.x) + 3.0 * g1 * vec3(dot(r.yzw, o), dot(gr.yzw, o), dot(b.yzw, o));
    vec3 ls = s + max(band, vec3(0.0)) * INV_4PI;   // rule: two bands clamped at 0
    // rule: non-finite (input overflowing float) counts as the floor
    ls = mix(ls, vec3(0.0), bvec3(isnan(ls.x) || isinf(ls.x), isnan(ls.y) || isinf(ls.y), isnan(ls.z) || isinf(ls.z)));
    field_view[c] = vec4(log(max(ls, vec3(1e-30))), 0.0);
}
