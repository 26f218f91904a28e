/* bench_traverse.cl - traversal micro-benchmark kernels for cbdpt-bench (src/bench/).
 *
 * One work-item per ray, rays and results in flat buffers, nothing else: the measured time is
 * the BVH traversal and the primitive tests. benchClosest/benchOccluded run the binary BVH's
 * traversals of bench_bvh_binary.h (-DCB_BVH_SKIP_ORDER: its unordered preorder closest-hit
 * loop), kept for comparison; the *Wide kernels run cb_bvh_wide.h, the traversal the renderers
 * use; the *Packet kernels run the work-group-wide prototype of bench_bvh_packet.h (work-groups
 * of CB_PACKET_SIZE, an 8x8 tile of rays each); the *Rays kernels the packets of CB_RAY_PACKET
 * rays per work-item of cb_bvh_ray_packet.h (the bench builds this file once per width). */
#include "bench_bvh_binary.h"
#include "bench_bvh_packet.h"
#include "cb_bvh_ray_packet.h"
#include "cb_bvh_wide.h"

__kernel void benchClosest(__global const struct BvhNode* nodes,
                           __global const Primitive* primitives, __global const Ray* rays,
                           __global const float* tMax, uint count, __global Hit* hits) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    Hit h = {CB_INFINITY, -1, 0.0f, 0.0f};
    if (tMax[i] > 0.0f) bvhIntersect(nodes, primitives, rays[i], tMax[i], &h);
    hits[i] = h;
}

__kernel void benchOccluded(__global const struct BvhNode* nodes,
                            __global const Primitive* primitives, __global const Ray* rays,
                            __global const float* tMax, uint count, __global int* occluded) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    occluded[i] = bvhOccluded(nodes, primitives, rays[i], tMax[i]) ? 1 : 0;
}

/* The wide BVH (cb_bvh_wide.h, the renderers' traversal) on the same rays. Closest hits take a
 * tMax per ray: CB_INFINITY, or 0 for an inactive ray (a path that ended, reported as a
 * miss), so that sets of coherent bounce rays keep one ray per pixel. */
__kernel void benchClosestWide(__global const struct BvhNodeWide* nodes,
                               __global const TrianglePack* packs,
                               __global const Primitive* primitives, __global const Ray* rays,
                               __global const float* tMax, uint count, __global Hit* hits) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    Hit h = {CB_INFINITY, -1, 0.0f, 0.0f};
    if (tMax[i] > 0.0f)
        bvhWideTraverse(nodes, packs, primitives, rays[i], tMax[i], true, false, &h, 0);
    hits[i] = h;
}

/* Rays in pixel order, traced as the renderers trace camera rays
 * (sceneIntersectCoherent). A kernel of its own: with both traversals inlined into one kernel,
 * the coherent one ran 10% slower than alone. */
__kernel void benchClosestWideCoherent(__global const struct BvhNodeWide* nodes,
                                       __global const TrianglePack* packs,
                                       __global const Primitive* primitives,
                                       __global const Ray* rays, __global const float* tMax,
                                       uint count, __global Hit* hits) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    Hit h = {CB_INFINITY, -1, 0.0f, 0.0f};
    if (tMax[i] > 0.0f)
        bvhWideTraverse(nodes, packs, primitives, rays[i], tMax[i], true, true, &h, 0);
    hits[i] = h;
}

/* Any hit, traced as the renderers' sceneOccluded traces it (the coherent traversal). */
__kernel void benchOccludedWide(__global const struct BvhNodeWide* nodes,
                                __global const TrianglePack* packs,
                                __global const Primitive* primitives, __global const Ray* rays,
                                __global const float* tMax, uint count, __global int* occluded) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    Hit h;
    occluded[i] = tMax[i] > 0.0f && bvhWideTraverse(nodes, packs, primitives, rays[i], tMax[i],
                                                    false, true, &h, 0)
                      ? 1
                      : 0;
}

/* The packet traversal (bench_bvh_packet.h): every work-item reaches its barriers, so the rays
 * past `count` (padding) take part as inactive rays. Returns whether the work-item's ray hit. */
__attribute__((always_inline)) bool
benchPacketRay(__global const struct BvhNodeWide* nodes, __global const TrianglePack* packs,
               __global const Primitive* primitives, __global const Ray* rays,
               __global const float* tMax, uint count, bool closestHit,
               __local PacketShared* shared, Hit* h) {
    uint i = (uint)get_global_id(0);
    bool inside = i < count;
    float t = inside ? tMax[i] : 0.0f;
    return packetTraverse(nodes, packs, primitives, rays[inside ? i : 0u],
                          t > 0.0f ? t : CB_INFINITY, t > 0.0f, closestHit, shared, h);
}

__kernel __attribute__((reqd_work_group_size(CB_PACKET_SIZE, 1, 1))) void
benchClosestWidePacket(__global const struct BvhNodeWide* nodes, __global const TrianglePack* packs,
                       __global const Primitive* primitives, __global const Ray* rays,
                       __global const float* tMax, uint count, __global Hit* hits) {
    __local PacketShared shared;
    Hit h;
    benchPacketRay(nodes, packs, primitives, rays, tMax, count, true, &shared, &h);
    if (get_global_id(0) < count) hits[get_global_id(0)] = h;
}

__kernel __attribute__((reqd_work_group_size(CB_PACKET_SIZE, 1, 1))) void
benchOccludedWidePacket(__global const struct BvhNodeWide* nodes,
                        __global const TrianglePack* packs, __global const Primitive* primitives,
                        __global const Ray* rays, __global const float* tMax, uint count,
                        __global int* occluded) {
    __local PacketShared shared;
    Hit h;
    bool hit = benchPacketRay(nodes, packs, primitives, rays, tMax, count, false, &shared, &h);
    if (get_global_id(0) < count) occluded[get_global_id(0)] = hit ? 1 : 0;
}

/* Packets of CB_RAY_PACKET rays, one per work-item (cb_bvh_ray_packet.h): packets[np .. np+n-1]
 * are the rays of packet p (a 2x4 or 4x4 tile of pixels, as the bench gives Embree's
 * rtcIntersect8 and rtcIntersect16; -1 pads the last packet). Closest hits into hits, or any hits
 * into occluded (1 or 0). */
CB_FN __attribute__((always_inline)) void
benchRays(__global const struct BvhNodeWide* nodes, __global const TrianglePack* packs,
          __global const Primitive* primitives, __global const Ray* rays,
          __global const float* tMax, __global const int* packets, uint packetCount,
          bool closestHit, __global Hit* hits, __global int* occluded) {
    uint p = (uint)get_global_id(0);
    if (p >= packetCount) return;
    rayPacketTrace(nodes, packs, primitives, rays, tMax, CB_RAY_PACKET_LOAD(p, packets), closestHit,
                   hits, occluded, 0);
}

__kernel void benchClosestWideRays(__global const struct BvhNodeWide* nodes,
                                   __global const TrianglePack* packs,
                                   __global const Primitive* primitives, __global const Ray* rays,
                                   __global const float* tMax, __global const int* packets,
                                   uint packetCount, __global Hit* hits) {
    benchRays(nodes, packs, primitives, rays, tMax, packets, packetCount, true, hits, 0);
}

__kernel void benchOccludedWideRays(__global const struct BvhNodeWide* nodes,
                                    __global const TrianglePack* packs,
                                    __global const Primitive* primitives, __global const Ray* rays,
                                    __global const float* tMax, __global const int* packets,
                                    uint packetCount, __global int* occluded) {
    benchRays(nodes, packs, primitives, rays, tMax, packets, packetCount, false, 0, occluded);
}
