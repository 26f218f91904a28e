// The render driver: runs estimates until the requested count or time, accumulates them, and
// stops cleanly between estimates when asked (Ctrl-C).
#pragma once

#include "image/image.h"
#include "integrators/integrator.h"

#include <atomic>
#include <functional>

namespace cb {

struct RenderLimits {
    long estimates = 16;     // stop after this many (0: no limit; then seconds must be > 0)
    double seconds = 0.0;    // stop once this much render time has passed (0: no limit)
};

struct RenderProgress {
    long estimatesDone = 0;
    long estimatesTarget = 0; // 0 when rendering to time
    double elapsedSeconds = 0.0;
    double remainingSeconds = 0.0; // estimate
};

struct RenderOutcome {
    double renderSeconds = 0.0; // estimates only: excludes scene load and kernel build
    bool interrupted = false;
    long nonFiniteSamples = 0;
};

// Render into `accumulator` (which may already hold estimates, e.g. when resuming: estimate
// numbers continue from accumulator.estimates()). `stop` is polled between estimates.
RenderOutcome renderEstimates(Integrator& integrator, EstimateAccumulator& accumulator,
                              const RenderLimits& limits, const std::atomic<bool>& stop,
                              const std::function<void(const RenderProgress&)>& onProgress = {});

} // namespace cb
