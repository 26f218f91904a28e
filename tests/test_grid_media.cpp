// pbrt-v4's "uniformgrid" media: sigma_a and sigma_s times a density trilinear between samples on
// a grid, in a box of the medium's own space. The density's integral along rays, the distance at
// which it reaches a value and the transmittance against a quadrature of pbrt-v4's lookup
// written apart; what the parser keeps and refuses; every method against the wall of a glowing
// sphere of grid fog seen through it, in a furnace of grid fog, and BDPT, CBDPT and MLT against
// PT in a box of it.
#include <doctest/doctest.h>

#include "cb_medium.h"
#include "fog_checks.h"
#include "method_checks.h"
#include "scene/device_scene.h"
#include "scene/nanovdb.h"
#include "scene_files.h"
#include "source_tree.h"
#include "test_render_util.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using namespace cbtest::fog_checks;
using namespace cbtest::method_checks;
using namespace cbtest::scene_files;

namespace {

using Point = std::array<double, 3>;

// A grid medium as the tests write it: nx x ny x nz densities (x fastest) over the box p0-p1 of
// its space, which a world point p reaches as S^-1 Rz(-angle) (p - translation): the CTM
// Translate, Rotate about z, Scale at its MakeNamedMedium.
struct Grid {
    std::array<int, 3> n{1, 1, 1};
    std::vector<double> density{1.0};
    Point p0{0, 0, 0}, p1{1, 1, 1};
    Point translation{0, 0, 0};
    double angle = 0.0; // degrees
    Point scale{1, 1, 1};
    double clip = 0.0; // samples: where the density ends inside the box (0.5 for nanovdb)

    // MakeNamedMedium "name" of this grid, sigma_a, sigma_s and g, and the CTM reset after it.
    std::string text(const std::string& name, const Rgb& sigmaA, const Rgb& sigmaS,
                     double g) const {
        std::string values;
        for (double d : density)
            values += fmt::format(" {}", d);
        return fmt::format("Translate {} {} {}\nRotate {} 0 0 1\nScale {} {} {}\n"
                           "MakeNamedMedium \"{}\" \"string type\" \"uniformgrid\" \"rgb "
                           "sigma_a\" [{} {} {}] \"rgb sigma_s\" [{} {} {}] \"float g\" {} "
                           "\"integer nx\" {} \"integer ny\" {} \"integer nz\" {} \"point3 p0\" "
                           "[{} {} {}] \"point3 p1\" [{} {} {}] \"float density\" [{}]\n"
                           "Identity\n",
                           translation[0], translation[1], translation[2], angle, scale[0],
                           scale[1], scale[2], name, sigmaA[0], sigmaA[1], sigmaA[2], sigmaS[0],
                           sigmaS[1], sigmaS[2], g, n[0], n[1], n[2], p0[0], p0[1], p0[2], p1[0],
                           p1[1], p1[2], values);
    }

    // pbrt-v4's density at world point p (GridMedium::SamplePoint, SampledGrid::Lookup): 0
    // outside the box (its sides moved `clip` samples in), else trilinear in the samples at (i +
    // 0.5) / n of the box, samples outside the grid 0.
    double at(const Point& p) const {
        const double c = std::cos(angle * M_PI / 180.0), s = std::sin(angle * M_PI / 180.0);
        const Point d{p[0] - translation[0], p[1] - translation[1], p[2] - translation[2]};
        const Point q{(c * d[0] + s * d[1]) / scale[0], (-s * d[0] + c * d[1]) / scale[1],
                      d[2] / scale[2]};
        std::array<int, 3> i0{};
        Point f{};
        for (size_t a = 0; a < 3; ++a) {
            const double u = (q[a] - p0[a]) / (p1[a] - p0[a]);
            const double sample = u * n[a] - 0.5;
            if (sample < clip - 0.5 || sample > n[a] - 0.5 - clip) return 0.0;
            i0[a] = int(std::floor(sample));
            f[a] = sample - i0[a];
        }
        double sum = 0.0;
        for (int corner = 0; corner < 8; ++corner) {
            double w = 1.0;
            std::array<int, 3> i{};
            for (size_t a = 0; a < 3; ++a) {
                const int bit = (corner >> a) & 1;
                i[a] = i0[a] + bit;
                w *= bit ? f[a] : 1.0 - f[a];
            }
            if (i[0] >= 0 && i[1] >= 0 && i[2] >= 0 && i[0] < n[0] && i[1] < n[1] && i[2] < n[2])
                sum += w * density[size_t((i[2] * n[1] + i[1]) * n[0] + i[0])];
        }
        return sum;
    }

    // The density's integral along o + t d (d of unit length), t in [0, tEnd]: the midpoint
    // rule over `steps` steps.
    double integral(const Point& o, const Point& d, double tEnd, int steps = 20000) const {
        const double h = tEnd / steps;
        double sum = 0.0;
        for (int k = 0; k < steps; ++k) {
            const double t = (k + 0.5) * h;
            sum += at({o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]});
        }
        return sum * h;
    }
};

// A grid of varying densities (one sample 0, some large), turned and stretched.
Grid lumpyGrid() {
    Grid g;
    g.n = {4, 3, 5};
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(0.0, 2.5);
    g.density.clear();
    for (int i = 0; i < 60; ++i)
        g.density.push_back(i == 17 ? 0.0 : std::round(u(rng) * 100.0) / 100.0);
    g.p0 = {-1.0, -0.8, -1.1};
    g.p1 = {0.9, 1.0, 1.2};
    g.translation = {0.1, -0.05, 0.08};
    g.angle = 30.0;
    g.scale = {1.1, 0.9, 1.0};
    return g;
}

cbk::Vec3 toDevice(const cb::DeviceScene& scene, const Point& p) {
    return cbk::vec3(float(p[0] - scene.origin[0]), float(p[1] - scene.origin[1]),
                     float(p[2] - scene.origin[2]));
}

Point unitVector(std::mt19937& rng) {
    std::normal_distribution<double> n;
    Point d{n(rng), n(rng), n(rng)};
    const double l = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    return {d[0] / l, d[1] / l, d[2] / l};
}

// The camera away from the world's origin (the device scene's coordinates are relative to it)
// in the grid medium "g", a sphere of radius 3 around it, a point light outside; `shapes` after.
std::string hostScene(const std::string& media, const std::string& shapes = "") {
    return media +
           "LookAt 0.7 -0.4 0.2  0 0 1  0 0 1\nMediumInterface \"\" \"g\"\n"
           "Camera \"perspective\"\nWorldBegin\nMediumInterface \"\" \"\"\n"
           "LightSource \"point\" \"point3 from\" [0 0 5]\n"
           "MediumInterface \"g\" \"\"\nShape \"sphere\" \"float radius\" 3\n" +
           shapes;
}

} // namespace

TEST_CASE("grid media: the density's integral along rays against pbrt-v4's lookup") {
    TempDirCleanup cleanup;
    // One sample of 1 at the box's centre, its neighbours outside the grid 0: along the axis
    // through it the density rises from 0.5 at the faces to 1, integral 0.75.
    {
        const Grid one;
        const cb::DeviceScene scene =
            cb::buildDeviceScene(parseInTemp(hostScene(one.text("g", {1, 1, 1}, {0, 0, 0}, 0.0))));
        const cbk::SceneView view = cbtest::hostView(scene);
        const int grid = cbk::mediumGrid(&view, scene.camera.medium);
        REQUIRE(grid >= 0);
        float length = 0.0f, t = 0.0f;
        CHECK(!cbk::gridDensityWalk(&view, grid, toDevice(scene, {-1, 0.5, 0.5}),
                                    cbk::vec3(1, 0, 0), CB_INFINITY, CB_INFINITY, &length, &t));
        CHECK(length == doctest::Approx(0.75).epsilon(1e-6));
    }
    const Grid g = lumpyGrid();
    const cb::DeviceScene scene =
        cb::buildDeviceScene(parseInTemp(hostScene(g.text("g", {1, 1, 1}, {0, 0, 0}, 0.0))));
    REQUIRE((scene.features & CB_FEATURE_GRID_MEDIUM) != 0);
    REQUIRE(std::fabs(scene.origin[0]) > 0.5); // the device coordinates are shifted
    const cbk::SceneView view = cbtest::hostView(scene);
    const int grid = cbk::mediumGrid(&view, scene.camera.medium);
    REQUIRE(grid >= 0);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-2.0, 2.0), fraction(0.05, 0.95);
    int crossing = 0;
    for (int k = 0; k < 300; ++k) {
        CAPTURE(k);
        // Origins inside the box and out, rays that end in it and that leave it.
        const Point o{u(rng), u(rng), u(rng)};
        const Point d = unitVector(rng);
        const double tMax = k % 3 == 0 ? CB_INFINITY : 0.5 + 4.0 * fraction(rng);
        const double expected = g.integral(o, d, std::min(tMax, 8.0));
        float length = 0.0f, t = 0.0f;
        CHECK(!cbk::gridDensityWalk(&view, grid, toDevice(scene, o),
                                    cbk::vec3(float(d[0]), float(d[1]), float(d[2])), float(tMax),
                                    CB_INFINITY, &length, &t));
        CHECK(length == doctest::Approx(expected).epsilon(2e-4).scale(1.0));
        if (!(expected > 0.05)) continue;
        ++crossing;
        // The distance at which the integral reaches a share of it, and nothing beyond it.
        const double target = fraction(rng) * expected;
        REQUIRE(cbk::gridDensityWalk(&view, grid, toDevice(scene, o),
                                     cbk::vec3(float(d[0]), float(d[1]), float(d[2])), float(tMax),
                                     float(target), &length, &t));
        CHECK(length == float(target));
        CHECK(t >= 0.0f);
        CHECK(t <= float(tMax));
        CHECK(g.integral(o, d, t) == doctest::Approx(target).epsilon(2e-4).scale(1.0));
        CHECK(!cbk::gridDensityWalk(&view, grid, toDevice(scene, o),
                                    cbk::vec3(float(d[0]), float(d[1]), float(d[2])), float(tMax),
                                    float(expected * 1.01 + 1e-3), &length, &t));
    }
    CHECK(crossing > 50);
}

TEST_CASE("grid media: transmittance and an absorbing segment, beside a homogeneous medium") {
    TempDirCleanup cleanup;
    const Grid g = lumpyGrid();
    const Rgb sigmaA{0.4, 1.0, 2.5};
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(
        hostScene(g.text("g", sigmaA, {0, 0, 0}, 0.0) + namedMedium("h", {0.5, 1, 2}, {0, 0, 0}, 0),
                  "MediumInterface \"h\" \"g\"\nShape \"sphere\" \"float radius\" 0.1\n")));
    const cbk::SceneView view = cbtest::hostView(scene);
    const int medium = scene.camera.medium;
    const int homogeneous = scene.materials.back().mediumInside;
    REQUIRE(homogeneous >= 0);
    CHECK(cbk::mediumGrid(&view, homogeneous) < 0);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    for (int k = 0; k < 40; ++k) {
        CAPTURE(k);
        const Point o{u(rng), u(rng), u(rng)};
        const Point d = unitVector(rng);
        const float tMax = k % 2 ? CB_INFINITY : 1.7f;
        const double length = g.integral(o, d, std::min(double(tMax), 8.0));
        const cbk::Vec3 od = toDevice(scene, o),
                        dd = cbk::vec3(float(d[0]), float(d[1]), float(d[2]));
        const cbk::Spectrum tr = cbk::mediumTransmittance(&view, medium, od, dd, tMax);
        cbk::MediumTrack track = cbk::mediumTrackStart(medium);
        cbk::Spectrum throughput = cbk::specConst(2.0f);
        float t = 0.0f;
        const cbk::SampleStream stream{};
        CHECK(cbk::mediumRaySegment(&view, &track, &throughput, stream, 0u, od, dd, tMax, &t) == 0);
        for (size_t c = 0; c < 3; ++c) {
            CHECK(tr.c[c] ==
                  doctest::Approx(std::exp(-sigmaA[c] * length)).epsilon(3e-4).scale(1.0));
            CHECK(throughput.c[c] == doctest::Approx(2.0 * tr.c[c]).epsilon(1e-6));
        }
        // The homogeneous medium's transmittance is its length's, wherever the segment lies.
        const cbk::Spectrum th = cbk::mediumTransmittance(&view, homogeneous, od, dd, 0.8f);
        for (size_t c = 0; c < 3; ++c)
            CHECK(th.c[c] == doctest::Approx(std::exp(-0.8 * std::array{0.5, 1.0, 2.0}[c])));
    }
}

TEST_CASE("grid media: the parser keeps the grid and refuses, naming the file, line and value") {
    TempDirCleanup cleanup;
    const Grid g = lumpyGrid();
    const cb::SceneDesc desc = parseInTemp(hostScene(g.text("g", {1, 1, 1}, {2, 2, 2}, 0.3)));
    const cb::MediumDesc& m = desc.media.at(0);
    CHECK(m.density.size() == 60);
    CHECK(m.density[17] == 0.0f);
    CHECK(m.samples == std::array<int, 3>{4, 3, 5});
    CHECK(m.p0 == g.p0);
    CHECK(m.p1 == g.p1);
    // A scene without grids compiles none of it.
    const cb::DeviceScene plain =
        cb::buildDeviceScene(parseInTemp(hostScene(namedMedium("g", {1, 1, 1}, {0, 0, 0}, 0))));
    CHECK((plain.features & CB_FEATURE_GRID_MEDIUM) == 0);
    CHECK(contains(cb::buildDeviceScene(desc).featureNames(), "grid-medium"));

    auto grid = [](const std::string& parameters, const std::string& ctm = "") {
        return hostScene(ctm + "MakeNamedMedium \"g\" \"string type\" \"uniformgrid\" " +
                         parameters + "\nIdentity\n");
    };
    CHECK(contains(errorOf(grid("\"integer nx\" 2 \"float density\" [1 2 3]")),
                   "t.pbrt:1:64: \"float density\" has 3 values; nx x ny x nz = 2 x 1 x 1 = 2 "
                   "expected"));
    CHECK(contains(errorOf(grid("\"float density\" [1 -2]  \"integer nx\" 2")),
                   "t.pbrt:1:68: \"float density\" value 1 is -2; a density must be finite and "
                   ">= 0"));
    CHECK(contains(errorOf(grid("\"integer ny\" 0 \"float density\" [1]")),
                   "t.pbrt:1:62: \"integer ny\" must be at least 1, got 0"));
    CHECK(contains(errorOf(grid("\"float density\" [1] \"point3 p1\" [1 0 1]")),
                   "t.pbrt:1:1: medium \"g\": its box \"p0\" to \"p1\" has no extent along y (0 "
                   "to 0)"));
    CHECK(contains(errorOf(grid("\"float density\" [1]", "Scale 1 0 1\n")),
                   "t.pbrt:2:1: medium \"g\" needs an invertible affine transform"));
    CHECK(errorOf(grid("\"float density\" [1]")).empty());
    CHECK(contains(errorOf(grid("\"float density\" [1] \"rgb Le\" [1 1 1]")),
                   "t.pbrt:1:1: medium \"g\" emits (its \"Le\" is not 0): cbdpt renders "
                   "\"homogeneous\", \"uniformgrid\" and \"nanovdb\" media of \"sigma_a\" and "
                   "\"sigma_s\" "
                   "without \"Le\" (the camera sits in it at "));
    CHECK(contains(errorOf(grid("\"float density\" [1] \"float temperature\" [900]")),
                   "medium \"g\" emits (it has a \"temperature\" grid)"));
    // pbrt-v4 needs the densities; media nothing sits in are no errors.
    CHECK(contains(errorOf(grid("\"integer nx\" 1")),
                   "of type \"uniformgrid\" needs \"float density\""));
    CHECK(errorOf("MakeNamedMedium \"g\" \"string type\" \"uniformgrid\" \"float density\" [1] "
                  "\"float temperature\" [900]\nWorldBegin\n") == "");
}

// pbrt-v4's "nanovdb" media: scenes/pbrt-v4/volumes/ball.nvdb, written by NanoVDB's own builder
// (tests/nanovdb/make_ball.cpp), holds a "temperature" and a "density" grid, each a ball beside
// a block of constant leaves pruned into tiles; tests/nanovdb/ball-samples.txt, NanoVDB's
// trilinear sampler at 400 world points in and around the density grid. The grid as a
// "nanovdb" medium, looked up as pbrt-v4's uniformgrid (Grid::at, written apart), must give
// NanoVDB's values everywhere, tiles and leaves alike.
TEST_CASE("grid media: a NanoVDB file's grid samples as NanoVDB's own sampler") {
    TempDirCleanup cleanup;
    const std::string file = cbtest::sourcePath("scenes", "pbrt-v4", "volumes", "ball.nvdb");
    CHECK(cb::nanoVdbGridNames(file) == std::vector<std::string>{"temperature", "density"});
    const cb::NanoVdbGrid raw = cb::readNanoVdbGrid(file, "density");
    CHECK(raw.indexMin == std::array<int, 3>{2, 1, 1}); // NanoVDB's index bounds
    CHECK(raw.indexMax == std::array<int, 3>{39, 23, 19});
    CHECK(raw.matrix == std::array<double, 9>{0.25, 0, 0, 0, 0.25, 0, 0, 0, 0.25});
    CHECK(raw.translation == std::array<double, 3>{1.0, 2.0, -0.5});

    // The density grid alone (a file whose temperature grid has another name than the one
    // asked for): pbrt-v4 would emit from "temperature".
    const std::string medium = fmt::format(
        "MakeNamedMedium \"g\" \"string type\" \"nanovdb\" \"string filename\" \"{}\" "
        "\"string temperaturename\" \"heat\" \"rgb sigma_a\" [1 1 1] \"rgb sigma_s\" [1 1 1]\n",
        file);
    const cb::SceneDesc desc = parseInTemp(hostScene(medium));
    const cb::MediumDesc& m = desc.media.at(0);
    Grid g;
    g.n = m.samples;
    g.density.assign(m.density.begin(), m.density.end());
    g.p0 = m.p0;
    g.p1 = m.p1;
    std::ifstream samples(cbtest::sourcePath("tests", "nanovdb", "ball-samples.txt"));
    REQUIRE(samples);
    g.clip = m.clipSamples;
    std::string line;
    int count = 0, nonZero = 0;
    while (std::getline(samples, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream in(line);
        Point p{};
        double expected = 0.0;
        in >> p[0] >> p[1] >> p[2] >> expected;
        CAPTURE(line);
        ++count;
        nonZero += expected > 0.0;
        // pbrt-v4 clips the grid to its world bounds, index points indexMin to indexMax + 1
        // (NanoVDB's sampler goes on beyond them, towards the background).
        bool inBounds = true;
        for (size_t a = 0; a < 3; ++a) {
            const double u = (p[a] - raw.translation[a]) / 0.25;
            inBounds &= u >= raw.indexMin[a] && u <= raw.indexMax[a] + 1;
        }
        CHECK(g.at(p) == doctest::Approx(inBounds ? expected : 0.0).epsilon(1e-6).scale(1.0));
    }
    CHECK(count == 400);
    CHECK(nonZero > 100);
    // The kernels' walk along rays through it, clipped as pbrt-v4 clips it.
    const cb::DeviceScene scene = cb::buildDeviceScene(desc);
    const cbk::SceneView view = cbtest::hostView(scene);
    const int grid = cbk::mediumGrid(&view, scene.camera.medium);
    REQUIRE(grid >= 0);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> x(1.0, 11.5), y(1.8, 8.5), z(-0.7, 5.0);
    for (int k = 0; k < 100; ++k) {
        CAPTURE(k);
        const Point o{x(rng), y(rng), z(rng)};
        const Point d = unitVector(rng);
        float length = 0.0f, t = 0.0f;
        CHECK(!cbk::gridDensityWalk(&view, grid, toDevice(scene, o),
                                    cbk::vec3(float(d[0]), float(d[1]), float(d[2])), CB_INFINITY,
                                    CB_INFINITY, &length, &t));
        CHECK(length == doctest::Approx(g.integral(o, d, 16.0)).epsilon(2e-4).scale(1.0));
    }

    // The file's "temperature" grid emits: refused where something sits in the medium.
    const std::string emitting = fmt::format(
        "MakeNamedMedium \"g\" \"string type\" \"nanovdb\" \"string filename\" \"{}\"\n", file);
    CHECK(contains(errorOf(hostScene(emitting)),
                   "medium \"g\" emits (its file holds a \"temperature\" grid)"));
    // A missing grid, a missing file, a file that is not NanoVDB: errors naming them.
    auto nanovdb = [](const std::string& parameters) {
        return hostScene("MakeNamedMedium \"g\" \"string type\" \"nanovdb\" " + parameters + "\n");
    };
    const std::string named = fmt::format("\"string filename\" \"{}\" ", file);
    CHECK(contains(errorOf(nanovdb(named + "\"string gridname\" \"smoke\" "
                                           "\"string temperaturename\" \"heat\"")),
                   "no grid \"smoke\" (the file holds \"temperature\", \"density\")"));
    CHECK(contains(errorOf(nanovdb("\"string filename\" \"nowhere.nvdb\"")),
                   "t.pbrt:1:63: no NanoVDB file \"nowhere.nvdb\""));
    CHECK(contains(errorOf(nanovdb("")), "of type \"nanovdb\" needs \"string filename\""));
    // Corrupted copies: each byte changed in turn at 300 places, or the file cut short, the
    // reader returns or throws std::runtime_error (under the sanitizers, without a fault).
    std::ifstream original(file, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(original)), {});
    REQUIRE(bytes.size() > 100000);
    std::mt19937 corrupt(3);
    int refused = 0;
    for (int k = 0; k < 300; ++k) {
        std::string copy = k < 290 ? bytes : bytes.substr(0, bytes.size() * size_t(k - 289) / 11);
        if (k < 290) {
            // The headers, the grids' first nodes and anywhere.
            const size_t at = k < 100   ? corrupt() % 2048
                              : k < 200 ? bytes.size() / 2 + corrupt() % 4096
                                        : corrupt() % bytes.size();
            copy[at] = char(copy[at] ^ (1 << (corrupt() % 8)));
        }
        const std::string path = (cbtest::scene_files::tempDir() / "corrupt.nvdb").string();
        std::ofstream(path, std::ios::binary) << copy;
        try {
            (void)cb::readNanoVdbGrid(path, "density", std::uint64_t(1) << 24);
        } catch (const std::runtime_error& e) {
            ++refused;
            CHECK(contains(e.what(), "corrupt.nvdb"));
        }
    }
    CHECK(refused > 10);
    const std::string notNanoVdb = writeImage("not.exr", 2, 2, [](int, int, int) { return 1.f; });
    CHECK(contains(errorOf(nanovdb("\"string filename\" \"not.exr\"")), "not a NanoVDB file"));
    (void)notNanoVdb;
}

// Every method's image through a sphere of grid fog, paths of 2 vertices (the camera at the
// centre, the glowing wall): per channel the wall's radiance times exp(-sigma_t D), D the
// density's integral along each camera ray, averaged over the film (box filter: each pixel's
// samples on its own area). Coloured absorption and scattering, so that the distance sampling's
// weights must leave exactly the transmittance where nothing scatters.
TEST_CASE("grid media: every method sees the wall through a sphere of grid fog" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    const Grid g = lumpyGrid();
    const Rgb sigmaA{0.1, 0.3, 0.6}, sigmaS{1.2, 0.7, 0.3};
    const double radius = 1.2, glow = 2.0, tanHalf = std::tan(M_PI / 6.0);
    const cb::DeviceScene scene = cb::buildDeviceScene(parseInTemp(fogSphereScene(
        "PixelFilter \"box\"\n" + g.text("fog", sigmaA, sigmaS, 0.6), radius, glow)));
    REQUIRE((scene.features & CB_FEATURE_GRID_MEDIUM) != 0);
    Rgb expected{};
    int samples = 0;
    forEachFilmSample(8, 6, tanHalf, [&](int, int, double fx, double fy) {
        const double l = std::sqrt(fx * fx + fy * fy + 1.0);
        const double length = g.integral({0, 0, 0}, {fx / l, fy / l, 1.0 / l}, radius, 4000);
        for (size_t c = 0; c < 3; ++c)
            expected[c] += glow * std::exp(-(sigmaA[c] + sigmaS[c]) * length);
        ++samples;
    });
    for (double& e : expected)
        e /= samples;
    for (const std::string method : kMethods) {
        CAPTURE(method);
        checkChannelMeans(channelMeans16(scene, runtime, pathSettings(method, 2), 4, 81u), expected,
                          1e-4);
    }
}

// A grid fog that does not absorb, inside a wall that glows: the radiance is the wall's
// everywhere, however the density varies (checkEveryMethodKeepsGlow), per channel of sigma_s.
TEST_CASE("grid media: every method in a furnace of grid fog keeps the wall's radiance" *
          doctest::test_suite("statistical")) {
    TempDirCleanup cleanup;
    cb::ClRuntime runtime;
    // Twice the densities at half the coefficients: a homogeneous medium of sigma_s would see
    // about half the grid's optical depths.
    Grid g = lumpyGrid();
    for (double& d : g.density)
        d *= 2.0;
    const cb::DeviceScene scene = cb::buildDeviceScene(
        parseInTemp(fogSphereScene(g.text("fog", {0, 0, 0}, {0.6, 0.25, 0}, 0.3), 1.0, 1.5)));
    REQUIRE((scene.features & CB_FEATURE_GRID_MEDIUM) != 0);
    checkEveryMethodKeepsGlow(scene, runtime, 1.5, 91u);
}

// Every strategy in grid fog (checkMethodsAgreeWithPtInFogBox), bounded by an interface.
TEST_CASE("grid media: BDPT, CBDPT and MLT agree with PT inside a box of grid fog" *
          doctest::test_suite("statistical")) {
    Grid g = lumpyGrid();
    g.p0 = {-2.2, -0.2, -3.5};
    g.p1 = {2.2, 2.2, 1.2};
    g.angle = 0.0;
    g.scale = {1, 1, 1};
    g.translation = {0, 0, 0};
    for (double& d : g.density)
        d *= 0.4;
    checkMethodsAgreeWithPtInFogBox("Material \"interface\"\n",
                                    g.text("fog", {0.05, 0.1, 0.2}, {0.6, 0.4, 0.3}, 0.3));
}
