// clip.glsl - the volume's box and the clip planes (picvr_set_clip): a ray's interval
// inside both, where every tracking loop starts, and the point test the cache's probes
// use, so that a clipped region is empty for every kernel.  Without clip planes
// (USE_CLIP false) nothing of them is compiled.
#ifndef CLIP_GLSL_ONCE
#define CLIP_GLSL_ONCE 1
#include "specialization.glsl"
#include "scene.glsl"
#include "geometry.glsl"

// Ray / clip plane: narrows [t0, t1] to where dot(n, x) + w >= 0.  A ray parallel to the
// plane (dot(n, rd) = 0) keeps all or nothing by its origin's side; the division is by a
// non-zero number only.
void clip_interval(vec4 plane, vec3 ro, vec3 rd, inout float t0, inout float t1) {
    float s = dot(plane.xyz, ro) + plane.w, c = dot(plane.xyz, rd);
    if (c > 0.0) t0 = max(t0, -s / c);
    else if (c < 0.0) t1 = min(t1, -s / c);
    else if (s < 0.0) t1 = t0;
}

// Ray / volume box (and the clip planes, whose region with the box is convex, so one
// interval): [t0, t1] clipped to t >= 0; false when missed.  Every tracking loop starts
// here, so a clipped region is empty for all of them.
bool box_interval(vec3 ro, vec3 rd, out float t0, out float t1) {
    vec3 inv = safe_inverse(rd);
    vec3 a = (scene.box_min - ro) * inv;
    vec3 b = (scene.box_min + scene.box_size - ro) * inv;
    vec3 lo = min(a, b), hi = max(a, b);
    t0 = max(max(lo.x, lo.y), max(lo.z, 0.0));
    t1 = min(min(hi.x, hi.y), hi.z);
    if (USE_CLIP)
        for (uint i = 0u; i < scene.clip_count; i++) clip_interval(scene.clip[i], ro, rd, t0, t1);
    return t1 > t0;
}

// x is inside every clip plane (always true without USE_CLIP).
bool inside_clip(vec3 x) {
    if (USE_CLIP)
        for (uint i = 0u; i < scene.clip_count; i++)
            if (dot(scene.clip[i].xyz, x) + scene.clip[i].w < 0.0) return false;
    return true;
}

#endif
