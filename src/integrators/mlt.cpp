// Primary-sample-space MLT over BDPT (Kelemen et al. 2002; kernels/mlt.cl, docs/mlt.md).
//
// The first estimate starts with the bootstrap: many independent uniform primary-sample vectors
// are evaluated (I = luminance of their BDPT contribution); their mean is the normalisation b and
// the chains are seeded by resampling them in proportion to I. Each estimate then advances every
// chain by a fixed number of mutations (chains x mutations ~ pixels, so `--spp K` is K mutations
// per pixel); the chains carry their state from one estimate to the next.
#include "integrators/bdpt_settings.h"
#include "integrators/kernel_integrator.h"

#include "cb_bdpt.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <random>
#include <stdexcept>

namespace cb {

namespace {

// Explicit work-group size: left to PoCL it picks 4096 work-items, whose private vertex arrays
// (16-channel spectra) overflow the worker thread's stack.
constexpr size_t kChainGroupSize = 64;

constexpr int kStatsPerChain = 4; // mlt.cl CB_MLT_STATS
// The stages of mlt.cl's one kernel (CB_MLT_STAGE_*).
enum class MltStage : cl_uint { Bootstrap = 0, Seed = 1, Advance = 2 };
constexpr long kBootstrapBatch = 1 << 16;

size_t roundUp(size_t n, size_t multiple) {
    return (n + multiple - 1) / multiple * multiple;
}

class MltIntegrator final : public KernelIntegrator {
  public:
    MltIntegrator(const IntegratorSettings& settings, const DeviceScene& scene, ClRuntime& runtime)
        : KernelIntegrator("mlt", settings, scene, runtime), bdpt_(bdptSettingsFor(settings)) {
        // Dimensions the BDPT subpaths can read (cb_bdpt.h): eye bounce b uses 4 + 8b + {0,1,2}
        // for b <= Ne-3 and the s = 1 light point 4 + 8b + {4,5,6} for b <= Ne-2; light bounce b
        // uses 8 + 8b + {0,1,2} for b <= Nl-3. In a scattering medium the ray to vertex b + 1 of
        // either subpath also samples its distance (mediumDistanceDimension), after them.
        const bool scattering = (scene.features & CB_FEATURE_SCATTERING) != 0;
        eyeDims_ = cbk::eyeStreamDimensionsWithMedia(settings.eyeVertices, scattering);
        lightDims_ =
            scattering
                ? cbk::mediumDistanceDimension(CB_LIGHT_DIM_FIRST_BOUNCE, settings.lightVertices,
                                               std::max(0, settings.lightVertices - 1))
                : CB_LIGHT_DIM_FIRST_BOUNCE +
                      CB_DIMS_PER_BOUNCE * unsigned(std::max(0, settings.lightVertices - 2));
        dims_ = eyeDims_ + lightDims_;
        chains_ =
            settings.mltChains > 0 ? size_t(settings.mltChains) : std::max<size_t>(1, pixels_ / 16);
        mutationsPerChain_ = long((pixels_ + chains_ - 1) / chains_);
        bootstrapSamples_ = mltBootstrapSamples(settings, long(pixels_));
        maxSplats_ = size_t(settings.lightVertices) + 1;

        auto defines = vertexCapDefines();
        defines.push_back(fmt::format("CB_MLT_EYE_DIMS={}u", eyeDims_));
        defines.push_back(fmt::format("CB_MLT_LIGHT_DIMS={}u", lightDims_));
        buildProgram("mlt.cl", defines);
        kernel_ = cl::Kernel(program_, "mlt");

        auto& ctx = runtime.context();
        state_ = runtime.createBuffer("MLT chain states (chains x primary samples)",
                                      CL_MEM_READ_WRITE, sizeof(float) * chains_ * dims_);
        chainLum_ = cl::Buffer(ctx, CL_MEM_READ_WRITE, sizeof(float) * chains_);
        splatCount_ = cl::Buffer(ctx, CL_MEM_READ_WRITE, sizeof(int) * chains_);
        splatPixel_ = runtime.createBuffer("MLT splat pixels (chains x (--light-vertices + 1))",
                                           CL_MEM_READ_WRITE, sizeof(int) * chains_ * maxSplats_);
        splatRaster_ =
            runtime.createBuffer("MLT splat raster points (chains x (--light-vertices + 1) x, y)",
                                 CL_MEM_READ_WRITE, 2 * sizeof(float) * chains_ * maxSplats_);
        splatRgb_ =
            runtime.createBuffer("MLT splat values (chains x (--light-vertices + 1) RGB)",
                                 CL_MEM_READ_WRITE, 3 * sizeof(float) * chains_ * maxSplats_);
        image_ =
            runtime.createBuffer("MLT image (width x height RGB)", CL_MEM_READ_WRITE, imageBytes());
        largeSum_ = cl::Buffer(ctx, CL_MEM_READ_WRITE, sizeof(float) * chains_);
        stats_ =
            cl::Buffer(ctx, CL_MEM_READ_WRITE, sizeof(std::uint32_t) * kStatsPerChain * chains_);
        stats.chains = long(chains_);
        stats.mutationsPerChain = mutationsPerChain_;
        stats.bootstrapSamples = bootstrapSamples_;
    }

    void renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) override {
        auto& queue = runtime_.queue();
        if (!seeded_) bootstrapAndSeed();

        queue.enqueueFillBuffer(image_, 0.0f, 0, imageBytes());
        KernelArguments args =
            stageArguments(MltStage::Advance, chains_,
                           cl_uint(std::uint64_t(estimate) * std::uint64_t(mutationsPerChain_)));
        args.add(cl::Buffer()).add(cl::Buffer()); // the bootstrap's luminance and indices
        addStateArguments(args);
        args.add(image_).add(largeSum_).add(stats_);
        addCounterArguments(args);
        launch(kernel_, cl::NDRange(roundUp(chains_, 64)), cl::NDRange(kChainGroupSize));

        rgb.resize(3 * pixels_);
        queue.enqueueReadBuffer(image_, CL_TRUE, 0, imageBytes(), rgb.data());
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
        readCounters();
    }

    MltStatistics stats;

  private:
    // The kernel's arguments up to its buffers: the stage, the work-items that do something,
    // the first bootstrap vector or mutation step, and the mutations' settings.
    KernelArguments stageArguments(MltStage stage, size_t count, cl_uint first) {
        KernelArguments args = integratorArguments(kernel_, bdpt_);
        args.add(cl_uint(stage)).add(cl_uint(count)).add(first);
        args.add(cl_int(mutationsPerChain_));
        args.add(float(settings_.largeStepProbability));
        args.add(float(settings_.mutationSize / 16.0)).add(float(settings_.mutationSize));
        return args;
    }

    // The chains' states, as the seed stage writes them and the advance stage reads and writes
    // them.
    void addStateArguments(KernelArguments& args) const {
        args.add(state_)
            .add(chainLum_)
            .add(splatCount_)
            .add(splatPixel_)
            .add(splatRaster_)
            .add(splatRgb_);
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
            KernelArguments args = stageArguments(MltStage::Bootstrap, count, cl_uint(first));
            args.add(lumBuffer).add(cl::Buffer());
            for (int unused = 0; unused < 9;
                 ++unused) // the six state buffers, image, largeSum, stats
                args.add(cl::Buffer());
            addCounterArguments(args);
            queue.enqueueNDRangeKernel(kernel_, cl::NullRange, cl::NDRange(roundUp(count, 64)),
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
        KernelArguments args = stageArguments(MltStage::Seed, chains_, 0);
        args.add(cl::Buffer()).add(indexBuffer);
        addStateArguments(args);
        args.add(cl::Buffer()).add(cl::Buffer()).add(cl::Buffer()); // image, largeSum, stats
        addCounterArguments(args);
        queue.enqueueNDRangeKernel(kernel_, cl::NullRange, cl::NDRange(roundUp(chains_, 64)),
                                   cl::NDRange(kChainGroupSize));
        queue.finish();
        seeded_ = true;
    }

    const cbk::BdptSettings bdpt_;
    cl::Kernel kernel_;
    cl::Buffer state_, chainLum_, splatCount_, splatPixel_, splatRaster_, splatRgb_, image_,
        largeSum_, stats_;
    size_t chains_ = 0, maxSplats_ = 0;
    unsigned eyeDims_ = 0, lightDims_ = 0, dims_ = 0;
    long mutationsPerChain_ = 0, bootstrapSamples_ = 0;
    bool seeded_ = false;
    double bSum_ = 0, bCount_ = 0;
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

long mltBootstrapSamples(const IntegratorSettings& settings, long pixels) {
    return settings.mltBootstrap > 0 ? settings.mltBootstrap : std::max(pixels, kBootstrapBatch);
}

std::string mltSummary(const MltStatistics& stats) {
    return fmt::format(
        "mlt: b = {:.6g} (bootstrap {:.6g} +- {:.2g}, {} samples, {} non-zero), {} chains x {} "
        "mutations per estimate, acceptance {:.4f}, large steps {:.4f} of {} accepted, zero "
        "proposals {:.4f}",
        stats.normalization, stats.bootstrapNormalization, stats.bootstrapStandardError,
        stats.bootstrapSamples, stats.bootstrapNonZero, stats.chains, stats.mutationsPerChain,
        stats.acceptanceRate(),
        stats.largeSteps ? double(stats.largeStepsAccepted) / double(stats.largeSteps) : 0.0,
        stats.largeSteps,
        stats.mutations ? double(stats.zeroProposals) / double(stats.mutations) : 0.0);
}

const MltStatistics* mltStatistics(const Integrator& integrator) {
    auto* mlt = dynamic_cast<const MltIntegrator*>(&integrator);
    return mlt ? &mlt->stats : nullptr;
}

} // namespace cb
