// Kernel sources compiled into the binary (generated from kernels/ by scripts/embed_kernels.cmake).
#pragma once

#include <map>
#include <string>

namespace cb {
// File name (e.g. "pt.cl", "cb_common.h") -> source text, starting with a #line directive.
const std::map<std::string, std::string>& embeddedKernelSources();
// The sources kernels are built from: the embedded ones, each replaced by the file of the same
// name in the folder CBDPT_KERNEL_DIR when set (kernels edited without rebuilding, e.g. to find
// where a device faults). Defined in kernel_sources.cpp.
std::map<std::string, std::string> kernelSources();
} // namespace cb
