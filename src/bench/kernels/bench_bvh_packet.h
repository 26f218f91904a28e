/* bench_bvh_packet.h - a work-group-wide (packet) traversal of the wide BVH (cb_bvh_wide.h),
 * a prototype for cbdpt-bench (`--traversal packet`), not used by the renderers.
 *
 * The CB_PACKET_SIZE work-items of a work-group (an 8x8 tile of pixels in the bench's ray
 * order) walk one node sequence together, still without a stack: a child is entered when any
 * active ray of the group hits its box within its own closest hit. Box and pack tests stay per
 * work-item (one ray each); the group's decision is the OR of the rays' hit-lane bits, formed
 * with a local atomic and read after one barrier per node visit. The children's visiting order
 * must be the same for the whole group and on every return to a node (the stackless
 * next-sibling rule of cb_bvh_wide.h), so it is the order of one representative ray, the mean
 * of the group's active rays, by the same integer keys (entry distance, lane) as cb_bvh_wide.h:
 * a strict total order that depends only on the node and the group. The set of children any
 * ray still hits only shrinks as the closest hits get closer, so the trail stays exact and
 * every child is visited at most once. Every work-item runs every iteration (PoCL needs
 * barriers in uniform control flow): rays that are done only skip their tests. */
#ifndef BENCH_BVH_PACKET_H
#define BENCH_BVH_PACKET_H

#include "cb_bvh_group.h"

/* The work-group size the packet kernels require: one 8x8 tile. */
#define CB_PACKET_SIZE 64

/* Local memory of one group: the representative ray's sums and the OR slots. */
typedef struct PacketShared {
    float rays[7][CB_PACKET_SIZE]; /* origin, direction, 1 for each active work-item */
    float mean[7];                 /* their sums (work-item 0) */
    uint bits[3];                  /* the OR of the hit-lane bits, one slot per visit mod 3 */
} PacketShared;

/* Whether any active ray of the group is still traversing, as a bit above the lanes'. */
#define CB_PACKET_ACTIVE (1u << CB_BVH_WIDE_LANES)

/* The packs of one leaf child, first to first + count - 1: whether one was hit below *closest
 * (then *closest and *hit are updated; an any-hit query returns at the first). Out of line:
 * PoCL turns every PHI node of a kernel with barriers into a per-work-item context array,
 * these loops' as well (164 more arrays when inlined). */
CB_FN __attribute__((noinline)) bool packetLeaf(CB_GLOBAL const TrianglePack* packs,
                                                CB_GLOBAL const Primitive* prims, Ray ray,
                                                TriangleRay sheared, uint first, uint count,
                                                bool closestHit, real* closest, Hit* hit) {
    bool found = false;
    for (uint p = first; p < first + count; ++p) {
        Hit h;
        if (intersectPack(packs + p, prims, ray, sheared, *closest, closestHit, &h, 0)) {
            *hit = h;
            *closest = h.t;
            found = true;
            if (!closestHit) break;
        }
    }
    return found;
}

/* Closest hit (closestHit) or any hit with t in (0, tMax) for the work-item's ray, traced with
 * its group. `active` false: a ray with nothing to trace (an ended path, padding); it still
 * takes part in every barrier. Returns whether the ray hit; *hit as bvhWideTraverse's. */
CB_FN __attribute__((always_inline)) bool packetTraverse(CB_GLOBAL const BvhNodeWide* nodes,
                                                         CB_GLOBAL const TrianglePack* packs,
                                                         CB_GLOBAL const Primitive* prims, Ray ray,
                                                         real tMax, bool active, bool closestHit,
                                                         __local PacketShared* shared, Hit* hit) {
    const uint lid = (uint)get_local_id(0);
    hit->t = tMax;
    hit->primitive = -1;
    hit->b1 = 0.0f;
    hit->b2 = 0.0f;
    /* The representative ray: the mean origin and direction of the active rays, summed by one
     * work-item (a loop of 64 adds per group rather than per work-item). */
    shared->rays[0][lid] = active ? ray.o.x : 0.0f;
    shared->rays[1][lid] = active ? ray.o.y : 0.0f;
    shared->rays[2][lid] = active ? ray.o.z : 0.0f;
    shared->rays[3][lid] = active ? ray.d.x : 0.0f;
    shared->rays[4][lid] = active ? ray.d.y : 0.0f;
    shared->rays[5][lid] = active ? ray.d.z : 0.0f;
    shared->rays[6][lid] = active ? 1.0f : 0.0f;
    barrier(CLK_LOCAL_MEM_FENCE);
    if (lid == 0u) {
        for (int c = 0; c < 7; ++c) {
            float s = 0.0f;
            for (int i = 0; i < CB_PACKET_SIZE; ++i)
                s += shared->rays[c][i];
            shared->mean[c] = s;
        }
        shared->bits[0] = 0u;
        shared->bits[1] = 0u;
        shared->bits[2] = 0u;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    const float activeCount = shared->mean[6];
    if (activeCount == 0.0f) return false; /* the same for the whole group */
    const float inv = 1.0f / activeCount;
    const BvhWideSlabs rep =
        bvhWideSlabsOf(vec3(shared->mean[0] * inv, shared->mean[1] * inv, shared->mean[2] * inv),
                       vec3(shared->mean[3] * inv, shared->mean[4] * inv, shared->mean[5] * inv));

    const BvhWideSlabs slabs = bvhWideSlabsOf(ray.o, ray.d);
    const TriangleRay sheared = triangleRayOf(ray);
    real closest = tMax;
    bool found = false;
    uint cur = 0u;
    int fromLane = -1; /* as in bvhWideTraverse: the lane just finished, -1 coming down */
    ulong trail = 0;   /* bvhWideTraverse's trail, for the group's node sequence */
    int depth = 0;
    uint slot = 0u;
    bool over = false;
    while (!over) {
        CB_GLOBAL const BvhNodeWide* node = nodes + cur;
        uint bits = 0u;
        if (active) {
            BvhWideReal tn, far;
            bvhWideBoxes(node, slabs.invNear, slabs.addNear, slabs.invFar, slabs.addFar, closest,
                         &tn, &far);
            bits = bvhWideBits((CB_BVHW_LOAD(node->child) != CB_BVHW_NONE) & (tn <= far)) |
                   CB_PACKET_ACTIVE;
            atomic_or(&shared->bits[slot], bits);
        }
        barrier(CLK_LOCAL_MEM_FENCE);
        const uint group = shared->bits[slot];
        /* The slot of the visit after next: everybody read it before this barrier, and it is
         * next written after the next one. */
        if (lid == 0u) shared->bits[slot == 0u ? 2u : slot - 1u] = 0u;
        slot = slot == 2u ? 0u : slot + 1u;
        if (group == 0u) break; /* every ray done (any hit) */

        /* The next child in the representative ray's order. */
        bool more;
        const int k = bvhGroupNext(node, rep, group & ~CB_PACKET_ACTIVE, fromLane, &more);
        if (k >= 0) {
            const uint count = bvhWideCount(node, k);
            if (count == 0u) {
                bvhGroupDescend(node, k, more, &cur, &fromLane, &depth, &trail);
                continue;
            }
            /* Only the rays whose own box test kept the leaf test its packs. */
            if (((bits >> k) & 1u) != 0u && packetLeaf(packs, prims, ray, sheared, node->child[k],
                                                       count, closestHit, &closest, hit)) {
                found = true;
                if (!closestHit) active = false;
            }
            if (more) {
                fromLane = k;
                continue;
            }
        }
        over = !bvhGroupClimb(nodes, trail, &cur, &fromLane, &depth);
    }
    return found;
}

#endif /* BENCH_BVH_PACKET_H */
