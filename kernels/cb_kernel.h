/* cb_kernel.h - what the integrator kernels (pt.cl, bdpt.cl, cbdpt.cl, mlt.cl) share: their first
 * parameters and their counters, which the host's KernelIntegrator
 * (src/integrators/kernel_integrator.h) sets in this order, and the end of a per-pixel kernel.
 * Kernel code only. */
#ifndef CB_KERNEL_H
#define CB_KERNEL_H

#include "cb_camera.h"
#include "cb_rng.h"
#include "cb_types.h"

#ifdef CB_KERNEL_SIDE
/* The first parameters of every integrator kernel: the scene, its spectrum-to-RGB matrix, the
 * camera, the method's settings (a struct of type SettingsType) and the sampler (seed and kind,
 * cb_rng.h). */
#define CB_INTEGRATOR_KERNEL_PARAMS(SettingsType)                                                  \
    CB_SCENE_KERNEL_PARAMS, __global const float *toRgb, Camera camera, SettingsType settings,     \
        SamplerSettings sampler

/* A per-pixel kernel's first lines: its pixel (x, y), leaving when it is outside the film, the
 * scene view, and samplerCopy, the private field-by-field copy of the sampler argument that the
 * kernel hands on: NVIDIA's compiler misread the by-value argument passed to an inlined function
 * (docs/gpu.md). */
#define CB_PIXEL_KERNEL_BEGIN(x, y, scene)                                                         \
    const int x = (int)get_global_id(0);                                                           \
    const int y = (int)get_global_id(1);                                                           \
    if (x >= camera.width || y >= camera.height) return;                                           \
    CB_SCENE_VIEW(scene);                                                                          \
    const SamplerSettings samplerCopy = samplerSettingsCopy(sampler)

/* The last parameters: the count of samples dropped as NaN or infinite (cumulative over the
 * render) and of rays traced (per launch, added only when countRays is set, since one atomic per
 * work-item on one counter contends between threads). */
#define CB_COUNTER_PARAMS                                                                          \
    volatile __global int *nonFiniteCount, volatile __global uint *rayCount, int countRays

static void cbAddCounts(volatile __global int* nonFiniteCount, volatile __global uint* rayCount,
                        int countRays, int nonFinite, int rays) {
    if (nonFinite > 0) atomic_add(nonFiniteCount, nonFinite);
    if (countRays) atomic_add(rayCount, (uint)rays);
}

/* The end of a per-pixel kernel: the pixel's RGB into outRgb (black, and counted, when it is not
 * finite) and the work-item's counts. `nonFinite` is what the work-item dropped already. */
static void cbWritePixel(__global float* outRgb, volatile __global int* nonFiniteCount,
                         volatile __global uint* rayCount, int countRays, uint pixel, Vec3 rgb,
                         int nonFinite, int rays) {
    if (!(isfinite(rgb.x) && isfinite(rgb.y) && isfinite(rgb.z))) {
        ++nonFinite;
        rgb = vec3(0.0f, 0.0f, 0.0f);
    }
    cbAddCounts(nonFiniteCount, rayCount, countRays, nonFinite, rays);
    outRgb[3 * pixel + 0] = rgb.x;
    outRgb[3 * pixel + 1] = rgb.y;
    outRgb[3 * pixel + 2] = rgb.z;
}

/* The arguments of cbWritePixel and cbAddCounts that a kernel passes on as it received them. */
#define CB_COUNTERS nonFiniteCount, rayCount, countRays
#endif

#endif /* CB_KERNEL_H */
