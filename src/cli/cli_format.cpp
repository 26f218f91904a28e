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

std::string perEstimateSummary(double steadySeconds, double firstSeconds, long rendered) {
    const std::string rate = fmt::format("{:.3g} s/estimate", steadySeconds);
    if (rendered < 2 || !(firstSeconds > 2.0 * steadySeconds + 0.1)) return rate;
    return fmt::format("{} after the first, which took {} with the kernel's compilation at its "
                       "launch",
                       rate, formatSeconds(firstSeconds));
}

nlohmann::json jsonNumber(double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

} // namespace cb::cli
