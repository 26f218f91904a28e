// CBDPT host light pass for spectral scenes: a second host instantiation of the shared kernel
// code with CB_CHANNELS = 16, the channel count the kernels are built with for spectral scenes.
//
// Every other host file sees `cbk::Spectrum` with 3 channels. To keep the two instantiations
// from colliding (the One Definition Rule: same names, different bodies), this file includes
// the shared headers inside its own namespace, so everything they declare becomes
// cb::cbdpt_spectral::cbk::..., and it must not include any header that pulls in the shared
// headers at global scope (device_scene.h does): the scene arrives as raw bytes
// (SceneBytes). The standard headers the shared code uses are included first, at global
// scope, so that their include guards keep them out of the namespace.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "integrators/cbdpt_light.h"

#ifdef CB_COMMON_H
#error "cbdpt_light_spectral.cpp must be the only place that includes the shared headers"
#endif
#define CB_CHANNELS 16

namespace cb {
namespace cbdpt_spectral {
#include "cb_bdpt.h"
namespace device = cbk; // the arrays are in this instantiation's own layout
#include "scene/host_scene.inc"
// needs HostScene, so after host_scene.inc
#include "integrators/cbdpt_light.inc"
} // namespace cbdpt_spectral

std::unique_ptr<CbdptLightTracer> makeCbdptLightTracerSpectral(const SceneBytes& scene,
                                                               const CbdptLightSettings& settings) {
    return std::make_unique<cbdpt_spectral::LightTracer>(scene, settings);
}

} // namespace cb
