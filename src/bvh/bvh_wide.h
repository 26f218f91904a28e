// 4- or 8-wide BVH (CB_BVH_WIDE_LANES) collapsed from the binary one: what the renderers
// traverse (kernels/cb_bvh_wide.h; DeviceScene::wideNodes).
#pragma once

#include <vector>

#include "bvh/bvh.h"
#include "cb_bvh_wide.h"

namespace cb {

// Nodes of the wide BVH over bvh.primitives (same order, the leaves are the binary
// leaves). Root at 0; the children of a node are allocated together, after it.
std::vector<cbk::BvhNodeWide> collapseBvhWide(const Bvh& bvh);

} // namespace cb
