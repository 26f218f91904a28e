// pbrt-v4's camera sensors ("string sensor" of its film): measured R, G, B sensitivities of
// the cameras it names, with the ColorChecker reflectances and CIE daylight components its
// sensor fit uses (camera_sensors_data.cpp, written by scripts/camera-sensors; docs/pbrt-v4.md,
// "Camera sensors").
#pragma once

#include <span>
#include <string>
#include <string_view>

namespace cb {

struct CameraSensorCurves {
    std::string_view name;         // pbrt-v4's sensor name, "canon_eos_100d"
    std::span<const double> table; // (nm, R, G, B) every 10 nm over 380-720 nm
};

// The built-in cameras, in the generated file's order.
std::span<const CameraSensorCurves> cameraSensors();

// The camera called `name`, or nullptr.
const CameraSensorCurves* findCameraSensor(std::string_view name);

// "cie1931" and the camera names, comma-separated, for error messages.
std::string cameraSensorNames();

// The 24 ColorChecker patches' reflectances, 36 values each (380-730 nm every 10 nm).
std::span<const double> colorCheckerReflectances();

// CIE daylight components as (nm, S0, S1, S2) rows every 10 nm over 300-830 nm.
std::span<const double> daylightComponents();

} // namespace cb
