// The scene's device buffers and the kernel launch over pixel tiles, shared by every
// integrator's host side (the kernels take the scene as CB_SCENE_KERNEL_PARAMS, cb_types.h).
#pragma once

#include "cl/cl_runtime.h"
#include "scene/device_scene.h"

#include <string>
#include <vector>

namespace cb {

// A read-only device copy of `data` (ClRuntime::createReadOnlyCopy), checked against the
// device's memory (named `what` in the error); OpenCL forbids zero-sized buffers, so an empty
// array still gets one (unused) element.
template <typename T>
cl::Buffer uploadArray(ClRuntime& runtime, const std::string& what, const std::vector<T>& data) {
    static const T zero{};
    const void* src = data.empty() ? &zero : data.data();
    size_t bytes = data.empty() ? sizeof(T) : sizeof(T) * data.size();
    return runtime.createReadOnlyCopy(what, src, bytes);
}

struct SceneBuffers {
    SceneBuffers(ClRuntime& runtime, const DeviceScene& scene);

    // Sets the seven CB_SCENE_KERNEL_PARAMS arguments from index `first`; returns the next index.
    int setKernelArgs(cl::Kernel& kernel, int first) const;

    cl::Buffer nodes, packs, primitives, materials, lights, spectra;
    cl::Buffer toRgb; // 3 x channels matrix, passed separately by the kernels that need it
    int lightCount = 0;
};

// One work-item per pixel over the whole image, in square work-groups of tile x tile pixels.
void launchOverPixels(cl::CommandQueue& queue, cl::Kernel& kernel, const cbk::Camera& camera,
                      int tile);

} // namespace cb
