#include "integrators/kernel_integrator.h"

#include "bvh/bvh_wide.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <string>

namespace cb {

namespace {

// Environment variable `name`'s value when it is set and not empty, which must be `first` or
// `second` (a comparison's forced choice); `unset` says in the error what unsetting it does.
std::optional<std::string> forcedChoice(const char* name, const char* first, const char* second,
                                        const std::string& unset) {
    const char* env = std::getenv(name);
    if (!env || !*env) return std::nullopt;
    const std::string forced = env;
    if (forced != first && forced != second)
        throw std::invalid_argument(fmt::format("{}='{}': expected {} or {} (unset it to {})", name,
                                                forced, first, second, unset));
    return forced;
}

} // namespace

KernelIntegrator::KernelIntegrator(std::string name, const IntegratorSettings& settings,
                                   const DeviceScene& scene, ClRuntime& runtime)
    : settings_(settings), scene_(scene), runtime_(runtime),
      pixels_(size_t(scene.camera.width) * size_t(scene.camera.height)), buffers_(runtime, scene),
      name_(std::move(name)), countRays_(std::getenv("CBDPT_RAY_STATS") != nullptr) {
    int zero = 0;
    auto& context = runtime.context();
    nonFinite_ = cl::Buffer(context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(int), &zero);
    rays_ = cl::Buffer(context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(int), &zero);
}

KernelIntegrator::~KernelIntegrator() {
    if (countRays_ && rayTotal_ > 0 && kernelSeconds_ > 0.0)
        fmt::print(stderr,
                   "{}: {} rays (extension + shadow) in {:.3f} s of kernel time: {:.3g} "
                   "rays/s\n",
                   name_, rayTotal_, kernelSeconds_, double(rayTotal_) / kernelSeconds_);
}

void KernelIntegrator::buildProgram(const std::string& file, std::vector<std::string> defines) {
    const std::size_t tree = scene_.wide.bytes();
    const auto cache = runtime_.info().globalCacheBytes;
    const auto forced = forcedChoice(
        "CBDPT_PREFETCH", "0", "1",
        fmt::format("prefetch only where the scene's tree, {:.3g} MB, is larger than a CPU "
                    "device's cache, {:.3g} MB",
                    double(tree) / 1e6, double(cache) / 1e6));
    const bool cpu = runtime_.info().cpu;
    treePrefetch_ = forced ? cpu && *forced == "1" : treePrefetchPays(tree, cache, cpu);
    std::vector<std::string> all = scene_.kernelDefines();
    all.push_back(fmt::format("CB_TREE_PREFETCH={}", treePrefetch_ ? 1 : 0));
    all.insert(all.end(), defines.begin(), defines.end());
    program_ = runtime_.buildProgram(file, all);
    buildSeconds_ = runtime_.lastBuildSeconds();
}

std::vector<std::string> KernelIntegrator::vertexCapDefines() const {
    return {fmt::format("CB_MAX_EYE_VERTICES={}", settings_.eyeVertices),
            fmt::format("CB_MAX_LIGHT_VERTICES={}", settings_.lightVertices)};
}

void KernelIntegrator::addCounterArguments(KernelArguments& args) const {
    args.add(nonFinite_).add(rays_).add(int(countRays_));
}

void KernelIntegrator::launch(cl::Kernel& kernel, const cl::NDRange& global,
                              const cl::NDRange& local) {
    auto& queue = runtime_.queue();
    if (countRays_) {
        std::uint32_t zero = 0;
        queue.enqueueWriteBuffer(rays_, CL_TRUE, 0, sizeof(zero), &zero);
    }
    const auto start = std::chrono::steady_clock::now();
    queue.enqueueNDRangeKernel(kernel, cl::NullRange, global, local);
    queue.finish();
    kernelSeconds_ +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void KernelIntegrator::readCounters() {
    auto& queue = runtime_.queue();
    int nonFinite = 0;
    queue.enqueueReadBuffer(nonFinite_, CL_TRUE, 0, sizeof(int), &nonFinite);
    nonFiniteTotal_ = nonFinite;
    if (countRays_) {
        std::uint32_t rays = 0;
        queue.enqueueReadBuffer(rays_, CL_TRUE, 0, sizeof(rays), &rays);
        rayTotal_ += rays;
    }
}

PixelKernelIntegrator::PixelKernelIntegrator(std::string name, const std::string& imageName,
                                             const IntegratorSettings& settings,
                                             const DeviceScene& scene, ClRuntime& runtime)
    : KernelIntegrator(std::move(name), settings, scene, runtime),
      image_(runtime.createBuffer(imageName + " image (width x height RGB)", CL_MEM_WRITE_ONLY,
                                  imageBytes())) {
    std::transform(settings_.name.begin(), settings_.name.end(), std::back_inserter(label_),
                   [](unsigned char c) { return char(std::toupper(c)); });
}

void PixelKernelIntegrator::addSharedSampleArguments(KernelArguments& args, std::uint32_t streams) {
    const char* env = std::getenv("CBDPT_SHARED_SAMPLES");
    const bool disabled = env && std::string(env) == "0";
    if (streams > 0 && !disabled && size_t(streams) * kPixelsPerSharedStream <= pixels_) {
        sharedStreams_ = streams;
        sharedDimensions_ = cbk::eyeStreamDimensionsWithMedia(
            settings_.eyeVertices, (scene_.features & CB_FEATURE_SCATTERING) != 0);
        sharedSamples_.resize(size_t(sharedStreams_) * sharedDimensions_);
    } else {
        sharedStreams_ = sharedDimensions_ = 0;
        sharedSamples_.assign(1, 0.0f); // OpenCL has no empty buffers; the kernel reads none
    }
    sharedSampleBuffer_ =
        runtime_.createBuffer("shared sample vectors (streams x dimensions)", CL_MEM_READ_ONLY,
                              sizeof(float) * sharedSamples_.size());
    args.add(sharedSampleBuffer_).add(sharedDimensions_);
}

void PixelKernelIntegrator::renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) {
    beforeLaunch(estimate);
    if (sharedStreams_ > 0) {
        // The same values samplerStream's sampleAt computes in the kernel, bit for bit.
        const cbk::SamplerSettings sampler = samplerSettings(settings_);
        for (std::uint32_t stream = 0; stream < sharedStreams_; ++stream) {
            const cbk::SampleStream s = cbk::samplerStream(sampler, estimate, stream);
            float* out = sharedSamples_.data() + size_t(stream) * sharedDimensions_;
            for (std::uint32_t d = 0; d < sharedDimensions_; ++d)
                out[d] = float(cbk::sampleAt(s, d));
        }
        runtime_.queue().enqueueWriteBuffer(sharedSampleBuffer_, CL_FALSE, 0,
                                            sizeof(float) * sharedSamples_.size(),
                                            sharedSamples_.data());
    }
    kernel_.setArg(estimateArgument_, estimate);
    const size_t tile = size_t(settings_.tileSize);
    const auto [across, down] = tiles(perTile_ ? settings_.coherenceTile : 1);
    if (perTile_)
        launch(kernel_, cl::NDRange(across, down), cl::NDRange(1, 1));
    else // a work-item per pixel, in square work-groups of tile x tile pixels
        launch(kernel_, cl::NDRange(across * tile, down * tile), cl::NDRange(tile, tile));
    rgb.resize(3 * pixels_);
    runtime_.queue().enqueueReadBuffer(image_, CL_TRUE, 0, imageBytes(), rgb.data());
    readCounters();
    afterReadBack(rgb);
}

bool PixelKernelIntegrator::packetsWanted() const {
    const char* env = std::getenv("CBDPT_PACKETS");
    // Packets trace one ray per path a round; a ray crossing an interface needs another at once.
    return runtime_.info().cpu && settings_.tileSize % 4 == 0 &&
           settings_.coherenceTile <= kMaxPacketCoherenceTile &&
           (scene_.features & CB_FEATURE_INTERFACE) == 0 && !(env && std::string(env) == "0");
}

std::vector<std::string> PixelKernelIntegrator::rayPacketDefines() {
    const int native = runtime_.info().nativeFloatWidth >= 16 ? 16 : 8;
    const auto width =
        forcedChoice("CBDPT_RAY_PACKET", "8", "16",
                     fmt::format("let the device choose: {} rays per packet", native));
    rayPacketRays_ = width ? std::stoi(*width) : native;
    return {fmt::format("CB_RAY_PACKET={}", rayPacketRays_)};
}

std::pair<size_t, size_t> PixelKernelIntegrator::tiles(int stride) const {
    const int tile = settings_.tileSize;
    return {size_t(cbk::packetTilesAcross(scene_.camera.width, tile, stride)),
            size_t(cbk::packetTilesAcross(scene_.camera.height, tile, stride))};
}

cl::Buffer PixelKernelIntegrator::packetScratch(const char* what, size_t perPixel, size_t bytes) {
    const size_t tile = size_t(settings_.tileSize);
    const auto [across, down] = tiles(settings_.coherenceTile);
    return runtime_.createBuffer(
        fmt::format("{} packet {} ({} per pixel x {} bytes)", label_, what, perPixel, bytes),
        CL_MEM_READ_WRITE, across * down * tile * tile * perPixel * bytes);
}

} // namespace cb
