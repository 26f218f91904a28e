// The scene's device buffers, shared by every integrator's host side (the kernels take the scene
// as CB_SCENE_KERNEL_PARAMS, cb_types.h), and the setting of kernel arguments in order.
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

// Sets a kernel's arguments one after the other, in the order its parameter list declares them.
class KernelArguments {
  public:
    explicit KernelArguments(cl::Kernel& kernel) : kernel_(&kernel) {}
    template <typename T> KernelArguments& add(const T& value) {
        kernel_->setArg(next_++, value);
        return *this;
    }
    // The index the next add() sets (to set that argument again before each launch).
    int next() const { return next_; }

  private:
    cl::Kernel* kernel_;
    int next_ = 0;
};

struct SceneBuffers {
    SceneBuffers(ClRuntime& runtime, const DeviceScene& scene);

    // Adds the eleven CB_SCENE_KERNEL_PARAMS arguments.
    void addKernelArguments(KernelArguments& args) const;

    cl::Buffer nodes, packs, primitives, materials, lights, spectra, lightTables, textures,
        shadingNormals, curves;
    cl::Buffer toRgb; // 3 x channels matrix, passed separately by the kernels that need it
    int lightCount = 0;
};

} // namespace cb
