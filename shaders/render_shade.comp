#version 450
// render_shade.comp - the rendering procedure's shading kernel (paper §3, Eq. 4; see
// render.glsl): one thread per queued scatter event (every event without the cache, the
// misses with it), shaded by plain Monte Carlo: one light and one phase sample (MIS);
// with USE_EQUIANGULAR also the equiangular sample and the end term (distance.glsl).
#extension GL_GOOGLE_include_directive : require
#include "render.glsl"
layout(local_size_x = EVENT_GROUP, local_size_y = 1) in;

void main() {
    ScatterEvent e;
    LOAD_EVENT(shade_queue, e)
    if (USE_EQUIANGULAR) {
        float coverage;
        vec3 L = finish_camera_sample(e, false, vec3(0.0), coverage);
        accumulate_sample(e.idx, L, coverage, e.truncated);
        return;
    }
    vec3 Ls = direct_light(e.x, e.rng, e.truncated);
    accumulate_sample(e.idx, albedo_at(e.x) * Ls, 1.0, e.truncated);
}
