// pbrt-v4's shape "alpha" (cut-outs and stochastic transparency): the parser's constants and
// textures and what it refuses, float textures read from an image's alpha channel as pbrt-v4
// reads them, the traversal's alpha test (kernels/cb_texture.h, alphaKeepsHit), and every
// method's image of alpha-tested planes against the analytic radiance and against PT; invisible
// area lights (alpha 0 on an emitter's shape) out of the BVH, and every method's image under
// them against the analytic radiance and against PT.
#include <doctest/doctest.h>

#include "cb_bvh_wide.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "test_render_util.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <fmt/format.h>
#include <stb_image_write.h>

#include <array>
#include <cmath>
#include <set>
#include <string>
#include <vector>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

using Byte = unsigned char;
using Texel = std::array<Byte, 4>;

// An 8-bit RGBA PNG in the test folder, texel (x, y) = rgba(x, y) (4 bytes).
template <class Rgba>
void writeRgbaPng(const std::string& name, int w, int h, int channels, Rgba rgba) {
    std::vector<Byte> bytes;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const Texel texel = rgba(x, y);
            for (int c = 0; c < channels; ++c)
                bytes.push_back(texel[size_t(c)]);
        }
    REQUIRE(stbi_write_png((tempDir() / name).string().c_str(), w, h, channels, bytes.data(),
                           w * channels) != 0);
}

const std::string kQuad = "Shape \"trianglemesh\" \"point3 P\" [-1 -1 0  1 -1 0  1 1 0  -1 1 0] "
                          "\"integer indices\" [0 1 2  0 2 3] \"point2 uv\" [0 0  1 0  1 1  0 1] ";

cb::DeviceScene deviceInTemp(const std::string& text) {
    return cb::buildDeviceScene(parseInTemp(text));
}

} // namespace

TEST_CASE("shape alpha: constants and textures, the shapes that take them, the refusals") {
    TempDirCleanup cleanup;
    writeImage("a.exr", 2, 1, [](int x, int, int c) { return 0.25f * float(1 + x + c); });
    const std::string head =
        "WorldBegin\nLightSource \"point\"\n"
        "Texture \"cut\" \"float\" \"imagemap\" \"string filename\" \"a.exr\"\n";
    cb::SceneDesc s =
        parseInTemp(head + kQuad + "\"float alpha\" 0.5\n" + kQuad + "\"float alpha\" 0.5\n" +
                    kQuad + "\"float alpha\" 0.25\n" + kQuad + "\"texture alpha\" \"cut\"\n" +
                    kQuad + "\"float alpha\" 1\n" + kQuad);
    REQUIRE(s.meshes.size() == 6);
    // The float texture holds its value three times: the mean of R, G, B (no alpha channel).
    REQUIRE(s.textures.size() == 3);
    CHECK(s.textures[0].rgb == std::vector<float>{0.5f, 0.5f, 0.5f, 0.75f, 0.75f, 0.75f});
    // Equal constants share one 1 x 1 texture.
    CHECK(s.meshes[0].alphaTexture == 1);
    CHECK(s.meshes[1].alphaTexture == 1);
    CHECK(s.meshes[2].alphaTexture == 2);
    CHECK(s.textures[1].rgb == std::vector<float>{0.5f, 0.5f, 0.5f});
    CHECK(s.textures[2].width == 1);
    CHECK(s.meshes[3].alphaTexture == 0);
    CHECK(s.meshes[4].alphaTexture == -1);
    CHECK(s.meshes[5].alphaTexture == -1);

    // Every triangle shape takes an alpha; a sphere only 0 or 1.
    for (const std::string shape :
         {"Shape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0] ", "Shape \"disk\" "}) {
        CAPTURE(shape);
        const cb::SceneDesc d = parseInTemp(head + shape + "\"float alpha\" 0.5\n");
        REQUIRE(d.meshes.size() == 1);
        CHECK(d.meshes[0].alphaTexture == 1);
    }
    CHECK(contains(errorOf(head + "Shape \"sphere\" \"float alpha\" 0.5\n"),
                   "t.pbrt:4:30: an \"alpha\" below 1 on a sphere is not supported"));
    CHECK(contains(errorOf(head + "Shape \"sphere\" \"texture alpha\" \"cut\"\n"),
                   "on a sphere is not supported"));
    CHECK(contains(errorOf(head + kQuad + "\"texture alpha\" \"leaf\"\n"),
                   ":4:" + std::to_string(kQuad.size() + 17) +
                       ": \"texture alpha\" names no float texture \"leaf\""));
    CHECK(contains(errorOf(head + "Texture \"w\" \"float\" \"bilerp\"\n" + kQuad +
                           "\"texture alpha\" \"w\"\n"),
                   "class \"bilerp\""));

    // The device: a material of its own per (material, alpha) pair, alpha-tested triangles in
    // packs of their own, the feature only where a shape has an alpha.
    const cb::DeviceScene device =
        deviceInTemp(head + "Material \"diffuse\"\n" + kQuad + "\"float alpha\" 0.5\n" + kQuad +
                     "\"float alpha\" 0.5\n" + kQuad + "\"texture alpha\" \"cut\"\n" + kQuad);
    CHECK((device.features & CB_FEATURE_ALPHA) != 0);
    CHECK((device.features & CB_FEATURE_TEXTURE) != 0);
    std::vector<int> alphaOffsets;
    for (const cbk::Material& m : device.materials)
        if (m.alphaTexture >= 0) alphaOffsets.push_back(m.alphaTexture);
    REQUIRE(alphaOffsets.size() == 2);
    CHECK(alphaOffsets[0] != alphaOffsets[1]);
    int alphaTested = 0;
    for (const cbk::Primitive& p : device.bvh.primitives) {
        CHECK((p.kind == CB_PRIM_ALPHA_TRIANGLE) ==
              (device.materials[size_t(p.material)].alphaTexture >= 0));
        alphaTested += p.kind == CB_PRIM_ALPHA_TRIANGLE;
    }
    CHECK(alphaTested == 6);
    for (const cbk::TrianglePack& pack : device.wide.packs)
        for (int k = 0; k < pack.count; ++k) {
            const int kind = device.bvh.primitives[size_t(pack.prim[k])].kind;
            CHECK((kind == CB_PRIM_ALPHA_TRIANGLE) == (pack.alphaTested != 0));
            CHECK(pack.scalar == 0);
        }
    CHECK((deviceInTemp(head + kQuad).features & CB_FEATURE_ALPHA) == 0);
    CHECK((deviceInTemp(head + kQuad + "\"float alpha\" 1\n").features & CB_FEATURE_ALPHA) == 0);

    // An emitter with an alpha, and an alpha texture on a disk (no (u, v) in cbdpt): refused by
    // the device, naming the shape's line; a constant alpha needs no (u, v).
    const std::string emitterError =
        deviceErrorOf(head + "AttributeBegin\nAreaLightSource \"diffuse\"\n" + kQuad +
                      "\"float alpha\" 0.5\nAttributeEnd\n");
    CHECK(contains(emitterError, "t.pbrt:6:"));
    CHECK(contains(emitterError, "an area light's shape with an \"alpha\" below 1"));
    const std::string diskError =
        deviceErrorOf(head + "Shape \"disk\" \"texture alpha\" \"cut\"\n");
    CHECK(contains(diskError, "t.pbrt:4:"));
    CHECK(contains(diskError, "\"alpha\" is a texture, which needs texture coordinates"));
    CHECK(deviceErrorOf(head + "Shape \"disk\" \"float alpha\" 0.5\n").empty());
}

TEST_CASE("shape alpha: float textures read an image's alpha channel as pbrt-v4 does") {
    TempDirCleanup cleanup;
    // RGBA with alpha 0, 128, 255: the bilinear float lookup reads the alpha, decoded by the
    // texture's encoding as pbrt-v4 decodes an 8-bit file's every channel; "point" reads R.
    writeRgbaPng("rgba.png", 3, 1, 4, [](int x, int) {
        return Texel{Byte(10 + x), 100, 200, Byte(x == 0 ? 0 : x == 1 ? 128 : 255)};
    });
    // All alpha 255 (pbrt-v4 drops such a channel): the mean of R, G, B.
    writeRgbaPng("opaque.png", 1, 1, 4, [](int, int) { return Texel{10, 100, 200, 255}; });
    // Grey and alpha (pbrt-v4 reads the grey only).
    writeRgbaPng("grey.png", 1, 1, 2, [](int, int) { return Texel{100, 0, 0, 0}; });
    auto floatTexture = [](const std::string& file, const std::string& extra = "") {
        const cb::SceneDesc s =
            parseInTemp("WorldBegin\nTexture \"t\" \"float\" \"imagemap\" \"string filename\" \"" +
                        file + "\" " + extra + "\n");
        REQUIRE(s.textures.size() == 1);
        return s.textures[0].rgb;
    };
    std::vector<float> a = floatTexture("rgba.png");
    REQUIRE(a.size() == 9);
    for (int x = 0; x < 3; ++x) {
        CAPTURE(x);
        const double expected = srgbByte(x == 0 ? 0 : x == 1 ? 128 : 255);
        for (int c = 0; c < 3; ++c)
            CHECK(a[size_t(3 * x + c)] == doctest::Approx(expected).epsilon(1e-6));
    }
    a = floatTexture("rgba.png", "\"string encoding\" \"linear\"");
    CHECK(a[3] == doctest::Approx(128.0 / 255.0).epsilon(1e-6));
    a = floatTexture("rgba.png", "\"string filter\" \"point\"");
    CHECK(a[3] == doctest::Approx(srgbByte(11)).epsilon(1e-6));
    a = floatTexture("rgba.png", "\"float scale\" 0.5 \"bool invert\" true");
    CHECK(a[3] == doctest::Approx(1.0 - 0.5 * srgbByte(128)).epsilon(1e-6));
    a = floatTexture("opaque.png");
    CHECK(a[0] ==
          doctest::Approx((srgbByte(10) + srgbByte(100) + srgbByte(200)) / 3.0).epsilon(1e-6));
    a = floatTexture("grey.png");
    CHECK(a[0] == doctest::Approx(srgbByte(100)).epsilon(1e-6));
    // A spectrum texture of the same file keeps its colour, not premultiplied.
    const cb::SceneDesc s = parseInTemp(
        "WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"rgba.png\"\n");
    CHECK(s.textures[0].rgb[3] == doctest::Approx(srgbByte(11)).epsilon(1e-6));
    CHECK(s.textures[0].rgb[5] == doctest::Approx(srgbByte(200)).epsilon(1e-6));

    // An EXR's "A" channel (linear).
    {
        Imf::Header header(2, 1);
        for (const char* c : {"R", "G", "B", "A"})
            header.channels().insert(c, Imf::Channel(Imf::FLOAT));
        const float rgba[2][4] = {{0.2f, 0.4f, 0.6f, 0.125f}, {0.2f, 0.4f, 0.6f, 1.f}};
        Imf::FrameBuffer fb;
        const char* names[4] = {"R", "G", "B", "A"};
        for (int c = 0; c < 4; ++c)
            fb.insert(names[c], Imf::Slice(Imf::FLOAT, (char*)&rgba[0][c], 4 * sizeof(float),
                                           8 * sizeof(float)));
        Imf::OutputFile file((tempDir() / "rgba.exr").string().c_str(), header);
        file.setFrameBuffer(fb);
        file.writePixels(1);
    }
    a = floatTexture("rgba.exr");
    CHECK(a[0] == 0.125f);
    CHECK(a[3] == 1.f);
}

// Rays straight down through a quad whose alpha runs from 0 (u < 1/4) to 1 (u > 3/4) (two
// texels, bilinear, clamped) over an opaque floor: the closest hit skips the quad where alpha
// is 0, keeps it where 1, and where 1/2 keeps it for about half the rays; the any-hit query
// always agrees with the closest hit.
TEST_CASE("shape alpha: the traversal skips what the alpha test skips") {
    TempDirCleanup cleanup;
    writeRgbaPng("ramp.png", 2, 1, 4, [](int x, int) {
        return Texel{0, 0, 0, Byte(x == 0 ? 0 : 255)};
    });
    const cb::DeviceScene scene =
        deviceInTemp("WorldBegin\nLightSource \"point\"\nTexture \"ramp\" \"float\" \"imagemap\" "
                     "\"string filename\" \"ramp.png\" \"string wrap\" \"clamp\"\n" +
                     kQuad + "\"texture alpha\" \"ramp\"\n" +
                     "Shape \"trianglemesh\" \"point3 P\" [-2 -2 -1  2 -2 -1  2 2 -1  -2 2 -1] "
                     "\"integer indices\" [0 1 2  0 2 3]\n");
    const cbk::SceneView view = cbtest::hostView(scene);
    auto keptShare = [&](double u, int rays) {
        int kept = 0;
        for (int i = 0; i < rays; ++i) {
            const double y = -0.9 + 1.8 * (i + 0.5) / rays;
            cbk::Ray ray;
            ray.o = cbk::vec3(float(2.0 * u - 1.0 - scene.origin[0]), float(y - scene.origin[1]),
                              float(1.0 - scene.origin[2]));
            ray.d = cbk::vec3(0.f, 0.f, -1.f);
            cbk::Hit hit;
            REQUIRE(cbk::sceneIntersect(&view, ray, CB_INFINITY, &hit));
            const bool quad = hit.t < 1.5f;
            CHECK((quad ? hit.t : 2.f) == doctest::Approx(quad ? 1.0 : 2.0).epsilon(1e-5));
            CHECK(cbk::sceneOccluded(&view, ray, 1.5f) == quad);
            kept += quad;
        }
        return double(kept) / rays;
    };
    CHECK(keptShare(0.1, 200) == 0.0);
    CHECK(keptShare(0.9, 200) == 1.0);
    // Binomial: 4.5 standard errors of a share of 1/2 over 4000 rays.
    CHECK(std::fabs(keptShare(0.5, 4000) - 0.5) <= 4.5 * std::sqrt(0.25 / 4000));
    CHECK(std::fabs(keptShare(0.375, 4000) - 0.25) <= 4.5 * std::sqrt(0.25 * 0.75 / 4000));
}

// Two large parallel diffuse planes under a uniform sky of radiance 1: the upper one (reflectance
// rf) of alpha a, the lower one (rb) opaque, the camera looking down at them. A path through the
// upper plane reaches the lower one with probability 1 - a, and between the planes each bounce
// off the upper plane's underside has probability a; so the image is
// a rf + (1 - a)^2 rb sum_k (a rf rb)^k, over the k round trips within the path-length cap. An
// alpha texture whose pattern repeats far finer than the planes' gap counts with its mean. The
// lower plane's alpha is a texture of 1, which keeps every hit.
TEST_CASE("shape alpha: two planes under a sky, every method, against the analytic radiance" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    // Alpha 255 in one texel of four: mean 1/4 (the bilinear lookup keeps the mean over a
    // repeating period).
    writeRgbaPng("holes.png", 2, 2, 4, [](int x, int y) {
        return Texel{0, 0, 0, Byte(x == 0 && y == 0 ? 255 : 0)};
    });
    // Alpha 1 as an image (a constant texture of 1 counts as no alpha, as pbrt-v4's).
    writeRgbaPng("ones.png", 1, 1, 4, [](int, int) { return Texel{255, 255, 255, 255}; });
    const double rf = 0.6, rb = 0.8;
    const int maxVertices = 8;
    for (const auto& [alphaLine, a] :
         {std::pair{std::string("\"float alpha\" 0.3"), 0.3},
          std::pair{std::string("\"texture alpha\" \"holes\""), 0.25}}) {
        CAPTURE(alphaLine);
        const cb::DeviceScene scene = deviceInTemp(fmt::format(
            "LookAt 0 0 1  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 30\n"
            "Film \"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 12\n"
            "PixelFilter \"box\"\nWorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n"
            "Texture \"holes\" \"float\" \"imagemap\" \"string filename\" \"holes.png\" "
            "\"float uscale\" 40000 \"float vscale\" 40000\n"
            "Texture \"one\" \"float\" \"imagemap\" \"string filename\" \"ones.png\"\n"
            "Material \"diffuse\" \"rgb reflectance\" [{0} {0} {0}]\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-100 -100 0  100 -100 0  -100 100 0  100 100 0] "
            "{2}\n"
            "Material \"diffuse\" \"rgb reflectance\" [{1} {1} {1}]\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-100 -100 -0.2  100 -100 -0.2  -100 100 -0.2  "
            "100 100 -0.2] \"texture alpha\" \"one\"\n",
            rf, rb, alphaLine));
        REQUIRE((scene.features & CB_FEATURE_ALPHA) != 0);
        // The lower plane is alpha-tested too (alpha 1): the four triangles share a pack, so a
        // ray whose nearest lane the test skips takes the next.
        REQUIRE(scene.wide.packs.size() == 1);
        REQUIRE(scene.wide.packs[0].alphaTested != 0);
        double expected = a * rf;
        for (int k = 0; 4 + 2 * k <= maxVertices; ++k)
            expected += (1.0 - a) * (1.0 - a) * rb * std::pow(a * rf * rb, k);
        for (const std::string method : kMethods) {
            CAPTURE(method);
            cb::IntegratorSettings settings = methodSettings(method);
            settings.maxPathVertices = maxVertices;
            const MethodMean m = methodMean(scene, runtime, settings, 6, method == "mlt" ? 32 : 8);
            CAPTURE(m.mean);
            CAPTURE(m.se);
            CAPTURE(expected);
            CHECK(std::fabs(m.mean - expected) <= 4.5 * m.se + 2e-3 * expected);
            CHECK(m.nonFinite == 0);
        }
    }
}

// Where every strategy matters: a cut-out screen (a checker of alpha 0 and 1, and its
// bilinear ramps of stochastic alpha) between the disk light and the block; BDPT, CBDPT and MLT
// against PT per region.
TEST_CASE("shape alpha: BDPT, CBDPT and MLT agree with PT through a cut-out screen" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    writeRgbaPng("checker.png", 4, 4, 4, [](int x, int y) {
        return Texel{0, 0, 0, Byte((x + y) % 2 ? 255 : 0)};
    });
    checkMethodsAgreeWithPt(kDiskLight,
                            "Texture \"checker\" \"float\" \"imagemap\" \"string filename\" \"" +
                                (tempDir() / "checker.png").string() +
                                "\"\nShape \"bilinearmesh\" \"point3 P\" [-1.5 1.2 -1.5  1.5 1.2 "
                                "-1.5  -1.5 1.2 1.5  1.5 1.2 1.5] \"texture alpha\" \"checker\"\n");
}

// pbrt-v4's invisible area lights (an area light's shape of "float alpha" 0): light sampling
// reaches them, no ray finds them. The device keeps their primitives out of the BVH, after the
// leaves' primitives, where their lights point.
TEST_CASE("invisible area lights: out of the BVH, where their lights find them") {
    const std::string lights =
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [2 2 2]\n"
        "Shape \"trianglemesh\" \"point3 P\" [-1 -1 1  1 -1 1  1 1 1  -1 1 1] "
        "\"integer indices\" [0 2 1  0 3 2] \"float alpha\" 0\n"
        "Translate 0 0 2\nShape \"sphere\" \"float radius\" 0.5 \"float alpha\" 0\nAttributeEnd\n";
    const std::string floor = "Material \"diffuse\"\nShape \"trianglemesh\" \"point3 P\" [-2 -2 0  "
                              "2 -2 0  2 2 0  -2 2 0] \"integer indices\" [0 1 2  0 2 3]\n";
    const cb::DeviceScene scene =
        cb::buildDeviceScene(cb::parseSceneString("WorldBegin\n" + lights + floor, "t.pbrt"));
    CHECK((scene.features & CB_FEATURE_INVISIBLE_LIGHT) != 0);
    std::set<int> inLeaves;
    for (const cbk::TrianglePack& pack : scene.wide.packs)
        for (int k = 0; k < pack.count; ++k)
            inLeaves.insert(pack.prim[k]);
    CHECK(inLeaves == std::set<int>{0, 1}); // the floor's two triangles
    REQUIRE(scene.bvh.primitives.size() == 5);
    REQUIRE(scene.lights.size() == 3);
    double triangleArea = 0.0, sphereArea = 0.0;
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        const cbk::Light& light = scene.lights[i];
        CAPTURE(i);
        CHECK(light.invisible == 1);
        REQUIRE(light.primitive >= 2);
        const cbk::Primitive& prim = scene.bvh.primitives[size_t(light.primitive)];
        CHECK(prim.light == int(i));
        (prim.kind == CB_PRIM_SPHERE ? sphereArea : triangleArea) += light.area;
    }
    CHECK(triangleArea == doctest::Approx(4.0));
    CHECK(sphereArea == doctest::Approx(M_PI));

    // A ray down through both lights, 0.36 off the sphere's axis, finds the floor; made visible,
    // the sphere.
    auto downward = [](const cb::DeviceScene& s) {
        cbk::Ray ray;
        ray.o =
            cbk::vec3(float(0.3 - s.origin[0]), float(0.2 - s.origin[1]), float(3.0 - s.origin[2]));
        ray.d = cbk::vec3(0.f, 0.f, -1.f);
        return ray;
    };
    const cbk::SceneView view = cbtest::hostView(scene);
    cbk::Hit hit;
    REQUIRE(cbk::sceneIntersect(&view, downward(scene), CB_INFINITY, &hit));
    CHECK(hit.t == doctest::Approx(3.0).epsilon(1e-5));
    CHECK(!cbk::sceneOccluded(&view, downward(scene), 2.9f));
    std::string shown = lights;
    for (size_t at; (at = shown.find(" \"float alpha\" 0")) != std::string::npos;)
        shown.erase(at, std::string(" \"float alpha\" 0").size());
    const cb::DeviceScene visible =
        cb::buildDeviceScene(cb::parseSceneString("WorldBegin\n" + shown + floor, "t.pbrt"));
    CHECK((visible.features & CB_FEATURE_INVISIBLE_LIGHT) == 0);
    const cbk::SceneView visibleView = cbtest::hostView(visible);
    REQUIRE(cbk::sceneIntersect(&visibleView, downward(visible), CB_INFINITY, &hit));
    CHECK(hit.t == doctest::Approx(1.0 - std::sqrt(0.25 - 0.13)).epsilon(1e-5));
}

// A diffuse floor (reflectance rho) under an invisible sphere light (radiance L, radius R, its
// centre at height h), seen from above through the sphere: a floor point at distance d from the
// centre receives pi L (R / d)^2 (h / d) (a sphere wholly above the horizon lights as a point of
// intensity pi R^2 L at its centre) and nothing else, as the floor's light escapes through the
// sphere. So a pixel is rho L R^2 h / d^3, from paths of three vertices only; a method whose MIS
// still counted the strategies that find the light by a ray (PT's BSDF sample, BDPT's s = 0)
// would come out low (by 4-6% here).
TEST_CASE("invisible area lights: a sphere light over a floor, every method, against the "
          "analytic radiance" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const double rho = 0.5, radiance = 2.0, radius = 1.0, h = 1.5, cameraHeight = 4.0;
    const cb::DeviceScene scene = cb::buildDeviceScene(cb::parseSceneString(
        fmt::format("LookAt 0 0 {}  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 60\n"
                    "Film \"rgb\" \"integer xresolution\" 12 \"integer yresolution\" 12\n"
                    "PixelFilter \"box\"\nWorldBegin\n"
                    "Material \"diffuse\" \"rgb reflectance\" [{} {} {}]\n"
                    "Shape \"bilinearmesh\" \"point3 P\" [-100 -100 0  100 -100 0  -100 100 0  "
                    "100 100 0]\nAttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [{} {} {}]\n"
                    "Translate 0 0 {}\nShape \"sphere\" \"float radius\" {} \"float alpha\" 0\n"
                    "AttributeEnd\n",
                    cameraHeight, rho, rho, rho, radiance, radiance, radiance, h, radius),
        "t.pbrt"));
    REQUIRE((scene.features & CB_FEATURE_INVISIBLE_LIGHT) != 0);
    // The film at distance 1 spans [-tan 30, tan 30]^2 and shows the floor point cameraHeight
    // times its film point; the box filter keeps each pixel's samples on its own area.
    const double tanHalf = std::tan(M_PI / 6.0);
    const int n = 400;
    double expected = 0.0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double x = tanHalf * (-1 + (i + 0.5) * 2.0 / n);
            const double y = tanHalf * (-1 + (j + 0.5) * 2.0 / n);
            const double d2 = h * h + cameraHeight * cameraHeight * (x * x + y * y);
            expected += rho * radiance * radius * radius * h / (d2 * std::sqrt(d2));
        }
    expected /= double(n) * n;
    for (const std::string method : kMethods) {
        CAPTURE(method);
        const MethodMean m =
            methodMean(scene, runtime, methodSettings(method), 6, method == "mlt" ? 32 : 8);
        CAPTURE(m.mean);
        CAPTURE(m.se);
        CAPTURE(expected);
        CHECK(std::fabs(m.mean - expected) <= 4.5 * m.se + 2e-3 * expected);
        CHECK(m.nonFinite == 0);
    }
}

// Every strategy, with shadows and interreflection: a quad light between the camera and the
// scene, facing the scene, invisible (the camera and every bounce look through it); BDPT, CBDPT
// and MLT against PT per region.
TEST_CASE("invisible area lights: BDPT, CBDPT and MLT agree with PT under a quad light the "
          "camera looks through" *
          doctest::test_suite("statistical")) {
    checkMethodsAgreeWithPt("AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [3 3 3]\n"
                            "Shape \"bilinearmesh\" \"point3 P\" [-1 1 -2  1 1 -2  -1 2.5 -2  1 "
                            "2.5 -2] \"float alpha\" 0\nAttributeEnd\n");
}
