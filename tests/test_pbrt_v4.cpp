// pbrt-v4 compatibility: the directives and parameters a pbrt-v4 file brings (Sampler,
// Integrator, PixelFilter, Accelerator, ColorSpace, Option, Import, TransformBegin, objects,
// named coordinate systems, bilinear patches, PLY faces, film colour parameters) and pbrt-v4's
// light normalisation and film colour (docs/pbrt-v4.md).
#include <doctest/doctest.h>

#include "cb_bsdf.h"
#include "cb_camera.h"
#include "layered_reference.h"
#include "method_checks.h"
#include "scene/scene_desc.h"
#include "scene_builders.h"
#include "source_tree.h"
#include "spectral/named_spectra.h"
#include "spectral/spectral.h"
#include "test_render_util.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <string>
#include <unistd.h>
#include <zlib.h>

using cb::parseSceneString;
using cb::SceneError;
using namespace cbtest::method_checks;

namespace {

const std::string kOptions = "Camera \"perspective\"\n";
const std::string kTri = "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n";

std::string errorOf(const std::string& text) {
    try {
        parseSceneString(text, "t.pbrt");
    } catch (const SceneError& e) {
        return e.what();
    }
    return "";
}

bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

// text is refused with a message that contains every part.
void expectError(const std::string& text, std::initializer_list<const char*> parts) {
    const std::string e = errorOf(text);
    INFO(text << " -> " << e);
    CHECK(!e.empty());
    for (const char* part : parts)
        CHECK(contains(e, part));
}

std::array<double, 3> normalOf(const cb::TriangleMeshDesc& m, size_t t) {
    const auto& tri = m.triangles[t];
    const auto &p0 = m.positions[tri[0]], &p1 = m.positions[tri[1]], &p2 = m.positions[tri[2]];
    const double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    const double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    return {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0]};
}

} // namespace

TEST_CASE("pbrt-v4: Sampler pixelsamples is the default estimate count, reported once") {
    auto s =
        parseSceneString("Sampler \"zsobol\" \"integer pixelsamples\" 64 \"integer seed\" 3\n" +
                             kOptions + "WorldBegin\n",
                         "t.pbrt");
    CHECK(s.sampler.type == "zsobol");
    CHECK(s.sampler.pixelSamples == 64);
    REQUIRE(s.notes.size() == 1);
    CHECK(contains(s.notes[0], "not used"));
    CHECK(contains(s.notes[0], "\"integer seed\""));
    s = parseSceneString("Sampler \"stratified\" \"integer xsamples\" 2 \"integer ysamples\" 3\n"
                         "WorldBegin\n",
                         "t.pbrt");
    CHECK(s.sampler.pixelSamples == 6);
    s = parseSceneString("Sampler \"halton\"\nWorldBegin\n", "t.pbrt");
    CHECK(s.sampler.pixelSamples == 16); // pbrt-v4's default
    s = parseSceneString("WorldBegin\n", "t.pbrt");
    CHECK(s.sampler.type.empty());
    CHECK(s.sampler.pixelSamples == 0);
    CHECK(contains(errorOf("WorldBegin\nSampler \"halton\"\n"), "only allowed before WorldBegin"));
}

TEST_CASE("pbrt-v4: Integrator chooses the method and maxdepth") {
    auto s = parseSceneString("Integrator \"path\" \"integer maxdepth\" 3\nWorldBegin\n", "t.pbrt");
    CHECK(s.integrator.type == "pt");
    CHECK(s.integrator.maxDepth == 3);
    s = parseSceneString("Integrator \"bdpt\"\nWorldBegin\n", "t.pbrt");
    CHECK(s.integrator.type == "bdpt");
    CHECK(s.integrator.maxDepth == 5); // pbrt-v4's default
    s = parseSceneString("Integrator \"mlt\" \"float largestepprobability\" 0.5\nWorldBegin\n",
                         "t.pbrt");
    CHECK(s.integrator.type == "mlt");
    REQUIRE(s.notes.size() == 1);
    CHECK(contains(s.notes[0], "largestepprobability"));
    s = parseSceneString("Integrator \"volpath\"\nWorldBegin\n", "t.pbrt");
    CHECK(s.integrator.type == "pt");
    const std::string e = errorOf("Integrator \"sppm\"\nWorldBegin\n");
    CHECK(contains(e, "t.pbrt:1:12"));
    CHECK(contains(e, "\"path\""));
    CHECK(contains(e, "\"bdpt\""));
    CHECK(contains(e, "\"mlt\""));
    CHECK(
        contains(errorOf("Integrator \"path\" \"integer maxdepth\" -1\nWorldBegin\n"), "maxdepth"));
}

// PixelFilter: tests/test_pixel_filter.cpp.
TEST_CASE("pbrt-v4: ColorSpace, Option") {
    auto s = parseSceneString("ColorSpace \"srgb\"\nWorldBegin\n", "t.pbrt");
    CHECK(s.notes.empty());
    CHECK(contains(errorOf("ColorSpace \"aces2065-1\"\nWorldBegin\n"), "srgb"));
    s = parseSceneString("Option \"disablepixeljitter\" false\n"
                         "Option \"disable_pixel_jitter\" false\nWorldBegin\n",
                         "t.pbrt");
    CHECK(s.notes.size() == 1); // once per option
}

TEST_CASE("pbrt-v4: Option \"name\" value, refused where it would change the image") {
    // pbrt-v4's syntax (parser.cpp, BasicSceneBuilder::Option): a quoted name, then one value.
    const auto s = parseSceneString(
        "Option \"seed\" 5\nOption \"wavefront\" true\nOption \"rendercoordsys\" \"world\"\n"
        "Option \"msereferenceimage\" \"ref.exr\"\nOption \"displacementedgescale\" 2\n"
        "Option \"pixelstats\" true\nOption \"disableTextureFiltering\" true\n"
        "Option \"forcediffuse\" false\nWorldBegin\nOption \"seed\" 6\n",
        "t.pbrt");
    REQUIRE(s.notes.size() == 8); // once per option
    CHECK(contains(s.notes[0], "t.pbrt:1"));
    CHECK(contains(s.notes[0], "no effect"));
    // Options that change pbrt-v4's image are refused: cbdpt does not implement them.
    for (const char* name :
         {"forcediffuse", "disablepixeljitter", "disablewavelengthjitter", "force_diffuse"}) {
        const std::string e = errorOf(std::string("Option \"") + name + "\" true\nWorldBegin\n");
        CHECK(contains(e, "t.pbrt:1:8"));
        CHECK(contains(e, "not supported"));
    }
    // The typed form is an unknown option in pbrt-v4; the message shows the right syntax.
    std::string e = errorOf("Option \"bool forcediffuse\" true\nWorldBegin\n");
    CHECK(contains(e, "t.pbrt:1:8"));
    CHECK(contains(e, "Option \"forcediffuse\" true"));
    CHECK(contains(errorOf("Option \"frobnicate\" 1\nWorldBegin\n"), "unknown option"));
    CHECK(contains(errorOf("Option \"pixelstats\" 1\nWorldBegin\n"), "t.pbrt:1:21"));
    CHECK(contains(errorOf("Option \"seed\" \"five\"\nWorldBegin\n"), "t.pbrt:1:15"));
    CHECK(contains(errorOf("Option \"rendercoordsys\" \"sideways\"\nWorldBegin\n"), "sideways"));
    CHECK(contains(errorOf("Option \"msereferenceimage\" ref\nWorldBegin\n"), "quoted"));
    CHECK(contains(errorOf("Option \"seed\""), "unexpected end of file"));
}

TEST_CASE("pbrt-v4: Import reads the file's shapes like Include") {
    const auto dir =
        std::filesystem::temp_directory_path() / ("cbdpt-import-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "part.pbrt") << kTri;
    std::ofstream(dir / "main.pbrt") << "WorldBegin\nImport \"part.pbrt\"\n";
    const auto s = cb::parseSceneFile((dir / "main.pbrt").string());
    CHECK(s.meshes.size() == 1);
    std::filesystem::remove_all(dir);
}

TEST_CASE("pbrt-v4: uv on a mesh is read, S ignored and reported once") {
    const auto s = parseSceneString(
        "WorldBegin\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"point2 uv\" [0 0 1 0 0 1]\n"
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"vector3 S\" [1 0 0 1 0 0 1 0 "
        "0]\n",
        "t.pbrt");
    REQUIRE(s.meshes.size() == 2);
    CHECK(s.meshes[0].cornerUv == std::vector<std::array<float, 6>>{{0, 0, 1, 0, 0, 1}});
    CHECK(s.meshes[1].cornerUv.empty());
    REQUIRE(s.notes.size() == 1);
    CHECK(contains(s.notes[0], "t.pbrt:3"));
    CHECK(contains(s.notes[0], "\"vector3 S\" is ignored"));
}

TEST_CASE("pbrt-v4: planar bilinear patches become two triangles facing pbrt's normal") {
    // p00, p10, p01, p11 of the unit square in z = 0: pbrt's normal cross(dpdu, dpdv) is +z.
    auto s = parseSceneString("WorldBegin\nShape \"bilinearmesh\" \"point3 P\" "
                              "[0 0 0  1 0 0  0 1 0  1 1 0]\n",
                              "t.pbrt");
    REQUIRE(s.meshes.size() == 1);
    REQUIRE(s.meshes[0].triangles.size() == 2);
    double area = 0.0;
    for (size_t t = 0; t < 2; ++t) {
        const auto n = normalOf(s.meshes[0], t);
        CHECK(n[2] > 0.0);
        area += 0.5 * n[2];
    }
    CHECK(area == doctest::Approx(1.0));
    s = parseSceneString("WorldBegin\nReverseOrientation\nShape \"bilinearmesh\" \"point3 P\" "
                         "[0 0 0  1 0 0  0 1 0  1 1 0]\n",
                         "t.pbrt");
    CHECK(normalOf(s.meshes[0], 0)[2] < 0.0);
    CHECK(contains(errorOf("WorldBegin\nShape \"bilinearmesh\" \"point3 P\" "
                           "[0 0 0  1 0 0  0 1 0  1 1 0.5]\n"),
                   "non-planar"));
    CHECK(contains(errorOf("WorldBegin\nShape \"bilinearmesh\" \"point3 P\" "
                           "[0 0 0  1 0 0  0 1 0  1 1 0] \"integer indices\" [0 1 2]\n"),
                   "multiple of 4"));
}

TEST_CASE("pbrt-v4: object instances are flattened with the instance transform") {
    const auto s = parseSceneString("WorldBegin\n"
                                    "ObjectBegin \"tri\"\n"
                                    "  Translate 0 0 1\n" +
                                        kTri +
                                        "ObjectEnd\n"
                                        "AttributeBegin\n  Translate 10 0 0\n"
                                        "  ObjectInstance \"tri\"\nAttributeEnd\n"
                                        "Scale -1 1 1\nObjectInstance \"tri\"\n",
                                    "t.pbrt");
    REQUIRE(s.meshes.size() == 2); // the definition itself is not drawn
    CHECK(s.meshes[0].positions[1] == std::array<double, 3>{11, 0, 1});
    CHECK(s.meshes[1].positions[1] == std::array<double, 3>{-1, 0, 1});
    // Both face +z: the mirror keeps the surface's side, as pbrt-v4 transforms the normal.
    CHECK(normalOf(s.meshes[0], 0)[2] > 0.0);
    CHECK(normalOf(s.meshes[1], 0)[2] > 0.0);
    CHECK(contains(errorOf("WorldBegin\nObjectInstance \"none\"\n"),
                   "t.pbrt:2:16: unknown object \"none\" (no ObjectBegin defines it)"));
    CHECK(contains(errorOf("WorldBegin\nObjectBegin \"a\"\nObjectBegin \"b\"\n"), "nesting"));
    CHECK(contains(errorOf("WorldBegin\nObjectBegin \"a\"\nAttributeEnd\n"), "ObjectEnd"));
    // Area lights inside an object definition do not emit (pbrt-v4 warns and drops them).
    const auto lit = parseSceneString("WorldBegin\nObjectBegin \"a\"\n"
                                      "AreaLightSource \"diffuse\"\n" +
                                          kTri + "ObjectEnd\nObjectInstance \"a\"\n",
                                      "t.pbrt");
    CHECK(lit.meshes[0].areaLight == -1);
    CHECK(lit.notes.size() == 1);
}

TEST_CASE("pbrt-v4: NamedMaterial and ObjectInstance before their definitions") {
    // pbrt-v4 resolves both names after parsing, so a file may use them before it defines them;
    // the scene must be the one the same file gives with the definitions first.
    const std::string red = "MakeNamedMaterial \"red\" \"string type\" \"diffuse\" "
                            "\"rgb reflectance\" [0.8 0.1 0.1]\n";
    const std::string glass = "MakeNamedMaterial \"glass\" \"string type\" \"dielectric\"\n";
    const std::string object =
        "ObjectBegin \"tri\"\nNamedMaterial \"glass\"\nTranslate 0 0 1\n" + kTri + "ObjectEnd\n";
    const std::string uses =
        "AttributeBegin\nNamedMaterial \"red\"\n" + kTri +
        "Shape \"sphere\" \"float radius\" 2\nAttributeEnd\n" + kTri +
        "AttributeBegin\nTranslate 10 0 0\nObjectInstance \"tri\"\nAttributeEnd\n";
    const auto later = parseSceneString("WorldBegin\n" + uses + object + red + glass, "t.pbrt");
    const auto first = parseSceneString("WorldBegin\n" + red + glass + object + uses, "t.pbrt");
    REQUIRE(later.meshes.size() == 3);
    REQUIRE(first.meshes.size() == 3);
    REQUIRE(later.spheres.size() == 1);
    auto nameOf = [](const cb::SceneDesc& s, int material) {
        REQUIRE(material >= 0);
        REQUIRE(material < static_cast<int>(s.materials.size()));
        return s.materials[static_cast<size_t>(material)].name;
    };
    for (const auto* s : {&later, &first}) {
        CHECK(nameOf(*s, s->meshes[0].material) == "red");
        CHECK(nameOf(*s, s->spheres[0].material) == "red");
        CHECK(nameOf(*s, s->meshes[1].material).empty()); // the default material after the block
        CHECK(nameOf(*s, s->meshes[2].material) == "glass");
        CHECK(s->meshes[2].positions[1] == std::array<double, 3>{11, 0, 1});
    }
    const auto& redDesc = later.materials[static_cast<size_t>(later.meshes[0].material)];
    CHECK(redDesc.kind == cb::MaterialKind::Diffuse);
    CHECK(later.materials[static_cast<size_t>(later.meshes[2].material)].kind ==
          cb::MaterialKind::Dielectric);
    // A name no directive defines is an error where a shape uses it, at the name's place.
    CHECK(contains(errorOf("WorldBegin\nNamedMaterial \"ghost\"\n" + kTri + red),
                   "t.pbrt:2:15: unknown named material \"ghost\""));
    CHECK(errorOf("WorldBegin\nNamedMaterial \"ghost\"\n" + red).empty()); // unused, as pbrt-v4
    CHECK(contains(errorOf("WorldBegin\nObjectInstance \"tri\"\nObjectBegin \"tri2\"\n" + kTri +
                           "ObjectEnd\n"),
                   "t.pbrt:2:16: unknown object \"tri\""));
}

TEST_CASE("pbrt-v4: a mix may name materials defined after it") {
    // pbrt-v4 creates every material after parsing, so a mix's parts may follow it; the scene
    // must be the one the same file gives with the parts first.
    const std::string parts = "MakeNamedMaterial \"red\" \"string type\" \"diffuse\" "
                              "\"rgb reflectance\" [0.8 0.1 0.1]\n"
                              "MakeNamedMaterial \"glass\" \"string type\" \"dielectric\"\n";
    const std::string mix = "MakeNamedMaterial \"blend\" \"string type\" \"mix\" "
                            "\"string materials\" [\"glass\" \"red\"] \"float amount\" 0.25\n"
                            "AttributeBegin\nNamedMaterial \"blend\"\n" +
                            kTri + "AttributeEnd\n";
    const auto later = parseSceneString("WorldBegin\n" + mix + parts, "t.pbrt");
    const auto first = parseSceneString("WorldBegin\n" + parts + mix, "t.pbrt");
    for (const auto* s : {&later, &first}) {
        REQUIRE(s->meshes.size() == 1);
        const auto& blend = s->materials.at(static_cast<size_t>(s->meshes[0].material));
        CHECK(blend.name == "blend");
        REQUIRE(blend.kind == cb::MaterialKind::Mix);
        CHECK(s->materials.at(static_cast<size_t>(blend.mix[0])).name == "glass");
        CHECK(s->materials.at(static_cast<size_t>(blend.mix[1])).name == "red");
        CHECK(blend.amount == doctest::Approx(0.25f));
    }
    // As pbrt-v4, a part nothing defines is an error even where no shape uses the mix, at the
    // part's name; a part that is a mix defined later is found.
    CHECK(contains(
        errorOf("WorldBegin\nMaterial \"mix\" \"string materials\" [\"red\" \"ghost\"]\n" + parts),
        "t.pbrt:2:42: unknown named material \"ghost\" in mix"));
    const auto nested = parseSceneString(
        "WorldBegin\nMaterial \"mix\" \"string materials\" [\"red\" \"m\"]\n" + parts +
            "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
            "[\"red\" \"glass\"]\n",
        "t.pbrt");
    CHECK(nested.materials.at(size_t(nested.materials[0].mix[1])).name == "m");
}

TEST_CASE("pbrt-v4: CoordinateSystem and CoordSysTransform, camera included") {
    auto s = parseSceneString("WorldBegin\nTranslate 5 0 0\nCoordinateSystem \"here\"\n"
                              "Identity\nCoordSysTransform \"here\"\n" +
                                  kTri,
                              "t.pbrt");
    CHECK(s.meshes[0].positions[1] == std::array<double, 3>{6, 0, 0});
    // "camera" is the camera's frame: a point at its origin lands at the eye.
    s = parseSceneString("LookAt 1 2 3  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n"
                         "CoordSysTransform \"camera\"\n"
                         "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n",
                         "t.pbrt");
    for (int a = 0; a < 3; ++a)
        CHECK(s.meshes[0].positions[0][a] == doctest::Approx(a + 1.0));
    CHECK(contains(errorOf("WorldBegin\nCoordSysTransform \"nowhere\"\n"),
                   "unknown coordinate system"));
}

TEST_CASE("pbrt-v4: rgb film colour parameters and the camera's shutter") {
    auto s = parseSceneString("Camera \"perspective\" \"float shutteropen\" 0 "
                              "\"float shutterclose\" 0.5\n"
                              "Film \"rgb\" \"float iso\" 400 \"float whitebalance\" 5000 "
                              "\"bool savefp16\" false \"string sensor\" \"cie1931\"\nWorldBegin\n",
                              "t.pbrt");
    CHECK(s.film.iso == 400.0);
    CHECK(s.film.whiteBalance == 5000.0);
    CHECK(s.film.exposureTime == 0.5);
    CHECK_FALSE(s.film.saveFp16);
    CHECK(s.film.saveFp16Given);
    CHECK(contains(errorOf("Film \"rgb\" \"string sensor\" \"canon_eos_10d\"\nWorldBegin\n"),
                   "unknown sensor"));
    CHECK(contains(errorOf("Film \"rgb\" \"float maxcomponentvalue\" 0\nWorldBegin\n"),
                   "maxcomponentvalue\" 0 must be positive"));
    CHECK(contains(errorOf("Film \"rgb\" \"float iso\" 0\nWorldBegin\n"), "iso"));
    // pbrt-v4's "gbuffer" film: the rgb film's image (and parameters) plus geometry channels,
    // which cbdpt does not write (a note says so).
    s = parseSceneString("Film \"gbuffer\" \"integer xresolution\" 20 \"float iso\" 200 "
                         "\"string coordinatesystem\" \"world\" \"string filename\" \"g.exr\"\n"
                         "WorldBegin\n",
                         "t.pbrt");
    CHECK(s.film.width == 20);
    CHECK(s.film.iso == 200.0);
    CHECK(s.film.filename == "g.exr");
    REQUIRE(s.notes.size() == 1);
    CHECK(contains(s.notes[0], "t.pbrt:1: Film \"gbuffer\" renders as \"rgb\""));
    CHECK(contains(errorOf("Film \"gbuffer\" \"string coordinatesystem\" \"screen\"\nWorldBegin\n"),
                   "t.pbrt:1:42: unknown \"string coordinatesystem\" \"screen\""));
    CHECK(contains(errorOf("Film \"gbuffer\" \"float gamma\" 2\nWorldBegin\n"),
                   "unknown or unsupported parameter \"float gamma\" for Film \"gbuffer\""));
}

TEST_CASE("pbrt-v4: light spectra are divided by their luminance integral") {
    // pbrt-v4's CIE_Y_integral: the 1 nm sum of the CIE 1931 y-bar table over 360-830 nm, which
    // is SpectrumToPhotometric of a flat spectrum of 1. The CMF fit gives it within 0.1%.
    CHECK(cb::photometricIntegral({{360.f, 1.f}, {830.f, 1.f}}) ==
          doctest::Approx(106.856895).epsilon(1e-3));
    // Only the part inside the samples counts: pbrt-v4's inline spectra are zero outside.
    CHECK(cb::photometricIntegral({{555.f, 1.f}, {556.f, 1.f}}) ==
          doctest::Approx(1.0).epsilon(2e-3)); // y-bar is 1 at 555 nm
    const auto s = parseSceneString("WorldBegin\n"
                                    "AreaLightSource \"diffuse\" \"spectrum L\" [400 2 700 2] "
                                    "\"float scale\" 3\n" +
                                        kTri +
                                        "LightSource \"point\" \"rgb I\" [1 1 1] "
                                        "\"float power\" 100\n"
                                        "LightSource \"point\" \"spectrum I\" [500 1 600 1]\n",
                                    "t.pbrt");
    const double flat400to700 = cb::photometricIntegral({{400.f, 1.f}, {700.f, 1.f}});
    CHECK(s.areaLights[0].scale == doctest::Approx(3.0 / (2.0 * flat400to700)).epsilon(1e-6));
    // "power" is luminous power; a unit point light emits 4 pi.
    CHECK(s.pointLights[0].scale == doctest::Approx(100.0 / (4.0 * M_PI)).epsilon(1e-6));
    CHECK(s.pointLights[1].scale ==
          doctest::Approx(1.0 / cb::photometricIntegral({{500.f, 1.f}, {600.f, 1.f}})));
    CHECK(
        contains(errorOf("WorldBegin\nAreaLightSource \"diffuse\" \"spectrum L\" [300 1 350 1]\n"),
                 "zero luminance"));
}

TEST_CASE("pbrt-v4: blackbody spectra, Planck's law at a temperature, lights normalised") {
    const auto s = parseSceneString("WorldBegin\n"
                                    "AreaLightSource \"diffuse\" \"blackbody L\" 2700 "
                                    "\"float scale\" 3\n" +
                                        kTri + "LightSource \"point\" \"blackbody I\" [6500]\n",
                                    "t.pbrt");
    CHECK(s.usesSpectra);
    REQUIRE(!s.areaLights[0].radiance.isRgb);
    CHECK(s.areaLights[0].radiance.samples == cb::blackbody(2700.0));
    CHECK(s.pointLights[0].intensity.samples == cb::blackbody(6500.0));
    // As any light spectrum: divided by its luminance integral, so its luminance is its scale.
    CHECK(s.areaLights[0].scale ==
          doctest::Approx(3.0 / cb::photometricIntegral(cb::blackbody(2700.0))).epsilon(1e-6));
    // One temperature in kelvin (pbrt-v3's [T scale] is refused, as pbrt-v4 without --upgrade).
    CHECK(contains(errorOf("WorldBegin\nLightSource \"point\" \"blackbody I\" [3000 2]\n"),
                   "t.pbrt:2:21: parameter \"blackbody I\" of LightSource \"point\" expects one "
                   "temperature in kelvin, got 2"));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"point\" \"blackbody I\" -5\n"),
                   "t.pbrt:2:35: parameter \"blackbody I\" must be a temperature in (0, 1e+09] "
                   "kelvin, got -5"));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"point\" \"blackbody I\" 1e10\n"),
                   "(0, 1e+09]"));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"point\" \"blackbody I\" \"hot\"\n"),
                   "expects a temperature in kelvin"));
    // A temperature with no visible light leaves nothing to normalise.
    CHECK(contains(errorOf("WorldBegin\nLightSource \"point\" \"blackbody I\" 1\n"),
                   "zero luminance"));
    // A dielectric's eta is one number or a spectrum (dispersion), never a blackbody.
    CHECK(contains(errorOf("WorldBegin\nMaterial \"dielectric\" \"blackbody eta\" 3000\n"),
                   "\"float eta\" or \"spectrum eta\", not blackbody"));
}

TEST_CASE("pbrt-v4: standard illuminants by name, lights normalised") {
    const auto s = parseSceneString("WorldBegin\n"
                                    "AreaLightSource \"diffuse\" \"spectrum L\" \"stdillum-F11\" "
                                    "\"float scale\" 2\n" +
                                        kTri +
                                        "LightSource \"distant\" \"spectrum L\" \"stdillum-A\"\n"
                                        "LightSource \"point\" \"spectrum I\" \"illum-acesD60\"\n",
                                    "t.pbrt");
    CHECK(s.usesSpectra);
    REQUIRE(!s.areaLights[0].radiance.isRgb);
    const cb::PiecewiseLinear f11 = cb::toPiecewiseLinear(*cb::findNamedSpectrum("stdillum-F11"));
    CHECK(s.areaLights[0].radiance.samples == f11);
    CHECK(s.distantLights[0].radiance.samples ==
          cb::toPiecewiseLinear(*cb::findNamedSpectrum("stdillum-A")));
    CHECK(s.pointLights[0].intensity.samples ==
          cb::toPiecewiseLinear(*cb::findNamedSpectrum("illum-acesD60")));
    // Luminance 1 as named, so a light's luminance is its scale, as any light spectrum's.
    CHECK(s.areaLights[0].scale == doctest::Approx(2.0 / cb::photometricIntegral(f11)));
    CHECK(cb::photometricIntegral(f11) ==
          doctest::Approx(cb::photometricIntegral({{360.0f, 1.0f}, {830.0f, 1.0f}})));
    // A named illuminant is no reflectance (it exceeds 1), and pbrt-v4's camera spectra are
    // not built in.
    CHECK(contains(errorOf("WorldBegin\nMaterial \"diffuse\" \"spectrum reflectance\" "
                           "\"stdillum-D65\"\n"),
                   "must be <= 1"));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"point\" \"spectrum I\" "
                           "\"canon_eos_5d_mkiv_r\"\n"),
                   "stdillum-D65"));
}

TEST_CASE("pbrt-v4: the thesis Cornell box keeps its luminance through the light's scale") {
    const auto s = cb::parseSceneFile(cbtest::sourcePath("scenes/cornell-box.pbrt"));
    REQUIRE(s.areaLights.size() == 2);
    // Before pbrt-v4's normalisation the spectrum was used as given and the film divided by
    // y-bar's integral over 400-700 nm; "scale" is written so that the product is unchanged.
    const double expected = 1.0 / cb::photometricIntegral({{400.f, 1.f}, {700.f, 1.f}});
    for (const auto& l : s.areaLights)
        CHECK(l.scale == doctest::Approx(expected).epsilon(1e-6));
}

TEST_CASE("pbrt-v4 film colour: XYZ to sRGB without adaptation, white balance, imaging ratio") {
    const auto m = cb::filmMatrix(16, {});
    // A flat spectrum of 1 has XYZ equal to the CMF integrals over 400-700 nm, which pbrt-v4's
    // cie1931 sensor passes to sRGB without white balance: reddish, (1.205, 0.948, 0.909) times
    // Y when X = Y = Z.
    std::array<double, 3> flat{};
    for (int c = 0; c < 3; ++c)
        for (int i = 0; i < 16; ++i)
            flat[c] += m[c * 16 + i];
    const double y = cb::photometricIntegral({{400.f, 1.f}, {700.f, 1.f}});
    CHECK(flat[0] / y == doctest::Approx(1.2048).epsilon(1e-2));
    CHECK(flat[1] / y == doctest::Approx(0.9484).epsilon(1e-2));
    CHECK(flat[2] / y == doctest::Approx(0.9087).epsilon(1e-2));
    // The white illuminant of RGB emission renders as (1, 1, 1) and is positive.
    for (int c = 0; c < 3; ++c) {
        double v = 0.0;
        for (int i = 0; i < 16; ++i)
            v += m[c * 16 + i] * cb::whiteIlluminantBins()[i];
        CHECK(v == doctest::Approx(1.0).epsilon(1e-5));
    }
    for (float w : cb::whiteIlluminantBins())
        CHECK(w > 0.f);
    // Imaging ratio: exposure time * ISO / 100 multiplies every pixel.
    const auto m4 = cb::filmMatrix(16, {0.0, 4.0});
    for (size_t i = 0; i < m.size(); ++i)
        CHECK(m4[i] == doctest::Approx(4.0 * m[i]));
    // pbrt-v4's D illuminant at 6500 K lies at D65's chromaticity to 1e-3, so balancing from it
    // is nearly the identity; 3000 K (a Planckian source) makes a white light's red drop.
    const auto xy = cb::whiteBalanceChromaticity(6500.0);
    CHECK(xy[0] == doctest::Approx(0.3127).epsilon(3e-3));
    CHECK(xy[1] == doctest::Approx(0.3290).epsilon(3e-3));
    const auto rgb3000 = cb::filmMatrix(3, {3000.0, 1.0});
    CHECK(rgb3000[0] < 0.9f);
    CHECK(rgb3000[8] > 1.1f);
    const auto identity = cb::filmMatrix(3, {});
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            CHECK(identity[r * 3 + c] == doctest::Approx(r == c ? 1.0 : 0.0).epsilon(1e-6));
}

TEST_CASE("pbrt-v4 spot light: parameters, normalisation and power") {
    const auto s =
        parseSceneString("WorldBegin\nTranslate 1 2 3\n"
                         "LightSource \"spot\" \"point3 from\" [0 0 0] \"point3 to\" [0 -2 0] "
                         "\"float coneangle\" 40 \"float conedeltaangle\" 10 \"float power\" 3\n",
                         "t.pbrt");
    REQUIRE(s.pointLights.size() == 1);
    const auto& l = s.pointLights[0];
    CHECK(l.spot);
    CHECK(l.position == std::array<double, 3>{1, 2, 3});
    CHECK(l.spotAxis == std::array<double, 3>{0, -1, 0});
    CHECK(l.spotCosEnd == doctest::Approx(std::cos(40.0 * M_PI / 180.0)));
    CHECK(l.spotCosStart == doctest::Approx(std::cos(30.0 * M_PI / 180.0)));
    // pbrt-v4's SpotLight::Create: k_e = 2 pi ((1 - cosStart) + (cosStart - cosEnd) / 2).
    const double ke = 2.0 * M_PI *
                      ((1.0 - std::cos(M_PI / 6.0)) +
                       (std::cos(M_PI / 6.0) - std::cos(40.0 * M_PI / 180.0)) / 2.0);
    CHECK(l.scale == doctest::Approx(3.0 / ke).epsilon(1e-5));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"spot\" \"float conedeltaangle\" 40\n"),
                   "conedeltaangle"));
    CHECK(contains(errorOf("WorldBegin\nScale 1 2 1\nLightSource \"spot\"\n"), "similarity"));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"projection\"\n"), "\"distant\""));
}

TEST_CASE("pbrt-v4 area light power: each shape emits it, radiance power / (pi area)") {
    // pbrt-v4's DiffuseAreaLight::Create scales each shape's radiance by power / (pi A), A the
    // shape's Area() (twice for two-sided): every triangle of a mesh is a shape, a bilinear
    // patch one, a sphere or disk one measured in object space.
    const std::string rgbLight = "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1] ";
    const auto scene = cb::buildDeviceScene(
        parseSceneString(
            "WorldBegin\nAttributeBegin\n" + rgbLight +
                "\"float power\" 10\n"
                "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0  0 0 5 2 0 5 0 2 5] "
                "\"integer indices\" [0 1 2 3 4 5]\n"
                "Shape \"bilinearmesh\" \"point3 P\" [0 0 9  2 0 9  0 3 9  2 3 9]\n"
                "Shape \"disk\" \"float radius\" 1\nAttributeEnd\n"
                "AttributeBegin\n" +
                rgbLight +
                "\"float power\" 10 \"bool twosided\" true \"float scale\" 3\n"
                "Translate 5 0 0\nScale 2 2 2\nShape \"sphere\" \"float radius\" 0.5\n"
                "AttributeEnd\nAttributeBegin\n" +
                rgbLight + "\"float power\" -1\nTranslate -5 0 0\nShape \"sphere\"\n" +
                "AttributeEnd\n",
            "t.pbrt"),
        cb::ChannelMode::Rgb);
    std::vector<double> radiance;
    for (const auto& light : scene.lights)
        radiance.push_back(scene.spectra[size_t(light.emission) * 3 + 1]);
    // 2 triangles, 2 of the patch, 256 of the disk, 2 spheres.
    REQUIRE(radiance.size() == 262);
    std::sort(radiance.begin(), radiance.end());
    std::vector<double> expected{10.0 / (M_PI * 0.5), 10.0 / (M_PI * 2.0)};
    expected.insert(expected.end(), 2, 10.0 / (M_PI * 6.0));
    expected.insert(expected.end(), 256, 10.0 / (M_PI * M_PI));
    // Two-sided, scale 3, radius 0.5 in object space (pbrt-v4's area; the world's is 4 times).
    expected.push_back(3.0 * 10.0 / (2.0 * M_PI * M_PI));
    expected.push_back(1.0); // power <= 0 is none
    std::sort(expected.begin(), expected.end());
    for (size_t i = 0; i < expected.size(); ++i) {
        CAPTURE(i);
        CHECK(radiance[i] == doctest::Approx(expected[i]).epsilon(1e-6));
    }
    // One spectrum per shape area: the disk's 256 triangles share one.
    std::set<int> entries;
    for (const auto& light : scene.lights)
        entries.insert(light.emission);
    CHECK(entries.size() == 6);
}

TEST_CASE("pbrt-v4 light power: lights are picked in proportion to their Phi") {
    // Every light has radiance or intensity 1, so the pick probabilities are the ratios of
    // pbrt-v4's Phi over its spectrum's mean: area A pi (twice two-sided), point 4 pi, spot
    // 2 pi (1 - (cosStart + cosEnd) / 2), distant pi R^2, infinite 4 pi^2 R^2 (R the bounding
    // sphere's radius the scene reports).
    cb::SceneDesc desc = cbtest::furnaceScene(0.5f, 1.f); // 12 one-sided triangles of area 2
    cb::AreaLightDesc twoSided;
    twoSided.twoSided = true;
    desc.areaLights.push_back(twoSided);
    cb::TriangleMeshDesc triangle;
    triangle.positions = {{0.0, 0.0, 0.5}, {0.5, 0.0, 0.5}, {0.0, 0.5, 0.5}}; // area 1/8
    triangle.triangles = {{0, 1, 2}};
    triangle.material = 0;
    triangle.areaLight = 1;
    desc.meshes.push_back(triangle);
    desc.areaLights.push_back(cb::AreaLightDesc{});
    cb::SphereDesc sphere;
    sphere.center = {-0.5, -0.5, -0.5};
    sphere.radius = 0.25f;
    sphere.material = 0;
    sphere.areaLight = 2;
    desc.spheres.push_back(sphere);
    desc.pointLights.push_back(cb::PointLightDesc{});
    cb::PointLightDesc spot;
    spot.spot = true;
    spot.spotCosStart = 0.9f;
    spot.spotCosEnd = 0.8f;
    desc.pointLights.push_back(spot);
    desc.distantLights.push_back(cb::DistantLightDesc{});
    desc.infiniteLights.push_back(cb::InfiniteLightDesc{});
    const cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    REQUIRE(scene.lights.size() == 18);
    const double r = scene.lights[16].sceneRadius;
    CHECK(scene.lights[17].sceneRadius == float(r));
    std::vector<double> power(12, 2.0 * M_PI);
    power.push_back(2.0 * 0.125 * M_PI);
    power.push_back(4.0 * M_PI * 0.25 * 0.25 * M_PI);
    power.push_back(4.0 * M_PI);
    power.push_back(2.0 * M_PI * (1.0 - 0.5 * (0.9 + 0.8)));
    power.push_back(M_PI * r * r);
    power.push_back(4.0 * M_PI * M_PI * r * r);
    double total = 0.0;
    for (double p : power)
        total += p;
    double cdf = 0.0;
    for (size_t i = 0; i < power.size(); ++i) {
        CAPTURE(i);
        cdf += power[i] / total;
        CHECK(scene.lights[i].pickProbability == doctest::Approx(power[i] / total).epsilon(1e-5));
        CHECK(scene.lights[i].cdf == doctest::Approx(cdf).epsilon(1e-5));
    }
    // The sphere's area is what its light samples by.
    CHECK(scene.lights[13].area == doctest::Approx(4.0 * M_PI * 0.25 * 0.25).epsilon(1e-6));
}

// A spot light 1 m above a diffuse plane, seen from straight above: each pixel's radiance is
// (rho / pi) I S(cos theta) cos theta / d^2 with d = sqrt(1 + r^2), cos theta = 1 / d, and S
// pbrt-v4's smoothstep falloff. The image mean is that averaged over the view, integrated here
// on a fine grid; PT (next-event estimation) and BDPT (light subpaths leave the spot with its
// falloff) must reproduce it.
namespace {

// PT and BDPT (3 eye, 2 light vertices) agree with an analytic image mean within 3.5 standard
// errors of 16 pooled runs, plus `relativeSlack` of the mean for the analytic quadrature.
void checkPtAndBdptImageMean(const cb::DeviceScene& scene, cb::ClRuntime& runtime, double expected,
                             unsigned seed, double relativeSlack) {
    for (const char* method : {"pt", "bdpt"}) {
        CAPTURE(method);
        cb::IntegratorSettings settings;
        settings.name = method;
        settings.eyeVertices = 3;
        settings.lightVertices = 2;
        settings.seed = seed;
        const auto stats = cbtest::renderPooled(scene, runtime, settings, 16);
        CAPTURE(expected);
        CAPTURE(stats.mean);
        CAPTURE(stats.standardError);
        CHECK(std::fabs(stats.mean - expected) <=
              3.5 * stats.standardError + relativeSlack * expected);
    }
}

} // namespace

TEST_CASE("pbrt-v4 spot light: falloff on a diffuse plane against the analytic image mean") {
    cb::ClRuntime runtime;
    const double rho = 0.5, coneDeg = 30.0, deltaDeg = 10.0;
    for (double fovDeg : {40.0, 90.0}) {
        CAPTURE(fovDeg);
        const std::string text =
            "LookAt 0 2 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" " +
            std::to_string(fovDeg) +
            "\nFilm \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\nWorldBegin\n"
            "LightSource \"spot\" \"point3 from\" [0 1 0] \"point3 to\" [0 0 0] "
            "\"float coneangle\" 30 \"float conedeltaangle\" 10\n"
            "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-10 0 -10  10 0 -10  -10 0 10  10 0 10]\n";
        const cb::DeviceScene scene = cb::buildDeviceScene(parseSceneString(text, "t.pbrt"));
        CHECK(contains(scene.featureNames(), "spot-light"));
        const double cosEnd = std::cos(coneDeg * M_PI / 180.0);
        const double cosStart = std::cos((coneDeg - deltaDeg) * M_PI / 180.0);
        const double halfWidth = 2.0 * std::tan(fovDeg * M_PI / 360.0);
        const int n = 400;
        double expected = 0.0;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                const double x = halfWidth * (2.0 * (i + 0.5) / n - 1.0);
                const double y = halfWidth * (2.0 * (j + 0.5) / n - 1.0);
                const double d = std::sqrt(1.0 + x * x + y * y), c = 1.0 / d;
                const double t = std::clamp((c - cosEnd) / (cosStart - cosEnd), 0.0, 1.0);
                expected += rho / M_PI * t * t * (3.0 - 2.0 * t) * c / (d * d);
            }
        expected /= double(n) * n;
        checkPtAndBdptImageMean(scene, runtime, expected, 11, 1e-4);
    }
}

namespace {

double meshArea(const cb::TriangleMeshDesc& m) {
    double area = 0.0;
    for (size_t t = 0; t < m.triangles.size(); ++t) {
        const auto n = normalOf(m, t);
        area += 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    }
    return area;
}

} // namespace

TEST_CASE("pbrt-v4 disk: tessellated with the disk's exact area, facing pbrt's normal") {
    struct Case {
        std::string params;
        double radius, inner, phimaxDeg;
    };
    for (const Case& c : {Case{"", 1.0, 0.0, 360.0}, Case{"\"float radius\" 2.5", 2.5, 0.0, 360.0},
                          Case{"\"float radius\" 2 \"float innerradius\" 0.5", 2.0, 0.5, 360.0},
                          Case{"\"float radius\" 2 \"float phimax\" 90", 2.0, 0.0, 90.0},
                          Case{"\"float radius\" 3 \"float innerradius\" 1 \"float phimax\" 200",
                               3.0, 1.0, 200.0}}) {
        CAPTURE(c.params);
        for (const std::string transform :
             {"", "Scale 2 2 2\n", "ReverseOrientation\n", "Scale -1 1 1\n", "Scale 1 1 -1\n"}) {
            CAPTURE(transform);
            const auto s =
                parseSceneString("WorldBegin\n" + transform +
                                     "Shape \"disk\" \"float height\" 0.5 " + c.params + "\n",
                                 "t.pbrt");
            REQUIRE(s.meshes.size() == 1);
            const auto& m = s.meshes[0];
            const double scale = transform == "Scale 2 2 2\n" ? 2.0 : 1.0;
            // pbrt-v4's Disk::Area: phimax / 2 (radius^2 - innerradius^2).
            const double area = c.phimaxDeg * M_PI / 360.0 *
                                (c.radius * c.radius - c.inner * c.inner) * scale * scale;
            CHECK(meshArea(m) == doctest::Approx(area).epsilon(1e-12));
            // Object-space normal +z, flipped by ReverseOrientation XOR a mirroring CTM
            // (Disk::InteractionFromIntersection), then transformed: a mirror in z keeps it +z
            // in world space, a mirror in x leaves it -z.
            const bool flipped =
                transform == "ReverseOrientation\n" || transform == "Scale -1 1 1\n";
            for (size_t t = 0; t < m.triangles.size(); ++t) {
                const auto n = normalOf(m, t);
                CHECK((flipped ? -n[2] : n[2]) > 0.0);
            }
            // Every vertex lies in the plane z = height, within the area-preserving ring radii.
            const double zWorld = transform == "Scale 1 1 -1\n" ? -0.5 : 0.5 * scale;
            for (const auto& p : m.positions) {
                CHECK(p[2] == doctest::Approx(zWorld));
                const double r = std::hypot(p[0], p[1]) / scale;
                CHECK(r <= c.radius * 1.001);
            }
        }
    }
    CHECK(contains(errorOf("WorldBegin\nShape \"disk\" \"float radius\" 0\n"), "t.pbrt:2:"));
    CHECK(contains(errorOf("WorldBegin\nShape \"disk\" \"float radius\" 0\n"), "radius"));
    CHECK(contains(errorOf("WorldBegin\nShape \"disk\" \"float innerradius\" 1\n"), "innerradius"));
    CHECK(contains(errorOf("WorldBegin\nShape \"disk\" \"float phimax\" 0\n"), "phimax"));
    CHECK(contains(errorOf("WorldBegin\nShape \"disk\" \"float zmin\" 0\n"), "zmin"));
}

namespace {

// The plane-under-a-light scenes: a camera at height 0.5 looking straight down (fov 90, 32 x 32)
// at a diffuse plane y = 0 of albedo 0.5, lit by an area light of radiance 2 and black material
// placed by `light` (its transforms and shape).
std::string planeUnderLight(const std::string& light) {
    return "LookAt 0 0.5 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 90\n"
           "Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\nWorldBegin\n"
           "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [2 2 2]\n"
           "Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n" +
           light +
           "AttributeEnd\nMaterial \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
           "Shape \"bilinearmesh\" \"point3 P\" [-10 0 -10  10 0 -10  -10 0 10  10 0 10]\n";
}

// That view's image mean: rho / pi E(x, z) averaged over n x n points of the 1 x 1 square of the
// plane the camera sees.
template <class Irradiance> double planeImageMean(int n, Irradiance irradianceAt) {
    const double rho = 0.5;
    double sum = 0.0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            sum +=
                rho / M_PI *
                irradianceAt(0.5 * (2.0 * (i + 0.5) / n - 1.0), 0.5 * (2.0 * (j + 0.5) / n - 1.0));
    return sum / (double(n) * n);
}

} // namespace

// A one-sided disk light (radius R, radiance L) at height h, facing a diffuse plane: a point of
// the plane at horizontal distance d from the axis receives E = (pi L / 2) (1 - (h^2 + d^2 -
// R^2) / sqrt((h^2 + d^2 + R^2)^2 - 4 R^2 d^2)) (the view factor of a parallel coaxial disk) and
// reflects rho / pi E. The camera sits between the plane and the disk looking down; the image
// mean is that averaged over its view, integrated on a fine grid. PT (next-event estimation on
// the disk's triangles, MIS with BSDF sampling) and BDPT must reproduce it. The disk is black,
// so that BDPT's longer paths (Ne + Nl vertices) add nothing.
TEST_CASE("pbrt-v4 disk light: irradiance on a plane against the analytic image mean" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double radius = 0.5, h = 1.0;
    const cb::DeviceScene scene = cb::buildDeviceScene(parseSceneString(
        planeUnderLight("Translate 0 1 0\nRotate 90 1 0 0\nShape \"disk\" \"float radius\" 0.5\n"),
        "t.pbrt"));
    double lightArea = 0.0;
    for (const auto& l : scene.lights)
        lightArea += l.area;
    CHECK(lightArea == doctest::Approx(M_PI * radius * radius).epsilon(1e-5));
    const double expected = planeImageMean(400, [&](double x, double z) {
        const double d2 = x * x + z * z, r2 = radius * radius, h2 = h * h;
        return M_PI * 2.0 / 2.0 *
               (1.0 - (h2 + d2 - r2) / std::sqrt((h2 + d2 + r2) * (h2 + d2 + r2) - 4.0 * r2 * d2));
    });
    checkPtAndBdptImageMean(scene, runtime, expected, 5, 2e-4);
}

TEST_CASE("pbrt-v4 cylinder: the exact area, pbrt's normals and (u, v), open at both ends") {
    struct Case {
        std::string params;
        double radius, z0, z1, phimaxDeg;
    };
    for (const Case& c :
         {Case{"", 1.0, -1.0, 1.0, 360.0},
          Case{"\"float radius\" 2 \"float zmin\" 0 \"float zmax\" 3", 2.0, 0.0, 3.0, 360.0},
          Case{"\"float zmin\" 2 \"float zmax\" 0.5", 1.0, 0.5, 2.0, 360.0}, // pbrt-v4 swaps them
          Case{"\"float radius\" 0.5 \"float phimax\" 90", 0.5, -1.0, 1.0, 90.0}}) {
        CAPTURE(c.params);
        for (const std::string transform :
             {"", "Scale 2 2 2\n", "ReverseOrientation\n", "Scale -1 1 1\n",
              "Scale -1 1 1\nReverseOrientation\n"}) {
            CAPTURE(transform);
            const auto s = parseSceneString(
                "WorldBegin\n" + transform + "Shape \"cylinder\" " + c.params + "\n", "t.pbrt");
            REQUIRE(s.meshes.size() == 1);
            const auto& m = s.meshes[0];
            const double scale = transform == "Scale 2 2 2\n" ? 2.0 : 1.0;
            const double phiMax = c.phimaxDeg * M_PI / 180.0;
            // pbrt-v4's Cylinder::Area: phimax r (zmax - zmin).
            CHECK(
                meshArea(m) ==
                doctest::Approx(phiMax * c.radius * (c.z1 - c.z0) * scale * scale).epsilon(1e-12));
            // Normal outward in object space, flipped by ReverseOrientation XOR a mirroring CTM
            // (as pbrt-v4's Cylinder::InteractionFromIntersection): the world normal points
            // inward for one of the two, outward for both.
            const bool inward = (transform.find("Reverse") != std::string::npos) !=
                                (transform.find("Scale -1") != std::string::npos);
            REQUIRE(m.normals.size() == m.positions.size());
            for (size_t v = 0; v < m.positions.size(); ++v) {
                const auto& p = m.positions[v];
                const auto& n = m.normals[v];
                // (Normals through the CTM's inverse transpose; the kernel normalises them.)
                const double r = std::hypot(p[0], p[1]), length = std::hypot(n[0], n[1]);
                CHECK(n[2] == 0.0);
                CHECK((n[0] * p[0] + n[1] * p[1]) / (r * length) ==
                      doctest::Approx(inward ? -1.0 : 1.0));
                // On the area-preserving ring, between the z bounds.
                CHECK(r / scale >= c.radius);
                CHECK(r / scale <= c.radius * 1.0001);
                CHECK(p[2] / scale >= c.z0 - 1e-12);
                CHECK(p[2] / scale <= c.z1 + 1e-12);
            }
            // Each triangle faces its vertex normals' side; its corners carry pbrt-v4's
            // (u, v) = (phi / phimax, (z - zmin) / (zmax - zmin)), phi of the object point.
            REQUIRE(m.cornerUv.size() == m.triangles.size());
            for (size_t t = 0; t < m.triangles.size(); ++t) {
                const auto ng = normalOf(m, t);
                const auto& n = m.normals[m.triangles[t][0]];
                CHECK(ng[0] * n[0] + ng[1] * n[1] + ng[2] * n[2] > 0.0);
                if (!transform.empty()) continue;
                for (size_t k = 0; k < 3; ++k) {
                    const auto& p = m.positions[m.triangles[t][k]];
                    double phi = std::atan2(p[1], p[0]);
                    if (phi < 0.0 || (phi == 0.0 && m.cornerUv[t][2 * k] > 0.5f)) phi += 2 * M_PI;
                    CHECK(m.cornerUv[t][2 * k] == doctest::Approx(phi / phiMax).epsilon(1e-6));
                    CHECK(m.cornerUv[t][2 * k + 1] ==
                          doctest::Approx((p[2] - c.z0) / (c.z1 - c.z0)).epsilon(1e-6));
                }
            }
        }
    }
    CHECK(contains(errorOf("WorldBegin\nShape \"cylinder\" \"float radius\" 0\n"),
                   "t.pbrt:2:18: \"float radius\" must be > 0"));
    CHECK(contains(errorOf("WorldBegin\nShape \"cylinder\" \"float zmin\" 1\n"),
                   "t.pbrt:2:18: \"float zmin\" and \"float zmax\" must differ, got 1 and 1"));
    CHECK(contains(errorOf("WorldBegin\nShape \"cylinder\" \"float phimax\" 400\n"), "(0, 360]"));
    CHECK(contains(errorOf("WorldBegin\nShape \"cylinder\" \"float innerradius\" 1\n"),
                   "innerradius"));
    // Given by power, it emits that power (radiance power / (pi A), A pbrt-v4's area).
    const auto scene = cb::buildDeviceScene(
        parseSceneString("WorldBegin\nAreaLightSource \"diffuse\" \"float power\" 10\n"
                         "Shape \"cylinder\" \"float radius\" 0.5 \"float phimax\" 180\n",
                         "t.pbrt"),
        cb::ChannelMode::Rgb);
    REQUIRE(scene.lights.size() == 256);
    double area = 0.0;
    for (const auto& light : scene.lights) {
        area += light.area;
        CHECK(scene.spectra[size_t(light.emission) * 3 + 1] ==
              doctest::Approx(10.0 / (M_PI * M_PI * 0.5 * 2.0)).epsilon(1e-6));
    }
    CHECK(area == doctest::Approx(M_PI * 0.5 * 2.0).epsilon(1e-5));
}

// A horizontal tube light (a one-sided cylinder of radius R and length 2, radiance L) at height
// h above a diffuse plane: a point x of the plane receives E(x), the integral over the tube's
// surface facing x of L cos(plane) cos(tube) / d^2 (a convex surface: nothing of it hides what
// faces x), and reflects rho / pi E. The image mean under a camera looking down, integrated on a
// grid over the exact cylinder, against PT (next-event estimation on the facets) and BDPT (light
// subpaths from them); the facets' geometry differs from the cylinder's by dphi^2 / 12 of the
// radius, far below the slack.
TEST_CASE("pbrt-v4 cylinder light: irradiance on a plane against the integral over the tube" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double radius = 0.1, h = 1.0, radiance = 2.0;
    const cb::DeviceScene scene = cb::buildDeviceScene(parseSceneString(
        planeUnderLight(
            "Translate 0 1 0\nRotate 90 0 1 0\nShape \"cylinder\" \"float radius\" 0.1\n"),
        "t.pbrt"));
    // The tube along x from -1 to 1 at height h: surface point (s, h + R sin a, R cos a),
    // outward normal (0, sin a, cos a).
    const int na = 256, ns = 128;
    const double expected = planeImageMean(48, [&](double x, double z) {
        double e = 0.0;
        for (int a = 0; a < na; ++a) {
            const double angle = 2.0 * M_PI * (a + 0.5) / na;
            const double ny = std::sin(angle), nz = std::cos(angle);
            for (int k = 0; k < ns; ++k) {
                const double s = 2.0 * (k + 0.5) / ns - 1.0;
                const double dx = s - x, dy = h + radius * ny, dz = radius * nz - z;
                const double d2 = dx * dx + dy * dy + dz * dz;
                const double cosTube = -(ny * dy + nz * dz) / std::sqrt(d2);
                if (cosTube <= 0.0) continue;
                e += dy / std::sqrt(d2) * cosTube / d2;
            }
        }
        return e * radiance * (2.0 * M_PI * radius / na) * (2.0 / ns);
    });
    checkPtAndBdptImageMean(scene, runtime, expected, 7, 1e-3);
}

TEST_CASE("pbrt-v4 distant light: parameters, normalisation and direction") {
    auto s =
        parseSceneString("WorldBegin\nRotate 90 0 0 1\n"
                         "LightSource \"distant\" \"point3 from\" [1 0 0] \"point3 to\" [0 0 0] "
                         "\"rgb L\" [1 2 3] \"float scale\" 2\n",
                         "t.pbrt");
    REQUIRE(s.distantLights.size() == 1);
    auto l = s.distantLights[0];
    CHECK(l.direction[0] == doctest::Approx(0.0).epsilon(1e-12));
    CHECK(l.direction[1] == doctest::Approx(1.0));
    CHECK(l.radiance.rgb == std::array<float, 3>{1, 2, 3});
    CHECK(l.scale == 2.f);
    // pbrt-v4's defaults: from (0,0,0) to (0,0,1): the light shines toward +z.
    s = parseSceneString("WorldBegin\nLightSource \"distant\" \"float illuminance\" 5 "
                         "\"spectrum L\" [400 1 700 1]\n",
                         "t.pbrt");
    l = s.distantLights[0];
    CHECK(l.direction == std::array<double, 3>{0, 0, -1});
    // Spectrum divided by its luminance integral, times the illuminance.
    CHECK(
        l.scale ==
        doctest::Approx(5.0 / cb::photometricIntegral({{400.f, 1.f}, {700.f, 1.f}})).epsilon(1e-5));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"distant\" \"point3 to\" [0 0 0]\n"),
                   "t.pbrt:2:"));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"distant\" \"point3 to\" [0 0 0]\n"),
                   "must differ"));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"distant\" \"float illuminance\" -1\n"),
                   "illuminance"));
    CHECK(contains(errorOf("WorldBegin\nLightSource \"distant\" \"float power\" 1\n"), "power"));
    // Without geometry there is no bounding sphere for its light subpaths.
    CHECK_THROWS_WITH_AS(
        cb::buildDeviceScene(parseSceneString("WorldBegin\nLightSource \"distant\"\n", "t.pbrt")),
        doctest::Contains("t.pbrt:2:"), SceneError);
}

// A diffuse plane lit by a distant light at angle theta from its normal has radiance
// rho / pi E cos(theta) everywhere (E the light's irradiance on a surface facing it). Every
// method must render that image mean; the light is compiled in only for scenes that have one.
TEST_CASE("pbrt-v4 distant light: a diffuse plane has radiance rho / pi E cos theta, every method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double rho = 0.5, thetaDeg = 60.0, irradiance = 2.0;
    const double theta = thetaDeg * M_PI / 180.0;
    const std::string text =
        "LookAt 0 1 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 60\n"
        "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\nWorldBegin\n"
        "LightSource \"distant\" \"point3 from\" [" +
        std::to_string(std::sin(theta)) + " " + std::to_string(std::cos(theta)) +
        " 0] \"point3 to\" [0 0 0] \"float scale\" 2\n"
        "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-10 0 -10  10 0 -10  -10 0 10  10 0 10]\n";
    const cb::DeviceScene scene = cb::buildDeviceScene(parseSceneString(text, "t.pbrt"));
    CHECK(contains(scene.featureNames(), "distant-light"));
    CHECK(!contains(scene.featureNames(), "point-light"));
    const double expected = rho / M_PI * irradiance * std::cos(theta);
    for (const std::string method : kMethods) {
        CAPTURE(method);
        const MethodMean m = methodMean(scene, runtime, methodSettings(method), 8, 4);
        CAPTURE(expected);
        CAPTURE(m.mean);
        CAPTURE(m.se);
        CHECK(std::fabs(m.mean - expected) <= 4.5 * m.se + 1e-4 * expected);
        CHECK(m.nonFinite == 0);
    }
}

TEST_CASE("pbrt-v4 distant light: BDPT, CBDPT and MLT agree with PT per region" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt("LightSource \"distant\" \"point3 from\" [-1 2 -0.5] "
                            "\"point3 to\" [0 0 0] \"rgb L\" [3 3 3]\n");
}

TEST_CASE("pbrt-v4 infinite light: a constant L, its normalisation, and what is refused") {
    auto s = parseSceneString("WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 2 3] "
                              "\"float scale\" 2\n",
                              "t.pbrt");
    REQUIRE(s.infiniteLights.size() == 1);
    CHECK(s.infiniteLights[0].radiance.rgb == std::array<float, 3>{1, 2, 3});
    CHECK(s.infiniteLights[0].scale == 2.f);
    // "illuminance" E: pbrt-v4 scales a unit-luminance sky by E / pi (the upper hemisphere's
    // cosine-weighted solid angle).
    s = parseSceneString("WorldBegin\nLightSource \"infinite\" \"float illuminance\" 3\n",
                         "t.pbrt");
    CHECK(s.infiniteLights[0].scale == doctest::Approx(3.0 / M_PI));
    s = parseSceneString("WorldBegin\nLightSource \"infinite\" \"spectrum L\" [400 2 700 2]\n",
                         "t.pbrt");
    CHECK(
        s.infiniteLights[0].scale ==
        doctest::Approx(1.0 / cb::photometricIntegral({{400.f, 2.f}, {700.f, 2.f}})).epsilon(1e-5));
    // An image is test_image_light.cpp's; a missing one is named with the directive's line.
    const std::string image =
        errorOf("WorldBegin\n\nLightSource \"infinite\" \"string filename\" \"sky.exr\"\n");
    CHECK(contains(image, "t.pbrt:3:"));
    CHECK(contains(image, "no image file \"sky.exr\""));
    // Behind a portal (test_image_light.cpp), in world space whatever the CTM.
    CHECK(parseSceneString("WorldBegin\nTranslate 1 2 3\nLightSource \"infinite\" \"point3 "
                           "portal\" [0 0 0 1 0 0 1 1 0 0 1 0]\n",
                           "t.pbrt")
              .infiniteLights[0]
              .portal[2] == std::array<double, 3>{1, 1, 0});
    const std::string second =
        errorOf("WorldBegin\nLightSource \"infinite\"\nLightSource \"infinite\"\n");
    CHECK(contains(second, "t.pbrt:3:"));
    CHECK(contains(second, "t.pbrt:2:"));
    CHECK_THROWS_WITH_AS(
        cb::buildDeviceScene(parseSceneString("WorldBegin\nLightSource \"infinite\"\n", "t.pbrt")),
        doctest::Contains("t.pbrt:2:"), SceneError);
}

// An open scene: a diffuse plane under a constant sky of radiance L receives pi L from its
// upper hemisphere and has radiance rho L everywhere. Every method must render that image mean
// (escaped rays, next-event estimation's uniform directions, light subpaths from the beam's
// disk, and their MIS weights).
TEST_CASE("pbrt-v4 infinite light: a diffuse plane under a constant sky has radiance rho L, every "
          "method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double rho = 0.5, radiance = 0.8;
    const std::string text =
        "LookAt 0 1 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 60\n"
        "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\nWorldBegin\n"
        "LightSource \"infinite\" \"rgb L\" [0.8 0.8 0.8]\n"
        "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-10 0 -10  10 0 -10  -10 0 10  10 0 10]\n";
    const cb::DeviceScene scene = cb::buildDeviceScene(parseSceneString(text, "t.pbrt"));
    CHECK(contains(scene.featureNames(), "infinite-light"));
    CHECK(!contains(scene.featureNames(), "area-light"));
    const double expected = rho * radiance;
    for (const std::string method : kMethods) {
        CAPTURE(method);
        const MethodMean m = methodMean(scene, runtime, methodSettings(method), 8, 4);
        CAPTURE(expected);
        CAPTURE(m.mean);
        CAPTURE(m.se);
        CHECK(std::fabs(m.mean - expected) <= 4.5 * m.se + 1e-4 * expected);
        CHECK(m.nonFinite == 0);
    }
}

TEST_CASE("pbrt-v4 infinite light: BDPT, CBDPT and MLT agree with PT per region" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt("LightSource \"infinite\" \"rgb L\" [0.5 0.5 0.5]\n");
}

TEST_CASE("pbrt-v4 infinite and distant light with an area light: BDPT agrees with PT" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt("LightSource \"infinite\" \"rgb L\" [0.3 0.3 0.3]\n"
                            "LightSource \"distant\" \"point3 from\" [1 3 -1] \"rgb L\" [2 2 2]\n"
                            "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [4 4 4]\n"
                            "Translate -0.5 1.5 0\nRotate 90 1 0 0\n"
                            "Shape \"disk\" \"float radius\" 0.3\nAttributeEnd\n");
}

TEST_CASE("pbrt-v4 conductor: eta and k, or reflectance, and what is refused") {
    const std::string gold = "\"spectrum eta\" [400 1.66 550 0.43 700 0.16] "
                             "\"spectrum k\" [400 1.96 550 2.45 700 3.92]";
    auto s = parseSceneString("WorldBegin\nLightSource \"point\"\nMaterial \"conductor\" " + gold +
                                  " \"float roughness\" 0.01\n" + kTri,
                              "t.pbrt");
    REQUIRE(s.materials.size() == 1);
    REQUIRE(s.materials[0].conductorEta.has_value());
    REQUIRE(s.materials[0].conductorK.has_value());
    CHECK(s.materials[0].conductorEta->samples.size() == 3);
    CHECK(s.materials[0].conductorK->samples[2].second == 3.92f);
    CHECK(s.usesSpectra);
    cb::DeviceScene scene = cb::buildDeviceScene(s);
    CHECK(contains(scene.featureNames(), "conductor-fresnel"));
    REQUIRE(scene.materials.size() == 1);
    CHECK(scene.materials[0].secondSpectrum >= 0);
    // Each bin holds the spectrum's mean over the bin: k rises from 1.96 to 3.92.
    const float* k = &scene.spectra[size_t(scene.materials[0].secondSpectrum * scene.channels)];
    CHECK(k[0] == doctest::Approx(1.96 + (2.45 - 1.96) * (409.375 - 400.0) / 150.0).epsilon(1e-4));
    CHECK(k[0] < k[scene.channels - 1]);
    // RGB values are the channels' eta and k; a conductor with reflectance keeps its tint and
    // compiles no Fresnel code.
    s = parseSceneString(
        "WorldBegin\nLightSource \"point\"\nMaterial \"conductor\" \"rgb eta\" [0.2 0.9 1.1] "
        "\"rgb k\" [3.9 2.4 1.9]\n" +
            kTri,
        "t.pbrt");
    scene = cb::buildDeviceScene(s);
    REQUIRE(scene.channels == 3);
    CHECK(scene.spectra[size_t(scene.materials[0].reflectance * 3 + 1)] == 0.9f);
    CHECK(scene.spectra[size_t(scene.materials[0].secondSpectrum * 3 + 2)] == 1.9f);
    s = parseSceneString("WorldBegin\nLightSource \"point\"\nMaterial \"conductor\" \"rgb "
                         "reflectance\" [0.9 0.8 0.7]\n" +
                             kTri,
                         "t.pbrt");
    scene = cb::buildDeviceScene(s);
    CHECK(scene.materials[0].secondSpectrum == -1);
    CHECK(contains(scene.featureNames(), "conductor"));
    CHECK(!contains(scene.featureNames(), "conductor-fresnel"));
    // pbrt-v4's default for a missing eta or k, and for a conductor given neither: copper's
    // measured spectra (metal-Cu-eta, metal-Cu-k), which render spectrally.
    using Samples = std::vector<std::pair<float, float>>;
    const Samples cuEta = cb::toPiecewiseLinear(*cb::findNamedSpectrum("metal-Cu-eta"));
    const Samples cuK = cb::toPiecewiseLinear(*cb::findNamedSpectrum("metal-Cu-k"));
    auto parsed = parseSceneString("WorldBegin\nMaterial \"conductor\"\n" + kTri, "t.pbrt");
    REQUIRE(parsed.materials.size() == 1);
    CHECK(parsed.materials[0].conductorEta->samples == cuEta);
    CHECK(parsed.materials[0].conductorK->samples == cuK);
    CHECK(parsed.usesSpectra);
    parsed = parseSceneString(
        "WorldBegin\nMaterial \"conductor\" \"rgb eta\" [0.2 0.9 1.1]\n" + kTri, "t.pbrt");
    CHECK(parsed.materials[0].conductorEta->isRgb);
    CHECK(parsed.materials[0].conductorK->samples == cuK);
    parsed =
        parseSceneString("WorldBegin\nMaterial \"conductor\" \"rgb k\" [1 1 1]\n" + kTri, "t.pbrt");
    CHECK(parsed.materials[0].conductorEta->samples == cuEta);
    CHECK(parsed.materials[0].conductorK->isRgb);
    // pbrt-v4's named spectra in place of numbers.
    parsed = parseSceneString("WorldBegin\nLightSource \"point\"\nMaterial \"conductor\" "
                              "\"spectrum eta\" \"metal-Au-eta\" \"spectrum k\" \"metal-Au-k\"\n" +
                                  kTri,
                              "t.pbrt");
    CHECK(parsed.materials[0].conductorEta->samples ==
          cb::toPiecewiseLinear(*cb::findNamedSpectrum("metal-Au-eta")));
    CHECK(parsed.materials[0].conductorK->samples ==
          cb::toPiecewiseLinear(*cb::findNamedSpectrum("metal-Au-k")));
    scene = cb::buildDeviceScene(parsed);
    CHECK(scene.channels == cb::kSpectralBins);
    CHECK(contains(scene.featureNames(), "conductor-fresnel"));
    // Refused, each at its line: both forms, negative or huge values, names cbdpt lacks.
    expectError("WorldBegin\n\nMaterial \"conductor\" \"rgb reflectance\" [0.9 0.8 0.7] " + gold,
                {"t.pbrt:3:", "not both"});
    expectError("WorldBegin\nMaterial \"conductor\" \"rgb eta\" [0.2 -0.9 1.1] \"rgb k\" [1 1 1]\n",
                {"negative"});
    expectError("WorldBegin\nMaterial \"conductor\" \"rgb eta\" [1 1 1] \"rgb k\" [1 2e6 1]\n",
                {"t.pbrt:2:", "2e+06", "up to 1e+06"});
    // Outside its samples a spectrum is 0: eta = k = 0 there would be a vacuum (pbrt-v4's
    // Fresnel gives NaN); a conductor's spectra must cover cbdpt's 400-700 nm.
    expectError("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" [450 1 700 1] "
                "\"spectrum k\" [400 1 700 1]\n",
                {"t.pbrt:2:22", "covers 450-700 nm", "must cover 400-700 nm"});
    expectError("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" \"metal-Pt-eta\" "
                "\"spectrum k\" \"metal-Au-k\"\n",
                {"t.pbrt:2:37", "no spectrum file \"metal-Pt-eta\"", "metal-Au-eta", "glass-*"});
    // A named conductor spectrum is no reflectance.
    expectError("WorldBegin\nMaterial \"diffuse\" \"spectrum reflectance\" \"metal-Cu-eta\"\n",
                {"t.pbrt:2:43", "must be <= 1"});
}

// gzip framing of `text` (one member), as `gzip` writes it.
std::string gzipped(const std::string& text) {
    z_stream zs{};
    REQUIRE(deflateInit2(&zs, Z_BEST_COMPRESSION, Z_DEFLATED, 16 + MAX_WBITS, 8,
                         Z_DEFAULT_STRATEGY) == Z_OK);
    std::string out(deflateBound(&zs, static_cast<uLong>(text.size())) + 32, '\0');
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
    zs.avail_in = static_cast<uInt>(text.size());
    zs.next_out = reinterpret_cast<Bytef*>(out.data());
    zs.avail_out = static_cast<uInt>(out.size());
    REQUIRE(deflate(&zs, Z_FINISH) == Z_STREAM_END);
    out.resize(zs.total_out);
    deflateEnd(&zs);
    return out;
}

TEST_CASE("pbrt-v4: scene files named .gz are read as gzip-compressed text") {
    const auto dir =
        std::filesystem::temp_directory_path() / ("cbdpt-gz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    auto write = [&](const std::string& name, const std::string& bytes) {
        std::ofstream(dir / name, std::ios::binary) << bytes;
        return (dir / name).string();
    };
    const std::string part = "Shape \"trianglemesh\" \"point3 P\" [0 0 0 2 0 0 0 2 0]\n";
    const std::string main = "WorldBegin\nLightSource \"point\"\n" + kTri +
                             "Include \"part.pbrt.gz\"\nImport \"plain.pbrt\"\n";
    write("part.pbrt.gz", gzipped(part));
    write("plain.pbrt", "Import \"two.pbrt.gz\"\n");
    // Two members, as `cat a.gz b.gz` makes them: read as their concatenation.
    write("two.pbrt.gz", gzipped(kTri) + gzipped(part));
    const auto s = cb::parseSceneFile(write("main.pbrt.gz", gzipped(main)));
    REQUIRE(s.meshes.size() == 4);
    CHECK(s.meshes[1].positions[1] == std::array<double, 3>{2, 0, 0});
    CHECK(s.meshes[3].positions[1] == std::array<double, 3>{2, 0, 0});
    CHECK(s.sourceFiles.size() == 4);
    auto errorIn = [&](const std::string& bytes) {
        try {
            cb::parseSceneFile(write("bad.pbrt.gz", bytes));
        } catch (const SceneError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    const std::string bad = (dir / "bad.pbrt.gz").string();
    CHECK(contains(errorIn(main), "cannot decompress \"" + bad + "\": not gzip data"));
    const std::string whole = gzipped(main);
    CHECK(contains(errorIn(whole.substr(0, whole.size() - 12)), "truncated"));
    std::string corrupt = whole;
    corrupt[12] = static_cast<char>(corrupt[12] ^ 0x55);
    corrupt[13] = static_cast<char>(corrupt[13] ^ 0x55);
    CHECK(contains(errorIn(corrupt), "at compressed byte"));
    CHECK(contains(errorIn(whole + "garbage"), "cannot decompress"));
    // What is decompressed must still be a scene.
    CHECK(contains(errorIn(gzipped("\x89PNG\r\n\x1a\n\0\0")), "PNG"));
    // An included file names its Include.
    write("inc.pbrt", "WorldBegin\nInclude \"bad.pbrt.gz\"\n");
    write("bad.pbrt.gz", "not compressed");
    try {
        cb::parseSceneFile((dir / "inc.pbrt").string());
        CHECK(false);
    } catch (const SceneError& e) {
        CHECK(contains(e.what(), "inc.pbrt:2:9: cannot decompress"));
    }
    std::filesystem::remove_all(dir);
}

TEST_CASE("pbrt-v4: spectrum files, found beside the file that names them, with '#' comments") {
    const auto dir =
        std::filesystem::temp_directory_path() / ("cbdpt-spd-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir / "spds");
    std::filesystem::create_directories(dir / "parts");
    std::ofstream(dir / "spds" / "Au.k.spd") << "# gold's k\n400 1.96\n550 2.45 # mid\n700 3.92\n";
    std::ofstream(dir / "parts" / "eta.spd") << "400 1.66 550 0.43 700 0.16";
    std::ofstream(dir / "parts" / "gold.pbrt") << "Material \"conductor\" \"spectrum eta\" "
                                                  "\"eta.spd\" \"spectrum k\" [\"spds/Au.k.spd\"]\n"
                                               << kTri;
    std::ofstream(dir / "main.pbrt") << "WorldBegin\nInclude \"parts/gold.pbrt\"\n";
    const auto s = cb::parseSceneFile((dir / "main.pbrt").string());
    REQUIRE(s.materials.size() == 1);
    // eta.spd beside parts/gold.pbrt, spds/Au.k.spd beside main.pbrt (pbrt-v4's folder).
    using Samples = std::vector<std::pair<float, float>>;
    CHECK(s.materials[0].conductorEta->samples ==
          Samples{{400, 1.66f}, {550, 0.43f}, {700, 0.16f}});
    CHECK(s.materials[0].conductorK->samples == Samples{{400, 1.96f}, {550, 2.45f}, {700, 3.92f}});
    CHECK(s.usesSpectra);
    CHECK(std::count_if(s.sourceFiles.begin(), s.sourceFiles.end(), [](const std::string& f) {
              return f.size() > 4 && f.compare(f.size() - 4, 4, ".spd") == 0;
          }) == 2);
    // Errors at the file's own line and column.
    auto errorIn = [&](const std::string& spd) {
        std::ofstream(dir / "bad.spd") << spd;
        std::ofstream(dir / "bad.pbrt")
            << "WorldBegin\nMaterial \"diffuse\" \"spectrum reflectance\" \"bad.spd\"\n";
        try {
            cb::parseSceneFile((dir / "bad.pbrt").string());
        } catch (const SceneError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    CHECK(contains(errorIn("400 0.5\n550 x\n"), "bad.spd:2:5: expected a number"));
    CHECK(contains(errorIn("400 0.5\n550 1.5\n"), "bad.spd:2:5: parameter \"spectrum reflectance\" "
                                                  "is a reflectance and must be <= 1"));
    CHECK(contains(errorIn("400 0.5 550\n"), "bad.spd: parameter \"spectrum reflectance\""));
    CHECK(contains(errorIn("# nothing\n"), "holds no (wavelength, value) pairs"));
    CHECK(contains(errorIn("500 0.5 400 0.5\n"), "bad.spd:1:9: wavelengths must be strictly"));
    // pbrt-v4 looks a name up among its named spectra first: a file of that name is not read.
    std::ofstream(dir / "metal-Ag-k") << "400 1 700 1\n";
    std::ofstream(dir / "silver.pbrt") << "WorldBegin\nMaterial \"conductor\" \"spectrum eta\" "
                                          "\"metal-Ag-eta\" \"spectrum k\" \"metal-Ag-k\"\n"
                                       << kTri;
    CHECK(cb::parseSceneFile((dir / "silver.pbrt").string()).materials[0].conductorK->samples ==
          cb::toPiecewiseLinear(*cb::findNamedSpectrum("metal-Ag-k")));
    std::filesystem::remove_all(dir);
}

// A smooth Fresnel conductor plane under a constant sky seen from straight above: each camera
// ray is reflected into the sky, so a pixel is L F(cos theta) with cos theta = 1 / sqrt(1 + x^2 +
// y^2) on the film plane at distance 1 (fov 90). The image mean per channel is L times F's mean
// over the film, with each channel its own eta and k; every method renders it.
TEST_CASE("pbrt-v4 conductor: a smooth eta, k plane under a constant sky has radiance L F, every "
          "method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double radiance = 0.8;
    struct Case {
        const char* material;
        float eta[3], k[3];
    };
    const Case cases[] = {{"\"rgb eta\" [0.17 0.43 1.5] \"rgb k\" [3.1 2.4 1.9]",
                           {0.17f, 0.43f, 1.5f},
                           {3.1f, 2.4f, 1.9f}},
                          // Flat spectra render spectrally (16 bins), grey.
                          {"\"spectrum eta\" [400 1.2 700 1.2] \"spectrum k\" [400 0.5 700 0.5]",
                           {1.2f, 1.2f, 1.2f},
                           {0.5f, 0.5f, 0.5f}}};
    for (const Case& c : cases) {
        CAPTURE(c.material);
        const std::string text =
            "LookAt 0 1 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 90\n"
            "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
            "PixelFilter \"box\"\nWorldBegin\n" // the film's own area, which F's mean covers
            "LightSource \"infinite\" \"rgb L\" [0.8 0.8 0.8]\n"
            "Material \"conductor\" " +
            std::string(c.material) +
            "\nShape \"bilinearmesh\" \"point3 P\" [-10 0 -10  10 0 -10  -10 0 10  10 0 10]\n";
        const cb::DeviceScene scene = cb::buildDeviceScene(parseSceneString(text, "t.pbrt"));
        CHECK(contains(scene.featureNames(), "conductor-fresnel"));
        double expected[3] = {0, 0, 0};
        const int n = 400; // midpoint rule on the film plane; F is smooth, error < 1e-6
        for (int j = 0; j < n; ++j)
            for (int i = 0; i < n; ++i) {
                const double x = -1 + (i + 0.5) * 2.0 / n, y = -1 + (j + 0.5) * 2.0 / n;
                const float cosTheta = float(1.0 / std::sqrt(1 + x * x + y * y));
                for (int ch = 0; ch < 3; ++ch)
                    expected[ch] += radiance * cbk::fresnelConductor(cosTheta, c.eta[ch], c.k[ch]) /
                                    (double(n) * n);
            }
        for (const std::string method : kMethods) {
            CAPTURE(method);
            const BinnedMeans b = channelMeans(scene, runtime, methodSettings(method), 4, 700u);
            // Spectral: the film's rendering of a flat spectrum under the sky's white, 1e-3.
            checkChannelMeans(b, {expected[0], expected[1], expected[2]},
                              scene.channels == 3 ? 1e-4 : 2e-3);
        }
    }
}

TEST_CASE("pbrt-v4 conductor: BDPT, CBDPT and MLT agree with PT with rough eta, k blocks" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt(kDiskLight,
                            "AttributeBegin\nMaterial \"conductor\" \"rgb eta\" [0.17 0.43 1.5] "
                            "\"rgb k\" [3.1 2.4 1.9] \"float roughness\" 0.1\n"
                            "Translate 0.8 0.3 -0.4\nShape \"sphere\" \"float radius\" 0.3\n"
                            "AttributeEnd\n");
}

TEST_CASE("pbrt-v4 dielectric: roughness makes it rough (alpha = sqrt(roughness) by default)") {
    const std::string light = "WorldBegin\nLightSource \"point\"\n";
    auto scene = cb::buildDeviceScene(parseSceneString(
        light + "Material \"dielectric\" \"float eta\" 1.33 \"float roughness\" 0.09\n" + kTri,
        "t.pbrt"));
    REQUIRE(scene.materials.size() == 1);
    CHECK(scene.materials[0].alpha == doctest::Approx(0.3));
    CHECK(scene.materials[0].eta == doctest::Approx(1.33));
    CHECK(contains(scene.featureNames(), "rough-dielectric"));
    scene = cb::buildDeviceScene(
        parseSceneString(light +
                             "Material \"dielectric\" \"float uroughness\" 0.09 \"float "
                             "vroughness\" 0.09 \"bool remaproughness\" false\n" +
                             kTri,
                         "t.pbrt"));
    CHECK(scene.materials[0].alpha == doctest::Approx(0.09));
    // Smooth glass compiles no rough code.
    scene = cb::buildDeviceScene(parseSceneString(
        light + "Material \"dielectric\" \"float roughness\" 0\n" + kTri, "t.pbrt"));
    CHECK(scene.materials[0].alpha == 0.0f);
    CHECK(contains(scene.featureNames(), "dielectric"));
    CHECK(!contains(scene.featureNames(), "rough-dielectric"));
    // A glass or coat of eta 1 is no interface (pbrt-v4): smooth whatever its roughness (a rough
    // one's straight transmission has no half vector: it rendered black).
    for (const char* material :
         {"dielectric\" \"float eta\" 1", "coateddiffuse\" \"float eta\" 1",
          "coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] \"float interface.eta\" 1"}) {
        CAPTURE(material);
        const cb::DeviceScene none = cb::buildDeviceScene(parseSceneString(
            light + "Material \"" + material + " \"float " +
                (contains(material, "interface") ? "interface." : "") + "roughness\" 0.2\n" + kTri,
            "t.pbrt"));
        CHECK(none.materials[0].alpha == 0.0f);
        CHECK(!contains(none.featureNames(), "rough-dielectric"));
    }
    // Glass of eta 1 passes everything straight through.
    cb::ClRuntime runtime;
    const cb::DeviceScene pane = cb::buildDeviceScene(
        parseSceneString("LookAt 0 1 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 90\n"
                         "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
                         "WorldBegin\nLightSource \"infinite\" \"rgb L\" [0.5 0.5 0.5]\n"
                         "Material \"dielectric\" \"float eta\" 1 \"float roughness\" 0.2\n"
                         "Shape \"bilinearmesh\" \"point3 P\" [-2 0 -2  2 0 -2  -2 0 2  2 0 2]\n",
                         "t.pbrt"));
    const BinnedMeans b = channelMeans(pane, runtime, methodSettings("pt"), 2, 1200u);
    checkChannelMeans(b, {0.5, 0.5, 0.5}, 1e-6);
}

TEST_CASE("pbrt-v4 dielectric: BDPT, CBDPT and MLT agree with PT with a rough glass sphere" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt(kDiskLight,
                            "AttributeBegin\nMaterial \"dielectric\" \"float eta\" 1.5 "
                            "\"float roughness\" 0.1\n"
                            "Translate 0.5 0.35 -0.5\nShape \"sphere\" \"float radius\" 0.3\n"
                            "AttributeEnd\n");
}

TEST_CASE("pbrt-v4 diffusetransmission and thindielectric: parameters, defaults, refusals") {
    const std::string light = "WorldBegin\nLightSource \"point\"\n";
    // pbrt-v4's defaults: reflectance and transmittance 0.25, eta 1.5.
    auto s = parseSceneString(light + "Material \"diffusetransmission\"\n" + kTri +
                                  "Material \"thindielectric\"\n" + kTri,
                              "t.pbrt");
    REQUIRE(s.materials.size() == 2);
    CHECK(s.materials[0].kind == cb::MaterialKind::DiffuseTransmission);
    CHECK(s.materials[1].kind == cb::MaterialKind::ThinDielectric);
    CHECK(s.materials[1].eta == 1.5f);
    cb::DeviceScene scene = cb::buildDeviceScene(s);
    REQUIRE(scene.channels == 3);
    CHECK(contains(scene.featureNames(), "diffuse-transmission"));
    CHECK(contains(scene.featureNames(), "thin-dielectric"));
    CHECK(!contains(scene.featureNames(), "conductor-fresnel"));
    auto entry = [&](int index, int channel) {
        return scene.spectra[size_t(index * scene.channels + channel)];
    };
    CHECK(entry(scene.materials[0].reflectance, 1) == 0.25f);
    CHECK(entry(scene.materials[0].secondSpectrum, 2) == 0.25f);
    // "scale" multiplies both; each product is clamped to 1 per channel, as pbrt-v4 clamps it.
    s = parseSceneString(light +
                             "Material \"diffusetransmission\" \"rgb reflectance\" [0.2 0.5 0.9] "
                             "\"rgb transmittance\" [0.1 0.3 0.6] \"float scale\" 2\n" +
                             kTri + "Material \"thindielectric\" \"float eta\" 1.33\n" + kTri,
                         "t.pbrt");
    scene = cb::buildDeviceScene(s);
    CHECK(entry(scene.materials[0].reflectance, 0) == doctest::Approx(0.4));
    CHECK(entry(scene.materials[0].reflectance, 2) == 1.0f);
    CHECK(entry(scene.materials[0].secondSpectrum, 1) == doctest::Approx(0.6));
    CHECK(entry(scene.materials[0].secondSpectrum, 2) == 1.0f);
    CHECK(scene.materials[1].kind == CB_MAT_THIN_DIELECTRIC);
    CHECK(scene.materials[1].eta == doctest::Approx(1.33));
    // Any scale, as pbrt-v4: a negative one clamps both to black; the spectral bins clamp alike.
    s = parseSceneString(light + "Material \"diffusetransmission\" \"float scale\" -2\n" + kTri +
                             "Material \"diffusetransmission\" \"spectrum reflectance\" "
                             "[400 0.2 700 0.9] \"float scale\" 1.5\n" +
                             kTri,
                         "t.pbrt");
    scene = cb::buildDeviceScene(s);
    REQUIRE(scene.channels == 16);
    for (int c = 0; c < scene.channels; ++c) {
        CHECK(entry(scene.materials[0].reflectance, c) == 0.0f);
        CHECK(entry(scene.materials[0].secondSpectrum, c) == 0.0f);
    }
    // 0.2 .. 0.9 over 400-700 nm times 1.5: 0.3 .. 1.35, the upper bins clamped to 1.
    CHECK(entry(scene.materials[1].reflectance, 0) ==
          doctest::Approx(1.5 * (0.2 + 0.7 * 9.375 / 300)).epsilon(1e-3));
    CHECK(entry(scene.materials[1].reflectance, scene.channels - 1) == 1.0f);
    CHECK(entry(scene.materials[1].secondSpectrum, 3) == doctest::Approx(0.375));
    // Without them, neither feature is compiled.
    scene = cb::buildDeviceScene(parseSceneString(light + kTri, "t.pbrt"));
    CHECK(!contains(scene.featureNames(), "transmission"));
    CHECK(!contains(scene.featureNames(), "thin"));
    expectError("WorldBegin\nMaterial \"diffusetransmission\" \"rgb transmittance\" [0.5 1.2 0]\n",
                {"t.pbrt:2:", "must be <= 1"});
    expectError("WorldBegin\nMaterial \"thindielectric\" \"rgb eta\" [1.5 1.4 1.3]\n",
                {"t.pbrt:2:", "\"float eta\" or \"spectrum eta\", not rgb"});
    expectError("WorldBegin\nMaterial \"thindielectric\" \"float eta\" 0\n",
                {"t.pbrt:2:39: \"float eta\" must be > 0, got 0"});
    expectError("WorldBegin\nMaterial \"thindielectric\" \"float roughness\" 0.1\n",
                {"t.pbrt:2:", "roughness"});
    expectError(
        "WorldBegin\nMaterial \"subsurface\"\n",
        {"t.pbrt:2:", "thindielectric, diffusetransmission, coateddiffuse, coatedconductor"});
}

using cbtest::thinSheetReflectance;

// The lid scene (method_checks.h, lidSceneText) with the material under test as its lid, from
// above and from inside. diffusetransmission: R L and T L per channel, everywhere.
// thindielectric: L R(theta) and L (1 - R(theta)), R the sheet's reflectance summed over its
// internal bounces, theta the pixel's angle to the lid's normal. Every method renders the image
// mean.
TEST_CASE("pbrt-v4 diffusetransmission and thindielectric: a lid on a black box under a "
          "constant sky, every method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double radiance = kLidSky;
    const double reflectance[3] = {0.5, 0.3, 0.2}, transmittance[3] = {0.2, 0.4, 0.6};
    const double thinR = lidFilmMean([](double c) { return thinSheetReflectance(c, 1.5); }, 400);
    struct Case {
        std::string material, camera;
        std::array<double, 3> expected;
    };
    const std::string dt = "Material \"diffusetransmission\" \"rgb reflectance\" [0.5 0.3 0.2] "
                           "\"rgb transmittance\" [0.2 0.4 0.6]\n";
    const std::string thin = "Material \"thindielectric\" \"float eta\" 1.5\n";
    const std::string &above = kLidAbove, &inside = kLidInside;
    auto scaled = [&](const double* v) {
        return std::array<double, 3>{radiance * v[0], radiance * v[1], radiance * v[2]};
    };
    const Case cases[] = {
        {dt, above, scaled(reflectance)},
        {dt, inside, scaled(transmittance)},
        {thin, above, {radiance * thinR, radiance * thinR, radiance * thinR}},
        {thin, inside, {radiance * (1 - thinR), radiance * (1 - thinR), radiance * (1 - thinR)}}};
    // The sheet reflects more than one face: R(0) = 0.04 for eta 1.5, the sheet 2R / (1 + R).
    CHECK(thinSheetReflectance(1.0, 1.5) == doctest::Approx(0.08 / 1.04).epsilon(1e-12));
    for (const Case& c : cases) {
        CAPTURE(c.material);
        CAPTURE(c.camera);
        const cb::DeviceScene scene =
            cb::buildDeviceScene(parseSceneString(lidSceneText(c.camera, c.material), "t.pbrt"));
        // CPT's and CBDPT's pixels share each estimate's lobe choice: 64 estimates per run.
        checkEveryMethodChannelMeans(scene, runtime, c.expected, 4, 64, 900u);
    }
}

// A mix of mixes: m = 0.5 diffuse + 0.5 n, n = 0.6 diffusetransmission + 0.4 thindielectric, so
// the lid weighs them 0.5, 0.3 and 0.2. From above it reflects L (0.5 rho + 0.3 R + 0.2
// R(theta)); from inside it transmits L (0.3 T + 0.2 (1 - R(theta))). Every method.
TEST_CASE("pbrt-v4 mix of mixes: a lid of three materials under a constant sky, every method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double thinR = lidFilmMean([](double c) { return thinSheetReflectance(c, 1.5); }, 400);
    const std::string lid =
        "MakeNamedMaterial \"d\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.9 0.5 0.1]\n"
        "MakeNamedMaterial \"t\" \"string type\" \"diffusetransmission\" \"rgb reflectance\" "
        "[0.5 0.3 0.2] \"rgb transmittance\" [0.2 0.4 0.6]\n"
        "MakeNamedMaterial \"g\" \"string type\" \"thindielectric\" \"float eta\" 1.5\n"
        "MakeNamedMaterial \"n\" \"string type\" \"mix\" \"string materials\" [\"t\" \"g\"] "
        "\"float amount\" 0.4\n"
        "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"d\" \"n\"]\n"
        "NamedMaterial \"m\"\n";
    const double rho[3] = {0.9, 0.5, 0.1}, r[3] = {0.5, 0.3, 0.2}, t[3] = {0.2, 0.4, 0.6};
    for (const bool above : {true, false}) {
        CAPTURE(above);
        std::array<double, 3> expected{};
        for (size_t c = 0; c < 3; ++c)
            expected[c] = kLidSky * (above ? 0.5 * rho[c] + 0.3 * r[c] + 0.2 * thinR
                                           : 0.3 * t[c] + 0.2 * (1 - thinR));
        const cb::DeviceScene scene = cb::buildDeviceScene(
            parseSceneString(lidSceneText(above ? kLidAbove : kLidInside, lid), "t.pbrt"));
        checkEveryMethodChannelMeans(scene, runtime, expected, 4, 64, 910u);
    }
}

TEST_CASE("pbrt-v4 diffusetransmission and thindielectric: BDPT, CBDPT and MLT agree with PT" *
          doctest::test_suite("statistical")) {
    // A diffuser below the light (most paths to it pass through), a translucent sphere, and a
    // thin pane standing before the block.
    checkMethodsAgreeWithPt("AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [6 6 6]\n"
                            "Translate -0.5 1.5 0\nRotate 90 1 0 0\n"
                            "Shape \"disk\" \"float radius\" 0.3\nAttributeEnd\n"
                            "AttributeBegin\nMaterial \"diffusetransmission\" \"rgb reflectance\" "
                            "[0.2 0.3 0.4] \"rgb transmittance\" [0.7 0.6 0.5]\n"
                            "Shape \"bilinearmesh\" \"point3 P\" [-1 1.3 -0.6  0 1.3 -0.6  "
                            "-1 1.3 0.6  0 1.3 0.6]\nAttributeEnd\n",
                            "AttributeBegin\nMaterial \"diffusetransmission\" \"rgb reflectance\" "
                            "[0.4 0.4 0.4] \"rgb transmittance\" [0.5 0.5 0.5]\n"
                            "Translate 0.8 0.3 -0.4\nShape \"sphere\" \"float radius\" 0.3\n"
                            "AttributeEnd\n"
                            "AttributeBegin\nMaterial \"thindielectric\" \"float eta\" 1.5\n"
                            "Translate 0 0.5 -0.6\nRotate 20 0 1 0\n"
                            "Shape \"bilinearmesh\" \"point3 P\" [-0.5 -0.4 0  0.5 -0.4 0  "
                            "-0.5 0.4 0  0.5 0.4 0]\nAttributeEnd\n");
}

namespace {

// A coated material's coat index and layer as parsed (MaterialDesc) or on the device (Material).
template <class M> void checkLayer(const M& m, float eta, float thickness, int depth, int samples) {
    CHECK(m.eta == eta);
    CHECK(m.thickness == thickness);
    CHECK(m.layerDepth == depth);
    CHECK(m.layerSamples == samples);
}

} // namespace

TEST_CASE("pbrt-v4 coateddiffuse: parameters, defaults, refusals") {
    const std::string light = "WorldBegin\nLightSource \"point\"\n";
    // pbrt-v4's defaults: reflectance 0.5, eta 1.5, thickness 0.01, maxdepth 10, nsamples 1.
    auto s = parseSceneString(light + "Material \"coateddiffuse\"\n" + kTri +
                                  "Material \"coateddiffuse\" \"rgb reflectance\" [0.9 0.4 0.1] "
                                  "\"float eta\" 1.33 \"float thickness\" 0.5 \"integer maxdepth\" "
                                  "4 \"integer nsamples\" 3 \"float roughness\" 0 "
                                  "\"rgb albedo\" [0 0 0] \"float g\" 0.3\n" +
                                  kTri,
                              "t.pbrt");
    REQUIRE(s.materials.size() == 2);
    CHECK(s.materials[0].kind == cb::MaterialKind::CoatedDiffuse);
    checkLayer(s.materials[0], 1.5f, 0.01f, 10, 1);
    cb::DeviceScene scene = cb::buildDeviceScene(s);
    REQUIRE(scene.channels == 3);
    CHECK(contains(scene.featureNames(), "coated-diffuse"));
    const cbk::Material& given = scene.materials[1];
    CHECK(given.kind == CB_MAT_COATED_DIFFUSE);
    checkLayer(given, 1.33f, 0.5f, 4, 3);
    CHECK(scene.spectra[size_t(given.reflectance * 3)] == doctest::Approx(0.9f));
    CHECK(scene.spectra[size_t(scene.materials[0].reflectance * 3 + 1)] == doctest::Approx(0.5f));
    // Only scenes with a coat compile it.
    cb::DeviceScene plain =
        cb::buildDeviceScene(parseSceneString(light + "Material \"diffuse\"\n" + kTri, "t.pbrt"));
    CHECK(!contains(plain.featureNames(), "coated-diffuse"));
    // Thickness 0 keeps pbrt-v4's smallest normal float (no absorption).
    cb::DeviceScene thin = cb::buildDeviceScene(parseSceneString(
        light + "Material \"coateddiffuse\" \"float thickness\" 0\n" + kTri, "t.pbrt"));
    CHECK(thin.materials[0].thickness == std::numeric_limits<float>::min());
    // A rough coat is a rough dielectric interface, alpha = sqrt(roughness) by default; below
    // pbrt-v4's alpha 1e-3 it is smooth: roughness 1e-7 (alpha 3.2e-4).
    cb::DeviceScene rough = cb::buildDeviceScene(parseSceneString(
        light + "Material \"coateddiffuse\" \"float roughness\" 0.09\n" + kTri, "t.pbrt"));
    CHECK(rough.materials[0].alpha == doctest::Approx(0.3f));
    CHECK(contains(rough.featureNames(), "rough-dielectric"));
    cb::DeviceScene nearlySmooth = cb::buildDeviceScene(parseSceneString(
        light + "Material \"coateddiffuse\" \"float roughness\" 1e-7\n" + kTri, "t.pbrt"));
    CHECK(nearlySmooth.materials[0].alpha == 0.0f);
    CHECK(!contains(nearlySmooth.featureNames(), "rough-dielectric"));
    CHECK(!contains(scene.featureNames(), "rough-dielectric"));
    // A coat of index below 1, smooth or rough (total reflection from outside).
    CHECK_NOTHROW(parseSceneString(
        light + "Material \"coateddiffuse\" \"float eta\" 0.9 \"float roughness\" 0.1\n" + kTri,
        "t.pbrt"));
    expectError(light + "Material \"coateddiffuse\" \"float uroughness\" 0.1 "
                        "\"float vroughness\" 0.2\n",
                {"t.pbrt:3:", "anisotropic"});
    // A scattering layer: its albedo (0, pbrt-v4's default, does not scatter) and g in (-1, 1).
    const cb::DeviceScene scattering = cb::buildDeviceScene(parseSceneString(
        light + "Material \"coateddiffuse\" \"rgb albedo\" [0.5 0.25 0] \"float g\" -0.4\n" + kTri,
        "t.pbrt"));
    REQUIRE(scattering.materials[0].layerAlbedo >= 0);
    CHECK(scattering.spectra[size_t(scattering.materials[0].layerAlbedo * 3 + 1)] ==
          doctest::Approx(0.25f));
    CHECK(scattering.materials[0].layerG == -0.4f);
    CHECK(scene.materials[1].layerAlbedo == -1);
    CHECK(scene.materials[1].layerG == 0.3f);
    // g beyond +-1 is clamped to it, as pbrt-v4 does (its phase function then keeps it within
    // 0.99).
    CHECK(cb::buildDeviceScene(parseSceneString(light +
                                                    "Material \"coateddiffuse\" \"rgb albedo\" "
                                                    "[0.5 0.5 0.5] \"float g\" 3\n" +
                                                    kTri,
                                                "t.pbrt"))
              .materials[0]
              .layerG == 1.0f);
    expectError(light + "Material \"coateddiffuse\" \"float thickness\" -1\n",
                {"t.pbrt:3:", "\"float thickness\" must be >= 0, got -1"});
    expectError(light + "Material \"coateddiffuse\" \"integer maxdepth\" -1\n",
                {"t.pbrt:3:", "must be in [0, 1000], got -1"});
    expectError(light + "Material \"coateddiffuse\" \"integer nsamples\" 0\n",
                {"t.pbrt:3:", "must be in [1, 1000], got 0"});
    expectError(light + "Material \"coateddiffuse\" \"spectrum eta\" [400 1.5 700 1.4]\n",
                {"t.pbrt:3:", "spectrally varying"});
    expectError(light + "Material \"coateddiffuse\" \"texture reflectance\" \"t\"\n",
                {"t.pbrt:3:"});
    // A bump map (tests/test_shading_normals.cpp) on a coat's material too.
    CHECK(parseSceneString(light + "Material \"coateddiffuse\" \"float displacement\" 0.1\n",
                           "t.pbrt")
              .materials.back()
              .displacement >= 0);
}

// The closed black box of the lid test above with a coated lid, seen from above under a
// constant sky: every pixel is L A(theta) per channel, theta its angle to the lid's normal. The
// coated diffuse's A is cbtest::CoatedDiffuseReference's: pbrt-v4's default depth 10 (five visits
// to the base) and a deep walk (1000), a thick and a vanishing layer, two indices. The coated
// conductor's, both layers smooth, is cbtest::smoothCoatedConductorAlbedo: a conductor given by
// its reflectance and one by eta and k, under a coat of index above and below 1.
TEST_CASE("pbrt-v4 coateddiffuse and coatedconductor: a coated lid under a constant sky renders "
          "L A(theta), every method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double radiance = kLidSky, rho[3] = {0.8, 0.5, 0.2};
    const double eta[3] = {0.2, 0.9, 1.4}, k[3] = {3.0, 2.5, 1.9};
    struct Case {
        std::string material;
        std::function<double(int channel, double cosTheta)> albedo;
    };
    auto coatedDiffuse = [&](double coatEta, double thickness, int maxDepth) {
        // One reference per channel: each integrates its layer's transmission once.
        std::vector<cbtest::CoatedDiffuseReference> perChannel;
        for (int ch = 0; ch < 3; ++ch)
            perChannel.emplace_back(rho[ch], coatEta, thickness, maxDepth);
        return Case{fmt::format("Material \"coateddiffuse\" \"rgb reflectance\" [0.8 0.5 0.2] "
                                "\"float eta\" {} \"float thickness\" {} \"integer maxdepth\" {}\n",
                                coatEta, thickness, maxDepth),
                    [perChannel](int ch, double c) { return perChannel[size_t(ch)].albedo(c); }};
    };
    const Case cases[] = {
        coatedDiffuse(1.5, 0.25, 10),
        coatedDiffuse(1.33, 0.0, 1000),
        {"Material \"coatedconductor\" \"rgb reflectance\" [0.8 0.5 0.2] "
         "\"float interface.eta\" 1.5 \"float thickness\" 0.25\n",
         [&](int ch, double c) {
             return cbtest::smoothCoatedConductorAlbedo(
                 c, 1.5, 1.0, cbtest::conductorKFromReflectance(rho[ch]), 0.25, 10);
         }},
        {"Material \"coatedconductor\" \"rgb conductor.eta\" [0.2 0.9 1.4] "
         "\"rgb conductor.k\" [3 2.5 1.9] \"float interface.eta\" 0.8 \"float thickness\" 0 "
         "\"integer maxdepth\" 1000\n",
         [&](int ch, double c) {
             return cbtest::smoothCoatedConductorAlbedo(c, 0.8, eta[ch], k[ch], 0.0, 1000);
         }}};
    for (const Case& c : cases) {
        CAPTURE(c.material);
        std::array<double, 3> expected{};
        for (int ch = 0; ch < 3; ++ch)
            expected[size_t(ch)] =
                radiance * lidFilmMean([&](double cosTheta) { return c.albedo(ch, cosTheta); });
        const cb::DeviceScene scene =
            cb::buildDeviceScene(parseSceneString(lidSceneText(kLidAbove, c.material), "t.pbrt"));
        // One shared coat choice per CPT and CBDPT estimate: 64 estimates per run.
        checkEveryMethodChannelMeans(scene, runtime, expected, 4, 64, 1100u);
    }
}

TEST_CASE("pbrt-v4 coateddiffuse: BDPT, CBDPT and MLT agree with PT" *
          doctest::test_suite("statistical")) {
    // A coated floor under the block, a sphere with a rough coat beside it.
    checkMethodsAgreeWithPt(kDiskLight,
                            "AttributeBegin\nMaterial \"coateddiffuse\" \"rgb reflectance\" "
                            "[0.6 0.3 0.2] \"float thickness\" 0.1\n"
                            "Shape \"bilinearmesh\" \"point3 P\" [-1.5 0.01 -1.5  1.5 0.01 -1.5  "
                            "-1.5 0.01 1  1.5 0.01 1]\nAttributeEnd\n"
                            "AttributeBegin\nMaterial \"coateddiffuse\" \"rgb reflectance\" "
                            "[0.2 0.5 0.7] \"float eta\" 1.4 \"float roughness\" 0.05\n"
                            "Translate 0.8 0.3 -0.4\nShape \"sphere\" \"float radius\" 0.3\n"
                            "AttributeEnd\n");
}

TEST_CASE("pbrt-v4 coatedconductor: parameters, defaults, refusals") {
    const std::string light = "WorldBegin\nLightSource \"point\"\n";
    // pbrt-v4's defaults: interface eta 1.5, both layers smooth, thickness 0.01, maxdepth 10,
    // nsamples 1; its default conductor is copper's measured spectra (below).
    auto s = parseSceneString(
        light + "Material \"coatedconductor\" \"rgb reflectance\" [0.9 0.5 0.2]\n" + kTri +
            "Material \"coatedconductor\" \"rgb conductor.eta\" [0.2 0.9 1.4] "
            "\"rgb conductor.k\" [3 2.5 1.9] \"float interface.eta\" 1.33 "
            "\"float interface.roughness\" 0.09 \"float conductor.roughness\" 0.16 "
            "\"float thickness\" 0.5 \"integer maxdepth\" 4 \"integer nsamples\" 3 "
            "\"rgb albedo\" [0 0 0] \"float g\" 0.3\n" +
            kTri +
            "Material \"coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] "
            "\"float conductor.uroughness\" 0.04 \"float conductor.vroughness\" 0.04 "
            "\"bool remaproughness\" false\n" +
            kTri,
        "t.pbrt");
    REQUIRE(s.materials.size() == 3);
    CHECK(s.materials[0].kind == cb::MaterialKind::CoatedConductor);
    checkLayer(s.materials[0], 1.5f, 0.01f, 10, 1);
    cb::DeviceScene scene = cb::buildDeviceScene(s);
    REQUIRE(scene.channels == 3);
    CHECK(contains(scene.featureNames(), "coated-conductor"));
    CHECK(contains(scene.featureNames(), "rough-dielectric"));
    CHECK(!contains(scene.featureNames(), "coated-diffuse"));
    const cbk::Material& plain = scene.materials[0];
    CHECK(plain.kind == CB_MAT_COATED_CONDUCTOR);
    CHECK(plain.alpha == 0.0f);
    CHECK(plain.baseAlpha == 0.0f);
    CHECK(plain.secondSpectrum == -1);
    CHECK(scene.spectra[size_t(plain.reflectance * 3 + 2)] == doctest::Approx(0.2f));
    const cbk::Material& given = scene.materials[1];
    checkLayer(given, 1.33f, 0.5f, 4, 3);
    CHECK(given.alpha == doctest::Approx(0.3f));
    CHECK(given.baseAlpha == doctest::Approx(0.4f));
    CHECK(scene.spectra[size_t(given.reflectance * 3)] == doctest::Approx(0.2f));
    CHECK(scene.spectra[size_t(given.secondSpectrum * 3 + 1)] == doctest::Approx(2.5f));
    CHECK(scene.materials[2].baseAlpha == doctest::Approx(0.04f)); // not remapped
    // Only scenes with the material compile it; a smooth coat needs no rough interface.
    const cb::DeviceScene smooth = cb::buildDeviceScene(parseSceneString(
        light + "Material \"coatedconductor\" \"rgb reflectance\" [0.9 0.5 0.2]\n" + kTri,
        "t.pbrt"));
    CHECK(contains(smooth.featureNames(), "coated-conductor"));
    CHECK(!contains(smooth.featureNames(), "rough-dielectric"));
    // pbrt-v4's default conductor under the coat, and for a missing conductor.k: copper's.
    const auto copperUnder =
        parseSceneString(light + "Material \"coatedconductor\"\n" + kTri +
                             "Material \"coatedconductor\" \"rgb conductor.eta\" [1 1 1]\n" + kTri,
                         "t.pbrt");
    const auto cuK = cb::toPiecewiseLinear(*cb::findNamedSpectrum("metal-Cu-k"));
    CHECK(copperUnder.materials[0].conductorEta->samples ==
          cb::toPiecewiseLinear(*cb::findNamedSpectrum("metal-Cu-eta")));
    CHECK(copperUnder.materials[0].conductorK->samples == cuK);
    CHECK(copperUnder.materials[1].conductorK->samples == cuK);
    expectError(light + "Material \"coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] "
                        "\"rgb conductor.k\" [1 1 1]\n",
                {"t.pbrt:3:", "not both"});
    expectError(light + "Material \"coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] "
                        "\"float conductor.uroughness\" 0.1\n",
                {"t.pbrt:3:", "anisotropic roughness (conductor.uroughness != "
                              "conductor.vroughness)"});
    expectError(light + "Material \"coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] "
                        "\"float interface.roughness\" -1\n",
                {"t.pbrt:3:", "interface.roughness must be >= 0, got -1"});
    expectError(light + "Material \"coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] "
                        "\"spectrum interface.eta\" [400 1.5 700 1.4]\n",
                {"t.pbrt:3:", "spectrally varying dielectric \"interface.eta\""});
    expectError(light + "Material \"coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] "
                        "\"rgb interface.eta\" [1.5 1.5 1.5]\n",
                {"t.pbrt:3:", "spectrally varying dielectric \"interface.eta\""});
    expectError(light + "Material \"coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] "
                        "\"float interface.eta\" 0\n",
                {"t.pbrt:3:", "\"float interface.eta\" must be > 0, got 0"});
    expectError(light + "Material \"coatedconductor\" \"rgb reflectance\" [0.5 0.5 0.5] "
                        "\"float eta\" 1.5\n",
                {"t.pbrt:3:", "unknown or unsupported parameter \"float eta\""});
}

// pbrt-v4 gives an RGB albedo a sigmoid spectrum fit under D65, so lit by the white of an RGB
// light it renders as its RGB; cbdpt's spectra (rgbToSpectrum) are fit through its film under
// that white too. A saturated red plane under a white sky, rendered in spectra: each channel is
// the albedo, every method.
TEST_CASE("pbrt-v4 colour: an RGB albedo under a white sky renders as its RGB in spectra" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = cb::buildDeviceScene(
        cb::parseSceneString(
            "LookAt 0 0 3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 20\n"
            "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n"
            "LightSource \"infinite\" \"rgb L\" [1 1 1]\n"
            "Material \"diffuse\" \"rgb reflectance\" [0.7 0.12 0.1]\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-5 -5 0  5 -5 0  -5 5 0  5 5 0]\n",
            "t.pbrt"),
        cb::ChannelMode::Spectral);
    REQUIRE(scene.channels == 16);
    checkEveryMethodChannelMeans(scene, runtime, {0.7, 0.12, 0.1}, 16, 64, 700u);
}

TEST_CASE("pbrt-v4 coatedconductor: BDPT, CBDPT and MLT agree with PT" *
          doctest::test_suite("statistical")) {
    // A floor of rough gold under a smooth coat, a sphere of a smooth conductor under a rough
    // coat, and a smaller one of a smooth conductor under a smooth coat over a layer that
    // scatters (its paths over the mirror).
    checkMethodsAgreeWithPt(kDiskLight,
                            "AttributeBegin\nMaterial \"coatedconductor\" \"rgb conductor.eta\" "
                            "[0.17 0.43 1.5] \"rgb conductor.k\" [3.15 2.45 1.88] "
                            "\"float conductor.roughness\" 0.1\n"
                            "Shape \"bilinearmesh\" \"point3 P\" [-1.5 0.01 -1.5  1.5 0.01 -1.5  "
                            "-1.5 0.01 1  1.5 0.01 1]\nAttributeEnd\n"
                            "AttributeBegin\nMaterial \"coatedconductor\" \"rgb reflectance\" "
                            "[0.9 0.6 0.3] \"float interface.roughness\" 0.05\n"
                            "Translate 0.8 0.3 -0.4\nShape \"sphere\" \"float radius\" 0.3\n"
                            "AttributeEnd\n"
                            "AttributeBegin\nMaterial \"coatedconductor\" \"rgb reflectance\" "
                            "[0.8 0.8 0.8] \"rgb albedo\" [0.9 0.7 0.4] \"float g\" 0.4 "
                            "\"float thickness\" 0.5\n"
                            "Translate -0.7 0.25 -0.6\nShape \"sphere\" \"float radius\" 0.25\n"
                            "AttributeEnd\n");
}

TEST_CASE("pbrt-v4 film crop window and pixel bounds, camera screen window and frame") {
    const std::string light = "WorldBegin\nLightSource \"point\"\n";
    auto film = [&](const std::string& params) {
        return parseSceneString("Film \"rgb\" \"integer xresolution\" 100 "
                                "\"integer yresolution\" 50 " +
                                    params + "\n" + light,
                                "t.pbrt")
            .film;
    };
    // pbrt-v4's FilmBaseParameters: pixels [ceil(W x0), ceil(W x1)) x [ceil(H y0), ceil(H y1)).
    auto f = film("\"float cropwindow\" [0.105 0.5 0.2 1]");
    CHECK(f.pixelBounds == std::array<int, 4>{11, 50, 10, 50});
    // "pixelbounds" win over "cropwindow"; kept as fractions for another resolution.
    f = film("\"float cropwindow\" [0 1 0 1] \"integer pixelbounds\" [10 60 5 45]");
    CHECK(f.pixelBounds == std::array<int, 4>{10, 60, 5, 45});
    REQUIRE(f.cropWindow);
    CHECK(cb::cropWindowPixels(200, 100, *f.cropWindow) == std::array<int, 4>{20, 120, 10, 90});
    const cb::DeviceScene cropped = cb::buildDeviceScene(
        parseSceneString("Film \"rgb\" \"integer xresolution\" 100 \"integer yresolution\" 50 "
                         "\"integer pixelbounds\" [10 60 5 45]\n" +
                             light,
                         "t.pbrt"));
    CHECK(cropped.camera.width == 50);
    CHECK(cropped.camera.height == 40);
    CHECK(contains(errorOf("Film \"rgb\" \"integer xresolution\" 100 \"integer yresolution\" 50 "
                           "\"integer pixelbounds\" [10 160 5 45]\n"),
                   "t.pbrt:1:63: \"integer pixelbounds\" 10 160 5 45 must be x0 x1 y0 y1 with 0 "
                   "<= x0 < x1 <= 100"));
    CHECK(contains(errorOf("Film \"rgb\" \"float cropwindow\" [0.5 0.5 0 1]\n"),
                   "t.pbrt:1:12: \"float cropwindow\" 0.5 0.5 0 1: must be x0 x1 y0 y1"));
    CHECK(contains(errorOf("Film \"rgb\" \"float cropwindow\" [0 1 0]\n"),
                   "expects a multiple of 4 values"));
    // "diagonal" sizes only pbrt-v4's realistic camera's sensor.
    const auto noted = parseSceneString("Film \"rgb\" \"float diagonal\" 50\n" + light, "t.pbrt");
    REQUIRE(noted.notes.size() == 1);
    CHECK(contains(noted.notes[0], "\"float diagonal\" is not used"));

    // The screen window, in units of tan(fov / 2): [-a, a] x [-1, 1] for the frame aspect ratio
    // a > 1, or "screenwindow" itself; rays through the raster corners go where it says.
    const double t = std::tan(40.0 * M_PI / 360.0);
    auto camera = [&](const std::string& params) {
        return cb::buildDeviceScene(
                   parseSceneString("Camera \"perspective\" \"float fov\" 40 " + params +
                                        "\nFilm \"rgb\" \"integer xresolution\" 64 "
                                        "\"integer yresolution\" 32\n" +
                                        light,
                                    "t.pbrt"))
            .camera;
    };
    auto corner = [](const cbk::Camera& c, float x, float y) {
        const cbk::Ray r = cbk::cameraGenerateRay(&c, x, y, cbk::vec3(0, 0, 0));
        const cbk::Vec3 d = cbk::affineTransformVector(c.worldToCamera, r.d);
        return std::array<double, 2>{d.x / d.z, d.y / d.z};
    };
    const cbk::Camera plain = camera("");
    CHECK(corner(plain, 0, 0)[0] == doctest::Approx(-2 * t));
    CHECK(corner(plain, 0, 0)[1] == doctest::Approx(t));
    const cbk::Camera frame = camera("\"float frameaspectratio\" 0.5");
    CHECK(corner(frame, 0, 0)[0] == doctest::Approx(-t));
    CHECK(corner(frame, 64, 32)[1] == doctest::Approx(-2 * t));
    const cbk::Camera window = camera("\"float screenwindow\" [-0.5 1.5 0 1]");
    CHECK(corner(window, 0, 0)[0] == doctest::Approx(-0.5 * t));
    CHECK(corner(window, 0, 0)[1] == doctest::Approx(t));
    CHECK(corner(window, 64, 32)[0] == doctest::Approx(1.5 * t));
    CHECK(corner(window, 64, 32)[1] == doctest::Approx(0.0).epsilon(1e-6));
    // Projecting back lands on the same raster point (BDPT's light tracing uses it).
    float rx = 0, ry = 0;
    REQUIRE(cbk::cameraProjectPoint(
        &window, cbk::vec3(0, 0, 0),
        cbk::affineTransformPoint(window.cameraToWorld,
                                  cbk::vec3(float(1.0 * t), float(0.5 * t), 1)),
        &rx, &ry));
    CHECK(rx == doctest::Approx(48.0f));
    CHECK(ry == doctest::Approx(16.0f));
    CHECK(
        contains(errorOf("Camera \"perspective\" \"float screenwindow\" [1 -1 0 1]\n"), "x0 < x1"));
    CHECK(contains(errorOf("Camera \"perspective\" \"float frameaspectratio\" 0\n"), "> 0"));
}

TEST_CASE("pbrt-v4 Attribute: defaults for later shapes, lights and materials, scoped") {
    const auto s = parseSceneString(
        "WorldBegin\n"
        "Attribute \"shape\" \"float radius\" 0.25\n"
        "Attribute \"light\" \"float scale\" 2\n"
        "Attribute \"material\" \"rgb reflectance\" [0.1 0.2 0.3]\n"
        "LightSource \"point\"\n"
        "LightSource \"point\" \"float scale\" 5\n"
        "Material \"diffuse\"\n"
        "Shape \"sphere\"\n"
        "Shape \"sphere\" \"float radius\" 2\n"
        // A radius is no trianglemesh parameter: attributes may go unused.
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"
        "AttributeBegin\nAttribute \"shape\" \"float radius\" 3\nShape \"sphere\"\n"
        "AttributeEnd\n"
        "Shape \"sphere\"\n"
        "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
        "Shape \"sphere\"\n",
        "t.pbrt");
    REQUIRE(s.spheres.size() == 5);
    CHECK(s.spheres[0].radius == 0.25f);
    CHECK(s.spheres[1].radius == 2.0f);  // its own parameter wins
    CHECK(s.spheres[2].radius == 3.0f);  // the latest Attribute wins
    CHECK(s.spheres[3].radius == 0.25f); // AttributeEnd restores the earlier one
    CHECK(s.meshes.size() == 1);
    REQUIRE(s.pointLights.size() == 2);
    CHECK(s.pointLights[0].scale == doctest::Approx(2.0));
    CHECK(s.pointLights[1].scale == doctest::Approx(5.0));
    REQUIRE(s.materials.size() == 2);
    CHECK(s.materials[0].reflectance.rgb == std::array<float, 3>{0.1f, 0.2f, 0.3f});
    CHECK(s.materials[1].reflectance.rgb == std::array<float, 3>{0.5f, 0.5f, 0.5f});
    // An attribute's value is checked where a directive reads it, at the Attribute's line.
    CHECK(contains(errorOf("WorldBegin\nAttribute \"shape\" \"float radius\" -1\n"
                           "Shape \"sphere\"\n"),
                   "t.pbrt:2:19: \"float radius\" must be > 0"));
    CHECK(contains(errorOf("WorldBegin\nAttribute \"camera\" \"float fov\" 30\n"),
                   "t.pbrt:2:11: unknown Attribute target \"camera\""));
}

TEST_CASE("pbrt-v4 shape alpha: 1 is opaque, 0 invisible, between alpha-tested") {
    const std::string shapes[] = {
        "Shape \"sphere\" ",
        "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] ",
        "Shape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0] ",
        "Shape \"disk\" ",
    };
    for (const std::string& shape : shapes) {
        CAPTURE(shape);
        const auto opaque = parseSceneString(
            "WorldBegin\nLightSource \"point\"\n" + shape + "\"float alpha\" 1\n", "t.pbrt");
        CHECK(opaque.meshes.size() + opaque.spheres.size() == 1);
        const auto hidden = parseSceneString(
            "WorldBegin\nLightSource \"point\"\n" + shape + "\"float alpha\" 0\n", "t.pbrt");
        CHECK(hidden.meshes.size() + hidden.spheres.size() == 0);
        REQUIRE(hidden.notes.size() == 1);
        CHECK(contains(hidden.notes[0], "t.pbrt:3: a shape of alpha 0 is invisible"));
        // An area light's shape of alpha 0 stays, as an invisible light (tests/test_alpha.cpp).
        const auto light = parseSceneString(
            "WorldBegin\nAreaLightSource \"diffuse\"\n" + shape + "\"float alpha\" 0\n", "t.pbrt");
        REQUIRE(light.meshes.size() + light.spheres.size() == 1);
        CHECK((light.meshes.empty() ? light.spheres[0].invisible : light.meshes[0].invisible));
        CHECK((light.meshes.empty() ? light.spheres[0].areaLight : light.meshes[0].areaLight) == 0);
        CHECK((opaque.meshes.empty() ? !opaque.spheres[0].invisible : !opaque.meshes[0].invisible));
        REQUIRE(light.notes.size() == 1);
        CHECK(contains(light.notes[0], "t.pbrt:3: an area light's shape of alpha 0 is "
                                       "an invisible light"));
        // A float texture of class "constant" counts as its number (pbrt-v4's
        // FloatConstantTexture): 0 makes the light invisible, 1 the shape opaque.
        const std::string constants =
            "WorldBegin\nTexture \"zero\" \"float\" \"constant\" \"float value\" 0\n"
            "Texture \"one\" \"float\" \"constant\" \"float value\" 1\n";
        const auto constantLight = parseSceneString(constants + "AreaLightSource \"diffuse\"\n" +
                                                        shape + "\"texture alpha\" \"zero\"\n",
                                                    "t.pbrt");
        REQUIRE(constantLight.meshes.size() + constantLight.spheres.size() == 1);
        CHECK((constantLight.meshes.empty() ? constantLight.spheres[0].invisible
                                            : constantLight.meshes[0].invisible));
        const auto constantOpaque = parseSceneString(constants + "LightSource \"point\"\n" + shape +
                                                         "\"texture alpha\" \"one\"\n",
                                                     "t.pbrt");
        REQUIRE(constantOpaque.meshes.size() + constantOpaque.spheres.size() == 1);
        if (!constantOpaque.meshes.empty()) CHECK(constantOpaque.meshes[0].alphaTexture == -1);
        // Between (tests/test_alpha.cpp): alpha-tested triangles; refused on spheres.
        if (shape == shapes[0]) {
            CHECK(contains(errorOf("WorldBegin\n" + shape + "\"float alpha\" 0.5\n"),
                           "an \"alpha\" below 1 on a sphere is not supported"));
        } else {
            const auto half = parseSceneString(
                "WorldBegin\nLightSource \"point\"\n" + shape + "\"float alpha\" 0.5\n", "t.pbrt");
            REQUIRE(half.meshes.size() == 1);
            CHECK(half.meshes[0].alphaTexture >= 0);
        }
    }
}

TEST_CASE("pbrt-v4 thin lens: lensradius and focaldistance, and what is refused") {
    auto s = parseSceneString("Camera \"perspective\" \"float lensradius\" 0.25 "
                              "\"float focaldistance\" 3\nWorldBegin\nLightSource \"point\"\n",
                              "t.pbrt");
    CHECK(s.camera.lensRadius == 0.25f);
    CHECK(s.camera.focalDistance == 3.0f);
    cb::DeviceScene scene = cb::buildDeviceScene(s);
    CHECK(scene.camera.lensRadius == 0.25f);
    CHECK(scene.camera.focalDistance == 3.0f);
    CHECK(contains(scene.featureNames(), "thin-lens"));
    // pbrt-v4's defaults: a pinhole (no lens code compiled), in focus at 1e6.
    s = parseSceneString(
        "Camera \"perspective\" \"float lensradius\" 0\nWorldBegin\nLightSource \"point\"\n",
        "t.pbrt");
    CHECK(s.camera.focalDistance == 1e6f);
    CHECK(!contains(cb::buildDeviceScene(s).featureNames(), "thin-lens"));
    CHECK(contains(errorOf("Camera \"perspective\" \"float lensradius\" -0.1\n"),
                   "t.pbrt:1:41: \"float lensradius\" must be in [0, 1e6], got -0.1"));
    CHECK(contains(errorOf("Camera \"perspective\" \"float lensradius\" 0.1 "
                           "\"float focaldistance\" 0\n"),
                   "\"float focaldistance\" must be in (0, 1e30], got 0"));
}

// A thin lens seen through its image of a disk light (radius a, distance D, radiance L, facing
// the camera, nothing else in the scene): the film point s (screen coordinates at z = 1) and the
// lens point l see the light when the ray from l through the focus point s f meets the disk,
// |l (1 - D / f) + s D| <= a. Each pixel is L times the fraction of (pixel, lens) pairs that
// do, integrated here by quadrature over both, and compared with every method per ring of
// pixels around the centre: in focus (f = D) the disk's edge is sharp, out of focus it spreads
// by the blur radius r |1 - D / f| / D on the film.
TEST_CASE("pbrt-v4 thin lens: the defocused image of a disk light against quadrature, every "
          "method" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const int size = 32;
    const double fovDeg = 30.0, a = 0.5, distance = 4.0, lensRadius = 0.3;
    const double tanHalf = std::tan(fovDeg * M_PI / 360.0);
    for (const double focus : {1.5, 4.0}) {
        CAPTURE(focus);
        const std::string text =
            "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 30 "
            "\"float lensradius\" 0.3 \"float focaldistance\" " +
            std::to_string(focus) +
            "\nFilm \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\nWorldBegin\n"
            "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n"
            "Translate 0 0 4\nRotate 180 1 0 0\nShape \"disk\" \"float radius\" 0.5\n"
            "AttributeEnd\n";
        const cb::DeviceScene scene = cb::buildDeviceScene(parseSceneString(text, "t.pbrt"));
        REQUIRE(contains(scene.featureNames(), "thin-lens"));
        // Rings by the pixel centre's distance from the image centre, in pixels.
        auto ring = [&](int x, int y) {
            const double r = std::hypot(x + 0.5 - size / 2.0, y + 0.5 - size / 2.0);
            return std::min(5, int(r / 3.0));
        };
        const int rings = 6;
        std::vector<double> expected(rings, 0.0), pixelsIn(rings, 0.0);
        const int sub = 6, radial = 12, angular = 24;
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                double seen = 0.0;
                for (int j = 0; j < sub; ++j)
                    for (int i = 0; i < sub; ++i) {
                        const double sx = (2.0 * (x + (i + 0.5) / sub) / size - 1.0) * tanHalf;
                        const double sy = (1.0 - 2.0 * (y + (j + 0.5) / sub) / size) * tanHalf;
                        for (int u = 0; u < radial; ++u)
                            for (int v = 0; v < angular; ++v) {
                                const double rl = lensRadius * std::sqrt((u + 0.5) / radial);
                                const double phi = 2.0 * M_PI * (v + 0.5) / angular;
                                const double k = 1.0 - distance / focus;
                                const double px = rl * std::cos(phi) * k + sx * distance;
                                const double py = rl * std::sin(phi) * k + sy * distance;
                                seen += px * px + py * py <= a * a ? 1.0 : 0.0;
                            }
                    }
                expected[size_t(ring(x, y))] += seen / (sub * sub * radial * angular);
                pixelsIn[size_t(ring(x, y))] += 1.0;
            }
        for (int r = 0; r < rings; ++r)
            expected[size_t(r)] /= pixelsIn[size_t(r)];
        // The disk's image has a radius of a / D / tanHalf * 16 = 7.5 pixels: ring 2 (6-9 px)
        // holds its edge, ring 3 (9-12 px) is dark in focus and lit only by the blur.
        if (focus == distance)
            CHECK(expected[3] == 0.0);
        else
            CHECK(expected[3] > 0.05);
        for (const std::string method : kMethods) {
            CAPTURE(method);
            const int estimates = method == "cpt" || method == "cbdpt" ? 64 : 8;
            const BinnedMeans b =
                binnedMeans(scene, runtime, methodSettings(method), 6, estimates, 1300u,
                            size_t(rings), [&](int x, int y, int) { return size_t(ring(x, y)); });
            const cbtest::RunStats& st = b.stats;
            for (int r = 0; r < rings; ++r) {
                CAPTURE(r);
                CAPTURE(expected[size_t(r)]);
                CAPTURE(st.mean[size_t(r)]);
                CAPTURE(st.se[size_t(r)]);
                // The disk is a polygon of 256 sides with its area: its outline is within
                // 5e-5 of the circle (docs/scene-format.md), far below the tolerance.
                CHECK(std::fabs(st.mean[size_t(r)] - expected[size_t(r)]) <=
                      4.5 * st.se[size_t(r)] + 2e-3);
            }
            CHECK(b.nonFinite == 0);
        }
    }
}

TEST_CASE("pbrt-v4 thin lens: BDPT, CBDPT and MLT agree with PT, light tracing included" *
          doctest::test_suite("statistical")) {
    // In focus at the block, the floor and the wall blurred; BDPT's t = 1 strategy projects
    // through the lens point.
    checkMethodsAgreeWithPt(kDiskLight, "", "\"float lensradius\" 0.2 \"float focaldistance\" 3.2");
}

// A black bar close to a thin-lens camera focused on a lit wall behind it: the bar's image is a
// soft band whose profile every strategy must reproduce, light tracing (t = 1, through its own
// lens point) included. Column means of a wide, short image against PT's.
TEST_CASE("pbrt-v4 thin lens: a defocused occluder's profile, BDPT, CBDPT and MLT against PT" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const std::string text =
        "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\" \"float fov\" 20 "
        "\"float lensradius\" 0.3 \"float focaldistance\" 4\n"
        "Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 8\nWorldBegin\n"
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [3 3 3] \"bool twosided\" true\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-2 1.5 0.5  2 1.5 0.5  -2 1.5 3.5  2 1.5 3.5]\n"
        "AttributeEnd\n"
        "Material \"diffuse\" \"rgb reflectance\" [0.7 0.7 0.7]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-3 -2 4  3 -2 4  -3 2 4  3 2 4]\n"
        "Material \"diffuse\" \"rgb reflectance\" [0 0 0]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-0.1 -1 1  0.1 -1 1  -0.1 1 1  0.1 1 1]\n";
    const cb::DeviceScene scene = cb::buildDeviceScene(parseSceneString(text, "t.pbrt"));
    const int w = scene.camera.width;
    auto columns = [&](cb::IntegratorSettings settings, int runs, int estimates) {
        return binnedMeans(scene, runtime, settings, runs, estimates, 1500u, size_t(w),
                           [](int x, int, int) { return size_t(x); })
            .stats;
    };
    cb::IntegratorSettings pt = methodSettings("pt");
    const cbtest::RunStats reference = columns(pt, 8, 32);
    // The band: the middle columns darker than the edges' but not black (the lens sees past it).
    CHECK(reference.mean[16] < 0.8 * reference.mean[4]);
    CHECK(reference.mean[16] > 0.05 * reference.mean[4]);
    for (const std::string method : {"bdpt", "cbdpt", "mlt"}) {
        CAPTURE(method);
        checkRunsAgree(columns(methodSettings(method), 8, method == "bdpt" ? 16 : 32), reference);
    }
}

// A caustic (point light, glass sphere, floor) reaches the camera only by light tracing (t = 1):
// BDPT connects to its eye subpath's lens point, CBDPT to one drawn from each light subpath's
// own stream (CB_LIGHT_DIM_LENS) on the host. Seen out of focus, both must blur the caustic
// alike: ring means around it, CBDPT against BDPT.
TEST_CASE("pbrt-v4 thin lens: a defocused caustic, CBDPT's light tracing against BDPT's" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const std::string text =
        "LookAt 0 3 -3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 30 "
        "\"float lensradius\" 0.3 \"float focaldistance\" 2\n"
        "Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\nWorldBegin\n"
        "LightSource \"point\" \"point3 from\" [0 3 0] \"rgb I\" [10 10 10]\n"
        "Material \"diffuse\" \"rgb reflectance\" [0.7 0.7 0.7]\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-3 0 -3  3 0 -3  -3 0 3  3 0 3]\n"
        "AttributeBegin\nMaterial \"dielectric\" \"float eta\" 1.5\nTranslate 0 1 0\n"
        "Shape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n";
    const cb::DeviceScene scene = cb::buildDeviceScene(parseSceneString(text, "t.pbrt"));
    const int size = scene.camera.width;
    const int rings = 4;
    auto ring = [&](int x, int y) {
        const double r = std::hypot(x + 0.5 - size / 2.0, y + 0.5 - size / 2.0);
        return std::min(rings - 1, int(r / 2.5));
    };
    auto ringMeans = [&](cb::IntegratorSettings settings, int estimates) {
        return binnedMeans(scene, runtime, settings, 6, estimates, 1700u, size_t(rings),
                           [&](int x, int y, int) { return size_t(ring(x, y)); })
            .stats;
    };
    cb::IntegratorSettings bdpt = methodSettings("bdpt"), cbdpt = methodSettings("cbdpt");
    bdpt.maxPathVertices = cbdpt.maxPathVertices = 5;
    const cbtest::RunStats reference = ringMeans(bdpt, 64);
    const cbtest::RunStats r = ringMeans(cbdpt, 1024);
    // The blurred caustic: the inner rings brighter than the floor around the sphere's shadow.
    CHECK(reference.mean[0] > 1.5 * reference.mean[rings - 1]);
    checkRunsAgree(r, reference);
}

// The comparison scenes of docs/pbrt-v4.md are read by pbrt-v4 unedited; each must also be a
// valid cbdpt scene, with the features it is there to compare.
TEST_CASE("pbrt-v4: every comparison scene in scenes/pbrt-v4 parses and builds") {
    const std::filesystem::path dir =
        std::filesystem::path(CBDPT_SOURCE_DIR) / "scenes" / "pbrt-v4";
    int scenes = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        if (entry.path().extension() != ".pbrt") continue;
        std::ifstream in(entry.path());
        const std::string text((std::istreambuf_iterator<char>(in)), {});
        if (text.find("WorldBegin") == std::string::npos) continue; // an Include'd part
        CAPTURE(entry.path().string());
        const cb::DeviceScene scene =
            cb::buildDeviceScene(cb::parseSceneFile(entry.path().string()));
        const std::string name = entry.path().stem().string();
        if (name == "translucent") {
            CHECK(contains(scene.featureNames(), "diffuse-transmission"));
            CHECK(contains(scene.featureNames(), "thin-dielectric"));
        }
        if (name == "thin-lens") CHECK(contains(scene.featureNames(), "thin-lens"));
        if (name == "rough-glass") CHECK(contains(scene.featureNames(), "rough-dielectric"));
        if (name == "conductor") CHECK(contains(scene.featureNames(), "conductor-fresnel"));
        if (name == "dispersion") CHECK(contains(scene.featureNames(), "dispersion"));
        if (name == "loopsubdiv") CHECK(contains(scene.featureNames(), "shading-normals"));
        if (name == "invisible-light") CHECK(contains(scene.featureNames(), "invisible-light"));
        if (name == "curves") CHECK(contains(scene.featureNames(), "curves"));
        if (name == "hair-curves") {
            CHECK(contains(scene.featureNames(), "curves"));
            CHECK(contains(scene.featureNames(), "hair"));
        }
        if (name == "thickness-texture") CHECK(contains(scene.featureNames(), "thickness-texture"));
        if (name == "direction-mix") CHECK(contains(scene.featureNames(), "direction-mix"));
        if (name == "sample-clamp") CHECK(contains(scene.featureNames(), "sample-clamp"));
        if (name == "noise-textures") CHECK(contains(scene.featureNames(), "noise-texture"));
        if (name == "mix-coated") CHECK(contains(scene.featureNames(), "mix-at-point"));
        if (name == "grid-media" || name == "nanovdb-medium")
            CHECK(contains(scene.featureNames(), "grid-medium"));
        ++scenes;
    }
    CHECK(scenes >= 9);
}

TEST_CASE("pbrt-v4: integer values are whole-number text, as pbrt-v4's parseInt reads them") {
    const std::string tri = "WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] "
                            "\"integer indices\" ";
    std::string e = errorOf(tri + "[0 1 2.0]\n");
    CHECK(contains(e, "t.pbrt:2:76"));
    CHECK(contains(e, "expects integers"));
    CHECK(contains(e, "'2.0'"));
    e = errorOf(tri + "[0 1 2e0]\n");
    CHECK(contains(e, "t.pbrt:2:76"));
    CHECK(contains(e, "'2e0'"));
    // Checked when read, as pbrt-v4 does, also where cbdpt does not use the parameter.
    e = errorOf("Sampler \"halton\" \"integer seed\" 3.0\nWorldBegin\n");
    CHECK(contains(e, "t.pbrt:1:33"));
    CHECK(contains(e, "'3.0'"));
    // A sign is part of pbrt-v4's integer syntax.
    const auto s = parseSceneString(tri + "[0 +1 2]\n", "t.pbrt");
    REQUIRE(s.meshes.size() == 1);
    CHECK(s.meshes[0].triangles.size() == 1);
}

TEST_CASE("pbrt-v4: the coordinate system \"world\" is the identity from WorldBegin on") {
    auto s = parseSceneString("WorldBegin\nTranslate 1 2 3\nCoordSysTransform \"world\"\n" + kTri,
                              "t.pbrt");
    REQUIRE(s.meshes.size() == 1);
    CHECK(s.meshes[0].positions[1] == std::array<double, 3>{1, 0, 0});
    // WorldBegin overrides a "world" the options block defined.
    s = parseSceneString("Translate 0 0 5\nCoordinateSystem \"world\"\nIdentity\nWorldBegin\n"
                         "CoordSysTransform \"world\"\n" +
                             kTri,
                         "t.pbrt");
    REQUIRE(s.meshes.size() == 1);
    CHECK(s.meshes[0].positions[1] == std::array<double, 3>{1, 0, 0});
    // Before WorldBegin it is whatever the file defined, as in pbrt-v4.
    CHECK(contains(errorOf("CoordSysTransform \"world\"\nWorldBegin\n"),
                   "unknown coordinate system \"world\""));
}

TEST_CASE("pbrt-v4: TransformBegin/TransformEnd are AttributeBegin/AttributeEnd, noted once") {
    // pbrt-v4's parser turns them into AttributeBegin/AttributeEnd: the whole graphics state,
    // material included, is saved and restored, not only the CTM.
    const auto s = parseSceneString(
        "WorldBegin\nTransformBegin\nTranslate 1 0 0\nMaterial \"conductor\" \"rgb reflectance\" "
        "[0.9 0.9 0.9]\nTransformEnd\n" +
            kTri + "TransformBegin\nTransformEnd\n",
        "t.pbrt");
    REQUIRE(s.meshes.size() == 1);
    CHECK(s.meshes[0].positions[1] == std::array<double, 3>{1, 0, 0});
    CHECK(s.materials[s.meshes[0].material].kind == cb::MaterialKind::Diffuse);
    REQUIRE(s.notes.size() == 1);
    CHECK(contains(s.notes[0], "t.pbrt:2"));
    CHECK(contains(s.notes[0], "deprecated"));
    CHECK(contains(errorOf("TransformBegin\nWorldBegin\n"),
                   "t.pbrt:1:1: TransformBegin is only allowed after WorldBegin"));
    CHECK(contains(errorOf("WorldBegin\nTransformBegin\n"),
                   "t.pbrt:2:1: TransformBegin without matching TransformEnd"));
    CHECK(contains(errorOf("WorldBegin\nTransformEnd\n"),
                   "t.pbrt:2:1: TransformEnd without matching TransformBegin"));
}

TEST_CASE("pbrt-v4: Accelerator is read, checked and reported once as not used") {
    auto s =
        parseSceneString("Accelerator \"bvh\" \"integer maxnodeprims\" 8 \"string splitmethod\" "
                         "\"middle\"\nAccelerator \"kdtree\" \"integer maxprims\" 2 "
                         "\"float emptybonus\" 0.25\nWorldBegin\n",
                         "t.pbrt");
    REQUIRE(s.notes.size() == 1);
    CHECK(contains(s.notes[0], "t.pbrt:1"));
    CHECK(contains(s.notes[0], "not used"));
    // What pbrt-v4 refuses (CreateAccelerator, ReportUnused) cbdpt refuses too.
    CHECK(contains(errorOf("Accelerator \"octree\"\nWorldBegin\n"), "t.pbrt:1:13"));
    CHECK(contains(errorOf("Accelerator \"bvh\" \"integer maxprims\" 2\nWorldBegin\n"),
                   "unknown or unsupported parameter \"integer maxprims\""));
    CHECK(contains(errorOf("WorldBegin\nAccelerator \"bvh\"\n"), "only allowed before WorldBegin"));
}

TEST_CASE("pbrt-v4: Import keeps the importer's graphics state; named things come back") {
    const auto dir = std::filesystem::temp_directory_path() /
                     ("cbdpt-import-state-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "part.pbrt")
        << "Translate 0 0 5\nMaterial \"conductor\" \"rgb reflectance\" [0.9 0.9 0.9]\n"
           "AreaLightSource \"diffuse\"\nReverseOrientation\n"
           "MakeNamedMaterial \"red\" \"string type\" \"diffuse\" \"rgb reflectance\" [1 0 0]\n"
           "ObjectBegin \"ball\"\nShape \"sphere\"\nObjectEnd\n"
           "CoordinateSystem \"there\"\nShape \"sphere\" \"float radius\" 0.5\n";
    const auto parse = [&](const std::string& main) {
        std::ofstream(dir / "main.pbrt") << main;
        return cb::parseSceneFile((dir / "main.pbrt").string());
    };
    const auto errorOfMain = [&](const std::string& main) -> std::string {
        try {
            parse(main);
        } catch (const SceneError& e) {
            return e.what();
        }
        return "";
    };
    // pbrt-v4 parses an imported file with a copy of the graphics state (CopyForImport) and
    // takes back only its shapes and named things (MergeImported).
    const auto s = parse("WorldBegin\nImport \"part.pbrt\"\nShape \"sphere\"\n"
                         "NamedMaterial \"red\"\nTranslate 3 0 0\nObjectInstance \"ball\"\n");
    REQUIRE(s.spheres.size() == 3);
    const cb::SphereDesc &imported = s.spheres[0], &after = s.spheres[1], &instance = s.spheres[2];
    CHECK(imported.center == std::array<double, 3>{0, 0, 5});
    CHECK(imported.areaLight >= 0);
    CHECK(imported.reverseOrientation);
    CHECK(s.materials[imported.material].kind == cb::MaterialKind::Conductor);
    CHECK(after.center == std::array<double, 3>{0, 0, 0});
    CHECK(after.areaLight < 0);
    CHECK(!after.reverseOrientation);
    CHECK(s.materials[after.material].kind == cb::MaterialKind::Diffuse);
    CHECK(s.materials[after.material].name.empty());
    CHECK(instance.center == std::array<double, 3>{3, 0, 5}); // the object and "red" came back
    // Named coordinate systems do not cross an Import either way in pbrt-v4: the imported
    // file's builder starts without them and MergeImported does not copy them back.
    std::string e = errorOfMain("WorldBegin\nImport \"part.pbrt\"\nCoordSysTransform \"there\"\n");
    CHECK(contains(e, "main.pbrt:3:19: unknown coordinate system \"there\""));
    CHECK(contains(e, "Import"));
    std::ofstream(dir / "cs.pbrt") << "CoordSysTransform \"world\"\n";
    e = errorOfMain("WorldBegin\nImport \"cs.pbrt\"\n");
    CHECK(contains(e, "cs.pbrt:1:19: unknown coordinate system \"world\""));
    CHECK(contains(e, "Import"));
    // Blocks may not cross the file boundary.
    std::ofstream(dir / "open.pbrt") << "AttributeBegin\n";
    CHECK(contains(errorOfMain("WorldBegin\nImport \"open.pbrt\"\nAttributeEnd\n"),
                   "open.pbrt:1:1: AttributeBegin without matching AttributeEnd"));
    std::ofstream(dir / "close.pbrt") << "AttributeEnd\n";
    CHECK(contains(errorOfMain("WorldBegin\nAttributeBegin\nImport \"close.pbrt\"\n"),
                   "close.pbrt:1:1: AttributeEnd without matching AttributeBegin"));
    std::ofstream(dir / "objend.pbrt") << "ObjectEnd\n";
    CHECK(contains(errorOfMain("WorldBegin\nObjectBegin \"o\"\nImport \"objend.pbrt\"\n"),
                   "objend.pbrt:1:1"));
    // As in pbrt-v4, an Import's shapes join an object being defined.
    std::ofstream(dir / "shape.pbrt") << "Shape \"sphere\"\n";
    const auto o = parse("WorldBegin\nObjectBegin \"o\"\nImport \"shape.pbrt\"\nObjectEnd\n"
                         "ObjectInstance \"o\"\nObjectInstance \"o\"\n");
    CHECK(o.spheres.size() == 2);
    CHECK(contains(errorOfMain("Import \"shape.pbrt\"\nWorldBegin\n"),
                   "main.pbrt:1:1: Import statement only allowed inside world definition block"));
    std::filesystem::remove_all(dir);
}

TEST_CASE("pbrt-v4: a flat but folded bilinear patch (a bowtie) is refused") {
    // p00 p10 p01 p11 = the unit square's corners in order round it: pbrt-v4's patch folds over
    // itself (cross(dpdu, dpdv) changes sign), not the square two triangles would make.
    std::string e = errorOf("WorldBegin\nShape \"bilinearmesh\" \"point3 P\" [0 0 0  1 0 0  1 1 0  "
                            "0 1 0]\n");
    CHECK(contains(e, "t.pbrt:2:1"));
    CHECK(contains(e, "folded"));
    // A planar but non-convex quadrilateral folds too.
    e = errorOf("WorldBegin\nShape \"bilinearmesh\" \"point3 P\" [0 0 0  2 0 0  0 2 0  0.5 0.5 0] "
                "\"integer indices\" [0 1 2 3  0 1 2 3]\n");
    CHECK(contains(e, "folded"));
    CHECK(contains(e, "patch 1"));
    // Convex patches, and one collapsed to a triangle (p11 = p10), are accepted.
    const auto s =
        parseSceneString("WorldBegin\nShape \"bilinearmesh\" \"point3 P\" [0 0 0  2 0 0  "
                         "0 1 0  1 1 0]\nShape \"bilinearmesh\" \"point3 P\" [0 0 0  1 0 "
                         "0  0 1 0  1 0 0]\n",
                         "t.pbrt");
    REQUIRE(s.meshes.size() == 2);
    CHECK(s.meshes[0].triangles.size() == 2);
    CHECK(s.meshes[1].triangles.size() == 1);
}

TEST_CASE("pbrt-v4: PLY faces of more than 4 vertices are skipped and reported once per file") {
    // pbrt-v4's rply_face_callback reads triangles and quads and ignores other faces.
    const auto dir =
        std::filesystem::temp_directory_path() / ("cbdpt-ply-faces-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "pent.ply")
        << "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
           "property float z\nelement face 4\nproperty list uchar int vertex_indices\n"
           "end_header\n0 0 0\n1 0 0\n1.3 1 0\n0.5 1.6 0\n-0.3 1 0\n"
           "5 0 1 2 3 4\n3 0 1 2\n5 0 1 2 3 4\n6 0 1 2 3 4 0\n";
    std::ofstream(dir / "main.pbrt")
        << "WorldBegin\nShape \"plymesh\" \"string filename\" \"pent.ply\"\n"
           "Shape \"plymesh\" \"string filename\" \"pent.ply\"\n";
    const auto s = cb::parseSceneFile((dir / "main.pbrt").string());
    REQUIRE(s.meshes.size() == 2);
    CHECK(s.meshes[0].triangles.size() == 1);
    REQUIRE(s.notes.size() == 1);
    CHECK(contains(s.notes[0], "main.pbrt:2"));
    CHECK(contains(s.notes[0], "pent.ply"));
    CHECK(contains(s.notes[0], "3 faces"));
    std::filesystem::remove_all(dir);
}
