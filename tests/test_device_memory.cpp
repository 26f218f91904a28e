// Device memory limits: a buffer too large for the device, or one that would take the
// device past its global memory, is refused before it is allocated, with an error that names
// the buffer, its size and the limit, and says what to reduce. The end-to-end check (a real
// PoCL device shrunk with POCL_MEMORY_LIMIT, through the CLI) is in tests/test_cli.py.
#include "cl/cl_runtime.h"

#include <doctest/doctest.h>
#include <fmt/format.h>
#include <string>
#include <vector>

namespace {

std::string messageOf(const cb::ClDeviceInfo& device, const std::string& what,
                      unsigned long long bytes, unsigned long long live) {
    try {
        cb::checkDeviceAllocation(device, what, bytes, live);
    } catch (const cb::ClError& e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST_CASE("device memory: allocations beyond the largest allocation or the global memory are "
          "refused with the buffer, its size and the limit") {
    cb::ClDeviceInfo device;
    device.deviceName = "test-device";
    device.maxAllocationBytes = 256ull << 20;
    device.globalMemoryBytes = 1ull << 30;
    CHECK(messageOf(device, "image", 256ull << 20, 0).empty());
    CHECK(messageOf(device, "image", 200ull << 20, (1ull << 30) - (200ull << 20)).empty());

    std::string tooLarge = messageOf(device, "BDPT image", (256ull << 20) + 1, 0);
    CAPTURE(tooLarge);
    CHECK(tooLarge.find("out of device memory") != std::string::npos);
    CHECK(tooLarge.find("BDPT image") != std::string::npos);
    CHECK(tooLarge.find("256.0 MiB") != std::string::npos);
    CHECK(tooLarge.find("CL_DEVICE_MAX_MEM_ALLOC_SIZE") != std::string::npos);
    CHECK(tooLarge.find("--width/--height") != std::string::npos);
    CHECK(tooLarge.find("--light-vertices") != std::string::npos);

    std::string sum = messageOf(device, "MLT chain states", 200ull << 20, 900ull << 20);
    CAPTURE(sum);
    CHECK(sum.find("MLT chain states needs 200.0 MiB") != std::string::npos);
    CHECK(sum.find("900.0 MiB already allocated") != std::string::npos);
    CHECK(sum.find("1024.0 MiB of global memory of test-device") != std::string::npos);
}

TEST_CASE("device memory: the OpenCL runtime checks its buffers and counts the live ones") {
    cb::ClRuntime runtime;
    const unsigned long long before = runtime.liveBufferBytes();
    {
        cl::Buffer b = runtime.createBuffer("test buffer", CL_MEM_READ_WRITE, 1 << 20);
        CHECK(runtime.liveBufferBytes() == before + (1 << 20));
    }
    // The count drops in the buffer's destructor callback, which OpenCL lets an implementation run
    // later: PoCL's CPU device runs it at once, NVIDIA's driver on an H100 did not (docs/gpu.md).
    if (runtime.info().cpu) CHECK(runtime.liveBufferBytes() == before);
    // One byte past the device's largest allocation: refused before OpenCL is asked.
    const size_t tooLarge = size_t(runtime.info().maxAllocationBytes) + 1;
    CHECK_THROWS_WITH_AS(runtime.createBuffer("test buffer", CL_MEM_READ_WRITE, tooLarge),
                         doctest::Contains("test buffer needs"), cb::ClError);
    if (runtime.info().cpu) CHECK(runtime.liveBufferBytes() == before);
}

TEST_CASE("device memory: read-only copies hold the data, small and huge-page ones alike, and "
          "are counted and released") {
    cb::ClRuntime runtime;
    // On a CPU device (PoCL) copies of kHugePageBytes and more take the huge-page path.
    const unsigned long long before = runtime.liveBufferBytes();
    // Below and above kHugePageBytes, and a size that is not a multiple of it.
    for (size_t count : {size_t(1000), cb::ClRuntime::kHugePageBytes / 4 * 3 + 12345}) {
        CAPTURE(count);
        std::vector<unsigned> data(count);
        for (size_t i = 0; i < count; ++i)
            data[i] = unsigned(i * 2654435761u);
        const size_t bytes = count * sizeof(unsigned);
        {
            cl::Buffer b = runtime.createReadOnlyCopy("test copy", data.data(), bytes);
            CHECK(runtime.liveBufferBytes() == before + bytes);
            std::vector<unsigned> back(count);
            runtime.queue().enqueueReadBuffer(b, CL_TRUE, 0, bytes, back.data());
            CHECK(back == data);
            // The device copy does not alias the caller's array.
            data[0] ^= 1u;
            runtime.queue().enqueueReadBuffer(b, CL_TRUE, 0, bytes, back.data());
            CHECK(back[0] != data[0]);
        }
        // Destructor callbacks may run later on other devices (see above).
        if (runtime.info().cpu) CHECK(runtime.liveBufferBytes() == before);
    }
}

namespace {

cb::ClDeviceInfo fakeDevice(int platform, int device, const char* platformName, bool cpu,
                            bool gpu) {
    cb::ClDeviceInfo d;
    d.platformIndex = platform;
    d.deviceIndex = device;
    d.platformName = platformName;
    d.deviceName = fmt::format("device {}:{}", platform, device);
    d.cpu = cpu;
    d.gpu = gpu;
    return d;
}

std::string chosen(const std::vector<cb::ClDeviceInfo>& devices, const std::string& selector) {
    const cb::ClDeviceInfo& d = cb::chooseClDevice(devices, selector);
    return fmt::format("{}:{}", d.platformIndex, d.deviceIndex);
}

} // namespace

TEST_CASE("device choice: PoCL's CPU device by default, cpu, gpu and P:D on request") {
    // A GPU platform installed before PoCL, and a second, non-PoCL CPU platform.
    const std::vector<cb::ClDeviceInfo> devices = {
        fakeDevice(0, 0, "NVIDIA CUDA", false, true),
        fakeDevice(0, 1, "NVIDIA CUDA", false, true),
        fakeDevice(1, 0, "Intel(R) OpenCL", true, false),
        fakeDevice(2, 0, "Portable Computing Language", true, false),
    };
    CHECK(chosen(devices, "") == "2:0");
    CHECK(chosen(devices, "cpu") == "2:0");
    CHECK(chosen(devices, "gpu") == "0:0");
    CHECK(chosen(devices, "0:1") == "0:1");
    CHECK(chosen(devices, "1") == "1:0");
    CHECK(chosen(devices, " 1:0 ") == "1:0");
    // Without PoCL: the first CPU device; without CPUs: the first device, but no "cpu".
    const std::vector<cb::ClDeviceInfo> noPocl(devices.begin(), devices.begin() + 3);
    CHECK(chosen(noPocl, "") == "1:0");
    const std::vector<cb::ClDeviceInfo> gpus(devices.begin(), devices.begin() + 2);
    CHECK(chosen(gpus, "") == "0:0");
    CHECK_THROWS_WITH_AS(chosen(gpus, "cpu"), doctest::Contains("no OpenCL device matches 'cpu'"),
                         cb::ClError);
    const std::vector<cb::ClDeviceInfo> cpus(devices.begin() + 2, devices.end());
    CHECK_THROWS_WITH_AS(chosen(cpus, "gpu"), doctest::Contains("device 2:0 (CPU)"), cb::ClError);
    for (const char* bad : {"0:", "x", "-1", "1:-2", "1:0:0", "1x", "GPU"})
        CHECK_THROWS_WITH_AS(chosen(devices, bad), doctest::Contains("invalid device"),
                             cb::ClError);
    CHECK_THROWS_WITH_AS(chosen(devices, "3:0"),
                         doctest::Contains("no OpenCL device matches '3:0'"), cb::ClError);
    CHECK_THROWS_AS(chosen({}, ""), cb::ClError);
}
