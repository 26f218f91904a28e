#include "integrators/render.h"

#include "image/metrics.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <time.h>

namespace cb {

double processCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

std::vector<long> parseCheckpointList(const std::string& text, const std::string& option) {
    std::vector<long> out;
    std::istringstream in(text);
    std::string item;
    while (std::getline(in, item, ',')) {
        size_t used = 0;
        long value = 0;
        try {
            value = std::stol(item, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used == 0 || used != item.size() || value <= 0)
            throw std::invalid_argument(
                fmt::format("{} '{}': '{}' is not a positive estimate count", option, text, item));
        if (!out.empty() && value <= out.back())
            throw std::invalid_argument(
                fmt::format("{} '{}' must be strictly increasing", option, text));
        out.push_back(value);
    }
    if (out.empty()) throw std::invalid_argument(fmt::format("{} is empty", option));
    return out;
}

namespace {
// Seconds per estimate after `done` estimates took `seconds`, the first of them `first`: the
// later ones' mean, since the first may include PoCL's lazy kernel compilation.
double perEstimateSeconds(double seconds, double first, long done) {
    if (done <= 0) return 0.0;
    if (done == 1) return seconds;
    return (seconds - first) / double(done - 1);
}
} // namespace

double RenderOutcome::secondsPerEstimate() const {
    return perEstimateSeconds(renderSeconds, firstEstimateSeconds, estimatesRendered);
}

RenderOutcome renderEstimates(Integrator& integrator, EstimateAccumulator& accumulator,
                              const RenderLimits& limits, const std::atomic<bool>& stop,
                              const std::function<void(const RenderProgress&)>& onProgress) {
    return renderEstimates(integrator, accumulator, limits, stop, onProgress, {}, {});
}

RenderOutcome renderEstimates(Integrator& integrator, EstimateAccumulator& accumulator,
                              const RenderLimits& limits, const std::atomic<bool>& stop,
                              const std::function<void(const RenderProgress&)>& onProgress,
                              const CheckpointSchedule& checkpoints,
                              const std::function<void(const Checkpoint&)>& onCheckpoint) {
    if (limits.estimates <= 0 && limits.seconds <= 0.0 && limits.targetStandardError <= 0.0)
        throw std::invalid_argument("a render needs a number of estimates (--spp), a time "
                                    "(--time) or a target standard error (--target-stderr)");
    if (checkpoints.everySeconds < 0.0 || !std::isfinite(checkpoints.everySeconds))
        throw std::invalid_argument("--checkpoint-every must be a positive number of seconds");
    using Clock = std::chrono::steady_clock;
    RenderOutcome outcome;
    std::vector<float> rgb;
    const auto start = Clock::now();
    // Time spent in checkpoint callbacks, subtracted from render time.
    Clock::duration paused{0};
    const double cpuStart = processCpuSeconds();
    double cpuPaused = 0.0;
    auto cpuElapsed = [&] { return processCpuSeconds() - cpuStart - cpuPaused; };
    long done = 0;
    const long first = accumulator.estimates();
    auto elapsed = [&] {
        return std::chrono::duration<double>(Clock::now() - start - paused).count();
    };
    size_t nextListed = 0;
    while (nextListed < checkpoints.estimates.size() && checkpoints.estimates[nextListed] <= first)
        ++nextListed;
    double nextTime = checkpoints.everySeconds;
    long lastCheckpoint = -1;
    auto fire = [&](double seconds, double cpuSeconds, bool final) {
        const auto before = Clock::now();
        const double cpuBefore = processCpuSeconds();
        Checkpoint c;
        c.estimates = first + done;
        c.renderSeconds = seconds;
        c.renderCpuSeconds = cpuSeconds;
        c.final = final;
        onCheckpoint(c);
        lastCheckpoint = first + done;
        paused += Clock::now() - before;
        cpuPaused += processCpuSeconds() - cpuBefore;
    };
    // Of the estimates so far (a resumed render starts with some), when there is a target.
    const bool haveTarget = limits.targetStandardError > 0.0;
    double standardError =
        haveTarget && first >= 2 ? estimateNoise(accumulator).meanStandardError : 0.0;
    while (true) {
        if (limits.estimates > 0 && first + done >= limits.estimates) break;
        if (limits.seconds > 0.0 && elapsed() >= limits.seconds) break;
        if (haveTarget && first + done >= 2 && standardError < limits.targetStandardError) {
            outcome.reachedTargetStandardError = true;
            break;
        }
        if (stop.load()) {
            outcome.interrupted = true;
            break;
        }
        integrator.renderEstimate(std::uint32_t(first + done), rgb);
        accumulator.add(rgb.data());
        ++done;
        if (haveTarget && first + done >= 2)
            standardError = estimateNoise(accumulator).meanStandardError;
        const double now = elapsed();
        const double cpuNow = cpuElapsed();
        if (done == 1) outcome.firstEstimateSeconds = now;
        if (onCheckpoint) {
            bool due = false;
            while (nextListed < checkpoints.estimates.size() &&
                   checkpoints.estimates[nextListed] <= first + done) {
                due = true;
                ++nextListed;
            }
            if (nextTime > 0.0 && now >= nextTime) {
                due = true;
                // A slow estimate may cross several multiples; the next is the one after now.
                nextTime =
                    (std::floor(now / checkpoints.everySeconds) + 1.0) * checkpoints.everySeconds;
            }
            if (due) fire(now, cpuNow, false);
        }
        if (onProgress) {
            RenderProgress p;
            p.estimatesDone = first + done;
            p.estimatesTarget = limits.estimates;
            p.elapsedSeconds = now;
            double perEstimate = perEstimateSeconds(now, outcome.firstEstimateSeconds, done);
            double byCount = limits.estimates > 0
                                 ? perEstimate * double(limits.estimates - first - done)
                                 : 1e300;
            double byTime = limits.seconds > 0.0 ? limits.seconds - p.elapsedSeconds : 1e300;
            // The standard error falls as 1/sqrt(n): n (E_n / target)^2 estimates reach it.
            double byTarget = 1e300;
            if (haveTarget && standardError > 0.0) {
                const double n = double(first + done);
                const double needed = n * std::pow(standardError / limits.targetStandardError, 2);
                byTarget = perEstimate * std::max(0.0, needed - n);
            }
            p.remainingSeconds = std::max(0.0, std::min({byCount, byTime, byTarget}));
            onProgress(p);
        }
    }
    outcome.renderSeconds = elapsed();
    outcome.renderCpuSeconds = cpuElapsed();
    outcome.estimatesRendered = done;
    outcome.nonFiniteSamples = integrator.nonFiniteSamples();
    if (onCheckpoint && first + done > 0 && lastCheckpoint != first + done)
        fire(outcome.renderSeconds, outcome.renderCpuSeconds, true);
    return outcome;
}

} // namespace cb
