/* layout_host.c - prints the host's mirrors of the shaders' layouts and constants, one
   "NAME VALUE" per line, for tools/check_layout.sh (`make check-layout`).  It compiles
   picvr_vk.c into itself to reach the library's private definitions. */
#include "../picvr_vk.c"

int main(void)
{
    printf("Scene %zu\n", sizeof(picvr_gpu_scene));
    printf("CacheEntries %u\n", PICVR_CACHE_ENTRY_BYTES);
    printf("CacheNodes %u\n", PICVR_CACHE_NODE_BYTES);
    printf("CacheRefs %u\n", PICVR_CACHE_REF_BYTES);
    printf("CacheRequests %u\n", PICVR_CACHE_REQUEST_BYTES);
    printf("CacheCounters %u\n", (unsigned)sizeof(picvr_cache_counters));
    printf("VIEW_IMAGE %d\nVIEW_CACHE %d\nVIEW_CACHE_ERROR %d\n", (int)PICVR_VIEW_IMAGE,
           (int)PICVR_VIEW_CACHE, (int)PICVR_VIEW_CACHE_ERROR);
    printf("CACHE_NODE_RADII %g\n", (double)PICVR_CACHE_NODE_RADII);
    printf("EVENT_WORDS %u\nEVENT_GROUP %u\n", PICVR_EVENT_WORDS, PICVR_EVENT_GROUP);
    return 0;
}
