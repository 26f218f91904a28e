/* cb_camera.h - pinhole perspective camera, pbrt-v4 conventions (see Camera in cb_types.h). */
#ifndef CB_CAMERA_H
#define CB_CAMERA_H

#include "cb_rng.h"
#include "cb_types.h"

CB_BEGIN_NAMESPACE

/* Primary ray through raster position (rasterX, rasterY), (0,0) the top-left image corner.
 * Direction is unit length; origin is the camera position. */
CB_FN Ray cameraGenerateRay(const Camera* camera, real rasterX, real rasterY) {
    real sx =
        camera->screenCenterX + (2.0f * rasterX / (real)camera->width - 1.0f) * camera->tanHalfFovX;
    real sy = camera->screenCenterY +
              (1.0f - 2.0f * rasterY / (real)camera->height) * camera->tanHalfFovY;
    Ray ray;
    ray.o = affineTransformPoint(camera->cameraToWorld, vec3(0.0f, 0.0f, 0.0f));
    ray.d = vnormalize(affineTransformVector(camera->cameraToWorld, vec3(sx, sy, 1.0f)));
    return ray;
}

/* Where pixel (x, y)'s sample lands on the film: the pixel's corner plus the jitter read from
 * dimensions CB_DIM_PIXEL and CB_DIM_PIXEL + 1 of its sample stream (one sample per pixel,
 * box filter: docs/method.md). Shared vectors (CPT, CBDPT) share the jitter too. */
CB_FN void cameraJitteredRaster(SampleStream stream, int x, int y, real* rasterX, real* rasterY) {
    real jitterX, jitterY;
    sampleAt2(stream, CB_DIM_PIXEL, &jitterX, &jitterY);
    *rasterX = (real)x + jitterX;
    *rasterY = (real)y + jitterY;
}

/* Raster position of a world point, if it lies in front of the camera and inside the image. */
CB_FN bool cameraProjectPoint(const Camera* camera, Vec3 p, real* rasterX, real* rasterY) {
    Vec3 c = affineTransformPoint(camera->worldToCamera, p);
    if (c.z <= 0.0f) return false;
    real sx = (c.x - camera->screenCenterX * c.z) / (c.z * camera->tanHalfFovX);
    real sy = (c.y - camera->screenCenterY * c.z) / (c.z * camera->tanHalfFovY);
    *rasterX = (sx + 1.0f) * 0.5f * (real)camera->width;
    *rasterY = (1.0f - sy) * 0.5f * (real)camera->height;
    return *rasterX >= 0.0f && *rasterX < (real)camera->width && *rasterY >= 0.0f &&
           *rasterY < (real)camera->height;
}

CB_END_NAMESPACE

#endif /* CB_CAMERA_H */
