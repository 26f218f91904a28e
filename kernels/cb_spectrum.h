/* cb_spectrum.h - the per-path quantity carried by every integrator.
 *
 * CB_CHANNELS is a compile-time switch (docs/method.md, spectra): 3 for RGB scenes, 16 for spectral
 * scenes (16 bins over 400-700 nm). Every path carries all channels, so spectral renders have no
 * colour noise. A fixed-size array lets PoCL unroll every loop. */
#ifndef CB_SPECTRUM_H
#define CB_SPECTRUM_H

#include "cb_common.h"

#ifndef CB_CHANNELS
#define CB_CHANNELS 3
#endif

CB_BEGIN_NAMESPACE

typedef struct Spectrum {
    real c[CB_CHANNELS];
} Spectrum;

CB_FN Spectrum specConst(real v) {
    Spectrum s;
    for (int i = 0; i < CB_CHANNELS; ++i)
        s.c[i] = v;
    return s;
}
CB_FN Spectrum specZero(void) {
    return specConst(0.0f);
}
CB_FN Spectrum specLoad(CB_GLOBAL const real* table, int index) {
    Spectrum s;
    for (int i = 0; i < CB_CHANNELS; ++i)
        s.c[i] = table[index * CB_CHANNELS + i];
    return s;
}
CB_FN Spectrum specAdd(Spectrum a, Spectrum b) {
    for (int i = 0; i < CB_CHANNELS; ++i)
        a.c[i] += b.c[i];
    return a;
}
CB_FN Spectrum specSub(Spectrum a, Spectrum b) {
    for (int i = 0; i < CB_CHANNELS; ++i)
        a.c[i] -= b.c[i];
    return a;
}
CB_FN Spectrum specMul(Spectrum a, Spectrum b) {
    for (int i = 0; i < CB_CHANNELS; ++i)
        a.c[i] *= b.c[i];
    return a;
}
CB_FN Spectrum specScale(Spectrum a, real s) {
    for (int i = 0; i < CB_CHANNELS; ++i)
        a.c[i] *= s;
    return a;
}
/* a + b*s */
CB_FN Spectrum specMadd(Spectrum a, Spectrum b, real s) {
    for (int i = 0; i < CB_CHANNELS; ++i)
        a.c[i] += b.c[i] * s;
    return a;
}
/* Smits 1999 ("An RGB-to-spectrum conversion for reflectances"), section 3: rgb, negative
 * components clamped to zero, as the smallest component times white, the gap to the middle one
 * times the secondary made of the two larger primaries, the gap to the largest times that
 * primary. Indices into the basis of smitsBasis() (src/spectral/spectral.h): white 0, cyan 1,
 * magenta 2, yellow 3, red 4, green 5, blue 6. The host's rgbToSpectrum and the image lights'
 * pixels (cb_lights.h) combine the basis with these weights. */
typedef struct SmitsSplit {
    real white;
    int secondary;
    real secondaryWeight;
    int primary;
    real primaryWeight;
} SmitsSplit;

CB_FN SmitsSplit smitsSplitOf(int secondary, int primary, real white, real secondaryWeight,
                              real primaryWeight) {
    SmitsSplit k;
    k.white = white;
    k.secondary = secondary;
    k.secondaryWeight = secondaryWeight;
    k.primary = primary;
    k.primaryWeight = primaryWeight;
    return k;
}

CB_FN SmitsSplit smitsSplit(real red, real green, real blue) {
    real r = fmax(red, 0.0f);
    real g = fmax(green, 0.0f);
    real b = fmax(blue, 0.0f);
    if (r <= g && r <= b)
        return g <= b ? smitsSplitOf(1, 6, r, g - r, b - g) : smitsSplitOf(1, 5, r, b - r, g - b);
    if (g <= r && g <= b)
        return r <= b ? smitsSplitOf(2, 6, g, r - g, b - r) : smitsSplitOf(2, 4, g, b - g, r - b);
    return r <= g ? smitsSplitOf(3, 5, b, r - b, g - r) : smitsSplitOf(3, 4, b, g - b, r - g);
}

/* Smits's spectrum of (red, green, blue) from his basis at spectra entries basis .. basis + 6
 * (white, cyan, magenta, yellow, red, green, blue): the kernels' copy of the host's
 * rgbToSpectrum, for RGB values stored as RGB (image lights' pixels, image textures). */
CB_FN Spectrum smitsSpectrum(CB_GLOBAL const real* spectra, int basis, real red, real green,
                             real blue) {
    SmitsSplit k = smitsSplit(red, green, blue);
    Spectrum s = specScale(specLoad(spectra, basis), k.white);
    s = specMadd(s, specLoad(spectra, basis + k.secondary), k.secondaryWeight);
    return specMadd(s, specLoad(spectra, basis + k.primary), k.primaryWeight);
}

CB_FN real specMaxComponent(Spectrum a) {
    real m = a.c[0];
    for (int i = 1; i < CB_CHANNELS; ++i)
        m = fmax(m, a.c[i]);
    return m;
}
CB_FN real specAverage(Spectrum a) {
    real sum = 0.0f;
    for (int i = 0; i < CB_CHANNELS; ++i)
        sum += a.c[i];
    return sum * (1.0f / (real)CB_CHANNELS);
}
/* The two tests below reduce over every channel without an early exit, so that the compiler
 * turns them into a vector compare: with an early exit they ran channel by channel. */
CB_FN bool specIsBlack(Spectrum a) {
    bool nonZero = false;
    for (int i = 0; i < CB_CHANNELS; ++i)
        nonZero |= a.c[i] != 0.0f;
    return !nonZero;
}
CB_FN bool specIsFinite(Spectrum a) {
    bool finite = true;
    for (int i = 0; i < CB_CHANNELS; ++i)
        finite &= isfinite(a.c[i]) != 0;
    return finite;
}

/* sum_i row[i] * c[i] in CB_SUM_LANES interleaved partial sums (channel i in lane i mod
 * CB_SUM_LANES), an order the compiler can vectorise; one running sum it must keep in channel
 * order, one channel at a time (3% of CBDPT's time with 16 channels). */
#define CB_SUM_LANES (CB_CHANNELS < 8 ? CB_CHANNELS : 8)

CB_FN real specDot(Spectrum a, CB_GLOBAL const real* row) {
    real lanes[CB_SUM_LANES];
    for (int i = 0; i < CB_SUM_LANES; ++i)
        lanes[i] = row[i] * a.c[i];
    for (int i = CB_SUM_LANES; i < CB_CHANNELS; ++i)
        lanes[i % CB_SUM_LANES] += row[i] * a.c[i];
    real sum = 0.0f;
    for (int i = 0; i < CB_SUM_LANES; ++i)
        sum += lanes[i];
    return sum;
}

/* Linear sRGB from the channels: rgb[k] = sum_i toRgb[k*CB_CHANNELS + i] * c[i]. The host
 * computes the 3 x CB_CHANNELS matrix (identity for RGB scenes, binned CIE 1931 matching
 * functions then XYZ->sRGB for spectral ones) in src/spectral. Three separate sums: an array of
 * three read back as a vector stalled store forwarding. */
CB_FN Vec3 specToRgb(Spectrum a, CB_GLOBAL const real* toRgb) {
    return vec3(specDot(a, toRgb), specDot(a, toRgb + CB_CHANNELS),
                specDot(a, toRgb + 2 * CB_CHANNELS));
}

CB_END_NAMESPACE

#endif /* CB_SPECTRUM_H */
