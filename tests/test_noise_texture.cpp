// pbrt-v4's procedural float textures "fbm", "wrinkled" and "windy" (kernels/cb_noise.h): the
// noise and its sums against values pbrt-v4 computes, the texture as the kernels look it up, and
// a bump-mapped plane rendered against the bump formula evaluated here.
#include <doctest/doctest.h>

#include "cb_camera.h"
#include "cb_texture.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene_files.h"
#include "test_render_util.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

// pbrt-v4 (5f7a6068, float build): Noise(p), FBm(p, 0, 0, 0.5, 8), Turbulence(p, 0, 0, 0.6, 6)
// and WindyTexture's |FBm(p / 10, .., 0.5, 3)| FBm(p, .., 0.5, 6), from a program linked
// against its library (zero differentials: every octave, as under disabletexturefiltering).
struct NoiseReference {
    float x, y, z;
    double noise, fbm, turbulence, windy;
};
const NoiseReference kPbrtNoise[] = {
    {0.5f, 0.5f, 0.5f, -0.125, -0.11803776, 0.245233387, -0.0308829248},
    {1.25f, -2.75f, 3.5f, 0.12009716, 0.361962408, 0.489161432, 0.204132572},
    {-7.3f, 0.1f, 4.9f, -0.23933965, -0.191919044, 0.504132628, -0.0743217617},
    {10.6f, 20.2f, -3.3f, -0.187907651, 0.0678610206, 0.586305082, 0.0142885149},
    {0.01f, 0.99f, 0.37f, 0.165544003, 0.0423425511, 0.499524057, 0.00104460877},
    {-123.456f, 78.9f, 0.25f, 0.175466865, 0.111326784, 0.500415266, 0.0287292227},
};

std::string camera(int size) {
    return "LookAt 0 3 0  0 0 0  0 0 1\nCamera \"perspective\" \"float fov\" 30\n"
           "Film \"rgb\" \"integer xresolution\" " +
           std::to_string(size) + " \"integer yresolution\" " + std::to_string(size) +
           "\nPixelFilter \"box\"\nWorldBegin\n"
           "LightSource \"distant\" \"point3 from\" [0 1 0] \"point3 to\" [0 0 0]\n";
}

// A grey plane y = 0, bump-mapped by `texture` (a Texture line, its CTM `transform`) or flat.
std::string planeScene(int size, const std::string& transform, const std::string& texture) {
    const std::string bump = texture.empty() ? "" : " \"texture displacement\" \"h\"";
    return camera(size) + "AttributeBegin\n" + transform + texture + "AttributeEnd\n" +
           "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]" + bump +
           "\nShape \"bilinearmesh\" \"point3 P\" [-2 0 -2  2 0 -2  -2 0 2  2 0 2] "
           "\"point2 uv\" [0 0  1 0  0 1  1 1]\n";
}

} // namespace

TEST_CASE("noise textures: Perlin's noise and its sums are pbrt-v4's") {
    for (const NoiseReference& r : kPbrtNoise) {
        CAPTURE(r.x);
        CAPTURE(r.y);
        CAPTURE(r.z);
        const cbk::Vec3 p = cbk::vec3(r.x, r.y, r.z);
        CHECK(std::fabs(cbk::perlinNoise(p) - r.noise) < 2e-5);
        CHECK(std::fabs(cbk::noiseFbm(p, 0.5f, 8) - r.fbm) < 2e-5);
        CHECK(std::fabs(cbk::noiseTurbulence(p, 0.6f, 6) - r.turbulence) < 2e-5);
        CHECK(std::fabs(cbk::noiseWindy(p) - r.windy) < 2e-5);
    }
    // Zero at every lattice point, whatever the gradients there.
    for (int i = -3; i <= 3; ++i)
        CHECK(cbk::perlinNoise(cbk::vec3(float(i), float(2 * i), float(-5 * i))) == 0.0f);
}

TEST_CASE("noise textures: parsed, placed by the CTM, refused where they cannot go") {
    TempDirCleanup cleanup;
    const std::string transform = "Translate 1 0.5 -2\nScale 0.5 0.5 0.5\n";
    for (const auto& [line, kind] :
         {std::pair{std::string("Texture \"h\" \"float\" \"wrinkled\" \"integer octaves\" 6 "
                                "\"float roughness\" 0.6\n"),
                    0},
          std::pair{std::string("Texture \"h\" \"float\" \"fbm\"\n"), 1},
          std::pair{std::string("Texture \"h\" \"float\" \"windy\"\n"), 2}}) {
        CAPTURE(line);
        const cb::DeviceScene scene =
            cb::buildDeviceScene(parseInTemp(planeScene(8, transform, line)), cb::ChannelMode::Rgb);
        CHECK((scene.features & CB_FEATURE_NOISE_TEXTURE) != 0);
        CHECK((scene.features & CB_FEATURE_TEXTURE_MAPPING) != 0);
        const cbk::SceneView view = cbtest::hostView(scene);
        const int offset = scene.materials[0].displacement;
        REQUIRE(offset >= 0);
        for (const auto& world :
             {std::array<double, 3>{0.3, 0.0, 0.7}, std::array<double, 3>{-1.2, 0.0, 1.9}}) {
            cbk::TexCoord uv{};
            uv.p = cbk::vec3(float(world[0] - scene.origin[0]), float(world[1] - scene.origin[1]),
                             float(world[2] - scene.origin[2]));
            // Texture space: the inverse of the CTM at the Texture line.
            const cbk::Vec3 q =
                cbk::vec3(float((world[0] - 1.0) / 0.5), float((world[1] - 0.5) / 0.5),
                          float((world[2] + 2.0) / 0.5));
            const double expected = kind == 0   ? cbk::noiseTurbulence(q, 0.6f, 6)
                                    : kind == 1 ? cbk::noiseFbm(q, 0.5f, 8)
                                                : cbk::noiseWindy(q);
            CHECK(cbk::textureFloat(&view, offset, uv) == doctest::Approx(expected).epsilon(1e-4));
        }
    }
    // Every octave is pbrt-v4's image only with its texture filtering off: a note says so.
    const cb::SceneDesc unfiltered =
        parseInTemp(planeScene(8, "", "Texture \"h\" \"float\" \"fbm\"\n"));
    CHECK(std::any_of(unfiltered.notes.begin(), unfiltered.notes.end(), [](const std::string& n) {
        return n.find("drops the octaves") != std::string::npos;
    }));
    const cb::SceneDesc filtered =
        parseInTemp("Option \"disabletexturefiltering\" true\n" +
                    planeScene(8, "", "Texture \"h\" \"float\" \"fbm\"\n"));
    CHECK(std::none_of(filtered.notes.begin(), filtered.notes.end(), [](const std::string& n) {
        return n.find("drops the octaves") != std::string::npos;
    }));
    // Folded textures need texels, the alpha test a (u, v) mapping: both refused, by name.
    const std::string scaled =
        camera(8) + "Texture \"n\" \"float\" \"fbm\"\n" +
        "Texture \"s\" \"float\" \"scale\" \"texture tex\" \"n\" \"float scale\" 2\n"
        "Material \"diffuse\" \"texture displacement\" \"s\"\nShape \"sphere\"\n";
    CHECK(errorOf(scaled).find("names the procedural \"n\"") != std::string::npos);
    CHECK(deviceErrorOf(planeScene(8, "", "Texture \"h\" \"float\" \"fbm\"\n") +
                        "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 0 1] "
                        "\"integer indices\" [0 1 2] \"texture alpha\" \"h\"\n")
              .find("alpha") != std::string::npos);
    CHECK(errorOf(planeScene(8, "", "Texture \"h\" \"float\" \"fbm\" \"integer octaves\" 40\n"))
              .find("\"integer octaves\" 40 must be in [0, 32]") != std::string::npos);
    CHECK(errorOf(planeScene(8, "", "Texture \"h\" \"float\" \"wrinkled\" \"float roughness\" 2\n"))
              .find("\"float roughness\" 2") != std::string::npos);
}

// Seen and lit straight from above, the plane's radiance is K (n_s . l), K the flat plane's
// and n_s pbrt-v4's bumped normal: with dp/du = (4, 0, 0), dp/dv = (0, 0, 4) and the slopes
// s_u, s_v of the displacement over (u, v) steps of 0.0005, n_s . l = 1 / sqrt(1 + (s_u^2 +
// s_v^2) / 16), whichever way the patch faces, where the viewer is on the same side of n_s as the
// light. Each block's mean against that formula averaged over the block's film.
TEST_CASE("noise textures: a bump-mapped plane against the bump formula, PT, CPT and BDPT" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const int size = 16;
    const std::string transform = "Scale 2 2 2\n";
    const std::string texture = "Texture \"h\" \"float\" \"fbm\" \"integer octaves\" 4\n";
    const cb::DeviceScene flat =
        cb::buildDeviceScene(parseInTemp(planeScene(size, "", "")), cb::ChannelMode::Rgb);
    const cb::DeviceScene bumped = cb::buildDeviceScene(
        parseInTemp(planeScene(size, transform, texture)), cb::ChannelMode::Rgb);
    cb::IntegratorSettings pt = methodSettings("pt");
    pt.maxPathVertices = 3;
    const double k = methodMean(flat, runtime, pt, 2, 1).mean;
    REQUIRE(k > 0.0);

    // The formula over a 16 x 16 grid of film positions in each pixel, the pixels in 4 x 4 blocks.
    const int blocks = 4, per = size / blocks, sub = 16;
    std::array<double, blocks * blocks> expected{};
    auto height = [](double x, double z) {
        return double(cbk::noiseFbm(cbk::vec3(float(x / 2), 0.0f, float(z / 2)), 0.5f, 4));
    };
    for (int py = 0; py < size; ++py)
        for (int px = 0; px < size; ++px)
            for (int j = 0; j < sub; ++j)
                for (int i = 0; i < sub; ++i) {
                    const cbk::Ray ray = cbk::cameraGenerateRay(
                        &bumped.camera, float(px + (i + 0.5) / sub), float(py + (j + 0.5) / sub),
                        cbk::vec3(0.f, 0.f, 0.f));
                    // The plane y = 0 in device coordinates (world minus the origin).
                    const double t = (-bumped.origin[1] - ray.o.y) / ray.d.y;
                    const double x = ray.o.x + t * ray.d.x + bumped.origin[0];
                    const double z = ray.o.z + t * ray.d.z + bumped.origin[2];
                    const double h = height(x, z), step = 0.0005;
                    const double su = (height(x + 4 * step, z) - h) / step;
                    const double sv = (height(x, z + 4 * step) - h) / step;
                    // n_s up to its sign; a diffuse surface reflects only where the viewer is on
                    // the light's side of it (pbrt-v4's SameHemisphere in the shading frame).
                    const double nx = 4 * su, ny = 16, nz = 4 * sv;
                    const double length = std::sqrt(nx * nx + ny * ny + nz * nz);
                    const double towardViewer = -(nx * ray.d.x + ny * ray.d.y + nz * ray.d.z);
                    const double value = towardViewer > 0 ? k * ny / length : 0.0;
                    expected[size_t((py / per) * blocks + px / per)] +=
                        value / (per * per * sub * sub);
                }
    double lowest = 1.0; // the formula must vary: the bumps are in the image
    for (double e : expected)
        lowest = std::min(lowest, e / k);
    CHECK(lowest < 0.97);
    for (const std::string method : {"pt", "cpt", "bdpt"}) {
        CAPTURE(method);
        cb::IntegratorSettings settings = methodSettings(method);
        settings.maxPathVertices = 3;
        const BinnedMeans b = binnedMeans(bumped, runtime, settings, 6, 16, 500u,
                                          size_t(blocks * blocks), [&](int x, int y, int c) {
                                              return c == 1 ? size_t((y / per) * blocks + x / per)
                                                            : size_t(blocks * blocks);
                                          });
        checkBinMeans(b, expected, 2e-3);
    }
}
