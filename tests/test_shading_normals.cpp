// Meshes shaded by their vertex normals (pbrt-v4's "normal N"): the normals' transforms, the
// shading normal at hit points (kernels/cb_intersect.h), and every method's estimate of the
// integral they define (Veach 1997, sec. 5.3; scatterCos in kernels/cb_bsdf.h).
#include <doctest/doctest.h>

#include "cb_bvh_wide.h"
#include "method_checks.h"
#include "scene/scene_desc.h"
#include "scene_files.h"
#include "test_render_util.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

cb::SceneDesc parse(const std::string& body) {
    return cb::parseSceneString("Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
                                "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n" +
                                    body,
                                "t.pbrt");
}

std::array<double, 3> unit(std::array<double, 3> v) {
    const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return {v[0] / l, v[1] / l, v[2] / l};
}

void checkDirection(std::array<double, 3> got, std::array<double, 3> expected, double tolerance) {
    got = unit(got);
    expected = unit(expected);
    for (size_t a = 0; a < 3; ++a)
        CHECK(got[a] == doctest::Approx(expected[a]).scale(1.0).epsilon(tolerance));
}

bool hasNote(const cb::SceneDesc& desc, const std::string& part) {
    return std::any_of(desc.notes.begin(), desc.notes.end(),
                       [&](const std::string& n) { return n.find(part) != std::string::npos; });
}

// An octahedron of radius 1 whose vertex normals point out of its vertices: 55 degrees from
// every face's normal, the strongest shading a convex mesh gets from its normals.
const std::string kOctahedron =
    "Shape \"trianglemesh\" \"point3 P\" [1 0 0  -1 0 0  0 1 0  0 -1 0  0 0 1  0 0 -1] "
    "\"normal N\" [1 0 0  -1 0 0  0 1 0  0 -1 0  0 0 1  0 0 -1] \"integer indices\" "
    "[0 2 4  2 1 4  1 3 4  3 0 4  2 0 5  1 2 5  3 1 5  0 3 5]\n";

} // namespace

TEST_CASE("shading normals: \"normal N\" in world space, through transforms and instances") {
    const cb::SceneDesc desc = parse(
        "AttributeBegin\nScale 2 1 1\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] "
        "\"normal N\" [1 0 1  0 1 1  1 1 1]\nAttributeEnd\n"
        "AttributeBegin\nReverseOrientation\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 "
        "0 1 0] \"normal N\" [0 0 1  0 0 1  0 0 1]\nAttributeEnd\n"
        "ObjectBegin \"tri\"\nRotate 90 0 0 1\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 "
        "0 1 0] \"normal N\" [1 0 1  1 0 1  1 0 1]\nObjectEnd\n"
        "AttributeBegin\nScale 1 4 1\nObjectInstance \"tri\"\nAttributeEnd\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 5 1 0 5 0 1 5]\n");
    REQUIRE(desc.meshes.size() == 4);
    // Normals go through the inverse transpose: diag(1/2, 1, 1) under Scale 2 1 1.
    REQUIRE(desc.meshes[0].normals.size() == 3);
    checkDirection(desc.meshes[0].normals[0], {0.5, 0, 1}, 1e-12);
    checkDirection(desc.meshes[0].normals[1], {0, 1, 1}, 1e-12);
    checkDirection(desc.meshes[0].normals[2], {0.5, 1, 1}, 1e-12);
    // ReverseOrientation negates them, as pbrt-v4's TriangleMesh does.
    checkDirection(desc.meshes[1].normals[0], {0, 0, -1}, 1e-12);
    // An instance: the definition's rotation, then the instance's scale diag(1, 1/4, 1).
    checkDirection(desc.meshes[2].normals[0], {0, 0.25, 1}, 1e-12);
    // A PLY's nx ny nz take N's place, through the CTM as well.
    {
        TempDirCleanup cleanup;
        std::ofstream(tempDir() / "n.ply")
            << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
               "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
               "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
               "0 0 0 1 0 1\n1 0 0 0 1 1\n0 1 0 0 0 1\n3 0 1 2\n";
        const cb::SceneDesc ply = parseInTemp(
            "WorldBegin\nScale 1 1 2\nShape \"plymesh\" \"string filename\" \"n.ply\"\n");
        REQUIRE(ply.meshes.size() == 1);
        REQUIRE(ply.meshes[0].normals.size() == 3);
        checkDirection(ply.meshes[0].normals[0], {1, 0, 0.5}, 1e-12);
        checkDirection(ply.meshes[0].normals[1], {0, 1, 0.5}, 1e-12);
    }
    // No "N": geometric shading.
    CHECK(desc.meshes[3].normals.empty());
    CHECK((cb::buildDeviceScene(desc).features & CB_FEATURE_SHADING_NORMALS) != 0);
    CHECK((cb::buildDeviceScene(parse("Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"))
               .features &
           CB_FEATURE_SHADING_NORMALS) == 0);

    // A bilinear patch's normals: linear over its triangles only where n00 + n11 = n10 + n01.
    const std::string patch = "Shape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0] ";
    CHECK_FALSE(
        hasNote(parse(patch + "\"normal N\" [0 0 1  0.2 0 1  0 0.2 1  0.2 0.2 1]\n"), "bilinear"));
    CHECK(hasNote(parse(patch + "\"normal N\" [0 0 1  0.2 0 1  0 0.2 1  0 0 1]\n"),
                  "interpolated linearly over each of the two triangles"));
    CHECK(hasNote(parse("Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] "
                        "\"vector3 S\" [1 0 0  1 0 0  1 0 0]\n"),
                  "changes none of cbdpt's isotropic materials"));
}

TEST_CASE("shading normals: the interpolated normal at hit points") {
    // A 4 x 4 grid in z = 0 whose normals are an affine field of the object position, n(x, y)
    // = (0.3 x, -0.2 y + 0.1, 1): interpolated by the barycentrics it is that field at the hit,
    // through the CTM's inverse transpose and the BVH's reordering. A mirrored copy, a
    // triangle without normals and a sphere share the scene.
    std::string positions, normals, indices;
    for (int j = 0; j <= 4; ++j)
        for (int i = 0; i <= 4; ++i) {
            const double x = -1.0 + 0.5 * i, y = -1.0 + 0.5 * j;
            positions += fmt::format("{} {} 0  ", x, y);
            normals += fmt::format("{} {} 1  ", 0.3 * x, -0.2 * y + 0.1);
        }
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            const int a = 5 * j + i;
            indices += fmt::format("{} {} {}  {} {} {}  ", a, a + 1, a + 6, a, a + 6, a + 5);
        }
    const std::string grid = "Shape \"trianglemesh\" \"point3 P\" [" + positions +
                             "] \"normal N\" [" + normals + "] \"integer indices\" [" + indices +
                             "]\n";
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parse("Material \"diffuse\"\nAttributeBegin\nScale 2 1 1\n" + grid + "AttributeEnd\n" +
              "AttributeBegin\nTranslate 10 0 0\nScale -1 1 1\n" + grid + "AttributeEnd\n" +
              "Shape \"trianglemesh\" \"point3 P\" [20 -1 0  22 -1 0  20 1 0]\n"
              "AttributeBegin\nTranslate 30 0 0\nShape \"sphere\"\nAttributeEnd\n"));
    REQUIRE((scene.features & CB_FEATURE_SHADING_NORMALS) != 0);
    REQUIRE(scene.shadingNormals.size() == 9 * scene.bvh.primitives.size());
    const cbk::SceneView view = cbtest::hostView(scene);
    struct Probe {
        double x0, x1;
        std::array<double, 3> (*normal)(double X, double Y); // expected ns at world (X, Y, 0)
    };
    const Probe probes[] = {
        // Object x = X / 2; the normal transform diag(1/2, 1, 1).
        {-1.95, 1.95,
         [](double X, double Y) {
             return std::array{0.5 * 0.3 * (X / 2), -0.2 * Y + 0.1, 1.0};
         }},
        // Mirrored: object x = 10 - X, the normal's x negated.
        {9.05, 10.95,
         [](double X, double Y) {
             return std::array{-0.3 * (10 - X), -0.2 * Y + 0.1, 1.0};
         }},
        {20.05, 20.9,
         [](double, double) {
             return std::array{0.0, 0.0, 1.0};
         }},
        {29.6, 30.4,
         [](double X, double Y) {
             const double dx = X - 30, dz = std::sqrt(1 - dx * dx - Y * Y);
             return std::array{dx, Y, dz};
         }},
    };
    std::mt19937 rng(5u);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    int hits = 0;
    for (const Probe& probe : probes)
        for (int i = 0; i < 300; ++i) {
            const double X = probe.x0 + (probe.x1 - probe.x0) * u01(rng);
            const double Y = &probe == &probes[2]   ? -0.95 + 0.9 * u01(rng) * (20.95 - X)
                             : &probe == &probes[3] ? -0.3 + 0.6 * u01(rng)
                                                    : -0.95 + 1.9 * u01(rng);
            CAPTURE(X);
            CAPTURE(Y);
            const auto found = cbtest::surfaceBelow(scene, view, X, Y, 3.0);
            REQUIRE(found);
            const cbk::SurfacePoint& sp = *found;
            checkDirection({sp.ns.x, sp.ns.y, sp.ns.z}, probe.normal(X, Y), 1e-5);
            CHECK(cbk::vlength(sp.ns) == doctest::Approx(1.0).epsilon(1e-6));
            // pbrt-v4's FaceForward: the geometric normal on the shading normal's side.
            CHECK(cbk::vdot(sp.ns, sp.ng) > 0.f);
            ++hits;
        }
    CHECK(hits == 1200);
}

namespace {

// A plane lit straight from above by a distant light of irradiance pi, seen from above, whose
// shading normals all lean 40 degrees from its face's, given by its vertex normals, by a
// normal map of one texel or by a bump map: in the integral the shading normals define (each
// vertex's f times |ns . w| on the light's side) a diffuse plane of albedo rho has radiance rho
// cos 40. The geometric cosine in its place, at an eye vertex or in a light subpath's vertex (whose
// correction |ns . wo| / |ng . wo| is cos 40 here), gives rho. (A uniform sky would not tell
// them apart: |m . w| over any hemisphere integrates to pi for every unit m.) The bump map's
// displacement rises along u at tan 40 per unit of length (a two-texel ramp, clamped, whose
// linear stretch the plane's (u, v) stays within).
enum class Lean { VertexNormals, NormalMap, BumpMap };
const Lean kLeans[] = {Lean::VertexNormals, Lean::NormalMap, Lean::BumpMap};

cb::DeviceScene tiltedPlane(Lean lean) {
    const bool normalMap = lean == Lean::NormalMap;
    const std::string leaning = "0.642788 0 0.766044";
    std::string shape =
        "Shape \"trianglemesh\" \"point3 P\" [-10 -10 0  10 -10 0  -10 10 0  10 10 0] "
        "\"integer indices\" [0 1 3  0 3 2]";
    std::string material = "Material \"diffuse\" \"rgb reflectance\" [0.8 0.5 0.2]";
    if (normalMap) {
        // The texel 2 rgb - 1 is the normal in the frame (dp/du, ns x dp/du, ns): u runs along
        // -y here, so the normal leans toward -y.
        writeImage("lean.exr", 1, 1, [](int, int, int c) {
            return std::array{0.821394f, 0.5f, 0.883022f}[size_t(c)];
        });
        material += " \"string normalmap\" \"lean.exr\"";
        shape += " \"point2 uv\" [1 0  1 1  0 0  0 1]";
    } else if (lean == Lean::BumpMap) {
        // D = 2 scale (u - 1/4) for u in [1/4, 3/4]; u runs 0.3 to 0.7 over the plane's 20
        // units, so dD/dx = 2 scale / 50 = tan 40.
        writeImage("ramp.exr", 2, 1, [](int x, int, int) { return float(x); });
        material = "Texture \"ramp\" \"float\" \"imagemap\" \"string filename\" \"ramp.exr\" "
                   "\"string wrap\" \"clamp\" \"float scale\" 20.97550034\n" +
                   material + " \"texture displacement\" \"ramp\"";
        shape += " \"point2 uv\" [0.3 0.3  0.7 0.3  0.3 0.7  0.7 0.7]";
    } else {
        shape +=
            " \"normal N\" [" + leaning + "  " + leaning + "  " + leaning + "  " + leaning + "]";
    }
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        "LookAt 0 0 3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n"
        "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
        "WorldBegin\nLightSource \"distant\" \"point3 from\" [0 0 1] \"point3 to\" [0 0 0] "
        "\"rgb L\" [1 1 1] \"float scale\" 3.14159265358979\n" +
        material + "\n" + shape + "\n"));
    REQUIRE((scene.features & (lean == Lean::NormalMap ? CB_FEATURE_NORMAL_MAP
                               : lean == Lean::BumpMap ? CB_FEATURE_BUMP_MAP
                                                       : CB_FEATURE_SHADING_NORMALS)) != 0);
    return scene;
}

const double kCos40 = 0.766044443;
const std::array<double, 3> kPlaneRadiance = {0.8 * kCos40, 0.5 * kCos40, 0.2 * kCos40};

} // namespace

TEST_CASE("shading normals: a tilted-normal plane's radiance, every method" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    for (const Lean lean : kLeans) {
        const cb::DeviceScene scene = tiltedPlane(lean);
        for (const std::string method : kMethods) {
            CAPTURE(int(lean));
            CAPTURE(method);
            checkChannelMeans(channelMeans(scene, runtime, methodSettings(method), 4, 300u),
                              kPlaneRadiance, 1e-4);
        }
    }
}

// Each of BDPT's strategies for these paths alone, unweighted, then both weighted: next-event
// estimation (s = 1: the connection's shading ratio at the eye vertex) and light tracing (s = 2,
// t = 1: the light vertex's correction |ns . wo| / |ng . wo|).
TEST_CASE("shading normals: each BDPT strategy alone sees the tilted plane" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    for (const Lean lean : kLeans) {
        const cb::DeviceScene scene = tiltedPlane(lean);
        for (const auto& [s, t, estimates] :
             {std::array<int, 3>{1, 2, 8}, std::array<int, 3>{2, 1, 64},
              std::array<int, 3>{-1, -1, 8}}) {
            CAPTURE(int(lean));
            CAPTURE(s);
            CAPTURE(t);
            cb::IntegratorSettings settings = methodSettings("bdpt");
            settings.debugS = s;
            settings.debugT = t;
            checkChannelMeans(channelMeans(scene, runtime, settings, estimates, 400u),
                              kPlaneRadiance, 1e-4);
        }
    }
}

// Light subpaths bounce off smooth-shaded surfaces before they connect (s >= 3), where the
// correction enters beta: two octahedra shaded as spheres, one of them a light's neighbour.
TEST_CASE("shading normals: BDPT, CBDPT and MLT agree with PT on smooth-shaded meshes" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt(kDiskLight,
                            "AttributeBegin\nTranslate 0.6 0.45 -0.3\nScale 0.45 0.45 0.45\n" +
                                kOctahedron +
                                "AttributeEnd\nAttributeBegin\nTranslate -0.9 0.95 0.2\n"
                                "Scale 0.35 0.35 0.35\n" +
                                kOctahedron + "AttributeEnd\n");
}

namespace {

// The shading normal a ray straight down from (X, Y, 1) finds, on the geometric normal's side.
std::array<double, 3> shadingNormalBelow(const cb::DeviceScene& scene, const cbk::SceneView& view,
                                         double X, double Y) {
    const auto found = cbtest::surfaceBelow(scene, view, X, Y, 1.0);
    REQUIRE(found);
    const cbk::SurfacePoint& sp = *found;
    CHECK(cbk::vdot(sp.ns, sp.ng) > 0.f);
    return {sp.ns.x, sp.ns.y, sp.ns.z};
}

// The device's error for `body` after a diffuse material "bumpy" with `bump` (a normal map or a
// displacement) and a plain one; "" where there is none.
std::string bumpyError(const std::string& bump, const std::string& body) {
    return deviceErrorOf(
        "WorldBegin\nLightSource \"infinite\"\nMakeNamedMaterial \"bumpy\" \"string type\" "
        "\"diffuse\" " +
        bump + "\nMakeNamedMaterial \"plain\" \"string type\" \"diffuse\"\n" + body);
}

} // namespace

TEST_CASE("normal maps: the mapped normal at hit points, and what is refused") {
    TempDirCleanup cleanup;
    // Two texels, the top row (v = 1) leaning along the frame's y, the bottom along its x;
    // bilinear between their centres (v = 3/4 and 1/4) and repeating, as pbrt-v4's NormalMap.
    const std::array<std::array<double, 3>, 2> texels = {std::array{0.0, 0.6, 0.8},
                                                         std::array{0.6, 0.0, 0.8}};
    writeImage("two.exr", 1, 2, [&](int, int y, int c) {
        return float(0.5 * (texels[size_t(y)][size_t(c)] + 1.0));
    });
    const double lean = 1.0 / std::sqrt(1.09); // the vertex normals (0.3, 0, 1), normalised
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n"
        "LightSource \"infinite\" \"rgb L\" [1 1 1]\n"
        "Material \"diffuse\" \"string normalmap\" \"two.exr\"\n"
        // u along +x, v along +y: the frame is (x, y, z).
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0  1 1 0] \"point2 uv\" "
        "[0 0  1 0  0 1  1 1] \"integer indices\" [0 1 3  0 3 2]\n"
        // u along +y, v along +x: the frame is (y, -x, z).
        "Shape \"trianglemesh\" \"point3 P\" [2 0 0  3 0 0  2 1 0  3 1 0] \"point2 uv\" "
        "[0 0  0 1  1 0  1 1] \"integer indices\" [0 1 3  0 3 2]\n"
        // Vertex normals leaning toward +x: z is theirs, x is dp/du = +x made perpendicular.
        "Shape \"trianglemesh\" \"point3 P\" [4 0 0  5 0 0  4 1 0  5 1 0] \"point2 uv\" "
        "[0 0  1 0  0 1  1 1] \"normal N\" [0.3 0 1  0.3 0 1  0.3 0 1  0.3 0 1] "
        "\"integer indices\" [0 1 3  0 3 2]\n"));
    REQUIRE((scene.features & CB_FEATURE_NORMAL_MAP) != 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    auto normalAt = [&](double X, double Y) { return shadingNormalBelow(scene, view, X, Y); };
    // The tangent-space normal at v: the texels' values interpolated, normalised.
    auto tangent = [&](double v) {
        const double w = std::clamp(1.5 - 2.0 * v, 0.0, 1.0); // the bottom row's weight
        std::array<double, 3> n{};
        for (size_t a = 0; a < 3; ++a)
            n[a] = (1.0 - w) * texels[0][a] + w * texels[1][a];
        return unit(n);
    };
    for (const double v : {0.75, 0.25, 0.5, 0.6}) {
        CAPTURE(v);
        const auto t = tangent(v);
        checkDirection(normalAt(0.3, v), {t[0], t[1], t[2]}, 1e-5);
        checkDirection(normalAt(2.0 + v, 0.3), {-t[1], t[0], t[2]}, 1e-5);
        // Frame (x', y, n) with n = (0.3, 0, 1) / |.| and x' = (1, 0, -0.3) / |.|.
        const double nx = 0.3 * lean, nz = lean;
        checkDirection(normalAt(4.3, v), {t[0] * nz + t[2] * nx, t[1], -t[0] * nx + t[2] * nz},
                       1e-5);
    }

    // Refused: a normal map on a disk (its polar (u, v) is not linear over its triangles), a
    // missing file. (In a mix: tests/test_mix_at_point.cpp.)
    auto buildError = [](const std::string& body) {
        return bumpyError("\"string normalmap\" \"two.exr\"", body);
    };
    CHECK(contains(buildError("NamedMaterial \"bumpy\"\nShape \"disk\"\n"),
                   "needs texture coordinates"));
    CHECK(contains(errorOf("WorldBegin\nMaterial \"diffuse\" \"string normalmap\" \"none.png\"\n"),
                   "none.png"));
    // "" is pbrt-v4's "no normal map".
    CHECK(parseInTemp("WorldBegin\nMaterial \"diffuse\" \"string normalmap\" \"\"\n")
              .materials.back()
              .normalMap == -1);
}

// pbrt-v4's BumpMap written out again in double precision: the bumped normal from the shading
// tangents, the shading normal, the normal's derivatives and the displacement's value and
// slopes along u and v.
std::array<double, 3> oracleBump(std::array<double, 3> dpdu, std::array<double, 3> dpdv,
                                 std::array<double, 3> ns, std::array<double, 3> dndu,
                                 std::array<double, 3> dndv, double d, double slopeU,
                                 double slopeV) {
    auto cross = [](std::array<double, 3> a, std::array<double, 3> b) {
        return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                     a[0] * b[1] - a[1] * b[0]};
    };
    std::array<double, 3> u{}, v{};
    for (size_t a = 0; a < 3; ++a) {
        u[a] = dpdu[a] + slopeU * ns[a] + d * dndu[a];
        v[a] = dpdv[a] + slopeV * ns[a] + d * dndv[a];
    }
    const std::array<double, 3> n = unit(cross(u, v));
    return n[2] < 0.0 ? std::array<double, 3>{-n[0], -n[1], -n[2]} : n;
}

TEST_CASE("bump maps: the bumped normal at hit points, and what is refused") {
    TempDirCleanup cleanup;
    // A ramp along the image's x (texels 0 and 1, clamped): D = 2 (u - 1/4) between the texel
    // centres, slope 2 per unit of u.
    writeImage("ramp.exr", 2, 1, [](int x, int, int) { return float(x); });
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n"
        "LightSource \"infinite\" \"rgb L\" [1 1 1]\n"
        "Texture \"ramp\" \"float\" \"imagemap\" \"string filename\" \"ramp.exr\" "
        "\"string wrap\" \"clamp\"\n"
        "Texture \"flat\" \"float\" \"constant\" \"float value\" 0.2\n"
        "Material \"diffuse\" \"texture displacement\" \"ramp\"\n"
        // u along +x, v along +y: dp/du = x, dp/dv = y.
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0  1 1 0] \"point2 uv\" "
        "[0 0  1 0  0 1  1 1] \"integer indices\" [0 1 3  0 3 2]\n"
        // u along +y, v along +x: dp/du = y, dp/dv = x, their cross product -z.
        "Shape \"trianglemesh\" \"point3 P\" [2 0 0  3 0 0  2 1 0  3 1 0] \"point2 uv\" "
        "[0 0  0 1  1 0  1 1] \"integer indices\" [0 1 3  0 3 2]\n"
        // Vertex normals (a u, 0, 1), a = 0.5, and a constant displacement 0.2: only the
        // normal's derivative dn/du = (a, 0, 0) bends the shading normal.
        "Material \"diffuse\" \"texture displacement\" \"flat\"\n"
        "Shape \"trianglemesh\" \"point3 P\" [4 0 0  5 0 0  4 1 0  5 1 0] \"point2 uv\" "
        "[0 0  1 0  0 1  1 1] \"normal N\" [0 0 1  0.5 0 1  0 0 1  0.5 0 1] "
        "\"integer indices\" [0 1 3  0 3 2]\n"));
    REQUIRE((scene.features & CB_FEATURE_BUMP_MAP) != 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    auto normalAt = [&](double X, double Y) { return shadingNormalBelow(scene, view, X, Y); };
    const std::array<double, 3> x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1}, zero{0, 0, 0};
    for (const double t : {0.3, 0.5, 0.7}) {
        CAPTURE(t);
        // The finite difference over 0.0005 of a linear stretch is its slope; the float lookups
        // round at about 1e-4 of it.
        checkDirection(normalAt(t, 0.4), oracleBump(x, y, z, zero, zero, 0.0, 2.0, 0.0), 2e-4);
        checkDirection(normalAt(2.4, t), oracleBump(y, x, z, zero, zero, 0.0, 2.0, 0.0), 2e-4);
        // pbrt-v4's shading tangents with vertex normals: dp/du made perpendicular to ns, and
        // ns x dp/du.
        const std::array<double, 3> ns = unit({0.5 * t, 0.0, 1.0});
        const std::array<double, 3> ts{ns[1] * x[2] - ns[2] * x[1], ns[2] * x[0] - ns[0] * x[2],
                                       ns[0] * x[1] - ns[1] * x[0]};
        const std::array<double, 3> ss{ts[1] * ns[2] - ts[2] * ns[1], ts[2] * ns[0] - ts[0] * ns[2],
                                       ts[0] * ns[1] - ts[1] * ns[0]};
        checkDirection(normalAt(4.0 + t, 0.4),
                       oracleBump(ss, ts, ns, {0.5, 0, 0}, zero, 0.2, 0.0, 0.0), 1e-5);
    }
    // The ramp's flat ends (clamped): no tilt.
    checkDirection(normalAt(0.1, 0.4), z, 1e-6);

    // Parsing: a constant displacement is a 1 x 1 texture, 0 none; with a normal map the
    // displacement is dropped with a note (pbrt-v4 uses the normal map); the errors.
    writeImage("n.exr", 1, 1, [](int, int, int c) { return c == 2 ? 1.f : 0.5f; });
    const cb::SceneDesc s =
        parseInTemp("WorldBegin\nMaterial \"diffuse\" \"float displacement\" 0.25\n"
                    "Material \"diffuse\" \"float displacement\" 0\n"
                    "Texture \"ramp\" \"float\" \"imagemap\" \"string filename\" \"ramp.exr\"\n"
                    "Material \"conductor\" \"texture displacement\" \"ramp\" \"string normalmap\" "
                    "\"n.exr\"\n");
    REQUIRE(s.materials.size() == 3);
    REQUIRE(s.materials[0].displacement >= 0);
    CHECK(s.textures[size_t(s.materials[0].displacement)].rgb == std::vector<float>(3, 0.25f));
    CHECK(s.materials[1].displacement == -1);
    CHECK(s.materials[2].displacement == -1);
    CHECK(s.materials[2].normalMap >= 0);
    CHECK(hasNote(s, "is shaded by its normal map"));
    CHECK(hasNote(s, "over 0.0005 in u and in v"));
    CHECK(contains(errorOf("WorldBegin\nMaterial \"diffuse\" \"texture displacement\" \"h\"\n"),
                   "t.pbrt:2:43: \"texture displacement\" names no float texture \"h\""));
    auto buildError = [](const std::string& body) {
        return bumpyError("\"float displacement\" 0.1", body);
    };
    CHECK(contains(buildError("NamedMaterial \"bumpy\"\nShape \"disk\"\n"),
                   "needs texture coordinates"));
    CHECK((cb::buildDeviceScene(
               parseInTemp("WorldBegin\nLightSource \"infinite\"\n"
                           "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"))
               .features &
           CB_FEATURE_BUMP_MAP) == 0);
}

namespace {

// pbrt-v4's Sphere::InteractionFromIntersection and its transform to world space, written out
// again in double precision: at world point p of a sphere of object radius r centred at c, whose
// CTM is M (world from object, 3 x 3), the shading partials and the geometric normal, flipped
// where `flip` (ReverseOrientation or a mirror).
struct SpherePartials {
    std::array<double, 3> dpdu, dpdv, dndu, dndv, n;
    double u, v;
};

SpherePartials oracleSphere(const std::array<double, 9>& m, std::array<double, 3> c, double r,
                            bool flip, std::array<double, 3> p) {
    using V = std::array<double, 3>;
    const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
                       m[2] * (m[3] * m[7] - m[4] * m[6]);
    // The inverse's transpose (cofactors over the determinant): normals' transform.
    const std::array<double, 9> it = {
        (m[4] * m[8] - m[5] * m[7]) / det, (m[5] * m[6] - m[3] * m[8]) / det,
        (m[3] * m[7] - m[4] * m[6]) / det, (m[2] * m[7] - m[1] * m[8]) / det,
        (m[0] * m[8] - m[2] * m[6]) / det, (m[1] * m[6] - m[0] * m[7]) / det,
        (m[1] * m[5] - m[2] * m[4]) / det, (m[2] * m[3] - m[0] * m[5]) / det,
        (m[0] * m[4] - m[1] * m[3]) / det};
    auto apply = [](const std::array<double, 9>& a, V v) {
        return V{a[0] * v[0] + a[1] * v[1] + a[2] * v[2], a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
                 a[6] * v[0] + a[7] * v[1] + a[8] * v[2]};
    };
    // Object point: M^-1 (p - c) = it^T (p - c).
    const V d{p[0] - c[0], p[1] - c[1], p[2] - c[2]};
    V o{};
    for (int i = 0; i < 3; ++i)
        o[size_t(i)] = it[size_t(i)] * d[0] + it[size_t(3 + i)] * d[1] + it[size_t(6 + i)] * d[2];
    const double zr = std::hypot(o[0], o[1]), cosTheta = o[2] / r;
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
    double phi = std::atan2(o[1], o[0]);
    if (phi < 0.0) phi += 2.0 * M_PI;
    const V dpdu{-2.0 * M_PI * o[1], 2.0 * M_PI * o[0], 0.0};
    const V dpdv{-M_PI * o[2] * o[0] / zr, -M_PI * o[2] * o[1] / zr, M_PI * r * sinTheta};
    SpherePartials s;
    s.u = phi / (2.0 * M_PI);
    s.v = 1.0 - std::acos(std::clamp(cosTheta, -1.0, 1.0)) / M_PI;
    s.dpdu = apply(m, dpdu);
    s.dpdv = apply(m, dpdv);
    s.dndu = apply(it, {dpdu[0] / r, dpdu[1] / r, dpdu[2] / r});
    s.dndv = apply(it, {dpdv[0] / r, dpdv[1] / r, dpdv[2] / r});
    s.n = unit(apply(it, {o[0] / r, o[1] / r, o[2] / r}));
    if (flip)
        for (double& x : s.n)
            x = -x;
    return s;
}

} // namespace

// Spheres' normal and bump maps take pbrt-v4's sphere partials: under a rotation, a uniform scale
// and a mirror, the kernels' dp/du and dp/dv against the oracle's, and against their own (u, v)
// moved along them; the normal-mapped and bumped normals at hit points against pbrt-v4's
// NormalMap and BumpMap on the oracle's partials.
TEST_CASE("normal and bump maps on spheres: pbrt-v4's partials and the mapped normals") {
    TempDirCleanup cleanup;
    // A tangent-space normal leaning along x, and a ramp along u (texels 0 and 1, clamped:
    // 2 (u - 1/4) between the texel centres).
    writeImage("lean.exr", 1, 1, [](int, int, int ch) {
        return float(0.5 * (std::array{0.6, 0.0, 0.8}[size_t(ch)] + 1.0));
    });
    writeImage("ramp.exr", 2, 1, [](int x, int, int) { return float(x); });
    struct Sphere {
        const char* transform;
        std::array<double, 9> m; // world from object
        std::array<double, 3> c;
        double r;
        bool flip;
        const char* material;
    };
    const double s45 = std::sqrt(0.5);
    const Sphere spheres[] = {
        // Object z along world -y: the top seen from above is the object's equator.
        {"Rotate 90 1 0 0\nScale 2 2 2",
         {2, 0, 0, 0, 0, -2, 0, 2, 0},
         {0, 0, 0},
         0.5,
         false,
         "\"string normalmap\" \"lean.exr\""},
        // Mirrored (its normal turns inward, as pbrt-v4's) and rotated about z.
        {"Rotate 45 0 0 1\nScale -1.5 1.5 1.5",
         {-1.5 * s45, -1.5 * s45, 0, -1.5 * s45, 1.5 * s45, 0, 0, 0, 1.5},
         {3, 0, 0},
         0.6,
         true,
         "\"string normalmap\" \"lean.exr\""},
        // Rotated about z, scaled: the ramp's u along the object's phi.
        {"Rotate 40 0 0 1\nScale 1.5 1.5 1.5",
         {1.5 * std::cos(0.6981317007977318), -1.5 * std::sin(0.6981317007977318), 0,
          1.5 * std::sin(0.6981317007977318), 1.5 * std::cos(0.6981317007977318), 0, 0, 0, 1.5},
         {0, 3, 0},
         0.6,
         false,
         "\"texture displacement\" \"ramp\""},
    };
    std::string body = "Texture \"ramp\" \"float\" \"imagemap\" \"string filename\" \"ramp.exr\" "
                       "\"string wrap\" \"clamp\"\n";
    for (const Sphere& s : spheres)
        body += fmt::format("AttributeBegin\nTranslate {} {} {}\n{}\nMaterial \"diffuse\" {}\n"
                            "Shape \"sphere\" \"float radius\" {}\nAttributeEnd\n",
                            s.c[0], s.c[1], s.c[2], s.transform, s.material, s.r);
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parseInTemp("Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
                    "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n" +
                    body));
    REQUIRE((scene.features & CB_FEATURE_NORMAL_MAP) != 0);
    REQUIRE((scene.features & CB_FEATURE_BUMP_MAP) != 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    auto toArray = [](cbk::Vec3 v) { return std::array<double, 3>{v.x, v.y, v.z}; };
    // Points seen from above, away from the poles and from u's seam and, on the ramp's sphere,
    // where the ramp is linear (u in (1/4, 3/4)).
    const std::array<std::array<double, 2>, 3> offsets = {
        std::array{-0.4, 0.1}, std::array{-0.3, -0.4}, std::array{-0.5, -0.2}};
    for (size_t k = 0; k < std::size(spheres); ++k) {
        const Sphere& s = spheres[k];
        const double radius = s.r * std::sqrt(s.m[0] * s.m[0] + s.m[3] * s.m[3] + s.m[6] * s.m[6]);
        for (const auto& offset : offsets) {
            CAPTURE(k);
            CAPTURE(offset[0]);
            CAPTURE(offset[1]);
            const double X = s.c[0] + offset[0] * radius, Y = s.c[1] + offset[1] * radius;
            const auto found = cbtest::surfaceBelow(scene, view, X, Y, 5.0);
            REQUIRE(found);
            const cbk::SurfacePoint& sp = *found;
            REQUIRE(sp.primitive >= 0);
            const std::array<double, 3> p{sp.p.x + scene.origin[0], sp.p.y + scene.origin[1],
                                          sp.p.z + scene.origin[2]};
            const SpherePartials o = oracleSphere(s.m, s.c, s.r, s.flip, p);
            const cbk::Vec3 pLocal = cbk::vsub(sp.p, cbk::vec3(float(s.c[0] - scene.origin[0]),
                                                               float(s.c[1] - scene.origin[1]),
                                                               float(s.c[2] - scene.origin[2])));
            const cbk::ShadingPartials d = cbk::sphereShadingPartials(&view, sp.primitive, pLocal);
            for (size_t a = 0; a < 3; ++a) {
                CHECK(toArray(d.dpdu)[a] == doctest::Approx(o.dpdu[a]).scale(radius).epsilon(1e-5));
                CHECK(toArray(d.dpdv)[a] == doctest::Approx(o.dpdv[a]).scale(radius).epsilon(1e-5));
                CHECK(toArray(d.dndu)[a] == doctest::Approx(o.dndu[a]).scale(1.0).epsilon(1e-5));
                CHECK(toArray(d.dndv)[a] == doctest::Approx(o.dndv[a]).scale(1.0).epsilon(1e-5));
            }
            checkDirection(toArray(sp.ng), o.n, 1e-6);
            CHECK(sp.uv.u == doctest::Approx(o.u).epsilon(1e-5));
            CHECK(sp.uv.v == doctest::Approx(o.v).epsilon(1e-5));
            // Moving along dp/du moves (u, v) by (1, 0) per unit, along dp/dv by (0, 1).
            const float step = 1e-3f;
            for (int along = 0; along < 2; ++along) {
                const cbk::Vec3 moved =
                    cbk::vadd(pLocal, cbk::vscale(along == 0 ? d.dpdu : d.dpdv, step));
                const cbk::TexCoord uv = cbk::sphereTexCoord(
                    &view, sp.primitive, cbk::vscale(moved, float(radius) / cbk::vlength(moved)));
                CHECK((uv.u - sp.uv.u) / step ==
                      doctest::Approx(along == 0 ? 1.0 : 0.0).scale(1.0).epsilon(3e-3));
                CHECK((uv.v - sp.uv.v) / step ==
                      doctest::Approx(along == 1 ? 1.0 : 0.0).scale(1.0).epsilon(3e-3));
            }
            // The mapped normal: pbrt-v4's NormalMap frame (x = dp/du made perpendicular to n),
            // or its BumpMap with the ramp's value and slope 2 along u.
            std::array<double, 3> expected{};
            if (k < 2) {
                std::array<double, 3> x = o.dpdu;
                const double along = x[0] * o.n[0] + x[1] * o.n[1] + x[2] * o.n[2];
                for (size_t a = 0; a < 3; ++a)
                    x[a] -= along * o.n[a];
                x = unit(x);
                for (size_t a = 0; a < 3; ++a)
                    expected[a] = 0.6 * x[a] + 0.8 * o.n[a];
            } else {
                REQUIRE(o.u > 0.26);
                REQUIRE(o.u < 0.74);
                expected =
                    oracleBump(o.dpdu, o.dpdv, o.n, o.dndu, o.dndv, 2.0 * (o.u - 0.25), 2.0, 0.0);
            }
            checkDirection(toArray(sp.ns), expected, 2e-4);
        }
    }
}

// The device's bumped sphere must not depend on what else the kernel compiles: with a second
// sphere whose material has a normal map (out of view, behind the camera), PoCL's work-item loop
// vectoriser once computed the bumped sphere's normals differently (surfacePointMapped,
// cb_intersect.h): where the kernel also held a rough conductor, 2007 of the image's 6912 values
// moved by more than 1e-4. Direct lighting at the first hit only (3 path vertices), so the two
// images agree but for rounding (two values in their last bits here).
TEST_CASE("normal and bump maps on spheres: a normal-mapped material beside leaves the bumps") {
    TempDirCleanup cleanup;
    writeImage("flat.exr", 1, 1, [](int, int, int ch) { return ch == 2 ? 1.f : 0.5f; });
    auto scene = [](const std::string& hiddenMaterial) {
        return cb::buildDeviceScene(parseInTemp(
            "LookAt 0 1.2 -2  0 0.45 0  0 1 0\nCamera \"perspective\" \"float fov\" 30\n"
            "Film \"rgb\" \"integer xresolution\" 48 \"integer yresolution\" 48\nWorldBegin\n"
            "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [6 6 6]\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-0.5 2.2 -0.3  0.5 2.2 -0.3  -0.5 2.2 0.5  "
            "0.5 2.2 0.5]\nAttributeEnd\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-1.5 0 -1.5  1.5 0 -1.5  -1.5 0 1.5  1.5 0 1.5]\n"
            "Texture \"bumps\" \"float\" \"imagemap\" \"string filename\" \"" +
            std::string(CBDPT_SOURCE_DIR) +
            "/scenes/pbrt-v4/textures/heights.png\" "
            "\"string encoding\" \"linear\" "
            "\"float scale\" 0.03\n"
            "AttributeBegin\nMaterial \"diffuse\" \"texture displacement\" \"bumps\"\n"
            "Translate 0 0.45 0\nRotate -60 1 0 0\nRotate 30 0 0 1\nScale 0.45 0.45 0.45\n"
            "Shape \"sphere\"\nAttributeEnd\n"
            "AttributeBegin\nMaterial \"conductor\" \"float roughness\" 0.05\n"
            "Translate 0.6 0.35 0.2\nShape \"sphere\" \"float radius\" 0.35\nAttributeEnd\n"
            "AttributeBegin\nMaterial \"diffuse\" " +
            hiddenMaterial +
            "\nTranslate 0 1.2 -4\nShape \"sphere\" \"float radius\" 0.2\nAttributeEnd\n"));
    };
    const cb::DeviceScene plain = scene(""), mapped = scene("\"string normalmap\" \"flat.exr\"");
    REQUIRE((plain.features & CB_FEATURE_NORMAL_MAP) == 0);
    REQUIRE((mapped.features & CB_FEATURE_NORMAL_MAP) != 0);
    cb::ClRuntime runtime;
    cb::IntegratorSettings settings = methodSettings("pt");
    settings.eyeVertices = 3;
    settings.seed = 5;
    std::vector<float> a, b;
    cb::makeIntegrator(settings, plain, runtime)->renderEstimate(0, a);
    cb::makeIntegrator(settings, mapped, runtime)->renderEstimate(0, b);
    REQUIRE(a.size() == b.size());
    size_t differing = 0, lit = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        differing += std::fabs(a[i] - b[i]) > 1e-4f * (1.f + std::fabs(a[i]));
        lit += a[i] > 0.f;
    }
    CHECK(lit > a.size() / 4); // the bumped sphere fills much of the image
    CHECK(differing == 0);
}
