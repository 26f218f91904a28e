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
      lightTables(uploadArray(runtime, "image lights' sampling tables", scene.lightTables)),
      textures(uploadArray(runtime, "texture coordinates and image textures", scene.textures)),
      shadingNormals(uploadArray(runtime, "vertex normals", scene.shadingNormals)),
      curves(uploadArray(runtime, "curve pieces", scene.curves)),
      toRgb(uploadArray(runtime, "spectrum-to-RGB matrix", scene.toRgb)),
      lightCount(int(scene.lights.size())) {}

void SceneBuffers::addKernelArguments(KernelArguments& args) const {
    args.add(nodes)
        .add(packs)
        .add(primitives)
        .add(materials)
        .add(lights)
        .add(spectra)
        .add(lightTables)
        .add(textures)
        .add(shadingNormals)
        .add(curves);
    args.add(lightCount);
}

} // namespace cb
