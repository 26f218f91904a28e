// Primary-sample-space MLT over BDPT (Kelemen et al. 2002; kernels/mlt.cl, docs/mlt.md).
//
// The first estimate starts with the bootstrap: many independent uniform primary-sample vectors
// are evaluated (I = luminance of their BDPT contribution); their mean is the normalisation b and
// the chains are seeded by resampling them in proportion to I. Each estimate then advances every
// chain by a fixed number of mutations (chains x mutations ~ pixels, so `--spp K` is K mutations
// per pixel); the chains carry their state from one estimate to the next.
#include "integrators/bdpt_settings.h"
#include "integrators/integrator.h"
#include "integrators/scene_buffers.h"

#include "cb_bdpt.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fmt/format.h>
#include <random>
#include <stdexcept>

namespace cb {

namespace {

// Explicit work-group size: left to PoCL it picks 4096 work-items, whose private vertex arrays
// (16-channel spectra) overflow the worker thread's stack.
constexpr size_t kChainGroupSize = 64;

constexpr int kStatsPerChain = 4; // mlt.cl CB_MLT_STATS
constexpr long kBootstrapBatch = 1 << 16;

size_t roundUp(size_t n, size_t multiple) {
    return (n + multiple - 1) / multiple * multiple;
}

class MltIntegrator final : public Integrator {
  public:
    MltIntegrator(const IntegratorSettings& settings, const DeviceScene& scene, ClRuntime& runtime)
        : settings_(settings), scene_(scene), runtime_(runtime), buffers_(runtime, scene) {
        pixels_ = size_t(scene.camera.width) * size_t(scene.camera.height);
        // Dimensions the BDPT subpaths can read (cb_bdpt.h): eye bounce b uses 4 + 8b + {0,1,2}
        // for b <= Ne-3 and the s = 1 light point 4 + 8b + {4,5,6} for b <= Ne-2; light bounce b
        // uses 8 + 8b + {0,1,2} for b <= Nl-3.
        eyeDims_ = CB_DIM_FIRST_BOUNCE +
                   CB_DIMS_PER_BOUNCE * unsigned(std::max(0, settings.eyeVertices - 1));
        lightDims_ = CB_LIGHT_DIM_FIRST_BOUNCE +
                     CB_DIMS_PER_BOUNCE * unsigned(std::max(0, settings.lightVertices - 2));
        dims_ = eyeDims_ + lightDims_;
        chains_ =
            settings.mltChains > 0 ? size_t(settings.mltChains) : std::max<size_t>(1, pixels_ / 16);
        mutationsPerChain_ = long((pixels_ + chains_ - 1) / chains_);
        bootstrapSamples_ = settings.mltBootstrap > 0
                                ? settings.mltBootstrap
                                : std::max<long>(long(pixels_), kBootstrapBatch);
        maxSplats_ = size_t(settings.lightVertices) + 1;

        auto defines = scene.kernelDefines();
        defines.push_back(fmt::format("CB_MAX_EYE_VERTICES={}", settings.eyeVertices));
        defines.push_back(fmt::format("CB_MAX_LIGHT_VERTICES={}", settings.lightVertices));
        defines.push_back(fmt::format("CB_MLT_EYE_DIMS={}u", eyeDims_));
        defines.push_back(fmt::format("CB_MLT_LIGHT_DIMS={}u", lightDims_));
        program_ = runtime.buildProgram("mlt.cl", defines);
        buildSeconds_ = runtime.lastBuildSeconds();
        bootstrapKernel_ = cl::Kernel(program_, "mltBootstrap");
        seedKernel_ = cl::Kernel(program_, "mltSeedChains");
        advanceKernel_ = cl::Kernel(program_, "mltAdvance");

        bdpt_ = bdptSettingsFor(settings);

        auto& ctx = runtime.context();
        state_ = runtime.createBuffer("MLT chain states (chains x primary samples)",
                                      CL_MEM_READ_WRITE, sizeof(float) * chains_ * dims_);
        chainLum_ = cl::Buffer(ctx, CL_MEM_READ_WRITE, sizeof(float) * chains_);
        splatCount_ = cl::Buffer(ctx, CL_MEM_READ_WRITE, sizeof(int) * chains_);
        splatPixel_ = runtime.createBuffer("MLT splat pixels (chains x (--light-vertices + 1))",
                                           CL_MEM_READ_WRITE, sizeof(int) * chains_ * maxSplats_);
        splatRgb_ =
            runtime.createBuffer("MLT splat values (chains x (--light-vertices + 1) RGB)",
                                 CL_MEM_READ_WRITE, 3 * sizeof(float) * chains_ * maxSplats_);
        image_ = runtime.createBuffer("MLT image (width x height RGB)", CL_MEM_READ_WRITE,
                                      3 * sizeof(float) * pixels_);
        largeSum_ = cl::Buffer(ctx, CL_MEM_READ_WRITE, sizeof(float) * chains_);
        stats_ =
            cl::Buffer(ctx, CL_MEM_READ_WRITE, sizeof(std::uint32_t) * kStatsPerChain * chains_);
        int zero = 0;
        nonFinite_ = cl::Buffer(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(int), &zero);
        rays_ = cl::Buffer(ctx, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof(int), &zero);
        reportRays_ = std::getenv("CBDPT_RAY_STATS") != nullptr;
        stats.chains = long(chains_);
        stats.mutationsPerChain = mutationsPerChain_;
        stats.bootstrapSamples = bootstrapSamples_;
    }

    ~MltIntegrator() override {
        if (stats.mutations > 0)
            std::fprintf(
                stderr,
                "mlt: b = %.6g (bootstrap %.6g +- %.2g, %ld samples, %ld non-zero), %ld "
                "chains x %ld mutations per estimate, acceptance %.4f, large steps "
                "%.4f of %ld accepted, zero proposals %.4f\n",
                stats.normalization, stats.bootstrapNormalization, stats.bootstrapStandardError,
                stats.bootstrapSamples, stats.bootstrapNonZero, stats.chains,
                stats.mutationsPerChain, stats.acceptanceRate(),
                stats.largeSteps ? double(stats.largeStepsAccepted) / double(stats.largeSteps)
                                 : 0.0,
                stats.largeSteps, double(stats.zeroProposals) / double(stats.mutations));
        if (reportRays_ && kernelSeconds_ > 0.0)
            std::fprintf(stderr, "mlt: %lld rays in %.3f s of kernel time: %.3g rays/s\n",
                         totalRays_, kernelSeconds_, double(totalRays_) / kernelSeconds_);
    }

    void renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) override {
        auto& queue = runtime_.queue();
        if (!seeded_) bootstrapAndSeed();

        queue.enqueueFillBuffer(image_, 0.0f, 0, 3 * sizeof(float) * pixels_);
        std::uint32_t zero = 0;
        queue.enqueueWriteBuffer(rays_, CL_TRUE, 0, sizeof(zero), &zero);
        int arg = buffers_.setKernelArgs(advanceKernel_, 0);
        advanceKernel_.setArg(arg++, buffers_.toRgb);
        advanceKernel_.setArg(arg++, scene_.camera);
        advanceKernel_.setArg(arg++, bdpt_);
        advanceKernel_.setArg(arg++, settings_.seed);
        advanceKernel_.setArg(arg++, cl_uint(chains_));
        advanceKernel_.setArg(arg++,
                              cl_uint(std::uint64_t(estimate) * std::uint64_t(mutationsPerChain_)));
        advanceKernel_.setArg(arg++, cl_int(mutationsPerChain_));
        advanceKernel_.setArg(arg++, float(settings_.largeStepProbability));
        advanceKernel_.setArg(arg++, float(settings_.mutationSize / 16.0));
        advanceKernel_.setArg(arg++, float(settings_.mutationSize));
        arg = setStateArgs(advanceKernel_, arg);
        advanceKernel_.setArg(arg++, image_);
        advanceKernel_.setArg(arg++, largeSum_);
        advanceKernel_.setArg(arg++, stats_);
        advanceKernel_.setArg(arg++, nonFinite_);
        advanceKernel_.setArg(arg++, rays_);
        auto start = std::chrono::steady_clock::now();
        queue.enqueueNDRangeKernel(advanceKernel_, cl::NullRange, cl::NDRange(roundUp(chains_, 64)),
                                   cl::NDRange(kChainGroupSize));
        queue.finish();
        kernelSeconds_ +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

        rgb.resize(3 * pixels_);
        queue.enqueueReadBuffer(image_, CL_TRUE, 0, 3 * sizeof(float) * pixels_, rgb.data());
        // Each mutation adds (expected) F/I with I distributed as I/b: times b it is F per unit
        // primary-sample volume, and pixels/mutations turns the sum into the image.
        const double mutations = double(chains_) * double(mutationsPerChain_);
        const float scale = float(stats.normalization * double(pixels_) / mutations);
        for (float& v : rgb)
            v *= scale;

        std::vector<float> largeSum(chains_);
        std::vector<std::uint32_t> chainStats(kStatsPerChain * chains_);
        queue.enqueueReadBuffer(largeSum_, CL_TRUE, 0, sizeof(float) * chains_, largeSum.data());
        queue.enqueueReadBuffer(stats_, CL_TRUE, 0, sizeof(std::uint32_t) * chainStats.size(),
                                chainStats.data());
        long large = 0;
        for (size_t c = 0; c < chains_; ++c) {
            bSum_ += double(largeSum[c]);
            stats.accepted += chainStats[kStatsPerChain * c + 0];
            large += chainStats[kStatsPerChain * c + 1];
            stats.largeStepsAccepted += chainStats[kStatsPerChain * c + 2];
            stats.zeroProposals += chainStats[kStatsPerChain * c + 3];
        }
        stats.largeSteps += large;
        stats.mutations += long(mutations);
        bCount_ += double(large);
        // The next estimate uses b refined by this one's large steps (uniform draws, so unbiased
        // for b); this estimate used b from before it, which its own splats do not depend on.
        stats.normalization = bSum_ / bCount_;

        int count = 0;
        queue.enqueueReadBuffer(nonFinite_, CL_TRUE, 0, sizeof(int), &count);
        nonFiniteTotal_ = count;
        std::uint32_t rays = 0;
        queue.enqueueReadBuffer(rays_, CL_TRUE, 0, sizeof(rays), &rays);
        totalRays_ += rays;
    }

    long nonFiniteSamples() const override { return nonFiniteTotal_; }
    double buildSeconds() const override { return buildSeconds_; }

    MltStatistics stats;

  private:
    int setStateArgs(cl::Kernel& kernel, int arg) {
        kernel.setArg(arg++, state_);
        kernel.setArg(arg++, chainLum_);
        kernel.setArg(arg++, splatCount_);
        kernel.setArg(arg++, splatPixel_);
        kernel.setArg(arg++, splatRgb_);
        return arg;
    }

    int setCommonArgs(cl::Kernel& kernel) {
        int arg = buffers_.setKernelArgs(kernel, 0);
        kernel.setArg(arg++, buffers_.toRgb);
        kernel.setArg(arg++, scene_.camera);
        kernel.setArg(arg++, bdpt_);
        kernel.setArg(arg++, settings_.seed);
        return arg;
    }

    void bootstrapAndSeed() {
        auto& queue = runtime_.queue();
        auto& ctx = runtime_.context();
        const size_t n = size_t(bootstrapSamples_);
        std::vector<float> lum(n);
        const size_t batch = std::min<size_t>(n, kBootstrapBatch);
        cl::Buffer lumBuffer(ctx, CL_MEM_WRITE_ONLY, sizeof(float) * batch);
        for (size_t first = 0; first < n; first += batch) {
            const size_t count = std::min(batch, n - first);
            int arg = setCommonArgs(bootstrapKernel_);
            bootstrapKernel_.setArg(arg++, cl_uint(first));
            bootstrapKernel_.setArg(arg++, cl_uint(count));
            bootstrapKernel_.setArg(arg++, lumBuffer);
            bootstrapKernel_.setArg(arg++, nonFinite_);
            queue.enqueueNDRangeKernel(bootstrapKernel_, cl::NullRange,
                                       cl::NDRange(roundUp(count, 64)),
                                       cl::NDRange(kChainGroupSize));
            queue.enqueueReadBuffer(lumBuffer, CL_TRUE, 0, sizeof(float) * count,
                                    lum.data() + first);
        }
        double sum = 0, sumSq = 0;
        long nonZero = 0;
        std::vector<double> cdf(n);
        for (size_t i = 0; i < n; ++i) {
            double v = double(lum[i]);
            sum += v;
            sumSq += v * v;
            nonZero += v > 0.0;
            cdf[i] = sum;
        }
        const double mean = sum / double(n);
        stats.bootstrapNormalization = mean;
        stats.bootstrapStandardError =
            n > 1 ? std::sqrt(std::max(0.0, sumSq / double(n) - mean * mean) / double(n - 1)) : 0.0;
        stats.bootstrapNonZero = nonZero;
        stats.normalization = mean;
        bSum_ = sum;
        bCount_ = double(n);

        // Systematic resampling in proportion to I: chain c takes the sample whose CDF interval
        // holds (c + offset) / chains of the total. Each chain's start is then distributed as
        // I / b up to the bootstrap's finite size (start-up bias O(1/n)).
        std::vector<std::uint32_t> index(chains_);
        std::mt19937_64 rng(0x6d6c74ull ^ settings_.seed);
        const double offset = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
        size_t j = 0;
        for (size_t c = 0; c < chains_; ++c) {
            if (!(sum > 0.0)) {
                index[c] = std::uint32_t(c % n); // nothing found: any start, b = 0 anyway
                continue;
            }
            const double target = (double(c) + offset) / double(chains_) * sum;
            while (j + 1 < n && cdf[j] <= target)
                ++j;
            index[c] = std::uint32_t(j);
        }
        cl::Buffer indexBuffer(ctx, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                               sizeof(std::uint32_t) * chains_, index.data());
        int arg = setCommonArgs(seedKernel_);
        seedKernel_.setArg(arg++, cl_uint(chains_));
        seedKernel_.setArg(arg++, indexBuffer);
        setStateArgs(seedKernel_, arg);
        queue.enqueueNDRangeKernel(seedKernel_, cl::NullRange, cl::NDRange(roundUp(chains_, 64)),
                                   cl::NDRange(kChainGroupSize));
        queue.finish();
        seeded_ = true;
    }

    IntegratorSettings settings_;
    const DeviceScene& scene_;
    ClRuntime& runtime_;
    SceneBuffers buffers_;
    cl::Program program_;
    cl::Kernel bootstrapKernel_, seedKernel_, advanceKernel_;
    cbk::BdptSettings bdpt_{};
    cl::Buffer state_, chainLum_, splatCount_, splatPixel_, splatRgb_, image_, largeSum_, stats_,
        nonFinite_, rays_;
    size_t pixels_ = 0, chains_ = 0, maxSplats_ = 0;
    unsigned eyeDims_ = 0, lightDims_ = 0, dims_ = 0;
    long mutationsPerChain_ = 0, bootstrapSamples_ = 0;
    bool seeded_ = false;
    double bSum_ = 0, bCount_ = 0;
    long nonFiniteTotal_ = 0;
    long long totalRays_ = 0;
    double kernelSeconds_ = 0.0;
    double buildSeconds_ = 0.0;
    bool reportRays_ = false;
};

} // namespace

std::unique_ptr<Integrator> makeMltIntegrator(const IntegratorSettings& settings,
                                              const DeviceScene& scene, ClRuntime& runtime) {
    if (!(settings.largeStepProbability >= 0.0 && settings.largeStepProbability <= 1.0))
        throw std::invalid_argument(
            fmt::format("--large-step {} must be between 0 and 1", settings.largeStepProbability));
    if (!(settings.mutationSize > 0.0 && settings.mutationSize <= 0.5))
        throw std::invalid_argument(
            fmt::format("--mutation-size {} must be in (0, 0.5]", settings.mutationSize));
    if (settings.mltChains < 0 || settings.mltChains > (1 << 24))
        throw std::invalid_argument(fmt::format(
            "--chains {} must be between 0 (automatic) and 16777216", settings.mltChains));
    if (settings.mltBootstrap < 0 || settings.mltBootstrap > (1L << 31))
        throw std::invalid_argument("the MLT bootstrap count must be between 0 and 2^31");
    if (settings.debugS >= 0 || settings.debugT >= 0)
        throw std::invalid_argument("--strategy is a BDPT debug mode, not available with mlt");
    return std::make_unique<MltIntegrator>(settings, scene, runtime);
}

const MltStatistics* mltStatistics(const Integrator& integrator) {
    auto* mlt = dynamic_cast<const MltIntegrator*>(&integrator);
    return mlt ? &mlt->stats : nullptr;
}

} // namespace cb
