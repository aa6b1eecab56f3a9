/* host/reproject.c - temporal reuse (picvr_scheduler_config.temporal_reuse): on a camera
 * move, picvr_set_camera moves the accumulation into the new view instead of clearing
 * it (shaders/reproject.comp).  The planes of the old view become the `previous` set
 * (the buffers are swapped, nothing is copied), the current set is cleared and receives
 * what lands in it.  Part of picvr_vk.c; uses util, vulkan, pipelines, image. */

/* Whether a move from the current camera to one of width x height can keep the image:
   reuse on, the same size, a depth plane that holds every sample since the reset, and
   something to keep (the debug views are not reprojected). */
static int picvr_can_reproject(const picvr_context *ctx, uint32_t width, uint32_t height) {
    return picvr_reuse_on(ctx) && ctx->scene.has_camera && ctx->scene.camera.width == width &&
           ctx->scene.camera.height == height && ctx->image.depth_valid && ctx->image.has_samples &&
           ctx->scene.gpu.debug_view == PICVR_VIEW_IMAGE;
}

/* The 14 floats of a view for the kernel: position, tan(fov / 2), forward, aspect,
   right, up. */
static void picvr_pack_view(const picvr_gpu_scene *g, float *out) {
    memcpy(out, g->cam_pos, 3 * sizeof(float));
    out[3] = g->tan_half_fov;
    memcpy(out + 4, g->cam_fwd, 3 * sizeof(float));
    out[7] = g->aspect;
    memcpy(out + 8, g->cam_right, 3 * sizeof(float));
    memcpy(out + 11, g->cam_up, 3 * sizeof(float));
}

/* The previous view's buffers, as large as the current ones, and the landing buffer. */
static picvr_status picvr_reproject_buffers(picvr_context *ctx, VkDeviceSize pixels) {
    picvr_image_state *im = &ctx->image;
    if (im->landing.buf) return PICVR_OK;
    VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                               VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    picvr_status s = PICVR_OK;
    for (int i = 0; i < 4 && !s; i++)
        s = picvr_buffer_create(ctx, &im->previous[i], i < 3 ? pixels * 16 : pixels * 8, usage, 0);
    if (!s) s = picvr_buffer_create(ctx, &im->landing, pixels * 8, usage, 0);
    if (s) picvr_reuse_buffers_destroy(ctx);
    return s;
}

/* Moves the accumulation of the view `old` into the current one (ctx->scene.gpu). */
static picvr_status picvr_reproject(picvr_context *ctx, const picvr_gpu_scene *old) {
    picvr_image_state *im = &ctx->image;
    uint32_t w = ctx->scene.camera.width, h = ctx->scene.camera.height;
    VkDeviceSize pixels = (VkDeviceSize)w * h;
    picvr_status s = picvr_aux_kernel_make(ctx, &ctx->reproject, 9, picvr_spv_reproject, sizeof picvr_spv_reproject);
    if (s || (s = picvr_reproject_buffers(ctx, pixels))) return s;
    for (int i = 0; i < 3; i++) {   /* the old view's planes become `previous` */
        picvr_buffer t = im->planes[i];
        im->planes[i] = im->previous[i];
        im->previous[i] = t;
    }
    picvr_buffer t = im->depth;
    im->depth = im->previous[3];
    im->previous[3] = t;
    ctx->pipes.descriptors_dirty = 1;
    VkBuffer bufs[9] = {im->previous[0].buf, im->previous[1].buf, im->previous[2].buf, im->previous[3].buf,
                        im->planes[0].buf, im->planes[1].buf, im->planes[2].buf, im->depth.buf, im->landing.buf};
    picvr_aux_kernel_bind(ctx, &ctx->reproject, bufs, 9);
    union { float f; uint32_t u; } push[32];
    float views[28];
    picvr_pack_view(old, views);
    picvr_pack_view(&ctx->scene.gpu, views + 14);
    for (int i = 0; i < 28; i++) push[i].f = views[i];
    push[28].u = w;
    push[29].u = h;
    push[30].u = ctx->sched.cfg.reuse_history;
    if ((s = picvr_cmd_begin(ctx))) return s;
    picvr_barrier_all(ctx);
    for (int i = 0; i < 3; i++) vkCmdFillBuffer(ctx->vk.cmd, im->planes[i].buf, 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(ctx->vk.cmd, im->depth.buf, 0, VK_WHOLE_SIZE, 0);
    /* the blend's statistics restart (its weights from 0): the moved samples' hits are
       other pixels' */
    if (im->blend.buf) vkCmdFillBuffer(ctx->vk.cmd, im->blend.buf, 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(ctx->vk.cmd, im->landing.buf, 0, VK_WHOLE_SIZE, 0xffffffffu);   /* "empty" */
    vkCmdFillBuffer(ctx->vk.cmd, im->render_queue.buf, 0, VK_WHOLE_SIZE, 0);         /* block credits */
    picvr_barrier_all(ctx);
    for (uint32_t pass = 0; pass < 3; pass++) {
        push[31].u = pass;
        picvr_aux_kernel_dispatch(ctx, &ctx->reproject, push, sizeof push, pixels);
        picvr_barrier_all(ctx);
    }
    if ((s = picvr_cmd_submit_wait(ctx))) return s;
    picvr_invalidate_accumulation(ctx);   /* counters restart: the first pass, timing, stats */
    im->has_samples = 1;                  /* ... but the pixels hold what was moved */
    return PICVR_OK;
}
