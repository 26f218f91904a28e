// 4-wide BVH collapsed from the binary one (prototype for cbdpt-bench, kernels/cb_bvh_wide.h).
#pragma once

#include <vector>

#include "bvh/bvh.h"
#include "cb_bvh_wide.h"

namespace cb {

// Nodes of the 4-wide BVH over bvh.primitives (same order, the leaves are the binary
// leaves). Root at 0; the children of a node are allocated together, after it.
std::vector<cbk::BvhNode4> collapseBvh4(const Bvh& bvh);

} // namespace cb
