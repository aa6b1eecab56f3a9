/* host/context.c - picvr_create and picvr_destroy: resolving the configuration,
 * opening the device (or adopting the application's), making what every scene needs,
 * and freeing it all; picvr_get_config and picvr_set_scheduler.  Part of picvr_vk.c;
 * the last part: it uses all the others. */

static picvr_status picvr_context_init(picvr_context *ctx, const picvr_config *cfg) {
    picvr_status s;
    if (cfg->vulkan.device) {
        ctx->vk.external = 1;
        ctx->vk.instance = (VkInstance)cfg->vulkan.instance;
        ctx->vk.phys = (VkPhysicalDevice)cfg->vulkan.physical_device;
        ctx->vk.device = (VkDevice)cfg->vulkan.device;
        ctx->vk.queue = (VkQueue)cfg->vulkan.queue;
        ctx->vk.queue_family = cfg->vulkan.queue_family;
    } else {
        const char *want = cfg->device_name ? cfg->device_name : getenv("PICVR_DEVICE");
        if ((s = picvr_create_instance(ctx, picvr_want_validation(cfg)))) return s;
        if ((s = picvr_pick_device(ctx, want))) return s;
        if ((s = picvr_create_device(ctx))) return s;
    }
    vkGetPhysicalDeviceProperties(ctx->vk.phys, &ctx->vk.props);
    vkGetPhysicalDeviceMemoryProperties(ctx->vk.phys, &ctx->vk.mem_props);
    picvr_log_message(ctx, PICVR_LOG_INFO, "device: %s", ctx->vk.props.deviceName);

    if (!picvr_format_filters(ctx, VK_FORMAT_R8_UNORM) || !picvr_format_filters(ctx, VK_FORMAT_R16_UNORM) ||
        !picvr_format_filters(ctx, VK_FORMAT_R32G32B32A32_SFLOAT)) {
        picvr_log_message(ctx, PICVR_LOG_ERROR, "device cannot filter R8/R16 volumes or RGBA32F tables");
        return PICVR_ERROR_UNSUPPORTED_TYPE;
    }
    ctx->vk.float_volume_format = picvr_format_filters(ctx, VK_FORMAT_R32_SFLOAT) ? VK_FORMAT_R32_SFLOAT : VK_FORMAT_R16_UNORM;
    if ((s = picvr_check_cache_device(ctx))) return s;

    VkCommandPoolCreateInfo pi;
    PICVR_VK_INIT(pi, VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO);
    pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pi.queueFamilyIndex = ctx->vk.queue_family;
    PICVR_VK_TRY(ctx, vkCreateCommandPool(ctx->vk.device, &pi, NULL, &ctx->vk.cmd_pool));
    VkCommandBufferAllocateInfo ai;
    PICVR_VK_INIT(ai, VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO);
    ai.commandPool = ctx->vk.cmd_pool;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    PICVR_VK_TRY(ctx, vkAllocateCommandBuffers(ctx->vk.device, &ai, &ctx->vk.cmd));
    VkFenceCreateInfo fi;
    PICVR_VK_INIT(fi, VK_STRUCTURE_TYPE_FENCE_CREATE_INFO);
    PICVR_VK_TRY(ctx, vkCreateFence(ctx->vk.device, &fi, NULL, &ctx->vk.fence));

    if ((s = picvr_create_pipelines(ctx)) || (s = picvr_create_sampler(ctx)) || (s = picvr_create_timestamps(ctx))) return s;
    ctx->sched.create_batch = picvr_creation_batch(ctx);
    ctx->vk.max_volume_bytes = picvr_volume_alloc_limit(ctx);
    if (ctx->cache.on && (s = picvr_create_cache_buffers(ctx))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->rounds.readback, PICVR_ROUND_READBACK_BYTES, VK_BUFFER_USAGE_TRANSFER_DST_BIT, 1))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->scene.ubo, sizeof(picvr_gpu_scene), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, 1))) return s;
    if ((s = picvr_image_create(ctx, &ctx->scene.tf_image, VK_IMAGE_TYPE_1D, VK_FORMAT_R32G32B32A32_SFLOAT, PICVR_TF_SIZE, 1, 1))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->scene.tf_staging, sizeof ctx->scene.tf_table, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 1))) return s;
    if (!(ctx->scene.tf_rm = (picvr_range_table *)picvr_host_alloc(&ctx->config.allocator, sizeof *ctx->scene.tf_rm))) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    if (!(ctx->scene.tf_rmin = (picvr_range_table *)picvr_host_alloc(&ctx->config.allocator, sizeof *ctx->scene.tf_rmin))) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    if ((s = picvr_buffer_create(ctx, &ctx->scene.tf_range_max, sizeof *ctx->scene.tf_rm,
                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0))) return s;
    ctx->scene.rot[0] = ctx->scene.rot[4] = ctx->scene.rot[8] = 1.0f;   /* the volume's frame is the world's */
    picvr_env_info no_env;
    memset(&no_env, 0, sizeof no_env);
    picvr_buffer env;
    if ((s = picvr_env_build(ctx, NULL, &no_env, &env))) return s;
    picvr_env_install(ctx, NULL, &no_env, &env);
    ctx->scene.gpu.vertex_cost = 64u;      /* as picvr_update_equiangular sets it without lights */
    return picvr_default_transfer_function(ctx);
}

picvr_status picvr_create(const picvr_config *cfg_in, picvr_context **out) {
    if (!out) return PICVR_ERROR_NULL_POINTER;
    *out = NULL;
    picvr_config cfg;
    if (cfg_in) cfg = *cfg_in; else memset(&cfg, 0, sizeof cfg);
    if ((cfg.allocator.alloc != NULL) != (cfg.allocator.free != NULL)) return PICVR_ERROR_INVALID_ARGUMENT;
    int ext = (cfg.vulkan.instance != NULL) + (cfg.vulkan.physical_device != NULL) + (cfg.vulkan.device != NULL) +
              (cfg.vulkan.queue != NULL);
    if (ext != 0 && ext != 4) return PICVR_ERROR_INVALID_ARGUMENT;
    if ((unsigned)cfg.log_level > PICVR_LOG_ERROR) return PICVR_ERROR_INVALID_ARGUMENT;
    if ((unsigned)cfg.validation > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    if ((unsigned)cfg.distance_sampling > PICVR_DISTANCE_AUTO) return PICVR_ERROR_INVALID_ARGUMENT;
    if ((unsigned)cfg.transmittance > PICVR_TRANSMITTANCE_RAY_MARCHING) return PICVR_ERROR_INVALID_ARGUMENT;
    if ((unsigned)cfg.kernel_pruning > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    picvr_context *ctx = (picvr_context *)picvr_host_alloc(&cfg.allocator, sizeof *ctx);
    if (!ctx) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    memset(ctx, 0, sizeof *ctx);
#if PICVR_THREADS
    ctx->vk.message_lock_ready = pthread_mutex_init(&ctx->vk.message_lock, NULL) == 0;
#endif
    ctx->config = cfg;
    ctx->config.device_name = NULL;      /* the application's string: not kept */
    if (!cfg.log_level) ctx->config.log_level = PICVR_LOG_WARNING;
    if (!cfg.distance_sampling) ctx->config.distance_sampling = PICVR_DISTANCE_MIS;
    if (!cfg.transmittance) ctx->config.transmittance = PICVR_TRANSMITTANCE_RESIDUAL;
    if (!cfg.kernel_pruning) ctx->config.kernel_pruning = PICVR_SWITCH_ON;
    ctx->config.compile_threads = picvr_resolve_compile_threads(cfg.compile_threads);
    picvr_status s = picvr_resolve_cache_config(&cfg.cache, &ctx->cache.cfg);
    if (!s) s = picvr_resolve_scheduler_config(&cfg.scheduler, &ctx->sched.cfg);
    ctx->cache.on = ctx->cache.cfg.mode != PICVR_CACHE_NONE;
    if (!s) s = picvr_resolve_field_config(&cfg.field, ctx->cache.on, &ctx->config.field);
    ctx->field.on = ctx->config.field.mode >= PICVR_RENDER_FIELD;
    ctx->field.mc = ctx->config.field.mode == PICVR_RENDER_FIELD_MC;
    ctx->sched.auto_mode.on = ctx->cache.cfg.mode == PICVR_CACHE_AUTO;
    ctx->sched.use_priorities = ctx->sched.cfg.priorities == PICVR_SWITCH_ON;
    picvr_update_targets(&ctx->sched, ctx->cache.on);
    if (!s) s = picvr_context_init(ctx, &cfg);
    if (s) { picvr_destroy(ctx); return s; }
    *out = ctx;
    return PICVR_OK;
}

picvr_status picvr_get_config(const picvr_context *ctx, picvr_config *out) {
    if (!ctx || !out) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    *out = ctx->config;
    out->device_name = ctx->vk.props.deviceName;
    out->validation = ctx->vk.validation_enabled ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF;
    out->vulkan.instance = ctx->vk.instance;
    out->vulkan.physical_device = ctx->vk.phys;
    out->vulkan.device = ctx->vk.device;
    out->vulkan.queue = ctx->vk.queue;
    out->vulkan.queue_family = ctx->vk.queue_family;
    out->cache = ctx->cache.cfg;
    out->scheduler = ctx->sched.cfg;
    return PICVR_OK;
}

/* The scene's device objects and host tables. */
static void picvr_scene_destroy(picvr_context *ctx) {
    picvr_buffer_destroy(ctx, &ctx->scene.ubo);
    picvr_buffer_destroy(ctx, &ctx->scene.tf_staging);
    picvr_buffer_destroy(ctx, &ctx->scene.tf_range_max);
    picvr_buffer_destroy(ctx, &ctx->scene.majorant);
    picvr_buffer_destroy(ctx, &ctx->scene.tf_g);
    picvr_buffer_destroy(ctx, &ctx->scene.env);
    picvr_image_destroy(ctx, &ctx->scene.tf_image);
    picvr_image_destroy(ctx, &ctx->scene.volume);
}

/* The device, the instance and their debug messenger, unless they are the
   application's. */
static void picvr_device_destroy(picvr_context *ctx) {
    VkDevice d = ctx->vk.device;
    if (d) {
        if (ctx->vk.fence) vkDestroyFence(d, ctx->vk.fence, NULL);
        if (ctx->vk.cmd_pool) vkDestroyCommandPool(d, ctx->vk.cmd_pool, NULL);
        if (!ctx->vk.external) vkDestroyDevice(d, NULL);
    }
    if (ctx->vk.external || !ctx->vk.instance) return;
    if (ctx->vk.messenger) {
        PFN_vkDestroyDebugUtilsMessengerEXT destroy = (PFN_vkDestroyDebugUtilsMessengerEXT)
            vkGetInstanceProcAddr(ctx->vk.instance, "vkDestroyDebugUtilsMessengerEXT");
        if (destroy) destroy(ctx->vk.instance, ctx->vk.messenger, NULL);
    }
    vkDestroyInstance(ctx->vk.instance, NULL);
}

void picvr_destroy(picvr_context *ctx) {
    if (!ctx) return;
    if (ctx->vk.device) {
        vkDeviceWaitIdle(ctx->vk.device);
        picvr_scene_destroy(ctx);
        picvr_image_buffers_destroy(ctx);
        picvr_cache_destroy(ctx);
        picvr_rounds_destroy(ctx);
        picvr_results_destroy(ctx);
        picvr_target_destroy(ctx);
        picvr_aux_kernel_destroy(ctx, &ctx->reproject);
        picvr_field_destroy(ctx);
        picvr_pipelines_destroy(ctx);
    }
    picvr_device_destroy(ctx);
    picvr_host_free(&ctx->config.allocator, ctx->scene.brick_min);
    picvr_host_free(&ctx->config.allocator, ctx->scene.brick_max);
    picvr_host_free(&ctx->config.allocator, ctx->scene.tf_rm);
    picvr_host_free(&ctx->config.allocator, ctx->scene.tf_rmin);
#if PICVR_THREADS
    if (ctx->vk.message_lock_ready) pthread_mutex_destroy(&ctx->vk.message_lock);
#endif
    picvr_allocator a = ctx->config.allocator;
    picvr_host_free(&a, ctx);
}

picvr_status picvr_set_scheduler(picvr_context *ctx, const picvr_scheduler_config *cfg) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    picvr_scheduler_config zero;
    memset(&zero, 0, sizeof zero);
    picvr_scheduler_config c;
    picvr_status s = picvr_resolve_scheduler_config(cfg ? cfg : &zero, &c);
    if (s) return s;
    if (c.priorities == PICVR_SWITCH_ON && (s = picvr_create_priority_pipeline(ctx))) return s;
    if (c.temporal_reuse != ctx->sched.cfg.temporal_reuse && ctx->scene.has_camera) {
        /* the depth plane follows: on a failure the old settings stay in force */
        picvr_scheduler_config old = ctx->sched.cfg;
        ctx->sched.cfg.temporal_reuse = c.temporal_reuse;
        s = picvr_reuse_buffers(ctx, ctx->scene.camera.width, ctx->scene.camera.height);
        if (s) {
            ctx->sched.cfg = old;
            return s;
        }
    }
    ctx->sched.cfg = c;
    ctx->sched.use_priorities = c.priorities == PICVR_SWITCH_ON;
    /* credit owed under the old shares would be spent under the new ones */
    ctx->sched.credit_ms[PICVR_PROC_CREATE] = ctx->sched.credit_ms[PICVR_PROC_UPDATE] = 0.0;
    picvr_update_targets(&ctx->sched, ctx->cache.on);
    return PICVR_OK;
}
