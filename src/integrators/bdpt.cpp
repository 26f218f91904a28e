// BDPT (kernels/bdpt.cl, shared code in kernels/cb_bdpt.h): one kernel per estimate traces a
// light and an eye subpath per pixel and combines them; light-tracing splats go to a second
// image that is added to the pixel image here.
#include "integrators/bdpt_settings.h"
#include "integrators/kernel_integrator.h"

#include "cb_bdpt.h"

#include <fmt/format.h>
#include <stdexcept>

namespace cb {

namespace {

class BdptIntegrator final : public PixelKernelIntegrator {
  public:
    BdptIntegrator(const IntegratorSettings& settings, const DeviceScene& scene, ClRuntime& runtime)
        : PixelKernelIntegrator("bdpt", "BDPT", settings, scene, runtime),
          splat_(runtime.createBuffer("BDPT light-tracing image (width x height RGB)",
                                      CL_MEM_READ_WRITE, imageBytes())) {
        buildProgram("bdpt.cl", vertexCapDefines());
        createKernel("renderBdpt", bdptSettingsFor(settings),
                     [&](KernelArguments& args) { args.add(splat_); });
    }

  private:
    void beforeLaunch(std::uint32_t) override {
        runtime_.queue().enqueueFillBuffer(splat_, 0.0f, 0, imageBytes());
    }
    void afterReadBack(std::vector<float>& rgb) override {
        splatHost_.resize(rgb.size());
        runtime_.queue().enqueueReadBuffer(splat_, CL_TRUE, 0, imageBytes(), splatHost_.data());
        for (size_t i = 0; i < rgb.size(); ++i)
            rgb[i] += splatHost_[i];
    }

    cl::Buffer splat_;
    std::vector<float> splatHost_;
};

} // namespace

std::unique_ptr<Integrator> makeBdptIntegrator(const IntegratorSettings& settings,
                                               const DeviceScene& scene, ClRuntime& runtime) {
    if (settings.debugS >= 0 || settings.debugT >= 0) {
        if (!cbk::bdptStrategyAllowed(settings.debugS, settings.debugT, settings.eyeVertices,
                                      settings.lightVertices))
            throw std::invalid_argument(fmt::format(
                "--strategy {},{} does not exist with --eye-vertices {} --light-vertices {}: "
                "need 0 <= s <= Nl, 1 <= t <= Ne, s + t >= 2, and not (1,1)",
                settings.debugS, settings.debugT, settings.eyeVertices, settings.lightVertices));
    }
    return std::make_unique<BdptIntegrator>(settings, scene, runtime);
}

} // namespace cb
