// cache.glsl - the irradiance cache (paper §4.2-§4.4, §5.1), shared by the cached
// rendering procedure and the entry-creation procedure: the entry, node, reference
// and request pools, the local frame, lookup with extrapolation (Eq. 7, 8, 11 and the
// Fig. 4 discard), insertion into the multi-reference octree, and node locks.
// The scalar formulas live in cache_math.glsl, which the host tests compile in double
// precision.  Specialization (specialization.glsl): MONO_CHANNEL, the lights' channel
// when they share one chromaticity; SCREEN_LOCKING, the locking mode;
// CACHE_MAX_LOOKUP_REFS, the walk's bound.
#include "specialization.glsl"
#include "scene.glsl"
#include "geometry.glsl"
#include "views.glsl"
#include "medium.glsl"
#include "phase.glsl"
#include "cache_math.glsl"
#include "mutation.glsl"

#define CACHE_MAX_DEPTH 10u        // octree depth limit (root = 0)
#define CACHE_NIL 0u               // index 0 of the ref pool, and as a child index, means "none"
#define CACHE_NO_NODE 0xffffffffu  // descend_create failed (node 0 is the root)

// One entry: centre, irradiance E_0 at the centre (RGB), virtual extinction per
// half-axis and channel (Eq. 6) and validity radius per half-axis (Eq. 9, 10).
// Half-axis order: +t, -t, +b, -b, +n, -n of the local frame (see entry_normal).
// RGB, not luminance plus colour: lights of different colours have different spatial
// falloff (e.g. a red light on one side, a blue one on the other), which one shared
// sigma_v per half-axis cannot extrapolate; the radius is the smallest over channels.
struct Entry {
    vec4 pos_rmax;        // xyz centre (world), w = largest of the six radii
    vec4 e0;              // rgb E_0, w the entry's offset delta_e (world; entry_delta)
    vec3 normal;          // n of the local frame (t, b = basis(n))
    uint medium_f;        // 1 - medium_fraction of +n (low 16 bits) and -n (high), unorm16;
                          // 0: f = 1, the paper's Eq. 6 secant (cache_math.glsl)
    float sigma_v[18];    // [half-axis * 3 + channel], per world unit
    uint radius[6];       // per half-axis, world units, as float bits: positive floats
                          // order like their bits, so the update procedure can shrink
                          // a radius with atomicMin
};

struct Node { uint children; uint refs; uint lock; uint pad; };  // children: first of 8
struct Ref { uint entry; uint next; };
struct Request { vec4 pos; uint node; uint pad0; uint pad1; uint pad2; };

layout(set = 0, binding = 9, std430) buffer CacheEntries { Entry entries[]; };
layout(set = 0, binding = 10, std430) coherent buffer CacheNodes { Node nodes[]; };
layout(set = 0, binding = 11, std430) coherent buffer CacheRefs { Ref refs[]; };
layout(set = 0, binding = 12, std430) coherent buffer CacheCounters {
    uint dispatch_x, dispatch_y, dispatch_z;   // indirect dispatch of the creation procedure
    uint request_count;
    uint entry_count, node_count, ref_count, full;
    uint hits, misses, requests;
    uint capped;          // entries stored without Eq. 5 met at the sample cap (cache_create)
    uint point_rounds;    // creation rounds of the stored entries' points (128 samples each);
                          // wraps at 2^32, the host sums the differences
    uint truncated;       // creation samples with a transmittance estimate cut at its loop bound
    uint lookups_cut;     // octree walks stopped at CACHE_MAX_LOOKUP_REFS (walk_next)
    uint lookups_spilled; // lookups with more than LOOKUP_CANDIDATES candidates (cache_lookup)
    uint routed;          // scatter events the blend sent to plain shading unlooked (blend_route)
    uint probes;          // probes whose gain was counted (count_gain)
    uint gain_lo, gain_hi; // their gain, 64 bits in units of 2^-16 (count_gain)
} cache_counters;
// Multiply scattered entries only (USE_BOUNCES; a 16-byte placeholder otherwise, which
// no kernel then reads): entry e's moment, xyz the fluence's first moment over the
// fluence at its centre, a = F / E (luminance; |a| <= 1), for anisotropic phase
// functions (ms_inscattered); w the centre's sample count (cache_create.comp,
// refine_main).
layout(set = 0, binding = 22, std430) buffer CacheMoments { vec4 entry_moments[]; };
layout(set = 0, binding = 13, std430) buffer CacheRequests { Request requests[]; };
// Screen-space locking (§5.2): per superpixel a lock, then two sets of (rays, misses)
// counters: round i counts into set i & 1 and reads the ratio of the other set (the
// previous round), which the host then clears for round i + 1.
layout(set = 0, binding = 14, std430) coherent buffer CacheSuperpixels { uint superpixels[]; };
#define LOCK_SUPERPIXEL 0x80000000u   // request.node: a superpixel index, not a node

float entry_radius(uint e, uint h) { return uintBitsToFloat(entries[e].radius[h]); }
// The medium fraction of entry e's half-axis +n (neg false) or -n (neg true).
float entry_medium_fraction(uint e, bool neg) {
    vec2 q = unpackUnorm2x16(entries[e].medium_f);
    return 1.0 - (neg ? q.y : q.x);
}
// The entry's minimum radius, scaled like its offset (cache_math.glsl, entry_r_min).
float entry_r_min_of(uint e) {
    return CM_FN(entry_r_min)(scene.radius_min, entries[e].e0.w, scene.delta);
}
// Its maximum radius (cache_math.glsl, entry_r_max).
float entry_r_max_of(uint e) {
    return CM_FN(entry_r_max)(scene.radius_max, entries[e].e0.w, scene.delta);
}

// ---- local frame: n is the normalized gradient of extinction (central differences of
// sigma_t_in_box, so that a face of the volume's box is a face of the medium),
// t and b follow from n by basis() (§4.2).  Rule: where the gradient vanishes (|grad|
// below 1e-6 of D per voxel, e.g. a homogeneous region or D = 0) n = +z, whose basis is
// the world axes.
// §4.2 recomputes the frame at every lookup to save memory; picvr computes it once, at
// creation, and stores n (16 bytes of the entry's 144): six extinction lookups per
// candidate entry cost a large share of the rendering time, growing with the cache
// (docs/cache.md, "What it does").  t and b are recomputed from the stored n bit for bit.
vec3 entry_normal(vec3 p) {
    vec3 h = scene.box_size / vec3(scene.dims.xyz);
    vec3 g = vec3(sigma_t_in_box(p + vec3(h.x, 0, 0)) - sigma_t_in_box(p - vec3(h.x, 0, 0)),
                  sigma_t_in_box(p + vec3(0, h.y, 0)) - sigma_t_in_box(p - vec3(0, h.y, 0)),
                  sigma_t_in_box(p + vec3(0, 0, h.z)) - sigma_t_in_box(p - vec3(0, 0, h.z))) / (2.0 * h);
    float gl = length(g);
    if (!(gl > 1e-6 * scene.density / scene.min_spacing)) return vec3(0, 0, 1);
    return g / gl;
}

// The frame of entry e (its stored n).
void entry_axes(uint e, out vec3 t, out vec3 b, out vec3 n) {
    n = entries[e].normal.xyz;
    basis(n, t, b);
}

// ---- lookup (rendering) ----
// Entry e's prediction at x: its Eq. 11 weight (0: x outside its zone), ln E per
// channel (Eq. 7, 8), and x's local coordinates (for the update procedure).
struct Prediction { float w; vec3 lnE; vec3 local; };

// Whether x lies in entry e's bounding sphere (the cheap test before the zone's).
bool sphere_holds(uint e, vec3 x) {
    vec3 dx = x - entries[e].pos_rmax.xyz;
    float rmax = entries[e].pos_rmax.w;
    return dot(dx, dx) < rmax * rmax;
}

// Where x lies in entry e's zone: its local coordinates l, the half-axes of its octant,
// its distance from the centre and the radius of the octant's elliptic section in
// x's direction (Fig. 4); x is inside when dist < r.
struct Zone { vec3 l; uvec3 half_axis; float dist; float r; };

Zone zone_at(uint e, vec3 x) {
    Zone z;
    vec3 dx = x - entries[e].pos_rmax.xyz;
    vec3 t, b, n;
    entry_axes(e, t, b, n);
    z.l = vec3(dot(dx, t), dot(dx, b), dot(dx, n));
    z.half_axis = uvec3(0u, 2u, 4u) + uvec3(lessThan(z.l, vec3(0.0)));
    vec3 a = abs(z.l);
    z.dist = length(z.l);                                    // the zone is an ellipsoid
    z.r = CM_FN(ellipsoid_radius)(a.x, a.y, a.z, entry_radius(e, z.half_axis.x),
                                  entry_radius(e, z.half_axis.y), entry_radius(e, z.half_axis.z));
    return z;
}

bool zone_holds(uint e, vec3 x) {
    Zone z = zone_at(e, x);
    return z.dist < z.r;
}

Prediction predict(uint e, vec3 x) {
    Prediction pr;
    pr.w = 0.0;
    pr.lnE = vec3(0.0);
    pr.local = vec3(0.0);
    if (!sphere_holds(e, x)) return pr;                      // cheap sphere test first
    Zone z = zone_at(e, x);
    vec3 l = z.l;                                            // local coordinates
    pr.local = l;
    uvec3 half_axis = z.half_axis;
    vec3 a = abs(l);
    float dist = z.dist, r = z.r;
    if (!(dist < r)) return pr;
    float w = CM_FN(weight)(dist, r);
    if (!(w > 0.0)) return pr;
    float d1 = CM_FN(length1)(a.x, a.y, a.z);               // the distance of Eq. 7 (see length1)
    float delta_e = entries[e].e0.w;
    // The medium model (cache_math.glsl, medium_coord) stretches the n coordinate; u = a
    // when it is off (medium_f = 0) or the axis stays in the medium.
    vec3 u = a;
    if (entries[e].medium_f != 0u)
        u.z = CM_FN(medium_coord)(a.z, entry_medium_fraction(e, l.z < 0.0), delta_e);
    bool stretched = u.z > a.z;
    float d1u = CM_FN(length1)(u.x, u.y, u.z);
    float rmin_e = entry_r_min_of(e), rmax_e = entry_r_max_of(e);
    // Lights of one chromaticity (scene.light_log_k): only their channel m is
    // extrapolated, the others follow below.  A specialization constant.
    const uint m = MONO_CHANNEL;
    uint c_end = m < 3u ? m + 1u : 3u;
    for (uint c = m < 3u ? m : 0u; c < c_end; c++) {
        float sx = entries[e].sigma_v[half_axis.x * 3u + c];
        float sy = entries[e].sigma_v[half_axis.y * 3u + c];
        float sz = entries[e].sigma_v[half_axis.z * 3u + c];
        float s = MUTATE(MUT_EXTRAPOLATION, CM_FN(sigma_interp)(sx, sy, sz, u.x, u.y, u.z));  // Eq. 8
        // Fig. 4: discard beyond the validity radius of the interpolated sigma_v.
        if (!(d1 <= CM_FN(interp_validity_radius)(sx, sy, sz, a.x, a.y, a.z, delta_e,
                                                  scene.epsilon, rmin_e,
                                                  rmax_e))) return pr;
        float lnE = CM_FN(log_extrapolate)(entries[e].e0[c], s, d1u);  // Eq. 7 in log space
        if (stretched)
            lnE = CM_FN(medium_bound)(lnE, CM_FN(ln_irradiance)(entries[e].e0[c]), sx, sy, sz,
                                      delta_e, scene.epsilon);
        pr.lnE[c] = lnE;
    }
    // E_c = (k_c / k_m) E_m at every point, so ln E_c = ln E_m + ln(k_c / k_m), clamped
    // like every ln E (san_ln): k_c = 0 (ratio code CM_LN_E_MIN - CM_LN_E_MAX) and a
    // zero E_m give the code for 0, as the three-channel path does.
    if (m < 3u)
        for (uint c = 0u; c < 3u; c++)
            if (c != m) pr.lnE[c] = CM_FN(san_ln)(pr.lnE[m] + scene.light_log_k[c]);
    pr.w = w;
    return pr;
}

// Adds entry e's extrapolation at x to the log-space weighted sums of Eq. 11.
// With USE_BOUNCES also the weighted sum of the entries' first moments (sum_wa).
void eval_entry(uint e, vec3 x, inout float sum_w, inout vec3 sum_wlog, inout vec3 sum_wa) {
    Prediction pr = predict(e, x);
    if (!(pr.w > 0.0)) return;
    sum_w += pr.w;
    sum_wlog += pr.w * pr.lnE;
    if (USE_BOUNCES) sum_wa += pr.w * entry_moments[e].xyz;
}

// The multiply scattered radiance scattered at x toward -d (d the direction the ray
// arrives in) from the fluence E and its first moment over it, a = F / E: with the
// radiance arriving from w taken to first order, L(w) = (E + 3 F . w) / (4 pi), and a
// phase function of mean cosine g_bar (both lobes), integral p L = (E + 3 g_bar F . d)
// / (4 pi) = E (1 + 3 g_bar a . d) / (4 pi).  Rule: a first-order radiance can go
// negative where the field is strongly directional; the factor is clamped at 0 (never
// negative light; its bias is the blend's to remove).  Isotropic (g_bar = 0): E / (4 pi).
vec3 ms_inscattered(vec3 E, vec3 a, Phase ph) {
    if (!USE_HG) return E * INV_4PI;
    float g_bar = mix(ph.g, scene.back_g, scene.back_weight);
    return E * INV_4PI * max(0.0, 1.0 + 3.0 * g_bar * dot(a, ph.d));
}

// One step down the octree: the child of first-child index ch whose octant of the
// node [lo, lo + size] contains x; lo and size become the child's.
uint child_containing(uint ch, vec3 x, inout vec3 lo, inout vec3 size) {
    size *= 0.5;
    uvec3 o = uvec3(greaterThanEqual(x, lo + size));
    lo += vec3(o) * size;
    return ch + o.x + 2u * o.y + 4u * o.z;
}

// ---- the octree walk: every reference of every node on x's path from the root to the
// deepest node enclosing x (an entry is referenced wherever its zone may reach, §4.4),
// shared by the lookup and the update procedure.
// Bounded in total, not per node: llvmpipe cuts an invocation's loops past 65535
// iterations in all (docs/lavapipe.md), and a render invocation's tracking loops
// (at most 5 x MAX_TRACK_STEPS with the error view) leave room for 8192 references
// (two loop iterations each, with walk_next's descent loop), the 11 levels and the
// lookup's two passes over its candidates (cache_lookup).  A walk
// that reaches the bound with references left says so in cache_counters.lookups_cut
// (stats.cache_lookups_cut) and ignores the rest.  The bound is cache.max_lookup_refs
// (CACHE_MAX_LOOKUP_REFS, a specialization constant, at most the default; picvr.h).
// Not per node: lists grow
// long (entries flat along n but wide along t, b sit high in the tree), and a lookup that
// missed the entries past a per-node bound created redundant ones (docs/cache.md,
// "Long lists").
// A walk's bound (at most CACHE_MAX_LOOKUP_REFS; creation's lookups take a smaller one out
// of their sample's loop budget) and the entries a lookup may use: those below
// lookup_entry_limit.  Rendering and update read the cache after a barrier and use all;
// creation looks up while other workgroups of its dispatch insert, so it uses only the
// entries of earlier rounds (complete before its submission) and a walk may follow a
// reference being pushed (push_ref): its stale `next` is an old reference or NIL, so the
// walk stays bounded and only visits entries whose zone test decides, as for any other.
uint walk_cap = CACHE_MAX_LOOKUP_REFS;
uint lookup_entry_limit = 0xffffffffu;
struct CacheWalk { uint node; uint ref; uint visited; vec3 lo; vec3 size; };

CacheWalk walk_start() {
    CacheWalk w;
    w.node = 0u;
    w.ref = nodes[0].refs;
    w.visited = 0u;
    w.lo = scene.box_min;
    w.size = scene.box_size;
    return w;
}

// Moves w one level down x's path; false at the deepest node.
bool walk_descend(inout CacheWalk w, vec3 x) {
    uint ch = nodes[w.node].children;
    if (ch == CACHE_NIL) return false;
    w.node = child_containing(ch, x, w.lo, w.size);
    w.ref = nodes[w.node].refs;
    return true;
}

// The next entry e referenced on x's path: true, or false at the path's end or the
// bound.  The tree is at most CACHE_MAX_DEPTH deep (descend_create), so the descent
// loop's bound is never the reason to stop.
bool walk_next(inout CacheWalk w, vec3 x, out uint e) {
    e = 0u;
    for (uint d = 0u; d <= CACHE_MAX_DEPTH && w.ref == CACHE_NIL; d++)
        if (!walk_descend(w, x)) return false;
    if (w.ref == CACHE_NIL) return false;
    if (w.visited >= walk_cap) {
        atomicAdd(cache_counters.lookups_cut, 1u);
        w.ref = CACHE_NIL;
        return false;
    }
    w.visited++;
    e = refs[w.ref].entry;
    w.ref = refs[w.ref].next;
    return true;
}

// The deepest node enclosing x (for locking), also after a walk cut at the bound.
uint walk_deepest(inout CacheWalk w, vec3 x) {
    for (uint d = 0u; d <= CACHE_MAX_DEPTH && walk_descend(w, x); d++) {}
    return w.node;
}

// Whether x lies within a voxel of entry e's centre (VIEW_CACHE marks the centres).
bool near_entry_centre(uint e, vec3 x) {
    vec3 d = x - entries[e].pos_rmax.xyz;
    return dot(d, d) < scene.min_spacing * scene.min_spacing;
}

// The entries on x's walk whose zone holds x, in walk order: candidate[0, n).  In
// passes, so that the lanes of a SIMD unit (llvmpipe's 8, a GPU's warp) run each
// pass's work together: the walk keeps the entries whose bounding sphere holds x (up
// to LOOKUP_CANDIDATES), a second pass those whose zone holds it, and the caller
// extrapolates only those.  Done per reference, the lanes waited for any one lane's
// prediction at most steps (docs/cache.md, "The lookup in three passes").  Returns
// true when more entries'
// spheres hold x than the buffer takes: then `next` is the first of them past the
// buffer and w goes on after it, for the caller to take one at a time, after the
// buffer's, so that it sees them in walk order either way (stats.cache_lookups_spilled).
// near_centre (VIEW_CACHE) looks at every visited entry up to `next`.  Loop bound: the
// second pass adds LOOKUP_CANDIDATES iterations to the walk's (walk_next).
#define LOOKUP_CANDIDATES 64u
bool zone_candidates(vec3 x, inout CacheWalk w, out uint candidate[LOOKUP_CANDIDATES], out uint n,
                     out uint next, inout bool near_centre) {
    n = 0u;
    bool spilled = false;
    while (walk_next(w, x, next)) {
        if (USE_DEBUG_VIEW && scene.debug_view == VIEW_CACHE) near_centre = near_centre || near_entry_centre(next, x);
        if (next >= lookup_entry_limit || !sphere_holds(next, x)) continue;
        if (n == LOOKUP_CANDIDATES) { spilled = true; break; }
        candidate[n++] = next;
    }
    uint m = 0u;
    for (uint i = 0u; i < n; i++)
        if (zone_holds(candidate[i], x)) candidate[m++] = candidate[i];
    n = m;
    if (spilled) atomicAdd(cache_counters.lookups_spilled, 1u);
    return spilled;
}

// Looks x up in the octree: true and the extrapolated irradiance when entries cover
// it (Eq. 11); always returns the deepest existing node enclosing x (for locking).
// aniso: with USE_BOUNCES the weighted mean of the covering entries' first moments
// (Eq. 11's weights, linear: a is bounded and smooth).
bool cache_lookup(vec3 x, out vec3 E, out vec3 aniso, out uint deepest, out bool near_centre) {
    near_centre = false;
    float sum_w = 0.0;
    vec3 sum_wlog = vec3(0.0), sum_wa = vec3(0.0);
    aniso = vec3(0.0);
    CacheWalk w = walk_start();
    uint candidate[LOOKUP_CANDIDATES];
    uint n, e;
    bool spilled = zone_candidates(x, w, candidate, n, e, near_centre);
    for (uint i = 0u; i < n; i++) eval_entry(candidate[i], x, sum_w, sum_wlog, sum_wa);
    if (spilled)
        do {
            if (USE_DEBUG_VIEW && scene.debug_view == VIEW_CACHE) near_centre = near_centre || near_entry_centre(e, x);
            if (e < lookup_entry_limit) eval_entry(e, x, sum_w, sum_wlog, sum_wa);
        } while (walk_next(w, x, e));
    deepest = walk_deepest(w, x);
    E = vec3(0.0);
    if (!CM_FN(log_average_valid)(sum_w)) return false;
    for (uint c = 0u; c < 3u; c++) E[c] = MUTATE(MUT_CACHE, CM_FN(log_average_finalize)(sum_wlog[c], sum_w));
    if (USE_BOUNCES) aniso = sum_wa / sum_w;   // sum_w valid (> 0, finite) here
    return true;
}

void cache_unlock(uint locked) {
    if ((locked & LOCK_SUPERPIXEL) != 0u) atomicExchange(superpixels[locked & ~LOCK_SUPERPIXEL], 0u);
    else atomicExchange(nodes[locked].lock, 0u);
}

// Queues a creation request for x holding `locked`; released again when this round
// already has `cap` requests.
void queue_request(vec3 x, uint locked, uint cap) {
    if (cache_counters.full != 0u) {               // the cache no longer grows
        cache_unlock(locked);
        return;
    }
    uint slot = atomicAdd(cache_counters.request_count, 1u);
    if (slot >= min(cap, scene.max_requests)) {
        cache_unlock(locked);
        return;
    }
    atomicAdd(cache_counters.requests, 1u);
    requests[slot].pos = vec4(x, 0.0);
    requests[slot].node = locked;
    atomicMax(cache_counters.dispatch_x, slot + 1u);
}

uint superpixel_of(uvec2 px) {
    uvec2 sp = px / scene.superpixel_side;
    return sp.y * scene.superpixels_per_row + sp.x;
}

// Counts a scatter event of this round in its superpixel (screen-space locking).
void count_ray(uvec2 px, bool miss, uint round) {
    uint n = scene.superpixel_count;
    uint base = n + 2u * n * (round & 1u) + 2u * superpixel_of(px);
    atomicAdd(superpixels[base], 1u);
    if (miss) atomicAdd(superpixels[base + 1u], 1u);
}

// A cache miss at x (pixel px): asks for a new entry under the chosen locking.
// Object space (§5.1): lock the deepest node enclosing x; one request per node.
// Screen space (§5.2): one request per superpixel at a time, and only if a random
// number falls below the superpixel's ratio of misses to rays in the previous
// round, so well-covered regions rarely ask (the first round, with no history, always
// asks).  Either way a refused request is simply dropped: the event is shaded
// by plain Monte Carlo.
void cache_request(vec3 x, uint node, uvec2 px, uint round, float u, uint cap) {
    // Plain reads first (test and test-and-set): once this round's requests are all
    // queued, or the node is locked - the common case for a miss - no atomic is spent.
    // Both reads may be stale; the atomics below decide, so this only saves work (on
    // lavapipe three atomics per miss are a large share of the render time).
    if (cache_counters.request_count >= min(cap, scene.max_requests)) return;
    if (!SCREEN_LOCKING) {
        if (nodes[node].lock != 0u) return;
        if (atomicCompSwap(nodes[node].lock, 0u, 1u) != 0u) return;
        queue_request(x, node, cap);
        return;
    }
    uint n = scene.superpixel_count, sp = superpixel_of(px);
    uint prev = n + 2u * n * ((round + 1u) & 1u) + 2u * sp;
    uint rays = superpixels[prev], misses = superpixels[prev + 1u];
    float ratio = rays > 0u ? float(misses) / float(rays) : 1.0;
    if (!(u < ratio)) return;
    if (superpixels[sp] != 0u) return;
    if (atomicCompSwap(superpixels[sp], 0u, 1u) != 0u) return;
    queue_request(x, sp | LOCK_SUPERPIXEL, cap);
}

// ---- insertion (creation procedure) ----
// The depth whose nodes are at least CACHE_NODE_RADII times the entry's largest radius
// along every axis.  With 1, the entry's bounding box (2 rmax wide) overlaps at most
// 3 x 3 x 3 nodes there.  Why not 2 (at most 2 x 2 x 2 nodes, fewer references per
// entry): a lookup visits every reference of the nodes on its path, and with nodes twice
// as large those lists hold many more entries that do not cover the point, so the
// cached renderer slowed down as the cache grew.  The price: more references per entry,
// fewer since the oriented bounding box decides too (zone_reaches).  host/cache.c
// (picvr_cache_scene_params) mirrors this rule for the pre-built top of the tree.
#define CACHE_NODE_RADII 1.0
uint insertion_depth(float rmax) {
    float edge = min(scene.box_size.x, min(scene.box_size.y, scene.box_size.z));
    uint depth = 0u;
    while (depth < CACHE_MAX_DEPTH && edge * 0.5 >= CACHE_NODE_RADII * rmax) { edge *= 0.5; depth++; }
    return depth;
}

// Integer cell of point q at `depth` (clamped to the box).
uvec3 cell_at(vec3 q, uint depth) {
    float n = float(1u << depth);
    vec3 f = (q - scene.box_min) / scene.box_size * n;
    return uvec3(clamp(f, vec3(0.0), vec3(n - 1.0)));
}

// The node of `cell` at `depth`, creating missing nodes on the way down.  Lock-free:
// 8 children are allocated speculatively and published with a compare-and-swap; a
// loser's allocation stays unused until the pools are cleared.  Returns CACHE_NO_NODE
// (and sets `full`) when the node pool is exhausted.
uint descend_create(uvec3 cell, uint depth) {
    uint node = 0u;
    for (uint d = 0u; d < depth; d++) {
        uint shift = depth - 1u - d;
        uvec3 o = (cell >> shift) & 1u;
        uint ch = nodes[node].children;
        if (ch == CACHE_NIL) {
            uint base = atomicAdd(cache_counters.node_count, 8u);
            if (base + 8u > scene.max_nodes) { atomicExchange(cache_counters.full, 1u); return CACHE_NO_NODE; }
            uint prev = atomicCompSwap(nodes[node].children, CACHE_NIL, base);
            ch = prev == CACHE_NIL ? base : prev;
        }
        node = ch + o.x + 2u * o.y + 4u * o.z;
    }
    return node;
}

// Pushes a reference to entry e onto node's list with one atomic exchange: no retry
// loop, so no reference is lost however many threads insert into the same node (a
// bounded compare-and-swap loop drops references when a whole workgroup hits one
// node at once).  The list is briefly inconsistent between the exchange and the write
// of `next`, which is safe because nothing reads the lists while insertion runs: the
// scheduler separates the creation and rebuild dispatches from every reader by a
// barrier.
void push_ref(uint node, uint e) {
    uint r = atomicAdd(cache_counters.ref_count, 1u) + 1u;    // ref 0 is NIL
    if (r >= scene.max_refs) { atomicExchange(cache_counters.full, 1u); return; }
    refs[r].entry = e;
    refs[r].next = atomicExchange(nodes[node].refs, r);
}

// Whether an entry's zone can reach into the box [bmin, bmin + size].  The zone (the
// union of elliptic octants) lies in the sphere of its largest radius rmax around x0,
// and in its oriented bounding box (§4.4): along each axis of the frame (t, b, n), from
// -r_neg to +r_pos.  Both must overlap the box.  The oriented box is tested on the
// separating axes of the world and of the frame, 6 of the exact test's 15: it may keep
// a box that only a cross-product axis separates, never drop one the zone reaches.
// What the box adds to the sphere: an entry flat along n (lit faces, the surfaces of
// leaves) reaches far fewer of the 3 x 3 x 3 nodes around it (docs/cache.md, "Long lists").
bool zone_reaches(vec3 x0, float rmax, mat3 frame, vec3 r_pos, vec3 r_neg, vec3 bmin, vec3 size) {
    vec3 d = max(max(bmin - x0, x0 - (bmin + size)), vec3(0.0));   // sphere-box distance
    if (dot(d, d) > rmax * rmax) return false;
    vec3 c = x0 + frame * (0.5 * (r_pos - r_neg));                 // the oriented box's centre
    vec3 h = 0.5 * (r_pos + r_neg);                                 // and half extents
    mat3 af = mat3(abs(frame[0]), abs(frame[1]), abs(frame[2]));
    vec3 to_box = bmin + 0.5 * size - c;
    if (any(greaterThan(abs(to_box), af * h + 0.5 * size))) return false;             // world axes
    return !any(greaterThan(abs(to_box * frame), h + (0.5 * size) * af));             // frame axes
}

// The largest of an entry's six radii (r_pos along +t, +b, +n, r_neg along -t, -b, -n):
// the radius of its bounding sphere, stored in pos_rmax.w for the lookup's sphere test.
float largest_radius(vec3 r_pos, vec3 r_neg) {
    vec3 r = max(r_pos, r_neg);
    return max(r.x, max(r.y, r.z));
}

// Inserts entry e (centre x0, frame normal n, radii r_pos along +t, +b, +n and r_neg
// along -t, -b, -n) into cell k (0..26) of the up to 3 x 3 x 3 cells its bounding
// sphere's box overlaps at the insertion depth, if that cell exists and the zone can
// reach into it (zone_reaches).  The creation procedure runs the 27 cells on 27 threads,
// the rebuild on one thread per entry.
void insert_cell(uint e, vec3 x0, vec3 n, vec3 r_pos, vec3 r_neg, uint k) {
    float rmax = largest_radius(r_pos, r_neg);
    uint depth = insertion_depth(rmax);
    uvec3 lo = cell_at(x0 - vec3(rmax), depth), hi = cell_at(x0 + vec3(rmax), depth);
    uvec3 cell = lo + uvec3(k % 3u, (k / 3u) % 3u, k / 9u);
    if (any(greaterThan(cell, hi))) return;
    vec3 size = scene.box_size / float(1u << depth);
    vec3 bmin = scene.box_min + vec3(cell) * size;
    vec3 t, b;
    basis(n, t, b);
    if (!zone_reaches(x0, rmax, mat3(t, b, n), r_pos, r_neg, bmin, size)) return;
    uint node = descend_create(cell, depth);
    if (node != CACHE_NO_NODE) push_ref(node, e);
}
