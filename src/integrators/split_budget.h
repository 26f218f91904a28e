// One time budget shared by several methods (`cbdpt combine --split-budget`): each renders its
// share of the budget into an accumulator that keeps the two halves of its estimates, ready to
// be combined (image/combine.h) without a round trip through files.
#pragma once

#include "image/combine.h"
#include "integrators/render.h"

#include <atomic>
#include <functional>
#include <string>
#include <vector>

namespace cb {

struct SplitBudgetSettings {
    std::vector<IntegratorSettings> methods;
    std::vector<double> shares; // fractions of the budget, one per method, summing to 1
    double seconds = 0.0;       // the budget: render seconds of all methods together
};

struct SplitBudgetRender {
    std::vector<EstimateAccumulator> accumulators;
    std::vector<RenderRecord> records;
    std::vector<RenderOutcome> outcomes;
    double kernelBuildSeconds = 0.0; // outside the budget, as for `cbdpt render --time`
    bool interrupted = false;
};

// Builds every method's kernels first, renders one discarded warm-up estimate per method (PoCL
// compiles work-group functions at the first launch), then each method for its share of the
// budget, one after the other. Each method's seed is settings.seed as given; the caller makes
// them differ so the renders are independent. `stop` ends the current method and skips the rest.
// `desc` (the parsed scene of `scene`) names the files whose content hash the records carry.
SplitBudgetRender
renderSplitBudget(const DeviceScene& scene, ClRuntime& runtime, const SceneDesc& desc,
                  const SplitBudgetSettings& settings, const std::atomic<bool>& stop,
                  const std::function<void(size_t, const RenderProgress&)>& onProgress = {});

// Parses "0.3,0.7" (or "0.3" for two methods: the rest goes to the second) into shares that
// are positive and sum to 1; throws std::invalid_argument naming the option.
std::vector<double> parseShares(const std::string& text, size_t methods);

} // namespace cb
