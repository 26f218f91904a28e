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
__kernel void renderCbdpt(CB_INTEGRATOR_KERNEL_PARAMS(BdptSettings),
                          uint estimate,
                          int streamTile,
                          int tileColumns,
                          __global const PathVertex* lightVertices,
                          __global const int* lightCounts,
                          int lightVertexStride,
                          float cameraCount,
                          __global const float* sharedSamples,
                          uint sharedDimensions,
                          __global float* outRgb,
                          CB_COUNTER_PARAMS) {
    int x = (int)get_global_id(0);
    int y = (int)get_global_id(1);
    if (x >= camera.width || y >= camera.height) return;

    CB_SCENE_VIEW(scene);

    int ti = y % streamTile;
    int tj = x % streamTile;
    uint stream = (uint)(ti * streamTile + tj);
    int subpath = ti * tileColumns + tj;

    /* cb_bdpt.h reads light vertices through private pointers; Nl is a handful. */
    PathVertex light[CB_MAX_LIGHT_VERTICES];
    int nLight = lightCounts[subpath];
    for (int i = 0; i < nLight; ++i)
        light[i] = lightVertices[subpath * lightVertexStride + i];

    int rays = 0;
    PathVertex eye[CB_MAX_EYE_VERTICES];
    SampleStream eyeStream =
        samplerStreamShared(sampler, estimate, stream, sharedSamples, sharedDimensions);
    float rasterX, rasterY;
    cameraJitteredRaster(eyeStream, x, y, &rasterX, &rasterY);
    int nEye = bdptEyeSubpath(&scene, &camera, rasterX, rasterY, true, eyeStream,
                              settings.eyeVertices, eye, &rays);

    Spectrum radiance = specZero();
    int nonFinite = 0;
    for (int t = 2; t <= nEye; ++t) {
        PathVertex nee[1]; /* s = 1's own light point for eye[t-1] (shared u: coherent) */
        bool haveNee = bdptNeeLightVertex(&scene, eyeStream, eye, t, nee);
        for (int s = 0; s <= nLight; ++s) {
            if (s == 1 && !haveNee) continue;
            float rx = 0.0f, ry = 0.0f;
            Spectrum c = bdptConnect(&scene, &camera, s == 1 ? nee : light, s, eye, t, settings,
                                     cameraCount, &rx, &ry, &rays);
            if (specIsBlack(c)) continue;
            if (!specIsFinite(c)) {
                ++nonFinite;
                continue;
            }
            radiance = specAdd(radiance, c);
        }
    }
    cbWritePixel(outRgb, CB_COUNTERS, (uint)(y * camera.width + x), specToRgb(radiance, toRgb),
                 nonFinite, rays);
}
