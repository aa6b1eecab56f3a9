// sobol.glsl - the first two dimensions of the Sobol sequence, shuffled per pixel and
// purpose by an Owen scramble of the index (Burley 2020, "Practical Hash-based Owen
// Scrambling", JCGT 9(4)) and randomized by a digital shift, in 32-bit integers,
// written in the common subset of C and GLSL so that tests/test_sampling.c runs this very code (the C side defines cm_uint as
// uint32_t and cm_bitrev; GLSL's are uint and bitfieldReverse, below).
//
// Why these properties, and why the estimate stays unbiased:
//   - The caller XORs each coordinate with a uniformly random 32-bit shift (a digital
//     shift; random.glsl, qmc_pair): every bit of the result is then a uniform bit, so
//     each point is uniform on [0, 1)^2 on its own and any estimator fed with it has the
//     expectation it has with independent numbers.
//   - The Sobol sequence's first two dimensions form a (0, 2)-sequence in base 2: every
//     aligned block of 2^k indices puts one point in each elementary interval of area
//     2^-k (each 2^a x 2^(k-a) grid).  A digital shift keeps that (it permutes the
//     intervals of each grid).
//   - sobol_shuffle(n, seed) permutes the indices by the same scramble: bit b of the
//     result is bit b of n flipped by a hash of n's bits above b, so the first 2^k
//     indices map onto one aligned block of 2^k.  Every power-of-two prefix of a pixel's
//     samples keeps the stratification, and two purposes (independent seeds) visit the
//     sequence in unrelated orders: their pairs are not correlated with each other
//     (padding, as PBRT's padded Sobol sampler does).
#ifndef SOBOL_GLSL_ONCE
#define SOBOL_GLSL_ONCE 1
#include "c_subset.glsl"

#ifdef CM_GLSL
#define cm_uint uint
#define cm_bitrev(x) bitfieldReverse(x)
#endif

// Laine and Karras's hash: a permutation of 32-bit values in which bit b depends only on
// bits at or below b.
CM_API cm_uint CM_FN(sobol_lk_hash)(cm_uint x, cm_uint seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// The index of a pixel's n-th sample in the sequence of `seed` (see the top): a nested
// uniform (Owen) scramble of n, bit b flipped by a hash of the bits above b.
CM_API cm_uint CM_FN(sobol_shuffle)(cm_uint n, cm_uint seed) {
    return cm_bitrev(CM_FN(sobol_lk_hash)(cm_bitrev(n), seed));
}

// Dimension 0 of point i, as a 32-bit fraction: the van der Corput sequence.
CM_API cm_uint CM_FN(sobol_x)(cm_uint i) { return cm_bitrev(i); }

// Dimension 1 of point i: its generator matrix is Pascal's triangle mod 2, column by
// column v_0 = 2^31, v_{j+1} = v_j ^ (v_j >> 1).  As many iterations as i has bits.
CM_API cm_uint CM_FN(sobol_y)(cm_uint i) {
    cm_uint r = 0u, v = 0x80000000u;
    while (i != 0u) {
        if ((i & 1u) != 0u) r ^= v;
        i >>= 1u;
        v ^= v >> 1u;
    }
    return r;
}

#ifdef CM_GLSL
#undef cm_uint
#undef cm_bitrev
#endif
#endif
