// OpenCL runtime: device choice, program build from the embedded kernel sources with per-scene
// feature defines, and clear errors (missing platform, build log on failure).
#pragma once

#define CL_HPP_TARGET_OPENCL_VERSION 120
#define CL_HPP_MINIMUM_OPENCL_VERSION 120
#define CL_HPP_ENABLE_EXCEPTIONS
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wignored-attributes"
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
#endif
#include <CL/opencl.hpp>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#include <atomic>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace cb {

class ClError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

// Human-readable name of an OpenCL status code, e.g. "CL_OUT_OF_RESOURCES".
const char* clStatusName(int status);

struct ClDeviceInfo {
    int platformIndex = 0;
    int deviceIndex = 0;
    std::string platformName;
    std::string deviceName;
    std::string deviceVersion;
    std::string driverVersion;
    unsigned computeUnits = 0;
    unsigned long long globalMemoryBytes = 0;
    unsigned long long maxAllocationBytes = 0;
    // CL_DEVICE_GLOBAL_MEM_CACHE_SIZE (PoCL: the CPU's last-level cache), 0 if none.
    unsigned long long globalCacheBytes = 0;
    bool cpu = false; // CL_DEVICE_TYPE_CPU: it reads host memory in place
    bool gpu = false; // CL_DEVICE_TYPE_GPU
    // CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT: floats per native vector register (PoCL: 16 with
    // AVX-512, 8 with AVX2), which sizes the coherent methods' ray packets.
    unsigned nativeFloatWidth = 0;
    bool pocl() const; // the Portable Computing Language platform
};

// Refuses, before anything is allocated, a device buffer of `bytes` that is larger than the
// device's largest allocation (CL_DEVICE_MAX_MEM_ALLOC_SIZE) or that, with `liveBytes` already
// allocated, exceeds its global memory (CL_DEVICE_GLOBAL_MEM_SIZE): throws ClError naming
// `what`, its size and the limit, and what to reduce. Some OpenCL implementations (PoCL)
// allocate lazily, so without this the failure would come at the first kernel launch, naming
// no buffer.
void checkDeviceAllocation(const ClDeviceInfo& device, const std::string& what,
                           unsigned long long bytes, unsigned long long liveBytes);

// Every device of every platform. Throws ClError with install instructions when no platform
// exists.
std::vector<ClDeviceInfo> listClDevices();

// The device that `selector` names among `devices`: "P:D" (platform and device indices, as
// `cbdpt info` lists them), "P" (the first device of platform P), "cpu" or "gpu" (the first
// device of that type; PoCL's first among CPU devices), or "" for the default, PoCL's CPU device
// (else the first CPU device, else the first device), since the kernels are written and tuned
// for it. Throws ClError naming the selector and the devices there are.
const ClDeviceInfo& chooseClDevice(const std::vector<ClDeviceInfo>& devices,
                                   const std::string& selector);

// The selector in effect: `option` when given, else the environment variable CBDPT_DEVICE, else
// "" (the default device).
std::string deviceSelector(const std::string& option);

// Limits PoCL's CPU device to `threads` worker threads (POCL_MAX_PTHREAD_COUNT, and
// POCL_CPU_MAX_CU_NUM for newer PoCL releases; the device reports them as its compute units).
// PoCL reads them when the first OpenCL call loads it, so call this before any.
void limitPoclThreads(int threads);

// The device is chosen by chooseClDevice(listClDevices(), deviceSelector(selector)).
class ClRuntime {
  public:
    explicit ClRuntime(const std::string& selector = "");

    const ClDeviceInfo& info() const { return info_; }
    cl::Context& context() { return context_; }
    cl::Device& device() { return device_; }
    cl::CommandQueue& queue() { return queue_; }

    // Build `mainFile` (a name in kernels/, e.g. "pt.cl") with its #includes resolved from the
    // embedded sources (each starting with a #line directive). Throws ClError holding the
    // build log on failure. Records the build time in lastBuildSeconds().
    cl::Program buildProgram(const std::string& mainFile, const std::vector<std::string>& defines);
    double lastBuildSeconds() const { return lastBuildSeconds_; }

    // A device buffer checked by checkDeviceAllocation against the bytes of the buffers made
    // here that are still alive. `what` names it in the error, e.g. "BDPT image (W x H RGB)".
    cl::Buffer createBuffer(const std::string& what, cl_mem_flags flags, size_t bytes,
                            void* host = nullptr);
    unsigned long long liveBufferBytes() const { return *liveBytes_; }

    // A read-only device copy of `bytes` at `data`, through createBuffer. On a CPU device a
    // copy of kHugePageBytes or more goes to host memory advised onto transparent huge pages,
    // which the device reads in place (CL_MEM_USE_HOST_PTR) and which is freed with the
    // buffer: a BVH of many megabytes then takes far fewer TLB misses, as Embree's does
    // (docs/performance.md: 1M-triangle sphere, incoherent and shadow rays 3-8% faster).
    cl::Buffer createReadOnlyCopy(const std::string& what, const void* data, size_t bytes);
    static constexpr size_t kHugePageBytes = size_t(2) << 20;

  private:
    ClDeviceInfo info_;
    cl::Context context_;
    cl::Device device_;
    cl::CommandQueue queue_;
    double lastBuildSeconds_ = 0.0;
    // Shared with the buffers' destructor callbacks, which may run after the runtime is gone.
    std::shared_ptr<std::atomic<unsigned long long>> liveBytes_ =
        std::make_shared<std::atomic<unsigned long long>>(0);
};

// The full source of `mainFile` with every `#include "name"` of an embedded file replaced by
// that file's text (once per file), keeping #line directives so logs name original lines.
std::string assembleKernelSource(const std::string& mainFile);

} // namespace cb
