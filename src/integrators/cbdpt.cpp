// CBDPT (docs/method.md, CBDPT; docs/cbdpt.md): per estimate the host traces the light subpaths
// (one per coherence-tile position, cbdpt_light.h) and splats their t = 1 connections; the
// combination kernel (kernels/cbdpt.cl) gives every pixel a coherent eye subpath and connects
// it to its tile position's light subpath with the BDPT weights.
#include "integrators/bdpt_settings.h"
#include "integrators/cbdpt_light.h"
#include "integrators/kernel_integrator.h"

#include "cb_bdpt.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fmt/format.h>
#include <stdexcept>

namespace cb {

static_assert(sizeof(cbk::CbdptWalk) == CB_CBDPT_WALK_BYTES(CB_CHANNELS),
              "CB_CBDPT_WALK_BYTES is CbdptWalk's size");

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

class CbdptIntegrator final : public PixelKernelIntegrator {
  public:
    CbdptIntegrator(const IntegratorSettings& settings, const DeviceScene& scene,
                    ClRuntime& runtime)
        : PixelKernelIntegrator("cbdpt", "CBDPT", settings, scene, runtime) {
        const int k = settings.coherenceTile;
        light_.seed = settings.seed;
        light_.sampler = samplerSettings(settings).kind;
        light_.eyeVertices = settings.eyeVertices;
        light_.lightVertices = settings.lightVertices;
        light_.maxPathVertices = settings.maxPathVertices;
        light_.weights = bdptSettingsFor(settings).weights;
        light_.coherenceTile = k;
        light_.tileRows = std::min(k, scene.camera.height);
        light_.tileColumns = std::min(k, scene.camera.width);
        tracer_ = makeCbdptLightTracer(scene, light_);
        subpaths_ = size_t(light_.tileRows) * size_t(light_.tileColumns);

        vertexBufferBytes_ = subpaths_ * size_t(settings.lightVertices) * tracer_->vertexBytes();
        lightVertices_ = runtime.createBuffer(
            "CBDPT light subpaths (coherence tile^2 x --light-vertices vertices)", CL_MEM_READ_ONLY,
            vertexBufferBytes_);
        lightCounts_ = cl::Buffer(runtime.context(), CL_MEM_READ_ONLY, sizeof(int) * subpaths_);
        const bool packets = packetsWanted();
        std::vector<std::string> defines = vertexCapDefines();
        if (packets) {
            const std::vector<std::string> packetDefines = rayPacketDefines();
            defines.insert(defines.end(), packetDefines.begin(), packetDefines.end());
        }
        buildProgram(packets ? "cbdpt_packets.cl" : "cbdpt.cl", defines);
        if (packets) {
            // Per pixel (cbdpt_packets.cl): its eye walk (Ne vertices) and one entry for each
            // strategy (t, s), t = 2 .. Ne, s = 0 .. Nl.
            const size_t eyeVertices = size_t(settings.eyeVertices);
            const size_t strategies = (eyeVertices - 1) * size_t(settings.lightVertices + 1);
            eyes_ = packetScratch("eye vertices", eyeVertices, tracer_->vertexBytes());
            walks_ = packetScratch("eye walks", 1, CB_CBDPT_WALK_BYTES(size_t(scene.channels)));
            rays_ = packetScratch("eye rays", 1, sizeof(cbk::Ray));
            tMaxes_ = packetScratch("eye ray ends", 1, sizeof(float));
            hits_ = packetScratch("eye hits", 1, sizeof(cbk::Hit));
            terms_ =
                packetScratch("contributions", strategies, sizeof(float) * size_t(scene.channels));
            shadowRays_ = packetScratch("shadow rays", strategies, sizeof(cbk::Ray));
            shadowTMaxes_ = packetScratch("shadow ray ends", strategies, sizeof(float));
            occluded_ = packetScratch("occlusion", strategies, sizeof(int));
        }
        createKernel(packets ? "renderCoherentBdpt" : "renderCbdpt", bdptSettingsFor(settings),
                     [&](KernelArguments& args) {
                         args.add(k).add(light_.tileColumns).add(lightVertices_).add(lightCounts_);
                         args.add(settings.lightVertices);
                         args.add(
                             cbdptCameraCount(scene.camera.width, scene.camera.height, light_));
                         addSharedSampleArguments(args, std::uint32_t(k) * std::uint32_t(k));
                         if (packets)
                             args.add(settings.tileSize)
                                 .add(eyes_)
                                 .add(walks_)
                                 .add(rays_)
                                 .add(tMaxes_)
                                 .add(hits_)
                                 .add(terms_)
                                 .add(shadowRays_)
                                 .add(shadowTMaxes_)
                                 .add(occluded_);
                     });
        if (packets) launchPerTile();
    }

    ~CbdptIntegrator() override {
        if (std::getenv("CBDPT_RAY_STATS") && hostRays_ > 0)
            fmt::print(stderr, "cbdpt: host light pass {} rays in {:.3f} s\n", hostRays_,
                       hostSeconds_);
    }

    long nonFiniteSamples() const override {
        return PixelKernelIntegrator::nonFiniteSamples() + hostNonFinite_;
    }

  private:
    // The estimate's light subpaths, traced on the host and copied to the device.
    void beforeLaunch(std::uint32_t estimate) override {
        auto start = std::chrono::steady_clock::now();
        tracer_->trace(estimate, pass_);
        hostSeconds_ +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        hostRays_ += pass_.rays;
        hostNonFinite_ += pass_.nonFinite;
        auto& queue = runtime_.queue();
        queue.enqueueWriteBuffer(lightVertices_, CL_FALSE, 0, vertexBufferBytes_,
                                 pass_.vertices.data());
        queue.enqueueWriteBuffer(lightCounts_, CL_FALSE, 0, sizeof(int) * subpaths_,
                                 pass_.counts.data());
    }
    // Their camera connections (t = 1), splatted on the host.
    void afterReadBack(std::vector<float>& rgb) override {
        for (std::uint32_t p : pass_.splatPixels)
            for (size_t c = 3 * size_t(p); c < 3 * size_t(p) + 3; ++c)
                rgb[c] += pass_.splatRgb[c];
    }

    CbdptLightSettings light_;
    std::unique_ptr<CbdptLightTracer> tracer_;
    CbdptLightPass pass_;
    cl::Buffer lightVertices_, lightCounts_;
    // The packets' scratch (cbdpt_packets.cl).
    cl::Buffer eyes_, walks_, rays_, tMaxes_, hits_, terms_, shadowRays_, shadowTMaxes_, occluded_;
    size_t subpaths_ = 1, vertexBufferBytes_ = 0;
    long hostNonFinite_ = 0;
    long long hostRays_ = 0;
    double hostSeconds_ = 0.0;
};

} // namespace

std::unique_ptr<Integrator> makeCbdptIntegrator(const IntegratorSettings& settings,
                                                const DeviceScene& scene, ClRuntime& runtime) {
    if (settings.debugS >= 0 || settings.debugT >= 0)
        throw std::invalid_argument("--strategy is a bdpt debug mode; cbdpt does not take it");
    return std::make_unique<CbdptIntegrator>(settings, scene, runtime);
}

} // namespace cb
