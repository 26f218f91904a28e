// Integrators compute one estimate (one sample per pixel) of the image at a time; the driver
// (render.h) accumulates estimates, reports progress and writes output.
#pragma once

#include "cl/cl_runtime.h"
#include "scene/device_scene.h"

#include "cb_rng.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cb {

struct IntegratorSettings {
    std::string name = "pt"; // pt | cpt | bdpt | cbdpt | mlt
    int eyeVertices = 8;     // Ne, the camera included (thesis convention)
    int lightVertices = 4;   // Nl, the point on the light included (bidirectional methods)
    // N > 0: pbrt-v4's and SmallVCM's total-length cap instead of the thesis's per-subpath caps:
    // paths of at most N vertices (camera and light point included), every strategy with
    // s + t <= N, so that BDPT, CBDPT and MLT cover every path PT renders with N vertices (and
    // point lights' caustics, which PT cannot sample; docs/bdpt.md). makeIntegrator then sets
    // Ne = N and Nl = N - 1. 0: the caps above.
    int maxPathVertices = 0;
    std::string weights = "power"; // bidirectional MIS: power | lafortune
    int debugS = -1;               // >= 0 with debugT: render only strategy (s, t), unweighted
    int debugT = -1;
    int rouletteVertex = 3; // Russian roulette from this vertex on; 0 disables it
    std::uint32_t seed = 0;
    // sobol | independent: the sample vectors' sampler (cb_rng.h, docs/sampling.md); sobol
    // measures best for every method; mlt's Markov chains choose their own samples
    std::string sampler = "sobol";
    int coherenceTile = 1; // cpt, cbdpt: k x k distinct sample vectors per estimate
    int tileSize = 8;      // pixel tile (work-group) edge
    // mlt (docs/mlt.md): Kelemen et al. 2002 primary-sample-space MLT over BDPT.
    double largeStepProbability = 0.3; // probability that a mutation draws all samples anew
    double mutationSize = 1.0 / 64.0;  // largest perturbation s2 (Kelemen: s1 = s2 / 16)
    int mltChains = 0;                 // chains (work-items); 0: pixels / 16
    long mltBootstrap = 0;             // bootstrap samples; 0: max(pixels, 65536)
};

class Integrator {
  public:
    virtual ~Integrator() = default;
    // Render estimate number `estimate` into rgb (3 floats per pixel, linear sRGB).
    virtual void renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) = 0;
    // Samples that came out NaN/Inf and were dropped (set to zero), over all estimates so far.
    virtual long nonFiniteSamples() const = 0;
    // Seconds spent building OpenCL programs (not part of render time).
    virtual double buildSeconds() const = 0;
    // CPT and CBDPT: how many shared sample vectors the host draws per estimate for the
    // kernel (0: the kernel draws every value itself).
    virtual std::uint32_t hostSampleStreams() const { return 0; }
    // CPT and CBDPT: whether the kernel traces the eye paths' rays as packets (a work-item per
    // tile of pixels that share one sample vector) rather than a work-item per pixel.
    virtual bool tracesPackets() const { return false; }
    // Rays per packet when tracesPackets() (8 or 16), else 0.
    virtual int rayPacketRays() const { return 0; }
    // Whether the kernels' traversals prefetch the tree's nodes and packs (a tree larger than
    // the device's cache).
    virtual bool treePrefetch() const { return false; }
};

// The kernels' sampler settings: seed and kind (CB_SAMPLER_*), from a validated name.
cbk::SamplerSettings samplerSettings(const IntegratorSettings& settings);

// The settings with the total-length cap resolved into subpath caps: with maxPathVertices N > 0,
// eyeVertices = N and lightVertices = N - 1 (each subpath as long as the cap allows); unchanged
// otherwise. makeIntegrator applies it; reports call it to state the caps actually used.
IntegratorSettings withResolvedCaps(const IntegratorSettings& settings);

// Validates the settings against the scene (caps, names) and builds the kernels.
std::unique_ptr<Integrator> makeIntegrator(const IntegratorSettings& settings,
                                           const DeviceScene& scene, ClRuntime& runtime);

// Per-method constructors, called by makeIntegrator after the common checks.
std::unique_ptr<Integrator> makePathTracingIntegrator(const IntegratorSettings& settings,
                                                      const DeviceScene& scene, ClRuntime& runtime);
// BDPT (src/integrators/bdpt.cpp): also validates the debug strategy (--strategy S,T).
std::unique_ptr<Integrator> makeBdptIntegrator(const IntegratorSettings& settings,
                                               const DeviceScene& scene, ClRuntime& runtime);
// CBDPT (src/integrators/cbdpt.cpp): host light subpaths, coherent eye subpaths, BDPT weights.
std::unique_ptr<Integrator> makeCbdptIntegrator(const IntegratorSettings& settings,
                                                const DeviceScene& scene, ClRuntime& runtime);

// MLT (src/integrators/mlt.cpp): validates its options (large-step probability, mutation size,
// chains) and the BDPT caps.
std::unique_ptr<Integrator> makeMltIntegrator(const IntegratorSettings& settings,
                                              const DeviceScene& scene, ClRuntime& runtime);

// The bootstrap samples an MLT render of `pixels` pixels draws: settings.mltBootstrap, or when
// that is 0, max(pixels, 65536).
long mltBootstrapSamples(const IntegratorSettings& settings, long pixels);

// Chain statistics of an MLT render, over all estimates so far.
struct MltStatistics {
    double normalization = 0;          // b: mean luminance of the image, bootstrap + large steps
    double bootstrapNormalization = 0; // b from the bootstrap alone
    double bootstrapStandardError = 0; // of bootstrapNormalization
    long bootstrapSamples = 0;
    long bootstrapNonZero = 0; // bootstrap samples with I > 0
    long chains = 0;
    long mutationsPerChain = 0; // per estimate
    long mutations = 0;         // proposals so far
    long accepted = 0;
    long largeSteps = 0;
    long largeStepsAccepted = 0;
    long zeroProposals = 0; // proposals with I = 0 (always rejected)
    double acceptanceRate() const { return mutations ? double(accepted) / double(mutations) : 0; }
};

// The statistics if `integrator` is an MLT integrator, else nullptr.
const MltStatistics* mltStatistics(const Integrator& integrator);
// One line of them, "mlt: b = ... zero proposals ...", as `cbdpt render` prints it.
std::string mltSummary(const MltStatistics& stats);

} // namespace cb
