// The device scene under extreme geometry and light input (docs/robustness.md): what the host
// must drop or reject before the float kernels see it, checked through the kernels' own
// functions (compiled for the host as cbk) or against independent arithmetic.
#include <doctest/doctest.h>

#include "scene/device_scene.h"
#include "scene/scene_desc.h"
#include "test_render_util.h"

#include "cb_intersect.h"
#include "cb_lights.h"

#include <cmath>
#include <map>
#include <string>

namespace {

// Camera at the world origin looking down +z, so that the device origin is the world origin
// (the camera lies inside the floor's bounds) and positions reach the kernels exactly as written.
const std::string kHeader =
    "LookAt 0 0 0  0 0 1  0 1 0\n"
    "Camera \"perspective\" \"float fov\" 60\n"
    "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
    "WorldBegin\n"
    "Shape \"trianglemesh\" \"point3 P\" [-5 -1 -5  5 -1 -5  5 -1 5  -5 -1 5]"
    " \"integer indices\" [0 2 1 0 3 2]\n";

cb::DeviceScene build(const std::string& world) {
    return cb::buildDeviceScene(cb::parseSceneString(kHeader + world, "t.pbrt"),
                                cb::ChannelMode::Rgb);
}

std::string errorOf(const std::string& world) {
    try {
        build(world);
    } catch (const cb::SceneError& e) {
        return e.what();
    }
    return "<no error>";
}

bool unit(cbk::Vec3 n) {
    return std::isfinite(n.x + n.y + n.z) && std::fabs(cbk::vlength(n) - 1.0f) < 1e-5f;
}

} // namespace

TEST_CASE("device scene: a sliver whose float cross product is 0 is dropped, not kept NaN") {
    // Edges (1 + 2^-23, 1, 0) and (1 + 2^-22, 1 + 2^-23, 0): the exact z of their cross product
    // is 2^-46 (area > 0 in double), but both float products round to 1 + 2^-22, so the
    // kernels' normal would be 0 / 0 at every hit and light sample on it.
    const cb::DeviceScene s =
        build("AttributeBegin\n"
              "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n"
              "Shape \"trianglemesh\" \"point3 P\" [-1 2 1  1 2 1  1 2 3] \"integer indices\" "
              "[0 2 1]\n"
              "Shape \"trianglemesh\" \"point3 P\" [0 0 2  1.00000011920928955078125 1 2  "
              "1.0000002384185791015625 1.00000011920928955078125 2] \"integer indices\" [0 1 2]\n"
              "AttributeEnd\n");
    CHECK(s.droppedDegenerateTriangles == 1);
    CHECK(s.triangleCount == 3);
    const cbk::SceneView view = cbtest::hostView(s);
    for (int i = 0; i < int(s.bvh.primitives.size()); ++i) {
        cbk::Hit hit{};
        hit.primitive = i;
        hit.b1 = hit.b2 = 1.0f / 3.0f;
        INFO("primitive " << i);
        CHECK(unit(cbk::surfacePointFromHit(&view, cbk::Ray{}, hit).ng));
    }
    for (int l = 0; l < int(s.lights.size()); ++l) {
        cbk::LightSample ls{};
        cbk::lightSamplePoint(&view, l, 0.25f, 0.5f, &ls);
        INFO("light " << l);
        CHECK(unit(ls.n));
        CHECK(std::isfinite(s.lights[size_t(l)].pickProbability));
    }
}

TEST_CASE("device scene: geometry beyond float intersection range is an error naming it") {
    // The watertight test's products of three coordinates overflow float beyond ~1e12 from the
    // device origin: such geometry rendered black without a word.
    const std::string e =
        errorOf("LightSource \"point\" \"point3 from\" [0 1 0] \"rgb I\" [1 1 1]\n"
                "Shape \"trianglemesh\" \"point3 P\" [-1e30 0 -1e30  1e30 0 -1e30  0 0 1e30]\n");
    INFO(e);
    CHECK(e.rfind("t.pbrt:7:1: a vertex reaches 1e+30 ", 0) == 0);
    CHECK(e.find("supports up to 1e+12") != std::string::npos);

    const std::string sphere =
        errorOf("AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n"
                "Shape \"sphere\" \"float radius\" 1e20\nAttributeEnd\n");
    INFO(sphere);
    CHECK(sphere.rfind("t.pbrt:8:1: a sphere reaches 1e+20 ", 0) == 0);

    // Within the range, the same shapes build.
    CHECK(errorOf("LightSource \"point\" \"point3 from\" [0 1 0] \"rgb I\" [1 1 1]\n"
                  "Shape \"trianglemesh\" \"point3 P\" [-1e11 0 -1e11  1e11 0 -1e11  0 0 1e11]\n"
                  "Shape \"sphere\" \"float radius\" 1e11\n") == "<no error>");
}

TEST_CASE("device scene: light powers beyond the float range keep pick probabilities exact") {
    // A point light of intensity 1 and a two-sided sphere light of radius 1e10 whose radiance is
    // scaled by k: the sphere's power (~8e21 k) passes 3.4e38 for k = 3e17. The odds of
    // picking the sphere over the point light must scale by exactly k (power is linear in L).
    auto odds = [](double k) {
        const cb::DeviceScene s =
            build("LightSource \"point\" \"point3 from\" [0 0.5 0] \"rgb I\" [1 1 1]\n"
                  "AttributeBegin\nTranslate 0 0 2e10\n"
                  "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1] \"bool twosided\" true "
                  "\"float scale\" " +
                  std::to_string(k) + "\nShape \"sphere\" \"float radius\" 1e10\nAttributeEnd\n");
        REQUIRE(s.lights.size() == 2);
        double sum = 0.0;
        for (const cbk::Light& l : s.lights) {
            CHECK(std::isfinite(l.pickProbability));
            CHECK(l.pickProbability > 0.0f);
            sum += l.pickProbability;
        }
        CHECK(sum == doctest::Approx(1.0).epsilon(1e-6));
        const cbk::Light& sphere = s.lights[0].kind == CB_LIGHT_AREA ? s.lights[0] : s.lights[1];
        const cbk::Light& point = s.lights[0].kind == CB_LIGHT_AREA ? s.lights[1] : s.lights[0];
        return double(sphere.pickProbability) / double(point.pickProbability);
    };
    const double ratio = odds(3e17) / odds(1.0);
    CHECK(ratio == doctest::Approx(3e17).epsilon(1e-4));
}

TEST_CASE("device scene: emission times scale beyond the float range is an error naming it") {
    // Each factor fits a float, so the parser accepts both; their product was +Inf radiance.
    const std::string e = errorOf("AttributeBegin\n"
                                  "AreaLightSource \"diffuse\" \"rgb L\" [1e20 1e20 1e20] "
                                  "\"float scale\" 1e20\n"
                                  "Shape \"sphere\" \"float radius\" 0.1\nAttributeEnd\n");
    INFO(e);
    CHECK(e.rfind("t.pbrt:7:1: the light's emission times its \"float scale\" 1e+20 exceeds", 0) ==
          0);
    const std::string point = errorOf("LightSource \"point\" \"point3 from\" [0 1 0] \"rgb I\" "
                                      "[3e38 3e38 3e38] \"float scale\" 10\n");
    INFO(point);
    CHECK(point.rfind("t.pbrt:6:1: the light's emission", 0) == 0);
}

TEST_CASE("device scene: a mix of mixes is a chain whose links weigh its leaves") {
    // m = 0.75 a + 0.25 n, n = 0.4 b + 0.6 o, o = 1.0 c + 0.0 a: leaves a 0.75, b 0.1, c 0.15.
    const cb::SceneDesc desc = cb::parseSceneString(
        kHeader +
            "LightSource \"point\"\n"
            "MakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n"
            "MakeNamedMaterial \"b\" \"string type\" \"conductor\"\n"
            "MakeNamedMaterial \"c\" \"string type\" \"dielectric\"\n"
            "MakeNamedMaterial \"o\" \"string type\" \"mix\" \"string materials\" [\"a\" \"c\"] "
            "\"float amount\" 1\n"
            "MakeNamedMaterial \"n\" \"string type\" \"mix\" \"string materials\" [\"b\" \"o\"] "
            "\"float amount\" 0.6\n"
            "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"a\" \"n\"] "
            "\"float amount\" 0.25\n"
            "NamedMaterial \"m\"\nShape \"sphere\"\n",
        "t.pbrt");
    const cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    auto named = [&](const std::string& name) {
        for (size_t i = 0; i < desc.materials.size(); ++i)
            if (desc.materials[i].name == name) return int(i);
        return -1;
    };
    std::map<int, double> weights;
    double weight = 1.0;
    int link = named("m"), links = 0;
    while (scene.materials.at(size_t(link)).kind == CB_MAT_MIX) {
        const cbk::Material& l = scene.materials[size_t(link)];
        REQUIRE(scene.materials.at(size_t(l.mixFirst)).kind != CB_MAT_MIX);
        weights[l.mixFirst] += weight * (1.0 - double(l.mixAmount));
        weight *= double(l.mixAmount);
        link = l.mixSecond;
        REQUIRE(++links < 10);
    }
    weights[link] += weight;
    // a's second appearance weighs 0 and is dropped: two links for three leaves.
    CHECK(links == 2);
    CHECK(weights.size() == 3);
    CHECK(weights[named("a")] == doctest::Approx(0.75).epsilon(1e-6));
    CHECK(weights[named("b")] == doctest::Approx(0.1).epsilon(1e-6));
    CHECK(weights[named("c")] == doctest::Approx(0.15).epsilon(1e-6));
    CHECK((scene.features & CB_FEATURE_DIELECTRIC) != 0); // a leaf only the inner mix names
}
