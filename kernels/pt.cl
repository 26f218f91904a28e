/* pt.cl - path tracing (PT) and, through the shared sample vector, coherent path tracing
 * (CPT). One work-item per pixel; work-groups are square pixel tiles. */
#include "cb_pt.h"

/* streamTile == 0: every pixel has its own sample vector (PT).
 * streamTile == k > 0: the image is covered by a k x k grid of tiles and the pixel at position
 * (i, j) inside its tile uses vector (i, j) of the estimate (CPT, METHOD.md). */
__kernel void renderPathTracing(CB_SCENE_KERNEL_PARAMS,
                                __global const float* toRgb,
                                Camera camera,
                                PathSettings settings,
                                uint seed,
                                uint estimate,
                                int streamTile,
                                __global float* outRgb,
                                volatile __global int* nonFiniteCount) {
    int x = (int)get_global_id(0);
    int y = (int)get_global_id(1);
    if (x >= camera.width || y >= camera.height) return;

    CB_SCENE_VIEW(scene);

    uint pixel = (uint)(y * camera.width + x);
    uint stream = streamTile > 0 ? (uint)((y % streamTile) * streamTile + (x % streamTile)) : pixel;
    SampleStream samples = sampleStreamStart(seed, estimate, stream);
    float rasterX, rasterY;
    cameraJitteredRaster(samples, x, y, &rasterX, &rasterY);
    Ray ray = cameraGenerateRay(&camera, rasterX, rasterY);

    Spectrum radiance = ptRadiance(&scene, ray, samples, settings);
    Vec3 rgb = specToRgb(radiance, toRgb);
    if (!(isfinite(rgb.x) && isfinite(rgb.y) && isfinite(rgb.z))) {
        atomic_inc(nonFiniteCount);
        rgb = vec3(0.0f, 0.0f, 0.0f);
    }
    outRgb[3 * pixel + 0] = rgb.x;
    outRgb[3 * pixel + 1] = rgb.y;
    outRgb[3 * pixel + 2] = rgb.z;
}
