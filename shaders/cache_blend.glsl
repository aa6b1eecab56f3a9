// cache_blend.glsl - the consistent cached estimator (render_lookup.comp, CACHE_BLEND):
// a cache hit's shading is blended with a plain Monte-Carlo estimate at the same event,
// so that each pixel converges to the unbiased image however wrong the cache is.
//
// At a hit with cached radiance C (Eq. 7, 8, 11) a probe, drawn with probability q,
// shades the same event by plain Monte Carlo, P (the random numbers after the hit's, so
// independent of C; plain_cached_part: with USE_BOUNCES C and P are the multiply
// scattered part only, the event's direct light being shaded alike either way).  The
// sample is
//     Y = C + (w / q) 1[probe] (P - C),
// with w and q fixed before the probe is drawn (from the pixel's earlier samples), so
//     E[Y] = E[C] + w b,   b = E[P - C], the cache's bias at this pixel's hits:
// the sample's bias is (1 - w) b.  w = 0 is the paper's cached estimator, w = 1 an
// unbiased one.  d = 1[probe] (P - C) / q is an unbiased sample of b whatever q is; each
// pixel keeps sum d, sum d^2 and its hit count m (binding 21), whence
//     b^ = mean d,   V = var(d) / m, the variance of b^.
// The weight that minimises the mean squared error of C + w b^ is b^2 / (b^2 + V); with
// b^2 estimated without bias by b^2 - V it is
//     w = max(0, 1 - V / b^^2)   (the positive-part James-Stein weight),
// and q = max(w, probe_fraction), so the unbiased part is sampled as often as it is
// weighted: w / q <= 1, and Y's variance stays within those of C and P together.  Where
// w >= probe_fraction the event is routed instead (blend_route): same sample, no lookup.
// Consistency: where b != 0, V -> 0 as m grows, so w -> 1 and the bias of later samples
// (1 - w) b -> 0; the pixel mean's bias, the mean of (1 - w_i) b over its samples, goes
// to 0 (a Cesaro mean).  Where b = 0 there is nothing to remove.  The statistics of the
// pixel's 3x3 neighbourhood, pooled, give a second weight and the larger one is used:
// neighbours share entries, so their common bias shows about 9x sooner, and a larger
// weight only moves the sample toward the unbiased one (the argument above holds with
// w >= the pixel's own weight).  The sums are float: they steer a weight, never a pixel.

layout(set = 0, binding = 21, std430) buffer CacheBlend { vec4 cache_blend[]; };  // sum d, sum d^2, m (uint bits), -

// The weight from the sums (s1 = sum d, s2 = sum d^2) of m hits.
// Rules: m < 2 -> 0 (no variance estimate yet); b^ = 0 -> 0 (no sign of a bias);
// var < 0 from rounding -> 0, so a constant nonzero difference gives 1; sums that
// overflowed (non-finite) -> 1, the unbiased estimator.
float blend_weight(float s1, float s2, float m) {
    if (m < 2.0) return 0.0;
    if (isinf(s1) || isinf(s2) || isnan(s1) || isnan(s2)) return 1.0;
    float b = s1 / m;
    if (b == 0.0) return 0.0;
    float var_mean = max(s2 - s1 * b, 0.0) / ((m - 1.0) * m);
    float w = 1.0 - var_mean / (b * b);
    return isnan(w) ? 1.0 : clamp(w, 0.0, 1.0);
}

// The weight for pixel px: the larger of its own and its 3x3 neighbourhood's.  The
// neighbours' statistics may be updated by this dispatch as they are read; a stale value
// only delays the weight.
float pixel_blend_weight(uvec2 px) {
    vec4 own = cache_blend[px.y * scene.image.x + px.x];
    float w = blend_weight(own.x, own.y, float(floatBitsToUint(own.z)));
    vec3 pool = vec3(0.0);
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            ivec2 q = ivec2(px) + ivec2(dx, dy);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, ivec2(scene.image.xy)))) continue;
            vec4 s = cache_blend[uint(q.y) * scene.image.x + uint(q.x)];
            pool += vec3(s.xy, float(floatBitsToUint(s.z)));
        }
    return max(w, blend_weight(pool.x, pool.y, pool.z));
}

// Routing, the blend without its wasted lookups: where w >= probe_fraction the blend's
// sample is P with probability q = w and C otherwise, so such an event goes straight to
// plain shading with probability w, before the lookup it would not use, and a hit that
// was not routed keeps C (blend_hit).  The sample has the blend's distribution,
// E = w E[P] + (1 - w) E[C] = E[C] + w b, at the cost of plain Monte Carlo where the
// cache's bias is established.  Where w < probe_fraction nothing is routed: the blend's
// sample C + (w/q)(P - C) then has the smaller variance.
bool blend_route(inout Rng rng, float w) {
    return w >= scene.probe_fraction && rnd(rng) < w;
}

// The cache's gain at a probe, for the automatic mode's economics (host/schedule.c): the
// share of the pixel's sample variance S^2 that plain shading's noise at the event makes,
// g = (lum(P - C)^2 - b^2) / S^2, clamped to [0, 1] (a hit removes that share; the bias
// part b^2 of the squared difference is not noise).  Added in units of 2^-16 to a 64-bit
// sum in two words (the high word takes the carry), with the count of probes.
// Rules: S^2 undefined (n < 2) or 0 -> not counted; a non-finite g -> not counted.
void count_gain(uint idx, float diff, float bias) {
    vec4 st = accum_stat[idx];
    float n = float(floatBitsToUint(st.z));
    if (n < 2.0 || !(st.y > 0.0)) return;
    float g = (diff * diff - bias * bias) / (st.y / (n - 1.0));
    if (isnan(g) || isinf(g)) return;
    uint units = uint(clamp(g, 0.0, 1.0) * 65536.0);
    ATOMIC_ADD64(cache_counters.gain_lo, cache_counters.gain_hi, units)
    atomicAdd(cache_counters.probes, 1u);
}

// Whether a hit is probed: drawn with q = probe_fraction (blend_sample says why).
bool blend_probe(inout Rng rng) { return rnd(rng) < scene.probe_fraction; }

// The hit sample Y (albedo and the path's throughput included) of pixel idx whose cached
// shading is `cached`, w the pixel's weight (pixel_blend_weight, taken before the
// routing), `plain` the plain estimate P of the same part when `probed` (blend_probe);
// records d in the pixel's sums.  The probe is drawn with q = probe_fraction: where
// w >= q the routing carried the weight and Y = C (the probe only feeds the
// statistics); below, Y = C + (w/q) 1[probe] (P - C).  Rule: a non-finite difference
// (only from extreme user input) is not recorded and the sample is the cached one.
vec3 blend_sample(uint idx, vec3 cached, float w, bool probed, vec3 plain) {
    float q = scene.probe_fraction;
    float wy = w >= q ? 0.0 : w;
    vec3 y = cached;
    float d = 0.0;
    vec4 s = cache_blend[idx];
    uint m = floatBitsToUint(s.z);
    if (probed) {
        vec3 diff = plain - cached;
        float dl = luminance(diff);
        d = dl / q;
        if (isinf(d) || isnan(d)) return cached;
        y = cached + (wy / q) * diff;
        count_gain(idx, dl, m > 0u ? s.x / float(m) : 0.0);
    }
    cache_blend[idx] = vec4(s.x + d, s.y + d * d, uintBitsToFloat(m + 1u), 0.0);
    return y;
}

// blend_sample at the camera ray's first scatter event e, P drawn by plain_cached_part.
vec3 blend_hit(inout ScatterEvent e, vec3 cached, float w) {
    bool probed = blend_probe(e.rng);
    return blend_sample(e.idx, cached, w, probed, probed ? plain_cached_part(e) : vec3(0.0));
}
