/* host/pipelines.c - shader modules, the descriptor set shared by every kernel, and the
 * pipeline variants: specialization constants compile out what the scene does not use
 * (phase-function MIS, voxel-level majorants, the debug views, per-channel light), and
 * each procedure keeps up to PICVR_VARIANT_SLOTS variants.  The kernels outside the
 * procedures are in aux_kernel.c.  Part of picvr_vk.c; uses util, vulkan, schedule,
 * cache, scattering, spirv. */

static picvr_status picvr_create_shader(picvr_context *ctx, const uint32_t *code, size_t size, VkShaderModule *out) {
    VkShaderModuleCreateInfo ci;
    PICVR_VK_INIT(ci, VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
    ci.codeSize = size;
    ci.pCode = code;
    PICVR_VK_TRY(ctx, vkCreateShaderModule(ctx->vk.device, &ci, NULL, out));
    return PICVR_OK;
}

/* A procedure's kernel (a module variants are made from, kept until the context is
   destroyed): its module, and the SPIR-V it came from for picvr_prune_variant. */
static picvr_status picvr_create_kernel(picvr_context *ctx, const uint32_t *code, size_t size, VkShaderModule *out) {
    picvr_status s = picvr_create_shader(ctx, code, size, out);
    picvr_pipelines *p = &ctx->pipes;
    if (!s && p->codes < PICVR_MODULES) {
        p->code[p->codes].mod = *out;
        p->code[p->codes].code = code;
        p->code[p->codes++].size = size;
    }
    return s;
}

/* The variant's kernels from their SPIR-V without the calls its constants rule out
   (host/spirv.c), each a module of its own in v->own; a kernel whose module does not
   prune, or prunes to nothing, keeps the context's module.  Off with
   config.kernel_pruning OFF.  Rule: a failure here is no failure of the variant: the
   whole module compiles to the same kernel, only more slowly. */
static void picvr_prune_variant(picvr_context *ctx, picvr_variant_build *v) {
    for (int k = 0; k < PICVR_KERNELS; k++) v->own[k] = VK_NULL_HANDLE;
    if (ctx->config.kernel_pruning == PICVR_SWITCH_OFF) return;
    for (int k = 0; k < PICVR_KERNELS; k++) {
        if (!v->mod[k]) continue;
        const uint32_t *code = NULL;
        size_t size = 0;
        for (uint32_t i = 0; i < ctx->pipes.codes && !code; i++)
            if (ctx->pipes.code[i].mod == v->mod[k]) { code = ctx->pipes.code[i].code; size = ctx->pipes.code[i].size; }
        if (!code) continue;
        uint32_t *pruned = NULL;
        size_t words = 0;
        long calls = picvr_spirv_prune(&ctx->config.allocator, code, size / 4, &v->spec, &pruned, &words);
        if (calls > 0) {
            VkShaderModuleCreateInfo ci;
            PICVR_VK_INIT(ci, VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO);
            ci.codeSize = words * 4;
            ci.pCode = pruned;
            if (vkCreateShaderModule(ctx->vk.device, &ci, NULL, &v->own[k]) == VK_SUCCESS) v->mod[k] = v->own[k];
            else v->own[k] = VK_NULL_HANDLE;
        }
        picvr_host_free(&ctx->config.allocator, pruned);
    }
}

/* The modules picvr_prune_variant made, once the variant's pipelines are made (a
   pipeline does not need its module afterwards). */
static void picvr_release_variant(picvr_context *ctx, picvr_variant_build *v) {
    for (int k = 0; k < PICVR_KERNELS; k++)
        if (v->own[k]) {
            vkDestroyShaderModule(ctx->vk.device, v->own[k], NULL);
            v->own[k] = VK_NULL_HANDLE;
        }
}

/* ---- pipelines made in parallel ------------------------------------------------
   A variant's kernels, and the variants one step needs, are independent
   vkCreateComputePipelines calls.  A driver compiles each on the thread that calls it
   (lavapipe for seconds per large kernel, even with its shader cache warm), and Vulkan
   lets any thread call it (only a VkPipelineCache would need the calls kept apart, and
   picvr passes none).  So a batch runs on the calling thread and up to
   config.compile_threads - 1 short-lived helpers, each taking the next job; all are
   joined before picvr_make_pipelines returns, and a helper that cannot start leaves its
   jobs to the others.  Helpers touch nothing but their jobs: the log and the context
   see the results on the calling thread. */
static void *picvr_pipeline_worker(void *arg) {
    picvr_pipeline_batch *b = (picvr_pipeline_batch *)arg;
    for (;;) {
#if PICVR_THREADS
        if (b->threaded) pthread_mutex_lock(&b->lock);
#endif
        uint32_t i = b->next < b->n ? b->next++ : b->n;
#if PICVR_THREADS
        if (b->threaded) pthread_mutex_unlock(&b->lock);
#endif
        if (i >= b->n) return NULL;
        picvr_pipeline_job *j = &b->job[i];
        j->result = vkCreateComputePipelines(b->device, VK_NULL_HANDLE, 1, &j->ci, NULL, &j->pipe);
        if (j->result != VK_SUCCESS) j->pipe = VK_NULL_HANDLE;
    }
}

/* config.compile_threads as the context runs with it: 0 means the processors online
   (1 where the system does not say); at most PICVR_MAX_COMPILE_THREADS. */
static uint32_t picvr_resolve_compile_threads(uint32_t given) {
    long n = (long)(given < PICVR_MAX_COMPILE_THREADS ? given : PICVR_MAX_COMPILE_THREADS);
    if (n <= 0) n = picvr_processors_online();
    return n < 1 ? 1u : n > (long)PICVR_MAX_COMPILE_THREADS ? PICVR_MAX_COMPILE_THREADS : (uint32_t)n;
}

/* Makes job[0..n) (each job's ci filled in).  On a failure the first failing job's
   status is returned (logged here) and no pipeline of the batch is left. */
static picvr_status picvr_make_pipelines(picvr_context *ctx, picvr_pipeline_job *job, uint32_t n) {
    picvr_pipeline_batch b;
    memset(&b, 0, sizeof b);
    b.device = ctx->vk.device;
    b.job = job;
    b.n = n;
    for (uint32_t i = 0; i < n; i++) job[i].pipe = VK_NULL_HANDLE;
#if PICVR_THREADS
    uint32_t helpers = ctx->config.compile_threads;
    helpers = n < helpers ? n : helpers;
    helpers = helpers ? helpers - 1u : 0u;
    if (helpers && pthread_mutex_init(&b.lock, NULL) != 0) helpers = 0;
    b.threaded = helpers > 0;
    pthread_t thread[PICVR_MAX_COMPILE_THREADS];
    uint32_t started = 0;
    while (started < helpers && pthread_create(&thread[started], NULL, picvr_pipeline_worker, &b) == 0) started++;
    picvr_pipeline_worker(&b);
    for (uint32_t i = 0; i < started; i++) pthread_join(thread[i], NULL);
    if (helpers) pthread_mutex_destroy(&b.lock);
#else
    picvr_pipeline_worker(&b);
#endif
    picvr_status s = PICVR_OK;
    for (uint32_t i = 0; i < n && !s; i++) s = picvr_vk_status(ctx, job[i].result, "vkCreateComputePipelines");
    if (s)
        for (uint32_t i = 0; i < n; i++)
            if (job[i].pipe) { vkDestroyPipeline(ctx->vk.device, job[i].pipe, NULL); job[i].pipe = VK_NULL_HANDLE; }
    return s;
}

static void picvr_pipeline_job_init(picvr_pipeline_job *j, VkShaderModule mod, VkPipelineLayout layout,
                                    const VkSpecializationInfo *spec) {
    memset(j, 0, sizeof *j);
    PICVR_VK_INIT(j->ci, VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO);
    j->ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    j->ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    j->ci.stage.module = mod;
    j->ci.stage.pName = "main";
    j->ci.stage.pSpecializationInfo = spec;
    j->ci.layout = layout;
}

/* One pipeline, on the calling thread. */
static picvr_status picvr_create_pipeline(picvr_context *ctx, VkShaderModule mod, VkPipelineLayout layout,
                                          const VkSpecializationInfo *spec, VkPipeline *out) {
    picvr_pipeline_job job;
    picvr_pipeline_job_init(&job, mod, layout, spec);
    picvr_status s = picvr_make_pipelines(ctx, &job, 1);
    *out = job.pipe;
    return s;
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
    if (ctx->config.transmittance == PICVR_TRANSMITTANCE_RAY_MARCHING) residual = PICVR_KEY_RAY_MARCHING;
    uint32_t mis_mode = ctx->config.distance_sampling != PICVR_DISTANCE_FREE_FLIGHT;
    uint32_t equi = ctx->scene.use_equiangular && mis_mode ? PICVR_KEY_EQUIANGULAR : 0u;
    /* the forced point (PICVR_DISTANCE_FORCED, and PICVR_DISTANCE_AUTO's forced kind):
       plain rendering only (specialization.glsl, USE_FORCED), which turns strategy B on
       where no light is served; PICVR_DISTANCE_AUTO measures in both of its kinds */
    int forced_on = ctx->config.distance_sampling == PICVR_DISTANCE_FORCED || forced_kind;
    uint32_t forced = ctx->scene.use_forced && mis_mode && forced_on ? PICVR_KEY_FORCED | PICVR_KEY_EQUIANGULAR : 0u;
    /* PICVR_DISTANCE_AUTO's second kind where the forced point serves no light with the
       default transmittance: ray marching (host/lights.c, auto_rm), the forced point
       serving the background where it lights the scene */
    if (forced_kind && ctx->scene.auto_rm) residual = PICVR_KEY_RAY_MARCHING;
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

/* The kernels of procedure proc's variant for key (VK_NULL_HANDLE modules where the
   procedure has no such kernel).  One set of constants for all kernels (a kernel
   ignores those it lacks), each at its PICVR_SPEC_ id (shaders/specialization.glsl):
   from the key, or fixed per context (the creation procedure's rounds and sample
   steps, SCREEN_LOCKING, CACHE_MAX_LOOKUP_REFS, CACHE_BLEND); with LOOKUP_EVENT > 1 the
   shading kernel is render_shade_cache.comp. */
static void picvr_build_variant(const picvr_context *ctx, int proc, uint32_t key, picvr_variant_build *v) {
    VkShaderModule *mod = v->mod;
    for (int k = 0; k < PICVR_KERNELS; k++) mod[k] = VK_NULL_HANDLE;
    if (proc == PICVR_PROC_CREATE) mod[PICVR_KERNEL_MAIN] = ctx->pipes.create_module;
    else if (proc == PICVR_PROC_UPDATE) mod[PICVR_KERNEL_MAIN] = ctx->pipes.update_module;
    else {
        int plain = (key & PICVR_KEY_PLAIN) != 0;
        mod[PICVR_KERNEL_MAIN] = plain ? ctx->pipes.plain_track_module : ctx->pipes.track_module;
        int later = !plain && ((key >> PICVR_KEY_LOOKUP_SHIFT) & 7u) != 0;   /* lookup_event > 1 */
        mod[PICVR_KERNEL_SHADE] = later ? ctx->pipes.shade_cache_module : ctx->pipes.shade_module;
        if (ctx->cache.on && !plain) mod[PICVR_KERNEL_LOOKUP] = ctx->pipes.lookup_module;
    }
    uint32_t *value = v->value;
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
    value[PICVR_SPEC_USE_RAY_MARCHING] = (key & PICVR_KEY_RAY_MARCHING) != 0;
    for (uint32_t i = 0; i < PICVR_SPEC_CONSTANTS; i++) {
        v->entry[i].constantID = i;
        v->entry[i].offset = 4 * i;
        v->entry[i].size = 4;
    }
    v->spec.mapEntryCount = PICVR_SPEC_CONSTANTS;
    v->spec.pMapEntries = v->entry;
    v->spec.dataSize = sizeof v->value;
    v->spec.pData = v->value;
}

/* A variant one step renders with: procedure proc, PICVR_CACHE_AUTO's plain kind,
   PICVR_DISTANCE_AUTO's forced kind. */
typedef struct picvr_variant_want {
    int proc, plain, forced_kind;
} picvr_variant_want;

#define PICVR_MAX_WANTS 4u

static picvr_variant_want picvr_want(int proc, int plain, int forced_kind) {
    picvr_variant_want w;
    w.proc = proc;
    w.plain = plain;
    w.forced_kind = forced_kind;
    return w;
}

static int picvr_find_variant(const picvr_context *ctx, int proc, uint32_t key) {
    const picvr_variant_slot *t = ctx->pipes.variants[proc];
    for (uint32_t i = 0; i < PICVR_VARIANT_SLOTS; i++)
        if (t[i].pipe[PICVR_KERNEL_MAIN] && t[i].key == key) return (int)i;
    return -1;
}

/* Chooses the variants want[0..n) (slot[i]: want i's slot; ctx->now_slot of each
   procedure: its last want), making those no slot holds, in one parallel batch, each in
   a free slot or in place of the least recently used one.  Rounds wait for their fence,
   so between steps no pipeline is in use.  On a failure the slots are as before. */
static picvr_status picvr_select_batch(picvr_context *ctx, const picvr_variant_want *want, uint32_t n,
                                       uint32_t *slot) {
    uint32_t key[PICVR_MAX_WANTS];
    int found[PICVR_MAX_WANTS], first[PICVR_MAX_WANTS];   /* first: the earlier want of the same variant */
    int from_async[PICVR_MAX_WANTS], built[PICVR_MAX_WANTS];
    picvr_async_variant *async = &ctx->pipes.async;
    picvr_variant_build build[PICVR_MAX_WANTS];
    picvr_pipeline_job job[PICVR_MAX_WANTS * PICVR_KERNELS];
    int job_of[PICVR_MAX_WANTS][PICVR_KERNELS];
    uint32_t jobs = 0;
    for (uint32_t w = 0; w < n; w++) {
        key[w] = picvr_variant_key(ctx, want[w].proc, want[w].plain, want[w].forced_kind);
        found[w] = picvr_find_variant(ctx, want[w].proc, key[w]);
        first[w] = -1;
        for (uint32_t e = 0; e < w; e++)
            if (want[e].proc == want[w].proc && key[e] == key[w]) { first[w] = (int)e; break; }
        from_async[w] = 0;
        built[w] = 0;
        if (found[w] >= 0 || first[w] >= 0) continue;
        if (async->valid && async->proc == want[w].proc && async->key == key[w]) {   /* made beside the steps */
            from_async[w] = 1;
            continue;
        }
        picvr_build_variant(ctx, want[w].proc, key[w], &build[w]);
        picvr_prune_variant(ctx, &build[w]);
        built[w] = 1;
        for (int k = 0; k < PICVR_KERNELS; k++) {
            job_of[w][k] = -1;
            if (!build[w].mod[k]) continue;
            picvr_pipeline_job_init(&job[jobs], build[w].mod[k], ctx->pipes.layout, &build[w].spec);
            job_of[w][k] = (int)jobs++;
        }
    }
    picvr_status s = picvr_make_pipelines(ctx, job, jobs);
    for (uint32_t w = 0; w < n; w++)
        if (built[w]) picvr_release_variant(ctx, &build[w]);
    if (s) return s;
    /* the variants already held are this step's first, so that a new one never takes
       the slot of one the step also renders with */
    for (uint32_t w = 0; w < n; w++)
        if (found[w] >= 0) ctx->pipes.variants[want[w].proc][found[w]].used = ctx->pipes.variant_clock;
    for (uint32_t w = 0; w < n; w++) {
        picvr_variant_slot *t = ctx->pipes.variants[want[w].proc];
        uint32_t pick = 0;
        if (found[w] >= 0) pick = (uint32_t)found[w];
        else if (first[w] >= 0) pick = slot[first[w]];
        else {
            for (uint32_t i = 1; i < PICVR_VARIANT_SLOTS && t[pick].pipe[PICVR_KERNEL_MAIN]; i++)
                if (!t[i].pipe[PICVR_KERNEL_MAIN] || t[i].used < t[pick].used) pick = i;
            for (int k = 0; k < PICVR_KERNELS; k++) {
                if (t[pick].pipe[k]) vkDestroyPipeline(ctx->vk.device, t[pick].pipe[k], NULL);
                t[pick].pipe[k] = from_async[w] ? async->pipe[k] : job_of[w][k] >= 0 ? job[job_of[w][k]].pipe : VK_NULL_HANDLE;
            }
            if (from_async[w]) async->valid = 0;
            t[pick].key = key[w];
            t[pick].dispatched = 0;
        }
        t[pick].used = ctx->pipes.variant_clock;
        slot[w] = pick;
        ctx->pipes.current_slot[want[w].proc] = pick;
    }
    return PICVR_OK;
}

/* ---- a variant made beside the steps -------------------------------------------- */

#if PICVR_THREADS
static void *picvr_async_main(void *arg) {
    picvr_async_variant *a = (picvr_async_variant *)arg;
    picvr_pipeline_worker(&a->batch);
    pthread_mutex_lock(&a->lock);
    a->done = 1;
    pthread_mutex_unlock(&a->lock);
    return NULL;
}
#endif

/* Joins the variant's thread once it has finished (with wait: when it finishes).  Its
   pipelines become valid if every one was made; otherwise none is kept, and the step
   that needs the variant makes it and reports the failure. */
static void picvr_async_finish(picvr_context *ctx, int wait) {
#if PICVR_THREADS
    picvr_async_variant *a = &ctx->pipes.async;
    if (!a->running) return;
    if (!wait) {
        pthread_mutex_lock(&a->lock);
        int done = a->done;
        pthread_mutex_unlock(&a->lock);
        if (!done) return;
    }
    pthread_join(a->thread, NULL);
    pthread_mutex_destroy(&a->lock);
    a->running = 0;
    picvr_release_variant(ctx, &a->build);
    int ok = 1;
    for (uint32_t i = 0; i < a->batch.n; i++) ok &= a->job[i].result == VK_SUCCESS;
    for (int k = 0; k < PICVR_KERNELS; k++) a->pipe[k] = VK_NULL_HANDLE;
    for (uint32_t i = 0; i < a->batch.n; i++) {
        if (ok) a->pipe[a->kernel[i]] = a->job[i].pipe;
        else if (a->job[i].pipe) vkDestroyPipeline(ctx->vk.device, a->job[i].pipe, NULL);
    }
    a->valid = ok;
#else
    (void)ctx;
    (void)wait;
#endif
}

/* Waits for the thread, and destroys a variant no slot took. */
static void picvr_async_discard(picvr_context *ctx) {
    picvr_async_variant *a = &ctx->pipes.async;
    picvr_async_finish(ctx, 1);
    if (a->valid)
        for (int k = 0; k < PICVR_KERNELS; k++)
            if (a->pipe[k]) vkDestroyPipeline(ctx->vk.device, a->pipe[k], NULL);
    a->valid = 0;
}

/* Starts making procedure proc's variant for key on a thread of its own (one thread:
   on a CPU device the rounds keep the other processors).  0 where threads are not
   available, config.compile_threads is 1 (the calling thread only) or the thread does
   not start: the caller makes it then. */
static int picvr_async_start(picvr_context *ctx, int proc, uint32_t key) {
#if PICVR_THREADS
    picvr_async_variant *a = &ctx->pipes.async;
    if (ctx->config.compile_threads <= 1) return 0;
    picvr_async_discard(ctx);
    a->proc = proc;
    a->key = key;
    picvr_build_variant(ctx, proc, key, &a->build);
    picvr_prune_variant(ctx, &a->build);
    uint32_t n = 0;
    for (int k = 0; k < PICVR_KERNELS; k++)
        if (a->build.mod[k]) {
            picvr_pipeline_job_init(&a->job[n], a->build.mod[k], ctx->pipes.layout, &a->build.spec);
            a->kernel[n++] = k;
        }
    memset(&a->batch, 0, sizeof a->batch);
    a->batch.device = ctx->vk.device;
    a->batch.job = a->job;
    a->batch.n = n;
    a->done = 0;
    if (pthread_mutex_init(&a->lock, NULL) != 0) {
        picvr_release_variant(ctx, &a->build);
        return 0;
    }
    if (pthread_create(&a->thread, NULL, picvr_async_main, a) != 0) {
        pthread_mutex_destroy(&a->lock);
        picvr_release_variant(ctx, &a->build);
        return 0;
    }
    a->running = 1;
    return 1;
#else
    (void)ctx;
    (void)proc;
    (void)key;
    return 0;
#endif
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
    picvr_variant_want want[PICVR_MAX_WANTS];
    uint32_t slot[PICVR_MAX_WANTS], n = 0;
    picvr_status s = PICVR_OK;
    if (picvr_auto_plain_allowed(ctx)) {
        /* a batch of its own: a new variant's making compiles its pipelines, the auto
           mode's pause */
        double t0 = picvr_clock_ms();
        want[0] = picvr_want(PICVR_PROC_RENDER, 1, 0);
        s = picvr_select_batch(ctx, want, 1, slot);
        picvr_auto_note_compile(&ctx->sched.auto_mode, picvr_clock_ms() - t0);
        if (!s) ctx->pipes.plain_slot = slot[0];
        /* the cached kind's pipelines wait for its first round (picvr_auto_choose) */
        if (s || !ctx->sched.auto_mode.cached_ready) return s;
    }
    /* PICVR_DISTANCE_AUTO: the forced kind's variant, once its first round asked for it
       (picvr_ready_forced), then the other, which stays the current one */
    int forced = ctx->sched.dauto.on && ctx->sched.dauto.forced_ready;
    if (forced) want[n++] = picvr_want(PICVR_PROC_RENDER, 0, 1);
    want[n++] = picvr_want(PICVR_PROC_RENDER, 0, 0);
    if (ctx->cache.on) {
        want[n++] = picvr_want(PICVR_PROC_CREATE, 0, 0);
        want[n++] = picvr_want(PICVR_PROC_UPDATE, 0, 0);
    }
    s = picvr_select_batch(ctx, want, n, slot);
    if (!s && forced) ctx->pipes.forced_slot = slot[0];
    return s;
}

/* Before a round of PICVR_DISTANCE_AUTO's forced kind: its variant is made at its first
   round, so that a scene where the probes never come (or the kinds are one renderer)
   neither makes nor compiles it. */
static picvr_status picvr_ready_forced(picvr_context *ctx) {
    if (ctx->sched.dauto.forced_ready || !ctx->sched.dauto.on) return PICVR_OK;
    picvr_async_finish(ctx, 1);   /* a variant being made beside the steps: wait for it */
    ctx->sched.dauto.forced_ready = 1;
    picvr_status s = picvr_select_variants(ctx);
    if (s) ctx->sched.dauto.forced_ready = 0;
    return s;
}

/* Before a timed round of PICVR_DISTANCE_AUTO whose rendering has the ROUND_* flags
   *flags.  A probe of the forced kind before its variant exists starts making it on a
   thread of its own, and the round renders the chosen kind instead (*flags: its flags)
   until the variant is ready: the steps do not stop for its compile (on a GPU it costs
   them nothing; on lavapipe they share the processors with it).  A round that renders
   the forced kind as the chosen one, or a context without threads, makes it here. */
static picvr_status picvr_probe_forced(picvr_context *ctx, uint32_t *flags) {
    picvr_dauto *d = &ctx->sched.dauto;
    if (!(*flags & PICVR_ROUND_FORCED)) return PICVR_OK;
    if (d->forced_ready || !d->on || !(*flags & PICVR_ROUND_PROBE)) return picvr_ready_forced(ctx);
    picvr_async_variant *a = &ctx->pipes.async;
    uint32_t key = picvr_variant_key(ctx, PICVR_PROC_RENDER, 0, 1);
    picvr_async_finish(ctx, 0);
    int made = (a->valid && a->proc == PICVR_PROC_RENDER && a->key == key) ||
               picvr_find_variant(ctx, PICVR_PROC_RENDER, key) >= 0;
    if (made || (!a->running && !picvr_async_start(ctx, PICVR_PROC_RENDER, key))) return picvr_ready_forced(ctx);
    *flags = picvr_dauto_chosen_flags(d);
    return PICVR_OK;
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
        ? picvr_create_kernel(ctx, picvr_spv_render_track_cache, sizeof picvr_spv_render_track_cache, &ctx->pipes.track_module)
        : picvr_create_kernel(ctx, picvr_spv_render_track, sizeof picvr_spv_render_track, &ctx->pipes.track_module);
    if (!s) s = picvr_create_kernel(ctx, picvr_spv_render_shade, sizeof picvr_spv_render_shade, &ctx->pipes.shade_module);
    if (!s && ctx->cache.on && ctx->cache.cfg.lookup_event > 1)   /* render_shade_cache.comp's only use */
        s = picvr_create_kernel(ctx, picvr_spv_render_shade_cache, sizeof picvr_spv_render_shade_cache,
                                &ctx->pipes.shade_cache_module);
    if (!s) s = picvr_create_shader(ctx, picvr_spv_stats, sizeof picvr_spv_stats, &ctx->pipes.stats_module);
    if (!s) s = picvr_create_shader(ctx, picvr_spv_block_select, sizeof picvr_spv_block_select, &ctx->pipes.select_module);
    if (!s) s = picvr_create_pipeline(ctx, ctx->pipes.select_module, ctx->pipes.layout, NULL, &ctx->pipes.select_pipe);
    if (!s && ctx->sched.use_priorities) s = picvr_create_priority_pipeline(ctx);
    if (!s && ctx->cache.on && ctx->cache.cfg.mode == PICVR_CACHE_AUTO)
        s = picvr_create_kernel(ctx, picvr_spv_render_track, sizeof picvr_spv_render_track, &ctx->pipes.plain_track_module);
    if (!s && ctx->cache.on) {
        s = picvr_create_kernel(ctx, picvr_spv_render_lookup, sizeof picvr_spv_render_lookup, &ctx->pipes.lookup_module);
        if (!s) s = picvr_create_kernel(ctx, picvr_spv_cache_create, sizeof picvr_spv_cache_create, &ctx->pipes.create_module);
        if (!s) s = picvr_create_kernel(ctx, picvr_spv_cache_update, sizeof picvr_spv_cache_update, &ctx->pipes.update_module);
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
    if (d) picvr_async_discard(ctx);   /* first: its thread uses the modules and the layout */
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
