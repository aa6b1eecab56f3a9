/* host/schedule.c - the scheduler's formulas, paper §6: the hit rate over a window of
 * rounds, the target shares t = t_min + (1 - h^e_c)(t_max - t_min) of cache-entry
 * creation and update, the credit that keeps each procedure at its share of device
 * time, the cost model (device time per work package), and the plan of a round.  Plain
 * arithmetic on picvr_sched: no Vulkan, no other part of the context.  Part of
 * picvr_vk.c; uses host/util.c. */

static picvr_status picvr_resolve_scheduler_config(const picvr_scheduler_config *in, picvr_scheduler_config *c) {
    *c = *in;
    if ((unsigned)c->priorities > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->priorities == PICVR_SWITCH_DEFAULT) c->priorities = PICVR_SWITCH_ON;
    if ((unsigned)c->frames > PICVR_SWITCH_OFF) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->frames == PICVR_SWITCH_DEFAULT) c->frames = PICVR_SWITCH_OFF;
    if ((unsigned)c->temporal_reuse > PICVR_SWITCH_OFF || c->reuse_history > (1u << 20))
        return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->temporal_reuse == PICVR_SWITCH_DEFAULT) c->temporal_reuse = PICVR_SWITCH_OFF;
    if (c->reuse_history == 0) c->reuse_history = 16;
    float *f[7] = {&c->create_min, &c->create_max, &c->update_min, &c->update_max, &c->exponent,
                   &c->rounds_per_second, &c->hit_rate_window_ms};
    const float def[7] = {0.05f, 0.15f, 0.01f, 0.02f, 3.0f, 20.0f, 100.0f};
    picvr_status s = picvr_resolve_floats(f, def, 7);
    if (s) return s;
    /* a pair given as (min, 0) keeps max at its default only if that is >= min */
    if (c->create_min > c->create_max || c->update_min > c->update_max) return PICVR_ERROR_INVALID_ARGUMENT;
    if (c->create_max + c->update_max > 0.9f) return PICVR_ERROR_INVALID_ARGUMENT;  /* rendering keeps >= 10% */
    if (c->rounds_per_second > 1000.0f || c->rounds_per_second < 1.0f) return PICVR_ERROR_INVALID_ARGUMENT;
    return PICVR_OK;
}

static double picvr_moving_average(double old, double now) { return old > 0.0 ? 0.7 * old + 0.3 * now : now; }

/* The hit rate over the last hit_rate_window_ms of rounds (at least the last round). */
static double picvr_window_hit_rate(const picvr_sched *sc, double now) {
    uint64_t hits = 0, events = 0;
    uint32_t n = sc->history_count < PICVR_SCHED_HISTORY ? sc->history_count : PICVR_SCHED_HISTORY;
    for (uint32_t k = 0; k < n; k++) {
        const picvr_round_record *r = &sc->history[(sc->history_count - 1 - k) % PICVR_SCHED_HISTORY];
        if (k > 0 && r->end_ms < now - sc->cfg.hit_rate_window_ms) break;
        hits += r->hits;
        events += (uint64_t)r->hits + r->misses;
    }
    return events ? (double)hits / (double)events : 0.0;
}

/* §6: t = t_min + (1 - h^e) (t_max - t_min), for creation and update. */
static void picvr_update_targets(picvr_sched *sc, int cache_on) {
    const picvr_scheduler_config *c = &sc->cfg;
    double f = 1.0 - pow(sc->hit_rate, c->exponent);
    sc->target[PICVR_PROC_CREATE] = cache_on ? c->create_min + f * (c->create_max - c->create_min) : 0.0;
    sc->target[PICVR_PROC_UPDATE] = cache_on ? c->update_min + f * (c->update_max - c->update_min) : 0.0;
}

/* An empty cache: the hit rate restarts from 0. */
static void picvr_sched_forget_hits(picvr_sched *sc, int cache_on) {
    for (uint32_t i = 0; i < PICVR_SCHED_HISTORY; i++) sc->history[i].hits = sc->history[i].misses = 0;
    sc->hit_rate = 0.0;
    picvr_update_targets(sc, cache_on);
}

/* After a round: the procedure was owed its target share of the round's device time
   and used dev_ms.  Rules: the credit stays below one round's share plus one batch of
   packages, so a stretch without work (no requests) is not paid back later in a burst;
   the debt stays below one round's share plus this round's use (or one batch if more),
   so a dispatch that ran long (entries vary several-fold in cost) is paid back in full -
   forgiving it made creation overshoot its share by 15-20 % with batches - but debts do
   not pile up beyond that. */
static void picvr_settle_credit(picvr_sched *sc, int proc, double device_total, double dev_ms) {
    double c = sc->credit_ms[proc] + sc->target[proc] * device_total - dev_ms;
    double batch = proc == PICVR_PROC_CREATE ? sc->create_batch : 1.0;
    double share = sc->target[proc] * 1000.0 / sc->cfg.rounds_per_second;
    double hi = share + batch * sc->cost[proc];
    double lo = -(share + (dev_ms > batch * sc->cost[proc] ? dev_ms : batch * sc->cost[proc]));
    sc->credit_ms[proc] = c > hi ? hi : c < lo ? lo : c;
}

/* Packages a procedure may run this round: the device time it is owed (its credit,
   settled against the measured time after every round in picvr_settle_credit) plus its share
   of this round, in whole packages of the estimated cost.  Because the credit is
   settled with measured times, an estimate that is off (packages of varying cost, a
   cost that drifts as the cache fills) does not bias the long-run share, and a package
   longer than one round's share still runs every few rounds.
   A procedure runs only when it is owed at least `batch` packages (picvr_creation_batch).
   Rule: an unmeasured cost (first round) allows one batch. */
static uint32_t picvr_sched_packages(const picvr_sched *sc, int proc, double share_ms, uint32_t available, uint32_t batch) {
    if (sc->cost[proc] <= 0.0) return available < batch ? available : batch;
    double owed = (sc->credit_ms[proc] + share_ms) / sc->cost[proc];
    if (!(owed >= (double)batch)) return 0;           /* also NaN */
    return owed < (double)available ? (uint32_t)owed : available;
}

/* Plans a round of round_ms of device time by the §6 shares and the measured costs. */
static picvr_round_plan picvr_sched_plan(const picvr_sched *sc, double round_ms, const picvr_plan_inputs *in) {
    picvr_round_plan p;
    memset(&p, 0, sizeof p);
    double avail = round_ms - sc->overhead_ms;
    if (avail < 0.1 * round_ms) avail = 0.1 * round_ms;
    double left = avail;
    const double *cost = sc->cost;
    if (in->cache_on) {
        double create_ms = sc->target[PICVR_PROC_CREATE] * avail, update_ms = sc->target[PICVR_PROC_UPDATE] * avail;
        /* Creation's packages: new entries for the queued requests, and with the multiply
           scattered cache refinement of existing ones (PICVR_REFINE_SHARE of them while
           requests wait, every package when none do). */
        uint64_t work = (uint64_t)in->requests_pending + in->refinable;
        uint32_t packages = picvr_sched_packages(sc, PICVR_PROC_CREATE, create_ms,
                                                 work > UINT32_MAX ? UINT32_MAX : (uint32_t)work, sc->create_batch);
        uint32_t reserved = in->requests_pending ? (uint32_t)(PICVR_REFINE_SHARE * packages) : packages;
        uint32_t create = packages - (reserved < in->refinable ? reserved : in->refinable);
        p.create_budget = create < in->requests_pending ? create : in->requests_pending;
        p.refine_groups = packages - p.create_budget < in->refinable ? packages - p.create_budget : in->refinable;
        p.update_groups = picvr_sched_packages(sc, PICVR_PROC_UPDATE, update_ms, UINT32_MAX, 1);
        /* requests for the next round: what its creation share can take, at least one batch */
        double next = cost[PICVR_PROC_CREATE] > 0.0 ? ceil(create_ms / cost[PICVR_PROC_CREATE]) : 4.0;
        if (next < sc->create_batch) next = sc->create_batch;
        p.request_cap = next > in->max_requests ? in->max_requests : (uint32_t)next;
        p.rebuild = in->rebuild_due;
        /* Work conserving: time creation and update cannot use goes to rendering. */
        left -= (p.create_budget + p.refine_groups) * cost[PICVR_PROC_CREATE] + p.update_groups * cost[PICVR_PROC_UPDATE];
    }
    double blocks = cost[PICVR_PROC_RENDER] > 0.0 ? left / cost[PICVR_PROC_RENDER] : 32.0;
    p.render_blocks = blocks < 1.0 ? 1 : blocks > 64.0 * in->block_total ? 64 * in->block_total : (uint32_t)blocks;
    return p;
}

/* After a round: the cost model (device ms per work package of each procedure), the
   credit of creation and update, and the overhead of a round beyond its device time.
   dev: the round's device time per procedure (PROC_*), rebuild_ms the part of
   dev[PROC_UPDATE] the octree rebuild took; created, update_groups and blocks: the work
   packages the procedures ran. */
static void picvr_sched_account(picvr_sched *sc, const double dev[3], double rebuild_ms, uint32_t created,
                                uint32_t update_groups, uint32_t blocks, double wall_ms, int cache_on) {
    /* Rule: a pipeline variant's first dispatch neither enters the cost model nor is
       charged to its procedure's credit.  llvmpipe compiles a pipeline at its first
       dispatch, inside the round's timestamps (docs/lavapipe.md); taken for the
       procedure's own cost, that time held the update procedure (1 % of a round) back
       for seconds of credit with a cold shader cache. */
    const int *first = sc->first_dispatch;
    /* Rule: a creation dispatch of fewer entries than a batch costs what a full batch
       does (picvr_creation_batch), so its cost per entry is its time over the batch. */
    if (created > 0 && !first[PICVR_PROC_CREATE])
        sc->cost[PICVR_PROC_CREATE] = picvr_moving_average(sc->cost[PICVR_PROC_CREATE],
            dev[PICVR_PROC_CREATE] / (created > sc->create_batch ? created : sc->create_batch));
    if (update_groups > 0 && !first[PICVR_PROC_UPDATE])
        sc->cost[PICVR_PROC_UPDATE] = picvr_moving_average(sc->cost[PICVR_PROC_UPDATE],
                                                           (dev[PICVR_PROC_UPDATE] - rebuild_ms) / update_groups);
    if (blocks > 0 && !first[PICVR_PROC_RENDER])
        sc->cost[PICVR_PROC_RENDER] = picvr_moving_average(sc->cost[PICVR_PROC_RENDER], dev[PICVR_PROC_RENDER] / blocks);
    double device_total = dev[0] + dev[1] + dev[2];
    if (cache_on) {
        if (!first[PICVR_PROC_CREATE]) picvr_settle_credit(sc, PICVR_PROC_CREATE, device_total, dev[PICVR_PROC_CREATE]);
        /* The update procedure's share (Table 1: 1-2 %) is its own: the octree rebuild
           runs on top (rendering gives way), though the stats count it as update time
           (octree maintenance).  Charged to the update's credit, it took most of that
           share as the cache grew. */
        if (!first[PICVR_PROC_UPDATE])
            picvr_settle_credit(sc, PICVR_PROC_UPDATE, device_total, dev[PICVR_PROC_UPDATE] - rebuild_ms);
    }
    sc->overhead_ms = picvr_moving_average(sc->overhead_ms, wall_ms > device_total ? wall_ms - device_total : 1e-3);
}

/* Remembers a round that ended at end_ms (for the shares of the stats and the hit-rate
   window) and moves the hit rate and the §6 targets on. */
static void picvr_sched_record(picvr_sched *sc, double end_ms, const double dev[3], uint32_t hits, uint32_t misses,
                               int cache_on) {
    picvr_round_record *r = &sc->history[sc->history_count % PICVR_SCHED_HISTORY];
    r->end_ms = end_ms;
    for (int i = 0; i < 3; i++) r->device_ms[i] = dev[i];
    r->hits = hits;
    r->misses = misses;
    sc->history_count++;
    sc->hit_rate = picvr_window_hit_rate(sc, end_ms);
    picvr_update_targets(sc, cache_on);
}

/* stats.fraction_*: each procedure's share of the device time of the rounds that ended
   in the last SHARE_WINDOW_MS; target_*: the §6 shares now. */
static double picvr_dauto_efficiency(const picvr_dauto *a);

static void picvr_sched_shares(const picvr_sched *sc, picvr_stats *st) {
    double sum[3] = {0, 0, 0};
    uint32_t n = sc->history_count < PICVR_SCHED_HISTORY ? sc->history_count : PICVR_SCHED_HISTORY;
    double newest = n ? sc->history[(sc->history_count - 1) % PICVR_SCHED_HISTORY].end_ms : 0.0;
    for (uint32_t k = 0; k < n; k++) {
        const picvr_round_record *r = &sc->history[(sc->history_count - 1 - k) % PICVR_SCHED_HISTORY];
        if (r->end_ms < newest - PICVR_SHARE_WINDOW_MS) break;
        for (int i = 0; i < 3; i++) sum[i] += r->device_ms[i];
    }
    double total = sum[0] + sum[1] + sum[2];
    const picvr_auto *a = &sc->auto_mode;
    double both = a->time_ms[0] + a->time_ms[1];
    st->auto_cached_share = !a->on ? 1.0 : both > 0.0 ? a->time_ms[1] / both : 0.0;
    const picvr_dauto *d = &sc->dauto;
    double kinds = d->time_ms[0] + d->time_ms[1];
    st->forced_share = d->on && kinds > 0.0 ? d->time_ms[1] / kinds : 0.0;   /* FORCED: host/readback.c */
    st->forced_efficiency = picvr_dauto_efficiency(d);
    st->fraction_create = total > 0.0 ? sum[PICVR_PROC_CREATE] / total : 0.0;
    st->fraction_update = total > 0.0 ? sum[PICVR_PROC_UPDATE] / total : 0.0;
    st->fraction_render = total > 0.0 ? sum[PICVR_PROC_RENDER] / total : 0.0;
    st->target_create = sc->target[PICVR_PROC_CREATE];
    st->target_update = sc->target[PICVR_PROC_UPDATE];
}

/* ---- PICVR_CACHE_AUTO: cached or plain, by measured efficiency ----------------------
   Per unit of device time a kind of round reduces the squared error in proportion to
   1 / (c v): c its device time per block (all procedures: a cached round pays for the
   creation and update it runs), v its variance per sample.  With a fraction h of the
   scatter events served by a hit, each removing the share g of a plain sample's variance
   that plain shading's noise makes (count_gain in shaders/cache_blend.glsl),
   v_cached / v_plain = 1 - h g, so cached rounds pay when
       E = c_plain / (c_cached (1 - h g)) >= 1.
   The cache's bias is left to the blend (cache.blend, on in this mode), which routes the
   events of pixels with an established bias to plain shading; those are counted in h's
   denominator and gain nothing.  Both kinds run at first (picvr_auto_choose says when);
   then the more efficient kind runs, and the other keeps PICVR_AUTO_EXPLORE of the device
   time, so that both costs and the gain stay measured (and the cache keeps growing) at a
   bounded price: that share of the time at the worse efficiency. */

/* E above; 0 while a kind is unmeasured.  Rule: 1 - h g is taken >= AUTO_MIN_VARIANCE
   (g and h are estimates: a cache is never credited with removing all the noise). */
static double picvr_auto_efficiency(const picvr_auto *a) {
    if (a->measured[0] < PICVR_AUTO_WARM || a->measured[1] < PICVR_AUTO_WARM || !(a->cost[1] > 0.0)) return 0.0;
    double v = 1.0 - a->served * a->gain;
    if (!(v >= PICVR_AUTO_MIN_VARIANCE)) v = PICVR_AUTO_MIN_VARIANCE;
    return a->cost[0] / (a->cost[1] * v);
}

/* PICVR_CACHE_AUTO: a selection of the plain rendering variant took made_ms of wall time
   (a new variant's making compiles its pipelines); the longest is the plain variant's
   compile time that picvr_auto_choose defers the cached kind by. */
static void picvr_auto_note_compile(picvr_auto *a, double made_ms) {
    if (made_ms > a->compile_ms) a->compile_ms = made_ms;
}

/* Whether the next round is plain.  Plain rounds first; the cached kind's first round
   makes and compiles its pipelines (seconds on lavapipe), so it waits until the plain
   rounds have rendered PICVR_AUTO_DEFER times the plain variant's own compile time (the
   longer of the time making its pipelines took and the first plain round's wall time
   beyond a later round's, where the driver compiles at the first dispatch; the cached
   kind compiles about three times as many kernels, and a pause of C at time t costs
   1 - sqrt(1 - C/t) of the error ratio), which keeps the error at every moment near
   plain's; then PICVR_AUTO_WARM rounds of each kind; then
   the more efficient kind, unless the other has had less than PICVR_AUTO_EXPLORE of the
   recent device time (time_ms). */
static int picvr_auto_choose(const picvr_auto *a) {
    if (a->measured[0] < PICVR_AUTO_WARM) return 1;
    double compile_ms = fmax(a->first_wall_ms - a->plain_round_ms, a->compile_ms);
    if (a->measured[1] == 0 && a->plain_wall_ms < PICVR_AUTO_DEFER * compile_ms) return 1;
    if (a->measured[1] < PICVR_AUTO_WARM) return 0;
    int prefer_plain = picvr_auto_efficiency(a) < 1.0;
    double other = a->time_ms[prefer_plain ? 1 : 0], total = a->time_ms[0] + a->time_ms[1];
    return other < PICVR_AUTO_EXPLORE * total ? !prefer_plain : prefer_plain;
}

/* After a round of kind `plain`: its cost per block and, for a cached round, the share of
   events a hit served and the mean gain of its probes.  Rule: a round that ran a variant
   for the first time (pipeline compilation inside the timestamps) or rendered nothing
   is left out; so are gains of a round without probes. */
static void picvr_auto_account(picvr_sched *sc, int plain, const double dev[3], uint32_t blocks, double wall_ms,
                               const picvr_cache_counters *got) {
    picvr_auto *a = &sc->auto_mode;
    int k = plain ? 0 : 1;
    /* an exponential window of PICVR_AUTO_WINDOW rounds: a kind starved long ago is
       measured again within seconds once its share of the window falls */
    for (int i = 0; i < 2; i++) a->time_ms[i] *= 1.0 - 1.0 / PICVR_AUTO_WINDOW;
    a->time_ms[k] += dev[0] + dev[1] + dev[2];
    uint64_t events = (uint64_t)got->hits + got->misses + got->routed;
    if (!plain && events) a->routed = 0.7 * a->routed + 0.3 * (double)got->routed / (double)events;
    if (!a->on) return;
    if (plain && a->plain_rounds++ == 0) a->first_wall_ms = wall_ms;
    else if (plain) {
        a->plain_wall_ms += wall_ms;
        a->plain_round_ms = picvr_moving_average(a->plain_round_ms, wall_ms);
    }
    a->render_cost[k] = sc->cost[PICVR_PROC_RENDER];   /* picvr_sched_account's, for this kind */
    if (blocks == 0 || sc->first_dispatch[0] || sc->first_dispatch[1] || sc->first_dispatch[2]) return;
    a->cost[k] = picvr_moving_average(a->cost[k], (dev[0] + dev[1] + dev[2]) / blocks);
    a->measured[k]++;
    if (plain) return;
    double served = events ? (double)got->hits / (double)events : 0.0;
    a->served = a->measured[1] == 1 ? served : 0.7 * a->served + 0.3 * served;
    if (got->probes > 0) {
        double gain = (double)((uint64_t)got->gain_hi << 32 | got->gain_lo) / 65536.0 / got->probes;
        a->gain = a->gain > 0.0 ? 0.7 * a->gain + 0.3 * gain : gain;
    }
}

/* ---- PICVR_DISTANCE_AUTO: MIS or the forced point, by measured efficiency ------------
   Both kinds are unbiased estimators of every pixel; per unit of device time a kind
   reduces the squared error in proportion to 1 / (c v): c its device time per block, v
   its variance per sample, measured on the device as the spread of its samples about
   the pixels' running means (shaders/render.glsl, measure_spread).  The forced point
   pays when E = c_mis v_mis / (c_forced v_forced) > 1.  The chosen kind adds to the
   image; averaged with equal weights, samples of kinds whose variances differ 10^4-fold
   (thin media under the sun) would leave the noisier kind's error in the image for
   good.  The other kind runs as probes, rounds that measure and add to the image only
   where that lowers its variance (picvr_dauto_flags), at first PICVR_DAUTO_WARM rounds
   of each and then PICVR_DAUTO_EXPLORE of the device time (the bound of what measuring
   costs).  A switch clears the image when the samples it has
   are the noisier: keeping n_o samples of variance v_o and adding n of v_n leaves the
   mean the variance (n_o v_o + n v_n) / (n_o + n)^2, below the restart's v_n / n for
   every n exactly when v_o <= 2 v_n. */

/* The kinds' spreads as the choice takes them.  Rule: a spread <= 0 (the correction for
   the mean's variance exceeded the sum: the kind's own variance is lost below the
   mean's) is taken as 1e-3 of the other kind's; both <= 0 (or unmeasured): 0, no choice. */
static int picvr_dauto_spreads(const picvr_dauto *a, double v[2]) {
    if (a->measured[0] < PICVR_DAUTO_WARM || a->measured[1] < PICVR_DAUTO_WARM) return 0;
    for (int k = 0; k < 2; k++) v[k] = a->spread_count[k] > 0.0 ? a->spread_sum[k] / a->spread_count[k] : 0.0;
    if (!(v[0] > 0.0) && !(v[1] > 0.0)) return 0;
    if (!(v[0] > 0.0)) v[0] = 1e-3 * v[1];
    if (!(v[1] > 0.0)) v[1] = 1e-3 * v[0];
    return 1;
}

/* E above; 0 while a kind is unmeasured (or its cost is). */
static double picvr_dauto_efficiency(const picvr_dauto *a) {
    double v[2];
    if (!picvr_dauto_spreads(a, v) || !(a->cost[0] > 0.0) || !(a->cost[1] > 0.0)) return 0.0;
    double e = a->cost[0] * v[0] / (a->cost[1] * v[1]);
    return isfinite(e) ? e : 0.0;
}

/* The ROUND_* flags of a timed round of the chosen kind. */
static uint32_t picvr_dauto_chosen_flags(const picvr_dauto *a) {
    int measure = a->measured[a->forced] < PICVR_DAUTO_WARM || a->rounds % PICVR_DAUTO_MEASURE_EVERY == 0;
    return (measure ? PICVR_ROUND_MEASURE : 0u) | (a->forced ? PICVR_ROUND_FORCED : 0u);
}

/* The ROUND_* flags of a timed round: a probe of the kind not chosen while it has fewer
   than PICVR_DAUTO_WARM measured rounds or less than its share of the recent device
   time, else the chosen kind, measured in its first PICVR_DAUTO_WARM rounds and then
   one round in PICVR_DAUTO_MEASURE_EVERY (the measure's atomics cost device time, and
   the choice needs no more).  A probe needs the image's means to
   measure against: it waits for a measured round of the chosen kind.  A probe keeps its
   samples in the image (PICVR_ROUND_KEEP) when its kind's measured variance is below
   twice the chosen kind's: adding n_p samples of variance v_p to n_c of v_c leaves the
   mean the variance (n_c v_c + n_p v_p) / (n_c + n_p)^2, below v_c / n_c exactly when
   v_p < v_c (2 + n_p / n_c), so for every n_p and n_c when v_p < 2 v_c; where the kinds'
   variances are alike (dense media) the probes then cost the image only their kind's
   extra time per sample.  Rule: unmeasured spreads keep nothing. */
static uint32_t picvr_dauto_flags(const picvr_dauto *a) {
    int other = !a->forced;
    double total = a->time_ms[0] + a->time_ms[1], v[2];
    if (a->measured[a->forced] >= 1 &&
        (a->measured[other] < PICVR_DAUTO_WARM || a->time_ms[other] < PICVR_DAUTO_EXPLORE * total)) {
        int keep = picvr_dauto_spreads(a, v) && v[other] < 2.0 * v[a->forced];
        return PICVR_ROUND_MEASURE | PICVR_ROUND_PROBE | (keep ? PICVR_ROUND_KEEP : 0u) |
               (other ? PICVR_ROUND_FORCED : 0u);
    }
    return picvr_dauto_chosen_flags(a);
}

/* After a round of a measuring context (flags): its device time dev_ms over
   `blocks` (the kind's cost, unless `first`: a variant's first dispatch compiles inside
   the timestamps); in a measured round `count` samples whose squared deviations and
   means' variances summed to sum_d and sum_m (2^-16 units); then the choice, which
   moves only past PICVR_DAUTO_SWITCH either way (a ratio that close to 1 is within the
   measurement's noise, and either kind is then about as good). */
static void picvr_dauto_account(picvr_dauto *a, uint32_t flags, double dev_ms, uint32_t blocks, int first,
                                uint32_t count, uint64_t sum_d, uint64_t sum_m) {
    if (!a->on) return;
    int k = (flags & PICVR_ROUND_FORCED) != 0;
    a->rounds++;
    if (a->scale_age) a->scale_age++;
    /* Rule: a variant's first round (its compile, seconds on lavapipe) counts toward
       neither kind's time nor cost */
    if (!first) {
        for (int i = 0; i < 2; i++) a->time_ms[i] *= 1.0 - 1.0 / PICVR_AUTO_WINDOW;
        a->time_ms[k] += dev_ms;
        if (blocks > 0) a->cost[k] = picvr_moving_average(a->cost[k], dev_ms / blocks);
    }
    /* Every measured round's samples count alike, whatever the scale they were measured
       at (it is divided out): the kinds' variances are the scene's, so the sums converge,
       and a rare bright sample moves them by its share of all samples, not of one round.
       Rule: a round measured without a scale (0) counts nothing. */
    if ((flags & PICVR_ROUND_MEASURE) && count > 0 && a->scale > 0.0f) {
        double s2 = (double)a->scale * a->scale;
        a->spread_sum[k] += ((double)sum_d - (double)sum_m) / 65536.0 / s2;
        a->spread_count[k] += count;
        a->measured[k]++;
    }
    double e = picvr_dauto_efficiency(a), v[2];
    int want = !(e > 0.0) ? a->forced : e > PICVR_DAUTO_SWITCH ? 1 : e < 1.0 / PICVR_DAUTO_SWITCH ? 0 : a->forced;
    if (want != a->forced && picvr_dauto_spreads(a, v)) {
        a->restart = v[a->forced] > 2.0 * v[want];
        a->forced = want;
    }
}

/* Forgets the measurements (the scene changed: lights, medium, scattering). */
static void picvr_dauto_forget(picvr_dauto *a) {
    memset(a, 0, sizeof *a);
}
