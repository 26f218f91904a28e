#include "bench/bench_meshes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace cb::bench {

PlyMesh displacedSphere(long triangles, const float centre[3], float radius) {
    // 2 * rings * segments - 2 * segments triangles with segments = 2 * rings.
    int rings = std::max(3, int(std::lround(std::sqrt(double(triangles) / 4.0 + 1.0))));
    int segments = 2 * rings;
    PlyMesh m;
    auto push = [&](double theta, double phi) {
        // Displacement: incommensurate frequencies, at most 15% of the radius.
        double r = radius * (1.0 + 0.08 * std::sin(7.0 * theta) * std::cos(5.0 * phi) +
                             0.05 * std::sin(23.0 * theta + 1.3) * std::sin(19.0 * phi) +
                             0.02 * std::cos(61.0 * phi + 47.0 * theta));
        m.positions.push_back({float(centre[0] + r * std::sin(theta) * std::cos(phi)),
                               float(centre[1] + r * std::cos(theta)),
                               float(centre[2] + r * std::sin(theta) * std::sin(phi))});
    };
    const double pi = 3.14159265358979323846;
    push(0.0, 0.0); // north pole, vertex 0
    for (int i = 1; i < rings; ++i)
        for (int j = 0; j < segments; ++j)
            push(pi * i / rings, 2.0 * pi * j / segments);
    push(pi, 0.0); // south pole
    const unsigned south = unsigned(m.positions.size() - 1);
    auto v = [&](int ring, int seg) {
        return unsigned(1 + (ring - 1) * segments + seg % segments);
    };
    for (int j = 0; j < segments; ++j)
        m.triangles.push_back({0u, v(1, j + 1), v(1, j)});
    for (int i = 1; i < rings - 1; ++i)
        for (int j = 0; j < segments; ++j) {
            m.triangles.push_back({v(i, j), v(i, j + 1), v(i + 1, j + 1)});
            m.triangles.push_back({v(i, j), v(i + 1, j + 1), v(i + 1, j)});
        }
    for (int j = 0; j < segments; ++j)
        m.triangles.push_back({south, v(rings - 1, j), v(rings - 1, j + 1)});
    return m;
}

PlyMesh withRoom(PlyMesh mesh) {
    std::array<float, 3> lo = {INFINITY, INFINITY, INFINITY},
                         hi = {-INFINITY, -INFINITY, -INFINITY};
    for (const auto& p : mesh.positions)
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], p[a]);
            hi[a] = std::max(hi[a], p[a]);
        }
    float half = 0.0f;
    for (int a = 0; a < 3; ++a)
        half = std::max(half, 0.5f * (hi[a] - lo[a]));
    const float cx = 0.5f * (lo[0] + hi[0]), cz = 0.5f * (lo[2] + hi[2]);
    const float x0 = cx - 1.5f * half, x1 = cx + 1.5f * half;
    const float z0 = cz - 1.5f * half, z1 = cz + 1.5f * half;
    const float y0 = lo[1] - 0.01f * half, y1 = y0 + 3.0f * half;
    // A quad a-b-c-d (in order around it) as two triangles.
    auto quad = [&](std::array<float, 3> a, std::array<float, 3> b, std::array<float, 3> c,
                    std::array<float, 3> d) {
        const unsigned first = unsigned(mesh.positions.size());
        mesh.positions.insert(mesh.positions.end(), {a, b, c, d});
        mesh.triangles.push_back({first, first + 1, first + 2});
        mesh.triangles.push_back({first, first + 2, first + 3});
    };
    quad({x0, y0, z0}, {x1, y0, z0}, {x1, y0, z1}, {x0, y0, z1}); // floor
    quad({x0, y0, z0}, {x0, y1, z0}, {x1, y1, z0}, {x1, y0, z0}); // back wall
    quad({x0, y0, z0}, {x0, y0, z1}, {x0, y1, z1}, {x0, y1, z0}); // left wall
    quad({x1, y0, z0}, {x1, y1, z0}, {x1, y1, z1}, {x1, y0, z1}); // right wall
    return mesh;
}

std::vector<cbk::Primitive> meshPrimitives(const PlyMesh& mesh) {
    std::vector<cbk::Primitive> prims;
    prims.reserve(mesh.triangles.size());
    for (const auto& t : mesh.triangles) {
        cbk::Primitive p{};
        p.kind = CB_PRIM_TRIANGLE;
        std::memcpy(p.p0, mesh.positions[t[0]].data(), sizeof p.p0);
        std::memcpy(p.p1, mesh.positions[t[1]].data(), sizeof p.p1);
        std::memcpy(p.p2, mesh.positions[t[2]].data(), sizeof p.p2);
        p.material = 0;
        p.light = -1;
        prims.push_back(p);
    }
    return prims;
}

void writePly(const PlyMesh& mesh, const std::string& path) {
    std::ofstream out(path, std::ios::binary);
    if (!out) throw std::runtime_error("cannot write " + path);
    out << "ply\nformat binary_little_endian 1.0\nelement vertex " << mesh.positions.size()
        << "\nproperty float x\nproperty float y\nproperty float z\nelement face "
        << mesh.triangles.size() << "\nproperty list uchar uint vertex_indices\nend_header\n";
    out.write(reinterpret_cast<const char*>(mesh.positions.data()),
              std::streamsize(mesh.positions.size() * sizeof(mesh.positions[0])));
    for (const auto& t : mesh.triangles) {
        const std::uint8_t three = 3;
        out.write(reinterpret_cast<const char*>(&three), 1);
        out.write(reinterpret_cast<const char*>(t.data()), 12);
    }
    if (!out) throw std::runtime_error("error writing " + path);
}

} // namespace cb::bench
