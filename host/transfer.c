/* host/transfer.c - the transfer function: validated control points, tabulated into a
 * 1D texture the kernels sample; a new one rebuilds the majorants, empties the cache
 * and restarts the image.  Part of picvr_vk.c; uses util, vulkan, cache, image,
 * majorant. */

/* Piecewise-linear evaluation at v, constant beyond the end points; at a step
   (equal values) the later point wins. */
static void picvr_tf_eval(const picvr_tf_point *p, uint32_t n, float v, float out[5]) {
    uint32_t i = 0;
    while (i < n && p[i].value <= v) i++;
    const picvr_tf_point *a = &p[i == 0 ? 0 : i - 1], *b = &p[i == n ? n - 1 : i];
    float span = b->value - a->value;
    float f = span > 0.0f ? (v - a->value) / span : 0.0f;   /* rule: no division by a zero span */
    for (int c = 0; c < 3; c++) out[c] = a->albedo[c] + f * (b->albedo[c] - a->albedo[c]);
    out[3] = a->opacity + f * (b->opacity - a->opacity);
    out[4] = a->g + f * (b->g - a->g);
}

static picvr_status picvr_upload_tf_table(picvr_context *ctx) {
    memcpy(ctx->scene.tf_staging.mapped, ctx->scene.tf_table, sizeof ctx->scene.tf_table);
    picvr_buffer_flush(ctx, &ctx->scene.tf_staging);
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_image_barrier(ctx, ctx->scene.tf_image.img, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    VkBufferImageCopy region;
    memset(&region, 0, sizeof region);
    region.imageSubresource = picvr_color_layers();
    region.imageExtent = picvr_extent(PICVR_TF_SIZE, 1, 1);
    vkCmdCopyBufferToImage(ctx->vk.cmd, ctx->scene.tf_staging.buf, ctx->scene.tf_image.img, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    picvr_image_barrier(ctx, ctx->scene.tf_image.img, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    s = picvr_cmd_submit_wait(ctx);
    ctx->pipes.descriptors_dirty = 1;
    return s;
}

static picvr_status picvr_validate_tf(const picvr_tf_point *p, uint32_t n, float density) {
    if (!p) return PICVR_ERROR_NULL_POINTER;
    if (n == 0 || n > PICVR_MAX_TF_POINTS) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
    if (!isfinite(density)) return PICVR_ERROR_NON_FINITE;
    if (density < 0.0f) return PICVR_ERROR_INVALID_ARGUMENT;
    for (uint32_t i = 0; i < n; i++) {
        if (!isfinite(p[i].value) || !picvr_finite3(p[i].albedo) || !isfinite(p[i].opacity) || !isfinite(p[i].g))
            return PICVR_ERROR_NON_FINITE;
        if (p[i].value < 0.0f || p[i].value > 1.0f || p[i].opacity < 0.0f) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
        if (!(fabsf(p[i].g) < 1.0f)) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
        for (int c = 0; c < 3; c++)
            if (p[i].albedo[c] < 0.0f || p[i].albedo[c] > 1.0f) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
        if (i > 0 && p[i].value < p[i - 1].value) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
        /* sigma_t = D * opacity must fit a float */
        if ((double)p[i].opacity * density > FLT_MAX) return PICVR_ERROR_INVALID_ARGUMENT;
    }
    return PICVR_OK;
}

/* The phase function's g per table entry (binding 18): a table where some point has g != 0,
   else the placeholder (USE_HG compiles its reads out; leave-out).  A new buffer is made
   before the old one goes, so a failure keeps the old one. */
static picvr_status picvr_upload_tf_g(picvr_context *ctx, const float *g, int has_g) {
    VkDeviceSize bytes = has_g ? PICVR_TF_SIZE * sizeof(float) : PICVR_PLACEHOLDER_BYTES;
    picvr_buffer b;
    picvr_status s = picvr_buffer_create(ctx, &b, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    if (s) return s;
    float zero[PICVR_PLACEHOLDER_BYTES / sizeof(float)] = {0};
    s = picvr_upload_buffer(ctx, &b, has_g ? g : zero, (size_t)bytes);
    if (s) { picvr_buffer_destroy(ctx, &b); return s; }
    picvr_buffer_destroy(ctx, &ctx->scene.tf_g);
    ctx->scene.tf_g = b;
    ctx->scene.tf_has_g = has_g;
    ctx->pipes.descriptors_dirty = 1;
    return PICVR_OK;
}

static picvr_status picvr_apply_tf(picvr_context *ctx, const picvr_tf_point *p, uint32_t n, float density) {
    float *e = (float *)picvr_host_alloc(&ctx->config.allocator, PICVR_TF_SIZE * 5 * sizeof(float));
    if (!e) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    float *g = e + PICVR_TF_SIZE * 4;   /* the g column after the rgba table */
    int has_g = 0;
    for (uint32_t i = 0; i < n; i++) has_g |= p[i].g != 0.0f;
    for (int i = 0; i < PICVR_TF_SIZE; i++) {
        float v[5];
        picvr_tf_eval(p, n, (float)i / (PICVR_TF_SIZE - 1), v);
        memcpy(&e[i * 4], v, 4 * sizeof(float));
        g[i] = v[4];
    }
    picvr_status sg = picvr_upload_tf_g(ctx, g, has_g);
    if (!sg) memcpy(ctx->scene.tf_table, e, sizeof ctx->scene.tf_table);
    picvr_host_free(&ctx->config.allocator, e);
    if (sg) return sg;
    ctx->scene.density = density;
    ctx->scene.gpu.density = density;
    picvr_range_build(ctx->scene.tf_rm, ctx->scene.tf_table, 0);
    picvr_range_build(ctx->scene.tf_rmin, ctx->scene.tf_table, 1);
    picvr_status s = picvr_upload_tf_table(ctx);
    if (!s) s = picvr_upload_buffer(ctx, &ctx->scene.tf_range_max, ctx->scene.tf_rm, sizeof *ctx->scene.tf_rm);
    if (!s) s = picvr_update_majorant(ctx);
    return picvr_light_state_changed(ctx, s);
}

static picvr_status picvr_default_transfer_function(picvr_context *ctx) {
    picvr_tf_point ramp[2] = {{0.0f, {1, 1, 1}, 0.0f, 0.0f}, {1.0f, {1, 1, 1}, 1.0f, 0.0f}};
    return picvr_apply_tf(ctx, ramp, 2, 1.0f);
}

picvr_status picvr_set_transfer_function(picvr_context *ctx, const picvr_tf_point *points,
                                         uint32_t count, float density) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    picvr_status s = picvr_validate_tf(points, count, density);
    if (s) return s;
    return picvr_apply_tf(ctx, points, count, density);
}
