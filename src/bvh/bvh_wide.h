// 4- or 8-wide BVH (CB_BVH_WIDE_LANES) collapsed from the binary one: what the renderers
// traverse (kernels/cb_bvh_wide.h; DeviceScene::wide).
#pragma once

#include <cstddef>
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

    // What a traversal reads: the nodes and the packs (which hold the vertices).
    std::size_t bytes() const {
        return nodes.size() * sizeof(cbk::BvhNodeWide) + packs.size() * sizeof(cbk::TrianglePack);
    }
};

// Whether the traversals prefetch the nodes and packs they are about to enter
// (kernels/cb_bvh_wide.h, CB_TREE_PREFETCH): only on a CPU device (`cpuDevice`; __builtin_prefetch
// is for PoCL's CPU code, a GPU hides latency with other work-items) and only for a tree of
// `treeBytes` larger than its cache of `cacheBytes` (ClDeviceInfo::globalCacheBytes; 0, unknown:
// no). 32 MiB cache:
// a 61 MB tree's incoherent rays +7-12% against rtcIntersect1, its packets +2-4% against
// Embree's; 122 MB +11% and up to +27%; 2 MB trees, which fit, 1-7% slower
// (docs/performance.md, "What was tried").
bool treePrefetchPays(std::size_t treeBytes, unsigned long long cacheBytes, bool cpuDevice);

// The wide BVH over bvh.primitives; its leaves are the binary leaves.
BvhWide collapseBvhWide(const Bvh& bvh);

} // namespace cb
