// The render driver: runs estimates until the requested count or time, accumulates them, and
// stops cleanly between estimates when asked (Ctrl-C).
#pragma once

#include "image/image.h"
#include "integrators/integrator.h"

#include <atomic>
#include <functional>
#include <string>
#include <vector>

namespace cb {

struct RenderLimits {
    long estimates = 16;  // stop after this many (0: no limit; then seconds or target is > 0)
    double seconds = 0.0; // stop once this much render time has passed (0: no limit)
    // Stop once the mean per-pixel standard error of the mean (estimateNoise, image/metrics.h)
    // falls below this; it needs 2 estimates (0: no target).
    double targetStandardError = 0.0;
};

struct RenderProgress {
    long estimatesDone = 0;
    long estimatesTarget = 0; // 0 when rendering to time
    double elapsedSeconds = 0.0;
    double remainingSeconds = 0.0; // estimate
};

struct RenderOutcome {
    double renderSeconds = 0.0;    // estimates only: excludes scene load and kernel build
    double renderCpuSeconds = 0.0; // process CPU seconds over the same span (checkpoints excluded)
    // Estimates this call rendered (fewer than the accumulator holds when resuming), and the
    // render seconds of the first of them: it includes PoCL's compilation of the kernel for its
    // work-group size, which happens at the first launch, so it can take seconds longer.
    long estimatesRendered = 0;
    double firstEstimateSeconds = 0.0;
    // Render seconds per estimate of this call, the first estimate excluded when there are
    // others (the steady-state cost); renderSeconds when only one estimate was rendered.
    double secondsPerEstimate() const;
    bool interrupted = false;
    bool reachedTargetStandardError = false;
    long nonFiniteSamples = 0;
};

// Render into `accumulator` (which may already hold estimates, e.g. when resuming: estimate
// numbers continue from accumulator.estimates()). `stop` is polled between estimates.
RenderOutcome renderEstimates(Integrator& integrator, EstimateAccumulator& accumulator,
                              const RenderLimits& limits, const std::atomic<bool>& stop,
                              const std::function<void(const RenderProgress&)>& onProgress = {});

// Checkpoints (issue 7): moments during a render at which the caller evaluates the image so far.
// They fire after the estimate that reaches a listed estimate count, and after the first estimate
// that ends at or past each multiple of everySeconds of render time; a last one fires when the
// render ends (by count, time or Ctrl-C) unless one fired on that same estimate. The time the
// callback takes is excluded from render time: the clock pauses while it runs, so error against
// time curves and --time budgets measure rendering alone.
// Process CPU time of all threads, in seconds.
double processCpuSeconds();

struct CheckpointSchedule {
    std::vector<long> estimates; // ascending, positive
    double everySeconds = 0.0;   // 0: none by time
    bool empty() const { return estimates.empty() && everySeconds <= 0.0; }
};

struct Checkpoint {
    long estimates = 0;
    double renderSeconds = 0.0; // estimates only, checkpoint evaluation excluded
    // Process CPU seconds (all threads, PoCL's included) over the same span: robust to other
    // processes sharing the machine, which wall time is not.
    double renderCpuSeconds = 0.0;
    bool final = false; // the render's last checkpoint
};

// Parses "1,2,4,8": positive, strictly increasing; throws std::invalid_argument naming `option`.
std::vector<long> parseCheckpointList(const std::string& text,
                                      const std::string& option = "--checkpoints");

RenderOutcome renderEstimates(Integrator& integrator, EstimateAccumulator& accumulator,
                              const RenderLimits& limits, const std::atomic<bool>& stop,
                              const std::function<void(const RenderProgress&)>& onProgress,
                              const CheckpointSchedule& checkpoints,
                              const std::function<void(const Checkpoint&)>& onCheckpoint);

} // namespace cb
