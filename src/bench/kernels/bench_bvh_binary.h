/* bench_bvh_binary.h - stackless traversals of the binary BVH (kernels/cb_bvh.h), for
 * cbdpt-bench and tests/test_bvh.cpp only: the renderers trace the wide BVH (cb_bvh_wide.h),
 * and no render kernel includes this header. They take the node and primitive arrays directly
 * rather than a SceneView.
 *
 * Any-hit queries and -DCB_BVH_SKIP_ORDER's closest hit run a single loop over one index: on
 * entering an interior node's box go to the next node; on missing a box or after a leaf jump to
 * its skip index. No per-ray stack, which keeps OpenCL work-items small.
 *
 * Closest-hit queries otherwise use the same layout in near-child-first order, still without a
 * stack: the parent-pointer state machine of Hapala, Davidovic, Wald, Havran and Slusallek 2011
 * ("Efficient stack-less BVH traversal for ray tracing", SCCG). The near child is chosen by the
 * sign of the ray direction along the split axis, so it can be recomputed when the traversal
 * comes back up and no per-ray state beyond (node, parent, state) is needed. Visiting the near
 * child first finds close hits early and culls the far subtrees. */
#ifndef CB_BENCH_BVH_BINARY_H
#define CB_BENCH_BVH_BINARY_H

#include "cb_bvh.h"
#include "cb_bvh_wide.h" /* bvhSlabCombine */
#include "cb_intersect.h"

CB_BEGIN_NAMESPACE

/* Slab test (Kay & Kajiya 1986) made conservative as in pbrt 3rd ed. sec. 3.9.2: the far
 * distance is enlarged by 1 + 2 gamma(3) to cover the rounding of both slab distances.
 * A zero direction component has inverse +inf (bvhInverseDirection turns -0 into +0). If the
 * origin lies on that slab's plane, 0 * inf = NaN: the selects below are ordered so that the
 * NaN ends up in the slab's near or far distance, never replacing the other one by an
 * infinity of the wrong sign, and the max/min selects (which keep the non-NaN operand) then
 * drop it, so the axis does not restrict the interval - a ray in a box face still enters the
 * box. */
CB_FN void bvhSlabInterval(Vec3 lo, Vec3 hi, Vec3 o, Vec3 invD, real tMax, real* tNearOut,
                           real* tFarOut) {
    real tx0 = (lo.x - o.x) * invD.x;
    real tx1 = (hi.x - o.x) * invD.x;
    real ty0 = (lo.y - o.y) * invD.y;
    real ty1 = (hi.y - o.y) * invD.y;
    real tz0 = (lo.z - o.z) * invD.z;
    real tz1 = (hi.z - o.z) * invD.z;
    real nx = tx0 > tx1 ? tx1 : tx0;
    real fx = tx0 > tx1 ? tx0 : tx1;
    real ny = ty0 > ty1 ? ty1 : ty0;
    real fy = ty0 > ty1 ? ty0 : ty1;
    real nz = tz0 > tz1 ? tz1 : tz0;
    real fz = tz0 > tz1 ? tz0 : tz1;
    bvhSlabCombine(nx, ny, nz, fx, fy, fz, tMax, tNearOut, tFarOut);
}

CB_FN bool bvhBoxHit(CB_GLOBAL const BvhNode* node, Vec3 o, Vec3 invD, real tMax) {
    real tNear, tFar;
    bvhSlabInterval(vec3FromGlobalArray(node->boundsMin), vec3FromGlobalArray(node->boundsMax), o,
                    invD, tMax, &tNear, &tFar);
    return tNear <= tFar * (1.0f + 2.0f * cbGamma(3));
}

CB_FN uint bvhEnd(CB_GLOBAL const BvhNode* nodes) {
    return (nodes[0].count & CB_BVH_LEAF) != 0u ? 1u : nodes[0].index;
}

/* d + 0 maps -0 to +0, so a zero component always has inverse +inf (see bvhBoxHit). */
CB_FN Vec3 bvhInverseDirection(Vec3 d) {
    return vec3(1.0f / (d.x + 0.0f), 1.0f / (d.y + 0.0f), 1.0f / (d.z + 0.0f));
}

/* Closest hit in preorder (skip indices). Kept as the reference and for benchmarks. */
CB_FN bool bvhIntersectSkip(CB_GLOBAL const BvhNode* nodes, CB_GLOBAL const Primitive* prims,
                            Ray ray, real tMax, Hit* hit) {
    hit->t = tMax;
    hit->primitive = -1;
    hit->b1 = 0.0f;
    hit->b2 = 0.0f;
    Vec3 invD = bvhInverseDirection(ray.d);
    uint end = bvhEnd(nodes);
    uint i = 0u;
    bool found = false;
    real closest = tMax;
    while (i < end) {
        CB_GLOBAL const BvhNode* node = nodes + i;
        if (!bvhBoxHit(node, ray.o, invD, closest)) {
            i = (node->count & CB_BVH_LEAF) != 0u ? i + 1u : node->index;
            continue;
        }
        if ((node->count & CB_BVH_LEAF) != 0u) {
            uint first = node->index;
            uint last = first + (node->count & ~CB_BVH_LEAF);
            for (uint k = first; k < last; ++k) {
                Hit h;
                if (intersectPrimitive(prims + k, ray, closest, &h)) {
                    h.primitive = (int)k;
                    *hit = h;
                    closest = h.t;
                    found = true;
                }
            }
        }
        ++i;
    }
    return found;
}

CB_FN bool bvhLeafIntersect(CB_GLOBAL const Primitive* prims, CB_GLOBAL const BvhNode* node,
                            Ray ray, real* closest, Hit* hit) {
    uint first = node->index;
    uint last = first + (node->count & ~CB_BVH_LEAF);
    bool found = false;
    for (uint k = first; k < last; ++k) {
        Hit h;
        if (intersectPrimitive(prims + k, ray, *closest, &h)) {
            h.primitive = (int)k;
            *hit = h;
            *closest = h.t;
            found = true;
        }
    }
    return found;
}

#define CB_BVH_FROM_PARENT 0
#define CB_BVH_FROM_SIBLING 1
#define CB_BVH_FROM_CHILD 2

/* Closest hit in near-child-first order (Hapala et al. 2011, fig. 2), stackless. `cur` is
 * the node at hand and `parent` its parent, carried in a register so that leaves need no
 * parent field. The three states are the paper's: coming down from the parent (on a miss or
 * after a leaf go to the far sibling), coming over from the near sibling (then go up), and
 * coming up from a finished child (go to the far sibling if this was the near child, else
 * further up). The children of p are p + 1 and the skip index of p + 1 (p + 2 after a leaf);
 * the sibling of a node is therefore found from the node itself and its parent. */
CB_FN bool bvhIntersectOrdered(CB_GLOBAL const BvhNode* nodes, CB_GLOBAL const Primitive* prims,
                               Ray ray, real tMax, Hit* hit) {
    hit->t = tMax;
    hit->primitive = -1;
    hit->b1 = 0.0f;
    hit->b2 = 0.0f;
    Vec3 invD = bvhInverseDirection(ray.d);
    /* Bit a set: the ray goes towards -a, so the second (high-side) child is the near one. */
    uint negative =
        (invD.x < 0.0f ? 1u : 0u) | (invD.y < 0.0f ? 2u : 0u) | (invD.z < 0.0f ? 4u : 0u);
    real closest = tMax;
    bool found = false;
    if (!bvhBoxHit(nodes, ray.o, invD, closest)) return false;
    if ((nodes[0].count & CB_BVH_LEAF) != 0u)
        return bvhLeafIntersect(prims, nodes, ray, &closest, hit);

    uint parent = 0u;
    uint rootCount = nodes[0].count;
    uint cur = ((negative >> (rootCount >> CB_BVH_AXIS_SHIFT)) & 1u) != 0u
                   ? ((nodes[1].count & CB_BVH_LEAF) != 0u ? 2u : nodes[1].index)
                   : 1u;
    int state = CB_BVH_FROM_PARENT;
    for (;;) {
        if (state == CB_BVH_FROM_CHILD) {
            if (cur == 0u) break;
            uint parentCount = nodes[parent].count;
            bool isFirst = cur == parent + 1u;
            bool nearIsFirst = ((negative >> (parentCount >> CB_BVH_AXIS_SHIFT)) & 1u) == 0u;
            if (isFirst == nearIsFirst) {
                /* cur was the near child: its sibling is next. */
                if (isFirst) {
                    uint c = nodes[cur].count;
                    cur = (c & CB_BVH_LEAF) != 0u ? cur + 1u : nodes[cur].index;
                } else {
                    cur = parent + 1u;
                }
                state = CB_BVH_FROM_SIBLING;
            } else {
                cur = parent;
                parent = parentCount & CB_BVH_PARENT_MASK;
            }
            continue;
        }
        CB_GLOBAL const BvhNode* node = nodes + cur;
        uint count = node->count;
        if (bvhBoxHit(node, ray.o, invD, closest)) {
            if ((count & CB_BVH_LEAF) == 0u) {
                parent = cur;
                bool secondNear = ((negative >> (count >> CB_BVH_AXIS_SHIFT)) & 1u) != 0u;
                if (secondNear) {
                    uint c1 = nodes[cur + 1u].count;
                    cur = (c1 & CB_BVH_LEAF) != 0u ? cur + 2u : nodes[cur + 1u].index;
                } else {
                    cur = cur + 1u;
                }
                state = CB_BVH_FROM_PARENT;
                continue;
            }
            if (bvhLeafIntersect(prims, node, ray, &closest, hit)) found = true;
        }
        if (state == CB_BVH_FROM_PARENT) {
            if (cur == parent + 1u)
                cur = (count & CB_BVH_LEAF) != 0u ? cur + 1u : node->index;
            else
                cur = parent + 1u;
            state = CB_BVH_FROM_SIBLING;
        } else {
            cur = parent;
            parent = nodes[parent].count & CB_BVH_PARENT_MASK;
            state = CB_BVH_FROM_CHILD;
        }
    }
    return found;
}

/* Closest hit with t in (0, tMax). On a miss *hit is left as {tMax, -1, 0, 0}, so it is
 * never read uninitialised. CB_BVH_SKIP_ORDER selects the unordered preorder loop (for
 * benchmarks). */
CB_FN bool bvhIntersect(CB_GLOBAL const BvhNode* nodes, CB_GLOBAL const Primitive* prims, Ray ray,
                        real tMax, Hit* hit) {
#ifdef CB_BVH_SKIP_ORDER
    return bvhIntersectSkip(nodes, prims, ray, tMax, hit);
#else
    return bvhIntersectOrdered(nodes, prims, ray, tMax, hit);
#endif
}

/* Any hit with t in (0, tMax): shadow rays stop at the first one. */
CB_FN bool bvhOccluded(CB_GLOBAL const BvhNode* nodes, CB_GLOBAL const Primitive* prims, Ray ray,
                       real tMax) {
    Vec3 invD = bvhInverseDirection(ray.d);
    uint end = bvhEnd(nodes);
    uint i = 0u;
    while (i < end) {
        CB_GLOBAL const BvhNode* node = nodes + i;
        if (!bvhBoxHit(node, ray.o, invD, tMax)) {
            i = (node->count & CB_BVH_LEAF) != 0u ? i + 1u : node->index;
            continue;
        }
        if ((node->count & CB_BVH_LEAF) != 0u) {
            uint first = node->index;
            uint last = first + (node->count & ~CB_BVH_LEAF);
            for (uint k = first; k < last; ++k) {
                Hit h;
                if (intersectPrimitive(prims + k, ray, tMax, &h)) return true;
            }
        }
        ++i;
    }
    return false;
}

CB_END_NAMESPACE

#endif /* CB_BENCH_BVH_BINARY_H */
