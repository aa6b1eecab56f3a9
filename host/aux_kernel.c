/* host/aux_kernel.c - the kernels outside the procedures (picvr_write_image's encoder,
 * the reprojection of temporal reuse): each with a descriptor set of its own (storage
 * buffers only) and 128 bytes of push constants, made at its first use, so that a
 * context that never needs one holds none of it.  Part of picvr_vk.c; uses util, vulkan,
 * pipelines (picvr_create_shader, picvr_create_pipeline). */

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

/* A descriptor set layout of `bindings` (at most PICVR_AUX_BINDINGS) storage buffers,
   bindings 0..n-1, for compute. */
static picvr_status picvr_storage_set_layout(picvr_context *ctx, uint32_t bindings, VkDescriptorSetLayout *out) {
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
    return picvr_vk_status(ctx, vkCreateDescriptorSetLayout(ctx->vk.device, &li, NULL, out), "vkCreateDescriptorSetLayout");
}

/* Makes kernel k from SPIR-V `code` (size bytes) with `bindings` (at most
   PICVR_AUX_BINDINGS) storage buffers, once; a failure leaves nothing behind. */
static picvr_status picvr_aux_kernel_make(picvr_context *ctx, picvr_aux_kernel *k, uint32_t bindings,
                                          const uint32_t *code, size_t size) {
    if (k->pipe) return PICVR_OK;
    if (bindings > PICVR_AUX_BINDINGS) return PICVR_ERROR_INVALID_ARGUMENT;
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
    picvr_status s = picvr_storage_set_layout(ctx, bindings, &k->set_layout);
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
