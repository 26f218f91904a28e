/* cb_pt.h - path tracing with next-event estimation and MIS (docs/method.md, PT).
 *
 * One function computes the radiance of one camera sample from an explicit sample stream, so
 * that PT (stream per pixel) and CPT (stream shared by the pixels of a coherence tile) are the
 * same code, and the host can run it as a reference. */
#ifndef CB_PT_H
#define CB_PT_H

#include "cb_bsdf.h"
#include "cb_bvh_wide.h"
#include "cb_camera.h"
#include "cb_lights.h"
#include "cb_rng.h"

CB_BEGIN_NAMESPACE

typedef struct PathSettings {
    int eyeVertices;    /* Ne: maximum vertices of a path, the camera included */
    int rouletteVertex; /* Russian roulette is applied when leaving this vertex and later; */
                        /* <= 0 disables it (paths run to the cap) */
    int pad[2];
} PathSettings;

/* Survival probability of Russian roulette: the throughput's largest channel, never below 0.05
 * (docs/method.md), so that roulette cannot create unbounded weights. */
CB_FN real rouletteSurvival(Spectrum throughput) {
    return cbClamp(specMaxComponent(throughput), 0.05f, 1.0f);
}

/* Radiance arriving at the camera along `ray`, estimated with paths of at most
 * settings.eyeVertices vertices. Vertex 0 is the camera; the vertex found by the k-th ray is
 * x_k. Emission found at x_k closes a path of k+1 vertices, next-event estimation at x_k
 * closes one of k+2 vertices, so both strategies exist exactly when k+2 <= Ne and are then
 * combined with the power heuristic (Veach 1997, ch. 9). */
CB_FN Spectrum ptRadiance(const SceneView* scene, Ray ray, SampleStream stream,
                          PathSettings settings) {
    Spectrum radiance = specZero();
    Spectrum throughput = specConst(1.0f);
    real previousPdfW = 0.0f;
    int previousDelta = 1;  /* the pinhole camera: emission seen directly takes full weight */
    Vec3 previousP = ray.o; /* the vertex the ray left, where next-event estimation sampled */
    real previousLightSum = -1.0f; /* the lights' importances there (lightSampleFromAt) */

    for (int vertex = 1; vertex < settings.eyeVertices; ++vertex) {
        Hit hit;
        /* The camera ray: neighbouring pixels are neighbouring work-items. */
        bool found = vertex == 1 ? sceneIntersectCoherent(scene, ray, CB_INFINITY, &hit)
                                 : sceneIntersect(scene, ray, CB_INFINITY, &hit);
        if (!found) {
#if CB_HAS(CB_FEATURE_INFINITE_LIGHT)
            /* The escaped ray sees the infinite light, weighed against next-event estimation's
             * uniform directions. */
            int infinite = lightInfinite(scene);
            if (infinite >= 0) {
                real weight = 1.0f;
                if (!previousDelta)
                    weight = powerHeuristic(previousPdfW, scene->lights[infinite].pickProbability *
                                                              uniformSpherePdf());
                Spectrum le = specLoad(scene->spectra, scene->lights[infinite].emission);
                radiance = specAdd(radiance, specScale(specMul(throughput, le), weight));
            }
#endif
            break;
        }
        SurfacePoint sp = surfacePointFromHit(scene, ray, hit);
        Vec3 wo = vneg(ray.d);
        int bounce = vertex - 1;

#if CB_HAS(CB_FEATURE_AREA_LIGHT)
        if (sp.light >= 0) {
            Spectrum emitted = lightEmittedRadiance(scene, sp.light, sp.ng, wo);
            if (!specIsBlack(emitted)) {
                real weight = 1.0f;
                if (!previousDelta) {
                    real pdfLightW = lightPdfSolidAngleFromAt(scene, sp.light, previousP, sp.p,
                                                              sp.ng, previousLightSum);
                    weight = powerHeuristic(previousPdfW, pdfLightW);
                }
                radiance = specAdd(radiance, specScale(specMul(throughput, emitted), weight));
            }
        }
#endif
        if (vertex + 1 >= settings.eyeVertices) break;

        Frame frame = frameFromNormal(sp.ng);

        /* Next-event estimation: one light point, one shadow ray. */
        real lightSum = -1.0f;
        if (materialHasNonDelta(scene, sp.material)) {
            LightSample ls;
            /* With one light lightChoose reads no number, so none is drawn. */
            real uChoice = scene->lightCount > 1
                               ? sampleAt(stream, bounceDimension(bounce, CB_SLOT_LIGHT_CHOICE))
                               : 0.0f;
            real uLight0, uLight1;
            sampleAt2(stream, bounceDimension(bounce, CB_SLOT_LIGHT_POINT), &uLight0, &uLight1);
            if (lightSampleFromAt(scene, sp.p, uChoice, uLight0, uLight1, &ls, &lightSum)) {
                Vec3 toLight = vsub(ls.p, sp.p);
                real dist2 = vlength2(toLight);
                Vec3 wi = vscale(toLight, 1.0f / sqrt(dist2));
                Spectrum emitted;
                real pdfLightW;
                if (ls.isDelta) {
                    emitted = deltaLightArriving(scene, &ls, wi, dist2, &pdfLightW);
                } else {
                    emitted = lightEmittedRadiance(scene, ls.light, ls.n, vneg(wi));
                    real cosLight = vabsdot(ls.n, wi);
                    pdfLightW = ls.pdfSolidAngle > 0.0f
                                    ? ls.pdfPick * ls.pdfSolidAngle
                                    : ls.pdfPick * ls.pdfArea * dist2 / cosLight;
                }
                if (!specIsBlack(emitted) && pdfLightW > 0.0f && isfinite(pdfLightW)) {
                    real pdfBsdfW, pdfRev;
                    Spectrum f = bsdfEval(scene, sp.material, frame, wo, wi, 0, &pdfBsdfW, &pdfRev);
                    if (!specIsBlack(f)) {
                        real tMax;
                        Ray shadow = spawnRayTo(sp, ls.p, ls.pError, ls.n, &tMax);
                        if (!sceneOccluded(scene, shadow, tMax)) {
                            real weight = ls.isDelta ? 1.0f : powerHeuristic(pdfLightW, pdfBsdfW);
                            real factor = vabsdot(wi, sp.ng) * weight / pdfLightW;
                            radiance = specAdd(
                                radiance,
                                specScale(specMul(specMul(throughput, f), emitted), factor));
                        }
                    }
                }
            }
        }

        /* Continue the path by sampling the BSDF. */
        BsdfSample bs;
        real u0, u1;
        sampleAt2(stream, bounceDimension(bounce, CB_SLOT_BSDF_DIRECTION), &u0, &u1);
        real uLobe = bsdfReadsLobeSample(scene, sp.material)
                         ? sampleAt(stream, bounceDimension(bounce, CB_SLOT_BSDF_LOBE))
                         : 0.0f;
        if (!bsdfSample(scene, sp.material, frame, wo, u0, u1, uLobe, 0, &bs)) break;
        if (bs.pdf <= 0.0f || specIsBlack(bs.f)) break;
        throughput = specMul(throughput, specScale(bs.f, vabsdot(bs.wi, sp.ng) / bs.pdf));
        previousPdfW = bs.pdf;
        previousDelta = bs.isDelta;
        previousP = sp.p;
        previousLightSum = lightSum;

        if (settings.rouletteVertex > 0 && vertex >= settings.rouletteVertex) {
            real survival = rouletteSurvival(throughput);
            if (sampleAt(stream, bounceDimension(bounce, CB_SLOT_ROULETTE)) >= survival) break;
            throughput = specScale(throughput, 1.0f / survival);
        }
        ray = spawnRay(sp, bs.wi);
    }
    return radiance;
}

/* One PT/CPT sample of pixel (x, y) in linear sRGB: the whole work of one work-item of
 * renderPathTracing (pt.cl), shared so that the host's double-precision build (src/float64/)
 * computes exactly the same estimate. streamTile == 0: every pixel has its own sample vector
 * (PT); streamTile == k > 0: the pixel at position (i, j) of its k x k tile uses vector (i, j)
 * of the estimate (CPT, docs/method.md), read from sharedSamples when the host drew the k x k
 * vectors' first sharedDimensions values there (0: none). */
CB_FN Vec3 ptPixelRgb(const SceneView* scene, CB_GLOBAL const real* toRgb, const Camera* camera,
                      PathSettings settings, SamplerSettings sampler, uint estimate, int streamTile,
                      CB_GLOBAL const float* sharedSamples, uint sharedDimensions, int x, int y) {
    uint pixel = (uint)(y * camera->width + x);
    uint stream = streamTile > 0 ? (uint)((y % streamTile) * streamTile + (x % streamTile)) : pixel;
    SampleStream samples =
        samplerStreamShared(sampler, estimate, stream, sharedSamples, sharedDimensions);
    real rasterX, rasterY;
    cameraJitteredRaster(samples, x, y, &rasterX, &rasterY);
    Ray ray = cameraGenerateRay(camera, rasterX, rasterY);
    return specToRgb(ptRadiance(scene, ray, samples, settings), toRgb);
}

CB_END_NAMESPACE

#endif /* CB_PT_H */
