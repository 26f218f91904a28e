// Kernel sources compiled into the binary (generated from kernels/ by scripts/embed_kernels.cmake).
#pragma once

#include <map>
#include <string>

namespace cb {
// File name (e.g. "pt.cl", "cb_common.h") -> source text, starting with a #line directive.
const std::map<std::string, std::string>& embeddedKernelSources();
} // namespace cb
