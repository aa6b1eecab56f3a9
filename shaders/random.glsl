// random.glsl - random numbers: a counter-based hash of (pixel, iteration, dimension,
// seed), so that any kernel can replay a sample's stream from its pixel and counter (the
// event queues store only the counter), and per pixel low-discrepancy sequences for the
// camera sample: a randomly shifted one for the jitter and the distance of B, scrambled
// Sobol pairs for the first free flight and the first events' direct light.
#ifndef RANDOM_GLSL_ONCE
#define RANDOM_GLSL_ONCE 1
#include "specialization.glsl"
#include "sobol.glsl"

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// key and counter: the hash stream of one sample.  lattice_key and index: the sample's
// place in its pixel's low-discrepancy sequences (qmc, qmc_pair below).  event: the
// purpose whose pairs the next scatter event's direct light draws (QMC_EVENT_*; 0:
// independent numbers); flight: the next free flight and its tentative collision draw
// the QMC_FLIGHT pair.  Both are set by the camera sample's code (render.glsl,
// render_track.glsl) and cleared once used, so later events draw independent numbers.
struct Rng { uint key; uint counter; uint lattice_key; uint index; uint event; bool flight; };

Rng rng_init(uint pixel, uint iteration, uint seed) {
    Rng r;
    r.key = pcg_hash(pixel ^ pcg_hash(iteration ^ pcg_hash(seed + 0x9e3779b9u)));
    r.counter = 0u;
    r.lattice_key = pcg_hash(pixel ^ pcg_hash(seed + 0x7f4a7c15u));
    r.index = iteration;
    r.event = 0u;
    r.flight = false;
    return r;
}

// Dimension dim (0-2) of sample `index` of a randomly shifted Kronecker sequence, the
// R3 sequence (Roberts 2018: frac(shift + n alpha), alpha_d = g^-d, g the root of
// x^4 = x + 1): successive samples of a pixel fill its 3D space evenly, so smooth
// integrands over these dimensions (the pixel's jitter, the equiangular distance)
// converge faster than with independent numbers.  The shift is uniform and fixed per
// pixel (lattice_key), so every sample is uniform on its own and the estimate stays
// unbiased.  32-bit fixed point: n alpha mod 1 is exact for any n.

float qmc(Rng r, uint dim) {
    uint alpha = dim == 0u ? 3518319154u : dim == 1u ? 2882110346u : 2360945575u;
    uint x = r.index * alpha + pcg_hash(r.lattice_key + dim * 0x9e3779b9u);
    return float(x >> 8u) * (1.0 / 16777216.0);
}

// Uniform in [0,1): 24 random bits, so 1 - u is never 0.
float rnd(inout Rng r) {
    uint h = pcg_hash(r.key ^ pcg_hash(r.counter * 0x68bc21ebu + 0x02e5be93u));
    r.counter++;
    return float(h >> 8u) * (1.0 / 16777216.0);
}

// The purposes of the camera sample's further sequences (qmc_pair; one_or_rnd where one
// number is needed): the first free flight of the camera ray (its distance, then its
// tentative collision's test), B's choice between its strategies, and for the direct
// light of the first scatter event (A) and of B's point, each: +0 the light's direction,
// +1 which light, +2 the phase function's direction (also the path's next direction).
#define QMC_FLIGHT 1u
#define QMC_B_CHOICE 2u
#define QMC_EVENT_A 8u
#define QMC_EVENT_B 12u

// The seed of the pixel's sequence for `purpose`: its index shuffle and, hashed again,
// its digital shifts.
uint qmc_seed(Rng r, uint purpose) { return pcg_hash(r.lattice_key ^ (purpose * 0x2545f491u)); }

// Point `index` of the pixel's two-dimensional sequence for `purpose` (> 0): the Sobol
// pair, its index shuffled and each coordinate digitally shifted with three hashes of the
// pixel and the purpose (sobol.glsl: each point is uniform on its own, so estimates stay
// unbiased; successive points of a pixel fill the square evenly, and two purposes visit
// the sequence in unrelated orders).  24 bits each.
vec2 qmc_pair(Rng r, uint purpose) {
    uint seed = qmc_seed(r, purpose);
    uint shift_x = pcg_hash(seed), shift_y = pcg_hash(shift_x);
    uint i = cm_sobol_shuffle(r.index, seed);
    uint x = cm_sobol_x(i) ^ shift_x, y = cm_sobol_y(i) ^ shift_y;
    return vec2(float(x >> 8u), float(y >> 8u)) * (1.0 / 16777216.0);
}

// The pair for purpose `purpose` from the pixel's sequence with USE_QMC when `use`, else
// two independent numbers.
vec2 pair_or_rnd(inout Rng r, bool use, uint purpose) {
    if (USE_QMC && use) return qmc_pair(r, purpose);
    float u1 = rnd(r);
    return vec2(u1, rnd(r));
}

// One number: qmc_pair(r, purpose).x without its second coordinate (the Sobol y loop)
// with USE_QMC when `use`, else an independent number.
float one_or_rnd(inout Rng r, bool use, uint purpose) {
    if (!(USE_QMC && use)) return rnd(r);
    uint seed = qmc_seed(r, purpose);
    uint x = cm_sobol_x(cm_sobol_shuffle(r.index, seed)) ^ pcg_hash(seed);
    return float(x >> 8u) * (1.0 / 16777216.0);
}

#endif
