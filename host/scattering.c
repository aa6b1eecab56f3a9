/* host/scattering.c - how the medium scatters beyond the transfer function's albedo:
 * picvr_set_scattering (the bounce count of the path tracer, a second Henyey-Greenstein
 * lobe) and whether the phase function is anisotropic anywhere.  Part of picvr_vk.c;
 * uses cache, image. */

/* Whether the phase function is anisotropic somewhere (USE_HG): some transfer-function
   point's g, or a second lobe that is not isotropic itself. */
static int picvr_use_hg(const picvr_context *ctx) {
    const picvr_scattering *sc = &ctx->scene.scattering;
    return ctx->scene.tf_has_g || (sc->back_weight > 0.0f && sc->back_g != 0.0f);
}

/* Rules: NULL is no bounces and no second lobe; |back_g| < 1, back_weight in [0, 1).
   The cache's first moments are refitted before anything changes (a failure leaves the
   context as it was); then the cache and the accumulation are emptied. */
picvr_status picvr_set_scattering(picvr_context *ctx, const picvr_scattering *sc) {
    if (!ctx) return PICVR_ERROR_NULL_POINTER;
    PICVR_REFUSE_IF_BUSY(ctx);
    picvr_scattering z;
    memset(&z, 0, sizeof z);
    if (!sc) sc = &z;
    if (!isfinite(sc->back_g) || !isfinite(sc->back_weight)) return PICVR_ERROR_NON_FINITE;
    if (!(fabsf(sc->back_g) < 1.0f) || sc->back_weight < 0.0f || sc->back_weight >= 1.0f) return PICVR_ERROR_INVALID_ARGUMENT;
    picvr_status s = picvr_cache_fit_moments(ctx, sc->max_bounces);   /* before any change */
    if (s) return s;
    ctx->scene.scattering = *sc;
    ctx->scene.gpu.max_bounces = sc->max_bounces;
    ctx->scene.gpu.back_g = sc->back_g;
    ctx->scene.gpu.back_weight = sc->back_weight;
    return picvr_light_state_changed(ctx, PICVR_OK);
}
