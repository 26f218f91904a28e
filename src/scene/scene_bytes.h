// A DeviceScene as raw arrays, for translation units that compile the shared kernel headers in a
// different instantiation (16 channels, or real = double) and therefore cannot see DeviceScene's
// 3-channel float types: they copy the bytes into their own structs.
#pragma once

#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace cb {

struct DeviceScene;

struct SceneBytes {
    const void* nodes;                // BvhNodeWide
    std::size_t nodeCount, nodeBytes; // nodeBytes: sizeof one struct, checked by the reader
    const void* packs;                // TrianglePack
    std::size_t packCount, packBytes;
    const void* primitives;
    std::size_t primitiveCount, primitiveBytes;
    const void* materials;
    std::size_t materialCount, materialBytes;
    const void* lights;
    std::size_t lightCount, lightBytes;
    const float* spectra;
    std::size_t spectraCount;
    const float* toRgb; // 3 x channels
    const void* camera;
    std::size_t cameraBytes;
    int channels;
};

// Points into `scene`, which must outlive the result.
SceneBytes sceneBytes(const DeviceScene& scene);

// Copies `count` structs of `bytes` bytes each into the reader's own type T, which must have the
// same layout (the shared headers assert every float-layout size). The types are distinct, so
// the bytes are copied rather than aliased.
template <typename T>
std::vector<T> copySceneArray(const void* data, std::size_t count, std::size_t bytes,
                              const char* what) {
    if (count > 0 && bytes != sizeof(T))
        throw std::logic_error(std::string("host struct size mismatch for ") + what);
    std::vector<T> out(count);
    if (count > 0) std::memcpy(static_cast<void*>(out.data()), data, count * sizeof(T));
    return out;
}

} // namespace cb
