#include "cli/cli_format.h"

#include <fmt/format.h>

#include <cmath>

namespace cb::cli {

std::string formatSeconds(double s) {
    if (!(s < 1e8)) return "unknown"; // no limit to estimate it from
    if (s < 60.0) return fmt::format("{:.1f}s", s);
    if (s < 3600.0) return fmt::format("{}m{:02d}s", int(s) / 60, int(s) % 60);
    return fmt::format("{}h{:02d}m", int(s) / 3600, (int(s) / 60) % 60);
}

nlohmann::json jsonNumber(double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

} // namespace cb::cli
