// Stand-alone PLY reader for triangle meshes (ascii 1.0, binary_little_endian 1.0,
// binary_big_endian 1.0). Written to survive hostile input: every count in the header is
// checked against the bytes actually present before anything is allocated, every read is
// bounds-checked, and every index is range-checked.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace cb {

struct PlyMesh {
    std::vector<std::array<float, 3>> positions;
    std::vector<std::array<unsigned, 3>> triangles; // quads split as (0,1,2), (0,2,3)
    // Per-vertex normals when the vertex element has nx, ny and nz, else empty. cbdpt shades
    // flat; the scene parser only uses these to orient faces as pbrt-v4 does.
    std::vector<std::array<float, 3>> normals;
    // Per-vertex texture coordinates when the vertex element has u and v (or s and t,
    // texture_u and texture_v, texture_s and texture_t, as pbrt-v4 reads them), else empty.
    std::vector<std::array<float, 2>> uv;
    // Faces of more than 4 vertices, skipped as pbrt-v4 skips them (with a warning).
    unsigned long long skippedFaces = 0;
};

// Throws SceneError. Header errors carry the header line (column 1); ascii payload errors the
// line and column of the bad value; binary payload errors have line 0 and name the element,
// the row index and the byte offset in the message.
PlyMesh readPly(const std::string& path);

// The same, from bytes already in memory; `path` only names the data in error messages.
PlyMesh readPlyFromMemory(const std::string& bytes, const std::string& path);

} // namespace cb
