// Picks the host instance of the kernel code (src/kernel_host/kernel_instance.h) for a precision.
#include "float64/host_kernels.h"

namespace cb::float64 {

std::unique_ptr<HostKernels> makeHostKernels(const SceneBytes& scene, Precision precision) {
    if (precision == Precision::Float) return makeHostKernelsFor<float>(scene);
    return makeHostKernelsFor<double>(scene);
}

std::unique_ptr<CbdptLightTracer> makeHostLightTracer(const SceneBytes& scene,
                                                      const CbdptLightSettings& settings,
                                                      Precision precision) {
    if (precision == Precision::Float) return makeCbdptLightTracerFor<float, 3>(scene, settings);
    return makeCbdptLightTracerFor<double, 3>(scene, settings);
}

} // namespace cb::float64
