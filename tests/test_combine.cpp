// Combinations of renders (image/combine.h): the analytic inverse-variance optimum on synthetic
// inputs, identities, refusals of inputs that cannot be combined, the EXR round trip of the
// render record and halves, and each combination's bias on the furnace against its bound.
#include "image/combine.h"
#include "image/render_state.h"
#include "integrators/split_budget.h"
#include "scene_builders.h"

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <random>

namespace {

cb::RenderRecord syntheticRecord(const std::string& method, std::uint32_t seed) {
    cb::RenderRecord r;
    r.method = method;
    r.eyeVertices = method == "pt" ? 8 : 4;
    r.lightVertices = 4;
    r.seed = seed;
    r.channels = 3;
    r.sceneFile = "synthetic.pbrt";
    r.sceneHash = "0123456789abcdef";
    return r;
}

// An input whose every estimate of every pixel and channel is N(mu, sigma^2).
cb::CombineInput gaussianInput(const std::string& method, std::uint32_t seed, int size,
                               long estimates, double mu, double sigma) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal(mu, sigma);
    cb::EstimateAccumulator acc(size, size);
    acc.trackHalves();
    std::vector<float> estimate(size_t(3 * size * size));
    for (long e = 0; e < estimates; ++e) {
        for (float& v : estimate)
            v = float(normal(rng));
        acc.add(estimate.data());
    }
    return cb::combineInputFromAccumulator(acc, syntheticRecord(method, seed),
                                           method + std::to_string(seed));
}

double imageMean(const cb::RgbImage& image) {
    double sum = 0.0;
    for (float v : image.rgb)
        sum += v;
    return sum / double(image.rgb.size());
}

double meanSquaredDeviation(const cb::RgbImage& image, double mu) {
    double sum = 0.0;
    for (float v : image.rgb)
        sum += (v - mu) * (v - mu);
    return sum / double(image.rgb.size());
}

} // namespace

TEST_CASE("combine: inverse variance of constant halves is the analytic weighted mean") {
    // Halves with known values and standard errors: the cross weights are the other half's
    // variances, so the result is sum_h (sum_i x_ih / v_i) / (sum_i 1 / v_i) / 2 exactly.
    std::vector<cb::CombineInput> inputs(2);
    const double values[2][2] = {{1.0, 1.2}, {0.7, 0.9}};
    const double se[2] = {0.1, 0.3};
    for (int i = 0; i < 2; ++i) {
        auto& in = inputs[size_t(i)];
        in.path = "in" + std::to_string(i);
        in.record = syntheticRecord(i ? "cbdpt" : "pt", std::uint32_t(i));
        in.mean = cb::RgbImage(3, 2);
        in.standardError = cb::RgbImage(3, 2);
        in.hasHalves = true;
        in.halfEstimates = {10, 10};
        for (int h = 0; h < 2; ++h) {
            in.halfMean[size_t(h)] = cb::RgbImage(3, 2);
            in.halfStandardError[size_t(h)] = cb::RgbImage(3, 2);
            for (float& v : in.halfMean[size_t(h)].rgb)
                v = float(values[i][h]);
            for (float& v : in.halfStandardError[size_t(h)].rgb)
                v = float(se[i]);
        }
        for (float& v : in.mean.rgb)
            v = float(0.5 * (values[i][0] + values[i][1]));
        for (float& v : in.standardError.rgb)
            v = float(se[i] / std::sqrt(2.0));
    }
    cb::CombineSettings settings;
    settings.how = cb::Combination::InverseVariance;
    auto result = cb::combine(inputs, settings);
    const double w0 = 1.0 / (se[0] * se[0]), w1 = 1.0 / (se[1] * se[1]);
    double expected = 0.0;
    for (int h = 0; h < 2; ++h)
        expected += 0.5 * (w0 * values[0][h] + w1 * values[1][h]) / (w0 + w1);
    for (float v : result.image.rgb)
        CHECK(v == doctest::Approx(expected).epsilon(1e-6));
    // Its standard error: 1 / sqrt(sum of the full means' inverse variances).
    const double full = 1.0 / std::sqrt(2.0 * w0 + 2.0 * w1);
    for (float v : result.standardError.rgb)
        CHECK(v == doctest::Approx(full).epsilon(1e-5));
}

TEST_CASE("combine: Gaussian inputs of known variance reach the inverse-variance optimum" *
          doctest::test_suite("statistical")) {
    // Two unbiased inputs, variances per estimate 1 and 9, 64 and 32 estimates: the optimum
    // variance is 1 / (64 / 1 + 32 / 9) = 0.01480; the plain mean's is (1/64 + 9/32) / 4 = 0.0742.
    const double mu = 2.0;
    const int size = 64;
    auto a = gaussianInput("pt", 11, size, 64, mu, 1.0);
    auto b = gaussianInput("cbdpt", 12, size, 32, mu, 3.0);
    const double optimum = 1.0 / (64.0 / 1.0 + 32.0 / 9.0);
    const double plain = (1.0 / 64.0 + 9.0 / 32.0) / 4.0;
    cb::CombineSettings settings;
    settings.how = cb::Combination::InverseVariance;
    settings.varianceRadius = 2; // 5x5 smoothing: weights from 25 x 16 estimates
    auto iv = cb::combine({a, b}, settings);
    const double n = double(iv.image.rgb.size());
    const double msd = meanSquaredDeviation(iv.image, mu);
    CAPTURE(msd);
    CAPTURE(optimum);
    // Cross weights from half the estimates cost a little: within 5% of the optimum, far from
    // the plain mean's 5x; and unbiased: the pixel mean within 4 standard errors of mu.
    CHECK(msd < 1.05 * optimum);
    CHECK(msd > 0.95 * optimum);
    CHECK(std::fabs(imageMean(iv.image) - mu) < 4.0 * std::sqrt(optimum / n));
    settings.how = cb::Combination::Mean;
    auto mean = cb::combine({a, b}, settings);
    CHECK(meanSquaredDeviation(mean.image, mu) == doctest::Approx(plain).epsilon(0.05));
}

TEST_CASE("combine: naive inverse-variance weights are biased, cross weights are not" *
          doctest::test_suite("statistical")) {
    // Skewed estimates (exponential, mean 1): a pixel whose samples came out low also measured a
    // low variance, so same-sample weights favour low values (bias < 0); cross weights do not.
    const int size = 64;
    auto exponentialInput = [&](const std::string& method, std::uint32_t seed, long estimates) {
        std::mt19937_64 rng(seed);
        std::exponential_distribution<double> exponential(1.0);
        cb::EstimateAccumulator acc(size, size);
        acc.trackHalves();
        std::vector<float> estimate(size_t(3 * size * size));
        for (long e = 0; e < estimates; ++e) {
            for (float& v : estimate)
                v = float(exponential(rng));
            acc.add(estimate.data());
        }
        return cb::combineInputFromAccumulator(acc, syntheticRecord(method, seed), method);
    };
    auto a = exponentialInput("pt", 21, 8);
    auto b = exponentialInput("cbdpt", 22, 8);
    cb::CombineSettings settings;
    settings.varianceRadius = 0;
    settings.how = cb::Combination::InverseVarianceNaive;
    const double naive = imageMean(cb::combine({a, b}, settings).image) - 1.0;
    settings.how = cb::Combination::InverseVariance;
    auto cross = cb::combine({a, b}, settings);
    const double crossBias = imageMean(cross.image) - 1.0;
    // The pixel mean of the cross combination: per-pixel variance below that of one 4-estimate
    // half (1/4), 3 x 64 x 64 independent pixels.
    const double tolerance = 4.0 * std::sqrt(0.25 / double(cross.image.rgb.size()));
    CAPTURE(naive);
    CAPTURE(crossBias);
    CHECK(std::fabs(crossBias) < tolerance);
    CHECK(naive < -4.0 * tolerance);
}

TEST_CASE("combine: a method combined with itself gives its own image") {
    auto a = gaussianInput("cbdpt", 5, 8, 16, 1.0, 0.5);
    for (auto how : {cb::Combination::Mean, cb::Combination::InverseVariance,
                     cb::Combination::InverseVarianceNaive, cb::Combination::Median,
                     cb::Combination::Reject}) {
        CAPTURE(cb::combinationName(how));
        cb::CombineSettings settings;
        settings.how = how;
        auto result = cb::combine({a, a, a}, settings);
        // Inverse variance mixes the halves, whose average is the mean (equal half counts).
        for (size_t e = 0; e < a.mean.rgb.size(); ++e)
            CHECK(result.image.rgb[e] == doctest::Approx(a.mean.rgb[e]).epsilon(1e-5));
    }
}

TEST_CASE("combine: two independent renders of one method give about their plain mean" *
          doctest::test_suite("statistical")) {
    // Same variance: the weights are equal up to their own noise, so inverse variance differs
    // from the plain mean by a small fraction of the standard error.
    auto a = gaussianInput("pt", 31, 32, 64, 1.0, 1.0);
    auto b = gaussianInput("pt", 32, 32, 64, 1.0, 1.0);
    cb::CombineSettings settings;
    settings.how = cb::Combination::Mean;
    auto mean = cb::combine({a, b}, settings);
    settings.how = cb::Combination::InverseVariance;
    settings.varianceRadius = 2;
    auto iv = cb::combine({a, b}, settings);
    const double se = std::sqrt(1.0 / 128.0);
    double sum = 0.0;
    for (size_t e = 0; e < iv.image.rgb.size(); ++e)
        sum += (iv.image.rgb[e] - mean.image.rgb[e]) * (iv.image.rgb[e] - mean.image.rgb[e]);
    const double rms = std::sqrt(sum / double(iv.image.rgb.size()));
    CAPTURE(rms);
    CHECK(rms < 0.25 * se);
}

TEST_CASE("combine: robust combinations reject an outlier run") {
    // Five runs agree on 1 except one that is 10 standard errors off at every pixel.
    std::vector<cb::CombineInput> inputs;
    for (int i = 0; i < 5; ++i) {
        cb::CombineInput in;
        in.path = "run" + std::to_string(i);
        in.record = syntheticRecord("cbdpt", std::uint32_t(i));
        in.mean = cb::RgbImage(2, 2);
        in.standardError = cb::RgbImage(2, 2);
        for (float& v : in.mean.rgb)
            v = i == 3 ? 2.0f : 1.0f + 0.01f * float(i);
        for (float& v : in.standardError.rgb)
            v = 0.1f;
        inputs.push_back(in);
    }
    cb::CombineSettings settings;
    settings.how = cb::Combination::Median;
    for (float v : cb::combine(inputs, settings).image.rgb)
        CHECK(v == doctest::Approx(1.02));
    settings.how = cb::Combination::Reject;
    for (float v : cb::combine(inputs, settings).image.rgb)
        CHECK(v == doctest::Approx((1.0 + 1.01 + 1.02 + 1.04) / 4.0));
    settings.how = cb::Combination::Mean;
    for (float v : cb::combine(inputs, settings).image.rgb)
        CHECK(v == doctest::Approx((1.0 + 1.01 + 1.02 + 2.0 + 1.04) / 5.0));
}

TEST_CASE("combine: the guided filter keeps constants and stops at the guide's edges") {
    cb::RgbImage values(16, 16), guide(16, 16);
    for (float& v : values.rgb)
        v = 0.5f;
    auto smooth = cb::jointBilateralFilter(values, values, 2.0, 0.25);
    for (float v : smooth.rgb)
        CHECK(v == doctest::Approx(0.5f));
    // Left half of the guide dark, right half bright; values -1 left, +1 right: with the edge
    // stop the columns next to the edge keep their side's value, without it they blur.
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x)
            for (int c = 0; c < 3; ++c) {
                guide.rgb[size_t(3 * (16 * y + x) + c)] = x < 8 ? 0.1f : 1.0f;
                values.rgb[size_t(3 * (16 * y + x) + c)] = x < 8 ? -1.0f : 1.0f;
            }
    auto stopped = cb::jointBilateralFilter(values, guide, 2.0, 0.25);
    auto blurred = cb::jointBilateralFilter(values, guide, 2.0, 0.0);
    const size_t left = size_t(3 * (16 * 8 + 7)), right = size_t(3 * (16 * 8 + 8));
    CHECK(stopped.rgb[left] < -0.99f);
    CHECK(stopped.rgb[right] > 0.99f);
    CHECK(blurred.rgb[left] > -0.5f);
    CHECK(blurred.rgb[right] < 0.5f);
}

TEST_CASE("combine: inputs of other scenes, sizes, caps or shared random numbers are refused") {
    auto base = gaussianInput("pt", 1, 4, 8, 1.0, 0.1);
    auto check = [&](cb::CombineInput other, const std::string& words) {
        CAPTURE(words);
        try {
            cb::requireCombinable({base, other});
            FAIL("not refused");
        } catch (const std::invalid_argument& e) {
            const std::string what = e.what();
            CAPTURE(what);
            CHECK(what.find(words) != std::string::npos);
            CHECK(what.find(base.path) != std::string::npos);
        }
    };
    auto other = gaussianInput("cbdpt", 2, 4, 8, 1.0, 0.1);
    CHECK_NOTHROW(cb::requireCombinable({base, other}));
    auto scene = other;
    scene.record.sceneHash = "fedcba9876543210";
    check(scene, "different scenes");
    // The content hash decides, not the file's name (a merged image records none).
    scene = other;
    scene.record.sceneFile = "";
    CHECK_NOTHROW(cb::requireCombinable({base, scene}));
    check(gaussianInput("cbdpt", 2, 5, 8, 1.0, 0.1), "differ in size");
    auto caps = other;
    caps.record.lightVertices = 3;
    check(caps, "vertex caps");
    auto channels = other;
    channels.record.channels = 16;
    check(channels, "colour channels");
    check(gaussianInput("pt", 1, 4, 8, 1.0, 0.1), "not independent");
}

TEST_CASE("combine: the render record and halves round-trip through EXR and the state") {
    const auto dir =
        std::filesystem::temp_directory_path() / ("cbdpt-combine-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string path = (dir / "r.exr").string();
    cb::EstimateAccumulator acc(4, 3);
    acc.trackHalves();
    std::vector<float> estimate(36);
    for (int e = 0; e < 5; ++e) {
        for (size_t i = 0; i < estimate.size(); ++i)
            estimate[i] = float(e * e) + 0.1f * float(i);
        acc.add(estimate.data());
    }
    CHECK(acc.halfEstimates(0) == 3);
    CHECK(acc.halfEstimates(1) == 2);
    // Half 0 holds estimates 0, 2, 4 (values 0, 4, 16 plus the offset), half 1 estimates 1, 3.
    CHECK(acc.halfMean(0).rgb[0] == doctest::Approx(20.0 / 3.0));
    CHECK(acc.halfMean(1).rgb[0] == doctest::Approx(5.0));
    cb::RenderRecord record = syntheticRecord("cbdpt", 0xdeadbeefu);
    record.renderCpuSeconds = 1.25;
    cb::writeRenderExr(path, acc, record);
    auto in = cb::readCombineInput(path);
    CHECK(in.record.method == "cbdpt");
    CHECK(in.record.seed == 0xdeadbeefu);
    CHECK(in.record.estimates == 5);
    CHECK(in.record.width == 4);
    CHECK(in.record.renderCpuSeconds == 1.25);
    CHECK(in.record.sceneHash == record.sceneHash);
    REQUIRE(in.hasHalves);
    CHECK(in.halfEstimates[0] == 3);
    CHECK(in.halfEstimates[1] == 2);
    CHECK(in.halfMean[1].rgb[0] == doctest::Approx(5.0));
    CHECK(in.halfStandardError[0].rgb[0] == doctest::Approx(acc.halfStandardError(0).rgb[0]));

    // Half 0 (even indices) is the full sums less the odd ones: its standard error is that of
    // 0, 4, 16: sqrt(var / 3) with var = ((20/3)^2 + (8/3)^2 + (28/3)^2) / 2.
    CHECK(acc.halfStandardError(0).rgb[0] ==
          doctest::Approx(std::sqrt((400.0 + 64.0 + 784.0) / 9.0 / 2.0 / 3.0)));
    CHECK(acc.halfStandardError(1).rgb[0] == doctest::Approx(4.0)); // 1, 9: var 32, n 2

    // The state keeps the halves, exactly.
    const std::string state = (dir / "r.state").string();
    cb::RenderIdentity identity;
    identity.settings = {{"test", "halves"}};
    identity.sceneHash = "0123456789abcdef";
    cb::saveRenderState(state, identity, acc);
    cb::EstimateAccumulator restored(4, 3);
    restored.trackHalves();
    cb::resumeRenderState(state, identity, restored);
    REQUIRE(restored.tracksHalves());
    CHECK(restored.sums() == acc.sums());
    CHECK(restored.squares() == acc.squares());
    CHECK(restored.oddSums() == acc.oddSums());
    CHECK(restored.oddSquares() == acc.oddSquares());
    for (int h = 0; h < 2; ++h)
        CHECK(restored.halfEstimates(h) == acc.halfEstimates(h));

    // Shards merged in any order hold the same halves, bit for bit, as the whole render.
    cb::EstimateAccumulator first(4, 3), second(4, 3);
    first.trackHalves();
    second.trackHalves();
    for (std::uint64_t e = 0; e < 5; ++e) {
        for (size_t i = 0; i < estimate.size(); ++i)
            estimate[i] = float(e * e) + 0.1f * float(i);
        (e == 1 || e == 4 ? first : second).add(e, estimate.data());
    }
    first.merge(second);
    CHECK(first.tracksHalves());
    CHECK(first.sums() == acc.sums());
    CHECK(first.oddSums() == acc.oddSums());
    CHECK(first.oddSquares() == acc.oddSquares());
    // A merge with estimates that have no halves cannot keep them, but keeps every sum: the
    // same bits as the six estimates added to an accumulator without halves.
    cb::EstimateAccumulator plain(4, 3), whole(4, 3);
    plain.add(7, estimate.data());
    for (std::uint64_t e = 0; e < 5; ++e) {
        for (size_t i = 0; i < estimate.size(); ++i)
            estimate[i] = float(e * e) + 0.1f * float(i);
        whole.add(e, estimate.data());
    }
    whole.add(7, estimate.data());
    first.merge(plain);
    CHECK_FALSE(first.tracksHalves());
    CHECK(first.estimates() == 6);
    CHECK(first.sums() == whole.sums());
    CHECK(first.squares() == whole.squares());
    CHECK(first.oddSums().empty());
    // And the other way round: halves merged into an accumulator without them.
    cb::EstimateAccumulator plainFirst(4, 3);
    plainFirst.add(7, estimate.data());
    plainFirst.merge(acc);
    CHECK_FALSE(plainFirst.tracksHalves());
    CHECK(plainFirst.sums() == whole.sums());
    CHECK(plainFirst.squares() == whole.squares());
    std::filesystem::remove_all(dir);
}

TEST_CASE("combine: each combination's bias on the furnace is within its bound" *
          doctest::test_suite("statistical")) {
    // A closed emitting diffuse box: every pixel's radiance is Le (1 - a^(n-1)) / (1 - a) for paths
    // of at most n vertices. PT (Ne = 5) and three CBDPT runs (Ne = 3, Nl = 2) of 16x16 pixels.
    cb::ClRuntime runtime;
    const float albedo = 0.8f, emission = 0.25f;
    const int vertices = 5;
    cb::DeviceScene scene =
        cb::buildDeviceScene(cbtest::furnaceScene(albedo, emission), cb::ChannelMode::Rgb);
    const double expected =
        emission * (1.0 - std::pow(double(albedo), vertices - 1)) / (1.0 - double(albedo));
    auto render = [&](const std::string& method, std::uint32_t seed, long estimates) {
        cb::IntegratorSettings s;
        s.name = method;
        s.eyeVertices = method == "pt" ? vertices : 3;
        s.lightVertices = 2;
        s.seed = seed;
        // Independent halves, as the cross-weighted combinations need (a Sobol render's are not).
        s.sampler = "independent";
        auto integrator = cb::makeIntegrator(s, scene, runtime);
        cb::EstimateAccumulator acc(scene.camera.width, scene.camera.height);
        acc.trackHalves();
        std::atomic<bool> stop{false};
        cb::RenderLimits limits;
        limits.estimates = estimates;
        cb::renderEstimates(*integrator, acc, limits, stop);
        cb::RenderRecord record = syntheticRecord(method, seed);
        record.eyeVertices = s.eyeVertices;
        record.lightVertices = s.lightVertices;
        record.sampler = s.sampler;
        return cb::combineInputFromAccumulator(acc, record, method + std::to_string(seed));
    };
    std::vector<cb::CombineInput> all{render("pt", 1, 64), render("cbdpt", 2, 32),
                                      render("cbdpt", 3, 32), render("cbdpt", 4, 32)};
    REQUIRE_NOTHROW(cb::requireCombinable(all));
    std::vector<cb::CombineInput> patterned(all.begin() + 1, all.end());
    // The image mean of pixels that may be correlated (CBDPT) has a standard deviation of at most
    // the mean per-pixel standard deviation: the statistical slack is 4 of those.
    auto meanStandardError = [](const std::vector<cb::CombineInput>& ins) {
        double s = 0.0;
        for (const auto& in : ins)
            s = std::max(s, imageMean(in.standardError));
        return s;
    };
    struct Case {
        cb::Combination how;
        const std::vector<cb::CombineInput>* inputs;
        double boundInSe; // the stated bias bound, in units of the largest input's standard error
        bool blend = false;
    };
    const double k = 3.0, z = 3.0;
    const double medianBound = std::sqrt(k / std::ceil(k / 2.0));
    const Case cases[] = {
        {cb::Combination::Mean, &all, 0.0},
        {cb::Combination::InverseVariance, &all, 0.0},
        // The naive weights' output lies between the inputs: |bias| <= sqrt(sum of variances).
        {cb::Combination::InverseVarianceNaive, &all, 2.0},
        {cb::Combination::Guided, &all, 0.0},
        {cb::Combination::Guided, &all, 0.0, true},
        {cb::Combination::Median, &patterned, medianBound},
        {cb::Combination::Reject, &patterned, medianBound + z},
    };
    for (const Case& c : cases) {
        CAPTURE(cb::combinationName(c.how));
        cb::CombineSettings settings;
        settings.how = c.how;
        settings.rejectThreshold = z;
        settings.guideBlend = c.blend;
        CAPTURE(c.blend);
        auto result = cb::combine(*c.inputs, settings);
        const double se = meanStandardError(*c.inputs);
        const double bias = imageMean(result.image) - expected;
        // A guided pixel is a half image plus a convex filter of (noisy half - that half), or a
        // convex mix of that and the noisy half: its deviation is at most three half images'
        // (sqrt 2 se each).
        const double slack =
            4.0 * (c.how == cb::Combination::Guided ? 3.0 * std::sqrt(2.0) : 1.0) * se;
        CAPTURE(expected);
        CAPTURE(bias);
        CAPTURE(se);
        const std::string name = cb::combinationName(c.how) + (c.blend ? " (blended)" : "");
        MESSAGE(name, ": furnace bias ", bias, " (", bias / expected * 100.0,
                "% of the radiance; input standard error ", se, ")");
        CHECK(std::fabs(bias) <= c.boundInSe * se + slack);
    }
}

namespace {

// An input whose halves are constant images: value halfValue[h] with standard error halfSe[h]
// from halfCount[h] estimates; the full mean and error follow from the halves.
cb::CombineInput constantHalves(const std::string& method, std::uint32_t seed,
                                std::array<double, 2> halfValue, std::array<double, 2> halfSe,
                                std::array<long, 2> halfCount, int w = 3, int h = 2) {
    cb::CombineInput in;
    in.path = method + std::to_string(seed);
    in.record = syntheticRecord(method, seed);
    in.hasHalves = true;
    in.halfEstimates = halfCount;
    const double n = double(halfCount[0] + halfCount[1]);
    const double full =
        (double(halfCount[0]) * halfValue[0] + double(halfCount[1]) * halfValue[1]) / n;
    in.mean = cb::RgbImage(w, h);
    in.standardError = cb::RgbImage(w, h);
    for (float& v : in.mean.rgb)
        v = float(full);
    for (float& v : in.standardError.rgb)
        v = float(std::hypot(double(halfCount[0]) * halfSe[0], double(halfCount[1]) * halfSe[1]) /
                  n);
    for (int half = 0; half < 2; ++half) {
        in.halfMean[size_t(half)] = cb::RgbImage(w, h);
        in.halfStandardError[size_t(half)] = cb::RgbImage(w, h);
        for (float& v : in.halfMean[size_t(half)].rgb)
            v = float(halfValue[size_t(half)]);
        for (float& v : in.halfStandardError[size_t(half)].rgb)
            v = float(halfSe[size_t(half)]);
    }
    return in;
}

} // namespace

TEST_CASE("combine: cross weights take the other half's variance scaled by the count ratio") {
    // Half h of input i is weighted by 1 / v_ih with v_ih = se_i,1-h^2 n_i,1-h / n_ih: the other
    // half's variance of its mean, scaled to a mean of n_ih estimates. Halves of unequal counts
    // and errors, so a weight from the wrong half or an inverted ratio changes the answer.
    const std::array<double, 2> x0{1.0, 1.3}, x1{0.6, 0.8}, se0{0.1, 0.25}, se1{0.3, 0.15};
    const std::array<long, 2> n0{6, 3}, n1{4, 4};
    std::vector<cb::CombineInput> inputs{constantHalves("pt", 1, x0, se0, n0),
                                         constantHalves("cbdpt", 2, x1, se1, n1)};
    cb::CombineSettings settings;
    settings.how = cb::Combination::InverseVariance;
    const auto result = cb::combine(inputs, settings);
    double expected = 0.0;
    for (int h = 0; h < 2; ++h) {
        const int o = 1 - h;
        const double v0 =
            se0[size_t(o)] * se0[size_t(o)] * double(n0[size_t(o)]) / double(n0[size_t(h)]);
        const double v1 =
            se1[size_t(o)] * se1[size_t(o)] * double(n1[size_t(o)]) / double(n1[size_t(h)]);
        expected += 0.5 * (x0[size_t(h)] / v0 + x1[size_t(h)] / v1) / (1.0 / v0 + 1.0 / v1);
    }
    for (float v : result.image.rgb)
        CHECK(v == doctest::Approx(expected).epsilon(1e-6));
}

TEST_CASE("combine: pixels without variance, an even number of inputs, the mean's error") {
    // A pixel every input computes exactly (standard error 0, e.g. a directly seen light) keeps
    // that value: the exact inputs are averaged, never summed.
    std::vector<cb::CombineInput> inputs;
    for (std::uint32_t i = 0; i < 4; ++i)
        inputs.push_back(constantHalves(i % 2 ? "cbdpt" : "pt", i, {0.7, 0.7}, {0.0, 0.0}, {4, 4}));
    cb::CombineSettings settings;
    for (auto how : {cb::Combination::InverseVariance, cb::Combination::InverseVarianceNaive}) {
        CAPTURE(cb::combinationName(how));
        settings.how = how;
        for (float v : cb::combine(inputs, settings).image.rgb)
            CHECK(v == doctest::Approx(0.7));
    }
    // The median of an even count is the mean of the middle two: 1, 2, 4, 8 -> 3.
    const double values[4] = {8.0, 1.0, 4.0, 2.0};
    for (size_t i = 0; i < 4; ++i) {
        for (float& v : inputs[i].mean.rgb)
            v = float(values[i]);
        for (float& v : inputs[i].standardError.rgb)
            v = float(0.1 * double(i + 1));
    }
    settings.how = cb::Combination::Median;
    for (float v : cb::combine(inputs, settings).image.rgb)
        CHECK(v == doctest::Approx(3.0));
    // The plain mean of k independent inputs has standard error sqrt(sum se_i^2) / k.
    settings.how = cb::Combination::Mean;
    const double meanError = std::sqrt(0.01 + 0.04 + 0.09 + 0.16) / 4.0;
    for (float v : cb::combine(inputs, settings).standardError.rgb)
        CHECK(v == doctest::Approx(meanError).epsilon(1e-6));
}

TEST_CASE("combine: variances are box means over the pixels inside the image") {
    // Naive inverse variance of two inputs: the standard error is 1 / sqrt(sum_i 1 / V_i), V_i
    // the mean of se_i^2 over the (2r + 1)^2 box clipped at the borders, computed here directly.
    const int w = 5, h = 4, r = 1;
    std::vector<cb::CombineInput> inputs;
    for (std::uint32_t i = 0; i < 2; ++i) {
        cb::CombineInput in;
        in.path = "in" + std::to_string(i);
        in.record = syntheticRecord(i ? "cbdpt" : "pt", i);
        in.mean = cb::RgbImage(w, h);
        in.standardError = cb::RgbImage(w, h);
        for (size_t e = 0; e < in.standardError.rgb.size(); ++e)
            in.standardError.rgb[e] = float(0.05 + 0.01 * double((e * (i + 3)) % 7));
        inputs.push_back(in);
    }
    cb::CombineSettings settings;
    settings.how = cb::Combination::InverseVarianceNaive;
    settings.varianceRadius = r;
    const auto result = cb::combine(inputs, settings);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) {
                double weights = 0.0;
                for (const auto& in : inputs) {
                    double sum = 0.0;
                    int count = 0;
                    for (int yy = y - r; yy <= y + r; ++yy)
                        for (int xx = x - r; xx <= x + r; ++xx) {
                            if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
                            const double se = in.standardError.rgb[size_t(3 * (yy * w + xx) + c)];
                            sum += se * se;
                            ++count;
                        }
                    weights += count / sum;
                }
                CAPTURE(x);
                CAPTURE(y);
                CHECK(result.standardError.rgb[size_t(3 * (y * w + x) + c)] ==
                      doctest::Approx(1.0 / std::sqrt(weights)).epsilon(1e-5));
            }
}

TEST_CASE("combine: guided winsorises with the group's variance and guides by the other half") {
    // One noisy input at 1 and two pattern-prone inputs at 0, constant halves: the difference
    // P - C = 1 is clamped at z sqrt(var P + var C), var C the variance of the mean of the two
    // (sum / 4); a constant survives the filter, so the image is that limit.
    const double sp = 0.2, sc = 0.3, z = 2.0;
    std::vector<cb::CombineInput> inputs{constantHalves("pt", 1, {1.0, 1.0}, {sp, sp}, {4, 4}),
                                         constantHalves("cbdpt", 2, {0.0, 0.0}, {sc, sc}, {4, 4}),
                                         constantHalves("cbdpt", 3, {0.0, 0.0}, {sc, sc}, {4, 4})};
    cb::CombineSettings settings;
    settings.how = cb::Combination::Guided;
    settings.guideClamp = z;
    const double limit = z * std::sqrt(sp * sp + 2.0 * sc * sc / 4.0);
    REQUIRE(limit < 1.0);
    for (float v : cb::combine(inputs, settings).image.rgb)
        CHECK(v == doctest::Approx(limit).epsilon(1e-5));

    // Half h's correction is filtered with edge stops from the pattern-prone half 1 - h (which
    // is independent of it): the halves differ, one with an edge and one flat, so using the
    // wrong half changes the image.
    const int w = 12, hgt = 3;
    auto a = constantHalves("pt", 4, {0, 0}, {0.1, 0.1}, {4, 4}, w, hgt);
    auto b = constantHalves("cbdpt", 5, {0, 0}, {0.1, 0.1}, {4, 4}, w, hgt);
    for (int y = 0; y < hgt; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) {
                const size_t e = size_t(3 * (y * w + x) + c);
                a.halfMean[0].rgb[e] = x < 6 ? -1.f : 1.f;
                a.halfMean[1].rgb[e] = x < 6 ? 1.f : -1.f;
                b.halfMean[0].rgb[e] = x < 6 ? 0.1f : 1.f; // an edge
                b.halfMean[1].rgb[e] = 0.5f;               // flat
            }
    settings.guideClamp = 0.0;
    const auto guided = cb::combine({a, b}, settings);
    cb::RgbImage expected(w, hgt);
    for (int half = 0; half < 2; ++half) {
        cb::RgbImage difference(w, hgt);
        for (size_t e = 0; e < difference.rgb.size(); ++e)
            difference.rgb[e] = a.halfMean[size_t(half)].rgb[e] - b.halfMean[size_t(half)].rgb[e];
        const auto filtered = cb::jointBilateralFilter(difference, b.halfMean[size_t(1 - half)],
                                                       settings.guideSigma, settings.guideRange);
        for (size_t e = 0; e < expected.rgb.size(); ++e)
            expected.rgb[e] += 0.5f * (b.halfMean[size_t(half)].rgb[e] + filtered.rgb[e]);
    }
    for (size_t e = 0; e < expected.rgb.size(); ++e)
        CHECK(guided.image.rgb[e] == doctest::Approx(expected.rgb[e]).epsilon(1e-5));
}

TEST_CASE("combine: refusals among three inputs, of crops, Sobol and too few half estimates") {
    auto a = gaussianInput("pt", 1, 4, 8, 1.0, 0.1);
    auto b = gaussianInput("cbdpt", 2, 4, 8, 1.0, 0.1);
    auto c = gaussianInput("cbdpt", 2, 4, 8, 1.0, 0.1);
    // The second and third share a seed and estimates: every pair is checked, not only pairs
    // with the first.
    CHECK_THROWS_WITH_AS(cb::requireCombinable({a, b, c}), doctest::Contains("not independent"),
                         std::invalid_argument);
    c.record.seed = 3;
    CHECK_NOTHROW(cb::requireCombinable({a, b, c}));
    auto crop = b;
    crop.record.pixelBounds = "0 4 0 4";
    CHECK_THROWS_WITH_AS(cb::requireCombinable({a, crop}), doctest::Contains("parts of the film"),
                         std::invalid_argument);
    // One seed with the Sobol sampler in either input: parts of one sequence.
    auto sobol = gaussianInput("cbdpt", 1, 4, 8, 1.0, 0.1);
    sobol.record.estimateSet = cb::EstimateSet::range(8, 16);
    sobol.record.sampler = "sobol";
    a.record.sampler = "independent";
    CHECK_THROWS_WITH_AS(cb::requireCombinable({a, sobol}), doctest::Contains("Sobol"),
                         std::invalid_argument);
    // CPT's cap is its Ne alone, as PT's: CPT Ne = 8 goes with PT Ne = 8, CPT Ne = 4 does not.
    auto cpt = b;
    cpt.record.method = "cpt";
    cpt.record.eyeVertices = 8;
    CHECK_NOTHROW(cb::requireCombinable({a, cpt}));
    cpt.record.eyeVertices = 4;
    CHECK_THROWS_WITH_AS(cb::requireCombinable({a, cpt}), doctest::Contains("vertex caps"),
                         std::invalid_argument);
    // Cross weights need a variance from each half: one estimate in a half has none.
    cb::CombineSettings settings;
    settings.how = cb::Combination::InverseVariance;
    auto thin = constantHalves("pt", 7, {1, 1}, {0.1, 0.1}, {2, 1});
    auto full = constantHalves("cbdpt", 8, {1, 1}, {0.1, 0.1}, {4, 4});
    CHECK_THROWS_WITH_AS(cb::combine({thin, full}, settings),
                         doctest::Contains("at least 2 estimates each"), std::invalid_argument);
}

TEST_CASE("combine: --shares parses fractions that sum to 1, the last one implied") {
    CHECK(cb::parseShares("0.25,0.75", 2) == std::vector<double>{0.25, 0.75});
    const auto implied = cb::parseShares("0.3", 2);
    REQUIRE(implied.size() == 2);
    CHECK(implied[1] == doctest::Approx(0.7));
    // Shares that already sum to 1 leave nothing for a third method (a zero share renders
    // nothing); sums off 1 beyond rounding, zero and non-numbers are refused.
    for (auto [text, methods] : std::vector<std::pair<std::string, size_t>>{
             {"0.5,0.5", 3}, {"0.3,0.695", 2}, {"0,0.5", 3}, {"0.5,x", 2}, {"0.2,0.2", 2}}) {
        CAPTURE(text);
        CHECK_THROWS_WITH_AS(cb::parseShares(text, methods), doctest::Contains("--shares"),
                             std::invalid_argument);
    }
}
