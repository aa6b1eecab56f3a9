/* host/lights.c - lights and background: validation, packing into the uniform block,
 * the power that chooses a light, the lights equiangular sampling serves, and the scene
 * facts the kernels specialize on (delta lights only, one chromaticity for every
 * emitter).  The background's map: host/environment.c.  Part of picvr_vk.c; uses util,
 * cache, image, environment. */

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
    memcpy(g->pos, l->position, sizeof g->pos);
    g->type = (int32_t)l->type;
    memcpy(g->radiance, rad, sizeof rad);
    if (l->type == PICVR_LIGHT_SPHERE) g->size = l->radius;
    if (l->type == PICVR_LIGHT_RECT) {
        float n[3];
        picvr_cross3(l->edge_u, l->edge_v, n);
        memcpy(g->edge_u, l->edge_u, sizeof g->edge_u);
        memcpy(g->edge_v, l->edge_v, sizeof g->edge_v);
        g->area = (float)picvr_len3(n);
    }
    if (l->type == PICVR_LIGHT_DIRECTIONAL) {
        double inv = 1.0 / picvr_len3(l->direction);
        float dir[3] = {(float)(l->direction[0] * inv), (float)(l->direction[1] * inv), (float)(l->direction[2] * inv)};
        memcpy(g->pos, dir, sizeof g->pos);
        /* 1 - cos(half angle) = 2 sin^2(half angle / 2), without cancellation.  Rule:
           cones below 1e-12 sr/(2 pi) are delta lights (their radiance would overflow). */
        double s = sin(0.25 * l->angular_diameter), omc = 2.0 * s * s;
        if (omc < 1e-12) omc = 0.0;
        g->size = (float)omc;
        /* colour * intensity is the irradiance on a plane facing the sun:
           E = L * pi sin^2(h), so L = E / (pi omc (2 - omc)). */
        if (omc > 0.0)
            for (int c = 0; c < 3; c++) g->radiance[c] = (float)(rad[c] / (PICVR_PI * omc * (2.0 - omc)));
    }
}

/* A packed light's geometry (world space, as picvr_pack_light leaves it) in the volume's
   frame.  A reflection reverses cross(edge_u, edge_v), the side a rect light emits to,
   so its edges swap then (a centred rect is the same set of points either way). */
static void picvr_light_to_local(const picvr_scene *sc, picvr_gpu_light *g) {
    if (g->type == PICVR_LIGHT_DIRECTIONAL) picvr_dir_to_local(sc, g->pos, g->pos);
    else picvr_point_to_local(sc, g->pos, g->pos);
    if (g->type != PICVR_LIGHT_RECT) return;
    float u[3], v[3];
    picvr_dir_to_local(sc, g->edge_u, u);
    picvr_dir_to_local(sc, g->edge_v, v);
    memcpy(g->edge_u, sc->reflected ? v : u, sizeof u);
    memcpy(g->edge_v, sc->reflected ? u : v, sizeof v);
}

/* Every light's geometry again from the world-space lights as set (a new placement). */
static void picvr_place_lights(picvr_context *ctx) {
    for (uint32_t i = 0; i < ctx->scene.light_count; i++) {
        picvr_gpu_light w, *g = &ctx->scene.gpu.lights[i];
        picvr_pack_light(&ctx->scene.lights[i], &w);
        picvr_light_to_local(&ctx->scene, &w);
        memcpy(g->pos, w.pos, sizeof g->pos);
        memcpy(g->edge_u, w.edge_u, sizeof g->edge_u);
        memcpy(g->edge_v, w.edge_v, sizeof g->edge_v);
    }
}

static int picvr_light_is_delta(const picvr_gpu_light *g) {
    return g->type == PICVR_LIGHT_POINT || (g->type == PICVR_LIGHT_DIRECTIONAL && g->size == 0.0f);
}

/* scene.gpu.light_log_k and .mono_channel: whether every emitter (a light or the background with power) has
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

static void picvr_light_chromaticity(const float (*emit)[3], uint32_t n, float log_k[3], float *channel) {
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
                log_k[0] = log_k[1] = log_k[2] = 0.0f;
                *channel = 3.0f;
                return;
            }
    }
    /* ln(k_c / k_m) > ln(1e-45 / FLT_MAX) > -193: a float; k_c = 0 -> below the code for 0 */
    for (int c = 0; c < 3; c++)
        log_k[c] = k[c] > 0.0f ? (float)log((double)k[c] / k[m]) : -138.2f;
    *channel = (float)m;
}

/* The lights equiangular sampling serves (shaders/distance.glsl): point, sphere and rect
   lights with power whose irradiance falls off steeply across the volume, chosen in
   proportion to their power (eq_pmf, eq_cdf; the last served light's eq_cdf is exactly
   1).  The falloff: (d_far / d_near)^2 over the volume's bounding sphere (radius R),
   d_near = max(centre distance - R, the light's radius, 1e-3 R), d_far = centre distance
   + R; served above PICVR_EQ_FALLOFF.  Where the light's 1/d^2 varies less, delta tracking
   samples it as well at less cost: bonsai under a distant sphere (falloff 2) and the
   engine under three large spheres near it (falloff 15) took longer to a given error
   with equiangular sampling, a thin medium under a point light just outside it (falloff
   1700) far less (docs/sampling.md).  Sets scene.use_equiangular: some light is served,
   scene.use_forced: the forced point has a share (below), and scene.auto_rm.
   Called when the lights or the volume's box change. */
static void picvr_update_equiangular(picvr_context *ctx) {
    picvr_gpu_light *g = ctx->scene.gpu.lights;
    uint32_t n = ctx->scene.gpu.light_count;
    double R = ctx->scene.has_volume ? ctx->scene.gpu.bound_radius : 1.0, total = 0.0, cdf = 0.0;
    int served[PICVR_MAX_LIGHTS], last = -1;
    for (uint32_t i = 0; i < n; i++) {
        double d = picvr_len3(g[i].pos), size = g[i].type == PICVR_LIGHT_SPHERE ? g[i].size : 0.0;
        if (g[i].type == PICVR_LIGHT_RECT) size = 0.5 * sqrt((double)g[i].area);
        double near = fmax(fmax(d - R, size), 1e-3 * R), far = d + R;
        served[i] = g[i].type != PICVR_LIGHT_DIRECTIONAL && g[i].pmf > 0.0f &&
                    (far / near) * (far / near) > PICVR_EQ_FALLOFF;
        if (served[i]) total += g[i].pmf;
    }
    for (uint32_t i = 0; i < n; i++) {
        g[i].eq_pmf = served[i] ? (float)(g[i].pmf / total) : 0.0f;
        cdf += served[i] ? g[i].pmf / total : 0.0;
        g[i].eq_cdf = (float)cdf;
        if (served[i]) last = (int)i;
    }
    if (last >= 0) g[last].eq_cdf = 1.0f;
    /* Strategy B's forced share (PICVR_DISTANCE_FORCED; shaders/distance.glsl, b_sample):
       the power of the lights that equiangular sampling does not serve (suns, lights of
       gentle falloff), so that every ray through the medium gathers each light's share
       by one strategy or the other.  The sum of the unserved shares, not 1 minus the
       served ones: exactly 0 when every light is served.  The background and environment
       map are left out with ratio tracking: a camera ray that passes the medium sees
       them, so delta tracking's pass or collision already gathers their light with
       little variance (a white sky over a thin grey medium is nearly a furnace), and the
       forced point's split into a transmitted and an in-scattered part, the first by a
       nearly 0/1 estimate, costs more than it brings.  With ray-marched transmittance
       the transmitted part is nearly exact in smooth media and they take their share
       (docs/sampling.md).  Rule: no such power gives 0. */
    double lights_unserved = 0.0;
    for (uint32_t i = 0; i < n; i++)
        if (!served[i]) lights_unserved += g[i].pmf;
    /* PICVR_DISTANCE_AUTO where the forced point would serve no light with the default
       transmittance (every light served by equiangular sampling, or only the background
       and map): its second kind is ray-marched transmittance instead, with the forced
       point serving the background as it does with that estimator.  There the noise left
       is the transmittance estimates' (docs/sampling.md measures it); the measured
       efficiency decides, as for the forced point.  With the default estimator (residual
       tracking) only: ratio tracking, which only an application chooses, is kept. */
    int auto_rm = ctx->config.distance_sampling == PICVR_DISTANCE_AUTO &&
                  ctx->config.transmittance == PICVR_TRANSMITTANCE_RESIDUAL && !(lights_unserved > 0.0) &&
                  (n > 0 || ctx->scene.gpu.background_pmf > 0.0f);
    double unserved = lights_unserved;
    if (ctx->config.transmittance == PICVR_TRANSMITTANCE_RAY_MARCHING || auto_rm)
        unserved += ctx->scene.gpu.background_pmf;
    int forced = (ctx->config.distance_sampling == PICVR_DISTANCE_FORCED ||
                  ctx->config.distance_sampling == PICVR_DISTANCE_AUTO) && unserved > 0.0;
    /* exactly 1 when no light is served (the shaders test forced_pmf < 1 for "some light
       is served"; a rounded sum of shares could fall an ulp short) */
    ctx->scene.gpu.forced_pmf = !forced ? 0.0f : last < 0 ? 1.0f : (float)fmin(unserved, 1.0);
    ctx->scene.use_equiangular = last >= 0;
    ctx->scene.use_forced = forced;
    ctx->scene.auto_rm = auto_rm;
    /* The pool charge of a path's event (shaders/path.glsl) for its loops other than
       tracking: over the lights (choice, area-light hits, sun cones), the map's two
       binary searches and, with equiangular sampling, the segment's three passes over
       the lights and its walk through at most 3 x 64 coarse cells (a path's later
       segments draw no forced point: the camera ray's walks are charged once,
       render.glsl, camera_sample). */
    ctx->scene.gpu.vertex_cost = 4u * n + 64u + (last >= 0 ? 3u * n + 3u * PICVR_MAX_GRID : 0u);
}

picvr_status picvr_set_lights(picvr_context *ctx, const picvr_light *lights, uint32_t count,
                              const picvr_background *bg) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    if (count > PICVR_MAX_LIGHTS) return PICVR_ERROR_TOO_MANY_LIGHTS;
    if (count > 0 && !lights) return PICVR_ERROR_NULL_POINTER;
    for (uint32_t i = 0; i < count; i++) {
        picvr_status s = picvr_validate_light(&lights[i]);
        if (s) return s;
    }
    picvr_env_info env;
    picvr_status s = picvr_env_validate(ctx, bg, &env);
    if (s) return s;
    picvr_buffer env_buf;
    if ((s = picvr_env_build(ctx, bg, &env, &env_buf))) return s;
    picvr_env_install(ctx, bg, &env, &env_buf);
    /* Scene radius for the power of lights at infinity: the volume's bounding sphere
       (1 before a volume is uploaded; only the ratios matter). */
    double R = ctx->scene.has_volume ? ctx->scene.gpu.bound_radius : 1.0;
    double power[PICVR_MAX_LIGHTS + 1], total = 0.0;
    for (uint32_t i = 0; i < count; i++) total += power[i] = picvr_light_power(&lights[i], R);
    double bg_power = env.lum_omega * PICVR_PI * R * R;
    total += bg_power;

    int mis = 0;
    double cdf = 0.0;
    for (uint32_t i = 0; i < count; i++) {
        picvr_gpu_light *g = &ctx->scene.gpu.lights[i];
        picvr_pack_light(&lights[i], g);
        picvr_light_to_local(&ctx->scene, g);
        /* Rule: with zero total power every probability is 0 and nothing is sampled. */
        double pmf = total > 0.0 ? power[i] / total : 0.0;
        cdf += pmf;
        g->pmf = (float)pmf;
        g->cdf = (float)cdf;
        if (!picvr_light_is_delta(g) && pmf > 0.0) mis = 1;
    }
    float bgr[3];
    memcpy(bgr, ctx->scene.gpu.background, sizeof bgr);
    ctx->scene.gpu.background_pmf = total > 0.0 ? (float)(bg_power / total) : 0.0f;
    if (bg_power > 0.0) mis = 1;
    float emit[PICVR_MAX_LIGHTS + 1][3];
    for (uint32_t i = 0; i < count; i++)
        for (int c = 0; c < 3; c++) emit[i][c] = power[i] > 0.0 ? ctx->scene.gpu.lights[i].radiance[c] : 0.0f;
    for (int c = 0; c < 3; c++) emit[count][c] = bg_power > 0.0 ? bgr[c] : 0.0f;
    picvr_light_chromaticity((const float (*)[3])emit, count + 1, ctx->scene.gpu.light_log_k,
                             &ctx->scene.gpu.mono_channel);
    if (env.is_map && bg_power > 0.0) {   /* a map's texels need not share one chromaticity */
        memset(ctx->scene.gpu.light_log_k, 0, sizeof ctx->scene.gpu.light_log_k);
        ctx->scene.gpu.mono_channel = 3.0f;
    }
    ctx->scene.gpu.light_count = count;
    if (count) memcpy(ctx->scene.lights, lights, count * sizeof *lights);
    ctx->scene.light_count = count;
    ctx->scene.use_phase_mis = mis;
    picvr_update_equiangular(ctx);
    return picvr_light_state_changed(ctx, PICVR_OK);
}
