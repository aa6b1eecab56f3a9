/* layout_host.c - prints the host's mirrors of the shaders' layouts and constants, one
   "NAME VALUE" per line, for tools/check_layout.sh (`make check-layout`), from the
   implementation's internal header. */
#include "../host/internal.h"

int main(void)
{
    printf("Scene %zu\n", sizeof(picvr_gpu_scene));
    printf("CacheEntries %u\n", PICVR_CACHE_ENTRY_BYTES);
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
    printf("VIEW_IMAGE %d\nVIEW_CACHE %d\nVIEW_CACHE_ERROR %d\n", (int)PICVR_VIEW_IMAGE,
           (int)PICVR_VIEW_CACHE, (int)PICVR_VIEW_CACHE_ERROR);
    printf("CACHE_NODE_RADII %g\n", (double)PICVR_CACHE_NODE_RADII);
    printf("EVENT_WORDS %u\nEVENT_GROUP %u\n", PICVR_EVENT_WORDS, PICVR_EVENT_GROUP);
    return 0;
}
