// pbrt-v4's image infinite light (LightSource "infinite" "string filename"): the image read from
// EXR and PNG, its frame, its sampling tables and densities, and every method's image of a
// diffuse plane under it against the irradiance integrated here (docs/pbrt-v4.md).
#include <doctest/doctest.h>

#include "cb_camera.h"
#include "cb_lights.h"
#include "chi2.h"
#include "image/image.h"
#include "method_checks.h"
#include "scene/scene_desc.h"
#include "scene_files.h"
#include "spectral/spectral.h"
#include "test_render_util.h"

#include <fmt/format.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

using cb::parseSceneString;
using cb::SceneError;
using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

TEST_CASE("pbrt-v4 image light: the image, its frame, its normalisation, and what is refused") {
    TempDirCleanup cleanup;
    writeImage("ramp.exr", 4, 4, [](int x, int y, int c) { return float(10 * y + x) + 0.25f * c; });
    auto s = parseInTemp("WorldBegin\nAttributeBegin\nRotate -90 1 0 0\nLightSource \"infinite\" "
                         "\"string filename\" \"ramp.exr\" \"float scale\" 2\nAttributeEnd\n");
    REQUIRE(s.infiniteLights.size() == 1);
    const cb::InfiniteLightDesc& l = s.infiniteLights[0];
    CHECK(l.image.size == 4);
    REQUIRE(l.image.rgb.size() == 48);
    CHECK(l.image.rgb[3 * (2 * 4 + 3) + 1] == 23.25f); // pixel (3, 2), green; top row first
    CHECK(l.scale == 2.f);
    CHECK(contains(l.image.path, "ramp.exr"));
    CHECK(std::count(s.sourceFiles.begin(), s.sourceFiles.end(), l.image.path) == 1);
    // Rotate -90 about x takes the map's +z to world +y and its +y to world -z.
    const std::array<double, 9> expected{1, 0, 0, 0, 0, 1, 0, -1, 0};
    for (size_t i = 0; i < 9; ++i)
        CHECK(l.worldFromLight[i] == doctest::Approx(expected[i]).epsilon(1e-12));
    // A mirror with a uniform scale is a rotation's equal: the scale is divided out.
    s = parseInTemp("WorldBegin\nScale -2 2 2\nLightSource \"infinite\" \"string filename\" "
                    "\"ramp.exr\"\n");
    CHECK(s.infiniteLights[0].worldFromLight[0] == doctest::Approx(-1.0));
    CHECK(s.infiniteLights[0].worldFromLight[4] == doctest::Approx(1.0));

    // Illuminance: a constant image of 1 at 4 x 4 has pixel centres above the horizon only in
    // the inner four (|u| + |v| = 1/2 in [-1,1]^2, so cos = 1 - 1/4), each 4 pi / 16 sr: 3 pi / 4
    // per unit scale; E = 3 makes the scale 4 / pi.
    writeImage("one4.exr", 4, 4, [](int, int, int) { return 1.f; });
    s = parseInTemp("WorldBegin\nLightSource \"infinite\" \"string filename\" \"one4.exr\" "
                    "\"float illuminance\" 3\n");
    CHECK(s.infiniteLights[0].scale == doctest::Approx(4.0 / M_PI).epsilon(1e-6));
    // Finer, the sum tends to the hemisphere's pi.
    writeImage("one64.exr", 64, 64, [](int, int, int) { return 1.f; });
    s = parseInTemp("WorldBegin\nLightSource \"infinite\" \"string filename\" \"one64.exr\" "
                    "\"float illuminance\" 2\n");
    CHECK(s.infiniteLights[0].scale * M_PI == doctest::Approx(2.0).epsilon(0.02));
    // At 2 x 2 every centre lies on the horizon: nothing to scale.
    writeImage("one2.exr", 2, 2, [](int, int, int) { return 1.f; });
    CHECK(contains(errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" \"one2.exr\" "
                           "\"float illuminance\" 2\n"),
                   "sends no light to an upward-facing surface"));

    // PNG: 8-bit values are sRGB-encoded and decoded exactly.
    cb::writePng8((tempDir() / "grey.png").string(), 2, 2,
                  {0, 0, 0, 128, 128, 128, 255, 255, 255, 10, 20, 30});
    s = parseInTemp("WorldBegin\nLightSource \"infinite\" \"string filename\" \"grey.png\"\n");
    REQUIRE(s.infiniteLights[0].image.rgb.size() == 12);
    CHECK(s.infiniteLights[0].image.rgb[0] == 0.f);
    CHECK(s.infiniteLights[0].image.rgb[3] == doctest::Approx(0.2158605).epsilon(1e-5));
    CHECK(s.infiniteLights[0].image.rgb[6] == doctest::Approx(1.0).epsilon(1e-6));
    CHECK(s.infiniteLights[0].image.rgb[9] == doctest::Approx(10.0 / 255 / 12.92).epsilon(1e-5));

    // Refusals, each naming the line and what was expected.
    const std::string both = errorOf("WorldBegin\n\nLightSource \"infinite\" \"string filename\" "
                                     "\"ramp.exr\" \"rgb L\" [1 1 1]\n");
    CHECK(contains(both, ":3:"));
    CHECK(contains(both, "not both"));
    const std::string missing =
        errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" \"none.exr\"\n");
    CHECK(contains(missing, ":2:"));
    CHECK(contains(missing, "no image file \"none.exr\""));
    writeImage("wide.exr", 4, 2, [](int, int, int) { return 1.f; });
    CHECK(
        contains(errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" \"wide.exr\"\n"),
                 "is 4 x 2"));
    writeImage("nan.exr", 2, 2, [](int x, int y, int c) {
        return x == 1 && y == 0 && c == 2 ? std::nanf("") : 1.f;
    });
    const std::string nan =
        errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" \"nan.exr\"\n");
    CHECK(contains(nan, "pixel (1, 0)"));
    CHECK(contains(nan, "finite"));
    std::ofstream(tempDir() / "sky.webp") << "RIFF";
    CHECK(contains(
        errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" \"sky.webp\"\n"),
        "cbdpt reads OpenEXR (.exr), PNG (.png), Radiance HDR (.hdr), PFM (.pfm), QOI (.qoi)"));
    std::ofstream(tempDir() / "sky.qoi") << "qoif";
    CHECK(
        contains(errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" \"sky.qoi\"\n"),
                 "not a QOI file"));
    std::ofstream(tempDir() / "sky.pfm") << "PF\n";
    CHECK(
        contains(errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" \"sky.pfm\"\n"),
                 "not a PFM file"));
    std::ofstream(tempDir() / "sky.hdr") << "#?RADIANCE\n";
    CHECK(contains(errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" "
                           "\"sky.hdr\"\n"),
                   "cannot read"));
    std::ofstream(tempDir() / "broken.exr") << "not an exr";
    CHECK(contains(errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" "
                           "\"broken.exr\"\n"),
                   "cannot read"));
    // A pixel times the scale beyond the float range is refused when the scene is built.
    writeImage("huge.exr", 2, 2, [](int x, int, int) { return x == 1 ? 1e30f : 1.f; });
    try {
        cb::buildDeviceScene(parseInTemp("WorldBegin\nLightSource \"infinite\" \"string "
                                         "filename\" \"huge.exr\" \"float scale\" 1e20\n" +
                                         std::string("Shape \"trianglemesh\" \"point3 P\" "
                                                     "[0 0 0 1 0 0 0 1 0]\n")));
        FAIL("a pixel of 1e30 times scale 1e20 was accepted");
    } catch (const SceneError& e) {
        CHECK(contains(e.what(), "pixel (1, 0)"));
        CHECK(contains(e.what(), "exceeds the float range"));
    }
    const std::string sheared = errorOf("WorldBegin\nScale 1 2 1\nLightSource \"infinite\" "
                                        "\"string filename\" \"ramp.exr\"\n");
    CHECK(contains(sheared, ":3:"));
    CHECK(contains(sheared, "must be a similarity"));
    // An image behind a portal keeps its frame; the portal's corners stay in world space.
    const cb::SceneDesc portal =
        parseInTemp("WorldBegin\nRotate 90 1 0 0\nLightSource \"infinite\" \"string filename\" "
                    "\"ramp.exr\" \"point3 portal\" [0 0 0 1 0 0 1 1 0 0 1 0]\n");
    REQUIRE(portal.infiniteLights.size() == 1);
    CHECK(portal.infiniteLights[0].image.size > 0);
    CHECK(portal.infiniteLights[0].worldFromLight[4] == doctest::Approx(0.0).scale(1.0));
    CHECK(portal.infiniteLights[0].portal ==
          std::vector<std::array<double, 3>>{{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}});

    // An EXR in another colour space (here Rec. 2020's primaries) is refused.
    {
        const std::string path = (tempDir() / "rec2020.exr").string();
        Imf::Header header(2, 2);
        Imf::addChromaticities(header, Imf::Chromaticities({0.708f, 0.292f}, {0.170f, 0.797f},
                                                           {0.131f, 0.046f}, {0.3127f, 0.3290f}));
        std::vector<float> pixels(4, 1.f);
        Imf::FrameBuffer fb;
        for (const char* name : {"R", "G", "B"}) {
            header.channels().insert(name, Imf::Channel(Imf::FLOAT));
            fb.insert(name, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(pixels.data()),
                                       sizeof(float), 2 * sizeof(float)));
        }
        Imf::OutputFile file(path.c_str(), header);
        file.setFrameBuffer(fb);
        file.writePixels(2);
    }
    const std::string rec2020 =
        errorOf("WorldBegin\nLightSource \"infinite\" \"string filename\" \"rec2020.exr\"\n");
    CHECK(contains(rec2020, "not sRGB's"));
    CHECK(contains(rec2020, "0.708"));
}

TEST_CASE("pbrt-v4 image light: sampling tables, densities and radiance by pixel") {
    TempDirCleanup cleanup;
    // 2 x 2, grey: pixels 1, 0 (top row), 3, 4, times scale 0.5.
    const float values[4] = {1.f, 0.f, 3.f, 4.f};
    writeImage("tables.exr", 2, 2, [&](int x, int y, int) { return values[2 * y + x]; });
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        "WorldBegin\nLightSource \"infinite\" \"string filename\" \"tables.exr\" \"float scale\" "
        "0.5\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"));
    CHECK(contains(scene.featureNames(), "image-light"));
    REQUIRE(scene.lights.size() == 1);
    const cbk::Light& light = scene.lights[0];
    CHECK(light.kind == CB_LIGHT_INFINITE);
    CHECK(light.imageSize == 2);
    // Rows by their sums 1 and 7, then each row's pixels, then the pixels' RGB times scale.
    const std::vector<float> expectedTables{0.f,       0.125f, 1.f,  0.f,  1.f,  1.f, 0.f,
                                            3.f / 7.f, 1.f,    0.5f, 0.5f, 0.5f, 0.f, 0.f,
                                            0.f,       1.5f,   1.5f, 1.5f, 2.f,  2.f, 2.f};
    REQUIRE(scene.lightTables.size() == expectedTables.size());
    for (size_t i = 0; i < expectedTables.size(); ++i)
        CHECK(scene.lightTables[i] == doctest::Approx(expectedTables[i]).epsilon(1e-7));
    const cbk::SceneView view = cbtest::hostView(scene);
    double total = 0.0;
    for (int p = 0; p < 4; ++p) {
        CAPTURE(p);
        const double pdf = cbk::imageLightPixelPdf(&view, &light, p);
        CHECK(pdf == doctest::Approx(values[p] / 8.0 * 4.0 / (4.0 * M_PI)).epsilon(1e-6));
        total += pdf * 4.0 * M_PI / 4.0; // each pixel covers 4 pi / 4 sr
        CHECK(cbk::imageLightPixelEmission(&view, &light, p).c[1] == 0.5f * values[p]);
    }
    CHECK(total == doctest::Approx(1.0).epsilon(1e-6));

    // Sampled directions: never the black pixel, each pixel as often as its share, the density
    // returned the one evaluated at the direction, the radiance there its pixel's.
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> uniform(0.f, 1.f);
    std::vector<double> observed(4, 0.0);
    constexpr int kSamples = 40000;
    for (int i = 0; i < kSamples; ++i) {
        float pdf = 0.f;
        const cbk::Vec3 w =
            cbk::infiniteLightSample(&view, &light, uniform(rng), uniform(rng), &pdf);
        const int p = cbk::imageLightPixel(&light, w);
        observed[size_t(p)] += 1.0;
        float pdfAt = 0.f;
        const cbk::Spectrum radiance = cbk::infiniteLightRadiancePdf(&view, &light, w, &pdfAt);
        CHECK(pdf == pdfAt);
        CHECK(radiance.c[0] == 0.5f * values[p]);
        CHECK(cbk::infiniteLightRadiance(&view, &light, w).c[0] == 0.5f * values[p]);
    }
    CHECK(observed[1] == 0.0);
    std::vector<double> o{observed[0], observed[2], observed[3]};
    std::vector<double> e{kSamples / 8.0, 3 * kSamples / 8.0, 4 * kSamples / 8.0};
    auto r = cbtest::chi2Test(o, e, 0.01);
    INFO(r.message);
    CHECK(r.passed);

    // A constant infinite light keeps the uniform code: no image feature, no tables.
    const cb::DeviceScene uniformSky = cb::buildDeviceScene(
        parseInTemp("WorldBegin\nLightSource \"infinite\"\nShape \"trianglemesh\" \"point3 P\" "
                    "[0 0 0 1 0 0 0 1 0]\n"));
    CHECK(!contains(uniformSky.featureNames(), "image-light"));
    CHECK(uniformSky.lightTables.empty());
}

// Extreme maps: an all-black one (its tables fall back to uniform, it is never chosen beside
// another light, and it renders black without NaN) and a 1 x 1 one (one pixel over the whole
// sphere: a constant sky of density 1 / 4 pi).
TEST_CASE("pbrt-v4 image light: a black map and a one-pixel map") {
    TempDirCleanup cleanup;
    writeImage("black4.exr", 4, 4, [](int, int, int) { return 0.f; });
    const std::string tri = "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n";
    cb::DeviceScene black = cb::buildDeviceScene(parseInTemp(
        "WorldBegin\nLightSource \"point\" \"point3 from\" [0 0 1]\nLightSource \"infinite\" "
        "\"string filename\" \"black4.exr\"\n" +
        tri));
    REQUIRE(black.lights.size() == 2);
    CHECK(black.lights[1].pickProbability == 0.f);
    const cbk::SceneView view = cbtest::hostView(black);
    const cbk::Light& sky = black.lights[1];
    for (int p = 0; p < 16; ++p) {
        CHECK(cbk::imageLightPixelPdf(&view, &sky, p) ==
              doctest::Approx(1.0 / (4.0 * M_PI)).epsilon(1e-6));
        CHECK(specIsBlack(cbk::imageLightPixelEmission(&view, &sky, p)));
    }
    writeImage("one1.exr", 1, 1, [](int, int, int c) { return float(c + 1); });
    const cb::DeviceScene one = cb::buildDeviceScene(parseInTemp(
        "WorldBegin\nLightSource \"infinite\" \"string filename\" \"one1.exr\"\n" + tri));
    const cbk::SceneView oneView = cbtest::hostView(one);
    for (const cbk::Vec3 w : {cbk::vec3(0, 0, 1), cbk::vec3(0, 0, -1), cbk::vec3(0.6f, -0.8f, 0)}) {
        float pdfAt = 0.f;
        cbk::infiniteLightRadiancePdf(&oneView, &one.lights[0], w, &pdfAt);
        CHECK(pdfAt == doctest::Approx(1.0 / (4.0 * M_PI)).epsilon(1e-6));
        CHECK(cbk::infiniteLightRadiance(&oneView, &one.lights[0], w).c[2] == 3.f);
    }
    float pdf = 0.f;
    const cbk::Vec3 w = cbk::infiniteLightSample(&oneView, &one.lights[0], 0.3f, 0.9f, &pdf);
    CHECK(std::fabs(cbk::vlength2(w) - 1.f) < 1e-5f);
    CHECK(pdf == doctest::Approx(1.0 / (4.0 * M_PI)).epsilon(1e-6));
}

namespace {

// 16 x 16 sky (map frame): a blue-to-white gradient by elevation, brown ground, and a sun, a 2 x 2
// block 200 times brighter, so that every method must sample the map by its radiance.
float skyValue(int x, int y, int c) {
    const double u = (x + 0.5) / 8.0 - 1.0, v = (y + 0.5) / 8.0 - 1.0;
    if ((x == 11 || x == 12) && (y == 5 || y == 6)) return c == 2 ? 150.f : 200.f;
    if (std::fabs(u) + std::fabs(v) > 1.0) return c == 0 ? 0.3f : (c == 1 ? 0.2f : 0.1f);
    const double t = std::fabs(u) + std::fabs(v);
    const double zenith[3] = {0.2, 0.4, 1.0}, horizon[3] = {0.9, 0.9, 1.0};
    return float(zenith[c] * (1 - t) + horizon[c] * t);
}

// Irradiance at a surface facing the map's +z, per channel: each pixel's film RGB (pixelRgb(x, y))
// times the integral of cos over its part of the upper hemisphere, by 64 x 64 sub-cells of 4 pi /
// (16^2 64^2) sr each through the equal-area map.
template <class PixelRgb> std::array<double, 3> skyIrradiance(PixelRgb pixelRgb) {
    std::array<double, 3> e{};
    constexpr int kSub = 64;
    const double cell = 4.0 * M_PI / (256.0 * kSub * kSub);
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            double cosSum = 0.0;
            for (int j = 0; j < kSub; ++j)
                for (int i = 0; i < kSub; ++i) {
                    const cbk::Vec3 w = cbk::equalAreaSquareToSphere(
                        (x + (i + 0.5f) / kSub) / 16.f, (y + (j + 0.5f) / kSub) / 16.f);
                    cosSum += std::max(0.0, double(w.z));
                }
            const std::array<double, 3> rgb = pixelRgb(x, y);
            for (size_t c = 0; c < 3; ++c)
                e[c] += rgb[c] * cosSum * cell;
        }
    return e;
}

} // namespace

namespace {

constexpr double kPlaneRho = 0.5, kSkyScale = 0.4;

// A diffuse plane (rho 0.5) of half-width `half` at y = 0 under sky16.exr (scale 0.4) turned so
// that its +z is world +y, seen from 1 above with `fov` degrees.
cb::DeviceScene planeUnderSky(int fov, int half, cb::ChannelMode mode = cb::ChannelMode::Auto) {
    writeImage("sky16.exr", 16, 16, skyValue);
    return cb::buildDeviceScene(
        parseInTemp(fmt::format(
            "LookAt 0 1 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" {0}\n"
            // Each pixel its own area: at fov 90 the plane just fills the film.
            "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
            "PixelFilter \"box\"\nWorldBegin\n"
            "AttributeBegin\nRotate -90 1 0 0\nLightSource \"infinite\" \"string filename\" "
            "\"sky16.exr\" \"float scale\" 0.4\nAttributeEnd\n"
            "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-{1} 0 -{1}  {1} 0 -{1}  -{1} 0 {1}  {1} 0 "
            "{1}]\n",
            fov, half)),
        mode);
}

// The plane's radiance rho E / pi per channel, each sky pixel seen as filmRgb(its RGB times scale).
template <class FilmRgb> std::array<double, 3> planeRadiance(FilmRgb filmRgb) {
    const std::array<double, 3> e = skyIrradiance([&](int x, int y) {
        return filmRgb(std::array<float, 3>{float(kSkyScale * skyValue(x, y, 0)),
                                            float(kSkyScale * skyValue(x, y, 1)),
                                            float(kSkyScale * skyValue(x, y, 2))});
    });
    return {kPlaneRho * e[0] / M_PI, kPlaneRho * e[1] / M_PI, kPlaneRho * e[2] / M_PI};
}

std::array<double, 3> asRgb(const std::array<float, 3>& rgb) {
    return {rgb[0], rgb[1], rgb[2]};
}

// BDPT's strategies for a sky's 3-vertex paths, each alone and unweighted, against `expected`:
// the eye path's escape (s = 0), next-event estimation (s = 1) and light tracing from the beam's
// disk (s = 2, t = 1); then, with `weighted`, all three under their MIS weights.
void checkSkyStrategies(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                        const std::array<double, 3>& expected, bool weighted, std::uint32_t seed) {
    std::vector<std::array<int, 3>> strategies{{0, 3, 16}, {1, 2, 16}, {2, 1, 64}};
    if (weighted) strategies.push_back({-1, -1, 16});
    for (const auto& [s, t, estimates] : strategies) {
        CAPTURE(s);
        CAPTURE(t);
        cb::IntegratorSettings settings = methodSettings("bdpt");
        settings.debugS = s;
        settings.debugT = t;
        checkChannelMeans(channelMeans(scene, runtime, settings, estimates, seed), expected, 1e-4);
    }
}

} // namespace

// The plane under the sky: radiance rho E / pi per channel, from escaped rays, next-event
// estimation by the map's tables, light subpaths from the beam's disk, and their MIS weights.
TEST_CASE("pbrt-v4 image light: a diffuse plane has radiance rho E / pi, every method" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = planeUnderSky(60, 10);
    const std::array<double, 3> expected = planeRadiance(asRgb);
    for (const std::string method : kMethods) {
        CAPTURE(method);
        checkChannelMeans(channelMeans(scene, runtime, methodSettings(method), 6, 300u), expected,
                          1e-4);
    }
}

// Each of BDPT's three strategies for those paths alone, unweighted, must render the same plane:
// the eye path's escape (s = 0), next-event estimation by the tables (s = 1) and light tracing
// from the beam's disk (s = 2, t = 1); then all three under their MIS weights. The plane fills
// the bounding sphere's disk, so that light tracing is about as good as next-event estimation
// here and a wrong density in its weights shows.
TEST_CASE("pbrt-v4 image light: each BDPT strategy alone renders the plane's rho E / pi" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = planeUnderSky(90, 1);
    checkSkyStrategies(scene, runtime, planeRadiance(asRgb), true, 400u);
}

// The same plane rendered in spectra: each pixel emits Smits's spectrum of its RGB times the white
// illuminant, made in the kernels from the basis (rgbIlluminantSpectrum on the host); the film
// sees that spectrum's RGB through its own matrix (DeviceScene::toRgb, 3 x 16).
TEST_CASE("pbrt-v4 image light: in a spectral scene, the plane under the pixels' spectra" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = planeUnderSky(60, 10, cb::ChannelMode::Spectral);
    REQUIRE(scene.channels == 16);
    const std::array<double, 3> expected = planeRadiance([&](const std::array<float, 3>& rgb) {
        const std::array<float, 16> bins = cb::rgbIlluminantSpectrum(rgb);
        std::array<double, 3> film{};
        for (size_t c = 0; c < 3; ++c)
            for (size_t i = 0; i < 16; ++i)
                film[c] += double(scene.toRgb[c * 16 + i]) * bins[i];
        return film;
    });
    for (const std::string method : {"pt", "bdpt", "cbdpt"}) {
        CAPTURE(method);
        checkChannelMeans(channelMeans(scene, runtime, methodSettings(method), 4, 500u), expected,
                          1e-4);
    }
}

TEST_CASE("pbrt-v4 image light: BDPT, CBDPT and MLT agree with PT per region" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    const std::string sky = writeImage("sky16.exr", 16, 16, skyValue);
    checkMethodsAgreeWithPt("AttributeBegin\nRotate -90 1 0 0\nLightSource \"infinite\" "
                            "\"string filename\" \"" +
                            sky + "\" \"float scale\" 0.4\nAttributeEnd\n");
}

TEST_CASE("pbrt-v4 goniometric light: its image, frame, power, and what is refused") {
    TempDirCleanup cleanup;
    writeImage("gonio.exr", 4, 4, [](int x, int y, int c) { return float(x + 4 * y) + c; });
    auto s = parseInTemp("WorldBegin\nTranslate 1 2 3\nLightSource \"goniometric\" \"string "
                         "filename\" \"gonio.exr\" \"float scale\" 2\n");
    REQUIRE(s.pointLights.size() == 1);
    const cb::PointLightDesc& l = s.pointLights[0];
    CHECK(l.position == std::array<double, 3>{1, 2, 3});
    CHECK(l.image.size == 4);
    CHECK(l.scale == 2.f);
    CHECK(!l.spot);
    // pbrt-v4 swaps the light frame's y and z: the map's +z is world +y.
    const std::array<double, 9> swapped{1, 0, 0, 0, 0, 1, 0, 1, 0};
    for (size_t i = 0; i < 9; ++i)
        CHECK(l.worldFromLight[i] == doctest::Approx(swapped[i]));
    // Power: 4 pi times the pixels' mean of R, G, B (here 8.5) per unit scale.
    s = parseInTemp("WorldBegin\nLightSource \"goniometric\" \"string filename\" \"gonio.exr\" "
                    "\"float power\" 100\n");
    CHECK(s.pointLights[0].scale == doctest::Approx(100.0 / (4.0 * M_PI * 8.5)).epsilon(1e-6));
    // The device scene: I times each pixel's mean, by pixel, with tables.
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        "WorldBegin\nLightSource \"goniometric\" \"string filename\" \"gonio.exr\" "
        "\"rgb I\" [1 1 1]\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"));
    CHECK(contains(scene.featureNames(), "image-light"));
    CHECK(contains(scene.featureNames(), "point-light"));
    const cbk::Light& light = scene.lights[0];
    CHECK(light.imageSize == 4);
    CHECK(scene.spectra[size_t(3 * light.emission)] == 1.f);
    const cbk::SceneView view = cbtest::hostView(scene);
    for (int p = 0; p < 16; ++p) {
        CHECK(scene.lightTables[size_t(light.imageTable + 25 + p)] == doctest::Approx(p + 1.0));
        CHECK(cbk::imageLightPixelEmission(&view, &light, p).c[2] == doctest::Approx(p + 1.0));
    }
    // The intensity straight up (world +y, the map's +z, its centre: pixel (2, 2) of 4 x 4).
    CHECK(cbk::pointLightIntensity(&view, 0, cbk::vec3(0, 1, 0)).c[0] == doctest::Approx(11.0));
    CHECK(cbk::lightDirectionPdf(&view, &scene.lights[0], cbk::vec3(0, 1, 0)) ==
          doctest::Approx(11.0 / (16 * 8.5) * 16 / (4 * M_PI)));

    const std::string none = errorOf("WorldBegin\n\nLightSource \"goniometric\"\n");
    CHECK(contains(none, ":3:"));
    CHECK(contains(none, "needs \"string filename\""));
    writeImage("black.exr", 2, 2, [](int, int, int) { return 0.f; });
    CHECK(contains(errorOf("WorldBegin\nLightSource \"goniometric\" \"string filename\" "
                           "\"black.exr\" \"float power\" 5\n"),
                   "is black"));
    CHECK(contains(errorOf("WorldBegin\nScale 1 1 2\nLightSource \"goniometric\" \"string "
                           "filename\" \"gonio.exr\"\n"),
                   "a goniometric light's transformation must be a similarity"));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"goniometric\" \"string filename\" "
                           "\"gonio.exr\" \"point3 from\" [0 0 0]\n"),
                   "from"));
}

namespace {

// A goniometric light 1 above a diffuse plane (rho 0.5), seen from 3 above: each pixel's mean
// radiance rho / pi I(w) cos / d^2 at the plane point its rays reach, from 8 x 8 rays per
// pixel through cbk::cameraGenerateRay; per cell of a 3 x 3 grid and channel (binOf's order).
std::vector<double> goniometricPlaneCells(const cb::DeviceScene& scene) {
    const cbk::SceneView view = cbtest::hostView(scene);
    const cbk::Light& light = scene.lights[0];
    const int w = scene.camera.width, h = scene.camera.height;
    const double planeY = -scene.origin[1];
    std::vector<double> sum(27, 0.0), count(27, 0.0);
    constexpr int kSub = 8;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int j = 0; j < kSub; ++j)
                for (int i = 0; i < kSub; ++i) {
                    const cbk::Ray ray = cbk::cameraGenerateRay(
                        &scene.camera, float(x) + (i + 0.5f) / kSub, float(y) + (j + 0.5f) / kSub,
                        cbk::vec3(0.f, 0.f, 0.f));
                    const double t = (planeY - ray.o.y) / ray.d.y;
                    const double p[3] = {ray.o.x + t * ray.d.x, planeY, ray.o.z + t * ray.d.z};
                    double d[3], d2 = 0.0;
                    for (int a = 0; a < 3; ++a) {
                        d[a] = p[a] - light.position[a];
                        d2 += d[a] * d[a];
                    }
                    const double dist = std::sqrt(d2);
                    const cbk::Vec3 out =
                        cbk::vec3(float(d[0] / dist), float(d[1] / dist), float(d[2] / dist));
                    const cbk::Spectrum intensity = cbk::pointLightIntensity(&view, 0, out);
                    const double cosPlane = -d[1] / dist;
                    const size_t cell = size_t((3 * y / h) * 3 + 3 * x / w);
                    for (size_t c = 0; c < 3; ++c) {
                        sum[cell * 3 + c] += 0.5 / M_PI * intensity.c[c] * cosPlane / d2;
                        count[cell * 3 + c] += 1.0;
                    }
                }
    for (size_t k = 0; k < 27; ++k)
        sum[k] /= count[k];
    return sum;
}

} // namespace

// Every method against that integral, per cell and channel: the light's frame (pbrt-v4's swapped
// y and z under a rotation), its pixels' intensity, and light subpaths leaving by its tables.
TEST_CASE("pbrt-v4 goniometric light: a diffuse plane below it, every method" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    // Bright toward the map's +u (x) and +v (y), dark elsewhere, a ramp within.
    writeImage("gonio16.exr", 16, 16, [](int x, int y, int c) {
        return (x >= 8 ? 3.f : 0.2f) * (y >= 6 ? 2.f : 0.5f) * (1.f + 0.1f * float(x)) *
               (c == 1 ? 0.8f : 1.f);
    });
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        "LookAt 0 3 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 60\n"
        "Film \"rgb\" \"integer xresolution\" 18 \"integer yresolution\" 18\n"
        "PixelFilter \"box\"\nWorldBegin\n" // the cells' pixels' own areas, as integrated below
        "AttributeBegin\nTranslate 0 1 0\nRotate 120 1 0 0\nRotate 30 0 1 0\n"
        "LightSource \"goniometric\" \"string filename\" \"gonio16.exr\" \"float scale\" 3\n"
        "AttributeEnd\nMaterial \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-10 0 -10  10 0 -10  -10 0 10  10 0 10]\n"));
    const std::vector<double> expected = goniometricPlaneCells(scene);
    const int w = scene.camera.width, h = scene.camera.height;
    for (const std::string method : kMethods) {
        CAPTURE(method);
        const BinnedMeans b = binnedMeans(
            scene, runtime, methodSettings(method), 8, method == "mlt" ? 32 : 8, 600u, 27,
            [&](int x, int y, int c) { return size_t(((3 * y / h) * 3 + 3 * x / w) * 3 + c); });
        for (size_t k = 0; k < 27; ++k) {
            CAPTURE(k);
            CAPTURE(expected[k]);
            CAPTURE(b.stats.mean[k]);
            CAPTURE(b.stats.se[k]);
            CHECK(std::fabs(b.stats.mean[k] - expected[k]) <=
                  4.5 * b.stats.se[k] + 3e-3 * expected[k]);
        }
        CHECK(b.nonFinite == 0);
    }
}

namespace {

// A floor y = 0 of albedo 0.5 under a constant sky of radiance 2 seen through a 0.5 x 0.5 portal
// at height 1 (its outer side up), from a camera at height 0.5 looking down (fov 90). The floor
// (1.2 x 1.2) is just larger than the camera's view, so that the beam's disk around it is small
// and light tracing matters.
const std::string kPortalCorners = "[-0.25 1 -0.25  0.25 1 -0.25  0.25 1 0.25  -0.25 1 0.25]";

std::string floorUnderPortal(const std::string& before, const std::string& portal) {
    return "LookAt 0 0.5 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 90\n"
           "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
           "PixelFilter \"box\"\nWorldBegin\n" +
           before + "LightSource \"infinite\" \"rgb L\" [2 2 2] \"point3 portal\" " + portal +
           "\nMaterial \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
           "Shape \"bilinearmesh\" \"point3 P\" [-0.6 0 -0.6  0.6 0 -0.6  -0.6 0 0.6  0.6 0 0.6]\n";
}

} // namespace

// pbrt-v4's PortalImageInfiniteLight: the portal's corners in world space (the CTM does not move
// them), its frame in the light's tables, which rays see the sky through it, and what is refused.
TEST_CASE("pbrt-v4 portal light: the rectangle, which rays it lets through, what is refused") {
    // A CTM before the light turns an image light's frame, never the portal.
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parseSceneString(floorUnderPortal("Rotate 90 1 0 0\nTranslate 5 5 5\n", kPortalCorners),
                         "t.pbrt"),
        cb::ChannelMode::Rgb);
    const cbk::SceneView view = cbtest::hostView(scene);
    const int infinite = cbk::lightInfinite(&view);
    REQUIRE(infinite >= 0);
    const int portal = scene.lights[size_t(infinite)].portal;
    REQUIRE(portal >= 0);
    REQUIRE(scene.lightTables.size() == size_t(portal) + 14);
    // p0 (device coordinates: world minus the scene's origin), x = p03, y = p01, z = x cross y
    // (up: the sky's side), and the edges' lengths.
    const float* t = scene.lightTables.data() + portal;
    CHECK(t[0] + scene.origin[0] == doctest::Approx(-0.25));
    CHECK(t[1] + scene.origin[1] == doctest::Approx(1.0));
    CHECK(t[2] + scene.origin[2] == doctest::Approx(-0.25));
    CHECK(std::vector<float>(t + 3, t + 14) ==
          std::vector<float>{0, 0, 1, 1, 0, 0, 0, 1, 0, 0.5f, 0.5f});
    auto seen = [&](double x, double y, double z, cbk::Vec3 d) {
        const cbk::Vec3 p = cbk::vec3(float(x - scene.origin[0]), float(y - scene.origin[1]),
                                      float(z - scene.origin[2]));
        return cbk::lightSeenThroughPortal(&view, infinite, p, cbk::vnormalize(d));
    };
    CHECK(seen(0, 0, 0, cbk::vec3(0, 1, 0)));
    CHECK(seen(0, 0, 0, cbk::vec3(0.24f, 1, 0.24f)));
    CHECK(!seen(0, 0, 0, cbk::vec3(0.26f, 1, 0)));
    CHECK(!seen(0, 0, 0, cbk::vec3(0, 1, -0.26f)));
    CHECK(seen(1, 0, 1, cbk::vec3(-1, 1, -1))); // slanting through the middle
    CHECK(!seen(0, 0, 0, cbk::vec3(0, -1, 0))); // away from it
    CHECK(!seen(0, 2, 0, cbk::vec3(0, 1, 0)));  // from its outer side
    CHECK(!seen(0, 2, 0, cbk::vec3(0, -1, 0)));
    // Other lights are never cut by it.
    const cb::DeviceScene plain = cb::buildDeviceScene(
        parseSceneString("WorldBegin\nLightSource \"infinite\"\nShape \"sphere\"\n", "t.pbrt"));
    CHECK(plain.lights.back().portal == -1);
    const cbk::SceneView plainView = cbtest::hostView(plain);
    CHECK(cbk::lightSeenThroughPortal(&plainView, cbk::lightInfinite(&plainView),
                                      cbk::vec3(0, 0, 0), cbk::vec3(0, -1, 0)));
    // Not a rectangle, or not 4 points: errors at the parameter.
    CHECK(contains(errorOf(floorUnderPortal("", "[0 1 0  1 1 0  1 1 1  0 1 1.5]")),
                   "\"point3 portal\" must be a rectangle"));
    CHECK(contains(errorOf(floorUnderPortal("", "[0 1 0  1 1 0  1 1 1]")),
                   "\"point3 portal\" expects 4 points (12 values), got 9"));
    CHECK(contains(errorOf(floorUnderPortal("", "[0 1 0  0 1 0  1 1 1  0 1 1]")),
                   "corners 0 and 1 coincide"));
}

// Next-event estimation through the portal (infiniteLightSampleFrom): from points below the
// window, near it, far from it (sampled by area: a solid angle under 0.01 sr), below its corner,
// almost in its plane and far to its side, every direction crosses the window, its density is
// infiniteLightPdfFrom's, the window's 8 x 8 cells are hit in proportion to their solid angles (by
// area: equally), and the mean of cos / pdf toward a floor facing up is the window's projected
// solid angle, both integrated here (64 x 64 points per cell). Beyond the window's plane nothing is
// sampled.
TEST_CASE("pbrt-v4 portal light: next-event estimation samples the window's solid angle") {
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parseSceneString(floorUnderPortal("", kPortalCorners), "t.pbrt"), cb::ChannelMode::Rgb);
    const cbk::SceneView view = cbtest::hostView(scene);
    const int infinite = cbk::lightInfinite(&view);
    REQUIRE(infinite >= 0);
    const cbk::Light* light = &scene.lights[size_t(infinite)];
    auto device = [&](double x, double y, double z) {
        return cbk::vec3(float(x - scene.origin[0]), float(y - scene.origin[1]),
                         float(z - scene.origin[2]));
    };
    // The window: x and z in [-0.25, 0.25] at y = 1.
    constexpr int kCells = 8, kSub = 64, kSamples = 200000;
    struct Ref {
        double x, y, z;
    };
    int byArea = 0;
    // The fourth is in line with two edges (the parametrisation's b0 = 0).
    for (const Ref ref : {Ref{0, 0, 0}, Ref{0.4, 0.2, -0.3}, Ref{0.1, -9, 0.05},
                          Ref{-0.25, 0.6, -0.25}, Ref{0.05, 0.98, 0.1}, Ref{3, 0.7, 0.5}}) {
        CAPTURE(ref.x);
        CAPTURE(ref.y);
        CAPTURE(ref.z);
        std::vector<double> cellSolidAngle(kCells * kCells, 0.0);
        double solidAngle = 0.0, projected = 0.0;
        for (int cell = 0; cell < kCells * kCells; ++cell)
            for (int j = 0; j < kSub; ++j)
                for (int i = 0; i < kSub; ++i) {
                    const double px = -0.25 + 0.5 * ((cell % kCells) + (i + 0.5) / kSub) / kCells;
                    const double pz = -0.25 + 0.5 * ((cell / kCells) + (j + 0.5) / kSub) / kCells;
                    const double dx = px - ref.x, dy = 1.0 - ref.y, dz = pz - ref.z;
                    const double d2 = dx * dx + dy * dy + dz * dz;
                    // dA cos(window) / d^2, and times cos at the floor (its normal +y).
                    const double omega =
                        0.25 / (kCells * kCells * kSub * kSub) * dy / (d2 * std::sqrt(d2));
                    cellSolidAngle[size_t(cell)] += omega;
                    solidAngle += omega;
                    projected += omega * dy / std::sqrt(d2);
                }
        // Sampled by area below 0.01 sr (the far point, the one far to the side).
        const bool sampledByArea = solidAngle < 0.01;
        byArea += sampledByArea;
        std::vector<double> expected(kCells * kCells, double(kSamples) / (kCells * kCells));
        if (!sampledByArea)
            for (size_t cell = 0; cell < expected.size(); ++cell)
                expected[cell] = kSamples * cellSolidAngle[cell] / solidAngle;
        std::mt19937 rng(11);
        std::uniform_real_distribution<float> uniform(0.f, 1.f);
        std::vector<double> observed(kCells * kCells, 0.0);
        double sum = 0.0, sum2 = 0.0;
        long misses = 0, pdfMismatches = 0;
        const cbk::Vec3 p = device(ref.x, ref.y, ref.z);
        for (int k = 0; k < kSamples; ++k) {
            float pdf = 0.f;
            const cbk::Vec3 w =
                cbk::infiniteLightSampleFrom(&view, light, p, uniform(rng), uniform(rng), &pdf);
            misses += !(pdf > 0.f) || !cbk::lightSeenThroughPortal(&view, infinite, p, w);
            const float again = cbk::infiniteLightPdfFrom(&view, light, p, w,
                                                          cbk::lightDirectionPdf(&view, light, w));
            pdfMismatches += std::fabs(again - pdf) > 1e-6f * pdf;
            const double s = (1.0 - ref.y) / double(w.y);
            const double hx = ref.x + s * w.x, hz = ref.z + s * w.z;
            const int cx = std::clamp(int((hx + 0.25) / 0.5 * kCells), 0, kCells - 1);
            const int cz = std::clamp(int((hz + 0.25) / 0.5 * kCells), 0, kCells - 1);
            observed[size_t(cz * kCells + cx)] += 1.0;
            const double value = double(w.y) / pdf;
            sum += value;
            sum2 += value * value;
        }
        CHECK(misses == 0);
        CHECK(pdfMismatches == 0);
        const auto r = cbtest::chi2Test(observed, expected, 0.001);
        INFO(r.message);
        CHECK(r.passed);
        const double mean = sum / kSamples;
        const double se = std::sqrt((sum2 / kSamples - mean * mean) / kSamples);
        CAPTURE(mean);
        CAPTURE(se);
        CAPTURE(projected);
        CHECK(std::fabs(mean - projected) <= 4.5 * se + 2e-5 * projected);
    }
    CHECK(byArea == 2);
    // From beyond the window's plane (or in it) no direction reaches the sky.
    for (const double y : {1.0, 1.5}) {
        float pdf = 1.f;
        cbk::infiniteLightSampleFrom(&view, light, device(0, y, 0), 0.3f, 0.6f, &pdf);
        CHECK(pdf == 0.f);
        CHECK(cbk::infiniteLightPdfFrom(&view, light, device(0, y, 0), cbk::vec3(0, 1, 0), 0.1f) ==
              0.f);
    }
}

// The floor under the portal: a point x receives E(x) = L times the integral over the window
// of cos(floor) cos(window) / d^2 = h^2 / d^4 (parallel planes), and reflects rho / pi E. Every
// method's image mean against that, integrated here over the camera's view, and each of BDPT's
// strategies alone, unweighted: escaped rays (s = 0) and next-event estimation (s = 1) cut by the
// portal, light subpaths from the beam's disk cut at their first hit (s = 2, t = 1).
TEST_CASE("pbrt-v4 portal light: a floor lit through a window, every method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parseSceneString(floorUnderPortal("", kPortalCorners), "t.pbrt"), cb::ChannelMode::Rgb);
    const int n = 128, m = 64;
    double mean = 0.0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double x = (i + 0.5) / n - 0.5, z = (j + 0.5) / n - 0.5;
            double e = 0.0;
            for (int a = 0; a < m; ++a)
                for (int b = 0; b < m; ++b) {
                    const double wx = 0.5 * (a + 0.5) / m - 0.25 - x;
                    const double wz = 0.5 * (b + 0.5) / m - 0.25 - z;
                    const double d2 = wx * wx + 1.0 + wz * wz;
                    e += 1.0 / (d2 * d2);
                }
            mean += 0.5 / M_PI * 2.0 * e * (0.25 / (m * m));
        }
    mean /= n * n;
    const std::array<double, 3> expected{mean, mean, mean};
    checkEveryMethodChannelMeans(scene, runtime, expected, 8, 128, 40u);
    checkSkyStrategies(scene, runtime, expected, false, 41u);
}

// An image sky behind the window: next-event estimation mixes the window's solid angle with the
// image's tables (infiniteLightSampleFrom), and PT's and BDPT's MIS weights take that mixture's
// density. Next-event estimation alone (BDPT's s = 1), PT and BDPT against the eye paths'
// escapes alone (s = 0), which sample neither, on a sky with a bright patch around the zenith
// that the window shows in part. Each strategy alone is unbiased whatever its density; the
// weighted methods sum to the image only where their weights take the density they sample with.
TEST_CASE("pbrt-v4 portal light: an image sky through the window, every strategy agrees" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    writeImage("window-sky.exr", 16, 16, [](int x, int y, int c) {
        if ((x == 7 || x == 8) && y >= 6 && y <= 8) return c == 2 ? 20.f : 40.f;
        return float(0.3 + 0.1 * x + 0.05 * y) * (0.5f + 0.25f * float(c));
    });
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parseInTemp(
            "LookAt 0 0.5 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 90\n"
            "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
            "PixelFilter \"box\"\nWorldBegin\n"
            "AttributeBegin\nRotate -90 1 0 0\nLightSource \"infinite\" \"string filename\" "
            "\"window-sky.exr\" \"point3 portal\" " +
            kPortalCorners +
            "\nAttributeEnd\nMaterial \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-0.6 0 -0.6  0.6 0 -0.6  -0.6 0 0.6  "
            "0.6 0 0.6]\n"),
        cb::ChannelMode::Rgb);
    REQUIRE(scene.lights.size() == 1);
    REQUIRE(scene.lights[0].imageSize == 16);
    REQUIRE(scene.lights[0].portal >= 0);
    auto strategy = [](int s, int t) {
        cb::IntegratorSettings settings = methodSettings("bdpt");
        settings.debugS = s;
        settings.debugT = t;
        return settings;
    };
    const cbtest::RunStats escapes = channelMeans(scene, runtime, strategy(0, 3), 2048, 60u).stats;
    CAPTURE(escapes.mean[1]);
    CAPTURE(escapes.se[1]);
    for (const auto& [name, settings] : {std::pair{std::string("s = 1"), strategy(1, 2)},
                                         std::pair{std::string("s = 2, t = 1"), strategy(2, 1)},
                                         std::pair{std::string("pt"), methodSettings("pt")},
                                         std::pair{std::string("bdpt"), methodSettings("bdpt")}}) {
        CAPTURE(name);
        const BinnedMeans b = channelMeans(scene, runtime, settings, 64, 61u);
        CAPTURE(b.stats.mean[1]);
        CAPTURE(b.stats.se[1]);
        checkRunsAgree(b.stats, escapes);
        CHECK(b.nonFinite == 0);
    }
}
