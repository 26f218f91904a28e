/* bdpt.cl - bidirectional path tracing (METHOD.md, BDPT). One work-item per pixel, work-groups
 * are square pixel tiles: each work-item traces a light subpath and an eye subpath into private
 * arrays and combines every (s,t) allowed by the caps. Light-tracing (t = 1) contributions land
 * in other pixels and are added to a separate splat image with atomic float adds; the host adds
 * the splat image to the pixel image after the kernel. */
#include "cb_atomics.h"
#include "cb_bdpt.h"

#ifndef CB_MAX_EYE_VERTICES
#define CB_MAX_EYE_VERTICES 8
#endif
#ifndef CB_MAX_LIGHT_VERTICES
#define CB_MAX_LIGHT_VERTICES 8
#endif


__kernel void renderBdpt(CB_SCENE_KERNEL_PARAMS,
                         __global const float* toRgb,
                         Camera camera,
                         BdptSettings settings,
                         SamplerSettings sampler,
                         uint estimate,
                         __global float* outRgb,
                         volatile __global float* splatRgb,
                         volatile __global int* nonFiniteCount,
                         volatile __global uint* rayCount,
                         int countRays) {
    int x = (int)get_global_id(0);
    int y = (int)get_global_id(1);
    if (x >= camera.width || y >= camera.height) return;

    CB_SCENE_VIEW(scene);

    uint pixel = (uint)(y * camera.width + x);
    int rays = 0;
    PathVertex light[CB_MAX_LIGHT_VERTICES];
    PathVertex eye[CB_MAX_EYE_VERTICES];
    int nLight = bdptLightSubpath(&scene, bdptLightStream(sampler, estimate, pixel),
                                  settings.lightVertices, light, &rays);
    SampleStream eyeStream = samplerStream(sampler, estimate, pixel);
    float rasterX, rasterY;
    cameraJitteredRaster(eyeStream, x, y, &rasterX, &rasterY);
    int nEye = bdptEyeSubpath(&scene, &camera, rasterX, rasterY, true, eyeStream,
                              settings.eyeVertices, eye, &rays);

    Spectrum radiance = specZero();
    int nonFinite = 0;
    for (int t = 1; t <= nEye; ++t) {
        PathVertex nee[1]; /* s = 1's own light point for eye[t-1] */
        bool haveNee = bdptNeeLightVertex(&scene, eyeStream, eye, t, nee);
        for (int s = 0; s <= nLight; ++s) {
            if (s == 1 && !haveNee) continue;
            float rx = 0.0f, ry = 0.0f;
            Spectrum c = bdptConnect(&scene, &camera, s == 1 ? nee : light, s, eye, t, settings,
                                     1.0f, &rx, &ry, &rays);
            if (specIsBlack(c)) continue;
            if (!specIsFinite(c)) {
                ++nonFinite;
                continue;
            }
            if (t == 1) {
                Vec3 rgb = specToRgb(c, toRgb);
                int px = min((int)rx, camera.width - 1);
                int py = min((int)ry, camera.height - 1);
                uint target = (uint)(py * camera.width + px);
                atomicAddFloat(&splatRgb[3 * target + 0], rgb.x);
                atomicAddFloat(&splatRgb[3 * target + 1], rgb.y);
                atomicAddFloat(&splatRgb[3 * target + 2], rgb.z);
            } else {
                radiance = specAdd(radiance, c);
            }
        }
    }
    Vec3 rgb = specToRgb(radiance, toRgb);
    if (!(isfinite(rgb.x) && isfinite(rgb.y) && isfinite(rgb.z))) {
        ++nonFinite;
        rgb = vec3(0.0f, 0.0f, 0.0f);
    }
    if (nonFinite > 0) atomic_add(nonFiniteCount, nonFinite);
    /* A per-pixel atomic on one counter contends between threads: only when asked for. */
    if (countRays) atomic_add(rayCount, (uint)rays);
    outRgb[3 * pixel + 0] = rgb.x;
    outRgb[3 * pixel + 1] = rgb.y;
    outRgb[3 * pixel + 2] = rgb.z;
}
