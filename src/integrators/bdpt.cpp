// BDPT (kernels/bdpt.cl, shared code in kernels/cb_bdpt.h): one kernel per estimate traces a
// light and an eye subpath per pixel and combines them; light-tracing splats are recorded per
// work-item and added to the pixel image here, in pixel order (deterministic).
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
          splatSlots_(pixels_ * size_t(settings.lightVertices)),
          splatTarget_(runtime.createBuffer(
              "BDPT light-tracing splat targets (width x height x --light-vertices)",
              CL_MEM_WRITE_ONLY, sizeof(int) * splatSlots_)),
          splat_(runtime.createBuffer("BDPT light-tracing splats (width x height x "
                                      "--light-vertices RGB)",
                                      CL_MEM_WRITE_ONLY, 3 * sizeof(float) * splatSlots_)) {
        buildProgram("bdpt.cl", vertexCapDefines());
        createKernel("renderBdpt", bdptSettingsFor(settings),
                     [&](KernelArguments& args) { args.add(splatTarget_).add(splat_); });
    }

  private:
    // Each work-item wrote one slot per light vertex (target -1: nothing to splat); adding them
    // in slot order makes an estimate the same bits however the work-items were scheduled.
    void afterReadBack(std::vector<float>& rgb) override {
        splatHost_.resize(3 * splatSlots_);
        splatTargetHost_.resize(splatSlots_);
        auto& queue = runtime_.queue();
        queue.enqueueReadBuffer(splatTarget_, CL_TRUE, 0, sizeof(int) * splatSlots_,
                                splatTargetHost_.data());
        queue.enqueueReadBuffer(splat_, CL_TRUE, 0, 3 * sizeof(float) * splatSlots_,
                                splatHost_.data());
        for (size_t slot = 0; slot < splatSlots_; ++slot) {
            const int target = splatTargetHost_[slot];
            if (target < 0) continue;
            // A device that skipped a pixel leaves its slots unset: refuse, not write past rgb.
            if (size_t(target) >= pixels_)
                throw std::runtime_error(fmt::format(
                    "BDPT: the kernel's light-tracing splat slot {} targets pixel {}, outside "
                    "the image's {} pixels (a device fault)",
                    slot, target, pixels_));
            for (size_t c = 0; c < 3; ++c)
                rgb[3 * size_t(target) + c] += splatHost_[3 * slot + c];
        }
    }

    size_t splatSlots_;
    cl::Buffer splatTarget_, splat_;
    std::vector<float> splatHost_;
    std::vector<int> splatTargetHost_;
};

} // namespace

std::unique_ptr<Integrator> makeBdptIntegrator(const IntegratorSettings& settings,
                                               const DeviceScene& scene, ClRuntime& runtime) {
    if (settings.debugS >= 0 || settings.debugT >= 0) {
        if (!cbk::bdptStrategyExists(settings.debugS, settings.debugT, bdptSettingsFor(settings)))
            throw std::invalid_argument(fmt::format(
                "--strategy {},{} does not exist with --eye-vertices {} --light-vertices {}{}: "
                "need 0 <= s <= Nl, 1 <= t <= Ne, s + t >= 2, and not (1,1)",
                settings.debugS, settings.debugT, settings.eyeVertices, settings.lightVertices,
                settings.maxPathVertices > 0
                    ? fmt::format(" and s + t <= --max-vertices {}", settings.maxPathVertices)
                    : std::string()));
    }
    return std::make_unique<BdptIntegrator>(settings, scene, runtime);
}

} // namespace cb
