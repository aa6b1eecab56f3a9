/* host/clip.c - picvr_set_clip: clip planes and the box's faces, validated in world
 * space and packed in the volume's frame (the kernels' space; picvr_scene.rot and
 * shift).  Part of picvr_vk.c; uses util, cache, image. */

/* Plane n . x + d >= 0 (world) in the volume's frame, scaled to a unit normal: n' =
   rot^T n, d' = d + n . shift, both over |n|.  0 when the result is not finite (a
   normal so small that 1/|n| overflows). */
static int picvr_plane_to_local(const picvr_scene *sc, const float p[4], float out[4]) {
    double n[3] = {p[0], p[1], p[2]}, len = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0.0)) return 0;
    double d = p[3] + n[0] * sc->shift[0] + n[1] * sc->shift[1] + n[2] * sc->shift[2];
    for (int i = 0; i < 3; i++)
        out[i] = (float)((sc->rot[i] * n[0] + sc->rot[3 + i] * n[1] + sc->rot[6 + i] * n[2]) / len);
    out[3] = (float)(d / len);
    return isfinite(out[0]) && isfinite(out[1]) && isfinite(out[2]) && isfinite(out[3]);
}

/* The kernels' clip planes from clip (world): its planes, then the box's six faces. */
static int picvr_pack_clip_planes(const picvr_scene *sc, const picvr_clip *clip, picvr_gpu_scene *g) {
    uint32_t n = 0;
    for (uint32_t i = 0; i < clip->plane_count; i++)
        if (!picvr_plane_to_local(sc, clip->planes[i], g->clip[n++])) return 0;
    if (clip->use_box)
        for (int a = 0; a < 3; a++) {
            float lo[4] = {0, 0, 0, -clip->box_min[a]}, hi[4] = {0, 0, 0, clip->box_max[a]};
            lo[a] = 1.0f;    /* x_a - min >= 0 */
            hi[a] = -1.0f;   /* max - x_a >= 0 */
            if (!picvr_plane_to_local(sc, lo, g->clip[n++]) || !picvr_plane_to_local(sc, hi, g->clip[n++])) return 0;
        }
    g->clip_count = n;
    return 1;
}

picvr_status picvr_set_clip(picvr_context *ctx, const picvr_clip *clip) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    picvr_clip c;
    memset(&c, 0, sizeof c);
    if (clip) {
        if (clip->plane_count > PICVR_MAX_CLIP_PLANES) return PICVR_ERROR_INVALID_ARGUMENT;
        c.plane_count = clip->plane_count;
        memcpy(c.planes, clip->planes, c.plane_count * sizeof c.planes[0]);   /* unused rows stay 0 */
        c.use_box = clip->use_box != 0;
        for (uint32_t i = 0; i < c.plane_count; i++) {
            if (!picvr_finite3(c.planes[i]) || !isfinite(c.planes[i][3])) return PICVR_ERROR_INVALID_ARGUMENT;
            if (c.planes[i][0] == 0.0f && c.planes[i][1] == 0.0f && c.planes[i][2] == 0.0f) return PICVR_ERROR_INVALID_ARGUMENT;
        }
        if (c.use_box) {
            memcpy(c.box_min, clip->box_min, sizeof c.box_min);
            memcpy(c.box_max, clip->box_max, sizeof c.box_max);
            if (!picvr_finite3(c.box_min) || !picvr_finite3(c.box_max)) return PICVR_ERROR_INVALID_ARGUMENT;
            for (int a = 0; a < 3; a++)
                if (c.box_min[a] > c.box_max[a]) return PICVR_ERROR_INVALID_ARGUMENT;
        }
    }
    picvr_gpu_scene probe = ctx->scene.gpu;   /* validated in full before anything changes */
    if (!picvr_pack_clip_planes(&ctx->scene, &c, &probe)) return PICVR_ERROR_INVALID_ARGUMENT;
    if (!memcmp(&c, &ctx->scene.clip, sizeof c)) return PICVR_OK;
    ctx->scene.clip = c;
    memcpy(ctx->scene.gpu.clip, probe.clip, sizeof probe.clip);
    ctx->scene.gpu.clip_count = probe.clip_count;
    return picvr_light_state_changed(ctx, PICVR_OK);
}
