/* cb_lights.h - choosing lights and points on them: light by power, point uniformly by area
 * (light subpaths) or, for next-event estimation from outside a sphere light, uniformly in the
 * cone the sphere subtends; point lights are deltas in position. Shared by next-event
 * estimation in the kernels and by light-subpath generation on the host. */
#ifndef CB_LIGHTS_H
#define CB_LIGHTS_H

#include "cb_sampling.h"
#include "cb_spectrum.h"
#include "cb_types.h"

CB_BEGIN_NAMESPACE

typedef struct LightSample {
    Vec3 p;             /* the point on the light */
    Vec3 pError;        /* error bound of p, for spawnRayTo */
    Vec3 n;             /* unit surface normal (front side); zero for point lights */
    int light;          /* index of the chosen light */
    int isDelta;        /* point or distant light: a delta, no MIS against BSDF sampling */
    real pdfPick;       /* probability of having chosen this light */
    real pdfArea;       /* density of p on the light in area measure (1 for point lights; */
                        /* distant: 1 from a reference point, 1 / (pi R^2) on the disk) */
    real pdfSolidAngle; /* lightSampleFrom on a sphere: the cone's solid-angle density; else 0 */
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

/* The origin of a ray of a light at infinity seen in unit direction `toLight`: uniform (u0, u1)
 * on the disk of the bounding sphere's radius R perpendicular to it, moved R toward the light,
 * so that the ray starts outside the scene: density 1 / (pi R^2) per unit area across the beam
 * (pbrt-v4's DistantLight and UniformInfiniteLight::SampleLe). */
CB_FN Vec3 lightBeamOrigin(CB_GLOBAL const Light* light, Vec3 toLight, real u0, real u1) {
    real radius = light->sceneRadius;
    real dx, dy;
    sampleConcentricDisk(u0, u1, &dx, &dy);
    Vec3 onDisk = frameToWorld(frameFromNormal(toLight), vec3(dx * radius, dy * radius, 0.0f));
    return vmadd(vadd(vec3FromGlobalArray(light->position), onDisk), toLight, radius);
}

/* The index of the scene's infinite light (always the last light), or -1. */
CB_FN int lightInfinite(const SceneView* scene) {
#if CB_HAS(CB_FEATURE_INFINITE_LIGHT)
    if (scene->lightCount > 0 && scene->lights[scene->lightCount - 1].kind == CB_LIGHT_INFINITE)
        return scene->lightCount - 1;
#else
    (void)scene;
#endif
    return -1;
}

/* ---- The infinite light: constant, or pbrt-v4's equal-area image ----------------------------- */

#if CB_HAS(CB_FEATURE_IMAGE_LIGHT)
/* Unit world direction w in the image light's frame (worldFromLight is a rotation: its
 * transpose is its inverse). */
CB_FN Vec3 imageLightFrameDirection(CB_GLOBAL const Light* light, Vec3 w) {
    CB_GLOBAL const real* m = light->worldFromLight;
    return vec3(m[0] * w.x + m[3] * w.y + m[6] * w.z, m[1] * w.x + m[4] * w.y + m[7] * w.z,
                m[2] * w.x + m[5] * w.y + m[8] * w.z);
}

/* The pixel (y * imageSize + x) whose radiance arrives from unit world direction toLight: the
 * one holding the direction's equal-area square point (pbrt-v4's nearest lookup, ImageLe). */
CB_FN int imageLightPixel(CB_GLOBAL const Light* light, Vec3 toLight) {
    real s, t;
    equalAreaSphereToSquare(imageLightFrameDirection(light, toLight), &s, &t);
    int n = light->imageSize;
    int x = (int)(s * (real)n);
    int y = (int)(t * (real)n);
    x = x < 0 ? 0 : (x > n - 1 ? n - 1 : x);
    y = y < 0 ? 0 : (y > n - 1 ? n - 1 : y);
    return y * n + x;
}

/* The image light's sampling tables, at lightTables[imageTable]: the CDF over the image's rows
 * (imageSize + 1 values), then each row's CDF over its pixels (imageSize + 1 values each), by
 * the pixels' mean radiance. Pixel (x, y) is chosen with probability (row y's share) times (x's
 * share in row y); its directions have that times the pixel count over 4 pi as their solid-angle
 * density, the map being equal-area. */
CB_FN real imageLightPixelPdf(const SceneView* scene, CB_GLOBAL const Light* light, int pixel) {
    int n = light->imageSize;
    int x = pixel % n;
    int y = pixel / n;
    CB_GLOBAL const real* rows = scene->lightTables + light->imageTable;
    CB_GLOBAL const real* row = rows + (n + 1) * (1 + y);
    return (rows[y + 1] - rows[y]) * (row[x + 1] - row[x]) * ((real)n * (real)n) * CB_INV_4PI;
}

/* The emission of the image light's pixel p, from the pixel values after its tables
 * (lightTables[imageTable + (imageSize + 1)^2 ...]): an infinite light's pixel holds its RGB
 * times scale, three values, which it emits as "rgb L" does (in spectral scenes Smits's spectrum
 * of it, from the basis at spectra entries emission .. emission + 6, times the white illuminant
 * at entry emission + 7: rgbIlluminantSpectrum); a goniometric light's holds one grey value, which
 * weights its intensity entry. */
CB_FN Spectrum imageLightPixelEmission(const SceneView* scene, CB_GLOBAL const Light* light,
                                       int pixel) {
    int n = light->imageSize;
    CB_GLOBAL const real* pixels = scene->lightTables + light->imageTable + (n + 1) * (n + 1);
    if (light->kind == CB_LIGHT_POINT)
        return specScale(specLoad(scene->spectra, light->emission), pixels[pixel]);
    CB_GLOBAL const real* rgb = pixels + 3 * pixel;
#if CB_CHANNELS == 3
    Spectrum s;
    s.c[0] = rgb[0];
    s.c[1] = rgb[1];
    s.c[2] = rgb[2];
    return s;
#else
    Spectrum s = smitsSpectrum(scene->spectra, light->emission, rgb[0], rgb[1], rgb[2]);
    return specMul(s, specLoad(scene->spectra, light->emission + 7));
#endif
}

/* A unit world direction of the image light by its tables (u1 the row, u0 the pixel in it), a
 * uniform point of the pixel mapped to the sphere (pbrt-v4's PiecewiseConstant2D::Sample and
 * EqualAreaSquareToSphere), and *pdf its solid-angle density, evaluated at the direction as for
 * a direction found otherwise, so that both agree where rounding moves a point across a
 * pixel's edge. */
CB_FN Vec3 imageLightSample(const SceneView* scene, CB_GLOBAL const Light* light, real u0, real u1,
                            real* pdf) {
    int n = light->imageSize;
    CB_GLOBAL const real* rows = scene->lightTables + light->imageTable;
    real dy, dx;
    int y = sampleCdf(rows, n, u1, &dy);
    int x = sampleCdf(rows + (n + 1) * (1 + y), n, u0, &dx);
    Vec3 v = equalAreaSquareToSphere(((real)x + dx) / (real)n, ((real)y + dy) / (real)n);
    CB_GLOBAL const real* m = light->worldFromLight;
    Vec3 w = vec3(m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
                  m[6] * v.x + m[7] * v.y + m[8] * v.z);
    *pdf = imageLightPixelPdf(scene, light, imageLightPixel(light, w));
    return w;
}
#endif

/* Whether light `lightIndex`, seen from p in unit direction d, arrives: always, but for an
 * infinite light with a portal (pbrt-v4's PortalImageInfiniteLight::Le and ImageBounds), only
 * along rays from p that pass through the portal's rectangle toward its outer side. Its entry
 * in lightTables: corner p0, the unit edge directions x (to p3) and y (to p1), the normal
 * z = x cross y, and the edges' lengths. */
CB_FN bool lightSeenThroughPortal(const SceneView* scene, int lightIndex, Vec3 p, Vec3 d) {
#if CB_HAS(CB_FEATURE_INFINITE_LIGHT)
    int portal = scene->lights[lightIndex].portal;
    if (scene->lights[lightIndex].kind != CB_LIGHT_INFINITE || portal < 0) return true;
    CB_GLOBAL const real* t = scene->lightTables + portal;
    Vec3 x = vec3FromGlobalArray(t + 3), y = vec3FromGlobalArray(t + 6),
         z = vec3FromGlobalArray(t + 9);
    Vec3 toCorner = vsub(vec3FromGlobalArray(t), p);
    real depth = vdot(toCorner, z), dz = vdot(d, z);
    if (!(depth > 0.0f) || !(dz > 0.0f)) return false;
    /* Where the ray meets the portal's plane, in the rectangle's coordinates from p0. */
    real s = depth / dz;
    real u = s * vdot(d, x) - vdot(toCorner, x), v = s * vdot(d, y) - vdot(toCorner, y);
    return u >= 0.0f && u <= t[12] && v >= 0.0f && v <= t[13];
#else
    (void)scene;
    (void)lightIndex;
    (void)p;
    (void)d;
    return true;
#endif
}

#if CB_HAS(CB_FEATURE_INFINITE_LIGHT)
/* Spherical rectangles below this solid angle (sr) are sampled by area: the angle sum that gives
 * S loses about 1e-6 sr to rounding, and so small a window subtends a few degrees, over which the
 * area density's d^2 / cos is nearly constant. Above the maximum ref is almost in the portal's
 * plane (S tends to 2 pi), where the parametrisation's angles degenerate (pbrt-v4 uses 3e-4 and
 * 6.22 alike). */
#define CB_PORTAL_MIN_SOLID_ANGLE 0.01f
#define CB_PORTAL_MAX_SOLID_ANGLE 6.2f

/* A portal seen from a point ref, in the frame of Urena, Fajardo and King 2013 ("An
 * Area-Preserving Parametrization for Spherical Rectangles"): origin ref, axes the rectangle's edge
 * directions x and y, the third -z (so the rectangle lies at depth z0 < 0), the rectangle
 * [x0, x1] x [y0, y1]; b0, b1 and k of the parametrisation, S its solid angle. byArea: sampled
 * uniformly by area instead (S outside the limits above). */
typedef struct PortalFromPoint {
    Vec3 x, y, z;
    real x0, x1, y0, y1, z0;
    real b0, b1, k, solidAngle, area;
    int byArea;
} PortalFromPoint;

/* The portal of lightTables entry t as seen from ref; false where ref is on its outer side or in
 * its plane, from where no direction crosses it toward the sky (lightSeenThroughPortal). */
CB_FN bool portalFromPoint(CB_GLOBAL const real* t, Vec3 ref, PortalFromPoint* q) {
    q->x = vec3FromGlobalArray(t + 3);
    q->y = vec3FromGlobalArray(t + 6);
    q->z = vec3FromGlobalArray(t + 9);
    Vec3 toCorner = vsub(vec3FromGlobalArray(t), ref);
    real depth = vdot(toCorner, q->z);
    if (!(depth > 0.0f)) return false;
    q->x0 = vdot(toCorner, q->x);
    q->y0 = vdot(toCorner, q->y);
    q->x1 = q->x0 + t[12];
    q->y1 = q->y0 + t[13];
    q->z0 = -depth;
    q->area = t[12] * t[13];
    /* The normals of the four planes through ref and an edge (the paper's n0..n3) and the
     * rectangle's interior angles on the sphere; S = their sum - 2 pi (Girard's theorem). */
    real z0 = q->z0;
    Vec3 n0 = vnormalize(vec3(0.0f, z0, -q->y0));
    Vec3 n1 = vnormalize(vec3(-z0, 0.0f, q->x1));
    Vec3 n2 = vnormalize(vec3(0.0f, -z0, q->y1));
    Vec3 n3 = vnormalize(vec3(z0, 0.0f, -q->x0));
    real g0 = acos(cbClamp(-vdot(n0, n1), -1.0f, 1.0f));
    real g1 = acos(cbClamp(-vdot(n1, n2), -1.0f, 1.0f));
    real g2 = acos(cbClamp(-vdot(n2, n3), -1.0f, 1.0f));
    real g3 = acos(cbClamp(-vdot(n3, n0), -1.0f, 1.0f));
    q->b0 = n0.z;
    q->b1 = n2.z;
    q->k = 2.0f * CB_PI - g2 - g3;
    q->solidAngle = g0 + g1 - q->k;
    q->byArea =
        !(q->solidAngle >= CB_PORTAL_MIN_SOLID_ANGLE && q->solidAngle <= CB_PORTAL_MAX_SOLID_ANGLE);
    return true;
}

/* A unit direction from ref through the portal and its solid-angle density: uniform in the
 * solid angle (the paper's inversion: the solid angle of the sub-rectangle [x0, xu] for xu, then
 * the height along that column for yu), or uniform over its area. */
CB_FN Vec3 portalSample(const PortalFromPoint* q, real u0, real u1, real* pdf) {
    real xu, yu;
    if (q->byArea) {
        xu = q->x0 + u0 * (q->x1 - q->x0);
        yu = q->y0 + u1 * (q->y1 - q->y0);
    } else {
        /* The angle au in units of pi: sinpi and cospi skip the general argument reduction. */
        real auOverPi = (u0 * q->solidAngle + q->k) * CB_INV_PI;
        real sinAu = cbSinPi(auOverPi);
        real fu = (cbCosPi(auOverPi) * q->b0 - q->b1) / (sinAu != 0.0f ? sinAu : 1e-20f);
        real cu = cbClamp((fu > 0.0f ? 1.0f : -1.0f) / sqrt(fu * fu + q->b0 * q->b0), -1.0f, 1.0f);
        xu = cbClamp(-(cu * q->z0) / cbSafeSqrt(1.0f - cu * cu), q->x0, q->x1);
        real d2 = xu * xu + q->z0 * q->z0;
        real h0 = q->y0 / sqrt(d2 + q->y0 * q->y0), h1 = q->y1 / sqrt(d2 + q->y1 * q->y1);
        real hv = h0 + u1 * (h1 - h0), hv2 = hv * hv;
        yu = hv2 < 1.0f - 1e-6f ? hv * sqrt(d2) / sqrt(1.0f - hv2) : q->y1;
        yu = cbClamp(yu, q->y0, q->y1);
    }
    /* The point ref + xu x + yu y + depth z, as a direction. */
    Vec3 toPoint = vadd(vadd(vscale(q->x, xu), vscale(q->y, yu)), vscale(q->z, -q->z0));
    real dist2 = vlength2(toPoint);
    Vec3 w = vscale(toPoint, 1.0f / sqrt(dist2));
    if (q->byArea) {
        real cosPortal = vdot(w, q->z);
        *pdf = cosPortal > 0.0f ? dist2 / (q->area * cosPortal) : 0.0f;
    } else {
        *pdf = 1.0f / q->solidAngle;
    }
    return w;
}

/* portalSample's density of unit direction w: 0 unless w crosses the rectangle. */
CB_FN real portalPdf(const PortalFromPoint* q, Vec3 w) {
    real dz = vdot(w, q->z);
    if (!(dz > 0.0f)) return 0.0f;
    /* w meets the portal's plane at distance -z0 / dz, at cosine dz. */
    real s = -q->z0 / dz;
    real x = s * vdot(w, q->x), y = s * vdot(w, q->y);
    if (!(x >= q->x0 && x <= q->x1 && y >= q->y0 && y <= q->y1)) return 0.0f;
    if (!q->byArea) return 1.0f / q->solidAngle;
    return s * s / (q->area * dz);
}
#endif

/* Radiance the infinite light sends from unit world direction toLight. */
CB_FN Spectrum infiniteLightRadiance(const SceneView* scene, CB_GLOBAL const Light* light,
                                     Vec3 toLight) {
#if CB_HAS(CB_FEATURE_IMAGE_LIGHT)
    if (light->imageSize > 0)
        return imageLightPixelEmission(scene, light, imageLightPixel(light, toLight));
#else
    (void)toLight;
#endif
    return specLoad(scene->spectra, light->emission);
}

/* Radiance the infinite light sends from unit world direction toLight and, in *pdf, the
 * solid-angle density with which infiniteLightSample produces that direction: an escaped ray's
 * emission and its MIS density from one lookup of the image's pixel. */
CB_FN Spectrum infiniteLightRadiancePdf(const SceneView* scene, CB_GLOBAL const Light* light,
                                        Vec3 toLight, real* pdf) {
#if CB_HAS(CB_FEATURE_IMAGE_LIGHT)
    if (light->imageSize > 0) {
        int pixel = imageLightPixel(light, toLight);
        *pdf = imageLightPixelPdf(scene, light, pixel);
        return imageLightPixelEmission(scene, light, pixel);
    }
#else
    (void)toLight;
#endif
    *pdf = uniformSpherePdf();
    return specLoad(scene->spectra, light->emission);
}

/* A unit direction toward the infinite light and its solid-angle density *pdf: uniform, or by
 * the image's tables (pbrt-v4's ImageInfiniteLight::SampleLi with its complete distribution). */
CB_FN Vec3 infiniteLightSample(const SceneView* scene, CB_GLOBAL const Light* light, real u0,
                               real u1, real* pdf) {
#if CB_HAS(CB_FEATURE_IMAGE_LIGHT)
    if (light->imageSize > 0) return imageLightSample(scene, light, u0, u1, pdf);
#else
    (void)scene;
    (void)light;
#endif
    *pdf = uniformSpherePdf();
    return sampleUniformSphere(u0, u1);
}

/* Solid-angle density with which a light's directions are sampled, for unit direction w: by
 * its image's tables where it has one (a goniometric light's pointLightSampleDirection, an image
 * sky's infiniteLightSample), else uniformly over the sphere. */
CB_FN real lightDirectionPdf(const SceneView* scene, CB_GLOBAL const Light* light, Vec3 w) {
#if CB_HAS(CB_FEATURE_IMAGE_LIGHT)
    if (light->imageSize > 0) return imageLightPixelPdf(scene, light, imageLightPixel(light, w));
#else
    (void)scene;
    (void)light;
    (void)w;
#endif
    return uniformSpherePdf();
}

#if CB_HAS(CB_FEATURE_INFINITE_LIGHT)
/* Next-event estimation's direction toward the infinite light from ref, and its solid-angle
 * density: infiniteLightSample's, unless the light has a portal. Then a constant sky is sampled
 * through the portal alone (portalSample: uniform in its solid angle), an image one by an even
 * mixture of the portal and the image's tables, so that a bright pixel (a sun) seen through the
 * window stays found with its image density (Veach 1997's one-sample model, ch. 9). The
 * density is 0 where ref cannot see the sky through the portal. */
CB_FN Vec3 infiniteLightSampleFrom(const SceneView* scene, CB_GLOBAL const Light* light, Vec3 ref,
                                   real u0, real u1, real* pdf) {
    if (light->portal < 0) return infiniteLightSample(scene, light, u0, u1, pdf);
    PortalFromPoint q;
    if (!portalFromPoint(scene->lightTables + light->portal, ref, &q)) {
        *pdf = 0.0f;
        return vec3(0.0f, 0.0f, 1.0f);
    }
    if (light->imageSize <= 0) return portalSample(&q, u0, u1, pdf);
    Vec3 w;
    real skyPdf;
    if (u0 < 0.5f) {
        real portal;
        w = portalSample(&q, 2.0f * u0, u1, &portal);
        skyPdf = lightDirectionPdf(scene, light, w);
    } else {
        w = infiniteLightSample(scene, light, 2.0f * u0 - 1.0f, u1, &skyPdf);
    }
    *pdf = 0.5f * (skyPdf + portalPdf(&q, w));
    return w;
}

/* infiniteLightSampleFrom's density at ref of unit direction toLight; skyPdf is
 * infiniteLightSample's density of it. */
CB_FN real infiniteLightPdfFrom(const SceneView* scene, CB_GLOBAL const Light* light, Vec3 ref,
                                Vec3 toLight, real skyPdf) {
    if (light->portal < 0) return skyPdf;
    PortalFromPoint q;
    if (!portalFromPoint(scene->lightTables + light->portal, ref, &q)) return 0.0f;
    real portal = portalPdf(&q, toLight);
    return light->imageSize > 0 ? 0.5f * (skyPdf + portal) : portal;
}
#endif

/* The direction a point light's subpath leaves in, and its solid-angle density: uniform, or for
 * a goniometric light by its image's tables (pbrt-v4's GoniometricLight::SampleLe). */
CB_FN Vec3 pointLightSampleDirection(const SceneView* scene, int lightIndex, real u0, real u1,
                                     real* pdf) {
#if CB_HAS(CB_FEATURE_IMAGE_LIGHT)
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    if (light->imageSize > 0) return imageLightSample(scene, light, u0, u1, pdf);
#else
    (void)scene;
    (void)lightIndex;
#endif
    *pdf = uniformSpherePdf();
    return sampleUniformSphere(u0, u1);
}

/* Area of the emitting primitive, its uniform point and the point's error bound. */
CB_FN void lightSamplePoint(const SceneView* scene, int lightIndex, real u0, real u1,
                            LightSample* out) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    out->light = lightIndex;
    out->pdfPick = light->pickProbability;
    out->pdfSolidAngle = 0.0f;
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
#if CB_HAS(CB_FEATURE_DISTANT_LIGHT)
    if (light->kind == CB_LIGHT_DISTANT) {
        /* The origin of a light subpath, on the beam's disk. */
        out->p = lightBeamOrigin(light, vec3FromGlobalArray(light->axis), u0, u1);
        out->pError = vec3(0.0f, 0.0f, 0.0f);
        out->n = vec3(0.0f, 0.0f, 0.0f);
        out->isDelta = 1;
        out->pdfArea = 1.0f / (CB_PI * light->sceneRadius * light->sceneRadius);
        return;
    }
#endif
#if CB_HAS(CB_FEATURE_INFINITE_LIGHT)
    if (light->kind == CB_LIGHT_INFINITE) {
        /* The origin depends on the direction, which bdptLightSubpath samples and places it. */
        out->p = vec3FromGlobalArray(light->position);
        out->pError = vec3(0.0f, 0.0f, 0.0f);
        out->n = vec3(0.0f, 0.0f, 0.0f);
        out->isDelta = 0;
        out->pdfArea = 1.0f / (CB_PI * light->sceneRadius * light->sceneRadius);
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
    out->n = triangleNormal(p0, p1, p2);
}

/* Choose a light by power (uChoice), then a point on it uniformly by area (u0, u1): the origin
 * of a light subpath. False if the scene has no lights. */
CB_FN bool lightSample(const SceneView* scene, real uChoice, real u0, real u1, LightSample* out) {
    if (scene->lightCount <= 0) return false;
    lightSamplePoint(scene, lightChoose(scene, uChoice), u0, u1, out);
    return out->pdfPick > 0.0f;
}

/* Below this sin^2(theta_max) the cone's 1 - cos(theta_max) is taken as sin^2/2 and theta from
 * sin^2 directly, where 1 - cos would cancel in real (pbrt-v4, Sphere::Sample). */
#define CB_CONE_SMALL_SIN2 0.00068523f

/* Solid-angle density, light choice excluded, with which lightSampleFrom samples sphere light
 * `lightIndex` as seen from `ref`: uniform over the cone the sphere subtends, 1 / (2 pi (1 -
 * cos theta_max)) (Shirley et al. 1996, "Monte Carlo Techniques for Direct Lighting
 * Calculations"; pbrt-v4 6.2.3). 0 when the light is sampled by area instead: not a sphere, or
 * ref inside it. */
CB_FN real lightConePdf(const SceneView* scene, int lightIndex, Vec3 ref) {
#if CB_HAS(CB_FEATURE_SPHERES)
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    if (light->kind != CB_LIGHT_AREA) return 0.0f;
    CB_GLOBAL const Primitive* prim = &scene->primitives[light->primitive];
    if (prim->kind != CB_PRIM_SPHERE) return 0.0f;
    real radius = prim->p1[0];
    real dc2 = vlength2(vsub(ref, vec3FromGlobalArray(prim->p0)));
    if (!(dc2 > radius * radius)) return 0.0f;
    real sin2Max = radius * radius / dc2;
    real oneMinusCosMax =
        sin2Max < CB_CONE_SMALL_SIN2 ? 0.5f * sin2Max : 1.0f - cbSafeSqrt(1.0f - sin2Max);
    return 1.0f / (2.0f * CB_PI * oneMinusCosMax);
#else
    (void)scene;
    (void)lightIndex;
    (void)ref;
    return 0.0f;
#endif
}

/* Next-event estimation from `ref`: a light by power, then a point on it. A sphere seen from
 * outside is sampled uniformly in the cone it subtends, which only produces points of the cap
 * that faces ref (uniform area sampling wastes the half facing away and samples the rest with
 * density cos/r^2 in solid angle instead of uniformly): the direction at angle theta from the
 * centre, then the point where that ray first meets the sphere, at angle alpha from the centre's
 * axis (pbrt-v4 Sphere::Sample with a reference point). pdfArea is then the cone density
 * converted to area at the point, and pdfSolidAngle the cone density itself; area sampling
 * leaves pdfSolidAngle 0. False if the scene has no lights or the density vanishes. */
CB_FN bool lightSampleFrom(const SceneView* scene, Vec3 ref, real uChoice, real u0, real u1,
                           LightSample* out) {
    if (scene->lightCount <= 0) return false;
    int lightIndex = lightChoose(scene, uChoice);
#if CB_HAS(CB_FEATURE_DISTANT_LIGHT)
    if (scene->lights[lightIndex].kind == CB_LIGHT_DISTANT) {
        /* The one direction, to a point beyond the bounding sphere (ref lies inside it). */
        CB_GLOBAL const Light* distant = &scene->lights[lightIndex];
        out->light = lightIndex;
        out->pdfPick = distant->pickProbability;
        out->pdfSolidAngle = 0.0f;
        out->p = vmadd(ref, vec3FromGlobalArray(distant->axis), 2.0f * distant->sceneRadius);
        out->pError = vec3(0.0f, 0.0f, 0.0f);
        out->n = vec3(0.0f, 0.0f, 0.0f);
        out->isDelta = 1;
        out->pdfArea = 1.0f;
        return out->pdfPick > 0.0f;
    }
#endif
#if CB_HAS(CB_FEATURE_INFINITE_LIGHT)
    if (scene->lights[lightIndex].kind == CB_LIGHT_INFINITE) {
        /* A direction, to a point beyond the bounding sphere: pdfSolidAngle is its density
         * (pdfArea too, so that 1 / (pdfPick pdfArea) is the sample's weight). */
        CB_GLOBAL const Light* infinite = &scene->lights[lightIndex];
        real pdfW;
        Vec3 w = infiniteLightSampleFrom(scene, infinite, ref, u0, u1, &pdfW);
        out->light = lightIndex;
        out->pdfPick = infinite->pickProbability;
        out->pdfSolidAngle = pdfW;
        out->p = vmadd(ref, w, 2.0f * infinite->sceneRadius);
        out->pError = vec3(0.0f, 0.0f, 0.0f);
        out->n = vec3(0.0f, 0.0f, 0.0f);
        out->isDelta = 0;
        out->pdfArea = pdfW;
        return out->pdfPick > 0.0f && pdfW > 0.0f;
    }
#endif
    real conePdf = lightConePdf(scene, lightIndex, ref);
    out->pdfSolidAngle = conePdf;
    if (!(conePdf > 0.0f)) {
        lightSamplePoint(scene, lightIndex, u0, u1, out);
        return out->pdfPick > 0.0f;
    }
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    CB_GLOBAL const Primitive* prim = &scene->primitives[light->primitive];
    Vec3 center = vec3FromGlobalArray(prim->p0);
    real radius = prim->p1[0];
    Vec3 toRef = vsub(ref, center);
    real dc = vlength(toRef);
    real sinMax = radius / dc;
    real sin2Max = sinMax * sinMax;
    real cosMax = cbSafeSqrt(1.0f - sin2Max);
    real cosTheta = (cosMax - 1.0f) * u0 + 1.0f;
    real sin2Theta = 1.0f - cosTheta * cosTheta;
    if (sin2Max < CB_CONE_SMALL_SIN2) {
        sin2Theta = sin2Max * u0;
        cosTheta = sqrt(1.0f - sin2Theta);
    }
    /* The angle at the centre between ref and the point: the law of sines on the triangle
     * (ref, centre, point) with |ref - centre| = r / sinMax. */
    real cosAlpha = sin2Theta / sinMax + cosTheta * cbSafeSqrt(1.0f - sin2Theta / sin2Max);
    real sinAlpha = cbSafeSqrt(1.0f - cosAlpha * cosAlpha);
    real phiOverPi = 2.0f * u1;
    Vec3 dirLocal = vec3(sinAlpha * cbCosPi(phiOverPi), sinAlpha * cbSinPi(phiOverPi), cosAlpha);
    Vec3 dir = frameToWorld(frameFromNormal(vscale(toRef, 1.0f / dc)), dirLocal);
    out->light = lightIndex;
    out->pdfPick = light->pickProbability;
    out->isDelta = 0;
    out->p = vmadd(center, dir, radius);
    out->pError = vscale(vabs(out->p), cbGamma(5));
    out->n = vscale(dir, prim->p1[1]);
    Vec3 toLight = vsub(out->p, ref);
    real dist2 = vlength2(toLight);
    real cosLight = vabsdot(out->n, toLight) / sqrt(dist2);
    out->pdfArea = conePdf * cosLight / dist2;
    return out->pdfPick > 0.0f && out->pdfArea > 0.0f && isfinite(out->pdfArea);
}

/* Solid-angle density at `ref`, light choice included, with which lightSampleFrom produces the
 * point p (normal n) of area light `lightIndex`: the cone's for spheres seen from outside, else
 * the area density converted (Veach 1997, eq. 8.10). */
CB_FN real lightPdfSolidAngleFrom(const SceneView* scene, int lightIndex, Vec3 ref, Vec3 p,
                                  Vec3 n) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    real conePdf = lightConePdf(scene, lightIndex, ref);
    if (conePdf > 0.0f) return light->pickProbability * conePdf;
    Vec3 d = vsub(p, ref);
    real dist2 = vlength2(d);
    real cosLight = vabsdot(n, d) / sqrt(dist2);
    return light->pickProbability / light->area * dist2 / cosLight;
}

/* Radiance leaving an area light with front normal n in direction w (unit), or arriving from
 * the infinite light travelling in direction w. One-sided lights emit only to the side n points
 * to. */
CB_FN Spectrum lightEmittedRadiance(const SceneView* scene, int lightIndex, Vec3 n, Vec3 w) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
#if CB_HAS(CB_FEATURE_INFINITE_LIGHT)
    if (light->kind == CB_LIGHT_INFINITE) return infiniteLightRadiance(scene, light, vneg(w));
#endif
    if (!light->twoSided && vdot(n, w) <= 0.0f) return specZero();
    return specLoad(scene->spectra, light->emission);
}

/* Intensity a point light sends in unit direction w: uniform, for a spot light pbrt-v4's
 * SmoothStep(cosEnd, cosStart, cos theta) falloff from its axis, for a goniometric light its
 * image's pixel in that direction (pbrt-v4's GoniometricLight::I). */
CB_FN Spectrum pointLightIntensity(const SceneView* scene, int lightIndex, Vec3 w) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
#if CB_HAS(CB_FEATURE_IMAGE_LIGHT)
    if (light->imageSize > 0)
        return imageLightPixelEmission(scene, light, imageLightPixel(light, w));
#endif
    Spectrum intensity = specLoad(scene->spectra, light->emission);
#if CB_HAS(CB_FEATURE_SPOT_LIGHT)
    if (light->spotCosEnd >= -1.0f) {
        real c = vdot(w, vec3FromGlobalArray(light->axis));
        real t = (c - light->spotCosEnd) / (light->spotCosStart - light->spotCosEnd);
        t = fmin(fmax(t, 0.0f), 1.0f);
        if (!(light->spotCosStart > light->spotCosEnd)) t = c < light->spotCosEnd ? 0.0f : 1.0f;
        intensity = specScale(intensity, t * t * (3.0f - 2.0f * t));
    }
#endif
    return intensity;
}

/* What delta light sample `ls` sends to the point it was sampled from, seen in unit direction
 * wi (toward the light) at squared distance dist2, and *pdfW, the light choice expressed as a
 * solid-angle density that divides it: a point light's intensity I arrives as I / r^2 (pdfW =
 * pick r^2), a distant light's radiance L from one direction is irradiance L (pdfW = pick). */
CB_FN Spectrum deltaLightArriving(const SceneView* scene, const LightSample* ls, Vec3 wi,
                                  real dist2, real* pdfW) {
#if CB_HAS(CB_FEATURE_DISTANT_LIGHT)
    if (scene->lights[ls->light].kind == CB_LIGHT_DISTANT) {
        *pdfW = ls->pdfPick;
        return specLoad(scene->spectra, scene->lights[ls->light].emission);
    }
#endif
    *pdfW = ls->pdfPick * dist2;
    return pointLightIntensity(scene, ls->light, vneg(wi));
}

/* Whether a ray can find light `lightIndex` (a point light, say, it cannot), so that
 * strategies which find it by a ray share its paths in MIS. */
CB_FN bool lightFoundByRays(const SceneView* scene, int lightIndex) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    if (light->kind == CB_LIGHT_POINT || light->kind == CB_LIGHT_DISTANT) return false;
#if CB_HAS(CB_FEATURE_INVISIBLE_LIGHT)
    if (light->invisible) return false;
#endif
    return true;
}

/* Probability density, in area measure and including the choice of light, with which
 * lightSample produces a given point of area light `lightIndex`. */
CB_FN real lightPdfArea(const SceneView* scene, int lightIndex) {
    CB_GLOBAL const Light* light = &scene->lights[lightIndex];
    return light->pickProbability / light->area;
}

CB_END_NAMESPACE

#endif /* CB_LIGHTS_H */
