/* cb_bvh.h - the binary BVH's node layout.
 *
 * The host builder (src/bvh/bvh.cpp) builds this tree, and src/bvh/bvh_wide.cpp collapses it
 * into the wide BVH of cb_bvh_wide.h, which is what the renderers trace; no render kernel
 * includes this header. cbdpt-bench and tests/test_bvh.cpp trace the binary tree itself, for
 * comparison, with the traversals of src/bench/kernels/bench_bvh_binary.h.
 *
 * The tree is stored in depth-first preorder, so the first child of an interior node is always
 * the next node, and each node has an escape ("skip") index: the node that follows its whole
 * subtree (LuxCore's layout; Smits 1998, "Efficiency issues for ray tracing"). Interior nodes
 * also keep their parent and split axis in the otherwise unused `count`, for the stackless
 * near-child-first traversal of Hapala et al. 2011. */
#ifndef CB_BVH_H
#define CB_BVH_H

#include "cb_types.h"

CB_BEGIN_NAMESPACE

/* Set in BvhNode::count for leaves; the low bits are the number of primitives. */
#define CB_BVH_LEAF 0x80000000u
#define CB_BVH_PARENT_MASK 0x1fffffffu
#define CB_BVH_NO_PARENT CB_BVH_PARENT_MASK
#define CB_BVH_AXIS_SHIFT 29u

/* 32 bytes. Interior: `index` is the skip index, the first child is the next node. Leaf:
 * `index` is the first primitive (primitives are stored in leaf order), the count is in the
 * low bits of `count`, and the skip index is implicitly the next node. The root is node 0;
 * traversal ends at the root's skip index (1 if the root is a leaf). An empty scene has one
 * empty leaf with an empty box. Interior `count`: leaf bit clear, split axis in bits 29-30
 * (the first child holds the primitives on the low side of that axis), parent index in bits
 * 0-28 (CB_BVH_NO_PARENT for the root). */
typedef struct BvhNode {
    real boundsMin[3];
    uint index;
    real boundsMax[3];
    uint count;
} BvhNode;

CB_STATIC_ASSERT(sizeof(BvhNode) == 32, "BvhNode must be 32 bytes");

CB_END_NAMESPACE

#endif /* CB_BVH_H */
