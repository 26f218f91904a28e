// Rendering helpers for statistical tests.
#pragma once

#include "cb_bvh_wide.h"
#include "integrators/integrator.h"
#include "scene/device_scene.h"

#include <cmath>
#include <optional>
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
    v.curves = s.curves.data();
    v.lightCount = int(s.lights.size());
    v.features = s.features;
    return v;
}

// The surface point that a ray straight down (-z) from world point (x, y, z) finds in `view`
// (the host view of `scene`, whose device coordinates are world minus scene.origin); none on a
// miss.
inline std::optional<cbk::SurfacePoint> surfaceBelow(const cb::DeviceScene& scene,
                                                     const cbk::SceneView& view, double x, double y,
                                                     double z) {
    cbk::Ray ray;
    ray.o = cbk::vec3(float(x - scene.origin[0]), float(y - scene.origin[1]),
                      float(z - scene.origin[2]));
    ray.d = cbk::vec3(0.f, 0.f, -1.f);
    cbk::Hit hit;
    if (!cbk::sceneIntersect(&view, ray, CB_INFINITY, &hit)) return std::nullopt;
    return cbk::surfacePointFromHit(&view, ray, hit);
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
