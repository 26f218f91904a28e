/* cb_lights.h - choosing lights and points on them (METHOD.md: light by power, point uniformly
 * by area; point lights are deltas in position). Shared by next-event estimation in the
 * kernels and by light-subpath generation on the host. */
#ifndef CB_LIGHTS_H
#define CB_LIGHTS_H

#include "cb_sampling.h"
#include "cb_spectrum.h"
#include "cb_types.h"

CB_BEGIN_NAMESPACE

typedef struct LightSample {
    Vec3 p;       /* the point on the light */
    Vec3 pError;  /* error bound of p, for spawnRayTo */
    Vec3 n;       /* unit surface normal (front side); zero for point lights */
    int light;    /* index of the chosen light */
    int isDelta;  /* point light: position is a delta, no MIS against BSDF sampling */
    real pdfPick; /* probability of having chosen this light */
    real pdfArea; /* density of p on the light in area measure (1 for point lights) */
} LightSample;

/* Index of the light whose CDF interval contains u (binary search over Light.cdf). */
CB_FN int lightChoose(const SceneView* scene, real u) {
    int lo = 0;
    int hi = scene->lightCount - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (u < scene->lights[mid].cdf)
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

/* Area of the emitting primitive, its uniform point and the point's error bound. */
CB_FN void lightSamplePoint(const SceneView* scene, int lightIndex, real u0, real u1,
                            LightSample* out) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    out->light = lightIndex;
    out->pdfPick = light->pickProbability;
#if CB_HAS(CB_FEATURE_POINT_LIGHT)
    if (light->kind == CB_LIGHT_POINT) {
        out->p = vec3FromGlobalArray(light->position);
        out->pError = vec3(0.0f, 0.0f, 0.0f);
        out->n = vec3(0.0f, 0.0f, 0.0f);
        out->isDelta = 1;
        out->pdfArea = 1.0f;
        return;
    }
#endif
    CB_GLOBAL const Primitive* prim = &scene->primitives[light->primitive];
    out->isDelta = 0;
    out->pdfArea = 1.0f / light->area;
#if CB_HAS(CB_FEATURE_SPHERES)
    if (prim->kind == CB_PRIM_SPHERE) {
        Vec3 center = vec3FromGlobalArray(prim->p0);
        real radius = prim->p1[0];
        Vec3 dir = sampleUniformSphere(u0, u1);
        out->p = vmadd(center, dir, radius);
        /* pbrt-v4's bound for a point reprojected onto a sphere. */
        out->pError = vscale(vabs(out->p), cbGamma(5));
        out->n = vscale(dir, prim->p1[1]);
        return;
    }
#endif
    Vec3 p0 = vec3FromGlobalArray(prim->p0);
    Vec3 p1 = vec3FromGlobalArray(prim->p1);
    Vec3 p2 = vec3FromGlobalArray(prim->p2);
    real b0, b1, b2;
    sampleUniformTriangle(u0, u1, &b0, &b1, &b2);
    out->p = vadd(vadd(vscale(p0, b0), vscale(p1, b1)), vscale(p2, b2));
    out->pError = vscale(
        vadd(vadd(vabs(vscale(p0, b0)), vabs(vscale(p1, b1))), vabs(vscale(p2, b2))), cbGamma(6));
    out->n = vnormalize(vcross(vsub(p1, p0), vsub(p2, p0)));
}

/* Choose a light by power (uChoice), then a point on it (u0, u1). False if the scene has no
 * lights. */
CB_FN bool lightSample(const SceneView* scene, real uChoice, real u0, real u1, LightSample* out) {
    if (scene->lightCount <= 0) return false;
    lightSamplePoint(scene, lightChoose(scene, uChoice), u0, u1, out);
    return out->pdfPick > 0.0f;
}

/* Radiance leaving an area light with front normal n in direction w (unit). One-sided lights
 * emit only to the side n points to. */
CB_FN Spectrum lightEmittedRadiance(const SceneView* scene, int lightIndex, Vec3 n, Vec3 w) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    if (!light->twoSided && vdot(n, w) <= 0.0f) return specZero();
    return specLoad(scene->spectra, light->emission);
}

/* Intensity a point light sends in unit direction w: uniform, or for a spot light pbrt-v4's
 * SmoothStep(cosEnd, cosStart, cos theta) falloff from its axis. */
CB_FN Spectrum pointLightIntensity(const SceneView* scene, int lightIndex, Vec3 w) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    Spectrum intensity = specLoad(scene->spectra, light->emission);
#if CB_HAS(CB_FEATURE_SPOT_LIGHT)
    if (light->spotCosEnd >= -1.0f) {
        real c = vdot(w, vec3FromGlobalArray(light->spotAxis));
        real t = (c - light->spotCosEnd) / (light->spotCosStart - light->spotCosEnd);
        t = fmin(fmax(t, 0.0f), 1.0f);
        if (!(light->spotCosStart > light->spotCosEnd)) t = c < light->spotCosEnd ? 0.0f : 1.0f;
        intensity = specScale(intensity, t * t * (3.0f - 2.0f * t));
    }
#endif
    return intensity;
}

/* Probability density, in area measure and including the choice of light, with which
 * lightSample produces a given point of area light `lightIndex`. */
CB_FN real lightPdfArea(const SceneView* scene, int lightIndex) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    return light->pickProbability / light->area;
}

CB_END_NAMESPACE

#endif /* CB_LIGHTS_H */
