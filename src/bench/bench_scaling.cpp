// cbdpt-bench, scaling section: PT's time per estimate against the triangle count, the
// resolution and the number of estimates (the thesis's appendix A.2 linearity check).
#include "bench/bench.h"

#include "cl/cl_runtime.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace fs = std::filesystem;

namespace cb::bench {
namespace {

IntegratorSettings ptSettings() {
    IntegratorSettings pt;
    pt.name = "pt";
    return pt;
}

// A displaced sphere of n triangles floating in the Cornell box, for each n.
json scaleTriangles(const Options& o, ClRuntime& rt, int size, int estimates) {
    std::vector<long> counts =
        o.quick ? std::vector<long>{1000, 10000} : std::vector<long>{1000, 10000, 100000, 1000000};
    json tri = json::array();
    fmt::print("{:<12} {:>10} {:>12}\n", "triangles", "in scene", "s/estimate");
    std::string base;
    {
        std::ifstream in(scenePath("cornell-box"));
        std::stringstream ss;
        ss << in.rdbuf();
        base = ss.str();
    }
    fs::path tmp = fs::temp_directory_path() / fmt::format("cbdpt-bench-{}", getpid());
    fs::create_directories(tmp);
    const IntegratorSettings pt = ptSettings();
    for (long n : counts) {
        const float c[3] = {0.0f, 0.0f, 0.0f};
        writePly(displacedSphere(n, c, 1.0f), (tmp / "sphere.ply").string());
        std::string text = base + "\nAttributeBegin\n  Translate 0.2 0.33 0.22\n"
                                  "  Scale 0.09 0.09 0.09\n  NamedMaterial \"white\"\n"
                                  "  Shape \"plymesh\" \"string filename\" \"sphere.ply\"\n"
                                  "AttributeEnd\n";
        SceneDesc desc = parseSceneString(text, (tmp / "scaling.pbrt").string());
        desc.film.width = size;
        desc.film.height = size;
        DeviceScene scene = buildDeviceScene(desc);
        RenderTiming t = timeIntegrator(rt, scene, pt, estimates);
        fmt::print("{:<12} {:>10} {:>12.4f}\n", n, scene.triangleCount, t.perEstimate);
        std::fflush(stdout);
        tri.push_back({{"requested", n},
                       {"triangles", scene.triangleCount},
                       {"width", size},
                       {"height", size},
                       {"seconds_per_estimate", t.perEstimate}});
    }
    fs::remove_all(tmp);
    return tri;
}

json scaleResolution(const Options& o, ClRuntime& rt, const SceneDesc& cornell, int estimates) {
    const IntegratorSettings pt = ptSettings();
    std::vector<int> sizes =
        o.quick ? std::vector<int>{32, 64} : std::vector<int>{64, 128, 256, 512};
    json res = json::array();
    fmt::print("{:<12} {:>10} {:>12} {:>14}\n", "resolution", "pixels", "s/estimate", "ns/path");
    for (int s : sizes) {
        SceneDesc d = cornell;
        d.film.width = s;
        d.film.height = s;
        DeviceScene scene = buildDeviceScene(d);
        RenderTiming t = timeIntegrator(rt, scene, pt, estimates);
        fmt::print("{:<12} {:>10} {:>12.4f} {:>14.1f}\n", fmt::format("{}x{}", s, s), s * s,
                   t.perEstimate, t.perEstimate / (s * s) * 1e9);
        std::fflush(stdout);
        res.push_back({{"width", s},
                       {"height", s},
                       {"pixels", s * s},
                       {"seconds_per_estimate", t.perEstimate}});
    }
    return res;
}

// Total time of n estimates for growing n; `fit` gets the least-squares line through them.
json scaleEstimates(const Options& o, ClRuntime& rt, const SceneDesc& cornell, int size,
                    json& fit) {
    const IntegratorSettings pt = ptSettings();
    std::vector<int> ns =
        o.quick ? std::vector<int>{1, 2, 4} : std::vector<int>{1, 2, 4, 8, 16, 32};
    SceneDesc d = cornell;
    d.film.width = size;
    d.film.height = size;
    DeviceScene scene = buildDeviceScene(d);
    auto integrator = makeIntegrator(pt, scene, rt);
    std::vector<float> rgb;
    integrator->renderEstimate(0, rgb);
    json est = json::array();
    std::vector<double> xs, ys;
    fmt::print("{:<12} {:>12}\n", "estimates", "total s");
    std::uint32_t next = 1;
    for (int n : ns) {
        auto start = Clock::now();
        for (int e = 0; e < n; ++e)
            integrator->renderEstimate(next++, rgb);
        double total = secondsSince(start);
        fmt::print("{:<12} {:>12.4f}\n", n, total);
        xs.push_back(n);
        ys.push_back(total);
        est.push_back({{"estimates", n}, {"seconds", total}, {"width", size}, {"height", size}});
    }
    // Least-squares line and R^2: linear in the number of estimates means R^2 near 1.
    double mx = 0, my = 0;
    for (size_t i = 0; i < xs.size(); ++i) {
        mx += xs[i] / xs.size();
        my += ys[i] / ys.size();
    }
    double sxy = 0, sxx = 0, syy = 0;
    for (size_t i = 0; i < xs.size(); ++i) {
        sxy += (xs[i] - mx) * (ys[i] - my);
        sxx += (xs[i] - mx) * (xs[i] - mx);
        syy += (ys[i] - my) * (ys[i] - my);
    }
    double slope = sxx > 0 ? sxy / sxx : 0.0;
    double r2 = (sxx > 0 && syy > 0) ? sxy * sxy / (sxx * syy) : 1.0;
    fmt::print("linear fit: {:.4f} s per estimate + {:.4f} s, R^2 = {:.5f}\n", slope,
               my - slope * mx, r2);
    fit = {{"slope_seconds", slope}, {"intercept_seconds", my - slope * mx}, {"r2", r2}};
    return est;
}

} // namespace

json runScaling(const Options& o, ClRuntime& rt) {
    json out;
    const int estimates = o.quick ? 2 : 5;
    const int size = o.quick ? 32 : 128;
    fmt::print("\n== scaling (PT, 8 vertices, Cornell box; median of {} estimates)\n", estimates);
    out["triangles"] = scaleTriangles(o, rt, size, estimates);
    SceneDesc cornell = parseSceneFile(scenePath("cornell-box"));
    out["resolution"] = scaleResolution(o, rt, cornell, estimates);
    json fit;
    out["estimates"] = scaleEstimates(o, rt, cornell, size, fit);
    out["estimates_fit"] = fit;
    return out;
}

} // namespace cb::bench
