/* host/gpu_image.c - picvr_write_image: the image into a VkImage of the application's,
 * with no host copy.  One submission: write_image.comp encodes the accumulated mean
 * into a buffer of picvr's (float32 images copy the accumulation plane as it is), then
 * the image goes to TRANSFER_DST_OPTIMAL, receives the buffer, and goes to the layout
 * the application asked for.  Part of picvr_vk.c; uses util, vulkan, pipelines, image,
 * step. */

/* What the kernel writes for a format (kind 3: no kernel, plane 0 as it is) and its
   bytes per pixel; 0 for a format picvr does not write. */
static uint32_t picvr_target_bytes(uint32_t format, uint32_t *kind) {
    switch ((VkFormat)format) {
    case VK_FORMAT_R8G8B8A8_UNORM: case VK_FORMAT_R8G8B8A8_SRGB: *kind = 0; return 4;
    case VK_FORMAT_B8G8R8A8_UNORM: case VK_FORMAT_B8G8R8A8_SRGB: *kind = 1; return 4;
    case VK_FORMAT_R16G16B16A16_SFLOAT: *kind = 2; return 8;
    case VK_FORMAT_R32G32B32A32_SFLOAT: *kind = 3; return 16;
    default: return 0;
    }
}

/* The layouts an application's image may be in before and after picvr's commands. */
static int picvr_target_layout_ok(uint32_t layout, int before) {
    switch ((VkImageLayout)layout) {
    case VK_IMAGE_LAYOUT_UNDEFINED: return before;
    case VK_IMAGE_LAYOUT_GENERAL: case VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL:
    case VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL: case VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL:
    case VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL: case VK_IMAGE_LAYOUT_PRESENT_SRC_KHR: return 1;
    default: return 0;
    }
}

static void picvr_target_destroy(picvr_context *ctx) {
    picvr_buffer_destroy(ctx, &ctx->target.encoded);
    picvr_aux_kernel_destroy(ctx, &ctx->target.kernel);
}

/* The encoded-pixel buffer, at least `bytes` (kept between calls; regrown when the
   image grows), and the kernel's bindings: plane 0, then it. */
static picvr_status picvr_target_buffer(picvr_context *ctx, VkDeviceSize bytes) {
    picvr_target_state *t = &ctx->target;
    if (t->encoded.size < bytes) {
        picvr_buffer fresh;
        memset(&fresh, 0, sizeof fresh);
        picvr_status s = picvr_buffer_create(ctx, &fresh, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT |
                                             VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 0);
        if (s) return s;
        picvr_buffer_destroy(ctx, &t->encoded);
        t->encoded = fresh;
    }
    VkBuffer bufs[2] = {ctx->image.planes[0].buf, t->encoded.buf};
    picvr_aux_kernel_bind(ctx, &t->kernel, bufs, 2);
    return PICVR_OK;
}

static picvr_status picvr_check_target(picvr_context *ctx, const picvr_image_target *t, uint32_t *kind, uint32_t *bpp) {
    if (!t || !t->image) return PICVR_ERROR_NULL_POINTER;
    if (!ctx->vk.external) {
        picvr_log_message(ctx, PICVR_LOG_ERROR, "picvr_write_image: the image must be on the application's device "
                          "(picvr_config.vulkan); this context made its own");
        return PICVR_ERROR_INVALID_ARGUMENT;
    }
    if (!ctx->scene.has_camera) return PICVR_ERROR_NOT_READY;
    if (t->width != ctx->scene.camera.width || t->height != ctx->scene.camera.height) {
        picvr_log_message(ctx, PICVR_LOG_ERROR, "picvr_write_image: image %ux%u, camera %ux%u", t->width, t->height,
                          ctx->scene.camera.width, ctx->scene.camera.height);
        return PICVR_ERROR_INVALID_ARGUMENT;
    }
    if (!(*bpp = picvr_target_bytes(t->format, kind))) {
        picvr_log_message(ctx, PICVR_LOG_ERROR, "picvr_write_image: VkFormat %u is not one picvr writes", t->format);
        return PICVR_ERROR_INVALID_ARGUMENT;
    }
    if (!picvr_target_layout_ok(t->old_layout, 1) || !picvr_target_layout_ok(t->new_layout, 0)) {
        picvr_log_message(ctx, PICVR_LOG_ERROR, "picvr_write_image: layout %u -> %u", t->old_layout, t->new_layout);
        return PICVR_ERROR_INVALID_ARGUMENT;
    }
    if (!isfinite(t->exposure)) return PICVR_ERROR_NON_FINITE;
    return PICVR_OK;
}

/* A layout transition of the application's image; the stages and accesses on its side
   are all of them, since picvr does not know what the application did or will do. */
static void picvr_target_barrier(picvr_context *ctx, VkImage image, VkImageLayout from, VkImageLayout to, int before) {
    VkImageMemoryBarrier b;
    PICVR_VK_INIT(b, VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER);
    b.srcAccessMask = before ? VK_ACCESS_MEMORY_WRITE_BIT : VK_ACCESS_TRANSFER_WRITE_BIT;
    b.dstAccessMask = before ? VK_ACCESS_TRANSFER_WRITE_BIT : VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = picvr_color_range();
    VkPipelineStageFlags src = before ? VK_PIPELINE_STAGE_ALL_COMMANDS_BIT : VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkPipelineStageFlags dst = before ? VK_PIPELINE_STAGE_TRANSFER_BIT : VK_PIPELINE_STAGE_ALL_COMMANDS_BIT;
    vkCmdPipelineBarrier(ctx->vk.cmd, src, dst, 0, 0, NULL, 0, NULL, 1, &b);
}

picvr_status picvr_write_image(picvr_context *ctx, const picvr_image_target *target) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    uint32_t kind = 0, bpp = 0;
    picvr_status s = picvr_check_target(ctx, target, &kind, &bpp);
    if (s) return s;
    uint32_t pixels = target->width * target->height;
    VkBuffer src = ctx->image.planes[0].buf;
    if (kind != 3) {
        if ((s = picvr_aux_kernel_make(ctx, &ctx->target.kernel, 2, picvr_spv_write_image, sizeof picvr_spv_write_image)) ||
            (s = picvr_target_buffer(ctx, (VkDeviceSize)pixels * bpp)))
            return s;
        src = ctx->target.encoded.buf;
    }
    if ((s = picvr_cmd_begin(ctx))) return s;
    picvr_barrier_all(ctx);   /* the rounds' writes to plane 0 before the kernel or the copy */
    if (kind != 3) {
        union { uint32_t u; float f; } push[4];
        push[0].u = pixels;
        push[1].u = kind;
        push[2].f = target->exposure > 0.0f ? target->exposure : 1.0f;
        push[3].u = 0;
        picvr_aux_kernel_dispatch(ctx, &ctx->target.kernel, push, sizeof push, pixels);
        picvr_barrier_all(ctx);
    }
    VkImage image = (VkImage)target->image;
    picvr_target_barrier(ctx, image, (VkImageLayout)target->old_layout, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1);
    VkBufferImageCopy region;
    memset(&region, 0, sizeof region);
    region.imageSubresource = picvr_color_layers();
    region.imageExtent = picvr_extent(target->width, target->height, 1);
    vkCmdCopyBufferToImage(ctx->vk.cmd, src, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    picvr_target_barrier(ctx, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, (VkImageLayout)target->new_layout, 0);
    s = picvr_cmd_submit_with(ctx, (VkSemaphore)target->wait_semaphore, VK_PIPELINE_STAGE_TRANSFER_BIT,
                              (VkSemaphore)target->signal_semaphore);
    return s ? s : picvr_cmd_wait(ctx, UINT64_MAX);
}
