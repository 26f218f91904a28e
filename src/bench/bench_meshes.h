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

// `mesh` standing in a room open at the top and at the front (+z, where the bench's camera
// looks from): a floor under it and three walls, 1.5 times its largest half extent from its
// centre, two triangles each. The camera then sees the mesh against walls, and bounces start
// inside the scene, as in the renderers' rooms (the Cornell box) rather than around a lone mesh;
// a light above the room (the bench's shadow rays) shines in through the open top.
PlyMesh withRoom(PlyMesh mesh);

// One Primitive per triangle, in mesh order (material 0, no light).
std::vector<cbk::Primitive> meshPrimitives(const PlyMesh& mesh);

// Binary little-endian PLY with float positions and uchar/uint faces.
void writePly(const PlyMesh& mesh, const std::string& path);

} // namespace cb::bench
