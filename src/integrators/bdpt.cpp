// BDPT (kernels/bdpt.cl, shared code in kernels/cb_bdpt.h): one kernel per estimate traces a
// light and an eye subpath per pixel and combines them; light-tracing splats are recorded per
// work-item and added to the pixel image here, in pixel order (deterministic).
#include "integrators/bdpt_settings.h"
#include "integrators/integrator.h"
#include "integrators/scene_buffers.h"

#include "cb_bdpt.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fmt/format.h>
#include <stdexcept>

namespace cb {

namespace {

class BdptIntegrator final : public Integrator {
  public:
    BdptIntegrator(const IntegratorSettings& settings, const DeviceScene& scene, ClRuntime& runtime)
        : settings_(settings), scene_(scene), runtime_(runtime), buffers_(runtime, scene) {
        auto defines = scene.kernelDefines();
        // The private vertex arrays are sized by the caps, so each cap pair is its own build.
        defines.push_back(fmt::format("CB_MAX_EYE_VERTICES={}", settings.eyeVertices));
        defines.push_back(fmt::format("CB_MAX_LIGHT_VERTICES={}", settings.lightVertices));
        program_ = runtime.buildProgram("bdpt.cl", defines);
        buildSeconds_ = runtime.lastBuildSeconds();
        kernel_ = cl::Kernel(program_, "renderBdpt");
        auto& ctx = runtime.context();
        pixels_ = size_t(scene.camera.width) * size_t(scene.camera.height);
        output_ = runtime.createBuffer("BDPT image (width x height RGB)", CL_MEM_WRITE_ONLY,
                                       3 * sizeof(float) * pixels_);
        splatSlots_ = pixels_ * size_t(settings.lightVertices);
        splatTarget_ = runtime.createBuffer(
            "BDPT light-tracing splat targets (width x height x --light-vertices)",
            CL_MEM_WRITE_ONLY, sizeof(int) * splatSlots_);
        splat_ = runtime.createBuffer("BDPT light-tracing splats (width x height x "
                                      "--light-vertices RGB)",
                                      CL_MEM_WRITE_ONLY, 3 * sizeof(float) * splatSlots_);
        int zero = 0;
        nonFinite_ = cl::Buffer(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(int), &zero);
        rays_ = cl::Buffer(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(int), &zero);

        reportRays_ = std::getenv("CBDPT_RAY_STATS") != nullptr;
        const cbk::BdptSettings bdpt = bdptSettingsFor(settings);
        int arg = 0;
        arg = buffers_.setKernelArgs(kernel_, arg);
        kernel_.setArg(arg++, buffers_.toRgb);
        kernel_.setArg(arg++, scene.camera);
        kernel_.setArg(arg++, bdpt);
        kernel_.setArg(arg++, samplerSettings(settings));
        estimateArg_ = arg++;
        kernel_.setArg(estimateArg_, 0u);
        kernel_.setArg(arg++, output_);
        kernel_.setArg(arg++, splatTarget_);
        kernel_.setArg(arg++, splat_);
        kernel_.setArg(arg++, nonFinite_);
        kernel_.setArg(arg++, rays_);
        // Counting costs an atomic per pixel, so the kernel counts only when asked to.
        kernel_.setArg(arg++, int(reportRays_));
    }

    ~BdptIntegrator() override {
        // Rays per second of the combination kernel, for docs/performance.md.
        if (reportRays_ && kernelSeconds_ > 0.0)
            std::fprintf(stderr,
                         "bdpt: %lld rays (extension + shadow) in %.3f s of kernel time: %.3g "
                         "rays/s\n",
                         totalRays_, kernelSeconds_, double(totalRays_) / kernelSeconds_);
    }

    void renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) override {
        auto& queue = runtime_.queue();
        kernel_.setArg(estimateArg_, estimate);
        if (reportRays_) {
            std::uint32_t zero = 0;
            queue.enqueueWriteBuffer(rays_, CL_TRUE, 0, sizeof(zero), &zero);
        }
        auto start = std::chrono::steady_clock::now();
        launchOverPixels(queue, kernel_, scene_.camera, settings_.tileSize);
        queue.finish();
        kernelSeconds_ +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        rgb.resize(3 * pixels_);
        splatHost_.resize(3 * splatSlots_);
        splatTargetHost_.resize(splatSlots_);
        queue.enqueueReadBuffer(output_, CL_TRUE, 0, 3 * sizeof(float) * pixels_, rgb.data());
        queue.enqueueReadBuffer(splatTarget_, CL_TRUE, 0, sizeof(int) * splatSlots_,
                                splatTargetHost_.data());
        queue.enqueueReadBuffer(splat_, CL_TRUE, 0, 3 * sizeof(float) * splatSlots_,
                                splatHost_.data());
        for (size_t slot = 0; slot < splatSlots_; ++slot) {
            const int target = splatTargetHost_[slot];
            if (target < 0) continue;
            for (size_t c = 0; c < 3; ++c)
                rgb[3 * size_t(target) + c] += splatHost_[3 * slot + c];
        }
        int count = 0;
        queue.enqueueReadBuffer(nonFinite_, CL_TRUE, 0, sizeof(int), &count);
        nonFiniteTotal_ = count;
        if (reportRays_) {
            std::uint32_t rays = 0;
            queue.enqueueReadBuffer(rays_, CL_TRUE, 0, sizeof(rays), &rays);
            totalRays_ += rays;
        }
    }

    long nonFiniteSamples() const override { return nonFiniteTotal_; }
    double buildSeconds() const override { return buildSeconds_; }

  private:
    IntegratorSettings settings_;
    const DeviceScene& scene_;
    ClRuntime& runtime_;
    cl::Program program_;
    cl::Kernel kernel_;
    SceneBuffers buffers_;
    cl::Buffer output_, splatTarget_, splat_, nonFinite_, rays_;
    std::vector<float> splatHost_;
    std::vector<int> splatTargetHost_;
    size_t splatSlots_ = 0;
    size_t pixels_ = 0;
    int estimateArg_ = 0;
    long nonFiniteTotal_ = 0;
    long long totalRays_ = 0;
    double kernelSeconds_ = 0.0;
    double buildSeconds_ = 0.0;
    bool reportRays_ = false;
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
