// libFuzzer target for the PLY reader (cb::readPlyFromMemory). A SceneError is the reader's
// documented answer to bad input; anything else escaping, a crash, a sanitizer report, a hang or
// an allocation not justified by the input size is a finding.
#include "scene/ply.h"
#include "scene/scene_desc.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string bytes(reinterpret_cast<const char*>(data), size);
    try {
        const cb::PlyMesh mesh = cb::readPlyFromMemory(bytes, "fuzz.ply");
        // A mesh that loads must be usable as loaded: finite coordinates, every index names a
        // vertex, normals and texture coordinates (if any) one per vertex.
        for (const auto& p : mesh.positions)
            for (float c : p)
                if (!std::isfinite(c)) __builtin_trap();
        for (const auto& n : mesh.normals)
            for (float c : n)
                if (!std::isfinite(c)) __builtin_trap();
        for (const auto& t : mesh.triangles)
            for (unsigned i : t)
                if (i >= mesh.positions.size()) __builtin_trap();
        if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) __builtin_trap();
        for (const auto& uv : mesh.uv)
            for (float c : uv)
                if (!std::isfinite(c)) __builtin_trap();
        if (!mesh.uv.empty() && mesh.uv.size() != mesh.positions.size()) __builtin_trap();
    } catch (const cb::SceneError&) {
    }
    return 0;
}
