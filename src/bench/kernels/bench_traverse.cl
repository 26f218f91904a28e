/* bench_traverse.cl - traversal micro-benchmark kernels for cbdpt-bench (src/bench/).
 *
 * One work-item per ray, rays and results in flat buffers, nothing else: the measured time is
 * the BVH traversal and the primitive tests. benchClosest/benchOccluded run the binary BVH's
 * traversals of bench_bvh_binary.h (-DCB_BVH_SKIP_ORDER: its unordered preorder closest-hit
 * loop), kept for comparison; the *Wide kernels run cb_bvh_wide.h, the traversal the renderers
 * use; the *Packet kernels run the work-group-wide prototype of bench_bvh_packet.h (work-groups
 * of CB_PACKET_SIZE, an 8x8 tile of rays each); the *Ray8 kernels the packets of eight rays per
 * work-item of bench_bvh_ray8.h. */
#include "bench_bvh_binary.h"
#include "bench_bvh_packet.h"
#include "bench_bvh_ray8.h"
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
        bvhWideTraverse(nodes, packs, primitives, rays[i], tMax[i], true, false, &h);
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
    if (tMax[i] > 0.0f) bvhWideTraverse(nodes, packs, primitives, rays[i], tMax[i], true, true, &h);
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
                                                    false, true, &h)
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

/* One ray's hit, unless the ray is padding (index < 0). */
CB_FN void benchStoreHit(__global Hit* hits, int index, float t, int prim, float b1, float b2) {
    Hit h = {t, prim, b1, b2};
    if (index >= 0) hits[index] = h;
}

/* Packets of eight rays, one per work-item (bench_bvh_ray8.h): packets[8p .. 8p+7] are the
 * rays of packet p (a 2x4 tile of pixels, as the bench gives Embree's rtcIntersect8; -1 pads
 * the last packet). */
__kernel void benchClosestWideRay8(__global const struct BvhNodeWide* nodes,
                                   __global const TrianglePack* packs,
                                   __global const Primitive* primitives, __global const Ray* rays,
                                   __global const float* tMax, __global const int* packets,
                                   uint packetCount, __global Hit* hits) {
    uint p = (uint)get_global_id(0);
    if (p >= packetCount) return;
    const int8 index = vload8(p, packets);
    float8 t, b1, b2;
    int8 prim;
    ray8Traverse(nodes, packs, primitives, rays, tMax, index, true, &t, &prim, &b1, &b2);
    benchStoreHit(hits, index.s0, t.s0, prim.s0, b1.s0, b2.s0);
    benchStoreHit(hits, index.s1, t.s1, prim.s1, b1.s1, b2.s1);
    benchStoreHit(hits, index.s2, t.s2, prim.s2, b1.s2, b2.s2);
    benchStoreHit(hits, index.s3, t.s3, prim.s3, b1.s3, b2.s3);
    benchStoreHit(hits, index.s4, t.s4, prim.s4, b1.s4, b2.s4);
    benchStoreHit(hits, index.s5, t.s5, prim.s5, b1.s5, b2.s5);
    benchStoreHit(hits, index.s6, t.s6, prim.s6, b1.s6, b2.s6);
    benchStoreHit(hits, index.s7, t.s7, prim.s7, b1.s7, b2.s7);
}

__kernel void benchOccludedWideRay8(__global const struct BvhNodeWide* nodes,
                                    __global const TrianglePack* packs,
                                    __global const Primitive* primitives, __global const Ray* rays,
                                    __global const float* tMax, __global const int* packets,
                                    uint packetCount, __global int* occluded) {
    uint p = (uint)get_global_id(0);
    if (p >= packetCount) return;
    const int8 index = vload8(p, packets);
    float8 t, b1, b2;
    int8 prim;
    const int8 hit =
        ray8Traverse(nodes, packs, primitives, rays, tMax, index, false, &t, &prim, &b1, &b2);
    const int8 out = select((int8)(0), (int8)(1), hit);
    if (index.s0 >= 0) occluded[index.s0] = out.s0;
    if (index.s1 >= 0) occluded[index.s1] = out.s1;
    if (index.s2 >= 0) occluded[index.s2] = out.s2;
    if (index.s3 >= 0) occluded[index.s3] = out.s3;
    if (index.s4 >= 0) occluded[index.s4] = out.s4;
    if (index.s5 >= 0) occluded[index.s5] = out.s5;
    if (index.s6 >= 0) occluded[index.s6] = out.s6;
    if (index.s7 >= 0) occluded[index.s7] = out.s7;
}
