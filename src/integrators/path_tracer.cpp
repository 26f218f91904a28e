// PT and CPT: one kernel (kernels/pt.cl); CPT differs only in who shares the sample vector.
#include "integrators/kernel_integrator.h"

#include "cb_pt.h"

namespace cb {

namespace {

class PathTracingIntegrator final : public PixelKernelIntegrator {
  public:
    PathTracingIntegrator(const IntegratorSettings& settings, const DeviceScene& scene,
                          ClRuntime& runtime)
        : PixelKernelIntegrator(settings.name, "path-tracing", settings, scene, runtime) {
        buildProgram("pt.cl");
        cbk::PathSettings path{};
        path.eyeVertices = settings.eyeVertices;
        path.rouletteVertex = settings.rouletteVertex;
        // The sample-vector tile: 0 for PT (every pixel its own), k for CPT's k x k.
        const int streamTile = settings.name == "cpt" ? settings.coherenceTile : 0;
        const std::uint32_t sharedStreams = std::uint32_t(streamTile * streamTile);
        createKernel("renderPathTracing", path, [&](KernelArguments& args) {
            args.add(streamTile);
            addSharedSampleArguments(args, sharedStreams);
        });
    }
};

} // namespace

std::unique_ptr<Integrator> makePathTracingIntegrator(const IntegratorSettings& settings,
                                                      const DeviceScene& scene,
                                                      ClRuntime& runtime) {
    return std::make_unique<PathTracingIntegrator>(settings, scene, runtime);
}

} // namespace cb
