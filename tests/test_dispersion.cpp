// Dispersion: pbrt-v4's "spectrum eta" on dielectric and thindielectric (a named glass, pairs or
// a file), the knots the device holds, what is refused, and every method's image of dispersive
// lids against the analytic radiance per bin and of a dispersive scene against PT.
#include <doctest/doctest.h>

#include "layered_reference.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "spectral/named_spectra.h"
#include "test_render_util.h"

#include <array>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

const std::string kTriangle =
    "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0] \"integer indices\" [0 1 2]\n";

cb::DeviceScene deviceOf(const std::string& world, cb::ChannelMode mode = cb::ChannelMode::Auto) {
    return cb::buildDeviceScene(
        cb::parseSceneString("WorldBegin\nLightSource \"point\"\n" + world + kTriangle, "t.pbrt"),
        mode);
}

// The knots of material 0 (Material.dispersion) and their wavelengths.
std::vector<double> knotsOf(const cb::DeviceScene& scene) {
    const int entry = scene.materials[0].dispersion;
    REQUIRE(entry >= 0);
    const int knots = CB_DISPERSION_KNOTS_PER_BIN * cb::kSpectralBins + 1;
    std::vector<double> out;
    for (int k = 0; k < knots; ++k)
        out.push_back(scene.spectra[size_t(entry * scene.channels + k)]);
    return out;
}
double knotNm(int k) {
    return cb::kLambdaMin + cb::kBinWidth * k / CB_DISPERSION_KNOTS_PER_BIN;
}

// text is refused with a message that contains every part.
void expectError(const std::string& text, std::initializer_list<const char*> parts) {
    const std::string e = errorOf(text);
    INFO(text << " -> " << e);
    CHECK(!e.empty());
    for (const char* part : parts)
        CHECK(contains(e, part));
}

} // namespace

TEST_CASE("dispersion: spectrum eta on (thin) dielectrics, the knots, and what is refused") {
    // Each glass's Sellmeier formula gives the catalogue's n_d at the helium d line.
    for (const cb::NamedGlass& g : cb::namedGlasses()) {
        CAPTURE(g.name);
        CHECK(cb::glassIndex(g, 587.5618) == doctest::Approx(g.nd).epsilon(2e-5));
        CHECK(cb::glassIndex(g, 400.0) > cb::glassIndex(g, 700.0));
    }
    const cb::NamedGlass& bk7 = *cb::findNamedGlass("glass-BK7");
    for (const std::string kind : {"dielectric", "thindielectric"}) {
        CAPTURE(kind);
        cb::DeviceScene scene =
            deviceOf("Material \"" + kind + "\" \"spectrum eta\" \"glass-BK7\"\n");
        CHECK(scene.channels == cb::kSpectralBins);
        CHECK(contains(scene.featureNames(), "dispersion"));
        std::vector<double> knots = knotsOf(scene);
        double mean = 0.0;
        for (size_t k = 0; k < knots.size(); ++k) {
            // The glass every 5 nm, linear between: within 1e-5 of the formula.
            CHECK(knots[k] == doctest::Approx(cb::glassIndex(bk7, knotNm(int(k)))).epsilon(1e-5));
            mean += (k == 0 || k + 1 == knots.size() ? 0.5 : 1.0) * knots[k];
        }
        CHECK(scene.materials[0].eta ==
              doctest::Approx(mean / double(knots.size() - 1)).epsilon(1e-6));
        // Pairs: linear between them.
        scene = deviceOf("Material \"" + kind + "\" \"spectrum eta\" [400 1.4 700 1.7]\n");
        knots = knotsOf(scene);
        CHECK(knots.front() == doctest::Approx(1.4));
        CHECK(knots[knots.size() / 2] == doctest::Approx(1.55));
        CHECK(knots.back() == doctest::Approx(1.7));
        CHECK(scene.materials[0].eta == doctest::Approx(1.55));
        // A constant spectrum is the same expectation without the one wavelength.
        scene = deviceOf("Material \"" + kind + "\" \"spectrum eta\" [350 1.45 750 1.45]\n");
        CHECK(scene.materials[0].dispersion == -1);
        CHECK(scene.materials[0].eta == doctest::Approx(1.45));
        CHECK(!contains(scene.featureNames(), "dispersion"));
        CHECK(scene.channels == cb::kSpectralBins);
    }
    cb::DeviceScene plain = deviceOf("Material \"dielectric\" \"float eta\" 1.33\n");
    CHECK(plain.materials[0].dispersion == -1);
    CHECK(plain.channels == 3);
    CHECK(!contains(plain.featureNames(), "dispersion"));

    // Refused, each where it is written.
    const std::string w = "WorldBegin\n";
    expectError(w + "Material \"coateddiffuse\" \"spectrum eta\" \"glass-BK7\"\n",
                {"t.pbrt:2:41", "dispersive index", "coats", "1.5168", "N-BK7"});
    expectError(w + "Material \"coatedconductor\" \"spectrum interface.eta\" [400 1.5 700 1.6]\n",
                {"t.pbrt:2:", "give \"float interface.eta\""});
    expectError(w + "Material \"dielectric\" \"rgb eta\" [1.5 1.5 1.5]\n",
                {"t.pbrt:2:", "\"float eta\" or \"spectrum eta\", not rgb"});
    expectError(w + "Material \"dielectric\" \"spectrum eta\" [450 1.5 700 1.6]\n",
                {"t.pbrt:2:", "covers 450-700 nm", "a dielectric's index must cover 400-700"});
    expectError(w + "Material \"thindielectric\" \"spectrum eta\" [400 1.5 700 0]\n",
                {"t.pbrt:2:", "must be in (0, 100]"});
    expectError(w + "Material \"dielectric\" \"spectrum eta\" \"glass-XY\"\n", {"glass-XY"});
    CHECK_THROWS_WITH(
        deviceOf("Material \"dielectric\" \"spectrum eta\" \"glass-F11\"\n", cb::ChannelMode::Rgb),
        doctest::Contains("needs spectral rendering"));
}

// The lid scene (method_checks.h, lidSceneText) with a dispersive (thin) dielectric lid, its index
// 1.3 at 400 nm rising linearly to 2.6 at 700 nm: a pixel at angle theta to the lid's normal
// sees, per wavelength, what the lid reflects of the sky from above and what it transmits from
// inside. The lid's normal points into the box, so a dielectric's glass is above it: from above,
// R of light leaving the glass (1 past the critical angle); from inside, (1 - R) / eta^2
// (radiance entering the glass). A thin sheet: R_sheet and 1 - R_sheet. Each bin expects the mean
// over its wavelengths, 8 per bin; the image mean in RGB is the film matrix times the sky's bins
// times those means.
TEST_CASE("dispersion: a dispersive lid on a black box under a constant sky, every method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    auto etaAt = [](double nm) { return 1.3 + 1.3 * (nm - 400.0) / 300.0; };
    // Per bin, the mean over its wavelengths of the film's mean of g(cos theta, eta).
    auto binMeans = [&](const std::function<double(double, double)>& g) {
        std::array<double, cb::kSpectralBins> out{};
        const int perBin = 8;
        for (int b = 0; b < cb::kSpectralBins; ++b)
            for (int s = 0; s < perBin; ++s) {
                const double eta = etaAt(cb::kLambdaMin + cb::kBinWidth * (b + (s + 0.5) / perBin));
                out[size_t(b)] +=
                    lidFilmMean([&](double cosTheta) { return g(cosTheta, eta); }, 160) / perBin;
            }
        return out;
    };
    struct Case {
        std::string material, camera;
        std::function<double(double, double)> g;
    };
    const std::string ramp = "\"spectrum eta\" [400 1.3 700 2.6]\n";
    const std::string &above = kLidAbove, &inside = kLidInside;
    const Case cases[] = {
        {"Material \"thindielectric\" " + ramp, above, cbtest::thinSheetReflectance},
        {"Material \"thindielectric\" " + ramp, inside,
         [](double c, double eta) { return 1.0 - cbtest::thinSheetReflectance(c, eta); }},
        {"Material \"dielectric\" " + ramp, above,
         [](double c, double eta) { return cbtest::dielectricFresnel(c, 1.0 / eta); }},
        {"Material \"dielectric\" " + ramp, inside, [](double c, double eta) {
             return (1.0 - cbtest::dielectricFresnel(c, eta)) / (eta * eta);
         }}};
    for (const Case& c : cases) {
        CAPTURE(c.material);
        CAPTURE(c.camera);
        const cb::DeviceScene scene = cb::buildDeviceScene(
            cb::parseSceneString(lidSceneText(c.camera, c.material), "t.pbrt"));
        REQUIRE(scene.channels == cb::kSpectralBins);
        REQUIRE(scene.lights.size() == 1);
        const std::array<double, cb::kSpectralBins> g = binMeans(c.g);
        std::array<double, 3> expected{};
        for (int rgb = 0; rgb < 3; ++rgb)
            for (int b = 0; b < cb::kSpectralBins; ++b)
                expected[size_t(rgb)] +=
                    double(scene.toRgb[size_t(rgb * cb::kSpectralBins + b)]) *
                    scene.spectra[size_t(scene.lights[0].emission * cb::kSpectralBins + b)] *
                    g[size_t(b)];
        // Every pixel of a CPT or CBDPT estimate follows the same wavelength at the lid: 64
        // estimates, so that each run sees every bin. MLT's chains move between wavelengths by
        // their mutations: with 8 estimates the start of its chains put the red channel of the
        // lid seen from inside 5 standard errors off, 64 pass.
        checkEveryMethodChannelMeans(scene, runtime, expected, 8, 64, 1100u, 64);
    }
}

TEST_CASE("dispersion: BDPT, CBDPT and MLT agree with PT through dispersive glass" *
          doctest::test_suite("statistical")) {
    // Floor, wall and block of rough dispersive glass (every connection through them reads the
    // wavelength its subpath follows) and a smooth glass-F11 sphere before the block.
    checkMethodsAgreeWithPt(kDiskLight,
                            "AttributeBegin\nMaterial \"dielectric\" \"spectrum eta\" "
                            "\"glass-F11\"\nTranslate 0.6 0.35 -0.6\n"
                            "Shape \"sphere\" \"float radius\" 0.3\nAttributeEnd\n",
                            "",
                            "Material \"dielectric\" \"spectrum eta\" [400 1.3 700 2.6] "
                            "\"float roughness\" 0.3\n");
}
