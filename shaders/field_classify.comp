#version 450
#extension GL_GOOGLE_include_directive : require
// field_classify.comp - the field's medium (field.glsl): one thread per cell, the mean of
// samples^3 points spread evenly over the cell, each classified first (the transfer
// function applied to the trilinear data value), so that a cell's extinction is the
// mean of its classified extinction and its albedo the ratio of the means of sigma_s and
// sigma_t.  Clipped points hold nothing.  Rules: a cell with no extinction takes albedo 0
// and g 0 (nothing scatters there); a cell whose scattering is 0 takes g 0.
layout(local_size_x = 256) in;
#include "field.glsl"
#include "clip.glsl"
#include "medium.glsl"
#include "phase.glsl"

void main() {
    uint c = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256u + gl_LocalInvocationID.x;
    if (c >= fp.n.w) return;
    ivec3 q = field_cell_of(c);
    uint s = max(fp.samples, 1u);
    float sum_t = 0.0, sum_g = 0.0, sum_s = 0.0;
    vec3 sum_rgb = vec3(0.0);
    for (uint k = 0u; k < s * s * s; k++) {
        vec3 j = vec3(float(k % s), float((k / s) % s), float(k / (s * s)));
        vec3 x = scene.box_min + (vec3(q) + (j + 0.5) / float(s)) * fp.cell.xyz;
        if (!inside_clip(x)) continue;
        vec4 tf = transfer(data_value(x));
        float st = scene.density * tf.a;
        vec3 ss = st * tf.rgb;
        float lum = dot(ss, vec3(0.2126, 0.7152, 0.0722));
        sum_t += st;
        sum_rgb += ss;
        sum_s += lum;
        sum_g += lum * phase_at(x, vec3(0.0)).g;
    }
    float inv = 1.0 / float(s * s * s);
    vec3 albedo = sum_t > 0.0 ? clamp(sum_rgb / sum_t, 0.0, 1.0) : vec3(0.0);
    float g = sum_s > 0.0 ? cm_hg_g(sum_g / sum_s) : 0.0;
    float w = USE_HG ? clamp(scene.back_weight, 0.0, 1.0) : 0.0;
    float gb = USE_HG ? cm_hg_g(scene.back_g) : 0.0;
    float g1 = (1.0 - w) * g + w * gb;
    float f = (1.0 - w) * g * g + w * gb * gb;
    cells[2u * c] = vec4(sum_t * inv, albedo);
    cells[2u * c + 1u] = vec4(g, g1, f, 0.0);
}
