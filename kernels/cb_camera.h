/* cb_camera.h - perspective camera, pinhole or thin lens, pbrt-v4 conventions (see Camera in
 * cb_types.h). */
#ifndef CB_CAMERA_H
#define CB_CAMERA_H

#include "cb_filter.h"
#include "cb_rng.h"
#include "cb_sampling.h"
#include "cb_types.h"

CB_BEGIN_NAMESPACE

/* The point on the lens, in camera space (z = 0), for the lens sample (u0, u1): uniform over the
 * lens disk by the concentric map (pbrt-v4's SampleUniformDiskConcentric), the origin for a
 * pinhole. */
CB_FN Vec3 cameraLensPoint(const Camera* camera, real u0, real u1) {
#if CB_HAS(CB_FEATURE_THIN_LENS)
    if (camera->lensRadius > 0.0f) {
        real x, y;
        sampleConcentricDisk(u0, u1, &x, &y);
        return vec3(x * camera->lensRadius, y * camera->lensRadius, 0.0f);
    }
#endif
    (void)camera;
    (void)u0;
    (void)u1;
    return vec3(0.0f, 0.0f, 0.0f);
}

/* The lens point of a sample stream: dimensions `dimension` and + 1 (a camera with a lens only). */
CB_FN Vec3 cameraStreamLensPoint(const Camera* camera, SampleStream stream, uint dimension) {
#if CB_HAS(CB_FEATURE_THIN_LENS)
    if (camera->lensRadius > 0.0f) {
        real u0, u1;
        sampleAt2(stream, dimension, &u0, &u1);
        return cameraLensPoint(camera, u0, u1);
    }
#endif
    (void)camera;
    (void)stream;
    (void)dimension;
    return vec3(0.0f, 0.0f, 0.0f);
}

/* Primary ray through raster position (rasterX, rasterY), (0,0) the top-left image corner, from
 * `lens` (camera space, cameraLensPoint). Direction is unit length. A pinhole's ray leaves the
 * camera position; a thin lens's leaves the lens point toward where the pinhole ray meets the
 * plane of focus (pbrt-v4's PerspectiveCamera::GenerateRay). */
CB_FN Ray cameraGenerateRay(const Camera* camera, real rasterX, real rasterY, Vec3 lens) {
    real sx =
        camera->screenCenterX + (2.0f * rasterX / (real)camera->width - 1.0f) * camera->tanHalfFovX;
    real sy = camera->screenCenterY +
              (1.0f - 2.0f * rasterY / (real)camera->height) * camera->tanHalfFovY;
    Vec3 origin = vec3(0.0f, 0.0f, 0.0f), dir = vec3(sx, sy, 1.0f);
#if CB_HAS(CB_FEATURE_THIN_LENS)
    if (camera->lensRadius > 0.0f) {
        origin = lens;
        dir = vsub(vscale(dir, camera->focalDistance), lens);
    }
#endif
    (void)lens;
    Ray ray;
    ray.o = affineTransformPoint(camera->cameraToWorld, origin);
    ray.d = vnormalize(affineTransformVector(camera->cameraToWorld, dir));
    return ray;
}

/* Where pixel (x, y)'s sample lands on the film: drawn from the pixel's filter (cb_filter.h; the
 * box of radius 0.5: its corner plus the jitter) by dimensions CB_DIM_PIXEL and CB_DIM_PIXEL + 1
 * of its sample stream (docs/method.md). Shared vectors (CPT, CBDPT) share the offset too.
 * Returns the sample's filter weight, which multiplies what the eye path brings to the pixel
 * (not its light-tracing splats): 1 but for filters with negative lobes. */
CB_FN real cameraSampleRaster(const Camera* camera, SampleStream stream, int x, int y,
                              real* rasterX, real* rasterY) {
    real u0, u1, weightX, weightY;
    sampleAt2(stream, CB_DIM_PIXEL, &u0, &u1);
    *rasterX = filterPixelSample(camera, 0, x, u0, &weightX);
    *rasterY = filterPixelSample(camera, 1, y, u1, &weightY);
    return weightX * weightY;
}

/* The weight cameraSampleRaster returns for the same stream, for kernels that placed the sample
 * earlier and kept only its ray: without the position, whose gaussian inversion is the costly
 * part, and 1 at once for filters that are never negative. */
CB_FN real cameraSampleWeight(const Camera* camera, SampleStream stream) {
#if CB_HAS(CB_FEATURE_PIXEL_FILTER)
    if (!filterHasNegativeLobes(camera->filterType)) return 1.0f;
    real u0, u1, weightX, weightY;
    sampleAt2(stream, CB_DIM_PIXEL, &u0, &u1);
    (void)filterTableSample1(camera, 0, u0, &weightX);
    (void)filterTableSample1(camera, 1, u1, &weightY);
    return weightX * weightY;
#else
    (void)camera;
    (void)stream;
    return 1.0f;
#endif
}

/* Raster position of a world point seen from the world point `lens` on the lens (the camera
 * position for a pinhole), if it lies in front of the camera where some pixel's filter reaches
 * (the image for the box of radius 0.5, filterReaches): for a thin
 * lens, where the ray from the lens point through p meets the plane of focus, projected through
 * the lens centre (pbrt-v4's PerspectiveCamera::We). */
CB_FN bool cameraProjectPoint(const Camera* camera, Vec3 lens, Vec3 p, real* rasterX,
                              real* rasterY) {
    Vec3 c = affineTransformPoint(camera->worldToCamera, p);
#if CB_HAS(CB_FEATURE_THIN_LENS)
    if (camera->lensRadius > 0.0f) {
        Vec3 l = affineTransformPoint(camera->worldToCamera, lens);
        Vec3 d = vsub(c, l);
        if (!(d.z > 0.0f)) return false;
        c = vmadd(l, d, camera->focalDistance / d.z);
    }
#endif
    (void)lens;
    if (c.z <= 0.0f) return false;
    real sx = (c.x - camera->screenCenterX * c.z) / (c.z * camera->tanHalfFovX);
    real sy = (c.y - camera->screenCenterY * c.z) / (c.z * camera->tanHalfFovY);
    *rasterX = (sx + 1.0f) * 0.5f * (real)camera->width;
    *rasterY = (1.0f - sy) * 0.5f * (real)camera->height;
    return filterReaches(camera, *rasterX, *rasterY);
}

/* pbrt-v4's RGBFilm::AddSample and AddSplat clamp each sample (the film's "maxcomponentvalue"):
 * its sensor RGB is scaled so that its largest component is at most camera->sampleClamp, before
 * the pixel filter weighs it. `rgb` is the sample's film RGB already times `weight`, its filter
 * weight (1 for a light-tracing splat), as the kernels form it; the test is on rgb / weight, so a
 * negative lobe's weight keeps its sign. A scene without the clamp compiles none of it. */
CB_FN Vec3 filmClampSample(const Camera* camera, Vec3 rgb, real weight) {
#if CB_HAS(CB_FEATURE_SAMPLE_CLAMP)
    if (camera->sampleClamp > 0.0f && weight != 0.0f) {
        const real* m = camera->sensorFromRgb;
        const Vec3 sensor = vec3(m[0] * rgb.x + m[1] * rgb.y + m[2] * rgb.z,
                                 m[3] * rgb.x + m[4] * rgb.y + m[5] * rgb.z,
                                 m[6] * rgb.x + m[7] * rgb.y + m[8] * rgb.z);
        const real largest = vmaxComponent(vscale(sensor, 1.0f / weight));
        if (largest > camera->sampleClamp) return vscale(rgb, camera->sampleClamp / largest);
    }
#endif
    (void)camera;
    (void)weight;
    return rgb;
}

CB_END_NAMESPACE

#endif /* CB_CAMERA_H */
