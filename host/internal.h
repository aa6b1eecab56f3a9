/* host/internal.h - what every part of picvr's implementation shares: the limits and
 * sizes the host mirrors from the shaders, the host copies of the shaders' uniform and
 * buffer layouts (`make check-layout` compares them with glslang's reflection), and the
 * context, grouped as the architecture is (ARCHITECTURE.md): device and pipelines;
 * scene; image and accumulation; cache; scheduler and rounds; readback and stats.
 * Included once, by picvr_vk.c, before the parts in host/; not a public header. */
#ifndef PICVR_INTERNAL_H
#define PICVR_INTERNAL_H

#include "picvr.h"
#include "picvr_shaders.h"

#include <vulkan/vulkan.h>

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#if defined(__unix__) || defined(__APPLE__)
#include <sys/time.h>
#include <unistd.h>
#endif
/* Pipelines are made on several threads where POSIX threads exist (host/pipelines.c);
   elsewhere on the calling thread alone. */
#if defined(_POSIX_THREADS) && _POSIX_THREADS > 0
#include <pthread.h>
#define PICVR_THREADS 1
#else
#define PICVR_THREADS 0
#endif
#define PICVR_MAX_COMPILE_THREADS 16u

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
#define PICVR_CONTROL_FRACTION 0.25      /* residual ratio tracking where at least this fraction
                                      of the bricks with medium have a control */
#define PICVR_EQ_FALLOFF 25.0            /* equiangular sampling serves lights whose 1/d^2 varies
                                      more than this across the volume (host/lights.c) */

/* Sizes of the shaders' buffer elements (std430), mirrored here; `make check-layout`
   (part of `make test`) compares them with glslang's reflection of the shaders. */
#define PICVR_CACHE_NODE_BYTES 16u       /* struct Node */
#define PICVR_CACHE_REF_BYTES 8u         /* struct Ref */
#define PICVR_CACHE_REQUEST_BYTES 32u    /* struct Request */
#define PICVR_CACHE_ENTRY_BYTES 144u     /* struct Entry */
#define PICVR_CACHE_MS_LANE_SAMPLES 8u   /* multiply scattered samples an invocation of
                                            creation takes per round (MS_LANE_SAMPLES) */
#define PICVR_CACHE_MOMENT_BYTES 16u     /* an entry's first moment and sample count
                                            (CacheMoments; multiply scattered caches) */

/* Eq. 5's sample cap (cache.max_samples; its limits PICVR_CACHE_MAX_SAMPLES and
   PICVR_CACHE_MAX_SAMPLES_CPU are in picvr.h): rounds of the 128-thread creation
   workgroup (shaders/cache_create.comp, CREATE_MAX_ROUNDS).  On a CPU device at most 6 rounds:
   llvmpipe silently truncates an invocation's loops past 65535 iterations, and 6 rounds
   x 7 points x 2 transmittance estimates x (640 pooled comb steps + 16 orders) = 55104,
   plus the light loops (the budget is spelled out in cache_create.comp). */
#define PICVR_CACHE_CREATE_GROUP 128u
#define PICVR_CACHE_DEFAULT_SAMPLES 768u
/* cache.probe_fraction's default (picvr.h; shaders/cache_blend.glsl) */
#define PICVR_CACHE_DEFAULT_PROBE 0.125f
#define PICVR_ROUND_READBACK_BYTES (sizeof(picvr_cache_counters) + 32)

/* The rendering procedure's event queues (shaders/render.glsl), one buffer each: a
   head (one uvec4: indirect dispatch, count), then one event of EVENT_WORDS words per
   pixel; the event kernels run EVENT_GROUP threads per workgroup. */
#define PICVR_EVENT_HEAD_BYTES 16u
#define PICVR_EVENT_WORDS 3u
#define PICVR_EVENT_GROUP 128u

enum { PICVR_PROC_CREATE, PICVR_PROC_UPDATE, PICVR_PROC_RENDER };

/* Pipeline variants.  The kernels' specialization constants (shaders/specialization.glsl)
   compile out what the scene does not use; the key of a procedure's variant holds those
   that vary with the scene (picvr_variant_key).  Each procedure keeps up to
   VARIANT_SLOTS variants, made by the first step that needs one; a new one replaces
   the least recently used. */
#define PICVR_VARIANT_SLOTS 8u
#define PICVR_KEY_PHASE_MIS 1u      /* USE_PHASE_MIS */
#define PICVR_KEY_FINE 2u           /* USE_FINE */
#define PICVR_KEY_DEBUG_VIEW 4u     /* USE_DEBUG_VIEW */
#define PICVR_KEY_MONO_SHIFT 3u     /* MONO_CHANNEL: 2 bits, 3 = colours differ */
#define PICVR_KEY_EQUIANGULAR 32u   /* USE_EQUIANGULAR */
#define PICVR_KEY_RESIDUAL 64u      /* USE_RESIDUAL */
#define PICVR_KEY_QMC 128u          /* USE_QMC */
#define PICVR_KEY_BOUNCES 256u      /* USE_BOUNCES */
#define PICVR_KEY_HG 512u           /* USE_HG */
#define PICVR_KEY_ENV_MAP 1024u     /* USE_ENV_MAP */
#define PICVR_KEY_REUSE 2048u       /* USE_REUSE */
#define PICVR_KEY_CLIP 4096u        /* USE_CLIP */
#define PICVR_KEY_PLAIN 8192u       /* PICVR_CACHE_AUTO's plain rounds: the plain tracking module */
#define PICVR_KEY_LOOKUP_SHIFT 14u  /* LOOKUP_EVENT - 1: 3 bits (render_shade_cache.comp) */
#define PICVR_KEY_FORCED 131072u    /* USE_FORCED (bit 17, past LOOKUP_EVENT's three) */
#define PICVR_KEY_MEASURE 262144u   /* USE_MEASURE */
#define PICVR_KEY_RAY_MARCHING 524288u /* USE_RAY_MARCHING */
/* The specialization constants' ids: PICVR_SPEC_<name> is the constant_id of <name> in
   shaders/specialization.glsl (`make check-layout` compares the two lists). */
enum {
    PICVR_SPEC_USE_PHASE_MIS = 0,
    PICVR_SPEC_USE_FINE = 1,
    PICVR_SPEC_CREATE_MAX_ROUNDS = 2,
    PICVR_SPEC_USE_DEBUG_VIEW = 3,
    PICVR_SPEC_MONO_CHANNEL = 4,
    PICVR_SPEC_SCREEN_LOCKING = 5,
    PICVR_SPEC_CACHE_MAX_LOOKUP_REFS = 6,
    PICVR_SPEC_USE_EQUIANGULAR = 7,
    PICVR_SPEC_USE_RESIDUAL = 8,
    PICVR_SPEC_USE_QMC = 9,
    PICVR_SPEC_USE_BOUNCES = 10,
    PICVR_SPEC_USE_HG = 11,
    PICVR_SPEC_USE_ENV_MAP = 12,
    PICVR_SPEC_USE_REUSE = 13,
    PICVR_SPEC_USE_CLIP = 14,
    PICVR_SPEC_CACHE_BLEND = 15,
    PICVR_SPEC_CREATE_SAMPLE_STEPS = 16,
    PICVR_SPEC_LOOKUP_EVENT = 17,
    PICVR_SPEC_USE_FORCED = 18,
    PICVR_SPEC_USE_MEASURE = 19,
    PICVR_SPEC_USE_RAY_MARCHING = 20,
    PICVR_SPEC_CONSTANTS            /* their number */
};
/* The multiply scattered cache on a CPU device (llvmpipe's loop cap of 65535 per
   invocation): a creation thread traces one whole path per point and round, so it takes
   at most this many rounds (128 samples per point) and each sample's loops share
   picvr_create_sample_steps of them. */
#define PICVR_CACHE_MS_ROUNDS_CPU 1u
/* The multiply scattered cache's progressive refinement (cache_create.comp, refine_main):
   the share of creation's work packages that refine existing entries while requests
   wait (all of them when none wait), and the flag its dispatch sets in the push
   constant `budget`. */
#define PICVR_REFINE_SHARE 0.5
#define PICVR_REFINE_PASS_DIVISOR 64u   /* picvr_step_iterations: entries / this per pass */
#define PICVR_REFINE_FLAG 0x80000000u
/* Clip planes the kernels test: the user's and the six faces of the clip box. */
#define PICVR_GPU_CLIP_PLANES (PICVR_MAX_CLIP_PLANES + 6)

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

/* ---- host mirror of the std140 uniform block in shaders/scene.glsl ---- */
typedef struct picvr_gpu_light {
    float pos[3];
    int32_t type;
    float radiance[3], pmf;
    float edge_u[3], size;
    float edge_v[3], area;
    float cdf, eq_pmf;
    float eq_cdf, unused;
} picvr_gpu_light;

typedef struct picvr_gpu_scene {
    float cam_pos[3], tan_half_fov;
    float cam_fwd[3], aspect;
    float cam_right[4], cam_up[4];
    float box_min[3], density;
    float box_size[3], bound_radius;
    float cell_size[3], min_spacing;
    uint32_t grid[3], light_count;
    uint32_t image[4], dims[4];
    float background[3], background_pmf;
    float value_map[4];
    float gamma, epsilon, delta, update_threshold;
    float radius_min, radius_max;
    uint32_t curvature_limit, medium_model;
    uint32_t max_entries, max_nodes, max_refs, max_requests;
    uint32_t superpixel_side, superpixels_per_row, superpixel_count;
    float probe_fraction;            /* 0 unless the blend is on (shaders/cache_blend.glsl) */
    uint32_t debug_view, view_unused[3];
    float light_log_k[3], mono_channel;
    uint32_t max_bounces;
    float back_g, back_weight;
    uint32_t vertex_cost;
    uint32_t env_w, env_h;
    float forced_pmf;                /* strategy B's forced share (host/lights.c) */
    float env_unused1;
    picvr_gpu_light lights[PICVR_MAX_LIGHTS];
    float env_basis[3][4];
    float clip[PICVR_GPU_CLIP_PLANES][4];
    uint32_t clip_count, clip_unused[3];
} picvr_gpu_scene;

/* Sparse table of the opacity column: level k holds the max (tf_rm) or the min (tf_rmin)
   over 2^k entries. */
typedef struct picvr_range_table { float level[13][PICVR_TF_SIZE]; } picvr_range_table;

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
    uint32_t routed;             /* events the blend sent to plain shading unlooked, this round */
    uint32_t probes;             /* probes whose gain was counted, this round */
    uint32_t gain_lo, gain_hi;   /* their gain (2^-16 units, 64 bits), this round */
} picvr_cache_counters;

/* PICVR_CACHE_AUTO: what a cached and a plain round cost and what a hit gains, from
   which each round is chosen cached or plain (host/schedule.c, picvr_auto_choose). */
typedef struct picvr_auto {
    int on;
    double cost[2];                  /* device ms per block, all procedures: [0] plain, [1] cached; 0: unmeasured */
    uint32_t measured[2];            /* rounds that entered cost[] */
    double render_cost[2];           /* the rendering procedure's device ms per block, per kind */
    double served;                   /* fraction of a cached round's scatter events a hit served */
    double gain;                     /* mean gain of a hit (shaders/cache_blend.glsl, count_gain) */
    double routed;                   /* fraction of the lookup's events the blend routed (any cached context) */
    int cached_ready;                /* the cached kind's pipelines are selected (picvr_ready_cached) */
    double compile_ms;               /* the longest a plain rendering variant took to make */
    uint32_t plain_rounds;           /* plain rounds run, the first (pipeline compilation) included */
    double first_wall_ms;            /* wall time of the first plain round */
    double plain_wall_ms;            /* wall time of the plain rounds after it (sum and moving average) */
    double plain_round_ms;
    double time_ms[2];               /* device time of each kind over the last PICVR_AUTO_WINDOW rounds
                                        (exponentially weighted) */
} picvr_auto;
#define PICVR_AUTO_WARM 2u            /* rounds of each kind measured before the choice is by efficiency */
#define PICVR_AUTO_EXPLORE 0.0625     /* share of device time the less efficient kind keeps */
#define PICVR_AUTO_DEFER 40.0         /* the first cached round waits for this many compile times of plain rendering */
#define PICVR_AUTO_WINDOW 200.0       /* rounds (about 10 s) over which the shares of time are kept */
#define PICVR_AUTO_MIN_VARIANCE 0.05  /* cached sample variance over plain's is taken >= this */

/* PICVR_DISTANCE_AUTO: what a round of each kind (0: MIS, 1: the forced point) costs and
   how far its samples spread, from which the kind that renders is chosen (host/schedule.c,
   picvr_dauto_account). */
typedef struct picvr_dauto {
    int on;                          /* measuring: AUTO, a forced share, the cache off (picvr_dauto_update) */
    int forced;                      /* the kind that adds to the image */
    double cost[2];                  /* device ms per block; 0: unmeasured */
    double spread_sum[2];            /* variance per sample times samples, in the image's units
                                        (render.glsl, measure_spread, unscaled): over every measured round */
    double spread_count[2];          /* the samples measured into spread_sum */
    uint32_t measured[2];            /* rounds that entered spread_sum */
    double time_ms[2];               /* device time of each kind, exponentially weighted (PICVR_AUTO_WINDOW) */
    float scale;                     /* the spread's scale: 1 / the image's mean luminance; 0: none */
    uint32_t scale_age;              /* rounds since scale was measured; 0: never */
    int restart;                     /* clear the image before the next round (a switch that pays it) */
    uint32_t rounds;                 /* rounds accounted */
    int forced_ready;                /* the forced kind's variant is selected (picvr_ready_forced) */
} picvr_dauto;
#define PICVR_ROUND_FORCED 1u         /* the forced kind's variant renders (host only) */
#define PICVR_ROUND_MEASURE 2u        /* shaders/render.glsl's ROUND_* flags */
#define PICVR_ROUND_PROBE 4u
#define PICVR_ROUND_KEEP 8u
#define PICVR_DAUTO_WARM 2u           /* rounds of each kind measured before the choice is by efficiency */
#define PICVR_DAUTO_EXPLORE 0.01     /* share of device time the kind not chosen keeps, in probes */
#define PICVR_DAUTO_MEASURE_EVERY 4u  /* the chosen kind's rounds measured, once warm: one in this many */
#define PICVR_DAUTO_SWITCH 1.25       /* efficiency ratio beyond which the choice changes */
#define PICVR_DAUTO_SCALE_ROUNDS 64u  /* rounds between measurements of the scale */

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
#if PICVR_THREADS
    /* the validation callback may run on the threads that make pipelines
       (host/pipelines.c): its count and the log are taken under this lock */
    pthread_mutex_t message_lock;
    int message_lock_ready;
#endif
    int lost;                        /* VK_ERROR_DEVICE_LOST seen: every call refuses */
    VkCommandPool cmd_pool;
    VkCommandBuffer cmd;             /* the one command buffer: record, submit, wait */
    VkFence fence;
    VkFormat float_volume_format;    /* R32_SFLOAT, or R16_UNORM where it cannot filter */
    VkDeviceSize max_volume_bytes;   /* largest volume image the device can hold; 0: unknown */
} picvr_device;

/* Shader modules, pipelines and the one descriptor set (host/pipelines.c). */
/* Pipelines made in parallel (host/pipelines.c, picvr_make_pipelines): one
   vkCreateComputePipelines call per job, taken by the next free thread. */
typedef struct picvr_pipeline_job {
    VkComputePipelineCreateInfo ci;
    VkPipeline pipe;
    VkResult result;
} picvr_pipeline_job;

typedef struct picvr_pipeline_batch {
    VkDevice device;
    picvr_pipeline_job *job;
    uint32_t n, next;
    int threaded;                    /* lock initialized: helpers take jobs too */
#if PICVR_THREADS
    pthread_mutex_t lock;
#endif
} picvr_pipeline_batch;

/* One variant to make: its kernels' modules and its specialization constants, which
   the batch's create infos point at (so it stays put until the batch is made). */
typedef struct picvr_variant_build {
    uint32_t value[PICVR_SPEC_CONSTANTS];
    VkSpecializationMapEntry entry[PICVR_SPEC_CONSTANTS];
    VkSpecializationInfo spec;
    VkShaderModule mod[PICVR_KERNELS];
    VkShaderModule own[PICVR_KERNELS];   /* modules made for this variant alone (pruned,
                                            host/spirv.c), destroyed once it is made */
} picvr_variant_build;

/* A variant made on a thread of its own while the steps go on (PICVR_DISTANCE_AUTO's
   forced kind before its first probe: host/pipelines.c, picvr_probe_forced).  running:
   the thread was started and not yet joined; done (under lock): it has finished; valid:
   pipe holds the variant of (proc, key), not yet in a slot. */
typedef struct picvr_async_variant {
    int running, valid;
    int proc;
    uint32_t key;
    picvr_variant_build build;
    picvr_pipeline_job job[PICVR_KERNELS];
    int kernel[PICVR_KERNELS];       /* job i makes kernel[i] */
    picvr_pipeline_batch batch;
    VkPipeline pipe[PICVR_KERNELS];
#if PICVR_THREADS
    int done;
    pthread_t thread;
    pthread_mutex_t lock;
#endif
} picvr_async_variant;

#define PICVR_MODULES 8u              /* the procedures' kernels: track (two), shade (two), lookup, create, update */
typedef struct picvr_pipelines {
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout, stats_layout;
    VkDescriptorPool desc_pool;
    VkDescriptorSet set;
    int descriptors_dirty;           /* a bound buffer or image changed */
    VkShaderModule track_module, shade_module, lookup_module; /* the rendering kernels; lookup: cached */
    VkShaderModule shade_cache_module;   /* cached: shading that looks up at a later event */
    VkShaderModule plain_track_module; /* PICVR_CACHE_AUTO's plain rounds (VK_NULL_HANDLE otherwise) */
    VkShaderModule stats_module, create_module, update_module, rebuild_module;
    VkShaderModule select_module, priority_module;
    struct {                         /* the procedures' kernels above: the SPIR-V each was made from */
        VkShaderModule mod;
        const uint32_t *code;
        size_t size;
    } code[PICVR_MODULES];
    uint32_t codes;
    VkPipeline select_pipe, priority_pipe; /* the rendering queue; priority_pipe only with priorities */
    VkPipeline stats_pipe, rebuild_pipe;
    picvr_variant_slot variants[3][PICVR_VARIANT_SLOTS]; /* PROC_*: the variants made so far */
    uint32_t variant_clock;          /* ticks once per step: the slots' last use */
    uint32_t current_slot[3];        /* PROC_*: the slot this step's rounds dispatch */
    uint32_t plain_slot;             /* PICVR_CACHE_AUTO: the rendering slot of its plain rounds */
    uint32_t forced_slot;            /* PICVR_DISTANCE_AUTO: the rendering slot of the forced kind */
    picvr_async_variant async;       /* a variant being made beside the steps */
    VkSampler linear_sampler;
} picvr_pipelines;

/* What is rendered: volume, transfer function, lights and background, scattering,
   clipping, camera (host/volume.c, transfer.c, lights.c, environment.c, scattering.c,
   clip.c, camera.c), and their uniform block. */
typedef struct picvr_scene {
    picvr_gpu_scene gpu;             /* the uniform block as the kernels read it */
    picvr_buffer ubo;                /* persistently mapped copy of gpu */
    int has_volume, has_camera;
    picvr_image volume;
    picvr_buffer majorant;           /* majorant grid, then the empty-space distances */
    uint32_t dims[3];
    float spacing[3];
    uint32_t grid[3];
    float *brick_min, *brick_max;    /* normalized data range per brick, with apron */
    int use_fine;                    /* some brick needs voxel-level majorants */
    picvr_image tf_image;
    picvr_buffer tf_staging;
    picvr_buffer tf_range_max;       /* sparse table of the opacity column (fine majorants) */
    float tf_table[PICVR_TF_SIZE * 4];
    picvr_range_table *tf_rm;
    picvr_range_table *tf_rmin;        /* the same table of minima (host only: the minorants) */
    float density;
    int use_phase_mis;               /* some light or the background needs MIS */
    int use_equiangular;             /* some light is served by equiangular sampling */
    int use_forced;                  /* gpu.forced_pmf > 0: camera rays' forced point */
    int auto_rm;                     /* PICVR_DISTANCE_AUTO's second kind is ray-marched
                                        transmittance (host/lights.c) */
    int use_control;                 /* enough bricks have a positive minorant for residual
                                        ratio tracking (host/majorant.c) */
    picvr_scattering scattering;     /* as set (picvr_set_scattering) */
    int tf_has_g;                    /* some transfer-function point has g != 0 */
    picvr_buffer tf_g;               /* g per table entry (binding 18), or a placeholder */
    picvr_buffer env;                /* the environment map's texels and CDFs (binding 19),
                                        or a placeholder (host/environment.c) */
    int use_env;                     /* the background is a map of more than one texel */
    float env_rotation;              /* picvr_background.rotation (radians about world +y) */
    picvr_camera camera;             /* as set, in world space */
    /* The volume's placement: world = rot * local + shift, rot orthonormal (rows: world
       axes in the volume's frame as columns of picvr_volume_desc.direction).  The
       kernels work in the volume's own frame (box centred at 0, axis-aligned); every
       world-space input is mapped into it when packed (host/volume.c). */
    float rot[9], shift[3];
    int reflected;                   /* det(rot) = -1 */
    picvr_light lights[PICVR_MAX_LIGHTS];   /* as set, in world space */
    uint32_t light_count;
    picvr_clip clip;                 /* as set, in world space */
} picvr_scene;

/* The image: accumulation planes, the rendering procedure's queues, block order
   (host/image.c). */
typedef struct picvr_image_state {
    picvr_buffer planes[3];          /* mean rgba, Kahan terms, (lum mean, M2, n, bad) */
    picvr_buffer depth;              /* binding 20: per pixel (mean depth of its scatter
                                        events, their count) with temporal reuse, else a
                                        placeholder */
    picvr_buffer previous[4];        /* temporal reuse: the three planes and the depth of
                                        the view before the last camera move, and */
    picvr_buffer landing;            /* per pixel the nearest distance landing there and the
                                        lowest old index at it (made at
                                        the first reprojection, host/reproject.c) */
    int depth_valid;                 /* the depth plane holds every sample since the reset */
    int has_samples;                 /* some pixel holds a sample (rendered or moved there) */
    picvr_buffer render_queue;       /* header + one uvec4 per block (shaders/queue.glsl) */
    picvr_buffer shade_queue;        /* the rendering procedure's event queues (shaders/render.glsl): */
    picvr_buffer lookup_queue;       /* for shading, and with the cache for the lookup */
    picvr_buffer blend;              /* binding 21: per pixel the sums of the consistent
                                        blend (16 bytes; a placeholder with it off) */
    uint32_t block_total;            /* 16x8 blocks of the image */
    uint32_t block_cursor;           /* position k in the round-robin order (k * stride) mod B */
    uint32_t block_stride;           /* coprime with block_total, near block_total / golden ratio */
    uint64_t block_samples;          /* blocks rendered since the accumulation was reset */
    uint32_t first_pass_blocks;      /* blocks of the first round-robin pass since then (from
                                        cursor 0, no priority dispatch before): the pass is
                                        complete, every pixel sampled, at block_total */
    int priority_used;               /* a priority dispatch since then (scheduler.frames
                                        then restarts the first pass from cursor 0) */
    uint64_t scatter_events;         /* camera paths' scatter events since then */
    double elapsed_ms;               /* wall time of the rounds since then */
} picvr_image_state;

/* The irradiance cache, §4-5 (host/cache.c); nothing allocated when it is off. */
typedef struct picvr_cache {
    picvr_cache_config cfg;          /* resolved: no zero fields */
    int on;
    picvr_buffer entries, nodes, refs, counters, requests;
    picvr_buffer moments;            /* the entries' first moments: max_entries of them with
                                        bounces (picvr_cache_fit_moments), else a placeholder */
    picvr_buffer prebuilt_nodes;     /* the pre-built top of the octree, copied on rebuild */
    picvr_buffer superpixels;        /* screen-space locking: locks + ray/miss counters */
    uint32_t superpixel_count;
    uint32_t prebuilt;               /* nodes of the pre-built top of the octree */
    double since_rebuild_ms;
    uint32_t requests_issued;        /* by the rounds of the last step */
    uint32_t requests_pending;       /* valid requests the last round queued (each holds a lock) */
    uint32_t refine_cursor;          /* the next entry to refine (multiply scattered cache) */
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
    picvr_auto auto_mode;            /* PICVR_CACHE_AUTO's economics (host/schedule.c) */
    picvr_dauto dauto;               /* PICVR_DISTANCE_AUTO's (host/schedule.c) */
} picvr_sched;

/* Submissions of rounds and their device timestamps (host/rounds.c). */
typedef struct picvr_rounds {
    uint32_t count;                  /* rounds since creation: keys the cache procedures' RNG */
    picvr_buffer readback;           /* cache counters and rendered-block count of a round */
    VkQueryPool timestamps;          /* PICVR_ROUND_TIMESTAMPS; VK_NULL_HANDLE: none */
    double timestamp_ns;             /* nanoseconds per timestamp tick */
    uint64_t timestamp_mask;         /* valid bits */
    double kernel_ms[2][3];          /* [plain, cached round][tracking, lookup, shading]: device ms per
                                        block of the round's first rendering dispatch (moving average) */
} picvr_rounds;

/* What one round does. */
typedef struct picvr_round_plan {
    uint32_t render_blocks;   /* blocks to render (more than the image has: several dispatches) */
    int whole_passes;         /* round-robin from the cursor, priorities ignored
                                 (picvr_step_iterations; the first pass of scheduler.frames) */
    uint32_t create_budget;   /* queued requests that become entries this round */
    uint32_t request_cap;     /* requests this round's rendering may queue */
    uint32_t update_groups;   /* update work packages */
    uint32_t refine_groups;   /* entries refined (multiply scattered cache), creation's packages */
    int rebuild;              /* rebuild the octree */
    int plain;                /* PICVR_CACHE_AUTO: a plain round (no cache procedure, no lookup) */
    uint32_t render_flags;    /* the rendering kernels' ROUND_* flags (shaders/render.glsl):
                                 the forced point, PICVR_DISTANCE_AUTO's measure and probe */
} picvr_round_plan;

/* A step begun by picvr_step_begin and not yet ended (host/step.c): its round is
   submitted and the context's command buffer and fence belong to it. */
typedef struct picvr_pending_step {
    int active;
    int field;                       /* the field's image, made by picvr_step_begin itself */
    picvr_round_plan plan;
    uint32_t created;                /* entries its creation may add */
    double t0;                       /* picvr_clock_ms at submission */
} picvr_pending_step;

/* A kernel outside the procedures, with a descriptor set of its own (storage buffers
   only) and 128 bytes of push constants, made at its first use (host/aux_kernel.c). */
typedef struct picvr_aux_kernel {
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkDescriptorPool pool;
    VkDescriptorSet set;
    VkShaderModule module;
    VkPipeline pipe;
} picvr_aux_kernel;

/* picvr_write_image's kernel (the accumulation's plane 0 in, the encoded pixels out) and
   the encoded pixels; made at its first call, so a context that never writes a device
   image holds none of it (host/gpu_image.c). */
typedef struct picvr_target_state {
    picvr_aux_kernel kernel;
    picvr_buffer encoded;
} picvr_target_state;

/* The light field (host/field.c, shaders/field*.comp): made at the first step of a
   context in PICVR_RENDER_FIELD, nothing before.  Its kernels take the main descriptor
   set as set 0 and the field's buffers as set 1 (two sets: the passes alternate which
   field buffer is read and which written). */
enum { PICVR_FIELD_CLASSIFY, PICVR_FIELD_LIGHT, PICVR_FIELD_SCATTER, PICVR_FIELD_VIEW, PICVR_FIELD_RENDER,
       PICVR_FIELD_KERNELS };
#define PICVR_FIELD_BINDINGS 6u
#define PICVR_FIELD_MAX_PASSES 1024u
typedef struct picvr_field {
    int on;                          /* config.field.mode is PICVR_RENDER_FIELD or _FIELD_MC */
    int mc;                          /* PICVR_RENDER_FIELD_MC: Monte Carlo goes on from it */
    int view_changed;                /* the accumulation was cleared or moved since the field
                                        image was made (host/image.c) */
    int dirty;                       /* the scene changed since the field was built */
    int image_dirty;                 /* the image does not show the current field and camera */
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkDescriptorPool pool;
    VkDescriptorSet set[2];          /* set[i]: field[i] read, field[1 - i] written */
    VkShaderModule module[PICVR_FIELD_KERNELS];
    VkPipeline pipe[PICVR_FIELD_KERNELS];
    uint32_t key;                    /* the rendering variant key the pipelines were made for */
    picvr_buffer cells, light_t, field[2], change, view;
    uint32_t n[3];                   /* cells per axis */
    uint32_t lights;                 /* lights light_t holds room for */
    uint32_t current;                /* the field buffer that holds the last pass */
    int warm;                        /* field[current] holds a field of this grid */
    int scattered;                   /* the scene needs the passes (host/field.c,
                                        picvr_field_scattered); else field[] are placeholders */
    uint32_t builds, passes;
    double change_value, build_ms;
} picvr_field;

/* Image readback and statistics (host/readback.c). */
typedef struct picvr_results {
    picvr_buffer readback;           /* one accumulation plane, host visible */
    picvr_buffer partials;           /* the stats kernel's per-workgroup sums */
    int valid;                       /* stats is up to date */
    picvr_stats stats;
} picvr_results;

struct picvr_context {
    picvr_config config;             /* as given to picvr_create, log_level resolved, without
                                        device_name; cache and scheduler as given (their
                                        resolved values: cache.cfg, sched.cfg) */
    picvr_device vk;
    picvr_pipelines pipes;
    picvr_scene scene;
    picvr_image_state image;
    picvr_cache cache;
    picvr_sched sched;
    picvr_rounds rounds;
    picvr_results results;
    picvr_pending_step pending;
    picvr_target_state target;
    picvr_aux_kernel reproject;      /* temporal reuse's kernel (host/reproject.c) */
    picvr_field field;               /* PICVR_RENDER_FIELD (host/field.c) */
};

/* Rule: between picvr_step_begin and picvr_step_end the command buffer, the fence and
   the accumulation belong to the step in flight, so every other call refuses. */
#define PICVR_REFUSE_IF_BUSY(ctx) do { if ((ctx)->pending.active) return PICVR_ERROR_BUSY; } while (0)

/* Zeroes a Vulkan struct and sets its sType: C and C++ alike, and no
   missing-initializer warning as `= {sType}` draws. */
#define PICVR_VK_INIT(var, stype) (memset(&(var), 0, sizeof(var)), (var).sType = (stype))
#define PICVR_VK_TRY(ctx, call) do { picvr_status s_ = picvr_vk_status((ctx), (call), #call); if (s_) return s_; } while (0)

/* Binding layout shared by all kernels (see ARCHITECTURE.md): 0 scene UBO, 1 volume,
   2 transfer function, 3 majorant grid, 4-6 accumulation planes, 7 stats partials,
   8 opacity range-max table, 9-13 cache entries, nodes, refs, counters, requests,
   14 superpixels (screen-space locking), 15 the rendering queue, 16 and 17 the rendering
   procedure's event queues for shading and for the cache lookup, 18 the phase function's
   g per transfer-function entry, 19 the environment map, 20 the depth plane (temporal
   reuse), 21 the consistent blend's per-pixel sums (cache on), 22 the entries' first
   moments (cache on; real with bounces). */
#define PICVR_NUM_BINDINGS 23
#define PICVR_PLACEHOLDER_BYTES 16u      /* bindings 18-22 when the scene needs none */
#define PICVR_CACHE_PREBUILT_MAX_DEPTH 4u  /* levels of the octree's pre-built top (§4.4) */
#define PICVR_CACHE_NODE_RADII 1.0f     /* as in shaders/cache.glsl (insertion_depth) */

/* picvr_step_iterations without cache.max_requests: one request per this many pixels
   per pass (a build-time knob). */
#ifndef PICVR_CACHE_PIXELS_PER_REQUEST
#define PICVR_CACHE_PIXELS_PER_REQUEST 4096u
#endif

/* Timestamps of a round: start, after creation, after rebuild, after update, end. */
#define PICVR_ROUND_TIMESTAMPS 9u   /* 0-4 around the procedures, 5-8 around the first rendering dispatch's kernels */


/* What the §6 plan of a round reads of the cache and the image. */
typedef struct picvr_plan_inputs {
    int cache_on;
    uint32_t requests_pending;    /* requests the last round queued: creation's work */
    uint32_t refinable;           /* entries refinement may take (0: no refinement) */
    uint32_t max_requests;
    int rebuild_due;              /* the octree rebuild interval has passed */
    uint32_t block_total;
} picvr_plan_inputs;

/* The normalization v' = clamp(v * scale + offset, 0, 1) applied to raw voxel values;
   the shader applies the same to the texture's value (UNORM formats read v / max). */
typedef struct picvr_value_map { double lo, hi; } picvr_value_map;

#endif /* PICVR_INTERNAL_H */
