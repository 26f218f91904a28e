// pbrt-v4's "interface" material: boundaries between media that scatter nothing, which rays and
// shadow rays cross without a vertex. What the parser and the device scene keep and refuse, the
// shadow rays' transmittance through nested media on the host, and every method's images
// against answers computed apart: concentric shells of different media about the camera (the
// wall seen through them, single scattering), a furnace of fogs that do not absorb split by
// interfaces, and BDPT, CBDPT and MLT against PT in a box of fog bounded by an interface.
#include <doctest/doctest.h>

#include "cb_medium.h"
#include "fog_checks.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "test_render_util.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

using namespace cbtest::fog_checks;
using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

// A sphere of `radius` about the origin of the interface material, `inside` within it and
// `outside` around it.
std::string interfaceSphere(const std::string& inside, const std::string& outside, double radius,
                            const std::string& where = "") {
    return fmt::format("AttributeBegin\n{}MediumInterface \"{}\" \"{}\"\nMaterial "
                       "\"interface\"\nShape \"sphere\" \"float radius\" {}\nAttributeEnd\n",
                       where, inside, outside, radius);
}

bool hasNote(const cb::SceneDesc& desc, const std::string& text) {
    return std::any_of(desc.notes.begin(), desc.notes.end(),
                       [&](const std::string& n) { return contains(n, text); });
}

} // namespace

TEST_CASE("interfaces: the device scene keeps them; an area light on one emits nothing") {
    TempDirCleanup cleanup;
    const std::string ink = "MakeNamedMedium \"ink\" \"string type\" \"homogeneous\" \"rgb "
                            "sigma_a\" [1 1 1] \"rgb sigma_s\" [0 0 0]\n";
    // pbrt-v4 takes the deprecated "none" and "" as "interface".
    for (const std::string name : {"interface", "none", ""}) {
        CAPTURE(name);
        const cb::DeviceScene scene = cb::buildDeviceScene(
            parseInTemp(ink + "WorldBegin\nLightSource \"point\"\nMaterial \"" + name +
                        "\"\nMediumInterface \"ink\" \"\"\nShape \"sphere\"\n"));
        CHECK((scene.features & CB_FEATURE_INTERFACE) != 0);
        CHECK(contains(scene.featureNames(), "interface"));
        CHECK(scene.materials.back().kind == CB_MAT_INTERFACE);
        CHECK(scene.materials.back().mediumInside >= 0);
    }
    const cb::DeviceScene plain = cb::buildDeviceScene(parseInTemp(
        ink + "WorldBegin\nLightSource \"point\"\nMaterial \"dielectric\" \"float eta\" 1\n"
              "MediumInterface \"ink\" \"\"\nShape \"sphere\"\n"));
    CHECK((plain.features & CB_FEATURE_INTERFACE) == 0);

    // pbrt-v4 ignores an area light on a shape of "interface" (named before its definition
    // too), with a warning; cbdpt notes it.
    const cb::SceneDesc desc = parseInTemp(
        ink + "WorldBegin\nLightSource \"point\"\nAttributeBegin\nNamedMaterial \"boundary\"\n"
              "AreaLightSource \"diffuse\"\nMediumInterface \"ink\" \"\"\nShape \"sphere\"\n"
              "AttributeEnd\nMakeNamedMaterial \"boundary\" \"string type\" \"interface\"\n");
    const cb::DeviceScene dropped = cb::buildDeviceScene(desc);
    CHECK(dropped.lights.size() == 1);
    CHECK(dropped.lights[0].kind == CB_LIGHT_POINT);
    CHECK(hasNote(desc, "t.pbrt:8: an area light on a shape of the \"interface\" material "
                        "emits nothing"));
}

TEST_CASE("interfaces: what cbdpt refuses, naming the file, line and value") {
    TempDirCleanup cleanup;
    std::string e = errorOf("WorldBegin\nMakeNamedMaterial \"a\" \"string type\" \"interface\"\n"
                            "MakeNamedMaterial \"b\" \"string type\" \"diffuse\"\n"
                            "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
                            "[\"a\" \"b\"]\nNamedMaterial \"m\"\nShape \"sphere\"\n");
    CHECK(contains(e, "t.pbrt:4"));
    CHECK(contains(e, "a mix of an \"interface\" material is not supported"));
    // "interface" takes no parameters (pbrt-v4 reports them unused).
    e = errorOf("WorldBegin\nMaterial \"interface\" \"float eta\" 1.5\nShape \"sphere\"\n");
    CHECK(contains(e, "t.pbrt:2"));
    CHECK(contains(e, "eta"));
}

// Nested spheres of ink about the origin, each boundary an interface, and an opaque ball on the
// +z axis: a shadow ray's transmittance is exp(-sum sigma_a length) over the media it crosses,
// 0 where the ball blocks it or where its last medium reaches a light at infinity.
TEST_CASE("interfaces: shadow rays cross them, each segment in its own medium") {
    TempDirCleanup cleanup;
    const std::array<double, 3> outerInk{1.0, 2.0, 3.0}, innerInk{0.5, 0.25, 0.0};
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        namedMedium("outer", outerInk, {0, 0, 0}, 0) +
        namedMedium("inner", innerInk, {0, 0, 0}, 0) + "WorldBegin\nLightSource \"point\"\n" +
        interfaceSphere("outer", "", 2.0) + interfaceSphere("inner", "outer", 1.0) +
        "AttributeBegin\nMaterial \"diffuse\"\nTranslate 0 0 6\nShape \"sphere\" \"float "
        "radius\" 0.5\nAttributeEnd\n"));
    REQUIRE((scene.features & CB_FEATURE_INTERFACE) != 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    int inner = -1, outer = -1; // the inner sphere's outside is the outer ink, the outer's vacuum
    for (const cbk::Material& m : scene.materials)
        if (m.kind == CB_MAT_INTERFACE) (m.mediumOutside < 0 ? outer : inner) = m.mediumInside;
    REQUIRE(inner >= 0);
    REQUIRE(outer >= 0);
    auto transmittance = [&](std::array<double, 3> from, std::array<double, 3> d, double tMax,
                             bool toInfinity, int medium) {
        cbk::Ray ray;
        ray.o = cbk::vec3(float(from[0] - scene.origin[0]), float(from[1] - scene.origin[1]),
                          float(from[2] - scene.origin[2]));
        ray.d = cbk::vnormalize(cbk::vec3(float(d[0]), float(d[1]), float(d[2])));
        return cbk::sceneTransmittance(&view, ray, float(tMax), toInfinity, medium);
    };
    auto expect = [](const cbk::Spectrum& t, double lengthInner, double lengthOuter,
                     const std::array<double, 3>& a, const std::array<double, 3>& b) {
        for (size_t c = 0; c < 3; ++c)
            CHECK(
                t.c[c] ==
                doctest::Approx(std::exp(-a[c] * lengthInner - b[c] * lengthOuter)).epsilon(1e-5));
    };
    // Out of both spheres into vacuum: 1 in the inner ink, 1 in the outer, 1 in vacuum.
    expect(transmittance({0, 0, 0}, {1, 0, 0}, 3.0, false, inner), 1.0, 1.0, innerInk, outerInk);
    expect(transmittance({0, 0, 0}, {0, 1, 0}, 3.0, true, inner), 1.0, 1.0, innerInk, outerInk);
    // Through the inner sphere from one side of the outer ink to the other.
    expect(transmittance({1.5, 0, 0}, {-1, 0, 0}, 3.0, false, outer), 2.0, 1.0, innerInk, outerInk);
    // Ending inside: the last segment's length only; at infinity in ink, nothing arrives.
    expect(transmittance({0, 0, 0}, {0, 0, -1}, 1.5, false, inner), 1.0, 0.5, innerInk, outerInk);
    const cbk::Spectrum none = transmittance({0, 0, 0}, {0, 0, -1}, 1.5, true, inner);
    CHECK(none.c[0] == 0.0f);
    // The opaque ball blocks; short of it, nothing does.
    const cbk::Spectrum blocked = transmittance({0, 0, 0}, {0, 0, 1}, 10.0, false, inner);
    CHECK(cbk::specIsBlack(blocked));
    expect(transmittance({0, 0, 0}, {0, 0, 1}, 5.0, false, inner), 1.0, 1.0, innerInk, outerInk);
}

// Concentric shells about the camera, each behind an interface: a scattering fog, an ink that
// only absorbs, and a second fog out to the glowing wall, per channel, coloured. Paths of 2
// vertices see the wall through all three (a camera ray whose distance sampling crosses the ink
// between the fogs); paths of 3 add single scattering, whose next-event estimation, connections
// and light tracing cross the shells too, against singleScatteringRadiance.
TEST_CASE("interfaces: every method in shells of fog and ink, against single scattering" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const Rgb fogA{0.1, 0.2, 0.05}, fogS{1.0, 0.6, 0.3}, inkA{0.8, 0.3, 1.2};
    const Rgb fog2A{0.05, 0.1, 0.2}, fog2S{0.4, 0.9, 0.5};
    const double g = 0.5, g2 = -0.3, glow = 2.0;
    const std::string media = namedMedium("fog", fogA, fogS, g) +
                              namedMedium("ink", inkA, {0, 0, 0}, 0) +
                              namedMedium("fog2", fog2A, fog2S, g2);
    const std::string text =
        media +
        "MediumInterface \"\" \"fog\"\nLookAt 0 0 0  0 0 1  0 1 0\n"
        "Camera \"perspective\" \"float fov\" 60\n"
        "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
        "WorldBegin\nAttributeBegin\nMediumInterface \"fog2\" \"\"\n"
        "Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n" +
        fmt::format("AreaLightSource \"diffuse\" \"rgb L\" [{0} {0} {0}] \"bool twosided\" "
                    "true\nShape \"sphere\" \"float radius\" 1.5\nAttributeEnd\n",
                    glow) +
        interfaceSphere("ink", "fog2", 0.9) + interfaceSphere("fog", "ink", 0.5);
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(text));
    REQUIRE((scene.features & CB_FEATURE_INTERFACE) != 0);
    REQUIRE((scene.features & CB_FEATURE_SCATTERING) != 0);
    std::array<Shells, 3> shells;
    for (size_t c = 0; c < 3; ++c)
        shells[c] = {{0.5, 0.9, 1.5},
                     {fogA[c] + fogS[c], inkA[c], fog2A[c] + fog2S[c]},
                     {fogS[c], 0.0, fog2S[c]},
                     {g, 0.0, g2}};
    checkEveryMethodAgainstSingleScattering(scene, runtime, shells, glow, 61u);
}

// A furnace of two fogs that do not absorb, one inside an off-centre interface sphere in the
// other: the radiance is the wall's everywhere, whatever each fog's sigma_s and phase function
// (channels with sigma_s 0 in one fog and not the other included), so any bias in carrying a
// ray's distance sampling across the boundary shows (paths of 24 vertices, as the scattering
// suite's furnace).
TEST_CASE("interfaces: every method in a furnace of two fogs keeps the wall's radiance" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        fogSphereScene(fogMedium({0, 0, 0}, {1.2, 0.5, 0}, 0.3) +
                           namedMedium("fog2", {0, 0, 0}, {0.3, 2.0, 0.8}, -0.4),
                       1.0, 1.5, interfaceSphere("fog2", "fog", 0.4, "Translate 0.1 0.05 0.4\n"))));
    REQUIRE((scene.features & CB_FEATURE_INTERFACE) != 0);
    checkEveryMethodKeepsGlow(scene, runtime, 1.5, 71u);
}

// Every strategy across an interface (checkMethodsAgreeWithPtInFogBox): next-event estimation
// and connections from inside the box to outside and back, light subpaths crossing it.
TEST_CASE("interfaces: BDPT, CBDPT and MLT agree with PT across the boundary of a box of fog" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPtInFogBox("Material \"interface\"\n");
}
