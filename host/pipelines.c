/* host/pipelines.c - shader modules, the descriptor set shared by every kernel, and the
 * pipeline variants: specialization constants compile out what the scene does not use
 * (phase-function MIS, voxel-level majorants, the debug views, per-channel light), and
 * each procedure keeps up to PICVR_VARIANT_SLOTS variants; the kernels outside the
 * procedures.  Part of picvr_vk.c; uses util, vulkan, schedule, cache, scattering. */

static picvr_status picvr_create_shader(picvr_context *ctx, const uint32_t *code, size_t size, VkShaderModule *out) {
    VkShaderModuleCreateInfo ci;
    PICVR_VK_INIT(ci, VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    ci.codeSize = size;
    ci.pCode = code;
    PICVR_VK_TRY(ctx, vkCreateShaderModule(ctx->vk.device, &ci, NULL, out));
    return PICVR_OK;
}

static picvr_status picvr_create_pipeline(picvr_context *ctx, VkShaderModule mod, VkPipelineLayout layout,
                                    const VkSpecializationInfo *spec, VkPipeline *out) {
    VkComputePipelineCreateInfo ci;
    PICVR_VK_INIT(ci, VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
    ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = mod;
    ci.stage.pName = "main";
    ci.stage.pSpecializationInfo = spec;
    ci.layout = layout;
    PICVR_VK_TRY(ctx, vkCreateComputePipelines(ctx->vk.device, VK_NULL_HANDLE, 1, &ci, NULL, out));
    return PICVR_OK;
}

/* The bindings only cached contexts write: 9-14, 17, 21 and 22. */
static int picvr_cache_binding(uint32_t i) { return (i >= 9 && i < 15) || i == 17 || i == 21 || i == 22; }

static VkDescriptorType picvr_binding_type(uint32_t i) {
    return i == 0 ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER
         : i < 3 ? VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
}

/* The Eq. 12 priority pipeline, made once (at creation with priorities on, or by the
   first picvr_set_scheduler that turns them on); a module left by a failure is reused
   next time and destroyed with the context. */
static picvr_status picvr_create_priority_pipeline(picvr_context *ctx) {
    picvr_status s = PICVR_OK;
    if (!ctx->pipes.priority_module)
        s = picvr_create_shader(ctx, picvr_spv_block_priority, sizeof picvr_spv_block_priority, &ctx->pipes.priority_module);
    if (!s && !ctx->pipes.priority_pipe)
        s = picvr_create_pipeline(ctx, ctx->pipes.priority_module, ctx->pipes.layout, NULL, &ctx->pipes.priority_pipe);
    return s;
}

/* True when the cached rendering procedure runs its debug-view variant. */
static int picvr_debug_view_on(const picvr_context *ctx) {
    return ctx->cache.on && ctx->scene.gpu.debug_view != PICVR_VIEW_IMAGE;
}

/* Whether the cache serves the scene.  With bounces it holds the multiply scattered
   light (picvr_cache_multiple); without, the single-scattered light for an isotropic
   phase function, so with an anisotropic one alone it idles (the rendering variant
   queues every event for plain shading, shaders/render_track.glsl, and the rounds plan
   no creation or update).  Here, not in host/cache.c: it asks the phase function
   (host/scattering.c), whose setter uses the cache's part. */
static int picvr_cache_serves(const picvr_context *ctx) {
    return picvr_cache_multiple(ctx) || (ctx->cache.on && !picvr_use_hg(ctx));
}

/* The key of procedure proc's variant for the current scene.  Only the constants a
   procedure reads are in its key, so that a change elsewhere makes no new variant:
   creation samples light but looks nothing up, the update procedure tracks and looks
   up but samples no light, plain Monte Carlo looks nothing up.  The light types present
   are not specialized: compiling them out gained nothing measurable (docs/cache.md),
   and each new combination would cost a new variant, and a pause, whenever an
   application turns a light of a new type on.  plain: the rendering variant of
   PICVR_CACHE_AUTO's plain rounds (the plain tracking module, no lookup). */
static uint32_t picvr_variant_key(const picvr_context *ctx, int proc, int plain, int forced_kind) {
    uint32_t mis = ctx->scene.use_phase_mis ? PICVR_KEY_PHASE_MIS : 0u, fine = ctx->scene.use_fine ? PICVR_KEY_FINE : 0u;
    uint32_t mono = (uint32_t)ctx->scene.gpu.mono_channel << PICVR_KEY_MONO_SHIFT;
    uint32_t residual = ctx->config.transmittance == PICVR_TRANSMITTANCE_RESIDUAL && ctx->scene.use_control
                      ? PICVR_KEY_RESIDUAL : 0u;
    uint32_t mis_mode = ctx->config.distance_sampling != PICVR_DISTANCE_FREE_FLIGHT;
    uint32_t equi = ctx->scene.use_equiangular && mis_mode ? PICVR_KEY_EQUIANGULAR : 0u;
    /* the forced point (PICVR_DISTANCE_FORCED, and PICVR_DISTANCE_AUTO's forced kind):
       plain rendering only (specialization.glsl, USE_FORCED), which turns strategy B on
       where no light is served; PICVR_DISTANCE_AUTO measures in both of its kinds */
    int forced_on = ctx->config.distance_sampling == PICVR_DISTANCE_FORCED || forced_kind;
    uint32_t forced = ctx->scene.use_forced && mis_mode && forced_on ? PICVR_KEY_FORCED | PICVR_KEY_EQUIANGULAR : 0u;
    if (ctx->sched.dauto.on) forced |= PICVR_KEY_MEASURE;
    uint32_t qmc = mis_mode ? PICVR_KEY_QMC : 0u;
    uint32_t env = ctx->scene.use_env ? PICVR_KEY_ENV_MAP : 0u;
    uint32_t paths = (ctx->scene.scattering.max_bounces > 0 ? PICVR_KEY_BOUNCES : 0u) |
                     (picvr_use_hg(ctx) ? PICVR_KEY_HG : 0u) |
                     (ctx->sched.cfg.temporal_reuse == PICVR_SWITCH_ON ? PICVR_KEY_REUSE : 0u);
    uint32_t clip = ctx->scene.gpu.clip_count ? PICVR_KEY_CLIP : 0u;   /* every procedure tracks rays */
    /* multiply scattered: creation traces paths; the fluence's colour is no longer the
       lights' (the albedo tints it at every event), so every channel is extrapolated */
    uint32_t create_paths = picvr_cache_multiple(ctx) ? paths & (PICVR_KEY_BOUNCES | PICVR_KEY_HG) : 0u;
    if (picvr_cache_multiple(ctx)) mono = 3u << PICVR_KEY_MONO_SHIFT;
    if (proc == PICVR_PROC_CREATE) return mis | fine | env | clip | create_paths;
    if (proc == PICVR_PROC_UPDATE) return fine | mono | qmc | clip;
    if (!ctx->cache.on) return mis | fine | residual | equi | forced | qmc | env | paths | clip;
    if (plain) return mis | fine | residual | equi | forced | qmc | env | paths | clip | PICVR_KEY_PLAIN;
    uint32_t lookup = (picvr_lookup_event(ctx) - 1u) << PICVR_KEY_LOOKUP_SHIFT;
    return mis | fine | mono | residual | equi | qmc | env | paths | clip | lookup |
           (picvr_debug_view_on(ctx) ? PICVR_KEY_DEBUG_VIEW : 0u);
}

/* The kernels of procedure proc's variant for key (out[KERNELS], VK_NULL_HANDLE where
   the procedure has no such kernel; on a failure none is left).  One set of constants
   for all kernels (a kernel ignores those it lacks), each at its PICVR_SPEC_ id
   (shaders/specialization.glsl): from the key, or fixed per context (the creation
   procedure's rounds and sample steps, SCREEN_LOCKING, CACHE_MAX_LOOKUP_REFS,
   CACHE_BLEND); with LOOKUP_EVENT > 1 the shading kernel is render_shade_cache.comp. */
static picvr_status picvr_create_variant(picvr_context *ctx, int proc, uint32_t key, VkPipeline *out) {
    VkShaderModule mod[PICVR_KERNELS] = {VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE};
    if (proc == PICVR_PROC_CREATE) mod[PICVR_KERNEL_MAIN] = ctx->pipes.create_module;
    else if (proc == PICVR_PROC_UPDATE) mod[PICVR_KERNEL_MAIN] = ctx->pipes.update_module;
    else {
        int plain = (key & PICVR_KEY_PLAIN) != 0;
        mod[PICVR_KERNEL_MAIN] = plain ? ctx->pipes.plain_track_module : ctx->pipes.track_module;
        int later = !plain && ((key >> PICVR_KEY_LOOKUP_SHIFT) & 7u) != 0;   /* lookup_event > 1 */
        mod[PICVR_KERNEL_SHADE] = later ? ctx->pipes.shade_cache_module : ctx->pipes.shade_module;
        if (ctx->cache.on && !plain) mod[PICVR_KERNEL_LOOKUP] = ctx->pipes.lookup_module;
    }
    uint32_t value[PICVR_SPEC_CONSTANTS];
    value[PICVR_SPEC_USE_PHASE_MIS] = (key & PICVR_KEY_PHASE_MIS) != 0;
    value[PICVR_SPEC_USE_FINE] = (key & PICVR_KEY_FINE) != 0;
    value[PICVR_SPEC_CREATE_MAX_ROUNDS] = picvr_create_rounds(ctx);
    value[PICVR_SPEC_USE_DEBUG_VIEW] = (key & PICVR_KEY_DEBUG_VIEW) != 0;
    value[PICVR_SPEC_MONO_CHANNEL] = (key >> PICVR_KEY_MONO_SHIFT) & 3u;
    value[PICVR_SPEC_SCREEN_LOCKING] = ctx->cache.on && ctx->cache.cfg.mode == PICVR_CACHE_SCREEN_SPACE;
    value[PICVR_SPEC_CACHE_MAX_LOOKUP_REFS] =
        ctx->cache.on ? ctx->cache.cfg.max_lookup_refs : PICVR_CACHE_MAX_LOOKUP_REFS;
    value[PICVR_SPEC_USE_EQUIANGULAR] = (key & PICVR_KEY_EQUIANGULAR) != 0;
    value[PICVR_SPEC_USE_RESIDUAL] = (key & PICVR_KEY_RESIDUAL) != 0;
    value[PICVR_SPEC_USE_QMC] = (key & PICVR_KEY_QMC) != 0;
    value[PICVR_SPEC_USE_BOUNCES] = (key & PICVR_KEY_BOUNCES) != 0;
    value[PICVR_SPEC_USE_HG] = (key & PICVR_KEY_HG) != 0;
    value[PICVR_SPEC_USE_ENV_MAP] = (key & PICVR_KEY_ENV_MAP) != 0;
    value[PICVR_SPEC_USE_REUSE] = (key & PICVR_KEY_REUSE) != 0;
    value[PICVR_SPEC_USE_CLIP] = (key & PICVR_KEY_CLIP) != 0;
    value[PICVR_SPEC_CACHE_BLEND] = picvr_blend_on(ctx) != 0;
    value[PICVR_SPEC_CREATE_SAMPLE_STEPS] = picvr_create_sample_steps(ctx);
    value[PICVR_SPEC_LOOKUP_EVENT] = ((key >> PICVR_KEY_LOOKUP_SHIFT) & 7u) + 1u;
    value[PICVR_SPEC_USE_FORCED] = (key & PICVR_KEY_FORCED) != 0;
    value[PICVR_SPEC_USE_MEASURE] = (key & PICVR_KEY_MEASURE) != 0;
    VkSpecializationMapEntry entry[PICVR_SPEC_CONSTANTS];
    for (uint32_t i = 0; i < PICVR_SPEC_CONSTANTS; i++) {
        entry[i].constantID = i;
        entry[i].offset = 4 * i;
        entry[i].size = 4;
    }
    VkSpecializationInfo spec = {PICVR_SPEC_CONSTANTS, entry, sizeof value, value};
    picvr_status s = PICVR_OK;
    for (int k = 0; k < PICVR_KERNELS; k++) {
        out[k] = VK_NULL_HANDLE;
        if (!s && mod[k]) s = picvr_create_pipeline(ctx, mod[k], ctx->pipes.layout, &spec, &out[k]);
    }
    if (s)
        for (int k = 0; k < PICVR_KERNELS; k++)
            if (out[k]) { vkDestroyPipeline(ctx->vk.device, out[k], NULL); out[k] = VK_NULL_HANDLE; }
    return s;
}

/* Chooses this step's variant of procedure proc (ctx->now_slot), making it if no slot
   holds its key, in a free slot or in place of the least recently used one.  Rounds
   wait for their fence, so between steps no pipeline is in use.  On a failure the
   slots are as before. */
static picvr_status picvr_select_variant(picvr_context *ctx, int proc, int plain, int forced_kind) {
    uint32_t key = picvr_variant_key(ctx, proc, plain, forced_kind), pick = 0;
    picvr_variant_slot *t = ctx->pipes.variants[proc];
    for (uint32_t i = 0; i < PICVR_VARIANT_SLOTS; i++)
        if (t[i].pipe[PICVR_KERNEL_MAIN] && t[i].key == key) {
            t[i].used = ctx->pipes.variant_clock;
            ctx->pipes.current_slot[proc] = i;
            return PICVR_OK;
        }
    for (uint32_t i = 1; i < PICVR_VARIANT_SLOTS && t[pick].pipe[PICVR_KERNEL_MAIN]; i++)
        if (!t[i].pipe[PICVR_KERNEL_MAIN] || t[i].used < t[pick].used) pick = i;
    VkPipeline pipe[PICVR_KERNELS];
    picvr_status s = picvr_create_variant(ctx, proc, key, pipe);
    if (s) return s;
    for (int k = 0; k < PICVR_KERNELS; k++) {
        if (t[pick].pipe[k]) vkDestroyPipeline(ctx->vk.device, t[pick].pipe[k], NULL);
        t[pick].pipe[k] = pipe[k];
    }
    t[pick].key = key;
    t[pick].used = ctx->pipes.variant_clock;
    t[pick].dispatched = 0;
    ctx->pipes.current_slot[proc] = pick;
    return PICVR_OK;
}

/* Kernel k of the variant this step dispatches for procedure proc (the rendering
   procedure of a plain round: PICVR_CACHE_AUTO's plain variant; of a round of the forced
   kind under PICVR_DISTANCE_AUTO: its forced variant). */
static uint32_t picvr_current_slot(const picvr_context *ctx, int proc, int plain, int forced_kind) {
    if (proc == PICVR_PROC_RENDER && forced_kind && ctx->sched.dauto.on) return ctx->pipes.forced_slot;
    return proc == PICVR_PROC_RENDER && plain ? ctx->pipes.plain_slot : ctx->pipes.current_slot[proc];
}

static VkPipeline picvr_current_kernel(const picvr_context *ctx, int proc, int k, int plain, int forced_kind) {
    return ctx->pipes.variants[proc][picvr_current_slot(ctx, proc, plain, forced_kind)].pipe[k];
}

static VkPipeline picvr_current_pipeline(const picvr_context *ctx, int proc) { return picvr_current_kernel(ctx, proc, PICVR_KERNEL_MAIN, 0, 0); }

/* PICVR_CACHE_AUTO may render a round plain: not with a debug view (it shows the cache)
   nor where the cache idles anyway (picvr_cache_serves). */
static int picvr_auto_plain_allowed(const picvr_context *ctx) {
    return ctx->cache.on && ctx->cache.cfg.mode == PICVR_CACHE_AUTO && !picvr_debug_view_on(ctx) && picvr_cache_serves(ctx);
}

/* The pipeline variants of every procedure the context runs, for the current scene. */
static picvr_status picvr_select_variants(picvr_context *ctx) {
    ctx->pipes.variant_clock++;
    picvr_status s = PICVR_OK;
    if (picvr_auto_plain_allowed(ctx)) {
        double t0 = picvr_clock_ms();   /* a new variant: its pipelines compile (the auto mode's pause) */
        s = picvr_select_variant(ctx, PICVR_PROC_RENDER, 1, 0);
        picvr_auto_note_compile(&ctx->sched.auto_mode, picvr_clock_ms() - t0);
        ctx->pipes.plain_slot = ctx->pipes.current_slot[PICVR_PROC_RENDER];
        /* the cached kind's pipelines wait for its first round (picvr_auto_choose) */
        if (s || !ctx->sched.auto_mode.cached_ready) return s;
    }
    /* PICVR_DISTANCE_AUTO: the forced kind's variant, once its first round asked for it
       (picvr_ready_forced), then the other, which stays the current one */
    if (!s && ctx->sched.dauto.on && ctx->sched.dauto.forced_ready) {
        s = picvr_select_variant(ctx, PICVR_PROC_RENDER, 0, 1);
        ctx->pipes.forced_slot = ctx->pipes.current_slot[PICVR_PROC_RENDER];
    }
    if (!s) s = picvr_select_variant(ctx, PICVR_PROC_RENDER, 0, 0);
    if (!s && ctx->cache.on) s = picvr_select_variant(ctx, PICVR_PROC_CREATE, 0, 0);
    if (!s && ctx->cache.on) s = picvr_select_variant(ctx, PICVR_PROC_UPDATE, 0, 0);
    return s;
}

/* Before a round of PICVR_DISTANCE_AUTO's forced kind: its variant is made at its first
   round, so that a scene where the probes never come (or the kinds are one renderer)
   neither makes nor compiles it. */
static picvr_status picvr_ready_forced(picvr_context *ctx) {
    if (ctx->sched.dauto.forced_ready || !ctx->sched.dauto.on) return PICVR_OK;
    ctx->sched.dauto.forced_ready = 1;
    picvr_status s = picvr_select_variants(ctx);
    if (s) ctx->sched.dauto.forced_ready = 0;
    return s;
}

/* Before a round that runs the cache: under PICVR_CACHE_AUTO its pipelines are made at
   the cached kind's first round, so that the plain rounds before it do not wait for
   their compilation. */
static picvr_status picvr_ready_cached(picvr_context *ctx) {
    if (ctx->sched.auto_mode.cached_ready || !picvr_auto_plain_allowed(ctx)) return PICVR_OK;
    ctx->sched.auto_mode.cached_ready = 1;
    picvr_status s = picvr_select_variants(ctx);
    if (s) ctx->sched.auto_mode.cached_ready = 0;
    return s;
}

static picvr_status picvr_create_pipelines(picvr_context *ctx) {
    VkDescriptorSetLayoutBinding b[PICVR_NUM_BINDINGS];
    memset(b, 0, sizeof b);
    for (uint32_t i = 0; i < PICVR_NUM_BINDINGS; i++) {
        b[i].binding = i;
        b[i].descriptorType = picvr_binding_type(i);
        b[i].descriptorCount = 1;
        b[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
    }
    VkDescriptorSetLayoutCreateInfo li;
    PICVR_VK_INIT(li, VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    li.bindingCount = PICVR_NUM_BINDINGS;
    li.pBindings = b;
    PICVR_VK_TRY(ctx, vkCreateDescriptorSetLayout(ctx->vk.device, &li, NULL, &ctx->pipes.set_layout));

    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, 20};   /* four words, every kernel; a fifth, rendering */
    VkPipelineLayoutCreateInfo pl;
    PICVR_VK_INIT(pl, VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    pl.setLayoutCount = 1;
    pl.pSetLayouts = &ctx->pipes.set_layout;
    pl.pushConstantRangeCount = 1;
    pl.pPushConstantRanges = &pcr;
    PICVR_VK_TRY(ctx, vkCreatePipelineLayout(ctx->vk.device, &pl, NULL, &ctx->pipes.layout));
    PICVR_VK_TRY(ctx, vkCreatePipelineLayout(ctx->vk.device, &pl, NULL, &ctx->pipes.stats_layout));

    VkDescriptorPoolSize sizes[3] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
                                     {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2},
                                     {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, PICVR_NUM_BINDINGS - 3}};
    VkDescriptorPoolCreateInfo pi;
    PICVR_VK_INIT(pi, VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    pi.maxSets = 1;
    pi.poolSizeCount = 3;
    pi.pPoolSizes = sizes;
    PICVR_VK_TRY(ctx, vkCreateDescriptorPool(ctx->vk.device, &pi, NULL, &ctx->pipes.desc_pool));
    VkDescriptorSetAllocateInfo ai;
    PICVR_VK_INIT(ai, VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    ai.descriptorPool = ctx->pipes.desc_pool;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &ctx->pipes.set_layout;
    PICVR_VK_TRY(ctx, vkAllocateDescriptorSets(ctx->vk.device, &ai, &ctx->pipes.set));

    picvr_status s = ctx->cache.on
        ? picvr_create_shader(ctx, picvr_spv_render_track_cache, sizeof picvr_spv_render_track_cache, &ctx->pipes.track_module)
        : picvr_create_shader(ctx, picvr_spv_render_track, sizeof picvr_spv_render_track, &ctx->pipes.track_module);
    if (!s) s = picvr_create_shader(ctx, picvr_spv_render_shade, sizeof picvr_spv_render_shade, &ctx->pipes.shade_module);
    if (!s && ctx->cache.on && ctx->cache.cfg.lookup_event > 1)   /* render_shade_cache.comp's only use */
        s = picvr_create_shader(ctx, picvr_spv_render_shade_cache, sizeof picvr_spv_render_shade_cache,
                                &ctx->pipes.shade_cache_module);
    if (!s) s = picvr_create_shader(ctx, picvr_spv_stats, sizeof picvr_spv_stats, &ctx->pipes.stats_module);
    if (!s) s = picvr_create_shader(ctx, picvr_spv_block_select, sizeof picvr_spv_block_select, &ctx->pipes.select_module);
    if (!s) s = picvr_create_pipeline(ctx, ctx->pipes.select_module, ctx->pipes.layout, NULL, &ctx->pipes.select_pipe);
    if (!s && ctx->sched.use_priorities) s = picvr_create_priority_pipeline(ctx);
    if (!s && ctx->cache.on && ctx->cache.cfg.mode == PICVR_CACHE_AUTO)
        s = picvr_create_shader(ctx, picvr_spv_render_track, sizeof picvr_spv_render_track, &ctx->pipes.plain_track_module);
    if (!s && ctx->cache.on) {
        s = picvr_create_shader(ctx, picvr_spv_render_lookup, sizeof picvr_spv_render_lookup, &ctx->pipes.lookup_module);
        if (!s) s = picvr_create_shader(ctx, picvr_spv_cache_create, sizeof picvr_spv_cache_create, &ctx->pipes.create_module);
        if (!s) s = picvr_create_shader(ctx, picvr_spv_cache_update, sizeof picvr_spv_cache_update, &ctx->pipes.update_module);
        if (!s) s = picvr_create_shader(ctx, picvr_spv_cache_rebuild, sizeof picvr_spv_cache_rebuild, &ctx->pipes.rebuild_module);
        if (!s) s = picvr_create_pipeline(ctx, ctx->pipes.rebuild_module, ctx->pipes.layout, NULL, &ctx->pipes.rebuild_pipe);
    }
    if (s) return s;
    /* The procedures' pipelines are variants made by the steps (picvr_select_variant). */
    return picvr_create_pipeline(ctx, ctx->pipes.stats_module, ctx->pipes.stats_layout, NULL, &ctx->pipes.stats_pipe);
}

static picvr_status picvr_create_sampler(picvr_context *ctx) {
    VkSamplerCreateInfo si;
    PICVR_VK_INIT(si, VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO);
    si.magFilter = si.minFilter = VK_FILTER_LINEAR;
    si.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    si.addressModeU = si.addressModeV = si.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    si.maxLod = 0.0f;
    PICVR_VK_TRY(ctx, vkCreateSampler(ctx->vk.device, &si, NULL, &ctx->pipes.linear_sampler));
    return PICVR_OK;
}

static void picvr_update_descriptors(picvr_context *ctx) {
    if (!ctx->pipes.descriptors_dirty) return;
    VkDescriptorBufferInfo ubo = {ctx->scene.ubo.buf, 0, VK_WHOLE_SIZE};
    VkDescriptorImageInfo vol = {ctx->pipes.linear_sampler, ctx->scene.volume.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkDescriptorImageInfo tf = {ctx->pipes.linear_sampler, ctx->scene.tf_image.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    VkDescriptorBufferInfo bufs[PICVR_NUM_BINDINGS - 3] = {
        {ctx->scene.majorant.buf, 0, VK_WHOLE_SIZE}, {ctx->image.planes[0].buf, 0, VK_WHOLE_SIZE},
        {ctx->image.planes[1].buf, 0, VK_WHOLE_SIZE}, {ctx->image.planes[2].buf, 0, VK_WHOLE_SIZE},
        {ctx->results.partials.buf, 0, VK_WHOLE_SIZE}, {ctx->scene.tf_range_max.buf, 0, VK_WHOLE_SIZE},
        {ctx->cache.entries.buf, 0, VK_WHOLE_SIZE}, {ctx->cache.nodes.buf, 0, VK_WHOLE_SIZE},
        {ctx->cache.refs.buf, 0, VK_WHOLE_SIZE}, {ctx->cache.counters.buf, 0, VK_WHOLE_SIZE},
        {ctx->cache.requests.buf, 0, VK_WHOLE_SIZE}, {ctx->cache.superpixels.buf, 0, VK_WHOLE_SIZE},
        {ctx->image.render_queue.buf, 0, VK_WHOLE_SIZE}, {ctx->image.shade_queue.buf, 0, VK_WHOLE_SIZE},
        {ctx->image.lookup_queue.buf, 0, VK_WHOLE_SIZE}, {ctx->scene.tf_g.buf, 0, VK_WHOLE_SIZE},
        {ctx->scene.env.buf, 0, VK_WHOLE_SIZE}, {ctx->image.depth.buf, 0, VK_WHOLE_SIZE},
        {ctx->image.blend.buf, 0, VK_WHOLE_SIZE}, {ctx->cache.moments.buf, 0, VK_WHOLE_SIZE}};
    VkWriteDescriptorSet w[PICVR_NUM_BINDINGS];
    memset(w, 0, sizeof w);
    uint32_t n = 0;
    for (uint32_t i = 0; i < PICVR_NUM_BINDINGS; i++) {
        /* The cache bindings stay unwritten when the cache is off: no pipeline then uses them. */
        if (!ctx->cache.on && picvr_cache_binding(i)) continue;
        w[n].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        w[n].dstSet = ctx->pipes.set;
        w[n].dstBinding = i;
        w[n].descriptorCount = 1;
        w[n].descriptorType = picvr_binding_type(i);
        if (i == 0) w[n].pBufferInfo = &ubo;
        else if (i == 1) w[n].pImageInfo = &vol;
        else if (i == 2) w[n].pImageInfo = &tf;
        else w[n].pBufferInfo = &bufs[i - 3];
        n++;
    }
    vkUpdateDescriptorSets(ctx->vk.device, n, w, 0, NULL);
    ctx->pipes.descriptors_dirty = 0;
}

/* Every pipeline, shader module, the descriptor pool and layouts, the sampler. */
static void picvr_pipelines_destroy(picvr_context *ctx) {
    VkDevice d = ctx->vk.device;
    picvr_pipelines *p = &ctx->pipes;
    for (int proc = 0; proc < 3; proc++)
        for (uint32_t i = 0; i < PICVR_VARIANT_SLOTS; i++)
            for (int k = 0; k < PICVR_KERNELS; k++)
                if (p->variants[proc][i].pipe[k]) vkDestroyPipeline(d, p->variants[proc][i].pipe[k], NULL);
    VkPipeline pipes[] = {p->rebuild_pipe, p->select_pipe, p->priority_pipe, p->stats_pipe};
    for (size_t i = 0; i < sizeof pipes / sizeof pipes[0]; i++)
        if (pipes[i]) vkDestroyPipeline(d, pipes[i], NULL);
    VkShaderModule modules[] = {p->select_module, p->priority_module, p->update_module, p->rebuild_module,
                                p->lookup_module, p->create_module, p->track_module, p->shade_module,
                                p->stats_module, p->plain_track_module, p->shade_cache_module};
    for (size_t i = 0; i < sizeof modules / sizeof modules[0]; i++)
        if (modules[i]) vkDestroyShaderModule(d, modules[i], NULL);
    if (p->linear_sampler) vkDestroySampler(d, p->linear_sampler, NULL);
    if (p->desc_pool) vkDestroyDescriptorPool(d, p->desc_pool, NULL);
    if (p->layout) vkDestroyPipelineLayout(d, p->layout, NULL);
    if (p->stats_layout) vkDestroyPipelineLayout(d, p->stats_layout, NULL);
    if (p->set_layout) vkDestroyDescriptorSetLayout(d, p->set_layout, NULL);
}

/* ---- kernels outside the procedures (picvr_write_image, the reprojection) ---------- */

static void picvr_aux_kernel_destroy(picvr_context *ctx, picvr_aux_kernel *k) {
    VkDevice d = ctx->vk.device;
    if (k->pipe) vkDestroyPipeline(d, k->pipe, NULL);
    if (k->module) vkDestroyShaderModule(d, k->module, NULL);
    if (k->pool) vkDestroyDescriptorPool(d, k->pool, NULL);   /* frees the set */
    if (k->layout) vkDestroyPipelineLayout(d, k->layout, NULL);
    if (k->set_layout) vkDestroyDescriptorSetLayout(d, k->set_layout, NULL);
    memset(k, 0, sizeof *k);
}

#define PICVR_AUX_BINDINGS 16u

/* Makes kernel k from SPIR-V `code` (size bytes) with `bindings` (at most
   PICVR_AUX_BINDINGS) storage buffers, once; a failure leaves nothing behind. */
static picvr_status picvr_aux_kernel_make(picvr_context *ctx, picvr_aux_kernel *k, uint32_t bindings,
                                          const uint32_t *code, size_t size) {
    if (k->pipe) return PICVR_OK;
    if (bindings > PICVR_AUX_BINDINGS) return PICVR_ERROR_INVALID_ARGUMENT;
    VkDescriptorSetLayoutBinding b[PICVR_AUX_BINDINGS];
    memset(b, 0, sizeof b);
    for (uint32_t i = 0; i < bindings; i++) {
        b[i].binding = i;
        b[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        b[i].descriptorCount = 1;
        b[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
    }
    VkDescriptorSetLayoutCreateInfo li;
    PICVR_VK_INIT(li, VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO);
    li.bindingCount = bindings;
    li.pBindings = b;
    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, 128};   /* every device's minimum */
    VkPipelineLayoutCreateInfo pl;
    PICVR_VK_INIT(pl, VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO);
    pl.setLayoutCount = 1;
    pl.pSetLayouts = &k->set_layout;
    pl.pushConstantRangeCount = 1;
    pl.pPushConstantRanges = &pcr;
    VkDescriptorPoolSize pool_size = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, bindings};
    VkDescriptorPoolCreateInfo pi;
    PICVR_VK_INIT(pi, VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO);
    pi.maxSets = 1;
    pi.poolSizeCount = 1;
    pi.pPoolSizes = &pool_size;
    VkDescriptorSetAllocateInfo ai;
    PICVR_VK_INIT(ai, VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO);
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &k->set_layout;
    picvr_status s = picvr_vk_status(ctx, vkCreateDescriptorSetLayout(ctx->vk.device, &li, NULL, &k->set_layout),
                                     "vkCreateDescriptorSetLayout");
    if (!s) s = picvr_vk_status(ctx, vkCreatePipelineLayout(ctx->vk.device, &pl, NULL, &k->layout), "vkCreatePipelineLayout");
    if (!s) s = picvr_vk_status(ctx, vkCreateDescriptorPool(ctx->vk.device, &pi, NULL, &k->pool), "vkCreateDescriptorPool");
    ai.descriptorPool = k->pool;
    if (!s) s = picvr_vk_status(ctx, vkAllocateDescriptorSets(ctx->vk.device, &ai, &k->set), "vkAllocateDescriptorSets");
    if (!s) s = picvr_create_shader(ctx, code, size, &k->module);
    if (!s) s = picvr_create_pipeline(ctx, k->module, k->layout, NULL, &k->pipe);
    if (s) picvr_aux_kernel_destroy(ctx, k);
    return s;
}

/* Points kernel k's bindings 0..n-1 (n <= the bindings it was made with) at the whole
   of buffers[0..n-1]. */
static void picvr_aux_kernel_bind(picvr_context *ctx, picvr_aux_kernel *k, const VkBuffer *buffers, uint32_t n) {
    VkDescriptorBufferInfo info[PICVR_AUX_BINDINGS];
    VkWriteDescriptorSet w[PICVR_AUX_BINDINGS];
    if (n > PICVR_AUX_BINDINGS) n = PICVR_AUX_BINDINGS;
    for (uint32_t i = 0; i < n; i++) {
        info[i].buffer = buffers[i];
        info[i].offset = 0;
        info[i].range = VK_WHOLE_SIZE;
        PICVR_VK_INIT(w[i], VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET);
        w[i].dstSet = k->set;
        w[i].dstBinding = i;
        w[i].descriptorCount = 1;
        w[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
        w[i].pBufferInfo = &info[i];
    }
    vkUpdateDescriptorSets(ctx->vk.device, n, w, 0, NULL);
}

/* Records kernel k over `threads` threads of 256 (a 2D grid past 65535 groups) with
   push constants push (bytes <= 128). */
static void picvr_aux_kernel_dispatch(picvr_context *ctx, const picvr_aux_kernel *k, const void *push, uint32_t bytes,
                                      uint64_t threads) {
    vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k->pipe);
    vkCmdBindDescriptorSets(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, k->layout, 0, 1, &k->set, 0, NULL);
    vkCmdPushConstants(ctx->vk.cmd, k->layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, bytes, push);
    uint64_t groups = (threads + 255) / 256;
    uint32_t gx = groups < 65535 ? (uint32_t)groups : 65535, gy = (uint32_t)((groups + gx - 1) / gx);
    vkCmdDispatch(ctx->vk.cmd, gx, gy, 1);
}
