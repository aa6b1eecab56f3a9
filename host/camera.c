/* host/camera.c - the camera: validation, its uniform-block fields in the volume's
 * frame, and picvr_set_camera, which (re)allocates the image for a new size and, with
 * temporal reuse, moves the accumulation into the new view instead of clearing it.
 * Part of picvr_vk.c; uses util, vulkan, cache, image, reproject. */

/* camera into out with its defaults (up +y, fov_y 40 degrees).  Rules: finite; a size
   of at least 1x1 and at most PICVR_MAX_IMAGE_SIZE per side; fov_y in (0, 179]; a
   target apart from the position; up not parallel to the view. */
static picvr_status picvr_validate_camera(const picvr_camera *c, picvr_camera *out) {
    if (!c) return PICVR_ERROR_NULL_POINTER;
    *out = *c;
    if (!picvr_finite3(c->position) || !picvr_finite3(c->target) || !picvr_finite3(c->up) || !isfinite(c->fov_y_degrees))
        return PICVR_ERROR_NON_FINITE;
    if (c->width == 0 || c->height == 0) return PICVR_ERROR_INVALID_DIMENSIONS;
    if (c->width > PICVR_MAX_IMAGE_SIZE || c->height > PICVR_MAX_IMAGE_SIZE) return PICVR_ERROR_SIZE_OVERFLOW;
    if (out->up[0] == 0.0f && out->up[1] == 0.0f && out->up[2] == 0.0f) out->up[1] = 1.0f;
    if (out->fov_y_degrees == 0.0f) out->fov_y_degrees = 40.0f;
    if (!(out->fov_y_degrees > 0.0f && out->fov_y_degrees <= 179.0f)) return PICVR_ERROR_INVALID_CAMERA;
    float f[3] = {c->target[0] - c->position[0], c->target[1] - c->position[1], c->target[2] - c->position[2]};
    double lf = picvr_len3(f);
    if (!(lf > 0.0) || !isfinite(lf)) return PICVR_ERROR_INVALID_CAMERA;
    float r[3];
    picvr_cross3(f, out->up, r);
    if (!(picvr_len3(r) > 1e-6 * lf * picvr_len3(out->up))) return PICVR_ERROR_INVALID_CAMERA;
    return PICVR_OK;
}

/* The camera's uniform-block fields from ctx->scene.camera (world space), in the volume's
   frame.  The basis f, r, u is built in world space and each vector mapped: built in a
   reflected volume's frame it would show the mirror image of the world's view. */
static void picvr_pack_camera(picvr_context *ctx) {
    const picvr_camera *c = &ctx->scene.camera;
    float f[3] = {c->target[0] - c->position[0], c->target[1] - c->position[1], c->target[2] - c->position[2]}, r[3], u[3];
    picvr_normalize3(f);
    picvr_cross3(f, c->up, r);
    picvr_normalize3(r);
    picvr_cross3(r, f, u);
    picvr_gpu_scene *g = &ctx->scene.gpu;
    picvr_point_to_local(&ctx->scene, c->position, g->cam_pos);
    picvr_dir_to_local(&ctx->scene, f, g->cam_fwd);
    picvr_dir_to_local(&ctx->scene, r, r);
    picvr_dir_to_local(&ctx->scene, u, u);
    g->tan_half_fov = (float)tan(0.5 * c->fov_y_degrees * PICVR_PI / 180.0);
    g->aspect = (float)c->width / (float)c->height;
    picvr_pack4(g->cam_right, r, 0.0f);
    picvr_pack4(g->cam_up, u, 0.0f);
    g->image[0] = c->width;
    g->image[1] = c->height;
}

/* An unchanged camera changes nothing; a new size makes the image anew (on a failure the
   old camera and image stay). */
picvr_status picvr_set_camera(picvr_context *ctx, const picvr_camera *camera) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    picvr_camera c;
    picvr_status s = picvr_validate_camera(camera, &c);
    if (s) return s;
    if (ctx->scene.has_camera && !memcmp(&c, &ctx->scene.camera, sizeof c)) return PICVR_OK;
    int reproject = picvr_can_reproject(ctx, c.width, c.height);
    picvr_gpu_scene old = ctx->scene.gpu;   /* the view the accumulation was made from */
    if (!ctx->scene.has_camera || c.width != ctx->scene.camera.width || c.height != ctx->scene.camera.height)
        if ((s = picvr_create_image_buffers(ctx, c.width, c.height))) return s;
    ctx->scene.camera = c;
    picvr_pack_camera(ctx);
    ctx->scene.has_camera = 1;
    if (ctx->cache.on) {
        picvr_cache_scene_params(ctx);   /* the request cap and superpixels follow the image size */
        if ((s = picvr_cmd_begin(ctx))) return s;
        picvr_barrier_all(ctx);
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.superpixels.buf, 0, VK_WHOLE_SIZE, 0);
        picvr_barrier_all(ctx);
        if ((s = picvr_cmd_submit_wait(ctx))) return s;
    }
    return reproject ? picvr_reproject(ctx, &old) : picvr_clear_accumulation(ctx);
}
