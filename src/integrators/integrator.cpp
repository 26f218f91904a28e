#include "integrators/integrator.h"

#include <algorithm>
#include <fmt/format.h>
#include <stdexcept>

namespace cb {

cbk::SamplerSettings samplerSettings(const IntegratorSettings& settings) {
    cbk::SamplerSettings sampler{};
    sampler.seed = settings.seed;
    if (settings.sampler == "independent")
        sampler.kind = CB_SAMPLER_INDEPENDENT;
    else if (settings.sampler == "sobol")
        sampler.kind = CB_SAMPLER_SOBOL;
    else
        throw std::invalid_argument(
            fmt::format("unknown --sampler '{}' (independent or sobol)", settings.sampler));
    return sampler;
}

IntegratorSettings withResolvedCaps(const IntegratorSettings& settings) {
    IntegratorSettings resolved = settings;
    if (settings.maxPathVertices > 0) {
        resolved.eyeVertices = settings.maxPathVertices;
        resolved.lightVertices = std::max(1, settings.maxPathVertices - 1);
    }
    return resolved;
}

std::unique_ptr<Integrator> makeIntegrator(const IntegratorSettings& requested,
                                           const DeviceScene& scene, ClRuntime& runtime) {
    (void)scene;
    // Caps are checked before anything is allocated or compiled.
    if (requested.maxPathVertices < 0 || requested.maxPathVertices == 1 ||
        requested.maxPathVertices > 1024)
        throw std::invalid_argument(fmt::format(
            "--max-vertices {} is out of range: 0 (off: the per-subpath caps) or 2 (emitters seen "
            "directly) to 1024 vertices, the camera and the light point included",
            requested.maxPathVertices));
    const IntegratorSettings settings = withResolvedCaps(requested);
    if (settings.eyeVertices < 2 || settings.eyeVertices > 1024)
        throw std::invalid_argument(fmt::format(
            "--eye-vertices {} is out of range: it counts the camera, so 2 (emitters seen "
            "directly) to 1024",
            settings.eyeVertices));
    if (settings.lightVertices < 1 || settings.lightVertices > 1024)
        throw std::invalid_argument(fmt::format(
            "--light-vertices {} is out of range: it counts the point on the light, so 1 to 1024",
            settings.lightVertices));
    if (settings.rouletteVertex < 0)
        throw std::invalid_argument("--rr-vertex must be >= 0 (0 disables Russian roulette)");
    if (settings.tileSize < 1 || settings.tileSize > 32)
        throw std::invalid_argument("--tile must be between 1 and 32 pixels");
    if (settings.coherenceTile < 1 || settings.coherenceTile > 4096)
        throw std::invalid_argument("--coherence-tile must be between 1 and 4096");
    if (settings.weights != "power" && settings.weights != "lafortune")
        throw std::invalid_argument(
            fmt::format("unknown --weights '{}' (power or lafortune)", settings.weights));
    (void)samplerSettings(settings); // validates the name; mlt's chains choose their own samples
    if (settings.name == "pt" || settings.name == "cpt")
        return makePathTracingIntegrator(settings, scene, runtime);
    // The bidirectional methods keep whole subpaths in each work-item's private memory.
    if ((settings.name == "bdpt" || settings.name == "cbdpt" || settings.name == "mlt") &&
        (settings.eyeVertices > 64 || settings.lightVertices > 64))
        throw std::invalid_argument(fmt::format(
            "{} keeps whole subpaths per work-item: --eye-vertices {} / --light-vertices {} "
            "(--max-vertices N sets them to N and N - 1) must be at most 64",
            settings.name, settings.eyeVertices, settings.lightVertices));
    if (settings.name == "bdpt") return makeBdptIntegrator(settings, scene, runtime);
    if (settings.name == "cbdpt") return makeCbdptIntegrator(settings, scene, runtime);
    if (settings.name == "mlt") return makeMltIntegrator(settings, scene, runtime);
    throw std::invalid_argument(fmt::format(
        "unknown integrator '{}' (available: pt, cpt, bdpt, cbdpt, mlt)", settings.name));
}

} // namespace cb
