// render_track.glsl - the rendering procedure's first kernel (paper §3, §4.1; see
// render.glsl): one workgroup per queued block (block_select.comp), one thread per
// pixel.  Tracks the primary ray by delta tracking: a ray that leaves the volume adds
// the area light or background it sees, a scatter event is queued for the cache
// lookup (PICVR_CACHE: render_track_cache.comp) or for shading (render_track.comp).
// Two SPIR-V modules rather than a specialization constant, so that the plain kernel
// declares no lookup queue.
#include "render.glsl"
layout(local_size_x = BLOCK_W, local_size_y = BLOCK_H) in;

void main() {
    uvec2 px = block_origin(render_queue.blocks[gl_WorkGroupID.x].x, scene.image.xy) + gl_LocalInvocationID.xy;
    if (px.x >= scene.image.x || px.y >= scene.image.y) return;
    uint idx = px.y * scene.image.x + px.x;
    Rng rng = pixel_rng(idx);
    vec3 ro = scene.cam_pos;
    vec3 rd = camera_ray(px, rng);
    bool truncated = false;

    float t_light;
    int light_hit = nearest_area_light(ro, rd, 1e30, t_light);
    float t = -1.0, t0 = 0.0, t1 = 0.0;
    if (box_interval(ro, rd, t0, t1)) {
        t1 = min(t1, t_light);
        rng.flight = true;   // the first free flight from the pixel's sequence
        if (t1 > t0) t = delta_track(ro, rd, t0, t1, rng, truncated);
    }
    // with strategy B every ray through medium has more to gather (a segment without
    // medium has nothing: it is seen through, T = 1 exactly, as below)
    if (USE_EQUIANGULAR && t < 0.0 && t1 > t0 && (track_met_medium || truncated) &&
        !(USE_DEBUG_VIEW && scene.debug_view != VIEW_IMAGE)) {
        QUEUE_EVENT(shade_queue, idx, t, rng, truncated)
        return;
    }
    if (t >= 0.0) {
#ifdef PICVR_CACHE
        // the cache serves multiple scattering (any phase function: it holds the fluence)
        // and isotropic single scattering: with an anisotropic one alone it idles
        if (!USE_BOUNCES && USE_HG) { QUEUE_EVENT(shade_queue, idx, t, rng, truncated) return; }
        // looked up at a later event by the shading kernel (the debug views: at the first)
        if (LOOKUP_EVENT > 1u && !(USE_DEBUG_VIEW && scene.debug_view != VIEW_IMAGE)) {
            QUEUE_EVENT(shade_queue, idx, t, rng, truncated)
            return;
        }
        QUEUE_EVENT(lookup_queue, idx, t, rng, truncated)
#else
        QUEUE_EVENT(shade_queue, idx, t, rng, truncated)
#endif
        return;
    }
    vec3 radiance;
    if (USE_DEBUG_VIEW && scene.debug_view != VIEW_IMAGE) radiance = vec3(0.0);   // the debug views show scatter events only
    else if (light_hit >= 0) radiance = area_light_radiance(uint(light_hit), rd);
    else radiance = background_radiance(rd);
    accumulate_sample(idx, radiance, 0.0, truncated);
}
