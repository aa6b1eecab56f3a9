#version 450
#extension GL_GOOGLE_include_directive : require
// field_scatter.comp - one pass of the field (field.glsl): one thread per cell, which
// gathers, for each direction w of this dispatch (each of the D / 2 used both ways), the
// radiance that arrives at the cell's centre travelling along w, and adds it to the
// cell's fluence phi and first moment F with the weight 4 pi / D.  The radiance is exact
// along the line through the constant cells: walking upstream (along -w) from the centre,
// a cell of optical depth tau adds T (1 - e^-tau) J and multiplies T by e^-tau, and the
// background seen along -w is added times the final T.  J is the cell's source: none in
// the first pass (the background's light alone), then its albedo times the radiance
// scattered into w from the lights (their transmittance per cell, as points) and from the
// previous pass's field, all in the delta-M scaled medium when FIELD_DELTA_M.
// Gathered per cell, the pass needs no atomics, so its result does not depend on the
// order threads run in, and every cell has one ray of every direction.  A dispatch takes
// a range of directions (the host keeps each invocation's loop within llvmpipe's
// iteration bound); FIELD_ADD adds to what the earlier ranges of the pass wrote.
layout(local_size_x = 256) in;
#include "field.glsl"
#define FIELD_T_CUT 1e-4
#include "background.glsl"

// The radiance scattered at cell j (centre x) into direction w per unit of scattering,
// from the lights and the previous pass, with the cell's phase function (scaled when
// delta-M: HG of g'; else both lobes).
vec3 field_source(uint j, vec3 x, vec3 w, bool dm) {
    vec4 ph = cells[2u * j + 1u];   // g, g1, f
    float g_band = ph.y;
    float g_scaled = dm ? (ph.y - ph.z) / (1.0 - ph.z) : 0.0;
    if (dm) g_band = g_scaled;
    vec3 s = vec3(0.0);
    for (uint i = 0u; i < scene.light_count; i++) {
        vec3 toward;
        float dist;
        vec3 e = field_light_irradiance(i, x, toward, dist);
        vec4 t = light_t[i * fp.n.w + j];
        float c = dot(-toward, w);   // the light travels along -toward, then along w
        float p = dm ? cm_hg_eval(g_scaled, c)
                     : (USE_HG ? cm_phase_eval(ph.x, scene.back_g, scene.back_weight, c) : INV_4PI);
        s += e * exp(-(dm ? t.yzw : vec3(t.x))) * p;
    }
    vec4 r = field_in[3u * j], gr = field_in[3u * j + 1u], b = field_in[3u * j + 2u];
    vec3 phi = vec3(r.x, gr.x, b.x);
    vec3 Fw = vec3(dot(r.yzw, w), dot(gr.yzw, w), dot(b.yzw, w));
    // rule: two bands clamped at 0
    return s + max(phi + 3.0 * g_band * Fw, vec3(0.0)) * INV_4PI;
}

// The radiance arriving at x travelling along w.
vec3 field_gather(vec3 x, vec3 w, bool source, bool dm) {
    vec3 u = -w, L = vec3(0.0), T = vec3(1.0);
    FieldWalk walk = field_walk_start(x, u);
    uint j;
    float len;
    while (field_walk_next(walk, 1e30, j, len)) {
        vec4 m = cells[2u * j];
        vec3 sigma = vec3(m.x), albedo = m.yzw;
        if (dm) field_scaled(m, cells[2u * j + 1u].z, sigma, albedo);
        vec3 e = exp(-sigma * len);
        vec3 J = vec3(0.0);
        if (source && m.x > 0.0) J = albedo * field_source(j, field_centre(field_cell_of(j)), w, dm);
        // 1 - e^-tau without cancellation (sampling_math.glsl)
        vec3 absorbed = vec3(cm_forced_norm(sigma.x * len), cm_forced_norm(sigma.y * len), cm_forced_norm(sigma.z * len));
        L += T * absorbed * J;
        T *= e;
        // Rule: below FIELD_T_CUT of transmittance the rest of the line is taken as
        // radiating the last cell's source J (what an optically thick remainder tends
        // to; exact in the white furnace), so the walk ends early in dense media.
        if (max(T.x, max(T.y, T.z)) < FIELD_T_CUT) return L + T * J;
    }
    return L + T * background_radiance(u);
}

void main() {
    uint c = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256u + gl_LocalInvocationID.x;
    if (c >= fp.n.w) return;
    // Rule: a cell with no medium around it is never read; it holds 0 and no change.
    if (cells[2u * c + 1u].w == 0.0) {
        for (uint k = 0u; k < 3u; k++) field_out[3u * c + k] = vec4(0.0);
        return;
    }
    bool source = (fp.flags & FIELD_SOURCE) != 0u, dm = (fp.flags & FIELD_DELTA_M) != 0u;
    vec3 x = field_centre(field_cell_of(c));
    vec4 acc[3];
    for (uint k = 0u; k < 3u; k++) acc[k] = (fp.flags & FIELD_ADD) != 0u ? field_out[3u * c + k] : vec4(0.0);
    float weight = 4.0 * PI / float(2u * fp.half_dirs);
    for (uint k = fp.dir_begin; k < fp.dir_end; k++) {
        vec3 w = field_direction(k >> 1u);
        if ((k & 1u) != 0u) w = -w;
        vec3 L = weight * field_gather(x, w, source, dm);
        for (uint ch = 0u; ch < 3u; ch++) acc[ch] += vec4(L[ch], L[ch] * w);
    }
    for (uint k = 0u; k < 3u; k++) field_out[3u * c + k] = acc[k];
    if ((fp.flags & FIELD_LAST) != 0u) {
        vec3 phi = vec3(acc[0].x, acc[1].x, acc[2].x);
        vec3 old = vec3(field_in[3u * c].x, field_in[3u * c + 1u].x, field_in[3u * c + 2u].x);
        vec3 d = abs(phi - old);
        float change = max(d.x, max(d.y, d.z)), top = max(phi.x, max(phi.y, phi.z));
        // rule: a non-finite value is recorded as the largest float (never converged)
        if (!(change <= 3.4e38)) change = 3.4e38;
        if (!(top <= 3.4e38)) top = 3.4e38;
        atomicMax(field_change[2u * fp.pass_index], floatBitsToUint(change));
        atomicMax(field_change[2u * fp.pass_index + 1u], floatBitsToUint(top));
    }
}
