// pbrt-v4's "loopsubdiv" shape: Loop's subdivision surface of a triangle control mesh (C. Loop,
// "Smooth Subdivision Surfaces Based on Triangles", 1987; pbrt's LoopSubdivide): the mesh split
// `levels` times, each triangle into four, then every vertex moved to its limit position and
// given the limit surface's normal there, which the renderer shades by.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace cb {

struct SubdivisionSurface {
    std::vector<std::array<double, 3>> positions; // on the limit surface
    std::vector<std::array<double, 3>> normals;   // the limit surface's, per vertex (unnormalised)
    std::vector<std::array<unsigned, 3>> triangles;
};

// The control mesh (vertex positions, triangles indexing them, wound consistently) subdivided
// `levels` >= 0 times. Vertices no triangle uses are dropped. Throws std::invalid_argument
// naming what the rules cannot handle: a triangle that repeats a vertex, an edge that two
// triangles run the same way (inconsistent winding, or more than two triangles on it), and a
// vertex whose triangles do not form one fan (two surfaces meeting at a point).
SubdivisionSurface loopSubdivide(const std::vector<std::array<double, 3>>& positions,
                                 const std::vector<std::array<unsigned, 3>>& triangles, int levels);

// The number of triangles `levels` subdivisions make of `triangles`: 4^levels times as many.
double loopSubdividedTriangles(std::size_t triangles, int levels);

} // namespace cb
