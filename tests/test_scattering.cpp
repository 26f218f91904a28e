// Scattering media (pbrt-v4's "homogeneous" media with sigma_s above 0): what the parser and the
// device scene keep, the Henyey-Greenstein phase function and its sampling, the distance
// sampling's weights against their integrals, and every method's images against the radiance
// transport equation solved apart: a sphere of fog lit by its own glowing wall, where single
// scattering has a one-dimensional integral and a fog that does not absorb keeps the wall's
// radiance everywhere (a furnace).
#include <doctest/doctest.h>

#include "cb_medium.h"
#include "fog_checks.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "test_render_util.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <string>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

using namespace cbtest::fog_checks;

namespace {

// A homogeneous medium's transmittance and distances do not depend on where its segment lies.
const cbk::Vec3 kOrigin = cbk::vec3(0.0f, 0.0f, 0.0f), kUp = cbk::vec3(0.0f, 0.0f, 1.0f);

} // namespace

TEST_CASE("scattering media: the device scene keeps sigma_t, sigma_s and g") {
    TempDirCleanup cleanup;
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parseInTemp(fmt::format("MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" "
                                "\"rgb sigma_a\" [0.1 0.2 0.3] \"rgb sigma_s\" [1 2 0] "
                                "\"float scale\" 2 \"float g\" -0.4\n") +
                    "WorldBegin\nLightSource \"point\"\nMaterial \"diffuse\"\n"
                    "MediumInterface \"fog\" \"\"\nShape \"sphere\"\n"));
    CHECK((scene.features & CB_FEATURE_SCATTERING) != 0);
    CHECK(contains(scene.featureNames(), "scattering"));
    const int fog = scene.materials.back().mediumInside;
    REQUIRE(fog >= 0);
    const std::array<double, 3> sigmaT{2.2, 4.4, 0.6}, sigmaS{2, 4, 0};
    for (int c = 0; c < 3; ++c) {
        CHECK(scene.spectra[size_t(fog * 3 + c)] == doctest::Approx(sigmaT[size_t(c)]));
        CHECK(scene.spectra[size_t((fog + CB_MEDIUM_SIGMA_S) * 3 + c)] ==
              doctest::Approx(sigmaS[size_t(c)]));
        CHECK(scene.spectra[size_t((fog + CB_MEDIUM_ASYMMETRY) * 3 + c)] == -0.4f);
    }
    const cbk::SceneView view = cbtest::hostView(scene);
    CHECK(cbk::mediumScatters(&view, fog));
    CHECK(cbk::mediumAsymmetry(&view, fog) == -0.4f);
    CHECK(!cbk::mediumScatters(&view, -1));
    // Transmittance is exp(-sigma_t d): absorption and out-scattering.
    const cbk::Spectrum t = cbk::mediumTransmittance(&view, fog, kOrigin, kUp, 0.5f);
    for (int c = 0; c < 3; ++c)
        CHECK(t.c[c] == doctest::Approx(std::exp(-0.5 * sigmaT[size_t(c)])).epsilon(1e-6));

    // pbrt-v4's defaults, sigma_a = sigma_s = 1 and g = 0, scatter; an absorbing medium does not.
    const cb::DeviceScene defaults =
        cb::buildDeviceScene(parseInTemp("MakeNamedMedium \"fog\" \"string type\" \"homogeneous\"\n"
                                         "WorldBegin\nLightSource \"point\"\nMaterial \"diffuse\"\n"
                                         "MediumInterface \"fog\" \"\"\nShape \"sphere\"\n"));
    CHECK((defaults.features & CB_FEATURE_SCATTERING) != 0);
    const int d = defaults.materials.back().mediumInside;
    CHECK(defaults.spectra[size_t(d * 3)] == doctest::Approx(2.0));
    CHECK(defaults.spectra[size_t((d + CB_MEDIUM_SIGMA_S) * 3)] == doctest::Approx(1.0));
    const cb::DeviceScene ink = cb::buildDeviceScene(
        parseInTemp("MakeNamedMedium \"ink\" \"string type\" \"homogeneous\" \"rgb sigma_s\" "
                    "[0 0 0]\nWorldBegin\nLightSource \"point\"\nMaterial \"diffuse\"\n"
                    "MediumInterface \"ink\" \"\"\nShape \"sphere\"\n"));
    CHECK((ink.features & CB_FEATURE_MEDIUM) != 0);
    CHECK((ink.features & CB_FEATURE_SCATTERING) == 0);
}

TEST_CASE("scattering media: what cbdpt refuses, naming the file, line and value") {
    TempDirCleanup cleanup;
    auto inMedium = [&](const std::string& parameters) {
        return errorOf("MakeNamedMedium \"m\" \"string type\" \"homogeneous\" " + parameters +
                       "\nWorldBegin\nMediumInterface \"m\" \"\"\nShape \"sphere\"\n");
    };
    std::string e = inMedium("\"float g\" 1");
    CHECK(contains(e, "t.pbrt:1"));
    CHECK(contains(e, "\"float g\" must be in (-1, 1), got 1"));
    CHECK(contains(inMedium("\"float g\" -1.5"), "got -1.5"));
    e = inMedium("\"string preset\" \"Wholemilk\"");
    CHECK(contains(e, "medium \"m\" names the measured \"preset\" \"Wholemilk\""));
    CHECK(contains(e, "cbdpt renders \"homogeneous\", \"uniformgrid\" and \"nanovdb\" media "
                      "of \"sigma_a\" and \"sigma_s\" without \"Le\" (a shape sits in it at "));
    CHECK(contains(e, "t.pbrt:4")); // the shape in it
    CHECK(contains(inMedium("\"rgb Le\" [1 1 1]"), "emits (its \"Le\" is not 0)"));
    CHECK(contains(inMedium("\"rgb sigma_s\" [1 -1 1]"), "negative value"));
}

// The phase function (cb_sampling.h, shared with the coated materials' layers) integrates to 1
// over the sphere; its sampled directions follow it (their mean cosine to the travel direction is
// g, Henyey and Greenstein 1941) with the pdf it reports.
TEST_CASE("scattering media: the Henyey-Greenstein phase function and its sampling") {
    const cbk::Vec3 d = cbk::vnormalize(cbk::vec3(0.3f, -0.5f, 0.8f));
    for (const double g : {-0.9, -0.3, 0.0, 0.0005, 0.5, 0.95}) {
        CAPTURE(g);
        // Integral over the sphere by the cosine alone (azimuthal symmetry).
        const int n = 200000;
        double integral = 0.0;
        for (int i = 0; i < n; ++i) {
            const double mu = -1.0 + (i + 0.5) * 2.0 / n;
            integral += henyeyGreenstein(g, mu) * 2.0 * M_PI * 2.0 / n;
        }
        CHECK(integral == doctest::Approx(1.0).epsilon(1e-4));
        // A stratified grid of samples: the mean cosine, the pdf, unit directions.
        const int m = 400;
        double meanCos = 0.0, meanSin = 0.0;
        double worstPdf = 0.0;
        for (int i = 0; i < m; ++i)
            for (int j = 0; j < m; ++j) {
                float pdf = 0.0f;
                const cbk::Vec3 wi = cbk::phaseHenyeyGreensteinSample(
                    d, float(g), (float(i) + 0.5f) / float(m), (float(j) + 0.5f) / float(m), &pdf);
                REQUIRE(cbk::vlength(wi) == doctest::Approx(1.0).epsilon(1e-5));
                const double cosTheta = cbk::vdot(d, wi);
                meanCos += cosTheta;
                meanSin += cbk::vdot(cbk::vcross(d, wi), cbk::vec3(1, 0, 0));
                const double expected =
                    std::fabs(g) < 1e-3 ? 1.0 / (4.0 * M_PI) : henyeyGreenstein(g, cosTheta);
                worstPdf = std::max(worstPdf, std::fabs(pdf / expected - 1.0));
                CHECK(cbk::phaseHenyeyGreenstein(float(cosTheta), float(g)) ==
                      doctest::Approx(pdf).epsilon(1e-3));
            }
        meanCos /= double(m) * m;
        CHECK(meanCos == doctest::Approx(std::fabs(g) < 1e-3 ? 0.0 : g).epsilon(1e-3).scale(1));
        CHECK(std::fabs(meanSin) / (double(m) * m) < 1e-3); // the azimuth is uniform
        CHECK(worstPdf < 1e-3);
    }
}

// Over a stratified grid of (channel, distance) numbers, the mean of the weights of the rays
// that scatter must be int_0^tMax sigma_s exp(-sigma_t t) dt = sigma_s / sigma_t (1 - T), and of
// those that pass, T = exp(-sigma_t tMax), per channel, whatever throughput weighs the channel
// choice: the one-sample MIS over channels is unbiased for each, also where a channel does not
// interact at all or carries nothing. The throughput's sum never grows. Where the channels'
// sigma_t lie up to 40 orders of magnitude apart no weight is non-finite or negative.
TEST_CASE("scattering media: distance sampling's weights integrate to the transmittance") {
    TempDirCleanup cleanup;
    struct Case {
        std::array<double, 3> sigmaA, sigmaS;
        bool integrate; // false: extreme values, checked for finite weights only
    };
    const Case cases[] = {{{0.1, 0.2, 0.3}, {1, 2, 3}, true},
                          {{0, 0, 0}, {0.5, 0.05, 5}, true},
                          {{0.5, 0, 0}, {0.5, 0, 0.2}, true},
                          {{1e20, 0, 1e-20}, {1e20, 0, 1e-20}, false},
                          {{0, 3e38, 0}, {1e-30, 0, 1e10}, false}};
    const std::array<cbk::Spectrum, 3> throughputs{
        cbk::specConst(1.0f), cbk::Spectrum{{0.2f, 1.0f, 3.0f}}, cbk::Spectrum{{0.0f, 2.0f, 0.5f}}};
    for (const Case& m : cases) {
        CAPTURE(m.sigmaS[0]);
        const cb::DeviceScene scene = cb::buildDeviceScene(
            parseInTemp(fogMedium(m.sigmaA, m.sigmaS, 0) +
                        "WorldBegin\nLightSource \"point\"\nMaterial \"diffuse\"\n"
                        "MediumInterface \"fog\" \"\"\nShape \"sphere\"\n"));
        const cbk::SceneView view = cbtest::hostView(scene);
        const int fog = scene.materials.back().mediumInside;
        for (const cbk::Spectrum& beta : throughputs) {
            CAPTURE(beta.c[1]);
            for (const double tMax : {0.05, 1.0, 30.0, double(CB_INFINITY)}) {
                CAPTURE(tMax);
                // 210 channel strata: the throughputs' shares end on their edges.
                const int nc = 210, nd = 20000;
                std::array<double, 3> scattered{0, 0, 0}, passed{0, 0, 0};
                long bad = 0;
                const double sum = double(beta.c[0]) + beta.c[1] + beta.c[2];
                for (int i = 0; i < nc; ++i)
                    for (int j = 0; j < nd; ++j) {
                        float t = 0.0f;
                        cbk::Spectrum w;
                        const bool s = cbk::mediumSampleDistance(
                            &view, fog, beta, kOrigin, kUp, float(tMax),
                            (float(i) + 0.5f) / float(nc), (float(j) + 0.5f) / float(nd), &t, &w);
                        if (s && !(t < float(tMax))) ++bad; // scattered beyond the surface
                        double after = 0.0;
                        for (int c = 0; c < 3; ++c) {
                            if (!std::isfinite(w.c[c]) || w.c[c] < 0.0f) ++bad;
                            (s ? scattered : passed)[size_t(c)] += w.c[c];
                            after += double(w.c[c]) * beta.c[c];
                        }
                        if (after > sum * (1.0 + 1e-5)) ++bad; // the sum grew
                    }
                CHECK(bad == 0);
                if (!m.integrate) continue;
                for (size_t c = 0; c < 3; ++c) {
                    CAPTURE(c);
                    // A channel that carries nothing has no estimate to check.
                    if (beta.c[c] == 0.0f) continue;
                    const double sigmaT = m.sigmaA[c] + m.sigmaS[c];
                    const double transmittance =
                        tMax < CB_INFINITY ? std::exp(-sigmaT * tMax) : (sigmaT > 0 ? 0.0 : 1.0);
                    const double scatter =
                        sigmaT > 0 ? m.sigmaS[c] / sigmaT * (1.0 - transmittance) : 0.0;
                    // The grid's quadrature error, at most a few parts in 1e3 of either integral.
                    CHECK(scattered[c] / (double(nc) * nd) ==
                          doctest::Approx(scatter).epsilon(3e-3).scale(1e-6));
                    CHECK(passed[c] / (double(nc) * nd) ==
                          doctest::Approx(transmittance).epsilon(3e-3).scale(1e-6));
                }
            }
        }
    }
    // No throughput: nothing to carry, no weight.
    const cb::DeviceScene scene =
        cb::buildDeviceScene(parseInTemp(fogMedium({0, 0, 0}, {1, 1, 1}, 0) +
                                         "WorldBegin\nLightSource \"point\"\nMaterial \"diffuse\"\n"
                                         "MediumInterface \"fog\" \"\"\nShape \"sphere\"\n"));
    const cbk::SceneView view = cbtest::hostView(scene);
    float t = 0.0f;
    cbk::Spectrum w;
    CHECK(!cbk::mediumSampleDistance(&view, scene.materials.back().mediumInside, cbk::specZero(),
                                     kOrigin, kUp, 2.0f, 0.5f, 0.5f, &t, &w));
    CHECK(cbk::specIsBlack(w));
}

// Every method against singleScatteringRadiance: paths of at most 3 vertices (the camera, a
// point in the fog or on the wall, and the wall), per channel, coloured absorption and scattering
// and a forward-scattering phase function, so that next-event estimation, phase sampling, light
// tracing from points in the fog (BDPT's t = 1) and their weights all count. Paths of 2 vertices
// see the wall through the fog alone.
TEST_CASE("scattering media: every method in a glowing sphere of fog, against single "
          "scattering" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const std::array<double, 3> sigmaA{0.1, 0.3, 0.6}, sigmaS{1.2, 0.7, 0.3};
    const double g = 0.6, radius = 1.5, glow = 2.0;
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parseInTemp(fogSphereScene(fogMedium(sigmaA, sigmaS, g), radius, glow)));
    REQUIRE((scene.features & CB_FEATURE_SCATTERING) != 0);
    std::array<Shells, 3> shells;
    for (size_t c = 0; c < 3; ++c)
        shells[c] = {{radius}, {sigmaA[c] + sigmaS[c]}, {sigmaS[c]}, {g}};
    checkEveryMethodAgainstSingleScattering(scene, runtime, shells, glow, 31u);
}

// A fog that does not absorb, inside a wall that glows with radiance L: the radiance is L at
// every point and in every direction (what the fog scatters in equals what it scatters out), for
// any sigma_s and phase function, per channel. Paths of 24 vertices leave out only those that
// scatter more than 22 times before reaching the wall, at optical radius up to 1.2 a negligible
// share. Channels with different sigma_s (one 0) test the one-sample MIS over channels; BDPT's
// strategies all meet points in the fog.
TEST_CASE("scattering media: every method in a furnace of fog keeps the wall's radiance" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    for (const double g : {-0.5, 0.0, 0.8}) {
        CAPTURE(g);
        checkEveryMethodKeepsGlow(cb::buildDeviceScene(parseInTemp(fogSphereScene(
                                      fogMedium({0, 0, 0}, {1.2, 0.5, 0}, g), 1.0, 1.5))),
                                  runtime, 1.5, 41u);
    }
}

// Every strategy in fog (checkMethodsAgreeWithPtInFogBox), the box closed by glass of index 1.
TEST_CASE("scattering media: BDPT, CBDPT and MLT agree with PT inside a box of fog" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPtInFogBox("Material \"dielectric\" \"float eta\" 1\n");
}
