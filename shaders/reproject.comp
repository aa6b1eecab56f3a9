#version 450
// reproject.comp - temporal reuse (picvr_scheduler_config.temporal_reuse; host/
// reproject.c): after a camera move, each pixel's accumulation moves to the pixel of the
// new view where its scene point lands.  The point is the old pixel's centre ray at the
// mean distance of its scatter events (render.glsl, accumulate_depth); a pixel whose
// rays never scattered saw only what lies beyond the medium, so it moves by its
// direction alone (a point at infinity).  One thread per old pixel, three passes, so
// that the result does not depend on the order threads run in:
//   pass 0: each landing pixel keeps the nearest landing distance (atomicMin on its
//           float bits: non-negative floats order as their bits);
//   pass 1: of the old pixels at that distance, the lowest index (atomicMin);
//   pass 2: that old pixel writes its history there, with at most `history` samples'
//           weight: mean and Kahan terms as they are, the sample variance kept (M2
//           scaled by (n' - 1) / (n - 1)), the truncated count and the depth count
//           scaled to n'.
// Pixels nothing lands on (disoccluded, newly in view) stay zero: no sample.
layout(local_size_x = 256) in;

layout(set = 0, binding = 0, std430) readonly buffer OldMean { vec4 old_mean[]; };
layout(set = 0, binding = 1, std430) readonly buffer OldComp { vec4 old_comp[]; };
layout(set = 0, binding = 2, std430) readonly buffer OldStat { vec4 old_stat[]; };   // lum mean, M2, n, bad
layout(set = 0, binding = 3, std430) readonly buffer OldDepth { vec2 old_depth[]; }; // mean t, count
layout(set = 0, binding = 4, std430) writeonly buffer NewMean { vec4 new_mean[]; };
layout(set = 0, binding = 5, std430) writeonly buffer NewComp { vec4 new_comp[]; };
layout(set = 0, binding = 6, std430) writeonly buffer NewStat { vec4 new_stat[]; };
layout(set = 0, binding = 7, std430) writeonly buffer NewDepth { vec2 new_depth[]; };
layout(set = 0, binding = 8, std430) buffer Landing { uint landing[]; };   // per pixel: distance bits, old index

// view[0..13] the old camera, view[14..27] the new one: position, tan(fov_y / 2),
// forward, aspect, right, up (host/image.c's basis).
layout(push_constant) uniform Push { float view[28]; uint width; uint height; uint history; uint pass_index; } pc;

struct View { vec3 pos; float tan_half; vec3 fwd; float aspect; vec3 right; vec3 up; };

View view_at(uint o) {
    View v;
    v.pos = vec3(pc.view[o], pc.view[o + 1u], pc.view[o + 2u]);
    v.tan_half = pc.view[o + 3u];
    v.fwd = vec3(pc.view[o + 4u], pc.view[o + 5u], pc.view[o + 6u]);
    v.aspect = pc.view[o + 7u];
    v.right = vec3(pc.view[o + 8u], pc.view[o + 9u], pc.view[o + 10u]);
    v.up = vec3(pc.view[o + 11u], pc.view[o + 12u], pc.view[o + 13u]);
    return v;
}

// The centre ray of pixel px (camera.glsl's camera_ray with the jitter at 1/2).
vec3 centre_ray(View v, uvec2 px) {
    float sx = (2.0 * (float(px.x) + 0.5) / float(pc.width) - 1.0) * v.tan_half * v.aspect;
    float sy = (1.0 - 2.0 * (float(px.y) + 0.5) / float(pc.height)) * v.tan_half;
    return normalize(v.fwd + sx * v.right + sy * v.up);
}

// The pixel of view v that offset w from its camera falls in (w a direction for a point
// at infinity); false behind the camera or outside the image.
bool land(View v, vec3 w, out uint idx) {
    idx = 0u;
    float z = dot(w, v.fwd);
    // Rule: at or behind the camera plane (z <= 1e-6 |w|) the point has no pixel.
    if (!(z > 1e-6 * length(w))) return false;
    float fx = (dot(w, v.right) / (z * v.tan_half * v.aspect) + 1.0) * 0.5 * float(pc.width);
    float fy = (1.0 - dot(w, v.up) / (z * v.tan_half)) * 0.5 * float(pc.height);
    if (!(fx >= 0.0 && fx < float(pc.width) && fy >= 0.0 && fy < float(pc.height))) return false;   // NaN too
    idx = min(uint(fy), pc.height - 1u) * pc.width + min(uint(fx), pc.width - 1u);
    return true;
}

void main() {
    uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256u + gl_LocalInvocationID.x;
    if (i >= pc.width * pc.height) return;
    vec4 stat = old_stat[i];
    uint n = floatBitsToUint(stat.z);
    if (n == 0u) return;                                   // nothing to move
    View from = view_at(0u), to = view_at(14u);
    vec2 depth = old_depth[i];
    uint scattered = floatBitsToUint(depth.y);
    vec3 d = centre_ray(from, uvec2(i % pc.width, i / pc.width));
    // Rule: a non-finite or negative mean depth (never written) counts as no scatter event.
    bool at_infinity = scattered == 0u || !(depth.x >= 0.0) || isinf(depth.x);
    vec3 w = at_infinity ? d : from.pos + d * depth.x - to.pos;
    uint q;
    if (!land(to, w, q)) return;
    float distance = at_infinity ? 3.4028235e38 : length(w);
    uint key = floatBitsToUint(distance);
    // landing starts at 0xffffffff: above every distance's bits and every index
    if (pc.pass_index == 0u) {
        atomicMin(landing[2u * q], key);
        return;
    }
    if (landing[2u * q] != key) return;
    if (pc.pass_index == 1u) {
        atomicMin(landing[2u * q + 1u], i);
        return;
    }
    if (landing[2u * q + 1u] != i) return;
    uint kept = min(n, pc.history);
    float m2 = kept >= 2u && n >= 2u ? stat.y * (float(kept - 1u) / float(n - 1u)) : 0.0;
    uint bad = min(floatBitsToUint(stat.w), kept);
    uint scattered_kept = scattered == 0u ? 0u : max(1u, uint(float(scattered) * float(kept) / float(n) + 0.5));
    new_mean[q] = old_mean[i];
    new_comp[q] = old_comp[i];
    new_stat[q] = vec4(stat.x, m2, uintBitsToFloat(kept), uintBitsToFloat(bad));
    new_depth[q] = at_infinity ? vec2(0.0) : vec2(distance, uintBitsToFloat(min(scattered_kept, kept)));
}
