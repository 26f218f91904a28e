/* pt.cl - path tracing (PT) and, through the shared sample vector, coherent path tracing
 * (CPT). One work-item per pixel; work-groups are square pixel tiles. */
#include "cb_pt.h"

/* streamTile: 0 for PT, k > 0 for CPT with k x k shared sample vectors (ptPixelRgb). */
__kernel void renderPathTracing(CB_SCENE_KERNEL_PARAMS,
                                __global const float* toRgb,
                                Camera camera,
                                PathSettings settings,
                                SamplerSettings sampler,
                                uint estimate,
                                int streamTile,
                                __global float* outRgb,
                                volatile __global int* nonFiniteCount) {
    int x = (int)get_global_id(0);
    int y = (int)get_global_id(1);
    if (x >= camera.width || y >= camera.height) return;

    CB_SCENE_VIEW(scene);

    Vec3 rgb = ptPixelRgb(&scene, toRgb, &camera, settings, sampler, estimate, streamTile, x, y);
    if (!(isfinite(rgb.x) && isfinite(rgb.y) && isfinite(rgb.z))) {
        atomic_inc(nonFiniteCount);
        rgb = vec3(0.0f, 0.0f, 0.0f);
    }
    int pixel = y * camera.width + x;
    outRgb[3 * pixel + 0] = rgb.x;
    outRgb[3 * pixel + 1] = rgb.y;
    outRgb[3 * pixel + 2] = rgb.z;
}
