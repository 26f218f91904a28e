// PT and CPT (kernels/pt.cl): one path code; CPT differs in who shares the sample vector, and
// traces its coherent rays as packets.
#include "integrators/kernel_integrator.h"

#include "cb_pt.h"

#include <fmt/format.h>

#include <cstdlib>
#include <stdexcept>
#include <string>

namespace cb {

namespace {

static_assert(sizeof(cbk::PtPath) == CB_PT_PATH_BYTES(CB_CHANNELS, true),
              "CB_PT_PATH_BYTES is PtPath's size");

cbk::PathSettings pathSettingsFor(const IntegratorSettings& settings) {
    cbk::PathSettings path{};
    path.eyeVertices = settings.eyeVertices;
    path.rouletteVertex = settings.rouletteVertex;
    return path;
}

// PT and CPT. CPT's coherent rays are traced as packets (pt.cl, renderCoherentPathTracing)
// when packetsWanted().
class PathTracingIntegrator final : public PixelKernelIntegrator {
  public:
    PathTracingIntegrator(const IntegratorSettings& settings, const DeviceScene& scene,
                          ClRuntime& runtime)
        : PixelKernelIntegrator(settings.name, "path-tracing", settings, scene, runtime) {
        const bool packets = settings.name == "cpt" && packetsWanted();
        buildProgram("pt.cl", packets ? rayPacketDefines() : std::vector<std::string>{});
        // The sample-vector tile: 0 for PT (every pixel its own), k for CPT's k x k.
        const int streamTile = settings.name == "cpt" ? settings.coherenceTile : 0;
        const std::uint32_t sharedStreams = std::uint32_t(streamTile * streamTile);
        if (!packets) {
            createKernel("renderPathTracing", pathSettingsFor(settings),
                         [&](KernelArguments& args) {
                             args.add(streamTile);
                             addSharedSampleArguments(args, sharedStreams);
                         });
            return;
        }
        // A work-item per tile of pixels, one entry per pixel.
        // The kernel's PtPath: its medium's track only where the scene scatters or has interfaces.
        const bool tracked = (scene.features & (CB_FEATURE_SCATTERING | CB_FEATURE_INTERFACE)) != 0;
        paths_ = packetScratch("paths", 1, CB_PT_PATH_BYTES(scene.channels, tracked));
        rays_ = packetScratch("rays", 1, sizeof(cbk::Ray));
        tMaxes_ = packetScratch("ray ends", 1, sizeof(float));
        hits_ = packetScratch("hits", 1, sizeof(cbk::Hit));
        shadowRays_ = packetScratch("shadow rays", 1, sizeof(cbk::Ray));
        shadowTMaxes_ = packetScratch("shadow ray ends", 1, sizeof(float));
        occluded_ = packetScratch("occlusion", 1, sizeof(int));
        createKernel("renderCoherentPathTracing", pathSettingsFor(settings),
                     [&](KernelArguments& args) {
                         args.add(streamTile);
                         addSharedSampleArguments(args, sharedStreams);
                         args.add(settings.tileSize).add(paths_).add(rays_).add(tMaxes_);
                         args.add(hits_).add(shadowRays_).add(shadowTMaxes_).add(occluded_);
                     });
        launchPerTile();
    }

  private:
    cl::Buffer paths_, rays_, tMaxes_, hits_, shadowRays_, shadowTMaxes_, occluded_;
};

} // namespace

std::unique_ptr<Integrator> makePathTracingIntegrator(const IntegratorSettings& settings,
                                                      const DeviceScene& scene,
                                                      ClRuntime& runtime) {
    if (settings.debugS >= 0 || settings.debugT >= 0)
        throw std::invalid_argument(
            fmt::format("--strategy is a bdpt debug mode; {} does not take it", settings.name));
    return std::make_unique<PathTracingIntegrator>(settings, scene, runtime);
}

} // namespace cb
