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
#include "cb_medium.h"
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

/* One path of ptRadiance between its rays: what it has gathered, its throughput and what
 * multiple importance sampling needs of the vertex the next ray leaves. ptRadiance keeps it in
 * registers; CPT's packets (pt.cl, renderCoherentPathTracing) keep it in a global buffer while
 * the tile's rays are traced, so it holds only 4-byte members: CB_PT_PATH_BYTES is its size, for
 * the host's buffer. */
typedef struct PtPath {
    Spectrum radiance;
    Spectrum throughput;
    Spectrum shadowTerm; /* next-event estimation's term, counted if its shadow ray is clear */
    Vec3 previousP;      /* the vertex the ray left, where next-event estimation sampled */
    real previousPdfW;
    int previousDelta;
    int vertex;        /* the vertex the next ray finds */
    int shadowPending; /* a shadow ray for shadowTerm waits */
    real hero;         /* the wavelength the path follows (TexCoord.hero), -1: every bin */
    MediumTrack track; /* the next ray's way through media (cb_medium.h), medium -1: vacuum */
} PtPath;
#define CB_PT_PATH_BYTES(channels, tracked)                                                        \
    (4 * (3 * (channels) + 8 + CB_MEDIUM_TRACK_WORDS(tracked)))

/* A path from the camera, which sits in `medium` (Camera.medium). */
CB_FN PtPath ptPathBegin(int medium) {
    PtPath path;
    path.radiance = specZero();
    path.throughput = specConst(1.0f);
    path.shadowTerm = specZero();
    path.previousP = vec3(0.0f, 0.0f, 0.0f); /* read only after a non-delta bounce sets it */
    path.previousPdfW = 0.0f;
    path.previousDelta = 1; /* the pinhole camera: emission seen directly takes full weight */
    path.vertex = 1;
    path.shadowPending = 0;
    path.hero = -1.0f;
    path.track = mediumTrackStart(medium);
    return path;
}

/* Next-event estimation's light point from p at `bounce`, from that bounce's light dimensions
 * (lightSampleFrom). With one light lightChoose reads no number, so none is drawn. */
CB_FN bool ptLightSampleFrom(const SceneView* scene, Vec3 p, SampleStream stream, int bounce,
                             LightSample* ls) {
    real uChoice = scene->lightCount > 1
                       ? sampleAt(stream, bounceDimension(bounce, CB_SLOT_LIGHT_CHOICE))
                       : 0.0f;
    real uLight0, uLight1;
    sampleAt2(stream, bounceDimension(bounce, CB_SLOT_LIGHT_POINT), &uLight0, &uLight1);
    return lightSampleFrom(scene, p, uChoice, uLight0, uLight1, ls);
}

/* Next-event estimation's light point *ls seen from p: the radiance arriving from it (black
 * where the light sends none that way), the unit direction *wi to it, its squared distance
 * *dist2, the pdf *pdfLightW of choosing it in solid angle at p, and the length *distance of
 * the shadow ray's way through a medium (CB_INFINITY to a light at infinity). */
CB_FN Spectrum ptLightArriving(const SceneView* scene, Vec3 p, const LightSample* ls, Vec3* wi,
                               real* dist2, real* pdfLightW, real* distance) {
    Vec3 toLight = vsub(ls->p, p);
    *dist2 = vlength2(toLight);
    *wi = vscale(toLight, 1.0f / sqrt(*dist2));
    Spectrum emitted;
    if (ls->isDelta) {
        emitted = deltaLightArriving(scene, ls, *wi, *dist2, pdfLightW);
    } else {
        emitted = lightSeenThroughPortal(scene, ls->light, p, *wi)
                      ? lightEmittedRadiance(scene, ls->light, ls->n, vneg(*wi))
                      : specZero();
        real cosLight = vabsdot(ls->n, *wi);
        *pdfLightW = ls->pdfSolidAngle > 0.0f ? ls->pdfPick * ls->pdfSolidAngle
                                              : ls->pdfPick * ls->pdfArea * *dist2 / cosLight;
    }
    int kind = scene->lights[ls->light].kind;
    *distance = kind == CB_LIGHT_DISTANT || kind == CB_LIGHT_INFINITE ? CB_INFINITY : sqrt(*dist2);
    if (!(*pdfLightW > 0.0f) || !isfinite(*pdfLightW)) return specZero();
    return emitted;
}

/* Russian roulette when leaving `vertex` (rouletteSurvival); returns whether the path survives,
 * its throughput divided by the survival probability. */
CB_FN bool ptRoulette(PtPath* path, SampleStream stream, PathSettings settings, int vertex) {
    if (settings.rouletteVertex <= 0 || vertex < settings.rouletteVertex) return true;
    real survival = rouletteSurvival(path->throughput);
    if (sampleAt(stream, bounceDimension(vertex - 1, CB_SLOT_ROULETTE)) >= survival) return false;
    path->throughput = specScale(path->throughput, 1.0f / survival);
    return true;
}

/* Next-event estimation's term `term` (throughput, scattering, light and weight) over the shadow
 * ray *shadow free up to shadowTMax, which leaves in `medium` toward a light point `distance` away
 * (CB_INFINITY: at infinity). Without interfaces the caller traces the shadow ray (ptPathShadow),
 * the term taking the medium's transmittance here; with them the shadow ray crosses the
 * interfaces on its way (sceneTransmittance), traced here at once. */
CB_FN void ptShadowTerm(const SceneView* scene, PtPath* path, Spectrum term, Ray shadow,
                        real shadowTMax, int medium, real distance) {
#if CB_HAS(CB_FEATURE_INTERFACE)
    if (CB_SCENE_HAS(scene, CB_FEATURE_INTERFACE)) {
        path->radiance = specAdd(
            path->radiance, specMul(term, sceneTransmittance(scene, shadow, shadowTMax,
                                                             !(distance < CB_INFINITY), medium)));
        return;
    }
#endif
    (void)shadowTMax;
#if CB_HAS(CB_FEATURE_MEDIUM)
    term = specMul(term, mediumTransmittance(scene, medium, shadow.o, shadow.d, distance));
#else
    (void)scene;
    (void)shadow;
    (void)medium;
    (void)distance;
#endif
    path->shadowTerm = term;
    path->shadowPending = 1;
}

#if CB_HAS(CB_FEATURE_SCATTERING)
/* Vertex x_k in the medium the path travels in, at p, reached along unit direction d:
 * next-event estimation through the medium (the phase function for the BSDF, weighed by the
 * power heuristic against phase sampling) and the next ray by the phase function's sample, whose
 * weight phase / pdf is 1 (pbrt-v4's volpath). Media emit nothing (pbrt-v4's "Le" is refused). */
CB_FN bool ptMediumVertex(const SceneView* scene, PtPath* path, Ray* ray, Vec3 p,
                          SampleStream stream, PathSettings settings, Ray* shadow,
                          real* shadowTMax) {
    int vertex = path->vertex;
    int bounce = vertex - 1;
    if (vertex + 1 >= settings.eyeVertices) return false;
    real g = mediumAsymmetry(scene, path->track.medium);
    Vec3 d = ray->d;

    LightSample ls;
    if (ptLightSampleFrom(scene, p, stream, bounce, &ls)) {
        Vec3 wi;
        real dist2, pdfLightW, distance;
        Spectrum emitted = ptLightArriving(scene, p, &ls, &wi, &dist2, &pdfLightW, &distance);
        if (!specIsBlack(emitted)) {
            /* The ray leaves a point inside the medium: no surface to offset it from. */
            *shadow = spawnRayFromTo(p, wi, ls.p, ls.pError, ls.n, shadowTMax);
            real phase = phaseHenyeyGreenstein(vdot(d, wi), g);
            real weight =
                lightFoundByRays(scene, ls.light) ? powerHeuristic(pdfLightW, phase) : 1.0f;
            ptShadowTerm(scene, path,
                         specScale(specMul(path->throughput, emitted), phase * weight / pdfLightW),
                         *shadow, *shadowTMax, path->track.medium, distance);
        }
    }

    real u0, u1, pdf;
    sampleAt2(stream, bounceDimension(bounce, CB_SLOT_BSDF_DIRECTION), &u0, &u1);
    Vec3 wi = phaseHenyeyGreensteinSample(d, g, u0, u1, &pdf);
    if (!(pdf > 0.0f)) return false;
    path->previousPdfW = pdf;
    path->previousDelta = 0;
    path->previousP = p;
    if (!ptRoulette(path, stream, settings, vertex)) return false;
    ray->o = p;
    ray->d = wi;
    path->track = mediumTrackStart(path->track.medium);
    path->vertex = vertex + 1;
    return true;
}
#endif

/* The vertex x_k that *ray found (found, hit) or the escape: emission seen there, next-event
 * estimation's shadow ray (*shadow, *shadowTMax, path->shadowPending; the caller traces it and
 * calls ptPathShadow) and the next ray into *ray. Vertex 0 is the camera; the vertex found by the
 * k-th ray is x_k. Emission found at x_k closes a path of k+1 vertices, next-event estimation at
 * x_k closes one of k+2 vertices, so both strategies exist exactly when k+2 <= Ne and are then
 * combined with the power heuristic (Veach 1997, ch. 9). In a scattering medium x_k may be a
 * point of the medium before the surface (ptMediumVertex); a surface of the interface material is
 * no vertex: *ray goes on beyond it, still looking for x_k. Returns whether the path goes on. */
CB_FN bool ptPathVertex(const SceneView* scene, PtPath* path, Ray* ray, bool found, Hit hit,
                        SampleStream stream, PathSettings settings, Ray* shadow, real* shadowTMax) {
    path->shadowPending = 0;
#if CB_HAS(CB_FEATURE_MEDIUM)
    /* The ray's way through its medium (camera and bounce rays have unit directions). */
    real t;
    int segment = mediumRaySegment(
        scene, &path->track, &path->throughput, stream,
        mediumDistanceDimension(CB_DIM_FIRST_BOUNCE, settings.eyeVertices, path->vertex - 1),
        ray->o, ray->d, found ? hit.t : CB_INFINITY, &t);
    if (segment < 0) return false;
#if CB_HAS(CB_FEATURE_SCATTERING)
    if (segment > 0)
        return ptMediumVertex(scene, path, ray, vmadd(ray->o, ray->d, t), stream, settings, shadow,
                              shadowTMax);
#endif
#endif
    if (!found) {
#if CB_HAS(CB_FEATURE_INFINITE_LIGHT)
        /* The escaped ray sees the infinite light, weighed against next-event estimation's
         * directions. */
        int infinite = lightInfinite(scene);
        if (infinite >= 0 && lightSeenThroughPortal(scene, infinite, ray->o, ray->d)) {
            CB_GLOBAL const Light* light = &scene->lights[infinite];
            real pdfLightW;
            Spectrum le = infiniteLightRadiancePdf(scene, light, ray->d, &pdfLightW);
            real weight = 1.0f;
            if (!path->previousDelta)
                weight = powerHeuristic(
                    path->previousPdfW,
                    light->pickProbability *
                        infiniteLightPdfFrom(scene, light, path->previousP, ray->d, pdfLightW));
            path->radiance =
                specAdd(path->radiance, specScale(specMul(path->throughput, le), weight));
        }
#endif
        return false;
    }
    SurfacePoint sp = surfacePointFromHit(scene, *ray, hit);
#if CB_HAS(CB_FEATURE_INTERFACE)
    /* No vertex at an interface: the same ray goes on beyond it. */
    if (materialIsInterface(scene, sp.material))
        return mediumCrossInterface(scene, sp, ray, &path->track);
#endif
    Vec3 wo = vneg(ray->d);
    int vertex = path->vertex;
    int bounce = vertex - 1;

#if CB_HAS(CB_FEATURE_AREA_LIGHT)
    if (sp.light >= 0) {
        Spectrum emitted = lightEmittedRadiance(scene, sp.light, sp.ng, wo);
        if (!specIsBlack(emitted)) {
            real weight = 1.0f;
            if (!path->previousDelta) {
                real pdfLightW =
                    lightPdfSolidAngleFrom(scene, sp.light, path->previousP, sp.p, sp.ng);
                weight = powerHeuristic(path->previousPdfW, pdfLightW);
            }
            path->radiance =
                specAdd(path->radiance, specScale(specMul(path->throughput, emitted), weight));
        }
    }
#endif
    if (vertex + 1 >= settings.eyeVertices) return false;
#if CB_HAS(CB_FEATURE_DISPERSION)
    /* After the emission found here, as pbrt-v4 chooses its wavelength in GetBSDF. */
    dispersionFollowOne(scene, sp.material,
                        sampleAt(stream, bounceDimension(bounce, CB_SLOT_WAVELENGTH)), &path->hero,
                        &path->throughput);
    sp.uv.hero = path->hero;
#endif

    Frame frame = surfaceFrame(sp);

    /* Next-event estimation: one light point, one shadow ray. */
    if (materialHasNonDelta(scene, sp.material)) {
        LightSample ls;
        if (ptLightSampleFrom(scene, sp.p, stream, bounce, &ls)) {
            Vec3 wi;
            real dist2, pdfLightW, distance;
            Spectrum emitted =
                ptLightArriving(scene, sp.p, &ls, &wi, &dist2, &pdfLightW, &distance);
            if (!specIsBlack(emitted)) {
                real pdfBsdfW, pdfRev;
                Spectrum f =
                    bsdfEval(scene, sp.material, sp.uv, frame, wo, wi, 0, &pdfBsdfW, &pdfRev);
                if (!specIsBlack(f)) {
                    *shadow = spawnRayTo(sp, ls.p, ls.pError, ls.n, shadowTMax);
                    /* BSDF sampling cannot find a delta or invisible light. */
                    real weight = lightFoundByRays(scene, ls.light)
                                      ? powerHeuristic(pdfLightW, pdfBsdfW)
                                      : 1.0f;
                    real factor = scatterCos(sp.ng, sp.ns, wo, wi, 0) * weight / pdfLightW;
                    ptShadowTerm(scene, path,
                                 specScale(specMul(specMul(path->throughput, f), emitted), factor),
                                 *shadow, *shadowTMax,
                                 mediumLeaving(scene, sp.material, sp.ng, wi, path->track.medium),
                                 distance);
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
    if (!bsdfSample(scene, sp.material, sp.uv, frame, wo, u0, u1, uLobe, 0, &bs)) return false;
    if (bs.pdf <= 0.0f || specIsBlack(bs.f)) return false;
    path->throughput =
        specMul(path->throughput, specScale(bs.f, scatterCos(sp.ng, sp.ns, wo, bs.wi, 0) / bs.pdf));
    path->previousPdfW = bs.pdf;
    path->previousDelta = bs.isDelta;
    path->previousP = sp.p;
    if (!ptRoulette(path, stream, settings, vertex)) return false;
    *ray = spawnRay(sp, bs.wi);
    path->track =
        mediumTrackStart(mediumLeaving(scene, sp.material, sp.ng, bs.wi, path->track.medium));
    path->vertex = vertex + 1;
    return true;
}

/* The answer of ptPathVertex's shadow ray: its term counts when nothing blocks it. */
CB_FN void ptPathShadow(PtPath* path, bool occluded) {
    if (path->shadowPending && !occluded)
        path->radiance = specAdd(path->radiance, path->shadowTerm);
    path->shadowPending = 0;
}

/* Radiance arriving at the camera (in `medium`) along `ray`, estimated with paths of at most
 * settings.eyeVertices vertices (ptPathVertex), every ray traced as soon as it is made. */
CB_FN Spectrum ptRadiance(const SceneView* scene, Ray ray, int medium, SampleStream stream,
                          PathSettings settings) {
    PtPath path = ptPathBegin(medium);
    bool more = settings.eyeVertices > 1;
    while (more) {
        Hit hit;
        /* The camera ray: neighbouring pixels are neighbouring work-items. */
        bool found = path.vertex == 1 ? sceneIntersectCoherent(scene, ray, CB_INFINITY, &hit)
                                      : sceneIntersect(scene, ray, CB_INFINITY, &hit);
        Ray shadow;
        real shadowTMax = 0.0f;
        more = ptPathVertex(scene, &path, &ray, found, hit, stream, settings, &shadow, &shadowTMax);
        if (path.shadowPending) ptPathShadow(&path, sceneOccluded(scene, shadow, shadowTMax));
    }
    return path.radiance;
}

/* The sample stream of pixel (x, y). streamTile == 0: every pixel has its own sample vector
 * (PT); streamTile == k > 0: the pixel at position (i, j) of its k x k tile uses vector (i, j)
 * of the estimate (CPT, docs/method.md), read from sharedSamples when the host drew the k x k
 * vectors' first sharedDimensions values there (0: none). */
CB_FN SampleStream ptPixelStream(SamplerSettings sampler, uint estimate, int streamTile,
                                 CB_GLOBAL const float* sharedSamples, uint sharedDimensions,
                                 int width, int x, int y) {
    uint pixel = (uint)(y * width + x);
    uint stream = streamTile > 0 ? (uint)((y % streamTile) * streamTile + (x % streamTile)) : pixel;
    return samplerStreamShared(sampler, estimate, stream, sharedSamples, sharedDimensions);
}

/* The camera ray of pixel (x, y), placed by its filter (and through the lens) by the pixel's
 * sample stream; *filterWeight gets the weight its radiance takes (cameraSampleRaster). */
CB_FN Ray ptCameraRay(const Camera* camera, SampleStream samples, int x, int y,
                      real* filterWeight) {
    real rasterX, rasterY;
    *filterWeight = cameraSampleRaster(camera, samples, x, y, &rasterX, &rasterY);
    return cameraGenerateRay(camera, rasterX, rasterY,
                             cameraStreamLensPoint(camera, samples, CB_DIM_LENS));
}

/* One PT/CPT sample of pixel (x, y) in linear sRGB: the whole work of one work-item of
 * renderPathTracing (pt.cl), shared so that the host's double-precision build (src/float64/)
 * computes exactly the same estimate. */
CB_FN Vec3 ptPixelRgb(const SceneView* scene, CB_GLOBAL const real* toRgb, const Camera* camera,
                      PathSettings settings, SamplerSettings sampler, uint estimate, int streamTile,
                      CB_GLOBAL const float* sharedSamples, uint sharedDimensions, int x, int y) {
    SampleStream samples = ptPixelStream(sampler, estimate, streamTile, sharedSamples,
                                         sharedDimensions, camera->width, x, y);
    real filterWeight;
    Ray ray = ptCameraRay(camera, samples, x, y, &filterWeight);
    return filmClampSample(
        camera,
        specToRgb(
            specScale(ptRadiance(scene, ray, camera->medium, samples, settings), filterWeight),
            toRgb),
        filterWeight);
}

CB_END_NAMESPACE

#endif /* CB_PT_H */
