/* cb_sampling.h - warps from the unit square to directions and points, the GGX microfacet
 * distribution, and the power heuristic.
 *
 * Every warp is continuous in (u0, u1): CPT/CBDPT share one sample vector across a coherence
 * tile (docs/method.md, coherence), so nearby pixels must turn the same u into nearby directions.
 * Directions are in a local frame with z along the normal. */
#ifndef CB_SAMPLING_H
#define CB_SAMPLING_H

#include "cb_common.h"

CB_BEGIN_NAMESPACE

/* ---- Disk, hemisphere, sphere, triangle ------------------------------------------------------ */

/* Shirley & Chiu 1997, "A Low Distortion Map Between Disk and Square": concentric squares go to
 * concentric circles, so the map is continuous and area-preserving up to a constant, unlike the
 * polar map (r = sqrt(u0)) whose angle jumps between u1 = 0 and 1 at the same point. */
CB_FN void sampleConcentricDisk(real u0, real u1, real* x, real* y) {
    real a = 2.0f * u0 - 1.0f;
    real b = 2.0f * u1 - 1.0f;
    if (a == 0.0f && b == 0.0f) {
        *x = 0.0f;
        *y = 0.0f;
        return;
    }
    real r, phiOverPi;
    if (fabs(a) > fabs(b)) {
        r = a;
        phiOverPi = 0.25f * (b / a);
    } else {
        r = b;
        phiOverPi = 0.5f - 0.25f * (a / b);
    }
    *x = r * cbCosPi(phiOverPi);
    *y = r * cbSinPi(phiOverPi);
}

/* Malley's method: project the uniform disk up onto the hemisphere, which gives density
 * cos(theta)/pi (pbrt-v4 13.6.3). */
CB_FN Vec3 sampleCosineHemisphere(real u0, real u1) {
    real x, y;
    sampleConcentricDisk(u0, u1, &x, &y);
    return vec3(x, y, cbSafeSqrt(1.0f - x * x - y * y));
}
CB_FN real cosineHemispherePdf(real cosTheta) {
    return fmax(cosTheta, 0.0f) * CB_INV_PI;
}

/* Archimedes: z uniform in [-1, 1] gives uniform area on the sphere. */
CB_FN Vec3 sampleUniformSphere(real u0, real u1) {
    real z = 1.0f - 2.0f * u0;
    real r = cbSafeSqrt(1.0f - z * z);
    real phiOverPi = 2.0f * u1;
    return vec3(r * cbCosPi(phiOverPi), r * cbSinPi(phiOverPi), z);
}
CB_FN real uniformSpherePdf(void) {
    return CB_INV_4PI;
}

CB_FN Vec3 sampleUniformHemisphere(real u0, real u1) {
    real z = u0;
    real r = cbSafeSqrt(1.0f - z * z);
    real phiOverPi = 2.0f * u1;
    return vec3(r * cbCosPi(phiOverPi), r * cbSinPi(phiOverPi), z);
}
CB_FN real uniformHemispherePdf(void) {
    return CB_INV_2PI;
}

/* ---- pbrt-v4's equal-area octahedral map ----------------------------------------------------- */

/* Clarberg 2008, "Fast Equal-Area Mapping of the (Hemi)Sphere using SIMD": the unit square onto
 * the unit sphere with every region keeping its share of the area, so that a density p over the
 * square is p / (4 pi) per steradian. In [-1,1]^2 the diamond |u| + |v| <= 1 is the northern
 * hemisphere (centre +z), the four corners the southern one (-z), |u| + |v| = r (r^2 = 1 - |z|
 * north) and the azimuth is linear along each diamond edge. pbrt-v4's image lights use it. */
CB_FN Vec3 equalAreaSquareToSphere(real s, real t) {
    real u = 2.0f * s - 1.0f;
    real v = 2.0f * t - 1.0f;
    real au = fabs(u);
    real av = fabs(v);
    real signedDistance = 1.0f - (au + av); /* from the equator; > 0 in the north */
    real r = 1.0f - fabs(signedDistance);
    /* The azimuth in the quadrant, in units of pi/2: 0 on the u axis, 1 on the v axis. */
    real phi = r == 0.0f ? 0.5f : 0.5f * ((av - au) / r + 1.0f);
    real z = copysign(1.0f - r * r, signedDistance);
    real radial = r * cbSafeSqrt(2.0f - r * r); /* sqrt(1 - z^2) */
    return vec3(copysign(radial * cbCosPi(0.5f * phi), u),
                copysign(radial * cbSinPi(0.5f * phi), v), z);
}

/* The inverse of equalAreaSquareToSphere for a unit direction d: its point (*s, *t) of the unit
 * square. */
CB_FN void equalAreaSphereToSquare(Vec3 d, real* s, real* t) {
    real ax = fabs(d.x);
    real ay = fabs(d.y);
    real r = cbSafeSqrt(1.0f - fabs(d.z));
    real big = fmax(ax, ay);
    real small = fmin(ax, ay);
    /* The azimuth in units of pi/2, from the nearer of the x and y axes, then from x. */
    real phi = big == 0.0f ? 0.0f : atan2(small, big) * (2.0f * CB_INV_PI);
    if (ax < ay) phi = 1.0f - phi;
    real v = phi * r;
    real u = r - v;
    if (d.z < 0.0f) {
        /* The south: the diamond's edge point mirrored out to the corner triangle. */
        real northU = u;
        u = 1.0f - v;
        v = 1.0f - northU;
    }
    *s = 0.5f * (copysign(u, d.x) + 1.0f);
    *t = 0.5f * (copysign(v, d.y) + 1.0f);
}

/* ---- Tabulated distributions ----------------------------------------------------------------- */

/* Inverts the CDF of `count` intervals, cdf[0] = 0 <= cdf[1] <= ... <= cdf[count] = 1: the last
 * interval i with cdf[i] <= u (never an empty one, for u < 1) and u's position inside it, in
 * [0, 1), in *within. Interval i is chosen with probability cdf[i+1] - cdf[i] exactly, which is
 * the density its users divide by. Unlike the warps above it is continuous in u only within an
 * interval: a coherence tile's shared u picks one interval for the whole tile. */
CB_FN int sampleCdf(CB_GLOBAL const real* cdf, int count, real u, real* within) {
    int lo = 0;
    int hi = count - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (cdf[mid] <= u)
            lo = mid;
        else
            hi = mid - 1;
    }
    real width = cdf[lo + 1] - cdf[lo];
    *within = width > 0.0f ? fmin((u - cdf[lo]) / width, 0.99999994f) : 0.0f;
    return lo;
}

/* Heitz 2019, "A Low-Distortion Map Between Triangle and Square": each half of the square maps
 * linearly (Jacobian 1/2) onto the triangle, and the two halves agree on the diagonal, so the map
 * is continuous and uniform by area. Returns barycentrics with b0 + b1 + b2 = 1. */
CB_FN void sampleUniformTriangle(real u0, real u1, real* b0, real* b1, real* b2) {
    real t0, t1;
    if (u1 > u0) {
        t0 = 0.5f * u0;
        t1 = u1 - t0;
    } else {
        t1 = 0.5f * u1;
        t0 = u0 - t1;
    }
    *b0 = t0;
    *b1 = t1;
    *b2 = fmax(1.0f - t0 - t1, 0.0f);
}

/* ---- GGX / Trowbridge-Reitz microfacets ------------------------------------------------------ */

/* Alpha below this is treated as this: D peaks at 1/(pi alpha^2), which stays far from real
 * overflow, and the sampled normals are still resolvable in real. */
#define CB_GGX_MIN_ALPHA 1e-4f

/* GGX's roughness along the local frame's x axis (the surface's dp/du, pbrt-v4's "uroughness")
 * and y axis ("vroughness"); equal where the lobe is isotropic. */
typedef struct GgxAlpha {
    real x, y;
} GgxAlpha;

CB_FN GgxAlpha ggxIsotropic(real alpha) {
    GgxAlpha a;
    a.x = alpha;
    a.y = alpha;
    return a;
}

/* Walter et al. 2007, eq. 33, anisotropic as Heitz 2014 (eq. 85), written with the unit normal's
 * components so that no tan() of a grazing angle appears: D = 1 / (pi ax ay (x^2/ax^2 + y^2/ay^2
 * + z^2)^2), as (x^2 + y^2 (ax/ay)^2) / ax^2 so that equal alphas round as the isotropic form. */
CB_FN real ggxD(Vec3 wm, GgxAlpha alpha) {
    if (wm.z <= 0.0f) return 0.0f;
    real a2 = alpha.x * alpha.y;
    real t =
        (wm.x * wm.x + wm.y * wm.y * cbSqr(alpha.x / alpha.y)) / (alpha.x * alpha.x) + wm.z * wm.z;
    return 1.0f / (CB_PI * a2 * t * t);
}

/* Smith's Lambda for GGX (Heitz 2014, "Understanding the Masking-Shadowing Function", eq. 72):
 * (sqrt(1 + a^2 tan^2) - 1) / 2, rewritten as s / (2 (sqrt(1 + s) + 1)) with s = a^2 tan^2 to
 * avoid the cancellation near the normal; anisotropic, a^2 tan^2 = (ax^2 x^2 + ay^2 y^2) / z^2
 * (Heitz 2014, eq. 86). Infinite (no visibility) in the tangent plane. */
CB_FN real ggxLambda(Vec3 w, GgxAlpha alpha) {
    real z = fabs(w.z);
    if (z == 0.0f) return CB_INFINITY;
    real tanTheta = alpha.x * sqrt(w.x * w.x + w.y * w.y * cbSqr(alpha.y / alpha.x)) / z;
    if (!(tanTheta < 1e15f)) return tanTheta < CB_INFINITY ? 0.5f * tanTheta : CB_INFINITY;
    real s = tanTheta * tanTheta;
    return s / (2.0f * (sqrt(1.0f + s) + 1.0f));
}

CB_FN real ggxG1(Vec3 w, GgxAlpha alpha) {
    return 1.0f / (1.0f + ggxLambda(w, alpha));
}

/* Height-correlated masking-shadowing (Heitz 2014, eq. 99). */
CB_FN real ggxG(Vec3 wo, Vec3 wi, GgxAlpha alpha) {
    return 1.0f / (1.0f + ggxLambda(wo, alpha) + ggxLambda(wi, alpha));
}

/* Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (listing 1): stretch wo to the
 * alpha = 1 configuration, sample the projected hemisphere as a disk whose far half is squashed
 * by (1 + Vh.z)/2, and unstretch (by ax along x, ay along y). The disk is sampled with the
 * concentric map (continuity). wo must have wo.z >= 0; the result has wm.z >= 0. */
CB_FN Vec3 ggxSampleVisibleNormal(Vec3 wo, GgxAlpha alpha, real u0, real u1) {
    Vec3 vh = vnormalize(vec3(alpha.x * wo.x, alpha.y * wo.y, fmax(wo.z, 0.0f)));
    real lensq = vh.x * vh.x + vh.y * vh.y;
    Vec3 t1 =
        lensq > 0.0f ? vscale(vec3(-vh.y, vh.x, 0.0f), 1.0f / sqrt(lensq)) : vec3(1.0f, 0.0f, 0.0f);
    Vec3 t2 = vcross(vh, t1);
    real p1, p2;
    sampleConcentricDisk(u0, u1, &p1, &p2);
    real s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * cbSafeSqrt(1.0f - p1 * p1) + s * p2;
    Vec3 nh = vadd(vadd(vscale(t1, p1), vscale(t2, p2)),
                   vscale(vh, cbSafeSqrt(1.0f - p1 * p1 - p2 * p2)));
    Vec3 ne = vec3(alpha.x * nh.x, alpha.y * nh.y, fmax(nh.z, 0.0f));
    real len = vlength(ne);
    return len > 0.0f ? vscale(ne, 1.0f / len) : vec3(0.0f, 0.0f, 1.0f);
}

/* Density of ggxSampleVisibleNormal in solid angle of wm: D_wo(wm) = G1(wo) max(0, wo.wm) D(wm)
 * / wo.z (Heitz 2018, eq. 3). */
CB_FN real ggxVisibleNormalPdf(Vec3 wo, Vec3 wm, GgxAlpha alpha) {
    if (wo.z <= 0.0f) return 0.0f;
    real cosOm = vdot(wo, wm);
    if (cosOm <= 0.0f) return 0.0f;
    real pdf = (ggxG1(wo, alpha) / wo.z) * cosOm * ggxD(wm, alpha);
    return isfinite(pdf) ? pdf : 0.0f;
}

/* ---- Multiple importance sampling ------------------------------------------------------------ */

/* Veach 1997, eq. 9.13 with beta = 2, as 1 / (1 + (b/a)^2) so that neither pdf^2 overflows; an
 * infinite (delta) pdfA against a finite pdfB gives 1, zero or NaN pdfA gives 0. */
CB_FN real powerHeuristic(real pdfA, real pdfB) {
    if (!(pdfA > 0.0f)) return 0.0f;
    if (!(pdfB > 0.0f)) return 1.0f;
    if (!isfinite(pdfA) && !isfinite(pdfB)) return 0.5f;
    real r = pdfB / pdfA;
    return 1.0f / (1.0f + r * r);
}

/* The Henyey-Greenstein phase function of asymmetry g at mu, the cosine between the propagation
 * directions before and after scattering (g > 0 scatters forward; pbrt-v4's HGPhaseFunction). g
 * is kept within 0.99 of 0, as pbrt-v4 keeps it: closer to +-1 the float inversion below drifts
 * from this density. Below 1e-3 it is 0, the uniform sphere the inversion then samples. Used by
 * the layers of coated materials (cb_bsdf.h) and by scattering media (cb_medium.h). */
CB_FN real phaseHenyeyGreensteinG(real g) {
    return fabs(g) < 1e-3f ? 0.0f : cbClamp(g, -0.99f, 0.99f);
}

CB_FN real phaseHenyeyGreenstein(real mu, real g) {
    g = phaseHenyeyGreensteinG(g);
    real denom = 1.0f + g * g - 2.0f * g * mu;
    return CB_INV_4PI * (1.0f - g * g) / (denom * cbSafeSqrt(denom));
}

/* A propagation direction after scattering from w, mu by inverting the phase function's
 * distribution, mu = (1 + g^2 - ((1 - g^2) / (1 - g + 2 g u))^2) / (2 g); its density in *pdf. */
CB_FN Vec3 phaseHenyeyGreensteinSample(Vec3 w, real g, real u0, real u1, real* pdf) {
    real mu;
    g = phaseHenyeyGreensteinG(g);
    if (g == 0.0f) {
        mu = 1.0f - 2.0f * u0;
    } else {
        real s = (1.0f - g * g) / (1.0f - g + 2.0f * g * u0);
        mu = (1.0f + g * g - s * s) / (2.0f * g);
    }
    mu = cbClamp(mu, -1.0f, 1.0f);
    real r = cbSafeSqrt(1.0f - mu * mu);
    *pdf = phaseHenyeyGreenstein(mu, g);
    return frameToWorld(frameFromNormal(w),
                        vec3(r * cbCosPi(2.0f * u1), r * cbSinPi(2.0f * u1), mu));
}

CB_END_NAMESPACE

#endif /* CB_SAMPLING_H */
