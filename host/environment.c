/* host/environment.c - the background's environment map (picvr_background.environment):
 * validation, and the buffer the kernels sample it from (binding 19; the layout is
 * described at `Environment` in shaders/background.glsl): per texel its radiance and the
 * solid-angle pdf of the luminance sampling, then the marginal CDF over rows and one CDF
 * over the columns of each row.  A constant background, or a 1x1 map, needs none of it:
 * the binding then holds a placeholder and USE_ENV_MAP compiles its code out.  Part of
 * picvr_vk.c; uses util, vulkan. */

/* What picvr_set_lights takes from a background: validated, in doubles. */
typedef struct picvr_env_info {
    int is_map;            /* a map of more than one texel */
    double scale[3];       /* colour * intensity */
    double lum_omega;      /* sum over texels of luminance * solid angle (4 pi L for a
                              constant L): the background's power is pi R^2 times it */
    float constant[3];     /* the radiance when it is not a map */
    uint64_t bytes;        /* of the device buffer, when a map */
} picvr_env_info;

/* Solid angle of a texel of row r of an h-row map with w columns: (2 pi / w) (cos
   theta_r - cos theta_{r+1}), the cosine difference as 2 sin(mid) sin(half) without
   cancellation near the poles. */
static double picvr_env_row_omega(uint32_t r, uint32_t w, uint32_t h) {
    double a = PICVR_PI * r / h, b = PICVR_PI * (r + 1) / h;
    return 2.0 * PICVR_PI / w * 2.0 * sin(0.5 * (a + b)) * sin(0.5 * (b - a));
}

/* Validates a background (NULL: black) and sums its power.  Rules: texels finite and
   >= 0, a map not all black (its luminance would be 0 everywhere: nothing to sample,
   surely a mistake), every colour * intensity * texel a finite float, sizes within
   PICVR_MAX_ENV_SIZE and the device's largest storage buffer. */
static picvr_status picvr_env_validate(const picvr_context *ctx, const picvr_background *bg, picvr_env_info *info) {
    memset(info, 0, sizeof *info);
    if (!bg) return PICVR_OK;
    if (!picvr_finite3(bg->color) || !isfinite(bg->intensity)) return PICVR_ERROR_NON_FINITE;
    if (bg->intensity < 0.0f || bg->color[0] < 0.0f || bg->color[1] < 0.0f || bg->color[2] < 0.0f)
        return PICVR_ERROR_INVALID_LIGHT;
    for (int c = 0; c < 3; c++) {
        info->scale[c] = (double)bg->color[c] * bg->intensity;
        if (info->scale[c] > FLT_MAX) return PICVR_ERROR_INVALID_LIGHT;
        info->constant[c] = (float)info->scale[c];
    }
    if (!isfinite(bg->env_rotation)) return PICVR_ERROR_NON_FINITE;
    if (!bg->environment) {
        info->lum_omega = 4.0 * PICVR_PI * (0.2126 * info->scale[0] + 0.7152 * info->scale[1] + 0.0722 * info->scale[2]);
        return PICVR_OK;
    }
    uint32_t w = bg->env_width, h = bg->env_height;
    if (w == 0 || h == 0) return PICVR_ERROR_INVALID_DIMENSIONS;
    if (w > PICVR_MAX_ENV_SIZE || h > PICVR_MAX_ENV_SIZE) return PICVR_ERROR_SIZE_OVERFLOW;
    uint64_t texels = (uint64_t)w * h;
    info->bytes = (4 * texels + (h + 1) + (uint64_t)h * (w + 1)) * sizeof(float);
    if (texels > 1 && info->bytes > ctx->vk.props.limits.maxStorageBufferRange) return PICVR_ERROR_SIZE_OVERFLOW;
    if (texels * 3 > SIZE_MAX / sizeof(float)) return PICVR_ERROR_SIZE_OVERFLOW;
    double any = 0.0;
    for (uint32_t r = 0; r < h; r++) {
        double omega = picvr_env_row_omega(r, w, h);
        for (uint32_t x = 0; x < w; x++) {
            const float *t = bg->environment + 3 * ((size_t)r * w + x);
            if (!picvr_finite3(t)) return PICVR_ERROR_NON_FINITE;
            if (t[0] < 0.0f || t[1] < 0.0f || t[2] < 0.0f) return PICVR_ERROR_INVALID_LIGHT;
            double L[3];
            for (int c = 0; c < 3; c++)
                if ((L[c] = info->scale[c] * t[c]) > FLT_MAX) return PICVR_ERROR_INVALID_LIGHT;
            any += (double)t[0] + t[1] + t[2];
            info->lum_omega += (0.2126 * L[0] + 0.7152 * L[1] + 0.0722 * L[2]) * omega;
        }
    }
    if (!(any > 0.0)) return PICVR_ERROR_INVALID_LIGHT;
    info->is_map = texels > 1;
    if (!info->is_map)
        for (int c = 0; c < 3; c++) info->constant[c] = (float)(info->scale[c] * bg->environment[c]);
    return PICVR_OK;
}

/* A CDF over n weights (doubles) into out[0..n] as floats: out[0] = 0, out[n] = 1
   exactly, non-decreasing.  Rule: all weights 0 (a black row) gives the uniform CDF, so
   the row's columns are still a partition of [0, 1) (such a row is never drawn: its
   marginal weight is 0). */
static void picvr_env_cdf(const double *wt, uint32_t n, float *out) {
    double total = 0.0, run = 0.0;
    for (uint32_t i = 0; i < n; i++) total += wt[i];
    out[0] = 0.0f;
    for (uint32_t i = 1; i < n; i++) {
        run += wt[i - 1];
        float v = total > 0.0 ? (float)(run / total) : (float)i / (float)n;
        out[i] = v > out[i - 1] ? v : out[i - 1];
        if (out[i] > 1.0f) out[i] = 1.0f;
    }
    out[n] = 1.0f;
}

/* Fills the device layout: texels (radiance, pdf), the marginal CDF, the rows' CDFs.
   Each texel's pdf is computed from the float CDFs as stored, P = (m[r+1] - m[r]) (c[x+1]
   - c[x]) over its solid angle, so the pdf the kernels weight by is the probability
   their search draws the texel with (up to the 24-bit resolution of the random
   numbers).  wt: scratch of w + h doubles. */
static void picvr_env_fill(const picvr_background *bg, const picvr_env_info *info, float *out, double *wt) {
    uint32_t w = bg->env_width, h = bg->env_height;
    size_t texels = (size_t)w * h;
    float *marg = out + 4 * texels, *cond = marg + h + 1;
    for (uint32_t r = 0; r < h; r++) {
        double omega = picvr_env_row_omega(r, w, h), row = 0.0;
        for (uint32_t x = 0; x < w; x++) {
            const float *t = bg->environment + 3 * ((size_t)r * w + x);
            float *o = out + 4 * ((size_t)r * w + x);
            for (int c = 0; c < 3; c++) o[c] = (float)(info->scale[c] * t[c]);
            wt[x] = picvr_luminance(o) * omega;
            row += wt[x];
        }
        picvr_env_cdf(wt, w, cond + (size_t)r * (w + 1));
        wt[w + r] = row;
    }
    picvr_env_cdf(wt + w, h, marg);
    for (uint32_t r = 0; r < h; r++) {
        double omega = picvr_env_row_omega(r, w, h), pr = (double)marg[r + 1] - marg[r];
        const float *c = cond + (size_t)r * (w + 1);
        for (uint32_t x = 0; x < w; x++)
            out[4 * ((size_t)r * w + x) + 3] = (float)(pr * ((double)c[x + 1] - c[x]) / omega);
    }
}

/* Makes the buffer of a validated background into *out (a placeholder when it is not a
   map); on failure *out is untouched and nothing leaks. */
static picvr_status picvr_env_build(picvr_context *ctx, const picvr_background *bg, const picvr_env_info *info,
                                    picvr_buffer *out) {
    VkDeviceSize bytes = info->is_map ? (VkDeviceSize)info->bytes : PICVR_PLACEHOLDER_BYTES;
    picvr_buffer b;
    picvr_status s = picvr_buffer_create(ctx, &b, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    if (s) return s;
    float *data = (float *)picvr_host_alloc(&ctx->config.allocator, (size_t)bytes);
    size_t n = info->is_map ? (size_t)bg->env_width + bg->env_height : 1;
    double *wt = (double *)picvr_host_alloc(&ctx->config.allocator, n * sizeof(double));
    if (!data || !wt) s = PICVR_ERROR_OUT_OF_HOST_MEMORY;
    if (!s) {
        memset(data, 0, (size_t)bytes);
        if (info->is_map) picvr_env_fill(bg, info, data, wt);
        s = picvr_upload_buffer(ctx, &b, data, (size_t)bytes);
    }
    if (data) picvr_host_free(&ctx->config.allocator, data);
    if (wt) picvr_host_free(&ctx->config.allocator, wt);
    if (s) { picvr_buffer_destroy(ctx, &b); return s; }
    *out = b;
    return PICVR_OK;
}

/* The map's frame from the volume's (shaders/background.glsl env_texel): the volume's
   orientation into world space, then the map's rotation about world +y turned back,
   e = R_y(-rotation) rot w. */
static void picvr_pack_env_basis(picvr_context *ctx) {
    double c = cos(ctx->scene.env_rotation), s = sin(ctx->scene.env_rotation);
    const double ry[3][3] = {{c, 0.0, -s}, {0.0, 1.0, 0.0}, {s, 0.0, c}};
    for (int r = 0; r < 3; r++) {
        for (int k = 0; k < 3; k++)
            ctx->scene.gpu.env_basis[r][k] = (float)(ry[r][0] * ctx->scene.rot[k] + ry[r][1] * ctx->scene.rot[3 + k] +
                                                     ry[r][2] * ctx->scene.rot[6 + k]);
        ctx->scene.gpu.env_basis[r][3] = 0.0f;
    }
}

/* Installs a built background: the buffer, the uniform block's fields. */
static void picvr_env_install(picvr_context *ctx, const picvr_background *bg, const picvr_env_info *info, picvr_buffer *b) {
    picvr_buffer_destroy(ctx, &ctx->scene.env);
    ctx->scene.env = *b;
    ctx->scene.use_env = info->is_map;
    ctx->scene.gpu.env_w = info->is_map ? bg->env_width : 1;
    ctx->scene.gpu.env_h = info->is_map ? bg->env_height : 1;
    ctx->scene.env_rotation = info->is_map ? bg->env_rotation : 0.0f;
    picvr_pack_env_basis(ctx);
    memcpy(ctx->scene.gpu.background, info->constant, sizeof info->constant);
    ctx->pipes.descriptors_dirty = 1;
}
