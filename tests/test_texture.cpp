// pbrt-v4's image textures (Texture "name" "spectrum" "imagemap") as diffuse and coated diffuse
// reflectance: the directive and its refusals, the texture coordinates of hit points, the
// lookups (kernels/cb_texture.h), and every method's image of textured surfaces
// (docs/pbrt-v4.md).
#include <doctest/doctest.h>

#include "cb_bsdf.h"
#include "cb_bvh_wide.h"
#include "cb_camera.h"
#include "cb_texture.h"
#include "method_checks.h"
#include "scene_files.h"
#include "spectral/spectral.h"
#include "test_render_util.h"

#include <fmt/format.h>
#include <qoi.h>
#include <stb_image_write.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <tuple>
#include <vector>

using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

// A 2 x 2 texture whose texels differ in every channel; (x, y) from the top left.
float texel(int x, int y, int c) {
    return 0.1f * float(1 + x + 2 * y) + 0.25f * float(c);
}
cbk::Vec3 texelRgb(int x, int y) {
    return cbk::vec3(texel(x, y, 0), texel(x, y, 1), texel(x, y, 2));
}

// A scene the device builder accepts, with `body` after WorldBegin.
cb::SceneDesc sceneDesc(const std::string& body) {
    return parseInTemp("Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\n"
                       "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n" +
                       body);
}
cb::DeviceScene deviceScene(const std::string& body) {
    return cb::buildDeviceScene(sceneDesc(body));
}

// A small triangle of the current material, at height z (each material must be used to be
// uploaded).
std::string triangleAt(int z) {
    return fmt::format("Shape \"trianglemesh\" \"point3 P\" [0 0 {0} 1 0 {0} 0 1 {0}]\n", z);
}

void checkRgb(cbk::Vec3 got, cbk::Vec3 expected) {
    CHECK(got.x == doctest::Approx(expected.x).epsilon(1e-6));
    CHECK(got.y == doctest::Approx(expected.y).epsilon(1e-6));
    CHECK(got.z == doctest::Approx(expected.z).epsilon(1e-6));
}

// pbrt-v4's sphere (u, v) of an object-space point.
std::array<double, 2> sphereUv(double x, double y, double z) {
    double phi = std::atan2(y, x);
    if (phi < 0.0) phi += 2.0 * M_PI;
    return {phi / (2.0 * M_PI), 1.0 - std::acos(z / std::sqrt(x * x + y * y + z * z)) / M_PI};
}

cbk::TexCoord uvOf(float u, float v) {
    return cbk::TexCoord{u, v, -1.0f};
}

} // namespace

TEST_CASE("image textures: the Texture directive, its parameters and what is refused") {
    TempDirCleanup cleanup;
    cb::writePng8((tempDir() / "grey.png").string(), 2, 1, {0, 128, 255, 10, 20, 30});
    auto s = parseInTemp(
        "WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"grey.png\" "
        "\"float scale\" 0.5 \"bool invert\" true \"string wrap\" \"clamp\" \"string filter\" "
        "\"point\" \"float uscale\" 2 \"float vdelta\" 0.5 \"float maxanisotropy\" 4\n"
        "Material \"diffuse\" \"texture reflectance\" \"t\"\n" +
        triangleAt(0));
    REQUIRE(s.textures.size() == 1);
    const cb::TextureDesc& t = s.textures[0];
    CHECK(t.width == 2);
    CHECK(t.height == 1);
    CHECK(t.wrap == cb::TextureDesc::Wrap::Clamp);
    CHECK(t.nearest);
    CHECK(t.mapping == std::array<float, 4>{2.f, 1.f, 0.f, 0.5f});
    REQUIRE(t.rgb.size() == 6);
    // 8-bit sRGB decoded, then 1 - scale v.
    CHECK(t.rgb[0] == doctest::Approx(1.0).epsilon(1e-6));
    CHECK(t.rgb[1] == doctest::Approx(1.0 - 0.5 * 0.2158605).epsilon(1e-5));
    CHECK(t.rgb[2] == doctest::Approx(0.5).epsilon(1e-6));
    CHECK(std::count(s.sourceFiles.begin(), s.sourceFiles.end(), t.path) == 1);
    REQUIRE(s.meshes.size() == 1);
    CHECK(s.materials[size_t(s.meshes[0].material)].reflectanceTexture == 0);
    // Without Option "disabletexturefiltering" true, a note says pbrt-v4 filters differently.
    auto hasNote = [](const cb::SceneDesc& d) {
        return std::any_of(d.notes.begin(), d.notes.end(),
                           [](const std::string& n) { return contains(n, "MIP maps"); });
    };
    CHECK(hasNote(s));
    const std::string plain = "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                              "\"grey.png\"\n";
    CHECK_FALSE(
        hasNote(parseInTemp("Option \"disabletexturefiltering\" true\nWorldBegin\n" + plain)));

    // "encoding": linear and gamma decode the bytes as pbrt-v4 does.
    s = parseInTemp("WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                    "\"grey.png\" \"string encoding\" \"linear\"\n");
    CHECK(s.textures[0].rgb[1] == doctest::Approx(128.0 / 255.0).epsilon(1e-6));
    s = parseInTemp("WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string filename\" "
                    "\"grey.png\" \"string encoding\" \"gamma 2.2\"\n");
    CHECK(s.textures[0].rgb[1] == doctest::Approx(std::pow(128.0 / 255.0, 2.2)).epsilon(1e-5));

    // The formats pbrt-v4 reads through stb_image: 8-bit from sRGB whatever the "encoding" (as
    // pbrt-v4), and Radiance HDR's linear floats (exact here: one exponent, whole mantissas).
    const unsigned char bmp[] = {0, 128, 255, 10, 20, 30};
    REQUIRE(stbi_write_bmp((tempDir() / "b.bmp").string().c_str(), 2, 1, 3, bmp) != 0);
    const float hdr[] = {0.5f, 2.f, 8.f, 1.f, 4.f, 0.25f};
    REQUIRE(stbi_write_hdr((tempDir() / "h.hdr").string().c_str(), 2, 1, 3, hdr) != 0);
    s = parseInTemp("WorldBegin\nTexture \"b\" \"spectrum\" \"imagemap\" \"string filename\" "
                    "\"b.bmp\" \"string encoding\" \"linear\"\nTexture \"h\" \"spectrum\" "
                    "\"imagemap\" \"string filename\" \"h.hdr\"\n");
    REQUIRE(s.textures.size() == 2);
    REQUIRE(s.textures[0].rgb.size() == 6);
    CHECK(s.textures[0].rgb[1] == doctest::Approx(0.2158605).epsilon(1e-5));
    CHECK(s.textures[0].rgb[5] == doctest::Approx(std::pow((30 / 255.0 + 0.055) / 1.055, 2.4)));
    CHECK(s.textures[1].rgb == std::vector<float>(std::begin(hdr), std::end(hdr)));

    // Textures cbdpt cannot render are an error only where a material uses one.
    const std::string unsupportedTextures = "Texture \"c\" \"spectrum\" \"dots\" \"float uscale\" "
                                            "4\nTexture \"r\" \"float\" \"bilerp\" \"float v00\" "
                                            "0.3\n";
    CHECK_NOTHROW(parseInTemp("WorldBegin\n" + unsupportedTextures));
    const std::string usedDots = errorOf("WorldBegin\n" + unsupportedTextures +
                                         "Material \"diffuse\" \"texture reflectance\" \"c\"\n");
    CHECK(contains(usedDots, ":4:"));
    CHECK(contains(usedDots, "class \"dots\""));
    CHECK(contains(usedDots, ":2")); // where the texture was defined
    CHECK(contains(errorOf("WorldBegin\n" + unsupportedTextures +
                           "Material \"diffuse\" \"texture reflectance\" \"r\"\n"),
                   "a float texture \"r\""));
    CHECK(contains(errorOf("WorldBegin\nMaterial \"coateddiffuse\" \"texture reflectance\" "
                           "\"nothing\"\n"),
                   "no texture \"nothing\""));
    CHECK(contains(errorOf("WorldBegin\n" + plain + plain), "redefined"));
    // As in pbrt-v4, which creates materials once the file is read, a material may name a
    // texture defined after it.
    s = parseInTemp("WorldBegin\nMakeNamedMaterial \"m\" \"string type\" \"diffuse\" "
                    "\"texture reflectance\" \"t\"\n" +
                    plain + "NamedMaterial \"m\"\n" + triangleAt(0));
    CHECK(s.materials[size_t(s.meshes[0].material)].reflectanceTexture == 0);
    CHECK(contains(
        errorOf("WorldBegin\n" + plain + "Material \"conductor\" \"texture reflectance\" \"t\"\n"),
        "diffusetransmission and coatedconductor materials"));
    const std::string missing = errorOf("WorldBegin\n\nTexture \"t\" \"spectrum\" \"imagemap\" "
                                        "\"string filename\" \"none.png\"\n");
    CHECK(contains(missing, ":3:"));
    CHECK(contains(missing, "no image file \"none.png\""));
    CHECK(contains(errorOf("WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\"\n"),
                   "needs \"string filename\""));
    CHECK(contains(errorOf("WorldBegin\nTexture \"t\" \"color\" \"imagemap\"\n"),
                   "must be \"spectrum\" or \"float\""));
    for (const auto& [param, message] :
         {std::pair{"\"string wrap\" \"octahedralsphere\"", "\"string wrap\" must be"},
          std::pair{"\"string mapping\" \"cubic\"", "must be \"uv\", \"spherical\""},
          std::pair{"\"string filter\" \"gaussian\"", "\"string filter\" must be"},
          std::pair{"\"string encoding\" \"gamma -1\"", "\"string encoding\" must be"},
          std::pair{"\"float udelta\" [1 2]", "exactly 1 value"}}) {
        CAPTURE(param);
        CHECK(contains(errorOf("WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string "
                               "filename\" \"grey.png\" " +
                               std::string(param) + "\n"),
                       message));
    }
    writeImage("nan.exr", 2, 2, [](int x, int y, int) { return x == 1 && y == 1 ? NAN : 0.5f; });
    const std::string nan = errorOf("WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" "
                                    "\"string filename\" \"nan.exr\"\n");
    CHECK(contains(nan, "pixel (1, 1)"));
    CHECK(contains(nan, "finite"));

    // "point2 uv" needs one (u, v) per vertex.
    CHECK(contains(errorOf("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] "
                           "\"point2 uv\" [0 0 1 0]\n"),
                   "one (u, v) per vertex (3), got 2"));
    // A textured material where cbdpt has no texture coordinates is refused when the scene is
    // built, naming the shape.
    const std::string textured = plain + "Material \"diffuse\" \"texture reflectance\" \"t\"\n";
    for (const auto& [shape, message] :
         {std::pair{"Shape \"disk\"", "a disk"},
          std::pair{"Shape \"bilinearmesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 2 2 0]",
                    "not a parallelogram"}}) {
        CAPTURE(shape);
        try {
            deviceScene(textured + shape + "\n");
            FAIL("a textured " << shape << " was accepted");
        } catch (const cb::SceneError& e) {
            CHECK(contains(e.what(), "a texture mapped by (u, v) (its reflectance"));
            CHECK(contains(e.what(), "needs texture coordinates"));
            CHECK(contains(e.what(), message));
        }
        // Untextured, or with a texture mapped by the hit point, the same shape renders.
        CHECK_NOTHROW(deviceScene(std::string(shape) + "\n"));
        const cb::DeviceScene planar =
            deviceScene("Texture \"p\" \"spectrum\" \"imagemap\" \"string filename\" "
                        "\"grey.png\" \"string mapping\" \"planar\"\nMaterial \"diffuse\" "
                        "\"texture reflectance\" \"p\"\n" +
                        std::string(shape) + "\n");
        CHECK((planar.features & CB_FEATURE_TEXTURE_MAPPING) != 0);
    }
}

// The lookup of cb_texture.h on a 2 x 2 texture: pbrt-v4's t = 1 - v (v = 1 is the top row),
// texel centres at (i + 1/2) / size, and each wrap mode, filter and mapping.
// A PFM file: its header, then `floats` as the file's bytes, each swapped where `bigEndian`.
void writePfm(const std::string& name, const std::string& header, std::vector<float> floats,
              bool bigEndian) {
    std::ofstream out(tempDir() / name, std::ios::binary);
    out << header;
    for (float f : floats) {
        unsigned char bytes[4];
        std::memcpy(bytes, &f, 4);
        if (bigEndian) std::reverse(bytes, bytes + 4);
        out.write(reinterpret_cast<const char*>(bytes), 4);
    }
}

TEST_CASE("image textures: PFM files as pbrt-v4 reads them") {
    TempDirCleanup cleanup;
    // RGB, little endian (scale -2: the values times 2), rows from the bottom.
    writePfm("rgb.pfm", "PF\n2 2\n-2\n",
             {1, 2, 3, 4, 5, 6, /* bottom row */ 0.5f, 0.25f, 0.125f, 7, 8, 9}, false);
    // Grey, big endian, scale 1.
    writePfm("grey.pfm", "Pf\n1 2\n1.0\n", {0.75f, 0.5f}, true);
    writePfm("short.pfm", "PF\n2 2\n-1\n", {1, 2, 3}, false);
    const cb::SceneDesc s = parseInTemp(
        "WorldBegin\nTexture \"a\" \"spectrum\" \"imagemap\" \"string filename\" \"rgb.pfm\"\n"
        "Texture \"b\" \"spectrum\" \"imagemap\" \"string filename\" \"grey.pfm\"\n");
    REQUIRE(s.textures.size() == 2);
    CHECK(s.textures[0].width == 2);
    CHECK(s.textures[0].height == 2);
    CHECK(s.textures[0].rgb ==
          std::vector<float>{1, 0.5f, 0.25f, 14, 16, 18, 2, 4, 6, 8, 10, 12}); // top row first
    CHECK(s.textures[1].rgb == std::vector<float>{0.5f, 0.5f, 0.5f, 0.75f, 0.75f, 0.75f});
    CHECK(contains(errorOf("WorldBegin\nTexture \"a\" \"spectrum\" \"imagemap\" \"string "
                           "filename\" \"short.pfm\"\n"),
                   "ends before its 2 x 2 pixels"));
}

// A QOI file of w x h pixels, `channels` bytes each, in the colour space `colorspace`.
void writeQoi(const std::string& name, unsigned w, unsigned h, unsigned char channels,
              unsigned char colorspace, const std::vector<unsigned char>& pixels) {
    const qoi_desc desc{w, h, channels, colorspace};
    REQUIRE(qoi_write((tempDir() / name).string().c_str(), pixels.data(), &desc) > 0);
}

TEST_CASE("image textures: QOI files as pbrt-v4 reads them") {
    TempDirCleanup cleanup;
    auto fromSrgb = [](int byte) { return float(srgbByte(byte)); };
    // sRGB RGBA, 2 x 1; linear RGB, 1 x 1.
    writeQoi("rgba.qoi", 2, 1, 4, QOI_SRGB, {255, 128, 0, 128, 0, 64, 255, 255});
    writeQoi("linear.qoi", 1, 1, 3, QOI_LINEAR, {51, 102, 204});
    std::ofstream(tempDir() / "short.qoi") << "qoif";
    // The file's colour space decides, whatever the texture's "encoding" (pbrt-v4's ReadQOI);
    // an RGBA file's float lookups read its alpha, decoded alike.
    const cb::SceneDesc s = parseInTemp(
        "WorldBegin\nTexture \"a\" \"spectrum\" \"imagemap\" \"string filename\" \"rgba.qoi\" "
        "\"string encoding\" \"linear\"\n"
        "Texture \"b\" \"spectrum\" \"imagemap\" \"string filename\" \"linear.qoi\"\n"
        "Texture \"f\" \"float\" \"imagemap\" \"string filename\" \"rgba.qoi\"\n");
    REQUIRE(s.textures.size() == 3);
    CHECK(s.textures[0].width == 2);
    CHECK(s.textures[0].height == 1);
    const std::vector<float> rgba{1.f, fromSrgb(128), 0.f, 0.f, fromSrgb(64), 1.f};
    for (size_t i = 0; i < rgba.size(); ++i)
        CHECK(s.textures[0].rgb[i] == doctest::Approx(rgba[i]).epsilon(1e-6));
    CHECK(s.textures[1].rgb[0] == doctest::Approx(0.2f));
    CHECK(s.textures[1].rgb[1] == doctest::Approx(0.4f));
    CHECK(s.textures[1].rgb[2] == doctest::Approx(0.8f));
    CHECK(s.textures[2].rgb[0] == doctest::Approx(fromSrgb(128)).epsilon(1e-6));
    CHECK(s.textures[2].rgb[3] == doctest::Approx(1.f));
    CHECK(contains(errorOf("WorldBegin\nTexture \"a\" \"spectrum\" \"imagemap\" \"string "
                           "filename\" \"short.qoi\"\n"),
                   "not a QOI file, or it ends before its pixels"));
}

TEST_CASE("image textures: bilinear and nearest lookups, wrap modes, mapping, clamping") {
    TempDirCleanup cleanup;
    writeImage("two.exr", 2, 2, texel);
    const char* const textures[] = {"\"string wrap\" \"repeat\"",
                                    "\"string wrap\" \"clamp\"",
                                    "\"string wrap\" \"black\"",
                                    "\"string filter\" \"point\"",
                                    "\"float uscale\" 2 \"float udelta\" 0.25",
                                    "\"float scale\" 4",
                                    "\"float scale\" 4 \"bool invert\" true"};
    std::string body;
    for (size_t i = 0; i < std::size(textures); ++i)
        body += fmt::format("Texture \"t{0}\" \"spectrum\" \"imagemap\" \"string filename\" "
                            "\"two.exr\" {1}\nMaterial \"diffuse\" \"texture reflectance\" "
                            "\"t{0}\"\n{2}",
                            i, textures[i], triangleAt(int(i)));
    const cb::SceneDesc desc = sceneDesc(body);
    const cb::DeviceScene scene = cb::buildDeviceScene(desc);
    CHECK((scene.features & CB_FEATURE_TEXTURE) != 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    std::vector<int> offset; // per texture, its offset in the scene's `textures`
    for (const cb::TriangleMeshDesc& mesh : desc.meshes) {
        offset.push_back(scene.materials[size_t(mesh.material)].reflectanceTexture);
        REQUIRE(offset.back() >= 0);
    }
    auto rgb = [&](size_t texture, float u, float v) {
        return cbk::textureRgb(&view, offset[texture], uvOf(u, v));
    };
    auto mix = [](cbk::Vec3 a, cbk::Vec3 b, float t) {
        return cbk::vadd(cbk::vscale(a, 1.f - t), cbk::vscale(b, t));
    };
    const cbk::Vec3 black = cbk::vec3(0.f, 0.f, 0.f);

    // Repeat, bilinear: texel centres, the middle, the edge between texels 1 and 0, a period on.
    checkRgb(rgb(0, 0.25f, 0.75f), texelRgb(0, 0)); // top left: v near 1 is the top row
    checkRgb(rgb(0, 0.75f, 0.25f), texelRgb(1, 1));
    checkRgb(rgb(0, 0.5f, 0.5f), mix(mix(texelRgb(0, 0), texelRgb(1, 0), 0.5f),
                                     mix(texelRgb(0, 1), texelRgb(1, 1), 0.5f), 0.5f));
    checkRgb(rgb(0, 0.f, 0.75f), mix(texelRgb(1, 0), texelRgb(0, 0), 0.5f));
    checkRgb(rgb(0, 1.25f, -0.25f), texelRgb(0, 0));
    checkRgb(rgb(0, 0.375f, 0.75f), mix(texelRgb(0, 0), texelRgb(1, 0), 0.25f));
    // Clamp: the edge texel beyond the image, however far.
    checkRgb(rgb(1, 0.f, 0.75f), texelRgb(0, 0));
    checkRgb(rgb(1, -5.f, 0.75f), texelRgb(0, 0));
    checkRgb(rgb(1, 5.f, -5.f), texelRgb(1, 1));
    // Black: nothing beyond the image; half of the edge texel at the edge.
    checkRgb(rgb(2, 0.f, 0.75f), cbk::vscale(texelRgb(0, 0), 0.5f));
    checkRgb(rgb(2, -5.f, 0.75f), black);
    checkRgb(rgb(2, 0.5f, 1e30f), black);
    // Point: the texel the coordinates fall in.
    checkRgb(rgb(3, 0.49f, 0.75f), texelRgb(0, 0));
    checkRgb(rgb(3, 0.51f, 0.75f), texelRgb(1, 0));
    checkRgb(rgb(3, 0.75f, 0.01f), texelRgb(1, 1));
    checkRgb(rgb(3, -0.25f, 0.99f), texelRgb(1, 0)); // repeat
    // Mapping: s = 2 u + 0.25.
    checkRgb(rgb(4, 0.f, 0.75f), texelRgb(0, 0));
    checkRgb(rgb(4, 0.25f, 0.75f), texelRgb(1, 0));
    // Scale, invert, and the reflectance's clamp to [0, 1].
    checkRgb(rgb(5, 0.25f, 0.75f), cbk::vscale(texelRgb(0, 0), 4.f));
    checkRgb(rgb(6, 0.25f, 0.75f),
             cbk::vsub(cbk::vec3(1.f, 1.f, 1.f), cbk::vscale(texelRgb(0, 0), 4.f)));
    const cbk::Spectrum scaled = cbk::textureReflectance(&view, offset[5], uvOf(0.75f, 0.25f));
    const cbk::Spectrum inverted = cbk::textureReflectance(&view, offset[6], uvOf(0.75f, 0.25f));
    for (int c = 0; c < 3; ++c) {
        CHECK(scaled.c[c] == doctest::Approx(std::min(1.f, 4.f * texel(1, 1, c))));
        CHECK(inverted.c[c] == doctest::Approx(std::max(0.f, 1.f - 4.f * texel(1, 1, c))));
    }
    // Coordinates that are not finite, or huge, give a finite value (no texel outside the image
    // is read: the sanitizer builds would see it).
    checkRgb(rgb(0, NAN, 0.5f), black);
    checkRgb(rgb(0, INFINITY, 0.5f), black);
    for (size_t t = 0; t < std::size(textures); ++t)
        for (float big : {1e30f, -1e30f, 3e9f, -7.5e6f}) {
            const cbk::Vec3 c = rgb(t, big, -big);
            CHECK(std::isfinite(c.x + c.y + c.z));
        }
}

// pbrt-v4's diffusetransmission with textured reflectance and transmittance: each texture's
// value at the hit, clamped to [0, 1], times "scale", clamped again; the lobe chosen by the
// largest channels there (DiffuseTransmissionBxDF).
TEST_CASE("image textures: diffusetransmission's reflectance and transmittance") {
    TempDirCleanup cleanup;
    writeImage("two.exr", 2, 2, texel);
    const std::string textures =
        "Texture \"r\" \"spectrum\" \"imagemap\" \"string filename\" \"two.exr\"\n"
        "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"two.exr\" \"bool invert\" "
        "true\n";
    const cb::SceneDesc desc =
        sceneDesc(textures +
                  "Material \"diffusetransmission\" \"texture reflectance\" \"r\" "
                  "\"texture transmittance\" \"t\" \"float scale\" 1.4\n" +
                  triangleAt(0));
    REQUIRE(desc.materials.size() == 1);
    CHECK(desc.materials[0].reflectanceTexture == 0);
    CHECK(desc.materials[0].transmittanceTexture == 1);
    const cb::DeviceScene scene = cb::buildDeviceScene(desc);
    CHECK((scene.features & CB_FEATURE_TEXTURE) != 0);
    const cbk::Material& m = scene.materials[0];
    REQUIRE(m.kind == CB_MAT_DIFFUSE_TRANSMISSION);
    REQUIRE(m.reflectanceTexture >= 0);
    REQUIRE(m.transmittanceTexture >= 0);
    CHECK(m.textureScale == 1.4f);
    const cbk::SceneView view = cbtest::hostView(scene);

    const cbk::Vec3 wo = cbk::vnormalize(cbk::vec3(0.3f, -0.2f, 0.9f));
    const cbk::Vec3 up = cbk::vnormalize(cbk::vec3(-0.4f, 0.1f, 0.8f));
    const cbk::Vec3 down = cbk::vec3(up.x, up.y, -up.z);
    for (const auto& [x, y] : {std::pair{0, 0}, std::pair{1, 1}, std::pair{1, 0}}) {
        CAPTURE(x);
        CAPTURE(y);
        const cbk::TexCoord uv = uvOf(0.25f + 0.5f * float(x), 0.75f - 0.5f * float(y));
        std::array<double, 3> r{}, t{};
        for (int c = 0; c < 3; ++c) {
            r[size_t(c)] = std::min(1.0, 1.4 * double(texel(x, y, c)));
            t[size_t(c)] = std::min(1.0, 1.4 * (1.0 - double(texel(x, y, c))));
        }
        const double maxR = *std::max_element(r.begin(), r.end());
        const double maxT = *std::max_element(t.begin(), t.end());
        const double reflect = maxR / (maxR + maxT);
        float pdf = 0.f, pdfRev = 0.f;
        const cbk::Spectrum fr = cbk::cbLobeEval(&view, m, uv, wo, up, true, 0, &pdf, &pdfRev);
        CHECK(pdf == doctest::Approx(reflect * up.z / M_PI).epsilon(1e-5));
        CHECK(pdfRev == doctest::Approx(reflect * wo.z / M_PI).epsilon(1e-5));
        const cbk::Spectrum ft = cbk::cbLobeEval(&view, m, uv, wo, down, true, 0, &pdf, &pdfRev);
        CHECK(pdf == doctest::Approx((1.0 - reflect) * up.z / M_PI).epsilon(1e-5));
        for (int c = 0; c < 3; ++c) {
            CHECK(fr.c[c] == doctest::Approx(r[size_t(c)] / M_PI).epsilon(1e-5));
            CHECK(ft.c[c] == doctest::Approx(t[size_t(c)] / M_PI).epsilon(1e-5));
        }
        // The sample's lobe by uLobe against the same probability, its f the lobe's.
        for (const double uLobe : {reflect - 0.01, reflect + 0.01}) {
            cbk::BsdfSample s{};
            REQUIRE(cbk::cbLobeSample(&view, m, uv, wo, true, 0.3f, 0.6f, float(uLobe), 0, &s));
            const bool reflected = s.wi.z > 0.f;
            CHECK(reflected == (uLobe < reflect));
            CHECK(s.pdf ==
                  doctest::Approx((reflected ? reflect : 1.0 - reflect) * std::fabs(s.wi.z) / M_PI)
                      .epsilon(1e-5));
            CHECK(s.f.c[1] == doctest::Approx((reflected ? r : t)[1] / M_PI).epsilon(1e-5));
        }
    }

    // A texture defined after the material resolves once the file is read, as in pbrt-v4.
    const cb::SceneDesc later =
        sceneDesc("MakeNamedMaterial \"m\" \"string type\" \"diffusetransmission\" \"texture "
                  "transmittance\" \"t\"\n" +
                  textures + "NamedMaterial \"m\"\n" + triangleAt(0));
    CHECK(later.materials[0].transmittanceTexture == 1);
    CHECK(later.materials[0].reflectanceTexture == -1);
    const std::string floatTexture =
        errorOf("WorldBegin\nTexture \"f\" \"float\" \"constant\" \"float value\" 0.5\n"
                "Material \"diffusetransmission\" \"texture transmittance\" \"f\"\n");
    CHECK(contains(floatTexture, ":3:"));
    CHECK(contains(floatTexture, "\"texture transmittance\" names a float texture \"f\""));
    CHECK(contains(errorOf("WorldBegin\nMaterial \"diffusetransmission\" \"texture "
                           "transmittance\" \"none\"\n"),
                   "no texture \"none\""));
    try {
        deviceScene(textures + "Material \"diffusetransmission\" \"texture transmittance\" "
                               "\"t\"\nShape \"disk\"\n");
        FAIL("a disk of textured transmittance was accepted");
    } catch (const cb::SceneError& e) {
        CHECK(contains(e.what(), "needs texture coordinates"));
    }
}

// pbrt-v4's coatedconductor given a "texture reflectance": the texel's reflectance r, clamped to
// [0, 0.9999], is the conductor's eta 1 and k = 2 sqrt(r) / sqrt(1 - r), both divided by the
// coat's index (CoatedConductorMaterial::GetBxDF).
TEST_CASE("image textures: coatedconductor's reflectance") {
    TempDirCleanup cleanup;
    writeImage("two.exr", 2, 2, texel);
    const std::string texture =
        "Texture \"r\" \"spectrum\" \"imagemap\" \"string filename\" \"two.exr\" \"float scale\" "
        "1.2\n";
    const cb::SceneDesc desc = sceneDesc(texture +
                                         "Material \"coatedconductor\" \"texture reflectance\" "
                                         "\"r\" \"float interface.eta\" 1.33\n" +
                                         triangleAt(0));
    REQUIRE(desc.materials.size() == 1);
    CHECK(desc.materials[0].reflectanceTexture == 0);
    CHECK(!desc.materials[0].conductorEta);
    const cb::DeviceScene scene = cb::buildDeviceScene(desc);
    CHECK((scene.features & CB_FEATURE_TEXTURE) != 0);
    const cbk::Material& m = scene.materials[0];
    REQUIRE(m.kind == CB_MAT_COATED_CONDUCTOR);
    REQUIRE(m.reflectanceTexture >= 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    for (const auto& [x, y] : {std::pair{0, 0}, std::pair{1, 1}}) {
        CAPTURE(x);
        CAPTURE(y);
        const cbk::LayerBase base =
            cbk::layerBaseLoad(&view, m, uvOf(0.25f + 0.5f * float(x), 0.75f - 0.5f * float(y)));
        CHECK(base.conductor == 1);
        for (int c = 0; c < 3; ++c) {
            const double r = std::clamp(1.2 * double(texel(x, y, c)), 0.0, 0.9999);
            CHECK(base.a.c[c] == doctest::Approx(1.0 / 1.33).epsilon(1e-6));
            CHECK(base.b.c[c] ==
                  doctest::Approx(2.0 * std::sqrt(r) / std::sqrt(1.0 - r) / 1.33).epsilon(1e-4));
        }
    }
    const std::string both =
        errorOf("WorldBegin\n" + texture +
                "Material \"coatedconductor\" \"texture reflectance\" \"r\" \"rgb conductor.eta\" "
                "[1 1 1]\n");
    CHECK(contains(both, ":3:"));
    CHECK(contains(both, "not both"));
    // A plain conductor's reflectance is a constant tint in cbdpt, never a texture.
    CHECK(contains(errorOf("WorldBegin\n" + texture +
                           "Material \"conductor\" \"texture reflectance\" \"r\"\n"),
                   "not \"texture\""));
}

// pbrt-v4's "directionmix": |n . dir| tex1 + (1 - |n . dir|) tex2 at the hit's geometric normal
// n, dir taken by the CTM at the Texture directive; its parts images or constants, mixed per hit.
TEST_CASE("image textures: directionmix mixes two textures by the normal's direction") {
    TempDirCleanup cleanup;
    writeImage("two.exr", 2, 2, texel);
    const std::string textures =
        "Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"two.exr\"\n"
        "AttributeBegin\nRotate 90 0 0 1\nTexture \"dm\" \"spectrum\" \"directionmix\" "
        "\"vector3 dir\" [2 0 0] \"texture tex1\" \"img\" \"rgb tex2\" [0.2 0.4 0.6]\n"
        "AttributeEnd\nTexture \"plain\" \"spectrum\" \"directionmix\"\n";
    const cb::SceneDesc desc = sceneDesc(
        textures + "Material \"diffuse\" \"texture reflectance\" \"dm\"\n" + triangleAt(0) +
        "Material \"diffuse\" \"texture reflectance\" \"img\"\n" + triangleAt(1) +
        "Material \"coateddiffuse\" \"texture reflectance\" \"plain\"\n" + triangleAt(2));
    REQUIRE(desc.textures.size() == 3);
    const cb::TextureDesc& dm = desc.textures[1];
    REQUIRE(dm.mixParts.size() == 2);
    // (2, 0, 0) turned 90 degrees about z, normalised.
    CHECK(dm.mixDirection[0] == doctest::Approx(0.0).scale(1.0));
    CHECK(dm.mixDirection[1] == doctest::Approx(1.0));
    CHECK(dm.mixDirection[2] == doctest::Approx(0.0).scale(1.0));
    CHECK(dm.mixParts[0].rgb == desc.textures[0].rgb);
    CHECK(dm.mixParts[1].rgb == std::vector<float>{0.2f, 0.4f, 0.6f});
    // pbrt-v4's defaults: dir (0 1 0), tex1 0, tex2 1.
    const cb::TextureDesc& plain = desc.textures[2];
    REQUIRE(plain.mixParts.size() == 2);
    CHECK(plain.mixDirection == std::array<double, 3>{0, 1, 0});
    CHECK(plain.mixParts[0].rgb == std::vector<float>{0.f, 0.f, 0.f});
    CHECK(plain.mixParts[1].rgb == std::vector<float>{1.f, 1.f, 1.f});

    const cb::DeviceScene scene = cb::buildDeviceScene(desc);
    CHECK((scene.features & CB_FEATURE_DIRECTION_MIX) != 0);
    CHECK((deviceScene("Material \"diffuse\"\n" + triangleAt(0)).features &
           CB_FEATURE_DIRECTION_MIX) == 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    const int mixOffset = scene.materials[0].reflectanceTexture;
    const int imageOffset = scene.materials[1].reflectanceTexture;
    for (const auto& [nx, ny, nz] :
         {std::tuple{0.f, 1.f, 0.f}, std::tuple{0.f, -1.f, 0.f}, std::tuple{1.f, 0.f, 0.f},
          std::tuple{0.6f, -0.8f, 0.f}, std::tuple{0.f, 0.28f, 0.96f}}) {
        cbk::TexCoord uv = uvOf(0.25f, 0.75f);
        uv.n = cbk::vec3(nx, ny, nz);
        const double a = std::fabs(double(ny));
        CAPTURE(a);
        const cbk::Spectrum got = cbk::textureReflectance(&view, mixOffset, uv);
        const cbk::Spectrum image = cbk::textureReflectance(&view, imageOffset, uv);
        const double tex2[3] = {0.2, 0.4, 0.6};
        for (int c = 0; c < 3; ++c)
            CHECK(got.c[c] == doctest::Approx(a * image.c[c] + (1.0 - a) * tex2[c]).epsilon(1e-6));
    }

    // Refused: a directionmix inside another texture, a zero direction, a float directionmix.
    for (const auto& [definition, message] :
         {std::pair{"\"scale\" \"texture tex\" \"dm\"",
                    "names the \"directionmix\" \"dm\", which cbdpt evaluates as a material's "
                    "texture only"},
          std::pair{"\"directionmix\" \"texture tex2\" \"dm\"", "not inside another"},
          std::pair{"\"directionmix\" \"vector3 dir\" [0 0 0]", "must be a direction"}}) {
        CAPTURE(definition);
        const std::string error = errorOf(
            "WorldBegin\nTexture \"dm\" \"spectrum\" \"directionmix\"\nTexture \"x\" "
            "\"spectrum\" " +
            std::string(definition) + "\nMaterial \"diffuse\" \"texture reflectance\" \"x\"\n");
        CHECK(contains(error, message));
    }
    CHECK(contains(errorOf("WorldBegin\nTexture \"f\" \"float\" \"directionmix\"\nMaterial "
                           "\"conductor\" \"texture roughness\" \"f\"\n"),
                   "class \"directionmix\""));
}

// pbrt-v4's mappings by the hit point (TextureMapping2D): a point in texture space q (the inverse
// of the CTM at the Texture directive, here translate, rotate about z, scale), its (s, t) by
// direction, about z or along v1 and v2, the kernels' points camera-relative.
TEST_CASE("image textures: planar, spherical and cylindrical mappings") {
    TempDirCleanup cleanup;
    writeImage("two.exr", 2, 2, texel);
    const std::string ctm = "Translate 1 2 3\nRotate 30 0 0 1\nScale 2 2 2\n";
    const std::string definitions =
        "AttributeBegin\n" + ctm +
        "Texture \"p\" \"spectrum\" \"imagemap\" \"string filename\" \"two.exr\" \"string "
        "mapping\" \"planar\" \"vector3 v1\" [1 0.5 0] \"vector3 v2\" [0 -1 2] \"float udelta\" "
        "0.25 \"float vdelta\" -0.5\n"
        "Texture \"s\" \"spectrum\" \"imagemap\" \"string filename\" \"two.exr\" \"string "
        "mapping\" \"spherical\"\n"
        "Texture \"c\" \"float\" \"imagemap\" \"string filename\" \"two.exr\" \"string mapping\" "
        "\"cylindrical\"\nAttributeEnd\n";
    const cb::SceneDesc desc = parseInTemp(
        "LookAt 3 -2 1  0 0 0  0 0 1\nCamera \"perspective\"\nFilm \"rgb\" \"integer "
        "xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\nLightSource \"infinite\"\n" +
        definitions + "Material \"diffuse\" \"texture reflectance\" \"p\"\n" + triangleAt(0) +
        "Material \"coateddiffuse\" \"texture reflectance\" \"s\"\n" + triangleAt(1) +
        "Material \"conductor\" \"texture roughness\" \"c\"\n" + triangleAt(2));
    const cb::DeviceScene scene = cb::buildDeviceScene(desc);
    REQUIRE((scene.features & CB_FEATURE_TEXTURE_MAPPING) != 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    const int offsets[3] = {scene.materials[0].reflectanceTexture,
                            scene.materials[1].reflectanceTexture,
                            scene.materials[2].roughnessTexture};
    // q = S^-1 R^-1 (p - T), independently of the parser's matrix inverse.
    auto textureSpace = [](std::array<double, 3> p) {
        const double x = p[0] - 1, y = p[1] - 2, z = p[2] - 3;
        const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
        return std::array<double, 3>{(c * x + s * y) / 2, (-s * x + c * y) / 2, z / 2};
    };
    auto expected = [&](int kind, std::array<double, 3> p) {
        const std::array<double, 3> q = textureSpace(p);
        double s0 = 0, t0 = 0;
        if (kind == 0) {
            s0 = 0.25 + q[0] * 1 + q[1] * 0.5;
            t0 = -0.5 + q[1] * -1 + q[2] * 2;
        } else if (kind == 1) {
            const double r = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
            double phi = std::atan2(q[1], q[0]);
            if (phi < 0) phi += 2 * M_PI;
            s0 = std::acos(q[2] / r) / M_PI;
            t0 = phi / (2 * M_PI);
        } else {
            s0 = (M_PI + std::atan2(q[1], q[0])) / (2 * M_PI);
            t0 = q[2];
        }
        return std::array<double, 2>{s0, 1 - t0}; // the image texture flips t
    };
    for (int kind = 0; kind < 3; ++kind)
        for (const std::array<double, 3>& p :
             {std::array<double, 3>{0.3, -0.7, 1.1}, std::array<double, 3>{2.5, 1.5, 3.5},
              std::array<double, 3>{-1.2, 4.0, 2.2}}) {
            CAPTURE(kind);
            CAPTURE(p[0]);
            cbk::TexCoord uv = uvOf(0.9f, 0.1f); // (u, v) plays no part
            uv.p = cbk::vec3(float(p[0] - scene.origin[0]), float(p[1] - scene.origin[1]),
                             float(p[2] - scene.origin[2]));
            float s = 0.f, t = 0.f;
            cbk::textureST(view.textures + offsets[kind], uv, &s, &t);
            const std::array<double, 2> st = expected(kind, p);
            CHECK(s == doctest::Approx(st[0]).epsilon(1e-5));
            CHECK(t == doctest::Approx(st[1]).epsilon(1e-5));
        }
    // The device origin is not the world's, so its folding into the matrix was exercised.
    CHECK(std::abs(scene.origin[0]) + std::abs(scene.origin[1]) + std::abs(scene.origin[2]) > 0.5);

    CHECK(contains(errorOf("WorldBegin\nTexture \"t\" \"spectrum\" \"imagemap\" \"string "
                           "filename\" \"two.exr\" \"string mapping\" \"sphere\"\n"),
                   "must be \"uv\", \"spherical\", \"cylindrical\" or \"planar\", not \"sphere\""));
    // The alpha test has (u, v) only.
    try {
        deviceScene("Texture \"a\" \"float\" \"imagemap\" \"string filename\" \"two.exr\" "
                    "\"string mapping\" \"planar\"\nMaterial \"diffuse\"\nShape \"trianglemesh\" "
                    "\"point3 P\" [0 0 0 1 0 0 0 1 0] \"texture alpha\" \"a\"\n");
        FAIL("a planar alpha texture was accepted");
    } catch (const cb::SceneError& e) {
        CHECK(contains(e.what(), "mapped by the hit point"));
    }
    // A mix of two images needs one mapping.
    CHECK(contains(errorOf("WorldBegin\nTexture \"u\" \"spectrum\" \"imagemap\" \"string "
                           "filename\" \"two.exr\"\n" +
                           definitions +
                           "Texture \"m\" \"spectrum\" \"mix\" \"texture tex1\" \"u\" \"texture "
                           "tex2\" \"s\"\nMaterial \"diffuse\" \"texture reflectance\" \"m\"\n"),
                   "mappings"));
}

// A hit point's (u, v) is the triangle's corners' interpolated at its barycentrics, after the
// BVH has reordered the primitives and the parser has reordered mirrored triangles' corners.
TEST_CASE("image textures: texture coordinates at hit points") {
    TempDirCleanup cleanup;
    writeImage("two.exr", 2, 2, texel);
    // A 3 x 3 grid of quads in z = 0 with uv an affine function of the object position.
    std::string positions, uv, indices;
    for (int j = 0; j <= 3; ++j)
        for (int i = 0; i <= 3; ++i) {
            const double x = -1.0 + 2.0 * i / 3.0, y = -1.0 + 2.0 * j / 3.0;
            positions += fmt::format("{} {} 0  ", x, y);
            uv += fmt::format("{} {}  ", 0.5 * x + 0.1, 0.25 * y - 0.3);
        }
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) {
            const int a = 4 * j + i;
            indices += fmt::format("{} {} {}  {} {} {}  ", a, a + 1, a + 5, a, a + 5, a + 4);
        }
    // pbrt-v4's defaults: a triangle without "uv" is (0,0) (1,0) (1,1) at its corners, a
    // bilinear patch (0,0) (1,0) (0,1) (1,1) at p00 p10 p01 p11; a PLY's "u" and "v".
    {
        std::ofstream ply(tempDir() / "uv.ply");
        ply << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
               "property float z\nproperty float u\nproperty float v\nelement face 1\n"
               "property list uchar int vertex_indices\nend_header\n"
               "0 0 0 0.2 0.4\n1 0 0 0.6 0.4\n0 1 0 0.2 0.9\n3 0 1 2\n";
    }
    const std::string body =
        "Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"two.exr\"\n"
        "Material \"diffuse\" \"texture reflectance\" \"t\"\n"
        "AttributeBegin\nTranslate 0.2 0 0\nScale -1 1 1\nShape \"trianglemesh\" \"point3 P\" [" +
        positions + "] \"integer indices\" [" + indices + "] \"point2 uv\" [" + uv +
        "]\nAttributeEnd\n"
        "AttributeBegin\nTranslate 5 0 0\nScale -1 1 1\nShape \"trianglemesh\" \"point3 P\" "
        "[0 0 0 1 0 0 1 1 0]\nAttributeEnd\n"
        "AttributeBegin\nTranslate 10 0 0\nShape \"bilinearmesh\" \"point3 P\" "
        "[0 0 0 2 0 0 0 1 0 2 1 0]\nAttributeEnd\n"
        "AttributeBegin\nTranslate 15 0 0\nShape \"plymesh\" \"string filename\" \"uv.ply\"\n"
        "AttributeEnd\n"
        "ObjectBegin \"tri\"\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 1 1 0] "
        "\"point2 uv\" [0.1 0.2 0.5 0.2 0.5 0.7]\nObjectEnd\n"
        "AttributeBegin\nTranslate 20 0 0\nScale -1 1 1\nObjectInstance \"tri\"\nAttributeEnd\n"
        "AttributeBegin\nTranslate 30 0 0\nRotate 90 0 0 1\nScale -0.5 0.5 0.5\nShape \"sphere\"\n"
        "AttributeEnd\n"
        "ObjectBegin \"ball\"\nRotate 90 1 0 0\nShape \"sphere\" \"float radius\" 0.5\nObjectEnd\n"
        "AttributeBegin\nTranslate 35 0 0\nRotate 45 0 0 1\nObjectInstance "
        "\"ball\"\nAttributeEnd\n";
    const cb::DeviceScene scene = deviceScene(body);
    const cbk::SceneView view = cbtest::hostView(scene);
    REQUIRE(scene.textures.size() >= 6 * scene.bvh.primitives.size());
    // World point (X, Y) of each shape and the (u, v) expected there.
    struct Probe {
        double x0, x1, y0, y1;
        std::array<double, 2> (*uv)(double, double);
    };
    const Probe probes[] = {
        {-0.75, 1.15, -0.95, 0.95,
         [](double X, double Y) {
             return std::array{0.5 * (0.2 - X) + 0.1, 0.25 * Y - 0.3};
         }},
        // Mirrored: object x = 5 - X, and the triangle (0,0) (1,0) (1,1) has uv = (x, y).
        {4.05, 4.95, 0.01, 0.04,
         [](double X, double Y) {
             return std::array{5.0 - X, Y};
         }},
        {10.05, 11.95, 0.05, 0.95,
         [](double X, double Y) {
             return std::array{(X - 10) / 2, Y};
         }},
        {15.05, 15.45, 0.05, 0.45,
         [](double X, double Y) {
             return std::array{0.2 + 0.4 * (X - 15), 0.4 + 0.5 * Y};
         }},
        // An instance mirrored by its transform: object x = 20 - X.
        {19.05, 19.95, 0.01, 0.04,
         [](double X, double Y) {
             return std::array{0.1 + 0.4 * (20 - X), 0.2 + 0.5 * Y};
         }},
        // Spheres: pbrt-v4's (phi / 2 pi, 1 - theta / pi) in the object frame, seen from above.
        // Object = diag(-1, 1, 1) Rz(-90) (world - centre): (-dy, -dx, dz).
        {30.1, 30.3, -0.2, 0.2,
         [](double X, double Y) {
             const double dx = X - 30, dy = Y, dz = std::sqrt(0.25 - dx * dx - dy * dy);
             return sphereUv(-dy, -dx, dz);
         }},
        // Instanced: object = Rx(-90) Rz(-45) (world - centre).
        {35.1, 35.3, -0.2, 0.2,
         [](double X, double Y) {
             const double dx = X - 35, dy = Y, dz = std::sqrt(0.25 - dx * dx - dy * dy);
             const double a = (dx + dy) / std::sqrt(2.0), b = (dy - dx) / std::sqrt(2.0);
             return sphereUv(a, dz, -b);
         }},
    };
    std::mt19937 rng(3u);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    int hits = 0;
    for (const Probe& probe : probes)
        for (int i = 0; i < 200; ++i) {
            const double X = probe.x0 + (probe.x1 - probe.x0) * unit(rng);
            double Y = probe.y0 + (probe.y1 - probe.y0) * unit(rng);
            if (&probe == &probes[1]) Y = std::min(Y, 5.0 - X - 0.01); // inside the triangles
            if (&probe == &probes[4]) Y = std::min(Y, 20.0 - X - 0.01);
            const bool onSphere = &probe >= &probes[5];
            CAPTURE(onSphere);
            const auto found = cbtest::surfaceBelow(scene, view, X, Y, 1.0);
            REQUIRE(found);
            const cbk::SurfacePoint& sp = *found;
            const auto expected = probe.uv(X, Y);
            CAPTURE(X);
            CAPTURE(Y);
            CHECK(sp.uv.u == doctest::Approx(expected[0]).epsilon(1e-5).scale(1.0));
            CHECK(sp.uv.v == doctest::Approx(expected[1]).epsilon(1e-5).scale(1.0));
            ++hits;
        }
    CHECK(hits == 1400);
}

namespace {

// A plane under a uniform sky of radiance 1, seen from above: its radiance is its reflectance
// (irradiance pi, rho / pi per unit), here a texture of two texels, the left one on x < 0, seen
// through the nearest texel; the camera's third of columns on either side sees one texel only.
const std::array<std::array<float, 3>, 2> kPlaneTexels = {std::array<float, 3>{0.8f, 0.3f, 0.1f},
                                                          std::array<float, 3>{0.2f, 0.5f, 0.9f}};

cb::DeviceScene texturedPlane(cb::ChannelMode mode) {
    writeImage("plane.exr", 2, 1,
               [](int x, int, int c) { return kPlaneTexels[size_t(x)][size_t(c)]; });
    return cb::buildDeviceScene(
        parseInTemp(
            "LookAt 0 0 3  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n"
            "Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\n"
            "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n"
            "Texture \"two\" \"spectrum\" \"imagemap\" \"string filename\" \"plane.exr\" "
            "\"string filter\" \"point\"\n"
            "Material \"diffuse\" \"texture reflectance\" \"two\"\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-10 -10 0  10 -10 0  -10 10 0  10 10 0]\n"),
        mode);
}

// Bins 0-2: the left third's channels, 3-5: the right third's; kNone elsewhere. Which texel
// each third sees follows from the camera ray through its middle.
struct PlaneBins {
    static constexpr size_t kNone = 6;
    int width = 0;
    bool leftIsNegativeX = true;
    size_t operator()(int x, int, int c) const {
        if (3 * x < width) return size_t(c);
        if (3 * x >= 2 * width) return 3 + size_t(c);
        return kNone;
    }
};

PlaneBins planeBins(const cb::DeviceScene& scene) {
    PlaneBins bins;
    bins.width = scene.camera.width;
    const cbk::Ray left =
        cbk::cameraGenerateRay(&scene.camera, 2.5f, 12.f, cbk::vec3(0.f, 0.f, 0.f));
    bins.leftIsNegativeX = left.d.x < 0.f;
    return bins;
}

// Per bin, the reflectance of the texel that third sees, as the film's RGB (filmRgb).
template <class FilmRgb>
std::array<double, 6> planeExpected(const PlaneBins& bins, FilmRgb filmRgb) {
    std::array<double, 6> out{};
    for (size_t side = 0; side < 2; ++side) {
        const size_t texelIndex = (side == 0) == bins.leftIsNegativeX ? 0 : 1;
        const std::array<double, 3> rgb = filmRgb(kPlaneTexels[texelIndex]);
        for (size_t c = 0; c < 3; ++c)
            out[3 * side + c] = rgb[c];
    }
    return out;
}

std::array<double, 3> asDouble(const std::array<float, 3>& rgb) {
    return {rgb[0], rgb[1], rgb[2]};
}

// The RGB plane, its bins and their expected values.
struct PlaneCase {
    cb::DeviceScene scene;
    PlaneBins bins;
    std::array<double, 6> expected{};
};

PlaneCase rgbPlane() {
    PlaneCase c{texturedPlane(cb::ChannelMode::Auto), {}, {}};
    c.bins = planeBins(c.scene);
    c.expected = planeExpected(c.bins, asDouble);
    return c;
}

} // namespace

TEST_CASE("image textures: a textured plane's radiance is its texel's reflectance, every method" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const PlaneCase plane = rgbPlane();
    for (const std::string method : kMethods) {
        CAPTURE(method);
        checkBinMeans(
            binnedMeans(plane.scene, runtime, methodSettings(method), 6, 4, 700u, 6, plane.bins),
            plane.expected, 1e-4);
    }
}

// BDPT's strategies for these paths alone, unweighted, then weighted: the eye path's escape
// (s = 0), next-event estimation (s = 1) and light tracing (s = 2, t = 1), whose vertex on the
// plane is a light subpath's and carries its own (u, v) (PathVertex.uv).
TEST_CASE("image textures: each BDPT strategy alone sees the texels" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const PlaneCase plane = rgbPlane();
    for (const auto& [s, t, estimates] :
         {std::array<int, 3>{0, 3, 8}, std::array<int, 3>{1, 2, 8}, std::array<int, 3>{2, 1, 64},
          std::array<int, 3>{-1, -1, 8}}) {
        CAPTURE(s);
        CAPTURE(t);
        cb::IntegratorSettings settings = methodSettings("bdpt");
        settings.debugS = s;
        settings.debugT = t;
        checkBinMeans(
            binnedMeans(plane.scene, runtime, settings, 6, estimates, 800u, 6, plane.bins),
            plane.expected, 1e-4);
    }
}

// In spectra each texel is Smits's spectrum of its RGB, clamped to [0, 1] per bin, as a constant
// reflectance is (rgbToSpectrum); the film sees it through its own matrix.
TEST_CASE("image textures: in a spectral scene, the texels' spectra" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const cb::DeviceScene scene = texturedPlane(cb::ChannelMode::Spectral);
    REQUIRE(scene.channels == 16);
    const PlaneBins bins = planeBins(scene);
    const std::array<double, 6> expected =
        planeExpected(bins, [&](const std::array<float, 3>& rgb) {
            const std::array<float, 16> bins16 = cb::rgbToSpectrum(rgb);
            // The sky's "rgb L" [1 1 1] is the illuminant's spectrum of luminance 1.
            const std::array<float, 16> sky = cb::rgbIlluminantSpectrum({1.f, 1.f, 1.f});
            std::array<double, 3> film{};
            for (size_t c = 0; c < 3; ++c)
                for (size_t i = 0; i < 16; ++i)
                    film[c] +=
                        double(scene.toRgb[c * 16 + i]) * std::clamp(bins16[i], 0.f, 1.f) * sky[i];
            return film;
        });
    for (const std::string method : {"pt", "bdpt", "cbdpt", "mlt"}) {
        CAPTURE(method);
        checkBinMeans(binnedMeans(scene, runtime, methodSettings(method), 6, 4, 900u, 6, bins),
                      expected, 1e-4);
    }
}

// Two scenes that must render the same estimates (a texture of one value and that constant), the
// first compiling `feature` and the second not: for each of `methods`, two estimates with the
// same seed, every pixel channel within `relative` of the image mean, the image not black.
void checkSameEstimates(const cb::DeviceScene& textured, const cb::DeviceScene& constant,
                        unsigned feature, const std::vector<std::string>& methods,
                        std::uint32_t seed, double relative, cb::ClRuntime& runtime) {
    REQUIRE((textured.features & feature) != 0);
    REQUIRE((constant.features & feature) == 0);
    for (const std::string& method : methods) {
        CAPTURE(method);
        cb::IntegratorSettings settings = methodSettings(method);
        settings.seed = seed;
        auto a = cb::makeIntegrator(settings, textured, runtime);
        auto b = cb::makeIntegrator(settings, constant, runtime);
        std::vector<float> ra, rb;
        double largest = 0.0, sum = 0.0;
        for (std::uint32_t e = 0; e < 2; ++e) {
            a->renderEstimate(e, ra);
            b->renderEstimate(e, rb);
            REQUIRE(ra.size() == rb.size());
            for (size_t i = 0; i < ra.size(); ++i) {
                largest = std::max(largest, double(std::fabs(ra[i] - rb[i])));
                sum += rb[i];
            }
        }
        CAPTURE(largest);
        CHECK(sum > 0.0);
        CHECK(largest <= relative * sum / double(ra.size()));
    }
}
const std::vector<std::string> kAllMethods(std::begin(kMethods), std::end(kMethods));

// A texture of one colour is that constant reflectance: the same image, estimate for estimate,
// for the plain diffuse floor, the coated diffuse wall, a diffuse transmitter's reflectance
// and transmittance (times its scale, clamped) and a coated conductor's reflectance, in RGB
// (where the texel is the constant exactly).
TEST_CASE("image textures: a one-colour texture renders as that constant reflectance" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    writeImage("flat.exr", 4, 4, [](int, int, int c) { return 0.25f + 0.25f * float(c); });
    writeImage("flat2.exr", 4, 4,
               [](int, int, int c) { return 0.6f - 0.3f * float(c) + (c == 2 ? 0.1f : 0.f); });
    auto scene = [&](bool textured) {
        const std::string reflectance =
            textured ? "\"texture reflectance\" \"flat\"" : "\"rgb reflectance\" [0.25 0.5 0.75]";
        const std::string transmittance = textured ? "\"texture transmittance\" \"flat2\""
                                                   : "\"rgb transmittance\" [0.6 0.3 0.1]";
        return cb::buildDeviceScene(parseInTemp(
            "LookAt 0 2 -3  0 0.3 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n"
            "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
            "WorldBegin\n" +
            kDiskLight +
            "Texture \"flat\" \"spectrum\" \"imagemap\" \"string filename\" \"flat.exr\"\n"
            "Texture \"flat2\" \"spectrum\" \"imagemap\" \"string filename\" \"flat2.exr\"\n"
            "Material \"diffuse\" " +
            reflectance +
            "\nShape \"bilinearmesh\" \"point3 P\" [-2 0 -2  2 0 -2  -2 0 2  2 0 2]\n"
            "Material \"coateddiffuse\" " +
            reflectance +
            "\nShape \"bilinearmesh\" \"point3 P\" [-2 0 1  2 0 1  -2 2 1  2 2 1]\n"
            // A sheet below the light: its transmittance lights the floor beneath.
            "Material \"diffusetransmission\" " +
            reflectance + " " + transmittance +
            " \"float scale\" 1.5\nShape \"bilinearmesh\" \"point3 P\" [-1.2 0.8 -0.6  0.4 0.8 "
            "-0.6  -1.2 0.8 0.4  0.4 0.8 0.4]\n"
            // A glossy coated conductor whose reflectance is its normal-incidence Fresnel.
            "Material \"coatedconductor\" " +
            reflectance +
            " \"float conductor.roughness\" 0.2\nShape \"trianglemesh\" \"point3 P\" [0.5 0.05 "
            "-0.2  1.6 0.05 0.3  1 1.2 0.6]\n"));
    };
    const cb::DeviceScene textured = scene(true);
    const cb::DeviceScene constant = scene(false);
    checkSameEstimates(textured, constant, CB_FEATURE_TEXTURE, kAllMethods, 11u, 1e-5, runtime);
}

// A sphere's pbrt-v4 (u, v) is (phi / 2 pi, 1 - theta / pi) in its object frame, and a
// "spherical" mapping in that frame gives (theta / pi, phi / 2 pi): the spherical mapping of an
// image looks up what the (u, v) of that image turned a quarter (rows become columns) looks up,
// texel centres onto texel centres. The same estimates in every method but CPT (PT's code):
// bidirectional vertices carry the hit point to their lookups.
TEST_CASE("image textures: a spherical mapping renders as the (u, v) of the image turned" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    auto a = [](int x, int y, int c) {
        return 0.1f + 0.2f * float(x) + 0.15f * float(y) * float(c + 1) - 0.05f * float(c);
    };
    writeImage("a.exr", 4, 2, a);
    writeImage("b.exr", 2, 4, [&](int x, int y, int c) { return a(y, 1 - x, c); });
    auto scene = [&](const std::string& texture) {
        return cb::buildDeviceScene(parseInTemp(
            "LookAt 0 2 -3  0 0.3 0  0 1 0\nCamera \"perspective\" \"float fov\" 30\n"
            "Film \"rgb\" \"integer xresolution\" 16 \"integer yresolution\" 16\n"
            "WorldBegin\n" +
            kDiskLight +
            "Material \"diffuse\"\nShape \"bilinearmesh\" \"point3 P\" [-2 0 -2  2 0 -2  -2 0 2  "
            "2 0 2]\nAttributeBegin\nTranslate 0.1 0.4 -0.2\nRotate 40 1 0.5 0\n"
            "Texture \"t\" \"spectrum\" \"imagemap\" " +
            texture +
            "\nMaterial \"diffuse\" \"texture reflectance\" \"t\"\n"
            "Shape \"sphere\" \"float radius\" 0.4\nAttributeEnd\n"));
    };
    const cb::DeviceScene mapped =
        scene("\"string filename\" \"a.exr\" \"string mapping\" \"spherical\"");
    const cb::DeviceScene turned = scene("\"string filename\" \"b.exr\"");
    checkSameEstimates(mapped, turned, CB_FEATURE_TEXTURE_MAPPING, {"pt", "bdpt", "cbdpt", "mlt"},
                       5u, 1e-4, runtime);
}

// A diffuse unit sphere whose reflectance is a directionmix by dir = +y of two colours, under a
// uniform sky of radiance 1, paths of at most three vertices: a pixel that sees the sphere at
// normal n is |n_y| c1 + (1 - |n_y|) c2 (a convex shape's point sees only sky), one that misses
// it the sky, 1. The expected mean of each band of rows and channel from 64 x 64 rays per
// pixel against the sphere; every method, whose vertices (PT's hits, BDPT's path vertices)
// carry the geometric normal to the lookup.
TEST_CASE("image textures: a directionmix on a sphere, every method, against the analytic "
          "radiance" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const std::array<double, 3> c1{0.9, 0.5, 0.1}, c2{0.1, 0.3, 0.8};
    const int size = 12;
    const double distance = 3.0, tanHalf = std::tan(25.0 * M_PI / 180.0);
    const cb::DeviceScene scene = cb::buildDeviceScene(cb::parseSceneString(
        fmt::format("LookAt 0 0 -{}  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n"
                    "Film \"rgb\" \"integer xresolution\" {} \"integer yresolution\" {}\n"
                    "PixelFilter \"box\"\nWorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\n"
                    "Texture \"dm\" \"spectrum\" \"directionmix\" \"vector3 dir\" [0 1 0] "
                    "\"rgb tex1\" [{} {} {}] \"rgb tex2\" [{} {} {}]\n"
                    "Material \"diffuse\" \"texture reflectance\" \"dm\"\nShape \"sphere\"\n",
                    distance, size, size, c1[0], c1[1], c1[2], c2[0], c2[1], c2[2]),
        "t.pbrt"));
    REQUIRE((scene.features & CB_FEATURE_DIRECTION_MIX) != 0);
    // Bins: three bands of rows (the mix varies with n_y) by channel.
    auto binOf = [&](int, int y, int c) { return size_t((3 * y / size) * 3 + c); };
    // The image is symmetric about both axes, so the expectation does not depend on which way
    // the camera's x and y run.
    std::array<double, 9> expected{};
    std::array<double, 9> members{};
    forEachFilmSample(size, 64, tanHalf, [&](int x, int y, double fx, double fy) {
        // The ray (0, 0, -distance) + t (fx, fy, 1) against the unit sphere.
        const double dd = fx * fx + fy * fy + 1.0, b = -distance;
        const double disc = b * b - dd * (distance * distance - 1.0);
        std::array<double, 3> value{1.0, 1.0, 1.0};
        if (disc >= 0.0) {
            const double t = (-b - std::sqrt(disc)) / dd;
            const double ny = fy * t; // the hit point's y, the unit normal's
            const double a = std::fabs(ny);
            for (size_t c = 0; c < 3; ++c)
                value[c] = a * c1[c] + (1.0 - a) * c2[c];
        }
        for (int c = 0; c < 3; ++c) {
            expected[binOf(x, y, c)] += value[size_t(c)];
            members[binOf(x, y, c)] += 1.0;
        }
    });
    for (size_t b = 0; b < expected.size(); ++b)
        expected[b] /= members[b];
    for (const std::string method : kMethods) {
        CAPTURE(method);
        cb::IntegratorSettings settings = methodSettings(method);
        settings.maxPathVertices = 3;
        checkBinMeans(
            binnedMeans(scene, runtime, settings, 16, method == "mlt" ? 128 : 4, 21u, 9, binOf),
            expected, 2e-3);
    }
}

TEST_CASE("image textures: BDPT, CBDPT and MLT agree with PT on textured surfaces" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    const std::string checks = writeImage("checks.exr", 8, 8, [](int x, int y, int c) {
        return (x + y) % 2 ? 0.8f - 0.3f * float(c) : 0.1f + 0.25f * float(c);
    });
    // Below the light, a diffuse transmitter of the checks and their inverse: most of the light
    // reaches the room through it.
    const std::string sheet =
        "Texture \"inverse\" \"spectrum\" \"imagemap\" \"string filename\" \"" + checks +
        "\" \"bool invert\" true\nAttributeBegin\nMaterial \"diffusetransmission\" "
        "\"texture reflectance\" \"checks\" \"texture transmittance\" \"inverse\"\n"
        "Shape \"bilinearmesh\" \"point3 P\" [-1.1 1.2 -0.5  0.1 1.2 -0.5  -1.1 1.2 0.5  0.1 1.2 "
        "0.5]\nAttributeEnd\n";
    checkMethodsAgreeWithPt(kDiskLight, sheet, "",
                            "Texture \"checks\" \"spectrum\" \"imagemap\" \"string filename\" \"" +
                                checks +
                                "\" \"float uscale\" 3 \"float vscale\" 2\n"
                                "Material \"diffuse\" \"texture reflectance\" \"checks\"\n");
}

// pbrt-v4's "constant", "scale" and 2D "checkerboard" textures of constants become image textures
// that look up to pbrt-v4's values: checkerboard tex1 where floor(s) + floor(t) is even.
TEST_CASE("image textures: constant, scale and checkerboard textures") {
    TempDirCleanup cleanup;
    writeImage("two.exr", 2, 2, texel);
    const char* const definitions[] = {
        "\"constant\" \"rgb value\" [0.2 0.4 0.6]",
        "\"scale\" \"texture tex\" \"img\" \"float scale\" 0.5",
        "\"scale\" \"rgb tex\" [0.2 0.4 0.6] \"float scale\" 2",
        "\"scale\" \"texture tex\" \"t2\" \"float scale\" 0.25", // a scale of a scale
        "\"checkerboard\" \"float uscale\" 4 \"float vscale\" 2 \"float udelta\" 0.5 "
        "\"rgb tex1\" [0.9 0.1 0.1] \"rgb tex2\" [0.1 0.1 0.9]",
        "\"mix\" \"rgb tex1\" [0.2 0.4 0.6] \"float amount\" 0.25", // tex2 1
        "\"mix\" \"texture tex1\" \"img\" \"rgb tex2\" [1 0 0.5] \"float amount\" 0.25",
        "\"mix\" \"texture tex1\" \"img\" \"texture tex2\" \"t1\"", // two images, amount 0.5
        "\"mix\" \"rgb tex1\" [0.2 0.4 0.6] \"texture tex2\" \"img\" \"float amount\" 0.75"};
    std::string body =
        "Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"two.exr\"\n";
    for (size_t i = 0; i < std::size(definitions); ++i)
        body += fmt::format("Texture \"t{0}\" \"spectrum\" {1}\nMaterial \"diffuse\" \"texture "
                            "reflectance\" \"t{0}\"\n{2}",
                            i, definitions[i], triangleAt(int(i)));
    const cb::SceneDesc desc = sceneDesc(body);
    const cb::DeviceScene scene = cb::buildDeviceScene(desc);
    const cbk::SceneView view = cbtest::hostView(scene);
    std::vector<int> offset;
    for (const cb::TriangleMeshDesc& mesh : desc.meshes)
        offset.push_back(scene.materials[size_t(mesh.material)].reflectanceTexture);
    auto rgb = [&](size_t texture, float u, float v) {
        return cbk::textureRgb(&view, offset[texture], uvOf(u, v));
    };
    for (float u : {0.1f, 0.7f, -3.3f})
        checkRgb(rgb(0, u, 0.4f), cbk::vec3(0.2f, 0.4f, 0.6f));
    checkRgb(rgb(1, 0.25f, 0.75f), cbk::vscale(texelRgb(0, 0), 0.5f));
    checkRgb(rgb(1, 0.75f, 0.25f), cbk::vscale(texelRgb(1, 1), 0.5f));
    checkRgb(rgb(2, 0.5f, 0.5f), cbk::vec3(0.4f, 0.8f, 1.2f));
    checkRgb(rgb(3, 0.5f, 0.5f), cbk::vec3(0.1f, 0.2f, 0.3f));
    // The checkerboard against pbrt-v4's rule at cell centres and off them, negative included.
    std::mt19937 rng(5u);
    std::uniform_real_distribution<float> coordinate(-3.f, 3.f);
    int tex1 = 0, tex2 = 0;
    for (int i = 0; i < 400; ++i) {
        const float u = coordinate(rng), v = coordinate(rng);
        const double s = 4.0 * u + 0.5, t = 2.0 * v;
        // Away from the lines between cells, where float rounding may pick either side.
        if (std::fabs(s - std::round(s)) < 1e-3 || std::fabs(t - std::round(t)) < 1e-3) continue;
        const bool even = (long(std::floor(s)) + long(std::floor(t))) % 2 == 0;
        CAPTURE(u);
        CAPTURE(v);
        checkRgb(rgb(4, u, v), even ? cbk::vec3(0.9f, 0.1f, 0.1f) : cbk::vec3(0.1f, 0.1f, 0.9f));
        ++(even ? tex1 : tex2);
    }
    CHECK(tex1 > 150);
    CHECK(tex2 > 150);
    // Mixes: (1 - amount) tex1 + amount tex2, folded into the texels.
    auto mixed = [](cbk::Vec3 a, cbk::Vec3 b, float amount) {
        return cbk::vadd(cbk::vscale(a, 1.f - amount), cbk::vscale(b, amount));
    };
    checkRgb(rgb(5, 0.3f, 0.3f),
             mixed(cbk::vec3(0.2f, 0.4f, 0.6f), cbk::vec3(1.f, 1.f, 1.f), 0.25f));
    for (const auto& [u, v, x, y] :
         {std::array{0.25f, 0.75f, 0.f, 0.f}, std::array{0.75f, 0.25f, 1.f, 1.f}}) {
        const cbk::Vec3 t = texelRgb(int(x), int(y));
        checkRgb(rgb(6, u, v), mixed(t, cbk::vec3(1.f, 0.f, 0.5f), 0.25f));
        checkRgb(rgb(7, u, v), mixed(t, cbk::vscale(t, 0.5f), 0.5f));
        checkRgb(rgb(8, u, v), mixed(cbk::vec3(0.2f, 0.4f, 0.6f), t, 0.75f));
    }
    // Between texels too (bilinear interpolation is linear, so folding changes nothing).
    checkRgb(rgb(6, 0.5f, 0.5f),
             mixed(cbk::vscale(cbk::vadd(cbk::vadd(texelRgb(0, 0), texelRgb(1, 0)),
                                         cbk::vadd(texelRgb(0, 1), texelRgb(1, 1))),
                               0.25f),
                   cbk::vec3(1.f, 0.f, 0.5f), 0.25f));

    // What cbdpt cannot fold is an error only where a material uses it, saying why.
    writeImage("small.exr", 3, 1, texel);
    for (const auto& [definition, message] :
         {std::pair{"\"scale\" \"texture tex\" \"img\" \"texture scale\" \"f\"",
                    "\"texture scale\" is a float texture"},
          std::pair{"\"checkerboard\" \"integer dimension\" 3", "three-dimensional"},
          std::pair{"\"checkerboard\" \"texture tex1\" \"img\"", "\"texture tex1\" is a texture"},
          std::pair{"\"constant\" \"spectrum value\" [400 0.5 700 0.5]", "is a spectrum"},
          std::pair{"\"scale\" \"texture tex\" \"d\"", "\"texture tex\" names the spectrum "
                                                       "texture \"d\" of class \"dots\""},
          std::pair{"\"mix\" \"texture amount\" \"f\"", "\"texture amount\" is a float texture"},
          std::pair{"\"mix\" \"texture tex1\" \"img\" \"texture tex2\" \"small\"",
                    "two images of different sizes"},
          std::pair{"\"mix\" \"texture tex1\" \"edged\"", "black outside itself"},
          std::pair{"\"dots\"", "\"checkerboard\" and \"directionmix\" only"}}) {
        CAPTURE(definition);
        const std::string defined =
            "WorldBegin\nTexture \"img\" \"spectrum\" \"imagemap\" \"string filename\" "
            "\"two.exr\"\nTexture \"d\" \"spectrum\" \"dots\"\nTexture \"small\" \"spectrum\" "
            "\"imagemap\" \"string filename\" \"small.exr\"\nTexture \"edged\" \"spectrum\" "
            "\"imagemap\" \"string filename\" \"two.exr\" \"string wrap\" \"black\"\n"
            "Texture \"x\" \"spectrum\" " +
            std::string(definition) + "\n";
        CHECK_NOTHROW(parseInTemp(defined));
        const std::string error =
            errorOf(defined + "Material \"diffuse\" \"texture reflectance\" \"x\"\n");
        CHECK(contains(error, ":7:"));
        CHECK(contains(error, message));
    }
}

// pbrt-v4's "texture roughness": a float texture (the mean of an image's channels, or a
// constant) as the GGX roughness of conductors, rough dielectrics and coats, looked up per hit.
TEST_CASE("roughness textures: float textures, the materials that take them, the refusals") {
    TempDirCleanup cleanup;
    writeImage("rough.exr", 2, 1,
               [](int x, int, int c) { return 0.1f * float(1 + x) + 0.1f * float(c); });
    const cb::SceneDesc s = parseInTemp(
        "WorldBegin\nTexture \"r\" \"float\" \"imagemap\" \"string filename\" \"rough.exr\"\n"
        "Texture \"k\" \"float\" \"constant\" \"float value\" 0.25\n"
        "Material \"conductor\" \"texture roughness\" \"r\"\n"
        "Material \"dielectric\" \"texture uroughness\" \"k\" \"texture vroughness\" \"k\" "
        "\"bool remaproughness\" false\n"
        "Material \"coateddiffuse\" \"texture roughness\" \"k\"\n"
        "Material \"coatedconductor\" \"texture interface.roughness\" \"r\"\n");
    REQUIRE(s.textures.size() == 2);
    // A float texture's texels hold the mean of R, G and B three times.
    CHECK(s.textures[0].rgb[0] == doctest::Approx(0.2f).epsilon(1e-6));
    CHECK(s.textures[0].rgb[2] == doctest::Approx(0.2f).epsilon(1e-6));
    CHECK(s.textures[0].rgb[3] == doctest::Approx(0.3f).epsilon(1e-6));
    CHECK(s.textures[0].rgb[5] == doctest::Approx(0.3f).epsilon(1e-6));
    CHECK(s.textures[1].rgb == std::vector<float>{0.25f, 0.25f, 0.25f});
    REQUIRE(s.materials.size() == 4);

    // The float classes scale, mix and checkerboard, their operands float textures and numbers.
    const cb::SceneDesc f = parseInTemp(
        "WorldBegin\nTexture \"r\" \"float\" \"imagemap\" \"string filename\" \"rough.exr\"\n"
        "Texture \"half\" \"float\" \"scale\" \"texture tex\" \"r\" \"float scale\" 0.5\n"
        "Texture \"m\" \"float\" \"mix\" \"texture tex1\" \"r\" \"float tex2\" 1 \"float amount\" "
        "0.25\n"
        "Texture \"c\" \"float\" \"checkerboard\" \"float tex1\" 0.2 \"float tex2\" 0.7\n"
        "Texture \"r2\" \"float\" \"imagemap\" \"string filename\" \"rough.exr\" \"float scale\" "
        "0.5\n");
    REQUIRE(f.textures.size() == 5);
    // A scale of an image is the image with that "scale", texel for texel (pbrt-v4 files scale
    // displacements either way).
    CHECK(f.textures[1].rgb == f.textures[4].rgb);
    auto texels = [&](size_t t) {
        std::vector<double> v;
        for (size_t i = 0; i < f.textures[t].rgb.size(); i += 3) {
            CHECK(f.textures[t].rgb[i] == f.textures[t].rgb[i + 2]);
            v.push_back(f.textures[t].rgb[i]);
        }
        return v;
    };
    const std::vector<double> half = texels(1), mixed = texels(2), checks = texels(3);
    REQUIRE(half.size() == 2);
    CHECK(half[0] == doctest::Approx(0.1).epsilon(1e-6));
    CHECK(half[1] == doctest::Approx(0.15).epsilon(1e-6));
    REQUIRE(mixed.size() == 2);
    CHECK(mixed[0] == doctest::Approx(0.75 * 0.2 + 0.25).epsilon(1e-6));
    CHECK(mixed[1] == doctest::Approx(0.75 * 0.3 + 0.25).epsilon(1e-6));
    CHECK(checks == std::vector<double>{0.7f, 0.2f, 0.2f, 0.7f});
    CHECK(f.textures[3].nearest);
    CHECK(contains(errorOf("WorldBegin\nTexture \"s\" \"float\" \"scale\" \"texture tex\" "
                           "\"none\"\n"),
                   "t.pbrt:2:43: \"texture tex\" names no float texture \"none\""));
    CHECK(contains(errorOf("WorldBegin\nTexture \"k\" \"float\" \"constant\"\nTexture \"s\" "
                           "\"spectrum\" \"scale\" \"texture tex\" \"k\"\n"),
                   "names no spectrum texture \"k\""));

    CHECK(s.materials[0].roughnessTexture == 0);
    CHECK(s.materials[1].roughnessTexture == 1);
    CHECK_FALSE(s.materials[1].remapRoughness);
    CHECK(s.materials[2].roughnessTexture == 1);
    CHECK(s.materials[3].roughnessTexture == 0);

    const std::string k = "WorldBegin\nTexture \"k\" \"float\" \"constant\" \"float value\" 0.25\n"
                          "Texture \"w\" \"float\" \"bilerp\"\n";
    for (const auto& [material, message] :
         {std::pair{"\"coatedconductor\" \"texture conductor.roughness\" \"k\"",
                    "a texture as \"conductor.roughness\" is not supported"},
          std::pair{"\"conductor\" \"texture uroughness\" \"k\" \"texture vroughness\" \"r\"",
                    "anisotropic roughness"},
          std::pair{"\"conductor\" \"texture roughness\" \"k\" \"float uroughness\" 0.1",
                    "is a number beside the texture"},
          std::pair{"\"conductor\" \"texture roughness\" \"later\"",
                    "no float texture \"later\" is defined before this material"},
          std::pair{"\"conductor\" \"texture roughness\" \"w\"", "class \"bilerp\""}}) {
        CAPTURE(material);
        const std::string error = errorOf(k + "Material " + material + "\n");
        CHECK(contains(error, ":4:"));
        CHECK(contains(error, message));
    }
    // A disk has no (u, v) in cbdpt to look the roughness up at.
    std::string diskError;
    try {
        cb::buildDeviceScene(parseInTemp(
            k + "LightSource \"infinite\"\nMaterial \"conductor\" \"texture roughness\" \"k\"\n"
                "Shape \"disk\"\n"));
    } catch (const cb::SceneError& e) {
        diskError = e.what();
    }
    CHECK(contains(diskError, ":6:"));
    CHECK(contains(diskError, "its roughness"));
    CHECK(contains(diskError, "needs texture coordinates"));
}

// pbrt-v4's "texture thickness" of the coats: a float texture as the layer's thickness, looked
// up per hit (materialThicknessAt): a coat's f and pdfs at a texel are those of the same coat
// with that texel's thickness, the walk's random numbers being hashed from the directions.
TEST_CASE("thickness textures: a coat's layer thickness looked up per hit") {
    TempDirCleanup cleanup;
    writeImage("thick.exr", 2, 1, [](int x, int, int) { return x == 0 ? 0.05f : 0.8f; });
    const std::string textures =
        "Texture \"t\" \"float\" \"imagemap\" \"string filename\" \"thick.exr\" \"string "
        "filter\" \"point\"\nTexture \"k\" \"float\" \"constant\" \"float value\" 0.3\n";
    const cb::SceneDesc desc = sceneDesc(
        textures +
        "Material \"coateddiffuse\" \"texture thickness\" \"t\" \"float roughness\" 0.2 "
        "\"rgb albedo\" [0.5 0.5 0.5]\n" +
        triangleAt(0) +
        "Material \"coatedconductor\" \"texture thickness\" \"k\" \"float interface.roughness\" "
        "0.1\n" +
        triangleAt(1) + "Material \"coateddiffuse\"\n" + triangleAt(2));
    REQUIRE(desc.materials.size() == 3);
    CHECK(desc.materials[0].thicknessTexture == 0);
    CHECK(desc.materials[1].thicknessTexture == 1);
    CHECK(desc.materials[2].thicknessTexture == -1);
    const cb::DeviceScene scene = cb::buildDeviceScene(desc);
    CHECK((scene.features & CB_FEATURE_THICKNESS_TEXTURE) != 0);
    CHECK((deviceScene("Material \"coateddiffuse\" \"float thickness\" 0.3\n" + triangleAt(0))
               .features &
           CB_FEATURE_THICKNESS_TEXTURE) == 0);
    const cbk::SceneView view = cbtest::hostView(scene);
    const cbk::Frame frame = cbk::frameFromNormal(cbk::vec3(0.f, 0.f, 1.f));
    const cbk::Vec3 wo = cbk::vnormalize(cbk::vec3(0.3f, -0.2f, 0.9f));
    const cbk::Vec3 wi = cbk::vnormalize(cbk::vec3(-0.5f, 0.1f, 0.6f));
    for (const auto& [material, u, thickness] :
         {std::tuple{0, 0.25f, 0.05f}, std::tuple{0, 0.75f, 0.8f}, std::tuple{1, 0.5f, 0.3f}}) {
        CAPTURE(material);
        CAPTURE(u);
        REQUIRE(scene.materials[size_t(material)].thicknessTexture >= 0);
        cb::DeviceScene constant = scene;
        constant.materials[size_t(material)].thicknessTexture = -1;
        constant.materials[size_t(material)].thickness = thickness;
        const cbk::SceneView constantView = cbtest::hostView(constant);
        float pdf = 0.f, pdfRev = 0.f, constantPdf = 0.f, constantPdfRev = 0.f;
        const cbk::Spectrum f =
            cbk::bsdfEval(&view, material, uvOf(u, 0.5f), frame, wo, wi, 0, &pdf, &pdfRev);
        const cbk::Spectrum expected = cbk::bsdfEval(&constantView, material, uvOf(u, 0.5f), frame,
                                                     wo, wi, 0, &constantPdf, &constantPdfRev);
        for (int c = 0; c < 3; ++c)
            CHECK(f.c[c] == doctest::Approx(expected.c[c]).epsilon(1e-6));
        CHECK(f.c[0] > 0.f);
        CHECK(pdf == doctest::Approx(constantPdf).epsilon(1e-6));
        CHECK(pdfRev == doctest::Approx(constantPdfRev).epsilon(1e-6));
    }
    // The two texels' coats differ (a thicker layer absorbs more of the base's light).
    float pdf = 0.f, pdfRev = 0.f;
    const float thin =
        cbk::bsdfEval(&view, 0, uvOf(0.25f, 0.5f), frame, wo, wi, 0, &pdf, &pdfRev).c[1];
    const float thick =
        cbk::bsdfEval(&view, 0, uvOf(0.75f, 0.5f), frame, wo, wi, 0, &pdf, &pdfRev).c[1];
    CHECK(thick < 0.9f * thin);

    for (const auto& [material, message] :
         {std::pair{"\"coateddiffuse\" \"texture thickness\" \"later\"",
                    "no float texture \"later\" is defined before this material (cbdpt reads a "
                    "texture thickness"},
          std::pair{"\"coatedconductor\" \"texture thickness\" \"w\"", "class \"bilerp\""},
          std::pair{"\"coateddiffuse\" \"float thickness\" -1", "must be >= 0"}}) {
        CAPTURE(material);
        const std::string error =
            errorOf("WorldBegin\nTexture \"w\" \"float\" \"bilerp\"\nMaterial " +
                    std::string(material) + "\n");
        CHECK(contains(error, ":3:"));
        CHECK(contains(error, message));
    }
}

// A roughness or thickness texture of one value renders as that constant: the same estimates,
// for every textured kind and method (RGB; the texel is the value, so the kernels' alpha is the
// host's up to the texture's bilinear weights' rounding). The seven kinds stand side by side in
// one scene, so that each method compiles its kernels twice, not fourteen times.
TEST_CASE("roughness and thickness textures: a one-value texture renders as that constant" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    writeImage("flat.exr", 3, 3, [](int, int, int) { return 0.3f; });
    // Each material and its textured parameter.
    const std::vector<std::pair<std::string, std::string>> materials = {
        {"\"conductor\"", "roughness"},
        {"\"conductor\" \"bool remaproughness\" false", "roughness"},
        {"\"dielectric\"", "roughness"},
        {"\"coateddiffuse\"", "roughness"},
        {"\"coatedconductor\"", "interface.roughness"},
        {"\"coateddiffuse\" \"float roughness\" 0.1", "thickness"},
        {"\"coatedconductor\" \"rgb albedo\" [0.6 0.6 0.6]", "thickness"}};
    auto scene = [&](bool textured) {
        std::string world =
            "LookAt 0 2 -3  0 0.3 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n"
            "Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 16\n"
            "WorldBegin\n" +
            kDiskLight +
            "Texture \"flat\" \"float\" \"imagemap\" \"string filename\" "
            "\"flat.exr\"\n"
            "Material \"diffuse\" \"rgb reflectance\" [0.6 0.5 0.4]\n"
            "Shape \"bilinearmesh\" \"point3 P\" [-3 0 -2  3 0 -2  -3 0 2  3 0 2]\n";
        // A wall of seven strips at z = 1, one kind each, and a triangle of each kind before it.
        for (size_t i = 0; i < materials.size(); ++i) {
            const auto& [material, param] = materials[i];
            const std::string x0 = std::to_string(-2.8 + 0.8 * double(i)),
                              x1 = std::to_string(-2.0 + 0.8 * double(i)),
                              xm = std::to_string(-2.4 + 0.8 * double(i));
            world += "Material " + material +
                     (textured ? " \"texture " + param + "\" \"flat\"\n"
                               : " \"float " + param + "\" 0.3\n") +
                     "Shape \"bilinearmesh\" \"point3 P\" [" + x0 + " 0 1  " + x1 + " 0 1  " + x0 +
                     " 2 1  " + x1 + " 2 1]\n" + "Shape \"trianglemesh\" \"point3 P\" [" + x0 +
                     " 0.2 0  " + x1 + " 0.2 0  " + xm + " 1 -0.3]\n";
        }
        return cb::buildDeviceScene(parseInTemp(world));
    };
    const cb::DeviceScene textured = scene(true);
    const cb::DeviceScene constant = scene(false);
    REQUIRE((textured.features & CB_FEATURE_THICKNESS_TEXTURE) != 0);
    REQUIRE((constant.features & CB_FEATURE_THICKNESS_TEXTURE) == 0);
    checkSameEstimates(textured, constant, CB_FEATURE_ROUGHNESS_TEXTURE, kAllMethods, 7u, 1e-4,
                       runtime);
}
