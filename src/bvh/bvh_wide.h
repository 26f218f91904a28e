// 4- or 8-wide BVH (CB_BVH_WIDE_LANES) collapsed from the binary one: what the renderers
// traverse (kernels/cb_bvh_wide.h; DeviceScene::wide).
#pragma once

#include <vector>

#include "bvh/bvh.h"
#include "cb_bvh_wide.h"

namespace cb {

struct BvhWide {
    // Root at 0; the children of a node are allocated together, after it.
    std::vector<cbk::BvhNodeWide> nodes;
    // The leaves' primitives, four to a pack, leaf by leaf: a leaf of n primitives has
    // ceil(n / 4) consecutive packs. The packs name primitives by their index in bvh.primitives.
    std::vector<cbk::TrianglePack> packs;
};

// The wide BVH over bvh.primitives; its leaves are the binary leaves.
BvhWide collapseBvhWide(const Bvh& bvh);

} // namespace cb
