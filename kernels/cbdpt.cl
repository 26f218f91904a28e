/* cbdpt.cl - the combination kernel of coherent bidirectional path tracing (docs/method.md, CBDPT;
 * docs/cbdpt.md). The host has traced this estimate's light subpaths (one per coherence-tile
 * position) with the same cb_bdpt.h code and splats their camera connections (t = 1) itself.
 * Here each pixel traces its eye subpath from the sample vector it shares with every pixel at
 * the same tile position (jitter included, as CPT), copies its tile position's light subpath into
 * private memory, and adds every strategy with t >= 2 with the BDPT weights. */
#include "cb_bdpt.h"
#include "cb_kernel.h"

#ifndef CB_MAX_EYE_VERTICES
#define CB_MAX_EYE_VERTICES 8
#endif
#ifndef CB_MAX_LIGHT_VERTICES
#define CB_MAX_LIGHT_VERTICES 8
#endif

/* streamTile = k: pixel (x, y) sits at tile position (y mod k, x mod k); its eye stream key is
 * that position's index (y mod k) * k + (x mod k), as in pt.cl, and its light subpath is number
 * (y mod k) * tileColumns + (x mod k) of lightVertices (tileColumns = min(k, width)), each
 * subpath owning lightVertexStride slots. cameraCount = (light subpaths) / (W*H): the t = 1
 * strategy's sampling rate relative to BDPT's, for the power heuristic (docs/cbdpt.md). The host
 * drew the eye streams' first sharedDimensions values into sharedSamples (0: none). */
#define CB_CBDPT_PARAMS                                                                            \
    CB_INTEGRATOR_KERNEL_PARAMS(BdptSettings), uint estimate, int streamTile, int tileColumns,     \
        __global const PathVertex *lightVertices, __global const int *lightCounts,                 \
        int lightVertexStride, float cameraCount, __global const float *sharedSamples,             \
        uint sharedDimensions

/* Pixel (x, y)'s light subpath, copied into light (cb_bdpt.h reads vertices through private
 * pointers; Nl is a handful), its vertex count into nLight, and its eye stream into eyeStream
 * (sampler: a pointer to the kernel's private copy of its sampler settings). */
#define CB_CBDPT_PIXEL_LIGHT(sampler, x, y, light, nLight, eyeStream)                              \
    do {                                                                                           \
        const int subpath = ((y) % streamTile) * tileColumns + (x) % streamTile;                   \
        nLight = lightCounts[subpath];                                                             \
        for (int i = 0; i < nLight; ++i)                                                           \
            light[i] = lightVertices[subpath * lightVertexStride + i];                             \
        eyeStream = CB_CBDPT_EYE_STREAM(sampler, x, y);                                            \
    } while (0)
/* Pixel (x, y)'s eye stream: its tile position's shared sample vector. */
#define CB_CBDPT_EYE_STREAM(sampler, x, y)                                                         \
    samplerStreamShared(*(sampler), estimate,                                                      \
                        (uint)(((y) % streamTile) * streamTile + (x) % streamTile), sharedSamples, \
                        sharedDimensions)

/* The strategies t = 2 .. nEye, s = 0 .. nLight of a pixel in order (scene: a SceneView
 * pointer), each through CB_CBDPT_STRATEGY(t, s, lightOrNee), which the kernel defines. */
#define CB_CBDPT_STRATEGIES(scene, eye, nEye, light, nLight, eyeStream)                            \
    for (int t = 2; t <= nEye; ++t) {                                                              \
        PathVertex nee[1]; /* s = 1's own light point for eye[t-1] (shared u: coherent) */         \
        bool haveNee = bdptNeeLightVertex(scene, eyeStream, eye, t, nee);                          \
        for (int s = 0; s <= nLight; ++s) {                                                        \
            if (s == 1 && !haveNee) continue;                                                      \
            CB_CBDPT_STRATEGY(t, s, s == 1 ? nee : light);                                         \
        }                                                                                          \
    }

/* A strategy's contribution counts unless it is black; a non-finite one is dropped and counted. */
#define CB_CBDPT_ADD(radiance, c, nonFinite)                                                       \
    do {                                                                                           \
        if (specIsBlack(c)) break;                                                                 \
        if (!specIsFinite(c)) {                                                                    \
            ++nonFinite;                                                                           \
            break;                                                                                 \
        }                                                                                          \
        radiance = specAdd(radiance, c);                                                           \
    } while (0)

/* Pixel (x, y)'s estimate: its eye subpath and every strategy with its tile position's light
 * subpath. A function renderCbdpt calls rather than the kernel's body, as bdptRenderPixel in
 * bdpt.cl: PoCL keeps the values a kernel body holds across its work-item loop as per-work-item
 * arrays, which a called function's locals are not. The parameters carry the names the
 * CB_CBDPT_* macros read; the settings and the sampler come through pointers to the kernel's
 * private copies, as in bdptRenderPixel. */
static __attribute__((noinline)) void
cbdptRenderPixel(const SceneView* scene, const Camera* camera, const BdptSettings* settings,
                 const SamplerSettings* sampler, uint estimate, int streamTile, int tileColumns,
                 __global const PathVertex* lightVertices, __global const int* lightCounts,
                 int lightVertexStride, float cameraCount, __global const float* sharedSamples,
                 uint sharedDimensions, __global const float* toRgb, __global float* outRgb,
                 CB_COUNTER_PARAMS, int x, int y) {
    int rays = 0;
    PathVertex light[CB_MAX_LIGHT_VERTICES];
    int nLight;
    SampleStream eyeStream;
    CB_CBDPT_PIXEL_LIGHT(sampler, x, y, light, nLight, eyeStream);
    PathVertex eye[CB_MAX_EYE_VERTICES];
    float rasterX, rasterY;
    const float filterWeight = cameraSampleRaster(camera, eyeStream, x, y, &rasterX, &rasterY);
    int nEye = bdptEyeSubpath(scene, camera, rasterX, rasterY, true, eyeStream,
                              settings->eyeVertices, eye, &rays);

    Spectrum radiance = specZero();
    int nonFinite = 0;
#define CB_CBDPT_STRATEGY(t, s, lightOrNee)                                                        \
    do {                                                                                           \
        float rx = 0.0f, ry = 0.0f;                                                                \
        /* Weighed per strategy, as cbdpt_packets.cl weighs them, so both sum the same terms. */   \
        Spectrum c = specScale(bdptConnect(scene, camera, lightOrNee, s, eye, t, *settings,        \
                                           cameraCount, &rx, &ry, &rays),                          \
                               filterWeight);                                                      \
        CB_CBDPT_ADD(radiance, c, nonFinite);                                                      \
    } while (0)
    CB_CBDPT_STRATEGIES(scene, eye, nEye, light, nLight, eyeStream)
#undef CB_CBDPT_STRATEGY
    cbWritePixel(outRgb, CB_COUNTERS, (uint)(y * camera->width + x),
                 filmClampSample(camera, specToRgb(radiance, toRgb), filterWeight), nonFinite,
                 rays);
}

__kernel void renderCbdpt(CB_CBDPT_PARAMS, __global float* outRgb, CB_COUNTER_PARAMS) {
    CB_PIXEL_KERNEL_BEGIN(x, y, scene);
    const BdptSettings settingsCopy = bdptSettingsCopy(settings);
    cbdptRenderPixel(&scene, &camera, &settingsCopy, &samplerCopy, estimate, streamTile,
                     tileColumns, lightVertices, lightCounts, lightVertexStride, cameraCount,
                     sharedSamples, sharedDimensions, toRgb, outRgb, CB_COUNTERS, x, y);
}
