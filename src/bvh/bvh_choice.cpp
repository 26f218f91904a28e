#include "bvh/bvh_choice.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <stdexcept>

#include <fmt/format.h>

#include "cb_sampling.h"

namespace cb {
namespace {

// splitmix64: a fixed, portable sequence, so the choice is the same on every machine.
struct SampleSequence {
    uint64_t state;
    float next() {
        uint64_t z = (state += 0x9e3779b97f4a7c15ull);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
        z ^= z >> 31;
        return float(z >> 40) * 0x1p-24f; // [0, 1)
    }
};

cbk::SceneView viewOf(const Bvh& bvh, const BvhWide& wide, const cbk::CurveSegment* curves) {
    cbk::SceneView view{};
    view.curves = curves;
    view.nodes = wide.nodes.data();
    view.packs = wide.packs.data();
    view.primitives = bvh.primitives.data();
    return view;
}

} // namespace

std::vector<WideBvhSettings> defaultWideBvhCandidates() {
    return {{2, 4}, {4, 8}};
}

std::vector<WideBvhSettings> wideBvhCandidates() {
    // CBDPT_BVH_SETTINGS=BLOCK,LEAF builds only that one: what docs/performance.md compares.
    if (const char* forced = std::getenv("CBDPT_BVH_SETTINGS"); forced && *forced) {
        WideBvhSettings s;
        char tail = 0;
        if (std::sscanf(forced, "%d,%d%c", &s.sahBlock, &s.maxLeafSize, &tail) != 2 ||
            s.sahBlock < 1 || s.maxLeafSize < 1 || s.maxLeafSize > 255 * CB_PACK_LANES)
            throw std::invalid_argument(
                fmt::format("CBDPT_BVH_SETTINGS='{}': expected SAH_BLOCK,MAX_LEAF_SIZE, two "
                            "positive integers such as 4,8 (unset it to let the scene choose)",
                            forced));
        return {s};
    }
    return defaultWideBvhCandidates();
}

TraversalWork measureTraversalWork(const Bvh& bvh, const BvhWide& wide,
                                   const std::vector<cbk::Ray>& rays,
                                   const cbk::CurveSegment* curves) {
    TraversalWork work;
    if (rays.empty()) return work;
    const cbk::SceneView view = viewOf(bvh, wide, curves);
    std::vector<uint32_t> todo;
    double nodes = 0.0, packs = 0.0;
    for (const cbk::Ray& ray : rays) {
        cbk::Hit hit;
        cbk::sceneIntersect(&view, ray, CB_INFINITY, &hit);
        // The traversal's own box test (conservative), with the hit as the closest distance.
        const cbk::BvhWideSlabs slabs = cbk::bvhWideSlabsOf(ray.o, ray.d);
        todo.assign(1, 0u);
        while (!todo.empty()) {
            const cbk::BvhNodeWide& node = wide.nodes[todo.back()];
            todo.pop_back();
            nodes += 1.0;
            cbk::BvhWideReal tn, far;
            cbk::bvhWideBoxes(&node, slabs.invNear, slabs.addNear, slabs.invFar, slabs.addFar,
                              hit.t, &tn, &far);
            for (int k = 0; k < CB_BVH_WIDE_LANES; ++k) {
                if (!cbk::bvhWideLaneHit(&node, tn, far, k)) continue;
                const uint32_t count = cbk::bvhWideCount(&node, k);
                if (count == 0u)
                    todo.push_back(cbk::bvhWideInteriorChild(&node, k));
                else
                    packs += double(count);
            }
        }
    }
    work.nodeVisits = nodes / double(rays.size());
    work.packTests = packs / double(rays.size());
    return work;
}

std::vector<cbk::Ray> sampleBounceRays(const Bvh& bvh, const BvhWide& wide,
                                       const std::vector<cbk::Ray>& cameraRays, int bounces,
                                       const cbk::CurveSegment* curves) {
    const cbk::SceneView view = viewOf(bvh, wide, curves);
    SampleSequence random{0x5eedu};
    std::vector<cbk::Ray> rays;
    rays.reserve(cameraRays.size() * size_t(bounces + 1));
    for (cbk::Ray ray : cameraRays) {
        for (int segment = 0; segment <= bounces; ++segment) {
            rays.push_back(ray);
            cbk::Hit hit;
            if (segment == bounces || !cbk::sceneIntersect(&view, ray, CB_INFINITY, &hit)) break;
            // The renderers' hit point, geometric normal and ray spawning.
            const cbk::SurfacePoint sp = cbk::surfacePointFromHit(&view, ray, hit);
            const cbk::Vec3 n = cbk::vdot(sp.ng, ray.d) > 0.0f ? cbk::vneg(sp.ng) : sp.ng;
            const float u0 = random.next(), u1 = random.next();
            const cbk::Vec3 d =
                cbk::frameToWorld(cbk::frameFromNormal(n), cbk::sampleCosineHemisphere(u0, u1));
            ray = cbk::spawnRay(sp, d);
        }
    }
    return rays;
}

WideBvhChoice buildWideBvhForRays(const std::vector<cbk::Primitive>& primitives,
                                  const std::vector<cbk::Ray>& cameraRays,
                                  const std::vector<WideBvhSettings>& candidates,
                                  const cbk::CurveSegment* curves) {
    if (candidates.empty())
        throw std::invalid_argument("buildWideBvhForRays: no candidate BVH settings");
    auto build = [&](const WideBvhSettings& s) {
        WideBvhChoice c;
        c.bvh = buildBvh(primitives, {s.maxLeafSize, 16, s.sahBlock});
        c.wide = collapseBvhWide(c.bvh);
        c.settings = s;
        c.candidates = candidates;
        return c;
    };
    if (cameraRays.empty() || candidates.size() == 1) return build(candidates[0]);
    // The other candidates build on a second thread while the first is measured.
    std::vector<std::future<WideBvhChoice>> others;
    for (size_t i = 1; i < candidates.size(); ++i)
        others.push_back(std::async(std::launch::async, build, candidates[i]));
    WideBvhChoice best = build(candidates[0]);
    const std::vector<cbk::Ray> rays = sampleBounceRays(best.bvh, best.wide, cameraRays, 3, curves);
    std::vector<TraversalWork> work{measureTraversalWork(best.bvh, best.wide, rays, curves)};
    int chosen = 0;
    for (size_t i = 1; i < candidates.size(); ++i) {
        WideBvhChoice c = others[i - 1].get();
        work.push_back(measureTraversalWork(c.bvh, c.wide, rays, curves));
        if (work.back().cost() < work[size_t(chosen)].cost()) {
            best = std::move(c);
            chosen = int(i);
        }
    }
    best.work = std::move(work);
    best.chosen = chosen;
    return best;
}

std::string describeChoice(const WideBvhChoice& choice) {
    const auto& candidates = choice.candidates;
    auto name = [](const WideBvhSettings& s) {
        return fmt::format("SAH block {}, leaves <= {}", s.sahBlock, s.maxLeafSize);
    };
    auto costOf = [&](size_t i) {
        const TraversalWork& w = choice.work[i];
        return fmt::format("{:.2f} = {:.2f} nodes + {} x {:.2f} packs", w.cost(), w.nodeVisits,
                           TraversalWork::kPackWeight, w.packTests);
    };
    std::string text = name(choice.settings);
    if (choice.work.empty()) return text;
    text += fmt::format(" (per sample ray {}", costOf(size_t(choice.chosen)));
    for (size_t i = 0; i < choice.work.size(); ++i)
        if (int(i) != choice.chosen)
            text += fmt::format("; {}: {}", name(candidates[i]), costOf(i));
    return text + ")";
}

} // namespace cb
