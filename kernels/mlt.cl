/* mlt.cl - primary-sample-space Metropolis light transport over BDPT (Kelemen et al. 2002;
 * docs/method.md, MLT).
 *
 * A state is a vector u of primary samples in [0,1)^D: the eye stream's dimensions first
 * (CB_MLT_EYE_DIMS, BDPT's eye layout except that dims 0-1 pick any pixel, and by what is left
 * of them the film position in its filter, instead of a position in a given pixel), then the light
 * stream's (CB_MLT_LIGHT_DIMS, BDPT's light layout). Connections draw no random numbers, so the two
 * streams are all there is, and a mutation of one leaves the other's decisions where they were
 * (separate random streams). The path code (cb_bdpt.h) reads u through SampleStream's
 * primary-sample table (cb_rng.h, CB_PRIMARY_SAMPLES).
 *
 * The contribution F(u) of a state is BDPT's full estimate for that sample: the weighted sum of
 * every strategy with t >= 2 for the pixel that (u0, u1) picks, plus every t = 1 strategy at the
 * raster point its light vertex projects to, added to every pixel that point's filter reaches
 * (cb_filter.h): a short list of splats. The target density is the scalar I(u), the sum of the
 * splats' |luminance| (the eye's splat is negative where a filter's negative lobes weigh it so;
 * F / I keeps the sign). Each chain is one work-item; its
 * state lives in private arrays during a launch and in __global buffers between launches. */
#define CB_PRIMARY_SAMPLES
#include "cb_atomics.h"
#include "cb_bdpt.h"
#include "cb_kernel.h"

#ifndef CB_MAX_EYE_VERTICES
#define CB_MAX_EYE_VERTICES 8
#endif
#ifndef CB_MAX_LIGHT_VERTICES
#define CB_MAX_LIGHT_VERTICES 8
#endif
#ifndef CB_MLT_EYE_DIMS
#define CB_MLT_EYE_DIMS (CB_DIM_FIRST_BOUNCE + CB_DIMS_PER_BOUNCE * CB_MAX_EYE_VERTICES)
#endif
#ifndef CB_MLT_LIGHT_DIMS
#define CB_MLT_LIGHT_DIMS (CB_LIGHT_DIM_FIRST_BOUNCE + CB_DIMS_PER_BOUNCE * CB_MAX_LIGHT_VERTICES)
#endif
#define CB_MLT_DIMS (CB_MLT_EYE_DIMS + CB_MLT_LIGHT_DIMS)
/* One splat at the sample's own pixel, one per t = 1 strategy (s = 2 .. Nl). A splat's pixel is
 * -1 where it is a light-tracing one, given by its raster point through the pixel filter. */
#define CB_MLT_MAX_SPLATS (CB_MAX_LIGHT_VERTICES + 1)

#define CB_MLT_BOOTSTRAP_SALT 0x426f6f74u
#define CB_MLT_MUTATION_SALT 0x4d757461u

/* Slots of a chain's per-launch statistics (uint each). */
#define CB_MLT_STAT_ACCEPTED 0
#define CB_MLT_STAT_LARGE 1
#define CB_MLT_STAT_LARGE_ACCEPTED 2
#define CB_MLT_STAT_ZERO_PROPOSALS 3
#define CB_MLT_STATS 4
/* The kernel's stages (the host's MltStage). */
#define CB_MLT_STAGE_BOOTSTRAP 0u
#define CB_MLT_STAGE_SEED 1u
#define CB_MLT_STAGE_ADVANCE 2u

typedef struct MltSample {
    int count;
    int pixel[CB_MLT_MAX_SPLATS];
    float raster[2 * CB_MLT_MAX_SPLATS];
    float rgb[3 * CB_MLT_MAX_SPLATS];
    float luminance; /* I(u); 0 when the sample contributes nothing */
} MltSample;

/* Rec. 709 luminance (the Y of CIE XYZ for linear sRGB). */
static float mltLuminance(Vec3 rgb) {
    return 0.2126f * rgb.x + 0.7152f * rgb.y + 0.0722f * rgb.z;
}

static void mltAddSplat(MltSample* out, int pixel, float rasterX, float rasterY, Vec3 rgb) {
    int i = out->count++;
    out->pixel[i] = pixel;
    out->raster[2 * i + 0] = rasterX;
    out->raster[2 * i + 1] = rasterY;
    out->rgb[3 * i + 0] = rgb.x;
    out->rgb[3 * i + 1] = rgb.y;
    out->rgb[3 * i + 2] = rgb.z;
}

/* F(u) and I(u): BDPT for the primary sample vector u (bdpt.cl's combination, with the pixel
 * taken from u: u0 W and u1 H pick it, their fractions its film position through its filter, as
 * every other method's pixel samples, so that its estimate counts for that pixel alone). Non-finite
 * strategy results are dropped and counted as in BDPT. A sample whose I is not positive
 * gets I = 0 and no splats: it can never be a chain state. */
static void mltEvaluate(const SceneView* scene, const Camera* camera, __global const float* toRgb,
                        BdptSettings settings, const float* u, MltSample* out, int* rays,
                        int* nonFinite) {
    out->count = 0;
    out->luminance = 0.0f;
    SampleStream eyeStream = sampleStreamStart(0u, 0u, 0u);
    eyeStream.primary = u;
    eyeStream.primaryCount = CB_MLT_EYE_DIMS;
    SampleStream lightStream = sampleStreamStart(0u, 0u, 1u);
    lightStream.primary = u + CB_MLT_EYE_DIMS;
    lightStream.primaryCount = CB_MLT_LIGHT_DIMS;

    PathVertex light[CB_MAX_LIGHT_VERTICES];
    PathVertex eye[CB_MAX_EYE_VERTICES];
    int nLight = bdptLightSubpath(scene, lightStream, settings.lightVertices, light, rays);
    const float filmX = u[CB_DIM_PIXEL] * (float)camera->width;
    const float filmY = u[CB_DIM_PIXEL + 1u] * (float)camera->height;
    const int px = min((int)filmX, camera->width - 1);
    const int py = min((int)filmY, camera->height - 1);
    /* The box of radius 0.5 gives px + (filmX - px) = filmX: the film position itself. */
    float weightX, weightY;
    const float rasterX = filterPixelSample(camera, 0, px, filmX - (float)px, &weightX);
    const float rasterY = filterPixelSample(camera, 1, py, filmY - (float)py, &weightY);
    int nEye = bdptEyeSubpath(scene, camera, rasterX, rasterY, false, eyeStream,
                              settings.eyeVertices, eye, rays);

    Spectrum radiance = specZero();
    for (int t = 1; t <= nEye; ++t) {
        PathVertex nee[1]; /* s = 1's own light point for eye[t-1] */
        bool haveNee = bdptNeeLightVertex(scene, eyeStream, eye, t, nee);
        for (int s = 0; s <= nLight; ++s) {
            if (s == 1 && !haveNee) continue;
            float rx = 0.0f, ry = 0.0f;
            Spectrum c = bdptConnect(scene, camera, s == 1 ? nee : light, s, eye, t, settings, 1.0f,
                                     &rx, &ry, rays);
            if (specIsBlack(c)) continue;
            if (!specIsFinite(c)) {
                *nonFinite += 1;
                continue;
            }
            if (t == 1) {
                mltAddSplat(out, -1, rx, ry, filmClampSample(camera, specToRgb(c, toRgb), 1.0f));
            } else {
                radiance = specAdd(radiance, c);
            }
        }
    }
    Vec3 rgb = filmClampSample(camera, specToRgb(specScale(radiance, weightX * weightY), toRgb),
                               weightX * weightY);
    if (!(isfinite(rgb.x) && isfinite(rgb.y) && isfinite(rgb.z))) {
        *nonFinite += 1;
        rgb = vec3(0.0f, 0.0f, 0.0f);
    }
    if (rgb.x != 0.0f || rgb.y != 0.0f || rgb.z != 0.0f)
        mltAddSplat(out, py * camera->width + px, rasterX, rasterY, rgb);
    float lum = 0.0f;
    for (int i = 0; i < out->count; ++i)
        lum += fabs(mltLuminance(vec3(out->rgb[3 * i], out->rgb[3 * i + 1], out->rgb[3 * i + 2])));
    if (!(lum > 0.0f) || !isfinite(lum)) {
        out->count = 0;
        lum = 0.0f;
    }
    out->luminance = lum;
}

/* Uniform number k of the stream `key` (24 bits, in [0,1)). */
static float mltUniform(uint key, uint k) {
    return cbUintToUnitFloat(cbHashCombine(key, k));
}

static uint mltBootstrapKey(uint seed, uint index) {
    return cbHashCombine(cbHash32(seed ^ CB_MLT_BOOTSTRAP_SALT), index);
}

static void mltBootstrapVector(uint seed, uint index, float* u) {
    uint key = mltBootstrapKey(seed, index);
    for (uint d = 0u; d < CB_MLT_DIMS; ++d)
        u[d] = mltUniform(key, d);
}

static void mltStoreState(__global float* state, __global float* chainLum, __global int* splatCount,
                          __global int* splatPixel, __global float* splatRaster,
                          __global float* splatRgb, uint chain, const float* u,
                          const MltSample* s) {
    for (uint d = 0u; d < CB_MLT_DIMS; ++d)
        state[chain * CB_MLT_DIMS + d] = u[d];
    chainLum[chain] = s->luminance;
    splatCount[chain] = s->count;
    for (int i = 0; i < s->count; ++i) {
        splatPixel[chain * CB_MLT_MAX_SPLATS + (uint)i] = s->pixel[i];
        for (int a = 0; a < 2; ++a)
            splatRaster[2u * (chain * CB_MLT_MAX_SPLATS + (uint)i) + (uint)a] =
                s->raster[2 * i + a];
        for (int c = 0; c < 3; ++c)
            splatRgb[3u * (chain * CB_MLT_MAX_SPLATS + (uint)i) + (uint)c] = s->rgb[3 * i + c];
    }
}

/* Adds weight * F / I of a state to the image, light-tracing splats through the pixel filter. */
static void mltSplat(volatile __global float* image, const Camera* camera, const MltSample* s,
                     float weight) {
    if (!(weight > 0.0f) || !(s->luminance > 0.0f)) return;
    float scale = weight / s->luminance;
    for (int i = 0; i < s->count; ++i) {
        if (s->pixel[i] >= 0) {
            const uint p = (uint)s->pixel[i];
            for (int c = 0; c < 3; ++c)
                atomicAddFloat(&image[3u * p + (uint)c], scale * s->rgb[3 * i + c]);
            continue;
        }
        const FilterSplat splat = filterSplatAt(camera, s->raster[2 * i], s->raster[2 * i + 1]);
        for (int y = splat.y0; y <= splat.y1; ++y) {
            const float row = scale * filterSplatRow(camera, &splat, y);
            for (int x = splat.x0; x <= splat.x1; ++x) {
                const float share = row * filterSplatColumn(camera, &splat, x);
                const uint p = (uint)(y * camera->width + x);
                for (int c = 0; c < 3; ++c)
                    atomicAddFloat(&image[3u * p + (uint)c], share * s->rgb[3 * i + c]);
            }
        }
    }
}

/* Advance every chain by `mutations` steps (global step numbers firstStep ..). Each step
 * proposes a large step (all dimensions fresh) with probability largeStepProbability, otherwise
 * Kelemen's exponential perturbation of every dimension: |du| = s2 (s1/s2)^r, r uniform, random
 * sign, wrapped to [0,1). Acceptance a = min(1, I(proposal)/I(current)); both states are
 * splatted with expected-value weights (Veach 1997, sec. 11.5: current (1 - a), proposal a), the
 * current one lazily (its weight is summed until it is left or the launch ends, which splats the
 * same amounts with fewer atomics). The image receives sum weight * F / I; the host multiplies
 * by b * pixels / mutations. largeSum/largeCount collect I of large-step proposals, which are
 * uniform draws and so refine the estimate of b. */
static void mltAdvance(const SceneView* scene, const Camera* camera, __global const float* toRgb,
                       BdptSettings settingsCopy, uint seed, uint chain, uint firstStep,
                       int mutations, float largeStepProbability, float s1, float s2,
                       __global float* state, __global float* chainLum, __global int* splatCount,
                       __global int* splatPixel, __global float* splatRaster,
                       __global float* splatRgb, volatile __global float* image,
                       __global float* largeSum, __global uint* stats, int* rays, int* nonFinite) {
    float bufferA[CB_MLT_DIMS], bufferB[CB_MLT_DIMS];
    float* cur = bufferA;
    float* prop = bufferB;
    MltSample curSample, propSample;
    for (uint d = 0u; d < CB_MLT_DIMS; ++d)
        cur[d] = state[chain * CB_MLT_DIMS + d];
    curSample.luminance = chainLum[chain];
    curSample.count = splatCount[chain];
    for (int i = 0; i < curSample.count; ++i) {
        curSample.pixel[i] = splatPixel[chain * CB_MLT_MAX_SPLATS + (uint)i];
        for (int a = 0; a < 2; ++a)
            curSample.raster[2 * i + a] =
                splatRaster[2u * (chain * CB_MLT_MAX_SPLATS + (uint)i) + (uint)a];
        for (int c = 0; c < 3; ++c)
            curSample.rgb[3 * i + c] =
                splatRgb[3u * (chain * CB_MLT_MAX_SPLATS + (uint)i) + (uint)c];
    }

    const float logRatio = log(s2 / s1);
    uint accepted = 0u, large = 0u, largeAccepted = 0u, zero = 0u;
    float sumLarge = 0.0f;
    float curWeight = 0.0f;
    uint chainKey = cbHashCombine(cbHash32(seed ^ CB_MLT_MUTATION_SALT), chain);
    for (int m = 0; m < mutations; ++m) {
        uint key = cbHashCombine(chainKey, firstStep + (uint)m);
        bool isLarge = mltUniform(key, 0u) < largeStepProbability;
        for (uint d = 0u; d < CB_MLT_DIMS; ++d) {
            uint bits = cbHashCombine(key, 2u + d);
            if (isLarge) {
                prop[d] = cbUintToUnitFloat(bits);
            } else {
                float du = s2 * exp(-logRatio * cbUintToUnitFloat(bits));
                float x = (bits & 1u) ? cur[d] + du : cur[d] - du;
                if (x >= 1.0f) x -= 1.0f;
                if (x < 0.0f) x += 1.0f;
                prop[d] = x < 1.0f ? x : 0.0f; /* rounding of x - 1 + 1 */
            }
        }
        mltEvaluate(scene, camera, toRgb, settingsCopy, prop, &propSample, rays, nonFinite);
        if (isLarge) {
            large += 1u;
            sumLarge += propSample.luminance;
        }
        float a;
        if (!(propSample.luminance > 0.0f)) {
            a = 0.0f; /* also catches NaN */
            zero += 1u;
        } else if (!(curSample.luminance > 0.0f)) {
            a = 1.0f;
        } else {
            a = min(1.0f, propSample.luminance / curSample.luminance);
        }
        curWeight += 1.0f - a;
        mltSplat(image, camera, &propSample, a);
        if (mltUniform(key, 1u) < a) {
            mltSplat(image, camera, &curSample, curWeight);
            curWeight = 0.0f;
            float* tmp = cur;
            cur = prop;
            prop = tmp;
            curSample = propSample;
            accepted += 1u;
            if (isLarge) largeAccepted += 1u;
        }
    }
    mltSplat(image, camera, &curSample, curWeight);
    /* A zero current state (only if the bootstrap found nothing) splats nothing either way. */

    mltStoreState(state, chainLum, splatCount, splatPixel, splatRaster, splatRgb, chain, cur,
                  &curSample);
    largeSum[chain] = sumLarge;
    stats[CB_MLT_STATS * chain + CB_MLT_STAT_ACCEPTED] = accepted;
    stats[CB_MLT_STATS * chain + CB_MLT_STAT_LARGE] = large;
    stats[CB_MLT_STATS * chain + CB_MLT_STAT_LARGE_ACCEPTED] = largeAccepted;
    stats[CB_MLT_STATS * chain + CB_MLT_STAT_ZERO_PROPOSALS] = zero;
}

/* The three stages in one kernel, chosen by `stage` (the host's MltStage): PoCL compiles each
 * kernel of a program on its own, each with its own copy of the path code (mltEvaluate), so one
 * kernel compiles in a third of three's time. A stage's buffers that the others do not use are
 * passed as null. Bootstrap: I(u) of independent uniform vectors u_i, i = first .. first +
 * count - 1, into bootstrapLuminance; their mean estimates the normalisation b = integral of I
 * over [0,1)^D. Seed: chain c < count starts at bootstrap vector bootstrapIndex[c] (resampled on
 * the host in proportion to I, so the chains start close to their stationary distribution).
 * Advance: mltAdvance, chains c < count, from step number first. */
__kernel void mlt(CB_INTEGRATOR_KERNEL_PARAMS(BdptSettings), uint stage, uint count, uint first,
                  int mutations, float largeStepProbability, float s1, float s2,
                  __global float* bootstrapLuminance, __global const uint* bootstrapIndex,
                  __global float* state, __global float* chainLum, __global int* splatCount,
                  __global int* splatPixel, __global float* splatRaster, __global float* splatRgb,
                  volatile __global float* image, __global float* largeSum, __global uint* stats,
                  CB_COUNTER_PARAMS) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    CB_SCENE_VIEW(scene);
    BdptSettings settingsCopy = bdptSettingsCopy(settings);
    int rays = 0, nonFinite = 0;
    if (stage == CB_MLT_STAGE_ADVANCE) {
        mltAdvance(&scene, &camera, toRgb, settingsCopy, sampler.seed, i, first, mutations,
                   largeStepProbability, s1, s2, state, chainLum, splatCount, splatPixel,
                   splatRaster, splatRgb, image, largeSum, stats, &rays, &nonFinite);
        cbAddCounts(CB_COUNTERS, nonFinite, rays);
        return;
    }
    float u[CB_MLT_DIMS];
    const bool bootstrap = stage == CB_MLT_STAGE_BOOTSTRAP;
    mltBootstrapVector(sampler.seed, bootstrap ? first + i : bootstrapIndex[i], u);
    MltSample sample;
    mltEvaluate(&scene, &camera, toRgb, settingsCopy, u, &sample, &rays, &nonFinite);
    if (bootstrap) {
        bootstrapLuminance[i] = sample.luminance;
        cbAddCounts(CB_COUNTERS, nonFinite, rays);
    } else {
        mltStoreState(state, chainLum, splatCount, splatPixel, splatRaster, splatRgb, i, u,
                      &sample);
    }
}
