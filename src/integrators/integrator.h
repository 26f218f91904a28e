// Integrators compute one estimate (one sample per pixel) of the image at a time; the driver
// (render.h) accumulates estimates, reports progress and writes output.
#pragma once

#include "cl/cl_runtime.h"
#include "scene/device_scene.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace cb {

struct IntegratorSettings {
    std::string name = "pt";  // pt | cpt | bdpt | cbdpt | mlt
    int eyeVertices = 8;      // Ne, the camera included (thesis convention)
    int lightVertices = 4;    // Nl, the point on the light included (bidirectional methods)
    std::string weights = "power"; // bidirectional MIS: power | lafortune
    int debugS = -1;          // >= 0 with debugT: render only strategy (s, t), unweighted
    int debugT = -1;
    int rouletteVertex = 3;   // Russian roulette from this vertex on; 0 disables it
    std::uint32_t seed = 0;
    int coherenceTile = 1;    // cpt: k x k distinct sample vectors per estimate
    int tileSize = 8;         // pixel tile (work-group) edge
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
};

// Validates the settings against the scene (caps, names) and builds the kernels.
std::unique_ptr<Integrator> makeIntegrator(const IntegratorSettings& settings,
                                           const DeviceScene& scene, ClRuntime& runtime);

// Per-method constructors, called by makeIntegrator after the common checks.
std::unique_ptr<Integrator> makePathTracingIntegrator(const IntegratorSettings& settings,
                                                      const DeviceScene& scene, ClRuntime& runtime);
// BDPT (src/integrators/bdpt.cpp): also validates the debug strategy (--strategy S,T).
std::unique_ptr<Integrator> makeBdptIntegrator(const IntegratorSettings& settings,
                                               const DeviceScene& scene, ClRuntime& runtime);

} // namespace cb
