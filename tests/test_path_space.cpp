// Which paths each method's caps cover (docs/bdpt.md, "Which paths each method computes").
//
// The thesis's per-subpath caps Ne + Nl leave out paths whose only strategies would connect at
// a delta vertex; the total-length cap N (pbrt-v4, SmallVCM) keeps every strategy with
// s + t <= N. On a scene with a planar mirror, a point light and diffuse walls, the paths that
// differ between the conventions are known in closed form (the mirror's virtual images), so each
// method's image is checked against PT plus or minus exactly those paths:
//   - BDPT 2+2 misses camera-mirror-diffuse-light (M): the only strategy of a 4-vertex path is
//     (2,2), which cannot connect at the mirror; PT 4 samples it by next-event estimation.
//   - With the total cap N = 4, BDPT (power weights) and CBDPT also render
//     camera-diffuse-mirror-light (C, the point light's caustic) by light tracing (t = 1), which
//     PT cannot sample at all; Lafortune's weights give t = 1 no weight, so they equal PT 4.
// M and C are integrated here over each pixel with an independent ray-quad tracer in double.
// Estimates are the independent samples (pixels of coherent estimates are correlated); per-pixel
// z-scores use the per-pixel spread across estimates.
#include "scene_builders.h"

#include "integrators/integrator.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"

#include "cb_bdpt.h"
#include "cb_camera.h"

#include "double_vectors.h"

#include <array>
#include <cmath>
#include <doctest/doctest.h>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace {

using namespace cbtest::double_vectors;

// A parallelogram corner + u * edgeU + v * edgeV, u, v in [0, 1].
struct Quad {
    V3 corner, edgeU, edgeV;
    double albedo; // diffuse reflectance, or the mirror's reflectance
    bool mirror;
    V3 normal() const { return unit(cross(edgeU, edgeV)); }
};

struct MirrorRoom {
    std::vector<Quad> quads; // quads[0] is the mirror
    V3 light;
    double intensity;
};

MirrorRoom mirrorRoom() {
    MirrorRoom r;
    // The mirror stands in the plane x = 0.8, seen at an angle by the camera (origin, +z).
    r.quads.push_back({{0.8, -1.0, 2.0}, {0.0, 0.0, 2.5}, {0.0, 2.0, 0.0}, 0.9, true});
    r.quads.push_back({{-3.0, -1.0, 0.5}, {0.0, 0.0, 5.5}, {6.0, 0.0, 0.0}, 0.6, false}); // floor
    // The back wall floats above the floor: a corner would make the (2,2) connection's
    // 1/r^2 a variance without bound, and per-pixel means far from Gaussian.
    r.quads.push_back({{-3.0, -0.5, 5.0}, {0.0, 3.5, 0.0}, {6.0, 0.0, 0.0}, 0.5, false}); // back
    r.light = {-0.5, 1.5, 2.5};
    r.intensity = 2.0;
    return r;
}

cb::SceneDesc mirrorRoomScene(const MirrorRoom& room, int size) {
    cb::SceneDesc d;
    d.path = "<mirror-room>";
    d.film.width = size;
    d.film.height = size;
    d.camera.fovDegrees = 60.f;
    for (const Quad& q : room.quads) {
        cb::MaterialDesc m;
        m.kind = q.mirror ? cb::MaterialKind::Conductor : cb::MaterialKind::Diffuse;
        m.reflectance = cb::SpectrumValue::constant(float(q.albedo));
        m.roughness = 0.f; // a perfect mirror: a delta lobe
        m.remapRoughness = false;
        d.materials.push_back(m);
        cb::TriangleMeshDesc mesh;
        mesh.positions = {q.corner, add(q.corner, q.edgeU), add(add(q.corner, q.edgeU), q.edgeV),
                          add(q.corner, q.edgeV)};
        mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
        mesh.material = int(d.materials.size()) - 1;
        d.meshes.push_back(mesh);
    }
    cb::PointLightDesc p;
    p.position = room.light;
    p.intensity = cb::SpectrumValue::constant(float(room.intensity));
    d.pointLights.push_back(p);
    return d;
}

struct QuadHit {
    int quad;
    double t;
    V3 p;
};

// Nearest quad hit along o + t d, t in (tMin, tMax), skipping quad `skip`.
std::optional<QuadHit> traceQuads(const MirrorRoom& room, V3 o, V3 d, double tMax, int skip) {
    std::optional<QuadHit> best;
    for (int i = 0; i < int(room.quads.size()); ++i) {
        if (i == skip) continue;
        const Quad& q = room.quads[size_t(i)];
        V3 n = cross(q.edgeU, q.edgeV);
        double denom = dot(n, d);
        if (std::fabs(denom) < 1e-12) continue;
        double t = dot(n, sub(q.corner, o)) / denom;
        if (!(t > 1e-7 && t < tMax)) continue;
        V3 p = add(o, mul(d, t));
        V3 rel = sub(p, q.corner);
        // Coordinates in the (edgeU, edgeV) basis; the quads here have orthogonal edges.
        double u = dot(rel, q.edgeU) / dot(q.edgeU, q.edgeU);
        double v = dot(rel, q.edgeV) / dot(q.edgeV, q.edgeV);
        if (u < 0 || u > 1 || v < 0 || v > 1) continue;
        if (!best || t < best->t) best = QuadHit{i, t, p};
    }
    return best;
}

bool segmentFree(const MirrorRoom& room, V3 a, V3 b, int skipA, int skipB) {
    V3 d = sub(b, a);
    double len = std::sqrt(dot(d, d));
    d = mul(d, 1.0 / len);
    for (int i = 0; i < int(room.quads.size()); ++i) {
        if (i == skipA || i == skipB) continue;
        MirrorRoom one;
        one.quads = {room.quads[size_t(i)]};
        if (traceQuads(one, a, d, len * (1 - 1e-7), -1)) return false;
    }
    return true;
}

// Direct light from the point light at diffuse point p of quad q, seen from `from`; 0 when the
// light and the viewer are on opposite sides or the light is hidden. Radiance toward `from`.
double directDiffuse(const MirrorRoom& room, int q, V3 p, V3 from) {
    const Quad& quad = room.quads[size_t(q)];
    V3 n = quad.normal();
    V3 toLight = sub(room.light, p);
    if (dot(n, toLight) * dot(n, sub(from, p)) <= 0) return 0;
    if (!segmentFree(room, p, room.light, q, -1)) return 0;
    double dist2 = dot(toLight, toLight);
    return quad.albedo / M_PI * room.intensity * std::fabs(dot(n, toLight)) / std::sqrt(dist2) /
           dist2;
}

// Radiance along one camera ray of the two path families of the header comment.
struct MissingRadiance {
    double mirrorThenDiffuse = 0; // M: camera-mirror-diffuse-light
    double caustic = 0;           // C: camera-diffuse-mirror-light
};

MissingRadiance missingAlongRay(const MirrorRoom& room, V3 o, V3 d) {
    MissingRadiance out;
    auto hit = traceQuads(room, o, d, 1e30, -1);
    if (!hit) return out;
    const Quad& first = room.quads[size_t(hit->quad)];
    if (first.mirror) {
        V3 n = first.normal();
        V3 r = sub(d, mul(n, 2 * dot(d, n)));
        auto second = traceQuads(room, hit->p, r, 1e30, hit->quad);
        if (second && !room.quads[size_t(second->quad)].mirror)
            out.mirrorThenDiffuse =
                first.albedo * directDiffuse(room, second->quad, second->p, hit->p);
        return out;
    }
    // The light reflected by the mirror reaches x as if from the light's mirror image.
    const Quad& mirror = room.quads[0];
    V3 nm = mirror.normal();
    V3 x = hit->p;
    double lightSide = dot(nm, sub(room.light, mirror.corner));
    double xSide = dot(nm, sub(x, mirror.corner));
    if (lightSide * xSide <= 0) return out;
    V3 image = sub(room.light, mul(nm, 2 * lightSide));
    V3 toImage = sub(image, x);
    MirrorRoom justMirror;
    justMirror.quads = {mirror};
    double dist = std::sqrt(dot(toImage, toImage));
    V3 dir = mul(toImage, 1.0 / dist);
    auto onMirror = traceQuads(justMirror, x, dir, dist, -1);
    if (!onMirror) return out;
    V3 m = onMirror->p;
    V3 nx = first.normal();
    if (dot(nx, dir) * dot(nx, sub(o, x)) <= 0) return out;
    if (!segmentFree(room, x, m, hit->quad, 0) || !segmentFree(room, m, room.light, 0, -1))
        return out;
    out.caustic = first.albedo / M_PI * mirror.albedo * room.intensity * std::fabs(dot(nx, dir)) /
                  (dist * dist);
    return out;
}

// Per-pixel mean and standard error, plus per-estimate means of grid x grid image regions.
struct ImageStats {
    int width = 0, height = 0;
    std::vector<double> mean, se;
    std::vector<double> regionMean, regionSe;
};

constexpr int kGrid = 4;

size_t regionOf(int x, int y, int w, int h) {
    return size_t((y * kGrid / h) * kGrid + x * kGrid / w);
}

ImageStats renderStats(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                       const cb::IntegratorSettings& settings, int estimates) {
    auto integrator = cb::makeIntegrator(settings, scene, runtime);
    const int w = scene.camera.width, h = scene.camera.height;
    const size_t pixels = size_t(w) * size_t(h), regions = size_t(kGrid * kGrid);
    std::vector<double> sum(pixels), sumSq(pixels), rSum(regions), rSumSq(regions);
    std::vector<float> rgb;
    for (int e = 0; e < estimates; ++e) {
        integrator->renderEstimate(std::uint32_t(e), rgb);
        std::vector<double> cells(regions, 0.0);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                size_t i = size_t(y * w + x);
                double v = (double(rgb[3 * i]) + rgb[3 * i + 1] + rgb[3 * i + 2]) / 3.0;
                sum[i] += v;
                sumSq[i] += v * v;
                cells[regionOf(x, y, w, h)] += v / double(pixels / regions);
            }
        for (size_t c = 0; c < regions; ++c) {
            rSum[c] += cells[c];
            rSumSq[c] += cells[c] * cells[c];
        }
    }
    REQUIRE(integrator->nonFiniteSamples() == 0);
    auto finish = [&](const std::vector<double>& s, const std::vector<double>& s2,
                      std::vector<double>& mean, std::vector<double>& se) {
        const double n = estimates;
        mean.resize(s.size());
        se.resize(s.size());
        for (size_t i = 0; i < s.size(); ++i) {
            mean[i] = s[i] / n;
            se[i] = std::sqrt(std::max(0.0, s2[i] / n - mean[i] * mean[i]) / (n - 1));
        }
    };
    ImageStats out;
    out.width = w;
    out.height = h;
    finish(sum, sumSq, out.mean, out.se);
    finish(rSum, rSumSq, out.regionMean, out.regionSe);
    return out;
}

// M and C per pixel (and per region) by jittered stratified sampling of each pixel's footprint
// (unbiased, with its standard error), through the renderer's camera model (the camera is not
// what is tested here).
struct MissingImages {
    ImageStats mirrorThenDiffuse, caustic;
};

MissingImages integrateMissing(const MirrorRoom& room, const cb::DeviceScene& scene) {
    const cbk::Camera& camera = scene.camera;
    const int w = camera.width, h = camera.height, strata = 16;
    std::mt19937 rng(12345);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    MissingImages out;
    for (ImageStats* s : {&out.mirrorThenDiffuse, &out.caustic}) {
        s->width = w;
        s->height = h;
        s->mean.assign(size_t(w * h), 0.0);
        s->se.assign(size_t(w * h), 0.0);
        s->regionMean.assign(size_t(kGrid * kGrid), 0.0);
        s->regionSe.assign(size_t(kGrid * kGrid), 0.0);
    }
    const double perRegion = double(w * h) / double(kGrid * kGrid);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const size_t p = size_t(y * w + x), r = regionOf(x, y, w, h);
            for (ImageStats* s : {&out.mirrorThenDiffuse, &out.caustic}) {
                // One value per stratum; the stratified estimate's variance is the sum of the
                // strata's variances, estimated from pairs of neighbouring strata.
                std::vector<double> values;
                for (int j = 0; j < strata; ++j)
                    for (int i = 0; i < strata; ++i) {
                        double rx = x + (i + uniform(rng)) / strata;
                        double ry = y + (j + uniform(rng)) / strata;
                        cbk::Ray ray = cbk::cameraGenerateRay(&camera, float(rx), float(ry),
                                                              cbk::vec3(0.0f, 0.0f, 0.0f));
                        // Device coordinates are world coordinates minus scene.origin.
                        V3 origin = add({ray.o.x, ray.o.y, ray.o.z}, scene.origin);
                        MissingRadiance m =
                            missingAlongRay(room, origin, unit({ray.d.x, ray.d.y, ray.d.z}));
                        values.push_back(s == &out.caustic ? m.caustic : m.mirrorThenDiffuse);
                    }
                const double n = double(values.size());
                double sum = 0, pairs = 0;
                for (size_t k = 0; k < values.size(); ++k)
                    sum += values[k];
                for (size_t k = 0; k + 1 < values.size(); k += 2)
                    pairs += (values[k] - values[k + 1]) * (values[k] - values[k + 1]) / 2.0;
                s->mean[p] = sum / n;
                s->se[p] = std::sqrt(pairs * 2.0) / n; // sum over strata of var / n^2
                s->regionMean[r] += s->mean[p] / perRegion;
                s->regionSe[r] += s->se[p] * s->se[p] / (perRegion * perRegion);
            }
        }
    for (ImageStats* s : {&out.mirrorThenDiffuse, &out.caustic})
        for (double& se : s->regionSe)
            se = std::sqrt(se);
    return out;
}

// Checks a ~= sum of signs[i] * parts[i]: every region within 4 combined standard errors, and,
// with perPixel, at most 0.5% of pixels beyond |z| = 4 (about 1 in 16000 expected by chance
// for Gaussian errors; the margin is for the heavier tails of a few estimates). The per-pixel
// test needs each pixel's mean to be near-Gaussian: not so for CBDPT's light tracing (16 light
// subpaths per estimate, each splat standing for 64 pixels' worth: most pixels see a caustic
// splat only a few times in 1024 estimates). Region means of whole estimates are near-Gaussian
// for every method.
void checkSum(const ImageStats& a, const std::vector<std::pair<double, const ImageStats*>>& parts,
              bool perPixel) {
    for (size_t r = 0; r < a.regionMean.size(); ++r) {
        double expected = 0, var = a.regionSe[r] * a.regionSe[r];
        for (auto [sign, part] : parts) {
            expected += sign * part->regionMean[r];
            var += part->regionSe[r] * part->regionSe[r];
        }
        CAPTURE(r);
        CAPTURE(a.regionMean[r]);
        CAPTURE(expected);
        CHECK(std::fabs(a.regionMean[r] - expected) <= 4.0 * std::sqrt(var) + 1e-5 * expected);
    }
    if (!perPixel) return;
    long beyond = 0, compared = 0;
    for (size_t p = 0; p < a.mean.size(); ++p) {
        double expected = 0, var = a.se[p] * a.se[p];
        for (auto [sign, part] : parts) {
            expected += sign * part->mean[p];
            var += part->se[p] * part->se[p];
        }
        if (var <= 0) {
            CHECK(std::fabs(a.mean[p] - expected) <= 1e-6);
            continue;
        }
        ++compared;
        if (std::fabs(a.mean[p] - expected) > 4.0 * std::sqrt(var)) ++beyond;
    }
    CAPTURE(beyond);
    CAPTURE(compared);
    CHECK(double(beyond) <= 0.005 * double(compared));
}

// The image-mean of `part`, in standard errors of the difference it must explain.
double significance(const ImageStats& part, const ImageStats& a, const ImageStats& b) {
    double mean = 0, var = 0;
    for (size_t r = 0; r < part.regionMean.size(); ++r) {
        mean += part.regionMean[r];
        var += a.regionSe[r] * a.regionSe[r] + b.regionSe[r] * b.regionSe[r];
    }
    return mean / std::sqrt(var);
}

cb::IntegratorSettings settingsFor(const char* name, int ne, int nl, int total,
                                   std::uint32_t seed) {
    cb::IntegratorSettings s;
    s.name = name;
    s.eyeVertices = ne;
    s.lightVertices = nl;
    s.maxPathVertices = total;
    s.rouletteVertex = 0;
    s.seed = seed;
    return s;
}

} // namespace

TEST_CASE("Path space: BDPT 2+2 misses exactly camera-mirror-diffuse-light, the total cap "
          "misses none" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    const MirrorRoom room = mirrorRoom();
    cb::DeviceScene scene = cb::buildDeviceScene(mirrorRoomScene(room, 32));
    const MissingImages missing = integrateMissing(room, scene);
    const int estimates = 1024;
    const ImageStats pt = renderStats(scene, runtime, settingsFor("pt", 4, 1, 0, 11), estimates);

    SUBCASE("BDPT 2+2 = PT 4 - M") {
        ImageStats b = renderStats(scene, runtime, settingsFor("bdpt", 2, 2, 0, 12), estimates);
        checkSum(b, {{1.0, &pt}, {-1.0, &missing.mirrorThenDiffuse}}, true);
        // The test can fail: M is far beyond the noise.
        CHECK(significance(missing.mirrorThenDiffuse, pt, b) > 10.0);
    }
    SUBCASE("BDPT and CBDPT with the total cap 4 = PT 4 + C (power); Lafortune = PT 4") {
        ImageStats b = renderStats(scene, runtime, settingsFor("bdpt", 2, 2, 4, 13), estimates);
        checkSum(b, {{1.0, &pt}, {1.0, &missing.caustic}}, true);
        CHECK(significance(missing.caustic, pt, b) > 10.0);

        cb::IntegratorSettings lafortune = settingsFor("bdpt", 2, 2, 4, 14);
        lafortune.weights = "lafortune";
        checkSum(renderStats(scene, runtime, lafortune, estimates), {{1.0, &pt}}, true);

        cb::IntegratorSettings coherent = settingsFor("cbdpt", 2, 2, 4, 15);
        coherent.coherenceTile = 4;
        checkSum(renderStats(scene, runtime, coherent, estimates),
                 {{1.0, &pt}, {1.0, &missing.caustic}}, false);
    }
}

TEST_CASE("Path space: a glass sphere under BDPT 3+2 loses light that the total cap 5 keeps" *
          doctest::test_suite("statistical")) {
    // A diffuse box, a square ceiling light and a glass sphere (eta 1.5): camera-glass-glass-
    // diffuse-light has 5 vertices and only the (2,3) strategy under 3+2, which would connect at
    // the second glass vertex.
    cb::ClRuntime runtime;
    cb::SceneDesc d = cbtest::furnaceScene(0.6f, 0.0f, 24);
    d.path = "<glass-box>";
    d.areaLights.clear();
    d.meshes.clear();
    d.camera.fovDegrees = 70.f;
    d.meshes.push_back(cbtest::insideOutBox(-1.f, 1.f, 0, -1));
    cb::MaterialDesc emitterMaterial = d.materials[0];
    d.materials.push_back(emitterMaterial);
    cb::AreaLightDesc light;
    light.radiance = cb::SpectrumValue::constant(5.f);
    d.areaLights.push_back(light);
    cb::TriangleMeshDesc lamp;
    lamp.positions = {{-0.3, 0.98, 0.0}, {0.3, 0.98, 0.0}, {0.3, 0.98, 0.6}, {-0.3, 0.98, 0.6}};
    lamp.triangles = {{0, 1, 2}, {0, 2, 3}};
    lamp.material = 1;
    lamp.areaLight = 0;
    d.meshes.push_back(lamp);
    cb::MaterialDesc glass;
    glass.kind = cb::MaterialKind::Dielectric;
    glass.eta = 1.5f;
    d.materials.push_back(glass);
    cb::SphereDesc sphere;
    sphere.center = {0.1, -0.55, 0.45};
    sphere.radius = 0.4f;
    sphere.material = 2;
    d.spheres.push_back(sphere);
    cb::DeviceScene scene = cb::buildDeviceScene(d);

    const int estimates = 512;
    const ImageStats pt = renderStats(scene, runtime, settingsFor("pt", 5, 1, 0, 21), estimates);
    for (const char* method : {"bdpt", "cbdpt"}) {
        CAPTURE(method);
        ImageStats total = renderStats(scene, runtime, settingsFor(method, 3, 2, 5, 22), estimates);
        checkSum(total, {{1.0, &pt}}, std::string(method) == "bdpt");
    }
    ImageStats capped = renderStats(scene, runtime, settingsFor("bdpt", 3, 2, 0, 23), estimates);
    double diff = 0, var = 0;
    for (size_t r = 0; r < pt.regionMean.size(); ++r) {
        diff += pt.regionMean[r] - capped.regionMean[r];
        var += pt.regionSe[r] * pt.regionSe[r] + capped.regionSe[r] * capped.regionSe[r];
    }
    CAPTURE(diff);
    CHECK(diff > 6.0 * std::sqrt(var)); // darker, by far more than the noise
}

TEST_CASE("Path space: the total cap resolves to subpath caps N and N - 1 and bounds s + t") {
    cb::IntegratorSettings s;
    s.eyeVertices = 8;
    s.lightVertices = 4;
    s.maxPathVertices = 6;
    cb::IntegratorSettings r = cb::withResolvedCaps(s);
    CHECK(r.eyeVertices == 6);
    CHECK(r.lightVertices == 5);
    s.maxPathVertices = 0;
    CHECK(cb::withResolvedCaps(s).eyeVertices == 8);
    CHECK(cb::withResolvedCaps(s).lightVertices == 4);

    cbk::BdptSettings b{};
    b.eyeVertices = 6;
    b.lightVertices = 5;
    b.maxPathVertices = 6;
    b.debugS = b.debugT = -1;
    for (int k = 2; k <= 11; ++k)
        for (int s2 = 0; s2 < k; ++s2) {
            int t = k - s2;
            bool expected = k <= 6 && s2 <= 5 && t <= 6 && !(s2 == 1 && t == 1);
            CAPTURE(s2);
            CAPTURE(t);
            CHECK(cbk::bdptStrategyExists(s2, t, b) == expected);
        }

    cb::ClRuntime runtime;
    cb::DeviceScene scene = cb::buildDeviceScene(cbtest::furnaceScene(0.5f, 1.0f, 8));
    s.name = "bdpt";
    for (int bad : {-1, 1, 1025}) {
        s.maxPathVertices = bad;
        CHECK_THROWS_AS(cb::makeIntegrator(s, scene, runtime), std::invalid_argument);
    }
    s.maxPathVertices = 65; // Ne = 65 exceeds the bidirectional methods' private arrays
    CHECK_THROWS_AS(cb::makeIntegrator(s, scene, runtime), std::invalid_argument);
}
