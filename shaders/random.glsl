// random.glsl - random numbers: a counter-based hash of (pixel, iteration, dimension,
// seed), so that any kernel can replay a sample's stream from its pixel and counter (the
// event queues store only the counter), and a randomly shifted low-discrepancy sequence
// per pixel for the camera's jitter.
#ifndef RANDOM_GLSL_ONCE
#define RANDOM_GLSL_ONCE 1

uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// key and counter: the hash stream of one sample.  lattice_key and index: the sample's
// place in its pixel's low-discrepancy sequence (qmc below).
struct Rng { uint key; uint counter; uint lattice_key; uint index; };

Rng rng_init(uint pixel, uint iteration, uint seed) {
    Rng r;
    r.key = pcg_hash(pixel ^ pcg_hash(iteration ^ pcg_hash(seed + 0x9e3779b9u)));
    r.counter = 0u;
    r.lattice_key = pcg_hash(pixel ^ pcg_hash(seed + 0x7f4a7c15u));
    r.index = iteration;
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

#endif
