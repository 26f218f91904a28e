/* bdpt.cl - bidirectional path tracing (docs/method.md, BDPT). One work-item per pixel, work-groups
 * are square pixel tiles: each pixel traces a light subpath and an eye subpath into private
 * arrays and combines every (s,t) allowed by the caps. Light-tracing (t = 1) contributions land
 * in other pixels: each pixel records its own (one slot per light vertex: raster point and RGB)
 * and the host adds them, through the pixel filter, in pixel order, so an estimate is the same
 * bits however the work-items were scheduled (atomic float adds would sum in a different order
 * each run). */
#include "cb_bdpt.h"
#include "cb_kernel.h"

#ifndef CB_MAX_EYE_VERTICES
#define CB_MAX_EYE_VERTICES 8
#endif
#ifndef CB_MAX_LIGHT_VERTICES
#define CB_MAX_LIGHT_VERTICES 8
#endif

/* Pixel (x, y)'s estimate: its light and eye subpaths and every strategy between them. The
 * settings and the sampler come through pointers to the kernel's field-by-field private copies,
 * never as by-value structs (docs/gpu.md: NVIDIA's compiler misread such an argument once this
 * function was inlined). */
static void bdptRenderPixel(const SceneView* scene, const Camera* camera,
                            const BdptSettings* settings, const SamplerSettings* sampler,
                            uint estimate, __global const float* toRgb, __global int* splatUsed,
                            __global float* splatRaster, __global float* splatRgb,
                            __global float* outRgb, CB_COUNTER_PARAMS, int x, int y) {
    uint pixel = (uint)(y * camera->width + x);
    int rays = 0;
    PathVertex light[CB_MAX_LIGHT_VERTICES];
    PathVertex eye[CB_MAX_EYE_VERTICES];
    int nLight = bdptLightSubpath(
        scene, bdptLightStream(*sampler, estimate, pixel, (uint)(camera->width * camera->height)),
        settings->lightVertices, light, &rays);
    SampleStream eyeStream = samplerStream(*sampler, estimate, pixel);
    float rasterX, rasterY;
    const float filterWeight = cameraSampleRaster(camera, eyeStream, x, y, &rasterX, &rasterY);
    int nEye = bdptEyeSubpath(scene, camera, rasterX, rasterY, true, eyeStream,
                              settings->eyeVertices, eye, &rays);

    Spectrum radiance = specZero();
    int nonFinite = 0;
    const uint splatBase = pixel * (uint)CB_MAX_LIGHT_VERTICES;
    for (int k = 0; k < CB_MAX_LIGHT_VERTICES; ++k)
        splatUsed[splatBase + (uint)k] = 0;
    for (int t = 1; t <= nEye; ++t) {
        PathVertex nee[1]; /* s = 1's own light point for eye[t-1] */
        bool haveNee = bdptNeeLightVertex(scene, eyeStream, eye, t, nee);
        for (int s = 0; s <= nLight; ++s) {
            if (s == 1 && !haveNee) continue;
            float rx = 0.0f, ry = 0.0f;
            Spectrum c = bdptConnect(scene, camera, s == 1 ? nee : light, s, eye, t, *settings,
                                     1.0f, &rx, &ry, &rays);
            if (specIsBlack(c)) continue;
            if (!specIsFinite(c)) {
                ++nonFinite;
                continue;
            }
            if (t == 1) {
                Vec3 rgb = filmClampSample(camera, specToRgb(c, toRgb), 1.0f);
                /* s >= 1 when t = 1: slot s - 1 of this pixel's light vertices. */
                const uint slot = splatBase + (uint)(s - 1);
                splatUsed[slot] = 1;
                splatRaster[2 * slot + 0] = rx;
                splatRaster[2 * slot + 1] = ry;
                splatRgb[3 * slot + 0] = rgb.x;
                splatRgb[3 * slot + 1] = rgb.y;
                splatRgb[3 * slot + 2] = rgb.z;
            } else {
                radiance = specAdd(radiance, c);
            }
        }
    }
    cbWritePixel(
        outRgb, CB_COUNTERS, pixel,
        filmClampSample(camera, specToRgb(specScale(radiance, filterWeight), toRgb), filterWeight),
        nonFinite, rays);
}

__kernel void renderBdpt(CB_INTEGRATOR_KERNEL_PARAMS(BdptSettings), uint estimate,
                         __global int* splatUsed, __global float* splatRaster,
                         __global float* splatRgb, __global float* outRgb, CB_COUNTER_PARAMS) {
    CB_PIXEL_KERNEL_BEGIN(x, y, scene);
    const BdptSettings settingsCopy = bdptSettingsCopy(settings);
    bdptRenderPixel(&scene, &camera, &settingsCopy, &samplerCopy, estimate, toRgb, splatUsed,
                    splatRaster, splatRgb, outRgb, CB_COUNTERS, x, y);
}
