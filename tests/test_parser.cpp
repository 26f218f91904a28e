// Scene parser: transforms against hand-computed matrices, graphics-state stack, materials,
// spectra, lights, shapes and orientation, includes and the model search path, and every error
// path with its file:line:column.
#include <doctest/doctest.h>

#include "scene/scene_desc.h"
#include "scene/transform.h"
#include "spectral/spectral.h"
#include "stanford_models.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;
using cb::parseSceneString;

bool contains(const std::string& s, const std::string& sub) {
    return s.find(sub) != std::string::npos;
}

std::string errorOf(const std::string& text, const std::string& path = "t.pbrt") {
    try {
        parseSceneString(text, path);
    } catch (const cb::SceneError& e) {
        return e.what();
    }
    return "<no error>";
}

// The message must start with the location and contain `what`.
void expectError(const std::string& text, const std::string& where, const std::string& what) {
    const std::string e = errorOf(text);
    INFO("scene:\n" << text << "\nerror: " << e);
    CHECK(e.rfind(where + ": ", 0) == 0);
    CHECK(contains(e, what));
}

const char* kWorld = "WorldBegin\n";

std::array<double, 3> cross(const std::array<double, 3>& a, const std::array<double, 3>& b,
                            const std::array<double, 3>& c) {
    const double e1[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double e2[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    return {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0]};
}

// Normal of the first stored triangle of mesh i, from its stored winding.
std::array<double, 3> windingNormal(const cb::SceneDesc& s, size_t mesh = 0, size_t tri = 0) {
    const auto& m = s.meshes.at(mesh);
    const auto& t = m.triangles.at(tri);
    return cross(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]);
}

const char* kTri = "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0]\n";

fs::path tempDir() {
    static int counter = 0;
    fs::path d = fs::temp_directory_path() / ("cbdpt_test_parser_" + std::to_string(::getpid()) +
                                              "_" + std::to_string(counter++));
    fs::create_directories(d);
    return d;
}

void writeFile(const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << text;
}

void checkMatrix(const std::array<double, 16>& got, const std::array<double, 16>& want) {
    for (int i = 0; i < 16; ++i) {
        INFO("element " << i);
        CHECK(got[i] == doctest::Approx(want[i]).epsilon(1e-12));
    }
}

} // namespace

TEST_CASE("parser: camera, film and the CTM before Camera") {
    // The classic Cornell box camera: pbrt's left-handed camera space plus Scale -1 1 1.
    const auto s =
        parseSceneString("Scale -1 1 1\nLookAt 0.278 0.273 -0.800  0.278 0.273 0  0 1 0\n"
                         "Camera \"perspective\" \"float fov\" [39.3077]\n"
                         "Film \"rgb\" \"integer xresolution\" 512 \"integer yresolution\" [256]\n"
                         "  \"string filename\" \"out.exr\"\nWorldBegin\n",
                         "cam.pbrt");
    // LookAt along +z with up +y is a pure translation by -eye; Scale -1 1 1 post-multiplies.
    checkMatrix(s.camera.worldToCamera,
                {-1, 0, 0, 0.278, 0, 1, 0, -0.273, 0, 0, 1, 0.8, 0, 0, 0, 1});
    CHECK(s.camera.fovDegrees == doctest::Approx(39.3077f));
    CHECK(s.camera.where.str() == "cam.pbrt:3:1");
    CHECK(s.film.width == 512);
    CHECK(s.film.height == 256);
    CHECK(s.film.filename == "out.exr");
    CHECK(s.path == "cam.pbrt");
    // Defaults (pbrt-v4): fov 90, 1280x720.
    const auto d = parseSceneString("Camera \"perspective\"\nWorldBegin\n", "d.pbrt");
    CHECK(d.camera.fovDegrees == 90.f);
    CHECK(d.film.width == 1280);
    CHECK(d.film.height == 720);
}

TEST_CASE("parser: LookAt off-axis matches the hand-computed camera frame") {
    // Looking down +x with up +y: dir=(1,0,0), right=normalize(up x dir)=(0,0,-1), up=(0,1,0).
    const auto s = parseSceneString(
        "LookAt 1 2 3  2 2 3  0 1 0\nCamera \"perspective\"\nWorldBegin\n", "t.pbrt");
    // rows: right, up, dir; last column -R*eye = (3, -2, -1).
    checkMatrix(s.camera.worldToCamera, {0, 0, -1, 3, 0, 1, 0, -2, 1, 0, 0, -1, 0, 0, 0, 1});
    // The look point lands on the camera's +z axis at distance 1.
    const cb::Mat4 m{s.camera.worldToCamera};
    const auto p = m.point({2, 2, 3});
    CHECK(p[0] == doctest::Approx(0.0));
    CHECK(p[1] == doctest::Approx(0.0));
    CHECK(p[2] == doctest::Approx(1.0));
}

TEST_CASE("parser: Translate/Scale/Rotate/Transform/ConcatTransform/Identity compose like pbrt") {
    auto lightAt = [](const std::string& xf) {
        const auto s = parseSceneString(std::string(kWorld) + xf +
                                            "\nLightSource \"point\" \"point3 from\" [1 0 0]\n",
                                        "t.pbrt");
        REQUIRE(s.pointLights.size() == 1);
        return s.pointLights[0].position;
    };
    auto near = [](std::array<double, 3> a, std::array<double, 3> b) {
        for (int i = 0; i < 3; ++i)
            CHECK(a[i] == doctest::Approx(b[i]).epsilon(1e-6));
    };
    // Post-multiplication: the last transform is applied to the object first.
    near(lightAt("Translate 1 0 0 Scale 2 2 2"), {3, 0, 0});
    near(lightAt("Scale 2 2 2 Translate 1 0 0"), {4, 0, 0});
    // Rotate 90 about +z maps +x to +y (right-handed Rodrigues rotation, as pbrt).
    near(lightAt("Rotate 90 0 0 1"), {0, 1, 0});
    near(lightAt("Rotate 90 0 0 -5"), {0, -1, 0});
    near(lightAt("Rotate 120 1 1 1"), {0, 1, 0}); // cycles the axes
    // Transform lists the matrix column by column: translation in values 13-15.
    near(lightAt("Translate 100 0 0 Transform [1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 1]"), {6, 6, 7});
    near(lightAt("Translate 100 0 0 ConcatTransform [0 1 0 0  -1 0 0 0  0 0 1 0  5 6 7 1]"),
         {105, 7, 7});
    near(lightAt("Translate 100 0 0 Identity"), {1, 0, 0});
    // The rotation matrix itself.
    const auto r = cb::rotateMatrix(90, 0, 0, 1);
    REQUIRE(r);
    checkMatrix(r->m, {0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
    // WorldBegin resets the CTM.
    const auto s =
        parseSceneString("Translate 5 5 5\nWorldBegin\nLightSource \"point\"\n", "t.pbrt");
    CHECK(s.pointLights[0].position == std::array<double, 3>{0, 0, 0});
}

TEST_CASE("parser: attribute stack saves CTM, material, area light and orientation") {
    const auto s = parseSceneString(std::string(kWorld) +
                                        "Material \"diffuse\" \"rgb reflectance\" [0.1 0.2 0.3]\n"
                                        "AttributeBegin\n"
                                        "  Translate 0 0 5\n"
                                        "  ReverseOrientation\n"
                                        "  Material \"conductor\" \"rgb reflectance\" [1 1 1]\n"
                                        "  AreaLightSource \"diffuse\" \"rgb L\" [4 5 6]\n" +
                                        kTri +
                                        "  Shape \"sphere\"\n"
                                        "AttributeEnd\n" +
                                        kTri + "Shape \"sphere\"\n",
                                    "t.pbrt");
    REQUIRE(s.meshes.size() == 2);
    REQUIRE(s.spheres.size() == 2);
    REQUIRE(s.materials.size() == 2);
    REQUIRE(s.areaLights.size() == 1);
    CHECK(s.meshes[0].material == 1);
    CHECK(s.meshes[0].areaLight == 0);
    CHECK(s.spheres[0].material == 1);
    CHECK(s.spheres[0].areaLight == 0);
    CHECK(s.spheres[0].reverseOrientation);
    CHECK(s.spheres[0].center == std::array<double, 3>{0, 0, 5});
    CHECK(s.meshes[0].positions[0][2] == 5.f);
    CHECK(windingNormal(s, 0)[2] < 0); // ReverseOrientation
    CHECK(s.meshes[1].material == 0);
    CHECK(s.meshes[1].areaLight == -1);
    CHECK(s.spheres[1].areaLight == -1);
    CHECK_FALSE(s.spheres[1].reverseOrientation);
    CHECK(s.spheres[1].center == std::array<double, 3>{0, 0, 0});
    CHECK(windingNormal(s, 1)[2] > 0);
    CHECK(s.areaLights[0].radiance.rgb == std::array<float, 3>{4, 5, 6});
    CHECK(s.materials[0].reflectance.rgb == std::array<float, 3>{0.1f, 0.2f, 0.3f});
    CHECK(s.materials[1].kind == cb::MaterialKind::Conductor);
}

TEST_CASE("parser: default material is pbrt's diffuse 0.5, created once on first use") {
    const auto s =
        parseSceneString(std::string(kWorld) + kTri + kTri + "Shape \"sphere\"\n", "t.pbrt");
    REQUIRE(s.materials.size() == 1);
    CHECK(s.materials[0].kind == cb::MaterialKind::Diffuse);
    CHECK(s.materials[0].reflectance.rgb == std::array<float, 3>{0.5f, 0.5f, 0.5f});
    CHECK(s.meshes[0].material == 0);
    CHECK(s.meshes[1].material == 0);
    CHECK(s.spheres[0].material == 0);
    CHECK_FALSE(s.usesSpectra);
}

TEST_CASE("parser: materials, named materials and mix") {
    const auto s = parseSceneString(
        std::string(kWorld) +
            "MakeNamedMaterial \"gold\" \"string type\" \"conductor\"\n"
            "   \"rgb reflectance\" [0.68 0.54 0.18] \"float roughness\" 0.1 "
            "\"bool remaproughness\" false\n"
            "MakeNamedMaterial \"matte\" \"string type\" [\"diffuse\"] \"rgb reflectance\" "
            "[0.68 0.54 0.18]\n"
            "MakeNamedMaterial \"glass\" \"string type\" \"dielectric\" \"float eta\" 1.33 "
            "\"float roughness\" 0\n"
            "MakeNamedMaterial \"dragon\" \"string type\" \"mix\" \"string materials\" "
            "[\"matte\" \"gold\"] \"float amount\" 0.3\n"
            "Material \"conductor\" \"spectrum reflectance\" [400 0.5 700 0.9] "
            "\"float uroughness\" 0.2 \"float vroughness\" 0.2 \"bool remaproughness\" [true]\n" +
            kTri + "NamedMaterial \"dragon\"\n" + kTri + "Material \"dielectric\"\n" + kTri,
        "t.pbrt");
    REQUIRE(s.materials.size() == 6);
    const auto& gold = s.materials[0];
    CHECK(gold.name == "gold");
    CHECK(gold.kind == cb::MaterialKind::Conductor);
    CHECK(gold.roughness == doctest::Approx(0.1f));
    CHECK_FALSE(gold.remapRoughness);
    CHECK(gold.reflectance.rgb == std::array<float, 3>{0.68f, 0.54f, 0.18f});
    CHECK(s.materials[1].kind == cb::MaterialKind::Diffuse);
    CHECK(s.materials[2].eta == doctest::Approx(1.33f));
    const auto& mix = s.materials[3];
    CHECK(mix.kind == cb::MaterialKind::Mix);
    CHECK(mix.mix == std::array<int, 2>{1, 0});
    CHECK(mix.amount == doctest::Approx(0.3f));
    const auto& anon = s.materials[4];
    CHECK(anon.name.empty());
    CHECK_FALSE(anon.reflectance.isRgb);
    CHECK(anon.roughness == doctest::Approx(0.2f));
    CHECK(anon.remapRoughness);
    CHECK(s.materials[5].eta == 1.5f);
    CHECK(s.meshes[0].material == 4);
    CHECK(s.meshes[1].material == 3);
    CHECK(s.meshes[2].material == 5);
    CHECK(s.usesSpectra);
}

TEST_CASE("parser: spectra are kept as written") {
    const auto s = parseSceneString(
        std::string(kWorld) +
            "AreaLightSource \"diffuse\" \"spectrum L\" [400 0 500 8 600 15.6 700 18.4] "
            "\"float scale\" 2 \"bool twosided\" true\n" +
            kTri +
            "LightSource \"point\" \"rgb I\" [1 2 3] \"float scale\" 0.5 \"point3 from\" [1 2 3]\n",
        "t.pbrt");
    CHECK(s.usesSpectra);
    REQUIRE(s.areaLights.size() == 1);
    const auto& L = s.areaLights[0];
    CHECK_FALSE(L.radiance.isRgb);
    REQUIRE(L.radiance.samples.size() == 4);
    CHECK(L.radiance.samples[1] == std::pair<float, float>{500.f, 8.f});
    CHECK(L.radiance.samples[3] == std::pair<float, float>{700.f, 18.4f});
    // pbrt-v4 divides a light spectrum by its luminance integral (SpectrumToPhotometric).
    CHECK(L.scale == doctest::Approx(2.0 / cb::photometricIntegral(L.radiance.samples)));
    CHECK(L.twoSided);
    REQUIRE(s.pointLights.size() == 1);
    CHECK(s.pointLights[0].intensity.rgb == std::array<float, 3>{1, 2, 3});
    CHECK(s.pointLights[0].scale == 0.5f);
    CHECK(s.pointLights[0].position == std::array<double, 3>{1, 2, 3});
    CHECK(s.meshes[0].areaLight == 0);
}

TEST_CASE("parser: sphere transform and orientation") {
    auto one = [](const std::string& xf) {
        const auto s = parseSceneString(
            std::string(kWorld) + xf + "\nShape \"sphere\" \"float radius\" 0.5\n", "t.pbrt");
        REQUIRE(s.spheres.size() == 1);
        return s.spheres[0];
    };
    auto a = one("Translate 1 2 3 Scale 2 2 2");
    CHECK(a.center == std::array<double, 3>{1, 2, 3});
    CHECK(a.radius == doctest::Approx(1.f));
    CHECK_FALSE(a.reverseOrientation);
    a = one("Rotate 33 1 2 3 Scale 3 3 3 Translate 1 0 0");
    CHECK(a.radius == doctest::Approx(1.5f));
    CHECK(std::hypot(a.center[0], a.center[1], a.center[2]) == doctest::Approx(3.0));
    CHECK(one("Scale -1 1 1").reverseOrientation);       // mirror: normals inward
    CHECK(one("ReverseOrientation").reverseOrientation); // explicit flip
    CHECK_FALSE(one("ReverseOrientation Scale -2 2 2").reverseOrientation); // both: outward
    CHECK(one("Scale -2 2 2").radius == doctest::Approx(1.f));
    CHECK(one("").radius == 0.5f);
    // Default radius 1.
    const auto s = parseSceneString(std::string(kWorld) + "Shape \"sphere\"\n", "t.pbrt");
    CHECK(s.spheres[0].radius == 1.f);
}

TEST_CASE("parser: triangle winding follows pbrt's normal under mirrors, ReverseOrientation, N") {
    auto normalZ = [](const std::string& pre, const std::string& extra = "") {
        const auto s =
            parseSceneString(std::string(kWorld) + pre + "\n" +
                                 "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 1 0] "
                                 "\"integer indices\" [0 1 2] " +
                                 extra + "\n",
                             "t.pbrt");
        REQUIRE(s.meshes.size() == 1);
        REQUIRE(s.meshes[0].triangles.size() == 1);
        return windingNormal(s)[2];
    };
    CHECK(normalZ("") > 0);
    CHECK(normalZ("ReverseOrientation") < 0);
    // A mirror keeps pbrt's normal the transformed geometric normal (+z stays +z for an x
    // mirror), so the stored winding is reversed relative to the transformed vertices.
    CHECK(normalZ("Scale -1 1 1") > 0);
    CHECK(normalZ("Scale 1 1 -1") < 0); // a z mirror does move the normal to -z
    CHECK(normalZ("Scale -1 1 1 ReverseOrientation") < 0);
    // Per-vertex normals decide the side (pbrt's FaceForward to the shading normal).
    CHECK(normalZ("", "\"normal N\" [0 0 -1  0 0 -1  0 0 -1]") < 0);
    CHECK(normalZ("", "\"normal N\" [0 0 1  0 0 1  0 0 1]") > 0);
    CHECK(normalZ("ReverseOrientation", "\"normal N\" [0 0 -1  0 0 -1  0 0 -1]") > 0);
    CHECK(normalZ("Scale -1 1 1", "\"normal N\" [0 0 -1  0 0 -1  0 0 -1]") < 0);
}

TEST_CASE("parser: degenerate triangles are dropped and counted") {
    const auto s = parseSceneString(
        std::string(kWorld) +
            "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  2 0 0  0 1 0]\n"
            "   \"integer indices\" [0 1 2  0 1 3  0 0 3  3 1 3]\n"
            "Scale 1 1 0\n" // flattens the xz triangle below to zero area
            "Shape \"trianglemesh\" \"point3 P\" [0 0 0  1 0 0  0 0 1  0 1 0] \"integer indices\" "
            "[0 1 2  0 1 3]\n",
        "t.pbrt");
    REQUIRE(s.meshes.size() == 2);
    CHECK(s.meshes[0].triangles.size() == 1); // collinear, repeated x2 dropped
    CHECK(s.meshes[0].triangles[0] == std::array<unsigned, 3>{0, 1, 3});
    CHECK(s.meshes[1].triangles.size() == 1); // only the xz triangle survives the flattening
    CHECK(s.droppedDegenerateTriangles == 4);
    CHECK(s.meshes[0].positions.size() == 4);
}

TEST_CASE("parser: Include resolves relative to the including file and reports its locations") {
    const fs::path d = tempDir();
    writeFile(d / "main.pbrt", "Camera \"perspective\"\nWorldBegin\nInclude \"parts/a.pbrt\"\n"
                               "Shape \"sphere\"\n");
    writeFile(d / "parts/a.pbrt", "# comment\nMaterial \"dielectric\"\nInclude \"b.pbrt\"\n");
    writeFile(d / "parts/b.pbrt", "Shape \"sphere\" \"float radius\" 2\n");
    const auto s = cb::parseSceneFile((d / "main.pbrt").string());
    REQUIRE(s.spheres.size() == 2);
    CHECK(s.spheres[0].radius == 2.f);
    CHECK(s.spheres[0].material == 0); // the Material from a.pbrt stays active (no scoping)
    CHECK(s.spheres[1].material == 0);
    CHECK(s.spheres[0].where.file == (d / "parts/b.pbrt").string());
    CHECK(s.spheres[0].where.line == 1);
    CHECK(s.spheres[1].where.file == (d / "main.pbrt").string());
    CHECK(s.spheres[1].where.line == 4);

    // Errors inside an included file name that file.
    writeFile(d / "parts/b.pbrt", "\n  Shape \"nurbs\"\n");
    std::string e;
    try {
        cb::parseSceneFile((d / "main.pbrt").string());
    } catch (const cb::SceneError& err) {
        e = err.what();
    }
    CHECK(e.rfind((d / "parts/b.pbrt").string() + ":2:9: unsupported shape \"nurbs\"", 0) == 0);

    // Recursion is detected.
    writeFile(d / "parts/b.pbrt", "Include \"../main.pbrt\"\n");
    e.clear();
    try {
        cb::parseSceneFile((d / "main.pbrt").string());
    } catch (const cb::SceneError& err) {
        e = err.what();
    }
    CHECK(e.rfind((d / "parts/b.pbrt").string() + ":1:9: recursive Include", 0) == 0);

    // Missing include.
    CHECK(contains(errorOf("Include \"nope.pbrt\"\n", (d / "x.pbrt").string()),
                   "x.pbrt:1:9: cannot find included file \"nope.pbrt\""));
    // An included file may not end in the middle of a directive.
    writeFile(d / "parts/b.pbrt", "Translate 1 2\n");
    e.clear();
    try {
        cb::parseSceneFile((d / "main.pbrt").string());
    } catch (const cb::SceneError& err) {
        e = err.what();
    }
    CHECK(e.rfind((d / "parts/b.pbrt").string() + ":1:1: unexpected end of file", 0) == 0);
    // Missing scene file.
    CHECK_THROWS_AS(cb::parseSceneFile((d / "absent.pbrt").string()), cb::SceneError);
    fs::remove_all(d);
}

TEST_CASE("parser: plymesh search path (scene folder, then CBDPT_MODEL_PATH)") {
    const fs::path d = tempDir();
    const std::string ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                            "property float y\nproperty float z\nelement face 1\n"
                            "property list uchar int vertex_indices\nend_header\n"
                            "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
    writeFile(d / "models/quad.ply", ply);
    writeFile(d / "scene/local.ply", ply);
    const std::string scene = "WorldBegin\nTranslate 0 0 1\nShape \"plymesh\" \"string filename\" ";
    const char* old = std::getenv("CBDPT_MODEL_PATH");
    const std::string saved = old ? old : "";
    ::setenv("CBDPT_MODEL_PATH", ("/nonexistent::" + (d / "models").string()).c_str(), 1);
    auto s = parseSceneString(scene + "\"quad.ply\"\n", (d / "scene/s.pbrt").string());
    REQUIRE(s.meshes.size() == 1);
    CHECK(s.meshes[0].triangles.size() == 2);
    CHECK(s.meshes[0].positions[2] == std::array<double, 3>{1, 1, 1});
    CHECK(windingNormal(s)[2] > 0);
    s = parseSceneString(scene + "\"local.ply\"\n", (d / "scene/s.pbrt").string());
    CHECK(s.meshes.size() == 1);
    const std::string e = errorOf(scene + "\"bunny2.ply\"\n", (d / "scene/s.pbrt").string());
    CHECK(contains(e, "s.pbrt:3:35: cannot find model file \"bunny2.ply\""));
    CHECK(contains(e, (d / "scene").string()));
    CHECK(contains(e, "/nonexistent"));
    CHECK(contains(e, (d / "models").string()));
    CHECK(contains(e, "scripts/get-models"));
    CHECK(contains(e, "CBDPT_MODEL_PATH"));
    // A broken PLY is reported at the Shape, with the PLY's own location inside.
    writeFile(d / "scene/bad.ply", "ply\nformat ascii 1.0\nnonsense\n");
    const std::string e2 = errorOf(scene + "\"bad.ply\"\n", (d / "scene/s.pbrt").string());
    CHECK(contains(e2, "s.pbrt:3:1: cannot load plymesh: "));
    CHECK(contains(e2, "bad.ply:3:1: unknown header keyword"));
    if (old)
        ::setenv("CBDPT_MODEL_PATH", saved.c_str(), 1);
    else
        ::unsetenv("CBDPT_MODEL_PATH");
    fs::remove_all(d);
}

TEST_CASE("parser: the Stanford bunny loads through a scene file") {
    if (!cbtest::stanfordModelsOrSkip()) return;
    const fs::path dir = cbtest::stanfordModelDir();
    const auto s =
        parseSceneString("WorldBegin\nShape \"plymesh\" \"string filename\" \"bunny.ply\"\n",
                         (dir / "virtual.pbrt").string());
    REQUIRE(s.meshes.size() == 1);
    CHECK(s.meshes[0].positions.size() == 17524);
    CHECK(s.meshes[0].triangles.size() == 34831);
    CHECK(s.droppedDegenerateTriangles == 0);
}

TEST_CASE("parser: syntax errors point at the offending token") {
    expectError("WorldBegin\n  Frobnicate 1\n", "t.pbrt:2:3", "unknown directive 'Frobnicate'");
    expectError("WorldBegin\n\"diffuse\"\n", "t.pbrt:2:1",
                "expected a directive, found \"diffuse\"");
    expectError("WorldBegin\n 3.5\n", "t.pbrt:2:2", "expected a directive, found '3.5'");
    expectError("WorldBegin\n]\n", "t.pbrt:2:1", "expected a directive");
    expectError("WorldBegin\nShape \"sphere\" \"float radius\" [1\n", "t.pbrt:2:31",
                "end of file inside '['");
    expectError("WorldBegin\nShape \"sphere\n", "t.pbrt:2:7", "unterminated string");
    expectError("WorldBegin\nShape \"sph\\qere\"\n", "t.pbrt:2:11", "unknown escape sequence");
    expectError("WorldBegin\nShape \"sphere\" \"float radius\"\nShape \"sphere\"\n", "t.pbrt:2:16",
                "has no value (found 'Shape')");
    expectError("WorldBegin\nShape \"sphere\" \"float radius\"", "t.pbrt:2:16",
                "has no value (end of file)");
    expectError("WorldBegin\nShape \"sphere\" \"float radius\" [1 Shape\n", "t.pbrt:2:34",
                "missing ']'");
    expectError("Translate 1 2\n", "t.pbrt:1:1",
                "unexpected end of file: Translate expects 3 numbers");
    expectError("Translate 1 2\nWorldBegin\n", "t.pbrt:2:1",
                "expected a number for Translate, found 'WorldBegin'");
    expectError("LookAt 0 0 0 0 0 1 0 1\n", "t.pbrt:1:1", "LookAt expects 9 numbers");
    expectError("Rotate 30 0 0 \"z\"\n", "t.pbrt:1:15", "expected a number for Rotate");
    expectError("Transform 1 0 0 0\n", "t.pbrt:1:11", "Transform expects '['");
    expectError("ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 0]\n", "t.pbrt:1:50",
                "exactly 16 numbers then ']'");
    expectError("ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0]\n", "t.pbrt:1:47",
                "expected a number for ConcatTransform, found ']'");
    expectError("WorldBegin\nMaterial diffuse\n", "t.pbrt:2:10", "in double quotes");
    expectError("WorldBegin\nNamedMaterial\n", "t.pbrt:2:1", "unexpected end of file");
    expectError("TransformBegin\n", "t.pbrt:1:1", "only allowed after WorldBegin");
    expectError("WorldBegin\nWorldEnd\n", "t.pbrt:2:1", "pbrt-v3");
    expectError("WorldBegin\nImport \"x.pbrt\"\n", "t.pbrt:2:8", "cannot find included file");
    expectError("Camera \"perspective\"\n", "t.pbrt:2:1", "end of file before WorldBegin");
    expectError("WorldBegin\nWorldBegin\n", "t.pbrt:2:1", "second WorldBegin");
}

TEST_CASE("parser: non-finite and out-of-range numbers are rejected") {
    expectError("Translate 1 nan 0\n", "t.pbrt:1:13", "not a finite number");
    expectError("Translate inf 0 0\n", "t.pbrt:1:11", "not a finite number");
    expectError("Scale 1 1 1e999\n", "t.pbrt:1:11", "out of range");
    expectError("WorldBegin\nShape \"sphere\" \"float radius\" [-nan]\n", "t.pbrt:2:32",
                "not a finite number");
    expectError("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 Infinity]\n",
                "t.pbrt:2:50", "not a finite number");
    expectError("WorldBegin\nShape \"sphere\" \"float radius\" 1x\n", "t.pbrt:2:31",
                "expected a number in parameter \"float radius\", found '1x'");
    // Finite numbers whose transformed position overflows float.
    expectError("WorldBegin\nScale 1e30 1 1\nLightSource \"point\" \"point3 from\" [1e30 0 0]\n",
                "t.pbrt:3:1", "not finite after transformation");
}

TEST_CASE("parser: parameter errors name the parameter") {
    const std::string w = kWorld;
    expectError(w + "Shape \"sphere\" \"float radius\" [1 2]\n", "t.pbrt:2:16",
                "expects exactly 1 value, got 2");
    expectError(w + "Shape \"sphere\" \"integer radius\" 1\n", "t.pbrt:2:16",
                "must have type \"float\", not \"integer\"");
    expectError(w + "Shape \"sphere\" \"float zmax\" 1\n", "t.pbrt:2:16",
                "unknown or unsupported parameter \"float zmax\" for Shape \"sphere\"");
    expectError(w + "Shape \"sphere\" \"color Kd\" [1 1 1]\n", "t.pbrt:2:16",
                "unknown parameter type \"color\"");
    expectError(w + "Shape \"sphere\" \"float\" 1\n", "t.pbrt:2:16", "must be \"type name\"");
    expectError(w + "Shape \"sphere\" \"float radius\" 1 \"float radius\" 2\n", "t.pbrt:2:33",
                "given twice");
    expectError(w + "Shape \"sphere\" \"float radius\" \"one\"\n", "t.pbrt:2:31",
                "expects numbers");
    expectError(w + "Shape \"sphere\" \"float radius\" []\n", "t.pbrt:2:16", "has no values");
    expectError(w + "Shape \"sphere\" \"float radius\" [1 \"a\"]\n", "t.pbrt:2:34",
                "mixed value types");
    expectError(w + "Shape \"sphere\" \"float radius\" -1\n", "t.pbrt:2:16", "must be > 0");
    expectError(w + "Material \"conductor\" \"texture reflectance\" \"checks\"\n", "t.pbrt:2:22",
                "spectrum textures as the \"reflectance\" of diffuse, coateddiffuse, "
                "diffusetransmission and coatedconductor materials");
    expectError(w + "Material \"diffuse\" \"texture reflectance\" \"checks\"\n", "t.pbrt:2:42",
                "names no texture \"checks\"");
    expectError(w + "Material \"diffuse\" \"blackbody reflectance\" [3000 1]\n", "t.pbrt:2:20",
                "expects one temperature in kelvin, got 2");
    expectError(w + "Material \"diffuse\" \"rgb reflectance\" [0.5 0.5]\n", "t.pbrt:2:20",
                "expects exactly 3 values, got 2");
    expectError(w + "Material \"diffuse\" \"rgb reflectance\" [0.5 1.5 0.5]\n", "t.pbrt:2:43",
                "must be <= 1");
    expectError(w + "Material \"diffuse\" \"rgb reflectance\" [0.5 -0.1 0.5]\n", "t.pbrt:2:43",
                "negative value");
    expectError(w + "AreaLightSource \"diffuse\" \"bool twosided\" \"yes\"\n", "t.pbrt:2:43",
                "expects true or false");
    expectError(w + "AreaLightSource \"diffuse\" \"bool twosided\" \"true\"\n", "t.pbrt:2:43",
                "write bare true/false");
    expectError(w + "AreaLightSource \"diffuse\" \"bool twosided\" [true false]\n", "t.pbrt:2:27",
                "exactly 1 value");
    expectError(w + "AreaLightSource \"diffuse\" \"float scale\" -2\n", "t.pbrt:2:27", ">= 0");
    expectError(w + "AreaLightSource \"diffuse\" \"float power\" [1 2]\n", "t.pbrt:2:27",
                "exactly 1 value");
    expectError(w + "LightSource \"point\" \"point3 from\" [1 2]\n", "t.pbrt:2:21",
                "a multiple of 3 values");
    expectError(w + "LightSource \"point\" \"point3 from\" [1 2 3 4 5 6]\n", "t.pbrt:2:21",
                "expects 3 values");
    expectError("Film \"rgb\" \"integer xresolution\" 1.5\n", "t.pbrt:1:34", "expects integers");
    expectError("Film \"rgb\" \"integer xresolution\" 0\n", "t.pbrt:1:12", "[1, 65536]");
    expectError("Film \"rgb\" \"float gain\" 100\n", "t.pbrt:1:12",
                "unknown or unsupported parameter");
    expectError("Camera \"perspective\" \"float fov\" 180\n", "t.pbrt:1:22", "(0, 180)");
    expectError("Camera \"perspective\" \"float lensradius\" -0.1\n", "t.pbrt:1:41",
                "\"float lensradius\" must be in [0, 1e6], got -0.1");
    expectError("Camera \"perspective\" \"float screenwindow\" [-1 1 -1]\n", "t.pbrt:1:22",
                "expects a multiple of 4 values");
    expectError("Camera \"perspective\" \"float focus\" 2\n", "t.pbrt:1:22",
                "unknown or unsupported parameter");
}

TEST_CASE("parser: spectrum parameter errors") {
    const std::string w = kWorld;
    expectError(w + "Material \"diffuse\" \"spectrum reflectance\" [400 0.5 500]\n", "t.pbrt:2:20",
                "even number of values");
    expectError(w + "Material \"diffuse\" \"spectrum reflectance\" [400 0.5 400 0.6]\n",
                "t.pbrt:2:52", "strictly increasing");
    expectError(w + "Material \"diffuse\" \"spectrum reflectance\" [500 0.5 400 0.6]\n",
                "t.pbrt:2:52", "strictly increasing");
    expectError(w + "Material \"diffuse\" \"spectrum reflectance\" \"metal-Cu-etta\"\n",
                "t.pbrt:2:43", "no spectrum file \"metal-Cu-etta\"");
    expectError(w + "Material \"diffuse\" \"spectrum reflectance\" [400 0.5 500 1.2]\n",
                "t.pbrt:2:56", "must be <= 1");
    expectError(w + "AreaLightSource \"diffuse\" \"spectrum L\" [0 1 500 2]\n", "t.pbrt:2:41",
                "wavelength must be positive");
    expectError(w + "AreaLightSource \"diffuse\" \"spectrum L\" [400 1 500 -2]\n", "t.pbrt:2:51",
                "negative value");
}

TEST_CASE("parser: unsupported types are rejected") {
    const std::string w = kWorld;
    expectError(w + "Shape \"nurbs\"\n", "t.pbrt:2:7", "unsupported shape \"nurbs\"");
    expectError("Camera \"orthographic\"\n", "t.pbrt:1:8", "unsupported camera \"orthographic\"");
    expectError(w + "LightSource \"projection\"\n", "t.pbrt:2:13",
                "unsupported light \"projection\"");
    expectError(w + "AreaLightSource \"projection\"\n", "t.pbrt:2:17", "unsupported area light");
    expectError("Film \"spectral\"\n", "t.pbrt:1:6", "unsupported film \"spectral\"");
    expectError(w + "Material \"measured\"\n", "t.pbrt:2:10",
                "unsupported material type \"measured\"");
    expectError(w + "MakeNamedMaterial \"a\" \"string type\" \"subsurface\"\n", "t.pbrt:2:37",
                "unsupported material type \"subsurface\"");
}

TEST_CASE("parser: material errors") {
    const std::string w = kWorld;
    expectError(
        w + "Material \"conductor\" \"spectrum eta\" [400 1 700 1] \"rgb reflectance\" [1 1 1]\n",
        "t.pbrt:2:22", "\"reflectance\" or \"eta\" and \"k\", not both");
    // Anisotropic roughness is a conductor's or a dielectric's (tests/test_anisotropic.cpp), not
    // a coat's.
    expectError(w + "Material \"coateddiffuse\" \"float uroughness\" 0.1\n", "t.pbrt:2:26",
                "anisotropic roughness (uroughness != vroughness) is not supported on a coat");
    expectError(w + "Material \"coateddiffuse\" \"float uroughness\" 0.1 "
                    "\"float vroughness\" 0.2\n",
                "t.pbrt:2:26", "anisotropic roughness");
    expectError(w + "Material \"conductor\" \"rgb reflectance\" [1 1 1] \"float roughness\" 0.1 "
                    "\"float uroughness\" 0.2 \"float vroughness\" 0.2\n",
                "t.pbrt:2:48", "overridden");
    expectError(w + "Material \"conductor\" \"rgb reflectance\" [1 1 1] \"float roughness\" -1\n",
                "t.pbrt:2:48", "must be >= 0");
    expectError(w + "Material \"dielectric\" \"float vroughness\" -0.3\n", "t.pbrt:2:23",
                "vroughness must be >= 0, got -0.3");
    expectError(w + "Material \"dielectric\" \"float roughness\" -0.3\n", "t.pbrt:2:23",
                "must be >= 0");
    expectError(w + "Material \"coateddiffuse\" \"spectrum eta\" \"glass-BK7\"\n", "t.pbrt:2:41",
                "\"glass-BK7\" is a dispersive index, which cbdpt's coats do not take (only "
                "\"dielectric\" and \"thindielectric\"); give \"float eta\" 1.5168 (SCHOTT "
                "N-BK7 at 587.6 nm)");
    expectError(w + "Material \"coatedconductor\" \"spectrum interface.eta\" \"glass-F11\"\n",
                "t.pbrt:2:53", "give \"float interface.eta\" 1.78472 (SCHOTT SF11 at 587.6 nm)");
    expectError(w + "Material \"dielectric\" \"rgb eta\" [1.5 1.4 1.3]\n", "t.pbrt:2:23",
                "a dielectric's \"eta\" is \"float eta\" or \"spectrum eta\", not rgb");
    expectError(w + "Material \"dielectric\" \"float eta\" 0\n", "t.pbrt:2:35",
                "must be > 0, got 0");
    expectError(w + "Material \"diffuse\" \"float sigma\" 10\n", "t.pbrt:2:20",
                "unknown or unsupported parameter \"float sigma\" for Material \"diffuse\"");
    // pbrt-v4 looks names up after parsing: an undefined one is an error where a shape uses it.
    expectError(w + "NamedMaterial \"ghost\"\nShape \"sphere\"\n", "t.pbrt:2:15",
                "unknown named material \"ghost\" (no MakeNamedMaterial defines it)");
    expectError(w + "MakeNamedMaterial \"a\" \"rgb reflectance\" [1 1 1]\n", "t.pbrt:2:1",
                "needs a \"string type\"");
    expectError(w + "MakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n"
                    "MakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n",
                "t.pbrt:3:19", "already defined (at t.pbrt:2:1)");
    const std::string ab = w + "MakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n"
                               "MakeNamedMaterial \"b\" \"string type\" \"dielectric\"\n";
    expectError(ab + "Material \"mix\" \"string materials\" [\"a\" \"c\"]\n", "t.pbrt:4:40",
                "unknown named material \"c\" in mix");
    expectError(ab + "Material \"mix\" \"string materials\" [\"a\"]\n", "t.pbrt:4:16",
                "exactly 2 named materials, got 1");
    expectError(ab + "Material \"mix\"\n", "t.pbrt:4:1", "mix needs \"string materials\"");
    expectError(ab + "Material \"mix\" \"string materials\" [\"a\" \"b\"] \"float amount\" 1.5\n",
                "t.pbrt:4:45", "[0, 1]");
    // A mix may hold mixes, but not itself: a part named before its definition closes loops.
    expectError(ab + "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
                     "[\"a\" \"n\"]\n"
                     "MakeNamedMaterial \"n\" \"string type\" \"mix\" \"string materials\" "
                     "[\"m\" \"b\"]\n",
                "t.pbrt:4:1", "mix \"m\" contains itself (\"m\" -> \"n\" -> \"m\")");
    expectError(ab + "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
                     "[\"m\" \"b\"]\n",
                "t.pbrt:4:1", "mix \"m\" contains itself (\"m\" -> \"m\")");
    // Reached from a mix outside it, the loop is named alone, at its first member's definition.
    expectError(ab + "Material \"mix\" \"string materials\" [\"m\" \"b\"]\n"
                     "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
                     "[\"a\" \"n\"]\n"
                     "MakeNamedMaterial \"n\" \"string type\" \"mix\" \"string materials\" "
                     "[\"m\" \"b\"]\n",
                "t.pbrt:5:1", "mix \"m\" contains itself (\"m\" -> \"n\" -> \"m\")");
    // A mix of the same mix at each of 20 levels has 2^20 paths to its two materials.
    std::string doubling = ab + "MakeNamedMaterial \"m0\" \"string type\" \"mix\" "
                                "\"string materials\" [\"a\" \"b\"]\n";
    for (int level = 1; level <= 20; ++level)
        doubling += "MakeNamedMaterial \"m" + std::to_string(level) +
                    "\" \"string type\" \"mix\" \"string materials\" [\"m" +
                    std::to_string(level - 1) + "\" \"m" + std::to_string(level - 1) + "\"]\n";
    expectError(doubling, "t.pbrt:19:1", "mix \"m15\" nests mixes into more than 100000 parts");
}

TEST_CASE("parser: a mix of mixes blends its materials by the product of the amounts") {
    // pbrt-v4's amount is the second material's probability: m = 0.75 a + 0.25 n, and
    // n = 0.4 b + 0.6 a, so a weighs 0.75 + 0.25 x 0.6 and b 0.25 x 0.4.
    const auto s = cb::parseSceneString(
        std::string(kWorld) +
            "MakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n"
            "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" [\"a\" \"n\"] "
            "\"float amount\" 0.25\n"
            "MakeNamedMaterial \"b\" \"string type\" \"conductor\"\n"
            "MakeNamedMaterial \"n\" \"string type\" \"mix\" \"string materials\" [\"b\" \"a\"] "
            "\"float amount\" 0.6\n"
            "NamedMaterial \"m\"\nShape \"sphere\"\n",
        "t.pbrt");
    const auto leaves = cb::mixLeaves(s, 1);
    REQUIRE(leaves.size() == 2);
    CHECK(leaves[0].first == 0);
    CHECK(leaves[0].second == doctest::Approx(0.75 + 0.25 * 0.6).epsilon(1e-7));
    CHECK(leaves[1].first == 2);
    CHECK(leaves[1].second == doctest::Approx(0.25 * 0.4).epsilon(1e-7));
    CHECK(cb::mixLeaves(s, 0) == std::vector<std::pair<int, double>>{{0, 1.0}});
}

TEST_CASE("parser: block-structure errors") {
    const std::string w = kWorld;
    expectError(w + "AttributeEnd\n", "t.pbrt:2:1", "AttributeEnd without matching AttributeBegin");
    expectError(w + "AttributeBegin\nAttributeBegin\nAttributeEnd\n", "t.pbrt:2:1",
                "AttributeBegin without matching AttributeEnd");
    expectError("Shape \"sphere\"\n", "t.pbrt:1:1", "only allowed after WorldBegin");
    expectError("AttributeBegin\n", "t.pbrt:1:1", "only allowed after WorldBegin");
    expectError("ReverseOrientation\n", "t.pbrt:1:1", "only allowed after WorldBegin");
    expectError(w + "Camera \"perspective\"\n", "t.pbrt:2:1", "only allowed before WorldBegin");
    expectError(w + "Film \"rgb\"\n", "t.pbrt:2:1", "only allowed before WorldBegin");
    expectError("Camera \"perspective\"\nCamera \"perspective\"\n", "t.pbrt:2:1", "second Camera");
    expectError("Film \"rgb\"\nFilm \"rgb\"\n", "t.pbrt:2:1", "second Film");
}

TEST_CASE("parser: geometry errors") {
    const std::string w = kWorld;
    expectError(w + "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" "
                    "[0 1 3]\n",
                "t.pbrt:2:76", "index 3 out of range (the mesh has 3 vertices)");
    expectError(w + "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" "
                    "[0 -1 2]\n",
                "t.pbrt:2:74", "index -1 out of range");
    expectError(w + "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" "
                    "[0 1.5 2]\n",
                "t.pbrt:2:74", "expects integers");
    expectError(w + "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" "
                    "[0 1 2 0]\n",
                "t.pbrt:2:53", "a multiple of 3 values");
    expectError(w + "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0]\n", "t.pbrt:2:1",
                "may only be omitted for a single triangle");
    expectError(w + "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1]\n", "t.pbrt:2:22",
                "a multiple of 3 values");
    expectError(w + "Shape \"trianglemesh\" \"integer indices\" [0 1 2]\n", "t.pbrt:2:1",
                "needs \"point3 P\"");
    expectError(
        w + "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"normal N\" [0 0 1]\n",
        "t.pbrt:2:53", "one normal per vertex");
    expectError(w + "Scale 1 2 1\nShape \"sphere\"\n", "t.pbrt:3:1", "must be a similarity");
    expectError(w + "ConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0.5 0 0 0 1]\nShape \"sphere\"\n",
                "t.pbrt:3:1", "projective transformations are not supported");
    expectError(w + "Shape \"plymesh\"\n", "t.pbrt:2:1", "needs \"string filename\"");
    expectError("LookAt 0 0 0  0 0 0  0 1 0\n", "t.pbrt:1:1", "eye equals look point");
    expectError("LookAt 0 0 0  0 1 0  0 1 0\n", "t.pbrt:1:1", "up is parallel");
    expectError("Rotate 10 0 0 0\n", "t.pbrt:1:1", "axis has zero length");
}

TEST_CASE("parser: a file that cannot be read is named with the reason, without a line") {
    const fs::path dir =
        fs::temp_directory_path() / ("cbdpt-unreadable-" + std::to_string(getpid()));
    fs::create_directories(dir / "folder.pbrt");
    const auto errorOfFile = [](const fs::path& path) -> std::string {
        try {
            cb::parseSceneFile(path.string());
        } catch (const cb::SceneError& e) {
            return e.what();
        }
        return "<no error>";
    };
    CHECK(errorOfFile(dir / "missing.pbrt") ==
          (dir / "missing.pbrt").string() + ": cannot read the scene file: no such file");
    CHECK(errorOfFile(dir / "folder.pbrt") ==
          (dir / "folder.pbrt").string() +
              ": cannot read the scene file: it is a folder, not a file");
    { std::ofstream(dir / "main.pbrt") << "WorldBegin\nInclude \"gone.pbrt\"\n"; }
    // An included file's failure is located at the Include that names it.
    CHECK(contains(errorOfFile(dir / "main.pbrt"),
                   (dir / "main.pbrt").string() + ":2:9: cannot find included file \"gone.pbrt\""));
    fs::remove_all(dir);
}
