/* cb_bsdf.h - the materials of cb_types.h as BSDFs: evaluation, sampling and the pdfs that MIS
 * needs in both directions.
 *
 * Conventions (shared by every integrator):
 * - wo points toward the viewer / previous vertex, wi toward the next vertex; both are world-space
 *   unit vectors pointing away from the surface.
 * - frame.n is the geometric (outward) normal. Surfaces are two-sided: diffuse and conductor
 *   reflect into wo's hemisphere; the dielectric decides entering/leaving by wo's side; diffuse
 *   transmission and the thin dielectric are the same from both sides.
 * - f excludes the cosine. A delta sample carries pdf = the discrete probability of its lobe and
 *   f = (lobe weight) / |cos wi|, so f |cos wi| / pdf is always the throughput factor.
 * - adjoint = 0 for radiance transport (eye paths), 1 for importance transport (light paths).
 * - Coated diffuse and coated conductor estimate f and its pdf by a random walk between their two
 *   layers (below), as pbrt-v4 does: bsdfSample's f |cos wi| / pdf is the walk's exact weight,
 *   its pdf the same estimate bsdfEval returns for MIS.
 * - Mix (f = (1-a) f1 + a f2): a non-delta sample returns the full mixture's f and its pdf
 *   (1-a) p1 + a p2 over the non-delta components, so bsdfEval's pdfFwd is exactly the density
 *   of bsdfSample's non-delta directions. A delta sample (a delta component was picked) returns
 *   f and pdf of that component, both multiplied by the probability of picking it; pdfRev alike.
 * - Hair (pbrt-v4's HairBxDF) is not reciprocal: adjoint evaluation and sampling return f(wi, wo)
 *   (the adjoint BSDF), with the pdfs of its own sampler (hairLobeEval).
 *
 * Each material kind is compiled only if its feature bit is in CB_FEATURES. */
#ifndef CB_BSDF_H
#define CB_BSDF_H

#include "cb_common.h"
#include "cb_rng.h"
#include "cb_sampling.h"
#include "cb_spectrum.h"
#include "cb_texture.h"
#include "cb_types.h"

CB_BEGIN_NAMESPACE

typedef struct BsdfSample {
    Vec3 wi;     /* world-space unit direction, away from the surface */
    Spectrum f;  /* BSDF value without |cos|; delta lobes: f |cos wi| / pdf = throughput factor */
    real pdf;    /* solid-angle pdf; delta lobes: discrete probability of the lobe */
    real pdfRev; /* pdf of sampling wo given wi, same conventions */
    int isDelta; /* the sampled lobe is a Dirac delta */
} BsdfSample;

/* ---- Dielectric Fresnel ---------------------------------------------------------------------- */

/* Unpolarised Fresnel reflectance of a smooth dielectric interface (Born & Wolf; pbrt-v4 eq. 9.6).
 * cosI > 0 on the incident side, eta = eta_transmitted / eta_incident. Returns 1 under total
 * internal reflection; *cosT receives the cosine of the refracted direction (0 under TIR). */
CB_FN real fresnelDielectric(real cosI, real eta, real* cosT) {
    cosI = cbClamp(cosI, 0.0f, 1.0f);
    real sin2T = (1.0f - cosI * cosI) / (eta * eta);
    if (sin2T >= 1.0f) {
        *cosT = 0.0f;
        return 1.0f;
    }
    real ct = cbSafeSqrt(1.0f - sin2T);
    *cosT = ct;
    real rs = (cosI - eta * ct) / (cosI + eta * ct);
    real rp = (eta * cosI - ct) / (eta * cosI + ct);
    return 0.5f * (rs * rs + rp * rp);
}

#if CB_HAS_CONDUCTOR_FRESNEL
/* Unpolarised Fresnel reflectance of a conductor of complex index eta + i k under vacuum, at
 * cosI to its normal (Born & Wolf sec. 13.2; the a, b form of Lagarde's "Memo on Fresnel
 * equations", as pbrt-v3's FrConductor), arranged against cancellation: t0 = eta^2 - k^2 -
 * sin^2 from whichever of its two groupings has the smaller rounding bound (sin^2 near 0: a
 * tiny eta at normal incidence; near 1: index matching at grazing angles), and a^2 =
 * (|z| + t0) / 2 with t0 < 0 as q^2 / (2 (|z| - t0)), z = t0 + i q (a nearly lossless index
 * below 1). hypot keeps eta, k up to 1e9 finite. */
CB_FN real fresnelConductor(real cosI, real eta, real k) {
    real c = cbClamp(cosI, 0.0f, 1.0f);
    real cos2 = c * c;
    real sin2 = (1.0f - c) * (1.0f + c);
    real etaK = (eta - k) * (eta + k), eta1 = (eta - 1.0f) * (eta + 1.0f);
    real t0 = fabs(etaK) + sin2 <= fabs(eta1) + k * k + cos2 ? etaK - sin2 : eta1 - k * k + cos2;
    real q = 2.0f * eta * k;
    real a2b2 = hypot(t0, q); /* a^2 + b^2 */
    real a = t0 >= 0.0f ? sqrt(0.5f * (a2b2 + t0)) : q / sqrt(2.0f * (a2b2 - t0));
    real t1 = a2b2 + cos2;
    real t2 = 2.0f * a * c;
    /* t1 - t2 >= (a - cos)^2 >= 0; t1 + t2 is 0 only at grazing on eta = 1, k = 0 (no
     * interface), where the limit is 0. */
    real rs = t1 + t2 > 0.0f ? fmax(t1 - t2, 0.0f) / (t1 + t2) : 0.0f;
    real t3 = cos2 * a2b2 + sin2 * sin2;
    real t4 = t2 * sin2;
    /* t3 + t4 is 0 only at normal incidence on eta = k = 0, where rp = rs. */
    real rp = t3 + t4 > 0.0f ? rs * fmax(t3 - t4, 0.0f) / (t3 + t4) : rs;
    return 0.5f * (rs + rp);
}
#endif

#if CB_HAS(CB_FEATURE_THIN_DIELECTRIC)
/* Reflectance of a thin sheet of index eta in vacuum, seen at cosO: the light reflected by its
 * first face plus what leaves through the first face after 1, 3, 5, ... internal reflections,
 * R + T^2 R / (1 - R^2) with T = 1 - R, which is 2R / (1 + R) (pbrt-v4's ThinDielectricBxDF,
 * sec. 9.5.1); the rest passes straight through. */
CB_FN real thinDielectricReflectance(real cosO, real eta) {
    real cosT;
    real r = fresnelDielectric(cosO, eta, &cosT);
    return 2.0f * r / (1.0f + r);
}
#endif

/* A diffuse, coated diffuse or coated conductor material's reflectance at texture coordinates
 * uv: its image texture's there, or its constant spectrum. */
CB_FN Spectrum materialReflectance(const SceneView* scene, Material m, TexCoord uv) {
#if CB_HAS(CB_FEATURE_TEXTURE)
    if (m.reflectanceTexture >= 0) return textureReflectance(scene, m.reflectanceTexture, uv);
#endif
    (void)uv;
    return specLoad(scene->spectra, m.reflectance);
}

#if CB_HAS(CB_FEATURE_DIFFUSE_TRANSMISSION)
/* A diffuse transmitter's reflectance (texture `reflectanceTexture`, spectrum `reflectance`) or
 * transmittance (`transmittanceTexture`, `secondSpectrum`) at uv: a texture's value times the
 * material's scale, clamped to [0, 1] again (pbrt-v4's DiffuseTransmissionMaterial), or the
 * constant spectrum, which holds the scale already. */
CB_FN Spectrum diffuseTransmissionSpectrum(const SceneView* scene, int texture, int spectrum,
                                           real scale, TexCoord uv) {
#if CB_HAS(CB_FEATURE_TEXTURE)
    if (texture >= 0) {
        Spectrum s = textureReflectance(scene, texture, uv);
        for (int i = 0; i < CB_CHANNELS; ++i)
            s.c[i] = cbClamp(s.c[i] * scale, 0.0f, 1.0f);
        return s;
    }
#endif
    (void)texture;
    (void)scale;
    (void)uv;
    return specLoad(scene->spectra, spectrum);
}

/* A diffuse transmitter's reflectance *r and transmittance *t at uv, and the probability that
 * its sample reflects: max r over max r + max t (pbrt-v4's DiffuseTransmissionBxDF), 0 and 1
 * included; below 0 when both are black. */
CB_FN real cbDiffuseTransmissionAt(const SceneView* scene, Material m, TexCoord uv, Spectrum* r,
                                   Spectrum* t) {
    *r =
        diffuseTransmissionSpectrum(scene, m.reflectanceTexture, m.reflectance, m.textureScale, uv);
    *t = diffuseTransmissionSpectrum(scene, m.transmittanceTexture, m.secondSpectrum,
                                     m.textureScale, uv);
    real pr = specMaxComponent(*r);
    real pt = specMaxComponent(*t);
    return pr + pt > 0.0f ? pr / (pr + pt) : -1.0f;
}
#endif

#if CB_HAS(CB_FEATURE_ROUGHNESS_TEXTURE)
/* A material whose roughness is a float texture, with its GGX alpha at uv: the texture's value
 * there, remapped as pbrt-v4's "remaproughness", kept at least 1e-3, the threshold below which
 * the host would have made the lobe smooth (pbrt-v4 renders such points as a smooth lobe). */
CB_FN Material materialRoughnessAt(const SceneView* scene, Material m, TexCoord uv) {
    if (m.roughnessTexture < 0 || m.alpha == 0.0f) return m;
    real roughness = fmax(textureFloat(scene, m.roughnessTexture, uv), 0.0f);
    real alpha = m.remapRoughness ? sqrt(roughness) : roughness;
    m.alpha = fmax(alpha, 1e-3f);
    m.alphaV = m.alpha; /* one texture: isotropic */
    return m;
}
#endif

#if CB_HAS(CB_FEATURE_THICKNESS_TEXTURE)
/* A coat whose layer thickness is a float texture, with its thickness at uv: the texture's
 * value there, at least the smallest normal float (pbrt-v4's LayeredBxDF keeps it so). */
CB_FN Material materialThicknessAt(const SceneView* scene, Material m, TexCoord uv) {
    if (m.thicknessTexture >= 0)
        m.thickness = fmax(textureFloat(scene, m.thicknessTexture, uv), 1.17549435e-38f);
    return m;
}
#endif

#if CB_HAS(CB_FEATURE_DISPERSION)
/* pbrt-v4's SampledWavelengths::TerminateSecondary over cbdpt's bins: a path that meets a
 * dielectric whose index varies with wavelength (DielectricMaterial::GetBxDF) keeps one
 * wavelength from there on, uniform over 400-700 nm by u: its bin's throughput times
 * CB_CHANNELS, the other bins' 0 (an unbiased estimate of every bin's), and its position over
 * the bins in *hero, which the path's later (thin) dielectrics refract by
 * (materialDispersionAt). A path already following one keeps it. */
CB_FN void dispersionFollowOne(const SceneView* scene, int material, real u, real* hero,
                               Spectrum* beta) {
    if (*hero >= 0.0f || scene->materials[material].dispersion < 0) return;
    const real position = fmin(u * (real)CB_CHANNELS, (real)CB_CHANNELS - 1e-4f);
    const int bin = (int)position;
    Spectrum kept = specZero();
    kept.c[bin] = beta->c[bin] * (real)CB_CHANNELS;
    *beta = kept;
    *hero = position;
}

/* A dispersive material's index at the wavelength its path follows: linear between the knots
 * (Material.dispersion). Without one (uv.hero < 0) it keeps `eta`, the knots' mean: a path
 * chooses its wavelength at the dispersive vertex before any lookup there (dispersionFollowOne),
 * so only direct calls see that. */
CB_FN Material materialDispersionAt(const SceneView* scene, Material m, TexCoord uv) {
    if (m.dispersion < 0 || !(uv.hero >= 0.0f)) return m;
    const real t = uv.hero * (real)CB_DISPERSION_KNOTS_PER_BIN;
    const int last = CB_DISPERSION_KNOTS - 2;
    const int i = (int)t < last ? (int)t : last;
    CB_GLOBAL const real* knots = scene->spectra + m.dispersion * CB_CHANNELS;
    m.eta = knots[i] + (t - (real)i) * (knots[i + 1] - knots[i]);
    return m;
}
#endif

/* ---- Per-kind lobes, in the local frame flipped so that wo.z > 0 ----------------------------- */

/* A conductor's or rough dielectric's GGX alphas along dp/du and dp/dv, at least
 * CB_GGX_MIN_ALPHA; kernels without anisotropic materials read `alpha` alone. */
CB_FN GgxAlpha materialGgxAlpha(Material m) {
    GgxAlpha a = ggxIsotropic(fmax(m.alpha, CB_GGX_MIN_ALPHA));
#if CB_HAS(CB_FEATURE_ANISOTROPIC)
    a.y = fmax(m.alphaV, CB_GGX_MIN_ALPHA);
#endif
    return a;
}

#if CB_HAS(CB_FEATURE_CONDUCTOR)

/* The conductor's Fresnel factor at cosH to the microfacet (or mirror) normal, given the entry
 * `reflectance` points to: that constant tint, or, where the material has eta and k, the complex
 * Fresnel equations per channel on eta (that entry) and k. */
CB_FN Spectrum cbConductorFresnel(const SceneView* scene, Material m, Spectrum reflectance,
                                  real cosH) {
#if CB_HAS(CB_FEATURE_CONDUCTOR_FRESNEL)
    if (m.secondSpectrum >= 0) {
        Spectrum k = specLoad(scene->spectra, m.secondSpectrum);
        Spectrum f;
        for (int c = 0; c < CB_CHANNELS; ++c)
            f.c[c] = fresnelConductor(cosH, reflectance.c[c], k.c[c]);
        return f;
    }
#endif
    (void)scene;
    (void)m;
    (void)cosH;
    return reflectance;
}

#endif

#if CB_HAS_GGX_REFLECTION
/* Torrance-Sparrow with GGX and height-correlated Smith G (Walter et al. 2007, eq. 20) without
 * its Fresnel term, which the caller multiplies. Returns the scalar D G / (4 cos_o cos_i) and the
 * pdfs of the visible-normal reflection (pdf_vn(wm) / (4 wo.wm), Heitz 2018 eq. 17) both ways;
 * zero everywhere when not finite (both directions in the grazing limit). */
CB_FN real cbGgxReflection(Vec3 wo, Vec3 wi, Vec3 wm, GgxAlpha alpha, real* pdfFwd, real* pdfRev) {
    *pdfFwd = 0.0f;
    *pdfRev = 0.0f;
    real cosO = wo.z, cosI = wi.z;
    if (!(cosO > 0.0f) || !(cosI > 0.0f)) return 0.0f;
    real d = ggxD(wm, alpha);
    real dotOm = vdot(wo, wm), dotIm = vdot(wi, wm);
    if (!(d > 0.0f) || !(dotOm > 0.0f) || !(dotIm > 0.0f)) return 0.0f;
    real value = d * ggxG(wo, wi, alpha) / (4.0f * cosO * cosI);
    real fwd = ggxVisibleNormalPdf(wo, wm, alpha) / (4.0f * dotOm);
    real rev = ggxVisibleNormalPdf(wi, wm, alpha) / (4.0f * dotIm);
    if (!isfinite(value) || !isfinite(fwd) || !isfinite(rev) || !(fwd > 0.0f)) return 0.0f;
    *pdfFwd = fwd;
    *pdfRev = rev;
    return value;
}

/* wo (wo.z > 0) mirrored about a microfacet normal *wm sampled from GGX's visible normals
 * (Heitz 2018), with cbGgxReflection's value and pdfs; false below the surface. D cancels in
 * f cos / pdf only if both use the sampled wm, not the recomputed half vector (which loses
 * precision at tiny alpha). */
CB_FN bool cbGgxReflectionSample(Vec3 wo, GgxAlpha alpha, real u0, real u1, Vec3* wi, Vec3* wm,
                                 real* value, real* pdfFwd, real* pdfRev) {
    Vec3 m = ggxSampleVisibleNormal(wo, alpha, u0, u1);
    Vec3 w = vsub(vscale(m, 2.0f * vdot(wo, m)), wo);
    real len = vlength(w);
    if (!(len > 0.0f)) return false;
    w = vscale(w, 1.0f / len);
    if (!(w.z > 0.0f)) return false;
    *value = cbGgxReflection(wo, w, m, alpha, pdfFwd, pdfRev);
    *wi = w;
    *wm = m;
    return *pdfFwd > 0.0f;
}
#endif

/* Which lobes of a dielectric interface a sample may take (pbrt-v4's BxDFReflTransFlags). */
#define CB_LOBE_REFLECT 1
#define CB_LOBE_TRANSMIT 2
#define CB_LOBES_BOTH 3

/* A smooth dielectric interface's delta sample from above it (wo.z > 0, eta the index below over
 * the index above): Fresnel chooses reflection or refraction among the allowed `lobes` by u (total
 * internal reflection leaves reflection). *f is the lobe's weight over |cos wi| (a delta's
 * f |cos|), *pdf its probability among the allowed lobes. Transmitted radiance is divided by
 * eta^2, importance is not (Veach 1997, sec. 5.2), which is what makes the adjoint BSDF differ. */
CB_FN bool smoothDielectricSample(Vec3 wo, real eta, int lobes, real u, int adjoint, Vec3* wi,
                                  real* f, real* pdf, bool* transmitted) {
    real cosT;
    real fr = fresnelDielectric(wo.z, eta, &cosT);
    real pr = (lobes & CB_LOBE_REFLECT) ? fr : 0.0f;
    real pt = (lobes & CB_LOBE_TRANSMIT) && cosT > 0.0f ? 1.0f - fr : 0.0f;
    /* Both lobes' probabilities sum to 1: not summed, which would round. */
    real total = lobes == CB_LOBES_BOTH && cosT > 0.0f ? 1.0f : pr + pt;
    if (!(total > 0.0f)) return false;
    *transmitted = !(u * total < pr);
    if (!*transmitted) {
        *wi = vec3(-wo.x, -wo.y, wo.z);
        *f = fr / wo.z;
        *pdf = pr / total;
    } else {
        /* Snell in vector form: the tangential part scales by 1/eta. */
        *wi = vnormalize(vec3(-wo.x / eta, -wo.y / eta, -cosT));
        *f = (1.0f - fr) * (adjoint ? 1.0f : 1.0f / (eta * eta)) / cosT;
        *pdf = pt / total;
    }
    return isfinite(*f) && *pdf > 0.0f;
}

#if CB_HAS(CB_FEATURE_ROUGH_DIELECTRIC)
/* A rough dielectric (Walter et al. 2007, eqs. 15-21, with GGX, height-correlated G and Heitz's
 * visible normals, as pbrt-v4's DielectricBxDF): wo.z > 0, eta = n(other side) / n(wo's side).
 * Returns f (radiance, or importance when adjoint: transmitted radiance is divided by eta^2,
 * Veach 1997 sec. 5.2), *pdfFwd, the density of bsdfSample choosing wi (the visible-normal pdf
 * through the generalized half vector's Jacobian, times the Fresnel probability of the lobe),
 * and *pdfRev, that of choosing wo from wi: the same microfacet seen from wi's side, whose
 * Fresnel term is the same (Stokes) and whose Jacobian's denominator carries eta^2; *fresnel is
 * that Fresnel term (the probability of the reflection lobe). */
CB_FN real cbRoughDielectric(Vec3 wo, Vec3 wi, real eta, GgxAlpha alpha, int adjoint, real* pdfFwd,
                             real* pdfRev, real* fresnel) {
    *pdfFwd = 0.0f;
    *pdfRev = 0.0f;
    *fresnel = 0.0f;
    real cosO = wo.z, cosI = wi.z;
    if (!(cosO > 0.0f) || cosI == 0.0f) return 0.0f;
    bool reflect = cosI > 0.0f;
    Vec3 wm = vadd(vscale(wi, reflect ? 1.0f : eta), wo);
    real len2 = vlength2(wm);
    if (!(len2 > 0.0f)) return 0.0f;
    wm = vscale(wm, (wm.z < 0.0f ? -1.0f : 1.0f) / sqrt(len2));
    real dotOm = vdot(wo, wm), dotIm = vdot(wi, wm);
    /* Back-facing microfacets: each direction must lie on the side of wm its z says. */
    if (!(dotOm > 0.0f) || !(dotIm * cosI > 0.0f)) return 0.0f;
    real cosT;
    real fr = fresnelDielectric(dotOm, eta, &cosT);
    *fresnel = fr;
    real d = ggxD(wm, alpha);
    /* Visible-normal densities of wm from each side, G1(w) |w.wm| D / |w.z| (Heitz 2018, eq. 3). */
    real visibleO = ggxG1(wo, alpha) * dotOm * d / cosO;
    real visibleI = ggxG1(wi, alpha) * fabs(dotIm) * d / fabs(cosI);
    real dg = d * ggxG(wo, wi, alpha);
    real f, fwd, rev;
    if (reflect) {
        f = dg * fr / (4.0f * cosO * cosI);
        fwd = visibleO / (4.0f * dotOm) * fr;
        rev = visibleI / (4.0f * dotIm) * fr;
    } else {
        real denom = cbSqr(dotIm + dotOm / eta);
        f = (1.0f - fr) * dg * fabs(dotIm * dotOm / (cosI * cosO * denom));
        if (!adjoint) f /= eta * eta;
        fwd = visibleO * fabs(dotIm) / denom * (1.0f - fr);
        rev = visibleI * dotOm / (eta * eta * denom) * (1.0f - fr);
    }
    if (!isfinite(f) || !isfinite(fwd) || !(fwd > 0.0f)) return 0.0f;
    *pdfFwd = fwd;
    *pdfRev = isfinite(rev) ? rev : 0.0f;
    return f;
}

/* A direction from a rough dielectric's visible normals (wo.z > 0, eta as cbRoughDielectric's):
 * reflected about the sampled microfacet or refracted through it, Fresnel choosing by uLobe when
 * both lobes are allowed; false where the choice has no direction (total internal reflection,
 * a reflection below the surface or a refraction above it: masking). */
CB_FN bool cbRoughDielectricDirection(Vec3 wo, real eta, GgxAlpha alpha, real u0, real u1,
                                      real uLobe, int lobes, Vec3* wi, bool* through) {
    Vec3 wm = ggxSampleVisibleNormal(wo, alpha, u0, u1);
    real dotOm = vdot(wo, wm);
    real cosT;
    real fr = fresnelDielectric(dotOm, eta, &cosT);
    bool reflect = lobes == CB_LOBES_BOTH ? uLobe < fr : lobes == CB_LOBE_REFLECT;
    Vec3 w;
    if (reflect) {
        w = vsub(vscale(wm, 2.0f * dotOm), wo);
    } else {
        if (!(cosT > 0.0f)) return false;
        /* Snell about wm: the tangential part scales by 1/eta. */
        w = vsub(vscale(wm, dotOm / eta - cosT), vscale(wo, 1.0f / eta));
    }
    real len = vlength(w);
    if (!(len > 0.0f)) return false;
    w = vscale(w, 1.0f / len);
    if (reflect != (w.z > 0.0f)) return false;
    *wi = w;
    *through = !reflect;
    return true;
}
#endif

#if CB_HAS_LAYERED
/* ---- Layered materials (pbrt-v4's CoatedDiffuseBxDF and CoatedConductorBxDF) ----------------
 * A base under a dielectric coat of index eta, smooth (alpha 0) or GGX-rough (alpha >= 1e-3, as
 * the host stores it), both faces alike, with a layer between them of `thickness` mean free
 * paths that absorbs (exp(-thickness / |cos|) per crossing; pbrt-v4's default albedo 0) or also
 * scatters, by a Henyey-Greenstein phase function. The base is Lambertian (coated diffuse) or a
 * conductor, smooth or GGX-rough (coated conductor). Light refracts in through the coat, bounces
 * between base and coat (scattering in the layer between) and refracts out. pbrt-v4's
 * LayeredBxDF estimates f by a random walk with next-event estimation through the exit, samples
 * directions by the walk itself (Guo et al. 2018, "Position-free Monte Carlo simulation for
 * arbitrary layered BSDFs"; pbrt-v4 sec. 14.3) and gives MIS a pdf estimate mixed with the uniform
 * sphere's; these are the same estimators for these pairs of layers. */

/* The walk's random numbers: a counter hashed under a key made from its arguments, so that an
 * estimate is a deterministic function of them, as pbrt-v4 seeds its RNG with Hash(wo), Hash(wi):
 * the two strategies of MIS then see the same pdf for the same directions. */
typedef struct LayerRng {
    uint key;
    uint count;
} LayerRng;

CB_FN uint layerHashDirection(uint seed, Vec3 w) {
    return cbHashCombine(cbHashCombine(cbHashCombine(seed, cbFloatBits(w.x)), cbFloatBits(w.y)),
                         cbFloatBits(w.z));
}

CB_FN real layerRngNext(LayerRng* rng) {
    rng->count += 1u;
    return cbUintToUnitFloat(cbHashCombine(rng->key, rng->count));
}

/* Transmittance of the layer along a direction of cosine cosTheta (pbrt-v4's LayeredBxDF::Tr). */
CB_FN real layerTransmittance(real thickness, real cosTheta) {
    return thickness > 1.17549435e-38f ? exp(-thickness / fabs(cosTheta)) : 1.0f;
}

/* The rough coat's f and its pdf restricted to `lobes` (DielectricBxDF::f and PDF), wo from
 * either side; 0 for a smooth coat, whose lobes are deltas. */
CB_FN real coatEval(Vec3 wo, Vec3 wi, real eta, real alpha, int lobes, int adjoint, real* pdf) {
    *pdf = 0.0f;
#if CB_HAS(CB_FEATURE_ROUGH_DIELECTRIC)
    if (alpha > 0.0f) {
        real flip = wo.z > 0.0f ? 1.0f : -1.0f;
        real etap = wo.z > 0.0f ? eta : 1.0f / eta;
        Vec3 lo = vec3(wo.x, wo.y, wo.z * flip), li = vec3(wi.x, wi.y, wi.z * flip);
        real fwd, rev, fr;
        real value = cbRoughDielectric(lo, li, etap, ggxIsotropic(alpha), adjoint, &fwd, &rev, &fr);
        bool through = li.z < 0.0f;
        real lobe = through ? 1.0f - fr : fr;
        real allowedR = (lobes & CB_LOBE_REFLECT) ? fr : 0.0f;
        real allowedT = (lobes & CB_LOBE_TRANSMIT) ? 1.0f - fr : 0.0f;
        if (!(value > 0.0f) || !(lobe > 0.0f) ||
            !(lobes & (through ? CB_LOBE_TRANSMIT : CB_LOBE_REFLECT)))
            return 0.0f;
        *pdf = fwd / (allowedR + allowedT);
        return value;
    }
#endif
    (void)wo;
    (void)wi;
    (void)eta;
    (void)alpha;
    (void)lobes;
    (void)adjoint;
    return 0.0f;
}

/* One scattering at the coat, pbrt-v4's DielectricBxDF::Sample_f restricted to `lobes`, from w's
 * side (w.z > 0: outside, relative index eta; below: 1 / eta): *wi, f (without the cosine; a
 * smooth coat's delta as f |cos| = its lobe's weight), pdf (a delta's: its lobe's probability
 * among those allowed) and whether it went through. Transmitted radiance is divided by the index
 * ratio squared, importance is not (Veach 1997, sec. 5.2). */
CB_FN bool coatSample(Vec3 w, real eta, real alpha, int lobes, real uc, real u0, real u1,
                      int adjoint, Vec3* wi, real* f, real* pdf, bool* transmitted) {
    real flip = w.z > 0.0f ? 1.0f : -1.0f;
    real etap = w.z > 0.0f ? eta : 1.0f / eta;
    Vec3 wo = vec3(w.x, w.y, fabs(w.z));
    Vec3 out;
    real value, density;
    bool through;
#if CB_HAS(CB_FEATURE_ROUGH_DIELECTRIC)
    if (alpha > 0.0f) {
        /* With both lobes allowed Fresnel chooses as the full interface does; with one, that one.
         */
        if (!cbRoughDielectricDirection(wo, etap, ggxIsotropic(alpha), u0, u1, uc, lobes, &out,
                                        &through) ||
            out.z == 0.0f)
            return false;
        /* f and the pdf from the half vector of (wo, out), as coatEval computes them. */
        value = coatEval(wo, out, etap, alpha, lobes, adjoint, &density);
    } else
#endif
    {
        (void)u0;
        (void)u1;
        (void)alpha;
        if (!smoothDielectricSample(wo, etap, lobes, uc, adjoint, &out, &value, &density, &through))
            return false;
    }
    *wi = vec3(out.x, out.y, out.z * flip);
    *f = value;
    *pdf = density;
    *transmitted = through;
    return isfinite(value) && value > 0.0f && density > 0.0f;
}

/* What lies under the coat, its spectra read once per estimate: the base, a Lambertian
 * reflectance rho or a conductor's complex index eta + i k relative to the coat's (pbrt-v4
 * divides both by the coat's eta; a "reflectance" r, clamped to [0, 0.9999], is eta 1,
 * k 2 sqrt(r) / sqrt(1 - r), whose Fresnel reflectance at normal incidence is r: pbrt-v4's
 * CoatedConductorMaterial), and the layer's single-scattering albedo where it scatters. */
typedef struct LayerBase {
    Spectrum a, b; /* rho; or eta and k */
    real alpha;    /* a conductor's GGX alpha, 0 for a smooth one (a delta) */
    int conductor;
    Spectrum albedo;
    int scatters;
} LayerBase;

CB_FN LayerBase layerBaseLoad(const SceneView* scene, Material m, TexCoord uv) {
    LayerBase base;
    base.a = materialReflectance(scene, m, uv);
    base.b = base.a;
    base.alpha = 0.0f;
    base.conductor = 0;
    base.scatters = m.layerAlbedo >= 0;
    base.albedo = base.scatters ? specLoad(scene->spectra, m.layerAlbedo) : specZero();
#if CB_HAS(CB_FEATURE_COATED_CONDUCTOR)
    if (m.kind == CB_MAT_COATED_CONDUCTOR) {
        base.conductor = 1;
        base.alpha = m.baseAlpha;
        if (m.secondSpectrum >= 0) base.b = specLoad(scene->spectra, m.secondSpectrum);
        for (int c = 0; c < CB_CHANNELS; ++c) {
            if (m.secondSpectrum < 0) {
                real r = cbClamp(base.a.c[c], 0.0f, 0.9999f);
                base.a.c[c] = 1.0f;
                base.b.c[c] = 2.0f * sqrt(r) / sqrt(1.0f - r);
            }
            base.a.c[c] /= m.eta;
            base.b.c[c] /= m.eta;
        }
    }
#endif
    return base;
}

CB_FN bool layerBaseIsDelta(LayerBase base) {
    return base.conductor && base.alpha == 0.0f;
}

#if CB_HAS(CB_FEATURE_COATED_CONDUCTOR)
CB_FN Spectrum layerBaseFresnel(LayerBase base, real cosH) {
    Spectrum f;
    for (int c = 0; c < CB_CHANNELS; ++c)
        f.c[c] = fresnelConductor(cosH, base.a.c[c], base.b.c[c]);
    return f;
}
#endif

/* The base's f (without the cosine) for wo, wi above it, and the density of layerBaseSample
 * choosing wi; 0 for a smooth conductor, whose reflection is a delta. */
CB_FN Spectrum layerBaseEval(LayerBase base, Vec3 wo, Vec3 wi, real* pdf) {
    *pdf = 0.0f;
    if (!(wi.z > 0.0f)) return specZero();
#if CB_HAS(CB_FEATURE_COATED_CONDUCTOR)
    if (base.conductor) {
        Vec3 h = vadd(wo, wi);
        real len = vlength(h);
        if (base.alpha == 0.0f || !(len > 0.0f)) return specZero();
        Vec3 wm = vscale(h, 1.0f / len);
        real rev;
        real value = cbGgxReflection(wo, wi, wm, ggxIsotropic(base.alpha), pdf, &rev);
        return specScale(layerBaseFresnel(base, vdot(wo, wm)), value);
    }
#endif
    (void)wo;
    *pdf = cosineHemispherePdf(wi.z);
    return specScale(base.a, CB_INV_PI);
}

/* A direction *wi from the base for wo above it, with f (without the cosine; a smooth
 * conductor's delta as f |cos| = its Fresnel reflectance) and the density (the delta's: 1). */
CB_FN bool layerBaseSample(LayerBase base, Vec3 wo, real u0, real u1, Vec3* wi, Spectrum* f,
                           real* pdf) {
#if CB_HAS(CB_FEATURE_COATED_CONDUCTOR)
    if (base.conductor) {
        if (!(wo.z > 0.0f)) return false;
        if (base.alpha == 0.0f) {
            *wi = vec3(-wo.x, -wo.y, wo.z);
            *f = specScale(layerBaseFresnel(base, wo.z), 1.0f / wo.z);
            *pdf = 1.0f;
            return true;
        }
        Vec3 wm;
        real value, rev;
        if (!cbGgxReflectionSample(wo, ggxIsotropic(base.alpha), u0, u1, wi, &wm, &value, pdf,
                                   &rev))
            return false;
        *f = specScale(layerBaseFresnel(base, vdot(wo, wm)), value);
        return true;
    }
#endif
    (void)wo;
    *wi = sampleCosineHemisphere(u0, u1);
    *f = specScale(base.a, CB_INV_PI);
    *pdf = cosineHemispherePdf(wi->z);
    return wi->z > 0.0f;
}

/* A free flight in the layer (extinction 1 per unit of thickness) from height z along w: where
 * it scatters, or, where that is beyond the layer, the interface it reaches (0 the base,
 * thickness the coat), with the probability of getting there. */
CB_FN real layerFlight(real z, Vec3 w, real thickness, real u) {
    real dz = -log(1.0f - u) * fabs(w.z);
    real next = w.z > 0.0f ? z + dz : z - dz;
    return cbClamp(next, 0.0f, thickness);
}

#if CB_HAS(CB_FEATURE_COATED_CONDUCTOR)
/* Between a smooth coat and a smooth conductor, the light scattered at height z toward the exit's
 * sample (inside, direction exit) reaches it straight up, or down over the mirror; either way it
 * may go round again, reflected by the coat (R, from inside) and the base (F), tau^2 per round,
 * as often as the walk's depth allows after step `depth` (one step per interface; the step to
 * the exit free, as for every next-event estimate of pbrt-v4's f). Returns the phase function
 * times the transmittance to the exit, summed over these delta chains, which the walk's
 * sampling takes but pbrt-v4's f, looking only straight up, leaves out. */
CB_FN Spectrum layerMirrorChains(LayerBase base, Material m, Vec3 w, Vec3 exit, real z, int depth) {
    real mu = fabs(exit.z), cosT;
    real rIn = fresnelDielectric(mu, 1.0f / m.eta, &cosT);
    real tau = exp(-m.thickness / mu);
    Spectrum fBase = layerBaseFresnel(base, mu);
    Vec3 up = vneg(exit), down = vec3(-exit.x, -exit.y, exit.z);
    int upRounds = (m.layerDepth - depth + 1) / 2, downRounds = (m.layerDepth - depth) / 2;
    real viaUp = phaseHenyeyGreenstein(vdot(w, up), m.layerG) * exp(-(m.thickness - z) / mu);
    real viaDown = phaseHenyeyGreenstein(vdot(w, down), m.layerG) * exp(-z / mu) * tau;
    Spectrum out;
    for (int c = 0; c < CB_CHANNELS; ++c) {
        real q = rIn * fBase.c[c] * tau * tau; /* one round: coat, base, both ways through */
        real sumUp = q < 1.0f ? (1.0f - pow(q, (real)upRounds)) / (1.0f - q) : (real)upRounds;
        real sumDown = q < 1.0f ? (1.0f - pow(q, (real)downRounds)) / (1.0f - q) : (real)downRounds;
        out.c[c] = viaUp * sumUp + viaDown * fBase.c[c] * sumDown;
    }
    return out;
}
#endif

/* The two refractions that begin a walk through the coat: the way in from wo (transported as
 * `adjoint`; false where it has none) and the exit's way out toward wi, sampled from wi as the
 * adjoint transport (hasExit false where that has none, as under total internal reflection at
 * the sampled microfacet). */
typedef struct CoatCrossings {
    Vec3 in, exit;
    real fIn, pIn, fExit, pExit;
    bool hasExit;
} CoatCrossings;

CB_FN bool coatCrossings(Material m, Vec3 wo, Vec3 wi, int adjoint, LayerRng* rng,
                         CoatCrossings* c) {
    real a0 = layerRngNext(rng), a1 = layerRngNext(rng), a2 = layerRngNext(rng);
    real b0 = layerRngNext(rng), b1 = layerRngNext(rng), b2 = layerRngNext(rng);
    bool through;
    c->exit = vec3(0.0f, 0.0f, 1.0f);
    c->fExit = 0.0f;
    c->pExit = 0.0f;
    c->hasExit = coatSample(wi, m.eta, m.alpha, CB_LOBE_TRANSMIT, b0, b1, b2, !adjoint, &c->exit,
                            &c->fExit, &c->pExit, &through);
    return coatSample(wo, m.eta, m.alpha, CB_LOBE_TRANSMIT, a0, a1, a2, adjoint, &c->in, &c->fIn,
                      &c->pIn, &through);
}

/* Through a rough coat from inside along w (w.z > 0) straight out to wi: the coat's f, and in
 * *pExit the density with which the exit's sample, drawn from wi, reaches the layer along w,
 * which is what the walk's own way out is weighed against. (pbrt-v4 weighs it with the density
 * of sampling wi from -w instead; with that weight f and the walk's sampling disagree, by 7% in
 * albedo at alpha 0.3.) */
CB_FN real layerWayOut(Material m, Vec3 w, Vec3 wi, int adjoint, real* pExit) {
    real unused;
    coatEval(wi, vneg(w), m.eta, m.alpha, CB_LOBE_TRANSMIT, !adjoint, pExit);
    return coatEval(vneg(w), wi, m.eta, m.alpha, CB_LOBE_TRANSMIT, adjoint, &unused);
}

/* pbrt-v4's pdf estimate (LayeredBxDF::PDF): the coat's own reflection, plus reflection into wi
 * through coat, base and coat, estimated from one walk per layerSamples (for a smooth coat
 * exactly the base's density between the refracted directions), mixed 0.9 : 0.1 with the
 * uniform sphere's density. Both flipped if wo.z < 0. Only for wi on wo's side: the base
 * transmits nothing, and cbLobeEval gives transmission neither f nor pdf. */
CB_FN real layeredPdf(LayerBase base, Material m, Vec3 wo, Vec3 wi) {
    if (wo.z < 0.0f) {
        wo = vneg(wo);
        wi = vneg(wi);
    }
    real sum = 0.0f;
    if (wi.z > 0.0f) {
        real pdfTop;
        coatEval(wo, wi, m.eta, m.alpha, CB_LOBE_REFLECT, 0, &pdfTop);
        sum = (real)m.layerSamples * pdfTop;
        LayerRng rng;
        rng.key = layerHashDirection(layerHashDirection(0xcc9e2d51u, wi), wo);
        rng.count = 0u;
        for (int sample = 0; sample < m.layerSamples; ++sample) {
            CoatCrossings c;
            /* As in layeredEval, a rough coat's walk without the exit's sample keeps its way out
             * from the base's sample. */
            if (!coatCrossings(m, wo, wi, 0, &rng, &c) || (!c.hasExit && m.alpha == 0.0f)) continue;
            real rPdf = 0.0f;
            if (c.hasExit) layerBaseEval(base, vneg(c.in), vneg(c.exit), &rPdf);
            if (m.alpha == 0.0f) {
                sum += rPdf;
            } else {
                /* MIS between the base's density toward the exit's sample and the coat's
                 * density of leaving toward wi after a base sample (the latter alone after a
                 * smooth conductor's delta), weighed as layeredEval weighs them. */
                bool baseDelta = layerBaseIsDelta(base);
                if (!baseDelta) sum += powerHeuristic(c.pExit, rPdf) * rPdf;
                real u0 = layerRngNext(&rng), u1 = layerRngNext(&rng);
                Vec3 up;
                Spectrum fBase;
                real upPdf, tPdf, pOut;
                if (!layerBaseSample(base, vneg(c.in), u0, u1, &up, &fBase, &upPdf)) continue;
                coatEval(vneg(up), wi, m.eta, m.alpha, CB_LOBES_BOTH, 0, &tPdf);
                coatEval(wi, vneg(up), m.eta, m.alpha, CB_LOBE_TRANSMIT, 1, &pOut);
                sum += baseDelta ? tPdf : powerHeuristic(upPdf, pOut) * tPdf;
            }
        }
    }
    return 0.1f * (0.25f * CB_INV_PI) + 0.9f * sum / (real)m.layerSamples;
}

/* f(wo, wi) estimated by layerSamples random walks (LayeredBxDF::f), wo.z > 0: the rough coat's
 * own reflection, then walks that enter at wo and, at each visit of the base, look toward the
 * exit's sampled way out to wi (and, through a rough coat, also toward wi from the base's
 * sample, the two combined by the power heuristic). The exit is sampled as the adjoint, so f for
 * radiance equals f(wi, wo) for importance. */
CB_FN Spectrum layeredEval(LayerBase base, Material m, Vec3 wo, Vec3 wi, int adjoint) {
    if (!(wi.z > 0.0f)) return specZero();
    real pdfTop;
    real top = coatEval(wo, wi, m.eta, m.alpha, CB_LOBES_BOTH, adjoint, &pdfTop);
    Spectrum f = specConst(top * (real)m.layerSamples);
    bool rough = m.alpha > 0.0f, baseDelta = layerBaseIsDelta(base);
    LayerRng rng;
    rng.key = layerHashDirection(layerHashDirection(0x1b873593u, wo), wi);
    rng.count = 0u;
    for (int sample = 0; sample < m.layerSamples; ++sample) {
        CoatCrossings c;
        /* Without a way out a smooth coat's walk has nothing to add. */
        if (!coatCrossings(m, wo, wi, adjoint, &rng, &c) || (!c.hasExit && !rough)) continue;
        Vec3 w = c.in, exit = c.exit;
        real pExit = c.pExit;
        bool t;
        /* What the exit's sample carries back out to wi: its f |cos| / pdf and the layer. Where
         * it has none the walk goes on without it, its paths to wi left to the base's samples
         * through a rough coat (pbrt-v4 drops the walk, which loses those paths). */
        real exitWeight =
            c.hasExit ? c.fExit * fabs(exit.z) / pExit * layerTransmittance(m.thickness, exit.z)
                      : 0.0f;
        Spectrum beta = specConst(c.fIn * fabs(w.z) / c.pIn);
        bool atTop = true;
        real z = m.thickness; /* the walk's height: the coat at thickness, the base at 0 */
        for (int depth = 0; depth < m.layerDepth; ++depth) {
            /* pbrt-v4's Russian roulette of the walk. */
            real largest = specMaxComponent(beta);
            if (depth > 3 && largest < 0.25f) {
                real q = fmax(0.0f, 1.0f - largest);
                if (layerRngNext(&rng) < q) break;
                beta = specScale(beta, 1.0f / (1.0f - q));
            }
            if (base.scatters) {
                real next = layerFlight(z, w, m.thickness, layerRngNext(&rng));
                if (next == z) continue;
                if (next > 0.0f && next < m.thickness) {
                    /* Scattered in the layer: next-event estimation through the exit's sample
                     * (pbrt-v4), then the phase function's direction and, through a rough coat,
                     * from it straight out to wi, weighed against the exit's sample as from
                     * the base. */
                    real pPhase;
                    if (c.hasExit) {
                        real pNee = phaseHenyeyGreenstein(vdot(w, vneg(exit)), m.layerG);
                        real nee = rough ? powerHeuristic(pExit, pNee) : 1.0f;
                        real mu = fabs(exit.z);
                        Spectrum toExit = specConst(pNee * nee * exp(-(m.thickness - next) / mu));
#if CB_HAS(CB_FEATURE_COATED_CONDUCTOR)
                        if (!rough && baseDelta)
                            toExit = layerMirrorChains(base, m, w, exit, next, depth);
#endif
                        f = specAdd(f, specScale(specMul(specMul(beta, base.albedo), toExit),
                                                 c.fExit / pExit));
                    }
                    real u0 = layerRngNext(&rng), u1 = layerRngNext(&rng);
                    w = phaseHenyeyGreensteinSample(w, m.layerG, u0, u1, &pPhase);
                    beta = specMul(beta, base.albedo); /* p / pdf = 1 */
                    z = next;
                    if (rough && w.z > 0.0f) {
                        real pOut;
                        real out = layerWayOut(m, w, wi, adjoint, &pOut);
                        if (out > 0.0f)
                            f = specAdd(f, specScale(beta, exp(-(m.thickness - z) / w.z) * out *
                                                               powerHeuristic(pPhase, pOut)));
                    }
                    continue;
                }
                /* Through the layer to an interface, with the probability of getting there. */
                z = next;
                atTop = z == m.thickness;
            } else {
                atTop = !atTop;
                beta = specScale(beta, layerTransmittance(m.thickness, w.z));
            }
            if (atTop) {
                /* Back at the coat from inside: only its reflection keeps the walk inside. */
                Vec3 next;
                real fr, pr;
                real c0 = layerRngNext(&rng), c1 = layerRngNext(&rng), c2 = layerRngNext(&rng);
                if (!coatSample(vneg(w), m.eta, m.alpha, CB_LOBE_REFLECT, c0, c1, c2, adjoint,
                                &next, &fr, &pr, &t))
                    break;
                beta = specScale(beta, fr * fabs(next.z) / pr);
                w = next;
            } else {
                /* Next-event estimation from the base through the exit's sample. */
                if (c.hasExit && !baseDelta) {
                    real pBase;
                    Spectrum fBase = layerBaseEval(base, vneg(w), vneg(exit), &pBase);
                    real nee = rough ? powerHeuristic(pExit, pBase) : 1.0f;
                    f = specAdd(f, specScale(specMul(beta, fBase), exitWeight * nee));
                }
                Vec3 up;
                Spectrum fBase;
                real pBase;
                real u0 = layerRngNext(&rng), u1 = layerRngNext(&rng);
                if (!layerBaseSample(base, vneg(w), u0, u1, &up, &fBase, &pBase)) break;
                w = up;
                beta = specMul(beta, specScale(fBase, w.z / pBase));
                if (rough) {
                    /* ... and through the coat from the base's sample straight to wi, weighed
                     * against the exit's sample (layerWayOut). After a smooth conductor's delta
                     * this is the only way out. */
                    real pOut;
                    real out = layerWayOut(m, w, wi, adjoint, &pOut);
                    real weight = baseDelta ? 1.0f : powerHeuristic(pBase, pOut);
                    if (out > 0.0f)
                        f = specAdd(f, specScale(beta, layerTransmittance(m.thickness, w.z) * out *
                                                           weight));
                }
            }
        }
    }
    return specScale(f, 1.0f / (real)m.layerSamples);
}

/* A direction by the walk itself (LayeredBxDF::Sample_f), wo.z > 0: the coat reflects (a delta
 * for a smooth coat) or the walk refracts in and bounces between base and coat until it leaves,
 * its weight f |cos| / pdf exact. A non-delta sample then carries the pdf estimate of
 * layeredPdf, f scaled so that the weight is kept. */
CB_FN bool layeredSample(LayerBase base, Material m, Vec3 wo, real u0, real u1, real uLobe,
                         int adjoint, BsdfSample* out) {
    Vec3 w;
    real fFirst, pdf;
    bool through;
    if (!coatSample(wo, m.eta, m.alpha, CB_LOBES_BOTH, uLobe, u0, u1, adjoint, &w, &fFirst, &pdf,
                    &through))
        return false;
    Spectrum f = specConst(fFirst);
    if (!through) {
        out->wi = w;
        out->isDelta = m.alpha == 0.0f;
        if (out->isDelta) {
            out->f = f;
            out->pdf = pdf;
            out->pdfRev = pdf; /* the same angle on the same side */
            return true;
        }
    } else {
        f = specScale(f, fabs(w.z));
        LayerRng rng;
        rng.key = cbHashCombine(
            cbHashCombine(cbHashCombine(layerHashDirection(0x85ebca6bu, wo), cbFloatBits(uLobe)),
                          cbFloatBits(u0)),
            cbFloatBits(u1));
        rng.count = 0u;
        bool atTop = true, left = false;
        /* Only a walk through smooth layers that never scatters leaves in a delta. */
        bool specular = m.alpha == 0.0f && layerBaseIsDelta(base);
        real z = m.thickness;
        for (int depth = 0; depth < m.layerDepth && !left; ++depth) {
            real rrWeight = specMaxComponent(f) / pdf;
            if (depth > 3 && rrWeight < 0.25f) {
                real q = fmax(0.0f, 1.0f - rrWeight);
                if (layerRngNext(&rng) < q) return false;
                pdf *= 1.0f - q;
            }
            if (w.z == 0.0f) return false;
            if (base.scatters) {
                real next = layerFlight(z, w, m.thickness, layerRngNext(&rng));
                if (next == z) return false;
                if (next > 0.0f && next < m.thickness) {
                    real pPhase;
                    real p0 = layerRngNext(&rng), p1 = layerRngNext(&rng);
                    w = phaseHenyeyGreensteinSample(w, m.layerG, p0, p1, &pPhase);
                    f = specScale(specMul(f, base.albedo), pPhase);
                    pdf *= pPhase;
                    specular = false;
                    z = next;
                    continue;
                }
                z = next;
                atTop = z == m.thickness;
            } else {
                atTop = !atTop;
                f = specScale(f, layerTransmittance(m.thickness, w.z));
            }
            if (!atTop) {
                real v0 = layerRngNext(&rng), v1 = layerRngNext(&rng);
                Vec3 up;
                Spectrum fBase;
                real pBase;
                if (!layerBaseSample(base, vneg(w), v0, v1, &up, &fBase, &pBase)) return false;
                /* f and pdf of the base, then the cosine of the new direction. */
                f = specMul(f, specScale(fBase, up.z));
                pdf *= pBase;
                w = up;
            } else {
                /* At the coat from inside: reflection or the way out. */
                Vec3 next;
                real fc, pc;
                real c0 = layerRngNext(&rng), c1 = layerRngNext(&rng), c2 = layerRngNext(&rng);
                if (!coatSample(vneg(w), m.eta, m.alpha, CB_LOBES_BOTH, c0, c1, c2, adjoint, &next,
                                &fc, &pc, &left))
                    return false;
                f = specScale(f, left ? fc : fc * fabs(next.z));
                pdf *= pc;
                w = next;
            }
        }
        if (!left) return false;
        out->wi = w;
        if (specular) {
            /* Smooth coat over a smooth conductor: every way out is the mirror direction, a
             * delta whose weight is the walk's (its reverse choice taken as equally likely). */
            out->isDelta = 1;
            out->f = f;
            out->pdf = pdf;
            out->pdfRev = pdf;
            return specIsFinite(f) && pdf > 0.0f && w.z > 0.0f;
        }
    }
    /* A non-delta sample, reflected by a rough coat or out of the walk: pbrt-v4's integrators
     * weigh it by the pdf estimate (pdfIsProportional), keeping f |cos| / pdf. */
    real pdfEstimate = layeredPdf(base, m, wo, out->wi);
    out->isDelta = 0;
    out->f = specScale(f, pdfEstimate / pdf);
    out->pdf = pdfEstimate;
    out->pdfRev = layeredPdf(base, m, out->wi, wo);
    return specIsFinite(out->f) && pdf > 0.0f && out->wi.z > 0.0f;
}
#endif

#if CB_HAS(CB_FEATURE_HAIR)
/* ---- Hair (Chiang, Bitterli, Tappan and Burley 2016; pbrt-v3 sec. 9.9, pbrt-v4's HairBxDF) ----
 *
 * In the hair's frame x runs along the fibre (the surface's dp/du), so sin(theta) = w.x and phi =
 * atan2(w.z, w.y); h in [-1, 1] is where across the fibre the ray hit it (pbrt-v4: -1 + 2 v).
 * Scattering sums the lobes p = 0 (R), 1 (TT), 2 (TRT) and the rest (p = 3), each a longitudinal
 * Mp times an attenuation Ap times an azimuthal Np. Like pbrt's, f(wo, wi) takes gamma_t and Ap
 * from wo's angle only, so it is not reciprocal: the adjoint is f(wi, wo) (hairLobeEval). */
#define CB_HAIR_PMAX 3

/* The modified Bessel function of the first kind, I0(x) = sum (x^2 / 4)^i / (i!)^2 (pbrt-v3 eq.
 * 9.43's), and its logarithm for x > 12, where I0 nears float's range: x - log(2 pi x) / 2 + log(1
 * + 1 / (8x) + 9 / (128 x^2) + 225 / (3072 x^3)) (Abramowitz & Stegun 9.7.1). pbrt's ten terms and
 * one-term asymptote are off by up to 2% and 0.5% near x = 12 (where R lands at beta_m 0.3);
 * these keep Mp the normalised density that hairSample draws. */
CB_FN real hairI0(real x) {
    real sum = 1.0f, term = 1.0f, q = 0.25f * x * x;
    for (int i = 1; i < 40 && term > 1e-9f * sum; ++i) {
        term *= q / (real)(i * i);
        sum += term;
    }
    return sum;
}
CB_FN real hairLogI0(real x) {
    if (x <= 12.0f) return log(hairI0(x));
    real r = 1.0f / x;
    return x - 0.5f * log(2.0f * CB_PI * x) +
           log(1.0f + r * (0.125f + r * (0.0703125f + r * 0.0732421875f)));
}

/* Longitudinal scattering of variance v (d'Eon et al. 2011, pbrt-v3 eq. 9.43); its log form for
 * small v, where sinh(1 / v) and I0 overflow. Normalised: the integral of Mp cos(theta_i) over
 * theta_i is 1. */
CB_FN real hairMp(real cosI, real cosO, real sinI, real sinO, real v) {
    real a = cosI * cosO / v, b = sinI * sinO / v;
    if (v <= 0.1f) return exp(hairLogI0(a) - b - 1.0f / v + 0.69314718f + log(1.0f / (2.0f * v)));
    return exp(-b) * hairI0(a) / (sinh(1.0f / v) * 2.0f * v);
}

/* The logistic distribution of scale s restricted to [-pi, pi] (pbrt-v3 eq. 9.48), and its
 * inverse-CDF sample at u. */
CB_FN real hairLogistic(real x, real s) {
    x = fabs(x);
    real e = exp(-x / s);
    return e / (s * cbSqr(1.0f + e));
}
CB_FN real hairLogisticCdf(real x, real s) {
    return 1.0f / (1.0f + exp(-x / s));
}
CB_FN real hairTrimmedLogistic(real x, real s) {
    return hairLogistic(x, s) / (hairLogisticCdf(CB_PI, s) - hairLogisticCdf(-CB_PI, s));
}
CB_FN real hairSampleTrimmedLogistic(real u, real s) {
    real k = hairLogisticCdf(CB_PI, s) - hairLogisticCdf(-CB_PI, s);
    real x = -s * log(1.0f / (u * k + hairLogisticCdf(-CB_PI, s)) - 1.0f);
    return cbClamp(x, -CB_PI, CB_PI);
}

/* What one direction w (as wo) fixes for every lobe: its longitudinal angle, the refracted ray's
 * azimuth gamma_t inside the fibre, and the lobes' attenuations Ap (pbrt-v3 eqs. 9.40-9.42: the
 * Fresnel factor at cos(theta) cos(gamma_o), the transmittance exp(-sigma_a 2 cos(gamma_t) /
 * cos(theta_t)) of one pass, the rest p >= 3 summed as a geometric series) with the shares of
 * their channel means by which a lobe is sampled. */
typedef struct HairFrom {
    real sinO, cosO, phiO;
    real gammaO, gammaT;
    Spectrum ap[CB_HAIR_PMAX + 1];
    real apPdf[CB_HAIR_PMAX + 1];
} HairFrom;

CB_FN HairFrom hairFrom(Material m, Spectrum sigmaA, real h, Vec3 w) {
    HairFrom o;
    o.sinO = cbClamp(w.x, -1.0f, 1.0f);
    o.cosO = cbSafeSqrt(1.0f - o.sinO * o.sinO);
    o.phiO = atan2(w.z, w.y);
    o.gammaO = asin(cbClamp(h, -1.0f, 1.0f));
    real sinT = o.sinO / m.eta;
    real cosT = cbSafeSqrt(1.0f - sinT * sinT);
    /* The modified index for the azimuthal refraction (Bravais; pbrt-v3 eq. 9.37). */
    real etap = o.cosO > 0.0f ? cbSafeSqrt(m.eta * m.eta - o.sinO * o.sinO) / o.cosO : CB_INFINITY;
    real sinGammaT = cbClamp(h / etap, -1.0f, 1.0f);
    real cosGammaT = cbSafeSqrt(1.0f - sinGammaT * sinGammaT);
    o.gammaT = asin(sinGammaT);
    real length = 2.0f * cosGammaT / cosT;
    real cosTheta;
    real f = fresnelDielectric(o.cosO * cbSafeSqrt(1.0f - h * h), m.eta, &cosTheta);
    real sum = 0.0f;
    for (int c = 0; c < CB_CHANNELS; ++c) {
        /* A clear channel transmits all even where the path is infinite (cos theta_t = 0). */
        real t = sigmaA.c[c] > 0.0f ? exp(-sigmaA.c[c] * length) : 1.0f;
        o.ap[0].c[c] = f;
        o.ap[1].c[c] = cbSqr(1.0f - f) * t;
        o.ap[2].c[c] = o.ap[1].c[c] * t * f;
        o.ap[3].c[c] = 1.0f - t * f > 0.0f ? o.ap[2].c[c] * f * t / (1.0f - t * f) : 0.0f;
    }
    for (int p = 0; p <= CB_HAIR_PMAX; ++p) {
        o.apPdf[p] = specAverage(o.ap[p]);
        sum += o.apPdf[p];
    }
    for (int p = 0; p <= CB_HAIR_PMAX; ++p)
        o.apPdf[p] = sum > 0.0f ? o.apPdf[p] / sum : 0.0f;
    return o;
}

/* Lobe p's longitudinal variance and wo's angle tilted by the cuticle's scales: R by -2 alpha,
 * TT by alpha, TRT by 4 alpha (pbrt-v3 sec. 9.9.5), cos kept positive as pbrt does. */
CB_FN real hairLobeTilt(Material m, int p, real sinO, real cosO, real* sinP, real* cosP) {
    real s1 = m.hairSinAlpha, c1 = m.hairCosAlpha;
    real s2 = 2.0f * c1 * s1, c2 = c1 * c1 - s1 * s1;
    real s4 = 2.0f * c2 * s2, c4 = c2 * c2 - s2 * s2;
    real s = p == 0 ? -s2 : p == 1 ? s1 : p == 2 ? s4 : 0.0f;
    real c = p == 0 ? c2 : p == 1 ? c1 : p == 2 ? c4 : 1.0f;
    *sinP = sinO * c + cosO * s;
    *cosP = fabs(cosO * c - sinO * s);
    return p == 0 ? m.hairV : p == 1 ? 0.25f * m.hairV : 4.0f * m.hairV;
}

/* pbrt-v3 eq. 9.45: the azimuthal deflection of lobe p. */
CB_FN real hairPhi(int p, real gammaO, real gammaT) {
    return 2.0f * (real)p * gammaT - 2.0f * gammaO + (real)p * CB_PI;
}

/* f(wo, wi) of pbrt-v4's HairBxDF::f, in the unflipped hair frame, with *pdf the density of
 * hairSample's directions wi from wo (HairBxDF::PDF): the same lobes with Ap replaced by its
 * sampling shares. */
CB_FN Spectrum hairEvalFrom(Material m, const HairFrom* o, Vec3 wi, real* pdf) {
    real sinI = cbClamp(wi.x, -1.0f, 1.0f);
    real cosI = cbSafeSqrt(1.0f - sinI * sinI);
    real phi = atan2(wi.z, wi.y) - o->phiO;
    Spectrum f = specZero();
    *pdf = 0.0f;
    for (int p = 0; p < CB_HAIR_PMAX; ++p) {
        real sinP, cosP;
        real v = hairLobeTilt(m, p, o->sinO, o->cosO, &sinP, &cosP);
        real dphi = phi - hairPhi(p, o->gammaO, o->gammaT);
        dphi -= 2.0f * CB_PI * floor((dphi + CB_PI) * CB_INV_2PI); /* into [-pi, pi) */
        real lobe = hairMp(cosI, cosP, sinI, sinP, v) * hairTrimmedLogistic(dphi, m.hairS);
        f = specMadd(f, o->ap[p], lobe);
        *pdf += o->apPdf[p] * lobe;
    }
    real rest = hairMp(cosI, o->cosO, sinI, o->sinO, 4.0f * m.hairV) * CB_INV_2PI;
    f = specMadd(f, o->ap[CB_HAIR_PMAX], rest);
    *pdf += o->apPdf[CB_HAIR_PMAX] * rest;
    /* pbrt's convention: f |cos theta_i| (the surface's normal, z) is the fibre's scattering. */
    return fabs(wi.z) > 0.0f ? specScale(f, 1.0f / fabs(wi.z)) : specZero();
}

/* Where across the fibre a hit at uv lies (pbrt-v4's HairMaterial::GetBxDF: h = -1 + 2 v). */
CB_FN real hairOffset(TexCoord uv) {
    return cbClamp(-1.0f + 2.0f * uv.v, -1.0f, 1.0f);
}

/* The hair lobe between unflipped local wo and wi: f, and the pdfs of sampling wi from wo and wo
 * from wi with hairSample. f(wo, wi) is pbrt's for radiance (wi toward the light); importance
 * (adjoint, wo toward the light) scatters by the adjoint BSDF f*(wo, wi) = f(wi, wo) (Veach 1997,
 * sec. 3.7.1), so that light and eye subpaths estimate one integral of a non-reciprocal f. */
CB_FN Spectrum hairLobeEvalFrom(Material m, Spectrum sigmaA, real h, const HairFrom* fromO, Vec3 wo,
                                Vec3 wi, int adjoint, real* pdfFwd, real* pdfRev) {
    HairFrom fromI = hairFrom(m, sigmaA, h, wi);
    Spectrum fFwd = hairEvalFrom(m, fromO, wi, pdfFwd);
    Spectrum fRev = hairEvalFrom(m, &fromI, wo, pdfRev);
    return adjoint ? fRev : fFwd;
}
CB_FN Spectrum hairLobeEval(const SceneView* scene, Material m, TexCoord uv, Vec3 wo, Vec3 wi,
                            int adjoint, real* pdfFwd, real* pdfRev) {
    Spectrum sigmaA = specLoad(scene->spectra, m.reflectance);
    real h = hairOffset(uv);
    HairFrom fromO = hairFrom(m, sigmaA, h, wo);
    return hairLobeEvalFrom(m, sigmaA, h, &fromO, wo, wi, adjoint, pdfFwd, pdfRev);
}

/* pbrt-v4's HairBxDF::Sample_f from unflipped local wo: uLobe picks the lobe by Ap's shares and,
 * rescaled, the azimuth; u0 the longitudinal angle about the tilted mirror of theta_o, u1 its
 * spread (pbrt-v3 sec. 9.9.7). f and both pdfs as hairLobeEval's at the direction found. */
CB_FN bool hairSample(const SceneView* scene, Material m, TexCoord uv, Vec3 wo, real u0, real u1,
                      real uLobe, int adjoint, BsdfSample* out) {
    Spectrum sigmaA = specLoad(scene->spectra, m.reflectance);
    real h = hairOffset(uv);
    HairFrom o = hairFrom(m, sigmaA, h, wo);
    int p = 0;
    real uc = uLobe;
    while (p < CB_HAIR_PMAX && (uc >= o.apPdf[p] || !(o.apPdf[p] > 0.0f))) {
        uc -= o.apPdf[p];
        ++p;
    }
    if (!(o.apPdf[p] > 0.0f)) return false;
    uc = cbClamp(uc / o.apPdf[p], 0.0f, 0.99999994f);
    real sinP, cosP;
    real v = hairLobeTilt(m, p, o.sinO, o.cosO, &sinP, &cosP);
    u0 = fmax(u0, 1e-5f);
    real cosTheta = 1.0f + v * log(u0 + (1.0f - u0) * exp(-2.0f / v));
    real sinTheta = cbSafeSqrt(1.0f - cosTheta * cosTheta);
    real sinI = cbClamp(-cosTheta * sinP + sinTheta * cbCosPi(2.0f * u1) * cosP, -1.0f, 1.0f);
    real cosI = cbSafeSqrt(1.0f - sinI * sinI);
    real dphi = p < CB_HAIR_PMAX
                    ? hairPhi(p, o.gammaO, o.gammaT) + hairSampleTrimmedLogistic(uc, m.hairS)
                    : 2.0f * CB_PI * uc;
    real phiI = o.phiO + dphi;
    Vec3 wi = vec3(sinI, cosI * cos(phiI), cosI * sin(phiI));
    if (wi.z == 0.0f) return false;
    out->wi = wi;
    out->f = hairLobeEvalFrom(m, sigmaA, h, &o, wo, wi, adjoint, &out->pdf, &out->pdfRev);
    return out->pdf > 0.0f && specIsFinite(out->f);
}
#endif

/* Non-delta part of a non-mix material. wo.z > 0 (flipped local frame); `entering` says whether
 * wo is on the side frame.n points to, adjoint as bsdfEval's. */
CB_FN Spectrum cbLobeEval(const SceneView* scene, Material m, TexCoord uv, Vec3 wo, Vec3 wi,
                          bool entering, int adjoint, real* pdfFwd, real* pdfRev) {
    *pdfFwd = 0.0f;
    *pdfRev = 0.0f;
#if CB_HAS(CB_FEATURE_ROUGHNESS_TEXTURE)
    m = materialRoughnessAt(scene, m, uv);
#endif
#if CB_HAS(CB_FEATURE_THICKNESS_TEXTURE)
    m = materialThicknessAt(scene, m, uv);
#endif
#if CB_HAS(CB_FEATURE_DISPERSION)
    m = materialDispersionAt(scene, m, uv);
#endif
    (void)entering;
    (void)adjoint;
#if CB_HAS(CB_FEATURE_DIFFUSE)
    if (m.kind == CB_MAT_DIFFUSE) {
        if (!(wi.z > 0.0f)) return specZero();
        *pdfFwd = cosineHemispherePdf(wi.z);
        *pdfRev = cosineHemispherePdf(wo.z);
        return specScale(materialReflectance(scene, m, uv), CB_INV_PI);
    }
#endif
#if CB_HAS(CB_FEATURE_DIFFUSE_TRANSMISSION)
    if (m.kind == CB_MAT_DIFFUSE_TRANSMISSION) {
        Spectrum r, t;
        real pr = cbDiffuseTransmissionAt(scene, m, uv, &r, &t);
        if (wi.z == 0.0f || !(pr >= 0.0f)) return specZero();
        bool reflect = wi.z > 0.0f;
        /* The lobe that reaches wi from wo also reaches wo from wi. */
        real lobe = reflect ? pr : 1.0f - pr;
        *pdfFwd = lobe * cosineHemispherePdf(fabs(wi.z));
        *pdfRev = lobe * cosineHemispherePdf(wo.z);
        if (!(lobe > 0.0f)) return specZero();
        return specScale(reflect ? r : t, CB_INV_PI);
    }
#endif
#if CB_HAS_LAYERED
    if (m.kind == CB_MAT_COATED_DIFFUSE || m.kind == CB_MAT_COATED_CONDUCTOR) {
        if (!(wi.z > 0.0f)) return specZero();
        LayerBase base = layerBaseLoad(scene, m, uv);
        *pdfFwd = layeredPdf(base, m, wo, wi);
        *pdfRev = layeredPdf(base, m, wi, wo);
        return layeredEval(base, m, wo, wi, adjoint);
    }
#endif
#if CB_HAS(CB_FEATURE_CONDUCTOR)
    if (m.kind == CB_MAT_CONDUCTOR) {
        if (m.alpha == 0.0f || !(wi.z > 0.0f)) return specZero();
        Vec3 h = vadd(wo, wi);
        real len = vlength(h);
        if (!(len > 0.0f)) return specZero();
        Vec3 wm = vscale(h, 1.0f / len);
        real value = cbGgxReflection(wo, wi, wm, materialGgxAlpha(m), pdfFwd, pdfRev);
        Spectrum r = specLoad(scene->spectra, m.reflectance);
        return specScale(cbConductorFresnel(scene, m, r, vdot(wo, wm)), value);
    }
#endif
#if CB_HAS(CB_FEATURE_HAIR)
    if (m.kind == CB_MAT_HAIR) {
        /* The fibre's azimuth tells its sides apart: back to the frame's own z. */
        real flip = entering ? 1.0f : -1.0f;
        return hairLobeEval(scene, m, uv, vec3(wo.x, wo.y, wo.z * flip),
                            vec3(wi.x, wi.y, wi.z * flip), adjoint, pdfFwd, pdfRev);
    }
#endif
#if CB_HAS(CB_FEATURE_ROUGH_DIELECTRIC)
    if (m.kind == CB_MAT_DIELECTRIC && m.alpha > 0.0f) {
        real eta = entering ? m.eta : 1.0f / m.eta;
        real fr;
        real f = cbRoughDielectric(wo, wi, eta, materialGgxAlpha(m), adjoint, pdfFwd, pdfRev, &fr);
        return f > 0.0f ? specConst(f) : specZero();
    }
#endif
    (void)scene;
    (void)m;
    (void)uv;
    (void)wo;
    (void)wi;
    return specZero();
}

CB_FN bool cbLobeIsDeltaOnly(Material m) {
#if CB_HAS(CB_FEATURE_THIN_DIELECTRIC)
    if (m.kind == CB_MAT_THIN_DIELECTRIC) return true;
#endif
#if CB_HAS(CB_FEATURE_COATED_CONDUCTOR)
    /* A smooth coat over a smooth conductor reflects only into the mirror direction, unless the
     * layer between them scatters. */
    if (m.kind == CB_MAT_COATED_CONDUCTOR)
        return m.alpha == 0.0f && m.baseAlpha == 0.0f && m.layerAlbedo < 0;
#endif
#if CB_HAS(CB_FEATURE_CONDUCTOR)
    if (m.kind == CB_MAT_CONDUCTOR) return m.alpha == 0.0f;
#endif
#if CB_HAS(CB_FEATURE_DIELECTRIC)
#if CB_HAS(CB_FEATURE_ROUGH_DIELECTRIC)
    if (m.kind == CB_MAT_DIELECTRIC) return m.alpha == 0.0f;
#else
    if (m.kind == CB_MAT_DIELECTRIC) return true;
#endif
#endif
    (void)m;
    return false;
}

CB_FN real cbLobeSpecularity(Material m) {
#if CB_HAS(CB_FEATURE_THIN_DIELECTRIC)
    if (m.kind == CB_MAT_THIN_DIELECTRIC) return 1.0f;
#endif
#if CB_HAS(CB_FEATURE_CONDUCTOR)
    if (m.kind == CB_MAT_CONDUCTOR) return 1.0f;
#endif
#if CB_HAS(CB_FEATURE_COATED_CONDUCTOR)
    /* As the conductor it coats, unless its layer scatters (diffuse, as coated diffuse). */
    if (m.kind == CB_MAT_COATED_CONDUCTOR) return m.layerAlbedo < 0 ? 1.0f : 0.0f;
#endif
#if CB_HAS(CB_FEATURE_DIELECTRIC)
    if (m.kind == CB_MAT_DIELECTRIC) return 1.0f;
#endif
    (void)m;
    return 0.0f;
}

/* Sample a non-mix material; wo.z > 0 in the flipped local frame, `entering` says whether wo is on
 * the side frame.n points to (the dielectric's outside). out->wi is local (flipped). Non-delta
 * results carry only this lobe's own f and pdfs. */
CB_FN bool cbLobeSample(const SceneView* scene, Material m, TexCoord uv, Vec3 wo, bool entering,
                        real u0, real u1, real uLobe, int adjoint, BsdfSample* out) {
    out->isDelta = 0;
    (void)uv;
#if CB_HAS(CB_FEATURE_ROUGHNESS_TEXTURE)
    m = materialRoughnessAt(scene, m, uv);
#endif
#if CB_HAS(CB_FEATURE_THICKNESS_TEXTURE)
    m = materialThicknessAt(scene, m, uv);
#endif
#if CB_HAS(CB_FEATURE_DISPERSION)
    m = materialDispersionAt(scene, m, uv);
#endif
#if CB_HAS(CB_FEATURE_DIFFUSE)
    if (m.kind == CB_MAT_DIFFUSE) {
        Vec3 wi = sampleCosineHemisphere(u0, u1);
        if (!(wi.z > 0.0f)) return false;
        out->wi = wi;
        out->f = specScale(materialReflectance(scene, m, uv), CB_INV_PI);
        out->pdf = cosineHemispherePdf(wi.z);
        out->pdfRev = cosineHemispherePdf(wo.z);
        return true;
    }
#endif
#if CB_HAS(CB_FEATURE_DIFFUSE_TRANSMISSION)
    if (m.kind == CB_MAT_DIFFUSE_TRANSMISSION) {
        Spectrum r, t;
        real pr = cbDiffuseTransmissionAt(scene, m, uv, &r, &t);
        Vec3 wi = sampleCosineHemisphere(u0, u1);
        if (!(wi.z > 0.0f) || !(pr >= 0.0f)) return false;
        bool reflect = uLobe < pr;
        real lobe = reflect ? pr : 1.0f - pr;
        out->wi = reflect ? wi : vec3(wi.x, wi.y, -wi.z);
        out->f = specScale(reflect ? r : t, CB_INV_PI);
        out->pdf = lobe * cosineHemispherePdf(wi.z);
        out->pdfRev = lobe * cosineHemispherePdf(wo.z);
        return out->pdf > 0.0f;
    }
#endif
#if CB_HAS_LAYERED
    if (m.kind == CB_MAT_COATED_DIFFUSE || m.kind == CB_MAT_COATED_CONDUCTOR)
        return layeredSample(layerBaseLoad(scene, m, uv), m, wo, u0, u1, uLobe, adjoint, out);
#endif
#if CB_HAS(CB_FEATURE_HAIR)
    if (m.kind == CB_MAT_HAIR) {
        real flip = entering ? 1.0f : -1.0f;
        if (!hairSample(scene, m, uv, vec3(wo.x, wo.y, wo.z * flip), u0, u1, uLobe, adjoint, out))
            return false;
        out->wi.z *= flip;
        return true;
    }
#endif
#if CB_HAS(CB_FEATURE_THIN_DIELECTRIC)
    if (m.kind == CB_MAT_THIN_DIELECTRIC) {
        real r = thinDielectricReflectance(wo.z, m.eta);
        bool reflect = uLobe < r;
        real lobe = reflect ? r : 1.0f - r;
        out->isDelta = 1;
        /* Transmission leaves unbent: the sheet's two faces are parallel. Neither lobe changes
         * the medium, so radiance and importance scatter alike, and the reverse choice sees the
         * same angle. */
        out->wi = reflect ? vec3(-wo.x, -wo.y, wo.z) : vec3(-wo.x, -wo.y, -wo.z);
        out->f = specConst(lobe / wo.z);
        out->pdf = lobe;
        out->pdfRev = lobe;
        return isfinite(out->f.c[0]) && lobe > 0.0f;
    }
#endif
#if CB_HAS(CB_FEATURE_CONDUCTOR)
    if (m.kind == CB_MAT_CONDUCTOR) {
        Spectrum r = specLoad(scene->spectra, m.reflectance);
        if (m.alpha == 0.0f) {
            out->wi = vec3(-wo.x, -wo.y, wo.z);
            out->f = specScale(cbConductorFresnel(scene, m, r, wo.z), 1.0f / wo.z);
            out->pdf = 1.0f;
            out->pdfRev = 1.0f;
            out->isDelta = 1;
            return isfinite(out->f.c[0]);
        }
        Vec3 wi, wm;
        real value;
        if (!cbGgxReflectionSample(wo, materialGgxAlpha(m), u0, u1, &wi, &wm, &value, &out->pdf,
                                   &out->pdfRev))
            return false;
        out->wi = wi;
        out->f = specScale(cbConductorFresnel(scene, m, r, vdot(wo, wm)), value);
        return true;
    }
#endif
#if CB_HAS(CB_FEATURE_ROUGH_DIELECTRIC)
    if (m.kind == CB_MAT_DIELECTRIC && m.alpha > 0.0f) {
        real eta = entering ? m.eta : 1.0f / m.eta;
        GgxAlpha alpha = materialGgxAlpha(m);
        Vec3 wi;
        bool through;
        if (!cbRoughDielectricDirection(wo, eta, alpha, u0, u1, uLobe, CB_LOBES_BOTH, &wi,
                                        &through))
            return false;
        /* f and both pdfs from the half vector of (wo, wi), as bsdfEval computes them. */
        real frAtWm;
        real f = cbRoughDielectric(wo, wi, eta, alpha, adjoint, &out->pdf, &out->pdfRev, &frAtWm);
        if (!(f > 0.0f)) return false;
        out->wi = wi;
        out->f = specConst(f);
        return true;
    }
#endif
#if CB_HAS(CB_FEATURE_DIELECTRIC)
    if (m.kind == CB_MAT_DIELECTRIC) {
        real eta = entering ? m.eta : 1.0f / m.eta;
        real f;
        bool through;
        out->isDelta = 1;
        if (!smoothDielectricSample(wo, eta, CB_LOBES_BOTH, uLobe, adjoint, &out->wi, &f, &out->pdf,
                                    &through))
            return false;
        out->f = specConst(f);
        /* The reverse choice sees the same angle (reflection) or the same Fresnel term (Stokes:
         * it is symmetric in the two sides), so it has the same probability. */
        out->pdfRev = out->pdf;
        return true;
    }
#endif
    (void)scene;
    (void)m;
    (void)wo;
    (void)entering;
    (void)u0;
    (void)u1;
    (void)uLobe;
    (void)adjoint;
    return false;
}

/* ---- Public interface ------------------------------------------------------------------------ */

/* |ns . w| / |ng . w|: what a geometric cosine at a surface point becomes with shading normals;
 * 1 without them (compiled out), 0 where w is tangent to the surface. */
CB_FN real shadingRatio(Vec3 ng, Vec3 ns, Vec3 w) {
#if CB_HAS_SHADING
    real c = vabsdot(ng, w);
    return c > 0.0f ? vabsdot(ns, w) / c : 0.0f;
#else
    (void)ng;
    (void)ns;
    (void)w;
    return 1.0f;
#endif
}

/* The cosine that multiplies f (evaluated in the frame of ns) where a path scatters from wo to
 * wi. Veach 1997, sec. 5.3: the integrand takes the shading normal's cosine on the light's side
 * of each vertex, |ns . wi| when radiance is traced (wi toward the light, as pbrt-v4's path
 * tracers), and the adjoint BSDF's |ng . wi| |ns . wo| / |ng . wo| when importance is (light
 * subpaths, wo toward the light; pbrt-v3's CorrectShadingNormal times |ns . wi|), so that both
 * directions of tracing estimate one integral. With ns = ng both are |ng . wi|. */
CB_FN real scatterCos(Vec3 ng, Vec3 ns, Vec3 wo, Vec3 wi, int adjoint) {
    if (adjoint) return vabsdot(ng, wi) * shadingRatio(ng, ns, wo);
#if CB_HAS_SHADING
    return vabsdot(ns, wi);
#else
    return vabsdot(ng, wi);
#endif
}

/* The BSDF's shading frame at sp: about ns, with its first axis along the surface's dp/du where
 * the material is anisotropic (surfacePointTangent); frameFromNormal's elsewhere, where any
 * rotation about ns is the same BSDF. */
CB_FN Frame surfaceFrame(SurfacePoint sp) {
#if CB_HAS(CB_FEATURE_ANISOTROPIC)
    return frameFromNormalTangent(sp.ns, sp.tangent);
#else
    return frameFromNormal(sp.ns);
#endif
}

/* Local coordinates with z multiplied by flip (+-1): flipping both directions by wo's side lets
 * every lobe assume wo.z > 0, which is how two-sided reflection works. */
CB_FN Vec3 cbToFlippedLocal(Frame frame, Vec3 w, real flip) {
    Vec3 l = frameToLocal(frame, w);
    return vec3(l.x, l.y, l.z * flip);
}

#if CB_HAS(CB_FEATURE_MIX)
/* A mix's f and pdfs in flipped local coordinates: its parts' weighted by amount. A mix of
 * mixes is a chain (the device scene's): each link's first part is a material that is not a
 * mix and its second the rest of the chain, of weight amount. */
CB_FN Spectrum cbMixEval(const SceneView* scene, Material m, TexCoord uv, Vec3 lo, Vec3 li,
                         bool entering, int adjoint, real* pdfFwd, real* pdfRev) {
    Spectrum f = specZero();
    real weight = 1.0f;
    *pdfFwd = 0.0f;
    *pdfRev = 0.0f;
    for (;;) {
        real a = m.mixAmount;
        real pf, pr;
        Spectrum f1 = cbLobeEval(scene, scene->materials[m.mixFirst], uv, lo, li, entering, adjoint,
                                 &pf, &pr);
        f = specAdd(f, specScale(f1, weight * (1.0f - a)));
        *pdfFwd += weight * (1.0f - a) * pf;
        *pdfRev += weight * (1.0f - a) * pr;
        weight *= a;
        Material rest = scene->materials[m.mixSecond];
        if (rest.kind != CB_MAT_MIX) {
            Spectrum f2 = cbLobeEval(scene, rest, uv, lo, li, entering, adjoint, &pf, &pr);
            *pdfFwd += weight * pf;
            *pdfRev += weight * pr;
            return specAdd(f, specScale(f2, weight));
        }
        m = rest;
    }
}
#endif

/* The BSDF of `material` at a surface point of texture coordinates uv (its textured
 * reflectance's) and shading frame `frame`. */
CB_FN Spectrum bsdfEval(const SceneView* scene, int material, TexCoord uv, Frame frame, Vec3 wo,
                        Vec3 wi, int adjoint, real* pdfFwd, real* pdfRev) {
    /* adjoint: dielectric transmission (its radiance scaling) and hair (f(wi, wo)) depend on it */
    *pdfFwd = 0.0f;
    *pdfRev = 0.0f;
    real cosO = vdot(wo, frame.n);
    if (cosO == 0.0f || !isfinite(cosO)) return specZero();
    real flip = cosO > 0.0f ? 1.0f : -1.0f;
    bool entering = cosO > 0.0f;
    Vec3 lo = cbToFlippedLocal(frame, wo, flip);
    Vec3 li = cbToFlippedLocal(frame, wi, flip);
    Material m = scene->materials[material];
#if CB_HAS(CB_FEATURE_MIX)
    if (m.kind == CB_MAT_MIX)
        return cbMixEval(scene, m, uv, lo, li, entering, adjoint, pdfFwd, pdfRev);
#endif
    return cbLobeEval(scene, m, uv, lo, li, entering, adjoint, pdfFwd, pdfRev);
}

CB_FN bool bsdfSample(const SceneView* scene, int material, TexCoord uv, Frame frame, Vec3 wo,
                      real u0, real u1, real uLobe, int adjoint, BsdfSample* out) {
    real cosO = vdot(wo, frame.n);
    if (cosO == 0.0f || !isfinite(cosO)) return false;
    real flip = cosO > 0.0f ? 1.0f : -1.0f;
    Vec3 lo = cbToFlippedLocal(frame, wo, flip);
    bool entering = cosO > 0.0f;
    Material m = scene->materials[material];
    BsdfSample s;
#if CB_HAS(CB_FEATURE_MIX)
    if (m.kind == CB_MAT_MIX) {
        /* One uniform number picks the part at each link and, rescaled to [0,1), the part's own
         * lobe: the choice stays monotone in uLobe, which keeps shared sample vectors coherent. */
        real pick = 1.0f, uRest = uLobe;
        Material c = m;
        while (c.kind == CB_MAT_MIX) {
            pick *= uRest < c.mixAmount ? c.mixAmount : 1.0f - c.mixAmount;
            c = scene->materials[mixLinkChoose(c, &uRest)];
        }
        if (!cbLobeSample(scene, c, uv, lo, entering, u0, u1, uRest, adjoint, &s)) return false;
        if (s.isDelta) {
            s.f = specScale(s.f, pick);
            s.pdf *= pick;
            s.pdfRev *= pick;
        } else {
            s.f = cbMixEval(scene, m, uv, lo, s.wi, entering, adjoint, &s.pdf, &s.pdfRev);
            if (!(s.pdf > 0.0f)) return false;
        }
    } else
#endif
    {
        if (!cbLobeSample(scene, m, uv, lo, entering, u0, u1, uLobe, adjoint, &s)) return false;
    }
    s.wi = frameToWorld(frame, vec3(s.wi.x, s.wi.y, s.wi.z * flip));
    *out = s;
    return true;
}

CB_FN bool materialHasNonDelta(const SceneView* scene, int material) {
    Material m = scene->materials[material];
#if CB_HAS(CB_FEATURE_MIX)
    /* A link's second part counts only where its amount is above 0, its first below 1. */
    while (m.kind == CB_MAT_MIX) {
        if (m.mixAmount < 1.0f && !cbLobeIsDeltaOnly(scene->materials[m.mixFirst])) return true;
        if (!(m.mixAmount > 0.0f)) return false;
        m = scene->materials[m.mixSecond];
    }
#endif
    return !cbLobeIsDeltaOnly(m);
}

/* Whether bsdfSample reads its uLobe, which only chooses between lobes (a mix's components, a
 * (thin) dielectric's, a diffuse transmitter's or a coat's reflection and transmission, a hair's
 * lobe p): otherwise
 * the caller need not draw it. A scene compiled without those materials reads none. */
CB_FN bool bsdfReadsLobeSample(const SceneView* scene, int material) {
    int kind = scene->materials[material].kind;
    (void)kind;
#if CB_HAS(CB_FEATURE_MIX)
    if (kind == CB_MAT_MIX) return true;
#endif
#if CB_HAS(CB_FEATURE_DIELECTRIC)
    if (kind == CB_MAT_DIELECTRIC) return true;
#endif
#if CB_HAS(CB_FEATURE_DIFFUSE_TRANSMISSION)
    if (kind == CB_MAT_DIFFUSE_TRANSMISSION) return true;
#endif
#if CB_HAS(CB_FEATURE_THIN_DIELECTRIC)
    if (kind == CB_MAT_THIN_DIELECTRIC) return true;
#endif
#if CB_HAS_LAYERED
    if (kind == CB_MAT_COATED_DIFFUSE || kind == CB_MAT_COATED_CONDUCTOR) return true;
#endif
#if CB_HAS(CB_FEATURE_HAIR)
    if (kind == CB_MAT_HAIR) return true; /* the lobe p */
#endif
    return false;
}

CB_FN real materialSpecularity(const SceneView* scene, int material) {
    Material m = scene->materials[material];
#if CB_HAS(CB_FEATURE_MIX)
    real specularity = 0.0f, weight = 1.0f;
    while (m.kind == CB_MAT_MIX) {
        specularity +=
            weight * (1.0f - m.mixAmount) * cbLobeSpecularity(scene->materials[m.mixFirst]);
        weight *= m.mixAmount;
        m = scene->materials[m.mixSecond];
    }
    return specularity + weight * cbLobeSpecularity(m);
#else
    return cbLobeSpecularity(m);
#endif
}

CB_END_NAMESPACE

#endif /* CB_BSDF_H */
