#version 450
// cache_update.comp - the cache update procedure (paper §4.3, §7).  A work package is
// a 16x8 block of the image; each thread picks a random pixel in it, finds a scatter
// event like the rendering procedure, and collects the predictions of all entries
// covering it.  While the predictions conflict (largest over smallest luminance
// irradiance above 1 + update threshold), the entry of lowest weight is removed from
// the event by shrinking its radii in that octant proportionally to the event's local
// coordinates (Fig. 6), until the remaining predictions agree or one is left.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 16, local_size_y = 8) in;

#include "specialization.glsl"
#include "scene.glsl"
#include "random.glsl"
#include "clip.glsl"
#include "views.glsl"
#include "tracking.glsl"
#include "camera.glsl"
#include "cache.glsl"

layout(push_constant) uniform Push { uint sched_round; uint seed; } pc;

// The candidates an event collects (a per-invocation array, so bounded).  Entries past
// the 16th would be left out of the conflict test; the test scenes' events have fewer
// (docs/cache.md, "The update procedure's candidates").
#define UPDATE_MAX_CANDIDATES 16u

void main() {
    uint lid = gl_LocalInvocationIndex;
    // The block: a hash of (work package, round), the same for the whole group.
    uint blocks_x = (scene.image.x + 15u) / 16u, blocks_y = (scene.image.y + 7u) / 8u;
    uint block = pcg_hash(gl_WorkGroupID.x ^ pcg_hash(pc.sched_round ^ pcg_hash(pc.seed + 0x27d4eb2du)))
                 % (blocks_x * blocks_y);
    Rng rng = rng_init(block * 128u + lid, pc.sched_round, pc.seed ^ 0x165667b1u);
    // A random pixel of the block (random, so neighbouring threads update entries at
    // different object-space positions, §7).
    uvec2 px = uvec2((block % blocks_x) * 16u + min(uint(rnd(rng) * 16.0), 15u),
                     (block / blocks_x) * 8u + min(uint(rnd(rng) * 8.0), 7u));
    if (px.x >= scene.image.x || px.y >= scene.image.y) return;   // no barriers below

    vec3 ro = scene.cam_pos;
    vec3 rd = camera_ray(px, rng);
    float t0, t1;
    if (!box_interval(ro, rd, t0, t1)) return;
    bool truncated = false;
    float t = delta_track(ro, rd, t0, t1, rng, truncated);
    if (t < 0.0) return;
    vec3 x = ro + rd * t;

    // Candidates: the first UPDATE_MAX_CANDIDATES entries whose zone contains x, in walk
    // order: those the lookup's passes find (zone_candidates), then, after a spilled
    // walk, the rest of it one at a time (`next`: the first past the buffer).
    uint cand[UPDATE_MAX_CANDIDATES];
    float weight[UPDATE_MAX_CANDIDATES], lnE[UPDATE_MAX_CANDIDATES];
    vec3 local[UPDATE_MAX_CANDIDATES];
    uint count = 0u;
    CacheWalk w = walk_start();
    uint found[LOOKUP_CANDIDATES];
    uint n, next, i = 0u;
    bool near_centre = false, more = true;
    bool spilled = zone_candidates(x, w, found, n, next, near_centre);
    while (count < UPDATE_MAX_CANDIDATES && more) {
        uint entry;
        if (i < n) entry = found[i++];
        else if (spilled) { entry = next; more = walk_next(w, x, next); }
        else break;
        Prediction p = predict(entry, x);
        if (p.w > 0.0) {
            cand[count] = entry;
            weight[count] = p.w;
            lnE[count] = luminance(p.lnE);   // the luminance weights applied to ln E
            local[count] = p.local;
            count++;
        }
    }

    // Resolve conflicts: at most count - 1 removals.
    float ln_threshold = log(1.0 + scene.update_threshold);
    for (uint iter = 0u; iter < UPDATE_MAX_CANDIDATES && count > 1u; iter++) {
        float lmin = 1e30, lmax = -1e30, wmin = 2.0;
        uint kmin = 0u;
        for (uint k = 0u; k < count; k++) {
            lmin = min(lmin, lnE[k]);
            lmax = max(lmax, lnE[k]);
            if (weight[k] < wmin) { wmin = weight[k]; kmin = k; }
        }
        if (lmax - lmin <= ln_threshold) break;
        // Shrink the lowest-weight entry's three half-axes of this octant (Fig. 6).
        uint e = cand[kmin];
        vec3 l = local[kmin];
        uvec3 h = uvec3(0u, 2u, 4u) + uvec3(lessThan(l, vec3(0.0)));
        vec3 a = abs(l);
        float rx = entry_radius(e, h.x), ry = entry_radius(e, h.y), rz = entry_radius(e, h.z);
        float f = CM_FN(reduce_factor)(a.x, a.y, a.z, rx, ry, rz);
        float rmin = entry_r_min_of(e);
        atomicMin(entries[e].radius[h.x], floatBitsToUint(CM_FN(reduced_radius)(rx, f, rmin)));
        atomicMin(entries[e].radius[h.y], floatBitsToUint(CM_FN(reduced_radius)(ry, f, rmin)));
        atomicMin(entries[e].radius[h.z], floatBitsToUint(CM_FN(reduced_radius)(rz, f, rmin)));
        // Remove it from the candidates (swap with the last).
        count--;
        cand[kmin] = cand[count];
        weight[kmin] = weight[count];
        lnE[kmin] = lnE[count];
        local[kmin] = local[count];
    }
}
