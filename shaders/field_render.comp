#version 450
#extension GL_GOOGLE_include_directive : require
// field_render.comp - the field's image (field.glsl): one thread per pixel, a
// deterministic ray through the pixel's centre marched front to back through the full-
// resolution volume, with the majorant grid's empty bricks skipped and the march ended
// where the transmittance falls below FIELD_T_MIN.  Each step of length ds at its middle
// x (sigma_t, albedo and g of the classified volume there) adds T (1 - e^-tau) a L_s and
// multiplies T by e^-tau, tau = sigma_t ds; L_s is the radiance scattered toward the
// camera: each light's irradiance at x (as a point or a delta sun, field.glsl) times its
// transmittance interpolated from the cells' centres (trilinear) times the phase
// function, plus the scattered field's two bands (phi + 3 g1 F . o) / 4 pi, interpolated
// the same way.  The background (or an area light the ray meets) is added times the
// final T.  The pixel's accumulation holds the result as its one sample.
layout(local_size_x = 256) in;
#include "field.glsl"
#include "clip.glsl"
#include "medium.glsl"
#include "majorant.glsl"
#include "background.glsl"
#include "lights.glsl"
#include "phase.glsl"

layout(set = 0, binding = 4, std430) buffer AccumMean { vec4 accum_mean[]; };  // rgb, coverage
layout(set = 0, binding = 5, std430) buffer AccumComp { vec4 accum_comp[]; };  // Kahan terms
layout(set = 0, binding = 6, std430) buffer AccumStat { vec4 accum_stat[]; };  // lum mean, M2, n, bad

// Trilinear weights over the cells' centres around x.  Within half a cell of the grid's
// faces, beyond the outer centres: the outer values held (clamped), or with `extend`
// the line through the last two centres continued (an axis of one cell holds its value).
struct FieldLerp { uint c[8]; float w[8]; };

FieldLerp field_lerp(vec3 x, bool extend) {
    FieldLerp r;
    vec3 p = (x - scene.box_min) / fp.cell.xyz - 0.5;
    ivec3 hi = ivec3(fp.n.xyz) - 1;
    ivec3 i0 = clamp(ivec3(floor(p)), ivec3(0), max(hi - 1, ivec3(0)));
    ivec3 i1 = min(i0 + 1, hi);
    vec3 f = extend ? clamp(p - vec3(i0), -0.5, 1.5) : clamp(p - vec3(i0), 0.0, 1.0);
    for (uint k = 0u; k < 8u; k++) {
        bvec3 up = bvec3((k & 1u) != 0u, (k & 2u) != 0u, (k & 4u) != 0u);
        ivec3 q = ivec3(up.x ? i1.x : i0.x, up.y ? i1.y : i0.y, up.z ? i1.z : i0.z);
        vec3 wt = mix(1.0 - f, f, vec3(up));
        r.c[k] = field_index(q);
        r.w[k] = wt.x * wt.y * wt.z;
    }
    return r;
}

// The first lobe's g for data value v (the table interpolated as phase.glsl does).
float field_g_at(float v) {
    if (!USE_HG) return 0.0;
    float f = v * (TF_SIZE - 1.0);
    uint i = min(uint(f), uint(TF_SIZE) - 2u);
    return mix(tf_g[i], tf_g[i + 1u], clamp(f - float(i), 0.0, 1.0));
}

// The radiance scattered at x toward the camera (o = -rd) per unit of scattering.
vec3 field_view(vec3 x, vec3 rd, float g) {
    FieldLerp lp = field_lerp(x, false), le = field_lerp(x, true);
    bool scaled = (fp.flags & (FIELD_DELTA_M | FIELD_MULTIPLE)) == (FIELD_DELTA_M | FIELD_MULTIPLE);
    vec3 s = vec3(0.0);
    for (uint i = 0u; i < scene.light_count; i++) {
        vec3 toward;
        float dist;
        vec3 e = field_light_irradiance(i, x, toward, dist);
        vec4 tau = vec4(0.0);
        for (uint k = 0u; k < 8u; k++) tau += le.w[k] * light_t[i * fp.n.w + le.c[k]];
        tau = max(tau, vec4(0.0));   // rule: an extrapolated optical depth is at least 0
        float c = dot(toward, rd);   // the light travels along -toward, then along -rd
        float p = USE_HG ? cm_phase_eval(g, scene.back_g, scene.back_weight, c) : INV_4PI;
        s += e * exp(-(scaled ? tau.yzw : vec3(tau.x))) * p;
    }
    vec4 r = vec4(0.0), gr = vec4(0.0), b = vec4(0.0);
    for (uint k = 0u; k < 8u; k++) {
        r += lp.w[k] * field_in[3u * lp.c[k]];
        gr += lp.w[k] * field_in[3u * lp.c[k] + 1u];
        b += lp.w[k] * field_in[3u * lp.c[k] + 2u];
    }
    float wb = USE_HG ? clamp(scene.back_weight, 0.0, 1.0) : 0.0;
    float g1 = USE_HG ? (1.0 - wb) * cm_hg_g(g) + wb * cm_hg_g(scene.back_g) : 0.0;
    vec3 o = -rd;
    vec3 band = vec3(r.x, gr.x, b.x) + 3.0 * g1 * vec3(dot(r.yzw, o), dot(gr.yzw, o), dot(b.yzw, o));
    return s + max(band, vec3(0.0)) * INV_4PI;   // rule: two bands clamped at 0
}

void main() {
    uint idx = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256u + gl_LocalInvocationID.x;
    uint width = scene.image.x;
    if (idx >= width * scene.image.y) return;
    uvec2 px = uvec2(idx % width, idx / width);
    float h = scene.tan_half_fov;
    float sx = (2.0 * (float(px.x) + 0.5) / float(width) - 1.0) * h * scene.aspect;
    float sy = (1.0 - 2.0 * (float(px.y) + 0.5) / float(scene.image.y)) * h;
    vec3 ro = scene.cam_pos, rd = normalize(scene.cam_fwd + sx * scene.cam_right.xyz + sy * scene.cam_up.xyz);
    float t_hit;
    int hit = nearest_area_light(ro, rd, 1e30, t_hit);
    vec3 L = vec3(0.0);
    float T = 1.0, t0, t1;
    if (box_interval(ro, rd, t0, t1)) {
        if (hit >= 0) t1 = min(t1, t_hit);
        Dda d = coarse_start(ro, rd, t0);
        float t = t0;
        uint steps = 0u;
        // Rule: at most 60000 steps per ray (llvmpipe's bound on an invocation's loop
        // iterations); the host sizes the step so that a ray across the box needs fewer.
        while (t < t1 && T > FIELD_T_MIN && steps < 60000u) {
            float te = min(dda_exit(d), t1);
            if (cell_majorant(d) > 0.0 && te > t) {
                uint n = uint(ceil((te - t) / fp.step));
                float ds = (te - t) / float(max(n, 1u));
                for (uint k = 0u; k < n && T > FIELD_T_MIN && steps < 60000u; k++, steps++) {
                    vec3 x = ro + rd * (t + (float(k) + 0.5) * ds);
                    float v = data_value(x);
                    vec4 tf = transfer(v);
                    float tau = scene.density * tf.a * ds;
                    if (!(tau > 0.0)) continue;
                    float e = exp(-tau);
                    L += T * (1.0 - e) * tf.rgb * field_view(x, rd, field_g_at(v));
                    T *= e;
                }
            }
            t = te;
            steps++;
            if (!dda_advance(d)) break;
        }
    }
    L += T * (hit >= 0 ? area_light_radiance(uint(hit), rd) : background_radiance(rd));
    // Rule: a non-finite pixel (only from input overflowing float) is 0 and counted bad.
    bool bad = any(isnan(L)) || any(isinf(L));
    if (bad) L = vec3(0.0);
    accum_mean[idx] = vec4(L, clamp(1.0 - T, 0.0, 1.0));
    accum_comp[idx] = vec4(0.0);
    accum_stat[idx] = vec4(dot(L, vec3(0.2126, 0.7152, 0.0722)), 0.0, uintBitsToFloat(1u), uintBitsToFloat(bad ? 1u : 0u));
}
