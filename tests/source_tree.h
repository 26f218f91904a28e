// Files of the source tree that tests read (scenes, kernels), by their path from its root.
#pragma once

#include <filesystem>
#include <string>

namespace cbtest {

// Joined as paths, not by std::string's operator+ on literals: GCC 12 at -O1 (the test files'
// level) reads that as a copy past the string's buffer, a known false -Warray-bounds.
template <class... Parts> std::string sourcePath(const Parts&... parts) {
    std::filesystem::path path(CBDPT_SOURCE_DIR);
    ((path /= parts), ...);
    return path.string();
}

} // namespace cbtest
