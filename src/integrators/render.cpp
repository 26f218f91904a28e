#include "integrators/render.h"

#include <chrono>
#include <stdexcept>

namespace cb {

RenderOutcome renderEstimates(Integrator& integrator, EstimateAccumulator& accumulator,
                              const RenderLimits& limits, const std::atomic<bool>& stop,
                              const std::function<void(const RenderProgress&)>& onProgress) {
    if (limits.estimates <= 0 && limits.seconds <= 0.0)
        throw std::invalid_argument("a render needs a number of estimates (--spp) or a time "
                                    "(--time), both were zero");
    using Clock = std::chrono::steady_clock;
    RenderOutcome outcome;
    std::vector<float> rgb;
    const auto start = Clock::now();
    long done = 0;
    const long first = accumulator.estimates();
    auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
    while (true) {
        if (limits.estimates > 0 && first + done >= limits.estimates) break;
        if (limits.seconds > 0.0 && elapsed() >= limits.seconds) break;
        if (stop.load()) {
            outcome.interrupted = true;
            break;
        }
        integrator.renderEstimate(std::uint32_t(first + done), rgb);
        accumulator.add(rgb.data());
        ++done;
        if (onProgress) {
            RenderProgress p;
            p.estimatesDone = first + done;
            p.estimatesTarget = limits.estimates;
            p.elapsedSeconds = elapsed();
            double perEstimate = p.elapsedSeconds / double(done);
            double byCount = limits.estimates > 0
                                 ? perEstimate * double(limits.estimates - first - done)
                                 : 1e300;
            double byTime = limits.seconds > 0.0 ? limits.seconds - p.elapsedSeconds : 1e300;
            p.remainingSeconds = std::max(0.0, std::min(byCount, byTime));
            onProgress(p);
        }
    }
    outcome.renderSeconds = elapsed();
    outcome.nonFiniteSamples = integrator.nonFiniteSamples();
    return outcome;
}

} // namespace cb
