#version 450
// stats.comp - reduces the per-pixel statistics to per-workgroup partial sums that
// the host adds up in double precision: mean luminance, the image mean of the left
// side of Eq. 5 (absolute and relative), sample counts, truncated samples and the pixels
// that hold a sample.
layout(local_size_x = 256) in;

layout(set = 0, binding = 6, std430) readonly buffer AccumStat { vec4 accum_stat[]; };
struct Partial { vec4 sums; uvec4 counts; };  // sums: lum, err, rel, valid; counts: min n, sum n, bad, sampled pixels
layout(set = 0, binding = 7, std430) writeonly buffer Partials { Partial partials[]; };

layout(push_constant) uniform Push { uint pixel_count; float rel_floor; } pc;

shared vec4 s_sums[256];
shared uvec4 s_counts[256];

void main() {
    // 2D grid of workgroups so images beyond 65535 * 256 pixels reduce too.
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    uint l = gl_LocalInvocationID.x;
    uint i = group * 256u + l;
    vec4 sums = vec4(0.0);
    uvec4 counts = uvec4(0xffffffffu, 0u, 0u, 0u);
    if (i < pc.pixel_count) {
        vec4 s = accum_stat[i];
        uint n = floatBitsToUint(s.z);
        float lum = s.x;
        sums.x = lum;
        // Eq. 5, left side: 1.96 sqrt(S^2(N) / N) with S^2 = M2 / (N - 1).
        // Rule: undefined for N < 2, so such pixels are left out (valid = 0); M2 is
        // clamped at 0 against rounding; rel = 0 when err = 0 (also covers 0/0).
        if (n >= 2u) {
            float var = max(s.y, 0.0) / float(n - 1u);
            float err = 1.96 * sqrt(var / float(n));
            sums.y = err;
            sums.z = err > 0.0 ? err / max(lum + pc.rel_floor, 1e-30) : 0.0;
            sums.w = 1.0;
        }
        counts = uvec4(n, n, floatBitsToUint(s.w), n > 0u ? 1u : 0u);
        // Rule: each pixel adds at most FLT_MAX / 256 to each sum, so that a workgroup's
        // sum of 256 stays finite (a pixel beyond ~1e36 saturates the image statistics).
        sums = min(sums, vec4(1.329e36));
    }
    s_sums[l] = sums;
    s_counts[l] = counts;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1u) {
        if (l < stride) {
            s_sums[l] += s_sums[l + stride];
            uvec4 a = s_counts[l], b = s_counts[l + stride];
            s_counts[l] = uvec4(min(a.x, b.x), a.y + b.y, a.z + b.z, a.w + b.w);
        }
        barrier();
    }
    if (l == 0u && group * 256u < pc.pixel_count) partials[group] = Partial(s_sums[0], s_counts[0]);
}
