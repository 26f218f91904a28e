// The render driver: runs estimates until the requested count or time, accumulates them, and
// stops cleanly between estimates when asked (Ctrl-C).
#pragma once

#include "image/accumulator.h"
#include "image/image.h"
#include "image/render_record.h"
#include "image/render_state.h"
#include "integrators/integrator.h"
#include "scene/scene_desc.h"

#include <atomic>
#include <functional>
#include <string>
#include <vector>

namespace cb {

// The render covers estimate indices [firstEstimate, firstEstimate + estimates): the index seeds
// every random stream of the estimate, so disjoint ranges (shards) rendered anywhere add up to
// the estimates of one render. Indices the accumulator already holds (a resumed state) are
// skipped.
struct RenderLimits {
    long estimates = 16;  // stop after this many (0: no limit; then seconds or target is > 0)
    double seconds = 0.0; // stop once this much render time has passed (0: no limit)
    // Stop once the mean per-pixel standard error of the mean (estimateNoise, image/metrics.h)
    // falls below this; it needs 2 estimates (0: no target).
    double targetStandardError = 0.0;
    std::uint64_t firstEstimate = 0;
};

// What identifies a render for --resume and merge: every setting that changes its image (the
// kernel sources' hash included) and the hash of the scene's files (docs/scale-out.md).
RenderIdentity renderIdentity(const IntegratorSettings& settings, const SceneDesc& desc,
                              const DeviceScene& scene);

// Processes that render one image together (MPI: src/cluster/mpi_team.h). Each takes every
// size()-th of the estimates left to render, and they agree once per estimate on when to stop,
// checkpoint and save, by process 0's clock. The default is one process alone.
class RenderTeam {
  public:
    virtual ~RenderTeam() = default;
    virtual int rank() const { return 0; }
    virtual int size() const { return 1; }
    // Element-wise sum of `values` over the processes, the same result on every one.
    virtual void sumAll(std::vector<double>& values) { (void)values; }
    // Process 0's `indices` on every process (the estimates a resumed state already holds).
    virtual EstimateSet shareFromRoot(const EstimateSet& indices) { return indices; }
    // The sum of every process's accumulator on process 0, nullptr on the others.
    virtual const EstimateAccumulator* gather(const EstimateAccumulator& local) { return &local; }
    // Wall seconds spent in gather() (its reductions across processes) and how many calls.
    virtual double reductionSeconds() const { return 0.0; }
    virtual long reductions() const { return 0; }
};

struct RenderProgress {
    long estimatesDone = 0;   // all processes', the resumed ones included
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

// Checkpoints: moments during a render at which the caller evaluates the image so far.
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
    // Periodic state saves (wall seconds; 0: none): they fire as checkpoints with saveState set
    // and evaluate clear unless an evaluation is due too. The interval stretches to 20 times
    // the last save's duration, so saving never takes more than about 5% of the time.
    double saveStateEverySeconds = 0.0;
    bool empty() const { return estimates.empty() && everySeconds <= 0.0; }
};

struct Checkpoint {
    long estimates = 0;
    double renderSeconds = 0.0; // estimates only, checkpoint evaluation excluded
    // Process CPU seconds (all threads, PoCL's included) over the same span: robust to other
    // processes sharing the machine, which wall time is not.
    double renderCpuSeconds = 0.0;
    bool final = false;     // the render's last checkpoint
    bool evaluate = true;   // a scheduled or final checkpoint (not only a state save)
    bool saveState = false; // the periodic state save is due
    // The image so far: every process's estimates (process 0 only; the callback runs there).
    const EstimateAccumulator* image = nullptr;
};

// Parses "1,2,4,8": positive, strictly increasing; throws std::invalid_argument naming `option`.
std::vector<long> parseCheckpointList(const std::string& text,
                                      const std::string& option = "--checkpoints");

RenderOutcome renderEstimates(Integrator& integrator, EstimateAccumulator& accumulator,
                              const RenderLimits& limits, const std::atomic<bool>& stop,
                              const std::function<void(const RenderProgress&)>& onProgress,
                              const CheckpointSchedule& checkpoints,
                              const std::function<void(const Checkpoint&)>& onCheckpoint,
                              RenderTeam* team = nullptr);

// The header record of a render (image/render_record.h) with these settings of the scene file
// `scenePath` whose content hash (sceneContentHash) is `sceneHash`; estimates and size are
// filled in when the EXR is written.
RenderRecord makeRenderRecord(const IntegratorSettings& settings, const std::string& scenePath,
                              const std::string& sceneHash, int channels,
                              const RenderOutcome& outcome);

} // namespace cb
