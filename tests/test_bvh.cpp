// BVH construction and stackless traversal: compared against brute force over every primitive,
// on the Stanford meshes, on the host and in an OpenCL kernel built from the same header.
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench/kernels/bench_bvh_binary.h"
#include "bvh/bvh.h"
#include "bvh/bvh_choice.h"
#include "bvh/bvh_wide.h"
#include "cl/cl_runtime.h"
#include "cl/embedded_kernels.h"
#include "scene/ply.h"
#include "source_tree.h"
#include "stanford_models.h"

using cbk::Hit;
using cbk::Primitive;
using cbk::Ray;
using cbk::SceneView;
using cbk::Vec3;

namespace {

struct Mesh {
    std::vector<Vec3> positions;
    std::vector<int> indices;
};

// Callers first check cbtest::stanfordModelsOrSkip().
Mesh loadModel(const std::string& name) {
    cb::PlyMesh ply = cb::readPly((cbtest::stanfordModelDir() / name).string());
    Mesh mesh;
    for (const auto& p : ply.positions)
        mesh.positions.push_back(cbk::vec3(p[0], p[1], p[2]));
    for (const auto& t : ply.triangles)
        for (unsigned i : t)
            mesh.indices.push_back(int(i));
    return mesh;
}

Primitive triangle(Vec3 a, Vec3 b, Vec3 c, int material = 0) {
    Primitive p{};
    p.kind = CB_PRIM_TRIANGLE;
    std::memcpy(p.p0, &a, sizeof p.p0);
    std::memcpy(p.p1, &b, sizeof p.p1);
    std::memcpy(p.p2, &c, sizeof p.p2);
    p.material = material;
    p.light = -1;
    return p;
}

Primitive sphere(Vec3 c, float r) {
    Primitive p{};
    p.kind = CB_PRIM_SPHERE;
    std::memcpy(p.p0, &c, sizeof p.p0);
    p.p1[0] = r;
    p.p1[1] = 1.0f;
    p.light = -1;
    return p;
}

std::vector<Primitive> meshPrimitives(const Mesh& mesh) {
    std::vector<Primitive> prims;
    for (size_t f = 0; f < mesh.indices.size(); f += 3)
        prims.push_back(triangle(mesh.positions[mesh.indices[f]],
                                 mesh.positions[mesh.indices[f + 1]],
                                 mesh.positions[mesh.indices[f + 2]], int(f / 3)));
    return prims;
}

// The renderers' view: the wide nodes collapsed from `bvh` (both must outlive it).
SceneView viewOf(const cb::Bvh& bvh, const cb::BvhWide& wide) {
    SceneView s{};
    s.nodes = wide.nodes.data();
    s.packs = wide.packs.data();
    s.primitives = bvh.primitives.data();
    return s;
}

struct Bounds {
    Vec3 lo, hi;
};

Bounds boundsOf(const std::vector<Primitive>& prims) {
    Bounds b{cbk::vec3(INFINITY, INFINITY, INFINITY), cbk::vec3(-INFINITY, -INFINITY, -INFINITY)};
    for (const auto& p : prims) {
        float lo[3], hi[3];
        cb::primitiveBounds(p, lo, hi);
        b.lo = cbk::vmin(b.lo, cbk::vec3FromArray(lo));
        b.hi = cbk::vmax(b.hi, cbk::vec3FromArray(hi));
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

Vec3 pointIn(const Bounds& b, std::mt19937& rng) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    return cbk::vec3(b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                     b.lo.z + u(rng) * (b.hi.z - b.lo.z));
}

// Half the rays come from a sphere around the mesh and aim at a random point of its box, half
// start inside the box in uniform directions.
std::vector<Ray> makeRays(const Bounds& b, int count, unsigned seed) {
    std::mt19937 rng(seed);
    Vec3 centre = cbk::vscale(cbk::vadd(b.lo, b.hi), 0.5f);
    float radius = cbk::vlength(cbk::vsub(b.hi, b.lo));
    std::vector<Ray> rays(count);
    for (int i = 0; i < count; ++i) {
        if (i % 2 == 0) {
            rays[i].o = cbk::vmadd(centre, uniformDirection(rng), radius);
            rays[i].d = cbk::vnormalize(cbk::vsub(pointIn(b, rng), rays[i].o));
        } else {
            rays[i].o = pointIn(b, rng);
            rays[i].d = uniformDirection(rng);
        }
    }
    return rays;
}

// Camera rays in pixel order (what sceneIntersectCoherent is for): from a point in front of
// the box through a side x side grid spanning its middle cross-section.
std::vector<Ray> cameraRays(const Bounds& b, int side) {
    Vec3 centre = cbk::vscale(cbk::vadd(b.lo, b.hi), 0.5f);
    Vec3 eye = cbk::vadd(centre, cbk::vec3(0.0f, 0.0f, 2.0f * (b.hi.z - b.lo.z)));
    std::vector<Ray> rays;
    for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x) {
            float fx = (float(x) + 0.5f) / float(side), fy = (float(y) + 0.5f) / float(side);
            Vec3 target = cbk::vec3(b.lo.x + fx * (b.hi.x - b.lo.x),
                                    b.hi.y - fy * (b.hi.y - b.lo.y), centre.z);
            rays.push_back(Ray{eye, cbk::vnormalize(cbk::vsub(target, eye))});
        }
    return rays;
}

// Brute force over every primitive. Candidates are pre-culled with a bounding sphere per
// primitive (evaluated in double with a 1% margin, so it never rejects a primitive the exact
// test could hit); every remaining primitive goes through intersectPrimitive in index order.
struct Brute {
    const std::vector<Primitive>* prims;
    std::vector<std::array<double, 4>> spheres; // centre, radius

    explicit Brute(const std::vector<Primitive>& p) : prims(&p) {
        for (const auto& prim : p) {
            float lo[3], hi[3];
            cb::primitiveBounds(prim, lo, hi);
            double c[3], r2 = 0.0;
            for (int a = 0; a < 3; ++a) {
                c[a] = 0.5 * (double(lo[a]) + hi[a]);
                r2 += 0.25 * (double(hi[a]) - lo[a]) * (double(hi[a]) - lo[a]);
            }
            spheres.push_back({c[0], c[1], c[2], 1.01 * std::sqrt(r2)});
        }
    }

    bool mayHit(size_t k, const Ray& ray) const {
        const auto& s = spheres[k];
        double d[3] = {ray.d.x, ray.d.y, ray.d.z};
        double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        double f[3] = {s[0] - ray.o.x, s[1] - ray.o.y, s[2] - ray.o.z};
        double proj = (f[0] * d[0] + f[1] * d[1] + f[2] * d[2]) / len;
        double f2 = f[0] * f[0] + f[1] * f[1] + f[2] * f[2];
        if (proj < -s[3]) return false; // entirely behind the origin
        return f2 - proj * proj <= s[3] * s[3] * 1.0201 + 1e-12 * f2;
    }

    bool intersect(Ray ray, float tMax, Hit* hit) const {
        bool found = false;
        for (size_t k = 0; k < prims->size(); ++k) {
            Hit h;
            if (mayHit(k, ray) && cbk::intersectPrimitive(&(*prims)[k], ray, tMax, &h)) {
                h.primitive = int(k);
                *hit = h;
                tMax = h.t;
                found = true;
            }
        }
        return found;
    }

    bool occluded(Ray ray, float tMax) const {
        for (size_t k = 0; k < prims->size(); ++k) {
            Hit h;
            if (mayHit(k, ray) && cbk::intersectPrimitive(&(*prims)[k], ray, tMax, &h)) return true;
        }
        return false;
    }
};

struct Mismatches {
    int closest = 0;  // hit/miss, primitive or t differ
    int occluded = 0; // any-hit answer differs
    int hits = 0;     // rays that hit at all (to show the test exercises something)
    int ties = 0;     // different primitives at the same t (shared edges/vertices)
};

// Runs BVH and brute force for rays [begin, end); for occlusion, tMax is a random fraction
// (0..2) of the closest hit distance so both answers occur.
// With `wide`, the wide BVH the renderers trace (cb_bvh_wide.h) over the same primitives is
// compared.
void compareRange(const cb::Bvh& bvh, const Brute& brute, const std::vector<Ray>& rays,
                  size_t begin, size_t end, Mismatches* out, const cb::BvhWide* wide = nullptr) {
    std::mt19937 rng(unsigned(begin) * 7919u + 1u);
    std::uniform_real_distribution<float> u(0.0f, 2.0f);
    for (size_t i = begin; i < end; ++i) {
        Hit a{}, b{};
        bool ha = wide ? cbk::bvhWideTraverse(wide->nodes.data(), wide->packs.data(),
                                              bvh.primitives.data(), rays[i], CB_INFINITY, true,
                                              false, &a, nullptr)
                       : cbk::bvhIntersect(bvh.nodes.data(), bvh.primitives.data(), rays[i],
                                           CB_INFINITY, &a);
        bool hb = brute.intersect(rays[i], CB_INFINITY, &b);
        if (ha != hb) {
            ++out->closest;
        } else if (ha) {
            ++out->hits;
            if (a.primitive != b.primitive) {
                // A tie: both primitives must really be hit at that same t.
                Hit check{};
                bool same = std::fabs(a.t - b.t) <= std::nextafter(a.t, INFINITY) - a.t &&
                            cbk::intersectPrimitive(&bvh.primitives[a.primitive], rays[i],
                                                    CB_INFINITY, &check);
                if (same)
                    ++out->ties;
                else
                    ++out->closest;
            } else if (a.t != b.t || a.b1 != b.b1 || a.b2 != b.b2) {
                ++out->closest;
            }
        }
        float tMax = hb ? b.t * u(rng) : 1e3f * u(rng);
        Hit any{};
        bool occ = wide ? cbk::bvhWideTraverse(wide->nodes.data(), wide->packs.data(),
                                               bvh.primitives.data(), rays[i], tMax, false, false,
                                               &any, nullptr)
                        : cbk::bvhOccluded(bvh.nodes.data(), bvh.primitives.data(), rays[i], tMax);
        if (occ != brute.occluded(rays[i], tMax)) ++out->occluded;
    }
}

Mismatches compareAll(const cb::Bvh& bvh, const std::vector<Ray>& rays,
                      const cb::BvhWide* wide = nullptr) {
    unsigned threads = std::max(1u, std::min(8u, std::thread::hardware_concurrency()));
    std::vector<Mismatches> parts(threads);
    std::vector<std::thread> pool;
    Brute brute(bvh.primitives);
    for (unsigned t = 0; t < threads; ++t)
        pool.emplace_back(compareRange, std::cref(bvh), std::cref(brute), std::cref(rays),
                          rays.size() * t / threads, rays.size() * (t + 1) / threads, &parts[t],
                          wide);
    for (auto& th : pool)
        th.join();
    Mismatches total;
    for (const auto& p : parts) {
        total.closest += p.closest;
        total.occluded += p.occluded;
        total.hits += p.hits;
        total.ties += p.ties;
    }
    return total;
}

// Structural invariants of the flattened tree.
void checkStructure(const cb::Bvh& bvh, size_t primitiveCount, int maxLeaf) {
    REQUIRE(!bvh.nodes.empty());
    REQUIRE(bvh.primitives.size() == primitiveCount);
    std::vector<int> seen(primitiveCount, 0);
    size_t n = bvh.nodes.size();
    size_t end = cbk::bvhEnd(bvh.nodes.data());
    CHECK(end == n);
    int badSkip = 0, badBox = 0, badLeaf = 0;
    for (size_t i = 0; i < n; ++i) {
        const auto& node = bvh.nodes[i];
        if (node.count & CB_BVH_LEAF) {
            uint32_t count = node.count & ~CB_BVH_LEAF;
            if (count == 0 || int(count) > maxLeaf) ++badLeaf;
            for (uint32_t k = node.index; k < node.index + count && k < primitiveCount; ++k) {
                ++seen[k];
                float lo[3], hi[3];
                cb::primitiveBounds(bvh.primitives[k], lo, hi);
                for (int a = 0; a < 3; ++a)
                    if (lo[a] < node.boundsMin[a] || hi[a] > node.boundsMax[a]) ++badBox;
            }
        } else {
            // Interior: children are i+1 and the skip of i+1; the subtree ends at index.
            size_t first = i + 1;
            size_t second =
                (bvh.nodes[first].count & CB_BVH_LEAF) ? first + 1 : bvh.nodes[first].index;
            if (!(node.index > second && node.index <= n)) ++badSkip;
            for (size_t c : {first, second}) {
                if (c >= n) {
                    ++badSkip;
                    continue;
                }
                for (int a = 0; a < 3; ++a)
                    if (bvh.nodes[c].boundsMin[a] < node.boundsMin[a] ||
                        bvh.nodes[c].boundsMax[a] > node.boundsMax[a])
                        ++badBox;
            }
        }
    }
    CHECK(badSkip == 0);
    CHECK(badBox == 0);
    CHECK(badLeaf == 0);
    CHECK(std::count(seen.begin(), seen.end(), 1) == long(primitiveCount));
    std::vector<int> orig = bvh.originalIndex;
    std::sort(orig.begin(), orig.end());
    for (size_t i = 0; i < orig.size(); ++i)
        REQUIRE(orig[i] == int(i));
}

} // namespace

TEST_CASE("bvh: structure of the bunny BVH") {
    if (!cbtest::stanfordModelsOrSkip()) return;
    Mesh mesh = loadModel("bunny.ply");
    auto prims = meshPrimitives(mesh);
    REQUIRE(prims.size() == 34831);
    cb::Bvh bvh = cb::buildBvh(prims);
    checkStructure(bvh, prims.size(), 4);
    // A balanced tree over 34831 primitives in leaves of <= 4 has depth >= 14; SAH trees are
    // deeper but not degenerate.
    CHECK(bvh.depth >= 14);
    CHECK(bvh.depth <= 64);
    // Reordering keeps each primitive intact (material holds the input index here).
    for (size_t i = 0; i < bvh.primitives.size(); ++i)
        REQUIRE(bvh.primitives[i].material == bvh.originalIndex[i]);
}

TEST_CASE("bvh: closest hit and occlusion equal brute force on the bunny (3k rays)") {
    if (!cbtest::stanfordModelsOrSkip()) return;
    Mesh mesh = loadModel("bunny.ply");
    cb::Bvh bvh = cb::buildBvh(meshPrimitives(mesh));
    auto rays = makeRays(boundsOf(bvh.primitives), 3000, 1234u);
    Mismatches m = compareAll(bvh, rays);
    CHECK(m.closest == 0);
    CHECK(m.occluded == 0);
    CHECK(m.hits > 1000); // most rays hit the bunny
}

TEST_CASE("bvh: closest hit and occlusion equal brute force on the bunny (100k rays)" *
          doctest::test_suite("statistical")) {
    if (!cbtest::stanfordModelsOrSkip()) return;
    Mesh mesh = loadModel("bunny.ply");
    cb::Bvh bvh = cb::buildBvh(meshPrimitives(mesh));
    auto rays = makeRays(boundsOf(bvh.primitives), 100000, 99u);
    Mismatches m = compareAll(bvh, rays);
    MESSAGE("hits " << m.hits << ", ties " << m.ties);
    CHECK(m.closest == 0);
    CHECK(m.occluded == 0);
    CHECK(m.hits > 40000);
}

// The wide BVH: every primitive in exactly one lane of one leaf's packs, packs full but for
// the last of each leaf, each pack lane a copy of its triangle (or marked for the scalar test),
// parents consistent, interior children first in lane order (bvhWideInteriorChild), each child
// box inside the binary box it came from (the lanes are the binary boxes themselves).
void checkWide(const cb::BvhWide& wide, const std::vector<Primitive>& prims) {
    const auto& nodes = wide.nodes;
    std::vector<int> seen(prims.size(), 0), packSeen(wide.packs.size(), 0);
    for (size_t i = 0; i < nodes.size(); ++i) {
        const auto& n = nodes[i];
        if (i == 0) CHECK(n.parent == CB_BVHW_NONE);
        for (int k = 0; k < CB_BVH_WIDE_LANES; ++k) {
            if (n.child[k] == CB_BVHW_NONE) continue;
            uint32_t count = cbk::bvhWideCount(&n, k);
            if (count == 0) {
                REQUIRE(n.child[k] < nodes.size());
                // Interior children come first and consecutive: the traversal's address rule.
                CHECK(n.child[k] == cbk::bvhWideInteriorChild(&n, k));
                CHECK(nodes[n.child[k]].parent == i);
                CHECK(nodes[n.child[k]].lane == uint32_t(k));
                for (int a = 0; a < 3; ++a)
                    for (int j = 0; j < CB_BVH_WIDE_LANES; ++j)
                        if (nodes[n.child[k]].child[j] != CB_BVHW_NONE) {
                            CHECK(nodes[n.child[k]].lo[a][j] >= n.lo[a][k]);
                            CHECK(nodes[n.child[k]].hi[a][j] <= n.hi[a][k]);
                        }
                continue;
            }
            for (uint32_t p = n.child[k]; p < n.child[k] + count; ++p) {
                REQUIRE(p < wide.packs.size());
                ++packSeen[p];
                const cbk::TrianglePack& pack = wide.packs[p];
                CHECK(pack.count >= 1);
                CHECK(pack.count <= CB_PACK_LANES);
                for (int lane = 0; lane < CB_PACK_LANES; ++lane) {
                    const int prim = pack.prim[lane];
                    REQUIRE(prim >= 0);
                    REQUIRE(size_t(prim) < prims.size());
                    if (lane < pack.count)
                        ++seen[size_t(prim)];
                    else
                        CHECK(prim == pack.prim[0]);
                    const Primitive& q = prims[size_t(prim)];
                    // A pack holds triangles only, their vertices copied, or others only.
                    CHECK(bool(pack.scalar) == (q.kind == CB_PRIM_SPHERE));
                    for (int a = 0; a < 3; ++a) {
                        CHECK(pack.v[0][a][lane] == (pack.scalar ? 0.0f : q.p0[a]));
                        CHECK(pack.v[1][a][lane] == (pack.scalar ? 0.0f : q.p1[a]));
                        CHECK(pack.v[2][a][lane] == (pack.scalar ? 0.0f : q.p2[a]));
                    }
                }
            }
        }
    }
    for (size_t p = 0; p < prims.size(); ++p)
        REQUIRE(seen[p] == 1);
    for (size_t p = 0; p < wide.packs.size(); ++p)
        REQUIRE(packSeen[p] == 1);
}

TEST_CASE("bvh: the wide BVH equals brute force on the bunny (3k rays)") {
    if (!cbtest::stanfordModelsOrSkip()) return;
    Mesh mesh = loadModel("bunny.ply");
    cb::Bvh bvh = cb::buildBvh(meshPrimitives(mesh));
    auto wide = cb::collapseBvhWide(bvh);
    checkWide(wide, bvh.primitives);
    // Four lanes per node: far fewer nodes than the binary tree's interior nodes.
    CHECK(wide.nodes.size() < bvh.nodes.size() / 4);
    auto rays = makeRays(boundsOf(bvh.primitives), 3000, 4321u);
    Mismatches m = compareAll(bvh, rays, &wide);
    CHECK(m.closest == 0);
    CHECK(m.occluded == 0);
    CHECK(m.hits > 1000);
}

TEST_CASE("bvh: a wide tree's bytes; traversals prefetch only a tree larger than a CPU's cache") {
    cb::Bvh one =
        cb::buildBvh({triangle(cbk::vec3(-1, -1, 2), cbk::vec3(1, -1, 2), cbk::vec3(0, 1, 2))});
    const auto wide = cb::collapseBvhWide(one);
    REQUIRE(wide.nodes.size() == 1);
    REQUIRE(wide.packs.size() == 1);
    CHECK(wide.bytes() == sizeof(cbk::BvhNodeWide) + sizeof(cbk::TrianglePack));
    const std::size_t mib = std::size_t(1) << 20;
    CHECK_FALSE(cb::treePrefetchPays(2 * mib, 32 * mib, true)); // the dragon's tree
    CHECK_FALSE(cb::treePrefetchPays(32 * mib, 32 * mib, true));
    CHECK(cb::treePrefetchPays(32 * mib + 1, 32 * mib, true));
    CHECK(cb::treePrefetchPays(61 * mib, 32 * mib, true));        // the 1M sphere's
    CHECK_FALSE(cb::treePrefetchPays(61 * mib, 0, true));         // a device that reports no cache
    CHECK_FALSE(cb::treePrefetchPays(61 * mib, 32 * mib, false)); // a GPU
}

TEST_CASE("bvh: the wide BVH on an empty scene, one triangle and spheres") {
    auto wideOf = [](const cb::Bvh& bvh) { return cb::collapseBvhWide(bvh); };
    Ray r{cbk::vec3(0, 0, 0), cbk::vec3(0, 0, 1)};
    Hit h;
    cb::Bvh empty = cb::buildBvh({});
    auto w0 = wideOf(empty);
    CHECK_FALSE(cbk::bvhWideTraverse(w0.nodes.data(), w0.packs.data(), empty.primitives.data(), r,
                                     CB_INFINITY, true, false, &h, nullptr));
    cb::Bvh one =
        cb::buildBvh({triangle(cbk::vec3(-1, -1, 2), cbk::vec3(1, -1, 2), cbk::vec3(0, 1, 2))});
    auto w1 = wideOf(one);
    checkWide(w1, one.primitives);
    REQUIRE(cbk::bvhWideTraverse(w1.nodes.data(), w1.packs.data(), one.primitives.data(), r,
                                 CB_INFINITY, true, false, &h, nullptr));
    CHECK(h.t == 2.0f);
    CHECK(cbk::bvhWideTraverse(w1.nodes.data(), w1.packs.data(), one.primitives.data(), r, 2.5f,
                               false, false, &h, nullptr));
    CHECK_FALSE(cbk::bvhWideTraverse(w1.nodes.data(), w1.packs.data(), one.primitives.data(), r,
                                     2.0f, false, false, &h, nullptr));
    std::vector<Primitive> prims;
    for (int i = 0; i < 1000; ++i)
        prims.push_back(sphere(cbk::vec3(0, 0, 10), 1.0f + float(i) * 1e-3f));
    cb::Bvh nested = cb::buildBvh(prims, {3, 8});
    auto w2 = wideOf(nested);
    checkWide(w2, nested.primitives);
    r.o = cbk::vec3(0, 0, 10); // inside every sphere: the innermost is nearest
    REQUIRE(cbk::bvhWideTraverse(w2.nodes.data(), w2.packs.data(), nested.primitives.data(), r,
                                 CB_INFINITY, true, false, &h, nullptr));
    CHECK(h.t == doctest::Approx(1.0f).epsilon(1e-6));
}

TEST_CASE("bvh: the slab set-up never gives a subnormal factor or addend") {
    // An FMA with a subnormal operand takes a microcode assist on Intel cores: with the
    // smallest subnormal as the outward nudge, camera rays (which start at the device origin,
    // o = 0) rendered 40-90% slower. Origins at zero, tiny, and ordinary; all directions.
    std::mt19937 rng(5u);
    auto normalOrZero = [](float v) { return v == 0.0f || std::fabs(v) >= FLT_MIN; };
    int checked = 0;
    for (float scale : {0.0f, 1e-30f, 1.0f, 1e4f})
        for (int i = 0; i < 2000; ++i) {
            Vec3 d = uniformDirection(rng);
            if (i % 7 == 0) d.y = 0.0f; // a flat axis
            const Vec3 o = cbk::vscale(uniformDirection(rng), scale);
            const cbk::BvhWideSlabs s = cbk::bvhWideSlabsOf(o, d);
            for (const Vec3& v : {s.invNear, s.addNear, s.invFar, s.addFar}) {
                CHECK(normalOrZero(v.x));
                CHECK(normalOrZero(v.y));
                CHECK(normalOrZero(v.z));
            }
            ++checked;
        }
    CHECK(checked == 8000);
}

TEST_CASE("bvh choice: traversal work is the nodes and packs entered before the hit") {
    // Two small triangles on the z axis, at z = 2 and z = 10, leaves of one: the root holds
    // both leaves, one pack each.
    auto square = [](float z) {
        return triangle(cbk::vec3(-1, -1, z), cbk::vec3(1, -1, z), cbk::vec3(0, 1, z));
    };
    cb::Bvh bvh = cb::buildBvh({square(2.0f), square(10.0f)}, {1, 16, 1});
    cb::BvhWide wide = cb::collapseBvhWide(bvh);
    REQUIRE(wide.nodes.size() == 1);
    auto workOf = [&](Ray r) { return cb::measureTraversalWork(bvh, wide, {r}); };
    // Along +z from the origin: the hit at z = 2 comes before the far box is entered.
    cb::TraversalWork w = workOf({cbk::vec3(0, 0, 0), cbk::vec3(0, 0, 1)});
    CHECK(w.nodeVisits == 1.0);
    CHECK(w.packTests == 1.0);
    // From beyond the far one, back along -z: the far one is now hit first.
    w = workOf({cbk::vec3(0, 0, 20), cbk::vec3(0, 0, -1)});
    CHECK(w.packTests == 1.0);
    // Between the boxes, rising slowly, through neither: both boxes' slabs are missed. (Not
    // exactly along +x: a zero direction component is a flat axis, which the conservative
    // test never uses to drop a box the origin lies beyond; see BvhWideSlabs.)
    w = workOf({cbk::vec3(0, 0, 5), cbk::vnormalize(cbk::vec3(1, 0, 0.01f))});
    CHECK(w.nodeVisits == 1.0);
    CHECK(w.packTests == 0.0);
    // Through both boxes and both planes outside the triangles (x = 0.9, y = 0.9 is inside
    // the box, outside the triangle): nothing is hit, so both packs are tested.
    w = workOf({cbk::vec3(0.9f, 0.9f, 0), cbk::vec3(0, 0, 1)});
    CHECK(w.nodeVisits == 1.0);
    CHECK(w.packTests == 2.0);
    // Averages over the rays given.
    w = cb::measureTraversalWork(
        bvh, wide,
        {{cbk::vec3(0, 0, 0), cbk::vec3(0, 0, 1)}, {cbk::vec3(0.9f, 0.9f, 0), cbk::vec3(0, 0, 1)}});
    CHECK(w.packTests == 1.5);
    CHECK(w.cost() == doctest::Approx(1.0 + cb::TraversalWork::kPackWeight * 1.5));
}

// The twelve triangles of the cube [-1, 1]^3, seen from inside.
std::vector<Primitive> closedCube() {
    std::vector<Primitive> prims;
    for (int axis = 0; axis < 3; ++axis)
        for (float side : {-1.0f, 1.0f}) {
            auto corner = [&](float u, float v) {
                float c[3];
                c[axis] = side;
                c[(axis + 1) % 3] = u;
                c[(axis + 2) % 3] = v;
                return cbk::vec3(c[0], c[1], c[2]);
            };
            prims.push_back(triangle(corner(-1, -1), corner(1, -1), corner(1, 1)));
            prims.push_back(triangle(corner(-1, -1), corner(1, 1), corner(-1, 1)));
        }
    return prims;
}

TEST_CASE("bvh choice: bounce rays inside a closed cube") {
    cb::Bvh bvh = cb::buildBvh(closedCube());
    cb::BvhWide wide = cb::collapseBvhWide(bvh);
    std::mt19937 rng(99u);
    std::vector<Ray> camera;
    for (int i = 0; i < 200; ++i)
        camera.push_back({cbk::vec3(0.1f, -0.2f, 0.3f), uniformDirection(rng)});
    const auto rays = cb::sampleBounceRays(bvh, wide, camera, 3);
    // Every ray inside a closed cube hits it, so every camera ray gets all three bounces.
    REQUIRE(rays.size() == camera.size() * 4);
    for (size_t i = 0; i < rays.size(); ++i) {
        if (i % 4 == 0) continue;
        const float o[3] = {rays[i].o.x, rays[i].o.y, rays[i].o.z};
        const float d[3] = {rays[i].d.x, rays[i].d.y, rays[i].d.z};
        CHECK(cbk::vlength(rays[i].d) == doctest::Approx(1.0f).epsilon(1e-5));
        // Leaves a face from just inside it, heading inwards.
        int face = 0;
        for (int a = 1; a < 3; ++a)
            if (std::fabs(o[a]) > std::fabs(o[face])) face = a;
        CHECK(std::fabs(o[face]) < 1.0f);
        CHECK(std::fabs(o[face]) > 0.999f);
        CHECK(d[face] * o[face] < 0.0f);
    }
    // Deterministic: the same rays again.
    const auto again = cb::sampleBounceRays(bvh, wide, camera, 3);
    REQUIRE(again.size() == rays.size());
    CHECK(std::memcmp(again.data(), rays.data(), rays.size() * sizeof(Ray)) == 0);
    // Cosine-distributed about the face normal: E[cos] = 2/3 (the mean of 600 is within 0.03
    // of it with probability > 0.999: the standard deviation of cos is sqrt(1/18) = 0.24).
    double cosines = 0.0;
    int bounces = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        if (i % 4 == 0) continue;
        const float o[3] = {rays[i].o.x, rays[i].o.y, rays[i].o.z};
        const float d[3] = {rays[i].d.x, rays[i].d.y, rays[i].d.z};
        int face = 0;
        for (int a = 1; a < 3; ++a)
            if (std::fabs(o[a]) > std::fabs(o[face])) face = a;
        cosines += std::fabs(d[face]);
        ++bounces;
    }
    CHECK(cosines / bounces == doctest::Approx(2.0 / 3.0).epsilon(0.045));
}

TEST_CASE("bvh choice: the isolated bunny takes SAH block 4; the chosen trees, in a room too, "
          "find the brute-force hits") {
    // Which candidate is faster was measured (docs/performance.md): block 4 on the isolated
    // meshes; test_scenes.cpp checks the seven scenes' choices against the same table.
    if (!cbtest::stanfordModelsOrSkip()) return;
    Mesh mesh = loadModel("bunny.ply");
    const auto prims = meshPrimitives(mesh);
    const Bounds b = boundsOf(prims);
    const auto camera = cameraRays(b, 32);
    // The default candidates, whatever CBDPT_BVH_SETTINGS says.
    const auto candidates = cb::defaultWideBvhCandidates();
    REQUIRE(candidates.size() == 2);
    cb::WideBvhChoice isolated = cb::buildWideBvhForRays(prims, camera, candidates);
    REQUIRE(isolated.work.size() == 2);
    CHECK(isolated.settings.sahBlock == 4);
    CHECK(isolated.chosen == 1);
    CHECK(isolated.work[1].cost() < isolated.work[0].cost());
    // Fuller leaves: fewer node visits, more pack tests.
    CHECK(isolated.work[1].nodeVisits < isolated.work[0].nodeVisits);
    CHECK(isolated.work[1].packTests > isolated.work[0].packTests);
    checkWide(isolated.wide, isolated.bvh.primitives);
    Mismatches m = compareAll(isolated.bvh, makeRays(b, 2000, 77u), &isolated.wide);
    CHECK(m.closest == 0);
    CHECK(m.occluded == 0);
    CHECK(m.hits > 500);

    // The bunny in a closed room ten times its size, the camera inside.
    std::vector<Primitive> room = prims;
    const Vec3 centre = cbk::vscale(cbk::vadd(b.lo, b.hi), 0.5f);
    const float half = 5.0f * cbk::vlength(cbk::vsub(b.hi, b.lo));
    for (Primitive wall : closedCube()) {
        for (float* p : {wall.p0, wall.p1, wall.p2})
            for (int a = 0; a < 3; ++a)
                p[a] = p[a] * half + cbk::vcomponent(centre, a);
        room.push_back(wall);
    }
    std::vector<Ray> inside;
    const Vec3 eye = cbk::vadd(centre, cbk::vec3(0.0f, 0.0f, 0.5f * half));
    for (const Ray& r : camera)
        inside.push_back({eye, r.d});
    cb::WideBvhChoice roomChoice = cb::buildWideBvhForRays(room, inside, candidates);
    REQUIRE(roomChoice.work.size() == 2);
    checkWide(roomChoice.wide, roomChoice.bvh.primitives);
    m = compareAll(roomChoice.bvh, makeRays(boundsOf(room), 2000, 78u), &roomChoice.wide);
    CHECK(m.closest == 0);
    CHECK(m.occluded == 0);
    // No camera rays: the first candidate, nothing measured.
    cb::WideBvhChoice none = cb::buildWideBvhForRays(prims, {}, candidates);
    CHECK(none.settings.sahBlock == candidates[0].sahBlock);
    CHECK(none.work.empty());
    // No primitives (a scene of point lights): every ray visits the empty root and stops.
    cb::WideBvhChoice empty = cb::buildWideBvhForRays({}, camera, candidates);
    REQUIRE(empty.work.size() == 2);
    for (const cb::TraversalWork& w : empty.work) {
        CHECK(w.nodeVisits == 1.0);
        CHECK(w.packTests == 0.0);
    }
    CHECK(empty.chosen == 0);
}

TEST_CASE("bvh: mixed triangles and spheres equal brute force") {
    if (!cbtest::stanfordModelsOrSkip()) return;
    Mesh mesh = loadModel("dragon.ply");
    auto prims = meshPrimitives(mesh);
    Bounds b = boundsOf(prims);
    float size = cbk::vlength(cbk::vsub(b.hi, b.lo));
    std::mt19937 rng(5u);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    // Spheres of very different sizes, some inside the dragon, some around it, some large.
    for (int i = 0; i < 300; ++i)
        prims.push_back(sphere(pointIn(b, rng), size * (i % 10 == 0 ? 0.2f : 0.01f) * u(rng)));
    prims.push_back(sphere(cbk::vec3(0.0f, -100.0f, 0.0f), 99.95f)); // a ground "plane"
    cb::Bvh bvh = cb::buildBvh(prims, {4, 16});
    checkStructure(bvh, prims.size(), 4);
    auto rays = makeRays(b, 2000, 77u);
    Mismatches m = compareAll(bvh, rays);
    CHECK(m.closest == 0);
    CHECK(m.occluded == 0);
    CHECK(m.hits > 1000);
    int sphereHits = 0;
    auto wideNodes = cb::collapseBvhWide(bvh);
    SceneView scene = viewOf(bvh, wideNodes);
    for (const auto& r : rays) {
        Hit h;
        if (cbk::sceneIntersect(&scene, r, CB_INFINITY, &h) &&
            bvh.primitives[h.primitive].kind == CB_PRIM_SPHERE)
            ++sphereHits;
    }
    CHECK(sphereHits > 100);
}

TEST_CASE("bvh: empty scene, single primitive and coincident centroids") {
    SUBCASE("empty") {
        cb::Bvh bvh = cb::buildBvh({});
        REQUIRE(bvh.nodes.size() == 1);
        CHECK(bvh.primitives.empty());
        auto wideNodes = cb::collapseBvhWide(bvh);
        SceneView scene = viewOf(bvh, wideNodes);
        std::mt19937 rng(3u);
        for (int i = 0; i < 100; ++i) {
            Ray r{cbk::vec3(0.0f, 0.0f, 0.0f), uniformDirection(rng)};
            Hit h;
            CHECK_FALSE(cbk::sceneIntersect(&scene, r, CB_INFINITY, &h));
            CHECK_FALSE(cbk::sceneOccluded(&scene, r, CB_INFINITY));
        }
    }
    SUBCASE("one triangle") {
        cb::Bvh bvh =
            cb::buildBvh({triangle(cbk::vec3(-1, -1, 2), cbk::vec3(1, -1, 2), cbk::vec3(0, 1, 2))});
        REQUIRE(bvh.nodes.size() == 1);
        auto wideNodes = cb::collapseBvhWide(bvh);
        SceneView scene = viewOf(bvh, wideNodes);
        Hit h;
        REQUIRE(cbk::sceneIntersect(&scene, Ray{cbk::vec3(0, 0, 0), cbk::vec3(0, 0, 1)},
                                    CB_INFINITY, &h));
        CHECK(h.t == 2.0f);
        CHECK(h.primitive == 0);
        CHECK(cbk::sceneOccluded(&scene, Ray{cbk::vec3(0, 0, 0), cbk::vec3(0, 0, 1)}, 2.5f));
        CHECK_FALSE(cbk::sceneOccluded(&scene, Ray{cbk::vec3(0, 0, 0), cbk::vec3(0, 0, 1)}, 2.0f));
    }
    SUBCASE("1000 identical triangles and 1000 concentric spheres") {
        std::vector<Primitive> prims;
        for (int i = 0; i < 1000; ++i)
            prims.push_back(
                triangle(cbk::vec3(-1, -1, 2), cbk::vec3(1, -1, 2), cbk::vec3(0, 1, 2), i));
        for (int i = 0; i < 1000; ++i)
            prims.push_back(sphere(cbk::vec3(0, 0, 10), 1.0f + float(i) * 1e-3f));
        cb::Bvh bvh = cb::buildBvh(prims, {3, 8});
        checkStructure(bvh, prims.size(), 3);
        auto wideNodes = cb::collapseBvhWide(bvh);
        SceneView scene = viewOf(bvh, wideNodes);
        Hit h;
        Ray r{cbk::vec3(0, 0, 0), cbk::vec3(0, 0, 1)};
        REQUIRE(cbk::sceneIntersect(&scene, r, CB_INFINITY, &h));
        CHECK(h.t == 2.0f);
        r.o = cbk::vec3(0, 0, 5);
        REQUIRE(cbk::sceneIntersect(&scene, r, CB_INFINITY, &h));
        CHECK(h.t == doctest::Approx(5.0f - 1.999f).epsilon(1e-5));
        r.o = cbk::vec3(0, 0, 10); // inside every sphere: the innermost is nearest
        REQUIRE(cbk::sceneIntersect(&scene, r, CB_INFINITY, &h));
        CHECK(h.t == doctest::Approx(1.0f).epsilon(1e-6));
    }
}

TEST_CASE("bvh: axis-parallel rays along box faces and through shared box planes") {
    // Unit cubes on a grid: rays with zero direction components whose origins lie exactly on
    // box planes (0 * inf = NaN in the slab test) must still find what brute force finds.
    std::vector<Primitive> prims;
    for (int x = 0; x < 4; ++x)
        for (int y = 0; y < 4; ++y) {
            float fx = float(x), fy = float(y);
            prims.push_back(
                triangle(cbk::vec3(fx, fy, 0), cbk::vec3(fx + 1, fy, 0), cbk::vec3(fx, fy + 1, 0)));
            prims.push_back(triangle(cbk::vec3(fx + 1, fy, 0), cbk::vec3(fx + 1, fy + 1, 0),
                                     cbk::vec3(fx, fy + 1, 0)));
            prims.push_back(
                triangle(cbk::vec3(fx, 0, fy), cbk::vec3(fx, 0, fy + 1), cbk::vec3(fx + 1, 0, fy)));
            prims.push_back(triangle(cbk::vec3(fx + 1, 0, fy), cbk::vec3(fx, 0, fy + 1),
                                     cbk::vec3(fx + 1, 0, fy + 1)));
        }
    cb::Bvh bvh = cb::buildBvh(prims, {1, 16});
    auto wideNodes = cb::collapseBvhWide(bvh);
    SceneView scene = viewOf(bvh, wideNodes);
    int hits = 0, mismatches = 0;
    for (int i = 0; i <= 16; ++i)
        for (int j = 0; j <= 16; ++j)
            for (int s = 0; s < 2; ++s) {
                float a = float(i) * 0.25f, b = float(j) * 0.25f;
                float z = s ? -0.0f : 0.0f; // both signs of zero give +inf inverses
                Ray rays[3] = {{cbk::vec3(a, b, s ? 5.0f : -5.0f), cbk::vec3(0, 0, s ? -1 : 1)},
                               {cbk::vec3(a, s ? 5.0f : -5.0f, b), cbk::vec3(0, s ? -1 : 1, 0)},
                               {cbk::vec3(a, -5.0f, b), cbk::vec3(z, 1.0f, z)}};
                for (const Ray& r : rays) {
                    Hit h1{}, h2{};
                    bool a1 = cbk::sceneIntersect(&scene, r, CB_INFINITY, &h1);
                    bool a2 = Brute(bvh.primitives).intersect(r, CB_INFINITY, &h2);
                    hits += a2;
                    if (a1 != a2 || (a1 && h1.t != h2.t)) ++mismatches;
                }
            }
    CHECK(mismatches == 0);
    CHECK(hits == 3 * 2 * 17 * 17);
}

// Rays from points inside the closed Buddha through every vertex and through the midpoints of
// the edges of a sample of triangles: a watertight traversal lets none of them escape.
std::vector<Ray> raysThroughVerticesAndEdges(const Mesh& mesh, const cb::Bvh& bvh,
                                             const SceneView& scene) {
    // Interior points: a little behind random triangles, accepted when the closest hit along
    // six axis directions is a back face (from inside a closed, outward-oriented mesh every
    // ray first meets the surface from behind).
    std::mt19937 rng(42u);
    std::vector<Vec3> inside;
    std::uniform_int_distribution<size_t> pick(0, bvh.primitives.size() - 1);
    const Vec3 axes[6] = {cbk::vec3(1, 0, 0),  cbk::vec3(-1, 0, 0), cbk::vec3(0, 1, 0),
                          cbk::vec3(0, -1, 0), cbk::vec3(0, 0, 1),  cbk::vec3(0, 0, -1)};
    while (inside.size() < 20) {
        const Primitive& p = bvh.primitives[pick(rng)];
        Vec3 p0 = cbk::vec3FromArray(p.p0), p1 = cbk::vec3FromArray(p.p1),
             p2 = cbk::vec3FromArray(p.p2);
        Vec3 c = cbk::vscale(cbk::vadd(cbk::vadd(p0, p1), p2), 1.0f / 3.0f);
        Vec3 n = cbk::vnormalize(cbk::vcross(cbk::vsub(p1, p0), cbk::vsub(p2, p0)));
        Vec3 q = cbk::vmadd(c, n, -2e-3f);
        bool ok = true;
        for (Vec3 d : axes) {
            Hit h;
            Ray r{q, d};
            if (!cbk::sceneIntersect(&scene, r, CB_INFINITY, &h)) {
                ok = false;
                break;
            }
            cbk::SurfacePoint sp = cbk::surfacePointFromHit(&scene, r, h);
            if (cbk::vdot(sp.ng, d) <= 0.0f) ok = false;
        }
        if (ok) inside.push_back(q);
    }
    std::vector<Vec3> targets = mesh.positions;
    for (size_t f = 0; f < mesh.indices.size(); f += 3 * 4)
        for (int e = 0; e < 3; ++e)
            targets.push_back(cbk::vscale(cbk::vadd(mesh.positions[mesh.indices[f + e]],
                                                    mesh.positions[mesh.indices[f + (e + 1) % 3]]),
                                          0.5f));
    std::vector<Ray> rays;
    for (size_t i = 0; i < targets.size(); ++i) {
        Vec3 o = inside[i % inside.size()];
        rays.push_back(Ray{o, cbk::vnormalize(cbk::vsub(targets[i], o))});
    }
    return rays;
}

TEST_CASE("bvh: rays from inside the closed Buddha through vertices and edges never escape") {
    if (!cbtest::stanfordModelsOrSkip()) return;
    Mesh mesh = loadModel("buddha.ply");
    cb::Bvh bvh = cb::buildBvh(meshPrimitives(mesh), {4, 16, CB_PACK_LANES});
    auto wideNodes = cb::collapseBvhWide(bvh);
    SceneView scene = viewOf(bvh, wideNodes);
    long escapes = 0;
    auto rays = raysThroughVerticesAndEdges(mesh, bvh, scene);
    for (const Ray& r : rays) {
        Hit h;
        if (!cbk::sceneIntersect(&scene, r, CB_INFINITY, &h)) ++escapes;
    }
    CHECK(rays.size() > 30000);
    CHECK(escapes == 0);
}

// ---- OpenCL: the same header compiled by PoCL ---------------------------------------------

namespace {

const char* kTraceKernel = R"CLC(
#include "cb_bvh_wide.h"
__kernel void trace(__global const BvhNodeWide* nodes, __global const TrianglePack* packs,
                    __global const Primitive* prims, __global const float* rays,
                    __global float* out, __global int* outPrim) {
    int i = get_global_id(0);
    SceneView scene;
    scene.nodes = nodes;
    scene.packs = packs;
    scene.primitives = prims;
    scene.materials = 0;
    scene.lights = 0;
    scene.spectra = 0;
    scene.lightCount = 0;
    Ray r;
    r.o = vec3(rays[6 * i], rays[6 * i + 1], rays[6 * i + 2]);
    r.d = vec3(rays[6 * i + 3], rays[6 * i + 4], rays[6 * i + 5]);
    Hit h;
    if (sceneIntersect(&scene, r, CB_INFINITY, &h)) {
        out[3 * i] = h.t;
        outPrim[2 * i] = h.primitive;
    } else {
        out[3 * i] = -1.0f;
        outPrim[2 * i] = -1;
    }
    /* Even rays: the segment up to half the closest hit (free); odd rays: past it (blocked). */
    float tOcc = (i % 2 == 0 ? 0.5f : 1.5f) * fabs(out[3 * i]);
    out[3 * i + 1] = sceneOccluded(&scene, r, tOcc) ? 1.0f : 0.0f;
    Hit c;
    if (sceneIntersectCoherent(&scene, r, CB_INFINITY, &c)) {
        out[3 * i + 2] = c.t;
        outPrim[2 * i + 1] = c.primitive;
    } else {
        out[3 * i + 2] = -1.0f;
        outPrim[2 * i + 1] = -1;
    }
}
)CLC";

#define CL_CHECK(expr)                                                                             \
    do {                                                                                           \
        cl_int err_ = (expr);                                                                      \
        REQUIRE_MESSAGE(err_ == CL_SUCCESS, #expr << " failed: " << err_);                         \
    } while (0)

// The trace kernel on PoCL: closest hits (t, -1 for a miss; primitive), whether anything
// occludes half the closest distance, and the closest hits of the coherent traversal.
class ClTracer {
  public:
    explicit ClTracer(const std::string& extraOptions = "") {
        cl_uint platformCount = 0;
        REQUIRE(clGetPlatformIDs(0, nullptr, &platformCount) == CL_SUCCESS);
        REQUIRE(platformCount > 0);
        std::vector<cl_platform_id> platforms(platformCount);
        CL_CHECK(clGetPlatformIDs(platformCount, platforms.data(), nullptr));
        cl_device_id device = nullptr;
        for (auto p : platforms)
            if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 1, &device, nullptr) == CL_SUCCESS) break;
        REQUIRE(device != nullptr);
        cl_int err = 0;
        ctx_ = clCreateContext(nullptr, 1, &device, nullptr, nullptr, &err);
        CL_CHECK(err);
        queue_ = clCreateCommandQueue(ctx_, device, 0, &err);
        CL_CHECK(err);
        program_ = clCreateProgramWithSource(ctx_, 1, &kTraceKernel, nullptr, &err);
        CL_CHECK(err);
        std::string options = "-cl-std=CL1.2 -DCB_CHANNELS=3 -I " + cbtest::sourcePath("kernels") +
                              " " + extraOptions;
        err = clBuildProgram(program_, 1, &device, options.c_str(), nullptr, nullptr);
        if (err != CL_SUCCESS) {
            size_t size = 0;
            clGetProgramBuildInfo(program_, device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &size);
            std::string log(size, '\0');
            clGetProgramBuildInfo(program_, device, CL_PROGRAM_BUILD_LOG, size, log.data(),
                                  nullptr);
            FAIL("clBuildProgram failed: " << log);
        }
        kernel_ = clCreateKernel(program_, "trace", &err);
        CL_CHECK(err);
    }
    ~ClTracer() {
        clReleaseKernel(kernel_);
        clReleaseProgram(program_);
        clReleaseCommandQueue(queue_);
        clReleaseContext(ctx_);
    }
    ClTracer(const ClTracer&) = delete;
    ClTracer& operator=(const ClTracer&) = delete;

    struct Result {
        std::vector<float> t;               // closest hit, -1 for a miss
        std::vector<int> primitive;         // -1 for a miss
        std::vector<int> occluded;          // anything within 0.5 (even rays) or 1.5 (odd) x t
        std::vector<float> coherentT;       // sceneIntersectCoherent's closest hit
        std::vector<int> coherentPrimitive; // and its primitive
    };

    Result trace(const cb::Bvh& bvh, const cb::BvhWide& wide, const std::vector<Ray>& rays) {
        const size_t count = rays.size();
        std::vector<float> rayData;
        for (const auto& r : rays)
            for (float v : {r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z})
                rayData.push_back(v);
        cl_mem args[6] = {buffer(wide.nodes.size() * sizeof(cbk::BvhNodeWide), wide.nodes.data()),
                          buffer(wide.packs.size() * sizeof(cbk::TrianglePack), wide.packs.data()),
                          buffer(bvh.primitives.size() * sizeof(Primitive), bvh.primitives.data()),
                          buffer(rayData.size() * sizeof(float), rayData.data()),
                          buffer(3 * count * sizeof(float), nullptr),
                          buffer(2 * count * sizeof(int), nullptr)};
        for (cl_uint a = 0; a < 6; ++a)
            CL_CHECK(clSetKernelArg(kernel_, a, sizeof(cl_mem), &args[a]));
        size_t global = count;
        CL_CHECK(clEnqueueNDRangeKernel(queue_, kernel_, 1, nullptr, &global, nullptr, 0, nullptr,
                                        nullptr));
        std::vector<float> out(3 * count);
        std::vector<int> prims(2 * count);
        CL_CHECK(clEnqueueReadBuffer(queue_, args[4], CL_TRUE, 0, out.size() * sizeof(float),
                                     out.data(), 0, nullptr, nullptr));
        CL_CHECK(clEnqueueReadBuffer(queue_, args[5], CL_TRUE, 0, prims.size() * sizeof(int),
                                     prims.data(), 0, nullptr, nullptr));
        for (cl_mem m : args)
            clReleaseMemObject(m);
        Result result;
        for (size_t i = 0; i < count; ++i) {
            result.t.push_back(out[3 * i]);
            result.occluded.push_back(out[3 * i + 1] != 0.0f);
            result.coherentT.push_back(out[3 * i + 2]);
            result.primitive.push_back(prims[2 * i]);
            result.coherentPrimitive.push_back(prims[2 * i + 1]);
        }
        return result;
    }

  private:
    cl_mem buffer(size_t bytes, const void* data) {
        cl_int err = 0;
        cl_mem m =
            clCreateBuffer(ctx_, data ? CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR : CL_MEM_WRITE_ONLY,
                           std::max<size_t>(bytes, 1), const_cast<void*>(data), &err);
        CL_CHECK(err);
        return m;
    }

    cl_context ctx_ = nullptr;
    cl_command_queue queue_ = nullptr;
    cl_program program_ = nullptr;
    cl_kernel kernel_ = nullptr;
};

} // namespace

TEST_CASE("bvh: OpenCL traversal of the bunny wide BVH matches the host") {
    // The candidate lanes' bits come from movmskps on x86; the portable multiply that other
    // targets use is checked here as well.
    if (!cbtest::stanfordModelsOrSkip()) return;
    Mesh mesh = loadModel("bunny.ply");
    const Bounds box = boundsOf(meshPrimitives(mesh));
    for (const char* options : {"", "-DCB_PORTABLE_LANE_BITS"}) {
        CAPTURE(options);
        ClTracer tracer(options);
        for (int variant = 0; variant < 3; ++variant) {
            CAPTURE(variant);
            // 0: leaves of 1-4 triangles priced per triangle, so packs with every number of
            // repeated lanes; 1, 2: the renderers' two candidate settings (bvh_choice.h), the
            // second with leaves of several packs and spheres among the triangles (in packs of
            // their own).
            auto prims = meshPrimitives(mesh);
            if (variant == 2) {
                std::mt19937 rng(9u);
                std::uniform_real_distribution<float> u(0.0f, 1.0f);
                float size = cbk::vlength(cbk::vsub(box.hi, box.lo));
                for (int i = 0; i < 200; ++i)
                    prims.push_back(sphere(pointIn(box, rng), size * 0.02f * u(rng)));
            }
            cb::WideBvhSettings settings{1, 4};
            if (variant > 0) settings = cb::defaultWideBvhCandidates()[size_t(variant - 1)];
            cb::Bvh bvh = cb::buildBvh(prims, {settings.maxLeafSize, 16, settings.sahBlock});
            auto wide = cb::collapseBvhWide(bvh);
            // Random rays, then camera rays in pixel order (the coherent traversal's use).
            auto rays = makeRays(box, 4096, 2024u);
            const size_t randomCount = rays.size();
            for (const Ray& r : cameraRays(box, 48))
                rays.push_back(r);
            ClTracer::Result device = tracer.trace(bvh, wide, rays);

            SceneView scene = viewOf(bvh, wide);
            int hits = 0, cameraHits = 0, sphereHits = 0, primMismatch = 0, tMismatch = 0,
                occMismatch = 0, coherentMismatch = 0, occludedCount = 0;
            for (size_t i = 0; i < rays.size(); ++i) {
                Hit h{};
                bool hit = cbk::sceneIntersect(&scene, rays[i], CB_INFINITY, &h);
                float t = hit ? h.t : -1.0f;
                hits += hit;
                cameraHits += hit && i >= randomCount;
                sphereHits += hit && bvh.primitives[size_t(h.primitive)].kind == CB_PRIM_SPHERE;
                if ((hit ? h.primitive : -1) != device.primitive[i]) ++primMismatch;
                if (std::fabs(device.t[i] - t) > 1e-5f * std::fabs(t)) ++tMismatch;
                const float tOcc = (i % 2 == 0 ? 0.5f : 1.5f) * std::fabs(t);
                bool occ = cbk::sceneOccluded(&scene, rays[i], tOcc);
                if ((device.occluded[i] != 0) != occ) ++occMismatch;
                // Past the closest hit the segment is blocked, before half of it free.
                if (hit && occ != (i % 2 == 1)) ++occMismatch;
                occludedCount += device.occluded[i] != 0;
                // Only the way the next child is found differs: the same hit, bit for bit.
                if (device.coherentPrimitive[i] != device.primitive[i] ||
                    device.coherentT[i] != device.t[i])
                    ++coherentMismatch;
            }
            // PoCL may contract a*b+c into fma, so a ray grazing an edge could in principle pick
            // the neighbouring triangle; with these random rays that has not happened, allow none.
            CHECK(hits > int(rays.size()) / 3);
            CHECK(cameraHits > int(rays.size() - randomCount) / 5);
            if (variant == 2) CHECK(sphereHits > 100);
            CHECK(primMismatch == 0);
            CHECK(tMismatch == 0);
            CHECK(occMismatch == 0);
            CHECK(occludedCount > hits / 3); // the any-hit query's early return is exercised
            CHECK(coherentMismatch == 0);
        }
    }
}

TEST_CASE("bvh: OpenCL traversal: rays through the closed Buddha's vertices and edges never "
          "escape") {
    ClTracer tracer;
    if (!cbtest::stanfordModelsOrSkip()) return;
    Mesh mesh = loadModel("buddha.ply");
    cb::Bvh bvh = cb::buildBvh(meshPrimitives(mesh), {4, 16, CB_PACK_LANES});
    auto wide = cb::collapseBvhWide(bvh);
    auto rays = raysThroughVerticesAndEdges(mesh, bvh, viewOf(bvh, wide));
    ClTracer::Result device = tracer.trace(bvh, wide, rays);
    long escapes = 0, coherentEscapes = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        escapes += device.t[i] < 0.0f;
        coherentEscapes += device.coherentT[i] < 0.0f;
    }
    MESSAGE(rays.size() << " rays through the kernel");
    CHECK(rays.size() > 30000);
    CHECK(escapes == 0);
    CHECK(coherentEscapes == 0);
}

// The render programs (every embedded .cl but the bench's) are compiled without the binary BVH's
// traversals: they trace the wide BVH only. The names are read from the bench header itself, and
// the bench program, which includes it, must contain them (so the search can fail).
TEST_CASE("bvh: render programs hold no binary-BVH traversal") {
    const auto& sources = cb::embeddedKernelSources();
    const std::string& bench = sources.at("bench_bvh_binary.h");
    std::vector<std::string> functions;
    for (std::size_t at = bench.find("CB_FN "); at != std::string::npos;
         at = bench.find("CB_FN ", at + 1)) {
        const std::size_t open = bench.find('(', at);
        const std::size_t nameStart = bench.rfind(' ', open) + 1;
        functions.push_back(bench.substr(nameStart, open - nameStart));
    }
    REQUIRE(functions.size() >= 8);
    auto mentions = [](const std::string& source, const std::string& name) {
        return source.find(" " + name + "(") != std::string::npos;
    };
    const std::string benchProgram = cb::assembleKernelSource("bench_traverse.cl");
    CHECK(benchProgram.find("#line 1 \"bench_bvh_binary.h\"") != std::string::npos);
    for (const std::string& name : functions) {
        CAPTURE(name);
        CHECK(mentions(benchProgram, name));
    }
    int programs = 0;
    for (const auto& [file, text] : sources) {
        if (!file.ends_with(".cl") || file.starts_with("bench_")) continue;
        ++programs;
        const std::string program = cb::assembleKernelSource(file);
        CAPTURE(file);
        CHECK(program.find("#line 1 \"bench_bvh_binary.h\"") == std::string::npos);
        CHECK(program.find("struct BvhNode {") == std::string::npos);
        for (const std::string& name : functions) {
            CAPTURE(name);
            CHECK_FALSE(mentions(program, name));
        }
    }
    CHECK(programs == 5); // pt.cl, bdpt.cl, cbdpt.cl, cbdpt_packets.cl, mlt.cl
}
