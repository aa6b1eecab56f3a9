/* host/volume.c - uploading a volume: validation against overflow and device limits,
 * the value range, the 3D image (float data as R16_UNORM where R32F cannot be
 * filtered), the bricks of the majorant grid, the placement (every world-space input
 * packed again in the new volume's frame) and the world box.  Part of picvr_vk.c; uses
 * util, vulkan, cache, image, camera, majorant, environment, lights, clip. */

static size_t picvr_voxel_bytes(picvr_voxel_type t) {
    switch (t) {
    case PICVR_VOXEL_UINT8: case PICVR_VOXEL_INT8: return 1;
    case PICVR_VOXEL_UINT16: case PICVR_VOXEL_INT16: case PICVR_VOXEL_FLOAT16: return 2;
    case PICVR_VOXEL_FLOAT32: case PICVR_VOXEL_INT32: return 4;
    case PICVR_VOXEL_FLOAT64: return 8;
    default: return 0;
    }
}

/* How a type is stored in the 3D image: 8- and 16-bit integers in R8/R16_UNORM (the
   signed ones offset by 128 and 32768: exact), everything else as float32 (R32_SFLOAT,
   or normalized R16_UNORM where the device cannot filter R32F). */
static int picvr_stored_as_float(picvr_voxel_type t) {
    return t == PICVR_VOXEL_FLOAT32 || t == PICVR_VOXEL_INT32 || t == PICVR_VOXEL_FLOAT16 || t == PICVR_VOXEL_FLOAT64;
}

/* The offset added to a signed integer voxel to store it unsigned. */
static double picvr_voxel_bias(picvr_voxel_type t) {
    return t == PICVR_VOXEL_INT8 ? 128.0 : t == PICVR_VOXEL_INT16 ? 32768.0 : 0.0;
}

/* IEEE 754 binary16 to double, exactly (subnormals, infinities and NaN included). */
static double picvr_half_to_double(uint16_t h) {
    int e = (h >> 10) & 31, f = h & 1023;
    double v = e == 0 ? ldexp(f, -24) : e == 31 ? (f ? NAN : INFINITY) : ldexp(f + 1024, e - 25);
    return (h & 0x8000) ? -v : v;
}

/* Reads voxel i as a double. */
static double picvr_voxel_at(const picvr_volume_desc *d, size_t i) {
    switch (d->type) {
    case PICVR_VOXEL_UINT8: return ((const uint8_t *)d->data)[i];
    case PICVR_VOXEL_UINT16: return ((const uint16_t *)d->data)[i];
    case PICVR_VOXEL_INT8: return ((const int8_t *)d->data)[i];
    case PICVR_VOXEL_INT16: return ((const int16_t *)d->data)[i];
    case PICVR_VOXEL_INT32: return ((const int32_t *)d->data)[i];
    case PICVR_VOXEL_FLOAT16: return picvr_half_to_double(((const uint16_t *)d->data)[i]);
    case PICVR_VOXEL_FLOAT64: return ((const double *)d->data)[i];
    default: return ((const float *)d->data)[i];
    }
}

static double picvr_normalize_value(picvr_value_map m, double v) {
    /* Rule: a degenerate range (constant float data) maps v to clamp(v, 0, 1). */
    double x = m.hi > m.lo ? (v - m.lo) / (m.hi - m.lo) : v;
    return x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x;
}

/* desc's placement (picvr_volume_desc.direction, has_origin, origin) as rot and shift
   (picvr_scene), for a box of size `size` centred in the volume's frame.  Rules: all-zero
   direction is the identity; a non-finite value is NON_FINITE; axes must be unit and
   pairwise orthogonal within 1e-3 (INVALID_ARGUMENT: a singular or sheared matrix has
   no rigid inverse), and are then made exactly orthonormal (Gram-Schmidt in double, the
   third axis the cross product with the given handedness) so that mapping a direction
   and back keeps its length. */
static picvr_status picvr_volume_placement(const picvr_volume_desc *d, const double size[3], float rot[9],
                                           float shift[3], int *reflected) {
    double a[3][3];
    int zero = 1;
    for (int i = 0; i < 9; i++) {
        if (!isfinite(d->direction[i])) return PICVR_ERROR_NON_FINITE;
        if (d->direction[i] != 0.0f) zero = 0;
        a[i / 3][i % 3] = d->direction[i];
    }
    if (d->has_origin && !picvr_finite3(d->origin)) return PICVR_ERROR_NON_FINITE;
    if (zero) for (int i = 0; i < 3; i++) for (int c = 0; c < 3; c++) a[i][c] = i == c;
    for (int i = 0; i < 3; i++) {
        double len = sqrt(a[i][0] * a[i][0] + a[i][1] * a[i][1] + a[i][2] * a[i][2]);
        if (!(fabs(len - 1.0) <= 1e-3)) return PICVR_ERROR_INVALID_ARGUMENT;
        for (int j = 0; j < i; j++)
            if (!(fabs(a[i][0] * a[j][0] + a[i][1] * a[j][1] + a[i][2] * a[j][2]) <= 1e-3)) return PICVR_ERROR_INVALID_ARGUMENT;
    }
    double x[3], y[3], z[3], dxy = 0.0;
    double lx = sqrt(a[0][0] * a[0][0] + a[0][1] * a[0][1] + a[0][2] * a[0][2]);
    for (int c = 0; c < 3; c++) { x[c] = a[0][c] / lx; dxy += x[c] * a[1][c]; }
    for (int c = 0; c < 3; c++) y[c] = a[1][c] - dxy * x[c];
    double ly = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
    for (int c = 0; c < 3; c++) y[c] /= ly;
    z[0] = x[1] * y[2] - x[2] * y[1];
    z[1] = x[2] * y[0] - x[0] * y[2];
    z[2] = x[0] * y[1] - x[1] * y[0];
    double hand = z[0] * a[2][0] + z[1] * a[2][1] + z[2] * a[2][2];
    *reflected = hand < 0.0;
    for (int c = 0; c < 3; c++) {
        if (*reflected) z[c] = -z[c];
        rot[3 * c + 0] = (float)x[c];   /* column a of rot is axis a in world space */
        rot[3 * c + 1] = (float)y[c];
        rot[3 * c + 2] = (float)z[c];
    }
    for (int r = 0; r < 3; r++) {
        /* voxel (0,0,0)'s centre is at -size/2 + spacing/2 in the volume's frame */
        double t = 0.0;
        if (d->has_origin) {
            t = d->origin[r];
            for (int c = 0; c < 3; c++) {
                double sp = d->spacing[c] > 0.0f ? d->spacing[c] : 1.0;
                t -= rot[3 * r + c] * (-0.5 * size[c] + 0.5 * sp);
            }
        }
        if (!(fabs(t) < FLT_MAX)) return PICVR_ERROR_INVALID_ARGUMENT;
        shift[r] = (float)t;
    }
    return PICVR_OK;
}

static picvr_status picvr_validate_volume(picvr_context *ctx, const picvr_volume_desc *d, size_t *bytes) {
    if (!d || !d->data) return PICVR_ERROR_NULL_POINTER;
    if (d->dims[0] == 0 || d->dims[1] == 0 || d->dims[2] == 0) return PICVR_ERROR_INVALID_DIMENSIONS;
    size_t bpv = picvr_voxel_bytes(d->type);
    if (!bpv) return PICVR_ERROR_UNSUPPORTED_TYPE;
    if (!picvr_finite3(d->spacing) || !isfinite(d->value_min) || !isfinite(d->value_max)) return PICVR_ERROR_NON_FINITE;
    for (int i = 0; i < 3; i++)
        if (d->spacing[i] < 0.0f) return PICVR_ERROR_INVALID_ARGUMENT;
    if (d->value_max < d->value_min) return PICVR_ERROR_INVALID_ARGUMENT;
    uint64_t n = d->dims[0];
    for (int i = 1; i < 3; i++) {
        if (n > UINT64_MAX / d->dims[i]) return PICVR_ERROR_SIZE_OVERFLOW;
        n *= d->dims[i];
    }
    if (n > (uint64_t)SIZE_MAX / bpv) return PICVR_ERROR_SIZE_OVERFLOW;
    uint32_t lim = ctx->vk.props.limits.maxImageDimension3D;
    if (d->dims[0] > lim || d->dims[1] > lim || d->dims[2] > lim) {
        picvr_log_message(ctx, PICVR_LOG_WARNING, "volume exceeds maxImageDimension3D = %u", lim);
        return PICVR_ERROR_SIZE_OVERFLOW;
    }
    *bytes = (size_t)n * bpv;
    return PICVR_OK;
}

/* Data range for normalization, and (the types stored as float32) the finiteness check:
   every such voxel must be finite, a float64 one within float's range. */
static picvr_status picvr_volume_range(const picvr_volume_desc *d, size_t n, picvr_value_map *m) {
    int given = d->value_min != 0.0f || d->value_max != 0.0f;
    if (!picvr_stored_as_float(d->type)) {
        static const double type_lo[] = {0, 0, 0, 0, -128.0, -32768.0}, type_hi[] = {0, 255.0, 65535.0, 0, 127.0, 32767.0};
        m->lo = given ? d->value_min : type_lo[d->type];
        m->hi = given ? d->value_max : type_hi[d->type];
        return PICVR_OK;
    }
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        double v = picvr_voxel_at(d, i);
        if (!isfinite(v) || fabs(v) > FLT_MAX) return PICVR_ERROR_NON_FINITE;
        if (v < lo) lo = v;
        if (v > hi) hi = v;
    }
    if (d->value_min != 0.0f || d->value_max != 0.0f) { lo = d->value_min; hi = d->value_max; }
    m->lo = lo; m->hi = hi;
    return PICVR_OK;
}

/* Bricks of `brick` voxels, at most MAX_GRID per axis; min/max of the normalized
   value over each brick plus a one-voxel apron (trilinear filtering reaches it). */
static picvr_status picvr_build_bricks(picvr_context *ctx, const picvr_volume_desc *d, picvr_value_map m,
                                 uint32_t brick, const uint32_t grid[3], float **bmin_out, float **bmax_out) {
    size_t cells = (size_t)grid[0] * grid[1] * grid[2];
    float *bmin = (float *)picvr_host_alloc(&ctx->config.allocator, cells * sizeof(float));
    float *bmax = (float *)picvr_host_alloc(&ctx->config.allocator, cells * sizeof(float));
    if (!bmin || !bmax) { picvr_host_free(&ctx->config.allocator, bmin); picvr_host_free(&ctx->config.allocator, bmax); return PICVR_ERROR_OUT_OF_HOST_MEMORY; }
    const uint32_t *dim = d->dims;
    for (uint32_t cz = 0; cz < grid[2]; cz++)
        for (uint32_t cy = 0; cy < grid[1]; cy++)
            for (uint32_t cx = 0; cx < grid[0]; cx++) {
                uint32_t c[3] = {cx, cy, cz}, lo[3], hi[3];
                for (int a = 0; a < 3; a++) {
                    uint32_t l = c[a] * brick, h = l + brick;   /* [l, h] with the apron */
                    lo[a] = l > 0 ? l - 1 : 0;
                    hi[a] = h < dim[a] - 1 ? h : dim[a] - 1;
                    if (lo[a] > hi[a]) lo[a] = hi[a];
                }
                double vmin = INFINITY, vmax = -INFINITY;
                for (uint32_t z = lo[2]; z <= hi[2]; z++)
                    for (uint32_t y = lo[1]; y <= hi[1]; y++)
                        for (uint32_t x = lo[0]; x <= hi[0]; x++) {
                            double v = picvr_voxel_at(d, x + (size_t)dim[0] * (y + (size_t)dim[1] * z));
                            if (v < vmin) vmin = v;
                            if (v > vmax) vmax = v;
                        }
                size_t i = cx + (size_t)grid[0] * (cy + (size_t)grid[1] * cz);
                bmin[i] = (float)picvr_normalize_value(m, vmin);
                bmax[i] = (float)picvr_normalize_value(m, vmax);
            }
    *bmin_out = bmin;
    *bmax_out = bmax;
    return PICVR_OK;
}

/* One slab's voxels [first, first + cnt) into the staging memory dst in the stored form
   (picvr_stored_as_float; R16_UNORM float data normalized by m). */
static void picvr_convert_voxels(const picvr_volume_desc *d, VkFormat fmt, picvr_value_map m, size_t first,
                                 size_t cnt, void *dst) {
    const uint8_t *src = (const uint8_t *)d->data + first * picvr_voxel_bytes(d->type);
    if (d->type == PICVR_VOXEL_UINT8 || d->type == PICVR_VOXEL_UINT16 ||
        (d->type == PICVR_VOXEL_FLOAT32 && fmt == VK_FORMAT_R32_SFLOAT)) {
        memcpy(dst, src, cnt * picvr_voxel_bytes(d->type));
        return;
    }
    for (size_t i = 0; i < cnt; i++) {
        double v = picvr_voxel_at(d, first + i);
        if (d->type == PICVR_VOXEL_INT8) ((uint8_t *)dst)[i] = (uint8_t)(v + 128.0);
        else if (d->type == PICVR_VOXEL_INT16) ((uint16_t *)dst)[i] = (uint16_t)(v + 32768.0);
        else if (fmt == VK_FORMAT_R16_UNORM) ((uint16_t *)dst)[i] = (uint16_t)lrint(picvr_normalize_value(m, v) * 65535.0);
        else ((float *)dst)[i] = (float)v;
    }
}

/* The bytes per voxel of the 3D image of type t. */
static size_t picvr_stored_bytes(const picvr_context *ctx, picvr_voxel_type t) {
    if (!picvr_stored_as_float(t)) return picvr_voxel_bytes(t);
    return ctx->vk.float_volume_format == VK_FORMAT_R16_UNORM ? 2 : 4;
}

/* Copies voxels into the 3D image in z-slabs of at most STAGING_CHUNK bytes, in their
   stored form (picvr_convert_voxels). */
static picvr_status picvr_upload_voxels(picvr_context *ctx, picvr_image *im, const picvr_volume_desc *d,
                                  VkFormat fmt, picvr_value_map m) {
    size_t out_bpv = picvr_stored_bytes(ctx, d->type);
    size_t slice_out = (size_t)d->dims[0] * d->dims[1] * out_bpv;
    uint32_t slab = (uint32_t)(PICVR_STAGING_CHUNK / slice_out);
    if (slab == 0) slab = 1;
    if (slab > d->dims[2]) slab = d->dims[2];
    picvr_buffer staging;
    picvr_status s = picvr_buffer_create(ctx, &staging, (VkDeviceSize)slab * slice_out, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 1);
    if (s) return s;
    size_t slice = (size_t)d->dims[0] * d->dims[1];
    for (uint32_t z0 = 0; z0 < d->dims[2] && !s; z0 += slab) {
        uint32_t nz = d->dims[2] - z0 < slab ? d->dims[2] - z0 : slab;
        picvr_convert_voxels(d, fmt, m, (size_t)z0 * slice, (size_t)nz * slice, staging.mapped);
        picvr_buffer_flush(ctx, &staging);
        if ((s = picvr_cmd_begin(ctx))) break;
        picvr_image_barrier(ctx, im->img, z0 == 0 ? VK_IMAGE_LAYOUT_UNDEFINED : VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                      VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
        VkBufferImageCopy region;
        memset(&region, 0, sizeof region);
        region.imageSubresource = picvr_color_layers();
        region.imageOffset.z = (int32_t)z0;
        region.imageExtent = picvr_extent(d->dims[0], d->dims[1], nz);
        vkCmdCopyBufferToImage(ctx->vk.cmd, staging.buf, im->img, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
        if (z0 + nz >= d->dims[2])
            picvr_image_barrier(ctx, im->img, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
        s = picvr_cmd_submit_wait(ctx);
    }
    picvr_buffer_destroy(ctx, &staging);
    return s;
}

/* scale/offset so that clamp(tex * scale + offset, 0, 1) is the normalized value: the
   texel times its format's unit, less the signed types' bias, is the data value. */
static void picvr_shader_value_map(picvr_context *ctx, const picvr_volume_desc *d, VkFormat fmt, picvr_value_map m) {
    double unit = fmt == VK_FORMAT_R8_UNORM ? 255.0 : fmt == VK_FORMAT_R16_UNORM ? 65535.0 : 1.0;
    double scale = 1.0, offset = 0.0;
    if (!(picvr_stored_as_float(d->type) && fmt == VK_FORMAT_R16_UNORM) && m.hi > m.lo) {
        scale = unit / (m.hi - m.lo);
        offset = -(m.lo + picvr_voxel_bias(d->type)) / (m.hi - m.lo);
    }
    ctx->scene.gpu.value_map[0] = (float)scale;
    ctx->scene.gpu.value_map[1] = (float)offset;
}

/* Every world-space input packed again in the volume's frame (a volume with another
   placement was uploaded).  A clip plane that no longer maps to finite numbers (a far
   origin) is dropped with a warning: the volume is in place, and a context with a
   half-applied clip would be worse. */
static void picvr_pack_world(picvr_context *ctx) {
    if (ctx->scene.has_camera) picvr_pack_camera(ctx);
    picvr_place_lights(ctx);
    picvr_pack_env_basis(ctx);
    if (!picvr_pack_clip_planes(&ctx->scene, &ctx->scene.clip, &ctx->scene.gpu)) {
        picvr_log_message(ctx, PICVR_LOG_WARNING, "clip planes out of float range in the new volume's frame: clipping off");
        memset(&ctx->scene.clip, 0, sizeof ctx->scene.clip);
        ctx->scene.gpu.clip_count = 0;
    }
}

picvr_status picvr_upload_volume(picvr_context *ctx, const picvr_volume_desc *desc) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    size_t bytes;
    picvr_status s = picvr_validate_volume(ctx, desc, &bytes);
    if (s) return s;
    float rot[9], shift[3];
    int reflected;
    {   /* the world box (dims * spacing, and its diagonal) must fit a float */
        double diag2 = 0.0, size[3];
        for (int i = 0; i < 3; i++) {
            size[i] = (double)desc->dims[i] * (desc->spacing[i] > 0.0f ? desc->spacing[i] : 1.0f);
            diag2 += size[i] * size[i];
        }
        if (!(sqrt(diag2) < FLT_MAX)) return PICVR_ERROR_INVALID_ARGUMENT;
        if ((s = picvr_volume_placement(desc, size, rot, shift, &reflected))) return s;
    }
    {   /* a volume larger than the device can allocate (picvr_volume_alloc_limit) is
           refused before anything is allocated */
        VkDeviceSize dev = (VkDeviceSize)(bytes / picvr_voxel_bytes(desc->type)) * picvr_stored_bytes(ctx, desc->type);
        if (ctx->vk.max_volume_bytes && dev > ctx->vk.max_volume_bytes) {
            picvr_log_message(ctx, PICVR_LOG_WARNING, "volume of %llu bytes exceeds the device's allocation limit", (unsigned long long)dev);
            return PICVR_ERROR_OUT_OF_DEVICE_MEMORY;
        }
    }
    picvr_value_map m;
    if ((s = picvr_volume_range(desc, bytes / picvr_voxel_bytes(desc->type), &m))) return s;

    uint32_t maxdim = desc->dims[0];
    for (int i = 1; i < 3; i++) if (desc->dims[i] > maxdim) maxdim = desc->dims[i];
    uint32_t brick = 8;   /* smaller bricks cost DDA steps, larger ones null collisions (docs/performance.md) */
    while ((maxdim + brick - 1) / brick > PICVR_MAX_GRID) brick *= 2;
    uint32_t grid[3];
    for (int i = 0; i < 3; i++) grid[i] = (desc->dims[i] + brick - 1) / brick;

    VkFormat fmt = picvr_stored_as_float(desc->type) ? ctx->vk.float_volume_format
                 : picvr_voxel_bytes(desc->type) == 1 ? VK_FORMAT_R8_UNORM : VK_FORMAT_R16_UNORM;
    /* Build the new volume beside the old one; swap only when everything succeeded. */
    picvr_image vol;
    picvr_buffer maj;
    float *bmin = NULL, *bmax = NULL;
    size_t cells = (size_t)grid[0] * grid[1] * grid[2];
    if ((s = picvr_image_create(ctx, &vol, VK_IMAGE_TYPE_3D, fmt, desc->dims[0], desc->dims[1], desc->dims[2]))) return s;
    if ((s = picvr_buffer_create(ctx, &maj, 3 * cells * sizeof(float),
                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0))) {
        picvr_image_destroy(ctx, &vol);
        return s;
    }
    s = picvr_upload_voxels(ctx, &vol, desc, fmt, m);
    if (!s) s = picvr_build_bricks(ctx, desc, m, brick, grid, &bmin, &bmax);
    if (s) { picvr_image_destroy(ctx, &vol); picvr_buffer_destroy(ctx, &maj); return s; }

    picvr_image_destroy(ctx, &ctx->scene.volume);
    picvr_buffer_destroy(ctx, &ctx->scene.majorant);
    picvr_host_free(&ctx->config.allocator, ctx->scene.brick_min);
    picvr_host_free(&ctx->config.allocator, ctx->scene.brick_max);
    ctx->scene.volume = vol;
    ctx->scene.majorant = maj;
    ctx->scene.brick_min = bmin;
    ctx->scene.brick_max = bmax;
    float min_spacing = FLT_MAX;
    for (int i = 0; i < 3; i++) {
        ctx->scene.dims[i] = desc->dims[i];
        ctx->scene.spacing[i] = desc->spacing[i] > 0.0f ? desc->spacing[i] : 1.0f;
        ctx->scene.grid[i] = grid[i];
        float size = ctx->scene.dims[i] * ctx->scene.spacing[i];
        ctx->scene.gpu.box_min[i] = -0.5f * size;
        ctx->scene.gpu.box_size[i] = size;
        ctx->scene.gpu.cell_size[i] = brick * ctx->scene.spacing[i];
        ctx->scene.gpu.grid[i] = grid[i];
        ctx->scene.gpu.dims[i] = desc->dims[i];
        if (ctx->scene.spacing[i] < min_spacing) min_spacing = ctx->scene.spacing[i];
    }
    ctx->scene.gpu.min_spacing = min_spacing;
    ctx->scene.gpu.bound_radius = 0.5f * (float)picvr_len3(ctx->scene.gpu.box_size);
    memcpy(ctx->scene.rot, rot, sizeof rot);
    memcpy(ctx->scene.shift, shift, sizeof shift);
    ctx->scene.reflected = reflected;
    picvr_pack_world(ctx);
    picvr_update_equiangular(ctx);
    picvr_shader_value_map(ctx, desc, fmt, m);
    ctx->scene.has_volume = 1;
    ctx->pipes.descriptors_dirty = 1;
    s = picvr_update_majorant(ctx);
    return picvr_light_state_changed(ctx, s);
}

picvr_status picvr_volume_box(const picvr_context *ctx, float box_min[3], float box_max[3]) {
    if (!ctx || !box_min || !box_max) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (!ctx->scene.has_volume) return PICVR_ERROR_NOT_READY;
    /* the world box around the eight corners: centre shift, half extent sum |rot| h */
    for (int r = 0; r < 3; r++) {
        double e = 0.0;
        for (int c = 0; c < 3; c++) e += fabs((double)ctx->scene.rot[3 * r + c]) * 0.5 * ctx->scene.gpu.box_size[c];
        box_min[r] = (float)(ctx->scene.shift[r] - e);
        box_max[r] = (float)(ctx->scene.shift[r] + e);
    }
    return PICVR_OK;
}
