// majorant.glsl - the majorant walk: the grids of majorants of sigma_t that delta and
// ratio tracking run against (bricks from host/majorant.c, and voxels, computed here
// from the transfer function's range maxima), a 3D DDA over either, empty-space skipping
// and the bricks' minorants.  tracking.glsl walks it.
#ifndef MAJORANT_GLSL_ONCE
#define MAJORANT_GLSL_ONCE 1
#include "scene.glsl"
#include "geometry.glsl"

// ---- majorant grids: bricks (coarse) and voxels (fine) ----
// Coarse: one majorant per brick of `brick` voxels (with a one-voxel apron), plus an
// empty-space distance.  Fine, used only inside bricks where delta tracking would take
// many steps (dense media: majorant * length > FINE_THRESHOLD): the dual grid of voxel
// centres, where the trilinear value is a convex combination of the 8 corner texels,
// so D * max(opacity over [min, max] of the corners) bounds sigma_t exactly.  Tracking
// walks the fine grid only in the variants with USE_FINE (specialization.glsl).
#define FINE_THRESHOLD 64.0

layout(set = 0, binding = 8, std430) readonly buffer TfRangeMax { float tf_range_max[]; };

struct Dda {
    ivec3 cell;
    ivec3 stp;
    ivec3 hi;       // last valid cell per axis (the first is 0)
    vec3 t_next;    // ray parameter of the next boundary per axis
    vec3 t_delta;   // ray parameter across one cell per axis
};

// DDA over cells of size cs whose cell (0,0,0) starts at origin.
Dda dda_start(vec3 ro, vec3 rd, float t, vec3 origin, vec3 cs, ivec3 hi) {
    Dda d;
    vec3 p = (ro + rd * t - origin) / cs;
    d.hi = hi;
    d.cell = clamp(ivec3(floor(p)), ivec3(0), hi);
    d.stp = ivec3(mix(vec3(-1.0), vec3(1.0), greaterThanEqual(rd, vec3(0.0))));
    vec3 inv = safe_inverse(rd);
    vec3 boundary = (vec3(d.cell) + vec3(greaterThan(d.stp, ivec3(0)))) * cs + origin;
    d.t_next = max((boundary - ro) * inv, vec3(t));
    d.t_delta = abs(cs * inv);
    return d;
}

Dda coarse_start(vec3 ro, vec3 rd, float t) {
    return dda_start(ro, rd, t, scene.box_min, scene.cell_size, ivec3(scene.grid) - 1);
}

// Fine cells are shifted by half a voxel (dual grid), so cell j spans voxel centres
// j-1 .. j (texels clamped at the border); there are dims + 1 of them per axis.
Dda fine_start(vec3 ro, vec3 rd, float t) {
    vec3 spacing = scene.box_size / vec3(scene.dims.xyz);
    return dda_start(ro, rd, t, scene.box_min - 0.5 * spacing, spacing, ivec3(scene.dims.xyz));
}

uint cell_index(Dda d) {
    uvec3 c = uvec3(d.cell);
    return c.x + scene.grid.x * (c.y + scene.grid.y * c.z);
}

float cell_majorant(Dda d) { return majorant[cell_index(d)]; }

float texel_value(ivec3 q) {
    q = clamp(q, ivec3(0), ivec3(scene.dims.xyz) - 1);
    return clamp(texelFetch(volume_tex, q, 0).r * scene.value_map.x + scene.value_map.y, 0.0, 1.0);
}

// Largest table opacity over entries [lo, hi] (sparse table: level k holds the max of
// 2^k entries), with one entry of margin each side as on the host.
float opacity_range_max(float vmin, float vmax) {
    int lo = max(int(floor(vmin * (TF_SIZE - 1.0))) - 1, 0);
    int hi = min(int(ceil(vmax * (TF_SIZE - 1.0))) + 1, int(TF_SIZE) - 1);
    int k = findMSB(hi - lo + 1);
    int n = int(TF_SIZE);
    return max(tf_range_max[k * n + lo], tf_range_max[k * n + hi - (1 << k) + 1]);
}

// Written out (no loop) so it does not count against llvmpipe's loop budget.
float fine_majorant(Dda f) {
    ivec3 j = f.cell - 1;
    float a = texel_value(j),                 b = texel_value(j + ivec3(1, 0, 0));
    float c = texel_value(j + ivec3(0, 1, 0)), d = texel_value(j + ivec3(1, 1, 0));
    float e = texel_value(j + ivec3(0, 0, 1)), g = texel_value(j + ivec3(1, 0, 1));
    float h = texel_value(j + ivec3(0, 1, 1)), k = texel_value(j + ivec3(1, 1, 1));
    float vmin = min(min(min(a, b), min(c, d)), min(min(e, g), min(h, k)));
    float vmax = max(max(max(a, b), max(c, d)), max(max(e, g), max(h, k)));
    return scene.density * opacity_range_max(vmin, vmax) * 1.001;
}

// Empty-space skipping.  The second half of the majorant buffer holds, per empty
// cell, the Chebyshev distance k (in cells) to the nearest non-empty cell.  From any
// point p of cell c, a move of less than m = k - 1 cells along every axis stays in
// cells within distance m of c, all empty; so the ray may jump by
// t = m / max_i(|rd_i| / cell_size_i) and restart the DDA there.  Returns 0 when
// no jump is possible (k < 2).
float empty_skip(Dda d, vec3 rd) {
    uint cells = scene.grid.x * scene.grid.y * scene.grid.z;
    float m = majorant[cells + cell_index(d)] - 1.0;
    if (m < 1.0) return 0.0;
    vec3 speed = abs(rd) / scene.cell_size;     // cells per unit of t, per axis
    return m / max(max(speed.x, speed.y), max(speed.z, 1e-30));
}

float dda_exit(Dda d) { return min(d.t_next.x, min(d.t_next.y, d.t_next.z)); }

// Moves to the next cell; false when the ray leaves the grid.
bool dda_advance(inout Dda d) {
    if (d.t_next.x <= d.t_next.y && d.t_next.x <= d.t_next.z) {
        d.cell.x += d.stp.x; d.t_next.x += d.t_delta.x;
    } else if (d.t_next.y <= d.t_next.z) {
        d.cell.y += d.stp.y; d.t_next.y += d.t_delta.y;
    } else {
        d.cell.z += d.stp.z; d.t_next.z += d.t_delta.z;
    }
    return all(greaterThanEqual(d.cell, ivec3(0))) && all(lessThanEqual(d.cell, d.hi));
}

#endif
