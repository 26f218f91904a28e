// Pieces shared by the commands that render (render_command.cpp, combine_command.cpp).
#pragma once

#include "scene/device_scene.h"

#include <atomic>
#include <string>

namespace cb::cli {

// auto | rgb | spectral; throws std::invalid_argument otherwise.
cb::ChannelMode parseChannels(const std::string& text);

// Ctrl-C and SIGTERM set stopRequested(), so a render ends after its current estimate and
// writes what it has; a second one ends the program at once.
void installStopHandler();
const std::atomic<bool>& stopRequested();

} // namespace cb::cli
