// CBDPT (METHOD.md, CBDPT; docs/cbdpt.md): per estimate the host traces the light subpaths
// (one per coherence-tile position, cbdpt_light.h) and splats their t = 1 connections; the
// combination kernel (kernels/cbdpt.cl) gives every pixel a coherent eye subpath and connects
// it to its tile position's light subpath with the BDPT weights.
#include "integrators/bdpt_settings.h"
#include "integrators/cbdpt_light.h"
#include "integrators/integrator.h"
#include "integrators/scene_buffers.h"

#include "cb_bdpt.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fmt/format.h>
#include <stdexcept>

namespace cb {

std::unique_ptr<CbdptLightTracer> makeCbdptLightTracer(const DeviceScene& scene,
                                                       const CbdptLightSettings& settings) {
    SceneBytes raw = sceneBytes(scene);
    if (scene.toRgb.size() != size_t(3 * scene.channels))
        throw std::logic_error("cbdpt: toRgb is not 3 x channels");
    if (scene.channels == 3) return makeCbdptLightTracerFor<float, 3>(raw, settings);
    if (scene.channels == 16) return makeCbdptLightTracerFor<float, 16>(raw, settings);
    throw std::invalid_argument(fmt::format(
        "cbdpt traces light subpaths on the host, which is built for 3 (RGB) or 16 (spectral) "
        "channels, not {}",
        scene.channels));
}

namespace {

class CbdptIntegrator final : public Integrator {
  public:
    CbdptIntegrator(const IntegratorSettings& settings, const DeviceScene& scene,
                    ClRuntime& runtime)
        : settings_(settings), scene_(scene), runtime_(runtime), buffers_(runtime, scene) {
        const int k = settings.coherenceTile;
        light_.seed = settings.seed;
        light_.sampler = samplerSettings(settings).kind;
        light_.eyeVertices = settings.eyeVertices;
        light_.lightVertices = settings.lightVertices;
        light_.weights = bdptSettingsFor(settings).weights;
        light_.coherenceTile = k;
        light_.tileRows = std::min(k, scene.camera.height);
        light_.tileColumns = std::min(k, scene.camera.width);
        tracer_ = makeCbdptLightTracer(scene, light_);
        subpaths_ = size_t(light_.tileRows) * size_t(light_.tileColumns);

        auto defines = scene.kernelDefines();
        defines.push_back(fmt::format("CB_MAX_EYE_VERTICES={}", settings.eyeVertices));
        defines.push_back(fmt::format("CB_MAX_LIGHT_VERTICES={}", settings.lightVertices));
        program_ = runtime.buildProgram("cbdpt.cl", defines);
        buildSeconds_ = runtime.lastBuildSeconds();
        kernel_ = cl::Kernel(program_, "renderCbdpt");
        auto& ctx = runtime.context();
        pixels_ = size_t(scene.camera.width) * size_t(scene.camera.height);
        output_ = runtime.createBuffer("CBDPT image (width x height RGB)", CL_MEM_WRITE_ONLY,
                                       3 * sizeof(float) * pixels_);
        vertexBufferBytes_ = subpaths_ * size_t(settings.lightVertices) * tracer_->vertexBytes();
        lightVertices_ = runtime.createBuffer(
            "CBDPT light subpaths (coherence tile^2 x --light-vertices vertices)", CL_MEM_READ_ONLY,
            vertexBufferBytes_);
        lightCounts_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, sizeof(int) * subpaths_);
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
        kernel_.setArg(arg++, k);
        kernel_.setArg(arg++, light_.tileColumns);
        kernel_.setArg(arg++, lightVertices_);
        kernel_.setArg(arg++, lightCounts_);
        kernel_.setArg(arg++, settings.lightVertices);
        kernel_.setArg(arg++, cbdptCameraCount(scene.camera.width, scene.camera.height, light_));
        kernel_.setArg(arg++, output_);
        kernel_.setArg(arg++, nonFinite_);
        kernel_.setArg(arg++, rays_);
        // Counting costs an atomic per pixel, so the kernel counts only when asked to.
        kernel_.setArg(arg++, int(reportRays_));
    }

    ~CbdptIntegrator() override {
        if (reportRays_ && kernelSeconds_ > 0.0)
            std::fprintf(stderr,
                         "cbdpt: %lld kernel rays in %.3f s (%.3g rays/s); host light pass "
                         "%lld rays in %.3f s\n",
                         kernelRays_, kernelSeconds_, double(kernelRays_) / kernelSeconds_,
                         hostRays_, hostSeconds_);
    }

    void renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) override {
        auto& queue = runtime_.queue();
        auto start = std::chrono::steady_clock::now();
        tracer_->trace(estimate, pass_);
        auto traced = std::chrono::steady_clock::now();
        hostSeconds_ += std::chrono::duration<double>(traced - start).count();
        hostRays_ += pass_.rays;
        hostNonFinite_ += pass_.nonFinite;

        queue.enqueueWriteBuffer(lightVertices_, CL_FALSE, 0, vertexBufferBytes_,
                                 pass_.vertices.data());
        queue.enqueueWriteBuffer(lightCounts_, CL_FALSE, 0, sizeof(int) * subpaths_,
                                 pass_.counts.data());
        if (reportRays_) {
            std::uint32_t zero = 0;
            queue.enqueueWriteBuffer(rays_, CL_TRUE, 0, sizeof(zero), &zero);
        }
        kernel_.setArg(estimateArg_, estimate);
        auto launched = std::chrono::steady_clock::now();
        launchOverPixels(queue, kernel_, scene_.camera, settings_.tileSize);
        queue.finish();
        kernelSeconds_ +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - launched).count();
        rgb.resize(3 * pixels_);
        queue.enqueueReadBuffer(output_, CL_TRUE, 0, 3 * sizeof(float) * pixels_, rgb.data());
        for (std::uint32_t p : pass_.splatPixels)
            for (size_t c = 3 * size_t(p); c < 3 * size_t(p) + 3; ++c)
                rgb[c] += pass_.splatRgb[c];
        int count = 0;
        queue.enqueueReadBuffer(nonFinite_, CL_TRUE, 0, sizeof(int), &count);
        kernelNonFinite_ = count;
        if (reportRays_) {
            std::uint32_t rays = 0;
            queue.enqueueReadBuffer(rays_, CL_TRUE, 0, sizeof(rays), &rays);
            kernelRays_ += rays;
        }
    }

    long nonFiniteSamples() const override { return kernelNonFinite_ + hostNonFinite_; }
    double buildSeconds() const override { return buildSeconds_; }

  private:
    IntegratorSettings settings_;
    const DeviceScene& scene_;
    ClRuntime& runtime_;
    CbdptLightSettings light_;
    std::unique_ptr<CbdptLightTracer> tracer_;
    CbdptLightPass pass_;
    cl::Program program_;
    cl::Kernel kernel_;
    SceneBuffers buffers_;
    cl::Buffer output_, lightVertices_, lightCounts_, nonFinite_, rays_;
    size_t pixels_ = 0, subpaths_ = 1, vertexBufferBytes_ = 0;
    int estimateArg_ = 0;
    long kernelNonFinite_ = 0, hostNonFinite_ = 0;
    long long kernelRays_ = 0, hostRays_ = 0;
    double kernelSeconds_ = 0.0, hostSeconds_ = 0.0, buildSeconds_ = 0.0;
    bool reportRays_ = false;
};

} // namespace

std::unique_ptr<Integrator> makeCbdptIntegrator(const IntegratorSettings& settings,
                                                const DeviceScene& scene, ClRuntime& runtime) {
    if (settings.debugS >= 0 || settings.debugT >= 0)
        throw std::invalid_argument("--strategy is a bdpt debug mode; cbdpt does not take it");
    return std::make_unique<CbdptIntegrator>(settings, scene, runtime);
}

} // namespace cb
