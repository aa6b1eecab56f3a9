/* host/step.c - picvr_step (rounds until the time budget is spent, sized by the §6
 * shares) and picvr_step_iterations (whole passes with a fixed split, for tests and
 * offline rendering), and picvr_prepare.  Part of picvr_vk.c; uses util, vulkan,
 * schedule, pipelines, cache, image, rounds. */

/* The scene's uniform block and the descriptors, as the next dispatches read them. */
static picvr_status picvr_upload_scene(picvr_context *ctx) {
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    if (!ctx->scene.has_volume || !ctx->scene.has_camera) return PICVR_ERROR_NOT_READY;
    memcpy(ctx->scene.ubo.mapped, &ctx->scene.gpu, sizeof ctx->scene.gpu);
    picvr_buffer_flush(ctx, &ctx->scene.ubo);
    picvr_update_descriptors(ctx);
    return PICVR_OK;
}

static picvr_status picvr_stats_pass(picvr_context *ctx, float rel_floor, double sums[4], uint64_t counts[4]);
static picvr_status picvr_field_step(picvr_context *ctx);
static int picvr_field_frame_due(const picvr_context *ctx);

static picvr_status picvr_prepare_render(picvr_context *ctx) {
    picvr_status s = picvr_upload_scene(ctx);   /* first: it checks that the scene is ready */
    if (s) return s;
    /* PICVR_DISTANCE_AUTO measures where the two kinds differ: a light the forced point
       serves (scene.use_forced) or ray marching as the second kind (scene.auto_rm), and
       plain rendering (the cache's rounds use MIS) */
    picvr_dauto *a = &ctx->sched.dauto;
    int on = ctx->config.distance_sampling == PICVR_DISTANCE_AUTO && (ctx->scene.use_forced || ctx->scene.auto_rm) &&
             !ctx->cache.on;
    if (on != a->on) picvr_dauto_forget(a);
    a->on = on;
    return picvr_select_variants(ctx);
}

/* The ROUND_* flags of a round's rendering: the forced kind always with
   PICVR_DISTANCE_FORCED; with PICVR_DISTANCE_AUTO the chosen kind, measured in timed
   rounds (picvr_dauto_flags) once the spread's scale is known.  The kernels read the
   measure and probe flags (variants with USE_MEASURE); the host binds the forced
   kind's variant (picvr_current_slot). */
static uint32_t picvr_round_flags(const picvr_context *ctx, int timed) {
    const picvr_dauto *a = &ctx->sched.dauto;
    if (ctx->config.distance_sampling == PICVR_DISTANCE_FORCED) return PICVR_ROUND_FORCED;
    if (!a->on) return 0u;
    if (!timed || a->scale_age == 0) return a->forced ? PICVR_ROUND_FORCED : 0u;
    return picvr_dauto_flags(a);
}

/* PICVR_DISTANCE_AUTO before a timed round: the image cleared when a switch asked for
   it (picvr_dauto_account; the measurements, the scale and the elapsed time are kept),
   and the spread's scale, 1 / the image's mean luminance, measured once the image has
   samples and again every PICVR_DAUTO_SCALE_ROUNDS rounds. */
static picvr_status picvr_dauto_prepare_round(picvr_context *ctx) {
    picvr_dauto *a = &ctx->sched.dauto;
    if (!a->on) return PICVR_OK;
    picvr_status s = PICVR_OK;
    if (ctx->image.has_samples && (a->scale_age == 0 || a->scale_age > PICVR_DAUTO_SCALE_ROUNDS)) {
        double sums[4];
        uint64_t counts[4];
        if ((s = picvr_stats_pass(ctx, 0.0f, sums, counts))) return s;
        /* the mean over the pixels that have samples: while the first pass is incomplete
           the others are 0, and a mean over all of them would overstate the scale */
        double sampled = (double)counts[3];
        double scale = sampled > 0.0 && sums[0] > 0.0 ? sampled / sums[0] : 0.0;
        /* Rule: a black image so far (mean 0) or a scale beyond float gives 0: nothing is
           measured, and the scale is measured again within 8 rounds */
        a->scale = isfinite(scale) && scale < 1e30 ? (float)scale : 0.0f;
        a->scale_age = a->scale > 0.0f ? 1u : PICVR_DAUTO_SCALE_ROUNDS - 6u;
        /* Rule: MIS's image still black after its first rounds has gathered no light yet
           (a medium so thin that delta tracking has not collided), and nothing can be
           measured against it; the forced point gathers on every ray through the medium,
           so it renders from a cleared image (the black one is all noise: the rule of a
           switch), and the scale is measured again at the next round.  The forced kind's
           image black too: the scene is dark, and it stays as it is. */
        if (a->scale == 0.0f && !a->forced && a->rounds >= PICVR_DAUTO_WARM) {
            a->forced = 1;
            a->restart = 1;
            a->scale_age = 0;
        }
    }
    if (a->restart) {
        double elapsed = ctx->image.elapsed_ms;   /* the image restarts; the run's time goes on */
        s = picvr_clear_accumulation(ctx);
        ctx->image.elapsed_ms = elapsed;
        a->restart = 0;
        if (s) return s;
    }
    return PICVR_OK;
}

picvr_status picvr_prepare(picvr_context *ctx) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (ctx->vk.lost) return PICVR_ERROR_DEVICE_LOST;
    if (!ctx->scene.has_volume) return PICVR_ERROR_NOT_READY;   /* dense media choose USE_FINE */
    return picvr_select_variants(ctx);
}

/* What the plan of a timed round needs to know of the cache and the image. */
static picvr_plan_inputs picvr_plan_inputs_now(const picvr_context *ctx) {
    picvr_plan_inputs in;
    in.cache_on = picvr_cache_serves(ctx);
    in.requests_pending = ctx->cache.requests_pending;
    in.refinable = picvr_cache_multiple(ctx) ? picvr_cache_trusted(ctx) : 0;
    in.max_requests = ctx->cache.cfg.max_requests;
    in.rebuild_due = ctx->cache.since_rebuild_ms >= ctx->cache.cfg.rebuild_interval_ms;
    in.block_total = ctx->image.block_total;
    return in;
}

/* Blocks the first pass still owes under scheduler.frames (0 when off or complete).  A
   priority dispatch before the pass was complete (frames just turned on) leaves the
   coverage unknown, so the pass starts again from cursor 0. */
static uint32_t picvr_first_pass_left(picvr_context *ctx) {
    picvr_image_state *im = &ctx->image;
    if (ctx->sched.cfg.frames != PICVR_SWITCH_ON || im->first_pass_blocks >= im->block_total) return 0;
    if (im->priority_used) {
        im->priority_used = 0;
        im->first_pass_blocks = 0;
        im->block_cursor = 0;
    }
    return im->block_total - im->first_pass_blocks;
}

/* The plan of one timed round of `round_ms`: plain or cached under PICVR_CACHE_AUTO
   (picvr_auto_choose), the §6 plan, and under scheduler.frames
   round-robin while the first pass is incomplete: at most the rest of the pass for
   picvr_step (its next rounds go by priority), at least the rest for picvr_step_begin
   (whose one round is the whole step; blocks beyond it start the next pass in the same
   order). */
static picvr_round_plan picvr_plan_timed_round(picvr_context *ctx, double round_ms, int whole_first_pass) {
    picvr_plan_inputs in = picvr_plan_inputs_now(ctx);
    /* PICVR_CACHE_AUTO: this round's kind, and the rendering cost of that kind to plan by */
    int plain = picvr_auto_plain_allowed(ctx) && picvr_auto_choose(&ctx->sched.auto_mode);
    if (picvr_auto_plain_allowed(ctx) && ctx->sched.auto_mode.render_cost[plain ? 0 : 1] > 0.0)
        ctx->sched.cost[PICVR_PROC_RENDER] = ctx->sched.auto_mode.render_cost[plain ? 0 : 1];
    if (plain) in.cache_on = 0;
    picvr_round_plan p = picvr_sched_plan(&ctx->sched, round_ms, &in);
    p.plain = plain;
    p.render_flags = picvr_round_flags(ctx, 1);
    uint32_t rest = picvr_first_pass_left(ctx);
    if (rest > 0) {
        /* the first pass is the image's: a probe would leave its blocks unsampled */
        if (p.render_flags & PICVR_ROUND_PROBE)
            p.render_flags = PICVR_ROUND_MEASURE | (ctx->sched.dauto.forced ? PICVR_ROUND_FORCED : 0u);
        p.whole_passes = 1;
        if (whole_first_pass ? p.render_blocks < rest : p.render_blocks > rest) p.render_blocks = rest;
        if (p.render_blocks == 0) p.render_blocks = 1;
    }
    return p;
}

/* picvr_step: rounds until `budget_ms` of wall time have passed (at least one round) and,
   under scheduler.frames, until the first pass is complete. */
static picvr_status picvr_step_time(picvr_context *ctx, double budget_ms) {
    picvr_status s = picvr_prepare_render(ctx);
    if (s) return s;
    ctx->cache.requests_issued = 0;
    double start = picvr_clock_ms(), round_ms = 1000.0 / ctx->sched.cfg.rounds_per_second;
    do {
        if ((s = picvr_dauto_prepare_round(ctx))) return s;
        double left = budget_ms - (picvr_clock_ms() - start);
        picvr_round_plan p = picvr_plan_timed_round(ctx, left < round_ms ? left : round_ms, 0);
        if (!p.plain && (s = picvr_ready_cached(ctx))) return s;
        if ((s = picvr_probe_forced(ctx, &p.render_flags))) return s;
        if ((s = picvr_run_round(ctx, &p))) return s;
        /* Rule: a remainder under a tenth of a round is not worth a round's fixed costs. */
    } while (budget_ms - (picvr_clock_ms() - start) > 0.1 * round_ms || picvr_first_pass_left(ctx) > 0);
    return PICVR_OK;
}

/* The fixed split of picvr_step_iterations: unless the application set max_requests,
   one request per CACHE_PIXELS_PER_REQUEST pixels per pass. */
static uint32_t picvr_pass_request_cap(const picvr_context *ctx) {
    if (ctx->config.cache.max_requests) return ctx->cache.cfg.max_requests;   /* the application chose it */
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
    if (!s) s = picvr_ready_cached(ctx);   /* whole passes render cached */
    if (s) return s;
    ctx->cache.requests_issued = 0;
    ctx->image.block_cursor = 0;
    for (uint32_t done = 0; done < passes;) {
        picvr_round_plan p;
        memset(&p, 0, sizeof p);
        p.whole_passes = 1;
        p.render_flags = picvr_round_flags(ctx, 0);
        if ((p.render_flags & PICVR_ROUND_FORCED) && (s = picvr_ready_forced(ctx))) return s;
        uint32_t k = 1;
        if (picvr_cache_serves(ctx)) {
            p.create_budget = UINT32_MAX;
            p.request_cap = picvr_pass_request_cap(ctx);
            p.update_groups = (ctx->image.block_total + 15) / 16;
            /* the multiply scattered cache: 1/PICVR_REFINE_PASS_DIVISOR of the entries refined per pass */
            if (picvr_cache_multiple(ctx))
                p.refine_groups = (picvr_cache_trusted(ctx) + PICVR_REFINE_PASS_DIVISOR - 1) / PICVR_REFINE_PASS_DIVISOR;
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

static picvr_status picvr_check_budget(picvr_context *ctx, double milliseconds) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (!isfinite(milliseconds)) return PICVR_ERROR_NON_FINITE;   /* the NaN/Inf convention */
    if (milliseconds < 0.0) return PICVR_ERROR_INVALID_ARGUMENT;
    return PICVR_OK;
}

picvr_status picvr_step(picvr_context *ctx, double milliseconds) {
    picvr_status s = picvr_check_budget(ctx, milliseconds);
    /* the field's image; PICVR_RENDER_FIELD_MC adds Monte Carlo to it while nothing changes */
    if (!s && ctx->field.on && picvr_field_frame_due(ctx)) return picvr_field_step(ctx);
    return s ? s : picvr_step_time(ctx, milliseconds);
}

/* One round of the whole budget, submitted; picvr_step_end reads it back.  The
   scheduler's shares and the cost model apply as in picvr_step (whose rounds are
   1/rounds_per_second long: a longer one only makes fewer, larger dispatches). */
picvr_status picvr_step_begin(picvr_context *ctx, double milliseconds) {
    picvr_status s = picvr_check_budget(ctx, milliseconds);
    if (!s && ctx->field.on && picvr_field_frame_due(ctx)) {   /* made here; picvr_step_end finds it done */
        if ((s = picvr_field_step(ctx))) return s;
        ctx->pending.active = 1;
        ctx->pending.field = 1;
        return PICVR_OK;
    }
    if (s || (s = picvr_prepare_render(ctx))) return s;
    ctx->cache.requests_issued = 0;
    if ((s = picvr_dauto_prepare_round(ctx))) return s;
    picvr_round_plan p = picvr_plan_timed_round(ctx, milliseconds, 1);
    if (!p.plain && (s = picvr_ready_cached(ctx))) return s;
    if ((s = picvr_probe_forced(ctx, &p.render_flags))) return s;
    if ((s = picvr_submit_round(ctx, &p))) return s;
    ctx->pending.active = 1;
    return PICVR_OK;
}

picvr_status picvr_step_end(picvr_context *ctx, uint64_t timeout_ns) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    if (!ctx->pending.active) return PICVR_ERROR_NO_STEP;
    if (ctx->pending.field) { ctx->pending.active = ctx->pending.field = 0; return PICVR_OK; }
    picvr_status s = picvr_complete_round(ctx, timeout_ns, 0);
    if (s == PICVR_ERROR_TIMEOUT) return s;   /* still running: the step stays begun */
    ctx->pending.active = 0;
    return s;
}

picvr_status picvr_step_iterations(picvr_context *ctx, uint32_t iterations) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (iterations == 0) return PICVR_OK;
    if (ctx->field.on && picvr_field_frame_due(ctx)) {
        picvr_status s = picvr_field_step(ctx);
        /* PICVR_RENDER_FIELD: deterministic, one image is every image; _FIELD_MC: then the
           passes, from it */
        if (s || !ctx->field.mc) return s;
    }
    return picvr_step_passes(ctx, iterations);
}
