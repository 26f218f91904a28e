#include "cli/cli_options.h"

#include "cl/cl_runtime.h"

#include <fmt/format.h>

#include <cmath>

namespace cb::cli {

CLI::Validator finiteRange(double low, double high, bool lowOpen) {
    const std::string range = fmt::format("{}{:g}, {:g}]", lowOpen ? "(" : "[", low, high);
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            double value = 0.0;
            if (!CLI::detail::lexical_cast(text, value) || !std::isfinite(value) || value > high ||
                value < low || (lowOpen && value == low))
                return fmt::format("Value {} not in {}", text, range);
            return {};
        },
        fmt::format("in {}", range));
}

void addDeviceOptions(CLI::App& cmd, DeviceOptions& o) {
    cmd.add_option("--device", o.device,
                   "OpenCL device: cpu, gpu or P:D as `cbdpt info` lists them (default: "
                   "CBDPT_DEVICE, else PoCL's CPU device)")
        ->group("Device");
    cmd.add_option("--nthreads", o.threads, "threads of PoCL's CPU device (default: one per core)")
        ->check(CLI::Range(1, 4096))
        ->group("Device");
}

void applyThreadLimit(const DeviceOptions& o) {
    if (o.threads > 0) limitPoclThreads(o.threads);
}

} // namespace cb::cli
