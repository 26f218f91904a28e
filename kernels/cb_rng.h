/* cb_rng.h - counter-based random numbers and the per-work-item sample vector.
 *
 * Every random decision reads dimension d of a sample vector u (docs/method.md, random numbers and
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

CB_FN uint cbReverseBits(uint x) {
    x = (x << 16) | (x >> 16);
    x = ((x & 0x00ff00ffu) << 8) | ((x & 0xff00ff00u) >> 8);
    x = ((x & 0x0f0f0f0fu) << 4) | ((x & 0xf0f0f0f0u) >> 4);
    x = ((x & 0x33333333u) << 2) | ((x & 0xccccccccu) >> 2);
    x = ((x & 0x55555555u) << 1) | ((x & 0xaaaaaaaau) >> 1);
    return x;
}

/* Map 32 random bits to [0,1) with 24 bits of mantissa: never returns 1. */
CB_FN real cbUintToUnitFloat(uint bits) {
    return (real)(bits >> 8) * (1.0f / 16777216.0f);
}

/* CB_PRIMARY_SAMPLES (defined only by kernels/mlt.cl before including this header): a stream may
 * instead read an explicit table of primary samples, the state of a Metropolis chain in primary
 * sample space (Kelemen et al. 2002), so that the path code samples paths from mutated vectors
 * without knowing it. Without the macro the struct and every function are exactly as before. */
/* The sampler behind a stream (--sampler): CB_SAMPLER_INDEPENDENT hashes (seed, estimate,
 * stream, dimension) into independent uniform numbers; CB_SAMPLER_SOBOL makes the estimates of
 * one stream a randomised low-discrepancy sequence (sobolSample below). Passed by value into the
 * kernels, so 16 bytes. */
#define CB_SAMPLER_INDEPENDENT 0
#define CB_SAMPLER_SOBOL 1

typedef struct SamplerSettings {
    uint seed;
    int kind; /* CB_SAMPLER_* */
    int pad[2];
} SamplerSettings;

/* Kernels hand their sampler to functions as a private, field-by-field copy: NVIDIA's OpenCL
 * compiler (driver 580) read a by-value kernel argument passed on to an inlined function through
 * the parameter's address taken as a local-memory one, and the kernel faulted (docs/gpu.md). */
CB_FN SamplerSettings samplerSettingsCopy(SamplerSettings in) {
    SamplerSettings out;
    out.seed = in.seed;
    out.kind = in.kind;
    out.pad[0] = in.pad[0];
    out.pad[1] = in.pad[1];
    return out;
}
/* The copy names every field: a new one must be added to it (and this size). */
typedef char cbSamplerSettingsCopyCheck[sizeof(SamplerSettings) == 4 * sizeof(int) ? 1 : -1];

/* CB_PRIMARY_SAMPLES (defined only by kernels/mlt.cl before including this header): a stream may
 * instead read an explicit table of primary samples, the state of a Metropolis chain in primary
 * sample space (Kelemen et al. 2002), so that the path code samples paths from mutated vectors
 * without knowing it. Without the macro the struct and every function are exactly as before. */
typedef struct SampleStream {
    uint key;       /* independent: hash of (seed, estimate, stream); Sobol: of (seed, stream) */
    uint dimension; /* next dimension to read */
    /* Sobol: the point's index in the sequence (the estimate), its bits reversed: every pair
     * of dimensions shuffles it in that form (sobolShuffleReversed), so it is reversed once. */
    uint reversedIndex;
    int sobol; /* CB_SAMPLER_SOBOL: read sobolSample */
    /* The coherent methods' shared vector, drawn once per estimate by the host (CPT, CBDPT:
     * every pixel at one tile position reads the same u, so no pixel need draw it): u[d] =
     * shared[d] for d < sharedCount, the same values sampleAt would compute. */
    CB_GLOBAL const float* shared;
    uint sharedCount;
#ifdef CB_PRIMARY_SAMPLES
    const real* primary; /* non-null: u[d] = primary[d] for d < primaryCount */
    uint primaryCount;
#endif
} SampleStream;

CB_FN SampleStream samplerStream(SamplerSettings sampler, uint estimate, uint stream) {
    SampleStream s;
    s.sobol = sampler.kind == CB_SAMPLER_SOBOL;
    /* The Sobol sequence runs over the estimates, so its key must not depend on them. */
    uint keyedEstimate = s.sobol ? 0xffffffffu : estimate;
    s.key = cbHashCombine(cbHashCombine(cbHash32(sampler.seed), keyedEstimate), stream);
    s.dimension = 0u;
    s.reversedIndex = cbReverseBits(estimate);
    s.shared = 0;
    s.sharedCount = 0u;
#ifdef CB_PRIMARY_SAMPLES
    s.primary = 0;
    s.primaryCount = 0u;
#endif
    return s;
}

/* The independent sampler's stream (MLT's chains and tests use it directly). */
CB_FN SampleStream sampleStreamStart(uint seed, uint estimate, uint stream) {
    SamplerSettings sampler;
    sampler.seed = seed;
    sampler.kind = CB_SAMPLER_INDEPENDENT;
    sampler.pad[0] = sampler.pad[1] = 0;
    return samplerStream(sampler, estimate, stream);
}

/* ---- Randomised Sobol points ------------------------------------------------------------ */

/* Sobol's second dimension (primitive polynomial x + 1, m_1 = 1), its digits reversed (first
 * digit in bit 0). Its direction numbers v_1 = 2^31, v_k = v_{k-1} xor (v_{k-1} >> 1) are, so
 * reversed, the rows of Pascal's triangle mod 2: digit j of the point is the xor of the index's
 * bits k with C(k, j) odd, that is with j's bits a subset of k's (Lucas' theorem). That sum over
 * supersets takes one shift, mask and xor per bit of the 5-bit position, with no loop over the
 * index's bits. The first dimension is the van der Corput sequence: reversed, the index itself. */
CB_FN uint sobolSecondDimensionReversed(uint index) {
    index ^= (index >> 1) & 0x55555555u;
    index ^= (index >> 2) & 0x33333333u;
    index ^= (index >> 4) & 0x0f0f0f0fu;
    index ^= (index >> 8) & 0x00ff00ffu;
    index ^= (index >> 16) & 0x0000ffffu;
    return index;
}

/* Owen scrambling (nested uniform digit permutation) of a 32-bit fraction given with its first
 * digit in bit 0, by Laine and Karras' hash as Burley 2020 ("Practical Hash-based Owen
 * Scrambling", JCGT 9(4)) gives it: every step changes a bit by the bits below it only, so
 * each elementary interval goes to one elementary interval (nets stay nets), and adding the
 * random seed first makes every single point exactly uniform. */
CB_FN uint owenScrambleReversed(uint x, uint seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

/* A bijection of the estimate indices that maps [0, 2^k) onto itself for every k, so that the
 * first 2^k estimates of every pair of dimensions are still the first 2^k Sobol points (a
 * (0,k,2)-net once scrambled) whatever the total count: each bit below the highest set bit is
 * flipped by a function of the bits above it, the highest set bit and the zeros above it stay.
 * Each pair of dimensions has its own, so that pairs are paired by a random permutation rather
 * than index for index (pbrt-v4's PaddedSobolSampler). The flips are Laine and Karras' hash on
 * the reversed index, as Burley 2020 shuffles Sobol indices (nested_uniform_scramble), with the
 * leading zeros and the highest set bit restored: constant work per sample. (A hash per bit, as
 * pbrt-v4's ZSobolSampler draws a permutation per base-4 digit, cost 31% of PT's kernel
 * instructions at 2^11 estimates, more for BDPT's image-wide light streams: docs/sampling.md.)
 * Given and returned with its bits reversed, the form in which it is scrambled. */
CB_FN uint sobolShuffleReversed(uint reversed, uint key) {
    uint highest = reversed & (0u - reversed); /* the highest set bit of index, reversed */
    uint kept = highest | (highest - 1u);      /* it and the zeros above it (all bits if 0) */
    uint scrambled = owenScrambleReversed(reversed, cbHashCombine(key, 0x5f1e0000u));
    return (scrambled & ~kept) | (reversed & kept);
}

CB_FN uint sobolShuffleIndex(uint index, uint key) {
    return cbReverseBits(sobolShuffleReversed(cbReverseBits(index), key));
}

/* Dimensions 2i and 2i+1 are the two-dimensional Sobol sequence, its index shuffled and each
 * coordinate Owen-scrambled with keys of (stream key, i) (padding as in pbrt-v4's
 * PaddedSobolSampler). Every estimate is uniform on the unit cube and different pairs are
 * independent, so every estimator stays unbiased; over the estimates each pair is stratified as
 * a scrambled (0,2)-sequence (Owen 1997: variance o(1/N) for smooth integrands, bounded by a
 * constant times Monte Carlo's for square-integrable ones). `coordinate` 0 or 1 of pair i,
 * given the pair's key and shuffled index. */
CB_FN uint sobolPairCoordinate(uint pairKey, uint shuffled, uint coordinate) {
    uint point = coordinate ? sobolSecondDimensionReversed(shuffled) : shuffled;
    return cbReverseBits(
        owenScrambleReversed(point, cbHashCombine(pairKey, 0x5eed0000u + coordinate)));
}

/* Dimension d of the estimate whose index, bits reversed, is reversedIndex. */
CB_FN uint sobolSample(uint key, uint reversedIndex, uint dimension) {
    uint pairKey = cbHashCombine(key, dimension >> 1);
    uint shuffled = cbReverseBits(sobolShuffleReversed(reversedIndex, pairKey));
    return sobolPairCoordinate(pairKey, shuffled, dimension & 1u);
}

/* u[d] of a dimension the stream draws itself (not in a shared or primary-sample table). */
CB_FN real sampleDrawn(SampleStream s, uint dimension) {
    if (s.sobol) return cbUintToUnitFloat(sobolSample(s.key, s.reversedIndex, dimension));
    return cbUintToUnitFloat(cbHashCombine(s.key, dimension));
}

/* u[d] for an arbitrary dimension, without advancing. The table lookups stay inline: a call
 * takes the 32-byte stream by value through the stack, whose wide reload of narrow stores
 * stalled store forwarding (14% of CBDPT's packet kernel's samples, perf annotate). */
CB_FN __attribute__((always_inline)) real sampleAt(SampleStream s, uint dimension) {
#ifdef CB_PRIMARY_SAMPLES
    if (s.primary && dimension < s.primaryCount) return s.primary[dimension];
#endif
    if (dimension < s.sharedCount) return s.shared[dimension];
    return sampleDrawn(s, dimension);
}

/* sampleAt2 for a pair the stream draws at least in part: the Sobol pair's key and shuffled
 * index computed once for both. */
CB_FN void sampleAt2Drawn(SampleStream s, uint dimension, real* u0, real* u1) {
    bool table = dimension < s.sharedCount;
#ifdef CB_PRIMARY_SAMPLES
    table = table || (s.primary && dimension < s.primaryCount);
#endif
    if (s.sobol && !table && (dimension & 1u) == 0u) {
        uint pairKey = cbHashCombine(s.key, dimension >> 1);
        uint shuffled = cbReverseBits(sobolShuffleReversed(s.reversedIndex, pairKey));
        *u0 = cbUintToUnitFloat(sobolPairCoordinate(pairKey, shuffled, 0u));
        *u1 = cbUintToUnitFloat(sobolPairCoordinate(pairKey, shuffled, 1u));
        return;
    }
    *u0 = sampleAt(s, dimension);
    *u1 = sampleAt(s, dimension + 1u);
}

/* u[d] and u[d + 1] for an even d, a two-dimensional decision: the same values as two sampleAt
 * calls. The coherent methods' eye paths read both from the shared table, inline (sampleAt). */
CB_FN __attribute__((always_inline)) void sampleAt2(SampleStream s, uint dimension, real* u0,
                                                    real* u1) {
#ifndef CB_PRIMARY_SAMPLES
    if (dimension + 1u < s.sharedCount) {
        *u0 = s.shared[dimension];
        *u1 = s.shared[dimension + 1u];
        return;
    }
#endif
    sampleAt2Drawn(s, dimension, u0, u1);
}

CB_FN real sampleNext(SampleStream* s) {
    real u = sampleAt(*s, s->dimension);
    s->dimension += 1u;
    return u;
}

/* Fixed dimension layout: the same decision reads the same dimension in every pixel, which is
 * what makes shared vectors coherent. Dimensions 0-1 are the pixel jitter, 2-3 the point on a
 * thin lens (read only by cameras with one); then each eye
 * vertex (bounce) owns CB_DIMS_PER_BOUNCE consecutive dimensions. Two-dimensional decisions start
 * at even dimensions: the Sobol sampler stratifies the pairs (2i, 2i+1) jointly. */
#define CB_DIM_PIXEL 0u
#define CB_DIM_LENS 2u
#define CB_DIM_FIRST_BOUNCE 4u
#define CB_DIMS_PER_BOUNCE 8u
#define CB_SLOT_BSDF_DIRECTION 0u /* 2 dims */
#define CB_SLOT_BSDF_LOBE 2u
#define CB_SLOT_ROULETTE 3u
#define CB_SLOT_LIGHT_POINT 4u /* 2 dims */
#define CB_SLOT_LIGHT_CHOICE 6u
#define CB_SLOT_WAVELENGTH 7u /* the one wavelength at a dispersive dielectric */

CB_FN uint bounceDimension(int bounce, uint slot) {
    return CB_DIM_FIRST_BOUNCE + (uint)bounce * CB_DIMS_PER_BOUNCE + slot;
}

/* How many dimensions an eye path of at most eyeVertices vertices reads (PT's and BDPT's eye
 * subpaths alike): the jitter and CB_DIMS_PER_BOUNCE for each of its eyeVertices - 1 bounces. */
CB_FN uint eyeStreamDimensions(int eyeVertices) {
    return bounceDimension(eyeVertices > 1 ? eyeVertices - 1 : 0, 0u);
}

/* The pair of dimensions from which the ray to a subpath's vertex path[bounce + 1] samples its
 * distance in a scattering medium (cb_medium.h, mediumSampleDistance): after every dimension of
 * the subpath's bounces (its first at firstBounceDim, at most maxVertices vertices), so that
 * scenes without such media read the layout they always had. PT's eye paths and BDPT's eye
 * subpaths read the same ones. */
CB_FN uint mediumDistanceDimension(uint firstBounceDim, int maxVertices, int bounce) {
    return firstBounceDim + (uint)(maxVertices > 1 ? maxVertices - 1 : 0) * CB_DIMS_PER_BOUNCE +
           2u * (uint)bounce;
}

/* How many dimensions an eye path reads where the scene's media may scatter (`scattering`): its
 * bounces' and then its distances' (mediumDistanceDimension); eyeStreamDimensions otherwise. */
CB_FN uint eyeStreamDimensionsWithMedia(int eyeVertices, bool scattering) {
    return scattering ? mediumDistanceDimension(CB_DIM_FIRST_BOUNCE, eyeVertices,
                                                eyeVertices > 1 ? eyeVertices - 1 : 0)
                      : eyeStreamDimensions(eyeVertices);
}

/* Stream `stream` of an estimate whose shared vectors (streams x dimensions values, stream by
 * stream) the host drew into `table` (dimensions = 0: none, every value is computed). */
CB_FN SampleStream samplerStreamShared(SamplerSettings sampler, uint estimate, uint stream,
                                       CB_GLOBAL const float* table, uint dimensions) {
    SampleStream s = samplerStream(sampler, estimate, stream);
    if (dimensions > 0u) {
        s.shared = table + (size_t)stream * dimensions;
        s.sharedCount = dimensions;
    }
    return s;
}

/* The packets' tiles (pt.cl renderCoherentPathTracing, cbdpt_packets.cl): a work-item renders
 * tile x tile pixels `stride` apart, stride the coherence tile k, so that all its pixels sit at
 * one position of their k x k tiles and follow one shared sample vector (neighbours would
 * follow k^2 different ones). Along an axis of `extent` pixels, blocks of k * tile pixels hold
 * k tiles each; tile t's i-th column (or row) is pixel packetTilePixel(t, i, ...). k = 1: plain
 * tiles of neighbouring pixels. */
CB_FN int packetTilesAcross(int extent, int tile, int stride) {
    return (extent + stride * tile - 1) / (stride * tile) * stride;
}
CB_FN int packetTilePixel(int t, int i, int tile, int stride) {
    return t / stride * stride * tile + t % stride + stride * i;
}

CB_END_NAMESPACE

#endif /* CB_RNG_H */
