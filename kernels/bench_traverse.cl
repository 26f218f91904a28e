/* bench_traverse.cl - traversal micro-benchmark kernels for cbdpt-bench (src/bench/).
 *
 * One work-item per ray, rays and results in flat buffers, nothing else: the measured time is
 * the BVH traversal and the primitive tests of cb_bvh.h as the renderers compile them.
 * -DCB_BVH_SKIP_ORDER selects the unordered preorder closest-hit loop for comparison. */
#include "cb_bvh_wide.h"

__kernel void benchClosest(__global const struct BvhNode* nodes,
                           __global const Primitive* primitives, __global const Ray* rays,
                           uint count, __global Hit* hits) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    SceneView scene;
    scene.nodes = nodes;
    scene.primitives = primitives;
    scene.materials = 0;
    scene.lights = 0;
    scene.spectra = 0;
    scene.lightCount = 0;
    Hit h;
    sceneIntersect(&scene, rays[i], CB_INFINITY, &h);
    hits[i] = h;
}

__kernel void benchOccluded(__global const struct BvhNode* nodes,
                            __global const Primitive* primitives, __global const Ray* rays,
                            __global const float* tMax, uint count, __global int* occluded) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    SceneView scene;
    scene.nodes = nodes;
    scene.primitives = primitives;
    scene.materials = 0;
    scene.lights = 0;
    scene.spectra = 0;
    scene.lightCount = 0;
    occluded[i] = sceneOccluded(&scene, rays[i], tMax[i]) ? 1 : 0;
}

/* The wide-BVH prototype (cb_bvh_wide.h) on the same rays. */
__kernel void benchClosestWide(__global const struct BvhNodeWide* nodes,
                               __global const Primitive* primitives, __global const Ray* rays,
                               uint count, __global Hit* hits) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    Hit h;
    bvhWideTraverse(nodes, primitives, rays[i], CB_INFINITY, true, &h);
    hits[i] = h;
}

__kernel void benchOccludedWide(__global const struct BvhNodeWide* nodes,
                                __global const Primitive* primitives, __global const Ray* rays,
                                __global const float* tMax, uint count, __global int* occluded) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    Hit h;
    occluded[i] = bvhWideTraverse(nodes, primitives, rays[i], tMax[i], false, &h) ? 1 : 0;
}
