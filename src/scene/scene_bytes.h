// A DeviceScene as raw arrays, for the host instances of the kernel code
// (src/kernel_host/kernel_instance.h), which cannot see DeviceScene's types: each reads the bytes
// into its own structs (HostScene).
#pragma once

#include <cstddef>

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
    const float* lightTables;
    std::size_t lightTableCount;
    const float* textures;
    std::size_t textureCount;
    const float* shadingNormals;
    std::size_t shadingNormalCount;
    const void* curves; // CurveSegment
    std::size_t curveCount, curveBytes;
    const float* toRgb; // 3 x channels
    const void* camera;
    std::size_t cameraBytes;
    int channels;
    std::uint64_t features; // CB_FEATURE_* bits
};

// Points into `scene`, which must outlive the result.
SceneBytes sceneBytes(const DeviceScene& scene);

} // namespace cb
