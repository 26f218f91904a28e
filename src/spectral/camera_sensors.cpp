#include "spectral/camera_sensors.h"

namespace cb {

const CameraSensorCurves* findCameraSensor(std::string_view name) {
    for (const CameraSensorCurves& c : cameraSensors())
        if (c.name == name) return &c;
    return nullptr;
}

std::string cameraSensorNames() {
    std::string out = "cie1931";
    for (const CameraSensorCurves& c : cameraSensors())
        out += ", " + std::string(c.name);
    return out;
}

} // namespace cb
