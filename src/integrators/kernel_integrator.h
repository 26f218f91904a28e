// The host side that every integrator shares, as pbrt-v4's integrators share a base class: the
// scene's device buffers, the program built with the scene's kernel features, kernel arguments
// set in the order the kernels declare them (kernels/cb_kernel.h), the counters of dropped
// (non-finite) samples and of rays, timed launches and the ray report (CBDPT_RAY_STATS=1).
// An integrator states only its kernel file, its defines, its own arguments and buffers, and
// what it does around a launch.
#pragma once

#include "integrators/integrator.h"
#include "integrators/scene_buffers.h"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace cb {

class KernelIntegrator : public Integrator {
  public:
    // Prints the ray report when CBDPT_RAY_STATS is set and the kernels counted rays.
    ~KernelIntegrator() override;
    long nonFiniteSamples() const override { return nonFiniteTotal_; }
    double buildSeconds() const override { return buildSeconds_; }
    bool treePrefetch() const override { return treePrefetch_; }

  protected:
    // `name` prefixes the ray report ("bdpt: ... rays").
    KernelIntegrator(std::string name, const IntegratorSettings& settings, const DeviceScene& scene,
                     ClRuntime& runtime);

    // Builds kernels/`file` with the scene's feature defines and `defines`, and CB_TREE_PREFETCH:
    // 1 on CPU devices where the scene's tree is larger than the device's cache
    // (treePrefetchPays, bvh/bvh_wide.h); CBDPT_PREFETCH=0 or 1 forces it, on CPU devices only.
    void buildProgram(const std::string& file, std::vector<std::string> defines = {});
    // CB_MAX_EYE_VERTICES and CB_MAX_LIGHT_VERTICES: the bidirectional kernels size their
    // private vertex arrays by the caps, so each cap pair is its own build.
    std::vector<std::string> vertexCapDefines() const;

    // Sets the first arguments every integrator kernel takes (CB_INTEGRATOR_KERNEL_PARAMS): the
    // scene, its spectrum-to-RGB matrix, the camera, the method's settings and the sampler.
    template <typename MethodSettings>
    KernelArguments integratorArguments(cl::Kernel& kernel, const MethodSettings& method) const {
        KernelArguments args(kernel);
        buffers_.addKernelArguments(args);
        args.add(buffers_.toRgb).add(scene_.camera).add(method).add(samplerSettings(settings_));
        return args;
    }
    // Sets the counters, a kernel's last arguments (CB_COUNTER_PARAMS).
    void addCounterArguments(KernelArguments& args) const;

    // Runs `kernel` over `global` work-items in groups of `local`, waits for it and adds its time
    // to the kernel time of the ray report; the ray counter starts from zero.
    void launch(cl::Kernel& kernel, const cl::NDRange& global, const cl::NDRange& local);
    // Reads the counters after a launch: the dropped samples so far, and this launch's rays.
    void readCounters();

    size_t imageBytes() const { return 3 * sizeof(float) * pixels_; }

    const IntegratorSettings settings_;
    const DeviceScene& scene_;
    ClRuntime& runtime_;
    const size_t pixels_;
    SceneBuffers buffers_;
    cl::Program program_;

  private:
    std::string name_;
    bool countRays_ = false;
    cl::Buffer nonFinite_, rays_;
    long nonFiniteTotal_ = 0;
    long long rayTotal_ = 0;
    double kernelSeconds_ = 0.0;
    double buildSeconds_ = 0.0;
    bool treePrefetch_ = false;
};

// An integrator whose kernel computes one pixel per work-item (pt, cpt, bdpt, cbdpt): each
// estimate is one launch over square tiles of pixels into an RGB image that is read back.
class PixelKernelIntegrator : public KernelIntegrator {
  public:
    void renderEstimate(std::uint32_t estimate, std::vector<float>& rgb) final;
    std::uint32_t hostSampleStreams() const override { return sharedStreams_; }
    bool tracesPackets() const override { return perTile_; }
    int rayPacketRays() const override { return perTile_ ? rayPacketRays_ : 0; }
    // With --coherence-tile k a packet's pixels are k apart: at k = 8 its rays had spread too
    // far to pay on the dragon (CPT 0.94x PT against the per-pixel kernel's 0.87x, 256x256;
    // k <= 4 paid everywhere: docs/performance.md). Larger k also overhang the film more.
    static constexpr int kMaxPacketCoherenceTile = 4;

  protected:
    // `imageName` names the image buffer in out-of-memory errors, e.g. "BDPT".
    PixelKernelIntegrator(std::string name, const std::string& imageName,
                          const IntegratorSettings& settings, const DeviceScene& scene,
                          ClRuntime& runtime);

    // Creates kernel `kernelName` of the built program and sets its arguments: the integrator's
    // first ones, the estimate number, those `addMethodArguments(KernelArguments&)` adds, then
    // the image and the counters.
    template <typename MethodSettings, typename AddArguments>
    void createKernel(const char* kernelName, const MethodSettings& method,
                      AddArguments&& addMethodArguments) {
        kernel_ = cl::Kernel(program_, kernelName);
        KernelArguments args = integratorArguments(kernel_, method);
        estimateArgument_ = args.next();
        args.add(0u);
        addMethodArguments(args);
        args.add(image_);
        addCounterArguments(args);
    }

    // Work before the launch of an estimate and on the image after it is read back.
    virtual void beforeLaunch(std::uint32_t estimate) { (void)estimate; }
    // The coherent methods' packets (kernels/pt.cl renderCoherentPathTracing, cbdpt_packets.cl
    // renderCoherentBdpt: a work-item per tile of pixels that share one sample vector, tracing
    // their rays in packets of 4 x 2 or 4 x 4): wanted on CPU devices unless CBDPT_PACKETS=0 (to
    // measure what they buy), the tile is not a whole number of packets, or --coherence-tile is
    // above kMaxPacketCoherenceTile. A GPU needs a work-item per pixel to fill its cores.
    bool packetsWanted() const;
    // The packets' program defines: CB_RAY_PACKET, the rays per packet (cb_bvh_ray_packet.h),
    // 16 where the device's native float vectors hold 16 lanes (AVX-512 under PoCL: CPT
    // 0.93-0.94x, CBDPT 0.90-0.98x the time with packets of 8, docs/performance.md), else 8.
    // CBDPT_RAY_PACKET=8 or 16 forces a width (to measure one against the other).
    std::vector<std::string> rayPacketDefines();
    // Launches a work-item per tile of tileSize x tileSize pixels coherenceTile apart
    // (tiles()), each its own work-group, from now on, instead of a work-item per pixel:
    // larger groups only add PoCL's per-work-item copies of private values (a group of 128 x 32,
    // PoCL's choice for 512 x 512 pixels in tiles of 4, overflowed its thread's stack).
    void launchPerTile() { perTile_ = true; }
    // Tiles of tileSize x tileSize pixels `stride` apart across and down the image
    // (kernels/cb_rng.h, packetTilesAcross): the packets' with stride coherenceTile, the
    // per-pixel kernels' work-groups with stride 1.
    std::pair<size_t, size_t> tiles(int stride) const;
    // A scratch buffer of the packets' kernels: `perPixel` entries of `bytes` each for every
    // pixel of every tile (a work-item works in its tile's slice); named in out-of-memory errors.
    cl::Buffer packetScratch(const char* what, size_t perPixel, size_t bytes);
    virtual void afterReadBack(std::vector<float>& rgb) { (void)rgb; }

    // Adds the two arguments of the coherent methods' shared sample vectors (kernels/cb_rng.h,
    // samplerStreamShared): a buffer and its dimensions per stream. With `streams` > 0 the host
    // draws each estimate's `streams` eye streams (keys 0 .. streams - 1), their first
    // eyeStreamDimensions(Ne) values (in scattering media the distances' too), before each launch,
    // since every pixel at one tile position would draw the same; with 0 (PT), or where each vector
    // would serve fewer than kPixelsPerSharedStream pixels, or under CBDPT_SHARED_SAMPLES=0, the
    // kernel draws them.
    void addSharedSampleArguments(KernelArguments& args, std::uint32_t streams);
    static constexpr size_t kPixelsPerSharedStream = 64;

  private:
    std::uint32_t sharedStreams_ = 0, sharedDimensions_ = 0;
    std::vector<float> sharedSamples_;
    cl::Buffer sharedSampleBuffer_;
    cl::Buffer image_;
    cl::Kernel kernel_;
    int estimateArgument_ = 0;
    bool perTile_ = false;
    int rayPacketRays_ = 0; // rayPacketDefines()'s choice
    std::string label_;     // the method, e.g. "CPT", in buffer names
};

} // namespace cb
