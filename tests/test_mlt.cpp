// MLT (kernels/mlt.cl, src/integrators/mlt.cpp): primary-sample-space Metropolis over BDPT must
// converge to the PT image. One MLT run's estimates are correlated (the chains carry on from one
// estimate to the next, and share one bootstrap), so error bars come from independent runs
// (different seeds): each run's image is one sample. PT's estimates are independent, so each PT
// estimate is one sample. Images are compared on a grid of cells, not pixels; every check is at
// 4.5 combined standard errors (with 16 cells and >= 24 samples per side the chance of a false
// failure per test is about 0.3%).
#include "scene_builders.h"
#include "test_render_util.h"

#include "scene/device_scene.h"
#include "scene/scene_desc.h"
#include "source_tree.h"

#include <algorithm>
#include <cmath>
#include <doctest/doctest.h>
#include <string>
#include <vector>

namespace {

cb::ClRuntime& runtime() {
    static cb::ClRuntime r;
    return r;
}

std::string scenePath(const char* name) {
    return cbtest::sourcePath("scenes", name);
}

constexpr int kGrid = 4;

double luminance(const float* rgb) {
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

// Channel-average means of the cells of a kGrid x kGrid partition, and the image's mean
// luminance as the last entry.
std::vector<double> cellMeans(const std::vector<float>& rgb, int w, int h) {
    std::vector<double> cells(kGrid * kGrid + 1, 0.0);
    std::vector<int> counts(cells.size(), 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float* p = &rgb[3 * size_t(y * w + x)];
            size_t c = size_t((y * kGrid / h) * kGrid + x * kGrid / w);
            cells[c] += (double(p[0]) + p[1] + p[2]) / 3.0;
            ++counts[c];
            cells.back() += luminance(p);
            ++counts.back();
        }
    for (size_t c = 0; c < cells.size(); ++c)
        cells[c] /= counts[c];
    return cells;
}

using CellStats = cbtest::RunStats;

// The cells relative to the mean luminance (the last entry): ratios of means, with standard
// errors by linearisation (the delta method), so the shape of the image is compared apart from
// its scale. For MLT the scale is b, whose error dominates a run's error (it comes from the
// bootstrap and large steps) and is checked on its own.
CellStats shape(const std::vector<std::vector<double>>& samples) {
    CellStats m = cbtest::summarizeRuns(samples);
    const size_t n = samples.size(), k = m.mean.size() - 1;
    const double lum = m.mean[k];
    CellStats s{std::vector<double>(k, 0.0), std::vector<double>(k, 0.0)};
    for (size_t c = 0; c < k; ++c) {
        s.mean[c] = m.mean[c] / lum;
        double var = 0;
        for (const auto& v : samples) {
            double r = (v[c] - s.mean[c] * v[k]) / lum;
            var += r * r / double(n - 1);
        }
        s.se[c] = std::sqrt(var / double(n));
    }
    return s;
}

bool allFinite(const std::vector<float>& rgb) {
    for (float v : rgb)
        if (!std::isfinite(v)) return false;
    return true;
}

std::vector<std::vector<double>> ptReference(const cb::DeviceScene& scene, int vertices,
                                             int estimates, std::uint32_t seed) {
    cb::IntegratorSettings pt;
    pt.name = "pt";
    pt.eyeVertices = vertices;
    pt.rouletteVertex = 0; // unbiased for all paths up to the cap, like BDPT's caps
    pt.seed = seed;
    auto integrator = cb::makeIntegrator(pt, scene, runtime());
    std::vector<std::vector<double>> samples;
    std::vector<float> rgb;
    for (int e = 0; e < estimates; ++e) {
        integrator->renderEstimate(std::uint32_t(e), rgb);
        samples.push_back(cellMeans(rgb, scene.camera.width, scene.camera.height));
    }
    return samples;
}

struct MltRuns {
    CellStats cells, shape;
    CellStats bootstrapB; // one entry: b from each run's bootstrap
    double minAcceptance = 1, maxAcceptance = 0;
    long nonFinite = 0;
    bool finite = true;
};

cb::IntegratorSettings mltSettings(int ne, int nl) {
    cb::IntegratorSettings s;
    s.name = "mlt";
    s.eyeVertices = ne;
    s.lightVertices = nl;
    s.mltChains = 256; // one mutation per chain per estimate: many short, independent chains
    s.mltBootstrap = 2048;
    return s;
}

MltRuns mltRuns(const cb::DeviceScene& scene, cb::IntegratorSettings settings, int runs,
                int estimates, std::uint32_t firstSeed) {
    MltRuns out;
    std::vector<std::vector<double>> images, bs;
    std::vector<float> rgb;
    const int w = scene.camera.width, h = scene.camera.height;
    for (int r = 0; r < runs; ++r) {
        settings.seed = firstSeed + std::uint32_t(r);
        auto integrator = cb::makeIntegrator(settings, scene, runtime());
        std::vector<double> sum(kGrid * kGrid + 1, 0.0);
        for (int e = 0; e < estimates; ++e) {
            integrator->renderEstimate(std::uint32_t(e), rgb);
            out.finite = out.finite && allFinite(rgb);
            auto cells = cellMeans(rgb, w, h);
            for (size_t c = 0; c < sum.size(); ++c)
                sum[c] += cells[c] / estimates;
        }
        images.push_back(sum);
        const cb::MltStatistics* st = cb::mltStatistics(*integrator);
        REQUIRE(st != nullptr);
        bs.push_back({st->bootstrapNormalization});
        out.minAcceptance = std::min(out.minAcceptance, st->acceptanceRate());
        out.maxAcceptance = std::max(out.maxAcceptance, st->acceptanceRate());
        out.nonFinite += integrator->nonFiniteSamples();
    }
    out.cells = cbtest::summarizeRuns(images);
    out.shape = shape(images);
    out.bootstrapB = cbtest::summarizeRuns(bs);
    return out;
}

// Cells (the kGrid^2 cells and the mean luminance) where a and b differ by more than 4.5
// combined standard errors.
int disagreeing(const CellStats& a, const CellStats& b) {
    int bad = 0;
    for (size_t c = 0; c < a.mean.size(); ++c) {
        double tol = 4.5 * std::sqrt(a.se[c] * a.se[c] + b.se[c] * b.se[c]);
        if (!(std::fabs(a.mean[c] - b.mean[c]) <= tol)) {
            ++bad;
            MESSAGE("cell " << c << ": " << a.mean[c] << " +- " << a.se[c] << " vs " << b.mean[c]
                            << " +- " << b.se[c]);
        }
    }
    return bad;
}

void checkConverges(const cb::DeviceScene& scene, int ne, int nl, int ptEstimates, int runs,
                    int estimates) {
    auto ptSamples = ptReference(scene, ne + nl, ptEstimates, 7);
    CellStats pt = cbtest::summarizeRuns(ptSamples);
    MltRuns mlt = mltRuns(scene, mltSettings(ne, nl), runs, estimates, 1000);
    double worst = 0;
    for (size_t c = 0; c < pt.mean.size(); ++c)
        worst = std::max(worst, mlt.cells.se[c] / pt.mean[c]);
    MESSAGE("acceptance " << mlt.minAcceptance << " .. " << mlt.maxAcceptance
                          << "; largest relative standard error of an MLT cell " << worst << "; b "
                          << mlt.bootstrapB.mean[0] << " +- " << mlt.bootstrapB.se[0]
                          << " vs PT mean luminance " << pt.mean.back() << " +- " << pt.se.back());
    CellStats ptShape = shape(ptSamples);
    double worstShape = 0;
    for (size_t c = 0; c < ptShape.mean.size(); ++c)
        worstShape = std::max(worstShape, mlt.shape.se[c] / ptShape.mean[c]);
    MESSAGE("largest relative standard error of an MLT cell / mean luminance " << worstShape);
    CHECK(disagreeing(mlt.cells, pt) == 0);
    CHECK(disagreeing(mlt.shape, ptShape) == 0);
    CHECK(mlt.finite);
    CHECK(mlt.nonFinite == 0);
    CHECK(mlt.minAcceptance > 0.0);
    CHECK(mlt.maxAcceptance < 1.0);
    // b is the mean luminance of the image (the last entry), from each run's bootstrap.
    CellStats ptLum{{pt.mean.back()}, {pt.se.back()}};
    CHECK(disagreeing(mlt.bootstrapB, ptLum) == 0);
}

// A closed grey room lit only by a small, bright ceiling light hidden behind a grille of slats
// (80% closed) just below it: most light paths hit the slats, and PT's shadow rays mostly do.
cb::SceneDesc grilleLightScene(int size) {
    cb::SceneDesc d;
    d.path = "<grille-light>";
    d.film.width = d.film.height = size;
    d.camera.fovDegrees = 70.f;
    cb::MaterialDesc grey;
    grey.kind = cb::MaterialKind::Diffuse;
    grey.reflectance = cb::SpectrumValue::constant(0.6f);
    cb::MaterialDesc dark = grey;
    dark.reflectance = cb::SpectrumValue::constant(0.2f);
    d.materials = {grey, dark};
    d.meshes.push_back(cbtest::insideOutBox(-1.f, 1.f, 0, -1));
    cb::AreaLightDesc light;
    light.radiance = cb::SpectrumValue::constant(400.f);
    d.areaLights.push_back(light);
    const double a = 0.06, cx = 0.2, cz = 0.6, yl = 0.99;
    cb::TriangleMeshDesc lamp;
    lamp.positions = {
        {cx - a, yl, cz - a}, {cx + a, yl, cz - a}, {cx + a, yl, cz + a}, {cx - a, yl, cz + a}};
    lamp.triangles = {{0, 1, 2}, {0, 2, 3}}; // normal -y: down into the room
    lamp.material = 1;
    lamp.areaLight = 0;
    d.meshes.push_back(lamp);
    // Slats along z at y = 0.93, 0.04 wide with 0.01 gaps, covering x in cx +- 0.3.
    cb::TriangleMeshDesc slats;
    slats.material = 1;
    const double yg = 0.93, half = 0.3;
    for (double x0 = cx - half; x0 < cx + half - 1e-9; x0 += 0.05) {
        unsigned base = unsigned(slats.positions.size());
        slats.positions.push_back({x0, yg, cz - half});
        slats.positions.push_back({x0 + 0.04, yg, cz - half});
        slats.positions.push_back({x0 + 0.04, yg, cz + half});
        slats.positions.push_back({x0, yg, cz + half});
        slats.triangles.push_back({base, base + 1, base + 2});
        slats.triangles.push_back({base, base + 2, base + 3});
    }
    d.meshes.push_back(slats);
    return d;
}

} // namespace

TEST_CASE("MLT: acceptance rate in (0,1), statistics consistent, no NaN, options validated") {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = desc.film.height = 16;
    cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    cb::IntegratorSettings s = mltSettings(3, 2);
    s.mltChains = 64;
    s.seed = 3;
    auto integrator = cb::makeIntegrator(s, scene, runtime());
    std::vector<float> rgb;
    for (int e = 0; e < 8; ++e) {
        integrator->renderEstimate(std::uint32_t(e), rgb);
        CHECK(allFinite(rgb));
    }
    const cb::MltStatistics* st = cb::mltStatistics(*integrator);
    REQUIRE(st != nullptr);
    CHECK(st->chains == 64);
    CHECK(st->mutationsPerChain == 4); // 256 pixels / 64 chains
    CHECK(st->mutations == 8 * 64 * 4);
    CHECK(st->acceptanceRate() > 0.0);
    CHECK(st->acceptanceRate() < 1.0);
    CHECK(st->bootstrapSamples == 2048);
    CHECK(st->bootstrapNonZero > 0);
    CHECK(st->normalization > 0.0);
    // Large steps: binomial(2048, 0.3), 5 standard deviations.
    const double n = double(st->mutations);
    CHECK(std::fabs(double(st->largeSteps) - 0.3 * n) <= 5.0 * std::sqrt(n * 0.3 * 0.7));
    CHECK(integrator->nonFiniteSamples() == 0);

    cb::IntegratorSettings bdpt = s;
    bdpt.name = "bdpt";
    CHECK(cb::mltStatistics(*cb::makeIntegrator(bdpt, scene, runtime())) == nullptr);
    cb::IntegratorSettings bad = s;
    bad.largeStepProbability = 1.5;
    CHECK_THROWS(cb::makeIntegrator(bad, scene, runtime()));
    bad = s;
    bad.mutationSize = 0.0;
    CHECK_THROWS(cb::makeIntegrator(bad, scene, runtime()));
    bad = s;
    bad.mltChains = -1;
    CHECK_THROWS(cb::makeIntegrator(bad, scene, runtime()));
}

TEST_CASE("MLT converges to PT on the Cornell box, b matches the PT image's mean luminance" *
          doctest::test_suite("statistical")) {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = desc.film.height = 16;
    cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    checkConverges(scene, 3, 2, 1024, 32, 32);
}

TEST_CASE("MLT converges to PT on the grille (grade)" * doctest::test_suite("statistical")) {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("grade.pbrt"));
    desc.film.width = desc.film.height = 16;
    cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    checkConverges(scene, 3, 2, 1024, 32, 32);
}

TEST_CASE("MLT converges to PT with a small bright light behind a grille" *
          doctest::test_suite("statistical")) {
    cb::DeviceScene scene = cb::buildDeviceScene(grilleLightScene(16), cb::ChannelMode::Rgb);
    checkConverges(scene, 3, 2, 2048, 32, 32);
}

TEST_CASE(
    "MLT renders a 16-channel spectral scene (work-group size must not overflow PoCL's stack)") {
    // Regression: with the work-group size left to PoCL (4096), the private vertex arrays of a
    // spectral scene overflowed the worker thread's stack and the process crashed.
    cb::SceneDesc desc = cb::parseSceneFile(cbtest::sourcePath("scenes/cornell-box.pbrt"));
    desc.film.width = desc.film.height = 16;
    cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Spectral);
    REQUIRE(scene.channels == 16);
    cb::IntegratorSettings s;
    s.name = "mlt";
    s.eyeVertices = 4;
    s.lightVertices = 4;
    s.mltBootstrap = 4096;
    auto integrator = cb::makeIntegrator(s, scene, runtime());
    std::vector<float> rgb;
    integrator->renderEstimate(0, rgb);
    double sum = 0;
    for (float v : rgb) {
        REQUIRE(std::isfinite(v));
        sum += v;
    }
    CHECK(sum > 0.0);
    CHECK(integrator->nonFiniteSamples() == 0);
}
