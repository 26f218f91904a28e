// Anisotropic GGX (pbrt-v4's "uroughness" and "vroughness" apart on conductors and dielectrics):
// what the parser and the device scene keep and refuse, the shading frame's first axis along
// each shape's dp/du (kernels/cb_intersect.h, surfacePointTangent), and every method's image of
// a brushed plane under a uniform sky against the radiance integrated apart from the kernels'
// GGX, and against PT under an area light.
#include <doctest/doctest.h>

#include "cb_bsdf.h"
#include "cb_bvh_wide.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "test_render_util.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <string>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

const std::string kWorld = "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n";
const std::string kPlane =
    "Shape \"trianglemesh\" \"point3 P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] \"integer indices\" "
    "[0 1 2  0 2 3]\n";

// The device material of a scene whose one shape is kPlane of `material`.
cbk::Material deviceMaterial(const std::string& material, unsigned* features = nullptr) {
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(kWorld + material + kPlane));
    if (features) *features = scene.features;
    REQUIRE(scene.materials.size() == 1);
    return scene.materials[0];
}

// The single-scattering albedo of a GGX reflector of Fresnel 1 seen from unit local direction wo
// (wo.z > 0): the integral of D G2 (wo . h) / wo.z over microfacet normals h whose mirror
// direction wi lies above the surface (Heitz 2014, eqs. 85, 86 and 99), by the midpoint rule in
// (theta, phi) of h. Written apart from kernels/cb_sampling.h.
double ggxAlbedo(const std::array<double, 3>& wo, double ax, double ay) {
    auto lambda = [&](const std::array<double, 3>& w) {
        const double s = (ax * ax * w[0] * w[0] + ay * ay * w[1] * w[1]) / (w[2] * w[2]);
        return (std::sqrt(1.0 + s) - 1.0) / 2.0;
    };
    const int thetas = 240, phis = 480;
    const double dTheta = M_PI / 2.0 / thetas, dPhi = 2.0 * M_PI / phis;
    double sum = 0.0;
    for (int i = 0; i < thetas; ++i) {
        const double theta = (i + 0.5) * dTheta;
        for (int j = 0; j < phis; ++j) {
            const double phi = (j + 0.5) * dPhi;
            const std::array<double, 3> h{std::sin(theta) * std::cos(phi),
                                          std::sin(theta) * std::sin(phi), std::cos(theta)};
            const double cosOh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
            if (cosOh <= 0.0) continue;
            const std::array<double, 3> wi{2.0 * cosOh * h[0] - wo[0], 2.0 * cosOh * h[1] - wo[1],
                                           2.0 * cosOh * h[2] - wo[2]};
            if (wi[2] <= 0.0) continue;
            const double t = h[0] * h[0] / (ax * ax) + h[1] * h[1] / (ay * ay) + h[2] * h[2];
            const double d = 1.0 / (M_PI * ax * ay * t * t);
            const double g2 = 1.0 / (1.0 + lambda(wo) + lambda(wi));
            sum += d * g2 * cosOh / wo[2] * std::sin(theta) * dTheta * dPhi;
        }
    }
    return sum;
}

} // namespace

TEST_CASE("anisotropic roughness: conductors and dielectrics keep uroughness and vroughness") {
    TempDirCleanup cleanup;
    unsigned features = 0;
    cbk::Material m = deviceMaterial("Material \"conductor\" \"float uroughness\" 0.04 "
                                     "\"float vroughness\" 0.25 \"bool remaproughness\" false\n",
                                     &features);
    CHECK(m.alpha == doctest::Approx(0.04));
    CHECK(m.alphaV == doctest::Approx(0.25));
    CHECK((features & CB_FEATURE_ANISOTROPIC) != 0);
    CHECK((features & CB_FEATURE_TEXTURE) != 0); // the (u, v) that give dp/du
    // pbrt-v4 remaps both (alpha = sqrt(roughness)) and keeps both at least 1e-4 where either is
    // rough (TrowbridgeReitzDistribution).
    m = deviceMaterial("Material \"conductor\" \"float uroughness\" 0.04 \"float vroughness\" "
                       "0.25\n");
    CHECK(m.alpha == doctest::Approx(0.2));
    CHECK(m.alphaV == doctest::Approx(0.5));
    m = deviceMaterial("Material \"dielectric\" \"float uroughness\" 0 \"float vroughness\" 0.09\n",
                       &features);
    CHECK(m.alpha == doctest::Approx(1e-4));
    CHECK(m.alphaV == doctest::Approx(0.3));
    CHECK((features & (CB_FEATURE_ANISOTROPIC | CB_FEATURE_ROUGH_DIELECTRIC)) ==
          (CB_FEATURE_ANISOTROPIC | CB_FEATURE_ROUGH_DIELECTRIC));
    // "roughness" is the default of both; eta 1 is no interface, smooth at any roughness.
    m = deviceMaterial(
        "Material \"conductor\" \"float roughness\" 0.09 \"float vroughness\" 0.01\n");
    CHECK(m.alpha == doctest::Approx(0.3));
    CHECK(m.alphaV == doctest::Approx(0.1));
    m = deviceMaterial("Material \"dielectric\" \"float eta\" 1 \"float uroughness\" 0.1 "
                       "\"float vroughness\" 0.2\n");
    CHECK(m.alpha == 0.0f);
    CHECK(m.alphaV == 0.0f);
    // Equal roughnesses, a roughness texture and other kinds: alphaV is alpha, the kernels keep
    // frameFromNormal.
    for (const std::string material :
         {"Material \"conductor\" \"float uroughness\" 0.1 \"float vroughness\" 0.1\n",
          "Texture \"r\" \"float\" \"constant\" \"float value\" 0.1\n"
          "Material \"conductor\" \"texture roughness\" \"r\"\n",
          "Material \"coateddiffuse\" \"float roughness\" 0.2\n", "Material \"diffuse\"\n"}) {
        CAPTURE(material);
        m = deviceMaterial(material, &features);
        CHECK(m.alphaV == m.alpha);
        CHECK((features & CB_FEATURE_ANISOTROPIC) == 0);
    }

    // What cbdpt refuses, naming the file, the line and the parameter.
    std::string e = errorOf(kWorld +
                            "Material \"coateddiffuse\" \"float uroughness\" 0.1 "
                            "\"float vroughness\" 0.2\n" +
                            kPlane);
    CHECK(contains(e, "t.pbrt:3"));
    CHECK(
        contains(e, "anisotropic roughness (uroughness != vroughness) is not supported on a coat"));
    e = errorOf(kWorld +
                "Material \"coatedconductor\" \"float conductor.uroughness\" 0.1 "
                "\"float conductor.vroughness\" 0.2\n" +
                kPlane);
    CHECK(contains(e, "conductor.uroughness != conductor.vroughness"));
    e = errorOf(kWorld +
                "Material \"conductor\" \"float uroughness\" 0.1 "
                "\"float vroughness\" -0.2\n" +
                kPlane);
    CHECK(contains(e, "vroughness must be >= 0, got -0.2"));
    e = deviceErrorOf(kWorld + "Texture \"h\" \"float\" \"constant\" \"float value\" 0.1\n" +
                      "Material \"conductor\" \"float uroughness\" 0.1 \"float vroughness\" 0.2 "
                      "\"texture displacement\" \"h\"\n" +
                      kPlane);
    CHECK(contains(e, "anisotropic roughness with a \"normalmap\" or a \"displacement\" is not "
                      "supported"));
    // pbrt-v4 turns the frame by a mesh's tangents "S", cbdpt by dp/du.
    e = errorOf(kWorld +
                "Material \"conductor\" \"float uroughness\" 0.1 "
                "\"float vroughness\" 0.2\n" +
                "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0] \"integer indices\" "
                "[0 1 2]\n    \"vector3 S\" [1 0 0  1 0 0  1 0 0]\n");
    CHECK(contains(e, "t.pbrt:5"));
    CHECK(contains(e, "\"vector3 S\" (tangents) with an anisotropic material is not supported"));
    // Also where the shape names a material defined after it, or a mix with one.
    e = errorOf(kWorld + "NamedMaterial \"brushed\"\n" +
                "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0] \"integer indices\" "
                "[0 1 2]\n    \"vector3 S\" [1 0 0  1 0 0  1 0 0]\n" +
                "MakeNamedMaterial \"brushed\" \"string type\" \"mix\" \"string materials\" "
                "[\"plain\" \"metal\"]\n" +
                "MakeNamedMaterial \"plain\" \"string type\" \"diffuse\"\n" +
                "MakeNamedMaterial \"metal\" \"string type\" \"conductor\" "
                "\"float uroughness\" 0.1 \"float vroughness\" 0.2\n");
    CHECK(contains(e, "t.pbrt:5"));
    CHECK(contains(e, "with an anisotropic material is not supported"));
    CHECK(errorOf(kWorld + "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0] "
                           "\"integer indices\" [0 1 2] \"vector3 S\" [1 0 0  1 0 0  1 0 0]\n")
              .empty());
    // A disk's (u, v) is not linear over the triangles cbdpt renders it as.
    e = deviceErrorOf(kWorld + "Material \"conductor\" \"float uroughness\" 0.1 "
                               "\"float vroughness\" 0.2\nShape \"disk\"\n");
    CHECK(contains(e, "anisotropic roughness (turned by dp/du), which needs texture coordinates"));
}

// pbrt-v4's BSDF frame is Frame::FromXZ(shading dp/du, ns): on a triangle dp/du from its corners'
// (u, v), made perpendicular to the vertex normals' ns (Gram-Schmidt); on a sphere the direction
// of increasing phi about the object's z axis, turned by the CTM.
TEST_CASE("anisotropic frames: the first axis is dp/du made perpendicular to the shading normal") {
    TempDirCleanup cleanup;
    // A triangle whose (u, v) runs diagonally, vertex normals leaning along x; a sphere turned
    // 90 degrees about x at (5, 0, 0).
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        kWorld +
        "Material \"conductor\" \"float uroughness\" 0.05 \"float vroughness\" 0.3\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0  2 0 0  0 1 0] \"integer indices\" [0 1 2]\n"
        "    \"point2 uv\" [0 0  1 1  -1 1] \"normal N\" [0.3 0 1  0.3 0 1  0.3 0 1]\n"
        "AttributeBegin\nTranslate 5 0 0\nRotate 90 1 0 0\nShape \"sphere\"\nAttributeEnd\n"));
    REQUIRE((scene.features & CB_FEATURE_ANISOTROPIC) != 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    auto hitAt = [&](double x, double y, double z, cbk::Vec3 d) {
        cbk::Ray ray;
        ray.o = cbk::vec3(float(x - scene.origin[0]), float(y - scene.origin[1]),
                          float(z - scene.origin[2]));
        ray.d = d;
        cbk::Hit hit;
        REQUIRE(cbk::sceneIntersect(&view, ray, CB_INFINITY, &hit));
        return cbk::surfacePointFromHit(&view, ray, hit);
    };
    // dp/du from (u, v): p1 - p0 = dpdu + dpdv, p2 - p0 = -dpdu + dpdv, so dpdu = (1, -0.5, 0).
    const cbk::SurfacePoint tri = hitAt(0.5, 0.3, 1.0, cbk::vec3(0.f, 0.f, -1.f));
    const double nx = 0.3 / std::sqrt(1.09), nz = 1.0 / std::sqrt(1.09);
    CHECK(tri.ns.x == doctest::Approx(nx));
    CHECK(tri.tangent.x == doctest::Approx(1.0).epsilon(1e-5));
    CHECK(tri.tangent.y == doctest::Approx(-0.5).epsilon(1e-5));
    CHECK(tri.tangent.z == doctest::Approx(0.0).epsilon(1e-5));
    // The frame's first axis, Gram-Schmidt: dpdu - ns (ns . dpdu), normalised.
    const double dot = 1.0 * nx;
    std::array<double, 3> s{1.0 - nx * dot, -0.5, -nz * dot};
    const double length = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    const cbk::Frame frame = cbk::surfaceFrame(tri);
    CHECK(frame.s.x == doctest::Approx(s[0] / length).epsilon(1e-5));
    CHECK(frame.s.y == doctest::Approx(s[1] / length).epsilon(1e-5));
    CHECK(frame.s.z == doctest::Approx(s[2] / length).epsilon(1e-5));
    CHECK(cbk::vdot(frame.s, frame.t) == doctest::Approx(0.0).epsilon(1e-6));
    CHECK(cbk::vdot(frame.t, frame.n) == doctest::Approx(0.0).epsilon(1e-6));
    // The sphere: object point (x, y, z) is world (x, -z, y) about its centre, and its dp/du
    // (-y, x, 0) world (-y, 0, x): at world offset (a, b, c), (-c, 0, a), normalised.
    for (const auto& d :
         {cbk::vec3(0.f, 0.f, -1.f), cbk::vec3(-1.f, 0.f, 0.f), cbk::vec3(0.f, 1.f, 0.f)}) {
        const cbk::SurfacePoint sp =
            hitAt(5.0 + 0.3 - 3.0 * d.x, 0.2 - 3.0 * d.y, -0.4 - 3.0 * d.z, d);
        const double a = sp.p.x + scene.origin[0] - 5.0, c = sp.p.z + scene.origin[2];
        const double norm = std::sqrt(a * a + c * c);
        CAPTURE(d.x);
        CAPTURE(d.y);
        const cbk::Frame sphereFrame = cbk::surfaceFrame(sp);
        CHECK(sphereFrame.s.x == doctest::Approx(-c / norm).epsilon(1e-4));
        CHECK(sphereFrame.s.y == doctest::Approx(0.0).epsilon(1e-4));
        CHECK(sphereFrame.s.z == doctest::Approx(a / norm).epsilon(1e-4));
    }
}

// A brushed reflector of Fresnel 1 (alpha 0.25 along dp/du, 0.7 along dp/dv) under a uniform sky
// of radiance 1, seen from above at a slant: each pixel's radiance is the albedo of its view
// direction in the local frame. The near half has dp/du along x, across the view; the far half
// along y, along it; a frame turned by 90 degrees would change every band by 4-9%.
TEST_CASE("anisotropic GGX: a brushed plane under a sky, every method, against the integrated "
          "radiance" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double ax = 0.25, ay = 0.7;
    const int size = 12;
    const std::array<double, 3> eye{0.0, -3.0, 2.2}, target{0.0, 0.3, 0.0};
    const double tanHalf = std::tan(20.0 * M_PI / 180.0);
    const cb::DeviceScene scene = cb::buildDeviceScene(cb::parseSceneString(
        fmt::format("LookAt {} {} {}  {} {} {}  0 0 1\nCamera \"perspective\" \"float fov\" 40\n"
                    "Film \"rgb\" \"integer xresolution\" {} \"integer yresolution\" {}\n"
                    "PixelFilter \"box\"\n{}"
                    "Material \"conductor\" \"rgb reflectance\" [1 1 1] \"float uroughness\" {} "
                    "\"float vroughness\" {} \"bool remaproughness\" false\n"
                    "Shape \"bilinearmesh\" \"point3 P\" [-10 -10 0  10 -10 0  -10 0 0  10 0 0]\n"
                    "Shape \"bilinearmesh\" \"point3 P\" [10 0 0  10 10 0  -10 0 0  -10 10 0]\n",
                    eye[0], eye[1], eye[2], target[0], target[1], target[2], size, size, kWorld, ax,
                    ay),
        "t.pbrt"));
    REQUIRE((scene.features & CB_FEATURE_ANISOTROPIC) != 0);
    // Bins: four bands of rows, the channels together (the image is grey).
    const int bands = 4;
    auto binOf = [&](int, int y, int) { return size_t(bands * y / size); };
    // The camera's frame (pbrt-v4's LookAt); the scene is symmetric about x = 0, so which way
    // the image's x runs does not matter.
    std::array<double, 3> forward{target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]};
    auto normalise = [](std::array<double, 3> v) {
        const double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        return std::array<double, 3>{v[0] / l, v[1] / l, v[2] / l};
    };
    auto cross = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
        return std::array<double, 3>{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                                     a[0] * b[1] - a[1] * b[0]};
    };
    forward = normalise(forward);
    const std::array<double, 3> right = normalise(cross(forward, {0.0, 0.0, 1.0}));
    const std::array<double, 3> up = cross(right, forward);
    // expected, and what a frame turned by 90 degrees would give.
    std::array<double, bands> expected{}, turned{}, members{};
    forEachFilmSample(size, 2, tanHalf, [&](int, int y, double fx, double fy) {
        std::array<double, 3> d;
        for (size_t k = 0; k < 3; ++k)
            d[k] = forward[k] + fx * right[k] + fy * up[k];
        d = normalise(d);
        const double t = -eye[2] / d[2];
        const double hitY = eye[1] + t * d[1];
        REQUIRE(t > 0.0);
        REQUIRE(std::fabs(hitY) < 10.0);
        // wo in the local frame (dp/du, n x dp/du, n): near, dp/du = x; far, y.
        const std::array<double, 3> wo{-d[0], -d[1], -d[2]};
        const std::array<double, 3> across{wo[1], -wo[0], wo[2]};
        const size_t band = size_t(bands * y / size);
        expected[band] += ggxAlbedo(hitY < 0.0 ? wo : across, ax, ay);
        turned[band] += ggxAlbedo(hitY < 0.0 ? across : wo, ax, ay);
        members[band] += 1.0;
    });
    for (size_t b = 0; b < bands; ++b) {
        expected[b] /= members[b];
        turned[b] /= members[b];
        // The test can tell a frame turned by 90 degrees.
        CAPTURE(b);
        CHECK(std::fabs(turned[b] / expected[b] - 1.0) > 0.03);
    }
    for (const std::string method : kMethods) {
        CAPTURE(method);
        cb::IntegratorSettings settings = methodSettings(method);
        settings.maxPathVertices = 3;
        checkBinMeans(
            binnedMeans(scene, runtime, settings, 16, method == "mlt" ? 128 : 4, 31u, bands, binOf),
            expected, 2e-3);
    }
}

// Where every strategy matters: brushed floor, wall and block, and a rough anisotropic glass
// sphere, under a disk light.
TEST_CASE("anisotropic GGX: BDPT, CBDPT and MLT agree with PT on brushed metal and rough glass" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt(
        kDiskLight,
        "AttributeBegin\nMaterial \"dielectric\" \"float uroughness\" 0.2 \"float vroughness\" "
        "0.01\nTranslate 0.6 0.35 -0.5\nShape \"sphere\" \"float radius\" 0.35\nAttributeEnd\n",
        "",
        "Material \"conductor\" \"rgb reflectance\" [0.8 0.7 0.5] \"float uroughness\" 0.05 "
        "\"float vroughness\" 0.4 \"bool remaproughness\" false\n");
}
