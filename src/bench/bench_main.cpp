// cbdpt-bench: kernel micro-benchmarks and end-to-end timings (issue 9, docs/performance.md).
//
// Sections: traverse (our OpenCL traversal against Embree 3 on the same rays), build (BVH and
// PoCL program build times, cold and warm cache), render (time per estimate of every
// integrator), scaling (time per estimate against triangles, resolution, estimates). Prints a
// table per section and writes everything to --json. All timings are medians of repeats.
#include "bench/bench_meshes.h"
#include "bench/embree_baseline.h"
#include "bench/kernels/bench_bvh_binary.h"
#include "bench/parallel_rays.h"

#include "bvh/bvh.h"
#include "bvh/bvh_choice.h"
#include "bvh/bvh_wide.h"
#include "cl/cl_runtime.h"
#include "integrators/integrator.h"
#include "integrators/scene_buffers.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include "cb_camera.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>
#include <time.h>
#include <unistd.h>

namespace fs = std::filesystem;
using json = nlohmann::json;
using cbk::Ray;
using cbk::Vec3;

namespace cb::bench {
namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

// CPU seconds of the whole process (all threads: PoCL's workers, Embree's std::threads). With
// other jobs on the machine, wall time includes waiting for a core; CPU time is much steadier.
double processCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Options {
    bool quick = false;
    std::string json;
    std::string models;
    std::vector<std::string> sections{"traverse", "build", "render", "scaling"};
    std::string traversal = "wide,ordered"; // comma-separated ordered, skip, wide; or both
    int repeats = 0;                        // 0: 5 (2 in --quick)
    int localSize = 64;                     // 0: let PoCL choose
    int leafSize = 4;
    int sahBlock = 0; // SAH cost per block of this many primitives; 0: as the renderers / 1
    long rays = 0;    // 0: 1M (64k in --quick)
    int threads = 2;
    bool host = false;               // also time the host (g++) build of the traversal
    std::vector<std::string> meshes; // default per mode
    // traverse: which ray sets to time (shadow rays start at the primary hits, so primary rays
    // are traced for them either way).
    std::vector<std::string> cases{"primary", "incoherent", "shadow", "incoh-any"};
    std::string device;
    // Internal: measure one program build in this process (run by the build section).
    std::vector<std::string> childBuild;
    std::vector<std::string> childRender;
};

std::string findModel(const Options& o, const std::string& file) {
    std::vector<std::string> dirs;
    if (!o.models.empty()) dirs.push_back(o.models);
    if (const char* env = std::getenv("CBDPT_MODEL_PATH")) {
        std::stringstream ss(env);
        std::string d;
        while (std::getline(ss, d, ':'))
            if (!d.empty()) dirs.push_back(d);
    }
    dirs.push_back(std::string(CBDPT_SOURCE_DIR) + "/../shared/models");
    for (const auto& d : dirs)
        if (fs::exists(fs::path(d) / file)) return (fs::path(d) / file).string();
    return "";
}

// ---- Rays ------------------------------------------------------------------------------

struct Box3 {
    Vec3 lo, hi;
};

Box3 meshBounds(const PlyMesh& m) {
    Box3 b{cbk::vec3(INFINITY, INFINITY, INFINITY), cbk::vec3(-INFINITY, -INFINITY, -INFINITY)};
    for (const auto& p : m.positions) {
        Vec3 v = cbk::vec3(p[0], p[1], p[2]);
        b.lo = cbk::vmin(b.lo, v);
        b.hi = cbk::vmax(b.hi, v);
    }
    return b;
}

Vec3 uniformDirection(std::mt19937& rng) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    float z = 1.0f - 2.0f * u(rng);
    float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    float phi = 2.0f * CB_PI * u(rng);
    return cbk::vec3(r * std::cos(phi), r * std::sin(phi), z);
}

// Primary rays of a pinhole camera looking at the mesh from the front (+z, a little above),
// one per pixel of a side x side image, ordered by 8x8 tiles so that a work-group (and an
// Embree thread's range) holds neighbouring pixels, as in the renderers.
std::vector<Ray> primaryRays(const Box3& b, long count) {
    int side = std::max(8, int(std::sqrt(double(count))) / 8 * 8);
    Vec3 centre = cbk::vscale(cbk::vadd(b.lo, b.hi), 0.5f);
    float radius = 0.5f * cbk::vlength(cbk::vsub(b.hi, b.lo));
    Vec3 eye = cbk::vadd(centre, cbk::vec3(0.3f * radius, 0.4f * radius, 2.6f * radius));
    Vec3 fwd = cbk::vnormalize(cbk::vsub(centre, eye));
    Vec3 right = cbk::vnormalize(cbk::vcross(fwd, cbk::vec3(0, 1, 0)));
    Vec3 up = cbk::vcross(right, fwd);
    float tanHalf = std::tan(0.5f * 40.0f * CB_PI / 180.0f);
    std::vector<Ray> rays;
    rays.reserve(size_t(side) * side);
    for (int ty = 0; ty < side; ty += 8)
        for (int tx = 0; tx < side; tx += 8)
            for (int y = ty; y < ty + 8; ++y)
                for (int x = tx; x < tx + 8; ++x) {
                    float sx = (2.0f * (x + 0.5f) / side - 1.0f) * tanHalf;
                    float sy = (1.0f - 2.0f * (y + 0.5f) / side) * tanHalf;
                    Vec3 d = cbk::vadd(fwd, cbk::vadd(cbk::vscale(right, sx), cbk::vscale(up, sy)));
                    rays.push_back(Ray{eye, cbk::vnormalize(d)});
                }
    return rays;
}

std::vector<Ray> incoherentRays(const Box3& b, long count, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Ray> rays(static_cast<size_t>(count));
    for (auto& r : rays) {
        r.o = cbk::vec3(b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                        b.lo.z + u(rng) * (b.hi.z - b.lo.z));
        r.d = uniformDirection(rng);
    }
    return rays;
}

// Shadow rays from the primary hit points (pulled back along the primary ray by 1e-4 of the
// mesh size, so both tracers agree on what the origin is) to points on a square light above
// the mesh; primary misses start at a random point of the box instead.
void shadowRays(const Box3& b, const std::vector<Ray>& primary, const std::vector<cbk::Hit>& hits,
                unsigned seed, std::vector<Ray>& rays, std::vector<float>& tMax) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    Vec3 centre = cbk::vscale(cbk::vadd(b.lo, b.hi), 0.5f);
    float size = cbk::vlength(cbk::vsub(b.hi, b.lo));
    rays.resize(primary.size());
    tMax.resize(primary.size());
    for (size_t i = 0; i < primary.size(); ++i) {
        Vec3 o;
        if (hits[i].primitive >= 0)
            o = cbk::vmadd(primary[i].o, primary[i].d, hits[i].t - 1e-4f * size);
        else
            o = cbk::vec3(b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                          b.lo.z + u(rng) * (b.hi.z - b.lo.z));
        Vec3 light = cbk::vadd(
            centre, cbk::vec3((u(rng) - 0.5f) * size, 0.8f * size, (u(rng) - 0.5f) * size));
        Vec3 d = cbk::vsub(light, o);
        float len = cbk::vlength(d);
        rays[i] = Ray{o, cbk::vscale(d, 1.0f / len)};
        tMax[i] = len * (1.0f - 1e-4f);
    }
}

std::vector<std::string> splitCommas(const std::string& v) {
    std::vector<std::string> out;
    std::stringstream ss(v);
    for (std::string item; std::getline(ss, item, ',');)
        if (!item.empty()) out.push_back(item);
    return out;
}

// About a thousand of the camera rays, spread over the image: what the wide BVH's build
// samples to choose its settings, as DeviceScene does with the scene's camera.
std::vector<Ray> cameraSample(const std::vector<Ray>& primary) {
    const size_t step = std::max<size_t>(1, primary.size() / 1024);
    std::vector<Ray> sample;
    for (size_t i = step / 2; i < primary.size(); i += step)
        sample.push_back(primary[i]);
    return sample;
}

// ---- Our OpenCL traversal ---------------------------------------------------------------

class ClTraversal {
  public:
    // variant: ordered | skip (binary BVH) | wide (cb_bvh_wide.h, what the renderers use)
    ClTraversal(ClRuntime& rt, const Bvh& bvh, const std::string& variant, int localSize)
        : rt_(rt), localSize_(localSize) {
        std::vector<std::string> defines = {"CB_CHANNELS=3", "CB_FEATURES=0x101u"};
        if (variant == "skip") defines.push_back("CB_BVH_SKIP_ORDER=1");
        program_ = rt.buildProgram("bench_traverse.cl", defines);
        const bool wide = variant == "wide";
        closest_ = cl::Kernel(program_, wide ? "benchClosestWide" : "benchClosest");
        occluded_ = cl::Kernel(program_, wide ? "benchOccludedWide" : "benchOccluded");
        if (wide) closestCoherent_ = cl::Kernel(program_, "benchClosestWideCoherent");
        if (wide) {
            wide_ = collapseBvhWide(bvh);
            nodes_ = uploadArray(rt, "bench wide BVH nodes", wide_.nodes);
            packs_ = uploadArray(rt, "bench BVH leaf triangles", wide_.packs);
        } else {
            nodes_ = uploadArray(rt, "bench binary BVH nodes", bvh.nodes);
        }
        prims_ = uploadArray(rt, "bench primitives", bvh.primitives);
    }

    // Returns the median seconds of `repeats` launches; hits from the last one.
    double closest(const std::vector<Ray>& rays, bool coherent, int repeats,
                   std::vector<cbk::Hit>& hits) {
        auto& ctx = rt_.context();
        cl::Buffer rayBuf(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, rays.size() * sizeof(Ray),
                          const_cast<Ray*>(rays.data()));
        cl::Buffer hitBuf(ctx, CL_MEM_WRITE_ONLY, rays.size() * sizeof(cbk::Hit));
        // Coherent rays go through the renderers' camera-ray traversal (wide BVH only).
        cl::Kernel& kernel = coherent && !wide_.nodes.empty() ? closestCoherent_ : closest_;
        int arg = setBvhArgs(kernel);
        kernel.setArg(arg++, rayBuf);
        kernel.setArg(arg++, cl_uint(rays.size()));
        kernel.setArg(arg, hitBuf);
        double t = launch(kernel, rays.size(), repeats);
        hits.resize(rays.size());
        rt_.queue().enqueueReadBuffer(hitBuf, CL_TRUE, 0, hits.size() * sizeof(cbk::Hit),
                                      hits.data());
        return t;
    }

    double occluded(const std::vector<Ray>& rays, const std::vector<float>& tMax, int repeats,
                    std::vector<int>& out) {
        auto& ctx = rt_.context();
        cl::Buffer rayBuf(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, rays.size() * sizeof(Ray),
                          const_cast<Ray*>(rays.data()));
        cl::Buffer tBuf(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, tMax.size() * sizeof(float),
                        const_cast<float*>(tMax.data()));
        cl::Buffer outBuf(ctx, CL_MEM_WRITE_ONLY, rays.size() * sizeof(int));
        int arg = setBvhArgs(occluded_);
        occluded_.setArg(arg++, rayBuf);
        occluded_.setArg(arg++, tBuf);
        occluded_.setArg(arg++, cl_uint(rays.size()));
        occluded_.setArg(arg, outBuf);
        double t = launch(occluded_, rays.size(), repeats);
        out.resize(rays.size());
        rt_.queue().enqueueReadBuffer(outBuf, CL_TRUE, 0, out.size() * sizeof(int), out.data());
        return t;
    }

  private:
    // The BVH arguments: nodes, [packs,] primitives. Returns the next argument index.
    int setBvhArgs(cl::Kernel& k) {
        int arg = 0;
        k.setArg(arg++, nodes_);
        if (!wide_.nodes.empty()) k.setArg(arg++, packs_);
        k.setArg(arg++, prims_);
        return arg;
    }

    double launch(cl::Kernel& k, size_t n, int repeats) {
        size_t global = n;
        cl::NDRange local = cl::NullRange;
        if (localSize_ > 0) {
            global = (n + size_t(localSize_) - 1) / size_t(localSize_) * size_t(localSize_);
            local = cl::NDRange(size_t(localSize_));
        }
        // One untimed launch: first-launch costs (PoCL's work-group function compilation for
        // this local size, buffer migration) are not traversal.
        rt_.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(global), local);
        rt_.queue().finish();
        std::vector<double> times, cpu;
        for (int r = 0; r < repeats; ++r) {
            auto start = Clock::now();
            double cpuStart = processCpuSeconds();
            rt_.queue().enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(global), local);
            rt_.queue().finish();
            times.push_back(secondsSince(start));
            cpu.push_back(processCpuSeconds() - cpuStart);
        }
        lastCpu = median(cpu);
        return median(times);
    }

    ClRuntime& rt_;
    int localSize_;
    cl::Program program_;
    cl::Kernel closest_, closestCoherent_, occluded_;
    cl::Buffer nodes_, packs_, prims_;
    BvhWide wide_; // empty for the binary BVH

  public:
    double lastCpu = 0.0; // median CPU seconds of the last closest() or occluded()
};

struct MeshEntry {
    std::string name;
    PlyMesh mesh;
};

std::vector<MeshEntry> loadMeshes(const Options& o) {
    std::vector<std::string> names = o.meshes;
    if (names.empty())
        names = o.quick ? std::vector<std::string>{"bunny", "sphere-10k"}
                        : std::vector<std::string>{"bunny", "dragon", "sphere-1M"};
    std::vector<MeshEntry> out;
    for (const auto& n : names) {
        if (n.rfind("sphere-", 0) == 0) {
            std::string s = n.substr(7);
            double scale = 1.0;
            if (!s.empty() && (s.back() == 'k' || s.back() == 'M')) {
                scale = s.back() == 'k' ? 1e3 : 1e6;
                s.pop_back();
            }
            long tris = long(std::stod(s) * scale);
            const float c[3] = {0.0f, 0.0f, 0.0f};
            out.push_back({n, displacedSphere(tris, c, 1.0f)});
            continue;
        }
        std::string path = findModel(o, n + ".ply");
        if (path.empty()) {
            fmt::print(stderr,
                       "warning: {}.ply not found (--models or CBDPT_MODEL_PATH); skipped\n", n);
            continue;
        }
        out.push_back({n, readPly(path)});
    }
    return out;
}

// Agreement of closest hits: same hit/miss and primitive, or a tie (both primitives at the
// same distance up to 1e-5 relative: shared edges and vertices).
// The binary BVH traversal (bench_bvh_binary.h) compiled by g++ for the host, on `threads`
// std::threads: separates what the traversal algorithm costs from what PoCL's code generation adds.
double hostSeconds(const Bvh& bvh, const std::vector<Ray>& rays, const std::vector<float>* tMax,
                   int threads, int repeats) {
    std::vector<double> times;
    std::atomic<int> sink{0}; // keeps the traversal from being optimised away
    for (int r = 0; r < repeats; ++r) {
        auto start = Clock::now();
        parallelRayChunks(rays.size(), threads, [&](size_t b, size_t e) {
            int count = 0;
            for (size_t i = b; i < e; ++i) {
                if (tMax) {
                    count += cbk::bvhOccluded(bvh.nodes.data(), bvh.primitives.data(), rays[i],
                                              (*tMax)[i]);
                } else {
                    cbk::Hit h;
                    count += cbk::bvhIntersect(bvh.nodes.data(), bvh.primitives.data(), rays[i],
                                               CB_INFINITY, &h);
                }
            }
            sink += count;
        });
        times.push_back(secondsSince(start));
    }
    return median(times);
}

double closestAgreement(const std::vector<cbk::Hit>& ours, const Bvh& bvh,
                        const std::vector<BaselineHit>& theirs) {
    size_t agree = 0;
    for (size_t i = 0; i < ours.size(); ++i) {
        bool hitA = ours[i].primitive >= 0, hitB = theirs[i].primitive >= 0;
        if (hitA != hitB) continue;
        if (!hitA) {
            ++agree;
            continue;
        }
        int primA = bvh.originalIndex[size_t(ours[i].primitive)];
        if (primA == theirs[i].primitive ||
            std::fabs(ours[i].t - theirs[i].t) <= 1e-5f * std::max(ours[i].t, theirs[i].t))
            ++agree;
    }
    return ours.empty() ? 1.0 : double(agree) / double(ours.size());
}

json runTraverse(const Options& o, ClRuntime& rt) {
    json out = json::array();
    const int repeats = o.repeats > 0 ? o.repeats : (o.quick ? 2 : 5);
    const long rayCount = o.rays > 0 ? o.rays : (o.quick ? 65536 : 1 << 20);
    std::vector<std::string> variants;
    if (o.traversal == "both")
        variants = {"ordered", "skip"};
    else
        variants = splitCommas(o.traversal);
    fmt::print("\n== traverse: Mrays/s (median of {}), {} rays, local size {}, Embree on {} "
               "threads, wide BVH {} lanes; each BVH's settings on its own line\n",
               repeats, rayCount, o.localSize, o.threads, CB_BVH_WIDE_LANES);
    // cpu-ratio: the same ratio from process CPU seconds instead of wall seconds, steadier when
    // other jobs share the cores.
    fmt::print("{:<11} {:>9} {:<8} {:<10} {:>9} {:>9} {:>7} {:>9} {:>9}\n", "mesh", "triangles",
               "order", "rays", "ours", "embree", "ratio", "cpu-ratio", "agree");
    for (auto& m : loadMeshes(o)) {
        auto prims = meshPrimitives(m.mesh);
        Box3 box = meshBounds(m.mesh);
        std::unique_ptr<EmbreeBaseline> embree;
        if (embreeAvailable()) embree = std::make_unique<EmbreeBaseline>(m.mesh, o.threads);

        auto primary = primaryRays(box, rayCount);
        auto incoherent = incoherentRays(box, rayCount, 7u);
        for (const auto& variant : variants) {
            Bvh bvh;
            std::string settings;
            if (variant == "wide" && o.sahBlock <= 0) {
                // As the renderers build it (DeviceScene): the candidate cheapest for a sample
                // of the camera rays and their bounces.
                WideBvhChoice choice = buildWideBvhForRays(prims, cameraSample(primary));
                bvh = std::move(choice.bvh);
                settings = describeChoice(choice);
            } else {
                const int block = o.sahBlock > 0 ? o.sahBlock : 1;
                bvh = buildBvh(prims, {o.leafSize, 16, block});
                settings = fmt::format("SAH block {}, leaves <= {}", block, o.leafSize);
            }
            fmt::print("{:<11} {:>9} {:<8} BVH: {}\n", m.name, prims.size(), variant, settings);
            ClTraversal cl(rt, bvh, variant, o.localSize);
            std::vector<cbk::Hit> primaryHits;
            std::vector<Ray> shadow;
            std::vector<float> shadowT;
            struct Case {
                const char* name;
                const std::vector<Ray>* rays;
                bool anyHit;
            };
            // Shadow rays need the primary hits first.
            std::vector<Case> cases = {{"primary", &primary, false},
                                       {"incoherent", &incoherent, false},
                                       {"shadow", &shadow, true},
                                       {"incoh-any", &incoherent, true}};
            std::vector<float> infT(incoherent.size(), CB_INFINITY);
            for (const auto& c : cases) {
                const bool wanted =
                    std::find(o.cases.begin(), o.cases.end(), c.name) != o.cases.end();
                const bool neededForShadow =
                    std::string(c.name) == "primary" &&
                    std::find(o.cases.begin(), o.cases.end(), "shadow") != o.cases.end();
                if (!wanted && !neededForShadow) continue;
                double ours = 0.0, theirs = 0.0, agree = 1.0, theirsCpu = 0.0;
                size_t n = 0;
                long hitCount = 0;
                if (!c.anyHit) {
                    std::vector<cbk::Hit> hits;
                    ours = cl.closest(*c.rays, std::string(c.name) == "primary", repeats, hits);
                    n = c.rays->size();
                    for (const auto& h : hits)
                        hitCount += h.primitive >= 0;
                    if (std::string(c.name) == "primary") {
                        primaryHits = hits;
                        shadowRays(box, primary, primaryHits, 11u, shadow, shadowT);
                    }
                    if (!wanted) continue;
                    if (embree) {
                        std::vector<BaselineHit> ref;
                        std::vector<double> times, cpu;
                        for (int r = 0; r < repeats + 1; ++r) {
                            auto start = Clock::now();
                            double cpuStart = processCpuSeconds();
                            embree->intersect(*c.rays, ref);
                            if (r > 0) times.push_back(secondsSince(start));
                            if (r > 0) cpu.push_back(processCpuSeconds() - cpuStart);
                        }
                        theirs = median(times);
                        theirsCpu = median(cpu);
                        agree = closestAgreement(hits, bvh, ref);
                    }
                } else {
                    const auto& tm = std::string(c.name) == "shadow" ? shadowT : infT;
                    std::vector<int> occ;
                    ours = cl.occluded(*c.rays, tm, repeats, occ);
                    n = c.rays->size();
                    for (int v : occ)
                        hitCount += v;
                    if (embree) {
                        std::vector<int> ref;
                        std::vector<double> times, cpu;
                        for (int r = 0; r < repeats + 1; ++r) {
                            auto start = Clock::now();
                            double cpuStart = processCpuSeconds();
                            embree->occluded(*c.rays, tm, ref);
                            if (r > 0) times.push_back(secondsSince(start));
                            if (r > 0) cpu.push_back(processCpuSeconds() - cpuStart);
                        }
                        theirs = median(times);
                        theirsCpu = median(cpu);
                        size_t same = 0;
                        for (size_t i = 0; i < n; ++i)
                            same += occ[i] == ref[i];
                        agree = double(same) / double(n);
                    }
                }
                double host = 0.0;
                if (o.host && variant == "ordered")
                    host = hostSeconds(
                        bvh, *c.rays,
                        c.anyHit ? (std::string(c.name) == "shadow" ? &shadowT : &infT) : nullptr,
                        o.threads, repeats);
                double oursM = double(n) / ours * 1e-6;
                double theirsM = theirs > 0 ? double(n) / theirs * 1e-6 : 0.0;
                double ratio = theirsM > 0 ? oursM / theirsM : 0.0;
                double cpuRatio = theirsCpu > 0 && cl.lastCpu > 0 ? theirsCpu / cl.lastCpu : 0.0;
                fmt::print("{:<11} {:>9} {:<8} {:<10} {:>9.2f} {:>9.2f} {:>7.3f} {:>9.3f} "
                           "{:>8.4f}%\n",
                           m.name, prims.size(), variant, c.name, oursM, theirsM, ratio, cpuRatio,
                           100.0 * agree);
                std::fflush(stdout);
                json row = {{"mesh", m.name},
                            {"triangles", prims.size()},
                            {"order", variant},
                            {"bvh_settings", settings},
                            {"rays", c.name},
                            {"query", c.anyHit ? "any-hit" : "closest-hit"},
                            {"count", n},
                            {"hit_fraction", double(hitCount) / double(n)},
                            {"ours_mrays_per_s", oursM},
                            {"ours_seconds", ours}};
                if (host > 0.0) {
                    row["host_mrays_per_s"] = double(n) / host * 1e-6;
                    fmt::print("{:<11} {:>9} {:<8} {:<10} {:>9.2f}  (same code, g++ on the host)\n",
                               "", "", "host", c.name, double(n) / host * 1e-6);
                }
                if (embree) {
                    row["embree_mrays_per_s"] = theirsM;
                    row["embree_seconds"] = theirs;
                    row["ratio"] = ratio;
                    row["cpu_ratio"] = cpuRatio;
                    row["agreement"] = agree;
                }
                out.push_back(row);
            }
        }
    }
    return out;
}

// ---- Build times ---------------------------------------------------------------------------

// Run in a child process (fresh POCL_CACHE_DIR for cold builds): build one program, print the
// seconds on stdout.
int childBuild(const Options& o) {
    ClRuntime rt(o.device);
    std::vector<std::string> defines(o.childBuild.begin() + 1, o.childBuild.end());
    rt.buildProgram(o.childBuild[0], defines);
    fmt::print("{:.6f}\n", rt.lastBuildSeconds());
    return 0;
}

double runChildBuild(const std::string& cacheDir, const std::string& file,
                     const std::vector<std::string>& defines, const std::string& device) {
    std::string cmd = fmt::format("POCL_CACHE_DIR='{}' '{}' --child-build {}", cacheDir,
                                  fs::read_symlink("/proc/self/exe").string(), file);
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

json runBuild(const Options& o) {
    json out;
    fmt::print("\n== build: BVH (binned SAH, {} bins, leaf <= {})\n", 16, o.leafSize);
    // wide s: what a scene load spends, the renderers' wide BVH built under both SAH settings
    // (the second on another thread), the sample rays traced through both, and the collapse.
    fmt::print("{:<11} {:>9} {:>9} {:>10} {:>10} {:>10}\n", "mesh", "triangles", "nodes", "ours s",
               "wide s", "embree s");
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
        for (int r = 0; r < (o.quick ? 1 : 3); ++r) {
            auto start = Clock::now();
            WideBvhChoice choice = buildWideBvhForRays(prims, sample);
            wideTimes.push_back(secondsSince(start));
        }
        double embreeS = 0.0;
        if (embreeAvailable()) {
            EmbreeBaseline e(m.mesh, o.threads);
            embreeS = e.buildSeconds();
        }
        fmt::print("{:<11} {:>9} {:>9} {:>10.3f} {:>10.3f} {:>10.3f}\n", m.name, prims.size(),
                   bvh.nodes.size(), median(times), median(wideTimes), embreeS);
        json row = {{"mesh", m.name},
                    {"triangles", prims.size()},
                    {"nodes", bvh.nodes.size()},
                    {"depth", bvh.depth},
                    {"seconds", median(times)},
                    {"threads", 1},
                    {"wide_seconds", median(wideTimes)}};
        if (embreeAvailable()) row["embree_seconds"] = embreeS;
        bvhRows.push_back(row);
    }
    out["bvh"] = bvhRows;

    struct Prog {
        std::string file, label;
        std::vector<std::string> defines;
    };
    std::vector<Prog> progs;
    for (const char* f : {"pt.cl", "bdpt.cl", "cbdpt.cl", "mlt.cl"}) {
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
    out["program"] = progRows;
    return out;
}

// ---- Render and scaling -----------------------------------------------------------------

struct RenderTiming {
    double perEstimate = 0.0; // median seconds
    double buildSeconds = 0.0;
    int pixels = 0;
};

// Median time of `estimates` estimates after one untimed warm-up estimate.
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

json runRender(const Options& o, ClRuntime& rt) {
    (void)rt;
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
            std::string cmd = fmt::format("'{}' --child-render {} {} {} {}",
                                          fs::read_symlink("/proc/self/exe").string(), sceneName,
                                          method, size, estimates);
            if (!o.device.empty()) cmd += " --device " + o.device;
            FILE* p = popen(cmd.c_str(), "r");
            std::string text;
            char buf[4096];
            while (p && std::fgets(buf, sizeof buf, p))
                text += buf;
            int status = p ? pclose(p) : -1;
            json row;
            try {
                row = json::parse(text);
            } catch (const std::exception&) {
                row = json();
            }
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

json runScaling(const Options& o, ClRuntime& rt) {
    json out;
    const int estimates = o.quick ? 2 : 5;
    const int size = o.quick ? 32 : 128;
    fmt::print("\n== scaling (PT, 8 vertices, Cornell box; median of {} estimates)\n", estimates);

    // Triangle count: a displaced sphere of n triangles floats in the Cornell box.
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
    IntegratorSettings pt;
    pt.name = "pt";
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
    out["triangles"] = tri;

    SceneDesc cornell = parseSceneFile(scenePath("cornell-box"));
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
    out["resolution"] = res;

    // Estimates (the thesis's appendix A.2 linearity check): total time of n estimates.
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
    out["estimates"] = est;
    out["estimates_fit"] = {
        {"slope_seconds", slope}, {"intercept_seconds", my - slope * mx}, {"r2", r2}};
    return out;
}

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

int run(int argc, char** argv) {
    Options o;
    CLI::App app{"cbdpt-bench: traversal, build, render and scaling benchmarks"};
    app.add_flag("--quick", o.quick, "small sizes and few repeats (CI)");
    app.add_option("--json", o.json, "write all results to this JSON file");
    app.add_option("--models", o.models, "folder with bunny.ply and dragon.ply");
    app.add_option("--sections", o.sections, "traverse build render scaling")->delimiter(',');
    app.add_option("--traversal", o.traversal,
                   "comma-separated: ordered | skip (binary BVH) | wide (4- or 8-wide, the "
                   "renderers' BVH); "
                   "both = ordered,skip")
        ->check([](const std::string& v) {
            if (v == "both") return std::string();
            for (const auto& s : splitCommas(v))
                if (s != "ordered" && s != "skip" && s != "wide")
                    return "unknown traversal '" + s + "' (ordered, skip, wide, both)";
            return std::string();
        });
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
    app.add_option("--meshes", o.meshes, "bunny, dragon, buddha, sphere-<n>[k|M]")->delimiter(',');
    app.add_option("--device", o.device, "OpenCL device P:D");
    app.add_option("--cases", o.cases, "traverse: primary, incoherent, shadow, incoh-any")
        ->delimiter(',')
        ->check([](const std::string& s) {
            for (const char* known : {"primary", "incoherent", "shadow", "incoh-any"})
                if (s == known) return std::string();
            return "unknown ray case '" + s + "' (primary, incoherent, shadow, incoh-any)";
        });
    app.add_option("--child-build", o.childBuild, "(internal)")->group("");
    app.add_option("--child-render", o.childRender, "(internal)")->group("");
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
    if (want("render")) result["render"] = runRender(o, rt), save();
    if (want("scaling")) result["scaling"] = runScaling(o, rt), save();
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
