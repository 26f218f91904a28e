#include "integrators/split_budget.h"

#include <fmt/format.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace cb {

SplitBudgetRender
renderSplitBudget(const DeviceScene& scene, ClRuntime& runtime, const SceneDesc& desc,
                  const SplitBudgetSettings& s, const std::atomic<bool>& stop,
                  const std::function<void(size_t, const RenderProgress&)>& onProgress) {
    if (s.methods.empty() || s.methods.size() != s.shares.size())
        throw std::invalid_argument("--split-budget: one share per method is needed");
    if (!(s.seconds > 0.0) || !std::isfinite(s.seconds))
        throw std::invalid_argument("--split-budget: the budget must be a positive number of "
                                    "seconds");
    SplitBudgetRender out;
    const std::string sceneHash = sceneContentHash(desc.sourceFiles);
    std::vector<std::unique_ptr<Integrator>> integrators;
    for (const auto& settings : s.methods) {
        integrators.push_back(makeIntegrator(settings, scene, runtime));
        out.kernelBuildSeconds += integrators.back()->buildSeconds();
        std::vector<float> discarded;
        integrators.back()->renderEstimate(0, discarded);
    }
    for (size_t i = 0; i < s.methods.size(); ++i) {
        out.accumulators.emplace_back(scene.camera.width, scene.camera.height);
        out.accumulators.back().trackHalves();
        RenderOutcome outcome;
        if (!out.interrupted) {
            RenderLimits limits;
            limits.estimates = 0;
            limits.seconds = s.shares[i] * s.seconds;
            outcome = renderEstimates(*integrators[i], out.accumulators.back(), limits, stop,
                                      [&](const RenderProgress& p) {
                                          if (onProgress) onProgress(i, p);
                                      });
            out.interrupted = outcome.interrupted;
        }
        out.records.push_back(makeRenderRecord(s.methods[i], desc.sourceFiles.at(0), sceneHash,
                                               scene.channels, outcome));
        out.outcomes.push_back(outcome);
    }
    return out;
}

std::vector<double> parseShares(const std::string& text, size_t methods) {
    std::vector<double> shares;
    std::istringstream in(text);
    std::string item;
    while (std::getline(in, item, ',')) {
        size_t used = 0;
        double v = 0.0;
        try {
            v = std::stod(item, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used == 0 || used != item.size() || !(v > 0.0) || !(v < 1.0))
            throw std::invalid_argument(
                fmt::format("--shares '{}': '{}' is not a fraction between 0 and 1", text, item));
        shares.push_back(v);
    }
    double sum = 0.0;
    for (double v : shares)
        sum += v;
    if (shares.size() + 1 == methods && sum < 1.0) shares.push_back(1.0 - sum);
    sum = 0.0;
    for (double v : shares)
        sum += v;
    if (shares.size() != methods || std::fabs(sum - 1.0) > 1e-9)
        throw std::invalid_argument(
            fmt::format("--shares '{}' must give {} fractions summing to 1 (or {} summing to less)",
                        text, methods, methods - 1));
    return shares;
}

} // namespace cb
