/* pt.cl - path tracing (PT) and, through the shared sample vector, coherent path tracing
 * (CPT). One work-item per pixel; work-groups are square pixel tiles. */
#include "cb_kernel.h"
#include "cb_pt.h"

/* streamTile: 0 for PT, k > 0 for CPT with k x k shared sample vectors (ptPixelRgb), whose
 * first sharedDimensions values the host drew into sharedSamples (0: the kernel draws them). */
__kernel void renderPathTracing(CB_INTEGRATOR_KERNEL_PARAMS(PathSettings),
                                uint estimate,
                                int streamTile,
                                __global const float* sharedSamples,
                                uint sharedDimensions,
                                __global float* outRgb,
                                CB_COUNTER_PARAMS) {
    int x = (int)get_global_id(0);
    int y = (int)get_global_id(1);
    if (x >= camera.width || y >= camera.height) return;

    CB_SCENE_VIEW(scene);

    Vec3 rgb = ptPixelRgb(&scene, toRgb, &camera, settings, sampler, estimate, streamTile,
                          sharedSamples, sharedDimensions, x, y);
    /* ptPixelRgb does not count its rays. */
    cbWritePixel(outRgb, CB_COUNTERS, (uint)(y * camera.width + x), rgb, 0, 0);
}
