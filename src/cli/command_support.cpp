#include "cli/command_support.h"

#include <fmt/format.h>

#include <csignal>
#include <filesystem>
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

std::string previewPngPath(const std::string& output, const std::string& png) {
    namespace fs = std::filesystem;
    if (fs::path(output).extension() != ".exr")
        throw std::invalid_argument(fmt::format("output '{}' must end in .exr", output));
    if (png.empty()) return fs::path(output).replace_extension(".png").string();
    if (fs::path(png).extension() != ".png")
        throw std::invalid_argument(fmt::format("--png '{}' must end in .png", png));
    return png;
}

void requireDistinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs) {
    namespace fs = std::filesystem;
    for (size_t i = 0; i < outputs.size(); ++i)
        for (size_t j = 0; j < i; ++j) {
            const auto& [path, what] = outputs[i];
            const auto& [otherPath, otherWhat] = outputs[j];
            if (path.empty() || otherPath.empty()) continue;
            std::error_code ec;
            // Compared as absolute, normalised paths: ./a.exr and a.exr are one file.
            if (fs::absolute(path, ec).lexically_normal() ==
                fs::absolute(otherPath, ec).lexically_normal())
                throw std::invalid_argument(fmt::format(
                    "{} and {} are both {}: one would overwrite the other", otherWhat, what, path));
        }
}

void installStopHandler() {
    std::signal(SIGINT, onStopSignal);
    std::signal(SIGTERM, onStopSignal);
}

const std::atomic<bool>& stopRequested() {
    return gStopRequested;
}

} // namespace cb::cli
