// Option checks and options shared by the commands.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

namespace cb::cli {

// A finite number in [low, high], or in (low, high] when `lowOpen`: CLI::Range lets NaN through.
CLI::Validator finiteRange(double low, double high, bool lowOpen = false);

// The OpenCL device and, for PoCL's CPU device, its thread count (render and info).
struct DeviceOptions {
    std::string device;
    int threads = 0; // 0: PoCL's default (one per core)
};
void addDeviceOptions(CLI::App& cmd, DeviceOptions& options);
// Applies --nthreads: before any OpenCL call, since PoCL reads it when it is loaded.
void applyThreadLimit(const DeviceOptions& options);

} // namespace cb::cli
