// Reading a float grid from a NanoVDB file (pbrt-v4's "nanovdb" medium): the file's layout is
// NanoVDB's (github.com/AcademySoftwareFoundation/openvdb, nanovdb/, version 32), uncompressed;
// the sparse tree is expanded into dense samples for cbdpt's grid media (docs/pbrt-v4.md,
// "NanoVDB media").
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace cb {

struct NanoVdbGrid {
    // The index-space box of the active values, inclusive (NanoVDB's root bounding box).
    std::array<int, 3> indexMin{0, 0, 0}, indexMax{-1, -1, -1};
    // Index space to the grid's world: p = matrix * ijk + translation (matrix row-major).
    std::array<double, 9> matrix{1, 0, 0, 0, 1, 0, 0, 0, 1};
    std::array<double, 3> translation{0, 0, 0};
    float background = 0.f; // the value of every voxel the tree does not store
    // The grid's values at the integer index points from indexMin to indexMax + 1 on each axis
    // (the last layer is beyond the active values), x fastest: dims() values.
    std::vector<float> values;
    std::array<int, 3> dims() const {
        return {indexMax[0] - indexMin[0] + 2, indexMax[1] - indexMin[1] + 2,
                indexMax[2] - indexMin[2] + 2};
    }
};

// The names of the grids in `path`, in file order. Throws std::runtime_error naming the file
// and what is wrong (not NanoVDB, another major version, truncated).
std::vector<std::string> nanoVdbGridNames(const std::string& path);

// Grid `name` of `path`, a float grid of an uncompressed file, expanded to dense values. Throws
// std::runtime_error naming the file and the reason (no such grid, not a float grid, compressed,
// more than `maxValues` dense values, a malformed tree).
NanoVdbGrid readNanoVdbGrid(const std::string& path, const std::string& name,
                            std::uint64_t maxValues = std::uint64_t(1) << 31);

} // namespace cb
