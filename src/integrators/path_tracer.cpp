// PT and CPT: one kernel (kernels/pt.cl); CPT differs only in who shares the sample vector.
#include "integrators/integrator.h"

#include "cb_pt.h"


namespace cb {

namespace {

template <typename T> cl::Buffer uploadArray(cl::Context& context, const std::vector<T>& data) {
    // OpenCL forbids zero-sized buffers; an unused array still gets one element.
    static const T zero{};
    const void* src = data.empty() ? &zero : data.data();
    size_t bytes = data.empty() ? sizeof(T) : sizeof(T) * data.size();
    return cl::Buffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes, const_cast<void*>(src));
}

class PathTracingIntegrator final : public Integrator {
  public:
    PathTracingIntegrator(const IntegratorSettings& settings, const DeviceScene& scene,
                          ClRuntime& runtime)
        : settings_(settings), scene_(scene), runtime_(runtime) {
        auto defines = scene.kernelDefines();
        program_ = runtime.buildProgram("pt.cl", defines);
        buildSeconds_ = runtime.lastBuildSeconds();
        kernel_ = cl::Kernel(program_, "renderPathTracing");
        auto& ctx = runtime.context();
        nodes_ = uploadArray(ctx, scene.bvh.nodes);
        primitives_ = uploadArray(ctx, scene.bvh.primitives);
        materials_ = uploadArray(ctx, scene.materials);
        lights_ = uploadArray(ctx, scene.lights);
        spectra_ = uploadArray(ctx, scene.spectra);
        toRgb_ = uploadArray(ctx, scene.toRgb);
        pixels_ = size_t(scene.camera.width) * size_t(scene.camera.height);
        output_ = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, 3 * sizeof(float) * pixels_);
        int zero = 0;
        nonFinite_ = cl::Buffer(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(int), &zero);

        cbk::PathSettings path{};
        path.eyeVertices = settings.eyeVertices;
        path.rouletteVertex = settings.rouletteVertex;
        int arg = 0;
        kernel_.setArg(arg++, nodes_);
        kernel_.setArg(arg++, primitives_);
        kernel_.setArg(arg++, materials_);
        kernel_.setArg(arg++, lights_);
        kernel_.setArg(arg++, spectra_);
        kernel_.setArg(arg++, int(scene.lights.size()));
        kernel_.setArg(arg++, toRgb_);
        kernel_.setArg(arg++, scene.camera);
        kernel_.setArg(arg++, path);
        kernel_.setArg(arg++, settings.seed);
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
        const size_t tile = size_t(settings_.tileSize);
        auto roundUp = [tile](int v) { return (size_t(v) + tile - 1) / tile * tile; };
        queue.enqueueNDRangeKernel(kernel_, cl::NullRange,
                                   cl::NDRange(roundUp(scene_.camera.width), roundUp(scene_.camera.height)),
                                   cl::NDRange(tile, tile));
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
    cl::Buffer nodes_, primitives_, materials_, lights_, spectra_, toRgb_, output_, nonFinite_;
    size_t pixels_ = 0;
    int estimateArg_ = 0;
    long nonFiniteTotal_ = 0;
    double buildSeconds_ = 0.0;
};

} // namespace

std::unique_ptr<Integrator> makePathTracingIntegrator(const IntegratorSettings& settings,
                                                      const DeviceScene& scene, ClRuntime& runtime) {
    return std::make_unique<PathTracingIntegrator>(settings, scene, runtime);
}

} // namespace cb
