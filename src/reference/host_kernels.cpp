// Two host instantiations of the shared kernel code (all of it: cb_bdpt.h and cb_pt.h) in one
// translation unit: real = float in namespace f32 and real = double in namespace f64. The headers
// are included twice, so their include guards are reset in between; nothing else in the program
// sees these namespaces (the rest of the host uses the global `cbk` instantiation), so there is no
// ODR conflict.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "integrators/cbdpt_light.h"
#include "reference/host_kernels.h"
#include "scene/scene_bytes.h"

#ifdef CB_COMMON_H
#error "host_kernels.cpp must be the only place that includes the shared headers"
#endif

#define CB_REAL float
namespace cb::reference::f32 {
#include "cb_bdpt.h"
#include "cb_pt.h"
namespace device = cbk;
#include "scene/host_scene.inc"
// these need HostScene
#include "reference/host_kernels.inc"
} // namespace cb::reference::f32
#undef CB_REAL

// Every include guard of the shared headers included above.
#undef CB_COMMON_H
#undef CB_TYPES_H
#undef CB_SPECTRUM_H
#undef CB_RNG_H
#undef CB_SAMPLING_H
#undef CB_BSDF_H
#undef CB_INTERSECT_H
#undef CB_BVH_H
#undef CB_BVH_WIDE_H
#undef CB_CAMERA_H
#undef CB_LIGHTS_H
#undef CB_PT_H
#undef CB_BDPT_H

#define CB_REAL double
namespace cb::reference::f64 {
#include "cb_bdpt.h"
#include "cb_pt.h"
static_assert(sizeof(cbk::real) == sizeof(double), "the f64 instantiation must compute in double");
namespace device = ::cb::reference::f32::cbk; // the device's float layout
#include "scene/host_scene.inc"
// these need HostScene
#include "integrators/cbdpt_light.inc"
#include "reference/host_kernels.inc"
} // namespace cb::reference::f64
#undef CB_REAL

namespace cb::reference {

std::unique_ptr<HostKernels> makeHostKernels(const SceneBytes& scene, Precision precision) {
    if (precision == Precision::Float) return std::make_unique<f32::Instance>(scene, precision);
    return std::make_unique<f64::Instance>(scene, precision);
}

std::unique_ptr<CbdptLightTracer> makeHostLightTracer(const SceneBytes& scene,
                                                      const CbdptLightSettings& settings,
                                                      Precision precision) {
    if (precision == Precision::Float) return makeCbdptLightTracerRgb(scene, settings);
    return std::make_unique<f64::LightTracer>(scene, settings);
}

} // namespace cb::reference
