// Formatting shared by the commands' output.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace cb::cli {

// "12.3s", "4m05s", "2h07m".
std::string formatSeconds(double seconds);

// A number for JSON output: null when not available (no reference, fewer than 2 estimates).
nlohmann::json jsonNumber(double value);

} // namespace cb::cli
