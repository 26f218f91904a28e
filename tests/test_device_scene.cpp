// The device scene under extreme geometry and light input (docs/robustness.md): what the host
// must drop or reject before the float kernels see it, checked through the kernels' own
// functions (compiled for the host as cbk) or against independent arithmetic.
#include <doctest/doctest.h>

#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include "cb_intersect.h"
#include "cb_lights.h"

#include <cmath>
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

cbk::SceneView viewOf(const cb::DeviceScene& s) {
    cbk::SceneView v{};
    v.nodes = s.wide.nodes.data();
    v.packs = s.wide.packs.data();
    v.primitives = s.bvh.primitives.data();
    v.materials = s.materials.data();
    v.lights = s.lights.data();
    v.spectra = s.spectra.data();
    v.lightCount = int(s.lights.size());
    return v;
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
    const cbk::SceneView view = viewOf(s);
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
