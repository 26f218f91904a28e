#include "bvh/bvh_choice.h"

#include <algorithm>
#include <cmath>
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

cbk::SceneView viewOf(const Bvh& bvh, const BvhWide& wide) {
    cbk::SceneView view{};
    view.nodes = wide.nodes.data();
    view.packs = wide.packs.data();
    view.primitives = bvh.primitives.data();
    return view;
}

// Whether the ray enters the box before tEnd (a plain slab test: an estimate, not a query).
bool entersBefore(const cbk::BvhNodeWide& node, int k, const float o[3], const float inv[3],
                  float tEnd) {
    float t0 = 0.0f, t1 = tEnd;
    for (int a = 0; a < 3; ++a) {
        float n = (node.lo[a][k] - o[a]) * inv[a];
        float f = (node.hi[a][k] - o[a]) * inv[a];
        if (n > f) std::swap(n, f);
        t0 = std::fmax(t0, n); // fmax and fmin drop the NaN of a flat axis through a plane
        t1 = std::fmin(t1, f);
    }
    return t0 <= t1;
}

} // namespace

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
    return {{2, 4}, {4, 8}};
}

TraversalWork measureTraversalWork(const Bvh& bvh, const BvhWide& wide,
                                   const std::vector<cbk::Ray>& rays) {
    TraversalWork work;
    if (rays.empty()) return work;
    const cbk::SceneView view = viewOf(bvh, wide);
    std::vector<uint32_t> todo;
    double nodes = 0.0, packs = 0.0;
    for (const cbk::Ray& ray : rays) {
        cbk::Hit hit;
        cbk::sceneIntersect(&view, ray, CB_INFINITY, &hit);
        const float o[3] = {ray.o.x, ray.o.y, ray.o.z};
        const float inv[3] = {1.0f / ray.d.x, 1.0f / ray.d.y, 1.0f / ray.d.z};
        todo.assign(1, 0u);
        while (!todo.empty()) {
            const cbk::BvhNodeWide& node = wide.nodes[todo.back()];
            todo.pop_back();
            nodes += 1.0;
            for (int k = 0; k < CBW; ++k) {
                if (node.child[k] == CB_BVHW_NONE || !entersBefore(node, k, o, inv, hit.t))
                    continue;
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
                                       const std::vector<cbk::Ray>& cameraRays, int bounces) {
    const cbk::SceneView view = viewOf(bvh, wide);
    SampleSequence random{0x5eedu};
    std::vector<cbk::Ray> rays;
    rays.reserve(cameraRays.size() * size_t(bounces + 1));
    for (cbk::Ray ray : cameraRays) {
        for (int segment = 0; segment <= bounces; ++segment) {
            rays.push_back(ray);
            cbk::Hit hit;
            if (segment == bounces || !cbk::sceneIntersect(&view, ray, CB_INFINITY, &hit)) break;
            const cbk::Primitive& prim = bvh.primitives[size_t(hit.primitive)];
            const cbk::Vec3 p = cbk::vmadd(ray.o, ray.d, hit.t);
            const cbk::Vec3 p0 = cbk::vec3FromArray(prim.p0);
            cbk::Vec3 n = prim.kind == CB_PRIM_SPHERE
                              ? cbk::vsub(p, p0)
                              : cbk::vcross(cbk::vsub(cbk::vec3FromArray(prim.p1), p0),
                                            cbk::vsub(cbk::vec3FromArray(prim.p2), p0));
            if (cbk::vlength2(n) == 0.0f) break;
            n = cbk::vnormalize(n);
            if (cbk::vdot(n, ray.d) > 0.0f) n = cbk::vneg(n);
            const float u0 = random.next(), u1 = random.next();
            const cbk::Vec3 d =
                cbk::frameToWorld(cbk::frameFromNormal(n), cbk::sampleCosineHemisphere(u0, u1));
            // Off the surface by a small multiple of the point's own magnitude: enough that
            // the bounce does not find its own surface, and the estimate needs no more.
            const float scale = std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z), 1e-6f});
            ray.o = cbk::vmadd(p, n, 1e-4f * scale);
            ray.d = d;
        }
    }
    return rays;
}

WideBvhChoice buildWideBvhForRays(const std::vector<cbk::Primitive>& primitives,
                                  const std::vector<cbk::Ray>& cameraRays, int bins) {
    const std::vector<WideBvhSettings> candidates = wideBvhCandidates();
    auto build = [&](const WideBvhSettings& s) {
        WideBvhChoice c;
        c.bvh = buildBvh(primitives, {s.maxLeafSize, bins, s.sahBlock});
        c.wide = collapseBvhWide(c.bvh);
        c.settings = s;
        return c;
    };
    if (cameraRays.empty() || candidates.size() == 1) return build(candidates[0]);
    // The other candidates build on a second thread while the first is measured.
    std::vector<std::future<WideBvhChoice>> others;
    for (size_t i = 1; i < candidates.size(); ++i)
        others.push_back(std::async(std::launch::async, build, candidates[i]));
    WideBvhChoice best = build(candidates[0]);
    const std::vector<cbk::Ray> rays = sampleBounceRays(best.bvh, best.wide, cameraRays);
    std::vector<TraversalWork> work{measureTraversalWork(best.bvh, best.wide, rays)};
    int chosen = 0;
    for (size_t i = 1; i < candidates.size(); ++i) {
        WideBvhChoice c = others[i - 1].get();
        work.push_back(measureTraversalWork(c.bvh, c.wide, rays));
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
    const auto candidates = wideBvhCandidates();
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
