#version 450
#extension GL_GOOGLE_include_directive : require
// field_render.comp - the field's image (field.glsl): one thread per pixel, a
// deterministic ray through the pixel's centre marched front to back through the full-
// resolution volume, with the majorant grid's empty bricks jumped and the march ended
// where the transmittance falls below FIELD_T_MIN (the rest taken as radiating the last
// step's light).  A step of optical depth tau (sigma_t and albedo of the classified
// volume at its middle) adds T a times the light it sends toward the camera, the light
// L_s toward the camera taken at both ends of the step and integrated as exponential
// between them (field_step_light), and multiplies T by e^-tau.  L_s is made per cell by
// field_view.comp and interpolated trilinearly in its logarithm.  The background (or an
// area light the ray meets) is added times the final T.  The pixel's accumulation holds
// the result as fp.prior samples of it.
layout(local_size_x = 256) in;
#include "field.glsl"
#include "clip.glsl"
#include "medium.glsl"
#include "majorant.glsl"
#include "background.glsl"
#include "lights.glsl"

// A step's optical depth against its brick's majorant at most this (the step then lies
// between the configured one and four times it).  Every step takes L_s, not points
// further apart, so that neighbouring rays (one SIMD group on a CPU device, one warp on
// a GPU) run the same code at the same time.
#define FIELD_TAU_STEP 0.5

layout(set = 0, binding = 4, std430) buffer AccumMean { vec4 accum_mean[]; };  // rgb, coverage
layout(set = 0, binding = 5, std430) buffer AccumComp { vec4 accum_comp[]; };  // Kahan terms
layout(set = 0, binding = 6, std430) buffer AccumStat { vec4 accum_stat[]; };  // lum mean, M2, n, bad

// What a step of optical depth tau sends toward the camera per unit of its albedo and of
// the transmittance before it, the light toward the camera being L_a = e^ln_a at its
// near end and L_b = e^ln_b at its far end, taken as exponential between them (exact
// where its logarithm is linear: a homogeneous region under a light, however dense):
//   int_0^1 tau e^(-tau u) L_a (L_b / L_a)^u du = tau (L_a - L_b e^-tau) / (tau + ln_a - ln_b).
// Rule: where the denominator is within 1e-3 of 0, its series L_a tau (1 - x / 2), x the
// denominator (no 0 / 0).
vec3 field_step_light(float tau, vec3 ln_a, vec3 ln_b) {
    vec3 x = tau + ln_a - ln_b;
    vec3 la = exp(ln_a), lb = exp(ln_b);
    vec3 exact = tau * (la - lb * exp(-tau)) / mix(x, vec3(1.0), lessThan(abs(x), vec3(1e-3)));
    vec3 series = la * tau * (1.0 - 0.5 * x);
    return max(mix(exact, series, lessThan(abs(x), vec3(1e-3))), vec3(0.0));
}

// The logarithm of the radiance scattered at x toward the camera per unit of
// scattering: the cells' logarithms (field_view.comp) interpolated trilinearly between
// their centres, and within half a cell of the grid's faces extended along the line
// through the last two
// (an axis of one cell holds its value): exact where the logarithm is linear, as in a
// homogeneous region lit along an axis, however dense.  Rule: the result stays at or
// below the largest of the eight corners' unshadowed light, so that extending next to a
// dark cell cannot blow up.
vec3 field_ln_view_at(vec3 x) {
    vec3 p = (x - scene.box_min) / fp.cell.xyz - 0.5;
    ivec3 hi = ivec3(fp.n.xyz) - 1;
    ivec3 i0 = clamp(ivec3(floor(p)), ivec3(0), max(hi - 1, ivec3(0)));
    ivec3 i1 = min(i0 + 1, hi);
    vec3 f = clamp(p - vec3(i0), -0.5, 1.5);
    uint y0 = uint(i0.y) * fp.n.x, y1 = uint(i1.y) * fp.n.x;
    uint z0 = uint(i0.z) * fp.n.x * fp.n.y, z1 = uint(i1.z) * fp.n.x * fp.n.y;
    uint x0 = uint(i0.x), x1 = uint(i1.x);
    vec4 v000 = field_view[x0 + y0 + z0], v100 = field_view[x1 + y0 + z0];
    vec4 v010 = field_view[x0 + y1 + z0], v110 = field_view[x1 + y1 + z0];
    vec4 v001 = field_view[x0 + y0 + z1], v101 = field_view[x1 + y0 + z1];
    vec4 v011 = field_view[x0 + y1 + z1], v111 = field_view[x1 + y1 + z1];
    vec4 v = mix(mix(mix(v000, v100, f.x), mix(v010, v110, f.x), f.y), mix(mix(v001, v101, f.x), mix(v011, v111, f.x), f.y), f.z);
    float top = max(max(max(v000.w, v100.w), max(v010.w, v110.w)), max(max(v001.w, v101.w), max(v011.w, v111.w)));
    return min(v.xyz, vec3(top));
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
    vec3 tail = vec3(0.0);   // the last step's albedo times the light at its far end
    if (box_interval(ro, rd, t0, t1)) {
        if (hit >= 0) t1 = min(t1, t_hit);
        Dda d = coarse_start(ro, rd, t0);
        float t = t0;
        uint steps = 0u;
        // Rule: at most 60000 steps per ray (llvmpipe's bound on an invocation's loop
        // iterations); the host sizes the step so that a ray across the box needs fewer.
        float t_known = -1.0;   // where ln_known, the light toward the camera, was taken
        vec3 ln_known = vec3(0.0);
        while (t < t1 && T > FIELD_T_MIN && steps < 60000u) {
            float te = min(dda_exit(d), t1);
            float sigma_max = cell_majorant(d);
            if (sigma_max == 0.0) {   // empty: jump over the empty bricks around (majorant.glsl)
                float jump = empty_skip(d, rd);
                if (jump > 0.0) {
                    t += jump;
                    steps++;
                    if (t >= t1) break;
                    d = coarse_start(ro, rd, t);
                    continue;
                }
            }
            if (sigma_max > 0.0 && te > t) {
                // steps of optical depth at most FIELD_TAU_STEP against the brick's
                // majorant, between the configured step and four times it
                float want = clamp(FIELD_TAU_STEP / sigma_max, fp.step, 4.0 * fp.step);
                uint n = uint(ceil((te - t) / want));
                float ds = (te - t) / float(max(n, 1u));
                for (uint k = 0u; k < n && T > FIELD_T_MIN && steps < 60000u; k++, steps++) {
                    float ta = t + float(k) * ds;
                    vec3 x = ro + rd * (ta + 0.5 * ds);
                    vec4 tf = transfer(data_value(x));
                    float tau = scene.density * tf.a * ds;
                    if (!(tau > 0.0)) continue;
                    // the light toward the camera at the step's ends (the far end of the
                    // step before is this one's near end)
                    vec3 ln_a = abs(ta - t_known) <= 1e-4 * ds ? ln_known : field_ln_view_at(ro + rd * ta);
                    vec3 ln_b = field_ln_view_at(ro + rd * (ta + ds));
                    t_known = ta + ds;
                    ln_known = ln_b;
                    L += T * tf.rgb * field_step_light(tau, ln_a, ln_b);
                    T *= exp(-tau);
                    tail = tf.rgb * exp(ln_b);
                }
            }
            t = te;
            steps++;
            if (!dda_advance(d)) break;
        }
    }
    if (T <= FIELD_T_MIN) {
        // Rule: a ray that ends in the medium takes the rest of it as radiating the last
        // step's light (what an opaque remainder tends to; exact in the white furnace),
        // and nothing from behind it.
        L += T * tail;
        T = 0.0;
    } else {
        L += T * (hit >= 0 ? area_light_radiance(uint(hit), rd) : background_radiance(rd));
    }
    // Rule: a non-finite pixel (only from input overflowing float) is 0 and counted bad.
    bool bad = any(isnan(L)) || any(isinf(L));
    if (bad) L = vec3(0.0);
    accum_mean[idx] = vec4(L, clamp(1.0 - T, 0.0, 1.0));
    accum_comp[idx] = vec4(0.0);
    // the image counts as fp.prior samples (PICVR_RENDER_FIELD_MC: Monte Carlo's samples are
    // then averaged in with it; else 1)
    accum_stat[idx] = vec4(dot(L, vec3(0.2126, 0.7152, 0.0722)), 0.0, uintBitsToFloat(max(fp.prior, 1u)),
                           uintBitsToFloat(bad ? 1u : 0u));
}
