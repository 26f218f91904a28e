/* cb_bvh_wide.h - a 4-wide BVH and its stackless traversal (prototype, used by cbdpt-bench).
 *
 * One node holds the boxes of up to four children in structure-of-arrays form, so one node
 * visit tests four boxes with the same instructions on four lanes (what Embree's BVH4 does
 * with SSE). src/bvh/bvh_wide.cpp builds it by collapsing the binary BVH (Wald, Benthin,
 * Boulos 2008, "Getting rid of packets": repeatedly open the largest child).
 *
 * The traversal stays stackless and near-child-first: each node stores its parent, and the
 * order in which a node's children are visited is recomputed from the node whenever the
 * traversal returns to it. Children are ordered by the key (entry distance, lane), a strict
 * total order that depends only on the ray and the boxes; coming back up from child c, the
 * next child is the hit child with the smallest key above c's key. The set of hit children
 * only shrinks as the closest hit gets closer, so every child is visited at most once and in
 * the same order as with a stack. Leaf children are handled in place, without leaving the
 * node. */
#ifndef CB_BVH_WIDE_H
#define CB_BVH_WIDE_H

#include "cb_bvh.h"

CB_BEGIN_NAMESPACE

#define CB_BVH4_NONE 0xffffffffu

/* 128 bytes. lo/hi[axis][lane] are the children's boxes. child[lane]: the child node for an
 * interior child, the first primitive for a leaf, CB_BVH4_NONE for an empty lane (its box is
 * empty as well). counts: byte `lane` is the leaf's primitive count, 0 for an interior child
 * or an empty lane. parent: the parent node, CB_BVH4_NONE for the root (node 0); lane: this
 * node's lane in its parent, so that coming back up needs no search. */
typedef struct BvhNode4 {
    real lo[3][4];
    real hi[3][4];
    uint child[4];
    uint counts;
    uint parent;
    uint lane;
    uint pad;
} BvhNode4;

CB_STATIC_ASSERT(sizeof(BvhNode4) == 128, "BvhNode4 must be 128 bytes");

#ifdef CB_KERNEL_SIDE
/* The kernels test the four lanes with OpenCL vectors (one SSE/AVX instruction per step
 * under PoCL). The selects are bvhBoxHit's, lane by lane (see there for NaNs); the exit
 * distance starts from +inf so a NaN slab is dropped as there. */
typedef float4 Bvh4Real;

CB_FN void bvh4Boxes(CB_GLOBAL const BvhNode4* node, Vec3 o, Vec3 invD, float4* tn, float4* tf) {
    float4 tx0 = (vload4(0, node->lo[0]) - o.x) * invD.x;
    float4 tx1 = (vload4(0, node->hi[0]) - o.x) * invD.x;
    float4 ty0 = (vload4(0, node->lo[1]) - o.y) * invD.y;
    float4 ty1 = (vload4(0, node->hi[1]) - o.y) * invD.y;
    float4 tz0 = (vload4(0, node->lo[2]) - o.z) * invD.z;
    float4 tz1 = (vload4(0, node->hi[2]) - o.z) * invD.z;
    float4 nx = select(tx0, tx1, tx0 > tx1);
    float4 fx = select(tx1, tx0, tx0 > tx1);
    float4 ny = select(ty0, ty1, ty0 > ty1);
    float4 fy = select(ty1, ty0, ty0 > ty1);
    float4 nz = select(tz0, tz1, tz0 > tz1);
    float4 fz = select(tz1, tz0, tz0 > tz1);
    float4 n = select((float4)(0.0f), nx, nx > 0.0f);
    n = select(n, ny, ny > n);
    n = select(n, nz, nz > n);
    float4 f = select((float4)(INFINITY), fx, fx < INFINITY);
    f = select(f, fy, fy < f);
    f = select(f, fz, fz < f);
    *tn = n;
    *tf = f;
}

/* The hit lane with the smallest key (tn, lane) above (keyT, keyLane); -1 if none. `ordered`
 * false: the lowest hit lane above keyLane (any-hit queries). */
CB_FN int bvh4Next(CB_GLOBAL const BvhNode4* node, float4 tn, float4 tf, real closest, real keyT,
                   int keyLane, bool ordered) {
    float4 far = select((float4)(closest), tf, tf < closest);
    int4 lane = (int4)(0, 1, 2, 3);
    int4 hit = (vload4(0, node->child) != CB_BVH4_NONE) & (tn <= far * (1.0f + 2.0f * cbGamma(3)));
    int4 after = ordered ? ((tn > keyT) | ((tn == keyT) & (lane > keyLane))) : (lane > keyLane);
    int4 cand = hit & after;
    if (!any(cand)) return -1;
    if (ordered) {
        float4 t = select((float4)(INFINITY), tn, cand);
        float m = fmin(fmin(t.x, t.y), fmin(t.z, t.w));
        cand = cand & (t == m);
    }
    return cand.x ? 0 : (cand.y ? 1 : (cand.z ? 2 : 3));
}
#define BVH4_LANE(v, k) ((k) == 0 ? (v).x : ((k) == 1 ? (v).y : ((k) == 2 ? (v).z : (v).w)))
#else
/* The host: the same per-lane arithmetic as plain loops. */
typedef struct Bvh4Real {
    real v[4];
} Bvh4Real;

CB_FN void bvh4Boxes(CB_GLOBAL const BvhNode4* node, Vec3 o, Vec3 invD, Bvh4Real* tn,
                     Bvh4Real* tf) {
    for (int k = 0; k < 4; ++k) {
        real tx0 = (node->lo[0][k] - o.x) * invD.x;
        real tx1 = (node->hi[0][k] - o.x) * invD.x;
        real ty0 = (node->lo[1][k] - o.y) * invD.y;
        real ty1 = (node->hi[1][k] - o.y) * invD.y;
        real tz0 = (node->lo[2][k] - o.z) * invD.z;
        real tz1 = (node->hi[2][k] - o.z) * invD.z;
        real nx = tx0 > tx1 ? tx1 : tx0;
        real fx = tx0 > tx1 ? tx0 : tx1;
        real ny = ty0 > ty1 ? ty1 : ty0;
        real fy = ty0 > ty1 ? ty0 : ty1;
        real nz = tz0 > tz1 ? tz1 : tz0;
        real fz = tz0 > tz1 ? tz0 : tz1;
        real n = nx > 0.0f ? nx : 0.0f;
        n = ny > n ? ny : n;
        n = nz > n ? nz : n;
        real f = fx < CB_INFINITY ? fx : CB_INFINITY;
        f = fy < f ? fy : f;
        f = fz < f ? fz : f;
        tn->v[k] = n;
        tf->v[k] = f;
    }
}

CB_FN int bvh4Next(CB_GLOBAL const BvhNode4* node, Bvh4Real tn, Bvh4Real tf, real closest,
                   real keyT, int keyLane, bool ordered) {
    int best = -1;
    real bestT = 0.0f;
    for (int k = 0; k < 4; ++k) {
        real t = tn.v[k];
        real far = tf.v[k] < closest ? tf.v[k] : closest;
        bool hit = node->child[k] != CB_BVH4_NONE && t <= far * (1.0f + 2.0f * cbGamma(3));
        bool after = ordered ? (t > keyT || (t == keyT && k > keyLane)) : k > keyLane;
        if (hit && after && (best < 0 || (ordered && t < bestT))) {
            best = k;
            bestT = t;
        }
    }
    return best;
}
#define BVH4_LANE(x, k) ((x).v[k])
#endif

/* Closest hit (ordered) or any hit (!ordered, returns at the first) with t in (0, tMax). */
CB_FN bool bvh4Traverse(CB_GLOBAL const BvhNode4* nodes, CB_GLOBAL const Primitive* prims, Ray ray,
                        real tMax, bool ordered, Hit* hit) {
    hit->t = tMax;
    hit->primitive = -1;
    hit->b1 = 0.0f;
    hit->b2 = 0.0f;
    Vec3 invD = bvhInverseDirection(ray.d);
    TriangleRay tr = triangleRaySetup(ray);
    real closest = tMax;
    bool found = false;
    uint cur = 0u;
    int fromLane = -1; /* the lane just finished when coming back up, -1 coming down */
    for (;;) {
        CB_GLOBAL const BvhNode4* node = nodes + cur;
        Bvh4Real tn, tf;
        bvh4Boxes(node, ray.o, invD, &tn, &tf);
        int keyLane = fromLane;
        real keyT = fromLane >= 0 ? BVH4_LANE(tn, fromLane) : -1.0f;
        uint down = CB_BVH4_NONE;
        for (;;) {
            int k = bvh4Next(node, tn, tf, closest, keyT, keyLane, ordered);
            if (k < 0) break;
            uint count = (node->counts >> (8 * k)) & 0xffu;
            if (count == 0u) {
                down = node->child[k];
                break;
            }
            uint first = node->child[k];
            for (uint p = first; p < first + count; ++p) {
                Hit h;
                if (intersectPrimitivePrepared(prims + p, ray, &tr, closest, &h)) {
                    h.primitive = (int)p;
                    *hit = h;
                    closest = h.t;
                    found = true;
                    if (!ordered) return true;
                }
            }
            keyT = BVH4_LANE(tn, k);
            keyLane = k;
        }
        if (down != CB_BVH4_NONE) {
            fromLane = -1;
            cur = down;
            continue;
        }
        if (cur == 0u) break;
        fromLane = (int)node->lane;
        cur = node->parent;
    }
    return found;
}

CB_END_NAMESPACE

#endif /* CB_BVH_WIDE_H */
