#include "integrators/scene_buffers.h"

namespace cb {

SceneBuffers::SceneBuffers(ClRuntime& runtime, const DeviceScene& scene)
    : nodes(uploadArray(runtime, "scene BVH nodes", scene.wide.nodes)),
      packs(uploadArray(runtime, "scene BVH leaf triangles", scene.wide.packs)),
      primitives(
          uploadArray(runtime, "scene primitives (triangles and spheres)", scene.bvh.primitives)),
      materials(uploadArray(runtime, "scene materials", scene.materials)),
      lights(uploadArray(runtime, "scene lights", scene.lights)),
      spectra(uploadArray(runtime, "scene spectra", scene.spectra)),
      toRgb(uploadArray(runtime, "spectrum-to-RGB matrix", scene.toRgb)),
      lightCount(int(scene.lights.size())) {}

int SceneBuffers::setKernelArgs(cl::Kernel& kernel, int first) const {
    kernel.setArg(first++, nodes);
    kernel.setArg(first++, packs);
    kernel.setArg(first++, primitives);
    kernel.setArg(first++, materials);
    kernel.setArg(first++, lights);
    kernel.setArg(first++, spectra);
    kernel.setArg(first++, lightCount);
    return first;
}

void launchOverPixels(cl::CommandQueue& queue, cl::Kernel& kernel, const cbk::Camera& camera,
                      int tile) {
    const size_t t = size_t(tile);
    auto roundUp = [t](int v) { return (size_t(v) + t - 1) / t * t; };
    queue.enqueueNDRangeKernel(kernel, cl::NullRange,
                               cl::NDRange(roundUp(camera.width), roundUp(camera.height)),
                               cl::NDRange(t, t));
}

} // namespace cb
