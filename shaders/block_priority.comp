#version 450
// block_priority.comp - rendering priorities (paper §6, Eq. 12): for every 16x8 block the
// mean over its pixels of the expected reduction of the error estimate by one more sample,
//   dE = 1.96 (sqrt(S^2(N) / N) - sqrt(S^2(N) / (N + 1))),
// assuming the sample variance S^2 stays the same.  One thread per block.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#include "queue.glsl"

layout(set = 0, binding = 6, std430) readonly buffer AccumStat { vec4 accum_stat[]; };  // lum mean, M2, n, bad

layout(push_constant) uniform Push { uint width; uint height; uint pad0; uint pad1; } pc;

// Eq. 12 for one pixel.  1/sqrt(N) - 1/sqrt(N+1) is written as
// 1 / (sqrt(N) sqrt(N+1) (sqrt(N) + sqrt(N+1))), which has no cancellation: at N = 1e6
// the direct difference would keep only about one significant digit in float.
float expected_gain(float m2, float n) {
    float s = sqrt(max(m2, 0.0) / (n - 1.0));           // rule: M2 < 0 from rounding -> 0
    float a = sqrt(n), b = sqrt(n + 1.0);
    return 1.96 * s / (a * b * (a + b));
}

void main() {
    uvec2 image = uvec2(pc.width, pc.height);
    uint b = gl_GlobalInvocationID.x;
    if (b >= block_count(image)) return;
    uvec2 o = block_origin(b, image);
    float sum = 0.0;
    uint valid = 0u;
    bool force = false;
    for (uint j = 0u; j < BLOCK_W * BLOCK_H; j++) {
        uvec2 px = o + uvec2(j % BLOCK_W, j / BLOCK_W);
        if (px.x >= image.x || px.y >= image.y) continue;
        vec4 s = accum_stat[px.y * image.x + px.x];
        float n = float(floatBitsToUint(s.z));
        // Rule: S^2 is undefined below two samples; such a pixel forces its block into
        // the queue (it has the largest possible gain: no estimate yet).
        if (n < 2.0) { force = true; continue; }
        float g = expected_gain(s.y, n);
        if (g < 3.0e38) { sum += g; valid++; }           // rule: non-finite (never seen) -> left out
    }
    float p = force ? PRIORITY_FORCE : valid > 0u ? sum / float(valid) : 0.0;
    render_queue.blocks[b].z = floatBitsToUint(p);
}
