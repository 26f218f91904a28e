// 4- or 8-wide BVH (CB_BVH_WIDE_LANES) collapsed from the binary one: what the renderers
// traverse (kernels/cb_bvh_wide.h; DeviceScene::wide).
#pragma once

#include <vector>

#include "bvh/bvh.h"
#include "cb_bvh_wide.h"

namespace cb {

struct BvhWide {
    // Root at 0. A node's interior children take its first lanes and are allocated together,
    // after it, in lane order: the interior child at lane k is node child[0] + k.
    std::vector<cbk::BvhNodeWide> nodes;
    // The leaves' primitives, leaf by leaf in consecutive packs: its triangles four to a pack,
    // then its other primitives (spheres) four to a pack. Packs name primitives by their index
    // in bvh.primitives.
    std::vector<cbk::TrianglePack> packs;
};

// The wide BVH over bvh.primitives; its leaves are the binary leaves.
BvhWide collapseBvhWide(const Bvh& bvh);

} // namespace cb
