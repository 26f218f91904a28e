// Coherent methods: every pixel of an estimate shares its sample vector, so one
// estimate is a smooth pattern rather than noise, yet the mean over estimates converges to the
// same image as the independent methods. Statistics use whole estimates as the independent
// samples, since pixels within one coherent estimate are correlated.
#include "test_render_util.h"

#include "integrators/kernel_integrator.h"
#include "scene/device_scene.h"
#include "scene/scene_desc.h"
#include "source_tree.h"

#include <cmath>
#include <cstdlib>
#include <doctest/doctest.h>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

std::string scenePath(const char* name) {
    return cbtest::sourcePath("scenes", name);
}

cb::ClRuntime& runtime() {
    static cb::ClRuntime r;
    return r;
}

// The integrator of `settings` built with environment variable `name` set to `value` (a
// setting of KernelIntegrator's: CBDPT_SHARED_SAMPLES, CBDPT_PACKETS, CBDPT_RAY_PACKET).
std::unique_ptr<cb::Integrator> makeIntegratorWith(const char* name, const char* value,
                                                   const cb::IntegratorSettings& settings,
                                                   const cb::DeviceScene& scene) {
    setenv(name, value, 1);
    struct Unset {
        const char* name;
        ~Unset() { unsetenv(name); }
    } unset{name};
    return cb::makeIntegrator(settings, scene, runtime());
}

// The same with the switch `name` off ("0").
std::unique_ptr<cb::Integrator> makeIntegratorWithout(const char* name,
                                                      const cb::IntegratorSettings& settings,
                                                      const cb::DeviceScene& scene) {
    return makeIntegratorWith(name, "0", settings, scene);
}

// Renders `estimates` estimates with both integrators and calls compare(a, b) on each pair of
// pixel values; returns the sums of a's and of b's values.
template <typename Compare>
std::pair<double, double> renderBoth(cb::Integrator& first, cb::Integrator& second, int estimates,
                                     Compare&& compare) {
    std::vector<float> a, b;
    double sumA = 0, sumB = 0;
    for (std::uint32_t e = 0; e < std::uint32_t(estimates); ++e) {
        first.renderEstimate(e, a);
        second.renderEstimate(e, b);
        REQUIRE(a.size() == b.size());
        for (size_t i = 0; i < a.size(); ++i) {
            sumA += a[i];
            sumB += b[i];
            compare(a[i], b[i]);
        }
    }
    return {sumA, sumB};
}

// Per-estimate means of each cell of a grid x grid partition of the image (channel average).
std::vector<std::vector<double>> regionMeansPerEstimate(const cb::DeviceScene& scene,
                                                        const cb::IntegratorSettings& settings,
                                                        int estimates, int grid) {
    auto renderer = cb::makeIntegrator(settings, scene, runtime());
    const int w = scene.camera.width, h = scene.camera.height;
    std::vector<float> rgb;
    std::vector<std::vector<double>> out;
    for (int e = 0; e < estimates; ++e) {
        renderer->renderEstimate(std::uint32_t(e), rgb);
        std::vector<double> cells(size_t(grid * grid), 0.0);
        std::vector<int> counts(cells.size(), 0);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                size_t c = size_t((y * grid / h) * grid + (x * grid / w));
                const float* px = &rgb[3 * size_t(y * w + x)];
                cells[c] += (double(px[0]) + px[1] + px[2]) / 3.0;
                ++counts[c];
            }
        for (size_t c = 0; c < cells.size(); ++c)
            cells[c] /= counts[c];
        out.push_back(cells);
    }
    REQUIRE(renderer->nonFiniteSamples() == 0);
    return out;
}

struct CellStats {
    std::vector<double> mean, standardError;
};

CellStats summarize(const std::vector<std::vector<double>>& perEstimate) {
    const size_t cells = perEstimate[0].size();
    const double n = double(perEstimate.size());
    CellStats s;
    s.mean.assign(cells, 0.0);
    s.standardError.assign(cells, 0.0);
    for (const auto& e : perEstimate)
        for (size_t c = 0; c < cells; ++c)
            s.mean[c] += e[c] / n;
    for (const auto& e : perEstimate)
        for (size_t c = 0; c < cells; ++c)
            s.standardError[c] += (e[c] - s.mean[c]) * (e[c] - s.mean[c]);
    for (double& v : s.standardError)
        v = std::sqrt(v / (n - 1.0) / n);
    return s;
}

// Counts cells whose difference exceeds 4 combined standard errors. With 16 cells and
// independent normal errors, P(any > 4 sigma) is about 1e-3.
int disagreeingCells(const CellStats& a, const CellStats& b) {
    int bad = 0;
    for (size_t c = 0; c < a.mean.size(); ++c) {
        double se = std::hypot(a.standardError[c], b.standardError[c]);
        if (std::fabs(a.mean[c] - b.mean[c]) > 4.0 * se + 1e-6) {
            ++bad;
            MESSAGE("cell " << c << ": " << a.mean[c] << " +- " << a.standardError[c] << " vs "
                            << b.mean[c] << " +- " << b.standardError[c]);
        }
    }
    return bad;
}

cb::SceneDesc glossyScene() {
    // The Cornell box with its white walls and blocks made a glossy grey conductor.
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    for (auto& m : desc.materials)
        if (m.name == "white") {
            m.kind = cb::MaterialKind::Conductor;
            m.roughness = 0.1f;
        }
    return desc;
}

// The roughness measure of the noise tests: mean |I(x+1,y) - I(x,y)| over a flat patch of the
// back wall (rows 12-24, columns 24-40 of the 64x64 Cornell box: no edges, no shadow
// boundaries), relative to the patch mean, for a single estimate.
double wallRoughness(const cb::DeviceScene& scene, const cb::IntegratorSettings& s) {
    REQUIRE(scene.camera.width == 64);
    auto renderer = cb::makeIntegrator(s, scene, runtime());
    std::vector<float> rgb;
    renderer->renderEstimate(0, rgb);
    double diff = 0, mean = 0;
    for (int y = 12; y < 24; ++y)
        for (int x = 24; x < 40; ++x) {
            auto lum = [&](int px, int py) {
                const float* p = &rgb[3 * size_t(py * 64 + px)];
                return (double(p[0]) + p[1] + p[2]) / 3.0;
            };
            diff += std::fabs(lum(x + 1, y) - lum(x, y));
            mean += lum(x, y);
        }
    return diff / mean;
}

// The sum of 3 estimates is the same bit for bit for one seed (run twice) and differs in more
// than half of its values for another seed.
void checkSeedsReproduceAndDiffer(const cb::DeviceScene& scene, cb::IntegratorSettings settings) {
    auto render = [&](std::uint32_t seed) {
        settings.seed = seed;
        auto renderer = cb::makeIntegrator(settings, scene, runtime());
        std::vector<float> rgb, sum;
        for (int e = 0; e < 3; ++e) {
            renderer->renderEstimate(std::uint32_t(e), rgb);
            if (sum.empty()) sum.assign(rgb.size(), 0.f);
            for (size_t i = 0; i < rgb.size(); ++i)
                sum[i] += rgb[i];
        }
        return sum;
    };
    auto a = render(1), b = render(1), c = render(2);
    CHECK(a == b);
    size_t differing = 0;
    for (size_t i = 0; i < a.size(); ++i)
        differing += a[i] != c[i];
    CHECK(differing > a.size() / 2);
}

} // namespace

TEST_CASE("CPT converges to the PT image (k = 1 and k = 4), Cornell box and glossy box" *
          doctest::test_suite("statistical")) {
    for (int glossy = 0; glossy < 2; ++glossy) {
        CAPTURE(glossy);
        cb::SceneDesc desc =
            glossy ? glossyScene() : cb::parseSceneFile(scenePath("cornell-box.pbrt"));
        desc.film.width = desc.film.height = 24;
        cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
        cb::IntegratorSettings pt;
        pt.name = "pt";
        pt.eyeVertices = 6;
        pt.seed = 100;
        CellStats reference = summarize(regionMeansPerEstimate(scene, pt, 1024, 4));
        for (int k : {1, 4}) {
            CAPTURE(k);
            cb::IntegratorSettings cpt = pt;
            cpt.name = "cpt";
            cpt.coherenceTile = k;
            cpt.seed = 200 + std::uint32_t(k);
            CellStats coherent = summarize(regionMeansPerEstimate(scene, cpt, 256, 4));
            CHECK(disagreeingCells(reference, coherent) == 0);
        }
    }
}

TEST_CASE("one CPT estimate is a pattern, not noise: neighbour differences far below PT's") {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = desc.film.height = 64;
    cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    auto roughness = [&](const char* name) {
        cb::IntegratorSettings s;
        s.name = name;
        s.eyeVertices = 6;
        s.seed = 9;
        // One estimate is one uniform draw with either sampler; the numbers below are this
        // seed's draw of the independent one (Sobol's estimate 0 is another draw, whose pattern
        // happens to cross the wall with a sharp edge).
        s.sampler = "independent";
        return wallRoughness(scene, s);
    };
    double independent = roughness("pt");
    double coherent = roughness("cpt");
    CAPTURE(independent);
    CAPTURE(coherent);
    // Observed: PT about 1 (noise as large as the signal), CPT about 0.01 (only the smooth
    // variation of the lighting). Require a factor of 10.
    CHECK(coherent * 10.0 < independent);
}

TEST_CASE("coherent estimates: one seed reproduces bit for bit, another seed differs") {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = desc.film.height = 16;
    cb::DeviceScene scene = cb::buildDeviceScene(desc);
    cb::IntegratorSettings s;
    s.name = "cpt";
    s.eyeVertices = 5;
    checkSeedsReproduceAndDiffer(scene, s);
}

// ---- CBDPT ------------------------------------------------------------------------------------

TEST_CASE("CBDPT with one vector per pixel is BDPT: same subpaths, t = 1 splats from the host") {
    // With --coherence-tile k >= the image size, every pixel has its own tile position, whose
    // eye and light streams use the same keys as BDPT's per-pixel streams. CBDPT then traces
    // exactly BDPT's subpaths, the light ones on the host, and splats t = 1 there with scale
    // W*H / (W*H light subpaths) = 1: the estimates must agree up to float differences between
    // host and device code. Both channel counts (two host instantiations) and both weightings.
    for (int spectral = 0; spectral < 2; ++spectral) {
        CAPTURE(spectral);
        cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
        desc.film.width = desc.film.height = 16;
        cb::DeviceScene scene =
            cb::buildDeviceScene(desc, spectral ? cb::ChannelMode::Spectral : cb::ChannelMode::Rgb);
        REQUIRE(scene.channels == (spectral ? 16 : 3));
        for (std::string weights : {"power", "lafortune"}) {
            CAPTURE(weights);
            cb::IntegratorSettings s;
            s.name = "bdpt";
            s.eyeVertices = 4;
            s.lightVertices = 4;
            s.weights = weights;
            s.seed = 31;
            cb::IntegratorSettings c = s;
            c.name = "cbdpt";
            c.coherenceTile = 16;
            auto bdpt = cb::makeIntegrator(s, scene, runtime());
            auto cbdpt = cb::makeIntegrator(c, scene, runtime());
            size_t far = 0;
            const auto [sumA, sumB] = renderBoth(*bdpt, *cbdpt, 4, [&](float x, float y) {
                far += std::fabs(x - y) > 1e-3 * (1.0 + std::fabs(x));
            });
            const size_t values = 3 * size_t(scene.camera.width) * size_t(scene.camera.height);
            CAPTURE(sumA);
            CAPTURE(sumB);
            CAPTURE(far);
            CHECK(sumA > 0.0);
            // A path may rarely diverge where host and device round differently at an edge
            // (observed: no pixel differs by more than 1e-3, sums agree to float precision).
            CHECK(far <= values / 100);
            CHECK(std::fabs(sumA - sumB) < 1e-3 * sumA);
            CHECK(cbdpt->nonFiniteSamples() == 0);
        }
    }
}

namespace {

// CBDPT k in {1, 4} x {power, lafortune} against a PT reference with the same longest path
// (PT N = Ne + Nl), on region means with estimate-level error bars.
void checkCbdptConverges(const cb::SceneDesc& desc, int referenceEstimates, int coherentEstimates) {
    cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    cb::IntegratorSettings pt;
    pt.name = "pt";
    pt.eyeVertices = 6;
    pt.rouletteVertex = 0;
    pt.seed = 100;
    CellStats reference = summarize(regionMeansPerEstimate(scene, pt, referenceEstimates, 4));
    for (std::string weights : {"power", "lafortune"})
        for (int k : {1, 4}) {
            CAPTURE(weights);
            CAPTURE(k);
            cb::IntegratorSettings c;
            c.name = "cbdpt";
            c.eyeVertices = 3;
            c.lightVertices = 3;
            c.weights = weights;
            c.coherenceTile = k;
            c.seed = 300 + std::uint32_t(k);
            CellStats coherent = summarize(regionMeansPerEstimate(scene, c, coherentEstimates, 4));
            CHECK(disagreeingCells(reference, coherent) == 0);
        }
}

} // namespace

TEST_CASE("CBDPT converges to the PT image (power and lafortune, k = 1 and k = 4), Cornell box" *
          doctest::test_suite("statistical")) {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = desc.film.height = 24;
    checkCbdptConverges(desc, 1024, 512);
}

TEST_CASE("CBDPT converges to the PT image (power and lafortune, k = 1 and k = 4), glossy box" *
          doctest::test_suite("statistical")) {
    cb::SceneDesc desc = glossyScene();
    desc.film.width = desc.film.height = 24;
    // Lafortune's weights never connect at the glossy conductor (specularity 1), so light
    // reaches it only through emitter hits: heavy tails (BDPT has them too; the sample standard
    // error of 512 estimates varied by 3x between seeds), hence twice the estimates.
    checkCbdptConverges(desc, 1024, 1024);
}

TEST_CASE("one CBDPT estimate is a pattern, not noise: neighbour differences far below BDPT's") {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = desc.film.height = 64;
    cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    for (std::string weights : {"power", "lafortune"}) {
        CAPTURE(weights);
        cb::IntegratorSettings s;
        s.eyeVertices = 4;
        s.lightVertices = 4;
        s.weights = weights;
        s.seed = 9;
        s.name = "bdpt";
        double independent = wallRoughness(scene, s);
        s.name = "cbdpt";
        double coherent = wallRoughness(scene, s);
        CAPTURE(independent);
        CAPTURE(coherent);
        CHECK(coherent * 10.0 < independent);
    }
}

TEST_CASE("CBDPT estimates: one seed reproduces bit for bit, another seed differs") {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = desc.film.height = 16;
    cb::DeviceScene scene = cb::buildDeviceScene(desc);
    for (int k : {1, 4}) {
        CAPTURE(k);
        cb::IntegratorSettings s;
        s.name = "cbdpt";
        s.eyeVertices = 4;
        s.lightVertices = 4;
        s.coherenceTile = k;
        checkSeedsReproduceAndDiffer(scene, s);
    }
}

// ---- Shared sample vectors drawn by the host -----------------------------------------------

TEST_CASE("CPT and CBDPT with the host's shared vectors: the kernels' own images, bit for bit") {
    // The host draws each estimate's k x k shared vectors once (PixelKernelIntegrator); the
    // kernels then read them instead of drawing them per pixel. Same values, same images: every
    // value is an exact float either way. Both samplers; k = 4 at 32x32 is 16 vectors for 1024
    // pixels; k = 8 would be 64, too few pixels each (kPixelsPerSharedStream), so the kernel
    // draws them.
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = desc.film.height = 32;
    cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    for (std::string method : {"pt", "cpt", "cbdpt"})
        for (std::string sampler : {"sobol", "independent"})
            for (int k : {1, 4, 8}) {
                CAPTURE(method);
                CAPTURE(sampler);
                CAPTURE(k);
                cb::IntegratorSettings s;
                s.name = method;
                s.eyeVertices = 4;
                s.lightVertices = 3;
                s.sampler = sampler;
                s.coherenceTile = k;
                s.seed = 5;
                auto shared = cb::makeIntegrator(s, scene, runtime());
                auto own = makeIntegratorWithout("CBDPT_SHARED_SAMPLES", s, scene);
                const bool tabled = method != "pt" && k * k * 64 <= 32 * 32;
                CHECK(shared->hostSampleStreams() == (tabled ? std::uint32_t(k * k) : 0u));
                CHECK(own->hostSampleStreams() == 0u);
                std::vector<float> a, b;
                double sum = 0;
                size_t differing = 0;
                for (std::uint32_t e = 0; e < 3; ++e) {
                    shared->renderEstimate(e + 40, a);
                    own->renderEstimate(e + 40, b);
                    REQUIRE(a.size() == b.size());
                    for (size_t i = 0; i < a.size(); ++i) {
                        sum += a[i];
                        differing += a[i] != b[i];
                    }
                }
                CHECK(sum > 0.0);
                CHECK(differing == 0);
            }
}

// ---- CPT's packets ---------------------------------------------------------------------------

TEST_CASE("CPT and CBDPT traced as packets: the per-pixel kernels' images") {
    // renderCoherentPathTracing (pt.cl) and renderCoherentBdpt (cbdpt.cl) run the per-pixel
    // kernels' code a tile at a time, tracing rays in packets of 4 x 2 or 4 x 4 pixels (8 or 16
    // rays, CBDPT_RAY_PACKET; both widths here); each ray gets the per-pixel traversal's hit up
    // to which of two hits within rounding is kept, so images agree bit for bit but for such
    // ties. Tiles of 4, 8 and 16 pixels (12 is not a whole number of
    // packets: the per-pixel kernels), a film that is not a whole number of tiles, RGB and
    // spectral (the scratch entries' sizes), CPT with roulette on and off, CBDPT under its
    // per-subpath caps and under a total cap (--max-vertices); with --coherence-tile 2 and 3 the
    // packets' pixels are 2 and 3 apart (packetTilePixel), the tiles' blocks overhanging the film.
    // Packets are for CPU devices (a work-item is a thread's loop there); a GPU runs the
    // per-pixel kernels either way (docs/gpu.md).
    const bool packetsDevice = runtime().info().cpu;
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = 37;
    desc.film.height = 29;
    // The two kernels' images over 4 estimates: the same bits but for ties (1 value in 500).
    auto checkSameImages = [](cb::Integrator& packets, cb::Integrator& pixels) {
        size_t differing = 0, values = 0;
        const auto [sumA, sumB] = renderBoth(packets, pixels, 4, [&](float x, float y) {
            differing += x != y;
            ++values;
        });
        CHECK(sumB > 0.0);
        CHECK(differing <= values / 500);
        CHECK(std::abs(sumA - sumB) <= 1e-4 * sumB);
        CHECK(packets.nonFiniteSamples() == pixels.nonFiniteSamples());
    };
    for (cb::ChannelMode mode : {cb::ChannelMode::Rgb, cb::ChannelMode::Spectral}) {
        cb::DeviceScene scene = cb::buildDeviceScene(desc, mode);
        for (std::string method : {"cpt", "cbdpt"})
            for (int k : {1, 2, 3})
                for (int tile : {4, 8, 12, 16})
                    for (int variant : {0, 1}) {
                        // k > 1: tiles of 4 and 8 only, k = 2 with the first variant and
                        // k = 3 with the second, to keep the case short.
                        if (k > 1 && (tile > 8 || variant != k - 2)) continue;
                        CAPTURE(mode == cb::ChannelMode::Rgb);
                        CAPTURE(method);
                        CAPTURE(k);
                        CAPTURE(tile);
                        CAPTURE(variant);
                        cb::IntegratorSettings s;
                        s.name = method;
                        s.eyeVertices = method == "cpt" ? 6 : 4;
                        s.lightVertices = 3;
                        if (method == "cpt") s.rouletteVertex = variant ? 3 : 0;
                        if (method == "cbdpt" && variant) s.maxPathVertices = 5; // Ne 5, Nl 4
                        s.coherenceTile = k;
                        s.tileSize = tile;
                        s.seed = 9;
                        auto pixels = makeIntegratorWithout("CBDPT_PACKETS", s, scene);
                        CHECK(!pixels->tracesPackets());
                        for (const char* width : {"8", "16"}) {
                            CAPTURE(width);
                            auto packets = makeIntegratorWith("CBDPT_RAY_PACKET", width, s, scene);
                            CHECK(packets->tracesPackets() == (packetsDevice && tile % 4 == 0));
                            CHECK(packets->rayPacketRays() ==
                                  (packets->tracesPackets() ? std::atoi(width) : 0));
                            checkSameImages(*packets, *pixels);
                        }
                    }
        // A packet width other than 8 or 16 is refused, naming the variable and the value.
        if (packetsDevice) {
            cb::IntegratorSettings s;
            s.name = "cpt";
            s.eyeVertices = 3;
            CHECK_THROWS_WITH_AS(makeIntegratorWith("CBDPT_RAY_PACKET", "12", s, scene),
                                 doctest::Contains("CBDPT_RAY_PACKET='12'"), std::invalid_argument);
        }
        // Above the largest coherence tile whose packets pay, the per-pixel kernels run.
        for (std::string method : {"cpt", "cbdpt"}) {
            cb::IntegratorSettings s;
            s.name = method;
            s.eyeVertices = s.lightVertices = 3;
            s.coherenceTile = cb::PixelKernelIntegrator::kMaxPacketCoherenceTile;
            const auto chosen = cb::makeIntegrator(s, scene, runtime());
            CHECK(chosen->tracesPackets() == packetsDevice);
            // Unforced, the width follows the device's native float vectors.
            const int native = runtime().info().nativeFloatWidth >= 16 ? 16 : 8;
            CHECK(chosen->rayPacketRays() == (packetsDevice ? native : 0));
            ++s.coherenceTile;
            CHECK(!cb::makeIntegrator(s, scene, runtime())->tracesPackets());
        }
    }
    // A filter with negative lobes weighs each pixel's sample (cb_filter.h): in both kernels.
    desc.filter = cb::FilterDesc::pbrtDefault();
    desc.filter.type = cb::FilterDesc::Type::Sinc;
    desc.filter.radiusX = desc.filter.radiusY = 4.0;
    const cb::DeviceScene filtered = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    for (std::string method : {"cpt", "cbdpt"}) {
        CAPTURE(method);
        cb::IntegratorSettings s;
        s.name = method;
        s.eyeVertices = 4;
        s.lightVertices = 3;
        s.tileSize = 8;
        s.seed = 9;
        auto pixels = makeIntegratorWithout("CBDPT_PACKETS", s, filtered);
        auto packets = cb::makeIntegrator(s, filtered, runtime());
        CHECK(packets->tracesPackets() == packetsDevice);
        checkSameImages(*packets, *pixels);
    }
}

TEST_CASE("every method: prefetching the tree changes no pixel") {
    // CB_TREE_PREFETCH (cb_bvh_wide.h) asks for the nodes and packs a traversal will enter, in
    // the single-ray traversal and in CPT's and CBDPT's packets; it must not change which it
    // enters. Unforced it is on only where the scene's tree is larger than a CPU device's cache
    // (treePrefetchPays), so never for this box; CBDPT_PREFETCH=1 forces it on, 0 off. It is
    // for CPU devices only (a GPU gets 0 either way).
    if (!runtime().info().cpu) return;
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = 37;
    desc.film.height = 29;
    const cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    for (std::string method : {"pt", "cpt", "bdpt", "cbdpt", "mlt"}) {
        CAPTURE(method);
        cb::IntegratorSettings s;
        s.name = method;
        s.eyeVertices = method == "pt" || method == "cpt" ? 6 : 4;
        s.lightVertices = 3;
        s.seed = 5;
        s.mltChains = 16;
        s.mltBootstrap = 1024;
        CHECK(!cb::makeIntegrator(s, scene, runtime())->treePrefetch());
        auto on = makeIntegratorWith("CBDPT_PREFETCH", "1", s, scene);
        auto off = makeIntegratorWithout("CBDPT_PREFETCH", s, scene);
        CHECK(on->tracesPackets() == (method == "cpt" || method == "cbdpt"));
        CHECK(on->treePrefetch());
        CHECK(!off->treePrefetch());
        size_t differing = 0;
        const auto [sumOn, sumOff] =
            renderBoth(*on, *off, 3, [&](float x, float y) { differing += x != y; });
        CHECK(sumOff > 0.0);
        CHECK(differing == 0);
        CHECK(sumOn == sumOff);
    }
    cb::IntegratorSettings s;
    s.name = "pt";
    s.eyeVertices = 3;
    CHECK_THROWS_WITH_AS(makeIntegratorWith("CBDPT_PREFETCH", "yes", s, scene),
                         doctest::Contains("CBDPT_PREFETCH='yes'"), std::invalid_argument);
}

TEST_CASE("CBDPT rejects --strategy (a BDPT debug mode)") {
    cb::SceneDesc desc = cb::parseSceneFile(scenePath("cornell-box.pbrt"));
    desc.film.width = desc.film.height = 8;
    cb::DeviceScene scene = cb::buildDeviceScene(desc, cb::ChannelMode::Rgb);
    cb::IntegratorSettings s;
    s.name = "cbdpt";
    s.debugS = 1;
    s.debugT = 2;
    CHECK_THROWS_AS(cb::makeIntegrator(s, scene, runtime()), std::invalid_argument);
}
