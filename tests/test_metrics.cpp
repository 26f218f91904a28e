// Error metrics and checkpoints on images whose answers are known in closed form.
#include "image/metrics.h"
#include "integrators/render.h"

#include <doctest/doctest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>

namespace {

cb::RgbImage constantImage(int w, int h, float value) {
    cb::RgbImage image(w, h);
    for (auto& v : image.rgb)
        v = value;
    return image;
}

// A gradient reference so the metrics cannot pass by treating every pixel alike.
cb::RgbImage gradientImage(int w, int h) {
    cb::RgbImage image(w, h);
    for (size_t i = 0; i < image.rgb.size(); ++i)
        image.rgb[i] = 0.0625f * float(i % 17);
    return image;
}

} // namespace

TEST_CASE("metrics: a constant offset gives RMSE and MAE equal to the offset") {
    cb::RgbImage reference = gradientImage(13, 7);
    for (float offset : {0.25f, -0.125f}) {
        cb::RgbImage image = reference;
        for (auto& v : image.rgb)
            v += offset;
        cb::ImageMetrics m = cb::compareImages(image, reference);
        // Offsets and the reference are dyadic, so the float sums are exact.
        CHECK(m.rmse == doctest::Approx(std::abs(offset)).epsilon(1e-12));
        CHECK(m.mae == doctest::Approx(std::abs(offset)).epsilon(1e-12));
        CHECK(cb::rootMeanSquaredError(image, reference) == doctest::Approx(std::abs(offset)));
        // relMSE = mean over reference values r of offset^2 / (r^2 + eps).
        double expected = 0.0;
        for (size_t i = 0; i < reference.rgb.size(); ++i) {
            double r = reference.rgb[i];
            expected += double(offset) * offset / (r * r + cb::kRelMseEpsilon);
        }
        expected /= double(reference.rgb.size());
        CHECK(m.relMse == doctest::Approx(expected).epsilon(1e-9));
        CHECK(cb::relativeMeanSquaredError(image, reference) == doctest::Approx(expected));
    }
}

TEST_CASE("metrics: identical images have zero error, and known values on a black reference") {
    cb::RgbImage reference = gradientImage(8, 8);
    cb::ImageMetrics same = cb::compareImages(reference, reference);
    CHECK(same.rmse == 0.0);
    CHECK(same.relMse == 0.0);
    CHECK(same.mae == 0.0);

    // Half the values off by 2 on a black reference: MSE 2, RMSE sqrt 2, MAE 1, relMSE 2/eps.
    cb::RgbImage black = constantImage(4, 2, 0.f);
    cb::RgbImage image = black;
    for (size_t i = 0; i < image.rgb.size(); i += 2)
        image.rgb[i] = 2.f;
    cb::ImageMetrics m = cb::compareImages(image, black);
    CHECK(m.rmse == doctest::Approx(std::sqrt(2.0)));
    CHECK(m.mae == doctest::Approx(1.0));
    CHECK(m.relMse == doctest::Approx(2.0 / cb::kRelMseEpsilon));
    CHECK(cb::relativeMeanSquaredError(image, black, 1.0) == doctest::Approx(2.0));
    CHECK(m.referenceMean == 0.0);
}

TEST_CASE("metrics: a size mismatch names both images and their sizes") {
    cb::RgbImage a = constantImage(4, 3, 1.f), b = constantImage(3, 4, 1.f);
    try {
        cb::requireSameSize(a, b, "a.exr", "b.exr");
        FAIL("no exception");
    } catch (const std::invalid_argument& e) {
        std::string what = e.what();
        CHECK(what.find("a.exr") != std::string::npos);
        CHECK(what.find("b.exr") != std::string::npos);
        CHECK(what.find("4x3") != std::string::npos);
        CHECK(what.find("3x4") != std::string::npos);
    }
    CHECK_THROWS_AS(cb::compareImages(a, b), std::invalid_argument);
}

TEST_CASE("metrics: standard error from the accumulator matches the sample formula") {
    // Every value of estimate k is k (k = 0..n-1): sample variance of 0..n-1 is n (n + 1) / 12,
    // so the standard error of the mean is sqrt((n + 1) / 12) at every pixel.
    const int n = 9;
    cb::EstimateAccumulator acc(5, 3);
    CHECK(std::isnan(cb::estimateNoise(acc).meanStandardError));
    std::vector<float> values(3 * 5 * 3);
    for (int k = 0; k < n; ++k) {
        for (auto& v : values)
            v = float(k);
        acc.add(values.data());
        if (k == 0) CHECK(std::isnan(cb::estimateNoise(acc).meanStandardError));
    }
    cb::NoiseEstimate noise = cb::estimateNoise(acc);
    const double expected = std::sqrt((n + 1) / 12.0);
    CHECK(noise.meanStandardError == doctest::Approx(expected).epsilon(1e-12));
    CHECK(noise.rmsStandardError == doctest::Approx(expected).epsilon(1e-12));
    CHECK(noise.imageMean == doctest::Approx((n - 1) / 2.0));
    CHECK(cb::meanOf(acc.standardError().rgb) == doctest::Approx(expected).epsilon(1e-6));

    // Mean and RMS differ when the per-pixel errors differ: values 3 and 4 give mean 3.5, RMS
    // 5/sqrt 2.
    CHECK(cb::meanOf({3.f, 4.f}) == doctest::Approx(3.5));
    CHECK(cb::rootMeanSquareOf({3.f, 4.f}) == doctest::Approx(std::sqrt(12.5)));
}

TEST_CASE("metrics: the stderr layer round-trips through EXR") {
    auto dir = std::filesystem::temp_directory_path();
    auto with = (dir / "cbdpt_test_metrics_with.exr").string();
    auto without = (dir / "cbdpt_test_metrics_without.exr").string();
    cb::RgbImage image = gradientImage(6, 5), error = constantImage(6, 5, 0.375f);
    error.rgb[7] = 2.5f;
    cb::writeExr(with, image, &error);
    cb::writeExr(without, image);
    cb::RgbImage read;
    REQUIRE(cb::readExrStandardError(with, read));
    CHECK(read.width == 6);
    CHECK(read.height == 5);
    CHECK(read.rgb == error.rgb);
    CHECK_FALSE(cb::readExrStandardError(without, read));
    std::filesystem::remove(with);
    std::filesystem::remove(without);
}

TEST_CASE("metrics: the relative-error colour map is white when exact, red/blue when off") {
    cb::RgbImage reference = constantImage(3, 1, 1.f);
    cb::RgbImage image = reference;
    // Luminance weights sum to 1, so a grey pixel's luminance is its value.
    for (int c = 0; c < 3; ++c) {
        image.rgb[size_t(3 + c)] = 1.f + float(0.5 * (1.0 + cb::kRelMseEpsilon)); // e = +0.5
        image.rgb[size_t(6 + c)] = -0.5f; // e = -1.5 / 1.01, saturated
    }
    auto map = cb::relativeErrorColourMap(image, reference, 1.0);
    REQUIRE(map.size() == 9);
    CHECK(map[0] == 255);
    CHECK(map[1] == 255);
    CHECK(map[2] == 255);
    CHECK(map[3] == 255);
    CHECK(int(map[4]) == doctest::Approx(128).epsilon(0.01));
    CHECK(int(map[5]) == doctest::Approx(128).epsilon(0.01));
    CHECK(map[6] == 0);
    CHECK(map[7] == 0);
    CHECK(map[8] == 255);
    CHECK_THROWS_AS(cb::relativeErrorColourMap(image, reference, 0.0), std::invalid_argument);
}

TEST_CASE("checkpoints: the list parser accepts increasing counts and names bad input") {
    CHECK(cb::parseCheckpointList("1,2,4,8") == std::vector<long>{1, 2, 4, 8});
    CHECK(cb::parseCheckpointList("5") == std::vector<long>{5});
    CHECK_THROWS_WITH_AS(cb::parseCheckpointList("1,x"), doctest::Contains("'x'"),
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(cb::parseCheckpointList("4,2"), doctest::Contains("increasing"),
                         std::invalid_argument);
    CHECK_THROWS_AS(cb::parseCheckpointList("0,1"), std::invalid_argument);
    CHECK_THROWS_AS(cb::parseCheckpointList("1,,2"), std::invalid_argument);
    CHECK_THROWS_AS(cb::parseCheckpointList("2.5"), std::invalid_argument);
    CHECK_THROWS_AS(cb::parseCheckpointList(""), std::invalid_argument);
}

namespace {

// Each estimate takes a fixed time and returns the estimate number everywhere.
class SleepyIntegrator : public cb::Integrator {
  public:
    explicit SleepyIntegrator(std::chrono::milliseconds perEstimate) : perEstimate_(perEstimate) {}
    void renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) override {
        std::this_thread::sleep_for(perEstimate_);
        rgb.assign(3 * 2 * 2, float(estimate));
    }
    long nonFiniteSamples() const override { return 0; }
    double buildSeconds() const override { return 0.0; }

  private:
    std::chrono::milliseconds perEstimate_;
};

} // namespace

TEST_CASE("checkpoints: fire at the listed counts and at the end, with the clock paused") {
    SleepyIntegrator integrator(std::chrono::milliseconds(2));
    cb::EstimateAccumulator acc(2, 2);
    std::atomic<bool> stop{false};
    cb::RenderLimits limits;
    limits.estimates = 10;
    cb::CheckpointSchedule schedule;
    schedule.estimates = {1, 2, 4, 8, 16};
    std::vector<cb::Checkpoint> seen;
    auto outcome = cb::renderEstimates(
        integrator, acc, limits, stop, {}, schedule, [&](const cb::Checkpoint& c) {
            seen.push_back(c);
            CHECK(acc.estimates() == c.estimates);
            // Busy for far longer than the render itself, in wall and in CPU time.
            const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(300);
            while (std::chrono::steady_clock::now() < until) {
            }
        });
    REQUIRE(seen.size() == 5); // 1, 2, 4, 8 and the final 10 (16 is never reached)
    CHECK(seen[0].estimates == 1);
    CHECK(seen[3].estimates == 8);
    CHECK(seen[4].estimates == 10);
    CHECK(seen[4].final);
    CHECK_FALSE(seen[3].final);
    for (size_t i = 1; i < seen.size(); ++i)
        CHECK(seen[i].renderSeconds > seen[i - 1].renderSeconds);
    // 10 estimates of 2 ms each; 5 x 300 ms of checkpoints must not be counted. The bound leaves
    // room for sleeps stretched by a loaded machine (0.36 s seen at load 12), still far below
    // the 1.5 s of wall time the checkpoints took.
    CHECK(outcome.renderSeconds >= 0.018);
    CHECK(outcome.renderSeconds < 1.0);
    CHECK(seen[4].renderSeconds == doctest::Approx(outcome.renderSeconds));
    // The integrator sleeps, so nearly no CPU time is rendering; the 1.5 s of busy checkpoints
    // must not be counted either.
    CHECK(outcome.renderCpuSeconds >= 0.0);
    CHECK(outcome.renderCpuSeconds < 0.1);
    CHECK(seen[4].renderCpuSeconds <= outcome.renderCpuSeconds + 1e-9);
}

TEST_CASE("checkpoints: by time, each after the estimate that crosses a multiple") {
    SleepyIntegrator integrator(std::chrono::milliseconds(5));
    cb::EstimateAccumulator acc(2, 2);
    std::atomic<bool> stop{false};
    cb::RenderLimits limits;
    limits.estimates = 12;
    cb::CheckpointSchedule schedule;
    schedule.everySeconds = 0.02;
    std::vector<cb::Checkpoint> seen;
    cb::renderEstimates(integrator, acc, limits, stop, {}, schedule,
                        [&](const cb::Checkpoint& c) { seen.push_back(c); });
    // 12 x >= 5 ms = >= 60 ms of render: at least the 20 and 40 ms marks, then the final one.
    REQUIRE(seen.size() >= 3);
    CHECK(seen.back().estimates == 12);
    for (size_t i = 0; i + 1 < seen.size(); ++i) {
        CHECK(seen[i].renderSeconds >= 0.02 * double(i + 1) - 1e-9);
        CHECK(seen[i + 1].estimates > seen[i].estimates);
    }
    // Without a checkpoint callback nothing fires and the old overload behaves as before.
    cb::EstimateAccumulator plain(2, 2);
    auto outcome = cb::renderEstimates(integrator, plain, limits, stop);
    CHECK(plain.estimates() == 12);
    CHECK_FALSE(outcome.interrupted);
}

TEST_CASE("render timing: the first estimate is reported apart from the steady-state rate") {
    // The first estimate of a render includes PoCL's lazy kernel compilation; seconds per
    // estimate leaves it out. Identities only: no thresholds on how long anything took.
    SleepyIntegrator integrator(std::chrono::milliseconds(1));
    std::atomic<bool> stop{false};
    cb::RenderLimits limits;
    limits.estimates = 5;
    cb::EstimateAccumulator acc(2, 2);
    double firstAtCheckpoint = -1.0;
    cb::CheckpointSchedule schedule;
    schedule.estimates = {1};
    auto outcome = cb::renderEstimates(integrator, acc, limits, stop, {}, schedule,
                                       [&](const cb::Checkpoint& c) {
                                           if (c.estimates == 1)
                                               firstAtCheckpoint = c.renderSeconds;
                                       });
    CHECK(outcome.estimatesRendered == 5);
    CHECK(outcome.firstEstimateSeconds > 0.0);
    CHECK(outcome.firstEstimateSeconds == firstAtCheckpoint);
    CHECK(outcome.firstEstimateSeconds <= outcome.renderSeconds);
    CHECK(outcome.secondsPerEstimate() ==
          doctest::Approx((outcome.renderSeconds - outcome.firstEstimateSeconds) / 4.0));
    CHECK(outcome.secondsPerEstimate() * 4.0 + outcome.firstEstimateSeconds ==
          doctest::Approx(outcome.renderSeconds));

    // Resuming: the accumulator already holds 5 estimates; this call renders 2 more.
    limits.estimates = 7;
    auto resumed = cb::renderEstimates(integrator, acc, limits, stop);
    CHECK(acc.estimates() == 7);
    CHECK(resumed.estimatesRendered == 2);
    CHECK(resumed.secondsPerEstimate() ==
          doctest::Approx(resumed.renderSeconds - resumed.firstEstimateSeconds));

    // One estimate: it is both the first and the per-estimate time.
    cb::EstimateAccumulator single(2, 2);
    limits.estimates = 1;
    auto one = cb::renderEstimates(integrator, single, limits, stop);
    CHECK(one.estimatesRendered == 1);
    CHECK(one.firstEstimateSeconds > 0.0);
    CHECK(one.firstEstimateSeconds <= one.renderSeconds);
    CHECK(one.secondsPerEstimate() == one.renderSeconds);

    // Nothing rendered (the limit was already reached): zero, not a division by zero.
    auto none = cb::renderEstimates(integrator, single, limits, stop);
    CHECK(none.estimatesRendered == 0);
    CHECK(none.secondsPerEstimate() == 0.0);
}

namespace {

// Independent noise around 1: each estimate's pixels are uniform in [0, 2).
class NoisyIntegrator : public cb::Integrator {
  public:
    void renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) override {
        std::mt19937 rng(estimate);
        std::uniform_real_distribution<float> uniform(0.0f, 2.0f);
        rgb.resize(3 * 4 * 4);
        for (float& v : rgb)
            v = uniform(rng);
    }
    long nonFiniteSamples() const override { return 0; }
    double buildSeconds() const override { return 0.0; }
};

} // namespace

TEST_CASE("target standard error: the render stops at the first estimate count below it") {
    // Uniform [0, 2) has standard deviation 1/sqrt(3): the mean standard error after n
    // estimates is about 0.577 / sqrt(n), so 0.1 takes about 33 estimates.
    NoisyIntegrator integrator;
    cb::EstimateAccumulator acc(4, 4);
    std::atomic<bool> stop{false};
    cb::RenderLimits limits;
    limits.estimates = 0;
    limits.targetStandardError = 0.1;
    const cb::RenderOutcome outcome = cb::renderEstimates(integrator, acc, limits, stop);
    CHECK(outcome.reachedTargetStandardError);
    const long n = acc.estimates();
    CHECK(n > 15);
    CHECK(n < 70);
    CHECK(cb::estimateNoise(acc).meanStandardError < 0.1);
    // One estimate fewer was not below the target.
    cb::EstimateAccumulator fewer(4, 4);
    std::vector<float> rgb;
    for (long e = 0; e < n - 1; ++e) {
        integrator.renderEstimate(std::uint32_t(e), rgb);
        fewer.add(rgb.data());
    }
    CHECK(cb::estimateNoise(fewer).meanStandardError >= 0.1);
    // With an estimate limit too, the first limit reached ends the render.
    cb::EstimateAccumulator capped(4, 4);
    limits.estimates = 5;
    const cb::RenderOutcome early = cb::renderEstimates(integrator, capped, limits, stop);
    CHECK(capped.estimates() == 5);
    CHECK_FALSE(early.reachedTargetStandardError);
}

TEST_CASE("metrics: per-value statistics that differ across pixels and channels") {
    // The reference mean is the plain mean of the reference's values (a gradient, not zero).
    const cb::RgbImage reference = gradientImage(5, 4);
    double refSum = 0.0;
    for (float v : reference.rgb)
        refSum += v;
    CHECK(cb::compareImages(reference, reference).referenceMean ==
          doctest::Approx(refSum / double(reference.rgb.size())).epsilon(1e-12));

    // Estimates whose spread differs per value: estimate k of value i is (i + 1) k, so value i's
    // sample variance is (i + 1)^2 n (n + 1) / 12 and its standard error (i + 1) sqrt((n + 1) /
    // 12). The mean of those and their root mean square then differ.
    const int n = 5;
    cb::EstimateAccumulator acc(2, 1);
    std::vector<float> values(6);
    for (int k = 0; k < n; ++k) {
        for (size_t i = 0; i < values.size(); ++i)
            values[i] = float(double(i + 1) * k);
        acc.add(values.data());
    }
    double seSum = 0.0, varSum = 0.0;
    for (size_t i = 0; i < values.size(); ++i) {
        const double se = double(i + 1) * std::sqrt((n + 1) / 12.0);
        seSum += se;
        varSum += se * se;
    }
    const cb::NoiseEstimate noise = cb::estimateNoise(acc);
    CHECK(noise.meanStandardError == doctest::Approx(seSum / 6.0).epsilon(1e-12));
    CHECK(noise.rmsStandardError == doctest::Approx(std::sqrt(varSum / 6.0)).epsilon(1e-12));
}

TEST_CASE("metrics: the colour map weighs channels by Rec. 709 luminance, signed by |L_ref|") {
    // A red-only excess x on a grey reference of 1 has luminance error 0.2126 x: x chosen for
    // e = 0.5 gives half-faded red (g = b = 128).
    cb::RgbImage reference = constantImage(2, 1, 1.f);
    cb::RgbImage image = reference;
    image.rgb[0] = float(1.0 + 0.5 * (1.0 + cb::kRelMseEpsilon) / 0.2126);
    // A reference of negative luminance (RGB from spectra can be) and an image above it: too
    // bright, so red, whatever the reference's sign: e = 0.5 / (|-1| + eps).
    for (int c = 0; c < 3; ++c) {
        reference.rgb[size_t(3 + c)] = -1.f;
        image.rgb[size_t(3 + c)] = -0.5f;
    }
    const auto map = cb::relativeErrorColourMap(image, reference, 1.0);
    REQUIRE(map.size() == 6);
    CHECK(map[0] == 255);
    CHECK(int(map[1]) == doctest::Approx(128).epsilon(0.01));
    CHECK(int(map[2]) == doctest::Approx(128).epsilon(0.01));
    const int fade = int(std::lround(255.0 * (1.0 - 0.5 / (1.0 + cb::kRelMseEpsilon))));
    CHECK(map[3] == 255);
    CHECK(int(map[4]) == fade);
    CHECK(int(map[5]) == fade);
}

TEST_CASE("metrics: a pixel buffer that does not fit the size is refused on either side") {
    cb::RgbImage a = constantImage(2, 2, 1.f), b = constantImage(2, 2, 1.f);
    b.rgb.resize(6); // claims 2x2 but holds 2 pixels: reading it would run past its end
    CHECK_THROWS_WITH_AS(cb::compareImages(a, b), doctest::Contains("malformed"),
                         std::invalid_argument);
    CHECK_THROWS_WITH_AS(cb::compareImages(b, a), doctest::Contains("malformed"),
                         std::invalid_argument);
}
