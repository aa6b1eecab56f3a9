/* host/readback.c - reading the image (linear RGBA, tone-mapped sRGB, sample counts)
 * and the statistics: the stats kernel reduces the per-pixel Eq. 5 error on the device,
 * the host adds the cache's counters and the scheduler's measured shares.  Part of
 * picvr_vk.c; uses util, vulkan, schedule, cache, pipelines, image, step. */

/* Copies accumulation plane `plane` (0: mean rgba, 2: lum mean, M2, n, bad) to readback. */
static picvr_status picvr_read_plane(picvr_context *ctx, int plane) {
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_barrier_all(ctx);
    VkBufferCopy region = {0, 0, ctx->results.readback.size};
    vkCmdCopyBuffer(ctx->vk.cmd, ctx->image.planes[plane].buf, ctx->results.readback.buf, 1, &region);
    picvr_barrier_all(ctx);
    if ((s = picvr_cmd_submit_wait(ctx))) return s;
    picvr_buffer_invalidate(ctx, &ctx->results.readback);
    return PICVR_OK;
}

static picvr_status picvr_check_image_read(picvr_context *ctx, const void *dst, size_t size, size_t bpp) {
    if (!ctx || !dst) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (!ctx->scene.has_camera) return PICVR_ERROR_NOT_READY;
    if (size / bpp < (size_t)ctx->scene.camera.width * ctx->scene.camera.height) return PICVR_ERROR_BUFFER_TOO_SMALL;
    return PICVR_OK;
}

picvr_status picvr_read_rgba32f(picvr_context *ctx, float *pixels, size_t size) {
    picvr_status s = picvr_check_image_read(ctx, pixels, size, 16);
    if (!s) s = picvr_read_plane(ctx, 0);
    if (!s) memcpy(pixels, ctx->results.readback.mapped, (size_t)ctx->scene.camera.width * ctx->scene.camera.height * 16);
    return s;
}

picvr_status picvr_read_sample_counts(picvr_context *ctx, uint32_t *counts, size_t count) {
    size_t bytes = count > SIZE_MAX / 4 ? SIZE_MAX : count * 4;   /* saturate: large is large enough */
    picvr_status s = picvr_check_image_read(ctx, counts, bytes, 4);
    if (!s) s = picvr_read_plane(ctx, 2);
    if (s) return s;
    const uint32_t *src = (const uint32_t *)ctx->results.readback.mapped;     /* vec4 per pixel, z = n as uint bits */
    size_t n = (size_t)ctx->scene.camera.width * ctx->scene.camera.height;
    for (size_t i = 0; i < n; i++) counts[i] = src[i * 4 + 2];
    return PICVR_OK;
}

static uint8_t picvr_to_srgb8(double x) {
    /* Rule: NaN (never produced, but never trusted) maps to 0. */
    if (!(x > 0.0)) return 0;
    if (x >= 1.0) return 255;
    double s = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    return (uint8_t)lrint(s * 255.0);
}

picvr_status picvr_read_rgba8(picvr_context *ctx, uint8_t *pixels, size_t size, float exposure) {
    picvr_status s = picvr_check_image_read(ctx, pixels, size, 4);
    if (!s) s = picvr_read_plane(ctx, 0);
    if (s) return s;
    double e = (isfinite(exposure) && exposure > 0.0f) ? exposure : 1.0;
    const float *src = (const float *)ctx->results.readback.mapped;
    size_t n = (size_t)ctx->scene.camera.width * ctx->scene.camera.height;
    for (size_t i = 0; i < n; i++) {
        for (int c = 0; c < 3; c++) pixels[i * 4 + c] = picvr_to_srgb8(1.0 - exp(-e * src[i * 4 + c]));
        double a = src[i * 4 + 3];
        pixels[i * 4 + 3] = (uint8_t)lrint((a > 0.0 ? (a < 1.0 ? a : 1.0) : 0.0) * 255.0);
    }
    return PICVR_OK;
}

/* One stats reduction pass with the given relative-error floor; sums the partials
   in double.  Output: sums[0..3] (lum, err, rel, valid), counts[0..3]. */
static picvr_status picvr_stats_pass(picvr_context *ctx, float rel_floor, double sums[4], uint64_t counts[4]) {
    uint32_t pixels = ctx->scene.camera.width * ctx->scene.camera.height;
    uint32_t groups = (pixels + 255) / 256;
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_barrier_all(ctx);
    vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.stats_pipe);
    vkCmdBindDescriptorSets(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.stats_layout, 0, 1, &ctx->pipes.set, 0, NULL);
    union { uint32_t u; float f; } push[2];
    push[0].u = pixels;
    push[1].f = rel_floor;
    vkCmdPushConstants(ctx->vk.cmd, ctx->pipes.stats_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, push);
    uint32_t gx = groups < 65535 ? groups : 65535, gy = (groups + gx - 1) / gx;
    vkCmdDispatch(ctx->vk.cmd, gx, gy, 1);
    picvr_barrier_all(ctx);
    if ((s = picvr_cmd_submit_wait(ctx))) return s;
    picvr_buffer_invalidate(ctx, &ctx->results.partials);
    const picvr_gpu_partial *p = (const picvr_gpu_partial *)ctx->results.partials.mapped;
    for (int i = 0; i < 4; i++) { sums[i] = 0.0; counts[i] = 0; }
    counts[0] = UINT32_MAX;
    for (uint32_t g = 0; g < groups; g++) {
        for (int i = 0; i < 4; i++) sums[i] += p[g].sums[i];
        if (p[g].counts[0] < counts[0]) counts[0] = p[g].counts[0];
        for (int i = 1; i < 4; i++) counts[i] += p[g].counts[i];
    }
    return PICVR_OK;
}

picvr_status picvr_get_stats(picvr_context *ctx, picvr_stats *out) {
    if (!ctx || !out) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    if (!ctx->results.valid) {
        picvr_stats st;
        memset(&st, 0, sizeof st);
        if (ctx->scene.has_volume && ctx->scene.has_camera && (ctx->image.block_samples > 0 || ctx->image.has_samples)) {
            double sums[4];
            uint64_t counts[4];
            picvr_status s = picvr_upload_scene(ctx);
            if (!s) s = picvr_stats_pass(ctx, 0.0f, sums, counts);
            if (s) return s;
            double pixels = (double)ctx->scene.camera.width * ctx->scene.camera.height;
            double mean_lum = pixels > 0 ? sums[0] / pixels : 0.0;
            /* the second pass: the relative error's floor is 1 % of the mean luminance */
            if ((s = picvr_stats_pass(ctx, (float)(0.01 * mean_lum), sums, counts))) return s;
            st.mean_luminance = mean_lum;
            st.iterations_min = (uint32_t)counts[0];
            st.iterations_mean = pixels > 0 ? (double)counts[1] / pixels : 0.0;
            st.truncated_paths = counts[2];
            st.pixels_unsampled = (uint64_t)pixels - counts[3];
            st.est_error = sums[3] > 0 ? sums[1] / sums[3] : 0.0;
            st.est_rel_error = sums[3] > 0 ? sums[2] / sums[3] : 0.0;
        } else if (ctx->scene.has_camera) {   /* nothing rendered yet: every pixel is a hole */
            st.pixels_unsampled = (uint64_t)ctx->scene.camera.width * ctx->scene.camera.height;
        }
        if (ctx->cache.on) {
            const picvr_cache_counters *c = &ctx->cache.counts;   /* as of the last round */
            st.cache_requests = ctx->cache.requests_issued;
            st.cache_pending = ctx->cache.requests_pending;
            st.cache_bytes = ctx->cache.entries.size + ctx->cache.nodes.size + ctx->cache.refs.size +
                             ctx->cache.counters.size + ctx->cache.requests.size + ctx->cache.prebuilt_nodes.size +
                             ctx->cache.superpixels.size + ctx->image.lookup_queue.size + ctx->image.blend.size +
                             ctx->cache.moments.size;
            st.cache_entries = c->entry_count < ctx->cache.cfg.max_entries ? c->entry_count : ctx->cache.cfg.max_entries;
            st.cache_nodes = c->node_count < ctx->cache.cfg.max_nodes ? c->node_count : ctx->cache.cfg.max_nodes;
            st.cache_refs = c->ref_count < ctx->cache.cfg.max_refs ? c->ref_count : ctx->cache.cfg.max_refs;
            st.cache_full = c->full;
            st.cache_refs_per_entry = st.cache_entries ? (double)st.cache_refs / st.cache_entries : 0.0;
            st.cache_entries_capped = c->capped < st.cache_entries ? c->capped : st.cache_entries;
            /* each round of a point: 128 samples */
            st.cache_samples = ctx->cache.point_rounds * 128u;
            st.cache_samples_truncated =
                ctx->cache.truncated < st.cache_samples ? ctx->cache.truncated : st.cache_samples;
            st.cache_lookups_cut = ctx->cache.lookups_cut;
            st.cache_lookups_spilled = ctx->cache.lookups_spilled;
            st.cache_hit_rate = ctx->sched.hit_rate;
            st.cache_routed = ctx->sched.auto_mode.routed;
            st.cache_gain = ctx->sched.auto_mode.gain;
            st.auto_efficiency = picvr_auto_efficiency(&ctx->sched.auto_mode);
        }
        st.cache_max_samples = picvr_create_rounds(ctx) * PICVR_CACHE_CREATE_GROUP;
        picvr_sched_shares(&ctx->sched, &st);
        if (!ctx->cache.on) st.auto_cached_share = 0.0;
        if (ctx->config.distance_sampling == PICVR_DISTANCE_FORCED && ctx->scene.use_forced && !ctx->cache.on)
            st.forced_share = 1.0;
        memcpy(st.kernel_ms_plain, ctx->rounds.kernel_ms[0], sizeof st.kernel_ms_plain);
        memcpy(st.kernel_ms_cached, ctx->rounds.kernel_ms[1], sizeof st.kernel_ms_cached);
        st.iterations = ctx->image.block_total ? (uint32_t)(ctx->image.block_samples / ctx->image.block_total) : 0;
        st.elapsed_ms = ctx->image.elapsed_ms;
        double samples = st.iterations_mean * ctx->scene.camera.width * ctx->scene.camera.height;
        st.samples_per_second = ctx->image.elapsed_ms > 0.0 ? samples / (ctx->image.elapsed_ms * 1e-3) : 0.0;
        st.mean_path_length = samples > 0.0 ? (double)ctx->image.scatter_events / samples : 0.0;
        picvr_field_stats(ctx, &st);
        ctx->results.stats = st;
        ctx->results.valid = 1;
    }
    *out = ctx->results.stats;
    out->validation_messages = ctx->vk.validation_messages;
    out->pipeline_variants = 0;
    for (int p = 0; p < 3; p++)
        for (uint32_t i = 0; i < PICVR_VARIANT_SLOTS; i++) out->pipeline_variants += ctx->pipes.variants[p][i].pipe[PICVR_KERNEL_MAIN] != VK_NULL_HANDLE;
    out->validation_enabled = (uint32_t)ctx->vk.validation_enabled;
    out->width = ctx->scene.has_camera ? ctx->scene.camera.width : 0;
    out->height = ctx->scene.has_camera ? ctx->scene.camera.height : 0;
    snprintf(out->device_name, sizeof out->device_name, "%s", ctx->vk.props.deviceName);
    out->device_type = picvr_device_type_of(ctx->vk.props.deviceType);
    return PICVR_OK;
}

static void picvr_results_destroy(picvr_context *ctx) {
    picvr_buffer_destroy(ctx, &ctx->results.readback);
    picvr_buffer_destroy(ctx, &ctx->results.partials);
}
