// Pieces shared by the commands (render, combine, merge).
#pragma once

#include "scene/device_scene.h"

#include <atomic>
#include <string>
#include <utility>
#include <vector>

namespace cb::cli {

// auto | rgb | spectral; throws std::invalid_argument otherwise.
cb::ChannelMode parseChannels(const std::string& text);

// The PNG preview's path for the image `output`: `png` as given, else the output with .png.
// Throws std::invalid_argument unless `output` ends in .exr and the PNG's path in .png.
std::string previewPngPath(const std::string& output, const std::string& png);

// A command's output files, each (path, what it is; an empty path is not written). Throws
// std::invalid_argument naming both when two are one file: one write would replace the other.
void requireDistinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs);

// Ctrl-C and SIGTERM set stopRequested(), so a render ends after its current estimate and
// writes what it has; a second one ends the program at once.
void installStopHandler();
const std::atomic<bool>& stopRequested();

} // namespace cb::cli
