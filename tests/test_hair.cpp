// pbrt-v4's "hair" material (Chiang, Bitterli, Tappan and Burley 2016; kernels/cb_bsdf.h,
// hairLobeEval and hairSample): what the parser and the device scene make of its parameters and
// refuse; the BSDF's white furnace (energy kept where nothing is absorbed), its sampler's weights,
// density and histogram, importance against uniform sampling where it absorbs, the adjoint
// f*(wo, wi) = f(wi, wo) of a non-reciprocal BSDF; and images: a hair quad and sphere in a white
// furnace, and BDPT, CBDPT and MLT against PT.
#include <doctest/doctest.h>

#include "cb_bsdf.h"
#include "chi2.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "test_render_util.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

const std::string kWorld = "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n";
const std::string kQuad = "Shape \"bilinearmesh\" \"point3 P\" [-1 -1 0  1 -1 0  -1 1 0  1 1 0]\n";

// The device scene of one quad of hair given `params`, with its host view.
struct HairScene {
    cb::DeviceScene scene;
    cbk::SceneView view;
    explicit HairScene(const std::string& params)
        : scene(cb::buildDeviceScene(cb::parseSceneString(
              kWorld + "Material \"hair\" " + params + "\n" + kQuad, "t.pbrt"))),
          view(cbtest::hostView(scene)) {}
    const cbk::Material& material() const { return scene.materials[0]; }
};

struct Uniform {
    std::mt19937 rng;
    explicit Uniform(unsigned seed) : rng(seed) {}
    float operator()() { return static_cast<float>(rng() >> 8) * (1.0f / 16777216.0f); }
};

// A shading frame whose first axis (the fibre) is not a coordinate axis.
const cbk::Frame kFrame = cbk::frameFromNormalTangent(cbk::vnormalize(cbk::vec3(0.3f, -0.5f, 0.8f)),
                                                      cbk::vec3(1.0f, 0.2f, 0.1f));

// The world direction of hair angles theta (from the normal plane toward the fibre, sin theta =
// x) and phi (atan2(z, y)) in kFrame, pbrt-v4's hair coordinates.
cbk::Vec3 hairDirection(double theta, double phi) {
    return cbk::frameToWorld(kFrame, cbk::vec3(float(std::sin(theta)),
                                               float(std::cos(theta) * std::cos(phi)),
                                               float(std::cos(theta) * std::sin(phi))));
}

// A uniformly random world direction.
cbk::Vec3 uniformDirection(Uniform& u) {
    const double z = 1.0 - 2.0 * u(), phi = 2.0 * M_PI * u();
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return cbk::vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
}

cbk::TexCoord uvAt(double h) {
    cbk::TexCoord uv{};
    uv.u = 0.3f;
    uv.v = float((h + 1.0) / 2.0);
    uv.hero = -1.0f;
    return uv;
}

// The integral over the sphere of g(wi) (a world direction), in hair angles (d omega = cos theta
// d theta d phi), by Gauss-Legendre panels fine enough for the narrowest lobes tested (beta 0.1:
// a longitudinal spread of about 0.04 rad).
double sphereIntegral(const std::function<double(cbk::Vec3)>& g, int thetaPanels = 64,
                      int phiPanels = 128) {
    const double* x = cbtest::gaussLegendre8Nodes();
    const double* w = cbtest::gaussLegendre8Weights();
    const double dt = M_PI / thetaPanels, dp = 2.0 * M_PI / phiPanels;
    double sum = 0.0;
    for (int a = 0; a < thetaPanels; ++a)
        for (int i = 0; i < 8; ++i) {
            const double theta = -M_PI / 2 + (a + 0.5 + 0.5 * x[i]) * dt;
            double row = 0.0;
            for (int b = 0; b < phiPanels; ++b)
                for (int j = 0; j < 8; ++j) {
                    const double phi = -M_PI + (b + 0.5 + 0.5 * x[j]) * dp;
                    row += w[j] * g(hairDirection(theta, phi));
                }
            sum += w[i] * std::cos(theta) * row;
        }
    return sum * 0.25 * dt * dp;
}

// f(wo, wi) |cos theta_i| (the surface's cosine), channel c.
double scattered(const HairScene& s, cbk::TexCoord uv, cbk::Vec3 wo, cbk::Vec3 wi, int c = 0,
                 int adjoint = 0) {
    float pf, pr;
    const cbk::Spectrum f = cbk::bsdfEval(&s.view, 0, uv, kFrame, wo, wi, adjoint, &pf, &pr);
    return double(f.c[c]) * std::fabs(double(cbk::vdot(wi, kFrame.n)));
}

} // namespace

TEST_CASE("hair: parameters as pbrt-v4's HairMaterial::Create, refusals with file and line") {
    TempDirCleanup cleanup;
    auto sigmaOf = [](const HairScene& s) {
        const int e = s.material().reflectance;
        return std::array<double, 3>{s.scene.spectra[size_t(3 * e)],
                                     s.scene.spectra[size_t(3 * e + 1)],
                                     s.scene.spectra[size_t(3 * e + 2)]};
    };
    // Defaults: eumelanin 1.3, eta 1.55, beta_m = beta_n = 0.3, alpha 2 degrees.
    {
        const HairScene s("");
        const cbk::Material& m = s.material();
        CHECK(m.kind == CB_MAT_HAIR);
        CHECK(m.eta == doctest::Approx(1.55));
        const std::array<double, 3> sigma = sigmaOf(s);
        CHECK(sigma[0] == doctest::Approx(1.3 * 0.419));
        CHECK(sigma[1] == doctest::Approx(1.3 * 0.697));
        CHECK(sigma[2] == doctest::Approx(1.3 * 1.37));
        const double b = 0.3;
        CHECK(m.hairV ==
              doctest::Approx(std::pow(0.726 * b + 0.812 * b * b + 3.7 * std::pow(b, 20), 2)));
        CHECK(m.hairS == doctest::Approx(std::sqrt(M_PI / 8) *
                                         (0.265 * b + 1.194 * b * b + 5.372 * std::pow(b, 22))));
        CHECK(m.hairSinAlpha == doctest::Approx(std::sin(2.0 * M_PI / 180)));
        CHECK(m.hairCosAlpha == doctest::Approx(std::cos(2.0 * M_PI / 180)));
        const std::uint64_t need = CB_FEATURE_HAIR | CB_FEATURE_TEXTURE | CB_FEATURE_ANISOTROPIC;
        CHECK((s.scene.features & need) == need);
        CHECK(contains(s.scene.featureNames(), "hair"));
    }
    // Melanin concentrations, in sRGB; roughnesses clamped to [0.01, 1] as GetBxDF does.
    {
        const HairScene s("\"float eumelanin\" 0.5 \"float pheomelanin\" 2 \"float beta_m\" 3 "
                          "\"float beta_n\" 0 \"float eta\" 1.3 \"float alpha\" 0");
        const std::array<double, 3> sigma = sigmaOf(s);
        CHECK(sigma[0] == doctest::Approx(0.5 * 0.419 + 2 * 0.187));
        CHECK(sigma[1] == doctest::Approx(0.5 * 0.697 + 2 * 0.4));
        CHECK(sigma[2] == doctest::Approx(0.5 * 1.37 + 2 * 1.05));
        CHECK(s.material().hairV == doctest::Approx(std::pow(0.726 + 0.812 + 3.7, 2)));
        CHECK(s.material().hairS ==
              doctest::Approx(std::sqrt(M_PI / 8) * (0.265 * 0.01 + 1.194 * 1e-4)));
        CHECK(s.material().eta == doctest::Approx(1.3));
        CHECK(s.material().hairSinAlpha == 0.0f);
    }
    // "reflectance" (or "color") becomes sigma_a per channel with beta_n (SigmaAFromReflectance);
    // a declaration with a leading space parses, as pbrt-v4 splits it on white space.
    for (const std::string name : {"reflectance", "color"}) {
        CAPTURE(name);
        const HairScene s("\"rgb " + name + "\" [0.5 0.3 0.1] \" float beta_n\" 0.5");
        const double bn = 0.5;
        const double d = 5.969 - 0.215 * bn + 2.532 * bn * bn - 10.73 * std::pow(bn, 3) +
                         5.574 * std::pow(bn, 4) + 0.245 * std::pow(bn, 5);
        const std::array<double, 3> sigma = sigmaOf(s), c{0.5, 0.3, 0.1};
        for (size_t k = 0; k < 3; ++k)
            CHECK(sigma[k] == doctest::Approx(std::pow(std::log(c[k]) / d, 2)));
    }
    // "sigma_a" wins over the others (pbrt-v4 warns; cbdpt notes); a constant float texture
    // counts as its number.
    {
        const HairScene s("\"rgb sigma_a\" [0.1 0.2 0.3] \"rgb reflectance\" [0.5 0.5 0.5] "
                          "\"float eumelanin\" 3");
        const std::array<double, 3> sigma = sigmaOf(s);
        CHECK(sigma[0] == doctest::Approx(0.1));
        CHECK(sigma[2] == doctest::Approx(0.3));
        const cb::DeviceScene t = cb::buildDeviceScene(
            cb::parseSceneString(kWorld +
                                     "Texture \"b\" \"float\" \"constant\" \"float value\" 0.7\n"
                                     "Material \"hair\" \"texture beta_m\" \"b\"\n" +
                                     kQuad,
                                 "t.pbrt"));
        CHECK(t.materials[0].hairV ==
              doctest::Approx(std::pow(0.726 * 0.7 + 0.812 * 0.49 + 3.7 * std::pow(0.7, 20), 2)));
    }
    // Refusals, naming the file and line.
    std::string e = errorOf(kWorld +
                            "Texture \"b\" \"float\" \"scale\" \"float scale\" 0.5 "
                            "\"float tex\" 0.3\n"
                            "Material \"hair\"\n  \"texture beta_n\" \"b\"\n" +
                            kQuad);
    CHECK(contains(e, "t.pbrt:5"));
    CHECK(contains(e, "hair's \"texture beta_n\" must name a float texture of class \"constant\""));
    e = errorOf(kWorld +
                "Texture \"c\" \"spectrum\" \"constant\" \"rgb value\" [0.5 0.5 0.5]\n"
                "Material \"hair\" \"texture reflectance\" \"c\"\n" +
                kQuad);
    CHECK(contains(e, "t.pbrt:4"));
    CHECK(contains(e, "a texture as hair's \"reflectance\" is not supported"));
    e = errorOf(kWorld + "Material \"hair\" \"float eta\" 0\n" + kQuad);
    CHECK(contains(e, "t.pbrt:3"));
    CHECK(contains(e, "hair's \"eta\" must be in (0, 100], got 0"));
    e = errorOf(kWorld + "Material \"hair\" \"rgb sigma_a\" [0.1 -0.2 0.3]\n" + kQuad);
    CHECK(contains(e, "t.pbrt:3"));
    CHECK(contains(e, "negative value"));
    e = errorOf(kWorld + "Material \"hair\" \"rgb reflectance\" [0.1 2 0.3]\n" + kQuad);
    CHECK(contains(e, "must be <= 1"));
    e = errorOf(kWorld + "Material \"hair\"\n \"float displacement\" 0.1\n" + kQuad);
    CHECK(contains(e, "t.pbrt:4"));
    CHECK(contains(e, "unknown or unsupported parameter \"float displacement\""));
    // pbrt-v4 turns the fibre by a mesh's tangents "S", cbdpt by dp/du.
    e = errorOf(kWorld + "Material \"hair\"\n" +
                "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0] \"integer indices\" "
                "[0 1 2]\n    \"vector3 S\" [1 0 0  1 0 0  1 0 0]\n");
    CHECK(contains(e, "t.pbrt:5"));
    CHECK(contains(e, "is not supported (nor with hair)"));
    // A disk's (u, v) is not linear over the triangles cbdpt renders it as: no h.
    e = deviceErrorOf(kWorld + "Material \"hair\"\nShape \"disk\"\n");
    CHECK(contains(e, "hair (along dp/du, across v)"));
    CHECK(contains(e, "which needs texture coordinates"));
}

// pbrt-v4's Hair.WhiteFurnace with a quadrature in place of its Monte Carlo: with sigma_a = 0
// the fibre absorbs nothing, and for every wo and h the scattering f |cos theta_i| integrates
// to 1 over the sphere (the lobes' Ap sum to 1 and each Mp and Np is normalised).
TEST_CASE("hair: white furnace, f |cos| integrates to 1 where sigma_a = 0") {
    Uniform u(7);
    double worst = 0.0;
    for (const double bm : {0.1, 0.3, 0.7})
        for (const double bn : {0.1, 0.5, 0.9}) {
            const HairScene s(fmt::format("\"rgb sigma_a\" [0 0 0] \"float beta_m\" {} "
                                          "\"float beta_n\" {}",
                                          bm, bn));
            {
                const cbk::Vec3 wo = uniformDirection(u);
                const double h = -1.0 + 2.0 * u();
                const double integral =
                    sphereIntegral([&](cbk::Vec3 wi) { return scattered(s, uvAt(h), wo, wi); });
                CAPTURE(bm);
                CAPTURE(bn);
                CAPTURE(h);
                CHECK(std::fabs(integral - 1.0) < 1e-4);
                worst = std::max(worst, std::fabs(integral - 1.0));
            }
        }
    MESSAGE("white furnace: worst |integral - 1| = " << worst);
}

// The adjoint: importance scatters by f*(wo, wi) = f(wi, wo) (Veach 1997, sec. 3.7.1), its
// pdfs those of the same sampler; and the hair's f is indeed not reciprocal.
TEST_CASE("hair: adjoint evaluation is f(wi, wo), sampling returns it") {
    const HairScene s("\"float eumelanin\" 0.8 \"float beta_m\" 0.25 \"float beta_n\" 0.4");
    Uniform u(11);
    double asymmetry = 0.0;
    for (int i = 0; i < 2000; ++i) {
        const cbk::Vec3 wo = uniformDirection(u), wi = uniformDirection(u);
        const cbk::TexCoord uv = uvAt(-1.0 + 2.0 * u());
        float pfA, prA, pf, pr;
        const cbk::Spectrum fA = cbk::bsdfEval(&s.view, 0, uv, kFrame, wo, wi, 1, &pfA, &prA);
        const cbk::Spectrum f = cbk::bsdfEval(&s.view, 0, uv, kFrame, wi, wo, 0, &pf, &pr);
        for (int c = 0; c < 3; ++c)
            CHECK(fA.c[c] == f.c[c]);
        CHECK(pfA == pr);
        CHECK(prA == pf);
        float pf2, pr2;
        const cbk::Spectrum fFwd = cbk::bsdfEval(&s.view, 0, uv, kFrame, wo, wi, 0, &pf2, &pr2);
        CHECK(pf2 == pfA);
        CHECK(pr2 == prA);
        if (f.c[0] > 1e-3f)
            asymmetry = std::max(asymmetry, std::fabs(double(fFwd.c[0]) / double(f.c[0]) - 1.0));
        // An adjoint sample carries the adjoint f and the pdfs bsdfEval gives.
        cbk::BsdfSample bs;
        if (cbk::bsdfSample(&s.view, 0, uv, kFrame, wo, u(), u(), u(), 1, &bs)) {
            float pe, pre;
            const cbk::Spectrum fe = cbk::bsdfEval(&s.view, 0, uv, kFrame, wo, bs.wi, 1, &pe, &pre);
            CHECK(bs.f.c[1] == doctest::Approx(fe.c[1]).epsilon(1e-4));
            CHECK(bs.pdf == doctest::Approx(pe).epsilon(1e-4));
            CHECK(bs.pdfRev == doctest::Approx(pre).epsilon(1e-4));
            CHECK(bs.isDelta == 0);
        }
    }
    CHECK(asymmetry > 0.1);
}

// pbrt-v4's Hair.SamplingWeights and WhiteFurnaceSampled: where sigma_a = 0 the sampler's pdf
// is f |cos| itself (the lobes chosen by Ap, which sum to 1), so every sample's weight is 1 up
// to rounding; and a sample's f and pdfs are bsdfEval's.
TEST_CASE("hair: sample weights are 1 where sigma_a = 0") {
    Uniform u(3);
    for (const double bm : {0.1, 0.3, 0.5, 0.9})
        for (const double bn : {0.1, 0.4, 0.8}) {
            CAPTURE(bm);
            CAPTURE(bn);
            const HairScene s(fmt::format("\"rgb sigma_a\" [0 0 0] \"float beta_m\" {} "
                                          "\"float beta_n\" {}",
                                          bm, bn));
            // Rounding: directions go to world space and back, and f's 1 / |cos theta_i| near
            // grazing magnifies it; so the worst within pbrt-v4's 1e-2, the typical far below.
            double worst = 0.0, worstEval = 0.0, meanDeviation = 0.0;
            int failed = 0, large = 0;
            const int n = 4000;
            for (int i = 0; i < n; ++i) {
                const cbk::Vec3 wo = uniformDirection(u);
                const cbk::TexCoord uv = uvAt(std::clamp(-1.0 + 2.0 * u(), -0.999999, 0.999999));
                cbk::BsdfSample bs;
                if (!cbk::bsdfSample(&s.view, 0, uv, kFrame, wo, u(), u(), u(), 0, &bs)) {
                    ++failed;
                    continue;
                }
                const double w =
                    bs.f.c[2] * std::fabs(double(cbk::vdot(bs.wi, kFrame.n))) / double(bs.pdf);
                worst = std::max(worst, std::fabs(w - 1.0));
                meanDeviation += std::fabs(w - 1.0) / n;
                float pf, pr;
                const cbk::Spectrum f =
                    cbk::bsdfEval(&s.view, 0, uv, kFrame, wo, bs.wi, 0, &pf, &pr);
                const double e = std::max(std::fabs(double(f.c[0]) / bs.f.c[0] - 1.0),
                                          std::fabs(double(pf) / bs.pdf - 1.0));
                worstEval = std::max(worstEval, e);
                if (e > 1e-4) ++large;
            }
            CAPTURE(worst);
            CAPTURE(meanDeviation);
            CAPTURE(worstEval);
            CAPTURE(large);
            CHECK(failed <= n / 1000);
            CHECK(worst < 1e-2);
            CHECK(meanDeviation < 1e-4);
            CHECK(worstEval < 1e-2);
            CHECK(large <= n / 100);
            MESSAGE("bm " << bm << " bn " << bn << ": worst " << worst << " mean " << meanDeviation
                          << " eval " << worstEval << " large " << large << " failed " << failed);
        }
}

// The sampler's directions against its pdf: the pdf integrates to 1 over the sphere, and the
// histogram over hair angles (cos-weighted cells in theta, uniform in phi) fits the pdf's
// integrals over the same cells (chi-square at a Sidak-corrected 1%).
TEST_CASE("hair: sampled directions follow the pdf (chi-square)" *
          doctest::test_suite("statistical")) {
    struct Case {
        double bm, bn, h;
        std::string sigma;
    };
    const std::vector<Case> cases{{0.3, 0.3, 0.2, "[0 0 0]"},
                                  {0.2, 0.6, -0.7, "[0.5 1 2]"},
                                  {0.6, 0.2, 0.9, "[0.1 0.1 0.1]"},
                                  {0.9, 0.9, -0.1, "[3 2 1]"}};
    const double level = cbtest::sidak(0.01, int(cases.size()) * 2);
    Uniform u(5);
    for (const Case& c : cases) {
        CAPTURE(c.bm);
        CAPTURE(c.bn);
        CAPTURE(c.h);
        const HairScene s(fmt::format("\"rgb sigma_a\" {} \"float beta_m\" {} \"float beta_n\" {}",
                                      c.sigma, c.bm, c.bn));
        const cbk::TexCoord uv = uvAt(c.h);
        for (int k = 0; k < 2; ++k) {
            const cbk::Vec3 wo = uniformDirection(u);
            auto pdf = [&](cbk::Vec3 wi) {
                float pf, pr;
                cbk::bsdfEval(&s.view, 0, uv, kFrame, wo, wi, 0, &pf, &pr);
                return double(pf);
            };
            // Cells: 36 in sin theta (equal solid angle), 72 in phi.
            const int nt = 36, np = 72;
            auto cellOf = [&](cbk::Vec3 w) {
                const cbk::Vec3 l = cbk::frameToLocal(kFrame, w);
                const double st = std::clamp(double(l.x), -1.0, 1.0);
                double phi = std::atan2(double(l.z), double(l.y)) + M_PI;
                const int it = std::min(nt - 1, int((st + 1.0) / 2.0 * nt));
                const int ip = std::min(np - 1, int(phi / (2 * M_PI) * np));
                return size_t(it * np + ip);
            };
            std::vector<double> expected(size_t(nt * np) + 1, 0.0),
                observed(size_t(nt * np) + 1, 0.0);
            double total = 0.0;
            for (int it = 0; it < nt; ++it)
                for (int ip = 0; ip < np; ++ip) {
                    // d omega = d(sin theta) d phi: integrate the pdf over the cell.
                    const double s0 = -1.0 + 2.0 * it / nt, s1 = -1.0 + 2.0 * (it + 1) / nt;
                    const double p0 = -M_PI + 2 * M_PI * ip / np, p1 = p0 + 2 * M_PI / np;
                    const double v = cbtest::integrate2D(
                        [&](double st, double phi) {
                            const double ct = std::sqrt(std::max(0.0, 1.0 - st * st));
                            return pdf(cbk::frameToWorld(
                                kFrame, cbk::vec3(float(st), float(ct * std::cos(phi)),
                                                  float(ct * std::sin(phi)))));
                        },
                        s0, s1, p0, p1, 3);
                    expected[size_t(it * np + ip)] = v;
                    total += v;
                }
            CHECK(total == doctest::Approx(1.0).epsilon(3e-3));
            const int n = 200000;
            for (int i = 0; i < n; ++i) {
                cbk::BsdfSample bs;
                if (cbk::bsdfSample(&s.view, 0, uv, kFrame, wo, u(), u(), u(), 0, &bs))
                    observed[cellOf(bs.wi)] += 1.0;
                else
                    observed.back() += 1.0;
            }
            for (double& e : expected)
                e *= n;
            expected.back() = std::max(0.0, 1.0 - total) * n;
            const cbtest::Chi2Result r = cbtest::chi2Test(observed, expected, level, 5.0, 1e-5 * n);
            CAPTURE(r.message);
            CHECK(r.passed);
        }
    }
}

// pbrt-v4's Hair.SamplingConsistency: where the fibre absorbs, the scattered radiance of a sky
// Li(w) = (w . n)^2 estimated by the sampler agrees with uniform sampling of the sphere.
TEST_CASE("hair: importance and uniform sampling agree where sigma_a > 0" *
          doctest::test_suite("statistical")) {
    Uniform u(9);
    for (const double bm : {0.2, 0.6})
        for (const double bn : {0.4, 0.8}) {
            CAPTURE(bm);
            CAPTURE(bn);
            const HairScene s(fmt::format("\"rgb sigma_a\" [0.25 0.5 1] \"float beta_m\" {} "
                                          "\"float beta_n\" {}",
                                          bm, bn));
            const cbk::Vec3 wo = uniformDirection(u);
            auto li = [&](cbk::Vec3 w) {
                const double z = cbk::vdot(w, kFrame.n);
                return z * z;
            };
            const int n = 200000;
            std::array<double, 3> sumI{}, sumI2{}, sumU{}, sumU2{};
            for (int i = 0; i < n; ++i) {
                const cbk::TexCoord uv = uvAt(-1.0 + 2.0 * u());
                cbk::BsdfSample bs;
                const bool ok = cbk::bsdfSample(&s.view, 0, uv, kFrame, wo, u(), u(), u(), 0, &bs);
                const cbk::Vec3 wi = uniformDirection(u);
                for (int c = 0; c < 3; ++c) {
                    const double a = ok ? bs.f.c[c] *
                                              std::fabs(double(cbk::vdot(bs.wi, kFrame.n))) *
                                              li(bs.wi) / double(bs.pdf)
                                        : 0.0;
                    const double b = scattered(s, uv, wo, wi, c) * li(wi) * 4.0 * M_PI;
                    sumI[size_t(c)] += a;
                    sumI2[size_t(c)] += a * a;
                    sumU[size_t(c)] += b;
                    sumU2[size_t(c)] += b * b;
                }
            }
            for (size_t c = 0; c < 3; ++c) {
                const double mi = sumI[c] / n, mu = sumU[c] / n;
                const double se =
                    std::sqrt((sumI2[c] / n - mi * mi) / n + (sumU2[c] / n - mu * mu) / n);
                CAPTURE(c);
                CAPTURE(mi);
                CAPTURE(mu);
                CAPTURE(se);
                CHECK(std::fabs(mi - mu) <= 4.5 * se);
                CHECK(se < 0.02 * mu); // the test can see a few per cent
            }
        }
}

// A quad of clear hair (sigma_a = 0) under a uniform sky of radiance 1: what it scatters toward
// the camera is what reaches it from the sky, all of it, so with one bounce (3 vertices) every
// pixel of every method is 1, seen through the hair or not.
TEST_CASE("hair: a clear hair quad in a white furnace renders 1 in every method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = cb::buildDeviceScene(cb::parseSceneString(
        "LookAt 0.3 -1.2 1.6  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 50\n"
        "Film \"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 12\n" +
            kWorld +
            "Material \"hair\" \"rgb sigma_a\" [0 0 0] \"float beta_m\" 0.2 "
            "\"float beta_n\" 0.3\n" +
            kQuad,
        "t.pbrt"));
    for (const std::string method : kMethods) {
        CAPTURE(method);
        cb::IntegratorSettings settings = methodSettings(method);
        settings.maxPathVertices = 3;
        checkChannelMeans(channelMeans(scene, runtime, settings,
                                       method == "mlt"                        ? 64
                                       : method == "cpt" || method == "cbdpt" ? 16
                                                                              : 4,
                                       21u),
                          {1.0, 1.0, 1.0}, 1e-3);
    }
}

// pbrt-v4's hair on a sphere, sigma_a = 0: light enters, crosses and leaves the sphere, never
// absorbed, so with enough bounces the image of the furnace is 1 (PT and BDPT).
TEST_CASE("hair: a clear hair sphere in a white furnace renders 1" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = cb::buildDeviceScene(cb::parseSceneString(
        "LookAt 0 -4 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 30\n"
        "Film \"rgb\" \"integer xresolution\" 10 \"integer yresolution\" 10\n" +
            kWorld + "Material \"hair\" \"rgb sigma_a\" [0 0 0]\nShape \"sphere\"\n",
        "t.pbrt"));
    for (const std::string method : {"pt", "bdpt"}) {
        CAPTURE(method);
        cb::IntegratorSettings settings = methodSettings(method);
        settings.maxPathVertices = 64;
        checkChannelMeans(channelMeans(scene, runtime, settings, 8, 41u), {1.0, 1.0, 1.0}, 2e-3);
    }
}

// Where every strategy matters (a floor, a wall and a block of brown hair under a disk light):
// light subpaths scatter by the adjoint f(wi, wo), so BDPT, CBDPT and MLT estimate PT's image.
TEST_CASE("hair: BDPT, CBDPT and MLT agree with PT" * doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt(kDiskLight, "", "",
                            "Material \"hair\" \"float eumelanin\" 0.4 \"float beta_m\" 0.35 "
                            "\"float beta_n\" 0.5\n");
}
