/* host/image.c - the image: the accumulation planes (running mean, Kahan terms and
 * per-pixel variance for Eq. 5), the rendering procedure's queues and the round-robin
 * order of its 16x8-pixel blocks, the depth plane of temporal reuse; resetting the
 * accumulation, the debug view.  The camera that sizes it: host/camera.c.  Part of
 * picvr_vk.c; uses util, vulkan, cache (the superpixels of §5.2 follow the image). */

static void picvr_invalidate_accumulation(picvr_context *ctx) {
    ctx->image.block_samples = 0;
    ctx->image.has_samples = 0;
    ctx->image.scatter_events = 0;
    ctx->image.block_cursor = 0;
    ctx->image.first_pass_blocks = 0;
    ctx->image.priority_used = 0;
    ctx->image.elapsed_ms = 0.0;
    ctx->results.valid = 0;
    ctx->field.view_changed = 1;   /* PICVR_RENDER_FIELD_MC shows the field again */
}

static int picvr_reuse_on(const picvr_context *ctx) { return ctx->sched.cfg.temporal_reuse == PICVR_SWITCH_ON; }

static picvr_status picvr_clear_accumulation(picvr_context *ctx) {
    picvr_invalidate_accumulation(ctx);
    if (!ctx->image.planes[0].buf) return PICVR_OK;
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_barrier_all(ctx);
    for (int i = 0; i < 3; i++) vkCmdFillBuffer(ctx->vk.cmd, ctx->image.planes[i].buf, 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(ctx->vk.cmd, ctx->image.depth.buf, 0, VK_WHOLE_SIZE, 0);
    if (ctx->image.blend.buf) vkCmdFillBuffer(ctx->vk.cmd, ctx->image.blend.buf, 0, VK_WHOLE_SIZE, 0);
    ctx->image.depth_valid = picvr_reuse_on(ctx);
    vkCmdFillBuffer(ctx->vk.cmd, ctx->image.render_queue.buf, 0, VK_WHOLE_SIZE, 0);   /* block credits */
    picvr_barrier_all(ctx);
    return picvr_cmd_submit_wait(ctx);
}

/* After a change of what the light depends on (volume, transfer function, lights,
   scattering, clipping), whose setter's own update ended with status s: the cache and the
   image are cleared, and PICVR_DISTANCE_AUTO forgets its measurements (the kinds'
   efficiency is the scene's).  Rule: after a failed update (s != 0) the measurements are
   forgotten all the same (the scene may be part changed), nothing else is cleared, and s
   is returned. */
static picvr_status picvr_light_state_changed(picvr_context *ctx, picvr_status s) {
    picvr_dauto_forget(&ctx->sched.dauto);
    ctx->field.dirty = 1;   /* rebuilt by the next field step (host/field.c) */
    if (!s) s = picvr_cache_clear(ctx);
    if (!s) s = picvr_clear_accumulation(ctx);
    return s;
}

picvr_status picvr_reset(picvr_context *ctx) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    return picvr_clear_accumulation(ctx);
}

picvr_status picvr_set_view(picvr_context *ctx, picvr_debug_view view) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if ((unsigned)view > PICVR_VIEW_CACHE_ERROR) return PICVR_ERROR_INVALID_ARGUMENT;
    if (view != PICVR_VIEW_IMAGE && !ctx->cache.on) return PICVR_ERROR_NOT_READY;
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    ctx->scene.gpu.debug_view = (uint32_t)view;
    return picvr_clear_accumulation(ctx);
}

static uint32_t picvr_gcd32(uint32_t a, uint32_t b) {
    while (b) { uint32_t t = a % b; a = b; b = t; }
    return a;
}

/* The round-robin stride over n blocks: coprime with n (so k -> k * stride mod n is a
   permutation) and near n / golden ratio (so consecutive k land far apart). */
static uint32_t picvr_spread_stride(uint32_t n) {
    if (n <= 2) return 1;
    uint32_t s = (uint32_t)(n * 0.6180339887) | 1u;
    while (picvr_gcd32(s, n) != 1) s++;
    return s % n ? s % n : 1;
}

/* The buffers of temporal reuse's reprojection (made by its first one). */
static void picvr_reuse_buffers_destroy(picvr_context *ctx) {
    for (int i = 0; i < 4; i++) picvr_buffer_destroy(ctx, &ctx->image.previous[i]);
    picvr_buffer_destroy(ctx, &ctx->image.landing);
}

/* The depth plane for the image size and the scheduler's temporal_reuse: 8 bytes per
   pixel with it, a placeholder without; the reprojection's buffers are dropped when it
   is off or the size changed (they come back at the next reprojection).  On a failure
   nothing changed.  The depth is stale afterwards (depth_valid 0) until the next reset. */
static picvr_status picvr_reuse_buffers(picvr_context *ctx, uint32_t w, uint32_t h) {
    VkDeviceSize want = picvr_reuse_on(ctx) ? (VkDeviceSize)w * h * 8 : PICVR_PLACEHOLDER_BYTES;
    if (ctx->image.previous[0].buf && (!picvr_reuse_on(ctx) || ctx->image.previous[0].size != (VkDeviceSize)w * h * 16))
        picvr_reuse_buffers_destroy(ctx);
    if (ctx->image.depth.buf && ctx->image.depth.size == want) return PICVR_OK;
    if (want > ctx->vk.props.limits.maxStorageBufferRange) return PICVR_ERROR_SIZE_OVERFLOW;
    picvr_buffer d;
    memset(&d, 0, sizeof d);
    picvr_status s = picvr_buffer_create(ctx, &d, want, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    if (s) return s;
    picvr_buffer_destroy(ctx, &ctx->image.depth);
    ctx->image.depth = d;
    ctx->image.depth_valid = 0;
    ctx->pipes.descriptors_dirty = 1;
    return PICVR_OK;
}

static picvr_status picvr_create_image_buffers(picvr_context *ctx, uint32_t w, uint32_t h) {
    VkDeviceSize pixels = (VkDeviceSize)w * h;
    VkDeviceSize plane = pixels * 16;
    if (plane > ctx->vk.props.limits.maxStorageBufferRange) {
        picvr_log_message(ctx, PICVR_LOG_WARNING, "image of %ux%u exceeds maxStorageBufferRange", w, h);
        return PICVR_ERROR_SIZE_OVERFLOW;
    }
    /* an event queue (shading; with the cache also the lookup): smaller than a plane */
    VkDeviceSize queue_bytes = PICVR_EVENT_HEAD_BYTES + pixels * PICVR_EVENT_WORDS * 4;
    if (queue_bytes > ctx->vk.props.limits.maxStorageBufferRange) {
        picvr_log_message(ctx, PICVR_LOG_WARNING, "image of %ux%u: its event queue exceeds maxStorageBufferRange", w, h);
        return PICVR_ERROR_SIZE_OVERFLOW;
    }
    VkDeviceSize groups = (pixels + 255) / 256;
    uint32_t blocks = ((w + 15) / 16) * ((h + 7) / 8);
    picvr_buffer acc[3], rb, part, queue, shade, lookup, sp, depth, blend;
    picvr_buffer *made[] = {&acc[0], &acc[1], &acc[2], &rb, &part, &queue, &shade, &lookup, &sp, &depth, &blend};
    for (size_t i = 0; i < sizeof made / sizeof made[0]; i++) memset(made[i], 0, sizeof *made[i]);
    picvr_status s = PICVR_OK;
    for (int i = 0; i < 3 && !s; i++)
        s = picvr_buffer_create(ctx, &acc[i], plane, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 0);
    if (!s) s = picvr_buffer_create(ctx, &rb, plane, VK_BUFFER_USAGE_TRANSFER_DST_BIT, 1);
    if (!s) s = picvr_buffer_create(ctx, &depth, picvr_reuse_on(ctx) ? pixels * 8 : PICVR_PLACEHOLDER_BYTES,
                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    if (!s) s = picvr_buffer_create(ctx, &part, groups * sizeof(picvr_gpu_partial), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, 1);
    /* the rendering queue: a 32-byte header, then one uvec4 per block */
    if (!s) s = picvr_buffer_create(ctx, &queue, 48 + (VkDeviceSize)blocks * 16,
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    VkBufferUsageFlags queue_usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                                     VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    if (!s) s = picvr_buffer_create(ctx, &shade, queue_bytes, queue_usage, 0);
    if (!s && ctx->cache.on) s = picvr_buffer_create(ctx, &lookup, queue_bytes, queue_usage, 0);
    if (!s && ctx->cache.on) s = picvr_buffer_create(ctx, &blend, picvr_blend_on(ctx) ? plane : PICVR_PLACEHOLDER_BYTES,
                                                     VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    /* superpixel locks and counters: the real thing in screen-space mode, a stub (the
       shader module declares the binding) in object-space mode */
    uint32_t side = ctx->cache.cfg.superpixel_size, superpixels = 0;
    if (!s && ctx->cache.on) {
        superpixels = ((w + side - 1) / side) * ((h + side - 1) / side);
        uint64_t bytes = ctx->cache.cfg.mode == PICVR_CACHE_SCREEN_SPACE ? (uint64_t)superpixels * 5 * 4 : 16;
        s = picvr_buffer_create(ctx, &sp, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    }
    if (s) {   /* nothing replaced yet: free what was made (a zeroed buffer is a no-op) */
        for (size_t i = 0; i < sizeof made / sizeof made[0]; i++) picvr_buffer_destroy(ctx, made[i]);
        return s;
    }
    if (ctx->cache.on) {
        picvr_buffer_destroy(ctx, &ctx->cache.superpixels);
        ctx->cache.superpixels = sp;
        ctx->cache.superpixel_count = superpixels;
    }
    for (int i = 0; i < 3; i++) { picvr_buffer_destroy(ctx, &ctx->image.planes[i]); ctx->image.planes[i] = acc[i]; }
    picvr_buffer_destroy(ctx, &ctx->results.readback);
    picvr_buffer_destroy(ctx, &ctx->results.partials);
    picvr_buffer_destroy(ctx, &ctx->image.render_queue);
    picvr_buffer_destroy(ctx, &ctx->image.shade_queue);
    picvr_buffer_destroy(ctx, &ctx->image.lookup_queue);
    picvr_buffer_destroy(ctx, &ctx->image.blend);
    ctx->results.readback = rb;
    ctx->results.partials = part;
    ctx->image.render_queue = queue;
    ctx->image.shade_queue = shade;
    ctx->image.lookup_queue = lookup;
    ctx->image.blend = blend;
    ctx->image.block_total = blocks;
    ctx->image.block_stride = picvr_spread_stride(blocks);
    ctx->pipes.descriptors_dirty = 1;
    picvr_reuse_buffers_destroy(ctx);   /* the previous view's size is gone */
    picvr_buffer_destroy(ctx, &ctx->image.depth);
    ctx->image.depth = depth;
    ctx->image.depth_valid = 0;
    return PICVR_OK;
}

/* The accumulation planes and the rendering procedure's queues. */
static void picvr_image_buffers_destroy(picvr_context *ctx) {
    picvr_reuse_buffers_destroy(ctx);
    picvr_buffer_destroy(ctx, &ctx->image.depth);
    for (int i = 0; i < 3; i++) picvr_buffer_destroy(ctx, &ctx->image.planes[i]);
    picvr_buffer_destroy(ctx, &ctx->image.render_queue);
    picvr_buffer_destroy(ctx, &ctx->image.shade_queue);
    picvr_buffer_destroy(ctx, &ctx->image.lookup_queue);
    picvr_buffer_destroy(ctx, &ctx->image.blend);
}
