/* host/rounds.c - one round, paper §6-7: a single submission that runs the three
 * procedures in turn, separated by barriers (they share the cache pools):
 *   creation (indirect: one workgroup per request the previous round queued, `budget`
 *   of them create entries, the rest only unlock) -> [octree rebuild, when due] ->
 *   update (N_u blocks) -> rendering (block_priority, Eq. 12, and block_select fill the
 *   queue, an indirect dispatch renders it; repeated while the round wants more blocks
 *   than the image has) -> counters copied for the host.
 * Device timestamps around the procedures give each one's device time, which the
 * scheduler (host/schedule.c) turns into the next round's shares.  Part of picvr_vk.c;
 * uses util, vulkan, schedule, pipelines, cache, image. */

/* Whether round p runs the cache procedures and the lookup: the cache is on and the
   round is not one of PICVR_CACHE_AUTO's plain rounds. */
static int picvr_round_cached(const picvr_context *ctx, const picvr_round_plan *p) {
    return ctx->cache.on && !p->plain;
}

static picvr_status picvr_create_timestamps(picvr_context *ctx) {
    uint32_t n = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(ctx->vk.phys, &n, NULL);
    VkQueueFamilyProperties fam[16];
    if (n > 16) n = 16;
    vkGetPhysicalDeviceQueueFamilyProperties(ctx->vk.phys, &n, fam);
    uint32_t bits = ctx->vk.queue_family < n ? fam[ctx->vk.queue_family].timestampValidBits : 0;
    if (bits == 0 || ctx->vk.props.limits.timestampPeriod <= 0.0f) {
        picvr_log_message(ctx, PICVR_LOG_INFO, "no device timestamps: procedure times are estimated from wall time");
        return PICVR_OK;
    }
    ctx->rounds.timestamp_ns = ctx->vk.props.limits.timestampPeriod;
    ctx->rounds.timestamp_mask = bits >= 64 ? UINT64_MAX : ((uint64_t)1 << bits) - 1;
    VkQueryPoolCreateInfo qi;
    PICVR_VK_INIT(qi, VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO);
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = PICVR_ROUND_TIMESTAMPS;
    PICVR_VK_TRY(ctx, vkCreateQueryPool(ctx->vk.device, &qi, NULL, &ctx->rounds.timestamps));
    return PICVR_OK;
}

static void picvr_write_timestamp(picvr_context *ctx, uint32_t i) {
    if (ctx->rounds.timestamps) vkCmdWriteTimestamp(ctx->vk.cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, ctx->rounds.timestamps, i);
}

static void picvr_push_constants(picvr_context *ctx, uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
    uint32_t push[4] = {a, b, c, d};
    vkCmdPushConstants(ctx->vk.cmd, ctx->pipes.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, push);
}

/* Entries this round's creation may add: one per workgroup of its indirect dispatch,
   which holds the requests the previous round queued (read back), within the budget. */
static uint32_t picvr_round_creations(const picvr_context *ctx, const picvr_round_plan *p) {
    if (!picvr_round_cached(ctx, p)) return 0;
    return p->create_budget < ctx->cache.requests_pending ? p->create_budget : ctx->cache.requests_pending;
}

/* The octree rebuild (§4.4): empty node and reference pools (the pre-built top copied
   back), then cache_rebuild.comp re-inserts every entry with its current, possibly
   shrunk, radii, so references that shrunk entries no longer need disappear.  Recorded
   after the creation procedure, when no request holds a node lock.  So the dispatch
   must cover the entries this round's creation adds (`created`, picvr_round_creations) as
   well as those the host read back: sized by the host's count alone, an entry past it
   lost every reference until the next rebuild (seen as 126 references for 127
   entries).  The shader skips threads past the device's count. */
static void picvr_record_rebuild(picvr_context *ctx, uint32_t created) {
    uint64_t upper = (uint64_t)ctx->cache.counts.entry_count + created;
    uint32_t entries = upper < ctx->cache.cfg.max_entries ? (uint32_t)upper : ctx->cache.cfg.max_entries;
    vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.nodes.buf, 0, VK_WHOLE_SIZE, 0);
    picvr_barrier_all(ctx);
    VkBufferCopy region = {0, 0, (VkDeviceSize)ctx->cache.prebuilt * 16};
    vkCmdCopyBuffer(ctx->vk.cmd, ctx->cache.prebuilt_nodes.buf, ctx->cache.nodes.buf, 1, &region);
    uint32_t counts[2] = {ctx->cache.prebuilt, 0};                  /* node_count, ref_count */
    vkCmdUpdateBuffer(ctx->vk.cmd, ctx->cache.counters.buf, offsetof(picvr_cache_counters, node_count), sizeof counts, counts);
    picvr_barrier_all(ctx);
    if (entries > 0) {
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.rebuild_pipe);
        vkCmdDispatch(ctx->vk.cmd, (entries + 63) / 64, 1, 1);
        picvr_barrier_all(ctx);
    }
}

/* Empties the event queues for the next dispatch of the rendering procedure; the
   barrier after block_select (picvr_record_render) orders it before the kernels. */
static void picvr_record_empty_queues(picvr_context *ctx, int cached) {
    static const uint32_t empty_head[4] = {0, 1, 1, 0};   /* dispatch (x, 1, 1), count */
    vkCmdUpdateBuffer(ctx->vk.cmd, ctx->image.shade_queue.buf, 0, sizeof empty_head, empty_head);
    if (cached) vkCmdUpdateBuffer(ctx->vk.cmd, ctx->image.lookup_queue.buf, 0, sizeof empty_head, empty_head);
}

/* One dispatch of the rendering procedure over the queued blocks: tracking, then with
   the cache the lookup, then shading, each event kernel as many workgroups as the kernel
   before it queued events for (shaders/render.glsl).  Without a debug view the lookup
   queues its misses for shading; with one it shades them itself and the shading
   dispatch has no workgroups. */
static void picvr_record_render_kernels(picvr_context *ctx, const picvr_round_plan *p, int first) {
    int plain = p->plain, forced = (p->render_flags & PICVR_ROUND_FORCED) != 0;
    picvr_push_constants(ctx, ctx->rounds.count, ctx->config.seed, p->request_cap, p->render_flags);
    float spread_scale = ctx->sched.dauto.scale;   /* render.glsl's fifth word */
    vkCmdPushConstants(ctx->vk.cmd, ctx->pipes.layout, VK_SHADER_STAGE_COMPUTE_BIT, 16, sizeof spread_scale, &spread_scale);
    if (first) picvr_write_timestamp(ctx, 5);
    vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_kernel(ctx, PICVR_PROC_RENDER, PICVR_KERNEL_MAIN, plain, forced));
    vkCmdDispatchIndirect(ctx->vk.cmd, ctx->image.render_queue.buf, 0);
    picvr_barrier_all(ctx);
    if (first) picvr_write_timestamp(ctx, 6);
    if (picvr_round_cached(ctx, p)) {
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_kernel(ctx, PICVR_PROC_RENDER, PICVR_KERNEL_LOOKUP, 0, 0));
        vkCmdDispatchIndirect(ctx->vk.cmd, ctx->image.lookup_queue.buf, 0);
        picvr_barrier_all(ctx);
    }
    if (first) picvr_write_timestamp(ctx, 7);
    vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_kernel(ctx, PICVR_PROC_RENDER, PICVR_KERNEL_SHADE, plain, forced));
    vkCmdDispatchIndirect(ctx->vk.cmd, ctx->image.shade_queue.buf, 0);
    picvr_barrier_all(ctx);
    if (first) picvr_write_timestamp(ctx, 8);
}

/* Keeps count of the first pass since the reset: round-robin dispatches from cursor 0
   add their blocks until every block had one; a priority dispatch before that leaves
   the coverage unknown (host/step.c then starts the pass again). */
static void picvr_note_first_pass(picvr_context *ctx, int prio, uint32_t blocks) {
    picvr_image_state *im = &ctx->image;
    if (prio) {
        im->priority_used = 1;
        return;
    }
    if (im->priority_used || im->first_pass_blocks >= im->block_total) return;
    uint32_t left = im->block_total - im->first_pass_blocks;
    im->first_pass_blocks += blocks < left ? blocks : left;
}

/* The rendering procedure for `blocks` blocks: dispatches of at most one image's worth
   (a block must not be rendered twice by one dispatch), each fed by block_select. */
static void picvr_record_render(picvr_context *ctx, const picvr_round_plan *p) {
    uint32_t B = ctx->image.block_total, cap = B < PICVR_MAX_QUEUE ? B : PICVR_MAX_QUEUE;
    int prio = ctx->sched.use_priorities && !p->whole_passes;
    for (uint32_t left = p->render_blocks; left > 0;) {
        uint32_t want = left < cap ? left : cap;
        if (prio) {
            vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.priority_pipe);
            picvr_push_constants(ctx, ctx->scene.camera.width, ctx->scene.camera.height, 0, 0);
            vkCmdDispatch(ctx->vk.cmd, (B + 63) / 64, 1, 1);
            picvr_barrier_all(ctx);
        }
        picvr_record_empty_queues(ctx, picvr_round_cached(ctx, p));
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.select_pipe);
        uint32_t base = (uint32_t)((uint64_t)ctx->image.block_cursor * ctx->image.block_stride % B);
        picvr_push_constants(ctx, want, B, prio ? ctx->image.block_cursor : base, prio ? 0 : ctx->image.block_stride);
        vkCmdDispatch(ctx->vk.cmd, 1, 1, 1);
        picvr_barrier_all(ctx);
        picvr_record_render_kernels(ctx, p, left == p->render_blocks);
        picvr_note_first_pass(ctx, prio, want);
        ctx->image.block_cursor = (uint32_t)(((uint64_t)ctx->image.block_cursor + want) % B);
        left -= want;
    }
}

/* Marks, per procedure, whether this round runs a pipeline variant for the first time
   (picvr_finish_round then keeps its time out of the cost model and the credit).  Creation
   runs when the last round queued requests: its indirect dispatch has one workgroup
   per request. */
static void picvr_note_dispatches(picvr_context *ctx, const picvr_round_plan *p) {
    int cached = picvr_round_cached(ctx, p);
    int runs[3] = {cached && (ctx->cache.requests_pending > 0 || p->refine_groups > 0), cached && p->update_groups > 0,
                   p->render_blocks > 0};
    for (int i = 0; i < 3; i++) {
        if (!runs[i]) {
            ctx->sched.first_dispatch[i] = 0;
            continue;
        }
        picvr_variant_slot *v =
            &ctx->pipes.variants[i][picvr_current_slot(ctx, i, p->plain, (p->render_flags & PICVR_ROUND_FORCED) != 0)];
        ctx->sched.first_dispatch[i] = !v->dispatched;
        v->dispatched = 1;
    }
}

static void picvr_record_round(picvr_context *ctx, const picvr_round_plan *p, uint32_t created) {
    int cached = picvr_round_cached(ctx, p);
    picvr_note_dispatches(ctx, p);
    picvr_barrier_all(ctx);
    if (ctx->rounds.timestamps) vkCmdResetQueryPool(ctx->vk.cmd, ctx->rounds.timestamps, 0, PICVR_ROUND_TIMESTAMPS);
    vkCmdBindDescriptorSets(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.layout, 0, 1, &ctx->pipes.set, 0, NULL);
    picvr_write_timestamp(ctx, 0);
    if (cached) {
        /* creation: one workgroup per request queued by the previous round */
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_pipeline(ctx, PICVR_PROC_CREATE));
        /* the entries complete before this round, for creation's own lookups */
        uint32_t trusted = picvr_cache_trusted(ctx);
        /* the budget below PICVR_REFINE_FLAG (requests never reach it) */
        uint32_t budget = p->create_budget < PICVR_REFINE_FLAG ? p->create_budget : PICVR_REFINE_FLAG - 1;
        picvr_push_constants(ctx, ctx->rounds.count, ctx->config.seed, budget, trusted);
        vkCmdDispatchIndirect(ctx->vk.cmd, ctx->cache.counters.buf, 0);
        picvr_barrier_all(ctx);
        if (p->refine_groups > 0) {
            /* refinement (multiply scattered cache): entries cursor.. of the trusted ones,
               after creation so that no workgroup inserts while it looks up */
            uint32_t first = ctx->cache.refine_cursor % trusted;
            picvr_push_constants(ctx, ctx->rounds.count, ctx->config.seed, PICVR_REFINE_FLAG | first, trusted);
            vkCmdDispatch(ctx->vk.cmd, p->refine_groups, 1, 1);
            picvr_barrier_all(ctx);
            ctx->cache.refine_cursor = (uint32_t)(((uint64_t)first + p->refine_groups) % trusted);
        }
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.counters.buf, offsetof(picvr_cache_counters, dispatch), 4, 0);
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.counters.buf, offsetof(picvr_cache_counters, request_count), 4, 0);
        picvr_barrier_all(ctx);
    }
    picvr_write_timestamp(ctx, 1);
    if (cached && p->rebuild) picvr_record_rebuild(ctx, created);
    picvr_write_timestamp(ctx, 2);
    if (cached && p->update_groups > 0) {
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_pipeline(ctx, PICVR_PROC_UPDATE));
        picvr_push_constants(ctx, ctx->rounds.count, ctx->config.seed, 0, 0);
        vkCmdDispatch(ctx->vk.cmd, p->update_groups, 1, 1);
        picvr_barrier_all(ctx);
    }
    picvr_write_timestamp(ctx, 3);
    picvr_record_render(ctx, p);
    picvr_write_timestamp(ctx, 4);
    if (cached && ctx->cache.cfg.mode == PICVR_CACHE_SCREEN_SPACE) {
        /* superpixel counters: the set this round read is the one the next round writes */
        VkDeviceSize n = ctx->cache.superpixel_count, set = (ctx->rounds.count + 1) & 1;
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.superpixels.buf, (n + 2 * n * set) * 4, 2 * n * 4, 0);
    }
    /* small counters for the host: the cache counters, then the blocks rendered */
    if (ctx->cache.on) {
        VkBufferCopy c = {0, 0, sizeof(picvr_cache_counters)};
        vkCmdCopyBuffer(ctx->vk.cmd, ctx->cache.counters.buf, ctx->rounds.readback.buf, 1, &c);
    }
    /* render_queue.totals: x blocks rendered, y and z the scatter events (64 bits), w the
       samples measured; then render_queue.spread (PICVR_DISTANCE_AUTO) */
    VkBufferCopy q = {16, sizeof(picvr_cache_counters), 32};
    vkCmdCopyBuffer(ctx->vk.cmd, ctx->image.render_queue.buf, ctx->rounds.readback.buf, 1, &q);
    picvr_barrier_all(ctx);
    if (ctx->cache.on) {   /* hits, misses, requests; routed, probes, gain */
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.counters.buf, offsetof(picvr_cache_counters, hits), 3 * 4, 0);
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.counters.buf, offsetof(picvr_cache_counters, routed), 4 * 4, 0);
    }
    vkCmdFillBuffer(ctx->vk.cmd, ctx->image.render_queue.buf, 16, 32, 0);
    picvr_barrier_all(ctx);
}

/* The rendering kernels' device time per block in the round's first rendering dispatch
   (k: the intervals between timestamps 5-8), into ctx->rounds.kernel_ms of the round's
   kind.  Rule: a round that compiled its rendering variant (first dispatch) is left out. */
static void picvr_note_kernel_times(picvr_context *ctx, const picvr_round_plan *p, const double k[3]) {
    uint32_t cap = ctx->image.block_total < PICVR_MAX_QUEUE ? ctx->image.block_total : PICVR_MAX_QUEUE;
    uint32_t blocks = p->render_blocks < cap ? p->render_blocks : cap;
    if (blocks == 0 || ctx->sched.first_dispatch[PICVR_PROC_RENDER]) return;
    double *out = ctx->rounds.kernel_ms[picvr_round_cached(ctx, p)];
    for (int i = 0; i < 3; i++) out[i] = picvr_moving_average(out[i], k[i] / blocks);
}

/* The device time of each procedure in the round just finished (dev[PROC_*]) and the
   octree rebuild's part of it, from the round's timestamps; packages: creation's (entries
   made and refined), for the split without timestamps. */
static picvr_status picvr_round_device_ms(picvr_context *ctx, const picvr_round_plan *p, double wall_ms,
                                          uint32_t packages, uint32_t blocks, double dev[3], double *rebuild_ms,
                                          int note_kernels) {
    dev[0] = dev[1] = dev[2] = 0.0;
    *rebuild_ms = 0.0;
    if (!ctx->rounds.timestamps) {
        /* Rule without timestamps: split the wall time by the planned costs. */
        const double *cost = ctx->sched.cost;
        double plan[3] = {packages * cost[PICVR_PROC_CREATE], p->update_groups * cost[PICVR_PROC_UPDATE],
                          blocks * cost[PICVR_PROC_RENDER]};
        double sum = plan[0] + plan[1] + plan[2];
        for (int i = 0; i < 3; i++) dev[i] = sum > 0.0 ? wall_ms * plan[i] / sum : (i == PICVR_PROC_RENDER ? wall_ms : 0.0);
        return PICVR_OK;
    }
    uint64_t t[PICVR_ROUND_TIMESTAMPS];
    PICVR_VK_TRY(ctx, vkGetQueryPoolResults(ctx->vk.device, ctx->rounds.timestamps, 0, PICVR_ROUND_TIMESTAMPS, sizeof t,
                                            t, sizeof t[0], VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    double ms[PICVR_ROUND_TIMESTAMPS - 1];
    for (uint32_t i = 0; i + 1 < PICVR_ROUND_TIMESTAMPS; i++)
        ms[i] = (double)((t[i + 1] - t[i]) & ctx->rounds.timestamp_mask) * ctx->rounds.timestamp_ns * 1e-6;
    if (note_kernels) picvr_note_kernel_times(ctx, p, ms + 5);
    dev[PICVR_PROC_CREATE] = ms[0];
    *rebuild_ms = ms[1];
    dev[PICVR_PROC_UPDATE] = ms[1] + ms[2];          /* octree maintenance counts as update */
    dev[PICVR_PROC_RENDER] = ms[3];
    /* Rule: without the cache (or in a plain round) the round is all rendering (the
       empty intervals hold only barriers). */
    if (!picvr_round_cached(ctx, p)) {
        dev[PICVR_PROC_RENDER] += dev[PICVR_PROC_CREATE] + dev[PICVR_PROC_UPDATE];
        dev[PICVR_PROC_CREATE] = dev[PICVR_PROC_UPDATE] = 0.0;
    }
    return PICVR_OK;
}

/* Reads back a finished round: device time per procedure, work done, cache counters;
   the scheduler accounts for it (cost model, history, hit rate, targets). */
static picvr_status picvr_finish_round(picvr_context *ctx, const picvr_round_plan *p, double wall_ms, uint32_t created) {
    picvr_buffer_invalidate(ctx, &ctx->rounds.readback);
    const uint8_t *rb = (const uint8_t *)ctx->rounds.readback.mapped;   /* counters, then blocks */
    uint32_t blocks, events[2], hits = 0, misses = 0, measured, spread[4];
    memcpy(&blocks, rb + sizeof(picvr_cache_counters), sizeof blocks);
    memcpy(events, rb + sizeof(picvr_cache_counters) + 4, sizeof events);
    memcpy(&measured, rb + sizeof(picvr_cache_counters) + 12, sizeof measured);
    memcpy(spread, rb + sizeof(picvr_cache_counters) + 16, sizeof spread);
    double dev[3], rebuild_ms;
    uint32_t packages = created + p->refine_groups;   /* creation's: entries made and refined */
    if (wall_ms < 0.0) {
        /* Rule: a step the application ended after it had finished has no measured wall
           time; it is taken as the device time (timestamps, else the cost model) plus
           the modelled overhead, so that the cost model learns nothing false from it. */
        picvr_status s = picvr_round_device_ms(ctx, p, 0.0, packages, blocks, dev, &rebuild_ms, 0);
        if (s) return s;
        const double *cost = ctx->sched.cost;
        double planned = packages * cost[PICVR_PROC_CREATE] + p->update_groups * cost[PICVR_PROC_UPDATE] +
                         blocks * cost[PICVR_PROC_RENDER];
        wall_ms = (ctx->rounds.timestamps ? dev[0] + dev[1] + dev[2] : planned) + ctx->sched.overhead_ms;
    }
    picvr_status s = picvr_round_device_ms(ctx, p, wall_ms, packages, blocks, dev, &rebuild_ms, 1);
    if (s) return s;
    picvr_sched_account(&ctx->sched, dev, rebuild_ms, packages, p->update_groups, blocks, wall_ms,
                        picvr_round_cached(ctx, p));
    picvr_dauto_account(&ctx->sched.dauto, p->render_flags, dev[PICVR_PROC_RENDER], blocks,
                        ctx->sched.first_dispatch[PICVR_PROC_RENDER], measured,
                        (uint64_t)spread[1] << 32 | spread[0], (uint64_t)spread[3] << 32 | spread[2]);
    if ((p->render_flags & (PICVR_ROUND_PROBE | PICVR_ROUND_KEEP)) == PICVR_ROUND_PROBE)
        blocks = 0;   /* a probe adds nothing to the image (unless it keeps its samples) */
    ctx->image.block_samples += blocks;
    if (blocks > 0) ctx->image.has_samples = 1;
    ctx->image.scatter_events += (uint64_t)events[1] << 32 | events[0];
    ctx->rounds.count++;
    ctx->image.elapsed_ms += wall_ms;
    ctx->cache.since_rebuild_ms = p->rebuild ? wall_ms : ctx->cache.since_rebuild_ms + wall_ms;
    ctx->results.valid = 0;
    if (ctx->cache.on) {   /* without the cache the round copied no counters */
        picvr_cache_counters got;
        memcpy(&got, rb, sizeof got);
        picvr_cache_take_counters(ctx, &got);
        hits = got.hits;
        misses = got.misses;
        picvr_auto_account(&ctx->sched, p->plain, dev, blocks, wall_ms, &got);
    }
    picvr_sched_record(&ctx->sched, picvr_clock_ms(), dev, hits, misses, ctx->cache.on);
    return PICVR_OK;
}

/* Records and submits a round without waiting for it (ctx->pending holds it). */
static picvr_status picvr_submit_round(picvr_context *ctx, const picvr_round_plan *p) {
    picvr_pending_step *q = &ctx->pending;
    q->plan = *p;
    q->created = picvr_round_creations(ctx, p);
    q->t0 = picvr_clock_ms();
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_record_round(ctx, p, q->created);
    return picvr_cmd_submit_with(ctx, VK_NULL_HANDLE, 0, VK_NULL_HANDLE);
}

/* Waits up to timeout_ns for the submitted round, then reads it back.  Its wall time is
   known when the caller submitted it and waited at once (blocking), or when it finished
   during the wait; not when it had finished before (then -1, see picvr_finish_round). */
static picvr_status picvr_complete_round(picvr_context *ctx, uint64_t timeout_ns, int blocking) {
    int done_before = !blocking && vkGetFenceStatus(ctx->vk.device, ctx->vk.fence) == VK_SUCCESS;
    picvr_status s = picvr_cmd_wait(ctx, timeout_ns);
    if (s) return s;
    const picvr_pending_step *q = &ctx->pending;
    return picvr_finish_round(ctx, &q->plan, done_before ? -1.0 : picvr_clock_ms() - q->t0, q->created);
}

static picvr_status picvr_run_round(picvr_context *ctx, const picvr_round_plan *p) {
    picvr_status s = picvr_submit_round(ctx, p);
    return s ? s : picvr_complete_round(ctx, UINT64_MAX, 1);
}

static void picvr_rounds_destroy(picvr_context *ctx) {
    picvr_buffer_destroy(ctx, &ctx->rounds.readback);
    if (ctx->rounds.timestamps) vkDestroyQueryPool(ctx->vk.device, ctx->rounds.timestamps, NULL);
}
