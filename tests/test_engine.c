/* test_engine.c - what an engine needs: real-time frames without holes
 * (scheduler.frames), steps that do not block (picvr_step_begin / picvr_step_end), and
 * the image written into a VkImage of the application's (picvr_write_image), consumed
 * by the application's own command buffer with the validation layer's synchronization
 * validation on.
 *
 * The application's device is a first context's (picvr_get_config hands out its
 * handles, as an engine would pass its own): that context's validation messenger sees
 * every call of the second context and of this file on the device, and tu_finish fails
 * on any message. */
#include "test_util.h"

#include <vulkan/vulkan.h>

/* ---- frames ------------------------------------------------------------------------- */

static picvr_context *frames_context(picvr_switch frames, picvr_switch priorities) {
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = 11;
    cfg.scheduler.frames = frames;
    cfg.scheduler.priorities = priorities;
    return tu_create_config(&cfg);
}

static void frames_scene(picvr_context *ctx, const tu_vol *vol, uint32_t w, uint32_t h, double az) {
    tu_upload(ctx, vol);
    tu_tf_const(ctx, 0.8f, 0.8f, 0.8f, 1.0f, 0.05f);
    tu_sun(ctx, 1, 1, 1, 1, 1, 1, 2.0f, 0.3f);
    tu_set_camera(ctx, 40 * sin(az), 5, 40 * cos(az), 0, 0, 0, 40, w, h);
}

/* Every pixel's sample count after a step (asserts the buffer read). */
static uint32_t *sample_counts(picvr_context *ctx, uint32_t w, uint32_t h) {
    uint32_t *n = (uint32_t *)malloc((size_t)w * h * sizeof *n);
    assert_non_null(n);
    TU_OK(picvr_read_sample_counts(ctx, n, (size_t)w * h));
    return n;
}

/* With scheduler.frames on, a step of 0 ms still leaves no pixel without a sample, after
   the first camera and after every move; every pixel has its first sample before any
   has a third (the blocks beyond the first pass continue the same round-robin order,
   so at most a second).  stats.pixels_unsampled agrees with the sample counts read
   back. */
void test_frames_leave_no_hole(void **state) {
    (void)state;
    const uint32_t w = 200, h = 120;   /* 13 x 15 blocks, the last column and row partial */
    tu_vol vol = tu_vol_ball(24);
    picvr_context *ctx = frames_context(PICVR_SWITCH_ON, PICVR_SWITCH_ON);
    for (int move = 0; move < 4; move++) {
        frames_scene(ctx, &vol, w, h, 0.4 * move);
        TU_OK(picvr_step(ctx, 0.0));
        picvr_stats st = tu_stats_finite(ctx);
        uint32_t *n = sample_counts(ctx, w, h);
        uint64_t holes = 0;
        uint32_t most = 0;
        for (size_t i = 0; i < (size_t)w * h; i++) {
            holes += n[i] == 0;
            most = n[i] > most ? n[i] : most;
        }
        print_message("frames: move %d: %llu unsampled (stats %llu), samples per pixel %u..%u\n", move,
                      (unsigned long long)holes, (unsigned long long)st.pixels_unsampled, st.iterations_min, most);
        assert_int_equal(holes, 0);
        assert_int_equal(st.pixels_unsampled, 0);
        assert_true(st.iterations_min >= 1);
        assert_true(most <= 2);
        free(n);
    }
    /* after the first pass, priorities choose: more steps keep every pixel sampled */
    for (int i = 0; i < 3; i++) TU_OK(picvr_step(ctx, 5.0));
    picvr_stats st = tu_stats_finite(ctx);
    assert_int_equal(st.pixels_unsampled, 0);
    tu_finish(ctx);
    tu_vol_free(&vol);
}

/* Without frames, stats.pixels_unsampled counts the holes the sample counts show
   (all of them before any step); turning frames on with picvr_set_scheduler after
   priority rounds restarts the first pass, so the next step leaves none. */
void test_frames_turned_on_later(void **state) {
    (void)state;
    const uint32_t w = 256, h = 256;
    tu_vol vol = tu_vol_ball(24);
    picvr_context *ctx = frames_context(PICVR_SWITCH_OFF, PICVR_SWITCH_ON);
    frames_scene(ctx, &vol, w, h, 0.0);
    picvr_stats st = tu_stats_finite(ctx);
    assert_int_equal(st.pixels_unsampled, (uint64_t)w * h);
    TU_OK(picvr_step(ctx, 0.0));
    st = tu_stats_finite(ctx);
    uint32_t *n = sample_counts(ctx, w, h);
    uint64_t holes = 0;
    for (size_t i = 0; i < (size_t)w * h; i++) holes += n[i] == 0;
    free(n);
    print_message("frames off: a 0 ms step leaves %llu of %u pixels unsampled\n", (unsigned long long)holes, w * h);
    assert_int_equal(st.pixels_unsampled, holes);
    picvr_scheduler_config sc;
    memset(&sc, 0, sizeof sc);
    sc.frames = PICVR_SWITCH_ON;
    TU_OK(picvr_set_scheduler(ctx, &sc));
    TU_OK(picvr_step(ctx, 0.0));
    st = tu_stats_finite(ctx);
    assert_int_equal(st.pixels_unsampled, 0);
    tu_finish(ctx);
    tu_vol_free(&vol);
}

/* ---- steps that do not block --------------------------------------------------------- */

/* picvr_step_begin returns before the device is done; until picvr_step_end every other
   call is refused with PICVR_ERROR_BUSY and changes nothing; polling with timeout 0
   ends it; the image is the one a blocking step would give (the background exactly,
   where the rays miss the ball; finite everywhere).  End without begin, and a bad
   budget, are refused without leaving a step begun. */
void test_step_begin_end(void **state) {
    (void)state;
    const uint32_t w = 64, h = 48;
    tu_vol vol = tu_vol_ball(16);
    picvr_context *ctx = frames_context(PICVR_SWITCH_ON, PICVR_SWITCH_ON);
    TU_EXPECT(picvr_step_end(NULL, 0), PICVR_ERROR_NULL_POINTER);
    TU_EXPECT(picvr_step_begin(NULL, 1.0), PICVR_ERROR_NULL_POINTER);
    TU_EXPECT(picvr_step_end(ctx, 0), PICVR_ERROR_NO_STEP);
    TU_EXPECT(picvr_step_begin(ctx, 10.0), PICVR_ERROR_NOT_READY);   /* no volume yet */
    frames_scene(ctx, &vol, w, h, 0.3);
    tu_background_only(ctx, 0.25f, 0.5f, 1.0f, 1.0f);
    TU_EXPECT(picvr_step_begin(ctx, NAN), PICVR_ERROR_NON_FINITE);
    TU_EXPECT(picvr_step_begin(ctx, -1.0), PICVR_ERROR_INVALID_ARGUMENT);
    TU_EXPECT(picvr_step_end(ctx, 0), PICVR_ERROR_NO_STEP);

    TU_OK(picvr_step_begin(ctx, 20.0));
    picvr_stats st;
    picvr_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position[2] = 30;
    cam.width = w;
    cam.height = h;
    float *img = (float *)malloc((size_t)w * h * 16);
    assert_non_null(img);
    picvr_scheduler_config sc;
    memset(&sc, 0, sizeof sc);
    TU_EXPECT(picvr_step_begin(ctx, 1.0), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_step(ctx, 1.0), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_step_iterations(ctx, 1), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_prepare(ctx), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_set_camera(ctx, &cam), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_reset(ctx), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_set_view(ctx, PICVR_VIEW_IMAGE), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_set_scheduler(ctx, &sc), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_set_scattering(ctx, NULL), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_set_lights(ctx, NULL, 0, NULL), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_set_transfer_function(ctx, NULL, 0, 1.0f), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_upload_volume(ctx, NULL), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_read_rgba32f(ctx, img, (size_t)w * h * 16), PICVR_ERROR_BUSY);
    TU_EXPECT(picvr_get_stats(ctx, &st), PICVR_ERROR_BUSY);
    picvr_image_target t;
    memset(&t, 0, sizeof t);
    TU_EXPECT(picvr_write_image(ctx, &t), PICVR_ERROR_BUSY);
    int polls = 0;
    picvr_status s;
    while ((s = picvr_step_end(ctx, 0)) == PICVR_ERROR_TIMEOUT) {
        polls++;
        assert_true(polls < 1000000);
    }
    TU_OK(s);
    print_message("begin/end: %d polls returned PICVR_ERROR_TIMEOUT before the step ended\n", polls);
    TU_EXPECT(picvr_step_end(ctx, 0), PICVR_ERROR_NO_STEP);
    st = tu_stats_finite(ctx);
    assert_int_equal(st.pixels_unsampled, 0);   /* frames: the one round held the whole first pass */
    assert_true(st.iterations_mean >= 1.0);
    TU_OK(picvr_read_rgba32f(ctx, img, (size_t)w * h * 16));
    tu_assert_image_valid(img, w, h, "after begin/end");
    /* a corner pixel misses the ball: the background exactly (it is all that it sees) */
    assert_float_equal(img[0], 0.25f, 1e-6);
    assert_float_equal(img[2], 1.0f, 1e-6);
    /* more begun steps, each ended with an unlimited wait */
    for (int i = 0; i < 5; i++) {
        TU_OK(picvr_step_begin(ctx, 5.0));
        TU_OK(picvr_step_end(ctx, UINT64_MAX));
    }
    picvr_stats st2 = tu_stats_finite(ctx);
    assert_true(st2.iterations_mean > st.iterations_mean);
    free(img);
    tu_finish(ctx);

    /* destroying a context with a step begun waits for it and frees everything (the
       leak checks of make test-asan and valgrind run this) */
    picvr_context *c2 = frames_context(PICVR_SWITCH_OFF, PICVR_SWITCH_ON);
    frames_scene(c2, &vol, w, h, 0.0);
    TU_OK(picvr_step_begin(c2, 5.0));
    TU_EXPECT(picvr_get_stats(c2, &st), PICVR_ERROR_BUSY);
    TU_OK(picvr_step_end(c2, UINT64_MAX));
    TU_OK(picvr_step_begin(c2, 5.0));
    tu_register(c2, 0);
    picvr_destroy(c2);
    tu_vol_free(&vol);
}

/* ---- the image on the device ---------------------------------------------------------- */

/* A second context, seed `seed`, on the Vulkan device of context a, as an application
   passes its own (registered for the teardown); *a_config: a's configuration, whose
   handles the application's side uses. */
static picvr_context *context_on_device_of(picvr_context *a, uint32_t seed, picvr_config *a_config) {
    TU_OK(picvr_get_config(a, a_config));
    picvr_config bc;
    memset(&bc, 0, sizeof bc);
    bc.vulkan = a_config->vulkan;
    bc.seed = seed;
    picvr_context *b = NULL;
    TU_OK(picvr_create(&bc, &b));
    tu_register(b, 1);
    return b;
}

/* The application's side: its device (the first context's), a command buffer, a
   host-visible buffer the image is copied into. */
typedef struct app {
    VkPhysicalDevice phys;
    VkDevice dev;
    VkQueue queue;
    uint32_t family;
    VkCommandPool pool;
    VkCommandBuffer cmd;
    VkFence fence;
    VkBuffer host_buf;
    VkDeviceMemory host_mem;
    void *mapped;
} app;

static uint32_t app_memory_type(const app *a, uint32_t bits, VkMemoryPropertyFlags want) {
    VkPhysicalDeviceMemoryProperties mp;
    vkGetPhysicalDeviceMemoryProperties(a->phys, &mp);
    for (uint32_t i = 0; i < mp.memoryTypeCount; i++)
        if ((bits & (1u << i)) && (mp.memoryTypes[i].propertyFlags & want) == want) return i;
    fail_msg("no memory type with flags %#x", (unsigned)want);
    return 0;
}

static app app_open(const picvr_config *c, VkDeviceSize host_bytes) {
    app a;
    memset(&a, 0, sizeof a);
    a.phys = (VkPhysicalDevice)c->vulkan.physical_device;
    a.dev = (VkDevice)c->vulkan.device;
    a.queue = (VkQueue)c->vulkan.queue;
    a.family = c->vulkan.queue_family;
    VkCommandPoolCreateInfo pi = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO, NULL,
                                  VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT, a.family};
    assert_int_equal(vkCreateCommandPool(a.dev, &pi, NULL, &a.pool), VK_SUCCESS);
    VkCommandBufferAllocateInfo ai = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO, NULL, a.pool,
                                      VK_COMMAND_BUFFER_LEVEL_PRIMARY, 1};
    assert_int_equal(vkAllocateCommandBuffers(a.dev, &ai, &a.cmd), VK_SUCCESS);
    VkFenceCreateInfo fi = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO, NULL, 0};
    assert_int_equal(vkCreateFence(a.dev, &fi, NULL, &a.fence), VK_SUCCESS);
    VkBufferCreateInfo bi;
    memset(&bi, 0, sizeof bi);
    bi.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    bi.size = host_bytes;
    bi.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    assert_int_equal(vkCreateBuffer(a.dev, &bi, NULL, &a.host_buf), VK_SUCCESS);
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(a.dev, a.host_buf, &req);
    VkMemoryAllocateInfo mi = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, NULL, req.size,
                               app_memory_type(&a, req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                               VK_MEMORY_PROPERTY_HOST_COHERENT_BIT)};
    assert_int_equal(vkAllocateMemory(a.dev, &mi, NULL, &a.host_mem), VK_SUCCESS);
    assert_int_equal(vkBindBufferMemory(a.dev, a.host_buf, a.host_mem, 0), VK_SUCCESS);
    assert_int_equal(vkMapMemory(a.dev, a.host_mem, 0, VK_WHOLE_SIZE, 0, &a.mapped), VK_SUCCESS);
    return a;
}

static void app_close(app *a) {
    vkDeviceWaitIdle(a->dev);
    vkUnmapMemory(a->dev, a->host_mem);
    vkDestroyBuffer(a->dev, a->host_buf, NULL);
    vkFreeMemory(a->dev, a->host_mem, NULL);
    vkDestroyFence(a->dev, a->fence, NULL);
    vkDestroyCommandPool(a->dev, a->pool, NULL);
}

typedef struct app_image { VkImage image; VkDeviceMemory mem; } app_image;

static app_image app_image_new(const app *a, VkFormat format, uint32_t w, uint32_t h) {
    app_image im;
    VkImageCreateInfo ci;
    memset(&ci, 0, sizeof ci);
    ci.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    ci.imageType = VK_IMAGE_TYPE_2D;
    ci.format = format;
    ci.extent.width = w;
    ci.extent.height = h;
    ci.extent.depth = 1;
    ci.mipLevels = ci.arrayLayers = 1;
    ci.samples = VK_SAMPLE_COUNT_1_BIT;
    ci.tiling = VK_IMAGE_TILING_OPTIMAL;
    ci.usage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_SAMPLED_BIT;
    ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    assert_int_equal(vkCreateImage(a->dev, &ci, NULL, &im.image), VK_SUCCESS);
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(a->dev, im.image, &req);
    VkMemoryAllocateInfo mi = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO, NULL, req.size,
                               app_memory_type(a, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT)};
    assert_int_equal(vkAllocateMemory(a->dev, &mi, NULL, &im.mem), VK_SUCCESS);
    assert_int_equal(vkBindImageMemory(a->dev, im.image, im.mem, 0), VK_SUCCESS);
    return im;
}

static void app_image_free(const app *a, app_image *im) {
    vkDestroyImage(a->dev, im->image, NULL);
    vkFreeMemory(a->dev, im->mem, NULL);
}

/* The application's second command buffer: the image (left by picvr in `layout`) copied
   into the host buffer, waiting on `wait` (a semaphore picvr signalled) if given.  No
   barrier before the copy: picvr's last barrier made its write visible to every later
   command on the queue, which is what its contract says and what synchronization
   validation checks here. */
static void app_read_image(app *a, VkImage image, VkImageLayout layout, uint32_t w, uint32_t h, VkSemaphore wait) {
    VkCommandBufferBeginInfo bi = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO, NULL,
                                   VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT, NULL};
    assert_int_equal(vkResetCommandBuffer(a->cmd, 0), VK_SUCCESS);
    assert_int_equal(vkBeginCommandBuffer(a->cmd, &bi), VK_SUCCESS);
    VkBufferImageCopy r;
    memset(&r, 0, sizeof r);
    r.imageSubresource.aspectMask = VK_IMAGE_ASPECT_COLOR_BIT;
    r.imageSubresource.layerCount = 1;
    r.imageExtent.width = w;
    r.imageExtent.height = h;
    r.imageExtent.depth = 1;
    vkCmdCopyImageToBuffer(a->cmd, image, layout, a->host_buf, 1, &r);
    VkMemoryBarrier mb = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, NULL, VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT};
    vkCmdPipelineBarrier(a->cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &mb, 0, NULL, 0, NULL);
    assert_int_equal(vkEndCommandBuffer(a->cmd), VK_SUCCESS);
    VkPipelineStageFlags stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
    VkSubmitInfo si;
    memset(&si, 0, sizeof si);
    si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    si.waitSemaphoreCount = wait != VK_NULL_HANDLE;
    si.pWaitSemaphores = &wait;
    si.pWaitDstStageMask = &stage;
    si.commandBufferCount = 1;
    si.pCommandBuffers = &a->cmd;
    assert_int_equal(vkResetFences(a->dev, 1, &a->fence), VK_SUCCESS);
    assert_int_equal(vkQueueSubmit(a->queue, 1, &si, a->fence), VK_SUCCESS);
    assert_int_equal(vkWaitForFences(a->dev, 1, &a->fence, VK_TRUE, UINT64_MAX), VK_SUCCESS);
}

/* Signals `sem` from an empty submission of the application's (an engine's "image is
   free" semaphore, as vkAcquireNextImageKHR would give). */
static void app_signal(app *a, VkSemaphore sem) {
    VkSubmitInfo si;
    memset(&si, 0, sizeof si);
    si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    si.signalSemaphoreCount = 1;
    si.pSignalSemaphores = &sem;
    assert_int_equal(vkQueueSubmit(a->queue, 1, &si, VK_NULL_HANDLE), VK_SUCCESS);
}

/* IEEE half to float (the test's own decoder). */
static float half_to_float(uint16_t h) {
    int e = (h >> 10) & 31, m = h & 1023;
    double v = e == 0 ? ldexp(m, -24) : e == 31 ? INFINITY : ldexp(1024 + m, e - 25);
    return (float)((h & 0x8000) ? -v : v);
}

/* Writes the image in every format picvr accepts into the application's images,
   reads each back through the application's command buffer and compares it with
   picvr_read_rgba8 / picvr_read_rgba32f: 8-bit formats within one code (the device
   rounds pow in float, the host in double), BGRA the same bytes swapped, half floats
   within half's rounding (2^-11 relative), float32 bit for bit.  One write waits on a
   semaphore the application signalled and signals one its read waits on; the others
   rely on queue order and picvr's final barrier.  The synchronization validation of
   the first context's messenger must stay silent (tu_finish). */
void test_write_image_formats(void **state) {
    (void)state;
    const uint32_t w = 40, h = 30;
    picvr_context *a = tu_create(5);
    picvr_config c;
    picvr_context *b = context_on_device_of(a, 2, &c);
    tu_vol vol = tu_vol_ball(16);
    frames_scene(b, &vol, w, h, 0.5);
    tu_sun(b, 1, 1, 1, 1, 0.9f, 0.8f, 3.0f, 0.5f);
    TU_OK(picvr_step_iterations(b, 4));
    uint8_t *ref8 = (uint8_t *)malloc((size_t)w * h * 4);
    float *ref32 = (float *)malloc((size_t)w * h * 16);
    assert_true(ref8 && ref32);
    const float exposure = 1.5f;
    TU_OK(picvr_read_rgba8(b, ref8, (size_t)w * h * 4, exposure));
    TU_OK(picvr_read_rgba32f(b, ref32, (size_t)w * h * 16));

    app ap = app_open(&c, (VkDeviceSize)w * h * 16);
    VkSemaphoreCreateInfo si = {VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO, NULL, 0};
    VkSemaphore free_sem, done_sem;
    assert_int_equal(vkCreateSemaphore(ap.dev, &si, NULL, &free_sem), VK_SUCCESS);
    assert_int_equal(vkCreateSemaphore(ap.dev, &si, NULL, &done_sem), VK_SUCCESS);
    const VkFormat formats[6] = {VK_FORMAT_R8G8B8A8_UNORM, VK_FORMAT_R8G8B8A8_SRGB, VK_FORMAT_B8G8R8A8_UNORM,
                                 VK_FORMAT_B8G8R8A8_SRGB, VK_FORMAT_R16G16B16A16_SFLOAT, VK_FORMAT_R32G32B32A32_SFLOAT};
    for (int f = 0; f < 6; f++) {
        app_image im = app_image_new(&ap, formats[f], w, h);
        picvr_image_target t;
        memset(&t, 0, sizeof t);
        t.image = (void *)im.image;
        t.width = w;
        t.height = h;
        t.format = (uint32_t)formats[f];
        t.old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
        t.new_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        t.exposure = exposure;
        int with_sems = f == 0;
        if (with_sems) {
            app_signal(&ap, free_sem);
            t.wait_semaphore = (void *)free_sem;
            t.signal_semaphore = (void *)done_sem;
        }
        TU_OK(picvr_write_image(b, &t));
        if (f == 1) {   /* a second write into the same image, from the layout the first left */
            t.old_layout = t.new_layout;
            TU_OK(picvr_write_image(b, &t));
        }
        app_read_image(&ap, im.image, (VkImageLayout)t.new_layout, w, h, with_sems ? done_sem : VK_NULL_HANDLE);
        int worst = 0;
        double worst_rel = 0.0;
        for (size_t i = 0; i < (size_t)w * h; i++) {
            if (f < 4) {
                const uint8_t *got = (const uint8_t *)ap.mapped + 4 * i;
                for (int ch = 0; ch < 4; ch++) {
                    int src = f >= 2 && ch < 3 ? 2 - ch : ch;   /* BGRA: the bytes swapped */
                    int d = abs((int)got[src] - (int)ref8[4 * i + ch]);
                    worst = d > worst ? d : worst;
                }
            } else if (f == 4) {
                const uint16_t *got = (const uint16_t *)ap.mapped + 4 * i;
                for (int ch = 0; ch < 4; ch++) {
                    double want = ref32[4 * i + ch], have = half_to_float(got[ch]);
                    double rel = fabs(have - want) / (fabs(want) > 6.1e-5 ? fabs(want) : 6.1e-5);
                    worst_rel = rel > worst_rel ? rel : worst_rel;
                }
            } else {
                assert_memory_equal((const float *)ap.mapped + 4 * i, ref32 + 4 * i, 16);
            }
        }
        print_message("write_image: VkFormat %d: largest difference %d codes, %.2g relative\n", (int)formats[f], worst,
                      worst_rel);
        assert_true(worst <= 1);
        assert_true(worst_rel <= 1.0 / 2048.0);
        app_image_free(&ap, &im);
    }
    vkDestroySemaphore(ap.dev, free_sem, NULL);
    vkDestroySemaphore(ap.dev, done_sem, NULL);
    app_close(&ap);
    free(ref8);
    free(ref32);
    tu_register(b, 0);
    picvr_destroy(b);
    tu_vol_free(&vol);
    tu_finish(a);   /* the messenger of a saw b's and this test's calls */
}

/* Hostile targets: each is refused with its status, nothing is submitted, and the
   context still writes a valid image afterwards. */
void test_write_image_bad_targets(void **state) {
    (void)state;
    const uint32_t w = 16, h = 8;
    picvr_context *a = tu_create(6);
    picvr_config c;
    picvr_context *b = context_on_device_of(a, 0, &c);
    app ap = app_open(&c, (VkDeviceSize)w * h * 16);
    app_image im = app_image_new(&ap, VK_FORMAT_R8G8B8A8_UNORM, w, h);
    picvr_image_target ok;
    memset(&ok, 0, sizeof ok);
    ok.image = (void *)im.image;
    ok.width = w;
    ok.height = h;
    ok.format = VK_FORMAT_R8G8B8A8_UNORM;
    ok.old_layout = VK_IMAGE_LAYOUT_UNDEFINED;
    ok.new_layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    TU_EXPECT(picvr_write_image(b, &ok), PICVR_ERROR_NOT_READY);   /* no camera yet */
    tu_vol vol = tu_vol_ball(8);
    frames_scene(b, &vol, w, h, 0.0);
    TU_OK(picvr_step_iterations(b, 1));
    struct { const char *what; picvr_status want; picvr_image_target t; picvr_context *ctx; } rows[16];
    int n = 0;
#define ROW(label, status, change)                                                        \
    do {                                                                                  \
        rows[n].what = label;                                                             \
        rows[n].want = status;                                                            \
        rows[n].t = ok;                                                                   \
        rows[n].ctx = b;                                                                  \
        { picvr_image_target *t = &rows[n].t; (void)t; change; }                          \
        n++;                                                                              \
    } while (0)
    ROW("NULL image", PICVR_ERROR_NULL_POINTER, t->image = NULL);
    ROW("width not the camera's", PICVR_ERROR_INVALID_ARGUMENT, t->width = w + 1);
    ROW("height 0", PICVR_ERROR_INVALID_ARGUMENT, t->height = 0);
    ROW("format R8_UNORM", PICVR_ERROR_INVALID_ARGUMENT, t->format = VK_FORMAT_R8_UNORM);
    ROW("format D32", PICVR_ERROR_INVALID_ARGUMENT, t->format = VK_FORMAT_D32_SFLOAT);
    ROW("format 0xffffffff", PICVR_ERROR_INVALID_ARGUMENT, t->format = 0xffffffffu);
    ROW("old layout PREINITIALIZED", PICVR_ERROR_INVALID_ARGUMENT, t->old_layout = VK_IMAGE_LAYOUT_PREINITIALIZED);
    ROW("old layout 12345", PICVR_ERROR_INVALID_ARGUMENT, t->old_layout = 12345);
    ROW("new layout UNDEFINED", PICVR_ERROR_INVALID_ARGUMENT, t->new_layout = VK_IMAGE_LAYOUT_UNDEFINED);
    ROW("new layout depth", PICVR_ERROR_INVALID_ARGUMENT,
        t->new_layout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL);
    ROW("exposure NaN", PICVR_ERROR_NON_FINITE, t->exposure = NAN);
    ROW("exposure -Inf", PICVR_ERROR_NON_FINITE, t->exposure = -INFINITY);
    ROW("the context made its own device", PICVR_ERROR_INVALID_ARGUMENT, rows[n].ctx = a);
#undef ROW
    for (int i = 0; i < n; i++) {
        print_message("bad target: %-34s -> %s\n", rows[i].what, picvr_status_string(rows[i].want));
        if (rows[i].ctx == a) {   /* a's own device: its camera first, so that only the device is wrong */
            frames_scene(a, &vol, w, h, 0.0);
            TU_OK(picvr_step_iterations(a, 1));
        }
        TU_EXPECT(picvr_write_image(rows[i].ctx, &rows[i].t), rows[i].want);
    }
    TU_EXPECT(picvr_write_image(NULL, &ok), PICVR_ERROR_NULL_POINTER);
    TU_EXPECT(picvr_write_image(b, NULL), PICVR_ERROR_NULL_POINTER);
    /* still usable: a valid write, a step and another write */
    TU_OK(picvr_write_image(b, &ok));
    TU_OK(picvr_step_iterations(b, 1));
    ok.old_layout = ok.new_layout;
    TU_OK(picvr_write_image(b, &ok));
    app_read_image(&ap, im.image, (VkImageLayout)ok.new_layout, w, h, VK_NULL_HANDLE);
    uint8_t ref[16 * 8 * 4];
    TU_OK(picvr_read_rgba8(b, ref, sizeof ref, 1.0f));
    for (size_t i = 0; i < sizeof ref; i++) assert_true(abs((int)((uint8_t *)ap.mapped)[i] - (int)ref[i]) <= 1);
    app_image_free(&ap, &im);
    app_close(&ap);
    tu_register(b, 0);
    picvr_destroy(b);
    tu_vol_free(&vol);
    tu_finish(a);
}

/* ---- temporal reuse -------------------------------------------------------------------- */

static picvr_context *reuse_context(picvr_switch reuse, uint32_t history, uint32_t seed) {
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = seed;
    cfg.scheduler.frames = PICVR_SWITCH_ON;
    cfg.scheduler.temporal_reuse = reuse;
    cfg.scheduler.reuse_history = history;
    return tu_create_config(&cfg);
}

/* Relative RMSE of the luminance of img against ref over the pixels where ref sees the
   medium (ref alpha > 0.5) and, when counts is given, where counts > 0; *used: those. */
static double lum_rel_rmse(const float *img, const float *ref, const uint32_t *counts, size_t n, size_t *used) {
    double se = 0.0, sum = 0.0;
    *used = 0;
    for (size_t i = 0; i < n; i++) {
        if (ref[4 * i + 3] < 0.5f || (counts && counts[i] == 0)) continue;
        double a = tu_lum(img[4 * i], img[4 * i + 1], img[4 * i + 2]), b = tu_lum(ref[4 * i], ref[4 * i + 1], ref[4 * i + 2]);
        se += (a - b) * (a - b);
        sum += b;
        (*used)++;
    }
    return *used && sum > 0.0 ? sqrt(se / (double)*used) / (sum / (double)*used) : 0.0;
}

/* A converged image moved by a small orbit lands where the new view sees the same
   medium: against a converged render of the new view, the moved pixels differ by little
   more than the two images' noise and the one-pixel rounding of the landing; they keep
   at most reuse_history samples; the pixels nothing landed on hold none, and the next
   frame gives them one. */
void test_reuse_moves_the_image(void **state) {
    (void)state;
    const uint32_t w = 96, h = 64, history = 24;
    const size_t n = (size_t)w * h;
    tu_vol vol = tu_vol_ball(32);
    picvr_context *ctx = reuse_context(PICVR_SWITCH_ON, history, 3);
    frames_scene(ctx, &vol, w, h, 0.0);
    TU_OK(picvr_step_iterations(ctx, 48));
    tu_set_camera(ctx, 40 * sin(0.02), 5, 40 * cos(0.02), 0, 0, 0, 40, w, h);   /* 1.15 degrees */
    picvr_stats st = tu_stats_finite(ctx);
    float *moved = tu_read(ctx, w, h);
    uint32_t *counts = sample_counts(ctx, w, h);
    size_t empty = 0;
    uint32_t most = 0;
    for (size_t i = 0; i < n; i++) {
        empty += counts[i] == 0;
        most = counts[i] > most ? counts[i] : most;
    }
    picvr_context *ref_ctx = reuse_context(PICVR_SWITCH_OFF, 0, 4);
    frames_scene(ref_ctx, &vol, w, h, 0.02);
    TU_OK(picvr_step_iterations(ref_ctx, 192));
    float *ref = tu_read(ref_ctx, w, h);
    size_t used;
    double err = lum_rel_rmse(moved, ref, counts, n, &used);
    print_message("reuse: after a 1.15 degree orbit %zu of %zu pixels hold samples (at most %u), %llu unsampled "
                  "by the stats; relative RMSE of the moved image against the new view's %.4f over %zu pixels\n",
                  n - empty, n, most, (unsigned long long)st.pixels_unsampled, err, used);
    assert_true(most <= history);
    assert_int_equal(st.pixels_unsampled, empty);
    assert_true(empty < n / 10);            /* a small move keeps nearly every pixel */
    assert_true(used > n / 4);
    /* 24 samples per pixel of this scene have a relative RMSE near 0.05 (measured
       beside it: the same view at 24 samples against 192); the move adds the
       view-dependence and the landing's rounding. */
    assert_true(err < 0.12);
    TU_OK(picvr_step(ctx, 0.0));
    st = tu_stats_finite(ctx);
    assert_int_equal(st.pixels_unsampled, 0);
    free(moved);
    free(ref);
    free(counts);
    tu_finish(ref_ctx);
    tu_finish(ctx);
    tu_vol_free(&vol);
}

/* What reuse is for: a camera orbiting slowly, one frame of one sample per pixel each.
   Without reuse the last frame is one sample; with it, the samples of the frames before
   moved along.  Against a converged render of the last view, its error is clearly
   lower (measured about half; asserted below 0.75 of the frame without reuse). */
void test_reuse_lowers_the_error_of_moving_frames(void **state) {
    (void)state;
    const uint32_t w = 96, h = 64;
    const size_t n = (size_t)w * h;
    const int frames = 12;
    tu_vol vol = tu_vol_ball(32);
    double err[2];
    float *ref = NULL;
    for (int reuse = 0; reuse < 2; reuse++) {
        picvr_context *ctx = reuse_context(reuse ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF, 0, 7);
        frames_scene(ctx, &vol, w, h, 0.0);
        for (int f = 0; f < frames; f++) {
            double az = 0.004 * f;                    /* 0.23 degrees a frame */
            tu_set_camera(ctx, 40 * sin(az), 5, 40 * cos(az), 0, 0, 0, 40, w, h);
            TU_OK(picvr_step(ctx, 0.0));              /* frames: one pass, one sample per pixel */
        }
        float *img = tu_read(ctx, w, h);
        if (!ref) {
            picvr_context *r = reuse_context(PICVR_SWITCH_OFF, 0, 8);
            frames_scene(r, &vol, w, h, 0.004 * (frames - 1));
            TU_OK(picvr_step_iterations(r, 256));
            ref = tu_read(r, w, h);
            tu_finish(r);
        }
        size_t used;
        err[reuse] = lum_rel_rmse(img, ref, NULL, n, &used);
        picvr_stats st = tu_stats_finite(ctx);
        print_message("reuse %s: last of %d orbiting frames: %.2f samples per pixel, relative RMSE %.4f (%zu pixels)\n",
                      reuse ? "on " : "off", frames, st.iterations_mean, err[reuse], used);
        free(img);
        tu_finish(ctx);
    }
    assert_true(err[1] < 0.75 * err[0]);
    free(ref);
    tu_vol_free(&vol);
}

/* Stiff and extreme moves with reuse on: a half turn (every old point behind the new
   camera), a jump a million times farther, the field of view from 179 to 0.01 degrees,
   the camera inside a medium of 1e4 extinctions per voxel (depths near 0), a 1x1 and a
   1x4096 image: every moved image is finite and non-negative, its holes are what the
   stats count, and the next frame fills them. */
void test_reuse_extreme_moves(void **state) {
    (void)state;
    tu_vol vol = tu_vol_ball(16);
    picvr_context *ctx = reuse_context(PICVR_SWITCH_ON, 0, 9);
    tu_upload(ctx, &vol);
    tu_tf_const(ctx, 0.9f, 0.9f, 0.9f, 1.0f, 0.5f);
    tu_sun(ctx, 1, 1, 1, 1, 1, 1, 2.0f, 0.5f);
    struct { double pos[3], target[3]; float fov; uint32_t w, h; float density; } moves[] = {
        {{0, 0, 30}, {0, 0, 0}, 40, 48, 32, 0.5f},      {{0, 0, -30}, {0, 0, 0}, 40, 48, 32, 0.5f},
        {{0, 0, -3e7}, {0, 0, 0}, 40, 48, 32, 0.5f},    {{0, 0, 30}, {0, 0, 0}, 179, 48, 32, 0.5f},
        {{0, 0, 30}, {0, 0, 0}, 0.01f, 48, 32, 0.5f},   {{0, 0, 30}, {0, 0, 0}, 40, 48, 32, 1e4f},
        {{0.1, 0.2, 0.3}, {5, 0, 0}, 90, 48, 32, 1e4f}, {{0.1, 0.3, 0.3}, {5, 1, 0}, 90, 48, 32, 1e4f},
        {{0, 0, 30}, {0, 0, 0}, 40, 1, 1, 0.5f},        {{1, 0, 30}, {0, 0, 0}, 40, 1, 1, 0.5f},
        {{0, 0, 30}, {0, 0, 0}, 40, 1, 4096, 0.5f},     {{0, 3, 30}, {0, 0, 0}, 40, 1, 4096, 0.5f}};
    float density = 0.5f;
    for (size_t m = 0; m < sizeof moves / sizeof moves[0]; m++) {
        if (moves[m].density != density) {
            density = moves[m].density;
            tu_tf_const(ctx, 0.9f, 0.9f, 0.9f, 1.0f, density);
        }
        picvr_camera c;
        memset(&c, 0, sizeof c);
        for (int i = 0; i < 3; i++) {
            c.position[i] = (float)moves[m].pos[i];
            c.target[i] = (float)moves[m].target[i];
        }
        c.fov_y_degrees = moves[m].fov;
        c.width = moves[m].w;
        c.height = moves[m].h;
        TU_OK(picvr_set_camera(ctx, &c));
        picvr_stats st = tu_stats_finite(ctx);
        float *img = tu_read(ctx, c.width, c.height);
        tu_assert_image_valid(img, c.width, c.height, "moved image");
        free(img);
        uint64_t before = st.pixels_unsampled;
        assert_true(before <= (uint64_t)c.width * c.height);
        TU_OK(picvr_step(ctx, 0.0));
        st = tu_stats_finite(ctx);
        print_message("reuse, extreme move %zu: %llu of %u pixels empty after the move, %llu after a frame\n", m,
                      (unsigned long long)before, c.width * c.height, (unsigned long long)st.pixels_unsampled);
        assert_int_equal(st.pixels_unsampled, 0);
        TU_OK(picvr_step_iterations(ctx, 2));
    }
    tu_finish(ctx);
    tu_vol_free(&vol);
}

/* Reuse is deterministic: where several old pixels land on one new pixel the nearest,
   then the lowest old index, wins, whatever order the device's threads run in.  Two
   contexts with one seed, the same moves and one pass a frame give bit-identical images. */
void test_reuse_is_deterministic(void **state) {
    (void)state;
    const uint32_t w = 64, h = 48;
    tu_vol vol = tu_vol_ball(24);
    float *img[2];
    for (int run = 0; run < 2; run++) {
        picvr_context *ctx = reuse_context(PICVR_SWITCH_ON, 0, 21);
        frames_scene(ctx, &vol, w, h, 0.0);
        for (int f = 0; f < 8; f++) {
            double az = 0.05 * f;   /* 2.9 degrees a frame: many landings collide */
            tu_set_camera(ctx, 40 * sin(az), 5 + f, 40 * cos(az), 0, 0, 0, 40, w, h);
            TU_OK(picvr_step(ctx, 0.0));
        }
        img[run] = tu_read(ctx, w, h);
        tu_finish(ctx);
    }
    assert_memory_equal(img[0], img[1], (size_t)w * h * 16);
    free(img[0]);
    free(img[1]);
    tu_vol_free(&vol);
}
