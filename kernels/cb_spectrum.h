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
CB_FN bool specIsBlack(Spectrum a) {
    for (int i = 0; i < CB_CHANNELS; ++i)
        if (a.c[i] != 0.0f) return false;
    return true;
}
CB_FN bool specIsFinite(Spectrum a) {
    for (int i = 0; i < CB_CHANNELS; ++i)
        if (!isfinite(a.c[i])) return false;
    return true;
}

/* Linear sRGB from the channels: rgb[k] = sum_i toRgb[k*CB_CHANNELS + i] * c[i]. The host
 * computes the 3 x CB_CHANNELS matrix (identity for RGB scenes, binned CIE 1931 matching
 * functions then XYZ->sRGB for spectral ones) in src/spectral. */
CB_FN Vec3 specToRgb(Spectrum a, CB_GLOBAL const real* toRgb) {
    real rgb[3];
    for (int k = 0; k < 3; ++k) {
        real sum = 0.0f;
        for (int i = 0; i < CB_CHANNELS; ++i)
            sum += toRgb[k * CB_CHANNELS + i] * a.c[i];
        rgb[k] = sum;
    }
    return vec3(rgb[0], rgb[1], rgb[2]);
}

CB_END_NAMESPACE

#endif /* CB_SPECTRUM_H */
