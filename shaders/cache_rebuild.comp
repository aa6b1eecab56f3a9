#version 450
// cache_rebuild.comp - rebuilds the multi-reference octree from the entries (paper
// §4.4, every 1000 ms by Table 1): the host empties the node and reference pools
// (keeping the pre-built top of the tree), then one thread per entry re-inserts it
// with its current, possibly shrunk, radii, so stale references disappear.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#include "specialization.glsl"
#include "cache.glsl"

void main() {
    uint e = gl_GlobalInvocationID.x;
    if (e >= min(cache_counters.entry_count, scene.max_entries)) return;
    // The radii may have shrunk: recompute the largest, the lookup's sphere test.
    vec3 r_pos = vec3(entry_radius(e, 0u), entry_radius(e, 2u), entry_radius(e, 4u));
    vec3 r_neg = vec3(entry_radius(e, 1u), entry_radius(e, 3u), entry_radius(e, 5u));
    entries[e].pos_rmax.w = largest_radius(r_pos, r_neg);
    vec3 x0 = entries[e].pos_rmax.xyz, n = entries[e].normal;
    for (uint k = 0u; k < 27u; k++) insert_cell(e, x0, n, r_pos, r_neg, k);
}
