// Ray/primitive intersection and ray offsets (kernels/cb_intersect.h): watertightness,
// accuracy against double precision, and self-intersection-free spawning at scene scales from
// 1e-4 to 1e4 and translations up to 1e5.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "bvh/bvh.h"
#include "bvh/bvh_wide.h"
#include "cb_lights.h"

using cbk::Hit;
using cbk::Primitive;
using cbk::Ray;
using cbk::SceneView;
using cbk::SurfacePoint;
using cbk::Vec3;
using cbk::vec3;

namespace {

Primitive makeTriangle(Vec3 a, Vec3 b, Vec3 c) {
    Primitive p{};
    p.kind = CB_PRIM_TRIANGLE;
    std::memcpy(p.p0, &a, sizeof p.p0);
    std::memcpy(p.p1, &b, sizeof p.p1);
    std::memcpy(p.p2, &c, sizeof p.p2);
    p.light = -1;
    return p;
}

Primitive makeSphere(Vec3 c, float r, float orientation = 1.0f) {
    Primitive p{};
    p.kind = CB_PRIM_SPHERE;
    std::memcpy(p.p0, &c, sizeof p.p0);
    p.p1[0] = r;
    p.p1[1] = orientation;
    p.light = -1;
    return p;
}

Vec3 uniformDirection(std::mt19937& rng) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    float z = 1.0f - 2.0f * u(rng);
    float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    float phi = 2.0f * CB_PI * u(rng);
    return vec3(r * std::cos(phi), r * std::sin(phi), z);
}

// Uniform direction in the hemisphere around n, away from grazing by at least ~1e-3 in cosine
// (exactly tangent directions are not "on a side" of the surface).
Vec3 hemisphereDirection(std::mt19937& rng, Vec3 n) {
    for (;;) {
        Vec3 d = uniformDirection(rng);
        float c = cbk::vdot(d, n);
        if (std::fabs(c) < 1e-3f) continue;
        return c > 0.0f ? d : cbk::vneg(d);
    }
}

// `wide`: the renderers' wide nodes collapsed from `bvh`, which must outlive the view.
SceneView viewOf(const std::vector<Primitive>& prims, const cb::Bvh* bvh = nullptr,
                 const cb::BvhWide* wide = nullptr) {
    SceneView s{};
    s.primitives = bvh ? bvh->primitives.data() : prims.data();
    s.nodes = wide ? wide->nodes.data() : nullptr;
    s.packs = wide ? wide->packs.data() : nullptr;
    return s;
}

// A closed cube [-1,1]^3 whose faces are n x n grids of vertex-sharing triangles, alternating
// the diagonal so that both diagonal directions occur. Coordinates are exact in float.
std::vector<Primitive> gridCube(int n, std::vector<Vec3>* vertices, std::vector<Vec3>* edgeMids) {
    std::vector<Primitive> prims;
    auto face = [&](int axis, float side) {
        int u = (axis + 1) % 3, v = (axis + 2) % 3;
        auto pt = [&](int i, int j) {
            float c[3];
            c[axis] = side;
            c[u] = -1.0f + 2.0f * float(i) / float(n);
            c[v] = -1.0f + 2.0f * float(j) / float(n);
            return vec3(c[0], c[1], c[2]);
        };
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                Vec3 a = pt(i, j), b = pt(i + 1, j), c = pt(i + 1, j + 1), d = pt(i, j + 1);
                Vec3 t[2][3];
                if ((i + j) % 2 == 0) {
                    t[0][0] = a, t[0][1] = b, t[0][2] = c;
                    t[1][0] = a, t[1][1] = c, t[1][2] = d;
                } else {
                    t[0][0] = a, t[0][1] = b, t[0][2] = d;
                    t[1][0] = b, t[1][1] = c, t[1][2] = d;
                }
                for (auto& tri : t) {
                    // Orient outwards: the normal must point along +side on `axis`.
                    Vec3 ng = cbk::vcross(cbk::vsub(tri[1], tri[0]), cbk::vsub(tri[2], tri[0]));
                    if (cbk::vcomponent(ng, axis) * side < 0.0f) std::swap(tri[1], tri[2]);
                    prims.push_back(makeTriangle(tri[0], tri[1], tri[2]));
                    for (int e = 0; e < 3; ++e)
                        edgeMids->push_back(cbk::vscale(cbk::vadd(tri[e], tri[(e + 1) % 3]), 0.5f));
                }
                vertices->push_back(a);
            }
    };
    for (int axis = 0; axis < 3; ++axis) {
        face(axis, -1.0f);
        face(axis, 1.0f);
    }
    return prims;
}

// Icosahedron subdivided `levels` times, vertices projected to the unit sphere.
std::vector<Primitive> icosphere(int levels, std::vector<Vec3>* vertices,
                                 std::vector<Vec3>* edgeMids) {
    const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
    std::vector<Vec3> v = {vec3(-1, t, 0), vec3(1, t, 0), vec3(-1, -t, 0), vec3(1, -t, 0),
                           vec3(0, -1, t), vec3(0, 1, t), vec3(0, -1, -t), vec3(0, 1, -t),
                           vec3(t, 0, -1), vec3(t, 0, 1), vec3(-t, 0, -1), vec3(-t, 0, 1)};
    std::vector<int> f = {0, 11, 5,  0, 5,  1, 0, 1, 7, 0, 7,  10, 0, 10, 11, 1, 5, 9, 5, 11,
                          4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3,  9,  4, 3,  4,  2, 3, 2, 6, 3,
                          6, 8,  3,  8, 9,  4, 9, 5, 2, 4, 11, 6,  2, 10, 8,  6, 7, 9, 8, 1};
    for (auto& p : v)
        p = cbk::vnormalize(p);
    for (int l = 0; l < levels; ++l) {
        std::vector<int> nf;
        std::vector<std::pair<std::pair<int, int>, int>> cache;
        auto mid = [&](int a, int b) {
            auto key = std::make_pair(std::min(a, b), std::max(a, b));
            for (auto& [k, idx] : cache)
                if (k == key) return idx;
            v.push_back(cbk::vnormalize(cbk::vscale(cbk::vadd(v[a], v[b]), 0.5f)));
            cache.push_back({key, int(v.size()) - 1});
            return int(v.size()) - 1;
        };
        for (size_t i = 0; i < f.size(); i += 3) {
            int a = f[i], b = f[i + 1], c = f[i + 2];
            int ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
            for (int x : {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca})
                nf.push_back(x);
        }
        f = nf;
    }
    std::vector<Primitive> prims;
    for (size_t i = 0; i < f.size(); i += 3) {
        prims.push_back(makeTriangle(v[f[i]], v[f[i + 1]], v[f[i + 2]]));
        for (int e = 0; e < 3; ++e)
            edgeMids->push_back(cbk::vscale(cbk::vadd(v[f[i + e]], v[f[i + (e + 1) % 3]]), 0.5f));
    }
    *vertices = v;
    return prims;
}

bool anyHit(const std::vector<Primitive>& prims, Ray r) {
    for (const auto& p : prims) {
        Hit h;
        if (cbk::intersectPrimitive(&p, r, CB_INFINITY, &h)) return true;
    }
    return false;
}

} // namespace

TEST_CASE("intersect: triangle hit distance and barycentrics") {
    Vec3 p0 = vec3(0, 0, 3), p1 = vec3(4, 0, 3), p2 = vec3(0, 2, 3);
    float t, b1, b2;
    Ray r{vec3(1, 0.5f, 0), vec3(0, 0, 1)};
    REQUIRE(cbk::intersectTriangle(r, CB_INFINITY, p0, p1, p2, &t, &b1, &b2));
    CHECK(t == 3.0f);
    CHECK(b1 == doctest::Approx(0.25f));
    CHECK(b2 == doctest::Approx(0.25f));
    // Reverse direction: behind the origin.
    CHECK_FALSE(
        cbk::intersectTriangle(Ray{r.o, vec3(0, 0, -1)}, CB_INFINITY, p0, p1, p2, &t, &b1, &b2));
    // tMax is exclusive.
    CHECK_FALSE(cbk::intersectTriangle(r, 3.0f, p0, p1, p2, &t, &b1, &b2));
    CHECK(cbk::intersectTriangle(r, std::nextafter(3.0f, 4.0f), p0, p1, p2, &t, &b1, &b2));
    // Outside the triangle.
    CHECK_FALSE(cbk::intersectTriangle(Ray{vec3(3, 1.5f, 0), vec3(0, 0, 1)}, CB_INFINITY, p0, p1,
                                       p2, &t, &b1, &b2));
    // Non-unit, oblique direction: t scales with 1/|d|.
    Ray o{vec3(-1, 0.5f, 1), vec3(2, 0, 2)};
    REQUIRE(cbk::intersectTriangle(o, CB_INFINITY, p0, p1, p2, &t, &b1, &b2));
    CHECK(t == doctest::Approx(1.0f));
    CHECK(b1 == doctest::Approx(0.25f));
}

TEST_CASE("intersect: watertight on closed meshes through vertices and edge midpoints") {
    SUBCASE("grid cube from exact interior points") {
        std::vector<Vec3> verts, mids;
        auto prims = gridCube(8, &verts, &mids);
        std::vector<Vec3> targets = verts;
        targets.insert(targets.end(), mids.begin(), mids.end());
        // The cube's own corners: rays through three faces' shared vertex.
        for (int c = 0; c < 8; ++c)
            targets.push_back(vec3(c & 1 ? 1.f : -1.f, c & 2 ? 1.f : -1.f, c & 4 ? 1.f : -1.f));
        const Vec3 origins[] = {vec3(0, 0, 0), vec3(0.25f, -0.5f, 0.125f),
                                vec3(0.999f, 0.999f, 0.999f), vec3(-0.75f, 0.0f, 0.5f)};
        long rays = 0, escapes = 0;
        for (Vec3 o : origins)
            for (Vec3 target : targets) {
                // Unnormalised, so that from the centre the direction is exact and the ray
                // passes exactly through the vertex or edge.
                Ray r{o, cbk::vsub(target, o)};
                ++rays;
                if (!anyHit(prims, r)) ++escapes;
            }
        CHECK(rays > 5000);
        CHECK(escapes == 0);
    }
    SUBCASE("icosphere, rotated and translated so that vertices are rounded") {
        std::vector<Vec3> verts, mids;
        auto base = icosphere(3, &verts, &mids);
        std::mt19937 rng(11u);
        long rays = 0, escapes = 0;
        for (float scale : {1e-4f, 1.0f, 1e4f}) {
            Vec3 shift = vec3(scale * 3.0f, -scale * 7.0f, scale * 1.5f);
            auto xf = [&](Vec3 p) { return cbk::vadd(cbk::vscale(p, scale), shift); };
            std::vector<Primitive> prims;
            for (const auto& p : base)
                prims.push_back(makeTriangle(xf(cbk::vec3FromArray(p.p0)),
                                             xf(cbk::vec3FromArray(p.p1)),
                                             xf(cbk::vec3FromArray(p.p2))));
            std::vector<Vec3> targets;
            for (Vec3 p : verts)
                targets.push_back(xf(p));
            for (Vec3 p : mids)
                targets.push_back(xf(p));
            for (int k = 0; k < 4; ++k) {
                Vec3 o = xf(cbk::vscale(uniformDirection(rng), 0.5f * float(k) / 3.0f));
                for (Vec3 target : targets) {
                    Ray r{o, cbk::vnormalize(cbk::vsub(target, o))};
                    ++rays;
                    if (!anyHit(prims, r)) ++escapes;
                }
            }
        }
        CHECK(rays > 30000);
        CHECK(escapes == 0);
    }
}

TEST_CASE("intersect: sphere roots against a double-precision reference") {
    std::mt19937 rng(7u);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    int hits = 0, wrongHit = 0, inaccurate = 0;
    double worst = 0.0;
    for (float radius : {1e-4f, 1e-2f, 1.0f, 1e3f})
        for (float dist : {1e1f, 1e3f, 1e5f})
            for (int i = 0; i < 200; ++i) {
                // Centre `dist * radius` away from the origin; aim within 0.9 r of the centre
                // (well away from tangency, where hit/miss is ill-conditioned) or clearly past.
                Vec3 c = cbk::vscale(uniformDirection(rng), dist * radius);
                c = cbk::vadd(c, vec3(0.5f * radius, 0.0f, 0.0f));
                bool aimHit = i % 4 != 0;
                Vec3 off = cbk::vscale(uniformDirection(rng),
                                       radius * (aimHit ? 0.9f * u(rng) : 1.2f + u(rng)));
                Ray r{vec3(0.0f, 0.0f, 0.0f), cbk::vnormalize(cbk::vadd(c, off))};
                double ox = r.o.x, oy = r.o.y, oz = r.o.z;
                double dx = r.d.x, dy = r.d.y, dz = r.d.z;
                double fx = ox - c.x, fy = oy - c.y, fz = oz - c.z;
                double a = dx * dx + dy * dy + dz * dz;
                double b = 2.0 * (fx * dx + fy * dy + fz * dz);
                double cc = fx * fx + fy * fy + fz * fz - double(radius) * radius;
                double disc = b * b - 4.0 * a * cc;
                float t = 0.0f;
                bool hit = cbk::intersectSphere(r, CB_INFINITY, c, radius, &t);
                // The perpendicular offset decides hit or miss unambiguously here.
                bool refHit = disc > 0.0;
                if (hit != refHit) {
                    ++wrongHit;
                    continue;
                }
                if (!hit) continue;
                ++hits;
                double tRef = (-b - std::sqrt(disc)) / (2.0 * a);
                // Error budget: a few ulps of t from the inputs, plus O(eps) of the radius.
                double err = std::fabs(double(t) - tRef);
                double tol = 1e-6 * tRef + 1e-5 * radius;
                worst = std::max(worst, err / tol);
                if (err > tol) ++inaccurate;
            }
    MESSAGE("worst error / tolerance " << worst);
    CHECK(hits > 1200);
    CHECK(wrongHit == 0);
    CHECK(inaccurate == 0);

    // From inside: the far root.
    float t = 0.0f;
    REQUIRE(cbk::intersectSphere(Ray{vec3(0, 0, 0), vec3(0, 0, 1)}, CB_INFINITY, vec3(0, 0, 0.5f),
                                 2.0f, &t));
    CHECK(t == doctest::Approx(2.5f));
    CHECK_FALSE(
        cbk::intersectSphere(Ray{vec3(0, 0, 0), vec3(0, 0, 1)}, 2.5f, vec3(0, 0, 0.5f), 2.0f, &t));
    // Behind the origin.
    CHECK_FALSE(cbk::intersectSphere(Ray{vec3(0, 0, 0), vec3(0, 0, -1)}, CB_INFINITY, vec3(0, 0, 5),
                                     1.0f, &t));
}

TEST_CASE("intersect: surface points lie within their error bounds") {
    std::mt19937 rng(17u);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    int checked = 0, outside = 0;
    for (float scale : {1e-4f, 1.0f, 1e4f}) {
        Vec3 shift = vec3(scale * 100.0f, 0.0f, -scale * 30.0f);
        std::vector<Primitive> prims = {
            makeTriangle(cbk::vadd(shift, vec3(-scale, -scale, 2 * scale)),
                         cbk::vadd(shift, vec3(scale, -scale, 3 * scale)),
                         cbk::vadd(shift, vec3(0, scale, 2.5f * scale))),
            makeSphere(cbk::vadd(shift, vec3(0, 0, 8 * scale)), 2 * scale)};
        SceneView scene = viewOf(prims);
        for (int i = 0; i < 400; ++i) {
            int k = i % 2;
            Vec3 target = k == 0 ? cbk::vadd(shift, vec3((u(rng) - 0.5f) * scale,
                                                         (u(rng) - 0.5f) * scale, 2.5f * scale))
                                 : cbk::vadd(shift, vec3(0, 0, 8 * scale));
            Vec3 o = cbk::vadd(shift, cbk::vscale(uniformDirection(rng), 0.3f * scale));
            Ray r{o, cbk::vnormalize(cbk::vsub(target, o))};
            Hit h;
            if (!cbk::intersectPrimitive(&prims[k], r, CB_INFINITY, &h)) continue;
            h.primitive = k;
            SurfacePoint sp = cbk::surfacePointFromHit(&scene, r, h);
            ++checked;
            // The exact surface must pass through the error box: measure the signed distance
            // of the box corners in double.
            double lo = INFINITY, hi = -INFINITY;
            for (int c = 0; c < 8; ++c) {
                double p[3] = {sp.p.x + (c & 1 ? 1.0 : -1.0) * sp.pError.x,
                               sp.p.y + (c & 2 ? 1.0 : -1.0) * sp.pError.y,
                               sp.p.z + (c & 4 ? 1.0 : -1.0) * sp.pError.z};
                double dist;
                if (k == 0) {
                    const float* a = prims[0].p0;
                    Vec3 n = cbk::vcross(
                        cbk::vsub(cbk::vec3FromArray(prims[0].p1), cbk::vec3FromArray(prims[0].p0)),
                        cbk::vsub(cbk::vec3FromArray(prims[0].p2),
                                  cbk::vec3FromArray(prims[0].p0)));
                    dist = (p[0] - a[0]) * n.x + (p[1] - a[1]) * n.y + (p[2] - a[2]) * n.z;
                } else {
                    const float* cc = prims[1].p0;
                    dist = std::sqrt((p[0] - cc[0]) * (p[0] - cc[0]) +
                                     (p[1] - cc[1]) * (p[1] - cc[1]) +
                                     (p[2] - cc[2]) * (p[2] - cc[2])) -
                           double(prims[1].p1[0]);
                }
                lo = std::min(lo, dist);
                hi = std::max(hi, dist);
            }
            if (!(lo <= 0.0 && hi >= 0.0)) ++outside;
            CHECK(std::fabs(cbk::vlength(sp.ng) - 1.0f) < 1e-6f);
        }
    }
    CHECK(checked > 1000);
    CHECK(outside == 0);
}

namespace {

struct Setting {
    float scale;
    float shift;
};

// Scales 1e-4..1e4, translations up to 1e5 where the primitive is still resolvable in float
// (a 1e-4 triangle at 1e5 would collapse to a point: float spacing there is 0.008).
std::vector<Setting> offsetSettings() {
    std::vector<Setting> s;
    for (float scale : {1e-4f, 1.0f, 1e4f})
        for (float shift : {0.0f, 1e3f * scale, 1e5f})
            if (shift <= 1e5f * scale) s.push_back({scale, shift});
    return s;
}

Vec3 randomPointNear(std::mt19937& rng, Vec3 centre, float size) {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    return cbk::vadd(centre, vec3(u(rng) * size, u(rng) * size, u(rng) * size));
}

} // namespace

TEST_CASE("intersect: spawned rays never re-hit their own surface, at any scale") {
    std::mt19937 rng(123u);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    long spawned = 0, selfHits = 0, sphereInward = 0, badChord = 0;
    for (Setting st : offsetSettings()) {
        Vec3 base = vec3(st.shift, -0.5f * st.shift, 0.25f * st.shift);
        for (int trial = 0; trial < 150; ++trial) {
            std::vector<Primitive> prims;
            if (trial % 2 == 0) {
                Vec3 a = randomPointNear(rng, base, st.scale);
                Vec3 b = randomPointNear(rng, base, st.scale);
                Vec3 c = randomPointNear(rng, base, st.scale);
                if (cbk::vlength(cbk::vcross(cbk::vsub(b, a), cbk::vsub(c, a))) <
                    0.05f * st.scale * st.scale)
                    continue; // sliver
                prims.push_back(makeTriangle(a, b, c));
            } else {
                prims.push_back(makeSphere(randomPointNear(rng, base, st.scale),
                                           st.scale * (0.1f + u(rng)),
                                           trial % 4 == 1 ? 1.0f : -1.0f));
            }
            SceneView scene = viewOf(prims);
            const Primitive& prim = prims[0];
            for (int i = 0; i < 20; ++i) {
                // Hit the primitive from a random point, at a random spot of it.
                Vec3 target;
                if (prim.kind == CB_PRIM_TRIANGLE) {
                    float b1 = u(rng), b2 = u(rng);
                    if (b1 + b2 > 1.0f) b1 = 1.0f - b1, b2 = 1.0f - b2;
                    Vec3 p0 = cbk::vec3FromArray(prim.p0), p1 = cbk::vec3FromArray(prim.p1),
                         p2 = cbk::vec3FromArray(prim.p2);
                    target = cbk::vadd(p0, cbk::vadd(cbk::vscale(cbk::vsub(p1, p0), b1),
                                                     cbk::vscale(cbk::vsub(p2, p0), b2)));
                } else {
                    target =
                        cbk::vmadd(cbk::vec3FromArray(prim.p0), uniformDirection(rng), prim.p1[0]);
                }
                // From outside, or (spheres, every third ray) from inside.
                bool fromInside = prim.kind == CB_PRIM_SPHERE && i % 3 == 0;
                Vec3 o = fromInside ? cbk::vec3FromArray(prim.p0)
                                    : randomPointNear(rng, target, 3.0f * st.scale);
                Ray r{o, cbk::vnormalize(cbk::vsub(target, o))};
                Hit h;
                if (!cbk::intersectPrimitive(&prim, r, CB_INFINITY, &h)) continue;
                h.primitive = 0;
                SurfacePoint sp = cbk::surfacePointFromHit(&scene, r, h);
                for (int j = 0; j < 10; ++j) {
                    Vec3 d = hemisphereDirection(rng, sp.ng);
                    if (j % 2 == 1) d = cbk::vneg(d);
                    Ray s = cbk::spawnRay(sp, d);
                    Hit h2;
                    ++spawned;
                    bool again = cbk::intersectPrimitive(&prim, s, CB_INFINITY, &h2);
                    if (prim.kind == CB_PRIM_TRIANGLE) {
                        if (again) ++selfHits;
                        continue;
                    }
                    // Sphere: leaving towards the outside of the ball never hits it again;
                    // going into the ball it hits the far side, a whole chord away.
                    Vec3 outward = cbk::vscale(sp.ng, prim.p1[1]);
                    if (cbk::vdot(d, outward) > 0.0f) {
                        if (again) ++selfHits;
                    } else {
                        ++sphereInward;
                        float chord = -2.0f * prim.p1[0] * cbk::vdot(d, outward);
                        if (!again || h2.t < 0.5f * chord) ++badChord;
                    }
                }
            }
        }
    }
    MESSAGE(spawned << " spawned rays");
    CHECK(spawned > 20000);
    CHECK(sphereInward > 3000);
    CHECK(selfHits == 0);
    CHECK(badChord == 0);
}

TEST_CASE("intersect: shadow rays between facing surfaces, at any scale") {
    std::mt19937 rng(321u);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    long rays = 0, falseOcclusion = 0, missedOccluder = 0, occluderTests = 0, pointLightFalse = 0;
    for (Setting st : offsetSettings()) {
        Vec3 base = vec3(st.shift, 0.5f * st.shift, -0.75f * st.shift);
        float s = st.scale;
        for (int trial = 0; trial < 40; ++trial) {
            // Two facing surfaces a random distance apart along a random axis frame: a floor
            // (two triangles) and a sphere or a tilted triangle above it, plus an optional
            // occluder half-way.
            Vec3 n = uniformDirection(rng);
            cbk::Frame f = cbk::frameFromNormal(n);
            auto at = [&](float x, float y, float z) {
                return cbk::vadd(base, cbk::frameToWorld(f, vec3(x * s, y * s, z * s)));
            };
            float gap = 0.01f + 2.0f * u(rng);
            std::vector<Primitive> prims = {makeTriangle(at(-1, -1, 0), at(1, -1, 0), at(1, 1, 0)),
                                            makeTriangle(at(-1, -1, 0), at(1, 1, 0), at(-1, 1, 0))};
            if (trial % 2 == 0) {
                prims.push_back(makeSphere(at(0, 0, gap + 0.5f), 0.5f * s));
            } else {
                prims.push_back(
                    makeTriangle(at(-1, -1, gap), at(-1, 1, gap + 0.1f), at(1, 1, gap)));
            }
            cb::Bvh bvh = cb::buildBvh(prims);
            auto wide = cb::collapseBvhWide(bvh);
            SceneView scene = viewOf(prims, &bvh, &wide);
            std::vector<Primitive> withOccluder = prims;
            withOccluder.push_back(
                makeTriangle(at(-3, -3, 0.5f * gap), at(3, -3, 0.5f * gap), at(0, 3, 0.5f * gap)));
            cb::Bvh bvhOcc = cb::buildBvh(withOccluder);
            auto wideOcc = cb::collapseBvhWide(bvhOcc);
            SceneView sceneOcc = viewOf(withOccluder, &bvhOcc, &wideOcc);
            // Points on the floor (hit from above) and on the upper surface (hit from below).
            for (int i = 0; i < 10; ++i) {
                Vec3 o1 = at(0.6f * (2 * u(rng) - 1), 0.6f * (2 * u(rng) - 1), 0.5f * gap);
                Hit h1, h2;
                Ray down{o1, cbk::vneg(n)}, up{o1, n};
                if (!cbk::sceneIntersect(&scene, down, CB_INFINITY, &h1)) continue;
                if (!cbk::sceneIntersect(&scene, up, CB_INFINITY, &h2)) continue;
                SurfacePoint a = cbk::surfacePointFromHit(&scene, down, h1);
                SurfacePoint b = cbk::surfacePointFromHit(&scene, up, h2);
                // Normals facing each other: flip the floor's to the upper side if needed, as a
                // two-sided surface would.
                if (cbk::vdot(a.ng, n) < 0.0f) a.ng = cbk::vneg(a.ng);
                if (cbk::vdot(b.ng, n) > 0.0f) b.ng = cbk::vneg(b.ng);
                for (int dir = 0; dir < 2; ++dir) {
                    const SurfacePoint& from = dir ? b : a;
                    const SurfacePoint& to = dir ? a : b;
                    float tMax = 0.0f;
                    Ray r = cbk::spawnRayTo(from, to.p, to.pError, to.ng, &tMax);
                    ++rays;
                    if (cbk::sceneOccluded(&scene, r, tMax)) ++falseOcclusion;
                    // The same in the scene with the occluder, whose BVH orders primitives
                    // differently: must be blocked - unless the occluder lies within a few
                    // offset distances of an endpoint (far from the origin with a small gap),
                    // where no float-precision method can tell which side it is on.
                    float offFrom = cbk::vdot(cbk::vabs(from.ng), from.pError);
                    float offTo = cbk::vdot(cbk::vabs(to.ng), to.pError);
                    if (0.5f * gap * s > 8.0f * std::max(offFrom, offTo)) {
                        ++occluderTests;
                        if (!cbk::sceneOccluded(&sceneOcc, r, tMax)) ++missedOccluder;
                    }
                    // A point light just off the target surface (beyond its error bound):
                    // zero error, zero normal.
                    Vec3 light = cbk::vmadd(to.p, to.ng, 1e-3f * s + 4.0f * offTo);
                    Ray rp = cbk::spawnRayTo(from, light, vec3(0, 0, 0), vec3(0, 0, 0), &tMax);
                    if (cbk::sceneOccluded(&scene, rp, tMax)) ++pointLightFalse;
                    CHECK(cbk::vlength(cbk::vsub(cbk::vmadd(rp.o, rp.d, tMax), light)) <
                          1e-3f * cbk::vlength(cbk::vsub(light, from.p)));
                }
            }
        }
    }
    MESSAGE(rays << " shadow rays");
    CHECK(rays > 800);
    CHECK(falseOcclusion == 0);
    CHECK(occluderTests > 0.9 * double(rays));
    CHECK(missedOccluder == 0);
    CHECK(pointLightFalse == 0);
}

TEST_CASE("intersect: triangle normals at hits and light samples are unit at scales 1e-18..1e18") {
    // Each triangle's normal against cross(p1 - p0, p2 - p0) normalised in double; before
    // cbk::triangleNormal, float vnormalize(vcross) gave 0 for edges above ~4e9 (|n|^2 overflows)
    // and NaN below ~1e-11 (it underflows), so the surface looked black or NaN at those scales.
    std::mt19937 rng(7u);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    long checked = 0;
    for (double scale : {1e-18, 1e-12, 1e-6, 1.0, 1e6, 1e10, 1e12, 1e18}) {
        for (int trial = 0; trial < 50; ++trial) {
            Vec3 v[3];
            for (Vec3& p : v)
                p = vec3(float(u(rng) * scale), float(u(rng) * scale), float(u(rng) * scale));
            double e1[3], e2[3];
            for (int a = 0; a < 3; ++a) {
                e1[a] = double(cbk::vcomponent(v[1], a)) - cbk::vcomponent(v[0], a);
                e2[a] = double(cbk::vcomponent(v[2], a)) - cbk::vcomponent(v[0], a);
            }
            double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                           e1[0] * e2[1] - e1[1] * e2[0]};
            const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            const double e1len = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
            const double e2len = std::sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
            if (len < 0.05 * e1len * e2len) continue; // sliver: its float normal is inexact
            std::vector<Primitive> prims{makeTriangle(v[0], v[1], v[2])};
            prims[0].light = 0;
            cbk::Light light{};
            light.kind = CB_LIGHT_AREA;
            light.primitive = 0;
            light.area = float(0.5 * len);
            light.pickProbability = 1.0f;
            light.cdf = 1.0f;
            SceneView view = viewOf(prims);
            view.lights = &light;
            view.lightCount = 1;
            Hit hit{};
            hit.primitive = 0;
            hit.b1 = hit.b2 = 1.0f / 3.0f;
            const Vec3 atHit = cbk::surfacePointFromHit(&view, Ray{}, hit).ng;
            cbk::LightSample ls{};
            cbk::lightSamplePoint(&view, 0, 0.3f, 0.6f, &ls);
            for (Vec3 got : {atHit, ls.n}) {
                INFO("scale " << scale << " trial " << trial << ": " << got.x << " " << got.y << " "
                              << got.z);
                for (int a = 0; a < 3; ++a)
                    CHECK(std::fabs(cbk::vcomponent(got, a) - n[a] / len) < 1e-5);
                ++checked;
            }
        }
    }
    CHECK(checked > 500);
}
