// PT and CPT: one kernel (kernels/pt.cl); CPT differs only in who shares the sample vector.
#include "integrators/integrator.h"
#include "integrators/scene_buffers.h"

#include "cb_pt.h"

namespace cb {

namespace {

class PathTracingIntegrator final : public Integrator {
  public:
    PathTracingIntegrator(const IntegratorSettings& settings, const DeviceScene& scene,
                          ClRuntime& runtime)
        : settings_(settings), scene_(scene), runtime_(runtime), buffers_(runtime, scene) {
        auto defines = scene.kernelDefines();
        program_ = runtime.buildProgram("pt.cl", defines);
        buildSeconds_ = runtime.lastBuildSeconds();
        kernel_ = cl::Kernel(program_, "renderPathTracing");
        auto& ctx = runtime.context();
        pixels_ = size_t(scene.camera.width) * size_t(scene.camera.height);
        output_ = runtime.createBuffer("path-tracing image (width x height RGB)", CL_MEM_WRITE_ONLY,
                                       3 * sizeof(float) * pixels_);
        int zero = 0;
        nonFinite_ = cl::Buffer(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(int), &zero);

        cbk::PathSettings path{};
        path.eyeVertices = settings.eyeVertices;
        path.rouletteVertex = settings.rouletteVertex;
        int arg = 0;
        arg = buffers_.setKernelArgs(kernel_, arg);
        kernel_.setArg(arg++, buffers_.toRgb);
        kernel_.setArg(arg++, scene.camera);
        kernel_.setArg(arg++, path);
        kernel_.setArg(arg++, samplerSettings(settings));
        estimateArg_ = arg++;
        kernel_.setArg(estimateArg_, 0u);
        int streamTile = settings.name == "cpt" ? settings.coherenceTile : 0;
        kernel_.setArg(arg++, streamTile);
        kernel_.setArg(arg++, output_);
        kernel_.setArg(arg++, nonFinite_);
    }

    void renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) override {
        auto& queue = runtime_.queue();
        kernel_.setArg(estimateArg_, estimate);
        launchOverPixels(queue, kernel_, scene_.camera, settings_.tileSize);
        rgb.resize(3 * pixels_);
        queue.enqueueReadBuffer(output_, CL_TRUE, 0, 3 * sizeof(float) * pixels_, rgb.data());
        int count = 0;
        queue.enqueueReadBuffer(nonFinite_, CL_TRUE, 0, sizeof(int), &count);
        nonFiniteTotal_ = count;
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
    cl::Buffer output_, nonFinite_;
    size_t pixels_ = 0;
    int estimateArg_ = 0;
    long nonFiniteTotal_ = 0;
    double buildSeconds_ = 0.0;
};

} // namespace

std::unique_ptr<Integrator> makePathTracingIntegrator(const IntegratorSettings& settings,
                                                      const DeviceScene& scene,
                                                      ClRuntime& runtime) {
    return std::make_unique<PathTracingIntegrator>(settings, scene, runtime);
}

} // namespace cb
