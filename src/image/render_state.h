// The state of an interrupted render, saved next to its EXR so that `--resume` continues it:
// the settings that produced it and the accumulator's exact double sums, so a resumed render
// ends bit for bit where an uninterrupted one would.
#pragma once

#include "image/image.h"

#include <string>

namespace cb {

// "<exr path>.state"
std::string renderStatePath(const std::string& exrPath);

// `settings` identifies the render (integrator, caps, seed, size, scene...); resuming with
// different settings is refused.
void saveRenderState(const std::string& path, const std::string& settings,
                     const EstimateAccumulator& accumulator);

// Restores `accumulator` from `path`; throws std::runtime_error naming the file if it is
// missing, malformed, or was made with other settings or another image size.
void loadRenderState(const std::string& path, const std::string& settings,
                     EstimateAccumulator& accumulator);

} // namespace cb
