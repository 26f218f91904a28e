// CBDPT's host half (docs/cbdpt.md, steps 1 and 3): per estimate, trace the few light subpaths
// with the shared kernel code (kernels/cb_bdpt.h compiled as C++) and splat their camera
// connections (t = 1). The kernel (kernels/cbdpt.cl) does the rest.
//
// The shared code's Spectrum has CB_CHANNELS floats, fixed at compile time, so the light pass
// (cbdpt_light_instance.cpp) is compiled once per host instance of the kernel code
// (src/kernel_host/kernel_instance.h). This header therefore uses no shared-header type: the
// scene comes in as raw arrays.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "scene/scene_bytes.h"

namespace cb {

struct DeviceScene;

struct CbdptLightSettings {
    std::uint32_t seed = 0;
    int sampler = 0;         // CB_SAMPLER_*, as the eye streams' (cb_rng.h)
    int eyeVertices = 4;     // Ne: the caps decide which strategies exist (MIS)
    int lightVertices = 4;   // Nl
    int maxPathVertices = 0; // N > 0: only strategies with s + t <= N (BdptSettings)
    int weights = 0;         // CB_WEIGHTS_*
    // Light subpaths per estimate: one per coherence-tile position present in the image,
    // numbered row-major over tileRows x tileColumns; subpath (i, j) uses the sample stream of
    // tile position (i, j), key i * coherenceTile + j (the same key as the eye stream there).
    int coherenceTile = 1;
    int tileRows = 1;
    int tileColumns = 1;
};

// What one estimate's light pass produces.
struct CbdptLightPass {
    // tileRows * tileColumns * lightVertices PathVertex structs, byte for byte as the kernel
    // reads them (unused slots zeroed), and the vertex count of each subpath.
    std::vector<unsigned char> vertices;
    std::vector<int> counts;
    // The t = 1 strategy, weighted and scaled (see CbdptLightTracer::trace), linear sRGB, 3
    // floats per pixel, zero except at splatPixels.
    std::vector<float> splatRgb;
    // The pixels (y * width + x) that received splats, ascending and distinct: a few per light
    // subpath, so trace clears and callers add only these instead of the whole image.
    std::vector<std::uint32_t> splatPixels;
    long nonFinite = 0; // t = 1 contributions dropped as NaN/Inf
    long rays = 0;      // extension rays of the subpaths plus camera shadow rays
};

class CbdptLightTracer {
  public:
    virtual ~CbdptLightTracer() = default;
    // sizeof(PathVertex) for this channel count.
    virtual std::size_t vertexBytes() const = 0;
    // Traces estimate `estimate`'s light subpaths and splats each light vertex seen by the
    // camera. Each splat is the BDPT t = 1 contribution (with its MIS weight) times
    // W*H / (number of light subpaths): BDPT averages W*H light subpaths per estimate, each
    // carrying importance for a pixel of 1/(W*H) of the film; with fewer subpaths each must
    // stand for W*H / count of them for the estimate to stay unbiased (docs/cbdpt.md).
    virtual void trace(std::uint32_t estimate, CbdptLightPass& out) = 0;
};

// Light subpaths per estimate / pixels: the sampling rate of the t = 1 strategy relative to
// BDPT's, which the power heuristic weighs in (Veach 1997, eq. 9.13; docs/cbdpt.md).
inline float cbdptCameraCount(int width, int height, const CbdptLightSettings& settings) {
    return float(double(settings.tileRows) * settings.tileColumns / (double(width) * height));
}

// Picks the instantiation matching scene.channels (3 or 16); throws std::invalid_argument for
// any other channel count.
std::unique_ptr<CbdptLightTracer> makeCbdptLightTracer(const DeviceScene& scene,
                                                       const CbdptLightSettings& settings);

// The light pass of the host instance with real = Real and Spectrum = Channels floats, one per
// instance that compiles cbdpt_light_instance.cpp (src/kernel_host/kernel_host.cmake).
template <typename Real, int Channels>
std::unique_ptr<CbdptLightTracer> makeCbdptLightTracerFor(const SceneBytes& scene,
                                                          const CbdptLightSettings& settings);
template <>
std::unique_ptr<CbdptLightTracer> makeCbdptLightTracerFor<float, 3>(const SceneBytes& scene,
                                                                    const CbdptLightSettings& s);
template <>
std::unique_ptr<CbdptLightTracer> makeCbdptLightTracerFor<float, 16>(const SceneBytes& scene,
                                                                     const CbdptLightSettings& s);
template <>
std::unique_ptr<CbdptLightTracer> makeCbdptLightTracerFor<double, 3>(const SceneBytes& scene,
                                                                     const CbdptLightSettings& s);

} // namespace cb
