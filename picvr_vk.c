/* picvr_vk.c - the Vulkan implementation of picvr.h.  See ARCHITECTURE.md for the
 * data flow (upload -> majorant grid -> render dispatches -> accumulation buffers ->
 * stats reduction / image readback).  One file, no global state. */
#include "picvr.h"
#include "picvr_shaders.h"

#include <vulkan/vulkan.h>

#include <float.h>
#include <stddef.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#if defined(__unix__) || defined(__APPLE__)
#include <unistd.h>
#endif

#define PICVR_FINE_THRESHOLD 64.0          /* expected steps per brick above which the shader
                                      tracks at voxel level (shaders: FINE_THRESHOLD) */
#define PICVR_TF_SIZE 4096               /* entries of the transfer-function table (shaders: TF_SIZE) */
#define PICVR_MAX_GRID 64                /* majorant grid cells per axis at most */
#define PICVR_STAGING_CHUNK (32u << 20)  /* bytes per volume upload slab */
#define PICVR_BATCH_TARGET_MS 100.0      /* picvr_step_iterations: one submission at most this long */
#define PICVR_MAX_BATCH 1024u
#define PICVR_SCHED_HISTORY 128u         /* rounds remembered for the time shares and the hit rate */
#define PICVR_SHARE_WINDOW_MS 1000.0     /* stats.fraction_*: measured over the last second */
#define PICVR_MAX_QUEUE 65535u           /* blocks per dispatch (shaders/block_select.comp) */
/* Sizes of the shaders' buffer elements (std430), mirrored here; `make check-layout`
   (part of `make test`) compares them with glslang's reflection of the shaders. */
#define PICVR_CACHE_NODE_BYTES 16u       /* struct Node */
#define PICVR_CACHE_REF_BYTES 8u         /* struct Ref */
#define PICVR_CACHE_REQUEST_BYTES 32u    /* struct Request */
#define PICVR_CACHE_ENTRY_BYTES 144u     /* struct Entry */
/* Eq. 5's sample cap (cache.max_samples; its limits PICVR_CACHE_MAX_SAMPLES and
   PICVR_CACHE_MAX_SAMPLES_CPU are in picvr.h): rounds of the 128-thread creation
   workgroup (shaders/cache_create.comp, CREATE_MAX_ROUNDS).  On a CPU device at most 6 rounds:
   llvmpipe silently truncates an invocation's loops past 65535 iterations, and 6 rounds
   x 7 points x 2 transmittance estimates x (640 pooled comb steps + 16 orders) = 55104,
   plus the light loops (the budget is spelled out in cache_create.comp). */
#define PICVR_CACHE_CREATE_GROUP 128u
#define PICVR_CACHE_DEFAULT_SAMPLES 768u
#define PICVR_ROUND_READBACK_BYTES (sizeof(picvr_cache_counters) + 16)
/* The rendering procedure's event queues (shaders/render.glsl), one buffer each: a
   head (one uvec4: indirect dispatch, count), then one event of EVENT_WORDS words per
   pixel; the event kernels run EVENT_GROUP threads per workgroup. */
#define PICVR_EVENT_HEAD_BYTES 16u
#define PICVR_EVENT_WORDS 3u
#define PICVR_EVENT_GROUP 128u
enum { PICVR_PROC_CREATE, PICVR_PROC_UPDATE, PICVR_PROC_RENDER };

/* Pipeline variants.  The kernels' specialization constants (shaders/common.glsl,
   cache.glsl) compile out what the scene does not use; the key of a procedure's variant
   holds those that vary with the scene (picvr_variant_key).  Each procedure keeps up to
   VARIANT_SLOTS variants, made by the first step that needs one; a new one replaces
   the least recently used. */
#define PICVR_VARIANT_SLOTS 8u
#define PICVR_KEY_PHASE_MIS 1u      /* constant 0 USE_PHASE_MIS */
#define PICVR_KEY_FINE 2u           /* constant 1 USE_FINE */
#define PICVR_KEY_DEBUG_VIEW 4u     /* constant 3 USE_DEBUG_VIEW */
#define PICVR_KEY_MONO_SHIFT 3u     /* constant 4 MONO_CHANNEL: 2 bits, 3 = colours differ */
/* The kernels of one variant: creation and update have one (KERNEL_MAIN); rendering
   has its tracking kernel there, then its shading kernel and, cached, the lookup
   (shaders/render.glsl). */
enum { PICVR_KERNEL_MAIN, PICVR_KERNEL_SHADE, PICVR_KERNEL_LOOKUP, PICVR_KERNELS };
typedef struct picvr_variant_slot {
    uint32_t key;
    VkPipeline pipe[PICVR_KERNELS];        /* pipe[KERNEL_MAIN] VK_NULL_HANDLE: a free slot */
    uint32_t used;                   /* variant_clock of the last step that chose it */
    int dispatched;                  /* it has run (a first dispatch stays out of the costs) */
} picvr_variant_slot;
#define PICVR_PI 3.14159265358979323846

/* ---- host mirror of the std140 uniform block in shaders/common.glsl ---- */
typedef struct picvr_gpu_light { float p0[4], p1[4], p2[4], p3[4], p4[4]; } picvr_gpu_light;
typedef struct picvr_gpu_scene {
    float cam_pos[4], cam_fwd[4], cam_right[4], cam_up[4];
    float box_min[4], box_size[4], cell_size[4];
    uint32_t grid[4], image[4], dims[4];
    float background[4];
    float value_map[4];
    float cache_params[4], cache_radii[4];
    uint32_t cache_caps[4], cache_screen[4], view[4];
    float light_mono[4];
    picvr_gpu_light lights[PICVR_MAX_LIGHTS];
} picvr_gpu_scene;

/* Sparse table of the opacity column: level k holds the max over 2^k entries. */
typedef struct picvr_range_max { float level[13][PICVR_TF_SIZE]; } picvr_range_max;

typedef struct picvr_gpu_partial { float sums[4]; uint32_t counts[4]; } picvr_gpu_partial;

typedef struct picvr_buffer {
    VkBuffer buf;
    VkDeviceMemory mem;
    VkDeviceSize size;
    void *mapped;      /* non-NULL when host visible */
    int coherent;
} picvr_buffer;

typedef struct picvr_image {
    VkImage img;
    VkDeviceMemory mem;
    VkImageView view;
} picvr_image;

/* The cache's counter block (struct CacheCounters of shaders/cache.glsl, word for
   word; `make check-layout` compares the offsets).  The device writes it; the host
   reads a copy after every round. */
typedef struct picvr_cache_counters {
    uint32_t dispatch[3];        /* indirect creation dispatch: x = valid requests queued */
    uint32_t request_count;      /* requests queued this round (valid or not) */
    uint32_t entry_count;
    uint32_t node_count;
    uint32_t ref_count;
    uint32_t full;               /* 1 once a pool ran out */
    uint32_t hits, misses;       /* scatter events served by the cache, and not, this round */
    uint32_t requests;           /* creation requests issued this round */
    uint32_t capped;             /* entries stored at the Eq. 5 sample cap */
    uint32_t point_rounds;       /* creation rounds of the stored entries' points (wraps) */
    uint32_t truncated;          /* their samples cut at the loop bound (wraps) */
    uint32_t lookups_cut;        /* octree walks stopped at max_lookup_refs (wraps) */
    uint32_t lookups_spilled;    /* lookups past the candidate buffer (wraps) */
} picvr_cache_counters;

/* A round's record for the §6 time shares and the hit-rate window. */
typedef struct picvr_round_record {
    double end_ms, device_ms[3];
    uint32_t hits, misses;
} picvr_round_record;

/* Device and queue (host/vulkan.c). */
typedef struct picvr_device {
    int external;                    /* instance/device belong to the application */
    VkInstance instance;
    VkDebugUtilsMessengerEXT messenger;
    VkPhysicalDevice phys;
    VkDevice device;
    VkQueue queue;
    uint32_t queue_family;
    VkPhysicalDeviceProperties props;
    VkPhysicalDeviceMemoryProperties mem_props;
    uint32_t validation_messages;
    int validation_enabled;
    int lost;                        /* VK_ERROR_DEVICE_LOST seen: every call refuses */
    VkCommandPool cmd_pool;
    VkCommandBuffer cmd;             /* the one command buffer: record, submit, wait */
    VkFence fence;
    VkFormat float_volume_format;    /* R32_SFLOAT, or R16_UNORM where it cannot filter */
    VkDeviceSize max_volume_bytes;   /* largest volume image the device can hold; 0: unknown */
} picvr_device;

/* Shader modules, pipelines and the one descriptor set (host/pipelines.c). */
typedef struct picvr_pipelines {
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout, stats_layout;
    VkDescriptorPool desc_pool;
    VkDescriptorSet set;
    int descriptors_dirty;           /* a bound buffer or image changed */
    VkShaderModule track_module, shade_module, lookup_module; /* the rendering kernels; lookup: cached */
    VkShaderModule stats_module, create_module, update_module, rebuild_module;
    VkShaderModule select_module, priority_module;
    VkPipeline select_pipe, priority_pipe; /* the rendering queue; priority_pipe only with priorities */
    VkPipeline stats_pipe, rebuild_pipe;
    picvr_variant_slot variants[3][PICVR_VARIANT_SLOTS]; /* PROC_*: the variants made so far */
    uint32_t variant_clock;          /* ticks once per step: the slots' last use */
    uint32_t current_slot[3];        /* PROC_*: the slot this step's rounds dispatch */
    VkSampler linear_sampler;
} picvr_pipelines;

/* What is rendered: volume, transfer function, lights, camera (host/volume.c,
   transfer.c, lights.c, camera.c), and their uniform block. */
typedef struct picvr_scene {
    picvr_gpu_scene gpu;             /* the uniform block as the kernels read it */
    picvr_buffer ubo;                /* persistently mapped copy of gpu */
    int has_volume, has_camera;
    picvr_image volume;
    picvr_buffer majorant;           /* majorant grid, then the empty-space distances */
    uint32_t dims[3];
    float spacing[3];
    uint32_t brick, grid[3];
    float *brick_min, *brick_max;    /* normalized data range per brick, with apron */
    int use_fine;                    /* some brick needs voxel-level majorants */
    picvr_image tf_image;
    picvr_buffer tf_staging;
    picvr_buffer tf_range_max;       /* sparse table of the opacity column (fine majorants) */
    float tf_table[PICVR_TF_SIZE * 4];
    picvr_range_max *tf_rm;
    float density;
    int use_phase_mis;               /* some light or the background needs MIS */
    picvr_camera camera;
} picvr_scene;

/* The image: accumulation planes, the rendering procedure's queues, block order
   (host/camera.c). */
typedef struct picvr_image_state {
    picvr_buffer planes[3];          /* mean rgba, Kahan terms, (lum mean, M2, n, bad) */
    picvr_buffer render_queue;       /* header + one uvec4 per block (shaders/queue.glsl) */
    picvr_buffer shade_queue;        /* the rendering procedure's event queues (shaders/render.glsl): */
    picvr_buffer lookup_queue;       /* for shading, and with the cache for the lookup */
    uint32_t block_total;            /* 16x8 blocks of the image */
    uint32_t block_cursor;           /* position k in the round-robin order (k * stride) mod B */
    uint32_t block_stride;           /* coprime with block_total, near block_total / golden ratio */
    uint64_t block_samples;          /* blocks rendered since the accumulation was reset */
    double elapsed_ms;               /* wall time of the rounds since then */
} picvr_image_state;

/* The irradiance cache, §4-5 (host/cache.c); nothing allocated when it is off. */
typedef struct picvr_cache {
    picvr_cache_config cfg;          /* resolved: no zero fields */
    int on;
    int requests_set;                /* the application chose max_requests */
    picvr_buffer entries, nodes, refs, counters, requests;
    picvr_buffer prebuilt_nodes;     /* the pre-built top of the octree, copied on rebuild */
    picvr_buffer superpixels;        /* screen-space locking: locks + ray/miss counters */
    uint32_t superpixel_count;
    uint32_t prebuilt;               /* nodes of the pre-built top of the octree */
    double since_rebuild_ms;
    uint32_t requests_issued;        /* by the rounds of the last step */
    uint32_t requests_pending;       /* valid requests the last round queued (each holds a lock) */
    picvr_cache_counters counts;     /* as read after the last round */
    uint64_t point_rounds;           /* counts.point_rounds, .truncated, .lookups_cut and */
    uint64_t truncated;              /* .lookups_spilled wrap at 2^32 on the device; */
    uint64_t lookups_cut;            /* summed here round by round */
    uint64_t lookups_spilled;
} picvr_cache;

/* The scheduler's state, §6-7 (host/schedule.c): no Vulkan here. */
typedef struct picvr_sched {
    picvr_scheduler_config cfg;      /* resolved: no zero fields */
    int use_priorities;
    double cost[3];                  /* device ms per work package, PROC_*; 0: not measured */
    double overhead_ms;              /* wall time of a round beyond its device time */
    double credit_ms[2];             /* PROC_CREATE, PROC_UPDATE: device time owed by the shares */
    int first_dispatch[3];           /* PROC_*: this round runs a variant for the first time */
    uint32_t create_batch;           /* entries a creation dispatch waits for (picvr_creation_batch) */
    picvr_round_record history[PICVR_SCHED_HISTORY];
    uint32_t history_count;          /* records in history (ring, newest at history_count-1 mod N) */
    double hit_rate;                 /* over the last hit_rate_window_ms */
    double target[2];                /* the §6 shares of creation and update now */
} picvr_sched;

/* Submissions of rounds and their device timestamps (host/rounds.c). */
typedef struct picvr_rounds {
    uint32_t count;                  /* rounds since creation: keys the cache procedures' RNG */
    picvr_buffer readback;           /* cache counters and rendered-block count of a round */
    VkQueryPool timestamps;          /* PICVR_ROUND_TIMESTAMPS; VK_NULL_HANDLE: none */
    double timestamp_ns;             /* nanoseconds per timestamp tick */
    uint64_t timestamp_mask;         /* valid bits */
} picvr_rounds;

/* Image readback and statistics (host/readback.c). */
typedef struct picvr_results {
    picvr_buffer readback;           /* one accumulation plane, host visible */
    picvr_buffer partials;           /* the stats kernel's per-workgroup sums */
    int valid;                       /* stats is up to date */
    picvr_stats stats;
} picvr_results;

struct picvr_context {
    picvr_config config;             /* as given to picvr_create (picvr_get_config) */
    picvr_allocator alloc;
    picvr_log_fn log;
    void *log_user;
    picvr_log_level log_level;
    uint32_t seed;
    picvr_device vk;
    picvr_pipelines pipes;
    picvr_scene scene;
    picvr_image_state image;
    picvr_cache cache;
    picvr_sched sched;
    picvr_rounds rounds;
    picvr_results results;
};

/* ---------------------------------------------------------------------------------- */
/* small utilities                                                                     */

const char *picvr_status_string(picvr_status s) {
    static const char *names[PICVR_STATUS_COUNT] = {
        "PICVR_OK", "PICVR_ERROR_NULL_POINTER", "PICVR_ERROR_INVALID_ARGUMENT",
        "PICVR_ERROR_NON_FINITE", "PICVR_ERROR_INVALID_DIMENSIONS", "PICVR_ERROR_SIZE_OVERFLOW",
        "PICVR_ERROR_UNSUPPORTED_TYPE", "PICVR_ERROR_INVALID_TRANSFER_FUNCTION",
        "PICVR_ERROR_INVALID_LIGHT", "PICVR_ERROR_TOO_MANY_LIGHTS", "PICVR_ERROR_INVALID_CAMERA",
        "PICVR_ERROR_BUFFER_TOO_SMALL", "PICVR_ERROR_NOT_READY", "PICVR_ERROR_NO_DEVICE",
        "PICVR_ERROR_VULKAN", "PICVR_ERROR_OUT_OF_HOST_MEMORY", "PICVR_ERROR_OUT_OF_DEVICE_MEMORY",
        "PICVR_ERROR_DEVICE_LOST"};
    if ((unsigned)s >= PICVR_STATUS_COUNT) return "PICVR_UNKNOWN_STATUS";
    return names[s];
}

static double picvr_clock_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static void picvr_log_message(picvr_context *ctx, picvr_log_level level, const char *fmt, ...) {
    if (level < ctx->log_level) return;
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (ctx->log) ctx->log(level, msg, ctx->log_user);
    else fprintf(stderr, "picvr: %s\n", msg);
}

static void *picvr_host_alloc(const picvr_allocator *a, size_t n) {
    if (n == 0) n = 1;
    return a->alloc ? a->alloc(n, a->user) : malloc(n);
}
static void picvr_host_free(const picvr_allocator *a, void *p) {
    if (!p) return;
    if (a->free) a->free(p, a->user); else free(p);
}

static int picvr_finite3(const float v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }
static void picvr_cross3(const float a[3], const float b[3], float r[3]) {
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}
static double picvr_len3(const float a[3]) { return sqrt((double)a[0] * a[0] + (double)a[1] * a[1] + (double)a[2] * a[2]); }
static void picvr_pack4(float d[4], const float s[3], float w) { d[0] = s[0]; d[1] = s[1]; d[2] = s[2]; d[3] = w; }
static double picvr_luminance(const float c[3]) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

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
#define PICVR_VK_TRY(ctx, call) do { picvr_status s_ = picvr_vk_status((ctx), (call), #call); if (s_) return s_; } while (0)

/* ---------------------------------------------------------------------------------- */
/* memory                                                                              */

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
    VkBufferCreateInfo bi = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
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
    VkImageCreateInfo ii = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ii.imageType = type;
    ii.format = fmt;
    ii.extent = (VkExtent3D){w, h, d};
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
        VkImageViewCreateInfo vi = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
        vi.image = im->img;
        vi.viewType = type == VK_IMAGE_TYPE_3D ? VK_IMAGE_VIEW_TYPE_3D : VK_IMAGE_VIEW_TYPE_1D;
        vi.format = fmt;
        vi.subresourceRange = (VkImageSubresourceRange){VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        s = picvr_vk_status(ctx, vkCreateImageView(ctx->vk.device, &vi, NULL, &im->view), "vkCreateImageView");
    }
    if (s) picvr_image_destroy(ctx, im);
    return s;
}

/* ---------------------------------------------------------------------------------- */
/* command submission: everything is synchronous (record, submit, wait)                */

static picvr_status picvr_cmd_begin(picvr_context *ctx) {
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    PICVR_VK_TRY(ctx, vkResetCommandBuffer(ctx->vk.cmd, 0));
    VkCommandBufferBeginInfo bi = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    PICVR_VK_TRY(ctx, vkBeginCommandBuffer(ctx->vk.cmd, &bi));
    return PICVR_OK;
}

/* A full compute/transfer memory barrier: earlier writes visible to later accesses. */
static void picvr_barrier_all(picvr_context *ctx) {
    VkMemoryBarrier mb = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_HOST_WRITE_BIT;
    mb.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                       VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_HOST_READ_BIT | VK_ACCESS_UNIFORM_READ_BIT |
                       VK_ACCESS_INDIRECT_COMMAND_READ_BIT;
    VkPipelineStageFlags src = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
                               VK_PIPELINE_STAGE_HOST_BIT;
    VkPipelineStageFlags dst = src | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT;
    vkCmdPipelineBarrier(ctx->vk.cmd, src, dst, 0, 1, &mb, 0, NULL, 0, NULL);
}

static picvr_status picvr_cmd_submit_wait(picvr_context *ctx) {
    PICVR_VK_TRY(ctx, vkEndCommandBuffer(ctx->vk.cmd));
    PICVR_VK_TRY(ctx, vkResetFences(ctx->vk.device, 1, &ctx->vk.fence));
    VkSubmitInfo si = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
    si.commandBufferCount = 1;
    si.pCommandBuffers = &ctx->vk.cmd;
    PICVR_VK_TRY(ctx, vkQueueSubmit(ctx->vk.queue, 1, &si, ctx->vk.fence));
    PICVR_VK_TRY(ctx, vkWaitForFences(ctx->vk.device, 1, &ctx->vk.fence, VK_TRUE, UINT64_MAX));
    return PICVR_OK;
}

static void picvr_image_barrier(picvr_context *ctx, VkImage img, VkImageLayout from, VkImageLayout to) {
    VkImageMemoryBarrier b = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
    b.srcAccessMask = from == VK_IMAGE_LAYOUT_UNDEFINED ? 0 : VK_ACCESS_TRANSFER_WRITE_BIT;
    b.dstAccessMask = to == VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL ? VK_ACCESS_TRANSFER_WRITE_BIT : VK_ACCESS_SHADER_READ_BIT;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = img;
    b.subresourceRange = (VkImageSubresourceRange){VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
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

/* ---------------------------------------------------------------------------------- */
/* instance, device, pipelines                                                         */

static VKAPI_ATTR VkBool32 VKAPI_CALL picvr_validation_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                     VkDebugUtilsMessageTypeFlagsEXT type,
                                                     const VkDebugUtilsMessengerCallbackDataEXT *data,
                                                     void *user) {
    picvr_context *ctx = user;
    if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
        ctx->vk.validation_messages++;
        picvr_log_message(ctx, PICVR_LOG_ERROR, "validation: %s", data && data->pMessage ? data->pMessage : "?");
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
    VkApplicationInfo app = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "picvr";
    app.pEngineName = "picvr";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo ci = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    ci.pApplicationInfo = &app;
    const char *layer = "VK_LAYER_KHRONOS_validation";
    const char *exts[] = {VK_EXT_DEBUG_UTILS_EXTENSION_NAME};
    VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
    VkValidationFeaturesEXT features = {VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
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
        VkDebugUtilsMessengerCreateInfoEXT mi = {VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
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
   (../shared/LAVAPIPE.md) shape the sample cap and the creation batch. */
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
    VkDeviceQueueCreateInfo qi = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    qi.queueFamilyIndex = ctx->vk.queue_family;
    qi.queueCount = 1;
    qi.pQueuePriorities = &prio;
    VkDeviceCreateInfo di = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
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

static picvr_status picvr_create_shader(picvr_context *ctx, const uint32_t *code, size_t size, VkShaderModule *out) {
    VkShaderModuleCreateInfo ci = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    ci.codeSize = size;
    ci.pCode = code;
    PICVR_VK_TRY(ctx, vkCreateShaderModule(ctx->vk.device, &ci, NULL, out));
    return PICVR_OK;
}

static picvr_status picvr_create_pipeline(picvr_context *ctx, VkShaderModule mod, VkPipelineLayout layout,
                                    const VkSpecializationInfo *spec, VkPipeline *out) {
    VkComputePipelineCreateInfo ci = {VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    ci.stage.module = mod;
    ci.stage.pName = "main";
    ci.stage.pSpecializationInfo = spec;
    ci.layout = layout;
    PICVR_VK_TRY(ctx, vkCreateComputePipelines(ctx->vk.device, VK_NULL_HANDLE, 1, &ci, NULL, out));
    return PICVR_OK;
}

/* Binding layout shared by all kernels (see ARCHITECTURE.md): 0 scene UBO, 1 volume,
   2 transfer function, 3 majorant grid, 4-6 accumulation planes, 7 stats partials,
   8 opacity range-max table, 9-13 cache entries, nodes, refs, counters, requests,
   14 superpixels (screen-space locking), 15 the rendering queue, 16 and 17 the rendering
   procedure's event queues for shading and for the cache lookup. */
#define PICVR_NUM_BINDINGS 18
/* The bindings only cached contexts write: 9-14 and 17. */
static int picvr_cache_binding(uint32_t i) { return (i >= 9 && i < 15) || i == 17; }
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
    return ctx->cache.on && ctx->scene.gpu.view[0] != PICVR_VIEW_IMAGE;
}

/* The key of procedure proc's variant for the current scene.  Only the constants a
   procedure reads are in its key, so that a change elsewhere makes no new variant:
   creation samples light but looks nothing up, the update procedure tracks and looks
   up but samples no light, plain Monte Carlo looks nothing up.  Not specialized,
   because measured without gain: the light types present (their code compiled out for
   bonsai under one sphere light: cached 32.6 / 37.8 iterations a second of rendering
   time against 35.4 / 41.5 without, plain +0-3 %; 2026-11-30), which would have made
   a new variant, and a pause, whenever an application turns a light of a new type on. */
static uint32_t picvr_variant_key(const picvr_context *ctx, int proc) {
    uint32_t mis = ctx->scene.use_phase_mis ? PICVR_KEY_PHASE_MIS : 0u, fine = ctx->scene.use_fine ? PICVR_KEY_FINE : 0u;
    uint32_t mono = (uint32_t)ctx->scene.gpu.light_mono[3] << PICVR_KEY_MONO_SHIFT;
    if (proc == PICVR_PROC_CREATE) return mis | fine;
    if (proc == PICVR_PROC_UPDATE) return fine | mono;
    if (!ctx->cache.on) return mis | fine;
    return mis | fine | mono | (picvr_debug_view_on(ctx) ? PICVR_KEY_DEBUG_VIEW : 0u);
}

/* The kernels of procedure proc's variant for key (out[KERNELS], VK_NULL_HANDLE where
   the procedure has no such kernel; on a failure none is left).  One set of constants
   for all kernels (a kernel ignores those it lacks): 0-1 and 3-4 from the key, 2 the
   creation procedure's rounds (CREATE_MAX_ROUNDS), 5 SCREEN_LOCKING and 6
   MAX_LOOKUP_REFS, fixed per context. */
static picvr_status picvr_create_variant(picvr_context *ctx, int proc, uint32_t key, VkPipeline *out) {
    VkShaderModule mod[PICVR_KERNELS] = {VK_NULL_HANDLE, VK_NULL_HANDLE, VK_NULL_HANDLE};
    if (proc == PICVR_PROC_CREATE) mod[PICVR_KERNEL_MAIN] = ctx->pipes.create_module;
    else if (proc == PICVR_PROC_UPDATE) mod[PICVR_KERNEL_MAIN] = ctx->pipes.update_module;
    else {
        mod[PICVR_KERNEL_MAIN] = ctx->pipes.track_module;
        mod[PICVR_KERNEL_SHADE] = ctx->pipes.shade_module;
        if (ctx->cache.on) mod[PICVR_KERNEL_LOOKUP] = ctx->pipes.lookup_module;
    }
    uint32_t value[7] = {(key & PICVR_KEY_PHASE_MIS) != 0, (key & PICVR_KEY_FINE) != 0, ctx->cache.cfg.max_samples / PICVR_CACHE_CREATE_GROUP,
                         (key & PICVR_KEY_DEBUG_VIEW) != 0, (key >> PICVR_KEY_MONO_SHIFT) & 3u,
                         ctx->cache.on && ctx->cache.cfg.mode == PICVR_CACHE_SCREEN_SPACE,
                         ctx->cache.on ? ctx->cache.cfg.max_lookup_refs : PICVR_CACHE_MAX_LOOKUP_REFS};
    VkSpecializationMapEntry entry[7];
    for (uint32_t i = 0; i < 7; i++) {
        entry[i].constantID = i;
        entry[i].offset = 4 * i;
        entry[i].size = 4;
    }
    VkSpecializationInfo spec = {7, entry, sizeof value, value};
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
static picvr_status picvr_select_variant(picvr_context *ctx, int proc) {
    uint32_t key = picvr_variant_key(ctx, proc), pick = 0;
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

/* Kernel k of the variant this step dispatches for procedure proc. */
static VkPipeline picvr_current_kernel(const picvr_context *ctx, int proc, int k) {
    return ctx->pipes.variants[proc][ctx->pipes.current_slot[proc]].pipe[k];
}
static VkPipeline picvr_current_pipeline(const picvr_context *ctx, int proc) { return picvr_current_kernel(ctx, proc, PICVR_KERNEL_MAIN); }

static picvr_status picvr_create_pipelines(picvr_context *ctx) {
    VkDescriptorSetLayoutBinding b[PICVR_NUM_BINDINGS];
    memset(b, 0, sizeof b);
    for (uint32_t i = 0; i < PICVR_NUM_BINDINGS; i++) {
        b[i].binding = i;
        b[i].descriptorType = picvr_binding_type(i);
        b[i].descriptorCount = 1;
        b[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
    }
    VkDescriptorSetLayoutCreateInfo li = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    li.bindingCount = PICVR_NUM_BINDINGS;
    li.pBindings = b;
    PICVR_VK_TRY(ctx, vkCreateDescriptorSetLayout(ctx->vk.device, &li, NULL, &ctx->pipes.set_layout));

    VkPushConstantRange pcr = {VK_SHADER_STAGE_COMPUTE_BIT, 0, 16};   /* four words, every kernel */
    VkPipelineLayoutCreateInfo pl = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    pl.setLayoutCount = 1;
    pl.pSetLayouts = &ctx->pipes.set_layout;
    pl.pushConstantRangeCount = 1;
    pl.pPushConstantRanges = &pcr;
    PICVR_VK_TRY(ctx, vkCreatePipelineLayout(ctx->vk.device, &pl, NULL, &ctx->pipes.layout));
    PICVR_VK_TRY(ctx, vkCreatePipelineLayout(ctx->vk.device, &pl, NULL, &ctx->pipes.stats_layout));

    VkDescriptorPoolSize sizes[3] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
                                     {VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2},
                                     {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, PICVR_NUM_BINDINGS - 3}};
    VkDescriptorPoolCreateInfo pi = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    pi.maxSets = 1;
    pi.poolSizeCount = 3;
    pi.pPoolSizes = sizes;
    PICVR_VK_TRY(ctx, vkCreateDescriptorPool(ctx->vk.device, &pi, NULL, &ctx->pipes.desc_pool));
    VkDescriptorSetAllocateInfo ai = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
    ai.descriptorPool = ctx->pipes.desc_pool;
    ai.descriptorSetCount = 1;
    ai.pSetLayouts = &ctx->pipes.set_layout;
    PICVR_VK_TRY(ctx, vkAllocateDescriptorSets(ctx->vk.device, &ai, &ctx->pipes.set));

    picvr_status s = ctx->cache.on
        ? picvr_create_shader(ctx, picvr_spv_render_track_cache, sizeof picvr_spv_render_track_cache, &ctx->pipes.track_module)
        : picvr_create_shader(ctx, picvr_spv_render_track, sizeof picvr_spv_render_track, &ctx->pipes.track_module);
    if (!s) s = picvr_create_shader(ctx, picvr_spv_render_shade, sizeof picvr_spv_render_shade, &ctx->pipes.shade_module);
    if (!s) s = picvr_create_shader(ctx, picvr_spv_stats, sizeof picvr_spv_stats, &ctx->pipes.stats_module);
    if (!s) s = picvr_create_shader(ctx, picvr_spv_block_select, sizeof picvr_spv_block_select, &ctx->pipes.select_module);
    if (!s) s = picvr_create_pipeline(ctx, ctx->pipes.select_module, ctx->pipes.layout, NULL, &ctx->pipes.select_pipe);
    if (!s && ctx->sched.use_priorities) s = picvr_create_priority_pipeline(ctx);
    if (!s && ctx->cache.on && picvr_on_cpu_device(ctx) &&
        ctx->cache.cfg.max_samples > PICVR_CACHE_MAX_SAMPLES_CPU) {
        picvr_log_message(ctx, PICVR_LOG_ERROR, "cache.max_samples %u: at most %u on a CPU device (loop bound)",
              ctx->cache.cfg.max_samples, PICVR_CACHE_MAX_SAMPLES_CPU);
        s = PICVR_ERROR_INVALID_ARGUMENT;
    }
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
    VkSamplerCreateInfo si = {VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    si.magFilter = si.minFilter = VK_FILTER_LINEAR;
    si.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    si.addressModeU = si.addressModeV = si.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
    si.maxLod = 0.0f;
    PICVR_VK_TRY(ctx, vkCreateSampler(ctx->vk.device, &si, NULL, &ctx->pipes.linear_sampler));
    return PICVR_OK;
}

static picvr_status picvr_default_transfer_function(picvr_context *ctx);
static picvr_status picvr_resolve_scheduler_config(const picvr_scheduler_config *in, picvr_scheduler_config *c);
static picvr_status picvr_resolve_cache_config(picvr_context *ctx, const picvr_cache_config *in, picvr_cache_config *c);
static picvr_status picvr_create_cache_buffers(picvr_context *ctx);
static picvr_status picvr_create_timestamps(picvr_context *ctx);
static void picvr_update_targets(picvr_context *ctx);
static uint32_t picvr_creation_batch(const picvr_context *ctx);

/* The smaller of one allocation's limit (maxMemoryAllocationSize) and the largest
   device-local heap; 0 when neither is known. */
static VkDeviceSize picvr_volume_alloc_limit(const picvr_context *ctx) {
    VkPhysicalDeviceMaintenance3Properties m3 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES};
    VkPhysicalDeviceProperties2 p2 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &m3};
    vkGetPhysicalDeviceProperties2(ctx->vk.phys, &p2);
    VkDeviceSize heap = 0;
    for (uint32_t i = 0; i < ctx->vk.mem_props.memoryHeapCount; i++)
        if ((ctx->vk.mem_props.memoryHeaps[i].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) && ctx->vk.mem_props.memoryHeaps[i].size > heap)
            heap = ctx->vk.mem_props.memoryHeaps[i].size;
    VkDeviceSize lim = m3.maxMemoryAllocationSize;
    if (heap && (!lim || heap < lim)) lim = heap;
    return lim;
}

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

    VkCommandPoolCreateInfo pi = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pi.queueFamilyIndex = ctx->vk.queue_family;
    PICVR_VK_TRY(ctx, vkCreateCommandPool(ctx->vk.device, &pi, NULL, &ctx->vk.cmd_pool));
    VkCommandBufferAllocateInfo ai = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = ctx->vk.cmd_pool;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    PICVR_VK_TRY(ctx, vkAllocateCommandBuffers(ctx->vk.device, &ai, &ctx->vk.cmd));
    VkFenceCreateInfo fi = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    PICVR_VK_TRY(ctx, vkCreateFence(ctx->vk.device, &fi, NULL, &ctx->vk.fence));

    if ((s = picvr_create_pipelines(ctx)) || (s = picvr_create_sampler(ctx)) || (s = picvr_create_timestamps(ctx))) return s;
    ctx->sched.create_batch = picvr_creation_batch(ctx);
    ctx->vk.max_volume_bytes = picvr_volume_alloc_limit(ctx);
    if (ctx->cache.on && (s = picvr_create_cache_buffers(ctx))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->rounds.readback, PICVR_ROUND_READBACK_BYTES, VK_BUFFER_USAGE_TRANSFER_DST_BIT, 1))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->scene.ubo, sizeof(picvr_gpu_scene), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, 1))) return s;
    if ((s = picvr_image_create(ctx, &ctx->scene.tf_image, VK_IMAGE_TYPE_1D, VK_FORMAT_R32G32B32A32_SFLOAT, PICVR_TF_SIZE, 1, 1))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->scene.tf_staging, sizeof ctx->scene.tf_table, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 1))) return s;
    if (!(ctx->scene.tf_rm = picvr_host_alloc(&ctx->alloc, sizeof *ctx->scene.tf_rm))) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    if ((s = picvr_buffer_create(ctx, &ctx->scene.tf_range_max, sizeof *ctx->scene.tf_rm,
                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0))) return s;
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
    picvr_context *ctx = picvr_host_alloc(&cfg.allocator, sizeof *ctx);
    if (!ctx) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    memset(ctx, 0, sizeof *ctx);
    ctx->config = cfg;
    ctx->alloc = cfg.allocator;
    ctx->log = cfg.log;
    ctx->log_user = cfg.log_user;
    ctx->log_level = cfg.log_level ? cfg.log_level : PICVR_LOG_WARNING;
    ctx->seed = cfg.seed;
    ctx->cache.requests_set = cfg.cache.max_requests != 0;
    picvr_status s = picvr_resolve_cache_config(ctx, &cfg.cache, &ctx->cache.cfg);
    if (!s) s = picvr_resolve_scheduler_config(&cfg.scheduler, &ctx->sched.cfg);
    ctx->cache.on = ctx->cache.cfg.mode != PICVR_CACHE_NONE;
    ctx->sched.use_priorities = ctx->sched.cfg.priorities == PICVR_SWITCH_ON;
    picvr_update_targets(ctx);
    if (!s) s = picvr_context_init(ctx, &cfg);
    if (s) { picvr_destroy(ctx); return s; }
    *out = ctx;
    return PICVR_OK;
}

picvr_status picvr_get_config(const picvr_context *ctx, picvr_config *out) {
    if (!ctx || !out) return PICVR_ERROR_NULL_POINTER;
    *out = ctx->config;
    out->validation = ctx->vk.validation_enabled ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF;
    out->log_level = ctx->log_level;
    out->vulkan.instance = ctx->vk.instance;
    out->vulkan.physical_device = ctx->vk.phys;
    out->vulkan.device = ctx->vk.device;
    out->vulkan.queue = ctx->vk.queue;
    out->vulkan.queue_family = ctx->vk.queue_family;
    out->cache = ctx->cache.cfg;
    out->scheduler = ctx->sched.cfg;
    return PICVR_OK;
}

void picvr_destroy(picvr_context *ctx) {
    if (!ctx) return;
    if (ctx->vk.device) {
        vkDeviceWaitIdle(ctx->vk.device);
        picvr_buffer_destroy(ctx, &ctx->scene.ubo);
        picvr_buffer_destroy(ctx, &ctx->scene.tf_staging);
        picvr_buffer_destroy(ctx, &ctx->scene.tf_range_max);
        picvr_buffer_destroy(ctx, &ctx->scene.majorant);
        picvr_buffer_destroy(ctx, &ctx->results.readback);
        picvr_buffer_destroy(ctx, &ctx->results.partials);
        for (int i = 0; i < 3; i++) picvr_buffer_destroy(ctx, &ctx->image.planes[i]);
        picvr_image_destroy(ctx, &ctx->scene.tf_image);
        picvr_image_destroy(ctx, &ctx->scene.volume);
        VkDevice d = ctx->vk.device;
        if (ctx->pipes.linear_sampler) vkDestroySampler(d, ctx->pipes.linear_sampler, NULL);
        for (int p = 0; p < 3; p++)
            for (uint32_t i = 0; i < PICVR_VARIANT_SLOTS; i++)
                for (int k = 0; k < PICVR_KERNELS; k++)
                    if (ctx->pipes.variants[p][i].pipe[k]) vkDestroyPipeline(d, ctx->pipes.variants[p][i].pipe[k], NULL);
        if (ctx->pipes.rebuild_pipe) vkDestroyPipeline(d, ctx->pipes.rebuild_pipe, NULL);
        if (ctx->pipes.select_pipe) vkDestroyPipeline(d, ctx->pipes.select_pipe, NULL);
        if (ctx->pipes.priority_pipe) vkDestroyPipeline(d, ctx->pipes.priority_pipe, NULL);
        if (ctx->pipes.select_module) vkDestroyShaderModule(d, ctx->pipes.select_module, NULL);
        if (ctx->pipes.priority_module) vkDestroyShaderModule(d, ctx->pipes.priority_module, NULL);
        if (ctx->rounds.timestamps) vkDestroyQueryPool(d, ctx->rounds.timestamps, NULL);
        picvr_buffer_destroy(ctx, &ctx->image.render_queue);
        picvr_buffer_destroy(ctx, &ctx->image.shade_queue);
        picvr_buffer_destroy(ctx, &ctx->image.lookup_queue);
        picvr_buffer_destroy(ctx, &ctx->rounds.readback);
        if (ctx->pipes.update_module) vkDestroyShaderModule(d, ctx->pipes.update_module, NULL);
        if (ctx->pipes.rebuild_module) vkDestroyShaderModule(d, ctx->pipes.rebuild_module, NULL);
        picvr_buffer_destroy(ctx, &ctx->cache.prebuilt_nodes);
        picvr_buffer_destroy(ctx, &ctx->cache.superpixels);
        if (ctx->pipes.lookup_module) vkDestroyShaderModule(d, ctx->pipes.lookup_module, NULL);
        if (ctx->pipes.create_module) vkDestroyShaderModule(d, ctx->pipes.create_module, NULL);
        picvr_buffer_destroy(ctx, &ctx->cache.entries);
        picvr_buffer_destroy(ctx, &ctx->cache.nodes);
        picvr_buffer_destroy(ctx, &ctx->cache.refs);
        picvr_buffer_destroy(ctx, &ctx->cache.counters);
        picvr_buffer_destroy(ctx, &ctx->cache.requests);
        if (ctx->pipes.stats_pipe) vkDestroyPipeline(d, ctx->pipes.stats_pipe, NULL);
        if (ctx->pipes.track_module) vkDestroyShaderModule(d, ctx->pipes.track_module, NULL);
        if (ctx->pipes.shade_module) vkDestroyShaderModule(d, ctx->pipes.shade_module, NULL);
        if (ctx->pipes.stats_module) vkDestroyShaderModule(d, ctx->pipes.stats_module, NULL);
        if (ctx->pipes.desc_pool) vkDestroyDescriptorPool(d, ctx->pipes.desc_pool, NULL);
        if (ctx->pipes.layout) vkDestroyPipelineLayout(d, ctx->pipes.layout, NULL);
        if (ctx->pipes.stats_layout) vkDestroyPipelineLayout(d, ctx->pipes.stats_layout, NULL);
        if (ctx->pipes.set_layout) vkDestroyDescriptorSetLayout(d, ctx->pipes.set_layout, NULL);
        if (ctx->vk.fence) vkDestroyFence(d, ctx->vk.fence, NULL);
        if (ctx->vk.cmd_pool) vkDestroyCommandPool(d, ctx->vk.cmd_pool, NULL);
        if (!ctx->vk.external) vkDestroyDevice(d, NULL);
    }
    if (!ctx->vk.external && ctx->vk.instance) {
        if (ctx->vk.messenger) {
            PFN_vkDestroyDebugUtilsMessengerEXT destroy = (PFN_vkDestroyDebugUtilsMessengerEXT)
                vkGetInstanceProcAddr(ctx->vk.instance, "vkDestroyDebugUtilsMessengerEXT");
            if (destroy) destroy(ctx->vk.instance, ctx->vk.messenger, NULL);
        }
        vkDestroyInstance(ctx->vk.instance, NULL);
    }
    picvr_host_free(&ctx->alloc, ctx->scene.brick_min);
    picvr_host_free(&ctx->alloc, ctx->scene.brick_max);
    picvr_host_free(&ctx->alloc, ctx->scene.tf_rm);
    picvr_allocator a = ctx->alloc;
    picvr_host_free(&a, ctx);
}

/* ---------------------------------------------------------------------------------- */
/* irradiance cache: configuration, pools, clearing                                    */

#define PICVR_CACHE_PREBUILT_MAX_DEPTH 4u
#define PICVR_CACHE_NODE_RADII 1.0f     /* as in shaders/cache.glsl (insertion_depth) */

#ifndef PICVR_CACHE_PIXELS_PER_REQUEST
#define PICVR_CACHE_PIXELS_PER_REQUEST 4096u
#endif

/* Fills in the Table 1 defaults and validates. */
static picvr_status picvr_resolve_cache_config(picvr_context *ctx, const picvr_cache_config *in, picvr_cache_config *c) {
    *c = *in;
    if ((unsigned)c->mode > PICVR_CACHE_SCREEN_SPACE) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->mode == PICVR_CACHE_DEFAULT) c->mode = PICVR_CACHE_NONE;   /* until issue 3 is validated */
    if (!c->superpixel_size) c->superpixel_size = 32;
    if (c->superpixel_size > 4096) return PICVR_ERROR_INVALID_ARGUMENT;
    if ((unsigned)c->curvature_limit > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->curvature_limit == PICVR_SWITCH_DEFAULT) c->curvature_limit = PICVR_SWITCH_OFF;
    if ((unsigned)c->medium_model > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->medium_model == PICVR_SWITCH_DEFAULT) c->medium_model = PICVR_SWITCH_ON;
    float *f[7] = {&c->gamma, &c->epsilon, &c->delta_voxels, &c->radius_min_voxels, &c->radius_max_voxels,
                   &c->update_threshold, &c->rebuild_interval_ms};
    const float def[7] = {0.1f, 0.1f, 2.0f, 0.01f, 16.0f, 0.1f, 1000.0f};
    for (int i = 0; i < 7; i++) {
        if (!isfinite(*f[i])) return PICVR_ERROR_NON_FINITE;
        if (*f[i] < 0.0f) return PICVR_ERROR_INVALID_ARGUMENT;
        if (*f[i] == 0.0f) *f[i] = def[i];
    }
    if (c->epsilon >= 1.0f || c->radius_max_voxels < c->radius_min_voxels) return PICVR_ERROR_INVALID_ARGUMENT;
    if (!c->max_entries) c->max_entries = 65536;
    if (c->max_entries > (1u << 24)) return PICVR_ERROR_SIZE_OVERFLOW;   /* indices pass through floats */
    /* at least 8192 nodes: the pre-built top of the octree takes up to 4681 */
    if (!c->max_nodes) c->max_nodes = 8 * c->max_entries > 8192 ? 8 * c->max_entries : 8192;
    if (!c->max_refs) c->max_refs = 16 * c->max_entries;
    if (!c->max_requests) c->max_requests = 1000;
    if (!c->max_samples) c->max_samples = PICVR_CACHE_DEFAULT_SAMPLES;
    if (c->max_samples > PICVR_CACHE_MAX_SAMPLES) return PICVR_ERROR_INVALID_ARGUMENT;
    c->max_samples = (c->max_samples + PICVR_CACHE_CREATE_GROUP - 1) / PICVR_CACHE_CREATE_GROUP * PICVR_CACHE_CREATE_GROUP;
    if (!c->max_lookup_refs) c->max_lookup_refs = PICVR_CACHE_MAX_LOOKUP_REFS;
    if (c->max_lookup_refs > PICVR_CACHE_MAX_LOOKUP_REFS) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->max_nodes < 4681 || c->max_refs < 2 || c->max_nodes > (1u << 28) || c->max_refs > (1u << 28))
        return PICVR_ERROR_INVALID_ARGUMENT;
    return PICVR_OK;
}

static picvr_status picvr_create_cache_buffers(picvr_context *ctx) {
    const picvr_cache_config *c = &ctx->cache.cfg;
    VkBufferUsageFlags st = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    uint64_t sizes[3] = {(uint64_t)c->max_entries * PICVR_CACHE_ENTRY_BYTES, (uint64_t)c->max_nodes * PICVR_CACHE_NODE_BYTES,
                         (uint64_t)c->max_refs * PICVR_CACHE_REF_BYTES};
    for (int i = 0; i < 3; i++)
        if (sizes[i] > ctx->vk.props.limits.maxStorageBufferRange) return PICVR_ERROR_SIZE_OVERFLOW;
    picvr_status s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.entries, sizes[0], st, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.nodes, sizes[1], st, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.refs, sizes[2], st, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.counters, sizeof(picvr_cache_counters),
                           st | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.requests, (uint64_t)c->max_requests * PICVR_CACHE_REQUEST_BYTES, st, 0))) return s;
    if ((s = picvr_buffer_create(ctx, &ctx->cache.prebuilt_nodes, 4681u * PICVR_CACHE_NODE_BYTES,
                           VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0))) return s;
    return PICVR_OK;
}

/* World-space cache parameters (Delta and the radii are given in voxels of the
   smallest spacing) and the depth of the pre-built top of the octree: the depth at
   which an entry of the largest radius is inserted (same rule as the shader's
   insertion_depth), at most CACHE_PREBUILT_MAX_DEPTH.  Pre-building it lets many
   entries be created in parallel from the start under object-space locking. */
static uint32_t picvr_cache_scene_params(picvr_context *ctx) {
    picvr_gpu_scene *g = &ctx->scene.gpu;
    float voxel = ctx->scene.has_volume ? g->cell_size[3] : 1.0f;
    g->cache_params[0] = ctx->cache.cfg.gamma;
    g->cache_params[1] = ctx->cache.cfg.epsilon;
    g->cache_params[2] = ctx->cache.cfg.delta_voxels * voxel;
    g->cache_params[3] = ctx->cache.cfg.update_threshold;
    g->cache_radii[0] = ctx->cache.cfg.radius_min_voxels * voxel;
    g->cache_radii[1] = ctx->cache.cfg.radius_max_voxels * voxel;
    g->cache_radii[2] = ctx->cache.cfg.curvature_limit == PICVR_SWITCH_ON ? 1.0f : 0.0f;
    g->cache_radii[3] = ctx->cache.cfg.medium_model == PICVR_SWITCH_ON ? 1.0f : 0.0f;
    g->cache_caps[0] = ctx->cache.cfg.max_entries;
    g->cache_caps[1] = ctx->cache.cfg.max_nodes;
    g->cache_caps[2] = ctx->cache.cfg.max_refs;
    g->cache_caps[3] = ctx->cache.cfg.max_requests;
    if (ctx->scene.has_camera) {
        uint32_t side = ctx->cache.cfg.superpixel_size;
        g->cache_screen[0] = side;
        g->cache_screen[1] = (ctx->scene.camera.width + side - 1) / side;
        g->cache_screen[2] = ctx->cache.superpixel_count;
        g->cache_screen[3] = ctx->cache.cfg.mode == PICVR_CACHE_SCREEN_SPACE;
    }
    float edge = g->box_size[0];
    if (g->box_size[1] < edge) edge = g->box_size[1];
    if (g->box_size[2] < edge) edge = g->box_size[2];
    uint32_t depth = 0;
    while (depth < PICVR_CACHE_PREBUILT_MAX_DEPTH && edge * 0.5f >= PICVR_CACHE_NODE_RADII * g->cache_radii[1]) { edge *= 0.5f; depth++; }
    return depth;
}

/* Empties the cache: a complete octree down to the pre-built depth (node i's children
   are 8i+1 .. 8i+8), no entries, no references, no requests, unlocked nodes. */
static picvr_status picvr_cache_clear(picvr_context *ctx) {
    if (!ctx->cache.on) return PICVR_OK;
    uint32_t depth = picvr_cache_scene_params(ctx);
    uint32_t count = 0, level = 1;
    for (uint32_t d = 0; d <= depth; d++, level *= 8) count += level;
    uint32_t inner = count - level / 8;            /* nodes above the deepest level */
    uint32_t *nodes = picvr_host_alloc(&ctx->alloc, (size_t)count * PICVR_CACHE_NODE_BYTES);
    if (!nodes) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    memset(nodes, 0, (size_t)count * PICVR_CACHE_NODE_BYTES);
    for (uint32_t i = 0; i < inner; i++) nodes[i * 4] = 8 * i + 1;
    picvr_status s = picvr_cmd_begin(ctx);
    if (!s) {
        picvr_barrier_all(ctx);
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.nodes.buf, 0, VK_WHOLE_SIZE, 0);
        if (ctx->cache.superpixels.buf) vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.superpixels.buf, 0, VK_WHOLE_SIZE, 0);
        picvr_barrier_all(ctx);
        s = picvr_cmd_submit_wait(ctx);
    }
    if (!s) s = picvr_upload_buffer(ctx, &ctx->cache.nodes, nodes, (size_t)count * PICVR_CACHE_NODE_BYTES);
    if (!s) s = picvr_upload_buffer(ctx, &ctx->cache.prebuilt_nodes, nodes, (size_t)count * PICVR_CACHE_NODE_BYTES);
    picvr_host_free(&ctx->alloc, nodes);
    picvr_cache_counters counters;
    memset(&counters, 0, sizeof counters);
    counters.dispatch[1] = counters.dispatch[2] = 1;
    counters.node_count = count;
    if (!s) s = picvr_upload_buffer(ctx, &ctx->cache.counters, &counters, sizeof counters);
    ctx->cache.prebuilt = count;
    ctx->cache.counts = counters;
    ctx->cache.point_rounds = ctx->cache.truncated = ctx->cache.lookups_cut = ctx->cache.lookups_spilled = 0;
    ctx->cache.requests_pending = 0;
    ctx->cache.since_rebuild_ms = 0.0;
    /* the hit rate restarts from an empty cache */
    for (uint32_t i = 0; i < PICVR_SCHED_HISTORY; i++) ctx->sched.history[i].hits = ctx->sched.history[i].misses = 0;
    ctx->sched.hit_rate = 0.0;
    picvr_update_targets(ctx);
    return s;
}

/* ---------------------------------------------------------------------------------- */
/* accumulation                                                                        */

static void picvr_invalidate_accumulation(picvr_context *ctx) {
    ctx->image.block_samples = 0;
    ctx->image.block_cursor = 0;
    ctx->image.elapsed_ms = 0.0;
    ctx->results.valid = 0;
}

static picvr_status picvr_clear_accumulation(picvr_context *ctx) {
    picvr_invalidate_accumulation(ctx);
    if (!ctx->image.planes[0].buf) return PICVR_OK;
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_barrier_all(ctx);
    for (int i = 0; i < 3; i++) vkCmdFillBuffer(ctx->vk.cmd, ctx->image.planes[i].buf, 0, VK_WHOLE_SIZE, 0);
    vkCmdFillBuffer(ctx->vk.cmd, ctx->image.render_queue.buf, 0, VK_WHOLE_SIZE, 0);   /* block credits */
    picvr_barrier_all(ctx);
    return picvr_cmd_submit_wait(ctx);
}

picvr_status picvr_set_view(picvr_context *ctx, picvr_debug_view view) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    if ((unsigned)view > PICVR_VIEW_CACHE_ERROR) return PICVR_ERROR_INVALID_ARGUMENT;
    if (view != PICVR_VIEW_IMAGE && !ctx->cache.on) return PICVR_ERROR_NOT_READY;
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    ctx->scene.gpu.view[0] = (uint32_t)view;
    return picvr_clear_accumulation(ctx);
}

picvr_status picvr_set_scheduler(picvr_context *ctx, const picvr_scheduler_config *cfg) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    const picvr_scheduler_config zero = {0};
    picvr_scheduler_config c;
    picvr_status s = picvr_resolve_scheduler_config(cfg ? cfg : &zero, &c);
    if (s) return s;
    if (c.priorities == PICVR_SWITCH_ON && (s = picvr_create_priority_pipeline(ctx))) return s;
    ctx->sched.cfg = c;
    ctx->sched.use_priorities = c.priorities == PICVR_SWITCH_ON;
    /* credit owed under the old shares would be spent under the new ones */
    ctx->sched.credit_ms[PICVR_PROC_CREATE] = ctx->sched.credit_ms[PICVR_PROC_UPDATE] = 0.0;
    picvr_update_targets(ctx);
    return PICVR_OK;
}

picvr_status picvr_reset(picvr_context *ctx) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    return picvr_clear_accumulation(ctx);
}

/* ---------------------------------------------------------------------------------- */
/* transfer function and majorant grid                                                 */

/* Piecewise-linear evaluation at v, constant beyond the end points; at a step
   (equal values) the later point wins. */
static void picvr_tf_eval(const picvr_tf_point *p, uint32_t n, float v, float out[4]) {
    uint32_t i = 0;
    while (i < n && p[i].value <= v) i++;
    const picvr_tf_point *a = &p[i == 0 ? 0 : i - 1], *b = &p[i == n ? n - 1 : i];
    float span = b->value - a->value;
    float f = span > 0.0f ? (v - a->value) / span : 0.0f;   /* rule: no division by a zero span */
    for (int c = 0; c < 3; c++) out[c] = a->albedo[c] + f * (b->albedo[c] - a->albedo[c]);
    out[3] = a->opacity + f * (b->opacity - a->opacity);
}

/* Maximum opacity table entry over [lo, hi] by a sparse table (O(1) per query). */
static void picvr_range_max_build(picvr_range_max *rm, const float *table) {
    memset(rm, 0, sizeof *rm);   /* entries past the end of a level are never read */
    for (int i = 0; i < PICVR_TF_SIZE; i++) rm->level[0][i] = table[i * 4 + 3];
    for (int k = 1; k < 13; k++)
        for (int i = 0; i + (1 << k) <= PICVR_TF_SIZE; i++)
            rm->level[k][i] = fmaxf(rm->level[k - 1][i], rm->level[k - 1][i + (1 << (k - 1))]);
}

static float picvr_range_max_query(const picvr_range_max *rm, int lo, int hi) {
    int k = 0;
    while ((2 << k) <= hi - lo + 1) k++;
    return fmaxf(rm->level[k][lo], rm->level[k][hi - (1 << k) + 1]);
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
   1 + 1e-3 against float rounding of the filtered lookups. */
static picvr_status picvr_update_majorant(picvr_context *ctx) {
    if (!ctx->scene.has_volume) return PICVR_OK;
    size_t cells = (size_t)ctx->scene.grid[0] * ctx->scene.grid[1] * ctx->scene.grid[2];
    float *maj = picvr_host_alloc(&ctx->alloc, 2 * cells * sizeof(float));
    if (!maj) return PICVR_ERROR_OUT_OF_HOST_MEMORY;
    const picvr_range_max *rm = ctx->scene.tf_rm;
    double diag = sqrt((double)ctx->scene.gpu.cell_size[0] * ctx->scene.gpu.cell_size[0] +
                       (double)ctx->scene.gpu.cell_size[1] * ctx->scene.gpu.cell_size[1] +
                       (double)ctx->scene.gpu.cell_size[2] * ctx->scene.gpu.cell_size[2]);
    ctx->scene.use_fine = 0;
    for (size_t c = 0; c < cells; c++) {
        int lo = (int)floorf(ctx->scene.brick_min[c] * (PICVR_TF_SIZE - 1)) - 1;
        int hi = (int)ceilf(ctx->scene.brick_max[c] * (PICVR_TF_SIZE - 1)) + 1;
        lo = lo < 0 ? 0 : lo;
        hi = hi > PICVR_TF_SIZE - 1 ? PICVR_TF_SIZE - 1 : hi;
        double m = (double)ctx->scene.density * picvr_range_max_query(rm, lo, hi) * (1.0 + 1e-3);
        maj[c] = m > FLT_MAX ? FLT_MAX : (float)m;
        if (m * diag > PICVR_FINE_THRESHOLD) ctx->scene.use_fine = 1;
    }
    picvr_empty_distance(ctx->scene.grid, maj, maj + cells);
    picvr_status s = picvr_upload_buffer(ctx, &ctx->scene.majorant, maj, 2 * cells * sizeof(float));
    picvr_host_free(&ctx->alloc, maj);
    return s;
}

static picvr_status picvr_upload_tf_table(picvr_context *ctx) {
    memcpy(ctx->scene.tf_staging.mapped, ctx->scene.tf_table, sizeof ctx->scene.tf_table);
    picvr_buffer_flush(ctx, &ctx->scene.tf_staging);
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_image_barrier(ctx, ctx->scene.tf_image.img, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    VkBufferImageCopy region = {0};
    region.imageSubresource = (VkImageSubresourceLayers){VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = (VkExtent3D){PICVR_TF_SIZE, 1, 1};
    vkCmdCopyBufferToImage(ctx->vk.cmd, ctx->scene.tf_staging.buf, ctx->scene.tf_image.img, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    picvr_image_barrier(ctx, ctx->scene.tf_image.img, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    s = picvr_cmd_submit_wait(ctx);
    ctx->pipes.descriptors_dirty = 1;
    return s;
}

static picvr_status picvr_validate_tf(const picvr_tf_point *p, uint32_t n, float density) {
    if (!p) return PICVR_ERROR_NULL_POINTER;
    if (n == 0 || n > PICVR_MAX_TF_POINTS) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
    if (!isfinite(density)) return PICVR_ERROR_NON_FINITE;
    if (density < 0.0f) return PICVR_ERROR_INVALID_ARGUMENT;
    for (uint32_t i = 0; i < n; i++) {
        if (!isfinite(p[i].value) || !picvr_finite3(p[i].albedo) || !isfinite(p[i].opacity)) return PICVR_ERROR_NON_FINITE;
        if (p[i].value < 0.0f || p[i].value > 1.0f || p[i].opacity < 0.0f) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
        for (int c = 0; c < 3; c++)
            if (p[i].albedo[c] < 0.0f || p[i].albedo[c] > 1.0f) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
        if (i > 0 && p[i].value < p[i - 1].value) return PICVR_ERROR_INVALID_TRANSFER_FUNCTION;
        /* sigma_t = D * opacity must fit a float */
        if ((double)p[i].opacity * density > FLT_MAX) return PICVR_ERROR_INVALID_ARGUMENT;
    }
    return PICVR_OK;
}

static picvr_status picvr_apply_tf(picvr_context *ctx, const picvr_tf_point *p, uint32_t n, float density) {
    for (int i = 0; i < PICVR_TF_SIZE; i++) picvr_tf_eval(p, n, (float)i / (PICVR_TF_SIZE - 1), &ctx->scene.tf_table[i * 4]);
    ctx->scene.density = density;
    ctx->scene.gpu.box_min[3] = density;
    picvr_range_max_build(ctx->scene.tf_rm, ctx->scene.tf_table);
    picvr_status s = picvr_upload_tf_table(ctx);
    if (!s) s = picvr_upload_buffer(ctx, &ctx->scene.tf_range_max, ctx->scene.tf_rm, sizeof *ctx->scene.tf_rm);
    if (!s) s = picvr_update_majorant(ctx);
    if (!s) s = picvr_cache_clear(ctx);
    if (!s) s = picvr_clear_accumulation(ctx);
    return s;
}

static picvr_status picvr_default_transfer_function(picvr_context *ctx) {
    picvr_tf_point ramp[2] = {{0.0f, {1, 1, 1}, 0.0f}, {1.0f, {1, 1, 1}, 1.0f}};
    return picvr_apply_tf(ctx, ramp, 2, 1.0f);
}

picvr_status picvr_set_transfer_function(picvr_context *ctx, const picvr_tf_point *points,
                                         uint32_t count, float density) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    picvr_status s = picvr_validate_tf(points, count, density);
    if (s) return s;
    return picvr_apply_tf(ctx, points, count, density);
}

/* ---------------------------------------------------------------------------------- */
/* volume                                                                              */

static size_t picvr_voxel_bytes(picvr_voxel_type t) {
    return t == PICVR_VOXEL_UINT8 ? 1 : t == PICVR_VOXEL_UINT16 ? 2 : t == PICVR_VOXEL_FLOAT32 ? 4 : 0;
}

/* Reads voxel i as a double. */
static double picvr_voxel_at(const picvr_volume_desc *d, size_t i) {
    switch (d->type) {
    case PICVR_VOXEL_UINT8: return ((const uint8_t *)d->data)[i];
    case PICVR_VOXEL_UINT16: return ((const uint16_t *)d->data)[i];
    default: return ((const float *)d->data)[i];
    }
}

/* The normalization v' = clamp(v * scale + offset, 0, 1) applied to raw voxel values;
   the shader applies the same to the texture's value (UNORM formats read v / max). */
typedef struct picvr_value_map { double lo, hi; } picvr_value_map;

static double picvr_normalize_value(picvr_value_map m, double v) {
    /* Rule: a degenerate range (constant float data) maps v to clamp(v, 0, 1). */
    double x = m.hi > m.lo ? (v - m.lo) / (m.hi - m.lo) : v;
    return x < 0.0 ? 0.0 : x > 1.0 ? 1.0 : x;
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

/* Data range for normalization, and (float32) the finiteness check. */
static picvr_status picvr_volume_range(const picvr_volume_desc *d, size_t n, picvr_value_map *m) {
    int given = d->value_min != 0.0f || d->value_max != 0.0f;
    if (d->type != PICVR_VOXEL_FLOAT32) {
        m->lo = given ? d->value_min : 0.0;
        m->hi = given ? d->value_max : d->type == PICVR_VOXEL_UINT8 ? 255.0 : 65535.0;
        return PICVR_OK;
    }
    /* float32: always scanned, every voxel must be finite */
    const float *f = d->data;
    double lo = INFINITY, hi = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(f[i])) return PICVR_ERROR_NON_FINITE;
        if (f[i] < lo) lo = f[i];
        if (f[i] > hi) hi = f[i];
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
    float *bmin = picvr_host_alloc(&ctx->alloc, cells * sizeof(float));
    float *bmax = picvr_host_alloc(&ctx->alloc, cells * sizeof(float));
    if (!bmin || !bmax) { picvr_host_free(&ctx->alloc, bmin); picvr_host_free(&ctx->alloc, bmax); return PICVR_ERROR_OUT_OF_HOST_MEMORY; }
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

/* Copies voxels into the 3D image in z-slabs of at most STAGING_CHUNK bytes, converting
   float data to R16_UNORM where the device cannot filter R32_SFLOAT. */
static picvr_status picvr_upload_voxels(picvr_context *ctx, picvr_image *im, const picvr_volume_desc *d,
                                  VkFormat fmt, picvr_value_map m) {
    size_t in_bpv = picvr_voxel_bytes(d->type);
    size_t out_bpv = fmt == VK_FORMAT_R16_UNORM ? 2 : in_bpv;
    size_t slice_in = (size_t)d->dims[0] * d->dims[1] * in_bpv;
    size_t slice_out = (size_t)d->dims[0] * d->dims[1] * out_bpv;
    uint32_t slab = (uint32_t)(PICVR_STAGING_CHUNK / slice_out);
    if (slab == 0) slab = 1;
    if (slab > d->dims[2]) slab = d->dims[2];
    picvr_buffer staging;
    picvr_status s = picvr_buffer_create(ctx, &staging, (VkDeviceSize)slab * slice_out, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 1);
    if (s) return s;
    int convert = d->type == PICVR_VOXEL_FLOAT32 && fmt == VK_FORMAT_R16_UNORM;
    for (uint32_t z0 = 0; z0 < d->dims[2] && !s; z0 += slab) {
        uint32_t nz = d->dims[2] - z0 < slab ? d->dims[2] - z0 : slab;
        const uint8_t *src = (const uint8_t *)d->data + (size_t)z0 * slice_in;
        if (convert) {
            uint16_t *dst = staging.mapped;
            const float *f = (const float *)src;
            size_t cnt = (size_t)nz * d->dims[0] * d->dims[1];
            for (size_t i = 0; i < cnt; i++) dst[i] = (uint16_t)lrint(picvr_normalize_value(m, f[i]) * 65535.0);
        } else {
            memcpy(staging.mapped, src, (size_t)nz * slice_in);
        }
        picvr_buffer_flush(ctx, &staging);
        if ((s = picvr_cmd_begin(ctx))) break;
        picvr_image_barrier(ctx, im->img, z0 == 0 ? VK_IMAGE_LAYOUT_UNDEFINED : VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                      VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
        VkBufferImageCopy region = {0};
        region.imageSubresource = (VkImageSubresourceLayers){VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageOffset = (VkOffset3D){0, 0, (int32_t)z0};
        region.imageExtent = (VkExtent3D){d->dims[0], d->dims[1], nz};
        vkCmdCopyBufferToImage(ctx->vk.cmd, staging.buf, im->img, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
        if (z0 + nz >= d->dims[2])
            picvr_image_barrier(ctx, im->img, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
        s = picvr_cmd_submit_wait(ctx);
    }
    picvr_buffer_destroy(ctx, &staging);
    return s;
}

/* scale/offset so that clamp(tex * scale + offset, 0, 1) is the normalized value. */
static void picvr_shader_value_map(picvr_context *ctx, const picvr_volume_desc *d, VkFormat fmt, picvr_value_map m) {
    double unit = fmt == VK_FORMAT_R8_UNORM ? 255.0 : fmt == VK_FORMAT_R16_UNORM ? 65535.0 : 1.0;
    double scale = 1.0, offset = 0.0;
    if (!(d->type == PICVR_VOXEL_FLOAT32 && fmt == VK_FORMAT_R16_UNORM) && m.hi > m.lo) {
        scale = unit / (m.hi - m.lo);
        offset = -m.lo / (m.hi - m.lo);
    }
    ctx->scene.gpu.value_map[0] = (float)scale;
    ctx->scene.gpu.value_map[1] = (float)offset;
}

picvr_status picvr_upload_volume(picvr_context *ctx, const picvr_volume_desc *desc) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    size_t bytes;
    picvr_status s = picvr_validate_volume(ctx, desc, &bytes);
    if (s) return s;
    {   /* issue 6: the world box (dims * spacing, and its diagonal) must fit a float */
        double diag2 = 0.0;
        for (int i = 0; i < 3; i++) {
            double size = (double)desc->dims[i] * (desc->spacing[i] > 0.0f ? desc->spacing[i] : 1.0f);
            diag2 += size * size;
        }
        if (!(sqrt(diag2) < FLT_MAX)) return PICVR_ERROR_INVALID_ARGUMENT;
    }
    {   /* issue 6: a volume larger than the device can allocate (picvr_volume_alloc_limit) is
           refused before anything is allocated */
        VkDeviceSize dev = (VkDeviceSize)(bytes / picvr_voxel_bytes(desc->type)) *
            (desc->type == PICVR_VOXEL_FLOAT32 && ctx->vk.float_volume_format == VK_FORMAT_R16_UNORM ? 2 : picvr_voxel_bytes(desc->type));
        if (ctx->vk.max_volume_bytes && dev > ctx->vk.max_volume_bytes) {
            picvr_log_message(ctx, PICVR_LOG_WARNING, "volume of %llu bytes exceeds the device's allocation limit", (unsigned long long)dev);
            return PICVR_ERROR_OUT_OF_DEVICE_MEMORY;
        }
    }
    picvr_value_map m;
    if ((s = picvr_volume_range(desc, bytes / picvr_voxel_bytes(desc->type), &m))) return s;

    uint32_t maxdim = desc->dims[0];
    for (int i = 1; i < 3; i++) if (desc->dims[i] > maxdim) maxdim = desc->dims[i];
    uint32_t brick = 8;   /* measured on bonsai: 8 beats 4 (DDA steps) and 16 (null collisions) */
    while ((maxdim + brick - 1) / brick > PICVR_MAX_GRID) brick *= 2;
    uint32_t grid[3];
    for (int i = 0; i < 3; i++) grid[i] = (desc->dims[i] + brick - 1) / brick;

    VkFormat fmt = desc->type == PICVR_VOXEL_UINT8 ? VK_FORMAT_R8_UNORM
                 : desc->type == PICVR_VOXEL_UINT16 ? VK_FORMAT_R16_UNORM : ctx->vk.float_volume_format;
    /* Build the new volume beside the old one; swap only when everything succeeded. */
    picvr_image vol;
    picvr_buffer maj;
    float *bmin = NULL, *bmax = NULL;
    size_t cells = (size_t)grid[0] * grid[1] * grid[2];
    if ((s = picvr_image_create(ctx, &vol, VK_IMAGE_TYPE_3D, fmt, desc->dims[0], desc->dims[1], desc->dims[2]))) return s;
    if ((s = picvr_buffer_create(ctx, &maj, 2 * cells * sizeof(float),
                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0))) {
        picvr_image_destroy(ctx, &vol);
        return s;
    }
    s = picvr_upload_voxels(ctx, &vol, desc, fmt, m);
    if (!s) s = picvr_build_bricks(ctx, desc, m, brick, grid, &bmin, &bmax);
    if (s) { picvr_image_destroy(ctx, &vol); picvr_buffer_destroy(ctx, &maj); return s; }

    picvr_image_destroy(ctx, &ctx->scene.volume);
    picvr_buffer_destroy(ctx, &ctx->scene.majorant);
    picvr_host_free(&ctx->alloc, ctx->scene.brick_min);
    picvr_host_free(&ctx->alloc, ctx->scene.brick_max);
    ctx->scene.volume = vol;
    ctx->scene.majorant = maj;
    ctx->scene.brick_min = bmin;
    ctx->scene.brick_max = bmax;
    ctx->scene.brick = brick;
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
    ctx->scene.gpu.cell_size[3] = min_spacing;
    ctx->scene.gpu.box_size[3] = 0.5f * (float)picvr_len3(ctx->scene.gpu.box_size);
    picvr_shader_value_map(ctx, desc, fmt, m);
    ctx->scene.has_volume = 1;
    ctx->pipes.descriptors_dirty = 1;
    s = picvr_update_majorant(ctx);
    if (!s) s = picvr_cache_clear(ctx);
    if (!s) s = picvr_clear_accumulation(ctx);
    return s;
}

picvr_status picvr_volume_box(const picvr_context *ctx, float box_min[3], float box_max[3]) {
    if (!ctx || !box_min || !box_max) return PICVR_ERROR_NULL_POINTER;
    if (!ctx->scene.has_volume) return PICVR_ERROR_NOT_READY;
    for (int i = 0; i < 3; i++) {
        box_min[i] = ctx->scene.gpu.box_min[i];
        box_max[i] = ctx->scene.gpu.box_min[i] + ctx->scene.gpu.box_size[i];
    }
    return PICVR_OK;
}

/* ---------------------------------------------------------------------------------- */
/* lights                                                                              */

static picvr_status picvr_validate_light(const picvr_light *l) {
    if (l->type < PICVR_LIGHT_SPHERE || l->type > PICVR_LIGHT_POINT) return PICVR_ERROR_INVALID_LIGHT;
    if (!picvr_finite3(l->color) || !isfinite(l->intensity) || !picvr_finite3(l->position) || !isfinite(l->radius) ||
        !picvr_finite3(l->direction) || !isfinite(l->angular_diameter) || !picvr_finite3(l->edge_u) || !picvr_finite3(l->edge_v))
        return PICVR_ERROR_NON_FINITE;
    if (l->intensity < 0.0f || l->color[0] < 0.0f || l->color[1] < 0.0f || l->color[2] < 0.0f)
        return PICVR_ERROR_INVALID_LIGHT;
    for (int c = 0; c < 3; c++)   /* colour * intensity must stay a finite float */
        if ((double)l->color[c] * l->intensity > FLT_MAX) return PICVR_ERROR_INVALID_LIGHT;
    if (l->type == PICVR_LIGHT_SPHERE && !(l->radius > 0.0f)) return PICVR_ERROR_INVALID_LIGHT;
    if (l->type == PICVR_LIGHT_RECT) {
        float n[3];
        picvr_cross3(l->edge_u, l->edge_v, n);
        double lu = picvr_len3(l->edge_u), lv = picvr_len3(l->edge_v), ln = picvr_len3(n);
        if (!(lu > 0.0) || !(lv > 0.0) || !(ln > 1e-6 * lu * lv) || !isfinite(ln)) return PICVR_ERROR_INVALID_LIGHT;
    }
    if (l->type == PICVR_LIGHT_DIRECTIONAL &&
        (!(picvr_len3(l->direction) > 0.0) || l->angular_diameter < 0.0f || l->angular_diameter >= (float)PICVR_PI))
        return PICVR_ERROR_INVALID_LIGHT;
    return PICVR_OK;
}

/* Emitted power used to choose a light (proportional sampling), in double. */
static double picvr_light_power(const picvr_light *l, double scene_radius) {
    double lum = picvr_luminance(l->color) * l->intensity;
    switch (l->type) {
    case PICVR_LIGHT_SPHERE: return lum * PICVR_PI * 4.0 * PICVR_PI * (double)l->radius * l->radius;
    case PICVR_LIGHT_RECT: { float n[3]; picvr_cross3(l->edge_u, l->edge_v, n); return lum * PICVR_PI * picvr_len3(n); }
    case PICVR_LIGHT_DIRECTIONAL: return lum * PICVR_PI * scene_radius * scene_radius;
    default: return lum * 4.0 * PICVR_PI;
    }
}

static void picvr_pack_light(const picvr_light *l, picvr_gpu_light *g) {
    memset(g, 0, sizeof *g);
    float rad[3];
    for (int c = 0; c < 3; c++) rad[c] = l->color[c] * l->intensity;
    picvr_pack4(g->p0, l->position, (float)l->type);
    picvr_pack4(g->p1, rad, 0.0f);
    if (l->type == PICVR_LIGHT_SPHERE) g->p2[3] = l->radius;
    if (l->type == PICVR_LIGHT_RECT) {
        float n[3];
        picvr_cross3(l->edge_u, l->edge_v, n);
        picvr_pack4(g->p2, l->edge_u, 0.0f);
        picvr_pack4(g->p3, l->edge_v, (float)picvr_len3(n));
    }
    if (l->type == PICVR_LIGHT_DIRECTIONAL) {
        double inv = 1.0 / picvr_len3(l->direction);
        float dir[3] = {(float)(l->direction[0] * inv), (float)(l->direction[1] * inv), (float)(l->direction[2] * inv)};
        picvr_pack4(g->p0, dir, (float)l->type);
        /* 1 - cos(half angle) = 2 sin^2(half angle / 2), without cancellation.  Rule:
           cones below 1e-12 sr/(2 pi) are delta lights (their radiance would overflow). */
        double s = sin(0.25 * l->angular_diameter), omc = 2.0 * s * s;
        if (omc < 1e-12) omc = 0.0;
        g->p2[3] = (float)omc;
        /* colour * intensity is the irradiance on a plane facing the sun:
           E = L * pi sin^2(h), so L = E / (pi omc (2 - omc)). */
        if (omc > 0.0)
            for (int c = 0; c < 3; c++) g->p1[c] = (float)(rad[c] / (PICVR_PI * omc * (2.0 - omc)));
    }
}

static int picvr_light_is_delta(const picvr_gpu_light *g) {
    int type = (int)g->p0[3];
    return type == PICVR_LIGHT_POINT || (type == PICVR_LIGHT_DIRECTIONAL && g->p2[3] == 0.0f);
}

/* scene.light_mono: whether every emitter (a light or the background with power) has
   one chromaticity k, as white lights do.  Transmittance and the phase function are
   scalars, so the irradiance is then k times one scalar field: an entry's three rates
   and radii agree, and a cache lookup extrapolates only channel m (k's largest) and
   adds ln(k_c / k_m) for the others (cache.glsl, predict), a third of the work.  The
   results are those of the three-channel path up to float rounding, except in an entry
   whose centre estimate is 0: there the zero rule of Eq. 6 (cache_math.glsl) gives each
   channel its own rate, while this path keeps the exact ratio k.  Colours count as one
   chromaticity when they agree to 1e-6 of k_m (cross-multiplied, no division).  No
   emitter at all: channel 0 with k = (1, 1, 1) (the image is black anyway). */
static int picvr_emits_light(const float e[3]) { return e[0] > 0.0f || e[1] > 0.0f || e[2] > 0.0f; }

static void picvr_light_chromaticity(const float (*emit)[3], uint32_t n, float out[4]) {
    const float *k = NULL;
    for (uint32_t i = 0; i < n && !k; i++)
        if (picvr_emits_light(emit[i])) k = emit[i];
    static const float white[3] = {1.0f, 1.0f, 1.0f};
    if (!k) k = white;
    int m = k[1] > k[0] ? 1 : 0;
    if (k[2] > k[m]) m = 2;
    for (uint32_t i = 0; i < n; i++) {
        const float *e = emit[i];
        if (!picvr_emits_light(e)) continue;
        for (int c = 0; c < 3; c++)
            if (fabs((double)e[c] * k[m] - (double)k[c] * e[m]) > 1e-6 * (double)e[m] * k[m]) {
                out[0] = out[1] = out[2] = 0.0f;
                out[3] = 3.0f;
                return;
            }
    }
    /* ln(k_c / k_m) > ln(1e-45 / FLT_MAX) > -193: a float; k_c = 0 -> below the code for 0 */
    for (int c = 0; c < 3; c++)
        out[c] = k[c] > 0.0f ? (float)log((double)k[c] / k[m]) : -138.2f;
    out[3] = (float)m;
}

picvr_status picvr_set_lights(picvr_context *ctx, const picvr_light *lights, uint32_t count,
                              const picvr_background *bg) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    if (count > PICVR_MAX_LIGHTS) return PICVR_ERROR_TOO_MANY_LIGHTS;
    if (count > 0 && !lights) return PICVR_ERROR_NULL_POINTER;
    for (uint32_t i = 0; i < count; i++) {
        picvr_status s = picvr_validate_light(&lights[i]);
        if (s) return s;
    }
    if (bg) {
        if (!picvr_finite3(bg->color) || !isfinite(bg->intensity)) return PICVR_ERROR_NON_FINITE;
        if (bg->intensity < 0.0f || bg->color[0] < 0.0f || bg->color[1] < 0.0f || bg->color[2] < 0.0f)
            return PICVR_ERROR_INVALID_LIGHT;
        for (int c = 0; c < 3; c++)
            if ((double)bg->color[c] * bg->intensity > FLT_MAX) return PICVR_ERROR_INVALID_LIGHT;
    }
    /* Scene radius for the power of lights at infinity: the volume's bounding sphere
       (1 before a volume is uploaded; only the ratios matter). */
    double R = ctx->scene.has_volume ? ctx->scene.gpu.box_size[3] : 1.0;
    double power[PICVR_MAX_LIGHTS + 1], total = 0.0;
    for (uint32_t i = 0; i < count; i++) total += power[i] = picvr_light_power(&lights[i], R);
    double bg_power = bg ? picvr_luminance(bg->color) * bg->intensity * 4.0 * PICVR_PI * PICVR_PI * R * R : 0.0;
    total += bg_power;

    int mis = 0;
    double cdf = 0.0;
    for (uint32_t i = 0; i < count; i++) {
        picvr_gpu_light *g = &ctx->scene.gpu.lights[i];
        picvr_pack_light(&lights[i], g);
        /* Rule: with zero total power every probability is 0 and nothing is sampled. */
        double pmf = total > 0.0 ? power[i] / total : 0.0;
        cdf += pmf;
        g->p1[3] = (float)pmf;
        g->p4[0] = (float)cdf;
        if (!picvr_light_is_delta(g) && pmf > 0.0) mis = 1;
    }
    float bgr[3] = {0, 0, 0};
    if (bg) for (int c = 0; c < 3; c++) bgr[c] = bg->color[c] * bg->intensity;
    picvr_pack4(ctx->scene.gpu.background, bgr, total > 0.0 ? (float)(bg_power / total) : 0.0f);
    if (bg_power > 0.0) mis = 1;
    float emit[PICVR_MAX_LIGHTS + 1][3];
    for (uint32_t i = 0; i < count; i++)
        for (int c = 0; c < 3; c++) emit[i][c] = power[i] > 0.0 ? ctx->scene.gpu.lights[i].p1[c] : 0.0f;
    for (int c = 0; c < 3; c++) emit[count][c] = bg_power > 0.0 ? bgr[c] : 0.0f;
    picvr_light_chromaticity((const float (*)[3])emit, count + 1, ctx->scene.gpu.light_mono);
    ctx->scene.gpu.grid[3] = count;
    ctx->scene.use_phase_mis = mis;
    picvr_status s = picvr_cache_clear(ctx);
    return s ? s : picvr_clear_accumulation(ctx);
}

/* ---------------------------------------------------------------------------------- */
/* camera and image buffers                                                            */

static uint32_t picvr_gcd32(uint32_t a, uint32_t b) {
    while (b) { uint32_t t = a % b; a = b; b = t; }
    return a;
}

/* The round-robin stride over n blocks: coprime with n (so k -> k * stride mod n is a
   permutation) and near n / golden ratio (so consecutive k land far apart). */
static uint32_t picvr_spread_stride(uint32_t n) {
    if (n <= 2) return 1;
    uint32_t s = (uint32_t)(n * 0.6180339887) | 1u;
    while (picvr_gcd32(s, n) != 1) s++;
    return s % n ? s % n : 1;
}

static picvr_status picvr_create_image_buffers(picvr_context *ctx, uint32_t w, uint32_t h) {
    VkDeviceSize pixels = (VkDeviceSize)w * h;
    VkDeviceSize plane = pixels * 16;
    if (plane > ctx->vk.props.limits.maxStorageBufferRange) {
        picvr_log_message(ctx, PICVR_LOG_WARNING, "image of %ux%u exceeds maxStorageBufferRange", w, h);
        return PICVR_ERROR_SIZE_OVERFLOW;
    }
    /* an event queue (shading; with the cache also the lookup): smaller than a plane */
    VkDeviceSize queue_bytes = PICVR_EVENT_HEAD_BYTES + pixels * PICVR_EVENT_WORDS * 4;
    if (queue_bytes > ctx->vk.props.limits.maxStorageBufferRange) {
        picvr_log_message(ctx, PICVR_LOG_WARNING, "image of %ux%u: its event queue exceeds maxStorageBufferRange", w, h);
        return PICVR_ERROR_SIZE_OVERFLOW;
    }
    VkDeviceSize groups = (pixels + 255) / 256;
    uint32_t blocks = ((w + 15) / 16) * ((h + 7) / 8);
    picvr_buffer acc[3], rb, part, queue, shade, lookup, sp;
    picvr_buffer *made[] = {&acc[0], &acc[1], &acc[2], &rb, &part, &queue, &shade, &lookup, &sp};
    for (size_t i = 0; i < sizeof made / sizeof made[0]; i++) memset(made[i], 0, sizeof *made[i]);
    picvr_status s = PICVR_OK;
    for (int i = 0; i < 3 && !s; i++)
        s = picvr_buffer_create(ctx, &acc[i], plane, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT, 0);
    if (!s) s = picvr_buffer_create(ctx, &rb, plane, VK_BUFFER_USAGE_TRANSFER_DST_BIT, 1);
    if (!s) s = picvr_buffer_create(ctx, &part, groups * sizeof(picvr_gpu_partial), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, 1);
    /* the rendering queue: a 32-byte header, then one uvec4 per block */
    if (!s) s = picvr_buffer_create(ctx, &queue, 32 + (VkDeviceSize)blocks * 16,
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    VkBufferUsageFlags queue_usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                                     VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    if (!s) s = picvr_buffer_create(ctx, &shade, queue_bytes, queue_usage, 0);
    if (!s && ctx->cache.on) s = picvr_buffer_create(ctx, &lookup, queue_bytes, queue_usage, 0);
    /* superpixel locks and counters: the real thing in screen-space mode, a stub (the
       shader module declares the binding) in object-space mode */
    uint32_t side = ctx->cache.cfg.superpixel_size, superpixels = 0;
    if (!s && ctx->cache.on) {
        superpixels = ((w + side - 1) / side) * ((h + side - 1) / side);
        uint64_t bytes = ctx->cache.cfg.mode == PICVR_CACHE_SCREEN_SPACE ? (uint64_t)superpixels * 5 * 4 : 16;
        s = picvr_buffer_create(ctx, &sp, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0);
    }
    if (s) {   /* nothing replaced yet: free what was made (a zeroed buffer is a no-op) */
        for (size_t i = 0; i < sizeof made / sizeof made[0]; i++) picvr_buffer_destroy(ctx, made[i]);
        return s;
    }
    if (ctx->cache.on) {
        picvr_buffer_destroy(ctx, &ctx->cache.superpixels);
        ctx->cache.superpixels = sp;
        ctx->cache.superpixel_count = superpixels;
    }
    for (int i = 0; i < 3; i++) { picvr_buffer_destroy(ctx, &ctx->image.planes[i]); ctx->image.planes[i] = acc[i]; }
    picvr_buffer_destroy(ctx, &ctx->results.readback);
    picvr_buffer_destroy(ctx, &ctx->results.partials);
    picvr_buffer_destroy(ctx, &ctx->image.render_queue);
    picvr_buffer_destroy(ctx, &ctx->image.shade_queue);
    picvr_buffer_destroy(ctx, &ctx->image.lookup_queue);
    ctx->results.readback = rb;
    ctx->results.partials = part;
    ctx->image.render_queue = queue;
    ctx->image.shade_queue = shade;
    ctx->image.lookup_queue = lookup;
    ctx->image.block_total = blocks;
    ctx->image.block_stride = picvr_spread_stride(blocks);
    ctx->pipes.descriptors_dirty = 1;
    return PICVR_OK;
}

static picvr_status picvr_validate_camera(const picvr_camera *c, picvr_camera *out) {
    if (!c) return PICVR_ERROR_NULL_POINTER;
    *out = *c;
    if (!picvr_finite3(c->position) || !picvr_finite3(c->target) || !picvr_finite3(c->up) || !isfinite(c->fov_y_degrees))
        return PICVR_ERROR_NON_FINITE;
    if (c->width == 0 || c->height == 0) return PICVR_ERROR_INVALID_DIMENSIONS;
    if (c->width > PICVR_MAX_IMAGE_SIZE || c->height > PICVR_MAX_IMAGE_SIZE) return PICVR_ERROR_SIZE_OVERFLOW;
    if (out->up[0] == 0.0f && out->up[1] == 0.0f && out->up[2] == 0.0f) out->up[1] = 1.0f;
    if (out->fov_y_degrees == 0.0f) out->fov_y_degrees = 40.0f;
    if (!(out->fov_y_degrees > 0.0f && out->fov_y_degrees <= 179.0f)) return PICVR_ERROR_INVALID_CAMERA;
    float f[3] = {c->target[0] - c->position[0], c->target[1] - c->position[1], c->target[2] - c->position[2]};
    double lf = picvr_len3(f);
    if (!(lf > 0.0) || !isfinite(lf)) return PICVR_ERROR_INVALID_CAMERA;
    float r[3];
    picvr_cross3(f, out->up, r);
    if (!(picvr_len3(r) > 1e-6 * lf * picvr_len3(out->up))) return PICVR_ERROR_INVALID_CAMERA;
    return PICVR_OK;
}

static void picvr_normalize3(float v[3]) {
    double l = picvr_len3(v);
    for (int i = 0; i < 3; i++) v[i] = (float)(v[i] / l);
}

picvr_status picvr_set_camera(picvr_context *ctx, const picvr_camera *camera) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    picvr_camera c;
    picvr_status s = picvr_validate_camera(camera, &c);
    if (s) return s;
    if (ctx->scene.has_camera && !memcmp(&c, &ctx->scene.camera, sizeof c)) return PICVR_OK;
    if (!ctx->scene.has_camera || c.width != ctx->scene.camera.width || c.height != ctx->scene.camera.height)
        if ((s = picvr_create_image_buffers(ctx, c.width, c.height))) return s;
    float f[3] = {c.target[0] - c.position[0], c.target[1] - c.position[1], c.target[2] - c.position[2]}, r[3], u[3];
    picvr_normalize3(f);
    picvr_cross3(f, c.up, r);
    picvr_normalize3(r);
    picvr_cross3(r, f, u);
    picvr_gpu_scene *g = &ctx->scene.gpu;
    picvr_pack4(g->cam_pos, c.position, (float)tan(0.5 * c.fov_y_degrees * PICVR_PI / 180.0));
    picvr_pack4(g->cam_fwd, f, (float)c.width / (float)c.height);
    picvr_pack4(g->cam_right, r, 0.0f);
    picvr_pack4(g->cam_up, u, 0.0f);
    g->image[0] = c.width;
    g->image[1] = c.height;
    ctx->scene.camera = c;
    ctx->scene.has_camera = 1;
    if (ctx->cache.on) {
        picvr_cache_scene_params(ctx);   /* the request cap and superpixels follow the image size */
        if ((s = picvr_cmd_begin(ctx))) return s;
        picvr_barrier_all(ctx);
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.superpixels.buf, 0, VK_WHOLE_SIZE, 0);
        picvr_barrier_all(ctx);
        if ((s = picvr_cmd_submit_wait(ctx))) return s;
    }
    return picvr_clear_accumulation(ctx);
}

/* ---------------------------------------------------------------------------------- */
/* rendering                                                                           */

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
        {ctx->image.lookup_queue.buf, 0, VK_WHOLE_SIZE}};
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

/* The pipeline variants of every procedure the context runs, for the current scene. */
static picvr_status picvr_select_variants(picvr_context *ctx) {
    ctx->pipes.variant_clock++;
    picvr_status s = picvr_select_variant(ctx, PICVR_PROC_RENDER);
    if (!s && ctx->cache.on) s = picvr_select_variant(ctx, PICVR_PROC_CREATE);
    if (!s && ctx->cache.on) s = picvr_select_variant(ctx, PICVR_PROC_UPDATE);
    return s;
}

/* The scene's uniform block and the descriptors, as the next dispatches read them. */
static picvr_status picvr_upload_scene(picvr_context *ctx) {
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    if (!ctx->scene.has_volume || !ctx->scene.has_camera) return PICVR_ERROR_NOT_READY;
    memcpy(ctx->scene.ubo.mapped, &ctx->scene.gpu, sizeof ctx->scene.gpu);
    picvr_buffer_flush(ctx, &ctx->scene.ubo);
    picvr_update_descriptors(ctx);
    return PICVR_OK;
}

static picvr_status picvr_prepare_render(picvr_context *ctx) {
    picvr_status s = picvr_upload_scene(ctx);   /* first: it checks that the scene is ready */
    return s ? s : picvr_select_variants(ctx);
}

picvr_status picvr_prepare(picvr_context *ctx) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    if (!ctx->scene.has_volume) return PICVR_ERROR_NOT_READY;   /* dense media choose USE_FINE */
    return picvr_select_variants(ctx);
}

/* ---------------------------------------------------------------------------------- */
/* the scheduler (paper §6, §7; ARCHITECTURE.md "The scheduler")                       */
/*                                                                                     */
/* picvr_step runs rounds of about 1/rounds_per_second.  A round is one submission:    */
/*   creation (indirect: one workgroup per request the previous round queued, `budget`  */
/*   of them create entries, the rest only unlock) -> [octree rebuild, when due] ->     */
/*   update (N_u blocks) -> rendering (block_priority + block_select fill the device    */
/*   queue, an indirect dispatch renders it; repeated while the round wants more       */
/*   blocks than the image has) -> counters copied for the host.                        */
/* Device timestamps around the three procedures give each one's device time; the host  */
/* keeps the cost of one work package of each and sizes the next round so that the     */
/* procedures get the §6 shares.  The procedures share the cache pools, so a barrier    */
/* separates them (Vulkan requires it for the writes each makes visible to the next).   */

/* Timestamps of a round: start, after creation, after rebuild, after update, end. */
#define PICVR_ROUND_TIMESTAMPS 5u

static picvr_status picvr_resolve_scheduler_config(const picvr_scheduler_config *in, picvr_scheduler_config *c) {
    *c = *in;
    if ((unsigned)c->priorities > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->priorities == PICVR_SWITCH_DEFAULT) c->priorities = PICVR_SWITCH_ON;
    float *f[7] = {&c->create_min, &c->create_max, &c->update_min, &c->update_max, &c->exponent,
                   &c->rounds_per_second, &c->hit_rate_window_ms};
    const float def[7] = {0.05f, 0.15f, 0.01f, 0.02f, 3.0f, 20.0f, 100.0f};
    for (int i = 0; i < 7; i++) {
        if (!isfinite(*f[i])) return PICVR_ERROR_NON_FINITE;
        if (*f[i] < 0.0f) return PICVR_ERROR_INVALID_ARGUMENT;
        if (*f[i] == 0.0f) *f[i] = def[i];
    }
    /* a pair given as (min, 0) keeps max at its default only if that is >= min */
    if (c->create_min > c->create_max || c->update_min > c->update_max) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->create_max + c->update_max > 0.9f) return PICVR_ERROR_INVALID_ARGUMENT;  /* rendering keeps >= 10% */
    if (c->rounds_per_second > 1000.0f || c->rounds_per_second < 1.0f) return PICVR_ERROR_INVALID_ARGUMENT;
    return PICVR_OK;
}

static picvr_status picvr_create_timestamps(picvr_context *ctx) {
    uint32_t n = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(ctx->vk.phys, &n, NULL);
    VkQueueFamilyProperties fam[16];
    if (n > 16) n = 16;
    vkGetPhysicalDeviceQueueFamilyProperties(ctx->vk.phys, &n, fam);
    uint32_t bits = ctx->vk.queue_family < n ? fam[ctx->vk.queue_family].timestampValidBits : 0;
    if (bits == 0 || ctx->vk.props.limits.timestampPeriod <= 0.0f) {
        picvr_log_message(ctx, PICVR_LOG_INFO, "no device timestamps: procedure times are estimated from wall time");
        return PICVR_OK;
    }
    ctx->rounds.timestamp_ns = ctx->vk.props.limits.timestampPeriod;
    ctx->rounds.timestamp_mask = bits >= 64 ? UINT64_MAX : ((uint64_t)1 << bits) - 1;
    VkQueryPoolCreateInfo qi = {VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qi.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qi.queryCount = PICVR_ROUND_TIMESTAMPS;
    PICVR_VK_TRY(ctx, vkCreateQueryPool(ctx->vk.device, &qi, NULL, &ctx->rounds.timestamps));
    return PICVR_OK;
}

/* What one round does. */
typedef struct picvr_round_plan {
    uint32_t render_blocks;   /* blocks to render (more than the image has: several dispatches) */
    int whole_passes;         /* round-robin from block 0, priorities ignored (picvr_step_iterations) */
    uint32_t create_budget;   /* queued requests that become entries this round */
    uint32_t request_cap;     /* requests this round's rendering may queue */
    uint32_t update_groups;   /* update work packages */
    int rebuild;              /* rebuild the octree */
} picvr_round_plan;

static void picvr_write_timestamp(picvr_context *ctx, uint32_t i) {
    if (ctx->rounds.timestamps) vkCmdWriteTimestamp(ctx->vk.cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, ctx->rounds.timestamps, i);
}

static void picvr_push_constants(picvr_context *ctx, uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
    uint32_t push[4] = {a, b, c, d};
    vkCmdPushConstants(ctx->vk.cmd, ctx->pipes.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, push);
}

/* Entries this round's creation may add: one per workgroup of its indirect dispatch,
   which holds the requests the previous round queued (read back), within the budget. */
static uint32_t picvr_round_creations(const picvr_context *ctx, const picvr_round_plan *p) {
    if (!ctx->cache.on) return 0;
    return p->create_budget < ctx->cache.requests_pending ? p->create_budget : ctx->cache.requests_pending;
}

/* The octree rebuild (§4.4): empty node and reference pools (the pre-built top copied
   back), then cache_rebuild.comp re-inserts every entry with its current, possibly
   shrunk, radii, so references that shrunk entries no longer need disappear.  Recorded
   after the creation procedure, when no request holds a node lock.  So the dispatch
   must cover the entries this round's creation adds (`created`, picvr_round_creations) as
   well as those the host read back: sized by the host's count alone, an entry past it
   lost every reference until the next rebuild (seen as 126 references for 127
   entries).  The shader skips threads past the device's count. */
static void picvr_record_rebuild(picvr_context *ctx, uint32_t created) {
    uint64_t upper = (uint64_t)ctx->cache.counts.entry_count + created;
    uint32_t entries = upper < ctx->cache.cfg.max_entries ? (uint32_t)upper : ctx->cache.cfg.max_entries;
    vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.nodes.buf, 0, VK_WHOLE_SIZE, 0);
    picvr_barrier_all(ctx);
    VkBufferCopy region = {0, 0, (VkDeviceSize)ctx->cache.prebuilt * 16};
    vkCmdCopyBuffer(ctx->vk.cmd, ctx->cache.prebuilt_nodes.buf, ctx->cache.nodes.buf, 1, &region);
    uint32_t counts[2] = {ctx->cache.prebuilt, 0};                  /* node_count, ref_count */
    vkCmdUpdateBuffer(ctx->vk.cmd, ctx->cache.counters.buf, offsetof(picvr_cache_counters, node_count), sizeof counts, counts);
    picvr_barrier_all(ctx);
    if (entries > 0) {
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.rebuild_pipe);
        vkCmdDispatch(ctx->vk.cmd, (entries + 63) / 64, 1, 1);
        picvr_barrier_all(ctx);
    }
}

/* Empties the event queues for the next dispatch of the rendering procedure; the
   barrier after block_select (picvr_record_render) orders it before the kernels. */
static void picvr_record_empty_queues(picvr_context *ctx) {
    static const uint32_t empty_head[4] = {0, 1, 1, 0};   /* dispatch (x, 1, 1), count */
    vkCmdUpdateBuffer(ctx->vk.cmd, ctx->image.shade_queue.buf, 0, sizeof empty_head, empty_head);
    if (ctx->cache.on) vkCmdUpdateBuffer(ctx->vk.cmd, ctx->image.lookup_queue.buf, 0, sizeof empty_head, empty_head);
}

/* One dispatch of the rendering procedure over the queued blocks: tracking, then with
   the cache the lookup, then shading, each event kernel as many workgroups as the kernel
   before it queued events for (shaders/render.glsl).  Without a debug view the lookup
   queues its misses for shading; with one it shades them itself and the shading
   dispatch has no workgroups. */
static void picvr_record_render_kernels(picvr_context *ctx, const picvr_round_plan *p) {
    picvr_push_constants(ctx, ctx->rounds.count, ctx->seed, p->request_cap, 0);
    vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_kernel(ctx, PICVR_PROC_RENDER, PICVR_KERNEL_MAIN));
    vkCmdDispatchIndirect(ctx->vk.cmd, ctx->image.render_queue.buf, 0);
    picvr_barrier_all(ctx);
    if (ctx->cache.on) {
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_kernel(ctx, PICVR_PROC_RENDER, PICVR_KERNEL_LOOKUP));
        vkCmdDispatchIndirect(ctx->vk.cmd, ctx->image.lookup_queue.buf, 0);
        picvr_barrier_all(ctx);
    }
    vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_kernel(ctx, PICVR_PROC_RENDER, PICVR_KERNEL_SHADE));
    vkCmdDispatchIndirect(ctx->vk.cmd, ctx->image.shade_queue.buf, 0);
    picvr_barrier_all(ctx);
}

/* The rendering procedure for `blocks` blocks: dispatches of at most one image's worth
   (a block must not be rendered twice by one dispatch), each fed by block_select. */
static void picvr_record_render(picvr_context *ctx, const picvr_round_plan *p) {
    uint32_t B = ctx->image.block_total, cap = B < PICVR_MAX_QUEUE ? B : PICVR_MAX_QUEUE;
    int prio = ctx->sched.use_priorities && !p->whole_passes;
    for (uint32_t left = p->render_blocks; left > 0;) {
        uint32_t want = left < cap ? left : cap;
        if (prio) {
            vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.priority_pipe);
            picvr_push_constants(ctx, ctx->scene.camera.width, ctx->scene.camera.height, 0, 0);
            vkCmdDispatch(ctx->vk.cmd, (B + 63) / 64, 1, 1);
            picvr_barrier_all(ctx);
        }
        picvr_record_empty_queues(ctx);
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.select_pipe);
        uint32_t base = (uint32_t)((uint64_t)ctx->image.block_cursor * ctx->image.block_stride % B);
        picvr_push_constants(ctx, want, B, prio ? ctx->image.block_cursor : base, prio ? 0 : ctx->image.block_stride);
        vkCmdDispatch(ctx->vk.cmd, 1, 1, 1);
        picvr_barrier_all(ctx);
        picvr_record_render_kernels(ctx, p);
        ctx->image.block_cursor = (uint32_t)(((uint64_t)ctx->image.block_cursor + want) % B);
        left -= want;
    }
}

/* Marks, per procedure, whether this round runs a pipeline variant for the first time
   (picvr_finish_round then keeps its time out of the cost model and the credit).  Creation
   runs when the last round queued requests: its indirect dispatch has one workgroup
   per request. */
static void picvr_note_dispatches(picvr_context *ctx, const picvr_round_plan *p) {
    int runs[3] = {ctx->cache.on && ctx->cache.requests_pending > 0, ctx->cache.on && p->update_groups > 0,
                   p->render_blocks > 0};
    for (int i = 0; i < 3; i++) {
        if (!runs[i]) {
            ctx->sched.first_dispatch[i] = 0;
            continue;
        }
        picvr_variant_slot *v = &ctx->pipes.variants[i][ctx->pipes.current_slot[i]];
        ctx->sched.first_dispatch[i] = !v->dispatched;
        v->dispatched = 1;
    }
}

static void picvr_record_round(picvr_context *ctx, const picvr_round_plan *p, uint32_t created) {
    picvr_note_dispatches(ctx, p);
    picvr_barrier_all(ctx);
    if (ctx->rounds.timestamps) vkCmdResetQueryPool(ctx->vk.cmd, ctx->rounds.timestamps, 0, PICVR_ROUND_TIMESTAMPS);
    vkCmdBindDescriptorSets(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.layout, 0, 1, &ctx->pipes.set, 0, NULL);
    picvr_write_timestamp(ctx, 0);
    if (ctx->cache.on) {
        /* creation: one workgroup per request queued by the previous round */
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_pipeline(ctx, PICVR_PROC_CREATE));
        picvr_push_constants(ctx, ctx->rounds.count, ctx->seed, p->create_budget, 0);
        vkCmdDispatchIndirect(ctx->vk.cmd, ctx->cache.counters.buf, 0);
        picvr_barrier_all(ctx);
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.counters.buf, offsetof(picvr_cache_counters, dispatch), 4, 0);
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.counters.buf, offsetof(picvr_cache_counters, request_count), 4, 0);
        picvr_barrier_all(ctx);
    }
    picvr_write_timestamp(ctx, 1);
    if (ctx->cache.on && p->rebuild) picvr_record_rebuild(ctx, created);
    picvr_write_timestamp(ctx, 2);
    if (ctx->cache.on && p->update_groups > 0) {
        vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, picvr_current_pipeline(ctx, PICVR_PROC_UPDATE));
        picvr_push_constants(ctx, ctx->rounds.count, ctx->seed, 0, 0);
        vkCmdDispatch(ctx->vk.cmd, p->update_groups, 1, 1);
        picvr_barrier_all(ctx);
    }
    picvr_write_timestamp(ctx, 3);
    picvr_record_render(ctx, p);
    picvr_write_timestamp(ctx, 4);
    if (ctx->cache.on && ctx->cache.cfg.mode == PICVR_CACHE_SCREEN_SPACE) {
        /* superpixel counters: the set this round read is the one the next round writes */
        VkDeviceSize n = ctx->cache.superpixel_count, set = (ctx->rounds.count + 1) & 1;
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.superpixels.buf, (n + 2 * n * set) * 4, 2 * n * 4, 0);
    }
    /* small counters for the host: the cache counters, then the blocks rendered */
    if (ctx->cache.on) {
        VkBufferCopy c = {0, 0, sizeof(picvr_cache_counters)};
        vkCmdCopyBuffer(ctx->vk.cmd, ctx->cache.counters.buf, ctx->rounds.readback.buf, 1, &c);
    }
    VkBufferCopy q = {16, sizeof(picvr_cache_counters), 4};                 /* render_queue.totals.x */
    vkCmdCopyBuffer(ctx->vk.cmd, ctx->image.render_queue.buf, ctx->rounds.readback.buf, 1, &q);
    picvr_barrier_all(ctx);
    if (ctx->cache.on)   /* hits, misses, requests */
        vkCmdFillBuffer(ctx->vk.cmd, ctx->cache.counters.buf, offsetof(picvr_cache_counters, hits), 3 * 4, 0);
    vkCmdFillBuffer(ctx->vk.cmd, ctx->image.render_queue.buf, 16, 4, 0);
    picvr_barrier_all(ctx);
}

static double picvr_moving_average(double old, double now) { return old > 0.0 ? 0.7 * old + 0.3 * now : now; }

/* The hit rate over the last hit_rate_window_ms of rounds (at least the last round). */
static double picvr_window_hit_rate(const picvr_context *ctx, double now) {
    uint64_t hits = 0, events = 0;
    uint32_t n = ctx->sched.history_count < PICVR_SCHED_HISTORY ? ctx->sched.history_count : PICVR_SCHED_HISTORY;
    for (uint32_t k = 0; k < n; k++) {
        const struct picvr_round_record *r = &ctx->sched.history[(ctx->sched.history_count - 1 - k) % PICVR_SCHED_HISTORY];
        if (k > 0 && r->end_ms < now - ctx->sched.cfg.hit_rate_window_ms) break;
        hits += r->hits;
        events += (uint64_t)r->hits + r->misses;
    }
    return events ? (double)hits / (double)events : 0.0;
}

/* §6: t = t_min + (1 - h^e) (t_max - t_min), for creation and update. */
static void picvr_update_targets(picvr_context *ctx) {
    double f = 1.0 - pow(ctx->sched.hit_rate, ctx->sched.cfg.exponent);
    ctx->sched.target[PICVR_PROC_CREATE] = ctx->cache.on ? ctx->sched.cfg.create_min + f * (ctx->sched.cfg.create_max - ctx->sched.cfg.create_min) : 0.0;
    ctx->sched.target[PICVR_PROC_UPDATE] = ctx->cache.on ? ctx->sched.cfg.update_min + f * (ctx->sched.cfg.update_max - ctx->sched.cfg.update_min) : 0.0;
}

/* After a round: the procedure was owed its target share of the round's device time
   and used dev_ms.  Rules: the credit stays below one round's share plus one batch of
   packages, so a stretch without work (no requests) is not paid back later in a burst;
   the debt stays below one round's share plus this round's use (or one batch if more),
   so a dispatch that ran long (entries vary several-fold in cost) is paid back in full -
   forgiving it made creation overshoot its share by 15-20 % with batches - but debts do
   not pile up beyond that. */
static void picvr_settle_credit(picvr_context *ctx, int proc, double device_total, double dev_ms) {
    double c = ctx->sched.credit_ms[proc] + ctx->sched.target[proc] * device_total - dev_ms;
    double batch = proc == PICVR_PROC_CREATE ? ctx->sched.create_batch : 1.0;
    double share = ctx->sched.target[proc] * 1000.0 / ctx->sched.cfg.rounds_per_second;
    double hi = share + batch * ctx->sched.cost[proc];
    double lo = -(share + (dev_ms > batch * ctx->sched.cost[proc] ? dev_ms : batch * ctx->sched.cost[proc]));
    ctx->sched.credit_ms[proc] = c > hi ? hi : c < lo ? lo : c;
}

/* Reads back a finished round: device time per procedure, work done, cache counters;
   updates the cost model, the history, the hit rate and the targets. */
static picvr_status picvr_finish_round(picvr_context *ctx, const picvr_round_plan *p, double wall_ms, uint32_t created) {
    picvr_buffer_invalidate(ctx, &ctx->rounds.readback);
    picvr_cache_counters got;
    uint32_t blocks;
    memcpy(&got, ctx->rounds.readback.mapped, sizeof got);
    memcpy(&blocks, (const uint8_t *)ctx->rounds.readback.mapped + sizeof got, sizeof blocks);
    double dev[3] = {0, 0, 0}, rebuild_ms = 0.0;
    if (ctx->rounds.timestamps) {
        uint64_t t[PICVR_ROUND_TIMESTAMPS];
        PICVR_VK_TRY(ctx, vkGetQueryPoolResults(ctx->vk.device, ctx->rounds.timestamps, 0, PICVR_ROUND_TIMESTAMPS, sizeof t, t, sizeof t[0],
                                          VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
        double ms[PICVR_ROUND_TIMESTAMPS - 1];
        for (uint32_t i = 0; i + 1 < PICVR_ROUND_TIMESTAMPS; i++)
            ms[i] = (double)((t[i + 1] - t[i]) & ctx->rounds.timestamp_mask) * ctx->rounds.timestamp_ns * 1e-6;
        dev[PICVR_PROC_CREATE] = ms[0];
        rebuild_ms = ms[1];
        dev[PICVR_PROC_UPDATE] = ms[1] + ms[2];          /* octree maintenance counts as update */
        dev[PICVR_PROC_RENDER] = ms[3];
        /* Rule: without the cache the round is all rendering (the empty intervals hold
           only barriers). */
        if (!ctx->cache.on) { dev[PICVR_PROC_RENDER] += dev[PICVR_PROC_CREATE] + dev[PICVR_PROC_UPDATE]; dev[PICVR_PROC_CREATE] = dev[PICVR_PROC_UPDATE] = 0.0; }
    } else {
        /* Rule without timestamps: split the wall time by the planned costs. */
        double plan[3] = {created * ctx->sched.cost[PICVR_PROC_CREATE], p->update_groups * ctx->sched.cost[PICVR_PROC_UPDATE],
                          blocks * ctx->sched.cost[PICVR_PROC_RENDER]};
        double sum = plan[0] + plan[1] + plan[2];
        for (int i = 0; i < 3; i++) dev[i] = sum > 0.0 ? wall_ms * plan[i] / sum : (i == PICVR_PROC_RENDER ? wall_ms : 0.0);
    }
    /* Rule: a pipeline variant's first dispatch neither enters the cost model nor is
       charged to its procedure's credit.  llvmpipe compiles a pipeline at its first
       dispatch, inside the round's timestamps (55 ms to about 1 s, ../shared/LAVAPIPE.md;
       Mesa's disk cache spares later runs).  Taken for the procedure's own cost, that
       time held the update procedure (1 % of a round) back for seconds of credit: with
       a cold shader cache it ran one work package in the first 10 s of bonsai, against
       867 with a warm one (2026-11-29). */
    const int *first = ctx->sched.first_dispatch;
    /* Rule: a creation dispatch of fewer entries than a batch costs what a full batch
       does (picvr_creation_batch), so its cost per entry is its time over the batch. */
    if (created > 0 && !first[PICVR_PROC_CREATE])
        ctx->sched.cost[PICVR_PROC_CREATE] = picvr_moving_average(ctx->sched.cost[PICVR_PROC_CREATE],
                                     dev[PICVR_PROC_CREATE] / (created > ctx->sched.create_batch ? created : ctx->sched.create_batch));
    if (p->update_groups > 0 && !first[PICVR_PROC_UPDATE])
        ctx->sched.cost[PICVR_PROC_UPDATE] = picvr_moving_average(ctx->sched.cost[PICVR_PROC_UPDATE], (dev[PICVR_PROC_UPDATE] - rebuild_ms) / p->update_groups);
    if (blocks > 0 && !first[PICVR_PROC_RENDER]) ctx->sched.cost[PICVR_PROC_RENDER] = picvr_moving_average(ctx->sched.cost[PICVR_PROC_RENDER], dev[PICVR_PROC_RENDER] / blocks);
    double device_total = dev[0] + dev[1] + dev[2];
    if (ctx->cache.on) {
        if (!first[PICVR_PROC_CREATE]) picvr_settle_credit(ctx, PICVR_PROC_CREATE, device_total, dev[PICVR_PROC_CREATE]);
        /* The update procedure's share (Table 1: 1-2 %) is its own: the octree rebuild,
           every 1000 ms by Table 1, runs on top (rendering gives way), though the stats
           count it as update time (octree maintenance).  Charged to the update's
           credit, it took most of that share as the cache grew: 30 update packages a
           second at 9,000-13,000 entries on bonsai, 56 with this rule (2026-11-29). */
        if (!first[PICVR_PROC_UPDATE]) picvr_settle_credit(ctx, PICVR_PROC_UPDATE, device_total, dev[PICVR_PROC_UPDATE] - rebuild_ms);
    }
    ctx->sched.overhead_ms = picvr_moving_average(ctx->sched.overhead_ms, wall_ms > device_total ? wall_ms - device_total : 1e-3);
    ctx->image.block_samples += blocks;
    ctx->rounds.count++;
    ctx->image.elapsed_ms += wall_ms;
    ctx->cache.since_rebuild_ms = p->rebuild ? wall_ms : ctx->cache.since_rebuild_ms + wall_ms;
    ctx->results.valid = 0;

    struct picvr_round_record *r = &ctx->sched.history[ctx->sched.history_count % PICVR_SCHED_HISTORY];
    memset(r, 0, sizeof *r);
    r->end_ms = picvr_clock_ms();
    for (int i = 0; i < 3; i++) r->device_ms[i] = dev[i];
    if (ctx->cache.on) {
        /* one round adds far less than 2^32, so the difference modulo 2^32 is exact */
        const picvr_cache_counters *old = &ctx->cache.counts;
        ctx->cache.point_rounds += (uint32_t)(got.point_rounds - old->point_rounds);
        ctx->cache.truncated += (uint32_t)(got.truncated - old->truncated);
        ctx->cache.lookups_cut += (uint32_t)(got.lookups_cut - old->lookups_cut);
        ctx->cache.lookups_spilled += (uint32_t)(got.lookups_spilled - old->lookups_spilled);
        ctx->cache.counts = got;
        r->hits = got.hits;
        r->misses = got.misses;
        ctx->cache.requests_issued += got.requests;
        ctx->cache.requests_pending = got.dispatch[0];   /* valid requests queued for the next round */
    }
    ctx->sched.history_count++;
    ctx->sched.hit_rate = picvr_window_hit_rate(ctx, r->end_ms);
    picvr_update_targets(ctx);
    return PICVR_OK;
}

/* stats.fraction_*: each procedure's share of the device time of the rounds that ended
   in the last SHARE_WINDOW_MS; target_*: the §6 shares now. */
static void picvr_sched_shares(const picvr_context *ctx, picvr_stats *st) {
    double sum[3] = {0, 0, 0};
    uint32_t n = ctx->sched.history_count < PICVR_SCHED_HISTORY ? ctx->sched.history_count : PICVR_SCHED_HISTORY;
    double newest = n ? ctx->sched.history[(ctx->sched.history_count - 1) % PICVR_SCHED_HISTORY].end_ms : 0.0;
    for (uint32_t k = 0; k < n; k++) {
        const struct picvr_round_record *r = &ctx->sched.history[(ctx->sched.history_count - 1 - k) % PICVR_SCHED_HISTORY];
        if (r->end_ms < newest - PICVR_SHARE_WINDOW_MS) break;
        for (int i = 0; i < 3; i++) sum[i] += r->device_ms[i];
    }
    double total = sum[0] + sum[1] + sum[2];
    st->fraction_create = total > 0.0 ? sum[PICVR_PROC_CREATE] / total : 0.0;
    st->fraction_update = total > 0.0 ? sum[PICVR_PROC_UPDATE] / total : 0.0;
    st->fraction_render = total > 0.0 ? sum[PICVR_PROC_RENDER] / total : 0.0;
    st->target_create = ctx->sched.target[PICVR_PROC_CREATE];
    st->target_update = ctx->sched.target[PICVR_PROC_UPDATE];
}

static picvr_status picvr_run_round(picvr_context *ctx, const picvr_round_plan *p) {
    uint32_t created = picvr_round_creations(ctx, p);
    double t0 = picvr_clock_ms();
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_record_round(ctx, p, created);
    if ((s = picvr_cmd_submit_wait(ctx))) return s;
    return picvr_finish_round(ctx, p, picvr_clock_ms() - t0, created);
}

/* Packages a procedure may run this round: the device time it is owed (its credit,
   settled against the measured time after every round in picvr_settle_credit) plus its share
   of this round, in whole packages of the estimated cost.  Because the credit is
   settled with measured times, an estimate that is off (packages of varying cost, a
   cost that drifts as the cache fills) does not bias the long-run share, and a package
   longer than one round's share still runs every few rounds.
   A procedure runs only when it is owed at least `batch` packages (picvr_creation_batch).
   Rule: an unmeasured cost (first round) allows one batch. */
static uint32_t picvr_sched_packages(const picvr_context *ctx, int proc, double share_ms, uint32_t available, uint32_t batch) {
    if (ctx->sched.cost[proc] <= 0.0) return available < batch ? available : batch;
    double owed = (ctx->sched.credit_ms[proc] + share_ms) / ctx->sched.cost[proc];
    if (!(owed >= (double)batch)) return 0;           /* also NaN */
    return owed < (double)available ? (uint32_t)owed : available;
}

/* Whether the physical device offers a device extension (a properties query may chain
   an extension's struct only then). */
static int picvr_device_has_extension(const picvr_context *ctx, const char *name) {
    uint32_t n = 0;
    if (vkEnumerateDeviceExtensionProperties(ctx->vk.phys, NULL, &n, NULL) != VK_SUCCESS || n == 0) return 0;
    VkExtensionProperties *props = picvr_host_alloc(&ctx->alloc, (size_t)n * sizeof *props);
    if (!props) return 0;
    int found = 0;
    if (vkEnumerateDeviceExtensionProperties(ctx->vk.phys, NULL, &n, props) == VK_SUCCESS)
        for (uint32_t i = 0; i < n && !found; i++) found = !strcmp(props[i].extensionName, name);
    picvr_host_free(&ctx->alloc, props);
    return found;
}

/* Creation workgroups a GPU runs side by side: SMs x warps per SM over the warps of one
   workgroup (VK_NV_shader_sm_builtins; 132 x 64 / 4 = 2112 on an H200); other GPUs
   report nothing comparable, so a modest 256.  0 on a CPU device. */
static uint32_t picvr_gpu_resident_groups(const picvr_context *ctx) {
    if (picvr_on_cpu_device(ctx)) return 0;
    if (!picvr_device_has_extension(ctx, VK_NV_SHADER_SM_BUILTINS_EXTENSION_NAME)) return 256;
    VkPhysicalDeviceShaderSMBuiltinsPropertiesNV sm = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_SM_BUILTINS_PROPERTIES_NV};
    VkPhysicalDeviceProperties2 p2 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &sm};
    vkGetPhysicalDeviceProperties2(ctx->vk.phys, &p2);
    uint64_t warps_per_group = (PICVR_CACHE_CREATE_GROUP + 31) / 32;
    uint64_t groups = (uint64_t)sm.shaderSMCount * sm.shaderWarpsPerSM / warps_per_group;
    return groups < 256 ? 256u : groups > 65536 ? 65536u : (uint32_t)groups;
}

/* Entry creation runs one workgroup per entry, and a round's procedures are separated by
   barriers, so a creation dispatch lasts about as long as its slowest entry whenever it
   holds fewer entries than the device runs side by side: a partial dispatch costs what a
   full one does.  So creation waits until it is owed a full batch, and its cost per
   entry is measured as if every dispatch were full (picvr_finish_round).
   - A CPU driver (lavapipe) runs one workgroup per thread, one thread per core: with one
     entry per dispatch (a 20 ms entry against a 7.5 ms share per round, bonsai) half of
     the creation share was idle time on 2 cores.  The batch is one entry per thread
     (LP_NUM_THREADS, lavapipe's own setting, else the online cores; at most 64).
   - A GPU runs thousands of workgroups at once, and one entry takes milliseconds of
     sequential sampling: with the batch at 1 an H200 created about 50 entries per 50 ms
     round in 6 ms of creation share, the cost model took 0.12 ms per entry, and bonsai's
     hit rate was 0.69 after 10 s (2026-11-30).  The batch is the resident workgroups
     (picvr_gpu_resident_groups), at most the request queue (cache.max_requests). */
static uint32_t picvr_creation_batch(const picvr_context *ctx) {
    uint32_t gpu = picvr_gpu_resident_groups(ctx);
    if (gpu) return gpu < ctx->cache.cfg.max_requests ? gpu : ctx->cache.cfg.max_requests;
    long n = 0;
    const char *env = getenv("LP_NUM_THREADS");
    if (env && *env) n = strtol(env, NULL, 10);
#if defined(_SC_NPROCESSORS_ONLN)
    if (n <= 0) n = sysconf(_SC_NPROCESSORS_ONLN);
#endif
    return n < 1 ? 1u : n > 64 ? 64u : (uint32_t)n;
}


/* Plans a round of round_ms of device time by the §6 shares and the measured costs. */
static picvr_round_plan picvr_plan_round(picvr_context *ctx, double round_ms) {
    picvr_round_plan p;
    memset(&p, 0, sizeof p);
    double avail = round_ms - ctx->sched.overhead_ms;
    if (avail < 0.1 * round_ms) avail = 0.1 * round_ms;
    double left = avail;
    if (ctx->cache.on) {
        double create_ms = ctx->sched.target[PICVR_PROC_CREATE] * avail, update_ms = ctx->sched.target[PICVR_PROC_UPDATE] * avail;
        p.create_budget = picvr_sched_packages(ctx, PICVR_PROC_CREATE, create_ms, ctx->cache.requests_pending, ctx->sched.create_batch);
        p.update_groups = picvr_sched_packages(ctx, PICVR_PROC_UPDATE, update_ms, UINT32_MAX, 1);
        /* requests for the next round: what its creation share can take, at least one batch */
        double next = ctx->sched.cost[PICVR_PROC_CREATE] > 0.0 ? ceil(create_ms / ctx->sched.cost[PICVR_PROC_CREATE]) : 4.0;
        if (next < ctx->sched.create_batch) next = ctx->sched.create_batch;
        p.request_cap = next > ctx->cache.cfg.max_requests ? ctx->cache.cfg.max_requests : (uint32_t)next;
        p.rebuild = ctx->cache.since_rebuild_ms >= ctx->cache.cfg.rebuild_interval_ms;
        /* Work conserving: time creation and update cannot use goes to rendering. */
        left -= p.create_budget * ctx->sched.cost[PICVR_PROC_CREATE] + p.update_groups * ctx->sched.cost[PICVR_PROC_UPDATE];
    }
    double blocks = ctx->sched.cost[PICVR_PROC_RENDER] > 0.0 ? left / ctx->sched.cost[PICVR_PROC_RENDER] : 32.0;
    p.render_blocks = blocks < 1.0 ? 1 : blocks > 64.0 * ctx->image.block_total ? 64 * ctx->image.block_total : (uint32_t)blocks;
    return p;
}

/* picvr_step: rounds until `budget_ms` of wall time have passed (at least one round). */
static picvr_status picvr_step_time(picvr_context *ctx, double budget_ms) {
    picvr_status s = picvr_prepare_render(ctx);
    if (s) return s;
    ctx->cache.requests_issued = 0;
    double start = picvr_clock_ms(), round_ms = 1000.0 / ctx->sched.cfg.rounds_per_second;
    do {
        double left = budget_ms - (picvr_clock_ms() - start);
        picvr_round_plan p = picvr_plan_round(ctx, left < round_ms ? left : round_ms);
        if ((s = picvr_run_round(ctx, &p))) return s;
        /* Rule: a remainder under a tenth of a round is not worth a round's fixed costs. */
    } while (budget_ms - (picvr_clock_ms() - start) > 0.1 * round_ms);
    return PICVR_OK;
}

/* The fixed split of picvr_step_iterations: unless the application set max_requests,
   one request per CACHE_PIXELS_PER_REQUEST pixels per pass. */
static uint32_t picvr_pass_request_cap(const picvr_context *ctx) {
    if (ctx->cache.requests_set) return ctx->cache.cfg.max_requests;
    uint64_t per = ((uint64_t)ctx->scene.camera.width * ctx->scene.camera.height) / PICVR_CACHE_PIXELS_PER_REQUEST;
    return per < 1 ? 1 : per < ctx->cache.cfg.max_requests ? (uint32_t)per : ctx->cache.cfg.max_requests;
}

/* picvr_step_iterations: whole passes over the image, priorities ignored, so that every
   pixel gets exactly `passes` samples.  With the cache, one pass per round and a fixed
   split that does not depend on timing: every request of a pass (at most the
   per-iteration request cap) is created in the next round and 1/16 of the blocks are
   updated.  Without it, passes are batched into rounds of about BATCH_TARGET_MS. */
static picvr_status picvr_step_passes(picvr_context *ctx, uint32_t passes) {
    picvr_status s = picvr_prepare_render(ctx);
    if (s) return s;
    ctx->cache.requests_issued = 0;
    ctx->image.block_cursor = 0;
    for (uint32_t done = 0; done < passes;) {
        picvr_round_plan p;
        memset(&p, 0, sizeof p);
        p.whole_passes = 1;
        uint32_t k = 1;
        if (ctx->cache.on) {
            p.create_budget = UINT32_MAX;
            p.request_cap = picvr_pass_request_cap(ctx);
            p.update_groups = (ctx->image.block_total + 15) / 16;
            p.rebuild = ctx->cache.since_rebuild_ms >= ctx->cache.cfg.rebuild_interval_ms;
        } else if (ctx->sched.cost[PICVR_PROC_RENDER] > 0.0) {
            double fit = PICVR_BATCH_TARGET_MS / (ctx->sched.cost[PICVR_PROC_RENDER] * ctx->image.block_total);
            k = fit < 1.0 ? 1u : fit > PICVR_MAX_BATCH ? PICVR_MAX_BATCH : (uint32_t)fit;
        }
        if (k > passes - done) k = passes - done;
        p.render_blocks = k * ctx->image.block_total;
        if ((s = picvr_run_round(ctx, &p))) return s;
        done += k;
    }
    return PICVR_OK;
}

picvr_status picvr_step(picvr_context *ctx, double milliseconds) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    if (!isfinite(milliseconds)) return PICVR_ERROR_NON_FINITE;   /* the NaN/Inf convention */
    if (milliseconds < 0.0) return PICVR_ERROR_INVALID_ARGUMENT;
    return picvr_step_time(ctx, milliseconds);
}

picvr_status picvr_step_iterations(picvr_context *ctx, uint32_t iterations) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    if (iterations == 0) return PICVR_OK;
    return picvr_step_passes(ctx, iterations);
}

/* ---------------------------------------------------------------------------------- */
/* reading results                                                                     */

/* Copies accumulation plane `plane` (0: mean rgba, 2: lum mean, M2, n, bad) to readback. */
static picvr_status picvr_read_plane(picvr_context *ctx, int plane) {
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_barrier_all(ctx);
    VkBufferCopy region = {0, 0, ctx->results.readback.size};
    vkCmdCopyBuffer(ctx->vk.cmd, ctx->image.planes[plane].buf, ctx->results.readback.buf, 1, &region);
    picvr_barrier_all(ctx);
    if ((s = picvr_cmd_submit_wait(ctx))) return s;
    picvr_buffer_invalidate(ctx, &ctx->results.readback);
    return PICVR_OK;
}

static picvr_status picvr_check_image_read(picvr_context *ctx, const void *dst, size_t size, size_t bpp) {
    if (!ctx || !dst) return PICVR_ERROR_NULL_POINTER;
    if (!ctx->scene.has_camera) return PICVR_ERROR_NOT_READY;
    if (size / bpp < (size_t)ctx->scene.camera.width * ctx->scene.camera.height) return PICVR_ERROR_BUFFER_TOO_SMALL;
    return PICVR_OK;
}

picvr_status picvr_read_rgba32f(picvr_context *ctx, float *pixels, size_t size) {
    picvr_status s = picvr_check_image_read(ctx, pixels, size, 16);
    if (!s) s = picvr_read_plane(ctx, 0);
    if (!s) memcpy(pixels, ctx->results.readback.mapped, (size_t)ctx->scene.camera.width * ctx->scene.camera.height * 16);
    return s;
}

picvr_status picvr_read_sample_counts(picvr_context *ctx, uint32_t *counts, size_t count) {
    size_t bytes = count > SIZE_MAX / 4 ? SIZE_MAX : count * 4;   /* saturate: large is large enough */
    picvr_status s = picvr_check_image_read(ctx, counts, bytes, 4);
    if (!s) s = picvr_read_plane(ctx, 2);
    if (s) return s;
    const uint32_t *src = ctx->results.readback.mapped;     /* vec4 per pixel, z = n as uint bits */
    size_t n = (size_t)ctx->scene.camera.width * ctx->scene.camera.height;
    for (size_t i = 0; i < n; i++) counts[i] = src[i * 4 + 2];
    return PICVR_OK;
}

static uint8_t picvr_to_srgb8(double x) {
    /* Rule: NaN (never produced, but never trusted) maps to 0. */
    if (!(x > 0.0)) return 0;
    if (x >= 1.0) return 255;
    double s = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    return (uint8_t)lrint(s * 255.0);
}

picvr_status picvr_read_rgba8(picvr_context *ctx, uint8_t *pixels, size_t size, float exposure) {
    picvr_status s = picvr_check_image_read(ctx, pixels, size, 4);
    if (!s) s = picvr_read_plane(ctx, 0);
    if (s) return s;
    double e = (isfinite(exposure) && exposure > 0.0f) ? exposure : 1.0;
    const float *src = ctx->results.readback.mapped;
    size_t n = (size_t)ctx->scene.camera.width * ctx->scene.camera.height;
    for (size_t i = 0; i < n; i++) {
        for (int c = 0; c < 3; c++) pixels[i * 4 + c] = picvr_to_srgb8(1.0 - exp(-e * src[i * 4 + c]));
        double a = src[i * 4 + 3];
        pixels[i * 4 + 3] = (uint8_t)lrint((a > 0.0 ? (a < 1.0 ? a : 1.0) : 0.0) * 255.0);
    }
    return PICVR_OK;
}

/* One stats reduction pass with the given relative-error floor; sums the partials
   in double.  Output: sums[0..3] (lum, err, rel, valid), counts[0..3]. */
static picvr_status picvr_stats_pass(picvr_context *ctx, float rel_floor, double sums[4], uint64_t counts[4]) {
    uint32_t pixels = ctx->scene.camera.width * ctx->scene.camera.height;
    uint32_t groups = (pixels + 255) / 256;
    picvr_status s = picvr_cmd_begin(ctx);
    if (s) return s;
    picvr_barrier_all(ctx);
    vkCmdBindPipeline(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.stats_pipe);
    vkCmdBindDescriptorSets(ctx->vk.cmd, VK_PIPELINE_BIND_POINT_COMPUTE, ctx->pipes.stats_layout, 0, 1, &ctx->pipes.set, 0, NULL);
    union { uint32_t u; float f; } push[2];
    push[0].u = pixels;
    push[1].f = rel_floor;
    vkCmdPushConstants(ctx->vk.cmd, ctx->pipes.stats_layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, push);
    uint32_t gx = groups < 65535 ? groups : 65535, gy = (groups + gx - 1) / gx;
    vkCmdDispatch(ctx->vk.cmd, gx, gy, 1);
    picvr_barrier_all(ctx);
    if ((s = picvr_cmd_submit_wait(ctx))) return s;
    picvr_buffer_invalidate(ctx, &ctx->results.partials);
    const picvr_gpu_partial *p = ctx->results.partials.mapped;
    for (int i = 0; i < 4; i++) { sums[i] = 0.0; counts[i] = 0; }
    counts[0] = UINT32_MAX;
    for (uint32_t g = 0; g < groups; g++) {
        for (int i = 0; i < 4; i++) sums[i] += p[g].sums[i];
        if (p[g].counts[0] < counts[0]) counts[0] = p[g].counts[0];
        for (int i = 1; i < 4; i++) counts[i] += p[g].counts[i];
    }
    return PICVR_OK;
}

picvr_status picvr_get_stats(picvr_context *ctx, picvr_stats *out) {
    if (!ctx || !out) return PICVR_ERROR_NULL_POINTER;
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    if (!ctx->results.valid) {
        picvr_stats st;
        memset(&st, 0, sizeof st);
        if (ctx->scene.has_volume && ctx->scene.has_camera && ctx->image.block_samples > 0) {
            picvr_status s = picvr_upload_scene(ctx);
            double sums[4];
            uint64_t counts[4];
            if (!s) s = picvr_stats_pass(ctx, 0.0f, sums, counts);
            double pixels = (double)counts[3];
            double mean_lum = pixels > 0 ? sums[0] / pixels : 0.0;
            if (!s) s = picvr_stats_pass(ctx, (float)(0.01 * mean_lum), sums, counts);
            if (s) return s;
            st.mean_luminance = mean_lum;
            st.iterations_min = (uint32_t)counts[0];
            st.iterations_mean = pixels > 0 ? (double)counts[1] / pixels : 0.0;
            st.truncated_paths = counts[2];
            st.est_error = sums[3] > 0 ? sums[1] / sums[3] : 0.0;
            st.est_rel_error = sums[3] > 0 ? sums[2] / sums[3] : 0.0;
        }
        if (ctx->cache.on) {
            const picvr_cache_counters *c = &ctx->cache.counts;   /* as of the last round */
            st.cache_requests = ctx->cache.requests_issued;
            st.cache_pending = ctx->cache.requests_pending;
            st.cache_bytes = ctx->cache.entries.size + ctx->cache.nodes.size + ctx->cache.refs.size +
                             ctx->cache.counters.size + ctx->cache.requests.size + ctx->cache.prebuilt_nodes.size +
                             ctx->cache.superpixels.size + ctx->image.lookup_queue.size;
            st.cache_entries = c->entry_count < ctx->cache.cfg.max_entries ? c->entry_count : ctx->cache.cfg.max_entries;
            st.cache_nodes = c->node_count < ctx->cache.cfg.max_nodes ? c->node_count : ctx->cache.cfg.max_nodes;
            st.cache_refs = c->ref_count < ctx->cache.cfg.max_refs ? c->ref_count : ctx->cache.cfg.max_refs;
            st.cache_full = c->full;
            st.cache_refs_per_entry = st.cache_entries ? (double)st.cache_refs / st.cache_entries : 0.0;
            st.cache_entries_capped = c->capped < st.cache_entries ? c->capped : st.cache_entries;
            /* each round of a point: 128 samples */
            st.cache_samples = ctx->cache.point_rounds * 128u;
            st.cache_samples_truncated =
                ctx->cache.truncated < st.cache_samples ? ctx->cache.truncated : st.cache_samples;
            st.cache_lookups_cut = ctx->cache.lookups_cut;
            st.cache_lookups_spilled = ctx->cache.lookups_spilled;
            st.cache_hit_rate = ctx->sched.hit_rate;
        }
        st.cache_max_samples = ctx->cache.cfg.max_samples;
        picvr_sched_shares(ctx, &st);
        st.iterations = ctx->image.block_total ? (uint32_t)(ctx->image.block_samples / ctx->image.block_total) : 0;
        st.elapsed_ms = ctx->image.elapsed_ms;
        double samples = st.iterations_mean * ctx->scene.camera.width * ctx->scene.camera.height;
        st.samples_per_second = ctx->image.elapsed_ms > 0.0 ? samples / (ctx->image.elapsed_ms * 1e-3) : 0.0;
        ctx->results.stats = st;
        ctx->results.valid = 1;
    }
    *out = ctx->results.stats;
    out->validation_messages = ctx->vk.validation_messages;
    out->pipeline_variants = 0;
    for (int p = 0; p < 3; p++)
        for (uint32_t i = 0; i < PICVR_VARIANT_SLOTS; i++) out->pipeline_variants += ctx->pipes.variants[p][i].pipe[PICVR_KERNEL_MAIN] != VK_NULL_HANDLE;
    out->validation_enabled = (uint32_t)ctx->vk.validation_enabled;
    out->width = ctx->scene.has_camera ? ctx->scene.camera.width : 0;
    out->height = ctx->scene.has_camera ? ctx->scene.camera.height : 0;
    snprintf(out->device_name, sizeof out->device_name, "%s", ctx->vk.props.deviceName);
    out->device_type = picvr_device_type_of(ctx->vk.props.deviceType);
    return PICVR_OK;
}
