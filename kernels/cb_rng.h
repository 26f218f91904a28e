/* cb_rng.h - counter-based random numbers and the per-work-item sample vector.
 *
 * Every random decision reads dimension d of a sample vector u (METHOD.md, random numbers and
 * coherence). u is a pure function of (seed, estimate, stream key, dimension), so no state is
 * carried between work-items or estimates: PT/BDPT key the stream by pixel, CPT/CBDPT by the
 * coherence tile, so that all pixels of a tile share u. */
#ifndef CB_RNG_H
#define CB_RNG_H

#include "cb_common.h"

CB_BEGIN_NAMESPACE

/* A 32-bit integer finaliser with low bias (Wellons' "lowbias32" constants): every input bit
 * affects every output bit. */
CB_FN uint cbHash32(uint x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

CB_FN uint cbHashCombine(uint seed, uint value) {
    return cbHash32(seed ^ (value + 0x9e3779b9u + (seed << 6) + (seed >> 2)));
}

/* Map 32 random bits to [0,1) with 24 bits of mantissa: never returns 1. */
CB_FN real cbUintToUnitFloat(uint bits) {
    return (real)(bits >> 8) * (1.0f / 16777216.0f);
}

/* CB_PRIMARY_SAMPLES (defined only by kernels/mlt.cl before including this header): a stream may
 * instead read an explicit table of primary samples, the state of a Metropolis chain in primary
 * sample space (Kelemen et al. 2002), so that the path code samples paths from mutated vectors
 * without knowing it. Without the macro the struct and every function are exactly as before. */
typedef struct SampleStream {
    uint key;       /* hash of (seed, estimate, stream) */
    uint dimension; /* next dimension to read */
#ifdef CB_PRIMARY_SAMPLES
    const real* primary; /* non-null: u[d] = primary[d] for d < primaryCount */
    uint primaryCount;
#endif
} SampleStream;

CB_FN SampleStream sampleStreamStart(uint seed, uint estimate, uint stream) {
    SampleStream s;
    s.key = cbHashCombine(cbHashCombine(cbHash32(seed), estimate), stream);
    s.dimension = 0u;
#ifdef CB_PRIMARY_SAMPLES
    s.primary = 0;
    s.primaryCount = 0u;
#endif
    return s;
}

/* u[d] for an arbitrary dimension, without advancing. */
CB_FN real sampleAt(SampleStream s, uint dimension) {
#ifdef CB_PRIMARY_SAMPLES
    if (s.primary && dimension < s.primaryCount) return s.primary[dimension];
#endif
    return cbUintToUnitFloat(cbHashCombine(s.key, dimension));
}

CB_FN real sampleNext(SampleStream* s) {
    real u = sampleAt(*s, s->dimension);
    s->dimension += 1u;
    return u;
}

/* Fixed dimension layout: the same decision reads the same dimension in every pixel, which is
 * what makes shared vectors coherent. Dimensions 0-1 are the pixel jitter; then each eye
 * vertex (bounce) owns CB_DIMS_PER_BOUNCE consecutive dimensions. */
#define CB_DIM_PIXEL 0u
#define CB_DIM_FIRST_BOUNCE 4u
#define CB_DIMS_PER_BOUNCE 8u
#define CB_SLOT_BSDF_DIRECTION 0u /* 2 dims */
#define CB_SLOT_BSDF_LOBE 2u
#define CB_SLOT_ROULETTE 3u
#define CB_SLOT_LIGHT_CHOICE 4u
#define CB_SLOT_LIGHT_POINT 5u /* 2 dims */

CB_FN uint bounceDimension(int bounce, uint slot) {
    return CB_DIM_FIRST_BOUNCE + (uint)bounce * CB_DIMS_PER_BOUNCE + slot;
}

CB_END_NAMESPACE

#endif /* CB_RNG_H */
