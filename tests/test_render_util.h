// Rendering helpers for statistical tests.
#pragma once

#include "integrators/integrator.h"
#include "scene/device_scene.h"

#include <cmath>
#include <vector>

namespace cbtest {

// The scene as the kernels' shared code sees it, run on the host (the kernels' headers compiled
// as C++): pointers into the device scene's arrays.
inline cbk::SceneView hostView(const cb::DeviceScene& s) {
    cbk::SceneView v{};
    v.nodes = s.wide.nodes.data();
    v.packs = s.wide.packs.data();
    v.primitives = s.bvh.primitives.data();
    v.materials = s.materials.data();
    v.lights = s.lights.data();
    v.spectra = s.spectra.data();
    v.lightTables = s.lightTables.data();
    v.textures = s.textures.data();
    v.shadingNormals = s.shadingNormals.data();
    v.lightCount = int(s.lights.size());
    return v;
}

struct PooledStats {
    double mean = 0;          // mean over all pixels, channels and estimates
    double standardError = 0; // of that mean, treating every pixel sample as independent
    long nonFinite = 0;
};

// Renders `estimates` estimates and pools every (pixel, estimate) sample's channel average.
inline PooledStats renderPooled(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                                const cb::IntegratorSettings& settings, int estimates) {
    auto integrator = cb::makeIntegrator(settings, scene, runtime);
    std::vector<float> rgb;
    double sum = 0, sumSq = 0;
    long n = 0;
    for (int e = 0; e < estimates; ++e) {
        integrator->renderEstimate(std::uint32_t(e), rgb);
        for (size_t i = 0; i + 2 < rgb.size(); i += 3) {
            double v = (double(rgb[i]) + rgb[i + 1] + rgb[i + 2]) / 3.0;
            sum += v;
            sumSq += v * v;
            ++n;
        }
    }
    PooledStats s;
    s.mean = sum / double(n);
    double variance =
        std::max(0.0, sumSq / double(n) - s.mean * s.mean) * double(n) / double(n - 1);
    s.standardError = std::sqrt(variance / double(n));
    s.nonFinite = integrator->nonFiniteSamples();
    return s;
}

// Per-entry mean over independent runs (one vector of values per run, e.g. image cells) and the
// standard error of each mean from the spread across the runs.
struct RunStats {
    std::vector<double> mean, se;
};

inline RunStats summarizeRuns(const std::vector<std::vector<double>>& runs) {
    const size_t n = runs.size(), k = runs[0].size();
    RunStats s{std::vector<double>(k, 0.0), std::vector<double>(k, 0.0)};
    for (const auto& r : runs)
        for (size_t c = 0; c < k; ++c)
            s.mean[c] += r[c] / double(n);
    for (const auto& r : runs)
        for (size_t c = 0; c < k; ++c)
            s.se[c] += (r[c] - s.mean[c]) * (r[c] - s.mean[c]) / double(n - 1);
    for (size_t c = 0; c < k; ++c)
        s.se[c] = std::sqrt(s.se[c] / double(n));
    return s;
}

} // namespace cbtest
