#include "scene/loop_subdivision.h"

#include "scene/transform.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <unordered_map>

namespace cb {
namespace {

using Point = Vec3d;
using Triangle = std::array<unsigned, 3>;

// a + w b, and a w: the weighted sums Loop's rules are made of.
Point plus(Point a, const Point& b, double w) {
    for (size_t i = 0; i < 3; ++i)
        a[i] += w * b[i];
    return a;
}
Point times(const Point& a, double w) {
    return {a[0] * w, a[1] * w, a[2] * w};
}

int next(int k) {
    return (k + 1) % 3;
}
int previous(int k) {
    return (k + 2) % 3;
}

// A vertex's neighbours in the order pbrt-v4's SDVertex::oneRing visits them (the limit normal's
// sign depends on it), and whether the vertex lies on the mesh's boundary, where the first and
// last are its neighbours along the boundary.
struct Ring {
    std::vector<unsigned> vertices;
    bool boundary = false;
};

// Which triangle lies across each edge, and the triangles around each vertex.
class Topology {
  public:
    Topology(size_t vertexCount, const std::vector<Triangle>& triangles)
        : triangles_(triangles), across_(triangles.size(), {-1, -1, -1}), corner_(vertexCount, -1),
          corners_(vertexCount, 0) {
        std::unordered_map<std::uint64_t, int> directed; // edge (a, b) -> its corner 3 t + k
        directed.reserve(3 * triangles.size());
        for (size_t t = 0; t < triangles.size(); ++t)
            for (int k = 0; k < 3; ++k) {
                const unsigned a = triangles[t][size_t(k)], b = triangles[t][size_t(next(k))];
                if (!directed.emplace(key(a, b), int(3 * t) + k).second)
                    throw std::invalid_argument(fmt::format(
                        "the edge from vertex {} to vertex {} belongs to two triangles that run "
                        "it the same way (triangles wound inconsistently, or more than two on "
                        "one edge), which Loop's rules cannot subdivide",
                        a, b));
                corner_[a] = int(3 * t) + k;
                ++corners_[a];
            }
        for (size_t t = 0; t < triangles.size(); ++t)
            for (int k = 0; k < 3; ++k) {
                const auto it =
                    directed.find(key(triangles[t][size_t(next(k))], triangles[t][size_t(k)]));
                if (it != directed.end()) across_[t][size_t(k)] = it->second / 3;
            }
    }

    // The triangle across edge k of triangle t (from its corner k to corner k + 1); -1: none.
    int across(int t, int k) const { return across_[size_t(t)][size_t(k)]; }
    bool used(unsigned v) const { return corner_[v] >= 0; }

    Ring ring(unsigned v) const {
        Ring r;
        const int start = corner_[v] / 3;
        // Around v by the triangle across the edge leaving v, until back at the start (inside)
        // or off the mesh (on its boundary: then from that last triangle back the other way).
        int t = start, visited = 1;
        for (;;) {
            const int n = across(t, cornerOf(t, v));
            if (n < 0) {
                r.boundary = true;
                break;
            }
            if (n == start) break;
            t = n;
            if (++visited > corners_[v]) throw notOneFan(v);
        }
        if (!r.boundary) {
            t = start;
            do {
                const int k = cornerOf(t, v);
                r.vertices.push_back(triangles_[size_t(t)][size_t(next(k))]);
                t = across(t, k);
            } while (t != start);
            if (int(r.vertices.size()) != corners_[v]) throw notOneFan(v);
            return r;
        }
        r.vertices.push_back(triangles_[size_t(t)][size_t(next(cornerOf(t, v)))]);
        for (visited = 1;; ++visited) {
            const int k = cornerOf(t, v);
            r.vertices.push_back(triangles_[size_t(t)][size_t(previous(k))]);
            t = across(t, previous(k));
            if (t < 0) break;
            if (visited >= corners_[v]) throw notOneFan(v);
        }
        if (visited != corners_[v]) throw notOneFan(v);
        return r;
    }

  private:
    static std::uint64_t key(unsigned a, unsigned b) { return std::uint64_t(a) << 32 | b; }
    int cornerOf(int t, unsigned v) const {
        const Triangle& tri = triangles_[size_t(t)];
        return tri[0] == v ? 0 : tri[1] == v ? 1 : 2;
    }
    static std::invalid_argument notOneFan(unsigned v) {
        return std::invalid_argument(fmt::format("the triangles at vertex {} do not form one fan "
                                                 "(surfaces meeting at a point), which Loop's "
                                                 "rules cannot subdivide",
                                                 v));
    }

    const std::vector<Triangle>& triangles_;
    std::vector<std::array<int, 3>> across_;
    std::vector<int> corner_;
    std::vector<int> corners_;
};

// Loop's weight of each neighbour of an interior vertex of valence n (Warren's 3/16 for 3).
double beta(size_t n) {
    return n == 3 ? 3.0 / 16.0 : 3.0 / (8.0 * double(n));
}

// The vertex and its ring: (1 - n w) p + w times the sum of the ring (an interior vertex), or
// (1 - 2 w) p + w times its two boundary neighbours.
Point weighted(const Point& p, const Ring& r, const std::vector<Point>& positions, double w) {
    if (r.boundary)
        return plus(plus(times(p, 1.0 - 2.0 * w), positions[r.vertices.front()], w),
                    positions[r.vertices.back()], w);
    Point out = times(p, 1.0 - double(r.vertices.size()) * w);
    for (unsigned u : r.vertices)
        out = plus(out, positions[u], w);
    return out;
}

// One subdivision: every triangle into four, the old vertices moved by the even rules and one
// new vertex per edge by the odd ones (pbrt-v4's LoopSubdivide, one level).
void subdivideOnce(std::vector<Point>& positions, std::vector<Triangle>& triangles) {
    const Topology topology(positions.size(), triangles);
    std::vector<Point> out(positions.size());
    for (unsigned v = 0; v < positions.size(); ++v) {
        const Ring r = topology.ring(v);
        out[v] =
            weighted(positions[v], r, positions, r.boundary ? 1.0 / 8.0 : beta(r.vertices.size()));
    }
    // The new vertex of each edge, shared by the triangles on its two sides.
    std::vector<std::array<unsigned, 3>> edgeVertex(triangles.size());
    for (size_t t = 0; t < triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            const int other = topology.across(int(t), k);
            if (other >= 0 && size_t(other) < t) continue; // made from the other side
            const Point& a = positions[triangles[t][size_t(k)]];
            const Point& b = positions[triangles[t][size_t(next(k))]];
            Point p;
            if (other < 0) {
                p = plus(times(a, 0.5), b, 0.5);
            } else {
                const Point& c = positions[triangles[t][size_t(previous(k))]];
                const Triangle& o = triangles[size_t(other)];
                unsigned d = o[0];
                for (unsigned u : o)
                    if (u != triangles[t][size_t(k)] && u != triangles[t][size_t(next(k))]) d = u;
                p = plus(plus(plus(times(a, 3.0 / 8.0), b, 3.0 / 8.0), c, 1.0 / 8.0), positions[d],
                         1.0 / 8.0);
            }
            const unsigned index = unsigned(out.size());
            out.push_back(p);
            edgeVertex[t][size_t(k)] = index;
            if (other >= 0)
                for (int j = 0; j < 3; ++j)
                    if (triangles[size_t(other)][size_t(j)] == triangles[t][size_t(next(k))])
                        edgeVertex[size_t(other)][size_t(j)] = index;
        }
    std::vector<Triangle> children;
    children.reserve(4 * triangles.size());
    for (size_t t = 0; t < triangles.size(); ++t) {
        const Triangle& v = triangles[t];
        const auto& m = edgeVertex[t]; // m[k] on edge (v[k], v[k + 1])
        children.push_back({v[0], m[0], m[2]});
        children.push_back({m[0], v[1], m[1]});
        children.push_back({m[2], m[1], v[2]});
        children.push_back({m[0], m[1], m[2]});
    }
    positions = std::move(out);
    triangles = std::move(children);
}

} // namespace

double loopSubdividedTriangles(std::size_t triangles, int levels) {
    return double(triangles) * std::pow(4.0, levels);
}

SubdivisionSurface loopSubdivide(const std::vector<std::array<double, 3>>& controlPositions,
                                 const std::vector<std::array<unsigned, 3>>& controlTriangles,
                                 int levels) {
    // The vertices the triangles use, in their order.
    std::vector<Point> positions;
    std::vector<Triangle> triangles = controlTriangles;
    std::vector<long> remap(controlPositions.size(), -1);
    for (size_t t = 0; t < triangles.size(); ++t) {
        Triangle& tri = triangles[t];
        if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0])
            throw std::invalid_argument(fmt::format(
                "triangle {} ({} {} {}) repeats a vertex, which Loop's rules cannot subdivide", t,
                tri[0], tri[1], tri[2]));
        for (unsigned& v : tri) {
            if (remap[v] < 0) {
                remap[v] = long(positions.size());
                positions.push_back(controlPositions[v]);
            }
            v = unsigned(remap[v]);
        }
    }
    for (int level = 0; level < levels; ++level)
        subdivideOnce(positions, triangles);

    // The limit surface: each vertex moved by Loop's limit weights (3/5, 1/5, 1/5 on the
    // boundary), then its normal the cross product of the limit tangents from its ring of limit
    // points (pbrt-v4's, which takes the boundary's from Hoppe et al. 1994).
    const Topology topology(positions.size(), triangles);
    std::vector<Ring> rings(positions.size());
    SubdivisionSurface out;
    out.positions.resize(positions.size());
    for (unsigned v = 0; v < positions.size(); ++v) {
        rings[v] = topology.ring(v);
        const size_t n = rings[v].vertices.size();
        out.positions[v] =
            weighted(positions[v], rings[v], positions,
                     rings[v].boundary ? 1.0 / 5.0 : 1.0 / (double(n) + 3.0 / (8.0 * beta(n))));
    }
    out.normals.resize(positions.size());
    const double pi = std::numbers::pi;
    for (unsigned v = 0; v < positions.size(); ++v) {
        const std::vector<unsigned>& ring = rings[v].vertices;
        const size_t n = ring.size();
        auto q = [&](size_t j) { return out.positions[ring[j]]; };
        const Point& p = out.positions[v];
        Point s{0, 0, 0}, t{0, 0, 0};
        if (!rings[v].boundary) {
            for (size_t j = 0; j < n; ++j) {
                s = plus(s, q(j), std::cos(2 * pi * double(j) / double(n)));
                t = plus(t, q(j), std::sin(2 * pi * double(j) / double(n)));
            }
        } else {
            s = plus(q(n - 1), q(0), -1.0);
            if (n == 2) {
                t = plus(plus(q(0), q(1), 1.0), p, -2.0);
            } else if (n == 3) {
                t = plus(q(1), p, -1.0);
            } else if (n == 4) {
                t = plus(plus(plus(plus(times(q(0), -1.0), q(1), 2.0), q(2), 2.0), q(3), -1.0), p,
                         -2.0);
            } else {
                const double theta = pi / double(n - 1);
                t = times(plus(q(0), q(n - 1), 1.0), -std::sin(theta));
                for (size_t k = 1; k + 1 < n; ++k)
                    t = plus(t, q(k), -(2 * std::cos(theta) - 2) * std::sin(double(k) * theta));
            }
        }
        out.normals[v] = vecCross(s, t);
    }
    out.triangles = std::move(triangles);
    return out;
}

} // namespace cb
