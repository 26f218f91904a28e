// CBDPT host light pass for RGB scenes: the shared kernel code with the host's default
// CB_CHANNELS (3), i.e. the same `cbk` instantiation every other host file uses.
#include "integrators/cbdpt_light.h"

#include "cb_bdpt.h"

#include <algorithm>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

static_assert(CB_CHANNELS == 3, "cbdpt_light_rgb.cpp must see the 3-channel shared headers");

namespace cb {
namespace cbdpt_rgb {
namespace device = cbk; // the arrays are in this instantiation's own layout
#include "scene/host_scene.inc"
// needs HostScene, so after host_scene.inc
#include "integrators/cbdpt_light.inc"
} // namespace cbdpt_rgb

std::unique_ptr<CbdptLightTracer> makeCbdptLightTracerRgb(const SceneBytes& scene,
                                                          const CbdptLightSettings& settings) {
    return std::make_unique<cbdpt_rgb::LightTracer>(scene, settings);
}

} // namespace cb
