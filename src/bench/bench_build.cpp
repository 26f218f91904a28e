// cbdpt-bench, build section: BVH build times (ours and Embree's) and PoCL program builds,
// cold and warm cache.
#include "bench/bench.h"
#include "bench/embree_baseline.h"

#include "bvh/bvh.h"
#include "bvh/bvh_choice.h"
#include "cl/cl_runtime.h"

#include <fmt/format.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

namespace fs = std::filesystem;

namespace cb::bench {
namespace {

double runChildBuild(const std::string& cacheDir, const std::string& file,
                     const std::vector<std::string>& defines, const std::string& device) {
    std::string cmd =
        fmt::format("POCL_CACHE_DIR='{}' '{}' --child-build {}", cacheDir, selfPath(), file);
    for (const auto& d : defines)
        cmd += " " + d;
    if (!device.empty()) cmd += " --device " + device;
    FILE* p = popen(cmd.c_str(), "r");
    if (!p) return -1.0;
    char buf[128] = {0};
    double s = -1.0;
    if (std::fgets(buf, sizeof buf, p)) s = std::atof(buf);
    if (pclose(p) != 0) return -1.0;
    return s;
}

// BVH build times: ours (binary and the renderers' wide BVH) and Embree's.
json bvhBuildRows(const Options& o) {
    fmt::print("\n== build: BVH (binned SAH, {} bins, leaf <= {})\n", 16, o.leafSize);
    // wide s: what a scene load spends, the renderers' wide BVH built under both SAH settings
    // (the second on another thread), the sample rays traced through both, and the collapse.
    // wide MB: the chosen wide BVH's nodes and leaf packs (the packs hold the vertices);
    // embree MB: what Embree holds after its build less the mesh's vertex and index buffers.
    fmt::print("{:<11} {:>9} {:>9} {:>10} {:>10} {:>10} {:>9} {:>10}\n", "mesh", "triangles",
               "nodes", "ours s", "wide s", "embree s", "wide MB", "embree MB");
    json bvhRows = json::array();
    for (auto& m : loadMeshes(o)) {
        auto prims = meshPrimitives(m.mesh);
        std::vector<double> times;
        Bvh bvh;
        for (int r = 0; r < (o.quick ? 1 : 3); ++r) {
            auto start = Clock::now();
            bvh = buildBvh(prims, {o.leafSize, 16});
            times.push_back(secondsSince(start));
        }
        std::vector<double> wideTimes;
        const auto sample = cameraSample(primaryRays(meshBounds(m.mesh), 65536));
        std::size_t nodeBytes = 0, packBytes = 0;
        for (int r = 0; r < (o.quick ? 1 : 3); ++r) {
            auto start = Clock::now();
            WideBvhChoice choice = buildWideBvhForRays(prims, sample);
            wideTimes.push_back(secondsSince(start));
            nodeBytes = choice.wide.nodes.size() * sizeof(cbk::BvhNodeWide);
            packBytes = choice.wide.packs.size() * sizeof(cbk::TrianglePack);
        }
        double embreeS = 0.0;
        std::size_t embreeBytes = 0, embreeMeshBytes = 0;
        if (embreeAvailable()) {
            EmbreeBaseline e(m.mesh, o.threads);
            embreeS = e.buildSeconds();
            embreeBytes = e.sceneBytes();
            embreeMeshBytes = e.meshBufferBytes();
        }
        constexpr double kMB = 1e6;
        fmt::print("{:<11} {:>9} {:>9} {:>10.3f} {:>10.3f} {:>10.3f} {:>9.1f} {:>10.1f}\n", m.name,
                   prims.size(), bvh.nodes.size(), median(times), median(wideTimes), embreeS,
                   (nodeBytes + packBytes) / kMB, (embreeBytes - embreeMeshBytes) / kMB);
        json row = {{"mesh", m.name},
                    {"triangles", prims.size()},
                    {"nodes", bvh.nodes.size()},
                    {"depth", bvh.depth},
                    {"seconds", median(times)},
                    {"threads", 1},
                    {"wide_seconds", median(wideTimes)},
                    {"wide_node_bytes", nodeBytes},
                    {"wide_pack_bytes", packBytes}};
        if (embreeAvailable()) {
            row["embree_seconds"] = embreeS;
            row["embree_bytes"] = embreeBytes;
            row["embree_mesh_buffer_bytes"] = embreeMeshBytes;
        }
        bvhRows.push_back(row);
    }
    return bvhRows;
}

// PoCL program build times, cold (empty cache) and warm, each in a child process.
json programBuildRows(const Options& o) {
    struct Prog {
        std::string file, label;
        std::vector<std::string> defines;
    };
    std::vector<Prog> progs;
    for (const char* f : {"pt.cl", "bdpt.cl", "cbdpt.cl", "cbdpt_packets.cl", "mlt.cl"}) {
        try {
            assembleKernelSource(f);
        } catch (const std::exception&) {
            continue; // not written yet
        }
        progs.push_back({f, "diffuse-only rgb", {"CB_CHANNELS=3", "CB_FEATURES=0x101u"}});
        if (!o.quick)
            progs.push_back(
                {f, "all features spectral-16", {"CB_CHANNELS=16", "CB_FEATURES=0xffffffffu"}});
        if (o.quick) break;
    }
    fmt::print("\n== build: PoCL program (cold: empty POCL_CACHE_DIR; warm: same cache again)\n");
    fmt::print("{:<10} {:<26} {:>8} {:>8}\n", "program", "features", "cold s", "warm s");
    json progRows = json::array();
    for (const auto& p : progs) {
        char tmpl[] = "/tmp/cbdpt-bench-pocl-XXXXXX";
        const char* dir = mkdtemp(tmpl);
        double cold = dir ? runChildBuild(dir, p.file, p.defines, o.device) : -1.0;
        double warm = dir ? runChildBuild(dir, p.file, p.defines, o.device) : -1.0;
        if (dir) fs::remove_all(dir);
        fmt::print("{:<10} {:<26} {:>8.2f} {:>8.3f}\n", p.file, p.label, cold, warm);
        std::fflush(stdout);
        progRows.push_back({{"program", p.file},
                            {"features", p.label},
                            {"defines", p.defines},
                            {"cold_seconds", cold},
                            {"warm_seconds", warm}});
    }
    return progRows;
}

} // namespace

// Run in a child process (fresh POCL_CACHE_DIR for cold builds): build one program, print the
// seconds on stdout.
int childBuild(const Options& o) {
    ClRuntime rt(o.device);
    std::vector<std::string> defines(o.childBuild.begin() + 1, o.childBuild.end());
    rt.buildProgram(o.childBuild[0], defines);
    fmt::print("{:.6f}\n", rt.lastBuildSeconds());
    return 0;
}

json runBuild(const Options& o) {
    json out;
    out["bvh"] = bvhBuildRows(o);
    out["program"] = programBuildRows(o);
    return out;
}

} // namespace cb::bench
