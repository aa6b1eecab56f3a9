/* host/majorant.c - the majorant grid for delta tracking: per brick of voxels the
 * largest extinction the transfer function gives over the brick's value range (a
 * sparse range-maximum table of the opacity column), and the distance to the nearest
 * non-empty brick for empty-space skipping.  Part of picvr_vk.c; uses util, vulkan. */

/* Maximum (take_min 0) or minimum (1) opacity table entry over [lo, hi] by a sparse
   table (O(1) per query). */
static float picvr_pick(float a, float b, int take_min) { return take_min ? fminf(a, b) : fmaxf(a, b); }

static void picvr_range_build(picvr_range_table *rm, const float *table, int take_min) {
    memset(rm, 0, sizeof *rm);   /* entries past the end of a level are never read */
    for (int i = 0; i < PICVR_TF_SIZE; i++) rm->level[0][i] = table[i * 4 + 3];
    for (int k = 1; k < 13; k++)
        for (int i = 0; i + (1 << k) <= PICVR_TF_SIZE; i++)
            rm->level[k][i] = picvr_pick(rm->level[k - 1][i], rm->level[k - 1][i + (1 << (k - 1))], take_min);
}

static float picvr_range_query(const picvr_range_table *rm, int lo, int hi, int take_min) {
    int k = 0;
    while ((2 << k) <= hi - lo + 1) k++;
    return picvr_pick(rm->level[k][lo], rm->level[k][hi - (1 << k) + 1], take_min);
}

/* Chebyshev distance (in cells, capped at 255) from each cell to the nearest cell
   with a non-zero majorant: 0 for non-empty cells.  Exact for the Chebyshev metric
   with two chamfer passes over the 26-neighbourhood.  The shader's empty_skip()
   uses it to jump over empty space. */
static void picvr_empty_distance(const uint32_t g[3], const float *maj, float *dist) {
    long nx = g[0], ny = g[1], nz = g[2];
    for (long i = 0; i < nx * ny * nz; i++) dist[i] = maj[i] > 0.0f ? 0.0f : 255.0f;
    for (int pass = 0; pass < 2; pass++) {
        int dir = pass == 0 ? 1 : -1;
        for (long zz = 0; zz < nz; zz++)
            for (long yy = 0; yy < ny; yy++)
                for (long xx = 0; xx < nx; xx++) {
                    long x = dir > 0 ? xx : nx - 1 - xx, y = dir > 0 ? yy : ny - 1 - yy, z = dir > 0 ? zz : nz - 1 - zz;
                    float *c = &dist[x + nx * (y + ny * z)];
                    /* neighbours already visited in this pass: 13 of the 26 */
                    for (int dz = -1; dz <= 0; dz++)
                        for (int dy = -1; dy <= 1; dy++)
                            for (int dx = -1; dx <= 1; dx++) {
                                if (dz == 0 && (dy > 0 || (dy == 0 && dx >= 0))) continue;
                                long qx = x + dir * dx, qy = y + dir * dy, qz = z + dir * dz;
                                if (qx < 0 || qy < 0 || qz < 0 || qx >= nx || qy >= ny || qz >= nz) continue;
                                float v = dist[qx + nx * (qy + ny * qz)] + 1.0f;
                                if (v < *c) *c = v;
                            }
                }
    }
}

/* Majorant per brick: D times the largest table opacity over the brick's value range
   (one table entry of margin each side because filtering blends neighbours), times
   1 + 1e-3 against float rounding of the filtered lookups.  Minorant, the control of
   residual ratio tracking: D times the smallest opacity over the same range, times
   1 - 1e-3 (0 where the range reaches opacity 0).  The buffer holds the majorants, the
   empty-space distances and the minorants, one part each (shaders/majorant.glsl). */
static picvr_status picvr_update_majorant(picvr_context *ctx) {
    if (!ctx->scene.has_volume) return PICVR_OK;
    size_t cells = (size_t)ctx->scene.grid[0] * ctx->scene.grid[1] * ctx->scene.grid[2];
    float *maj = (float *)picvr_host_alloc(&ctx->config.allocator, 3 * cells * sizeof(float));
    if (!maj) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    const picvr_range_table *rm = ctx->scene.tf_rm, *rmin = ctx->scene.tf_rmin;
    double diag = sqrt((double)ctx->scene.gpu.cell_size[0] * ctx->scene.gpu.cell_size[0] +
                       (double)ctx->scene.gpu.cell_size[1] * ctx->scene.gpu.cell_size[1] +
                       (double)ctx->scene.gpu.cell_size[2] * ctx->scene.gpu.cell_size[2]);
    ctx->scene.use_fine = 0;
    float *mino = maj + 2 * cells;
    size_t medium = 0, controlled = 0;
    for (size_t c = 0; c < cells; c++) {
        int lo = (int)floorf(ctx->scene.brick_min[c] * (PICVR_TF_SIZE - 1)) - 1;
        int hi = (int)ceilf(ctx->scene.brick_max[c] * (PICVR_TF_SIZE - 1)) + 1;
        lo = lo < 0 ? 0 : lo;
        hi = hi > PICVR_TF_SIZE - 1 ? PICVR_TF_SIZE - 1 : hi;
        double m = (double)ctx->scene.density * picvr_range_query(rm, lo, hi, 0) * (1.0 + 1e-3);
        double n = (double)ctx->scene.density * picvr_range_query(rmin, lo, hi, 1) * (1.0 - 1e-3);
        maj[c] = m > FLT_MAX ? FLT_MAX : (float)m;
        mino[c] = n > FLT_MAX ? FLT_MAX : (float)n;
        if (mino[c] > maj[c]) mino[c] = maj[c];
        medium += maj[c] > 0.0f;
        controlled += mino[c] > 0.0f;
        if (m * diag > PICVR_FINE_THRESHOLD) ctx->scene.use_fine = 1;
    }
    /* Residual ratio tracking pays where bricks have a control; where (nearly) every
       brick's range reaches opacity 0 (CT: tissue beside air) it is ratio tracking with
       one more lookup per cell, so the variant leaves it out (docs/sampling.md). */
    ctx->scene.use_control = (double)controlled >= PICVR_CONTROL_FRACTION * (double)medium && controlled > 0;
    picvr_empty_distance(ctx->scene.grid, maj, maj + cells);
    picvr_status s = picvr_upload_buffer(ctx, &ctx->scene.majorant, maj, 3 * cells * sizeof(float));
    picvr_host_free(&ctx->config.allocator, maj);
    return s;
}
