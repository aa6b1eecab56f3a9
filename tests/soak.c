/* soak.c - `make soak`: SOAK_SECONDS (the Makefile's default 45) of picvr_step with random camera
 * moves, image-size changes, transfer-function (with phase g), light (with environment
 * maps), scattering (bounces, lobes), scheduler and volume changes, image reads
 * and stats, then checks that memory is flat.  Half the steps are picvr_step_begin /
 * picvr_step_end pairs, polled.
 *
 * Three measures, each taken in the same scene configuration (the same volume and
 * image size) after a warm-up and at the end:
 *   - device memory: live bytes of VkDeviceMemory.  picvr calls vkAllocateMemory and
 *     vkFreeMemory through the loader; this program defines both (symbol interposition:
 *     libpicvr.a is linked into it) and forwards them with dlsym(RTLD_NEXT), so it
 *     counts exactly what picvr holds on any device (lavapipe has no
 *     VK_EXT_memory_budget).  Tolerance: 0 bytes.
 *   - picvr's host heap: live bytes through cfg.allocator hooks.  Tolerance: 0 bytes.
 *   - process RSS (/proc/self/statm), which on lavapipe also holds the "device" memory
 *     and the driver's own caches, read after malloc_trim(0) so that pages glibc keeps
 *     free in its arenas (a driver compile or a first dispatch on a worker thread
 *     leaves tens of MiB) are not counted.  Tolerance: 16 MiB growth, for fragmentation
 *     (the thresholds are stated at the end of the run; a real leak per step or per
 *     change would add far more: hundreds of steps and changes run).
 * Any status other than PICVR_OK, a non-finite pixel or stat fails the run.
 * Usage: picvr-soak [seconds] [none|object|screen] [paths]  (paths: bounces, phase lobes
 * and environment maps on for the run)
 */
#define _GNU_SOURCE
#include "picvr.h"

#include <dlfcn.h>
#include <malloc.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <vulkan/vulkan.h>

/* ---- device memory accounting (interposed Vulkan entry points) ---------------------- */

typedef struct { VkDeviceMemory mem; VkDeviceSize size; } mem_rec;
static mem_rec g_recs[4096];
static size_t g_nrecs;
static unsigned long long g_dev_live, g_dev_allocs, g_dev_frees;
static pthread_mutex_t g_lock = PTHREAD_MUTEX_INITIALIZER;

VKAPI_ATTR VkResult VKAPI_CALL vkAllocateMemory(VkDevice device, const VkMemoryAllocateInfo *info,
                                                const VkAllocationCallbacks *cb, VkDeviceMemory *mem) {
    static PFN_vkAllocateMemory real;
    if (!real) real = (PFN_vkAllocateMemory)dlsym(RTLD_NEXT, "vkAllocateMemory");
    VkResult r = real(device, info, cb, mem);
    if (r == VK_SUCCESS) {
        pthread_mutex_lock(&g_lock);
        if (g_nrecs < sizeof g_recs / sizeof g_recs[0]) g_recs[g_nrecs++] = (mem_rec){*mem, info->allocationSize};
        else { fprintf(stderr, "soak: more than 4096 live allocations\n"); exit(2); }
        g_dev_live += info->allocationSize;
        g_dev_allocs++;
        pthread_mutex_unlock(&g_lock);
    }
    return r;
}

VKAPI_ATTR void VKAPI_CALL vkFreeMemory(VkDevice device, VkDeviceMemory mem, const VkAllocationCallbacks *cb) {
    static PFN_vkFreeMemory real;
    if (!real) real = (PFN_vkFreeMemory)dlsym(RTLD_NEXT, "vkFreeMemory");
    if (mem != VK_NULL_HANDLE) {
        pthread_mutex_lock(&g_lock);
        for (size_t i = 0; i < g_nrecs; i++)
            if (g_recs[i].mem == mem) {
                g_dev_live -= g_recs[i].size;
                g_recs[i] = g_recs[--g_nrecs];
                g_dev_frees++;
                break;
            }
        pthread_mutex_unlock(&g_lock);
    }
    real(device, mem, cb);
}

/* Pipeline compiles, counted the same way: each is a driver compile whose memory
   lavapipe keeps in part after the pipeline is destroyed, so RSS is compared only
   across a stretch with no compile (see main).  A pipeline's first dispatch grows the
   driver's memory too (its worker threads' state for that shader), and it may come
   iterations after the compile (one made at the end of the warm-up and first bound
   after the reference measurement grows RSS in a stretch with no compile).  So first
   binds are counted like compiles. */
static unsigned long long g_compiles;        /* pipelines whose compile began */
static unsigned long long g_compiles_done;   /* ... and ended (picvr compiles on a thread) */
static unsigned long long g_first_binds;     /* pipelines bound for the first time */
static VkPipeline g_unbound[1024];           /* made, not yet bound, not destroyed */
static size_t g_nunbound;

/* Removes p from the unbound pipelines; 1 if it was there.  Caller holds g_lock. */
static int take_unbound(VkPipeline p) {
    for (size_t i = 0; i < g_nunbound; i++)
        if (g_unbound[i] == p) {
            g_unbound[i] = g_unbound[--g_nunbound];
            return 1;
        }
    return 0;
}

VKAPI_ATTR VkResult VKAPI_CALL vkCreateComputePipelines(VkDevice device, VkPipelineCache cache, uint32_t n,
                                                        const VkComputePipelineCreateInfo *infos,
                                                        const VkAllocationCallbacks *cb, VkPipeline *out) {
    static PFN_vkCreateComputePipelines real;
    if (!real) real = (PFN_vkCreateComputePipelines)dlsym(RTLD_NEXT, "vkCreateComputePipelines");
    pthread_mutex_lock(&g_lock);
    g_compiles += n;
    pthread_mutex_unlock(&g_lock);
    VkResult r = real(device, cache, n, infos, cb, out);
    pthread_mutex_lock(&g_lock);
    g_compiles_done += n;
    for (uint32_t i = 0; r == VK_SUCCESS && i < n; i++) {
        if (g_nunbound == sizeof g_unbound / sizeof g_unbound[0]) {
            fprintf(stderr, "soak: more than 1024 pipelines never bound\n");
            exit(2);
        }
        g_unbound[g_nunbound++] = out[i];
    }
    pthread_mutex_unlock(&g_lock);
    return r;
}

VKAPI_ATTR void VKAPI_CALL vkCmdBindPipeline(VkCommandBuffer cmd, VkPipelineBindPoint point, VkPipeline p) {
    static PFN_vkCmdBindPipeline real;
    if (!real) real = (PFN_vkCmdBindPipeline)dlsym(RTLD_NEXT, "vkCmdBindPipeline");
    pthread_mutex_lock(&g_lock);
    g_first_binds += (unsigned long long)take_unbound(p);
    pthread_mutex_unlock(&g_lock);
    real(cmd, point, p);
}

VKAPI_ATTR void VKAPI_CALL vkDestroyPipeline(VkDevice device, VkPipeline p, const VkAllocationCallbacks *cb) {
    static PFN_vkDestroyPipeline real;
    if (!real) real = (PFN_vkDestroyPipeline)dlsym(RTLD_NEXT, "vkDestroyPipeline");
    pthread_mutex_lock(&g_lock);
    take_unbound(p);
    pthread_mutex_unlock(&g_lock);
    real(device, p, cb);
}

/* Compiles begun and ended so far, read together; a first bind counts as a compile
   that began and ended (its driver memory grows then). */
static void compile_counts(unsigned long long *begun, unsigned long long *ended) {
    pthread_mutex_lock(&g_lock);
    *begun = g_compiles + g_first_binds;
    *ended = g_compiles_done + g_first_binds;
    pthread_mutex_unlock(&g_lock);
}

/* ---- picvr host heap accounting (allocator hooks) ------------------------------------ */

static long long g_host_live;
typedef union { size_t size; max_align_t align; } hdr;

static void *h_alloc(size_t size, void *user) {
    (void)user;
    hdr *h = malloc(sizeof(hdr) + size);
    if (!h) return NULL;
    h->size = size;
    g_host_live += (long long)size;
    return h + 1;
}
static void h_free(void *p, void *user) {
    (void)user;
    if (!p) return;
    hdr *h = (hdr *)p - 1;
    g_host_live -= (long long)h->size;
    free(h);
}
/* ---- helpers ---------------------------------------------------------------------------- */

static double now_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static long long rss_bytes(void) {
    long long size = 0, res = 0;
    FILE *f = fopen("/proc/self/statm", "r");
    if (!f) return -1;
    if (fscanf(f, "%lld %lld", &size, &res) != 2) res = -1;
    fclose(f);
    return res < 0 ? -1 : res * sysconf(_SC_PAGESIZE);
}

static uint64_t g_rng = 0x9e3779b97f4a7c15ull;
static double rnd(void) {
    uint64_t z = (g_rng += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

#define CHECK(call)                                                                         \
    do {                                                                                    \
        picvr_status s_ = (call);                                                           \
        if (s_ != PICVR_OK) {                                                               \
            fprintf(stderr, "soak: %s failed: %s (line %d)\n", #call, picvr_status_string(s_), __LINE__); \
            exit(1);                                                                        \
        }                                                                                   \
    } while (0)

/* Two volumes: a soft ball with noise (64^3) and an anisotropic slab (48x64x32). */
static uint8_t *make_volume(uint32_t nx, uint32_t ny, uint32_t nz) {
    uint8_t *v = malloc((size_t)nx * ny * nz);
    if (!v) exit(2);
    for (uint32_t z = 0; z < nz; z++)
        for (uint32_t y = 0; y < ny; y++)
            for (uint32_t x = 0; x < nx; x++) {
                double dx = x - nx / 2.0, dy = y - ny / 2.0, dz = z - nz / 2.0;
                double r = sqrt(dx * dx + dy * dy + dz * dz) / (0.45 * nx);
                double val = 255 * (1 - r) + 40 * (rnd() - 0.5);
                v[x + (size_t)nx * (y + (size_t)ny * z)] = (uint8_t)(val < 0 ? 0 : val > 255 ? 255 : val);
            }
    return v;
}

static void upload(picvr_context *ctx, const uint8_t *data, uint32_t nx, uint32_t ny, uint32_t nz) {
    picvr_volume_desc d;
    memset(&d, 0, sizeof d);
    d.dims[0] = nx; d.dims[1] = ny; d.dims[2] = nz;
    d.type = PICVR_VOXEL_UINT8;
    d.data = data;
    CHECK(picvr_upload_volume(ctx, &d));
}

/* The path tracer's features (bounces, an anisotropic phase function, an environment map)
   are on for a whole run (the `paths` argument) or off: each is a pipeline variant, and a
   soak that toggled them would keep meeting new combinations with the other variant
   switches, each compiled by the driver at its first use and evicting another from
   the slots, so the warm-up would never end (docs/robustness.md, "Soak"). */
static int paths_on;

static void random_tf(picvr_context *ctx) {
    picvr_tf_point p[6];
    memset(p, 0, sizeof p);
    uint32_t n = 1 + (uint32_t)(rnd() * 6);
    float v = 0;
    for (uint32_t i = 0; i < n; i++) {
        v += (float)(rnd() * (1.0 - v) * 0.6);
        p[i].value = v;
        for (int c = 0; c < 3; c++) p[i].albedo[c] = (float)rnd();
        p[i].opacity = (float)(rnd() < 0.2 ? 0 : rnd());
        p[i].g = paths_on ? (float)(rnd() * 1.8 - 0.9) : 0.0f;
    }
    CHECK(picvr_set_transfer_function(ctx, p, n, (float)pow(10.0, rnd() * 3 - 1)));
}

static void random_lights(picvr_context *ctx) {
    picvr_light l[4];
    memset(l, 0, sizeof l);
    uint32_t n = (uint32_t)(rnd() * 5);
    for (uint32_t i = 0; i < n; i++) {
        l[i].type = (picvr_light_type)(1 + (int)(rnd() * 4));
        for (int c = 0; c < 3; c++) {
            l[i].color[c] = (float)rnd();
            l[i].position[c] = (float)(rnd() * 160 - 80);
            l[i].direction[c] = (float)(rnd() * 2 - 1);
        }
        l[i].direction[2] += 1.5f; /* never zero */
        l[i].intensity = (float)(rnd() * 20);
        l[i].radius = (float)(1 + rnd() * 10);
        l[i].angular_diameter = (float)(rnd() < 0.3 ? 0 : rnd() * 0.5);
        l[i].edge_u[0] = (float)(2 + rnd() * 10);
        l[i].edge_v[1] = (float)(2 + rnd() * 10);
    }
    picvr_background bg;
    memset(&bg, 0, sizeof bg);
    for (int c = 0; c < 3; c++) bg.color[c] = (float)rnd();
    /* Always a lit background: it keeps phase-function MIS on in every scene, so that the
       variants the run meets (equiangular sampling, fine majorants, residual tracking
       on or off) fit the 8 slots and the warm-up can compile them all: each compile
       after it leaves lavapipe about 1 MiB of RSS that no destroy returns. */
    bg.intensity = (float)(0.05 + rnd());
    static float map[16 * 8 * 3];
    if (paths_on) {   /* an environment map of 2..16 x 1..8 texels, one texel lit at least */
        bg.env_width = 2 + (uint32_t)(rnd() * 15);
        bg.env_height = 1 + (uint32_t)(rnd() * 8);
        for (uint32_t i = 0; i < 3 * bg.env_width * bg.env_height; i++) map[i] = (float)(rnd() < 0.5 ? 0 : rnd() * 4);
        map[0] = 1.0f;
        bg.environment = map;
        bg.env_rotation = (float)(rnd() * 7);
    }
    CHECK(picvr_set_lights(ctx, l, n, &bg));
}

/* With paths_on: 1, 4 or unlimited bounces, a second phase lobe, and a new transfer
   function (with g) and lights (with a map). */
static void random_scattering(picvr_context *ctx) {
    static const uint32_t bounces[3] = {1, 4, PICVR_BOUNCES_UNLIMITED};
    picvr_scattering sc;
    memset(&sc, 0, sizeof sc);
    if (paths_on) {
        sc.max_bounces = bounces[(int)(rnd() * 3) % 3];
        sc.back_g = (float)(rnd() * 1.8 - 0.9);
        sc.back_weight = (float)(0.05 + rnd() * 0.85);
    }
    CHECK(picvr_set_scattering(ctx, &sc));
    random_tf(ctx);
    random_lights(ctx);
}

static const uint32_t SIZES[3][2] = {{64, 64}, {96, 48}, {128, 128}};

static void set_camera(picvr_context *ctx, int size) {
    picvr_camera c;
    memset(&c, 0, sizeof c);
    double th = rnd() * 2 * M_PI, ph = (rnd() - 0.5) * 3.0, r = 50 + rnd() * 100;
    c.position[0] = (float)(r * cos(ph) * cos(th));
    c.position[1] = (float)(r * sin(ph));
    c.position[2] = (float)(r * cos(ph) * sin(th));
    c.target[0] = (float)(rnd() * 20 - 10);
    c.fov_y_degrees = (float)(20 + rnd() * 70);
    c.width = SIZES[size][0];
    c.height = SIZES[size][1];
    CHECK(picvr_set_camera(ctx, &c));
}

/* Random valid scheduler settings (picvr_set_scheduler on a running context). */
static void random_scheduler(picvr_context *ctx) {
    picvr_scheduler_config c;
    memset(&c, 0, sizeof c);
    c.priorities = rnd() < 0.5 ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF;
    c.frames = rnd() < 0.5 ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF;
    c.temporal_reuse = rnd() < 0.5 ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF;   /* camera moves reproject */
    c.reuse_history = (uint32_t)(rnd() * 64);
    c.create_min = (float)(rnd() * 0.3);
    c.create_max = c.create_min + (float)(rnd() * 0.3);
    c.update_min = (float)(rnd() * 0.05);
    c.update_max = c.update_min + (float)(rnd() * 0.05);
    c.rounds_per_second = (float)(5 + rnd() * 35);
    CHECK(picvr_set_scheduler(ctx, rnd() < 0.2 ? NULL : &c));
}

typedef struct { long long rss, host; unsigned long long dev; } sample;

static sample measure(void) {
    sample s;
    malloc_trim(0);   /* free pages of every glibc arena back to the kernel: RSS then counts live memory */
    s.rss = rss_bytes();
    s.host = g_host_live;
    pthread_mutex_lock(&g_lock);
    s.dev = g_dev_live;
    pthread_mutex_unlock(&g_lock);
    return s;
}

int main(int argc, char **argv) {
    double seconds = argc > 1 ? atof(argv[1]) : 120.0;
    if (!(seconds > 0)) seconds = 120.0;
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.allocator.alloc = h_alloc;
    cfg.allocator.free = h_free;
    const char *mode = argc > 2 ? argv[2] : "none";
    cfg.cache.mode = strcmp(mode, "object") == 0 ? PICVR_CACHE_OBJECT_SPACE
                   : strcmp(mode, "screen") == 0 ? PICVR_CACHE_SCREEN_SPACE : PICVR_CACHE_NONE;
    paths_on = argc > 3 && strcmp(argv[3], "paths") == 0;
    double t_start = now_s();
    sample boot = measure();
    picvr_context *ctx;
    CHECK(picvr_create(&cfg, &ctx));

    uint8_t *va = make_volume(64, 64, 64), *vb = make_volume(48, 64, 32);
    float *img = malloc(128 * 128 * 16);
    uint8_t *img8 = malloc(128 * 128 * 4);
    if (!img || !img8) return 2;

    /* The reference configuration, restored before each measurement. */
    /* With paths the reference is a path-traced scene too (g, a second lobe, a map), so
       that it is one of the run's variants rather than one more that would evict one of
       them from the slots at every measurement. */
    const float ref_g = paths_on ? 0.5f : 0.0f;
    const picvr_tf_point ref_tf[2] = {{0.1f, {0.9f, 0.8f, 0.7f}, 0.0f, ref_g}, {0.6f, {0.9f, 0.8f, 0.7f}, 1.0f, ref_g}};
    static const float ref_map[2 * 1 * 3] = {1.0f, 0.9f, 0.8f, 0.2f, 0.3f, 0.4f};
    const picvr_scattering ref_sc = {4, -0.3f, 0.2f};
    picvr_light ref_light;
    memset(&ref_light, 0, sizeof ref_light);
    ref_light.type = PICVR_LIGHT_SPHERE;
    ref_light.position[0] = 80; ref_light.position[1] = 60; ref_light.position[2] = 80;
    ref_light.radius = 10;
    ref_light.color[0] = ref_light.color[1] = ref_light.color[2] = 1;
    ref_light.intensity = 5;
    const picvr_background ref_bg = {{0.4f, 0.5f, 0.7f}, 0.3f, paths_on ? ref_map : NULL, paths_on ? 2u : 0u,
                                     paths_on ? 1u : 0u, 0.0f};
    picvr_camera ref_cam;
    memset(&ref_cam, 0, sizeof ref_cam);
    ref_cam.position[2] = 120;
    ref_cam.width = 128; ref_cam.height = 128;

    unsigned long steps = 0, changes = 0, reads = 0, uploads = 0, iters = 0, nonblocking = 0;
    int cur_vol = 0, size = 0;
    upload(ctx, va, 64, 64, 64);
    CHECK(picvr_set_camera(ctx, &ref_cam));
    if (paths_on) random_scattering(ctx);
    /* The warm-up lasts until the driver has compiled the run's variants: at least a
       quarter of the run (half with paths, whose variants compile slower), then until
       no compile for 10 s, at most three quarters of the run. */
    double warm = paths_on ? 0.5 * seconds : seconds < 80 ? 0.25 * seconds : 20.0;
    double last_compile_t = 0;
    unsigned long long seen_compiles = 0, base_compiles = 0;
    sample base = {0, 0, 0};
    int have_base = 0;
    double next_report = 0, t0 = now_s();
    long long compile_growth = 0;   /* RSS added across the iterations that compiled a pipeline */
    for (;;) {
        /* Rule: an iteration in which the driver compiled a pipeline after the warm-up
           (a variant evicted and made again) has its RSS change set apart: lavapipe keeps
           about 8 MiB of each compile, which no destroy returns (measured: flat between
           compiles, +8 MiB at each).  picvr's own memory is checked exactly above. */
        /* picvr compiles variants on its own thread: an iteration "compiled" when a
           compile began or ended in it, one was under way as it began (the driver's
           memory grows while the compile runs, not when it is counted), or it bound a
           pipeline for the first time (compile_counts) */
        unsigned long long c_begun, c_ended;
        compile_counts(&c_begun, &c_ended);
        int measured_iter = have_base;
        long long rss_iter = measured_iter ? measure().rss : 0;
        double t = now_s() - t0;
        int finishing = t >= seconds;
        if (c_ended + c_begun != seen_compiles) { seen_compiles = c_ended + c_begun; last_compile_t = t; }
        int warmed = t >= warm && ((t - last_compile_t >= 10.0 && c_begun == c_ended) || t >= 0.75 * seconds);
        if ((!have_base && warmed) || finishing) {
            /* the reference configuration: the same volume, TF, lights and image size */
            if (cur_vol != 0) { upload(ctx, va, 64, 64, 64); cur_vol = 0; uploads++; }
            CHECK(picvr_set_transfer_function(ctx, ref_tf, 2, 1.0f));
            CHECK(picvr_set_lights(ctx, &ref_light, 1, &ref_bg));
            CHECK(picvr_set_scattering(ctx, paths_on ? &ref_sc : NULL));
            /* the default scheduler: temporal reuse off, so its buffers (made by the
               first camera move with it on) are not part of one measurement only */
            CHECK(picvr_set_scheduler(ctx, NULL));
            CHECK(picvr_set_camera(ctx, &ref_cam));
            CHECK(picvr_step_iterations(ctx, 2));
            CHECK(picvr_read_rgba32f(ctx, img, 128 * 128 * 16));
            sample s = measure();
            if (!have_base) {
                base = s;
                base_compiles = g_compiles;
                have_base = 1;
                printf("soak: after %.0f s warm-up: RSS %.1f MiB, device memory %.2f MiB, picvr host heap %.1f KiB\n",
                       t, s.rss / 1048576.0, s.dev / 1048576.0, s.host / 1024.0);
            }
            if (finishing) break;
            if (paths_on) random_scattering(ctx);   /* back to the run's kind of scene */
        }
        double a = rnd();
        if (a < 0.35) { set_camera(ctx, (size = (rnd() < 0.2 ? (int)(rnd() * 3) : size))); changes++; }
        else if (a < 0.5) { random_tf(ctx); changes++; }
        else if (a < 0.65) { random_lights(ctx); changes++; }
        else if (a < 0.67) {
            cur_vol ^= 1;
            if (cur_vol) upload(ctx, vb, 48, 64, 32); else upload(ctx, va, 64, 64, 64);
            uploads++;
        } else if (a < 0.69) { CHECK(picvr_reset(ctx)); }
        else if (a < 0.71) { random_scheduler(ctx); changes++; }
        else if (a < 0.75 && paths_on) { random_scattering(ctx); changes++; }
        /* half the steps do not block: begun, polled (every other call is refused
           meanwhile, which must change nothing), ended */
        if (rnd() < 0.5) {
            CHECK(picvr_step(ctx, 20 + rnd() * 60));
        } else {
            CHECK(picvr_step_begin(ctx, 20 + rnd() * 60));
            picvr_status s;
            while ((s = picvr_step_end(ctx, rnd() < 0.5 ? 0 : 1000000)) == PICVR_ERROR_TIMEOUT)
                if (picvr_reset(ctx) != PICVR_ERROR_BUSY) {
                    fprintf(stderr, "soak: a call during a begun step was not refused\n");
                    return 1;
                }
            CHECK(s);
            nonblocking++;
        }
        steps++;
        picvr_stats st;
        CHECK(picvr_get_stats(ctx, &st));
        iters += st.iterations;
        if (!isfinite(st.mean_luminance) || !isfinite(st.est_error) || !isfinite(st.est_rel_error) ||
            !isfinite(st.samples_per_second)) {
            fprintf(stderr, "soak: non-finite stats after %lu steps\n", steps);
            return 1;
        }
        if (rnd() < 0.5) {
            size_t n = (size_t)st.width * st.height;
            if (rnd() < 0.5) {
                CHECK(picvr_read_rgba32f(ctx, img, 128 * 128 * 16));
                for (size_t i = 0; i < 4 * n; i++)
                    if (!isfinite(img[i]) || img[i] < 0) {
                        fprintf(stderr, "soak: pixel value %g after %lu steps\n", (double)img[i], steps);
                        return 1;
                    }
            } else {
                CHECK(picvr_read_rgba8(ctx, img8, 128 * 128 * 4, (float)(0.5 + rnd())));
            }
            reads++;
        }
        unsigned long long e_begun, e_ended;
        compile_counts(&e_begun, &e_ended);
        if (measured_iter && (e_begun != c_begun || e_ended != c_ended || c_begun != c_ended))
            compile_growth += measure().rss - rss_iter;
        if (t >= next_report) {
            sample s = measure();
            printf("soak: t %5.0f s  steps %6lu  RSS %7.1f MiB  device %7.2f MiB  picvr heap %8.1f KiB  compiles %llu\n", t, steps,
                   s.rss / 1048576.0, s.dev / 1048576.0, s.host / 1024.0, g_compiles);
            fflush(stdout);
            next_report += 10;
        }
    }
    sample end = measure();
    double total = now_s() - t0;
    picvr_destroy(ctx);
    sample after = measure();
    free(va); free(vb); free(img); free(img8);

    printf("soak: %.0f s, %lu steps (%lu of them begun and ended without blocking), %lu scene changes, "
           "%lu volume uploads, %lu image reads, %lu iterations counted\n",
           total, steps, nonblocking, changes, uploads, reads, iters);
    printf("soak: RSS          %.1f MiB -> %.1f MiB (%+.1f MiB, of which %+.1f MiB in the iterations that compiled "
           "%llu pipelines after the warm-up, set apart when positive; the rest must be within +16 MiB); "
           "%llu compiles in all\n",
           base.rss / 1048576.0, end.rss / 1048576.0, (end.rss - base.rss) / 1048576.0, compile_growth / 1048576.0,
           g_compiles - base_compiles, g_compiles);
    printf("soak: device memory %.3f MiB -> %.3f MiB (%+lld bytes; tolerance 0), %llu allocations, %llu frees\n",
           base.dev / 1048576.0, end.dev / 1048576.0, (long long)end.dev - (long long)base.dev, g_dev_allocs, g_dev_frees);
    printf("soak: picvr heap   %lld -> %lld bytes (tolerance 0)\n", base.host, end.host);
    printf("soak: after destroy: device memory %llu bytes, picvr heap %lld bytes (both must be 0); "
           "RSS %.1f MiB (%.1f MiB before create)\n", after.dev, after.host, after.rss / 1048576.0, boot.rss / 1048576.0);
    (void)t_start;
    /* Rule: compile iterations may explain growth, never pay for it: where they freed
       more than they took (a variant evicted that the warm-up had compiled), nothing is
       set apart, and the whole growth must be within the tolerance. */
    long long set_apart = compile_growth > 0 ? compile_growth : 0;
    int ok = end.rss - base.rss - set_apart <= 16ll << 20 && end.dev == base.dev && end.host == base.host &&
             after.dev == 0 && after.host == 0 && steps > 0;
    printf("soak: %s\n", ok ? "PASS (flat)" : "FAIL");
    return ok ? 0 : 1;
}
