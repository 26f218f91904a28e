// pbrt-v4's "mix" of parts that cannot be blended into one BSDF (a coat, whose density is an
// estimate; a normal- or bump-mapped material, which shades at its own normal; a dispersive
// dielectric, which follows one wavelength): one part per surface point, chosen by a hash of the
// point (kernels' mixPartAtPoint). What picks it, the parts' shares at the hits, the part's own
// normal and media, and images against the parts' images and against PT.
#include <doctest/doctest.h>

#include "cb_intersect.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "test_render_util.h"

#include <array>
#include <cmath>
#include <random>
#include <string>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

const std::string kCoat =
    "MakeNamedMaterial \"coat\" \"string type\" \"coateddiffuse\" \"rgb reflectance\" [0.1 0.3 "
    "0.6]\n";
const std::string kRed =
    "MakeNamedMaterial \"red\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.7 0.12 0.1]\n";

// The floor z = 0, 4 x 4 about the origin, of material `material`, with texture coordinates.
std::string floorOf(const std::string& material) {
    return "NamedMaterial \"" + material +
           "\"\nShape \"bilinearmesh\" \"point3 P\" [-2 -2 0  2 -2 0  -2 2 0  2 2 0] "
           "\"point2 uv\" [0 0  1 0  0 1  1 1]\n";
}

// The material each of n rays straight down onto the floor finds, counted per material index.
std::vector<int> partsFound(const cb::DeviceScene& scene, int n) {
    const cbk::SceneView view = cbtest::hostView(scene);
    std::vector<int> count(scene.materials.size(), 0);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.9, 1.9);
    for (int i = 0; i < n; ++i) {
        const auto sp = cbtest::surfaceBelow(scene, view, u(rng), u(rng), 1.0);
        REQUIRE(sp.has_value());
        REQUIRE(sp->material >= 0);
        ++count[size_t(sp->material)];
    }
    return count;
}

} // namespace

TEST_CASE("mix at point: which mixes pick a part per point, and the parts' shares at hits") {
    TempDirCleanup cleanup;
    const std::string world = "WorldBegin\nLightSource \"infinite\"\n";
    // Each kind of part that cannot join a mixture makes its mix one picked per point.
    const std::string normalMap = writeImage(
        "tilt.exr", 1, 1, [](int, int, int c) { return c == 0 ? 0.8f : 0.5f + c * 0.2f; });
    for (const std::string& part :
         {kCoat, std::string("MakeNamedMaterial \"coat\" \"string type\" \"coatedconductor\"\n"),
          "MakeNamedMaterial \"coat\" \"string type\" \"diffuse\" \"string normalmap\" \"" +
              normalMap + "\"\n",
          std::string("MakeNamedMaterial \"coat\" \"string type\" \"diffuse\" "
                      "\"float displacement\" 0.1\n"),
          std::string("MakeNamedMaterial \"coat\" \"string type\" \"dielectric\" "
                      "\"spectrum eta\" \"glass-F11\"\n")}) {
        CAPTURE(part);
        const cb::DeviceScene scene = cb::buildDeviceScene(
            parseInTemp(world + part + kRed +
                        "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
                        "[\"coat\" \"red\"]\n" +
                        floorOf("m")));
        CHECK((scene.features & CB_FEATURE_MIX_AT_POINT) != 0);
        CHECK((scene.features & CB_FEATURE_MIX) == 0);
        CHECK(contains(scene.featureNames(), "mix-at-point"));
        CHECK(scene.materials[scene.bvh.primitives[0].material].kind == CB_MAT_MIX_AT_POINT);
    }
    // Parts that blend keep the exact mixture.
    const cb::DeviceScene blended = cb::buildDeviceScene(parseInTemp(
        world + kRed +
        "MakeNamedMaterial \"gold\" \"string type\" \"conductor\" \"float roughness\" 0.2\n"
        "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
        "[\"gold\" \"red\"]\n" +
        floorOf("m")));
    CHECK((blended.features & CB_FEATURE_MIX) != 0);
    CHECK((blended.features & CB_FEATURE_MIX_AT_POINT) == 0);

    // A mix of mixes: red 0.3, the coat 0.7 x 0.5, the normal-mapped white 0.35. Every hit finds
    // one of the three parts (never a mix), each in its share within 5 binomial deviations; the
    // normal-mapped one shades at its tilted normal, the others at the floor's.
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        world + kCoat + kRed +
        "MakeNamedMaterial \"bumpy\" \"string type\" \"diffuse\" \"string normalmap\" \"" +
        normalMap +
        "\"\nMakeNamedMaterial \"inner\" \"string type\" \"mix\" \"string materials\" "
        "[\"coat\" \"bumpy\"]\n"
        "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"red\" \"inner\"] "
        "\"float amount\" 0.7\n" +
        floorOf("m")));
    const cbk::SceneView view = cbtest::hostView(scene);
    const int n = 60000;
    const std::vector<int> count = partsFound(scene, n);
    const std::array<std::pair<int, double>, 3> shares{{{1, 0.3}, {0, 0.35}, {2, 0.35}}};
    int total = 0;
    for (const auto& [material, share] : shares) {
        CAPTURE(material);
        CHECK(scene.materials[size_t(material)].kind != CB_MAT_MIX_AT_POINT);
        const double sd = std::sqrt(share * (1 - share) / n);
        CHECK(std::fabs(count[size_t(material)] / double(n) - share) < 5 * sd);
        total += count[size_t(material)];
    }
    CHECK(total == n);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-1.9, 1.9);
    int tilted = 0;
    for (int i = 0; i < 2000; ++i) {
        const auto sp = cbtest::surfaceBelow(scene, view, u(rng), u(rng), 1.0);
        REQUIRE(sp.has_value());
        const bool bumpy = sp->material == 2;
        CHECK((std::fabs(cbk::vdot(sp->ns, sp->ng)) < 0.99f) == bumpy);
        tilted += bumpy ? 1 : 0;
    }
    CHECK(tilted > 500);
    // The same point finds the same part: every strategy of a path sees one material there.
    for (int i = 0; i < 100; ++i) {
        const double x = u(rng), y = u(rng);
        CHECK(cbtest::surfaceBelow(scene, view, x, y, 1.0)->material ==
              cbtest::surfaceBelow(scene, view, x, y, 2.5)->material);
    }
}

TEST_CASE("mix at point: a part found at a boundary keeps the boundary's media") {
    TempDirCleanup cleanup;
    // A mix of two parts, and one of three, two levels deep (its chain's links copied too).
    const std::string gold =
        "MakeNamedMaterial \"gold\" \"string type\" \"conductor\" \"float roughness\" 0.2\n"
        "MakeNamedMaterial \"inner\" \"string type\" \"mix\" \"string materials\" "
        "[\"coat\" \"gold\"]\n";
    for (const auto& [mix, parts] :
         {std::pair{std::string("[\"coat\" \"red\"]"), 2},
          std::pair{std::string("[\"red\" \"inner\"] \"float amount\" 0.7"), 3}}) {
        CAPTURE(mix);
        const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
            "MakeNamedMedium \"ink\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [1 2 3] "
            "\"rgb sigma_s\" [0 0 0]\nWorldBegin\nLightSource \"infinite\"\n" +
            kCoat + kRed + gold +
            "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" " + mix +
            "\nAttributeBegin\nMediumInterface \"ink\" \"\"\n" + floorOf("m") + "AttributeEnd\n"));
        const cbk::Material& boundary = scene.materials[size_t(scene.bvh.primitives[0].material)];
        REQUIRE(boundary.mediumInside >= 0);
        CHECK(boundary.kind == CB_MAT_MIX_AT_POINT);
        const std::vector<int> count = partsFound(scene, 3000);
        int kinds = 0;
        for (size_t m = 0; m < count.size(); ++m) {
            if (count[m] == 0) continue;
            CAPTURE(m);
            ++kinds;
            CHECK(scene.materials[m].kind != CB_MAT_MIX_AT_POINT);
            CHECK(scene.materials[m].mediumInside == boundary.mediumInside);
            CHECK(scene.materials[m].mediumOutside == -1);
        }
        CHECK(kinds == parts);
    }
}

// The floor lit by a disk light the camera does not see, nothing else in the scene: every path
// reflects once, so the image is linear in the floor's BSDF, and a mix's is (1 - a) times the
// first part's image plus a times the second's. A coat and a normal-mapped red diffuse, a = 0.4;
// the parts' images by PT, every method's mix against them per channel.
TEST_CASE("mix at point: the image is the parts' images mixed by the amount, every method" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const std::string normalMap = writeImage(
        "tilt.exr", 1, 1, [](int, int, int c) { return c == 0 ? 0.7f : 0.5f + c * 0.2f; });
    const std::string head =
        "LookAt 0 0 3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n"
        "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nPixelFilter \"box\"\n"
        "WorldBegin\nAttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [6 6 6]\n"
        "Material \"diffuse\" \"rgb reflectance\" [0 0 0]\nTranslate 1.6 0.4 1.5\n"
        "Rotate 180 1 0 0\nShape \"disk\" \"float radius\" 0.5\nAttributeEnd\n" +
        kCoat +
        "MakeNamedMaterial \"red\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.7 0.12 0.1] "
        "\"string normalmap\" \"" +
        normalMap +
        "\"\nMakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
        "[\"coat\" \"red\"] \"float amount\" 0.4\n";
    auto build = [&](const std::string& material) {
        return cb::buildDeviceScene(parseInTemp(head + floorOf(material)), cb::ChannelMode::Rgb);
    };
    const cb::DeviceScene coat = build("coat"), red = build("red"), mix = build("m");
    REQUIRE((mix.features & CB_FEATURE_MIX_AT_POINT) != 0);
    cb::IntegratorSettings pt = methodSettings("pt");
    // 16 runs each: a correct method then fails one of the 15 channel checks in about 1 of 300
    // seeds or fewer (Student's t, 20-30 degrees of freedom), where 6 runs would in 1 of 60.
    auto perChannel = [&](const cb::DeviceScene& scene, cb::IntegratorSettings settings,
                          int estimates, std::uint32_t seed) {
        return binnedMeans(scene, runtime, settings, 16, estimates, seed, 3,
                           [](int, int, int c) { return size_t(c); });
    };
    const cbtest::RunStats a = perChannel(coat, pt, 64, 300u).stats;
    const cbtest::RunStats b = perChannel(red, pt, 64, 400u).stats;
    cbtest::RunStats expected = a;
    for (size_t c = 0; c < 3; ++c) {
        expected.mean[c] = 0.6 * a.mean[c] + 0.4 * b.mean[c];
        expected.se[c] = std::hypot(0.6 * a.se[c], 0.4 * b.se[c]);
        CHECK(std::fabs(a.mean[c] - b.mean[c]) > 10 * expected.se[c]); // the parts differ
    }
    for (const std::string method : kMethods) {
        CAPTURE(method);
        const int n = method == "cpt" || method == "cbdpt" ? 256 : 64;
        const BinnedMeans m = perChannel(mix, methodSettings(method), n, 500u);
        checkRunsAgree(m.stats, expected);
        CHECK(m.nonFinite == 0);
    }
}

// Where the mix's points reflect onto each other (floor, wall and block), every strategy meets
// parts picked per point: BDPT, CBDPT and MLT against PT. A coat and a diffuse bumped by fbm
// noise.
TEST_CASE("mix at point: BDPT, CBDPT and MLT agree with PT" * doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt(
        kDiskLight, "", "",
        kCoat +
            "Texture \"h\" \"float\" \"fbm\" \"integer octaves\" 3\n"
            "MakeNamedMaterial \"bumpy\" \"string type\" \"diffuse\" \"rgb reflectance\" "
            "[0.7 0.7 0.6] \"texture displacement\" \"h\"\n"
            "Material \"mix\" \"string materials\" [\"coat\" \"bumpy\"] \"float amount\" 0.5\n");
}
