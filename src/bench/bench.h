// cbdpt-bench's common parts: the options, timing helpers, the test meshes and rays, and the
// sections (one file each: bench_traverse.cpp, bench_build.cpp, bench_render.cpp,
// bench_scaling.cpp, bench_accumulate.cpp), each returning its part of the JSON that bench_main.cpp
// writes.
#pragma once

#include "bench/bench_meshes.h"
#include "integrators/integrator.h"

#include "cb_types.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <string>
#include <vector>

namespace cb {
class ClRuntime;
struct DeviceScene;
} // namespace cb

namespace cb::bench {

using json = nlohmann::json;

struct Options {
    bool quick = false;
    std::string json;
    std::string models;
    std::vector<std::string> sections{"traverse", "build", "render", "scaling", "accumulate"};
    std::string traversal = "wide,ordered"; // comma-separated ordered, skip, wide; or both
    std::string prefetch = "auto";          // the wide BVH: auto (the renderers' rule), on, off
    int repeats = 0;                        // 0: 5 (2 in --quick)
    int localSize = 64;                     // 0: let PoCL choose
    int leafSize = 4;
    int sahBlock = 0; // SAH cost per block of this many primitives; 0: as the renderers / 1
    long rays = 0;    // 0: 1M (64k in --quick)
    int threads = 2;
    bool host = false;               // also time the host (g++) build of the traversal
    std::vector<std::string> meshes; // default per mode
    // traverse: which ray sets to time (shadow rays and bounces start at the primary hits, so
    // primary rays are traced for them either way).
    std::vector<std::string> cases{"primary", "incoherent", "shadow",    "incoh-any",
                                   "bounce1", "bounce2",    "coh-shadow"};
    std::string device;
    // Internal: measure one program build in this process (run by the build section).
    std::vector<std::string> childBuild;
    std::vector<std::string> childRender;
};

// ---- Timing and helpers (bench_common.cpp) ---------------------------------------------------

using Clock = std::chrono::steady_clock;
inline double secondsSince(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}
// CPU seconds of the whole process (all threads: PoCL's workers, Embree's std::threads). With
// other jobs on the machine, wall time includes waiting for a core; CPU time is much steadier.
double processCpuSeconds();
double median(std::vector<double> v);
std::vector<std::string> splitCommas(const std::string& v);
// `file` in --models, CBDPT_MODEL_PATH or the shared models folder; "" when absent.
std::string findModel(const Options& o, const std::string& file);
// --meshes (or the mode's default): Stanford models found by findModel, sphere-<n>[k|M]
// generated; a missing model is skipped with a warning.
std::vector<BenchMesh> loadMeshes(const Options& o);
// This executable, for the sections that time in child processes.
std::string selfPath();

// ---- Rays (bench_rays.cpp) -------------------------------------------------------------------

struct Box3 {
    cbk::Vec3 lo, hi;
};
Box3 meshBounds(const PlyMesh& m);
// Primary rays of a pinhole camera looking at the mesh from the front (+z, a little above),
// one per pixel of a side x side image, ordered by 8x8 tiles so that a work-group (and an
// Embree thread's range) holds neighbouring pixels, as in the renderers.
std::vector<cbk::Ray> primaryRays(const Box3& b, long count);
std::vector<cbk::Ray> incoherentRays(const Box3& b, long count, unsigned seed);
// Shadow rays from the primary hit points (pulled back along the primary ray by 1e-4 of the
// mesh size, so both tracers agree on what the origin is) to points on a square light above
// the mesh; primary misses start at a random point of the box instead.
void shadowRays(const Box3& b, const std::vector<cbk::Ray>& primary,
                const std::vector<cbk::Hit>& hits, unsigned seed, std::vector<cbk::Ray>& rays,
                std::vector<float>& tMax);
// The coherent rays of one CPT estimate, in which every pixel follows one shared sample
// vector: each path of `rays` (inactive where tMax[i] <= 0, or null for all active) that hit
// (`hits`, primitives indexing `prims`) scatters with the same cosine-distributed direction
// sample (u0, u1) about its hit's geometric normal, turned to the side the ray came from; the
// origin is moved off the surface by 1e-4 of the mesh size along that normal. Paths that ended
// give inactive rays (tMax 0), so the set keeps the pixel order of `rays` (one per pixel).
void coherentBounce(const Box3& b, const std::vector<cbk::Primitive>& prims,
                    const std::vector<cbk::Ray>& rays, const std::vector<float>* tMax,
                    const std::vector<cbk::Hit>& hits, float u0, float u1,
                    std::vector<cbk::Ray>& out, std::vector<float>& outTMax);
// CPT's shadow rays at the primary hits: all to one point of the square light above the mesh
// (the estimate's shared light sample); pixels whose camera ray missed are inactive (tMax 0).
void coherentShadowRays(const Box3& b, const std::vector<cbk::Ray>& primary,
                        const std::vector<cbk::Hit>& hits, std::vector<cbk::Ray>& rays,
                        std::vector<float>& tMax);
// Embree's packets over rays in primaryRays' order (8x8 tiles, row by row): `width` ray
// indices per packet, 2x4 pixel blocks for 8, 4x4 for 16.
std::vector<int> tilePackets(size_t count, int width);
// About a thousand of the camera rays, spread over the image: what the wide BVH's build
// samples to choose its settings, as DeviceScene does with the scene's camera.
std::vector<cbk::Ray> cameraSample(const std::vector<cbk::Ray>& primary);

// ---- Renders (bench_render.cpp), shared with the scaling section -----------------------------

struct RenderTiming {
    double perEstimate = 0.0; // median seconds
    double buildSeconds = 0.0;
    int pixels = 0;
};
// Median time of `estimates` estimates after one untimed warm-up estimate.
RenderTiming timeIntegrator(ClRuntime& rt, const DeviceScene& scene, const IntegratorSettings& s,
                            int estimates);
std::string scenePath(const std::string& name);

// ---- The sections ----------------------------------------------------------------------------

json runTraverse(const Options& o, ClRuntime& rt);
json runBuild(const Options& o);
json runRender(const Options& o);
json runScaling(const Options& o, ClRuntime& rt);
json runAccumulate(const Options& o);
// Child processes: build one program (--child-build), time one integrator (--child-render).
int childBuild(const Options& o);
int childRender(const Options& o);

} // namespace cb::bench
