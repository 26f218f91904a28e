// cbdpt-bench: kernel micro-benchmarks and end-to-end timings.
//
// Sections, one file each: traverse (our OpenCL traversal against Embree 3 on the same rays),
// build (BVH and PoCL program build times, cold and warm cache), render (time per estimate of
// every integrator), scaling (time per estimate against triangles, resolution, estimates),
// accumulate (the host's exact sums of one estimate's image). Each
// prints a table; this file parses the options and writes everything to --json. All timings are
// medians of repeats.
#include "bench/bench.h"
#include "bench/embree_baseline.h"

#include "cl/cl_runtime.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

namespace fs = std::filesystem;

namespace cb::bench {
namespace {

json machineInfo(ClRuntime& rt) {
    json m;
    double load[3] = {0, 0, 0};
    if (getloadavg(load, 3) == 3) m["load_average"] = {load[0], load[1], load[2]};
    m["hardware_threads"] = std::thread::hardware_concurrency();
    std::ifstream cpu("/proc/cpuinfo");
    std::string line;
    while (std::getline(cpu, line))
        if (line.rfind("model name", 0) == 0) {
            m["cpu"] = line.substr(line.find(':') + 2);
            break;
        }
    m["opencl_device"] = rt.info().deviceName;
    m["opencl_driver"] = rt.info().driverVersion;
    m["compute_units"] = rt.info().computeUnits;
    if (const char* wg = std::getenv("POCL_WORK_GROUP_METHOD")) m["pocl_work_group_method"] = wg;
    m["embree"] = embreeAvailable();
    return m;
}

void addOptions(CLI::App& app, Options& o) {
    app.add_flag("--quick", o.quick, "small sizes and few repeats (CI)");
    app.add_option("--json", o.json, "write all results to this JSON file");
    app.add_option("--models", o.models, "folder with bunny.ply and dragon.ply");
    app.add_option("--sections", o.sections, "traverse build render scaling accumulate")
        ->delimiter(',');
    app.add_option(
           "--traversal", o.traversal,
           "comma-separated: ordered | skip (binary BVH) | wide (4- or 8-wide, the "
           "renderers' BVH) | packet (the wide BVH traversed by work-groups of 64 rays "
           "together, a prototype) | ray8, ray16 (the wide BVH, packets of 2x4 or 4x4 rays per "
           "work-item, as CPT and CBDPT trace); both = ordered,skip")
        ->check([](const std::string& v) {
            if (v == "both") return std::string();
            for (const auto& s : splitCommas(v))
                if (s != "ordered" && s != "skip" && s != "wide" && s != "packet" && s != "ray8" &&
                    s != "ray16")
                    return "unknown traversal '" + s +
                           "' (ordered, skip, wide, packet, ray8, ray16, both)";
            return std::string();
        });
    app.add_option("--prefetch", o.prefetch,
                   "wide, ray8, ray16: prefetch the nodes and packs a traversal will enter: auto "
                   "(on a CPU, where the tree is larger than the device's cache, as the "
                   "renderers), on, off")
        ->check(CLI::IsMember({"auto", "on", "off"}));
    app.add_option("--repeats", o.repeats, "timed repeats per measurement");
    app.add_option("--local-size", o.localSize, "traversal work-group size (0: PoCL chooses)");
    app.add_option("--leaf-size", o.leafSize, "BVH maximum leaf size");
    app.add_option(
        "--sah-block", o.sahBlock,
        "traverse: the SAH prices primitive tests in blocks of this many, with leaves of "
        "--leaf-size (0: the wide BVH chosen as the renderers choose it, "
        "bvh_choice.h; 1 for the binary)");
    app.add_option("--rays", o.rays, "rays per traversal case");
    app.add_option("--threads", o.threads, "Embree (and --host) threads");
    app.add_flag("--host", o.host, "also time bench_bvh_binary.h compiled for the host");
    app.add_option(
           "--meshes", o.meshes,
           "bunny, dragon, buddha, sphere-<n>[k|M]; NAME-room: NAME standing in an open room")
        ->delimiter(',');
    app.add_option("--device", o.device, "OpenCL device P:D");
    app.add_option("--cases", o.cases,
                   "traverse: primary, incoherent, shadow, incoh-any, and one CPT estimate's "
                   "coherent rays: bounce1, bounce2 (its first and second bounces), coh-shadow "
                   "(its shadow rays); primary and these also against Embree's packets")
        ->delimiter(',')
        ->check([](const std::string& s) {
            for (const char* known : {"primary", "incoherent", "shadow", "incoh-any", "bounce1",
                                      "bounce2", "coh-shadow"})
                if (s == known) return std::string();
            return "unknown ray case '" + s +
                   "' (primary, incoherent, shadow, incoh-any, bounce1, bounce2, coh-shadow)";
        });
    app.add_option("--child-build", o.childBuild, "(internal)")->group("");
    app.add_option("--child-render", o.childRender, "(internal)")->group("");
}

int run(int argc, char** argv) {
    Options o;
    CLI::App app{"cbdpt-bench: traversal, build, render, scaling and accumulation benchmarks"};
    addOptions(app, o);
    CLI11_PARSE(app, argc, argv);
    if (!o.childBuild.empty()) return childBuild(o);
    if (!o.childRender.empty()) return childRender(o);

    // The scene files find dragon.ply through CBDPT_MODEL_PATH: point it at --models or the
    // shared folder when the caller did not.
    std::string dragon = findModel(o, "dragon.ply");
    if (!dragon.empty()) {
        std::string dir = fs::path(dragon).parent_path().string();
        const char* env = std::getenv("CBDPT_MODEL_PATH");
        std::string value = env && *env ? dir + ":" + env : dir;
        setenv("CBDPT_MODEL_PATH", value.c_str(), 1);
    }
    ClRuntime rt(o.device);
    json result;
    result["machine"] = machineInfo(rt);
    result["quick"] = o.quick;
    result["settings"] = {{"local_size", o.localSize},
                          {"leaf_size", o.leafSize},
                          {"sah_block", o.sahBlock},
                          {"traversal", o.traversal},
                          {"embree_threads", o.threads}};
    fmt::print("cbdpt-bench on {} ({}), load average {}\n", rt.info().deviceName,
               rt.info().driverVersion, result["machine"].value("load_average", json()).dump());
    auto want = [&](const char* s) {
        return std::find(o.sections.begin(), o.sections.end(), s) != o.sections.end();
    };
    auto save = [&] {
        if (o.json.empty()) return;
        std::ofstream f(o.json);
        f << result.dump(2) << "\n";
    };
    if (want("traverse")) result["traverse"] = runTraverse(o, rt), save();
    if (want("build")) result["build"] = runBuild(o), save();
    if (want("render")) result["render"] = runRender(o), save();
    if (want("scaling")) result["scaling"] = runScaling(o, rt), save();
    if (want("accumulate")) result["accumulate"] = runAccumulate(o), save();
    save();
    return 0;
}

} // namespace
} // namespace cb::bench

int main(int argc, char** argv) {
    try {
        return cb::bench::run(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "cbdpt-bench: %s\n", e.what());
        return 1;
    }
}
