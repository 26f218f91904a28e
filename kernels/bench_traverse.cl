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

/* The 4-wide prototype (cb_bvh_wide.h) on the same rays. */
__kernel void benchClosest4(__global const struct BvhNode4* nodes,
                            __global const Primitive* primitives, __global const Ray* rays,
                            uint count, __global Hit* hits) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    Hit h;
    bvh4Traverse(nodes, primitives, rays[i], CB_INFINITY, true, &h);
    hits[i] = h;
}

__kernel void benchOccluded4(__global const struct BvhNode4* nodes,
                             __global const Primitive* primitives, __global const Ray* rays,
                             __global const float* tMax, uint count, __global int* occluded) {
    uint i = (uint)get_global_id(0);
    if (i >= count) return;
    Hit h;
    occluded[i] = bvh4Traverse(nodes, primitives, rays[i], tMax[i], false, &h) ? 1 : 0;
}
