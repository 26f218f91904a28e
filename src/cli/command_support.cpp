#include "cli/command_support.h"

#include <csignal>
#include <stdexcept>

namespace cb::cli {

namespace {
std::atomic<bool> gStopRequested{false};

extern "C" void onStopSignal(int) {
    gStopRequested.store(true);
    // A second Ctrl-C ends the program at once.
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
}
} // namespace

cb::ChannelMode parseChannels(const std::string& s) {
    if (s == "auto") return cb::ChannelMode::Auto;
    if (s == "rgb") return cb::ChannelMode::Rgb;
    if (s == "spectral") return cb::ChannelMode::Spectral;
    throw std::invalid_argument("--channels must be auto, rgb or spectral");
}

void installStopHandler() {
    std::signal(SIGINT, onStopSignal);
    std::signal(SIGTERM, onStopSignal);
}

const std::atomic<bool>& stopRequested() {
    return gStopRequested;
}

} // namespace cb::cli
