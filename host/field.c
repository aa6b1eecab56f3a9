/* host/field.c - the light field (PICVR_RENDER_FIELD; paper 002 carried to volumes,
 * docs/field.md): its configuration, its kernels and buffers (made at the first step
 * that needs them, so a Monte-Carlo context holds none), the build (classification, the
 * lights' transmittance, the passes until the bounces or the tolerance are reached) and
 * the image rendered from it.  Part of picvr_vk.c; uses util, vulkan, pipelines, image. */

static picvr_status picvr_resolve_field_config(const picvr_field_config *in, int cache_on, picvr_field_config *out) {
    picvr_field_config c = *in;
    if ((unsigned)c.mode > PICVR_RENDER_FIELD_MC) return PICVR_ERROR_INVALID_ARGUMENT;
    if (!c.mode) c.mode = PICVR_RENDER_MC;
    if (!c.grid_ratio) c.grid_ratio = 8;
    if (!c.directions) c.directions = 32;
    if (!c.max_passes) c.max_passes = 64;
    if (c.tolerance == 0.0f) c.tolerance = 1e-3f;
    if (c.step_voxels == 0.0f) c.step_voxels = 2.0f;
    if (!c.prior_samples) c.prior_samples = 8;
    if (!isfinite(c.tolerance) || !isfinite(c.step_voxels)) return PICVR_ERROR_NON_FINITE;
    if (c.grid_ratio > 8 || c.directions < 8 || c.directions > 1024 || (c.directions & 1u) ||
        c.max_passes > PICVR_FIELD_MAX_PASSES || !(c.tolerance > 0.0f && c.tolerance < 1.0f) ||
        !(c.step_voxels >= 0.125f && c.step_voxels <= 64.0f) || c.prior_samples > 1024)
        return PICVR_ERROR_INVALID_ARGUMENT;
    /* the field renders without the cache's procedures */
    if (c.mode >= PICVR_RENDER_FIELD && cache_on) return PICVR_ERROR_INVALID_ARGUMENT;
    *out = c;
    return PICVR_OK;
}

/* The push constants of every field kernel (shaders/field.glsl, FieldPush). */
typedef struct picvr_field_push {
    uint32_t n[4];
    float cell[4];
    uint32_t half_dirs, dir_begin, dir_end, flags, pass_index, samples;
    float step;
    uint32_t prior;   /* field_render: the samples the image counts as in each pixel */
} picvr_field_push;

#define PICVR_FIELD_SOURCE 1u
#define PICVR_FIELD_DELTA_M 2u
#define PICVR_FIELD_ADD 4u
#define PICVR_FIELD_LAST 8u
#define PICVR_FIELD_MULTIPLE 16u
/* Passes recorded per submission between reads of the convergence measure. */
#define PICVR_FIELD_PASSES_PER_SUBMIT 4u
/* llvmpipe's bound on one invocation's loop iterations (../shared/LAVAPIPE.md), with
   room: each dispatch of a pass takes as many directions as stay under it. */
#define PICVR_FIELD_LOOP_BUDGET 60000u

static void picvr_field_pipelines_destroy(picvr_context *ctx) {
    for (int k = 0; k < PICVR_FIELD_KERNELS; k++)
        if (ctx->field.pipe[k]) { vkDestroyPipeline(ctx->vk.device, ctx->field.pipe[k], NULL); ctx->field.pipe[k] = VK_NULL_HANDLE; }
}

static void picvr_field_buffers_destroy(picvr_context *ctx) {
    picvr_field *f = &ctx->field;
    picvr_buffer_destroy(ctx, &f->cells);
    picvr_buffer_destroy(ctx, &f->light_t);
    picvr_buffer_destroy(ctx, &f->field[0]);
    picvr_buffer_destroy(ctx, &f->field[1]);
    picvr_buffer_destroy(ctx, &f->change);
    picvr_buffer_destroy(ctx, &f->view);
    memset(f->n, 0, sizeof f->n);
    f->lights = 0;
}

static void picvr_field_destroy(picvr_context *ctx) {
    picvr_field *f = &ctx->field;
    VkDevice d = ctx->vk.device;
    if (!d) return;
    picvr_field_pipelines_destroy(ctx);
    picvr_field_buffers_destroy(ctx);
    for (int k = 0; k < PICVR_FIELD_KERNELS; k++)
        if (f->module[k]) vkDestroyShaderModule(d, f->module[k], NULL);
    if (f->pool) vkDestroyDescriptorPool(d, f->pool, NULL);
    if (f->layout) vkDestroyPipelineLayout(d, f->layout, NULL);
    if (f->set_layout) vkDestroyDescriptorSetLayout(d, f->set_layout, NULL);
    int on = f->on;
    memset(f, 0, sizeof *f);
    f->on = on;
}

/* The set layout, the pipeline layout (set 0 the main one), the pool, the two sets and
   the modules, once. */
static picvr_status picvr_field_make_layouts(picvr_context *ctx) {
    picvr_field *f = &ctx->field;
    if (f->layout) return PICVR_OK;
    picvr_status s0 = picvr_storage_set_layout(ctx, PICVR_FIELD_BINDINGS, &f->set_layout);
    if (s0) return s0;
    VkDescriptorSetLayout sets[2] = {ctx->pipes.set_layout, f->set_layout};
    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(picvr_field_push)};
    VkPipelineLayoutCreateInfo pl;
    PICVR_VK_INIT(pl, VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    pl.setLayoutCount = 2;
    pl.pSetLayouts = sets;
    pl.pushConstantRangeCount = 1;
    pl.pPushConstantRanges = &pcr;
    PICVR_VK_TRY(ctx, vkCreatePipelineLayout(ctx->vk.device, &pl, NULL, &f->layout));
    VkDescriptorPoolSize size = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2 * PICVR_FIELD_BINDINGS};
    VkDescriptorPoolCreateInfo pi;
    PICVR_VK_INIT(pi, VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    pi.maxSets = 2;
    pi.poolSizeCount = 1;
    pi.pPoolSizes = &size;
    PICVR_VK_TRY(ctx, vkCreateDescriptorPool(ctx->vk.device, &pi, NULL, &f->pool));
    VkDescriptorSetLayout both[2] = {f->set_layout, f->set_layout};
    VkDescriptorSetAllocateInfo ai;
    PICVR_VK_INIT(ai, VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    ai.descriptorPool = f->pool;
    ai.descriptorSetCount = 2;
    ai.pSetLayouts = both;
    PICVR_VK_TRY(ctx, vkAllocateDescriptorSets(ctx->vk.device, &ai, f->set));
    const uint32_t *code[PICVR_FIELD_KERNELS] = {picvr_spv_field_classify, picvr_spv_field_light, picvr_spv_field_scatter,
                                                 picvr_spv_field_view, picvr_spv_field_render};
    size_t size_of[PICVR_FIELD_KERNELS] = {sizeof picvr_spv_field_classify, sizeof picvr_spv_field_light,
                                           sizeof picvr_spv_field_scatter, sizeof picvr_spv_field_view,
                                           sizeof picvr_spv_field_render};
    picvr_status s = PICVR_OK;
    for (int k = 0; k < PICVR_FIELD_KERNELS && !s; k++) s = picvr_create_shader(ctx, code[k], size_of[k], &f->module[k]);
    return s;
}

/* The pipelines, specialized as the scene's rendering variant is (its clip planes,
   phase function, environment map); made again when that changes. */
static picvr_status picvr_field_make_pipelines(picvr_context *ctx) {
    picvr_field *f = &ctx->field;
    uint32_t key = picvr_variant_key(ctx, PICVR_PROC_RENDER, 0, 0);
    if (f->pipe[0] && f->key == key) return PICVR_OK;
    picvr_field_pipelines_destroy(ctx);
    picvr_variant_build v;
    memset(&v, 0, sizeof v);
    picvr_build_variant(ctx, PICVR_PROC_RENDER, key, &v);
    picvr_pipeline_job job[PICVR_FIELD_KERNELS];
    for (int k = 0; k < PICVR_FIELD_KERNELS; k++) picvr_pipeline_job_init(&job[k], f->module[k], f->layout, &v.spec);
    picvr_status s = picvr_make_pipelines(ctx, job, PICVR_FIELD_KERNELS);
    if (s) return s;
    for (int k = 0; k < PICVR_FIELD_KERNELS; k++) f->pipe[k] = job[k].pipe;
    f->key = key;
    return PICVR_OK;
}

/* Scatter events per path, the camera's included (PICVR_FIELD_MAX_PASSES: unlimited). */
static uint32_t picvr_field_bounces(const picvr_context *ctx) {
    uint32_t b = ctx->scene.scattering.max_bounces;
    if (b == PICVR_BOUNCES_UNLIMITED) return PICVR_FIELD_MAX_PASSES;
    return b >= PICVR_FIELD_MAX_PASSES - 1 ? PICVR_FIELD_MAX_PASSES : b + 1;
}

/* Whether the scene needs the scattered field at all: more than one scatter event, or
   a background that lights the medium.  Without it (single scattering of the lights
   alone) the passes are left out and the field's buffers are placeholders. */
static int picvr_field_scattered(const picvr_context *ctx) {
    const float *bg = ctx->scene.gpu.background;
    return picvr_field_bounces(ctx) > 1 || ctx->scene.use_env || bg[0] > 0.0f || bg[1] > 0.0f || bg[2] > 0.0f;
}

/* Cells per axis: the volume's voxels over the grid ratio, rounded up. */
static void picvr_field_grid(const picvr_context *ctx, uint32_t n[3]) {
    uint32_t r = ctx->config.field.grid_ratio;
    for (int i = 0; i < 3; i++) n[i] = (ctx->scene.dims[i] + r - 1) / r;
}

/* The buffers for the scene's grid and lights, and both sets pointed at them. */
static picvr_status picvr_field_make_buffers(picvr_context *ctx) {
    picvr_field *f = &ctx->field;
    uint32_t n[3];
    picvr_field_grid(ctx, n);
    uint32_t lights = ctx->scene.light_count ? ctx->scene.light_count : 1u;
    int scattered = picvr_field_scattered(ctx);
    if (f->cells.buf && !memcmp(n, f->n, sizeof n) && f->lights == lights && f->scattered == scattered) return PICVR_OK;
    picvr_field_buffers_destroy(ctx);
    uint64_t cells = (uint64_t)n[0] * n[1] * n[2];
    VkDeviceSize field = scattered ? 48 * cells : 16;   /* a placeholder when no pass runs */
    VkDeviceSize sizes[PICVR_FIELD_BINDINGS] = {32 * cells, 16 * cells * lights, field, field,
                                                8 * PICVR_FIELD_MAX_PASSES, 16 * cells};
    for (uint32_t i = 0; i < PICVR_FIELD_BINDINGS; i++)
        if (sizes[i] > ctx->vk.props.limits.maxStorageBufferRange) return PICVR_ERROR_SIZE_OVERFLOW;
    VkBufferUsageFlags usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                               VK_BUFFER_USAGE_TRANSFER_SRC_BIT;   /* picvr_read_field copies from it */
    picvr_buffer *bufs[PICVR_FIELD_BINDINGS] = {&f->cells, &f->light_t, &f->field[0], &f->field[1], &f->change, &f->view};
    picvr_status s = PICVR_OK;
    for (uint32_t i = 0; i < PICVR_FIELD_BINDINGS && !s; i++)
        s = picvr_buffer_create(ctx, bufs[i], sizes[i], usage, i == 4);   /* the change is read on the host */
    if (s) { picvr_field_buffers_destroy(ctx); return s; }
    memcpy(f->n, n, sizeof n);
    f->lights = lights;
    f->scattered = scattered;
    f->warm = 0;
    for (uint32_t set = 0; set < 2; set++) {
        VkDescriptorBufferInfo info[PICVR_FIELD_BINDINGS];
        VkWriteDescriptorSet w[PICVR_FIELD_BINDINGS];
        picvr_buffer *order[PICVR_FIELD_BINDINGS] = {&f->cells, &f->light_t, &f->field[set], &f->field[1 - set],
                                                     &f->change, &f->view};
        for (uint32_t i = 0; i < PICVR_FIELD_BINDINGS; i++) {
            info[i].buffer = order[i]->buf;
            info[i].offset = 0;
            info[i].range = VK_WHOLE_SIZE;
            PICVR_VK_INIT(w[i], VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
            w[i].dstSet = f->set[set];
            w[i].dstBinding = i;
            w[i].descriptorCount = 1;
            w[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
            w[i].pBufferInfo = &info[i];
        }
        vkUpdateDescriptorSets(ctx->vk.device, PICVR_FIELD_BINDINGS, w, 0, NULL);
    }
    return PICVR_OK;
}

static picvr_field_push picvr_field_push_base(const picvr_context *ctx) {
    picvr_field_push p;
    memset(&p, 0, sizeof p);
    const picvr_field *f = &ctx->field;
    for (int i = 0; i < 3; i++) {
        p.n[i] = f->n[i];
        p.cell[i] = ctx->scene.gpu.box_size[i] / (float)f->n[i];
    }
    p.n[3] = f->n[0] * f->n[1] * f->n[2];
    p.half_dirs = ctx->config.field.directions / 2;
    uint32_t r = ctx->config.field.grid_ratio;
    p.samples = r < 4 ? r : 4;   /* up to 4^3 classified points per cell */
    /* the step: at least the box's diagonal / 16384, so a ray's steps stay within the
       kernel's bound */
    float diag = sqrtf(ctx->scene.gpu.box_size[0] * ctx->scene.gpu.box_size[0] +
                       ctx->scene.gpu.box_size[1] * ctx->scene.gpu.box_size[1] +
                       ctx->scene.gpu.box_size[2] * ctx->scene.gpu.box_size[2]);
    float step = ctx->config.field.step_voxels * ctx->scene.gpu.min_spacing;
    p.step = step > diag / 16384.0f ? step : diag / 16384.0f;
    return p;
}

static void picvr_field_dispatch(picvr_context *ctx, int kernel, uint32_t set, const picvr_field_push *p, uint64_t threads) {
    picvr_field *f = &ctx->field;
    VkDescriptorSet sets[2] = {ctx->pipes.set, f->set[set]};
    vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, f->pipe[kernel]);
    vkCmdBindDescriptorSets(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, f->layout, 0, 2, sets, 0, NULL);
    vkCmdPushConstants(ctx->vk.cmd, f->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof *p, p);
    uint64_t groups = (threads + 255) / 256;
    uint32_t gx = groups < 65535 ? (uint32_t)groups : 65535, gy = (uint32_t)((groups + gx - 1) / gx);
    if (groups) vkCmdDispatch(ctx->vk.cmd, gx, gy, 1);
}

/* Records pass `pass`, reading field[cur] (flags without PICVR_FIELD_SOURCE: the
   background alone): its directions in as many dispatches as keep each invocation's
   loop within PICVR_FIELD_LOOP_BUDGET. */
static void picvr_field_record_pass(picvr_context *ctx, uint32_t pass, uint32_t cur, uint32_t flags) {
    picvr_field_push p = picvr_field_push_base(ctx);
    uint32_t walk = p.n[0] + p.n[1] + p.n[2] + 2;
    uint32_t per_dir = walk * (1 + ((flags & PICVR_FIELD_SOURCE) ? ctx->scene.light_count : 0));
    uint32_t chunk = PICVR_FIELD_LOOP_BUDGET / per_dir;
    if (chunk < 1) chunk = 1;
    uint32_t dirs = 2 * p.half_dirs;
    p.pass_index = pass;
    for (uint32_t k = 0; k < dirs; k += chunk) {
        p.dir_begin = k;
        p.dir_end = k + chunk < dirs ? k + chunk : dirs;
        p.flags = flags | (k ? PICVR_FIELD_ADD : 0u) |
                  (p.dir_end == dirs ? PICVR_FIELD_LAST : 0u);
        picvr_field_dispatch(ctx, PICVR_FIELD_SCATTER, cur, &p, p.n[3]);
        if (p.dir_end < dirs) picvr_barrier_all(ctx);
    }
}

/* Whether delta-M applies: some cell may scatter anisotropically and paths have more
   than one event. */
static int picvr_field_delta_m(const picvr_context *ctx) {
    return picvr_use_hg(ctx) && picvr_field_bounces(ctx) > 1;
}

/* The build: classification, the lights' transmittance, then passes until the bounces
   are done or (unlimited) the largest change falls to the tolerance. */
static picvr_status picvr_field_build(picvr_context *ctx) {
    picvr_field *f = &ctx->field;
    double start = picvr_clock_ms();
    picvr_field_push p = picvr_field_push_base(ctx);
    uint32_t flags = picvr_field_delta_m(ctx) ? PICVR_FIELD_DELTA_M : 0u;
    p.flags = flags;
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_barrier_all(ctx);
    vkCmdFillBuffer(ctx->vk.cmd, f->change.buf, 0, VK_WHOLE_SIZE, 0);
    picvr_field_dispatch(ctx, PICVR_FIELD_CLASSIFY, 0, &p, p.n[3]);
    picvr_barrier_all(ctx);
    picvr_field_dispatch(ctx, PICVR_FIELD_LIGHT, 0, &p,
                         (uint64_t)p.n[3] * (ctx->scene.light_count ? ctx->scene.light_count : 1u));
    picvr_barrier_all(ctx);
    if (!f->scattered) {   /* the lights' single scattering alone: no pass */
        if ((s = picvr_cmd_submit_wait(ctx))) return s;
        f->current = 0;
        f->passes = 0;
        f->change_value = 0.0;
        f->builds++;
        f->build_ms = picvr_clock_ms() - start;
        f->dirty = 0;
        return PICVR_OK;
    }
    uint32_t limit = picvr_field_bounces(ctx), unlimited = limit == PICVR_FIELD_MAX_PASSES;
    if (unlimited) limit = ctx->config.field.max_passes;
    /* Unlimited bounces converge to the same field from any start: a field of the same
       grid is where the passes start (a small edit then needs few); limited bounces
       count their passes from the background's. */
    int warm = unlimited && f->warm;
    uint32_t cur = warm ? f->current : 0, pass = 0;
    double change = 0.0;
    for (;;) {
        picvr_field_record_pass(ctx, pass, cur, flags | (pass || warm ? PICVR_FIELD_SOURCE : 0u));
        picvr_barrier_all(ctx);
        cur = 1 - cur;
        pass++;
        int last = pass >= limit;
        if (last || pass % PICVR_FIELD_PASSES_PER_SUBMIT == 0) {
            if ((s = picvr_cmd_submit_wait(ctx))) return s;
            picvr_buffer_invalidate(ctx, &f->change);
            const float *c = (const float *)f->change.mapped;
            float top = c[2 * (pass - 1) + 1], d = c[2 * (pass - 1)];
            /* Rule: an all-dark field has converged (no change relative to nothing) */
            change = top > 0.0f ? (double)d / top : 0.0;
            if (last || (unlimited && pass > 1 && change <= ctx->config.field.tolerance)) break;
            if ((s = picvr_cmd_begin(ctx))) return s;
            picvr_barrier_all(ctx);
        }
    }
    f->current = cur;
    f->warm = 1;
    f->passes = pass;
    f->change_value = change;
    f->builds++;
    f->build_ms = picvr_clock_ms() - start;
    f->dirty = 0;
    return PICVR_OK;
}

/* One image from the field into the accumulation: one sample per pixel, or with
   PICVR_RENDER_FIELD_MC field.prior_samples of them (Monte Carlo goes on from it). */
static picvr_status picvr_field_render(picvr_context *ctx) {
    double start = picvr_clock_ms();
    picvr_field_push p = picvr_field_push_base(ctx);
    p.flags = (picvr_field_delta_m(ctx) ? PICVR_FIELD_DELTA_M : 0u) | (picvr_field_bounces(ctx) > 1 ? PICVR_FIELD_MULTIPLE : 0u) |
              (ctx->field.scattered ? PICVR_FIELD_SOURCE : 0u);   /* SOURCE here: the field holds scattered light */
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_barrier_all(ctx);
    p.prior = ctx->field.mc ? ctx->config.field.prior_samples : 1u;
    picvr_field_dispatch(ctx, PICVR_FIELD_VIEW, ctx->field.current, &p, p.n[3]);
    picvr_barrier_all(ctx);
    picvr_field_dispatch(ctx, PICVR_FIELD_RENDER, ctx->field.current, &p,
                         (uint64_t)ctx->scene.camera.width * ctx->scene.camera.height);
    picvr_barrier_all(ctx);
    if ((s = picvr_cmd_submit_wait(ctx))) return s;
    picvr_image_state *im = &ctx->image;
    im->block_samples = im->block_total;   /* one pass over the image: one iteration */
    im->first_pass_blocks = im->block_total;
    im->has_samples = 1;
    im->depth_valid = 0;                   /* no scatter depths: a camera move clears */
    im->elapsed_ms = picvr_clock_ms() - start;
    ctx->results.valid = 0;
    ctx->field.view_changed = 0;
    return PICVR_OK;
}

/* PICVR_RENDER_FIELD_MC: whether this step shows the field (something changed since the
   image was made, or there is none) rather than adding Monte-Carlo samples to it. */
static int picvr_field_frame_due(const picvr_context *ctx) {
    const picvr_field *f = &ctx->field;
    return !f->mc || f->dirty || f->view_changed || !f->builds || !ctx->image.has_samples;
}

/* A step that shows the field (every step of PICVR_RENDER_FIELD, those after a change
   in PICVR_RENDER_FIELD_MC): the kernels and buffers at first use, the field rebuilt
   after a change, and one image. */
static picvr_status picvr_field_step(picvr_context *ctx) {
    picvr_status s = picvr_upload_scene(ctx);   /* first: it checks that the scene is ready */
    if (!s) s = picvr_field_make_layouts(ctx);
    if (!s) s = picvr_field_make_pipelines(ctx);
    if (!s) s = picvr_field_make_buffers(ctx);   /* nothing when the grid and lights are as they were */
    if (!s && (ctx->field.dirty || ctx->field.builds == 0)) s = picvr_field_build(ctx);
    return s ? s : picvr_field_render(ctx);
}

/* The field's part of picvr_get_stats. */
static void picvr_field_stats(const picvr_context *ctx, picvr_stats *st) {
    const picvr_field *f = &ctx->field;
    st->field_builds = f->builds;
    st->field_passes = f->passes;
    st->field_change = f->change_value;
    st->field_build_ms = f->build_ms;
    st->field_bytes = f->cells.size + f->light_t.size + f->field[0].size + f->field[1].size + f->change.size + f->view.size;
    memcpy(st->field_cells, f->n, sizeof f->n);
}

picvr_status picvr_read_field(picvr_context *ctx, float *out, size_t size, uint32_t dims[3]) {
    if (!ctx || !out) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    picvr_field *f = &ctx->field;
    if (!f->on || !f->builds) return PICVR_ERROR_NOT_READY;
    uint64_t cells = (uint64_t)f->n[0] * f->n[1] * f->n[2];
    if (cells > SIZE_MAX / 64 || size < cells * 64) return PICVR_ERROR_BUFFER_TOO_SMALL;
    if (dims) memcpy(dims, f->n, sizeof f->n);
    picvr_buffer host;
    VkDeviceSize bytes = 80 * cells;   /* the medium's 32 bytes per cell, then the field's 48 */
    picvr_status s = picvr_buffer_create(ctx, &host, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, 1);
    if (s) return s;
    if (!(s = picvr_cmd_begin(ctx))) {
        picvr_barrier_all(ctx);
        VkBufferCopy medium = {0, 0, 32 * cells}, field = {0, 32 * cells, 48 * cells};
        vkCmdCopyBuffer(ctx->vk.cmd, f->cells.buf, host.buf, 1, &medium);
        if (f->scattered) vkCmdCopyBuffer(ctx->vk.cmd, f->field[f->current].buf, host.buf, 1, &field);
        else vkCmdFillBuffer(ctx->vk.cmd, host.buf, 32 * cells, 48 * cells, 0);   /* no scattered light */
        picvr_barrier_all(ctx);
        s = picvr_cmd_submit_wait(ctx);
    }
    if (!s) {
        picvr_buffer_invalidate(ctx, &host);
        const float *m = (const float *)host.mapped, *fl = m + 8 * cells;
        for (uint64_t c = 0; c < cells; c++) {
            memcpy(out + 16 * c, m + 8 * c, 4 * sizeof(float));
            memcpy(out + 16 * c + 4, fl + 12 * c, 12 * sizeof(float));
        }
    }
    picvr_buffer_destroy(ctx, &host);
    return s;
}
