// BDPT (kernels/bdpt.cl, shared code in kernels/cb_bdpt.h): one kernel per estimate traces a
// light and an eye subpath per pixel and combines them; light-tracing splats are recorded per
// work-item and added to the pixel image here, through the pixel filter, in pixel order
// (deterministic).
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
          splatUsed_(runtime.createBuffer(
              "BDPT light-tracing splat flags (width x height x --light-vertices)",
              CL_MEM_WRITE_ONLY, sizeof(int) * splatSlots_)),
          splatRaster_(runtime.createBuffer("BDPT light-tracing splat points (width x height x "
                                            "--light-vertices raster x, y)",
                                            CL_MEM_WRITE_ONLY, 2 * sizeof(float) * splatSlots_)),
          splat_(runtime.createBuffer("BDPT light-tracing splats (width x height x "
                                      "--light-vertices RGB)",
                                      CL_MEM_WRITE_ONLY, 3 * sizeof(float) * splatSlots_)) {
        buildProgram("bdpt.cl", vertexCapDefines());
        createKernel("renderBdpt", bdptSettingsFor(settings), [&](KernelArguments& args) {
            args.add(splatUsed_).add(splatRaster_).add(splat_);
        });
    }

  private:
    // Each work-item wrote one slot per light vertex (flag 0: nothing to splat); adding them
    // in slot order makes an estimate the same bits however the work-items were scheduled.
    void afterReadBack(std::vector<float>& rgb) override {
        splatHost_.resize(3 * splatSlots_);
        splatRasterHost_.resize(2 * splatSlots_);
        splatUsedHost_.resize(splatSlots_);
        auto& queue = runtime_.queue();
        queue.enqueueReadBuffer(splatUsed_, CL_TRUE, 0, sizeof(int) * splatSlots_,
                                splatUsedHost_.data());
        queue.enqueueReadBuffer(splatRaster_, CL_TRUE, 0, 2 * sizeof(float) * splatSlots_,
                                splatRasterHost_.data());
        queue.enqueueReadBuffer(splat_, CL_TRUE, 0, 3 * sizeof(float) * splatSlots_,
                                splatHost_.data());
        const cbk::Camera& camera = scene_.camera;
        for (size_t slot = 0; slot < splatSlots_; ++slot) {
            if (splatUsedHost_[slot] == 0) continue;
            const float rx = splatRasterHost_[2 * slot], ry = splatRasterHost_[2 * slot + 1];
            // A device that skipped a pixel leaves its slots unset: refuse, not write past rgb.
            if (!cbk::filterReaches(&camera, rx, ry))
                throw std::runtime_error(fmt::format(
                    "BDPT: the kernel's light-tracing splat slot {} lands at raster point ({}, "
                    "{}), outside the {} x {} image's pixel filters (a device fault)",
                    slot, rx, ry, camera.width, camera.height));
            const cbk::FilterSplat splat = cbk::filterSplatAt(&camera, rx, ry);
            for (int y = splat.y0; y <= splat.y1; ++y) {
                const float row = cbk::filterSplatRow(&camera, &splat, y);
                for (int x = splat.x0; x <= splat.x1; ++x) {
                    const float weight = row * cbk::filterSplatColumn(&camera, &splat, x);
                    float* pixel = &rgb[3 * (size_t(y) * size_t(camera.width) + size_t(x))];
                    for (size_t c = 0; c < 3; ++c)
                        pixel[c] += weight * splatHost_[3 * slot + c];
                }
            }
        }
    }

    size_t splatSlots_;
    cl::Buffer splatUsed_, splatRaster_, splat_;
    std::vector<float> splatHost_, splatRasterHost_;
    std::vector<int> splatUsedHost_;
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
