// Statistical checks shared by the pbrt-v4 suites: per-bin means over independent runs, a
// method's image mean, and BDPT, CBDPT and MLT against PT per region of a test scene.
#pragma once

#include "integrators/integrator.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"
#include "test_render_util.h"

#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

namespace cbtest::method_checks {

// A closed black box (4 x 1 x 4, below y = 0) whose lid, the square y = 0 with its normal into
// the box, is `material`, under a constant sky of radiance kLidSky, seen at fov 90 on a 16 x 16
// film from `camera`: kLidAbove (1 above the lid, looking down) or kLidInside (0.5 below it,
// looking up). The box sends no light, so from above a pixel is what the lid reflects of the sky
// and from inside what it transmits. The box filter keeps each pixel's samples on its own area,
// so the image mean is the film plane's (lidFilmMean).
inline constexpr double kLidSky = 0.8;
inline const std::string kLidAbove = "LookAt 0 1 0  0 0 0  0 0 1\n";
inline const std::string kLidInside = "LookAt 0 -0.5 0  0 0 0  0 0 1\n";
inline std::string lidSceneText(const std::string& camera, const std::string& material) {
    return camera +
           "Camera \"perspective\" \"float fov\" 90\n"
           "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
           "PixelFilter \"box\"\n"
           "WorldBegin\nLightSource \"infinite\" \"rgb L\" [0.8 0.8 0.8]\n"
           "Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n"
           "Shape \"trianglemesh\" \"point3 P\" [-2 -1 -2  2 -1 -2  2 -1 2  -2 -1 2  "
           "-2 0 -2  2 0 -2  2 0 2  -2 0 2] \"integer indices\" [0 1 2  0 2 3  0 1 5  0 5 4  "
           "1 2 6  1 6 5  2 3 7  2 7 6  3 0 4  3 4 7]\n" +
           material + "Shape \"bilinearmesh\" \"point3 P\" [-2 0 -2  2 0 -2  -2 0 2  2 0 2]\n";
}

// The mean over the lid scene's film (x, y in [-1, 1] at distance 1) of g(cos theta), theta a
// pixel's angle to the lid's normal, cos theta = 1 / sqrt(1 + x^2 + y^2); midpoint rule, g
// smooth.
inline double lidFilmMean(const std::function<double(double)>& g, int n = 200) {
    double sum = 0.0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double x = -1 + (i + 0.5) * 2.0 / n, y = -1 + (j + 0.5) * 2.0 / n;
            sum += g(1.0 / std::sqrt(1 + x * x + y * y));
        }
    return sum / (double(n) * n);
}

// The mean of each bin of pixel channels (binOf(x, y, channel): a bin below `bins`, or `bins`
// for none) over `estimates` estimates, per run of seeds seed, seed + 1, ...: the checks use the
// spread over runs, so that methods whose pixels share samples (CPT, CBDPT) or chains (MLT) are
// judged fairly.
struct BinnedMeans {
    cbtest::RunStats stats;
    long nonFinite = 0;
};

template <class BinOf>
BinnedMeans binnedMeans(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                        cb::IntegratorSettings settings, int runs, int estimates,
                        std::uint32_t seed, size_t bins, BinOf binOf) {
    const int w = scene.camera.width, h = scene.camera.height;
    std::vector<double> members(bins, 0.0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c)
                if (const size_t b = binOf(x, y, c); b < bins) members[b] += 1.0;
    BinnedMeans out;
    std::vector<std::vector<double>> all;
    std::vector<float> rgb;
    for (int r = 0; r < runs; ++r) {
        settings.seed = seed + std::uint32_t(r);
        auto integrator = cb::makeIntegrator(settings, scene, runtime);
        std::vector<double> sum(bins, 0.0);
        for (int e = 0; e < estimates; ++e) {
            integrator->renderEstimate(std::uint32_t(e), rgb);
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x)
                    for (int c = 0; c < 3; ++c)
                        if (const size_t b = binOf(x, y, c); b < bins)
                            sum[b] += rgb[3 * size_t(y * w + x) + size_t(c)];
        }
        for (size_t b = 0; b < bins; ++b)
            sum[b] /= members[b] * estimates;
        all.push_back(sum);
        out.nonFinite += integrator->nonFiniteSamples();
    }
    out.stats = cbtest::summarizeRuns(all);
    return out;
}

// The image mean (all channels) and its standard error over runs.
struct MethodMean {
    double mean = 0.0, se = 0.0;
    long nonFinite = 0;
};

inline MethodMean methodMean(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                             cb::IntegratorSettings settings, int runs, int estimates) {
    const BinnedMeans b = binnedMeans(scene, runtime, settings, runs, estimates, 100u, 1,
                                      [](int, int, int) { return size_t(0); });
    return {b.stats.mean[0], b.stats.se[0], b.nonFinite};
}

// Per channel, for images whose expected value is known per channel.
inline BinnedMeans channelMeans(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                                cb::IntegratorSettings settings, int estimates,
                                std::uint32_t seed) {
    return binnedMeans(scene, runtime, settings, 6, estimates, seed, 3,
                       [](int, int, int c) { return size_t(c); });
}

// Each bin's mean within 4.5 standard errors over runs, plus relativeFloor of the expected
// value's size, and no non-finite sample.
template <size_t Bins>
void checkBinMeans(const BinnedMeans& b, const std::array<double, Bins>& expected,
                   double relativeFloor) {
    for (size_t bin = 0; bin < Bins; ++bin) {
        CAPTURE(bin);
        CAPTURE(expected[bin]);
        CAPTURE(b.stats.mean[bin]);
        CAPTURE(b.stats.se[bin]);
        CHECK(std::fabs(b.stats.mean[bin] - expected[bin]) <=
              4.5 * b.stats.se[bin] + relativeFloor * std::fabs(expected[bin]));
    }
    CHECK(b.nonFinite == 0);
}

// The same for channelMeans' three channels.
inline void checkChannelMeans(const BinnedMeans& b, const std::array<double, 3>& expected,
                              double relativeFloor) {
    checkBinMeans(b, expected, relativeFloor);
}

inline cb::IntegratorSettings methodSettings(const std::string& name) {
    cb::IntegratorSettings s;
    s.name = name;
    s.maxPathVertices = 4;
    s.coherenceTile = 4;
    s.mltChains = 64;
    s.mltBootstrap = 4096;
    return s;
}

inline const char* const kMethods[] = {"pt", "cpt", "bdpt", "cbdpt", "mlt"};

// A square pinhole film of size x size pixels whose half field of view has tangent tanHalf,
// sampled on a sub x sub grid per pixel: visit(x, y, fx, fy) for each sample, (fx, fy) its point
// on the image plane at distance 1 (fx growing with x, fy shrinking with y: row 0 is the top).
template <class Visit> void forEachFilmSample(int size, int sub, double tanHalf, Visit visit) {
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x)
            for (int j = 0; j < sub; ++j)
                for (int i = 0; i < sub; ++i)
                    visit(x, y, tanHalf * (-1.0 + 2.0 * (x + (i + 0.5) / sub) / size),
                          tanHalf * (1.0 - 2.0 * (y + (j + 0.5) / sub) / size));
}

// Every method's image mean per channel against `expected` (checkChannelMeans, relative floor
// 1e-4), 6 runs of `estimates` estimates each from `seed` on. CPT and CBDPT run
// `coherentEstimates`: their pixels share each estimate's samples, so one random decision (a
// lobe, a coat's walk, a wavelength) moves the whole image, and few estimates per run would let
// 6 runs misjudge the spread. MLT runs `mltEstimates` (0: `estimates`).
inline void checkEveryMethodChannelMeans(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                                         const std::array<double, 3>& expected, int estimates,
                                         int coherentEstimates, std::uint32_t seed,
                                         int mltEstimates = 0) {
    for (const std::string method : kMethods) {
        CAPTURE(method);
        const int n = method == "cpt" || method == "cbdpt"  ? coherentEstimates
                      : method == "mlt" && mltEstimates > 0 ? mltEstimates
                                                            : estimates;
        checkChannelMeans(channelMeans(scene, runtime, methodSettings(method), n, seed), expected,
                          1e-4);
    }
}

// Every entry of r within 4.5 combined standard errors of the reference's.
inline void checkRunsAgree(const cbtest::RunStats& r, const cbtest::RunStats& reference) {
    for (size_t c = 0; c < r.mean.size(); ++c) {
        CAPTURE(c);
        CAPTURE(r.mean[c]);
        CAPTURE(reference.mean[c]);
        const double se = std::sqrt(r.se[c] * r.se[c] + reference.se[c] * reference.se[c]);
        CAPTURE(se);
        CHECK(std::fabs(r.mean[c] - reference.mean[c]) <= 4.5 * se);
    }
}

// The area light of checkMethodsAgreeWithPt's scenes: a disk above the block, facing down.
inline const std::string kDiskLight =
    "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n"
    "Translate -0.5 1.5 0\nRotate 90 1 0 0\n"
    "Shape \"disk\" \"float radius\" 0.3\nAttributeEnd\n";

// BDPT, CBDPT and MLT against PT where every strategy matters: a floor, a wall and a floating
// block between them, all of `material`, under `light` (shadows, interreflection up to 5
// vertices). The mean over
// each cell of a 3 x 3 grid must agree within 4.5 combined standard errors, spread over 16 runs:
// with 8 (Student's t, 7 degrees of freedom) a correct method fails one of the 27 cells in about
// 1 of 14 seeds, with 16 in 1 of 88. `options`: directives before the camera's.
inline void checkMethodsAgreeWithPt(
    const std::string& light, const std::string& extra = "",
    const std::string& cameraParameters = "",
    const std::string& material = "Material \"diffuse\" \"rgb reflectance\" [0.7 0.7 0.7]\n",
    const std::string& options = "") {
    cb::ClRuntime runtime;
    const std::string text =
        options + "LookAt 0 2 -3  0 0.3 0  0 1 0\nCamera \"perspective\" \"float fov\" 50 " +
        cameraParameters +
        "\n"
        "Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\nWorldBegin\n" +
        light + material +
        "Shape \"bilinearmesh\" \"point3 P\" [-2 0 -2  2 0 -2  -2 0 2  2 0 2]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-2 0 1  2 0 1  -2 2 1  2 2 1]\n"
        "AttributeBegin\nTranslate 0 0.6 0\nScale 0.4 0.3 0.4\n"
        "Shape \"trianglemesh\" \"point3 P\" [-1 -1 -1  1 -1 -1  1 1 -1  -1 1 -1  -1 -1 1  1 -1 1 "
        " 1 1 1  -1 1 1] \"integer indices\" [0 2 1  0 3 2  4 5 6  4 6 7  0 1 5  0 5 4  2 3 7 "
        " 2 7 6  0 4 7  0 7 3  1 2 6  1 6 5]\nAttributeEnd\n" +
        extra;
    const cb::DeviceScene scene = cb::buildDeviceScene(cb::parseSceneString(text, "t.pbrt"));
    const int w = scene.camera.width, h = scene.camera.height;
    auto cells = [&](cb::IntegratorSettings settings, int runs, int estimates) {
        return binnedMeans(scene, runtime, settings, runs, estimates, 500u, 9,
                           [&](int x, int y, int) { return size_t((3 * y / h) * 3 + 3 * x / w); })
            .stats;
    };
    cb::IntegratorSettings pt = methodSettings("pt");
    pt.maxPathVertices = 0;
    pt.eyeVertices = 5;
    const cbtest::RunStats reference = cells(pt, 16, 16);
    for (const std::string method : {"bdpt", "cbdpt", "mlt"}) {
        CAPTURE(method);
        cb::IntegratorSettings s = methodSettings(method);
        s.maxPathVertices = 5;
        checkRunsAgree(cells(s, 16, method == "mlt" ? 16 : 8), reference);
    }
}

} // namespace cbtest::method_checks
