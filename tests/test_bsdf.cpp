// BSDFs of kernels/cb_bsdf.h: chi-square of sampled directions against bsdfEval's pdf, pdf and
// albedo integrals, reciprocity, delta lobes (mirror, Fresnel, Snell, TIR, adjoint scaling),
// mixtures, robustness at grazing angles and alpha = 1e-4, and the same header built as OpenCL C
// by PoCL giving the host's numbers.
#include <doctest/doctest.h>

#include <CL/cl.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "cb_bsdf.h"
#include "chi2.h"
#include "float64/host_kernels.h"
#include "layered_reference.h"
#include "scene/device_scene.h"
#include "scene/scene_bytes.h"
#include "scene/scene_desc.h"
#include "source_tree.h"

using namespace cbk;
using cbtest::kPi;

namespace {

constexpr int kChi2Tests = 54;
const double kLevel = cbtest::sidak(0.01, kChi2Tests);

struct Uniform {
    std::mt19937 rng;
    explicit Uniform(unsigned seed) : rng(seed) {}
    float operator()() { return static_cast<float>(rng() >> 8) * (1.0f / 16777216.0f); }
};

// A handful of materials over a small spectra table, viewed as the kernels would see it.
struct TestScene {
    std::vector<Material> materials;
    std::vector<float> spectra;
    int spectrum(float r, float g, float b) {
        static_assert(CB_CHANNELS == 3, "host tests assume RGB");
        for (float channel : {r, g, b})
            spectra.push_back(channel);
        return static_cast<int>(spectra.size() / 3) - 1;
    }
    int add(int kind, int refl, float alpha, float eta, int first = -1, int second = -1,
            float amount = 0.0f) {
        Material m{};
        m.kind = kind;
        m.reflectance = refl;
        m.alpha = alpha;
        m.alphaV = alpha;
        m.eta = eta;
        m.mixFirst = first;
        m.mixSecond = second;
        m.mixAmount = amount;
        m.secondSpectrum = -1;
        m.layerAlbedo = -1;
        m.reflectanceTexture = -1;
        m.transmittanceTexture = -1;
        m.textureScale = 1.0f;
        m.normalMap = -1;
        m.roughnessTexture = -1;
        m.thicknessTexture = -1;
        m.alphaTexture = -1;
        m.displacement = -1;
        m.dispersion = -1;
        materials.push_back(m);
        return static_cast<int>(materials.size()) - 1;
    }
    int diffuse(int refl) { return add(CB_MAT_DIFFUSE, refl, 0.0f, 1.0f); }
    int conductor(int refl, float alpha) { return add(CB_MAT_CONDUCTOR, refl, alpha, 1.0f); }
    // A conductor given its complex index eta + i k (two spectra), as pbrt-v4's eta and k.
    int fresnelConductor(int eta, int k, float alpha) {
        int m = conductor(eta, alpha);
        materials[size_t(m)].secondSpectrum = k;
        return m;
    }
    int dielectric(float eta) { return add(CB_MAT_DIELECTRIC, 0, 0.0f, eta); }
    int mix(int a, int b, float amount) { return add(CB_MAT_MIX, 0, 0.0f, 1.0f, a, b, amount); }
    int diffuseTransmission(int refl, int trans) {
        int m = add(CB_MAT_DIFFUSE_TRANSMISSION, refl, 0.0f, 1.0f);
        materials[size_t(m)].secondSpectrum = trans;
        return m;
    }
    int thinDielectric(float eta) { return add(CB_MAT_THIN_DIELECTRIC, 0, 0.0f, eta); }
    int coatedDiffuse(int refl, float eta, float thickness, int depth, int samples,
                      float alpha = 0.0f) {
        int m = add(CB_MAT_COATED_DIFFUSE, refl, alpha, eta);
        materials[size_t(m)].thickness = thickness;
        materials[size_t(m)].layerDepth = depth;
        materials[size_t(m)].layerSamples = samples;
        return m;
    }
    // A conductor under a coat: `index`, `k` its complex index (k -1: `index` is a reflectance),
    // alpha the coat's, baseAlpha the conductor's.
    int coatedConductor(int index, int k, float eta, float thickness, int depth, int samples,
                        float alpha, float baseAlpha) {
        int m = coatedDiffuse(index, eta, thickness, depth, samples, alpha);
        materials[size_t(m)].kind = CB_MAT_COATED_CONDUCTOR;
        materials[size_t(m)].secondSpectrum = k;
        materials[size_t(m)].baseAlpha = baseAlpha;
        return m;
    }
    // Material m made anisotropic: alphaV its GGX alpha along the frame's second axis.
    int anisotropic(int m, float alphaV) {
        materials[size_t(m)].alphaV = alphaV;
        return m;
    }
    // The layer of a coated material scatters: its albedo (a spectrum) and Henyey-Greenstein g.
    int scattering(int m, int albedo, float g) {
        materials[size_t(m)].layerAlbedo = albedo;
        materials[size_t(m)].layerG = g;
        return m;
    }
    SceneView view() const {
        SceneView v{};
        v.materials = materials.data();
        v.spectra = spectra.data();
        return v;
    }
};

// The materials every test uses.
struct Fixture {
    TestScene s;
    int white, tint, gold;
    int diffuse, diffuseTint, mirror, rough005, rough03, rough1, glass, glassWater, tiny;
    int mixDiffuseRough, mixDragon, mixDiffuseGlossy, mixDiffuseGlass, mixMirrorGlass;
    // Mixes of mixes, as the device scene chains them (the second part the rest of the chain).
    int goldMirror, mixNested, mixNestedGlossy, mixNestedDelta;
    int goldEta, goldK, goldFresnelMirror, goldFresnelRough, mixDiffuseGoldRough;
    int roughGlass01, roughGlass05, roughGlassTiny, mixDiffuseRoughGlass;
    int black, translucent, transmitterOnly, reflectorOnly, mixDiffuseTranslucent;
    int thinGlass, thinLowIndex, mixTranslucentThin, thinTinyIndex, thinHugeIndex;
    int coatedThick, coatedDefault, coatedLowIndex, coatedRough, coatedRoughGold, coatedNearSmooth;
    int coatedRoughLow;
    int ccSmoothGold, ccSmoothTint, ccSmoothLow, ccRoughBase, ccRoughCoat, ccRoughBoth, ccRoughLow;
    int ccNearSmooth, cdScatter, ccScatterRough, ccScatterSmooth;
    int anisoConductor, anisoGoldSwapped, anisoGold, anisoGlass;
    Fixture() {
        white = s.spectrum(1.0f, 1.0f, 1.0f);
        tint = s.spectrum(0.8f, 0.6f, 0.4f);
        gold = s.spectrum(0.68f, 0.54f, 0.18f);
        diffuse = s.diffuse(white);
        diffuseTint = s.diffuse(tint);
        mirror = s.conductor(tint, 0.0f);
        rough005 = s.conductor(white, 0.05f);
        rough03 = s.conductor(white, 0.3f);
        rough1 = s.conductor(white, 1.0f);
        glass = s.dielectric(1.5f);
        glassWater = s.dielectric(1.33f);
        tiny = s.conductor(white, 1e-4f);
        mixDiffuseRough = s.mix(diffuse, rough03, 0.3f);
        int goldDiffuse = s.diffuse(gold);
        goldMirror = s.conductor(gold, 0.0f);
        mixDragon = s.mix(goldDiffuse, goldMirror, 0.3f); // the thesis's dragon: 70% / 30%
        mixDiffuseGlossy = s.mix(diffuseTint, rough005, 0.6f);
        mixDiffuseGlass = s.mix(diffuse, glass, 0.5f);
        mixMirrorGlass = s.mix(mirror, glass, 0.4f);
        // Weights 0.4 diffuse, 0.3 rough, 0.3 mirror; 0.5, 0.125, 0.375; 0.3, 0.28, 0.42.
        mixNested = s.mix(diffuseTint, s.mix(rough03, goldMirror, 0.5f), 0.6f);
        mixNestedGlossy = s.mix(diffuse, s.mix(rough005, rough03, 0.75f), 0.5f);
        mixNestedDelta = s.mix(mirror, s.mix(glass, goldMirror, 0.6f), 0.7f);
        // Gold's complex index at about 650, 550 and 450 nm (Johnson and Christy 1972).
        goldEta = s.spectrum(0.166f, 0.43f, 1.5f);
        goldK = s.spectrum(3.15f, 2.45f, 1.88f);
        goldFresnelMirror = s.fresnelConductor(goldEta, goldK, 0.0f);
        goldFresnelRough = s.fresnelConductor(goldEta, goldK, 0.3f);
        mixDiffuseGoldRough = s.mix(diffuseTint, goldFresnelRough, 0.5f);
        roughGlass01 = s.add(CB_MAT_DIELECTRIC, 0, 0.1f, 1.5f);
        roughGlass05 = s.add(CB_MAT_DIELECTRIC, 0, 0.5f, 1.33f);
        roughGlassTiny = s.add(CB_MAT_DIELECTRIC, 0, 1e-4f, 1.5f);
        mixDiffuseRoughGlass = s.mix(diffuseTint, roughGlass05, 0.5f);
        // Anisotropic lobes: alpha along the frame's first axis, then along its second.
        anisoConductor = s.anisotropic(s.conductor(white, 0.05f), 0.4f);
        anisoGold = s.anisotropic(s.fresnelConductor(goldEta, goldK, 0.6f), 0.15f);
        anisoGoldSwapped = s.anisotropic(s.fresnelConductor(goldEta, goldK, 0.15f), 0.6f);
        anisoGlass = s.anisotropic(s.add(CB_MAT_DIELECTRIC, 0, 0.4f, 1.5f), 0.08f);
        black = s.spectrum(0.0f, 0.0f, 0.0f);
        // Lobe choice by the largest channels: reflect with probability 0.5 / (0.5 + 0.45).
        translucent =
            s.diffuseTransmission(s.spectrum(0.5f, 0.3f, 0.2f), s.spectrum(0.35f, 0.45f, 0.1f));
        transmitterOnly = s.diffuseTransmission(black, tint);
        reflectorOnly = s.diffuseTransmission(tint, black);
        mixDiffuseTranslucent = s.mix(diffuseTint, translucent, 0.4f);
        thinGlass = s.thinDielectric(1.5f);
        thinLowIndex = s.thinDielectric(0.7f); // an index below 1: total reflection at grazing
        mixTranslucentThin = s.mix(translucent, thinGlass, 0.5f);
        thinTinyIndex = s.thinDielectric(1e-6f); // stiff: total reflection almost everywhere
        thinHugeIndex = s.thinDielectric(1e6f);  // stiff: a near-perfect mirror
        coatedThick = s.coatedDiffuse(tint, 1.5f, 0.25f, 1000, 1);
        coatedDefault = s.coatedDiffuse(tint, 1.5f, 0.01f, 10, 1); // pbrt-v4's defaults
        coatedLowIndex = s.coatedDiffuse(gold, 0.7f, 0.0f, 40, 2); // total reflection inside
        coatedRough = s.coatedDiffuse(tint, 1.5f, 0.1f, 10, 1, 0.3f);
        coatedRoughGold = s.coatedDiffuse(gold, 1.25f, 0.0f, 20, 2, 0.6f);
        coatedRoughLow = s.coatedDiffuse(gold, 0.8f, 0.0f, 20, 2, 0.6f); // total reflection
        coatedNearSmooth = s.coatedDiffuse(tint, 1.5f, 0.25f, 1000, 1, 2e-3f);
        ccSmoothGold = s.coatedConductor(goldEta, goldK, 1.5f, 0.1f, 10, 1, 0.0f, 0.0f);
        ccSmoothTint = s.coatedConductor(tint, -1, 1.33f, 0.0f, 1000, 1, 0.0f, 0.0f);
        ccSmoothLow = s.coatedConductor(goldEta, goldK, 0.8f, 0.05f, 40, 2, 0.0f, 0.0f);
        ccRoughBase = s.coatedConductor(goldEta, goldK, 1.5f, 0.1f, 10, 1, 0.0f, 0.3f);
        ccRoughCoat = s.coatedConductor(tint, -1, 1.5f, 0.0f, 20, 1, 0.4f, 0.0f);
        ccRoughBoth = s.coatedConductor(goldEta, goldK, 1.25f, 0.0f, 20, 2, 0.3f, 0.5f);
        // The exit's sample from outside meets total reflection at its microfacet (eta < 1).
        ccRoughLow = s.coatedConductor(tint, -1, 0.8f, 0.0f, 20, 2, 0.6f, 0.2f);
        ccNearSmooth = s.coatedConductor(goldEta, goldK, 1.5f, 0.1f, 10, 1, 2e-3f, 2e-3f);
        const int milk = s.spectrum(0.9f, 0.6f, 0.3f);
        cdScatter = s.scattering(s.coatedDiffuse(tint, 1.5f, 0.5f, 100, 1), milk, 0.5f);
        ccScatterRough = s.scattering(
            s.coatedConductor(goldEta, goldK, 1.25f, 0.3f, 50, 1, 0.3f, 0.4f), milk, -0.3f);
        ccScatterSmooth = s.scattering(
            s.coatedConductor(goldEta, goldK, 1.5f, 0.5f, 100, 1, 0.0f, 0.0f), milk, 0.7f);
    }
};

const Frame kFrame = frameFromNormal(vnormalize(vec3(0.3f, -0.5f, 0.8f)));
// Texture coordinates for bsdfEval and bsdfSample: these materials are untextured.
const TexCoord kNoUv{0.0f, 0.0f, -1.0f};

Vec3 localDir(float cosTheta, float phi) {
    float sinTheta = std::sqrt(std::max(0.0f, 1.0f - cosTheta * cosTheta));
    return vec3(sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta);
}
Vec3 worldDir(float cosTheta, float phi) {
    return frameToWorld(kFrame, localDir(cosTheta, phi));
}

double rel(double a, double b) {
    return std::fabs(a - b) / std::max({std::fabs(a), std::fabs(b), 1e-30});
}

// Exact dielectric Fresnel in double, written independently of the header (Hecht, eq. 4.42/4.43).
double fresnelRef(double cosI, double eta) {
    double sinT = std::sqrt(1.0 - cosI * cosI) / eta;
    if (sinT >= 1.0) return 1.0;
    double cosT = std::sqrt(1.0 - sinT * sinT);
    double rs = (cosI - eta * cosT) / (cosI + eta * cosT);
    double rp = (eta * cosI - cosT) / (eta * cosI + cosT);
    return 0.5 * (rs * rs + rp * rp);
}

using cbtest::conductorFresnel;

// In double via atan2: acos of a float dot product near 1 has an error of ~3e-4 rad.
double angleBetween(Vec3 a, Vec3 b) {
    double ax = a.x, ay = a.y, az = a.z, bx = b.x, by = b.y, bz = b.z;
    double cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
    return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz);
}

struct SamplerCheck {
    cbtest::Chi2Result chi2;
    double pdfIntegral = 0.0; // of bsdfEval's pdfFwd over the sphere
    double albedoQuad = 0.0;  // integral of f |cos| (channel 0)
    double albedoMean = 0.0;  // mean of f |cos| / pdf over the samples (0 for failed ones)
    double albedoStdErr = 0.0;
    double deltaFraction = 0.0;     // fraction of samples that were delta
    double worstSampleVsEval = 0.0; // relative mismatch of sample's f/pdf/pdfRev vs bsdfEval
};

// Histogram bsdfSample's non-delta directions in the frame's (theta, phi) cells, plus one cell for
// delta samples (expected deltaMass) and one for failed samples (the mass the pdf lacks).
// quadrature: Gauss-Legendre sub-cells per cell side for the expected counts; a pdf with
// discontinuities inside cells (a rough dielectric's back-facing microfacets) needs more.
SamplerCheck checkSampler(const SceneView& scene, int material, Vec3 wo, double deltaMass,
                          int samples, unsigned seed, int adjoint = 0, int quadrature = 2) {
    cbtest::SphereHistogram hist(40, 80);
    std::vector<double> observed(hist.cells() + 2, 0.0);
    SamplerCheck out;
    Uniform u(seed);
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < samples; ++i) {
        float u0 = u(), u1 = u(), ul = u();
        BsdfSample s;
        double w = 0.0;
        if (!bsdfSample(&scene, material, kNoUv, kFrame, wo, u0, u1, ul, adjoint, &s)) {
            observed[hist.cells() + 1] += 1.0;
        } else {
            w = s.f.c[0] * std::fabs(vdot(s.wi, kFrame.n)) / s.pdf;
            if (s.isDelta) {
                observed[hist.cells()] += 1.0;
            } else {
                observed[hist.cell(frameToLocal(kFrame, s.wi))] += 1.0;
                if (i % 16 == 0) {
                    float pf, pr;
                    Spectrum f =
                        bsdfEval(&scene, material, kNoUv, kFrame, wo, s.wi, adjoint, &pf, &pr);
                    out.worstSampleVsEval = std::max({out.worstSampleVsEval, rel(f.c[0], s.f.c[0]),
                                                      rel(pf, s.pdf), rel(pr, s.pdfRev)});
                }
            }
        }
        sum += w;
        sum2 += w * w;
    }
    out.deltaFraction = observed[hist.cells()] / samples;
    out.albedoMean = sum / samples;
    out.albedoStdErr =
        std::sqrt(std::max(0.0, sum2 / samples - out.albedoMean * out.albedoMean) / samples);
    std::vector<double> expected = hist.integrate(
        [&](Vec3 wl) {
            float pf, pr;
            bsdfEval(&scene, material, kNoUv, kFrame, wo, frameToWorld(kFrame, wl), 0, &pf, &pr);
            return static_cast<double>(pf);
        },
        quadrature);
    std::vector<double> albedo = hist.integrate(
        [&](Vec3 wl) {
            float pf, pr;
            Spectrum f = bsdfEval(&scene, material, kNoUv, kFrame, wo, frameToWorld(kFrame, wl),
                                  adjoint, &pf, &pr);
            return static_cast<double>(f.c[0]) * std::fabs(wl.z);
        },
        2);
    for (double a : albedo)
        out.albedoQuad += a;
    for (double& e : expected) {
        out.pdfIntegral += e;
        e *= samples;
    }
    expected.push_back(deltaMass * samples);
    expected.push_back(std::max(0.0, 1.0 - out.pdfIntegral - deltaMass) * samples);
    out.chi2 = cbtest::chi2Test(observed, expected, kLevel, 5.0, 1e-5 * samples);
    return out;
}

// The chi-square, pdf-integral and albedo checks shared by every non-delta material.
void checkNonDelta(const SceneView& scene, int material, double deltaMass, bool conservesMass,
                   std::initializer_list<float> cosines, unsigned seed, int adjoint = 0,
                   int quadrature = 2) {
    int k = 0;
    for (float c : cosines) {
        Vec3 wo = worldDir(c, 0.7f + 1.3f * k);
        SamplerCheck r =
            checkSampler(scene, material, wo, deltaMass, 200000, seed + k, adjoint, quadrature);
        ++k;
        INFO("material " << material << ", cos wo = " << c << ": " << r.chi2.message
                         << ", pdf integral " << r.pdfIntegral << ", albedo " << r.albedoQuad
                         << " / " << r.albedoMean << " +- " << r.albedoStdErr);
        CHECK(r.chi2.passed);
        if (conservesMass) CHECK(r.pdfIntegral == doctest::Approx(1.0 - deltaMass).epsilon(2e-3));
        CHECK(r.pdfIntegral <= 1.0 - deltaMass + 2e-3);
        CHECK(r.albedoQuad <= 1.0 + 2e-3);
        CHECK(r.albedoMean <= 1.0 + 5.0 * r.albedoStdErr + 1e-6);
        if (deltaMass == 0.0)
            CHECK(r.deltaFraction == 0.0);
        else {
            double sigma = std::sqrt(deltaMass * (1.0 - deltaMass) / 200000.0);
            CHECK(std::fabs(r.deltaFraction - deltaMass) < 5.0 * sigma);
        }
        CHECK(r.worstSampleVsEval < 2e-3);
    }
}

} // namespace

TEST_CASE("diffuse: sampling matches pdf, pdf and albedo integrate to 1, two-sided") {
    Fixture fx;
    SceneView v = fx.s.view();
    checkNonDelta(v, fx.diffuse, 0.0, true, {0.95f, 0.6f, 0.05f, -0.5f}, 10);
    // Albedo of a white Lambertian is exactly 1 and every sample carries weight R.
    Uniform u(11);
    for (int i = 0; i < 1000; ++i) {
        Vec3 wo = worldDir(i % 2 ? 0.4f : -0.4f, 0.1f * i);
        BsdfSample s;
        REQUIRE(bsdfSample(&v, fx.diffuseTint, kNoUv, kFrame, wo, u(), u(), u(), 0, &s));
        CHECK(vdot(s.wi, kFrame.n) * vdot(wo, kFrame.n) > 0.0f);
        double w = s.f.c[1] * vabsdot(s.wi, kFrame.n) / s.pdf;
        CHECK(w == doctest::Approx(0.6).epsilon(1e-5));
        CHECK(s.isDelta == 0);
    }
}

TEST_CASE("rough conductor alpha 0.05: sampling matches pdf, mass and albedo <= 1") {
    Fixture fx;
    SceneView v = fx.s.view();
    checkNonDelta(v, fx.rough005, 0.0, false, {0.95f, 0.6f, 0.05f, -0.5f}, 20);
}

TEST_CASE("rough conductor alpha 0.3: sampling matches pdf, mass and albedo <= 1") {
    Fixture fx;
    SceneView v = fx.s.view();
    checkNonDelta(v, fx.rough03, 0.0, false, {0.95f, 0.6f, 0.05f, -0.5f}, 30);
}

TEST_CASE("rough conductor alpha 1: sampling matches pdf, mass and albedo <= 1") {
    Fixture fx;
    SceneView v = fx.s.view();
    checkNonDelta(v, fx.rough1, 0.0, false, {0.95f, 0.6f, 0.05f}, 40);
}

TEST_CASE("mixtures of diffuse and rough conductor: sampling matches the mixture pdf") {
    Fixture fx;
    SceneView v = fx.s.view();
    checkNonDelta(v, fx.mixDiffuseRough, 0.0, false, {0.9f, 0.3f, 0.05f}, 50);
    checkNonDelta(v, fx.mixDiffuseGlossy, 0.0, false, {0.8f, -0.2f}, 60);
}

TEST_CASE("mixtures with a delta component: non-delta pdf and delta probability match") {
    Fixture fx;
    SceneView v = fx.s.view();
    checkNonDelta(v, fx.mixDragon, 0.3, true, {0.7f, 0.05f}, 70);
    checkNonDelta(v, fx.mixDiffuseGlass, 0.5, true, {0.7f, -0.7f}, 80);
}

TEST_CASE("mixes of mixes: f and pdfs are the leaves' weighted by the amounts' products") {
    Fixture fx;
    SceneView v = fx.s.view();
    struct Leaf {
        int material;
        double weight;
    };
    const std::vector<std::pair<int, std::vector<Leaf>>> mixes = {
        {fx.mixNested, {{fx.diffuseTint, 0.4}, {fx.rough03, 0.3}, {fx.goldMirror, 0.3}}},
        {fx.mixNestedGlossy, {{fx.diffuse, 0.5}, {fx.rough005, 0.125}, {fx.rough03, 0.375}}}};
    Uniform u(15);
    for (const auto& [mix, leaves] : mixes) {
        for (int i = 0; i < 2000; ++i) {
            const Vec3 wo = frameToWorld(kFrame, sampleUniformSphere(u(), u()));
            const Vec3 wi = frameToWorld(kFrame, sampleUniformSphere(u(), u()));
            float pf, pr;
            const Spectrum f = bsdfEval(&v, mix, kNoUv, kFrame, wo, wi, i % 2, &pf, &pr);
            double expectedF[3] = {0, 0, 0}, expectedFwd = 0.0, expectedRev = 0.0;
            for (const Leaf& leaf : leaves) {
                float lf, lr;
                const Spectrum g =
                    bsdfEval(&v, leaf.material, kNoUv, kFrame, wo, wi, i % 2, &lf, &lr);
                for (int c = 0; c < 3; ++c)
                    expectedF[c] += leaf.weight * g.c[c];
                expectedFwd += leaf.weight * lf;
                expectedRev += leaf.weight * lr;
            }
            for (int c = 0; c < 3; ++c)
                CHECK(f.c[c] == doctest::Approx(expectedF[c]).epsilon(1e-6).scale(1e-30));
            CHECK(pf == doctest::Approx(expectedFwd).epsilon(1e-6).scale(1e-30));
            CHECK(pr == doctest::Approx(expectedRev).epsilon(1e-6).scale(1e-30));
        }
    }
    // Sampling: the chain's choices give each leaf its weight (the mirror's as the delta mass).
    checkNonDelta(v, fx.mixNested, 0.3, false, {0.8f, 0.3f}, 300);
    checkNonDelta(v, fx.mixNestedGlossy, 0.0, false, {0.9f, 0.2f}, 310);
    // A chain of delta materials: each leaf chosen by its weight, told apart by its colour
    // (the tint's mirror red / blue 2, the gold one's 3.8, the glass's 1).
    const Vec3 wo = worldDir(0.6f, 0.2f);
    std::array<int, 3> count{}; // tint mirror, gold mirror, glass
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        BsdfSample s{};
        REQUIRE(bsdfSample(&v, fx.mixNestedDelta, kNoUv, kFrame, wo, u(), u(), u(), 0, &s));
        REQUIRE(s.isDelta);
        const double ratio = s.f.c[0] / s.f.c[2];
        const size_t leaf = ratio > 3.0 ? 1 : ratio > 1.5 ? 0 : 2;
        count[leaf] += 1;
        // A delta sample's pdf is its probability: the leaf's weight times its lobe's.
        const double fresnel = fresnelRef(0.6, 1.5);
        const double lobe = leaf < 2 ? 1.0 : vdot(s.wi, kFrame.n) > 0.0f ? fresnel : 1.0 - fresnel;
        CHECK(s.pdf == doctest::Approx(std::array{0.3, 0.42, 0.28}[leaf] * lobe).epsilon(1e-4));
    }
    const std::array<double, 3> share{0.3, 0.7 * 0.6, 0.7 * 0.4};
    for (size_t k = 0; k < 3; ++k)
        CHECK(std::fabs(double(count[k]) / n - share[k]) <
              4.5 * std::sqrt(share[k] * (1 - share[k]) / n));
    CHECK(materialSpecularity(&v, fx.mixNested) == doctest::Approx(0.6));
    CHECK(materialSpecularity(&v, fx.mixNestedGlossy) == doctest::Approx(0.5));
    CHECK(materialHasNonDelta(&v, fx.mixNested));
    CHECK(!materialHasNonDelta(&v, fx.mixNestedDelta));
}

TEST_CASE("rough conductor loses mass only by masking, near-normal incidence keeps almost all") {
    Fixture fx;
    SceneView v = fx.s.view();
    // At normal incidence and alpha = 0.05 almost no reflected direction goes below the surface,
    // and GGX with a constant Fresnel of 1 then reflects all but a sliver of the energy.
    SamplerCheck r = checkSampler(v, fx.rough005, worldDir(1.0f, 0.0f), 0.0, 100000, 90);
    CHECK(r.pdfIntegral == doctest::Approx(1.0).epsilon(2e-3));
    CHECK(r.albedoQuad == doctest::Approx(1.0).epsilon(1e-2));
    CHECK(r.albedoQuad <= 1.0 + 2e-3);
}

TEST_CASE("reflection BSDFs are reciprocal and pdfRev is the swapped pdfFwd") {
    Fixture fx;
    SceneView v = fx.s.view();
    Uniform u(12);
    for (int m : {fx.diffuse, fx.rough005, fx.rough03, fx.rough1, fx.mixDiffuseRough,
                  fx.mixDiffuseGlossy, fx.mixDragon, fx.goldFresnelRough, fx.mixDiffuseGoldRough,
                  fx.anisoConductor, fx.anisoGold}) {
        int nonZero = 0;
        for (int i = 0; i < 2000; ++i) {
            Vec3 a = frameToWorld(kFrame, sampleUniformSphere(u(), u()));
            Vec3 b = frameToWorld(kFrame, sampleUniformSphere(u(), u()));
            float pab, rab, pba, rba;
            Spectrum fab = bsdfEval(&v, m, kNoUv, kFrame, a, b, 0, &pab, &rab);
            Spectrum fba = bsdfEval(&v, m, kNoUv, kFrame, b, a, 0, &pba, &rba);
            bool sameSide = vdot(a, kFrame.n) * vdot(b, kFrame.n) > 0.0f;
            INFO("material " << m);
            if (!sameSide) {
                CHECK(fab.c[0] == 0.0f);
                CHECK(pab == 0.0f);
                continue;
            }
            ++nonZero;
            for (int c = 0; c < 3; ++c)
                CHECK(rel(fab.c[c], fba.c[c]) < 1e-4);
            CHECK(rel(pab, rba) < 1e-4);
            CHECK(rel(pba, rab) < 1e-4);
        }
        CHECK(nonZero > 500);
    }
}

TEST_CASE("conductor Fresnel: the complex-amplitude form, its limits and stiff indices") {
    // Against the complex form in double on a grid of angles and indices, from index-matched
    // (eta 1, k 0) through metals to stiff ones (eta, k from 1e-6 to 1e6).
    double worst = 0.0;
    const double indices[] = {0.0, 1e-6, 1e-3, 0.05, 0.166, 0.43, 1.0, 1.5, 3.15, 10.0, 1e3, 1e6};
    const double cosines[] = {1.0, 0.99, 0.8, 0.5, 0.2, 0.05, 1e-3, 1e-6, 0.0};
    for (double eta : indices)
        for (double k : indices)
            for (double c : cosines) {
                // No medium, or no interface at grazing: the complex form divides 0 by 0.
                if ((eta == 0.0 || (eta == 1.0 && c == 0.0)) && k == 0.0) continue;
                const float f = fresnelConductor(float(c), float(eta), float(k));
                const double ref =
                    conductorFresnel(double(float(c)), double(float(eta)), double(float(k)));
                INFO("cos " << c << " eta " << eta << " k " << k << ": " << f << " vs " << ref);
                REQUIRE(std::isfinite(f));
                REQUIRE(f >= 0.0f);
                REQUIRE(f <= 1.0f);
                // Absolute: near index matching the reflectance is 0 and float's rounding of
                // a^2 + b^2 ~ 1 leaves ~1e-7.
                worst = std::max(worst, std::fabs(f - ref));
                CHECK(std::fabs(f - ref) < 1e-6);
            }
    MESSAGE("worst |F - F_complex| " << worst);
    // Normal incidence: ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2); grazing: 1.
    for (double eta : {0.2, 1.0, 2.5})
        for (double k : {0.0, 0.5, 3.0}) {
            const double normal = ((eta - 1) * (eta - 1) + k * k) / ((eta + 1) * (eta + 1) + k * k);
            CHECK(fresnelConductor(1.0f, float(eta), float(k)) ==
                  doctest::Approx(normal).epsilon(1e-6).scale(1.0));
            if (eta != 1.0 || k != 0.0)
                CHECK(fresnelConductor(0.0f, float(eta), float(k)) == doctest::Approx(1.0));
        }
    // k = 0 is a dielectric seen from outside: the dielectric's Fresnel (eta > 1 and < 1, with
    // total internal reflection).
    for (double eta : {1.33, 1.5, 2.4, 0.7})
        for (double c : {1.0, 0.9, 0.6, 0.3, 0.1}) {
            float cosT;
            CHECK(fresnelConductor(float(c), float(eta), 0.0f) ==
                  doctest::Approx(fresnelDielectric(float(c), float(eta), &cosT)).epsilon(1e-5));
        }
    // eta = k = 0 reflects everything (the limit of the complex form), also at normal incidence.
    for (double c : cosines)
        CHECK(fresnelConductor(float(c), 0.0f, 0.0f) == 1.0f);
    // eta = 1, k = 0 is no interface: nothing is reflected, also at grazing (the limit).
    for (double c : cosines)
        CHECK(fresnelConductor(float(c), 1.0f, 0.0f) <= 1e-6f);
}

TEST_CASE("Fresnel conductor: mirror and rough lobes carry F(wo . wm) per channel") {
    Fixture fx;
    SceneView v = fx.s.view();
    const float eta[3] = {0.166f, 0.43f, 1.5f}, k[3] = {3.15f, 2.45f, 1.88f};
    // The mirror: throughput F(cos wo) per channel.
    for (float c : {1.0f, 0.7f, 0.2f, 0.02f, -0.5f}) {
        Vec3 wo = worldDir(c, 1.0f);
        BsdfSample s;
        REQUIRE(bsdfSample(&v, fx.goldFresnelMirror, kNoUv, kFrame, wo, 0.3f, 0.8f, 0.5f, 0, &s));
        CHECK(s.isDelta == 1);
        const float cosI = vabsdot(s.wi, kFrame.n);
        for (int ch = 0; ch < 3; ++ch)
            CHECK(s.f.c[ch] * cosI / s.pdf ==
                  doctest::Approx(conductorFresnel(std::fabs(c), eta[ch], k[ch])).epsilon(2e-5));
    }
    // The rough lobe: f equals the tint-1 GGX lobe times F at the half vector, in eval and in
    // sample, so MIS and the sampler see the same function.
    Uniform u(18);
    int checked = 0;
    for (int i = 0; i < 2000; ++i) {
        Vec3 wo = worldDir(0.05f + 0.95f * u(), 6.28f * u());
        BsdfSample s;
        if (!bsdfSample(&v, fx.goldFresnelRough, kNoUv, kFrame, wo, u(), u(), u(), 0, &s)) continue;
        float pf, pr, pf1, pr1;
        Spectrum f = bsdfEval(&v, fx.goldFresnelRough, kNoUv, kFrame, wo, s.wi, 0, &pf, &pr);
        Spectrum one = bsdfEval(&v, fx.rough03, kNoUv, kFrame, wo, s.wi, 0, &pf1, &pr1);
        const Vec3 h = vnormalize(vadd(wo, s.wi));
        const double cosH = std::fabs(vdot(wo, h));
        for (int ch = 0; ch < 3; ++ch) {
            const double fr = conductorFresnel(cosH, eta[ch], k[ch]);
            CHECK(f.c[ch] == doctest::Approx(one.c[ch] * fr).epsilon(1e-3));
            CHECK(s.f.c[ch] == doctest::Approx(f.c[ch]).epsilon(2e-3));
        }
        CHECK(pf == pf1);
        CHECK(pr == pr1);
        ++checked;
    }
    CHECK(checked > 1800);
    checkNonDelta(v, fx.goldFresnelRough, 0.0, false, {0.9f, 0.3f, 0.05f}, 95);
    checkNonDelta(v, fx.mixDiffuseGoldRough, 0.0, false, {0.8f, -0.2f}, 96);
}

TEST_CASE("rough dielectric: sampling matches pdf on both sides, energy <= 1 (adjoint)") {
    Fixture fx;
    SceneView v = fx.s.view();
    // Negative cosines: wo inside the glass (total internal reflection beyond the critical
    // angle). The albedo of the adjoint BSDF is the energy scattered from wo, at most 1; the
    // radiance BSDF's transmission carries eta^2 (Veach 1997, sec. 5.2).
    // The pdf drops to 0 across curves inside the cells (back-facing microfacets, total
    // internal reflection): 12 x 12 Gauss sub-cells; with 2, its integral was off by 0.4%.
    checkNonDelta(v, fx.roughGlass01, 0.0, false, {0.9f, 0.1f, -0.8f, -0.3f}, 200, 1, 12);
    checkNonDelta(v, fx.roughGlass05, 0.0, false, {0.4f, 0.1f, -0.8f}, 210, 1, 12);
    checkNonDelta(v, fx.mixDiffuseRoughGlass, 0.0, false, {0.6f, -0.5f}, 220, 1, 12);
    // Near normal incidence and alpha 0.1 almost nothing is masked: the sampler keeps nearly
    // all its mass and the energy is nearly 1 from outside.
    SamplerCheck r = checkSampler(v, fx.roughGlass01, worldDir(1.0f, 0.0f), 0.0, 100000, 230, 1);
    CHECK(r.pdfIntegral == doctest::Approx(1.0).epsilon(1e-2));
    CHECK(r.albedoQuad == doctest::Approx(1.0).epsilon(2e-2));
}

TEST_CASE("anisotropic GGX conductor and dielectric: sampling matches pdf, the frame turns the "
          "lobe") {
    Fixture fx;
    SceneView v = fx.s.view();
    checkNonDelta(v, fx.anisoConductor, 0.0, false, {0.9f, 0.4f, 0.1f}, 240);
    checkNonDelta(v, fx.anisoGlass, 0.0, false, {0.8f, 0.2f, -0.6f}, 250, 1, 12);
    // The lobe of alphas (a, b) in a frame is that of (b, a) in the frame turned by 90 degrees
    // about the normal; in the frame itself the two differ.
    Frame turned = kFrame;
    turned.s = kFrame.t;
    turned.t = vneg(kFrame.s);
    Uniform u(13);
    double largestDifference = 0.0;
    for (int i = 0; i < 2000; ++i) {
        const Vec3 wo = frameToWorld(kFrame, sampleUniformHemisphere(u(), u()));
        const Vec3 wi = frameToWorld(kFrame, sampleUniformHemisphere(u(), u()));
        float pf, pr, pfTurned, prTurned, pfSame, prSame;
        const Spectrum f = bsdfEval(&v, fx.anisoGold, kNoUv, kFrame, wo, wi, 0, &pf, &pr);
        const Spectrum fTurned =
            bsdfEval(&v, fx.anisoGoldSwapped, kNoUv, turned, wo, wi, 0, &pfTurned, &prTurned);
        const Spectrum fSame =
            bsdfEval(&v, fx.anisoGoldSwapped, kNoUv, kFrame, wo, wi, 0, &pfSame, &prSame);
        for (int c = 0; c < 3; ++c)
            CHECK(rel(f.c[c], fTurned.c[c]) < 1e-4);
        CHECK(rel(pf, pfTurned) < 1e-4);
        CHECK(rel(pr, prTurned) < 1e-4);
        largestDifference = std::max(largestDifference, rel(f.c[0], fSame.c[0]));
    }
    CHECK(largestDifference > 0.5);
}

TEST_CASE("rough dielectric: the adjoint is the transpose, pdfRev the swapped pdf, float as "
          "double") {
    // The kernels' code in double (the float64 check's oracle) and in float, on glass of alpha
    // 0.1 (eta 1.5) and 0.5 (eta 1.33) and a diffuse-glass mix; a point light only to be valid.
    const cb::DeviceScene scene = cb::buildDeviceScene(
        cb::parseSceneString(
            "WorldBegin\nLightSource \"point\"\n"
            "MakeNamedMaterial \"g01\" \"string type\" \"dielectric\" \"float eta\" 1.5 "
            "\"float roughness\" 0.01\n"
            "MakeNamedMaterial \"g05\" \"string type\" \"dielectric\" \"float eta\" 1.33 "
            "\"float roughness\" 0.25\n"
            "MakeNamedMaterial \"d\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.8 0.6 "
            "0.4]\n"
            "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"d\" \"g05\"]\n"
            "NamedMaterial \"m\"\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n",
            "t.pbrt"),
        cb::ChannelMode::Rgb);
    const auto single =
        cb::float64::makeHostKernels(cb::sceneBytes(scene), cb::float64::Precision::Float);
    const auto wide =
        cb::float64::makeHostKernels(cb::sceneBytes(scene), cb::float64::Precision::Double);
    const std::array<double, 3> n{0.3 / std::sqrt(0.98), -0.5 / std::sqrt(0.98),
                                  0.8 / std::sqrt(0.98)};
    // Unit length in double: the half vector of directions 1e-7 off unit length bisects them
    // only to 1e-7, which the double check would see.
    auto array = [](Vec3 v) {
        const double l = std::sqrt(double(v.x) * v.x + double(v.y) * v.y + double(v.z) * v.z);
        return std::array<double, 3>{v.x / l, v.y / l, v.z / l};
    };
    Uniform u(19);
    // g01, g05, m: the materials in the order of their definition.
    for (int m : {0, 1, 3}) {
        const Material& mat = scene.materials[size_t(m)];
        const double eta =
            mat.kind == CB_MAT_MIX ? scene.materials[size_t(mat.mixSecond)].eta : mat.eta;
        int transmitted = 0, reflected = 0, loose = 0;
        double worstDouble = 0.0, worstFloat = 0.0;
        int looseDouble = 0;
        for (int i = 0; i < 4000; ++i) {
            const auto a = array(sampleUniformSphere(u(), u()));
            const auto b = array(sampleUniformSphere(u(), u()));
            const double an = a[0] * n[0] + a[1] * n[1] + a[2] * n[2];
            const double bn = b[0] * n[0] + b[1] * n[1] + b[2] * n[2];
            const cb::float64::BsdfValue ab = wide->bsdf(m, n, a, b, 0);
            const cb::float64::BsdfValue adj = wide->bsdf(m, n, a, b, 1);
            const cb::float64::BsdfValue baAdj = wide->bsdf(m, n, b, a, 1);
            const cb::float64::BsdfValue abFloat = single->bsdf(m, n, a, b, 0);
            INFO("material " << m << " a.n " << an << " b.n " << bn);
            if (ab.f == 0.0) continue;
            (an * bn > 0.0 ? reflected : transmitted) += 1;
            // In double, f*(a, b) = f(b, a) (importance against radiance) and pdfRev is the
            // swapped pdfFwd, to the frame's accuracy: frameFromNormal's rotation constants are
            // float literals, so local directions are unit only to ~2e-8 in double too, which
            // near the critical angle (T = 1 - F, infinitely steep there) moves a value by up to
            // 8.4e-3 (measured). Relative to the value plus 1e-4 (f and pdf are O(1) and above):
            // 98% of the pairs to 1e-5, all to 1e-2. Densities do not depend on the transported
            // quantity, and the adjoint's eta^2 is exact.
            auto close = [](double x, double y) {
                return std::fabs(x - y) / (std::max(std::fabs(x), std::fabs(y)) + 1e-4);
            };
            const double transposed =
                std::max({close(ab.f, baAdj.f), close(ab.pdfRev, baAdj.pdfFwd),
                          close(ab.pdfFwd, baAdj.pdfRev)});
            CHECK(transposed < 1e-2);
            looseDouble += transposed >= 1e-5 ? 1 : 0;
            worstDouble = std::max(worstDouble, transposed);
            CHECK(adj.pdfFwd == ab.pdfFwd);
            // Transmission: radiance carries (n_a / n_b)^2 over importance (Veach 1997, sec.
            // 5.2); a mix's diffuse part transmits nothing.
            if (an * bn < 0.0)
                CHECK(ab.f == doctest::Approx(adj.f * (an > 0.0 ? 1.0 / (eta * eta) : eta * eta))
                                  .epsilon(1e-12));
            // Float against double: 98% of the pairs to 1e-4; all to 2e-2, the oracle itself
            // being off by up to 8.4e-3 near the critical angle (measured worst 1.1e-2).
            const double worst = std::max({close(abFloat.f, ab.f), close(abFloat.pdfFwd, ab.pdfFwd),
                                           close(abFloat.pdfRev, ab.pdfRev)});
            CHECK(worst < 2e-2);
            worstFloat = std::max(worstFloat, worst);
            loose += worst >= 1e-4 ? 1 : 0;
        }
        CHECK(transmitted > 200);
        CHECK(reflected > 200);
        CHECK(looseDouble <= (transmitted + reflected) / 50);
        CHECK(loose <= (transmitted + reflected) / 50);
        MESSAGE("material " << m << ": double transpose worst " << worstDouble << ", "
                            << looseDouble << " above 1e-5; float against double " << loose
                            << " above 1e-4 (worst " << worstFloat << "), of "
                            << transmitted + reflected);
    }
}

TEST_CASE("rough dielectric of alpha 1e-4: Fresnel's split and Snell's directions") {
    Fixture fx;
    SceneView v = fx.s.view();
    Uniform u(20);
    for (float c : {0.9f, 0.5f, -0.85f, -0.95f}) { // inside: below the critical angle
        const Vec3 wo = worldDir(c, 0.4f);
        const bool outside = c > 0.0f;
        const float eta = outside ? 1.5f : 1.0f / 1.5f;
        float cosT;
        const float fr = fresnelDielectric(std::fabs(c), eta, &cosT);
        // GGX's tails tilt about alpha^2 / theta^2 of the microfacets by more than theta: 98% of
        // the directions lie within 1e-3 of the smooth ones.
        int reflections = 0, off = 0, n = 20000;
        for (int i = 0; i < n; ++i) {
            BsdfSample s;
            REQUIRE(bsdfSample(&v, fx.roughGlassTiny, kNoUv, kFrame, wo, u(), u(), u(), 0, &s));
            CHECK(s.isDelta == 0);
            const float cosI = vdot(s.wi, kFrame.n);
            if (cosI * c > 0.0f) {
                ++reflections;
                off += std::fabs(cosI - c) > 1e-3f * std::fabs(c) ? 1 : 0;
            } else {
                off += std::fabs(std::fabs(cosI) - cosT) > 1e-3f * cosT ? 1 : 0;
            }
        }
        const double sigma = std::sqrt(fr * (1.0 - fr) / n);
        CAPTURE(c);
        CHECK(std::fabs(double(reflections) / n - fr) <= 5.0 * sigma + 1e-4);
        CHECK(off <= n / 50);
    }
}

TEST_CASE("diffuse transmission: sampling matches pdf on both sides, albedo R + T, symmetric") {
    Fixture fx;
    SceneView v = fx.s.view();
    // Channel 0: R = 0.5, T = 0.35, so the albedo is 0.85 from either side.
    checkNonDelta(v, fx.translucent, 0.0, true, {0.9f, 0.3f, 0.02f, -0.6f}, 300);
    checkNonDelta(v, fx.transmitterOnly, 0.0, true, {0.7f, -0.2f}, 310);
    checkNonDelta(v, fx.mixDiffuseTranslucent, 0.0, true, {0.5f, -0.9f}, 320);
    SamplerCheck r = checkSampler(v, fx.translucent, worldDir(-0.4f, 1.0f), 0.0, 100000, 330);
    CHECK(r.albedoQuad == doctest::Approx(0.85).epsilon(2e-3));
    CHECK(std::fabs(r.albedoMean - 0.85) < 5.0 * r.albedoStdErr);
    // f is R / pi on wo's side and T / pi on the other, the same both ways (no eta: one medium
    // on both sides), and pdfRev is the swapped pdfFwd.
    Uniform u(331);
    int across = 0;
    for (int i = 0; i < 2000; ++i) {
        Vec3 a = frameToWorld(kFrame, sampleUniformSphere(u(), u()));
        Vec3 b = frameToWorld(kFrame, sampleUniformSphere(u(), u()));
        float pab, rab, pba, rba;
        Spectrum fab = bsdfEval(&v, fx.translucent, kNoUv, kFrame, a, b, i % 2, &pab, &rab);
        Spectrum fba = bsdfEval(&v, fx.translucent, kNoUv, kFrame, b, a, 0, &pba, &rba);
        bool sameSide = vdot(a, kFrame.n) * vdot(b, kFrame.n) > 0.0f;
        across += sameSide ? 0 : 1;
        const float expected[2][3] = {{0.35f, 0.45f, 0.1f}, {0.5f, 0.3f, 0.2f}};
        for (int c = 0; c < 3; ++c) {
            CHECK(fab.c[c] == doctest::Approx(expected[sameSide][c] / M_PI).epsilon(1e-6));
            CHECK(rel(fab.c[c], fba.c[c]) < 1e-6);
        }
        const double lobe = sameSide ? 0.5 / 0.95 : 0.45 / 0.95;
        CHECK(pab == doctest::Approx(lobe * std::fabs(vdot(b, kFrame.n)) / M_PI).epsilon(1e-5));
        CHECK(rel(pab, rba) < 1e-5);
        CHECK(rel(pba, rab) < 1e-5);
    }
    CHECK(across > 800);
    // One black side: that lobe is never sampled and has no density; every sample carries the
    // other side's spectrum as its weight.
    for (int m : {fx.transmitterOnly, fx.reflectorOnly}) {
        Uniform w(332);
        for (int i = 0; i < 500; ++i) {
            Vec3 wo = worldDir(i % 2 ? 0.6f : -0.3f, 0.2f * i);
            BsdfSample s{};
            REQUIRE(bsdfSample(&v, m, kNoUv, kFrame, wo, w(), w(), w(), 0, &s));
            bool transmitted = vdot(s.wi, kFrame.n) * vdot(wo, kFrame.n) < 0.0f;
            CHECK(transmitted == (m == fx.transmitterOnly));
            double weight = s.f.c[1] * vabsdot(s.wi, kFrame.n) / s.pdf;
            CHECK(weight == doctest::Approx(0.6).epsilon(1e-5));
            float pf, pr;
            Vec3 mirrored = vsub(s.wi, vscale(kFrame.n, 2.0f * vdot(s.wi, kFrame.n)));
            CHECK(specIsBlack(bsdfEval(&v, m, kNoUv, kFrame, wo, mirrored, 0, &pf, &pr)));
            CHECK(pf == 0.0f);
        }
    }
    // Both sides black: no sample, no value.
    TestScene blackScene;
    int none = blackScene.spectrum(0.0f, 0.0f, 0.0f);
    int blackMaterial = blackScene.diffuseTransmission(none, none);
    SceneView bv = blackScene.view();
    BsdfSample s;
    CHECK(!bsdfSample(&bv, blackMaterial, kNoUv, kFrame, worldDir(0.5f, 0.0f), 0.3f, 0.3f, 0.3f, 0,
                      &s));
    CHECK(materialSpecularity(&v, fx.translucent) == 0.0f);
    CHECK(bsdfReadsLobeSample(&v, fx.translucent));
}

TEST_CASE("thin dielectric: the sheet's reflectance from both sides, straight transmission") {
    Fixture fx;
    SceneView v = fx.s.view();
    for (int m : {fx.thinGlass, fx.thinLowIndex, fx.thinTinyIndex, fx.thinHugeIndex})
        for (float c : {1.0f, 0.8f, 0.3f, 0.05f, -0.5f, -0.95f}) {
            const double eta = v.materials[m].eta;
            // The sheet: the first face's Fresnel R (in double, fresnelRef), then what leaves
            // through it after each odd number of internal reflections, T R T, T R^3 T, ...:
            // R + T^2 R / (1 - R^2) (pbrt-v4's form; a series would need ~1e5 terms at R near 1).
            const double r1 = fresnelRef(std::fabs(c), eta), t1 = 1.0 - r1;
            const double sheet = r1 < 1.0 ? r1 + t1 * t1 * r1 / (1.0 - r1 * r1) : 1.0;
            CAPTURE(eta);
            CAPTURE(c);
            Vec3 wo = worldDir(c, 0.4f);
            BsdfSample s;
            // uLobe just below and at the reflectance picks reflection, then transmission.
            REQUIRE(bsdfSample(&v, m, kNoUv, kFrame, wo, 0.5f, 0.5f, float(sheet) * 0.999f, 0, &s));
            CHECK(s.isDelta == 1);
            CHECK(s.pdf == doctest::Approx(sheet).epsilon(2e-6));
            CHECK(s.pdfRev == s.pdf);
            Vec3 mirror = vsub(vscale(kFrame.n, 2.0f * vdot(wo, kFrame.n)), wo);
            CHECK(angleBetween(s.wi, mirror) < 1e-6);
            CHECK(s.f.c[2] * vabsdot(s.wi, kFrame.n) / s.pdf == doctest::Approx(1.0).epsilon(1e-5));
            if (sheet < 0.999) {
                for (int adjoint = 0; adjoint < 2; ++adjoint) {
                    REQUIRE(bsdfSample(&v, m, kNoUv, kFrame, wo, 0.5f, 0.5f,
                                       float(sheet) * 1.001f + 1e-4f, adjoint, &s));
                    CHECK(s.pdf == doctest::Approx(1.0 - sheet).epsilon(2e-5));
                    CHECK(s.pdfRev == s.pdf);
                    // Unbent, and no eta^2: the same medium on both sides.
                    CHECK(angleBetween(s.wi, vscale(wo, -1.0f)) < 1e-6);
                    CHECK(s.f.c[0] * vabsdot(s.wi, kFrame.n) / s.pdf ==
                          doctest::Approx(1.0).epsilon(1e-5));
                }
            }
        }
    // Frequencies: reflection in proportion R over uniform uLobe; bsdfEval has no non-delta part.
    Uniform u(340);
    Vec3 wo = worldDir(0.3f, 1.0f);
    const double expected = [] {
        const double r = fresnelRef(0.3, 1.5);
        return 2.0 * r / (1.0 + r);
    }();
    int reflected = 0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        BsdfSample s{};
        REQUIRE(bsdfSample(&v, fx.thinGlass, kNoUv, kFrame, wo, u(), u(), u(), 0, &s));
        reflected += vdot(s.wi, kFrame.n) > 0.0f ? 1 : 0;
    }
    CHECK(std::fabs(reflected / double(n) - expected) <
          5.0 * std::sqrt(expected * (1 - expected) / n));
    float pf, pr;
    CHECK(
        specIsBlack(bsdfEval(&v, fx.thinGlass, kNoUv, kFrame, wo, vscale(wo, -1.0f), 0, &pf, &pr)));
    CHECK(!materialHasNonDelta(&v, fx.thinGlass));
    CHECK(materialHasNonDelta(&v, fx.mixTranslucentThin));
    CHECK(materialSpecularity(&v, fx.thinGlass) == 1.0f);
    CHECK(materialSpecularity(&v, fx.mixTranslucentThin) == 0.5f);
    checkNonDelta(v, fx.mixTranslucentThin, 0.5, true, {0.7f, -0.4f}, 341);
}

// pbrt-v4's coated diffuse estimates f by a random walk (cb_bsdf.h), so its sampler is checked
// against closed forms (tests/layered_reference.h) instead of a chi-square against bsdfEval's
// pdf, which is an estimate only MIS uses.
TEST_CASE("coated diffuse: the walk's albedo and f against the closed form, adjoint, pdfs") {
    Fixture fx;
    SceneView v = fx.s.view();
    struct Case {
        int material;
        double rho, eta, thickness;
        int depth;
    };
    // Channel 0 of tint and gold: 0.8 and 0.68.
    const Case cases[] = {{fx.coatedThick, 0.8, 1.5, 0.25, 1000},
                          {fx.coatedDefault, 0.8, 1.5, 0.01, 10},
                          {fx.coatedLowIndex, 0.68, 0.7, 0.0, 40}};
    for (const Case& c : cases) {
        CAPTURE(c.material);
        const cbtest::CoatedDiffuseReference ref(c.rho, c.eta, c.thickness, c.depth);
        // Sampling, from both faces: f |cos| / pdf averages to the albedo, the coat's delta
        // reflection is taken with probability R, and every walk's sample carries bsdfEval's pdfs.
        for (float cosO : {0.9f, 0.35f, -0.6f}) {
            CAPTURE(cosO);
            const Vec3 wo = worldDir(cosO, 0.4f);
            Uniform u(500 + unsigned(c.material));
            const int n = 100000;
            double sum = 0.0, sum2 = 0.0, worstPdf = 0.0;
            int deltas = 0, wrongSide = 0;
            // The walk's weights by the cosine of their direction, in 8 bins.
            constexpr int kBins = 8;
            std::array<double, kBins> binSum{}, binSum2{};
            for (int i = 0; i < n; ++i) {
                BsdfSample s;
                double w = 0.0;
                if (bsdfSample(&v, c.material, kNoUv, kFrame, wo, u(), u(), u(), i % 2, &s)) {
                    w = s.f.c[0] * vabsdot(s.wi, kFrame.n) / s.pdf;
                    deltas += s.isDelta;
                    if (!s.isDelta) {
                        const int b =
                            std::min(kBins - 1, int(vabsdot(s.wi, kFrame.n) * float(kBins)));
                        binSum[size_t(b)] += w;
                        binSum2[size_t(b)] += w * w;
                    }
                    wrongSide += vdot(s.wi, kFrame.n) * cosO <= 0.0f;
                    if (!s.isDelta && i % 8 == 0) {
                        float pf, pr;
                        bsdfEval(&v, c.material, kNoUv, kFrame, wo, s.wi, i % 2, &pf, &pr);
                        worstPdf = std::max({worstPdf, rel(pf, s.pdf), rel(pr, s.pdfRev)});
                    }
                }
                sum += w;
                sum2 += w * w;
            }
            const double mean = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
            const double expected = ref.albedo(std::fabs(cosO));
            CAPTURE(mean);
            CAPTURE(se);
            CAPTURE(expected);
            CHECK(std::fabs(mean - expected) < 5.0 * se + 1e-5);
            // Per bin, E[f] mu over its cosines (and azimuths): where the walk leaves to.
            for (int b = 0; b < kBins; ++b) {
                double reference = 0.0;
                const int steps = 200;
                for (int k = 0; k < steps; ++k) {
                    const double mu = (b + (k + 0.5) / steps) / kBins;
                    reference += ref.meanF(std::fabs(cosO), mu) * mu * 2.0 * M_PI / (steps * kBins);
                }
                const double binMean = binSum[size_t(b)] / n;
                const double binSe =
                    std::sqrt(std::max(0.0, binSum2[size_t(b)] / n - binMean * binMean) / n);
                CAPTURE(b);
                CAPTURE(binMean);
                CAPTURE(reference);
                CHECK(std::fabs(binMean - reference) < 5.0 * binSe + 1e-5);
            }
            const double r = cbtest::dielectricFresnel(std::fabs(cosO), c.eta);
            CHECK(std::fabs(double(deltas) / n - r) < 5.0 * std::sqrt(r * (1 - r) / n) + 1e-6);
            CHECK(wrongSide == 0);
            // The sample's pdf is computed before its direction goes to world space and back;
            // near a low index's critical angle the refracted cosine magnifies that rounding.
            CHECK(worstPdf < (c.eta < 1.0 ? 1e-3 : 1e-5));
        }
        // Evaluation: f(wo, wi) is an estimate of E[f] per pair; over random pairs on one face
        // the ratio to E[f] averages to 1, for radiance and for the adjoint with the pair swapped
        // (f* (wi, wo) = f(wo, wi)). Across the faces f is 0: the base transmits nothing.
        Uniform u(600 + unsigned(c.material));
        const int pairs = 4000;
        double ratio[2] = {0, 0}, ratio2[2] = {0, 0};
        int counted = 0;
        for (int i = 0; i < pairs; ++i) {
            const float side = i % 2 ? 1.0f : -1.0f;
            const float cosO = side * (0.05f + 0.95f * u()), cosI = side * (0.05f + 0.95f * u());
            const Vec3 wo = worldDir(cosO, 6.28f * u()), wi = worldDir(cosI, 6.28f * u());
            const double expected = ref.meanF(std::fabs(cosO), std::fabs(cosI));
            float pf, pr;
            const Spectrum f = bsdfEval(&v, c.material, kNoUv, kFrame, wo, wi, 0, &pf, &pr);
            const Spectrum fAdjoint = bsdfEval(&v, c.material, kNoUv, kFrame, wi, wo, 1, &pf, &pr);
            CHECK(specIsFinite(f));
            if (expected == 0.0) { // total internal reflection keeps wo or wi out
                CHECK(specIsBlack(f));
                continue;
            }
            ++counted;
            for (int k = 0; k < 2; ++k) {
                const double q = (k ? fAdjoint : f).c[0] / expected;
                ratio[k] += q;
                ratio2[k] += q * q;
            }
            const Vec3 below = worldDir(-cosI, 1.0f);
            CHECK(specIsBlack(bsdfEval(&v, c.material, kNoUv, kFrame, wo, below, 0, &pf, &pr)));
        }
        REQUIRE(counted > pairs / 20); // eta 0.7 refracts only within 44 degrees of the normal
        for (int k = 0; k < 2; ++k) {
            const double mean = ratio[k] / counted;
            const double se = std::sqrt(std::max(0.0, ratio2[k] / counted - mean * mean) / counted);
            CAPTURE(k);
            CAPTURE(mean);
            CAPTURE(se);
            CHECK(std::fabs(mean - 1.0) < 5.0 * se + 1e-5);
        }
    }
    CHECK(bsdfReadsLobeSample(&v, fx.coatedThick));
    CHECK(materialHasNonDelta(&v, fx.coatedThick));
}

// Both layers smooth: a delta into the mirror direction whose weight averages to the closed form,
// per channel, with the conductor's index taken relative to the coat's.
TEST_CASE("coated conductor, smooth layers: a mirror delta of the closed form's albedo") {
    Fixture fx;
    SceneView v = fx.s.view();
    struct Case {
        int material;
        float eta, thickness;
        int depth;
    };
    const Case cases[] = {{fx.ccSmoothGold, 1.5f, 0.1f, 10},
                          {fx.ccSmoothTint, 1.33f, 0.0f, 1000},
                          {fx.ccSmoothLow, 0.8f, 0.05f, 40}};
    const double goldEta[3] = {0.166, 0.43, 1.5}, goldK[3] = {3.15, 2.45, 1.88};
    const double tint[3] = {0.8, 0.6, 0.4};
    for (const Case& c : cases) {
        CAPTURE(c.material);
        CHECK(!materialHasNonDelta(&v, c.material));
        // (-0.6 would be eta 0.8's critical angle, where float and double disagree on TIR.)
        for (float cosO : {0.9f, 0.35f, -0.7f}) {
            CAPTURE(cosO);
            const Vec3 wo = worldDir(cosO, 0.4f);
            const Vec3 mirror =
                vsub(vscale(kFrame.n, 2.0f * vdot(wo, kFrame.n)), wo); // wo about the normal
            Uniform u(900 + unsigned(c.material));
            const int n = 50000;
            std::array<double, 3> sum{}, sum2{};
            int nonDelta = 0, offMirror = 0;
            for (int i = 0; i < n; ++i) {
                BsdfSample s;
                if (!bsdfSample(&v, c.material, kNoUv, kFrame, wo, u(), u(), u(), i % 2, &s))
                    continue;
                nonDelta += !s.isDelta;
                offMirror += angleBetween(s.wi, mirror) > 1e-3;
                for (int ch = 0; ch < 3; ++ch) {
                    const double w = s.f.c[ch] * vabsdot(s.wi, kFrame.n) / s.pdf;
                    sum[size_t(ch)] += w;
                    sum2[size_t(ch)] += w * w;
                }
            }
            CHECK(nonDelta == 0);
            CHECK(offMirror == 0);
            for (int ch = 0; ch < 3; ++ch) {
                const bool gold = c.material != fx.ccSmoothTint;
                const double eta = gold ? goldEta[ch] : 1.0;
                const double k = gold ? goldK[ch] : cbtest::conductorKFromReflectance(tint[ch]);
                const double expected = cbtest::smoothCoatedConductorAlbedo(
                    std::fabs(cosO), c.eta, eta, k, c.thickness, c.depth);
                const double mean = sum[size_t(ch)] / n;
                const double se = std::sqrt(std::max(0.0, sum2[size_t(ch)] / n - mean * mean) / n);
                CAPTURE(ch);
                CAPTURE(mean);
                CAPTURE(se);
                CAPTURE(expected);
                CHECK(std::fabs(mean - expected) < 5.0 * se + 1e-5);
            }
            // Every pair evaluates to 0: the whole BSDF is the delta.
            float pf, pr;
            CHECK(specIsBlack(
                bsdfEval(&v, c.material, kNoUv, kFrame, wo, worldDir(cosO, 2.0f), 0, &pf, &pr)));
        }
    }
    // A reflectance r reflects r at normal incidence without a coat (eta 1, thickness 0).
    TestScene bare;
    const int r = bare.spectrum(0.3f, 0.6f, 0.95f);
    const int m = bare.coatedConductor(r, -1, 1.0f, 0.0f, 10, 1, 0.0f, 0.0f);
    SceneView bv = bare.view();
    BsdfSample s;
    REQUIRE(bsdfSample(&bv, m, kNoUv, kFrame, kFrame.n, 0.5f, 0.5f, 0.5f, 0, &s));
    const float weight[3] = {0.3f, 0.6f, 0.95f};
    for (int ch = 0; ch < 3; ++ch)
        CHECK(s.f.c[ch] / s.pdf == doctest::Approx(weight[ch]).epsilon(1e-5));
}

// A coat of index 1 and no thickness is no coat: the coated conductor's f is the plain
// conductor's, pair by pair (one visit of the base, looking straight through to wi), and its
// sampled albedo the plain conductor's. This checks the base's lobe and Fresnel in absolute terms.
TEST_CASE("coated conductor under no coat: the rough conductor's f and albedo") {
    TestScene s;
    const int eta = s.spectrum(0.166f, 0.43f, 1.5f), k = s.spectrum(3.15f, 2.45f, 1.88f);
    const int plain = s.fresnelConductor(eta, k, 0.3f);
    const int coated = s.coatedConductor(eta, k, 1.0f, 0.0f, 10, 1, 0.0f, 0.3f);
    SceneView v = s.view();
    Uniform u(950);
    double worst = 0.0;
    for (int i = 0; i < 2000; ++i) {
        const float side = i % 2 ? 1.0f : -1.0f;
        const Vec3 wo = worldDir(side * (0.1f + 0.9f * u()), 6.28f * u());
        const Vec3 wi = worldDir(side * (0.1f + 0.9f * u()), 6.28f * u());
        float pf, pr;
        const Spectrum a = bsdfEval(&v, plain, kNoUv, kFrame, wo, wi, i % 4 < 2, &pf, &pr);
        const Spectrum b = bsdfEval(&v, coated, kNoUv, kFrame, wo, wi, i % 4 < 2, &pf, &pr);
        for (int ch = 0; ch < 3; ++ch)
            if (a.c[ch] > 1e-3f) worst = std::max(worst, rel(a.c[ch], b.c[ch]));
    }
    CAPTURE(worst);
    CHECK(worst < 1e-3);
    for (float cosO : {0.9f, 0.4f}) {
        CAPTURE(cosO);
        const Vec3 wo = worldDir(cosO, 0.3f);
        std::array<double, 2> mean{}, se{};
        for (int which = 0; which < 2; ++which) {
            Uniform w(960);
            double sum = 0.0, sum2 = 0.0;
            const int n = 100000;
            for (int i = 0; i < n; ++i) {
                BsdfSample bs;
                double x = 0.0;
                if (bsdfSample(&v, which ? coated : plain, kNoUv, kFrame, wo, w(), w(), w(), 0,
                               &bs))
                    x = bs.f.c[1] * vabsdot(bs.wi, kFrame.n) / bs.pdf;
                sum += x;
                sum2 += x * x;
            }
            mean[size_t(which)] = sum / n;
            se[size_t(which)] = std::sqrt(std::max(0.0, sum2 / n - sum * sum / n / n) / n);
        }
        CAPTURE(mean[0]);
        CAPTURE(mean[1]);
        CHECK(std::fabs(mean[0] - mean[1]) < 5.0 * std::hypot(se[0], se[1]) + 1e-6);
    }
}

namespace {

// The reflectance of a plane-parallel layer of optical thickness tau (extinction 1), single-
// scattering albedo a and Henyey-Greenstein asymmetry g, under a smooth coat of index eta and over
// a Lambertian floor of reflectance rho, lit from outside at cosine mu0: an analogue random walk in
// double over the cosine alone (the layer is the same at every azimuth), its phase function
// sampled by rejection from the uniform sphere, apart from the kernels' walk. Returns the mean and
// sets its standard error.
double slabReflectance(double mu0, double eta, double tau, double a, double g, double rho, int n,
                       unsigned seed, double* se) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    auto hg = [g](double mu) { return (1 - g * g) / std::pow(1 + g * g - 2 * g * mu, 1.5); };
    const double hgMax = hg(g >= 0.0 ? 1.0 : -1.0);
    const double r0 = cbtest::dielectricFresnel(mu0, eta);
    const double muIn = std::sqrt(1.0 - (1.0 - mu0 * mu0) / (eta * eta));
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < n; ++i) {
        double weight = 1.0 - r0, z = tau, mu = -muIn, out = 0.0;
        for (int event = 0; event < 100000; ++event) {
            if (weight < 0.05) { // roulette
                if (uniform(rng) < 0.5) break;
                weight *= 2.0;
            }
            const double next = z - std::log(1.0 - uniform(rng)) * mu;
            if (next <= 0.0) { // the floor: a cosine-distributed bounce
                if (rho == 0.0) break;
                weight *= rho;
                mu = std::sqrt(uniform(rng));
                z = 0.0;
            } else if (next >= tau) { // the coat from inside: reflected, or out
                if (uniform(rng) < cbtest::dielectricFresnel(mu, 1.0 / eta)) {
                    mu = -mu;
                    z = tau;
                } else {
                    out = weight;
                    break;
                }
            } else { // scattered: the new cosine from the old and the deflection
                weight *= a;
                double cosDeflection;
                do
                    cosDeflection = 2.0 * uniform(rng) - 1.0;
                while (uniform(rng) * hgMax > hg(cosDeflection));
                const double phi = 2.0 * M_PI * uniform(rng);
                mu = mu * cosDeflection +
                     std::sqrt(std::max(0.0, 1.0 - mu * mu)) *
                         std::sqrt(std::max(0.0, 1.0 - cosDeflection * cosDeflection)) *
                         std::cos(phi);
                z = next;
            }
        }
        sum += out;
        sum2 += out * out;
    }
    const double mean = sum / n;
    *se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
    return r0 + mean;
}

} // namespace

// A layer that scatters: the walk's sampled albedo against the slab's independent random walk,
// under a smooth coat over a white-ish floor (forward scattering) and index-matched over a black
// one (backward scattering, the layer alone).
TEST_CASE("coated diffuse with a scattering layer: the walk's albedo against a slab walk") {
    TestScene s;
    struct Case {
        float eta, thickness, albedo, g, rho;
    };
    for (const Case c :
         {Case{1.5f, 0.5f, 0.9f, 0.5f, 0.8f}, Case{1.0f, 1.0f, 0.95f, -0.3f, 0.0f}}) {
        CAPTURE(c.eta);
        CAPTURE(c.g);
        const int rho = s.spectrum(c.rho, c.rho, c.rho),
                  a = s.spectrum(c.albedo, c.albedo, c.albedo);
        const int m = s.scattering(s.coatedDiffuse(rho, c.eta, c.thickness, 1000, 1), a, c.g);
        SceneView v = s.view();
        for (float cosO : {0.9f, 0.4f}) {
            CAPTURE(cosO);
            const Vec3 wo = worldDir(cosO, 0.2f);
            Uniform u(970 + unsigned(m));
            const int n = 100000;
            double sum = 0.0, sum2 = 0.0;
            for (int i = 0; i < n; ++i) {
                BsdfSample bs;
                double x = 0.0;
                if (bsdfSample(&v, m, kNoUv, kFrame, wo, u(), u(), u(), i % 2, &bs))
                    x = bs.f.c[0] * vabsdot(bs.wi, kFrame.n) / bs.pdf;
                sum += x;
                sum2 += x * x;
            }
            const double mean = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
            double refSe = 0.0;
            const double ref = slabReflectance(cosO, c.eta, c.thickness, c.albedo, c.g, c.rho,
                                               200000, 980 + unsigned(m), &refSe);
            CAPTURE(mean);
            CAPTURE(se);
            CAPTURE(ref);
            CAPTURE(refSe);
            CHECK(std::fabs(mean - ref) < 5.0 * std::hypot(se, refSe) + 1e-5);
        }
    }
}

// A rough layer has no closed form: the walk's sampling and its evaluation are two estimators of
// the same albedo (beside a smooth coat's delta reflection, taken with probability R), and at
// alpha 2e-3 both reach the smooth layers'.
TEST_CASE("coated diffuse and conductor, rough layers: sampled and evaluated albedo agree, "
          "adjoint, smooth limit") {
    Fixture fx;
    SceneView v = fx.s.view();
    for (int material : {fx.coatedRough, fx.coatedRoughGold, fx.coatedRoughLow, fx.coatedNearSmooth,
                         fx.ccRoughBase, fx.ccRoughCoat, fx.ccRoughBoth, fx.ccRoughLow,
                         fx.ccNearSmooth, fx.cdScatter, fx.ccScatterRough, fx.ccScatterSmooth}) {
        CAPTURE(material);
        const Material& mat = fx.s.materials[size_t(material)];
        const bool nearSmooth = material == fx.coatedNearSmooth || material == fx.ccNearSmooth;
        for (float cosO : {0.8f, 0.3f, -0.5f}) {
            CAPTURE(cosO);
            const Vec3 wo = worldDir(cosO, 1.1f);
            Uniform u(700 + unsigned(material));
            const int n = 100000;
            // Sampling: the mean of f |cos| / pdf.
            double sum = 0.0, sum2 = 0.0, worstPdf = 0.0, deltaSum = 0.0, deltaSum2 = 0.0;
            int deltas = 0, wrongSide = 0;
            // Both estimators by the cosine of wi, in 4 bins: where the energy goes.
            constexpr int kBins = 4;
            std::array<double, kBins> sampledBin{}, sampledBin2{}, evaluatedBin{}, evaluatedBin2{};
            auto binOf = [&](double cosine) {
                return size_t(std::min(kBins - 1, int(std::fabs(cosine) * kBins)));
            };
            for (int i = 0; i < n; ++i) {
                BsdfSample s;
                double w = 0.0;
                if (bsdfSample(&v, material, kNoUv, kFrame, wo, u(), u(), u(), i % 2, &s)) {
                    wrongSide += vdot(s.wi, kFrame.n) * cosO <= 0.0f;
                    CHECK(s.pdf > 0.0f);
                    deltas += s.isDelta;
                    if (s.isDelta) {
                        const double d = s.f.c[0] * vabsdot(s.wi, kFrame.n) / s.pdf;
                        deltaSum += d;
                        deltaSum2 += d * d;
                    }
                    // Under a smooth coat the pdf estimate is the base's exact density between
                    // the refracted directions, which bsdfEval must give again (a rough coat's is
                    // keyed by the directions' bits, which the world-space round trip changes).
                    if (!s.isDelta && mat.alpha == 0.0f && i % 8 == 0) {
                        float pf, pr;
                        bsdfEval(&v, material, kNoUv, kFrame, wo, s.wi, i % 2, &pf, &pr);
                        worstPdf = std::max({worstPdf, rel(pf, s.pdf), rel(pr, s.pdfRev)});
                    }
                    if (!s.isDelta) { // bsdfEval's f has no delta
                        w = s.f.c[0] * vabsdot(s.wi, kFrame.n) / s.pdf;
                        const size_t b = binOf(vdot(s.wi, kFrame.n));
                        sampledBin[b] += w;
                        sampledBin2[b] += w * w;
                    }
                }
                sum += w;
                sum2 += w * w;
            }
            const double sampled = sum / n;
            const double sampledSe = std::sqrt(std::max(0.0, sum2 / n - sampled * sampled) / n);
            // Evaluation: pi f over cosine-distributed directions on wo's side.
            double esum = 0.0, esum2 = 0.0;
            for (int i = 0; i < n; ++i) {
                Vec3 l = sampleCosineHemisphere(u(), u());
                if (cosO < 0.0f) l.z = -l.z;
                float pf, pr;
                const double e = M_PI * bsdfEval(&v, material, kNoUv, kFrame, wo,
                                                 frameToWorld(kFrame, l), i % 2, &pf, &pr)
                                            .c[0];
                esum += e;
                esum2 += e * e;
                evaluatedBin[binOf(l.z)] += e;
                evaluatedBin2[binOf(l.z)] += e * e;
            }
            if (!nearSmooth)
                for (size_t b = 0; b < size_t(kBins); ++b) {
                    const double ms = sampledBin[b] / n, me = evaluatedBin[b] / n;
                    const double ses = std::sqrt(std::max(0.0, sampledBin2[b] / n - ms * ms) / n);
                    const double see = std::sqrt(std::max(0.0, evaluatedBin2[b] / n - me * me) / n);
                    CAPTURE(b);
                    CAPTURE(ms);
                    CAPTURE(me);
                    CHECK(std::fabs(ms - me) < 5.0 * std::hypot(ses, see) + 1e-5);
                }
            const double evaluated = esum / n;
            const double evaluatedSe =
                std::sqrt(std::max(0.0, esum2 / n - evaluated * evaluated) / n);
            CAPTURE(sampled);
            CAPTURE(sampledSe);
            CAPTURE(evaluated);
            CAPTURE(evaluatedSe);
            // Cosine-distributed directions all but miss a near-delta coat's reflection.
            if (!nearSmooth)
                CHECK(std::fabs(sampled - evaluated) <
                      5.0 * std::hypot(sampledSe, evaluatedSe) + 1e-5);
            CHECK(sampled <= 1.0 + 5.0 * sampledSe);
            // The delta share is the smooth coat's reflection R, and more where the walk's own
            // ways out through smooth layers are deltas too.
            const double r =
                mat.alpha == 0.0f ? cbtest::dielectricFresnel(std::fabs(cosO), mat.eta) : 0.0;
            const double rSe = 5.0 * std::sqrt(r * (1.0 - r) / n) + 1e-6;
            if (mat.kind == CB_MAT_COATED_CONDUCTOR && mat.alpha == 0.0f && mat.baseAlpha == 0.0f) {
                // The walks that never scatter see the absorbing layer's closed form (gold's
                // channel 0 under ccScatterSmooth's coat and layer).
                CHECK(double(deltas) / n > r + rSe);
                const double mean = deltaSum / n;
                const double se = std::sqrt(std::max(0.0, deltaSum2 / n - mean * mean) / n);
                CAPTURE(mean);
                CHECK(std::fabs(mean - cbtest::smoothCoatedConductorAlbedo(std::fabs(cosO), 1.5,
                                                                           0.166, 3.15, 0.5, 100)) <
                      5.0 * se + 1e-5);
            } else
                CHECK(std::fabs(double(deltas) / n - r) < rSe);
            CHECK(worstPdf < 1e-3);
            CHECK(wrongSide == 0);
            if (material == fx.coatedNearSmooth) {
                const cbtest::CoatedDiffuseReference smooth(0.8, 1.5, 0.25, 1000);
                CHECK(std::fabs(sampled - smooth.albedo(std::fabs(cosO))) < 5.0 * sampledSe + 2e-3);
            }
            if (material == fx.ccNearSmooth) // gold's channel 0 under the coat of ccSmoothGold
                CHECK(std::fabs(sampled - cbtest::smoothCoatedConductorAlbedo(
                                              std::fabs(cosO), 1.5, 0.166, 3.15, 0.1, 10)) <
                      5.0 * sampledSe + 2e-3);
        }
        // f for radiance against f for importance with the pair swapped, pair by pair. Not for
        // the near-smooth conductor: its f away from the mirror direction is the product of two
        // lobes' far tails, found only where the walk's sampled way in meets the far peak of
        // the way out (a conductor of alpha 2e-3 gives no next-event estimate to weigh against),
        // an estimate too heavy-tailed for a mean (as pbrt-v4's LayeredBxDF).
        if (material == fx.ccNearSmooth) continue;
        Uniform u(800 + unsigned(material));
        double diff = 0.0, diff2 = 0.0, total = 0.0;
        const int pairs = 20000;
        for (int i = 0; i < pairs; ++i) {
            // wo steep and wi grazing: f(wo, wi) for radiance must equal f(wi, wo) for
            // importance pair by pair, not only over pairs drawn alike.
            const float side = i % 2 ? 1.0f : -1.0f;
            const Vec3 wo = worldDir(side * (0.6f + 0.4f * u()), 6.28f * u());
            const Vec3 wi = worldDir(side * (0.05f + 0.35f * u()), 6.28f * u());
            float pf, pr;
            const double f = bsdfEval(&v, material, kNoUv, kFrame, wo, wi, 0, &pf, &pr).c[0];
            const double fAdjoint = bsdfEval(&v, material, kNoUv, kFrame, wi, wo, 1, &pf, &pr).c[0];
            CHECK(std::isfinite(pf));
            diff += f - fAdjoint;
            diff2 += (f - fAdjoint) * (f - fAdjoint);
            total += f;
        }
        const double meanDiff = diff / pairs;
        const double se = std::sqrt(std::max(0.0, diff2 / pairs - meanDiff * meanDiff) / pairs);
        CAPTURE(meanDiff);
        CAPTURE(se);
        CAPTURE(total / pairs);
        CHECK(std::fabs(meanDiff) < 5.0 * se + 1e-6);
    }
}

TEST_CASE("perfect mirror: exact reflection, tint as throughput, delta contract") {
    Fixture fx;
    SceneView v = fx.s.view();
    for (float c : {1.0f, 0.7f, 0.05f, -0.3f}) {
        Vec3 wo = worldDir(c, 2.0f);
        BsdfSample s;
        REQUIRE(bsdfSample(&v, fx.mirror, kNoUv, kFrame, wo, 0.3f, 0.8f, 0.5f, 0, &s));
        Vec3 expected = vsub(vscale(kFrame.n, 2.0f * vdot(wo, kFrame.n)), wo);
        CHECK(vlength(vsub(s.wi, expected)) < 1e-6f);
        CHECK(s.isDelta == 1);
        CHECK(s.pdf == 1.0f);
        CHECK(s.pdfRev == 1.0f);
        float cosI = vabsdot(s.wi, kFrame.n);
        CHECK(s.f.c[0] * cosI / s.pdf == doctest::Approx(0.8).epsilon(1e-5));
        CHECK(s.f.c[2] * cosI / s.pdf == doctest::Approx(0.4).epsilon(1e-5));
        float pf, pr;
        CHECK(specIsBlack(bsdfEval(&v, fx.mirror, kNoUv, kFrame, wo, expected, 0, &pf, &pr)));
        CHECK(pf == 0.0f);
        CHECK(pr == 0.0f);
    }
}

TEST_CASE("dielectric: normal-incidence Fresnel, Snell's law, TIR, adjoint scaling") {
    Fixture fx;
    SceneView v = fx.s.view();
    for (int m : {fx.glass, fx.glassWater}) {
        const double eta = fx.s.materials[m].eta;
        const double f0 = (eta - 1.0) * (eta - 1.0) / ((eta + 1.0) * (eta + 1.0));
        INFO("eta = " << eta);
        for (float side : {1.0f, -1.0f}) {
            Vec3 wo = vscale(kFrame.n, side);
            BsdfSample s;
            REQUIRE(bsdfSample(&v, m, kNoUv, kFrame, wo, 0.5f, 0.5f, static_cast<float>(f0) * 0.99f,
                               0, &s));
            CHECK(s.isDelta == 1);
            CHECK(s.pdf == doctest::Approx(f0).epsilon(1e-5));
            CHECK(vlength(vsub(s.wi, wo)) < 1e-6f);
            CHECK(s.f.c[0] * vabsdot(s.wi, kFrame.n) / s.pdf == doctest::Approx(1.0).epsilon(1e-5));
            REQUIRE(bsdfSample(&v, m, kNoUv, kFrame, wo, 0.5f, 0.5f, static_cast<float>(f0) * 1.01f,
                               0, &s));
            CHECK(s.pdf == doctest::Approx(1.0 - f0).epsilon(1e-5));
            CHECK(vlength(vadd(s.wi, wo)) < 1e-6f);
            // Radiance: 1/eta_rel^2 on the way in (eta_rel = eta), eta^2 on the way out.
            double etaRel = side > 0.0f ? eta : 1.0 / eta;
            CHECK(s.f.c[0] * vabsdot(s.wi, kFrame.n) / s.pdf ==
                  doctest::Approx(1.0 / (etaRel * etaRel)).epsilon(1e-5));
        }

        for (float side : {1.0f, -1.0f})
            for (float cosO : {0.95f, 0.7f, 0.4f, 0.1f}) {
                Vec3 wo = vscale(worldDir(cosO, 1.1f), 1.0f);
                if (side < 0.0f) wo = vsub(wo, vscale(kFrame.n, 2.0f * vdot(wo, kFrame.n)));
                double etaRel = side > 0.0f ? eta : 1.0 / eta;
                double sinO = std::sqrt(1.0 - cosO * cosO);
                double fr = fresnelRef(cosO, etaRel);
                BsdfSample r, t0, t1;
                REQUIRE(bsdfSample(&v, m, kNoUv, kFrame, wo, 0.5f, 0.5f, 0.0f, 0, &r));
                CHECK(r.pdf == doctest::Approx(fr).epsilon(1e-5));
                CHECK(r.pdfRev == doctest::Approx(fr).epsilon(1e-5));
                CHECK(vlength(vsub(r.wi, vsub(vscale(kFrame.n, 2.0f * vdot(wo, kFrame.n)), wo))) <
                      1e-6f);
                if (sinO / etaRel >= 1.0) {
                    // Total internal reflection: every lobe number reflects.
                    CHECK(fr == 1.0);
                    REQUIRE(bsdfSample(&v, m, kNoUv, kFrame, wo, 0.5f, 0.5f, 0.99999994f, 0, &t0));
                    CHECK(t0.pdf == 1.0f);
                    CHECK(vdot(t0.wi, kFrame.n) * vdot(wo, kFrame.n) > 0.0f);
                    continue;
                }
                REQUIRE(bsdfSample(&v, m, kNoUv, kFrame, wo, 0.5f, 0.5f, 0.99999994f, 0, &t0));
                REQUIRE(bsdfSample(&v, m, kNoUv, kFrame, wo, 0.5f, 0.5f, 0.99999994f, 1, &t1));
                CHECK(t0.pdf == doctest::Approx(1.0 - fr).epsilon(1e-5));
                // Snell: eta_i sin_i = eta_t sin_t, in the plane of wo and n, other side.
                double cosT = vdot(t0.wi, kFrame.n);
                CHECK(cosT * vdot(wo, kFrame.n) < 0.0);
                CHECK(std::sqrt(1.0 - cosT * cosT) * etaRel == doctest::Approx(sinO).epsilon(1e-5));
                CHECK(std::fabs(vdot(vcross(wo, kFrame.n), t0.wi)) < 1e-6f);
                // The tangential parts point opposite ways (the ray goes straight on).
                Vec3 tanO = vsub(wo, vscale(kFrame.n, vdot(wo, kFrame.n)));
                Vec3 tanT = vsub(t0.wi, vscale(kFrame.n, vdot(t0.wi, kFrame.n)));
                CHECK(vdot(tanO, tanT) < 0.0f);
                // Importance is not compressed: the two transports differ by eta_rel^2 exactly.
                CHECK(t1.f.c[0] / t0.f.c[0] == doctest::Approx(etaRel * etaRel).epsilon(1e-6));
                CHECK(t1.f.c[0] * std::fabs(cosT) / t1.pdf == doctest::Approx(1.0).epsilon(1e-5));
                CHECK(vlength(vsub(t0.wi, t1.wi)) == 0.0f);
            }

        // A smooth dielectric has nothing for bsdfEval or next-event estimation.
        float pf, pr;
        CHECK(specIsBlack(bsdfEval(&v, m, kNoUv, kFrame, worldDir(0.5f, 0.0f), worldDir(-0.5f, kPi),
                                   0, &pf, &pr)));
        CHECK(pf == 0.0f);
        CHECK(!materialHasNonDelta(&v, m));
    }
}

TEST_CASE("dielectric: reflect/refract frequency matches Fresnel") {
    Fixture fx;
    SceneView v = fx.s.view();
    Uniform u(13);
    for (float cosO : {0.9f, 0.5f, 0.15f}) {
        Vec3 wo = worldDir(cosO, 0.4f);
        const int n = 100000;
        int reflected = 0;
        for (int i = 0; i < n; ++i) {
            BsdfSample s{};
            REQUIRE(bsdfSample(&v, fx.glass, kNoUv, kFrame, wo, u(), u(), u(), 0, &s));
            if (vdot(s.wi, kFrame.n) > 0.0f) ++reflected;
        }
        double fr = fresnelRef(cosO, 1.5);
        double sigma = std::sqrt(fr * (1.0 - fr) / n);
        INFO("cos = " << cosO << " F = " << fr << " freq = " << double(reflected) / n);
        CHECK(std::fabs(double(reflected) / n - fr) < 4.5 * sigma);
    }
}

TEST_CASE("mix: component frequencies follow the amount, delta contract, specularity") {
    Fixture fx;
    SceneView v = fx.s.view();
    Uniform u(14);
    const int n = 100000;
    Vec3 wo = worldDir(0.6f, 0.2f);
    int deltaCount = 0, glassReflect = 0;
    for (int i = 0; i < n; ++i) {
        BsdfSample s;
        REQUIRE(bsdfSample(&v, fx.mixDiffuseGlass, kNoUv, kFrame, wo, u(), u(), u(), 0, &s));
        if (!s.isDelta) continue;
        ++deltaCount;
        if (vdot(s.wi, kFrame.n) > 0.0f) {
            ++glassReflect;
            CHECK(s.pdf == doctest::Approx(0.5 * fresnelRef(0.6, 1.5)).epsilon(1e-4));
        } else {
            CHECK(s.pdf == doctest::Approx(0.5 * (1.0 - fresnelRef(0.6, 1.5))).epsilon(1e-4));
        }
        // The component's own throughput: the pick probability cancels.
        double w = s.f.c[0] * vabsdot(s.wi, kFrame.n) / s.pdf;
        CHECK(w == doctest::Approx(vdot(s.wi, kFrame.n) > 0.0f ? 1.0 : 1.0 / 2.25).epsilon(1e-4));
    }
    double p = 0.5, sigma = std::sqrt(p * (1 - p) / n);
    CHECK(std::fabs(double(deltaCount) / n - p) < 4.5 * sigma);
    // The lobe number, rescaled, still drives the glass's own Fresnel choice.
    double pr = 0.5 * fresnelRef(0.6, 1.5), sr = std::sqrt(pr * (1 - pr) / n);
    CHECK(std::fabs(double(glassReflect) / n - pr) < 4.5 * sr);

    // Dragon mix: the mirror lobe at 30% with the tint as throughput, pdf 0.3.
    int mirrorCount = 0;
    for (int i = 0; i < n; ++i) {
        BsdfSample s;
        REQUIRE(bsdfSample(&v, fx.mixDragon, kNoUv, kFrame, wo, u(), u(), u(), 0, &s));
        double w = s.f.c[2] * vabsdot(s.wi, kFrame.n) / s.pdf;
        CHECK(w == doctest::Approx(0.18).epsilon(1e-4));
        if (s.isDelta) {
            ++mirrorCount;
            CHECK(s.pdf == doctest::Approx(0.3).epsilon(1e-6));
            CHECK(s.pdfRev == doctest::Approx(0.3).epsilon(1e-6));
        } else {
            CHECK(s.pdf == doctest::Approx(0.7 * vabsdot(s.wi, kFrame.n) / kPi).epsilon(1e-5));
        }
    }
    sigma = std::sqrt(0.3 * 0.7 / n);
    CHECK(std::fabs(double(mirrorCount) / n - 0.3) < 4.5 * sigma);

    // A mix of two delta materials has nothing to evaluate.
    float pf, pr2;
    CHECK(specIsBlack(bsdfEval(&v, fx.mixMirrorGlass, kNoUv, kFrame, wo, worldDir(0.6f, 0.2f + kPi),
                               0, &pf, &pr2)));
    CHECK(pf == 0.0f);

    CHECK(materialSpecularity(&v, fx.diffuse) == 0.0f);
    CHECK(materialSpecularity(&v, fx.mirror) == 1.0f);
    CHECK(materialSpecularity(&v, fx.rough03) == 1.0f);
    CHECK(materialSpecularity(&v, fx.glass) == 1.0f);
    CHECK(materialSpecularity(&v, fx.mixDragon) == doctest::Approx(0.3));
    CHECK(materialSpecularity(&v, fx.mixDiffuseGlossy) == doctest::Approx(0.6));
    CHECK(materialSpecularity(&v, fx.mixDiffuseGlass) == doctest::Approx(0.5));
    CHECK(materialSpecularity(&v, fx.mixMirrorGlass) == doctest::Approx(1.0));
    CHECK(materialHasNonDelta(&v, fx.diffuse));
    CHECK(materialHasNonDelta(&v, fx.rough005));
    CHECK(materialHasNonDelta(&v, fx.tiny));
    CHECK(!materialHasNonDelta(&v, fx.mirror));
    CHECK(!materialHasNonDelta(&v, fx.glass));
    CHECK(materialHasNonDelta(&v, fx.mixDragon));
    CHECK(!materialHasNonDelta(&v, fx.mixMirrorGlass));
}

TEST_CASE(
    "conductor at alpha = 1e-4: finite, and samples within 1e-2 rad of the mirror direction") {
    Fixture fx;
    SceneView v = fx.s.view();
    Uniform u(15);
    for (float cosO : {1.0f, 0.8f, 0.3f, 0.05f}) {
        Vec3 wo = worldDir(cosO, 1.0f);
        Vec3 mirror = vsub(vscale(kFrame.n, 2.0f * vdot(wo, kFrame.n)), wo);
        int valid = 0, within1e2 = 0, within1e3 = 0;
        const int n = 20000;
        for (int i = 0; i < n; ++i) {
            BsdfSample s;
            if (!bsdfSample(&v, fx.tiny, kNoUv, kFrame, wo, u(), u(), u(), 0, &s)) continue;
            ++valid;
            REQUIRE(std::isfinite(s.pdf));
            REQUIRE(std::isfinite(s.pdfRev));
            REQUIRE(specIsFinite(s.f));
            REQUIRE(s.pdf > 0.0f);
            double angle = angleBetween(s.wi, mirror);
            if (angle < 1e-2) ++within1e2;
            if (angle < 1e-3) ++within1e3;
            // The weight f cos / pdf = G / G1(wo) stays in [0, 1].
            double w = s.f.c[0] * vabsdot(s.wi, kFrame.n) / s.pdf;
            REQUIRE(w <= 1.0 + 1e-3);
            REQUIRE(w >= 0.0);
            float pf, pr;
            Spectrum f = bsdfEval(&v, fx.tiny, kNoUv, kFrame, wo, s.wi, 0, &pf, &pr);
            REQUIRE(specIsFinite(f));
            REQUIRE(std::isfinite(pf));
            REQUIRE(std::isfinite(pr));
        }
        INFO("cos wo = " << cosO);
        CHECK(valid > n * 9 / 10);
        // GGX tails are heavy: at normal incidence P(tilt > T) = alpha^2 / (alpha^2 + T^2), so a
        // deviation of 1e-2 rad (tilt 5e-3) has probability 4e-4 and of 1e-3 rad about 4%.
        CHECK(within1e2 >= valid * 99 / 100);
        CHECK(within1e3 >= valid * 85 / 100);
    }
}

TEST_CASE("no NaN or Inf from any material at grazing, tangent and extreme inputs") {
    Fixture fx;
    SceneView v = fx.s.view();
    Uniform u(16);
    Frame frames[2] = {kFrame, frameFromNormal(vec3(0.0f, 0.0f, 1.0f))};
    std::vector<Vec3> locals;
    for (float c :
         {1.0f, 0.5f, 0.05f, 1e-3f, 1e-6f, 1e-20f, 1e-38f, 0.0f, -1e-20f, -1e-6f, -0.05f, -1.0f})
        for (float phi : {0.0f, 1.0f, 4.0f})
            locals.push_back(localDir(c, phi));
    const float us[] = {0.0f, 0.5f, 0.99999994f, 1e-7f};
    for (int m = 0; m < static_cast<int>(fx.s.materials.size()); ++m)
        for (const Frame& frame : frames)
            for (Vec3 lo : locals) {
                Vec3 wo = frameToWorld(frame, lo);
                for (Vec3 li : locals) {
                    float pf, pr;
                    Spectrum f =
                        bsdfEval(&v, m, kNoUv, frame, wo, frameToWorld(frame, li), 0, &pf, &pr);
                    REQUIRE(specIsFinite(f));
                    REQUIRE(std::isfinite(pf));
                    REQUIRE(std::isfinite(pr));
                    REQUIRE(pf >= 0.0f);
                    REQUIRE(pr >= 0.0f);
                    REQUIRE(f.c[0] >= 0.0f);
                }
                for (int i = 0; i < 40; ++i) {
                    float u0 = i < 16 ? us[i % 4] : u(), u1 = i < 16 ? us[i / 4] : u();
                    float ul = i < 16 ? us[(i + 1) % 4] : u();
                    for (int adjoint = 0; adjoint < 2; ++adjoint) {
                        BsdfSample s;
                        if (!bsdfSample(&v, m, kNoUv, frame, wo, u0, u1, ul, adjoint, &s)) continue;
                        INFO("material " << m << " wo.z " << lo.z);
                        REQUIRE(specIsFinite(s.f));
                        REQUIRE(std::isfinite(s.pdf));
                        REQUIRE(std::isfinite(s.pdfRev));
                        REQUIRE(s.pdf > 0.0f);
                        REQUIRE(s.pdfRev >= 0.0f);
                        REQUIRE(s.f.c[0] >= 0.0f);
                        REQUIRE(vlength(s.wi) == doctest::Approx(1.0).epsilon(1e-4));
                    }
                }
            }
    // wo exactly in the tangent plane of an axis-aligned frame has no sample and no value.
    Frame up = frames[1];
    BsdfSample s;
    for (int m = 0; m < static_cast<int>(fx.s.materials.size()); ++m) {
        CHECK(!bsdfSample(&v, m, kNoUv, up, vec3(1.0f, 0.0f, 0.0f), 0.3f, 0.3f, 0.3f, 0, &s));
        float pf, pr;
        CHECK(specIsBlack(bsdfEval(&v, m, kNoUv, up, vec3(1.0f, 0.0f, 0.0f), vec3(0.0f, 0.0f, 1.0f),
                                   0, &pf, &pr)));
    }
}

// ---- The same header as OpenCL C -----------------------------------------------------------

namespace {

const char* kProbeKernel = R"CLC(
#include "cb_bsdf.h"
/* in: wo[3] n[3] u0 u1 uLobe wiEval[3] material adjoint (14 floats); out: see OUT_STRIDE */
#define OUT_STRIDE (8 + 2 * CB_CHANNELS + 4)
__kernel void bsdfProbe(__global const Material* materials, __global const float* spectra,
                        __global const float* in, __global float* out) {
    int i = get_global_id(0);
    __global const float* p = in + i * 14;
    __global float* o = out + i * OUT_STRIDE;
    SceneView sv;
    sv.nodes = 0;
    sv.primitives = 0;
    sv.materials = materials;
    sv.lights = 0;
    sv.spectra = spectra;
    sv.textures = 0; /* the probe's materials are untextured */
    sv.shadingNormals = 0;
    sv.lightCount = 0;
    TexCoord noUv;
    noUv.u = noUv.v = 0.0f;
    noUv.hero = -1.0f;
    Frame frame = frameFromNormal(vnormalize(vec3(p[3], p[4], p[5])));
    Vec3 wo = vec3(p[0], p[1], p[2]);
    int material = (int)p[12];
    int adjoint = (int)p[13];
    BsdfSample s;
    bool ok = bsdfSample(&sv, material, noUv, frame, wo, p[6], p[7], p[8], adjoint, &s);
    o[0] = ok ? 1.0f : 0.0f;
    o[1] = ok ? s.wi.x : 0.0f;
    o[2] = ok ? s.wi.y : 0.0f;
    o[3] = ok ? s.wi.z : 0.0f;
    o[4] = ok ? s.pdf : 0.0f;
    o[5] = ok ? s.pdfRev : 0.0f;
    o[6] = ok ? (float)s.isDelta : 0.0f;
    for (int c = 0; c < CB_CHANNELS; ++c) o[8 + c] = ok ? s.f.c[c] : 0.0f;
    float pf, pr;
    Spectrum f = bsdfEval(&sv, material, noUv, frame, wo, vec3(p[9], p[10], p[11]), adjoint, &pf, &pr);
    for (int c = 0; c < CB_CHANNELS; ++c) o[8 + CB_CHANNELS + c] = f.c[c];
    o[8 + 2 * CB_CHANNELS] = pf;
    o[8 + 2 * CB_CHANNELS + 1] = pr;
    o[8 + 2 * CB_CHANNELS + 2] = materialSpecularity(&sv, material);
    o[8 + 2 * CB_CHANNELS + 3] = materialHasNonDelta(&sv, material) ? 1.0f : 0.0f;
}
)CLC";

constexpr int kDeviceChannels = 16;
constexpr int kOutStride = 8 + 2 * kDeviceChannels + 4;

#define CL_REQUIRE(call)                                                                           \
    do {                                                                                           \
        cl_int status_ = (call);                                                                   \
        REQUIRE_MESSAGE(status_ == CL_SUCCESS, #call " failed: " << status_);                      \
    } while (0)

struct ClProbe {
    cl_context context = nullptr;
    cl_command_queue queue = nullptr;
    cl_device_id device = nullptr;
    ~ClProbe() {
        if (queue) clReleaseCommandQueue(queue);
        if (context) clReleaseContext(context);
    }
};

// Run the probe kernel built with `options` over `inputs`; returns kOutStride floats per input.
std::vector<float> runProbe(ClProbe& cl, const std::string& options, const TestScene& scene,
                            const std::vector<float>& inputs) {
    cl_int err = CL_SUCCESS;
    const char* src = kProbeKernel;
    cl_program program = clCreateProgramWithSource(cl.context, 1, &src, nullptr, &err);
    CL_REQUIRE(err);
    cl_int built = clBuildProgram(program, 1, &cl.device, options.c_str(), nullptr, nullptr);
    if (built != CL_SUCCESS) {
        size_t size = 0;
        clGetProgramBuildInfo(program, cl.device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &size);
        std::string log(size, '\0');
        clGetProgramBuildInfo(program, cl.device, CL_PROGRAM_BUILD_LOG, size, log.data(), nullptr);
        clReleaseProgram(program);
        FAIL("clBuildProgram(" << options << ") failed:\n" << log);
    }
    cl_kernel kernel = clCreateKernel(program, "bsdfProbe", &err);
    CL_REQUIRE(err);
    // Device spectra: channel c of entry k is the host's channel c % 3, so all 16 channels are
    // checked against the RGB host.
    std::vector<float> spectra;
    for (size_t k = 0; k < scene.spectra.size() / 3; ++k)
        for (int c = 0; c < kDeviceChannels; ++c)
            spectra.push_back(scene.spectra[k * 3 + c % 3]);
    const size_t count = inputs.size() / 14;
    std::vector<float> out(count * kOutStride, -1.0f);
    auto buffer = [&](const void* data, size_t bytes, cl_mem_flags flags) {
        cl_mem m = clCreateBuffer(cl.context, flags, bytes, const_cast<void*>(data), &err);
        CL_REQUIRE(err);
        return m;
    };
    cl_mem bm = buffer(scene.materials.data(), scene.materials.size() * sizeof(Material),
                       CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR);
    cl_mem bs = buffer(spectra.data(), spectra.size() * sizeof(float),
                       CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR);
    cl_mem bi = buffer(inputs.data(), inputs.size() * sizeof(float),
                       CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR);
    cl_mem bo = buffer(nullptr, out.size() * sizeof(float), CL_MEM_WRITE_ONLY);
    CL_REQUIRE(clSetKernelArg(kernel, 0, sizeof(cl_mem), &bm));
    CL_REQUIRE(clSetKernelArg(kernel, 1, sizeof(cl_mem), &bs));
    CL_REQUIRE(clSetKernelArg(kernel, 2, sizeof(cl_mem), &bi));
    CL_REQUIRE(clSetKernelArg(kernel, 3, sizeof(cl_mem), &bo));
    CL_REQUIRE(
        clEnqueueNDRangeKernel(cl.queue, kernel, 1, nullptr, &count, nullptr, 0, nullptr, nullptr));
    CL_REQUIRE(clEnqueueReadBuffer(cl.queue, bo, CL_TRUE, 0, out.size() * sizeof(float), out.data(),
                                   0, nullptr, nullptr));
    for (cl_mem m : {bm, bs, bi, bo})
        clReleaseMemObject(m);
    clReleaseKernel(kernel);
    clReleaseProgram(program);
    return out;
}

bool closeRel(float a, float b) {
    return std::fabs(a - b) <= 1e-5f * std::max(std::fabs(a), std::fabs(b)) + 1e-6f;
}

// Compare one probe output row with the host computing the same thing.
void compareWithHost(const SceneView& v, const float* in, const float* o) {
    Frame frame = frameFromNormal(vnormalize(vec3(in[3], in[4], in[5])));
    Vec3 wo = vec3(in[0], in[1], in[2]);
    int material = static_cast<int>(in[12]), adjoint = static_cast<int>(in[13]);
    BsdfSample s;
    bool ok = bsdfSample(&v, material, kNoUv, frame, wo, in[6], in[7], in[8], adjoint, &s);
    INFO("material " << material << " adjoint " << adjoint);
    REQUIRE((o[0] == 1.0f) == ok);
    if (ok) {
        CHECK(std::fabs(o[1] - s.wi.x) < 1e-5f);
        CHECK(std::fabs(o[2] - s.wi.y) < 1e-5f);
        CHECK(std::fabs(o[3] - s.wi.z) < 1e-5f);
        CHECK(closeRel(o[4], s.pdf));
        CHECK(closeRel(o[5], s.pdfRev));
        CHECK(static_cast<int>(o[6]) == s.isDelta);
        for (int c = 0; c < kDeviceChannels; ++c)
            CHECK(closeRel(o[8 + c], s.f.c[c % 3]));
    }
    float pf, pr;
    Spectrum f =
        bsdfEval(&v, material, kNoUv, frame, wo, vec3(in[9], in[10], in[11]), adjoint, &pf, &pr);
    for (int c = 0; c < kDeviceChannels; ++c)
        CHECK(closeRel(o[8 + kDeviceChannels + c], f.c[c % 3]));
    CHECK(closeRel(o[8 + 2 * kDeviceChannels], pf));
    CHECK(closeRel(o[8 + 2 * kDeviceChannels + 1], pr));
    CHECK(o[8 + 2 * kDeviceChannels + 2] == materialSpecularity(&v, material));
    CHECK((o[8 + 2 * kDeviceChannels + 3] == 1.0f) == materialHasNonDelta(&v, material));
}

} // namespace

TEST_CASE("cb_bsdf.h built as OpenCL C by PoCL matches the host, with all and with one feature") {
    ClProbe cl;
    cl_platform_id platform = nullptr;
    cl_uint platforms = 0;
    CL_REQUIRE(clGetPlatformIDs(1, &platform, &platforms));
    REQUIRE(platforms > 0);
    CL_REQUIRE(clGetDeviceIDs(platform, CL_DEVICE_TYPE_ALL, 1, &cl.device, nullptr));
    cl_int err = CL_SUCCESS;
    cl.context = clCreateContext(nullptr, 1, &cl.device, nullptr, nullptr, &err);
    CL_REQUIRE(err);
    cl.queue = clCreateCommandQueue(cl.context, cl.device, 0, &err);
    CL_REQUIRE(err);

    Fixture fx;
    SceneView v = fx.s.view();
    // Moderate angles and roughness only: PoCL may contract to FMA and its sin/cos differ by an
    // ulp or two, which GGX at alpha 0.05 amplifies past 1e-5 near its peak.
    std::vector<int> materials = {fx.diffuse,           fx.diffuseTint,      fx.mirror,
                                  fx.rough03,           fx.rough1,           fx.glass,
                                  fx.mixDiffuseRough,   fx.mixDragon,        fx.mixDiffuseGlass,
                                  fx.goldFresnelMirror, fx.goldFresnelRough, fx.roughGlass05,
                                  fx.translucent,       fx.thinGlass,        fx.mixTranslucentThin};
    Uniform u(17);
    std::vector<float> inputs, diffuseInputs;
    for (int m : materials)
        for (int i = 0; i < 24; ++i) {
            Vec3 n = vnormalize(vec3(u() - 0.5f, u() - 0.5f, u() - 0.5f));
            Frame fr = frameFromNormal(n);
            float side = i % 3 == 0 ? -1.0f : 1.0f;
            Vec3 lo = localDir(side * (0.2f + 0.75f * u()), 6.28f * u());
            Vec3 li = localDir(side * (0.2f + 0.75f * u()), 6.28f * u());
            if (i % 5 == 0) li.z = -li.z; // other side: zero for reflection
            Vec3 wo = frameToWorld(fr, lo), wi = frameToWorld(fr, li);
            std::vector<float> row = {wo.x,
                                      wo.y,
                                      wo.z,
                                      n.x,
                                      n.y,
                                      n.z,
                                      u(),
                                      u(),
                                      u(),
                                      wi.x,
                                      wi.y,
                                      wi.z,
                                      static_cast<float>(m),
                                      static_cast<float>(i % 2)};
            inputs.insert(inputs.end(), row.begin(), row.end());
            if (m == fx.diffuse || m == fx.diffuseTint)
                diffuseInputs.insert(diffuseInputs.end(), row.begin(), row.end());
        }
    const std::string dir = cbtest::sourcePath("kernels");
    const std::string base = "-cl-std=CL1.2 -I " + dir + " -DCB_CHANNELS=16";

    std::vector<float> out = runProbe(cl, base, fx.s, inputs);
    for (size_t i = 0; i < inputs.size() / 14; ++i)
        compareWithHost(v, &inputs[i * 14], &out[i * kOutStride]);

    // Diffuse only: the other kinds are compiled out and diffuse still agrees.
    std::vector<float> outDiffuse = runProbe(cl, base + " -DCB_FEATURES=1", fx.s, diffuseInputs);
    for (size_t i = 0; i < diffuseInputs.size() / 14; ++i)
        compareWithHost(v, &diffuseInputs[i * 14], &outDiffuse[i * kOutStride]);

    // A coated conductor alone, smooth and under a rough coat, builds without the conductor's own
    // bits (its base shares their GGX lobe and Fresnel equations).
    for (unsigned features :
         {CB_FEATURE_COATED_CONDUCTOR, CB_FEATURE_COATED_CONDUCTOR | CB_FEATURE_ROUGH_DIELECTRIC}) {
        const std::string options = base + " -DCB_FEATURES=" + std::to_string(features) + "u";
        cl_int probeErr = CL_SUCCESS;
        const char* src = kProbeKernel;
        cl_program program = clCreateProgramWithSource(cl.context, 1, &src, nullptr, &probeErr);
        CL_REQUIRE(probeErr);
        const cl_int built =
            clBuildProgram(program, 1, &cl.device, options.c_str(), nullptr, nullptr);
        size_t size = 0;
        clGetProgramBuildInfo(program, cl.device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &size);
        std::string log(size, '\0');
        clGetProgramBuildInfo(program, cl.device, CL_PROGRAM_BUILD_LOG, size, log.data(), nullptr);
        clReleaseProgram(program);
        INFO(options << ":\n" << log);
        CHECK(built == CL_SUCCESS);
    }
}
