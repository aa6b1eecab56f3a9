#version 450
#extension GL_GOOGLE_include_directive : require
// field_light.comp - each light's optical depth from every cell's centre (field.glsl,
// light_t): one thread per cell and light, summed exactly along the line to the light
// through the constant cells, through the true medium and through the delta-M scaled
// one.  The medium ends at the grid (the lights stand outside it or in it).  Rule: a
// light at the centre itself (distance 0) has optical depth 0.
layout(local_size_x = 256) in;
#include "field.glsl"

// Whether some cell of the 5 x 5 x 5 around q holds medium: only such cells are read by
// the passes and the image.  A point of the image with medium lies in a cell with
// medium or next to one (the classification samples points of the cell, the image the
// trilinear volume between them), and its trilinear stencil reaches one cell further.
bool field_near_medium(ivec3 q) {
    for (int k = 0; k < 125; k++) {
        ivec3 p = q + ivec3(k % 5, (k / 5) % 5, k / 25) - 2;
        if (any(lessThan(p, ivec3(0))) || any(greaterThanEqual(p, ivec3(fp.n.xyz)))) continue;
        if (cells[2u * field_index(p)].x > 0.0) return true;
    }
    return false;
}

void main() {
    uint id = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256u + gl_LocalInvocationID.x;
    uint ncells = fp.n.w;
    // the first light's threads mark the active cells (cells[2c + 1].w; the medium's
    // extinction, which they read, is in the other element)
    if (id < ncells) cells[2u * id + 1u].w = field_near_medium(field_cell_of(id)) ? 1.0 : 0.0;
    if (id >= ncells * max(scene.light_count, 1u)) return;
    if (scene.light_count == 0u) return;
    uint c = id % ncells, l = id / ncells;
    vec3 x = field_centre(field_cell_of(c)), toward;
    float dist;
    field_light_irradiance(l, x, toward, dist);
    float tau = 0.0;
    vec3 tau_scaled = vec3(0.0);
    if (dist > 0.0) {
        FieldWalk w = field_walk_start(x, toward);
        uint cell;
        float len;
        bool dm = (fp.flags & FIELD_DELTA_M) != 0u;
        while (field_walk_next(w, dist, cell, len)) {
            vec4 m = cells[2u * cell];
            tau += m.x * len;
            if (dm) {
                vec3 sigma, albedo;
                field_scaled(m, cells[2u * cell + 1u].z, sigma, albedo);
                tau_scaled += sigma * len;
            }
        }
        if (!dm) tau_scaled = vec3(tau);
    }
    light_t[id] = vec4(tau, tau_scaled);
}

