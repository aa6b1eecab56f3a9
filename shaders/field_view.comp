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
// a light's transmittance falls exponentially; rule: a cell that no light reaches takes
// FIELD_LN_FLOOR (e^-100 is 0 in float), so that every logarithm is finite.  Cells with
// no medium near them (never read) are skipped.
layout(local_size_x = 256) in;
#include "field.glsl"
#include "phase.glsl"

// The logarithm of a sum from the logarithms of its terms, without overflow: a term at
// the floor adds nothing.
float field_log_add(float a, float b) {
    float hi = max(a, b), lo = min(a, b);
    return hi + log(1.0 + exp(lo - hi));
}

void main() {
    uint c = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256u + gl_LocalInvocationID.x;
    if (c >= fp.n.w || cells[2u * c + 1u].w == 0.0) return;
    vec3 x = field_centre(field_cell_of(c));
    vec3 v = scene.cam_pos - x;
    float dv = length(v);
    vec3 o = dv > 0.0 ? v / dv : -scene.cam_fwd;   // rule: a camera at the centre looks along cam_fwd
    vec4 ph = cells[2u * c + 1u];                   // g, g1
    bool scaled = (fp.flags & (FIELD_DELTA_M | FIELD_MULTIPLE)) == (FIELD_DELTA_M | FIELD_MULTIPLE);
    // The logarithm per channel, summed in log space (log-sum-exp) so that a light far
    // behind medium keeps its exact ln E p - tau instead of underflowing; and the light
    // the cell would scatter with no shadow at all, the bound the image's extension to
    // the grid's faces is held under.
    vec3 ln_ls = vec3(-1e30);   // the logarithm of nothing yet
    float unshadowed = 0.0;
    for (uint i = 0u; i < scene.light_count; i++) {
        vec3 toward;
        float dist;
        vec3 e = field_light_irradiance(i, x, toward, dist);
        vec4 tau = light_t[i * fp.n.w + c];
        float cosine = dot(-toward, o);   // the light travels along -toward, then along o
        float p = USE_HG ? cm_phase_eval(ph.x, scene.back_g, scene.back_weight, cosine) : INV_4PI;
        vec3 a = e * p, t = scaled ? tau.yzw : vec3(tau.x);
        for (int k = 0; k < 3; k++)
            if (a[k] > 0.0) ln_ls[k] = field_log_add(ln_ls[k], log(a[k]) - t[k]);
        unshadowed += max(a.x, max(a.y, a.z));
    }
    vec3 band = vec3(0.0);
    if ((fp.flags & FIELD_SOURCE) != 0u) {   // the field holds scattered light (else: a placeholder)
        vec4 r = field_in[3u * c], gr = field_in[3u * c + 1u], b = field_in[3u * c + 2u];
        float g1 = USE_HG ? ph.y : 0.0;
        band = vec3(r.x, gr.x, b.x) + 3.0 * g1 * vec3(dot(r.yzw, o), dot(gr.yzw, o), dot(b.yzw, o));
        band = max(band, vec3(0.0)) * INV_4PI;   // rule: two bands clamped at 0
    }
    for (int k = 0; k < 3; k++)
        if (band[k] > 0.0) ln_ls[k] = field_log_add(ln_ls[k], log(band[k]));
    unshadowed += max(band.x, max(band.y, band.z));
    // Rules: no light at all, or a non-finite logarithm (input overflowing float), is the
    // floor; a non-finite bound the largest float's logarithm.  A logarithm below the
    // floor is kept as it is: its slope is what extends a dense cell's light to the
    // grid's face.
    for (int k = 0; k < 3; k++)
        if (isnan(ln_ls[k]) || isinf(ln_ls[k]) || ln_ls[k] <= -1e29) ln_ls[k] = FIELD_LN_FLOOR;
    float ln_bound = unshadowed > 0.0 ? log(unshadowed) : FIELD_LN_FLOOR;
    if (isnan(ln_bound) || isinf(ln_bound)) ln_bound = 88.7;
    field_view[c] = vec4(ln_ls, max(ln_bound, FIELD_LN_FLOOR));
}
