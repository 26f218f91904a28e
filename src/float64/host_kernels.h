// The float64 check: the shared kernel code (kernels/cb_*.h) run on the host in double
// precision, against the float kernels.
//
// The double build is the oracle: the same source as the OpenCL kernels, compiled by g++ with
// `real` = double, on the same scene arrays widened exactly from the device's floats. Where the
// float kernels and this build disagree, the cause is float arithmetic in our code, not a second
// implementation. The float build (g++, real = float) separates PoCL's code generation from the
// arithmetic itself. Both are host instances of the kernel code (src/kernel_host/).
//
// Error bounds used for spawning rays stay float-sized in both builds (CB_MACHINE_EPSILON), so
// that both trace the same paths; only the arithmetic along them differs.
#pragma once

#include "integrators/cbdpt_light.h"
#include "scene/scene_bytes.h"

#include <array>
#include <cstdint>
#include <memory>

namespace cb::float64 {

enum class Precision { Float, Double };

struct RayQuery {
    std::array<double, 3> origin{};
    std::array<double, 3> direction{}; // need not be unit length
    double tMax = 3.402823466e+38;
};

struct RayHit {
    bool hit = false;
    int primitive = -1; // index into the device's (leaf-ordered) primitive array
    double t = 0;
    double b1 = 0, b2 = 0;
};

// What renderPathTracing (kernels/pt.cl) is given besides the scene.
struct PtPixelSettings {
    int eyeVertices = 8;
    int rouletteVertex = 3; // <= 0: no Russian roulette
    std::uint32_t seed = 0;
    int sampler = 1; // CB_SAMPLER_*: Sobol, as the integrators' default
    std::uint32_t estimate = 0;
    int streamTile = 0; // 0: PT; k > 0: CPT with k x k shared sample vectors
};

struct BsdfValue {
    double f = 0, pdfFwd = 0, pdfRev = 0;
};

class HostKernels {
  public:
    virtual ~HostKernels() = default;
    virtual Precision precision() const = 0;
    // The ray through raster position (x, y), as cameraGenerateRay computes it in this
    // precision.
    virtual RayQuery cameraRay(double rasterX, double rasterY) const = 0;
    // The origin and direction are rounded to this precision first.
    virtual RayHit closestHit(const RayQuery& ray) const = 0;
    virtual bool occluded(const RayQuery& ray) const = 0;
    // One PT/CPT sample of pixel (x, y) in linear sRGB (ptPixelRgb in kernels/cb_pt.h), not
    // filtered for non-finite values.
    virtual std::array<double, 3> ptPixel(int x, int y, const PtPixelSettings& settings) const = 0;
    // bsdfEval (kernels/cb_bsdf.h) of `material` at a surface of normal n, directions rounded
    // to this precision; the reflectance's first channel and both densities.
    virtual BsdfValue bsdf(int material, const std::array<double, 3>& n,
                           const std::array<double, 3>& wo, const std::array<double, 3>& wi,
                           int adjoint) const = 0;
};

// Copies the scene (3 channels only: the host builds have CB_CHANNELS == 3); throws
// std::invalid_argument for spectral scenes.
std::unique_ptr<HostKernels> makeHostKernels(const SceneBytes& scene, Precision precision);

// The instance with real = Real (src/float64/host_kernels_instance.cpp).
template <typename Real> std::unique_ptr<HostKernels> makeHostKernelsFor(const SceneBytes& scene);
template <> std::unique_ptr<HostKernels> makeHostKernelsFor<float>(const SceneBytes& scene);
template <> std::unique_ptr<HostKernels> makeHostKernelsFor<double>(const SceneBytes& scene);

// CBDPT's host light pass (src/integrators/cbdpt_light_instance.cpp: light subpaths, their t = 1
// camera connections and MIS weights) in this precision; RGB scenes only. Float: the one `cbdpt`
// renders RGB scenes with.
std::unique_ptr<CbdptLightTracer> makeHostLightTracer(const SceneBytes& scene,
                                                      const CbdptLightSettings& settings,
                                                      Precision precision);

} // namespace cb::float64
