/* cb_bvh.h - stackless BVH traversal shared by the kernels and the host.
 *
 * The host builder (src/bvh/bvh.cpp) stores the tree in depth-first preorder, so the first
 * child of an interior node is always the next node, and gives each node an escape ("skip")
 * index: the node that follows its whole subtree. Traversal is then a single loop over one
 * index (LuxCore's layout; Smits 1998, "Efficiency issues for ray tracing"): on entering an
 * interior node's box go to the next node; on missing a box or after a leaf jump to its skip
 * index. No per-ray stack, which keeps OpenCL work-items small. */
#ifndef CB_BVH_H
#define CB_BVH_H

#include "cb_intersect.h"

CB_BEGIN_NAMESPACE

/* Set in BvhNode::count for leaves; the low bits are the number of primitives. */
#define CB_BVH_LEAF 0x80000000u

/* 32 bytes. Interior: `index` is the skip index, the first child is the next node. Leaf:
 * `index` is the first primitive (primitives are stored in leaf order), the count is in the
 * low bits of `count`, and the skip index is implicitly the next node. The root is node 0;
 * traversal ends at the root's skip index (1 if the root is a leaf). An empty scene has one
 * empty leaf with an empty box. */
typedef struct BvhNode {
    float boundsMin[3];
    uint index;
    float boundsMax[3];
    uint count;
} BvhNode;

CB_STATIC_ASSERT(sizeof(BvhNode) == 32, "BvhNode must be 32 bytes");

/* Slab test (Kay & Kajiya 1986) made conservative as in pbrt 3rd ed. sec. 3.9.2: the far
 * distance is enlarged by 1 + 2 gamma(3) to cover the rounding of both slab distances.
 * A zero direction component has inverse +inf (bvhInverseDirection turns -0 into +0). If the
 * origin lies on that slab's plane, 0 * inf = NaN: the selects below are ordered so that the
 * NaN ends up in the slab's near or far distance, never replacing the other one by an
 * infinity of the wrong sign, and fmin/fmax (which return the non-NaN operand) then drop it,
 * so the axis does not restrict the interval - a ray in a box face still enters the box. */
CB_FN bool bvhBoxHit(CB_GLOBAL const BvhNode* node, Vec3 o, Vec3 invD, float tMax) {
    float tx0 = (node->boundsMin[0] - o.x) * invD.x;
    float tx1 = (node->boundsMax[0] - o.x) * invD.x;
    float ty0 = (node->boundsMin[1] - o.y) * invD.y;
    float ty1 = (node->boundsMax[1] - o.y) * invD.y;
    float tz0 = (node->boundsMin[2] - o.z) * invD.z;
    float tz1 = (node->boundsMax[2] - o.z) * invD.z;
    float nx = tx0 > tx1 ? tx1 : tx0;
    float fx = tx0 > tx1 ? tx0 : tx1;
    float ny = ty0 > ty1 ? ty1 : ty0;
    float fy = ty0 > ty1 ? ty0 : ty1;
    float nz = tz0 > tz1 ? tz1 : tz0;
    float fz = tz0 > tz1 ? tz0 : tz1;
    float tNear = fmax(fmax(nx, ny), fmax(nz, 0.0f));
    float tFar = fmin(fmin(fx, fy), fmin(fz, tMax));
    return tNear <= tFar * (1.0f + 2.0f * cbGamma(3));
}

CB_FN uint bvhEnd(CB_GLOBAL const BvhNode* nodes) {
    return (nodes[0].count & CB_BVH_LEAF) != 0u ? 1u : nodes[0].index;
}

/* d + 0 maps -0 to +0, so a zero component always has inverse +inf (see bvhBoxHit). */
CB_FN Vec3 bvhInverseDirection(Vec3 d) {
    return vec3(1.0f / (d.x + 0.0f), 1.0f / (d.y + 0.0f), 1.0f / (d.z + 0.0f));
}

/* Closest hit with t in (0, tMax). On a miss *hit is left as {tMax, -1, 0, 0}, so it is
 * never read uninitialised. */
CB_FN bool sceneIntersect(const SceneView* scene, Ray ray, float tMax, Hit* hit) {
    CB_GLOBAL const BvhNode* nodes = scene->nodes;
    hit->t = tMax;
    hit->primitive = -1;
    hit->b1 = 0.0f;
    hit->b2 = 0.0f;
    Vec3 invD = bvhInverseDirection(ray.d);
    uint end = bvhEnd(nodes);
    uint i = 0u;
    bool found = false;
    float closest = tMax;
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
                if (intersectPrimitive(scene->primitives + k, ray, closest, &h)) {
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

/* Any hit with t in (0, tMax): shadow rays stop at the first one. */
CB_FN bool sceneOccluded(const SceneView* scene, Ray ray, float tMax) {
    CB_GLOBAL const BvhNode* nodes = scene->nodes;
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
                if (intersectPrimitive(scene->primitives + k, ray, tMax, &h)) return true;
            }
        }
        ++i;
    }
    return false;
}

CB_END_NAMESPACE

#endif /* CB_BVH_H */
