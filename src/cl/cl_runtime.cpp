#include "cl/cl_runtime.h"

#include "cl/embedded_kernels.h"

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fmt/format.h>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <sys/mman.h>

namespace cb {

const char* clStatusName(int status) {
    switch (status) {
    case CL_SUCCESS:
        return "CL_SUCCESS";
    case CL_DEVICE_NOT_FOUND:
        return "CL_DEVICE_NOT_FOUND";
    case CL_DEVICE_NOT_AVAILABLE:
        return "CL_DEVICE_NOT_AVAILABLE";
    case CL_COMPILER_NOT_AVAILABLE:
        return "CL_COMPILER_NOT_AVAILABLE";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE:
        return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_OUT_OF_RESOURCES:
        return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY:
        return "CL_OUT_OF_HOST_MEMORY";
    case CL_BUILD_PROGRAM_FAILURE:
        return "CL_BUILD_PROGRAM_FAILURE";
    case CL_INVALID_VALUE:
        return "CL_INVALID_VALUE";
    case CL_INVALID_PLATFORM:
        return "CL_INVALID_PLATFORM";
    case CL_INVALID_DEVICE:
        return "CL_INVALID_DEVICE";
    case CL_INVALID_CONTEXT:
        return "CL_INVALID_CONTEXT";
    case CL_INVALID_COMMAND_QUEUE:
        return "CL_INVALID_COMMAND_QUEUE";
    case CL_INVALID_MEM_OBJECT:
        return "CL_INVALID_MEM_OBJECT";
    case CL_INVALID_BUILD_OPTIONS:
        return "CL_INVALID_BUILD_OPTIONS";
    case CL_INVALID_PROGRAM:
        return "CL_INVALID_PROGRAM";
    case CL_INVALID_PROGRAM_EXECUTABLE:
        return "CL_INVALID_PROGRAM_EXECUTABLE";
    case CL_INVALID_KERNEL_NAME:
        return "CL_INVALID_KERNEL_NAME";
    case CL_INVALID_KERNEL:
        return "CL_INVALID_KERNEL";
    case CL_INVALID_ARG_INDEX:
        return "CL_INVALID_ARG_INDEX";
    case CL_INVALID_ARG_VALUE:
        return "CL_INVALID_ARG_VALUE";
    case CL_INVALID_ARG_SIZE:
        return "CL_INVALID_ARG_SIZE";
    case CL_INVALID_KERNEL_ARGS:
        return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_WORK_DIMENSION:
        return "CL_INVALID_WORK_DIMENSION";
    case CL_INVALID_WORK_GROUP_SIZE:
        return "CL_INVALID_WORK_GROUP_SIZE";
    case CL_INVALID_GLOBAL_OFFSET:
        return "CL_INVALID_GLOBAL_OFFSET";
    case CL_INVALID_BUFFER_SIZE:
        return "CL_INVALID_BUFFER_SIZE";
    case CL_INVALID_GLOBAL_WORK_SIZE:
        return "CL_INVALID_GLOBAL_WORK_SIZE";
    case -1001:
        return "CL_PLATFORM_NOT_FOUND_KHR (no OpenCL platform installed)";
    default:
        return "unknown OpenCL status";
    }
}

namespace {

const char* kNoPlatformHelp =
    "no OpenCL platform found. cbdpt runs its kernels on the CPU through PoCL: install it "
    "with `apt-get install pocl-opencl-icd ocl-icd-libopencl1` (Debian/Ubuntu), and check "
    "with `clinfo -l`.";

std::vector<cl::Platform> platformsOrThrow() {
    std::vector<cl::Platform> platforms;
    try {
        cl::Platform::get(&platforms);
    } catch (const cl::Error& e) {
        if (e.err() != -1001) throw ClError(fmt::format("{}: {}", e.what(), clStatusName(e.err())));
    }
    if (platforms.empty()) throw ClError(kNoPlatformHelp);
    return platforms;
}

ClDeviceInfo describe(int platformIndex, int deviceIndex, const cl::Platform& platform,
                      const cl::Device& device) {
    ClDeviceInfo info;
    info.platformIndex = platformIndex;
    info.deviceIndex = deviceIndex;
    info.platformName = platform.getInfo<CL_PLATFORM_NAME>();
    info.deviceName = device.getInfo<CL_DEVICE_NAME>();
    info.deviceVersion = device.getInfo<CL_DEVICE_VERSION>();
    info.driverVersion = device.getInfo<CL_DRIVER_VERSION>();
    info.computeUnits = device.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
    info.globalMemoryBytes = device.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
    info.maxAllocationBytes = device.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
    info.globalCacheBytes = device.getInfo<CL_DEVICE_GLOBAL_MEM_CACHE_SIZE>();
    const auto type = device.getInfo<CL_DEVICE_TYPE>();
    info.cpu = (type & CL_DEVICE_TYPE_CPU) != 0;
    info.gpu = (type & CL_DEVICE_TYPE_GPU) != 0;
    info.nativeFloatWidth = device.getInfo<CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT>();
    return info;
}

std::vector<cl::Device> devicesOf(const cl::Platform& platform) {
    std::vector<cl::Device> devices;
    try {
        platform.getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error&) {
        devices.clear(); // CL_DEVICE_NOT_FOUND: a platform without devices
    }
    return devices;
}

std::string deviceList(const std::vector<ClDeviceInfo>& devices) {
    std::string list;
    for (const auto& d : devices)
        list += fmt::format("{}{}:{} {} ({})", list.empty() ? "" : ", ", d.platformIndex,
                            d.deviceIndex, d.deviceName,
                            d.gpu   ? "GPU"
                            : d.cpu ? "CPU"
                                    : "other");
    return list.empty() ? "none" : list;
}

} // namespace

void checkDeviceAllocation(const ClDeviceInfo& device, const std::string& what,
                           unsigned long long bytes, unsigned long long liveBytes) {
    constexpr double MiB = 1024.0 * 1024.0;
    const char* advice = "try a smaller --width/--height, lower --eye-vertices/--light-vertices, "
                         "or (mlt) fewer --chains, (cbdpt) a smaller --coherence-tile";
    if (bytes > device.maxAllocationBytes)
        throw ClError(fmt::format(
            "out of device memory: the {} needs {:.1f} MiB, more than the largest single "
            "allocation of {} ({:.1f} MiB, CL_DEVICE_MAX_MEM_ALLOC_SIZE); {}",
            what, double(bytes) / MiB, device.deviceName, double(device.maxAllocationBytes) / MiB,
            advice));
    if (bytes + liveBytes > device.globalMemoryBytes)
        throw ClError(fmt::format(
            "out of device memory: the {} needs {:.1f} MiB, and with the {:.1f} MiB already "
            "allocated that exceeds the {:.1f} MiB of global memory of {} "
            "(CL_DEVICE_GLOBAL_MEM_SIZE); {}",
            what, double(bytes) / MiB, double(liveBytes) / MiB,
            double(device.globalMemoryBytes) / MiB, device.deviceName, advice));
}

namespace {

struct LiveBuffer {
    std::shared_ptr<std::atomic<unsigned long long>> live;
    unsigned long long bytes;
};

void CL_CALLBACK releaseLiveBuffer(cl_mem, void* data) {
    auto* buffer = static_cast<LiveBuffer*>(data);
    *buffer->live -= buffer->bytes;
    delete buffer;
}

void CL_CALLBACK freeHostCopy(cl_mem, void* host) {
    std::free(host);
}

} // namespace

cl::Buffer ClRuntime::createReadOnlyCopy(const std::string& what, const void* data, size_t bytes) {
    auto plainCopy = [&] {
        return createBuffer(what, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes,
                            const_cast<void*>(data));
    };
    if (!info_.cpu || bytes < kHugePageBytes) return plainCopy();
    const size_t rounded = (bytes + kHugePageBytes - 1) / kHugePageBytes * kHugePageBytes;
    void* host = std::aligned_alloc(kHugePageBytes, rounded);
    if (!host) return plainCopy();
#ifdef MADV_HUGEPAGE
    // Advice only: where transparent huge pages are off it changes nothing.
    madvise(host, rounded, MADV_HUGEPAGE);
#endif
    std::memcpy(host, data, bytes);
    cl::Buffer buffer;
    try {
        buffer = createBuffer(what, CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, bytes, host);
    } catch (...) {
        std::free(host);
        throw;
    }
    if (clSetMemObjectDestructorCallback(buffer(), freeHostCopy, host) != CL_SUCCESS) {
        // Without the callback nothing would free the host copy when the buffer goes.
        buffer = cl::Buffer();
        std::free(host);
        return plainCopy();
    }
    return buffer;
}

cl::Buffer ClRuntime::createBuffer(const std::string& what, cl_mem_flags flags, size_t bytes,
                                   void* host) {
    checkDeviceAllocation(info_, what, bytes, *liveBytes_);
    cl::Buffer buffer(context_, flags, bytes, host);
    auto* tracked = new LiveBuffer{liveBytes_, bytes};
    if (clSetMemObjectDestructorCallback(buffer(), releaseLiveBuffer, tracked) != CL_SUCCESS) {
        delete tracked; // not counted; the check still bounds each buffer on its own
        return buffer;
    }
    *liveBytes_ += bytes;
    return buffer;
}

std::vector<ClDeviceInfo> listClDevices() {
    std::vector<ClDeviceInfo> result;
    auto platforms = platformsOrThrow();
    for (size_t p = 0; p < platforms.size(); ++p) {
        auto devices = devicesOf(platforms[p]);
        for (size_t d = 0; d < devices.size(); ++d)
            result.push_back(describe(int(p), int(d), platforms[p], devices[d]));
    }
    return result;
}

bool ClDeviceInfo::pocl() const {
    return platformName.find("Portable Computing Language") != std::string::npos ||
           platformName.find("PoCL") != std::string::npos;
}

const ClDeviceInfo& chooseClDevice(const std::vector<ClDeviceInfo>& devices,
                                   const std::string& selector) {
    auto first = [&](auto&& wanted) -> const ClDeviceInfo* {
        for (const auto& d : devices)
            if (wanted(d)) return &d;
        return nullptr;
    };
    const ClDeviceInfo* found = nullptr;
    if (selector.empty() || selector == "cpu") {
        found = first([](const ClDeviceInfo& d) { return d.cpu && d.pocl(); });
        if (!found) found = first([](const ClDeviceInfo& d) { return d.cpu; });
        if (!found && selector.empty() && !devices.empty()) found = &devices.front();
    } else if (selector == "gpu") {
        found = first([](const ClDeviceInfo& d) { return d.gpu; });
    } else {
        int platform = -1, device = -1;
        char colon = 0;
        std::istringstream in(selector);
        bool valid = bool(in >> platform) && platform >= 0;
        const bool hasDevice = valid && bool(in >> colon);
        if (hasDevice) valid = colon == ':' && bool(in >> device) && device >= 0;
        if (!valid || !(in >> std::ws).eof())
            throw ClError(fmt::format("invalid device '{}': expected cpu, gpu, P or P:D "
                                      "(devices: {})",
                                      selector, deviceList(devices)));
        found = first([&](const ClDeviceInfo& d) {
            return d.platformIndex == platform && (!hasDevice || d.deviceIndex == device);
        });
    }
    if (!found)
        throw ClError(fmt::format("no OpenCL device matches '{}' (devices: {}; see `cbdpt info`)",
                                  selector.empty() ? "the default" : selector,
                                  deviceList(devices)));
    return *found;
}

std::string deviceSelector(const std::string& option) {
    if (!option.empty()) return option;
    const char* env = std::getenv("CBDPT_DEVICE");
    return env ? env : "";
}

void limitPoclThreads(int threads) {
    if (threads < 1) throw std::invalid_argument("the thread count must be at least 1");
    const std::string value = std::to_string(threads);
    setenv("POCL_MAX_PTHREAD_COUNT", value.c_str(), 1);
    setenv("POCL_CPU_MAX_CU_NUM", value.c_str(), 1);
}

ClRuntime::ClRuntime(const std::string& selector) {
    info_ = chooseClDevice(listClDevices(), deviceSelector(selector));
    device_ = devicesOf(platformsOrThrow()[size_t(info_.platformIndex)])[size_t(info_.deviceIndex)];
    try {
        context_ = cl::Context(device_);
        queue_ = cl::CommandQueue(context_, device_);
    } catch (const cl::Error& e) {
        throw ClError(fmt::format("cannot create an OpenCL context on {}: {} ({})",
                                  info_.deviceName, e.what(), clStatusName(e.err())));
    }
}

std::string assembleKernelSource(const std::string& mainFile) {
    const auto sources = kernelSources();
    std::set<std::string> included;
    std::string out;
    // Recursive inliner; each embedded source already starts with `#line 1 "name"`.
    auto inlineFile = [&](auto&& self, const std::string& name) -> void {
        auto it = sources.find(name);
        if (it == sources.end())
            throw ClError(fmt::format("kernel source '{}' is not embedded in this binary", name));
        if (!included.insert(name).second) return;
        std::istringstream in(it->second);
        std::string line;
        int lineNumber = 0; // line 0 is the #line directive added by the embedding
        while (std::getline(in, line)) {
            auto first = line.find_first_not_of(" \t");
            if (first != std::string::npos && line.compare(first, 8, "#include") == 0) {
                auto open = line.find('"', first);
                auto close = open == std::string::npos ? open : line.find('"', open + 1);
                if (close != std::string::npos) {
                    std::string inc = line.substr(open + 1, close - open - 1);
                    if (sources.count(inc)) {
                        self(self, inc);
                        out += fmt::format("#line {} \"{}\"\n", lineNumber + 1, name);
                        ++lineNumber;
                        continue;
                    }
                }
            }
            out += line;
            out += '\n';
            ++lineNumber;
        }
    };
    inlineFile(inlineFile, mainFile);
    return out;
}

// The device's binary of a built program (NVIDIA: PTX text), for reading what its compiler made
// of a kernel: DIR/<file>-<n>.bin, n counting this process's builds of that file.
static void writeProgramBinary(const cl::Program& program, const std::string& dir,
                               const std::string& mainFile) {
    static std::map<std::string, int> builds;
    const auto binaries = program.getInfo<CL_PROGRAM_BINARIES>();
    if (binaries.empty()) return;
    const std::string path = fmt::format("{}/{}-{}.bin", dir, mainFile, builds[mainFile]++);
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(binaries.front().data()),
              std::streamsize(binaries.front().size()));
    if (!out)
        throw ClError(fmt::format("CBDPT_KERNEL_BINARY_DIR: cannot write '{}' (expected a "
                                  "writable folder)",
                                  path));
}

cl::Program ClRuntime::buildProgram(const std::string& mainFile,
                                    const std::vector<std::string>& defines) {
    std::string source = assembleKernelSource(mainFile);
    std::string options = "-cl-std=CL1.2";
    for (const auto& d : defines)
        options += " -D" + d;
    // Vendor options for diagnosis or tuning, e.g. NVIDIA's -cl-nv-verbose (registers and stack
    // per kernel, printed with CBDPT_KERNEL_LOG=1).
    if (const char* extra = std::getenv("CBDPT_KERNEL_OPTIONS"); extra && *extra)
        options += std::string(" ") + extra;
    auto start = std::chrono::steady_clock::now();
    cl::Program program(context_, source);
    try {
        program.build({device_}, options.c_str());
    } catch (const cl::Error& e) {
        std::string log;
        try {
            log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_);
        } catch (const cl::Error&) {
            log = "(no build log available)";
        }
        throw ClError(fmt::format("OpenCL build of {} failed ({}) with options '{}':\n{}", mainFile,
                                  clStatusName(e.err()), options, log));
    }
    lastBuildSeconds_ =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (const char* log = std::getenv("CBDPT_KERNEL_LOG"); log && std::strcmp(log, "1") == 0)
        fmt::print(stderr, "OpenCL build log of {} ({}):\n{}\n", mainFile, options,
                   program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_));
    if (const char* dir = std::getenv("CBDPT_KERNEL_BINARY_DIR"); dir && *dir)
        writeProgramBinary(program, dir, mainFile);
    return program;
}

} // namespace cb
