// pbrt-v4's film clamp, "float maxcomponentvalue": each camera sample's sensor RGB (for the
// cie1931 sensor, XYZ times the imaging ratio) and each light-tracing splat's is scaled down to
// at most that largest component before the pixel filter weighs it (kernels' filmClampSample).
#include <doctest/doctest.h>

#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "spectral/spectral.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

std::string film(const std::string& clamp) {
    return "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 40\n"
           "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16 " +
           clamp + "\nPixelFilter \"box\"\nWorldBegin\n";
}

// A grey wall filling the view, lit by a small one-sided light beside the camera that the camera
// does not see: paths of 3 vertices reach a pixel by next-event estimation, by the BSDF's
// direction and, for the bidirectional methods, by light tracing (s = 2, t = 1). The light is so
// bright that every strategy's weighted contribution exceeds the clamp, so every sample and every
// splat is clamped to one and the same colour: a pixel of one estimate is a whole number of them.
std::string wallScene(const std::string& clamp) {
    return film(clamp) +
           "AttributeBegin\nMaterial \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
           "Shape \"bilinearmesh\" \"point3 P\" [-3 -3 3  -3 3 3  3 -3 3  3 3 3]\nAttributeEnd\n"
           "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [30 10 2] \"float scale\" 1e9\n"
           "Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n"
           "Shape \"bilinearmesh\" \"point3 P\" [-0.2 0.8 -0.5  0.2 0.8 -0.5  -0.2 1.2 -0.5  "
           "0.2 1.2 -0.5]\nAttributeEnd\n";
}

// The emitter behind the camera seen in a mirror that fills the view: the one path of each pixel
// (camera, mirror, light) has a single strategy, weight 1, in every method.
std::string mirrorScene(const std::string& clamp) {
    return film(clamp) +
           "AttributeBegin\nMaterial \"conductor\" \"spectrum eta\" [300 0.2 800 0.2] "
           "\"spectrum k\" [300 3 800 3] \"float roughness\" 0\n"
           "Shape \"bilinearmesh\" \"point3 P\" [-2 -2 2  2 -2 2  -2 2 2  2 2 2]\nAttributeEnd\n"
           "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [30 10 2]\n"
           "Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n"
           "Shape \"bilinearmesh\" \"point3 P\" [-4 -4 -2  4 -4 -2  -4 4 -2  4 4 -2]\n"
           "AttributeEnd\n";
}

cb::IntegratorSettings settingsFor(const std::string& method) {
    cb::IntegratorSettings s = methodSettings(method);
    s.maxPathVertices = 3;
    s.rouletteVertex = 0;
    return s;
}

double sensorMax(const cbk::Camera& camera, const float* rgb) {
    double largest = -INFINITY;
    for (int r = 0; r < 3; ++r)
        largest = std::max(largest, double(camera.sensorFromRgb[3 * r]) * rgb[0] +
                                        double(camera.sensorFromRgb[3 * r + 1]) * rgb[1] +
                                        double(camera.sensorFromRgb[3 * r + 2]) * rgb[2]);
    return largest;
}

// Each pixel of `rgb` (one estimate) as a multiple of the clamped colour: the pixel whose sensor
// RGB is smallest is taken as one clamped sample, whose largest component must be `clamp`; every
// other pixel must be that colour times 1 (its camera sample) plus a whole number of splats of
// `splat` samples each (0: none). Returns the largest multiple.
int checkWholeMultiples(const cbk::Camera& camera, const std::vector<float>& rgb, double clamp,
                        int splat) {
    size_t unit = 0;
    for (size_t p = 0; p < rgb.size() / 3; ++p)
        if (sensorMax(camera, &rgb[3 * p]) < sensorMax(camera, &rgb[3 * unit])) unit = p;
    CHECK(sensorMax(camera, &rgb[3 * unit]) == doctest::Approx(clamp).epsilon(1e-5));
    int largest = 0;
    for (size_t p = 0; p < rgb.size() / 3; ++p) {
        const double multiple = sensorMax(camera, &rgb[3 * p]) / clamp;
        const int whole = int(std::lround(multiple));
        CAPTURE(p);
        CAPTURE(multiple);
        // An unclamped splat is thousands of samples: a whole number too, within a relative
        // tolerance, but not of this form.
        CHECK(std::fabs(multiple - whole) < 1e-3);
        CHECK(whole >= 1);
        CHECK((whole - 1) % std::max(splat, 1) == 0);
        CHECK(whole <= 1 + 8 * splat);
        for (int c = 0; c < 3; ++c)
            CHECK(rgb[3 * p + size_t(c)] ==
                  doctest::Approx(whole * rgb[3 * unit + size_t(c)]).epsilon(1e-4));
        largest = std::max(largest, whole);
    }
    return largest;
}

} // namespace

TEST_CASE("sample clamp: maxcomponentvalue parsed, refused unless positive") {
    TempDirCleanup cleanup;
    const cb::SceneDesc clamped = parseInTemp(wallScene("\"float maxcomponentvalue\" 2.5"));
    REQUIRE(clamped.film.maxComponentValue.has_value());
    CHECK(*clamped.film.maxComponentValue == 2.5);
    const cb::DeviceScene device = cb::buildDeviceScene(clamped);
    CHECK((device.features & CB_FEATURE_SAMPLE_CLAMP) != 0);
    CHECK(device.camera.sampleClamp == 2.5f);
    CHECK(device.featureNames().find("sample-clamp") != std::string::npos);
    // pbrt-v4's default is infinity: no clamp, and no clamp compiled.
    const cb::SceneDesc none = parseInTemp(wallScene(""));
    CHECK_FALSE(none.film.maxComponentValue.has_value());
    const cb::DeviceScene plain = cb::buildDeviceScene(none);
    CHECK((plain.features & CB_FEATURE_SAMPLE_CLAMP) == 0);
    CHECK(plain.camera.sampleClamp == 0.0f);
    for (const std::string bad : {"0", "-3"}) {
        const std::string error = errorOf(film("\"float maxcomponentvalue\" " + bad));
        CAPTURE(error);
        CHECK(error.find("t.pbrt:3:") != std::string::npos);
        CHECK(error.find("maxcomponentvalue\" " + bad + " must be positive") != std::string::npos);
    }
}

TEST_CASE("sample clamp: the sensor is XYZ times the imaging ratio, whatever the white balance") {
    // sRGB's linear RGB -> XYZ (IEC 61966-2-1), the inverse of the film's XYZ -> RGB.
    const double srgbToXyz[9] = {0.4124, 0.3576, 0.1805, 0.2126, 0.7152,
                                 0.0722, 0.0193, 0.1192, 0.9505};
    for (const cb::FilmColour& colour :
         {cb::FilmColour{0.0, 1.0}, cb::FilmColour{0.0, 4.0}, cb::FilmColour{3200.0, 2.0},
          cb::FilmColour{6500.0, 0.5}}) {
        CAPTURE(colour.whiteBalanceKelvin);
        CAPTURE(colour.imagingRatio);
        // A path's linear sRGB (an RGB scene's channels) through the film, then to the sensor.
        const std::vector<float> film = cb::filmMatrix(3, colour);
        const std::array<float, 9> sensor = cb::sensorFromFilmRgb(colour);
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) {
                double v = 0.0;
                for (int k = 0; k < 3; ++k)
                    v += double(sensor[size_t(3 * r + k)]) * film[size_t(3 * k + c)];
                CHECK(v == doctest::Approx(colour.imagingRatio * srgbToXyz[3 * r + c])
                               .epsilon(2e-4)
                               .scale(colour.imagingRatio));
            }
    }
}

TEST_CASE("sample clamp: every sample and splat clamped to one colour, every method") {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const double clamp = 1.0;
    const cb::DeviceScene scene =
        cb::buildDeviceScene(parseInTemp(wallScene("\"float maxcomponentvalue\" 1")));
    std::vector<float> rgb;
    // CPT and CBDPT twice: their CPU kernels (a work-item per tile, packets of rays) and the
    // per-pixel ones GPUs run (CBDPT_PACKETS=0).
    for (const std::string variant :
         {"pt", "cpt", "cpt-per-pixel", "bdpt", "cbdpt", "cbdpt-per-pixel"}) {
        CAPTURE(variant);
        const bool perPixel = variant.find("-per-pixel") != std::string::npos;
        const std::string method = variant.substr(0, variant.find('-'));
        if (perPixel) setenv("CBDPT_PACKETS", "0", 1);
        auto integrator = cb::makeIntegrator(settingsFor(method), scene, runtime);
        unsetenv("CBDPT_PACKETS");
        if (method == "cpt" || method == "cbdpt") CHECK(integrator->tracesPackets() == !perPixel);
        // A splat of BDPT is one light path; of CBDPT, with k = 4, W H / k^2 = 16 of them.
        const int splat = method == "bdpt" ? 1 : method == "cbdpt" ? 16 : 0;
        int largest = 0;
        for (std::uint32_t e = 0; e < 4; ++e) {
            integrator->renderEstimate(e, rgb);
            largest = std::max(largest, checkWholeMultiples(scene.camera, rgb, clamp, splat));
        }
        CHECK(integrator->nonFiniteSamples() == 0);
        // Some of BDPT's and CBDPT's pixels hold splats.
        CHECK((splat == 0 ? largest == 1 : largest > 1));
    }
    // Without the clamp the same pixels are no such multiples: the check above has power.
    const cb::DeviceScene unclamped = cb::buildDeviceScene(parseInTemp(wallScene("")));
    auto integrator = cb::makeIntegrator(settingsFor("pt"), unclamped, runtime);
    integrator->renderEstimate(0, rgb);
    double furthest = 0.0; // from a whole multiple of the dimmest pixel
    const double dimmest = *std::min_element(rgb.begin(), rgb.end());
    for (float v : rgb)
        furthest = std::max(furthest, std::fabs(v / dimmest - std::round(v / dimmest)));
    CHECK(furthest > 0.1);
}

TEST_CASE("sample clamp: the mirrored light clamped alike by every method") {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const cb::DeviceScene scene =
        cb::buildDeviceScene(parseInTemp(mirrorScene("\"float maxcomponentvalue\" 2")));
    const cb::DeviceScene unclamped = cb::buildDeviceScene(parseInTemp(mirrorScene("")));
    std::vector<float> rgb;
    auto integrator = cb::makeIntegrator(settingsFor("pt"), scene, runtime);
    integrator->renderEstimate(0, rgb);
    const std::array<float, 3> clamped = {rgb[0], rgb[1], rgb[2]};
    CHECK(sensorMax(scene.camera, clamped.data()) == doctest::Approx(2.0).epsilon(1e-5));
    auto open = cb::makeIntegrator(settingsFor("pt"), unclamped, runtime);
    open->renderEstimate(0, rgb);
    CHECK(sensorMax(scene.camera, rgb.data()) > 5.0);
    for (const std::string method : kMethods) {
        CAPTURE(method);
        const int estimates = method == "mlt" ? 4 : 2;
        const BinnedMeans means = channelMeans(scene, runtime, settingsFor(method), estimates, 7u);
        for (int c = 0; c < 3; ++c) {
            CAPTURE(c);
            // Deterministic for all but MLT, whose image mean is b, the bootstrap's mean
            // luminance, which is exact here: every sample is the same clamped colour.
            CHECK(means.stats.mean[size_t(c)] ==
                  doctest::Approx(clamped[size_t(c)]).epsilon(method == "mlt" ? 1e-4 : 1e-5));
        }
    }
}

// MLT's F(u) is BDPT's estimate for the sample u, clamped alike, so both converge to the same
// clamped image, well below the unclamped one.
TEST_CASE("sample clamp: MLT converges to BDPT's clamped image" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const cb::DeviceScene scene =
        cb::buildDeviceScene(parseInTemp(wallScene("\"float maxcomponentvalue\" 1")));
    const MethodMean bdpt = methodMean(scene, runtime, settingsFor("bdpt"), 6, 8);
    const MethodMean mlt = methodMean(scene, runtime, settingsFor("mlt"), 6, 32);
    const MethodMean open = methodMean(cb::buildDeviceScene(parseInTemp(wallScene(""))), runtime,
                                       settingsFor("bdpt"), 6, 8);
    CAPTURE(bdpt.mean);
    CAPTURE(bdpt.se);
    CAPTURE(mlt.mean);
    CAPTURE(mlt.se);
    CAPTURE(open.mean);
    CHECK(std::fabs(mlt.mean - bdpt.mean) <= 4.5 * std::hypot(mlt.se, bdpt.se));
    CHECK(bdpt.mean < 0.1 * open.mean);
    CHECK(mlt.nonFinite == 0);
}
