#include "integrators/render.h"

#include "image/metrics.h"

#include <fmt/format.h>

#include <filesystem>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>
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

RenderIdentity renderIdentity(const IntegratorSettings& settings, const SceneDesc& desc,
                              const DeviceScene& scene) {
    RenderIdentity id;
    const char* forcedBvh = std::getenv("CBDPT_BVH_SETTINGS");
    id.settings = {{"integrator", settings.name},
                   {"eye_vertices", settings.eyeVertices},
                   {"light_vertices", settings.lightVertices},
                   {"max_vertices", settings.maxPathVertices},
                   {"weights", settings.weights},
                   {"strategy", {settings.debugS, settings.debugT}},
                   {"roulette_vertex", settings.rouletteVertex},
                   {"coherence_tile", settings.coherenceTile},
                   {"tile", settings.tileSize},
                   {"seed", settings.seed},
                   {"sampler", settings.sampler},
                   {"channels", scene.channels},
                   {"width", scene.camera.width},
                   {"height", scene.camera.height},
                   {"bvh_settings", forcedBvh ? forcedBvh : "chosen"},
                   {"kernel_sources", kernelSourceHash()}};
    // A crop window (--cropwindow) renders part of a larger film: another image of the same size.
    if (desc.film.pixelBounds) id.settings["pixel_bounds"] = *desc.film.pixelBounds;
    if (settings.name == "mlt")
        id.settings["mlt"] = {settings.largeStepProbability, settings.mutationSize,
                              settings.mltChains, settings.mltBootstrap};
    id.sceneHash = sceneContentHash(desc.sourceFiles);
    return id;
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
                              const std::function<void(const Checkpoint&)>& onCheckpoint,
                              RenderTeam* team) {
    if (limits.estimates <= 0 && limits.seconds <= 0.0 && limits.targetStandardError <= 0.0)
        throw std::invalid_argument("a render needs a number of estimates (--spp), a time "
                                    "(--time) or a target standard error (--target-stderr)");
    if (checkpoints.everySeconds < 0.0 || !std::isfinite(checkpoints.everySeconds))
        throw std::invalid_argument("--checkpoint-every must be a positive number of seconds");
    if (checkpoints.saveStateEverySeconds < 0.0 ||
        !std::isfinite(checkpoints.saveStateEverySeconds))
        throw std::invalid_argument("--save-state-every must be a positive number of seconds");
    RenderTeam alone;
    RenderTeam& crew = team ? *team : alone;
    const bool root = crew.rank() == 0;
    using Clock = std::chrono::steady_clock;
    RenderOutcome outcome;
    std::vector<float> rgb;
    const auto start = Clock::now();
    // Time spent in checkpoint callbacks, subtracted from render time.
    Clock::duration paused{0};
    const double cpuStart = processCpuSeconds();
    double cpuPaused = 0.0;
    auto cpuElapsed = [&] { return processCpuSeconds() - cpuStart - cpuPaused; };
    auto elapsed = [&] {
        return std::chrono::duration<double>(Clock::now() - start - paused).count();
    };
    auto wall = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };

    // The estimates left: indices from firstEstimate on that the accumulator does not hold yet
    // (every process walks the same sequence and takes every size()-th of it).
    const std::uint64_t rangeEnd = limits.estimates > 0
                                       ? limits.firstEstimate + std::uint64_t(limits.estimates)
                                       : std::numeric_limits<std::uint64_t>::max();
    const EstimateSet initial = crew.shareFromRoot(accumulator.indices());
    long initialInRange = 0;
    for (const auto& [b, e] : initial.ranges()) {
        const std::uint64_t lo = std::max(b, limits.firstEstimate), hi = std::min(e, rangeEnd);
        if (lo < hi) initialInRange += long(hi - lo);
    }
    std::uint64_t cursor = limits.firstEstimate;
    std::uint64_t position = 0;
    auto nextOwnIndex = [&](std::uint64_t& index) {
        while (true) {
            cursor = initial.nextMissing(cursor);
            if (cursor >= rangeEnd) return false;
            const std::uint64_t candidate = cursor++;
            if (position++ % std::uint64_t(crew.size()) == std::uint64_t(crew.rank())) {
                index = candidate;
                return true;
            }
        }
    };
    std::uint64_t pending = 0;
    bool havePending = nextOwnIndex(pending);

    long done = 0;      // this process's estimates
    long totalDone = 0; // every process's, as last agreed
    size_t nextListed = 0;
    while (nextListed < checkpoints.estimates.size() &&
           checkpoints.estimates[nextListed] <= initialInRange)
        ++nextListed;
    double nextTime = checkpoints.everySeconds;
    double nextSave = checkpoints.saveStateEverySeconds;
    double lastEstimateSeconds = 0.0, lastEstimateCpu = 0.0;
    long lastCheckpoint = -1;
    auto fire = [&](double seconds, double cpuSeconds, bool final, bool evaluate, bool save) {
        const auto before = Clock::now();
        const double cpuBefore = processCpuSeconds();
        const EstimateAccumulator* image = crew.gather(accumulator);
        if (image) {
            Checkpoint c;
            c.estimates = initialInRange + totalDone;
            c.renderSeconds = seconds;
            c.renderCpuSeconds = cpuSeconds;
            c.final = final;
            c.evaluate = evaluate;
            c.saveState = save;
            c.image = image;
            onCheckpoint(c);
        }
        if (evaluate) lastCheckpoint = totalDone;
        paused += Clock::now() - before;
        cpuPaused += processCpuSeconds() - cpuBefore;
        if (save) {
            const double took = std::chrono::duration<double>(Clock::now() - before).count();
            nextSave = wall() + std::max(checkpoints.saveStateEverySeconds, 20.0 * took);
        }
    };
    // The target standard error is measured on this process's accumulator, which is the whole
    // image only when it renders alone.
    const bool haveTarget = limits.targetStandardError > 0.0;
    if (haveTarget && crew.size() > 1)
        throw std::invalid_argument("--target-stderr needs a single process (not under MPI)");
    auto currentStandardError = [&] {
        return haveTarget && accumulator.estimates() >= 2
                   ? estimateNoise(accumulator).meanStandardError
                   : 0.0;
    };
    double standardError = currentStandardError();
    // One round per estimate: agree on the totals and on process 0's clock, evaluate what is
    // due for the estimates done so far, then stop or render the next.
    // Process 0 alone decides when a state is saved (its nextSave, on its clock): processes
    // whose own clocks disagreed would enter the save's reduction in different rounds.
    std::vector<double> shared(7);
    long lastReported = -1;
    while (true) {
        shared = {double(done),
                  stop.load() ? 1.0 : 0.0,
                  havePending ? 1.0 : 0.0,
                  root ? lastEstimateSeconds : 0.0,
                  root ? lastEstimateCpu : 0.0,
                  root && nextSave > 0.0 && wall() >= nextSave ? 1.0 : 0.0,
                  root ? elapsed() : 0.0};
        crew.sumAll(shared);
        const long previous = totalDone;
        totalDone = long(shared[0]);
        const bool stopAsked = shared[1] > 0.0;
        const bool workLeft = shared[2] > 0.0;
        const double now = shared[3], cpuNow = shared[4];
        const bool saveDue = shared[5] > 0.0;
        if (totalDone > previous) {
            if (previous == 0) outcome.firstEstimateSeconds = now;
            if (onCheckpoint) {
                bool due = false;
                while (nextListed < checkpoints.estimates.size() &&
                       checkpoints.estimates[nextListed] <= initialInRange + totalDone) {
                    due = true;
                    ++nextListed;
                }
                if (nextTime > 0.0 && now >= nextTime) {
                    due = true;
                    // A slow estimate may cross several multiples; the next is the one after now.
                    nextTime = (std::floor(now / checkpoints.everySeconds) + 1.0) *
                               checkpoints.everySeconds;
                }
                if (due || saveDue) fire(now, cpuNow, false, due, saveDue);
            }
        }
        if (onProgress && root && totalDone != lastReported) {
            lastReported = totalDone;
            RenderProgress p;
            p.estimatesDone = initialInRange + totalDone;
            p.estimatesTarget = limits.estimates;
            p.elapsedSeconds = now;
            double perEstimate = perEstimateSeconds(now, outcome.firstEstimateSeconds, totalDone) /
                                 double(crew.size());
            double byCount =
                limits.estimates > 0
                    ? perEstimate * double(limits.estimates - initialInRange - totalDone)
                    : 1e300;
            double byTime = limits.seconds > 0.0 ? limits.seconds - p.elapsedSeconds : 1e300;
            // The standard error falls as 1/sqrt(n): n (E_n / target)^2 estimates reach it.
            double byTarget = 1e300;
            if (haveTarget && standardError > 0.0) {
                const double n = double(accumulator.estimates());
                const double needed = n * std::pow(standardError / limits.targetStandardError, 2);
                byTarget = perEstimate * std::max(0.0, needed - n);
            }
            p.remainingSeconds = std::max(0.0, std::min({byCount, byTime, byTarget}));
            if (totalDone > 0) onProgress(p);
        }
        if (stopAsked) {
            outcome.interrupted = true;
            break;
        }
        if (haveTarget && accumulator.estimates() >= 2 &&
            standardError < limits.targetStandardError) {
            outcome.reachedTargetStandardError = true;
            break;
        }
        if (!workLeft) break;
        // A time budget ends the render once it has an estimate: a budget shorter than one
        // estimate still gives an image, as --spp 1 would.
        if (limits.seconds > 0.0 && shared[6] >= limits.seconds && initialInRange + totalDone > 0)
            break;
        if (havePending) {
            integrator.renderEstimate(std::uint32_t(pending), rgb);
            accumulator.add(pending, rgb.data());
            ++done;
            havePending = nextOwnIndex(pending);
            if (haveTarget) standardError = currentStandardError();
        }
        lastEstimateSeconds = elapsed();
        lastEstimateCpu = cpuElapsed();
    }
    outcome.renderSeconds = elapsed();
    outcome.renderCpuSeconds = cpuElapsed();
    outcome.estimatesRendered = done;
    outcome.nonFiniteSamples = integrator.nonFiniteSamples();
    if (onCheckpoint && initialInRange + totalDone > 0 && lastCheckpoint != totalDone)
        fire(outcome.renderSeconds, outcome.renderCpuSeconds, true, true, false);
    return outcome;
}

RenderRecord makeRenderRecord(const IntegratorSettings& settings, const std::string& scenePath,
                              const std::string& sceneHash, int channels,
                              const RenderOutcome& outcome) {
    RenderRecord r;
    r.method = settings.name;
    r.eyeVertices = settings.eyeVertices;
    r.lightVertices = settings.lightVertices;
    r.maxVertices = settings.maxPathVertices;
    r.weights = settings.weights;
    r.coherenceTile = settings.coherenceTile;
    r.rouletteVertex = settings.rouletteVertex;
    r.seed = settings.seed;
    r.sampler = recordedSampler(settings.name, settings.sampler);
    r.strategy = strategyText(settings.debugS, settings.debugT);
    r.channels = channels;
    r.renderSeconds = outcome.renderSeconds;
    r.renderCpuSeconds = outcome.renderCpuSeconds;
    r.sceneFile = std::filesystem::path(scenePath).filename().string();
    r.sceneHash = sceneHash;
    return r;
}

} // namespace cb
