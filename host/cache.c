/* host/cache.c - the irradiance cache's host side, paper §4-5: its configuration
 * (Table 1 defaults), the pools of entries, octree nodes, references and creation
 * requests (allocated only when the cache is on), the world-space parameters of Eq. 5-11
 * in the uniform block, the pre-built top of the octree (§4.4), the creation batch, and
 * the counters each round leaves; what the configuration turns on (the blend, the
 * multiply scattered cache, the lookup's event) and the creation kernel's loop budgets
 * it implies on the device.  The cache procedures themselves are
 * shaders/cache_create.comp (§4.2), cache_update.comp (§4.3) and cache_rebuild.comp
 * (§4.4).  Part of picvr_vk.c; uses util, vulkan, schedule. */

/* Fills in the Table 1 defaults and validates. */
static picvr_status picvr_resolve_cache_config(const picvr_cache_config *in, picvr_cache_config *c) {
    *c = *in;
    if ((unsigned)c->mode > PICVR_CACHE_AUTO) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->mode == PICVR_CACHE_DEFAULT) c->mode = PICVR_CACHE_NONE;   /* picvr.h: plain until the cache pays */
    if (!c->superpixel_size) c->superpixel_size = 32;
    if (c->superpixel_size > 4096) return PICVR_ERROR_INVALID_ARGUMENT;
    if ((unsigned)c->curvature_limit > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->curvature_limit == PICVR_SWITCH_DEFAULT) c->curvature_limit = PICVR_SWITCH_OFF;
    if ((unsigned)c->medium_model > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->medium_model == PICVR_SWITCH_DEFAULT) c->medium_model = PICVR_SWITCH_ON;
    if ((unsigned)c->blend > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->blend == PICVR_SWITCH_DEFAULT) c->blend = PICVR_SWITCH_ON;
    /* the automatic mode leaves the cache's bias to the blend (host/schedule.c) */
    if (c->mode == PICVR_CACHE_AUTO && c->blend == PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    float *f[8] = {&c->gamma, &c->epsilon, &c->delta_voxels, &c->radius_min_voxels, &c->radius_max_voxels,
                   &c->update_threshold, &c->rebuild_interval_ms, &c->probe_fraction};
    const float def[8] = {0.1f, 0.1f, 2.0f, 0.01f, 16.0f, 0.1f, 1000.0f, PICVR_CACHE_DEFAULT_PROBE};
    picvr_status s = picvr_resolve_floats(f, def, 8);
    if (s) return s;
    if (c->epsilon >= 1.0f || c->radius_max_voxels < c->radius_min_voxels || c->probe_fraction > 1.0f)
        return PICVR_ERROR_INVALID_ARGUMENT;
    if (!c->max_entries) c->max_entries = 65536;
    if (c->max_entries > (1u << 24)) return PICVR_ERROR_SIZE_OVERFLOW;   /* indices pass through floats */
    /* at least 8192 nodes: the pre-built top of the octree takes up to 4681 */
    if (!c->max_nodes) c->max_nodes = 8 * c->max_entries > 8192 ? 8 * c->max_entries : 8192;
    if (!c->max_refs) c->max_refs = 16 * c->max_entries;
    if (!c->max_requests) c->max_requests = 1000;
    if (!c->max_samples) c->max_samples = PICVR_CACHE_DEFAULT_SAMPLES;
    if (c->max_samples > PICVR_CACHE_MAX_SAMPLES) return PICVR_ERROR_INVALID_ARGUMENT;
    c->max_samples = (c->max_samples + PICVR_CACHE_CREATE_GROUP - 1) / PICVR_CACHE_CREATE_GROUP * PICVR_CACHE_CREATE_GROUP;
    if (!c->max_lookup_refs) c->max_lookup_refs = PICVR_CACHE_MAX_LOOKUP_REFS;
    if (c->max_lookup_refs > PICVR_CACHE_MAX_LOOKUP_REFS) return PICVR_ERROR_INVALID_ARGUMENT;
    if (!c->lookup_event) c->lookup_event = 1;
    if (c->lookup_event > PICVR_CACHE_MAX_LOOKUP_EVENT) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->max_nodes < 4681 || c->max_refs < 2 || c->max_nodes > (1u << 28) || c->max_refs > (1u << 28))
        return PICVR_ERROR_INVALID_ARGUMENT;
    return PICVR_OK;
}

/* The resolved configuration against the device, before anything is made for it: on a
   CPU device cache.max_samples is at most PICVR_CACHE_MAX_SAMPLES_CPU (llvmpipe's loop
   bound, docs/lavapipe.md). */
static picvr_status picvr_check_cache_device(picvr_context *ctx) {
    if (!ctx->cache.on || !picvr_on_cpu_device(ctx) || ctx->cache.cfg.max_samples <= PICVR_CACHE_MAX_SAMPLES_CPU)
        return PICVR_OK;
    picvr_log_message(ctx, PICVR_LOG_ERROR, "cache.max_samples %u: at most %u on a CPU device (loop bound)",
                      ctx->cache.cfg.max_samples, PICVR_CACHE_MAX_SAMPLES_CPU);
    return PICVR_ERROR_INVALID_ARGUMENT;
}

/* The consistent blend of cached and plain shading (shaders/cache_blend.glsl). */
static int picvr_blend_on(const picvr_context *ctx) {
    return ctx->cache.on && ctx->cache.cfg.blend == PICVR_SWITCH_ON;
}

/* Whether the cache holds the multiply scattered light: with bounces (a fluence: any
   phase function); without, it holds the single-scattered light (picvr_cache_serves in
   host/pipelines.c says when that serves). */
static int picvr_cache_multiple(const picvr_context *ctx) {
    return ctx->cache.on && ctx->scene.scattering.max_bounces > 0;
}

/* The scatter event at which a camera path takes the cache (LOOKUP_EVENT): cache.lookup_event
   for the multiply scattered cache with unlimited bounces, else 1 (with a bounce limit an
   entry holds the light of more events than a later event may still have). */
/* LOOKUP_EVENT - 1 takes 3 bits of the variant key (a compile-time check that C and C++
   both accept: the array's size is negative if it fails). */
typedef char picvr_lookup_event_fits_key[PICVR_CACHE_MAX_LOOKUP_EVENT - 1u <= 7u ? 1 : -1];
static uint32_t picvr_lookup_event(const picvr_context *ctx) {
    return picvr_cache_multiple(ctx) && ctx->scene.scattering.max_bounces == PICVR_BOUNCES_UNLIMITED
           ? ctx->cache.cfg.lookup_event : 1u;
}

/* Creation's rounds per point (CREATE_MAX_ROUNDS): cache.max_samples / 128, and with the
   multiply scattered cache on a CPU device at most PICVR_CACHE_MS_ROUNDS_CPU. */
static uint32_t picvr_create_rounds(const picvr_context *ctx) {
    uint32_t rounds = ctx->cache.cfg.max_samples / PICVR_CACHE_CREATE_GROUP;
    if (picvr_cache_multiple(ctx) && picvr_on_cpu_device(ctx) && rounds > PICVR_CACHE_MS_ROUNDS_CPU)
        rounds = PICVR_CACHE_MS_ROUNDS_CPU;
    return rounds;
}

/* The loop iterations one multiply scattered creation sample may take
   (CREATE_SAMPLE_STEPS, shaders/cache_create.comp).  On a CPU device an invocation's
   PICVR_CACHE_MS_LANE_SAMPLES * rounds samples share llvmpipe's 65535 less 1000 for the
   rest of the kernel: a sample of S takes at most S/2 tracking steps (each scatter event
   charged vertex_cost >= 64 of them), ray marching's order loops (at most 2 * 16 per
   event, so S/4), S/4 ray-marching steps and a lookup of S/8 references (two iterations
   each) plus its two passes over at most 64 candidates, their predictions and the levels
   (at most 400), so 5S/4 + 400 in all.  A GPU has no such cap. */
static uint32_t picvr_create_sample_steps(const picvr_context *ctx) {
    if (!picvr_on_cpu_device(ctx)) return PICVR_PATH_STEPS;
    uint32_t samples = PICVR_CACHE_MS_LANE_SAMPLES * picvr_create_rounds(ctx);
    return (65535u - 1000u - 400u * samples) * 4u / (5u * samples);
}

/* The entries' first moments (binding 22) as a cache with max_bounces needs them: one per
   entry with bounces (the multiply scattered cache), a placeholder without, which no
   kernel then reads.  Rule: on failure the old buffer stays, so the caller can refuse
   the change and leave the context as it was. */
static picvr_status picvr_cache_fit_moments(picvr_context *ctx, uint32_t max_bounces) {
    if (!ctx->cache.on) return PICVR_OK;
    uint64_t want = max_bounces > 0 ? (uint64_t)ctx->cache.cfg.max_entries * PICVR_CACHE_MOMENT_BYTES
                                    : PICVR_PLACEHOLDER_BYTES;
    if (ctx->cache.moments.buf && ctx->cache.moments.size == want) return PICVR_OK;
    if (want > ctx->vk.props.limits.maxStorageBufferRange) return PICVR_ERROR_SIZE_OVERFLOW;
    picvr_buffer b;
    picvr_status s = picvr_buffer_create(ctx, &b, want, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, 0);
    if (s) return s;
    picvr_buffer_destroy(ctx, &ctx->cache.moments);
    ctx->cache.moments = b;
    ctx->pipes.descriptors_dirty = 1;
    return PICVR_OK;
}

static picvr_status picvr_create_cache_buffers(picvr_context *ctx) {
    const picvr_cache_config *c = &ctx->cache.cfg;
    VkBufferUsageFlags st = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    uint64_t sizes[3] = {(uint64_t)c->max_entries * PICVR_CACHE_ENTRY_BYTES, (uint64_t)c->max_nodes * PICVR_CACHE_NODE_BYTES,
                         (uint64_t)c->max_refs * PICVR_CACHE_REF_BYTES};
    for (int i = 0; i < 3; i++)
        if (sizes[i] > ctx->vk.props.limits.maxStorageBufferRange) return PICVR_ERROR_SIZE_OVERFLOW;
    picvr_status s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.entries, sizes[0], st, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.nodes, sizes[1], st, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.refs, sizes[2], st, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.counters, sizeof(picvr_cache_counters),
                           st | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.requests, (uint64_t)c->max_requests * PICVR_CACHE_REQUEST_BYTES, st, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.prebuilt_nodes, 4681u * PICVR_CACHE_NODE_BYTES,
                           VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0))) return s;
    return picvr_cache_fit_moments(ctx, ctx->scene.scattering.max_bounces);
}

/* Entry creation runs one workgroup per entry, and a round's procedures are separated by
   barriers, so a creation dispatch lasts about as long as its slowest entry whenever it
   holds fewer entries than the device runs side by side: a partial dispatch costs what a
   full one does.  So creation waits until it is owed a full batch, and its cost per
   entry is measured as if every dispatch were full (picvr_finish_round).
   - A CPU driver (lavapipe) runs one workgroup per thread, one thread per core: with one
     entry per dispatch most of the creation share would be idle cores.  The batch is one
     entry per thread (LP_NUM_THREADS, lavapipe's own setting, else the online cores; at
     most 64).
   - A GPU runs thousands of workgroups at once, and one entry takes milliseconds of
     sequential sampling: small dispatches would leave it idle and teach the cost model a
     per-entry cost far below the truth (docs/gpu.md).  The batch is the resident
     workgroups (picvr_gpu_resident_groups), at most the request queue
     (cache.max_requests). */
static uint32_t picvr_creation_batch(const picvr_context *ctx) {
    uint32_t gpu = picvr_gpu_resident_groups(ctx);
    if (gpu) return gpu < ctx->cache.cfg.max_requests ? gpu : ctx->cache.cfg.max_requests;
    long n = 0;
    const char *env = getenv("LP_NUM_THREADS");
    if (env && *env) n = strtol(env, NULL, 10);
    if (n <= 0) n = picvr_processors_online();
    return n < 1 ? 1u : n > 64 ? 64u : (uint32_t)n;
}

/* World-space cache parameters (Delta and the radii are given in voxels of the
   smallest spacing) and the depth of the pre-built top of the octree: the depth at
   which an entry of the largest radius is inserted (same rule as the shader's
   insertion_depth), at most CACHE_PREBUILT_MAX_DEPTH.  Pre-building it lets many
   entries be created in parallel from the start under object-space locking. */
static uint32_t picvr_cache_scene_params(picvr_context *ctx) {
    picvr_gpu_scene *g = &ctx->scene.gpu;
    const picvr_cache_config *c = &ctx->cache.cfg;
    float voxel = ctx->scene.has_volume ? g->min_spacing : 1.0f;
    g->gamma = c->gamma;
    g->epsilon = c->epsilon;
    g->delta = c->delta_voxels * voxel;
    g->update_threshold = c->update_threshold;
    g->radius_min = c->radius_min_voxels * voxel;
    g->radius_max = c->radius_max_voxels * voxel;
    g->curvature_limit = c->curvature_limit == PICVR_SWITCH_ON;
    g->medium_model = c->medium_model == PICVR_SWITCH_ON;
    g->max_entries = c->max_entries;
    g->max_nodes = c->max_nodes;
    g->max_refs = c->max_refs;
    g->max_requests = c->max_requests;
    g->probe_fraction = c->blend == PICVR_SWITCH_ON ? c->probe_fraction : 0.0f;
    if (ctx->scene.has_camera) {
        uint32_t side = ctx->cache.cfg.superpixel_size;
        g->superpixel_side = side;
        g->superpixels_per_row = (ctx->scene.camera.width + side - 1) / side;
        g->superpixel_count = ctx->cache.superpixel_count;
    }
    float edge = g->box_size[0];
    if (g->box_size[1] < edge) edge = g->box_size[1];
    if (g->box_size[2] < edge) edge = g->box_size[2];
    uint32_t depth = 0;
    while (depth < PICVR_CACHE_PREBUILT_MAX_DEPTH && edge * 0.5f >= PICVR_CACHE_NODE_RADII * g->radius_max) { edge *= 0.5f; depth++; }
    return depth;
}

/* Empties the cache: a complete octree down to the pre-built depth (node i's children
   are 8i+1 .. 8i+8), no entries, no references, no requests, unlocked nodes. */
static picvr_status picvr_cache_clear(picvr_context *ctx) {
    if (!ctx->cache.on) return PICVR_OK;
    uint32_t depth = picvr_cache_scene_params(ctx);
    uint32_t count = 0, level = 1;
    for (uint32_t d = 0; d <= depth; d++, level *= 8) count += level;
    uint32_t inner = count - level / 8;            /* nodes above the deepest level */
    uint32_t *nodes = (uint32_t *)picvr_host_alloc(&ctx->config.allocator, (size_t)count * PICVR_CACHE_NODE_BYTES);
    if (!nodes) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    memset(nodes, 0, (size_t)count * PICVR_CACHE_NODE_BYTES);
    for (uint32_t i = 0; i < inner; i++) nodes[i * 4] = 8 * i + 1;
    picvr_status s = picvr_cmd_begin(ctx);
    if (!s) {
        picvr_barrier_all(ctx);
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.nodes.buf, 0, VK_WHOLE_SIZE, 0);
        if (ctx->cache.superpixels.buf) vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.superpixels.buf, 0, VK_WHOLE_SIZE, 0);
        picvr_barrier_all(ctx);
        s = picvr_cmd_submit_wait(ctx);
    }
    if (!s) s = picvr_upload_buffer(ctx, &ctx->cache.nodes, nodes, (size_t)count * PICVR_CACHE_NODE_BYTES);
    if (!s) s = picvr_upload_buffer(ctx, &ctx->cache.prebuilt_nodes, nodes, (size_t)count * PICVR_CACHE_NODE_BYTES);
    picvr_host_free(&ctx->config.allocator, nodes);
    picvr_cache_counters counters;
    memset(&counters, 0, sizeof counters);
    counters.dispatch[1] = counters.dispatch[2] = 1;
    counters.node_count = count;
    if (!s) s = picvr_upload_buffer(ctx, &ctx->cache.counters, &counters, sizeof counters);
    ctx->cache.prebuilt = count;
    ctx->cache.counts = counters;
    ctx->cache.point_rounds = ctx->cache.truncated = ctx->cache.lookups_cut = ctx->cache.lookups_spilled = 0;
    ctx->cache.requests_pending = 0;
    ctx->cache.refine_cursor = 0;
    ctx->cache.since_rebuild_ms = 0.0;
    picvr_sched_forget_hits(&ctx->sched, ctx->cache.on);
    return s;
}

/* The entries complete before the next round (the host's last count, within the pool):
   those creation may look up and refinement may take (cache_create.comp). */
static uint32_t picvr_cache_trusted(const picvr_context *ctx) {
    uint32_t n = ctx->cache.counts.entry_count, cap = ctx->cache.cfg.max_entries;
    return n < cap ? n : cap;
}

/* The cache counters a round left: the 64-bit sums of the wrapping ones, the requests. */
static void picvr_cache_take_counters(picvr_context *ctx, const picvr_cache_counters *got) {
    /* one round adds far less than 2^32, so the difference modulo 2^32 is exact */
    const picvr_cache_counters *old = &ctx->cache.counts;
    ctx->cache.point_rounds += (uint32_t)(got->point_rounds - old->point_rounds);
    ctx->cache.truncated += (uint32_t)(got->truncated - old->truncated);
    ctx->cache.lookups_cut += (uint32_t)(got->lookups_cut - old->lookups_cut);
    ctx->cache.lookups_spilled += (uint32_t)(got->lookups_spilled - old->lookups_spilled);
    ctx->cache.counts = *got;
    ctx->cache.requests_issued += got->requests;
    ctx->cache.requests_pending = got->dispatch[0];   /* valid requests queued for the next round */
}

/* The cache's pools (zeroed buffers when the cache is off: no-ops). */
static void picvr_cache_destroy(picvr_context *ctx) {
    picvr_buffer *b[] = {&ctx->cache.entries, &ctx->cache.nodes, &ctx->cache.refs, &ctx->cache.counters,
                         &ctx->cache.requests, &ctx->cache.prebuilt_nodes, &ctx->cache.superpixels,
                         &ctx->cache.moments};
    for (size_t i = 0; i < sizeof b / sizeof b[0]; i++) picvr_buffer_destroy(ctx, b[i]);
}
