/* test_scheduler.c - the three-procedure scheduler (paper §6, §7): the §6 time shares
 * follow the hit rate by the formula and the measured device-time shares track them;
 * Eq. 12 priorities give more samples to the blocks whose error falls fastest without
 * starving any; picvr_step keeps its budget on average; tiny pools never deadlock.
 *
 * Scene: the homogeneous cube under a delta sun of test_cache.c (its cache fills within
 * seconds, so the hit rate sweeps from 0 to near 1 during a test).
 */
#include "test_util.h"

#include <signal.h>
#include <time.h>
#include <unistd.h>

static double wall_ms(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

/* 16^3 cube, sigma_t = 0.15, albedo 0.8, white delta sun; camera at (cx, 0, 30). */
static void cube_scene(picvr_context *ctx, tu_vol *vol, double cx, uint32_t w, uint32_t h) {
    *vol = tu_vol_new(16, 16, 16, 1.0f, 255);
    tu_upload(ctx, vol);
    tu_tf_const(ctx, 0.8f, 0.8f, 0.8f, 1.0f, 0.15f);
    tu_sun(ctx, 0.6, 0.45, 0.66, 1.0f, 1.0f, 1.0f, 2.0f, 0.0f);
    tu_set_camera(ctx, cx, 0, 30, cx, 0, 0, 40, w, h);
}

/* The config of these tests: the seed and the cache mode, the rest at its defaults. */
static picvr_config sched_config(uint32_t seed, picvr_cache_mode mode) {
    picvr_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.seed = seed;
    cfg.cache.mode = mode;
    return cfg;
}

static picvr_context *create_sched(picvr_cache_mode mode, picvr_switch prio, uint32_t seed) {
    picvr_config cfg = sched_config(seed, mode);
    cfg.scheduler.priorities = prio;
    return tu_create_config(&cfg);
}

/* §6: t_c = t_min + (1 - h^e)(t_max - t_min), checked on every step against the hit
   rate the stats report (the same windowed value the scheduler uses), with
   non-default parameters: as the cube's cache fills, the target falls from near t_max
   to near t_min.  The measured shares always sum to 1. */
void test_scheduler_shares_follow_hit_rate(void **state) {
    (void)state;
    picvr_config cfg = sched_config(5, PICVR_CACHE_SCREEN_SPACE);   /* many requests in flight from the start */
    cfg.cache.superpixel_size = 8;
    cfg.scheduler.create_min = 0.04f;
    cfg.scheduler.create_max = 0.30f;
    cfg.scheduler.update_min = 0.01f;
    cfg.scheduler.update_max = 0.03f;
    cfg.scheduler.exponent = 2.0f;
    picvr_context *ctx = tu_create_config(&cfg);
    tu_vol vol;
    cube_scene(ctx, &vol, 0, 48, 48);
    double first_target = -1, last_target = -1, last_h = 0;
    for (int i = 0; i < 40; i++) {
        /* The first step is one short round, so its target comes from the empty cache's
           hit rate on any device: an H200 filled the cube's cache within the first 50 ms
           (target 0.100 after it, 2026-11-30). */
        TU_OK(picvr_step(ctx, i == 0 ? 1.0 : 50.0));
        picvr_stats st = tu_stats_finite(ctx);
        double h = st.cache_hit_rate, f = 1.0 - pow(h, 2.0);
        if (getenv("PICVR_TEST_VERBOSE"))
            print_message("    step %d: h %.3f target %.3f share %.3f pending %u entries %u\n", i, h, st.target_create,
                          st.fraction_create, st.cache_pending, st.cache_entries);
        assert_true(h >= 0.0 && h <= 1.0);
        assert_true(fabs(st.target_create - (0.04 + f * 0.26)) < 1e-6);
        assert_true(fabs(st.target_update - (0.01 + f * 0.02)) < 1e-6);
        double sum = st.fraction_render + st.fraction_create + st.fraction_update;
        assert_true(fabs(sum - 1.0) < 1e-9);
        if (first_target < 0) first_target = st.target_create;
        last_target = st.target_create;
        last_h = h;
    }
    print_message("    target_create %.3f -> %.3f as the hit rate reached %.3f\n", first_target, last_target, last_h);
    assert_true(first_target > 0.25);
    assert_true(last_h > 0.6);
    assert_true(last_target < first_target - 0.1);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* The stats after 20 steps of 100 ms on the cube (size x size) with config cfg; with
   cold_compile the context is created with Mesa's shader cache off, so that lavapipe
   compiles every pipeline at its first dispatch (other drivers ignore the variable). */
static picvr_stats cube_shares_after_2s(const picvr_config *cfg, int cold_compile, uint32_t size) {
    if (cold_compile) setenv("MESA_SHADER_CACHE_DISABLE", "true", 1);
    picvr_context *ctx = tu_create_config(cfg);
    if (cold_compile) unsetenv("MESA_SHADER_CACHE_DISABLE");
    tu_vol vol;
    cube_scene(ctx, &vol, 0, size, size);
    for (int i = 0; i < 20; i++) TU_OK(picvr_step(ctx, 100.0));
    picvr_stats st = tu_stats_finite(ctx);
    print_message("    hit rate %.3f, %u entries: create %.3f (target %.3f), update %.4f (target %.4f), render %.3f\n",
                  st.cache_hit_rate, st.cache_entries, st.fraction_create, st.target_create, st.fraction_update,
                  st.target_update, st.fraction_render);
    tu_vol_free(&vol);
    tu_finish(ctx);
    return st;
}

/* The update procedure gets its share from the start, also when the driver compiles
   each pipeline at its first dispatch (lavapipe with its shader cache off: the compile
   lands inside the round's timestamps).  That time used to be taken for one update
   package's cost, 1 % of a round bought no package for seconds, and on bonsai the update
   procedure ran one package in the first 10 s (fraction_update 0.004 against a target
   of 0.02; 0.017 with the rule).  Table 1's shares, 2 s of rounds on the cube: the
   update share over the last second must reach half its target (measured: 0.0114
   against 0.0102, 121 entries; without the rule 0.0014, and creation starved too: 39
   entries).  On a GPU (which compiles at pipeline creation) the same must hold. */
void test_scheduler_update_runs_after_cold_compile(void **state) {
    (void)state;
    picvr_config cfg = sched_config(8, PICVR_CACHE_OBJECT_SPACE);
    picvr_stats st = cube_shares_after_2s(&cfg, 1, 48);
    if (!(st.fraction_update >= 0.5 * st.target_update))
        fail_msg("update share %.4f, target %.4f", st.fraction_update, st.target_update);
}

/* Requests always plentiful: entries with a validity radius of at most 0.5 voxels cover
   almost nothing, screen-space locking with 4x4 superpixels on a 48x48 image; creation
   0.20-0.30 and update 0.05-0.08 of the device time.  A GPU creates a whole batch of
   entries (2112 on an H200, picvr_creation_batch in host/cache.c) in the time lavapipe takes for
   one, so there the image is 256x256 with 2x2 superpixels and up to 16384 requests:
   with 48x48 an H200's creation share was 0.012 against 0.268, all its 144 requests
   created in a sliver of each round, and with 256x256 it filled the default pool of
   65536 entries within 2 s, so there the pool holds 2^20 (2026-11-30; this GPU
   configuration has not run on a GPU yet). */
static picvr_config plentiful_requests_config(uint32_t *size) {
    int cpu = tu_device_is_cpu();   /* opens a context: asked once */
    *size = cpu ? 48 : 256;
    picvr_config cfg = sched_config(6, PICVR_CACHE_SCREEN_SPACE);
    cfg.cache.superpixel_size = cpu ? 4 : 2;
    if (!cpu) {
        cfg.cache.max_requests = 16384;
        cfg.cache.max_entries = 1u << 20;   /* 65536 filled within 2 s on the H200 */
    }
    cfg.cache.radius_max_voxels = 0.5f;
    cfg.scheduler.create_min = 0.20f;
    cfg.scheduler.create_max = 0.30f;
    cfg.scheduler.update_min = 0.05f;
    cfg.scheduler.update_max = 0.08f;
    return cfg;
}

/* The measured device-time share tracks the target.  Entries with a validity radius of
   at most 0.5 voxels cover almost nothing, so the hit rate stays low and requests are
   always plentiful (screen-space locking, 4x4 superpixels): over the last second the
   creation and update shares must be within 0.05 of their targets (one entry of this
   cube costs a few ms, a tenth of a round's creation share, so rounding to whole
   entries is small), and rendering gets the rest. */
void test_scheduler_measured_shares_track_targets(void **state) {
    (void)state;
    uint32_t size;
    picvr_config cfg = plentiful_requests_config(&size);
    picvr_stats st = cube_shares_after_2s(&cfg, 0, size);
    assert_true(st.cache_full == 0);
    assert_true(fabs(st.fraction_create - st.target_create) < 0.05);
    assert_true(fabs(st.fraction_update - st.target_update) < 0.05);
}

/* The cube fills the left half of a 128x32 image, the right half is black background.
   Background pixels have zero variance, so Eq. 12 gives them no priority and only the
   starvation floor (0.1 of the uniform share) renders them: with priorities the lit
   half must receive clearly more samples (at least 2x the mean of the dark half), and
   every pixel keeps receiving samples.  With priorities off the order is round robin:
   no two pixels differ by more than one sample. */
void test_scheduler_priorities_favour_lit_blocks(void **state) {
    (void)state;
    const uint32_t w = 128, h = 32;
    uint32_t *n = malloc(sizeof(uint32_t) * w * h);
    assert_non_null(n);
    for (int prio = 0; prio < 2; prio++) {
        picvr_context *ctx = create_sched(PICVR_CACHE_NONE, prio ? PICVR_SWITCH_ON : PICVR_SWITCH_OFF, 9);
        tu_vol vol;
        cube_scene(ctx, &vol, 8.5, w, h);     /* the cube spans x in [-8, 8]: left of centre */
        for (int i = 0; i < 15; i++) TU_OK(picvr_step(ctx, 50.0));
        TU_OK(picvr_read_sample_counts(ctx, n, (size_t)w * h));
        float *img = tu_read(ctx, w, h);
        double lit = 0, dark = 0;
        uint32_t lo = UINT32_MAX, hi = 0;
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t x = 0; x < w; x++) {
                uint32_t v = n[y * w + x];
                if (x < w / 2) lit += v; else dark += v;
                if (v < lo) lo = v;
                if (v > hi) hi = v;
                if (x >= w / 2 + 16) assert_true(img[(y * w + x) * 4 + 3] == 0.0f);  /* really background */
            }
        lit /= (w / 2) * h;
        dark /= (w / 2) * h;
        print_message("    priorities %s: mean samples lit %.1f, dark %.1f, min %u, max %u\n", prio ? "on" : "off",
                      lit, dark, lo, hi);
        assert_true(lo >= 2);                      /* no pixel starves */
        if (prio) assert_true(lit > 2.0 * dark);
        else assert_true(hi - lo <= 1);
        free(img);
        tu_vol_free(&vol);
        tu_finish(ctx);
    }
    TU_EXPECT(picvr_read_sample_counts(NULL, n, 1), PICVR_ERROR_NULL_POINTER);
    free(n);
}

/* The rendering procedure's three kernels (shaders/render.glsl) finish every pixel
   exactly once per pass, whichever kernel does it: tracking (escaping rays), the
   lookup (cache hits; misses too in a debug view) or shading (queued events).  A
   67x45 image (3,015 pixels: partial blocks, partial event workgroups), with the cube
   filling the whole view (every ray scatters: sigma_t 5 over 16 units, T = e^-80) or
   its left half, without the cache, in both locking modes, and in the cache debug
   view.  After 6 passes every pixel holds exactly 6 samples; coverage is exactly 1
   where every ray scatters and exactly 0 on the background. */
void test_render_kernels_finish_every_pixel_once(void **state) {
    (void)state;
    const uint32_t w = 67, h = 45, passes = 6;
    uint32_t *n = malloc(sizeof(uint32_t) * w * h);
    assert_non_null(n);
    const picvr_cache_mode modes[3] = {PICVR_CACHE_NONE, PICVR_CACHE_OBJECT_SPACE, PICVR_CACHE_SCREEN_SPACE};
    for (int m = 0; m < 3; m++)
        for (int full = 0; full < 2; full++)
            for (int view = 0; view < (modes[m] == PICVR_CACHE_NONE ? 1 : 2); view++) {
                picvr_context *ctx = create_sched(modes[m], PICVR_SWITCH_ON, 11);
                tu_vol vol = tu_vol_new(16, 16, 16, 1.0f, 255);
                tu_upload(ctx, &vol);
                tu_tf_const(ctx, 0.8f, 0.8f, 0.8f, 1.0f, full ? 5.0f : 0.15f);
                tu_sun(ctx, 0.6, 0.45, 0.66, 1.0f, 1.0f, 1.0f, 2.0f, 0.0f);
                if (full) tu_set_camera(ctx, 0, 0, 12, 0, 0, 0, 40, w, h);   /* the view within the front face */
                else tu_set_camera(ctx, 8.5, 0, 30, 8.5, 0, 0, 40, w, h);    /* the cube left of centre */
                if (view) TU_OK(picvr_set_view(ctx, PICVR_VIEW_CACHE));
                TU_OK(picvr_step_iterations(ctx, passes));
                TU_OK(picvr_read_sample_counts(ctx, n, (size_t)w * h));
                float *img = tu_read(ctx, w, h);
                tu_assert_image_valid(img, w, h, "three kernels");
                uint32_t wrong = 0, lit = 0, covered = 0;
                for (uint32_t i = 0; i < w * h; i++) {
                    wrong += n[i] != passes;
                    lit += img[i * 4 + 3] == 1.0f;
                    covered += img[i * 4 + 3] > 0.0f;
                }
                picvr_stats st = tu_stats_finite(ctx);
                print_message("    cache %d, %s view, %s: %u pixels off %u samples, coverage 1: %u, > 0: %u, hits %.3f\n",
                              (int)modes[m], full ? "full" : "half", view ? "debug" : "image", wrong, passes, lit, covered,
                              st.cache_hit_rate);
                assert_int_equal(wrong, 0);
                if (full) assert_int_equal(lit, w * h);
                else {
                    assert_true(covered > w * h / 4);
                    for (uint32_t y = 0; y < h; y++)     /* the cube spans x in [-8, 8]: right of it is background */
                        for (uint32_t x = w / 2 + 12; x < w; x++) assert_true(img[(y * w + x) * 4 + 3] == 0.0f);
                }
                free(img);
                tu_vol_free(&vol);
                tu_finish(ctx);
            }
    free(n);
}

/* picvr_step keeps its budget on average: 20 steps of 100 ms take 80% to 130% of 2 s
   (loose: the machines are shared; the tight figure is in the benchmark), none more
   than the budget + 250 ms. */
void test_scheduler_step_budget(void **state) {
    (void)state;
    picvr_context *ctx = create_sched(PICVR_CACHE_OBJECT_SPACE, PICVR_SWITCH_ON, 3);
    tu_vol vol;
    cube_scene(ctx, &vol, 0, 64, 64);
    TU_OK(picvr_step(ctx, 100.0));           /* warm up: costs measured */
    double total = 0, worst = 0;
    for (int i = 0; i < 20; i++) {
        double t0 = wall_ms();
        TU_OK(picvr_step(ctx, 100.0));
        double dt = wall_ms() - t0;
        total += dt;
        if (dt > worst) worst = dt;
    }
    print_message("    20 x picvr_step(100 ms): mean %.1f ms, worst %.1f ms\n", total / 20, worst);
    assert_true(total >= 0.8 * 2000.0 && total <= 1.3 * 2000.0);
    assert_true(worst <= 350.0);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

static void watchdog(int sig) {
    (void)sig;
    static const char msg[] = "test_scheduler_no_deadlock_with_tiny_pools: watchdog fired (deadlock?)\n";
    if (write(2, msg, sizeof msg - 1) < 0) _exit(2);
    _exit(1);
}

/* Tiny pools (8 entries, 48 references), many requests per round (up to 1000) and both
   locking modes: the pools fill, the stats say so, steps keep returning (a watchdog
   kills the test binary after 120 s), and the image stays finite. */
void test_scheduler_no_deadlock_with_tiny_pools(void **state) {
    (void)state;
    struct sigaction sa, old;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = watchdog;
    sigaction(SIGALRM, &sa, &old);
    alarm(120);
    for (int mode = 0; mode < 2; mode++) {
        picvr_config cfg;
        memset(&cfg, 0, sizeof cfg);
        cfg.cache.mode = mode ? PICVR_CACHE_SCREEN_SPACE : PICVR_CACHE_OBJECT_SPACE;
        cfg.cache.max_entries = 8;
        cfg.cache.max_refs = 48;
        cfg.cache.superpixel_size = 2;
        cfg.scheduler.create_min = cfg.scheduler.create_max = 0.5f;   /* creation-heavy */
        cfg.scheduler.update_min = cfg.scheduler.update_max = 0.2f;
        picvr_context *ctx = tu_create_config(&cfg);
        tu_vol vol;
        cube_scene(ctx, &vol, 0, 64, 64);
        for (int i = 0; i < 30; i++) TU_OK(picvr_step(ctx, 30.0));
        picvr_stats st = tu_stats_finite(ctx);
        print_message("    %s: %u entries, %u refs, full %u, pending %u\n", mode ? "screen" : "object",
                      st.cache_entries, st.cache_refs, st.cache_full, st.cache_pending);
        assert_true(st.cache_entries <= 8);
        assert_int_equal(st.cache_full, 1);
        float *img = tu_read(ctx, 64, 64);
        tu_assert_finite(img, 64 * 64 * 4, "image");
        free(img);
        tu_vol_free(&vol);
        tu_finish(ctx);
    }
    alarm(0);
    sigaction(SIGALRM, &old, NULL);
}

/* picvr_set_scheduler switches the shares of a running context, as an application
   that fills the cache while a scene loads and then renders at the defaults:
   plentiful_requests_config with priorities off for 2 s, then creation at 0.5, update at 0.02 and
   priorities on (their pipeline created by the call) for 2 s.  Over the last second
   the measured shares must be within 0.05 of the new targets, while the cache and the
   accumulated image are kept (entries and iterations only grow). */
void test_scheduler_set_scheduler_switches_shares(void **state) {
    (void)state;
    uint32_t size;
    picvr_config cfg = plentiful_requests_config(&size);
    cfg.scheduler.priorities = PICVR_SWITCH_OFF;
    picvr_context *ctx = tu_create_config(&cfg);
    tu_vol vol;
    cube_scene(ctx, &vol, 0, size, size);
    for (int i = 0; i < 20; i++) TU_OK(picvr_step(ctx, 100.0));
    picvr_stats before = tu_stats_finite(ctx);
    picvr_scheduler_config sc;
    memset(&sc, 0, sizeof sc);
    sc.priorities = PICVR_SWITCH_ON;
    sc.create_min = sc.create_max = 0.5f;
    sc.update_min = sc.update_max = 0.02f;
    TU_OK(picvr_set_scheduler(ctx, &sc));
    for (int i = 0; i < 20; i++) TU_OK(picvr_step(ctx, 100.0));
    picvr_stats st = tu_stats_finite(ctx);
    print_message("    before: create %.3f (target %.3f), %u entries, %u iterations; after: create %.3f "
                  "(target %.3f), update %.4f (target %.4f), %u entries, %u iterations\n",
                  before.fraction_create, before.target_create, before.cache_entries, before.iterations_min,
                  st.fraction_create, st.target_create, st.fraction_update, st.target_update, st.cache_entries,
                  st.iterations_min);
    assert_true(fabs(st.target_create - 0.5) < 1e-6 && fabs(st.target_update - 0.02) < 1e-6);
    assert_true(fabs(st.fraction_create - 0.5) < 0.05);
    assert_true(fabs(st.fraction_update - 0.02) < 0.05);
    assert_true(st.cache_entries >= before.cache_entries);
    assert_true(st.iterations_min > before.iterations_min);
    /* NULL: back to the defaults of Table 1 */
    TU_OK(picvr_set_scheduler(ctx, NULL));
    TU_OK(picvr_step(ctx, 50.0));
    st = tu_stats_finite(ctx);
    double f = 1.0 - pow(st.cache_hit_rate, 3.0);
    assert_true(fabs(st.target_create - (0.05 + f * 0.10)) < 1e-6);
    tu_vol_free(&vol);
    tu_finish(ctx);
}

/* Bad scheduler configurations are refused with a status, by picvr_create (nothing
   leaks) and by picvr_set_scheduler (the context keeps its settings). */
void test_scheduler_config_errors(void **state) {
    (void)state;
    picvr_config cfg;
    picvr_context *ctx = NULL;
    picvr_context *live = create_sched(PICVR_CACHE_OBJECT_SPACE, PICVR_SWITCH_DEFAULT, 1);
    picvr_stats st0 = tu_stats_finite(live);
    const struct { float cmin, cmax, umin, umax, e, rps; picvr_status want; } rows[] = {
        {0.2f, 0.1f, 0, 0, 0, 0, PICVR_ERROR_INVALID_ARGUMENT},      /* min > max */
        {-0.1f, 0, 0, 0, 0, 0, PICVR_ERROR_INVALID_ARGUMENT},
        {NAN, 0, 0, 0, 0, 0, PICVR_ERROR_NON_FINITE},
        {0, 0.8f, 0, 0.2f, 0, 0, PICVR_ERROR_INVALID_ARGUMENT},      /* rendering < 10% */
        {0, 0, 0, 0, INFINITY, 0, PICVR_ERROR_NON_FINITE},
        {0, 0, 0, 0, 0, 5000.0f, PICVR_ERROR_INVALID_ARGUMENT},
    };
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        memset(&cfg, 0, sizeof cfg);
        cfg.scheduler.create_min = rows[i].cmin;
        cfg.scheduler.create_max = rows[i].cmax;
        cfg.scheduler.update_min = rows[i].umin;
        cfg.scheduler.update_max = rows[i].umax;
        cfg.scheduler.exponent = rows[i].e;
        cfg.scheduler.rounds_per_second = rows[i].rps;
        TU_EXPECT(picvr_create(&cfg, &ctx), rows[i].want);
        assert_null(ctx);
        TU_EXPECT(picvr_set_scheduler(live, &cfg.scheduler), rows[i].want);
    }
    memset(&cfg, 0, sizeof cfg);
    cfg.scheduler.priorities = (picvr_switch)7;
    TU_EXPECT(picvr_create(&cfg, &ctx), PICVR_ERROR_INVALID_ARGUMENT);
    assert_null(ctx);
    TU_EXPECT(picvr_set_scheduler(live, &cfg.scheduler), PICVR_ERROR_INVALID_ARGUMENT);
    TU_EXPECT(picvr_set_scheduler(NULL, NULL), PICVR_ERROR_NULL_POINTER);
    picvr_stats st = tu_stats_finite(live);
    assert_true(st.target_create == st0.target_create && st.target_update == st0.target_update);
    tu_finish(live);
}
