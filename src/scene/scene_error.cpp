#include "scene/scene_desc.h"

namespace cb {

std::string SourceLocation::str() const {
    return file + ":" + std::to_string(line) + ":" + std::to_string(column);
}

SceneError::SceneError(const SourceLocation& where, const std::string& message)
    : std::runtime_error(where.str() + ": " + message), where_(where) {}

} // namespace cb
