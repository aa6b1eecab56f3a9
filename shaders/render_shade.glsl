// render_shade.glsl - the rendering procedure's shading kernel (paper §3, Eq. 4; see
// render.glsl): one thread per queued scatter event (every event without the cache, the
// misses with it), shaded by plain Monte Carlo: one light and one phase sample (MIS), and with
// USE_BOUNCES the rest of the path (path.glsl), in render_shade_cache.comp with the cache
// looked up at its LOOKUP_EVENT-th event (path_cache.glsl);
// with USE_EQUIANGULAR also the equiangular sample and the end term (distance.glsl).
#include "render.glsl"
layout(local_size_x = EVENT_GROUP, local_size_y = 1) in;

void main() {
    ScatterEvent e;
    LOAD_EVENT(shade_queue, e)
    uint events;
    vec3 L;
    float coverage = 1.0;
    if (USE_EQUIANGULAR) {
        L = finish_camera_sample(e, false, vec3(0.0), vec3(0.0), coverage, events);
    } else {
        vec3 direct;
        L = event_radiance(e, direct, events);
    }
    count_events(events);
    accumulate_sample(e.idx, L, coverage, e.truncated);
    accumulate_depth(e.idx, e.t);
}
