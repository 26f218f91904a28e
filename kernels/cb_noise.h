/* cb_noise.h - Perlin's gradient noise and its sums over octaves, for pbrt-v4's procedural float
 * textures "fbm", "wrinkled" and "windy" (cb_texture.h, textureFloat), shared by the kernels and
 * the host.
 *
 * The noise is Perlin's improved noise (Perlin 2002, "Improving Noise"): gradients at the integer
 * lattice chosen by his permutation of 0..255 and blended by 6t^5 - 15t^4 + 10t^3, with the
 * twelve gradient directions picked from the hash's low four bits as pbrt-v4 picks them, so that
 * a texture has pbrt-v4's pattern. The sums are pbrt-v4's FBm and Turbulence for a zero footprint
 * (every octave), which is what pbrt-v4 computes under Option "disabletexturefiltering" true. */
#ifndef CB_NOISE_H
#define CB_NOISE_H

#include "cb_common.h"

CB_BEGIN_NAMESPACE

/* The permutation of Perlin's reference implementation (2002). */
static CB_CONSTANT const int cbNoisePermutation[256] = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225, 140, 36,  103,
    30,  69,  142, 8,   99,  37,  240, 21,  10,  23,  190, 6,   148, 247, 120, 234, 75,  0,   26,
    197, 62,  94,  252, 219, 203, 117, 35,  11,  32,  57,  177, 33,  88,  237, 149, 56,  87,  174,
    20,  125, 136, 171, 168, 68,  175, 74,  165, 71,  134, 139, 48,  27,  166, 77,  146, 158, 231,
    83,  111, 229, 122, 60,  211, 133, 230, 220, 105, 92,  41,  55,  46,  245, 40,  244, 102, 143,
    54,  65,  25,  63,  161, 1,   216, 80,  73,  209, 76,  132, 187, 208, 89,  18,  169, 200, 196,
    135, 130, 116, 188, 159, 86,  164, 100, 109, 198, 173, 186, 3,   64,  52,  217, 226, 250, 124,
    123, 5,   202, 38,  147, 118, 126, 255, 82,  85,  212, 207, 206, 59,  227, 47,  16,  58,  17,
    182, 189, 28,  42,  223, 183, 170, 213, 119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101,
    155, 167, 43,  172, 9,   129, 22,  39,  253, 19,  98,  108, 110, 79,  113, 224, 232, 178, 185,
    112, 104, 218, 246, 97,  228, 251, 34,  242, 193, 238, 210, 144, 12,  191, 179, 162, 241, 81,
    51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,  181, 199, 106, 157, 184, 84,  204, 176,
    115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,  222, 114, 67,  29,  24,  72,  243,
    141, 128, 195, 78,  66,  215, 61,  156, 180};

/* The gradient of lattice point (x, y, z), each in 0..256, dotted with the offset (dx, dy, dz)
 * from it: one of the twelve edge directions of a cube (four of them twice). */
CB_FN real noiseGradient(int x, int y, int z, real dx, real dy, real dz) {
    const int h =
        cbNoisePermutation[(cbNoisePermutation[(cbNoisePermutation[x & 255] + y) & 255] + z) &
                           255] &
        15;
    const real u = h < 8 || h == 12 || h == 13 ? dx : dy;
    const real v = h < 4 || h == 12 || h == 13 ? dy : dz;
    return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
}

/* Perlin's blend 6t^5 - 15t^4 + 10t^3: zero first and second derivatives at 0 and 1. */
CB_FN real noiseBlend(real t) {
    return t * t * t * (t * (6.0f * t - 15.0f) + 10.0f);
}

/* The noise at p: 0 at every lattice point, within about [-1, 1]. Coordinates are first brought
 * below 2^30 (the pattern repeats every 256 anyway), as pbrt-v4 does, so that the cell's integer
 * corner fits an int. */
CB_FN real perlinNoise(Vec3 p) {
    const real period = 1073741824.0f; /* 2^30 */
    const real x = fmod(p.x, period), y = fmod(p.y, period), z = fmod(p.z, period);
    const real fx = floor(x), fy = floor(y), fz = floor(z);
    const real dx = x - fx, dy = y - fy, dz = z - fz;
    const int ix = (int)fx & 255, iy = (int)fy & 255, iz = (int)fz & 255;
    const real wx = noiseBlend(dx), wy = noiseBlend(dy), wz = noiseBlend(dz);
    const real x00 = cbLerp(wx, noiseGradient(ix, iy, iz, dx, dy, dz),
                            noiseGradient(ix + 1, iy, iz, dx - 1.0f, dy, dz));
    const real x10 = cbLerp(wx, noiseGradient(ix, iy + 1, iz, dx, dy - 1.0f, dz),
                            noiseGradient(ix + 1, iy + 1, iz, dx - 1.0f, dy - 1.0f, dz));
    const real x01 = cbLerp(wx, noiseGradient(ix, iy, iz + 1, dx, dy, dz - 1.0f),
                            noiseGradient(ix + 1, iy, iz + 1, dx - 1.0f, dy, dz - 1.0f));
    const real x11 = cbLerp(wx, noiseGradient(ix, iy + 1, iz + 1, dx, dy - 1.0f, dz - 1.0f),
                            noiseGradient(ix + 1, iy + 1, iz + 1, dx - 1.0f, dy - 1.0f, dz - 1.0f));
    return cbLerp(wz, cbLerp(wy, x00, x10), cbLerp(wy, x01, x11));
}

/* Fractional Brownian motion: octaves of noise, each at 1.99 times the last's frequency and
 * omega times its weight (pbrt-v4's FBm with every octave). */
CB_FN real noiseFbm(Vec3 p, real omega, int octaves) {
    real sum = 0.0f, frequency = 1.0f, weight = 1.0f;
    for (int i = 0; i < octaves; ++i) {
        sum += weight * perlinNoise(vscale(p, frequency));
        frequency *= 1.99f;
        weight *= omega;
    }
    return sum;
}

/* Turbulence: the same sum of |noise|, plus 0.2 times the next octave's weight, which pbrt-v4's
 * Turbulence adds for the octaves a footprint clamps (none here, but the term stays). */
CB_FN real noiseTurbulence(Vec3 p, real omega, int octaves) {
    real sum = 0.0f, frequency = 1.0f, weight = 1.0f;
    for (int i = 0; i < octaves; ++i) {
        sum += weight * fabs(perlinNoise(vscale(p, frequency)));
        frequency *= 1.99f;
        weight *= omega;
    }
    return sum + 0.2f * weight;
}

/* pbrt-v4's WindyTexture: waves of fbm heights scaled by a slower fbm "wind strength". */
CB_FN real noiseWindy(Vec3 p) {
    return fabs(noiseFbm(vscale(p, 0.1f), 0.5f, 3)) * noiseFbm(p, 0.5f, 6);
}

CB_END_NAMESPACE

#endif /* CB_NOISE_H */
