// pbrt-v4's "loopsubdiv" shape (src/scene/loop_subdivision.h): Loop's rules against their
// closed forms (limit points that stay put from level to level, the limit normal's direction),
// the mesh sizes, what is refused, and the shape as the parser gives it to the renderer.
#include <doctest/doctest.h>

#include "scene/device_scene.h"
#include "scene/loop_subdivision.h"
#include "scene/scene_desc.h"
#include "scene_files.h"

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

using namespace cbtest::scene_files;

namespace {

using Points = std::vector<std::array<double, 3>>;
using Triangles = std::vector<std::array<unsigned, 3>>;

// A regular octahedron, wound counter-clockwise seen from outside: vertex 0 is +x.
const Points kOctahedron = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
const Triangles kOctahedronFaces = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                    {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};

// Six triangles around a centre lifted to height h, its ring the unit hexagon at z = 0,
// counter-clockwise seen from +z: the centre (vertex 0) is a regular interior vertex, the ring
// boundary vertices.
Points hexagonFan(double h) {
    Points p = {{0, 0, h}};
    for (int j = 0; j < 6; ++j)
        p.push_back({std::cos(j * M_PI / 3), std::sin(j * M_PI / 3), 0});
    return p;
}
Triangles hexagonFanFaces() {
    Triangles t;
    for (unsigned j = 0; j < 6; ++j)
        t.push_back({0, 1 + j, 1 + (j + 1) % 6});
    return t;
}

// The output vertex nearest p.
size_t nearest(const cb::SubdivisionSurface& s, const std::array<double, 3>& p) {
    size_t best = 0;
    double bestDistance = 1e300;
    for (size_t i = 0; i < s.positions.size(); ++i) {
        double d = 0;
        for (size_t c = 0; c < 3; ++c)
            d += (s.positions[i][c] - p[c]) * (s.positions[i][c] - p[c]);
        if (d < bestDistance) bestDistance = d, best = i;
    }
    return best;
}

std::array<double, 3> unit(std::array<double, 3> v) {
    const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return {v[0] / l, v[1] / l, v[2] / l};
}

} // namespace

TEST_CASE("loopsubdiv: limit points and normals against Loop's closed forms") {
    for (int levels = 0; levels <= 3; ++levels) {
        CAPTURE(levels);
        // Each level splits every triangle into four and adds a vertex per edge.
        const cb::SubdivisionSurface octa =
            cb::loopSubdivide(kOctahedron, kOctahedronFaces, levels);
        size_t vertices = 6, edges = 12, faces = 8;
        for (int l = 0; l < levels; ++l) {
            vertices += edges;
            edges = 2 * edges + 3 * faces;
            faces *= 4;
        }
        CHECK(octa.triangles.size() == faces);
        CHECK(octa.positions.size() == vertices);
        CHECK(cb::loopSubdividedTriangles(8, levels) == double(faces));
        // A valence-4 vertex's limit point is (1 - 4 g) p + g (its ring), g = 1 / (4 + 3 /
        // (8 beta)) = 1/8 with beta = 3 / 32: +x goes to (1/2, 0, 0), at every level, since each
        // level keeps the limit surface. Its normal is the cross product of the ring's tangents,
        // which pbrt-v4's ring order turns into the mesh (-x for this outward winding).
        const size_t v = nearest(octa, {0.5, 0, 0});
        CHECK(octa.positions[v][0] == doctest::Approx(0.5).epsilon(1e-12));
        CHECK(std::fabs(octa.positions[v][1]) < 1e-12);
        CHECK(std::fabs(octa.positions[v][2]) < 1e-12);
        const std::array<double, 3> n = unit(octa.normals[v]);
        CHECK(n[0] == doctest::Approx(-1.0).epsilon(1e-12));

        // The regular (valence 6) centre of the fan: limit 1/2 p + 1/12 (its ring), the ring at
        // z = 0, so (0, 0, h/2) at every level; the normal -z by symmetry and winding.
        const double h = 0.8;
        const cb::SubdivisionSurface fan =
            cb::loopSubdivide(hexagonFan(h), hexagonFanFaces(), levels);
        const size_t c = nearest(fan, {0, 0, h / 2});
        CHECK(fan.positions[c][2] == doctest::Approx(h / 2).epsilon(1e-12));
        CHECK(std::fabs(fan.positions[c][0]) < 1e-12);
        const std::array<double, 3> nc = unit(fan.normals[c]);
        CHECK(nc[2] == doctest::Approx(-1.0).epsilon(1e-12));
    }
    // Without subdivision, a boundary vertex moves to 3/5 p + 1/5 its two boundary neighbours:
    // ring vertex (1, 0, 0) to (3/5 + (cos 60 + cos 300) / 5, 0, 0) = (0.8, 0, 0).
    const cb::SubdivisionSurface fan0 = cb::loopSubdivide(hexagonFan(0.8), hexagonFanFaces(), 0);
    CHECK(fan0.positions[1][0] == doctest::Approx(0.8).epsilon(1e-12));
    CHECK(std::fabs(fan0.positions[1][1]) < 1e-12);
    CHECK(std::fabs(fan0.positions[1][2]) < 1e-12);
    // One level's even rule at the centre: (1 - 6/16) p + 1/16 (its ring) = 5/8 p, then the
    // limit rule of the next level brings it back to h/2 (checked above); a flat fan stays flat.
    const cb::SubdivisionSurface flat = cb::loopSubdivide(hexagonFan(0), hexagonFanFaces(), 2);
    for (const auto& p : flat.positions)
        CHECK(std::fabs(p[2]) < 1e-12);
    for (const auto& n : flat.normals) {
        const std::array<double, 3> u = unit(n);
        CHECK(u[2] == doctest::Approx(-1.0).epsilon(1e-9));
    }
    // Vertices no triangle uses are dropped.
    Points extra = kOctahedron;
    extra.push_back({9, 9, 9});
    Triangles shifted = kOctahedronFaces;
    CHECK(cb::loopSubdivide(extra, shifted, 1).positions.size() == 18);
}

TEST_CASE("loopsubdiv: meshes Loop's rules cannot subdivide are refused") {
    auto errorOfMesh = [](const Points& p, const Triangles& t) {
        try {
            cb::loopSubdivide(p, t, 1);
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    Triangles flipped = kOctahedronFaces;
    std::swap(flipped[1][0], flipped[1][1]);
    CHECK(contains(errorOfMesh(kOctahedron, flipped), "wound inconsistently"));
    // Three triangles on one edge.
    CHECK(contains(errorOfMesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}},
                               {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}}),
                   "more than two on one edge"));
    // Two fans meeting at vertex 0.
    CHECK(contains(errorOfMesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}},
                               {{0, 1, 2}, {0, 3, 4}}),
                   "vertex 0 do not form one fan"));
    CHECK(contains(errorOfMesh(kOctahedron, {{0, 2, 2}}), "triangle 0 (0 2 2) repeats a vertex"));
    // Any small mesh of random triangles over six vertices is subdivided or refused: every
    // output triangle indexes an output vertex, and nothing else escapes (the sanitized suites
    // run this too).
    std::mt19937 random(7);
    int subdivided = 0, refused = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        Triangles t(1 + random() % 7);
        for (auto& tri : t)
            for (unsigned& v : tri)
                v = unsigned(random() % 6);
        try {
            const cb::SubdivisionSurface s = cb::loopSubdivide(kOctahedron, t, int(random() % 3));
            for (const auto& tri : s.triangles)
                for (unsigned v : tri)
                    REQUIRE(v < s.positions.size());
            REQUIRE(s.normals.size() == s.positions.size());
            ++subdivided;
        } catch (const std::invalid_argument&) {
            ++refused;
        }
    }
    CHECK(subdivided > 100);
    CHECK(refused > 100);

    const std::string w = "WorldBegin\nShape \"loopsubdiv\" ";
    const std::string octa = "\"point3 P\" [1 0 0 -1 0 0 0 1 0 0 -1 0 0 0 1 0 0 -1] "
                             "\"integer indices\" [0 2 4 2 1 4 1 3 4 3 0 4 2 0 5 1 2 5 3 1 5 0 3 "
                             "5]";
    CHECK(contains(errorOf(w + "\"point3 P\" [0 0 0 1 0 0 0 1 0]\n"),
                   "loopsubdiv needs \"integer indices\""));
    CHECK(contains(errorOf(w + "\"integer levels\" -1 " + octa + "\n"),
                   "t.pbrt:2:37: \"integer levels\" must be >= 0, got -1"));
    CHECK(
        contains(errorOf(w + "\"integer levels\" 12 " + octa + "\n"),
                 "t.pbrt:2:37: \"integer levels\" 12 makes 1.34218e+08 triangles; cbdpt subdivides "
                 "into at most 1.67772e+07"));
    CHECK(contains(errorOf(w + "\"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 1]\n"),
                   "t.pbrt:2:1: loopsubdiv: triangle 0 (0 1 1) repeats a vertex"));
}

TEST_CASE("loopsubdiv: the parser's mesh, its normals and its orientation") {
    const std::string octa = "\"point3 P\" [1 0 0 -1 0 0 0 1 0 0 -1 0 0 0 1 0 0 -1] "
                             "\"integer indices\" [0 2 4 2 1 4 1 3 4 3 0 4 2 0 5 1 2 5 3 1 5 0 3 "
                             "5]";
    // pbrt-v4's default of 3 levels: 8 x 64 triangles, moved by the CTM with their normals.
    cb::SceneDesc s =
        parseInTemp("WorldBegin\nLightSource \"point\"\nTranslate 5 0 0\nScale 2 2 2\n"
                    "Shape \"loopsubdiv\" " +
                    octa + " \"string scheme\" \"loop\"\n");
    REQUIRE(s.meshes.size() == 1);
    const cb::TriangleMeshDesc& m = s.meshes[0];
    CHECK(m.triangles.size() == 512);
    REQUIRE(m.normals.size() == m.positions.size());
    // +x's limit point (1/2, 0, 0) at (6, 0, 0), its normal still -x (a uniform scale).
    size_t v = 0;
    for (size_t i = 0; i < m.positions.size(); ++i)
        if (std::fabs(m.positions[i][0] - 6.0) < 1e-9) v = i;
    CHECK(m.positions[v][0] == doctest::Approx(6.0));
    CHECK(unit(m.normals[v])[0] == doctest::Approx(-1.0));
    CHECK(contains(cb::buildDeviceScene(s).featureNames(), "shading-normals"));
    // ReverseOrientation turns the normals, as for any mesh given "N".
    s = parseInTemp("WorldBegin\nReverseOrientation\nShape \"loopsubdiv\" \"integer levels\" 1 " +
                    octa + "\n");
    REQUIRE(s.meshes.size() == 1);
    int found = 0;
    for (size_t i = 0; i < s.meshes[0].positions.size(); ++i)
        if (std::fabs(s.meshes[0].positions[i][0] - 0.5) < 1e-9) {
            CHECK(unit(s.meshes[0].normals[i])[0] == doctest::Approx(1.0));
            ++found;
        }
    CHECK(found == 1);
}
