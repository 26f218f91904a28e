// cbdpt-bench, render section: time per estimate of every integrator on the thesis's scenes
// at its settings, each (scene, method) in a child process.
#include "bench/bench.h"

#include "cl/cl_runtime.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include <fmt/format.h>

#include <cstdio>
#include <stdexcept>

namespace cb::bench {
namespace {

// Thesis settings (scene file headers): Cornell box PT/CPT 8 vertices, BDPT/CBDPT Ne = Nl = 4;
// dragon PT/CPT 4 vertices, BDPT/CBDPT Ne = Nl = 2.
IntegratorSettings thesisSettings(const std::string& method, const std::string& sceneName) {
    IntegratorSettings s;
    s.name = method;
    bool dragon = sceneName == "dragon";
    if (method == "pt" || method == "cpt" || method == "mlt") {
        s.eyeVertices = dragon ? 4 : 8;
    } else {
        s.eyeVertices = dragon ? 2 : 4;
        s.lightVertices = dragon ? 2 : 4;
    }
    return s;
}

// Runs --child-render for one (scene, method) and parses its JSON line; `status` is its exit
// status.
json childRenderRow(const Options& o, const std::string& sceneName, const std::string& method,
                    int size, int estimates, int& status) {
    std::string cmd = fmt::format("'{}' --child-render {} {} {} {}", selfPath(), sceneName, method,
                                  size, estimates);
    if (!o.device.empty()) cmd += " --device " + o.device;
    FILE* p = popen(cmd.c_str(), "r");
    std::string text;
    char buf[4096];
    while (p && std::fgets(buf, sizeof buf, p))
        text += buf;
    status = p ? pclose(p) : -1;
    try {
        return json::parse(text);
    } catch (const std::exception&) {
        return json();
    }
}

} // namespace

RenderTiming timeIntegrator(ClRuntime& rt, const DeviceScene& scene, const IntegratorSettings& s,
                            int estimates) {
    auto integrator = makeIntegrator(s, scene, rt);
    std::vector<float> rgb;
    integrator->renderEstimate(0, rgb);
    std::vector<double> times;
    for (int e = 1; e <= estimates; ++e) {
        auto start = Clock::now();
        integrator->renderEstimate(std::uint32_t(e), rgb);
        times.push_back(secondsSince(start));
    }
    return {median(times), integrator->buildSeconds(), scene.camera.width * scene.camera.height};
}

std::string scenePath(const std::string& name) {
    return std::string(CBDPT_SOURCE_DIR) + "/scenes/" + name + ".pbrt";
}

// Run in a child process per (scene, method), so that an integrator still being written that
// crashes costs its own row only: prints one JSON object on stdout.
int childRender(const Options& o) {
    const std::string sceneName = o.childRender.at(0), method = o.childRender.at(1);
    const int size = std::stoi(o.childRender.at(2)), estimates = std::stoi(o.childRender.at(3));
    SceneDesc desc = parseSceneFile(scenePath(sceneName));
    desc.film.width = size;
    desc.film.height = size;
    DeviceScene scene = buildDeviceScene(desc);
    ClRuntime rt(o.device);
    IntegratorSettings s = thesisSettings(method, sceneName);
    json row;
    try {
        RenderTiming t = timeIntegrator(rt, scene, s, estimates);
        bool bidir = method == "bdpt" || method == "cbdpt";
        row = {{"scene", sceneName},
               {"method", method},
               {"width", size},
               {"height", size},
               {"eye_vertices", s.eyeVertices},
               {"light_vertices", bidir ? s.lightVertices : 0},
               {"seconds_per_estimate", t.perEstimate},
               {"paths_per_second", t.pixels / t.perEstimate},
               {"estimates_timed", estimates},
               {"program_build_seconds", t.buildSeconds},
               {"channels", scene.channels}};
    } catch (const std::invalid_argument&) {
        row = {{"unavailable", true}}; // not (yet) an integrator
    }
    fmt::print("{}\n", row.dump());
    return 0;
}

json runRender(const Options& o) {
    json out = json::array();
    const int size = o.quick ? 64 : 512;
    const int estimates = o.quick ? 2 : 8;
    fmt::print("\n== render: time per estimate at {}x{} (median of {} after one warm-up)\n", size,
               size, estimates);
    fmt::print("{:<12} {:<7} {:>4} {:>4} {:>12} {:>14} {:>9}\n", "scene", "method", "Ne", "Nl",
               "s/estimate", "Mpaths/s", "build s");
    for (const std::string sceneName : {"cornell-box", "dragon"}) {
        try {
            parseSceneFile(scenePath(sceneName)); // missing models: skip the scene, say why
        } catch (const std::exception& e) {
            fmt::print(stderr, "warning: {} skipped: {}\n", sceneName, e.what());
            continue;
        }
        for (const std::string method : {"pt", "cpt", "bdpt", "cbdpt", "mlt"}) {
            int status = 0;
            json row = childRenderRow(o, sceneName, method, size, estimates, status);
            if (status != 0 || !row.is_object()) {
                fmt::print("{:<12} {:<7} failed (exit status {}): not timed\n", sceneName, method,
                           status);
                out.push_back({{"scene", sceneName}, {"method", method}, {"failed", true}});
                continue;
            }
            if (row.value("unavailable", false)) continue;
            bool bidir = method == "bdpt" || method == "cbdpt";
            fmt::print("{:<12} {:<7} {:>4} {:>4} {:>12.4f} {:>14.3f} {:>9.2f}\n", sceneName, method,
                       row["eye_vertices"].get<int>(),
                       bidir ? std::to_string(row["light_vertices"].get<int>()) : "-",
                       row["seconds_per_estimate"].get<double>(),
                       row["paths_per_second"].get<double>() * 1e-6,
                       row["program_build_seconds"].get<double>());
            std::fflush(stdout);
            out.push_back(row);
        }
    }
    return out;
}

} // namespace cb::bench
