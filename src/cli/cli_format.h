// Formatting shared by the commands' output.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace cb::cli {

// "12.3s", "4m05s", "2h07m".
std::string formatSeconds(double seconds);

// "0.0047 s/estimate" at the rate after the first estimate (`steadySeconds`, as the statistics'
// seconds_per_estimate), adding the first's time where it stands out: it includes PoCL's
// compilation of the kernel at the first launch, which can take longer than a whole small render.
std::string perEstimateSummary(double steadySeconds, double firstSeconds, long rendered);

// A number for JSON output: null when not available (no reference, fewer than 2 estimates).
nlohmann::json jsonNumber(double value);

} // namespace cb::cli
