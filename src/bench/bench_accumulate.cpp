// cbdpt-bench, accumulate section: the host's exact accumulation of one estimate's image
// (EstimateAccumulator::add, image/accumulator.h), in process CPU seconds per estimate, with and
// without the two halves that every render keeps. The renders wait for it between kernel
// launches, so it bounds how fast a fast device (a GPU) can render small estimates.
#include "bench/bench.h"

#include "image/accumulator.h"

#include <fmt/format.h>

#include <random>

namespace cb::bench {

json runAccumulate(const Options& o) {
    const int repeats = o.repeats > 0 ? o.repeats : (o.quick ? 2 : 5);
    fmt::print("\n== accumulate: EstimateAccumulator::add, CPU ms per estimate (median of {})\n",
               repeats);
    fmt::print("{:<10} {:>8} {:>12} {:>12}\n", "image", "halves", "cpu ms", "ns/value");
    json rows = json::array();
    const std::vector<int> sizes = o.quick ? std::vector<int>{64} : std::vector<int>{256, 512};
    const int estimates = o.quick ? 4 : 32;
    for (int size : sizes)
        for (bool halves : {false, true}) {
            // Radiance-like values: exponential, a few larger than 16 (whose squares take the
            // wide path of FixedPoint::addScaled), none zero.
            std::vector<float> rgb(size_t(3) * size_t(size) * size_t(size));
            std::mt19937 generator(7);
            std::exponential_distribution<float> value(2.0f);
            for (float& v : rgb)
                v = value(generator) + 1e-6f;
            std::vector<double> perEstimate;
            for (int r = 0; r < repeats; ++r) {
                EstimateAccumulator accumulator(size, size);
                if (halves) accumulator.trackHalves();
                accumulator.add(rgb.data()); // first touch of the sums' pages: not timed
                const double before = processCpuSeconds();
                for (int e = 0; e < estimates; ++e)
                    accumulator.add(rgb.data());
                perEstimate.push_back((processCpuSeconds() - before) / estimates);
            }
            const double seconds = median(perEstimate);
            const double values = double(rgb.size());
            fmt::print("{:<10} {:>8} {:>12.3f} {:>12.2f}\n", fmt::format("{}x{}", size, size),
                       halves ? "yes" : "no", 1e3 * seconds, 1e9 * seconds / values);
            rows.push_back({{"width", size},
                            {"height", size},
                            {"halves", halves},
                            {"cpu_seconds_per_estimate", seconds},
                            {"cpu_ns_per_value", 1e9 * seconds / values}});
        }
    return rows;
}

} // namespace cb::bench
