#version 450
// cache_rebuild.comp - rebuilds the multi-reference octree from the entries (paper
// §4.4, every 1000 ms by Table 1): the host empties the node and reference pools
// (keeping the pre-built top of the tree), then one thread per entry re-inserts it
// with its current, possibly shrunk, radii, so stale references disappear.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 64) in;

#include "common.glsl"
#include "cache.glsl"

void main() {
    uint e = gl_GlobalInvocationID.x;
    if (e >= min(cache_counters.entry_count, scene.cache_caps.x)) return;
    // The largest radius may have shrunk: recompute the bound used for insertion.
    float rmax = 0.0;
    for (uint h = 0u; h < 6u; h++) rmax = max(rmax, entry_radius(e, h));
    entries[e].pos_rmax.w = rmax;
    vec3 x0 = entries[e].pos_rmax.xyz;
    for (uint k = 0u; k < 27u; k++) insert_cell(e, x0, rmax, k);
}
