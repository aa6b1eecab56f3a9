/* layout_host.c - prints the host's mirrors of the shaders' layouts and constants, one
   "NAME VALUE" per line, for tools/check_layout.sh (`make check-layout`), from the
   implementation's internal header. */
#include "../host/internal.h"

int main(void)
{
    printf("Scene %zu\n", sizeof(picvr_gpu_scene));
    /* the members the kernels read (glslang reflects only those) */
#define PICVR_SCENE(m) printf("Scene.%s %u\n", #m, (unsigned)offsetof(picvr_gpu_scene, m))
    PICVR_SCENE(cam_pos);
    PICVR_SCENE(tan_half_fov);
    PICVR_SCENE(cam_fwd);
    PICVR_SCENE(aspect);
    PICVR_SCENE(cam_right);
    PICVR_SCENE(cam_up);
    PICVR_SCENE(box_min);
    PICVR_SCENE(density);
    PICVR_SCENE(box_size);
    PICVR_SCENE(cell_size);
    PICVR_SCENE(min_spacing);
    PICVR_SCENE(grid);
    PICVR_SCENE(light_count);
    PICVR_SCENE(image);
    PICVR_SCENE(dims);
    PICVR_SCENE(background);
    PICVR_SCENE(background_pmf);
    PICVR_SCENE(value_map);
    PICVR_SCENE(gamma);
    PICVR_SCENE(epsilon);
    PICVR_SCENE(delta);
    PICVR_SCENE(update_threshold);
    PICVR_SCENE(radius_min);
    PICVR_SCENE(radius_max);
    PICVR_SCENE(curvature_limit);
    PICVR_SCENE(medium_model);
    PICVR_SCENE(max_entries);
    PICVR_SCENE(max_nodes);
    PICVR_SCENE(max_refs);
    PICVR_SCENE(max_requests);
    PICVR_SCENE(superpixel_side);
    PICVR_SCENE(superpixels_per_row);
    PICVR_SCENE(superpixel_count);
    PICVR_SCENE(probe_fraction);
    PICVR_SCENE(debug_view);
    PICVR_SCENE(light_log_k);
    PICVR_SCENE(max_bounces);
    PICVR_SCENE(back_g);
    PICVR_SCENE(back_weight);
    PICVR_SCENE(vertex_cost);
    PICVR_SCENE(env_w);
    PICVR_SCENE(env_h);
    PICVR_SCENE(env_basis);
    PICVR_SCENE(clip);
    PICVR_SCENE(clip_count);
#define PICVR_LIGHT(m) \
    printf("Scene.lights.%s %u\n", #m, (unsigned)(offsetof(picvr_gpu_scene, lights) + offsetof(picvr_gpu_light, m)))
    PICVR_LIGHT(pos);
    PICVR_LIGHT(type);
    PICVR_LIGHT(radiance);
    PICVR_LIGHT(pmf);
    PICVR_LIGHT(edge_u);
    PICVR_LIGHT(size);
    PICVR_LIGHT(edge_v);
    PICVR_LIGHT(area);
    PICVR_LIGHT(cdf);
    PICVR_LIGHT(eq_pmf);
    PICVR_LIGHT(eq_cdf);
    printf("CacheEntries %u\n", PICVR_CACHE_ENTRY_BYTES);
    printf("CacheMoments %u\n", PICVR_CACHE_MOMENT_BYTES);
    printf("MS_LANE_SAMPLES %u\n", PICVR_CACHE_MS_LANE_SAMPLES);
    printf("CacheNodes %u\n", PICVR_CACHE_NODE_BYTES);
    printf("CacheRefs %u\n", PICVR_CACHE_REF_BYTES);
    printf("CacheRequests %u\n", PICVR_CACHE_REQUEST_BYTES);
    printf("CacheCounters %u\n", (unsigned)sizeof(picvr_cache_counters));
#define PICVR_COUNTER(glsl, host) \
    printf("CacheCounters.%s %u\n", glsl, (unsigned)offsetof(picvr_cache_counters, host))
    PICVR_COUNTER("dispatch_x", dispatch);
    PICVR_COUNTER("request_count", request_count);
    PICVR_COUNTER("entry_count", entry_count);
    PICVR_COUNTER("node_count", node_count);
    PICVR_COUNTER("ref_count", ref_count);
    PICVR_COUNTER("full", full);
    PICVR_COUNTER("hits", hits);
    PICVR_COUNTER("misses", misses);
    PICVR_COUNTER("requests", requests);
    PICVR_COUNTER("capped", capped);
    PICVR_COUNTER("point_rounds", point_rounds);
    PICVR_COUNTER("truncated", truncated);
    PICVR_COUNTER("lookups_cut", lookups_cut);
    PICVR_COUNTER("lookups_spilled", lookups_spilled);
    PICVR_COUNTER("routed", routed);
    PICVR_COUNTER("probes", probes);
    PICVR_COUNTER("gain_lo", gain_lo);
    PICVR_COUNTER("gain_hi", gain_hi);
    printf("VIEW_IMAGE %d\nVIEW_CACHE %d\nVIEW_CACHE_ERROR %d\n", (int)PICVR_VIEW_IMAGE,
           (int)PICVR_VIEW_CACHE, (int)PICVR_VIEW_CACHE_ERROR);
    printf("CACHE_NODE_RADII %g\n", (double)PICVR_CACHE_NODE_RADII);
    printf("EVENT_WORDS %u\nEVENT_GROUP %u\n", PICVR_EVENT_WORDS, PICVR_EVENT_GROUP);
    printf("PATH_STEPS %u\n", PICVR_PATH_STEPS);
    /* the specialization constants' ids (shaders/specialization.glsl) and their number */
#define PICVR_SPEC(name) printf("SPEC.%s %d\n", #name, (int)PICVR_SPEC_##name)
    PICVR_SPEC(USE_PHASE_MIS);
    PICVR_SPEC(USE_FINE);
    PICVR_SPEC(CREATE_MAX_ROUNDS);
    PICVR_SPEC(USE_DEBUG_VIEW);
    PICVR_SPEC(MONO_CHANNEL);
    PICVR_SPEC(SCREEN_LOCKING);
    PICVR_SPEC(CACHE_MAX_LOOKUP_REFS);
    PICVR_SPEC(USE_EQUIANGULAR);
    PICVR_SPEC(USE_RESIDUAL);
    PICVR_SPEC(USE_QMC);
    PICVR_SPEC(USE_BOUNCES);
    PICVR_SPEC(USE_HG);
    PICVR_SPEC(USE_ENV_MAP);
    PICVR_SPEC(USE_REUSE);
    PICVR_SPEC(USE_CLIP);
    PICVR_SPEC(CACHE_BLEND);
    PICVR_SPEC(CREATE_SAMPLE_STEPS);
    PICVR_SPEC(LOOKUP_EVENT);
    PICVR_SPEC(USE_FORCED);
    PICVR_SPEC(USE_MEASURE);
    PICVR_SPEC(USE_RAY_MARCHING);
    printf("SPEC_CONSTANTS %d\n", (int)PICVR_SPEC_CONSTANTS);
    return 0;
}
