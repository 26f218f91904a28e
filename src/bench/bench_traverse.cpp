// cbdpt-bench, traverse section: our OpenCL traversals (the renderers' wide BVH, the binary
// BVH's for comparison) against Embree 3 on the same rays and threads, in Mrays/s.
#include "bench/bench.h"
#include "bench/embree_baseline.h"
#include "bench/kernels/bench_bvh_binary.h"
#include "bench/parallel_rays.h"

#include "bvh/bvh.h"
#include "bvh/bvh_choice.h"
#include "bvh/bvh_wide.h"
#include "cl/cl_runtime.h"
#include "integrators/scene_buffers.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>

using cbk::Ray;

namespace cb::bench {
namespace {

// Rays per work-item of the ray-packet traversals (cb_bvh_ray_packet.h): 8 for `ray8`, 16 for
// `ray16`, 0 for the others.
int packetRaysOf(const std::string& variant) {
    return variant == "ray8" ? 8 : variant == "ray16" ? 16 : 0;
}

class ClTraversal {
  public:
    // variant: ordered | skip (binary BVH) | wide (cb_bvh_wide.h, what the renderers use) |
    // packet (the wide BVH, work-group-wide traversal of bench_bvh_packet.h, for every ray set;
    // its kernels require work-groups of 64, whatever localSize says) | ray8, ray16 (the wide
    // BVH, packets of 2x4 or 4x4 rays per work-item, cb_bvh_ray_packet.h). prefetch (the wide
    // BVH's traversals): auto (the renderers' choice, treePrefetchPays), on or off.
    ClTraversal(ClRuntime& rt, const Bvh& bvh, const std::string& variant, int localSize,
                const std::string& prefetch)
        : rt_(rt), localSize_(variant == "packet" ? kPacketSize : localSize) {
        std::vector<std::string> defines = {"CB_CHANNELS=3", "CB_FEATURES=0x101u"};
        if (variant == "skip") defines.push_back("CB_BVH_SKIP_ORDER=1");
        packetRays_ = packetRaysOf(variant);
        const bool packet = variant == "packet";
        const bool wide = variant == "wide" || packet || packetRays_ > 0;
        if (wide) {
            wide_ = collapseBvhWide(bvh);
            // "on" as CBDPT_PREFETCH=1: forced, but on CPU devices only.
            const bool cpu = rt.info().cpu;
            prefetch_ = prefetch == "auto"
                            ? treePrefetchPays(wide_.bytes(), rt.info().globalCacheBytes, cpu)
                            : cpu && prefetch == "on";
            defines.push_back(fmt::format("CB_TREE_PREFETCH={}", prefetch_ ? 1 : 0));
        }
        if (packetRays_ > 0) defines.push_back(fmt::format("CB_RAY_PACKET={}", packetRays_));
        program_ = rt.buildProgram("bench_traverse.cl", defines);
        if (packetRays_ > 0) {
            closest_ = cl::Kernel(program_, "benchClosestWideRays");
            closestCoherent_ = closest_;
            occluded_ = cl::Kernel(program_, "benchOccludedWideRays");
        } else if (packet) {
            closest_ = cl::Kernel(program_, "benchClosestWidePacket");
            closestCoherent_ = closest_;
            occluded_ = cl::Kernel(program_, "benchOccludedWidePacket");
        } else {
            closest_ = cl::Kernel(program_, wide ? "benchClosestWide" : "benchClosest");
            occluded_ = cl::Kernel(program_, wide ? "benchOccludedWide" : "benchOccluded");
            if (wide) closestCoherent_ = cl::Kernel(program_, "benchClosestWideCoherent");
        }
        if (wide) {
            nodes_ = uploadArray(rt, "bench wide BVH nodes", wide_.nodes);
            packs_ = uploadArray(rt, "bench BVH leaf triangles", wide_.packs);
        } else {
            nodes_ = uploadArray(rt, "bench binary BVH nodes", bvh.nodes);
        }
        prims_ = uploadArray(rt, "bench primitives", bvh.primitives);
    }

    bool prefetches() const { return prefetch_; }

    // Returns the median seconds of `repeats` launches; hits from the last one.
    // tMax[i] <= 0: an inactive ray, reported as a miss.
    double closest(const std::vector<Ray>& rays, const std::vector<float>& tMax, bool coherent,
                   int repeats, std::vector<cbk::Hit>& hits) {
        auto& ctx = rt_.context();
        cl::Buffer rayBuf(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, rays.size() * sizeof(Ray),
                          const_cast<Ray*>(rays.data()));
        cl::Buffer tBuf(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, tMax.size() * sizeof(float),
                        const_cast<float*>(tMax.data()));
        cl::Buffer hitBuf(ctx, CL_MEM_WRITE_ONLY, rays.size() * sizeof(cbk::Hit));
        // Coherent rays go through the renderers' coherent traversal (wide BVH only).
        cl::Kernel& kernel = coherent && !wide_.nodes.empty() ? closestCoherent_ : closest_;
        int arg = setBvhArgs(kernel);
        kernel.setArg(arg++, rayBuf);
        kernel.setArg(arg++, tBuf);
        cl::Buffer packetBuf;
        const size_t items = setCountArgs(kernel, arg, rays.size(), packetBuf);
        kernel.setArg(arg, hitBuf);
        double t = launch(kernel, items, repeats);
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
        cl::Buffer packetBuf;
        const size_t items = setCountArgs(occluded_, arg, rays.size(), packetBuf);
        occluded_.setArg(arg, outBuf);
        double t = launch(occluded_, items, repeats);
        out.resize(rays.size());
        rt_.queue().enqueueReadBuffer(outBuf, CL_TRUE, 0, out.size() * sizeof(int), out.data());
        return t;
    }

  private:
    static constexpr int kPacketSize = 64; // CB_PACKET_SIZE of bench_bvh_packet.h

    // The BVH arguments: nodes, [packs,] primitives. Returns the next argument index.
    int setBvhArgs(cl::Kernel& k) {
        int arg = 0;
        k.setArg(arg++, nodes_);
        if (!wide_.nodes.empty()) k.setArg(arg++, packs_);
        k.setArg(arg++, prims_);
        return arg;
    }

    // The ray count, or for ray8 and ray16 the packets' ray indices (2x4 or 4x4 tiles of the 8x8
    // tiles, the rays after the last whole tile in order, -1 padding the last packet) and their
    // count. Returns the work-items to launch; `arg` is advanced.
    size_t setCountArgs(cl::Kernel& k, int& arg, size_t rayCount, cl::Buffer& packetBuf) {
        if (packetRays_ == 0) {
            k.setArg(arg++, cl_uint(rayCount));
            return rayCount;
        }
        const size_t n = size_t(packetRays_);
        std::vector<int> packets = tilePackets(rayCount, packetRays_);
        for (size_t i = rayCount / 64 * 64; i < rayCount; ++i)
            packets.push_back(int(i));
        while (packets.size() % n != 0)
            packets.push_back(-1);
        packetBuf = cl::Buffer(rt_.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                               packets.size() * sizeof(int), packets.data());
        k.setArg(arg++, packetBuf);
        k.setArg(arg++, cl_uint(packets.size() / n));
        return packets.size() / n;
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
    int packetRays_ = 0; // rays per work-item: 8 or 16 for ray8 and ray16, else 0
    bool prefetch_ = false;
    cl::Program program_;
    cl::Kernel closest_, closestCoherent_, occluded_;
    cl::Buffer nodes_, packs_, prims_;
    BvhWide wide_; // empty for the binary BVH

  public:
    double lastCpu = 0.0; // median CPU seconds of the last closest() or occluded()
};

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

// Agreement of closest hits: same hit/miss and primitive, or a tie (both primitives at the
// same distance up to 1e-5 relative: shared edges and vertices).
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

// Median wall and CPU seconds of `repeats` calls after one untimed call.
template <typename Call> void timeEmbree(int repeats, Call call, double& wall, double& cpu) {
    std::vector<double> times, cpuTimes;
    for (int r = 0; r < repeats + 1; ++r) {
        auto start = Clock::now();
        double cpuStart = processCpuSeconds();
        call();
        if (r > 0) times.push_back(secondsSince(start));
        if (r > 0) cpuTimes.push_back(processCpuSeconds() - cpuStart);
    }
    wall = median(times);
    cpu = median(cpuTimes);
}

// One ray set of one mesh and traversal: ours, Embree's (when built in) and their agreement.
struct CaseResult {
    double ours = 0.0, theirs = 0.0, theirsCpu = 0.0, agree = 1.0;
    size_t n = 0;
    long hitCount = 0;
};

CaseResult closestCase(ClTraversal& cl, const EmbreeBaseline* embree, const Bvh& bvh,
                       const std::vector<Ray>& rays, const std::vector<float>& tMax, bool coherent,
                       int repeats, bool compare, std::vector<cbk::Hit>& hits) {
    CaseResult r;
    r.ours = cl.closest(rays, tMax, coherent, repeats, hits);
    r.n = rays.size();
    for (const auto& h : hits)
        r.hitCount += h.primitive >= 0;
    if (compare && embree) {
        std::vector<BaselineHit> ref;
        timeEmbree(
            repeats, [&] { embree->intersect(rays, ref, &tMax); }, r.theirs, r.theirsCpu);
        r.agree = closestAgreement(hits, bvh, ref);
    }
    return r;
}

// Embree's packet interface (rtcIntersect8/16, rtcOccluded8/16) on the rays of a case whose
// ours were timed in `r`: `r` with Embree's times and agreement replaced.
CaseResult packetCase(const CaseResult& r, const EmbreeBaseline& embree, const Bvh& bvh,
                      const std::vector<Ray>& rays, const std::vector<float>& tMax,
                      const std::vector<int>& packets, int width, bool anyHit,
                      const std::vector<cbk::Hit>& hits, const std::vector<int>& occ, int repeats) {
    CaseResult p = r;
    if (anyHit) {
        std::vector<int> ref;
        timeEmbree(
            repeats, [&] { embree.occludedPackets(rays, tMax, packets, width, ref); }, p.theirs,
            p.theirsCpu);
        size_t same = 0;
        for (size_t i = 0; i < r.n; ++i)
            same += occ[i] == ref[i];
        p.agree = double(same) / double(r.n);
    } else {
        std::vector<BaselineHit> ref;
        timeEmbree(
            repeats, [&] { embree.intersectPackets(rays, &tMax, packets, width, ref); }, p.theirs,
            p.theirsCpu);
        p.agree = closestAgreement(hits, bvh, ref);
    }
    return p;
}

CaseResult anyHitCase(ClTraversal& cl, const EmbreeBaseline* embree, const std::vector<Ray>& rays,
                      const std::vector<float>& tMax, int repeats, std::vector<int>& occ) {
    CaseResult r;
    r.ours = cl.occluded(rays, tMax, repeats, occ);
    r.n = rays.size();
    for (int v : occ)
        r.hitCount += v;
    if (embree) {
        std::vector<int> ref;
        timeEmbree(
            repeats, [&] { embree->occluded(rays, tMax, ref); }, r.theirs, r.theirsCpu);
        size_t same = 0;
        for (size_t i = 0; i < r.n; ++i)
            same += occ[i] == ref[i];
        r.agree = double(same) / double(r.n);
    }
    return r;
}

// What one traversal of one mesh is run on.
struct TraverseInput {
    const BenchMesh& mesh;
    size_t triangles;
    const std::string& variant;
    const std::string& settings;
    const Bvh& bvh;
    const EmbreeBaseline* embree;
};

// Prints the case's table line(s) and returns its JSON row.
json caseRow(const TraverseInput& in, const std::string& name, bool anyHit, const CaseResult& r,
             double cpuOurs, double host, const char* embreeCall = nullptr) {
    double oursM = double(r.n) / r.ours * 1e-6;
    double theirsM = r.theirs > 0 ? double(r.n) / r.theirs * 1e-6 : 0.0;
    double ratio = theirsM > 0 ? oursM / theirsM : 0.0;
    double cpuRatio = r.theirsCpu > 0 && cpuOurs > 0 ? r.theirsCpu / cpuOurs : 0.0;
    fmt::print("{:<11} {:>9} {:<8} {:<10} {:>9.2f} {:>9.2f} {:>7.3f} {:>9.3f} "
               "{:>8.4f}%\n",
               in.mesh.name, in.triangles, in.variant, name, oursM, theirsM, ratio, cpuRatio,
               100.0 * r.agree);
    std::fflush(stdout);
    json row = {{"mesh", in.mesh.name},
                {"triangles", in.triangles},
                {"order", in.variant},
                {"bvh_settings", in.settings},
                {"rays", name},
                {"query", anyHit ? "any-hit" : "closest-hit"},
                {"count", r.n},
                {"hit_fraction", double(r.hitCount) / double(r.n)},
                {"ours_mrays_per_s", oursM},
                {"ours_seconds", r.ours}};
    if (host > 0.0) {
        row["host_mrays_per_s"] = double(r.n) / host * 1e-6;
        fmt::print("{:<11} {:>9} {:<8} {:<10} {:>9.2f}  (same code, g++ on the host)\n", "", "",
                   "host", name, double(r.n) / host * 1e-6);
    }
    if (in.embree) {
        row["embree_mrays_per_s"] = theirsM;
        row["embree_seconds"] = r.theirs;
        row["ratio"] = ratio;
        row["cpu_ratio"] = cpuRatio;
        row["agreement"] = r.agree;
        row["embree_call"] = embreeCall ? embreeCall : anyHit ? "rtcOccluded1" : "rtcIntersect1";
    }
    return row;
}

// The BVH a traversal variant runs on and a description of its settings.
Bvh variantBvh(const Options& o, const std::string& variant,
               const std::vector<cbk::Primitive>& prims, const std::vector<Ray>& primary,
               std::string& settings) {
    if ((variant == "wide" || variant == "packet" || packetRaysOf(variant) > 0) &&
        o.sahBlock <= 0) {
        // As the renderers build it (DeviceScene): the candidate cheapest for a sample of the
        // camera rays and their bounces.
        WideBvhChoice choice = buildWideBvhForRays(prims, cameraSample(primary));
        settings = describeChoice(choice);
        return std::move(choice.bvh);
    }
    const int block = o.sahBlock > 0 ? o.sahBlock : 1;
    settings = fmt::format("SAH block {}, leaves <= {}", block, o.leafSize);
    return buildBvh(prims, {o.leafSize, 16, block});
}

// Every wanted ray set of one mesh through one traversal variant, rows appended to `out`.
void traverseVariant(const Options& o, ClRuntime& rt, const BenchMesh& m,
                     const std::vector<cbk::Primitive>& prims, const EmbreeBaseline* embree,
                     const std::string& variant, const std::vector<Ray>& primary,
                     const std::vector<Ray>& incoherent, json& out) {
    const int repeats = o.repeats > 0 ? o.repeats : (o.quick ? 2 : 5);
    std::string settings;
    const Bvh bvh = variantBvh(o, variant, prims, primary, settings);
    ClTraversal cl(rt, bvh, variant, o.localSize, o.prefetch);
    if (cl.prefetches()) settings += "; prefetch";
    fmt::print("{:<11} {:>9} {:<8} BVH: {}\n", m.name, prims.size(), variant, settings);
    const TraverseInput in{m, prims.size(), variant, settings, bvh, embree};
    auto wanted = [&](const char* name) {
        return std::find(o.cases.begin(), o.cases.end(), name) != o.cases.end();
    };
    std::vector<Ray> shadow, cohShadow, bounce1, bounce2;
    std::vector<float> shadowT, cohShadowT, bounce1T, bounce2T;
    const std::vector<float> infT(incoherent.size(), CB_INFINITY);
    const std::vector<float> primaryT(primary.size(), CB_INFINITY);
    const std::vector<int> packets8 = tilePackets(primary.size(), 8);
    const std::vector<int> packets16 = tilePackets(primary.size(), 16);
    // The coherent sets (pixel order, one ray per pixel) also against Embree's packets of 2x4
    // and 4x4 pixels, ours timed once: rows "<case>/8" and "<case>/16".
    auto packetRows = [&](const std::string& name, const CaseResult& r, double cpuOurs,
                          const std::vector<Ray>& rays, const std::vector<float>& tMax, bool anyHit,
                          const std::vector<cbk::Hit>& hits, const std::vector<int>& occ) {
        if (!embree) return;
        for (int width : {8, 16}) {
            CaseResult p =
                packetCase(r, *embree, bvh, rays, tMax, width == 8 ? packets8 : packets16, width,
                           anyHit, hits, occ, repeats);
            const char* call = anyHit ? (width == 8 ? "rtcOccluded8" : "rtcOccluded16")
                                      : (width == 8 ? "rtcIntersect8" : "rtcIntersect16");
            out.push_back(
                caseRow(in, name + "/" + std::to_string(width), anyHit, p, cpuOurs, 0.0, call));
        }
    };
    // Shadow rays and bounces need the primary hits first.
    if (wanted("primary") || wanted("shadow") || wanted("coh-shadow") || wanted("bounce1") ||
        wanted("bounce2")) {
        std::vector<cbk::Hit> hits;
        CaseResult r =
            closestCase(cl, embree, bvh, primary, primaryT, true, repeats, wanted("primary"), hits);
        const double cpuOurs = cl.lastCpu;
        const Box3 box = meshBounds(m.mesh);
        shadowRays(box, primary, hits, 11u, shadow, shadowT);
        coherentShadowRays(box, primary, hits, cohShadow, cohShadowT);
        // One estimate's shared BSDF samples at the first and second bounces.
        coherentBounce(box, bvh.primitives, primary, nullptr, hits, 0.31f, 0.62f, bounce1,
                       bounce1T);
        if (wanted("primary")) {
            double host = o.host && variant == "ordered"
                              ? hostSeconds(bvh, primary, nullptr, o.threads, repeats)
                              : 0.0;
            out.push_back(caseRow(in, "primary", false, r, cpuOurs, host));
            packetRows("primary", r, cpuOurs, primary, primaryT, false, hits, {});
        }
    }
    if (wanted("incoherent")) {
        std::vector<cbk::Hit> hits;
        CaseResult r = closestCase(cl, embree, bvh, incoherent, infT, false, repeats, true, hits);
        double host = o.host && variant == "ordered"
                          ? hostSeconds(bvh, incoherent, nullptr, o.threads, repeats)
                          : 0.0;
        out.push_back(caseRow(in, "incoherent", false, r, cl.lastCpu, host));
    }
    // The bounces of one estimate: ours with the coherent traversal, and (row "<case>/inc")
    // with the incoherent one against rtcIntersect1.
    for (int bounce = 1; bounce <= 2; ++bounce) {
        const std::string name = "bounce" + std::to_string(bounce);
        if (!wanted(name.c_str()) && !(bounce == 1 && wanted("bounce2"))) continue;
        const std::vector<Ray>& rays = bounce == 1 ? bounce1 : bounce2;
        const std::vector<float>& tMax = bounce == 1 ? bounce1T : bounce2T;
        std::vector<cbk::Hit> hits;
        CaseResult r =
            closestCase(cl, embree, bvh, rays, tMax, true, repeats, wanted(name.c_str()), hits);
        const double cpuOurs = cl.lastCpu;
        if (bounce == 1)
            coherentBounce(meshBounds(m.mesh), bvh.primitives, bounce1, &bounce1T, hits, 0.77f,
                           0.18f, bounce2, bounce2T);
        if (!wanted(name.c_str())) continue;
        out.push_back(caseRow(in, name, false, r, cpuOurs, 0.0));
        out.back()["active_fraction"] =
            double(std::count_if(tMax.begin(), tMax.end(), [](float t) { return t > 0.0f; })) /
            double(tMax.size());
        packetRows(name, r, cpuOurs, rays, tMax, false, hits, {});
        std::vector<cbk::Hit> incHits;
        CaseResult inc = closestCase(cl, embree, bvh, rays, tMax, false, repeats, true, incHits);
        out.push_back(caseRow(in, name + "/inc", false, inc, cl.lastCpu, 0.0));
    }
    struct AnyHit {
        const char* name;
        const std::vector<Ray>& rays;
        const std::vector<float>& tMax;
        bool packets;
    };
    for (const AnyHit& c : {AnyHit{"shadow", shadow, shadowT, false},
                            AnyHit{"coh-shadow", cohShadow, cohShadowT, true},
                            AnyHit{"incoh-any", incoherent, infT, false}}) {
        if (!wanted(c.name)) continue;
        std::vector<int> occ;
        CaseResult r = anyHitCase(cl, embree, c.rays, c.tMax, repeats, occ);
        const double cpuOurs = cl.lastCpu;
        double host = o.host && variant == "ordered"
                          ? hostSeconds(bvh, c.rays, &c.tMax, o.threads, repeats)
                          : 0.0;
        out.push_back(caseRow(in, c.name, true, r, cpuOurs, host));
        if (c.packets) packetRows(c.name, r, cpuOurs, c.rays, c.tMax, true, {}, occ);
    }
}

} // namespace

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
        for (const auto& variant : variants)
            traverseVariant(o, rt, m, prims, embree.get(), variant, primary, incoherent, out);
    }
    return out;
}

} // namespace cb::bench
