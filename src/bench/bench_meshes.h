// Test meshes for cbdpt-bench: the Stanford models and generated displaced spheres of any size.
#pragma once

#include "scene/ply.h"

#include "cb_types.h"

#include <string>
#include <vector>

namespace cb::bench {

struct BenchMesh {
    std::string name;
    PlyMesh mesh;
};

// A sphere of radius `radius` around `centre`, tessellated as a latitude-longitude grid of
// about `triangles` triangles (exactly 2 * rings * segments - 2 * segments, poles fanned), its
// radius displaced by a few octaves of sines so that the BVH sees an uneven surface rather than
// a regular grid.
PlyMesh displacedSphere(long triangles, const float centre[3], float radius);

// One Primitive per triangle, in mesh order (material 0, no light).
std::vector<cbk::Primitive> meshPrimitives(const PlyMesh& mesh);

// Binary little-endian PLY with float positions and uchar/uint faces.
void writePly(const PlyMesh& mesh, const std::string& path);

} // namespace cb::bench
