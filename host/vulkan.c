/* host/vulkan.c - Vulkan plumbing: results to status codes, device memory, buffers and
 * images, the one command buffer (record, submit, wait), the instance with the
 * validation layer, choosing and probing the device.  No procedure of the paper lives
 * here.  Part of picvr_vk.c; uses host/util.c. */

/* The one mip level and layer of a colour image (C and C++ alike: no compound literals). */
static VkImageSubresourceRange picvr_color_range(void) {
    VkImageSubresourceRange r = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    return r;
}
static VkImageSubresourceLayers picvr_color_layers(void) {
    VkImageSubresourceLayers l = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    return l;
}
static VkExtent3D picvr_extent(uint32_t w, uint32_t h, uint32_t d) {
    VkExtent3D e = {w, h, d};
    return e;
}

/* Maps a VkResult to a status; logs the call that failed. */
static picvr_status picvr_vk_status(picvr_context *ctx, VkResult r, const char *what) {
    if (r == VK_SUCCESS) return PICVR_OK;
    picvr_log_message(ctx, PICVR_LOG_ERROR, "%s failed: VkResult %d", what, (int)r);
    switch (r) {
    case VK_ERROR_OUT_OF_HOST_MEMORY: return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return PICVR_ERROR_OUT_OF_DEVICE_MEMORY;
    case VK_ERROR_DEVICE_LOST: ctx->vk.lost = 1; return PICVR_ERROR_DEVICE_LOST;
    default: return PICVR_ERROR_VULKAN;
    }
}

static int picvr_find_memory(picvr_context *ctx, uint32_t bits, VkMemoryPropertyFlags need,
                       VkMemoryPropertyFlags want) {
    int fallback = -1;
    for (uint32_t i = 0; i < ctx->vk.mem_props.memoryTypeCount; i++) {
        VkMemoryPropertyFlags f = ctx->vk.mem_props.memoryTypes[i].propertyFlags;
        if (!(bits & (1u << i)) || (f & need) != need) continue;
        if ((f & want) == want) return (int)i;
        if (fallback < 0) fallback = (int)i;
    }
    return fallback;
}

static picvr_status picvr_alloc_memory(picvr_context *ctx, VkMemoryRequirements req,
                                 VkMemoryPropertyFlags need, VkMemoryPropertyFlags want,
                                 VkDeviceMemory *out, VkMemoryPropertyFlags *got) {
    int type = picvr_find_memory(ctx, req.memoryTypeBits, need, want);
    if (type < 0) return PICVR_ERROR_OUT_OF_DEVICE_MEMORY;
    VkMemoryAllocateInfo ai = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, NULL, req.size, (uint32_t)type};
    VkResult r = vkAllocateMemory(ctx->vk.device, &ai, NULL, out);
    if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY) {
        picvr_log_message(ctx, PICVR_LOG_WARNING, "device allocation of %llu bytes failed", (unsigned long long)req.size);
        return r == VK_ERROR_OUT_OF_HOST_MEMORY ? PICVR_ERROR_OUT_OF_HOST_MEMORY : PICVR_ERROR_OUT_OF_DEVICE_MEMORY;
    }
    if (got) *got = ctx->vk.mem_props.memoryTypes[type].propertyFlags;
    return picvr_vk_status(ctx, r, "vkAllocateMemory");
}

static void picvr_buffer_destroy(picvr_context *ctx, picvr_buffer *b) {
    if (b->mapped) vkUnmapMemory(ctx->vk.device, b->mem);
    if (b->buf) vkDestroyBuffer(ctx->vk.device, b->buf, NULL);
    if (b->mem) vkFreeMemory(ctx->vk.device, b->mem, NULL);
    memset(b, 0, sizeof *b);
}

/* host: 1 = host visible and mapped (for uniforms, staging, readback). */
static picvr_status picvr_buffer_create(picvr_context *ctx, picvr_buffer *b, VkDeviceSize size,
                                  VkBufferUsageFlags usage, int host) {
    memset(b, 0, sizeof *b);
    VkBufferCreateInfo bi;
    PICVR_VK_INIT(bi, VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO);
    bi.size = size;
    bi.usage = usage;
    bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    PICVR_VK_TRY(ctx, vkCreateBuffer(ctx->vk.device, &bi, NULL, &b->buf));
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(ctx->vk.device, b->buf, &req);
    VkMemoryPropertyFlags got = 0;
    picvr_status s = host
        ? picvr_alloc_memory(ctx, req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                       VK_MEMORY_PROPERTY_HOST_COHERENT_BIT | VK_MEMORY_PROPERTY_HOST_CACHED_BIT, &b->mem, &got)
        : picvr_alloc_memory(ctx, req, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, &b->mem, &got);
    if (s) { picvr_buffer_destroy(ctx, b); return s; }
    b->size = size;
    s = picvr_vk_status(ctx, vkBindBufferMemory(ctx->vk.device, b->buf, b->mem, 0), "vkBindBufferMemory");
    if (!s && host) {
        s = picvr_vk_status(ctx, vkMapMemory(ctx->vk.device, b->mem, 0, VK_WHOLE_SIZE, 0, &b->mapped), "vkMapMemory");
        b->coherent = (got & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) != 0;
    }
    if (s) picvr_buffer_destroy(ctx, b);
    return s;
}

static void picvr_buffer_invalidate(picvr_context *ctx, picvr_buffer *b) {
    if (b->coherent) return;
    VkMappedMemoryRange r = {VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE, NULL, b->mem, 0, VK_WHOLE_SIZE};
    vkInvalidateMappedMemoryRanges(ctx->vk.device, 1, &r);
}

static void picvr_buffer_flush(picvr_context *ctx, picvr_buffer *b) {
    if (b->coherent) return;
    VkMappedMemoryRange r = {VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE, NULL, b->mem, 0, VK_WHOLE_SIZE};
    vkFlushMappedMemoryRanges(ctx->vk.device, 1, &r);
}

static void picvr_image_destroy(picvr_context *ctx, picvr_image *im) {
    if (im->view) vkDestroyImageView(ctx->vk.device, im->view, NULL);
    if (im->img) vkDestroyImage(ctx->vk.device, im->img, NULL);
    if (im->mem) vkFreeMemory(ctx->vk.device, im->mem, NULL);
    memset(im, 0, sizeof *im);
}

static picvr_status picvr_image_create(picvr_context *ctx, picvr_image *im, VkImageType type, VkFormat fmt,
                                 uint32_t w, uint32_t h, uint32_t d) {
    memset(im, 0, sizeof *im);
    VkImageCreateInfo ii;
    PICVR_VK_INIT(ii, VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO);
    ii.imageType = type;
    ii.format = fmt;
    ii.extent = picvr_extent(w, h, d);
    ii.mipLevels = 1;
    ii.arrayLayers = 1;
    ii.samples = VK_SAMPLE_COUNT_1_BIT;
    ii.tiling = VK_IMAGE_TILING_OPTIMAL;
    ii.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    ii.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkResult r = vkCreateImage(ctx->vk.device, &ii, NULL, &im->img);
    if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY) return PICVR_ERROR_OUT_OF_DEVICE_MEMORY;
    PICVR_VK_TRY(ctx, r);
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(ctx->vk.device, im->img, &req);
    picvr_status s = picvr_alloc_memory(ctx, req, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, &im->mem, NULL);
    if (!s) s = picvr_vk_status(ctx, vkBindImageMemory(ctx->vk.device, im->img, im->mem, 0), "vkBindImageMemory");
    if (!s) {
        VkImageViewCreateInfo vi;
        PICVR_VK_INIT(vi, VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO);
        vi.image = im->img;
        vi.viewType = type == VK_IMAGE_TYPE_3D ? VK_IMAGE_VIEW_TYPE_3D : VK_IMAGE_VIEW_TYPE_1D;
        vi.format = fmt;
        vi.subresourceRange = picvr_color_range();
        s = picvr_vk_status(ctx, vkCreateImageView(ctx->vk.device, &vi, NULL, &im->view), "vkCreateImageView");
    }
    if (s) picvr_image_destroy(ctx, im);
    return s;
}

static picvr_status picvr_cmd_begin(picvr_context *ctx) {
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    PICVR_VK_TRY(ctx, vkResetCommandBuffer(ctx->vk.cmd, 0));
    VkCommandBufferBeginInfo bi;
    PICVR_VK_INIT(bi, VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO);
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    PICVR_VK_TRY(ctx, vkBeginCommandBuffer(ctx->vk.cmd, &bi));
    return PICVR_OK;
}

/* A full compute/transfer memory barrier: earlier writes visible to later accesses. */
static void picvr_barrier_all(picvr_context *ctx) {
    VkMemoryBarrier mb;
    PICVR_VK_INIT(mb, VK_STRUCTURE_TYPE_MEMORY_BARRIER);
    mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_HOST_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                       VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT | VK_ACCESS_UNIFORM_READ_BIT |
                       VK_ACCESS_INDIRECT_COMMAND_READ_BIT;
    VkPipelineStageFlags src = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
                               VK_PIPELINE_STAGE_HOST_BIT;
    VkPipelineStageFlags dst = src | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT;
    vkCmdPipelineBarrier(ctx->vk.cmd, src, dst, 0, 1, &mb, 0, NULL, 0, NULL);
}

/* Ends the command buffer and submits it with the fence; wait (stage: wait_stage)
   and signal are optional binary semaphores. */
static picvr_status picvr_cmd_submit_with(picvr_context *ctx, VkSemaphore wait, VkPipelineStageFlags wait_stage,
                                          VkSemaphore signal) {
    PICVR_VK_TRY(ctx, vkEndCommandBuffer(ctx->vk.cmd));
    PICVR_VK_TRY(ctx, vkResetFences(ctx->vk.device, 1, &ctx->vk.fence));
    VkSubmitInfo si;
    PICVR_VK_INIT(si, VK_STRUCTURE_TYPE_SUBMIT_INFO);
    si.commandBufferCount = 1;
    si.pCommandBuffers = &ctx->vk.cmd;
    si.waitSemaphoreCount = wait != VK_NULL_HANDLE;
    si.pWaitSemaphores = &wait;
    si.pWaitDstStageMask = &wait_stage;
    si.signalSemaphoreCount = signal != VK_NULL_HANDLE;
    si.pSignalSemaphores = &signal;
    PICVR_VK_TRY(ctx, vkQueueSubmit(ctx->vk.queue, 1, &si, ctx->vk.fence));
    return PICVR_OK;
}

/* Waits up to timeout_ns for the last submission: PICVR_ERROR_TIMEOUT if it is still
   running. */
static picvr_status picvr_cmd_wait(picvr_context *ctx, uint64_t timeout_ns) {
    VkResult r = vkWaitForFences(ctx->vk.device, 1, &ctx->vk.fence, VK_TRUE, timeout_ns);
    if (r == VK_TIMEOUT) return PICVR_ERROR_TIMEOUT;
    PICVR_VK_TRY(ctx, r);
    return PICVR_OK;
}

static picvr_status picvr_cmd_submit_wait(picvr_context *ctx) {
    picvr_status s = picvr_cmd_submit_with(ctx, VK_NULL_HANDLE, 0, VK_NULL_HANDLE);
    return s ? s : picvr_cmd_wait(ctx, UINT64_MAX);
}

static void picvr_image_barrier(picvr_context *ctx, VkImage img, VkImageLayout from, VkImageLayout to) {
    VkImageMemoryBarrier b;
    PICVR_VK_INIT(b, VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER);
    b.srcAccessMask = from == VK_IMAGE_LAYOUT_UNDEFINED ? 0 : VK_ACCESS_TRANSFER_WRITE_BIT;
    b.dstAccessMask = to == VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL ? VK_ACCESS_TRANSFER_WRITE_BIT : VK_ACCESS_SHADER_READ_BIT;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = img;
    b.subresourceRange = picvr_color_range();
    VkPipelineStageFlags src = from == VK_IMAGE_LAYOUT_UNDEFINED ? VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT : VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkPipelineStageFlags dst = to == VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL ? VK_PIPELINE_STAGE_TRANSFER_BIT : VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT;
    vkCmdPipelineBarrier(ctx->vk.cmd, src, dst, 0, 0, NULL, 0, NULL, 1, &b);
}

/* Copies host bytes into a device-local buffer through a temporary staging buffer. */
static picvr_status picvr_upload_buffer(picvr_context *ctx, picvr_buffer *dst, const void *data, size_t size) {
    picvr_buffer staging;
    picvr_status s = picvr_buffer_create(ctx, &staging, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 1);
    if (s) return s;
    memcpy(staging.mapped, data, size);
    picvr_buffer_flush(ctx, &staging);
    s = picvr_cmd_begin(ctx);
    if (!s) {
        picvr_barrier_all(ctx);
        VkBufferCopy region = {0, 0, size};
        vkCmdCopyBuffer(ctx->vk.cmd, staging.buf, dst->buf, 1, &region);
        picvr_barrier_all(ctx);
        s = picvr_cmd_submit_wait(ctx);
    }
    picvr_buffer_destroy(ctx, &staging);
    return s;
}

static VKAPI_ATTR VkBool32 VKAPI_CALL picvr_validation_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT type,
                                                     const VkDebugUtilsMessengerCallbackDataEXT *data,
                                                     void *user) {
    picvr_context *ctx = (picvr_context *)user;
    if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
#if PICVR_THREADS
        if (ctx->vk.message_lock_ready) pthread_mutex_lock(&ctx->vk.message_lock);
#endif
        ctx->vk.validation_messages++;
        picvr_log_message(ctx, PICVR_LOG_ERROR, "validation: %s", data && data->pMessage ? data->pMessage : "?");
#if PICVR_THREADS
        if (ctx->vk.message_lock_ready) pthread_mutex_unlock(&ctx->vk.message_lock);
#endif
    }
    (void)type;
    return VK_FALSE;
}

static int picvr_has_layer(const char *name) {
    uint32_t n = 0;
    vkEnumerateInstanceLayerProperties(&n, NULL);
    VkLayerProperties props[64];
    if (n > 64) n = 64;
    vkEnumerateInstanceLayerProperties(&n, props);
    for (uint32_t i = 0; i < n; i++)
        if (!strcmp(props[i].layerName, name)) return 1;
    return 0;
}

/* picvr.h, ENVIRONMENT: PICVR_VALIDATION=0 always wins, OFF beats PICVR_VALIDATION=1. */
static int picvr_want_validation(const picvr_config *cfg) {
    const char *env = getenv("PICVR_VALIDATION");
    if (env && env[0] == '0') return 0;
    if (cfg->validation == PICVR_SWITCH_OFF) return 0;
    if (env && env[0] == '1') return 1;
    return cfg->validation == PICVR_SWITCH_ON;
}

static picvr_status picvr_create_instance(picvr_context *ctx, int validation) {
    VkApplicationInfo app;
    PICVR_VK_INIT(app, VK_STRUCTURE_TYPE_APPLICATION_INFO);
    app.pApplicationName = "picvr";
    app.pEngineName = "picvr";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo ci;
    PICVR_VK_INIT(ci, VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO);
    ci.pApplicationInfo = &app;
    const char *layer = "VK_LAYER_KHRONOS_validation";
    const char *exts[] = {VK_EXT_DEBUG_UTILS_EXTENSION_NAME};
    VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
    VkValidationFeaturesEXT features;
    PICVR_VK_INIT(features, VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT);
    features.enabledValidationFeatureCount = 1;
    features.pEnabledValidationFeatures = enables;
    if (validation && !picvr_has_layer(layer)) {
        picvr_log_message(ctx, PICVR_LOG_WARNING, "validation requested but %s is not installed", layer);
        validation = 0;
    }
    if (validation) {
        ci.enabledLayerCount = 1;
        ci.ppEnabledLayerNames = &layer;
        ci.enabledExtensionCount = 1;
        ci.ppEnabledExtensionNames = exts;
        ci.pNext = &features;
    }
    VkResult r = vkCreateInstance(&ci, NULL, &ctx->vk.instance);
    if (r == VK_ERROR_INCOMPATIBLE_DRIVER) {
        /* The loader found no driver it could load (VK_LOADER_DEBUG=error says why). */
        picvr_log_message(ctx, PICVR_LOG_ERROR, "vkCreateInstance: no Vulkan driver could be loaded");
        return PICVR_ERROR_NO_DEVICE;
    }
    PICVR_VK_TRY(ctx, r);
    if (validation) {
        PFN_vkCreateDebugUtilsMessengerEXT create = (PFN_vkCreateDebugUtilsMessengerEXT)
            vkGetInstanceProcAddr(ctx->vk.instance, "vkCreateDebugUtilsMessengerEXT");
        VkDebugUtilsMessengerCreateInfoEXT mi;
        PICVR_VK_INIT(mi, VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT);
        mi.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
        mi.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                         VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
        mi.pfnUserCallback = picvr_validation_callback;
        mi.pUserData = ctx;
        if (create) PICVR_VK_TRY(ctx, create(ctx->vk.instance, &mi, NULL, &ctx->vk.messenger));
        ctx->vk.validation_enabled = 1;
    }
    return PICVR_OK;
}

const char *picvr_device_type_string(picvr_device_type type) {
    switch (type) {
    case PICVR_DEVICE_INTEGRATED_GPU: return "integrated-gpu";
    case PICVR_DEVICE_DISCRETE_GPU: return "discrete-gpu";
    case PICVR_DEVICE_VIRTUAL_GPU: return "virtual-gpu";
    case PICVR_DEVICE_CPU: return "cpu";
    default: return "other";
    }
}

/* lavapipe and other CPU drivers: llvmpipe's loop bound and one workgroup per core
   (docs/lavapipe.md) shape the sample cap and the creation batch. */
static int picvr_on_cpu_device(const picvr_context *ctx) {
    return ctx->vk.props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
}

static picvr_device_type picvr_device_type_of(VkPhysicalDeviceType t) {
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return PICVR_DEVICE_INTEGRATED_GPU;
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return PICVR_DEVICE_DISCRETE_GPU;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return PICVR_DEVICE_VIRTUAL_GPU;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return PICVR_DEVICE_CPU;
    default: return PICVR_DEVICE_OTHER;
    }
}

static int picvr_device_rank(VkPhysicalDeviceType t) {
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
    }
}

static int picvr_compute_family(VkPhysicalDevice pd, uint32_t *family) {
    uint32_t n = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, NULL);
    VkQueueFamilyProperties props[32];
    if (n > 32) n = 32;
    vkGetPhysicalDeviceQueueFamilyProperties(pd, &n, props);
    for (uint32_t i = 0; i < n; i++)
        if (props[i].queueFlags & VK_QUEUE_COMPUTE_BIT) { *family = i; return 1; }
    return 0;
}

/* Best device by type (discrete > integrated > virtual > CPU), or the first whose
   name contains `want`. */
static picvr_status picvr_pick_device(picvr_context *ctx, const char *want) {
    uint32_t n = 0;
    PICVR_VK_TRY(ctx, vkEnumeratePhysicalDevices(ctx->vk.instance, &n, NULL));
    VkPhysicalDevice devs[16];
    if (n > 16) n = 16;
    VkResult r = vkEnumeratePhysicalDevices(ctx->vk.instance, &n, devs);
    if (r != VK_SUCCESS && r != VK_INCOMPLETE) return picvr_vk_status(ctx, r, "vkEnumeratePhysicalDevices");
    int best = -1, best_rank = -1;
    for (uint32_t i = 0; i < n; i++) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(devs[i], &p);
        uint32_t fam;
        if (p.apiVersion < VK_API_VERSION_1_1 || !picvr_compute_family(devs[i], &fam)) continue;
        if (want && *want && !strstr(p.deviceName, want)) continue;
        if (picvr_device_rank(p.deviceType) > best_rank) { best = (int)i; best_rank = picvr_device_rank(p.deviceType); }
    }
    if (best < 0) {
        picvr_log_message(ctx, PICVR_LOG_ERROR, "no Vulkan 1.1 compute device%s%s", want && *want ? " matching " : "", want ? want : "");
        return PICVR_ERROR_NO_DEVICE;
    }
    ctx->vk.phys = devs[best];
    picvr_compute_family(ctx->vk.phys, &ctx->vk.queue_family);
    return PICVR_OK;
}

static picvr_status picvr_create_device(picvr_context *ctx) {
    float prio = 1.0f;
    VkDeviceQueueCreateInfo qi;
    PICVR_VK_INIT(qi, VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO);
    qi.queueFamilyIndex = ctx->vk.queue_family;
    qi.queueCount = 1;
    qi.pQueuePriorities = &prio;
    VkDeviceCreateInfo di;
    PICVR_VK_INIT(di, VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO);
    di.queueCreateInfoCount = 1;
    di.pQueueCreateInfos = &qi;
    PICVR_VK_TRY(ctx, vkCreateDevice(ctx->vk.phys, &di, NULL, &ctx->vk.device));
    vkGetDeviceQueue(ctx->vk.device, ctx->vk.queue_family, 0, &ctx->vk.queue);
    return PICVR_OK;
}

static int picvr_format_filters(picvr_context *ctx, VkFormat f) {
    VkFormatProperties p;
    vkGetPhysicalDeviceFormatProperties(ctx->vk.phys, f, &p);
    VkFormatFeatureFlags need = VK_FORMAT_FEATURE_SAMPLED_IMAGE_BIT | VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT |
                                VK_FORMAT_FEATURE_TRANSFER_DST_BIT;
    return (p.optimalTilingFeatures & need) == need;
}

/* Fills one extension's properties struct (its sType set, pNext NULL) through
   vkGetPhysicalDeviceProperties2. */
static void picvr_query_properties(const picvr_context *ctx, void *properties) {
    VkPhysicalDeviceProperties2 p2;
    PICVR_VK_INIT(p2, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2);
    p2.pNext = properties;
    vkGetPhysicalDeviceProperties2(ctx->vk.phys, &p2);
}

/* The smaller of one allocation's limit (maxMemoryAllocationSize) and the largest
   device-local heap; 0 when neither is known. */
static VkDeviceSize picvr_volume_alloc_limit(const picvr_context *ctx) {
    VkPhysicalDeviceMaintenance3Properties m3;
    PICVR_VK_INIT(m3, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES);
    picvr_query_properties(ctx, &m3);
    VkDeviceSize heap = 0;
    for (uint32_t i = 0; i < ctx->vk.mem_props.memoryHeapCount; i++)
        if ((ctx->vk.mem_props.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) && ctx->vk.mem_props.memoryHeaps[i].size > heap)
            heap = ctx->vk.mem_props.memoryHeaps[i].size;
    VkDeviceSize lim = m3.maxMemoryAllocationSize;
    if (heap && (!lim || heap < lim)) lim = heap;
    return lim;
}

/* Whether the physical device offers a device extension (a properties query may chain
   an extension's struct only then). */
static int picvr_device_has_extension(const picvr_context *ctx, const char *name) {
    uint32_t n = 0;
    if (vkEnumerateDeviceExtensionProperties(ctx->vk.phys, NULL, &n, NULL) != VK_SUCCESS || n == 0) return 0;
    VkExtensionProperties *props = (VkExtensionProperties *)picvr_host_alloc(&ctx->config.allocator, (size_t)n * sizeof *props);
    if (!props) return 0;
    int found = 0;
    if (vkEnumerateDeviceExtensionProperties(ctx->vk.phys, NULL, &n, props) == VK_SUCCESS)
        for (uint32_t i = 0; i < n && !found; i++) found = !strcmp(props[i].extensionName, name);
    picvr_host_free(&ctx->config.allocator, props);
    return found;
}

/* Creation workgroups a GPU runs side by side: SMs x warps per SM over the warps of one
   workgroup (VK_NV_shader_sm_builtins); other GPUs report nothing comparable, so a
   modest 256.  0 on a CPU device. */
static uint32_t picvr_gpu_resident_groups(const picvr_context *ctx) {
    if (picvr_on_cpu_device(ctx)) return 0;
    if (!picvr_device_has_extension(ctx, VK_NV_SHADER_SM_BUILTINS_EXTENSION_NAME)) return 256;
    VkPhysicalDeviceShaderSMBuiltinsPropertiesNV sm;
    PICVR_VK_INIT(sm, VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_SM_BUILTINS_PROPERTIES_NV);
    picvr_query_properties(ctx, &sm);
    uint64_t warps_per_group = (PICVR_CACHE_CREATE_GROUP + 31) / 32;
    uint64_t groups = (uint64_t)sm.shaderSMCount * sm.shaderWarpsPerSM / warps_per_group;
    return groups < 256 ? 256u : groups > 65536 ? 65536u : (uint32_t)groups;
}
