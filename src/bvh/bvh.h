// Binned-SAH BVH built on the host in the node layout of kernels/cb_bvh.h (preorder with skip
// indices; interior nodes also record their parent and split axis). The renderers trace the wide
// BVH collapsed from it (bvh_wide.h); the bench and tests also trace it directly.
#pragma once

#include <vector>

#include "cb_bvh.h"

namespace cb {

struct BvhBuildOptions {
    int maxLeafSize = 4; // leaves never hold more; smaller leaves only where SAH prefers them
    int bins = 16;       // SAH bins per axis (Wald 2007)
    // The SAH prices primitive tests in blocks of this many primitives (2 or 4 for the wide
    // BVH, whose leaves test up to four triangles at once: bvh_choice.h).
    int primitivesPerTest = 1;
};

struct Bvh {
    std::vector<cbk::BvhNode> nodes;        // depth-first preorder, root at 0, never empty
    std::vector<cbk::Primitive> primitives; // reordered to leaf order
    std::vector<int> originalIndex;         // primitives[i] was input primitive originalIndex[i]
    int depth = 0;                          // levels, a lone root leaf counts as 1
};

// Binned SAH construction (Wald 2007, "On fast construction of SAH-based bounding volume
// hierarchies"). Primitives with coincident centroids are split at the median instead, so
// the build always terminates with leaves of at most maxLeafSize primitives. An empty input
// gives a single empty leaf that every ray misses.
Bvh buildBvh(std::vector<cbk::Primitive> primitives, const BvhBuildOptions& options = {});

// Conservative bounds of one primitive (spheres are rounded outwards).
void primitiveBounds(const cbk::Primitive& prim, float lo[3], float hi[3]);

} // namespace cb
