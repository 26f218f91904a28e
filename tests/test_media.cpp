// Absorbing media (pbrt-v4's "homogeneous" media of sigma_s 0 behind MediumInterface): what the
// parser and the device scene keep and refuse, the kernels' side and transmittance rules, and
// every method's image against Beer-Lambert's law through a slab, against the radiance
// integrated apart under a sphere light in ink, and against PT in a box of ink.
#include <doctest/doctest.h>

#include "cb_bdpt.h"
#include "cb_medium.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "test_render_util.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

// A homogeneous medium's transmittance and distances do not depend on where its segment lies.
const cbk::Vec3 kOrigin = cbk::vec3(0.0f, 0.0f, 0.0f), kUp = cbk::vec3(0.0f, 0.0f, 1.0f);

} // namespace

namespace {

// pbrt-v4's absorbing medium "ink" of sigma_a per channel times `scale`.
std::string inkMedium(const std::array<double, 3>& sigma, double scale = 1.0) {
    return fmt::format("MakeNamedMedium \"ink\" \"string type\" \"homogeneous\" \"rgb sigma_a\" "
                       "[{} {} {}] \"rgb sigma_s\" [0 0 0] \"float scale\" {}\n",
                       sigma[0], sigma[1], sigma[2], scale);
}
// A camera at `lookAt`, its fov, on a size x size film whose box filter keeps each pixel's
// samples on its own area.
std::string boxFilteredCamera(const std::string& lookAt, double fov, int size) {
    return fmt::format("LookAt {}\nCamera \"perspective\" \"float fov\" {}\n"
                       "Film \"rgb\" \"integer xresolution\" {} \"integer yresolution\" {}\n"
                       "PixelFilter \"box\"\n",
                       lookAt, fov, size, size);
}
const std::string kInk = inkMedium({0.5, 1, 2}, 2);
// An area light's square at z = -2, wider than any view of the tests.
const std::string kFarLight =
    "Shape \"bilinearmesh\" \"point3 P\" [-9 -9 -2  9 -9 -2  -9 9 -2  9 9 -2]\n";
const std::string kQuad =
    "Shape \"trianglemesh\" \"point3 P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] \"integer indices\" "
    "[0 1 2  0 2 3]\n";

} // namespace

TEST_CASE("absorbing media: the device scene gives boundaries their media") {
    TempDirCleanup cleanup;
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parseInTemp(kInk + "WorldBegin\nLightSource \"point\"\nMaterial \"diffuse\"\n" + kQuad +
                    "AttributeBegin\nMediumInterface \"ink\" \"\"\n" + kQuad +
                    "Shape \"sphere\" \"float radius\" 0.5\nAttributeEnd\n"
                    "AttributeBegin\nMediumInterface \"ink\"\n" +
                    kQuad + "AttributeEnd\n"));
    CHECK((scene.features & CB_FEATURE_MEDIUM) != 0);
    CHECK(contains(scene.featureNames(), "medium"));
    // The material as written, and one copy per pair of media, in the order shapes meet them:
    // (ink, vacuum) for the second quad and the sphere, (ink, ink) for the last quad.
    REQUIRE(scene.materials.size() == 3);
    CHECK(scene.materials[0].mediumInside == -1);
    CHECK(scene.materials[0].mediumOutside == -1);
    std::array<int, 3> primitivesOf{0, 0, 0};
    for (const cbk::Primitive& p : scene.bvh.primitives) {
        REQUIRE(p.material >= 0);
        REQUIRE(p.material < 3);
        ++primitivesOf[size_t(p.material)];
        if (p.kind == CB_PRIM_SPHERE) CHECK(p.material == 1);
    }
    CHECK(primitivesOf == std::array<int, 3>{2, 3, 2});
    const cbk::Material& boundary = scene.materials[1];
    REQUIRE(boundary.mediumInside >= 0);
    CHECK(boundary.mediumOutside == -1);
    // sigma_a times the medium's scale, per channel.
    for (int c = 0; c < 3; ++c)
        CHECK(scene.spectra[size_t(boundary.mediumInside * 3 + c)] ==
              doctest::Approx(std::array<double, 3>{1, 2, 4}[size_t(c)]));
    const cbk::Material& inside = scene.materials[2];
    CHECK(inside.mediumInside == boundary.mediumInside); // one entry per medium
    CHECK(inside.mediumOutside == inside.mediumInside);

    // No shape in a medium: the materials as written and no medium code.
    const cb::DeviceScene none = cb::buildDeviceScene(
        parseInTemp(kInk + "WorldBegin\nLightSource \"point\"\nMaterial \"diffuse\"\n" + kQuad));
    CHECK((none.features & CB_FEATURE_MEDIUM) == 0);
    CHECK(none.materials.size() == 1);
    CHECK(none.camera.medium == -1);
    // The camera in ink (pbrt-v4's camera medium, the outside at the Camera directive).
    const cb::DeviceScene camera =
        cb::buildDeviceScene(parseInTemp(kInk +
                                         "MediumInterface \"\" \"ink\"\nCamera \"perspective\"\n"
                                         "WorldBegin\nMediumInterface \"\"\nLightSource \"point\"\n"
                                         "Material \"diffuse\"\n" +
                                         kQuad));
    CHECK((camera.features & CB_FEATURE_MEDIUM) != 0);
    REQUIRE(camera.camera.medium >= 0);
    CHECK(camera.spectra[size_t(camera.camera.medium * 3 + 2)] == doctest::Approx(4));
    CHECK(camera.materials.size() == 1);

    // pbrt-v4 resolves the names once the file is read: a MediumInterface may come first. A
    // spectrum renders spectrally, each bin sigma_a's over it.
    const cb::SceneDesc later = parseInTemp(
        "WorldBegin\nLightSource \"point\"\nMediumInterface \"later\" \"\"\nMaterial "
        "\"dielectric\"\n" +
        kQuad +
        "MakeNamedMedium \"later\" \"string type\" \"homogeneous\" \"spectrum sigma_a\" "
        "[300 0.25 800 0.25] \"spectrum sigma_s\" [300 0 800 0]\n");
    CHECK(later.usesSpectra);
    const cb::DeviceScene spectral = cb::buildDeviceScene(later);
    REQUIRE(spectral.channels == 16);
    const int entry = spectral.materials.back().mediumInside;
    REQUIRE(entry >= 0);
    for (int bin = 0; bin < 16; ++bin)
        CHECK(spectral.spectra[size_t(entry * 16 + bin)] == doctest::Approx(0.25));
}

TEST_CASE("absorbing media: what cbdpt refuses, naming the file and line") {
    TempDirCleanup cleanup;
    auto inMedium = [&](const std::string& medium) {
        return errorOf(medium + "WorldBegin\nMediumInterface \"m\" \"\"\n" + kQuad);
    };
    std::string e = inMedium("");
    CHECK(contains(e, "t.pbrt:2"));
    CHECK(contains(e, "unknown medium \"m\""));
    CHECK(contains(e, "t.pbrt:3")); // the shape in it
    // What else cbdpt's media may not do, and what the message says of it (scattering media:
    // test_scattering.cpp).
    const std::pair<const char*, const char*> refused[] = {
        {"\"string preset\" \"Skin1\"", "names the measured \"preset\" \"Skin1\""},
        {"\"rgb sigma_s\" [0 0 0] \"rgb Le\" [1 1 1]", "emits (its \"Le\" is not 0)"},
        {"\"rgb sigma_a\" [1 -1 1] \"rgb sigma_s\" [0 0 0]", "negative value"}};
    for (const auto& [parameters, message] : refused) {
        CAPTURE(parameters);
        e = inMedium(std::string("MakeNamedMedium \"m\" \"string type\" \"homogeneous\" ") +
                     parameters + "\n");
        CHECK(contains(e, message));
        CHECK(contains(e, "t.pbrt:1"));
    }
    e = inMedium("MakeNamedMedium \"m\" \"string type\" \"rgbgrid\" \"integer nx\" 1\n");
    CHECK(contains(e, "medium \"m\" is of type \"rgbgrid\""));
    e = errorOf("MakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"rgb sigma_s\" [0 0 0]\n"
                "MakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"rgb sigma_s\" [0 0 0]\n"
                "WorldBegin\n");
    CHECK(contains(e, "t.pbrt:2"));
    CHECK(contains(e, "named medium \"m\" is already defined (at "));
    // Media nothing sits in are not errors, as in pbrt-v4; nor is a MediumInterface no shape
    // follows.
    CHECK(errorOf("MakeNamedMedium \"m\" \"string type\" \"homogeneous\"\n"
                  "MakeNamedMedium \"v\" \"string type\" \"uniformgrid\" \"float density\" [1]\n"
                  "WorldBegin\nMediumInterface \"m\" \"fog\"\n")
              .empty());
    // The camera and lights sit in the outside medium of pbrt-v4's MediumInterface: the camera
    // may sit in one, lights other than area lights (which emit into their shape's media) not.
    const std::string ink = "MakeNamedMedium \"m\" \"string type\" \"homogeneous\" \"rgb sigma_s\" "
                            "[0 0 0]\n";
    const cb::SceneDesc inInk = parseInTemp(ink + "MediumInterface \"\" \"m\"\n"
                                                  "Camera \"perspective\"\nWorldBegin\n");
    CHECK(inInk.camera.medium == 0);
    CHECK(parseInTemp(ink + "MediumInterface \"m\" \"\"\nCamera \"perspective\"\nWorldBegin\n")
              .camera.medium == -1);
    e = errorOf("MediumInterface \"\" \"fog\"\nCamera \"perspective\"\nWorldBegin\n");
    CHECK(contains(e, "unknown medium \"fog\" (no MakeNamedMedium defines it; the camera sits in "
                      "it at "));
    CHECK(contains(e, "t.pbrt:2"));
    e = errorOf(ink + "WorldBegin\nMediumInterface \"m\"\nLightSource \"point\"\n");
    CHECK(contains(e, "a LightSource inside the medium \"m\""));
}

TEST_CASE("absorbing media: the kernels' sides and Beer-Lambert transmittance") {
    TempDirCleanup cleanup;
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        kInk +
        "MakeNamedMedium \"clear\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [0 0 0] "
        "\"rgb sigma_s\" [0 0 0]\n"
        "WorldBegin\nLightSource \"point\"\nMaterial \"diffuse\"\n" +
        kQuad + "AttributeBegin\nMediumInterface \"ink\" \"clear\"\n" + kQuad +
        "AttributeEnd\nAttributeBegin\nMediumInterface \"ink\"\n" + kQuad + "AttributeEnd\n"));
    const cbk::SceneView view = cbtest::hostView(scene);
    REQUIRE(scene.materials.size() == 3);
    const int ink = scene.materials[1].mediumInside, clear = scene.materials[1].mediumOutside;
    REQUIRE(ink >= 0);
    REQUIRE(clear >= 0);
    const cbk::Vec3 n = cbk::vec3(0, 0, 1), up = cbk::vec3(0.6f, 0, 0.8f),
                    down = cbk::vec3(0.6f, 0, -0.8f);
    // A boundary gives the side the direction points to, the outside along its normal.
    CHECK(cbk::mediumLeaving(&view, 1, n, up, 7) == clear);
    CHECK(cbk::mediumLeaving(&view, 1, n, down, 7) == ink);
    // A surface without media, or with one on both sides, keeps the ray's.
    CHECK(cbk::mediumLeaving(&view, 0, n, down, 7) == 7);
    CHECK(cbk::mediumLeaving(&view, 2, n, down, -1) == -1);
    CHECK(cbk::mediumLeaving(&view, -1, n, down, 5) == 5);
    const cbk::Spectrum t = cbk::mediumTransmittance(&view, ink, kOrigin, kUp, 0.3f);
    for (int c = 0; c < 3; ++c)
        CHECK(t.c[c] == doctest::Approx(std::exp(-0.3 * std::array<double, 3>{1, 2, 4}[size_t(c)]))
                            .epsilon(1e-6));
    // To a light at infinity nothing crosses an absorbing medium; vacuum and sigma_a 0 pass all.
    const cbk::Spectrum far = cbk::mediumTransmittance(&view, ink, kOrigin, kUp, CB_INFINITY);
    const cbk::Spectrum clearFar =
        cbk::mediumTransmittance(&view, clear, kOrigin, kUp, CB_INFINITY);
    const cbk::Spectrum vacuum = cbk::mediumTransmittance(&view, -1, kOrigin, kUp, 10.0f);
    for (int c = 0; c < 3; ++c) {
        CHECK(far.c[c] == 0.0f);
        CHECK(clearFar.c[c] == 1.0f);
        CHECK(vacuum.c[c] == 1.0f);
    }
}

// The subpaths and connections of BDPT (host code, which also traces CBDPT's light subpaths)
// against the same scene of clear ink (sigma_a 0): the same random numbers give the same
// vertices, and each throughput and contribution must be the clear one's times exp(-sigma_a L)
// per channel, L the length of its path's segments in ink. Two scenes: a box of ink closed by
// glass of index 1 that the camera looks into (a segment is in ink where its midpoint is in the
// box; light tracing, whose segment to the camera crosses the glass, left out), and the same
// without the box, the camera in the ink (pbrt-v4's camera medium): every segment in ink, light
// tracing (t = 1) included.
TEST_CASE("absorbing media: every BDPT segment in ink carries Beer-Lambert's factor") {
    TempDirCleanup cleanup;
    const std::array<double, 3> sigma{0.3, 0.6, 1.2};
    for (const bool cameraInInk : {false, true}) {
        CAPTURE(cameraInInk);
        auto sceneOf = [&](double scale) {
            return cb::buildDeviceScene(parseInTemp(
                inkMedium(sigma, scale) + (cameraInInk ? "MediumInterface \"\" \"ink\"\n" : "") +
                "LookAt 0 2 -3  0 0.3 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n"
                "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
                "WorldBegin\nMediumInterface \"ink\"\n" +
                kDiskLight +
                "Material \"diffuse\" \"rgb reflectance\" [0.7 0.7 0.7]\n"
                "Shape \"bilinearmesh\" \"point3 P\" [-2 0 -2  2 0 -2  -2 0 2  2 0 2]\n"
                "Shape \"bilinearmesh\" \"point3 P\" [-2 0 1  2 0 1  -2 2 1  2 2 1]\n" +
                (cameraInInk ? ""
                             : "Material \"dielectric\" \"float eta\" 1\n"
                               "MediumInterface \"ink\" \"\"\n" +
                                   boxShape(-2.2, -0.2, -2.2, 2.2, 2.2, 1.2))));
        };
        const cb::DeviceScene inkScene = sceneOf(1.0), clearScene = sceneOf(0.0);
        REQUIRE((inkScene.camera.medium >= 0) == cameraInInk);
        const cbk::SceneView ink = cbtest::hostView(inkScene), clear = cbtest::hostView(clearScene);
        // Vertices are in device space, world space less the camera's position.
        const std::array<double, 3>& origin = inkScene.origin;
        auto inInk = [&](cbk::Vec3 a, cbk::Vec3 b) {
            const double x = 0.5 * (a.x + b.x) + origin[0], y = 0.5 * (a.y + b.y) + origin[1],
                         z = 0.5 * (a.z + b.z) + origin[2];
            return cameraInInk ||
                   (x > -2.2 && x < 2.2 && y > -0.2 && y < 2.2 && z > -2.2 && z < 1.2);
        };
        auto inkLength = [&](const std::vector<cbk::PathVertex>& path, int count) {
            double length = 0.0;
            for (int i = 1; i < count; ++i) {
                const cbk::Vec3 a = cbk::pvP(&path[size_t(i - 1)]), b = cbk::pvP(&path[size_t(i)]);
                if (inInk(a, b)) length += cbk::vlength(cbk::vsub(b, a));
            }
            return length;
        };
        // ink / clear = exp(-sigma_a length) per channel, where the clear value is not 0.
        long compared = 0;
        auto checkRatio = [&](const cbk::Spectrum& inkValue, const cbk::Spectrum& clearValue,
                              double length) {
            for (int c = 0; c < 3; ++c) {
                if (!(clearValue.c[c] > 0.0f)) continue;
                CHECK(inkValue.c[c] / clearValue.c[c] ==
                      doctest::Approx(std::exp(-sigma[size_t(c)] * length)).epsilon(2e-4));
                ++compared;
            }
        };
        const int ne = 5, nl = 4;
        int inkConnections = 0, lightTracing = 0;
        for (unsigned pixel = 0; pixel < 256; ++pixel) {
            std::vector<cbk::PathVertex> light[2], eye[2];
            int nLight[2], nEye[2];
            for (int k = 0; k < 2; ++k) {
                const cbk::SceneView* view = k == 0 ? &ink : &clear;
                light[k].resize(size_t(nl));
                eye[k].resize(size_t(ne));
                int rays = 0;
                nLight[k] = cbk::bdptLightSubpath(
                    view,
                    cbk::bdptLightStream(cbk::SamplerSettings{3, CB_SAMPLER_INDEPENDENT, {0, 0}}, 0,
                                         pixel, 256),
                    nl, light[k].data(), &rays);
                cbk::SampleStream es = cbk::sampleStreamStart(3, 0, pixel);
                nEye[k] = cbk::bdptEyeSubpath(view, &inkScene.camera, float(pixel % 16) + 0.5f,
                                              float(pixel / 16) + 0.5f, true, es, ne, eye[k].data(),
                                              &rays);
            }
            REQUIRE(nLight[0] == nLight[1]);
            REQUIRE(nEye[0] == nEye[1]);
            for (int i = 0; i < nLight[0]; ++i)
                checkRatio(light[0][size_t(i)].beta, light[1][size_t(i)].beta,
                           inkLength(light[0], i + 1));
            for (int j = 0; j < nEye[0]; ++j)
                checkRatio(eye[0][size_t(j)].beta, eye[1][size_t(j)].beta,
                           inkLength(eye[0], j + 1));
            for (int t = cameraInInk ? 1 : 2; t <= nEye[0]; ++t)
                for (int s = 0; s <= nLight[0]; ++s) {
                    if (!cbk::bdptStrategyAllowed(s, t, ne, nl)) continue;
                    cbk::BdptConnection c[2];
                    bool made[2];
                    for (int k = 0; k < 2; ++k)
                        made[k] =
                            cbk::bdptConnectUnoccluded(k == 0 ? &ink : &clear, &inkScene.camera,
                                                       light[k].data(), s, eye[k].data(), t, &c[k]);
                    REQUIRE(made[0] == made[1]);
                    if (!made[0]) continue;
                    double length = inkLength(light[0], s) + inkLength(eye[0], t);
                    if (s > 0) {
                        const cbk::Vec3 a = cbk::pvP(&light[0][size_t(s - 1)]),
                                        b = cbk::pvP(&eye[0][size_t(t - 1)]);
                        if (inInk(a, b)) {
                            length += cbk::vlength(cbk::vsub(b, a));
                            ++inkConnections;
                            if (t == 1) ++lightTracing;
                        }
                    }
                    checkRatio(c[0].contribution, c[1].contribution, length);
                }
        }
        CHECK(compared > 3000);
        CHECK(inkConnections > 300);
        if (cameraInInk) CHECK(lightTracing > 100);
    }
}

// A slab of ink (sigma_a per channel, 1 thick) behind glass of index 1 (no refraction, no
// reflection), between the camera and an area light of radiance 1 that fills the view: a pixel
// is exp(-sigma_a / cos theta) per channel, theta the camera ray's angle to the slab's normal.
TEST_CASE("absorbing media: every method through a slab of ink, against Beer-Lambert's law" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const std::array<double, 3> sigma{0.25, 0.5, 1.0};
    const cb::DeviceScene scene = cb::buildDeviceScene(cb::parseSceneString(
        boxFilteredCamera("0 0 5  0 0 0  0 1 0", 40, 12) + "WorldBegin\n" + inkMedium(sigma) +
            "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n" + kFarLight +
            "AttributeEnd\nMaterial \"dielectric\" \"float eta\" 1\n"
            "MediumInterface \"ink\" \"\"\n" +
            boxShape(-6, -6, -0.5, 6, 6, 0.5),
        "t.pbrt"));
    REQUIRE((scene.features & CB_FEATURE_MEDIUM) != 0);
    std::array<double, 3> expected{0, 0, 0};
    const int size = 12, sub = 24;
    forEachFilmSample(size, sub, std::tan(20.0 * M_PI / 180.0), [&](int, int, double x, double y) {
        const double length = std::sqrt(1.0 + x * x + y * y); // 1 / cos theta
        for (int c = 0; c < 3; ++c)
            expected[size_t(c)] += std::exp(-sigma[size_t(c)] * length);
    });
    for (double& e : expected)
        e /= double(size * size * sub * sub);
    checkEveryMethodChannelMeans(scene, runtime, expected, 4, 16, 11u);

    // The camera in ink (pbrt-v4's camera medium), 7 from the light: exp(-7 sigma_a / cos). The
    // glass is in the ink on both sides, no boundary (and the scene compiles the same kernels).
    const double scale = 0.1;
    const cb::DeviceScene inInk = cb::buildDeviceScene(cb::parseSceneString(
        inkMedium(sigma, scale) + "MediumInterface \"\" \"ink\"\n" +
            boxFilteredCamera("0 0 5  0 0 0  0 1 0", 40, 12) +
            "WorldBegin\nMediumInterface \"ink\"\nAttributeBegin\n"
            "AreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\n" +
            kFarLight + "AttributeEnd\nMaterial \"dielectric\" \"float eta\" 1\n" +
            boxShape(-6, -6, -0.5, 6, 6, 0.5),
        "t.pbrt"));
    REQUIRE(inInk.features == scene.features);
    REQUIRE(inInk.camera.medium >= 0);
    expected = {0, 0, 0};
    forEachFilmSample(size, sub, std::tan(20.0 * M_PI / 180.0), [&](int, int, double x, double y) {
        const double length = 7.0 * std::sqrt(1.0 + x * x + y * y);
        for (int c = 0; c < 3; ++c)
            expected[size_t(c)] += std::exp(-scale * sigma[size_t(c)] * length);
    });
    for (double& e : expected)
        e /= double(size * size * sub * sub);
    checkEveryMethodChannelMeans(inInk, runtime, expected, 4, 16, 12u);
}

// A diffuse floor (reflectance rho) in ink under an invisible sphere light (radiance L, radius R,
// its centre at height h), seen from above through a window of glass of index 1 at height w that
// closes the ink: a floor point at distance d from the centre receives
//   E = 2 pi L (h / d) int_0^asin(R/d) exp(-sigma t(theta)) cos(theta) sin(theta) dtheta
// (the azimuth's part of the floor's cosine integrates to 0 about the cone's axis), t(theta) the
// distance to the sphere along a direction theta off the axis, and the pixel sees rho E / pi
// through exp(-sigma w / cos) of ink. Only next-event estimation (BDPT's s = 1) finds the light,
// so its transmittance, and the eye walk's, decide the image.
TEST_CASE("absorbing media: every method's floor under a sphere light in ink, against the "
          "radiance integrated apart" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double rho = 0.5, radiance = 2.0, radius = 0.5, h = 1.5, window = 2.5, cameraHeight = 4.0;
    const std::array<double, 3> sigma{0.2, 0.4, 0.8};
    const cb::DeviceScene scene = cb::buildDeviceScene(cb::parseSceneString(
        boxFilteredCamera(fmt::format("0 0 {}  0 0 0  0 1 0", cameraHeight), 60, 12) +
            "WorldBegin\n" + inkMedium(sigma) +
            fmt::format(
                "AttributeBegin\nMaterial \"dielectric\" \"float eta\" 1\n"
                "MediumInterface \"ink\" \"\"\n"
                "Shape \"bilinearmesh\" \"point3 P\" [-50 -50 {}  50 -50 {}  -50 50 {}  50 50 "
                "{}]\nAttributeEnd\nMediumInterface \"ink\"\n"
                "Material \"diffuse\" \"rgb reflectance\" [{} {} {}]\n"
                "Shape \"bilinearmesh\" \"point3 P\" [-100 -100 0  100 -100 0  -100 100 0  "
                "100 100 0]\nAttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [{} {} {}]\n"
                "Translate 0 0 {}\nShape \"sphere\" \"float radius\" {} \"float alpha\" 0\n"
                "AttributeEnd\n",
                window, window, window, window, rho, rho, rho, radiance, radiance, radiance, h,
                radius),
        "t.pbrt"));
    REQUIRE((scene.features & (CB_FEATURE_MEDIUM | CB_FEATURE_INVISIBLE_LIGHT)) ==
            (CB_FEATURE_MEDIUM | CB_FEATURE_INVISIBLE_LIGHT));
    auto irradiance = [&](double d, double s) {
        const double alpha = std::asin(radius / d);
        const int n = 400;
        double sum = 0.0;
        for (int i = 0; i < n; ++i) {
            const double theta = (i + 0.5) * alpha / n;
            const double sin2 = std::sin(theta) * std::sin(theta);
            const double t = d * std::cos(theta) - std::sqrt(radius * radius - d * d * sin2);
            sum += std::exp(-s * t) * std::cos(theta) * std::sin(theta);
        }
        return 2.0 * M_PI * radiance * (h / d) * sum * alpha / n;
    };
    std::array<double, 3> expected{0, 0, 0};
    const int size = 12, sub = 16;
    forEachFilmSample(size, sub, std::tan(M_PI / 6.0), [&](int, int, double x, double y) {
        const double r2 = cameraHeight * cameraHeight * (x * x + y * y);
        const double d = std::sqrt(h * h + r2);
        const double inInk = window * std::sqrt(1.0 + x * x + y * y);
        for (int c = 0; c < 3; ++c)
            expected[size_t(c)] +=
                rho / M_PI * irradiance(d, sigma[size_t(c)]) * std::exp(-sigma[size_t(c)] * inInk);
    });
    for (double& e : expected)
        e /= double(size * size * sub * sub);
    checkEveryMethodChannelMeans(scene, runtime, expected, 8, 32, 21u, 32);
}

// Every strategy in ink: checkMethodsAgreeWithPt's floor, wall, block and light inside a box of
// ink closed by glass of index 1, which the camera looks into (BDPT's connections inside the ink,
// s >= 1 to eye vertices past the glass, each cross it), or in which it sits (light tracing too).
TEST_CASE("absorbing media: BDPT, CBDPT and MLT agree with PT inside a box of ink" *
          doctest::test_suite("statistical")) {
    const std::array<double, 3> boxInk{0.15, 0.3, 0.6};
    SUBCASE("the camera outside") {
        checkMethodsAgreeWithPt(inkMedium(boxInk) + "MediumInterface \"ink\"\n" + kDiskLight,
                                "AttributeBegin\nMaterial \"dielectric\" \"float eta\" "
                                "1\nMediumInterface \"ink\" \"\"\n" +
                                    boxShape(-2.2, -0.2, -2.2, 2.2, 2.2, 1.2) + "AttributeEnd\n");
    }
    // Light tracing (t = 1) too: the camera in the ink (pbrt-v4's camera medium), inside the
    // glass, which has ink on both sides (no boundary; the same kernels as above).
    SUBCASE("the camera in the ink") {
        checkMethodsAgreeWithPt(inkMedium(boxInk) + "MediumInterface \"ink\"\n" + kDiskLight,
                                "AttributeBegin\nMaterial \"dielectric\" \"float eta\" 1\n" +
                                    boxShape(-2.2, -0.2, -3.5, 2.2, 2.2, 1.2) + "AttributeEnd\n",
                                "", "Material \"diffuse\" \"rgb reflectance\" [0.7 0.7 0.7]\n",
                                "MediumInterface \"\" \"ink\"\n");
    }
}
