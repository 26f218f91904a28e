// The Sobol sampler (kernels/cb_rng.h) and sphere lights sampled by the cone they subtend
// (kernels/cb_lights.h): nets, uniformity of every estimate, decorrelated dimension pairs, the
// cone's density, and renders against analytic values with both samplers.
#include "scene_builders.h"
#include "test_render_util.h"

#include "chi2.h"
#include "integrators/integrator.h"
#include "scene/device_scene.h"

#include "cb_bdpt.h"
#include "cb_camera.h"
#include "cb_lights.h"
#include "cb_rng.h"

#include <doctest/doctest.h>

#include <cmath>
#include <random>
#include <vector>

using namespace cbk;

namespace {

// Chi-square tests in this file share one family-wise level of 1% (Sidak).
const double kLevel = cbtest::sidak(0.01, 4);

double sobolValue(uint key, uint index, uint dimension) {
    return double(cbUintToUnitFloat(sobolSample(key, cbReverseBits(index), dimension)));
}

// Whether points (x, y) form a (0,k,2)-net in base 2: every elementary interval of area 2^-k
// holds exactly one of the 2^k points.
bool isNet(const std::vector<double>& x, const std::vector<double>& y, int k) {
    const size_t n = size_t(1) << k;
    for (int a = 0; a <= k; ++a) {
        std::vector<int> count(n, 0);
        for (size_t i = 0; i < n; ++i) {
            size_t cx = size_t(x[i] * double(1 << a));
            size_t cy = size_t(y[i] * double(1 << (k - a)));
            ++count[cx * (size_t(1) << (k - a)) + cy];
        }
        for (int c : count)
            if (c != 1) return false;
    }
    return true;
}

// A diffuse plane z = 2 facing the camera (at the origin, looking +z) lit only by a sphere light
// above the view. A sphere of radiance L entirely above a point's horizon gives irradiance
// pi L (r/d)^2 cos(theta) there, so the plane reflects rho L (r/d)^2 cos(theta).
struct SphereLitPlane {
    double rho = 0.5, radiance = 4.0, radius = 0.25;
    std::array<double, 3> center{0.0, 1.5, 1.3}; // out of view (fov 60)

    cb::SceneDesc desc(int size) const {
        cb::SceneDesc d;
        d.path = "<sphere-lit plane>";
        d.film.width = d.film.height = size;
        d.camera.fovDegrees = 60.f;
        cb::MaterialDesc plane;
        plane.kind = cb::MaterialKind::Diffuse;
        plane.reflectance = cb::SpectrumValue::constant(float(rho));
        cb::MaterialDesc black = plane;
        black.reflectance = cb::SpectrumValue::constant(0.f);
        d.materials = {plane, black};
        cb::TriangleMeshDesc mesh;
        mesh.positions = {{-4, -4, 2}, {4, -4, 2}, {4, 4, 2}, {-4, 4, 2}};
        mesh.triangles = {{0, 2, 1}, {0, 3, 2}}; // normal -z, toward the camera
        mesh.material = 0;
        d.meshes.push_back(mesh);
        cb::AreaLightDesc light;
        light.radiance = cb::SpectrumValue::constant(float(radiance));
        d.areaLights.push_back(light);
        cb::SphereDesc sphere;
        sphere.center = center;
        sphere.radius = float(radius);
        sphere.material = 1;
        sphere.areaLight = 0;
        d.spheres.push_back(sphere);
        return d;
    }

    // The image's mean value: the reflected radiance averaged over every pixel's area (the
    // kernels jitter uniformly in the pixel), by an 8 x 8 midpoint rule per pixel.
    double expectedMean(const cb::DeviceScene& scene) const {
        const Camera& camera = scene.camera;
        const auto& o = scene.origin; // device coordinates are world minus this
        double sum = 0.0;
        const int sub = 8;
        for (int y = 0; y < camera.height; ++y)
            for (int x = 0; x < camera.width; ++x)
                for (int j = 0; j < sub; ++j)
                    for (int i = 0; i < sub; ++i) {
                        Ray ray =
                            cameraGenerateRay(&camera, real(x + (i + 0.5) / sub),
                                              real(y + (j + 0.5) / sub), vec3(0.0f, 0.0f, 0.0f));
                        double t = (2.0 - o[2] - double(ray.o.z)) / double(ray.d.z);
                        double p[3] = {o[0] + ray.o.x + t * ray.d.x, o[1] + ray.o.y + t * ray.d.y,
                                       2.0};
                        double d[3] = {center[0] - p[0], center[1] - p[1], center[2] - p[2]};
                        double dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                        double cosTheta = -d[2] / std::sqrt(dist2);
                        sum += rho * radiance * radius * radius / dist2 * cosTheta;
                    }
        return sum / double(camera.width * camera.height * sub * sub);
    }
};

// Image means of `runs` renders (seeds 1..runs) of `estimates` estimates each: the mean over
// runs and its standard error from their spread (valid for correlated pixels and estimates).
cbtest::RunStats imageMeans(const cb::DeviceScene& scene, cb::ClRuntime& runtime,
                            cb::IntegratorSettings settings, int runs, int estimates) {
    std::vector<std::vector<double>> values;
    for (int r = 0; r < runs; ++r) {
        settings.seed = std::uint32_t(1 + r);
        auto integrator = cb::makeIntegrator(settings, scene, runtime);
        std::vector<float> rgb;
        double sum = 0.0;
        for (int e = 0; e < estimates; ++e) {
            integrator->renderEstimate(std::uint32_t(e), rgb);
            for (size_t i = 0; i + 2 < rgb.size(); i += 3)
                sum += (double(rgb[i]) + rgb[i + 1] + rgb[i + 2]) / 3.0;
        }
        values.push_back({sum / double(estimates) / double(rgb.size() / 3)});
        CHECK(integrator->nonFiniteSamples() == 0);
    }
    return cbtest::summarizeRuns(values);
}

} // namespace

TEST_CASE("Sobol sampler: the first 2^k estimates of every dimension pair are a (0,k,2)-net") {
    for (uint key : {0u, 1u, 0xdeadbeefu, 12345u})
        for (uint pair : {0u, 1u, 2u, 7u, 40u})
            for (int k : {1, 3, 6, 9}) {
                const size_t n = size_t(1) << k;
                std::vector<double> x(n), y(n);
                for (size_t i = 0; i < n; ++i) {
                    x[i] = sobolValue(key, uint(i), 2 * pair);
                    y[i] = sobolValue(key, uint(i), 2 * pair + 1);
                }
                CAPTURE(key);
                CAPTURE(pair);
                CAPTURE(k);
                CHECK(isNet(x, y, k));
            }
}

TEST_CASE("Sobol sampler: the second dimension's closed form is its direction numbers' sum") {
    // Direction numbers of the polynomial x + 1 (m_1 = 1): v_1 = 2^31, v_k = v_{k-1} ^ v_{k-1} >>
    // 1; the point is the xor of v_k over the index's set bits k.
    auto byDirectionNumbers = [](uint index) {
        uint point = 0u, v = 0x80000000u;
        for (; index != 0u; index >>= 1, v ^= v >> 1)
            if (index & 1u) point ^= v;
        return point;
    };
    std::vector<uint> indices;
    for (uint i = 0; i < 4096; ++i)
        indices.push_back(i);
    for (uint i = 0; i < 4096; ++i)
        indices.push_back(cbHash32(i));
    for (uint index : indices) {
        CAPTURE(index);
        CHECK(cbReverseBits(byDirectionNumbers(index)) == sobolSecondDimensionReversed(index));
    }
}

TEST_CASE("sampleAt2 reads the same two values as two sampleAt calls, for every sampler") {
    std::vector<float> table(10 * 12); // streams 0-9 x 12 dimensions, as samplerStreamShared reads
    for (size_t d = 0; d < table.size(); ++d)
        table[d] = 0.003f * float(d + 1);
    for (int kind : {CB_SAMPLER_INDEPENDENT, CB_SAMPLER_SOBOL})
        for (uint estimate : {0u, 1u, 5u, 1000u, 0x7fffffffu})
            for (uint stream : {0u, 4u, 9u})
                for (uint shared : {0u, 12u}) {
                    SamplerSettings sampler{};
                    sampler.seed = 17u;
                    sampler.kind = kind;
                    SampleStream s =
                        samplerStreamShared(sampler, estimate, stream, table.data(), shared);
                    for (uint d = 0; d < 40; ++d) {
                        real u0 = -1.0f, u1 = -1.0f;
                        sampleAt2(s, d, &u0, &u1);
                        CAPTURE(kind);
                        CAPTURE(estimate);
                        CAPTURE(d);
                        CHECK(u0 == sampleAt(s, d));
                        CHECK(u1 == sampleAt(s, d + 1u));
                    }
                }
}

TEST_CASE(
    "Sobol sampler: the index shuffle maps every power-of-two prefix of estimates onto itself") {
    for (uint key : {3u, 77u, 0xfeedfaceu}) {
        std::vector<int> seen(1024, 0);
        for (uint i = 0; i < 1024; ++i) {
            uint s = sobolShuffleIndex(i, key);
            // [0, 2^k) for the smallest k holding i: the same power-of-two block.
            uint block = 1;
            while (block <= i)
                block <<= 1;
            CHECK(s < block);
            if (s < 1024) ++seen[s];
        }
        for (int c : seen)
            CHECK(c == 1);
    }
}

TEST_CASE("Sobol sampler: one estimate's BDPT light subpaths are a net over the whole image") {
    // Every light subpath splats into every pixel (t = 1), so the W*H subpaths of one estimate
    // are one block of an image-wide sequence: with 2^k streams, each pair of their dimensions
    // is a (0,k,2)-net; with fewer, no elementary interval of area 2^-k holds two of them.
    for (uint seed : {1u, 7u})
        for (uint estimate : {0u, 1u, 13u})
            for (uint pair : {0u, 1u, 4u}) {
                SamplerSettings sampler{seed, CB_SAMPLER_SOBOL, {0, 0}};
                const int k = 10;
                const uint n = 1u << k;
                std::vector<double> x(n), y(n);
                for (uint stream = 0; stream < n; ++stream) {
                    SampleStream s = bdptLightStream(sampler, estimate, stream, n);
                    x[stream] = double(sampleAt(s, 2 * pair));
                    y[stream] = double(sampleAt(s, 2 * pair + 1));
                }
                CAPTURE(seed);
                CAPTURE(estimate);
                CAPTURE(pair);
                CHECK(isNet(x, y, k));
                // 1000 streams (not a power of two): a subset of the same net, at most one point
                // per finest elementary interval.
                std::vector<int> count(n, 0);
                bool distinct = true;
                for (uint stream = 0; stream < 1000u; ++stream) {
                    SampleStream s = bdptLightStream(sampler, estimate, stream, 1000u);
                    size_t cx = size_t(double(sampleAt(s, 2 * pair)) * 32.0);
                    size_t cy = size_t(double(sampleAt(s, 2 * pair + 1)) * 32.0);
                    distinct = distinct && ++count[cx * 32 + cy] == 1;
                }
                CHECK(distinct);
            }
    // Past 2^(31-b) estimates a new, independently scrambled sequence starts: the index stays
    // within 31 bits and the key changes.
    SamplerSettings sampler{3u, CB_SAMPLER_SOBOL, {0, 0}};
    const uint streams = 1u << 22;
    SampleStream last = bdptLightStream(sampler, (1u << 9) - 1u, streams - 1u, streams);
    SampleStream next = bdptLightStream(sampler, 1u << 9, 0u, streams);
    CHECK(last.reversedIndex == cbReverseBits(0x7fffffffu));
    CHECK(next.reversedIndex == 0u);
    CHECK(next.key != last.key);
    CHECK(next.key != samplerStream(sampler, 1u << 9, 0u).key);
}

TEST_CASE("a stream with a shared table reads it below its dimension count, draws past it") {
    // samplerStreamShared: stream 2 of a table of 3 streams x 5 dimensions reads values 10-14;
    // from dimension 5 on, and without a table, the stream's own values.
    std::vector<float> table(15);
    for (size_t i = 0; i < table.size(); ++i)
        table[i] = 0.01f * float(i);
    for (int kind : {CB_SAMPLER_SOBOL, CB_SAMPLER_INDEPENDENT}) {
        CAPTURE(kind);
        SamplerSettings sampler{9u, kind, {0, 0}};
        SampleStream plain = samplerStream(sampler, 17u, 2u);
        SampleStream shared = samplerStreamShared(sampler, 17u, 2u, table.data(), 5u);
        SampleStream none = samplerStreamShared(sampler, 17u, 2u, table.data(), 0u);
        for (uint d = 0; d < 12u; ++d) {
            CAPTURE(d);
            CHECK(sampleAt(shared, d) == (d < 5u ? table[10 + d] : sampleAt(plain, d)));
            CHECK(sampleAt(none, d) == sampleAt(plain, d));
        }
    }
    // The table covers every dimension an eye path of Ne vertices reads: the jitter and the
    // Ne - 1 bounces' slots, the last of which (the light choice) comes at Ne = 8 at
    // bounceDimension(6, CB_SLOT_LIGHT_CHOICE) = 58.
    CHECK(eyeStreamDimensions(8) == 60u);
    CHECK(bounceDimension(6, CB_SLOT_LIGHT_CHOICE) < eyeStreamDimensions(8));
    CHECK(eyeStreamDimensions(1) == CB_DIM_FIRST_BOUNCE);
}

TEST_CASE("Sobol sampler: every estimate is uniform, and dimension pairs are independent") {
    // Over random keys (seeds, streams), a fixed estimate's values of one dimension and of two
    // dimensions from different pairs: 16 x 16 cells, uniform expected.
    const int samples = 64000;
    for (uint index : {0u, 5u, 1000u}) {
        std::vector<double> observed(256, 0.0);
        std::vector<double> expected(256, double(samples) / 256.0);
        std::mt19937 rng(index);
        for (int s = 0; s < samples; ++s) {
            uint key = uint(rng());
            int a = int(sobolValue(key, index, 4) * 16.0);
            int b = int(sobolValue(key, index, 9) * 16.0);
            observed[size_t(a * 16 + b)] += 1.0;
        }
        auto r = cbtest::chi2Test(observed, expected, kLevel);
        CAPTURE(index);
        INFO(r.message);
        CHECK(r.passed);
    }
}

TEST_CASE("Sobol sampler: pairs are not paired index for index (no correlation across pairs)") {
    // Without the per-pair shuffle, dimension 0 and dimension 2 of the same estimate are two
    // scrambles of the same van der Corput point, so the fraction of 256 estimates with both
    // below 1/2 is 0 or 1/2 and never near 1/4. With it, its variance over keys stays within
    // twice Monte Carlo's (3/16)/256 (Latin-hypercube-like pairing: below MC on average).
    const int n = 256, keys = 400;
    double sum = 0.0, sumSq = 0.0;
    for (int k = 0; k < keys; ++k) {
        uint key = cbHash32(uint(k) + 99u);
        int both = 0;
        for (int i = 0; i < n; ++i)
            both += sobolValue(key, uint(i), 0) < 0.5 && sobolValue(key, uint(i), 2) < 0.5;
        double f = double(both) / n;
        sum += f;
        sumSq += f * f;
    }
    double mean = sum / keys;
    double variance = (sumSq - keys * mean * mean) / (keys - 1);
    CAPTURE(mean);
    CAPTURE(variance);
    CHECK(std::fabs(mean - 0.25) < 5.0 * std::sqrt(variance / keys) + 1e-3);
    CHECK(variance < 2.0 * (3.0 / 16.0) / n);
}

TEST_CASE("sphere light by cone: points on the visible cap, uniform in solid angle, pdf agrees") {
    SphereLitPlane setup;
    for (double radius : {0.25, 0.01}) { // the second takes the small-angle branch
        setup.radius = radius;
        cb::DeviceScene scene = cb::buildDeviceScene(setup.desc(8));
        SceneView view = cbtest::hostView(scene);
        REQUIRE(view.lightCount == 1);
        // Device coordinates are world coordinates minus scene.origin.
        const auto& o = scene.origin;
        Vec3 ref = vec3(real(0.3 - o[0]), real(-0.2 - o[1]), real(2.0 - o[2]));
        Vec3 center = vec3(real(setup.center[0] - o[0]), real(setup.center[1] - o[1]),
                           real(setup.center[2] - o[2]));
        Vec3 axis = vnormalize(vsub(center, ref));
        double dc2 = vlength2(vsub(center, ref));
        double cosMax = std::sqrt(1.0 - radius * radius / dc2);
        double conePdf = double(lightConePdf(&view, 0, ref));
        CHECK(conePdf == doctest::Approx(1.0 / (2.0 * cbtest::kPi * (1.0 - cosMax))).epsilon(2e-3));

        const int samples = 40000, thetaBins = 20, phiBins = 8;
        std::vector<double> observed(size_t(thetaBins * phiBins), 0.0);
        std::vector<double> expected(observed.size(), double(samples) / observed.size());
        Frame frame = frameFromNormal(axis);
        std::mt19937 rng(5);
        auto uniform = [&] { return float(rng() >> 8) * (1.0f / 16777216.0f); };
        for (int s = 0; s < samples; ++s) {
            LightSample ls{};
            REQUIRE(lightSampleFrom(&view, ref, uniform(), uniform(), uniform(), &ls));
            CHECK(std::fabs(vlength(vsub(ls.p, center)) - radius) <= 1e-5 + 1e-5 * radius);
            Vec3 w = vsub(ls.p, ref);
            real dist = vlength(w);
            w = vscale(w, 1.0f / dist);
            CHECK(vdot(ls.n, w) <= 1e-4f); // the cap that faces ref
            CHECK(double(ls.pdfSolidAngle) == doctest::Approx(conePdf).epsilon(1e-6));
            CHECK(double(lightPdfSolidAngleFrom(&view, 0, ref, ls.p, ls.n)) ==
                  doctest::Approx(conePdf).epsilon(1e-6));
            Vec3 local = frameToLocal(frame, w);
            // 1 - cos(theta) in double from |d x a|^2: in float it would be quantised at the
            // small cone's scale.
            double d[3] = {double(ls.p.x) - ref.x, double(ls.p.y) - ref.y, double(ls.p.z) - ref.z};
            double a[3] = {double(center.x) - ref.x, double(center.y) - ref.y,
                           double(center.z) - ref.z};
            double cx = d[1] * a[2] - d[2] * a[1], cy = d[2] * a[0] - d[0] * a[2],
                   cz = d[0] * a[1] - d[1] * a[0];
            double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            double aa = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
            double sin2 = (cx * cx + cy * cy + cz * cz) / (dd * aa);
            double cosTheta = (d[0] * a[0] + d[1] * a[1] + d[2] * a[2]) / std::sqrt(dd * aa);
            double u = sin2 / (1.0 + cosTheta) / (1.0 - cosMax); // uniform in [0, 1)
            int ti = std::min(thetaBins - 1, std::max(0, int(u * thetaBins)));
            double phi = std::atan2(double(local.y), double(local.x)) + cbtest::kPi;
            int pi = std::min(phiBins - 1, int(phi / (2.0 * cbtest::kPi) * phiBins));
            observed[size_t(ti * phiBins + pi)] += 1.0;
        }
        auto r = cbtest::chi2Test(observed, expected, kLevel);
        CAPTURE(radius);
        INFO(r.message);
        CHECK(r.passed);
    }
}

TEST_CASE("sphere light, direct lighting: PT, CPT, BDPT and CBDPT with both samplers equal the "
          "analytic image" *
          doctest::test_suite("statistical")) {
    cb::ClRuntime runtime;
    SphereLitPlane setup;
    for (double radius : {0.25, 0.01}) {
        setup.radius = radius;
        setup.radiance = 4.0 * 0.0625 / (radius * radius); // the same power for both
        cb::DeviceScene scene = cb::buildDeviceScene(setup.desc(16));
        const double expected = setup.expectedMean(scene);
        for (const char* name : {"pt", "cpt", "bdpt", "cbdpt"})
            for (const char* sampler : {"independent", "sobol"}) {
                cb::IntegratorSettings settings;
                settings.name = name;
                settings.sampler = sampler;
                settings.eyeVertices = 3; // camera, plane, light
                settings.lightVertices = 2;
                settings.rouletteVertex = 0;
                settings.coherenceTile = 4;
                auto stats = imageMeans(scene, runtime, settings, 8, 16);
                CAPTURE(radius);
                CAPTURE(name);
                CAPTURE(sampler);
                CAPTURE(expected);
                CAPTURE(stats.mean[0]);
                CAPTURE(stats.se[0]);
                // 4 standard errors of the 8-run mean, plus the midpoint rule's and float's
                // error (1e-3 relative).
                CHECK(std::fabs(stats.mean[0] - expected) <= 4.0 * stats.se[0] + 1e-3 * expected);
            }
    }
}

TEST_CASE("furnace: the Sobol sampler's mean equals the independent sampler's and the analytic "
          "value, for every method") {
    cb::ClRuntime runtime;
    const float albedo = 0.7f, emission = 0.5f;
    cb::DeviceScene scene = cb::buildDeviceScene(cbtest::furnaceScene(albedo, emission));
    for (const char* name : {"pt", "cpt", "bdpt", "cbdpt"}) {
        cbtest::RunStats byKind[2];
        int kind = 0;
        for (const char* sampler : {"independent", "sobol"}) {
            cb::IntegratorSettings settings;
            settings.name = name;
            settings.sampler = sampler;
            settings.eyeVertices = 5;
            settings.lightVertices = 3;
            settings.coherenceTile = 2;
            byKind[kind++] = imageMeans(scene, runtime, settings, 8, 16);
        }
        // Paths of at most Ne = 5 vertices (PT, CPT) or Ne + Nl = 8 (BDPT, CBDPT): the analytic
        // value is the series truncated there.
        const int maxVertices = std::string(name) == "pt" || std::string(name) == "cpt" ? 5 : 8;
        const double expected =
            emission * (1.0 - std::pow(double(albedo), maxVertices - 1)) / (1.0 - double(albedo));
        const double a = byKind[0].mean[0], b = byKind[1].mean[0];
        const double seA = byKind[0].se[0], seB = byKind[1].se[0];
        CAPTURE(name);
        CAPTURE(expected);
        CAPTURE(a);
        CAPTURE(seA);
        CAPTURE(b);
        CAPTURE(seB);
        CHECK(std::fabs(a - b) <= 4.0 * std::sqrt(seA * seA + seB * seB) + 1e-5 * expected);
        CHECK(std::fabs(b - expected) <= 4.0 * seB + 1e-5 * expected);
        CHECK(std::fabs(a - expected) <= 4.0 * seA + 1e-5 * expected);
    }
}
