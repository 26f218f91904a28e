/* cb_bvh_group.h - what the two packet traversals share (cb_bvh_ray_packet.h: 8 or 16 rays
 * per work-item, CPT's and CBDPT's packets; src/bench/kernels/bench_bvh_packet.h: a work-group of
 * rays, a bench prototype): one stackless walk of the wide BVH (cb_bvh_wide.h) for a group of rays.
 * The group enters a node's child when any of its rays enters the child's box; the children are
 * visited in the order of one representative ray's keys, which depend only on the node and that
 * ray, so returning to a node finds the same order and the trail of cb_bvh_wide.h stays exact. */
#ifndef CB_BVH_GROUP_H
#define CB_BVH_GROUP_H

#include "cb_bvh_wide.h"

/* The next child to visit: of the children whose bits are set in `group`, the one after lane
 * fromLane (-1 coming down) in the representative ray's order (its slabs `rep`); coming down to
 * a node with a single such child, that child, without the representative's box tests. Returns
 * the lane, or -1 when none is left; *more: whether another candidate remains after it. */
CB_FN __attribute__((always_inline)) int bvhGroupNext(CB_GLOBAL const BvhNodeWide* node,
                                                      BvhWideSlabs rep, uint group, int fromLane,
                                                      bool* more) {
    uint candBits = group;
    int k = 31 - (int)clz(group);
    if (group != 0u && (fromLane >= 0 || (group & (group - 1u)) != 0u)) {
        BvhWideReal repTn, repFar;
        bvhWideBoxes(node, rep.invNear, rep.addNear, rep.invFar, rep.addFar, CB_INFINITY, &repTn,
                     &repFar);
        const BvhWideInt keys = bvhWideKeys(repTn);
        const BvhWideKey after = fromLane >= 0 ? bvhWideKeyOf(keys, fromLane) : bvhWideKeyNone();
        const BvhWideInt cand =
            (((BvhWideInt)((int)group) & ((BvhWideInt)(1) << CB_BVHW_LANE_INDICES)) != 0) &
            (keys > after);
        candBits = bvhWideBits(cand);
        k = bvhWideMinAll(select((BvhWideInt)(INT_MAX), keys, cand)) & (CB_BVH_WIDE_LANES - 1);
    }
    *more = (candBits & (candBits - 1u)) != 0u;
    return candBits != 0u ? k : -1;
}

/* Down into the interior child at lane k of node *cur, the trail's bit of this depth recording
 * whether the node has candidates left (bvhWideTraverse's trail). */
CB_FN __attribute__((always_inline)) void bvhGroupDescend(CB_GLOBAL const BvhNodeWide* node, int k,
                                                          bool more, uint* cur, int* fromLane,
                                                          int* depth, ulong* trail) {
    if (*depth < 64) {
        ulong bit = (ulong)1 << *depth;
        *trail = more ? (*trail | bit) : (*trail & ~bit);
    }
    *fromLane = -1;
    *cur = bvhWideInteriorChild(node, k);
    ++*depth;
}

/* Up to the nearest ancestor that may have children left (bvhWideTraverse's climb), *fromLane
 * the lane come back from. Returns false when none is left: the traversal is over. */
CB_FN __attribute__((always_inline)) bool bvhGroupClimb(CB_GLOBAL const BvhNodeWide* nodes,
                                                        ulong trail, uint* cur, int* fromLane,
                                                        int* depth) {
    if (*depth <= 64) {
        ulong below = *depth == 64 ? trail : (trail & (((ulong)1 << *depth) - (ulong)1));
        if (below == 0) return false;
    }
    for (;;) {
        if (*cur == 0u) return false;
        *fromLane = (int)nodes[*cur].lane;
        *cur = nodes[*cur].parent;
        --*depth;
        if (*depth >= 64 || ((trail >> *depth) & 1u) != 0u) return true;
    }
}

#endif /* CB_BVH_GROUP_H */
